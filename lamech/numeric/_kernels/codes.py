"""The loop's integer codes, defined once: the compiled loop uses the constants (copied
into its module by :func:`constants_text`), Python reads its results through the maps
below them.

The loop keeps the contact and friction mode in arrays: ``kinds`` (3, m) int64 rows
unilateral, holonomic, normal (-1: not friction); ``imode`` (4, m) int64 rows engaged,
friction state (``FR_*``), contact armed, stick armed; ``fmode`` (5, m) rows sigma (slip
sign), sN (sign of a bilateral normal), offset (f held while friction sticks), the
accumulation time of a Zeno sequence's contact (NaN: none) and the time of the
constraint's last impact (NaN: none; a bounce's too). Each run ends with a status
(``ST_*``); each logged event has a kind (``EV_*``) and a detail code (``DT_*``) with up
to three values.
"""

from __future__ import annotations

import math

import numpy as np

from .._events import EventKind, FrictionState

# the kinds of events, watched and logged
EV_LIFT_OFF = 0
EV_CONTACT = 1
EV_SLIP = 2
EV_STICK = 3
EV_IMPACT = 4  # a bounce (only logged: the event watched is EV_CONTACT)
EV_SWITCH = 5  # an input's branch switched (logged with the switch's index)
# a friction constraint's state
FR_NONE = 0
FR_STICK = 1
FR_SLIP = 2
FR_OFF = 3
# how a run of the loop ends
ST_END = 0  # reached t_end
ST_FOUND = 1  # stopped once every wanted event was found
ST_CONTACT = 2  # fallbacks: a contact the loop cannot apply (singular, or met below the gap)
ST_STICK = 3  # unused: stick is mirrored (the code kept for the status names)
ST_EVENTS = 4  # more events than the record holds
ST_STEP = 5  # step size collapsed, or too many steps
ST_GROWTH = 6  # the state blows up or is not finite
ST_PENETRATION = 7  # a released constraint passed through
ST_GRAZE = 8  # a released gap turns within a step (simulate's inside_step)
ST_SETTLE = 9  # the mode does not settle
ST_START = 10  # the start violates the constraints (simulate says how)
ST_SINGULAR = 11  # the KKT solve fails at an accepted state
ST_BUDGET = 12  # ev_segment: its steps done, or its event record nearly full (go on)
ST_MEMORY = 13  # the C engine's scratch memory could not grow (lamech/numeric/_engine)
# an event's detail (Event's optional fields)
DT_NONE = 0  # none
DT_MULTIPLIER = 1  # the pulling multiplier of a lift-off in settling
DT_RATIO = 2  # |F| / (mu N) of a slip in settling
DT_REVERSAL = 3  # a stick that could not hold: the slip went on (1.0 reversed, 0.0 not)
DT_INITIAL = 4  # a slip at the start
DT_IMPACT = 5  # an impact or contact: impulse, velocity_before, restitution (columns 1-3)
DT_ACCUMULATION = 6  # a contact at the end of a Zeno sequence: restitution, accumulation
DT_IMPULSE = 7  # a slip through an impact: its impulse

# the records the kernels pass around (tuples and arrays numba types once for every
# system; a kernel takes a record, not a dozen loose values):
#   tab  DOP853's tables (A, B, C, E3, E5, A_EXTRA, C_EXTRA, D);
#   md   the mode (kinds, imode, fmode), above;
#   act  the mode's active set (rows, hrows (the holonomic ones), slip_j, slip_k, slip_c);
#   lg   the event record (kind, j, t, y, x (detail code and 3 values), want, found):
#        ``want`` (2, w) the (kind, constraint or -1) of the wanted events, ``found`` (w,);
#   smp  the samples (times TS, states SY, multipliers SL, residuals and energy SR);
#   tl   the tolerances and bounds, a float64 array indexed by TL_*;
#   lim  the integer limits and switches, an int64 array indexed by LM_*;
#   io, fo  ev_segment's counters (IO_*) and clock (FO_*), read and written.
TL_RTOL = 0
TL_ATOL = 1
TL_MAX_STEP = 2
TL_ARM_POS = 3  # how far a gap must open before its contact may fire again
TL_ARM_VEL = 4  # how far a slip velocity must grow before its stick may fire again
TL_BLOW_UP = 5  # max |y| that is a blow-up (ev_run_one: a factor of 1 + max |y0|)
TL_PEN = 6  # a gap below -TL_PEN (1 + max |q|) is a penetration
TL_TOL = 7  # the start meets a constraint where |f|, |F| <= TL_TOL (1 + max |q|)
TL_T_END = 8
TL_SIZE = 9
LM_MAX_STEPS = 0
LM_TO_END = 1  # 1: run to t_end even once every wanted event is found
LM_IMPACTS = 2  # 1: apply impacts in the loop (else a located contact stops the run)
LM_DIPS = 3  # points inside each step where force events are sought (t in the system)
LM_STARTS = 4  # 1: ev_run makes each start consistent first (its held values kept)
LM_SIZE = 5
IO_NEXT = 0  # the next output time to sample
IO_CONTACT = 1  # the constraint of a contact left to the simulator (ST_CONTACT)
IO_EVALUATIONS = 2  # right-hand sides evaluated
IO_SIZE = 3
FO_T = 0  # the time: where the segment starts, then where it stopped
FO_H = 1  # the step size to begin with (0: the initial step's rule), then to go on with
FO_MOVED = 2  # the largest projection so far
FO_SIZE = 3

PREFIXES = ("EV_", "FR_", "ST_", "DT_", "TL_", "LM_", "IO_", "FO_")


def borrowed(a):
    """``a`` itself: the mark of an array the caller holds for the whole call (kept from
    the numba engine, where it saved a reference count per call; the engine in C has
    none)."""
    return a


def constants() -> dict[str, int]:
    """Every code above by name, in the order defined."""
    return {k: v for k, v in globals().items() if k.startswith(PREFIXES) and isinstance(v, int)}


def constants_text() -> str:
    """The codes as assignments, for the compiled loop's module."""
    return "\n".join(f"{k} = {v!r}" for k, v in constants().items())


EVENT_KINDS = {
    EV_LIFT_OFF: EventKind.LIFT_OFF,
    EV_CONTACT: EventKind.CONTACT,
    EV_SLIP: EventKind.SLIP,
    EV_STICK: EventKind.STICK,
    EV_IMPACT: EventKind.IMPACT,
    EV_SWITCH: EventKind.SWITCH,
}
"""The :class:`EventKind` of each ``EV_*`` code."""
EVENT_CODES = {kind: code for code, kind in EVENT_KINDS.items()}
"""The ``EV_*`` code of each :class:`EventKind` the loop knows."""

FRICTION = {
    None: FR_NONE,
    FrictionState.STICK: FR_STICK,
    FrictionState.SLIP: FR_SLIP,
    FrictionState.OFF: FR_OFF,
}
"""The ``FR_*`` code of each friction state (None: not a friction constraint)."""
FRICTION_STATES = {code: state for state, code in FRICTION.items()}

FALLBACKS = {
    ST_CONTACT: "contact",
    ST_STICK: "stick",
    ST_EVENTS: "events",
    ST_STEP: "step",
    ST_GROWTH: "growth",
    ST_PENETRATION: "penetration",
    ST_GRAZE: "graze",
    ST_SETTLE: "settle",
    ST_START: "start",
    ST_SINGULAR: "singular",
}
"""The statuses of a run the loop with events leaves to :func:`lamech.numeric.simulate`,
by name."""
STATUS_NAMES = {ST_END: "end", ST_FOUND: "found", **FALLBACKS}
"""Every status a run of the loop with events reports (``ST_BUDGET`` is internal)."""

DETAILS = {
    DT_MULTIPLIER: ("multiplier",),
    DT_RATIO: ("ratio",),
    DT_REVERSAL: ("reversal",),
    DT_INITIAL: ("initial",),
    DT_IMPACT: ("impulse", "velocity_before", "restitution"),
    DT_ACCUMULATION: ("restitution", "accumulation"),
    DT_IMPULSE: ("impulse",),
}
"""The :class:`~lamech.numeric.Event` fields of each detail code, the values in the
event record's columns 1, 2, 3 (``reversal`` a flag, ``initial`` always True)."""


def tolerances(
    *,
    rtol: float,
    atol: float,
    t_end: float,
    max_step: float = math.inf,
    arm_pos: float = 0.0,
    arm_vel: float = 0.0,
    blow_up: float = math.inf,
    pen: float = 0.0,
    tol: float = 0.0,
) -> np.ndarray:
    """The tolerances record ``tl`` (TL_*) of the named values."""
    tl = np.zeros(TL_SIZE)
    tl[TL_RTOL], tl[TL_ATOL], tl[TL_T_END], tl[TL_MAX_STEP] = rtol, atol, t_end, max_step
    tl[TL_ARM_POS], tl[TL_ARM_VEL], tl[TL_BLOW_UP] = arm_pos, arm_vel, blow_up
    tl[TL_PEN], tl[TL_TOL] = pen, tol
    return tl


FORCE_SAMPLES = 4
"""Interior points of a step at which the force events of a system with t in it are
sought (the engine's ``ev_dips``, and the simulator's own steps)."""


def limits(
    *,
    max_steps: int,
    to_end: bool = True,
    impacts: bool = True,
    dips: bool = False,
    starts: bool = False,
) -> np.ndarray:
    """The limits record ``lim`` (LM_*) of the named values; ``dips``: seek force events
    inside each step (:data:`FORCE_SAMPLES` points), for a system with t in it;
    ``starts``: the engine's ``ev_run`` makes each start consistent before its run."""
    lim = np.zeros(LM_SIZE, dtype=np.int64)
    lim[LM_MAX_STEPS], lim[LM_TO_END], lim[LM_IMPACTS] = max_steps, to_end, impacts
    lim[LM_DIPS] = FORCE_SAMPLES if dips else 0
    lim[LM_STARTS] = starts
    return lim
