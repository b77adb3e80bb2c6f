"""The batch loop of :func:`lamech.numeric.integrate_batch`: DOP853 (:mod:`.dop853`) with
the projection onto the constraints after every accepted step, every constraint active,
no events: ``tab`` DOP853's tables, ``tl`` the tolerances and t_end (max_step infinite),
``lim`` the step budget (:mod:`.codes`). Without numba the same functions run as Python
(``prange`` is ``range``).
"""

import numpy as np

from .codes import LM_MAX_STEPS, TL_T_END, borrowed
from .dop853 import STAGES, borrowed_tables, dop853_step, ev_first_step
from .kkt import accelerations, borrowed_record
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


def batch_run_one(sy, y0, p, tab, tl, lim):
    """One run from t = 0 to tl[TL_T_END]: (the final state, the steps), or (NaN, -1)
    where the step size collapsed or the steps ran out."""
    sy, tab = borrowed_record(sy), borrowed_tables(tab)
    y0, p, tl, lim = borrowed(y0), borrowed(p), borrowed(tl), borrowed(lim)
    N = y0.shape[0]
    y = y0.copy()
    t = 0.0
    t_end = tl[TL_T_END]
    K = np.zeros((STAGES + 1, N))
    f = np.zeros(N)
    batch_deriv(sy, t, y, p, f)
    none = np.zeros(0, dtype=np.int64)
    # every constraint active, none holonomic by name (the batch projection takes all)
    act = (np.arange(sy[1].shape[0] - 1), none, none, none, np.zeros(0))
    h = ev_first_step(sy, t, y, f, p, act, t_end, tl)
    steps = 0
    ynew = np.zeros(N)
    while t < t_end:
        if steps >= lim[LM_MAX_STEPS]:
            return y * np.nan, -1
        t, _, h, trials = dop853_step(sy, t, y, f, h, t_end, p, act, tl, tab, K, ynew)
        if trials <= 0:
            return y * np.nan, -1
        y[:] = ynew
        batch_project(sy, t, y, p)
        batch_deriv(sy, t, y, p, f)
        steps += 1
    return y, steps


def batch_run(sy, Y0, P, tab, tl, lim, out, steps):
    """Every row of Y0 (parameters P) to t_end, over the cores (numba's prange)."""
    for b in prange(Y0.shape[0]):
        y, s = batch_run_one(sy, Y0[b], P[b], tab, tl, lim)
        out[b] = y
        steps[b] = s


def batch_run_serial(sy, Y0, P, tab, tl, lim, out, steps):
    """:func:`batch_run` in one thread, for a batch smaller than the thread count (its own
    function: numba's cache keys a function by its name, not by ``parallel``)."""
    for b in range(Y0.shape[0]):
        y, s = batch_run_one(sy, Y0[b], P[b], tab, tl, lim)
        out[b] = y
        steps[b] = s
