"""The sweep's table on disk: rows appended (flushed) as cases finish, read back on resume,
rewritten sorted (atomically) at the end."""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TextIO

import numpy as np

from ._parse import SweepError

__all__ = ["Table", "format_value"]


def format_value(x) -> str:
    if isinstance(x, str):
        return x
    if isinstance(x, (int, np.integer)):
        return str(int(x))
    x = float(x)
    return "nan" if math.isnan(x) else repr(x)


class Table:
    """The output table: rows appended (flushed) as cases finish; read back on resume."""

    def __init__(self, path: Path | None, columns: Sequence[str]):
        self.path = path
        self.columns = list(columns)
        self.parquet = path is not None and path.suffix.lower() == ".parquet"
        # The file rows are appended to: the CSV itself, or a CSV beside a Parquet table.
        self.journal: Path | None = path
        if path is not None and self.parquet:
            self.journal = path.with_name(path.name + ".partial.csv")
        self._fh: TextIO | None = None

    def read(self, cases: list[dict], names: list[str]) -> dict[int, dict]:
        """Rows already in the table (resume), checked against this sweep's grid."""
        if self.path is None:
            raise SweepError("resume needs an output table (out=... / --out)")
        journal = self.journal
        assert journal is not None  # set from path, which is not None
        rows: list[dict] = []
        source = None
        if journal.exists():
            source = journal
            with open(journal, newline="", encoding="utf-8") as fh:
                text = fh.read()
            complete = text if text.endswith("\n") else text[: text.rfind("\n") + 1]
            reader = csv.reader(complete.splitlines())
            header = next(reader, None)
            if header is None:
                return {}
            if header != self.columns:
                raise SweepError(
                    f"cannot resume from {source}: its columns "
                    f"({', '.join(header)}) are not this sweep's "
                    f"({', '.join(self.columns)})"
                )
            for rec in reader:
                if len(rec) == len(self.columns):
                    rows.append(dict(zip(self.columns, rec)))
        elif self.parquet and self.path.exists():
            source = self.path
            import pandas as pd

            df = pd.read_parquet(self.path)
            if list(df.columns) != self.columns:
                raise SweepError(
                    f"cannot resume from {source}: its columns "
                    f"({', '.join(df.columns)}) are not this sweep's "
                    f"({', '.join(self.columns)})"
                )
            rows = df.to_dict("records")
        done: dict[int, dict] = {}
        for record in rows:
            row = {}
            for k, x in record.items():
                row[k] = x if k in ("status", "message") else float(x)
            row["message"] = "" if row["message"] is None else str(row["message"])
            case = int(row["case"])
            if not 0 <= case < len(cases) or any(row[n] != cases[case][n] for n in names):
                raise SweepError(
                    f"cannot resume from {source}: case {case} has "
                    + ", ".join(f"{n} = {row[n]!r}" for n in names)
                    + ", not a point of this sweep's grid (a different sweep?)"
                )
            row["case"] = case
            done[case] = row
        return done

    def open(self, kept: Iterable[dict]) -> None:
        if self.journal is None:
            return
        self.journal.parent.mkdir(parents=True, exist_ok=True)
        self._fh = open(self.journal, "w", newline="", encoding="utf-8")
        self._writer = csv.writer(self._fh, lineterminator="\n")
        self._writer.writerow(self.columns)
        for row in kept:
            self._writer.writerow([format_value(row[c]) for c in self.columns])
        self._fh.flush()

    def append(self, row: dict) -> None:
        if self._fh is not None:
            self._writer.writerow([format_value(row[c]) for c in self.columns])
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
        if self.parquet:
            import pandas as pd

            pd.DataFrame(rows, columns=self.columns).to_parquet(self.path, index=False)
            assert self.journal is not None  # set from path, which is not None
            self.journal.unlink(missing_ok=True)
            return
        tmp = self.path.with_name(self.path.name + ".tmp")
        with open(tmp, "w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh, lineterminator="\n")
            w.writerow(self.columns)
            for row in rows:
                w.writerow([format_value(row[c]) for c in self.columns])
        os.replace(tmp, self.path)
