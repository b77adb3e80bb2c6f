"""The bundled example problems: names, files and titles (standard library only, so that
``lamech examples`` answers without importing SymPy)."""

from __future__ import annotations

import sys
from importlib import resources
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["example_names", "example_path", "example_title"]


def example_names() -> list[str]:
    """Names of the bundled example problems (``lamech.load(name)`` loads one)."""
    folder = resources.files("lamech") / "examples"
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


def example_path(name: str) -> Path:
    """The file of the bundled example ``name``."""
    if name not in example_names():
        raise KeyError(f"no bundled example `{name}`; known: {', '.join(example_names())}")
    return Path(str(resources.files("lamech") / "examples" / f"{name}.toml"))


def example_title(name: str) -> str:
    """The title of a bundled example, read from its TOML alone (no SymPy: fast)."""
    data = tomllib.loads(example_path(name).read_text(encoding="utf-8"))
    return str(data.get("title", name))
