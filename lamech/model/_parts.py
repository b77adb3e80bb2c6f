"""The parts of a model, each a frozen definition that checks itself when it is made
(``__post_init__``) and raises :class:`~lamech.model.ModelError` listing everything
wrong: parameters, coordinates, constraints (with friction and where their force acts),
bodies and scenery. The rules for each part are here, beside it; what holds of a whole
system is in :mod:`._whole`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import sympy as sp

from ..expr import TimeDerivative
from ._base import (
    ConstraintKind,
    Issues,
    ModelError,
    SceneryKind,
    ShapeKind,
    as_enum,
    as_tuple,
    identifier_problem,
    is_bool,
    is_expr,
    join,
    name_problem,
    not_expr,
)

__all__ = [
    "Drive",
    "parameter",
    "parameters",
    "parameter_numbers",
    "signed_symbol",
    "coordinate",
    "Parameter",
    "Coordinate",
    "Friction",
    "ForceSpec",
    "Constraint",
    "Body",
    "Scenery",
    "inertia_components",
    "inertia_diagonal",
    "is_matrix3",
]


@dataclass(frozen=True)
class Parameter:
    """A named constant: symbolic in derivations, ``value`` used for numbers."""

    name: str
    symbol: sp.Symbol
    value: sp.Expr  # as written: a number or an expression of other parameters
    numeric: float  # ``value`` with every parameter substituted

    def __post_init__(self) -> None:
        ModelError.check(parameter_issues(self))


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
        ModelError.check(coordinate_issues(self))


@dataclass(frozen=True)
class Drive:
    """What makes a constraint a drive (a prescribed motion, ``[[drives]]``): its
    multiplier is reported as the force or torque the drive applies, lambda df/dq_c on
    its ``coordinate`` q_c (positive when it pushes the coordinate forward: with
    f = q_c - motion(t), df/dq_c = 1 and the generalized force on q_c is lambda itself);
    ``coordinate`` None for a general f(q, t), whose generalized force is lambda df/dq."""

    coordinate: str | None = None


@dataclass(frozen=True)
class Friction:
    """A friction limit: ``|lambda| <= mu * lambda_normal``, ``normal`` a constraint's name."""

    mu: sp.Expr
    normal: str

    def __post_init__(self) -> None:
        ModelError.check(friction_issues(self))


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
        as_tuple(self, "bodies", "at", "along")
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
        ModelError.check(force_issues(self))


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
    drive: Drive | None = None  # a prescribed motion ([[drives]]): see Drive

    def __post_init__(self) -> None:
        as_enum(self, "kind", ConstraintKind)
        if self.multiplier is None and isinstance(self.name, str):
            object.__setattr__(self, "multiplier", sp.Symbol(f"lambda_{self.name}", real=True))
        ModelError.check(constraint_issues(self))

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
        as_tuple(self, "position", "shape")
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
        ModelError.check(body_issues(self))


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
        as_enum(self, "kind", SceneryKind)
        if isinstance(self.points, (list, tuple)):
            object.__setattr__(
                self,
                "points",
                tuple(tuple(p) if isinstance(p, list) else p for p in self.points),
            )
        ModelError.check(scenery_issues(self))


# ----- parts on their own --------------------------------------------------------------
def parameter_numbers(values: Mapping[str, sp.Expr]) -> tuple[dict[str, float], list[str]]:
    """({name: number}, names in a cycle) of parameters whose ``values`` are expressions of
    each other (in Symbols named as the parameters), evaluated in dependency order. A cycle
    is returned, not looped on; a value that is not finite is NaN, and 1 stands in for it
    in the values that use it (a Parameter reports it)."""
    numeric: dict[str, float] = {}
    pending = dict(values)
    while pending:
        progress = False
        for n, e in list(pending.items()):
            if {str(s) for s in e.free_symbols} <= set(numeric):
                env = {
                    s: numeric[str(s)] if math.isfinite(numeric[str(s)]) else 1.0
                    for s in e.free_symbols
                }
                try:
                    numeric[n] = float(e.subs(env).evalf(30))
                except (TypeError, ValueError):
                    numeric[n] = float("nan")
                del pending[n]
                progress = True
        if not progress:
            return numeric, sorted(pending)
    return numeric, []


def signed_symbol(name: str, value: float) -> sp.Symbol:
    """A parameter's symbol: positive when its value is, negative when it is negative, real
    at 0 or NaN (the sign is part of the derivation: sqrt(R^2) = R)."""
    if value > 0:
        return sp.Symbol(name, positive=True)
    if value < 0:
        return sp.Symbol(name, negative=True)
    return sp.Symbol(name, real=True)


def _exact(value: Any) -> Any:
    """A float as the decimal written (0.05 is 1/20, as the parser reads it); a number
    as a SymPy number; anything else as it is (a SymPy expression, or what the checks
    report)."""
    if isinstance(value, float):
        return sp.Rational(repr(value))
    if isinstance(value, int) and not isinstance(value, bool):
        return sp.Integer(value)
    return value


def parameters(values: Mapping[str, float | sp.Expr]) -> tuple[Parameter, ...]:
    """Parameters as a problem file's ``[parameters]`` makes them: each value a number (a
    float taken as the decimal written) or an expression of the others (in any Symbols
    named as them), evaluated in dependency order, and each symbol signed as its value
    (``lamech.model.signed_symbol``: positive, negative or zero as the value).

    Raises
    ------
    ModelError
        An unknown name in a value, values that refer to each other in a cycle, or what
        a :class:`~lamech.Parameter` refuses (a value that is not a finite number).
    """
    exact = {n: _exact(v) for n, v in values.items()}
    issues: Issues = []
    for n, e in exact.items():
        if not is_expr(e):
            issues.append((f"parameters.{n}", not_expr(e, "the value")))
        elif unknown := sorted(str(s) for s in e.free_symbols if str(s) not in exact):
            known = ", ".join(exact)
            issues.append((f"parameters.{n}", f"unknown name `{unknown[0]}`; known: {known}"))
    ModelError.check(issues)
    real = {n: sp.Symbol(n, real=True) for n in exact}
    exprs = {n: e.xreplace({s: real[str(s)] for s in e.free_symbols}) for n, e in exact.items()}
    numeric, cycle = parameter_numbers(exprs)
    if cycle:
        raise ModelError([("parameters", _cycle(cycle))])
    final = {real[n]: signed_symbol(n, numeric[n]) for n in exprs}
    return tuple(Parameter(n, final[real[n]], exprs[n].xreplace(final), numeric[n]) for n in exprs)


def _cycle(names: list[str]) -> str:
    return (
        f"parameter values refer to each other in a cycle ({', '.join(names)}); give at "
        "least one of them a number"
    )


def parameter(name: str, value: float | sp.Expr) -> Parameter:
    """One parameter of a numeric ``value`` (:func:`parameters` for values that are
    expressions of each other)."""
    return parameters({name: value})[0]


def coordinate(
    name: str, initial: float | sp.Expr = 0, velocity: float | sp.Expr = 0, keep: bool = False
) -> Coordinate:
    """A coordinate as a problem file makes it: the real symbol ``name``, its velocity
    ``name'`` and acceleration ``name''`` (they print with dots in LaTeX), its initial
    value and velocity (numbers, floats taken as the decimal written, or expressions of
    the parameters)."""
    return Coordinate(
        name,
        sp.Symbol(name, real=True),
        TimeDerivative(name + "'", real=True),
        TimeDerivative(name + "''", real=True),
        _exact(initial),
        _exact(velocity),
        keep,
    )


def parameter_issues(p: Parameter) -> Issues:
    where = f"parameters.{p.name}"
    out: Issues = []
    if not isinstance(p.name, str) or not p.name:
        out.append((where, "a parameter needs a name (a string)"))
    if not isinstance(p.symbol, sp.Symbol):
        out.append((where, f"the symbol must be a SymPy Symbol, not {type(p.symbol).__name__}"))
    elif (problem := name_problem(p.symbol.name)) is not None:
        out.append((where, problem))
    if not is_expr(p.value):
        out.append((where, not_expr(p.value, "the value")))
    if (
        is_bool(p.numeric)
        or not isinstance(p.numeric, (int, float))
        or not math.isfinite(p.numeric)
    ):
        out.append((where, "value is not a finite real number"))
    elif isinstance(p.symbol, sp.Symbol) and (
        (p.symbol.is_positive and p.numeric < 0) or (p.symbol.is_negative and p.numeric > 0)
    ):
        sign = "positive" if p.symbol.is_positive else "negative"
        out.append((where, f"the symbol is declared {sign} but the value is {p.numeric:g}"))
    return out


def coordinate_issues(c: Coordinate) -> Issues:
    where = f"coordinates.{c.name}"
    out: Issues = []
    if (problem := name_problem(c.name)) is not None:
        out.append((where, problem))
        return out
    for label, sym, expected in (
        ("symbol", c.symbol, c.name),
        ("velocity", c.velocity, c.name + "'"),
        ("acceleration", c.acceleration, c.name + "''"),
    ):
        if not isinstance(sym, sp.Symbol):
            out.append(
                (
                    where,
                    f"the {label} symbol must be a SymPy Symbol named "
                    f"`{expected}`, not {type(sym).__name__}",
                )
            )
        elif sym.name != expected:
            out.append((where, f"the {label} symbol must be named `{expected}`, got `{sym.name}`"))
    if not is_expr(c.initial):
        out.append((where + ".initial", not_expr(c.initial, "the initial value")))
    if not is_expr(c.initial_velocity):
        out.append((where + ".velocity", not_expr(c.initial_velocity, "the initial velocity")))
    if not is_bool(c.keep):
        out.append((where + ".keep", "`keep` must be true or false"))
    return out


def friction_issues(f: Friction) -> Issues:
    out: Issues = []
    if not is_expr(f.mu):
        out.append(("friction.mu", not_expr(f.mu, "the coefficient of friction")))
    if not isinstance(f.normal, str):
        out.append(("friction.normal", "must be the name of the normal constraint (a string)"))
    return out


def force_issues(fs: ForceSpec) -> Issues:
    out: Issues = []
    if (
        not isinstance(fs.bodies, tuple)
        or len(fs.bodies) not in (1, 2)
        or not all(isinstance(n, str) for n in fs.bodies)
    ):
        out.append(
            ("force.body", "one body name, or two (force on the first, reaction on the second)")
        )
    if not isinstance(fs.at, tuple) or len(fs.at) not in (2, 3):
        n = len(fs.at) if isinstance(fs.at, tuple) else 1
        out.append(("force.at", f"must be a list of 2 or 3 expressions (x, y[, z]); got {n}"))
    elif not all(is_expr(x) for x in fs.at):
        out.append(
            ("force.at", not_expr(next(x for x in fs.at if not is_expr(x)), "each component"))
        )
    if not isinstance(fs.along, tuple):
        out.append(("force.along", "must be a tuple of (name, direction) pairs"))
        return out
    seen = set()
    for item in fs.along:
        if not (isinstance(item, tuple) and len(item) == 2 and isinstance(item[0], str)):
            out.append(("force.along", "must be a tuple of (name, direction) pairs"))
            continue
        name, vec = item
        where = f"force.along.{name}"
        if name == "residual":
            out.append(
                (
                    where,
                    "a direction may not be called `residual` (that name reports "
                    "what the point cannot carry); rename it",
                )
            )
            continue
        if name in seen:
            out.append((where, f"the direction `{name}` is given twice"))
        seen.add(name)
        if not isinstance(vec, tuple) or len(vec) not in (2, 3):
            n = len(vec) if isinstance(vec, tuple) else 1
            out.append((where, f"must be a list of 2 or 3 expressions (x, y[, z]); got {n}"))
        elif not all(is_expr(x) for x in vec):
            out.append((where, not_expr(next(x for x in vec if not is_expr(x)), "each component")))
        elif all(x.is_zero for x in vec):
            out.append(
                (
                    where,
                    "the direction is the zero vector; give one to project the "
                    'force on, e.g. ["sin(x)", "cos(x)"]',
                )
            )
    return out


def constraint_issues(c: Constraint) -> Issues:
    where = f"constraint `{c.name}`"
    out: Issues = []
    if (problem := identifier_problem(c.name)) is not None:
        out.append((join(where, "name"), problem))
    kinds = [k.value for k in ConstraintKind]
    field = "velocity" if c.kind == ConstraintKind.VELOCITY else "f"
    if not isinstance(c.kind, ConstraintKind):
        out.append((join(where, "kind"), f"kind `{c.kind}` is not one of " + ", ".join(kinds)))
    if not is_expr(c.expr):
        out.append((join(where, field), not_expr(c.expr, "the constraint")))
    elif c.expr == 0:
        out.append((join(where, field), "the constraint is identically zero"))
    if not is_bool(c.unilateral):
        out.append((join(where, "unilateral"), "`unilateral` must be true or false"))
    elif c.unilateral and c.kind != ConstraintKind.HOLONOMIC:
        out.append((join(where, "unilateral"), "only holonomic constraints (f) can be unilateral"))
    if c.friction is not None and not isinstance(c.friction, Friction):
        out.append((join(where, "friction"), "must be a Friction or None"))
    if c.force is not None and not isinstance(c.force, ForceSpec):
        out.append((join(where, "force"), "must be a ForceSpec or None"))
    if not is_expr(c.restitution):
        out.append((join(where, "restitution"), not_expr(c.restitution, "the restitution")))
    if c.drive is not None and not isinstance(c.drive, Drive):
        out.append((join(where, "drive"), "must be a Drive or None"))
    elif c.drive is not None and (c.unilateral or c.friction is not None):
        out.append((join(where, "drive"), "a drive is bilateral and has no friction"))
    expected = f"lambda_{c.name}"
    if isinstance(c.name, str) and (
        not isinstance(c.multiplier, sp.Symbol) or c.multiplier.name != expected
    ):
        out.append(
            (
                join(where, "multiplier"),
                f"the multiplier must be the Symbol `{expected}` (leave it out to get it)",
            )
        )
    return out


def body_issues(b: Body) -> Issues:
    where = f"body `{b.name}`"
    out: Issues = []
    if (problem := identifier_problem(b.name)) is not None:
        out.append((join(where, "name"), problem))
    if not is_expr(b.mass):
        out.append((join(where, "mass"), not_expr(b.mass, "the mass")))
    if not isinstance(b.position, tuple) or len(b.position) not in (2, 3):
        n = len(b.position) if isinstance(b.position, tuple) else 1
        out.append(
            (join(where, "position"), f"must be a list of 2 or 3 expressions (x, y[, z]); got {n}")
        )
    elif not all(is_expr(x) for x in b.position):
        out.append(
            (
                join(where, "position"),
                not_expr(next(x for x in b.position if not is_expr(x)), "each component"),
            )
        )
    if b.angle is not None:
        if not is_expr(b.angle):
            out.append((join(where, "angle"), not_expr(b.angle, "the angle")))
        if b.inertia is None:
            out.append(
                (
                    join(where, "angle"),
                    "a body with an `angle` needs its `inertia` "
                    "about the centre of mass (e.g. inertia = "
                    '"m*R^2/2")',
                )
            )
        if isinstance(b.position, tuple) and len(b.position) == 3:
            out.append(
                (
                    join(where, "angle"),
                    "an `angle` turns a planar body: give a 2-component position, or, in "
                    'space, a `rotation` (e.g. rotation = ["z:psi", "x:theta", "z:phi"])',
                )
            )
    out += _spatial_issues(b, where)
    shape = b.shape
    if not (isinstance(shape, tuple) and len(shape) == 2):
        out.append(
            (
                join(where, "shape"),
                'shape is (kind, size): ("point", None), ("circle", R) or ("rod", l)',
            )
        )
    elif not isinstance(shape[0], ShapeKind):
        out.append((join(where, "shape"), f"unknown shape `{shape[0]}`; use circle, rod or point"))
    elif shape[0] == ShapeKind.POINT and shape[1] is not None:
        out.append((join(where, "shape"), "a point has no size (give None)"))
    elif shape[0] != ShapeKind.POINT and not is_expr(shape[1]):
        out.append((join(where, "shape"), not_expr(shape[1], f"the size of the {shape[0].value}")))
    if b.shape_axis not in ("x", "y", "z"):
        out.append((join(where, "shape"), f"axis is x, y or z (got {b.shape_axis!r})"))
    elif b.shape_axis != "z" and not (isinstance(b.position, tuple) and len(b.position) == 3):
        out.append(
            (join(where, "shape"), "an axis orients a shape in space: a planar body has none")
        )
    return out


def _spatial_issues(b: Body, where: str) -> Issues:
    """A body in space: its rotation or orientation, and the form of its inertia."""
    out: Issues = []
    spatial = b.rotation is not None or b.orientation is not None
    if b.rotation is not None and b.orientation is not None:
        out.append((join(where, "rotation"), "give `rotation` or `orientation`, not both"))
    if spatial and b.angle is not None:
        out.append(
            (join(where, "angle"), "a body in space turns by its `rotation`, not an `angle`")
        )
    if spatial and not (isinstance(b.position, tuple) and len(b.position) == 3):
        out.append(
            (
                join(where, "rotation"),
                "a body turning in space needs a 3-component position (x, y, z)",
            )
        )
    if spatial and b.inertia is None:
        out.append(
            (
                join(where, "inertia"),
                "a turning body needs its `inertia` about the centre of mass, in its own "
                'axes: the principal moments (inertia = ["I1", "I2", "I3"]) or the 3 x 3 '
                "tensor",
            )
        )
    if b.rotation is not None:
        turns = b.rotation
        if not isinstance(turns, tuple) or not turns:
            out.append((join(where, "rotation"), 'give a list of turns, e.g. ["z:psi", "x:theta"]'))
        else:
            for turn in turns:
                if not (isinstance(turn, tuple) and len(turn) == 2 and turn[0] in ("x", "y", "z")):
                    out.append(
                        (
                            join(where, "rotation"),
                            f"each turn is (axis, angle) with axis x, y or z; got {turn!r}",
                        )
                    )
                elif not is_expr(turn[1]):
                    out.append((join(where, "rotation"), not_expr(turn[1], "each angle")))
    if b.rotation_frame not in ("body", "space"):
        out.append(
            (
                join(where, "rotation_frame"),
                'must be "body" (intrinsic turns) or "space" (extrinsic); '
                f"got {b.rotation_frame!r}",
            )
        )
    if b.orientation is not None and not is_matrix3(b.orientation):
        out.append(
            (join(where, "orientation"), "must be 3 rows of 3 expressions (the rotation matrix)")
        )
    inertia = b.inertia
    if inertia is None:
        return out
    if isinstance(inertia, tuple):
        if not spatial:
            out.append(
                (
                    join(where, "inertia"),
                    "principal moments or a tensor need a body in space (a `rotation` or an "
                    "`orientation`); a planar body has one moment about its centre",
                )
            )
        elif len(inertia) == 3 and all(is_expr(x) for x in inertia):
            pass
        elif is_matrix3(inertia):
            if any(
                sp.simplify(inertia[i][j] - inertia[j][i]) != 0 for i in range(3) for j in range(i)
            ):
                out.append((join(where, "inertia"), "the inertia tensor must be symmetric"))
        else:
            out.append(
                (
                    join(where, "inertia"),
                    "give one moment, the 3 principal moments, or 3 rows of 3 (the tensor)",
                )
            )
    elif not is_expr(inertia):
        out.append((join(where, "inertia"), not_expr(inertia, "the inertia")))
    return out


def is_matrix3(m) -> bool:
    return (
        isinstance(m, tuple)
        and len(m) == 3
        and all(isinstance(r, tuple) and len(r) == 3 and all(is_expr(x) for x in r) for r in m)
    )


def inertia_components(b: Body) -> list:
    """Every expression in a body's inertia (scalar, moments or tensor), for checks."""
    i = b.inertia
    if i is None:
        return []
    if isinstance(i, tuple):
        return [x for row in i for x in (row if isinstance(row, tuple) else (row,))]
    return [i]


def inertia_diagonal(b: Body) -> list:
    """The moments that must be >= 0: the scalar, the principal moments, or the tensor's
    diagonal."""
    i = b.inertia
    if i is None:
        return []
    if isinstance(i, tuple):
        return [i[k][k] if isinstance(i[k], tuple) else i[k] for k in range(len(i))]
    return [i]


_SCENERY_FORMS = (
    'point = [x, y], line = [[x1, y1], [x2, y2], ...] or circle = { center = [x, y], radius = "R" }'
)


def scenery_issues(g: Scenery) -> Issues:
    where = f"scenery `{g.name}`"
    out: Issues = []
    if not isinstance(g.name, str) or not g.name.strip():
        out.append((join(where, "name"), "a name must be a non-empty string"))
    if not isinstance(g.kind, SceneryKind):
        return out + [(where, f"unknown kind `{g.kind}`; scenery is one of {_SCENERY_FORMS}")]
    kind = g.kind.value
    if not isinstance(g.points, tuple) or not all(isinstance(p, tuple) for p in g.points):
        return out + [
            (join(where, kind), f"points must be lists of 2 or 3 expressions; {_SCENERY_FORMS}")
        ]
    wanted = "2 or more points" if g.kind == SceneryKind.LINE else "one point"
    if (g.kind == SceneryKind.LINE) != (len(g.points) != 1) or not g.points:
        out.append((join(where, kind), f"a {kind} has {wanted}; got {len(g.points)}"))
    sizes = {len(p) for p in g.points}
    if sizes - {2, 3} or len(sizes) > 1:
        out.append(
            (
                join(where, kind),
                "each point is a list of 2 or 3 expressions (x, y[, z]), all of one size",
            )
        )
    for p in g.points:
        for x in p:
            if not is_expr(x):
                out.append((join(where, kind), not_expr(x, "each component")))
                return out
    if (g.kind == SceneryKind.CIRCLE) != (g.radius is not None):
        out.append(
            (
                join(where, kind),
                "a circle needs a radius"
                if g.kind == SceneryKind.CIRCLE
                else f"a {kind} has no radius",
            )
        )
    elif g.radius is not None and not is_expr(g.radius):
        out.append((join(where, kind), not_expr(g.radius, "the radius")))
    return out
