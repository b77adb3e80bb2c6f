"""Tables as CSV, and as Parquet: a sweep's (:class:`~lamech.SweepResult`, and its table
on disk, which :mod:`lamech.sweeps._table` writes row by row with :func:`csv_line` as the
cases finish) and a map's (:class:`~lamech.MapResult`).

A number is written as the shortest text that reads back the same float (``repr``),
``nan`` where there is none; integers (``case``) as integers; text (``status``,
``message``, a map's ``first``) as it is, quoted by the CSV rules where it holds a comma,
a quote or a line break. A trajectory's CSV, 17 significant digits, is
:func:`lamech.present._trajectory.trajectory_csv`.
"""

from __future__ import annotations

import csv
import io
import math
import os
from collections.abc import Iterable, Mapping, Sequence

import numpy as np

from ..outputs import write_output

__all__ = ["cell", "csv_line", "table_csv", "map_csv", "write_parquet"]


def cell(x) -> str:
    """One value as a table's cell: text as it is, an integer as one, a float as the
    shortest text that reads back the same (``nan`` for NaN)."""
    if isinstance(x, str):
        return x
    if isinstance(x, (int, np.integer)):
        return str(int(x))
    x = float(x)
    return "nan" if math.isnan(x) else repr(x)


def _csv(rows: Iterable[Sequence]) -> str:
    out = io.StringIO(newline="")
    w = csv.writer(out, lineterminator="\n")
    for row in rows:
        w.writerow([cell(x) for x in row])
    return out.getvalue()


def csv_line(values: Sequence) -> str:
    """One row of a table as CSV text, ending in a newline."""
    return _csv([values])


def table_csv(columns: Sequence[str], rows: Iterable[Mapping]) -> str:
    """The CSV of a table: the header ``columns``, then each row's values in that order
    (a sweep's table: :attr:`lamech.SweepResult.rows`)."""
    return _csv([list(columns), *([row[c] for c in columns] for row in rows)])


def map_csv(result) -> str:
    """The CSV of a :class:`~lamech.MapResult`: its columns in order, one row per point of
    the grid; numbers written as a sweep's table writes them."""
    names = list(result.columns)
    values = [
        list(result.columns[n])
        if n == "first"
        else np.asarray(result.columns[n], dtype=float).tolist()
        for n in names
    ]
    return _csv([names, *zip(*values)])


def write_parquet(
    path: str | os.PathLike, columns: Sequence[str], rows: Iterable[Mapping], flag: str
) -> None:
    """Write a table as Parquet to ``path`` (whole or not at all; needs pandas and
    pyarrow); ``flag`` names the path in a message."""
    import pandas as pd

    frame = pd.DataFrame(list(rows), columns=list(columns))
    write_output(path, lambda tmp: frame.to_parquet(tmp, index=False), (".parquet",), flag)
