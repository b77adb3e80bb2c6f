"""The rules a model obeys, each stated once: the definitions of :mod:`._system` check
themselves with these (``__post_init__``), and :mod:`lamech.problem` reports what they
find with the file and line.

Every function returns a list of (where, message); ``where`` names the place the way a
problem file does: ``parameters.l``, ``coordinates.x.initial``, ``lagrangian.V``,
``constraints[2] `rolling` friction.mu``, ``bodies[1] `wheel` mass``, ``forces.x``,
``gravity.acceleration``, ``scenery[1] `pivot` point``. A part checked on its own,
before it is in a system, does not know its index: ``constraint `rolling` unilateral``,
``body `wheel` position``, and a friction or force spec ``friction.mu``, ``force.at``.
"""

from __future__ import annotations

import keyword
import math
import re
from typing import TYPE_CHECKING, Any

import sympy as sp
from sympy.core.function import AppliedUndef

from ..expr import FUNCTIONS, RESERVED, Table

if TYPE_CHECKING:  # pragma: no cover
    from ._system import (
        Body,
        Constraint,
        Coordinate,
        ForceSpec,
        Friction,
        Parameter,
        Scenery,
        System,
    )

__all__ = [
    "FIELDS",
    "name_problem",
    "parameter_issues",
    "coordinate_issues",
    "friction_issues",
    "force_issues",
    "constraint_issues",
    "body_issues",
    "scenery_issues",
    "system_issues",
]

Issues = list[tuple[str, str]]

_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")

FIELDS: dict[str, tuple[str, str]] = {
    # field: (what may appear in it, how messages name it). "parameters": parameters
    # only; "positions": parameters, coordinates and t; "velocities": those and the
    # coordinates' velocities x'.
    "parameter value": ("parameters", "parameter values"),
    "initial": ("parameters", "initial values (parameters only)"),
    "initial velocity": ("parameters", "initial velocities (parameters only)"),
    "T": ("velocities", "T"),
    "V": ("positions", "V (positions only)"),
    "L": ("velocities", "L"),
    "f": (
        "positions",
        'a holonomic constraint f (positions only; use `velocity = "..."` '
        "for a velocity constraint)",
    ),
    "velocity": ("velocities", "velocity constraints"),
    "restitution": ("positions", "restitution"),
    "mu": ("positions", "mu"),
    "at": ("positions", "positions"),
    "along": ("positions", "directions"),
    "forces": ("velocities", "generalized forces"),
    "mass": ("parameters", "masses (parameters only)"),
    "position": ("positions", "positions"),
    "angle": ("positions", "angles"),
    "inertia": ("parameters", "inertia (parameters only)"),
    "shape": ("parameters", "shapes (parameters only)"),
    "scenery": ("positions", "scenery"),
    "gravity": ("parameters", "gravity (parameters only)"),
    "spring": ("parameters", "spring constants, lengths and damping (parameters only)"),
}
"""What each kind of expression may contain, and its name in messages (the loader
parses with the same)."""


# ----- names ---------------------------------------------------------------------------
def name_problem(name: Any) -> str | None:
    """Why ``name`` cannot name a parameter or coordinate, or None: an identifier, not a
    function or ``t``/``pi``, not ``lambda_...`` (the multipliers) nor containing ``__``."""
    if not isinstance(name, str) or not _IDENT.match(name):
        return f"`{name}` is not a valid name (letters, digits and _, not starting with a digit)"
    if name in RESERVED:
        kind = "a function" if name in FUNCTIONS else "reserved"
        return f"`{name}` is {kind} and cannot be a parameter or coordinate name; rename it"
    if keyword.iskeyword(name):
        return (
            f"`{name}` is reserved (a keyword of the expression syntax, so no expression "
            f"could use it) and cannot be a parameter or coordinate name; rename it "
            f"(e.g. {name}1)"
        )
    if name.startswith("lambda_") or "__" in name:
        return (
            f"`{name}`: names starting with `lambda_` or containing `__` are reserved "
            "(lambda_<constraint> names the multipliers); rename it"
        )
    return None


def _identifier_problem(name: Any) -> str | None:
    if not isinstance(name, str) or not _IDENT.match(name):
        return f"`{name}` is not a valid name (letters, digits and _, not starting with a digit)"
    return None


def _join(where: str, field: str) -> str:
    return f"{where} {field}" if where else field


def _not_expr(value: Any, what: str) -> str:
    return (
        f"{what} must be a SymPy expression (a number as sp.Integer/sp.Float, or in "
        f"the declared symbols), not {type(value).__name__}"
    )


def _is_expr(value: Any) -> bool:
    return isinstance(value, sp.Expr)


def _is_bool(value: Any) -> bool:
    return isinstance(value, bool)


# ----- parts on their own --------------------------------------------------------------
def parameter_issues(p: Parameter) -> Issues:
    where = f"parameters.{p.name}"
    out: Issues = []
    if not isinstance(p.name, str) or not p.name:
        out.append((where, "a parameter needs a name (a string)"))
    if not isinstance(p.symbol, sp.Symbol):
        out.append((where, f"the symbol must be a SymPy Symbol, not {type(p.symbol).__name__}"))
    elif (problem := name_problem(p.symbol.name)) is not None:
        out.append((where, problem))
    if not _is_expr(p.value):
        out.append((where, _not_expr(p.value, "the value")))
    if (
        _is_bool(p.numeric)
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
    if not _is_expr(c.initial):
        out.append((where + ".initial", _not_expr(c.initial, "the initial value")))
    if not _is_expr(c.initial_velocity):
        out.append((where + ".velocity", _not_expr(c.initial_velocity, "the initial velocity")))
    if not _is_bool(c.keep):
        out.append((where + ".keep", "`keep` must be true or false"))
    return out


def friction_issues(f: Friction) -> Issues:
    out: Issues = []
    if not _is_expr(f.mu):
        out.append(("friction.mu", _not_expr(f.mu, "the coefficient of friction")))
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
    elif not all(_is_expr(x) for x in fs.at):
        out.append(
            ("force.at", _not_expr(next(x for x in fs.at if not _is_expr(x)), "each component"))
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
        elif not all(_is_expr(x) for x in vec):
            out.append(
                (where, _not_expr(next(x for x in vec if not _is_expr(x)), "each component"))
            )
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
    from ._system import ConstraintKind, ForceSpec, Friction

    where = f"constraint `{c.name}`"
    out: Issues = []
    if (problem := _identifier_problem(c.name)) is not None:
        out.append((_join(where, "name"), problem))
    kinds = [k.value for k in ConstraintKind]
    field = "velocity" if c.kind == ConstraintKind.VELOCITY else "f"
    if not isinstance(c.kind, ConstraintKind):
        out.append((_join(where, "kind"), f"kind `{c.kind}` is not one of " + ", ".join(kinds)))
    if not _is_expr(c.expr):
        out.append((_join(where, field), _not_expr(c.expr, "the constraint")))
    elif c.expr == 0:
        out.append((_join(where, field), "the constraint is identically zero"))
    if not _is_bool(c.unilateral):
        out.append((_join(where, "unilateral"), "`unilateral` must be true or false"))
    elif c.unilateral and c.kind != ConstraintKind.HOLONOMIC:
        out.append((_join(where, "unilateral"), "only holonomic constraints (f) can be unilateral"))
    if c.friction is not None and not isinstance(c.friction, Friction):
        out.append((_join(where, "friction"), "must be a Friction or None"))
    if c.force is not None and not isinstance(c.force, ForceSpec):
        out.append((_join(where, "force"), "must be a ForceSpec or None"))
    if not _is_expr(c.restitution):
        out.append((_join(where, "restitution"), _not_expr(c.restitution, "the restitution")))
    expected = f"lambda_{c.name}"
    if isinstance(c.name, str) and (
        not isinstance(c.multiplier, sp.Symbol) or c.multiplier.name != expected
    ):
        out.append(
            (
                _join(where, "multiplier"),
                f"the multiplier must be the Symbol `{expected}` (leave it out to get it)",
            )
        )
    return out


def body_issues(b: Body) -> Issues:
    from ._system import ShapeKind

    where = f"body `{b.name}`"
    out: Issues = []
    if (problem := _identifier_problem(b.name)) is not None:
        out.append((_join(where, "name"), problem))
    if not _is_expr(b.mass):
        out.append((_join(where, "mass"), _not_expr(b.mass, "the mass")))
    if not isinstance(b.position, tuple) or len(b.position) not in (2, 3):
        n = len(b.position) if isinstance(b.position, tuple) else 1
        out.append(
            (_join(where, "position"), f"must be a list of 2 or 3 expressions (x, y[, z]); got {n}")
        )
    elif not all(_is_expr(x) for x in b.position):
        out.append(
            (
                _join(where, "position"),
                _not_expr(next(x for x in b.position if not _is_expr(x)), "each component"),
            )
        )
    if b.angle is not None:
        if not _is_expr(b.angle):
            out.append((_join(where, "angle"), _not_expr(b.angle, "the angle")))
        if b.inertia is None:
            out.append(
                (
                    _join(where, "angle"),
                    "a body with an `angle` needs its `inertia` "
                    "about the centre of mass (e.g. inertia = "
                    '"m*R^2/2")',
                )
            )
        if isinstance(b.position, tuple) and len(b.position) == 3:
            out.append(
                (
                    _join(where, "angle"),
                    "an `angle` turns a planar body: give a 2-component position, or, in "
                    'space, a `rotation` (e.g. rotation = ["z:psi", "x:theta", "z:phi"])',
                )
            )
    out += _spatial_issues(b, where)
    shape = b.shape
    if not (isinstance(shape, tuple) and len(shape) == 2):
        out.append(
            (
                _join(where, "shape"),
                'shape is (kind, size): ("point", None), ("circle", R) or ("rod", l)',
            )
        )
    elif not isinstance(shape[0], ShapeKind):
        out.append((_join(where, "shape"), f"unknown shape `{shape[0]}`; use circle, rod or point"))
    elif shape[0] == ShapeKind.POINT and shape[1] is not None:
        out.append((_join(where, "shape"), "a point has no size (give None)"))
    elif shape[0] != ShapeKind.POINT and not _is_expr(shape[1]):
        out.append(
            (_join(where, "shape"), _not_expr(shape[1], f"the size of the {shape[0].value}"))
        )
    if b.shape_axis not in ("x", "y", "z"):
        out.append((_join(where, "shape"), f"axis is x, y or z (got {b.shape_axis!r})"))
    elif b.shape_axis != "z" and not (isinstance(b.position, tuple) and len(b.position) == 3):
        out.append(
            (_join(where, "shape"), "an axis orients a shape in space: a planar body has none")
        )
    return out


def _spatial_issues(b: Body, where: str) -> Issues:
    """A body in space: its rotation or orientation, and the form of its inertia."""
    out: Issues = []
    spatial = b.rotation is not None or b.orientation is not None
    if b.rotation is not None and b.orientation is not None:
        out.append((_join(where, "rotation"), "give `rotation` or `orientation`, not both"))
    if spatial and b.angle is not None:
        out.append(
            (_join(where, "angle"), "a body in space turns by its `rotation`, not an `angle`")
        )
    if spatial and not (isinstance(b.position, tuple) and len(b.position) == 3):
        out.append(
            (
                _join(where, "rotation"),
                "a body turning in space needs a 3-component position (x, y, z)",
            )
        )
    if spatial and b.inertia is None:
        out.append(
            (
                _join(where, "inertia"),
                "a turning body needs its `inertia` about the centre of mass, in its own "
                'axes: the principal moments (inertia = ["I1", "I2", "I3"]) or the 3 x 3 '
                "tensor",
            )
        )
    if b.rotation is not None:
        turns = b.rotation
        if not isinstance(turns, tuple) or not turns:
            out.append(
                (_join(where, "rotation"), 'give a list of turns, e.g. ["z:psi", "x:theta"]')
            )
        else:
            for turn in turns:
                if not (isinstance(turn, tuple) and len(turn) == 2 and turn[0] in ("x", "y", "z")):
                    out.append(
                        (
                            _join(where, "rotation"),
                            f"each turn is (axis, angle) with axis x, y or z; got {turn!r}",
                        )
                    )
                elif not _is_expr(turn[1]):
                    out.append((_join(where, "rotation"), _not_expr(turn[1], "each angle")))
    if b.rotation_frame not in ("body", "space"):
        out.append(
            (
                _join(where, "rotation_frame"),
                'must be "body" (intrinsic turns) or "space" (extrinsic); '
                f"got {b.rotation_frame!r}",
            )
        )
    if b.orientation is not None and not _is_matrix3(b.orientation):
        out.append(
            (_join(where, "orientation"), "must be 3 rows of 3 expressions (the rotation matrix)")
        )
    inertia = b.inertia
    if inertia is None:
        return out
    if isinstance(inertia, tuple):
        if not spatial:
            out.append(
                (
                    _join(where, "inertia"),
                    "principal moments or a tensor need a body in space (a `rotation` or an "
                    "`orientation`); a planar body has one moment about its centre",
                )
            )
        elif len(inertia) == 3 and all(_is_expr(x) for x in inertia):
            pass
        elif _is_matrix3(inertia):
            if any(
                sp.simplify(inertia[i][j] - inertia[j][i]) != 0 for i in range(3) for j in range(i)
            ):
                out.append((_join(where, "inertia"), "the inertia tensor must be symmetric"))
        else:
            out.append(
                (
                    _join(where, "inertia"),
                    "give one moment, the 3 principal moments, or 3 rows of 3 (the tensor)",
                )
            )
    elif not _is_expr(inertia):
        out.append((_join(where, "inertia"), _not_expr(inertia, "the inertia")))
    return out


def _is_matrix3(m) -> bool:
    return (
        isinstance(m, tuple)
        and len(m) == 3
        and all(isinstance(r, tuple) and len(r) == 3 and all(_is_expr(x) for x in r) for r in m)
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
    from ._system import SceneryKind

    where = f"scenery `{g.name}`"
    out: Issues = []
    if not isinstance(g.name, str) or not g.name.strip():
        out.append((_join(where, "name"), "a name must be a non-empty string"))
    if not isinstance(g.kind, SceneryKind):
        return out + [(where, f"unknown kind `{g.kind}`; scenery is one of {_SCENERY_FORMS}")]
    kind = g.kind.value
    if not isinstance(g.points, tuple) or not all(isinstance(p, tuple) for p in g.points):
        return out + [
            (_join(where, kind), f"points must be lists of 2 or 3 expressions; {_SCENERY_FORMS}")
        ]
    wanted = "2 or more points" if g.kind == SceneryKind.LINE else "one point"
    if (g.kind == SceneryKind.LINE) != (len(g.points) != 1) or not g.points:
        out.append((_join(where, kind), f"a {kind} has {wanted}; got {len(g.points)}"))
    sizes = {len(p) for p in g.points}
    if sizes - {2, 3} or len(sizes) > 1:
        out.append(
            (
                _join(where, kind),
                "each point is a list of 2 or 3 expressions (x, y[, z]), all of one size",
            )
        )
    for p in g.points:
        for x in p:
            if not _is_expr(x):
                out.append((_join(where, kind), _not_expr(x, "each component")))
                return out
    if (g.kind == SceneryKind.CIRCLE) != (g.radius is not None):
        out.append(
            (
                _join(where, kind),
                "a circle needs a radius"
                if g.kind == SceneryKind.CIRCLE
                else f"a {kind} has no radius",
            )
        )
    elif g.radius is not None and not _is_expr(g.radius):
        out.append((_join(where, kind), _not_expr(g.radius, "the radius")))
    return out


_PLURAL = {
    "velocity": "velocities are",
    "acceleration": "accelerations are",
    "coordinate": "coordinates are",
    "time": "time is",
    "parameter": "parameters are",
}


# ----- the whole -----------------------------------------------------------------------
class _Scope:
    """The declared symbols of a system and what each field may contain."""

    def __init__(self, s: System):
        self.roles: dict[sp.Symbol, str] = {s.t: "time"}
        params = {p.symbol for p in s.parameters if isinstance(p.symbol, sp.Symbol)}
        for sym in params:
            self.roles[sym] = "parameter"
        for c in s.coordinates:
            self.roles[c.symbol] = "coordinate"
            self.roles[c.velocity] = "velocity"
            self.roles[c.acceleration] = "acceleration"
        coords = {c.symbol for c in s.coordinates}
        vels = {c.velocity for c in s.coordinates}
        self.allowed = {
            "parameters": params,
            "positions": params | coords | {s.t},
            "velocities": params | coords | vels | {s.t},
        }
        self.by_name = {str(sym): sym for sym in self.roles}
        self.known = {
            scope: ", ".join(sorted(str(x) for x in syms if "'" not in str(x))) or "(none)"
            for scope, syms in self.allowed.items()
        }

    def problem(self, expr: sp.Expr, field: str) -> str | None:
        """The first undeclared or disallowed name in ``expr`` as a field ``field``
        (a key of FIELDS), in the loader's words; None when all is well."""
        scope, what = FIELDS[field]
        allowed = self.allowed[scope]
        for sym in sorted(expr.free_symbols, key=str):
            if sym in allowed:
                continue
            role = self.roles.get(sym)
            if role is not None:
                return f"`{sym}`: {_PLURAL[role]} not allowed in {what}"
            if str(sym) in self.by_name:
                return (
                    f"`{sym}` is not the declared symbol `{sym}` (same name, other "
                    "assumptions); use the system's own symbol"
                )
            return f"unknown name `{sym}`; known: {self.known[scope]}"
        undefined = sorted(expr.atoms(AppliedUndef), key=str)
        if undefined:
            return f"unknown function `{undefined[0].func}`; known: " + ", ".join(sorted(FUNCTIONS))
        return None


def system_issues(s: System) -> Issues:
    """Everything wrong with ``s`` as a whole. The checks at numbers that cost most (the
    initial state, dependent constraints) run only when everything else is right."""
    from ._system import Body, Constraint, Coordinate, Parameter, Scenery

    out: Issues = []
    for label, items, cls in (
        ("parameters", s.parameters, Parameter),
        ("coordinates", s.coordinates, Coordinate),
        ("constraints", s.constraints, Constraint),
        ("bodies", s.bodies, Body),
        ("scenery", s.scenery, Scenery),
    ):
        if not isinstance(items, tuple) or not all(isinstance(x, cls) for x in items):
            out.append((label, f"{label} must be a tuple of {cls.__name__}"))
    if out:
        return out
    if not isinstance(s.t, sp.Symbol):
        return [("t", "t must be a SymPy Symbol")]
    out += _name_issues(s)
    scope = _Scope(s)
    out += _expression_issues(s, scope)
    out += _structure_issues(s, scope)
    out += _value_issues(s, scope)
    if out:
        return out
    out = _initial_issues(s) + _dependent_issues(s)
    if out or s.chart is None:
        return out
    from ._chart import chart_issues

    return chart_issues(s)


def _name_issues(s: System) -> Issues:
    out: Issues = []
    seen: dict[str, str] = {}
    for p in s.parameters:
        for n in {p.name, p.symbol.name}:
            if n in seen:
                out.append(
                    (f"parameters.{p.name}", f"`{n}` is declared twice as a parameter; rename one")
                )
            seen[n] = "parameter"
    for c in s.coordinates:
        where = f"coordinates.{c.name}"
        if seen.get(c.name) == "parameter":
            out.append(
                (
                    where,
                    f"`{c.name}` is declared both as a parameter and as a coordinate; rename one",
                )
            )
        elif c.name in seen:
            out.append((where, f"`{c.name}` is declared twice as a coordinate; rename one"))
        seen[c.name] = "coordinate"
    for label, names in (
        ("constraints", [con.name for con in s.constraints]),
        ("bodies", [b.name for b in s.bodies]),
    ):
        first: dict[str, int] = {}
        what = "constraint" if label == "constraints" else "body"
        for i, name in enumerate(names):
            if name in first:
                out.append(
                    (
                        f"{label}[{i + 1}] `{name}` name",
                        f"the name `{name}` "
                        f"is already used by {label}[{first[name] + 1}]; each {what} "
                        "needs a unique name",
                    )
                )
            else:
                first[name] = i
    return out


def _expression_issues(s: System, scope: _Scope) -> Issues:
    """Each expression contains only what its field allows."""
    out: Issues = []
    wrong: set[str] = set()

    def check(expr: Any, field: str, where: str) -> None:
        if where in wrong:
            return  # one issue per place: the first thing wrong there
        if not _is_expr(expr):
            problem: str | None = _not_expr(expr, FIELDS[field][1])
        else:
            problem = scope.problem(expr, field) or _kink_problem(expr, field, s)
        if problem is not None:
            wrong.add(where)
            out.append((where, problem))

    for p in s.parameters:
        check(p.value, "parameter value", f"parameters.{p.name}")
    for c in s.coordinates:
        check(c.initial, "initial", f"coordinates.{c.name}.initial")
        check(c.initial_velocity, "initial velocity", f"coordinates.{c.name}.velocity")
    check(s.T, "T", "lagrangian.T")
    check(s.V, "V", "lagrangian.V")
    if s.gravity is not None:
        check(s.gravity, "gravity", "gravity.acceleration")
    if not isinstance(s.forces, tuple) or len(s.forces) not in (0, len(s.coordinates)):
        out.append(("forces", "forces are one generalized force per coordinate (or none)"))
    else:
        for c, Q in zip(s.coordinates, s.forces):
            check(Q, "forces", f"forces.{c.name}")
    for i, con in enumerate(s.constraints):
        where = f"constraints[{i + 1}] `{con.name}`"
        field = "f" if con.holonomic else "velocity"
        check(con.expr, field, f"{where} {field}")
        check(con.restitution, "restitution", f"{where} restitution")
        if con.friction is not None:
            check(con.friction.mu, "mu", f"{where} friction.mu")
        if con.force is not None:
            for x in con.force.at:
                check(x, "at", f"{where} force.at")
            for name, vec in con.force.along:
                for x in vec:
                    check(x, "along", f"{where} force.along.{name}")
    for i, b in enumerate(s.bodies):
        where = f"bodies[{i + 1}] `{b.name}`"
        check(b.mass, "mass", f"{where} mass")
        for x in b.position:
            check(x, "position", f"{where} position")
        if b.angle is not None:
            check(b.angle, "angle", f"{where} angle")
        for x in inertia_components(b):
            check(x, "inertia", f"{where} inertia")
        for _axis, angle in b.rotation or ():
            check(angle, "angle", f"{where} rotation")
        for row in b.orientation or ():
            for x in row:
                check(x, "angle", f"{where} orientation")
        if b.shape[1] is not None:
            check(b.shape[1], "shape", f"{where} shape")
    for i, g in enumerate(s.scenery):
        where = f"scenery[{i + 1}] `{g.name}` {g.kind.value}"
        for point in g.points:
            for x in point:
                check(x, "scenery", where)
        if g.radius is not None:
            check(g.radius, "scenery", where)
    return out


def _kink_problem(expr: sp.Expr, field: str, s: System) -> str | None:
    """A function with a kink or a jump (``abs``, ``sign``, ``step``, ``min``, ``max``,
    ``clip``, ``piecewise``) where the derivation differentiates ``field`` into a delta
    function: V once in q (the force), T and L in q' and then in q, q', t (M and
    d/dt dT/dq'), f and the bodies' positions twice in q, t (gamma, and T from the
    bodies), velocity constraints once, a force's point once in q (partial velocities)."""
    if not expr.has(sp.Abs, sp.sign, sp.Heaviside, sp.Min, sp.Max, sp.Piecewise, Table):
        return None
    q = {c.symbol for c in s.coordinates}
    v = {c.velocity for c in s.coordinates}
    qt = q | {s.t}
    taken: dict[str, tuple[set, list, str]] = {
        "T": (q | v | {s.t}, [(v, q | v | {s.t})], "T twice (M = d2T/dq'2)"),
        "L": (q | v | {s.t}, [(v, q | v | {s.t})], "L twice (M = d2L/dq'2)"),
        "V": (q, [], "V once (the force -dV/dq)"),
        "f": (qt, [(qt, qt)], "a constraint f twice (its gamma)"),
        "position": (qt, [(qt, qt)], "positions twice (T from the bodies)"),
        "angle": (qt, [(qt, qt)], "angles twice (T from the bodies)"),
        "velocity": (q | v | {s.t}, [], "a velocity constraint once"),
        "at": (q, [], "a force's point once (its partial velocities)"),
    }
    if field not in taken:
        return None
    from ..expr import not_differentiable

    once, twice, how = taken[field]
    problem = not_differentiable(expr, once, twice)
    return None if problem is None else f"{problem}; lamech differentiates {how}"


def _no_velocity_issue(s: System) -> tuple[str, str]:
    """T without velocities: every body massless (T from the bodies is 0), or a typo."""
    from ._checks import massless

    if s.T == 0 and s.bodies and len(massless(s, s.parameter_values)) == len(s.bodies):
        return (
            "bodies[1] `" + s.bodies[0].name + "` mass",
            "every body is massless, so T = 0 and nothing has inertia; give at least "
            "one body a mass",
        )
    return ("lagrangian.T", "T has no velocity in it; write velocities as x'")


def _structure_issues(s: System, scope: _Scope) -> Issues:
    from ._system import ConstraintKind

    out: Issues = []
    qd = s.qd
    if _is_expr(s.T) and (s.T == 0 or not s.T.has(*qd)):
        out.append(_no_velocity_issue(s))
    names = [c.name for c in s.constraints]
    bodies = {b.name: b for b in s.bodies}
    for i, c in enumerate(s.constraints):
        where = f"constraints[{i + 1}] `{c.name}`"
        if c.kind == ConstraintKind.VELOCITY and _is_expr(c.expr):
            e = c.expr
            if not e.has(*qd):
                out.append(
                    (
                        f"{where} velocity",
                        "a velocity constraint must contain a "
                        "velocity (x'); for a constraint on positions use `f`",
                    )
                )
            elif any(sp.diff(e, a, b) != 0 for a in qd if e.has(a) for b in qd):
                out.append(
                    (
                        f"{where} velocity",
                        "a non-holonomic constraint must be linear "
                        "in the velocities (a(q,t).q' + b = 0)",
                    )
                )
        if c.friction is not None and (
            c.friction.normal == c.name or c.friction.normal not in names
        ):
            known = ", ".join(n for n in names if n != c.name) or "(none)"
            out.append(
                (
                    f"{where} friction.normal",
                    f"`{c.friction.normal}` is not another constraint; known: {known}",
                )
            )
        if c.force is not None:
            known = ", ".join(bodies) or "(none: declare bodies)"
            unknown = [n for n in c.force.bodies if n not in bodies]
            for n in unknown:
                out.append((f"{where} force.body", f"unknown body {n!r}; known: {known}"))
            if not unknown:
                dim = len(bodies[c.force.bodies[0]].position)
                if len(c.force.at) != dim:
                    out.append(
                        (
                            f"{where} force.at",
                            f"must have {dim} components, like the "
                            f"position of body `{c.force.bodies[0]}`; got "
                            f"{len(c.force.at)}",
                        )
                    )
                for name, vec in c.force.along:
                    if len(vec) != dim:
                        out.append(
                            (
                                f"{where} force.along.{name}",
                                f"must have {dim} "
                                f"components, like the position of body "
                                f"`{c.force.bodies[0]}`; got {len(vec)}",
                            )
                        )
    if len({len(b.position) for b in s.bodies}) > 1:
        out.append(
            (
                "bodies",
                "all bodies must have positions of the same size (2 for a plane, 3 for space)",
            )
        )
    if s.bodies:
        dim = s.dimension
        for i, g in enumerate(s.scenery):
            if any(len(p) != dim for p in g.points):
                out.append(
                    (
                        f"scenery[{i + 1}] `{g.name}` {g.kind.value}",
                        f"points must have {dim} components, like the bodies' positions",
                    )
                )
    return out


_ZERO = {"mass": "0 for a massless body", "inertia": "0 for no rotational inertia"}


def _impossible_inertia(b: Body, at_parameters) -> str | None:
    """What no rigid body has in ``b``'s inertia at the parameter values: a tensor that is
    not positive semidefinite, or principal moments that break the triangle inequality
    (each at most the sum of the other two: I1 + I2 >= I3, equal for a flat plate)."""
    import numpy as np

    i = b.inertia
    if not isinstance(i, tuple) or len(i) != 3:
        return None
    if all(not isinstance(x, tuple) for x in i):
        rows = [[i[k] if k == j else 0 for j in range(3)] for k in range(3)]
        given = "principal moments"
    elif _is_matrix3(i):
        rows = [list(r) for r in i]
        given = "inertia tensor"
    else:
        return None
    values = [[at_parameters(x) if _is_expr(x) else 0.0 for x in r] for r in rows]
    if any(v is None or not math.isfinite(v) for r in values for v in r):
        return None
    tensor = np.array(values, dtype=float)
    moments = np.sort(np.linalg.eigvalsh(0.5 * (tensor + tensor.T)))
    tol = 1e-9 * max(1.0, float(np.max(np.abs(moments))))
    shown = ", ".join(f"{m:.6g}" for m in moments)
    if moments[0] < -tol:
        return (
            f"the {given} is not positive definite (principal moments {shown}): no body "
            "has a negative moment of inertia"
        )
    if moments[2] > moments[0] + moments[1] + tol:
        return (
            f"principal moments {shown}: no body has them (the triangle inequality: the "
            f"largest, {moments[2]:.6g}, is at most the sum of the other two, "
            f"{moments[0] + moments[1]:.6g}, equal for a flat plate)"
        )
    return None


def _value_issues(s: System, scope: _Scope) -> Issues:
    """Masses and inertias >= 0 (a massless pulley, rod or attachment point is an
    idealisation the KKT system allows when the constraints give its motion to something
    with inertia; when they do not, :func:`_massless_issues` names the coordinate),
    friction coefficients >= 0, restitution in [0, 1], at the parameter values."""
    from ._checks import value

    out: Issues = []
    pv = s.parameter_values
    params = scope.allowed["parameters"]

    def at_parameters(expr: Any) -> float | None:
        if not _is_expr(expr) or not expr.free_symbols <= params:
            return None  # reported as a name problem
        try:
            return value(expr, pv)
        except (TypeError, ValueError):
            return float("nan")

    for i, b in enumerate(s.bodies):
        where = f"bodies[{i + 1}] `{b.name}`"
        negative = False
        for label, expr in [("mass", b.mass)] + [("inertia", x) for x in inertia_diagonal(b)]:
            if expr is None:
                continue
            v = at_parameters(expr)
            if v is not None and not (math.isfinite(v) and v >= 0):
                negative = True
                out.append(
                    (
                        f"{where} {label}",
                        f"must be >= 0 ({_ZERO[label]}), got {v:g}",
                    )
                )
        problem = None if negative else _impossible_inertia(b, at_parameters)
        if problem:
            out.append((f"{where} inertia", problem))
        if b.shape and len(b.shape) > 1 and b.shape[1] is not None and b.shape[0] == "circle":
            r = at_parameters(b.shape[1])
            if r is not None and not (math.isfinite(r) and r >= 0):
                out.append((f"{where} shape", f"a circle's radius must be >= 0, got {r:g}"))
    for i, g in enumerate(s.scenery):
        if g.radius is not None:
            r = at_parameters(g.radius)
            if r is not None and not (math.isfinite(r) and r >= 0):
                out.append(
                    (
                        f"scenery[{i + 1}] `{g.name}` {g.kind.value}",
                        f"a circle's radius must be >= 0, got {r:g}",
                    )
                )
    for i, c in enumerate(s.constraints):
        if c.unilateral:
            e = at_parameters(c.restitution)
            if e is not None and not (math.isfinite(e) and 0 <= e <= 1):
                out.append(
                    (
                        f"constraints[{i + 1}] `{c.name}` restitution",
                        f"must be between 0 (plastic) and 1 (elastic), got {e:g}: an impact "
                        "cannot return more energy than it had",
                    )
                )
        if c.friction is None:
            continue
        v = at_parameters(c.friction.mu)
        if v is not None and not (math.isfinite(v) and v >= 0):
            out.append(
                (
                    f"constraints[{i + 1}] `{c.name}` friction.mu",
                    f"must be a coefficient of friction >= 0, got {v:g}",
                )
            )
    return out


def _initial_issues(s: System) -> Issues:
    """The initial state meets every constraint (a unilateral contact may start open, see
    :func:`~lamech.model.open_at_start`, not on its forbidden side)."""
    from ._checks import INITIAL_TOLERANCE, value
    from ._kinematics import time_derivative

    out: Issues = []
    pv = s.parameter_values
    state = {}
    for c in s.coordinates:
        for sym, expr, label in (
            (c.symbol, c.initial, "initial"),
            (c.velocity, c.initial_velocity, "velocity"),
        ):
            try:
                state[sym] = value(expr, pv)
            except (TypeError, ValueError):
                state[sym] = float("nan")
            if not math.isfinite(state[sym]):
                out.append(
                    (
                        f"coordinates.{c.name}.{label}",
                        "the initial value is not a finite real number at the parameter values",
                    )
                )
    if out:
        return out
    scale = 1 + max((abs(v) for v in state.values()), default=0.0)
    tol = INITIAL_TOLERANCE * scale
    # Floats once, not in each value() call (the 30-link chain: 120 entries, 60 calls).
    env = {sym: sp.Float(v, 30) for sym, v in {**pv, **state, s.t: 0.0}.items()}
    out += _energy_at_start_issues(s, env, state)
    for i, con in enumerate(s.constraints):
        where = f"constraints[{i + 1}] `{con.name}`"
        try:
            if con.holonomic:
                res = value(con.expr, env)
                vres = value(time_derivative(con.expr, s), env)
            else:
                res, vres = 0.0, value(con.expr, env)
        except (TypeError, ValueError):
            out.append(
                (
                    where,
                    "cannot evaluate the constraint at the initial state "
                    "(complex or undefined value)",
                )
            )
            continue
        if con.unilateral and con.holonomic and (res > tol or (abs(res) <= tol and vres > tol)):
            continue  # an open (or opening) contact: allowed, see open_at_start
        if con.unilateral and con.holonomic and res < -tol:
            out.append(
                (
                    where,
                    f"the initial state is on the forbidden side of the "
                    f"unilateral constraint: f = {res:.6g} < 0 (f >= 0 is "
                    "allowed); change the coordinates' initial values",
                )
            )
        elif abs(res) > tol:
            out.append(
                (
                    where,
                    f"the initial state violates the constraint: f = {res:.6g} "
                    "(should be 0); change the coordinates' initial values",
                )
            )
        elif abs(vres) > tol:
            label = "df/dt" if con.holonomic else "the constraint"
            out.append(
                (
                    where,
                    f"the initial velocities violate the constraint: {label} = "
                    f"{vres:.6g} (should be 0); change the coordinates' initial "
                    "velocities",
                )
            )
    return out


def _energy_at_start_issues(s: System, env: dict, state: dict) -> Issues:
    """T, V and the generalized forces are finite real numbers at the initial state (a
    pole there, V = 1/(theta - 1/2) at theta = 1/2, would make every multiplier zoo)."""
    from ._checks import value

    out: Issues = []
    parts = [("lagrangian.T", "T", s.T), ("lagrangian.V", "V", s.V)]
    parts += [
        (f"forces.{c.name}", f"the force on {c.name}", Q)
        for c, Q in zip(s.coordinates, s.forces)
        if Q != 0
    ]
    for where, label, expr in parts:
        try:
            x = value(expr, env)
        except (TypeError, ValueError, ArithmeticError):
            x = float("nan")
        if math.isfinite(x):
            continue
        at = ", ".join(f"{sym} = {state[sym]:.6g}" for sym in state if expr.has(sym))
        out.append(
            (
                where,
                f"{label} is not a finite real number at the initial state"
                f"{f' ({at})' if at else ''}: a pole or a complex value there; start "
                f"elsewhere or correct {label}",
            )
        )
    if not out:
        out += _negative_kinetic_issues(s, env)
    return out


def _negative_kinetic_issues(s: System, env: dict) -> Issues:
    """T is never negative: its mass matrix d^2T/dq'^2 at the initial state has no
    negative eigenvalue (zero ones are a massless coordinate, allowed where the
    constraints give it inertia)."""
    import numpy as np

    from ._checks import numeric_matrix
    from ._kinematics import gradient, jacobian

    qd = [c.velocity for c in s.coordinates if s.T.has(c.velocity)]
    if not qd:
        return []
    try:
        M = numeric_matrix(jacobian(gradient(s.T, qd), qd), env)
    except (TypeError, ValueError, ArithmeticError):
        return []
    if not np.all(np.isfinite(M)):
        return []
    w, v = np.linalg.eigh((M + M.T) / 2)
    if w[0] >= -1e-12 * max(1.0, float(np.abs(w).max())):
        return []
    along = qd[int(np.argmax(np.abs(v[:, 0])))]
    return [
        (
            "lagrangian.T",
            f"T is negative for some velocities at the initial state (its mass matrix "
            f"d^2T/dq'^2 has the eigenvalue {w[0]:.6g}, mostly along {along}): a kinetic "
            "energy is never negative; check the signs and the masses in T",
        )
    ]


def _dependent_issues(s: System) -> Issues:
    """The KKT matrix at the start: constraints that are dependent there, else a
    massless body whose motion nothing gives inertia (:func:`_massless_issues`)."""
    from ._checks import dependent_constraints

    out: Issues = []
    for group, singular in dependent_constraints(s):
        idx = [c.name for c in s.constraints].index(group[0])
        where = f"constraints[{idx + 1}] `{group[0]}`"
        names = (
            " and ".join(f"`{n}`" for n in group)
            if len(group) <= 2
            else ", ".join(f"`{n}`" for n in group)
        )
        if singular:
            out.append(
                (
                    where,
                    f"constraints {names} are dependent at the initial state (a "
                    "singular configuration): forces cannot be uniquely "
                    "determined there; start elsewhere",
                )
            )
        else:
            out.append(
                (
                    where,
                    f"constraints {names} are dependent: forces cannot be "
                    "uniquely determined; remove the redundant one",
                )
            )
    return out or _massless_issues(s)


def _massless_issues(s: System) -> Issues:
    """A massless body (mass 0 at the parameter values) that leaves a motion the
    constraints allow without inertia at the initial state: the KKT matrix is singular
    and the accelerations cannot be found. Only systems with a massless body pay for
    this check (M at numbers)."""
    from ._checks import (
        holding_at_start,
        initial_values,
        massless,
        numeric_matrix,
        without_inertia,
    )
    from ._kinematics import constraint_jacobian, gradient, jacobian

    pv = s.parameter_values
    if not massless(s, pv):
        return []
    try:
        env = {**pv, **initial_values(s), s.t: 0.0}
        qd = sp.Matrix(s.qd)
        M = numeric_matrix(jacobian(gradient(s.L, qd), qd), env)
        A = numeric_matrix(constraint_jacobian(holding_at_start(s))[0], env)
    except (TypeError, ValueError):
        return []  # not numbers at the start: reported elsewhere, or left to solve
    weak = without_inertia(s, M, A.reshape(-1, len(s.coordinates)), env)
    if weak is None or not weak.massless:
        return []  # no massless body in it: solve names the coordinate
    i = weak.massless[0]
    return [
        (
            f"bodies[{i + 1}] `{s.bodies[i].name}` mass",
            f"{weak.describe(s)}, so the accelerations cannot be found (the KKT "
            "matrix is singular at the initial state); give the body a mass, or a "
            "constraint that ties its motion to a body with one",
        )
    ]
