"""What a sweep gives: :class:`SweepResult`, its table of one row per case (rows sorted by
case), the grid, and how the rows were obtained."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ._parse import Measure

__all__ = ["SweepResult"]

_NOT_MEASURES = ("case", "status", "message")


@dataclass(repr=False)
class SweepResult:
    """The table of a sweep (:func:`lamech.sweep`): one row per case, sorted by case.

    The columns are ``case``, the swept parameters, each measure's columns (a lift-off's
    ``liftoff:t`` and ``liftoff:<coordinate>``, a ``max:<series>``, ...), ``status`` and
    ``message``. :meth:`column` gives one as a NumPy array, :meth:`to_dataframe` the
    whole table as a pandas DataFrame, :meth:`to_xarray` an xarray Dataset with one
    dimension per parameter, :func:`lamech.to_csv` the CSV of ``lamech sweep``'s table; in
    Jupyter it shows as a table and a plot.

    Attributes
    ----------
    parameters : dict of str to numpy.ndarray
        The grid: each swept name and its values (the last name varies fastest).
    measures : list of Measure
        The measures, parsed.
    columns : list of str
        The table's column names, in order.
    rows : list of dict
        One {column: value} per case, sorted by case.
    ran, kept, retried : int
        Cases simulated now (``ran_cases`` lists them in the order they finished), rows
        read back from the table (``resume=True``), and rows of that table run again
        because their status was not ``ok``.
    seconds, compile_seconds : float
        The run's wall time, and the part of it spent compiling the system.
    backend : str
        Where the cases ran ("this process", "2 local processes", "Dask at ...", "the
        compiled loop with events (...)").
    path : pathlib.Path or None
        The table on disk (``out=``), if any.
    units : dict of str to str
        Where the problem gives units (issue 46): the SI unit of each column whose
        dimension is known (``"R2": "m"``, ``"liftoff:t": "s"``, ``"liftoff:theta1":
        "rad"``, ``"max:lambda:contact": "N"``); every value is in these units. Empty
        for a problem without units.
    interrupted, stopped
        For a sweep that did not finish (only the command line sees one: :func:`lamech.sweep`
        raises instead): ``interrupted`` is True after Ctrl-C (or the command's SIGTERM
        and SIGHUP), ``stopped`` says why a run ended otherwise (a worker process died,
        the cluster failed). The table on disk then holds the finished rows and
        ``resume=True`` completes it.

    Examples
    --------
    >>> import lamech
    >>> res = lamech.sweep("cylinder", {"mu": [0.2, 0.4]}, "slip", t_end=2.7,
    ...                    initial={"theta1": 0.01}, samples=11)
    >>> res
    <SweepResult: 2 cases (mu: 2); ok 2; columns case, mu, slip:t, slip:r, ...>
    >>> res.column("slip:theta1").round(4)
    array([0.4669, 0.6596])
    """

    parameters: dict[str, np.ndarray]
    measures: list[Measure]
    columns: list[str]
    rows: list[dict]
    ran: int = 0
    kept: int = 0
    seconds: float = 0.0
    compile_seconds: float = 0.0
    backend: str = ""
    interrupted: bool = False
    stopped: str = ""
    path: Path | None = None
    ran_cases: list[int] = field(default_factory=list)
    retried: int = 0
    units: dict[str, str] = field(default_factory=dict)

    @property
    def cases(self) -> int:
        """The number of cases in the grid (``len(result)`` is the number of rows)."""
        return math.prod(len(a) for a in self.parameters.values())

    @property
    def complete(self) -> bool:
        """True when every case of the grid has its row."""
        return len(self.rows) == self.cases

    @property
    def measure_columns(self) -> list[str]:
        """The columns of the measures (not ``case``, the parameters, ``status``, ``message``)."""
        return [c for c in self.columns if c not in self.parameters and c not in _NOT_MEASURES]

    @property
    def counts(self) -> dict[str, int]:
        """How many rows have each status ({"ok": 48, "error": 2}, say)."""
        out: dict[str, int] = {}
        for r in self.rows:
            out[r["status"]] = out.get(r["status"], 0) + 1
        return out

    def column(self, name: str) -> np.ndarray:
        """One column over the rows: floats for the parameters and measures (NaN where a
        measure has no value), integers for ``case``, strings for ``status`` and
        ``message``."""
        if name not in self.columns:
            raise KeyError(f"no column {name!r}; the columns: {', '.join(self.columns)}")
        values = [r[name] for r in self.rows]
        if name == "case":
            return np.array(values, dtype=int)
        if name in ("status", "message"):
            return np.array(values, dtype=str)
        return np.array(values, dtype=float)

    def records(self) -> list[dict]:
        """The rows as a list of new dicts (a copy)."""
        return [dict(r) for r in self.rows]

    def __len__(self) -> int:
        return len(self.rows)

    def __repr__(self) -> str:
        sizes = ", ".join(f"{n}: {len(a)}" for n, a in self.parameters.items())
        counts = ", ".join(f"{k} {v}" for k, v in sorted(self.counts.items())) or "no rows"
        cases = f"{self.cases} cases ({sizes})"
        if not self.complete:
            why = "interrupted" if self.interrupted else f"stopped: {self.stopped}"
            cases = f"{len(self.rows)} of {cases}, {why}"
        return f"<SweepResult: {cases}; {counts}; columns {', '.join(self.columns)}>"

    def __getattr__(self, name: str) -> Any:
        # lamech 0.2's sweep returned a pandas DataFrame: name the way to one rather than
        # a bare AttributeError on `result.round` or `result.loc`.
        if name.startswith("_"):
            raise AttributeError(name)
        raise AttributeError(
            f"'SweepResult' object has no attribute {name!r}; lamech.sweep returns a "
            "SweepResult (lamech 0.2 returned a pandas DataFrame): result.to_dataframe() gives one"
        )

    def __getitem__(self, key: Any) -> Any:
        raise TypeError(
            "a SweepResult is not indexed; result.column(name) gives a column as an array, "
            "result.to_dataframe() the table as a pandas DataFrame (what lamech.sweep "
            "returned in lamech 0.2)"
        )

    def _repr_html_(self) -> str:
        # Jupyter's display protocol: the one import against the layer order (sweeps ->
        # present), declared in the import-linter contract.
        from ..present._notebook import sweep_html

        return sweep_html(self)

    def to_dataframe(self):
        """The table as a pandas DataFrame (needs pandas)."""
        try:
            import pandas as pd
        except ImportError:
            raise ImportError("to_dataframe needs pandas: pip install pandas") from None
        return pd.DataFrame(self.rows, columns=self.columns)

    def to_xarray(self):
        """An xarray Dataset with one dimension per swept parameter (needs pandas and
        xarray)."""
        try:
            import xarray  # noqa: F401
        except ImportError:
            raise ImportError("to_xarray needs xarray: pip install xarray") from None
        df = self.to_dataframe().drop(columns=["case"])
        return df.set_index(list(self.parameters)).to_xarray()
