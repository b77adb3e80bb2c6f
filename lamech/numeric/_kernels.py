"""The compiled kernels of the hot path, as text for each system's generated module.

numba compiles a system's KKT solve and right-hand sides from one module per system
(:mod:`._jitcache`): the generated functions of its derivation (``dynamics``,
``constraints``: :mod:`._codegen`), its sparsity pattern as module constants (``PTR``,
``IDX``, ``CPTR``, ``CROW``: :func:`._kkt.sparsity`) and ``DIAGONAL``, the loops of
:func:`lamech.linalg.gauss_inplace` and :func:`lamech.linalg.cholesky_inplace`, and the
text of this file below the ``KERNELS`` line. Module-level functions over module-level
constants, not closures: that is what lets numba cache the compiled code on disk
(``cache=True`` keys a closure's cache by its cells, and a cell holding another compiled
function pickles differently in every process, so a closure is compiled anew in each).

The names above the ``KERNELS`` line stand in for those the generated module defines
(they make this file a module that can be imported and checked by itself). The compiled
solve is the twin of :func:`._kkt.kkt_solve_numpy` (the same system, the same numbers to
rounding):

The KKT system  M q'' - A_r^T lambda + sum_s c_s A_{j_s}^T lambda_{k_s} = rhs,
A_r q'' = -gamma_r  on the active ``rows`` (a slipping friction row j_s on the normal
row at position k_s adds its kinetic friction, c_s = mu_j * slip_c[s]).

``DIAGONAL`` (known from the symbolic M, as for particles and planar bodies in maximal
coordinates): while every M_ii is nonzero, the Schur complement
S lambda = -gamma_r - A_r M^-1 rhs with S = A_r M^-1 G^T (m x m) replaces the
(n + m)-square elimination (8-link chain: 24 x 24 -> 8 x 8), and every product runs over
the structural nonzeros of A only. S is factored by Cholesky when it is symmetric
positive definite (no slipping row, M_ii > 0), else by elimination. A zero M_ii (a
massless coordinate), or a Cholesky that finds S singular (dependent rows), falls back
to the full KKT matrix, which may be regular where M is not.

Written as loops so that numba compiles them: at these sizes numba's
``np.linalg.solve`` (LAPACK, with its copies to Fortran order) was measured slower than
this elimination (8 x 8: 1.3 against 0.34 us; 24 x 24: 5.3 against 2.5 us).
"""

import numpy as np

from ..linalg import cholesky_inplace, gauss_inplace
from ._project import PROJECTION_ITERATIONS

__all__ = ["kernel_text", "KERNEL_NAMES", "BATCH_NAMES", "STAGES", "PROJECTION_ITERATIONS"]

STAGES = 12
"""DOP853's number of stages (checked against SciPy's table in :mod:`._batch`)."""


# Stand-ins for the generated module's names (see the module docstring).
def dynamics(t, q, v, p):  # (M, rhs, A, gamma, mu)
    raise NotImplementedError


def dynamics_sparse(t, q, v, p):  # (diagonal of M, rhs, A's nonzeros in CSR order, gamma, mu)
    raise NotImplementedError


def constraints(t, q, p):  # (f, A, b)
    raise NotImplementedError


PTR = IDX = CPTR = CROW = CPOS = np.zeros(1, dtype=np.int64)
DIAGONAL = False
prange = range  # numba.prange in the generated module

KERNEL_NAMES = (
    "dynamics_sparse",
    "kkt_dense",
    "kkt_schur",
    "kkt_schur_sparse",
    "dense_matrices",
    "kkt_state",
    "rhs_kernel",
    "accelerations",
)
"""The functions of the ``KERNELS`` part that numba compiles (and the generated
``dynamics_sparse``); ``kkt_solve`` is ``kkt_schur`` when ``DIAGONAL``, else
``kkt_dense``."""
BATCH_NAMES = ("batch_solve", "batch_deriv", "batch_project", "batch_run_one")
"""The functions of the ``BATCH`` part that numba compiles (and ``batch_run`` in
parallel, ``batch_run_serial``)."""


def kernel_text(part: str = "KERNELS") -> str:
    """The text of this file's ``KERNELS`` part (to the ``BATCH`` line) or its
    ``BATCH`` part (to the end)."""
    import inspect
    import sys

    text = inspect.getsource(sys.modules[__name__])
    start = text.index("\n# KERNELS\n") + 1
    batch = text.index("\n# BATCH\n") + 1
    return text[start:batch] if part == "KERNELS" else text[batch:]


# KERNELS
def kkt_dense(M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c):
    """The full KKT matrix, by elimination with partial pivoting."""
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
    gauss_inplace(K, r)
    return r


def kkt_schur(M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c):
    """:func:`kkt_schur_sparse` on dense M and A (the simulator's solve at a state)."""
    n = rhs.shape[0]
    Md = np.empty(n)
    for i in range(n):
        Md[i] = M[i, i]
    Av = np.empty(IDX.shape[0])
    for j in range(PTR.shape[0] - 1):
        for e in range(PTR[j], PTR[j + 1]):
            Av[e] = A[j, IDX[e]]
    return kkt_schur_sparse(Md, rhs, Av, gam, mu, rows, slip_j, slip_k, slip_c)


def dense_matrices(Md, Av):
    """M and A as matrices from their structural nonzeros."""
    n = Md.shape[0]
    M = np.zeros((n, n))
    for i in range(n):
        M[i, i] = Md[i]
    A = np.zeros((PTR.shape[0] - 1, n))
    for j in range(PTR.shape[0] - 1):
        for e in range(PTR[j], PTR[j + 1]):
            A[j, IDX[e]] = Av[e]
    return M, A


def kkt_schur_sparse(Md, rhs, Av, gam, mu, rows, slip_j, slip_k, slip_c):
    """The Schur complement over the structural nonzeros: M's diagonal ``Md`` and A's
    nonzeros ``Av`` (by row: PTR, IDX; by column: CPTR, CROW, and CPOS their positions
    in Av). Nothing of size n x n or m x n is formed, unless a zero M_ii or dependent rows
    send it to the full KKT matrix."""
    n = rhs.shape[0]
    m = PTR.shape[0] - 1
    na = rows.shape[0]
    minv = np.empty(n)
    positive = True
    for i in range(n):
        if Md[i] == 0.0:
            M, A = dense_matrices(Md, Av)
            return kkt_dense(M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c)
        minv[i] = 1.0 / Md[i]
        positive = positive and Md[i] > 0.0
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
        for e in range(PTR[j], PTR[j + 1]):
            i = IDX[e]
            w = Av[e] * minv[i]
            acc -= w * rhs[i]
            for f in range(CPTR[i], CPTR[i + 1]):
                b = pos[CROW[f]]
                if b >= 0:
                    S[a, b] += w * Av[CPOS[f]]
            for s in range(slip_j.shape[0]):
                js = slip_j[s]
                # A[js, i]: row js's entry in column i, if it has one
                for g in range(PTR[js], PTR[js + 1]):
                    if IDX[g] == i:
                        S[a, slip_k[s]] -= w * mu[js] * slip_c[s] * Av[g]
        r[a] = acc
    if slip_j.shape[0] == 0 and positive:
        # S = A_r M^-1 A_r^T is symmetric positive definite (M_ii > 0, independent
        # rows): Cholesky, half the work of elimination and no pivot search.
        if not cholesky_inplace(S, r):  # dependent rows here: let the full KKT decide
            M, A = dense_matrices(Md, Av)
            return kkt_dense(M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c)
    else:
        gauss_inplace(S, r)  # r becomes lambda
    for a in range(na):
        j = rows[a]
        out[n + a] = r[a]
        for e in range(PTR[j], PTR[j + 1]):
            out[IDX[e]] += Av[e] * r[a]
    for s in range(slip_j.shape[0]):
        j = slip_j[s]
        c = mu[j] * slip_c[s] * r[slip_k[s]]
        for e in range(PTR[j], PTR[j + 1]):
            out[IDX[e]] -= c * Av[e]
    for i in range(n):
        out[i] *= minv[i]
    return out


kkt_solve = kkt_schur if DIAGONAL else kkt_dense


def kkt_state(t, q, v, p, rows, slip_j, slip_k, slip_c):
    """[q''; lambda_rows] at a state: the generated functions and the solve, over the
    structural nonzeros when ``DIAGONAL`` (no n x n M or m x n A filled per call)."""
    if DIAGONAL:
        Md, rhs, Av, gam, mu = dynamics_sparse(t, q, v, p)
        return kkt_schur_sparse(Md, rhs, Av, gam, mu, rows, slip_j, slip_k, slip_c)
    M, rhs, A, gam, mu = dynamics(t, q, v, p)
    return kkt_dense(M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c)


def rhs_kernel(t, y, p, rows, slip_j, slip_k, slip_c):
    """y' = [v; q''] on a mode's active rows."""
    n = y.shape[0] // 2
    q = y[:n].copy()
    v = y[n:].copy()
    sol = kkt_state(t, q, v, p, rows, slip_j, slip_k, slip_c)
    out = np.empty(2 * n)
    for i in range(n):
        out[i] = v[i]
        out[n + i] = sol[i]
    return out


def accelerations(t, y, p):
    """[q''; lambda] with every constraint active."""
    n = y.shape[0] // 2
    # writable arrays of rhs_kernel's types, so that numba reuses the compiled solve
    # (read-only constant arrays would compile it again: 2 s more)
    none = np.zeros(0, dtype=np.int64)
    rows = np.arange(PTR.shape[0] - 1)
    return kkt_state(t, y[:n].copy(), y[n:].copy(), p, rows, none, none, np.zeros(0))


# BATCH
# The compiled integration loop of :func:`lamech.numeric.integrate_batch`: SciPy's DOP853
# (same tableau, error norm and step-size control) with the projection onto the
# constraints after every accepted step. Without numba the same functions run as Python
# (``accelerations`` and ``constraints`` then the NumPy ones, ``prange`` is ``range``).
def batch_solve(K, r):
    """K x = r by elimination, K and r kept."""
    x = r.copy()
    gauss_inplace(K.copy(), x)
    return x


def batch_deriv(t, y, p, out):
    """out = [v; q''] with every constraint active."""
    n = y.shape[0] // 2
    sol = accelerations(t, y, p)
    for i in range(n):
        out[i] = y[n + i]
        out[n + i] = sol[i]


def batch_project(t, y, p):
    """Positions onto f = 0 (Gauss-Newton, minimum norm), then velocities onto
    A v + b = 0; in place. The compiled twin of :mod:`._project` with
    the Euclidean metric, at most PROJECTION_ITERATIONS Gauss-Newton steps."""
    n = y.shape[0] // 2
    q = y[:n].copy()
    for _ in range(PROJECTION_ITERATIONS):
        f, A, b = constraints(t, q, p)
        m = f.shape[0]
        big = 0.0
        for j in range(m):
            big = max(big, abs(f[j]))
        if big <= 1e-15 * (1.0 + np.max(np.abs(q))):
            break
        G = A @ A.T
        w = batch_solve(G, f)
        q -= A.T @ w
    f, A, b = constraints(t, q, p)
    v = y[n:].copy()
    G = A @ A.T
    w = batch_solve(G, A @ v + b)
    v -= A.T @ w
    y[:n] = q
    y[n:] = v


def batch_run_one(y0, p, t_end, rtol, atol, max_steps, A, B, C, E3, E5):
    N = y0.shape[0]
    y = y0.copy()
    t = 0.0
    K = np.zeros((STAGES + 1, N))
    f = np.zeros(N)
    batch_deriv(t, y, p, f)
    # initial step (Hairer's heuristic, as scipy's select_initial_step)
    scale = atol + np.abs(y) * rtol
    d0 = np.sqrt(np.mean((y / scale) ** 2))
    d1 = np.sqrt(np.mean((f / scale) ** 2))
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    y1 = y + h0 * f
    f1 = np.zeros(N)
    batch_deriv(t + h0, y1, p, f1)
    d2 = np.sqrt(np.mean(((f1 - f) / scale) ** 2)) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    h = min(100 * h0, h1, t_end)
    steps = 0
    ynew = np.zeros(N)
    while t < t_end:
        if steps >= max_steps:
            return y * np.nan, -1
        h = min(h, t_end - t)
        if h < 10 * np.abs(np.nextafter(t, np.inf) - t):
            return y * np.nan, -1
        K[0] = f
        for s in range(1, STAGES):
            dy = np.zeros(N)
            for k in range(s):
                if A[s, k] != 0.0:
                    dy += A[s, k] * K[k]
            batch_deriv(t + C[s] * h, y + h * dy, p, K[s])
        acc = np.zeros(N)
        for k in range(STAGES):
            acc += B[k] * K[k]
        ynew[:] = y + h * acc
        batch_deriv(t + h, ynew, p, K[STAGES])
        scale = atol + np.maximum(np.abs(y), np.abs(ynew)) * rtol
        err5 = np.zeros(N)
        err3 = np.zeros(N)
        for k in range(STAGES + 1):
            err5 += E5[k] * K[k]
            err3 += E3[k] * K[k]
        e5 = np.sum((err5 / scale) ** 2)
        e3 = np.sum((err3 / scale) ** 2)
        if e5 == 0.0 and e3 == 0.0:
            err = 0.0
        else:
            err = abs(h) * e5 / np.sqrt((e5 + 0.01 * e3) * N)
        if not np.isfinite(err):
            return y * np.nan, -1
        if err < 1.0:
            factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-1.0 / 8.0))
            t = t + h
            y[:] = ynew
            batch_project(t, y, p)
            batch_deriv(t, y, p, f)
            h = h * factor
            steps += 1
        else:
            h = h * max(0.2, 0.9 * err ** (-1.0 / 8.0))
    return y, steps


def batch_run(Y0, P, t_end, rtol, atol, max_steps, A, B, C, E3, E5, out, steps):
    """Every row of Y0 (parameters P) to t_end, over the cores (numba's prange)."""
    for b in prange(Y0.shape[0]):
        y, s = batch_run_one(Y0[b], P[b], t_end, rtol, atol, max_steps, A, B, C, E3, E5)
        out[b] = y
        steps[b] = s


def batch_run_serial(Y0, P, t_end, rtol, atol, max_steps, A, B, C, E3, E5, out, steps):
    """:func:`batch_run` in one thread, for a batch smaller than the thread count (its own
    function: numba's cache keys a function by its name, not by ``parallel``)."""
    for b in range(Y0.shape[0]):
        y, s = batch_run_one(Y0[b], P[b], t_end, rtol, atol, max_steps, A, B, C, E3, E5)
        out[b] = y
        steps[b] = s
