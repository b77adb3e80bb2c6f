"""The simulator's options and its two exceptions: :class:`SimulationError` (bad input:
nothing was integrated) and :class:`Stop` (a run stops early, keeping what it
computed)."""

from __future__ import annotations

import math

import numpy as np

from .._options import (
    BLOW_UP,
    DEFAULT_ATOL,
    DEFAULT_RTOL,
    IMPLICIT,
    INITIAL_TOLERANCE,
    METHODS,
    Options,
    SimulationError,
    is_bad,
)

__all__ = [
    "DEFAULT_RTOL",
    "DEFAULT_ATOL",
    "INITIAL_TOLERANCE",
    "BLOW_UP",
    "METHODS",
    "IMPLICIT",
    "MAX_STEPS",
    "MAX_SAMPLES",
    "SimulationError",
    "Stop",
    "Options",
    "check_options",
    "sample_times",
]

MAX_STEPS = 10**8
"""The most steps a ``max_step`` may force on one run: (t_end - t0) / max_step above it
(a day or more at a typical millisecond a step) is refused before the run."""


MAX_SAMPLES = 10_000_000
"""The most output times one run keeps (about 80 MB a column; ``lamech simulate``'s
bound too): more is refused before the run, never a run that fills the memory."""


class Stop(Exception):
    """Stop the run: ``cause`` names the time, the reason and what to try."""

    def __init__(self, cause: str):
        super().__init__(cause)
        self.cause = cause


def sample_times(t0: float, t_end: float, samples: int | None, dt: float | None) -> np.ndarray:
    """The output times: every ``dt`` from ``t0`` (and ``t_end``), or ``samples`` (default
    1001) evenly spaced, both ends counted."""
    if dt is not None:
        count = int(math.floor((t_end - t0) / dt + 1e-9))
        times = t0 + dt * np.arange(count + 1)
        if times[-1] < t_end - 1e-12 * max(1.0, abs(t_end)):
            times = np.append(times, t_end)
        return times
    return np.linspace(t0, t_end, 1001 if samples is None else int(samples))


def check_options(t_end, t0, options: Options) -> Options:
    """``options`` checked with the run's times: raise :class:`SimulationError` naming the
    first bad value (an end time not after the start, a ``max_step`` that forces more
    than :data:`MAX_STEPS` steps, more than :data:`MAX_SAMPLES` output times)."""
    if is_bad(t_end) or is_bad(t0) or t_end <= t0:
        raise SimulationError(
            f"t_end must be a finite number after the start time {t0} (got {t_end})"
        )
    if options.max_step < math.inf:
        _check_max_step(float(options.max_step), float(t0), float(t_end))
    samples, dt = options.samples, options.dt
    count = samples if samples is not None else ((t_end - t0) / dt + 1 if dt is not None else 0)
    if count > MAX_SAMPLES:
        what = f"samples={samples}" if samples is not None else f"dt={dt} gives {count:.3g} samples"
        raise SimulationError(
            f"{what}: more output times than lamech keeps in one run ({MAX_SAMPLES:.0e}, "
            "about 80 MB a column); give fewer samples or a larger dt"
        )
    return options


def _check_max_step(max_step: float, t0: float, t_end: float) -> None:
    """A max_step that forces more than MAX_STEPS steps, or that t cannot resolve (t +
    max_step == t), would run for days or never end: refused with the smallest
    acceptable value."""
    span = t_end - t0
    floor = max(span / MAX_STEPS, 16 * math.ulp(max(abs(t0), abs(t_end))))
    if max_step >= floor:
        return
    if span / max_step > MAX_STEPS:
        why = (
            f"it forces at least {span / max_step:.3g} steps to reach t_end {t_end:g}, "
            f"more than the {MAX_STEPS:.0e} lamech takes in one run (a day or more at a "
            "typical millisecond a step)"
        )
    else:
        why = f"it is below the resolution of t near {max(abs(t0), abs(t_end)):g}"
    raise SimulationError(
        f"max_step {max_step:g} is too small: {why}; give max_step >= {floor:.3g}"
    )
