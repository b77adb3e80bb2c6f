"""Problem files (TOML) and plain dicts to a checked :class:`~lamech.model.System`.

Every problem found is collected and reported at once in a :class:`ProblemFileError`
naming the file, line, offending text and the fix, so a user mends a file in one pass.
Expressions go through :func:`lamech.expr.parse` only: nothing in a file is executed.
See the problem-file reference (docs/reference/problem-file.md) for the format.
"""

from __future__ import annotations

import math
import random
import re
import stat
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import sympy as sp

from ..expr import (
    MAX_NUMBER_DIGITS,
    RESERVED,
    ExpressionError,
    TimeDerivative,
    parse,
    printable,
    tabulated,
    to_text,
)
from ..model import (
    FIELDS,
    Body,
    Chart,
    Constraint,
    ConstraintKind,
    Coordinate,
    ForceSpec,
    Friction,
    ModelError,
    Parameter,
    Scenery,
    ShapeKind,
    System,
    angular_velocity,
    body_energy,
    body_rotation,
    name_problem,
    partial_velocities,
    time_derivative,
)
from ._examples import example_names, example_path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["ProblemFileError", "Issue", "load", "loads", "from_dict"]

# A model's `where` for a part in a system (constraints[2] `rolling` friction.mu) and for
# a part checked on its own (constraint `rolling` unilateral).
_PART_IN_SYSTEM = re.compile(r"^(constraints|bodies|scenery)\[(\d+)\] `[^`]*`(?: (\S+))?")
_PART_ALONE = re.compile(r"^(?:constraint|body|scenery) `[^`]*`")
_KNOWN_SECTIONS = {
    "title",
    "parameters",
    "coordinates",
    "lagrangian",
    "constraints",
    "bodies",
    "gravity",
    "forces",
    "description",
    "scenery",
    "parametrisation",
    "loads",
    "inputs",
    "sliders",
}


@dataclass(frozen=True)
class Issue:
    """One thing wrong in a problem file: where (``where`` like ``constraints[2].f``,
    ``line``), what (``message``, with the fix) and the offending ``text``."""

    where: str
    message: str
    line: int | None = None
    text: str | None = None

    def format(self, source: str) -> str:
        """``file:line: where: message`` and the offending line; control characters
        (from a file name, a key, a title) escaped, never sent to the terminal raw."""
        source, where, message = printable(source), printable(self.where), printable(self.message)
        head = f"{source}:{self.line}:" if self.line else f"{source}:"
        out = f"{head} {where}: {message}" if where else f"{head} {message}"
        if self.text:
            out += f"\n    {printable(self.text)}"
        return out


_KEY_LINE = re.compile(r"""^\s*("[^"]*"|'[^']*'|[A-Za-z0-9_.\-]+)\s*=""")
_TABLE_LINE = re.compile(r"^\s*\[\[?\s*([^\]]+?)\s*\]\]?")


def _repeated_key(text: str) -> tuple[int, str, int] | None:
    """(line, key, first line) of a key repeated within one table, for the message only.

    tomllib says "Cannot overwrite a value", sometimes "at end of document": this scan
    finds which key and where. The file is still parsed by tomllib alone.
    """
    seen: dict[str, int] = {}
    tables: dict[str, int] = {}
    for number, line in enumerate(text.splitlines(), 1):
        if m := _TABLE_LINE.match(line):
            name = m.group(1)
            if not line.lstrip().startswith("[[") and name in tables:
                return number, f"[{name}]", tables[name]
            tables[name] = number
            seen = {}
        elif m := _KEY_LINE.match(line):
            key = m.group(1).strip("\"'")
            if key in seen:
                return number, key, seen[key]
            seen[key] = number
    return None


class ProblemFileError(ValueError):
    """A problem file (or dict) cannot be used; ``problems`` lists everything wrong."""

    def __init__(self, source: str, problems: list[Issue]):
        self.source = source
        self.problems = list(problems)
        super().__init__("\n".join(p.format(source) for p in problems))


class _Lines:
    """Find the line of a key in TOML text (tomllib keeps no positions)."""

    _HEADER = re.compile(r"^\s*(\[\[?)\s*([A-Za-z0-9_.\"' -]+?)\s*\]\]?\s*(#.*)?$")

    def __init__(self, text: str | None):
        self.lines = text.splitlines() if text else []

    def find(self, table: str | None, index: int | None, key: str | None) -> int | None:
        """Line (1-based) of ``key`` in ``[table]`` (the ``index``-th ``[[table]]``)."""
        if not self.lines:
            return None
        current: tuple[str, int | None] | None = None
        count, header_line = -1, None
        key_re = None
        if key:
            # a key with control characters is written with TOML escapes (\u001b)
            spelled = {key, *(_toml_escaped(key, form) for form in ("\\u{:04x}", "\\u{:04X}"))}
            either = "|".join(re.escape(k) for k in sorted(spelled))
            key_re = re.compile(r"^\s*[\"']?(?:" + either + r")[\"']?\s*=")
        for i, line in enumerate(self.lines, start=1):
            m = self._HEADER.match(line)
            if m:
                name = m.group(2).strip()
                if m.group(1) == "[[":
                    count = count + 1 if name == table else count
                    current = (name, count)
                else:
                    current = (name, None)
                if current == (table, index) and key is None:
                    return i
                if current == (table, index):
                    header_line = i
                continue
            in_table = (current == (table, index)) if table else current is None
            if in_table and key_re and key_re.match(line):
                return i
        return header_line


def _toml_escaped(key: str, form: str) -> str:
    return "".join(c if c.isprintable() else form.format(ord(c)) for c in key)


MAX_BYTES = 1_000_000
"""The largest problem file read (bytes); a larger one, or an endless one, is refused."""
LIMITS = {
    "parameters": 500,
    "coordinates": 200,
    "constraints": 200,
    "bodies": 200,
    "scenery": 1000,
    "loads": 1000,
}
"""The most entries of each section a problem file may have: 20,000 coordinates fit in
a 369 kB file, but their 20000 x 20000 symbolic mass matrix takes minutes to build."""


MAX_TABLE_ROWS = 2000
"""Rows of a tabulated input (each row is a switch the generated code evaluates)."""


def _inside(path: Path, folders: tuple[Path, ...]) -> bool:
    """Whether ``path``, symlinks followed, lies in one of ``folders``."""
    try:
        real = path.resolve()
    except (OSError, RuntimeError):  # a symlink loop
        return False
    return any(real.is_relative_to(f) for f in folders)


def _read_table(
    folders: tuple[Path, ...] | None, spec: dict
) -> tuple[list[float], list[float]] | str:
    """(times, values) of an ``[inputs]`` table, or what is wrong with it. The file is
    named relative to the problem file and must lie, symlinks followed, in one of
    ``folders`` (the problem file's, and ``--data-dir``'s); at most 1 MB of it is read.
    Nothing of a file that is not a table of numbers is ever quoted, and a path outside
    the folders is refused before it is looked at (whether it exists is not told)."""
    import csv
    import io

    file = spec["csv"]
    if not isinstance(file, str) or not file or "\0" in file:
        return "csv must be a file name"
    if not folders:
        return (
            "a problem given as text (not loaded from a file) names no files; save it "
            "as a .toml file beside its table and load that"
        )
    path = folders[0] / file
    if not _inside(path, folders):
        return (
            f"`{printable(file)}` is outside the problem file's folder (symlinks "
            "followed); put the table beside the problem file, or name the folder that "
            "holds it with `data_dir=`"
        )
    try:
        if not path.is_file():
            return f"no such file `{printable(file)}` (a csv path is relative to the problem file)"
        with path.open("rb") as fh:
            raw = fh.read(MAX_BYTES + 1)
        if len(raw) > MAX_BYTES:
            return f"`{printable(file)}` is too large (over 1 MB)"
        rows = list(csv.reader(io.StringIO(raw.decode("utf-8-sig"))))
    except OSError as exc:
        return f"cannot read `{printable(file)}`: {exc.strerror or 'error'}"
    except (UnicodeDecodeError, csv.Error):
        return (
            f"`{printable(file)}` is not a table of numbers (not UTF-8 CSV text); give a "
            "CSV file: a header row of names, then rows of numbers"
        )
    rows = [r for r in rows if any(c.strip() for c in r)]
    if len(rows) < 3:
        return f"`{printable(file)}` needs a header row and two or more rows of numbers"
    header = [c.strip() for c in rows[0]]
    for line, row in enumerate(rows[1:], start=2):
        if len(row) != len(header) or not all(_number(c) for c in row):
            # not a table: nothing of it is quoted (it may be anything, a .env file)
            return (
                f"`{printable(file)}` is not a table of numbers: row {line}: not "
                f"{_COUNT.get(len(header), len(header))} numbers (as many as the header's "
                "names); give a "
                "CSV file: a header row of names, then rows of numbers"
            )
    time_name = spec.get("time", header[0])
    column = spec.get("column")
    if column is None:
        if len(header) != 2:
            return f'`{printable(file)}` has {len(header)} columns: say which with column = "..."'
        column = header[1]
    for what, key in (("time", time_name), ("column", column)):
        if not isinstance(key, str) or key not in header:
            return (
                f"{what} `{printable(str(key))}` is not a column of `{printable(file)}`; "
                "its columns: " + ", ".join(printable(h) for h in header)
            )
    ti, vi = header.index(time_name), header.index(column)
    times: list[float] = []
    values: list[float] = []
    for line, row in enumerate(rows[1:], start=2):
        try:
            tv, vv = float(row[ti]), float(row[vi])
        except (IndexError, ValueError):
            return (
                f"`{printable(file)}` row {line}: not two numbers in columns {time_name}, {column}"
            )
        if not (math.isfinite(tv) and math.isfinite(vv)):
            return f"`{printable(file)}` row {line}: not a finite number"
        if times and tv <= times[-1]:
            return (
                f"`{printable(file)}` row {line}: the times must increase ({tv:g} after "
                f"{times[-1]:g})"
            )
        times.append(tv)
        values.append(vv)
    if len(times) > MAX_TABLE_ROWS:
        return f"`{printable(file)}` has {len(times)} rows; at most {MAX_TABLE_ROWS} (resample it)"
    return times, values


_COUNT = {1: "one", 2: "two", 3: "three", 4: "four"}


def _number(cell: str) -> bool:
    try:
        float(cell)
    except ValueError:
        return False
    return True


def load(path: str | Path, data_dir: str | Path | None = None) -> System:
    """Load a problem file, or a bundled example by name (``"cylinder"``).

    A file the problem names (an ``[inputs]`` table) must lie, symlinks followed, in the
    problem file's folder or in ``data_dir``.

    Raises
    ------
    ProblemFileError
        Everything wrong with the file, each with its line and the fix.
    """
    p = Path(path)
    if not p.exists() and not p.suffix and str(path) in example_names():
        p = example_path(str(path))
    if not p.exists():
        hint = ", ".join(example_names())
        raise ProblemFileError(
            str(path),
            [
                Issue(
                    "",
                    f"no such file; give a path to a .toml problem file or a bundled example "
                    f"({hint})",
                )
            ],
        )
    if p.is_dir():
        raise ProblemFileError(str(path), [Issue("", "is a directory, not a problem file")])
    try:
        if not stat.S_ISREG(p.stat().st_mode):
            # /dev/zero would be read forever, a FIFO would block: neither is a file
            raise ProblemFileError(
                str(path),
                [Issue("", "is not a regular file (a device, pipe or socket); give a .toml file")],
            )
        with p.open("rb") as fh:
            raw = fh.read(MAX_BYTES + 1)  # never more than the limit, whatever the file
        if len(raw) > MAX_BYTES:
            raise ProblemFileError(str(path), [Issue("", "file too large (over 1 MB)")])
        text = raw.decode("utf-8-sig")  # a byte-order mark is not part of the TOML
    except (OSError, UnicodeDecodeError) as exc:
        raise ProblemFileError(str(path), [Issue("", f"cannot read the file: {exc}")]) from None
    folders = [p.resolve().parent]
    if data_dir is not None:
        folders.append(Path(data_dir).resolve())
    return _parse(text.replace("\r\n", "\n"), str(path), tuple(folders))


def loads(text: str, name: str = "<string>") -> System:
    """Load a problem from TOML text; ``name`` is used in error messages. A problem
    given as text has no folder: it may name no files (an ``[inputs]`` table is refused;
    save it as a file and :func:`load` that)."""
    return _parse(text, name, None)


def _parse(text: str, name: str, folders: tuple[Path, ...] | None) -> System:
    if len(text) > MAX_BYTES:
        raise ProblemFileError(name, [Issue("", "file too large (over 1 MB)")])
    text = text.removeprefix("\ufeff")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc)
        m = re.search(r"\(at line (\d+), column (\d+)\)", msg)
        line = int(m.group(1)) if m else None
        bare = re.sub(r"\s*\(at line \d+, column \d+\)", "", msg)
        hint = "check quoting (expressions go in double quotes) and that each line is `key = value`"
        if "overwrite" in bare or "twice" in bare:
            found = _repeated_key(text)
            if found:
                line, key, first = found
                bare = f"`{key}` is defined twice (first on line {first})"
                hint = "each key may appear once in a table: remove or rename one of them"
        offending = text.splitlines()[line - 1] if line and line <= len(text.splitlines()) else None
        raise ProblemFileError(
            name, [Issue("", f"TOML syntax error: {bare}; {hint}", line, offending)]
        ) from None
    except ValueError:
        # tomllib's int() of an integer longer than Python converts (4300 digits)
        lines = text.splitlines()
        line = next((i for i, ln in enumerate(lines, 1) if _LONG_NUMBER.search(ln)), None)
        raise ProblemFileError(
            name,
            [
                Issue(
                    "",
                    f"a number with more than {_INT_DIGITS} digits; numbers "
                    f"in a problem file have at most {MAX_NUMBER_DIGITS} digits",
                    line,
                    lines[line - 1][:60] + "..." if line else None,
                )
            ],
        ) from None
    except RecursionError:
        raise ProblemFileError(
            name, [Issue("", "TOML nested too deeply (arrays or tables inside each other)")]
        ) from None
    return _Loader(data, name, text, folders).build()


_LONG_NUMBER = re.compile(r"[0-9_]{1000,}")
_INT_DIGITS = getattr(sys, "get_int_max_str_digits", lambda: 4300)()


def from_dict(data: dict[str, Any], name: str = "<dict>", text: str | None = None) -> System:
    """Build a checked :class:`System` from a dict in the problem-file layout.

    Values that are expressions may be strings in the grammar, numbers, or SymPy
    expressions whose symbols carry declared names.
    """
    return _Loader(data, name, text).build()


class _Loader:
    """Parses a problem (TOML shapes, expressions) into the model's parts; the model
    checks them (:mod:`lamech.model`), and each issue it finds is reported here with the
    file's line."""

    def __init__(
        self, data: Any, name: str, text: str | None, folders: tuple[Path, ...] | None = None
    ):
        self.data = data
        self.source = name
        self.folders = folders  # where named files may be; None: no files
        self.lines = _Lines(text)
        self.problems: list[Issue] = []
        self.t = sp.Symbol("t", real=True)
        self.scopes: dict[str, dict[str, sp.Expr]] = {}
        self.spin_hints: dict[str, str] = {}  # body: why `body.wx` means nothing

    # ----- reporting -----------------------------------------------------------------
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

    def make(self, cls: type, *args: Any, part: str | None = None, **kwargs: Any) -> Any:
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
        try:
            return parse(value, names, what, hints=hints)
        except ExpressionError as exc:
            shown = str(value) if len(str(value)) <= 120 else str(value)[:117] + "..."
            col = f" (column {exc.column})" if exc.column else ""
            self.problem(where, exc.message + col, loc, None if self.lines.lines else shown)
            return None

    def field(self, value: Any, field: str, where: str, loc: tuple) -> sp.Expr | None:
        """Parse ``value`` as the model's ``field`` (a key of :data:`lamech.model.FIELDS`):
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

    # ----- build -------------------------------------------------------------------
    def build(self) -> System:
        if not isinstance(self.data, dict):
            raise ProblemFileError(self.source, [Issue("", "a problem must be a table")])
        for key in self.data:
            if key not in _KNOWN_SECTIONS:
                self.problem(
                    key,
                    f"unknown section or key `{key}`; known: " + ", ".join(sorted(_KNOWN_SECTIONS)),
                    (None, None, key),
                )
        for section, limit in LIMITS.items():
            items = self.data.get(section)
            if isinstance(items, (dict, list)) and len(items) > limit:
                self.problem(
                    section,
                    f"{len(items)} {section}: a problem file may have at most {limit} "
                    "(the symbolic derivation grows faster than the system: n coordinates "
                    "make an n x n mass matrix); describe a smaller system",
                    (section, 0, None) if isinstance(items, list) else (section, None, None),
                )
        self.fail_if_any()
        title = self.data.get("title", Path(self.source).stem)
        if not isinstance(title, str):
            self.problem("title", "title must be a string", (None, None, "title"))
            title = str(title)
        elif printable(title) != title:
            bad = next(c for c in title if printable(c) != c)
            self.problem(
                "title",
                f"the title contains the control character {printable(bad)}; a title is "
                "one line of plain text",
                (None, None, "title"),
            )
        params = self._parameters()
        self.scopes["parameters"] = {p.name: p.symbol for p in params}
        coords = self._coordinates()
        declared = self.data.get("coordinates")
        if not coords or not isinstance(declared, dict) or len(coords) != len(declared):
            # A coordinate missing would make each use of it an 'unknown name'. With all
            # of them made (a bad value replaced), go on: the next error is reported too.
            self.fail_if_any()

        positions = {"t": self.t, **self.scopes["parameters"]}
        for c in coords:
            positions[c.name] = c.symbol
        velocities = dict(positions)
        for c in coords:
            velocities[c.name + "'"] = c.velocity
        self.scopes.update(positions=positions, velocities=velocities)
        for name, value in self._inputs(positions).items():
            positions[name] = velocities[name] = value
        # The coordinates and parameters alone (checked as such), for the kinematics of
        # the bodies: T is a stand-in (time derivatives need only q and t).
        skeleton = self.make(
            System,
            title=title,
            parameters=tuple(params),
            coordinates=tuple(coords),
            T=sum((c.velocity**2 for c in coords), sp.Integer(0)),
            V=sp.Integer(0),
            constraints=(),
            t=self.t,
        )
        if skeleton is None:
            self.fail_if_any()

        gravity = self._gravity()
        bodies = self._bodies()
        self._angular_velocities(skeleton, bodies)
        T, V = self._lagrangian(skeleton, bodies, gravity)
        constraints = self._constraints()
        forces = self._forces(coords)
        if skeleton is not None and "loads" in self.data:
            extra_Q, extra_V = self._loads(skeleton, bodies)
            forces = [f + q for f, q in zip(forces, extra_Q)]
            V = V + extra_V
        scenery = self._scenery()
        sliders = self._sliders(params, constraints)
        self.fail_if_any()
        notes = self._compare_energy(skeleton, bodies, gravity, T, V)
        chart = self._chart(coords)
        self.fail_if_any()
        system = self.make(
            System,
            title=title,
            parameters=tuple(params),
            coordinates=tuple(coords),
            T=T,
            V=V,
            constraints=tuple(constraints),
            bodies=tuple(bodies),
            gravity=gravity,
            forces=tuple(forces),
            t=self.t,
            source=self.source,
            notes=tuple(notes),
            scenery=tuple(scenery),
            chart=chart,
            sliders=tuple(sliders),
        )
        self.fail_if_any()
        return system

    def _chart(self, coords: list[Coordinate]) -> Chart | None:
        """``[parametrisation]``: ``coordinates = ["theta1", ...]`` (the new ones) and
        ``x1 = "l1*sin(theta1)"`` for each coordinate parametrised."""
        table = self.table("parametrisation")
        if table is None:
            return None
        loc = ("parametrisation", None, "coordinates")
        names = table.get("coordinates")
        if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
            self.problem(
                "parametrisation.coordinates",
                'list the new coordinates: `coordinates = ["theta1", "theta2"]`',
                loc if "coordinates" in table else ("parametrisation", None, None),
            )
            return None
        new = []
        taken = set(self.scopes["positions"])
        for n in names:
            problem = name_problem(n)
            if problem is None and n in taken:
                problem = (
                    f"`{n}` is already a parameter or a coordinate; new coordinates need new names"
                )
            if problem is not None:
                self.problem("parametrisation.coordinates", problem, loc)
                continue
            new.append(
                Coordinate(
                    n,
                    sp.Symbol(n, real=True),
                    TimeDerivative(n + "'", real=True),
                    TimeDerivative(n + "''", real=True),
                    sp.Integer(0),
                    sp.Integer(0),
                )
            )
        by_name = {c.name: c for c in coords}
        scope = dict(self.scopes["positions"])
        scope.update({c.name: c.symbol for c in new})
        pairs = []
        for key, value in table.items():
            if key == "coordinates":
                continue
            where = f"parametrisation.{key}"
            kloc = ("parametrisation", None, key)
            if key not in by_name:
                self.problem(
                    where,
                    f"`{key}` is not a coordinate; the parametrisation gives coordinates "
                    "(known: " + ", ".join(by_name) + ") as expressions of the new ones",
                    kloc,
                )
                continue
            if not isinstance(value, (str, int, float)) or isinstance(value, bool):
                self.problem(where, 'an expression string, e.g. "l1*sin(theta1)"', kloc)
                continue
            e = self.expr(value, scope, where, kloc, "a parametrised coordinate")
            if e is not None:
                pairs.append((by_name[key].symbol, e))
        if not pairs:
            self.problem(
                "parametrisation",
                "give at least one coordinate as an expression of the new ones "
                '(x1 = "l1*sin(theta1)")',
                ("parametrisation", None, None),
            )
            return None
        return Chart(tuple(new), tuple(pairs))

    def _inputs(self, taken: dict) -> dict[str, sp.Expr]:
        """``[inputs]``: tabulated inputs, ``name = { csv = "file.csv", column = "tau" }``
        (``time = "t"``: the time column, by default the first), a function of t
        interpolated linearly between the rows (:func:`lamech.expr.tabulated`)."""
        table = self.table("inputs") or {}
        out: dict[str, sp.Expr] = {}
        for name, spec in table.items():
            where, loc = f"inputs.{name}", ("inputs", None, name)
            if (
                name in taken
                or name in RESERVED
                or not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name)
            ):
                self.problem(
                    where,
                    f"`{name}` cannot name an input: it is taken or not a plain name",
                    loc,
                )
                continue
            if not isinstance(spec, dict) or "csv" not in spec:
                self.problem(
                    where,
                    'an input is a table: name = { csv = "file.csv", column = "name" }',
                    loc,
                )
                continue
            extra = sorted(set(spec) - {"csv", "column", "time"})
            if extra:
                self.problem(where, f"unknown key `{extra[0]}`; known: csv, column, time", loc)
                continue
            read = _read_table(self.folders, spec)
            if isinstance(read, str):
                self.problem(where, read, loc)
                read = ([0.0, 1.0], [0.0, 0.0])  # a stand-in: its uses are no further error
            out[name] = tabulated(name, *read, self.t)
        return out

    def _parameters(self) -> list[Parameter]:
        table = self.table("parameters") or {}
        raw: dict[str, Any] = {}
        for name, value in table.items():
            problem = name_problem(name)
            if problem is not None:
                self.problem(f"parameters.{name}", problem, ("parameters", None, name))
            else:
                raw[name] = value
        symbols = {n: sp.Symbol(n, real=True) for n in raw}
        exprs: dict[str, sp.Expr] = {}
        for n, value in raw.items():
            if isinstance(value, bool) or not isinstance(value, (int, float, str, sp.Basic)):
                self.problem(
                    f"parameters.{n}",
                    f"value must be a number or an expression string, not {type(value).__name__}",
                    ("parameters", None, n),
                )
                continue
            e = self.expr(
                value,
                symbols,
                f"parameters.{n}",
                ("parameters", None, n),
                FIELDS["parameter value"][1],
            )
            if e is not None:
                exprs[n] = e
        numeric: dict[str, float] = {}
        # Resolve values in dependency order; a cycle is reported, not looped on. A value
        # that is not finite is the model's to report; 1 stands in for it meanwhile.
        pending = dict(exprs)
        while pending:
            progress = False
            for n, e in list(pending.items()):
                deps = {str(s) for s in e.free_symbols}
                if deps <= set(numeric):
                    env = {
                        symbols[d]: numeric[d] if math.isfinite(numeric[d]) else 1.0 for d in deps
                    }
                    try:
                        numeric[n] = float(e.subs(env).evalf(30))
                    except (TypeError, ValueError):
                        numeric[n] = float("nan")
                    del pending[n]
                    progress = True
            if not progress:
                cyc = ", ".join(sorted(pending))
                self.problem(
                    "parameters",
                    f"parameter values refer to each other in a cycle "
                    f"({cyc}); give at least one of them a number",
                    ("parameters", None, sorted(pending)[0]),
                )
                break
        final = {}
        for n in raw:
            v = numeric.get(n, float("nan"))
            final[symbols[n]] = (
                sp.Symbol(n, positive=True)
                if v > 0
                else (sp.Symbol(n, negative=True) if v < 0 else sp.Symbol(n, real=True))
            )
        out = []
        for n in raw:
            p = None
            if n in numeric:
                p = self.make(Parameter, n, final[symbols[n]], exprs[n].xreplace(final), numeric[n])
            # On an error (recorded), keep the name known so that later expressions
            # using it do not report a misleading 'unknown name'.
            out.append(p or Parameter(n, symbols[n], symbols[n], 1.0))
        return out

    def _coordinates(self) -> list[Coordinate]:
        table = self.table("coordinates", required=True)
        if not table:
            if table is not None:
                self.problem(
                    "coordinates",
                    "[coordinates] is empty; declare at least one "
                    "coordinate as `x = { initial = 0, velocity = 0 }`",
                    ("coordinates", None, None),
                )
            return []
        out = []
        for name, spec in table.items():
            loc = ("coordinates", None, name)
            where = f"coordinates.{name}"
            if not isinstance(spec, dict):
                self.problem(
                    where,
                    f"a coordinate is an inline table: `{name} = {{ initial = 0, velocity = 0 }}`",
                    loc,
                )
                continue
            extra = set(spec) - {"initial", "velocity", "keep"}
            if extra:
                self.problem(
                    where,
                    f"unknown key `{sorted(extra)[0]}`; a coordinate takes "
                    "initial, velocity and keep",
                    loc,
                )
            if "initial" not in spec:
                self.problem(
                    where,
                    "missing `initial` (the initial value, a number or an "
                    "expression of parameters)",
                    loc,
                )
                continue
            q0 = self.field(spec["initial"], "initial", where + ".initial", loc)
            v0 = self.field(spec.get("velocity", 0), "initial velocity", where + ".velocity", loc)
            keep = spec.get("keep", False)
            if not isinstance(keep, bool):
                self.problem(where + ".keep", "`keep` must be true or false", loc)
            # a bad value is reported; 0 and False stand in for it, so that the rest of
            # the file is still read and its errors are reported with this one
            q0 = sp.Integer(0) if q0 is None else q0
            v0 = sp.Integer(0) if v0 is None else v0
            coordinate = self.make(
                Coordinate,
                name,
                sp.Symbol(name, real=True),
                TimeDerivative(name + "'", real=True),
                TimeDerivative(name + "''", real=True),
                q0,
                v0,
                keep if isinstance(keep, bool) else False,
            )
            if coordinate is not None:
                out.append(coordinate)
        return out

    def _gravity(self) -> sp.Expr | None:
        table = self.table("gravity")
        if table is None:
            return None
        if "acceleration" not in table:
            self.problem(
                "gravity",
                'missing `acceleration` (e.g. acceleration = "g")',
                ("gravity", None, None),
            )
            return None
        return self.field(
            table["acceleration"],
            "gravity",
            "gravity.acceleration",
            ("gravity", None, "acceleration"),
        )

    def _bodies(self) -> list[Body]:
        raw = self.data.get("bodies", [])
        if not isinstance(raw, list):
            self.problem(
                "bodies",
                "bodies are an array of tables: each starts with `[[bodies]]`",
                (None, None, "bodies"),
            )
            return []
        out = []
        for i, spec in enumerate(raw):
            loc0 = ("bodies", i, None)
            if not isinstance(spec, dict):
                self.problem(f"bodies[{i + 1}]", "must be a table", loc0)
                continue
            name = spec.get("name", f"body{i + 1}")
            where = f"bodies[{i + 1}] `{name}`"
            before = len(self.problems)
            keys = {"name", "mass", "position", "angle", "inertia", "shape"}
            keys |= {"rotation", "rotation_frame", "orientation"}
            extra = set(spec) - keys
            if extra:
                self.problem(
                    where,
                    f"unknown key `{sorted(extra)[0]}`; a body takes name, mass, position, "
                    "angle, inertia, shape, and in space rotation, rotation_frame or "
                    "orientation",
                    loc0,
                )
            if "mass" not in spec:
                self.problem(where, "missing `mass`", loc0)
                continue
            parts: dict[str, Any] = {}
            for key in ("mass", "angle"):
                if key in spec:
                    parts[key] = self.field(spec[key], key, f"{where} {key}", ("bodies", i, key))
            if "inertia" in spec:
                parts["inertia"] = self._inertia(spec["inertia"], where, ("bodies", i, "inertia"))
            if "rotation" in spec:
                parts["rotation"] = self._rotation(
                    spec["rotation"], where, ("bodies", i, "rotation")
                )
            if "rotation_frame" in spec:
                parts["rotation_frame"] = spec["rotation_frame"]
            if "orientation" in spec:
                parts["orientation"] = self._matrix(
                    spec["orientation"],
                    "angle",
                    f"{where} orientation",
                    ("bodies", i, "orientation"),
                )
            parts["position"] = self._vector(
                spec.get("position"), "position", f"{where} position", ("bodies", i, "position")
            )
            shape = spec.get("shape")
            if isinstance(shape, dict) and "axis" in shape:  # in space: the rod's or axle's
                parts["shape_axis"] = shape["axis"]
                shape = {k: v for k, v in shape.items() if k != "axis"}
            parts["shape"] = self._shape(shape, where, ("bodies", i, "shape"))
            if len(self.problems) == before:
                body = self.make(Body, name, part=where, **parts)
                if body is not None:
                    out.append(body)
        return out

    def _body_names(self) -> list[str]:
        """The names the file gives its bodies (parsed or not)."""
        raw = self.data.get("bodies")
        if not isinstance(raw, list):
            return []
        return [b["name"] for b in raw if isinstance(b, dict) and isinstance(b.get("name"), str)]

    def _angular_velocities(self, skeleton: System, bodies: list[Body]) -> None:
        """``top.wx, top.wy, top.wz`` (world axes) and ``top.w1, top.w2, top.w3`` (the
        body's own axes) into the velocities' names, for each body in space that turns
        (T from the bodies asks for the same, remembered); and what `disc.wx` says for
        a planar body, a point or a body whose description failed."""
        for name in self._body_names():
            self.spin_hints[name] = "this body's description has errors (see above)"
        for body in bodies:
            if body.rotation is not None or body.orientation is not None:
                self.spin_hints.pop(body.name, None)
                spin = angular_velocity(skeleton, body)
                if spin is None:
                    continue
                for k, axis in enumerate("xyz"):
                    self.scopes["velocities"][f"{body.name}.w{axis}"] = spin[0][k]
                    self.scopes["velocities"][f"{body.name}.w{k + 1}"] = spin[1][k]
            elif body.angle is not None:
                rate = to_text(time_derivative(body.angle, skeleton))
                self.spin_hints[body.name] = (
                    f"{body.name} is a planar body: its angular velocity is the rate of its "
                    f"angle, {rate} (counterclockwise); write that"
                )
            else:
                self.spin_hints[body.name] = (
                    f"{body.name} does not turn: a point mass has no angular velocity "
                    "(give a body in space a `rotation` or `orientation`)"
                )

    def _rotation(self, value, where: str, loc: tuple):
        """``["z:psi", "x:theta", "z:phi"]``: turns (axis, angle expression)."""
        if not isinstance(value, list) or not value:
            self.problem(
                f"{where} rotation",
                'give a list of turns "axis:angle", e.g. ["z:psi", "x:theta", "z:phi"]',
                loc,
            )
            return None
        turns = []
        for item in value:
            axis, sep, angle = str(item).partition(":") if isinstance(item, str) else ("", "", "")
            axis = axis.strip().lower()
            if not sep or axis not in ("x", "y", "z") or not angle.strip():
                self.problem(
                    f"{where} rotation",
                    f'each turn is "axis:angle" with axis x, y or z (e.g. "z:psi"); got {item!r}',
                    loc,
                )
                return None
            expr = self.field(angle.strip(), "angle", f"{where} rotation", loc)
            if expr is None:
                return None
            turns.append((axis, expr))
        return tuple(turns)

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

    def _inertia(self, value, where: str, loc: tuple):
        """One moment, the 3 principal moments, or 3 rows of 3 (the tensor)."""
        if isinstance(value, list) and value and all(isinstance(r, list) for r in value):
            return self._matrix(value, "inertia", f"{where} inertia", loc)
        if isinstance(value, list):
            if len(value) != 3:
                self.problem(
                    f"{where} inertia",
                    "give one moment, the 3 principal moments, or 3 rows of 3 (the tensor)",
                    loc,
                )
                return None
            parts = [self.field(x, "inertia", f"{where} inertia", loc) for x in value]
            return None if any(p is None for p in parts) else tuple(parts)
        return self.field(value, "inertia", f"{where} inertia", loc)

    def _sliders(self, params: list[Parameter], constraints: list) -> list:
        """``[sliders]``: ``NAME = [low, high]``, the range of the report's slider of a
        parameter given as a number, or of a friction coefficient given as a number
        (``mu``, or ``"mu:<constraint>"`` when there are several, as ``--param``)."""
        table = self.table("sliders") or {}
        friction = [c for c in constraints if c.friction is not None]
        names = {p.name for p in params if sp.sympify(p.value).is_Number}
        literal = [c for c in friction if sp.sympify(c.friction.mu).is_Number]
        if len(friction) == 1 and "mu" not in {p.name for p in params}:
            names |= {"mu"} if literal else set()
        else:
            names |= {f"mu:{c.name}" for c in literal}
        out = []
        for name, value in table.items():
            where, loc = f"sliders.{name}", ("sliders", None, name)
            if name not in names:
                self.problem(
                    where,
                    f"no slider `{name}`: a slider is a parameter given as a number or a "
                    "friction coefficient given as a number; known: "
                    + (", ".join(sorted(names)) or "none"),
                    loc,
                )
                continue
            ok = (
                isinstance(value, list)
                and len(value) == 2
                and all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                    for v in value
                )
            )
            if not ok:
                self.problem(where, "a slider's range is [low, high], two numbers", loc)
                continue
            low, high = float(value[0]), float(value[1])
            if not low < high:
                self.problem(
                    where, f"a slider's range needs low < high (got [{low:g}, {high:g}])", loc
                )
                continue
            out.append((name, low, high))
        return out

    def _scenery(self) -> list[Scenery]:
        """``[[scenery]]``: drawn geometry, each entry a point, a line or a circle."""
        raw = self.data.get("scenery", [])
        forms = (
            "point = [x, y], line = [[x1, y1], [x2, y2], ...] "
            'or circle = { center = [x, y], radius = "R" }'
        )
        if not isinstance(raw, list):
            self.problem(
                "scenery",
                "scenery is an array of tables: each starts with `[[scenery]]`",
                (None, None, "scenery"),
            )
            return []
        out = []
        for i, spec in enumerate(raw):
            loc0 = ("scenery", i, None)
            if not isinstance(spec, dict):
                self.problem(f"scenery[{i + 1}]", "must be a table", loc0)
                continue
            name = spec.get("name", f"scenery{i + 1}")
            where = f"scenery[{i + 1}] `{name}`"
            extra = sorted(set(spec) - {"name", "point", "line", "circle"})
            kinds = [k for k in ("point", "line", "circle") if k in spec]
            if extra:
                self.problem(
                    where, f"unknown key `{extra[0]}`; a scenery entry takes name and {forms}", loc0
                )
                continue
            if len(kinds) != 1:
                self.problem(where, f"give exactly one of {forms}", loc0)
                continue
            kind = kinds[0]
            value, loc, at = spec[kind], ("scenery", i, kind), f"{where} {kind}"
            before, radius = len(self.problems), None
            if kind == "circle":
                if not isinstance(value, dict) or set(value) != {"center", "radius"}:
                    self.problem(at, 'a circle is { center = [x, y], radius = "R" }', loc)
                    continue
                radius = self.field(value["radius"], "scenery", at, loc)
                points = [value["center"]]
            elif kind == "line":
                if not isinstance(value, list) or not all(isinstance(p, list) for p in value):
                    self.problem(at, "a line is a list of points: [[x1, y1], [x2, y2], ...]", loc)
                    continue
                points = value
            else:
                points = [value]
            if not all(isinstance(p, list) for p in points):
                self.problem(at, "a point is a list of 2 or 3 expressions: [x, y]", loc)
                continue
            parsed = [tuple(self.field(x, "scenery", at, loc) for x in p) for p in points]
            if len(self.problems) == before:
                item = self.make(Scenery, str(name), kind, tuple(parsed), radius, part=where)
                if item is not None:
                    out.append(item)
        return out

    def _shape(self, spec, where, loc) -> tuple | None:
        if spec is None:
            return (ShapeKind.POINT, None)
        if not isinstance(spec, dict) or len(spec) != 1:
            self.problem(
                where,
                'shape is one of { circle = "R" }, { rod = "l" }, { point = true } (in space '
                'with axis = "x", "y" or "z": the rod\'s body axis, the circle\'s axle)',
                loc,
            )
            return None
        ((kind, value),) = spec.items()
        if kind == ShapeKind.POINT or kind not in [k.value for k in ShapeKind]:
            return (kind, None)  # an unknown kind is the model's to report
        size = self.field(value, "shape", where + " shape", loc)
        return None if size is None else (kind, size)

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

    def _lagrangian(self, skeleton, bodies, gravity):
        table = self.table("lagrangian")
        loc = ("lagrangian", None, None)
        if table is not None:
            extra = set(table) - {"T", "V", "L"}
            if extra:
                self.problem(
                    "lagrangian", f"unknown key `{sorted(extra)[0]}`; give T and V, or L", loc
                )
            if "L" in table and ("T" in table or "V" in table):
                self.problem("lagrangian", "give either L, or T and V, not both", loc)
                return sp.Integer(0), sp.Integer(0)
            if "L" in table:
                L = self.field(table["L"], "L", "lagrangian.L", ("lagrangian", None, "L"))
                if L is None:
                    return sp.Integer(0), sp.Integer(0)
                # Split L into T (terms with velocities) and V (the rest, negated).
                qd = skeleton.qd
                poly = sp.expand(L)
                T = sum((a for a in sp.Add.make_args(poly) if a.has(*qd)), sp.Integer(0))
                return T, sp.expand(T - L)
            if "T" not in table:
                if not bodies and self.data.get("bodies"):
                    return sp.Integer(0), sp.Integer(0)  # the bodies' problems are said
                if not bodies:
                    self.problem(
                        "lagrangian",
                        "missing T (the kinetic energy); give T and V, "
                        "or L, or describe [[bodies]]",
                        loc,
                    )
                    return sp.Integer(0), sp.Integer(0)
                T = body_energy(skeleton, tuple(bodies), gravity)[0]
            else:
                T = self.field(table["T"], "T", "lagrangian.T", ("lagrangian", None, "T"))
            V = sp.Integer(0)
            if "V" in table:
                V = self.field(table["V"], "V", "lagrangian.V", ("lagrangian", None, "V"))
            elif gravity is not None and bodies:
                V = body_energy(skeleton, tuple(bodies), gravity)[1]
            if T is None or V is None:
                return sp.Integer(0), sp.Integer(0)
            return T, V
        if not bodies and self.data.get("bodies"):
            return sp.Integer(0), sp.Integer(0)  # bodies given, with problems said above
        if not bodies:
            self.problem(
                "lagrangian",
                "missing [lagrangian] (T and V, or L) and no [[bodies]] to compute them from",
                (None, None, None),
            )
            return sp.Integer(0), sp.Integer(0)
        return body_energy(skeleton, tuple(bodies), gravity)

    def _constraints(self) -> list[Constraint]:
        raw = self.data.get("constraints", [])
        if not isinstance(raw, list):
            self.problem(
                "constraints",
                "constraints are an array of tables: each starts with `[[constraints]]`",
                (None, None, "constraints"),
            )
            return []
        out = []
        for i, spec in enumerate(raw):
            loc0 = ("constraints", i, None)
            if not isinstance(spec, dict):
                self.problem(f"constraints[{i + 1}]", "must be a table", loc0)
                continue
            name = spec.get("name", f"c{i + 1}")
            where = f"constraints[{i + 1}] `{name}`"
            before = len(self.problems)
            extra = set(spec) - {
                "name",
                "f",
                "velocity",
                "unilateral",
                "friction",
                "force",
                "restitution",
            }
            if extra:
                self.problem(
                    where,
                    f"unknown key `{sorted(extra)[0]}`; a constraint takes "
                    "name, f or velocity, unilateral, friction, force, restitution",
                    loc0,
                )
            if ("f" in spec) == ("velocity" in spec):
                self.problem(
                    where,
                    "give exactly one of `f` (holonomic, f(q, t) = 0) or "
                    "`velocity` (linear in the velocities, a(q,t).q' + b = 0)",
                    loc0,
                )
                continue
            key = "f" if "f" in spec else "velocity"
            kind = ConstraintKind.HOLONOMIC if key == "f" else ConstraintKind.VELOCITY
            e = self.field(spec[key], key, f"{where} {key}", ("constraints", i, key))
            friction = self._friction(spec.get("friction"), where, ("constraints", i, "friction"))
            force = self._force_spec(spec.get("force"), where, ("constraints", i, "force"))
            restitution = self.field(
                spec.get("restitution", 0),
                "restitution",
                f"{where} restitution",
                ("constraints", i, "restitution"),
            )
            if len(self.problems) == before:
                constraint = self.make(
                    Constraint,
                    name,
                    e,
                    kind,
                    spec.get("unilateral", False),
                    friction,
                    force,
                    restitution,
                    part=where,
                )
                if constraint is not None:
                    out.append(constraint)
        return out

    def _friction(self, spec, where, loc) -> Friction | None:
        if spec is None:
            return None
        if not isinstance(spec, dict) or set(spec) != {"mu", "normal"}:
            self.problem(
                where,
                'friction is { mu = <coefficient>, normal = "<name of the normal constraint>" }',
                loc,
            )
            return None
        mu = self.field(spec["mu"], "mu", where + " friction.mu", loc)
        return None if mu is None else self.make(Friction, mu, spec["normal"], part=where)

    def _force_spec(self, spec, where, loc) -> ForceSpec | None:
        if spec is None:
            return None
        if (
            not isinstance(spec, dict)
            or not {"body", "at"} <= set(spec)
            or set(spec) - {"body", "at", "along"}
        ):
            self.problem(
                where,
                'force is { body = "<body>" (or ["a", "b"]), at = [x, y], '
                "along = { name = [dx, dy] } }",
                loc,
            )
            return None
        before = len(self.problems)
        names = spec["body"] if isinstance(spec["body"], list) else [spec["body"]]
        at = self._vector(spec["at"], "at", where + " force.at", loc)
        along = []
        raw_along = spec.get("along", {})
        if not isinstance(raw_along, dict):
            self.problem(
                where,
                "force.along is a table of named directions, e.g. "
                '{ normal = ["sin(x)", "cos(x)"] }',
                loc,
            )
            return None
        for dname, vec in raw_along.items():
            v = self._vector(vec, "along", where + f" force.along.{dname}", loc)
            along.append((dname, v))
        if len(self.problems) > before:
            return None
        return self.make(ForceSpec, tuple(names), at, tuple(along), part=where)

    def _forces(self, coords) -> list[sp.Expr]:
        table = self.table("forces") or {}
        by_name = {c.name: i for i, c in enumerate(coords)}
        out = [sp.Integer(0)] * len(coords)
        for name, value in table.items():
            if name not in by_name:
                self.problem(
                    f"forces.{name}",
                    f"`{name}` is not a coordinate; known: " + ", ".join(by_name),
                    ("forces", None, name),
                )
                continue
            e = self.field(value, "forces", f"forces.{name}", ("forces", None, name))
            if e is not None:
                out[by_name[name]] = e
        return out

    def _loads(self, skeleton: System, bodies: list[Body]) -> tuple[list, sp.Expr]:
        """``[[loads]]``: forces at material points, torques on bodies, springs and
        dampers between points, as generalized forces by virtual work (Q_q = F . dr_P/dq,
        tau . domega/dq'); a spring's energy k (d - L0)^2 / 2 joins V, its damper
        -c d' dd/dq joins Q."""
        n = len(skeleton.coordinates)
        Q = [sp.Integer(0)] * n
        V_extra = sp.Integer(0)
        raw = self.data.get("loads", [])
        if not isinstance(raw, list):
            self.problem(
                "loads",
                "loads are an array of tables: each starts with `[[loads]]`",
                (None, None, "loads"),
            )
            return Q, V_extra
        by_name = {b.name: b for b in bodies}
        kinds = ("force", "torque", "spring")
        for i, spec in enumerate(raw):
            loc0 = ("loads", i, None)
            if not isinstance(spec, dict):
                self.problem(f"loads[{i + 1}]", "must be a table", loc0)
                continue
            name = spec.get("name", f"load{i + 1}")
            where = f"loads[{i + 1}] `{name}`"
            given = [k for k in kinds if k in spec]
            extra = sorted(set(spec) - {"name", "body", "at", "frame", *kinds})
            if extra or len(given) != 1:
                self.problem(
                    where,
                    (f"unknown key `{extra[0]}`; " if extra else "")
                    + "a load is one of: force = [Fx, Fy(, Fz)] with body and at (a point of "
                    "the body; default its centre), torque with body, or spring = { from = "
                    '[...], to = [...], k = "k", length = "L0", damping = "c" }',
                    loc0,
                )
                continue
            frame = spec.get("frame", "world")
            if frame not in ("world", "body"):
                self.problem(where, 'frame is "world" (default) or "body"', ("loads", i, "frame"))
                continue
            if given[0] == "spring":
                got = self._spring(skeleton, spec["spring"], where, ("loads", i, "spring"))
                if got is not None:
                    V_extra += got[0]
                    Q = [a + b for a, b in zip(Q, got[1])]
                continue
            body = by_name.get(spec.get("body", ""))
            if body is None:
                self.problem(
                    where,
                    f"`body` must name one of the [[bodies]] ({', '.join(by_name) or 'none'})",
                    ("loads", i, "body"),
                )
                continue
            dim = len(body.position)
            R = body_rotation(body)
            if frame == "body" and R is None and body.angle is None:
                self.problem(where, "a point mass has no body frame", ("loads", i, "frame"))
                continue
            if given[0] == "force":
                F = self._vector(spec["force"], "forces", f"{where} force", ("loads", i, "force"))
                at = (
                    self._vector(spec["at"], "at", f"{where} at", ("loads", i, "at"))
                    if "at" in spec
                    else body.position
                )
                if F is None or at is None:
                    continue
                if len(F) != dim or len(at) != dim:
                    self.problem(
                        where,
                        f"force and at need {dim} components, as the body's position",
                        ("loads", i, "force"),
                    )
                    continue
                Fw = sp.Matrix(F)
                if frame == "body":
                    Fw = (R if R is not None else _planar_turn(body.angle)) * Fw
                J = partial_velocities(skeleton, body, tuple(at))
                Q = [Q[k] + (Fw.T * J[:, k])[0] for k in range(n)]
            else:
                loc = ("loads", i, "torque")
                value = spec["torque"]
                if dim == 2:
                    tau = self.field(value, "forces", f"{where} torque", loc)
                    if tau is None:
                        continue
                    if body.angle is None:
                        self.problem(where, "a torque needs a body that turns (an angle)", loc)
                        continue
                    Q = [
                        Q[k] + tau * sp.diff(body.angle, c.symbol)
                        for k, c in enumerate(skeleton.coordinates)
                    ]
                    continue
                vec = self._vector(value, "forces", f"{where} torque", loc)
                if vec is None:
                    continue
                spin = angular_velocity(skeleton, body)
                if spin is None or len(vec) != 3:
                    self.problem(
                        where,
                        "a torque in space needs 3 components and a body "
                        "with a rotation or orientation",
                        loc,
                    )
                    continue
                tw = sp.Matrix(vec)
                if frame == "body" and R is not None:
                    tw = R * tw
                Q = [
                    Q[k] + (tw.T * spin[0].diff(c.velocity))[0]
                    for k, c in enumerate(skeleton.coordinates)
                ]
        return Q, V_extra

    def _spring(self, skeleton: System, spec, where: str, loc: tuple):
        """(energy, generalized damping forces) of a spring (and damper) between two
        points given as expressions (each may move with the coordinates)."""
        if not isinstance(spec, dict) or not {"from", "to", "k"} <= set(spec):
            self.problem(
                where,
                'spring = { from = [...], to = [...], k = "k", length = "L0", '
                'damping = "c" } (length and damping optional)',
                loc,
            )
            return None
        a = self._vector(spec["from"], "at", f"{where} spring.from", loc)
        b = self._vector(spec["to"], "at", f"{where} spring.to", loc)
        k = self.field(spec["k"], "spring", f"{where} spring.k", loc)
        L0 = self.field(spec.get("length", 0), "spring", f"{where} spring.length", loc)
        c = self.field(spec.get("damping", 0), "spring", f"{where} spring.damping", loc)
        if a is None or b is None or k is None or L0 is None or c is None:
            return None
        if len(a) != len(b):
            self.problem(where, "from and to need the same number of components", loc)
            return None
        d = sp.Matrix(b) - sp.Matrix(a)
        length = sp.sqrt(sum(x**2 for x in d)) if L0 != 0 else None
        if length is None:  # a zero-length spring: k |d|^2 / 2, no square root
            energy = k * sum(x**2 for x in d) / 2
            rate = sum(x * time_derivative(x, skeleton) for x in d)  # |d| |d|'
            Q = [
                -c * rate * sum(x * sp.diff(x, q.symbol) for x in d) / sum(x**2 for x in d)
                if c != 0
                else sp.Integer(0)
                for q in skeleton.coordinates
            ]
            return energy, Q
        energy = k * (length - L0) ** 2 / 2
        rate = time_derivative(length, skeleton)
        Q = [
            -c * rate * sp.diff(length, q.symbol) if c != 0 else sp.Integer(0)
            for q in skeleton.coordinates
        ]
        return energy, Q

    # ----- notes ---------------------------------------------------------------------
    def _compare_energy(self, skeleton, bodies, gravity, T, V) -> list[str]:
        table = self.data.get("lagrangian")
        if not bodies or not isinstance(table, dict):
            return []
        Tb, Vb = body_energy(skeleton, tuple(bodies), gravity)
        notes = []
        checks = [("T", T, Tb)]
        if gravity is not None:
            checks.append(("V", V, Vb))
        for label, given, kin in checks:
            if "L" in table or (label not in table):
                continue
            if _numerically_equal(given, kin, skeleton):
                continue
            diff = sp.simplify(given - kin) if sp.count_ops(given - kin) < 200 else given - kin
            if label == "T":
                notes.append(
                    f"[lagrangian] T differs from the kinetic energy of [[bodies]] by "
                    f"{to_text(diff)}; check for a missing term (T is used as given)"
                )
            else:
                notes.append(
                    f"[lagrangian] V differs from the gravitational energy of "
                    f"[[bodies]] by {to_text(diff)} (fine if that is a spring or "
                    "other potential; V is used as given)"
                )
        return notes


def _planar_turn(angle: sp.Expr) -> sp.Matrix:
    """The plane rotation by ``angle`` (a planar body's frame)."""
    return sp.Matrix([[sp.cos(angle), -sp.sin(angle)], [sp.sin(angle), sp.cos(angle)]])


def _numerically_equal(a: sp.Expr, b: sp.Expr, system: System, tries: int = 3) -> bool:
    """Compare two expressions at a few seeded random states (parameters at their values)."""
    rng = random.Random(1234)
    symbols = sorted(a.free_symbols | b.free_symbols, key=str)
    pv = system.parameter_values
    for _ in range(tries):
        env = {s: sp.sympify(pv.get(s, rng.uniform(0.3, 1.3))) for s in symbols}
        try:
            # xreplace, not subs: a plain swap of symbols for numbers, ten times faster
            da, db = complex(a.xreplace(env).evalf()), complex(b.xreplace(env).evalf())
        except (TypeError, ValueError):
            return False
        if abs(da - db) > 1e-9 * (1 + abs(da) + abs(db)):
            return False
    return True
