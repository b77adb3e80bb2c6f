"""Elimination of constrained coordinates and the closed-form KKT solution.

Elimination rule (the contract): for each holonomic constraint in file order, eliminate
the last-listed coordinate not yet eliminated (and not ``keep``) that the constraint
can be solved for in closed form (here: f is a polynomial of degree 1 or 2 in it);
with two roots, take the branch through the initial state, and skip the coordinate
when the initial state sits on the branch point. Velocity constraints are never used
for elimination.

The closed forms solve the KKT system of :mod:`lamech.derive` with the eliminated
coordinates substituted: unknowns are the independent accelerations and every
multiplier; equations the n Euler-Lagrange equations and the acceleration form of the
constraints not eliminated. Simplification is bounded by expression size
(:data:`CLOSED_FORM_LIMIT`, :data:`SIMPLIFY_OPS`) so large systems never hang.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import sympy as sp

try:  # SymPy >= 1.13 keeps it here, and no longer at the top level
    from sympy.matrices.exceptions import NonInvertibleMatrixError
except ImportError:  # pragma: no cover - SymPy 1.12
    from sympy.matrices.common import NonInvertibleMatrixError

from ..model import Coordinate, System, open_at_start, time_derivative
from ._derive import Dynamics
from ._manifold import manifold_simplifier
from ._student import outer_signs, student

__all__ = [
    "Reduction",
    "eliminate",
    "ClosedForms",
    "closed_forms",
    "tidy",
    "CLOSED_FORM_LIMIT",
    "SIMPLIFY_OPS",
]

CLOSED_FORM_LIMIT = 8
"""Largest number of unknowns (independent accelerations + multipliers) solved symbolically."""
SIMPLIFY_OPS = 300
"""Expressions with more operations than this get only cheap simplification."""
KKT_OPS = 1500
"""Substituted KKT systems larger than this (operations) are not solved symbolically."""
READABLE_OPS = 1500
"""Closed forms larger than this (after simplification) are not reported."""
MAX_OPS = 6000
"""Expressions larger than this are left as they are."""


def tidy(expr: sp.Expr) -> sp.Expr:
    """Simplify within a size budget: full ``simplify`` for small expressions, a cheap
    ``cancel``/``trigsimp`` pass for medium ones, nothing for large ones."""
    expr = sp.sympify(expr)
    if expr.is_Number or expr.is_Symbol:
        return expr
    ops = sp.count_ops(expr)
    if ops > MAX_OPS:
        return expr
    if ops > SIMPLIFY_OPS:
        try:
            return sp.together(sp.expand_trig(expr)) if ops < 2 * SIMPLIFY_OPS else expr
        except (TypeError, ValueError, RecursionError):
            return expr
    try:
        out = sp.simplify(sp.factor_terms(expr))
        trig = sp.trigsimp(out)
        if sp.count_ops(trig) < sp.count_ops(out):
            out = trig
        return student(out if sp.count_ops(out) <= ops else expr)
    except (TypeError, ValueError, RecursionError, NotImplementedError):
        return expr


def present(expr: sp.Expr, velocities: list[sp.Symbol]) -> sp.Expr:
    """Group a result by powers of the velocities with factored coefficients
    (m g cos th - m (R1 + R2) th'^2 rather than m (g cos th - R1 th'^2 - R2 th'^2))."""
    present_v = [v for v in velocities if expr.has(v)]
    if not present_v or sp.count_ops(expr) > SIMPLIFY_OPS:
        return expr
    try:
        grouped = sp.collect(sp.expand(expr), present_v, func=sp.factor)
    except (TypeError, ValueError, sp.PolynomialError):
        return expr
    return outer_signs(grouped if sp.count_ops(grouped) <= sp.count_ops(expr) + 4 else expr)


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


def _solve_closed(f: sp.Expr, x: sp.Symbol) -> list[sp.Expr] | None:
    """Closed-form roots of f = 0 for x when f is a polynomial of degree 1 or 2 in x."""
    try:
        poly = sp.Poly(f, x)
    except (sp.PolynomialError, sp.GeneratorsNeeded):
        return None
    if poly.degree() not in (1, 2) or any(c.has(x) for c in poly.all_coeffs()):
        return None
    coeffs = poly.all_coeffs()
    if poly.degree() == 1:
        a, b = coeffs
        return [sp.expand(-b / a)] if a != 0 else None
    a, b, c = coeffs
    disc = sp.factor_terms(sp.expand(b**2 - 4 * a * c))  # sqrt(4 (l^2 - x^2)) = 2 sqrt(...)
    return [(-b + sp.sqrt(disc)) / (2 * a), (-b - sp.sqrt(disc)) / (2 * a)]


def eliminate(system: System) -> Reduction:
    """Apply the elimination rule of this module's docstring.

    Nothing is eliminated when even a full elimination would leave more unknowns than
    :data:`CLOSED_FORM_LIMIT`: the reduced expressions (nested radicals for a chain in
    maximal coordinates) would cost minutes and be read by no one.
    """
    n, m = len(system.coordinates), len(system.constraints)
    m_hol = sum(1 for c in system.constraints if c.holonomic)
    if n - m_hol + m > CLOSED_FORM_LIMIT:
        note = (
            f"{n} coordinates and {m} constraints: too large for closed forms (at least "
            f"{n - m_hol + m} unknowns; the limit is {CLOSED_FORM_LIMIT}), so no "
            "coordinate was eliminated"
        )
        return Reduction(tuple(system.coordinates), (), {}, (), (note,))
    opened = open_at_start(system)
    env0 = _initial_numeric(system)
    positions: dict[sp.Symbol, sp.Expr] = {}
    order: list[Coordinate] = []
    used: list[str] = []
    notes: list[str] = []
    for con in system.constraints:
        if not con.holonomic:
            continue
        f = con.expr.xreplace(positions) if positions else con.expr
        done = False
        for coord in reversed(system.coordinates):
            if coord.keep or coord.symbol in positions or not f.has(coord.symbol):
                continue
            roots = _solve_closed(f, coord.symbol)
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
                "no closed-form solution for " + ", ".join(free)
                if free
                else "its coordinates are kept or already eliminated"
            )
            notes.append(
                f"constraint `{con.name}` was not used to eliminate a coordinate "
                f"({why}); results keep the full coordinates"
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
    independent = tuple(c for c in system.coordinates if c.symbol not in positions)
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
    independent coordinates, velocities, t and parameters (or ``None`` where skipped)."""

    accelerations: dict  # Symbol (independent acceleration) -> Expr
    multipliers: dict  # constraint name -> Expr
    skipped: str | None = None  # why closed forms were not attempted
    singular: bool = False  # the KKT matrix is singular identically
    manifold: Any = None  # the kept constraints' simplifier (symbolic._manifold)


def closed_forms(dyn: Dynamics, red: Reduction) -> ClosedForms:
    """Solve the substituted KKT system symbolically (bounded; see module docstring)."""
    system = dyn.system
    rest = [j for j, c in enumerate(system.constraints) if c.name not in red.eliminated_constraints]
    unknowns = [c.acceleration for c in red.independent] + system.multipliers
    if len(unknowns) > CLOSED_FORM_LIMIT:
        return ClosedForms(
            {},
            {},
            f"system too large for closed forms ({len(unknowns)} "
            f"unknowns; the limit is {CLOSED_FORM_LIMIT})",
        )
    qdd = sp.Matrix(system.qdd)
    eqs = [red.apply(e) for e in dyn.equations]
    eqs += [red.apply((dyn.A[j, :] * qdd)[0] + dyn.gamma[j]) for j in rest]
    E = sp.Matrix(eqs)
    K = E.jacobian(unknowns)
    rhs = -E.xreplace({u: 0 for u in unknowns})
    size = sum(sp.count_ops(e) for e in list(K) + list(rhs))
    if size > KKT_OPS:
        return ClosedForms(
            {},
            {},
            f"substituted KKT system too large for closed forms "
            f"({size} operations; the limit is {KKT_OPS})",
        )
    kept = [system.constraints[j].expr for j in rest if system.constraints[j].holonomic]
    on_manifold = manifold_simplifier(system, kept)
    K = K.applyfunc(lambda e: _pre(on_manifold.radicals_replaced(e)))
    rhs = rhs.applyfunc(lambda e: _pre(on_manifold.radicals_replaced(e)))
    try:
        sol = _solve_linear(K, rhs)
    except (ValueError, ZeroDivisionError, NonInvertibleMatrixError):
        return ClosedForms(
            {}, {}, "the substituted KKT matrix is singular symbolically", singular=True
        )
    sol = [on_manifold(tidy(s)) for s in sol]
    biggest = max((sp.count_ops(s) for s in sol), default=0)
    if biggest > READABLE_OPS:
        return ClosedForms(
            {},
            {},
            f"closed forms too large to be useful ({biggest} "
            f"operations; the limit is {READABLE_OPS})",
        )
    nacc = len(red.independent)
    acc = {c.acceleration: sol[i] for i, c in enumerate(red.independent)}
    velocities = [c.velocity for c in red.independent]
    lam = {c.name: present(sol[nacc + j], velocities) for j, c in enumerate(system.constraints)}
    return ClosedForms(acc, lam, manifold=on_manifold)


def _pre(e: sp.Expr) -> sp.Expr:
    e = sp.sympify(e)
    return sp.cancel(e) if sp.count_ops(e) < SIMPLIFY_OPS else e


def _solve_linear(K: sp.Matrix, rhs: sp.Matrix) -> list[sp.Expr]:
    """Solve K x = rhs, exploiting block structure: small systems by LU with cancel."""
    n = K.rows
    if n == 0:
        return []
    if n <= 3:
        det = sp.cancel(K.det(method="berkowitz"))
        if det == 0:
            raise NonInvertibleMatrixError("singular")
        adj = K.adjugate(method="berkowitz")
        return list((adj * rhs).applyfunc(lambda e: sp.cancel(e / det)))
    return list(K.LUsolve(rhs).applyfunc(_pre))
