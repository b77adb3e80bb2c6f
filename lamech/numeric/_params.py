"""The numbers of a run's system: friction coefficients as parameters, the compiled
system and its parameter vector."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable

import numpy as np
import sympy as sp

from ..model import Parameter, System
from ._codegen import NumericSystem, compile_system
from ._options import SimulationError

__all__ = ["friction_names", "with_friction_parameters", "numeric_system"]


def numeric_system(
    system: System | NumericSystem, params: dict | None, jit: bool | None
) -> tuple[NumericSystem, np.ndarray]:
    """(compiled system, parameter vector with ``params`` {name: value} applied); a
    friction coefficient named in ``params`` becomes a parameter first. Raises
    :class:`SimulationError` for unknown names and values that are not numbers."""
    if params and not isinstance(system, NumericSystem):
        extra = [k for k in params if k not in {par.name for par in system.parameters}]
        if extra:
            try:
                system = with_friction_parameters(system, extra)
            except ValueError as exc:
                raise SimulationError(str(exc)) from None
    ns = system if isinstance(system, NumericSystem) else compile_system(system, jit=jit)
    try:
        return ns, ns.parameter_vector(params)
    except KeyError as exc:
        raise SimulationError(str(exc.args[0])) from None
    except (TypeError, ValueError) as exc:
        raise SimulationError(f"parameter values must be numbers: {exc}") from None


def friction_names(system: System) -> dict[str, str]:
    """Sweepable friction names -> constraint name."""
    fr = [c.name for c in system.constraints if c.friction is not None]
    out = {f"mu:{c}": c for c in fr}
    if len(fr) == 1 and "mu" not in {p.name for p in system.parameters}:
        out["mu"] = fr[0]
    return out


def with_friction_parameters(system: System, names: Iterable[str]) -> System:
    """``system`` with the friction coefficients named in ``names`` made parameters."""
    params = {p.name for p in system.parameters}
    friction = friction_names(system)
    known = [p.name for p in system.parameters] + list(friction)
    unknown = [n for n in names if n not in params and n not in friction]
    if unknown:
        raise ValueError(
            f"unknown parameter{'s' if len(unknown) > 1 else ''} "
            f"{', '.join(f'`{n}`' for n in unknown)}; known: {', '.join(known)}"
        )
    new_params = list(system.parameters)
    constraints = list(system.constraints)
    taken = {str(s) for s in system.symbols.values()}
    done: set[str] = set()
    for name in names:
        if name in params or friction[name] in done:
            continue
        cname = friction[name]
        done.add(cname)
        j = next(i for i, c in enumerate(constraints) if c.name == cname)
        c = constraints[j]
        assert c.friction is not None  # friction_names lists friction constraints only
        sym_name = f"mu_{cname}"
        while sym_name in taken:
            sym_name += "_"
        taken.add(sym_name)
        sym = sp.Symbol(sym_name, positive=True)
        value = c.friction.mu
        new_params.append(Parameter(name, sym, value, float(system.numeric(value))))
        constraints[j] = dataclasses.replace(c, friction=dataclasses.replace(c.friction, mu=sym))
    if not done:
        return system
    return dataclasses.replace(system, parameters=tuple(new_params), constraints=tuple(constraints))
