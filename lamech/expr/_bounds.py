"""What the parser bounds with: the digits of exact powers, magnitudes, the number of
terms an expression would expand to, the zero test of a divisor by evaluation
(:func:`identically_zero`), and the short forms of numbers and text its messages show."""

from __future__ import annotations

import math

import sympy as sp

from ._grammar import (
    _SYMPY_FAILURES,
    MAX_TERMS,
)
from ._inputs import Table

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


def _terms(e: sp.Expr, cache: dict) -> int:
    """An upper bound on the number of terms of ``sympy.expand(e)`` (capped just
    above MAX_TERMS, so that the numbers stay small); functions count one each.
    ``cache`` holds the counts of the subexpressions seen (one per parse)."""
    known = cache.get(e)
    if known is not None:
        return known
    if e.is_Add:
        n = sum(_terms(a, cache) for a in e.args)
    elif e.is_Mul:
        n = 1
        for a in e.args:
            n = min(n * _terms(a, cache), MAX_TERMS + 1)
    elif e.is_Pow:
        n = _power_terms(e.args[0], e.args[1], cache)
    else:
        n = 1
    n = min(n, MAX_TERMS + 1)
    cache[e] = n
    return n


def _power_terms(base: sp.Expr, exponent: sp.Expr, cache: dict) -> int:
    if not exponent.is_Rational or base.is_Number:
        return 1
    k = abs(exponent.p) // exponent.q  # expand keeps the fractional part whole
    if k <= 1:
        return _terms(base, cache) if k == 1 else 1
    if base.is_Mul:
        n = 1
        for f in base.args:
            n = min(n * _power_terms(f, exponent, cache), MAX_TERMS + 1)
        return n
    if base.is_Pow and base.args[1].is_Rational:
        return _power_terms(base.args[0], base.args[1] * k, cache)
    t = _terms(base, cache)
    if t <= 1:
        return 1
    # monomials of degree k in t terms (a multinomial): C(k + t - 1, t - 1)
    return min(math.comb(k + t - 1, t - 1), MAX_TERMS + 1) if k <= 10**4 else MAX_TERMS + 1
