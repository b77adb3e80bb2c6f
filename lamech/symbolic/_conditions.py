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
from dataclasses import dataclass, field, replace

import numpy as np
import sympy as sp

from ..expr import to_text
from ..model import System
from ._budget import count_ops
from ._integrals import Shell
from ._normal import normal
from ._sensitivity import friction_mu, root_sensitivity
from ._student import has_big_integer, student

__all__ = [
    "Root",
    "Verdict",
    "vanishing_points",
    "sign_change_note",
    "closing_points",
    "slip_points",
    "is_angle",
    "lets_go_verdict",
    "slip_verdict",
]

GRID = 4001


@dataclass(frozen=True)
class Root:
    """One root: ``equation`` (text with " = "), the ``coordinate``, its ``value`` in the
    coordinate's units and ``degrees`` (None unless the coordinate is an angle);
    ``sensitivity`` its derivative by each free parameter, {name: d value / d name}
    (None where undefined: a double root), by implicit differentiation of the closed
    form (:mod:`lamech.symbolic._sensitivity`); given for the first root of a list (the
    event), empty for the later ones (where it would have happened had it still held)."""

    equation: str
    coordinate: str
    value: float
    degrees: float | None
    sensitivity: dict = field(default_factory=dict, compare=False)

    def to_json(self) -> dict:
        return {
            "equation": self.equation,
            "coordinate": self.coordinate,
            "value": self.value,
            "degrees": self.degrees,
            "sensitivity": dict(self.sensitivity),
        }


def is_angle(system: System, symbol: sp.Symbol) -> bool:
    """True when ``symbol`` appears in the file's L, and only inside sin/cos/tan; a
    chart's coordinate through the chart (x = l sin(theta) makes theta an angle)."""
    L = system.L
    if system.chart is not None and symbol in system.chart.symbols:
        L = L.xreplace(system.chart.substitution)
    if not L.has(symbol):
        return False
    trig = (sp.sin, sp.cos, sp.tan)
    stripped = L.replace(lambda e: isinstance(e, trig) and e.has(symbol), lambda e: sp.Dummy())
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
    coord = shell.coordinate
    pv = system.parameter_values
    x0 = float(sp.sympify(coord.initial).subs(pv))
    v0 = float(sp.sympify(coord.initial_velocity).subs(pv))
    K = _numeric(system, shell.speed_squared, coord.symbol)
    dK = _numeric(system, sp.diff(shell.speed_squared, coord.symbol), coord.symbol)
    angle = is_angle(system, coord.symbol)
    span = (
        2 * math.pi
        if angle
        else 100.0 * (1.0 + abs(x0) + max((abs(v) for v in pv.values()), default=1.0))
    )
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
                return _bracketed_root(K, a, b)
        except ValueError:
            pass
        return a

    end = turning(direction)
    if end is None:
        return [(x0, x0 + direction * span)]
    other = turning(-direction)
    back = other if other is not None else x0 - direction * span
    return [(x0, end), (x0, back)]


def _bracketed_root(F, a: float, b: float) -> float:
    """The root of F in [a, b], where F(a) and F(b) differ in sign, to the last bit.

    Written here rather than taken from SciPy: importing ``scipy.optimize`` costs 0.7-1.8 s
    of CPU (it parses every docstring of the package), more than solving the lecture's
    cylinder, and only a bracketed root is needed. Regula falsi with the Illinois
    modification converges superlinearly; a bisection every third step bounds the count
    of evaluations (about 70 at most), and the answer depends on F alone, never on timing.
    """
    fa, fb = float(F(a)), float(F(b))
    if fa == 0:
        return float(a)
    if fb == 0:
        return float(b)
    if (fa > 0) == (fb > 0):
        raise ValueError("F(a) and F(b) must differ in sign")
    side = 0
    for step in range(200):
        if step % 3 == 2 or not (math.isfinite(fa) and math.isfinite(fb)):
            c = 0.5 * (a + b)
        else:
            c = (a * fb - b * fa) / (fb - fa)
            if not (min(a, b) < c < max(a, b)):
                c = 0.5 * (a + b)
        if c in (a, b) or abs(b - a) <= 4e-16 * max(abs(a), abs(b), 1e-300):
            break
        fc = float(F(c))
        if fc == 0:
            return float(c)
        if (fc > 0) == (fb > 0):
            b, fb = c, fc
            if side == -1:
                fa *= 0.5
            side = -1
        else:
            a, fa = c, fc
            if side == 1:
                fb *= 0.5
            side = 1
    return float(a if abs(fa) < abs(fb) else b)


def _roots(F, a: float, b: float) -> list[float]:
    """Sign changes of F on [a, b], refined, ordered from a towards b."""
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
            out.append(_bracketed_root(F, lo, hi))
    return out


def _ordered_roots(system: System, shell: Shell, F) -> list[float]:
    seen: list[float] = []
    for a, b in _segments(system, shell):
        for r in _roots(F, a, b):
            if all(abs(r - s) > 1e-9 for s in seen):
                seen.append(r)
    return seen


def _symbolic_solutions(num: sp.Expr, x: sp.Symbol) -> list[tuple[sp.Expr, sp.Expr]]:
    """(lhs, rhs) pairs with lhs in {cos x, sin x, x} solving num = 0 in closed form, for
    each factor of num that has x (3 g m (3 sin x - 2 sin a) cos x: sin x = 2 sin(a)/3
    and cos x = 0)."""
    try:
        factors = [f for f, _ in sp.factor_list(num)[1] if f.has(x)]
    except (sp.PolynomialError, TypeError, ValueError, NotImplementedError, RecursionError):
        factors = [num]
    out = []
    for factor in factors or [num]:
        out += _factor_solutions(factor, x)
    return out


def _factor_solutions(num: sp.Expr, x: sp.Symbol) -> list[tuple[sp.Expr, sp.Expr]]:
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
            out.append((lhs, student(normal(r))))
        if out:
            return out
    return out


def _label(system, x, root: float, equation: str) -> Root:
    angle = is_angle(system, x.symbol)
    if abs(root) < 1e-14:
        root = 0.0  # a root at zero, found to rounding (4e-19)
    return Root(equation, x.name, root, math.degrees(root) if angle else None)


def _with_sensitivity(system: System, root: Root, F: sp.Expr, x: sp.Symbol) -> Root:
    """``root`` with its derivative by each free parameter (F(x, p) = 0 there)."""
    return replace(root, sensitivity=root_sensitivity(system, F, x, root.value))


def vanishing_points(system: System, shell: Shell, name: str) -> list[Root]:
    """Where multiplier ``name`` on the shell reaches zero, in the order reached."""
    lam = shell.multipliers.get(name)
    if lam is None:
        return []
    return _zeros(system, shell, lam)


def sign_change_note(system: System, shell: Shell, name: str, start: float | None) -> str | None:
    """What to say of bilateral constraint ``name`` when its multiplier on the energy
    shell changes sign where the motion goes (found as :func:`vanishing_points` finds
    where a unilateral one lets go); None when it keeps its sign, or when the
    constraint is a rolling or friction constraint, a velocity constraint or a drive (its
    f depends on t): their multipliers change sign without anything letting go.
    ``start``: the multiplier's value at the initial state, if known.

    A rod, or a bead threaded on a wire, holds both ways; a string or a one-sided contact
    (a particle on a sphere, the student's forgotten ``unilateral = true``) lets go at
    the first root, and that is what the note says: the particle released at rest at
    theta0 from the top of a smooth sphere, f = r - R, leaves it where
    cos(theta) = 2 cos(theta0)/3."""
    con = system.constraint(name)
    if con.unilateral or not con.holonomic or con.friction is not None or con.expr.has(system.t):
        return None
    if any(c.friction is not None and c.friction.normal == name for c in system.constraints):
        return None  # a normal force: the friction hint (lamech.model._hints) speaks of it
    if _defines_a_coordinate(system, con.expr):
        return None  # x - a (s + sin(s)): a point of a curve, not a contact or a string
    lam = shell.multipliers.get(name)
    if lam is None:
        return None
    F = _numeric(system, lam, shell.coordinate.symbol)
    roots = [r for r in vanishing_points(system, shell, name) if _crosses(F, r.value)]
    if not roots:
        return None  # no root, or a zero it touches without crossing (lambda = 0 throughout)
    r = roots[0]
    deg = f" ({r.degrees:.2f}°)" if r.degrees is not None else ""
    lam = f"lambda_{name}"
    was = f" (it is {start + 0.0:.6g} at the start)" if start is not None else ""
    return (
        f"`{name}` is bilateral and {lam} changes sign along the motion{was}: on the "
        f"energy shell it is 0 where {r.equation}, {r.coordinate} = {r.value:.10g}{deg}, "
        "and has the other sign beyond. A rod, or a bead threaded on a wire, holds both "
        "ways; a string or a one-sided contact would let go there. If "
        f"`{name}` is one, write f with its allowed side f >= 0 and set "
        "unilateral = true: lamech then gives where it lets go, and simulate follows the "
        "flight"
    )


def _defines_a_coordinate(system: System, f: sp.Expr) -> bool:
    """f = a x - g(the other coordinates) with a constant a and g not linear in them: a
    parametric curve or surface written as constraints (the helix's x - Rh cos(s), the
    cycloid's x - a (s + sin(s))), whose multiplier is a force component that changes
    sign as the point moves along it; a string (l - y1 - y2), a contact (r - R) or a
    circle (x^2 + y^2 - l^2) is not one."""
    q = list(system.q)
    for x in q:
        a = sp.diff(f, x)
        if a == 0 or a.free_symbols & (set(q) | {system.t}):
            continue
        g = sp.expand(a * x - f)
        others = [y for y in q if y != x and g.has(y)]
        if others and not all(sp.diff(g, y).free_symbols.isdisjoint(q) for y in others):
            return True
    return False


def _crosses(F, x: float) -> bool:
    """F has opposite signs, both nonzero, just before and just after ``x``."""
    h = 1e-6 * (1.0 + abs(x))
    a, b = F(x - h), F(x + h)
    return bool(math.isfinite(a) and math.isfinite(b) and a * b < 0)


def closing_points(system: System, shell: Shell, f: sp.Expr, reduction) -> list[Root] | None:
    """Where an open contact's gap ``f`` (in the full coordinates; ``reduction`` brings
    it to the independent one) reaches zero along the shell's motion, in the order
    reached; None when f depends on more of the state than the shell's coordinate."""
    gap = tidy_light(reduction.apply(f))
    if gap.free_symbols & (_state_symbols(system) - {shell.coordinate.symbol}):
        return None
    return _zeros(system, shell, gap)


def _zeros(system: System, shell: Shell, expr: sp.Expr) -> list[Root]:
    """Where ``expr`` (a function of the shell's coordinate) is zero along the motion,
    each with its equation in closed form where one is found."""
    x = shell.coordinate
    F = _numeric(system, expr, x.symbol)
    roots = _ordered_roots(system, shell, F)
    num = sp.numer(sp.together(expr))
    sols = _symbolic_solutions(num, x.symbol)
    out: list[Root] = []
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
        root = _label(system, x, r, eq or f"{to_text(num)} = 0")
        out.append(_with_sensitivity(system, root, expr, x.symbol) if not out else root)
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
    out: list[Root] = []
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
        if has_big_integer(num) or has_big_integer(den):
            # a small initial value's denominator cleared: 10000 g sin = 3 (70000 g ...)
            num, den = student(s * lf), student(ln)
        eq = f"{to_text(num)} = {to_text(sp.Mul(fr.mu, den, evaluate=False))}"
        F = s * lf - friction_mu(system, name) * ln
        root = _label(system, x, r, eq)
        out.append(_with_sensitivity(system, root, F, x.symbol) if not out else root)
    return out


# ----- verdicts: at the start, never, the roots, or not determined ---------------------
@dataclass(frozen=True)
class Verdict:
    """The answer to "does constraint ``name`` let go (``kind`` "lets go") / start to slip
    (``kind`` "slips")?" beyond the list of roots.

    ``when`` is "at the start" (lost at the initial state already), "never" (shown for
    every state the motion reaches: a constant multiplier, or no root in the reached
    range), "at the roots" (see the Root list) or "not determined" (no energy shell);
    ``reason`` says why in words and numbers, ``condition`` the inequality on the
    parameters under which the constraint holds at the start (None when it does not
    depend on them), ``hint`` what to check when the sign suggests a constraint written
    the wrong way round.
    """

    kind: str
    when: str
    reason: str
    condition: str | None = None
    hint: str | None = None
    constant: bool = False  # decided by a multiplier (or ratio) constant along the motion

    def to_json(self) -> dict:
        return {
            "when": self.when,
            "reason": self.reason,
            "condition": self.condition,
            "hint": self.hint,
            "constant": self.constant,
        }


def _state_symbols(system: System) -> set:
    """The symbols of the state: coordinates, velocities and t, the chart's too (a
    multiplier in the chart's angle psi is not constant)."""
    chart = system.chart_coordinates
    return (
        set(system.q)
        | set(system.qd)
        | {c.symbol for c in chart}
        | {c.velocity for c in chart}
        | {system.t}
    )


def _at_start(system: System, expr: sp.Expr) -> tuple[sp.Expr, float | None]:
    """``expr`` at the initial state: symbolic in the parameters, and its value."""
    at0 = tidy_light(sp.sympify(expr).xreplace({**system.initial_state, system.t: 0}))
    try:
        value = complex(at0.xreplace(system.parameter_values).evalf())
    except (TypeError, ValueError):
        return at0, None
    if abs(value.imag) > 1e-12 * (1 + abs(value.real)):
        return at0, None
    return at0, value.real


def tidy_light(expr: sp.Expr) -> sp.Expr:
    """A cheap simplification for conditions (bounded by size and counted work)."""
    if count_ops(expr) > 200:
        return expr
    return student(normal(expr))


def _at_least_zero(expr: sp.Expr) -> str:
    """``expr >= 0`` as a student states it: positive factors (a mass, g) dropped, the
    negative terms moved to the right: m (g - 16 R) >= 0 reads g >= 16 R."""
    e = sp.factor_terms(expr)
    coeff, factors = e.as_coeff_mul()
    if coeff.is_negative:
        return f"{to_text(expr)} >= 0"
    kept = [f for f in factors if not f.is_positive]
    rest = sp.Mul(*kept)
    if len(kept) == 1 and rest.is_Add:
        right = [-t for t in rest.args if t.could_extract_minus_sign()]
        left = [t for t in rest.args if not t.could_extract_minus_sign()]
        if left and right:
            return f"{to_text(sp.Add(*left))} >= {to_text(sp.Add(*right))}"
    return f"{to_text(rest)} >= 0" if kept else f"{to_text(expr)} >= 0"


POSITIVE_OPS = 200
"""Multipliers up to this size are tested for being positive in every state."""


def positive_everywhere(expr: sp.Expr, system: System) -> bool:
    """Whether ``expr`` is positive for every real state and the parameters' signs as
    their values have them (a m (a g + x'^2 + y'^2) / (a^2 + x^2 + y^2) with a, m, g > 0):
    SymPy's assumptions on the expression with each parameter a positive or negative
    symbol and each state symbol real. Bounded by size (:data:`POSITIVE_OPS`)."""
    expr = sp.sympify(expr)
    if count_ops(expr) > POSITIVE_OPS or not expr.free_symbols & _state_symbols(system):
        return False
    signs: dict = {}
    for s, v in system.parameter_values.items():
        try:
            x = float(v)
        except (TypeError, ValueError):
            return False
        if x == 0:
            continue
        signs[s] = sp.Dummy(s.name, positive=True) * (1 if x > 0 else -1)
    for s in _state_symbols(system):
        signs[s] = sp.Dummy(s.name, real=True)
    try:
        return bool(expr.xreplace(signs).is_positive)
    except (TypeError, ValueError, RecursionError):
        return False


def _depends_on_parameters(expr: sp.Expr, system: System) -> bool:
    return bool(expr.free_symbols & {p.symbol for p in system.parameters})


def lets_go_verdict(
    system: System,
    name: str,
    multiplier: sp.Expr | None,
    roots: list[Root],
    shell_reason: str | None,
    resting: bool = False,
) -> Verdict:
    """Whether and where unilateral constraint ``name`` lets go (lambda < 0 or = 0).
    ``resting``: the system stays at its initial state (at rest in equilibrium), so the
    answer at the start is the answer for all time."""
    kind = "lets go"
    if multiplier is None:
        return Verdict(kind, "not determined", shell_reason or "no closed-form multiplier")
    lam0, value = _at_start(system, multiplier)
    lam_name = f"lambda_{name}"
    scale = 1e-12 * (1 + max((abs(v) for v in system.parameter_values.values()), default=1))
    constant = not (sp.sympify(multiplier).free_symbols & _state_symbols(system))
    cond = _at_least_zero(lam0) if _depends_on_parameters(lam0, system) else None
    if cond and sp.sympify(lam0).is_negative:
        cond = None  # -g*m >= 0: no positive parameters meet it (said as such elsewhere)
    if value is not None and value < -scale:
        at_rest = all(
            sp.sympify(c.initial_velocity).xreplace(system.parameter_values) == 0
            for c in system.coordinates
        )
        hint = None
        if at_rest:
            hint = (
                f"at rest the constraint would have to pull ({lam_name} < 0): if it is "
                "meant to push or hold (a floor, a taut string), it is written the wrong "
                "way round; write f with its allowed side f >= 0 (e.g. l - r for a "
                "string of length l)"
            )
        return Verdict(
            kind,
            "at the start",
            f"{lam_name} = {value:.6g} < 0 at the initial "
            f"state ({lam_name} = {to_text(lam0)} there)",
            cond,
            hint,
        )
    if constant and value is not None:
        return Verdict(
            kind,
            "never",
            f"{lam_name} is constant: {to_text(multiplier)} = {value:.6g} > 0",
            cond,
            constant=True,
        )
    if value is not None and positive_everywhere(multiplier, system):
        return Verdict(
            kind,
            "never",
            f"{lam_name} = {to_text(multiplier)} > 0 in every state (a sum of positive "
            "terms and squares, over a positive denominator)",
            cond,
            constant=True,  # for all time, as a constant lambda
        )
    if resting and value is not None:
        return Verdict(
            kind,
            "never",
            f"at rest in equilibrium, {lam_name} keeps its initial value "
            f"{to_text(lam0)} = {value:.6g} > 0",
            cond,
            constant=True,
        )
    if roots:
        return Verdict(kind, "at the roots", f"{lam_name} = 0 where the motion reaches it", cond)
    if shell_reason is None:
        return Verdict(kind, "never", f"{lam_name} > 0 in the whole range the motion reaches", cond)
    return Verdict(kind, "not determined", shell_reason, cond)


def slip_verdict(
    system: System,
    name: str,
    multipliers: dict,
    roots: list[Root],
    shell_reason: str | None,
    resting: bool = False,
) -> Verdict:
    """Whether and where friction constraint ``name`` starts to slip (|lambda| > mu N);
    ``resting`` as in :func:`lets_go_verdict`."""
    kind = "slips"
    fr = system.constraint(name).friction
    lf, ln = multipliers.get(name), multipliers.get(fr.normal) if fr else None
    if fr is None or lf is None or ln is None:
        return Verdict(kind, "not determined", shell_reason or "no closed-form multiplier")
    lf0, f_value = _at_start(system, lf)
    ln0, n_value = _at_start(system, ln)
    mu = sp.sympify(fr.mu)
    try:
        mu_value = float(mu.xreplace(system.parameter_values))
    except (TypeError, ValueError):
        return Verdict(kind, "not determined", "mu is not a number at the parameter values")
    if f_value is None or n_value is None or n_value <= 0:
        return Verdict(
            kind,
            "not determined",
            f"the normal force lambda_{fr.normal} is not positive at the start"
            if n_value is not None
            else "the multipliers cannot be evaluated at the start",
        )
    sign = 1 if f_value >= 0 else -1
    ratio0 = tidy_light(sign * lf0 / ln0)
    ratio_value = abs(f_value) / n_value
    cond = (
        f"{to_text(fr.mu)} >= {to_text(ratio0)}"
        if _depends_on_parameters(ratio0, system) or _depends_on_parameters(mu, system)
        else None
    )
    ratio = sp.sympify(lf) / sp.sympify(ln)
    constant = not (ratio.free_symbols & _state_symbols(system))
    needed = f"|lambda_{name}|/lambda_{fr.normal} = {to_text(ratio0)} = {ratio_value:.6g}"
    if ratio_value > mu_value * (1 + 1e-12):
        return Verdict(
            kind,
            "at the start",
            f"{needed} > mu = {mu_value:.6g} at the "
            "initial state: the friction needed exceeds mu N",
            cond,
        )
    if constant or resting:
        why = "the ratio is constant" if constant else "at rest in equilibrium"
        return Verdict(
            kind,
            "never",
            f"{why}: {needed} <= mu = {mu_value:.6g}",
            cond,
            constant=True,
        )
    if roots:
        return Verdict(
            kind,
            "at the roots",
            f"|lambda_{name}| = mu lambda_{fr.normal} where the motion reaches it",
            cond,
        )
    if shell_reason is None:
        return Verdict(
            kind,
            "never",
            f"|lambda_{name}| < mu lambda_{fr.normal} in the whole range the motion reaches",
            cond,
        )
    return Verdict(kind, "not determined", shell_reason, cond)
