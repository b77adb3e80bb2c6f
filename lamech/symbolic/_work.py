"""Counting the work of simplification: the budget a solve runs under (:class:`Work`,
:func:`work_budget`, in units, never in time, so a problem prints the same on any
machine), the bound of one call, the labels of what was left untidied, the stage hook
of a progress display, and the flag a Ctrl-C sets to stop simplifying
(:func:`interruptible`). The normal forms (:mod:`._normal`) charge it."""

from __future__ import annotations

import contextlib
import contextvars
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

__all__ = [
    "DEFAULT_BUDGET",
    "CALL_WORK",
    "OverBudget",
    "Work",
    "work_budget",
    "labelled",
    "stage_hook",
    "current_work",
    "interruptible",
    "interrupted",
]

DEFAULT_BUDGET = 20_000_000
"""Default work of one solve, in units (a product of polynomials of a and b terms costs
a * b units). The lecture's cylinder takes about 10^4, the rolling disc and the heavy top
about 10^6; past the budget results are delivered as derived (untidied)."""


class OverBudget(Exception):
    """The work budget (or the per-call bound :data:`TERMS`) would be exceeded."""


@dataclass
class Work:
    """A budget of work units, charged by the normal forms computed under it, and the
    list of results left as derived because it ran out (``untidied``)."""

    limit: int = DEFAULT_BUDGET
    used: int = 0
    untidied: list = field(default_factory=list)

    def charge(self, units: int) -> None:
        self.used += units
        if self.used > self.limit:
            raise OverBudget(f"work budget of {self.limit} units spent")

    @property
    def left(self) -> int:
        return max(self.limit - self.used, 0)

    @property
    def exhausted(self) -> bool:
        return self.used >= self.limit


_WORK: contextvars.ContextVar[Work | None] = contextvars.ContextVar("lamech_work", default=None)
_LABEL: contextvars.ContextVar[str] = contextvars.ContextVar("lamech_work_label", default="")


@contextlib.contextmanager
def work_budget(units: int | Work | None = None) -> Iterator[Work]:
    """Count the normal forms inside the block against ``units`` (a fresh :class:`Work`
    of that many units, :data:`DEFAULT_BUDGET` by default, or a given one). Context
    variables carry it, so it holds in the thread (or task) that opened it."""
    if isinstance(units, Work):
        work = units
    else:
        limit = DEFAULT_BUDGET if units is None else int(units)
        if limit <= 0:
            raise ValueError(f"budget must be a positive number of work units, got {units!r}")
        work = Work(limit)
    token = _WORK.set(work)
    try:
        yield work
    finally:
        _WORK.reset(token)


@contextlib.contextmanager
def labelled(label: str) -> Iterator[None]:
    """Name the results computed in the block (``"multipliers"``, ``"forces"``) for the
    list of what was left untidied when the budget ran out, and tell the stage hook
    (:func:`stage_hook`), if any."""
    hook = _HOOK.get()
    if hook is not None and label != _LABEL.get():
        hook(label)
    token = _LABEL.set(label)
    try:
        yield
    finally:
        _LABEL.reset(token)


_HOOK: contextvars.ContextVar[Callable[[str], None] | None] = contextvars.ContextVar(
    "lamech_stage_hook", default=None
)


@contextlib.contextmanager
def stage_hook(hook: Callable[[str], None]) -> Iterator[None]:
    """Call ``hook(stage)`` as a solve inside the block enters each stage (the
    multipliers, the energy, the conditions, the forces, ...): a progress display."""
    token = _HOOK.set(hook)
    try:
        yield
    finally:
        _HOOK.reset(token)


def current_work() -> Work | None:
    return _WORK.get()


CALL_WORK = 400_000
"""The most work one normal form (or one linear solve) may take, beside the solve's
budget: an expression past it is given back as it is, at a bounded cost."""

_CALL: contextvars.ContextVar[list | None] = contextvars.ContextVar("lamech_call", default=None)


_STOP: contextvars.ContextVar[list | None] = contextvars.ContextVar("lamech_stop", default=None)


@contextlib.contextmanager
def interruptible() -> Iterator[list]:
    """A flag (``flag[0]``) that, once set (by a Ctrl-C handler, say), makes every
    normal form inside the block give up as if the budget had run out: the solve then
    finishes quickly with what is done and the rest as derived, and says so."""
    flag = [False]
    token = _STOP.set(flag)
    try:
        yield flag
    finally:
        _STOP.reset(token)


def interrupted() -> bool:
    flag = _STOP.get()
    return bool(flag and flag[0])


def _charge(units: int) -> None:
    flag = _STOP.get()
    if flag is not None and flag[0]:
        raise OverBudget("interrupted")
    call = _CALL.get()
    if call is not None:
        call[0] += units
        if call[0] > call[1]:
            raise OverBudget(f"more than {call[1]} units of work in one normal form")
    work = _WORK.get()
    if work is not None:
        work.charge(units)


@contextlib.contextmanager
def _one_call(limit: int) -> Iterator[None]:
    token = _CALL.set([0, limit])
    try:
        yield
    finally:
        _CALL.reset(token)
