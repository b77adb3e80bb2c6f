"""The KKT solve of the hot path, twice: with NumPy/LAPACK (:func:`kkt_solve_numpy`, the
reference) and as loops numba compiles (:func:`make_kkt_solve`, its compiled twin); and
the right-hand sides built on them (:func:`numpy_kernels`, :func:`jit_kernels`).

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

from ..linalg import cholesky_inplace, gauss_inplace, solve_kkt

__all__ = [
    "slip_directions",
    "kkt_solve_numpy",
    "make_kkt_solve",
    "sparsity",
    "numpy_kernels",
    "jit_kernels",
]


def slip_directions(A, rows, mu, slip_j, slip_k, slip_c) -> np.ndarray:
    """G: the active rows A[rows], the row at position slip_k[s] minus
    mu_j slip_c[s] A_j for each slipping friction row j = slip_j[s]."""
    G = A[rows]
    for s in range(slip_j.shape[0]):
        G[slip_k[s]] -= mu[slip_j[s]] * slip_c[s] * A[slip_j[s]]
    return G


def kkt_solve_numpy(diagonal: bool):
    """solve(M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c) -> [q''; lambda_rows] with
    NumPy/LAPACK (NaN where singular): the KKT system of :func:`make_kkt_solve`, by the
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


def jit_kernels(jd, diagonal: bool, pattern):
    """(rhs_kernel, accelerations, solve) as :func:`numpy_kernels`, numba-compiled around
    the compiled solve of :func:`make_kkt_solve` and the compiled dynamics ``jd``."""
    import numba

    solve = make_kkt_solve(numba.njit(cache=False), diagonal, pattern)

    @numba.njit(cache=False)
    def rhs_kernel(t, y, p, rows, slip_j, slip_k, slip_c):
        n = y.shape[0] // 2
        q = y[:n].copy()
        v = y[n:].copy()
        M, rhs, A, gam, mu = jd(t, q, v, p)
        sol = solve(M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c)
        out = np.empty(2 * n)
        for i in range(n):
            out[i] = v[i]
            out[n + i] = sol[i]
        return out

    @numba.njit(cache=False)
    def accelerations(t, y, p):
        n = y.shape[0] // 2
        M, rhs, A, gam, mu = jd(t, y[:n], y[n:], p)
        # writable arrays of rhs_kernel's types, so that numba reuses the compiled solve
        # (read-only constant arrays would compile it again: 2 s more)
        none = np.zeros(0, dtype=np.int64)
        return solve(M, rhs, A, gam, mu, np.arange(A.shape[0]), none, none, np.zeros(0))

    return rhs_kernel, accelerations, solve


def sparsity(A):
    """The structural nonzeros of the constraint rows A, by row (CSR: ptr, idx) and by
    column (CSC: cptr, crow), as int64 arrays for the compiled solve."""
    m, n = A.shape
    rows = [[i for i in range(n) if A[j, i] != 0] for j in range(m)]
    cols = [[j for j in range(m) if A[j, i] != 0] for i in range(n)]

    def pack(lists):
        ptr = np.zeros(len(lists) + 1, dtype=np.int64)
        ptr[1:] = np.cumsum([len(x) for x in lists])
        idx = np.array([k for x in lists for k in x], dtype=np.int64)
        return ptr, idx

    return (*pack(rows), *pack(cols))


def make_kkt_solve(njit, diagonal: bool, pattern=None):
    """solve(M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c) -> [q''; lambda_rows]: the
    compiled twin of :func:`kkt_solve_numpy` (the same system, the same numbers to
    rounding).

    The KKT system  M q'' - A_r^T lambda + sum_s c_s A_{j_s}^T lambda_{k_s} = rhs,
    A_r q'' = -gamma_r  on the active ``rows`` (a slipping friction row j_s on the normal
    row at position k_s adds its kinetic friction, c_s = mu_j * slip_c[s]).

    ``diagonal`` (known from the symbolic M, as for particles and planar bodies in
    maximal coordinates): while every M_ii is nonzero, the Schur complement
    S lambda = -gamma_r - A_r M^-1 rhs with S = A_r M^-1 G^T (m x m) replaces the
    (n + m)-square elimination (8-link chain: 24 x 24 -> 8 x 8), and every product runs
    over the structural nonzeros of A only (``pattern`` from :func:`sparsity`). S is
    factored by Cholesky when it is symmetric positive definite (no slipping row, M_ii
    > 0), else by elimination. A zero M_ii (a massless coordinate), or a Cholesky that
    finds S singular (dependent rows), falls back to the full KKT matrix, which may be
    regular where M is not.

    Written as loops so that numba compiles them: at these sizes numba's
    ``np.linalg.solve`` (LAPACK, with its copies to Fortran order) was measured slower
    than this elimination (8 x 8: 1.3 against 0.34 us; 24 x 24: 5.3 against 2.5 us).
    """
    gauss = njit(gauss_inplace)
    cholesky = njit(cholesky_inplace)

    def dense(M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c):
        n = rhs.shape[0]
        na = rows.shape[0]
        K = np.zeros((n + na, n + na))
        r = np.zeros(n + na)
        for i in range(n):
            r[i] = rhs[i]
            for k in range(n):
                K[i, k] = M[i, k]
        for a in range(na):
            j = rows[a]
            r[n + a] = -gam[j]
            for i in range(n):
                K[i, n + a] = -A[j, i]
                K[n + a, i] = A[j, i]
        for s in range(slip_j.shape[0]):
            j = slip_j[s]
            c = mu[j] * slip_c[s]
            for i in range(n):
                K[i, n + slip_k[s]] += c * A[j, i]
        gauss(K, r)
        return r

    dense = njit(dense)
    if not diagonal:
        return dense
    ptr, idx, cptr, crow = pattern

    def schur(M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c):
        n = rhs.shape[0]
        m = A.shape[0]
        na = rows.shape[0]
        minv = np.empty(n)
        positive = True
        for i in range(n):
            if M[i, i] == 0.0:
                return dense(M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c)
            minv[i] = 1.0 / M[i, i]
            positive = positive and M[i, i] > 0.0
        out = np.empty(n + na)
        for i in range(n):
            out[i] = rhs[i]
        if na == 0:
            for i in range(n):
                out[i] *= minv[i]
            return out
        pos = np.full(m, -1)  # position of each constraint among the rows
        for a in range(na):
            pos[rows[a]] = a
        S = np.zeros((na, na))
        r = np.empty(na)
        for a in range(na):
            j = rows[a]
            acc = -gam[j]
            for e in range(ptr[j], ptr[j + 1]):
                i = idx[e]
                w = A[j, i] * minv[i]
                acc -= w * rhs[i]
                for f in range(cptr[i], cptr[i + 1]):
                    b = pos[crow[f]]
                    if b >= 0:
                        S[a, b] += w * A[crow[f], i]
                for s in range(slip_j.shape[0]):
                    S[a, slip_k[s]] -= w * mu[slip_j[s]] * slip_c[s] * A[slip_j[s], i]
            r[a] = acc
        if slip_j.shape[0] == 0 and positive:
            # S = A_r M^-1 A_r^T is symmetric positive definite (M_ii > 0, independent
            # rows): Cholesky, half the work of elimination and no pivot search.
            if not cholesky(S, r):  # dependent rows here: let the full KKT decide
                return dense(M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c)
        else:
            gauss(S, r)  # r becomes lambda
        for a in range(na):
            j = rows[a]
            out[n + a] = r[a]
            for e in range(ptr[j], ptr[j + 1]):
                out[idx[e]] += A[j, idx[e]] * r[a]
        for s in range(slip_j.shape[0]):
            j = slip_j[s]
            c = mu[j] * slip_c[s] * r[slip_k[s]]
            for e in range(ptr[j], ptr[j + 1]):
                out[idx[e]] -= c * A[j, idx[e]]
        for i in range(n):
            out[i] *= minv[i]
        return out

    return njit(schur)
