"""The kernels' small array operations (largest entry, finiteness, products with the
constraint matrix), written as loops for numba, and as the NumPy expressions they stand
for when the kernels run as Python (:data:`PYTHON`, put in their place by
:func:`.python_namespace`).

Why loops where NumPy has the operation: numba compiles ``np.max``, ``np.all``,
``np.mean`` and the like from its module ``numba.np.arraymath``, and ``A @ B`` as a call
of SciPy's BLAS (``numba.np.linalg``). Loading the loop's cached machine code then
imports those modules (each compiled function's environment names its module), and
``numba.np.arraymath`` imports ``scipy.linalg`` to find a BLAS: 0.13-0.2 s of CPU in
every process that runs the compiled loop (measured 2026-11-27 on the 2-core machine,
``lamech sweep cylinder`` with 400 cases: numba's own import is 0.2 s). The loops also
allocate no temporary array (``np.max(np.abs(x))`` made one), and the products skip the
zeros of the constraint matrix (a few nonzeros a row), where BLAS multiplies them all.

The loops give the same numbers as numba's own ``np.max``, ``np.all`` and ``np.mean``
(the same terms in the same order), and so do their twins; the products may differ from
BLAS's in the last bit (another order of the same sums).
"""

import math

import numpy as np


def _max_abs_numpy(x):
    return float(np.max(np.abs(x), initial=0.0))


def _max_abs_diff_numpy(a, b):
    return float(np.max(np.abs(a - b), initial=0.0))


def _all_finite_numpy(x):
    return bool(np.all(np.isfinite(x)))


def _any_nonzero_numpy(x):
    return bool(np.any(x != 0.0))


# np.mean adds pairwise; the loops (and numba's np.mean) add in order, as accumulate does
def _rms_scaled_numpy(x, scale):
    return float(np.sqrt(np.add.accumulate((x / scale) ** 2)[-1] / x.shape[0]))


def _rms_diff_scaled_numpy(a, b, scale):
    return float(np.sqrt(np.add.accumulate(((a - b) / scale) ** 2)[-1] / a.shape[0]))


# the products by BLAS: the same to rounding, not to the last bit (the loop as Python
# keeps BLAS's speed on a large system's projection, at each of SciPy's steps)
def _a_bt_numpy(A, B):
    return A @ B.T


def _at_v_numpy(A, w):
    return A.T @ w


def _a_v_numpy(A, v):
    return A @ v


def _diagonal_weights_numpy(W):
    d = np.diag(W).copy()
    if np.all(d > 0.0) and np.count_nonzero(W) == W.shape[0]:
        return d
    return np.empty(0)


PYTHON = {
    "max_abs": _max_abs_numpy,
    "max_abs_diff": _max_abs_diff_numpy,
    "all_finite": _all_finite_numpy,
    "any_nonzero": _any_nonzero_numpy,
    "rms_scaled": _rms_scaled_numpy,
    "rms_diff_scaled": _rms_diff_scaled_numpy,
    "a_bt": _a_bt_numpy,
    "at_v": _at_v_numpy,
    "a_v": _a_v_numpy,
    "diagonal_weights": _diagonal_weights_numpy,
}
"""The functions below that the kernels run as Python replace by these."""


# KERNELS
def max_abs(x):
    """The largest |x_i| of an array of any shape (``np.max(np.abs(x))``); NaN where an
    entry is NaN; 0 for an empty array."""
    m = 0.0
    for v in x.flat:
        a = abs(v)
        if a > m or a != a:  # a NaN is kept: no later entry compares greater
            m = a
    return m


def max_abs_diff(a, b):
    """The largest |a_i - b_i| of two vectors (``np.max(np.abs(a - b))``)."""
    m = 0.0
    for i in range(a.shape[0]):
        d = abs(a[i] - b[i])
        if d > m or d != d:
            m = d
    return m


def all_finite(x):
    """Whether every entry of an array is finite (``np.all(np.isfinite(x))``)."""
    for v in x.flat:
        if not math.isfinite(v):
            return False
    return True


def any_nonzero(x):
    """Whether an entry of a vector is not 0 (``np.any(x != 0.0)``; NaN is not 0)."""
    for i in range(x.shape[0]):
        if x[i] != 0.0:
            return True
    return False


def rms_scaled(x, scale):
    """sqrt(mean((x / scale)^2)) of two vectors, the terms summed in order as numba's
    ``np.mean`` sums them."""
    s = 0.0
    for i in range(x.shape[0]):
        s += (x[i] / scale[i]) ** 2
    return np.sqrt(s / x.shape[0])


def rms_diff_scaled(a, b, scale):
    """sqrt(mean(((a - b) / scale)^2)) of three vectors (:func:`rms_scaled`)."""
    s = 0.0
    for i in range(a.shape[0]):
        s += ((a[i] - b[i]) / scale[i]) ** 2
    return np.sqrt(s / a.shape[0])


def a_bt(A, B):
    """A B^T (k x j) of A (k x n) and B (j x n), skipping A's zeros: the constraint
    matrix has a few nonzeros a row (the Gram matrix of a projection)."""
    k, n = A.shape
    j = B.shape[0]
    G = np.zeros((k, j))
    for i in range(k):
        for c in range(n):
            a = A[i, c]
            if a != 0.0:
                for r in range(j):
                    G[i, r] += a * B[r, c]
    return G


def at_v(A, w):
    """A^T w (n) of A (k x n) and w (k)."""
    k, n = A.shape
    out = np.zeros(n)
    for i in range(k):
        wi = w[i]
        for c in range(n):
            out[c] += A[i, c] * wi
    return out


def a_v(A, v):
    """A v (k) of A (k x n) and v (n)."""
    k, n = A.shape
    out = np.empty(k)
    for i in range(k):
        s = 0.0
        for c in range(n):
            s += A[i, c] * v[c]
        out[i] = s
    return out


def diagonal_weights(W):
    """W's diagonal (a copy) where W (n x n) is diagonal and positive there, else an
    empty array."""
    n = W.shape[0]
    d = np.empty(n)
    for i in range(n):
        for c in range(n):
            if c == i:
                if not W[i, i] > 0.0:
                    return np.empty(0)
                d[i] = W[i, i]
            elif W[i, c] != 0.0:
                return np.empty(0)
    return d
