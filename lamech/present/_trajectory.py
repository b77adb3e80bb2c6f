"""A :class:`~lamech.numeric.Trajectory` as text (the summary ``lamech simulate`` prints)
and as CSV (17 significant digits, both ends of the run)."""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

from ..outputs import write_output
from ._drives import simulated_drive_lines

__all__ = ["trajectory_text", "trajectory_csv"]


def _fmt(x: float) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "nan"
    return f"{float(x):.17g}"


def _g(x) -> str:
    return "n/a" if x is None else f"{x:.3g}"


def trajectory_csv(traj, path: str | Path | None = None) -> str | None:
    """Write the CSV of ``traj.columns()`` to ``path`` (a .csv file, by
    :func:`lamech.outputs.write_output`); return the text when None."""
    cols = traj.columns()
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow([name for name, _ in cols])
    for k in range(len(traj.t)):
        w.writerow([_fmt(arr[k]) for _, arr in cols])
    text = buf.getvalue()
    if path is None:
        return text
    write_output(path, text, (".csv",))
    return None


def _value(name: str, x: float, units: dict[str, str], degrees: bool = False) -> str:
    """``r = 1.5``; with units ``r = 1.5 m``, an angle ``theta1 = 0.5843 rad``, with
    ``degrees`` ``theta1 = 0.5843 rad (33.48°)``."""
    unit = units.get(name)
    text = f"{name} = {x:.10g}"
    if unit is None:
        return text
    if unit == "rad" and degrees:
        return f"{text} rad ({math.degrees(x):.2f}°)"
    return f"{text} {unit}"


def trajectory_text(traj) -> str:
    """The readable summary of a run: status, events, final state, residuals, energy;
    with units (issue 46), each value with its unit, an event's angles in degrees too,
    and the units of the CSV's columns."""
    s = traj.summary()
    units = getattr(traj, "units", None) or {}
    sec = " s" if units else ""
    lines = [
        f"{traj.title}" if traj.title else "simulation",
        f"  status: {s['status']}" + (f" ({s['message']})" if s["message"] else ""),
        f"  t = 0 .. {s['final_time']:.6g} of {s['t_end']:.6g}{sec}; {s['steps']} steps, "
        f"{s['evaluations']} dynamics evaluations, {s['samples']} samples"
        + (f"; engine: {s['engine']}" if s.get("engine") else "")
        + (f", {s['handed_back']} handed to SciPy's" if s.get("handed_back") else ""),
    ]
    for note in s["notes"]:
        lines.append(f"  note: {note}")
    lines.append(f"  events: {len(s['events'])}")
    for e in traj.events:
        coords = ", ".join(
            _value(k, v, units, degrees=True)
            for k, v in e.coordinates.items()
            if not k.endswith("'")
        )
        line = f"    t = {e.t:.12g}{sec}  {e.kind:<8} {e.constraint}: {coords}"
        if e.kind == "impact" and e.impulse is not None:
            line += f"; impulse {e.impulse:.6g}"
            if e.energy_lost is not None:
                line += f", kinetic energy lost {e.energy_lost:.6g}"
        lines.append(line)
    lines += simulated_drive_lines(s)
    final = ", ".join(_value(k, v, units) for k, v in s["final"].items())
    lines.append("  final state: " + final)
    lines.append(
        f"  max residual: |f| {_g(s['max_residual_position'])}, "
        f"|f'| {_g(s['max_residual_velocity'])}"
        f" (largest projection {_g(s['max_projection'])})"
    )
    ee = s["energy_error"]
    lines.append(
        "  energy error: "
        + (
            _g(ee) + " (relative)"
            if ee is not None
            else "n/a (driven, time-dependent or dissipative)"
        )
    )
    if units:
        columns = [name for name, _ in traj.columns()]
        lines.append(
            "  units (SI; the columns of --out): "
            + ", ".join(f"{k} {units[k]}" for k in columns if k in units)
        )
    return "\n".join(lines) + "\n"
