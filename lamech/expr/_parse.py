"""The parser's front: checks on the text, the lexical rewrites (``x'``, ``^``),
Python's ``ast`` with bounded nesting, and :func:`parse`, which hands the tree to
the builder."""

from __future__ import annotations

import ast
import keyword
import math
import re
import warnings
from collections.abc import Mapping

import sympy as sp

from ._build import _Builder
from ._grammar import (
    _ACC_SUFFIX,
    _GROUP,
    _PRIME,
    _SYMPY_FAILURES,
    _VEL_SUFFIX,
    MAX_DEPTH,
    MAX_LENGTH,
    ExpressionError,
    _velocity_hint,
)


def _lex(text: str) -> tuple[str, list[int]]:
    """Rewrite ``x''``/``x'`` to identifiers and ``^`` to ``**``; nothing else changes.

    Returns the rewritten text and, for each of its characters, the 0-based index of the
    character of ``text`` it came from, so that errors point into the user's own text.
    """
    out: list[str] = []
    origin: list[int] = []
    pos = 0
    for match in _PRIME.finditer(text):
        for k in range(pos, match.start()):
            out.append(text[k])
            origin.append(k)
        name, primes = match.group(1), match.group(2)
        suffix = _ACC_SUFFIX if len(primes) == 2 else _VEL_SUFFIX  # one letter a quote
        out.extend(name + suffix)
        origin.extend(match.start(1) + i for i in range(len(name)))
        origin.extend(match.start(2) + i for i in range(len(suffix)))
        pos = match.end()
    for k in range(pos, len(text)):
        out.append(text[k])
        origin.append(k)
    src = "".join(out)
    if "'" in src or '"' in src:
        col = origin[src.find("'") if "'" in src else src.find('"')] + 1
        raise ExpressionError(
            "a quote may only follow a coordinate name (x' is the velocity of x); "
            "strings are not allowed in expressions",
            text,
            col,
        )
    final: list[str] = []
    final_origin: list[int] = []
    for ch, k in zip(src, origin):
        if ch == "^":
            final.append("**")
            final_origin.extend((k, k))
        else:
            final.append(ch)
            final_origin.append(k)
    return "".join(final), final_origin


_NUMBER = r"\d+(?:\.\d*)?(?:[eE][-+]?\d+)?"
_NAME = r"[A-Za-z_]\w*(?:\s*''?)?"
# a number written against a name (2m2, 1.5e-3x, 2pi), and two terms side by side (m g)
_AGAINST = re.compile(rf"(?<![\w.'])({_NUMBER})([A-Za-z]\w*(?:''?)?)")
_SIDE_BY_SIDE = re.compile(rf"(?<![\w.'])({_NAME}|{_NUMBER})[ \t]+({_NAME}|{_NUMBER})")


def _juxtaposed(text: str) -> tuple[str, int] | None:
    """(message, column) for text that Python cannot parse because two factors are
    written without `*` between them, as on paper: ``2m2`` (write ``2*m2``), ``m g``
    (``m*g``); None when the text has no such pair (the syntax error is something
    else). Keywords of the conditions (``and``, ``or``, ``not``) are not factors."""
    m = _AGAINST.search(text)
    if m is not None:
        number, name = m.group(1), m.group(2)
        return (
            f"`{m.group(0)}` is a number written against a name, and lamech multiplies "
            f"only with `*`: write `{number}*{name}`",
            m.start() + 1,
        )
    for m in _SIDE_BY_SIDE.finditer(text):
        left, right = m.group(1), m.group(2)
        words = (left.rstrip("' "), right.rstrip("' "))
        if any(keyword.iskeyword(w) for w in words):
            continue
        return (
            f"`{m.group(0)}` is two terms side by side, and lamech multiplies only with "
            f"`*`: write `{left}*{right}`",
            m.start() + 1,
        )
    return None


def _depth(text: str) -> int:
    depth = best = 0
    for ch in text:
        if ch in "([":
            depth += 1
            best = max(best, depth)
        elif ch in ")]":
            depth -= 1
    return best


def parse(
    text: object,
    names: Mapping[str, sp.Expr],
    what: str = "this expression",
    *,
    hints: Mapping[str, str] | None = None,
) -> sp.Expr:
    """Parse expression ``text`` into SymPy using only ``names``.

    Parameters
    ----------
    text : str or number
        The expression, in the grammar of the module docstring.
    names : mapping
        Every name the expression may use, including ``t``; velocities are keyed
        ``"x'"`` and accelerations ``"x''"``. ``pi`` and the functions are always known.
        A dotted key (``"top.wx"``) is written ``top.wx`` (a body's angular velocity).
    what : str
        How to call the expression's place in error messages ("positions", ...).
    hints : mapping, optional
        Why ``name.anything`` cannot be used here, by the name before the dot (a planar
        body, a point mass): the message for such a dotted name.

    Raises
    ------
    ExpressionError
        For anything outside the grammar, unknown names, oversized text, nesting or
        numbers. Nothing is evaluated.
    """
    if isinstance(text, bool):
        raise ExpressionError(f"expected an expression, got {text!r}", str(text))
    if isinstance(text, int):
        text = str(text)
    elif isinstance(text, float):
        if not math.isfinite(text):
            raise ExpressionError(f"expected a finite number, got {text!r}", str(text))
        text = repr(text)
    if not isinstance(text, str):
        raise ExpressionError(
            f"expected an expression as a string or number, got {type(text).__name__}", str(text)
        )
    if len(text) > MAX_LENGTH:
        raise ExpressionError(
            f"expression too long ({len(text)} characters; at most {MAX_LENGTH})", text[:40] + "..."
        )
    if not text.strip():
        raise ExpressionError("empty expression", text)
    bad = next((c for c in text if not (c.isascii() and (c.isprintable() or c in " \t"))), None)
    if bad is not None:
        raise ExpressionError(
            f"character {bad!r} is not allowed in an expression", text, text.index(bad) + 1
        )
    if "\\" in text or "#" in text or ";" in text or "\n" in text:
        ch = next(c for c in "\\#;\n" if c in text)
        raise ExpressionError(
            f"character {ch!r} is not allowed in an expression", text, text.index(ch) + 1
        )
    src, origin = _lex(text)
    lead = len(src) - len(src.lstrip())
    src = src.strip()

    def column_of(offset: int) -> int:
        """1-based column in the user's text of 0-based ``offset`` in ``src``."""
        index = lead + offset
        if index >= len(origin):
            return max(len(text), 1)
        return origin[max(index, 0)] + 1

    encoded = src.encode("utf-8")

    def node_column(offset: int) -> int:
        """The column of a node's ``col_offset``, which ``ast`` counts in UTF-8 bytes
        (the letters standing for quotes take two)."""
        return column_of(len(encoded[:offset].decode("utf-8", errors="ignore")))

    if _depth(src) > MAX_DEPTH:
        raise ExpressionError(f"expression nested too deeply (more than {MAX_DEPTH} levels)", text)
    try:
        with warnings.catch_warnings():
            # Python warns on stderr about text like '0x1Fin'; the error below says it.
            warnings.simplefilter("ignore")
            tree = ast.parse(src, mode="eval")
    except SyntaxError as exc:
        col = column_of((exc.offset or 1) - 1) if (exc.lineno or 1) == 1 else None
        dotted = re.search(r"\b([A-Za-z_]\w*)\.(?![\w.])", text)  # theta. (Newton's dot)
        hint = _velocity_hint(dotted.group(1) + "_dot", names) if dotted else None
        if hint and dotted is not None:
            message = f"syntax error at `{dotted.group(0)}`: {hint}"
            raise ExpressionError(message, text, col) from None
        juxtaposed = _juxtaposed(text)
        if juxtaposed is not None:
            raise ExpressionError(juxtaposed[0], text, juxtaposed[1]) from None
        raise ExpressionError(f"syntax error: {exc.msg}", text, col) from None
    except (RecursionError, MemoryError, ValueError):
        raise ExpressionError("expression too complex to parse", text) from None
    if _tree_depth(tree) > MAX_DEPTH:
        raise ExpressionError(f"expression nested too deeply (more than {MAX_DEPTH} levels)", text)
    builder = _Builder(text, names, what, src, node_column)
    builder.hints = hints or {}
    try:
        return builder.build(tree)
    except RecursionError:
        raise ExpressionError("expression too complex", text) from None
    except ExpressionError:
        raise
    except _SYMPY_FAILURES as exc:  # SymPy's own failure on some value: still an answer
        raise ExpressionError(
            f"cannot be evaluated ({type(exc).__name__} in SymPy); write it differently", text
        ) from None


def _tree_depth(node: ast.AST) -> int:
    """Nesting depth of the tree; a chain of + - (or of * /) counts as one level."""
    best = 0
    stack = [(node, 1)]
    while stack:
        current, d = stack.pop()
        best = max(best, d)
        if d > MAX_DEPTH + 1:
            return d
        group = _GROUP.get(type(current.op)) if isinstance(current, ast.BinOp) else None
        for child in ast.iter_child_nodes(current):
            same = (
                group is not None
                and isinstance(child, ast.BinOp)
                and _GROUP.get(type(child.op)) == group
            )
            stack.append((child, d if same else d + 1))
    return best
