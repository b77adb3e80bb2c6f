"""``lamech report``: one self-contained HTML page of a problem.

The page opens on a drawing of the system at its initial state beside the key results
(:mod:`._first`), then the sliders, the results, the drives' torques, the derivation
step by step, the force plot with the events, the animation and the simulation summary,
and the problem file (folded) at the end; it opens offline: the
math is rendered in the browser by KaTeX, vendored in ``vendor/katex`` (MIT licence,
kept beside it and quoted in the page), its script and style inlined and its fonts
embedded as data URIs (woff2 only: every browser that runs KaTeX reads it); plots and
the animation are embedded images. No CDN, no request leaves the page, and its
Content-Security-Policy (:mod:`._policy`) lets none: it runs its own scripts only.
"""

from __future__ import annotations

import base64
import html
import json
import re
import tempfile
from functools import cache
from pathlib import Path

from ..symbolic import Derivation
from ._first import FIRST_STYLE, drives_html, first_screen
from ._live import LIVE_STYLE, live_section
from ._policy import REFERRER, report_policy, tagged
from ._report import latex_names
from ._report import to_latex as _solution_latex
from ._report import to_text as _solution_text
from ._steps import step_rows

__all__ = ["report_page", "KATEX_DIR"]

KATEX_DIR = Path(__file__).resolve().parent / "vendor" / "katex"


@cache
def _katex() -> tuple[str, str, str]:
    """(script, style with the fonts inlined, licence) of the vendored KaTeX."""
    script = (KATEX_DIR / "katex.min.js").read_text(encoding="utf-8")
    style = (KATEX_DIR / "katex.min.css").read_text(encoding="utf-8")

    def font(match: re.Match) -> str:
        name = match.group(1)
        data = base64.b64encode((KATEX_DIR / "fonts" / f"{name}.woff2").read_bytes()).decode()
        return f'url(data:font/woff2;base64,{data}) format("woff2")'

    # src: woff2, woff, ttf -> the woff2 alone, inlined
    style = re.sub(
        r'url\(fonts/([\w-]+)\.woff2\) format\("woff2"\)'
        r'(?:,url\(fonts/[\w-]+\.woff\) format\("woff"\))?'
        r'(?:,url\(fonts/[\w-]+\.ttf\) format\("truetype"\))?',
        font,
        style,
    )
    licence = (KATEX_DIR / "LICENSE").read_text(encoding="utf-8")
    return script, style, licence


_STYLE = """
body { font-family: system-ui, sans-serif; max-width: 60rem; margin: 2rem auto;
       padding: 0 1rem; color: #222; line-height: 1.45; }
h1 { font-size: 1.6rem; } h2 { border-bottom: 1px solid #ddd; margin-top: 2.2rem; }
h3 { font-size: 1.05rem; margin-bottom: .3rem; }
pre { background: #f6f6f6; padding: .7rem; overflow-x: auto; font-size: .85rem; }
.math { overflow-x: auto; padding: .1rem 0; }
table.eqs { border-collapse: collapse; width: 100%; table-layout: fixed; }
table.eqs td { padding: 0 .4rem; vertical-align: middle; overflow-x: auto; }
table.eqs td.label { color: #666; font-size: .85rem; width: 30%; }
.note { color: #555; font-size: .9rem; margin: .2rem 0 .2rem 1rem; }
.correction { color: #8a4b00; }
img { max-width: 100%; }
nav a { margin-right: .8rem; }
footer { margin-top: 3rem; font-size: .75rem; color: #777; }
"""

KATEX_OPTIONS = {"throwOnError": False, "trust": False, "maxExpand": 1000, "maxSize": 20}
"""KaTeX's options in the page: a bad block shows as red text, never stops the others;
``trust`` off (no ``\\href``, ``\\url``, ``\\includegraphics`` nor HTML attributes from the
TeX, though the TeX lamech writes has none: user text is escaped, :mod:`._plain`);
macro expansions per block bounded (``\\def\\a{\\a\\a}\\a`` stops at 1000) and sizes
(``\\rule``, ``\\kern``) at 20 em."""

_RENDER = (
    """
var OPTIONS = """
    + json.dumps(KATEX_OPTIONS)
    + """;
document.querySelectorAll(".math, .tex").forEach(function (el) {
  var options = Object.assign({displayMode: el.classList.contains("math")}, OPTIONS);
  try { katex.render(el.textContent, el, options); }
  catch (e) { el.classList.add("unrendered"); }
});
document.body.setAttribute("data-rendered", document.querySelectorAll(".katex").length);
"""
)


def _math(tex: str) -> str:
    """A display-math block: the TeX as text (what shows without script), rendered by
    KaTeX on load."""
    return f'<div class="math">{html.escape(tex)}</div>'


def _table(rows: list[str]) -> str:
    """Rows ``lhs &= rhs && \\text{label}`` as a table: the equation in display math, its
    label (where it comes from) in a column of its own."""
    out = []
    for row in rows:
        eq, _, label = row.partition(" && ")
        eq = eq.replace("&=", "=", 1)
        cell = f'<span class="tex">{html.escape(label.strip())}</span>' if label.strip() else ""
        out.append(f'<tr><td>{_math(eq)}</td><td class="label">{cell}</td></tr>')
    return f'<table class="eqs">{"".join(out)}</table>' if out else ""


def _image(data: bytes, kind: str, alt: str) -> str:
    b64 = base64.b64encode(data).decode()
    return f'<img alt="{html.escape(alt)}" src="data:image/{kind};base64,{b64}">'


def _steps_html(d: Derivation) -> str:
    names = latex_names(d.system)
    out = []
    for k, step in enumerate(d.steps, 1):
        out.append(f'<h3 id="step-{k}">Step {k}. {html.escape(step.title)}</h3>')
        out.append(_table(step_rows(step, names)))
        for n in step.notes:
            cls = "note correction" if n.startswith("correction") else "note"
            out.append(f'<p class="{cls}">{html.escape(n)}</p>')
    return "\n".join(out)


def _results_html(sol) -> str:
    tex = _solution_latex(sol)
    body = tex.split("\\begin{align*}\n", 1)[1].rsplit("\n\\end{align*}", 1)[0]
    rows = [r for r in body.split(" \\\\\n") if r.strip()]
    return _table(rows) + (
        "<details><summary>The text report (<code>lamech solve</code>)</summary>"
        f"<pre>{html.escape(_solution_text(sol))}</pre></details>"
    )


def _simulation_html(traj, system, params) -> tuple[str, list[str]]:
    """The force plot, the animation and the summary; notes on what could not be drawn."""
    from ._animate import animate
    from ._plot import plot_trajectory
    from ._trajectory import trajectory_text

    parts, notes = [], []
    try:
        import matplotlib  # noqa: F401
    except ImportError as exc:
        notes.append(
            f"no plot and no animation: they need matplotlib ({exc}); pip install matplotlib"
        )
        parts.append(f"<pre>{html.escape(trajectory_text(traj))}</pre>")
        return "\n".join(parts), notes
    with tempfile.TemporaryDirectory(prefix="lamech-report-") as tmp:
        png = Path(tmp) / "forces.png"
        plot_trajectory(traj, png)
        parts.append(_image(png.read_bytes(), "png", "multipliers and forces against time"))
        if system.bodies:
            gif = Path(tmp) / "motion.gif"
            try:
                animate(traj, system, gif, params=params, fps=12, max_frames=90, dpi=55)
                parts.append(_image(gif.read_bytes(), "gif", "the motion"))
            except (ValueError, RuntimeError) as exc:  # pragma: no cover - no writer
                notes.append(f"no animation: {exc}")
        else:
            notes.append("no animation: the problem declares no [[bodies]] to draw")
    parts.append(f"<pre>{html.escape(trajectory_text(traj))}</pre>")
    return "\n".join(parts), notes


def equilibria(sol) -> tuple:
    """The equilibria whose frequencies the sliders follow: those of a motion with an
    energy shell (one degree of freedom: found quickly), else none."""
    if sol.shell is None:
        return ()
    try:
        return tuple(sol.equilibria)
    except (ValueError, TypeError, NotImplementedError, ArithmeticError):
        return ()  # the modes are a bonus here: `lamech modes` says what went wrong


def report_page(
    sol,
    derivation: Derivation,
    source: str | None,
    traj=None,
    params=None,
    note: str = "",
    nonce: str | None = None,
) -> str:
    """The HTML page (a string) of a solved problem: ``source`` is the problem file's
    text, ``traj`` an optional simulation of it (run with ``params``). The page carries
    its Content-Security-Policy (:func:`._policy.report_policy`: its own scripts and
    styles by hash, no network); ``nonce``: the served page's, written on each script
    and style for the frame that inherits that page's policy."""
    script, style, licence = _katex()
    title = html.escape(sol.system.title)
    eqs = equilibria(sol)
    drives = drives_html(sol, traj)
    sections = [
        ("first", "At the start"),
        ("live", "Move the parameters"),
        ("results", "Results"),
    ]
    if drives:
        sections.append(("drives", "Drives"))
    sections.append(("steps", "Step by step"))
    if traj is not None:
        sections.append(("motion", "The motion"))
    sections.append(("problem", "The problem"))
    nav = " ".join(f'<a href="#{k}">{v}</a>' for k, v in sections)
    body = [f"<h1>{title}</h1>", f"<nav>{nav}</nav>"]
    if note:
        body.append(f'<p class="note">{html.escape(note)}</p>')
    body.append(first_screen(sol, traj, params, eqs))
    live, live_script = live_section(sol, eqs)
    body += ['<section id="live"><h2>Move the parameters</h2>', live, "</section>"]
    body += ['<h2 id="results">Results</h2>', _results_html(sol)]
    if drives:
        body += ['<h2 id="drives">Drives: force or torque against the coordinate driven</h2>']
        body.append(drives)
    body += ['<h2 id="steps">Step by step</h2>', _steps_html(derivation)]
    if traj is not None:
        sim, notes = _simulation_html(traj, sol.system, params)
        body += ['<h2 id="motion">The motion</h2>', sim]
        body += [f'<p class="note">{html.escape(n)}</p>' for n in notes]
    body.append('<h2 id="problem">The problem</h2>')
    if source is not None:
        lines = source.count("\n") + 1
        body.append(
            f'<details id="problem-file"><summary>The problem file ({lines} lines)</summary>'
            f"<pre>{html.escape(source)}</pre></details>"
        )
    body.append(
        "<footer>Made by lamech. Math rendered by KaTeX (embedded; licence below).<pre>"
        + html.escape(licence)
        + "</pre></footer>"
    )
    styles = [style, _STYLE + LIVE_STYLE + FIRST_STYLE]
    scripts = [script, _RENDER] + ([live_script] if live_script else [])
    policy = html.escape(report_policy(scripts, styles))
    return (
        '<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">\n'
        f'<meta http-equiv="Content-Security-Policy" content="{policy}">\n'
        f'<meta name="referrer" content="{REFERRER}">\n'
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        f"<title>{title}</title>\n"
        + "\n".join(tagged("style", s, nonce) for s in styles)
        + "\n</head><body>\n"
        + "\n".join(body)
        + "\n"
        + "\n".join(tagged("script", s, nonce) for s in scripts)
        + "\n</body></html>\n"
    )
