"""Where a printed closed form divides by what vanishes on the constraint manifold.

A multiplier or reduced acceleration is a quotient; where its denominator is 0 at a
state the motion can have, the form says nothing there, and the output must say where
(issue 43: "no printed form divides by an expression that vanishes on the manifold
without saying where it is singular"). Two kinds of factor are looked at:

* a sine or cosine of one coordinate (the spherical pendulum's phi'' = -2 theta' phi'
  cot(theta), 0 at the pole theta = 0): named as such;
* any other factor of the denominator in the coordinates (and t): the cycloid's
  cos(phi) - 1 at its cusp, the cone's sin(be)^4 (x^2 + y^2) + cos(be)^4 z^2 at its
  apex. A zero on the constraints is sought numerically (least squares on the factor
  and the constraints still kept, from seeded starts; a bounded number of evaluations,
  so the same file gives the same note) and the note gives the point found. A factor
  that keeps its sign there (the ellipse's A^4 h^2 + B^4 u^2) gets none.
"""

from __future__ import annotations

import random
import warnings

import numpy as np
import sympy as sp

from ..expr import to_text
from ..model import System
from ..model._checks import initial_values
from ._budget import count_ops
from ._conditions import is_angle

__all__ = ["singular_notes"]

FACTOR_OPS = 200
"""Denominator factors longer than this (operations) are not searched for zeros."""
STARTS = 12
"""Seeded starting points of the search for a zero of one factor."""
ZERO_TOL = 1e-9
"""A factor below this fraction of its size at the starts is 0 there."""


def singular_notes(system: System, red, forms) -> list[str]:
    """Notes on the printed multipliers and accelerations whose denominators vanish
    where the constraints hold (see the module docstring), one per factor, naming the
    results that divide by it."""
    angles = set(system.q) | {c.symbol for c in system.chart_coordinates}
    printed = [(f"lambda_{k}", v) for k, v in forms.readable_multipliers.items()]
    printed += [
        (f"{c.name}''", forms.accelerations[c.acceleration])
        for c in red.independent
        if c.acceleration in forms.accelerations and not forms.is_long(c.acceleration)
    ]
    named: dict = {}
    for label, expr in printed:
        e = sp.sympify(expr).rewrite(sp.sin) if expr.has(sp.cot, sp.tan, sp.sec, sp.csc) else expr
        try:
            num, den = sp.fraction(sp.together(e))
            if count_ops(den) <= FACTOR_DEN_OPS:
                _, factors = sp.factor_list(den)
                found = [f for f, _ in factors]
            else:
                found = _trig_factors(num, den, angles)
        except (sp.PolynomialError, TypeError, ValueError):
            continue
        for f in found:
            named.setdefault(f, []).append(label)
    notes = []
    zeros = _ZeroSearch(system, red)
    for f, labels in named.items():
        labels = list(dict.fromkeys(labels))
        verb = f"divide{'s' if len(labels) == 1 else ''}"
        subject = "it holds" if len(labels) == 1 else "they hold"
        if isinstance(f, (sp.sin, sp.cos)) and f.args[0] in angles:
            notes.append(
                f"{', '.join(labels)} {verb} by {to_text(f)}: {subject} where "
                f"{to_text(f)} != 0 (these coordinates are singular where it is 0)"
            )
            continue
        where = zeros.find(f)
        if where is not None:
            notes.append(
                f"{', '.join(labels)} {verb} by {to_text(f)}, which is 0 where the "
                f"constraints hold ({where}, for one): {subject} where it is not 0 (the "
                "form has no value there)"
            )
    return notes


FACTOR_DEN_OPS = 200
"""Denominators up to this many operations are factored; a larger one (a rolling
sphere's multipliers: 1 s each in ``factor_list``) is tested for each sine and cosine
factor by where it vanishes."""


def _trig_factors(num: sp.Expr, den: sp.Expr, angles: set) -> list:
    """The sin(x), cos(x) of the coordinates ``x`` in ``angles`` that divide a long
    ``den`` (past :data:`FACTOR_DEN_OPS`): those at whose two zeros (x = 0, pi
    for a sine; +-pi/2 for a cosine) ``den`` vanishes at a generic value of every other
    symbol, as a factor does (and 1 - sin^2 does too), while ``num`` does not there (a
    rolling sphere's 0/0, which has a limit, is no singularity)."""
    rng = random.Random(5)
    free = sorted(den.free_symbols, key=str)
    point = {x: sp.Float(0.3 + 0.5 * rng.random(), 30) for x in free}
    scale = abs(complex(sp.N(den.xreplace(point), 30)))
    if not scale:
        return []
    out = []
    for x in sorted(angles & den.free_symbols, key=str):
        for trig, zeros in ((sp.sin, (0, sp.pi)), (sp.cos, (sp.pi / 2, -sp.pi / 2))):
            if not den.has(trig(x)):
                continue
            at = [{**point, x: z} for z in zeros]
            dens = [abs(complex(sp.N(den.xreplace(p), 30))) for p in at]
            if any(v > 1e-15 * scale for v in dens):
                continue
            nums = [abs(complex(sp.N(num.xreplace(p), 30))) for p in at]
            top = abs(complex(sp.N(num.xreplace(point), 30)))
            if all(v > 1e-15 * top for v in nums):
                out.append(trig(x))
    return out


class _ZeroSearch:
    """Zeros of a denominator factor on the constraints still kept after the
    elimination, in the reduced coordinates (and t); a point where an eliminated
    coordinate is not real is no point of the manifold."""

    def __init__(self, system: System, red) -> None:
        self.system = system
        self.red = red
        self.pv = system.parameter_values
        coords = {c.symbol for c in red.independent} | {c.symbol for c in system.coordinates}
        self.state = coords | {system.t}
        self.kept = [
            red.apply(c.expr)
            for c in system.constraints
            if c.holonomic and c.name not in red.eliminated_constraints
        ]
        try:
            start = initial_values(system)
        except (TypeError, ValueError):
            start = {}
        self.start = {k: float(v) for k, v in start.items() if k in self.state}

    def find(self, f: sp.Expr) -> str | None:
        """ "x = 0, y = 0" where ``f`` is 0 on the constraints, or None when none is
        found (or f holds no coordinate, or is too long to search)."""
        here = f.free_symbols & self.state
        if not here or count_ops(f) > FACTOR_OPS or _positive(f.xreplace(self.pv)):
            return None
        kept = [g for g in self.kept if g.free_symbols & self.state]
        xs = sorted(here.union(*(g.free_symbols & self.state for g in kept)), key=str)
        try:
            fun = sp.lambdify([xs], [e.xreplace(self.pv) for e in [f, *kept]], modules="numpy")
            subs = [  # the eliminated coordinates these fix (the others take any value)
                sp.lambdify([xs], e.xreplace(self.pv), modules="numpy")
                for e in self.red.position_substitution.values()
                if e.free_symbols & self.state and e.free_symbols & self.state <= set(xs)
            ]
        except (TypeError, ValueError, SyntaxError):
            return None

        def residual(x):
            return np.asarray(fun(x), dtype=float).reshape(-1)

        from scipy.optimize import least_squares

        rng = random.Random(17)
        found = None
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            starts = [self._start(xs, rng) for _ in range(STARTS)]
            sizes = [abs(residual(x)[0]) for x in starts]
            size = float(np.median([s for s in sizes if np.isfinite(s)] or [1.0])) or 1.0
            for x0 in starts:
                try:
                    r = least_squares(residual, x0, xtol=1e-15, ftol=1e-15, gtol=1e-15,
                                      max_nfev=200 * (1 + len(xs)))  # fmt: skip
                    res = residual(r.x)
                except (ValueError, TypeError, ZeroDivisionError, np.linalg.LinAlgError):
                    continue
                if not np.all(np.isfinite(res)) or abs(res[0]) > ZERO_TOL * size:
                    continue
                if np.any(np.abs(res[1:]) > 1e-9 * (1 + np.abs(r.x).max())):
                    continue
                if not all(_real_at(s, r.x) for s in subs):
                    continue
                found = r.x
                # a quadratic zero (the apex) is found to 1e-5 only: 0 where 0 is one
                snapped = np.where(np.abs(found) < 1e-4, 0.0, found)
                back = residual(snapped)
                if np.all(np.isfinite(back)) and np.all(np.abs(back) <= np.abs(res) + 1e-12):
                    found = snapped
                break
        if found is None:
            return None
        return ", ".join(f"{x} = {_short(v, x, self.system)}" for x, v in zip(xs, found))

    def _start(self, xs, rng: random.Random) -> np.ndarray:
        out = []
        for x in xs:
            if x == self.system.t or is_angle(self.system, x):
                out.append(rng.uniform(-np.pi, np.pi))
            else:
                a = self.start.get(x, 0.0)
                out.append(a + rng.uniform(-1.5, 1.5) * (1 + abs(a)))
        return np.array(out, dtype=float)


def _positive(f: sp.Expr) -> bool:
    """``f`` (numbers for the parameters) is positive in every state by its form: with
    each even power of a cosine written in the sine (cos^2 = 1 - sin^2), a positive
    number plus terms that are each a positive number times even powers (a double
    pendulum's m1 + m2 sin^2(theta1 - theta2)). Such a factor has no zero to seek, and
    seeking it costs a process SciPy's optimiser (a third of a second to import)."""

    def even_cos(e):
        return e.is_Pow and isinstance(e.base, sp.cos) and e.exp.is_Integer and e.exp % 2 == 0

    try:
        g = sp.expand(
            f.replace(even_cos, lambda e: (1 - sp.sin(e.base.args[0]) ** 2) ** (e.exp // 2))
        )
    except (TypeError, ValueError, RecursionError):
        return False
    constant = False
    for term in sp.Add.make_args(g):
        coeff, rest = term.as_coeff_Mul()
        if not (coeff.is_number and coeff > 0):
            return False
        if rest == 1:
            constant = True
            continue
        for factor in sp.Mul.make_args(rest):
            base, exp = factor.as_base_exp()
            if not (exp.is_Integer and exp % 2 == 0) and not (base.is_number and base > 0):
                return False
    return constant


def _real_at(fn, x) -> bool:
    """``fn(x)`` is a finite real number (an eliminated coordinate exists there)."""
    try:
        v = complex(fn(x))
    except (TypeError, ValueError, ZeroDivisionError):
        return False
    return bool(np.isfinite(v) and abs(v.imag) < 1e-9)


def _short(v: float, x, system: System) -> str:
    """A zero as read: an angle reduced to (-pi, pi], 4 digits, no -0."""
    if x != system.t and is_angle(system, x):
        v = (v + np.pi) % (2 * np.pi) - np.pi
    return f"{v + 0.0:.4g}" if abs(v) >= 1e-12 else "0"
