"""``simulate`` on the loop with events (the engine's ``ev_segment``): the same DOP853
loop, projection, event location and mode changes as the sweeps' loop
(:func:`lamech.numeric.integrate_events`), here with the output times sampled inside it
(state, lambda from the mode's KKT solve, residuals and energy).

The loop runs in chunks of :data:`CHUNK` steps, so that ``progress``, ``pace`` and Ctrl-C
are served between them; a chunk resumes exactly where the last stopped (its step size
carried over). The loop and the simulator's own steps share one mode (the run's arrays,
``Run.md``, changed in place) and one set of rules: the loop applies lift-off, slip, stick
and impacts (Newton's law with restitution, the engaging contact with its friction, the Zeno
accumulation, whose ``contact`` is logged at the accumulation time) in C, the simulator the
same functions through ``lamech.numeric._crules``. What the loop does not do it hands back:
a contact it cannot apply (a singular impact matrix, a gap met below the surface) the
simulator reports, and after a step the loop cannot take (a step-size collapse, a blow-up, a
penetration, a gap that turns within a step, a mode that does not settle, a
singular KKT matrix) SciPy's DOP853 integrates one segment, up to its next event, with
the simulator's diagnosis of a failure. The conditioning check of the simulator's steps
(a nearly singular KKT matrix stops the run) is not made in the loop; an exactly
singular one is.
"""

from __future__ import annotations

import numpy as np

from ._batch import _event_functions, logged_events
from ._codegen import compiled_available
from ._engines import ENGINES, engine_name
from ._kernels import codes
from ._kernels.codes import ST_BUDGET, ST_CONTACT, ST_END
from ._options import INITIAL_TOLERANCE, SimulationError
from ._record import Progress, Recorder, Sample
from ._run import Run, dissipative
from ._tableau import _tables

__all__ = ["Loop", "loop_for", "ENGINES", "CHUNK"]

CHUNK = 2000
"""Steps per call of the loop (a few ms compiled): progress and Ctrl-C between them."""

CONTINUE, CONTACT, HANDBACK, DONE = "continue", "contact", "handback", "done"


def loop_for(run: Run, engine: str, times: np.ndarray) -> Loop | None:
    """The loop for this run, or None where SciPy's integrators run it (``engine``
    :data:`._engines.ENGINES`): "scipy"; "auto" unless the system is compiled (the
    engine in C, ``lamech.numeric._cengine``; and none of its functions replaced since:
    :attr:`NumericSystem.replaced`);
    a method other than DOP853: SimulationError (a ValueError) for "compiled" and
    "python". "compiled" on a system not compiled is a SimulationError too."""
    engine = engine_name(engine, SimulationError)
    if engine == "scipy":
        return None
    ns = run.setup.ns
    if run.setup.options.method != "DOP853":
        if engine != "auto":
            raise SimulationError(
                f"engine {engine!r} cannot run this problem: method "
                f"{run.setup.options.method} (the loop is DOP853); use 'scipy' or 'auto'"
            )
        return None
    compiled = ns.jit and not ns.replaced and compiled_available()
    if engine == "auto" and not compiled:
        return None
    if engine == "compiled" and not compiled:
        raise SimulationError(
            "engine 'compiled': the system is not compiled (compile_system(..., jit=True)), "
            "or lamech's C engine or a C compiler is missing; use 'python' or 'auto'"
        )
    if engine == "python":
        compiled = False
    functions = _event_functions(ns, compiled)
    loop = Loop(run, functions["ev_segment"], times)
    loop.name = "loop (C)" if functions["compiled"] else "loop (Python)"
    run.solve_few()
    return loop


class Loop:
    """The loop's constants and buffers for one run (:func:`loop_for`)."""

    def __init__(self, run: Run, segment, times: np.ndarray):
        setup = run.setup
        n, m = setup.n, setup.m
        self.run, self.segment = run, segment
        self.tables = _tables()
        # to t_end, impacts applied, force events sought inside the steps where t is in
        # the problem
        self.limits = codes.limits(max_steps=CHUNK, dips=setup.ns.explicit_time)
        self.times = np.ascontiguousarray(times, dtype=float)
        S = len(self.times)
        self.SY, self.SL, self.SR = np.zeros((S, 2 * n)), np.zeros((S, m)), np.zeros((S, 4))
        cap = 64 + 4 * m + 8
        self.EK = np.zeros(cap, dtype=np.int64)
        self.EJ = np.zeros(cap, dtype=np.int64)
        self.ET, self.EY, self.EX = np.zeros(cap), np.zeros((cap, 2 * n)), np.zeros((cap, 4))
        self.want, self.found = np.zeros((2, 0), dtype=np.int64), np.zeros(0, dtype=np.bool_)
        self.h = 0.0  # the step size to go on with (0: the initial step's rule)
        self.name = "loop"

    def advance(self, rec: Recorder, at: Progress, t_end: float, blow_up: float, zeno) -> tuple:
        """One call of the loop from ``at``: the samples, events and mode it reached, ``at``
        moved there. (what next: CONTINUE, CONTACT (the located contact's constraint in
        the second entry: apply it), HANDBACK (the simulator takes one segment) or DONE;
        the last step size)."""
        run = self.run
        setup = run.setup
        opts, n = setup.options, setup.n
        io = np.zeros(codes.IO_SIZE, dtype=np.int64)
        io[codes.IO_NEXT], io[codes.IO_CONTACT] = rec.next, -1
        fo = np.zeros(codes.FO_SIZE)
        fo[codes.FO_T], fo[codes.FO_H], fo[codes.FO_MOVED] = at.t, self.h, at.max_projection
        tl = codes.tolerances(
            rtol=float(opts.rtol), atol=float(opts.atol), t_end=float(t_end),
            max_step=float(opts.max_step), arm_pos=setup.arm_pos, arm_vel=setup.arm_vel,
            blow_up=float(blow_up), pen=INITIAL_TOLERANCE,
        )  # fmt: skip
        lg = (self.EK, self.EJ, self.ET, self.EY, self.EX, self.want, self.found)
        smp = (self.times, self.SY, self.SL, self.SR)
        state = np.array(at.y, dtype=float)  # the state at t when the call returns
        # the run's mode (run.md) is changed in place
        t, status, nev, steps = self.segment(
            setup.p, self.tables, run.md, tl, self.limits, lg, 0, smp, state, io, fo
        )
        for k in range(rec.next, int(io[codes.IO_NEXT])):
            y, r = self.SY[k], self.SR[k]
            sample = Sample(float(self.times[k]), y[:n].copy(), y[n:].copy(), self.SL[k].copy(),
                            float(r[0]), float(r[1]), float(r[2]), float(r[3]))  # fmt: skip
            rec.samples.append(sample)
        sampled = int(io[codes.IO_NEXT])
        # the right-hand sides, and a KKT solve a sample
        run.evaluations += int(io[codes.IO_EVALUATIONS]) + sampled - rec.next
        rec.next = sampled
        at.steps += int(steps)
        at.max_projection = float(fo[codes.FO_MOVED])
        at.t, at.y = float(t), state
        events = logged_events(setup.ns, self.EK, self.EJ, self.ET, self.EY, self.EX, int(nev))
        run.events.extend(events)
        if any(dissipative(e) for e in events):
            run.dissipative = True
        run.rebuild()
        # the chattering test after each event and its settling (_simulate._event); not
        # after an accumulation's contact (_simulate._accumulated)
        checked = [e for e in events if e.accumulation is None]
        for te in sorted({e.t for e in checked}):
            zeno.check(te, [(str(e.kind), e.constraint) for e in checked if e.t == te])
        h = float(fo[codes.FO_H])
        self.h = h if status == ST_BUDGET else 0.0
        if status == ST_END:
            return DONE, h
        if status == ST_BUDGET:
            return CONTINUE, h
        if status == ST_CONTACT:
            return CONTACT, int(io[codes.IO_CONTACT])
        return HANDBACK, status
