"""A problem file's free text (its title, its force directions' names) is shown as text
in every picture and every piece of LaTeX lamech writes (issue 44, items 4 and 5):
matplotlib never reads mathtext in it, TeX never a command, generated code never the
title."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

import lamech
from lamech.present._plain import drawn, tex_label, tex_text

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "lamech" / "examples"
MATHTEXT = r"Tension $\lambda$ and $\frac{1}$"
PRICE = "costs $5, was $10"
HOSTILE = r"\href{javascript:alert(1)}{x} \def\a{\a\a}\a"


def _lamech(*args: str, tmp_path: Path) -> subprocess.CompletedProcess:
    env = {"LAMECH_CACHE_DIR": str(tmp_path / "cache"), "PATH": "/usr/bin:/bin"}
    return subprocess.run(
        [sys.executable, "-m", "lamech", *args], capture_output=True, text=True, env=env
    )


def _toml_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _titled(tmp_path: Path, example: str, title: str) -> Path:
    text = (EXAMPLES / f"{example}.toml").read_text(encoding="utf-8")
    text = re.sub(r"^title = .*$", lambda _: f"title = {_toml_string(title)}", text, flags=re.M)
    out = tmp_path / f"{example}-titled.toml"
    out.write_text(text, encoding="utf-8")
    return out


def _hostile_label(tmp_path: Path) -> Path:
    """The cylinder with its contact force's direction named by TeX that links and loops."""
    text = (EXAMPLES / "cylinder.toml").read_text(encoding="utf-8")
    assert "along = { normal = [" in text
    text = text.replace("along = { normal = [", f"along = {{ '{HOSTILE}' = [")
    out = tmp_path / "hostile.toml"
    out.write_text(text, encoding="utf-8")
    return out


# ----- item 4: matplotlib ---------------------------------------------------------------
@pytest.mark.parametrize("text", [MATHTEXT, PRICE, "$$", r"a\$b $x^2$"])
def test_drawn_text_is_never_read_as_mathtext(text):
    from matplotlib.figure import Figure

    fig = Figure()
    ax = fig.subplots()
    ax.set_title(drawn(text))
    ax.plot([0, 1], label=drawn(text))
    ax.legend()
    fig.canvas.draw()  # parses every text: raises on mathtext it cannot read
    assert ax.title._preprocess_math(ax.title.get_text()) == (text, False)


@pytest.mark.slow
@pytest.mark.parametrize("title", [MATHTEXT, PRICE], ids=["mathtext", "price"])
def test_a_title_with_dollars_gives_a_report_and_a_plot(tmp_path, title):
    problem = _titled(tmp_path, "pendulum", title)
    page = tmp_path / "r.html"
    run = _lamech("report", str(problem), "-o", str(page), "--t-end", "1", tmp_path=tmp_path)
    assert run.returncode == 0 and "Traceback" not in run.stderr, run.stderr
    assert page.read_text(encoding="utf-8").count("data:image/png;base64,") == 1
    png = tmp_path / "p.png"
    run = _lamech("simulate", str(problem), "--t-end", "1", "--plot", str(png), tmp_path=tmp_path)
    assert run.returncode == 0 and "Traceback" not in run.stderr, run.stderr
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# ----- item 5: LaTeX ----------------------------------------------------------------------
def test_tex_text_escapes_every_special_character():
    assert tex_text(r"\ { } $ & # ^ _ % ~") == (
        r"\textbackslash{} \{ \} \$ \& \# \textasciicircum{} \_ \% \textasciitilde{}"
    )
    assert tex_text("a\nb\rc") == "a b c"
    assert tex_label("rolling_1") == r"\mathrm{rolling\_1}"
    assert tex_label("normal force") == r"\text{normal force}"
    assert "\\href" not in tex_label(HOSTILE) and "\\def" not in tex_label(HOSTILE)


@pytest.mark.slow
def test_a_tex_label_is_escaped_in_solve_latex(tmp_path):
    problem = _hostile_label(tmp_path)
    for extra in ([], ["--steps"]):
        run = _lamech("solve", str(problem), "--latex", *extra, tmp_path=tmp_path)
        assert run.returncode == 0, run.stderr
        assert "\\href" not in run.stdout and "\\def" not in run.stdout
        assert r"\textbackslash{}href\{javascript:alert(1)\}" in run.stdout


@pytest.mark.slow
def test_a_tex_label_is_text_in_the_report_in_chromium(tmp_path, chromium):
    problem = _hostile_label(tmp_path)
    out = tmp_path / "r.html"
    run = _lamech("report", str(problem), "-o", str(out), "--no-simulate", tmp_path=tmp_path)
    assert run.returncode == 0, run.stderr
    page = chromium.new_page()
    page.goto(out.as_uri())
    page.wait_for_selector("body[data-rendered]", timeout=30_000)
    assert page.locator(".katex-error").count() == 0
    assert page.locator(".katex a, .katex [href]").count() == 0  # no link made from the TeX
    row = page.locator("tr", has_text="contact force").first
    shown = re.sub(r"[\s\u200b]", "", row.inner_text())  # KaTeX's spans apart
    assert HOSTILE.replace(" ", "") in shown  # typeset letter for letter
    page.close()


@pytest.mark.slow
def test_a_sweep_picture_of_a_table_named_with_dollars_is_drawn(tmp_path):
    import lamech
    from lamech.present import plot_sweep

    table = tmp_path / r"Tension $\lambda$ and $\frac{1}$.csv"
    run = lamech.sweep(
        "pendulum", {"theta0": "0.2,0.4"}, ["max:lambda:string"], t_end=1.0, out=table
    )
    png = tmp_path / "sweep.png"
    plot_sweep(run, png)  # the table's name is the picture's title
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


PENDULUM = lamech.problem.example_path("pendulum").read_text(encoding="utf-8")


def test_the_title_never_reaches_generated_code():
    """A backslash-N (a Python escape) or a NUL in the title once broke the generated
    source; the title is the user's text and is not part of it."""
    import dataclasses

    text = PENDULUM.replace(
        'title = "Simple pendulum: the string\'s tension as a Lagrange multiplier"',
        'title = \'Pendulum \\N{oops} """ \\x00 \\\'',
    )
    assert text != PENDULUM
    system = lamech.loads(text, "p.toml")
    assert "\\N{oops}" in system.title
    for title in (system.title, "nul \x00 inside"):
        ns = lamech.compile_system(dataclasses.replace(system, title=title))
        assert title not in ns.source
    traj = lamech.simulate(system, 0.05, samples=3)
    assert traj.status == "ok", traj.message
