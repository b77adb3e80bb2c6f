"""Derivation to the multipliers, fast: every lambda in closed form, untidied.

The like-for-like of SymPy's ``LagrangesMethod.form_lagranges_equations()`` +
``solve_multipliers()``: from the system's Lagrangian and constraints to the
Euler-Lagrange equations with multipliers (:func:`~lamech.symbolic.dynamics`), then to
each multiplier as one expression of the coordinates, velocities, t and parameters,
with every constraint taken as holding. No elimination, no simplification: the
expressions are correct at any state, of any size, and as long as the algebra makes
them (:func:`~lamech.solve` gives the tidy ones, on the constraint manifold).

The KKT system is solved by its structure, not as one (n + m) x (n + m) matrix. From
M q'' + h - A^T lambda - Q = 0 and A q'' + gamma = 0,

.. math::

    S\\,\\lambda = A M^{-1} (h - Q) - \\gamma, \\qquad S = A M^{-1} A^T,

with M^{-1} applied by a symbolic LDL^T factorisation of the symmetric mass matrix
(its pivots are the diagonal's, positive for a positive definite M, so no zero test
and no pivot that vanishes at some state, as a pivot chosen on a constraint row can:
the four-bar's A has cos(theta1) = 0 at its start) and the small m x m system S by the
same factorisation. Where M is singular (a massless coordinate) but the KKT matrix is
not, M + A^T A is positive definite and the same steps run on it:

.. math::

    \\tilde S\\,\\lambda = \\tilde S \\gamma - \\gamma + A \\tilde M^{-1} (h - Q), \\qquad
    \\tilde M = M + A^T A, \\ \\tilde S = A \\tilde M^{-1} A^T.

Singularity is decided at one seeded numeric state near the initial one
(:func:`~lamech.model._checks.probe_states`), never by a symbolic zero test.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import sympy as sp

from ..model import System
from ..model._checks import holding_at_start, probe_states
from ._derive import DegenerateConstraintsError, Dynamics, dynamics

__all__ = ["multipliers"]

_ZERO = sp.Integer(0)
_SINGULAR = 1e-10
"""A pivot smaller than this (relative to the largest diagonal entry) at the probe
state counts as zero: the matrix is singular there, so generically."""


def multipliers(system: System | Dynamics) -> dict[str, sp.Expr]:
    """Every multiplier of ``system`` as a closed-form expression, by constraint name.

    Functions of the coordinates, velocities, t and parameters of the system as written
    (nothing eliminated), correct at every state where the KKT matrix is regular,
    unsimplified (see the module docstring for how). The constraints are those that
    hold at the start, as in :func:`~lamech.solve`: a unilateral contact open
    there (f > 0) has lambda = 0 until it closes and is left out. Given a
    :class:`~lamech.Dynamics` already derived, every constraint of its system
    is taken as holding. The sign convention is :mod:`lamech.model`'s (lambda_lamech =
    -lambda in SymPy's ``eom``).

    Raises
    ------
    DegenerateConstraintsError
        The KKT matrix is singular (dependent constraints, or a motion the constraints
        allow that has no inertia).
    """
    if not isinstance(system, (Dynamics, System)):
        from ..problem._coerce import as_system

        system = as_system(system, "multipliers")
    dyn = system if isinstance(system, Dynamics) else dynamics(holding_at_start(system))
    sys_ = dyn.system
    n, m = len(sys_.q), len(sys_.constraints)
    if m == 0:
        return {}
    M, A = dyn.M, dyn.A
    a_rows = [[A[k, i] for i in range(n)] for k in range(m)]
    rest = [dyn.h[i] - dyn.Q[i] for i in range(n)]
    gamma = [dyn.gamma[k] for k in range(m)]
    probe = _probe(sys_)
    Mn, An = _numeric(M, probe), _numeric(A, probe)
    if Mn is None or An is None:
        Mn = An = None
    mass = [[M[i, j] for j in range(n)] for i in range(n)]
    factor = _ldl(mass, Mn)
    augmented = factor is None
    if augmented:  # M singular: M + A^T A is definite when the KKT matrix is regular
        mass = [
            [
                mass[i][j] + sp.Add(*[r[i] * r[j] for r in a_rows if r[i] != 0 and r[j] != 0])
                for j in range(n)
            ]
            for i in range(n)
        ]
        if Mn is not None and An is not None:
            Mn = Mn + An.T @ An
        factor = _ldl(mass, Mn)
        if factor is None:  # pragma: no cover - the loader refuses such systems
            raise DegenerateConstraintsError(
                "the KKT matrix is singular: the mass matrix gives no inertia to a motion "
                "the constraints allow"
            )
    if factor is None:  # pragma: no cover - raised above
        raise AssertionError
    L, D = factor
    X = [_solve_factored(L, D, col) for col in a_rows + [rest]]  # M^-1 A^T, M^-1 (h - Q)
    S = [[_dot(a_rows[a], X[b]) for b in range(m)] for a in range(m)]
    rhs = [_dot(a_rows[a], X[m]) - gamma[a] for a in range(m)]
    if augmented:  # the module docstring's S~ lambda = S~ gamma - gamma + A M~^-1 (h - Q)
        rhs = [rhs[a] + _dot(S[a], gamma) for a in range(m)]
    s_num = None
    if Mn is not None and An is not None:
        try:
            s_num = An @ np.linalg.solve(Mn, An.T)
        except np.linalg.LinAlgError:
            s_num = None
    s_factor = _ldl(S, s_num)
    if s_factor is None:
        raise DegenerateConstraintsError(
            "the constraints are dependent: the multipliers are not uniquely determined"
        )
    lam = _solve_factored(*s_factor, rhs)
    return {c.name: lam[k] for k, c in enumerate(sys_.constraints)}


def _probe(system: System) -> dict | None:
    """One seeded numeric state near the initial one (30 digits), or None without one."""
    try:
        env = probe_states(system, count=1, seed=7)[0]
    except (TypeError, ValueError):
        return None
    return {s: sp.Float(v, 30) for s, v in env.items()}


def _numeric(matrix: sp.Matrix, env: dict | None) -> np.ndarray | None:
    if env is None:
        return None
    try:
        out = np.array(matrix.xreplace(env).evalf(), dtype=complex)
    except (TypeError, ValueError):
        return None
    if not np.all(np.isfinite(out)):
        return None
    return out.reshape(matrix.shape)


def _ldl(
    K: list[list[sp.Expr]] | list[list], num: np.ndarray | None
) -> tuple[list[list[sp.Expr]], list[sp.Expr]] | None:
    """K = L D L^T for symmetric K (unit lower-triangular L, diagonal D), symbolic and
    without pivoting; the same factorisation of ``num`` (K at the probe state) decides
    whether a pivot vanishes: None then (K singular). Structural zeros of K stay zeros
    of L."""
    n = len(K)
    L: list[list[sp.Expr]] = [[_ZERO] * n for _ in range(n)]
    D: list[sp.Expr] = [_ZERO] * n
    Ln = np.zeros((n, n), dtype=complex)
    Dn = np.zeros(n, dtype=complex)
    scale = max(1.0, float(np.abs(np.diag(num)).max())) if num is not None and n else 1.0
    for i in range(n):
        for j in range(i):
            s = K[i][j]
            terms = [L[i][k] * L[j][k] * D[k] for k in range(j) if L[i][k] != 0 and L[j][k] != 0]
            if terms:
                s = s - sp.Add(*terms)
            L[i][j] = s / D[j] if s != 0 else _ZERO
            if num is not None:
                Ln[i, j] = (num[i, j] - np.sum(Ln[i, :j] * Ln[j, :j] * Dn[:j])) / Dn[j]
        terms = [L[i][k] ** 2 * D[k] for k in range(i) if L[i][k] != 0]
        D[i] = K[i][i] - sp.Add(*terms) if terms else sp.sympify(K[i][i])
        if num is not None:
            Dn[i] = num[i, i] - np.sum(Ln[i, :i] ** 2 * Dn[:i])
            if abs(Dn[i]) <= _SINGULAR * scale:
                return None
        elif D[i] == 0:
            return None
    return L, D


def _solve_factored(L: list[list[sp.Expr]], D: list[sp.Expr], b: Sequence[sp.Expr]) -> list:
    """x with L D L^T x = b: forward substitution, the diagonal, back substitution."""
    n = len(D)
    y = list(b)
    for i in range(n):
        terms = [L[i][k] * y[k] for k in range(i) if L[i][k] != 0 and y[k] != 0]
        if terms:
            y[i] = y[i] - sp.Add(*terms)
    z = [y[i] / D[i] if y[i] != 0 else _ZERO for i in range(n)]
    for i in range(n - 1, -1, -1):
        terms = [L[k][i] * z[k] for k in range(i + 1, n) if L[k][i] != 0 and z[k] != 0]
        if terms:
            z[i] = z[i] - sp.Add(*terms)
    return z


def _dot(row: Sequence[sp.Expr], col: Sequence[sp.Expr]) -> sp.Expr:
    return sp.Add(*[a * b for a, b in zip(row, col) if a != 0 and b != 0])
