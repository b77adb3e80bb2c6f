"""Safe expressions: problem-file text to SymPy, and SymPy back to problem-file text.

The grammar (the only thing a problem file may contain in an expression):
numbers, declared names, ``t``, ``x'`` for the velocity of coordinate ``x`` (``x''``
for its acceleration in printed equations), ``+ - * / ^ **``, parentheses, the
functions in :data:`FUNCTIONS` and ``pi``.

User text is never handed to ``eval``, ``sympify`` or ``parse_expr``: Python's own
tokenizer-free ``ast`` parses it (after two purely lexical rewrites, ``'`` suffixes and
``^``), and a whitelist walk builds the SymPy expression node by node. Size, nesting
and exponents are bounded *before* anything is built, so hostile text (``9^9^9^9``,
ten thousand parentheses) fails fast with :class:`ExpressionError`.
"""

from __future__ import annotations

import ast
import math
import re
import warnings
from collections.abc import Mapping

import sympy as sp
from sympy.printing.str import StrPrinter

__all__ = [
    "ExpressionError",
    "FUNCTIONS",
    "parse",
    "to_text",
    "velocity_name",
    "acceleration_name",
    "MAX_LENGTH",
    "MAX_DEPTH",
    "TimeDerivative",
]

MAX_LENGTH = 4000
"""Longest expression text accepted, in characters."""
MAX_DEPTH = 60
"""Deepest nesting (parentheses, operators, calls) accepted."""
MAX_INT_EXPONENT = 64
"""Largest integer exponent |n| in ``x^n`` for a symbolic base."""
MAX_NUMBER_DIGITS = 400
"""Largest number of decimal digits an exact number may reach while parsing."""


class ExpressionError(ValueError):
    """An expression does not follow the grammar; ``message`` says what and how to fix it.

    ``column`` is the 1-based column in the expression text where known.
    """

    def __init__(self, message: str, text: str = "", column: int | None = None):
        super().__init__(message)
        self.message = message
        self.text = text
        self.column = column


def _atan2(y, x):
    return sp.atan2(y, x)


FUNCTIONS: dict[str, object] = {
    "sin": sp.sin,
    "cos": sp.cos,
    "tan": sp.tan,
    "asin": sp.asin,
    "acos": sp.acos,
    "atan": sp.atan,
    "atan2": _atan2,
    "sinh": sp.sinh,
    "cosh": sp.cosh,
    "tanh": sp.tanh,
    "exp": sp.exp,
    "log": sp.log,
    "sqrt": sp.sqrt,
    "abs": sp.Abs,
    "sign": sp.sign,
}
_ARITY = {name: (2 if name == "atan2" else 1) for name in FUNCTIONS}
RESERVED = frozenset(FUNCTIONS) | {"t", "pi"}
_GROUP = {ast.Add: "+", ast.Sub: "+", ast.Mult: "*", ast.Div: "*"}

_DECIMAL = re.compile(r"((?:[0-9]+\.?[0-9]*|\.[0-9]+))(?:[eE]([+-]?[0-9]+))?")
_UNDEFINED = (sp.nan, sp.zoo, sp.oo, -sp.oo)

_VEL_SUFFIX = "__vel"
_ACC_SUFFIX = "__acc"
_PRIME = re.compile(r"([A-Za-z_][A-Za-z_0-9]*)\s*(''?)")


class TimeDerivative(sp.Symbol):
    r"""The symbol of a velocity ``x'`` or an acceleration ``x''``: a plain real Symbol in
    every computation, printed in LaTeX (and so in Jupyter) as ``\dot{x}`` /
    ``\ddot{x}`` instead of SymPy's ``x'``.

    >>> import sympy as sp
    >>> print(sp.latex(TimeDerivative("theta'", real=True) ** 2))
    \dot{\theta}^{2}
    """

    def _latex(self, printer) -> str:
        base = self.name.rstrip("'")
        primes = len(self.name) - len(base)
        inner = printer._print(sp.Symbol(base))
        if primes == 1:
            return rf"\dot{{{inner}}}"
        if primes == 2:
            return rf"\ddot{{{inner}}}"
        return printer._print(sp.Symbol(self.name))


def velocity_name(name: str) -> str:
    """The printed name of coordinate ``name``'s velocity: ``x'``."""
    return name + "'"


def acceleration_name(name: str) -> str:
    """The printed name of coordinate ``name``'s acceleration: ``x''``."""
    return name + "''"


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
        piece = name + (_ACC_SUFFIX if len(primes) == 2 else _VEL_SUFFIX)
        out.extend(piece)
        origin.extend(match.start() + min(i, len(name) - 1) for i in range(len(piece)))
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


def _depth(text: str) -> int:
    depth = best = 0
    for ch in text:
        if ch in "([":
            depth += 1
            best = max(best, depth)
        elif ch in ")]":
            depth -= 1
    return best


def _describe(node: ast.AST) -> str:
    kinds = {
        ast.Attribute: "attribute access (a.b)",
        ast.Lambda: "lambda",
        ast.ListComp: "comprehension",
        ast.GeneratorExp: "comprehension",
        ast.SetComp: "comprehension",
        ast.DictComp: "comprehension",
        ast.Subscript: "indexing (a[b])",
        ast.Compare: "comparison",
        ast.BoolOp: "and/or",
        ast.IfExp: "if/else",
        ast.List: "list",
        ast.Tuple: "tuple (a comma)",
        ast.Dict: "dict",
        ast.Set: "set",
        ast.NamedExpr: "assignment (:=)",
        ast.Starred: "starred argument",
        ast.Await: "await",
        ast.Yield: "yield",
        ast.JoinedStr: "string",
    }
    for kind, label in kinds.items():
        if isinstance(node, kind):
            return label
    if isinstance(node, ast.Constant):
        return f"constant {node.value!r}"
    return type(node).__name__


def _plain(expr: sp.Expr) -> str:
    try:
        return to_text(expr)
    except ValueError:
        return str(expr)


class _Builder:
    """Walk a whitelisted ``ast`` tree and build SymPy, with bounds on every number."""

    def __init__(self, text: str, names: Mapping[str, sp.Expr], what: str, src: str, column_of):
        self.text = text
        self.names = names
        self.what = what
        self.src = src
        self.column_of = column_of

    def fail(self, message: str, node: ast.AST | None = None) -> ExpressionError:
        col = getattr(node, "col_offset", None)
        return ExpressionError(message, self.text, None if col is None else self.column_of(col))

    def build(self, node: ast.AST) -> sp.Expr:
        method = getattr(self, "_" + type(node).__name__, None)
        if method is None:
            raise self.fail(
                f"{_describe(node)} is not allowed in an expression; use numbers, "
                "names, + - * / ^, parentheses and the functions " + ", ".join(sorted(FUNCTIONS)),
                node,
            )
        return method(node)

    def _Expression(self, node: ast.Expression) -> sp.Expr:
        return self.build(node.body)

    def _Constant(self, node: ast.Constant) -> sp.Expr:
        value = node.value
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.fail(f"{_describe(node)} is not a number", node)
        segment = (ast.get_source_segment(self.src, node) or repr(value)).replace("_", "")
        match = _DECIMAL.fullmatch(segment)
        if match is None:
            raise self.fail(
                f"`{segment}` is not a decimal number (write numbers like 3, 0.25 or 1.5e-3)", node
            )
        # Bound the size of the exact number before building it: '1e-999999999' would
        # otherwise ask for a billion-digit integer.
        mantissa, exponent = match.group(1), int(match.group(2) or 0)
        digits = len(mantissa.replace(".", "").lstrip("0")) or 1
        point = mantissa.find(".")
        magnitude = (len(mantissa) - point - 1 if point >= 0 else 0) - exponent
        if digits + abs(magnitude) > MAX_NUMBER_DIGITS:
            raise self.fail(
                f"number `{segment}` is out of range (more than "
                f"{MAX_NUMBER_DIGITS} digits written out)",
                node,
            )
        if isinstance(value, int):
            return sp.Integer(value)
        # Exact decimal: 0.3 means 3/10, so results print as exact rationals.
        return sp.Rational(segment)

    def _Name(self, node: ast.Name) -> sp.Expr:
        ident = node.id
        if ident == "pi":
            return sp.pi
        if ident in FUNCTIONS:
            raise self.fail(f"`{ident}` is a function: write {ident}(...)", node)
        base, kind = ident, ""
        if ident.endswith(_ACC_SUFFIX):
            base, kind = ident[: -len(_ACC_SUFFIX)], "''"
        elif ident.endswith(_VEL_SUFFIX):
            base, kind = ident[: -len(_VEL_SUFFIX)], "'"
        key = base + kind
        if key in self.names:
            return self.names[key]
        if kind and base in self.names:
            allowed = "velocities" if kind == "'" else "accelerations"
            raise self.fail(f"`{key}`: {allowed} are not allowed in {self.what}", node)
        known = sorted(n for n in self.names if not n.endswith("'"))
        raise self.fail(f"unknown name `{key}`; known: " + (", ".join(known) or "(none)"), node)

    def _UnaryOp(self, node: ast.UnaryOp) -> sp.Expr:
        operand = self.build(node.operand)
        if isinstance(node.op, ast.USub):
            return -operand
        if isinstance(node.op, ast.UAdd):
            return operand
        raise self.fail(f"operator {type(node.op).__name__} is not allowed", node)

    def _BinOp(self, node: ast.BinOp) -> sp.Expr:
        op = node.op
        if not isinstance(op, (ast.Add, ast.Sub, ast.Mult, ast.Div, ast.Pow)):
            symbol = {
                ast.Mod: "%",
                ast.FloorDiv: "//",
                ast.BitAnd: "&",
                ast.BitOr: "|",
                ast.LShift: "<<",
                ast.RShift: ">>",
                ast.MatMult: "@",
            }.get(type(op), "?")
            raise self.fail(f"operator `{symbol}` is not allowed; use + - * / ^", node)
        if isinstance(op, ast.Pow):
            out = self._power(self.build(node.left), self.build(node.right), node)
            self._check_size(out, node)
            return out
        # A long sum (a + b - c + ...) is one chain, not deep nesting: walk it iteratively.
        group = _GROUP[type(op)]
        items: list[tuple[ast.BinOp, ast.AST]] = []  # (operator's node, right operand)
        current: ast.AST = node
        while isinstance(current, ast.BinOp) and _GROUP.get(type(current.op)) == group:
            items.append((current, current.right))
            current = current.left
        items.reverse()
        out = self.build(current)  # the leftmost operand
        for owner, operand in items:
            value = self.build(operand)
            kind = type(owner.op)
            if kind is ast.Add:
                out = out + value
            elif kind is ast.Sub:
                out = out - value
            elif kind is ast.Mult:
                out = out * value
            else:
                if value == 0:
                    raise self.fail("division by zero", owner)
                out = out / value
            self._check_size(out, owner)
        return out

    def _power(self, base: sp.Expr, exponent: sp.Expr, node: ast.AST) -> sp.Expr:
        if exponent.is_Number:
            if (
                exponent.is_Integer
                and abs(int(exponent)) > MAX_INT_EXPONENT
                and not (base.is_Number and abs(base) in (0, 1))
            ):
                raise self.fail(
                    f"exponent {exponent} is too large (at most "
                    f"{MAX_INT_EXPONENT} in absolute value)",
                    node,
                )
            if base.is_Number and base != 0:
                digits = (
                    abs(float(exponent)) * abs(math.log10(abs(float(base))))
                    if abs(float(base)) not in (0.0, float("inf"))
                    else 0.0
                )
                if digits > MAX_NUMBER_DIGITS:
                    raise self.fail(
                        f"number too large: the power has more than {MAX_NUMBER_DIGITS} digits",
                        node,
                    )
            if base == 0 and exponent.is_negative:
                raise self.fail("division by zero (0 to a negative power)", node)
        out = sp.Pow(base, exponent)
        if out.has(*_UNDEFINED):
            raise self.fail(
                f"undefined: {_plain(base)}^({_plain(exponent)}) is not a finite "
                "number (0 to a power that may be negative)",
                node,
            )
        return out

    def _check_size(self, out: sp.Expr, node: ast.AST) -> None:
        if out.is_Rational and not out.is_Integer:
            p, q = out.p, out.q
        elif out.is_Integer:
            p, q = int(out), 1
        else:
            return
        if max(abs(p), q).bit_length() > MAX_NUMBER_DIGITS * 3.33:
            raise self.fail(f"number too large (more than {MAX_NUMBER_DIGITS} digits)", node)

    def _Call(self, node: ast.Call) -> sp.Expr:
        if not isinstance(node.func, ast.Name):
            raise self.fail(
                f"only the functions {', '.join(sorted(FUNCTIONS))} may be called", node
            )
        name = node.func.id
        if name not in FUNCTIONS:
            raise self.fail(
                f"unknown function `{name}`; known: " + ", ".join(sorted(FUNCTIONS)), node
            )
        if node.keywords:
            raise self.fail(f"`{name}` takes no keyword arguments", node)
        if len(node.args) != _ARITY[name]:
            raise self.fail(
                f"`{name}` takes {_ARITY[name]} argument"
                f"{'s' if _ARITY[name] > 1 else ''}, got {len(node.args)}",
                node,
            )
        args = [self.build(a) for a in node.args]
        if name == "log" and args[0] == 0:
            raise self.fail("log(0) is undefined", node)
        out = FUNCTIONS[name](*args)  # type: ignore[operator]
        if out.has(*_UNDEFINED):
            raise self.fail(
                f"undefined: {name}({', '.join(_plain(a) for a in args)}) is not a "
                "finite number (a pole, or atan2(0, 0))",
                node,
            )
        return out


def parse(text: object, names: Mapping[str, sp.Expr], what: str = "this expression") -> sp.Expr:
    """Parse expression ``text`` into SymPy using only ``names``.

    Parameters
    ----------
    text : str or number
        The expression, in the grammar of the module docstring.
    names : mapping
        Every name the expression may use, including ``t``; velocities are keyed
        ``"x'"`` and accelerations ``"x''"``. ``pi`` and the functions are always known.
    what : str
        How to call the expression's place in error messages ("positions", ...).

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

    if _depth(src) > MAX_DEPTH:
        raise ExpressionError(f"expression nested too deeply (more than {MAX_DEPTH} levels)", text)
    try:
        with warnings.catch_warnings():
            # Python warns on stderr about text like '0x1Fin'; the error below says it.
            warnings.simplefilter("ignore")
            tree = ast.parse(src, mode="eval")
    except SyntaxError as exc:
        col = column_of((exc.offset or 1) - 1) if (exc.lineno or 1) == 1 else None
        raise ExpressionError(f"syntax error: {exc.msg}", text, col) from None
    except (RecursionError, MemoryError, ValueError):
        raise ExpressionError("expression too complex to parse", text) from None
    if _tree_depth(tree) > MAX_DEPTH:
        raise ExpressionError(f"expression nested too deeply (more than {MAX_DEPTH} levels)", text)
    builder = _Builder(text, names, what, src, column_of)
    try:
        return builder.build(tree)
    except RecursionError:
        raise ExpressionError("expression too complex", text) from None


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

    def _print_Piecewise(self, expr):
        raise ValueError("piecewise result: no closed form in the grammar")


_REWRITES = (
    (sp.sec, lambda x: 1 / sp.cos(x)),
    (sp.csc, lambda x: 1 / sp.sin(x)),
    (sp.cot, lambda x: sp.cos(x) / sp.sin(x)),
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
    expr = grammar_form(sp.sympify(expr))
    return TextPrinter().doprint(expr).replace("**", "^")
