"""Quantities with units in a problem file (issue 46): a parameter's value
(``R2 = "30 cm"``), a coordinate's ``unit`` and its initial value and velocity
(``initial = "10 deg"``, ``velocity = "0.5 m/s"``), each converted exactly to SI
(:func:`lamech.expr.quantity`) and its dimension recorded in the reader's ``dimensions``
(by parameter or coordinate name) for :func:`lamech.model.infer_units`.

A coordinate's ``unit`` says its dimension and the unit of a plain number given as its
initial value (its velocity's: that unit per second); an expression of parameters is in
SI already, as the parameters are. The coordinate itself is always in SI (an angle in
radians, a length in metres), as every result is.
"""

from __future__ import annotations

import re
from typing import Any

import sympy as sp

from ..expr import Dimension, ExpressionError, is_angle_unit, is_quantity, quantity, unit

__all__ = ["parameter_value", "coordinate_values", "overridden", "spelled_units"]

_TIME = Dimension.of(T=1)


def parameter_value(reader: Any, name: str, value: Any) -> Any:
    """``value`` as the reader parses it: a quantity becomes its exact value in SI (its
    dimension recorded), anything else is unchanged; None when refused (reported)."""
    if not is_quantity(value):
        return value
    try:
        q = quantity(value)
    except ExpressionError as exc:
        reader.problem(f"parameters.{name}", exc.message, ("parameters", None, name))
        return None
    reader.dimensions[name] = q.dimension
    reader.quantities[name] = value
    if is_angle_unit(q.unit):
        reader.angles.add(name)
    return q.value


def _number(value: Any) -> sp.Expr | None:
    """A plain number given in the file (10, 0.5, "0.5") exactly, else None."""
    if isinstance(value, bool):
        return None
    if isinstance(value, int):
        return sp.Integer(value)
    if isinstance(value, float):
        return sp.Rational(repr(value))
    if isinstance(value, str):
        try:
            return sp.Rational(value.strip())
        except (TypeError, ValueError):
            return None
    return None


def coordinate_values(reader: Any, name: str, spec: dict) -> tuple[Any, Any]:
    """The initial value and velocity of coordinate ``name`` as the reader parses them:
    quantities and plain numbers in the coordinate's ``unit`` converted to SI, the
    dimensions recorded; a mismatch between them is reported."""
    where, loc = f"coordinates.{name}", ("coordinates", None, name)
    q0, v0 = spec["initial"], spec.get("velocity", 0)
    factor: sp.Expr = sp.Integer(1)
    declared: Dimension | None = None
    if "unit" in spec:
        text = spec["unit"]
        if not isinstance(text, str):
            reader.problem(where + ".unit", 'a unit is a string: unit = "m", "rad" or "deg"', loc)
        else:
            try:
                factor, declared = unit(text)
            except ExpressionError as exc:
                reader.problem(where + ".unit", exc.message, loc)
    found: dict[str, Dimension] = {}
    out = []
    for key, raw, per in (("initial", q0, Dimension()), ("velocity", v0, _TIME)):
        if is_quantity(raw):
            try:
                q = quantity(raw)
            except ExpressionError as exc:
                reader.problem(f"{where}.{key}", exc.message, loc)
                out.append(0)
                continue
            found[key] = q.dimension * per
            out.append(q.value)
            continue
        number = _number(raw)
        if declared is not None and factor != 1 and number is not None:
            out.append(number * factor)
        else:
            out.append(raw)
    if declared is not None:
        reader.dimensions[name] = declared
    for key, d in found.items():
        said = "its unit" if declared is not None else None
        if declared is None and key == "velocity" and "initial" in found:
            declared, said = found["initial"], "its initial value"
        if declared is None:
            declared = d
            reader.dimensions[name] = d
            continue
        if d != declared:
            needed = declared / (_TIME if key == "velocity" else Dimension())
            given = d / (_TIME if key == "velocity" else Dimension())
            reader.problem(
                f"{where}.{key}",
                f"the {key} `{spec[key]}` has dimension {given.described()}, but {said} makes "
                f"`{name}` {declared.described()}, so its {key} needs {needed.described()}",
                loc,
            )
    return out[0], out[1]


def overridden(system: Any, params: Any, name: str) -> Any:
    """``system`` with the parameter values ``params`` (numbers in SI, quantities as text
    or pint Quantities) put in its file's place (:func:`lamech.model.with_values`), each
    quantity converted to SI and its dimension checked (:func:`lamech.model.in_si`); a
    ProblemFileError naming the value otherwise."""
    from ..model import ModelError, in_si, with_values
    from ._files import Issue, ProblemFileError

    try:
        values = in_si(system, params)
        for key, value in values.items():
            if isinstance(value, bool) or not isinstance(value, (int, float, sp.Number)):
                raise ModelError(
                    [
                        (
                            "",
                            f"params[{key!r}] = {value!r}: give a number (in SI) or a "
                            'quantity ("30 cm", or a pint Quantity)',
                        )
                    ]
                )
        return with_values(system, parameters={k: float(v) for k, v in values.items()})
    except ValueError as exc:  # ModelError too
        raise ProblemFileError(name, [Issue("", str(exc))]) from None


def spelled_units(reader: Any, system: Any, units: Any, conflicts: Any = ()) -> list[str]:
    """Where a parameter's quantity is a number and a unit that spells a parameter's name
    (``a = "2 g"`` beside a parameter g: two grams, never twice g), the warnings to give:
    one for each such parameter whose dimension nothing else in the file fixes, so that
    the checks could not tell grams from twice g. With ``units`` None (the checks found
    ``conflicts``, their messages), each such parameter a conflict names is reported as
    a problem at its line instead, beside the conflict it may explain."""
    from ..expr import quantity, spelled_hint
    from ..model import ModelError, infer_units

    names = {p.name for p in system.parameters}
    out = []
    for name, text in reader.quantities.items():
        word = quantity(text).unit.strip()
        hint = spelled_hint(text, word, names) if word.isidentifier() else ""
        if not hint:
            continue
        if units is None:
            if any(re.search(rf"(?<![\w']){re.escape(name)}(?![\w'])", c) for c in conflicts):
                reader.problem(f"parameters.{name}", hint, ("parameters", None, name))
            continue
        others = {k: d for k, d in reader.dimensions.items() if k != name}
        try:
            alone = infer_units(system, others) if others else None
        except ModelError:
            continue
        if alone is None or alone.of(name) is None:
            out.append(
                f"parameters.{name}: {hint}; nothing else in the file fixes the dimension of "
                f"`{name}`, so the checks cannot tell which was meant"
            )
    return out
