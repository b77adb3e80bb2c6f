"""Drives (issue 47 item 1): a prescribed motion whose multiplier is the force or torque
the drive applies, against hand derivations.

The bundled slider-crank (massless crank r and rod l, slider mass M, the crank turned at
omega): x(phi) = r cos(phi) + sqrt(l^2 - r^2 sin(phi)^2), and the power balance
tau omega = d/dt (M x'^2 / 2) gives tau = M omega^2 x_phi x_phiphi; the rod, a two-force
member, pushes the slider with F = 2 l lambda_rod where M x'' = F (x - r cos(phi)) / l.
The four-bar driven by its crank: the motor's work equals the change of the links'
energy (no other force does work).
"""

from __future__ import annotations

import csv
import io
import json
import math

import numpy as np
import pytest
import sympy as sp
from scipy.optimize import brentq

import lamech
from lamech.problem import ProblemFileError

M, R, L, OMEGA = 2.0, 0.1, 0.3, 10.0
PHI = sp.Symbol("phi", real=True)
X = R * sp.cos(PHI) + sp.sqrt(L**2 - R**2 * sp.sin(PHI) ** 2)
X1, X2 = sp.diff(X, PHI), sp.diff(X, PHI, 2)
TAU = M * OMEGA**2 * X1 * X2
tau = sp.lambdify(PHI, TAU)
tau_rate = sp.lambdify(PHI, sp.diff(TAU, PHI))
x_of, x1_of, x2_of = (sp.lambdify(PHI, e) for e in (X, X1, X2))


@pytest.fixture(scope="module")
def slider_crank():
    return lamech.solve(lamech.load("slider_crank"))


def _hand_extremes():
    """The torque's extremes over a turn: the roots of its derivative, each bracketed on
    a grid of 3600 points and found by Brent's method."""
    grid = np.linspace(0.0, 2 * math.pi, 3601)
    rates = tau_rate(grid)
    roots = [
        brentq(tau_rate, a, b, xtol=1e-15)
        for a, b, ra, rb in zip(grid, grid[1:], rates, rates[1:])
        if ra * rb < 0
    ]
    values = [float(tau(r)) for r in roots]
    k_max, k_min = int(np.argmax(values)), int(np.argmin(values))
    return (values[k_max], roots[k_max]), (values[k_min], roots[k_min])


def test_the_slider_cranks_torque_is_the_hand_derivations_at_random_angles(slider_crank):
    drive = slider_crank.drives["motor"]
    assert drive.coordinate == "phi" and drive.cycle is not None
    rng = np.random.default_rng(47)
    for phi in rng.uniform(0, 2 * math.pi, 25):
        assert abs(drive.cycle.at(phi) - tau(phi)) <= 1e-10, phi
    # and the closed form itself, in the state (x, x', t), at the same angles
    system = slider_crank.system
    s = system.symbols
    expr = drive.expr.subs(system.parameter_values)
    form = sp.lambdify((s["x"], s["x'"], system.t), expr)
    for phi in rng.uniform(0, 2 * math.pi, 25):
        x, v = x_of(phi), x1_of(phi) * OMEGA
        assert abs(form(x, v, phi / OMEGA) - tau(phi)) <= 1e-10, phi


def test_the_slider_cranks_pin_force_is_the_hand_derivations(slider_crank):
    s = slider_crank.system
    lam = sp.lambdify(
        (s.symbols["x"], s.symbols["x'"], s.t),
        slider_crank.multipliers["rod"].subs(s.parameter_values),
    )
    for phi in np.random.default_rng(3).uniform(0, 2 * math.pi, 25):
        x = x_of(phi)
        xdd = OMEGA**2 * x2_of(phi)
        pushed = M * xdd * L / (x - R * math.cos(phi))  # F, the rod's push on the slider
        assert abs(2 * L * lam(x, x1_of(phi) * OMEGA, phi / OMEGA) - pushed) <= 1e-10, phi


def test_the_torques_extremes_over_a_turn_are_where_its_derivative_vanishes(slider_crank):
    cycle = slider_crank.drives["motor"].cycle
    (hi, at_hi), (lo, at_lo) = _hand_extremes()
    assert cycle.max.value == pytest.approx(hi, abs=1e-10)
    assert cycle.min.value == pytest.approx(lo, abs=1e-10)
    assert abs(cycle.max.angle - at_hi) <= 1e-8 and abs(cycle.min.angle - at_lo) <= 1e-8
    assert cycle.max.t == pytest.approx(at_hi / OMEGA, abs=1e-9)
    assert cycle.period == pytest.approx(2 * math.pi / OMEGA)


def test_simulate_gives_the_torque_along_the_motion():
    t_end = 2 * (2 * math.pi / OMEGA)  # two turns
    traj = lamech.simulate(lamech.load("slider_crank"), t_end, samples=4001)
    assert traj.status == "ok", traj.message
    phi = traj.coordinate("phi")
    assert np.allclose(phi, OMEGA * traj.t, atol=1e-9)
    hand = tau(phi)
    peak = float(np.max(np.abs(hand)))
    assert np.max(np.abs(traj.drive_forces["motor"] - hand)) <= 1e-7 * peak
    summary = lamech.to_json(traj)["drives"]["motor"]
    (hi, at_hi), (lo, at_lo) = _hand_extremes()
    # refined between the samples: the hand extremes' value, at one of their angles
    assert summary["peak"] == pytest.approx(max(hi, -lo), rel=1e-9)
    at = summary["at"]
    assert at["phi"] == pytest.approx(OMEGA * at["t"], abs=1e-8)
    assert min(abs(math.remainder(at["phi"] - a, 2 * math.pi)) for a in (at_hi, at_lo)) < 1e-5
    assert at["x"] == pytest.approx(x_of(at["phi"]), abs=1e-9)
    # the RMS of the hand form over two turns (the trapezoids of the same samples)
    rms = math.sqrt(np.trapezoid(hand**2, traj.t) / t_end)
    assert summary["rms"] == pytest.approx(rms, rel=1e-6)
    # power balance: the motor's work is the slider's kinetic energy, back to 0 each turn
    assert abs(summary["work_per_cycle"]) <= 1e-8
    assert abs(summary["mean_power"]) <= 1e-8


def test_the_peak_is_refined_between_coarse_samples():
    """61 samples over a turn: the sampled peak is off by ~6e-4, the quartic's vertex by
    ~1e-6; where it is, the crank angle and the slider's x agree with the motion."""
    period = 2 * math.pi / OMEGA
    traj = lamech.simulate(lamech.load("slider_crank"), period, samples=61)
    (hi, _), (lo, _) = _hand_extremes()
    truth = max(hi, -lo)
    sampled = float(np.max(np.abs(traj.drive_forces["motor"])))
    summary = lamech.to_json(traj)["drives"]["motor"]
    assert abs(summary["peak"] - truth) < abs(sampled - truth) / 100
    assert summary["peak"] == pytest.approx(truth, rel=5e-6)
    at = summary["at"]
    assert at["x"] == pytest.approx(x_of(at["phi"]), abs=1e-6)
    assert tau(at["phi"]) == pytest.approx(math.copysign(summary["peak"], tau(at["phi"])), rel=1e-4)


def test_a_named_reactions_peak_is_the_pendulums_tension_at_the_bottom():
    """The pendulum released at theta0: its string's tension m g (3 cos(theta) - 2
    cos(theta0)) (energy conservation) peaks at the bottom, m g (3 - 2 cos(theta0));
    from 41 samples over a swing the refined peak has it, at theta = 0."""
    theta0 = 1.0
    system = lamech.load("pendulum")
    p = {q.name: float(q.value) for q in system.parameters}
    traj = lamech.simulate(system, 2.0, initial={"theta": theta0}, samples=41)
    assert traj.status == "ok", traj.message
    reactions = lamech.to_json(traj)["reactions"]
    (name,) = reactions
    truth = p["m"] * p["g"] * (3 - 2 * math.cos(theta0))
    sampled = float(np.nanmax(traj.reactions()[name]))
    assert abs(reactions[name]["peak"] - truth) < abs(sampled - truth) / 10
    assert reactions[name]["peak"] == pytest.approx(truth, rel=1e-6)
    assert abs(reactions[name]["at"]["theta"]) < 1e-4


def test_a_reactions_magnitude_is_that_of_its_components():
    traj = lamech.simulate(lamech.load("knife_edge"), 1.0, samples=101)
    mag = traj.reactions()
    (name,) = {k.split(":")[0] for k in traj.forces}
    parts = [v for k, v in traj.forces.items() if k.startswith(name + ":")]
    assert len(parts) == 2
    assert np.allclose(mag[name], np.hypot(*parts), equal_nan=True)


@pytest.mark.slow
def test_the_four_bars_motor_does_the_work_the_links_energy_gains():
    system = lamech.load("four_bar_driven")
    sol = lamech.solve(system)
    cycle = sol.drives["motor"].cycle
    traj = lamech.simulate(system, 0.6, samples=3001)
    assert traj.status == "ok", traj.message
    power = traj.drive_power["motor"]
    work = np.concatenate([[0.0], np.cumsum((power[1:] + power[:-1]) / 2 * np.diff(traj.t))])
    gained = traj.energy - traj.energy[0]
    assert np.max(np.abs(work - gained)) <= 1e-5 * np.max(np.abs(traj.energy))
    # and the closed form along the motion, at every sample
    th1 = traj.coordinate("th1")
    along = np.array([cycle.at(a) for a in th1[::100]])
    assert np.allclose(along, traj.drive_forces["motor"][::100], rtol=1e-7, atol=1e-7)


def test_the_cli_gives_the_drives_in_text_json_and_csv(tmp_path, capsys):
    from lamech.cli import main

    out = tmp_path / "run.csv"
    assert main(["simulate", "slider_crank", "--t-end", "0.7", "--json", "--out", str(out)]) == 0
    data = json.loads(capsys.readouterr().out)
    motor = data["drives"]["motor"]
    assert {"peak", "at", "rms", "mean_power", "work_per_cycle"} <= set(motor)
    rows = list(csv.DictReader(io.StringIO(out.read_text())))
    assert "drive:motor" in rows[0]
    assert main(["simulate", "slider_crank", "--t-end", "0.7"]) == 0
    assert "motor on phi: peak" in capsys.readouterr().out
    assert main(["solve", "slider_crank"]) == 0
    text = capsys.readouterr().out
    assert "motor on phi =" in text and "max 1.38415" in text
    assert main(["solve", "slider_crank", "--json"]) == 0
    cyc = json.loads(capsys.readouterr().out)["drives"]["motor"]["cycle"]
    assert cyc["max"]["value"] == pytest.approx(_hand_extremes()[0][0], abs=1e-10)


@pytest.mark.parametrize(
    "entry, message",
    [
        ('coordinate = "psi"\nspeed = "omega"', "unknown coordinate `psi`"),
        ('coordinate = "phi"\nspeed = "omega"\nmotion = "omega*t"', "exactly one of"),
        ('coordinate = "phi"\nspeed = "omega*t"', "`speed` is a constant rate"),
        ('speed = "omega"', "needs the `coordinate`"),
        ('coordinate = "phi"\nrate = "omega"', "unknown key `rate`"),
    ],
)
def test_a_bad_drive_is_refused_at_its_line(entry, message):
    from importlib import resources

    text = (resources.files("lamech") / "examples" / "slider_crank.toml").read_text()
    text = text.replace('coordinate = "phi"\nspeed = "omega"', entry)
    with pytest.raises(ProblemFileError) as info:
        lamech.loads(text, "crank.toml")
    said = str(info.value)
    assert message in said and "drives[1]" in said and "crank.toml:" in said


CART = """
title = "Pendulum under a cart shaken sideways"
[parameters]
M = 2.0
m = 0.5
l = 0.8
g = 9.81
A = 0.1
w = 3.0
[coordinates]
x = { initial = 0, velocity = "A*w" }
theta = { initial = 0.3, velocity = 0 }
[lagrangian]
T = "M/2*x'^2 + m/2*((x' + l*cos(theta)*theta')^2 + (l*sin(theta)*theta')^2)"
V = "-m*g*l*cos(theta)"
[[drives]]
name = "shaker"
DRIVE
"""


def test_a_drive_that_leaves_freedom_does_the_work_the_energy_gains():
    system = lamech.loads(CART.replace("DRIVE", 'coordinate = "x"\nmotion = "A*sin(w*t)"'))
    sol = lamech.solve(system)
    drive = sol.drives["shaker"]
    assert drive.cycle is None and "freedom" in drive.note
    traj = lamech.simulate(system, 3.0, samples=3001)
    power = traj.drive_power["shaker"]
    # the force on the cart times its velocity: the same power
    assert np.allclose(power, traj.drive_forces["shaker"] * traj.velocity("x"), atol=1e-12)
    work = np.concatenate([[0.0], np.cumsum((power[1:] + power[:-1]) / 2 * np.diff(traj.t))])
    gained = traj.energy - traj.energy[0]
    assert np.max(np.abs(work - gained)) <= 1e-5 * np.max(np.abs(traj.energy))
    summary = lamech.to_json(traj)["drives"]["shaker"]
    assert summary["work_per_cycle"] is None  # x is not an angle: no turn to a cycle
    # a general f (no coordinate) is the same constraint: its multiplier, the same force
    general = lamech.loads(CART.replace("DRIVE", 'f = "x - A*sin(w*t)"'))
    other = lamech.simulate(general, 3.0, samples=3001)
    assert np.allclose(other.drive_forces["shaker"], traj.drive_forces["shaker"], atol=1e-9)
    assert lamech.solve(general).drives["shaker"].coordinate is None


def test_the_plot_draws_the_torque_against_time_and_the_crank_angle(tmp_path):
    """--plot with a drive: a third panel (the torque against time) and, for a crank that
    turns, a fourth (the torque against the crank angle); a joint that only swings has
    no fourth."""
    from matplotlib.image import imread

    from lamech.present import plot_trajectory

    heights = {}
    for name, t_end in (("pendulum", 1.0), ("robot_arm", 1.0), ("slider_crank", 0.7)):
        path = tmp_path / f"{name}.png"
        plot_trajectory(lamech.simulate(lamech.load(name), t_end, samples=201), path)
        heights[name] = imread(str(path)).shape[0]
    assert heights["pendulum"] < heights["robot_arm"] < heights["slider_crank"]


def test_a_peak_at_an_event_is_not_refined_across_it():
    """The cylinder's friction grows until it slips at t = 2.2835, then drops to mu N: the
    largest sample is beside the event, and no smooth curve runs through the samples
    around it, so the peak is the sample's (a time of the samples)."""
    traj = lamech.simulate(lamech.load("cylinder"), 3.0, initial={"theta1": 0.01})
    slip = next(e.t for e in traj.events if e.kind == "slip")
    rolling = lamech.to_json(traj)["reactions"]["rolling"]
    assert abs(rolling["at"]["t"] - slip) < 2 * (traj.t[1] - traj.t[0])
    assert rolling["at"]["t"] in traj.t
    assert rolling["peak"] == float(np.nanmax(traj.reactions()["rolling"]))
