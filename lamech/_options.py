"""The options of a run (:class:`Options`), their defaults, and the error a bad one
raises (:class:`SimulationError`).

It lives outside the layers, beside :mod:`lamech._errors`, and imports neither NumPy nor
SciPy: the command line reads the options' help and choices from here, and ``lamech
--help`` stays instant. The simulator's own limits and checks against the run's times
are in :mod:`lamech.numeric._options`.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, field, fields, replace

from ._errors import LamechError

__all__ = [
    "DEFAULT_RTOL",
    "DEFAULT_ATOL",
    "INITIAL_TOLERANCE",
    "BLOW_UP",
    "METHODS",
    "IMPLICIT",
    "ENGINES",
    "ALIASES",
    "SimulationError",
    "Options",
    "is_bad",
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
ENGINES = ("auto", "compiled", "python", "scipy")
"""The engines of ``simulate`` and ``sweep`` (:mod:`lamech.numeric._engines`)."""
ALIASES = {"loop": "loop", "simulate": "scipy"}
"""Older names still accepted (``"loop"`` keeps its meaning: compiled where the system
is, else Python)."""


class SimulationError(LamechError, ValueError):
    """Bad options or an inconsistent initial state (nothing was integrated)."""


def _option(default, help: str, choices: tuple | None = None):
    """A field of :class:`Options` with its help text (and its choices), which the command
    line's options take from here."""
    return field(default=default, metadata={"help": help, "choices": choices})


@dataclass(frozen=True)
class Options:
    """How a run integrates: tolerances, step bound, method, output times, engine. The
    one place their defaults live (:func:`lamech.simulate`, :func:`lamech.sweep`,
    ``integrate_batch``, ``integrate_events`` and the command line take theirs from here).

    It checks itself when made: :class:`SimulationError` (a ValueError) names the first
    bad option, its value and the default. Pass it as ``options=``; the same names given
    as keyword arguments to ``simulate`` or ``sweep`` replace its fields
    (:meth:`merged`).

    Parameters
    ----------
    rtol, atol : float
        Relative and absolute tolerance of every step (defaults 1e-11 and 1e-12,
        ``lamech.numeric.DEFAULT_RTOL`` and ``DEFAULT_ATOL``; rtol in [1e-14, 1)).
    max_step : float
        The largest step (default inf: no bound); refused when it would force more than
        1e8 steps.
    method : {"DOP853", "RK45", "Radau", "BDF"}
        SciPy's integrator; Radau and BDF (implicit) for stiff systems.
    samples : int, optional
        Output times: this many, evenly spaced, both ends counted (default 1001).
    dt : float, optional
        Output times every ``dt`` instead (not with ``samples``).
    engine : {"auto", "compiled", "python", "scipy"}
        What integrates (see :func:`lamech.simulate`); the older ``"loop"`` and
        ``"simulate"`` are accepted.
    jit : bool, optional
        Run the system on lamech's engine in C (None: wherever it can; False: NumPy and
        SciPy only).
    project_initial : bool
        Move an initial state off the constraints to the nearest consistent one instead
        of refusing it.

    Examples
    --------
    >>> import lamech
    >>> opts = lamech.Options(rtol=1e-9, samples=11)
    >>> lamech.simulate("pendulum", 1.0, options=opts).t.shape
    (11,)
    >>> try:
    ...     lamech.Options(rtol=2.0)
    ... except lamech.SimulationError as exc:
    ...     print(exc)
    rtol must be in (0, 1) (got 2.0); default 1e-11
    """

    rtol: float = _option(DEFAULT_RTOL, "relative tolerance")
    atol: float = _option(DEFAULT_ATOL, "absolute tolerance")
    max_step: float = _option(
        math.inf,
        "largest integrator step (default: unlimited); refused when it would force more than "
        "1e8 steps to reach the end time (a day or more)",
    )
    method: str = _option(
        "DOP853",
        "the integrator: DOP853 (explicit, order 8), RK45, or the implicit Radau and BDF for "
        "stiff systems, such as a stiff damper or spring whose fastest time scale is far "
        "below the motion's (lamech says so when a long run's step is held down by stability)",
        METHODS,
    )
    samples: int | None = _option(None, "output times: N evenly spaced, both ends counted")
    dt: float | None = _option(None, "output spacing")
    engine: str = _option("auto", "what integrates", ENGINES)
    jit: bool | None = _option(None, "run on lamech's engine in C (None: wherever it can)")
    project_initial: bool = _option(
        False, "move an initial state off the constraints to the nearest consistent one"
    )

    def __post_init__(self) -> None:
        if is_bad(self.rtol) or self.rtol <= 0 or self.rtol >= 1:
            raise SimulationError(
                f"rtol must be in (0, 1) (got {self.rtol}); default {DEFAULT_RTOL}"
            )
        if self.rtol < 1e-14:
            raise SimulationError(
                f"rtol {self.rtol} is below 1e-14, which double precision cannot honour; use "
                "rtol >= 1e-14"
            )
        if is_bad(self.atol) or self.atol <= 0:
            raise SimulationError(
                f"atol must be positive (got {self.atol}); default {DEFAULT_ATOL}"
            )
        step = self.max_step
        if not isinstance(step, numbers.Real) or math.isnan(step):
            raise SimulationError(f"max_step must be positive (got {step})")
        if step <= 0:
            raise SimulationError(f"max_step must be positive (got {step})")
        if self.method not in METHODS:
            raise SimulationError(f"unknown method {self.method!r}; one of {', '.join(METHODS)}")
        samples, dt = self.samples, self.dt
        if samples is not None and dt is not None:
            raise SimulationError("give samples or dt, not both")
        if samples is not None and (
            isinstance(samples, bool) or not isinstance(samples, numbers.Integral) or samples < 2
        ):
            raise SimulationError(
                f"samples counts both ends and must be an integer >= 2 (got {samples})"
            )
        if dt is not None and (is_bad(dt) or dt <= 0):
            raise SimulationError(f"dt must be a positive number (got {dt})")
        if self.engine not in ENGINES and self.engine not in ALIASES:
            raise SimulationError(
                f"engine must be one of {', '.join(ENGINES)}, got {self.engine!r}; default 'auto'"
            )
        if self.jit not in (None, True, False):
            raise SimulationError(f"jit must be True, False or None (got {self.jit!r})")
        if self.project_initial not in (True, False):
            raise SimulationError(
                f"project_initial must be True or False (got {self.project_initial!r})"
            )

    @property
    def arm(self) -> float:
        """How far a gap or a slip velocity must move from zero before its contact or
        stick event may fire again (and the slip speed below which a slip starts from
        rest): 100 atol, at least 1e-13. The simulator's and the loops'."""
        return max(100.0 * self.atol, 1e-13)

    @classmethod
    def given(cls, rtol=None, atol=None, max_step=None, method=None) -> Options:
        """The options with those given (not None), the defaults for the others."""
        return cls.merged(None, rtol=rtol, atol=atol, max_step=max_step, method=method)

    @classmethod
    def merged(cls, options: Options | None = None, **loose) -> Options:
        """``options`` (default: the defaults) with the fields given in ``loose`` (not
        None) replaced: the one place ``simulate``'s and ``sweep``'s keyword arguments
        become an :class:`Options`. TypeError for a name that is not a field."""
        if options is not None and not isinstance(options, Options):
            raise TypeError(f"options must be a lamech.Options (got {type(options).__name__})")
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(loose) - names)
        if unknown:
            raise TypeError(
                f"unknown option {unknown[0]!r}; the options are {', '.join(sorted(names))}"
            )
        given = {k: v for k, v in loose.items() if v is not None}
        if options is None:
            return cls(**given)
        return replace(options, **given) if given else options

    def integrator(self):
        """SciPy's integrator class (imported on first use)."""
        import scipy.integrate

        return getattr(scipy.integrate, self.method)

    def times(self, t0: float, t_end: float):
        """The output times from ``t0`` to ``t_end``: every ``dt`` from ``t0`` (and
        ``t_end``), or ``samples`` (default 1001) evenly spaced, both ends counted (a
        NumPy array)."""
        from .numeric._options import sample_times

        return sample_times(t0, t_end, self.samples, self.dt)


def is_bad(x) -> bool:
    """Not a finite real number."""
    return not isinstance(x, numbers.Real) or not math.isfinite(x)
