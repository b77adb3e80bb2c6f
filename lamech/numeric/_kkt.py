"""The KKT solve of the hot path with NumPy/LAPACK (:func:`kkt_solve_numpy`, the
reference; its compiled twin is in C, ``lamech.numeric._cengine``), the
right-hand sides built on it (:func:`numpy_kernels`), and the sparsity pattern of the
constraint rows that the compiled solve runs over (:func:`sparsity`).

Both solve, on a mode's active ``rows``, the KKT system of :mod:`lamech.linalg`

    M q'' - G^T lambda = rhs,   A_r q'' = -gamma_r,

where G = A_r except that a slipping friction row j_s, on the normal row at position
k_s among the rows, moves its kinetic friction c_s A_j (c_s = mu_j * slip_c[s]) into
the column of lambda_{k_s} (:func:`slip_directions`). The NumPy solve assembles the
matrix with :func:`lamech.linalg.kkt_matrix`; the compiled one fills the same matrix
in its loops.
"""

from __future__ import annotations

import numpy as np

from ..linalg import solve_kkt

__all__ = [
    "slip_directions",
    "kkt_solve_numpy",
    "sparsity",
    "numpy_kernels",
]


def slip_directions(A, rows, mu, slip_j, slip_k, slip_c) -> np.ndarray:
    """G: the active rows A[rows], the row at position slip_k[s] minus
    mu_j slip_c[s] A_j for each slipping friction row j = slip_j[s]."""
    G = A[rows]
    for s in range(slip_j.shape[0]):
        G[slip_k[s]] -= mu[slip_j[s]] * slip_c[s] * A[slip_j[s]]
    return G


def python_side_solve(ns):
    """The KKT solve the Python side of a run uses (SciPy's steps, a compiled
    run's first sample and handed-back segments): NumPy's (:func:`kkt_solve_numpy`), also
    for a compiled system, where the compiled solve would be an entry point of its own to
    load for a handful of solves (0.07 s of CPU, measured 2026-11-27); ``ns``' own where
    one of its functions was replaced (``NumericSystem.replaced``)."""
    return ns.kkt_solve if ns.replaced else kkt_solve_numpy(ns.mass_diagonal)


def kkt_solve_numpy(diagonal: bool):
    """solve(M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c) -> [q''; lambda_rows] with
    NumPy/LAPACK (NaN where singular): the KKT system of the engine's kkt.c, by the
    Schur complement when M is diagonal with no zero entry and the KKT matrix is larger
    than 32 (30-link chain: a 30-square solve instead of a 90-square one, 74 -> 48 us;
    below that NumPy's per-call overhead makes the few extra products cost more than they
    save: 2-link 15 -> 26 us, 8-link equal), else the full KKT matrix
    (:func:`lamech.linalg.solve_kkt`)."""

    def solve(M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c):
        n, na = rhs.shape[0], rows.shape[0]
        G = slip_directions(A, rows, mu, slip_j, slip_k, slip_c)
        try:
            if diagonal and n + na > 32:
                d = np.diagonal(M)
                if np.all(d != 0.0):
                    minv = 1.0 / d
                    if na == 0:
                        return rhs * minv
                    W = A[rows] * minv
                    lam = np.linalg.solve(W @ G.T, -gam[rows] - W @ rhs)
                    return np.concatenate(((rhs + G.T @ lam) * minv, lam))
            return np.concatenate(solve_kkt(M, rhs, A[rows], gam[rows], G))
        except np.linalg.LinAlgError:
            return np.full(n + na, np.nan)

    return solve


def numpy_kernels(dyn, diagonal: bool):
    """(rhs_kernel, accelerations, solve) around the NumPy solve:
    ``rhs_kernel(t, y, p, rows, slip_j, slip_k, slip_c) -> y'`` on a mode's active rows,
    ``accelerations(t, y, p) -> [q''; lambda]`` with every constraint active, and the
    solve itself (:func:`kkt_solve_numpy`), for the simulator's KKT solve at a state."""
    solve = kkt_solve_numpy(diagonal)
    none = np.zeros(0, dtype=np.int64)

    def rhs_kernel(t, y, p, rows, slip_j, slip_k, slip_c):
        n = y.shape[0] // 2
        q, v = y[:n], y[n:]
        M, rhs, A, gam, mu = dyn(t, q, v, p)
        out = np.empty(2 * n)
        out[:n] = v
        out[n:] = solve(M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c)[:n]
        return out

    def accelerations(t, y, p):
        n = y.shape[0] // 2
        M, rhs, A, gam, mu = dyn(t, y[:n], y[n:], p)
        return solve(M, rhs, A, gam, mu, np.arange(A.shape[0]), none, none, np.zeros(0))

    return rhs_kernel, accelerations, solve


def sparsity(A):
    """The structural nonzeros of the constraint rows A, by row (CSR: ptr, idx; the
    generated ``dynamics_sparse`` gives A's values in this order) and by column (CSC:
    cptr, crow, and cpos: the CSR position of each CSC entry), as int64 arrays for the
    compiled solve."""
    m, n = A.shape
    nonzero = sorted(A.todok()) if m and n else []  # (j, i), by row then column
    rows: list[list[int]] = [[] for _ in range(m)]
    cols: list[list[int]] = [[] for _ in range(n)]
    cpos_of: list[list[int]] = [[] for _ in range(n)]
    for e, (j, i) in enumerate(nonzero):
        rows[j].append(i)
        cols[i].append(j)
        cpos_of[i].append(e)

    def pack(lists):
        ptr = np.zeros(len(lists) + 1, dtype=np.int64)
        ptr[1:] = np.cumsum([len(x) for x in lists])
        idx = np.array([k for x in lists for k in x], dtype=np.int64)
        return ptr, idx

    return (*pack(rows), *pack(cols), pack(cpos_of)[1])
