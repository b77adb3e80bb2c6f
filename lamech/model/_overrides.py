"""Values given in units where a problem's numbers are overridden (issue 46): ``--param
R2="30 cm"``, ``lamech.simulate(..., params={"R2": "30 cm"})``, a pint Quantity, a
sweep's ``"10 cm:50 cm:5"``. Each is converted to SI and its dimension checked against
the one the problem gives ``R2`` or infers for it; where the problem says nothing of
R2's dimension (a file without units), the dimensions are inferred from the file's
equations with R2 in the unit given, and a file whose equations then do not balance is
refused, as a file with that unit written in it would be.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ..expr import Dimension, ExpressionError, Quantity, as_quantity, spelled_hint
from ._base import ModelError
from ._dimensions import TIME, infer_units
from ._system import System

__all__ = ["in_si", "check_dimensions"]


def check_dimensions(system: System, given: Mapping[str, tuple[Dimension, str]]) -> None:
    """Refuse a quantity of the wrong dimension: ``given`` maps a parameter, coordinate
    or velocity (``x'``) name to (the dimension of the quantity given for it, the words
    that name it in a message: ``"--param R2=30 kg"``).

    Raises
    ------
    ModelError
        The dimension differs from the problem's for that name (both said), or, where
        the problem gives that name none, the problem's equations do not balance with it
        (the first conflict said).
    """
    units = system.units
    unknown: dict[str, Dimension] = {}
    for name, (dimension, said) in given.items():
        known = units.of(name) if units is not None else None
        if known is None:
            base = name.rstrip("'")
            unknown[base] = dimension * TIME if name.endswith("'") else dimension
            continue
        if known != dimension:
            raise ModelError(
                [
                    (
                        "",
                        f"{said}: has dimension {dimension.described()}, but `{name}` has "
                        f"{known.described()} in the problem file",
                    )
                ]
            )
    if not unknown:
        return
    names = {p.name for p in system.parameters} | {c.name for c in system.coordinates}
    seeds = {n: d for n, d in (units.symbols if units is not None else ()) if n in names}
    try:
        infer_units(system, {**seeds, **unknown})
    except ModelError as exc:
        said = ", ".join(s for _, s in given.values())
        first = exc.issues[0]
        where = f"{first[0]}: " if first[0] else ""
        dims = ", ".join(f"`{n}` in {d.described()}" for n, d in unknown.items())
        raise ModelError(
            [
                (
                    "",
                    f"{said}: the problem gives this no unit, and with {dims} its equations "
                    f"do not balance ({where}{first[1]}); give a plain number in the "
                    "problem's own units instead",
                )
            ]
        ) from None


def in_si(
    system: System, values: Mapping[str, Any], what: str = "params[{name!r}] = {value!r}"
) -> dict[str, Any]:
    """``values`` {name: value} with each quantity, the text ``"30 cm"`` or a pint
    Quantity (``30 * ureg.cm``), replaced by its value in SI (a float, or an array of
    floats for an array Quantity); other values unchanged. Each quantity's dimension is
    checked by :func:`check_dimensions`; ``what`` says a value in messages, a template of
    ``name`` and ``value`` (``"--param {name}={value}"``).

    Raises
    ------
    ModelError
        A unit unknown, or a dimension that does not fit (see :func:`check_dimensions`).
    """
    out: dict[str, Any] = {}
    given: dict[str, tuple[Dimension, str]] = {}
    hints: list[str] = []
    names = {p.name for p in system.parameters}
    for name, value in values.items():
        said = what.format(name=name, value=value)
        try:
            q: Quantity | None = as_quantity(value)
        except ExpressionError as exc:
            raise ModelError([("", f"{said}: {exc.message}")]) from None
        if q is None:
            out[name] = value
            continue
        given[name] = (q.dimension, said)
        out[name] = q.value if not hasattr(q.value, "free_symbols") else float(q.value)
        word = q.unit.strip()
        units = system.units
        if word in names and units is not None and units.of(name) is not None:
            # "3 g" for an acceleration beside a parameter g: 3*g was meant
            if units.of(word) == units.of(name):
                hints.append(spelled_hint(q.text, word, names))
    try:
        check_dimensions(system, given)
    except ModelError as exc:
        hint = "; ".join(h for h in hints if h)
        if not hint:
            raise
        raise ModelError([("", f"{exc}; {hint}")]) from None
    return out
