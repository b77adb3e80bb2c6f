"""The drives' forces and torques (``[[drives]]``) as text and JSON: in ``lamech solve``'s
report (the closed form and the extremes over a cycle) and in ``lamech simulate``'s
summary (:meth:`lamech.numeric.Trajectory.drive_summary`)."""

from __future__ import annotations

import math
from collections.abc import Callable

from ..expr import to_text

__all__ = ["drive_lines", "drives_json", "simulated_drive_lines"]


def _what(sol, name: str) -> str:
    d = sol.drives[name]
    return (
        f"on {d.coordinate}" if d.coordinate else "(its multiplier: generalized force lambda df/dq)"
    )


def _unit_of(sol, name: str, unit: Callable[[str], str]) -> str:
    """The multiplier's unit, which is the force's where df/dq_c = 1 (a motion or a speed)."""
    d = sol.drives[name]
    c = sol.system.constraint(name)
    if d.coordinate is None:
        return unit(name)
    from sympy import diff

    return unit(name) if diff(c.expr, sol.system.symbols[d.coordinate]) == 1 else ""


def drive_lines(sol, shown: Callable, unit: Callable[[str], str]) -> list[str]:
    """The ``Drives`` section of the report (empty without drives)."""
    if not getattr(sol, "drives", None):
        return []
    lines = ["", "Drives (force or torque on the coordinate driven, positive forward)"]
    for name, d in sol.drives.items():
        u = _unit_of(sol, name, unit)
        value = "no closed form" if d.expr is None else shown(d.expr) + u
        lines.append(f"  {name} {_what(sol, name)} = {value}")
        cyc = d.cycle
        if cyc is None:
            if d.note:
                lines.append(f"    over a cycle: not found ({d.note})")
            continue
        x = cyc.coordinate
        lines.append(
            f"    over a turn of {x} (the drives leave no freedom; {x} = {cyc.start:.6g} at t = 0, "
            f"a turn in {cyc.period:.6g}), extremes where its derivative vanishes:"
        )
        for label, e in (("max", cyc.max), ("min", cyc.min)):
            deg = math.degrees(e.angle - cyc.start)
            lines.append(
                f"      {label} {e.value:.10g}{u} at {x} = {e.angle:.10g} "
                f"({deg:.4f}° from the start, t = {e.t:.6g})"
            )
    return lines


def drives_json(sol) -> dict:
    """{name: {"coordinate", "force", "cycle": {"period", "start", "max": {...}, "min"}}}."""
    out = {}
    for name, d in getattr(sol, "drives", {}).items():
        item: dict = {
            "coordinate": d.coordinate,
            "force": None if d.expr is None else to_text(d.expr),
        }
        if d.cycle is not None:
            c = d.cycle
            item["cycle"] = {
                "period": c.period,
                "start": c.start,
                **{
                    k: {"value": e.value, "angle": e.angle, "t": e.t}
                    for k, e in (("max", c.max), ("min", c.min))
                },
            }
        elif d.note:
            item["cycle"] = None
            item["note"] = d.note
        out[name] = item
    return out


def simulated_drive_lines(summary: dict) -> list[str]:
    """The drives of a simulation's summary (``summary["drives"]``) as text, and beside
    them the named reactions' peaks (``summary["reactions"]``)."""
    drives = summary.get("drives") or {}
    if not drives:
        return []
    lines = [
        "  drives (force or torque on the coordinate driven, positive forward; the peak "
        "refined between the samples):"
    ]
    for name, d in drives.items():
        u = f" {d['unit']}" if d.get("unit") else ""
        on = f" on {d['coordinate']}" if d.get("coordinate") else ""
        pu = f" {d['power_unit']}" if d.get("power_unit") else ""
        lines.append(
            f"    {name}{on}: peak |value| {d['peak']:.8g}{u} {_at(d['at'])}; "
            f"RMS {d['rms']:.8g}{u}; mean power {d['mean_power']:.8g}{pu}"
        )
        if d.get("work_per_cycle") is not None:
            wu = f" {d['work_unit']}" if d.get("work_unit") else ""
            lines[-1] += f"; work per turn {d['work_per_cycle']:.8g}{wu}"
    reactions = summary.get("reactions") or {}
    if reactions:
        lines.append("  reactions (the magnitude of each named constraint force):")
        for name, r in reactions.items():
            u = f" {r['unit']}" if r.get("unit") else ""
            lines.append(f"    {name}: peak {r['peak']:.8g}{u} {_at(r['at'])}")
    return lines


def _at(at: dict) -> str:
    where = ", ".join(f"{k} = {v:.8g}" for k, v in at.items() if k != "t")
    return f"at t = {at['t']:.8g} ({where})"
