"""The model: a constrained mechanical system as plain frozen data.

A :class:`System` holds SymPy expressions in its own symbols: coordinates ``q`` (real),
their velocities ``q'`` and accelerations ``q''``, parameters (positive when their value
is), and time ``t``. It is built by :mod:`lamech.problem` from a problem file or a dict, or
directly in Python; either way each definition checks itself when it is made
(``__post_init__``, :mod:`lamech.model._rules`) and raises :class:`ModelError` listing
everything wrong, and a System checks the whole. Derivations (:mod:`lamech.symbolic` and
after) are pure functions of it.

The canonical equations every other docstring refers to (the lecture's convention)::

    d/dt dL/dq'_r - dL/dq_r - sum_j lambda_j dF_j/dq'_r = Q^nc_r      (r = 1..n)

where for a holonomic constraint f_j(q, t) = 0 the velocity form is F_j = df_j/dt, so
dF_j/dq'_r = df_j/dq_r, and for a non-holonomic one F_j = g_j = a_j(q,t).q' + b_j(q,t).
The generalized force of constraint j is Q^(j)_r = lambda_j dF_j/dq'_r. A unilateral
constraint holds on the side f_j >= 0, where lambda_j >= 0 pushes the system back.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum
from typing import Any

import sympy as sp

from . import _rules

__all__ = [
    "Parameter",
    "Coordinate",
    "Friction",
    "ForceSpec",
    "Constraint",
    "Body",
    "System",
    "ModelError",
    "ConstraintKind",
    "ShapeKind",
]


class ModelError(ValueError):
    """A definition breaks a rule of the model. ``issues`` lists every (where, message)
    found, so that a user fixes everything in one pass."""

    def __init__(self, issues: list[tuple[str, str]]):
        self.issues = list(issues)
        super().__init__("\n".join(f"{w}: {m}" if w else m for w, m in self.issues))

    @classmethod
    def check(cls, issues: list[tuple[str, str]]) -> None:
        """Raise for ``issues``, if there are any."""
        if issues:
            raise cls(issues)


class _Text(str, Enum):
    """A str enum that prints as its value (``f"{kind}"`` is ``holonomic``)."""

    def __str__(self) -> str:
        return str.__str__(self)

    def __format__(self, spec: str) -> str:
        return str.__format__(str.__str__(self), spec)


class ConstraintKind(_Text):
    """What a constraint's ``expr`` is: f(q, t) = 0, or g(q, q', t) = 0 linear in q'."""

    HOLONOMIC = "holonomic"
    VELOCITY = "velocity"


class ShapeKind(_Text):
    """How a body is drawn: ``Body.shape`` is (kind, size), size None for a point."""

    POINT = "point"
    CIRCLE = "circle"
    ROD = "rod"


class SceneryKind(_Text):
    """What a piece of scenery is: ``Scenery.points`` holds one point, 2 or more, or the
    centre (with ``radius``)."""

    POINT = "point"
    LINE = "line"
    CIRCLE = "circle"


def _as_enum(obj, name: str, enum: type[Enum]) -> None:
    """Store a field given as its string value (``"holonomic"``) as the enum member."""
    raw = getattr(obj, name)
    if isinstance(raw, str) and not isinstance(raw, enum):
        try:
            object.__setattr__(obj, name, enum(raw))
        except ValueError:
            pass  # reported by the checks


def _as_tuple(obj, *names: str) -> None:
    """Store list fields as tuples (frozen data is hashable)."""
    for name in names:
        raw = getattr(obj, name)
        if isinstance(raw, list):
            object.__setattr__(obj, name, tuple(raw))


@dataclass(frozen=True)
class Parameter:
    """A named constant: symbolic in derivations, ``value`` used for numbers."""

    name: str
    symbol: sp.Symbol
    value: sp.Expr  # as written: a number or an expression of other parameters
    numeric: float  # ``value`` with every parameter substituted

    def __post_init__(self) -> None:
        ModelError.check(_rules.parameter_issues(self))


@dataclass(frozen=True)
class Coordinate:
    """A generalized coordinate, its velocity and acceleration symbols, its initial state."""

    name: str
    symbol: sp.Symbol
    velocity: sp.Symbol
    acceleration: sp.Symbol
    initial: sp.Expr  # expression of parameters
    initial_velocity: sp.Expr  # expression of parameters
    keep: bool = False  # never eliminated

    def __post_init__(self) -> None:
        ModelError.check(_rules.coordinate_issues(self))


@dataclass(frozen=True)
class Friction:
    """A friction limit: ``|lambda| <= mu * lambda_normal``, ``normal`` a constraint's name."""

    mu: sp.Expr
    normal: str

    def __post_init__(self) -> None:
        ModelError.check(_rules.friction_issues(self))


@dataclass(frozen=True)
class ForceSpec:
    """Where a constraint's force acts, for its Cartesian components.

    ``bodies`` is one body name, or two (force on the first, reaction on the second);
    ``at`` the point (plane or space) in q and t; ``along`` named directions.
    """

    bodies: tuple[str, ...]
    at: tuple[sp.Expr, ...]
    along: tuple[tuple[str, tuple[sp.Expr, ...]], ...] = ()

    def __post_init__(self) -> None:
        if isinstance(self.bodies, str):
            object.__setattr__(self, "bodies", (self.bodies,))
        _as_tuple(self, "bodies", "at", "along")
        if isinstance(self.along, tuple):
            object.__setattr__(
                self,
                "along",
                tuple(
                    (d[0], tuple(d[1]))
                    if isinstance(d, (tuple, list)) and len(d) == 2 and isinstance(d[1], list)
                    else tuple(d)
                    if isinstance(d, list)
                    else d
                    for d in self.along
                ),
            )
        ModelError.check(_rules.force_issues(self))


@dataclass(frozen=True)
class Constraint:
    """One constraint. ``expr`` is f(q, t) (``kind`` holonomic) or g(q, q', t) linear in
    the velocities (``kind`` velocity); see the module docstring. ``kind`` may be given
    as its string; ``multiplier`` defaults to the real Symbol ``lambda_<name>``."""

    name: str
    expr: sp.Expr
    kind: ConstraintKind = ConstraintKind.HOLONOMIC
    unilateral: bool = False
    friction: Friction | None = None
    force: ForceSpec | None = None
    restitution: sp.Expr = sp.Integer(0)
    multiplier: sp.Symbol = field(default=None)

    def __post_init__(self) -> None:
        _as_enum(self, "kind", ConstraintKind)
        if self.multiplier is None and isinstance(self.name, str):
            object.__setattr__(self, "multiplier", sp.Symbol(f"lambda_{self.name}", real=True))
        ModelError.check(_rules.constraint_issues(self))

    @property
    def holonomic(self) -> bool:
        return self.kind == ConstraintKind.HOLONOMIC


@dataclass(frozen=True)
class Body:
    """A point mass, a planar rigid body or a rigid body in space.

    ``position`` is the centre of mass (2 or 3 components, y or z up). A planar rigid body
    has a counterclockwise ``angle`` and a scalar ``inertia`` about the centre. A body in
    space (3 components) is oriented by ``rotation``, a sequence of (axis, angle) turns
    about x, y or z (``rotation_frame`` "body": each about the axes turned by the ones
    before, intrinsic, as Euler's z-x-z or the 3-1-2 of a rolling disc; "space": each
    about the fixed axes, extrinsic), or by ``orientation``, the 3 x 3 matrix whose columns
    are the body axes in the world frame; its ``inertia`` about the centre, in the body
    axes, is a scalar (the same about every axis), the 3 principal moments, or the 3 x 3
    tensor. ``shape`` is (kind, size) for drawing: (POINT, None), (CIRCLE, R) or (ROD, l);
    the kind may be given as its string. In space, ``shape_axis`` ("x", "y" or "z") is the
    body axis a rod lies along and a circle turns about (its axle: the circle lies in the
    plane of the other two body axes)."""

    name: str
    mass: sp.Expr
    position: tuple[sp.Expr, ...]
    angle: sp.Expr | None = None
    inertia: Any = None  # Expr; 3 principal moments; or a 3 x 3 tensor (tuples)
    shape: tuple[ShapeKind, sp.Expr | None] = (ShapeKind.POINT, None)
    rotation: tuple[tuple[str, sp.Expr], ...] | None = None
    rotation_frame: str = "body"
    orientation: tuple[tuple[sp.Expr, ...], ...] | None = None
    shape_axis: str = "z"

    def __post_init__(self) -> None:
        _as_tuple(self, "position", "shape")
        for name in ("rotation", "orientation", "inertia"):
            raw = getattr(self, name)
            if isinstance(raw, (list, tuple)):
                object.__setattr__(
                    self, name, tuple(tuple(x) if isinstance(x, list) else x for x in raw)
                )
        if isinstance(self.shape, tuple) and len(self.shape) == 2:
            kind = self.shape[0]
            if isinstance(kind, str) and kind in [k.value for k in ShapeKind]:
                object.__setattr__(self, "shape", (ShapeKind(kind), self.shape[1]))
        ModelError.check(_rules.body_issues(self))


@dataclass(frozen=True)
class Scenery:
    """Geometry drawn with the bodies but not a body: a fixed cylinder, a pivot, a wall, a
    string from a pivot to a bob. ``points`` (each 2 or 3 expressions, like a body's
    position) are one point (POINT), a polyline of 2 or more (LINE) or the centre of a
    circle of ``radius`` (CIRCLE); they may depend on the coordinates and t, so a string
    or a rod between bodies moves with them. It plays no part in the mechanics."""

    name: str
    kind: SceneryKind
    points: tuple[tuple[sp.Expr, ...], ...]
    radius: sp.Expr | None = None

    def __post_init__(self) -> None:
        _as_enum(self, "kind", SceneryKind)
        if isinstance(self.points, (list, tuple)):
            object.__setattr__(
                self,
                "points",
                tuple(tuple(p) if isinstance(p, list) else p for p in self.points),
            )
        ModelError.check(_rules.scenery_issues(self))


@dataclass(frozen=True)
class System:
    """A constrained system: the input of every derivation (frozen, self-consistent).

    ``T`` and ``V`` are in coordinates, velocities, parameters and ``t``; ``forces`` is
    Q^nc, one entry per coordinate. ``notes`` carries warnings found while loading (a T
    that disagrees with the bodies' kinematics); ``scenery`` is drawn, never simulated.
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

    def __post_init__(self) -> None:
        # Every check, once per construction (``dataclasses.replace`` included): the
        # rules are in lamech.model._rules.
        _as_tuple(
            self, "parameters", "coordinates", "constraints", "bodies", "forces", "notes", "scenery"
        )
        ModelError.check(_rules.system_issues(self))
        if self.chart is not None:
            self._place_chart()
        # the warnings about these values (a 30 that is meant in degrees), said once:
        # those about a system's earlier values (dataclasses.replace) are dropped
        from ._hints import hints, is_hint

        kept = [n for n in self.notes if not is_hint(n)]
        object.__setattr__(self, "notes", tuple(dict.fromkeys(kept + hints(self))))

    def _place_chart(self) -> None:
        """Give the chart's coordinates the initial values that reproduce this system's
        initial state (so ``dataclasses.replace`` with new values moves them too)."""
        from ._chart import Chart, chart_initial
        from ._checks import initial_values

        state = {k: v for k, v in initial_values(_without_chart(self)).items()}
        found = chart_initial(self, state)
        if isinstance(found, str):
            raise ModelError([("parametrisation", found)])
        coords = tuple(
            Coordinate(
                c.name,
                c.symbol,
                c.velocity,
                c.acceleration,
                sp.Float(found[c.symbol], 17),
                sp.Float(found[c.velocity], 17),
            )
            for c in self.chart.coordinates
        )
        object.__setattr__(self, "chart", Chart(coords, self.chart.map))

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
