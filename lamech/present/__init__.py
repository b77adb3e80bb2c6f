"""Presenting results: the only layer that formats or draws.

:func:`to_text`, :func:`to_latex` and :func:`to_json` take a
:class:`~lamech.symbolic.Solution` (the ``lamech solve`` report) or, for text and JSON, a
:class:`~lamech.numeric.Trajectory` (the ``lamech simulate`` summary). Plots and
animations use matplotlib (imported when one is drawn; the backend is chosen by the
caller: the CLI selects Agg, a notebook keeps its own).
"""

from __future__ import annotations

import importlib
import sys
from typing import TYPE_CHECKING, Any

from ._modes import modes_latex, modes_text
from ._report import CONVENTION
from ._report import to_json as _solution_json
from ._report import to_latex as _solution_latex
from ._report import to_text as _solution_text
from ._steps import steps_json, steps_latex, steps_text
from ._trajectory import trajectory_csv, trajectory_text

if TYPE_CHECKING:
    from ._animate import FORMATS, Scene, animate
    from ._live import LiveError, LiveModel, live_model, to_javascript
    from ._notebook import Animation, animation, solution_html, sweep_html, trajectory_html
    from ._page import report_page
    from ._plot import plot_trajectory
    from ._sweep_plot import plot_sweep

# Drawing, the report page and the sweep plots are imported on first use (PEP 562): a
# `lamech solve` that prints text never pays for them (about 0.3 s of CPU).
_LAZY = {
    "FORMATS": "_animate",
    "Scene": "_animate",
    "animate": "_animate",
    "Animation": "_notebook",
    "animation": "_notebook",
    "sweep_html": "_notebook",
    "trajectory_html": "_notebook",
    "solution_html": "_notebook",
    "LiveError": "_live",
    "LiveModel": "_live",
    "live_model": "_live",
    "to_javascript": "_live",
    "report_page": "_page",
    "plot_trajectory": "_plot",
    "plot_sweep": "_sweep_plot",
}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f".{module}", __name__), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


__all__ = [
    "to_text",
    "to_latex",
    "to_json",
    "trajectory_csv",
    "plot_trajectory",
    "plot_sweep",
    "animate",
    "modes_text",
    "modes_latex",
    "steps_text",
    "steps_latex",
    "steps_json",
    "report_page",
    "live_model",
    "LiveModel",
    "LiveError",
    "to_javascript",
    "animation",
    "Animation",
    "trajectory_html",
    "sweep_html",
    "solution_html",
    "Scene",
    "FORMATS",
    "CONVENTION",
]


def _is_trajectory(obj: Any) -> bool:
    # A Trajectory exists only once lamech.numeric is imported: a report of a Solution
    # does not import the numeric layer (0.2-0.4 s of CPU) only to learn it is not one.
    numeric = sys.modules.get("lamech.numeric")
    return numeric is not None and isinstance(obj, numeric.Trajectory)


def _is_derivation(obj: Any) -> bool:
    from ..symbolic import Derivation

    return isinstance(obj, Derivation)


def to_text(result: Any) -> str:
    """The readable report of a Solution, the steps of a Derivation
    (:func:`lamech.steps`), or the summary of a Trajectory."""
    if _is_derivation(result):
        return steps_text(result)
    return trajectory_text(result) if _is_trajectory(result) else _solution_text(result)


def to_json(result: Any) -> dict:
    """The ``--json`` object of a Solution (schema in docs/reference/json.md) or a Trajectory."""
    if _is_derivation(result):
        return steps_json(result)
    return result.summary() if _is_trajectory(result) else _solution_json(result)


def to_latex(result: Any, standalone_math: bool = False) -> str:
    """A LaTeX fragment (amsmath ``align*``) of a Solution's main results, or of a
    Derivation's steps."""
    if _is_derivation(result):
        return steps_latex(result, standalone_math=standalone_math)
    return _solution_latex(result, standalone_math=standalone_math)
