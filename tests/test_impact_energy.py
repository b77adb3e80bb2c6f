"""The kinetic energy an impact loses (issue 47 item 3), against Newton's law in closed
form: an impact of restitution e turns the gap velocity F- into F+ = -e F-; on a
frictionless surface only the velocity along the surface's normal changes, so the
energy lost is (1 - e^2) of the normal kinetic energy, 1/2 m F-^2 / |grad f|^2 for a
point mass. Where another constraint holds through the impact (a pendulum's rod) and the
motion has one degree of freedom, the velocity is scaled by -e: T+ = e^2 T-.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

import lamech
from lamech.numeric import simulate

HERE = Path(__file__).parent
BALL = (HERE / "problems" / "ball.toml").read_text(encoding="utf-8")
INCLINE = (HERE / "problems" / "ball_on_incline.toml").read_text(encoding="utf-8")

# a bob on a rod (Cartesian, the rod a bilateral constraint) swung into a wall at x = -d
PENDULUM_AT_A_WALL = """
title = "Pendulum swung into a wall"
[parameters]
m = 2.0
g = 9.81
l = 1.0
d = 0.5
e = 0.6
[coordinates]
x = { initial = 1, velocity = 0 }
y = { initial = 0, velocity = 0 }
[lagrangian]
T = "m/2*(x'^2 + y'^2)"
V = "m*g*y"
[[constraints]]
name = "rod"
f = "x^2 + y^2 - l^2"
[[constraints]]
name = "wall"
f = "x + d"
unilateral = true
restitution = "e"
"""


def _impacts(tr):
    return [ev for ev in tr.events if ev.kind == "impact"]


@pytest.mark.parametrize("e", [0.5, 0.8])
def test_a_ball_on_a_floor_loses_one_minus_e_squared_of_its_kinetic_energy(e):
    m = 1.0
    tr = simulate(lamech.loads(BALL.replace("e = 0.5", f"e = {e}")), 2.0, samples=11)
    impacts = _impacts(tr)
    assert len(impacts) >= 3
    for ev in impacts:
        normal = 0.5 * m * ev.velocity_before**2
        assert ev.energy_lost == pytest.approx((1 - e**2) * normal, rel=1e-10, abs=1e-14)


def test_a_ball_on_an_incline_loses_only_normal_kinetic_energy():
    m, e, alpha = 1.0, 0.7, 0.3
    tr = simulate(lamech.loads(INCLINE), 1.5, samples=11)
    impacts = _impacts(tr)
    assert len(impacts) >= 2
    for ev in impacts:
        # f = y + x tan(alpha): |grad f| = 1 / cos(alpha)
        normal = 0.5 * m * (ev.velocity_before * math.cos(alpha)) ** 2
        assert ev.energy_lost == pytest.approx((1 - e**2) * normal, rel=1e-10)


def test_a_pendulum_at_a_wall_keeps_e_squared_of_its_kinetic_energy():
    m, g, l, d, e = 2.0, 9.81, 1.0, 0.5, 0.6
    tr = simulate(lamech.loads(PENDULUM_AT_A_WALL), 1.5, samples=11)
    ev = _impacts(tr)[0]
    # released from rest at the horizontal, it reaches x = -d at height -sqrt(l^2 - d^2)
    before = m * g * math.sqrt(l**2 - d**2)
    assert ev.energy_lost == pytest.approx((1 - e**2) * before, rel=1e-9)


def test_the_summary_and_the_text_give_the_energy_lost(tmp_path, capsys):
    from lamech.cli import main

    path = tmp_path / "ball.toml"
    path.write_text(BALL, encoding="utf-8")
    assert main(["simulate", str(path), "--t-end", "1", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    first = next(ev for ev in out["events"] if ev["kind"] == "impact")
    assert first["energy_lost"] == pytest.approx(0.75 * 0.5 * first["velocity_before"] ** 2)
    assert main(["simulate", str(path), "--t-end", "1"]) == 0
    text = capsys.readouterr().out
    line = next(s for s in text.splitlines() if "impact" in s)
    assert "impulse" in line and "kinetic energy lost" in line
