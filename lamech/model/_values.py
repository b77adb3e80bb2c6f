"""A system with other numbers: parameter values, friction coefficients and initial values
overridden by name (what ``--param`` and ``--initial`` do), checked again as any System."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import sympy as sp

from ._system import System

__all__ = ["with_values", "friction_names", "check_names"]


def _exact(x: float) -> sp.Rational:
    """0.05 -> 1/20: the decimal the user wrote, exactly (as the parser reads 0.05)."""
    return sp.Rational(repr(float(x)))


def friction_names(system: System) -> dict[str, str]:
    """The names a friction coefficient goes by -> its constraint: ``mu:<constraint>``
    for each friction constraint, and ``mu`` when there is exactly one and no parameter
    is called ``mu``. The one rule for ``--param``, ``params=`` and the sweeps."""
    fr = [c.name for c in system.constraints if c.friction is not None]
    out = {f"mu:{c}": c for c in fr}
    if len(fr) == 1 and "mu" not in {p.name for p in system.parameters}:
        out["mu"] = fr[0]
    return out


def check_names(system: System, names) -> None:
    """ValueError naming every name of ``names`` that is neither a parameter nor a
    friction coefficient (:func:`friction_names`), with the known ones."""
    known = [p.name for p in system.parameters] + list(friction_names(system))
    unknown = [n for n in names if n not in known]
    if unknown:
        raise ValueError(
            f"unknown parameter{'s' if len(unknown) > 1 else ''} "
            f"{', '.join(f'`{n}`' for n in unknown)}; known: {', '.join(known)}"
        )


def with_values(
    system: System,
    parameters: Mapping[str, float] | None = None,
    initial: Mapping[str, float] | None = None,
) -> System:
    """``system`` with parameter values (``mu`` / ``mu:<constraint>`` for a friction
    coefficient) and initial values (a coordinate, or ``x'`` for its velocity) replaced.

    Parameters whose value is an expression of overridden ones follow them. A parameter
    keeps its sign (its symbol carries it into the derivation: sqrt(R^2) = R); a value of
    the other sign raises ValueError saying to change the file. The result is checked
    like any System (the initial state must still meet the constraints: give every
    coordinate the constraints tie together, or let ``lamech.numeric.consistent_initial``
    find them).
    """
    parameters = dict(parameters or {})
    by_name = {p.name: p for p in system.parameters}
    check_names(system, parameters)
    friction = friction_names(system)
    constraints = list(system.constraints)
    for name in [n for n in parameters if n not in by_name]:
        target = next(c for c in constraints if c.name == friction[name])
        value = parameters.pop(name)
        if not value >= 0:
            raise ValueError(f"{name}: a coefficient of friction is >= 0 (got {value:g})")
        j = constraints.index(target)
        c = constraints[j]
        assert c.friction is not None  # friction_names names friction constraints only
        constraints[j] = dataclasses.replace(
            c, friction=dataclasses.replace(c.friction, mu=_exact(value))
        )
    numbers = {p.symbol: p.numeric for p in system.parameters}
    for name, value in parameters.items():
        p = by_name[name]
        if (p.symbol.is_positive and not value > 0) or (p.symbol.is_negative and not value < 0):
            raise ValueError(
                f"parameter `{name}` is {p.numeric:g} in the file and its sign "
                f"is part of the derivation; {value:g} needs the file changed"
            )
        numbers[p.symbol] = float(value)
    fixed = {by_name[n].symbol for n in parameters}
    for _ in range(len(system.parameters)):  # values that are expressions follow
        for p in system.parameters:
            if p.symbol not in fixed and p.value.free_symbols:
                numbers[p.symbol] = float(p.value.xreplace(numbers))
    new_params = tuple(
        dataclasses.replace(
            p,
            value=_exact(parameters[p.name]) if p.name in parameters else p.value,
            numeric=numbers[p.symbol],
        )
        for p in system.parameters
    )
    coords = list(system.coordinates)
    names = {c.name: i for i, c in enumerate(coords)}
    for name, value in (initial or {}).items():
        base = name.rstrip("'")
        if base not in names or name.count("'") > 1:
            raise ValueError(
                f"initial value for unknown coordinate `{name}`; known: "
                + ", ".join(list(names) + [n + "'" for n in names])
            )
        i = names[base]
        field = "initial_velocity" if name.endswith("'") else "initial"
        coords[i] = dataclasses.replace(coords[i], **{field: _exact(value)})
    return dataclasses.replace(
        system, parameters=new_params, coordinates=tuple(coords), constraints=tuple(constraints)
    )
