"""What :func:`lamech.symbolic.modes` returns: the equilibria (:class:`Equilibrium`), each
with its normal modes (:class:`Mode`) and the linear system about it (:class:`Linear`),
gathered in :class:`Modes`. Plain frozen data with their JSON forms; the search and the
linearisation are in :mod:`._modes`."""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from ..expr import to_text
from ..model import System, result_units

__all__ = ["Equilibrium", "Linear", "Mode", "Modes"]


@dataclass(frozen=True)
class Mode:
    """One eigenvalue of the linearised motion and its shape.

    ``eigenvalue`` is complex; ``frequency`` omega (rad/s) when it oscillates, ``growth``
    its real part when that is positive (unstable), ``squared`` omega^2 in closed form
    (negative: the square of a growth rate) when available, ``shape`` the displacement
    in every coordinate (largest component 1); where the coordinates move out of phase
    (gyroscopic coupling) ``shape`` holds the amplitudes and ``phases`` the phase of each
    in degrees."""

    eigenvalue: complex
    frequency: float | None
    growth: float | None
    shape: dict[str, float]
    squared: sp.Expr | None = None
    phases: dict[str, float] | None = None

    def to_json(self) -> dict:
        return {
            "eigenvalue": [self.eigenvalue.real, self.eigenvalue.imag],
            "frequency": self.frequency,
            "growth": self.growth,
            "shape": self.shape,
            "squared": None if self.squared is None else to_text(self.squared),
            "phases": self.phases,
        }


@dataclass(frozen=True)
class Linear:
    """The linearised motion d/dt x = A x about a point at rest, in coordinates regular
    there: ``state`` names the entries of x (positions, then velocities such as
    ``"x'"``), ``A`` is the matrix (row i: d/dt of entry i), and ``multipliers`` gives
    each multiplier's first-order change over x (lambda = lambda_0 + row . x)."""

    state: tuple[str, ...]
    A: tuple[tuple[float, ...], ...]
    multipliers: dict[str, tuple[float, ...]] = field(default_factory=dict)

    def to_json(self) -> dict:
        return {
            "state": list(self.state),
            "A": [list(r) for r in self.A],
            "multipliers": {k: list(v) for k, v in self.multipliers.items()},
        }


@dataclass(frozen=True)
class Equilibrium:
    """A configuration where the system can rest (``at``: the independent coordinates,
    symbolic; ``values``: every coordinate, numeric), the ``condition`` for it to exist,
    whether it does at the parameter values (``exists``), the ``multipliers`` at rest,
    whether every unilateral constraint can hold it (``holds``, with ``note`` saying which
    cannot), its ``stability`` ("stable", "unstable", "marginal"), ``modes``, and the
    ``linear`` system (:class:`Linear`) about it, and ``check``: how the frequencies agree
    with det(K - omega^2 M) = 0 from the unreduced equations (None where that check does
    not apply; a disagreement is reported in ``note``)."""

    at: dict[str, sp.Expr]
    values: dict[str, float]
    condition: str | None = None
    exists: bool = True
    multipliers: dict[str, float] = field(default_factory=dict)
    holds: bool = True
    note: str | None = None
    stability: str | None = None
    modes: tuple[Mode, ...] = ()
    linear: Linear | None = None
    check: str | None = None

    def displaced(self, mode: int, amplitude: float) -> dict[str, float]:
        """Initial values that release the system at rest along ``mode`` (0-based index
        into ``modes``), its largest component moved by ``amplitude``: the regular
        coordinates of the linearisation (``linear.state``) displaced, their velocities
        zero, for :func:`lamech.model.with_values` or ``simulate(initial=...)`` (the
        other coordinates follow from the constraints)."""
        if not self.exists or not self.modes or self.linear is None:
            raise ValueError("this equilibrium has no modes to release the system along")
        if not 0 <= mode < len(self.modes):
            raise ValueError(f"mode {mode + 1}: this equilibrium has modes 1 to {len(self.modes)}")
        shape = self.modes[mode].shape
        out = {}
        for name in self.linear.state:
            if name.endswith("'"):
                out[name] = self.values.get(name, 0.0)  # a steady motion keeps its speed
            else:
                out[name] = self.values[name] + amplitude * shape[name]
        return out

    def __repr__(self) -> str:
        where = ", ".join(f"{k} = {to_text(v)}" for k, v in self.at.items())
        if not self.exists:
            return f"<Equilibrium {where}: does not exist at these values>"
        n = len(self.modes)
        held = "" if self.holds else "; a contact cannot hold it"
        return f"<Equilibrium {where}: {self.stability}, {n} mode{'' if n == 1 else 's'}{held}>"

    def to_json(self) -> dict:
        return {
            "at": {k: to_text(v) for k, v in self.at.items()},
            "values": self.values,
            "condition": self.condition,
            "exists": self.exists,
            "multipliers": self.multipliers,
            "holds": self.holds,
            "note": self.note,
            "stability": self.stability,
            "modes": [m.to_json() for m in self.modes],
            "linear": None if self.linear is None else self.linear.to_json(),
            "check": self.check,
        }


@dataclass(frozen=True)
class Modes:
    """Every equilibrium found (``equilibria``), or why none could be (``reason``);
    ``free`` says which coordinates rest at every value (shown at one); ``frame``, for a
    problem whose equations depend on t, the chart in which they do not and the
    equilibria are relative ones (``system`` is then the problem in that chart)."""

    system: System
    independent: tuple[str, ...]
    equilibria: tuple[Equilibrium, ...]
    reason: str | None = None
    free: str | None = None
    frame: str | None = None

    def __str__(self) -> str:
        # what `lamech modes` prints: the one import against the layer order (symbolic ->
        # present) of this module, declared in the import-linter contract as
        # Solution's _repr_latex_ is
        from ..present._modes import modes_text

        return modes_text(self)

    def __repr__(self) -> str:
        n = len(self.equilibria)
        stable = sum(1 for e in self.equilibria if e.exists and e.stability == "stable")
        found = f"{n} equilibri{'um' if n == 1 else 'a'} ({stable} stable)" if n else "none"
        why = f": {self.reason[:80]}" if self.reason and not n else ""
        return f"<Modes of {self.system.title!r}: {found} in {', '.join(self.independent)}{why}>"

    def _repr_latex_(self) -> str:
        from ..present._modes import modes_latex  # as __str__

        return modes_latex(self)

    @property
    def units(self) -> dict[str, str]:
        """Where the file gives units (issue 46): the SI unit of each parameter, coordinate,
        velocity and multiplier (``"lambda:<constraint>"``) by name
        (:func:`lamech.model.result_units`), and of a mode's ``"frequency"`` (rad/s),
        ``"growth"`` (1/s) and ``"period"`` (s); empty for a file without units."""
        table = result_units(self.system)
        if table:
            table |= {"frequency": "rad/s", "growth": "1/s", "period": "s"}
        return table

    def to_json(self) -> dict:
        out: dict = {
            "title": self.system.title,
            "independent": list(self.independent),
            "equilibria": [e.to_json() for e in self.equilibria],
            "reason": self.reason,
            "free": self.free,
            "frame": self.frame,
        }
        units = self.units
        if units:
            out["units"] = units
        return out
