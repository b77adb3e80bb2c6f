"""The projections onto the constraints: after a step (the batch loop's in the Euclidean
metric, the loop with events' and the simulator's in the mass-matrix metric on the
mode's rows), and the consistent starts (:func:`.._initial.consistent_initial` and a
batch's).
"""

import numpy as np

from ...linalg import gauss_inplace
from .arrays import (
    a_bt,
    a_v,
    all_finite,
    any_nonzero,
    at_v,
    diagonal_weights,
    max_abs,
    max_abs_diff,
)
from .codes import borrowed
from .kkt import batch_solve, borrowed_record, constraints, dynamics

PROJECTION_ITERATIONS = 6
"""Gauss-Newton iterations at most per position projection (it converges quadratically:
after a step one or two suffice)."""


# KERNELS
def ev_correction(W, Ar, r):
    """dx minimising dx^T W dx subject to Ar dx = r (the KKT system, by elimination);
    Euclidean where that is singular, then least squares (linalg.min_norm_correction).
    Where W is diagonal and positive (particles and planar bodies in maximal
    coordinates), by the Schur complement dx = W^-1 Ar^T (Ar W^-1 Ar^T)^-1 r: a k-square
    solve instead of the (n + k)-square one (the 20-link chain's projection took most of
    a step's time)."""
    n = W.shape[0]
    k = Ar.shape[0]
    # Written with whole-array operations, not loops over entries: the simulator's own
    # steps (SciPy's integrators) run this as Python at every step, where a loop over
    # the 120-square W of a 60-link chain cost more than the step. Compiled, arrays.py's
    # operations are loops; as Python, the NumPy expressions they stand for.
    d = diagonal_weights(W)
    if d.shape[0] == n:
        ArW = Ar / d
        w = batch_solve(a_bt(ArW, Ar), r)
        if all_finite(w):
            return at_v(ArW, w)
    K = np.zeros((n + k, n + k))
    x = np.zeros(n + k)
    K[:n, :n] = W
    K[:n, n:] = Ar.T
    K[n:, :n] = Ar
    x[n:] = r
    gauss_inplace(K, x)
    if all_finite(x):
        return x[:n].copy()
    G = a_bt(Ar, Ar)
    w = batch_solve(G, r)
    return at_v(Ar, w)


def ev_project(sy, t, y, p, rows, hrows, offset):
    """y onto the mode's manifold, in place (in the mass-matrix metric):
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
            scale = 1.0 + max_abs(q)
            if big <= 2e-16 * scale * max(1.0, max_abs(A)):
                break
            if not have_w:
                W = dynamics(sy, t, q, v, p)[0]
                have_w = True
            dq = ev_correction(W, A[hrows], r)
            q += dq
            if max_abs(dq) <= 1e-16 * scale:
                break
    if rows.shape[0] > 0:
        f, A, b = constraints(sy, t, q, p)
        Ar = A[rows]
        r = -(a_v(Ar, v) + b[rows])
        if any_nonzero(r):
            W = dynamics(sy, t, q, v, p)[0]
            v += ev_correction(W, Ar, r)
    y[:n] = q
    y[n:] = v


def batch_project(sy, t, y, p):
    """Positions onto f = 0 (Gauss-Newton, minimum norm), then velocities onto
    A v + b = 0; in place. :func:`ev_project` in
    the Euclidean metric, at most PROJECTION_ITERATIONS Gauss-Newton steps."""
    n = y.shape[0] // 2
    q = y[:n].copy()
    for _ in range(PROJECTION_ITERATIONS):
        f, A, b = constraints(sy, t, q, p)
        m = f.shape[0]
        big = 0.0
        for j in range(m):
            big = max(big, abs(f[j]))
        if big <= 1e-15 * (1.0 + max_abs(q)):
            break
        G = a_bt(A, A)
        w = batch_solve(G, f)
        q -= at_v(A, w)
    f, A, b = constraints(sy, t, q, p)
    v = y[n:].copy()
    G = a_bt(A, A)
    w = batch_solve(G, a_v(A, v) + b)
    v -= at_v(A, w)
    y[:n] = q
    y[n:] = v


def ev_restricted(sy, t, q, v, p, rows, free, what):
    """One correction of the start onto the constraints ``rows`` over the ``free``
    coordinates (mask), the mass-matrix metric restricted to them (with
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
    if what == 0 and big <= 2e-16 * (1.0 + max_abs(q)) * max(1.0, max_abs(A)):
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
    tol_q = tol * (1.0 + max_abs(q))
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
    if nq > 0 and any_nonzero(free_q):
        for _ in range(PROJECTION_ITERATIONS):
            dx, big, na, step = ev_restricted(sy, 0.0, q, v, p, rows_q, free_q, 0)
            if na == 0 or step == 0.0:
                break
            q += dx
            if step <= 1e-16 * (1.0 + max_abs_diff(q, dx)):
                break
    if nv > 0 and any_nonzero(free_v):
        dx, big, na, step = ev_restricted(sy, 0.0, q, v, p, rows_v[:nv].copy(), free_v, 1)
        v += dx


def ev_starts(sy, Q, V, P, hold_q, hold_v, value_q, value_v, kinds, tol):
    """:func:`ev_consistent` for every row of Q, V (parameters P), in place."""
    sy, Q, V, P, kinds = borrowed_record(sy), borrowed(Q), borrowed(V), borrowed(P), borrowed(kinds)
    for b in range(Q.shape[0]):
        ev_consistent(sy, Q[b], V[b], P[b], hold_q, hold_v, value_q, value_v, kinds, tol)
