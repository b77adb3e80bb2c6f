"""``lamech modes`` never invents or misses an equilibrium (issue 43, section 2): every
equilibrium it reports is one of the equations as written (the KKT system solved at rest
here, apart from lamech's own test, gives q'' = 0), the ones on the branches of the
constraints the elimination did not take are found, and the frequencies are the
textbooks'. Nothing from generated code reaches the terminal."""

from __future__ import annotations

import math
import re
import warnings

import numpy as np
import pytest
import sympy as sp

import lamech
from lamech.cli import main

TAUTOCHRONE = """
title = "Huygens' tautochrone (parametric)"
[parameters]
m = 1.0
g = 9.81
a = 0.25
s0 = 1.5
[coordinates]
x = { initial = "a*(s0 + sin(s0))", velocity = 0 }
y = { initial = "a*(1 - cos(s0))", velocity = 0 }
s = { initial = "s0", velocity = 0 }
[lagrangian]
T = "m/2*(x'^2 + y'^2)"
V = "m*g*y"
[[constraints]]
name = "cx"
f = "x - a*(s + sin(s))"
[[constraints]]
name = "cy"
f = "y - a*(1 - cos(s))"
"""

BOWL = """
title = "Rod in a hemispherical bowl"
[parameters]
m = 1.0
g = 9.81
a = 0.6
r = 1.0
psi0 = 0.5
[coordinates]
x = { initial = "sqrt(r^2 - a^2)*sin(psi0)", velocity = 0 }
y = { initial = "-sqrt(r^2 - a^2)*cos(psi0)", velocity = 0 }
phi = { initial = "psi0", velocity = 0 }
[lagrangian]
T = "m/2*(x'^2 + y'^2) + m*a^2/6*phi'^2"
V = "m*g*y"
[[constraints]]
name = "left"
f = "r^2 - (x - a*cos(phi))^2 - (y - a*sin(phi))^2"
unilateral = true
[[constraints]]
name = "right"
f = "r^2 - (x + a*cos(phi))^2 - (y + a*sin(phi))^2"
unilateral = true
"""

TRAMMEL = """
title = "Cartesian trammel"
[parameters]
m = 1.0
g = 9.81
l = 1.0
[coordinates]
x = { initial = "0.6*l", velocity = 0 }
y = { initial = "0.8*l", velocity = 0 }
[lagrangian]
T = "m/2*(x'^2 + y'^2)"
V = "m*g*y"
[[constraints]]
name = "rod"
f = "x^2 + y^2 - l^2"
"""


def _values(system) -> dict[str, float]:
    return {p.name: p.numeric for p in system.parameters}


def kkt_at_rest(system, values: dict[str, float]) -> np.ndarray:
    """q'' of the KKT system [[M, -A^T], [A, 0]] [q'', lambda] = [Q - h, -gamma] at rest
    at ``values`` (every coordinate), from the derived matrices evaluated by SymPy and
    solved by NumPy: apart from lamech's own test in generated code."""
    dyn = lamech.dynamics(system)
    env = {p.symbol: sp.Float(p.numeric, 30) for p in system.parameters}
    env.update({c.symbol: sp.Float(values[c.name], 30) for c in system.coordinates})
    env.update({c.velocity: 0 for c in system.coordinates})
    env[system.t] = 0

    def num(M):
        return np.array(M.xreplace(env).evalf(30), dtype=float).reshape(M.shape)

    M, A = num(dyn.M), num(dyn.A)
    n, m = M.shape[0], A.shape[0]
    K = np.block([[M, -A.T], [A, np.zeros((m, m))]])
    rhs = np.concatenate([num(dyn.Q - dyn.h).ravel(), -num(dyn.gamma).ravel()])
    return np.linalg.solve(K, rhs)[:n]


def assert_every_equilibrium_rests(md, g: float) -> None:
    for e in md.equilibria:
        if e.exists:
            qdd = kkt_at_rest(md.system, e.values)
            assert np.abs(qdd).max() <= 1e-10 * g, (e.at, qdd)


def test_the_parametric_tautochrone_rests_at_the_bottom_with_omega_squared_g_over_4a(tmp_path):
    """s = 0 with omega^2 = g/(4a) (the cycloid's isochronous period); the cusp s = pi,
    where the reduced equations are 0/0 (dx/ds = dy/ds = 0) and the bead would slide
    off along the vertical tangent, is no equilibrium (it crashed with a traceback)."""
    system = lamech.loads(TAUTOCHRONE, "tautochrone.toml")
    p = _values(system)
    md = lamech.modes(system)
    assert [e.values["s"] for e in md.equilibria] == [0.0]
    (bottom,) = md.equilibria
    assert bottom.stability == "stable" and bottom.holds
    (mode,) = bottom.modes
    assert mode.frequency**2 == pytest.approx(p["g"] / (4 * p["a"]), rel=1e-12)
    S = {q.name: q.symbol for q in system.parameters}
    assert sp.simplify(mode.squared - S["g"] / (4 * S["a"])) == 0
    assert_every_equilibrium_rests(md, p["g"])


@pytest.mark.slow  # 2 s or more in the default set (2026-11-29)
def test_the_rod_in_a_bowl_rests_only_horizontal_at_the_bottom():
    """The rod (length 2a) with both ends on the bowl (radius r) rests horizontal at the
    bottom, y = -d, d = sqrt(r^2 - a^2), and rocks in the angle psi of its centre about
    the bowl's: T = m/2 (d^2 + a^2/3) psi'^2, V = -m g d cos psi, so
    omega^2 = g d / (d^2 + a^2/3). The rod stood on end at x = -4/5 (phi'' = 10.33 there)
    is not reported; every point reported is at rest by the KKT solve."""
    system = lamech.loads(BOWL, "bowl.toml")
    p = _values(system)
    md = lamech.modes(system)
    assert_every_equilibrium_rests(md, p["g"])
    assert not any(abs(abs(e.values["phi"]) - math.pi / 2) < 1e-6 for e in md.equilibria)
    d = math.sqrt(p["r"] ** 2 - p["a"] ** 2)
    holding = [e for e in md.equilibria if e.exists and e.holds]
    assert holding and all(
        e.values["x"] == pytest.approx(0, abs=1e-12)
        and e.values["y"] == pytest.approx(-d, rel=1e-12)
        and math.sin(e.values["phi"]) == pytest.approx(0, abs=1e-12)
        for e in holding
    )
    flat = next(e for e in holding if e.values["phi"] == pytest.approx(0, abs=1e-12))
    assert flat.stability == "stable"
    (mode,) = flat.modes
    omega2 = p["g"] * d / (d**2 + p["a"] ** 2 / 3)
    assert mode.frequency**2 == pytest.approx(omega2, rel=1e-10)
    # at the top of the (whole) circle the ends would have to be pulled: not held
    assert all(e.values["y"] < 0 for e in holding)


@pytest.mark.slow  # 2 s or more in the default set (2026-11-29)
def test_no_warning_from_generated_code_reaches_the_terminal(tmp_path, capfd, monkeypatch):
    """The numeric search evaluates generated functions where they are NaN (a square
    root of a negative number off the manifold): 18 kB of RuntimeWarning with the
    generated code reached stderr before the report. pytest records warnings instead of
    printing them, so the test asks Python to show each one, as a terminal would."""
    path = tmp_path / "bowl.toml"
    path.write_text(BOWL)
    monkeypatch.setenv("LAMECH_PROGRESS_AFTER", "1e9")  # no stage said, however busy the machine
    capfd.readouterr()
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        assert main(["modes", str(path)]) == 0
    out, err = capfd.readouterr()
    assert [str(w.message)[:200] for w in seen] == []
    assert err == "" and "Equilibrium 1: x = 0, y = -4/5, phi = 0" in out
    assert "lambdify" not in out


def test_the_trammel_hangs_stably_on_the_branch_the_elimination_did_not_take():
    """y is eliminated as +sqrt(l^2 - x^2) (the start is above); the search in x, y
    finds y = -l too: stable with omega^2 = g/l, and y = +l unstable with rate^2 = g/l."""
    system = lamech.loads(TRAMMEL, "trammel.toml")
    p = _values(system)
    md = lamech.modes(system)
    assert_every_equilibrium_rests(md, p["g"])
    assert sorted(e.values["y"] for e in md.equilibria) == [-1.0, 1.0]
    down = next(e for e in md.equilibria if e.values["y"] == -1.0)
    up = next(e for e in md.equilibria if e.values["y"] == 1.0)
    assert down.stability == "stable" and up.stability == "unstable"
    (mode,) = down.modes
    assert mode.frequency**2 == pytest.approx(p["g"] / p["l"], rel=1e-10)
    assert mode.shape["x"] == 1 and mode.shape["y"] == 0  # it swings in x
    assert down.multipliers["rod"] == pytest.approx(-p["m"] * p["g"] / (2 * p["l"]))
    assert down.linear.state == ("x", "x'")
    assert down.linear.A[1][0] == pytest.approx(-p["g"] / p["l"], rel=1e-10)
    assert "agrees" in down.check
    (grow,) = up.modes
    assert grow.growth**2 == pytest.approx(p["g"] / p["l"], rel=1e-10)


def test_simulate_mode_releases_the_trammel_about_its_hanging_equilibrium(tmp_path, capsys):
    """`simulate --mode` starts at the equilibrium on its own branch (the file starts
    above): released 0.05 from y = -l it swings at omega^2 = g/l, so after the four
    periods it runs it is back where it started (it fell from the top before)."""
    path = tmp_path / "trammel.toml"
    path.write_text(TRAMMEL)
    assert main(["simulate", str(path), "--mode", "1"]) == 0
    out = capsys.readouterr().out
    # the trammel is solved in its circle's angle: y = -l is its first equilibrium
    assert "x = 0, y = -1), amplitude 0.05" in out
    final = re.search(r"final state: x = (\S+), y = (\S+),", out)
    assert final is not None, out
    assert float(final.group(1)) == pytest.approx(0.05, abs=1e-5)
    assert float(final.group(2)) == pytest.approx(-math.sqrt(1 - 0.05**2), abs=1e-6)


def test_the_bundled_double_pendulum_in_its_chart_has_the_textbook_frequencies():
    """Cartesian bobs with results in the rods' angles (a [parametrisation]): hanging,
    omega^2 = (2 -+ sqrt 2) g/l for equal masses and rods, linearised in the angles (it
    stopped with "'theta1' is not in list"); every equilibrium at rest by the KKT solve."""
    system = lamech.load("double_pendulum")
    p = _values(system)
    md = lamech.modes(system)
    assert len(md.equilibria) == 4
    assert_every_equilibrium_rests(md, p["g"])
    down = next(e for e in md.equilibria if e.values["y2"] == pytest.approx(-2.0))
    assert down.stability == "stable"
    assert down.linear.state == ("theta1", "theta2", "theta1'", "theta2'")
    squares = sorted(m.frequency**2 for m in down.modes)
    g = p["g"]
    assert squares == pytest.approx([(2 - math.sqrt(2)) * g, (2 + math.sqrt(2)) * g], rel=1e-12)


PROBLEMS = __import__("pathlib").Path(__file__).parent / "problems"


@pytest.mark.slow  # 5 s
def test_a_cone_has_no_continuum_of_equilibria():
    """A particle on the cone z^2 = tan(be)^2 (x^2 + y^2): at rest anywhere but the apex
    gravity has a component along the surface (the KKT solve gives q'' != 0), and the apex
    is a singular point of the constraint (grad f = 0). The equations at rest have only
    complex families (x = +-i y) besides it: never "a continuum of equilibria"."""
    system = lamech.load(PROBLEMS / "cone_xyz.toml")
    p = _values(system)
    md = lamech.modes(system)
    assert "continuum" not in (md.reason or "") and not md.free
    # at most the apex, where the KKT matrix is singular (grad f = 0): not linearised
    for e in md.equilibria:
        assert max(abs(v) for v in e.values.values()) < 1e-12 and e.stability is None
    # the independent truth: at rest at a random point of either nappe, q'' != 0
    rng = np.random.default_rng(7)
    for _ in range(4):
        r, ang, side = rng.uniform(0.1, 2), rng.uniform(-3, 3), rng.choice([-1, 1])
        pt = {"x": r * math.cos(ang), "y": r * math.sin(ang), "z": side * r * math.tan(p["be"])}
        assert np.abs(kkt_at_rest(system, pt)).max() > 1e-3 * p["g"]


@pytest.mark.slow  # 4 s
def test_a_cart_with_a_pendulum_in_the_bobs_coordinates_gives_its_frequency():
    """The cart (mass Mc) rolls freely, so it rests anywhere: a continuum of equilibria
    along s (with xb = s), the zero mode of its drift. At the initial s the hanging
    pendulum oscillates with the textbook omega^2 = g (Mc + m)/(Mc l), the upright one
    grows at the same rate, and every equilibrium given rests by the KKT solve."""
    system = lamech.load(PROBLEMS / "cart_pendulum_xy.toml")
    p = _values(system)
    md = lamech.modes(system)
    assert md.free and "rests as well" in md.free
    assert_every_equilibrium_rests(md, p["g"])
    w2 = p["g"] * (p["Mc"] + p["m"]) / (p["Mc"] * p["l"])
    down = [e for e in md.equilibria if e.exists and e.values["yb"] == pytest.approx(-p["l"])]
    up = [e for e in md.equilibria if e.exists and e.values["yb"] == pytest.approx(p["l"])]
    assert len(down) == 1 and len(up) == 1
    assert down[0].stability == "marginal"  # the cart's free drift: a zero mode
    assert [m.frequency**2 for m in down[0].modes if m.frequency] == [pytest.approx(w2, rel=1e-10)]
    assert [m.growth**2 for m in up[0].modes if m.growth] == [pytest.approx(w2, rel=1e-10)]


@pytest.mark.slow  # 15 s: the rod in a bowl's modes
def test_an_equilibrium_found_numerically_prints_as_the_exact_number_it_is(capsys):
    """The rod (length 2b) in the bowl (radius Rb) rests horizontal at the bottom, its
    centre at yc = -sqrt(Rb^2 - b^2) (= -3 sqrt(21)/20 for b = 0.3, Rb = 0.75), found
    numerically: printed exactly as above the rim's +3 sqrt(21)/20 is, never as the
    17 digits -0.68738635424335826; with omega^2 = g d/(d^2 + b^2/3), d = sqrt(Rb^2 - b^2)."""
    path = PROBLEMS / "rod_in_small_bowl.toml"
    system = lamech.load(path)
    p = _values(system)
    md = lamech.modes(system)
    d = math.sqrt(p["Rb"] ** 2 - p["b"] ** 2)
    bottom = [e for e in md.equilibria if e.exists and e.values["yc"] == pytest.approx(-d)]
    assert bottom
    for e in bottom:
        assert (
            sp.simplify(
                sp.sympify(e.at["yc"]) + sp.sqrt(sp.Rational(3, 4) ** 2 - sp.Rational(3, 10) ** 2)
            )
            == 0
        )
        assert e.stability == "stable"
        (mode,) = e.modes
        assert mode.frequency**2 == pytest.approx(p["g"] * d / (d**2 + p["b"] ** 2 / 3), rel=1e-9)
    assert_every_equilibrium_rests(md, p["g"])
    assert main(["modes", str(path)]) == 0
    heads = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("Equilibrium")]
    assert heads and not any(re.search(r"\d{13}", ln) for ln in heads), heads


def test_a_bead_on_a_helix_has_no_equilibrium_and_no_free_direction_claimed():
    """Down a helix x = Rh cos(s), y = Rh sin(s), z = p s the bead accelerates at rest
    with z'' = -g p^2/(Rh^2 + p^2) (the KKT solve, here): no equilibrium anywhere, so
    not "every value of z rests as well"."""
    system = lamech.load(PROBLEMS / "helix_bead.toml")
    p = _values(system)
    qdd = kkt_at_rest(system, {"x": p["Rh"], "y": 0.0, "z": 0.0, "s": 0.0})
    assert qdd[2] == pytest.approx(-p["g"] * p["p"] ** 2 / (p["Rh"] ** 2 + p["p"] ** 2))
    md = lamech.modes(system)
    assert md.equilibria == () and not md.free
    assert "rests as well" not in str(md)


def test_a_sphere_in_its_angles_rests_at_its_poles_with_the_azimuth_free():
    """The particle on the sphere X^2 + Y^2 + Z^2 = Rs^2 in the sphere's angles (as
    --angles gives it): the azimuth phi is free (no force along it at rest) and is an
    angle of the chart, not of the file (it stopped with StopIteration looking for its
    initial value among the file's coordinates); bottom stable, omega^2 = G/Rs; the top
    unstable; both at rest by the KKT solve."""
    from lamech.model import circle_chart, with_chart

    system = lamech.load(PROBLEMS / "sphere_outside.toml")
    charted = with_chart(system, circle_chart(system))
    p = _values(system)
    md = lamech.modes(charted)
    assert md.free and "phisurface" in md.free
    assert_every_equilibrium_rests(md, p["G"])
    by_z = {round(e.values["Z"], 9): e for e in md.equilibria if e.exists}
    assert set(by_z) == {-p["Rs"], p["Rs"]}
    assert by_z[-p["Rs"]].stability != "unstable" and by_z[p["Rs"]].stability == "unstable"
    w2 = [m.frequency**2 for m in by_z[-p["Rs"]].modes if m.frequency]
    assert w2 and all(x == pytest.approx(p["G"] / p["Rs"], rel=1e-10) for x in w2)
