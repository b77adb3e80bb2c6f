"""A compiled integration loop for ensembles: many runs of one system, bilateral only.

:func:`integrate_batch` integrates a batch of initial states of a compiled system
(:func:`lamech.numeric.compile_system`) to ``t_end`` inside one numba-compiled loop (the
batch spread over the cores; a batch smaller than numba's thread count runs serially),
and returns the final states and multipliers. It is the fast path for sweeps and
ensembles of problems whose constraints are all bilateral and frictionless-or-sticking:
it has no events (no lift-off, impact or slip) and no dense output.
:func:`lamech.numeric.simulate` remains the reference; the tests hold the two to the
same numbers.

Why a hand-written loop: SciPy's DOP853 drives the right-hand side from Python (about
20 µs a call around a 2–3 µs compiled KKT kernel), and no maintained library offers an
adaptive high-order Runge–Kutta that numba can call with a compiled right-hand side and
a projection step. The loop is SciPy's DOP853 (same tableau, the same error norm and
step-size control: ``scipy.integrate._ivp.rk``), plus, after every accepted step, the
projection of positions (Gauss–Newton) and velocities onto the constraints: the
compiled twin of the simulator's projection (:mod:`lamech.numeric._project`), in the
Euclidean metric (its normal equations A A^T w = f, solved by the compiled elimination)
and with the same iteration cap (:data:`PROJECTION_ITERATIONS`). The loop's code is the
``BATCH`` part of :mod:`._kernels`, compiled with the system's kernels (and cached on
disk with them, :mod:`._jitcache`) by ``compile_system(system, jit=True)``; without
numba the same Python functions run uncompiled: the same numbers, slowly.
"""

from __future__ import annotations

import types

import numpy as np

from ..linalg import gauss_inplace as _gauss
from ._codegen import NumericSystem, numba_available
from ._kernels import STAGES as _S  # DOP853's number of stages, checked in _tableau
from ._project import PROJECTION_ITERATIONS
from ._threads import one_blas_thread

__all__ = ["integrate_batch", "BatchResult"]


def _tableau():
    """SciPy's DOP853 coefficients (A, B, C, E3, E5), imported on first use."""
    from scipy.integrate._ivp import dop853_coefficients as dop

    assert dop.N_STAGES == _S
    return (
        np.ascontiguousarray(dop.A[:_S, :_S]),
        np.ascontiguousarray(dop.B),
        np.ascontiguousarray(dop.C[:_S]),
        np.ascontiguousarray(dop.E3),
        np.ascontiguousarray(dop.E5),
    )


class BatchResult:
    """Final states of a batch: ``q`` (B, n), ``qd`` (B, n), ``lambdas`` (B, m),
    ``steps`` (B,) accepted steps, ``ok`` (B,) False where a run failed (step-size
    collapse or a singular KKT matrix; its row holds NaN)."""

    def __init__(self, names, constraint_names, y, lam, steps):
        n = len(names)
        self.coordinates = list(names)
        self.constraints = list(constraint_names)
        self.q, self.qd = y[:, :n], y[:, n:]
        self.lambdas = lam
        self.steps = steps
        self.ok = np.all(np.isfinite(y), axis=1) & (steps >= 0)


def _python_loops(accel, cons):
    """(parallel loop, serial loop) of :mod:`._kernels`' batch part as Python, around the
    system's NumPy ``accelerations`` and ``constraints``: its functions with globals of
    their own (no numba: the same code the compiled system runs, slowly)."""
    from . import _kernels

    namespace = {
        "np": np,
        "gauss_inplace": _gauss,
        "accelerations": accel,
        "constraints": cons,
        "PROJECTION_ITERATIONS": PROJECTION_ITERATIONS,
        "STAGES": _S,
        "prange": range,
    }
    for name in (*_kernels.BATCH_NAMES, "batch_run", "batch_run_serial"):
        f = getattr(_kernels, name)
        namespace[name] = types.FunctionType(f.__code__, namespace, name)
    return namespace["batch_run"], namespace["batch_run_serial"]


_CACHE: dict[int, tuple] = {}


def _threads() -> int:
    """numba's thread count (1 without numba: the loop is serial then anyway)."""
    if not numba_available():
        return 1
    import numba

    return int(numba.get_num_threads())


def integrate_batch(
    ns: NumericSystem,
    y0s,
    t_end: float,
    *,
    params=None,
    rtol: float = 1e-10,
    atol: float = 1e-12,
    max_steps: int = 1_000_000,
) -> BatchResult:
    """Integrate every row of ``y0s`` ((B, 2n): positions then velocities, consistent
    with the constraints) from t = 0 to ``t_end`` in one compiled loop.

    ``params``: None (the file's values), one dict {name: value} for every run, or a
    sequence of such dicts, one per row of ``y0s`` (an ensemble over parameters: a sweep
    of lengths or masses in one compiled loop); parameters defined by expressions of the
    overridden ones follow them, as in :meth:`NumericSystem.parameter_vector`.

    ``ns`` from ``compile_system(system, jit=True)`` runs compiled (numba); otherwise the
    same loop runs as Python. Only for systems whose constraints are all bilateral and
    without friction limits (raises ValueError otherwise): there are no events here.
    """
    system = ns.system
    if any(c.unilateral or c.friction is not None for c in system.constraints):
        raise ValueError(
            "integrate_batch handles bilateral constraints only (no lift-off, "
            "impact or slip events); use lamech.simulate for this system"
        )
    if not (t_end > 0 and np.isfinite(t_end)):
        raise ValueError(f"t_end must be a positive finite number, got {t_end}")
    if not (0 < rtol < 1 and atol > 0):
        raise ValueError("need 0 < rtol < 1 and atol > 0")
    Y0 = np.ascontiguousarray(np.atleast_2d(np.asarray(y0s, dtype=float)))
    if Y0.shape[1] != 2 * ns.n:
        raise ValueError(
            f"each initial state has {2 * ns.n} entries (q then q'), got {Y0.shape[1]}"
        )
    if params is None or isinstance(params, dict):
        P = np.tile(ns.parameter_vector(params), (Y0.shape[0], 1))
    else:
        params = list(params)
        if len(params) != Y0.shape[0]:
            raise ValueError(
                f"params: {len(params)} parameter sets for {Y0.shape[0]} "
                "initial states; give one dict per row of y0s, or one dict "
                "for all"
            )
        P = np.array([ns.parameter_vector(d) for d in params], dtype=float)
    P = np.ascontiguousarray(P.reshape(Y0.shape[0], len(ns.parameter_names)))
    key = id(ns)
    if key not in _CACHE or _CACHE[key][0] is not ns:
        loops = ns.batch_loops or _python_loops(ns.accelerations, ns.constraints)
        _CACHE[key] = (ns, loops)
    _, (run_parallel, run_serial) = _CACHE[key]
    # A batch smaller than the thread count runs serially (issue 16): one trajectory
    # through the parallel loop pays for waking numba's other threads, which on a busy
    # machine can cost more than the run (5-link chain, 10 s, on a loaded 2-core machine:
    # 13.9 ms at rtol 1e-5 against 2.5 ms at the tighter 1e-7).
    run_batch = run_parallel if Y0.shape[0] >= _threads() else run_serial
    out = np.empty_like(Y0)
    steps = np.zeros(Y0.shape[0], dtype=np.int64)
    lam = np.full((Y0.shape[0], ns.m), np.nan)
    n = ns.n
    # One BLAS thread (issue 16, see ._threads): the loop's small products (A A^T) gain
    # nothing from OpenBLAS's helper threads and wait on them when a core is busy; under
    # numba's parallel loop they would only compete with its threads for the cores.
    with one_blas_thread():
        run_batch(
            Y0, P, float(t_end), float(rtol), float(atol), int(max_steps), *_tableau(), out, steps
        )
        for b in range(Y0.shape[0]):
            if np.all(np.isfinite(out[b])):
                lam[b] = ns.accelerations(float(t_end), out[b].copy(), P[b].copy())[n:]
    return BatchResult(ns.coordinate_names, ns.constraint_names, out, lam, steps)
