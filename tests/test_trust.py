"""Every answer right or plainly refused: regression tests for failures found by trying
lamech as a new user would (each failed before its fix)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

import lamech

PENDULUM = lamech.problem.example_path("pendulum").read_text(encoding="utf-8")


def _closed_pipe_run(args: list[str]) -> subprocess.CompletedProcess:
    """Run ``lamech ARGS`` with its standard output a pipe nobody reads (closed)."""
    read, write = os.pipe()
    os.close(read)
    try:
        return subprocess.run(
            [sys.executable, "-m", "lamech", *args],
            stdout=write,
            stderr=subprocess.PIPE,
            text=True,
            timeout=120,
        )
    finally:
        os.close(write)


@pytest.mark.parametrize(
    "args", [["examples"], pytest.param(["solve", "pendulum"], marks=pytest.mark.slow)]
)
def test_a_closed_pipe_ends_quietly(args):
    out = _closed_pipe_run(args)
    assert "Traceback" not in out.stderr and "BrokenPipeError" not in out.stderr
    assert out.returncode == 141


@pytest.mark.slow
def test_sweep_into_a_closed_pipe_ends_quietly():
    out = _closed_pipe_run(
        [
            "sweep",
            "pendulum",
            "--param",
            "l=0.5,1",
            "--measure",
            "max:lambda:string",
            "--t-end",
            "0.2",
            "--samples",
            "3",
            "--workers",
            "1",
        ]
    )
    assert "Traceback" not in out.stderr and "BrokenPipeError" not in out.stderr
    assert out.returncode == 141


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


# ----- "does it roll at all?", "does it leave at once?": answered, not "never" ----------
def _verdicts(text: str):
    s = lamech.solve(lamech.loads(text, "x.toml"))
    return s, lamech.to_text(s)


@pytest.mark.slow
def test_a_disk_that_slips_at_once_says_so_with_the_rolling_condition():
    """tan(alpha) > 3 mu: the friction a rolling disk needs (m g sin(alpha)/3) exceeds
    mu N (N = m g cos(alpha)) from the first instant."""
    base = lamech.problem.example_path("incline_disk").read_text(encoding="utf-8")
    text = base.replace("mu = 0.3", "mu = 0.05")
    assert text != base
    s, report = _verdicts(text)
    v = s.slipping["rolling"]
    assert v.when == "at the start"
    alpha = s.system.parameter_values[s.symbols["alpha"]]
    import math

    assert f"= {math.tan(alpha) / 3:.6g} > mu = 0.05" in v.reason
    assert v.condition == "mu >= tan(alpha)/3"
    assert "rolling: at the start" in report and "never" not in report.split("slip")[1][:80]
    rolls = lamech.solve(lamech.load("incline_disk")).slipping["rolling"]
    assert rolls.when == "never" and rolls.constant  # mu = 0.3 >= tan(alpha)/3


def test_a_string_written_the_wrong_way_round_is_flagged():
    text = PENDULUM.replace('f = "l - r"', 'f = "r - l"')
    assert text != PENDULUM
    s, report = _verdicts(text)
    v = s.lets_go["string"]
    g, m, theta0 = (s.system.parameter_values[s.symbols[n]] for n in ("g", "m", "theta0"))
    import math

    assert v.when == "at the start"
    assert f"= {-m * g * math.cos(theta0):.6g} < 0" in v.reason  # minus the tension
    assert "wrong way round" in v.hint and "wrong way round" in report
    assert "never" not in report.split("lets go")[1][:200]


def test_a_particle_too_fast_on_top_of_the_sphere_leaves_at_once():
    """m v^2/R > m g at the top: the sphere would have to pull; it lets go at t = 0."""
    base = lamech.problem.example_path("sphere_slide").read_text(encoding="utf-8")
    text = base.replace(
        "theta = { initial = 0, velocity = 0 }", "theta = { initial = 0, velocity = 4 }"
    )
    assert text != base
    s, report = _verdicts(text)
    v = s.lets_go["contact"]
    g, m, R = (s.system.parameter_values[s.symbols[n]] for n in ("g", "m", "R"))
    assert v.when == "at the start" and v.hint is None  # moving: no sign suspicion
    assert f"= {m * g - m * R * 16:.6g} < 0" in v.reason
    assert "contact: at the start" in report
    # the condition as a student states it (m R theta'0^2 <= m g, theta'0 = 4): m dropped
    assert v.condition == "g >= 16*R"


@pytest.mark.parametrize(
    "name, constraint, expected",
    [
        pytest.param(
            "wedge",
            "contact",
            lambda p: (
                p["M"]
                * p["m"]
                * p["g"]
                * __import__("math").cos(p["alpha"])
                / (p["M"] + p["m"] * __import__("math").sin(p["alpha"]) ** 2)
            ),
            marks=pytest.mark.slow,
        ),
        ("incline_disk", "contact", lambda p: p["m"] * p["g"] * __import__("math").cos(p["alpha"])),
    ],
)
def test_a_constant_positive_multiplier_never_lets_go(name, constraint, expected):
    """The block on a movable wedge keeps N = M m g cos(a)/(M + m sin^2 a) (textbook); a
    disk rolling down an incline N = m g cos(a): 'never', with the constant, not 'not
    determined'."""
    s = lamech.solve(lamech.load(name))
    v = s.lets_go[constraint]
    p = {k.name: x for k, x in s.system.parameter_values.items()}
    assert v.when == "never" and v.constant
    assert f"= {expected(p):.6g} > 0" in v.reason
    assert f"{constraint}: never (lambda_{constraint} is constant" in lamech.to_text(s)


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
def test_equations_are_simplified_as_a_student_would():
    """The driven pendulum's equations had (2 sin^2 + 2 cos^2)/2 left in them; the
    readable form is the derived one, simplified (the difference simplifies to 0)."""
    import sympy as sp

    s = lamech.solve(lamech.load("moving_support"))
    text = lamech.to_text(s)
    assert "sin(theta)^2 + 2*cos(theta)^2" not in text
    for shown, derived in zip(s.equations, s.dynamics.equations):
        assert sp.simplify(shown - derived) == 0
    assert sum(sp.count_ops(e) for e in s.equations) < 0.5 * sum(
        sp.count_ops(e) for e in s.dynamics.equations
    )


@pytest.mark.slow
def test_the_html_animation_works_offline_and_is_small(tmp_path):
    """It loaded an icon font from a CDN (blank buttons offline) and was 13.5 MB for
    1.5 s of motion with 300 frames whatever the length."""
    from lamech.present import animate

    system = lamech.load("cylinder")
    traj = lamech.simulate(system, 1.5, initial={"theta1": 0.3}, samples=301)
    page = animate(traj, system, tmp_path / "m.html").read_text(encoding="utf-8")
    assert "http://" not in page and "https://" not in page
    assert 'class="fa ' not in page
    assert (tmp_path / "m.html").stat().st_size < 2_000_000
    assert page.count("data:image/jpeg") == 2 * 20 + 1  # 2 s of play at 20 frames/s
    gif = animate(traj, system, tmp_path / "m.gif", duration=1.0, fps=10)
    from PIL import Image

    with Image.open(gif) as im:
        assert im.n_frames == 11


def test_velocities_render_with_dots_in_jupyter(solved_example):
    """A multiplier shown raw in a notebook (SymPy's LaTeX) reads l m theta-dot^2, not
    theta'^{2}; the text form keeps the file grammar."""
    import sympy as sp

    s = solved_example("pendulum")
    latex = sp.latex(s.multipliers["string"])
    assert latex == r"g m \cos{\left(\theta \right)} + l m \dot{\theta}^{2}"
    assert lamech.to_text(s).count("theta'^2") >= 1
    assert r"\ddot{r}" in sp.latex(s.equations[0])


@pytest.mark.slow
def test_solve_takes_param_and_initial_like_simulate():
    """`lamech solve` had no --param/--initial. With them, the cylinder started at
    theta1 = 0.01 leaves at cos(theta1) = 4/7 cos(0.01) (closed form) and slips where the
    simulation's slip event is (an independent integration)."""
    import json
    import math

    out = subprocess.run(
        [
            sys.executable,
            "-m",
            "lamech",
            "solve",
            "cylinder",
            "--initial",
            "theta1=0.01",
            "--param",
            "mu=0.1",
            "--json",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert out.returncode == 0, out.stderr
    j = json.loads(out.stdout)
    assert abs(j["vanishes"]["contact"][0]["value"] - math.acos(4 / 7 * math.cos(0.01))) < 1e-9
    slip = j["slips"]["rolling"][0]["value"]
    traj = lamech.simulate(
        lamech.load("cylinder"), 3.0, initial={"theta1": 0.01}, params={"mu": 0.1}, samples=3
    )
    event = next(e for e in traj.events if str(e.kind) == "slip")
    assert abs(event.coordinates["theta1"] - slip) < 1e-8
    bad = subprocess.run(
        [sys.executable, "-m", "lamech", "solve", "pendulum", "--param", "m=-1"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert bad.returncode == 2 and "sign" in bad.stderr and "Traceback" not in bad.stderr


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


# ----- item 1: landing while slipping ------------------------------------------------
LOOP = """
title = "Solid disk inside a vertical loop"
[parameters]
m = 1.0
g = 9.81
R = 1.0
a = 0.2
w0 = 5.0
mu = 0.1
[coordinates]
r     = { initial = "R - a", velocity = 0 }
theta = { initial = 0, velocity = "w0" }
phi   = { initial = 0, velocity = "-(R - a)*w0/a" }
[lagrangian]
T = "m/2*(r'^2 + r^2*theta'^2) + (m*a^2/2)/2*phi'^2"
V = "-m*g*r*cos(theta)"
[[constraints]]
name = "contact"
f = "(R - a) - r"
unilateral = true
[[constraints]]
name = "rolling"
f = "(R - a)*theta + a*phi"
friction = { mu = "mu", normal = "contact" }
[[bodies]]
name = "disk"
mass = "m"
position = ["r*sin(theta)", "-r*cos(theta)"]
angle = "phi"
inertia = "m*a^2/2"
shape = { circle = "a" }
[gravity]
acceleration = "g"
"""


def _disk_momenta(state, m, a):
    """(centre velocity (2,), spin) of the loop's disk from (r, theta, phi, r', theta', phi')."""
    import numpy as np

    r, th, _, rd, thd, phd = state
    v = np.array([rd * np.sin(th) + r * np.cos(th) * thd, -rd * np.cos(th) + r * np.sin(th) * thd])
    return v, phd


def test_a_disk_landing_on_the_loop_while_slipping_obeys_coulomb_and_newton_euler():
    """The disk leaves the loop (w0 = 5, mu = 0.1) and lands back while slipping: this
    died with KeyError in the impact. Now the landing is a Coulomb impact: checked with
    Newton-Euler on the disk from the states just before and just after, the impulse
    m (v+ - v-) has tangential part mu times its normal part, and I (phi'+ - phi'-) is its
    moment about the centre; the radial velocity is stopped (e = 0) and energy is lost."""
    import numpy as np

    system = lamech.loads(LOOP, "loop.toml")
    traj = lamech.simulate(system, 1.2, samples=50)
    assert traj.status == "ok", traj.message
    kinds = [(str(e.kind), e.constraint) for e in traj.events]
    i = kinds.index(("contact", "contact"))
    assert kinds[i + 1] == ("slip", "rolling") and kinds[:i].count(("lift-off", "contact")) == 1
    landing = traj.events[i]
    t_c = landing.t
    before = lamech.simulate(system, t_c - 1e-9, samples=2)
    y_minus = np.concatenate((before.final_q, before.final_qd))
    c = landing.coordinates
    y_plus = np.array([c[k] for k in ("r", "theta", "phi", "r'", "theta'", "phi'")])
    m, a, mu, R = 1.0, 0.2, 0.1, 1.0
    (v0, w0), (v1, w1) = _disk_momenta(y_minus, m, a), _disk_momenta(y_plus, m, a)
    J = m * (v1 - v0)
    th = y_plus[1]
    outward = np.array([np.sin(th), -np.cos(th)])  # from the loop's centre to the disk
    tangent = np.array([np.cos(th), np.sin(th)])
    Jn, Jt = -J @ outward, J @ tangent  # the track pushes inward
    assert Jn > 0 and abs(y_plus[3]) < 1e-9
    assert abs(abs(Jt) - mu * Jn) < 1e-6 * Jn
    torque = a * (outward[0] * J[1] - outward[1] * J[0])  # (a outward) x J
    assert abs(m * a**2 / 2 * (w1 - w0) - torque) < 1e-6 * Jn * a
    assert abs(traj.events[i + 1].impulse - Jt) < 1e-6 * Jn
    slip = lambda y: (R - a) * y[4] + a * y[5]  # noqa: E731  the slip velocity
    assert np.sign(slip(y_minus)) == np.sign(slip(y_plus)) != 0
    energy = lambda y, v, w: m / 2 * v @ v + m * a**2 / 4 * w**2 - m * 9.81 * y[0] * np.cos(y[1])  # noqa: E731
    assert energy(y_plus, v1, w1) < energy(y_minus, v0, w0)


# ----- item 5: no silent penetration after many impacts -----------------------------------
BALL_2D = """
title = "Ball bouncing across a floor"
[parameters]
m = 1.0
g = 9.81
e = 0.8
[coordinates]
x = { initial = 0, velocity = 1 }
y = { initial = 1, velocity = 0 }
[lagrangian]
T = "m/2*(x'^2 + y'^2)"
V = "m*g*y"
[[constraints]]
name = "floor"
f = "y"
unilateral = true
restitution = "e"
"""


@pytest.mark.parametrize(
    "rtol", [*(pytest.param(r, marks=pytest.mark.slow) for r in (1e-6, 1e-8, 1e-10)), 1e-12]
)
def test_a_ball_bouncing_many_times_comes_to_rest_on_the_floor(rtol):
    """With rtol <= 1e-8 the ball (e = 0.8) fell through the floor after ~20 bounces with
    status ok: a bounce whose whole flight fits in one step never re-armed the contact.
    Truth: bounce k rises to e^(2k) h at t_k = t1 (1 + 2 e + ... + 2 e^(k-1)); the
    bounces accumulate at t1 (1 + e)/(1 - e), after which it rests (lambda = m g);
    x' = 1 throughout (no horizontal impulse)."""
    import math

    import numpy as np

    h, e, g = 1.0, 0.8, 9.81
    traj = lamech.simulate(lamech.loads(BALL_2D, "ball.toml"), 6.0, samples=3001, rtol=rtol)
    assert traj.status == "ok", traj.message
    assert traj.coordinate("y").min() > -1e-9 and abs(traj.final_q[1]) < 1e-9
    impacts = [ev for ev in traj.events if ev.kind == "impact"]
    t1 = math.sqrt(2 * h / g)
    t_k = t1
    for k, ev in enumerate(impacts[:15], start=1):
        up = ev.coordinates["y'"]
        assert abs(up**2 / (2 * g) - e ** (2 * k) * h) <= 1e-7 * h
        assert abs(ev.t - t_k) <= 1e-7
        t_k += 2 * e**k * t1
    rest = traj.events[-1]
    assert rest.kind == "contact" and abs(rest.t - t1 * (1 + e) / (1 - e)) < 1e-3
    after = traj.t > rest.t + 1e-6
    assert np.allclose(traj.multiplier("floor")[after], g, rtol=1e-9)
    assert np.allclose(traj.velocity("x"), 1.0, atol=1e-12)


BUMP = """
title = "A particle sent along the floor at a bump"
[parameters]
m = 1.0
H = 0.1
w = 0.2
[coordinates]
x = { initial = 0, velocity = 10 }
y = { initial = 0.05, velocity = 0 }
[lagrangian]
T = "m/2*(x'^2 + y'^2)"
V = "0"
[[constraints]]
name = "bump"
f = "y - H*exp(-((x - 1)/w)^2)"
unilateral = true
restitution = 1
"""


def test_a_particle_does_not_pass_through_a_bump_inside_one_step():
    """Force-free flight takes steps of a second: the bump's gap dipped below zero and
    came back inside one step, unseen at its ends, and the particle went through it with
    status ok. Truth: it hits where 0.05 = H exp(-((x - 1)/w)^2), x = 1 - w sqrt(ln 2),
    and reflects elastically about the surface normal (-h'(x), 1)."""
    import math

    import numpy as np

    traj = lamech.simulate(lamech.loads(BUMP, "bump.toml"), 0.3, samples=31)
    assert traj.status == "ok", traj.message
    assert [ev.kind for ev in traj.events] == ["impact"]
    ev = traj.events[0]
    x = 1 - 0.2 * math.sqrt(math.log(2))
    assert abs(ev.coordinates["x"] - x) < 1e-9 and abs(ev.t - x / 10) < 1e-9
    slope = -2 * (x - 1) / 0.2**2 * 0.05
    n = np.array([-slope, 1.0]) / math.hypot(slope, 1.0)
    v = np.array([10.0, 0.0])
    reflected = v - 2 * (v @ n) * n
    assert np.allclose([ev.coordinates["x'"], ev.coordinates["y'"]], reflected, atol=1e-8)


# ----- item 4: bundled examples are physically complete -------------------------------
# the cases of 2 s or more: left out of the default set
SLOW_SURFACES = {
    "andrews_squeezer",
    "double_pendulum",
    "four_bar",
    "heavy_top",
    "hoop_bead",
    "moving_support",
    "rolling_disc",
    "rolling_sphere",
    "spherical_pendulum",
}
assert SLOW_SURFACES <= set(lamech.problem.example_names()), SLOW_SURFACES


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(n, marks=pytest.mark.slow) if n in SLOW_SURFACES else n
        for n in lamech.problem.example_names()
    ],
)
def test_no_bundled_example_passes_through_a_surface_it_names(name):
    """The ladder swung through the floor after leaving the wall (only its foot's contact
    was modelled), the Atwood masses rose through the pulley, the wedge's block sank
    through the floor. Every unilateral constraint of every example holds (f >= 0) at
    every sample of a 3 s run (20 s for the ladder, to well after it lands; the stiff
    Andrews squeezer, with no unilateral constraint, over its reference 0.03 s)."""

    from lamech.numeric import compile_system

    system = lamech.load(name)
    ns = compile_system(system)
    t_end = {"ladder": 20.0, "andrews_squeezer": 0.03}.get(name, 3.0)
    traj = lamech.simulate(ns, t_end, samples=601)
    assert traj.status == "ok", traj.message
    unilateral = [i for i, c in enumerate(system.constraints) if c.unilateral]
    for t, q in zip(traj.t, traj.q):
        f = ns.constraints(t, q, ns.parameters)[0]
        assert all(f[i] > -1e-9 for i in unilateral), (t, f)


def test_the_atwood_mass_stops_at_the_pulley_when_the_closed_form_says():
    """Mass 1 rises with a = (m2 - m1) g / (m1 + m2) from l/2 below the pulley: it
    reaches it at t = sqrt(l (m1 + m2) / ((m2 - m1) g)) and stops there (e = 0)."""
    import math

    m1, m2, g, l = 1.0, 2.0, 9.81, 2.0
    traj = lamech.simulate(lamech.load("atwood"), 2.0, samples=201)
    (ev,) = traj.events
    assert (ev.kind, ev.constraint) == ("contact", "pulley1")
    assert abs(ev.t - math.sqrt(l * (m1 + m2) / ((m2 - m1) * g))) < 1e-9
    assert abs(traj.final_q[0]) < 1e-12 and abs(traj.final_qd).max() < 1e-12
    solved = lamech.solve(lamech.load("atwood"))
    assert solved.lets_go["pulley1"].when == "open at the start"
    assert "it closes where y1 = 0" in solved.lets_go["pulley1"].reason


# ----- item 8: what a student would write ----------------------------------------------
@pytest.mark.slow
def test_results_read_as_a_student_would_write_them():
    """X sin(a)/cos(a) was left for X tan(a); sin(2a) over a denominator with a leading
    minus for the wedge's textbook acceleration m g sin(a) cos(a)/(M + m sin(a)^2);
    factors 10000 from an initial velocity 0.01; a chain's links in their angles;
    -m theta'^2 (-R + a) for m theta'^2 (R - a). Each shown form equals the derived one."""
    import sympy as sp

    wedge = lamech.solve(lamech.load("wedge"))
    text = lamech.to_text(wedge)
    assert "yb = h + (X - xb)*tan(alpha)" in text
    S = wedge.symbols
    M, m, g, al = S["M"], S["m"], S["g"], S["alpha"]
    assert sp.srepr(wedge.reduced_equations[0]) == sp.srepr(
        S["X''"] + g * m * sp.sin(al) * sp.cos(al) / (M + m * sp.sin(al) ** 2)
    )
    assert "sin(2*alpha)" not in text
    fast = lamech.to_text(
        lamech.solve(
            lamech.model.with_values(
                lamech.load("cylinder"), initial={"theta1'": 0.01, "theta2'": 0.03}
            )
        )
    )
    assert "10000*g" not in fast and "30000" not in fast
    assert "theta1'^2 = 4*g*(1 - cos(theta1))/(3*(R1 + R2)) + 1/10000" in fast
    chain = lamech.to_text(lamech.solve(lamech.loads(lamech.problem.chain_toml(2), "c.toml")))
    # the links are circles: solved in their angles (no y1 = -sqrt(l^2 - x1^2), which
    # held below the pivot only; issue 43)
    assert "eliminated: y1 = -l*cos(theta1)" in chain
    assert "eliminated: x2 = l*sin(theta1) + l*sin(theta2)" in chain
    loop = lamech.solve(lamech.loads(LOOP, "loop.toml"))
    assert "lambda_contact = g*m*cos(theta) + m*theta'^2*(R - a)" in lamech.to_text(loop)
    th, thd, R, a = (loop.symbols[k] for k in ("theta", "theta'", "R", "a"))
    shown = loop.multipliers["contact"]
    assert sp.simplify(shown - (g * m * sp.cos(th) + m * thd**2 * (R - a))) == 0


CARTESIAN_PENDULUM = """
title = "Pendulum in Cartesian coordinates"
[parameters]
m = 1.0
g = 9.81
l1 = 1.0
[coordinates]
x1 = { initial = 0.6, velocity = 0 }
y1 = { initial = -0.8, velocity = 0 }
[lagrangian]
T = "m/2*(x1'^2 + y1'^2)"
V = "m*g*y1"
[[constraints]]
name = "rod"
f = "l1 - sqrt(x1^2 + y1^2)"
"""


@pytest.mark.slow
def test_a_kept_constraint_is_used_on_its_manifold():
    """f = l1 - sqrt(x1^2 + y1^2) kept: sqrt(x1^2 + y1^2) is l1 and x1 x1' + y1 y1' = 0
    in every result. The tension is the textbook m v^2/l1 - m g y1/l1 (was a quartic
    over (x1^2 + y1^2)^(3/2)); at states on the manifold it equals the polar form
    m l theta'^2 + m g cos(theta) (x1 = l sin(theta), y1 = -l cos(theta)). The
    coordinates are kept (keep = true): lamech would otherwise solve the circle in its
    angle."""
    import numpy as np
    import sympy as sp

    kept = CARTESIAN_PENDULUM.replace("velocity = 0 }", "velocity = 0, keep = true }")
    sol = lamech.solve(lamech.loads(kept, "cart.toml"))
    S = sol.symbols
    m, g, l1 = S["m"], S["g"], S["l1"]
    x, y, xd, yd = S["x1"], S["y1"], S["x1'"], S["y1'"]
    lam = sol.multipliers["rod"]
    assert sp.simplify(lam - m * (xd**2 + yd**2 - g * y) / l1) == 0
    text = lamech.to_text(sol)
    assert "sqrt" not in text.split("Constraints")[1].split("Notes")[0].replace(
        "f = l1 - sqrt(x1^2 + y1^2)", ""
    )
    x1dd = x * (g * y - xd**2 - yd**2) / l1**2
    assert sp.simplify(sol.closed.accelerations[S["x1''"]] - x1dd) == 0
    rng = np.random.default_rng(3)
    for th, w, L in rng.uniform([-3, -4, 0.3], [3, 4, 2], size=(5, 3)):
        state = {
            m: 1.3,
            g: 9.81,
            l1: L,
            x: L * np.sin(th),
            y: -L * np.cos(th),
            xd: L * w * np.cos(th),
            yd: L * w * np.sin(th),
        }
        polar = 1.3 * L * w**2 + 1.3 * 9.81 * np.cos(th)
        assert float(lam.subs(state)) == pytest.approx(polar, rel=1e-12)


# ------------------------------------------ issue 17: hostile input answered, not crashed


def test_ctrl_c_where_no_command_handles_it_is_one_line_and_130(monkeypatch, capsys):
    """Ctrl-C while SymPy loads or the problem is read: no traceback, the shell's 130."""
    from lamech.cli import main

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(lamech.problem, "load", interrupted)
    assert main(["solve", "pendulum"]) == 130
    out, err = capsys.readouterr()
    assert (out, err) == ("", "lamech: interrupted\n")


# ``python -m lamech`` as run by ``-m`` (runpy, sys.argv the command's), with an import
# hook that stops the import of SymPy until the test's signal comes: the signal lands
# while lamech is starting up, whatever the machine's speed (a fixed sleep before the
# signal once let a fast machine finish starting and interrupt the solve instead)
PAUSED_AT_SYMPY = """
import importlib.abc, runpy, sys, time

class PauseAtSympy(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name == "sympy":
            sys.meta_path.remove(self)
            print("importing sympy", file=sys.stderr, flush=True)
            time.sleep(120)  # until the signal
        return None

sys.meta_path.insert(0, PauseAtSympy())
sys.argv = ["lamech", *sys.argv[1:]]
runpy.run_module("lamech", run_name="__main__", alter_sys=True)
"""


def test_ctrl_c_during_start_up_of_the_real_command():
    import signal

    proc = subprocess.Popen(
        [sys.executable, "-c", PAUSED_AT_SYMPY, "solve", "cylinder"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        assert proc.stderr.readline() == "importing sympy\n"  # lamech is starting up
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert "Traceback" not in err
    assert (proc.returncode, out, err) == (130, "", "lamech: interrupted\n")


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


def test_the_title_never_reaches_generated_code():
    """A backslash-N (a Python escape) or a NUL in the title once broke the generated
    source; the title is the user's text and is not part of it."""
    import dataclasses

    text = PENDULUM.replace(
        'title = "Simple pendulum: the string\'s tension as a Lagrange multiplier"',
        'title = \'Pendulum \\N{oops} """ \\x00 \\\'',
    )
    assert text != PENDULUM
    system = lamech.loads(text, "p.toml")
    assert "\\N{oops}" in system.title
    for title in (system.title, "nul \x00 inside"):
        ns = lamech.compile_system(dataclasses.replace(system, title=title))
        assert title not in ns.source
    traj = lamech.simulate(system, 0.05, samples=3)
    assert traj.status == "ok", traj.message


@pytest.mark.slow
def test_twenty_thousand_coordinates_are_refused_at_once():
    """369 kB of coordinates once built a 20000 x 20000 symbolic mass matrix for minutes."""
    import time

    lines = [f"q{i} = {{ initial = 0, velocity = 0 }}" for i in range(20000)]
    text = "[coordinates]\n" + "\n".join(lines) + '\n[lagrangian]\nT = "q0\'^2"\n'
    start = time.perf_counter()
    with pytest.raises(
        lamech.ProblemFileError,
        match=r"big.toml:1: coordinates: 20000 coordinates: a problem file may "
        r"have at most 200",
    ):
        lamech.loads(text, "big.toml")
    assert time.perf_counter() - start < 10


@pytest.mark.parametrize(
    "text, message",
    [
        # one fault does not hide the next: both are reported, each at its line
        (
            'theta = { initial = "theta0", velocity = 0, keep = "yes" }',
            ["coordinates.theta.keep: `keep` must be true or false", "unknown name `R3`"],
        ),
    ],
)
def test_a_bad_value_does_not_hide_the_next_error(text, message):
    bad = PENDULUM.replace('theta = { initial = "theta0", velocity = 0 }', text)
    bad = bad.replace('V = "-m*g*r*cos(theta)"', 'V = "-m*g*r*cos(theta) + R3"')
    assert bad.count("R3") == 1 and "yes" in bad
    with pytest.raises(lamech.ProblemFileError) as info:
        lamech.loads(bad, "p.toml")
    for m in message:
        assert m in str(info.value)
