"""Pages written at build time from the library itself, so that they never go stale.

- ``_generated/gallery/<name>.md``: one page per bundled example (``lamech.example_names``):
  its problem file, ``lamech solve``'s text output, a plot of a simulation and its
  equations in LaTeX, computed by the library while the docs build.
- ``_generated/cli/<command>.txt``: ``lamech [<command>] --help`` as the installed
  command prints it (the argument parser is the only source of the CLI reference).

``LAMECH_DOCS_GALLERY`` limits the gallery to a comma-separated list of examples (the
quick docs test builds three; unset or ``all``: every bundled example).
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

COMMANDS = ("", "solve", "modes", "examples", "simulate", "sweep", "map", "report", "serve")


def _write(path: Path, text: str) -> None:
    """Write only when changed, so that Sphinx rebuilds only what changed."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


def cli_help(command: str) -> str:
    """``lamech [command] --help`` as a user's terminal of 88 columns shows it."""
    argv = [sys.executable, "-m", "lamech", *([command] if command else []), "--help"]
    env = dict(os.environ, COLUMNS="88")
    return subprocess.run(argv, capture_output=True, text=True, check=True, env=env).stdout


def write_cli(out: Path) -> None:
    for command in COMMANDS:
        _write(out / f"{command or 'lamech'}.txt", cli_help(command))


def _align_body(latex: str) -> str:
    match = re.search(r"\\begin\{align\*\}\n(.*?)\\end\{align\*\}", latex, re.S)
    return match.group(1).rstrip() if match else ""


# How long each example is simulated for its plot (default 2 s): the squeezer's motion
# takes 0.03 s (Hairer and Wanner's reference time), the top spins 20 turns a second,
# and the lecture's cylinder, started just off the top, slips and leaves by 2.5 s.
PLOT_T_END = {"andrews_squeezer": 0.03, "heavy_top": 0.5, "cylinder": 3.0}
PLOT_INITIAL = {"cylinder": {"theta1": 0.01}}
PLOT_SAMPLES = 301


def plot(name: str, system, path: Path) -> str:
    """Simulate the example, plot its multipliers and coordinates to ``path``; return
    the command that makes the same plot."""
    import matplotlib

    matplotlib.use("Agg")
    import lamech

    t_end = PLOT_T_END.get(name, 2.0)
    initial = PLOT_INITIAL.get(name)
    traj = lamech.simulate(system, t_end, initial=initial, samples=PLOT_SAMPLES)
    path.parent.mkdir(parents=True, exist_ok=True)
    lamech.plot_trajectory(traj, path)
    options = "".join(f" --initial {k}={v}" for k, v in (initial or {}).items())
    return (
        f"lamech simulate {name}{options} --t-end {t_end:g} --samples {PLOT_SAMPLES} "
        f"--plot {path.name}"
    )


def gallery_page(name: str, folder: Path | None = None) -> str:
    import lamech
    from lamech.problem import example_path

    path = example_path(name)
    source = path.read_text(encoding="utf-8")
    system = lamech.load(name)
    solution = lamech.solve(system)
    text = lamech.to_text(solution)
    body = _align_body(lamech.to_latex(solution))
    title = system.title
    parts = [
        f"({name})=",
        f"# {title}",
        "",
        f"Bundled example `{name}` (`lamech/examples/{path.name}`): run it with "
        f"`lamech solve {name}`, `lamech simulate {name}`, `lamech report {name} -o "
        f"{name}.html`.",
        "",
    ]
    parts += [
        "## The problem file",
        "",
        "Its comment says what the problem is and the textbook answer it is checked against.",
        "",
        "```toml",
        source.rstrip(),
        "```",
        "",
    ]
    parts += [f"## `lamech solve {name}`", "", "```text", text.rstrip(), "```", ""]
    if folder is not None:
        command = plot(name, system, folder / f"{name}.png")
        parts += [
            "## The motion",
            "",
            f"`{command}`: the multipliers (constraint forces) and the coordinates "
            "against time, with the events.",
            "",
            f"![The multipliers and coordinates of {title} against time]({name}.png)",
            "",
        ]
    if body:
        parts += [
            f"## The equations (`lamech solve {name} --latex`)",
            "",
            "```{math}",
            ":nowrap:",
            "",
            "\\begin{align*}",
            body,
            "\\end{align*}",
            "```",
            "",
        ]
    return "\n".join(parts)


def gallery_names() -> list[str]:
    import lamech

    names = list(lamech.example_names())
    wanted = os.environ.get("LAMECH_DOCS_GALLERY", "all").strip()
    if wanted and wanted != "all":
        chosen = [n.strip() for n in wanted.split(",") if n.strip()]
        unknown = sorted(set(chosen) - set(names))
        if unknown:
            raise ValueError(f"LAMECH_DOCS_GALLERY: no bundled example {unknown}")
        names = [n for n in names if n in chosen]
    return names


def write_gallery(out: Path) -> None:
    names = gallery_names()
    for old in [*out.glob("*.md"), *out.glob("*.png")] if out.exists() else []:
        if old.stem not in names:
            old.unlink()
    for name in names:
        _write(out / f"{name}.md", gallery_page(name, out))


def generate(app) -> None:
    src = Path(app.srcdir)
    write_cli(src / "_generated" / "cli")
    write_gallery(src / "_generated" / "gallery")


def setup(app):
    app.connect("builder-inited", generate)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
