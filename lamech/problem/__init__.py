"""Problem files (TOML) and plain dicts to a checked :class:`~lamech.model.System`, and
the bundled example problems.

Every problem found is collected and reported at once in a :class:`ProblemFileError`
naming the file, line, offending text and the fix. Expressions go through
:func:`lamech.expr.parse` only: nothing in a file is executed.

The example listing is light (standard library); the loader (SymPy) is imported on the
first use of one of its names.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from ._examples import example_names, example_path, example_title

__all__ = [
    "load",
    "loads",
    "from_dict",
    "example_names",
    "example_path",
    "example_title",
    "ProblemFileError",
    "Issue",
    "chain_toml",
    "as_system",
]

_LAZY = {
    "load": "_loader",
    "loads": "_loader",
    "from_dict": "_loader",
    "ProblemFileError": "_loader",
    "Issue": "_loader",
    "chain_toml": "_generated",
    "as_system": "_coerce",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'lamech.problem' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"lamech.problem.{module}"), name)
    globals()[name] = value
    return value


if TYPE_CHECKING:
    from ._coerce import as_system
    from ._generated import chain_toml
    from ._loader import Issue, ProblemFileError, from_dict, load, loads
