"""SIGTERM and SIGHUP treated like Ctrl-C: they raise :class:`Stopped` (a
KeyboardInterrupt) in the main thread, so a simulation keeps its trajectory and a sweep
its finished rows exactly as after Ctrl-C; the command then says which signal stopped it
and exits with 128 + its number (143 for SIGTERM, 129 for SIGHUP, 130 for SIGINT)."""

from __future__ import annotations

import signal
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["Stopped", "stop_signals", "noting", "signal_name", "exit_status"]

CAUGHT = tuple(getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name))


class Stopped(KeyboardInterrupt):
    """Raised by a caught signal (``signum``)."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


def signal_name(exc: BaseException) -> str:
    """SIGTERM, SIGHUP, or SIGINT for a plain KeyboardInterrupt (Ctrl-C)."""
    signum = getattr(exc, "signum", signal.SIGINT)
    return signal.Signals(signum).name


def exit_status(exc: BaseException) -> int:
    """128 + the signal's number."""
    return 128 + int(getattr(exc, "signum", signal.SIGINT))


@contextmanager
def stop_signals() -> Iterator[None]:
    """Within: SIGTERM and SIGHUP raise :class:`Stopped` (each time one arrives); the
    previous handlers come back after."""

    def handler(signum, frame):
        raise Stopped(signum)

    saved = {}
    try:
        for s in CAUGHT:
            saved[s] = signal.signal(s, handler)
    except ValueError:  # not the main thread: leave the signals alone
        pass
    try:
        yield
    finally:
        for s, old in saved.items():
            signal.signal(s, old)


@contextmanager
def noting(seen: list[BaseException]) -> Iterator[None]:
    """Within: Ctrl-C, SIGTERM and SIGHUP raise :class:`Stopped` (a KeyboardInterrupt)
    and are noted in ``seen``, for the code inside catches them (the simulator keeps its
    trajectory, a sweep its rows) and the command must still say which signal it was."""

    def handler(signum, frame):
        exc = Stopped(signum)
        seen.append(exc)
        raise exc

    saved = {}
    for s in (signal.SIGINT, *CAUGHT):
        try:
            saved[s] = signal.signal(s, handler)
        except ValueError:  # not the main thread
            break
    try:
        yield
    finally:
        for s, old in saved.items():
            signal.signal(s, old)
