"""Simulation against independent truths: closed forms, invariants, convergence order."""

from __future__ import annotations

import csv
import io
import json
import math
import re
from importlib import resources
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from scipy.optimize import brentq
from scipy.special import ellipk

import lamech
from lamech.numeric import (
    Event,
    EventKind,
    FrictionState,
    SimulationError,
    Status,
    compile_system,
    compiled_available,
    consistent_initial,
    simulate,
)

G = 9.81
HERE = Path(__file__).parent


def _example_text(name: str) -> str:
    return (resources.files("lamech") / "examples" / f"{name}.toml").read_text()


def _pendulum_period(theta0: float, g: float = G, l: float = 1.0) -> float:
    return 4 * math.sqrt(l / g) * ellipk(math.sin(theta0 / 2) ** 2)


@pytest.fixture(scope="module")
def pendulum():
    return compile_system(lamech.load("pendulum"))


def _check_pendulum(tr, theta0=0.5):
    assert tr.status == "ok", tr.message
    assert np.max(tr.residual_position) <= 1e-10
    assert tr.energy_error is not None and tr.energy_error <= 1e-9
    th = tr.coordinate("theta")
    ref = G * (3 * np.cos(th) - 2 * math.cos(theta0))  # m = 1
    rel = np.max(np.abs(tr.multiplier("string") - ref) / np.abs(ref))
    assert rel <= 1e-8, rel
    # the Cartesian tension equals the multiplier (f = l - r, unit radial direction)
    assert np.allclose(tr.forces["string:tension"], tr.multiplier("string"), rtol=1e-12)


@pytest.mark.slow
def test_pendulum_20_periods(pendulum):
    tr = simulate(pendulum, 20 * _pendulum_period(0.5), samples=4001)
    _check_pendulum(tr)
    assert tr.events == []


@pytest.mark.slow
@pytest.mark.shared_cache
def test_pendulum_1000_periods(pendulum):
    tr = simulate(pendulum, 1000 * _pendulum_period(0.5), samples=20001)
    _check_pendulum(tr)
    # back at the release point after a whole number of periods
    assert abs(tr.q[-1, 1] - 0.5) < 1e-7


def _cylinder(mu: str | None) -> lamech.System:
    text = _example_text("cylinder")
    old = 'friction = { mu = 0.3, normal = "contact" }'
    assert old in text
    if mu is None:
        text = text.replace(old + "\n", "")
    else:
        text = text.replace(old, f'friction = {{ mu = {mu}, normal = "contact" }}')
    return lamech.loads(text)


THS = 0.01  # start angle: at rest slightly off the top


@pytest.mark.slow
def test_cylinder_multipliers_match_closed_form():
    system = lamech.load("cylinder")
    sol = lamech.solve(system)
    syms = system.symbols
    args = [syms["theta1"], syms["theta1'"]]
    pv = system.parameter_values
    tr = simulate(system, 2.2, q0={"theta1": THS, "theta2": 3 * THS}, samples=2201)
    assert tr.status == "ok", tr.message
    assert tr.events == []  # rolls the whole time (slips at t = 2.28)
    th, thd = tr.coordinate("theta1"), tr.velocity("theta1")
    for name in ("contact", "rolling"):
        expr = sp.sympify(sol.multipliers[name]).subs(pv)
        assert expr.free_symbols <= set(args)
        f = sp.lambdify(args, expr, "numpy")
        ref = np.broadcast_to(f(th, thd), th.shape)
        err = np.max(np.abs(tr.multiplier(name) - ref)) / (1.0 * G)
        assert err <= 1e-8, (name, err)


def test_cylinder_lift_off_angle():
    tr = simulate(_cylinder(None), 3.0, q0={"theta1": THS, "theta2": 3 * THS}, samples=301)
    assert tr.status == "ok", tr.message
    kinds = [(e.kind, e.constraint) for e in tr.events]
    assert kinds == [("lift-off", "contact")]
    theta = tr.events[0].coordinates["theta1"]
    assert abs(theta - math.acos(4 / 7 * math.cos(THS))) <= 1e-9
    # flies free afterwards: the gap opens, the contact multiplier is NaN
    after = tr.t > tr.events[0].t + 0.05
    assert np.all(tr.coordinate("r")[after] > 1.5)
    assert np.all(np.isnan(tr.multiplier("contact")[after]))


@pytest.mark.parametrize("mu", [0.3, 0.1])
def test_cylinder_slips_where_closed_form_says(mu):
    tr = simulate(
        lamech.load("cylinder"),
        3.0,
        q0={"theta1": THS, "theta2": 3 * THS},
        samples=301,
        params={"mu": mu},
    )
    assert tr.status == "ok", tr.message
    kinds = [(e.kind, e.constraint) for e in tr.events]
    assert kinds[:2] == [("slip", "rolling"), ("lift-off", "contact")]
    ref = brentq(
        lambda th: math.sin(th) - mu * (7 * math.cos(th) - 4 * math.cos(THS)), 0.05, 0.9, xtol=1e-15
    )
    assert abs(tr.events[0].coordinates["theta1"] - ref) <= 1e-9
    # while slipping the friction column holds the kinetic friction -mu N
    k = np.nonzero((tr.t > tr.events[0].t) & (tr.t < tr.events[1].t))[0]
    assert len(k)
    assert np.allclose(tr.multiplier("rolling")[k], -mu * tr.multiplier("contact")[k], rtol=1e-12)


# dropped from q0={"y": h}
BALL = (HERE / "problems" / "ball.toml").read_text(encoding="utf-8")


def test_ball_bounce_heights():
    h, e = 1.0, 0.5
    tr = simulate(lamech.loads(BALL), 2.0, q0={"y": h}, samples=2001)
    assert tr.status == "ok", tr.message
    impacts = [ev for ev in tr.events if ev.kind == "impact"]
    assert len(impacts) >= 8
    t1 = math.sqrt(2 * h / G)
    t_k = t1
    for k, ev in enumerate(impacts[:8], start=1):
        up = ev.coordinates["y'"]  # velocity after the impact
        assert abs(up**2 / (2 * G) - e ** (2 * k) * h) <= 1e-9 * h
        assert abs(ev.t - t_k) <= 1e-9
        assert abs(ev.velocity_before + up / e) <= 1e-9
        t_k += 2 * e**k * t1
    # Zeno: the bounces accumulate at t1 (1 + e)/(1 - e), then it rests on the floor
    assert tr.events[-1].kind == "contact"
    assert abs(tr.events[-1].t - t1 * (1 + e) / (1 - e)) < 1e-4
    rest = tr.t > tr.events[-1].t
    assert np.allclose(tr.multiplier("floor")[rest], G, rtol=1e-12)
    # the sampled apex of the first bounce
    first = (tr.t > impacts[0].t) & (tr.t < impacts[1].t)
    assert abs(tr.coordinate("y")[first].max() - e**2 * h) < 1e-5


def test_disk_on_steep_incline_slips_at_once():
    mu, alpha, R, T = 0.1, 0.5, 0.2, 1.0
    assert math.tan(alpha) > 3 * mu
    text = _example_text("incline_disk").replace("mu = 0.3", f"mu = {mu}")
    tr = simulate(lamech.loads(text), T, samples=101)
    assert tr.status == "ok", tr.message
    assert [(e.kind, e.t) for e in tr.events] == [("slip", 0.0)]
    t = tr.t
    s_ref = 0.5 * G * (math.sin(alpha) - mu * math.cos(alpha)) * t**2
    th_ref = 0.5 * (2 * mu * G * math.cos(alpha) / R) * t**2
    assert np.max(np.abs(tr.coordinate("s") - s_ref)) <= 1e-9
    assert np.max(np.abs(tr.coordinate("theta") - th_ref)) <= 1e-8
    assert np.allclose(tr.multiplier("rolling"), -mu * G * math.cos(alpha), rtol=1e-12)


def test_sliding_disk_sticks_when_it_rolls():
    v0, mu = 2.0, 0.3
    text = _example_text("incline_disk").replace("alpha = 0.5", "alpha = 0.0")
    tr = simulate(lamech.loads(text), 1.0, qd0={"s": v0}, samples=101)
    assert tr.status == "ok", tr.message
    kinds = [e.kind for e in tr.events]
    assert kinds == ["slip", "stick"]
    t_stick = v0 / (3 * mu * G)  # v = v0 - mu g t meets R w = 2 mu g t
    assert abs(tr.events[1].t - t_stick) <= 1e-9
    assert abs(tr.qd[-1, 0] - 2 * v0 / 3) <= 1e-9
    assert np.max(tr.residual) < 1e-9


@pytest.mark.slow
def test_convergence_order(pendulum):
    theta0 = 0.5
    P = _pendulum_period(theta0)
    steps, errs = [], []
    for rtol in (1e-5, 1e-6, 1e-7, 1e-8, 1e-9):
        tr = simulate(pendulum, 10 * P, samples=2, rtol=rtol, atol=rtol * 1e-2)
        steps.append(tr.steps)
        errs.append(abs(tr.q[-1, 1] - theta0) + 0.3 * abs(tr.qd[-1, 1]))
    slope_steps = np.polyfit(np.log(steps), np.log(errs), 1)[0]
    slope_tol = np.polyfit(np.log([1e-5, 1e-6, 1e-7, 1e-8, 1e-9]), np.log(errs), 1)[0]
    assert -10 < slope_steps < -6.5, slope_steps  # DOP853: order 8
    assert 0.8 < slope_tol < 1.3, slope_tol  # error proportional to tolerance
    assert errs[-1] < errs[0] * 1e-3


def test_initial_state_off_the_constraints(pendulum):
    with pytest.raises(SimulationError, match="violates"):
        simulate(pendulum, 1.0, q0={"r": 1.001})
    tr = simulate(pendulum, 1.0, q0={"r": 1.001}, qd0={"r": 0.2}, project_initial=True, samples=11)
    assert tr.status == "ok"
    assert abs(tr.q[0, 0] - 1.0) < 1e-14 and abs(tr.qd[0, 0]) < 1e-14
    assert tr.notes and "projected" in tr.notes[0]


def test_bad_options(pendulum):
    for kwargs in (
        {"t_end": -1.0},
        {"t_end": float("nan")},
        {"t_end": 1.0, "rtol": 0.0},
        {"t_end": 1.0, "rtol": -1e-8},
        {"t_end": 1.0, "atol": 0.0},
        {"t_end": 1.0, "samples": 1},
        {"t_end": 1.0, "dt": -0.1},
        {"t_end": 1.0, "samples": 10, "dt": 0.1},
    ):
        with pytest.raises(SimulationError):
            simulate(pendulum, **kwargs)


def test_csv_and_summary(pendulum):
    tr = simulate(pendulum, 1.0, samples=2)
    assert list(tr.t) == [0.0, 1.0]
    text = lamech.present.trajectory_csv(tr)
    rows = list(csv.reader(io.StringIO(text)))
    assert rows[0] == [
        "t",
        "r",
        "theta",
        "r'",
        "theta'",
        "lambda:string",
        "force:string:tension",
        "energy",
        "residual",
    ]
    assert len(rows) == 3
    assert float(rows[2][2]) == tr.q[-1, 1]  # 17 significant digits round-trip
    s = lamech.to_json(tr)
    for key in (
        "events",
        "final",
        "max_residual",
        "max_residual_position",
        "max_residual_velocity",
        "energy_error",
        "status",
        "message",
    ):
        assert key in s
    assert set(s["final"]) == {"r", "theta", "r'", "theta'"}
    assert s["status"] == "ok"
    tr2 = simulate(pendulum, 1.0, dt=0.25)
    assert np.allclose(tr2.t, [0, 0.25, 0.5, 0.75, 1.0])


def test_to_csv_and_to_json_are_the_trajectorys_formats_and_its_old_summary_warns(
    pendulum, tmp_path
):
    """lamech.to_csv / lamech.to_json are the one home of a run's CSV and JSON (the
    present layer); Trajectory.summary() still gives the JSON for a release, warning."""
    tr = simulate(pendulum, 1.0, samples=3)
    text = lamech.to_csv(tr)
    assert text == lamech.present.trajectory_csv(tr)
    rows = list(csv.reader(io.StringIO(text)))
    assert [float(x) for x in next(zip(*rows[1:]))] == tr.t.tolist()  # t, read back exactly
    assert lamech.to_csv(tr, tmp_path / "run.csv") is None
    assert (tmp_path / "run.csv").read_text(encoding="utf-8") == text
    with pytest.warns(DeprecationWarning, match=r"lamech.to_json\(trajectory\) gives the same"):
        old = tr.summary()
    assert old == lamech.to_json(tr) and json.loads(json.dumps(old)) == old
    with pytest.raises(
        TypeError, match="to_csv takes a Trajectory, a SweepResult or a MapResult, not dict"
    ):
        lamech.to_csv({"t": [0.0, 1.0]})


def test_parameters_as_arguments(pendulum):
    """A sweep changes parameters without regenerating code."""
    tr = simulate(pendulum, 1.0, params={"theta0": 0.3, "g": 9.0}, samples=101)
    th = tr.coordinate("theta")
    assert abs(th[0] - 0.3) < 1e-15
    ref = 9.0 * (3 * np.cos(th) - 2 * math.cos(0.3))
    assert np.max(np.abs(tr.multiplier("string") - ref) / ref) < 1e-8


@pytest.mark.slow
def test_rheonomic_hoop_keeps_its_jacobi_integral():
    system = lamech.load("hoop_bead")
    tr = simulate(system, 3.0, samples=301)
    assert tr.status == "ok", tr.message
    assert tr.energy_error is None  # the drive does work
    m, g, R, w = 1.0, 9.81, 0.5, 6.0
    th, thd = tr.coordinate("theta"), tr.velocity("theta")
    h = m * R**2 * thd**2 / 2 - m * R**2 * w**2 * np.sin(th) ** 2 / 2 - m * g * R * np.cos(th)
    assert np.max(np.abs(h - h[0])) <= 1e-9 * abs(h[0])
    assert np.max(np.abs(tr.coordinate("phi") - w * tr.t)) < 1e-10


def test_knife_edge_nonholonomic_invariants():
    tr = simulate(lamech.load("knife_edge"), 5.0, samples=201)
    assert tr.status == "ok", tr.message
    assert np.max(tr.residual_velocity) < 1e-10
    assert np.allclose(tr.velocity("phi"), 1.5, rtol=1e-10)
    assert tr.energy_error < 1e-10
    # the lateral force is the centripetal force m v phi' = 1 * 2 * 1.5
    assert np.allclose(tr.forces["blade:lateral"], 3.0, rtol=1e-8)


@pytest.mark.slow
@pytest.mark.shared_cache
@pytest.mark.skipif(not compiled_available(), reason="no C compiler or engine")
def test_jit_gives_the_same_numbers():
    system = lamech.load("cylinder")
    a = simulate(compile_system(system), 3.0, q0={"theta1": THS, "theta2": 3 * THS})
    ns = compile_system(system, jit=True)
    assert ns.jit
    b = simulate(ns, 3.0, q0={"theta1": THS, "theta2": 3 * THS})
    assert [e.kind for e in a.events] == [e.kind for e in b.events]
    assert np.allclose(a.q, b.q, rtol=0, atol=1e-12)
    assert np.allclose(np.nan_to_num(a.lambdas), np.nan_to_num(b.lambdas), atol=1e-10)


def test_ladder_leaves_the_wall_at_two_thirds_height():
    tr = simulate(lamech.load("ladder"), 0.8, samples=101)  # the top lands at t = 0.816
    assert tr.status == "ok", tr.message
    assert [(e.kind, e.constraint) for e in tr.events] == [("lift-off", "wall")]
    phi = tr.events[0].coordinates["phi"]
    assert abs(phi - math.asin(2 / 3 * math.sin(1.2))) <= 1e-9
    assert tr.energy_error < 1e-9  # frictionless: lift-off dissipates nothing


def test_ladder_lands_flat_and_slides_on():
    """After the wall, the ladder's top end falls to the floor (it swung through the floor
    before `top_floor` was modelled). Truth: with no horizontal force x' keeps its
    lift-off value; energy then gives the landing speed, m l^2 phi'^2 / 6 = E - m x'^2/2
    at phi = 0 (foot on the floor), so the top meets the floor at l |phi'|; the plastic
    landing leaves it flat (phi' = y' = 0), sliding at x'."""
    m, g, l, phi0 = 1.0, G, 2.0, 1.2
    tr = simulate(lamech.load("ladder"), 2.0, samples=201)
    assert tr.status == "ok", tr.message
    kinds = [(e.kind, e.constraint) for e in tr.events]
    assert kinds == [("lift-off", "wall"), ("contact", "top_floor")]
    lift, land = tr.events
    vx = lift.coordinates["x'"]
    assert abs(land.coordinates["x'"] - vx) < 1e-9 and abs(land.coordinates["phi"]) < 1e-9
    E = m * g * l / 2 * math.sin(phi0)
    phid = math.sqrt(6 * (E - m * vx**2 / 2) / (m * l**2))
    assert abs(land.velocity_before + l * phid) < 1e-7
    assert abs(land.coordinates["phi'"]) < 1e-12 and abs(land.coordinates["y'"]) < 1e-12
    after = tr.t > land.t
    assert np.allclose(tr.coordinate("y")[after], 0, atol=1e-12)
    assert np.allclose(
        tr.coordinate("x")[after], land.coordinates["x"] + vx * (tr.t[after] - land.t), atol=1e-9
    )
    assert tr.coordinate("y").min() > -1e-9
    top = tr.coordinate("y") + l / 2 * np.sin(tr.coordinate("phi"))
    assert top.min() > -1e-9  # never through the floor


def test_events_and_status_are_typed():
    """Events are typed records whose JSON is the --json summary's; statuses and kinds
    are str enumerations equal to their plain values."""
    tr = simulate(lamech.load("ladder"), 0.8, samples=11)
    assert tr.status is Status.OK and tr.status == "ok" and f"{tr.status}" == "ok"
    assert "what to try" in Status.FAILED.meaning
    (ev,) = tr.events
    assert isinstance(ev, Event) and ev.kind is EventKind.LIFT_OFF and ev.kind == "lift-off"
    js = ev.to_json()
    assert list(js) == ["t", "kind", "constraint", "coordinates"] and js["kind"] == "lift-off"
    assert lamech.to_json(tr)["events"] == [js] and lamech.to_json(tr)["status"] == "ok"
    assert FrictionState("slip") is FrictionState.SLIP


@pytest.mark.slow
def test_cli_simulate(tmp_path, capsys):
    import json

    from lamech.cli import main

    out, png = tmp_path / "traj.csv", tmp_path / "forces.png"
    assert (
        main(
            [
                "simulate",
                "ladder",
                "--t-end",
                "1",
                "--samples",
                "51",
                "--out",
                str(out),
                "--json",
                "--plot",
                str(png),
            ]
        )
        == 0
    )
    summary = json.loads(capsys.readouterr().out)
    assert summary["status"] == "ok"
    assert summary["events"][0]["kind"] == "lift-off"
    assert len(out.read_text().splitlines()) == 52
    assert png.stat().st_size > 10_000
    with pytest.raises(SystemExit):
        main(["simulate", "ladder", "--t-end", "-1"])


INVERSE_SQUARE = """
title = "inverse-square attraction along a line"
[parameters]
k = 1.0
[coordinates]
x = { initial = 2, velocity = 0 }
y = { initial = 0, velocity = 0 }
[lagrangian]
T = "x'^2/2 + y'^2/2"
V = "-k/x - k/x^3 + x^(5/2)"
[[constraints]]
name = "c"
f = "y"
"""


# the cases of 2 s or more (andrews_squeezer: about 5 s of SymPy on its own): left out
# of the default set
SLOW_SYMPY = {
    "andrews_squeezer",
    "four_bar",
    "heavy_top",
    "hoop_bead",
    "moving_support",
    "rolling_disc",
    "rolling_sphere",
    "spherical_pendulum",
}
assert SLOW_SYMPY <= set(lamech.example_names()), SLOW_SYMPY - set(lamech.example_names())


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(n, marks=pytest.mark.slow) if n in SLOW_SYMPY else n
        for n in lamech.example_names() + ["<inverse-square>"]
    ],
)
def test_generated_code_matches_sympy(name):
    """The generated numeric functions against SymPy's own evaluation at random states."""
    from lamech.symbolic import dynamics

    system = lamech.loads(INVERSE_SQUARE) if name.startswith("<") else lamech.load(name)
    ns = compile_system(system)
    dyn = dynamics(system)
    rng = np.random.default_rng(3)
    p = ns.parameters
    for _ in range(3):
        q = rng.uniform(0.2, 1.5, ns.n)
        v = rng.uniform(-1.0, 1.0, ns.n)
        t = float(rng.uniform(0, 2))
        env = {
            **system.parameter_values,
            system.t: t,
            **dict(zip(system.q, q)),
            **dict(zip(system.qd, v)),
        }
        M, rhs, A, gam, _ = ns.dynamics(t, q, v, p)
        for got, expr in ((M, dyn.M), (rhs, dyn.Q - dyn.h), (A, dyn.A), (gam, dyn.gamma)):
            ref = np.array(sp.Matrix(expr).subs(env).evalf(), dtype=float).reshape(np.shape(got))
            assert np.allclose(got, ref, rtol=1e-13, atol=1e-13), (name, got, ref)
        T, V = ns.energy(t, q, v, p)
        assert math.isclose(T, float(system.T.subs(env)), rel_tol=1e-13, abs_tol=1e-13)
        assert math.isclose(V, float(system.V.subs(env)), rel_tol=1e-13, abs_tol=1e-13)


def test_initial_values_held_and_friction_as_parameter():
    """--initial / initial=: the named value is held, the others meet the constraints;
    the slip angle then follows the energy integral from that start."""
    cyl = lamech.load("cylinder")
    theta_s, mu = 0.02, 0.1
    tr = lamech.simulate(cyl, 3.0, initial={"theta1": theta_s}, params={"mu": mu}, samples=11)
    assert tr.status == "ok", tr.message
    R1, R2 = 1.0, 0.5
    assert tr.coordinate("theta1")[0] == theta_s
    assert abs(tr.coordinate("r")[0] - (R1 + R2)) < 1e-15
    assert abs(tr.coordinate("theta2")[0] - (R1 + R2) / R2 * theta_s) < 1e-14
    slip = next(e for e in tr.events if e.kind == "slip")
    # N = m g (7 cos θ - 4 cos θs)/3, F = -m g sin θ / 3: slip where sin θ = μ (7 cos θ - 4 cos θs)
    root = brentq(
        lambda th: math.sin(th) - mu * (7 * math.cos(th) - 4 * math.cos(theta_s)), theta_s, 1.0
    )
    assert abs(slip.coordinates["theta1"] - root) < 1e-9
    with pytest.raises(SimulationError, match="unknown coordinate `phi`"):
        lamech.simulate(cyl, 1.0, initial={"phi": 1.0})
    with pytest.raises(SimulationError, match="known: .*mu:rolling"):
        lamech.simulate(cyl, 1.0, params={"nu": 1.0})


def test_held_initial_values_move_the_others_least_in_the_mass_metric():
    """consistent_initial uses the simulator's projection: the free coordinates move to
    the constraints by the smallest change in kinetic metric. Double Atwood machine
    (m1, m2, m3 = 3, 1, 2; the pulley yp massless): holding yp 0.05 higher makes the upper
    string lower y1 by 0.05 and the lower string share its 0.1 as m3 : m2 between y2 and
    y3; holding y3' = 0.3 gives yp' = 0.6 m2 / (m1 + 4 m2) (least m1 y1'^2 + m2 y2'^2)."""
    ns = compile_system(lamech.load("double_atwood"))
    q, v = consistent_initial(ns, ns.parameters, [("yp", -0.95), ("y3'", 0.3)])
    assert np.allclose(q, [-0.95, -1.05, -1.5 + 0.2 / 3, -1.5 + 0.1 / 3], rtol=0, atol=1e-15)
    vp = 0.6 / 7
    assert np.allclose(v, [vp, -vp, -0.3 + 2 * vp, 0.3], rtol=0, atol=1e-15)


@pytest.mark.slow
def test_trajectory_as_dataframe():
    pd = pytest.importorskip("pandas", reason="pandas not installed")
    tr = lamech.simulate(lamech.load("pendulum"), 1.0, samples=5)
    df = tr.to_dataframe()
    assert isinstance(df, pd.DataFrame)
    assert list(df["t"]) == [0.0, 0.25, 0.5, 0.75, 1.0]
    assert {"theta", "theta'", "lambda:string", "energy", "residual"} <= set(df.columns)


BLOW_UP = (HERE / "problems" / "blow_up.toml").read_text(encoding="utf-8")


def test_a_failed_run_keeps_what_it_computed(tmp_path):
    tr = lamech.simulate(lamech.loads(BLOW_UP), 2.0, samples=21)
    assert tr.status == "failed"
    assert "t = 0.9999" in tr.message and "grows without bound" in tr.message
    assert list(tr.t) == pytest.approx([0.1 * k for k in range(10)])
    # The force is 1/(1-t)^3 on x along the rail y = x/2 (mass m (1 + 1/4) along x):
    # x'' = 1/(1.25 (1-t)^3), so x' = (1/(1-t)^2 - 1)/2.5 — the computed part is right.
    t = tr.t
    assert np.allclose(tr.velocity("x"), (1 / (1 - t) ** 2 - 1) / 2.5, rtol=1e-9, atol=1e-12)
    path = tmp_path / "partial.csv"
    lamech.present.trajectory_csv(tr, path)
    rows = list(csv.DictReader(path.open()))
    assert len(rows) == 10 and float(rows[-1]["t"]) == pytest.approx(0.9)


def test_ctrl_c_keeps_the_trajectory():
    def progress(t):
        if t > 0.5:
            raise KeyboardInterrupt

    tr = lamech.simulate(
        lamech.load("pendulum"), 5.0, samples=51, progress=progress, engine="scipy"
    )
    assert tr.status == "interrupted"
    assert "interrupted at t = " in tr.message
    assert 0 < len(tr.t) < 51 and tr.t[-1] <= 0.6 + 1e-12
    assert np.all(np.isfinite(tr.multiplier("string")))


def test_cli_initial_and_param(capsys):
    from lamech.cli import main

    code = main(
        [
            "simulate",
            "cylinder",
            "--t-end",
            "2.6",
            "--samples",
            "3",
            "--initial",
            "theta1=pi/200",
            "--param",
            "mu=0.1",
            "--json",
        ]
    )
    out = json.loads(capsys.readouterr().out)
    assert code == 0 and out["status"] == "ok"
    assert [e["kind"] for e in out["events"]][:2] == ["slip", "lift-off"]
    code = main(["simulate", "cylinder", "--t-end", "1", "--initial", "theta1=__import__"])
    assert code == 2
    assert "unknown name" in capsys.readouterr().err


@pytest.mark.slow
def test_cli_engine_chooses_the_integrator_and_says_which_ran(capsys):
    from lamech.cli import main

    args = [
        "simulate",
        "cylinder",
        "--t-end",
        "2.6",
        "--samples",
        "3",
        "--initial",
        "theta1=pi/200",
        "--param",
        "mu=0.1",
        "--json",
    ]
    runs = {}
    for engine in ("python", "scipy"):
        assert main([*args, "--engine", engine]) == 0
        runs[engine] = json.loads(capsys.readouterr().out)
    assert runs["python"]["engine"] == "loop (Python)"
    assert runs["scipy"]["engine"] == "SciPy DOP853"
    times = [[e["t"] for e in runs[k]["events"]] for k in ("python", "scipy")]
    assert len(times[0]) == len(times[1]) >= 2
    assert max(abs(a - b) for a, b in zip(*times)) <= 1e-10
    assert main([*args[:-1], "--engine", "python", "--method", "Radau"]) == 2
    err = capsys.readouterr().err
    assert "engine 'python' cannot run this problem: method Radau" in err
    assert "Traceback" not in err
    # the older name, still accepted, says which to use
    with pytest.warns(DeprecationWarning, match="engine 'loop' is deprecated"):
        assert main([*args, "--engine", "loop"]) == 0
    captured = capsys.readouterr()
    assert json.loads(captured.out)["engine"] == "loop (C)"  # compiled where it can
    assert "--engine loop is deprecated" in captured.err
    with pytest.raises(SystemExit) as stop:
        main([*args[:-1], "--engine", "rk4"])
    assert stop.value.code == 2 and "invalid choice: 'rk4'" in capsys.readouterr().err


SINGULAR = """
title = "Bead on a circle, pushed across by a drive"
[parameters]
m = 1.0
[coordinates]
x = { initial = 0, velocity = 1 }
y = { initial = 1, velocity = 0 }
[lagrangian]
T = "m/2*(x'^2 + y'^2)"
[[constraints]]
name = "circle"
f = "x^2 + y^2 - 1"
[[constraints]]
name = "drive"
f = "x - t"
"""


@pytest.mark.slow
def test_driven_into_a_singular_configuration():
    """x = t drives the bead along the unit circle to (1, 0) at t = 1, where the two
    constraint gradients (2x, 2y) and (1, 0) become parallel: the run stops there as
    'failed', naming the time, the cause and what to try; the part before is exact."""
    tr = lamech.simulate(lamech.loads(SINGULAR), 2.0, samples=21)
    assert tr.status == "failed"
    assert "singular" in tr.message and "try" in tr.message.lower()
    t_stop = float(re.search(r"at t = ([0-9.e+-]+)", tr.message).group(1))
    assert 0.99 < t_stop <= 1.0
    t = tr.t
    assert 5 <= len(t) < 11 and t[-1] < 1
    # closed form: y = sqrt(1 - t^2); m y'' = 2 y lambda_circle, 0 = 2 x lambda_circle
    # + lambda_drive, so lambda_circle = -1/(2 (1 - t^2)^2), lambda_drive = t/(1 - t^2)^2
    assert np.allclose(tr.coordinate("y"), np.sqrt(1 - t**2), rtol=1e-9, atol=1e-12)
    assert np.allclose(tr.multiplier("circle"), -1 / (2 * (1 - t**2) ** 2), rtol=1e-6)
    assert np.allclose(tr.multiplier("drive"), t / (1 - t**2) ** 2, rtol=1e-6, atol=1e-12)
    rows = list(csv.DictReader(io.StringIO(lamech.present.trajectory_csv(tr))))
    assert len(rows) == len(t)
    assert lamech.to_json(tr)["status"] == "failed"


def test_nan_in_the_dynamics_fails_with_time_and_cause():
    """A force sqrt(1 - t) is NaN after t = 1: the run stops 'failed' near t = 1 with
    what it computed, x' = (2/3)(1 - (1 - t)^(3/2)) (m = 1)."""
    text = """
title = "Force that leaves its domain"
[parameters]
m = 1.0
[coordinates]
x = { initial = 0, velocity = 0 }
[lagrangian]
T = "m/2*x'^2"
[forces]
x = "sqrt(1 - t)"
"""
    tr = lamech.simulate(lamech.loads(text), 2.0, samples=21)
    assert tr.status == "failed", tr.message
    t_stop = float(re.search(r"at t = ([0-9.e+-]+)", tr.message).group(1))
    assert abs(t_stop - 1) < 1e-6
    assert "NaN or undefined" in tr.message or "domain" in tr.message
    assert tr.t[-1] <= 1.0 + 1e-12 and len(tr.t) >= 10
    t = tr.t
    assert np.allclose(tr.velocity("x"), 2 / 3 * (1 - (1 - t) ** 1.5), rtol=1e-7, atol=1e-9)


def _moving_support_truth(t_eval, m=1.0, g=9.81, l=1.0, a=0.1, w=3.0, theta0=0.3):
    """Independent truth: the textbook reduced equation
    theta'' = -(g/l) sin(theta) + (a w^2/l) cos(w t) cos(theta), solved by solve_ivp."""
    from scipy.integrate import solve_ivp

    def rhs(t, y):
        return [y[1], -g / l * math.sin(y[0]) + a * w**2 / l * math.cos(w * t) * math.cos(y[0])]

    sol = solve_ivp(
        rhs, (0, t_eval[-1]), [theta0, 0.0], t_eval=t_eval, method="DOP853", rtol=1e-12, atol=1e-12
    )
    return sol.y[0], sol.y[1]


@pytest.mark.slow
def test_pendulum_on_a_driven_support_matches_the_reduced_equation():
    tr = simulate(lamech.load("moving_support"), 10.0, samples=501)
    assert tr.status == "ok", tr.message
    assert tr.energy_error is None  # the drive does work
    assert tr.events == []  # the string stays taut
    t = tr.t
    m, g, l, a, w, M = 1.0, 9.81, 1.0, 0.1, 3.0, 2.0
    assert np.max(np.abs(tr.coordinate("xs") - a * np.cos(w * t))) < 1e-10
    assert np.max(np.abs(tr.coordinate("r") - l)) < 1e-10
    th_ref, thd_ref = _moving_support_truth(t)
    th, thd = tr.coordinate("theta"), tr.velocity("theta")
    assert np.max(np.abs(th - th_ref)) < 1e-7
    assert np.max(np.abs(thd - thd_ref)) < 1e-6
    # multipliers against the closed forms, evaluated on the computed state
    tension = m * l * thd**2 + m * g * np.cos(th) + m * a * w**2 * np.cos(w * t) * np.sin(th)
    assert np.allclose(tr.multiplier("string"), tension, rtol=1e-8)
    support = -tension * np.sin(th) - M * a * w**2 * np.cos(w * t)
    assert np.allclose(tr.multiplier("support"), support, rtol=1e-8, atol=1e-8)


@pytest.mark.slow
def test_cli_csv_and_json_contract(tmp_path, capsys):
    """The CSV and --json summary parsed back: columns, 17 significant digits, both
    ends sampled, events with t/kind/constraint/coordinates, energy_error null for a
    driven (time-dependent) problem."""
    from lamech.cli import main

    out = tmp_path / "m.csv"
    code = main(
        [
            "simulate",
            "moving_support",
            "--t-end",
            "2",
            "--samples",
            "5",
            "--out",
            str(out),
            "--json",
        ]
    )
    assert code == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["status"] == "ok" and summary["energy_error"] is None
    assert summary["max_residual"] < 1e-9
    rows = list(csv.reader(out.open()))
    assert rows[0] == [
        "t",
        "xs",
        "r",
        "theta",
        "xs'",
        "r'",
        "theta'",
        "lambda:support",
        "lambda:string",
        "force:string:tension",
        "energy",
        "residual",
    ]
    assert [float(r[0]) for r in rows[1:]] == [0.0, 0.5, 1.0, 1.5, 2.0]
    last = rows[-1]
    for name, value in summary["final"].items():
        assert float(last[rows[0].index(name)]) == value  # round-trips exactly
    assert abs(float(last[1]) - 0.1 * math.cos(6.0)) < 1e-10  # xs = a cos(w t)
    th_ref, _ = _moving_support_truth(np.array([0.0, 2.0]))
    assert abs(float(last[3]) - th_ref[-1]) < 1e-7
    assert last[3] == f"{float(last[3]):.17g}"  # written with 17 digits

    code = main(["simulate", "ladder", "--t-end", "0.8", "--samples", "3", "--json"])
    summary = json.loads(capsys.readouterr().out)
    ev = summary["events"][0]
    assert {"t", "kind", "constraint", "coordinates"} <= set(ev)
    assert ev["kind"] == "lift-off"
    assert set(ev["coordinates"]) >= {"phi", "x", "y", "phi'", "x'", "y'"}
    assert isinstance(summary["energy_error"], float)


@pytest.mark.slow
@pytest.mark.shared_cache
def test_thirty_link_chain_without_special_handling():
    """Issue 4's large system: derive, compile and simulate the 30-link chain (60
    coordinates, 30 constraints); energy and constraints hold."""
    from lamech.problem import chain_toml

    tr = lamech.simulate(lamech.loads(chain_toml(30)), 1.0, samples=3)
    assert tr.status == "ok", tr.message
    assert lamech.to_json(tr)["max_residual"] < 1e-10
    assert tr.energy_error < 1e-9


SHAKEN = """
title = "Block on a floor, shaken"
[parameters]
m = 1.0
g = 9.81
F = 20.0
w = 3.0
[coordinates]
y = { initial = 0, velocity = 0 }
[lagrangian]
T = "m/2*y'^2"
V = "m*g*y"
[forces]
y = "F*sin(w*t)"
[[constraints]]
name = "floor"
f = "y"
unilateral = true
"""


def test_a_force_that_rises_and_falls_within_a_step_lifts_the_block_off():
    """A block resting on the floor stands still, so one step may span the force's whole
    rise and fall: the lift-off where F sin(w t) first exceeds m g is still found (it
    was missed, status ok), then the flight, the landing and the next lift-off, each
    against its closed form."""
    m, g, F, w = 1.0, G, 20.0, 3.0
    tr = simulate(lamech.loads(SHAKEN), 3.0, samples=301)
    assert tr.status == "ok", tr.message
    kinds = [e.kind for e in tr.events]
    assert kinds == ["lift-off", "contact", "lift-off"]
    t0 = math.asin(m * g / F) / w
    assert abs(tr.events[0].t - t0) <= 1e-9

    def y(t):  # the flight from rest at t0 under F sin(w t) - m g
        return (
            -F / (m * w**2) * (math.sin(w * t) - math.sin(w * t0))
            + F / (m * w) * math.cos(w * t0) * (t - t0)
            - g / 2 * (t - t0) ** 2
        )

    from scipy.optimize import brentq

    landing = brentq(y, t0 + 0.5, 2.5, xtol=1e-15)
    assert abs(tr.events[1].t - landing) <= 1e-9
    assert abs(tr.events[2].t - (2 * math.pi + math.asin(m * g / F)) / w) <= 1e-9
    flight = (tr.t > t0) & (tr.t < landing)
    assert np.max(np.abs(tr.coordinate("y")[flight] - np.vectorize(y)(tr.t[flight]))) <= 1e-9
