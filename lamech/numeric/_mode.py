"""The contact and friction mode of a run, apart from the compiled model's constants (in
the spirit of MuJoCo's mjModel/mjData): :class:`ConstraintKinds` says what each
constraint is (fixed for the run), :class:`ContactMode` what each does now.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._events import EventKind, FrictionState

__all__ = ["ConstraintKinds", "ContactMode", "slip_sign"]


@dataclass(frozen=True)
class ConstraintKinds:
    """Per constraint: ``unilateral``, ``holonomic``, and ``normal`` (the index of the
    normal constraint a friction constraint names, -1 for the others)."""

    unilateral: np.ndarray
    holonomic: np.ndarray
    normal: np.ndarray

    @classmethod
    def of(cls, system) -> ConstraintKinds:
        names = [c.name for c in system.constraints]
        return cls(
            unilateral=np.array([c.unilateral for c in system.constraints], dtype=bool),
            holonomic=np.array([c.holonomic for c in system.constraints], dtype=bool),
            normal=np.array(
                [names.index(c.friction.normal) if c.friction else -1 for c in system.constraints],
                dtype=int,
            ),
        )

    @property
    def m(self) -> int:
        return len(self.normal)

    def array(self) -> np.ndarray:
        """(3, m) int64, the kernels' ``kinds``: unilateral, holonomic, normal index."""
        return np.stack([self.unilateral, self.holonomic, self.normal]).astype(np.int64)


class ContactMode:
    """Which constraints act and how: ``engaged`` (unilateral constraints in contact),
    ``friction`` (:class:`FrictionState` per friction constraint, None for the others),
    ``sigma`` (the sign of each slip velocity), ``sN`` (the sign of a bilateral normal
    force, so that the friction limit is mu |N|), ``offset`` (the value f_j is held at
    while friction j sticks), ``armed`` (an event (kind, j) that must first move away
    from zero before it may fire again) and ``accumulating`` {unilateral j: (t_impact,
    t_acc)}: j engaged at an impact at t_impact whose further bounces are too small to
    resolve, its ``contact`` to be logged at their accumulation time t_acc (dropped if j
    lets go first).

    Derived by :meth:`rebuild` after every switch: ``rows`` (the active constraint rows),
    ``hrows`` (the holonomic ones), ``pos`` (each row's position among them), ``slips``
    [(friction j, normal k)], ``kernel_args`` (the arrays the compiled right-hand side
    takes), ``watch`` [(kind, j)]: the events that can happen in this mode, and
    ``released`` (a unilateral constraint is released: a contact is watched).
    """

    def __init__(self, kinds: ConstraintKinds):
        self.kinds = kinds
        m = kinds.m
        self.engaged = np.ones(m, dtype=bool)
        self.friction = [FrictionState.STICK if k >= 0 else None for k in kinds.normal]
        self.sigma = np.zeros(m)
        self.sN = np.ones(m)
        self.offset = np.zeros(m)
        self.armed: dict[tuple[EventKind, int], bool] = {}
        self.accumulating: dict[int, tuple[float, float]] = {}
        self.rebuild()

    # ----- derived ----------------------------------------------------------------
    def rebuild(self) -> None:
        """Recompute the active rows, the slips and the watched events (friction on a
        released normal is off, and sticks again when the normal engages)."""
        normal = self.kinds.normal
        rows = []
        for j in range(self.kinds.m):
            k = normal[j]
            if k >= 0:
                if not self.row_active(k):
                    self.friction[j] = FrictionState.OFF
                elif self.friction[j] == FrictionState.OFF:
                    self.friction[j] = FrictionState.STICK
                if self.friction[j] == FrictionState.STICK:
                    rows.append(j)
            elif self.row_active(j):
                rows.append(j)
        self.rows = np.array(rows, dtype=int)
        self.hrows = np.array([j for j in rows if self.kinds.holonomic[j]], dtype=int)
        self.pos = {j: i for i, j in enumerate(rows)}
        self.slips = [
            (j, int(normal[j]))
            for j in range(self.kinds.m)
            if normal[j] >= 0 and self.friction[j] == FrictionState.SLIP
        ]
        self.kernel_args = (
            self.rows.astype(np.int64),
            np.array([j for j, _ in self.slips], dtype=np.int64),
            np.array([self.pos[k] for _, k in self.slips], dtype=np.int64),
            np.array([self.sN[j] * self.sigma[j] for j, _ in self.slips], dtype=float),
        )
        self.watch = self._watched()
        self.released = any(kind == EventKind.CONTACT for kind, _ in self.watch)

    def _watched(self) -> list[tuple[EventKind, int]]:
        out = []
        for j in range(self.kinds.m):
            if self.kinds.unilateral[j]:
                out.append((EventKind.LIFT_OFF if self.engaged[j] else EventKind.CONTACT, j))
            if self.kinds.normal[j] >= 0:
                if self.friction[j] == FrictionState.STICK:
                    out.append((EventKind.SLIP, j))
                elif self.friction[j] == FrictionState.SLIP:
                    out.append((EventKind.STICK, j))
        return out

    def row_active(self, j: int) -> bool:
        """Constraint j's row is in the KKT system."""
        k = self.kinds.normal[j]
        if k >= 0:
            return self.friction[j] == FrictionState.STICK and self.row_active(int(k))
        return bool(self.engaged[j]) if self.kinds.unilateral[j] else True

    def is_armed(self, kind: EventKind, j: int) -> bool:
        return self.armed.get((kind, j), True)

    def all_armed(self) -> bool:
        return all(self.armed.values())

    def arm(self, kind: EventKind, j: int) -> None:
        self.armed[(kind, j)] = True

    # ----- switches ---------------------------------------------------------------
    def open_at_start(self, j: int, armed: bool) -> None:
        """Unilateral j starts released, its contact event ``armed`` or not (the gap
        must open first); :meth:`rebuild` once all are set."""
        self.engaged[j] = False
        self.armed[(EventKind.CONTACT, j)] = armed

    def disarm(self, kind: EventKind, j: int) -> None:
        """Event (kind, j) may not fire until it moves away from zero (after a bounce)."""
        self.armed[(kind, j)] = False

    def release(self, j: int) -> None:
        """Unilateral j lifts off; its contact event waits until the gap opens."""
        self.engaged[j] = False
        self.accumulating.pop(j, None)
        self.disarm(EventKind.CONTACT, j)
        self.rebuild()

    def engage(self, j: int) -> None:
        """Unilateral j comes into contact."""
        self.engaged[j] = True
        self.rebuild()

    def start_slip(self, j: int, sigma: float) -> None:
        """Friction j slips with slip-velocity sign ``sigma``; its stick event waits until
        the slip velocity moves away from zero."""
        self.friction[j] = FrictionState.SLIP
        self.sigma[j] = sigma
        self.disarm(EventKind.STICK, j)
        self.rebuild()

    def stick(self, j: int, offset: float) -> None:
        """Friction j sticks, its f held at ``offset``."""
        self.offset[j] = offset
        self.friction[j] = FrictionState.STICK
        self.rebuild()


def slip_sign(lam_j: float, s: float, still: float) -> float:
    """The sign of a new slip velocity: that of s, or against the friction force lam_j
    when |s| <= ``still`` (the slip starts from rest)."""
    return -math.copysign(1.0, lam_j) if abs(s) <= still else math.copysign(1.0, s)
