"""Small oscillations: equilibria, their stability, and the normal modes.

Built on the closed forms of :func:`~lamech.solve`: with the independent
coordinates u (the others eliminated through the constraints), the motion is
u'' = F(u, u') (t absent: a steadily driven system, such as a hoop spun at a fixed
rate, has its drive eliminated, so its relative equilibria are equilibria here).

* **Equilibria**: F(u, 0) = 0 together with the constraints kept in u, solved by SymPy
  (bounded in size); each solution with the condition for it to exist (the argument of
  an acos within [-1, 1], of a square root >= 0) and the multipliers at rest there. A
  unilateral constraint whose multiplier at rest is negative cannot hold it: such a
  point is listed as no equilibrium of the real system.
* **Checked, on every branch** (:mod:`._rest`, :mod:`._branches`): the reduced
  equations live on a chart (one branch of each root the elimination took, singular
  where it is), so each solution must also pass the KKT test at rest in the file's
  coordinates (q'' = 0), or it is dropped; and equilibria are sought there too, from
  seeded starts on every branch. One only that search finds, one where the reduced
  equations are singular, or where they are too long to differentiate
  (:data:`LINEARISE_OPS`), is linearised in the file's coordinates on the constraints'
  tangent space.
* **Moving constraints** (:mod:`._steady`): where F depends on t, a chart in which it
  does not (the spun hoop's own angle) is looked for; the equilibria there are relative
  ones (``Modes.frame`` says so).
* **Linearisation**: d/dt [du, du'] = J [du, du'], J = [[0, I], [dF/du, dF/du']], on the
  tangent space of the constraints kept in u (an orthonormal basis of the null space of
  their Jacobian, so the coordinates used are regular there whatever the elimination).
* **Modes**: the eigenvalues of J. lambda = +-i omega is an oscillation of angular
  frequency omega, a positive real part a growth rate. Mode shapes are given in every
  coordinate (the eliminated ones through d q / d u). Where J has no velocity block
  (no gyroscopic or damping terms) and at most two degrees of freedom, omega^2 is also
  given in closed form: the eigenvalues of -dF/du (det(K - omega^2 M) = 0 on the
  tangent space).
"""

from __future__ import annotations

import functools
import warnings

import numpy as np
import sympy as sp

from ..expr import to_text
from ..model import System
from ._budget import count_ops
from ._conditions import is_angle
from ._equilibria import Equilibrium, Linear, Mode, Modes
from ._integrals import _coordinate_jacobian
from ._reduce import tidy
from ._rest import Rest, RestTest, rest_test
from ._solution import Solution

__all__ = ["Equilibrium", "Linear", "Mode", "Modes", "check_modes", "modes"]

SOLVE_OPS = 400
"""Equilibrium equations larger than this (operations) are not solved symbolically."""
LINEARISE_OPS = 2000
"""Reduced accelerations and multipliers longer than this (operations, together) are
linearised numerically in the file's coordinates, not differentiated symbolically (the
rod in a bowl's: 20,000, 13 s an equilibrium)."""
SOLVE_UNKNOWNS = 3
"""At most this many independent coordinates are solved for symbolically."""


def modes(problem: Solution | System | str, at: dict[str, float] | None = None) -> Modes:
    """Equilibria, stability and normal modes of a system or its solution (see the
    module docstring; ``problem`` also a file's path or an example's name, as
    :func:`~lamech.solve` takes it). ``at`` ({independent coordinate: value},
    finite numbers) linearises about that configuration at rest instead of searching for
    equilibria (a note says when it is not one)."""
    from ..problem._coerce import as_system
    from ._solution import solve

    if at is not None:
        at = _checked_point(at)
    if not isinstance(problem, Solution):
        problem = solve(as_system(problem, "modes", "problem"))
    sol = problem
    system, red, forms = sol.system, sol.reduction, sol.closed
    u = [c.symbol for c in red.independent]
    names = tuple(c.name for c in red.independent)
    if forms.skipped or not forms.accelerations:
        return Modes(system, names, (), forms.skipped or "no closed-form accelerations")
    ud = [c.velocity for c in red.independent]
    F = [forms.accelerations[c.acceleration] for c in red.independent]
    kept = [
        c.expr
        for c in system.constraints
        if c.holonomic and c.name not in red.eliminated_constraints
    ]
    kept = [red.apply(f) for f in kept]
    if any(f.has(system.t) for f in F) or any(f.has(system.t) for f in kept):
        return _in_a_steady_frame(sol, names, at)
    rest = {v: 0 for v in ud}
    pv = system.parameter_values
    free_note = None
    speeds: dict = {}
    if at is not None:
        allowed = set(names) | {n + "'" for n in names}
        unknown = sorted(set(at) - allowed)
        if unknown:
            raise ValueError(
                f"`at=`: `{unknown[0]}` is not an independent coordinate or its velocity; "
                "these are: " + ", ".join(names)
            )
        missing = [n for n in names if n not in at]
        if missing:
            raise ValueError(
                "`at=` must give every independent coordinate; missing: " + ", ".join(missing)
            )
        speeds = {v: _snapped(float(at[n + "'"])) for v, n in zip(ud, names) if n + "'" in at}
        points = [({s: _snapped(float(at[n])) for s, n in zip(u, names)}, None)]
        reason = None
    else:
        eqs = [sp.numer(sp.together(f)) for f in _forces_at_rest(sol, u, F, rest)] + [
            _polynomial_form(f, system) for f in kept
        ]
        eqs = [e for e in eqs if e != 0]
        # a coordinate no equation holds (the spherical pendulum's azimuth) is free:
        # every value rests; the rest are solved for with it at its initial value
        free = [x for x in u if eqs and not any(e.has(x) for e in eqs)]
        fixed = {x: _initial_of(system, x) for x in free}
        points, reason, free_note = _solve(
            [e.xreplace(fixed) for e in eqs], [x for x in u if x not in fixed], system
        )
        points = [({x: {**p, **fixed}[x] for x in u}, cond) for p, cond in points]
        if free and points:  # (none: a force acts at rest, though not through them)
            shown = ", ".join(f"{x} = {to_text(v)}" for x, v in fixed.items())
            free_note = (
                f"every value of {', '.join(map(str, free))} rests as well "
                f"(no force acts along it at rest); shown at {shown}"
            )
    kkt = rest_test(sol.dynamics)
    out: list[Equilibrium] = []
    for point, condition in points:
        e = _equilibrium(sol, u, ud, F, kept, point, condition, pv, at is not None, speeds, kkt)
        if e is not None:
            out.append(e)
    if at is None and kkt is not None:
        from ._branches import other_branches  # built on this module

        out += other_branches(sol, pv, kkt, out)
    out.sort(key=lambda e: (not e.exists, not e.holds, [e.values.get(n, 0.0) for n in names]))
    return Modes(system, names, tuple(out), reason if not out else None, free_note, _frame(system))


def _frame(system: System) -> str | None:
    """What the equilibria are when the system's chart moves with t (the hoop's angle
    in x = R sin(theta) cos(wt), ...): relative ones; None for a chart that does not."""
    chart = system.chart
    if chart is None or not any(e.has(system.t) for _, e in chart.map):
        return None
    shown = "; ".join(f"{s} = {to_text(e)}" for s, e in chart.map)
    return (
        f"in the chart {shown}, which moves with t and satisfies every constraint on "
        "those coordinates identically, the equations do not depend on t: the equilibria "
        "are relative ones, at rest in that moving frame (steady motions of the file's "
        "coordinates)"
    )


def _in_a_steady_frame(sol: Solution, names: tuple[str, ...], at) -> Modes:
    """The modes of a problem whose reduced equations depend on t, as relative
    equilibria in a chart where they do not (:func:`~._steady.autonomous_chart`: the
    spun hoop's own angle); else no equilibria, with what to do."""
    from ._solution import solve
    from ._steady import autonomous_chart

    system = sol.system
    charted = autonomous_chart(system)
    if charted is not None:
        again = solve(charted)
        forms = again.closed
        t_free = not forms.skipped and not any(
            e.has(system.t) for e in forms.accelerations.values()
        )
        if t_free:
            return modes(again, at)
    return Modes(
        system,
        names,
        (),
        "the reduced equations depend on t explicitly, so nothing rests in these "
        "coordinates, and no chart in the angles of the constraints' circles and spheres "
        "(or along a line turning with t) that satisfies every constraint identically "
        "takes t out. For steady motions "
        "(relative equilibria), give a [parametrisation] in coordinates in which the "
        "problem does not depend on t (a turning frame's angle), or follow the motion "
        "with `lamech simulate`",
    )


def _checked_point(at) -> dict[str, float]:
    """``at`` as {name: float}: a mapping of finite real numbers, else TypeError or
    ValueError naming the entry."""
    import math
    from collections.abc import Mapping

    if not isinstance(at, Mapping):
        raise TypeError(
            f"modes: at must be a dict {{coordinate: value}} (e.g. {{'theta': 0.1}}); "
            f"got {type(at).__name__}"
        )
    out = {}
    for name, value in at.items():
        try:
            x = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"modes: at[{name!r}] must be a real number, got {value!r}") from None
        if not math.isfinite(x):
            raise ValueError(f"modes: at[{name!r}] must be a finite number, got {x}")
        out[str(name)] = x
    return out


def _forces_at_rest(sol, u, F, rest) -> list[sp.Expr]:
    """J^T (h - Q) at rest, J = d q / d u: the generalized forces in u, which separate
    where the accelerations mix them (the double pendulum's sin(th1) = 0, sin(th2) = 0).
    The eliminated constraints' forces drop out (A J = 0); with constraints kept in u
    they would not, so then the accelerations themselves are used; and so they are where
    the elimination moves with t (a turning frame: at rest in it the coordinates
    accelerate, and M q'' carries the centrifugal force J^T (h - Q) leaves out)."""
    red, dyn = sol.reduction, sol.dynamics
    moving = any(e.has(sol.system.t) for e in red.position_substitution.values())
    if len(red.eliminated_constraints) != len(sol.system.constraints) or moving:
        return [f.xreplace(rest) for f in F]
    J = _coordinate_jacobian(sol.system, red)
    h = (dyn.h - dyn.Q).applyfunc(lambda e: red.apply(e).xreplace(rest))
    forces = J.T * h
    if sum(sp.count_ops(e) for e in forces) > SOLVE_OPS:
        return [f.xreplace(rest) for f in F]
    return [tidy(e) for e in forces]


def _solve(eqs, u, system) -> tuple[list, str | None, str | None]:
    """Solutions of eqs = 0 for u, each with its existence condition (bounded); the
    reason when there are none, and what to say of a continuum of them."""
    eqs = [e for e in eqs if e != 0]
    if not eqs:
        return (
            [],
            (
                "every configuration is an equilibrium (no force acts at rest); "
                "give a point with `at=` to linearise about it"
            ),
            None,
        )
    if len(u) > SOLVE_UNKNOWNS or sum(sp.count_ops(e) for e in eqs) > SOLVE_OPS:
        return (*_numeric_equilibria(eqs, u, system), None)  # too large for SymPy: numbers
    found = _separable(eqs, u)
    if found is None:
        if not all(e.is_polynomial(*u) for e in eqs):
            return (*_numeric_equilibria(eqs, u, system), None)
        try:
            found = sp.solve(eqs, u, dict=True)
        except (NotImplementedError, ValueError, TypeError, RecursionError) as exc:
            return [], f"SymPy could not solve the equilibrium equations ({exc})", None
    points = []
    seen: list[np.ndarray] = []
    free_names: list[str] = []
    for sol in found:
        if set(sol) != set(u):
            sol, free = _on_the_continuum(sol, u, system)
            if sol is None:
                continue  # a complex family (x = I*y): no real continuum
            free_names += [n for n in free if n not in free_names]
        point = {x: _principal(tidy(sol[x]), x, system) for x in u}
        key = _numeric_point(point, system, u)
        if key is not None and any(np.allclose(key, s, atol=1e-9) for s in seen):
            continue
        if key is not None:
            seen.append(key)
        points.append((point, _condition(point)))
    if free_names and not points:
        return (
            [],
            (
                "a continuum of equilibria (free: " + ", ".join(free_names) + "); give a point "
                "with `at=`"
            ),
            None,
        )
    free_note = (
        f"a continuum of equilibria: every value of {', '.join(free_names)} rests as well "
        "(the others following); shown at its initial value"
        if free_names
        else None
    )
    return points, None if points else "the equilibrium equations have no solution", free_note


def _on_the_continuum(sol: dict, u, system: System) -> tuple[dict | None, list[str]]:
    """A solution family of the equations at rest that leaves some unknowns free (a cart
    that rests anywhere, with the pendulum's bob above it: xb = s), taken at the free
    ones' initial values; None when it is not real there (the cone's x = +-I*y, whose
    only real point is the apex): a complex family is no continuum of equilibria."""
    free = [x for x in u if x not in sol]
    fixed = {x: _initial_of(system, x) for x in free}
    point = {x: sp.sympify(sol[x]).xreplace(fixed) if x in sol else fixed[x] for x in u}
    # real at the start's values and at others nearby (x = I*y is real at y = 0 only)
    moved = {x: v + sp.Rational(3, 7) * (1 + i) for i, (x, v) in enumerate(fixed.items())}
    for at in (fixed, moved):
        value = _numeric_point({x: sp.sympify(sol.get(x, x)).xreplace(at) for x in u}, system, u)
        if value is None or np.abs(value.imag).max(initial=0) > 1e-12 * (1 + np.abs(value).max()):
            return None, []
    return point, [str(x) for x in free]


def _polynomial_form(f: sp.Expr, system: System) -> sp.Expr:
    """A kept constraint as a polynomial where it fixes a square root
    (l1 - sqrt(x1^2 + y1^2): x1^2 + y1^2 - l1^2), else its numerator."""
    from ._manifold import _radical_rule

    rule = _radical_rule(f, set(system.q))
    if rule is not None:
        P, s = rule
        return sp.expand(P - s**2)
    return sp.numer(sp.together(f))


def _separable(eqs, u) -> list[dict] | None:
    """Solutions of equations that each hold one unknown (solved one by one, then
    combined), or None when they couple the unknowns."""
    by: dict = {x: [] for x in u}
    for e in eqs:
        inside = e.free_symbols & set(u)
        if len(inside) != 1:
            return None
        by[next(iter(inside))].append(e)
    if any(not v for v in by.values()):
        return None
    choices = []
    for x in u:
        try:
            sets = [set(sp.solve(e, x)) for e in by[x]]
        except (NotImplementedError, ValueError, TypeError, RecursionError):
            return None
        common = set.intersection(*sets)
        choices.append([(x, v) for v in common])
    import itertools

    return [dict(combo) for combo in itertools.product(*choices)]


def _numeric_equilibria(eqs, u, system) -> tuple[list, str | None]:
    """Roots of the equations at the parameter values from a grid of starts (angles at
    multiples of pi/2, other coordinates at their initial values and their negatives):
    numbers, no conditions. For equations too large or in too many unknowns for SymPy,
    and for those it cannot solve."""
    import itertools

    from scipy.optimize import least_squares

    pv = system.parameter_values
    f = sp.lambdify([u], [e.xreplace(pv) for e in eqs], modules="numpy")
    init = {c.symbol: float(sp.N(c.initial.xreplace(pv))) for c in system.coordinates}
    axes = [
        [-np.pi / 2, 0.0, np.pi / 2, np.pi]
        if is_angle(system, x)
        else sorted({init.get(x, 0.0), -init.get(x, 0.0)})  # both sides of the origin
        for x in u
    ]
    starts = list(itertools.product(*axes))[:256] + [tuple(init.get(x, 0.0) for x in u)]
    found: list[np.ndarray] = []
    for x0 in starts:
        # the generated function is NaN off the real manifold (a square root of a
        # negative number): read as "not here", never printed
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            try:
                r = least_squares(
                    lambda x: np.asarray(f(x), dtype=float),
                    x0,
                    xtol=1e-14,
                    ftol=1e-14,
                    gtol=1e-14,
                )
                res = np.abs(np.asarray(f(r.x), dtype=float))
            except (ValueError, TypeError, ZeroDivisionError):
                continue
        if not np.all(res <= 1e-9):
            continue
        x = np.array(r.x, dtype=float)
        for i, sym in enumerate(u):
            if is_angle(system, sym):
                x[i] = (x[i] + np.pi) % (2 * np.pi) - np.pi
                if abs(x[i] + np.pi) < 1e-9:
                    x[i] = np.pi
        if not any(np.allclose(x, y, atol=1e-7) for y in found):
            found.append(x)
    points = [({sym: _snapped(v) for sym, v in zip(u, x)}, None) for x in found]
    reason = (
        None
        if points
        else "no equilibrium found numerically (from a grid of starting points); "
        "give a point with `at=`"
    )
    return points, reason


def _initial_of(system: System, x: sp.Symbol) -> sp.Expr:
    """The initial value of coordinate ``x``, a file's or a chart's (the sphere's
    azimuth), exact where it is given so."""
    return sp.nsimplify(
        next(c.initial for c in system.coordinates + system.chart_coordinates if c.symbol == x)
    )


def _snapped(v: float) -> sp.Expr:
    """A root found numerically, as the simple number it is to 1e-10 (0, -1, pi/2,
    2/3), else as a 12-digit float: the output reads y1 = -1, not -0.99999999999998."""
    if abs(v) < 1e-12:
        return sp.Integer(0)
    try:
        simple = sp.nsimplify(v, [sp.pi], tolerance=1e-10, rational=False)
    except (ValueError, TypeError):  # pragma: no cover - nsimplify's own failures
        simple = None
    if (
        simple is not None
        and sp.count_ops(-simple if v < 0 else simple) <= 4  # -3*sqrt(21)/20 as +: a sign
        and abs(float(simple) - v) <= 1e-10 * (1 + abs(v))
    ):
        return simple
    return sp.Float(v, 12)


def _principal(value: sp.Expr, x: sp.Symbol, system: System) -> sp.Expr:
    """An angle in (-pi, pi] (2 pi - acos(a) is -acos(a)); other coordinates as they are."""
    if not _is_angle(system, x):
        return value
    try:
        v = float(sp.N(value.xreplace(system.parameter_values)))
    except (TypeError, ValueError):
        return value
    turns = int(np.floor((v + np.pi) / (2 * np.pi) - 1e-12))
    return sp.expand(value - 2 * sp.pi * turns) if turns else value


def _is_angle(system: System, x: sp.Symbol) -> bool:
    """An angle of the file's L, or a chart's coordinate that its map takes only
    through sin and cos (the hoop's theta)."""
    from ..model._chart import _periodic

    if is_angle(system, x):
        return True
    if system.chart is None or x not in system.chart.symbols:
        return False
    return _periodic([e for _, e in system.chart.map], x)


def _numeric_point(point: dict, system: System, order) -> np.ndarray | None:
    """The values of ``point`` {coordinate symbol: value} at the parameter values, in the
    order of the symbols ``order`` (by name, never by the dict's order: a free
    coordinate is added to a solved point last)."""
    try:
        vals = [
            complex(sp.N(sp.sympify(sp.sympify(point[x]).xreplace(system.parameter_values))))
            for x in order
        ]
    except (TypeError, ValueError):
        return None
    return np.array(vals)


def _condition(point: dict) -> str | None:
    """Where a solution exists: acos/asin arguments in [-1, 1], square roots of >= 0."""
    parts = []
    for v in point.values():
        for f in v.atoms(sp.acos, sp.asin):
            a = f.args[0]
            if a.is_positive:
                parts.append(f"{to_text(a)} <= 1")
            elif a.is_negative:
                parts.append(f"{to_text(-a)} <= 1")
            else:
                parts.append(f"-1 <= {to_text(a)} <= 1")
        for p in v.atoms(sp.Pow):
            if p.exp.is_Rational and p.exp.q == 2 and p.base.free_symbols:
                parts.append(f"{to_text(p.base)} >= 0")
    return " and ".join(dict.fromkeys(parts)) or None


def _equilibrium(
    sol, u, ud, F, kept, point, condition, pv, given, speeds=None, rest: RestTest | None = None
) -> Equilibrium | None:
    """The equilibrium at ``point`` (or, with ``speeds``, the steady motion: the state
    with those velocities, a fixed point when the accelerations vanish there); None for
    a point found (not ``given``) that fails the KKT test in the file's coordinates
    (:meth:`~._rest.RestTest.check`: the reduced equations' chart is singular there, or
    the point is no solution at all)."""
    system, red, forms = sol.system, sol.reduction, sol.closed
    speeds = speeds or {}
    at_point = {**point, **{v: speeds.get(v, 0) for v in ud}}
    num = {**pv, system.t: 0.0}
    uval = _numeric_point(point, system, u)
    if uval is None or np.abs(uval.imag).max(initial=0) > 1e-9 * (1 + np.abs(uval).max()):
        return Equilibrium(
            {str(x): v for x, v in point.items()},
            {},
            condition,
            exists=False,
            note="not real at the parameter values",
        )
    uval = uval.real
    env = {**num, **dict(zip(u, uval)), **{v: _real(speeds.get(v, 0), num) for v in ud}}
    # a chart's own coordinates first (the hoop's angle), then every file coordinate
    values = {str(x): float(env[x]) for x in u if x not in set(system.q)}
    try:
        for c in system.coordinates:
            expr = red.position_substitution.get(c.symbol, c.symbol)
            values[c.name] = _real(expr, env)
    except (TypeError, ValueError):  # an eliminated coordinate is not real there
        if not given:
            return None
        raise ValueError(
            "`at=`: the eliminated coordinates are not real at "
            + ", ".join(f"{x} = {v:.6g}" for x, v in zip(u, uval))
        ) from None
    for v, x in zip(ud, u):
        if v in speeds:
            values[f"{x}'"] = env[v]
    from ._branches import full_equilibrium  # built on this module

    verdict = _kkt_test(sol, rest, env, u, ud, speeds) if rest is not None else None
    if verdict is not None and not verdict.ok and not given:
        return None  # not an equilibrium of the equations as written
    if (
        rest is not None
        and verdict is not None
        and verdict.ok
        and not verdict.singular
        and not given
        and _reduced_size(sol) > LINEARISE_OPS
    ):
        q = np.array([values[c.name] for c in system.coordinates])
        why = (
            "the reduced equations are too long to linearise symbolically: linearised in "
            "the file's coordinates, every constraint kept"
        )
        return full_equilibrium(sol, rest, q, verdict.multipliers, condition, point, why)
    notes = []
    try:
        residual = [_real(f, env) for f in F]
    except (TypeError, ValueError):
        residual = None  # the reduced equations are singular here (0/0)
    if residual is None or not all(map(np.isfinite, residual)):
        if rest is not None and verdict is not None and not verdict.singular and not speeds:
            q = np.array([values[c.name] for c in sol.system.coordinates])
            why = (
                "the reduced equations are singular here: linearised in the file's "
                "coordinates, every constraint kept"
            )
            return full_equilibrium(sol, rest, q, verdict.multipliers, condition, point, why)
        return Equilibrium(
            {str(x): v for x, v in point.items()},
            values,
            condition,
            note="the reduced equations are singular here (their coordinates are)",
        )
    resting = max(map(abs, residual), default=0.0) <= 1e-9
    if given and not resting:
        notes.append(
            ("not a steady state: there" if speeds else "not an equilibrium: at rest there")
            + " the accelerations are "
            + ", ".join(f"{x}'' = {r:.6g}" for x, r in zip(u, residual))
        )
    lam = {}
    for c in system.constraints:
        expr = forms.multipliers.get(c.name)
        if expr is None:
            continue
        try:
            lam[c.name] = _real(expr, env)
        except (TypeError, ValueError):
            continue
    lam, holds = _holding(system, lam, notes)
    stability, found, linear = _linearise(sol, u, ud, F, kept, at_point, env, point)
    if stability is None and rest is not None and verdict is not None and verdict.ok:
        if not verdict.singular and not speeds and resting:
            # a chart's pole (the sphere's angles at its top): the file's coordinates are
            # regular there, so linearise in them
            q = np.array([values[c.name] for c in sol.system.coordinates])
            why = (
                "these coordinates are singular here: linearised in the file's "
                "coordinates, every constraint kept"
            )
            return full_equilibrium(sol, rest, q, verdict.multipliers, condition, point, why)
    check = None
    if (
        resting and not speeds
    ):  # at an equilibrium: the same frequencies from the unreduced equations
        check = _tangent_check(sol, values, lam, found)
        if check is not None and check.startswith("DISAGREES"):
            notes.append(check)
            check = None
    return Equilibrium(
        {**{str(x): v for x, v in point.items()}, **{str(v): w for v, w in speeds.items()}},
        values,
        condition,
        True,
        lam,
        holds,
        "; ".join(notes) or None,
        stability,
        found,
        linear,
        check,
    )


def _reduced_size(sol) -> int:
    """The length (operations) of the reduced accelerations and multipliers."""
    forms = sol.closed
    return sum(count_ops(e) for e in (*forms.accelerations.values(), *forms.multipliers.values()))


def _holding(system, lam: dict, notes: list) -> tuple[dict, bool]:
    """The multipliers with rounding zeros made 0, and whether every unilateral
    constraint can hold the point (a note in ``notes`` for each that cannot)."""
    holds = True
    for c in system.constraints:
        if c.name in lam and c.unilateral and lam[c.name] < -1e-12:
            holds = False
            notes.append(
                f"`{c.name}` cannot hold it (lambda_{c.name} = {lam[c.name]:.6g} < 0 at rest: "
                "it would have to pull)"
            )
    big = max(map(abs, lam.values()), default=0.0)
    return {k: (0.0 if abs(v) <= 1e-12 * big else v) for k, v in lam.items()}, holds


def _kkt_test(sol, rest: RestTest, env: dict, u, ud, speeds) -> Rest | None:
    """The KKT test (:meth:`~._rest.RestTest.check`) of the state the point stands
    for: every coordinate, velocity and acceleration from the reduction with the
    independent coordinates at ``env``, their velocities ``speeds`` (0 at rest) and
    their accelerations 0; None where the reduction cannot be evaluated there."""
    system, red = sol.system, sol.reduction
    full = {**env, system.t: 0.0, **{c.acceleration: 0.0 for c in red.independent}}
    state = []
    try:
        for c in system.coordinates:
            for sym in (c.symbol, c.velocity, c.acceleration):
                e = red.substitution.get(sym, sym)
                state.append(_real(e, full) if e not in full else float(full[e]))
    except (TypeError, ValueError, KeyError):
        return None
    q, qd, qdd = (np.array(state[i::3]) for i in range(3))
    moving = bool(np.any(qd) or np.any(qdd))
    return rest.check(q, qd, 0.0, qdd if moving else None)


@functools.lru_cache(maxsize=256)
def _diff(expr: sp.Expr, x: sp.Symbol) -> sp.Expr:
    """d expr / d x, kept for the next equilibrium of the same system (the rod in a
    bowl's reduced equations take seconds to differentiate)."""
    return sp.diff(expr, x)


def _jacobian(exprs: tuple, symbols: tuple) -> sp.Matrix:
    """The Jacobian of ``exprs`` in ``symbols`` (entries by :func:`_diff`)."""
    return sp.Matrix([[_diff(e, x) for x in symbols] for e in exprs])


def _real(expr, env) -> float:
    """``expr`` at the numbers ``env`` (a real number, or TypeError)."""
    return float(sp.N(sp.sympify(sp.sympify(expr).xreplace(env))))


def _null_basis(G: np.ndarray, n: int) -> np.ndarray:
    """Orthonormal basis (n, k) of the null space of G (rows: constraints)."""
    if G.size == 0:
        return np.eye(n)
    _, s, vt = np.linalg.svd(G)
    rank = int((s > 1e-10 * max(1.0, s.max(initial=0.0))).sum())
    return vt[rank:].T


def _linearise(sol, u, ud, F, kept, at_point, env, point):
    """Stability, modes and the named linear system about a point at rest.

    The state (du, du') is restricted to the tangent space of the kept holonomic
    constraints (du = N z, du' = N w) and then to the linearised velocity constraints
    (Gq du + Gv du' = 0: a non-holonomic system has fewer velocities than positions),
    as SymPy's ``Linearizer`` does; the eigenvalues are those of J on that subspace."""
    system, red = sol.system, sol.reduction
    k = len(u)
    Fu = _jacobian(tuple(F), tuple(u))
    Fv = _jacobian(tuple(F), tuple(ud))
    velocity = [
        red.apply(c.expr)
        for c in system.constraints
        if not c.holonomic and c.name not in red.eliminated_constraints
    ]

    def num(M: sp.Matrix) -> np.ndarray:
        return np.array(M.xreplace(env).evalf(), dtype=float).reshape(M.shape)

    try:
        A21, A22 = num(Fu), num(Fv)
        G = num(_jacobian(tuple(kept), tuple(u))) if kept else np.zeros((0, k))
        g = sp.Matrix(velocity)
        Gq = num(g.jacobian(u)) if velocity else np.zeros((0, k))
        Gv = num(g.jacobian(ud)) if velocity else np.zeros((0, k))
        Xq = num(_coordinate_jacobian(system, red))  # d q_all / d u
    except (TypeError, ValueError):
        return None, (), None
    if not (np.isfinite(A21).all() and np.isfinite(A22).all()):
        return None, (), None
    N = _null_basis(G, k)  # tangent directions of the kept constraints, in u
    d = N.shape[1]
    if _singular_coordinates(sol, env, Xq @ N):
        return None, (), None
    Jz = np.block([[np.zeros((d, d)), np.eye(d)], [N.T @ A21 @ N, N.T @ A22 @ N]])
    P = _null_basis(np.hstack([Gq @ N, Gv @ N]), 2 * d)  # the velocity constraints
    w, V = np.linalg.eig(P.T @ Jz @ P)
    Y = P @ V  # eigenvectors in (z, w)
    Xq = Xq @ N  # d q_all / d z: the shapes in every coordinate
    squared = _closed_squares(Fu, Fv, at_point, kept, k) if not velocity else []
    # a chart's own coordinates (the hoop's angle) lead the shapes: at a relative
    # equilibrium the file's coordinates move, so theirs hold at t = 0 only
    # (not lamech's own chart, a circle's angle: the shapes in the file's coordinates)
    names = [c.name for c in system.coordinates]
    own = system.chart is not None and system.chart.automatic
    chart = [] if own else [i for i, x in enumerate(u) if str(x) not in names]
    shapes = np.vstack([N[chart], Xq]) if chart else Xq
    stability, out = _spectrum([str(u[i]) for i in chart] + names, w, Y, shapes, d, squared, env)
    linear = _named(sol, u, ud, env, Jz, N, Xq, Gq @ N, Gv @ N)
    return stability, out, linear


def _spectrum(names, w, Y, Xq, d, squared, env) -> tuple[str, tuple[Mode, ...]]:
    """The stability and the modes of the eigenvalues ``w`` with eigenvectors ``Y``
    (columns, in (z, z')) of a linear system whose positions are z, d of them, seen in
    the coordinates ``names`` through ``Xq`` (len(names), d); ``squared``: closed forms
    of omega^2 to name the frequencies with."""
    # zero to this tolerance: a defective zero eigenvalue (the rolling disc's free
    # drift, a Jordan block) comes out of LAPACK as about sqrt(machine epsilon)
    tol = 1e-6 * max(1.0, float(np.abs(w).max(initial=0.0)))
    out = []
    for i in np.argsort(-w.real * 1e6 + np.abs(w.imag)):
        lam = complex(w[i])
        if lam.imag < -tol:
            continue  # one of each conjugate pair
        if abs(lam.imag) <= tol and lam.real < -tol and np.abs(w + lam).min() <= tol:
            continue  # the decaying partner of a growing mode (a damped one is kept)
        shape = Xq @ Y[:d, i]
        big = shape[np.argmax(np.abs(shape))] if shape.size else 1.0
        shape = shape / big if abs(big) > 1e-12 else shape
        phases = None
        if np.abs(shape.imag).max(initial=0.0) > 1e-9:  # gyroscopic: out of phase
            phases = {
                name: float(round(np.degrees(np.angle(x)), 9)) + 0.0
                for name, x in zip(names, shape)
                if abs(x) > 1e-12
            }
            shape = np.abs(shape)
        shape = shape.real
        freq = lam.imag if lam.imag > tol else None
        growth = lam.real if lam.real > tol else None
        sq = _match_square(squared, lam, env)
        out.append(
            Mode(
                lam,
                freq,
                growth,
                {name: float(round(x, 12)) + 0.0 for name, x in zip(names, shape)},
                sq,
                phases,
            )
        )
    if any(m.growth for m in out):
        stability = "unstable"
    elif all(abs(complex(x).real) <= tol for x in w) and all(abs(x) > tol for x in w):
        stability = "stable"
    elif all(complex(x).real < -tol for x in w):
        stability = "stable"
    else:
        stability = "marginal"
    return stability, tuple(out)


def check_modes(solution: Solution, equilibrium: Equilibrium, modes=None) -> str | None:
    """Check ``modes`` (default: the equilibrium's own) against det(K - omega^2 M) = 0 on
    the tangent space, from the unreduced Euler-Lagrange equations; a sentence, starting
    "DISAGREES" when they do not match, or None where the check does not apply."""
    found = equilibrium.modes if modes is None else tuple(modes)
    return _tangent_check(solution, equilibrium.values, equilibrium.multipliers, found)


def _tangent_check(sol, values, lam, found) -> str | None:
    """The physical check: omega^2 from det(K - omega^2 M) = 0 on the tangent space of
    all the constraints, in all the coordinates (the Euler-Lagrange equations before any
    elimination: K = d/dq (h - Q - A^T lambda_0) at rest, M the mass matrix), against the
    modes found from the reduced equations. Only where it applies: scleronomic holonomic
    constraints and no velocity terms at rest (no gyroscopic coupling or damping)."""
    from scipy.linalg import eig

    system, dyn = sol.system, sol.dynamics
    t = system.t
    if not found or any(not c.holonomic or c.expr.has(t) for c in system.constraints):
        return None
    if any(c.name not in lam for c in system.constraints):
        return None
    q, qd = list(system.q), list(system.qd)
    env = {
        **system.parameter_values,
        **{c.symbol: values[c.name] for c in system.coordinates},
        **{v: 0.0 for v in qd},
        **{c.multiplier: lam[c.name] for c in system.constraints},
    }
    lam_vec = sp.Matrix([c.multiplier for c in system.constraints])
    R = dyn.h - dyn.Q - (dyn.A.T * lam_vec if system.constraints else sp.zeros(len(q), 1))
    if R.has(t):
        return None

    def num(M: sp.Matrix) -> np.ndarray:
        return np.array(M.xreplace(env).evalf(), dtype=float).reshape(M.shape)

    try:
        if np.abs(num(R.jacobian(qd))).max(initial=0.0) > 1e-12:
            return None
        K, M = num(R.jacobian(q)), num(dyn.M)
        N = _null_basis(num(dyn.A) if system.constraints else np.zeros((0, len(q))), len(q))
    except (TypeError, ValueError):
        return None
    w2 = eig(N.T @ K @ N, N.T @ M @ N, right=False)
    w2 = w2[np.isfinite(w2)]
    mine = np.array([-(m.eigenvalue**2) for m in found])
    scale = max(1.0, float(np.abs(w2).max(initial=0.0)), float(np.abs(mine).max(initial=0.0)))
    worst = max(
        [float(np.abs(mine - x).min(initial=np.inf)) for x in w2]
        + [float(np.abs(w2 - x).min(initial=np.inf)) for x in mine],
        default=0.0,
    )
    if worst > 1e-6 * scale:
        return (
            "DISAGREES: det(K - omega^2 M) = 0 on the tangent space gives omega^2 = "
            + ", ".join(f"{complex(x).real:.6g}" for x in sorted(w2, key=lambda z: z.real))
            + " (please report this)"
        )
    return (
        f"omega^2 from det(K - omega^2 M) = 0 on the tangent space agrees (to {worst / scale:.0e})"
    )


def _singular_coordinates(sol, env, X) -> bool:
    """Whether the coordinates are singular at the point (the pole of spherical
    coordinates): the mass matrix seen through d q / d z loses rank there while the mass
    matrix of all the coordinates does not (a massless pulley's is singular everywhere)."""
    try:
        M = np.array(
            sol.dynamics.M.applyfunc(sol.reduction.apply).xreplace(env).evalf(), dtype=float
        )
    except (TypeError, ValueError):
        return False
    if not np.isfinite(M).all() or X.shape[1] == 0:
        return False

    def rank(A: np.ndarray) -> int:
        sv = np.linalg.svd(A, compute_uv=False)
        return int((sv > 1e-9 * max(1.0, sv.max(initial=0.0))).sum())

    return rank(X.T @ M @ X) < min(X.shape[1], rank(M))


def _pick(X: np.ndarray) -> list[int]:
    """The rows of X (n, d) that make the best-conditioned d x d block (pivoted QR on
    X^T), in their original order: the coordinates regular at the point."""
    from scipy.linalg import qr

    if X.shape[1] == 0:
        return []
    _, _, piv = qr(X.T, pivoting=True)
    return sorted(int(i) for i in piv[: X.shape[1]])


def _named(sol, u, ud, env, Jz, N, Xq, GqN, GvN) -> Linear | None:
    """The linear system in coordinates regular at the point: d of the coordinates for
    the positions (picked from d q / d z: the Cartesian pendulum hanging gives x, never
    y), and for a non-holonomic system as many velocities as the velocity constraints
    leave free; with the multipliers' first-order change over that state."""
    system = sol.system
    names = [c.name for c in system.coordinates]
    d = N.shape[1]
    if GqN.size and np.abs(GqN).max() > 1e-10:
        return None  # velocity constraints that tie positions to velocities: no split
    Nw = _null_basis(GvN, d)
    chosen = system.chart is not None and not system.chart.automatic
    if chosen and not all(str(x) in names for x in u):
        # the file's chart (the hoop's angle): the linear system in its coordinates, the
        # file's coordinates moving at a relative equilibrium
        names, Xq = [str(x) for x in u], N
    # the independent coordinates, if regular; lamech's own chart (a circle's angle):
    # the file's coordinates regular at the point (the Cartesian pendulum's x)
    own = [names.index(str(x)) for x in u if str(x) in names]
    S = own if len(own) == d and np.linalg.cond(Xq[own]) < 1e8 else _pick(Xq)
    own_v = own if len(own) == Nw.shape[1] and len(own) else []
    W = own_v if own_v and np.linalg.cond((Xq @ Nw)[own_v]) < 1e8 else _pick(Xq @ Nw)
    Tp, Tv = Xq[S], (Xq @ Nw)[W]
    if (Tp.size and np.linalg.cond(Tp) > 1e10) or (Tv.size and np.linalg.cond(Tv) > 1e10):
        return None
    Tp_inv = np.linalg.inv(Tp)
    Tv_inv = np.linalg.inv(Tv) if Tv.size else np.zeros((0, 0))
    dv = Nw.shape[1]
    L = np.block([[Tp, np.zeros((d, d))], [np.zeros((dv, d)), Tv @ Nw.T]])
    M = np.block([[Tp_inv, np.zeros((d, dv))], [np.zeros((d, d)), Nw @ Tv_inv]])
    A = L @ Jz @ M
    lam = {}
    for c in system.constraints:
        expr = sol.closed.multipliers.get(c.name)
        if expr is None:
            continue
        try:
            du = [_real(_diff(expr, x), env) for x in u]
            dv_ = [_real(_diff(expr, v), env) for v in ud]
        except (TypeError, ValueError):
            continue
        row = np.concatenate([np.array(du) @ N @ Tp_inv, np.array(dv_) @ N @ Nw @ Tv_inv])
        lam[c.name] = tuple(float(round(x, 12)) for x in row)
    state = tuple(names[i] for i in S) + tuple(names[i] + "'" for i in W)
    return Linear(state, tuple(tuple(float(round(x, 12)) for x in r) for r in A), lam)


def _closed_squares(Fu, Fv, at_point, kept, k) -> list[sp.Expr]:
    """omega^2 in closed form: eigenvalues of -dF/du when there is no velocity block and
    no kept constraint (at most two degrees of freedom)."""
    if kept or k > 2:
        return []
    if any(tidy(e.xreplace(at_point)) != 0 for e in Fv):
        return []
    K = (-Fu).xreplace(at_point).applyfunc(tidy)
    try:
        return [tidy(e) for e in K.eigenvals(multiple=True)]
    except (NotImplementedError, ValueError, TypeError):
        return []


def _match_square(squared, lam: complex, env) -> sp.Expr | None:
    """The closed-form omega^2 (lambda^2 = -omega^2) equal to this eigenvalue's."""
    target = -(lam**2)
    for s in squared:
        try:
            v = complex(sp.N(sp.sympify(s.xreplace(env))))
        except (TypeError, ValueError):
            continue
        if abs(v - target) <= 1e-8 * (1 + abs(target)):
            return s
    return None
