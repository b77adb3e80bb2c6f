"""Steady motions of problems whose constraints move (issue 43, section 2): the bead on
a hoop spun at w, written in Cartesian coordinates, has equations with t in them; in the
hoop's angle (x = R sin(theta) cos(wt), y = R sin(theta) sin(wt), z = -R cos(theta),
which satisfies both constraints identically) it has none, and its relative
equilibria are the textbook's: theta = 0, stable iff w^2 < g/R, and
cos(theta) = g/(R w^2) with Omega^2 = w^2 - g^2/(R^2 w^2)."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import lamech
from lamech.cli import main
from lamech.model import with_values

HOOP = """
title = "Bead on a spinning hoop (Cartesian, two constraints)"
[parameters]
m = 0.1
g = 9.81
R = 0.5
w = 6.0
th0 = 0.3
[coordinates]
x = { initial = "R*sin(th0)", velocity = 0 }
y = { initial = 0, velocity = "w*R*sin(th0)" }
z = { initial = "-R*cos(th0)", velocity = 0 }
[lagrangian]
T = "m/2*(x'^2 + y'^2 + z'^2)"
V = "m*g*z"
[[constraints]]
name = "hoop"
f = "x^2 + y^2 + z^2 - R^2"
[[constraints]]
name = "plane"
f = "y*cos(w*t) - x*sin(w*t)"
"""

BREATHING = """
title = "Pendulum whose string is paid out and hauled in"
[parameters]
m = 1.0
g = 9.81
l = 1.0
b = 0.1
w = 3.0
[coordinates]
x = { initial = 0, velocity = 0 }
y = { initial = "-l", velocity = "-b*w" }
[lagrangian]
T = "m/2*(x'^2 + y'^2)"
V = "m*g*y"
[[constraints]]
name = "string"
f = "x^2 + y^2 - (l + b*sin(w*t))^2"
"""


def _values(system) -> dict[str, float]:
    return {p.name: p.numeric for p in system.parameters}


def _theta(e) -> float:
    (value,) = (v for k, v in e.values.items() if k not in ("x", "y", "z"))
    return value


def steady_accelerations_agree(system, e, t: float) -> float:
    """max |q'' (KKT) - q'' (riding the hoop at the fixed angle)| at time t: the KKT
    system [[M, -A^T], [A, 0]] [q'', lambda] = [Q - h, -gamma], solved by NumPy with the
    derived matrices evaluated by SymPy, against the second derivative of the steady
    motion x = R sin(th) cos(wt), y = R sin(th) sin(wt), z = -R cos(th)."""
    p = {s.symbol: s.numeric for s in system.parameters}
    R, w = (next(s.numeric for s in system.parameters if s.name == n) for n in ("R", "w"))
    th = e.values[next(c.name for c in system.chart_coordinates)]
    q = [R * math.sin(th) * math.cos(w * t), R * math.sin(th) * math.sin(w * t), -R * math.cos(th)]
    qd = [-R * w * math.sin(th) * math.sin(w * t), R * w * math.sin(th) * math.cos(w * t), 0.0]
    want = [-(w**2) * q[0], -(w**2) * q[1], 0.0]
    dyn = lamech.dynamics(system)
    env = {**p, system.t: t}
    env.update({c.symbol: v for c, v in zip(system.coordinates, q)})
    env.update({c.velocity: v for c, v in zip(system.coordinates, qd)})

    def num(M):
        return np.array(M.xreplace(env).evalf(), dtype=float).reshape(M.shape)

    M, A = num(dyn.M), num(dyn.A)
    K = np.block([[M, -A.T], [A, np.zeros((2, 2))]])
    rhs = np.concatenate([num(dyn.Q - dyn.h).ravel(), -num(dyn.gamma).ravel()])
    return float(np.abs(np.linalg.solve(K, rhs)[:3] - want).max())


@pytest.mark.slow  # 2 s or more in the default set (2026-11-29)
def test_the_spun_hoop_in_cartesian_coordinates_has_the_textbooks_relative_equilibria():
    system = lamech.loads(HOOP, "hoop.toml")
    p = _values(system)
    g, R, w = p["g"], p["R"], p["w"]
    md = lamech.modes(system)
    assert md.reason is None and "relative ones" in md.frame
    side = [e for e in md.equilibria if e.condition]
    assert sorted(_theta(e) for e in side) == pytest.approx(
        [-math.acos(g / (R * w**2)), math.acos(g / (R * w**2))], rel=1e-12
    )
    S = {q.name: q.symbol for q in md.system.parameters}
    for e in side:
        assert e.exists and e.stability == "stable" and e.condition == "g/(R*w^2) <= 1"
        (mode,) = e.modes
        assert mode.frequency**2 == pytest.approx(w**2 - g**2 / (R**2 * w**2), rel=1e-12)
        closed = S["w"] ** 2 - S["g"] ** 2 / (S["R"] ** 2 * S["w"] ** 2)
        assert sp.simplify(mode.squared - closed) == 0
    bottom = next(e for e in md.equilibria if _theta(e) == 0)
    assert bottom.stability == "unstable"  # w^2 = 36 > g/R = 19.6
    assert bottom.modes[0].growth ** 2 == pytest.approx(w**2 - g / R, rel=1e-12)
    # riding the turning hoop at those angles is a motion of the file's equations
    for e in md.equilibria:
        for t in (0.0, 0.37, 1.1):
            assert steady_accelerations_agree(md.system, e, t) <= 1e-10 * g, (e.at, t)
    # spun slowly the bottom is stable (Omega^2 = g/R - w^2) and the side points do not exist
    slow = lamech.modes(with_values(system, parameters={"w": 3.0}))
    assert [e.exists for e in slow.equilibria if e.condition] == [False, False]
    bottom = next(e for e in slow.equilibria if e.exists and _theta(e) == 0)
    assert bottom.stability == "stable"
    assert bottom.modes[0].frequency ** 2 == pytest.approx(g / R - 9.0, rel=1e-12)


def test_angles_gives_the_chart_in_which_the_spun_hoop_is_autonomous(tmp_path, capsys):
    """The solve's note suggests --angles; it was refused ("does not satisfy constraint
    `plane` identically"): the turning plane is now solved for the sphere's azimuth."""
    path = tmp_path / "hoop.toml"
    path.write_text(HOOP)
    assert main(["modes", "--angles", str(path)]) == 0
    out = capsys.readouterr().out
    assert "independent coordinates: thetahoop" in out
    assert "thetahoop = acos(g/(R*w^2))" in out
    assert main(["solve", "--angles", str(path)]) == 0
    assert "x = R*sin(thetahoop)*cos(t*w)" in capsys.readouterr().out


def test_a_problem_no_chart_makes_autonomous_is_refused_with_what_to_do():
    """A string paid out and hauled in: its circle's angle satisfies the constraint but
    the equations keep t (the radius moves): nothing rests, and the reason says how to
    ask for steady motions."""
    md = lamech.modes(lamech.loads(BREATHING, "breathing.toml"))
    assert md.equilibria == ()
    assert "depend on t explicitly" in md.reason and "[parametrisation]" in md.reason


def test_simulate_mode_releases_the_bead_on_the_turning_hoop(tmp_path, capsys):
    """`simulate --mode` on the Cartesian hoop: released 0.05 rad from the relative
    equilibrium in the hoop's angle (x, y, z and their velocities from the chart, the
    bead carried round by the hoop), after the four periods of Omega it runs it is back
    at that angle: z = -R cos(theta) (and the chart's angle reached `simulate`, which
    knew only x, y, z, as file coordinates)."""
    path = tmp_path / "hoop.toml"
    path.write_text(HOOP)
    assert main(["simulate", str(path), "--mode", "1"]) == 0
    out = capsys.readouterr().out
    theta = -math.acos(9.81 / (0.5 * 36.0)) + 0.05
    final = re.search(r"final state: x = (\S+), y = (\S+), z = (\S+),", out)
    assert final is not None, out
    x, y, z = (float(final.group(i)) for i in (1, 2, 3))
    assert z == pytest.approx(-0.5 * math.cos(theta), abs=1e-4)  # (amplitude: 1e-5 off)
    assert math.hypot(x, y) == pytest.approx(0.5 * abs(math.sin(theta)), abs=1e-4)


def test_a_bead_on_a_turning_wire_rests_at_the_axis_and_runs_away_at_its_rate():
    """A bead on a straight wire turned at W in a horizontal plane, in x, y with the
    wire px sin(Wt) - py cos(Wt) = 0: in the wire's own coordinate r (px = r cos(Wt),
    py = r sin(Wt), which satisfies the constraint identically) r'' = W^2 r, so the
    relative equilibrium is r = 0, unstable with rate W (it refused: "depends on t
    explicitly"). The KKT solve at the axis at rest gives q'' = 0 at any t."""
    from lamech.symbolic._derive import kkt_numeric

    system = lamech.load(Path(__file__).parent / "problems" / "rotating_wire.toml")
    W = next(p.numeric for p in system.parameters if p.name == "W")
    md = lamech.modes(system)
    [e] = [e for e in md.equilibria if e.exists]
    assert e.values["px"] == 0 and e.values["py"] == 0 and e.stability == "unstable"
    [mode] = e.modes
    assert mode.growth**2 == pytest.approx(W**2, rel=1e-10)
    dyn = lamech.dynamics(system)
    for t in (0.0, 0.37, 1.9):
        state = {**system.parameter_values, system.t: t}
        state.update({q: 0.0 for q in system.q})
        state.update({v: 0.0 for v in system.qd})
        qdd, _ = kkt_numeric(dyn, state)
        assert np.abs(np.asarray(qdd, dtype=float)).max() < 1e-12
