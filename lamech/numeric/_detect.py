"""What SciPy's steps look for besides the watched events' sign changes (the functions
themselves are the loop's: :meth:`._run.Run.values`), and where: contacts made and
unmade inside one step (:func:`inside_step`, what the loop hands back as a graze), force
events that go through zero and back inside one step of a system with t in it
(:func:`force_dips`), inputs that switch, and the location of each by root finding
(Brent) on the step's dense output."""

from __future__ import annotations

import numpy as np

from ._events import EventKind
from ._kernels.codes import EV_CONTACT, EV_LIFT_OFF, EV_SLIP
from ._run import Run

__all__ = [
    "inside_step",
    "locate",
    "lock_switches",
    "switches_crossed",
    "locate_switch",
    "flip_switch",
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


FORCE_SAMPLES = 4
"""Interior points of a step at which :func:`force_dips` looks at the force events."""


def force_dips(
    run: Run, dense, t_a: float, t_b: float, g_a: np.ndarray, g_b: np.ndarray
) -> dict[int, tuple[float, float]]:
    """Force events (lift-off: lambda_j; slip: mu N - |lambda_j|) that go through zero
    and back inside one step, which its ends cannot see: {watch index: (t_a, s)}, s the
    first of :data:`FORCE_SAMPLES` evenly spaced interior points of the step where the
    event's function is <= 0 while it is > 0 at both ends.

    The step size follows the state's error only, and a multiplier is not part of the
    state: a block resting on a floor under F sin(w t) has a state that stands still, so
    a single step may span the whole rise and fall of the force, and the lift-off where
    F sin(w t) first exceeds m g would never be seen. Asked for only when the system
    depends on t explicitly (the only way a multiplier can change while the state stands
    still); it costs FORCE_SAMPLES KKT solves a step there."""
    forces = [
        i
        for i, kind in enumerate(run.watch[0])
        if kind in (EV_LIFT_OFF, EV_SLIP) and g_a[i] > 0.0 and g_b[i] > 0.0
    ]
    out: dict[int, tuple[float, float]] = {}
    if not forces:
        return out
    for k in range(1, FORCE_SAMPLES + 1):
        s = t_a + (t_b - t_a) * k / (FORCE_SAMPLES + 1)
        g = run.values(s, dense()(s))
        for i in forces:
            if i not in out and g[i] <= 0.0:
                out[i] = (t_a, s)
    return out


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
    the dense output."""

    te, ie = t_b, -1
    brackets = brackets or {}
    for i in hit:
        t_from, t_to = brackets.get(int(i), (t_a, t_b))

        def g(s, i=i):
            return run.values(s, dense(s))[i]

        r = _root(g, t_from, t_to, t_b)
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
    """Hold every switch on the branch it is on at (t, y): step(s) = 1 where s >= 0."""
    ns, p = run.setup.ns, run.setup.p
    slots = ns.switch_slots
    if not len(slots):
        return
    n = ns.n
    p[slots] = np.nan  # free: evaluated from the state, inner switches too
    s = ns.switches(t, y[:n], y[n:], p)
    p[slots] = np.where(s >= 0.0, 1.0, 0.0)


def switches_crossed(run: Run, t: float, y: np.ndarray) -> np.ndarray:
    """The switches whose s at (t, y) is on the other side of their held branch."""
    ns, p = run.setup.ns, run.setup.p
    slots = ns.switch_slots
    if not len(slots):
        return slots
    n = ns.n
    s = ns.switches(t, y[:n], y[n:], p)
    return np.nonzero((s >= 0.0) != (p[slots] == 1.0))[0]


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


def flip_switch(run: Run, t: float, y: np.ndarray, k: int) -> None:
    """Switch k takes its other branch from t on; logged as a ``switch`` event."""
    from ._events import Event

    ns, p = run.setup.ns, run.setup.p
    slot = ns.switch_slots[k]
    p[slot] = 1.0 - p[slot]
    if not ns.switch_names[k]:  # a table's row: a corner of an input, not an event
        return
    n, names = ns.n, ns.coordinate_names
    coords = {c: float(y[i]) for i, c in enumerate(names)}
    coords.update({c + "'": float(y[n + i]) for i, c in enumerate(names)})
    run.events.append(Event(float(t), EventKind.SWITCH, ns.switch_names[k], coords))
