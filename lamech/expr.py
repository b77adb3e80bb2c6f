"""Safe expressions: problem-file text to SymPy, and SymPy back to problem-file text.

The grammar (the only thing a problem file may contain in an expression):
numbers, declared names, ``t``, ``x'`` for the velocity of coordinate ``x`` (``x''``
for its acceleration in printed equations), ``+ - * / ^ **``, parentheses, the
functions in :data:`FUNCTIONS` and ``pi``; and ``body.wx`` (a dotted name: a body's
angular velocity component, see :func:`parse`).

User text is never handed to ``eval``, ``sympify`` or ``parse_expr``: Python's own
tokenizer-free ``ast`` parses it (after two purely lexical rewrites, ``'`` suffixes and
``^``), and a whitelist walk builds the SymPy expression node by node. Size, nesting
and exponents are bounded *before* anything is built, so hostile text (``9^9^9^9``,
ten thousand parentheses) fails fast with :class:`ExpressionError`. What each node
*builds* is bounded too, since SymPy evaluates as it goes: exact numbers by their
digits (not their magnitude: ``1.0000001^1000000000`` is small but has 7e9 digits),
powers of non-numbers by their exponent after SymPy has combined them (``x^64*x`` is
``x^65``, so what :func:`to_text` prints always parses back), constants by their
magnitude and realness (``exp(exp(20))``, ``asin(2)``), and expressions by the number of
terms they would expand to (``(a + b + c + d + e)^64``).
"""

from __future__ import annotations

import ast
import math
import re
import warnings
from collections.abc import Collection, Mapping

import sympy as sp
from sympy.core.symbol import Str
from sympy.printing.latex import LatexPrinter
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
    "MAX_INT_EXPONENT",
    "MAX_NUMBER_DIGITS",
    "MAX_TERMS",
    "TimeDerivative",
    "printable",
    "not_differentiable",
    "INPUTS",
    "latex",
    "switch_form",
    "tabulated",
    "Table",
    "is_table",
    "table_form",
    "table_knots",
]

MAX_LENGTH = 4000
"""Longest expression text accepted, in characters."""
MAX_DEPTH = 60
"""Deepest nesting (parentheses, operators, calls) accepted."""
MAX_INT_EXPONENT = 64
"""Largest numeric exponent |n| in ``x^n`` for a base that is not a number, after SymPy
has combined powers (``x^64*x`` is ``x^65``); integer or not (``x^100000.5``)."""
MAX_NUMBER_DIGITS = 400
"""Largest number of decimal digits an exact number may reach while parsing, and the
largest magnitude of a constant, 10^400 (``exp(1000)`` is over it)."""
MAX_TERMS = 10_000
"""Most terms an expression may expand to: ``(a + b + c)^64`` (2145) is fine,
``(a + b + c + d + e)^64`` (814,385) is refused before anything expands it."""


class ExpressionError(ValueError):
    """An expression does not follow the grammar; ``message`` says what and how to fix it.

    ``column`` is the 1-based column in the expression text where known.
    """

    def __init__(self, message: str, text: str = "", column: int | None = None):
        super().__init__(message)
        self.message = message
        self.text = text
        self.column = column


_VELOCITY_SPELLINGS = (
    re.compile(r"^(?P<c>.+?)_?(?:dot|d|t|prime)$"),  # theta_dot, thetadot, theta_d, theta_t
    re.compile(r"^d_?(?P<c>.+?)(?:_?dt)?$"),  # dtheta, d_theta, dthetadt
)


def _velocity_hint(key: str, names) -> str | None:
    """For a name that spells a coordinate's velocity another way (``theta_dot``,
    ``dtheta``, ``thetadot``; ``theta.`` is asked as ``theta_dot``): how lamech writes
    it, where that coordinate's velocity is a name here (else None: a parameter's
    ``dt`` is not a velocity)."""
    for pattern in _VELOCITY_SPELLINGS:
        match = pattern.match(key)
        if match is None:
            continue
        base = match.group("c")
        if base + "'" in names:
            return f"a velocity is written with a prime: `{base}'` (the rate of {base})"
    return None


def _atan2(y, x):
    return sp.atan2(y, x)


def _step(u):
    """The unit step: 1 for u >= 0, else 0 (SymPy's Heaviside with H(0) = 1)."""
    return sp.Heaviside(u, 1)


def _clip(x, lo, hi):
    """x held within [lo, hi]."""
    return sp.Min(sp.Max(x, lo), hi)


FUNCTIONS: dict[str, object] = {
    "sin": sp.sin,
    "cos": sp.cos,
    "tan": sp.tan,
    "cot": lambda x: 1 / sp.tan(x),  # read as 1/tan: the algebra sees tan alone
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
    "step": _step,
    "min": sp.Min,
    "max": sp.Max,
    "clip": _clip,
    "piecewise": sp.Piecewise,
}
_ARITY: dict[str, int | None] = {
    name: {"atan2": 2, "clip": 3, "min": None, "max": None, "piecewise": None}.get(name, 1)
    for name in FUNCTIONS
}
"""How many arguments each function takes (None: two or more)."""
MAX_MINMAX_ARGS = 64
"""The most arguments of one ``min`` or ``max``: SymPy compares every pair of them on
building, a cost that grows faster than the square of their count."""
INPUTS = ("step", "min", "max", "clip", "piecewise")
"""The functions with a jump or a kink: inputs that switch (a torque until t = 2, a
one-sided spring). :func:`lamech.simulate` locates where they switch (an event), never
steps over it."""
RESERVED = frozenset(FUNCTIONS) | {"t", "pi"}
ANGULAR_VELOCITY = ("wx", "wy", "wz", "w1", "w2", "w3")
"""The components a dotted name ``body.wx`` may ask for: a body's angular velocity in
the world axes (x, y, z) and in its own (1, 2, 3)."""
_GROUP = {ast.Add: "+", ast.Sub: "+", ast.Mult: "*", ast.Div: "*"}

_DECIMAL = re.compile(r"((?:[0-9]+\.?[0-9]*|\.[0-9]+))(?:[eE]([+-]?[0-9]+))?")
_UNDEFINED = (sp.nan, sp.zoo, sp.oo, -sp.oo)
# what SymPy raises when a value defeats it (asin(sin(1e300)) raises AttributeError from
# its cache): the parser answers with an ExpressionError instead
_MAX_EXP = MAX_NUMBER_DIGITS * math.log(10)  # exp(921.03) is 10^400
_SYMPY_FAILURES = (ArithmeticError, TypeError, ValueError, AttributeError, NotImplementedError)

# The parser's own spelling of x' and x'' as Python identifiers: a letter outside ASCII,
# which expression text may not contain, so that no user name can mean a velocity.
_VEL_SUFFIX = "\u02b9"  # MODIFIER LETTER PRIME
_ACC_SUFFIX = "\u02b9\u02b9"
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
        self.hints: Mapping[str, str] = {}
        self.what = what
        self.src = src
        self.src_bytes = src.encode("utf-8")
        self.column_of = column_of
        self.terms_cache: dict[sp.Expr, int] = {}

    def fail(self, message: str, node: ast.AST | None = None) -> ExpressionError:
        col = getattr(node, "col_offset", None)
        return ExpressionError(message, self.text, None if col is None else self.column_of(col))

    def cannot(self, node: ast.AST, exc: BaseException) -> ExpressionError:
        """SymPy failed on a value it was given (its own errors, not the user's)."""
        shown = _short(self.segment(node) or self.text)
        return self.fail(f"`{shown}` cannot be evaluated ({type(exc).__name__} in SymPy)", node)

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
        # the source is one line: the node's bytes, without ast.get_source_segment's
        # splitting of the whole text for each number
        written = self.src_bytes[node.col_offset : node.end_col_offset or 0].decode("utf-8")
        segment = (written or repr(value)).replace("_", "")
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
        if kind and base == "t":
            raise self.fail(
                f"`{key}`: t is time, not a coordinate; only coordinates have velocities (x')",
                node,
            )
        if kind and base in self.names:
            velocities_here = any(n.endswith("'") for n in self.names)
            if velocities_here and kind == "'":
                raise self.fail(
                    f"`{key}`: {base} is not a coordinate; only coordinates have velocities (x')",
                    node,
                )
            allowed = "velocities" if kind == "'" else "accelerations"
            raise self.fail(f"`{key}`: {allowed} are not allowed in {self.what}", node)
        known = sorted(n for n in self.names if not n.endswith("'") and "." not in n)
        hint = _velocity_hint(key, self.names)
        raise self.fail(
            f"unknown name `{key}`; " + (hint or "known: " + (", ".join(known) or "(none)")),
            node,
        )

    def _Attribute(self, node: ast.Attribute) -> sp.Expr:
        """``body.wx``: a dotted name, looked up whole in ``names`` (a body's angular
        velocity component); ``hints`` says why a body's have none here."""
        body = node.value.id if isinstance(node.value, ast.Name) else None
        part = node.attr.removesuffix(_VEL_SUFFIX)
        spinning = sorted({n.partition(".")[0] for n in self.names if "." in n})
        if body is not None and body not in spinning:
            hint = _velocity_hint(f"{body}_{part}", self.names)
            if hint:
                raise self.fail(f"`{body}.{part}`: {hint}", node)
        if body is None or part not in ANGULAR_VELOCITY:
            if body in spinning:
                raise self.fail(
                    f"`{body}.{part}`: unknown component `{part}`; {body} has "
                    + ", ".join(sorted(ANGULAR_VELOCITY)),
                    node,
                )
            raise self.fail(
                "attribute access (a.b) is not allowed in an expression; the only dotted "
                "names are a body's angular velocity components, body."
                + ", body.".join(ANGULAR_VELOCITY),
                node,
            )
        key = f"{body}.{part}"
        if node.attr != part:
            raise self.fail(
                f"`{key}'`: the rates of angular velocities are not allowed in {self.what}", node
            )
        if key in self.names:
            return self.names[key]
        if body in self.hints:
            raise self.fail(f"`{key}`: {self.hints[body]}", node)
        raise self.fail(
            f"`{key}`: no body named `{body}` turns in space here; bodies with an angular "
            "velocity: " + (", ".join(spinning) or "(none)"),
            node,
        )

    def _UnaryOp(self, node: ast.UnaryOp) -> sp.Expr:
        operand = self.build(node.operand)
        if isinstance(node.op, ast.USub):
            out = -operand
            self._check_built(out, node, (operand,))
            return out
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
            base, exponent = self.build(node.left), self.build(node.right)
            out = self._power(base, exponent, node)
            self._check_built(out, node, (base, exponent))
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
            left = out
            kind = type(owner.op)
            if kind is ast.Add:
                out = out + value
            elif kind is ast.Sub:
                out = out - value
            elif kind is ast.Mult:
                self._combined_powers(out, value, 1, owner)
                out = out * value
            else:
                if value == 0:
                    raise self.fail("division by zero", owner)
                self._nonzero_divisor(value, operand)
                self._combined_powers(out, value, -1, owner)
                out = out / value
            self._check_built(out, owner, (left, value))
        return out

    def _power(self, base: sp.Expr, exponent: sp.Expr, node: ast.AST) -> sp.Expr:
        if exponent.is_Number:
            self._numbers_to_power(base, exponent, node)
            if base == 0 and exponent.is_negative:
                raise self.fail("division by zero (0 to a negative power)", node)
            if exponent.is_negative:
                self._nonzero_divisor(base, node.left if isinstance(node, ast.BinOp) else node)
        if base == sp.E:
            self._exponential(exponent, node)
        try:
            out = sp.Pow(base, exponent)
        except _SYMPY_FAILURES as exc:
            raise self.cannot(node, exc) from None
        if out.has(*_UNDEFINED):
            raise self.fail(
                f"undefined: {_plain(base)}^({_plain(exponent)}) is not a finite "
                "number (0 to a power that may be negative)",
                node,
            )
        return out

    def _exact_power_size(self, base: sp.Rational, exponent: sp.Expr, node: ast.AST) -> None:
        """Refuse ``p/q`` to the power ``e`` when SymPy would work with exact numbers of
        more than MAX_NUMBER_DIGITS digits to build it: |e| log10(max(|p|, q)) for the
        result, whatever its magnitude (``1.0000001^1000000000`` is about 1e43 but has
        7e9 digits), and, for e = a/b not whole, b log10(...) more for the root it takes
        (``251352^3.14159`` would factor a 460,000-digit integer)."""
        whole, root = _power_digits(base, exponent)
        if max(whole, root) <= MAX_NUMBER_DIGITS:
            return
        shown = _short(self.segment(node) or f"({_plain(base)})^({_plain(exponent)})")
        if whole > MAX_NUMBER_DIGITS:
            raise self.fail(
                f"number too large: `{shown}` has more than {MAX_NUMBER_DIGITS} digits as "
                f"the exact number lamech keeps ({_short(_plain(base), 30)} to the power "
                f"{_short(_plain(exponent), 30)}); write a smaller power",
                node,
            )
        raise self.fail(
            f"number too large: `{shown}` is an exact number to the power "
            f"{_short(_plain(exponent), 30)}, whose root SymPy takes on integers of more than "
            f"{MAX_NUMBER_DIGITS} digits; write the exponent as a fraction with a small "
            "denominator (like 3/2)",
            node,
        )

    def _numbers_to_power(self, base: sp.Expr, exponent: sp.Expr, node: ast.AST) -> None:
        """Before base^exponent (exponent a number): SymPy takes the power of each
        factor of a product when it may, and (b^e1)^e2 is b^(e1 e2) for it: bound each
        exact number it would make."""
        for factor in sp.Mul.make_args(base):
            if factor.is_Rational:
                self._exact_power_size(factor, exponent, node)
            elif factor.is_Pow and factor.args[0].is_Rational and factor.args[1].is_Rational:
                self._exact_power_size(factor.args[0], factor.args[1] * exponent, node)

    def _exponential(self, arg: sp.Expr, node: ast.AST) -> None:
        """Before exp(arg): SymPy splits a sum and makes exp(c log(b)) the exact b^c
        (exp(-10^300 log(10)) would be 10^(-10^300) written out), so each constant term
        of arg must keep exp within 10^-400 .. 10^400."""
        # exp() also combines c log(b) into log(b^c) anywhere inside its argument
        for sub in sp.preorder_traversal(arg):
            if sub.is_Mul:
                coeff, rest = sub.as_coeff_Mul()
                for f in sp.Mul.make_args(rest):
                    if isinstance(f, sp.log) and f.args[0].is_number and coeff.is_Rational:
                        self._numbers_to_power(f.args[0], coeff, node)
        for term in sp.Add.make_args(arg):
            if not term.is_number or term.is_zero:
                continue
            try:
                power = float(sp.re(term).evalf(15))
            except _SYMPY_FAILURES:
                power = math.inf
            shown = _short(self.segment(node) or f"exp({_plain(arg)})")
            if power > _MAX_EXP:
                raise self.fail(
                    f"`{shown}` is too large (about 10^{_count(power / math.log(10))}; a "
                    f"constant may be at most 10^{MAX_NUMBER_DIGITS})",
                    node,
                )
            if power < -_MAX_EXP and term.has(sp.log):
                raise self.fail(
                    f"`{shown}` is too small to keep exact (SymPy writes exp(c log(b)) as "
                    f"b^c, here more than {MAX_NUMBER_DIGITS} digits)",
                    node,
                )

    def _combined_powers(self, left: sp.Expr, right: sp.Expr, sign: int, node: ast.AST) -> None:
        """Before ``left * right**sign``: SymPy merges powers of numbers (2^(1/7)*2^(1/11)
        is 2^(18/77), 2^(1/3)*3^(1/3) is 6^(1/3)), and the merged one's exact root must
        stay within bounds too (12^(1/7)*12^(1/11)*12^(1/13)*... would not)."""
        ours, theirs = _numeric_powers(left), _numeric_powers(right)
        if not ours or not theirs:
            return
        merged = dict(ours)
        for b, e in theirs.items():
            merged[b] = merged.get(b, sp.Integer(0)) + sign * e
        by_exponent: dict[sp.Rational, float] = {}
        for b, e in merged.items():
            if e.is_Integer:
                continue
            self._exact_power_size(b, e, node)
            by_exponent[e] = by_exponent.get(e, 0.0) + math.log10(max(abs(b.p), b.q))
        for e, digits in by_exponent.items():
            if digits * (abs(e) + e.q) > MAX_NUMBER_DIGITS:
                raise self.fail(
                    f"number too large: the powers of numbers in `{_short(self.segment(node))}` "
                    f"combine into one whose exact root SymPy takes on integers of more than "
                    f"{MAX_NUMBER_DIGITS} digits; write exponents with small denominators",
                    node,
                )

    # ----- bounds on what was built ---------------------------------------------------
    def segment(self, node: ast.AST) -> str:
        """The user's own text of ``node`` (before the ``'`` and ``^`` rewrites)."""
        start, end = getattr(node, "col_offset", None), getattr(node, "end_col_offset", None)
        if start is None or end is None or end <= start:
            return ""
        return self.text[self.column_of(start) - 1 : self.column_of(end - 1)].strip()

    def _nonzero_divisor(self, value: sp.Expr, node: ast.AST) -> None:
        """Refuse a divisor that is zero whatever its names' values
        (``1/(sin(x)^2 + cos(x)^2 - 1)``): the quotient is undefined everywhere."""
        if identically_zero(value):
            shown = self.segment(node) or _plain(value)
            raise self.fail(
                f"division by zero: `{_short(shown)}` is 0 whatever the values of "
                f"{', '.join(sorted(map(str, value.free_symbols)))} (checked at "
                f"{ZERO_TEST_POINTS} random values, to 30 digits), so the quotient is "
                "undefined everywhere",
                node,
            )

    def _check_built(self, out: sp.Expr, node: ast.AST, operands: tuple = ()) -> None:
        """Bound what SymPy made of an operation on ``operands``: exact numbers by their
        digits, exponents after combining, new constants by magnitude and realness, and
        the number of terms the result would expand to."""
        self._check_size(out, node)
        self._check_exponents(out, node, operands)
        parts = set(_factors(out))
        old: set[sp.Expr] = set()
        for operand in operands:
            old.update(_factors(operand))
        for part in parts - old:
            # a sum of checked constants is no larger than its terms and real like them
            if part.is_number and not (part.is_Rational or part.is_NumberSymbol or part.is_Add):
                self._check_constant(part, node)
        terms = self._terms(out)
        if terms > MAX_TERMS:
            shown = self.segment(node) or _plain(out)
            raise self.fail(
                f"`{_short(shown)}` would expand to more than {MAX_TERMS} terms (lamech "
                "expands while it derives the equations); write a smaller power or fewer "
                "terms",
                node,
            )

    def _check_size(self, out: sp.Expr, node: ast.AST) -> None:
        """Every exact number at the top of ``out`` (a coefficient of a product, of each
        term of a sum) has at most MAX_NUMBER_DIGITS digits."""
        terms = sp.Add.make_args(out) if out.is_Add else (out,)
        for term in terms:
            coeff = term.as_coeff_Mul()[0] if term.is_Mul else term
            if not coeff.is_Rational:
                continue
            if max(abs(coeff.p), coeff.q).bit_length() > MAX_NUMBER_DIGITS * 3.33:
                raise self.fail(f"number too large (more than {MAX_NUMBER_DIGITS} digits)", node)

    def _check_exponents(self, out: sp.Expr, node: ast.AST, operands: tuple) -> None:
        """The cap on exponents, applied to the powers SymPy has just made: the one
        printed is the one checked, so what lamech prints parses back."""
        for factor in _factors(out):
            if not factor.is_Pow:
                continue
            base, exponent = factor.args
            if not exponent.is_Number or base.is_Number or abs(exponent) <= MAX_INT_EXPONENT:
                continue
            written = self.segment(node)
            printed = _plain(factor)
            same = not written or tuple(factor.args) == tuple(operands)
            raise self.fail(
                f"exponent {_plain(exponent)} is too large (at most {MAX_INT_EXPONENT} in "
                "absolute value"
                + (
                    ")"
                    if same
                    else f", after combining powers: {_short(written)} is {_short(printed)})"
                ),
                node,
            )

    def _check_constant(self, value: sp.Expr, node: ast.AST, what: str = "") -> None:
        """A constant (no names in it) is a real number of magnitude at most
        10^MAX_NUMBER_DIGITS: ``exp(exp(20))`` would make later steps (``sin`` of it,
        floats) hang or overflow, ``asin(2)`` is complex."""
        shown = _short(what or self.segment(node) or _plain(value))
        try:
            number = value.evalf(15)
            re_part, im_part = number.as_real_imag()
        except (ArithmeticError, ValueError, TypeError, RecursionError, MemoryError):
            raise self.fail(f"`{shown}` cannot be evaluated as a number", node) from None
        if not (re_part.is_Float or re_part.is_zero) or not (im_part.is_Float or im_part.is_zero):
            return  # SymPy could not put a number on it; nothing was built either
        size = max(_magnitude(re_part), _magnitude(im_part))
        if size > MAX_NUMBER_DIGITS:
            raise self.fail(
                f"`{shown}` is too large (about 10^{_count(size)}; a constant may be at "
                f"most 10^{MAX_NUMBER_DIGITS})",
                node,
            )
        if value.is_extended_real is False or (
            value.is_extended_real is None
            and not im_part.is_zero
            and abs(float(im_part)) > 1e-10 * max(1.0, abs(float(re_part)))
        ):
            raise self.fail(
                f"`{shown}` is not a real number (it is {_plain_complex(number)}); "
                "expressions must be real",
                node,
            )

    def _terms(self, e: sp.Expr) -> int:
        """An upper bound on the number of terms of ``sympy.expand(e)`` (capped just
        above MAX_TERMS, so that the numbers stay small); functions count one each."""
        known = self.terms_cache.get(e)
        if known is not None:
            return known
        if e.is_Add:
            n = sum(self._terms(a) for a in e.args)
        elif e.is_Mul:
            n = 1
            for a in e.args:
                n = min(n * self._terms(a), MAX_TERMS + 1)
        elif e.is_Pow:
            n = self._power_terms(e.args[0], e.args[1])
        else:
            n = 1
        n = min(n, MAX_TERMS + 1)
        self.terms_cache[e] = n
        return n

    def _power_terms(self, base: sp.Expr, exponent: sp.Expr) -> int:
        if not exponent.is_Rational or base.is_Number:
            return 1
        k = abs(exponent.p) // exponent.q  # expand keeps the fractional part whole
        if k <= 1:
            return self._terms(base) if k == 1 else 1
        if base.is_Mul:
            n = 1
            for f in base.args:
                n = min(n * self._power_terms(f, exponent), MAX_TERMS + 1)
            return n
        if base.is_Pow and base.args[1].is_Rational:
            return self._power_terms(base.args[0], base.args[1] * k)
        t = self._terms(base)
        if t <= 1:
            return 1
        # monomials of degree k in t terms (a multinomial): C(k + t - 1, t - 1)
        return min(math.comb(k + t - 1, t - 1), MAX_TERMS + 1) if k <= 10**4 else MAX_TERMS + 1

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
        arity = _ARITY[name]
        if arity is None and len(node.args) < 2:
            raise self.fail(f"`{name}` takes two or more arguments, got {len(node.args)}", node)
        if arity is not None and len(node.args) != arity:
            raise self.fail(
                f"`{name}` takes {arity} argument{'s' if arity > 1 else ''}, got {len(node.args)}",
                node,
            )
        if name in ("min", "max") and len(node.args) > MAX_MINMAX_ARGS:
            raise self.fail(
                f"`{name}` of {len(node.args)} arguments: at most {MAX_MINMAX_ARGS} (SymPy "
                "compares every pair of them); give fewer, or tabulate the input",
                node,
            )
        if name == "piecewise":
            return self._piecewise(node)
        args = [self.build(a) for a in node.args]
        if name == "clip" and (args[1] - args[2]).is_positive:
            raise self.fail(
                f"clip(x, lo, hi) needs lo <= hi; got lo = {_plain(args[1])} > hi = "
                f"{_plain(args[2])}: swap them",
                node,
            )
        if name == "log" and args[0] == 0:
            raise self.fail("log(0) is undefined", node)
        for arg, arg_node in zip(args, node.args):
            if arg.is_number and not arg.is_Rational and not arg.is_NumberSymbol:
                self._check_constant(arg, arg_node)
        if name == "exp":
            self._exponential(args[0], node)
        try:
            out = FUNCTIONS[name](*args)  # type: ignore[operator]
        except _SYMPY_FAILURES as exc:
            raise self.cannot(node, exc) from None
        if out.has(*_UNDEFINED):
            raise self.fail(
                f"undefined: {name}({', '.join(_plain(a) for a in args)}) is not a "
                "finite number (a pole, or atan2(0, 0))",
                node,
            )
        self._check_built(out, node, tuple(args))
        return out

    # ----- inputs: piecewise and its conditions ------------------------------------------
    def _piecewise(self, node: ast.Call) -> sp.Expr:
        """``piecewise((v1, c1), (v2, c2), ..., otherwise)``: v1 where c1 holds, else v2
        where c2 holds, ..., else ``otherwise``."""
        *pairs, last = node.args
        usage = "write piecewise((value, condition), ..., value otherwise)"
        if isinstance(last, ast.Tuple):
            raise self.fail(f"piecewise: the last argument is the value otherwise; {usage}", last)
        cases = []
        for pair in pairs:
            if not isinstance(pair, ast.Tuple) or len(pair.elts) != 2:
                raise self.fail(
                    f"piecewise: `{_short(self.segment(pair))}` is not a (value, condition) "
                    f"pair; {usage}",
                    pair,
                )
            cases.append((self.build(pair.elts[0]), self._condition(pair.elts[1])))
        cases.append((self.build(last), sp.true))
        try:
            out = sp.Piecewise(*cases)
        except _SYMPY_FAILURES as exc:
            raise self.cannot(node, exc) from None
        self._check_built(out, node, tuple(v for v, _ in cases))
        return out

    def _condition(self, node: ast.AST):
        """A condition of piecewise: comparisons (``t < 2``, ``0 <= x < 1``) joined by
        ``and``, ``or`` and ``not``."""
        if isinstance(node, ast.Compare):
            ops = {ast.Lt: sp.Lt, ast.LtE: sp.Le, ast.Gt: sp.Gt, ast.GtE: sp.Ge}
            terms = [self.build(node.left)] + [self.build(c) for c in node.comparators]
            parts = []
            for op, a, b in zip(node.ops, terms, terms[1:]):
                if type(op) not in ops:
                    raise self.fail(
                        "piecewise conditions compare with < <= > >= only (an equality "
                        "holds at single points: no force can act there alone)",
                        node,
                    )
                for side in (a, b):
                    if side.is_number and not side.is_extended_real:
                        raise self.fail(
                            f"`{_plain(side)}` is not real: it cannot be compared", node
                        )
                parts.append(ops[type(op)](a, b))
            return sp.And(*parts)
        if isinstance(node, ast.BoolOp):
            join = sp.And if isinstance(node.op, ast.And) else sp.Or
            return join(*(self._condition(v) for v in node.values))
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.Not):
            return sp.Not(self._condition(node.operand))
        raise self.fail(
            f"piecewise: `{_short(self.segment(node))}` is not a condition (write a "
            "comparison such as t < 2 or 0 <= x < 1, joined by and/or)",
            node,
        )

    def _Compare(self, node: ast.Compare) -> sp.Expr:
        raise self.fail(
            "a comparison is not allowed here: it is a condition, only inside "
            "piecewise((value, condition), ..., value otherwise); for a switch write "
            "step(t - 2)",
            node,
        )

    def _BoolOp(self, node: ast.BoolOp) -> sp.Expr:
        raise self.fail(
            "and/or are not allowed here: they join conditions, only inside piecewise(...)",
            node,
        )


ZERO_TEST_POINTS = 4
"""The seeded random points at which :func:`identically_zero` evaluates an expression."""


def identically_zero(e: sp.Expr) -> bool:
    """Whether ``e``, an expression of names, is zero at each of :data:`ZERO_TEST_POINTS`
    seeded random values of them (each in [0.3, 2] with the sign its symbol allows),
    evaluated to 30 digits: the zero test by evaluation of the design notes, for a
    divisor. An analytic expression zero at random points is zero everywhere; one with
    a switch (step, min, max, clip, piecewise, a table) may be zero on a region only and
    is never called zero here, nor one that is not a finite number at a point."""
    import random

    names = sorted(e.free_symbols, key=str)
    if not names or e.has(sp.Piecewise, sp.Min, sp.Max, sp.Heaviside, Table):
        return False
    rng = random.Random(28)
    for _ in range(ZERO_TEST_POINTS):
        env = {}
        for s in names:
            x = sp.Rational(rng.randint(300, 2000), 1000)
            negative = s.is_nonpositive or (not s.is_nonnegative and rng.random() < 0.5)
            env[s] = -x if negative else x
        try:
            value = complex(e.evalf(30, subs=env))
            terms = e.args if e.is_Add else (e,)
            scale = max(abs(complex(a.evalf(30, subs=env))) for a in terms)
        except _SYMPY_FAILURES:
            return False
        if not (math.isfinite(abs(value)) and math.isfinite(scale)):
            return False
        if abs(value) > 1e-20 * max(1.0, scale):
            return False
    return True


def _power_digits(base: sp.Rational, exponent: sp.Expr) -> tuple[float, float]:
    """(digits of the exact base^exponent, digits of the integer whose root SymPy takes
    for it): |e| log10(s) and, for e = a/b not whole, (|e| + b) log10(s), where s is the
    larger of the base's numerator and denominator."""
    size = max(abs(base.p), base.q)
    if size <= 1:
        return 0.0, 0.0  # 0, 1, -1: any power is 0, 1 or -1 (or undefined, reported later)
    if not exponent.is_Rational:
        return math.inf, math.inf
    whole = abs(exponent.p) // exponent.q
    work = whole + (exponent.q if exponent.q > 1 else 0)
    log = math.log10(size)
    return (whole * log if whole < 10**6 else math.inf, work * log if work < 10**6 else math.inf)


def _numeric_powers(e: sp.Expr) -> dict:
    """{b: x} for the factors b^x of ``e`` with b and x rational numbers."""
    return {
        f.args[0]: f.args[1]
        for f in sp.Mul.make_args(e)
        if f.is_Pow and f.args[0].is_Rational and f.args[1].is_Rational
    }


def _factors(e: sp.Expr) -> tuple:
    """The factors of ``e`` at its top (``e`` itself unless it is a product)."""
    return sp.Mul.make_args(e)


def _magnitude(x: sp.Expr) -> float:
    """log10 |x| of a SymPy Float (any exponent: inf past floats), or -inf for 0."""
    if x.is_zero:
        return -math.inf
    _sign, _man, exp, bits = x._mpf_
    return (exp + bits) * math.log10(2) if abs(exp + bits) < 10**300 else math.inf


def _count(x: float) -> str:
    """A decimal exponent for a message: 9566, or (2.1e+08)."""
    if not math.isfinite(x):
        return "(10^300) at least"
    return f"{x:.0f}" if x < 1e6 else f"({x:.2g})"


def _short(text: str, width: int = 60) -> str:
    return text if len(text) <= width else text[: width - 3] + "..."


def _plain_complex(number: sp.Expr) -> str:
    re_part, im_part = number.as_real_imag()
    sign = "-" if im_part < 0 else "+"
    return f"{float(re_part):.6g} {sign} {abs(float(im_part)):.6g} i"


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


def not_differentiable(
    expr: sp.Expr,
    once: Collection[sp.Symbol],
    twice: Collection[tuple[Collection[sp.Symbol], Collection[sp.Symbol]]] = (),
) -> str | None:
    """Why ``expr`` has no derivative in the grammar by a symbol of ``once``, or by a
    pair (a, b) with a, b from one of the pairs of sets ``twice``; None when it has.

    ``abs``, ``min``, ``max`` and ``clip`` are the grammar's functions with a kink,
    ``sign``, ``step`` and ``piecewise`` those with a jump: the derivative of a jump is
    a delta function (an impulse), and so is the second derivative of a kink; and
    ``abs`` or ``sign`` of a u that may be complex has no real derivative. Only these
    functions' own derivatives are taken (a product's others are no worse), so the
    check is cheap. A piecewise counts as jumping in the names of its conditions (its
    values may be continuous there, but that is not checked: write such a function with
    min, max or clip).
    """
    once = set(once)
    kinds = (sp.Abs, sp.sign, sp.Heaviside, sp.Min, sp.Max, sp.Piecewise)
    found = expr.atoms(*kinds, Table)
    for f in sorted(found, key=sp.default_sort_key):
        free = _switch_symbols(f)
        orders = {(x,) for x in free & once}
        for first, second in twice:
            orders |= {
                tuple(sorted((a, b), key=str))
                for a in free & set(first)
                for b in free & set(second)
            }
        for wrt in sorted(orders, key=lambda w: (len(w), [str(x) for x in w])):
            if not isinstance(f, (sp.Piecewise, Table)) and _has_real_derivative(f, wrt):
                continue
            return _kink_message(f)
    return None


def _switch_symbols(f: sp.Expr) -> set:
    """The names in which ``f`` (one of the kinked or jumping functions) switches."""
    if isinstance(f, sp.Piecewise):
        return set().union(*(c.free_symbols for _, c in f.args))
    if isinstance(f, (sp.Min, sp.Max, Table)):
        return f.free_symbols
    return f.args[0].free_symbols


def _kink_message(f: sp.Expr) -> str:
    if is_table(f):
        return (
            f"`{f.label}` is a table, interpolated linearly: its rate jumps at every row, "
            "so it cannot be differentiated in t; use it where lamech does not "
            "differentiate it in time (a force in [forces] or [[loads]], or V)"
        )
    text = _plain(f)
    if isinstance(f, (sp.Abs, sp.sign)) and not f.args[0].is_extended_real:
        u = _plain(f.args[0])
        return (
            f"`{text}`: {u} may be complex, and then {text} has no real "
            "derivative; take abs or sign of a real expression"
        )
    if isinstance(f, (sp.Abs, sp.Min, sp.Max)):
        where = (
            f"at {_plain(f.args[0])} = 0" if isinstance(f, sp.Abs) else "where its arguments meet"
        )
        smooth = (
            f"sqrt({_plain(f.args[0])}^2 + eps^2)"
            if isinstance(f, sp.Abs)
            else "(a + b + sqrt((a - b)^2 + eps^2))/2 for max(a, b)"
        )
        return (
            f"`{text}` has a kink {where}, where its second derivative is a delta function "
            f"(an impulse) that the equations of motion cannot carry; write a smooth form "
            f"such as {smooth} with a small parameter eps"
        )
    if isinstance(f, sp.Piecewise):
        where, smooth = "where its conditions change", "(1 + tanh(u/eps))/2 for step(u)"
    else:
        u = _plain(f.args[0])
        where = f"at {u} = 0"
        over = f"{u}/eps" if f.args[0].is_Atom else f"({u})/eps"
        smooth = f"tanh({over})" if isinstance(f, sp.sign) else f"(1 + tanh({over}))/2"
    return (
        f"`{text}` jumps {where}, where its derivative is a delta function (an impulse) "
        f"that the equations of motion cannot carry; switch a force there instead "
        f"([forces], [[loads]]), or write a smooth form such as {smooth} with a small "
        "parameter eps"
    )


class Table(sp.Function):
    """``Table(t, times, values, name)``: an input tabulated at ``times`` (strictly
    increasing, two or more) with ``values``, interpolated linearly between them and
    held at the first and last value outside; made by :func:`tabulated`. It prints as
    its name, evaluates at a number (``subs(t, 0.5)``), and pickles (a sweep's workers
    get it). :func:`table_form` writes it with steps (a switch at every row, where its
    slope changes): that is how the simulator evaluates it, locating each corner like
    any other switch."""

    nargs = 4

    @classmethod
    def eval(cls, t, times, values, name):
        if t.is_Number:
            return sp.Float(_interpolate(t, times, values))
        return None

    def _eval_evalf(self, prec):
        t = self.args[0].evalf(prec)
        return sp.Float(_interpolate(t, *self.args[1:3]), prec) if t.is_Number else None

    @property
    def label(self) -> str:
        return str(self.args[3])

    def _sympystr(self, printer) -> str:
        return self.label

    def _latex(self, printer) -> str:
        return rf"\operatorname{{{self.label}}}\left({printer._print(self.args[0])}\right)"

    def _eval_derivative(self, s):
        if s in self.args[0].free_symbols:
            return sp.Derivative(self, s, evaluate=False)
        return sp.Integer(0)


def _interpolate(t, times, values) -> float:
    import bisect

    ts, vs = [float(x) for x in times], [float(x) for x in values]
    x = float(t)
    if x <= ts[0]:
        return vs[0]
    if x >= ts[-1]:
        return vs[-1]
    i = bisect.bisect_right(ts, x) - 1
    return vs[i] + (vs[i + 1] - vs[i]) * (x - ts[i]) / (ts[i + 1] - ts[i])


def tabulated(name: str, times, values, t: sp.Symbol) -> sp.Expr:
    """The input ``name``, tabulated (see :class:`Table`), as a function of ``t``."""
    return Table(
        t,
        sp.Tuple(*(sp.Float(x) for x in times)),
        sp.Tuple(*(sp.Float(x) for x in values)),
        Str(name),
    )


def is_table(e: sp.Basic) -> bool:
    """Whether ``e`` is a tabulated input (:func:`tabulated`)."""
    return isinstance(e, Table)


def table_form(expr: sp.Expr) -> sp.Expr:
    """``expr`` with each tabulated input written out: v0 + sum over the rows of the
    slope times ((t - t_i) step(t - t_i) - (t - t_i+1) step(t - t_i+1)), each term
    bounded by the rise of its row (no sum of ever larger terms cancelling)."""
    tables = sp.sympify(expr).atoms(Table)
    if not tables:
        return expr
    out = {}
    for a in tables:
        t, ts, vs, _ = a.args
        terms = [sp.Float(vs[0])]
        for i in range(len(ts) - 1):
            slope = (float(vs[i + 1]) - float(vs[i])) / (float(ts[i + 1]) - float(ts[i]))
            if slope == 0:
                continue
            lo, hi = t - ts[i], t - ts[i + 1]
            terms.append(sp.Float(slope) * (lo * sp.Heaviside(lo, 1) - hi * sp.Heaviside(hi, 1)))
        out[a] = sp.Add(*terms)
    return expr.xreplace(out)


def table_knots(expr: sp.Expr) -> set:
    """The switching functions t - t_i of the tabulated inputs in ``expr``."""
    out = set()
    for a in sp.sympify(expr).atoms(Table):
        t, ts = a.args[:2]
        out |= {t - x for x in ts}
    return out


def switch_form(expr: sp.Expr, branch) -> sp.Expr:
    """``expr`` with every input function written through its switches, innermost first:
    ``step(u)`` is ``branch(u)``, ``max(a, b)`` is ``b + (a - b) branch(a - b)``,
    ``min(a, b)`` is ``a + (b - a) branch(a - b)``, and ``piecewise`` the sum of its
    values weighted by its conditions (``u < v``: ``branch(v - u)``; and, or, not:
    products). ``branch(s)`` stands for step(s), 1 where s >= 0 and 0 elsewhere; the
    caller gives it: a symbol per switch locks the branches (the simulator holds them
    fixed between the events where s crosses 0), a random value tests an identity
    for every combination of branches at once (the expression is linear in each)."""
    expr = table_form(sp.sympify(expr))
    if not expr.has(sp.Heaviside, sp.Min, sp.Max, sp.Piecewise):
        return expr

    def cond(c) -> sp.Expr:
        if c == sp.true:
            return sp.Integer(1)
        if c == sp.false:
            return sp.Integer(0)
        if isinstance(c, sp.And):
            return sp.Mul(*(cond(a) for a in c.args))
        if isinstance(c, sp.Or):
            return 1 - sp.Mul(*(1 - cond(a) for a in c.args))
        if isinstance(c, sp.Not):
            return 1 - cond(c.args[0])
        lhs, rhs = walk(c.lhs), walk(c.rhs)
        if isinstance(c, (sp.StrictLessThan, sp.LessThan)):
            return branch(rhs - lhs)
        if isinstance(c, (sp.StrictGreaterThan, sp.GreaterThan)):
            return branch(lhs - rhs)
        raise ValueError(f"condition {c} is not a comparison with < <= > >=")

    def walk(e: sp.Expr) -> sp.Expr:
        if not isinstance(e, sp.Basic) or not e.has(sp.Heaviside, sp.Min, sp.Max, sp.Piecewise):
            return e
        if isinstance(e, sp.Piecewise):
            out = walk(e.args[-1].expr)
            if e.args[-1].cond != sp.true:
                out = walk(e.args[-1].expr) * cond(e.args[-1].cond)
            for v, c in reversed(e.args[:-1]):
                w = cond(c)
                out = walk(v) * w + out * (1 - w)
            return out
        args = [walk(a) for a in e.args]
        if isinstance(e, sp.Heaviside):
            return branch(args[0])
        if isinstance(e, (sp.Min, sp.Max)):
            # in pairs, a balanced tree: its depth grows as log2 of the count, never a
            # chain as deep as the arguments are many (SymPy recurses through depth)
            big = isinstance(e, sp.Max)
            while len(args) > 1:
                paired = []
                for k in range(0, len(args) - 1, 2):
                    a, c = args[k], args[k + 1]
                    b = branch(a - c)  # 1 where a >= c
                    paired.append(a * b + c * (1 - b) if big else c * b + a * (1 - b))
                args = paired + args[len(args) - len(args) % 2 :]
            return args[0]
        return e.func(*args)

    return walk(expr)


def _has_real_derivative(f: sp.Expr, wrt: tuple) -> bool:
    try:
        d = sp.diff(f, *wrt)
    except (ValueError, TypeError, NotImplementedError):
        return False
    if d.has(sp.DiracDelta, sp.Derivative, sp.re, sp.im, sp.Subs):
        return False
    try:
        to_text(d)
    except ValueError:
        return False
    return True
