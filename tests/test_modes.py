"""Small oscillations (``lamech modes``): equilibria, stability, frequencies and mode
shapes, each checked against its textbook closed form or against the simulated motion."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import sympy as sp
from test_whole_manifold import CARTESIAN_PENDULUM as CARTESIAN

import lamech
from lamech.cli import main
from lamech.model import with_values

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


@pytest.mark.slow
def test_the_lectures_cylinder_on_top_is_unstable_with_the_textbook_growth_rate():
    system = lamech.load("cylinder")
    md = lamech.modes(system)
    p = _values(system)
    top = _by_position(md, theta1=0.0)
    assert top.stability == "unstable" and top.holds
    (mode,) = top.modes
    assert mode.growth == pytest.approx(
        math.sqrt(2 * p["g"] / (3 * (p["R1"] + p["R2"]))), rel=1e-12
    )
    g, R1, R2 = (
        next(q.symbol for q in system.parameters if q.name == n) for n in ("g", "R1", "R2")
    )
    assert sp.simplify(mode.squared + 2 * g / (3 * (R1 + R2))) == 0
    # rolling ties the wheel's turn to the centre's: (R1 + R2) theta1 = R2 theta2
    ratio = p["R2"] / (p["R1"] + p["R2"])
    assert mode.shape["theta1"] / mode.shape["theta2"] == pytest.approx(ratio)
    assert mode.shape["r"] == 0
    assert not _by_position(md, theta1=math.pi).holds  # under the cylinder: it falls off


@pytest.mark.slow
def test_the_spun_bead_rests_off_the_axis_only_when_the_hoop_spins_fast_enough():
    system = lamech.load("hoop_bead")
    p = _values(system)
    md = lamech.modes(system)
    theta0 = math.acos(p["g"] / (p["omega"] ** 2 * p["R"]))
    side = _by_position(md, theta=theta0)
    assert side.condition == "g/(R*omega^2) <= 1" and side.stability == "stable"
    (mode,) = side.modes
    assert mode.frequency**2 == pytest.approx(p["omega"] ** 2 * math.sin(theta0) ** 2, rel=1e-10)
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


@pytest.mark.slow
def test_double_pendulum_frequencies_are_two_plus_minus_root_two_g_over_l():
    system = lamech.loads(DOUBLE, "double.toml")
    md = lamech.modes(system)
    assert len(md.equilibria) == 4  # each bob up or down
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


@pytest.mark.slow
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


@pytest.mark.slow
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


@pytest.mark.slow
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
    assert "--at: `phi` is not an independent coordinate or its velocity; these are: theta" in err
    with pytest.raises(ValueError, match=r"`at=`: `phi` is not an independent coordinate"):
        lamech.modes(lamech.load("pendulum"), at={"phi": 1.0})


# SymPy's documented example (doc/src/modules/physics/mechanics/linearize.rst, "Nonminimal
# Coordinates Pendulum", Lagrange's method): q1 along gravity, q2 across, the rod kept as
# the constraint q1^2 + q2^2 = L^2; hanging at q1 = L its linearisation with q2
# independent is A = [[0, 1], [-g/L, 0]].
NONMINIMAL = """
title = "SymPy's non-minimal pendulum"
[parameters]
m = 1.0
g = 9.8
L = 1.3
[coordinates]
q1 = { initial = 1.3, velocity = 0 }
q2 = { initial = 0, velocity = 0 }
[lagrangian]
T = "m/2*(q1'^2 + q2'^2)"
V = "-m*g*q1"
[[constraints]]
name = "rod"
f = "q1^2 + q2^2 - L^2"
"""


def _sympy_linearizer_A(g, L, m):
    """SymPy's own answer, by its documented recipe."""
    from sympy.physics.mechanics import (
        LagrangesMethod,
        Lagrangian,
        Particle,
        Point,
        ReferenceFrame,
        dynamicsymbols,
    )

    q1, q2 = dynamicsymbols("q1:3")
    q1d, q2d = dynamicsymbols("q1:3", level=1)
    t = dynamicsymbols._t
    N = ReferenceFrame("N")
    pN = Point("N*")
    pN.set_vel(N, 0)
    P = pN.locatenew("P1", q1 * N.x + q2 * N.y)
    P.set_vel(N, P.pos_from(pN).dt(N))
    pP = Particle("pP", P, m)
    LM = LagrangesMethod(
        Lagrangian(N, pP),
        [q1, q2],
        hol_coneqs=sp.Matrix([q1**2 + q2**2 - L**2]),
        forcelist=[(P, m * g * N.x)],
        frame=N,
    )
    LM.form_lagranges_equations()
    op = {q1: L, q2: 0, q1d: 0, q2d: 0, q1d.diff(t): 0, q2d.diff(t): 0}
    op.update(LM.solve_multipliers(op))
    lin = LM.to_linearizer(q_ind=[q2], qd_ind=[q2d], q_dep=[q1], qd_dep=[q1d])
    A, _ = lin.linearize(op_point=op, A_and_B=True)
    return np.array(A.evalf(), dtype=float)


@pytest.mark.slow
def test_linearisation_equals_sympys_linearizer_on_its_documented_pendulum():
    system = lamech.loads(NONMINIMAL, "nonminimal.toml")
    md = lamech.modes(system)
    down = _by_position(md, q1=1.3, q2=0.0)
    lin = down.linear
    assert lin.state == ("q2", "q2'")
    assert np.allclose(lin.A, [[0, 1], [-9.8 / 1.3, 0]], atol=1e-12)
    assert np.allclose(lin.A, _sympy_linearizer_A(9.8, 1.3, 1.0), atol=1e-12)
    # at rest the rod pulls with m g; with f = q1^2 + q2^2 - L^2 the multiplier is
    # -m g / (2 L) (grad f = 2 q), unchanged to first order (the hanging point is a minimum)
    assert down.multipliers["rod"] == pytest.approx(-9.8 / (2 * 1.3), rel=1e-12)
    assert np.allclose(lin.multipliers["rod"], [0, 0], atol=1e-12)


@pytest.mark.slow
def test_non_holonomic_linearisation_has_fewer_velocities_than_positions():
    """The rolling disc at rest (theta = 0): four positions, two free velocities
    (theta', phi'), and the rolling ties y' = -a phi' (x' = a sin(theta) phi' = 0)."""
    system = lamech.load("vertical_disk")
    a = _values(system)["a"]
    (e,) = lamech.modes(system, at={"x": 0, "y": 0, "theta": 0, "phi": 0}).equilibria
    lin = e.linear
    assert lin.state == ("x", "y", "theta", "phi", "theta'", "phi'")
    expected = np.zeros((6, 6))
    expected[1, 5] = -a  # y' = -a phi'
    expected[2, 4] = expected[3, 5] = 1
    assert np.allclose(lin.A, expected, atol=1e-12)
    assert e.stability == "marginal" and all(abs(m.eigenvalue) < 1e-6 for m in e.modes)
    # the knife edge: the blade forbids y' at phi = 0
    (k,) = lamech.modes(lamech.load("knife_edge"), at={"x": 0, "y": 0, "phi": 0}).equilibria
    assert k.linear.state == ("x", "y", "phi", "x'", "phi'")


def test_a_mass_on_a_turning_table_rests_at_the_relative_equilibrium():
    """r* = k r0/(k - m Omega^2), omega^2 = k/m - Omega^2, and to first order the groove's
    torque is the Coriolis 2 m r* Omega dr' (rotating_table's textbook answers)."""
    system = lamech.load("rotating_table")
    p = _values(system)
    S = {q.name: q.symbol for q in system.parameters}
    (e,) = lamech.modes(system).equilibria
    m, k, r0, W = S["m"], S["k"], S["r0"], S["Omega"]
    assert sp.simplify(e.at["r"] - k * r0 / (k - m * W**2)) == 0
    r_star = p["k"] * p["r0"] / (p["k"] - p["m"] * p["Omega"] ** 2)
    (mode,) = e.modes
    assert sp.simplify(mode.squared - (k / m - W**2)) == 0
    assert mode.frequency == pytest.approx(math.sqrt(p["k"] / p["m"] - p["Omega"] ** 2))
    assert e.linear.state == ("r", "r'")
    assert e.linear.multipliers["drive"] == pytest.approx((0, 2 * p["m"] * r_star * p["Omega"]))


@pytest.mark.slow
def test_the_linearised_multiplier_follows_the_simulated_one():
    """Independent truth: the simulated bead near the spun hoop's side equilibrium, its
    hoop force against lambda_0 + c . (dtheta, dtheta') from the linearisation."""
    system = lamech.load("hoop_bead")
    p = _values(system)
    theta0 = math.acos(p["g"] / (p["omega"] ** 2 * p["R"]))
    side = _by_position(lamech.modes(system), theta=theta0)
    c = np.array(side.linear.multipliers["hoop"])
    assert side.linear.state == ("theta", "theta'") and abs(c[0]) > 1
    amp = 1e-4
    start = with_values(system, initial={"theta": theta0 + amp})
    traj = lamech.simulate(start, 2.0, samples=401, rtol=1e-11, atol=1e-13)
    dth = traj.coordinate("theta") - theta0
    dthd = traj.velocity("theta")
    predicted = side.multipliers["hoop"] + c[0] * dth + c[1] * dthd
    lam = traj.multiplier("hoop")
    assert np.abs(lam - predicted).max() < 1e-6 * abs(side.multipliers["hoop"])  # second order
    assert np.abs(lam - side.multipliers["hoop"]).max() > 1e-4  # it does move


TRIPLE = (
    DOUBLE.replace('title = "Double pendulum"', 'title = "Triple pendulum"').replace(
        "th2 = { initial = 0.1, velocity = 0 }",
        "th2 = { initial = 0.1, velocity = 0 }\nth3 = { initial = 0.1, velocity = 0 }",
    )
    + """
[[bodies]]
name = "bob3"
mass = "m"
position = ["l*sin(th1) + l*sin(th2) + l*sin(th3)", "-l*cos(th1) - l*cos(th2) - l*cos(th3)"]
"""
)


def _spectral_peaks(t, x, count):
    """The ``count`` strongest angular frequencies in x(t): Hann-windowed FFT, each peak
    refined by a parabola through the log-magnitudes of its bin and neighbours."""
    dt = t[1] - t[0]
    spec = np.abs(np.fft.rfft((x - x.mean()) * np.hanning(len(x))))
    w = 2 * np.pi * np.fft.rfftfreq(len(x), dt)
    interior = np.nonzero((spec[1:-1] > spec[:-2]) & (spec[1:-1] > spec[2:]))[0] + 1
    out = []
    for i in sorted(interior, key=lambda i: -spec[i])[:count]:
        a, b, c = np.log(spec[i - 1 : i + 2])
        out.append(w[i] + 0.5 * (a - c) / (a - 2 * b + c) * (w[1] - w[0]))
    return sorted(out)


@pytest.mark.slow
def test_the_triple_pendulums_frequencies_are_the_peaks_of_its_simulated_spectrum():
    """Independent truth: released at rest with all three angles at 0.01 rad, the
    simulated triple pendulum's th1 has its spectral peaks at the three predicted
    frequencies (also the textbook's: omega^2 l/g are the roots of
    x^3 - 9 x^2 + 18 x - 6 = 0 for equal masses and lengths)."""
    system = lamech.loads(TRIPLE, "triple.toml")
    md = lamech.modes(system)
    assert len(md.equilibria) == 8  # each bob up or down
    down = _by_position(md, th1=0.0, th2=0.0, th3=0.0)
    assert down.stability == "stable"
    predicted = sorted(m.frequency for m in down.modes)
    textbook = sorted(np.sqrt(9.81 * np.roots([1, -9, 18, -6]).real))
    assert predicted == pytest.approx(textbook, rel=1e-10)
    start = with_values(system, initial={"th1": 0.01, "th2": 0.01, "th3": 0.01})
    traj = lamech.simulate(start, 120.0, samples=12001, rtol=1e-10, atol=1e-12)
    seen = _spectral_peaks(traj.t, traj.coordinate("th1"), 3)
    assert seen == pytest.approx(predicted, rel=1e-3)  # bin width 0.052 rad/s, refined


@pytest.mark.slow
def test_simulate_mode_releases_the_system_along_one_mode(capsys, tmp_path):
    """`lamech simulate --mode 1` on the turning table: r starts at r* + 0.05 at rest and,
    after the default four periods of omega = sqrt(k/m - Omega^2), is back there."""
    csv = tmp_path / "table.csv"
    assert main(["simulate", "rotating_table", "--mode", "1", "--out", str(csv)]) == 0
    out = capsys.readouterr().out
    assert out.startswith("released at rest along mode 1 (omega = 1.6 rad/s) of equilibrium 1")
    data = np.genfromtxt(csv, delimiter=",", names=True)
    r_star = 4.0 * 0.5 / (4.0 - 1.2**2)
    assert data["t"][-1] == pytest.approx(4 * 2 * math.pi / 1.6)
    assert data["r"][0] == pytest.approx(r_star + 0.05, rel=1e-12)
    assert data["r"][-1] == pytest.approx(r_star + 0.05, rel=1e-6)
    assert data["r"].min() == pytest.approx(r_star - 0.05, rel=1e-4)  # linear: symmetric


@pytest.mark.slow
def test_simulate_mode_and_end_time_errors(capsys):
    assert main(["simulate", "pendulum", "--mode", "2"]) == 2
    assert "mode 2: this equilibrium has modes 1 to 1" in capsys.readouterr().err
    assert main(["simulate", "pendulum"]) == 2
    assert "give the end time: --t-end T (or --mode K" in capsys.readouterr().err
    assert main(["simulate", "pendulum", "--t-end", "1", "--equilibrium", "1"]) == 2
    assert "give --mode K too" in capsys.readouterr().err
    assert main(["simulate", "pendulum", "--mode", "1", "--equilibrium", "3"]) == 2
    assert "`lamech modes` finds 2 equilibria" in capsys.readouterr().err


@pytest.mark.slow
def test_frequencies_agree_with_det_k_minus_omega_squared_m_on_the_tangent_space():
    """The physical check, from the Euler-Lagrange equations before elimination, is made
    and passes where it applies (scleronomic holonomic constraints, no velocity terms);
    it is not claimed for the spun hoop (rheonomic: a relative equilibrium)."""
    for system in (
        lamech.loads(TRIPLE, "triple.toml"),
        lamech.loads(NONMINIMAL, "n.toml"),
        lamech.load("cylinder"),
        lamech.loads(CARTESIAN, "cart.toml"),
    ):
        for e in lamech.modes(system).equilibria:
            assert e.check.startswith(
                "omega^2 from det(K - omega^2 M) = 0 on the tangent space agrees"
            ), (system.title, e.values)
    assert all(e.check is None for e in lamech.modes(lamech.load("hoop_bead")).equilibria)


@pytest.mark.slow
def test_the_spherical_pendulum_rests_at_every_azimuth_and_its_pole_is_singular(capsys):
    md = lamech.modes(lamech.load("spherical_pendulum"))
    assert md.free.startswith("every value of phi rests as well")
    bottom = _by_position(md, theta=0.0)
    assert bottom.stability is None and bottom.modes == ()  # not a wrong answer: none
    assert main(["modes", "spherical_pendulum"]) == 0
    assert "these coordinates are singular here" in capsys.readouterr().out


@pytest.mark.slow
def test_the_tangent_check_reports_a_disagreement(solved_example):
    from lamech.symbolic import Mode
    from lamech.symbolic._modes import check_modes

    sol = solved_example("pendulum")
    down = _by_position(lamech.modes(sol), theta=0.0)
    assert check_modes(sol, down) == down.check
    wrong = [Mode(complex(0, 2.0), 2.0, None, {})]  # omega^2 = 4, not g/l = 9.81
    verdict = check_modes(sol, down, wrong)
    assert verdict.startswith("DISAGREES") and "omega^2 = 9.81" in verdict


CARTESIAN_DOUBLE = """
title = "Double pendulum in Cartesian coordinates"
[parameters]
m = 1.0
g = 9.81
l = 1.0
[coordinates]
x1 = { initial = 0.6, velocity = 0 }
y1 = { initial = -0.8, velocity = 0 }
x2 = { initial = 1.2, velocity = 0 }
y2 = { initial = -1.6, velocity = 0 }
[lagrangian]
T = "m/2*(x1'^2 + y1'^2 + x2'^2 + y2'^2)"
V = "m*g*(y1 + y2)"
[[constraints]]
name = "rod1"
f = "l - sqrt(x1^2 + y1^2)"
[[constraints]]
name = "rod2"
f = "l - sqrt((x2 - x1)^2 + (y2 - y1)^2)"
"""


@pytest.mark.slow
def test_the_cartesian_double_pendulum_is_solved_numerically_in_four_unknowns():
    """Four coordinates and two rods (circles: solved in their angles); hanging, it
    swings in x1, x2 (the file's coordinates regular there) at (2 +- sqrt 2) g/l like
    the angle form."""
    md = lamech.modes(lamech.loads(CARTESIAN_DOUBLE, "cdp.toml"))
    assert sorted((round(e.values["y1"], 9), round(e.values["y2"], 9)) for e in md.equilibria) == [
        (-1, -2),
        (-1, 0),
        (1, 0),
        (1, 2),
    ]
    down = _by_position(md, x1=0.0, y1=-1.0, x2=0.0, y2=-2.0)
    assert down.stability == "stable" and down.linear.state == ("x1", "x2", "x1'", "x2'")
    squares = sorted(m.frequency**2 for m in down.modes)
    assert squares == pytest.approx([(2 - math.sqrt(2)) * 9.81, (2 + math.sqrt(2)) * 9.81])
    assert down.multipliers == pytest.approx({"rod1": 2 * 9.81, "rod2": 9.81})
    assert "agrees" in down.check


@pytest.mark.slow
def test_the_conical_pendulum_is_linearised_about_its_steady_motion(capsys):
    """--at with a velocity: the spherical pendulum going round at theta0 with
    phi'^2 = g/(l cos(theta0)) is a fixed point of the reduced motion; it nods at
    omega^2 = phi'^2 (1 + 3 cos^2(theta0)) (by hand: theta'' = sin cos phi'^2 - (g/l) sin
    with sin^2(theta) phi' conserved), theta and phi a quarter period apart."""
    th0 = 0.5
    spin = math.sqrt(9.81 / math.cos(th0))
    system = lamech.load("spherical_pendulum")
    (e,) = lamech.modes(system, at={"theta": th0, "phi": 0.0, "phi'": spin}).equilibria
    assert e.note is None and e.values["phi'"] == pytest.approx(spin)
    nod = next(m for m in e.modes if m.frequency)
    assert nod.frequency**2 == pytest.approx(spin**2 * (1 + 3 * math.cos(th0) ** 2), rel=1e-10)
    assert abs(abs(nod.phases["theta"] - nod.phases["phi"]) - 90) < 1e-6
    assert e.check is None  # not at rest: the K, M check does not apply
    assert (
        main(
            ["modes", "spherical_pendulum", "--at", "theta=0.5", "--at", "phi=0", "--at", "phi'=1"]
        )
        == 0
    )
    assert "not a steady state: there the accelerations are theta'' = " in capsys.readouterr().out


def test_modes_print_as_the_cli_shows_them_and_repr_in_one_line(capsys):
    md = lamech.modes(lamech.load("pendulum"))
    text = str(md)
    assert text == lamech.to_text(md)
    assert text.startswith("Small oscillations: Simple pendulum")
    assert "Equilibrium 1: theta = 0" in text and "omega^2 = g/l" in text
    assert main(["modes", "pendulum"]) == 0
    assert capsys.readouterr().out.strip() == text.strip()
    short = repr(md)
    assert short.startswith('<Modes of "Simple pendulum') and "\n" not in short
    assert "2 equilibria (1 stable)" in short and len(short) < 200, short
    assert repr(md.equilibria[0]) == "<Equilibrium theta = 0: stable, 1 mode>"


CART_T = ("M/2*X'^2 + m/2*((X' + r'*sin(theta) + r*cos(theta)*theta')^2"
          " + (r*sin(theta)*theta' - r'*cos(theta))^2)")  # fmt: skip


def _cart_pendulum(M: float, m: float, length: float, free_first: bool = True) -> str:
    """A pendulum (bob m on a rod of length l, ``l - r = 0`` as a user writes it) hanging
    from a cart M that slides freely on a horizontal rail; theta from the downward
    vertical."""
    cart = "X     = { initial = 0, velocity = 0 }\n"
    rest = 'r     = { initial = "l", velocity = 0 }\ntheta = { initial = 0.3, velocity = 0 }\n'
    coords = cart + rest if free_first else rest + cart
    return f"""
title = "Pendulum on a free cart"

[parameters]
M = {M}
m = {m}
g = 9.81
l = {length}

[coordinates]
{coords}
[lagrangian]
T = "{CART_T}"
V = "-m*g*r*cos(theta)"

[[constraints]]
name = "rod"
f = "l - r"
"""


# ----- values assigned to coordinates by name, never by position -------------------------
# The truth, by hand: with r = l the Lagrangian is
#   L = (M + m)/2 X'^2 + m l cos(theta) X' theta' + m l^2/2 theta'^2 + m g l cos(theta);
# X is cyclic, (M + m) X' + m l cos(theta) theta' = const, and about theta = 0 (pi) the
# linearised theta'' = -(+) g (M + m) / (M l) dtheta: omega^2 = g (M + m)/(M l) hanging,
# the same number as the square of the growth rate inverted. The r equation,
# d/dt dL/dr' - dL/dr - lambda df/dr = 0 with df/dr = -1, at rest gives
# lambda = dL/dr = m g cos(theta): +m g hanging, -m g inverted.


@pytest.mark.parametrize(
    "M, m, L, free_first",
    [pytest.param(3.0, 0.5, 0.7, True, marks=pytest.mark.slow), (2.0, 1.0, 1.0, False)],
)
def test_the_cart_pendulum_hangs_stably_and_is_unstable_inverted(M, m, L, free_first):
    g = 9.81
    md = lamech.modes(lamech.loads(_cart_pendulum(M, m, L, free_first)))
    rate2 = g * (M + m) / (M * L)
    by_theta = {}
    for e in md.equilibria:
        assert e.exists and e.holds
        # the label and the values say the same configuration
        for name, value in e.at.items():
            assert e.values[name] == pytest.approx(float(value), abs=1e-12), (name, e.at)
        by_theta[round(e.values["theta"], 9)] = e
    assert sorted(by_theta) == [0.0, round(math.pi, 9)]
    hanging, inverted = by_theta[0.0], by_theta[round(math.pi, 9)]
    assert hanging.values["X"] == inverted.values["X"] == 0.0
    assert hanging.stability == "stable" or hanging.stability == "marginal"  # X drifts freely
    omegas = [mo.frequency for mo in hanging.modes if mo.frequency is not None]
    assert len(omegas) == 1 and omegas[0] == pytest.approx(math.sqrt(rate2), rel=1e-12)
    assert not any(mo.growth for mo in hanging.modes)
    assert hanging.multipliers["rod"] == pytest.approx(m * g, rel=1e-12)
    assert inverted.stability == "unstable"
    growth = [mo.growth for mo in inverted.modes if mo.growth is not None]
    assert len(growth) == 1 and growth[0] == pytest.approx(math.sqrt(rate2), rel=1e-12)
    assert not any(mo.frequency for mo in inverted.modes)
    assert inverted.multipliers["rod"] == pytest.approx(-m * g, rel=1e-12)
    # the mode's shape: the momentum (M + m) dX' + m l dtheta' = 0 kept zero
    shape = next(mo for mo in hanging.modes if mo.frequency).shape
    assert shape["X"] / shape["theta"] == pytest.approx(-m * L / (M + m), rel=1e-12)


@pytest.mark.slow
def test_cli_modes_of_the_cart_pendulum_at_the_inverted_position(tmp_path, capsys):
    path = tmp_path / "cart.toml"
    path.write_text(_cart_pendulum(2.0, 1.0, 1.0), encoding="utf-8")
    assert main(["modes", str(path), "--at", "X=0", "--at", "theta=pi"]) == 0
    out = capsys.readouterr().out
    assert "theta = 3.14159" in out and "lambda_rod = -9.81" in out
    assert f"grows: rate {math.sqrt(9.81 * 3 / 2):.6g} /s" in out
    assert main(["modes", str(path)]) == 0
    out = capsys.readouterr().out
    assert "Equilibrium 2: X = 0, theta = pi" in out
    assert "at the values: X = 0, r = 1, theta = 3.14159" in out
