"""Inputs that switch (issue 13, item 4): step, min, max, clip and piecewise in the
expression grammar, located by the simulator as events (``switch``), never stepped
over. Each against a closed-form motion or the switching condition itself."""

from __future__ import annotations

import math

import numpy as np
import pytest

import lamech
from lamech.numeric import compiled_available

PUSHED = """
title = "oscillator pushed from t = 1"
[parameters]
m = 1
k = 4
F = 2
[coordinates]
x = { initial = 0, velocity = 0 }
[lagrangian]
T = "m/2*x'^2"
V = "k/2*x^2"
[forces]
x = "F*step(t - 1)"
"""

BUMPER = """
title = "a cart against a one-sided spring"
[parameters]
m = 2
k = 50
d = 1
v0 = 0.8
[coordinates]
x = { initial = 0, velocity = "v0" }
[lagrangian]
T = "m/2*x'^2"
V = "k/2*max(0, x - d)^2"
"""

SPUN_UP = """
title = "a rotor spun up by a torque until t = 2"
[parameters]
I = 0.5
tau = 15
[coordinates]
phi = { initial = 0, velocity = 0 }
[lagrangian]
T = "I/2*phi'^2"
V = "0"
[forces]
phi = "piecewise((tau, t < 2), 0)"
"""

LIFTED = """
title = "a block on the floor, pulled up by 2 m g from t = 1"
[parameters]
m = 1
g = 9.81
[coordinates]
y = { initial = 0, velocity = 0 }
[lagrangian]
T = "m/2*y'^2"
V = "m*g*y"
[[constraints]]
name = "floor"
f = "y"
unilateral = true
[forces]
y = "2*m*g*step(t - 1)"
"""

SATURATED = """
title = "a cart held at x = 0 by a saturated controller"
[parameters]
m = 1
K = 10
umax = 2
[coordinates]
x = { initial = 1, velocity = 0 }
[lagrangian]
T = "m/2*x'^2"
V = "0"
[forces]
x = "clip(-K*x, -umax, umax)"
"""

TIGHT = {"rtol": 1e-11, "atol": 1e-12}


def _switches(traj):
    return [e for e in traj.events if e.kind == "switch"]


def test_a_step_force_is_located_and_the_motion_is_the_closed_form():
    system = lamech.loads(PUSHED)
    traj = lamech.simulate(system, 4.0, samples=401, **TIGHT)
    assert traj.status == "ok"
    (sw,) = _switches(traj)
    assert sw.t == pytest.approx(1.0, abs=1e-14)
    assert sw.constraint == "step(t - 1)"
    # x = F/k (1 - cos(w (t - 1))) after the push, 0 before; w = sqrt(k/m) = 2
    t = traj.t
    exact = np.where(t >= 1, 0.5 * (1 - np.cos(2 * (t - 1))), 0.0)
    assert np.max(np.abs(traj.q[:, 0] - exact)) < 1e-9


def test_a_state_switch_bounces_the_cart_off_the_spring_on_time():
    system = lamech.loads(BUMPER)
    traj = lamech.simulate(system, 3.0, **TIGHT)
    assert traj.status == "ok"
    on, off = _switches(traj)
    # max(0, x - d) switches where x = d: at d/v0 on the way in, a half period later out
    t1 = 1 / 0.8
    assert on.t == pytest.approx(t1, abs=1e-10)
    assert off.t == pytest.approx(t1 + math.pi / math.sqrt(50 / 2), abs=1e-9)
    assert on.coordinates["x"] == pytest.approx(1, abs=1e-10)
    assert off.coordinates["x'"] == pytest.approx(-0.8, abs=1e-9)  # elastic: v0 back
    assert traj.qd[-1, 0] == pytest.approx(-0.8, abs=1e-9)
    # the spring's energy is conservative: T + V holds across both switches
    assert traj.energy_error < 1e-9


def test_a_piecewise_torque_spins_the_rotor_up_then_lets_it_coast():
    traj = lamech.simulate(lamech.loads(SPUN_UP), 3.0, samples=301, **TIGHT)
    (sw,) = _switches(traj)
    assert sw.t == pytest.approx(2.0, abs=1e-13)
    alpha = 15 / 0.5
    t = traj.t
    exact = np.where(t < 2, alpha * t**2 / 2, alpha * 2 * (t - 1))  # 2 alpha + 2 alpha (t - 2)
    assert np.max(np.abs(traj.q[:, 0] - exact)) < 1e-8
    assert traj.qd[-1, 0] == pytest.approx(alpha * 2, rel=1e-12)


def test_a_force_that_switches_on_lifts_the_block_off_at_that_moment():
    traj = lamech.simulate(lamech.loads(LIFTED), 2.0, samples=201, **TIGHT)
    kinds = [(e.kind, e.constraint) for e in traj.events]
    assert kinds[:2] == [("switch", "step(t - 1)"), ("lift-off", "floor")]
    assert traj.events[1].t == pytest.approx(1.0, abs=1e-13)
    # afterwards (2 m g - m g)/m = g upward: y = g (t - 1)^2 / 2
    assert traj.q[-1, 0] == pytest.approx(9.81 / 2, rel=1e-9)
    before = traj.t < 1
    assert np.allclose(traj.lambdas[before, 0], 9.81)  # the floor holds the block up


def test_a_saturated_controller_switches_where_the_command_reaches_its_limit():
    traj = lamech.simulate(lamech.loads(SATURATED), 5.0, **TIGHT)
    assert traj.status == "ok"
    switches = _switches(traj)
    assert switches, "the controller saturates at x = 1 (|K x| = 10 > 2)"
    for e in switches:
        x = e.coordinates["x"]
        assert abs(10 * x) == pytest.approx(2, abs=1e-9), (e.t, e.constraint, x)
    # the first: full push -umax from rest at x = 1 until K x = umax, x = 1 - t^2 umax/2
    first = switches[0]
    assert first.t == pytest.approx(math.sqrt(2 * (1 - 0.2) / 2), abs=1e-9)


def test_solve_shows_the_input_and_does_not_call_the_pushed_energy_conserved():
    sol = lamech.solve(lamech.loads(PUSHED))
    text = lamech.to_text(sol)
    assert "step(t - 1)" in text
    assert sol.integrals.energy is None
    assert r"\operatorname{step}\left(t - 1\right)" in lamech.to_latex(sol)


def test_the_bumpers_energy_is_conserved_symbolically():
    sol = lamech.solve(lamech.loads(BUMPER))
    assert sol.integrals.energy is not None
    assert "max(0, -d + x)" in lamech.to_text(sol)


@pytest.mark.slow
@pytest.mark.shared_cache
@pytest.mark.skipif(not compiled_available(), reason="no C compiler or engine")
def test_the_compiled_path_gives_the_same_switches():
    system = lamech.loads(BUMPER)
    a = lamech.simulate(system, 3.0, **TIGHT)
    b = lamech.simulate(system, 3.0, jit=True, **TIGHT)
    assert [e.t for e in _switches(a)] == pytest.approx([e.t for e in _switches(b)], abs=1e-12)
    assert np.max(np.abs(a.q - b.q)) < 1e-10


TABLED = """
title = "a rotor driven by a tabulated torque"
[parameters]
I = 0.5
[coordinates]
phi = { initial = 0, velocity = 0 }
[inputs]
tau = { csv = "torque.csv", column = "tau" }
[lagrangian]
T = "I/2*phi'^2"
V = "0"
[forces]
phi = "tau"
"""


@pytest.fixture
def tabled(tmp_path):
    (tmp_path / "torque.csv").write_text("t,tau,unused\n0,0,9\n1,2,9\n2,2,9\n3,0,9\n")
    path = tmp_path / "rotor.toml"
    path.write_text(TABLED)
    return path


def test_a_tabulated_torque_is_interpolated_and_its_corners_located(tabled):
    system = lamech.load(tabled)
    assert "tau" in lamech.to_text(lamech.solve(system))
    traj = lamech.simulate(system, 4.0, samples=401, **TIGHT)
    assert traj.status == "ok"
    assert _switches(traj) == []  # a table's rows are corners, not events
    # phi'' = tau/I = 2 tau; tau a ramp to 2 over [0, 1], 2 until 2, a ramp to 0 at 3
    t = traj.t
    exact = np.select(
        [t <= 1, t <= 2, t <= 3],
        [
            2 * t**3 / 3,
            2 / 3 + 2 * (t - 1) + 2 * (t - 1) ** 2,
            14 / 3 + 6 * (t - 2) + 2 * (t - 2) ** 2 - 2 * (t - 2) ** 3 / 3,
        ],
        12 + 8 * (t - 3),
    )
    assert np.max(np.abs(traj.q[:, 0] - exact)) < 1e-9
    assert traj.qd[-1, 0] == pytest.approx(8, abs=1e-10)


def test_a_tabulated_input_evaluates_prints_and_pickles(tabled):
    import pickle

    system = lamech.load(tabled)
    (Q,) = system.forces
    assert float(Q.subs(system.t, 0.25)) == 0.5
    assert float(Q.subs(system.t, 7)) == 0.0  # held at the last row
    assert pickle.loads(pickle.dumps(system)).forces == system.forces  # a sweep's workers
    assert lamech.to_latex(lamech.solve(system)).count(r"\operatorname{tau}") >= 1


@pytest.mark.parametrize(
    "table, words",
    [
        ("t,tau\n0,0\n1,2\n1,3\n", ["row 4", "the times must increase"]),
        ("t,tau\n0,0\n", ["two or more rows"]),
        ("t,tau\n0,0\n1,x\n", ["row 3", "not two numbers"]),
        ("t,torque\n0,0\n1,1\n", ["column `tau` is not a column", "torque"]),
    ],
)
def test_a_bad_table_is_refused_with_its_row(tmp_path, table, words):
    (tmp_path / "torque.csv").write_text(table)
    path = tmp_path / "rotor.toml"
    path.write_text(TABLED)
    with pytest.raises(lamech.ProblemFileError) as err:
        lamech.load(path)
    text = str(err.value)
    assert "inputs.tau" in text and ":8:" in text  # the line of the input
    assert "unknown name" not in text  # its uses are no further error
    for w in words:
        assert w in text, text


def test_a_table_differentiated_in_time_is_refused(tmp_path):
    (tmp_path / "torque.csv").write_text("t,tau\n0,1\n1,2\n")
    path = tmp_path / "rotor.toml"
    path.write_text(TABLED.replace('T = "I/2*phi\'^2"', 'T = "tau*I/2*phi\'^2"'))
    with pytest.raises(lamech.ProblemFileError) as err:
        lamech.load(path)
    assert "`tau` is a table" in str(err.value)
