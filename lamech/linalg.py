"""Dense linear algebra of the KKT system (the base layer: NumPy only).

The KKT system of :mod:`lamech.model` at one state,

    [ M  -G^T ] [ q'' ]   [ rhs    ]
    [ A    0  ] [ lam ] = [ -gamma ]

with G = A unless a slipping friction row moves its kinetic force into the column of
its normal multiplier. :func:`kkt_matrix` and :func:`kkt_rhs` are the one place that
assembles it with NumPy: :func:`solve_kkt` solves it (the simulator, the impact
impulses, :func:`lamech.symbolic._derive.kkt_numeric`), :func:`min_norm_correction` solves the
same matrix for the projection onto the constraints. :func:`gauss_inplace` and
:func:`cholesky_inplace` are plain loops, whose twins in C run the hot path
(:mod:`lamech.numeric`, whose compiled KKT solve assembles the same matrix in loops) and
that run as Python without it.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "kkt_matrix",
    "kkt_rhs",
    "solve_kkt",
    "min_norm_correction",
    "gauss_inplace",
    "cholesky_inplace",
]


def kkt_matrix(M: np.ndarray, A: np.ndarray, G: np.ndarray | None = None) -> np.ndarray:
    """[[M, -G^T], [A, 0]], shape (n + k, n + k), for M (n, n), A and G (k, n)."""
    n, k = M.shape[0], A.shape[0]
    K = np.zeros((n + k, n + k))
    K[:n, :n] = M
    K[:n, n:] = -(A if G is None else G).T
    K[n:, :n] = A
    return K


def kkt_rhs(rhs: np.ndarray, gamma: np.ndarray) -> np.ndarray:
    """[rhs; -gamma], the right-hand side of the KKT system."""
    return np.concatenate((rhs, -gamma))


def solve_kkt(
    M: np.ndarray, rhs: np.ndarray, A: np.ndarray, gamma: np.ndarray, G: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(q'', lam) of the KKT system; raises numpy.linalg.LinAlgError when singular."""
    n = M.shape[0]
    sol = np.linalg.solve(kkt_matrix(M, A, G), kkt_rhs(rhs, gamma))
    return sol[:n], sol[n:]


def min_norm_correction(W: np.ndarray, A: np.ndarray, r: np.ndarray) -> np.ndarray:
    """dx minimising dx^T W dx subject to A dx = r: the KKT system with M = W, rhs 0 and
    gamma = -r (its multipliers are those of the problem with the opposite sign, dx is
    the same to the last bit: negating columns changes no pivot and no rounding). Raises
    numpy.linalg.LinAlgError when singular; may hold NaN or inf when nearly so."""
    return solve_kkt(W, np.zeros(W.shape[0]), A, -r)[0]


def cholesky_inplace(K, x):
    """Solve K y = x in place for a symmetric positive definite K (x becomes y; the lower
    triangle of K becomes L with K = L L^T). Row i of L starts where row i of K does (its
    envelope), so a banded K costs O(N) band rows. Returns False, with x undefined, when
    K is not positive definite to working precision."""
    N = x.shape[0]
    first = np.empty(N, dtype=np.int64)
    for i in range(N):
        f = 0
        while f < i and K[i, f] == 0.0:
            f += 1
        first[i] = f
        for j in range(f, i):
            acc = K[i, j]
            for k in range(max(f, first[j]), j):
                acc -= K[i, k] * K[j, k]
            K[i, j] = acc / K[j, j]
        acc = K[i, i]
        for k in range(f, i):
            acc -= K[i, k] * K[i, k]
        if not acc > 0.0:
            return False
        K[i, i] = math.sqrt(acc)
    for i in range(N):  # L y = x
        acc = x[i]
        for k in range(first[i], i):
            acc -= K[i, k] * x[k]
        x[i] = acc / K[i, i]
    for i in range(N - 1, -1, -1):  # L^T z = y
        x[i] /= K[i, i]
        for k in range(first[i], i):
            x[k] -= K[i, k] * x[i]
    return True


def gauss_inplace(K, x):
    """Solve K y = x in place: x becomes y (NaN when K is singular), K is destroyed.
    Gaussian elimination with partial pivoting; row operations stop at the pivot row's
    last nonzero, so a banded K (a chain's Schur complement) costs O(N) rows of its band."""
    N = x.shape[0]
    for c in range(N):
        piv = c
        big = abs(K[c, c])
        for i in range(c + 1, N):
            if abs(K[i, c]) > big:
                big = abs(K[i, c])
                piv = i
        if big == 0.0:
            x[:] = np.nan
            return
        if piv != c:
            for k in range(N):
                tmp = K[c, k]
                K[c, k] = K[piv, k]
                K[piv, k] = tmp
            tmp = x[c]
            x[c] = x[piv]
            x[piv] = tmp
        last = N - 1  # the pivot row's last nonzero: banded matrices stay cheap
        while K[c, last] == 0.0:
            last -= 1
        inv = 1.0 / K[c, c]
        for i in range(c + 1, N):
            if K[i, c] != 0.0:
                f = K[i, c] * inv
                for k in range(c, last + 1):
                    K[i, k] -= f * K[c, k]
                x[i] -= f * x[c]
    for i in range(N - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, N):
            s -= K[i, k] * x[k]
        x[i] = s / K[i, i]
