"""Results in the coordinates a physicist picks ([parametrisation], --angles), and closed
forms delivered at any size: checked against Newton's law on each bob, the textbook
tensions, and the numeric KKT solution."""

from __future__ import annotations

import json
import math
import random

import pytest
import sympy as sp

import lamech
from lamech.cli import main
from lamech.problem import chain_toml
from lamech.symbolic import dynamics, eliminate
from lamech.symbolic._reduce import closed_forms

PROBLEMS = __import__("pathlib").Path(__file__).parent / "problems"

CARTESIAN = """
title = "Double pendulum, Cartesian"
[parameters]
m1 = 1.0
m2 = 0.7
l1 = 1.0
l2 = 0.8
g = 9.81
[coordinates]
x1 = { initial = 0.6, velocity = 0 }
y1 = { initial = -0.8, velocity = 0 }
x2 = { initial = 1.24, velocity = 0 }
y2 = { initial = -1.28, velocity = 0 }
[[constraints]]
name = "rod1"
f = "x1^2 + y1^2 - l1^2"
[[constraints]]
name = "rod2"
f = "(x2 - x1)^2 + (y2 - y1)^2 - l2^2"
[[bodies]]
name = "bob1"
mass = "m1"
position = ["x1", "y1"]
shape = { point = true }
[[bodies]]
name = "bob2"
mass = "m2"
position = ["x2", "y2"]
shape = { point = true }
[gravity]
acceleration = "g"
"""

CHART = """
[parametrisation]
coordinates = ["theta1", "theta2"]
x1 = "l1*sin(theta1)"
y1 = "-l1*cos(theta1)"
x2 = "l1*sin(theta1) + l2*sin(theta2)"
y2 = "-l1*cos(theta1) - l2*cos(theta2)"
"""


@pytest.fixture(scope="module")
def in_angles():
    return lamech.solve(lamech.loads(CARTESIAN + CHART, "dp.toml"))


def test_the_parametrisation_gives_the_double_pendulum_in_its_angles(in_angles):
    sol = in_angles
    assert sol.independent == ["theta1", "theta2"]
    th = sol.system.chart_coordinates
    assert [float(c.initial) for c in th] == pytest.approx(
        [math.atan2(0.6, 0.8), math.atan2(0.64, 0.48)]
    )
    assert set(sol.multipliers) == {"rod1", "rod2"}
    assert not sol.closed.sizes  # short enough to print


def test_the_tensions_are_the_textbook_ones(in_angles):
    """T2 = m1 m2 (g cos th1 cos D + l1 th1'^2 cos D + l2 th2'^2) / (m1 + m2 sin^2 D),
    D = th1 - th2; with f = |r2 - r1|^2 - l2^2 the force on bob 2 is 2 lambda (r2 - r1),
    so lambda_rod2 = -T2 / (2 l2)."""
    S = in_angles.symbols
    m1, m2, l1, l2, g = (S[k] for k in ("m1", "m2", "l1", "l2", "g"))
    t1, t2, w1, w2 = S["theta1"], S["theta2"], S["theta1'"], S["theta2'"]
    D = t1 - t2
    T2 = m1 * m2 * (g * sp.cos(t1) * sp.cos(D) + l1 * w1**2 * sp.cos(D) + l2 * w2**2)
    T2 /= m1 + m2 * sp.sin(D) ** 2
    assert sp.simplify(in_angles.multipliers["rod2"] + T2 / (2 * l2)) == 0


def test_newtons_law_holds_on_each_bob(in_angles):
    """m a = rod forces + weight on both bobs, at random states, with the accelerations
    from the reduced equations and the forces from the multipliers (independent of the
    Lagrangian machinery: only F = m a and the rods' directions)."""
    sol = in_angles
    S = sol.symbols
    t1, t2, w1, w2 = S["theta1"], S["theta2"], S["theta1'"], S["theta2'"]
    a1, a2 = S["theta1''"], S["theta2''"]
    pv = sol.system.parameter_values
    m1, m2, l1, l2, g = (pv[S[k]] for k in ("m1", "m2", "l1", "l2", "g"))
    acc = {k: v for k, v in sol.closed.accelerations.items()}
    rng = random.Random(4)
    for _ in range(5):
        st = {
            t1: rng.uniform(-3, 3),
            t2: rng.uniform(-3, 3),
            w1: rng.uniform(-2, 2),
            w2: rng.uniform(-2, 2),
        }
        env = {**pv, **st}
        dd1, dd2 = (float(acc[a].xreplace(env)) for a in (a1, a2))
        lam1, lam2 = (float(sol.multipliers[k].xreplace(env)) for k in ("rod1", "rod2"))
        th1, th2, v1, v2 = st[t1], st[t2], st[w1], st[w2]
        r1 = (l1 * math.sin(th1), -l1 * math.cos(th1))
        r2 = (r1[0] + l2 * math.sin(th2), r1[1] - l2 * math.cos(th2))
        acc1 = (
            l1 * (math.cos(th1) * dd1 - math.sin(th1) * v1**2),
            l1 * (math.sin(th1) * dd1 + math.cos(th1) * v1**2),
        )
        acc2 = (
            acc1[0] + l2 * (math.cos(th2) * dd2 - math.sin(th2) * v2**2),
            acc1[1] + l2 * (math.sin(th2) * dd2 + math.cos(th2) * v2**2),
        )
        d = (r2[0] - r1[0], r2[1] - r1[1])
        f2 = (2 * lam2 * d[0], 2 * lam2 * d[1] - m2 * g)
        f1 = (2 * lam1 * r1[0] - 2 * lam2 * d[0], 2 * lam1 * r1[1] - 2 * lam2 * d[1] - m1 * g)
        assert m2 * acc2[0] == pytest.approx(f2[0], abs=1e-9)
        assert m2 * acc2[1] == pytest.approx(f2[1], abs=1e-9)
        assert m1 * acc1[0] == pytest.approx(f1[0], abs=1e-9)
        assert m1 * acc1[1] == pytest.approx(f1[1], abs=1e-9)


@pytest.mark.slow
def test_the_circles_angles_are_the_files_parametrisation(in_angles, capsys):
    """lamech solves the Cartesian double pendulum in its rods' angles by itself (the
    chart lamech.model.circle_chart proposes), the file's [parametrisation] of them."""
    plain = lamech.solve(lamech.loads(CARTESIAN, "dp.toml"))
    assert plain.independent == ["theta1", "theta2"]
    assert any(
        "results in the angle of each circle" in n and "x2 = l1*sin(theta1) + l2*sin(theta2)" in n
        for n in plain.notes
    )
    for k in ("rod1", "rod2"):
        assert sp.simplify(plain.multipliers[k] - in_angles.multipliers[k]) == 0


@pytest.mark.slow
def test_kept_cartesian_coordinates_give_rational_tensions(in_angles):
    """keep = true on every coordinate: no square roots, and the same tension as the
    angle form at the same state."""
    text = CARTESIAN.replace("velocity = 0 }", "velocity = 0, keep = true }")
    sol = lamech.solve(lamech.loads(text, "dpk.toml"))
    S = sol.symbols
    lam = sol.multipliers["rod2"]
    assert not any(not p.exp.is_Integer for p in lam.atoms(sp.Pow))
    pv = sol.system.parameter_values
    l1, l2 = pv[S["l1"]], pv[S["l2"]]
    th1, th2, v1, v2 = 0.4, -0.9, 0.7, -1.1
    x1, y1 = l1 * math.sin(th1), -l1 * math.cos(th1)
    x2, y2 = x1 + l2 * math.sin(th2), y1 - l2 * math.cos(th2)
    vx1, vy1 = l1 * math.cos(th1) * v1, l1 * math.sin(th1) * v1
    vx2, vy2 = vx1 + l2 * math.cos(th2) * v2, vy1 + l2 * math.sin(th2) * v2
    cart = {
        S["x1"]: x1,
        S["y1"]: y1,
        S["x2"]: x2,
        S["y2"]: y2,
        S["x1'"]: vx1,
        S["y1'"]: vy1,
        S["x2'"]: vx2,
        S["y2'"]: vy2,
        **pv,
    }
    A = in_angles.symbols
    ang = {A["theta1"]: th1, A["theta2"]: th2, A["theta1'"]: v1, A["theta2'"]: v2, **pv}
    for k in ("rod1", "rod2"):
        assert float(sol.multipliers[k].xreplace(cart)) == pytest.approx(
            float(in_angles.multipliers[k].xreplace(ang)), rel=1e-10
        )


@pytest.mark.parametrize(
    "chart, message",
    [
        (
            CHART.replace('y2 = "-l1*cos(theta1) - l2*cos(theta2)"', 'y2 = "-l1*cos(theta1)"'),
            "does not satisfy constraint `rod2` identically",
        ),
        (
            CHART.replace('x1 = "l1*sin(theta1)"', 'z1 = "l1*sin(theta1)"'),
            "`z1` is not a coordinate",
        ),
        (
            CHART.replace('"theta1", "theta2"', '"theta1", "g"'),
            "`g` is already a parameter or a coordinate",
        ),
        (CHART.replace("theta2)", "phi)"), "unknown name `phi`"),
        (CHART.replace('coordinates = ["theta1", "theta2"]', ""), "list the new coordinates"),
        (
            '[parametrisation]\ncoordinates = ["theta1"]\nx1 = "l1*tanh(theta1)"\n'
            'y1 = "l1*sqrt(1 - tanh(theta1)^2)"\n',
            "not reached by the parametrisation",
        ),
    ],
)
def test_a_wrong_parametrisation_is_refused_with_the_reason(chart, message):
    with pytest.raises(lamech.ProblemFileError) as err:
        lamech.loads(CARTESIAN + chart, "dp.toml")
    assert message in str(err.value)
    assert "dp.toml:" in str(err.value)


@pytest.mark.slow
def test_long_closed_forms_are_delivered_and_summarised(capsys):
    """The four-bar linkage's multipliers are long: the API and --json give them whole
    (equal to the numeric KKT solution at the initial state), the text summarises."""
    system = lamech.load("four_bar")
    sol = lamech.solve(system)
    assert set(sol.multipliers) == {c.name for c in system.constraints}
    env = {**system.parameter_values, system.t: 0}
    env.update(
        {
            s: float(sp.sympify(v).xreplace(system.parameter_values))
            for s, v in system.initial_state.items()
        }
    )
    for k, lam in sol.multipliers.items():
        assert float(lam.xreplace(env)) == pytest.approx(sol.initial_multipliers[k], rel=1e-9)
    assert main(["solve", "four_bar", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert set(data["multipliers"]) == set(sol.multipliers)
    assert main(["solve", "four_bar"]) == 0
    text = capsys.readouterr().out
    if sol.closed.sizes:
        assert "operations" in text and "--json" in text


@pytest.mark.slow
def test_the_symbolic_solve_is_bounded_by_counted_work():
    """The elimination of a large system (a chain of eight links in Cartesian
    coordinates: 24 unknowns) past the bounds of the normal forms stops and says so,
    the same on every machine (no clock)."""
    system = lamech.loads(chain_toml(8))
    forms = closed_forms(dynamics(system), eliminate(system))
    assert forms.skipped and "24 unknowns" in forms.skipped
    again = closed_forms(dynamics(system), eliminate(system))
    assert again.skipped == forms.skipped


@pytest.mark.slow
def test_a_partial_parametrisation_keeps_the_other_constraint():
    """Only the first rod in an angle: x2, y2 stay, the second rod stays a constraint,
    and the multipliers agree with the full chart's at the same state."""
    chart = (
        '[parametrisation]\ncoordinates = ["theta1"]\nx1 = "l1*sin(theta1)"\n'
        'y1 = "-l1*cos(theta1)"\n'
    )
    sol = lamech.solve(lamech.loads(CARTESIAN + chart, "dp.toml"))
    assert sol.independent[0] == "theta1" and "theta1" in sol.independent
    assert sol.reduction.eliminated_constraints[:1] == ("rod1",)
    env = {**sol.system.parameter_values, sol.system.t: 0}
    env.update(
        {
            k: float(sp.sympify(v).xreplace(sol.system.parameter_values))
            for k, v in sol.system.initial_state.items()
        }
    )
    for k, lam in sol.multipliers.items():
        assert float(lam.xreplace(env)) == pytest.approx(sol.initial_multipliers[k], rel=1e-9)


@pytest.mark.slow
def test_the_bundled_double_pendulum_has_the_textbook_equation_of_motion():
    """theta1'' as on Wikipedia's "Double pendulum" page (the file's comment), at random
    states, and T1 = -2 l1 lambda_rod1 as the comment says."""
    sol = lamech.solve(lamech.load("double_pendulum"))
    S = sol.symbols
    m1, m2, l1, l2, g = (S[k] for k in ("m1", "m2", "l1", "l2", "g"))
    t1, t2, w1, w2 = S["theta1"], S["theta2"], S["theta1'"], S["theta2'"]
    D = t1 - t2
    textbook = -(
        g * (2 * m1 + m2) * sp.sin(t1)
        + m2 * g * sp.sin(t1 - 2 * t2)
        + 2 * m2 * sp.sin(D) * (l2 * w2**2 + l1 * w1**2 * sp.cos(D))
    )
    textbook /= l1 * (2 * m1 + m2 - m2 * sp.cos(2 * D))
    T1 = m1 * ((m1 + m2) * (g * sp.cos(t1) + l1 * w1**2) + m2 * l2 * w2**2 * sp.cos(D))
    T1 /= m1 + m2 * sp.sin(D) ** 2
    rng = random.Random(8)
    for _ in range(5):
        env = {
            m1: rng.uniform(0.5, 2),
            m2: rng.uniform(0.5, 2),
            l1: rng.uniform(0.5, 2),
            l2: rng.uniform(0.5, 2),
            g: 9.81,
            t1: rng.uniform(-3, 3),
            t2: rng.uniform(-3, 3),
            w1: rng.uniform(-2, 2),
            w2: rng.uniform(-2, 2),
        }
        ours = sol.closed.accelerations[S["theta1''"]]
        assert float(ours.xreplace(env)) == pytest.approx(float(textbook.xreplace(env)))
        assert float((-2 * l1 * sol.multipliers["rod1"]).xreplace(env)) == pytest.approx(
            float(T1.xreplace(env))
        )


def test_a_circles_start_on_its_far_side_is_read_as_the_angle_it_is():
    """The trammel with y measured down starts at X = d sin(2/5), Y = d cos(2/5); in the
    circle's angle (X = d sin(theta), Y = -d cos(theta)) that is theta0 = pi - 2/5, and the
    shell reads cos(2/5) (it printed thetarod = pi - atan(sin(2/5)/cos(2/5)))."""
    sol = lamech.solve(lamech.load(PROBLEMS / "trammel_ydown.toml"))
    (theta,) = sol.system.chart_coordinates
    d = sol.system.parameter_values[sol.symbols["d"]]
    X0, Y0 = d * math.sin(0.4), d * math.cos(0.4)  # the file's start
    th0 = float(theta.initial)
    assert (d * math.sin(th0), -d * math.cos(th0)) == pytest.approx((X0, Y0), abs=1e-12)
    assert sp.simplify(theta.initial - (sp.pi - sp.Rational(2, 5))) == 0
    assert not theta.initial.has(sp.atan, sp.atan2)
    assert "atan" not in str(sol)


def test_a_circles_start_at_minus_pi_is_kept_exact():
    """The string pendulum with y down starts at the bottom, x = 0, y = L: in the circle's
    angle (x = L sin(theta), y = -L cos(theta)) theta0 = +-pi, read exactly as the numeric
    start's side of the turn (it printed -3.1415926535897931), and the shell and the
    lift-off carry no 17-digit number."""
    sol = lamech.solve(lamech.load(PROBLEMS / "string_pendulum_ydown.toml"))
    (theta,) = sol.system.chart_coordinates
    L = sol.system.parameter_values[sol.symbols["L"]]
    th0 = float(theta.initial)
    assert (L * math.sin(th0), -L * math.cos(th0)) == pytest.approx((0.0, L), abs=1e-12)
    assert theta.initial in (sp.pi, -sp.pi)
    assert not any(len(d) >= 13 for d in __import__("re").findall(r"\d+", str(sol))), str(sol)


def test_a_turning_charts_start_is_kept_exact():
    """The hoop spun at Om in its angle (px = a sin(theta) cos(Om t), py = a sin(theta)
    sin(Om t), pz = -a cos(theta), as --angles gives it): the file starts at theta = 0.7
    at t = 0, so theta0 = 7/10 exactly and theta0' = 0 (the start's py' = Om a sin(0.7)
    is the turning), and the Jacobi shell carries no 17-digit integers."""
    from lamech.model import circle_chart
    from lamech.symbolic._steady import complete_chart

    system = lamech.load(PROBLEMS / "hoop_spin_zup.toml")
    sol = lamech.solve(complete_chart(system, circle_chart(system)))
    (theta,) = sol.system.chart_coordinates
    assert theta.initial == sp.Rational(7, 10) and theta.initial_velocity == 0
    assert not any(len(d) >= 13 for d in __import__("re").findall(r"\d+", str(sol))), str(sol)


def test_a_spheres_start_is_kept_exact_and_says_where_it_lets_go():
    """The particle released at rest at a0 from the top of the sphere X^2 + Y^2 + Z^2 =
    Rs^2 (z up, bilateral), in the sphere's angles (Z = -Rs cos(theta): theta0 = pi - a0
    exactly, phi0 = 0): the shell then says the textbook's lift-off, the multiplier 0 at
    cos(theta_top) = 2 cos(a0)/3, i.e. cos(theta) = -2 cos(a0)/3 (it printed 17-digit
    integers: 98006657784124139/150000000000000000)."""
    from lamech.model import circle_chart, with_chart

    system = lamech.load(PROBLEMS / "sphere_outside.toml")
    sol = lamech.solve(with_chart(system, circle_chart(system)))
    theta, phi = sol.system.chart_coordinates
    a0 = sol.symbols["a0"]
    assert sp.simplify(theta.initial - (sp.pi - a0)) == 0 and phi.initial == 0
    [note] = [n for n in sol.notes if "changes sign" in n]
    assert "cos(thetasurface) = -2*cos(a0)/3" in note
    a0v = sol.system.parameter_values[a0]
    found = float(__import__("re").search(r"thetasurface = ([0-9.]+) \(", note).group(1))
    assert math.cos(found) == pytest.approx(-2 * math.cos(a0v) / 3, abs=1e-9)
    assert not any(len(d) >= 13 for d in __import__("re").findall(r"\d+", str(sol))), str(sol)
