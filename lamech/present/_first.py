"""What the report shows first (issue 48): the drawing of the initial state
(:mod:`._figure`) beside the key results (each multiplier there, where a contact lets go
or slips, the frequencies, the drives' extremes, the simulation's events), and the drives'
force or torque against the coordinate they drive (issue 47). Every text is escaped."""

from __future__ import annotations

import html
import math

import numpy as np

from ._drives import _unit_of
from ._figure import initial_state, initial_svg
from ._report import _condition_lines
from ._svgplot import line_plot

__all__ = ["first_screen", "drives_html", "FIRST_STYLE"]

FIRST_STYLE = """
.first { display: flex; flex-wrap: wrap; gap: 1rem 1.5rem; align-items: flex-start; }
.first figure { margin: 0; flex: 0 0 auto; }
.first figure svg { max-width: 100%; height: auto; border: 1px solid #ddd; background: #fff; }
.first figcaption { font-size: .8rem; color: #555; max-width: 460px; }
.keys { flex: 1 1 20rem; min-width: 18rem; }
.keys h3 { margin: .4rem 0 .2rem; }
.keys ul { margin: 0; padding-left: 1.1rem; }
.keys li { margin: .15rem 0; }
"""


def _unit(sol, key: str) -> str:
    u = sol.units.get(key, "")
    return f" {u}" if u else ""


def _li(text: str, cls: str = "") -> str:
    c = f' class="{cls}"' if cls else ""
    return f"<li{c}>{html.escape(text)}</li>"


def _key_items(sol, traj, eqs) -> list[str]:
    """The key results as HTML, each heading with its list."""
    out = []
    state = initial_state(sol, traj)
    lams = [
        _li(f"λ_{c.name} = {lam + 0.0:.6g}{_unit(sol, 'lambda:' + c.name)}", "key-lambda")
        for c, lam in zip(sol.system.constraints, state.lambdas[0])
        if np.isfinite(lam)
    ]
    if lams:
        when = f"t = {state.t[0]:g}" if traj is not None else "the file's initial state"
        out.append(
            f"<h3>Multipliers at the start ({html.escape(when)})</h3><ul>{''.join(lams)}</ul>"
        )
    events = []
    for table, verdicts in (
        (sol.vanishes, sol.lets_go),
        (sol.slips, sol.slipping),
    ):
        lines = _condition_lines(sol, table, verdicts)
        # the answer per constraint: the first line of each (the others indented deeper)
        events += [_li(f"{ln.strip()}", "key-event") for ln in lines if not ln.startswith("    ")]
    if events:
        out.append(f"<h3>Where a contact lets go or slips</h3><ul>{''.join(events)}</ul>")
    modes = []
    for eq in eqs:
        at = ", ".join(f"{k} = {v:.4g}" for k, v in eq.values.items())
        for m in eq.modes:
            if m.frequency is not None and m.frequency > 0:
                period = 2 * math.pi / m.frequency
                text = f"about {at}: ω = {m.frequency:.6g} rad/s (period {period:.6g} s)"
            elif m.growth is not None:
                text = f"about {at}: unstable, growth rate {m.growth:.6g} 1/s"
            else:
                continue
            modes.append(_li(text, "key-mode"))
    if modes:
        out.append(f"<h3>Small oscillations</h3><ul>{''.join(modes)}</ul>")
    drives = []
    for name, d in getattr(sol, "drives", {}).items():
        cyc = d.cycle
        if cyc is None:
            continue
        u = _unit_of(sol, name, lambda k: _unit(sol, "lambda:" + k))
        for label, e in (("max", cyc.max), ("min", cyc.min)):
            deg = math.degrees(e.angle - cyc.start)
            drives.append(
                _li(
                    f"{name} on {cyc.coordinate}: {label} {e.value:.6g}{u} "
                    f"at {deg:.2f}° of the turn"
                )
            )
    if drives:
        out.append(f"<h3>Drives over a turn</h3><ul>{''.join(drives)}</ul>")
    if traj is not None:
        seen = [e for e in traj.events if not e.initial][:4]
        if seen:
            items = [
                _li(f"t = {e.t:.6g} s: {e.kind}" + (f" ({e.constraint})" if e.constraint else ""))
                for e in seen
            ]
            out.append(f"<h3>In the simulation</h3><ul>{''.join(items)}</ul>")
    return out


def first_screen(sol, traj=None, params=None, eqs=()) -> str:
    """The drawing of the initial state beside the key results."""
    drawing = initial_svg(sol, traj, params)
    parts = ['<section id="first" class="first">']
    if drawing:
        shown = ["the bodies"]
        if 'class="scenery"' in drawing:
            shown.append("the scenery")
        if 'class="contact"' in drawing:
            shown.append("the contact points (open circles)")
        if 'class="force"' in drawing:
            shown.append(
                "each constraint force (red arrows, their lengths in proportion to the "
                "forces; hover for the value)"
            )
        else:
            shown.append(
                "no force arrow (give a constraint a force = {at, along} to draw its force)"
            )
        text = "At the start: " + ", ".join(shown[:-1]) + " and " + shown[-1] + "."
        parts.append(f"<figure>{drawing}<figcaption>{html.escape(text)}</figcaption></figure>")
    else:
        parts.append(
            '<p class="note">No drawing: the problem declares no [[bodies]] (add them '
            "with a position and a shape).</p>"
        )
    parts.append('<div class="keys">' + "".join(_key_items(sol, traj, eqs)) + "</div></section>")
    return "".join(parts)


def _drive_curve(sol, traj, name, d):
    """(x, y, marks) of drive ``name`` against its coordinate: over a turn from the
    closed form where the drives leave no freedom, else along the simulated motion."""
    cyc = d.cycle
    if cyc is not None:
        x = np.linspace(cyc.start, cyc.start + 2 * math.pi, 361)
        y = np.array([cyc.at(a) for a in x])
        marks = [
            (e.angle, f"{label} {e.value:.6g}") for label, e in (("max", cyc.max), ("min", cyc.min))
        ]
        return x, y, marks
    if traj is None or name not in traj.drive_forces or d.coordinate is None:
        return None
    i = [c.name for c in sol.system.coordinates].index(d.coordinate)
    return traj.q[:, i], np.asarray(traj.drive_forces[name]), []


def drives_html(sol, traj=None) -> str:
    """A plot of each drive's force or torque against the coordinate it drives (issue
    47); "" without drives."""
    from ..symbolic._conditions import is_angle
    from ..symbolic._drives import turns

    out = []
    for name, d in getattr(sol, "drives", {}).items():
        curve = _drive_curve(sol, traj, name, d)
        if curve is None:
            continue
        x, y, marks = curve
        coord = d.coordinate or ""
        # an angle: in the Lagrangian only inside sin and cos, or the system repeats
        # after a turn of it (a massless crank is not in the Lagrangian)
        angle = bool(coord) and (
            turns(sol.system, name) or is_angle(sol.system, sol.system.symbols[coord])
        )
        if angle:
            x = np.degrees(x)
            marks = [(math.degrees(v), t) for v, t in marks]
        xu = "deg" if angle else sol.units.get(coord, "")
        u = _unit_of(sol, name, lambda k: _unit(sol, "lambda:" + k)).strip()
        what = "torque" if angle else "force"
        source = "over a turn (closed form)" if d.cycle is not None else "along the simulation"
        out.append(f"<h3>{html.escape(name)}: {what} on {html.escape(coord)}, {source}</h3>")
        out.append(
            line_plot(
                x,
                [(name, y)],
                f"{coord}" + (f" [{xu}]" if xu else ""),
                f"{what} of {name}" + (f" [{u}]" if u else ""),
                marks,
                plot_id=f"drive-{name}",
                x_degrees=angle,
            )
        )
    return "\n".join(out)
