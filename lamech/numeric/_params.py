"""The numbers of a run's system: friction coefficients as parameters, the compiled
system and its parameter vector."""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable, Mapping

import numpy as np
import sympy as sp

from ..model import Parameter, System
from ..model._values import check_names, friction_names
from ._codegen import NumericSystem, compile_system
from ._options import SimulationError

__all__ = [
    "friction_names", "with_friction_parameters", "numeric_system", "check_values", "values_in_si",
]  # fmt: skip


def numeric_system(
    system: System | NumericSystem | str, params: dict | None, jit: bool | None
) -> tuple[NumericSystem, np.ndarray]:
    """(compiled system, parameter vector with ``params`` {name: value} applied); a
    friction coefficient named in ``params`` becomes a parameter first; a value may be a
    quantity (``"30 cm"``, a pint Quantity), converted to SI (:func:`values_in_si`). ``system`` may
    also be a problem file's path or an example's name (:func:`lamech.problem._coerce.as_system`).
    Raises :class:`SimulationError` for unknown names, values that are not finite
    numbers, and values the problem's own checks refuse (a parameter's sign, which the
    derivation assumed; a mass, a restitution out of range): those of
    :func:`lamech.model.with_values`, which ``--param`` applies."""
    if params is not None and not isinstance(params, Mapping):
        raise TypeError(
            f"simulate: params must be a dict {{name: value}}; got {type(params).__name__}"
        )
    if not isinstance(system, NumericSystem):
        from ..problem._coerce import as_system

        system = as_system(system, "simulate")
    if params:
        params = values_in_si(
            system.system if isinstance(system, NumericSystem) else system, params
        )
    _check_finite(params or {})
    if params and not isinstance(system, NumericSystem):
        check_values(system, params)
        extra = [k for k in params if k not in {par.name for par in system.parameters}]
        if extra:
            try:
                system = with_friction_parameters(system, extra)
            except ValueError as exc:
                raise SimulationError(str(exc)) from None
    ns = system if isinstance(system, NumericSystem) else compile_system(system, jit=jit)
    try:
        p = ns.parameter_vector(params)
    except KeyError as exc:
        raise SimulationError(str(exc.args[0])) from None
    except (TypeError, ValueError) as exc:
        raise SimulationError(f"parameter values must be numbers: {exc}") from None
    if params:
        _check_signs(ns, params, p)
    return ns, p


def values_in_si(system: System, values: Mapping, what: str = "params") -> dict:
    """``values`` with each quantity (``"30 cm"``, a pint Quantity) in SI, of the
    dimension the problem gives the name (:func:`lamech.model.in_si`); SimulationError
    otherwise."""
    from ..model import ModelError, in_si

    try:
        return in_si(system, values, what + "[{name!r}] = {value!r}")
    except ModelError as exc:
        raise SimulationError(str(exc)) from None


def _check_finite(params: dict) -> None:
    for name, value in params.items():
        try:
            x = float(value)
        except (TypeError, ValueError):
            raise SimulationError(f"params[{name!r}] must be a number, got {value!r}") from None
        if not np.isfinite(x):
            raise SimulationError(f"params[{name!r}] must be a finite number, got {x}")


def check_values(system: System, params: dict, given_as: str = "params") -> None:
    """The file's checks (masses >= 0, restitution in [0, 1], a parameter's sign, ...) at
    these parameter values (:func:`lamech.model.with_values`): :class:`SimulationError`
    saying which, prefixed ``given_as`` (``simulate``'s ``params``, the command line's
    ``--param``): m = -1 would otherwise run, chattering contacts. The one check of both."""
    from ..model import with_values

    own = {k: float(v) for k, v in params.items() if k in {p.name for p in system.parameters}}
    if not own:
        return
    try:
        with_values(system, parameters=own)
    except ValueError as exc:  # ModelError too
        raise SimulationError(f"{given_as}: {exc}") from None


def _check_signs(ns: NumericSystem, params: dict, p: np.ndarray) -> None:
    """Each parameter (those computed from the overridden ones too) finite and not of
    the other sign than its symbol declares, which the derivation assumed
    (sqrt(R^2) = R): checked on a compiled system (a sweep's cases), where the System's
    own checks are not run again. Zero, the boundary, is let through here (a sweep's
    level floor, alpha = 0, is right: the tests check it against its closed form)."""
    for i, par in enumerate(ns.system.parameters):
        x = float(p[i])
        sym = par.symbol
        if par.name == "mu" or par.name.startswith("mu:"):  # a friction coefficient, >= 0
            wrong = not x >= 0
        else:
            wrong = (sym.is_nonnegative and x < 0) or (sym.is_nonpositive and x > 0)
        wrong = wrong or not np.isfinite(x)
        if not wrong:
            continue
        given = par.name if par.name in params else None
        why = f"params[{given!r}] = {x:g}" if given else f"`{par.name}` = {x:g} (from params)"
        if par.name == "mu" or par.name.startswith("mu:"):
            raise SimulationError(f"{why}: a coefficient of friction is >= 0")
        raise SimulationError(
            f"{why}: `{par.name}` is {par.numeric:g} in the file and its sign is part of the "
            "derivation; another sign needs the file changed"
        )


def with_friction_parameters(system: System, names: Iterable[str]) -> System:
    """``system`` with the friction coefficients named in ``names`` made parameters."""
    names = list(names)
    check_names(system, names)
    params = {p.name for p in system.parameters}
    friction = friction_names(system)
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
