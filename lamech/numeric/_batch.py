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
and with the same iteration cap (:data:`PROJECTION_ITERATIONS`). Without numba the same
Python functions run uncompiled: the same numbers, slowly.
"""

from __future__ import annotations

import numpy as np

from ..linalg import gauss_inplace as _gauss
from ._codegen import NumericSystem, numba_available
from ._project import PROJECTION_ITERATIONS
from ._threads import one_blas_thread

__all__ = ["integrate_batch", "BatchResult"]

_S = 12
"""DOP853's number of stages (checked against SciPy's table in :func:`_tableau`)."""


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


def _build(accel, cons, jit: bool):
    """The loop, built around the system's compiled ``accelerations`` and ``constraints``
    (numba-compiled when ``jit``: the same solve ``simulate`` uses, compiled once).
    Returns (parallel loop, serial loop): the same function without numba."""
    if jit:
        import numba

        njit = numba.njit(cache=False)
    else:

        def njit(f):
            return f

    gauss_inplace = njit(_gauss)

    def gauss(K, r):
        x = r.copy()
        gauss_inplace(K.copy(), x)
        return x

    gauss = njit(gauss)

    def deriv(t, y, p, out):
        n = y.shape[0] // 2
        sol = accel(t, y, p)
        for i in range(n):
            out[i] = y[n + i]
            out[n + i] = sol[i]

    deriv = njit(deriv)

    def project(t, y, p):
        """Positions onto f = 0 (Gauss-Newton, minimum norm), then velocities onto
        A v + b = 0; in place. The compiled twin of :mod:`lamech.numeric._project` with
        the Euclidean metric, at most PROJECTION_ITERATIONS Gauss-Newton steps."""
        n = y.shape[0] // 2
        q = y[:n].copy()
        for _ in range(PROJECTION_ITERATIONS):
            f, A, b = cons(t, q, p)
            m = f.shape[0]
            big = 0.0
            for j in range(m):
                big = max(big, abs(f[j]))
            if big <= 1e-15 * (1.0 + np.max(np.abs(q))):
                break
            G = A @ A.T
            w = gauss(G, f)
            q -= A.T @ w
        f, A, b = cons(t, q, p)
        v = y[n:].copy()
        G = A @ A.T
        w = gauss(G, A @ v + b)
        v -= A.T @ w
        y[:n] = q
        y[n:] = v

    project = njit(project)

    def run_one(y0, p, t_end, rtol, atol, max_steps, A, B, C, E3, E5):
        N = y0.shape[0]
        y = y0.copy()
        t = 0.0
        K = np.zeros((_S + 1, N))
        f = np.zeros(N)
        deriv(t, y, p, f)
        # initial step (Hairer's heuristic, as scipy's select_initial_step)
        scale = atol + np.abs(y) * rtol
        d0 = np.sqrt(np.mean((y / scale) ** 2))
        d1 = np.sqrt(np.mean((f / scale) ** 2))
        h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
        y1 = y + h0 * f
        f1 = np.zeros(N)
        deriv(t + h0, y1, p, f1)
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
            for s in range(1, _S):
                dy = np.zeros(N)
                for k in range(s):
                    if A[s, k] != 0.0:
                        dy += A[s, k] * K[k]
                deriv(t + C[s] * h, y + h * dy, p, K[s])
            acc = np.zeros(N)
            for k in range(_S):
                acc += B[k] * K[k]
            ynew[:] = y + h * acc
            deriv(t + h, ynew, p, K[_S])
            scale = atol + np.maximum(np.abs(y), np.abs(ynew)) * rtol
            err5 = np.zeros(N)
            err3 = np.zeros(N)
            for k in range(_S + 1):
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
                project(t, y, p)
                deriv(t, y, p, f)
                h = h * factor
                steps += 1
            else:
                h = h * max(0.2, 0.9 * err ** (-1.0 / 8.0))
        return y, steps

    run_one = njit(run_one)

    def run_batch(Y0, P, t_end, rtol, atol, max_steps, A, B, C, E3, E5, out, steps):
        for b in prange(Y0.shape[0]):
            y, s = run_one(Y0[b], P[b], t_end, rtol, atol, max_steps, A, B, C, E3, E5)
            out[b] = y
            steps[b] = s

    if jit:
        import numba

        prange = numba.prange
        # the same loop twice: over the cores, and serial (numba's prange is range
        # outside a parallel function) for a batch smaller than the thread count
        return numba.njit(parallel=True, cache=False)(run_batch), njit(run_batch)
    prange = range
    return run_batch, run_batch


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
        _CACHE[key] = (ns, _build(ns.accelerations, ns.constraints, ns.jit and numba_available()))
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
