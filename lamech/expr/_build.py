"""The whitelist walk: an ``ast`` tree to SymPy node by node, each node's result
bounded (digits, magnitude, exponents, terms) before the next is built."""

from __future__ import annotations

import ast
import math
from collections.abc import Mapping

import sympy as sp

from ._bounds import (
    ZERO_TEST_POINTS,
    _count,
    _factors,
    _magnitude,
    _numeric_powers,
    _plain_complex,
    _power_digits,
    _short,
    _terms,
    identically_zero,
)
from ._grammar import (
    _ACC_SUFFIX,
    _ARITY,
    _DECIMAL,
    _GROUP,
    _MAX_EXP,
    _SYMPY_FAILURES,
    _UNDEFINED,
    _VEL_SUFFIX,
    ANGULAR_VELOCITY,
    FUNCTIONS,
    MAX_INT_EXPONENT,
    MAX_MINMAX_ARGS,
    MAX_NUMBER_DIGITS,
    MAX_TERMS,
    ExpressionError,
    _describe,
    _velocity_hint,
)
from ._print import _plain


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
        terms = _terms(out, self.terms_cache)
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

    def _Call(self, node: ast.Call) -> sp.Expr:
        if not isinstance(node.func, ast.Name) or (
            node.func.id not in FUNCTIONS and node.func.id in self.names
        ):
            # 2(x + 1), (a + b)(c + d), m(x + 1): a product written as on paper
            whole = self.segment(node)
            if isinstance(node.func, ast.Name) and [self.segment(a) for a in node.args] == ["t"]:
                raise self.fail(
                    f"`{whole}`: `{node.func.id}` is not a function; a coordinate is a "
                    f"function of time without saying so: write `{node.func.id}`",
                    node,
                )
            cut = _opening(whole)
            if cut and len(node.args) == 1 and not isinstance(node.func, ast.Attribute):
                left, right = whole[:cut].strip(), whole[cut:]
                raise self.fail(
                    f"`{whole}`: `{left}` is not a function, and lamech multiplies only "
                    f"with `*`: write `{left}*{right}`",
                    node,
                )
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


def _opening(call: str) -> int:
    """The index of the bracket that opens the arguments of ``call`` (text ending in
    ``)``: the match of its last bracket); 0 when there is none after some text."""
    if not call.endswith(")"):
        return 0
    depth = 0
    for i in range(len(call) - 1, -1, -1):
        depth += {")": 1, "(": -1}.get(call[i], 0)
        if depth == 0:
            return i
    return 0
