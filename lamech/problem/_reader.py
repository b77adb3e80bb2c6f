"""The reader's groundwork: reporting an issue at its line, parsing an expression in
the names a field may contain (:data:`lamech.model._base.FIELDS`), making a part of the model
and placing the issues it finds, and the shapes TOML gives (tables, lists, matrices)."""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path
from typing import Any

import sympy as sp

from ..expr import Dimension, ExpressionError, is_quantity, parse
from ..model import ModelError
from ..model._base import FIELDS
from ._files import Issue, Lines, ProblemFileError

# A model's `where` for a part in a system (constraints[2] `rolling` friction.mu) and for
# a part checked on its own (constraint `rolling` unilateral).
_PART_IN_SYSTEM = re.compile(r"^(constraints|bodies|scenery|loads)\[(\d+)\] `[^`]*`(?: (\S+))?")
_PART_ALONE = re.compile(r"^(?:constraint|body|scenery|load) `[^`]*`")


class Reader:
    """What every section's reader shares: the problem's data, its lines, the issues
    found so far, and the names each kind of field may use."""

    def __init__(
        self, data: Any, name: str, text: str | None, folders: tuple[Path, ...] | None = None
    ):
        self.data = data
        self.source = name
        self.folders = folders  # where named files may be; None: no files
        self.lines = Lines(text)
        self.problems: list[Issue] = []
        self.t = sp.Symbol("t", real=True)
        self.scopes: dict[str, dict[str, sp.Expr]] = {}
        self.spin_hints: dict[str, str] = {}  # body: why `body.wx` means nothing
        # the dimensions the file gives by a unit (issue 46), by parameter or coordinate
        self.dimensions: dict[str, Dimension] = {}
        self.angles: set[str] = set()  # the parameters given in a unit of angle ("30 deg")
        self.quantities: dict[str, str] = {}  # each parameter given as a quantity: its text

    def problem(
        self, where: str, message: str, loc: tuple = (None, None, None), text: str | None = None
    ) -> None:
        line = self.lines.find(*loc)
        if text is None and line and self.lines.lines:
            text = self.lines.lines[line - 1].strip()
        self.problems.append(Issue(where, message, line, text))

    def model_problems(self, error: ModelError, part: str | None = None) -> None:
        """Report the issues the model found, each at its line. ``part`` (like
        ``constraints[2] `rolling```) places the issues of a part checked on its own
        (``constraint `rolling` unilateral``, ``friction.mu``)."""
        for where, message in error.issues:
            if part is not None:
                where, n = _PART_ALONE.subn(part, where, count=1)
                where = where if n else f"{part} {where}"
            self.problem(where, message, self._locate(where))

    def _locate(self, where: str) -> tuple:
        """The location tuple (table, index, key) of a model's ``where``."""
        if m := _PART_IN_SYSTEM.match(where):
            table, i, field = m.group(1), int(m.group(2)) - 1, m.group(3)
            key = field.split(".")[0] if field else None
            if table == "constraints" and key in (None, "kind", "multiplier"):
                raw = self.data.get("constraints")
                spec = raw[i] if isinstance(raw, list) and i < len(raw) else {}
                key = "velocity" if isinstance(spec, dict) and "velocity" in spec else "f"
            return (table, i, key)
        head, _, rest = where.partition(".")
        if head in ("parameters", "forces"):
            return (head, None, rest or None)
        if head == "coordinates":
            name = re.sub(r"\.(initial|velocity|keep)$", "", rest)
            return (head, None, name or None)
        if head == "lagrangian":
            table = self.data.get("lagrangian")
            table = table if isinstance(table, dict) else {}
            return ("lagrangian", None, rest if rest in table else "L" if "L" in table else None)
        if head == "gravity":
            return ("gravity", None, "acceleration")
        if head == "bodies":
            return ("bodies", 0, "position")
        if head.startswith("parametrisation"):
            key = rest if rest and " " not in rest else None
            return ("parametrisation", None, key)
        return (None, None, None)

    def make(
        self, cls: Callable[..., Any], *args: Any, part: str | None = None, **kwargs: Any
    ) -> Any:
        """``cls(*args, **kwargs)``, a part of the model that checks itself; None (and its
        issues reported) when the model refuses it."""
        try:
            return cls(*args, **kwargs)
        except ModelError as exc:
            self.model_problems(exc, part)
            return None

    def expr(
        self,
        value: Any,
        names: dict[str, sp.Expr],
        where: str,
        loc: tuple,
        what: str,
        hints: dict[str, str] | None = None,
    ) -> sp.Expr | None:
        if isinstance(value, sp.Basic):
            return self._sympy_value(value, names, where, loc)
        if is_quantity(value):
            self.problem(
                where,
                f"`{value}` is a quantity with a unit, which only [parameters] and "
                "[coordinates] take: declare a parameter (`name = "
                f'"{value}"`) and use its name here',
                loc,
            )
            return None
        try:
            return parse(value, names, what, hints=hints)
        except ExpressionError as exc:
            shown = str(value) if len(str(value)) <= 120 else str(value)[:117] + "..."
            col = f" (column {exc.column})" if exc.column else ""
            self.problem(where, exc.message + col, loc, None if self.lines.lines else shown)
            return None

    def field(self, value: Any, field: str, where: str, loc: tuple) -> sp.Expr | None:
        """Parse ``value`` as the model's ``field`` (a key of :data:`lamech.model._base.FIELDS`):
        with the names that field may contain, named in messages as the model does."""
        scope, what = FIELDS[field]
        hints = self.spin_hints
        if scope != "velocities":  # a body's angular velocity is a velocity
            hints = {b: f"angular velocities are not allowed in {what}" for b in self._body_names()}
        return self.expr(value, self.scopes[scope], where, loc, what, hints)

    def _sympy_value(
        self, value: sp.Basic, names: dict[str, sp.Expr], where: str, loc: tuple
    ) -> sp.Expr | None:
        by_name = {str(s): s for s in value.free_symbols}
        unknown = sorted(n for n in by_name if n not in names)
        if unknown:
            self.problem(
                where,
                f"unknown name `{unknown[0]}`; known: "
                + ", ".join(sorted(n for n in names if "'" not in n and "." not in n)),
                loc,
            )
            return None
        return value.xreplace({s: names[n] for n, s in by_name.items()})

    def table(self, key: str, required: bool = False) -> dict | None:
        value = self.data.get(key)
        if value is None:
            if required:
                self.problem(
                    key,
                    f"missing section [{key}]; see the problem-file reference "
                    "(docs/reference/problem-file.md)",
                )
            return None
        if not isinstance(value, dict):
            self.problem(
                key,
                f"[{key}] must be a table (`[{key}]` followed by `name = ...` "
                f"lines), not {type(value).__name__}",
                (None, None, key),
            )
            return None
        return value

    def fail_if_any(self) -> None:
        if self.problems:
            # the model may see again what the loader reported: each issue once
            raise ProblemFileError(self.source, list(dict.fromkeys(self.problems)))

    def _vector(self, value, field, where, loc) -> tuple | None:
        """A list of expressions (its length is the model's to check)."""
        if value is None:
            self.problem(where, "missing (a list of 2 or 3 expressions)", loc)
            return None
        items = value if isinstance(value, (list, tuple)) else [value]
        parts = [self.field(v, field, where, loc) for v in items]
        if any(p is None for p in parts):
            return None
        return tuple(parts)

    def _matrix(self, value, field: str, where: str, loc: tuple):
        """3 rows of 3 expressions."""
        if not (
            isinstance(value, list)
            and len(value) == 3
            and all(isinstance(r, list) and len(r) == 3 for r in value)
        ):
            self.problem(where, "must be 3 rows of 3 expressions", loc)
            return None
        rows = [[self.field(x, field, where, loc) for x in r] for r in value]
        if any(x is None for r in rows for x in r):
            return None
        return tuple(tuple(r) for r in rows)

    def _body_names(self) -> list[str]:
        """The names the file gives its bodies (parsed or not)."""
        raw = self.data.get("bodies")
        if not isinstance(raw, list):
            return []
        return [b["name"] for b in raw if isinstance(b, dict) and isinstance(b.get("name"), str)]
