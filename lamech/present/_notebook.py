"""Jupyter's faces of results: a :class:`~lamech.numeric.Trajectory` shows its summary
and its force plot inline, a :class:`~lamech.SweepResult` a table and a plot, and
:func:`animation` an inline player (a :class:`~lamech.symbolic.Solution` already renders
as LaTeX with dotted velocities). Images are embedded as data URIs, so a saved notebook
keeps them."""

from __future__ import annotations

import base64
import html
import tempfile
from pathlib import Path

__all__ = ["trajectory_html", "sweep_html", "solution_html", "animation", "Animation"]

TABLE_ROWS = 30
"""Rows of a sweep shown inline (the rest: ``run.to_dataframe()``)."""


def _png(draw) -> str:
    """``draw(path)`` writes a PNG; the <img> that embeds it."""
    with tempfile.TemporaryDirectory(prefix="lamech-nb-") as tmp:
        path = Path(tmp) / "figure.png"
        draw(path)
        data = base64.b64encode(path.read_bytes()).decode()
    return f'<img style="max-width:100%" src="data:image/png;base64,{data}">'


def trajectory_html(traj) -> str:
    """The run's summary and its plot (multipliers and forces with the events, and the
    coordinates), as HTML."""
    from ._plot import plot_trajectory
    from ._trajectory import trajectory_text

    return f"<pre>{html.escape(trajectory_text(traj))}</pre>" + _png(
        lambda p: plot_trajectory(traj, p)
    )


def solution_html(sol) -> str:
    """A Solution in a notebook: its main results in LaTeX (typeset by the notebook's
    MathJax), then the report page's sliders (:mod:`lamech.present._live`: the closed
    forms compiled to JavaScript, re-evaluated as a parameter moves), inside an element
    of its own so that several outputs can share the notebook."""
    import uuid

    from ._live import LIVE_STYLE, live_section
    from ._page import equilibria
    from ._report import to_latex

    root = f"lamech-live-{uuid.uuid4().hex[:12]}"
    body, script = live_section(sol, equilibria(sol), root_id=root)
    math = html.escape(to_latex(sol, standalone_math=True))
    out = (
        f"<div>{math}</div><style>{LIVE_STYLE}</style>"
        f'<div id="{root}"><h4>Move the parameters</h4>{body}</div>'
    )
    return out + (f"<script>{script}</script>" if script else "")


def _cell(v) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    return html.escape(str(v))


def sweep_html(run) -> str:
    """The sweep's counts, its first :data:`TABLE_ROWS` rows and, over one or two swept
    parameters, its plot, as HTML."""
    from ._sweep_plot import plot_sweep

    counts = ", ".join(f"{n} {k}" for k, n in sorted(run.counts.items()))
    head = "".join(f"<th>{html.escape(c)}</th>" for c in run.columns)
    rows = "".join(
        "<tr>" + "".join(f"<td>{_cell(r.get(c, ''))}</td>" for c in run.columns) + "</tr>"
        for r in run.rows[:TABLE_ROWS]
    )
    more = (
        f"<p>... {len(run.rows) - TABLE_ROWS} more rows: run.to_dataframe()</p>"
        if len(run.rows) > TABLE_ROWS
        else ""
    )
    out = (
        f"<p>sweep: {len(run.rows)} cases ({counts}) in {run.seconds:.3g} s</p>"
        f"<table><thead><tr>{head}</tr></thead><tbody>{rows}</tbody></table>{more}"
    )
    swept = [n for n, a in run.parameters.items() if len(a) > 1]
    if len(swept) in (1, 2) and run.measure_columns:
        out += _png(lambda p: plot_sweep(run, p))
    return out


class Animation:
    """An animation that Jupyter shows inline (``_repr_html_``); ``html`` is the page."""

    def __init__(self, page: str):
        self.html = page

    def _repr_html_(self) -> str:
        return self.html

    def save(self, path: str | Path) -> None:
        Path(path).write_text(self.html, encoding="utf-8")


def animation(traj, system, **options) -> Animation:
    """``traj`` (a run of ``system``) as an inline player: :func:`lamech.animate` to a
    self-contained HTML page (offline, JPEG frames), kept in memory. ``options`` are
    :func:`lamech.animate`'s (``fps``, ``duration``, ``max_frames``, ``dpi``, ...)."""
    from ._animate import animate

    with tempfile.TemporaryDirectory(prefix="lamech-nb-") as tmp:
        path = Path(tmp) / "animation.html"
        animate(traj, system, path, **options)
        return Animation(path.read_text(encoding="utf-8"))
