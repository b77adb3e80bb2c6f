"""The last step of simplification: the form a student would write down, chosen among a
few rewritings of an already simplified expression by a score that counts operations
and penalises what a textbook does not print:

* multiple angles (sin(2a) where the problem has sin a and cos a): undone;
* sin(a)/cos(a): written tan(a);
* large integers made by clearing a small initial value's denominator
  ((3 R + 40000 g (1 - cos)) / (30000 R) from theta'(0) = 1/100): terms kept apart;
* an Add factor that prints with a leading minus, -m (-R + a) or g/(-M - m): the
  minus taken out, m (R - a) and -g/(M + m).

SymPy's ``simplify`` optimises the operation count alone and prefers sin(2a) and a
common denominator; no SymPy function has this notion of "readable", hence these few
lines. Every candidate is an identity of the input (rewrites, not approximations).
"""

from __future__ import annotations

import sympy as sp

from ._budget import count_ops

__all__ = ["student", "outer_signs", "has_big_integer"]

BUDGET = 150
"""Expressions with more operations than this are only sign-normalised."""


def student(expr: sp.Expr) -> sp.Expr:
    """The most readable of a few identities of ``expr`` (see the module docstring);
    bounded by its size (:data:`BUDGET`)."""
    expr = sp.sympify(expr)
    if expr.is_Atom or count_ops(expr) > BUDGET:
        return outer_signs(expr)
    return _student(expr)


def _student(expr: sp.Expr) -> sp.Expr:
    best, best_score = expr, _score(expr)
    for cand in _candidates(expr):
        try:
            cand = outer_signs(cand)
        except (TypeError, ValueError, RecursionError):
            continue
        s = _score(cand)
        if s < best_score:
            best, best_score = cand, s
    return outer_signs(best)


def _candidates(expr: sp.Expr):
    trig = _trig_arguments(expr)
    multiple = any(_is_multiple(a, trig) for a in trig)
    work = [expr]
    if multiple:
        try:
            expanded = sp.factor(sp.expand_trig(expr))
            work.append(expanded)
        except (sp.PolynomialError, TypeError, ValueError, RecursionError):
            pass
    for e in list(work):
        yield e
        for x in {a for a in _trig_arguments(e) if not _is_multiple(a, trig)}:
            s, c = sp.sin(x), sp.cos(x)
            for old, new in ((c**2, 1 - s**2), (s**2, 1 - c**2)):
                if e.has(old):
                    yield _factored(e.subs(old, new))
            if e.has(s) and e.has(c):
                t = e.subs(s, sp.tan(x) * c)
                if not t.has(c):
                    yield t
                    yield sp.collect(sp.expand(t), sp.tan(x), func=sp.factor)
        if has_big_integer(e):
            ex = sp.expand(e)
            for sym in sorted(e.free_symbols, key=str):
                yield sp.collect(ex, sym, func=sp.factor)


def _factored(e: sp.Expr) -> sp.Expr:
    try:
        return sp.factor(e)
    except (sp.PolynomialError, TypeError, ValueError, RecursionError):
        return e


def _trig_arguments(expr: sp.Expr) -> set:
    return {f.args[0] for f in expr.atoms(sp.sin, sp.cos, sp.tan)}


def _is_multiple(arg: sp.Expr, args: set) -> bool:
    """arg = k x with an integer k > 1 (sin(2 alpha))."""
    coeff, rest = arg.as_coeff_Mul()
    return coeff.is_Integer and abs(coeff) > 1


def has_big_integer(e: sp.Expr) -> bool:
    return any(abs(n.p) >= 1000 or abs(n.q) >= 1000 for n in e.atoms(sp.Rational))


def _score(e: sp.Expr) -> float:
    score = float(count_ops(e))
    trig = _trig_arguments(e)
    score += 6 * sum(1 for a in trig if _is_multiple(a, trig))
    score += 4 * sum(1 for n in e.atoms(sp.Rational) if abs(n.p) >= 1000 or abs(n.q) >= 1000)
    score += 1 * sum(1 for a in e.atoms(sp.Add) if a.could_extract_minus_sign())
    return score


def outer_signs(expr: sp.Expr) -> sp.Expr:
    """Take the minus out of Add factors that print with a leading minus where it goes
    somewhere: -m (-R + a) becomes m (R - a) (two minuses cancel), g/(-M - m) becomes
    -g/(M + m) (every term negative). A lone l m (-2 g + l) is left alone: flipping it
    would only move the minus outside."""

    def flippable(f) -> tuple[sp.Expr, sp.Expr, bool] | None:
        """(base, exponent, every term negative) of an Add factor with a negative term
        (4 g (cos x - 1) after a minus: 4 g (1 - cos x))."""
        base, ex = f.as_base_exp()
        if base.is_Add and ex.is_Integer:
            negative = [t.could_extract_minus_sign() for t in base.args]
            if any(negative):
                return base, ex, all(negative)
        return None

    def fix(e: sp.Mul) -> sp.Expr:
        negative = bool(e.as_coeff_Mul()[0].is_negative)
        flips = 0
        args = []
        for f in e.args:
            hit = flippable(f)
            if hit is not None:
                base, ex, all_negative = hit
                if all_negative or (negative and flips % 2 == 0):
                    args.append((-base) ** ex)
                    flips += int(ex) % 2
                    continue
            args.append(f)
        return sp.Mul(*args) * (-1) ** flips if flips else e

    def needs(e) -> bool:
        return bool(e.is_Mul) and any(flippable(f) is not None for f in e.args)

    try:
        return expr.replace(needs, fix)
    except (TypeError, ValueError, RecursionError):
        return expr
