"""A compiled integration loop for ensembles: many runs of one system; bilateral only, or
with the contact and friction events of sweeps (:func:`integrate_events`).

:func:`integrate_batch` integrates a batch of initial states of a compiled system
(:func:`lamech.numeric.compile_system`) to ``t_end`` inside one compiled loop (lamech's
engine in C, ``lamech.numeric._cengine``: the batch spread over the cores in threads),
and returns the final states and multipliers. It is the fast path for sweeps and
ensembles of problems whose constraints are all bilateral and frictionless-or-sticking:
it has no events (no lift-off, impact or slip) and no dense output.
:func:`lamech.numeric.simulate` remains the reference; the tests hold the two to the
same numbers.

Why a hand-written loop: SciPy's DOP853 drives the right-hand side from Python (about
20 µs a call around a 2–3 µs compiled KKT kernel), and no maintained library offers an
adaptive high-order Runge–Kutta with a compiled right-hand side, a projection step and
these events. The loop is SciPy's DOP853 (same tableau, the same error norm and
step-size control: ``scipy.integrate._ivp.rk``), plus, after every accepted step, the
projection of positions (Gauss–Newton) and velocities onto the constraints: the
simulator's projection (the engine's ``ev_project``), in the
Euclidean metric (its normal equations A A^T w = f, solved by the compiled elimination)
and with the same iteration cap (6). The loop's code is ``batch.c`` on the stepper of
``dop853.c`` (the loop with events' too), in lamech's engine in C
(``lamech/numeric/_engine/``, built when lamech is installed), with the system's compiled
functions for ``compile_system(system, jit=True)``; otherwise its NumPy functions are
called back from the engine (``lamech.numeric._crules.callback_kernels``): the same numbers to
rounding, slower, in one thread.

:func:`integrate_events` is the loop with events, what ``lamech sweep`` runs: the same
DOP853 loop carrying the simulator's contact and friction mode (``loop.c``,
``modes.c``, ``impacts.c``), the watched events located by Brent's
method on DOP853's dense output, lift-off, slip and stick applied in the loop, and a
status that hands what it does not mirror (impacts and contacts, failures) to
:func:`lamech.numeric.simulate`; with :func:`parameter_rows` and :func:`initial_states`,
the case-by-case parameter vectors and consistent starts computed for a whole batch at
once. Its projection is the
simulator's (mass-matrix metric), so that its event times are the simulator's to about
1e-14 (the tests hold them to 1e-9).
"""

from __future__ import annotations

import os

import numpy as np

from ._codegen import NumericSystem, compiled_available
from ._events import EventKind
from ._kernels import codes
from ._options import Options
from ._run import ConstraintKinds
from ._tableau import _tables
from ._threads import one_blas_thread

__all__ = [
    "integrate_batch",
    "BatchResult",
    "integrate_events",
    "EventBatchResult",
    "parameter_rows",
    "initial_states",
    "jit_is_cached",
    "FALLBACKS",
]


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


def _python_loops(ns: NumericSystem):
    """(parallel loop, serial loop) of the batch part on the engine in C with the
    system's NumPy functions called back (``lamech.numeric._crules.callback_kernels``: one thread,
    the callbacks hold the GIL)."""
    from ._crules import callback_kernels

    f = callback_kernels(ns).functions
    return f["batch_run_serial"], f["batch_run_serial"]


_CACHE: dict[int, tuple] = {}


def _cpus() -> int:
    """The CPUs this process may use (its affinity mask where the OS has one)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - macOS, Windows
        return os.cpu_count() or 1


def _threads() -> int:
    """The threads the compiled batch loop spreads a batch over (the CPUs this process
    may use)."""
    return _cpus()


def integrate_batch(
    ns: NumericSystem,
    y0s,
    t_end: float,
    *,
    params=None,
    rtol: float | None = None,
    atol: float | None = None,
    max_steps: int = 1_000_000,
) -> BatchResult:
    """Integrate every row of ``y0s`` ((B, 2n): positions then velocities, consistent
    with the constraints) from t = 0 to ``t_end`` in one compiled loop.

    ``params``: None (the file's values), one dict {name: value} for every run, or a
    sequence of such dicts, one per row of ``y0s`` (an ensemble over parameters: a sweep
    of lengths or masses in one compiled loop); parameters defined by expressions of the
    overridden ones follow them, as in :meth:`~lamech.numeric.NumericSystem.parameter_vector`.

    ``rtol``, ``atol``: by default those of :class:`~lamech.Options` (the simulator's).
    ``ns`` from ``compile_system(system, jit=True)`` runs compiled (C); otherwise the
    same loop calls its NumPy functions back. Only for systems whose constraints are all
    bilateral and without friction limits (raises ValueError otherwise): there are no events here.
    """
    system = ns.system
    if any(c.unilateral or c.friction is not None for c in system.constraints):
        raise ValueError(
            "integrate_batch handles bilateral constraints only (no lift-off, "
            "impact or slip events); use lamech.simulate for this system"
        )
    if not (t_end > 0 and np.isfinite(t_end)):
        raise ValueError(f"t_end must be a positive finite number, got {t_end}")
    opts = Options.given(rtol, atol)  # checked: a SimulationError is a ValueError
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
        loops = (ns.batch_loops if not ns.replaced else ()) or _python_loops(ns)
        _CACHE[key] = (ns, loops)
    _, (run_parallel, run_serial) = _CACHE[key]
    # A batch smaller than the thread count runs serially (issue 16): one trajectory
    # through the parallel loop pays for waking the other threads, which on a busy
    # machine can cost more than the run (5-link chain, 10 s, on a loaded 2-core machine:
    # 13.9 ms at rtol 1e-5 against 2.5 ms at the tighter 1e-7).
    run_batch = run_parallel if Y0.shape[0] >= _threads() else run_serial
    out = np.empty_like(Y0)
    steps = np.zeros(Y0.shape[0], dtype=np.int64)
    lam = np.full((Y0.shape[0], ns.m), np.nan)
    n = ns.n
    # One BLAS thread (issue 16, see ._threads): the loop's small products (A A^T) gain
    # nothing from OpenBLAS's helper threads and wait on them when a core is busy; under
    # the parallel loop they would only compete with its threads for the cores.
    with one_blas_thread():
        tl = codes.tolerances(rtol=float(opts.rtol), atol=float(opts.atol), t_end=float(t_end))
        run_batch(Y0, P, _tables(), tl, codes.limits(max_steps=int(max_steps)), out, steps)
        for b in range(Y0.shape[0]):
            if np.all(np.isfinite(out[b])):
                lam[b] = ns.accelerations(float(t_end), out[b].copy(), P[b].copy())[n:]
    return BatchResult(ns.coordinate_names, ns.constraint_names, out, lam, steps)


# ----- the loop with events -------------------------------------------------------------
FALLBACKS = dict(codes.FALLBACKS)
"""The statuses of a run the loop with events leaves to :func:`lamech.numeric.simulate`
(the loop's ``ST_*`` codes, :mod:`._kernels.codes`; 3, stick, is no longer used): an
impact or contact (with ``impacts``: only one the loop cannot apply, a singular impact
matrix or a gap met below the surface), more events than recorded, a step-size
collapse, a blow-up, a penetration, a gap that turns within a step, a mode that does
not settle, a start off the constraints, a singular KKT solve."""


class EventBatchResult:
    """Runs of :func:`integrate_events`: ``t`` (B,) the time reached, ``y`` (B, 2n) the
    state there, ``events`` (B lists of :class:`~lamech.numeric.Event`: kind, constraint,
    t, coordinates and velocities), ``steps`` (B,), ``status`` (B,): ``"end"`` (reached
    t_end), ``"found"`` (stopped once every wanted event was found), or the reason the
    run is left to ``simulate`` (:data:`FALLBACKS`); ``fallback`` (B,) is True for
    those, whose ``t``, ``y`` and ``events`` are where the loop stopped."""

    def __init__(self, t, y, status, events, steps):
        self.t, self.y, self.events, self.steps = t, y, events, steps
        self.status = [codes.STATUS_NAMES[s] for s in status]
        self.fallback = np.array([s in codes.FALLBACKS for s in status], dtype=bool)


_EVENT_CACHE: dict[tuple[int, bool], tuple] = {}


def _event_functions(ns: NumericSystem, jit: bool | None = None) -> dict:
    """{"ev_run", "ev_starts", "ev_segment", "compiled"}: the engine in C's, with the
    system's compiled functions when ``jit`` (default: ``ns.jit``) and they compile
    (``"compiled"`` True), else with its NumPy functions called back
    (``lamech.numeric._crules.callback_kernels``; also where one of ``ns``' functions was replaced:
    the compiled functions would not run the replacement, :attr:`NumericSystem.replaced`)."""
    use = bool(ns.jit if jit is None else jit) and not ns.replaced and compiled_available()
    key = (id(ns), use)
    known = _EVENT_CACHE.get(key)
    if known is not None and known[0] is ns:
        return known[1]
    names = ("ev_run", "ev_starts", "ev_segment")
    from ._crules import callback_kernels, engine_kernels

    kernels = engine_kernels(ns, use) if use else callback_kernels(ns)
    use = kernels.parallel  # compiled: its own functions, no callback
    f = kernels.functions
    out: dict = {k: f[k] for k in names}
    out["compiled"] = use
    _EVENT_CACHE[key] = (ns, out)
    return out


def logged_events(ns: NumericSystem, EK, EJ, ET, EY, EX, count: int) -> list:
    """The first ``count`` events a loop with events logged (kinds EK, constraints EJ,
    times ET, states EY, details EX (code, then up to 3 values: :data:`codes.DETAILS`))
    as :class:`~lamech.numeric.Event`; an input switch's under its name (a table's
    corners, unnamed, are not events: left out)."""
    from ._events import Event

    coords, names, n = ns.coordinate_names, ns.constraint_names, ns.n
    out = []
    for e in range(count):
        if EK[e] == codes.EV_SWITCH:
            name = ns.switch_names[EJ[e]]
            if name:
                y = EY[e]
                values = {c: float(y[i]) for i, c in enumerate(coords)}
                values.update({c + "'": float(y[n + i]) for i, c in enumerate(coords)})
                out.append(Event(float(ET[e]), codes.EVENT_KINDS[codes.EV_SWITCH], name, values))
            continue
        y = EY[e]
        values = {c: float(y[i]) for i, c in enumerate(coords)}
        values.update({c + "'": float(y[n + i]) for i, c in enumerate(coords)})
        details: dict = {}
        code = int(EX[e, 0])
        if code == codes.DT_REVERSAL:
            details["reversal"] = bool(EX[e, 1])
        elif code == codes.DT_INITIAL:
            details["initial"] = True
        elif code in codes.DETAILS:
            for c, name in enumerate(codes.DETAILS[code]):
                details[name] = float(EX[e, 1 + c])
        kind = codes.EVENT_KINDS[int(EK[e])]
        out.append(Event(float(ET[e]), kind, names[EJ[e]], values, **details))
    return out


def jit_is_cached(ns: NumericSystem | None = None, function: str = "ev_run_one") -> bool:
    """Whether ``ns`` (or, given None, any system) runs compiled without compiling
    anything: the engine in C is built (at install) and, given ``ns``, its own C library
    is in the cache folder (:func:`._cc.is_built`). ``function`` is ignored (the engine
    is whole)."""
    if not compiled_available():
        return False
    if ns is None:
        return True
    from ._cc import cache_dir, is_built

    try:
        return bool(ns.c_source) and is_built(ns.c_source, cache_dir())
    except OSError:
        return False


def parameter_rows(ns: NumericSystem, names, values) -> np.ndarray:
    """The parameter vectors (B, len(ns.parameters)) of B cases that set the parameters
    ``names`` to the columns of ``values`` (B, len(names)): the rows
    :meth:`NumericSystem.parameter_vector` gives (a parameter written as an expression
    of the set ones follows them, the others keep the file's values), each derived
    expression turned into a NumPy function once instead of substituted per case."""
    import sympy as sp

    system = ns.system
    values = np.asarray(values, dtype=float).reshape(-1, len(names))
    unknown = set(names) - set(ns.parameter_names)
    if unknown:
        raise KeyError(
            f"unknown parameter(s) {sorted(unknown)}; known: {', '.join(ns.parameter_names)}"
        )
    cols = {name: values[:, k] for k, name in enumerate(names)}
    syms = [p.symbol for p in system.parameters if p.name in cols]
    args = [cols[p.name] for p in system.parameters if p.name in cols]
    rest = {s: v for s, v in system.parameter_values.items() if s not in set(syms)}
    out = np.tile(ns.parameters, (values.shape[0], 1))
    for i, par in enumerate(system.parameters):
        if par.name in cols:
            out[:, i] = cols[par.name]
            continue
        val = sp.sympify(par.value)
        if val.free_symbols & set(syms):
            fn = _of_parameters(syms, val.subs(rest))
            out[:, i] = np.broadcast_to(np.asarray(fn(*args), dtype=float), values.shape[0])
    return out


_STARTS: dict[int, tuple] = {}  # id(ns) -> (ns, the initial expressions as functions)


def initial_states(
    ns: NumericSystem, P: np.ndarray, initial=(), *, jit: bool | None = None
) -> np.ndarray:
    """The initial states (B, 2n) at the parameter vectors P (B, len(ns.parameters)): the
    coordinates' initial expressions, with ``initial`` [(coordinate or ``x'``, value)]
    held and the others moved onto the constraints the problem's own start meets, as
    :func:`lamech.numeric.consistent_initial` does case by case (here the expressions
    are evaluated as NumPy functions over the batch, and the projection runs in the
    compiled engine when ``jit``, by default ``ns.jit``)."""
    from ._options import INITIAL_TOLERANCE

    system = ns.system
    P = np.ascontiguousarray(np.atleast_2d(np.asarray(P, dtype=float)))
    B, n = P.shape[0], ns.n
    syms = [p.symbol for p in system.parameters]
    cols = [P[:, i] for i in range(len(syms))]
    known = _STARTS.get(id(ns))
    if known is None or known[0] is not ns:
        exprs = [c.initial for c in system.coordinates]
        exprs += [c.initial_velocity for c in system.coordinates]
        known = _STARTS[id(ns)] = (ns, [_of_parameters(syms, e) for e in exprs])
    Y = np.empty((B, 2 * n))
    for k, fn in enumerate(known[1]):
        Y[:, k] = np.broadcast_to(np.asarray(fn(*cols), dtype=float), B)
    if not initial:
        return Y
    hold, value = _held(ns, initial)
    Q = np.ascontiguousarray(Y[:, :n])
    V = np.ascontiguousarray(Y[:, n:])
    starts = _event_functions(ns, jit)["ev_starts"]
    with one_blas_thread():
        starts(Q, V, P, hold[0], hold[1], value[0], value[1], _kinds(system), INITIAL_TOLERANCE)
    return np.concatenate((Q, V), axis=1)


def _held(ns: NumericSystem, initial) -> tuple[np.ndarray, np.ndarray]:
    """(hold, value), (2, n) each: which coordinates (row 0) and velocities (row 1) a start
    holds at ``initial`` [(coordinate or ``x'``, value)], and their values."""
    names = ns.coordinate_names
    hold = np.zeros((2, ns.n), dtype=np.bool_)
    value = np.zeros((2, ns.n))
    for name, x in initial:
        w = 1 if name.endswith("'") else 0
        i = names.index(name.rstrip("'"))
        hold[w, i] = True
        value[w, i] = float(x)
    return hold, value


def _of_parameters(syms: list, expr):
    """``expr`` as a NumPy function of the parameter columns ``syms``: a number without
    any code; otherwise SymPy's NumPy printer's line (what ``lambdify`` writes, without
    the 50-90 ms its first call spends gathering NumPy's namespace; measured 2026-11-27)
    or, where that printer gives up, ``lambdify`` itself. ``expr`` is the problem's own,
    parsed by :mod:`lamech.expr`: no user text reaches the code."""
    import sympy as sp
    from sympy.printing.numpy import NumPyPrinter

    expr = sp.sympify(expr)
    if not expr.free_symbols:
        try:
            value = float(expr)
        except TypeError:  # zoo, nan: lambdify's value, as before
            pass
        else:
            return lambda *cols: value
    names = [f"p_{i}" for i in range(len(syms))]
    printer = NumPyPrinter({"fully_qualified_modules": True, "allow_unknown_functions": False})
    try:
        line = printer.doprint(expr.xreplace(dict(zip(syms, map(sp.Symbol, names)))))
    except Exception:  # noqa: BLE001 - any printer failure: lambdify decides
        line = ""
    if not line or getattr(printer, "_not_supported", None) or "\n" in line:
        return sp.lambdify(syms, expr, "numpy")
    namespace: dict = {"numpy": np}
    exec(f"def f({', '.join(names)}):\n    return {line}\n", namespace)  # noqa: S102
    return namespace["f"]


def _kinds(system) -> np.ndarray:
    """(3, m) int64: unilateral, holonomic, normal index (-1 where not friction)."""
    return ConstraintKinds.of(system).array()


def _parameter_rows(ns: NumericSystem, params, rows: int) -> np.ndarray:
    """(rows, len(p)) parameter vectors: None, one dict, a sequence of dicts, or an array
    of vectors as :meth:`NumericSystem.parameter_vector` gives them."""
    if params is None or isinstance(params, dict):
        return np.tile(ns.parameter_vector(params), (rows, 1))
    if isinstance(params, np.ndarray):
        P = np.array(params, dtype=float, ndmin=2)
        if P.shape != (rows, len(ns.parameters)):
            raise ValueError(f"params: an array of shape ({rows}, {len(ns.parameters)})")
        return P
    params = list(params)
    if len(params) != rows:
        raise ValueError(
            f"params: {len(params)} parameter sets for {rows} initial states; give one "
            "dict per row of y0s, or one dict for all"
        )
    return np.array([ns.parameter_vector(d) for d in params], dtype=float)


def integrate_events(
    ns: NumericSystem,
    y0s,
    t_end: float,
    *,
    params=None,
    rtol: float | None = None,
    atol: float | None = None,
    max_step: float | None = None,
    want=(),
    to_end: bool = True,
    max_events: int = 32,
    max_steps: int = 10_000_000,
    threads: int | None = None,
    jit: bool | None = None,
    impacts: bool = False,
    initial=(),
) -> EventBatchResult:
    """Every row of ``y0s`` ((B, 2n), consistent with the constraints) from t = 0 to
    ``t_end`` in the compiled loop with events: the DOP853 loop of :func:`~lamech.integrate_batch`
    (SciPy's tableau and step control, its rule that a step does not grow right after a
    rejection, its initial step after every event), with the contact and friction mode
    of :func:`lamech.simulate` and its events located the same way: after every
    accepted step the watched event functions (a unilateral lambda for lift-off, the gap
    of a released one for contact, ``mu N - |F|`` for slip, the slip velocity for stick) are
    checked for a sign change, and a crossing is located by Brent's method on DOP853's
    dense output (the 7th-order interpolant with its 3 extra stages). Lift-off, slip
    (kinetic friction against the slip velocity) and stick (friction held where the slip
    velocity reaches zero if mu N can hold it, else a slip on, reversed or not) are
    applied in the loop, each followed by the simulator's settling (a constraint that
    pulls is released, friction beyond mu N slips); the start's mode is the simulator's
    (a unilateral constraint open or opening starts released, friction with a slip
    velocity starts slipping), and the projection after each step is the simulator's
    (mass-matrix metric, the mode's rows and held offsets).

    Not mirrored here, and left to ``simulate`` (the run stops with that ``status``,
    ``fallback`` True): impacts and contacts (status ``"contact"``) unless ``impacts``, a
    start off the constraints (simulate refuses it, naming the values), a released gap that
    turns within one step, and failures (see ``lamech.numeric._batch.FALLBACKS``).
    The conditioning check and the chattering test of ``simulate`` are not made (a run
    with more than ``max_events`` events falls back).

    ``want``: (kind, constraint or None) pairs (kinds ``"lift-off"``, ``"slip"``,
    ``"stick"``, ``"contact"``, ``"impact"``); with ``to_end=False`` a run stops once each
    has happened (status ``"found"``). ``params`` as for :func:`~lamech.integrate_batch`, or an
    array of parameter vectors (B, len(ns.parameters)). Compiled (the engine in C) when
    ``jit`` (default: ``ns.jit``, whether ``ns`` was compiled with ``jit=True``) and it can
    run, else the same loop with its NumPy functions called back (same numbers to
    rounding). Compiled, the batch is cut into slices run in ``threads`` threads
    (default: the CPUs this process may use; the loop releases the GIL).
    Inputs that switch (step, min, max, clip, piecewise) switch where their s crosses 0,
    located as the events are, and a system with t in it has its force events sought
    inside each step too (as in ``simulate``).

    ``impacts=True`` applies impacts and contacts in the loop as ``simulate`` does
    (Newton's law with restitution, the contact's friction sticking or slipping through
    the impact, the Zeno accumulation's ``contact`` at its time), events ``"impact"``
    and ``"contact"`` with their details; ``max_events`` must then hold the bounces.
    ``rtol``, ``atol``, ``max_step``: by default those of :class:`~lamech.Options` (the
    simulator's).

    ``initial`` [(coordinate or ``x'``, value)]: each row of ``y0s`` is first made
    consistent as :func:`~lamech.numeric.initial_states` makes it (those held, the others
    moved onto the constraints the row meets), in the run's own thread; a start that is then
    not finite falls back (status ``"start"``). ``y0s`` itself is not changed.
    """
    from ._options import BLOW_UP, INITIAL_TOLERANCE

    if not (t_end > 0 and np.isfinite(t_end)):
        raise ValueError(f"t_end must be a positive finite number, got {t_end}")
    Y0 = np.atleast_2d(np.array(y0s, dtype=float, order="C"))  # a copy: starts made here
    B, N = Y0.shape
    if N != 2 * ns.n:
        raise ValueError(f"each initial state has {2 * ns.n} entries (q then q'), got {N}")
    P = np.ascontiguousarray(_parameter_rows(ns, params, B))
    names = ns.constraint_names
    wanted = np.array(
        [
            [codes.EVENT_CODES[EventKind(k)] for k, _ in want],
            [-1 if c is None else names.index(c) for _, c in want],
        ],
        dtype=np.int64,
    ).reshape(2, len(want))
    kinds = _kinds(ns.system)
    m = ns.m
    IM = np.zeros((B, 4, m), dtype=np.int64)
    IM[:, 0, :] = 1  # engaged
    IM[:, 1, :] = np.where(kinds[2] >= 0, codes.FR_STICK, codes.FR_NONE)  # friction sticks
    IM[:, 2:, :] = 1  # contact and stick events armed
    FM = np.zeros((B, 5, m))
    FM[:, 1, :] = 1.0  # sN
    FM[:, 3:, :] = np.nan  # no accumulation pending
    opts = Options.given(rtol, atol, max_step)
    arm = opts.arm
    EK = np.zeros((B, max_events), dtype=np.int64)
    EJ = np.zeros((B, max_events), dtype=np.int64)
    ET = np.zeros((B, max_events))
    EY = np.zeros((B, max_events, N))
    EX = np.zeros((B, max_events, 4))
    YOUT = np.zeros((B, N))
    TOUT = np.zeros(B)
    STATUS = np.zeros(B, dtype=np.int64)
    NEV = np.zeros(B, dtype=np.int64)
    STEPS = np.zeros(B, dtype=np.int64)
    run = _event_functions(ns, jit)
    tl = codes.tolerances(
        rtol=float(opts.rtol), atol=float(opts.atol), t_end=float(t_end),
        max_step=float(opts.max_step), arm_pos=arm, arm_vel=arm,
        blow_up=BLOW_UP, pen=INITIAL_TOLERANCE, tol=INITIAL_TOLERANCE,
    )  # fmt: skip
    lim = codes.limits(
        max_steps=int(max_steps), to_end=bool(to_end), impacts=bool(impacts),
        dips=ns.explicit_time, starts=bool(initial),
    )  # fmt: skip
    tab = _tables()
    start = _held(ns, initial)

    def part(a: int, b: int) -> None:
        Y, Pp, modes = Y0[a:b], P[a:b], (kinds, IM[a:b], FM[a:b])
        logs = tuple(x[a:b] for x in (EK, EJ, ET, EY, EX))
        outs = tuple(x[a:b] for x in (YOUT, TOUT, STATUS, NEV, STEPS))
        run["ev_run"](Y, Pp, tab, modes, start, tl, lim, wanted, logs, outs)

    k = 1 if not run["compiled"] else max(1, min(int(threads or _cpus()), B))
    # trial states a step rejects may overflow (the Python loop's NumPy warns; C not)
    with one_blas_thread(), np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        if k == 1:
            part(0, B)
        else:  # the compiled loop releases the GIL: slices of the batch in k threads
            from concurrent.futures import ThreadPoolExecutor

            cuts = np.linspace(0, B, min(B, 4 * k) + 1).astype(int)
            with ThreadPoolExecutor(k) as pool:
                list(pool.map(part, cuts[:-1], cuts[1:]))
    events = [logged_events(ns, EK[b], EJ[b], ET[b], EY[b], EX[b], int(NEV[b])) for b in range(B)]
    return EventBatchResult(TOUT, YOUT, STATUS, events, STEPS)
