"""A problem file as text: reading it (size, encoding, what a file may be), the
:class:`Issue` s found in it with their lines (:class:`Lines` finds a key's line, which
tomllib does not keep), and the CSV tables an ``[inputs]`` section names."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

from .._errors import LamechError
from ..expr import printable

__all__ = ["Issue", "ProblemFileError", "MAX_BYTES", "LIMITS", "MAX_TABLE_ROWS"]


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
            text = self.text
            if len(text) > SHOWN_TEXT:  # a 28 kB line is not read again in full
                text = text[: SHOWN_TEXT - 3] + "..."
            out += f"\n    {printable(text)}"
        return out


SHOWN_TEXT = 200
"""The most characters of the offending line an error shows (the line is in the file)."""


_KEY_LINE = re.compile(r"""^\s*("[^"]*"|'[^']*'|[A-Za-z0-9_.\-]+)\s*=""")
_TABLE_LINE = re.compile(r"^\s*\[\[?\s*([^\]]+?)\s*\]\]?")


def repeated_key(text: str) -> tuple[int, str, int] | None:
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


class ProblemFileError(LamechError, ValueError):
    """A problem file (or dict) cannot be used; ``problems`` lists everything wrong."""

    def __init__(self, source: str, problems: list[Issue]):
        self.source = source
        self.problems = list(problems)
        super().__init__("\n".join(p.format(source) for p in problems))


class Lines:
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
    "drives": 200,
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


def read_table(
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
