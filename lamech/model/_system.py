"""The model: a constrained mechanical system as plain frozen data.

A :class:`System` holds SymPy expressions in its own symbols: coordinates ``q`` (real),
their velocities ``q'`` and accelerations ``q''``, parameters (positive when their value
is), and time ``t``. It is built by :mod:`lamech.problem` from a problem file or a dict, or
directly in Python (:func:`lamech.model.assemble` adds what a file's bodies, loads and L
imply); either way each definition checks itself when it is made (``__post_init__``,
:mod:`lamech.model._parts`) and raises :class:`ModelError` listing everything wrong, and
a System checks the whole (:mod:`lamech.model._whole`). Derivations
(:mod:`lamech.symbolic` and after) are pure functions of it.

The canonical equations every other docstring refers to (the lecture's convention)::

    d/dt dL/dq'_r - dL/dq_r - sum_j lambda_j dF_j/dq'_r = Q^nc_r      (r = 1..n)

where for a holonomic constraint f_j(q, t) = 0 the velocity form is F_j = df_j/dt, so
dF_j/dq'_r = df_j/dq_r, and for a non-holonomic one F_j = g_j = a_j(q,t).q' + b_j(q,t).
The generalized force of constraint j is Q^(j)_r = lambda_j dF_j/dq'_r. A unilateral
constraint holds on the side f_j >= 0, where lambda_j >= 0 pushes the system back.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import sympy as sp

from ._base import Memo, ModelError, as_tuple
from ._chart import Chart, chart_initial, exact_start
from ._checks import initial_values
from ._hints import hints, is_hint
from ._parts import Body, Constraint, Coordinate, Parameter, Scenery
from ._whole import CHART, system_issues

_REMEMBERED = Memo()
"""What the checks found clean, the hints and the placed charts, by the values read."""
_HINTED = ("parameters", "coordinates", "constraints", "bodies", "gravity", "T", "V", "forces", "t")
"""The fields the hints read (:mod:`._hints`)."""
_PLACED = ("chart", "parameters", "coordinates", "t")
"""The fields placing a chart reads (:func:`lamech.model._chart.chart_initial`)."""

__all__ = ["System"]


@dataclass(frozen=True)
class System:
    """A constrained system: the input of every derivation (frozen, self-consistent).

    ``T`` and ``V`` are in coordinates, velocities, parameters and ``t``; ``forces`` is
    Q^nc, one entry per coordinate. ``notes`` carries warnings found while loading (a T
    that disagrees with the bodies' kinematics); ``scenery`` is drawn, never simulated;
    ``units`` holds the dimensions inferred where the problem gives units
    (:func:`lamech.model.infer_units`), None where it gives none.
    A System takes T, V and the forces as given: :func:`lamech.model.assemble` makes them
    from bodies, an L and applied loads, as a problem file's sections do.
    """

    title: str
    parameters: tuple[Parameter, ...]
    coordinates: tuple[Coordinate, ...]
    T: sp.Expr
    V: sp.Expr
    constraints: tuple[Constraint, ...]
    bodies: tuple[Body, ...] = ()
    gravity: sp.Expr | None = None
    forces: tuple[sp.Expr, ...] = ()
    t: sp.Symbol = sp.Symbol("t", real=True)
    source: str | None = None
    notes: tuple[str, ...] = ()
    scenery: tuple[Scenery, ...] = ()
    chart: Any = None  # a lamech.model.Chart: the coordinates results are given in
    sliders: tuple[tuple[str, float, float], ...] = ()  # (name, low, high): [sliders]
    units: Any = None  # a lamech.model.Units where the file uses units (issue 46), else None

    def __post_init__(self) -> None:
        # Every check for values not found clean before: a copy (dataclasses.replace,
        # with_values) is checked again only in the groups of rules that read a field it
        # changed (the groups and their fields: lamech.model._whole).
        as_tuple(
            self, "parameters", "coordinates", "constraints", "bodies", "forces", "notes", "scenery"
        )
        ModelError.check(system_issues(self, _REMEMBERED))
        if self.chart is not None:
            self._place_chart()
        # the warnings about these values (a 30 that is meant in degrees), said once:
        # those about a system's earlier values (dataclasses.replace) are dropped
        kept = [n for n in self.notes if not is_hint(n)]
        found = _REMEMBERED.get(Memo.key("hints", self, _HINTED), lambda: tuple(hints(self)))
        object.__setattr__(self, "notes", tuple(dict.fromkeys(kept + list(found))))

    def _place_chart(self) -> None:
        """Give the chart's coordinates the initial values that reproduce this system's
        initial state (so ``dataclasses.replace`` with new values moves them too)."""
        key = Memo.key("placed", self, _PLACED)
        chart = _REMEMBERED.get(key, self._placed_chart)
        object.__setattr__(self, "chart", chart)
        # the chart as placed is placed, and its rules found clean as the one given
        _REMEMBERED.put(Memo.key("placed", self, _PLACED), chart)
        _REMEMBERED.put(Memo.key("chart", self, CHART), True)

    def _placed_chart(self) -> Chart:
        state = {k: v for k, v in initial_values(_without_chart(self)).items()}
        found = chart_initial(self, state)
        if isinstance(found, str):
            raise ModelError([("parametrisation", found)])
        exact = exact_start(self, found)
        coords = tuple(
            Coordinate(
                c.name,
                c.symbol,
                c.velocity,
                c.acceleration,
                exact.get(c.symbol, sp.Float(found[c.symbol], 17)),
                exact.get(c.velocity, sp.Float(found[c.velocity], 17)),
            )
            for c in self.chart.coordinates
        )
        return Chart(coords, self.chart.map, self.chart.automatic)

    # ----- views -----------------------------------------------------------------
    @property
    def L(self) -> sp.Expr:
        return self.T - self.V

    @property
    def q(self) -> list[sp.Symbol]:
        return [c.symbol for c in self.coordinates]

    @property
    def qd(self) -> list[sp.Symbol]:
        return [c.velocity for c in self.coordinates]

    @property
    def qdd(self) -> list[sp.Symbol]:
        return [c.acceleration for c in self.coordinates]

    @property
    def multipliers(self) -> list[sp.Symbol]:
        return [c.multiplier for c in self.constraints]

    @property
    def parameter_values(self) -> dict[sp.Symbol, float]:
        return {p.symbol: p.numeric for p in self.parameters}

    @property
    def dimension(self) -> int:
        """2 for a planar system, 3 when any body moves in space; 2 without bodies."""
        return max((len(b.position) for b in self.bodies), default=2)

    def constraint(self, name: str) -> Constraint:
        for c in self.constraints:
            if c.name == name:
                return c
        raise KeyError(name)

    def body(self, name: str) -> Body:
        for b in self.bodies:
            if b.name == name:
                return b
        raise KeyError(name)

    def coordinate(self, name: str) -> Coordinate:
        for c in self.coordinates:
            if c.name == name:
                return c
        raise KeyError(name)

    @property
    def symbols(self) -> dict[str, sp.Symbol]:
        """Every symbol by its printed name: parameters, ``x``, ``x'``, ``x''``, ``t``,
        ``lambda_<constraint>``."""
        out: dict[str, sp.Symbol] = {"t": self.t}
        for p in self.parameters:
            out[p.name] = p.symbol
        for c in self.coordinates + self.chart_coordinates:
            out[c.name] = c.symbol
            out[c.name + "'"] = c.velocity
            out[c.name + "''"] = c.acceleration
        for con in self.constraints:
            out[con.multiplier.name] = con.multiplier
        return out

    @property
    def initial_state(self) -> dict[sp.Symbol, sp.Expr]:
        """Initial coordinates and velocities, as expressions of the parameters (the
        chart's coordinates, when there is one, as numbers)."""
        out: dict[sp.Symbol, sp.Expr] = {}
        for c in self.coordinates + self.chart_coordinates:
            out[c.symbol] = c.initial
            out[c.velocity] = c.initial_velocity
        return out

    @property
    def chart_coordinates(self) -> tuple[Coordinate, ...]:
        """The coordinates of the chart (:class:`lamech.model.Chart`), or ()."""
        return tuple(self.chart.coordinates) if self.chart is not None else ()

    # ----- numbers --------------------------------------------------------------
    def numeric(self, expr: sp.Expr) -> sp.Expr:
        """``expr`` with every parameter replaced by its value."""
        return sp.sympify(expr).subs(self.parameter_values)


def _without_chart(system: System) -> System:
    """A shallow stand-in of ``system`` whose initial state is the coordinates' alone."""
    clone = object.__new__(System)
    clone.__dict__.update(system.__dict__)
    clone.__dict__["chart"] = None
    return clone
