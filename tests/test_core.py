"""Unit tests of the core modules (derive, reduce, integrals, report, cli) on small
systems whose answers are derived by hand in each test."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest
import sympy as sp

import lamech
from lamech.expr import parse
from lamech.model._checks import holding_at_start
from lamech.problem import chain_toml
from lamech.symbolic import DegenerateConstraintsError, dynamics, eliminate
from lamech.symbolic._derive import kkt_numeric
from lamech.symbolic._reduce import CLOSED_FORM_LIMIT

FALLING_CLOCK = """
title = "Bead on a rod whose end is driven: x = a cos(w t)"
[parameters]
m = 2.0
a = 0.5
w = 3.0
g = 9.81
[coordinates]
x = { initial = "a", velocity = 0 }
y = { initial = 0, velocity = 0 }
[lagrangian]
T = "m/2*(x'^2 + y'^2)"
V = "m*g*y"
[[constraints]]
name = "drive"
f = "x - a*cos(w*t)"
[[constraints]]
name = "rail"
f = "y"
"""


def _same(a, b) -> bool:
    return sp.simplify(sp.sympify(a) - sp.sympify(b)) == 0


# ------------------------------------------------------------------------------ derive


def test_dynamics_of_the_pendulum_by_hand():
    system = lamech.load("pendulum")
    d = dynamics(system)
    S = system.symbols
    m, g, r, th = S["m"], S["g"], S["r"], S["theta"]
    rd, thd = S["r'"], S["theta'"]
    assert d.M == sp.diag(m, m * r**2)
    assert _same(d.h[0], -m * r * thd**2 - m * g * sp.cos(th))
    assert _same(d.h[1], 2 * m * r * rd * thd + m * g * r * sp.sin(th))
    assert d.A == sp.Matrix([[-1, 0]])  # f = l - r: written, not normalised
    assert d.gamma == sp.Matrix([0])


def test_rheonomic_gamma_and_the_force_that_drives():
    """f = x - a cos(w t): A q'' + gamma = 0 gives x'' = -a w^2 cos(w t), and the
    multiplier is the driving force m x'' (A = [1, 0], so lambda = m x'')."""
    system = lamech.loads(FALLING_CLOCK)
    d = dynamics(system)
    S = system.symbols
    a, w, t, m, g = S["a"], S["w"], S["t"], S["m"], S["g"]
    assert _same(d.gamma[0], a * w**2 * sp.cos(w * t))
    s = lamech.solve(system)
    assert _same(s.multipliers["drive"], -m * a * w**2 * sp.cos(w * t))
    assert _same(s.multipliers["rail"], m * g)
    assert s.energy is None  # the drive does work
    assert lamech.to_json(s)["energy"] is None


def test_numeric_kkt_singular_mass_matrix_is_fine():
    """Double Atwood with a massless pulley: M is singular, the KKT matrix is not."""
    system = holding_at_start(lamech.load("double_atwood"))  # no open stops
    d = dynamics(system)
    state = {**system.parameter_values, system.t: 0.0}
    state.update(
        {
            s: float(sp.sympify(e).subs(system.parameter_values))
            for s, e in system.initial_state.items()
        }
    )
    M = np.array(d.M.subs(state).evalf(), dtype=float)
    assert np.linalg.matrix_rank(M) < M.shape[0]
    qdd, lam = kkt_numeric(d, state)
    assert np.all(np.isfinite(qdd)) and np.all(np.isfinite(lam))


def test_redundant_constraints_are_named():
    text = FALLING_CLOCK + '[[constraints]]\nname = "rail_again"\nf = "2*y"\n'
    with pytest.raises((DegenerateConstraintsError, lamech.ProblemFileError)) as err:
        lamech.solve(lamech.loads(text))
    msg = str(err.value)
    assert "`rail`" in msg and "`rail_again`" in msg and "dependent" in msg


# ------------------------------------------------------------------------------ reduce


def test_elimination_takes_no_branch_of_a_square_root():
    """x^2 + y^2 = l^2 with the bob below the pivot: y = -sqrt(l^2 - x^2) holds only
    while the bob is below the pivot, which the motion may leave; both coordinates are
    kept (issue 43; the multipliers are then reduced modulo the constraint)."""
    system = lamech.loads(chain_toml(1))
    red = eliminate(system)
    assert red.eliminated == ()
    assert [c.name for c in red.independent] == ["x1", "y1"]
    assert "one sign of a square root" in red.notes[0]


def test_large_systems_keep_their_coordinates():
    system = lamech.loads(chain_toml(CLOSED_FORM_LIMIT))
    red = eliminate(system)
    assert red.eliminated == () and len(red.independent) == 2 * CLOSED_FORM_LIMIT
    assert "one sign of a square root" in red.notes[0]


@pytest.mark.parametrize("n", [pytest.param(2, marks=pytest.mark.slow), 8])
def test_chain_tensions_at_rest_against_statics(n):
    """An aligned chain released at rest falls tangentially as one piece at that
    instant (every bob accelerates by -g sin(alpha) along the tangent), so the links
    carry the static tensions T_k = (n - k + 1) m g cos(alpha). With
    f_k = |r_k - r_{k-1}|^2 - l^2, Q = 2 lambda_k (r_k - r_{k-1}), so
    lambda_k = -T_k / (2 l). Checked on the numeric multipliers lamech reports when
    the closed forms are out of reach."""
    alpha = math.radians(30.0)
    s = lamech.solve(lamech.loads(chain_toml(n, 30.0)))
    lam = s.initial_multipliers
    assert lam, s.notes
    for k in range(1, n + 1):
        expected = -(n - k + 1) * 9.81 * math.cos(alpha) / 2.0
        assert lam[f"link{k}"] == pytest.approx(expected, rel=1e-10)
    assert lamech.to_json(s)["initial_multipliers"] == lam


# --------------------------------------------------------------------------- integrals


@pytest.mark.slow
def test_cyclic_momentum_of_the_spherical_pendulum():
    s = lamech.solve(lamech.load("spherical_pendulum"))
    S = s.symbols
    m, l, th, phd = S["m"], S["l"], S["theta"], S["phi'"]
    assert any(_same(c, m * l**2 * sp.sin(th) ** 2 * phd) for c in s.conserved)


# ------------------------------------------------------------------------------ report


@pytest.mark.parametrize(
    "name",
    [
        pytest.param("cylinder", marks=pytest.mark.slow),
        "pendulum",
        pytest.param("hoop_bead", marks=pytest.mark.slow),
        "knife_edge",
        pytest.param("double_atwood", marks=pytest.mark.slow),
    ],
)
def test_json_expressions_parse_back(name):
    """Every expression in --json parses with lamech's own parser to the same value."""
    s = lamech.solve(lamech.load(name))
    j = lamech.to_json(s)
    names = dict(s.symbols)

    def back(text):
        return parse(text, names)

    for text, expr in zip(j["equations"], s.equations):
        assert _same(back(text), expr)
    for k, text in j["multipliers"].items():
        assert _same(back(text), s.multipliers[k])
    for k, text in j.get("on_energy_shell", {}).items():
        assert _same(back(text), s.on_energy_shell[k])
    if j["energy"] is not None:
        assert _same(back(j["energy"]), s.energy)
    for k, comps in j["forces"].items():
        for d, text in comps.items():
            if text is not None:
                assert _same(back(text), s.forces[k][d])
    for k, comps in j["generalized_forces"].items():
        for c, text in comps.items():
            assert _same(back(text), s.generalized_forces[k][c])
    json.dumps(j)  # plain JSON types only


def test_latex_has_the_multipliers(solved_example):
    tex = lamech.to_latex(solved_example("pendulum"))
    assert "\\lambda_{\\mathrm{string}}" in tex and "\\begin{align*}" in tex
    assert "\\cos{\\left(\\theta_{0} \\right)}" in tex


# --------------------------------------------------------------------------------- cli


def _cli(*args, timeout=240):
    return subprocess.run(
        [sys.executable, "-m", "lamech", *args], capture_output=True, text=True, timeout=timeout
    )


@pytest.mark.slow
def test_cli_without_arguments_solves_the_cylinder():
    out = _cli()
    assert out.returncode == 0, out.stderr
    assert "lambda_contact = g*m*cos(theta1) - m*theta1'^2*(R1 + R2)" in out.stdout
    assert "cos(theta1) = 4/7:  theta1 = 0.9625507479 (55.15°)" in out.stdout
    assert "tangent = -g*m*sin(theta1)/3" in out.stdout


@pytest.mark.slow
def test_cli_json_is_one_object():
    out = _cli("solve", "pendulum", "--json")
    assert out.returncode == 0, out.stderr
    j = json.loads(out.stdout)
    assert j["on_energy_shell"]["string"] == "g*m*(3*cos(theta) - 2*cos(theta0))"


@pytest.mark.slow
def test_cli_bad_file_gives_a_message_not_a_traceback(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(FALLING_CLOCK.replace('f = "y"', 'f = "y + R3"'))
    out = _cli("solve", str(bad))
    assert out.returncode == 2
    assert "Traceback" not in out.stderr
    assert f"{bad}:" in out.stderr and "`R3`" in out.stderr and "known:" in out.stderr
    missing = _cli("solve", str(tmp_path / "nope.toml"))
    assert missing.returncode == 2 and "Traceback" not in missing.stderr


def test_cli_examples_lists_every_bundled_problem():
    out = _cli("examples")
    assert out.returncode == 0
    for name in ["cylinder", "pendulum", "knife_edge", "atwood"]:
        assert name in out.stdout


def test_open_contact_at_the_start_loads_and_is_said():
    """A unilateral contact may start open (f > 0): a ball dropped on a floor."""
    text = """
title = "Ball above a floor"
[parameters]
m = 2.0
g = 9.81
[coordinates]
y = { initial = 1.5, velocity = 0 }
[lagrangian]
T = "m/2*y'^2"
V = "m*g*y"
[[constraints]]
name = "floor"
f = "y"
unilateral = true
"""
    sol = lamech.solve(lamech.loads(text))
    # lambda = 0 until it closes: free fall, and the floor closes where y = 0
    assert "floor" not in sol.multipliers
    assert sol.reduced_equations == [sol.symbols["y''"] + sol.symbols["g"]]
    assert sol.vanishes["floor"] == []
    assert sol.lets_go["floor"].when == "open at the start"
    (closes,) = sol.closes["floor"]
    assert closes.value == 0.0 and closes.equation == "y = 0"
    assert "it closes where y = 0" in lamech.to_text(sol)
    assert any("open at the start" in n for n in sol.notes)
    with pytest.raises(lamech.ProblemFileError, match="forbidden side"):
        lamech.loads(text.replace("initial = 1.5", "initial = -0.5"))
