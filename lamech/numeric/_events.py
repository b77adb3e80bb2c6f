"""The typed values of a simulation's log: its :class:`Status`, the :class:`EventKind` of
each :class:`Event`, and the :class:`FrictionState` of a friction constraint.

The enumerations subclass ``str``: ``traj.status == "ok"`` and ``event.kind == "slip"``
hold, and they print, format and serialise (JSON, CSV) as their plain values.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

__all__ = ["Status", "EventKind", "FrictionState", "Event"]


class _Text(str, enum.Enum):
    """A str enumeration that prints, formats and hashes as its value."""

    def __str__(self) -> str:
        return str.__str__(self)

    def __format__(self, spec: str) -> str:
        return str.__format__(str.__str__(self), spec)

    def __hash__(self) -> int:
        return str.__hash__(self)


class Status(_Text):
    """How a run ended (the ``message`` of the :class:`~lamech.Trajectory` says
    when and why)."""

    OK = "ok"
    FAILED = "failed"
    PENETRATED = "penetrated"
    """A state reached the forbidden side of a unilateral constraint (f below minus the
    event tolerance while it was released) with no contact located: a body through a
    surface, stopped there rather than followed."""
    INTERRUPTED = "interrupted"

    @property
    def meaning(self) -> str:
        """What the status means and what to try."""
        return _MEANINGS[self]


_MEANINGS = {
    Status.OK: "the run reached t_end",
    Status.FAILED: "the run stopped early: see the message for the time, cause and what to try",
    Status.PENETRATED: "the run stopped where a body had passed through a unilateral "
    "constraint's surface unseen (f < 0 while released, no contact located): see the message "
    "for the constraint, the time and the depth; try a tighter rtol/atol or a smaller max_step",
    Status.INTERRUPTED: "the run was interrupted (Ctrl-C; SIGTERM or SIGHUP in the "
    "command): the trajectory up to there is kept; run again to go further",
}


class EventKind(_Text):
    """What happened at an event (see :func:`lamech.simulate`)."""

    LIFT_OFF = "lift-off"
    IMPACT = "impact"
    CONTACT = "contact"
    SLIP = "slip"
    STICK = "stick"
    SWITCH = "switch"
    """An input (step, min, max, clip, piecewise) takes its other branch; the event's
    ``constraint`` names it as step(s), s its switching function."""


class FrictionState(_Text):
    """The state of a friction constraint: sticking (its row is active), slipping
    (kinetic friction on its normal's column) or off (its normal is released)."""

    STICK = "stick"
    SLIP = "slip"
    OFF = "off"


@dataclass(frozen=True)
class Event:
    """One mode change of a run: its time, kind, constraint, and the coordinates and
    velocities (``x'``) at the event. The optional details: ``multiplier`` (the pulling
    multiplier of a lift-off found when the mode settles), ``ratio`` (``|lambda| / (mu N)`` of
    a slip found when the mode settles), ``impulse``, ``velocity_before`` and
    ``restitution`` (impact and contact), ``initial`` (a slip at the start),
    ``reversal`` (a stick that could not hold: the slip went on, reversed or not) and
    ``accumulation`` (a contact that begins where impacts accumulate: the bounces after
    the last logged impact too small to resolve, their flights summed in closed form;
    ``accumulation`` is the time they took) and ``energy_lost`` (an impact's kinetic
    energy T- - T+ from the velocities before and after it)."""

    t: float
    kind: EventKind
    constraint: str
    coordinates: dict[str, float]
    multiplier: float | None = None
    ratio: float | None = None
    impulse: float | None = None
    velocity_before: float | None = None
    restitution: float | None = None
    initial: bool = False
    reversal: bool | None = None
    accumulation: float | None = None
    energy_lost: float | None = None

    def to_json(self) -> dict:
        """The event as the ``--json`` summary gives it: t, kind, constraint,
        coordinates, then the details this event has."""
        out = {
            "t": float(self.t),
            "kind": self.kind.value,
            "constraint": self.constraint,
            "coordinates": {k: float(v) for k, v in self.coordinates.items()},
        }
        for name in (
            "multiplier",
            "ratio",
            "impulse",
            "velocity_before",
            "restitution",
            "accumulation",
            "energy_lost",
        ):
            value = getattr(self, name)
            if value is not None:
                out[name] = value
        if self.initial:
            out["initial"] = True
        if self.reversal is not None:
            out["reversal"] = self.reversal
        return out
