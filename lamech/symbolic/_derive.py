"""The general derivation: M, h, A, gamma, Q and the KKT system of a :class:`System`.

With the canonical equations of :mod:`lamech.model`,

.. math::

    M(q,t)\\,\\ddot q + h(q,\\dot q,t) = A^T\\lambda + Q^{nc}, \\qquad
    A\\,\\ddot q + \\gamma(q,\\dot q,t) = 0,

where :math:`M = \\partial^2 L/\\partial\\dot q^2`, each constraint row of A is
:math:`\\partial F_j/\\partial\\dot q` of its velocity form F_j (df/dt for holonomic f, g
itself for a non-holonomic one) and :math:`\\gamma_j = \\partial F_j/\\partial q\\,\\dot q +
\\partial F_j/\\partial t`. Together, the KKT system

.. math::

    \\begin{bmatrix} M & -A^T \\\\ A & 0 \\end{bmatrix}
    \\begin{bmatrix} \\ddot q \\\\ \\lambda \\end{bmatrix} =
    \\begin{bmatrix} Q^{nc} - h \\\\ -\\gamma \\end{bmatrix}.

M may be singular (a massless coordinate) as long as the KKT matrix is not: M is never
inverted on its own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from .._errors import LamechError
from ..linalg import kkt_matrix, kkt_rhs
from ..model import System
from ..model._checks import dependent_group, numeric_matrix, without_inertia
from ..model._kinematics import constraint_jacobian, gradient, jacobian

__all__ = ["Dynamics", "dynamics", "kkt_numeric", "DegenerateConstraintsError"]


class DegenerateConstraintsError(LamechError, ValueError):
    """The KKT matrix is singular: the multipliers are not uniquely determined."""


@dataclass(frozen=True)
class Dynamics:
    """M, h, Q, A, gamma of a system (shapes (n, n), (n, 1), (n, 1), (m, n), (m, 1)).

    ``velocity_forms`` holds F_j (df_j/dt or g_j), ``equations`` the Euler-Lagrange
    equations M q'' + h - A^T lambda - Q (each = 0), one per coordinate.
    """

    system: System
    M: sp.Matrix
    h: sp.Matrix
    Q: sp.Matrix
    A: sp.Matrix
    gamma: sp.Matrix
    velocity_forms: sp.Matrix
    equations: tuple[sp.Expr, ...]


def dynamics(system: System) -> Dynamics:
    """Derive M, h, Q, A, gamma and the Euler-Lagrange equations (pure, no simplification).
    ``system`` as :func:`~lamech.solve` takes it."""
    if not isinstance(system, System):
        from ..problem._coerce import as_system

        system = as_system(system, "dynamics")
    q, qd, qdd = system.q, system.qd, system.qdd
    n = len(q)
    L = system.L
    p = gradient(L, qd)
    M = jacobian(p, qd)
    dLdq = gradient(L, q)
    h = sp.Matrix(
        [
            sp.Add(*(sp.diff(p[i], x) * v for x, v in zip(q, qd) if x in p[i].free_symbols))
            + sp.diff(p[i], system.t)
            - dLdq[i]
            for i in range(n)
        ]
    )
    Q = sp.Matrix(list(system.forces) if system.forces else [0] * n)
    A, F = constraint_jacobian(system)
    m = len(system.constraints)
    gamma = sp.Matrix(
        [
            sp.Add(*(sp.diff(F[j], x) * v for x, v in zip(q, qd) if x in F[j].free_symbols))
            + sp.diff(F[j], system.t)
            for j in range(m)
        ]
    )
    lam = sp.Matrix(system.multipliers)
    acc = sp.Matrix(qdd)
    lhs = M * acc + h - (A.T * lam if m else sp.zeros(n, 1)) - Q
    return Dynamics(system, M, h, Q, A, gamma, F, tuple(lhs))


def kkt_numeric(
    dyn: Dynamics, state: dict, active: list[int] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Solve the KKT system numerically at ``state`` (symbols -> numbers, parameters too).

    Returns (q'', lambda) for the ``active`` constraints (all by default).

    Raises
    ------
    DegenerateConstraintsError
        The KKT matrix is singular at this state.
    """
    n = len(dyn.system.coordinates)
    rows = list(range(dyn.A.rows)) if active is None else list(active)
    M = numeric_matrix(dyn.M, state)
    A = numeric_matrix(dyn.A, state).reshape(dyn.A.rows, n)[rows]
    rhs_top = numeric_matrix(dyn.Q - dyn.h, state).reshape(n)
    g = numeric_matrix(dyn.gamma, state).reshape(dyn.A.rows)[rows] if rows else np.zeros(0)
    K = kkt_matrix(M, A)
    cond = np.linalg.cond(K)
    if not np.isfinite(cond) or cond > 1e13:
        raise DegenerateConstraintsError(_singular_message(dyn, M, A, rows, state))
    sol = np.linalg.solve(K, kkt_rhs(rhs_top, g))
    return sol[:n], sol[n:]


def _singular_message(
    dyn: Dynamics, M: np.ndarray, A: np.ndarray, rows: list[int], state: dict
) -> str:
    names = [dyn.system.constraints[i].name for i in rows]
    group = dependent_group(A, names) if rows else None
    if group:
        return (
            "constraints "
            + " and ".join(f"`{n}`" for n in group)
            + " are dependent: forces cannot be uniquely determined"
        )
    # M singular on the motions the constraints allow: name the coordinate without
    # inertia (and the massless bodies it moves).
    weak = without_inertia(dyn.system, M, A, state)
    hint = f" ({weak.describe(dyn.system)})" if weak else ""
    return (
        "the KKT matrix is singular: the mass matrix gives no inertia to a motion the "
        f"constraints allow{hint}; add a mass or a constraint"
    )
