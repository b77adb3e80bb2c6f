"""Names a sub-package's face no longer exports (plumbing, or renamed): each still
resolves, from the private module that defines it, with a :class:`DeprecationWarning`
naming what to use instead, so that code written against the wider face keeps working
for a release."""

from __future__ import annotations

import importlib
import warnings
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["moved"]


def moved(
    package: str, names: Mapping[str, tuple[str, str]], lazy: Mapping[str, str] | None = None
) -> Callable[[str], Any]:
    """A module ``__getattr__`` for ``package``.

    Parameters
    ----------
    package : str
        The package's name (``"lamech.sweeps"``).
    names : dict of str to (str, str)
        Each name no longer on the face: (the private module that defines it, relative to
        the package, e.g. ``"_parse"``, or absolute, ``"lamech.present._table"``, where it
        moved to another layer; what to use instead, said in the warning). The module may
        define it under another name as ``"_module:name"``.
    lazy : dict of str to str, optional
        Names of the face itself imported on first use (no warning): {name: module}.
    """

    def __getattr__(name: str) -> Any:
        if lazy and name in lazy:
            value = getattr(importlib.import_module(f"{package}.{lazy[name]}"), name)
            importlib.import_module(package).__dict__[name] = value
            return value
        if name not in names:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        where, instead = names[name]
        module, _, attr = where.partition(":")
        if not module.startswith("lamech."):
            module = f"{package}.{module}"
        warnings.warn(
            f"{package}.{name} is deprecated: {instead} ({module}.{attr or name})",
            DeprecationWarning,
            stacklevel=2,
        )
        return getattr(importlib.import_module(module), attr or name)

    return __getattr__
