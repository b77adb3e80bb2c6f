"""Small oscillations (``lamech modes``): equilibria, stability, frequencies and mode
shapes, each checked against its textbook closed form or against the simulated motion."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import sympy as sp

import lamech
from lamech.cli import main
from lamech.model import with_values
from test_trust import CARTESIAN_PENDULUM as CARTESIAN

DOUBLE = """
title = "Double pendulum"
[parameters]
m = 1.0
g = 9.81
l = 1.0
[coordinates]
th1 = { initial = 0.1, velocity = 0 }
th2 = { initial = 0.1, velocity = 0 }
[[bodies]]
name = "bob1"
mass = "m"
position = ["l*sin(th1)", "-l*cos(th1)"]
[[bodies]]
name = "bob2"
mass = "m"
position = ["l*sin(th1) + l*sin(th2)", "-l*cos(th1) - l*cos(th2)"]
[gravity]
acceleration = "g"
"""



def _values(system):
    return {p.name: p.numeric for p in system.parameters}


def _by_position(md, **at):
    """The equilibrium whose coordinates have these values."""
    for e in md.equilibria:
        if all(abs(e.values[k] - v) < 1e-9 for k, v in at.items()):
            return e
    raise AssertionError(f"no equilibrium at {at}: {[e.values for e in md.equilibria]}")


def test_pendulum_hangs_stably_with_omega_squared_g_over_l():
    md = lamech.modes(lamech.load("pendulum"))
    S = lamech.load("pendulum").parameters
    g, l = (next(p.symbol for p in S if p.name == n) for n in ("g", "l"))
    down = _by_position(md, theta=0.0)
    assert down.stability == "stable" and down.holds
    (mode,) = down.modes
    assert sp.simplify(mode.squared - g / l) == 0
    p = _values(lamech.load("pendulum"))
    assert mode.frequency == pytest.approx(math.sqrt(p["g"] / p["l"]), rel=1e-12)
    assert down.multipliers["string"] == pytest.approx(p["m"] * p["g"], rel=1e-12)
    # upside down the string would have to push: no equilibrium of the real pendulum
    up = _by_position(md, theta=math.pi)
    assert not up.holds and "`string` cannot hold it" in up.note


def test_the_lectures_cylinder_on_top_is_unstable_with_the_textbook_growth_rate():
    system = lamech.load("cylinder")
    md = lamech.modes(system)
    p = _values(system)
    top = _by_position(md, theta1=0.0)
    assert top.stability == "unstable" and top.holds
    (mode,) = top.modes
    assert mode.growth == pytest.approx(math.sqrt(2 * p["g"] / (3 * (p["R1"] + p["R2"]))),
                                        rel=1e-12)
    g, R1, R2 = (next(q.symbol for q in system.parameters if q.name == n)
                 for n in ("g", "R1", "R2"))
    assert sp.simplify(mode.squared + 2 * g / (3 * (R1 + R2))) == 0
    # rolling ties the wheel's turn to the centre's: (R1 + R2) theta1 = R2 theta2
    assert mode.shape["theta1"] / mode.shape["theta2"] == pytest.approx(p["R2"] / (p["R1"] + p["R2"]))
    assert mode.shape["r"] == 0
    assert not _by_position(md, theta1=math.pi).holds   # under the cylinder: it falls off


def test_the_spun_bead_rests_off_the_axis_only_when_the_hoop_spins_fast_enough():
    system = lamech.load("hoop_bead")
    p = _values(system)
    md = lamech.modes(system)
    theta0 = math.acos(p["g"] / (p["omega"] ** 2 * p["R"]))
    side = _by_position(md, theta=theta0)
    assert side.condition == "g/(R*omega^2) <= 1" and side.stability == "stable"
    (mode,) = side.modes
    assert mode.frequency ** 2 == pytest.approx(p["omega"] ** 2 * math.sin(theta0) ** 2, rel=1e-10)
    S = {q.name: q.symbol for q in system.parameters}
    th0 = sp.acos(S["g"] / (S["R"] * S["omega"] ** 2))
    assert sp.simplify(mode.squared - S["omega"] ** 2 * sp.sin(th0) ** 2) == 0
    assert _by_position(md, theta=0.0).stability == "unstable"
    # spun slowly (omega^2 < g/R) the bottom is stable and the side points do not exist
    slow = lamech.modes(with_values(system, parameters={"omega": 3.0}))
    assert [e.exists for e in slow.equilibria if e.condition] == [False, False]
    bottom = _by_position(slow, theta=0.0)
    assert bottom.stability == "stable"
    assert bottom.modes[0].frequency ** 2 == pytest.approx(p["g"] / p["R"] - 9.0, rel=1e-12)


def test_double_pendulum_frequencies_are_two_plus_minus_root_two_g_over_l():
    system = lamech.loads(DOUBLE, "double.toml")
    md = lamech.modes(system)
    assert len(md.equilibria) == 4                      # each bob up or down
    down = _by_position(md, th1=0.0, th2=0.0)
    assert down.stability == "stable"
    g, l = (next(q.symbol for q in system.parameters if q.name == n) for n in ("g", "l"))
    squares = sorted((m.squared for m in down.modes), key=lambda e: float(e.subs({g: 1, l: 1})))
    assert sp.simplify(squares[0] - (2 - sp.sqrt(2)) * g / l) == 0
    assert sp.simplify(squares[1] - (2 + sp.sqrt(2)) * g / l) == 0
    slow, fast = sorted(down.modes, key=lambda m: m.frequency)
    assert slow.shape["th2"] / slow.shape["th1"] == pytest.approx(math.sqrt(2))
    assert fast.shape["th2"] / fast.shape["th1"] == pytest.approx(-math.sqrt(2))
    for e in md.equilibria:
        if e is not down:
            assert e.stability == "unstable"


def test_the_simulated_motion_oscillates_at_the_predicted_frequencies():
    """Independent truth: released along each mode with a small amplitude, the simulated
    double pendulum swings at that mode's frequency (zero crossings of th1)."""
    system = lamech.loads(DOUBLE, "double.toml")
    down = _by_position(lamech.modes(system), th1=0.0, th2=0.0)
    for mode in down.modes:
        a = 1e-3
        start = with_values(system, initial={k: a * v for k, v in mode.shape.items()})
        period = 2 * math.pi / mode.frequency
        traj = lamech.simulate(start, 6 * period, samples=6001, rtol=1e-11, atol=1e-13)
        th1 = traj.coordinate("th1")
        s = np.sign(th1)
        idx = np.nonzero(s[:-1] * s[1:] < 0)[0]
        t = traj.t
        crossings = [t[i] - th1[i] * (t[i + 1] - t[i]) / (th1[i + 1] - th1[i]) for i in idx]
        measured = 2 * float(np.mean(np.diff(crossings)))
        assert measured == pytest.approx(period, rel=1e-5)


def test_the_cartesian_pendulum_is_linearised_in_x_about_the_hanging_position():
    """y = -sqrt(l^2 - x^2) is singular nowhere near the bottom, but y as the coordinate
    would be: the tangent space of the kept constraint gives the regular direction x."""
    md = lamech.modes(lamech.loads(CARTESIAN, "cart.toml"))
    down = _by_position(md, x1=0.0, y1=-1.0)
    (mode,) = down.modes
    assert down.stability == "stable"
    assert mode.frequency == pytest.approx(math.sqrt(9.81), rel=1e-10)
    assert mode.shape == {"x1": 1.0, "y1": 0.0}
    assert down.multipliers["rod"] == pytest.approx(9.81, rel=1e-12)
    assert _by_position(md, x1=0.0, y1=1.0).stability == "unstable"


def test_cli_modes_text_json_and_bad_at(capsys):
    assert main(["modes", "pendulum", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    freqs = [m["frequency"] for e in data["equilibria"] for m in e["modes"] if m["frequency"]]
    assert freqs == [pytest.approx(math.sqrt(9.81))]
    assert main(["modes", "pendulum", "--at", "theta=pi/2"]) == 0
    out = capsys.readouterr().out
    assert "not an equilibrium: at rest there the accelerations are theta'' = -9.81" in out
    assert main(["modes", "pendulum", "--at", "phi=1"]) == 2
    err = capsys.readouterr().err
    assert "--at phi: not an independent coordinate; these are: theta" in err
