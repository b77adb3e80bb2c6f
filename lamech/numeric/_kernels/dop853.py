"""DOP853, the one stepper of both loops (the batch's and the one with events): SciPy's
tableau, error norm and step-size control (``scipy.integrate._ivp.rk``), its initial
step, and the dense output (the 7th-order interpolant with its 3 extra stages).

``tab``: DOP853's tables (A, B, C, E3, E5, then the dense output's A_EXTRA, C_EXTRA, D:
:func:`.._tableau._tableau`, :func:`.._tableau._dense_tableau`); ``act`` the mode's active set
and ``tl`` the tolerances (:mod:`.codes`).
"""

import numpy as np

from .codes import TL_ATOL, TL_MAX_STEP, TL_RTOL
from .kkt import rhs_kernel

STAGES = 12
"""DOP853's number of stages (checked against SciPy's table in :mod:`.._batch`)."""


# KERNELS
def dop853_trial(sy, t, y, f, h, p, act, tl, tab, K, ynew):
    """One DOP853 step of size h from (t, y) with y' = f there, on the mode's active set
    ``act``: the stages into K, the solution into ``ynew``; returns SciPy's error norm
    (< 1: accept)."""
    A, B, C, E3, E5 = tab[0], tab[1], tab[2], tab[3], tab[4]
    rows, slip_j, slip_k, slip_c = act[0], act[2], act[3], act[4]
    rtol, atol = tl[TL_RTOL], tl[TL_ATOL]
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


def dop853_step(sy, t, y, f, h_abs, bound, p, act, tl, tab, K, ynew):
    """One accepted DOP853 step from (t, y), y' = f there, trying ``h_abs`` first and
    ending at ``bound`` at the latest, the solution into ``ynew``: SciPy's step-size
    control (``max_step`` tl[TL_MAX_STEP]; a rejected step shrinks by 0.9 err^(-1/8), to
    no less than 0.2 of it, also where err is NaN; an accepted one grows by at most 10,
    and not at all right after a rejection). The step of both loops. (t_new, h, the next
    step size, trials); trials <= 0 (minus the trials made) where the step size fell
    below 10 units in the last place of t (a collapse: no step taken)."""
    min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
    if h_abs > tl[TL_MAX_STEP]:
        h_abs = tl[TL_MAX_STEP]
    elif h_abs < min_step:
        h_abs = min_step
    rejected = False
    trials = 0
    while True:
        if h_abs < min_step:
            return t, 0.0, h_abs, -trials
        t_new = t + h_abs
        if t_new > bound:
            t_new = bound
        h = t_new - t
        h_abs = abs(h)
        err = dop853_trial(sy, t, y, f, h, p, act, tl, tab, K, ynew)
        trials += 1
        if err < 1.0:
            factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-1.0 / 8.0))
            if rejected:
                factor = min(1.0, factor)
            return t_new, h, h_abs * factor, trials
        shrink = 0.9 * err ** (-1.0 / 8.0)
        if not shrink > 0.2:  # also NaN, as max(0.2, nan) in scipy
            shrink = 0.2
        h_abs *= shrink
        rejected = True


def ev_first_step(sy, t, y, f, p, act, t_end, tl):
    """scipy's select_initial_step for DOP853 (error estimator order 7), on the mode's
    active set ``act``, towards ``t_end``."""
    rtol, atol = tl[TL_RTOL], tl[TL_ATOL]
    interval = abs(t_end - t)
    if interval == 0.0:
        return 0.0
    scale = atol + np.abs(y) * rtol
    d0 = np.sqrt(np.mean((y / scale) ** 2))
    d1 = np.sqrt(np.mean((f / scale) ** 2))
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    h0 = min(h0, interval)
    f1 = rhs_kernel(sy, t + h0, y + h0 * f, p, act[0], act[2], act[3], act[4])
    d2 = np.sqrt(np.mean(((f1 - f) / scale) ** 2)) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    return min(100.0 * h0, h1, interval, tl[TL_MAX_STEP])


def ev_dense(s, dn):
    """DOP853's dense output at s (scipy's Dop853DenseOutput) of the step ``dn`` (t_old,
    h, y_old, F: :func:`ev_dense_stages`)."""
    t_old, h, y_old, F = dn
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


def ev_dense_stages(sy, t, y, ynew, h, p, act, tab, K, F):
    """The step's dense output into F: the 3 more stages of scipy's _dense_output_impl."""
    AX, CX, D = tab[5], tab[6], tab[7]
    N = y.shape[0]
    for s in range(STAGES + 1, D.shape[1]):
        dy = np.zeros(N)
        for k in range(s):
            if AX[s - STAGES - 1, k] != 0.0:
                dy += AX[s - STAGES - 1, k] * K[k]
        K[s] = rhs_kernel(sy, t + CX[s - STAGES - 1] * h, y + h * dy, p, act[0], act[2],
                          act[3], act[4])  # fmt: skip
    F[0] = ynew - y
    F[1] = h * K[0] - F[0]
    F[2] = 2.0 * F[0] - h * (K[STAGES] + K[0])
    for r in range(D.shape[0]):
        acc = np.zeros(N)
        for k in range(D.shape[1]):
            acc += D[r, k] * K[k]
        F[3 + r] = h * acc
