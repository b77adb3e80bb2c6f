"""Massless bodies: a pulley with inertia but no mass, a massless rod, a massless point.

A body of mass 0 (or inertia 0) is the textbook idealisation; it is accepted whenever
the KKT matrix is regular (the constraints give every massless motion to something
with inertia) and refused with the coordinate named when it is not (tests/bad/76). Negative masses
and inertias stay refused (tests/bad/23 to 26).

Closed forms are checked against Newton's laws on each body, and simulations against
the same closed forms along the run.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import lamech
from lamech.cli import main

EXAMPLES = Path(lamech.__file__).resolve().parent / "examples"


# ------------------------------------------------------------- Atwood, massive pulley


@pytest.fixture(scope="module")
def pulley():
    return lamech.solve(lamech.load("atwood_pulley"))


def _pulley_answers(S):
    """a (m1's downward acceleration), T1, T2 by Newton on each mass and the pulley."""
    m1, m2, g, r, I = (S[k] for k in ("m1", "m2", "g", "r", "I"))
    a = (m1 - m2) * g / (m1 + m2 + I / r**2)
    return a, m1 * (g - a), m2 * (g + a)


def test_the_pulley_is_a_massless_body_with_inertia():
    system = lamech.load("atwood_pulley")
    pulley = next(b for b in system.bodies if b.name == "pulley")
    assert pulley.mass == 0 and pulley.inertia is not None
    assert system.parameter_values[system.symbols["I"]] > 0


def test_pulley_tensions_are_the_textbook_ones(pulley):
    """T1 = m1 (g - a), T2 = m2 (g + a), a = (m1 - m2) g / (m1 + m2 + I/r^2), with the
    parameters as symbols: the multipliers are the rope tensions."""
    S = pulley.symbols
    a, T1, T2 = _pulley_answers(S)
    assert sp.simplify(pulley.multipliers["rope1"] - T1) == 0
    assert sp.simplify(pulley.multipliers["rope2"] - T2) == 0
    assert sp.simplify(pulley.on_energy_shell["rope1"] - T1) == 0
    (eq,) = pulley.reduced_equations
    (acc,) = sp.solve(eq, S[pulley.independent[0] + "''"])
    expected = {"y1": -a, "y2": a, "phi": a / S["r"]}[pulley.independent[0]]
    assert sp.simplify(acc - expected) == 0
    # never slack: the tensions are constant and positive
    assert pulley.vanishes.get("rope1", []) == [] and pulley.vanishes.get("rope2", []) == []


def test_pulley_without_inertia_is_the_plain_atwood(pulley):
    S = pulley.symbols
    m1, m2, g = S["m1"], S["m2"], S["g"]
    for name in ("rope1", "rope2"):
        assert (
            sp.simplify(pulley.multipliers[name].subs(S["I"], 0) - 2 * m1 * m2 * g / (m1 + m2)) == 0
        )


def test_pulley_rope_forces_on_mass_and_rim(pulley):
    """The Cartesian force of each rope on its mass (the reaction on the massless pulley
    where the rope leaves the rim) is the tension, straight up, with no residual."""
    S = pulley.symbols
    _, T1, T2 = _pulley_answers(S)
    for name, T in (("rope1", T1), ("rope2", T2)):
        force = pulley.forces[name]
        assert sp.simplify(force["up"] - T) == 0
        assert sp.simplify(force["residual"]) == 0


def test_pulley_simulated_tensions_match_the_closed_form():
    system = lamech.load("atwood_pulley")
    tr = lamech.simulate(system, 0.5, samples=201)
    assert tr.status == "ok", tr.message
    values = {str(k): v for k, v in system.parameter_values.items()}
    m1, m2, g, r, I = (values[k] for k in ("m1", "m2", "g", "r", "I"))
    a = (m1 - m2) * g / (m1 + m2 + I / r**2)
    assert np.allclose(tr.multiplier("rope1"), m1 * (g - a), rtol=1e-9, atol=0)
    assert np.allclose(tr.multiplier("rope2"), m2 * (g + a), rtol=1e-9, atol=0)
    assert np.allclose(tr.forces["rope1:up"], m1 * (g - a), rtol=1e-9, atol=0)
    y1 = tr.coordinate("y1")
    assert np.allclose(y1, -values["l1"] - a * tr.t**2 / 2, rtol=0, atol=1e-10)
    assert np.max(tr.residual_position) <= 1e-10
    assert tr.energy_error is not None and tr.energy_error <= 1e-9


def test_pulley_solve_cli_prints_the_tensions(capsys):
    assert main(["solve", "atwood_pulley"]) == 0
    out = capsys.readouterr().out
    assert "rope1" in out and "rope2" in out


# ------------------------------------------------- a bob on a massless rod, by its pivot

ROD = """
title = "Bob on a massless rod, in the rod's centre coordinates"
[parameters]
m = 1.5
g = 9.81
l = 0.8
[coordinates]
x     = { initial = "l/2*sin(0.4)", velocity = 0 }
y     = { initial = "-l/2*cos(0.4)", velocity = 0 }
theta = { initial = 0.4, velocity = 0 }
[[constraints]]
name = "pin_x"
f = "x - l/2*sin(theta)"
force = { body = "rod", at = [0, 0], along = { horizontal = [1, 0] } }
[[constraints]]
name = "pin_y"
f = "y + l/2*cos(theta)"
force = { body = "rod", at = [0, 0], along = { vertical = [0, 1] } }
[[bodies]]
name = "rod"
mass = 0
position = ["x", "y"]
angle = "theta"
inertia = 0
shape = { rod = "l" }
[[bodies]]
name = "bob"
mass = "m"
position = ["x + l/2*sin(theta)", "y - l/2*cos(theta)"]
shape = { point = true }
[gravity]
acceleration = "g"
"""


@pytest.mark.slow
def test_pivot_force_on_a_massless_rod_is_what_the_bob_needs():
    """The rod is massless, so the pin's force on it at the pivot is the force the rod
    passes to the bob: m (a_bob + g y^) = T (-sin theta, cos theta), with the pendulum's
    T = m (g cos theta + l theta'^2)."""
    s = lamech.solve(lamech.loads(ROD, "rod.toml"))
    assert s.independent == ["theta"]
    S = s.symbols
    m, g, l, th, w = S["m"], S["g"], S["l"], S["theta"], S["theta'"]
    T = m * (g * sp.cos(th) + l * w**2)
    assert sp.simplify(s.forces["pin_x"]["horizontal"] - (-T * sp.sin(th))) == 0
    assert sp.simplify(s.forces["pin_y"]["vertical"] - T * sp.cos(th)) == 0
    for name in ("pin_x", "pin_y"):
        assert sp.simplify(s.forces[name]["residual"]) == 0
    (eq,) = s.reduced_equations
    (acc,) = sp.solve(eq, S["theta''"])
    assert sp.simplify(acc + g / l * sp.sin(th)) == 0


def test_pivot_force_on_a_massless_rod_along_a_run():
    system = lamech.loads(ROD, "rod.toml")
    tr = lamech.simulate(system, 2.0, samples=401)
    assert tr.status == "ok", tr.message
    m, g, l = 1.5, 9.81, 0.8
    th, w = tr.coordinate("theta"), tr.velocity("theta")
    T = m * (g * np.cos(th) + l * w**2)
    assert np.allclose(tr.forces["pin_x:horizontal"], -T * np.sin(th), rtol=0, atol=1e-8)
    assert np.allclose(tr.forces["pin_y:vertical"], T * np.cos(th), rtol=0, atol=1e-8)
    assert tr.energy_error is not None and tr.energy_error <= 1e-9


# --------------------------------------------------------- a massless attachment point

POINT = """
title = "Pendulum rod with a massless eye at its tip, held by a horizontal spring"
[parameters]
m = 2.0
g = 9.81
l = 1.2
k = 3.0
[coordinates]
theta = { initial = 0.3, velocity = 0 }
xp    = { initial = "l*sin(0.3)", velocity = 0 }
yp    = { initial = "-l*cos(0.3)", velocity = 0 }
[lagrangian]
T = "m*l^2/6*theta'^2"
V = "-m*g*l/2*cos(theta)"
[forces]
xp = "-k*xp"
[[constraints]]
name = "weld_x"
f = "xp - l*sin(theta)"
force = { body = "eye", at = ["xp", "yp"], along = { horizontal = [1, 0] } }
[[constraints]]
name = "weld_y"
f = "yp + l*cos(theta)"
force = { body = "eye", at = ["xp", "yp"], along = { vertical = [0, 1] } }
[[bodies]]
name = "rod"
mass = "m"
position = ["l/2*sin(theta)", "-l/2*cos(theta)"]
angle = "theta"
inertia = "m*l^2/12"
shape = { rod = "l" }
[[bodies]]
name = "eye"
mass = 0
position = ["xp", "yp"]
shape = { point = true }
"""


def test_force_at_a_massless_point_balances_the_load_on_it():
    """Nothing with mass is at the eye: the weld's force on it cancels the spring's,
    F = (k xp, 0) = (k l sin theta, 0), and the rod swings under gravity and the spring's
    torque, (m l^2/3) theta'' = -m g l/2 sin theta - k l^2 sin theta cos theta."""
    system = lamech.loads(POINT, "eye.toml")
    assert not system.notes, system.notes  # the bodies' T and V agree with [lagrangian]
    s = lamech.solve(system)
    assert s.independent == ["theta"]
    S = s.symbols
    m, g, l, k, th = S["m"], S["g"], S["l"], S["k"], S["theta"]
    assert sp.simplify(s.forces["weld_x"]["horizontal"] - k * l * sp.sin(th)) == 0
    assert sp.simplify(s.forces["weld_y"]["vertical"]) == 0
    (eq,) = s.reduced_equations
    (acc,) = sp.solve(eq, S["theta''"])
    expected = (-m * g * l / 2 * sp.sin(th) - k * l**2 * sp.sin(th) * sp.cos(th)) / (m * l**2 / 3)
    assert sp.simplify(acc - expected) == 0


# -------------------------------------------------------------------------- refusals

LONE = """
title = "A massless bead on a hoop, beside a sliding block"
[parameters]
m = 1.0
R = 0.5
[coordinates]
x   = { initial = 0, velocity = 1 }
phi = { initial = 0, velocity = 0 }
[[bodies]]
name = "block"
mass = "m"
position = ["x", 0]
shape = { point = true }
[[bodies]]
name = "bead"
mass = 0
position = ["R*cos(phi)", "R*sin(phi)"]
shape = { point = true }
"""


def test_a_massless_body_nothing_moves_is_refused_at_load():
    """The bead has no mass and no constraint ties it to the block: its angle has no
    inertia, and the file is refused at the bead's mass, naming the coordinate and the
    body (tests/bad/76 is the same through the corpus)."""
    with pytest.raises(lamech.ProblemFileError) as info:
        lamech.loads(LONE, "bead.toml")
    message = str(info.value)
    assert "bead.toml:16: bodies[2] `bead` mass" in message
    assert "coordinate `phi` has no inertia: it moves only the massless body `bead`" in message
    assert "missing prime" not in message


def test_a_zero_mass_parameter_is_checked_the_same_way():
    text = LONE.replace("R = 0.5\n", "R = 0.5\nmb = 0\n").replace("mass = 0", 'mass = "mb"')
    with pytest.raises(lamech.ProblemFileError, match="`phi` has no inertia"):
        lamech.loads(text, "bead.toml")
    # with a mass the same file is fine, and so is the bead tied to the block
    lamech.loads(text.replace("mb = 0", "mb = 0.1"), "bead.toml")
    tied = LONE.replace(
        "[[bodies]]", '[[constraints]]\nname = "tie"\nf = "x - R*phi"\n[[bodies]]', 1
    ).replace("velocity = 1", "velocity = 0")
    s = lamech.solve(lamech.loads(tied, "tied.toml"))
    assert s.multipliers["tie"] == 0  # nothing to push: the block coasts, the bead follows


def test_every_body_massless_says_so():
    text = (EXAMPLES / "atwood.toml").read_text(encoding="utf-8")
    text = text.replace('mass = "m1"', "mass = 0").replace('mass = "m2"', "mass = 0")
    with pytest.raises(lamech.ProblemFileError) as info:
        lamech.loads(text, "light.toml")
    message = str(info.value)
    assert "every body is massless" in message and "write velocities" not in message


def test_a_massless_body_nothing_moves_is_a_problem_file_error_in_the_cli(tmp_path, capsys):
    path = tmp_path / "bead.toml"
    path.write_text(LONE, encoding="utf-8")
    out = tmp_path / "o.csv"
    for command in (
        ["solve", str(path)],
        ["simulate", str(path), "--t-end", "0.1", "--out", str(out)],
    ):
        status = main(command)
        captured = capsys.readouterr()
        assert status == 2, (command, captured)
        assert captured.out == "" and "Traceback" not in captured.err
        assert captured.err.startswith("lamech: error in problem file\n")
        assert "bead.toml:16:" in captured.err and "`phi` has no inertia" in captured.err
    assert not out.exists()


def test_a_run_that_cannot_start_is_one_line(tmp_path, capsys):
    """A KKT matrix singular at the initial state in a way the file's checks do not
    look for (a T without phi' and no massless body): `simulate` says so in one line,
    naming the coordinate, and writes nothing; `solve` too."""
    text = LONE[: LONE.index("[[bodies]]")] + '[lagrangian]\nT = "m/2*x\'^2"\nV = "m*phi"\n'
    path = tmp_path / "typo.toml"
    path.write_text(text, encoding="utf-8")
    out = tmp_path / "o.csv"
    for command in (
        ["solve", str(path)],
        ["simulate", str(path), "--t-end", "0.1", "--out", str(out)],
    ):
        status = main(command)
        captured = capsys.readouterr()
        assert status == 2, (command, captured)
        lines = captured.err.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("lamech: "), captured.err
        assert "coordinate `phi` has no inertia" in lines[0]
    assert not out.exists()


def test_a_negative_mass_is_refused_and_zero_is_not():
    text = (EXAMPLES / "atwood_pulley.toml").read_text(encoding="utf-8")
    assert text.count("mass = 0\n") == 1
    lamech.loads(text, "zero.toml")
    with pytest.raises(lamech.ProblemFileError, match=r"mass: must be >= 0.*got -1"):
        lamech.loads(text.replace("mass = 0\n", "mass = -1\n"), "negative.toml")
    with pytest.raises(lamech.ProblemFileError, match=r"inertia: must be >= 0.*got -0\.02"):
        lamech.loads(text.replace('inertia = "I"', 'inertia = "-I"'), "negative.toml")


@pytest.mark.slow
def test_param_overrides_obey_the_same_rule(tmp_path, capsys):
    """--param sets a mass with the file's rules: a parameter that is 0 in the file may
    become positive but not negative (and a positive one keeps its sign: the file says
    so)."""
    text = (EXAMPLES / "atwood_pulley.toml").read_text(encoding="utf-8")
    path = tmp_path / "q.toml"
    path.write_text(
        text.replace("[parameters]\n", "[parameters]\nM = 0\n", 1).replace(
            "mass = 0\n", 'mass = "M"\n'
        ),
        encoding="utf-8",
    )
    out = str(tmp_path / "o.csv")
    assert main(["simulate", str(path), "--t-end", "0.05", "--param", "M=3", "--out", out]) == 0
    capsys.readouterr()
    assert main(["simulate", str(path), "--t-end", "0.05", "--param", "M=-1", "--out", out]) == 2
    err = capsys.readouterr().err
    assert "mass" in err and ">= 0" in err and "-1" in err
    assert main(["simulate", str(path), "--t-end", "0.05", "--param", "I=0", "--out", out]) == 2
    err = capsys.readouterr().err
    assert "sign" in err and "`I`" in err
