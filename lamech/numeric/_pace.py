"""How fast a run goes: after a short pilot (:data:`PILOT_SECONDS` of wall time) the
simulator measures its pace, projects the wall time to t_end, and checks whether its
step is held down by stability rather than accuracy (a stiff system, which an implicit
method integrates in far fewer steps). The result is a :class:`Pace`, given to the
caller's ``pace`` callback once; the simulator itself never prints.

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

__all__ = ["PILOT_SECONDS", "STIFF", "Pace", "Watch", "stiffness"]

PILOT_SECONDS = 0.5
"""Wall time after which a run measures its pace (shorter runs are never measured)."""
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
    """Calls ``progress(t)`` after every accepted step and, once, ``pace(Pace)`` after the
    pilot."""

    def __init__(
        self,
        t0: float,
        t_end: float,
        method: str,
        progress: Callable[[float], None] | None,
        pace: Callable[[Pace], None] | None,
    ):
        self.t0, self.t_end, self.method = t0, t_end, method
        self.progress, self.pace = progress, pace
        self.start = time.monotonic()
        self.first: tuple[float, float] | None = None  # (clock, t) after the first step

    def step(self, run: Run, t: float, y: np.ndarray, h: float, steps: int) -> None:
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
