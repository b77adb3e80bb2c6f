"""The picture of a map of regimes (:func:`lamech.map`): the regions of the grid by the
event met first (slips first, lifts off first, slips or lets go at the start, holds),
their boundaries drawn, and each measure's angle beside it."""

from __future__ import annotations

import os

import numpy as np

from ..outputs import write_output
from ..sweeps import SweepError
from ._plain import drawn

__all__ = ["plot_map"]


def plot_map(result, path: str | os.PathLike) -> None:
    """Regions over one or two swept parameters (one: a strip), a panel per measure's
    angle; PNG or SVG by ``path``'s suffix."""
    from matplotlib.colors import ListedColormap
    from matplotlib.figure import Figure  # no pyplot: the caller's backend is untouched

    names = [n for n in result.parameters if len(np.unique(result.columns[n])) > 1]
    if len(names) not in (1, 2):
        raise SweepError(
            f"a picture of regions needs 1 or 2 parameters with several values (got "
            f"{len(names)}: {', '.join(names) or 'none'})"
        )
    cols = result.columns
    first = np.asarray(cols["first"], dtype=object)
    labels = sorted(set(first.tolist()), key=lambda s: (s == "none", s))
    code = np.array([labels.index(v) for v in first.tolist()], dtype=float)
    xa = np.unique(cols[names[0]])
    xb = np.unique(cols[names[1]]) if len(names) == 2 else np.array([0.0])

    def grid(values: np.ndarray) -> np.ndarray:
        Z = np.full((len(xb), len(xa)), np.nan)
        ia = np.searchsorted(xa, cols[names[0]])
        ib = np.searchsorted(xb, cols[names[1]]) if len(names) == 2 else np.zeros(len(ia), int)
        Z[ib, ia] = values
        return Z

    panels = [("first event", grid(code))]
    for m in result.measures:
        name = f"{m}:{result.coordinate}"
        panels.append((name, grid(np.asarray(cols[name], dtype=float))))
    fig = Figure(figsize=(4.8 * len(panels), 3.8))
    axes = fig.subplots(1, len(panels), squeeze=False)[0]
    palette = ["tab:orange", "tab:blue", "tab:red", "tab:purple", "tab:green", "0.8"]
    colors = [
        palette[i % (len(palette) - 1)] if v != "none" else "0.8" for i, v in enumerate(labels)
    ]
    for ax, (title, Z) in zip(axes, panels):
        ea, eb = _edges(xa), _edges(xb)
        if title == "first event":
            cmap = ListedColormap(colors)
            ax.pcolormesh(ea, eb, Z, cmap=cmap, vmin=-0.5, vmax=len(labels) - 0.5, shading="flat")
            if len(names) == 2 and len(labels) > 1:  # the boundaries between regions
                ax.contour(xa, xb, Z, levels=np.arange(len(labels) - 1) + 0.5, colors="k",
                           linewidths=0.8)  # fmt: skip
            from matplotlib.patches import Patch

            ax.legend(
                [Patch(color=c) for c in colors],
                [("holds" if v == "none" else v) for v in labels],
                fontsize=7,
                loc="best",
            )
        else:
            ax.set_facecolor("0.85")  # no such event: grey
            mesh = ax.pcolormesh(ea, eb, np.ma.masked_invalid(Z), shading="flat")
            fig.colorbar(mesh, ax=ax).set_label(drawn(title), fontsize=8)
        ax.set_xlabel(drawn(names[0]))
        if len(names) == 2:
            ax.set_ylabel(drawn(names[1]))
        else:
            ax.set_yticks([])
        ax.set_title(drawn(title), fontsize=9)
    fig.suptitle(drawn(f"map of regimes ({len(result)} points, closed forms)"), fontsize=10)
    fig.tight_layout()
    write_output(path, lambda tmp: fig.savefig(tmp, dpi=110), (".png", ".svg"), flag="`out=`")


def _edges(x: np.ndarray) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if len(x) == 1:
        return np.array([x[0] - 0.5, x[0] + 0.5])
    mid = (x[1:] + x[:-1]) / 2
    return np.concatenate(([2 * x[0] - mid[0]], mid, [2 * x[-1] - mid[-1]]))
