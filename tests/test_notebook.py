"""In Jupyter (issue 15, item 5): a Trajectory shows its summary and force plot inline, a
sweep a table and a plot, an animation plays inline, a Solution renders with dotted
velocities. Jupyter calls ``_repr_html_``/``_repr_latex_``; so do these tests."""

from __future__ import annotations

import base64
import re

import pytest

import lamech
from lamech.present import Animation, animation


def _images(page: str) -> list[bytes]:
    found = re.findall(r"data:image/png;base64,([A-Za-z0-9+/=]+)", page)
    return [base64.b64decode(b) for b in found]


@pytest.mark.slow
def test_a_trajectory_shows_its_summary_and_plot():
    traj = lamech.simulate(lamech.load("cylinder"), 2.0, initial={"theta1": 0.05})
    page = traj._repr_html_()
    assert "lift-off" in page and "status: ok" in page
    (png,) = _images(page)
    assert png.startswith(b"\x89PNG") and len(png) > 10_000


def test_a_sweep_shows_a_table_and_a_plot():
    run = lamech.sweep(
        "cylinder", {"mu": [0.2, 0.3, 0.4]}, ["slip"], t_end=2.7, samples=11, workers=1
    )
    page = run._repr_html_()
    assert page.count("<tr>") == 1 + 3 and "<th>slip:theta1</th>" in page
    assert "3 cases (3 ok)" in page
    assert len(_images(page)) == 1


@pytest.mark.slow
def test_an_animation_plays_inline_offline():
    system = lamech.load("pendulum")
    anim = animation(lamech.simulate(system, 1.0), system, max_frames=10, dpi=40)
    assert isinstance(anim, Animation)
    page = anim._repr_html_()
    assert "<script" in page and "image/jpeg;base64" in page
    assert not re.search(r'(src|href)="https?://', page)


def test_a_solution_renders_with_dotted_velocities(solved_example):
    latex = solved_example("pendulum")._repr_latex_()
    assert r"\dot{\theta}" in latex and "theta'" not in latex


def test_velocities_render_with_dots_in_jupyter(solved_example):
    """A multiplier shown raw in a notebook (SymPy's LaTeX) reads l m theta-dot^2, not
    theta'^{2}; the text form keeps the file grammar."""
    import sympy as sp

    s = solved_example("pendulum")
    latex = sp.latex(s.multipliers["string"])
    assert latex == r"g m \cos{\left(\theta \right)} + l m \dot{\theta}^{2}"
    assert lamech.to_text(s).count("theta'^2") >= 1
    assert r"\ddot{r}" in sp.latex(s.equations[0])
