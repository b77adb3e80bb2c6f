"""Coordinates on the constraint manifold: a parametrisation of some coordinates.

A problem in maximal coordinates (the Cartesian double pendulum: x1, y1, x2, y2 with two
rods) reads best in the coordinates a physicist would choose (theta1, theta2). A
:class:`Chart` gives them: new coordinates u and each parametrised coordinate as an
expression of u (and of the parameters, t and the coordinates not parametrised),
``x1 = l1 sin(theta1)``. It must satisfy identically every holonomic constraint whose
coordinates it parametrises (checked at random points, see :func:`chart_issues`); those
constraints are then eliminated by it, and every result (reduced equations, multipliers,
forces, energy shell, where a constraint lets go) is in u. The multipliers are those of
the original constraints: the Euler-Lagrange equations stay those of the original
coordinates, only written in u.

The initial values of u are found from the initial state of the system (nothing to
declare twice): by least squares from a few starts (:func:`chart_initial`), and the
velocities from the chart's Jacobian.

:func:`circle_chart` proposes a chart for the commonest case: a holonomic constraint
that is a circle (or sphere) in two (three) coordinates, |r - c|^2 = R^2 with the centre
c free of them: r = c + R (sin theta, -cos theta), the angle from the downward vertical
(y up; in space z up, theta and the azimuth phi).
"""

from __future__ import annotations

import dataclasses
import math
import random
from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..expr import TimeDerivative, to_text
from ._parts import Coordinate

__all__ = [
    "Chart",
    "chart_issues",
    "chart_initial",
    "circle_chart",
    "ChartProposal",
    "satisfied_by_chart",
    "with_chart",
    "exact_start",
]


@dataclass(frozen=True)
class Chart:
    """New coordinates and the coordinates they parametrise.

    ``coordinates`` are :class:`~lamech.model.Coordinate` objects (their ``initial`` and
    ``initial_velocity`` are filled from the system's initial state when the System is
    made); ``map`` pairs each parametrised coordinate's symbol with its expression.
    ``automatic``: lamech chose it (a circle's angle, so that the closed forms hold on the
    whole circle); results the user reads in coordinates (a linearisation) stay in the
    file's own then.
    """

    coordinates: tuple
    map: tuple[tuple[sp.Symbol, sp.Expr], ...]
    automatic: bool = False  # chosen by lamech (a circle's angle), not by the file

    @property
    def substitution(self) -> dict:
        return dict(self.map)

    @property
    def symbols(self) -> list[sp.Symbol]:
        return [c.symbol for c in self.coordinates]


def _random_points(symbols: list[sp.Symbol], values: dict, count: int, seed: int) -> list[dict]:
    rng = random.Random(seed)
    out = []
    for _ in range(count):
        env = dict(values)
        for s in symbols:
            if s not in env:
                env[s] = rng.uniform(-2.0, 2.0)
        out.append(env)
    return out


def _vanishes(expr: sp.Expr, points: list[dict]) -> tuple[bool, dict | None, complex | None]:
    """Zero at every point (30 digits), or the first point where it is not, with its value."""
    expr = sp.sympify(expr)
    if expr == 0:
        return True, None, None
    for env in points:
        try:
            v = complex(expr.xreplace({k: sp.Float(x, 30) for k, x in env.items()}).evalf(30))
        except (TypeError, ValueError, ZeroDivisionError):
            continue
        if not np.isfinite(v):
            continue
        scale = 1 + max(abs(float(x)) for x in env.values())
        if abs(v) > 1e-18 * scale**4:
            return False, env, v
    return True, None, None


def chart_issues(system) -> list[tuple[str, str]]:
    """Everything wrong with ``system.chart``: names, what the expressions may use, the
    holonomic constraints it must satisfy identically, a rank-deficient Jacobian."""
    chart: Chart | None = system.chart
    if chart is None:
        return []
    out: list[tuple[str, str]] = []
    taken = {p.name for p in system.parameters} | {c.name for c in system.coordinates}
    names = [c.name for c in chart.coordinates]
    for n in names:
        if n in taken or names.count(n) > 1:
            out.append(
                (
                    "parametrisation.coordinates",
                    f"`{n}` is already a parameter, a coordinate or listed twice; new "
                    "coordinates need new names",
                )
            )
    mapped = [s for s, _ in chart.map]
    coords = {c.symbol for c in system.coordinates}
    allowed = (
        set(chart.symbols)
        | {p.symbol for p in system.parameters}
        | {system.t}
        | (coords - set(mapped))
    )
    for s, e in chart.map:
        bad = sorted(str(x) for x in e.free_symbols - allowed)
        if bad:
            out.append(
                (
                    f"parametrisation.{s}",
                    f"uses {', '.join(bad)}: a parametrised coordinate is an expression of the "
                    "new coordinates, the parameters, t and the coordinates not parametrised",
                )
            )
    if out:
        return out
    used = set().union(*(e.free_symbols for _, e in chart.map)) if chart.map else set()
    for c in chart.coordinates:
        if c.symbol not in used:
            out.append(
                (
                    "parametrisation.coordinates",
                    f"new coordinate `{c.name}` is used by no parametrised coordinate",
                )
            )
    if out:
        return out
    sub = chart.substitution
    pv = system.parameter_values
    points = _random_points(sorted(allowed - set(pv), key=str), pv, 3, 17)
    for i, con in enumerate(system.constraints):
        if not con.holonomic or not (con.expr.free_symbols & set(mapped)):
            continue
        if (con.expr.free_symbols & coords) - set(mapped):
            continue  # also in coordinates kept as they are: it stays a constraint
        f = con.expr.xreplace(sub)
        ok, where, val = _vanishes(f, points)
        if not ok and not con.unilateral and where is not None and val is not None:
            at = ", ".join(f"{k} = {float(v):.3g}" for k, v in where.items() if k not in pv)
            out.append(
                (
                    f"parametrisation (constraints[{i + 1}] `{con.name}`)",
                    f"the parametrisation does not satisfy constraint `{con.name}` identically: "
                    f"f = {float(abs(val)):.3g} at {at}; every holonomic constraint on the "
                    "parametrised coordinates must hold for all values of the new coordinates",
                )
            )
    J = sp.Matrix([[sp.diff(e, u) for u in chart.symbols] for _, e in chart.map])
    try:
        ranks = [
            np.linalg.matrix_rank(
                np.array(J.xreplace({k: sp.Float(v) for k, v in env.items()}).evalf(), dtype=float),
                tol=1e-9,
            )
            for env in points
        ]
    except (TypeError, ValueError):
        ranks = []
    if ranks and max(ranks) < len(chart.coordinates):
        out.append(
            (
                "parametrisation",
                f"the new coordinates are not independent (the parametrisation's Jacobian has "
                f"rank {max(ranks)} < {len(chart.coordinates)}): drop one",
            )
        )
    return out


def chart_initial(system, coords_state: dict) -> dict | str:
    """{u: value, u': value} such that the chart reproduces ``coords_state`` (the
    coordinates' and velocities' initial values, floats), or the reason it cannot."""
    chart: Chart = system.chart
    pv = system.parameter_values
    u = chart.symbols
    env = {**pv, system.t: 0.0, **coords_state}
    targets = [(s, coords_state[s]) for s, _ in chart.map]
    exprs = [e.xreplace({k: v for k, v in env.items() if k not in u}) for _, e in chart.map]
    f = sp.lambdify(u, exprs, modules="numpy")
    J = sp.Matrix([[sp.diff(e, x) for x in u] for e in exprs])
    fj = sp.lambdify(u, J, modules="numpy")
    goal = np.array([v for _, v in targets], dtype=float)
    scale = 1 + float(np.abs(goal).max(initial=0.0))
    best = None
    rng = np.random.default_rng(3)
    starts = [np.zeros(len(u))] + [rng.uniform(-np.pi, np.pi, len(u)) for _ in range(12)]
    for x in starts:
        x = np.array(x, dtype=float)
        for _ in range(60):  # Gauss-Newton with a least-squares step
            with np.errstate(all="ignore"):
                r = np.array(f(*x), dtype=float) - goal
                Jx = np.array(fj(*x), dtype=float).reshape(len(exprs), len(u))
            if not np.all(np.isfinite(r)) or not np.all(np.isfinite(Jx)):
                break
            if np.linalg.norm(r) < 1e-14 * scale:
                break
            step, *_ = np.linalg.lstsq(Jx, -r, rcond=None)
            x = x + step
            if np.linalg.norm(step) < 1e-15 * (1 + np.linalg.norm(x)):
                break
        with np.errstate(all="ignore"):
            r = np.array(f(*x), dtype=float) - goal
        err = float(np.linalg.norm(r)) if np.all(np.isfinite(r)) else float("inf")
        if best is None or err < best[0]:
            best = (err, x)
        if err < 1e-12 * scale:
            break
    assert best is not None
    if best[0] > 1e-9 * scale:
        listed = ", ".join(f"{s} = {v:.6g}" for s, v in targets)
        return (
            f"the initial state ({listed}) is not reached by the parametrisation for any "
            "value of the new coordinates"
        )
    x = np.array(
        [
            (v + np.pi) % (2 * np.pi) - np.pi if _periodic(exprs, s) else v
            for s, v in zip(u, best[1])
        ]
    )
    Jx = np.array(fj(*x), dtype=float).reshape(len(exprs), len(u))
    vel_goal = np.array([coords_state.get(_velocity_of(system, s), 0.0) for s, _ in targets])
    # the velocity of a parametrised coordinate also gets terms from t and unparametrised
    # coordinates: subtract them
    rest = []
    for _s, e in chart.map:
        d = sp.diff(e, system.t)
        for c in system.coordinates:
            if e.has(c.symbol):
                d += sp.diff(e, c.symbol) * c.velocity
        rest.append(
            float(
                sp.sympify(d)
                .xreplace({**{k: v for k, v in env.items()}, **dict(zip(u, x))})
                .evalf()
            )
            if d != 0
            else 0.0
        )
    ud, *_ = np.linalg.lstsq(Jx, vel_goal - np.array(rest), rcond=None)
    if np.linalg.norm(Jx @ ud + np.array(rest) - vel_goal) > 1e-8 * (1 + np.abs(vel_goal).max()):
        return "the initial velocities are not tangent to the parametrisation"
    out: dict = {}
    for c, xv, vv in zip(chart.coordinates, x, ud):
        out[c.symbol] = float(xv)
        out[c.velocity] = float(vv)
    return out


def exact_start(system, found: dict) -> dict:
    """The chart's initial values as exact expressions of the parameters where the chart
    gives them: an angle u whose sine and cosine the map states linearly (a circle's
    x = c_x + R sin u, y = c_y - R cos u) is atan2(sin u0, cos u0) at the coordinates'
    exact initial values, and its velocity follows from one map entry's derivative;
    kept only where it equals the numeric value ``found`` (:func:`chart_initial`). A
    start found numerically would put 17-digit integers into every form built on it
    (12500000000000000 cos(psi) - 10969782023629659 for 2 cos(psi) - 2 cos(1/2))."""
    chart = system.chart
    pv = system.parameter_values
    init = {c.symbol: c.initial for c in system.coordinates}
    init.update({c.velocity: c.initial_velocity for c in system.coordinates})
    out: dict = {}
    S, C = sp.Dummy("S"), sp.Dummy("C")
    # an exact start names no parameter the file's start does not (x2 = 1.24 with the
    # chart's l1, l2 would give atan2((31 - 15 l1)/(25 l2), ...): a number reads better)
    mentioned = set().union(*(sp.sympify(e).free_symbols for e in init.values()))
    for coord in chart.coordinates:
        u = coord.symbol
        periodic = _periodic([e for _, e in chart.map], u)
        u0 = next(
            (
                c
                for c in (
                    _turned(c, found[u], pv) if periodic else c
                    for c in _exact_candidates(chart, init, u, S, C, system.t, out)
                )
                if _equals(c, found[u], pv) and c.free_symbols <= mentioned
            ),
            None,
        )
        if u0 is None:
            continue
        out[u] = u0
        # the velocity: d/dt of one map entry that moves with u, x' = dg/du u' (+ the rest)
        for x, e in chart.map:
            du = sp.diff(e, u).xreplace({system.t: 0})  # at the start, t = 0
            rest = time_derivative_free(e, system, u).xreplace({system.t: 0})
            vel = {c.symbol: c.velocity for c in system.coordinates}.get(x)
            if vel is None:
                continue
            slope = du.xreplace({u: u0, **{k: v for k, v in init.items()}})
            if slope == 0 or not sp.simplify(slope).is_nonzero:
                continue
            v0 = sp.simplify((init[vel] - rest.xreplace({u: u0, **init})) / slope)
            try:
                if abs(float(v0.subs(pv)) - found[coord.velocity]) <= 1e-9 * (
                    1 + abs(found[coord.velocity])
                ):
                    out[coord.velocity] = v0
            except (TypeError, ValueError):
                pass
            break
    return out


def _exact_candidates(chart, init: dict, u, S, C, t, known: dict):
    """Exact values of u at the start (t = 0: a chart may turn with t; the chart's
    coordinates already found, ``known``, put in), first to last: from a map entry linear
    in u (the rod's phi = psi: psi0 = phi0), then the angle of its sine and cosine where
    the map states them linearly (a circle; on a sphere, theta from z = -R cos(theta)
    alone, then phi from x and y)."""
    others = set(chart.symbols) - {u} - set(known)
    start_map = [(x, e.xreplace({t: 0, **known})) for x, e in chart.map]
    for x, e in start_map:
        if not e.has(u) or e.free_symbols & others:
            continue
        a = sp.diff(e, u)
        if a != 0 and not a.has(u) and not (a.free_symbols & others):
            yield sp.simplify((init.get(x, x) - e.xreplace({u: 0})) / a)
    rows: list[sp.Eq] = []
    for x, e in start_map:
        if not e.has(u):
            continue
        g = e.xreplace({sp.sin(u): S, sp.cos(u): C})
        if g.has(u):
            return
        if g.free_symbols & others:
            continue  # a row of another angle still unknown (a sphere's x, for theta)
        rows.append(sp.Eq(init.get(x, x), g))
    if not rows:
        return
    try:
        sol = sp.solve(rows, [S, C], dict=True)
    except (NotImplementedError, ValueError, TypeError):
        return
    if len(sol) != 1:
        return
    s0, c0 = (sp.simplify(sol[0][k]) if k in sol[0] else None for k in (S, C))
    if s0 is None and c0 is None:
        return
    yield from _angle_of(s0, c0)
    if s0 is not None and c0 is not None:
        yield sp.atan2(s0, c0)
    elif c0 is not None:
        yield from (sp.acos(c0), -sp.acos(c0))
    else:
        yield from (sp.asin(s0), sp.pi - sp.asin(s0))


def _angle_of(s0: sp.Expr | None, c0: sp.Expr | None):
    """Angles a whose sine is s0 and cosine c0 exactly (None: not stated), read off the
    sines and cosines in them (sin(2/5), -cos(2/5): pi - 2/5, where atan2 gives
    pi - atan(sin(2/5)/cos(2/5))); the caller keeps the one equal to the numeric start."""
    known = [e for e in (s0, c0) if e is not None]
    args = {f.args[0] for e in known for f in e.atoms(sp.sin, sp.cos)}
    for a in sorted(args, key=sp.default_sort_key):
        for u in (a, -a, sp.pi - a, a - sp.pi, a + sp.pi / 2, a - sp.pi / 2, sp.pi / 2 - a):
            if (s0 is None or sp.expand(sp.sin(u) - s0) == 0) and (
                c0 is None or sp.expand(sp.cos(u) - c0) == 0
            ):
                yield u


def _turned(exact: sp.Expr, value: float, pv: dict) -> sp.Expr:
    """``exact`` turned by whole turns to the side of ``value`` (pi for a start found as
    -pi: the same point of a circle), for an angle the map takes through sin and cos only."""
    try:
        k = round((value - float(exact.subs(pv))) / (2 * math.pi))
    except (TypeError, ValueError):
        return exact
    return exact + 2 * k * sp.pi if k else exact


def _equals(exact: sp.Expr, value: float, pv: dict) -> bool:
    try:
        return abs(float(exact.subs(pv)) - value) <= 1e-9 * (1 + abs(value))
    except (TypeError, ValueError):
        return False


def time_derivative_free(e: sp.Expr, system, u: sp.Symbol) -> sp.Expr:
    """The part of d e/dt that does not come from u: from t and the coordinates not
    parametrised (their velocities), for :func:`exact_start`."""
    out = sp.diff(e, system.t)
    for c in system.coordinates:
        if e.has(c.symbol):
            out += sp.diff(e, c.symbol) * c.velocity
    return out


def _periodic(exprs: list[sp.Expr], s: sp.Symbol) -> bool:
    """``s`` enters only through sin and cos: its value is read in (-pi, pi]."""
    trig = (sp.sin, sp.cos)
    for e in exprs:
        stripped = e.replace(lambda a: isinstance(a, trig) and a.has(s), lambda a: sp.Dummy())
        if stripped.has(s):
            return False
    return True


def _velocity_of(system, symbol: sp.Symbol) -> sp.Symbol:
    for c in system.coordinates:
        if c.symbol == symbol:
            return c.velocity
    raise KeyError(symbol)


@dataclass(frozen=True)
class ChartProposal:
    """A proposed chart: for the constraints named, the new coordinates' names and each
    parametrised coordinate's expression (in the new coordinates and the earlier ones)."""

    constraints: tuple[str, ...]
    coordinates: tuple[str, ...]
    map: tuple[tuple[str, sp.Expr], ...]

    def toml(self) -> str:
        lines = [
            "[parametrisation]",
            "coordinates = [" + ", ".join(f'"{n}"' for n in self.coordinates) + "]",
        ]
        lines += [f'{name} = "{to_text(e)}"' for name, e in self.map]
        return "\n".join(lines)


def circle_chart(system, *, unilateral: bool = False, spheres: bool = True) -> ChartProposal | None:
    """Angles for every holonomic constraint that is a circle or sphere in coordinates
    not yet parametrised (see the module docstring), in file order; None if none is.
    ``unilateral``: contacts too (the chart then holds while they do); ``spheres``:
    spheres too (their angles are singular at the poles, a circle's angle nowhere)."""
    if system.chart is not None:
        return None
    coords = {c.symbol: c for c in system.coordinates}
    names = {c.name for c in system.coordinates} | {p.name for p in system.parameters}
    sub: dict = {}
    new: list[str] = []
    used: list[str] = []
    out_map: list[tuple[str, sp.Expr]] = []
    for con in system.constraints:
        if not con.holonomic or (con.unilateral and not unilateral):
            continue
        f = con.expr
        free = [s for s in coords if f.has(s) and s not in sub and not coords[s].keep]
        if len(free) == 3 and not spheres:
            continue
        if len(free) not in (2, 3) or any(
            s not in free for s in f.free_symbols & set(coords) if s not in sub
        ):
            continue
        found = _sphere(f, free)
        if found is None:
            continue
        centre, radius = found
        suffix = _suffix([coords[s].name for s in free]) or con.name
        angle_names = ["theta" + suffix] if len(free) == 2 else ["theta" + suffix, "phi" + suffix]
        angle_names = [n if n not in names else n + "_" for n in angle_names]
        names.update(angle_names)
        th = sp.Symbol(angle_names[0], real=True)
        order = sorted(free, key=lambda s: list(coords).index(s))
        if len(free) == 2:
            x, y = order
            exprs = [centre[x] + radius * sp.sin(th), centre[y] - radius * sp.cos(th)]
        else:
            ph = sp.Symbol(angle_names[1], real=True)
            x, y, z = order
            exprs = [
                centre[x] + radius * sp.sin(th) * sp.cos(ph),
                centre[y] + radius * sp.sin(th) * sp.sin(ph),
                centre[z] - radius * sp.cos(th),
            ]
        exprs = [e.xreplace(sub) for e in exprs]
        for s, e in zip(order, exprs):
            sub[s] = e
            out_map.append((coords[s].name, e))
        new += angle_names
        used.append(con.name)
    if not used:
        return None
    return ChartProposal(tuple(used), tuple(new), tuple(out_map))


def _suffix(names: list[str]) -> str | None:
    """The common trailing digits of x1, y1 (-> "1"), else None."""
    tails = set()
    for n in names:
        digits = ""
        for ch in reversed(n):
            if not ch.isdigit():
                break
            digits = ch + digits
        tails.add(digits)
    (tail,) = tails if len(tails) == 1 else (None,)
    return tail or None


def _sphere(f: sp.Expr, free: list[sp.Symbol]) -> tuple[dict, sp.Expr] | None:
    """(centre, radius) when f = 0 says |r - centre| = radius in ``free``."""
    roots = [a for a in f.atoms(sp.Pow) if a.exp == sp.Rational(1, 2) and a.has(*free)]
    if len(roots) == 1:  # l - sqrt(x^2 + y^2): the polynomial under the root
        (root,) = roots
        w = sp.Dummy("w")
        g = f.xreplace({root: w})
        a, b = sp.diff(g, w), g.xreplace({w: 0})
        if a == 0 or a.has(w) or a.has(*free) or b.has(*free):
            return None
        poly_f = sp.expand(root.base - (b / a) ** 2)
    elif roots:
        return None
    else:
        poly_f = sp.expand(sp.numer(sp.together(f)))
    try:
        p = sp.Poly(poly_f, *free)
    except sp.PolynomialError:
        return None
    if p.total_degree() != 2:
        return None
    lead = p.coeff_monomial(free[0] ** 2)
    if lead == 0:
        return None
    centre = {}
    for i, s in enumerate(free):
        if sp.cancel(p.coeff_monomial(s**2) - lead) != 0:
            return None
        for t in free[i + 1 :]:
            if p.coeff_monomial(s * t) != 0:
                return None
        centre[s] = sp.cancel(-p.coeff_monomial(s) / (2 * lead))
    const = p.coeff_monomial(1) / lead
    r2 = sp.factor(sp.cancel(sum(centre[s] ** 2 for s in free) - const))
    if r2.has(*free):
        return None
    radius = sp.sqrt(r2)
    if not radius.is_positive:
        return None
    return centre, radius


def satisfied_by_chart(system) -> list[str]:
    """The holonomic constraints the chart satisfies identically (in file order): those
    on parametrised coordinates only that vanish at random values of the new ones."""
    chart: Chart | None = system.chart
    if chart is None:
        return []
    mapped = {s for s, _ in chart.map}
    coords = set(system.q)
    pv = system.parameter_values
    free = sorted(set(chart.symbols) | {system.t} | (coords - mapped), key=str)
    points = _random_points(free, pv, 3, 17)
    out = []
    for con in system.constraints:
        syms = con.expr.free_symbols & coords
        if not con.holonomic or not syms or syms - mapped:
            continue
        if _vanishes(con.expr.xreplace(chart.substitution), points)[0]:
            out.append(con.name)
    return out


def with_chart(system, proposal: ChartProposal, automatic: bool = False):
    """``system`` with the proposed chart applied (results then in its angles);
    ``automatic``: lamech's choice, not the user's (:attr:`Chart.automatic`)."""
    new = tuple(
        Coordinate(
            n,
            sp.Symbol(n, real=True),
            _derivative(n + "'"),
            _derivative(n + "''"),
            sp.Integer(0),
            sp.Integer(0),
        )
        for n in proposal.coordinates
    )
    by_name = {c.name: c.symbol for c in system.coordinates}
    symbols = {c.name: c.symbol for c in new}
    pairs = tuple(
        (by_name[name], e.xreplace({sp.Symbol(k, real=True): v for k, v in symbols.items()}))
        for name, e in proposal.map
    )
    return dataclasses.replace(system, chart=Chart(new, pairs, automatic))


def _derivative(name: str) -> sp.Symbol:
    return TimeDerivative(name, real=True)
