"""The README tells the truth: its tour output is what `lamech` prints, and its Python
snippets run and print what they say."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest

import lamech

README = Path(__file__).resolve().parents[1] / "README.md"


def _blocks(kind: str) -> list[str]:
    return re.findall(rf"```{kind}\n(.*?)```", README.read_text(encoding="utf-8"), re.S)


@pytest.mark.slow
def test_tour_output_is_what_lamech_prints():
    tour = next(b for b in _blocks("text") if b.startswith("Solid cylinder rolling"))
    actual = lamech.to_text(lamech.solve(lamech.load("cylinder")))
    assert tour.strip() == actual.strip()


@pytest.mark.parametrize(
    "snippet",
    [
        # numba compiles
        pytest.param(
            b, marks=[pytest.mark.slow, pytest.mark.shared_cache] if "jit=True" in b else []
        )
        for b in _blocks("python")
        if re.search(r"^print\(.*#", b, re.M)
    ],
)
def test_python_snippet_prints_what_its_comments_say(snippet):
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(snippet, "README.md", "exec"), {})  # our own README, not user text
    printed = out.getvalue().splitlines()
    comments = [
        line.split("#", 1)[1].strip()
        for line in snippet.splitlines()
        if line.startswith("print(") and "#" in line
    ]
    assert printed == comments


def test_latex_sample_is_what_lamech_prints():
    """The README's `--latex` block is the whole real output (it once differed)."""
    block = next(b for b in _blocks("console") if b.startswith("$ ./run solve pendulum --latex"))
    shown = block.split("\n", 1)[1]
    assert shown.strip() == lamech.to_latex(lamech.solve(lamech.load("pendulum"))).strip()


@pytest.mark.slow
def test_readme_modes_block_is_real_output():
    block = next(b for b in _blocks("text") if b.startswith("Small oscillations: Bead"))
    found = lamech.modes(lamech.load("hoop_bead"))
    from lamech.present import modes_text

    assert block == modes_text(found)
