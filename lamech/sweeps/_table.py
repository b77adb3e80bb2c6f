"""The sweep's table on disk: rows appended (flushed) as cases finish, read back on resume,
rewritten sorted (atomically) at the end.

Beside the table ``<table>.sweep.json`` records the sweep that made it (the problem's
SHA-256, the grid, the measures, t_end, the initial values, samples, tolerances, method):
a resume whose options differ is refused, naming the option, so that two sweeps never
share one table. While a sweep writes, it holds a lock on ``<table>.lock`` (released when
it ends, however it ends): a second sweep on the same table is refused. A resume reads
the table strictly: a damaged line (a field that is not a number, a row with too few
fields, a case twice) is refused with its line number; only a last line cut short by an
interruption is dropped. Rows whose status is not ``ok`` are run again.

How the rows are written (a number's text, a status, a message; a Parquet table's frame)
is the present layer's, :mod:`lamech.present._table`, which :func:`lamech.to_csv` uses
too: the table is written here, as the cases finish, and formatted there, through the
one import of this module against the layer order (declared in the import-linter
contract). This module keeps what makes the table a journal: the lock, the record beside
it, reading it back."""

from __future__ import annotations

import csv
import io
import json
import math
import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any, TextIO

from ..outputs import write_output
from ._parse import SweepError

__all__ = ["Table", "STATUSES"]

STATUSES = ("ok", "failed", "error")
"""The statuses a row on disk may have (an interrupted case is never written)."""

OPTIONS = {
    "problem_sha256": "the problem",
    "parameters": "`params=`",
    "measures": "`measures=`",
    "t_end": "`t_end=`",
    "initial": "`initial=`",
    "samples": "`samples=`",
    "rtol": "`rtol=`",
    "atol": "`atol=`",
    "max_step": "`max_step=`",
    "method": "`method=`",
}
"""What a resume must match, and the argument of :func:`lamech.sweep` that sets it (the
command line names its flag: :mod:`lamech.cli._terms`)."""


class Table:
    """The output table: rows appended (flushed) as cases finish; read back on resume."""

    def __init__(self, path: Path | None, columns: Sequence[str], spec: dict | None = None):
        self.path = path
        self.columns = list(columns)
        self.spec = dict(spec or {}, columns=self.columns)
        self.record = None if path is None else path.with_name(path.name + ".sweep.json")
        self._lock: Any = None
        self.parquet = path is not None and path.suffix.lower() == ".parquet"
        # The file rows are appended to: the CSV itself, or a CSV beside a Parquet table.
        self.journal: Path | None = path
        if path is not None and self.parquet:
            self.journal = path.with_name(path.name + ".partial.csv")
        self._fh: TextIO | None = None

    # ----- one writer per table ------------------------------------------------
    def lock(self) -> None:
        """Hold ``<table>.lock`` until :meth:`unlock`; SweepError when another sweep
        holds it (POSIX; elsewhere tables are not locked)."""
        if self.path is None:
            return
        try:
            import fcntl
        except ImportError:  # pragma: no cover - Windows
            return
        where = self.path.with_name(self.path.name + ".lock")
        where.parent.mkdir(parents=True, exist_ok=True)
        fh = open(where, "a+", encoding="utf-8")
        try:
            fcntl.flock(fh.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            fh.seek(0)
            holder = fh.read().strip() or "another process"
            fh.close()
            raise SweepError(
                f"{self.path} is being written by another lamech sweep ({holder}); two "
                "sweeps on one table would mix their rows: wait for it, or choose another "
                "`out=`"
            ) from None
        fh.seek(0)
        fh.truncate()
        fh.write(f"pid {os.getpid()}\n")
        fh.flush()
        self._lock = (fh, where)

    def unlock(self) -> None:
        if self._lock is not None:
            fh, where = self._lock
            where.unlink(missing_ok=True)
            fh.close()  # closing releases the lock
            self._lock = None

    # ----- resume ---------------------------------------------------------------------
    def read(self, cases: Sequence[dict], names: list[str]) -> dict[int, dict]:
        """Rows already in the table (resume), every status, checked: made by a sweep
        with these options (the record beside it), undamaged, on this sweep's grid."""
        if self.path is None:
            raise SweepError("`resume=True` needs an output table (`out=`)")
        journal = self.journal
        assert journal is not None  # set from path, which is not None
        if journal.exists():
            source = journal
        elif self.parquet and self.path.exists():
            source = self.path
        else:
            return {}  # nothing yet: the whole sweep runs
        self._check_record(source)
        if source == journal:
            rows = self._read_csv(journal)
        else:
            rows = self._read_parquet(source)
        done: dict[int, dict] = {}
        first_line: dict[int, int] = {}
        for line, record in rows:
            row = self._row(source, line, record, len(cases))
            case = row["case"]
            if case in done:
                raise SweepError(
                    f"cannot resume from {source}: line {line}: case {case} again (first on "
                    f"line {first_line[case]}); the table is damaged" + _MEND
                )
            if any(row[n] != cases[case][n] for n in names):
                raise SweepError(
                    f"cannot resume from {source}: line {line}: case {case} has "
                    + ", ".join(f"{n} = {row[n]!r}" for n in names)
                    + ", not a point of this sweep's grid (a different sweep?)"
                )
            done[case], first_line[case] = row, line
        return done

    def _check_record(self, source: Path) -> None:
        """SweepError unless the record beside the table says it was made with this
        sweep's options (naming the first that differs)."""
        assert self.record is not None
        again = "; run without `resume=True` to start a new table"
        try:
            with open(self.record, encoding="utf-8") as fh:
                made = json.load(fh)
            if not isinstance(made, dict):
                raise ValueError("not a JSON object")
        except FileNotFoundError:
            raise SweepError(
                f"cannot resume from {source}: there is no record of the sweep that made it "
                f"({self.record.name} is missing), so nothing says its rows were computed "
                f"with these options{again}"
            ) from None
        except (OSError, ValueError) as exc:
            raise SweepError(
                f"cannot resume from {source}: its record {self.record.name} cannot be "
                f"read ({exc}){again}"
            ) from None
        for key, option in OPTIONS.items():
            then, now = made.get(key), self.spec.get(key)
            if then == now:
                continue
            if key == "problem_sha256":
                raise SweepError(
                    f"cannot resume from {source}: the problem has changed since the table "
                    f"was made (SHA-256 {str(then)[:12]}... then, {str(now)[:12]}... now){again}"
                )
            if key == "parameters" and isinstance(then, dict) and isinstance(now, dict):
                for name in list(now) + [n for n in then if n not in now]:
                    if then.get(name) != now.get(name):
                        option = f"`params=` `{name}`"
                        then, now = then.get(name), now.get(name)
                        break
                else:
                    option, then, now = "`params=` (the order of the names)", list(then), list(now)
            raise SweepError(
                f"cannot resume from {source}: {option} differs: the table was made with "
                f"{_shown(then)}, this sweep has {_shown(now)}; give the same options (the "
                f"table's are in {self.record.name}), or run without `resume=True` to start a "
                "new table"
            )

    def _read_csv(self, journal: Path) -> list[tuple[int, dict]]:
        """(line, {column: text}) of every complete row; SweepError at a damaged line."""
        with open(journal, newline="", encoding="utf-8", errors="replace") as fh:
            text = fh.read()
        complete = text if text.endswith("\n") else text[: text.rfind("\n") + 1]
        reader = csv.reader(io.StringIO(complete, newline=""))
        header = next(reader, None)
        if header is None:
            return []
        if header != self.columns:
            raise SweepError(
                f"cannot resume from {journal}: its columns "
                f"({', '.join(header)}) are not this sweep's "
                f"({', '.join(self.columns)})"
            )
        rows = []
        try:
            for rec in reader:
                if len(rec) != len(self.columns):
                    raise SweepError(
                        f"cannot resume from {journal}: line {reader.line_num}: {len(rec)} "
                        f"fields where the table has {len(self.columns)} columns; the table "
                        "is damaged" + _MEND
                    )
                rows.append((reader.line_num, dict(zip(self.columns, rec))))
        except csv.Error as exc:
            raise SweepError(
                f"cannot resume from {journal}: line {reader.line_num}: {exc}; the table "
                "is damaged" + _MEND
            ) from None
        return rows

    def _read_parquet(self, path: Path) -> list[tuple[int, dict]]:
        import pandas as pd

        try:
            df = pd.read_parquet(path)
        except Exception as exc:  # pyarrow's errors for a damaged file are many
            raise SweepError(f"cannot resume from {path}: it cannot be read ({exc})") from None
        if list(df.columns) != self.columns:
            raise SweepError(
                f"cannot resume from {path}: its columns "
                f"({', '.join(df.columns)}) are not this sweep's "
                f"({', '.join(self.columns)})"
            )
        return [(k + 1, rec) for k, rec in enumerate(df.to_dict("records"))]

    def _row(self, source: Path, line: int, record: dict, ncases: int) -> dict:
        """One row read back, its numbers as numbers; SweepError naming the line and the
        column of a field that is not one."""
        row: dict = {}
        for k, x in record.items():
            if k in ("status", "message"):
                row[k] = "" if x is None else str(x)
                continue
            try:
                row[k] = float(x)
            except (TypeError, ValueError):
                raise SweepError(
                    f"cannot resume from {source}: line {line}, column `{k}`: {str(x)!r} is "
                    "not a number; the table is damaged" + _MEND
                ) from None
        case = row["case"]
        if not (math.isfinite(case) and case == int(case) and 0 <= case < ncases):
            raise SweepError(
                f"cannot resume from {source}: line {line}: case {record['case']!r} is not a "
                f"case of this sweep (0 to {ncases - 1}); the table is damaged" + _MEND
            )
        row["case"] = int(case)
        if row["status"] not in STATUSES:
            raise SweepError(
                f"cannot resume from {source}: line {line}: status {row['status']!r} is not "
                f"one of {', '.join(STATUSES)}; the table is damaged" + _MEND
            )
        return row

    # ----- writing ----------------------------------------------------------------------
    def open(self, kept: Iterable[dict]) -> None:
        """Write the record of this sweep, then start the table with the ``kept`` rows."""
        if self.journal is None:
            return
        self.journal.parent.mkdir(parents=True, exist_ok=True)
        assert self.record is not None
        write_output(self.record, json.dumps(self.spec, indent=1) + "\n", (".json",), "`out=`")
        # the rows' text is the present layer's (the module docstring)
        from ..present._table import table_csv

        self._fh = open(self.journal, "w", newline="", encoding="utf-8")
        self._fh.write(table_csv(self.columns, kept))
        self._fh.flush()

    def append(self, row: dict) -> None:
        if self._fh is not None:
            from ..present._table import csv_line

            self._fh.write(csv_line([row[c] for c in self.columns]))
            self._fh.flush()

    def close(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None

    def finish(self, rows: list[dict]) -> None:
        """Rewrite the table sorted by case (atomically); Parquet from the journal."""
        self.close()
        if self.path is None:
            return
        from ..present._table import table_csv, write_parquet

        if self.parquet:
            write_parquet(self.path, self.columns, rows, "`out=`")
            assert self.journal is not None  # set from path, which is not None
            self.journal.unlink(missing_ok=True)
            return
        write_output(self.path, table_csv(self.columns, rows), (".csv",), "`out=`")


_MEND = ": mend or delete that line, or run without `resume=True` to start a new table"


def _number(x: float) -> str:
    """2.7, 3, 1e-11: as short as exact (in a message)."""
    if isinstance(x, int):
        return str(int(x))
    text = "nan" if math.isnan(x) else repr(float(x))
    return text[:-2] if text.endswith(".0") else text


def _shown(value) -> str:
    """An option's value as a user gave it: lists as a,b,c (shortened), None as unset."""
    if value is None:
        return "none (the default)"
    if isinstance(value, list):
        items = [_number(x) if isinstance(x, (int, float)) else str(x) for x in value]
        if len(items) > 6:
            return ",".join(items[:3]) + ",...," + items[-1] + f" ({len(items)} values)"
        return ",".join(items) if items else "none"
    if isinstance(value, dict):
        return ", ".join(f"{k}={_number(v)}" for k, v in value.items()) or "none"
    return _number(value) if isinstance(value, (int, float)) else str(value)
