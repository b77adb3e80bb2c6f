"""The system's functions and the KKT solves at a state, the right-hand sides.

The KKT system  M q'' - A_r^T lambda + sum_s c_s A_{j_s}^T lambda_{k_s} = rhs,
A_r q'' = -gamma_r  on the active ``rows`` (a slipping friction row j_s on the normal
row at position k_s adds its kinetic friction, c_s = mu_j * slip_c[s]): the compiled
twin of :func:`.._kkt.kkt_solve_numpy` (the same system, the same numbers to rounding).

Where M is diagonal (``sy[0]``, known from the symbolic M, as for particles and planar
bodies in maximal coordinates): while every M_ii is nonzero, the Schur complement
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

from ...linalg import cholesky_inplace, gauss_inplace
from .codes import borrowed


# KERNELS
def borrowed_record(sy):
    """The system record with its arrays borrowed (:func:`.codes.borrowed`), for a
    function whose caller holds ``sy`` for the call."""
    return (sy[0], borrowed(sy[1]), borrowed(sy[2]), borrowed(sy[3]), borrowed(sy[4]),
            borrowed(sy[5]), sy[6], sy[7], sy[8], sy[9], sy[10], sy[11], sy[12],
            borrowed(sy[13]))  # fmt: skip


def borrowed_act(act):
    """A mode's active set borrowed (:func:`.codes.borrowed`), as :func:`borrowed_record`."""
    return (borrowed(act[0]), borrowed(act[1]), borrowed(act[2]), borrowed(act[3]),
            borrowed(act[4]))  # fmt: skip


# Where the system's functions are C (``sy[12]``, :mod:`.._cc`), they fill arrays zeroed
# here, passed by address; else they return their arrays (numba cfuncs, or Python).
def dynamics(sy, t, q, v, p):
    """(M, rhs, A, gamma, mu) of the system."""
    if sy[12]:
        n, m = q.shape[0], sy[1].shape[0] - 1
        M, rhs, A = np.zeros((n, n)), np.zeros(n), np.zeros((m, n))
        gam, mu = np.zeros(m), np.zeros(m)
        sy[6](t, q.ctypes.data, v.ctypes.data, p.ctypes.data, M.ctypes.data,
              rhs.ctypes.data, A.ctypes.data, gam.ctypes.data, mu.ctypes.data)  # fmt: skip
        return M, rhs, A, gam, mu
    return sy[6](t, q, v, p)


def dynamics_sparse(sy, t, q, v, p):
    """(diagonal of M, rhs, A's nonzeros in CSR order, gamma, mu)."""
    return dynamics_sparse_in(sy, t, q, v, p, np.empty(dynamics_space(sy, q.shape[0])))


def dynamics_space(sy, n):
    """The floats :func:`dynamics_sparse_in` fills for n coordinates: 2n + nnz(A) + 2m
    (the one place that says so: numba does not check the bounds of a view)."""
    m = sy[1].shape[0] - 1
    return 2 * n + sy[1][m] + 2 * m


def dynamics_sparse_in(sy, t, q, v, p, buf):
    """:func:`dynamics_sparse`; where the functions are C, the five arrays are views into
    ``buf`` (2n + nnz(A) + 2m long, zeroed here): allocations were a quarter of a compiled
    step, and this runs 13 times a step (perf, 2026-11-27)."""
    if sy[12]:
        n, m = q.shape[0], sy[1].shape[0] - 1
        z = sy[1][m]
        buf[:] = 0.0
        Md, rhs, Av = buf[:n], buf[n : 2 * n], buf[2 * n : 2 * n + z]
        gam, mu = buf[2 * n + z : 2 * n + z + m], buf[2 * n + z + m :]
        sy[7](t, q.ctypes.data, v.ctypes.data, p.ctypes.data, Md.ctypes.data,
              rhs.ctypes.data, Av.ctypes.data, gam.ctypes.data, mu.ctypes.data)  # fmt: skip
        return Md, rhs, Av, gam, mu
    return sy[7](t, q, v, p)


def constraints(sy, t, q, p):
    """(f, A, b) with F = A v + b."""
    if sy[12]:
        n, m = q.shape[0], sy[1].shape[0] - 1
        f, A, b = np.zeros(m), np.zeros((m, n)), np.zeros(m)
        sy[8](t, q.ctypes.data, p.ctypes.data, f.ctypes.data, A.ctypes.data, b.ctypes.data)
        return f, A, b
    return sy[8](t, q, p)


def energy(sy, t, q, v, p):
    """(T, V)."""
    if sy[12]:
        E = np.zeros(2)
        sy[9](t, q.ctypes.data, v.ctypes.data, p.ctypes.data, E.ctypes.data)
        return E
    return sy[9](t, q, v, p)


def restitution(sy, t, q, p):
    """e per constraint."""
    if sy[12]:
        e = np.zeros(sy[1].shape[0] - 1)
        sy[10](t, q.ctypes.data, p.ctypes.data, e.ctypes.data)
        return e
    return sy[10](t, q, p)


def switches(sy, t, q, v, p):
    """The inputs' switching functions s (a branch switches where one crosses 0)."""
    if sy[12]:
        s = np.zeros(sy[13].shape[0])
        sy[11](t, q.ctypes.data, v.ctypes.data, p.ctypes.data, s.ctypes.data)
        return s
    return sy[11](t, q, v, p)


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


def kkt_schur(sy, M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c):
    """:func:`kkt_schur_sparse` on dense M and A (the simulator's solve at a state)."""
    PTR, IDX = sy[1], sy[2]
    n = rhs.shape[0]
    Md = np.empty(n)
    for i in range(n):
        Md[i] = M[i, i]
    Av = np.empty(IDX.shape[0])
    for j in range(PTR.shape[0] - 1):
        for e in range(PTR[j], PTR[j + 1]):
            Av[e] = A[j, IDX[e]]
    return kkt_schur_sparse(sy, Md, rhs, Av, gam, mu, rows, slip_j, slip_k, slip_c)


def dense_matrices(sy, Md, Av):
    """M and A as matrices from their structural nonzeros."""
    PTR, IDX = sy[1], sy[2]
    n = Md.shape[0]
    M = np.zeros((n, n))
    for i in range(n):
        M[i, i] = Md[i]
    A = np.zeros((PTR.shape[0] - 1, n))
    for j in range(PTR.shape[0] - 1):
        for e in range(PTR[j], PTR[j + 1]):
            A[j, IDX[e]] = Av[e]
    return M, A


def kkt_schur_sparse(sy, Md, rhs, Av, gam, mu, rows, slip_j, slip_k, slip_c):
    """The Schur complement over the structural nonzeros: M's diagonal ``Md`` and A's
    nonzeros ``Av`` (by row: PTR, IDX; by column: CPTR, CROW, and CPOS their positions
    in Av). Nothing of size n x n or m x n is formed, unless a zero M_ii or dependent rows
    send it to the full KKT matrix. (:func:`kkt_schur_sparse_in`, its space made here.)"""
    m = sy[1].shape[0] - 1
    work, iwork = np.empty(schur_space(sy, rhs.shape[0])), np.empty(m, dtype=np.int64)
    return kkt_schur_sparse_in(sy, Md, rhs, Av, gam, mu, rows, slip_j, slip_k, slip_c, work,
                               iwork)  # fmt: skip


def schur_space(sy, n):
    """The floats :func:`kkt_schur_sparse_in` works in for n coordinates: 2n + 2m."""
    return 2 * n + 2 * (sy[1].shape[0] - 1)


def kkt_schur_sparse_in(sy, Md, rhs, Av, gam, mu, rows, slip_j, slip_k, slip_c, work, iwork):
    """:func:`kkt_schur_sparse` in the space ``work`` (2n + 2m floats) and ``iwork`` (m
    integers): M's inverse, the solution (returned: a view into ``work``) and lambda's
    right-hand side there, each row's position among the active ones in ``iwork``. Runs
    13 times a step: its arguments are borrowed (:func:`.codes.borrowed`; the caller
    holds them), but not ``work``, a view of which it returns: where the caller made
    ``work`` (:func:`kkt_schur_sparse`), the view keeps it alive; where the caller lent
    it borrowed (a DOP853 trial's space), the view is borrowed too."""
    Md, rhs, Av, gam, mu = borrowed(Md), borrowed(rhs), borrowed(Av), borrowed(gam), borrowed(mu)
    rows, slip_j = borrowed(rows), borrowed(slip_j)
    slip_k, slip_c = borrowed(slip_k), borrowed(slip_c)
    iwork = borrowed(iwork)
    PTR, IDX, CPTR, CROW, CPOS = sy[1], sy[2], sy[3], sy[4], sy[5]
    n = rhs.shape[0]
    m = PTR.shape[0] - 1
    na = rows.shape[0]
    minv = work[:n]
    positive = True
    for i in range(n):
        if Md[i] == 0.0:
            M, A = dense_matrices(sy, Md, Av)
            return kkt_dense(M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c)
        minv[i] = 1.0 / Md[i]
        positive = positive and Md[i] > 0.0
    out = work[n : 2 * n + na]
    for i in range(n):
        out[i] = rhs[i]
    if na == 0:
        for i in range(n):
            out[i] *= minv[i]
        return out
    pos = iwork  # position of each constraint among the rows
    pos[:] = -1
    for a in range(na):
        pos[rows[a]] = a
    S = np.zeros((na, na))
    r = work[2 * n + m : 2 * n + m + na]
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
            M, A = dense_matrices(sy, Md, Av)
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


def kkt_solve(sy, M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c):
    """The solve at a state: :func:`kkt_schur` where M is diagonal (``sy[0]``), else
    :func:`kkt_dense`."""
    if sy[0]:
        return kkt_schur(sy, M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c)
    return kkt_dense(M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c)


def kkt_state(sy, t, q, v, p, rows, slip_j, slip_k, slip_c):
    """[q''; lambda_rows] at a state: the generated functions and the solve, over the
    structural nonzeros where M is diagonal (no n x n M or m x n A filled per call)."""
    if sy[0]:
        Md, rhs, Av, gam, mu = dynamics_sparse(sy, t, q, v, p)
        return kkt_schur_sparse(sy, Md, rhs, Av, gam, mu, rows, slip_j, slip_k, slip_c)
    M, rhs, A, gam, mu = dynamics(sy, t, q, v, p)
    return kkt_dense(M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c)


def rhs_space(sy, N):
    """(floats, integers) of the space :func:`rhs_into` works in for a state of size N."""
    n = N // 2
    return N + dynamics_space(sy, n) + schur_space(sy, n), sy[1].shape[0] - 1


def rhs_into(sy, t, y, p, rows, slip_j, slip_k, slip_c, out, work, iwork):
    """y' = [v; q''] on a mode's active rows, into ``out`` (a DOP853 stage's row), in the
    space ``work``, ``iwork`` (:func:`rhs_space`; a step's 13 right-hand sides make no
    array where the system's functions are C and M is diagonal)."""
    N = y.shape[0]
    n = N // 2
    yc = work[:N]  # q and v contiguous, whatever y is
    yc[:] = y
    q = yc[:n]
    v = yc[n:]
    if sy[0]:
        end = N + dynamics_space(sy, n)
        Md, rhs, Av, gam, mu = dynamics_sparse_in(sy, t, q, v, p, work[N:end])
        sol = kkt_schur_sparse_in(sy, Md, rhs, Av, gam, mu, rows, slip_j, slip_k, slip_c,
                                  work[end:], iwork)  # fmt: skip
    else:
        M, rhs, A, gam, mu = dynamics(sy, t, q, v, p)
        sol = kkt_dense(M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c)
    for i in range(n):
        out[i] = v[i]
        out[n + i] = sol[i]


def rhs_kernel(sy, t, y, p, rows, slip_j, slip_k, slip_c):
    """y' = [v; q''] on a mode's active rows (:func:`rhs_into`)."""
    out = np.empty(y.shape[0])
    floats, ints = rhs_space(sy, y.shape[0])
    work, iwork = np.empty(floats), np.empty(ints, dtype=np.int64)
    rhs_into(sy, t, y, p, rows, slip_j, slip_k, slip_c, out, work, iwork)
    return out


def accelerations(sy, t, y, p):
    """[q''; lambda] with every constraint active."""
    n = y.shape[0] // 2
    # writable arrays of rhs_kernel's types, so that numba reuses the compiled solve
    # (read-only constant arrays would compile it again: 2 s more)
    none = np.zeros(0, dtype=np.int64)
    rows = np.arange(sy[1].shape[0] - 1)
    return kkt_state(sy, t, y[:n].copy(), y[n:].copy(), p, rows, none, none, np.zeros(0))


def batch_solve(K, r):
    """K x = r by elimination, K and r kept."""
    x = r.copy()
    gauss_inplace(K.copy(), x)
    return x
