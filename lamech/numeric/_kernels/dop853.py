"""DOP853, the one stepper of both loops (the batch's and the one with events): SciPy's
tableau, error norm and step-size control (``scipy.integrate._ivp.rk``), its initial
step, and the dense output (the 7th-order interpolant with its 3 extra stages).

``tab``: DOP853's tables (A, B, C, E3, E5, then the dense output's A_EXTRA, C_EXTRA, D:
:func:`.._batch._tableau`, :func:`.._batch._dense_tableau`).
"""

import numpy as np

from .kkt import rhs_kernel

STAGES = 12
"""DOP853's number of stages (checked against SciPy's table in :mod:`.._batch`)."""


# KERNELS
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
