"""The batch loop of :func:`lamech.numeric.integrate_batch`: DOP853 (:mod:`.dop853`) with
the projection onto the constraints after every accepted step, every constraint active,
no events. Without numba the same functions run as Python (``prange`` is ``range``).
"""

import numpy as np

from .dop853 import STAGES, dop853_trial, ev_first_step
from .kkt import accelerations
from .project import batch_project

prange = range  # numba.prange in the compiled module


# KERNELS
def batch_deriv(sy, t, y, p, out):
    """out = [v; q''] with every constraint active."""
    n = y.shape[0] // 2
    sol = accelerations(sy, t, y, p)
    for i in range(n):
        out[i] = y[n + i]
        out[n + i] = sol[i]


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
