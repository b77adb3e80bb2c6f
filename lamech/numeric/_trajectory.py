"""The result of a simulation: sampled states, multipliers, forces, energy, residuals and
the event log (see :func:`lamech.numeric.simulate`)."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from ._events import Event, Status

__all__ = ["Trajectory"]


def _index(names, name: str, what: str) -> int:
    try:
        return list(names).index(name)
    except ValueError:
        raise KeyError(f"no {what} `{name}`; known: {', '.join(names)}") from None


@dataclass
class Trajectory:
    """Arrays sampled at ``t`` (dense output, not the integrator's steps).

    ``q``, ``qd``: (N, n); ``lambdas``: (N, m) in the sign convention and scaling of
    ``lamech solve`` (NaN while a unilateral constraint is released or a friction constraint
    is off; while a friction constraint slips, its column holds the kinetic friction -mu N
    sign(slip velocity) that replaces its multiplier); ``forces``:
    {"<constraint>:<direction>": (N,)} Cartesian components by virtual work; ``energy`` T +
    V; ``residual_position`` max ``|f|`` and ``residual_velocity`` max ``|F|`` of the active
    constraints; ``residual`` their max. ``events`` is the log, a list of
    :class:`~lamech.numeric.Event` (``t``, ``kind``, ``constraint``, ``coordinates`` and the
    details of its kind); ``status`` is a :class:`~lamech.numeric.Status` (equal to "ok",
    "failed" or "interrupted") with ``message`` saying when, why and what to try.
    ``engine``: what integrated it (``"loop (C)"``, ``"loop (Python)"``: the loop with
    events; ``"SciPy DOP853"`` and the other methods); ``handed_back``: the contacts and
    segments the loop left to the simulator's own code (a step it could not take, an impact
    it could not apply).

    ``units``: where the problem file gives units (issue 46), the SI unit of each column of
    ``columns()`` whose dimension is known, by its name (``"t": "s"``, ``"r": "m"``,
    ``"theta1": "rad"``, ``"theta1'": "rad/s"``, ``"lambda:contact": "N"``,
    ``"force:contact:normal": "N"``, ``"energy": "J"``) and of each parameter; every
    array is in these units (SI). Empty for a file without units.

    A Trajectory holds data: its summary as text, JSON and CSV are
    :func:`lamech.to_text`, :func:`lamech.to_json` and :func:`lamech.to_csv`.
    """

    coordinates: list[str]
    constraints: list[str]
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    lambdas: np.ndarray
    forces: dict
    energy: np.ndarray
    residual_position: np.ndarray
    residual_velocity: np.ndarray
    events: list[Event] = field(default_factory=list)
    status: Status = Status.OK
    message: str = ""
    t_end: float = 0.0
    final_time: float = 0.0
    final_q: np.ndarray | None = None
    final_qd: np.ndarray | None = None
    energy_conserved: bool = True
    max_projection: float = 0.0
    steps: int = 0
    evaluations: int = 0
    notes: list = field(default_factory=list)
    title: str = ""
    kinetic: np.ndarray | None = None
    engine: str = ""
    handed_back: int = 0
    units: dict[str, str] = field(default_factory=dict)
    # per drive ([[drives]]): its force or torque on the coordinate driven (the multiplier
    # itself for a general f) and the power of its force, lambda A_j q', at the samples;
    # the coordinate each drives (None for a general f)
    drive_forces: dict = field(default_factory=dict)
    drive_power: dict = field(default_factory=dict)
    drive_coordinates: dict = field(default_factory=dict)
    drive_units: dict = field(default_factory=dict)  # SI, where the file has units
    drive_turns: dict = field(default_factory=dict)  # its coordinate an angle: a turn a cycle

    # ----- views ------------------------------------------------------------------
    @property
    def residual(self) -> np.ndarray:
        return np.maximum(self.residual_position, self.residual_velocity)

    def coordinate(self, name: str) -> np.ndarray:
        """The samples of coordinate ``name``."""
        return self.q[:, _index(self.coordinates, name, "coordinate")]

    def velocity(self, name: str) -> np.ndarray:
        """The samples of the velocity of ``name`` (``x`` or ``x'``)."""
        return self.qd[:, _index(self.coordinates, name.rstrip("'"), "coordinate")]

    def multiplier(self, name: str) -> np.ndarray:
        """The samples of the multiplier of constraint ``name``: NaN while it is released
        (a unilateral constraint after lift-off, a friction constraint whose normal is
        released), the kinetic friction -mu N sign(slip velocity) while it slips.

        Examples
        --------
        >>> import lamech
        >>> traj = lamech.simulate(lamech.load("cylinder"), 3.0, initial={"theta1": 0.01},
        ...                        samples=4)
        >>> [(str(e.kind), e.constraint) for e in traj.events]
        [('slip', 'rolling'), ('lift-off', 'contact')]
        >>> traj.multiplier("contact").round(3)
        array([9.81 , 9.791, 8.613,   nan])
        """
        return self.lambdas[:, _index(self.constraints, name, "constraint")]

    @property
    def energy_error(self) -> float | None:
        """max |E - E0| / max(|E0|, max T) for a conservative, time-independent run
        (no driving force, no explicit t, no slip or inelastic impact); None otherwise."""
        if not self.energy_conserved or len(self.energy) == 0:
            return None
        e = self.energy[np.isfinite(self.energy)]
        if len(e) == 0:
            return None
        scale = max(
            abs(e[0]),
            float(np.nanmax(self.kinetic))
            if self.kinetic is not None and len(self.kinetic)
            else 0.0,
        )
        if scale == 0:
            return 0.0
        return float(np.max(np.abs(e - e[0])) / scale)

    # ----- tables -----------------------------------------------------------------
    def columns(self) -> list[tuple[str, np.ndarray]]:
        cols = [("t", self.t)]
        cols += [(c, self.q[:, i]) for i, c in enumerate(self.coordinates)]
        cols += [(c + "'", self.qd[:, i]) for i, c in enumerate(self.coordinates)]
        cols += [("lambda:" + c, self.lambdas[:, j]) for j, c in enumerate(self.constraints)]
        cols += [("force:" + k, v) for k, v in self.forces.items()]
        cols += [("drive:" + k, v) for k, v in self.drive_forces.items()]
        cols += [("energy", self.energy), ("residual", self.residual)]
        return cols

    def _repr_html_(self) -> str:
        # Jupyter's display protocol calls this on the object itself: the one import of
        # this module against the layer order (numeric -> present), declared as an
        # exception in the import-linter contract; elsewhere, lamech.present.
        from ..present._notebook import trajectory_html

        return trajectory_html(self)

    def to_dataframe(self):
        """A pandas DataFrame with the CSV's columns (pandas must be installed)."""
        try:
            import pandas as pd
        except ImportError:  # pragma: no cover - optional dependency
            raise ImportError("to_dataframe needs pandas: pip install pandas") from None
        return pd.DataFrame({name: arr for name, arr in self.columns()})

    # ----- summary ----------------------------------------------------------------
    def summary(self) -> dict:
        """The ``--json`` summary of the run: deprecated, :func:`lamech.to_json` gives it
        (the present layer formats; this calls it, the one import of this method against
        the layer order, declared in the import-linter contract)."""
        warnings.warn(
            "Trajectory.summary() is deprecated: lamech.to_json(trajectory) gives the same object",
            DeprecationWarning,
            stacklevel=2,
        )
        from ..present._trajectory import trajectory_json

        return trajectory_json(self)

    def _where(self, y: np.ndarray) -> tuple[float, dict]:
        """The largest of ``y`` (finite samples, >= 0) refined between the samples, and
        where: t and the coordinates there (:func:`_refined_peak`)."""
        kinks = np.array([e.t for e in self.events], dtype=float)
        value, at_t, q = _refined_peak(self.t, y, self.q, self.qd, kinks)
        at = {"t": at_t}
        at.update({c: float(q[i]) for i, c in enumerate(self.coordinates)})
        return value, at

    def drive_summary(self) -> dict:
        """Per drive: ``peak`` |force or torque| and where (``at``: t and the
        coordinates), refined between the samples (the vertex of the parabola through the
        largest sample and its neighbours; the coordinates there by cubic Hermite
        interpolation of the samples' positions and velocities), ``rms``, ``mean_power``
        (the work over the run / its duration) and ``work_per_cycle`` (over the first
        turn of the coordinate driven, 2 pi; None before a turn is complete, or where the
        system does not repeat after a turn of it), from the samples; ``unit`` of the
        force or torque, and ``power_unit`` (W) and ``work_unit`` (J), where the file has
        units."""
        out = {}
        t = self.t
        span = float(t[-1] - t[0]) if len(t) > 1 else 0.0
        for name, tau in self.drive_forces.items():
            power = self.drive_power[name]
            ok = np.isfinite(tau)
            if not ok.any():
                continue
            peak, at = self._where(np.abs(tau))
            item = {
                "coordinate": self.drive_coordinates.get(name),
                "unit": self.drive_units.get(name),
                "peak": peak,
                "at": at,
                "rms": _mean(t, tau**2, span) ** 0.5 if span > 0 else float(abs(tau[0])),
                "mean_power": _mean(t, power, span) if span > 0 else float(power[0]),
                "work_per_cycle": None,
            }
            if self.units:
                item["power_unit"], item["work_unit"] = "W", "J"
            coord = self.drive_coordinates.get(name)
            if coord is not None and span > 0 and self.drive_turns.get(name):
                item["work_per_cycle"] = _work_per_turn(t, self.coordinate(coord), power)
            out[name] = item
        return out

    def reactions(self) -> dict[str, np.ndarray]:
        """Per named reaction (a constraint with a ``force = {...}`` spec): the magnitude
        of its Cartesian force at the samples, the root of the sum of the squares of its
        components (``forces["<constraint>:<direction>"]``; the directions taken as
        orthogonal); NaN while it is released."""
        parts: dict[str, list[np.ndarray]] = {}
        for key, arr in self.forces.items():
            parts.setdefault(key.split(":", 1)[0], []).append(np.asarray(arr, dtype=float))
        return {c: np.sqrt(sum(a**2 for a in arrs)) for c, arrs in parts.items()}

    def reaction_summary(self) -> dict:
        """Per named reaction: the ``peak`` magnitude of its Cartesian force and where
        (``at``: t and the coordinates), refined between the samples as a drive's peak
        (:meth:`drive_summary`); ``unit`` (N) where the file has units."""
        out = {}
        for name, mag in self.reactions().items():
            if not np.isfinite(mag).any():
                continue
            peak, at = self._where(mag)
            keys = [k for k in self.units if k.startswith(f"force:{name}:")]
            out[name] = {"peak": peak, "at": at, "unit": self.units[keys[0]] if keys else None}
        return out


def _refined_peak(
    t: np.ndarray, y: np.ndarray, q: np.ndarray, qd: np.ndarray, kinks: np.ndarray
) -> tuple[float, float, np.ndarray]:
    """The largest value of the samples ``y`` (NaN skipped) refined between them: the
    largest of the polynomial through the largest sample and its neighbours (a quartic
    through five samples, a parabola through three near an end or a NaN) between the
    neighbours, where it bends down there (else the sample itself); never across an
    event's time in ``kinks`` (a slip, a lift-off: the samples there are not of one
    smooth curve), where the sample itself is the answer; its time, and the coordinates
    there by cubic Hermite interpolation of ``q`` and ``qd`` on the step that holds
    it."""
    k = int(np.nanargmax(y))
    value, at, qk = float(y[k]), float(t[k]), np.array(q[k], dtype=float)
    if not 0 < k < len(t) - 1:
        return value, at, qk

    def smooth(a: int, b: int) -> bool:  # no NaN and no event on t[a] .. t[b - 1]
        inside = (kinks > t[a]) & (kinks < t[b - 1])
        return bool(np.all(np.isfinite(y[a:b])) and not inside.any())

    if not smooth(k - 1, k + 2):
        return value, at, qk
    lo, hi = k - 1, k + 2
    if k >= 2 and k + 3 <= len(t) and smooth(k - 2, k + 3):
        lo, hi = k - 2, k + 3
    h = float(t[k + 1] - t[k - 1]) / 2
    x = (np.asarray(t[lo:hi], dtype=float) - float(t[k])) / h  # scaled: well conditioned
    poly = np.polynomial.Polynomial.fit(x, np.asarray(y[lo:hi], dtype=float), hi - lo - 1)
    poly = poly.convert()
    x0, x1 = float(x[k - 1 - lo]), float(x[k + 1 - lo])
    best = None
    for r in poly.deriv().roots():
        if abs(r.imag) < 1e-12 and x0 <= r.real <= x1 and poly.deriv(2)(r.real) < 0:
            v = float(poly(r.real))
            if v >= value and (best is None or v > best[0]):
                best = (v, float(r.real))
    if best is None:
        return value, at, qk
    value, s = best[0], float(t[k]) + best[1] * h
    j = k - 1 if s < float(t[k]) else k
    step = float(t[j + 1] - t[j])
    u = (s - float(t[j])) / step
    h00, h10 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u
    h01, h11 = -2 * u**3 + 3 * u**2, u**3 - u**2
    qs = h00 * q[j] + h10 * step * qd[j] + h01 * q[j + 1] + h11 * step * qd[j + 1]
    return float(value), float(s), np.asarray(qs, dtype=float)


def _mean(t: np.ndarray, y: np.ndarray, span: float) -> float:
    """The time average of y over the samples (trapezoids)."""
    return float(np.trapezoid(y, t) / span)


def _work_per_turn(t: np.ndarray, q: np.ndarray, power: np.ndarray) -> float | None:
    """The work of ``power`` over the first turn of q (|q - q(0)| reaching 2 pi, the
    last part by linear interpolation); None before a turn is complete."""
    moved = np.abs(q - q[0])
    full = np.nonzero(moved >= 2 * np.pi)[0]
    if not len(full):
        return None
    k = int(full[0])
    s = (2 * np.pi - moved[k - 1]) / (moved[k] - moved[k - 1])
    t_turn = t[k - 1] + s * (t[k] - t[k - 1])
    p_turn = power[k - 1] + s * (power[k] - power[k - 1])
    tt = np.append(t[:k], t_turn)
    pp = np.append(power[:k], p_turn)
    return float(np.trapezoid(pp, tt))
