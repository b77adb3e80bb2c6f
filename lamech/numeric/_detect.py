"""What SciPy's steps look for besides the watched events' sign changes (the functions
themselves are the loop's: :meth:`._run.Run.values`), and where: contacts made and
unmade inside one step (:func:`inside_step`, what the loop hands back as a graze), force
events that go through zero and back inside one step of a system with t in it
(:func:`force_dips`), inputs that switch, and the location of each by root finding
(Brent) on the step's dense output."""

from __future__ import annotations

import numpy as np

from ._kernels.codes import EV_CONTACT, FORCE_SAMPLES
from ._run import Run

__all__ = [
    "inside_step",
    "locate",
    "lock_switches",
    "switches_crossed",
    "locate_switch",
]


def inside_step(
    run: Run, dense, t_a: float, y_a: np.ndarray, t_b: float, y_b: np.ndarray
) -> dict[int, tuple[float, float]]:
    """Contacts made and unmade inside one step, which its ends cannot see, found where
    a released gap's velocity changes sign on the dense output:

    * a disarmed contact whose gap rises and falls again (a small bounce, the whole
      flight in the step) is armed at the apex if the gap opened beyond ``arm_pos``;
      its crossing is sought in (apex, t_b];
    * an armed one whose gap falls and rises again (a narrow obstacle passed in one
      step) hit the surface if the gap went negative; the crossing is in (t_a, bottom]
      (a disarmed one likewise if it went below -``arm_pos``, where its event fires).

    Returns {watch index: (t_from, t_to)}, the bracket to search. ``dense()`` gives the
    step's dense output, asked for only when a gap velocity changes sign (y_a, y_b: the
    states at the step's ends)."""
    from scipy.optimize import brentq

    n, setup = run.setup.n, run.setup
    imode = run.md[1]  # row 2: the contact armed
    out: dict[int, tuple[float, float]] = {}

    def gap(s: float, j: int, y: np.ndarray | None = None) -> tuple[float, float]:
        y = dense()(s) if y is None else y
        f, A, b = run.constraints(s, y[:n])
        return float(f[j]), float(A[j] @ y[n:] + b[j])

    def turn(j: int) -> float:
        return brentq(lambda s: gap(s, j)[1], t_a, t_b, xtol=1e-15 * max(1.0, abs(t_b)))

    for i, (kind, j) in enumerate(zip(*run.watch)):
        if kind != EV_CONTACT:
            continue
        j = int(j)
        (_, rate_a), (_, rate_b) = gap(t_a, j, y_a), gap(t_b, j, y_b)
        if not imode[2, j]:
            if rate_a > 0.0 > rate_b:
                apex = turn(j)
                if gap(apex, j)[0] > setup.arm_pos:
                    imode[2, j] = 1
                    out[i] = (apex, t_b)
            elif rate_a < 0.0 < rate_b:
                bottom = turn(j)
                if gap(bottom, j)[0] + setup.arm_pos <= 0.0:
                    out[i] = (t_a, bottom)
        elif rate_a < 0.0 < rate_b:
            bottom = turn(j)
            if gap(bottom, j)[0] <= 0.0:
                out[i] = (t_a, bottom)
    return out


def force_dips(
    run: Run, dense, t_a: float, t_b: float, g_a: np.ndarray, g_b: np.ndarray
) -> dict[int, tuple[float, float]]:
    """Force events that go through zero and back inside one step, which its ends cannot
    see (the loop's the engine's ``ev_dips``, at :data:`FORCE_SAMPLES` points of the
    step's dense output): {watch index: (t_a, s)}, s the first point where the event's
    function is <= 0 while it is > 0 at both ends. Asked for only where the system
    depends on t explicitly."""
    rules = run.rules
    S = FORCE_SAMPLES
    YS = np.array([dense()(rules.dip_time(t_a, t_b, c, S)) for c in range(S)])
    upper = np.full(len(run.watch[0]), t_b)
    if not rules.ev_dips(t_a, t_b, YS, run.setup.p, run.watch, run.md, run.act, run.tl,
                         g_a, g_b, upper):  # fmt: skip
        return {}
    return {i: (t_a, float(s)) for i, s in enumerate(upper) if s < t_b}


def locate(
    run: Run,
    dense,
    hit,
    t_a: float,
    t_b: float,
    brackets: dict[int, tuple[float, float]] | None = None,
) -> tuple[float, int]:
    """(te, i): the first of the events ``hit`` (indices into the mode's watch list)
    within (t_a, t_b] (for event i in ``brackets``, within that bracket), located on
    the dense output; (t_b, -1) where each was a contact's impact just applied found
    again (the engine's ``ev_again``, as the loop drops it)."""

    te, ie = t_b, -1
    brackets = brackets or {}
    kinds, constraints = run.watch
    for i in hit:
        t_from, t_to = brackets.get(int(i), (t_a, t_b))

        def g(s, i=i):
            return run.values(s, dense(s))[i]

        r = _root(g, t_from, t_to, t_b)
        if run.rules.ev_again(kinds[i], constraints[i], r, t_b, run.md[2]):
            continue
        if r < te or ie < 0:
            te, ie = r, int(i)
    return te, ie


def _root(g, lo: float, hi: float, t_b: float) -> float:
    """Where g crosses zero in [lo, hi] (Brent, to about 1e-15 of the step's end t_b);
    ``hi`` when g has the same sign at both ends (a crossing only just seen)."""
    from scipy.optimize import brentq

    try:
        return brentq(
            g, lo, hi, xtol=1e-15 * max(1.0, abs(t_b)), rtol=4 * np.finfo(float).eps, maxiter=200
        )
    except ValueError:
        return hi


# ----- inputs that switch -------------------------------------------------------------
# An input with a jump or a kink (step, min, max, clip, piecewise) is evaluated with each
# switch's branch held (its lock in p: 0 or 1), so that the right-hand side is smooth
# within a segment and the integrator's error control and dense output stay valid up to
# the switch; where a switching function s crosses 0 is located on the dense output like
# any event, the branch flips there, and the integration restarts (as a contact change
# does). Stepping over the jump instead costs accuracy (the step that contains it is
# accepted with an error of the size of the jump times the step) and makes an event time
# such as a lift-off that follows from the switch come out late by up to a step.


def lock_switches(run: Run, t: float, y: np.ndarray) -> None:
    """Hold every switch on the branch it is on at (t, y) (the loop's
    the engine's ``ev_lock``): step(s) = 1 where s >= 0."""
    run.rules.ev_lock(t, y, run.setup.p)


def switches_crossed(run: Run, t: float, y: np.ndarray) -> np.ndarray:
    """The switches whose s at (t, y) is on the other side of their held branch
    (the engine's ``ev_crossed``)."""
    return run.rules.ev_crossed(t, y, run.setup.p)


def locate_switch(run: Run, dense, crossed, t_a: float, t_b: float) -> tuple[float, int]:
    """(ts, k): the first of the switches ``crossed`` within (t_a, t_b], located on the
    dense output (root finding, Brent)."""

    ns, p = run.setup.ns, run.setup.p
    n, slots = ns.n, ns.switch_slots
    best = (t_b, -1)
    for k in crossed:
        held = p[slots[k]]

        def side(tau: float, k=int(k)) -> float:
            y = dense(tau)
            return float(ns.switches(tau, y[:n], y[n:], p)[k])

        s_a = side(t_a)
        if (s_a >= 0.0) != (held == 1.0):  # already across at the step's start
            ts = t_a
        else:
            ts = _root(side, t_a, t_b, t_b)
            # s = 0 exactly counts as switched (step(0) = 1): for a branch held at 0 the
            # root is where s reaches 0; Brent may stop just short of it, which is fine
            # to within its tolerance.
        if ts < best[0] or best[1] < 0:
            best = (ts, int(k))
    return best
