"""What the Python API's functions take as a problem (:func:`as_system`): a
:class:`~lamech.model.System`, or a problem file's path or a bundled example's name,
loaded as ``lamech.load`` does (what ``run_sweep`` and the command line take); anything
else is a TypeError that names the argument and what to pass."""

from __future__ import annotations

import os

from ..model import System

__all__ = ["as_system"]


def as_system(problem, function: str, argument: str = "system") -> System:
    """``problem`` as a System: itself, or the file or bundled example it names
    (:func:`lamech.load`; a :class:`ProblemFileError` where there is none). Text of a
    problem (several lines) is refused with a pointer to :func:`lamech.loads`; any other
    type raises TypeError naming ``function``'s ``argument``."""
    if isinstance(problem, System):
        return problem
    if isinstance(problem, (str, os.PathLike)):
        text = str(os.fspath(problem))
        if "\n" in text:
            raise ValueError(
                f"{function}({argument}=...): this text looks like a problem file's contents; "
                "pass lamech.loads(text), or the file's path"
            )
        from ._loader import load

        return load(text)
    raise TypeError(
        f"{function}: {argument} must be a lamech.System (lamech.load('pendulum'), "
        "lamech.loads(text), lamech.from_dict(d)), a problem file's path or a bundled "
        f"example's name; got {type(problem).__name__}"
    )
