"""Where a unilateral constraint lets go (lambda = 0) and a rolling contact slips
(|lambda_friction| = mu lambda_normal), on the energy shell of a one-degree-of-freedom
motion.

The range searched is the one the motion reaches from the initial state: from the start
in the direction of the initial velocity (of the initial acceleration when at rest;
increasing when at rest at an equilibrium) up to a turning point (q'^2 = 0 on the
shell), then back past the start to the other turning point; an angle that never
turns is followed for one revolution. Roots are listed in the order the motion meets
them. The equation is symbolic where the condition is a polynomial of degree <= 2 in
cos q, sin q or q itself; the value is always numeric (parameters at their values).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..expr import to_text
from ..model import System
from ._integrals import Shell

__all__ = ["Root", "vanishing_points", "slip_points", "is_angle"]

GRID = 4001


@dataclass(frozen=True)
class Root:
    """One root: ``equation`` (text with " = "), the ``coordinate``, its ``value`` in the
    coordinate's units and ``degrees`` (None unless the coordinate is an angle)."""

    equation: str
    coordinate: str
    value: float
    degrees: float | None

    def to_json(self) -> dict:
        return {"equation": self.equation, "coordinate": self.coordinate,
                "value": self.value, "degrees": self.degrees}


def is_angle(system: System, symbol: sp.Symbol) -> bool:
    """True when ``symbol`` appears in the file's L, and only inside sin/cos/tan."""
    L = system.L
    if not L.has(symbol):
        return False
    trig = (sp.sin, sp.cos, sp.tan)
    stripped = L.replace(lambda e: isinstance(e, trig) and e.has(symbol),
                         lambda e: sp.Dummy())
    return not stripped.has(symbol)


def _numeric(system: System, expr: sp.Expr, x: sp.Symbol):
    e = system.numeric(expr)
    f = sp.lambdify([x], e, modules="numpy")

    def call(v):
        with np.errstate(all="ignore"):
            out = np.asarray(f(np.asarray(v, dtype=float)), dtype=float)
        return np.broadcast_to(out, np.shape(v)).copy() if np.ndim(v) else float(out)
    return call


def _segments(system: System, shell: Shell) -> list[tuple[float, float]]:
    """The reached range as ordered (start, end) segments; see module docstring."""
    from scipy.optimize import brentq  # SciPy on use: `import lamech` stays light

    coord = shell.coordinate
    pv = system.parameter_values
    x0 = float(sp.sympify(coord.initial).subs(pv))
    v0 = float(sp.sympify(coord.initial_velocity).subs(pv))
    K = _numeric(system, shell.speed_squared, coord.symbol)
    dK = _numeric(system, sp.diff(shell.speed_squared, coord.symbol), coord.symbol)
    angle = is_angle(system, coord.symbol)
    span = 2 * math.pi if angle else 100.0 * (1.0 + abs(x0) + max(
        (abs(v) for v in pv.values()), default=1.0))
    if v0 != 0:
        direction = 1.0 if v0 > 0 else -1.0
    else:
        slope = dK(x0)
        direction = -1.0 if (math.isfinite(slope) and slope < -1e-12) else 1.0
    scale = max(abs(v0) ** 2, 1e-300)

    def turning(d: float) -> float | None:
        xs = x0 + d * np.linspace(0.0, span, GRID)
        ks = K(xs)
        tol = 1e-12 * max(scale, float(np.nanmax(np.abs(ks[np.isfinite(ks)]), initial=1.0)))
        bad = np.where(~(ks >= -tol))[0]
        bad = bad[bad > 0]
        if not len(bad):
            return None
        i = int(bad[0])
        a, b = xs[i - 1], xs[i]
        try:
            if np.isfinite(ks[i]):
                return brentq(lambda s: K(s), a, b, xtol=1e-14)
        except ValueError:
            pass
        return a

    end = turning(direction)
    if end is None:
        return [(x0, x0 + direction * span)]
    other = turning(-direction)
    back = other if other is not None else x0 - direction * span
    return [(x0, end), (x0, back)]


def _roots(F, a: float, b: float) -> list[float]:
    """Sign changes of F on [a, b], refined, ordered from a towards b."""
    from scipy.optimize import brentq

    if a == b:
        return []
    xs = np.linspace(a, b, GRID)
    ys = F(xs)
    out = []
    for i in range(GRID - 1):
        y0, y1 = ys[i], ys[i + 1]
        if not (np.isfinite(y0) and np.isfinite(y1)):
            continue
        if y0 == 0 and i > 0:
            out.append(float(xs[i]))
        elif y0 * y1 < 0:
            lo, hi = sorted((xs[i], xs[i + 1]))
            out.append(float(brentq(F, lo, hi, xtol=1e-15, rtol=1e-15)))
    return out


def _ordered_roots(system: System, shell: Shell, F) -> list[float]:
    seen: list[float] = []
    for a, b in _segments(system, shell):
        for r in _roots(F, a, b):
            if all(abs(r - s) > 1e-9 for s in seen):
                seen.append(r)
    return seen


def _symbolic_solutions(num: sp.Expr, x: sp.Symbol) -> list[tuple[sp.Expr, sp.Expr]]:
    """(lhs, rhs) pairs with lhs in {cos x, sin x, x} solving num = 0 in closed form."""
    out = []
    for lhs in (sp.cos(x), sp.sin(x), x):
        u = sp.Dummy("u")
        G = num.subs(lhs, u) if lhs is not x else num
        var = u if lhs is not x else x
        if G.has(x) and lhs is not x:
            continue
        try:
            poly = sp.Poly(G, var)
        except sp.PolynomialError:
            continue
        if poly.degree() not in (1, 2) or any(c.has(x) for c in poly.all_coeffs()):
            continue
        for r in sp.roots(poly, multiple=True) or []:
            out.append((lhs, sp.simplify(r)))
        if out:
            return out
    return out


def _label(system, x, root: float, equation: str) -> Root:
    angle = is_angle(system, x.symbol)
    return Root(equation, x.name, root, math.degrees(root) if angle else None)


def vanishing_points(system: System, shell: Shell, name: str) -> list[Root]:
    """Where multiplier ``name`` on the shell reaches zero, in the order reached."""
    lam = shell.multipliers.get(name)
    if lam is None:
        return []
    x = shell.coordinate
    F = _numeric(system, lam, x.symbol)
    roots = _ordered_roots(system, shell, F)
    num = sp.numer(sp.together(lam))
    sols = _symbolic_solutions(num, x.symbol)
    out = []
    pv = system.parameter_values
    for r in roots:
        eq = None
        for lhs, rhs in sols:
            try:
                lv = float(lhs.subs(x.symbol, r))
                rv = complex(rhs.subs(pv).evalf())
            except (TypeError, ValueError):
                continue
            if abs(rv.imag) < 1e-12 and abs(lv - rv.real) < 1e-7 * (1 + abs(lv)):
                eq = f"{to_text(lhs)} = {to_text(rhs)}"
                break
        out.append(_label(system, x, r, eq or f"{to_text(num)} = 0"))
    return out


def slip_points(system: System, shell: Shell, name: str) -> list[Root]:
    """Where |lambda_name| = mu lambda_normal with lambda_normal > 0, in the order reached."""
    con = system.constraint(name)
    fr = con.friction
    if fr is None or name not in shell.multipliers or fr.normal not in shell.multipliers:
        return []
    x = shell.coordinate
    lf, ln = shell.multipliers[name], shell.multipliers[fr.normal]
    Ff = _numeric(system, lf, x.symbol)
    Fn = _numeric(system, ln, x.symbol)
    mu_num = float(system.numeric(fr.mu))

    def G(v):
        n = Fn(v)
        g = np.abs(Ff(v)) - mu_num * n
        return np.where(n > 0, g, np.nan) if np.ndim(v) else (g if n > 0 else float("nan"))

    roots = _ordered_roots(system, shell, G)
    out = []
    for r in roots:
        s = 1 if Ff(r) >= 0 else -1
        ratio = sp.cancel(sp.together(s * lf / ln))
        num, den = sp.fraction(ratio)
        env = {**system.parameter_values, x.symbol: r}
        try:
            if float(den.subs(env)) < 0:
                num, den = -num, -den
        except (TypeError, ValueError):
            pass
        eq = f"{to_text(num)} = {to_text(sp.Mul(fr.mu, den, evaluate=False))}"
        out.append(_label(system, x, r, eq))
    return out
