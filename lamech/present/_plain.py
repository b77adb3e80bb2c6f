"""User text shown as text: in matplotlib's pictures and in LaTeX (KaTeX's included).

A problem file's title, its force directions' names (``along = { "normal force" = ...
}``) and a file's name are free text; matplotlib reads ``$...$`` in any label as
mathtext (and raises on what it cannot parse: a price ``$5``, a ``\\frac{1}``), and TeX
reads a backslash as a command (``\\href``, ``\\def``). Every such string goes through
one of these functions on its way out, so that it is drawn or typeset letter for letter
and never run. Names that the model checks are identifiers (coordinates, parameters,
constraints, bodies) pass through unchanged.
"""

from __future__ import annotations

import re

__all__ = ["drawn", "tex_text", "tex_label", "tex_comment"]

_TEX_SPECIAL = {
    "\\": r"\textbackslash{}",
    "{": r"\{",
    "}": r"\}",
    "$": r"\$",
    "&": r"\&",
    "#": r"\#",
    "^": r"\textasciicircum{}",
    "_": r"\_",
    "%": r"\%",
    "~": r"\textasciitilde{}",
}
_TEX_RE = re.compile("|".join(re.escape(c) for c in _TEX_SPECIAL))
_CONTROL = re.compile(r"[\x00-\x1f\x7f\u2028\u2029]+")
_IDENT = re.compile(r"[A-Za-z][A-Za-z0-9_]*")


def drawn(text: str) -> str:
    """``text`` for a matplotlib label or title, drawn as it is: every ``$`` escaped, so
    that matplotlib never reads mathtext in it (it draws ``\\$`` as ``$``)."""
    return str(text).replace("$", r"\$")


def tex_text(text: str) -> str:
    """``text`` for the inside of LaTeX's ``\\text{...}``: the ten characters TeX gives a
    meaning (``\\ { } $ & # ^ _ % ~``) escaped and line breaks made spaces, so that no
    command, group, math shift or comment can start in it (KaTeX and LaTeX typeset
    the escapes alike)."""
    one_line = _CONTROL.sub(" ", str(text))
    return _TEX_RE.sub(lambda m: _TEX_SPECIAL[m.group(0)], one_line)


def tex_label(name: str) -> str:
    """A name for a subscript in math mode: an identifier in upright letters
    (``\\mathrm{normal}``, ``\\mathrm{rolling\\_1}``), any other text in ``\\text{...}``
    escaped (``\\text{normal force}``): upright both, and never a command."""
    name = str(name)
    if _IDENT.fullmatch(name):
        escaped = name.replace("_", r"\_")
        return rf"\mathrm{{{escaped}}}"
    return rf"\text{{{tex_text(name)}}}"


def tex_comment(text: str) -> str:
    """``text`` for a LaTeX comment line (``% lamech: <title>``): on one line, so that
    nothing after a line break in it is read as TeX."""
    return _CONTROL.sub(" ", str(text))
