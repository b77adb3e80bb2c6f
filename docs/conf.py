"""Sphinx configuration for lamech's documentation (MyST Markdown, numpydoc).

Build: ``./run-docs`` (sets up ``.venv`` on first use), or in an environment with lamech
and its ``docs`` extra, ``python -m sphinx -W -b html docs docs/_build/html``
(``tests/test_docs.py`` does, with warnings as errors). Nothing needs to run before: the
gallery and the CLI reference are written at build time from the library itself
(``_ext/lamech_docs.py``). Every cross-reference resolves (``nitpicky``): a docstring
names a private helper as ``literal`` text, not as a reference.
"""

from __future__ import annotations

import sys
from pathlib import Path

here = Path(__file__).resolve().parent
sys.path.insert(0, str(here / "_ext"))

import lamech  # noqa: E402

project = "lamech"
author = "the lamech developers"
copyright = "the lamech developers, MIT licence"
version = release = lamech.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "lamech_katex",  # math by the vendored KaTeX, offline (not MathJax from a CDN)
    "numpydoc",
    "lamech_docs",
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]
myst_heading_anchors = 3
exclude_patterns = ["_build", "**/.ipynb_checkpoints"]
html_theme = "alabaster"
html_title = f"lamech {release}"
html_static_path: list[str] = []
html_theme_options = {"page_width": "1240px", "sidebar_width": "240px"}

autodoc_member_order = "bysource"
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False

# The console lexer gives up on output with an unbalanced quote (the pendulum's
# tension's "string's"); the block is still shown, unhighlighted.
suppress_warnings = ["misc.highlighting_failure"]
nitpicky = True  # every cross-reference resolves (tests/test_docs.py builds with -W)
