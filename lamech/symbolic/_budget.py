"""A time bound that SymPy cannot overrun.

``simplify``, ``trigsimp``, ``cancel`` and ``factor`` have no time limit, and how long
one takes on a medium expression depends on more than its size: on what SymPy's cache
already holds (so on what ran before in the process), on the order of sets (the hash
seed) and on how far the bounded elimination got before its own deadline. The same
call that takes a tenth of a second in one process can take many minutes in another.
Size limits alone cannot rule that out; a clock checked between steps cannot either,
since one step is the problem.

:func:`within` runs one such call with a real bound: a timer signal (``SIGALRM``)
raises inside SymPy's pure-Python code when the time is up, and the caller gets its
fallback (the expression as it was). SymPy has no such option and neither has any
library made for it; ``signal.setitimer`` is the standard mechanism. Only the main
thread receives signals: elsewhere (and where ``setitimer`` does not exist) the call
runs unbounded, as before. An outer timer (a test runner's, another :func:`within`
further out) is kept: when it is due sooner it governs alone; otherwise it is re-armed
with its remaining time afterwards.
"""

from __future__ import annotations

import contextlib
import contextvars
import functools
import signal
import threading
import time
from collections.abc import Callable, Iterator
from typing import Any, TypeVar

import sympy as sp

__all__ = ["within", "SIMPLIFY_SECONDS", "simplification_bound", "count_ops"]

SIMPLIFY_SECONDS = 8.0
"""Default bound on one simplification, in seconds (the slowest useful one here takes
about a second); :func:`simplification_bound` changes it for a block of code."""

_BOUND: contextvars.ContextVar[float] = contextvars.ContextVar(
    "lamech_simplify_seconds", default=SIMPLIFY_SECONDS
)


@contextlib.contextmanager
def simplification_bound(seconds: float) -> Iterator[None]:
    """Bound each simplification inside the block by ``seconds`` (instead of
    :data:`SIMPLIFY_SECONDS`): lower for a faster, less tidy solve; results are the
    same functions either way, only their written form differs."""
    if not seconds > 0:
        raise ValueError(f"a simplification bound must be positive, got {seconds!r}")
    token = _BOUND.set(float(seconds))
    try:
        yield
    finally:
        _BOUND.reset(token)


T = TypeVar("T")


class _Late(BaseException):
    """Raised by the timer inside the bounded call (a BaseException, so that SymPy's
    ``except Exception`` clauses do not swallow it)."""


def _usable() -> bool:
    return hasattr(signal, "setitimer") and threading.current_thread() is threading.main_thread()


def within(fn: Callable[..., T], *args: Any, fallback: T, seconds: float | None = None) -> T:
    """``fn(*args)``, or ``fallback`` when it has not returned after ``seconds`` (by
    default the bound of :func:`simplification_bound`, else :data:`SIMPLIFY_SECONDS`)."""
    seconds = _BOUND.get() if seconds is None else seconds
    if not _usable():
        return fn(*args)
    old_delay, old_interval = signal.getitimer(signal.ITIMER_REAL)
    if old_delay and old_delay <= seconds:
        return fn(*args)  # an outer bound is due first: it governs
    armed = [True]

    def late(signum, frame):
        if armed[0]:
            raise _Late

    try:
        old_handler = signal.signal(signal.SIGALRM, late)
    except ValueError:  # pragma: no cover - not the main interpreter
        return fn(*args)
    start = time.monotonic()
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        try:
            return fn(*args)
        finally:
            # Disarmed first: a timer that fires between fn's return and here raises
            # _Late in this block, which the clause below still catches (under load, a
            # 1 ms bound let it escape from the old single finally).
            armed[0] = False
    except _Late:
        return fallback
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old_handler)
        if old_delay:
            left = max(old_delay - (time.monotonic() - start), 1e-3)
            signal.setitimer(signal.ITIMER_REAL, left, old_interval)


@functools.lru_cache(maxsize=4096)
def _count(expr: Any) -> int:
    return int(sp.count_ops(expr))


def count_ops(expr: Any) -> int:
    """``sympy.count_ops(expr)``, remembered: a solve asks it of the same long closed
    forms again and again (to bound ``simplify``, ``angle_tidy``, the manifold
    rewriting, to decide what is printed), and on an expression of 15,000 operations
    (the rolling disc's accelerations) one count takes tens of milliseconds; counting
    them was three quarters of ``closed_forms`` there."""
    expr = sp.sympify(expr)
    if expr.is_Atom:
        return 0
    try:
        return _count(expr)
    except TypeError:  # unhashable (a matrix): count it afresh
        return int(sp.count_ops(expr))
