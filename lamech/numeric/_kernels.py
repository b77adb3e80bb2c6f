"""The kernels of the hot path: the KKT solves, DOP853's step, the batch loop and the loop
with events with its contact rules, as plain Python that numba compiles.

Every kernel below the ``KERNELS`` line takes the system record ``sy``
(:data:`SYSTEM_FIELDS`) first: the system's generated functions and its sparsity pattern
arrive as arguments, not as module globals, so that the same compiled code serves every
system. :mod:`._jitcache` compiles this text once per machine (numba's cache on disk),
with each system's functions as numba cfuncs (first-class functions of one signature);
:mod:`._batch` runs the same functions as Python around the NumPy ones (the same
numbers, slowly). The compiled solve is the twin of :func:`._kkt.kkt_solve_numpy` (the
same system, the same numbers to rounding):

The KKT system  M q'' - A_r^T lambda + sum_s c_s A_{j_s}^T lambda_{k_s} = rhs,
A_r q'' = -gamma_r  on the active ``rows`` (a slipping friction row j_s on the normal
row at position k_s adds its kinetic friction, c_s = mu_j * slip_c[s]).

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

from ..linalg import cholesky_inplace, gauss_inplace
from ._project import PROJECTION_ITERATIONS

__all__ = ["kernel_text", "SYSTEM_FIELDS", "STAGES", "PROJECTION_ITERATIONS"]

STAGES = 12
"""DOP853's number of stages (checked against SciPy's table in :mod:`._batch`)."""


SYSTEM_FIELDS = (
    "diagonal",
    "PTR",
    "IDX",
    "CPTR",
    "CROW",
    "CPOS",
    "dynamics",
    "dynamics_sparse",
    "constraints",
    "energy",
    "restitution",
)
"""The system record ``sy`` every kernel takes first, a tuple in this order: whether M
is diagonal, the sparsity pattern of A (:func:`._kkt.sparsity`), and the generated
functions of :mod:`._codegen` (``dynamics(t, q, v, p)`` -> (M, rhs, A, gamma,
mu); ``dynamics_sparse`` -> (M's diagonal, rhs, A's nonzeros in CSR order, gamma, mu);
``constraints(t, q, p)`` -> (f, A, b); ``energy(t, q, v, p)`` -> (T, V) as an array;
``restitution(t, q, p)`` -> e). Compiled, the functions are the addresses of numba
cfuncs of one signature for every system (:mod:`._jitcache`, :mod:`._fnptr`), so that the
loop is compiled once, not per system."""
prange = range  # numba.prange in the compiled module


def kernel_text() -> str:
    """The text of this file from its ``KERNELS`` line on: the kernels, the batch loop
    and the loop with events (:func:`._jitcache.engine_text` compiles it)."""
    import inspect
    import sys

    text = inspect.getsource(sys.modules[__name__])
    return text[text.index("\n# KERNELS\n") + 1 :]


# KERNELS
# The system record ``sy`` every kernel below takes first (see :data:`SYSTEM_FIELDS`): the
# system's generated functions (numba cfuncs when compiled: first-class functions, so
# that this code is compiled once for every system) and its sparsity pattern.
def dynamics(sy, t, q, v, p):
    """(M, rhs, A, gamma, mu) of the system."""
    return sy[6](t, q, v, p)


def dynamics_sparse(sy, t, q, v, p):
    """(diagonal of M, rhs, A's nonzeros in CSR order, gamma, mu)."""
    return sy[7](t, q, v, p)


def constraints(sy, t, q, p):
    """(f, A, b) with F = A v + b."""
    return sy[8](t, q, p)


def energy(sy, t, q, v, p):
    """(T, V)."""
    return sy[9](t, q, v, p)


def restitution(sy, t, q, p):
    """e per constraint."""
    return sy[10](t, q, p)


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
    send it to the full KKT matrix."""
    PTR, IDX, CPTR, CROW, CPOS = sy[1], sy[2], sy[3], sy[4], sy[5]
    n = rhs.shape[0]
    m = PTR.shape[0] - 1
    na = rows.shape[0]
    minv = np.empty(n)
    positive = True
    for i in range(n):
        if Md[i] == 0.0:
            M, A = dense_matrices(sy, Md, Av)
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


def rhs_kernel(sy, t, y, p, rows, slip_j, slip_k, slip_c):
    """y' = [v; q''] on a mode's active rows."""
    n = y.shape[0] // 2
    q = y[:n].copy()
    v = y[n:].copy()
    sol = kkt_state(sy, t, q, v, p, rows, slip_j, slip_k, slip_c)
    out = np.empty(2 * n)
    for i in range(n):
        out[i] = v[i]
        out[n + i] = sol[i]
    return out


def accelerations(sy, t, y, p):
    """[q''; lambda] with every constraint active."""
    n = y.shape[0] // 2
    # writable arrays of rhs_kernel's types, so that numba reuses the compiled solve
    # (read-only constant arrays would compile it again: 2 s more)
    none = np.zeros(0, dtype=np.int64)
    rows = np.arange(sy[1].shape[0] - 1)
    return kkt_state(sy, t, y[:n].copy(), y[n:].copy(), p, rows, none, none, np.zeros(0))


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


def batch_deriv(sy, t, y, p, out):
    """out = [v; q''] with every constraint active."""
    n = y.shape[0] // 2
    sol = accelerations(sy, t, y, p)
    for i in range(n):
        out[i] = y[n + i]
        out[n + i] = sol[i]


def batch_project(sy, t, y, p):
    """Positions onto f = 0 (Gauss-Newton, minimum norm), then velocities onto
    A v + b = 0; in place. The compiled twin of :mod:`._project` with
    the Euclidean metric, at most PROJECTION_ITERATIONS Gauss-Newton steps."""
    n = y.shape[0] // 2
    q = y[:n].copy()
    for _ in range(PROJECTION_ITERATIONS):
        f, A, b = constraints(sy, t, q, p)
        m = f.shape[0]
        big = 0.0
        for j in range(m):
            big = max(big, abs(f[j]))
        if big <= 1e-15 * (1.0 + np.max(np.abs(q))):
            break
        G = A @ A.T
        w = batch_solve(G, f)
        q -= A.T @ w
    f, A, b = constraints(sy, t, q, p)
    v = y[n:].copy()
    G = A @ A.T
    w = batch_solve(G, A @ v + b)
    v -= A.T @ w
    y[:n] = q
    y[n:] = v


def dop853_trial(
    sy, t, y, f, h, p, rows, slip_j, slip_k, slip_c, rtol, atol, A, B, C, E3, E5, K, ynew
):
    """One DOP853 step of size h from (t, y) with y' = f there, on a mode's active rows:
    the stages into K, the solution into ``ynew``; returns SciPy's error norm (< 1:
    accept). The one step of both loops, the batch's and the one with events."""
    N = y.shape[0]
    K[0] = f
    for s in range(1, STAGES):
        dy = np.zeros(N)
        for k in range(s):
            if A[s, k] != 0.0:
                dy += A[s, k] * K[k]
        K[s] = rhs_kernel(sy, t + C[s] * h, y + h * dy, p, rows, slip_j, slip_k, slip_c)
    acc = np.zeros(N)
    for k in range(STAGES):
        acc += B[k] * K[k]
    ynew[:] = y + h * acc
    K[STAGES] = rhs_kernel(sy, t + h, ynew, p, rows, slip_j, slip_k, slip_c)
    scale = atol + np.maximum(np.abs(y), np.abs(ynew)) * rtol
    err5 = np.zeros(N)
    err3 = np.zeros(N)
    for k in range(STAGES + 1):
        err5 += E5[k] * K[k]
        err3 += E3[k] * K[k]
    e5 = np.sum((err5 / scale) ** 2)
    e3 = np.sum((err3 / scale) ** 2)
    if e5 == 0.0 and e3 == 0.0:
        return 0.0
    return abs(h) * e5 / np.sqrt((e5 + 0.01 * e3) * N)


def batch_run_one(sy, y0, p, t_end, rtol, atol, max_steps, A, B, C, E3, E5):
    N = y0.shape[0]
    y = y0.copy()
    t = 0.0
    K = np.zeros((STAGES + 1, N))
    f = np.zeros(N)
    batch_deriv(sy, t, y, p, f)
    rows = np.arange(sy[1].shape[0] - 1)  # every constraint active
    none = np.zeros(0, dtype=np.int64)
    nothing = np.zeros(0)
    h = ev_first_step(sy, t, y, f, p, rows, none, none, nothing, t_end, np.inf, rtol, atol)
    steps = 0
    ynew = np.zeros(N)
    while t < t_end:
        if steps >= max_steps:
            return y * np.nan, -1
        h = min(h, t_end - t)
        if h < 10 * np.abs(np.nextafter(t, np.inf) - t):
            return y * np.nan, -1
        err = dop853_trial(
            sy, t, y, f, h, p, rows, none, none, nothing, rtol, atol, A, B, C, E3, E5, K, ynew
        )
        if not np.isfinite(err):
            return y * np.nan, -1
        if err < 1.0:
            factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-1.0 / 8.0))
            t = t + h
            y[:] = ynew
            batch_project(sy, t, y, p)
            batch_deriv(sy, t, y, p, f)
            h = h * factor
            steps += 1
        else:
            h = h * max(0.2, 0.9 * err ** (-1.0 / 8.0))
    return y, steps


def batch_run(sy, Y0, P, t_end, rtol, atol, max_steps, A, B, C, E3, E5, out, steps):
    """Every row of Y0 (parameters P) to t_end, over the cores (numba's prange)."""
    for b in prange(Y0.shape[0]):
        y, s = batch_run_one(sy, Y0[b], P[b], t_end, rtol, atol, max_steps, A, B, C, E3, E5)
        out[b] = y
        steps[b] = s


def batch_run_serial(sy, Y0, P, t_end, rtol, atol, max_steps, A, B, C, E3, E5, out, steps):
    """:func:`batch_run` in one thread, for a batch smaller than the thread count (its own
    function: numba's cache keys a function by its name, not by ``parallel``)."""
    for b in range(Y0.shape[0]):
        y, s = batch_run_one(sy, Y0[b], P[b], t_end, rtol, atol, max_steps, A, B, C, E3, E5)
        out[b] = y
        steps[b] = s


# The compiled loop with events (lamech.numeric.integrate_events): the loop above with a
# contact and friction mode, the twin of lamech.numeric.simulate for the events it can
# apply (lift-off, slip, stick with its re-check and slip reversal, impact and contact
# with restitution and the Zeno accumulation; the initial mode and each event's
# settling), stopping with a fallback status where simulate's rules are not mirrored here
# (a singular impact matrix or a gap met below the surface (ST_CONTACT), an inside-step
# graze, too many events, a start off the constraints, a failure), so that the caller
# runs simulate for that case. The mode
# lives in arrays: ``kinds`` (3, m) int64 rows unilateral, holonomic, normal (-1: not
# friction); ``imode`` (4, m) int64 rows engaged, friction state (FR_*), contact armed,
# stick armed; ``fmode`` (5, m) rows sigma (slip sign), sN (sign of a bilateral normal),
# offset (f held while friction sticks), the accumulation time of a Zeno sequence's
# contact (NaN: none; Mode.accumulating) and the time of its impact.
EV_LIFT_OFF = 0
EV_CONTACT = 1
EV_SLIP = 2
EV_STICK = 3
EV_IMPACT = 4  # a bounce (only logged: the event watched is EV_CONTACT)
FR_NONE = 0
FR_STICK = 1
FR_SLIP = 2
FR_OFF = 3
ST_END = 0  # reached t_end
ST_FOUND = 1  # stopped once every wanted event was found
ST_CONTACT = 2  # fallbacks: a contact the loop cannot apply (singular, or met below the gap)
ST_STICK = 3  # unused: stick is mirrored (the code kept for the status names)
ST_EVENTS = 4  # more events than the record holds
ST_STEP = 5  # step size collapsed, or too many steps
ST_GROWTH = 6  # the state blows up or is not finite
ST_PENETRATION = 7  # a released constraint passed through
ST_GRAZE = 8  # a released gap turns within a step (simulate's inside_step)
ST_SETTLE = 9  # the mode does not settle
ST_START = 10  # the start violates the constraints (simulate says how)
ST_SINGULAR = 11  # the KKT solve fails at an accepted state
ST_BUDGET = 12  # ev_segment: its steps done, or its event record nearly full (go on)
DT_NONE = 0  # an event's detail (Event's optional fields): none
DT_MULTIPLIER = 1  # the pulling multiplier of a lift-off in settling
DT_RATIO = 2  # |F| / (mu N) of a slip in settling
DT_REVERSAL = 3  # a stick that could not hold: the slip went on (1.0 reversed, 0.0 not)
DT_INITIAL = 4  # a slip at the start
DT_IMPACT = 5  # an impact or contact: impulse, velocity_before, restitution (columns 1-3)
DT_ACCUMULATION = 6  # a contact at the end of a Zeno sequence: restitution, accumulation
DT_IMPULSE = 7  # a slip through an impact: its impulse


def ev_active(j, kinds, imode):
    """Constraint j's row is in the KKT system (Mode.row_active)."""
    for _ in range(kinds.shape[1] + 1):
        k = kinds[2, j]
        if k < 0:
            if kinds[0, j] == 1:
                return imode[0, j] == 1
            return True
        if imode[1, j] != FR_STICK:
            return False
        j = k
    return False


def ev_mode(kinds, imode, fmode):
    """(rows, hrows, slip_j, slip_k, slip_c) of the mode (Mode.rebuild; friction on a
    released normal goes off, and sticks again when it engages)."""
    m = kinds.shape[1]
    rows = np.empty(m, dtype=np.int64)
    na = 0
    for j in range(m):
        k = kinds[2, j]
        if k >= 0:
            if not ev_active(k, kinds, imode):
                imode[1, j] = FR_OFF
            elif imode[1, j] == FR_OFF:
                imode[1, j] = FR_STICK
            if imode[1, j] == FR_STICK:
                rows[na] = j
                na += 1
        elif ev_active(j, kinds, imode):
            rows[na] = j
            na += 1
    pos = np.full(m, -1, dtype=np.int64)
    nh = 0
    for a in range(na):
        pos[rows[a]] = a
        if kinds[1, rows[a]] == 1:
            nh += 1
    hrows = np.empty(nh, dtype=np.int64)
    nh = 0
    for a in range(na):
        if kinds[1, rows[a]] == 1:
            hrows[nh] = rows[a]
            nh += 1
    ns = 0
    for j in range(m):
        if kinds[2, j] >= 0 and imode[1, j] == FR_SLIP:
            ns += 1
    slip_j = np.empty(ns, dtype=np.int64)
    slip_k = np.empty(ns, dtype=np.int64)
    slip_c = np.empty(ns)
    ns = 0
    for j in range(m):
        if kinds[2, j] >= 0 and imode[1, j] == FR_SLIP:
            slip_j[ns] = j
            slip_k[ns] = pos[kinds[2, j]]
            slip_c[ns] = fmode[1, j] * fmode[0, j]
            ns += 1
    return rows[:na].copy(), hrows, slip_j, slip_k, slip_c


def ev_watch(kinds, imode):
    """(kinds, constraints) of the events the mode watches (Mode._watched)."""
    m = kinds.shape[1]
    wk = np.empty(2 * m, dtype=np.int64)
    wj = np.empty(2 * m, dtype=np.int64)
    nw = 0
    for j in range(m):
        if kinds[0, j] == 1:
            wk[nw] = EV_LIFT_OFF if imode[0, j] == 1 else EV_CONTACT
            wj[nw] = j
            nw += 1
        if kinds[2, j] >= 0:
            if imode[1, j] == FR_STICK:
                wk[nw] = EV_SLIP
                wj[nw] = j
                nw += 1
            elif imode[1, j] == FR_SLIP:
                wk[nw] = EV_STICK
                wj[nw] = j
                nw += 1
    return wk[:nw].copy(), wj[:nw].copy()


def ev_lam(sy, t, y, p, m, rows, slip_j, slip_k, slip_c):
    """(q'', lambda (m,): NaN where inactive, the kinetic friction where slipping, mu)
    on the mode's rows (Run.kkt)."""
    n = y.shape[0] // 2
    q = y[:n].copy()
    v = y[n:].copy()
    M, rhs, A, gam, mu = dynamics(sy, t, q, v, p)
    sol = kkt_solve(sy, M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c)
    lam = np.full(m, np.nan)
    for a in range(rows.shape[0]):
        lam[rows[a]] = sol[n + a]
    for s in range(slip_j.shape[0]):
        lam[slip_j[s]] = -mu[slip_j[s]] * slip_c[s] * sol[n + slip_k[s]]
    return sol[:n].copy(), lam, mu


def ev_values(
    sy, t, y, p, wk, wj, kinds, imode, fmode, rows, slip_j, slip_k, slip_c, arm_pos, arm_vel
):
    """The watched events' functions at (t, y) (_detect.event_values): lambda_j of an
    engaged unilateral (lift-off), f_j of a released one (contact), mu sN N - |lambda_j| of
    sticking friction (slip), sigma s_j of slipping friction (stick); a disarmed contact
    or stick shifted up by its threshold."""
    nw = wk.shape[0]
    out = np.empty(nw)
    if nw == 0:
        return out
    n = y.shape[0] // 2
    m = kinds.shape[1]
    qdd, lam, mu = ev_lam(sy, t, y, p, m, rows, slip_j, slip_k, slip_c)
    f, A, b = constraints(sy, t, y[:n].copy(), p)
    for i in range(nw):
        kind = wk[i]
        j = wj[i]
        if kind == EV_LIFT_OFF:
            out[i] = lam[j]
        elif kind == EV_CONTACT:
            out[i] = f[j] + (0.0 if imode[2, j] == 1 else arm_pos)
        elif kind == EV_SLIP:
            out[i] = mu[j] * fmode[1, j] * lam[kinds[2, j]] - abs(lam[j])
        else:
            s = b[j]
            for c in range(n):
                s += A[j, c] * y[n + c]
            out[i] = fmode[0, j] * s + (0.0 if imode[3, j] == 1 else arm_vel)
    return out


def ev_correction(W, Ar, r):
    """dx minimising dx^T W dx subject to Ar dx = r (the KKT system, by elimination);
    Euclidean where that is singular (linalg.min_norm_correction, _project.Metric).
    Where W is diagonal and positive (particles and planar bodies in maximal
    coordinates), by the Schur complement dx = W^-1 Ar^T (Ar W^-1 Ar^T)^-1 r: a k-square
    solve instead of the (n + k)-square one (the 20-link chain's projection took most of
    a step's time)."""
    n = W.shape[0]
    k = Ar.shape[0]
    diagonal = True
    for i in range(n):
        if not W[i, i] > 0.0:
            diagonal = False
        for c in range(n):
            if c != i and W[i, c] != 0.0:
                diagonal = False
        if not diagonal:
            break
    if diagonal:
        ArW = np.empty((k, n))
        for a in range(k):
            for i in range(n):
                ArW[a, i] = Ar[a, i] / W[i, i]
        w = batch_solve(ArW @ Ar.T, r)
        if np.all(np.isfinite(w)):
            return ArW.T @ w
    K = np.zeros((n + k, n + k))
    x = np.zeros(n + k)
    for i in range(n):
        for c in range(n):
            K[i, c] = W[i, c]
    for a in range(k):
        x[n + a] = r[a]
        for i in range(n):
            K[i, n + a] = Ar[a, i]
            K[n + a, i] = Ar[a, i]
    gauss_inplace(K, x)
    if np.all(np.isfinite(x)):
        return x[:n].copy()
    G = Ar @ Ar.T
    w = batch_solve(G, r)
    return Ar.T @ w


def ev_project(sy, t, y, p, rows, hrows, offset):
    """y onto the mode's manifold, in place (_project in the mass-matrix metric):
    positions onto f_h = offset_h (Gauss-Newton), velocities onto A_r v + b_r = 0."""
    n = y.shape[0] // 2
    q = y[:n].copy()
    v = y[n:].copy()
    if hrows.shape[0] > 0:
        W = np.zeros((n, n))
        have_w = False
        for _ in range(PROJECTION_ITERATIONS):
            f, A, b = constraints(sy, t, q, p)
            r = np.empty(hrows.shape[0])
            big = 0.0
            for a in range(hrows.shape[0]):
                r[a] = -(f[hrows[a]] - offset[hrows[a]])
                big = max(big, abs(r[a]))
            scale = 1.0 + np.max(np.abs(q))
            if big <= 2e-16 * scale * max(1.0, np.max(np.abs(A))):
                break
            if not have_w:
                W = dynamics(sy, t, q, v, p)[0]
                have_w = True
            dq = ev_correction(W, A[hrows], r)
            q += dq
            if np.max(np.abs(dq)) <= 1e-16 * scale:
                break
    if rows.shape[0] > 0:
        f, A, b = constraints(sy, t, q, p)
        Ar = A[rows]
        r = -(Ar @ v + b[rows])
        if np.any(r != 0.0):
            W = dynamics(sy, t, q, v, p)[0]
            v += ev_correction(W, Ar, r)
    y[:n] = q
    y[n:] = v


def ev_dense(s, t_old, h, y_old, F):
    """DOP853's dense output at s (scipy's Dop853DenseOutput)."""
    x = (s - t_old) / h
    y = np.zeros(y_old.shape[0])
    P = F.shape[0]
    for i in range(P):
        y += F[P - 1 - i]
        if i % 2 == 0:
            y *= x
        else:
            y *= 1.0 - x
    y += y_old
    return y


def ev_brent(
    sy,
    i,
    xa,
    xb,
    t_old,
    h,
    y_old,
    F,
    p,
    wk,
    wj,
    kinds,
    imode,
    fmode,
    rows,
    slip_j,
    slip_k,
    slip_c,
    arm_pos,
    arm_vel,
):
    """Where event i's function crosses zero on the dense output in [xa, xb]: Brent's
    method as scipy.optimize.brentq (xtol 1e-15 max(1, |xb|), rtol 4 eps, 200
    iterations: _detect._root); xb where the ends have one sign."""
    xtol = 1e-15 * max(1.0, abs(xb))
    rtol = 4.0 * 2.220446049250313e-16
    xpre = xa
    xcur = xb
    fpre = ev_values(
        sy,
        xpre,
        ev_dense(xpre, t_old, h, y_old, F),
        p,
        wk,
        wj,
        kinds,
        imode,
        fmode,
        rows,
        slip_j,
        slip_k,
        slip_c,
        arm_pos,
        arm_vel,
    )[i]
    fcur = ev_values(
        sy,
        xcur,
        ev_dense(xcur, t_old, h, y_old, F),
        p,
        wk,
        wj,
        kinds,
        imode,
        fmode,
        rows,
        slip_j,
        slip_k,
        slip_c,
        arm_pos,
        arm_vel,
    )[i]
    if fpre == 0.0:
        return xpre
    if fcur == 0.0:
        return xcur
    if (fpre < 0.0) == (fcur < 0.0):
        return xb
    xblk = 0.0
    fblk = 0.0
    spre = 0.0
    scur = 0.0
    for _ in range(200):
        if fpre != 0.0 and fcur != 0.0 and (fpre < 0.0) != (fcur < 0.0):
            xblk = xpre
            fblk = fpre
            spre = xcur - xpre
            scur = spre
        if abs(fblk) < abs(fcur):
            xpre = xcur
            xcur = xblk
            xblk = xpre
            fpre = fcur
            fcur = fblk
            fblk = fpre
        delta = (xtol + rtol * abs(xcur)) / 2.0
        sbis = (xblk - xcur) / 2.0
        if fcur == 0.0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:
                stry = -fcur * (xcur - xpre) / (fcur - fpre)
            else:
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2.0 * abs(stry) < min(abs(spre), 3.0 * abs(sbis) - delta):
                spre = scur
                scur = stry
            else:
                spre = sbis
                scur = sbis
        else:
            spre = sbis
            scur = sbis
        xpre = xcur
        fpre = fcur
        if abs(scur) > delta:
            xcur += scur
        else:
            xcur += delta if sbis > 0.0 else -delta
        fcur = ev_values(
            sy,
            xcur,
            ev_dense(xcur, t_old, h, y_old, F),
            p,
            wk,
            wj,
            kinds,
            imode,
            fmode,
            rows,
            slip_j,
            slip_k,
            slip_c,
            arm_pos,
            arm_vel,
        )[i]
    return xcur


def ev_log(kind, j, t, y, want, found, ev_kind, ev_j, ev_t, ev_y, ev_x, code, value, nev):
    """Record event (kind, j) at (t, y) with its detail (``code``: DT_*, ``value``); mark
    the wanted events it is; the new count, or -1 when the record is full."""
    if nev >= ev_kind.shape[0]:
        return -1
    ev_kind[nev] = kind
    ev_j[nev] = j
    ev_t[nev] = t
    ev_y[nev, :] = y
    ev_x[nev, 0] = code
    ev_x[nev, 1] = value
    for c in range(2, ev_x.shape[1]):
        ev_x[nev, c] = 0.0
    for w in range(want.shape[1]):
        if want[0, w] == kind and (want[1, w] < 0 or want[1, w] == j):
            found[w] = True
    return nev + 1


def ev_settle(
    sy, t, y, p, kinds, imode, fmode, arm_vel, want, found, ev_kind, ev_j, ev_t, ev_y, ev_x, nev
):
    """Make the mode consistent at (t, y), in place (_switch.settle): release the
    unilateral constraint pulling hardest, else let the friction furthest beyond mu N
    slip, logging each; (count, 0) or (count, ST_EVENTS / ST_SETTLE / ST_SINGULAR)."""
    n = y.shape[0] // 2
    m = kinds.shape[1]
    for _ in range(4 * m + 4):
        rows, hrows, slip_j, slip_k, slip_c = ev_mode(kinds, imode, fmode)
        ev_project(sy, t, y, p, rows, hrows, fmode[2])
        qdd, lam, mu = ev_lam(sy, t, y, p, m, rows, slip_j, slip_k, slip_c)
        if not np.all(np.isfinite(qdd)):
            return nev, ST_SINGULAR
        scale = 0.0
        for j in range(m):
            if np.isfinite(lam[j]):
                scale = max(scale, abs(lam[j]))
        scale += 1.0
        for a in range(rows.shape[0]):
            j = rows[a]
            k = kinds[2, j]
            if k >= 0 and kinds[0, k] == 0 and lam[k] != 0.0:
                fmode[1, j] = np.copysign(1.0, lam[k])
        worst = 0.0
        jw = -1
        for a in range(rows.shape[0]):
            j = rows[a]
            if kinds[0, j] == 1 and lam[j] < -1e-12 * scale and lam[j] < worst:
                worst = lam[j]
                jw = j
        if jw >= 0:
            imode[0, jw] = 0
            imode[2, jw] = 0
            fmode[3, jw] = np.nan  # Mode.release
            nev = ev_log(
                EV_LIFT_OFF, jw, t, y, want, found, ev_kind, ev_j, ev_t, ev_y, ev_x, DT_MULTIPLIER,
                worst, nev,
            )  # fmt: skip
            if nev < 0:
                return 0, ST_EVENTS
            continue
        worst = 0.0
        jw = -1
        for a in range(rows.shape[0]):
            j = rows[a]
            k = kinds[2, j]
            if k >= 0:
                excess = abs(lam[j]) - mu[j] * fmode[1, j] * lam[k]
                if excess > 1e-12 * scale and excess > worst:
                    worst = excess
                    jw = j
        if jw >= 0:
            ratio = abs(lam[jw]) / max(abs(mu[jw] * lam[kinds[2, jw]]), 1e-300)
            f, A, b = constraints(sy, t, y[:n].copy(), p)
            s = b[jw]
            for c in range(n):
                s += A[jw, c] * y[n + c]
            if abs(s) <= arm_vel:
                fmode[0, jw] = -np.copysign(1.0, lam[jw])
            else:
                fmode[0, jw] = np.copysign(1.0, s)
            imode[1, jw] = FR_SLIP
            imode[3, jw] = 0
            nev = ev_log(
                EV_SLIP, jw, t, y, want, found, ev_kind, ev_j, ev_t, ev_y, ev_x, DT_RATIO, ratio,
                nev,
            )  # fmt: skip
            if nev < 0:
                return 0, ST_EVENTS
            continue
        return nev, 0
    return nev, ST_SETTLE


def ev_first_step(sy, t, y, f, p, rows, slip_j, slip_k, slip_c, t_end, max_step, rtol, atol):
    """scipy's select_initial_step for DOP853 (error estimator order 7)."""
    interval = abs(t_end - t)
    if interval == 0.0:
        return 0.0
    scale = atol + np.abs(y) * rtol
    d0 = np.sqrt(np.mean((y / scale) ** 2))
    d1 = np.sqrt(np.mean((f / scale) ** 2))
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    h0 = min(h0, interval)
    f1 = rhs_kernel(sy, t + h0, y + h0 * f, p, rows, slip_j, slip_k, slip_c)
    d2 = np.sqrt(np.mean(((f1 - f) / scale) ** 2)) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    return min(100.0 * h0, h1, interval, max_step)


def ev_all(found, to_end):
    """Every wanted event found (and no need to go on to t_end)."""
    if to_end or found.shape[0] == 0:
        return False
    for w in range(found.shape[0]):
        if not found[w]:
            return False
    return True


def ev_run_one(
    sy,
    y0,
    p,
    t_end,
    rtol,
    atol,
    max_step,
    max_steps,
    tab,
    kinds,
    imode,
    fmode,
    arm_pos,
    arm_vel,
    blow,
    pen,
    tol,
    want,
    to_end,
    impacts,
    ev_kind,
    ev_j,
    ev_t,
    ev_y,
    ev_x,
    y_out,
):
    """One run from t = 0, every constraint engaged and sticking: (t reached, status
    ST_*, events logged, steps); y_out the state at t. ``impacts``: apply impacts in
    the loop (else a located contact stops the run with ST_CONTACT)."""
    N = y0.shape[0]
    n = N // 2
    m = kinds.shape[1]
    y = y0.copy()
    t = 0.0
    y_out[:] = y
    found = np.zeros(want.shape[1], dtype=np.bool_)
    # the start (_switch.initial_mode): a unilateral constraint open or opening starts
    # released, friction with a slip velocity starts slipping; a start off the
    # constraints is left to simulate (which refuses it with the values)
    f0, A0, b0 = constraints(sy, t, y[:n].copy(), p)
    tol_q = tol * (1.0 + np.max(np.abs(y[:n])))
    F0 = np.empty(m)
    for j in range(m):
        F0[j] = b0[j]
        for c in range(n):
            F0[j] += A0[j, c] * y[n + c]
    for j in range(m):
        if kinds[0, j] == 1 and (f0[j] > tol_q or (abs(f0[j]) <= tol_q and F0[j] > tol_q)):
            imode[0, j] = 0
            imode[2, j] = 1 if f0[j] > arm_pos else 0
    rows = ev_mode(kinds, imode, fmode)[0]
    nev = 0
    for a in range(rows.shape[0]):
        j = rows[a]
        if kinds[2, j] >= 0 and abs(F0[j]) > tol_q:
            imode[1, j] = FR_SLIP
            fmode[0, j] = np.copysign(1.0, F0[j])
            imode[3, j] = 0
            ev_mode(kinds, imode, fmode)
            nev = ev_log(
                EV_SLIP, j, t, y, want, found, ev_kind, ev_j, ev_t, ev_y, ev_x, DT_INITIAL, 0.0,
                nev,
            )  # fmt: skip
            if nev < 0:
                return t, ST_EVENTS, 0, 0
    rows = ev_mode(kinds, imode, fmode)[0]
    for a in range(rows.shape[0]):
        j = rows[a]
        if (kinds[1, j] == 1 and abs(f0[j]) > tol_q) or abs(F0[j]) > tol_q:
            return t, ST_START, nev, 0
    nev, st = ev_settle(
        sy, t, y, p, kinds, imode, fmode, arm_vel, want, found, ev_kind, ev_j, ev_t, ev_y, ev_x, nev
    )
    y_out[:] = y
    if st != 0:
        return t, st, nev, 0
    if ev_all(found, to_end):
        return t, ST_FOUND, nev, 0
    blow_up = blow * (1.0 + np.max(np.abs(y)))
    none = np.zeros(0)
    io = np.zeros(4, dtype=np.int64)
    fo = np.zeros(2)
    t, st, nev, steps = ev_segment(
        sy,
        t, y, 0.0, t_end, p, rtol, atol, max_step, max_steps, tab,
        kinds, imode, fmode, arm_pos, arm_vel, blow_up, pen, want, found, to_end, impacts,
        ev_kind, ev_j, ev_t, ev_y, ev_x, nev, none, np.zeros((0, N)), np.zeros((0, m)),
        np.zeros((0, 4)), io, fo, y_out,
    )  # fmt: skip
    if st == ST_BUDGET:
        st = ST_STEP
    return t, st, nev, steps


def ev_sample(sy, t, y, p, m, rows, hrows, slip_j, slip_k, slip_c, offset, k, SY, SL, SR):
    """Sample k of a simulation at (t, y) (_record.Recorder.record): the state, lambda of
    the mode's KKT solve, the residuals max |f_h - offset_h| and max |A_r v + b_r|, T and
    V."""
    n = y.shape[0] // 2
    SY[k, :] = y
    SL[k, :] = ev_lam(sy, t, y, p, m, rows, slip_j, slip_k, slip_c)[1]
    q = y[:n].copy()
    v = y[n:].copy()
    rp = 0.0
    rv = 0.0
    if rows.shape[0] > 0:
        f, Ac, b = constraints(sy, t, q, p)
        for a in range(hrows.shape[0]):
            rp = max(rp, abs(f[hrows[a]] - offset[hrows[a]]))
        for a in range(rows.shape[0]):
            j = rows[a]
            s = b[j]
            for c in range(n):
                s += Ac[j, c] * v[c]
            rv = max(rv, abs(s))
    E = energy(sy, t, q, v, p)
    SR[k, 0] = rp
    SR[k, 1] = rv
    SR[k, 2] = E[0]
    SR[k, 3] = E[1]


def ev_dense_stages(sy, t, y, ynew, h, p, rows, slip_j, slip_k, slip_c, K, AX, CX, D, F):
    """The step's dense output into F: the 3 more stages of scipy's _dense_output_impl."""
    N = y.shape[0]
    for s in range(STAGES + 1, D.shape[1]):
        dy = np.zeros(N)
        for k in range(s):
            if AX[s - STAGES - 1, k] != 0.0:
                dy += AX[s - STAGES - 1, k] * K[k]
        K[s] = rhs_kernel(
            sy, t + CX[s - STAGES - 1] * h, y + h * dy, p, rows, slip_j, slip_k, slip_c
        )
    F[0] = ynew - y
    F[1] = h * K[0] - F[0]
    F[2] = 2.0 * F[0] - h * (K[STAGES] + K[0])
    for r in range(D.shape[0]):
        acc = np.zeros(N)
        for k in range(D.shape[1]):
            acc += D[r, k] * K[k]
        F[3 + r] = h * acc


def ev_impulses(sy, M, A, b, v, mu, rows, slip_j, slip_k, slip_c, j, target, extra, sj2, sc2):
    """(q'+, impulses (m,): NaN where none) of _switch._impulses' solve: the velocity
    jump on the active rows, j (its velocity form brought to ``target`` - b_j) and the
    rows ``extra``; the mode's slips and the friction rows ``sj2`` slipping through the
    impact on j (signs ``sc2``) take mu times their normal's impulse. NaN where the
    matrix is singular."""
    n = M.shape[0]
    m = A.shape[0]
    na = rows.shape[0]
    k = na + 1 + extra.shape[0]
    R = np.empty(k, dtype=np.int64)
    for a in range(na):
        R[a] = rows[a]
    R[na] = j
    for a in range(extra.shape[0]):
        R[na + 1 + a] = extra[a]
    G = np.empty((k, n))
    for a in range(k):
        for c in range(n):
            G[a, c] = A[R[a], c]
    for s in range(slip_j.shape[0]):
        for c in range(n):
            G[slip_k[s], c] -= mu[slip_j[s]] * slip_c[s] * A[slip_j[s], c]
    for s in range(sj2.shape[0]):
        for c in range(n):
            G[na, c] -= mu[sj2[s]] * sc2[s] * A[sj2[s], c]
    K = np.zeros((n + k, n + k))
    x = np.zeros(n + k)
    for i in range(n):
        for c in range(n):
            K[i, c] = M[i, c]
            x[i] += M[i, c] * v[c]
    for a in range(k):
        x[n + a] = -b[R[a]]
        for c in range(n):
            K[c, n + a] = -G[a, c]
            K[n + a, c] = A[R[a], c]
    x[n + na] = target
    gauss_inplace(K, x)
    imp = np.full(m, np.nan)
    for a in range(k):
        imp[R[a]] = x[n + a]
    for s in range(slip_j.shape[0]):
        imp[slip_j[s]] = -mu[slip_j[s]] * slip_c[s] * x[n + slip_k[s]]
    for s in range(sj2.shape[0]):
        imp[sj2[s]] = -mu[sj2[s]] * sc2[s] * x[n + na]
    return x[:n].copy(), imp


def ev_impact(
    sy,
    t, y, p, j, kinds, imode, fmode, arm_pos, arm_vel, want, found, ev_kind, ev_j, ev_t, ev_y,
    ev_x, nev,
):  # fmt: skip
    """Released unilateral j closes its gap at (t, y) (_switch.impact): the impulse on
    the active rows and j gives F_j+ = -e F_j-; it bounces (EV_IMPACT, the contact
    disarmed) or, when e = 0 or the bounce is too small to resolve, engages (EV_CONTACT)
    with its friction sticking or slipping through the impact; a Zeno sequence (0 < e <
    1, pressed back onto the surface) logs the bounce, engages, and keeps its
    accumulation time in fmode[3, j] (the impact's time in fmode[4, j]) for
    :func:`ev_accumulated`. y's velocities jump in place. (count, 0), or (count,
    ST_CONTACT) with nothing changed where the simulator must apply it (a singular
    matrix), or (0, ST_EVENTS)."""
    n = y.shape[0] // 2
    m = kinds.shape[1]
    q = y[:n].copy()
    v = y[n:].copy()
    f, A, b = constraints(sy, t, q, p)
    e = restitution(sy, t, q, p)[j]
    Fm = b[j]
    for c in range(n):
        Fm += A[j, c] * v[c]
    rows, hrows, slip_j, slip_k, slip_c = ev_mode(kinds, imode, fmode)
    M, rhs, Ad, gam, mu = dynamics(sy, t, q, v, p)
    qdd = kkt_solve(sy, M, rhs, Ad, gam, mu, rows, slip_j, slip_k, slip_c)[:n].copy()
    if not np.all(np.isfinite(qdd)):
        return nev, ST_CONTACT
    a_gap = gam[j]
    for c in range(n):
        a_gap += A[j, c] * qdd[c]
    a_gap = abs(a_gap)
    v_small = 2.0 * np.sqrt(2.0 * a_gap * arm_pos) + 10.0 * arm_vel
    engage = e == 0.0 or e * abs(Fm) <= v_small
    nf = 0
    if engage:
        for i in range(m):
            if kinds[2, i] == j:
                nf += 1
    frows = np.empty(nf, dtype=np.int64)
    nf = 0
    if engage:
        for i in range(m):
            if kinds[2, i] == j:
                frows[nf] = i
                nf += 1
    target = (0.0 if engage else -e * Fm) - b[j]
    none_i = np.zeros(0, dtype=np.int64)
    none_f = np.zeros(0)
    vp, imp = ev_impulses(
        sy, M, A, b, v, mu, rows, slip_j, slip_k, slip_c, j, target, frows, none_i, none_f
    )
    if not np.all(np.isfinite(vp)):
        return nev, ST_CONTACT
    trial = imp.copy()
    ns2 = 0
    for a in range(nf):
        i = frows[a]
        if abs(imp[i]) > mu[i] * imp[j] * (1.0 + 1e-9):
            ns2 += 1
    sj2 = np.empty(ns2, dtype=np.int64)
    sc2 = np.empty(ns2)
    stay = np.empty(nf - ns2, dtype=np.int64)
    ns2 = 0
    nst = 0
    for a in range(nf):
        i = frows[a]
        if abs(imp[i]) > mu[i] * imp[j] * (1.0 + 1e-9):
            sj2[ns2] = i
            sc2[ns2] = -np.copysign(1.0, imp[i])
            ns2 += 1
        else:
            stay[nst] = i
            nst += 1
    if ns2 > 0:
        vp, imp = ev_impulses(
            sy, M, A, b, v, mu, rows, slip_j, slip_k, slip_c, j, target, stay, sj2, sc2
        )
        if not np.all(np.isfinite(vp)):
            return nev, ST_CONTACT
    rest = -1.0
    vb = vp
    ib = 0.0
    if engage and 0.0 < e < 1.0:  # _switch._accumulation: the bounces' time to rest
        M2, rhs2, A2, gam2, mu2 = dynamics(sy, t, q, vp, p)
        qdd2 = kkt_solve(sy, M2, rhs2, A2, gam2, mu2, rows, slip_j, slip_k, slip_c)[:n].copy()
        a_n = gam2[j]
        for c in range(n):
            a_n += A[j, c] * qdd2[c]
        if a_n < 0.0:
            rest = 2.0 * e * abs(Fm) / (-a_n * (1.0 - e))
            vb, imb = ev_impulses(
                sy,
                M, A, b, v, mu, rows, slip_j, slip_k, slip_c, j, -e * Fm - b[j], none_i,
                none_i, none_f,
            )  # fmt: skip
            if not np.all(np.isfinite(vb)):
                return nev, ST_CONTACT
            ib = imb[j]
    yb = y.copy()
    yb[n:] = vb
    y[n:] = vp
    if not engage:
        imode[2, j] = 0
        nev = ev_log(EV_IMPACT, j, t, y, want, found, ev_kind, ev_j, ev_t, ev_y, ev_x,
                     DT_IMPACT, imp[j], nev)  # fmt: skip
        if nev < 0:
            return 0, ST_EVENTS
        ev_x[nev - 1, 2] = Fm
        ev_x[nev - 1, 3] = e
        return nev, 0
    if rest >= 0.0:
        nev = ev_log(EV_IMPACT, j, t, yb, want, found, ev_kind, ev_j, ev_t, ev_y, ev_x,
                     DT_IMPACT, ib, nev)  # fmt: skip
        if nev < 0:
            return 0, ST_EVENTS
        ev_x[nev - 1, 2] = Fm
        ev_x[nev - 1, 3] = e
    # _switch._engage: j engages, its friction sticks (f held where it is), or slips on
    imode[0, j] = 1
    ev_mode(kinds, imode, fmode)
    for a in range(nf):
        i = frows[a]
        fmode[2, i] = f[i] if kinds[1, i] == 1 else 0.0
        imode[1, i] = FR_STICK
    for s in range(ns2):
        i = sj2[s]
        sv = b[i]
        for c in range(n):
            sv += A[i, c] * vp[c]
        if abs(sv) <= arm_vel:
            fmode[0, i] = -np.copysign(1.0, trial[i])
        else:
            fmode[0, i] = np.copysign(1.0, sv)
        imode[1, i] = FR_SLIP
        imode[3, i] = 0
    ev_mode(kinds, imode, fmode)
    if rest < 0.0:
        nev = ev_log(EV_CONTACT, j, t, y, want, found, ev_kind, ev_j, ev_t, ev_y, ev_x,
                     DT_IMPACT, imp[j], nev)  # fmt: skip
        if nev < 0:
            return 0, ST_EVENTS
        ev_x[nev - 1, 2] = Fm
        ev_x[nev - 1, 3] = e
    else:
        fmode[3, j] = t + rest
        fmode[4, j] = t
    for s in range(ns2):
        i = sj2[s]
        nev = ev_log(EV_SLIP, i, t, y, want, found, ev_kind, ev_j, ev_t, ev_y, ev_x,
                     DT_IMPULSE, imp[i], nev)  # fmt: skip
        if nev < 0:
            return 0, ST_EVENTS
    return nev, 0


def ev_bound(t_end, fmode):
    """The end of the next stretch: t_end, or an earlier accumulation time (the Zeno
    sequences' contacts to log: _simulate._segment's bound)."""
    bound = t_end
    for j in range(fmode.shape[1]):
        if fmode[3, j] < bound:  # NaN: none
            bound = fmode[3, j]
    return bound


def ev_accumulated(sy, t, y, p, fmode, want, found, ev_kind, ev_j, ev_t, ev_y, ev_x, nev):
    """Log EV_CONTACT for each constraint whose bounces have accumulated by t, in the
    order of their accumulation times (_simulate._accumulated); the new count, or -1."""
    n = y.shape[0] // 2
    while True:
        jn = -1
        for j in range(fmode.shape[1]):
            if fmode[3, j] <= t and (jn < 0 or fmode[3, j] < fmode[3, jn]):
                jn = j
        if jn < 0:
            return nev
        fmode[3, jn] = np.nan
        e = restitution(sy, t, y[:n].copy(), p)[jn]
        nev = ev_log(EV_CONTACT, jn, t, y, want, found, ev_kind, ev_j, ev_t, ev_y, ev_x,
                     DT_ACCUMULATION, e, nev)  # fmt: skip
        if nev < 0:
            return -1
        ev_x[nev - 1, 2] = t - fmode[4, jn]


def ev_segment(
    sy,
    t,
    y,
    h_abs,
    t_end,
    p,
    rtol,
    atol,
    max_step,
    max_steps,
    tab,
    kinds,
    imode,
    fmode,
    arm_pos,
    arm_vel,
    blow_up,
    pen,
    want,
    found,
    to_end,
    impacts,
    ev_kind,
    ev_j,
    ev_t,
    ev_y,
    ev_x,
    nev,
    TS,
    SY,
    SL,
    SR,
    io,
    fo,
    y_out,
):
    """The loop with events from (t, y) in the mode (imode, fmode), settled: DOP853 steps
    (the first of size h_abs, or scipy's initial step where h_abs is 0), the projection,
    the watched events located and lift-off, slip, stick and impacts (:func:`ev_impact`)
    applied, each stretch ending at the next accumulation time of a Zeno sequence, whose
    contact is logged there (:func:`ev_bound`, :func:`ev_accumulated`); the output times
    TS from io[0] on sampled into SY, SL, SR (:func:`ev_sample`). Returns (t, status,
    events logged, steps) with y_out the state at t: at t_end (ST_END); at a located
    contact the loop cannot apply, before it is applied (ST_CONTACT, io[1] its
    constraint: the simulator applies it); after ``max_steps`` steps,
    or with the event record nearly full (ST_BUDGET: go on from there with h_abs =
    fo[0]); ST_FOUND; and for the other statuses the last accepted state, from which
    the simulator takes over. Without ``impacts`` every located contact returns
    ST_CONTACT. fo[1]: the largest projection; io[2]: right-hand sides. ``tab``: DOP853's
    tables (A, B, C, E3, E5, then the dense output's A_EXTRA, C_EXTRA, D: _batch)."""
    A, B, C, E3, E5, AX, CX, D = tab
    N = y.shape[0]
    n = N // 2
    m = kinds.shape[1]
    y = y.copy()
    y_out[:] = y
    rows, hrows, slip_j, slip_k, slip_c = ev_mode(kinds, imode, fmode)
    wk, wj = ev_watch(kinds, imode)
    f = rhs_kernel(sy, t, y, p, rows, slip_j, slip_k, slip_c)
    io[2] += 1
    bound = ev_bound(t_end, fmode)
    if bound <= t < t_end:  # accumulated already (_simulate._segment): a fresh start
        nev = ev_accumulated(sy, t, y, p, fmode, want, found, ev_kind, ev_j, ev_t, ev_y, ev_x, nev)
        if nev < 0:
            return t, ST_EVENTS, 0, 0
        if ev_all(found, to_end):
            return t, ST_FOUND, nev, 0
        bound = ev_bound(t_end, fmode)
        h_abs = 0.0
    if h_abs <= 0.0:
        h_abs = ev_first_step(
            sy, t, y, f, p, rows, slip_j, slip_k, slip_c, bound, max_step, rtol, atol
        )
        io[2] += 1
    g_old = ev_values(
        sy, t, y, p, wk, wj, kinds, imode, fmode, rows, slip_j, slip_k, slip_c, arm_pos, arm_vel
    )
    K = np.zeros((D.shape[1], N))
    F = np.zeros((7, N))
    ynew = np.zeros(N)
    steps = 0
    room = 4 * m + 8  # the events one step may log (an event and its settling)
    while t < t_end:
        fo[0] = h_abs
        if steps >= max_steps or nev + room > ev_kind.shape[0]:
            return t, ST_BUDGET, nev, steps
        min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
        if h_abs > max_step:
            h_abs = max_step
        elif h_abs < min_step:
            h_abs = min_step
        rejected = False
        t_new = t
        h = 0.0
        while True:
            if h_abs < min_step:
                return t, ST_STEP, nev, steps
            t_new = t + h_abs
            if t_new > bound:
                t_new = bound
            h = t_new - t
            h_abs = abs(h)
            err = dop853_trial(
                sy,
                t,
                y,
                f,
                h,
                p,
                rows,
                slip_j,
                slip_k,
                slip_c,
                rtol,
                atol,
                A,
                B,
                C,
                E3,
                E5,
                K,
                ynew,
            )
            io[2] += STAGES
            if err < 1.0:
                factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-1.0 / 8.0))
                if rejected:
                    factor = min(1.0, factor)
                h_abs *= factor
                break
            shrink = 0.9 * err ** (-1.0 / 8.0)
            if not shrink > 0.2:  # also NaN, as max(0.2, nan) in scipy
                shrink = 0.2
            h_abs *= shrink
            rejected = True
        steps += 1
        big = np.max(np.abs(ynew))
        if not np.isfinite(big) or big > blow_up:
            return t, ST_GROWTH, nev, steps
        yb = ynew.copy()
        ev_project(sy, t_new, yb, p, rows, hrows, fmode[2])
        g_new = ev_values(
            sy,
            t_new, yb, p, wk, wj, kinds, imode, fmode, rows, slip_j, slip_k, slip_c, arm_pos,
            arm_vel,
        )  # fmt: skip
        released = False
        for i in range(wk.shape[0]):
            if wk[i] == EV_CONTACT:
                released = True
        if released:  # a gap that turns within the step: simulate's inside_step
            fa, Aa, ba = constraints(sy, t, y[:n].copy(), p)
            fb, Ab, bb = constraints(sy, t_new, yb[:n].copy(), p)
            for i in range(wk.shape[0]):
                if wk[i] == EV_CONTACT:
                    j = wj[i]
                    ra = ba[j]
                    rb = bb[j]
                    for c in range(n):
                        ra += Aa[j, c] * y[n + c]
                        rb += Ab[j, c] * yb[n + c]
                    if (imode[2, j] == 0 and ra > 0.0 > rb) or (imode[2, j] == 1 and ra < 0.0 < rb):
                        return t, ST_GRAZE, nev, steps
        hit = False
        for i in range(wk.shape[0]):
            if g_old[i] > 0.0 and g_new[i] <= 0.0:
                hit = True
        k = io[0]
        dense = hit or (k < TS.shape[0] and TS[k] < t_new)
        if dense:
            ev_dense_stages(sy, t, y, ynew, h, p, rows, slip_j, slip_k, slip_c, K, AX, CX, D, F)
            io[2] += 3
        if hit:
            te = t_new
            ie = -1
            for i in range(wk.shape[0]):
                if g_old[i] > 0.0 and g_new[i] <= 0.0:
                    r = ev_brent(
                        sy,
                        i, t, t_new, t, h, y, F, p, wk, wj, kinds, imode, fmode, rows, slip_j,
                        slip_k, slip_c, arm_pos, arm_vel,
                    )  # fmt: skip
                    if r < te or ie < 0:
                        te = r
                        ie = i
            # the samples up to the event, on the dense output (Recorder.up_to)
            while k < TS.shape[0] and TS[k] <= te:
                ys = ev_dense(TS[k], t, h, y, F)
                ev_sample(sy, TS[k], ys, p, m, rows, hrows, slip_j, slip_k, slip_c, fmode[2], k,
                          SY, SL, SR)  # fmt: skip
                k += 1
            io[0] = k
            ye = ev_dense(te, t, h, y, F)
            ev_project(sy, te, ye, p, rows, hrows, fmode[2])
            y_out[:] = ye
            kind = wk[ie]
            j = wj[ie]
            logged = kind
            if kind == EV_CONTACT:
                # _simulate._check_penetration where the contact is met: a gap that jumped
                # below zero is the simulator's to report
                fc = constraints(sy, te, ye[:n].copy(), p)[0]
                depth = max(pen * (1.0 + np.max(np.abs(ye[:n]))), 10.0 * arm_pos)
                if fc[j] < -depth:
                    io[1] = j
                    return te, ST_CONTACT, nev, steps
                if not impacts:  # left to the caller (integrate_events' default)
                    io[1] = j
                    return te, ST_CONTACT, nev, steps
                nev, st = ev_impact(
                    sy,
                    te, ye, p, j, kinds, imode, fmode, arm_pos, arm_vel, want, found, ev_kind,
                    ev_j, ev_t, ev_y, ev_x, nev,
                )  # fmt: skip
                if st == ST_CONTACT:  # not applied: the simulator applies it
                    io[1] = j
                    return te, ST_CONTACT, nev, steps
                if st != 0:
                    return te, st, nev, steps
                logged = -1
            code = DT_NONE
            value = 0.0
            if kind == EV_STICK:
                # _switch._stick: it sticks, f held where it is, if mu N can hold it;
                # else it slips on (a reversal when the direction changes)
                sigma = fmode[0, j]
                fj = constraints(sy, te, ye[:n].copy(), p)[0][j]
                fmode[2, j] = fj if kinds[1, j] == 1 else 0.0
                imode[1, j] = FR_STICK
                r2, h2, sj2, sk2, sc2 = ev_mode(kinds, imode, fmode)
                ev_project(sy, te, ye, p, r2, h2, fmode[2])
                lam2, mu2 = ev_lam(sy, te, ye, p, m, r2, sj2, sk2, sc2)[1:]
                kn = kinds[2, j]
                if not abs(lam2[j]) <= mu2[j] * fmode[1, j] * lam2[kn] * (1.0 + 1e-9):
                    fmode[0, j] = -np.copysign(1.0, lam2[j])
                    imode[1, j] = FR_SLIP
                    imode[3, j] = 0
                    logged = EV_SLIP
                    code = DT_REVERSAL
                    value = 1.0 if fmode[0, j] != sigma else 0.0
            elif kind == EV_LIFT_OFF:
                imode[0, j] = 0
                imode[2, j] = 0
                fmode[3, j] = np.nan  # Mode.release: a pending accumulation is dropped
            elif kind == EV_SLIP:
                lam_j = ev_lam(sy, te, ye, p, m, rows, slip_j, slip_k, slip_c)[1][j]
                fmode[0, j] = -np.copysign(1.0, lam_j)
                imode[1, j] = FR_SLIP
                imode[3, j] = 0
            if logged >= 0:
                nev = ev_log(
                    logged, j, te, ye, want, found, ev_kind, ev_j, ev_t, ev_y, ev_x, code, value,
                    nev,
                )  # fmt: skip
                if nev < 0:
                    return te, ST_EVENTS, 0, steps
            nev, st = ev_settle(
                sy,
                te, ye, p, kinds, imode, fmode, arm_vel, want, found, ev_kind, ev_j, ev_t, ev_y,
                ev_x, nev,
            )  # fmt: skip
            y_out[:] = ye
            if st != 0:
                return te, st, nev, steps
            if ev_all(found, to_end):
                return te, ST_FOUND, nev, steps
            t = te
            y = ye
            rows, hrows, slip_j, slip_k, slip_c = ev_mode(kinds, imode, fmode)
            wk, wj = ev_watch(kinds, imode)
            f = rhs_kernel(sy, t, y, p, rows, slip_j, slip_k, slip_c)
            bound = ev_bound(t_end, fmode)
            if bound <= t:  # accumulated at the event's time: logged before going on
                nev = ev_accumulated(sy, t, y, p, fmode, want, found, ev_kind, ev_j, ev_t, ev_y,
                                     ev_x, nev)  # fmt: skip
                if nev < 0:
                    return t, ST_EVENTS, 0, steps
                if ev_all(found, to_end):
                    return t, ST_FOUND, nev, steps
                bound = ev_bound(t_end, fmode)
            h_abs = ev_first_step(
                sy, t, y, f, p, rows, slip_j, slip_k, slip_c, bound, max_step, rtol, atol
            )
            io[2] += 2
            g_old = ev_values(
                sy,
                t,
                y,
                p,
                wk,
                wj,
                kinds,
                imode,
                fmode,
                rows,
                slip_j,
                slip_k,
                slip_c,
                arm_pos,
                arm_vel,
            )
            continue
        if released:  # a body through a surface (simulate's _check_penetration)
            fb = constraints(sy, t_new, yb[:n].copy(), p)[0]
            depth = max(pen * (1.0 + np.max(np.abs(yb[:n]))), 10.0 * arm_pos)
            for i in range(wk.shape[0]):
                if wk[i] == EV_CONTACT and fb[wj[i]] < -depth:
                    return t, ST_PENETRATION, nev, steps
        # the samples up to the step's end: on the dense output, at t_new the projected
        # state (Recorder.up_to)
        while k < TS.shape[0] and TS[k] <= t_new:
            ys = yb if TS[k] == t_new else ev_dense(TS[k], t, h, y, F)
            ev_sample(sy, TS[k], ys, p, m, rows, hrows, slip_j, slip_k, slip_c, fmode[2], k,
                      SY, SL, SR)  # fmt: skip
            k += 1
        io[0] = k
        moved = np.max(np.abs(yb - ynew))
        if moved > fo[1]:
            fo[1] = moved
        armed = False
        for i in range(wk.shape[0]):
            j = wj[i]
            if (wk[i] == EV_CONTACT and imode[2, j] == 0) or (
                wk[i] == EV_STICK and imode[3, j] == 0
            ):
                fb, Ab, bb = constraints(sy, t_new, yb[:n].copy(), p)
                if wk[i] == EV_CONTACT:
                    if fb[j] > arm_pos:
                        imode[2, j] = 1
                        armed = True
                else:
                    s = bb[j]
                    for c in range(n):
                        s += Ab[j, c] * yb[n + c]
                    if fmode[0, j] * s > arm_vel:
                        imode[3, j] = 1
                        armed = True
        if armed:
            g_old = ev_values(
                sy,
                t_new, yb, p, wk, wj, kinds, imode, fmode, rows, slip_j, slip_k, slip_c,
                arm_pos, arm_vel,
            )  # fmt: skip
        else:
            g_old = g_new
        t = t_new
        y = yb
        y_out[:] = y
        f = rhs_kernel(sy, t, y, p, rows, slip_j, slip_k, slip_c)
        io[2] += 1
        if not np.all(np.isfinite(f)):
            return t, ST_SINGULAR, nev, steps
        if t >= bound:  # the bounces accumulated: their contacts logged, a fresh start
            nev = ev_accumulated(sy, t, y, p, fmode, want, found, ev_kind, ev_j, ev_t, ev_y, ev_x,
                                 nev)  # fmt: skip
            if nev < 0:
                return t, ST_EVENTS, 0, steps
            if ev_all(found, to_end):
                return t, ST_FOUND, nev, steps
            if t < t_end:
                bound = ev_bound(t_end, fmode)
                h_abs = ev_first_step(
                    sy, t, y, f, p, rows, slip_j, slip_k, slip_c, bound, max_step, rtol, atol
                )
                io[2] += 1
    fo[0] = h_abs
    y_out[:] = y
    return t, ST_END, nev, steps


def ev_run(
    sy,
    Y0,
    P,
    t_end,
    rtol,
    atol,
    max_step,
    max_steps,
    tab,
    kinds,
    IM,
    FM,
    arm_pos,
    arm_vel,
    blow,
    pen,
    tol,
    want,
    to_end,
    impacts,
    EK,
    EJ,
    ET,
    EY,
    EX,
    YOUT,
    TOUT,
    STATUS,
    NEV,
    STEPS,
):
    """Every row of Y0 (parameters P, modes IM, FM) through :func:`ev_run_one`, in one
    thread (compiled with ``nogil``: the caller spreads slices of a batch over threads)."""
    for b in range(Y0.shape[0]):
        t, st, nev, steps = ev_run_one(
            sy,
            Y0[b],
            P[b],
            t_end,
            rtol,
            atol,
            max_step,
            max_steps,
            tab,
            kinds,
            IM[b],
            FM[b],
            arm_pos,
            arm_vel,
            blow,
            pen,
            tol,
            want,
            to_end,
            impacts,
            EK[b],
            EJ[b],
            ET[b],
            EY[b],
            EX[b],
            YOUT[b],
        )
        TOUT[b] = t
        STATUS[b] = st
        NEV[b] = nev
        STEPS[b] = steps


def ev_restricted(sy, t, q, v, p, rows, free, what):
    """One correction of the start onto the constraints ``rows`` over the ``free``
    coordinates (mask), the mass-matrix metric restricted to them (_project with
    ``free``): ``what`` 0 positions (f = 0), 1 velocities (A v + b = 0). (dx over all
    coordinates, 0 on the held ones; the residual's size; the number of movable rows)."""
    n = q.shape[0]
    f, A, b = constraints(sy, t, q, p)
    nf = 0
    for i in range(n):
        if free[i]:
            nf += 1
    idx = np.empty(nf, dtype=np.int64)
    nf = 0
    for i in range(n):
        if free[i]:
            idx[nf] = i
            nf += 1
    act = np.empty(rows.shape[0], dtype=np.int64)
    na = 0
    for a in range(rows.shape[0]):
        for c in range(nf):
            if A[rows[a], idx[c]] != 0.0:
                act[na] = rows[a]
                na += 1
                break
    dx = np.zeros(n)
    if na == 0:
        return dx, 0.0, 0, 0.0
    r = np.empty(na)
    big = 0.0
    for a in range(na):
        j = act[a]
        if what == 0:
            r[a] = -f[j]
        else:
            s = b[j]
            for c in range(n):
                s += A[j, c] * v[c]
            r[a] = -s
        big = max(big, abs(r[a]))
    Af = np.empty((na, nf))
    for a in range(na):
        for c in range(nf):
            Af[a, c] = A[act[a], idx[c]]
    if what == 0 and big <= 2e-16 * (1.0 + np.max(np.abs(q))) * max(1.0, np.max(np.abs(A))):
        return dx, big, na, 0.0
    if what == 1 and big == 0.0:
        return dx, big, na, 0.0
    M = dynamics(sy, t, q, v, p)[0]
    W = np.empty((nf, nf))
    for a in range(nf):
        for c in range(nf):
            W[a, c] = M[idx[a], idx[c]]
    d = ev_correction(W, Af, r)
    step = 0.0
    for c in range(nf):
        dx[idx[c]] = d[c]
        step = max(step, abs(d[c]))
    return dx, big, na, step


def ev_consistent(sy, q, v, p, hold_q, hold_v, value_q, value_v, kinds, tol):
    """The start with the held coordinates and velocities set and the others moved onto
    the constraints the unheld start meets (_initial.consistent_initial), in place."""
    n = q.shape[0]
    m = kinds.shape[1]
    f, A, b = constraints(sy, 0.0, q, p)
    tol_q = tol * (1.0 + np.max(np.abs(q)))
    nq = 0
    nv = 0
    inq = np.zeros(m, dtype=np.bool_)
    for j in range(m):
        if kinds[1, j] == 1 and abs(f[j]) <= tol_q:
            inq[j] = True
            nq += 1
    rows_q = np.empty(nq, dtype=np.int64)
    rows_v = np.empty(m, dtype=np.int64)
    nq = 0
    for j in range(m):
        if inq[j]:
            rows_q[nq] = j
            nq += 1
        s = b[j]
        for c in range(n):
            s += A[j, c] * v[c]
        if abs(s) <= tol_q and (kinds[1, j] == 0 or inq[j]):
            rows_v[nv] = j
            nv += 1
    free_q = np.ones(n, dtype=np.bool_)
    free_v = np.ones(n, dtype=np.bool_)
    for i in range(n):
        if hold_q[i]:
            q[i] = value_q[i]
            free_q[i] = False
        if hold_v[i]:
            v[i] = value_v[i]
            free_v[i] = False
    if nq > 0 and np.any(free_q):
        # the metric's M at the first iteration's state (_project.project_positions)
        for _ in range(PROJECTION_ITERATIONS):
            dx, big, na, step = ev_restricted(sy, 0.0, q, v, p, rows_q, free_q, 0)
            if na == 0 or step == 0.0:
                break
            q += dx
            if step <= 1e-16 * (1.0 + np.max(np.abs(q - dx))):
                break
    if nv > 0 and np.any(free_v):
        dx, big, na, step = ev_restricted(sy, 0.0, q, v, p, rows_v[:nv].copy(), free_v, 1)
        v += dx


def ev_starts(sy, Q, V, P, hold_q, hold_v, value_q, value_v, kinds, tol):
    """:func:`ev_consistent` for every row of Q, V (parameters P), in place."""
    for b in range(Q.shape[0]):
        ev_consistent(sy, Q[b], V[b], P[b], hold_q, hold_v, value_q, value_v, kinds, tol)
