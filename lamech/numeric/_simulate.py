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
  bounce is too small to resolve, engages (``contact``);
* ``slip``: |lambda_friction| reaches mu N: the friction constraint is removed and
  kinetic friction applied, opposing the slip velocity;
* ``stick``: the slip velocity reaches zero and sticking can hold (else the slip
  reverses, logged as ``slip``).

The pieces: :mod:`._run` (the run's constants :class:`Setup` and data :class:`Run`, with
its :class:`~._mode.Mode`), :mod:`._project` (the projection), :mod:`._detect` (event
functions and their location), :mod:`._switch` (the mode switches) and :mod:`._record`
(the samples and the :class:`Trajectory`). :func:`simulate` reads: check the options,
the numbers (parameters, initial state), the initial mode, then step / locate the event
/ apply it / sample, and assemble the trajectory.
"""

from __future__ import annotations

import math

import numpy as np

from ..model import System
from ._codegen import NumericSystem
from ._detect import event_values, inside_step, locate, update_arming
from ._events import EventKind, Status
from ._initial import initial_state
from ._options import (
    BLOW_UP,
    DEFAULT_ATOL,
    DEFAULT_RTOL,
    PENETRATION,
    Options,
    Stop,
    check_options,
    sample_times,
)
from ._params import numeric_system
from ._record import Progress, Recorder, assemble
from ._run import Accel, Run, Setup
from ._switch import apply, initial_mode, settle
from ._trajectory import Trajectory

__all__ = ["simulate"]


def simulate(
    system: System | NumericSystem,
    t_end: float,
    *,
    t0: float = 0.0,
    samples: int | None = None,
    dt: float | None = None,
    rtol: float = DEFAULT_RTOL,
    atol: float = DEFAULT_ATOL,
    max_step: float | None = None,
    params: dict | None = None,
    q0=None,
    qd0=None,
    initial: dict | None = None,
    project_initial: bool = False,
    method: str = "DOP853",
    progress=None,
    jit: bool = False,
) -> Trajectory:
    """Simulate ``system`` from ``t0`` to ``t_end``; see the module docstring.

    ``samples`` (default 1001, both ends counted) or ``dt`` set the output times (dense
    output). ``params`` overrides parameter values by name; ``q0``/``qd0`` override the
    initial state (dicts by coordinate name, or arrays in coordinate order), as given.
    ``initial`` {coordinate or ``x'``: value} sets those values and holds them while the
    other coordinates and velocities move (the projection onto the constraints) to meet
    the constraints the problem's own initial state meets: ``initial={"theta1": 0.01}``
    starts the cylinder just off the top, with r and theta2 following. ``params`` may
    also name a friction coefficient (``"mu:<constraint>"``, or ``"mu"`` when there is
    one). An initial state off the constraints (|f| or |F| > 1e-10 (1 + max |q|)) raises
    :class:`SimulationError` unless ``project_initial``, which moves it to the nearest
    consistent state (mass-matrix metric) and says what changed in ``notes``. A
    unilateral constraint with f > 0 at the start begins released.

    A singular KKT matrix, NaN, a step-size collapse or Ctrl-C stop the run: the
    trajectory computed so far is returned with ``status`` :attr:`Status.FAILED` or
    :attr:`Status.INTERRUPTED` (equal to "failed", "interrupted") and a ``message``
    naming the time and cause.
    """
    check_options(t_end, t0, rtol, atol, max_step, samples, dt, method)
    ns, p = numeric_system(system, params, jit)
    y0 = initial_state(ns, p, initial, q0, qd0)
    times = sample_times(t0, t_end, samples, dt)
    run = Run(Setup.of(ns, p, Options(rtol, atol, max_step or math.inf, method)))
    notes: list[str] = []
    y = initial_mode(run, t0, y0, project_initial, notes)
    return _integrate(run, Recorder(run, times), Progress(t0, y), t_end, progress, notes)


def _integrate(
    run: Run, rec: Recorder, at: Progress, t_end: float, progress, notes: list[str]
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
        at.y = settle(run, at.t, at.y)
        rec.start(at.t, at.y)
        # A state 1e12 times its start (in size) is a blow-up, not physics to follow with
        # ever smaller steps (a 1/(1 - t)^3 force took 175 000 steps to fail otherwise).
        blow_up = BLOW_UP * (1.0 + float(np.max(np.abs(at.y), initial=0.0)))
        zeno = _Zeno()
        while at.t < t_end and rec.pending:
            _segment(run, rec, at, t_end, blow_up, zeno, progress)
    except Stop as stop:
        status, message = Status.FAILED, stop.cause
    except KeyboardInterrupt:
        status, message = (
            Status.INTERRUPTED,
            f"interrupted at t = {at.t:.12g}; the trajectory up to there is kept",
        )
    finally:
        np.seterr(**saved)
    return assemble(run, rec, notes, status, message, t_end, at)


def _segment(
    run: Run, rec: Recorder, at: Progress, t_end: float, blow_up: float, zeno: _Zeno, progress
) -> None:
    """Integrate from ``at`` until an event (applied) or t_end: step, project, look for
    an event, sample; ``at`` follows every accepted step."""
    n, opts = run.setup.n, run.setup.options
    solver = opts.integrator()(
        run.fun, at.t, at.y, t_end, rtol=opts.rtol, atol=opts.atol, max_step=opts.max_step
    )
    g_old = event_values(run, at.t, at.y)
    while solver.status == "running":
        msg = solver.step()
        at.steps += 1
        if solver.status == "failed":
            raise Stop(diagnose_failure(run, solver.t, solver.y, msg))
        t_a, t_b = solver.t_old, solver.t
        _check_growth(solver.y, t_b, blow_up)
        yb, moved = run.project(t_b, solver.y)
        at.max_projection = max(at.max_projection, moved)
        acc = run.kkt(t_b, yb[:n], yb[n:])
        g_new = event_values(run, t_b, yb, acc)
        dense = _Lazy(solver.dense_output)  # DOP853's costs 3 more evaluations: on need
        brackets = inside_step(run, dense, t_a, at.y, t_b, yb) if run.mode.released else {}
        if brackets:
            g_new = event_values(run, t_b, yb, acc)  # arming changed them
        crossed = (g_old > 0) & (g_new <= 0)
        for i, (_, hi) in brackets.items():
            crossed[i] = hi < t_b or g_new[i] <= 0  # a dip, or a crossing after the apex
        hit = np.nonzero(crossed)[0]
        if len(hit):
            _event(run, rec, at, dense(), hit, t_a, t_b, zeno, brackets)
            return
        _check_penetration(run, t_b, yb)
        rec.up_to(t_b, dense, yb)
        _check_conditioning(acc, t_b, at.steps)
        if not run.mode.all_armed():
            update_arming(run, t_b, yb)
        g_old = event_values(run, t_b, yb, acc)
        solver.y = yb
        solver.f = np.concatenate((yb[n:], acc.qdd))
        at.t, at.y = t_b, yb
        if progress is not None:
            progress(at.t)
    at.t = t_end  # finished


def _event(
    run: Run,
    rec: Recorder,
    at: Progress,
    dense,
    hit,
    t_a: float,
    t_b: float,
    zeno: _Zeno,
    brackets: dict[int, tuple[float, float]],
) -> None:
    """Locate the first event of the step, sample up to it, and apply it."""
    te, ie = locate(run, dense, hit, t_a, t_b, brackets)
    rec.up_to(te, lambda: dense)
    ye, _ = run.project(te, dense(te))
    kind, j = run.mode.watch[ie]
    zeno.check(te)
    at.y = apply(run, te, ye, kind, j)
    at.t = te


class _Lazy:
    """A value computed on the first call, then kept."""

    def __init__(self, make):
        self.make, self.value = make, None

    def __call__(self):
        if self.value is None:
            self.value = self.make()
        return self.value


class _Zeno:
    """Stops a run with more than 50 events at one time (Zeno behaviour, chattering)."""

    def __init__(self):
        self.last: float | None = None
        self.burst = 0

    def check(self, te: float) -> None:
        if self.last is not None and te - self.last <= 1e-12 * max(1, abs(te)):
            self.burst += 1
            if self.burst > 50:
                raise Stop(
                    f"more than 50 events at t = {te:.12g} (Zeno behaviour or "
                    "chattering contact); try a smaller restitution or check the "
                    "friction data"
                )
        else:
            self.burst = 0
        self.last = te


def _check_penetration(run: Run, t: float, y: np.ndarray) -> None:
    """A released unilateral constraint whose gap is below -``PENETRATION`` (relative
    to the size of q) at a step end is a body through a surface the problem names: a
    failure, never a silent ``ok``."""
    mode, setup = run.mode, run.setup
    if not mode.released:
        return
    released = [j for kind, j in mode.watch if kind == EventKind.CONTACT]
    n = setup.n
    f = run.constraints(t, y[:n])[0]
    depth = PENETRATION * (1.0 + float(np.max(np.abs(y[:n]))))
    for j in released:
        if f[j] < -max(depth, 10.0 * setup.arm_pos):
            raise Stop(
                f"`{setup.ns.constraint_names[j]}` was passed through undetected at "
                f"t = {t:.12g} (f = {f[j]:.3g} < 0 while released): a contact the "
                "event detection missed; try a smaller --max-step or a tighter rtol"
            )


def _check_growth(y: np.ndarray, t: float, blow_up: float) -> None:
    big = float(np.max(np.abs(y)))
    if not math.isfinite(big) or big > blow_up:
        raise Stop(
            f"the state grows without bound at t = {t:.12g} (max |q|, "
            f"|q'| = {big:.3g}): a force or a singularity that blows up; "
            "check [forces], the parameters and the initial state"
        )


def _check_conditioning(acc: Accel, t: float, steps: int) -> None:
    """Every 8th step: stop where the KKT matrix is nearly singular."""
    if steps % 8 != 1:
        return
    cond = np.linalg.cond(acc.K)
    if cond > 1e13:
        raise Stop(
            f"the KKT matrix is nearly singular at t = {t:.12g} "
            f"(condition number {cond:.3g}): a singular "
            "configuration (dependent constraints) or a motion without "
            "inertia; forces there are not determined. Try "
            "starting elsewhere, a shorter --t-end, or removing "
            "a redundant constraint"
        )


def diagnose_failure(run: Run, t: float, y: np.ndarray, msg) -> str:
    """The message of a step-size collapse at (t, y): the KKT matrix's condition there,
    or NaN in the dynamics just after it."""
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
    return (
        f"step size collapsed at t = {t:.12g} ({msg}){extra}; try a looser rtol/atol, "
        "or check for a singular configuration or a force that blows up"
    )
