"""The loop's integer codes, defined once: the compiled loop uses the constants (copied
into its module by :func:`constants_text`), Python reads its results through the maps
below them.

The loop keeps the contact and friction mode in arrays: ``kinds`` (3, m) int64 rows
unilateral, holonomic, normal (-1: not friction); ``imode`` (4, m) int64 rows engaged,
friction state (``FR_*``), contact armed, stick armed; ``fmode`` (5, m) rows sigma (slip
sign), sN (sign of a bilateral normal), offset (f held while friction sticks), the
accumulation time of a Zeno sequence's contact (NaN: none; ``Mode.accumulating``) and the
time of its impact. Each run ends with a status (``ST_*``); each logged event has a kind
(``EV_*``) and a detail code (``DT_*``) with up to three values.
"""

from __future__ import annotations

from .._events import EventKind, FrictionState

# the kinds of events, watched and logged
EV_LIFT_OFF = 0
EV_CONTACT = 1
EV_SLIP = 2
EV_STICK = 3
EV_IMPACT = 4  # a bounce (only logged: the event watched is EV_CONTACT)
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
# an event's detail (Event's optional fields)
DT_NONE = 0  # none
DT_MULTIPLIER = 1  # the pulling multiplier of a lift-off in settling
DT_RATIO = 2  # |F| / (mu N) of a slip in settling
DT_REVERSAL = 3  # a stick that could not hold: the slip went on (1.0 reversed, 0.0 not)
DT_INITIAL = 4  # a slip at the start
DT_IMPACT = 5  # an impact or contact: impulse, velocity_before, restitution (columns 1-3)
DT_ACCUMULATION = 6  # a contact at the end of a Zeno sequence: restitution, accumulation
DT_IMPULSE = 7  # a slip through an impact: its impulse

PREFIXES = ("EV_", "FR_", "ST_", "DT_")


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
