"""A :class:`~lamech.numeric.Trajectory` as text (the summary ``lamech simulate`` prints),
as the ``--json`` object (:func:`trajectory_json`, what :func:`lamech.to_json` gives) and
as CSV (17 significant digits, both ends of the run)."""

from __future__ import annotations

import csv
import io
import math
import os

import numpy as np

from ..outputs import write_output
from ._drives import simulated_drive_lines

__all__ = ["trajectory_text", "trajectory_csv", "trajectory_json"]


def _fmt(x: float) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "nan"
    return f"{float(x):.17g}"


def _g(x) -> str:
    return "n/a" if x is None else f"{x:.3g}"


def trajectory_csv(traj, path: str | os.PathLike | None = None) -> str | None:
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


def trajectory_json(traj) -> dict:
    """The ``--json`` summary of a run (docs/reference/json.md): status, events (with
    units, each angle in degrees beside its radians), the final state, residuals, the
    energy error, counters, and the drives' and named reactions' peaks
    (:meth:`~lamech.numeric.Trajectory.drive_summary`,
    :meth:`~lamech.numeric.Trajectory.reaction_summary`)."""
    rp = float(np.nanmax(traj.residual_position)) if len(traj.t) else None
    rv = float(np.nanmax(traj.residual_velocity)) if len(traj.t) else None
    final = {}
    if traj.final_q is not None and traj.final_qd is not None:
        for i, c in enumerate(traj.coordinates):
            final[c] = float(traj.final_q[i])
        for i, c in enumerate(traj.coordinates):
            final[c + "'"] = float(traj.final_qd[i])
    angles = [c for c in traj.coordinates if traj.units.get(c) == "rad"]
    out = {
        "title": traj.title,
        "t_end": traj.t_end,
        "final_time": traj.final_time,
        "events": [_event_json(e, angles) for e in traj.events],
        "final": final,
        "max_residual": None if rp is None or rv is None else max(rp, rv),
        "max_residual_position": rp,
        "max_residual_velocity": rv,
        "max_projection": traj.max_projection,
        "energy_error": traj.energy_error,
        "steps": traj.steps,
        "evaluations": traj.evaluations,
        "engine": traj.engine,
        "handed_back": traj.handed_back,
        "samples": int(len(traj.t)),
        "status": str(traj.status),
        "message": traj.message,
        "notes": list(traj.notes),
        **({"drives": traj.drive_summary()} if traj.drive_forces else {}),
        **({"reactions": traj.reaction_summary()} if traj.forces else {}),
    }
    if traj.units:
        out["units"] = dict(traj.units)
    return out


def _event_json(e, angles: list[str]) -> dict:
    """An event as the summary gives it; with units, each of the ``angles`` (the
    coordinates in rad) in degrees beside its radians."""
    out = e.to_json()
    if angles:
        there = e.coordinates
        out["degrees"] = {c: math.degrees(there[c]) for c in angles if c in there}
    return out


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
    s = trajectory_json(traj)
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
