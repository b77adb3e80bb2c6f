"""The base of every error lamech raises for what it was given (:class:`LamechError`).

Each layer's refusal (a problem file's mistake, a model that cannot be built, constraints
that are dependent, a simulation that cannot run, a sweep's bad grid, an output that
cannot be written, a closed form that failed its self-check) is a subclass of it and of
``ValueError``, so a program can tell lamech's refusals apart from its own bugs::

    try:
        sol = lamech.solve(path)
    except lamech.LamechError as exc:
        print(exc)

It lives outside the layers (any of them may import it; it imports nothing).
"""

from __future__ import annotations

__all__ = ["LamechError"]


class LamechError(Exception):
    """An input lamech refuses, with a message that says what, where and what to do.

    ``ProblemFileError`` adds the file and line where there are some; see each
    subclass."""
