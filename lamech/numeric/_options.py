"""The simulator's options and its two exceptions: :class:`SimulationError` (bad input:
nothing was integrated) and :class:`Stop` (a run stops early, keeping what it
computed)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._errors import LamechError

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

DEFAULT_RTOL = 1e-11
DEFAULT_ATOL = 1e-12
INITIAL_TOLERANCE = 1e-10
"""An initial state meets a constraint when |f| and |F| <= this (1 + max |q|)."""
BLOW_UP = 1e12
"""A run stops as failed when max(|q|, |q'|) exceeds BLOW_UP (1 + its size at the start)."""
METHODS = ("DOP853", "RK45", "Radau", "BDF")
"""SciPy's integrators by name (SciPy is imported when a simulation runs, not before)."""
IMPLICIT = ("Radau", "BDF")
"""The implicit ones: for stiff systems (a stiff damper or spring), whose explicit steps
are held down by stability rather than accuracy."""
MAX_STEPS = 10**8
"""The most steps a ``max_step`` may force on one run: (t_end - t0) / max_step above it
(a day or more at a typical millisecond a step) is refused before the run."""


MAX_SAMPLES = 10_000_000
"""The most output times one run keeps (about 80 MB a column; ``lamech simulate``'s
bound too): more is refused before the run, never a run that fills the memory."""


class SimulationError(LamechError, ValueError):
    """Bad options or an inconsistent initial state (nothing was integrated)."""


class Stop(Exception):
    """Stop the run: ``cause`` names the time, the reason and what to try."""

    def __init__(self, cause: str):
        super().__init__(cause)
        self.cause = cause


@dataclass(frozen=True)
class Options:
    """The integration options of a run, the one place their defaults live (``simulate``,
    ``integrate_batch``, ``integrate_events`` and the sweeps take theirs from here). It
    checks itself when made: :class:`SimulationError` (a ValueError) names the first bad
    option, its value and the default. :meth:`given` fills the options a caller left as
    None with the defaults."""

    rtol: float = DEFAULT_RTOL
    atol: float = DEFAULT_ATOL
    max_step: float = math.inf
    method: str = "DOP853"

    def __post_init__(self) -> None:
        if _bad(self.rtol) or self.rtol <= 0 or self.rtol >= 1:
            raise SimulationError(
                f"rtol must be in (0, 1) (got {self.rtol}); default {DEFAULT_RTOL}"
            )
        if self.rtol < 1e-14:
            raise SimulationError(
                f"rtol {self.rtol} is below 1e-14, which double precision cannot honour; use "
                "rtol >= 1e-14"
            )
        if _bad(self.atol) or self.atol <= 0:
            raise SimulationError(
                f"atol must be positive (got {self.atol}); default {DEFAULT_ATOL}"
            )
        step = self.max_step
        if not isinstance(step, (int, float, np.floating, np.integer)) or math.isnan(step):
            raise SimulationError(f"max_step must be positive (got {step})")
        if step <= 0:
            raise SimulationError(f"max_step must be positive (got {step})")
        if self.method not in METHODS:
            raise SimulationError(f"unknown method {self.method!r}; one of {', '.join(METHODS)}")

    @property
    def arm(self) -> float:
        """How far a gap or a slip velocity must move from zero before its contact or
        stick event may fire again (and the slip speed below which a slip starts from
        rest): 100 atol, at least 1e-13. The simulator's and the loops'."""
        return max(100.0 * self.atol, 1e-13)

    @classmethod
    def given(cls, rtol=None, atol=None, max_step=None, method=None) -> Options:
        """The options with those given (not None), the defaults for the others."""
        given = {"rtol": rtol, "atol": atol, "max_step": max_step, "method": method}
        return cls(**{k: v for k, v in given.items() if v is not None})

    def integrator(self):
        """SciPy's integrator class (imported on first use)."""
        import scipy.integrate

        return getattr(scipy.integrate, self.method)


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


def _bad(x) -> bool:
    """Not a finite real number."""
    return not isinstance(x, (int, float, np.floating, np.integer)) or not math.isfinite(x)


def check_options(t_end, t0, rtol, atol, max_step, samples, dt, method: str = "DOP853") -> Options:
    """The run's :class:`Options` (``max_step`` None: no bound), checked with the times
    and samples: raise :class:`SimulationError` naming the first bad option."""
    if _bad(t_end) or _bad(t0) or t_end <= t0:
        raise SimulationError(
            f"t_end must be a finite number after the start time {t0} (got {t_end})"
        )
    options = Options.given(rtol, atol, max_step, method)
    if options.max_step < math.inf:
        _check_max_step(float(options.max_step), float(t0), float(t_end))
    if samples is not None and dt is not None:
        raise SimulationError("give samples or dt, not both")
    if samples is not None and (not isinstance(samples, (int, np.integer)) or samples < 2):
        raise SimulationError(
            f"samples counts both ends and must be an integer >= 2 (got {samples})"
        )
    if dt is not None and (_bad(dt) or dt <= 0):
        raise SimulationError(f"dt must be a positive number (got {dt})")
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
