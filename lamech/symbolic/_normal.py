"""Normal forms of closed forms, by polynomial algebra, bounded by counted work.

What the symbolic layer manipulates is narrow: rational functions of sines and cosines
of the angles, of the other coordinates, velocities and parameters (and now and then a
square root). :func:`normal` brings such an expression to a normal form in SymPy's
sparse polynomial rings (``sympy.polys.rings``), where arithmetic is one to two orders
of magnitude faster than on ``Expr`` trees and its results are canonical:

* every ``sin(k1 x1 + k2 x2 + c)``, ``cos(...)`` with rational ``k`` is expanded by the
  addition formulas into polynomials in ``s_u = sin u`` and ``c_u = cos u`` of one base
  angle ``u = x / d`` per symbol (``d`` the common denominator of its coefficients);
  ``tan``, ``cot``, ``sec``, ``csc`` become quotients of those;
* ``s_u**2 + c_u**2 - 1`` is its own Groebner basis, so reducing modulo it
  (``s_u**2 -> 1 - c_u**2``) gives a normal form of every polynomial in which zero is
  zero; a square root ``r = sqrt(b)`` of a polynomial joins the ideal as ``r**2 - b``;
* a quotient is kept as a numerator over a product of denominator factors (each reduced
  and made primitive), so sums need no gcd, and a factor is cancelled where it divides
  the numerator exactly.

The work is counted, never timed: every product charges ``len(a) * len(b)`` units to
the :class:`Work` in force (:func:`work_budget`), every sum ``len(a) + len(b)``, a
division ``len(num) * len(f)``. A call that would exceed the budget, or make one
polynomial larger than :data:`TERMS`, gives its input back unchanged
(:class:`OverBudget` inside). The same input therefore gives the same bytes on any
machine, loaded or idle, in any thread, under any hash seed: generators are ordered by
SymPy's ``default_sort_key``, never by a set's iteration order.

SymPy's ``simplify``/``trigsimp`` are a search (their outcome depends on time limits,
cache contents and set order); ``cancel`` over ``Expr`` treats ``sin`` and ``cos`` as
unrelated, so ``(sin(x)**2 + cos(x)**2 - 1)**2`` survives it. Nothing in SymPy brings a
trigonometric rational function to a normal form modulo the circle's ideal with a
bound on work, hence this module.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from math import lcm

import sympy as sp
from sympy.core.sorting import default_sort_key
from sympy.polys.domains import QQ
from sympy.polys.monomials import monomial_div, monomial_mul
from sympy.polys.rings import PolyElement, PolyRing

from ._work import (
    _LABEL,
    _WORK,
    CALL_WORK,
    DEFAULT_BUDGET,
    OverBudget,
    Work,
    _charge,
    _one_call,
    current_work,
    work_budget,
)

__all__ = [
    "Work",
    "OverBudget",
    "work_budget",
    "current_work",
    "normal",
    "is_zero",
    "Rational",
    "to_rational",
    "DEFAULT_BUDGET",
    "TERMS",
]

TERMS = 4000
"""No polynomial built by one normal form may have more terms than this; past it the
expression is given back unchanged (a bound per call, beside the solve's budget)."""

FACTOR_TERMS = 40
"""Polynomials up to this many terms are factored for printing (multivariate
factorisation is exact but its cost grows fast with size)."""


# ----- generators ---------------------------------------------------------------------

_TRIG = (sp.sin, sp.cos, sp.tan, sp.cot, sp.sec, sp.csc)


def _linear_angle(arg: sp.Expr) -> tuple[dict, sp.Expr] | None:
    """``arg`` as {symbol: rational coefficient} plus a constant, or None."""
    coeffs: dict = {}
    const = sp.Integer(0)
    for term in sp.Add.make_args(sp.expand(arg)):
        if term.is_number:
            const += term
            continue
        c, rest = term.as_coeff_Mul()
        if rest.is_Symbol and c.is_Rational:
            coeffs[rest] = coeffs.get(rest, sp.Integer(0)) + c
        else:
            return None
    coeffs = {k: v for k, v in coeffs.items() if v != 0}
    if not coeffs:
        return None  # a number: sin(1) is a generator of its own (an opaque angle)
    if const != 0 and (sp.sin(const).has(*_TRIG) or sp.cos(const).has(*_TRIG)):
        return None  # sin(x + 1): an opaque angle too
    return coeffs, const


class _Space:
    """The polynomial ring of one set of expressions: a generator for each symbol met
    outside trigonometry, ``c_u, s_u`` for each base angle ``u``, one for each square
    root and one for each other function; the relations that reduce them."""

    def __init__(self, exprs: list[sp.Expr], per_symbol: bool = False):
        self.denoms: dict = {}  # angle symbol -> common denominator d (u = x/d)
        self.forms: set = set()  # the linear parts of trig arguments, as sorted tuples
        self.opaque_angles: set = set()  # trig arguments not linear in symbols
        self.symbols: set = set()
        self.roots: set = set()  # Pow(base, 1/2) with a non-constant or rational base
        self.others: set = set()
        for e in exprs:
            self._scan(e)
        self.basis, self.in_basis = _angle_basis(self.forms, self.denoms, per_symbol)
        opaque = sorted(self.opaque_angles, key=default_sort_key)
        self.angle_keys = [("x", b) for b in self.basis] + [("o", a) for a in opaque]
        names: list[str] = []
        self.expr_of: list[sp.Expr] = []
        # roots first (highest in lex order), then sines, cosines, the rest
        for r in sorted(self.roots, key=default_sort_key):
            names.append(f"r{len(names)}")
            self.expr_of.append(r)
        self.s_index: dict = {}
        self.c_index: dict = {}
        for key in self.angle_keys:
            u = self._angle_expr(key)
            self.s_index[key] = len(names)
            names.append(f"s{len(names)}")
            self.expr_of.append(sp.sin(u))
        for key in self.angle_keys:
            u = self._angle_expr(key)
            self.c_index[key] = len(names)
            names.append(f"c{len(names)}")
            self.expr_of.append(sp.cos(u))
        self.sym_index: dict = {}
        for s in sorted(self.symbols, key=default_sort_key):
            self.sym_index[s] = len(names)
            names.append(f"x{len(names)}")
            self.expr_of.append(s)
        self.other_index: dict = {}
        for o in sorted(self.others, key=default_sort_key):
            self.other_index[o] = len(names)
            names.append(f"y{len(names)}")
            self.expr_of.append(o)
        if not names:
            names = ["z"]
            self.expr_of.append(sp.Dummy("z"))
        self.ring = PolyRing(names, QQ)
        self.gens = self.ring.gens
        self.root_index = {r: i for i, r in enumerate(sorted(self.roots, key=default_sort_key))}
        self.root_rel: dict[int, PolyElement] = {}
        self._trig_cache: dict = {}
        # each root's square, in the ring (bases hold no roots of their own: see _scan)
        for r, i in self.root_index.items():
            num, den = self.convert(r.base)
            if den:
                raise OverBudget("a square root of a quotient")  # pragma: no cover
            self.root_rel[i] = num

    # -- scanning --
    def _scan(self, e: sp.Expr) -> None:
        if e.is_Symbol:
            self.symbols.add(e)
            return
        if e.is_Number or e in (sp.pi, sp.E):
            if e in (sp.pi, sp.E):
                self.others.add(e)
            return
        if e.is_Add or e.is_Mul:
            for a in e.args:
                self._scan(a)
            return
        if e.is_Pow:
            base, ex = e.args
            if ex.is_Integer:
                self._scan(base)
                return
            if ex.is_Rational and ex.q == 2 and _polynomial_base(base):
                self.roots.add(sp.sqrt(base))
                self._scan(base)
                return
            self.others.add(e)
            return
        if isinstance(e, _TRIG):
            arg = e.args[0]
            lin = _linear_angle(arg)
            if lin is None:
                self.opaque_angles.add(arg)
                return
            coeffs, _ = lin
            for x, k in coeffs.items():
                self.denoms[x] = lcm(self.denoms.get(x, 1), int(k.q))
            if coeffs:
                self.forms.add(_form_key(coeffs))
            return
        if e is sp.I:
            self.others.add(e)
            return
        self.others.add(e)

    def _angle_expr(self, key) -> sp.Expr:
        kind, a = key
        return sp.Add(*[k * x for x, k in a]) if kind == "x" else a

    # -- conversion --
    def convert(self, e: sp.Expr) -> tuple[PolyElement, dict]:
        """``e`` as (numerator, {denominator factor: exponent})."""
        R = self.ring
        if e.is_Rational:
            return R(QQ(int(e.p), int(e.q))), {}
        if e.is_Float:
            r = sp.Rational(str(e))
            return R(QQ(int(r.p), int(r.q))), {}
        if e.is_Symbol:
            return self.gens[self.sym_index[e]], {}
        if e.is_Add:
            acc: tuple = (R.zero, {})
            for a in e.args:
                acc = _add(self, acc, self.convert(a))
            return acc
        if e.is_Mul:
            acc = (R.one, {})
            for a in e.args:
                acc = _mul(self, acc, self.convert(a))
            return acc
        if e.is_Pow:
            base, ex = e.args
            if ex.is_Integer:
                b = self.convert(base)
                n = int(ex)
                out = _power(self, b, abs(n))
                return _invert(self, out) if n < 0 else out
            if ex.is_Rational and ex.q == 2 and sp.sqrt(base) in self.root_index:
                r = self.gens[self.root_index[sp.sqrt(base)]]
                out = _power(self, (r, {}), abs(int(ex.p)))
                out = (self.reduce(out[0]), out[1])
                return _invert(self, out) if ex < 0 else out
        if isinstance(e, _TRIG):
            return self._trig(e)
        if e in self.other_index:
            return self.gens[self.other_index[e]], {}
        raise OverBudget(f"no generator for {e}")  # pragma: no cover - scanned first

    def _trig(self, e: sp.Expr) -> tuple[PolyElement, dict]:
        arg = e.args[0]
        lin = _linear_angle(arg)
        if lin is None:
            key = ("o", arg)
            s, c = self.gens[self.s_index[key]], self.gens[self.c_index[key]]
        else:
            coeffs, const = lin
            s, c = self.ring.zero, self.ring.one  # sin 0, cos 0
            for b, n in self.in_basis(coeffs):
                sn, cn = self._multiple(("x", b), n)
                s, c = (
                    self.reduce(s * cn + c * sn),
                    self.reduce(c * cn - s * sn),
                )
                _charge(4 * max(len(s), 1))
            if const != 0:
                sk, ck = self.convert(sp.sin(const)), self.convert(sp.cos(const))
                if sk[1] or ck[1]:
                    raise OverBudget("a trigonometric constant with a denominator")
                s, c = (
                    self.reduce(s * ck[0] + c * sk[0]),
                    self.reduce(c * ck[0] - s * sk[0]),
                )
        f = e.func
        if f is sp.sin:
            return s, {}
        if f is sp.cos:
            return c, {}
        if f is sp.tan:
            return _mul(self, (s, {}), _invert(self, (c, {})))
        if f is sp.cot:
            return _mul(self, (c, {}), _invert(self, (s, {})))
        if f is sp.sec:
            return _invert(self, (c, {}))
        return _invert(self, (s, {}))  # csc

    def _multiple(self, key, n: int) -> tuple[PolyElement, PolyElement]:
        """(sin(n u), cos(n u)) in the ring."""
        if (key, n) in self._trig_cache:
            return self._trig_cache[(key, n)]
        s1, c1 = self.gens[self.s_index[key]], self.gens[self.c_index[key]]
        if n < 0:
            s, c = self._multiple(key, -n)
            out = (-s, c)
        elif n == 0:
            out = (self.ring.zero, self.ring.one)
        elif n == 1:
            out = (s1, c1)
        else:
            s, c = self._multiple(key, n - 1)
            out = (self.reduce(s * c1 + c * s1), self.reduce(c * c1 - s * s1))
        self._trig_cache[(key, n)] = out
        return out

    # -- the ideal --
    def reduce(self, p: PolyElement, towards: str = "cos") -> PolyElement:
        """The normal form of ``p`` modulo s^2 + c^2 - 1 (each angle) and r^2 - b (each
        root): with ``towards="cos"`` no sine above the first power, with ``"sin"`` no
        cosine above it."""
        if len(p) > TERMS:
            raise OverBudget(f"a polynomial of more than {TERMS} terms")
        rules = []
        for i, b in self.root_rel.items():
            rules.append((i, b))
        one = self.ring.one
        for key in self.angle_keys:
            si, ci = self.s_index[key], self.c_index[key]
            if towards == "cos":
                rules.append((si, one - self.gens[ci] ** 2))
            else:
                rules.append((ci, one - self.gens[si] ** 2))
        for i, sq in rules:
            if not any(m[i] >= 2 for m in p):
                continue
            # the terms gathered in one dict, the polynomial made once: adding them one
            # by one as polynomials copied the sum each time (quadratic in its terms)
            acc: dict = {}
            powers = [one]
            for m, coeff in p.items():
                k = m[i]
                if k < 2:
                    acc[m] = acc[m] + coeff if m in acc else coeff
                    continue
                while len(powers) <= k // 2:
                    powers.append(powers[-1] * sq)
                m2 = list(m)
                m2[i] = k % 2
                power = powers[k // 2]
                for mp, cp in power.items():
                    key = monomial_mul(tuple(m2), mp)
                    acc[key] = acc[key] + coeff * cp if key in acc else coeff * cp
                _charge(len(power))
            p = self.ring.from_dict({m: c for m, c in acc.items() if c})
            if len(p) > TERMS:
                raise OverBudget(f"a polynomial of more than {TERMS} terms")
        return p

    def to_expr(self, p: PolyElement) -> sp.Expr:
        return p.as_expr(*self.expr_of)


def _form_key(coeffs: dict) -> tuple:
    return tuple(sorted(coeffs.items(), key=lambda xk: default_sort_key(xk[0])))


def _angle_basis(forms: set, denoms: dict, per_symbol_only: bool = False):
    """The base angles: the simplest linearly independent trigonometric arguments, when
    every argument is an integer combination of them (SymPy's relative joint angles q1,
    q1 + q2, q1 + q2 + q3 are three base angles, so cos(q1 + q2 + q3) is one generator,
    not a product of three sums); else one angle x/d per symbol (d the common
    denominator of its coefficients). Returns (basis, in_basis) with ``in_basis(coeffs)``
    the [(base form, integer multiple)] of an argument's linear part."""
    symbols = sorted(denoms, key=default_sort_key)
    fallback = [((x, sp.Rational(1, denoms[x])),) for x in symbols]

    def per_symbol(coeffs: dict) -> list:
        return [
            (((x, sp.Rational(1, denoms[x])),), int(coeffs[x] * denoms[x]))
            for x in sorted(coeffs, key=default_sort_key)
        ]

    def row(form) -> list:
        d = dict(form)
        return [d.get(x, 0) for x in symbols]

    if per_symbol_only:
        return fallback, per_symbol
    # each form up to sign, simplest first
    normal_forms = set()
    for f in forms:
        sign = -1 if f[0][1] < 0 else 1
        normal_forms.add(tuple((x, sign * k) for x, k in f))
    cands = sorted(
        normal_forms, key=lambda f: (len(f), default_sort_key(sp.Tuple(*map(sp.Tuple, f))))
    )
    basis: list = []
    for f in cands:
        trial = sp.Matrix([row(b) for b in basis + [f]])
        if trial.rank() == len(basis) + 1:
            basis.append(f)
        if len(basis) == len(symbols):
            break
    if not basis:
        return fallback, per_symbol
    B = sp.Matrix([row(b) for b in basis])
    gram_inv = (B * B.T).inv()
    table = {}
    for f in forms:
        c = sp.Matrix([row(f)]) * B.T * gram_inv
        if any(not v.is_Integer for v in c) or sp.Matrix([row(f)]) != c * B:
            return fallback, per_symbol
        table[f] = [(basis[i], int(v)) for i, v in enumerate(c) if v != 0]

    def in_basis(coeffs: dict) -> list:
        return table[_form_key(coeffs)]

    return basis, in_basis


def _polynomial_base(base: sp.Expr) -> bool:
    """A square root's base that is a polynomial with no roots of its own (sqrt(l^2 -
    x^2), sqrt(2)): it joins the ideal. Others stay opaque generators."""
    for p in base.atoms(sp.Pow):
        if not p.exp.is_Integer or p.exp < 0:
            return False
    return not base.has(*_TRIG)


# ----- arithmetic on (numerator, denominator factors) -----------------------------------


def _add(space: _Space, a: tuple, b: tuple) -> tuple:
    na, da = a
    nb, db = b
    if not na:
        return b
    if not nb:
        return a
    den = dict(da)
    for f, k in db.items():
        den[f] = max(den.get(f, 0), k)
    ma = _den_product(space, den, da)
    mb = _den_product(space, den, db)
    _charge(len(na) * len(ma) + len(nb) * len(mb))
    num = space.reduce(na * ma + nb * mb)
    _check(num)
    return num, den


def _den_product(space: _Space, full: dict, part: dict) -> PolyElement:
    out = space.ring.one
    for f, k in full.items():
        extra = k - part.get(f, 0)
        if extra:
            _charge(len(out) * len(f) * extra)
            out = out * f**extra
            _check(out)
    return out


def _mul(space: _Space, a: tuple, b: tuple) -> tuple:
    na, da = a
    nb, db = b
    if not na or not nb:
        return space.ring.zero, {}
    _charge(len(na) * len(nb))
    if len(na) * len(nb) > 20 * TERMS:
        raise OverBudget("a product too large")
    num = space.reduce(na * nb)
    _check(num)
    den = dict(da)
    for f, k in db.items():
        den[f] = den.get(f, 0) + k
    return _cancel(space, num, den)


def _power(space: _Space, a: tuple, n: int) -> tuple:
    out: tuple = (space.ring.one, {})
    for _ in range(n):
        out = _mul(space, out, a)
    return out


def _invert(space: _Space, a: tuple) -> tuple:
    """1 / a: the numerator's factors join the denominator (each reduced, primitive,
    with a positive leading coefficient); the old denominator becomes the numerator."""
    num, den = a
    if not num:
        raise ZeroDivisionError("division by an expression that is identically zero")
    R = space.ring
    new_num = R.one
    for f, k in den.items():
        _charge(len(new_num) * len(f) * k)
        new_num = space.reduce(new_num * f**k)
        _check(new_num)
    new_den: dict = {}
    content, prim = num.primitive()
    if prim.LC < 0:
        content, prim = -content, -prim
    new_num = new_num.quo_ground(content) if content != 1 else new_num
    if prim != R.one:
        for f, k in _split_monomial(space, prim).items():
            new_den[f] = new_den.get(f, 0) + k
    return _cancel(space, new_num, new_den)


def _split_monomial(space: _Space, p: PolyElement) -> dict:
    """A denominator factor as {factor: exponent}: a monomial split into its generators
    (x^2 s -> {x: 2, s: 1}), anything else kept whole."""
    if len(p) == 1:
        ((m, _),) = p.items()
        return {space.gens[i]: k for i, k in enumerate(m) if k}
    return {p: 1}


def _check(p: PolyElement) -> None:
    if len(p) > TERMS:
        raise OverBudget(f"a polynomial of more than {TERMS} terms")


def _exact_quotient(p: PolyElement, f: PolyElement) -> PolyElement | None:
    """p / f where f divides p exactly, else None. SymPy's ``div`` runs the division to
    its remainder; an exact quotient fails at the first leading term of what is left that
    f's leading term does not divide, which for a large numerator and a factor that does
    not divide it is at once, not after a pass of a maximum over every term per step
    (a quarter of the time of a linkage's elimination went there)."""
    ring = p.ring
    ef = f.leading_expv()
    cf = f[ef]
    terms: dict = {}
    while p:
        ep = p.leading_expv()
        m = monomial_div(ep, ef)
        if m is None:
            return None
        c = ring.domain.quo(p[ep], cf)
        terms[m] = c
        p = p - f.mul_term((m, c))
    return ring(terms)


def _cancel(space: _Space, num: PolyElement, den: dict) -> tuple:
    """Cancel every denominator factor that divides the numerator exactly; a sine over
    a power of it is cancelled through s^2 = 1 - c^2."""
    if not num:
        return num, {}
    if not den:
        return num, den
    out = dict(den)
    for f in sorted(out, key=_poly_key):
        k = out[f]
        while k and num:
            _charge(len(num) * len(f))
            q = _exact_quotient(num, f)
            if q is None:
                break
            num, k = q, k - 1
        if k and len(f) == 1 and f in space.gens:
            i = space.gens.index(f)
            key = next((a for a, j in space.s_index.items() if j == i), None)
            if key is not None:  # num / s = num s / (1 - c^2)
                c = space.gens[space.c_index[key]]
                one = space.ring.one
                while k:
                    trial = space.reduce(num * f)
                    _charge(len(trial) * 2)
                    q1 = _exact_quotient(trial, one - c)
                    q2 = None if q1 is None else _exact_quotient(q1, one + c)
                    if q2 is None:
                        break
                    num, k = q2, k - 1
        if k:
            out[f] = k
        else:
            del out[f]
    return num, out


def _poly_key(p: PolyElement) -> tuple:
    return (len(p), sorted(p.items()))


# ----- the public face -------------------------------------------------------------------


@dataclass(frozen=True)
class Rational:
    """An expression in normal form: numerator over denominator factors, in ``space``."""

    space: _Space
    num: PolyElement
    den: tuple  # ((factor, exponent), ...) in a canonical order

    @property
    def is_zero(self) -> bool:
        return not self.num

    def as_expr(self) -> sp.Expr:
        sp_ = self.space
        num = sp_.to_expr(self.num)
        den = sp.Mul(*[sp_.to_expr(f) ** k for f, k in self.den])
        return num / den


def to_rational(expr: sp.Expr) -> Rational:
    """``expr`` in normal form (raises :class:`OverBudget` past the bounds and
    ``ZeroDivisionError`` for a division by an expression identically zero)."""
    with _one_call(CALL_WORK):
        return _to_rational(expr)


def _to_rational(expr: sp.Expr) -> Rational:
    expr = sp.sympify(expr)
    space = _Space([expr])
    num, den = space.convert(expr)
    return Rational(space, num, tuple(sorted(den.items(), key=lambda fk: _poly_key(fk[0]))))


def is_zero(expr: sp.Expr) -> bool | None:
    """Whether ``expr`` is identically zero (on every circle s^2 + c^2 = 1); None when
    the bounds do not allow the normal form to decide."""
    try:
        return to_rational(expr).is_zero
    except OverBudget:
        return None


def normal(
    expr: sp.Expr,
    *,
    velocities: tuple = (),
    angles: tuple = (),
    pretty: bool = True,
) -> sp.Expr:
    """The shortest readable form of ``expr`` found by the normal form: the numerator
    expanded, factored (when short) or collected by powers of ``velocities`` with
    factored coefficients, over the factored denominator; written with cosines (sines
    reduced to the first power) or with sines, whichever is shorter; in chains also in
    the differences of consecutive ``angles``. ``expr`` itself when it is already
    the shortest, or when the work budget (:func:`work_budget`) or :data:`TERMS` does
    not allow the normal form. Deterministic: the same input gives the same output.
    With ``pretty=False`` (intermediates of an elimination) only the expanded numerator
    over the denominator factors is tried, with cosines."""
    expr = sp.sympify(expr)
    if expr.is_Atom:
        return expr
    try:
        return _normal(expr, tuple(velocities), tuple(angles), pretty)
    except OverBudget:
        work = _WORK.get()
        if work is not None and work.exhausted:
            work.untidied.append(_LABEL.get() or "result")
        return expr


def _normal(expr: sp.Expr, velocities: tuple, angles: tuple, pretty: bool = True) -> sp.Expr:
    from ._budget import count_ops

    best, best_ops = expr, count_ops(expr)
    shift_sets: list[dict] = [{}]
    used = [a for a in angles if any(a in f.free_symbols for f in expr.atoms(*_TRIG))]
    if len(used) >= 2 and pretty and not _sums_only(expr):
        deltas = {}
        # theta_k = theta_1 + delta_k (delta_k printed back as theta_k - theta_1 ...)
        for k in range(1, len(used)):
            d = sp.Dummy(f"delta{k}")
            deltas[used[k]] = (d, used[k] - used[k - 1])
        shift = {}
        acc = used[0]
        for k in range(1, len(used)):
            d, _ = deltas[used[k]]
            acc = acc + d
            shift[used[k]] = acc
        back = {d: diff for d, diff in deltas.values()}
        shift_sets.append({"to": shift, "back": back})
    if pretty and _joins_symbols(expr):
        # the base angles are the arguments themselves (q1, q1 + q2: few generators);
        # written in one angle per symbol instead, a relative-angle chain's
        # sin(q1) sin(q1 + q2) + cos(q1) cos(q1 + q2) is cos(q2)
        shift_sets.append({"per_symbol": True})
    for shifts in shift_sets:
        try:
            with _one_call(CALL_WORK):
                found = _best_of(expr, shifts, velocities, pretty, best_ops)
        except OverBudget:
            work = _WORK.get()
            if work is not None and work.exhausted:
                raise
            continue  # this writing is past the per-call bound; the others may not be
        if found is not None:
            best, best_ops = found
            if best == 0:
                return best
    return best


def _sums_only(expr: sp.Expr) -> bool:
    """Every sine or cosine of two or more symbols in ``expr`` is of a sum (q1 + q2: a
    chain in relative joint angles, where the differences of the angles mean nothing),
    and there is one."""
    args = [f.args[0] for f in expr.atoms(*_TRIG) if len(f.args[0].free_symbols) >= 2]
    if not args:
        return False
    for a in args:
        lin = _linear_angle(a)
        if lin is None or len({c > 0 for c in lin[0].values()}) > 1:
            return False
    return True


def _joins_symbols(expr: sp.Expr) -> bool:
    """A sine or cosine in ``expr`` of an argument with two or more symbols."""
    return any(len(f.args[0].free_symbols) >= 2 for f in expr.atoms(*_TRIG))


def _best_of(expr: sp.Expr, shifts: dict, velocities: tuple, pretty: bool, best_ops: int):
    """(form, operations) of the shortest presentation of ``expr`` written with the
    angle ``shifts`` (none: as it is), when shorter than ``best_ops``; else None."""
    from ._budget import count_ops

    to = shifts.get("to") if shifts else None
    e = expr.xreplace(to) if to else expr
    # shifted: the first angle and differences, each its own base angle
    space = _Space([e], per_symbol=bool(to) or bool(shifts.get("per_symbol")))
    num, den = space.convert(e)
    if not num:
        return sp.Integer(0), 0
    best = None
    if not pretty:
        dens = sorted(den.items(), key=lambda fk: _poly_key(fk[0]))
        cand = space.to_expr(num) / sp.Mul(*[space.to_expr(f) ** k for f, k in dens])
        ops = count_ops(cand)
        return (cand, ops) if ops < best_ops else None
    for towards in ("cos", "sin"):
        n2 = space.reduce(num, towards) if towards == "sin" else num
        for cand in _presentations(space, n2, den, velocities, towards):
            if to:
                cand = cand.xreplace(shifts["back"])
            ops = count_ops(cand)
            if ops < best_ops:
                best, best_ops = (cand, ops), ops
    return best


def _presentations(space: _Space, num: PolyElement, den: dict, velocities: tuple, towards):
    """Printed forms of num / den: the numerator expanded, factored when short (each
    factor collected by the velocities' powers), and collected by those powers with
    factored coefficients."""
    if not velocities:  # lamech's velocities are the symbols written x'
        velocities = tuple(v for v in space.sym_index if v.name.endswith("'"))
    vel_idx = tuple(space.sym_index[v] for v in velocities if v in space.sym_index)
    content, prim = num.primitive()
    if prim and prim.LC < 0:
        content, prim = -content, -prim
    c = sp.Rational(int(content.numerator), int(content.denominator))
    # the denominator as irreducible factors (few generators: cheap), each cancelled
    # where it divides the numerator exactly: the numerator itself is factored only when
    # small (_factor_list), so a common factor is found by division, not by factoring it
    pieces: list = []
    scale = sp.Integer(1)  # the denominator's numeric content, kept in it: 3 (R1 + R2)
    for f, k in sorted(den.items(), key=lambda fk: _poly_key(fk[0])):
        g = space.reduce(f, towards) if towards == "sin" else f
        if 1 < len(g) <= FACTOR_TERMS:
            _charge(len(g) ** 3)
            dc, factors = _factor_list(g)
            scale *= sp.Rational(int(dc.numerator), int(dc.denominator)) ** k
            pieces += [(h, e * k) for h, e in factors]
        else:
            pieces.append((g, k))
    kept = []
    # a numerator factored in full (small) meets its denominator in SymPy's product, as
    # it always did; a larger one is divided by each factor here
    divide = len(prim) > FACTOR_TERMS or _gens_used(prim) > FACTOR_GENS
    for h, e in pieces:
        while divide and e and prim and not h.is_ground:
            q = _exact_quotient(prim, h)
            if q is None:
                break
            _charge(len(prim) * len(h))
            prim, e = q, e - 1
        if e:
            kept.append((h, e))
    D = sp.Mul(scale, *[_shown_factor(space, h, vel_idx) ** e for h, e in kept])
    yield c * space.to_expr(prim) / D
    if len(prim) <= FACTOR_TERMS:
        yield _factored(space, prim, vel_idx, c, 1 / D)
    if vel_idx and len(prim) > 1:
        yield c * _collected(space, prim, vel_idx) / D


def _collected(space: _Space, p: PolyElement, vel_idx: tuple) -> sp.Expr:
    """``p`` grouped by the powers of the velocities (generators ``vel_idx``), each
    coefficient factored when short: m g cos(th) - m (R1 + R2) th'^2."""
    groups: dict = {}
    for m, coeff in p.items():
        key = tuple(m[i] for i in vel_idx)
        m2 = list(m)
        for i in vel_idx:
            m2[i] = 0
        groups.setdefault(key, []).append((tuple(m2), coeff))
    if len(groups) == 1:
        return _factored(space, p)
    terms = []
    for key in sorted(groups, reverse=True):
        coeff = space.ring(dict(groups[key]))
        vpart = sp.Mul(*[space.expr_of[i] ** k for i, k in zip(vel_idx, key)])
        terms.append(_factored(space, coeff, (), vpart))
    return sp.Add(*terms)


def _shown_factor(space: _Space, f: PolyElement, vel_idx: tuple) -> sp.Expr:
    """One factor as printed: collected by the velocities where that is shorter."""
    e = space.to_expr(f)
    if vel_idx and len(f) > 2 and any(m[i] for m in f for i in vel_idx):
        grouped = _collected(space, f, vel_idx)
        if _ops(grouped) <= _ops(e):
            e = grouped
    return e


def _factored(space: _Space, p: PolyElement, vel_idx: tuple = (), *more: sp.Expr) -> sp.Expr:
    """``p`` as a product of its irreducible factors (when short), each collected by the
    velocities (``vel_idx``) where that is shorter; else expanded. Multiplied by ``more``
    in one product, so that a number stays outside a sum (3 (R1 + R2), which SymPy's
    two-factor product would distribute to 3 R1 + 3 R2)."""
    if len(p) <= 1 or len(p) > FACTOR_TERMS:
        return sp.Mul(space.to_expr(p), *more)
    _charge(len(p) ** 3)
    coeff, factors = _factor_list(p)
    parts: list = [sp.Rational(int(coeff.numerator), int(coeff.denominator)), *more]
    parts += [_shown_factor(space, f, vel_idx) ** k for f, k in factors]
    return sp.Mul(*parts)


FACTOR_GENS = 8
"""Polynomials in more generators than this are split only into their monomial and
numeric content and the rest (SymPy's multivariate factorisation costs 0.1 s on ten
terms in eleven generators, a double pendulum's numerators, and rarely finds a factor
there that the denominators and the content do not already show)."""


def _gens_used(p: PolyElement) -> int:
    monoms = list(p.keys())
    return sum(1 for i in range(p.ring.ngens) if any(m[i] for m in monoms))


@functools.lru_cache(maxsize=4096)
def _factor_list(p: PolyElement) -> tuple:
    """``p.factor_list()``, remembered: the rings of :class:`_Space` are SymPy's cached
    rings of positional generator names, so the same polynomial recurs across calls, and
    its factors do not depend on what the generators stand for. Past
    :data:`FACTOR_GENS` generators, the content alone (see there)."""
    monoms = list(p.keys())
    if _gens_used(p) <= FACTOR_GENS:
        return p.factor_list()
    ring = p.ring
    g = tuple(min(m[i] for m in monoms) for i in range(ring.ngens))
    content, prim = p.primitive()
    if prim.LC < 0:
        content, prim = -content, -prim
    rest = ring({tuple(a - b for a, b in zip(m, g)): c for m, c in prim.items()})
    factors = [(ring.gens[i], k) for i, k in enumerate(g) if k]
    if rest != 1:
        factors.append((rest, 1))
    return content, factors


def _ops(e: sp.Expr) -> int:
    from ._budget import count_ops

    return count_ops(e)


# ----- linear systems in the ring -------------------------------------------------------


def solve_linear(K: sp.Matrix, rhs: sp.Matrix, probe: dict) -> list[sp.Expr]:
    """x with K x = rhs, by Gauss-Jordan elimination in one polynomial ring (every entry
    a numerator over denominator factors, reduced modulo the circles' ideal), the pivots
    chosen by partial pivoting on K evaluated at ``probe`` (a generic point, so a pivot
    that is zero identically is never chosen). Each result is the expanded numerator
    over its denominator factors. Raises :class:`OverBudget` past the work budget or
    :data:`TERMS`, ``ZeroDivisionError`` when K is singular at the probe."""
    n = K.rows
    if n == 0:
        return []
    with _one_call(10 * CALL_WORK):
        return _solve_linear(K, rhs, probe)


def _solve_linear(K: sp.Matrix, rhs: sp.Matrix, probe: dict) -> list[sp.Expr]:
    import numpy as np

    n = K.rows
    entries = list(K) + list(rhs)
    space = _Space(entries)
    rows = [[space.convert(K[i, j]) for j in range(n)] + [space.convert(rhs[i])] for i in range(n)]
    symbols = sorted(probe, key=default_sort_key)
    f = sp.lambdify(symbols, K, modules=["numpy"])
    with np.errstate(all="ignore"):
        N = np.array(f(*[probe[s] for s in symbols]), dtype=complex)
    if not np.all(np.isfinite(N)):
        raise ZeroDivisionError("the system is not finite at the probe point")
    scale = max(1.0, float(np.abs(N).max()))
    zero: tuple = (space.ring.zero, {})
    for col in range(n):
        piv = col + int(np.argmax(np.abs(N[col:, col])))
        if abs(N[piv, col]) <= 1e-10 * scale or not rows[piv][col][0]:
            raise ZeroDivisionError("singular at a generic point")
        if piv != col:
            rows[col], rows[piv] = rows[piv], rows[col]
            N[[col, piv]] = N[[piv, col]]
        inv = _invert(space, rows[col][col])
        rows[col] = [_mul(space, e, inv) if e[0] else e for e in rows[col]]
        rows[col][col] = (space.ring.one, {})
        N[col] = N[col] / N[col, col]
        for r in range(n):
            if r == col or not rows[r][col][0]:
                continue
            factor = rows[r][col]
            neg = (-factor[0], factor[1])
            rows[r] = [
                rows[r][j]
                if j == col or not rows[col][j][0]
                else _add(space, rows[r][j], _mul(space, neg, rows[col][j]))
                for j in range(n + 1)
            ]
            rows[r][col] = zero
            N[r] -= N[r, col] * N[col]
    out = []
    for i in range(n):
        num, den = rows[i][n]
        dens = sorted(den.items(), key=lambda fk: _poly_key(fk[0]))
        out.append(space.to_expr(num) / sp.Mul(*[space.to_expr(f) ** k for f, k in dens]))
    return out
