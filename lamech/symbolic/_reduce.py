"""Elimination of constrained coordinates and the closed-form KKT solution.

Elimination rule (the contract): for each holonomic constraint in file order, eliminate
the last-listed coordinate not yet eliminated (and not ``keep``) that the constraint
can be solved for in closed form by a function on the whole constraint
(:func:`_solve_closed`: f linear in it with a constant coefficient, or quadratic with
roots whose square root is constant along the motion; never one sign of a square root
of the coordinates, which is a chart of half the constraint, nor a division by what can
vanish); with two roots, take the one through the initial state, and skip the
coordinate when the initial state sits on the point where they meet. Velocity
constraints are never used for elimination. A circle is solved in its angle before
this rule runs (:func:`lamech.symbolic._solution.in_circle_angles`).

The closed forms solve the KKT system of :mod:`lamech.symbolic._derive` with the eliminated
coordinates substituted: unknowns are the independent accelerations and every
multiplier; equations the n Euler-Lagrange equations and the acceleration form of the
constraints not eliminated. Simplification is bounded by expression size
(:data:`CLOSED_FORM_LIMIT`, :data:`SIMPLIFY_OPS`) so large systems never hang.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp

try:  # SymPy >= 1.13 keeps it here, and no longer at the top level
    from sympy.matrices.exceptions import NonInvertibleMatrixError
except ImportError:  # pragma: no cover - SymPy 1.12
    from sympy.matrices.common import NonInvertibleMatrixError

from ..expr import to_text
from ..model import Coordinate, System
from ..model._chart import satisfied_by_chart
from ..model._checks import open_at_start
from ..model._kinematics import time_derivative
from ._budget import count_ops
from ._derive import Dynamics
from ._manifold import manifold_simplifier
from ._normal import is_zero, normal, solve_linear
from ._student import outer_signs, student
from ._work import OverBudget, labelled

__all__ = [
    "Reduction",
    "eliminate",
    "ClosedForms",
    "closed_forms",
    "tidy",
    "CLOSED_FORM_LIMIT",
    "SIMPLIFY_OPS",
    "READABLE_OPS",
]

CLOSED_FORM_LIMIT = 8
"""Largest number of unknowns (independent accelerations + multipliers) solved symbolically."""
SIMPLIFY_OPS = 300
"""Expressions with more operations than this get only cheap simplification."""
KKT_OPS = 1500
"""Substituted KKT systems larger than this (operations) are solved without
simplification on the way (:func:`_solve_bounded`)."""
READABLE_OPS = 1500
"""Closed forms larger than this (after simplification) are delivered, not printed."""
MAX_OPS = 6000
"""Expressions larger than this are left as they are."""
ELIMINATION_OPS = 100_000
"""The most operations the entries of an elimination (:func:`_solve_bounded`) may add up
to before it gives up: closed forms past it would be read by no one, and the count,
unlike a clock, gives the same answer on every machine."""


class _TooLarge(Exception):
    """The elimination's entries passed :data:`ELIMINATION_OPS`."""


def tidy(
    expr: sp.Expr, velocities: tuple = (), angles: tuple = (), upto: int = READABLE_OPS
) -> sp.Expr:
    """The shortest readable form of ``expr`` (:func:`._normal.normal`: a normal form
    modulo sin^2 + cos^2 = 1, cancelled, factored where short; in chains also written in
    the differences of consecutive ``angles``), then a student's last touches
    (:func:`._student.student`). Bounded by counted work: past the solve's budget or
    :data:`MAX_OPS`, ``expr`` as it is; past ``upto`` operations too (a polynomial
    normal form may go up to :data:`MAX_OPS`: its conversion is cheap)."""
    expr = sp.sympify(expr)
    if expr.is_Number or expr.is_Symbol:
        return expr
    if count_ops(expr) > upto:
        return expr
    out = normal(expr, velocities=tuple(velocities), angles=tuple(angles))
    return student(_grouped(out, tuple(velocities)))


def present(expr: sp.Expr, velocities: list[sp.Symbol]) -> sp.Expr:
    """Group a result by powers of the velocities with factored coefficients
    (m g cos th - m (R1 + R2) th'^2 rather than m (g cos th - R1 th'^2 - R2 th'^2)),
    where that is no longer (:func:`._normal.normal`)."""
    present_v = tuple(v for v in velocities if expr.has(v))
    if not present_v or count_ops(expr) > SIMPLIFY_OPS:
        return expr
    return outer_signs(_grouped(normal(expr, velocities=present_v), present_v))


def _grouped(out: sp.Expr, velocities: tuple) -> sp.Expr:
    """``out`` grouped by the powers of the velocities, each coefficient factored (the
    energy as m l^2 th'^2/2 - m g l cos th, a force as m g cos th - m (R1 + R2) th'^2),
    where that costs at most 4 more operations: a textbook groups so. Only short results
    (:data:`GROUP_OPS`); the velocities are the symbols written x' when not given."""
    if not velocities:
        velocities = tuple(sorted((s for s in out.free_symbols if s.name.endswith("'")), key=str))
    if not velocities or count_ops(out) > GROUP_OPS:
        return out
    try:
        grouped = sp.collect(sp.expand(out), list(velocities), func=sp.factor)
    except (TypeError, ValueError, sp.PolynomialError):
        return out
    return grouped if count_ops(grouped) <= count_ops(out) + 4 else out


GROUP_OPS = 60
"""Results up to this size are grouped by the velocities' powers (:func:`present`)."""


@dataclass(frozen=True)
class Reduction:
    """Which coordinates remain, and how the eliminated ones depend on them.

    ``substitution`` maps every eliminated coordinate, velocity and acceleration to an
    expression of the independent ones (and t); ``eliminated_constraints`` are the
    constraints satisfied identically by it.
    """

    independent: tuple[Coordinate, ...]
    eliminated: tuple[tuple[Coordinate, sp.Expr], ...]
    substitution: dict
    eliminated_constraints: tuple[str, ...]
    notes: tuple[str, ...]

    @property
    def position_substitution(self) -> dict:
        return {c.symbol: e for c, e in self.eliminated}

    def apply(self, expr: sp.Expr) -> sp.Expr:
        return sp.sympify(expr).xreplace(self.substitution) if self.substitution else expr


def _initial_numeric(system: System) -> dict:
    pv = system.parameter_values
    env = {s: float(sp.sympify(e).subs(pv)) for s, e in system.initial_state.items()}
    return {**pv, **env, system.t: 0.0}


def _solve_closed(f: sp.Expr, x: sp.Symbol, moving: set) -> tuple[list[sp.Expr] | None, str | None]:
    """Closed-form roots of f = 0 for x when f is a polynomial of degree 1 or 2 in x,
    and each root is a function on the whole constraint: (roots, None); else (None,
    why not, or None when f is no such polynomial).

    ``moving`` are the symbols that change along the motion (the coordinates and t). A
    root that divides by an expression of them (y = x tan(w t) from y cos(w t) = x
    sin(w t)) is singular where that expression vanishes; a root that takes one sign of
    a square root of them (y = +sqrt(l^2 - x^2)) is a chart of half the constraint,
    which the motion may leave. Neither is used: the results then keep the coordinate
    and hold on the whole constraint (reduced modulo it, :mod:`._manifold`). Two roots
    whose square root is free of ``moving`` (r = +-l) are two separate pieces of the
    constraint, and the motion stays on the one it starts on."""
    try:
        poly = sp.Poly(f, x)
    except (sp.PolynomialError, sp.GeneratorsNeeded):
        return None, None
    if poly.degree() not in (1, 2) or any(c.has(x) for c in poly.all_coeffs()):
        return None, None
    coeffs = poly.all_coeffs()
    a = coeffs[0]
    if a == 0:
        return None, None
    if a.free_symbols & moving:
        return None, f"solving it for {x} divides by {to_text(student(a))}, which can vanish"
    if poly.degree() == 1:
        return [sp.expand(-coeffs[1] / a)], None
    _, b, c = coeffs
    disc = sp.factor_terms(sp.expand(b**2 - 4 * a * c))  # sqrt(4 (l^2 - x^2)) = 2 sqrt(...)
    root = sp.sqrt(disc)
    if any(
        e.exp.q != 1 and e.base.free_symbols & moving
        for e in root.atoms(sp.Pow)
        if e.exp.is_Rational
    ):
        return None, (
            f"solving it for {x} takes one sign of a square root, {x} = "
            f"{to_text(student((-b + root) / (2 * a)))} or the other, which holds on "
            "part of it only"
        )
    return [(-b + root) / (2 * a), (-b - root) / (2 * a)], None


def eliminate(system: System) -> Reduction:
    """Apply the elimination rule of this module's docstring, whatever the size of the
    system: each elimination is linear (or by a root constant along the motion), cheap
    and short, so none is refused by a count; the closed forms that follow are bounded
    by the work budget."""
    opened = open_at_start(system)
    env0 = _initial_numeric(system)
    positions: dict[sp.Symbol, sp.Expr] = {}
    order: list[Coordinate] = []
    used: list[str] = []
    notes: list[str] = []
    if system.chart is not None:  # the file's parametrisation comes first
        positions = dict(system.chart.substitution)
        order = [c for c in system.coordinates if c.symbol in positions]
        used = satisfied_by_chart(system)
    moving = set(system.q) | {system.t}
    for con in system.constraints:
        if not con.holonomic or con.name in used:
            continue
        f = con.expr.xreplace(positions) if positions else con.expr
        done = False
        refused: list[str] = []
        for coord in reversed(system.coordinates):
            if coord.keep or coord.symbol in positions or not f.has(coord.symbol):
                continue
            roots, why_not = _solve_closed(f, coord.symbol, moving)
            if why_not:
                refused.append(why_not)
            if not roots:
                continue
            x0 = env0[coord.symbol]
            good = []
            for r in roots:
                try:
                    val = complex(r.subs(env0).evalf())
                except (TypeError, ValueError):
                    continue
                if abs(val.imag) < 1e-12 and abs(val.real - x0) <= 1e-8 * (1 + abs(x0)):
                    good.append(r)
            if con.name in opened:
                # Off the contact at the start: no branch passes through the initial
                # state; a single root is still the contact's, two are ambiguous.
                good = roots if len(roots) == 1 else []
                if not good:
                    notes.append(
                        f"constraint `{con.name}` is open at the start, so the "
                        f"branch of its solution for `{coord.name}` is unknown; "
                        f"kept `{coord.name}`"
                    )
                    continue
            elif len(good) != 1 or (len(roots) == 2 and _same(roots, env0)):
                notes.append(
                    f"constraint `{con.name}`: the initial state sits on a branch "
                    f"point of its solution for `{coord.name}`; kept `{coord.name}`"
                )
                continue
            sol = good[0]
            positions = {k: v.xreplace({coord.symbol: sol}) for k, v in positions.items()}
            positions[coord.symbol] = sol
            order.append(coord)
            used.append(con.name)
            done = True
            break
        if not done:
            free = [
                c.name
                for c in system.coordinates
                if f.has(c.symbol) and not c.keep and c.symbol not in positions
            ]
            why = (
                refused[0]
                if refused
                else "no closed-form solution for " + ", ".join(free)
                if free
                else "its coordinates are kept or already eliminated"
            )
            notes.append(
                f"constraint `{con.name}` was not used to eliminate a coordinate "
                f"({why}); results keep the full coordinates"
                + (" and hold wherever the constraint does" if refused else "")
            )
    substitution: dict = {}
    eliminated = []
    for coord in order:
        expr = positions[coord.symbol]
        vel = time_derivative(expr, system)
        acc = time_derivative(vel, system)
        substitution[coord.symbol] = expr
        substitution[coord.velocity] = vel
        substitution[coord.acceleration] = acc
        eliminated.append((coord, student(expr)))  # shown; the same function
    independent = system.chart_coordinates + tuple(
        c for c in system.coordinates if c.symbol not in positions
    )
    return Reduction(independent, tuple(eliminated), substitution, tuple(used), tuple(notes))


def _same(roots: list[sp.Expr], env: dict) -> bool:
    try:
        a, b = (complex(r.subs(env).evalf()) for r in roots)
    except (TypeError, ValueError):
        return False
    return abs(a - b) <= 1e-9 * (1 + abs(a))


@dataclass(frozen=True)
class ClosedForms:
    """q'' of the independent coordinates and every multiplier, as functions of the
    independent coordinates, velocities, t and parameters.

    Every one is delivered whatever its size; ``sizes`` gives the operation count of
    each multiplier (by name) and acceleration (by symbol) longer than
    :data:`READABLE_OPS`: reports summarise those instead of printing them. ``skipped``
    says why there are none at all.
    """

    accelerations: dict  # Symbol (independent acceleration) -> Expr
    multipliers: dict  # constraint name -> Expr
    skipped: str | None = None  # why closed forms were not attempted
    singular: bool = False  # the KKT matrix is singular identically
    manifold: Any = None  # the kept constraints' simplifier (symbolic._manifold)
    sizes: dict = field(default_factory=dict)  # name or Symbol -> operations, when long

    def is_long(self, key: Any) -> bool:
        """Whether the closed form of ``key`` (a multiplier's name or an acceleration
        symbol) is longer than :data:`READABLE_OPS`: delivered, not printed."""
        return key in self.sizes

    @property
    def readable_multipliers(self) -> dict:
        """The multipliers short enough to print and to analyse further (energy shell,
        where they vanish)."""
        return {k: v for k, v in self.multipliers.items() if k not in self.sizes}


def closed_forms(dyn: Dynamics, red: Reduction) -> ClosedForms:
    """Solve the substituted KKT system symbolically (bounded; see module docstring).

    Small systems (at most :data:`CLOSED_FORM_LIMIT` unknowns and :data:`KKT_OPS`
    operations) are solved with simplification on the way; larger ones by elimination
    pivoted at a generic numeric point, simplified only where short, so every multiplier
    is delivered, raw where the work budget (:func:`._work.work_budget`) runs out: the
    multipliers are tidied first, then the accelerations.
    """
    system = dyn.system
    rest = [j for j, c in enumerate(system.constraints) if c.name not in red.eliminated_constraints]
    unknowns = [c.acceleration for c in red.independent] + system.multipliers
    qdd = sp.Matrix(system.qdd)
    eqs = [red.apply(e) for e in dyn.equations]
    eqs += [red.apply((dyn.A[j, :] * qdd)[0] + dyn.gamma[j]) for j in rest]
    E = sp.Matrix(eqs)
    K = E.jacobian(unknowns)
    rhs = -E.xreplace({u: 0 for u in unknowns})
    kept = [system.constraints[j].expr for j in rest if system.constraints[j].holonomic]
    on_manifold = manifold_simplifier(system, kept)
    small = len(unknowns) <= CLOSED_FORM_LIMIT and (
        sum(count_ops(e) for e in list(K) + list(rhs)) <= KKT_OPS
    )
    try:
        projected = None
        if (
            not rest
            and red.eliminated
            and len(unknowns) <= CLOSED_FORM_LIMIT
            and not any(_has_radical(e) for _, e in red.eliminated)
            and len(angles_of(system, red)) >= 2
        ):
            projected = _solve_projected(dyn, red)
        if projected is not None:
            lams = _multipliers_projected(system, eqs, red, projected)
            if lams is not None:
                return _closed(system, red, projected + lams, on_manifold)
        if (
            not red.eliminated
            and system.chart is None
            and on_manifold.relations
            and len(unknowns) <= CLOSED_FORM_LIMIT
        ):
            schur = _solve_schur(dyn, red, on_manifold)
            if schur is not None:
                return _closed(system, red, schur, on_manifold)
        if small:
            K = K.applyfunc(on_manifold.radicals_replaced)
            rhs = rhs.applyfunc(on_manifold.radicals_replaced)
        probe = _probe(system, red, K.free_symbols | rhs.free_symbols)
        upto = READABLE_OPS
        try:
            sol = solve_linear(K, rhs, probe)  # in the polynomial ring: fast, exact
            # normal forms already, written in the arguments' base angles (q1, q1 + q2):
            # worth writing anew up to MAX_OPS (a relative-angle double pendulum's
            # q1'' is 3,858 operations in q1, q1 + q2 and 80 in q1, q2)
            upto = MAX_OPS
        except OverBudget:
            if len(unknowns) > CLOSED_FORM_LIMIT:
                return ClosedForms(
                    {},
                    {},
                    f"{len(unknowns)} unknowns: closed forms past the bounds of the "
                    "normal forms (a larger budget may reach them)",
                )
            sol = _solve_bounded(K, rhs, probe)  # beyond the ring's bounds: as SymPy does
    except (ValueError, ZeroDivisionError, NonInvertibleMatrixError):
        return ClosedForms(
            {}, {}, "the substituted KKT matrix is singular symbolically", singular=True
        )
    except _TooLarge as large:
        return ClosedForms({}, {}, str(large))
    nacc = len(red.independent)
    angles = angles_of(system, red)
    out = list(sol)
    # the multipliers first: they are what a solve is for
    for i in list(range(nacc, len(sol))) + list(range(nacc)):
        if projected is not None and i < nacc:
            out[i] = projected[i]
            continue
        with labelled("multipliers" if i >= nacc else "reduced equations"):
            out[i] = on_manifold(_tidy_angles(sol[i], angles, upto))
    return _closed(system, red, out, on_manifold)


def _closed(system: System, red: Reduction, out: list, on_manifold: Any) -> ClosedForms:
    """The :class:`ClosedForms` of the solution ``out`` (independent accelerations, then
    the multipliers in constraint order), long ones measured."""
    nacc = len(red.independent)
    velocities = [c.velocity for c in red.independent]
    acc = {c.acceleration: out[i] for i, c in enumerate(red.independent)}
    lam = {}
    sizes: dict = {}
    for j, c in enumerate(system.constraints):
        expr = out[nacc + j]
        ops = count_ops(expr)
        if ops > READABLE_OPS:
            sizes[c.name] = ops
            lam[c.name] = expr
        else:
            lam[c.name] = present(expr, velocities)
    for key, expr in acc.items():
        ops = count_ops(expr)
        if ops > READABLE_OPS:
            sizes[key] = ops
    return ClosedForms(acc, lam, manifold=on_manifold, sizes=sizes)


def spatial_angles(system: System) -> set:
    """The symbols in the turns or orientation of a body in space: Euler angles turn
    about different axes, so their differences mean nothing, and writing a form in them
    only costs (a rolling sphere's equations: 0.5 s)."""
    out: set = set()
    for b in system.bodies:
        if b.rotation is not None:
            for _, angle in b.rotation:
                out |= sp.sympify(angle).free_symbols
        if b.orientation is not None:
            for row in b.orientation:
                for e in row:
                    out |= sp.sympify(e).free_symbols
    return out


def angles_of(system: System, red: Reduction) -> list[sp.Symbol]:
    """The independent coordinates that enter the reduced Lagrangian only through sin and
    cos (angles), in order, but for the turns of bodies in space
    (:func:`spatial_angles`)."""
    Lr = red.apply(system.L)
    trig = (sp.sin, sp.cos, sp.tan)
    out = []
    spatial = spatial_angles(system)
    for c in red.independent:
        x = c.symbol
        if not Lr.has(x) or x in spatial:
            continue
        stripped = Lr.replace(lambda e, x=x: isinstance(e, trig) and e.has(x), lambda e: sp.Dummy())
        if not stripped.has(x):
            out.append(x)
    return out


def _solve_projected(dyn: Dynamics, red: Reduction) -> list[sp.Expr]:
    """The accelerations when every constraint is eliminated (by the rule or a chart) and
    two or more angles remain (a chain: elsewhere the whole KKT solve reads as well), by
    projection: with q = q(u), q'' = J u'' + b, and A J = 0 identically, J^T times the
    Euler-Lagrange equations has no multiplier: (J^T M J) u'' = -J^T (M b + h - Q), the
    reduced mass matrix being the textbook one once its few short entries are
    simplified. Each step is small and simplified on its own, so the accelerations come
    out in textbook form (the double pendulum's m1 + m2 sin^2(theta1 - theta2) below)
    where solving the whole KKT system leaves sin^2 + cos^2 unsimplified. Returns the
    accelerations only: the multipliers come from the whole system, shorter there."""
    system = dyn.system
    u = [c.symbol for c in red.independent]
    udd = [c.acceleration for c in red.independent]
    zero = {a: 0 for a in udd}
    J = sp.Matrix(
        [[sp.diff(red.position_substitution.get(q, q), x) for x in u] for q in system.q]
    ).applyfunc(tidy)
    qdd = sp.Matrix([red.apply(a) for a in system.qdd])
    b = qdd.xreplace(zero)
    M = dyn.M.applyfunc(red.apply)
    rest = (dyn.h - dyn.Q).applyfunc(red.apply)
    Mr = (J.T * M * J).applyfunc(tidy)
    fr = (J.T * (M * b + rest)).applyfunc(tidy)
    angles = angles_of(system, red)
    return [_tidy_angles(e, angles) for e in _solve_linear(Mr, -fr)]


def _multipliers_projected(
    system: System, eqs: list, red: Reduction, acc: list[sp.Expr]
) -> list[sp.Expr] | None:
    """The multipliers from the Euler-Lagrange equations with the projected (already
    tidy) accelerations substituted: linear in the multipliers alone, so as many
    equations as multipliers suffice, the shortest whose coefficients are regular at a
    generic point (the polar double pendulum's r-equations, where each multiplier stands
    alone). Each comes out short, where the multipliers of the whole KKT solve, the same
    functions, are long expressions whose cancelling costs seconds. None when no such
    equations are found."""
    lam = list(system.multipliers)
    if not lam:
        return []
    sub = {c.acceleration: a for c, a in zip(red.independent, acc)}
    rows = []
    for e in eqs[: len(system.q)]:
        coeffs = [sp.diff(e, x) for x in lam]
        rest = e.xreplace({x: 0 for x in lam}).xreplace(sub)
        rows.append((sum(count_ops(c) for c in coeffs) + count_ops(rest), coeffs, rest))
    rows.sort(key=lambda r: r[0])
    probe = _probe(system, red, set().union(*(sp.Matrix(r[1]).free_symbols for r in rows)))
    chosen: list = []
    for row in rows:
        trial = chosen + [row]
        values = [[complex(c.xreplace(probe).evalf()) for c in r[1]] for r in trial]
        if np.linalg.matrix_rank(np.array(values), tol=1e-9) == len(trial):
            chosen = trial
        if len(chosen) == len(lam):
            break
    else:
        return None
    K = sp.Matrix([r[1] for r in chosen])
    rhs = sp.Matrix([-r[2] for r in chosen])
    angles = angles_of(system, red)
    return [_tidy_angles(_pre(x), angles) for x in _solve_linear(K, rhs)]


def _solve_schur(dyn: Dynamics, red: Reduction, on_manifold: Any) -> list[sp.Expr] | None:
    """The accelerations and multipliers when every constraint is kept, as a physicist
    solves them: q'' = M^-1 (A^T lambda + Q - h) into A q'' + gamma = 0 gives
    (A M^-1 A^T) lambda = -gamma - A M^-1 (Q - h). Each entry of A M^-1 A^T and of the
    right-hand side is a short expression, reduced modulo the constraints
    (:mod:`._manifold`: x^2 + y^2 + z^2 -> R^2, y cos(w t) - x sin(w t) -> 0) before the
    small system is solved, so the multipliers come out in the user's coordinates,
    short and valid on the whole constraint (the spinning hoop's lambda_plane =
    2 m w (x' cos(w t) + y' sin(w t)), its Coriolis force), where solving the whole KKT
    system first leaves forms of thousands of operations that no reduction reaches.
    None when a step runs out of work."""
    system = dyn.system
    M, A = dyn.M, dyn.A
    n, m = M.rows, A.rows
    rest = dyn.Q - dyn.h
    columns = [sp.Matrix(A[j, :]).T for j in range(m)] + [rest]
    probe = _probe(system, red, M.free_symbols | A.free_symbols | rest.free_symbols)
    try:
        solved = [solve_linear(M, col, probe) for col in columns]
        X = [[on_manifold(e) for e in col] for col in solved[:m]]  # M^-1 A^T, by column
        y = [on_manifold(e) for e in solved[m]]  # M^-1 (Q - h)
        S = sp.Matrix(m, m, lambda i, j: on_manifold(sum(A[i, k] * X[j][k] for k in range(n))))
        b = sp.Matrix(
            [on_manifold(-dyn.gamma[i] - sum(A[i, k] * y[k] for k in range(n))) for i in range(m)]
        )
        probe_s = _probe(system, red, S.free_symbols | b.free_symbols)
        lam = [on_manifold(e) for e in solve_linear(S, b, probe_s)]
    except (OverBudget, ZeroDivisionError):
        return None
    acc = [on_manifold(y[k] + sum(X[j][k] * lam[j] for j in range(m))) for k in range(n)]
    return acc + lam


def _has_radical(expr: sp.Expr) -> bool:
    """A fractional power in ``expr`` (an eliminated y = -sqrt(l^2 - x^2)): cancelling
    with those costs minutes, so such reductions are solved as one KKT system."""
    return any(not p.exp.is_Integer for p in sp.sympify(expr).atoms(sp.Pow))


def _tidy_angles(expr: sp.Expr, angles: list[sp.Symbol], upto: int = READABLE_OPS) -> sp.Expr:
    """:func:`tidy`, also trying the differences of consecutive ``angles`` (a chain's
    m1 + m2 sin^2(theta1 - theta2))."""
    return tidy(expr, angles=tuple(angles), upto=upto)


def _probe(system: System, red: Reduction, symbols: set) -> dict:
    """A generic numeric point near the initial state (parameters at their values,
    coordinates and velocities shifted by seeded random amounts), complex so that a
    square root off the manifold stays defined: pivots are chosen there."""
    rng = random.Random(7)
    env: dict = {}
    pv = system.parameter_values
    start = _initial_numeric(system)
    for s in sorted(symbols, key=str):  # the same point in every process (hash seed)
        if s in pv:
            env[s] = complex(pv[s])
        elif s in start and s != system.t:
            env[s] = complex(start[s]) + 0.05 * (1 + rng.random())
        else:
            env[s] = complex(0.3 + 0.4 * rng.random())
    return _onto_kept(system, red, env)


def _onto_kept(system: System, red: Reduction, env: dict) -> dict:
    """``env`` with its coordinates moved onto the holonomic constraints the reduction
    kept (a few Newton steps, least squares, in complex numbers), so that no pivot chosen
    there vanishes where the constraints hold: pivoting off them on x sin(wt) - y cos(wt)
    gave forms that are 0/0 on the turning plane. ``env`` itself where there are none or
    Newton does not converge."""
    import numpy as np

    kept = [
        red.apply(c.expr)
        for c in system.constraints
        if c.holonomic and c.name not in red.eliminated_constraints
    ]
    xs = [
        q
        for q in sorted(env, key=str)
        if q in set(system.q) or q in {c.symbol for c in red.independent}
    ]
    kept = [f for f in kept if f.free_symbols & set(xs)]
    if not kept or not xs:
        return env
    others = {**system.parameter_values, system.t: 0.3}
    others.update({k: v for k, v in env.items() if k not in xs})
    kept = [f.xreplace(others) for f in kept]
    if any(f.free_symbols - set(xs) for f in kept):
        return env  # (a velocity constraint's symbols: not a point to move)
    try:
        F = sp.lambdify([xs], [f.xreplace(others) for f in kept], modules="numpy")
        J = sp.lambdify([xs], sp.Matrix(kept).jacobian(xs).xreplace(others), modules="numpy")
        x = np.array([env[q] for q in xs], dtype=complex)
        with np.errstate(all="ignore"):
            for _ in range(30):
                r = np.asarray(F(x), dtype=complex).reshape(-1)
                if not np.all(np.isfinite(r)):
                    return env
                if np.abs(r).max() < 1e-13 * (1 + np.abs(x).max()):
                    return {**env, **dict(zip(xs, (complex(v) for v in x)))}
                step = np.linalg.lstsq(
                    np.asarray(J(x), dtype=complex).reshape(len(kept), len(xs)), -r, rcond=None
                )[0]
                x = x + step
    except (TypeError, ValueError, ZeroDivisionError, np.linalg.LinAlgError):
        return env
    return env


def _solve_bounded(K: sp.Matrix, rhs: sp.Matrix, probe: dict) -> list[sp.Expr]:
    """Gauss-Jordan elimination of K x = rhs with the pivots chosen by partial pivoting
    on K evaluated at ``probe`` (a generic point): a symbolic pivot that is zero
    identically (sin^2 + cos^2 - 1 in disguise) is never chosen, and no zero test on
    large expressions is needed. Entries are brought to normal form while short (its work
    counted against the budget); SymPy's ``LUsolve``, which
    ``LagrangesMethod.solve_multipliers`` uses, does the same elimination."""
    n = K.rows
    rows = [list(K.row(i)) + [rhs[i]] for i in range(n)]
    symbols = sorted(probe, key=str)
    values = [probe[s] for s in symbols]
    f = sp.lambdify(symbols, [list(r) for r in rows], modules=["numpy", "sympy"])
    with np.errstate(all="ignore"):
        N = np.array(f(*values), dtype=complex)
    if not np.all(np.isfinite(N)):
        raise ValueError("the KKT system is not finite at the probe point")
    scale = max(1.0, float(np.abs(N[:, :n]).max()))
    spent = 0
    for col in range(n):
        piv = col + int(np.argmax(np.abs(N[col:, col])))
        if abs(N[piv, col]) <= 1e-10 * scale:
            raise NonInvertibleMatrixError("singular at a generic point")
        if piv != col:
            rows[col], rows[piv] = rows[piv], rows[col]
            N[[col, piv]] = N[[piv, col]]
        p = rows[col][col]
        for r in range(n):
            if r == col or rows[r][col] == 0:
                continue
            factor = rows[r][col] / p
            rows[r] = [
                rows[r][j]
                if rows[col][j] == 0 or j == col
                else _pre(rows[r][j] - factor * rows[col][j])
                for j in range(n + 1)
            ]
            rows[r][col] = sp.Integer(0)
            spent += sum(count_ops(e) for e in rows[r]) if n > CLOSED_FORM_LIMIT else 0
            if spent > ELIMINATION_OPS:
                raise _TooLarge(
                    f"closed forms not attempted past {ELIMINATION_OPS} operations of "
                    f"elimination (eliminated {col} of {n} unknowns)"
                )
            N[r] -= N[r, col] / N[col, col] * N[col]
    return [_pre(rows[i][n] / rows[i][i]) for i in range(n)]


def _pre(e: sp.Expr) -> sp.Expr:
    """The normal form (:func:`._normal.normal`) while short and free of nested radicals
    (cancelling over nested square roots, a chain eliminated in Cartesian coordinates,
    swells); bounded by counted work."""
    e = sp.sympify(e)
    if e.is_Atom or count_ops(e) >= SIMPLIFY_OPS or _nested_radical(e):
        return e
    return normal(e, pretty=False)


def _nested_radical(e: sp.Expr) -> bool:
    roots = [p for p in e.atoms(sp.Pow) if not p.exp.is_Integer]
    return len({p.base for p in roots}) > 1


def _solve_linear(K: sp.Matrix, rhs: sp.Matrix) -> list[sp.Expr]:
    """Solve K x = rhs, exploiting block structure: small systems by LU with cancel."""
    n = K.rows
    if n == 0:
        return []
    if n <= 3:
        det = K.det(method="berkowitz")
        if is_zero(det):
            raise NonInvertibleMatrixError("singular")
        det = _pre(det)
        adj = K.adjugate(method="berkowitz")
        return list((adj * rhs).applyfunc(lambda e: _pre(e / det)))
    return list(K.LUsolve(rhs).applyfunc(_pre))
