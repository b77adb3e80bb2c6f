"""Simulation: the constrained motion, kept on the constraint manifold, with its
multipliers, contact changes (lift-off, impact, contact), and friction (slip, stick).

The motion is the index-3 DAE of :mod:`lamech.symbolic`. At each evaluation the KKT system

    [ M  -A_a^T ] [ q'' ]   [ Q - h    ]
    [ A_a   0   ] [ lam ] = [ -gamma_a ]

is solved for the active constraints a (M is never inverted alone); SciPy's DOP853
integrates (q, q') step by step and after every accepted step the state is projected
back onto the manifold: positions onto f_a = 0 by Gauss-Newton in the mass-matrix metric
(Euclidean where M is singular), velocities onto A_a q' + b_a = 0. A slipping friction
constraint j on normal k is not in a; its generalized force -mu N sign(s) dF_j/dq'
(s = F_j, the slip velocity; N = lambda_k) enters the KKT matrix as an extra term in the
column of lambda_k, so N stays exact.

Events are sign changes, checked at every step and located by root finding (Brent) on
the step's dense output:

* ``lift-off``: an engaged unilateral lambda crosses zero: the constraint and the
  friction constraints that name it as their normal are released;
* ``impact`` / ``contact``: a released unilateral f reaches zero from f > 0: the
  generalized impulse on the active set plus this constraint gives F_j+ = -e F_j-
  (Newton's law, ``restitution`` e); it bounces (``impact``) or, when e = 0 or the
  bounce is too small to resolve, engages (``contact``). Bounces that accumulate
  (0 < e < 1) engage at the last one resolved and log the ``contact`` at their
  accumulation time, 2 e |F_j-| / (|a_n| (1 - e)) later (the engine's ``ev_impact``);
* ``slip``: |lambda_friction| reaches mu N: the friction constraint is removed and
  kinetic friction applied, opposing the slip velocity;
* ``stick``: the slip velocity reaches zero and sticking can hold (else the slip
  reverses, logged as ``slip``).

The pieces: :mod:`._run` (the run's constants :class:`Setup` and data :class:`Run`, with
its contact and friction mode and the loop's rules that change it: the projection, the
event functions, the settling and the switches, one code for every engine),
:mod:`._detect` (what SciPy's steps look for besides: contacts made and unmade inside a
step, force events of systems with t in them, inputs that switch, and the location of
each on the dense output) and :mod:`._record` (the samples and the :class:`Trajectory`).
:func:`simulate` reads: check the options, the numbers (parameters, initial state), the
initial mode, then step / locate the event / apply it / sample, and assemble the
trajectory.
"""

from __future__ import annotations

import collections
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..model import System
from ._codegen import NumericSystem
from ._detect import (
    force_dips,
    inside_step,
    locate,
    locate_switch,
    lock_switches,
    switches_crossed,
)
from ._events import Status
from ._initial import initial_residuals, initial_state
from ._kernels.codes import EV_CONTACT
from ._loop import CONTACT, HANDBACK, Loop, loop_for
from ._options import (
    BLOW_UP,
    IMPLICIT,
    Options,
    SimulationError,
    Stop,
    check_options,
)
from ._pace import Watch, stiffness
from ._params import numeric_system, values_in_si
from ._record import Progress, Recorder, assemble
from ._run import Accel, Run, Setup
from ._threads import one_blas_thread
from ._trajectory import Trajectory

__all__ = ["simulate"]


def simulate(
    system: System | NumericSystem,
    t_end: float,
    *,
    params: dict | None = None,
    initial: dict | None = None,
    q0=None,
    qd0=None,
    options: Options | None = None,
    **more: Any,
) -> Trajectory:
    """Simulate ``system`` from ``t0`` to ``t_end``; see the module docstring.

    Parameters
    ----------
    system : System or NumericSystem
        The model (compiled here), or a system compiled already.
    t_end : float
        The end time.
    params : dict, optional
        Parameter values by name, overriding the problem's; a friction coefficient as
        ``"mu:<constraint>"`` (or ``"mu"`` when there is one). A value in ``params``,
        ``initial``, ``q0`` or ``qd0`` may be a quantity: text (``"30 cm"``, ``"10 deg"``)
        or a pint Quantity, converted to SI and checked against the dimension the problem
        gives or infers for its name.
    initial : dict, optional
        {coordinate or ``x'``: value}: sets those values and holds them while the other
        coordinates and velocities move (the projection onto the constraints) to meet the
        constraints the problem's own initial state meets: ``initial={"theta1": 0.01}``
        starts the cylinder just off the top, with r and theta2 following.
    q0, qd0 : dict or array, optional
        The initial state, as given (dicts by coordinate name, or arrays in coordinate
        order).
    options : Options, optional
        Tolerances, method, output times, engine (:class:`~lamech.Options`; default its
        defaults).

    Other Parameters
    ----------------
    rtol, atol, max_step, method, samples, dt, engine, jit, project_initial
        Each replaces that field of ``options`` (the keyword arguments of earlier
        versions, still accepted).
    t0 : float
        The start time (default 0).
    progress, pace, projection : callable
        Called while the run goes on (below).

    Returns
    -------
    Trajectory
        The samples, the multipliers and forces along them, the event log, the status.

    Notes
    -----
    ``samples`` (default 1001, both ends counted) or ``dt`` set the output times (dense
    output). An initial state off the constraints (``|f|`` or ``|F|`` > 1e-10 (1 + max
    ``|q|``)) raises :class:`SimulationError` unless ``project_initial``, which moves it
    to the nearest consistent state (mass-matrix metric) and says what changed in
    ``notes``. A unilateral constraint with f > 0 at the start begins released.

    ``method``: SciPy's ``"DOP853"`` (default), ``"RK45"``, or the implicit ``"Radau"`` and
    ``"BDF"`` for stiff systems (a stiff damper or spring). ``max_step`` may not force more
    than 10^8 steps. ``progress(t)`` is called after every accepted step; ``pace(pace)``
    once, after 0.5 s of wall time, with the projected wall time of the whole run and
    whether its step is held down by stability (``lamech.numeric._pace.Pace``; a callback
    may raise KeyboardInterrupt to stop the run there); ``projection(projection)`` once,
    after 1000 steps, with the steps the whole run needs at its mean step so far
    (``lamech.numeric._pace.Projection``: from counts and step sizes, the same on any
    machine; a run of fewer steps never calls it).

    A singular KKT matrix, NaN, a step-size collapse, chattering events (many events in a
    vanishing window of time) or Ctrl-C stop the run: the trajectory computed so far is
    returned with ``status`` :attr:`~lamech.numeric.Status.FAILED` or
    :attr:`~lamech.numeric.Status.INTERRUPTED` (equal to "failed", "interrupted") and a
    ``message`` naming the time and cause; its ``final_time`` and final state are the last
    ones reached, between samples too. A state through the surface of a released unilateral
    constraint (f below -1000 atol with no contact located, or a gap that jumps below zero)
    stops it with :attr:`~lamech.numeric.Status.PENETRATED` ("penetrated").

    ``jit``: run the system on lamech's engine in C (built at install): its own functions
    are compiled by the C compiler on its first run (a fraction of a second) and kept in
    the cache folder (``lamech.numeric.jit_cache_dir()``). The default, None, does so
    wherever it can (the engine built and a C compiler found), else NumPy; False: NumPy.
    Ignored when ``system`` is already a :class:`~lamech.numeric.NumericSystem`.

    ``engine``: ``"auto"`` (default) runs DOP853 in the compiled loop with events (the
    loop of :func:`lamech.numeric.integrate_events`, with the output times sampled inside
    it: ``lamech.numeric._loop``) when the system is compiled (the engine in C), else
    SciPy's integrator
    driven from Python (``"scipy"``); ``"compiled"`` asks for the compiled loop,
    ``"python"`` for the same loop with the system's NumPy functions called back from C
    (the same numbers to rounding, slower); the names of
    ``lamech.numeric._engines``, shared with ``sweep`` (the older ``"loop"`` is accepted). The loop
    applies lift-off, impacts (with the accumulation of bounces), slip and stick, inputs
    that switch and the force events inside the steps of a system with t in it, and hands
    a step it cannot take to SciPy's DOP853 for one segment; it does not run other methods
    (SimulationError for ``"compiled"`` and ``"python"``; ``"auto"`` uses SciPy there).
    Both apply the same rules: the engine's, in C (SciPy's steps call them too).

    While it runs, BLAS (NumPy's and SciPy's OpenBLAS) uses one thread, in the whole
    process: its helper threads only slow these small solves down. The limits in force
    before are restored after the run.

    Examples
    --------
    >>> import lamech
    >>> traj = lamech.simulate(lamech.load("pendulum"), 2.0, options=lamech.Options(samples=5))
    >>> str(traj.status), traj.t.tolist()
    ('ok', [0.0, 0.5, 1.0, 1.5, 2.0])
    """
    t0, hooks, options = _arguments(options, more)
    options = check_options(t_end, t0, options)
    ns, p = numeric_system(system, params, options.jit)
    if isinstance(initial, Mapping):
        initial = values_in_si(ns.system, initial, "initial")
    if isinstance(q0, Mapping):
        q0 = values_in_si(ns.system, q0, "q0")
    if isinstance(qd0, Mapping):  # checked as velocities (x')
        rates = values_in_si(ns.system, {f"{k}'": v for k, v in qd0.items()}, "qd0")
        qd0 = {k[:-1]: v for k, v in rates.items()}
    y0 = initial_state(ns, p, initial, q0, qd0)
    times = options.times(t0, t_end)
    run = Run(Setup.of(ns, p, options))
    loop = loop_for(run, options.engine, times)
    if loop is None:  # SciPy's integrators: their BLAS is limited too, so loaded first
        import scipy.linalg  # noqa: F401  (the integrators import it anyway)
    notes: list[str] = _degree_notes(ns, p, y0)
    # One BLAS thread for the run, entered once (issue 16: with other work on the 2 cores,
    # OpenBLAS's helper threads made the 40- to 100-link chains 5-70 times slower; the
    # measurements are in ._threads).
    with one_blas_thread():
        y = initial_mode(run, t0, y0, options.project_initial, notes)
        watch = Watch(t0, t_end, options.method, *hooks)
        return _integrate(run, Recorder(run, times), Progress(t0, y), t_end, watch, notes, loop)


_HOOKS = ("progress", "pace", "projection")


def _arguments(options: Options | None, more: dict) -> tuple[float, tuple, Options]:
    """``simulate``'s other keyword arguments: (t0, the callbacks (progress, pace,
    projection), the options with the fields given as keywords replaced)."""
    more = dict(more)
    t0 = more.pop("t0", 0.0)
    hooks = tuple(more.pop(name, None) for name in _HOOKS)
    try:
        return t0, hooks, Options.merged(options, **more)
    except TypeError as exc:
        raise TypeError(f"simulate: {exc}; or t0, {', '.join(_HOOKS)}") from None


def initial_mode(
    run: Run, t0: float, y: np.ndarray, project_initial: bool, notes: list[str]
) -> np.ndarray:
    """Set the mode the initial state is in (:meth:`Run.start`: a unilateral constraint
    open or opening starts released, a friction constraint with a slip velocity starts
    slipping). Returns y, projected onto the constraints when ``project_initial`` (else a
    state off them raises :class:`SimulationError`, saying which and by how much)."""
    if run.start(t0, y):
        return y
    setup = run.setup
    n = setup.n
    f, F, tol = initial_residuals(setup.ns, setup.p, t0, y[:n], y[n:])
    names, hol = setup.ns.constraint_names, setup.kinds.holonomic
    bad = []
    for j in run.act[0]:
        if hol[j] and abs(f[j]) > tol:
            bad.append(f"`{names[j]}` f = {f[j]:.6g}")
        elif abs(F[j]) > tol:
            bad.append(
                f"`{names[j]}` df/dt = {F[j]:.6g}" if hol[j] else f"`{names[j]}` g = {F[j]:.6g}"
            )
    if not project_initial:
        raise SimulationError(
            "the initial state violates the constraints: "
            + "; ".join(bad)
            + " (tolerance 1e-10 (1 + max |q|)); fix the initial values "
            "or use `project_initial=True`"
        )
    y2, _ = run.project(t0, y)
    changes = [
        f"{name}{s}: {a:.12g} -> {b_:.12g}"
        for i, name in enumerate(setup.ns.coordinate_names)
        for s, a, b_ in (("", y[i], y2[i]), ("'", y[n + i], y2[n + i]))
        if abs(a - b_) > 0
    ]
    notes.append(
        "initial state projected onto the constraints ("
        + "; ".join(bad)
        + "): "
        + ", ".join(changes)
    )
    return y2


def _degree_notes(ns: NumericSystem, p: np.ndarray, y0: np.ndarray) -> list[str]:
    """The run's angles that look like degrees (:func:`lamech.model._hints.degree_hints`) at
    its own parameters and start, those the system's notes do not say already."""
    from ..model._hints import degree_hints

    system = ns.system
    found = degree_hints(
        system,
        initial={c: float(y0[i]) for i, c in enumerate(ns.coordinate_names)},
        parameters={par.name: float(p[i]) for i, par in enumerate(system.parameters)},
    )
    return [h for h in found if h not in system.notes]


def _integrate(
    run: Run,
    rec: Recorder,
    at: Progress,
    t_end: float,
    watch: Watch,
    notes: list[str],
    loop: Loop | None = None,
) -> Trajectory:
    """Settle the initial mode, then integrate segment by segment (a new integrator after
    each event) until t_end or the last sample; a failure or Ctrl-C ends the run early
    with what it computed."""
    status, message = Status.OK, ""
    # Trial states the integrator rejects may overflow or give NaN (that is how they are
    # rejected); a failure at an accepted state stops the run with its cause. NumPy's
    # warnings about them are noise: off for the run (set once: per call it costs 1 us).
    saved = np.seterr(invalid="ignore", over="ignore", divide="ignore")
    try:
        at.y = run.settle(at.t, at.y)
        lock_switches(run, at.t, at.y)
        rec.start(at.t, at.y)
        # A state 1e12 times its start (in size) is a blow-up, not physics to follow with
        # ever smaller steps (a 1/(1 - t)^3 force took 175 000 steps to fail otherwise).
        blow_up = BLOW_UP * (1.0 + float(np.max(np.abs(at.y), initial=0.0)))
        zeno = _Zeno(at.t, t_end)
        while at.t < t_end and rec.pending:
            if loop is None:
                _segment(run, rec, at, t_end, blow_up, zeno, watch)
            else:
                _loop_call(loop, run, rec, at, t_end, blow_up, zeno, watch)
    except _Penetrated as stop:
        status, message = Status.PENETRATED, stop.cause
    except Stop as stop:
        status, message = Status.FAILED, stop.cause
    except KeyboardInterrupt:
        rec.drop_after(at.t)
        status, message = (
            Status.INTERRUPTED,
            f"interrupted at t = {at.t:.12g}; the trajectory up to there is kept",
        )
    finally:
        np.seterr(**saved)
    engine = loop.name if loop is not None else f"SciPy {run.setup.options.method}"
    return assemble(run, rec, notes, status, message, t_end, at, engine)


def _segment(
    run: Run, rec: Recorder, at: Progress, t_end: float, blow_up: float, zeno: _Zeno, watch: Watch
) -> None:
    """Integrate from ``at`` until an event (applied) or t_end: step, project, look for
    an event, sample; ``at`` follows every accepted step."""
    n, opts = run.setup.n, run.setup.options
    # A contact engaged at an impact whose bounces accumulate begins at their
    # accumulation time: the segment ends there, to log it (the mode does not change).
    bound = run.bound(t_end)
    if bound <= at.t:
        run.accumulated(at.t, at.y)
        return
    solver = opts.integrator()(
        run.fun, at.t, at.y, bound, rtol=opts.rtol, atol=opts.atol, max_step=opts.max_step
    )
    g_old = run.values(at.t, at.y)
    while solver.status == "running":
        msg = solver.step()
        at.steps += 1
        if solver.status == "failed":
            raise Stop(diagnose_failure(run, solver.t, solver.y, msg, opts.method))
        t_a, t_b = solver.t_old, solver.t
        _check_growth(solver.y, t_b, blow_up)
        yb, moved = run.project(t_b, solver.y)
        at.max_projection = max(at.max_projection, moved)
        acc = run.kkt(t_b, yb[:n], yb[n:])
        g_new = run.values(t_b, yb, acc)
        dense = _Lazy(solver.dense_output)  # DOP853's costs 3 more evaluations: on need
        brackets = inside_step(run, dense, t_a, at.y, t_b, yb) if run.released else {}
        if brackets:
            g_new = run.values(t_b, yb, acc)  # arming changed them
        crossed = (g_old > 0) & (g_new <= 0)
        if run.setup.ns.explicit_time and not crossed.any():
            brackets.update(force_dips(run, dense, t_a, t_b, g_old, g_new))
        for i, (_, hi) in brackets.items():
            crossed[i] = hi < t_b or g_new[i] <= 0  # a dip, or a crossing after the apex
        hit = np.nonzero(crossed)[0]
        switched = switches_crossed(run, t_b, yb)
        located = locate(run, dense(), hit, t_a, t_b, brackets) if len(hit) else (t_b, -1)
        first = locate_switch(run, dense(), switched, t_a, t_b) if len(switched) else None
        if first is not None and (located[1] < 0 or first[0] <= located[0]):
            _switch(run, rec, at, dense(), first, zeno)
        elif located[1] >= 0:
            _event(run, rec, at, dense(), located, zeno)
        if first is not None or located[1] >= 0:
            watch.step(run, at.t, at.y, t_b - t_a, at.steps)
            return
        _check_penetration(run, t_b, yb)
        rec.up_to(t_b, dense, yb)
        _check_conditioning(run, acc, t_b, yb, at.steps)
        run.arm(t_b, yb)
        g_old = run.values(t_b, yb, acc)
        _restart_from(solver, yb, np.concatenate((yb[n:], acc.qdd)))
        at.t, at.y = t_b, yb
        watch.step(run, t_b, yb, t_b - t_a, at.steps)
    at.t = bound  # finished
    run.accumulated(at.t, at.y)


def _loop_call(
    loop: Loop,
    run: Run,
    rec: Recorder,
    at: Progress,
    t_end: float,
    blow_up: float,
    zeno: _Zeno,
    watch: Watch,
) -> None:
    """One call of the loop (:mod:`._loop`); a contact it located is applied here, and
    what it cannot do the simulator does for one segment."""
    what, detail = loop.advance(rec, at, t_end, blow_up, zeno)
    if what in (CONTACT, HANDBACK):
        run.handed_back += 1
    if what == CONTACT:
        j = int(detail)
        _check_penetration(run, at.t, at.y, met=j)
        logged = len(run.events)
        at.y = run.apply(at.t, at.y, EV_CONTACT, j)
        zeno.check(at.t, [(str(e.kind), e.constraint) for e in run.events[logged:]])
    elif what == HANDBACK:
        at.y = run.settle(at.t, at.y)  # a mode the loop could not settle: the cause
        _segment(run, rec, at, t_end, blow_up, zeno, watch)
    elif detail > 0:
        watch.step(run, at.t, at.y, detail, at.steps)


def _restart_from(solver, y: np.ndarray, f: np.ndarray) -> None:
    """Continue the integrator from the projected state y (f the right-hand side there).
    BDF keeps its state in a table of backward differences whose first row is y: the
    projection's correction goes there too (its later rows, differences, are kept)."""
    from scipy.integrate import BDF

    if isinstance(solver, BDF):
        solver.D[0] += y - solver.y
    solver.y = y
    solver.f = f


def _event(
    run: Run, rec: Recorder, at: Progress, dense, located: tuple[float, int], zeno: _Zeno
) -> None:
    """Sample up to the first event of the step (``located``: its time and index in the
    mode's watch list), and apply it."""
    te, ie = located
    rec.up_to(te, lambda: dense)
    ye, _ = run.project(te, dense(te))
    kind, j = int(run.watch[0][ie]), int(run.watch[1][ie])
    at.t, at.y = te, ye  # reached, whether or not the event can be applied
    if kind == EV_CONTACT:
        _check_penetration(run, te, ye, met=j)
    logged = len(run.events)
    at.y = run.apply(te, ye, kind, j)
    zeno.check(te, [(str(e.kind), e.constraint) for e in run.events[logged:]])


def _switch(
    run: Run, rec: Recorder, at: Progress, dense, located: tuple[float, int], zeno: _Zeno
) -> None:
    """Sample up to the time an input switches, hold its new branch from there, and
    make the mode consistent (a force that jumps may lift a contact off)."""
    ts, k = located
    rec.up_to(ts, lambda: dense)
    ys, _ = run.project(ts, dense(ts))
    at.t, at.y = ts, ys
    logged = len(run.events)
    at.y = run.switch(ts, ys, k)
    zeno.check(ts, [(str(e.kind), e.constraint) for e in run.events[logged:]])


class _Lazy:
    """A value computed on the first call, then kept."""

    def __init__(self, make):
        self.make, self.value = make, None

    def __call__(self):
        if self.value is None:
            self.value = self.make()
        return self.value


class _Zeno:
    """Stops a run whose events accumulate: more than :data:`SAME_TIME` at one t (Zeno
    behaviour), or the last :data:`WINDOW` events in so short a window of time that at
    their rate more than :data:`MAX_PROJECTED` would come before t_end, without the
    intervals shrinking as a Zeno sequence's do (a bouncing ball's; the impact law ends
    those by engaging the contact once a bounce is too small to resolve): a contact
    that chatters, released and re-engaged at once, over and over.
    """

    SAME_TIME = 50
    WINDOW = 100
    MAX_PROJECTED = 1e5
    SHRINKING = 0.9
    """The intervals shrink when the later half of the window spans less than this
    fraction of the earlier half (a ball with e < 0.998)."""

    def __init__(self, t0: float, t_end: float):
        self.t0, self.t_end = t0, t_end
        self.last: float | None = None
        self.burst = 0
        self.recent: collections.deque = collections.deque(maxlen=self.WINDOW)

    def check(self, te: float, logged: list[tuple[str, str]]) -> None:
        """After the events ``logged`` (kind, constraint) at ``te``."""
        if self.last is not None and te - self.last <= 1e-12 * max(1, abs(te)):
            self.burst += 1
            if self.burst > self.SAME_TIME:
                raise Stop(
                    f"more than {self.SAME_TIME} events at t = {te:.12g} (Zeno behaviour or "
                    "chattering contact); try a smaller restitution or check the "
                    "friction data"
                )
        else:
            self.burst = 0
        self.last = te
        self.recent.extend((te, kind, constraint) for kind, constraint in logged)
        if len(self.recent) < self.WINDOW:
            return
        first, middle = self.recent[0][0], self.recent[self.WINDOW // 2][0]
        window = te - first
        if window <= 0 or te - middle < self.SHRINKING * (middle - first):
            return
        projected = (self.t_end - te) * self.WINDOW / window
        if projected <= self.MAX_PROJECTED:
            return
        cycle = ", ".join(sorted({f"{k} of `{c}`" for _, k, c in self.recent}))
        raise Stop(
            f"chattering: the last {self.WINDOW} events ({cycle}) came within "
            f"{window:.3g} s before t = {te:.12g}; at that rate about {projected:.2g} more "
            "before t_end. A contact that can neither hold nor open (lambda < 0 when it is "
            "held, the gap closing at once when it is released): check the masses and the "
            "sign of T, the restitution and the friction data"
        )


class _Penetrated(Stop):
    """A run stopped at a state on the forbidden side of a unilateral constraint."""


def _check_penetration(run: Run, t: float, y: np.ndarray, met: int | None = None) -> None:
    """A released unilateral constraint whose gap is below minus the event tolerance is a
    body through a surface the problem names: the run stops with status ``penetrated``,
    never a silent ``ok``. Checked at each step end with no contact located (there the
    crossing was not seen: the step began on or below the surface) and, for constraint
    ``met``, where its contact was located (a gap that jumps below zero: the surface
    moved through the body). The tolerance is 10 ``arm_pos`` (1000 atol; a contact is
    located at a gap of at most ``arm_pos`` below zero), or the initial state's
    tolerance where that is larger."""
    setup = run.setup
    if not run.released:
        return
    wk, wj = run.watch
    released = [int(j) for kind, j in zip(wk, wj) if kind == EV_CONTACT]
    if met is not None:
        released = [met]
    n = setup.n
    f = run.constraints(t, y[:n])[0]
    depth = run.depth(y[:n])
    for j in released:
        if f[j] >= -depth:
            continue
        name = setup.ns.constraint_names[j]
        if met is None:
            where = (
                "and no contact was located (the step began on or below the surface); the "
                "run stops at the last state on the allowed side"
            )
        else:
            where = "where its contact was located: the gap jumped below zero (the surface "
            where += "moved through the body, or f is discontinuous); the run stops there"
        raise _Penetrated(
            f"`{name}` was passed through at t = {t:.12g}: f = {f[j]:.3g} < -{depth:.3g} "
            f"(the tolerance) while it was released, {where}. Try a tighter rtol/atol or a "
            "smaller `max_step=`, and check that f is continuous"
        )


def _check_growth(y: np.ndarray, t: float, blow_up: float) -> None:
    big = float(np.max(np.abs(y)))
    if not math.isfinite(big) or big > blow_up:
        raise Stop(
            f"the state grows without bound at t = {t:.12g} (max |q|, "
            f"|q'| = {big:.3g}): a force or a singularity that blows up; "
            "check [forces], the parameters and the initial state"
        )


def _check_conditioning(run: Run, acc: Accel, t: float, y: np.ndarray, steps: int) -> None:
    """Every 8th step: stop where the KKT matrix is nearly singular (saying so where the
    cause is the pole of polar coordinates, :meth:`Run.pole`)."""
    if steps % 8 != 1:
        return
    cond = np.linalg.cond(acc.K)
    if cond > 1e13:
        pole = run.pole(t, y[: run.setup.n])
        if pole:
            raise Stop(
                f"the KKT matrix is nearly singular at t = {t:.12g} (condition number "
                f"{cond:.3g}): {pole}"
            )
        raise Stop(
            f"the KKT matrix is nearly singular at t = {t:.12g} "
            f"(condition number {cond:.3g}): a singular "
            "configuration (dependent constraints) or a motion without "
            "inertia; forces there are not determined. Try "
            "starting elsewhere, a shorter `t_end=`, or removing "
            "a redundant constraint"
        )


def diagnose_failure(run: Run, t: float, y: np.ndarray, msg, method: str = "DOP853") -> str:
    """The message of a step-size collapse at (t, y): the KKT matrix's condition there,
    NaN in the dynamics just after it, or a stiff system (the step held down by
    stability: an implicit method is the cure)."""
    n = run.setup.n
    extra = ""
    try:
        c = np.linalg.cond(run.kkt(t, y[:n], y[n:]).K)
        if c > 1e10:
            extra = f"; the KKT matrix is nearly singular there (condition {c:.3g})"
    except Stop as s:
        extra = "; " + s.cause
    if not extra:
        probe = run.fun(t + 1e-9 * max(1.0, abs(t)), y)
        if not np.all(np.isfinite(probe)):
            extra = (
                "; the dynamics are NaN or undefined just after it (an expression "
                "left its domain, e.g. sqrt or log of a negative number)"
            )
    if not extra and method not in IMPLICIT:
        ratio, fastest = stiffness(run, t, y, max(abs(t), 1.0) * 1e-12)
        if fastest < 1e-6 * max(abs(t), 1.0):
            extra = (
                f"; the system is stiff here (its fastest time scale is {fastest:.3g} s): "
                'try method Radau or BDF (`method="Radau"`)'
            )
    return (
        f"step size collapsed at t = {t:.12g} ({msg}){extra}; try a looser rtol/atol, "
        "or check for a singular configuration or a force that blows up"
    )
