"""The inputs' vocabulary: tabulated inputs (:class:`Table`), the switch form of the
functions with a jump or a kink (:func:`switch_form`), and why such a function
cannot be differentiated where the equations need it (:func:`not_differentiable`)."""

from __future__ import annotations

from collections.abc import Collection

import sympy as sp
from sympy.core.symbol import Str

from ._print import _plain, to_text


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
