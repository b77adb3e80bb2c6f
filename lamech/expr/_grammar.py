"""The grammar's vocabulary: its limits, its functions and reserved names, the
error it raises, and the symbols and names of velocities and accelerations."""

from __future__ import annotations

import ast
import math
import re

import sympy as sp

from .._errors import LamechError

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


class ExpressionError(LamechError, ValueError):
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
