"""The rules a whole system obeys: names declared once, each expression in its field's
symbols (:data:`~lamech.model._base.FIELDS`) and differentiable as the derivation needs, the
parts fitting together (a friction's normal constraint, a force's bodies, one dimension),
and values possible at the parameters (masses >= 0, a real inertia). What must hold at
the numbers of the initial state follows in :mod:`._start`, and a chart's rules in
:mod:`._chart`. :class:`~lamech.model.System` checks itself with :func:`system_issues`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
import sympy as sp
from sympy.core.function import AppliedUndef

from ..expr import FUNCTIONS, Table, not_differentiable, to_text
from ._base import FIELDS, ConstraintKind, Issues, Memo, is_expr, not_expr
from ._chart import chart_issues
from ._checks import massless, value
from ._kinematics import polar_radii
from ._parts import (
    Body,
    Constraint,
    Coordinate,
    Parameter,
    Scenery,
    inertia_components,
    inertia_diagonal,
    is_matrix3,
)
from ._start import dependent_issues, initial_issues

if TYPE_CHECKING:  # pragma: no cover
    from ._system import System

__all__ = ["system_issues", "Scope"]


_PLURAL = {
    "velocity": "velocities are",
    "acceleration": "accelerations are",
    "coordinate": "coordinates are",
    "time": "time is",
    "parameter": "parameters are",
}


# ----- the whole -----------------------------------------------------------------------
class Scope:
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


FORM = (
    *("parameters", "coordinates", "constraints", "bodies", "scenery"),
    *("t", "T", "V", "gravity", "forces"),
)
"""The fields the rules of the form read (names, expressions, structure, values)."""
START = ("parameters", "coordinates", "constraints", "bodies", "t", "T", "V", "forces")
"""The fields the rules at the initial state read (:mod:`._start`)."""
CHART = ("parameters", "coordinates", "constraints", "t", "chart")
"""The fields a chart's rules read (:func:`lamech.model._chart.chart_issues`)."""


def system_issues(s: System, clean: Memo | None = None) -> Issues:
    """Everything wrong with ``s`` as a whole. The checks at numbers that cost most (the
    initial state, dependent constraints) run only when everything else is right.

    ``clean`` remembers each group of rules (:data:`FORM`, :data:`START`, :data:`CHART`)
    found clean for the values of the fields it reads; a group is skipped for values
    found clean before (a copy that changed other fields), and run for any other.
    """
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
    groups: list[tuple[str, tuple[str, ...], Callable[[System], Issues]]] = [
        ("form", FORM, _form_issues),
        # the dependent constraints only from a valid start (they build the system of the
        # contacts holding there, which would report the start's issues at its own indices)
        ("start", START, lambda s: initial_issues(s) or dependent_issues(s)),
    ]
    if s.chart is not None:
        groups.append(("chart", CHART, chart_issues))
    for name, fields, rules in groups:
        key = None if clean is None else clean.key(name, s, fields)
        if key is not None and clean is not None and key in clean:
            continue
        out = rules(s)
        if out:
            return out
        if clean is not None:
            clean.put(key, True)
    return []


def _form_issues(s: System) -> Issues:
    out = _name_issues(s)
    scope = Scope(s)
    out += _expression_issues(s, scope)
    out += _structure_issues(s, scope)
    out += _value_issues(s, scope)
    return out


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


def _expression_issues(s: System, scope: Scope) -> Issues:
    """Each expression contains only what its field allows."""
    out: Issues = []
    wrong: set[str] = set()

    def check(expr: Any, field: str, where: str) -> None:
        if where in wrong:
            return  # one issue per place: the first thing wrong there
        if not is_expr(expr):
            problem: str | None = not_expr(expr, FIELDS[field][1])
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
        names = [c.name for c in s.coordinates]
        if con.drive is not None and con.drive.coordinate not in (None, *names):
            out.append(
                (
                    f"{where} drive",
                    f"drives `{con.drive.coordinate}`, which is not a coordinate; known: "
                    + ", ".join(names),
                )
            )
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

    once, twice, how = taken[field]
    problem = not_differentiable(expr, once, twice)
    return None if problem is None else f"{problem}; lamech differentiates {how}"


def _no_velocity_issue(s: System) -> tuple[str, str]:
    """T without velocities: every body massless (T from the bodies is 0), or a typo."""

    if s.T == 0 and s.bodies and len(massless(s, s.parameter_values)) == len(s.bodies):
        return (
            "bodies[1] `" + s.bodies[0].name + "` mass",
            "every body is massless, so T = 0 and nothing has inertia; give at least "
            "one body a mass",
        )
    return ("lagrangian.T", "T has no velocity in it; write velocities as x'")


def _unused_issues(s: System) -> Issues:
    """A coordinate declared but in none of T, V, the constraints and the forces (the
    loads' included): nothing gives it inertia or moves it, its row of the KKT system is
    0, and the accelerations cannot be found; said at its declaration's line. One that
    places a body (a massless one: :func:`lamech.model._start.dependent_issues` names
    the body) is used."""
    placed = [e for b in s.bodies for e in (*b.position, b.angle) if e is not None]
    parts = (s.T, s.V, *(c.expr for c in s.constraints), *s.forces, *placed)
    exprs = [e for e in parts if is_expr(e)]
    used: set = set().union(*(e.free_symbols for e in exprs)) if exprs else set()
    return [
        (
            f"coordinates.{c.name}",
            f"coordinate `{c.name}` is declared but appears in neither T, V, a constraint "
            f"nor a force: nothing gives it inertia or moves it, so the accelerations "
            f"cannot be found; remove `{c.name}` from [coordinates], or write it where "
            f"it belongs ({c.name}'^2 in T for a coordinate that moves a mass)",
        )
        for c in s.coordinates
        if c.symbol not in used and c.velocity not in used
    ]


def _structure_issues(s: System, scope: Scope) -> Issues:

    out: Issues = []
    qd = s.qd
    if is_expr(s.T) and (s.T == 0 or not s.T.has(*qd)):
        out.append(_no_velocity_issue(s))
    else:
        out += _unused_issues(s)
    names = [c.name for c in s.constraints]
    bodies = {b.name: b for b in s.bodies}
    for i, c in enumerate(s.constraints):
        where = f"constraints[{i + 1}] `{c.name}`"
        if c.kind == ConstraintKind.VELOCITY and is_expr(c.expr):
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

    i = b.inertia
    if not isinstance(i, tuple) or len(i) != 3:
        return None
    if all(not isinstance(x, tuple) for x in i):
        rows = [[i[k] if k == j else 0 for j in range(3)] for k in range(3)]
        given = "principal moments"
    elif is_matrix3(i):
        rows = [list(r) for r in i]
        given = "inertia tensor"
    else:
        return None
    values = [[at_parameters(x) if is_expr(x) else 0.0 for x in r] for r in rows]
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


def _value_issues(s: System, scope: Scope) -> Issues:
    """Masses and inertias >= 0 (a massless pulley, rod or attachment point is an
    idealisation the KKT system allows when the constraints give its motion to something
    with inertia; when they do not, :func:`_massless_issues` names the coordinate),
    friction coefficients >= 0, restitution in [0, 1], at the parameter values."""

    out: Issues = []
    pv = s.parameter_values
    params = scope.allowed["parameters"]

    def at_parameters(expr: Any) -> float | None:
        if not is_expr(expr) or not expr.free_symbols <= params:
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
    out += _negative_radius_issues(s, at_parameters)
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


def _negative_radius_issues(s: System, at_parameters: Callable[[Any], float | None]) -> Issues:
    """A constraint that holds a polar radius at a negative value: refused, since no
    configuration has it.

    The rule: a coordinate r is a polar radius when T has it as one (r^2 theta'^2:
    :func:`lamech.model._kinematics.polar_radii`), and a holonomic constraint fixes it
    when its f has no other coordinate and no t and is linear in r (``r - (R1 + R2)``,
    ``l - r``, ``(R1 - R2) - r``); the value it fixes, -f(0)/(df/dr) at the parameter
    values, must not be negative. So a trough of radius R1 = 0.5 with the cylinder's
    radius typed as R2 = 10 (centimetres for metres) is refused at the constraint's
    line, rather than a lift-off printed for a cylinder whose centre is 9.5 below the
    trough's. A radius that merely starts negative is not refused: a bead on a rod
    through the axis of a turntable passes r = 0, its r < 0 the rod's other half."""
    coords = set(s.q)
    alone = [
        (i, c, held.pop())
        for i, c in enumerate(s.constraints)
        if c.holonomic and is_expr(c.expr) and not c.expr.has(s.t)
        if len(held := c.expr.free_symbols & coords) == 1
    ]
    radii = polar_radii(s) if alone else {}
    out: Issues = []
    for i, c, r in alone:
        if r not in radii:
            continue
        slope = sp.diff(c.expr, r)
        if slope == 0 or slope.has(r):
            continue
        fixed = sp.cancel(-c.expr.subs(r, 0) / slope)
        v = at_parameters(fixed)
        if v is None or not math.isfinite(v) or v >= 0:
            continue
        angle = radii[r]
        names = sorted(fixed.free_symbols, key=str)
        values = ", ".join(f"{p} = {at_parameters(p):g}" for p in names)
        check = f"the values and units of {values}" if values else "the numbers in f"
        out.append(
            (
                f"constraints[{i + 1}] `{c.name}`",
                f"holds `{r}` at {to_text(fixed)} = {v:g} < 0, but `{r}` is a polar "
                f"radius ({r}^2*{angle}'^2 in T), a distance from the centre, never "
                f"negative: no configuration has it. Check {check} (a length in "
                "centimetres among metres?), or how f is written",
            )
        )
    return out
