"""The ``lamech`` command: a thin layer that parses arguments and calls the library.

Heavy imports (SymPy, NumPy, SciPy, matplotlib) happen inside the subcommands, so
``lamech --help`` and ``lamech examples`` answer without them. :func:`make_app` is the
``lamech serve`` web application (Starlette), for tests and for serving it another way.
"""

from ._main import main
from ._serve import make_app

__all__ = ["main", "make_app"]
