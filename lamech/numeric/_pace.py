"""How fast a run goes: after a short pilot (:data:`PILOT_SECONDS` of wall time) the
simulator measures its pace, projects the wall time to t_end, and checks whether its
step is held down by stability rather than accuracy (a stiff system, which an implicit
method integrates in far fewer steps). The result is a :class:`Pace`, given to the
caller's ``pace`` callback once; the simulator itself never prints.

Before that, after its first :data:`PILOT_STEPS` steps, a run projects how many steps
it needs to reach t_end at its mean step so far (:class:`Projection`, given to the
``projection`` callback once): counts and sizes only, no clock, so that the same run
projects the same on any machine, and a run too long to end (``--t-end 1e12``) is told
within milliseconds. A run of fewer steps is never projected; a longer one pays one
comparison a step.

Stiffness test: the spectral radius rho of the Jacobian of the right-hand side (the
index-1 form, by finite differences at the present state) times the present step h.
An explicit method's step that follows the motion's accuracy keeps h rho well below 1
(the pendulum at rtol 1e-11: 0.2); a step limited by stability sits near the edge of
the method's stability region (DOP853: about 6 on the negative real axis, RK45 3.3).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ._options import IMPLICIT
from ._run import Run

__all__ = ["PILOT_SECONDS", "PILOT_STEPS", "STIFF", "Pace", "Projection", "Watch", "stiffness"]

PILOT_SECONDS = 0.5
"""Wall time after which a run measures its pace (shorter runs are never measured)."""
PILOT_STEPS = 1000
"""Steps after which a run projects its step count (the compiled loop reports after each
chunk of 2000 steps: after its first)."""
STIFF = 1.0
"""h rho above this, with an explicit method: the step is held down by stability."""


@dataclass(frozen=True)
class Pace:
    """A run's pace after its pilot.

    ``t`` reached from ``t0`` in ``seconds`` of wall time and ``steps`` steps; ``step``
    the present step size; ``remaining`` the wall seconds still to go to ``t_end`` at the
    pace of the steps since the first (which carries the start-up costs), ``estimate``
    the whole run's; ``stiffness`` h rho (see :mod:`lamech.numeric._pace`) and
    ``fastest`` 1/rho, the fastest time scale of the dynamics; ``stiff`` is True when an
    explicit ``method``'s step is held down by stability: an implicit method (Radau,
    BDF) would take steps the motion allows.
    """

    t: float
    t0: float
    t_end: float
    seconds: float
    steps: int
    step: float
    remaining: float
    stiffness: float
    fastest: float
    method: str

    @property
    def estimate(self) -> float:
        """Projected wall seconds of the whole run."""
        return self.seconds + self.remaining

    @property
    def stiff(self) -> bool:
        return self.method not in IMPLICIT and self.stiffness > STIFF


@dataclass(frozen=True)
class Projection:
    """A run's step count projected after its first :data:`PILOT_STEPS` steps.

    ``steps`` steps took it from ``t0`` to ``t`` (a mean step of :attr:`mean_step`); at
    that mean step, :attr:`total` steps reach ``t_end``. Counts and sizes only: the
    projection does not depend on the machine's speed. ``seconds``, the wall time so
    far, is for the caller to say what the total would take at this pace.
    """

    t: float
    t0: float
    t_end: float
    steps: int
    seconds: float

    @property
    def mean_step(self) -> float:
        return (self.t - self.t0) / self.steps

    @property
    def total(self) -> float:
        """Projected steps of the whole run, t0 to t_end."""
        return self.steps * (self.t_end - self.t0) / (self.t - self.t0)

    @property
    def estimate(self) -> float:
        """Wall seconds of :attr:`total` steps at the pace of the steps so far."""
        return self.seconds * self.total / self.steps


def stiffness(run: Run, t: float, y: np.ndarray, h: float) -> tuple[float, float]:
    """(h rho, 1/rho) at (t, y): rho the spectral radius of d(rhs)/dy by forward
    differences (2n + 1 evaluations, once per run); (0, inf) where it cannot be had."""
    f0 = run.fun(t, y)
    if not np.all(np.isfinite(f0)):
        return 0.0, float("inf")
    J = np.empty((len(y), len(y)))
    for i in range(len(y)):
        d = 1.5e-8 * max(1.0, abs(float(y[i])))
        yi = y.copy()
        yi[i] += d
        J[:, i] = (run.fun(t, yi) - f0) / d
    if not np.all(np.isfinite(J)):
        return 0.0, float("inf")
    rho = float(np.max(np.abs(np.linalg.eigvals(J)), initial=0.0))
    if rho == 0.0:
        return 0.0, float("inf")
    return h * rho, 1.0 / rho


class Watch:
    """Calls ``progress(t)`` after every accepted step and, once each,
    ``projection(Projection)`` after :data:`PILOT_STEPS` steps and ``pace(Pace)`` after
    the pilot."""

    def __init__(
        self,
        t0: float,
        t_end: float,
        method: str,
        progress: Callable[[float], None] | None,
        pace: Callable[[Pace], None] | None,
        projection: Callable[[Projection], None] | None = None,
    ):
        self.t0, self.t_end, self.method = t0, t_end, method
        self.progress, self.pace, self.projection = progress, pace, projection
        self.start = time.monotonic()
        self.first: tuple[float, float] | None = None  # (clock, t) after the first step

    def step(self, run: Run, t: float, y: np.ndarray, h: float, steps: int) -> None:
        if self.projection is not None and steps >= PILOT_STEPS and t > self.t0:
            report_steps, self.projection = self.projection, None
            seconds = time.monotonic() - self.start
            report_steps(Projection(t, self.t0, self.t_end, steps, seconds))
        if self.pace is not None:
            now = time.monotonic()
            if self.first is None:
                self.first = (now, t)
            elif now - self.first[0] >= PILOT_SECONDS and t > self.first[1]:
                report, self.pace = self.pace, None
                ratio, fastest = stiffness(run, t, y, h)
                rate = (now - self.first[0]) / (t - self.first[1])  # wall s per unit of t
                remaining = rate * (self.t_end - t)
                seconds = now - self.start
                report(
                    Pace(
                        t,
                        self.t0,
                        self.t_end,
                        seconds,
                        steps,
                        h,
                        remaining,
                        ratio,
                        fastest,
                        self.method,
                    )
                )
        if self.progress is not None:
            self.progress(t)
