"""Pictures of a sweep: a line plot per measure over one swept parameter, heat maps over two."""

from __future__ import annotations

import math
import os

import numpy as np

from ..outputs import write_output
from ..sweeps import SweepError, SweepResult
from ._plain import drawn

__all__ = ["plot_sweep"]


def plot_sweep(run: SweepResult, path: str | os.PathLike, max_panels: int = 9) -> None:
    """A line plot per measure column over one swept parameter, a heat map over two."""
    from matplotlib.figure import Figure  # no pyplot: the caller's backend is untouched

    swept = [n for n, a in run.parameters.items() if len(a) > 1]
    if len(swept) not in (1, 2):
        raise SweepError(
            f"a picture needs 1 or 2 parameters with several values (got "
            f"{len(swept)}: {', '.join(swept) or 'none'})"
        )
    cols = []  # the columns that vary (a constant one, e.g. r at a slip, says nothing)
    for c in run.measure_columns:
        vals = np.array([r[c] for r in run.rows], dtype=float)
        if np.any(np.isfinite(vals)) and np.nanmax(vals) != np.nanmin(vals):
            cols.append(c)
    cols = cols[:max_panels] or run.measure_columns[:1]
    k = len(cols)
    ncol = min(k, 3)
    nrow = math.ceil(k / ncol)
    fig = Figure(figsize=(4.6 * ncol, 3.6 * nrow))
    axes = fig.subplots(nrow, ncol, squeeze=False)
    fixed = {n: float(a[0]) for n, a in run.parameters.items() if len(a) == 1}
    failed = np.array([r["status"] != "ok" for r in run.rows], dtype=bool)
    for ax, c in zip(axes.flat, cols):
        if len(swept) == 1:
            x = np.array([r[swept[0]] for r in run.rows], dtype=float)
            y = np.array([r[c] for r in run.rows], dtype=float)
            order = np.argsort(x)
            ax.plot(x[order], y[order], "o-", ms=3)
            if failed.any():  # a failed run is not "no event": marked where it sits
                ax.plot(
                    x[failed],
                    np.full(failed.sum(), np.nanmin(y) if np.isfinite(y).any() else 0.0),
                    "x",
                    color="tab:red",
                    ms=7,
                    label="run failed",
                )
                ax.legend(fontsize=7)
            ax.set_xlabel(drawn(swept[0]))
            ax.set_ylabel(drawn(c))
        else:
            a, b = swept
            xa, xb = run.parameters[a], run.parameters[b]
            Z = np.full((len(xb), len(xa)), np.nan)
            F = np.zeros((len(xb), len(xa)), dtype=bool)
            ia = {float(v): i for i, v in enumerate(xa)}
            ib = {float(v): i for i, v in enumerate(xb)}
            for r, bad in zip(run.rows, failed):
                Z[ib[r[b]], ia[r[a]]] = r[c]
                F[ib[r[b]], ia[r[a]]] = bad
            ax.set_facecolor("0.85")  # cells with no value (no such event): grey
            mesh = ax.pcolormesh(
                _edges(xa), _edges(xb), np.ma.masked_invalid(np.where(F, np.nan, Z)), shading="flat"
            )
            bar = fig.colorbar(mesh, ax=ax)
            bar.set_label(drawn(c), fontsize=8)
            if F.any():  # failed runs: red cross-hatched cells
                ax.pcolormesh(
                    _edges(xa),
                    _edges(xb),
                    np.ma.masked_where(~F, F.astype(float)),
                    shading="flat",
                    cmap="Reds",
                    vmin=0,
                    vmax=1.5,
                    hatch="xx",
                    alpha=0.9,
                )
            ax.set_xlabel(drawn(a))
            ax.set_ylabel(drawn(b))
        ax.set_title(drawn(c), fontsize=9)
    for ax in list(axes.flat)[k:]:
        ax.set_visible(False)
    title = run.path.name if run.path else "sweep"
    if fixed:
        title += "  (" + ", ".join(f"{n} = {v:g}" for n, v in fixed.items()) + ")"
    if len(swept) == 2:
        title += "   grey: no such event" + ("; red hatched: run failed" if failed.any() else "")
    fig.suptitle(drawn(title), fontsize=10)
    fig.tight_layout()
    write_output(path, lambda tmp: fig.savefig(tmp, dpi=110), flag="`path=`")


def _edges(x: np.ndarray) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if len(x) == 1:
        return np.array([x[0] - 0.5, x[0] + 0.5])
    mid = (x[1:] + x[:-1]) / 2
    return np.concatenate(([2 * x[0] - mid[0]], mid, [2 * x[-1] - mid[-1]]))
