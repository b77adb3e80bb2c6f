"""Presenting results: the only layer that formats or draws.

:func:`to_text`, :func:`to_latex` and :func:`to_json` take a
:class:`~lamech.symbolic.Solution` (the ``lamech solve`` report) or, for text and JSON, a
:class:`~lamech.numeric.Trajectory` (the ``lamech simulate`` summary); :func:`to_csv` the
tables: a Trajectory's samples, a :class:`~lamech.sweeps.SweepResult`'s rows, a
:class:`~lamech.sweeps.MapResult`'s points. Plots and animations use matplotlib (imported
when one is drawn; the backend is chosen by the caller: the CLI selects Agg, a notebook
keeps its own).

The result types (``Trajectory``, ``SweepResult``, ``MapResult``) hold data; their text,
JSON and CSV are made here, and only here.
"""

from __future__ import annotations

import os
import sys
from typing import TYPE_CHECKING, Any

from .._moved import moved
from ._modes import modes_latex, modes_text
from ._report import to_json as _solution_json
from ._report import to_latex as _solution_latex
from ._report import to_text as _solution_text
from ._steps import steps_json as _steps_json
from ._steps import steps_latex as _steps_latex
from ._steps import steps_text as _steps_text
from ._trajectory import trajectory_csv
from ._trajectory import trajectory_json as _trajectory_json
from ._trajectory import trajectory_text as _trajectory_text

if TYPE_CHECKING:
    from ._animate import animate
    from ._map_plot import plot_map
    from ._notebook import Animation, animation
    from ._page import report_page
    from ._plot import plot_trajectory
    from ._sweep_plot import plot_sweep

__all__ = [
    "to_text",
    "to_latex",
    "to_json",
    "to_csv",
    "trajectory_csv",
    "plot_trajectory",
    "plot_sweep",
    "plot_map",
    "animate",
    "animation",
    "Animation",
    "report_page",
    "modes_text",
    "modes_latex",
]

# Drawing, the report page and the sweep plots are imported on first use (PEP 562): a
# `lamech solve` that prints text never pays for them (about 0.3 s of CPU). The names this
# face exported before that are plumbing (the notebook views the result types' display
# hooks call, the report page's parts) are found in their private modules, and here with
# a DeprecationWarning.
_INTERNAL = "internal to lamech.present"
__getattr__ = moved(
    __name__,
    {
        "FORMATS": ("_animate", _INTERNAL),
        "Scene": ("_animate", _INTERNAL),
        "LiveError": ("_live", _INTERNAL),
        "LiveModel": ("_live", _INTERNAL),
        "live_model": ("_live", _INTERNAL),
        "to_javascript": ("_live", _INTERNAL),
        "solution_html": ("_notebook", _INTERNAL),
        "sweep_html": ("_notebook", _INTERNAL),
        "trajectory_html": ("_notebook", _INTERNAL),
        "CONVENTION": ("_report", _INTERNAL),
        "steps_text": ("_steps", "lamech.present.to_text gives a Derivation's steps"),
        "steps_latex": ("_steps", "lamech.present.to_latex gives a Derivation's steps"),
        "steps_json": ("_steps", "lamech.present.to_json gives a Derivation's steps"),
        "trajectory_text": ("_trajectory", "lamech.present.to_text gives a Trajectory's"),
    },
    lazy={
        "animate": "_animate",
        "Animation": "_notebook",
        "animation": "_notebook",
        "report_page": "_page",
        "plot_trajectory": "_plot",
        "plot_sweep": "_sweep_plot",
        "plot_map": "_map_plot",
    },
)
del moved


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


def _is_trajectory(obj: Any) -> bool:
    # A Trajectory exists only once lamech.numeric is imported: a report of a Solution
    # does not import the numeric layer (0.2-0.4 s of CPU) only to learn it is not one.
    numeric = sys.modules.get("lamech.numeric")
    return numeric is not None and isinstance(obj, numeric.Trajectory)


def _is_derivation(obj: Any) -> bool:
    from ..symbolic import Derivation

    return isinstance(obj, Derivation)


def _is_modes(obj: Any) -> bool:
    from ..symbolic import Modes

    return isinstance(obj, Modes)


def to_text(result: Any) -> str:
    """The readable report of a Solution, the steps of a Derivation
    (:func:`lamech.steps`), the summary of a Trajectory, or the equilibria and modes of
    :func:`lamech.modes` (as ``lamech modes`` prints them)."""
    if _is_derivation(result):
        return _steps_text(result)
    if _is_modes(result):
        from ._modes import modes_text

        return modes_text(result)
    return _trajectory_text(result) if _is_trajectory(result) else _solution_text(result)


def to_json(result: Any) -> dict:
    """The ``--json`` object of a Solution (schema in docs/reference/json.md) or a Trajectory."""
    if _is_derivation(result):
        return _steps_json(result)
    return _trajectory_json(result) if _is_trajectory(result) else _solution_json(result)


def to_csv(result: Any, path: str | os.PathLike | None = None) -> str | None:
    """The CSV of a table: a Trajectory's samples (the columns of ``lamech simulate
    --out``, 17 significant digits), a SweepResult's rows (``lamech sweep``'s table) or a
    MapResult's points (``lamech map``'s); numbers in a sweep's or a map's table as the
    shortest text that reads back the same float.

    Parameters
    ----------
    result : Trajectory, SweepResult or MapResult
        The table.
    path : str or path-like, optional
        A ``.csv`` file to write (whole or not at all, as every file lamech writes);
        None (the default) returns the text.

    Returns
    -------
    str or None
        The CSV text when ``path`` is None.

    Examples
    --------
    >>> import lamech
    >>> m = lamech.map("cylinder", {"mu": "0.2,0.4"})
    >>> header, first, second = lamech.to_csv(m).splitlines()
    >>> header.split(",")[:4]
    ['mu', 'slip:t', 'slip:r', 'slip:theta1']
    >>> first.split(",")[:4]  # a map has no times: nan
    ['0.2', 'nan', '1.5', '0.466922898163114']
    """
    if _is_trajectory(result):
        return trajectory_csv(result, path)
    from ..outputs import write_output
    from ..sweeps import MapResult, SweepResult
    from ._table import map_csv, table_csv

    if isinstance(result, SweepResult):
        text = table_csv(result.columns, result.rows)
    elif isinstance(result, MapResult):
        text = map_csv(result)
    else:
        raise TypeError(
            f"to_csv takes a Trajectory, a SweepResult or a MapResult, not {type(result).__name__}"
        )
    if path is None:
        return text
    write_output(path, text, (".csv",))
    return None


def to_latex(result: Any, standalone_math: bool = False) -> str:
    """A LaTeX fragment (amsmath ``align*``) of a Solution's main results, or of a
    Derivation's steps."""
    if _is_derivation(result):
        return _steps_latex(result, standalone_math=standalone_math)
    return _solution_latex(result, standalone_math=standalone_math)
