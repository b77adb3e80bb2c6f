"""Plots of a :class:`~lamech.numeric.Trajectory` (matplotlib)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..outputs import write_output
from ._plain import drawn

__all__ = ["plot_trajectory"]

_EVENT_COLOURS = {
    "lift-off": "tab:red",
    "contact": "tab:green",
    "impact": "tab:purple",
    "slip": "tab:orange",
    "stick": "tab:blue",
}


def plot_trajectory(traj, path: str | Path, title: str | None = None) -> None:
    """Two panels: multipliers (and Cartesian forces) against time with the events marked
    and labelled; the coordinates against time. With drives (``[[drives]]``), a third:
    each drive's force or torque against time, and below it, for a drive that turns its
    coordinate (an angle through a whole turn or more), the torque against that angle
    over each turn, in degrees."""
    # A Figure of its own (no pyplot): drawing to a file never switches the caller's
    # backend (a notebook keeps its inline one).
    from matplotlib.figure import Figure

    units = getattr(traj, "units", None) or {}

    def unit(key: str) -> str:  # " [N]" where the file gives units (issue 46)
        return f" [{units[key]}]" if key in units else ""

    drives = getattr(traj, "drive_forces", None) or {}
    turning = [n for n in drives if _turns(traj, n)]
    if drives:
        rows = [3, 2, 2] + ([2] if turning else [])
        fig = Figure(figsize=(9, 7.5 + 2.5 * (len(rows) - 2)))
        grid = fig.add_gridspec(len(rows), 1, height_ratios=rows)
        ax1 = fig.add_subplot(grid[0])
        ax2 = fig.add_subplot(grid[1], sharex=ax1)
        _plot_drives(traj, fig, grid, ax1, turning)
        ax1.tick_params(labelbottom=False)
        ax2.tick_params(labelbottom=False)
    else:
        fig = Figure(figsize=(9, 7.5))
        ax1, ax2 = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": [3, 2]})
    t = traj.t
    for j, name in enumerate(traj.constraints):
        lam = traj.lambdas[:, j]
        if np.any(np.isfinite(lam)):
            ax1.plot(t, lam, lw=1.6, label=drawn(f"λ {name}{unit('lambda:' + name)}"))
    for key, arr in traj.forces.items():
        c, d = key.split(":", 1)
        j = traj.constraints.index(c)
        if np.any(np.isfinite(arr)) and not np.allclose(arr, traj.lambdas[:, j], equal_nan=True):
            label = f"{c} force along {d}{unit('force:' + key)}"
            ax1.plot(t, arr, lw=1.0, ls="--", label=drawn(label))
    ax1.axhline(0.0, color="0.6", lw=0.8)
    ax1.set_ylabel("multiplier λ / constraint force")  # units: those of the file
    ax1.set_title(drawn(title or traj.title or "lamech simulation"))
    seen = set()
    ymax = ax1.get_ylim()[1]
    for e in traj.events:
        colour = _EVENT_COLOURS.get(e.kind, "k")
        for ax in (ax1, ax2):
            ax.axvline(e.t, color=colour, lw=0.9, ls=":")
        if len(traj.events) <= 12 or e.kind not in seen:
            ax1.annotate(
                drawn(f"{e.kind} ({e.constraint})\nt = {e.t:.4g}"),
                xy=(e.t, ymax),
                xytext=(3, -3),
                textcoords="offset points",
                fontsize=7.5,
                color=colour,
                va="top",
                rotation=90,
            )
        seen.add(e.kind)
    if ax1.get_legend_handles_labels()[0]:  # a system without constraints has no lambda
        ax1.legend(fontsize=8, loc="best")
    ax1.grid(alpha=0.25)
    for i, name in enumerate(traj.coordinates):
        ax2.plot(t, traj.q[:, i], lw=1.3, label=drawn(name + unit(name)))
    ax2.set_xlabel("" if drives else "time t" + unit("t"))
    ax2.set_ylabel("coordinates")
    ax2.legend(fontsize=8, loc="best")
    ax2.grid(alpha=0.25)
    if traj.status != "ok":
        message = drawn(f"{traj.status}: {traj.message}"[:160])
        fig.text(0.01, 0.005, message, fontsize=7, color="red")
    fig.tight_layout()
    write_output(path, lambda tmp: fig.savefig(str(tmp), dpi=120), flag="`path=`")


def _turns(traj, name: str) -> bool:
    """Whether drive ``name`` turns its coordinate, an angle, through a whole turn."""
    coord = traj.drive_coordinates.get(name)
    if coord is None or not traj.drive_turns.get(name) or len(traj.t) < 2:
        return False
    angle = traj.coordinate(coord)
    return bool(np.nanmax(np.abs(angle - angle[0])) >= 2 * np.pi)


def _plot_drives(traj, fig, grid, ax1, turning: list[str]) -> None:
    """The drives' row: each drive's force or torque against time (sharing the time axis
    of ``ax1``); for those in ``turning``, against their coordinate's angle over each
    turn (0..360 degrees from the start, a line a turn)."""
    units = traj.drive_units
    ax = fig.add_subplot(grid[2], sharex=ax1)
    for name, tau in traj.drive_forces.items():
        on = traj.drive_coordinates.get(name)
        u = f" [{units[name]}]" if name in units else ""
        ax.plot(traj.t, tau, lw=1.3, label=drawn(f"{name}" + (f" on {on}" if on else "") + u))
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("time t" + (f" [{traj.units['t']}]" if "t" in traj.units else ""))
    ax.set_ylabel("drive force / torque")
    ax.legend(fontsize=8, loc="best")
    ax.grid(alpha=0.25)
    if not turning:
        return
    side = fig.add_subplot(grid[3])
    for name in turning:
        angle = traj.coordinate(traj.drive_coordinates[name])
        turned = np.degrees(angle - angle[0])
        wrapped = np.mod(turned, 360.0)
        # a break (NaN) where a turn ends, so each turn is a line of its own
        cut = np.nonzero(np.diff(np.floor_divide(turned, 360.0)) != 0)[0] + 1
        x = np.insert(wrapped, cut, np.nan)
        y = np.insert(np.asarray(traj.drive_forces[name], dtype=float), cut, np.nan)
        side.plot(x, y, lw=1.3, label=drawn(name))
    side.axhline(0.0, color="0.6", lw=0.8)
    coords = sorted({traj.drive_coordinates[n] for n in turning})
    side.set_xlabel(drawn(f"{', '.join(coords)} from the start [deg]"))
    side.set_xlim(0.0, 360.0)
    side.set_ylabel("drive torque")
    side.legend(fontsize=8, loc="best")
    side.grid(alpha=0.25)
