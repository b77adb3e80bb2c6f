"""Problem files (TOML) and plain dicts to a checked :class:`~lamech.model.System`, and
the bundled example problems.

Every problem found is collected and reported at once in a :class:`ProblemFileError`
naming the file, line, offending text and the fix. Expressions go through
:func:`lamech.expr.parse` only: nothing in a file is executed.

The example listing is light (standard library); the loader (SymPy) is imported on the
first use of one of its names.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .._moved import moved
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
]

_LAZY = {
    "load": "_loader",
    "loads": "_loader",
    "from_dict": "_loader",
    "ProblemFileError": "_loader",
    "Issue": "_loader",
    "chain_toml": "_generated",
}


# as_system (a System from a System, a path or an example's name) is plumbing: lamech
# imports it from ._coerce; here it warns.
__getattr__ = moved(__name__, {"as_system": ("_coerce", "internal to lamech.problem")}, _LAZY)


if TYPE_CHECKING:
    from ._generated import chain_toml
    from ._loader import Issue, ProblemFileError, from_dict, load, loads
