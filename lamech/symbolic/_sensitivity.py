"""How an event angle moves with the parameters: implicit differentiation of the
closed-form condition at its root.

A lift-off angle x* is a root of F(x, p) = lambda(x, p) = 0 on the energy shell, a slip
angle one of F = s lambda_friction - mu lambda_normal (s the sign of the friction
multiplier there); by the implicit function theorem

.. math:: \\frac{dx^*}{dp} = -\\frac{\\partial F / \\partial p}{\\partial F / \\partial x}
   \\Big|_{x = x^*},

undefined where dF/dx = 0 (a double root: the event appears or disappears there).

The parameters differentiated by are the *free* ones: those the problem file gives a
number (a parameter written as an expression of others follows them, its expression
substituted), and each friction coefficient written as a number, under the name
:func:`friction_parameters` gives it (``mu``; ``mu:<constraint>`` when several).
"""

from __future__ import annotations

import math

import sympy as sp

from ..model import System
from ._budget import count_ops

EXPAND_OPS = 400
"""Derivatives up to this size are expanded to tell a cancellation from a value."""

__all__ = [
    "free_parameters",
    "friction_parameters",
    "friction_mu",
    "in_free_parameters",
    "root_sensitivity",
]


def _free(system: System) -> list:
    return [p for p in system.parameters if sp.sympify(p.value).is_Number]


def friction_parameters(system: System) -> dict[str, tuple[str, sp.Symbol, float]]:
    """{constraint name: (label, symbol, value)} for each friction coefficient the file
    gives as a number, labelled as :func:`lamech.model.with_values` (and ``--param``)
    name it: ``mu`` when the problem has one friction constraint and no parameter so
    named, else ``mu:<constraint>``."""
    friction = [c for c in system.constraints if c.friction is not None]
    single = len(friction) == 1 and "mu" not in {p.name for p in system.parameters}
    out = {}
    for c in friction:
        mu = c.friction.mu if c.friction is not None else None
        if mu is None or not sp.sympify(mu).is_Number:
            continue
        label = "mu" if single else f"mu:{c.name}"
        out[c.name] = (label, sp.Symbol(f"{label} (friction)", real=True), float(mu))
    return out


def free_parameters(system: System) -> list[tuple[str, sp.Symbol, float]]:
    """(name, symbol, value) of every free parameter (module docstring), the file's
    order, then the friction coefficients."""
    out = [(p.name, p.symbol, float(p.numeric)) for p in _free(system)]
    return out + list(friction_parameters(system).values())


def in_free_parameters(system: System, expr: sp.Expr) -> sp.Expr:
    """``expr`` with every parameter written as an expression of others replaced by that
    expression (repeatedly: chains are followed), so that only free ones remain."""
    derived = {
        p.symbol: sp.sympify(p.value)
        for p in system.parameters
        if not sp.sympify(p.value).is_Number
    }
    out = sp.sympify(expr)
    for _ in range(len(derived) + 1):
        if not (out.free_symbols & set(derived)):
            return out
        out = out.xreplace(derived)
    raise ValueError("parameters defined in a cycle: " + ", ".join(str(s) for s in derived))


def friction_mu(system: System, name: str) -> sp.Expr:
    """The friction coefficient of constraint ``name`` in the free parameters (a number
    written in the file becomes its symbol from :func:`friction_parameters`)."""
    fr = system.constraint(name).friction
    if fr is None:
        raise ValueError(f"constraint `{name}` has no friction")
    pseudo = friction_parameters(system)
    if name in pseudo:
        return pseudo[name][1]
    return in_free_parameters(system, fr.mu)


def root_sensitivity(
    system: System, F: sp.Expr, x: sp.Symbol, root: float
) -> dict[str, float | None]:
    """{parameter: dx*/dp} at the root ``root`` of F(x, p) = 0, every free parameter
    (None where dF/dx = 0 there, or a value is not finite)."""
    F = in_free_parameters(system, F)
    free = free_parameters(system)
    env = {s: sp.Float(v) for _, s, v in free}
    env[x] = sp.Float(root)

    def value(e: sp.Expr) -> float:
        """e at the root; 0 where its terms cancel to rounding (dF/dm = F/m = 0)."""
        e = sp.sympify(e)
        terms = sp.Add.make_args(sp.expand(e)) if count_ops(e) <= EXPAND_OPS else (e,)
        total, size = 0.0, 0.0
        for term in terms:
            try:
                v = complex(sp.sympify(term).xreplace(env).evalf())
            except (TypeError, ValueError):
                return math.nan
            if abs(v.imag) > 1e-12 * (1 + abs(v.real)):
                return math.nan
            total, size = total + v.real, size + abs(v.real)
        return 0.0 if abs(total) <= 1e-13 * size else total

    Fx = value(sp.diff(F, x))
    out: dict[str, float | None] = {}
    for name, sym, _ in free:
        Fp = value(sp.diff(F, sym)) if F.has(sym) else 0.0
        if not (math.isfinite(Fx) and math.isfinite(Fp)) or Fx == 0:
            out[name] = None
            continue
        d = -Fp / Fx
        out[name] = 0.0 if d == 0 else d
    return out
