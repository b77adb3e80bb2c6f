"""Quantities with units in problem-file text (``"30 cm"``, ``"9.81 m/s^2"``, ``"30 deg"``),
converted exactly to SI, and the physical dimensions lamech infers and checks
(:class:`Dimension`).

The unit syntax and the table of units are pint's (https://pint.readthedocs.io), the
scientific-Python standard: it reads ``m/s^2``, ``N/cm``, ``kg*m^2``, ``deg``, ``rpm``,
``min``, prefixes and plurals, and knows each unit's dimension and factor to SI. SymPy's
``physics.units`` was the other candidate: it would have kept the factors symbolic, but it
has no parser for unit text (a unit is a Python name such as ``centimeter``; ``m/s^2``
would go through ``sympify``, which lamech never applies to a file's text), fewer units
and no plurals or prefixes on demand. pint parses unit text with its own tokenizer (no
``eval``) and is imported only when a file uses a unit, so a file without units loads as
fast as before.

A quantity is a number followed by a unit, nothing else: ``"30 cm"``, ``"-2.5e-3 kg"``,
``"200 N/m"``. Anything else in a string is an expression (``"R1 + R2"``, ``"2*pi"``), so
the two never overlap: an expression never starts with a number followed by a space and
a name, which the expression grammar refuses.

Exactness: the number is read as the exact decimal written (``9.81`` is 981/100, as the
expression parser reads it) and each unit's factor to SI as an exact number: a decimal
(``cm``: 1/100, ``ft``: 3048/10000) or a rational multiple of pi (``deg``: pi/180,
``rpm``: pi/30), so ``"30 deg"`` is ``pi/6`` exactly. A factor that is neither (a unit
defined by a measured constant) is the exact decimal of pint's float. Units with an
offset (``degC``) are refused: a temperature difference is in ``K``.
"""

from __future__ import annotations

import math
import re
import threading
from dataclasses import dataclass
from fractions import Fraction
from typing import Any, NamedTuple

import sympy as sp

from ._grammar import ExpressionError

__all__ = [
    "Dimension",
    "Quantity",
    "DIMENSIONLESS",
    "MASS",
    "LENGTH",
    "TIME",
    "ENERGY",
    "FORCE",
    "is_quantity",
    "is_angle_unit",
    "as_quantity",
    "spelled_names",
    "spelled_hint",
    "quantity",
    "unit",
]

# ----- dimensions ---------------------------------------------------------------------
_BASES = ("M", "L", "T", "I", "Theta", "N", "J")
"""The SI base dimensions, in the order they are printed."""
_PINT_BASES = {
    "[mass]": "M",
    "[length]": "L",
    "[time]": "T",
    "[current]": "I",
    "[temperature]": "Theta",
    "[substance]": "N",
    "[luminosity]": "J",
}
_SI = {"M": "kg", "L": "m", "T": "s", "I": "A", "Theta": "K", "N": "mol", "J": "cd"}
MAX_UNIT_POWER = 12
"""The largest power of a unit in a quantity (``m^12``): no mechanics needs more."""


def _order(name: str) -> tuple:
    return (_BASES.index(name), "") if name in _BASES else (len(_BASES), name)


@dataclass(frozen=True)
class Dimension:
    """A physical dimension: powers of the SI base dimensions, M (mass), L (length),
    T (time), ... ; angles are dimensionless (a radian is a length over a length).

    ``powers`` holds (base, power) pairs with nonzero rational powers, in base order.
    Dimensions multiply, divide and take rational powers.
    """

    powers: tuple[tuple[str, Fraction], ...] = ()

    @classmethod
    def of(cls, **powers: Any) -> Dimension:
        """``Dimension.of(M=1, L=2, T=-2)``: energy."""
        return cls._make(powers)

    @classmethod
    def _make(cls, powers: dict[str, Any]) -> Dimension:
        kept = {k: Fraction(v) for k, v in powers.items() if Fraction(v) != 0}
        return cls(tuple(sorted(kept.items(), key=lambda kv: _order(kv[0]))))

    def power(self, base: str) -> Fraction:
        return dict(self.powers).get(base, Fraction(0))

    def __mul__(self, other: Dimension) -> Dimension:
        out = dict(self.powers)
        for k, v in other.powers:
            out[k] = out.get(k, Fraction(0)) + v
        return Dimension._make(out)

    def __truediv__(self, other: Dimension) -> Dimension:
        return self * other**-1

    def __pow__(self, p: Any) -> Dimension:
        p = Fraction(p)
        return Dimension._make({k: v * p for k, v in self.powers})

    @property
    def dimensionless(self) -> bool:
        return not self.powers

    def __str__(self) -> str:
        """``M*L^2/T^2``; ``1`` when dimensionless."""
        return _formula(self.powers, dict(zip(_BASES, _BASES))) or "1"

    def described(self) -> str:
        """``M*L^2/T^2 (energy)``, ``L (length)``, ``1 (dimensionless)``."""
        if self.dimensionless:
            return "1 (dimensionless)"
        name = _NAMES.get(self)
        return f"{self} ({name})" if name else str(self)

    def si(self) -> str:
        """The dimension's unit in SI symbols, with N for kg*m/s^2 where a mass enters
        once: ``N``, ``N*m``, ``N/m``, ``N*s``, ``kg``, ``m/s^2``, ``1``."""
        powers = dict(self.powers)
        if powers.get("M") == 1 and set(powers) <= {"M", "L", "T"} and powers.get("T", 0) < 0:
            rest = {"N": Fraction(1), "m": powers.get("L", 0) - 1, "s": powers.get("T", 0) + 2}
            return _formula(tuple(rest.items()), {"N": "N", "m": "m", "s": "s"}) or "1"
        return _formula(self.powers, _SI) or "1"


def _formula(powers, symbols: dict[str, str]) -> str:
    """``a*b^2/(c*d^2)`` from (base, power) pairs."""

    def one(base: str, p: Fraction) -> str:
        s = symbols.get(base, base)
        if p == 1:
            return s
        return f"{s}^{p}" if p.denominator == 1 else f"{s}^({p})"

    up = [one(b, Fraction(p)) for b, p in powers if p > 0]
    down = [one(b, -Fraction(p)) for b, p in powers if p < 0]
    if not up and not down:
        return ""
    text = "*".join(up) or "1"
    if down:
        text += "/" + (down[0] if len(down) == 1 else "(" + "*".join(down) + ")")
    return text


DIMENSIONLESS = Dimension()
MASS = Dimension.of(M=1)
LENGTH = Dimension.of(L=1)
TIME = Dimension.of(T=1)
FORCE = Dimension.of(M=1, L=1, T=-2)
ENERGY = Dimension.of(M=1, L=2, T=-2)
_NAMES = {
    MASS: "mass",
    LENGTH: "length",
    TIME: "time",
    ENERGY: "energy",
    FORCE: "force",
    Dimension.of(L=1, T=-1): "velocity",
    Dimension.of(L=1, T=-2): "acceleration",
    Dimension.of(T=-1): "frequency",
    Dimension.of(L=2): "area",
    Dimension.of(M=1, T=-2): "force/length",
    Dimension.of(M=1, L=2): "moment of inertia",
    Dimension.of(M=1, L=1, T=-1): "momentum",
    Dimension.of(L=2, T=-2): "energy/mass",
}


# ----- quantities ---------------------------------------------------------------------
_QUANTITY = re.compile(
    r"^\s*(?P<number>[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?)"
    r"\s*(?![eE][+-]?[0-9])(?P<unit>[A-Za-z_°µΩ][^\n]*?)\s*$"
)
"""A number followed by a unit: what tells a quantity from an expression."""
_UNIT_TEXT = re.compile(r"^[A-Za-z_°µΩ0-9\s*/^().+-]+$")
_MAX_DECIMAL_EXPONENT = 300


class Quantity(NamedTuple):
    """A quantity read from text: its exact value in SI units and its dimension."""

    value: sp.Expr
    dimension: Dimension
    text: str
    unit: str = ""
    """The unit as written (``"cm"``)."""


def is_quantity(value: Any) -> bool:
    """Whether ``value`` is text of a quantity (a number followed by a unit, ``"30 cm"``),
    not an expression (``"R1 + R2"``, ``"2*pi"``, ``"0.5"``)."""
    return isinstance(value, str) and _QUANTITY.match(value) is not None


def quantity(text: str) -> Quantity:
    """The quantity ``text`` (``"30 cm"``) in SI: its exact value and dimension.

    Raises
    ------
    ExpressionError
        The unit is unknown, has an offset (``degC``) or too high a power; the text is
        not a number followed by a unit.
    """
    m = _QUANTITY.match(text)
    if m is None:
        raise ExpressionError('not a number followed by a unit (e.g. "30 cm")', text)
    number = m.group("number")
    exponent = re.search(r"[eE]([+-]?[0-9]+)$", number)
    if exponent and abs(int(exponent.group(1))) > _MAX_DECIMAL_EXPONENT:
        raise ExpressionError(
            f"the number {number} is out of range (powers of ten up to {_MAX_DECIMAL_EXPONENT})",
            text,
        )
    factor, dimension = unit(m.group("unit"), text)
    return Quantity(sp.Rational(number) * factor, dimension, text, m.group("unit"))


def as_quantity(value: Any) -> Quantity | None:
    """``value`` as a ``Quantity`` (:func:`quantity`'s) in SI: the text of a quantity
    (``"30 cm"``) or a pint Quantity (anything with ``magnitude`` and ``units``, from any
    registry: its unit is read again by name); None for anything else (a number, an
    expression). A pint Quantity's value is exact for a scalar (its float's decimal
    times the unit's exact factor), an array of floats for an array.

    Raises
    ------
    ExpressionError
        As :func:`quantity` and :func:`unit`.
    """
    if isinstance(value, str):
        return quantity(value) if is_quantity(value) else None
    if not (hasattr(value, "magnitude") and hasattr(value, "units")):
        return None
    text = str(value.units)  # pint's names: "centimeter", "meter / second ** 2"
    factor, dimension = (
        (sp.Integer(1), DIMENSIONLESS) if text in ("", "dimensionless") else unit(text)
    )
    magnitude = value.magnitude
    if getattr(magnitude, "shape", ()) == ():
        try:
            exact = sp.Rational(repr(float(magnitude))) * factor
        except (TypeError, ValueError):
            raise ExpressionError(
                "a quantity's magnitude must be a real number", str(value)
            ) from None
        return Quantity(exact, dimension, str(value), text)
    import numpy as np

    array = np.asarray(magnitude, dtype=float) * float(factor)
    return Quantity(array, dimension, str(value), text)


_REGISTRY: Any = None
_LOCK = threading.Lock()


def _registry() -> Any:
    """pint's registry of units, made on first use (importing pint takes 0.3-1 s)."""
    global _REGISTRY
    with _LOCK:
        if _REGISTRY is None:
            import pint

            _REGISTRY = pint.UnitRegistry()
        return _REGISTRY


def unit(text: str, whole: str | None = None) -> tuple[sp.Expr, Dimension]:
    """The unit ``text`` (``"m/s^2"``, ``"deg"``): its exact factor to SI and its
    dimension (``"cm"``: (1/100, L); ``"deg"``: (pi/180, dimensionless)).

    Raises
    ------
    ExpressionError
        Unknown to pint, with an offset, or a power above 12.
    """
    shown = whole if whole is not None else text
    words = text.strip()
    if not words or len(words) > 80 or not _UNIT_TEXT.match(words):
        raise ExpressionError(
            f"`{words}` is not a unit; write units such as m, cm, kg, s, N, J, rad, deg, "
            "m/s^2, N/m, kg*m^2",
            shown,
        )
    ureg = _registry()
    try:
        parsed = ureg.parse_units(words)
    except Exception as exc:  # pint's UndefinedUnitError, and its tokenizer's errors
        detail = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise ExpressionError(
            f"unknown unit `{words}` ({detail}); write units such as m, cm, kg, s, N, J, "
            'rad, deg, m/s^2, N/m, kg*m^2 (a unit follows the number: "30 cm")',
            shown,
        ) from None
    factor: sp.Expr = sp.Integer(1)
    powers: dict[str, Fraction] = {}
    for name, raw_power in dict(parsed._units).items():
        p = Fraction(raw_power).limit_denominator(12)
        if abs(p) > MAX_UNIT_POWER:
            raise ExpressionError(
                f"`{words}`: the power {raw_power} of {name} is above {MAX_UNIT_POWER}", shown
            )
        one = ureg.Quantity(1, name).to_base_units()
        two = ureg.Quantity(2, name).to_base_units()
        f1, f2 = float(one.magnitude), float(two.magnitude)
        if not math.isfinite(f1) or f1 == 0 or abs(f2 - 2 * f1) > 1e-12 * abs(f1):
            raise ExpressionError(
                f"`{name}` has an offset (a temperature scale); give a difference in K", shown
            )
        factor *= _exact_factor(f1) ** sp.Rational(p.numerator, p.denominator)
        for base, q in dict(one.dimensionality).items():
            key = _PINT_BASES.get(base, base.strip("[]"))
            powers[key] = powers.get(key, Fraction(0)) + Fraction(q).limit_denominator(12) * p
    return factor, Dimension._make(powers)


def is_angle_unit(text: str) -> bool:
    """Whether the unit ``text`` is an angle or an angle per time (``deg``, ``rad``,
    ``turn``, ``rpm``, ``deg/s``): a unit pint's registry roots in radians. False for
    text that is not a unit."""
    try:
        ureg = _registry()
        root = dict(ureg.get_root_units(ureg.parse_units(text.strip()))[1]._units)
    except Exception:  # not a unit: said where the unit is read
        return False
    return root.get("radian") == 1 and set(root) <= {"radian", "second"}


def spelled_names(unit_text: str, names: Any) -> list[tuple[str, str]]:
    """The words of ``unit_text`` that spell one of ``names`` (a problem's parameters),
    each with the unit pint reads it as: ``("2 g" beside a parameter g)`` gives
    ``[("g", "gram")]``. In a quantity a word is always a unit, so ``"2 g"`` is two grams,
    never twice the parameter g (that is ``"2*g"``)."""
    out = []
    for word in dict.fromkeys(re.findall(r"[A-Za-z_µΩ°][A-Za-z_µΩ°0-9]*", unit_text)):
        if word in names:
            try:
                long = str(_registry().parse_units(word))
            except Exception:  # not a unit alone (said where the unit is read)
                continue
            out.append((word, long))
    return out


def spelled_hint(value: str, unit_text: str, names: Any) -> str:
    """What a quantity's unit that spells a parameter's name means (:func:`spelled_names`),
    as a sentence; "" when it spells none."""
    found = spelled_names(unit_text, names)
    if not found:
        return ""
    said = ", ".join(f"`{w}` is the unit {long}, not the parameter {w}" for w, long in found)
    m = _QUANTITY.match(value)
    number = m.group("number") if m else value
    w = found[0][0]
    return (
        f'in the quantity "{value}", {said}: write "{number}*{w}" for {number} times the parameter'
    )


def _exact_factor(f: float) -> sp.Expr:
    """pint's float factor as the exact number it stands for: a short decimal (0.01,
    0.3048), a rational multiple of pi (pi/180), else the float's exact decimal."""
    for digits in range(1, 13):
        short = float(f"{f:.{digits}g}")
        if short == f or abs(short - f) <= 1e-14 * abs(f):
            return sp.Rational(f"{f:.{digits}g}")
    over_pi = Fraction(f / math.pi).limit_denominator(100_000)
    if abs(float(over_pi) * math.pi - f) <= 1e-14 * abs(f):
        return sp.Rational(over_pi.numerator, over_pi.denominator) * sp.pi
    return sp.Rational(repr(f))
