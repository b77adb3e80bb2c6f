"""The ``lamech`` command: a thin layer that parses arguments and calls the library.

Heavy imports (SymPy, NumPy, SciPy, matplotlib) happen inside the subcommands, so
``lamech --help`` and ``lamech examples`` answer without them.
"""

from ._main import main

__all__ = ["main"]
