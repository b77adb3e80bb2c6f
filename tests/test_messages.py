"""The library's messages name its arguments (`` `max_step=` ``); the command line says
its flags (``--max-step``) for the same messages (the command line's terms module). And
where a file is valid but probably not what its author meant (issue 43, section 5), a
word: a bilateral contact whose multiplier changes sign, gravity's sign, a T that
disagrees with the bodies, an angle in degrees written as radians. A mistake is named
(a missing prime, a typo) and a file name never reaches the terminal as control codes."""

from __future__ import annotations

import dataclasses
import json
import math
import re
import subprocess
import sys
from pathlib import Path

import pytest
import sympy

import lamech
from lamech.cli import main
from lamech.cli._terms import FLAGS, in_flags


@pytest.mark.parametrize(
    "library, command",
    [
        ("a smaller `max_step=`, and check", "a smaller --max-step, and check"),
        ("give a point with `at=` to linearise", "give a point with --at to linearise"),
        ('try Radau or BDF (`method="Radau"`)', "try Radau or BDF (--method Radau)"),
        ("or use `project_initial=True`", "or use --project-initial"),
        ("`params=` `mu` differs", "--param `mu` differs"),
        ("run without `resume=True` to start", "run without --resume to start"),
        # a constraint or coordinate in backticks is a name, not an argument
        ("`string` f = -0.001; `at` and `theta`", "`string` f = -0.001; `at` and `theta`"),
        # a keyword the command has no flag for stays as the library says it
        (
            "`path=` x.txt: the format follows the suffix",
            "`path=` x.txt: the format follows the suffix",
        ),
        (
            "`c` is a circle: `with_chart(system, circle_chart(system))` (from lamech.model) gives",
            "`c` is a circle: `--angles` gives",
        ),
    ],
)
def test_the_command_renders_the_librarys_keywords_as_flags(library, command):
    assert in_flags(library) == command


def test_every_flag_named_exists_on_the_command_line(capsys):
    helps = ""
    for command in ("solve", "modes", "simulate", "sweep"):
        with pytest.raises(SystemExit):
            main([command, "--help"])
        helps += capsys.readouterr().out
    assert [f for f in FLAGS.values() if not re.search(rf"{f}\b", helps)] == []


def test_an_initial_state_off_the_constraints_in_both_terms(capsys):
    with pytest.raises(lamech.SimulationError) as exc:
        lamech.simulate(lamech.load("pendulum"), 1.0, q0={"r": 1.001})
    assert str(exc.value).endswith("fix the initial values or use `project_initial=True`")
    assert main(["simulate", "pendulum", "--initial", "r=1.001", "--t-end", "1"]) == 2
    err = capsys.readouterr().err
    assert err.rstrip().endswith("fix the initial values or use --project-initial")
    assert "project_initial" not in err


@pytest.mark.parametrize("command", ["simulate", "sweep"])
def test_the_help_states_the_library_s_own_default_tolerances(command, capsys):
    """The command line cannot import the numeric layer to ask (it starts without NumPy),
    so its help spells the defaults: they must be the library's (one default an option)."""
    from lamech.numeric._options import DEFAULT_ATOL, DEFAULT_RTOL

    with pytest.raises(SystemExit):
        main([command, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert f"relative tolerance (default {DEFAULT_RTOL:g};" in text
    assert f"absolute tolerance (default {DEFAULT_ATOL:g})" in text


# ----- issue 43, section 5: silent where a user needs a word ---------------------------
SPHERE = """
title = "Particle on a smooth sphere, the contact written bilateral"
[parameters]
m = 1.0
g = 9.81
R = 1.0
theta0 = {theta0}
[coordinates]
r = {{ initial = "R", velocity = 0 }}
theta = {{ initial = "theta0", velocity = 0 }}
[lagrangian]
T = "m/2*(r'^2 + r^2*theta'^2)"
V = "m*g*r*cos(theta)"
[[constraints]]
name = "surface"
f = "{f}"
"""


def _sign_change_notes(sol) -> list[str]:
    return [n for n in sol.notes if "changes sign along the motion" in n]


@pytest.mark.parametrize("theta0", [0.3, 0.7])
def test_a_bilateral_contact_whose_multiplier_changes_sign_says_where(theta0, tmp_path, capsys):
    """Released at rest at theta0 from the top of a smooth sphere, the particle presses on
    it with m g (3 cos(theta) - 2 cos(theta0)) (energy: v^2 = 2 g R (cos(theta0) -
    cos(theta)), radial: m g cos(theta) - N = m v^2/R), zero where cos(theta) =
    2 cos(theta0)/3: a contact written bilateral (unilateral = true forgotten) says so."""
    text = SPHERE.format(theta0=theta0, f="r - R")
    [note] = _sign_change_notes(lamech.solve(lamech.loads(text, "sphere.toml")))
    assert "`surface` is bilateral" in note and "cos(theta) = 2*cos(theta0)/3" in note
    found = re.search(r"theta = ([-+0-9.e]+) \(([-0-9.]+)°\)", note)
    assert found, note
    truth = math.acos(2 / 3 * math.cos(theta0))
    assert float(found.group(1)) == pytest.approx(truth, rel=0, abs=1e-9)
    assert float(found.group(2)) == pytest.approx(math.degrees(truth), abs=0.005)
    assert "would let go there" in note and "unilateral = true" in note
    # written the other way round (lambda < 0 at the start) it changes sign at the same place
    [other] = _sign_change_notes(
        lamech.solve(lamech.loads(SPHERE.format(theta0=theta0, f="R - r")))
    )
    assert float(re.search(r"theta = ([-+0-9.e]+)", other).group(1)) == pytest.approx(truth)
    # and the note is in --json's notes
    path = tmp_path / "sphere.toml"
    path.write_text(text, encoding="utf-8")
    assert main(["solve", "--json", str(path)]) == 0
    assert json.loads(capsys.readouterr().out)["notes"] == [note]


def test_a_unilateral_contact_and_a_multiplier_of_one_sign_get_no_such_note():
    """With unilateral = true the lift-off is reported where it belongs; a bilateral
    multiplier that keeps its sign (the pendulum's tension from theta0 = 0.3) is not
    remarked on."""
    text = SPHERE.format(theta0=0.3, f="r - R").replace(
        'f = "r - R"', 'f = "r - R"\nunilateral = true'
    )
    sol = lamech.solve(lamech.loads(text))
    assert _sign_change_notes(sol) == []
    assert sol.lets_go["surface"].when == "at the roots"
    hanging = SPHERE.format(theta0=0.3, f="r - R").replace("m*g*r*cos", "-m*g*r*cos")
    assert _sign_change_notes(lamech.solve(lamech.loads(hanging))) == []


FLOOR = """
title = "Block on a floor"
[parameters]
m = 2.0
g = 9.81
[coordinates]
x = { initial = 0, velocity = 1 }
y = { initial = 0, velocity = 0 }
[lagrangian]
T = "m/2*(x'^2 + y'^2)"
V = "VALUE"
[[constraints]]
name = "floor"
f = "y"
unilateral = true
"""


def _gravity_notes(system) -> list[str]:
    return [n for n in system.notes if "is its sign right?" in n]


def test_gravity_that_pulls_up_is_questioned():
    """V = -m g y with y up: at rest the block would accelerate upward (y'' = +g with the
    floor gone, the reduced equation below), and the floor "lets go at the start" for
    that reason alone. The warning names the coordinate, the slope and its value."""
    system = lamech.loads(FLOOR.replace("VALUE", "-m*g*y"))
    [note] = _gravity_notes(system)
    assert "`y`" in note and "dV/dy = -g*m = -19.62" in note
    assert "accelerate towards larger y, upward if y is measured up" in note
    assert "+g*m*y" in note
    assert lamech.solve(system).lets_go["floor"].when == "at the start"
    free = lamech.solve(lamech.loads(FLOOR.split("[[constraints]]")[0].replace("VALUE", "-m*g*y")))
    [y] = [c for c in free.system.coordinates if c.name == "y"]
    assert free.closed.accelerations[y.acceleration] == sympy.Symbol("g", positive=True)
    # y measured down, as the body's position says: lamech's own V from [gravity] is
    # -m*g*y and right; the same V without the [gravity] that made it is questioned
    free = FLOOR.split("[[constraints]]")[0].replace("VALUE", "-m*g*y")
    body = '[[bodies]]\nname = "block"\nmass = "m"\nposition = ["x", "-y"]\n'
    made = lamech.loads(free + body + '[gravity]\nacceleration = "g"\n')
    assert _gravity_notes(made) == []
    assert len(_gravity_notes(dataclasses.replace(made, gravity=None))) == 1
    # the right sign, a slope that is not a weight, and a weight through a sum: no word
    for V in ("m*g*y", "-m*g*y*x", "-(m + 1)*g*y", "-m*y", "m*g*(y + x/2)"):
        assert _gravity_notes(lamech.loads(FLOOR.replace("VALUE", V))) == [], V


@pytest.mark.slow  # loads the 25 examples: 5 s
def test_gravity_is_not_questioned_in_any_bundled_example():
    """The 25 examples load without the warning: the incline's m g (n cos(alpha) - s
    sin(alpha)) has a sine in its slope, and V made from the bodies is lamech's own."""
    names = lamech.example_names()
    assert len(names) == 25
    assert [n for n in names if _gravity_notes(lamech.load(n))] == []


def test_a_zero_mass_the_constraints_carry_is_a_warning_and_one_nothing_carries_an_error():
    """Atwood's machine with m2 = 0: y2 has no inertia but the string carries it, so the
    accelerations exist (m1 falls freely: y1'' = -g, the tension 2 g m1 m2/(m1 + m2) = 0)
    and the warning names m2; a block on a spring with m = 0 cannot move at all: refused
    at m's line (tests/bad/132-zero-mass-parameter.toml), naming m and x."""
    text = """
title = "Atwood, one mass typed as 0"
[parameters]
m1 = 1.0
m2 = 0
g = 9.81
l = 2.0
[coordinates]
y1 = { initial = 0.5, velocity = 0 }
y2 = { initial = 1.5, velocity = 0 }
[lagrangian]
T = "m1/2*y1'^2 + m2/2*y2'^2"
V = "m1*g*y1 + m2*g*y2"
[[constraints]]
name = "string"
f = "l - y1 - y2"
"""
    system = lamech.loads(text)
    [note] = [n for n in system.notes if "is 0 and is the mass of" in n]
    assert note.startswith("parameter `m2` is 0 and is the mass of `y2`")
    assert "give `m2` its value" in note
    sol = lamech.solve(system)
    assert sol.initial_multipliers["string"] == 0
    assert [n for n in sol.notes if "changes sign" in n] == []  # lambda = 0 throughout
    # the same T with m2 > 0 says nothing
    assert [n for n in lamech.loads(text.replace("m2 = 0", "m2 = 2.0")).notes if "mass" in n] == []
    with pytest.raises(lamech.ProblemFileError) as info:
        lamech.loads(text.split("[[constraints]]")[0], "x.toml")
    assert "x.toml:5: parameters.m2: parameter `m2` = 0 is the mass of `y2`" in str(info.value)


def test_a_polar_radius_held_negative_is_refused_and_one_that_starts_negative_is_not(
    tmp_path, capsys
):
    """tests/bad/135: the cylinder inside a trough of radius 0.5 with its own radius typed
    as 10 (centimetres) is refused at the contact's line, never given a lift-off. With
    R2 = 0.1 it loads; so does a bead on a turntable's rod that starts at r = -0.3 (the
    rod's other half: r is not held by a constraint); and --param cannot make it so."""
    bad = (Path(__file__).parent / "bad" / "135-negative-polar-radius.toml").read_text("utf-8")
    with pytest.raises(lamech.ProblemFileError, match=r"R1 - R2 = -9\.5 < 0"):
        lamech.loads(bad)
    good = tmp_path / "trough.toml"
    good.write_text(bad.replace("R2 = 10\n", "R2 = 0.1\n"), encoding="utf-8")
    lamech.load(good)
    table = (Path(lamech.__file__).parent / "examples" / "rotating_table.toml").read_text("utf-8")
    lamech.loads(table.replace("initial = 0.8,", "initial = -0.3,"))
    for f in ('"l - r"', '"r - l"'):  # a string or a rod of length l = -1
        text = SPHERE.format(theta0=0.3, f="r - R").replace('"r - R"', f.replace("l", "R"))
        with pytest.raises(lamech.ProblemFileError, match=r"holds `r` at R = -1 < 0"):
            lamech.loads(text.replace("R = 1.0", "R = -1.0"))
    assert main(["solve", str(good), "--param", "R2=10"]) == 2
    assert "holds `r` at R1 - R2 = -9.5 < 0" in capsys.readouterr().err


# ----- issue 48: one rule for the names a friction coefficient goes by ----------------
def test_params_sweep_and_with_values_know_the_same_names():
    from lamech.model import with_values

    cylinder = lamech.load("cylinder")
    said = []
    for attempt in (
        lambda: with_values(cylinder, parameters={"R3": 1.0}),
        lambda: lamech.simulate(cylinder, 0.1, params={"R3": 1.0}),
        lambda: lamech.sweep(cylinder, {"R3": [1.0]}, t_end=0.1),
    ):
        with pytest.raises(ValueError) as info:
            attempt()
        said.append(str(info.value).partition("unknown parameter")[2])
    assert said[0] == said[1] == said[2] == " `R3`; known: m, g, R1, R2, mu:rolling, mu"


PENDULUM = lamech.problem.example_path("pendulum").read_text(encoding="utf-8")


@pytest.mark.slow
def test_a_velocity_missing_from_T_is_named(tmp_path):
    """T = m/2 (r'^2 + r^2 theta^2): a forgotten prime leaves theta without inertia; the
    solve names it instead of crashing in SymPy (SymPy 1.14 has no
    sympy.NonInvertibleMatrixError at the top level)."""
    text = PENDULUM.replace("r^2*theta'^2", "r^2*theta^2")
    assert text != PENDULUM
    system = lamech.loads(text, "noprime.toml")
    with pytest.raises(lamech.DegenerateConstraintsError) as info:
        lamech.solve(system)
    message = str(info.value)
    assert "`theta'` does not appear in T" in message and "missing prime" in message
    path = tmp_path / "noprime.toml"
    path.write_text(text, encoding="utf-8")
    out = subprocess.run(
        [sys.executable, "-m", "lamech", "solve", str(path)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 2 and "Traceback" not in out.stderr
    assert "missing prime" in out.stderr


@pytest.mark.slow
def test_a_T_that_disagrees_with_the_bodies_is_a_warning_at_the_top():
    """The README promises that lamech says so when [lagrangian] and [[bodies]]
    disagree: first thing in the report, not a last note."""
    text = PENDULUM.replace("r^2*theta'^2", "r*theta'^2")
    assert text != PENDULUM
    report = lamech.to_text(lamech.solve(lamech.loads(text, "x.toml")))
    head = report.splitlines()[:5]
    assert any(
        line.startswith("warning: [lagrangian] T differs from the kinetic energy") for line in head
    ), head


@pytest.mark.slow
def test_simulate_warns_first_and_writes_into_new_folders(tmp_path):
    """The T/[[bodies]] disagreement is said by simulate too, before anything else; the
    README's `--out out/traj.csv` creates out/."""
    path = tmp_path / "t.toml"
    path.write_text(PENDULUM.replace("r^2*theta'^2", "r*theta'^2"), encoding="utf-8")
    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "lamech",
            "simulate",
            str(path),
            "--t-end",
            "0.2",
            "--samples",
            "5",
            "--out",
            str(tmp_path / "out" / "t.csv"),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 0, out.stderr
    assert out.stderr.splitlines()[0].startswith("lamech: warning: [lagrangian] T differs")
    assert len((tmp_path / "out" / "t.csv").read_text().splitlines()) == 6


@pytest.mark.slow
def test_control_characters_in_a_file_name_are_escaped(tmp_path, monkeypatch, capsys):
    """A file name (or title, or key) cannot clear the screen or recolour the terminal."""
    from lamech.cli import main

    monkeypatch.chdir(tmp_path)
    assert main(["solve", "no\x1b[2Jwhere.toml"]) == 2
    err = capsys.readouterr().err
    assert "no\\x1b[2Jwhere.toml: no such file" in err and "\x1b" not in err
    # a message from solving, not loading: the same
    singular = PENDULUM.replace(
        "T = \"m/2*(r'^2 + r^2*theta'^2)\"", "T = \"m/2*(r' + theta')^2\""
    ).replace('f = "l - r"', 'f = "l - r - theta + theta0"')
    assert singular != PENDULUM
    (tmp_path / "bad\x1b[31m.toml").write_text(singular, encoding="utf-8")
    assert main(["solve", "bad\x1b[31m.toml"]) == 2
    err = capsys.readouterr().err
    assert "lamech: bad\\x1b[31m.toml: " in err and "\x1b" not in err


PENDULUM_TEXT = PENDULUM


# ----- messages that mislead -------------------------------------------------------------
def test_a_typo_in_a_bodys_position_is_the_only_problem_reported(tmp_path, capsys):
    path = tmp_path / "typo.toml"
    path.write_text(
        'title = "typo"\n[parameters]\nm = 1.0\ng = 9.81\nl = 1.0\n[coordinates]\n'
        "theta = { initial = 0.3, velocity = 0 }\n"
        '[[bodies]]\nname = "bob"\nmass = "m"\nposition = ["l*sin(theta)", "-l*cos(thta)"]\n'
        '[gravity]\nacceleration = "g"\n',
        encoding="utf-8",
    )
    assert main(["solve", str(path)]) == 2
    err = capsys.readouterr().err
    assert "unknown name `thta`" in err and ":11:" in err
    assert "no [[bodies]]" not in err and "missing" not in err


# ----- a word where a user needs one -----------------------------------------------------
@pytest.mark.parametrize(
    "written, shown",
    [
        ("theta_dot", "unknown name `theta_dot`"),
        ("dtheta", "unknown name `dtheta`"),
        ("thetadot", "unknown name `thetadot`"),
        ("theta.", "syntax error at `theta.`"),
        ("theta.dot", "`theta.dot`"),
    ],
)
def test_a_velocity_written_another_way_is_answered_with_the_prime(written, shown):
    text = PENDULUM_TEXT.replace("r^2*theta'^2", f"r^2*{written}^2")
    with pytest.raises(lamech.ProblemFileError) as err:
        lamech.loads(text)
    message = str(err.value)
    assert shown in message and "a velocity is written with a prime: `theta'`" in message
    assert "lagrangian.T" in message


def test_a_released_pendulum_through_its_pivot_says_the_polar_chart_is_singular():
    # upside down at rest, the string slack: the bob falls freely through the pivot,
    # reached after sqrt(2 l / g); there theta's inertia m r^2 vanishes
    tr = lamech.simulate(
        lamech.load("pendulum"), 3.0, initial={"theta": 3.14159265}, engine="scipy"
    )
    assert tr.status == "failed"
    assert "`theta` has no inertia there: its mass matrix entry m*r^2 vanishes as r -> 0" in (
        tr.message
    )
    assert "the pole of the polar" in tr.message and "Cartesian coordinates" in tr.message
    assert "dependent constraints" not in tr.message
    assert tr.final_time == pytest.approx(math.sqrt(2 * 1.0 / 9.81), abs=1e-4)


def _degree_warnings(notes) -> list[str]:
    return [n for n in notes if "If " in n and "degrees were meant" in n]


@pytest.mark.slow
def test_an_angle_of_whole_degrees_written_as_radians_is_said_once(capsys):
    disk = lamech.problem.example_path("incline_disk").read_text(encoding="utf-8")
    system = lamech.loads(disk.replace("alpha = 0.5", "alpha = 30"))
    said = _degree_warnings(system.notes)
    assert len(said) == 1 and said[0].startswith("parameter `alpha` is 30, an angle in ")
    assert said[0].endswith(
        "where angles are in radians: 30 rad is 4.77 turns. If 30 degrees were meant, write "
        "30*pi/180 (= 0.523599)"
    )
    assert main(["solve", "pendulum", "--initial", "theta=45"]) == 0
    out = capsys.readouterr().out
    assert out.count("If 45 degrees were meant, write 45*pi/180 (= 0.785398)") == 1
    run = lamech.simulate("pendulum", 0.1, samples=3, initial={"theta": 45})
    assert len(_degree_warnings(run.notes)) == 1 and "`theta` is 45" in run.notes[0]
    # radians, a frequency in cos(w t), and new values that are radians: nothing said
    assert _degree_warnings(lamech.simulate("pendulum", 0.1, samples=3).notes) == []
    shaken = lamech.problem.example_path("moving_support").read_text(encoding="utf-8")
    assert _degree_warnings(lamech.loads(shaken.replace("w = 3.0", "w = 30")).notes) == []
    again = lamech.model.with_values(system, parameters={"alpha": 0.5})
    assert _degree_warnings(again.notes) == []


def test_friction_on_a_bilateral_normal_is_said_to_mean_little():
    text = lamech.problem.example_path("cylinder").read_text(encoding="utf-8")
    bilateral = lamech.loads(text.replace("unilateral = true\n", "", 1))
    notes = [n for n in bilateral.notes if "bilateral" in n]
    assert len(notes) == 1
    assert notes[0].startswith("friction `rolling` takes its normal force from `contact`")
    assert "unilateral = true" in notes[0]
    assert not any("bilateral" in n for n in lamech.load("cylinder").notes)


@pytest.mark.slow
def test_a_force_named_on_one_of_the_two_bodies_it_joins_says_which_to_name():
    text = lamech.problem.example_path("moving_support").read_text(encoding="utf-8")
    one = lamech.solve(lamech.loads(text.replace('body = ["bob", "cart"]', 'body = "bob"')))
    assert one.forces["string"]["residual"] != 0
    said = [n for n in one.notes if n.startswith("`string` joins")]
    assert said == [
        "`string` joins `bob` and `cart` (it moves both): its force named on `bob` alone "
        "leaves a residual, and its components are not the force; name both, body = "
        '["bob", "cart"] (the force on the second is the opposite), and the residual is 0'
    ]
    # (named on both, as the bundled file does, the residual is 0: tests/test_examples.py)


_PROBLEMS = Path(__file__).parent / "problems"


def _leaves_the_sphere_at(R: float, g: float, theta0: float) -> float:
    """When a particle released at rest at theta0 from the top of a smooth sphere reaches
    cos(theta) = 2 cos(theta0)/3 (where the normal force m g (3 cos(theta) - 2
    cos(theta0)) is 0), from theta'' = g sin(theta)/R integrated by SciPy: independent
    of lamech."""
    from scipy.integrate import solve_ivp

    def at(t, y):
        return math.cos(y[0]) - 2 * math.cos(theta0) / 3

    at.terminal = True
    run = solve_ivp(lambda t, y: [y[1], g / R * math.sin(y[0])], (0, 10), [theta0, 0.0],
                    events=at, rtol=1e-12, atol=1e-12)  # fmt: skip
    return float(run.t_events[0][0])


def test_a_bilateral_sphere_in_x_y_z_says_when_its_multiplier_changes_sign(capsys):
    """On the sphere X^2 + Y^2 + Z^2 = Rs^2 (z up, unilateral = true forgotten), released
    at rest near the top: two degrees of freedom, so solve has no energy shell to say it
    from; simulate sees lambda change sign along the motion and says when, and where a
    contact would let go. The time is the textbook's, cos(theta) = 2 cos(theta0)/3."""
    path = _PROBLEMS / "sphere_outside.toml"
    system = lamech.load(path)
    p = {s.name: s.numeric for s in system.parameters}
    truth = _leaves_the_sphere_at(p["Rs"], p["G"], p["a0"])
    traj = lamech.simulate(system, 1.2)
    [note] = [n for n in traj.notes if "changes sign" in n]
    assert "`surface` is bilateral" in note and "unilateral = true" in note
    found = re.search(r"at t = ([-+0-9.e]+)", note)
    assert found, note
    assert float(found.group(1)) == pytest.approx(truth, abs=1e-6)
    assert main(["simulate", str(path), "--t-end", "1.2"]) == 0
    assert "changes sign" in capsys.readouterr().out
    # a multiplier that keeps its sign (the hanging spherical pendulum) is not remarked on
    hanging = lamech.simulate(lamech.load(_PROBLEMS / "sphere_cartesian.toml"), 1.2)
    assert [n for n in hanging.notes if "changes sign" in n] == []


def test_a_parametric_curve_written_as_constraints_gets_no_let_go_note():
    """A bead on a helix written x - Rh cos(s), y - Rh sin(s), z - p s: the first two
    define x and y along the wire; their multipliers are the wire's force components,
    which change sign as the bead turns (by the KKT solve at two points of the motion,
    here), but no string or contact is there to let go: no note (it said "(it is -0 at
    the start) ... a string or a one-sided contact would let go there")."""
    from lamech.symbolic import dynamics
    from lamech.symbolic._derive import kkt_numeric

    path = _PROBLEMS / "helix_bead.toml"
    sol = lamech.solve(lamech.load(path))
    dyn = dynamics(sol.system)
    pv = sol.system.parameter_values
    P = {s.name: s.numeric for s in sol.system.parameters}
    signs = set()
    for s in (0.5, 4.0):  # at rest at two points of the wire
        env = {**pv, sol.system.t: 0.0}
        vals = (P["Rh"] * math.cos(s), P["Rh"] * math.sin(s), P["p"] * s, s)
        env.update(zip(sol.system.q, vals))
        env.update({v: 0.0 for v in sol.system.qd})
        _, lam = kkt_numeric(dyn, env)
        signs.add(math.copysign(1, float(lam[0])))
    assert signs == {-1.0, 1.0}  # lambda_cx does change sign
    assert [n for n in sol.notes if "changes sign" in n] == []
    assert "-0 " not in str(sol)


def test_a_start_condition_no_positive_parameters_meet_is_not_offered():
    """Gravity written with the wrong sign: the floor's multiplier at the start is -g m,
    negative for every positive g and m (the KKT solve at the start, here, gives -g m
    too), so "stays on at the start while -g*m >= 0" offers a condition nothing meets:
    it is not printed; the verdict stays "at the start"."""
    from lamech.symbolic import dynamics
    from lamech.symbolic._derive import kkt_numeric

    system = lamech.loads(FLOOR.replace("VALUE", "-m*g*y"))
    env = {**system.parameter_values, system.t: 0.0}
    env.update({c.symbol: 0.0 for c in system.coordinates})
    env.update({c.velocity: 0.0 for c in system.coordinates})
    _, lam = kkt_numeric(dynamics(system), env)
    assert float(lam[0]) == pytest.approx(-2.0 * 9.81)
    sol = lamech.solve(system)
    verdict = sol.lets_go["floor"]
    assert verdict.when == "at the start" and verdict.condition is None
    assert "stays on at the start while" not in str(sol)
    # the right sign: the floor never lets go
    assert (
        lamech.solve(lamech.loads(FLOOR.replace("VALUE", "m*g*y"))).lets_go["floor"].when == "never"
    )


def test_a_start_velocity_into_the_second_contact_points_at_its_line():
    """Two balls on a floor, the first rising off it (allowed: it opens), the second
    moving into it: the error names `floor2` and shows floor2's line, not floor1's (the
    index was counted among the contacts still closed)."""
    text = """title = "Two balls"
[parameters]
m = 1.0
g = 9.81
[coordinates]
y1 = { initial = 0, velocity = 1 }
y2 = { initial = 0, velocity = -1 }
[lagrangian]
T = "m/2*(y1'^2 + y2'^2)"
V = "m*g*(y1 + y2)"
[[constraints]]
name = "floor1"
f = "y1"
unilateral = true
[[constraints]]
name = "floor2"
f = "y2"
unilateral = true
"""
    with pytest.raises(lamech.ProblemFileError) as info:
        lamech.loads(text, "two.toml")
    message = str(info.value)
    assert "`floor2`" in message and "df/dt = -1" in message
    assert "two.toml:17: constraints[2] `floor2`" in message, message
    assert 'f = "y2"' in message
