"""The vocabulary every rule of the model shares: :class:`ModelError`, the kinds of
constraint, shape and scenery, what each field of a problem may contain (:data:`FIELDS`)
and which names may name a parameter or a coordinate.

Every rule returns a list of (where, message); ``where`` names the place the way a
problem file does: ``parameters.l``, ``coordinates.x.initial``, ``lagrangian.V``,
``constraints[2] `rolling` friction.mu``, ``bodies[1] `wheel` mass``, ``forces.x``,
``gravity.acceleration``, ``scenery[1] `pivot` point``, ``loads[1] `push` body``. A part
checked on its own, before it is in a system, does not know its index: ``constraint
`rolling` unilateral``, ``body `wheel` position``, ``load `push` frame``, and a friction
or force spec ``friction.mu``, ``force.at``. The rules themselves are with what they
check: the parts' in :mod:`._parts` and :mod:`._loads`, the whole system's in
:mod:`._whole` and, at the numbers of the initial state, :mod:`._start`.
"""

from __future__ import annotations

import keyword
import re
import threading
from collections import OrderedDict
from collections.abc import Callable, Hashable, Sequence
from enum import Enum
from typing import Any

import sympy as sp

from .._errors import LamechError
from ..expr import FUNCTIONS, RESERVED

__all__ = [
    "ModelError",
    "ConstraintKind",
    "ShapeKind",
    "SceneryKind",
    "FIELDS",
    "name_problem",
    "Memo",
]

Issues = list[tuple[str, str]]


class ModelError(LamechError, ValueError):
    """A definition breaks a rule of the model. ``issues`` lists every (where, message)
    found, so that a user fixes everything in one pass."""

    def __init__(self, issues: list[tuple[str, str]]):
        self.issues = list(issues)
        super().__init__("\n".join(f"{w}: {m}" if w else m for w, m in self.issues))

    @classmethod
    def check(cls, issues: list[tuple[str, str]]) -> None:
        """Raise for ``issues``, if there are any."""
        if issues:
            raise cls(issues)


class _Text(str, Enum):
    """A str enum that prints as its value (``f"{kind}"`` is ``holonomic``)."""

    def __str__(self) -> str:
        return str.__str__(self)

    def __format__(self, spec: str) -> str:
        return str.__format__(str.__str__(self), spec)


class ConstraintKind(_Text):
    """What a constraint's ``expr`` is: f(q, t) = 0, or g(q, q', t) = 0 linear in q'."""

    HOLONOMIC = "holonomic"
    VELOCITY = "velocity"


class ShapeKind(_Text):
    """How a body is drawn: ``Body.shape`` is (kind, size), size None for a point."""

    POINT = "point"
    CIRCLE = "circle"
    ROD = "rod"


class SceneryKind(_Text):
    """What a piece of scenery is: ``Scenery.points`` holds one point, 2 or more, or the
    centre (with ``radius``)."""

    POINT = "point"
    LINE = "line"
    CIRCLE = "circle"


def as_enum(obj, name: str, enum: type[Enum]) -> None:
    """Store a field given as its string value (``"holonomic"``) as the enum member."""
    raw = getattr(obj, name)
    if isinstance(raw, str) and not isinstance(raw, enum):
        try:
            object.__setattr__(obj, name, enum(raw))
        except ValueError:
            pass  # reported by the checks


def as_tuple(obj, *names: str) -> None:
    """Store list fields as tuples (frozen data is hashable)."""
    for name in names:
        raw = getattr(obj, name)
        if isinstance(raw, list):
            object.__setattr__(obj, name, tuple(raw))


_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")

FIELDS: dict[str, tuple[str, str]] = {
    # field: (what may appear in it, how messages name it). "parameters": parameters
    # only; "positions": parameters, coordinates and t; "velocities": those and the
    # coordinates' velocities x'.
    "parameter value": ("parameters", "parameter values"),
    "initial": ("parameters", "initial values (parameters only)"),
    "initial velocity": ("parameters", "initial velocities (parameters only)"),
    "T": ("velocities", "T"),
    "V": ("positions", "V (positions only)"),
    "L": ("velocities", "L"),
    "f": (
        "positions",
        'a holonomic constraint f (positions only; use `velocity = "..."` '
        "for a velocity constraint)",
    ),
    "velocity": ("velocities", "velocity constraints"),
    "restitution": ("positions", "restitution"),
    "mu": ("positions", "mu"),
    "at": ("positions", "positions"),
    "along": ("positions", "directions"),
    "forces": ("velocities", "generalized forces"),
    "mass": ("parameters", "masses (parameters only)"),
    "position": ("positions", "positions"),
    "angle": ("positions", "angles"),
    "inertia": ("parameters", "inertia (parameters only)"),
    "shape": ("parameters", "shapes (parameters only)"),
    "scenery": ("positions", "scenery"),
    "gravity": ("parameters", "gravity (parameters only)"),
    "spring": ("parameters", "spring constants, lengths and damping (parameters only)"),
}
"""What each kind of expression may contain, and its name in messages (the loader
parses with the same)."""


# ----- names ---------------------------------------------------------------------------
def name_problem(name: Any) -> str | None:
    """Why ``name`` cannot name a parameter or coordinate, or None: an identifier, not a
    function or ``t``/``pi``, not ``lambda_...`` (the multipliers) nor containing ``__``."""
    if not isinstance(name, str) or not _IDENT.match(name):
        return f"`{name}` is not a valid name (letters, digits and _, not starting with a digit)"
    if name in RESERVED:
        kind = "a function" if name in FUNCTIONS else "reserved"
        return f"`{name}` is {kind} and cannot be a parameter or coordinate name; rename it"
    if keyword.iskeyword(name):
        return (
            f"`{name}` is reserved (a keyword of the expression syntax, so no expression "
            f"could use it) and cannot be a parameter or coordinate name; rename it "
            f"(e.g. {name}1)"
        )
    if name.startswith("lambda_") or "__" in name:
        return (
            f"`{name}`: names starting with `lambda_` or containing `__` are reserved "
            "(lambda_<constraint> names the multipliers); rename it"
        )
    return None


def identifier_problem(name: Any) -> str | None:
    if not isinstance(name, str) or not _IDENT.match(name):
        return f"`{name}` is not a valid name (letters, digits and _, not starting with a digit)"
    return None


def join(where: str, field: str) -> str:
    return f"{where} {field}" if where else field


def not_expr(value: Any, what: str) -> str:
    return (
        f"{what} must be a SymPy expression (a number as sp.Integer/sp.Float, or in "
        f"the declared symbols), not {type(value).__name__}"
    )


def is_expr(value: Any) -> bool:
    return isinstance(value, sp.Expr)


def is_bool(value: Any) -> bool:
    return isinstance(value, bool)


class Memo:
    """Results remembered by the values they were computed from, for a System's checks:
    each entry is keyed on the values of the fields its computation reads (compared by
    value, as the frozen parts are), so that a copy made with ``dataclasses.replace``
    computes again only what reads a field it changed. The oldest entries are dropped
    beyond ``size``; thread-safe."""

    def __init__(self, size: int = 1024):
        self._data: OrderedDict[Hashable, Any] = OrderedDict()
        self._size = size
        self._lock = threading.Lock()

    @staticmethod
    def key(name: str, obj: Any, fields: Sequence[str]) -> tuple | None:
        """(name, the values of ``obj``'s ``fields``), or None when one of them cannot be
        a key (an unhashable value, which the checks themselves report)."""
        key = (name, *(getattr(obj, f) for f in fields))
        try:
            hash(key)
        except TypeError:
            return None
        return key

    def get(self, key: tuple | None, compute: Callable[[], Any]) -> Any:
        """The value remembered for ``key``, else ``compute()`` (remembered when ``key``
        is not None; an exception is not)."""
        if key is None:
            return compute()
        with self._lock:
            if key in self._data:
                self._data.move_to_end(key)
                return self._data[key]
        value = compute()
        self.put(key, value)
        return value

    def put(self, key: tuple | None, value: Any) -> None:
        if key is None:
            return
        with self._lock:
            self._data[key] = value
            self._data.move_to_end(key)
            while len(self._data) > self._size:
                self._data.popitem(last=False)

    def __contains__(self, key: object) -> bool:
        with self._lock:
            return key in self._data
