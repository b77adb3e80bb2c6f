"""Warnings about a system that is valid but probably not what its author meant, said
once in its ``notes`` (:func:`hints`; recomputed whenever a System is made, so new values
given with ``with_values`` are judged, and a warning about old ones is dropped):

* an angle of a whole number of degrees written as radians: a parameter or an initial
  value of 30, 45, 90 that enters sin, cos or tan as an angle (``sin(alpha)``,
  ``cos(theta1 - theta2)``, not the ``w`` of ``cos(w*t)``);
* friction whose normal is a bilateral constraint: its multiplier can pull, so mu N
  bounds the friction by |N| of a force that may hold the bodies together.
"""

from __future__ import annotations

import math

import sympy as sp

__all__ = ["hints", "degree_hints", "is_hint"]

_GIVEN: set[str] = set()
"""Every hint text made in this process (a System's old hints are recognised by it)."""


def is_hint(note: str) -> bool:
    return note in _GIVEN


def _said(text: str) -> str:
    _GIVEN.add(text)
    return text


def hints(system) -> list[str]:
    """The warnings of the module docstring for ``system`` at its own values."""
    return _friction_hints(system) + degree_hints(system)


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
