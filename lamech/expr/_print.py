"""The printers: SymPy back to problem-file text (:func:`to_text`, which parses back),
LaTeX with the grammar's names (:func:`latex`), and text safe on a terminal
(:func:`printable`)."""

from __future__ import annotations

import sympy as sp
from sympy.printing.latex import LatexPrinter
from sympy.printing.str import StrPrinter

from ._grammar import (
    FUNCTIONS,
)


def _plain(expr: sp.Expr) -> str:
    try:
        return to_text(expr)
    except ValueError:
        return str(expr)


class TextPrinter(StrPrinter):
    """Print SymPy in the problem-file grammar, so the output parses back.

    Only the grammar's functions appear (``abs``, never ``Abs``; ``1/cos`` for ``sec``);
    floats carry 17 significant digits; rationals stay exact (``4/7``).
    """

    def _print_Abs(self, expr):
        return f"abs({self._print(expr.args[0])})"

    def _print_sign(self, expr):
        return f"sign({self._print(expr.args[0])})"

    def _print_Exp1(self, expr):
        return "exp(1)"

    def _print_Float(self, expr):
        return f"{float(expr):.17g}"

    def _print_Pow(self, expr, rational=False):
        return super()._print_Pow(expr, rational).replace("**", "^")

    def _print_ImaginaryUnit(self, expr):
        raise ValueError("complex result: the expression has no real form")

    def _print_Function(self, expr):
        name = type(expr).__name__
        if name not in FUNCTIONS:
            raise ValueError(f"cannot print function {name} in the problem-file grammar")
        return f"{name}(" + ", ".join(self._print(a) for a in expr.args) + ")"

    def _print_Table(self, expr):
        return expr.label

    def _print_Heaviside(self, expr):
        return f"step({self._print(expr.args[0])})"

    def _print_Min(self, expr):
        return "min(" + ", ".join(self._print(a) for a in expr.args) + ")"

    def _print_Max(self, expr):
        return "max(" + ", ".join(self._print(a) for a in expr.args) + ")"

    def _print_Piecewise(self, expr):
        pairs = list(expr.args)
        if pairs[-1].cond != sp.true:
            raise ValueError("piecewise result without a value otherwise: not in the grammar")
        shown = [f"({self._print(v)}, {self._condition(c)})" for v, c in pairs[:-1]]
        return "piecewise(" + ", ".join([*shown, self._print(pairs[-1].expr)]) + ")"

    def _condition(self, cond) -> str:
        if isinstance(cond, sp.And):
            return " and ".join(f"({self._condition(a)})" for a in cond.args)
        if isinstance(cond, sp.Or):
            return " or ".join(f"({self._condition(a)})" for a in cond.args)
        if isinstance(cond, sp.Not):
            return f"not ({self._condition(cond.args[0])})"
        if isinstance(cond, sp.core.relational.Relational) and cond.rel_op in _RELATIONS:
            return f"{self._print(cond.lhs)} {cond.rel_op} {self._print(cond.rhs)}"
        raise ValueError(f"condition {cond} is not in the grammar")


_RELATIONS = ("<", "<=", ">", ">=")


class _LatexPrinter(LatexPrinter):
    """SymPy's LaTeX with the grammar's names for the inputs: step(u), not SymPy's
    theta(u, 1), which reads as a coordinate theta."""

    def _print_Heaviside(self, expr, exp=None):
        tex = rf"\operatorname{{step}}\left({self._print(expr.args[0])}\right)"
        return tex if exp is None else rf"{tex}^{{{exp}}}"


def _cotangents(expr: sp.Basic) -> sp.Basic:
    """1/tan(x)^n printed as cot(x)^n, as a textbook writes mu >= cot(phi0)/2."""
    if not isinstance(expr, sp.Basic) or not expr.has(sp.tan):
        return expr
    return expr.replace(
        lambda e: e.is_Pow and isinstance(e.base, sp.tan) and e.exp.is_Integer and e.exp < 0,
        lambda e: sp.cot(e.base.args[0]) ** (-e.exp),
    )


def latex(expr, **settings) -> str:
    """LaTeX of ``expr`` (``settings`` as for :func:`sympy.latex`), with the grammar's
    step function printed by name and 1/tan as cot."""
    return _LatexPrinter(settings).doprint(_cotangents(sp.sympify(expr)))


_REWRITES = (
    (sp.sec, lambda x: 1 / sp.cos(x)),
    (sp.csc, lambda x: 1 / sp.sin(x)),
    (sp.cot, lambda x: 1 / sp.tan(x)),
    (sp.asec, lambda x: sp.acos(1 / x)),
    (sp.acsc, lambda x: sp.asin(1 / x)),
    (sp.acot, lambda x: sp.atan(1 / x)),
    (sp.coth, lambda x: sp.cosh(x) / sp.sinh(x)),
    (sp.sech, lambda x: 1 / sp.cosh(x)),
    (sp.csch, lambda x: 1 / sp.sinh(x)),
)


def grammar_form(expr: sp.Expr) -> sp.Expr:
    """Rewrite functions outside the grammar (sec, cot, ...) into grammar functions."""
    if not isinstance(expr, sp.Basic):
        return sp.sympify(expr)
    for func, repl in _REWRITES:
        if expr.has(func):
            expr = expr.replace(func, repl)
    return expr


def to_text(expr: sp.Expr) -> str:
    """Problem-file text for ``expr``: parses back with :func:`parse` to the same value."""
    expr = _cotangents(grammar_form(sp.sympify(expr)))
    return TextPrinter().doprint(expr).replace("**", "^")


_BIDI = frozenset("\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069")


def printable(text: str) -> str:
    r"""``text`` safe to show on a terminal: control characters (tab excepted) and the
    bidirectional overrides written as Python escapes (``\x1b``, ``\u202e``), so a
    title, key or file name cannot move the cursor, clear the screen or reorder a line."""
    if text.isprintable() and not _BIDI.intersection(text):
        return text
    return "".join(
        ch if ch == "\t" or (ch.isprintable() and ch not in _BIDI) else ascii(ch)[1:-1]
        for ch in text
    )
