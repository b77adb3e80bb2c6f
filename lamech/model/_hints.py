"""Warnings about a system that is valid but probably not what its author meant, said
once in its ``notes`` (:func:`hints`; recomputed whenever a System is made, so new values
given with ``with_values`` are judged, and a warning about old ones is dropped):

* an angle of a whole number of degrees written as radians: a parameter or an initial
  value of 30, 45, 90 that enters sin, cos or tan as an angle (``sin(alpha)``,
  ``cos(theta1 - theta2)``, not the ``w`` of ``cos(w*t)``);
* friction whose normal is a bilateral constraint: its multiplier can pull, so mu N
  bounds the friction by |N| of a force that may hold the bodies together;
* gravity that pulls up: V linear in a coordinate with the slope of a weight taken with
  the wrong sign, -m*g (see :func:`gravity_hints` for the rule);
* a zero mass the constraints carry: a parameter that is 0 and multiplies a velocity
  squared in T (see :func:`zero_mass_hints`; when nothing carries it the file is refused,
  :mod:`lamech.model._start`).
"""

from __future__ import annotations

import math

import sympy as sp

from ..expr import to_text

__all__ = ["hints", "degree_hints", "gravity_hints", "zero_mass_hints", "is_hint"]

_GIVEN: set[str] = set()
"""Every hint text made in this process (a System's old hints are recognised by it)."""


def is_hint(note: str) -> bool:
    return note in _GIVEN


def _said(text: str) -> str:
    _GIVEN.add(text)
    return text


def hints(system) -> list[str]:
    """The warnings of the module docstring for ``system`` at its own values."""
    return (
        _friction_hints(system)
        + degree_hints(system)
        + gravity_hints(system)
        + zero_mass_hints(system)
    )


def _gravity_symbols(system) -> set:
    """The parameters that are the acceleration of gravity: one named g (G, g0, grav,
    gravity), and those of the system's own [gravity] acceleration."""
    out = {
        p.symbol
        for p in system.parameters
        if p.name.lower() in ("g", "g0", "grav", "gravity") and isinstance(p.symbol, sp.Symbol)
    }
    if system.gravity is not None:
        out |= sp.sympify(system.gravity).free_symbols
    return out


def _positive_weight(c: sp.Expr, system, gravity: set) -> bool:
    """``c`` is a weight: a positive number times parameters, each positive at its value,
    one of them gravity's (m*g, (m1 + m2)*g is not: a sum is a modelling choice)."""
    coeff, factors = sp.sympify(c).as_coeff_mul()
    if not (coeff.is_Rational and coeff > 0) or not factors:
        return False
    pv = system.parameter_values
    params = {p.symbol for p in system.parameters}
    bases = [f.base if f.is_Pow and f.exp.is_Integer and f.exp > 0 else f for f in factors]
    if not all(b in params for b in bases) or not any(b in gravity for b in bases):
        return False
    try:
        return all(float(pv[b]) > 0 for b in bases)
    except (TypeError, ValueError, KeyError):
        return False


def gravity_hints(system) -> list[str]:
    """A warning for each coordinate q in which V is linear with dV/dq = -w, w a weight
    (:func:`_positive_weight`: m*g, a positive product of parameters with gravity's):
    the force -dV/dq = +w pushes q to larger values, so at rest the body would
    accelerate towards larger q, upward if q is measured up: V = -m g y with y up, the
    sign of gravity's term wrong. Said only for the V a user wrote: the V lamech makes
    from the bodies and [gravity] (their positions say which way is up) is not judged,
    and V = m g (n cos(alpha) - s sin(alpha)) (s down a slope) is not flagged, its slope
    carrying a sine."""
    gravity = _gravity_symbols(system)
    if not gravity or system.V == 0:
        return []
    made = sp.Integer(0)
    if system.gravity is not None:
        made = sp.Add(*(b.mass * system.gravity * b.position[-1] for b in system.bodies))
    state = {*system.q, *system.qd, system.t}
    out = []
    for c in system.coordinates:
        slope = sp.expand(sp.diff(system.V, c.symbol))
        if (
            slope == 0
            or slope.free_symbols & state
            or not _positive_weight(-slope, system, gravity)
        ):
            continue
        if sp.expand(sp.diff(made, c.symbol) - slope) == 0:
            continue  # the bodies' own V: their positions say which way is up
        w = -slope
        try:
            accel = float(w.xreplace(system.parameter_values))
        except (TypeError, ValueError):
            continue
        q = c.name
        out.append(_said(
            f"V = {to_text(system.V)} decreases as `{q}` grows (dV/d{q} = {to_text(slope)} "
            f"= {-accel:.6g}): the force {to_text(w)} pushes `{q}` to larger values, so at "
            f"rest the body would accelerate towards larger {q}, upward if {q} is measured "
            f"up, as if gravity pulled up. For {q} measured up gravity's term is "
            f"+{to_text(w)}*{q} (V = m*g*height): is its sign right? (For {q} measured "
            "down this is right.)"
        ))  # fmt: skip
    return out


def _friction_hints(system) -> list[str]:
    out = []
    by_name = {c.name: c for c in system.constraints}
    for c in system.constraints:
        if c.friction is None:
            continue
        normal = by_name.get(c.friction.normal)
        if normal is None or normal.unilateral:
            continue
        out.append(_said(
            f"friction `{c.name}` takes its normal force from `{normal.name}`, which is "
            f"bilateral: lambda_{normal.name} may pull as well as push, and the limit "
            f"mu |lambda_{normal.name}| then bounds the friction by a force that holds the "
            f"bodies together; if `{normal.name}` is a contact that can let go, make it "
            "unilateral = true"
        ))  # fmt: skip
    return out


def _angles(system) -> dict[sp.Symbol, str]:
    """{symbol: the function} of the parameters and coordinates that enter sin, cos or
    tan as an angle: with a constant numeric coefficient in its argument."""
    exprs = [system.T, system.V, *(c.expr for c in system.constraints), *system.forces]
    for b in system.bodies:
        exprs += list(b.position) + ([b.angle] if b.angle is not None else [])
    wanted = {p.symbol for p in system.parameters} | {c.symbol for c in system.coordinates}
    out: dict[sp.Symbol, str] = {}
    for e in exprs:
        for f in sorted(sp.sympify(e).atoms(sp.sin, sp.cos, sp.tan), key=sp.default_sort_key):
            arg = f.args[0]
            for s in arg.free_symbols & wanted:
                if s not in out and sp.diff(arg, s).is_Number and sp.diff(arg, s) != 0:
                    out[s] = type(f).__name__
    return out


def degree_hints(
    system, initial: dict[str, float] | None = None, parameters: dict[str, float] | None = None
) -> list[str]:
    """A warning for each parameter and initial value that enters a sine or cosine as an
    angle and is a whole number of degrees more than a turn in radians (30, 45, 90, 180);
    ``initial`` {coordinate: value} and ``parameters`` {name: value} override the
    system's values (a run's)."""
    angles = _angles(system)
    if not angles:
        return []
    pv = system.parameter_values
    if parameters:
        pv = {**pv, **{p.symbol: parameters[p.name] for p in system.parameters
                       if p.name in parameters}}  # fmt: skip
    out = []
    for p in system.parameters:
        if p.symbol in angles:
            out += _degrees(f"parameter `{p.name}`", float(pv[p.symbol]), angles[p.symbol])
    for c in system.coordinates:
        if c.symbol not in angles:
            continue
        if initial is not None and c.name in initial:
            value = float(initial[c.name])
        else:
            try:
                value = float(sp.sympify(c.initial).xreplace(pv))
            except (TypeError, ValueError):
                continue
        out += _degrees(f"the initial value of `{c.name}`", value, angles[c.symbol])
    return out


def _degrees(what: str, value: float, function: str) -> list[str]:
    if not math.isfinite(value) or abs(value) <= 2 * math.pi or value != round(value):
        return []
    return [_said(
        f"{what} is {value:g}, an angle in {function}(...), where angles are in radians: "
        f"{value:g} rad is {abs(value) / (2 * math.pi):.3g} turns. If {value:g} degrees were "
        f"meant, write {value:g}*pi/180 (= {math.radians(value):.6g})"
    )]  # fmt: skip


def zero_masses(system) -> list[tuple]:
    """(parameter, coordinate) for each parameter that is 0 at its value and is the mass
    of the coordinate: it is in T's d^2T/dq'^2 for q, and that entry is 0 with the
    parameters at their values (T = m/2*x'^2 with m = 0; not (m1 + m2)/2*y'^2 with
    m2 = 0, where m1 still gives y inertia). A parameter that is a body's mass is left
    out: a body given a mass of 0 is a massless pulley or rod meant as such (its own
    rule: :func:`lamech.model._start.dependent_issues`)."""
    pv = system.parameter_values
    zero = {
        p.symbol: p
        for p in system.parameters
        if isinstance(p.symbol, sp.Symbol) and pv.get(p.symbol) == 0
    }
    if not zero:
        return []
    for b in system.bodies:
        for s in sp.sympify(b.mass).free_symbols:
            zero.pop(s, None)
    T = sp.sympify(system.T)
    out = []
    for c in system.coordinates:
        entry = sp.diff(T, c.velocity, 2)
        held = sorted(entry.free_symbols & set(zero), key=str)
        if held and sp.expand(entry.xreplace({s: sp.Integer(0) for s in held})) == 0:
            out.append((zero[held[0]], c))
    return out


def zero_mass_hints(system) -> list[str]:
    """A warning for each :func:`zero_masses` pair in a system whose constraints still
    give the accelerations (the coordinate moves as they carry it): valid, and a
    probable slip (a mass typed as 0)."""
    return [_said(
        f"parameter `{p.name}` is 0 and is the mass of `{c.name}` (d^2T/d{c.name}'^2 = "
        f"{to_text(sp.diff(system.T, c.velocity, 2))} = 0): `{c.name}` has no inertia of "
        "its own and moves only as the constraints carry it (the mass matrix is "
        f"singular); if a mass was meant, give `{p.name}` its value"
    ) for p, c in zero_masses(system)]  # fmt: skip
