"""The engines' names, one set for ``simulate`` and ``sweep``.

- ``"auto"``: the loop with events on lamech's engine in C wherever it can run the
  problem, else the other engines' best choice;
- ``"compiled"``: the loop with events on the engine in C (the system's own functions
  compiled now if they were not);
- ``"python"``: the same loop on the engine in C, with the system's functions called back
  in Python (its NumPy functions: no C compiler needed, the same numbers to rounding,
  slower per step); the name stays from when the loop itself ran as Python;
- ``"scipy"``: SciPy's integrators driven from Python (for a sweep: ``simulate`` for every
  case).

Older names stay accepted, with a DeprecationWarning: ``simulate``'s ``"loop"`` (the loop,
compiled where the system is, else as Python) and ``sweep``'s ``"simulate"``
(``"scipy"``).
"""

from __future__ import annotations

import warnings

__all__ = ["ENGINES", "ALIASES", "engine_name"]

from .._options import ALIASES, ENGINES


def engine_name(engine: str, error: type[Exception] = ValueError) -> str:
    """``engine`` checked: one of :data:`ENGINES`, or an older name (a DeprecationWarning
    names its successor); ``error`` (the caller's exception class) otherwise."""
    if engine in ENGINES:
        return engine
    if engine in ALIASES:
        new = "'compiled' or 'python'" if engine == "loop" else repr(ALIASES[engine])
        warnings.warn(
            f"engine {engine!r} is deprecated; use {new}", DeprecationWarning, stacklevel=3
        )
        return ALIASES[engine]
    raise error(f"engine must be one of {', '.join(ENGINES)}, got {engine!r}")
