"""Parsing sweep input: value ranges, NAME=VALUE assignments and measures (numbers and
quantities with units only, ``30 cm`` in SI: no expression is evaluated here)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .._errors import LamechError
from ..expr import Dimension, ExpressionError, is_quantity, quantity
from ..model import System

__all__ = [
    "SweepError",
    "Measure",
    "parse_values",
    "parse_assignment",
    "parse_measure",
    "number",
    "EVENT_MEASURES",
    "SERIES_MEASURES",
    "MAX_CASES",
]

EVENT_MEASURES = {
    "liftoff": "lift-off",
    "slip": "slip",
    "stick": "stick",
    "contact": "contact",
    "impact": "impact",
}
SERIES_MEASURES = ("max", "min", "final")
MAX_CASES = 1_000_000


class SweepError(LamechError, ValueError):
    """Bad sweep input (names, ranges, measures, a table that does not fit); nothing ran."""


# ----- parsing ------------------------------------------------------------------------
def number(text: str, what: str, dimension: Dimension | None = None) -> float:
    """``text`` as a float: a number, or a quantity (``30 cm``) in SI, refused when
    ``dimension`` (the problem file's, where it gives units) is another."""
    if is_quantity(text):
        try:
            q = quantity(text.strip())
        except ExpressionError as exc:
            raise SweepError(f"{what}: {exc.message}") from None
        if dimension is not None and q.dimension != dimension:
            raise SweepError(
                f"{what}: {text.strip()!r} has dimension {q.dimension.described()}, but the "
                f"problem file gives it {dimension.described()}"
            )
        return float(q.value)
    try:
        x = float(text.strip())
    except ValueError:
        raise SweepError(f"{what}: {text.strip()!r} is not a number") from None
    if not math.isfinite(x):
        raise SweepError(f"{what}: {text.strip()!r} is not a finite number")
    return x


def parse_values(text: str, name: str = "value", dimension: Dimension | None = None) -> np.ndarray:
    """``"A:B:N"`` (N values from A to B, both included), ``"a,b,c"`` or ``"a"``.

    A range of one value has equal ends (``A:A:1`` is ``A``); ``A:B:1`` with A != B is
    refused, saying what to write.

    Numbers, or quantities converted to SI (``10 cm:50 cm:5``; of ``dimension`` where it
    is given); no expression is evaluated.
    """
    what = f"parameter `{name}`"
    text = str(text).strip()
    if not text:
        raise SweepError(f"{what}: no values (write A:B:N, a,b,c or a single number)")
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise SweepError(
                f"{what}: range {text!r} must be A:B:N (start, stop, count), e.g. 0.1:1.0:50"
            )
        a, b = number(parts[0], what, dimension), number(parts[1], what, dimension)
        try:
            count = int(parts[2].strip())
        except ValueError:
            raise SweepError(
                f"{what}: count {parts[2].strip()!r} in {text!r} is not an integer"
            ) from None
        if count < 1:
            raise SweepError(f"{what}: range {text!r}: count {count}: a range has at least 1 value")
        if count == 1 and a != b:  # which end is meant is not known: say what to write
            start, stop = parts[0].strip(), parts[1].strip()
            raise SweepError(
                f"{what}: range {text!r} has one value but two ends: write {name}={start} "
                f"for that value, or {start}:{stop}:N with N >= 2 for a range"
            )
        if count > MAX_CASES:
            raise SweepError(f"{what}: count {count} exceeds {MAX_CASES}")
        # 15 significant digits: 0.3, not linspace's 0.30000000000000004
        return np.array([float(f"{x:.15g}") for x in np.linspace(a, b, count)])
    values = [number(part, what, dimension) for part in text.split(",")]
    return np.array(values, dtype=float)


def parse_assignment(text: str, what: str) -> tuple[str, str]:
    """``"NAME=VALUE"`` -> (NAME, VALUE), both stripped."""
    name, sep, value = str(text).partition("=")
    if not sep or not name.strip() or not value.strip():
        raise SweepError(f"{what} {text!r}: write NAME=VALUE")
    return name.strip(), value.strip()


@dataclass(frozen=True)
class Measure:
    """One measured quantity of a case (see the module docstring); ``text`` as written."""

    kind: str  # liftoff, slip, stick, contact, impact, max, min, final
    target: str  # a constraint ("" = any) for events; a series for max/min/final
    text: str

    def columns(self, coordinates: Sequence[str]) -> list[str]:
        if self.kind in EVENT_MEASURES:
            return [f"{self.text}:t"] + [f"{self.text}:{c}" for c in coordinates]
        return [self.text]


def _series_names(system: System) -> list[str]:
    names = [c.name for c in system.coordinates] + [c.name + "'" for c in system.coordinates]
    names += ["lambda:" + c.name for c in system.constraints]
    for c in system.constraints:
        if c.force is not None:
            dirs = [d for d, _ in c.force.along] or list("xyz"[: system.dimension])
            names += [f"force:{c.name}:{d}" for d in dirs]
    return names + ["energy", "residual"]


def parse_measure(text: str, system: System) -> Measure:
    """Check ``text`` against ``system``; a :class:`SweepError` names the known choices."""
    text = str(text).strip()
    kind, _, rest = text.partition(":")
    kinds = list(EVENT_MEASURES) + [k + ":<series>" for k in SERIES_MEASURES]
    if kind in EVENT_MEASURES:
        if rest:
            known = [c.name for c in system.constraints]
            if rest not in known:
                raise SweepError(
                    f"measure {text!r}: unknown constraint `{rest}`; known: {', '.join(known)}"
                )
        return Measure(kind, rest, text)
    if kind in SERIES_MEASURES:
        known = _series_names(system)
        if rest not in known:
            raise SweepError(
                f"measure {text!r}: unknown series `{rest}`; known: {', '.join(known)}"
            )
        return Measure(kind, rest, text)
    raise SweepError(f"unknown measure {text!r}; known: {', '.join(kinds)}")
