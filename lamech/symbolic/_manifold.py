"""Results written on the constraint manifold, as a student would: where a kept constraint
says ``l1 - sqrt(x1^2 + y1^2) = 0``, every ``sqrt(x1^2 + y1^2)`` is ``l1``, ``x1^2 + y1^2``
is ``l1^2`` and, along the motion, ``x1 x1' + y1 y1' = 0``. The Cartesian pendulum's
tension then reads ``m (x1'^2 + y1'^2 - g y1) / l1`` (the textbook's m v^2/l - m g y/l)
instead of a quartic over ``(x1^2 + y1^2)^(3/2)``.

The constraints kept (not used to eliminate a coordinate) define a polynomial ideal:
each one's polynomial form and its time derivative. The numerator and denominator of a
result are replaced by their normal forms modulo a Groebner basis of that ideal (SymPy's
``groebner``; the polynomial reduction is standard, its choice here is not), under a
few variable orders, and the shortest candidate is kept; a result is never made longer.
Every candidate equals the input wherever the kept constraints hold, which is where
the closed forms are used. Bounded: only polynomial relations with few generators,
only expressions below :data:`BUDGET` operations.
"""

from __future__ import annotations

import sympy as sp

from ..model import System
from ..model._kinematics import time_derivative
from ._budget import count_ops
from ._student import student

__all__ = ["manifold_simplifier"]

BUDGET = 200
"""Expressions with more operations than this get no Groebner normal form."""
MAX_OPS = 3000
"""Expressions with more operations than this are left as they are."""
MAX_RELATIONS = 6
"""At most this many polynomial relations (each constraint gives two)."""
MAX_DEGREE = 4
"""Relations of higher total degree are not used (Groebner bases grow fast)."""
MAX_ANGLES = 2
"""At most this many angles (a coordinate or a driven w t) get sine and cosine
generators: a four-bar's three loop angles make Groebner bases that cost seconds and
reductions that cost minutes, for nothing shorter."""


def _radical_rule(f: sp.Expr, coords: set) -> tuple[sp.Expr, sp.Expr] | None:
    """(P, s) when f is linear in one square root sqrt(P) of a polynomial in the
    coordinates and the constraint fixes it to s, free of the coordinates:
    f = l1 - sqrt(x1^2 + y1^2) gives (x1^2 + y1^2, l1)."""
    roots = [
        a for a in f.atoms(sp.Pow) if a.exp == sp.Rational(1, 2) and a.base.free_symbols & coords
    ]
    if len(roots) != 1:
        return None
    (root,) = roots
    u = sp.Dummy("u")
    g = f.xreplace({root: u})
    a, b = sp.diff(g, u), g.xreplace({u: 0})
    if a == 0 or a.has(u) or (a.free_symbols | b.free_symbols) & coords:
        return None
    s = sp.simplify(-b / a)
    return (sp.expand(root.base), s) if s.free_symbols.isdisjoint(coords) else None


class _Manifold:
    def __init__(self, system: System, kept: list[sp.Expr]):
        self.system = system
        coords = set(system.q)
        self.radicals: list[tuple[sp.Expr, sp.Expr]] = []
        relations: list[sp.Expr] = []
        for f in kept:
            rule = _radical_rule(f, coords)
            if rule is not None:
                self.radicals.append(rule)
                P, s = rule
                relations.append(P - s**2)
            else:
                num = sp.numer(sp.together(f))
                if num.free_symbols & coords:
                    relations.append(sp.expand(num))
        # a constraint in an angle (r^2 - (x - a cos(phi))^2 - ...) or driven through one
        # (y cos(w t) = x sin(w t)) is polynomial in its sine and cosine: each becomes a
        # generator, related by s^2 + c^2 = 1
        rates = [sp.expand(time_derivative(r, system)) for r in relations]
        self.angles = _angle_generators(relations + rates, coords, set(system.qd))
        to_gens = self.angles
        gens = [s for s in system.q + system.qd] + list(to_gens.values())
        self.relations: list[sp.Expr] = []
        pairs: dict = {}
        for e, g in to_gens.items():
            pairs.setdefault(e.args[0], {})[e.func] = g
        circles = [d[sp.sin] ** 2 + d[sp.cos] ** 2 - 1 for d in pairs.values() if len(d) == 2]
        for r, r_t in zip(relations, rates):
            r, r_t = (sp.expand(x.xreplace(to_gens)) for x in (r, r_t))
            try:
                p = sp.Poly(r, *gens)
            except sp.PolynomialError:
                continue
            if not p.domain.is_Numerical and not _symbols_only(p):
                continue
            if p.total_degree() > MAX_DEGREE:
                continue
            self.relations += [r, r_t]
        self.relations = [r for r in self.relations if r != 0][:MAX_RELATIONS]
        if self.relations:
            self.relations += circles
        used = set().union(*(r.free_symbols for r in self.relations)) if self.relations else set()
        self.gens = [g for g in gens if g in used]
        positions = [g for g in self.gens if g in coords or g in to_gens.values()]
        velocities = [g for g in self.gens if g not in positions]
        self.orders = (
            [positions + velocities, positions[::-1] + velocities[::-1]] if self.gens else []
        )
        self._bases: dict[frozenset, list] = {}

    def bases(self, symbols: frozenset) -> list:
        """Groebner bases (one per variable order) over the rational functions of
        ``symbols`` (the parameters and whatever else the expression holds)."""
        if symbols not in self._bases:
            domain = sp.QQ.frac_field(*sorted(symbols, key=str)) if symbols else sp.QQ
            out = []
            for order in self.orders:
                try:
                    out.append(sp.groebner(self.relations, *order, order="grevlex", domain=domain))
                except (sp.PolynomialError, sp.CoercionFailed, ValueError):
                    continue
            self._bases[symbols] = out
        return self._bases[symbols]

    def __call__(self, expr: sp.Expr) -> sp.Expr:
        expr = sp.sympify(expr)
        if expr.is_Atom or not (self.radicals or self.orders) or count_ops(expr) > MAX_OPS:
            return expr
        return self._on_manifold(expr)

    def _on_manifold(self, expr: sp.Expr) -> sp.Expr:
        try:
            first = self.radicals_replaced(expr)
            best, score = expr, count_ops(expr)
            candidates = [first]
            if self.orders and count_ops(first) <= BUDGET:
                num, den = sp.fraction(sp.together(first))
                # every parameter in the field, so one basis serves every expression
                # (a basis per set of symbols met cost 8 Groebner bases for a rod in a bowl)
                params = {p.symbol for p in self.system.parameters}
                symbols = (
                    num.free_symbols | den.free_symbols | _symbols(self.relations) | params
                ) - set(self.gens)
                if self.angles:
                    symbols -= {self.system.t}
                candidates += [self._normal(num, den, G) for G in self.bases(frozenset(symbols))]
        except (sp.PolynomialError, sp.CoercionFailed, ValueError, TypeError, RecursionError):
            return expr
        for cand in candidates:
            if cand is None:
                continue
            cand = student(sp.factor_terms(cand))
            ops = count_ops(cand)
            if ops < score:
                best, score = cand, ops
        return best

    def radicals_replaced(self, expr: sp.Expr) -> sp.Expr:
        """``expr`` with each square root a kept constraint fixes replaced by its value
        (sqrt(x1^2 + y1^2) -> l1, (x1^2 + y1^2)^(3/2) -> l1^3): cheap, for any size."""
        for P, s in self.radicals:
            expr = expr.replace(
                lambda e, P=P: (
                    (e.is_Pow and (2 * e.exp).is_Integer and _same(e.base, P))
                    or (e.is_Add and _same(e, P))
                ),
                lambda e, s=s: s ** (2 * e.exp) if e.is_Pow else s**2,
            )
        return expr

    def _normal(self, num: sp.Expr, den: sp.Expr, G) -> sp.Expr | None:
        parts = []
        to_gens = self.angles
        if to_gens:
            num, den = (sp.expand(_expanded_trig(x, to_gens)).xreplace(to_gens) for x in (num, den))
        for part in (num, den):
            if not part.free_symbols & set(self.gens):
                parts.append(part)
                continue
            poly = sp.Poly(sp.expand(part), *self.gens)
            if not _symbols_only(poly):
                return None  # sin(phi) as a coefficient: not over a field of symbols
            _, r = G.reduce(poly.as_expr())
            parts.append(sp.factor(r))
        if parts[1] == 0:
            return None
        out = sp.cancel(parts[0] / parts[1]) if parts[0] != 0 else sp.Integer(0)
        back = {g: e for e, g in to_gens.items()}
        return out.xreplace(back) if back else out


def _angle_generators(exprs: list[sp.Expr], coords: set, velocities: set) -> dict:
    """{sin(w t): S, cos(w t): C, sin(phi): S, ...}: a generator for the sine and the
    cosine of each argument of a trigonometric function in ``exprs`` that is one
    coordinate (the rod's inclination phi in r^2 - (x - a cos(phi))^2 - ...), or free of
    the coordinates and velocities but not of t (the angle through which a constraint
    is driven). Both of a pair are made, so s^2 + c^2 = 1 relates them; the constraints
    are then polynomials in them."""
    moving = coords | velocities
    args: set = set()
    for e in exprs:
        for a in sp.sympify(e).atoms(sp.sin, sp.cos, sp.tan):
            arg = a.args[0]
            if arg in coords or (arg.free_symbols and not arg.free_symbols & moving):
                args.add(arg)
    if len(args) > MAX_ANGLES:  # too many: the driven ones only, if few enough
        args = {a for a in args if a not in coords}
        if len(args) > MAX_ANGLES:
            return {}
    out: dict = {}
    for i, arg in enumerate(sorted(args, key=sp.default_sort_key)):
        out[sp.sin(arg)] = sp.Dummy(f"S{i}")
        out[sp.cos(arg)] = sp.Dummy(f"C{i}")
    return out


def _expanded_trig(e: sp.Expr, to_gens: dict) -> sp.Expr:
    """``e`` with tan of a driven angle written sin/cos (the generators know no tan)."""
    args = {k.args[0] for k in to_gens}
    return e.replace(
        lambda a: isinstance(a, sp.tan) and a.args[0] in args,
        lambda a: sp.sin(a.args[0]) / sp.cos(a.args[0]),
    )


def _same(e: sp.Expr, P: sp.Expr) -> bool:
    """e is the polynomial P (cheap tests first: most subexpressions are not)."""
    return (
        e.is_Add
        and e.free_symbols == P.free_symbols
        and count_ops(e) <= 2 * count_ops(P) + 4
        and sp.expand(e) == P
    )


def _symbols(exprs) -> set:
    return set().union(*(e.free_symbols for e in exprs)) if exprs else set()


def _symbols_only(p: sp.Poly) -> bool:
    """The coefficients are rational functions of symbols (the parameters), so the
    Groebner basis is over a field of fractions."""
    return all(c.is_rational_function() for c in p.coeffs())


def manifold_simplifier(system: System, kept: list[sp.Expr]) -> _Manifold:
    """A callable that writes an expression on the manifold of the holonomic constraints
    ``kept`` (see the module docstring); it returns its input when they give no relation.
    Its ``radicals_replaced`` does only the square roots, for expressions of any size."""
    return _Manifold(system, kept)
