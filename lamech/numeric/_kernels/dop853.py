"""DOP853, the one stepper of both loops (the batch's and the one with events): SciPy's
tableau, error norm and step-size control (``scipy.integrate._ivp.rk``), its initial
step, and the dense output (the 7th-order interpolant with its 3 extra stages).

``tab``: DOP853's tables (A, B, C, E3, E5, then the dense output's A_EXTRA, C_EXTRA, D:
:func:`.._tableau._tableau`, :func:`.._tableau._dense_tableau`); ``act`` the mode's active set
and ``tl`` the tolerances (:mod:`.codes`).
"""

import numpy as np

from .arrays import rms_diff_scaled, rms_scaled
from .codes import TL_ATOL, TL_MAX_STEP, TL_RTOL, borrowed
from .kkt import borrowed_act, rhs_into, rhs_kernel, rhs_space

STAGES = 12
"""DOP853's number of stages (checked against SciPy's table in :mod:`.._batch`)."""


# The sums over the stages, as the kernels run as Python (:func:`.python_namespace` puts
# these in place of the loops below): whole-array operations, the same terms added in the
# same order, so the same numbers to the last bit. Compiled, each array operation would
# allocate a temporary per term (about 400 per step: most of a step's time, measured
# 2026-11-27); the loops below allocate nothing.
def _combine_numpy(out, coef, K, count, skip):
    out[:] = 0.0
    for k in range(count):
        if not skip or coef[k] != 0.0:
            out += coef[k] * K[k]


def _advance_numpy(out, y, h, d):
    out[:] = y + h * d


def _error_norm_numpy(y, ynew, err5, err3, h, rtol, atol):
    scale = atol + np.maximum(np.abs(y), np.abs(ynew)) * rtol
    e5 = np.sum((err5 / scale) ** 2)
    e3 = np.sum((err3 / scale) ** 2)
    if e5 == 0.0 and e3 == 0.0:
        return 0.0
    return abs(h) * e5 / np.sqrt((e5 + 0.01 * e3) * y.shape[0])


def _dense_numpy(s, dn, y):
    t_old, h, y_old, F = dn
    x = (s - t_old) / h
    y[:] = 0.0
    P = F.shape[0]
    for i in range(P):
        y += F[P - 1 - i]
        if i % 2 == 0:
            y *= x
        else:
            y *= 1.0 - x
    y += y_old
    return y


def _dense_rows_numpy(F, y, ynew, h, K, D, dy):
    F[0] = ynew - y
    F[1] = h * K[0] - F[0]
    F[2] = 2.0 * F[0] - h * (K[STAGES] + K[0])
    for r in range(D.shape[0]):
        _combine_numpy(dy, D[r], K, D.shape[1], False)
        F[3 + r] = h * dy


PYTHON = {
    "combine": _combine_numpy,
    "advance": _advance_numpy,
    "error_norm": _error_norm_numpy,
    "dense_into": _dense_numpy,
    "dense_rows": _dense_rows_numpy,
}
"""The functions below that the kernels run as Python replace by these."""


# KERNELS
def borrowed_tables(tab):
    """DOP853's tables borrowed (:func:`.codes.borrowed`), for a function whose caller
    holds ``tab`` for the call."""
    return (borrowed(tab[0]), borrowed(tab[1]), borrowed(tab[2]), borrowed(tab[3]),
            borrowed(tab[4]), borrowed(tab[5]), borrowed(tab[6]), borrowed(tab[7]))  # fmt: skip


def combine(out, coef, K, count, skip):
    """out = sum over k < count of coef[k] K[k], in order of k (``skip``: the terms with
    coef[k] = 0 left out)."""
    for i in range(out.shape[0]):
        acc = 0.0
        for k in range(count):
            if not skip or coef[k] != 0.0:
                acc += coef[k] * K[k, i]
        out[i] = acc


def advance(out, y, h, d):
    """out = y + h d."""
    for i in range(out.shape[0]):
        out[i] = y[i] + h * d[i]


def error_norm(y, ynew, err5, err3, h, rtol, atol):
    """SciPy's DOP853 error norm of a step of size h from y to ynew (< 1: accept)."""
    e5 = 0.0
    e3 = 0.0
    for i in range(y.shape[0]):
        scale = atol + max(abs(y[i]), abs(ynew[i])) * rtol
        e5 += (err5[i] / scale) ** 2
        e3 += (err3[i] / scale) ** 2
    if e5 == 0.0 and e3 == 0.0:
        return 0.0
    return abs(h) * e5 / np.sqrt((e5 + 0.01 * e3) * y.shape[0])


def dop853_trial(sy, t, y, f, h, p, act, tl, tab, K, ynew):
    """One DOP853 step of size h from (t, y) with y' = f there, on the mode's active set
    ``act``: the stages into K, the solution into ``ynew``; returns SciPy's error norm
    (< 1: accept). Its arguments are borrowed (:func:`.codes.borrowed`; the caller holds
    them): each stage passes them down the right-hand side's calls."""
    y, f, p, tl = borrowed(y), borrowed(f), borrowed(p), borrowed(tl)
    K, ynew = borrowed(K), borrowed(ynew)
    act = borrowed_act(act)
    A, B, C, E3, E5 = tab[0], tab[1], tab[2], tab[3], tab[4]
    rows, slip_j, slip_k, slip_c = act[0], act[2], act[3], act[4]
    N = y.shape[0]
    K[0] = f
    floats, ints = rhs_space(sy, N)
    # dy, ys, err3 and the right-hand sides' space in one array; the space is borrowed:
    # err3, a view of the same array, keeps it alive to the end
    space = np.empty(3 * N + floats)
    dy, ys, err3 = space[:N], space[N : 2 * N], space[2 * N : 3 * N]
    work, iwork = borrowed(space[3 * N :]), np.empty(ints, dtype=np.int64)
    for s in range(1, STAGES):
        combine(dy, A[s], K, s, True)
        advance(ys, y, h, dy)
        rhs_into(sy, t + C[s] * h, ys, p, rows, slip_j, slip_k, slip_c, K[s], work, iwork)
    combine(dy, B, K, STAGES, False)
    advance(ynew, y, h, dy)
    rhs_into(sy, t + h, ynew, p, rows, slip_j, slip_k, slip_c, K[STAGES], work, iwork)
    combine(dy, E5, K, STAGES + 1, False)
    combine(err3, E3, K, STAGES + 1, False)
    return error_norm(y, ynew, dy, err3, h, tl[TL_RTOL], tl[TL_ATOL])


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
    d0 = rms_scaled(y, scale)
    d1 = rms_scaled(f, scale)
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    h0 = min(h0, interval)
    f1 = rhs_kernel(sy, t + h0, y + h0 * f, p, act[0], act[2], act[3], act[4])
    d2 = rms_diff_scaled(f1, f, scale) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / 8.0)
    return min(100.0 * h0, h1, interval, tl[TL_MAX_STEP])


def dense_into(s, dn, y):
    """DOP853's dense output at s (scipy's Dop853DenseOutput) of the step ``dn`` (t_old,
    h, y_old, F: :func:`ev_dense_stages`) into y; returns y."""
    t_old, h, y_old, F = dn
    x = (s - t_old) / h
    P = F.shape[0]
    for j in range(y.shape[0]):
        acc = 0.0
        for i in range(P):
            acc += F[P - 1 - i, j]
            if i % 2 == 0:
                acc *= x
            else:
                acc *= 1.0 - x
        y[j] = acc + y_old[j]
    return y


def ev_dense(s, dn):
    """DOP853's dense output at s of the step ``dn`` (:func:`dense_into`), a new array."""
    return dense_into(s, dn, np.empty(dn[2].shape[0]))


def ev_dense_stages(sy, t, y, ynew, h, p, act, tab, K, F):
    """The step's dense output into F: the 3 more stages of scipy's _dense_output_impl
    (the arguments borrowed, as :func:`dop853_trial`)."""
    y, ynew, p, K, F = borrowed(y), borrowed(ynew), borrowed(p), borrowed(K), borrowed(F)
    act = borrowed_act(act)
    AX, CX, D = tab[5], tab[6], tab[7]
    N = y.shape[0]
    floats, ints = rhs_space(sy, N)
    space = np.empty(2 * N + floats)  # as in dop853_trial: dy, used last, keeps it alive
    dy, ys = space[:N], space[N : 2 * N]
    work, iwork = borrowed(space[2 * N :]), np.empty(ints, dtype=np.int64)
    for s in range(STAGES + 1, D.shape[1]):
        combine(dy, AX[s - STAGES - 1], K, s, True)
        advance(ys, y, h, dy)
        rhs_into(sy, t + CX[s - STAGES - 1] * h, ys, p, act[0], act[2], act[3], act[4], K[s],
                 work, iwork)  # fmt: skip
    dense_rows(F, y, ynew, h, K, D, dy)


def dense_rows(F, y, ynew, h, K, D, dy):
    """F's rows (the dense output's coefficients) from the step's stages K; ``dy`` is
    scratch space."""
    N = y.shape[0]
    for i in range(N):
        d0 = ynew[i] - y[i]
        F[0, i] = d0
        F[1, i] = h * K[0, i] - d0
        F[2, i] = 2.0 * d0 - h * (K[STAGES, i] + K[0, i])
    for r in range(D.shape[0]):
        combine(dy, D[r], K, D.shape[1], False)
        for i in range(N):
            F[3 + r, i] = h * dy[i]
