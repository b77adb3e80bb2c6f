"""The README and the documentation tell the truth: the tour's output is what `lamech`
prints, the `--latex` sample and the modes block are the whole real output.

(Every console and doctest example of the README and of docs/ runs in
tests/test_docs.py; this file keeps the whole-output checks of the blocks that print
SymPy's LaTeX and the modes report, which moved from the README into docs/.)"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import lamech

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]


def _blocks(kind: str) -> list[str]:
    return [
        block
        for page in PAGES
        if "_generated" not in page.parts and "_build" not in page.parts
        for block in re.findall(rf"```{kind}\n(.*?)```", page.read_text(encoding="utf-8"), re.S)
    ]


@pytest.mark.slow
def test_tour_output_is_what_lamech_prints():
    tour = next(b for b in _blocks("console") if b.startswith("$ ./run\nSolid cylinder rolling"))
    actual = lamech.to_text(lamech.solve(lamech.load("cylinder")))
    assert tour.split("\n", 1)[1].strip() == actual.strip()


def test_latex_sample_is_what_lamech_prints():
    """The README's `--latex` block is the whole real output (it once differed)."""
    block = next(b for b in _blocks("console") if b.startswith("$ ./run solve pendulum --latex"))
    shown = block.split("\n", 1)[1]
    assert shown.strip() == lamech.to_latex(lamech.solve(lamech.load("pendulum"))).strip()


@pytest.mark.slow
def test_modes_block_is_real_output():
    """docs/guide/modes.md shows the bead on a hoop's whole modes report."""
    block = next(b for b in _blocks("text") if b.startswith("Small oscillations: Bead"))
    found = lamech.modes(lamech.load("hoop_bead"))
    from lamech.present import modes_text

    assert block == modes_text(found)
