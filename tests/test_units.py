"""Units in the problem file (issue 46): quantities converted exactly to SI, dimensions
inferred and checked (each mistake refused at its line with its cause), each multiplier
printed with its unit, and files without units unchanged."""

from __future__ import annotations

import json
import random
import subprocess
import sys

import pytest
import sympy as sp

import lamech
from lamech.expr import Dimension, is_quantity, quantity
from lamech.problem import ProblemFileError, example_path

CYLINDER = example_path("cylinder").read_text(encoding="utf-8")
UNITS = {
    "m = 1.0": 'm = "2 kg"',
    "g = 9.81": 'g = "9.81 m/s^2"',
    "R1 = 1.0": 'R1 = "1 m"',
    "R2 = 0.5": 'R2 = "50 cm"',
}


def _with_units(text: str = CYLINDER) -> str:
    for old, new in UNITS.items():
        assert f"\n{old}\n" in text
        text = text.replace(f"\n{old}\n", f"\n{new}\n")
    return text


def _cli(*args: str, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "lamech", *args], capture_output=True, text=True, cwd=cwd
    )


# ----- quantities -------------------------------------------------------------------
@pytest.mark.parametrize(
    "text, value, dimension",
    [
        ("30 cm", sp.Rational(3, 10), Dimension.of(L=1)),
        ("9.81 m/s^2", sp.Rational(981, 100), Dimension.of(L=1, T=-2)),
        ("30 deg", sp.pi / 6, Dimension()),
        ("2 kg", sp.Integer(2), Dimension.of(M=1)),
        ("200 N/m", sp.Integer(200), Dimension.of(M=1, T=-2)),
        ("5 N/cm", sp.Integer(500), Dimension.of(M=1, T=-2)),
        ("0.5 m/s", sp.Rational(1, 2), Dimension.of(L=1, T=-1)),
        ("-2.5e-3 kg*m^2", sp.Rational(-1, 400), Dimension.of(M=1, L=2)),
        ("3 min", sp.Integer(180), Dimension.of(T=1)),
        ("60 rpm", 2 * sp.pi, Dimension.of(T=-1)),
        ("1 ft", sp.Rational(3048, 10000), Dimension.of(L=1)),
    ],
)
def test_a_quantity_is_converted_exactly_to_si(text, value, dimension):
    q = quantity(text)
    assert sp.simplify(q.value - value) == 0 and q.value == value
    assert q.dimension == dimension


@pytest.mark.parametrize("text", ["R1 + R2", "2*pi", "0.5", "1e-3", "x^2", "-R", "(1 + 2)"])
def test_an_expression_is_not_a_quantity(text):
    assert not is_quantity(text)


def test_units_print_in_si_symbols():
    energy = Dimension.of(M=1, L=2, T=-2)
    assert (energy / Dimension.of(L=1)).si() == "N"
    assert energy.si() == "N*m"
    assert (energy / Dimension.of(L=2)).si() == "N/m"
    assert (energy / Dimension.of(L=1, T=-1)).si() == "N*s"
    assert Dimension.of(M=1).si() == "kg"
    assert Dimension().si() == "1"


# ----- the cylinder with units ------------------------------------------------------
@pytest.fixture(scope="module")
def cylinders():
    plain = lamech.solve(lamech.load("cylinder"))
    text = _with_units().replace('R2 = "50 cm"', 'R2 = "50 cm"', 1)
    units = lamech.solve(lamech.loads(text))
    return plain, units


def test_the_cylinder_with_units_converts_to_the_unit_free_numbers(cylinders):
    _, units = cylinders
    values = {p.name: p.value for p in units.system.parameters}
    assert values == {"m": 2, "g": sp.Rational(981, 100), "R1": 1, "R2": sp.Rational(1, 2)}


def test_the_cylinder_with_units_leaves_and_slips_where_the_unit_free_one_does(cylinders):
    plain, units = cylinders
    for table in ("vanishes", "slips"):
        a, b = getattr(plain, table), getattr(units, table)
        assert list(a) == list(b)
        for k in a:
            assert [r.equation for r in a[k]] == [r.equation for r in b[k]]
            assert [r.value for r in a[k]] == pytest.approx([r.value for r in b[k]], abs=1e-12)
    liftoff = units.vanishes["contact"][0]
    assert liftoff.value == pytest.approx(float(sp.acos(sp.Rational(4, 7))), abs=1e-9)


def test_lambda_contact_with_units_equals_the_unit_free_one_at_random_states(cylinders):
    plain, units = cylinders
    lam_plain, lam_units = plain.multipliers["contact"], units.multipliers["contact"]
    sys_p, sys_u = plain.system, units.system
    rng = random.Random(46)
    for _ in range(20):
        state = {"theta1": rng.uniform(-3, 3), "theta1'": rng.uniform(-2, 2)}
        params = {"m": rng.uniform(0.1, 5), "g": rng.uniform(1, 20)}
        params |= {"R1": rng.uniform(0.1, 3), "R2": rng.uniform(0.1, 3)}

        given = {**state, **params}
        a = float(lam_units.xreplace({sys_u.symbols[k]: v for k, v in given.items()}))
        b = float(lam_plain.xreplace({sys_p.symbols[k]: v for k, v in given.items()}))
        assert a == pytest.approx(b, rel=1e-12)


@pytest.mark.slow
def test_solve_prints_each_multiplier_in_newtons_and_json_carries_the_units(tmp_path):
    path = tmp_path / "cylinder_units.toml"
    path.write_text(_with_units(), encoding="utf-8")
    out = _cli("solve", str(path))
    assert out.returncode == 0, out.stderr
    assert "  lambda_contact = g*m*cos(theta1) - m*theta1'^2*(R1 + R2) [N]\n" in out.stdout
    assert "  lambda_rolling = -g*m*sin(theta1)/3 [N]\n" in out.stdout
    assert "  lambda_contact = g*m*(7*cos(theta1) - 4)/3 [N]\n" in out.stdout
    assert "    normal = g*m*cos(theta1) - m*theta1'^2*(R1 + R2) [N]\n" in out.stdout
    data = json.loads(_cli("solve", str(path), "--json").stdout)
    assert data["units"]["multipliers"] == {"contact": "N", "rolling": "N"}
    assert data["units"]["forces"] == {"contact": "N", "rolling": "N"}
    assert data["units"]["coordinates"]["theta1"] == "rad"
    assert data["units"]["coordinates"]["r'"] == "m/s"


def test_latex_writes_each_multiplier_with_its_unit(cylinders):
    plain, units = cylinders
    tex = lamech.to_latex(units)
    assert r"\frac{g m \sin{\left(\theta_{1} \right)}}{3}\,\mathrm{N}" in tex
    assert r"\right)\right)\,\mathrm{N} && \text{multiplier}" in tex  # a sum in parentheses
    assert r"\mathrm{N}" not in lamech.to_latex(plain)


@pytest.mark.slow  # 2 s or more in the default set (2026-11-29)
def test_param_takes_a_quantity_of_the_dimension_the_file_gives(tmp_path):
    path = tmp_path / "cylinder_units.toml"
    path.write_text(_with_units(), encoding="utf-8")
    a = json.loads(_cli("solve", str(path), "--json", "--param", "R2=30 cm").stdout)
    b = json.loads(_cli("solve", "cylinder", "--json", "--param", "R2=0.3").stdout)
    assert a["initial_multipliers"]["contact"] == pytest.approx(
        b["initial_multipliers"]["contact"] * 2  # m = 2 kg against m = 1
    )
    bad = _cli("solve", str(path), "--param", "R2=30 kg")
    assert bad.returncode != 0
    assert "R2=30 kg: has dimension M (mass), but `R2` has L (length)" in bad.stderr


def test_a_multiplier_of_an_angle_constraint_is_in_newton_metres_and_of_an_area_in_n_per_m():
    text = """
    [parameters]
    m = "1 kg"
    g = "9.81 m/s^2"
    l = "2 m"
    [coordinates]
    x = { initial = "2 m", velocity = 0 }
    y = { initial = 0, velocity = 0 }
    phi = { initial = 0, velocity = 0, unit = "rad" }
    psi = { initial = 0, velocity = 0 }
    [lagrangian]
    T = "m/2*(x'^2 + y'^2) + m*l^2/2*(phi'^2 + psi'^2)"
    V = "m*g*y"
    [[constraints]]
    name = "circle"
    f = "x^2 + y^2 - l^2"
    [[constraints]]
    name = "gear"
    f = "phi - 2*psi"
    """
    s = lamech.loads(text)
    assert s.units.multiplier("circle").si() == "N/m"
    assert s.units.multiplier("gear").si() == "N*m"


# ----- conversions against hand values ----------------------------------------------
INCLINE = """
title = "Block on an incline"
[parameters]
m = "2 kg"
g = "9.81 m/s^2"
alpha = "30 deg"
[coordinates]
s = { initial = 0, velocity = 0, unit = "m" }
n = { initial = 0, velocity = 0, unit = "m" }
[lagrangian]
T = "m/2*(s'^2 + n'^2)"
V = "m*g*(n*cos(alpha) - s*sin(alpha))"
[[constraints]]
name = "contact"
f = "n"
unilateral = true
"""


def test_an_incline_of_30_deg_gives_the_block_g_sin_30():
    system = lamech.loads(INCLINE)
    alpha = next(p for p in system.parameters if p.name == "alpha")
    assert alpha.value == sp.pi / 6
    sol = lamech.solve(system)
    acc = sol.closed.accelerations[system.coordinate("s").acceleration]
    assert sp.simplify(system.numeric(acc) - sp.Rational(981, 100) / 2) == 0
    lam = system.numeric(sol.multipliers["contact"])
    assert float(lam) == pytest.approx(2 * 9.81 * (3**0.5 / 2))
    assert system.units.multiplier("contact").si() == "N"


SPRING = """
title = "Mass on a spring"
[parameters]
m = "500 g"
k = "{k}"
[coordinates]
x = {{ initial = "{x0}", velocity = "{v0}" }}
[lagrangian]
T = "m/2*x'^2"
V = "k/2*x^2"
"""


def test_a_spring_constant_in_n_per_cm_and_a_start_in_cm():
    s = lamech.loads(SPRING.format(k="2 N/cm", x0="5 cm", v0="10 cm/s"))
    assert {p.name: p.value for p in s.parameters} == {"m": sp.Rational(1, 2), "k": 200}
    x = s.coordinate("x")
    assert (x.initial, x.initial_velocity) == (sp.Rational(1, 20), sp.Rational(1, 10))
    assert s.units.of("x") == Dimension.of(L=1)  # inferred from k/2*x^2 beside m/2*x'^2
    omega2 = s.numeric(lamech.solve(s).closed.accelerations[x.acceleration] / -x.symbol)
    assert float(omega2) == pytest.approx(400)  # k/m = 200 N/m / 0.5 kg


def test_a_coordinate_unit_reads_its_plain_numbers_in_that_unit():
    text = """
    [parameters]
    m = "1 kg"
    g = "9.81 m/s^2"
    l = "1 m"
    [coordinates]
    theta = { initial = 30, velocity = 90, unit = "deg" }
    [lagrangian]
    T = "m*l^2/2*theta'^2"
    V = "-m*g*l*cos(theta)"
    """
    c = lamech.loads(text).coordinate("theta")
    assert (c.initial, c.initial_velocity) == (sp.pi / 6, sp.pi / 2)
    s = lamech.loads(text.replace("initial = 30, velocity = 90", 'initial = "10 deg"'))
    assert s.coordinate("theta").initial == sp.pi / 18


# ----- mistakes refused ---------------------------------------------------------------
BASE = """title = "Units"
[parameters]
m = "2 kg"
g = "9.81 m/s^2"
R = "50 cm"
mu = 0.3
b = "0.5 kg/s"
[coordinates]
x = { initial = 0, velocity = 0 }
y = { initial = 0, velocity = 0, unit = "m" }
theta = { initial = 0, velocity = 0, unit = "rad" }
[lagrangian]
T = "m/2*(x'^2 + y'^2) + m*R^2/4*theta'^2"
V = "m*g*y"
[[constraints]]
name = "contact"
f = "y"
unilateral = true
[[constraints]]
name = "rolling"
f = "x - R*theta"
friction = { mu = "mu", normal = "contact" }
[forces]
x = "-b*x'"
"""


def test_the_base_file_of_the_mistakes_loads():
    s = lamech.loads(BASE)
    assert s.units.multiplier("rolling").si() == "N"


MISTAKES = [
    # (what, old text, new text, line, words the message must say)
    (
        "a mass missing from T",
        "T = \"m/2*(x'^2 + y'^2) + m*R^2/4*theta'^2\"",
        "T = \"1/2*(x'^2 + y'^2) + 1/4*R^2*theta'^2\"",
        13,
        ["of T has dimension L^2/T^2", "V has M*L^2/T^2 (energy)", "is a mass missing from `"],
    ),
    (
        "a length added to an angle",
        'f = "x - R*theta"',
        'f = "x - R*theta - theta"',
        21,
        ["rolling", "`-R*theta` has L (length)", "dimensionless", "is a radius missing"],
    ),
    (
        "sin of a length",
        'V = "m*g*y"',
        'V = "m*g*R*sin(y)"',
        14,
        ["lagrangian.V", "the argument of sin, `y`, has dimension L (length)", "dimensionless"],
    ),
    (
        "a constraint mixing m and m^2",
        'f = "y"',
        'f = "y^2 + R*y + y"',
        17,
        ["contact", "`y` has L (length)", "L^2 (area)"],
    ),
    (
        "mu with a unit",
        "mu = 0.3",
        'mu = "0.3 N"',
        22,
        ["friction.mu", "mu has dimension M*L/T^2 (force)", "give it without a unit"],
    ),
    (
        "V without its height",
        'V = "m*g*y"',
        'V = "m*g"',
        14,
        ["V has dimension M*L/T^2 (force)", "an energy needs", "is a length missing from V"],
    ),
    (
        "a force named with the wrong dimension",
        'x = "-b*x\'"',
        'x = "-b*x"',
        24,
        ["forces.x", "M*L/T (momentum)", "M*L/T^2 (force)", "where a velocity was meant"],
    ),
    (
        "exp of a time",
        'x = "-b*x\'"',
        'x = "-b*x\'*exp(t)"',
        24,
        ["the argument of exp, `t`, has dimension T (time)"],
    ),
    (
        "a parameter whose expression adds a mass to a length",
        'b = "0.5 kg/s"',
        'b = "0.5 kg/s"\nL0 = "R + m"',
        8,
        ["parameters.L0", "`m` has M (mass)", "`R` has L (length)"],
    ),
    (
        "an initial value in the wrong unit",
        'theta = { initial = 0, velocity = 0, unit = "rad" }',
        'theta = { initial = "10 cm", velocity = 0, unit = "rad" }',
        11,
        ["coordinates.theta.initial", "`10 cm` has dimension L (length)", "dimensionless"],
    ),
    (
        "a velocity without its time",
        "x = { initial = 0, velocity = 0 }",
        'x = { initial = 0, velocity = "0.5 m", unit = "m" }',
        9,
        ["coordinates.x.velocity", "`0.5 m` has dimension L (length)", "L/T (velocity)"],
    ),
    (
        "a length compared with a time",
        'x = "-b*x\'"',
        'x = "piecewise((-b*x\', x < t), 0)"',
        24,
        ["forces.x", "sides of a comparison", "`t` has T (time)", "`x` has L (length)"],
    ),
    (
        "a coefficient of restitution with a unit",
        "unilateral = true",
        'unilateral = true\nrestitution = "b"',
        19,
        ["constraints[1] `contact` restitution", "M/T", "a coefficient of restitution"],
    ),
    (
        "an unknown unit",
        'R = "50 cm"',
        'R = "50 cn"',
        5,
        ["parameters.R", "unknown unit `cn`"],
    ),
    (
        "a quantity where only an expression may be",
        'f = "y"',
        'f = "0.3 m"',
        17,
        ["`0.3 m` is a quantity with a unit", "declare a parameter"],
    ),
]


@pytest.mark.parametrize("what, old, new, line, words", MISTAKES, ids=[m[0] for m in MISTAKES])
def test_a_dimension_mistake_is_refused_at_its_line(what, old, new, line, words):
    assert old in BASE
    with pytest.raises(ProblemFileError) as info:
        lamech.loads(BASE.replace(old, new, 1), "units.toml")
    message = str(info.value)
    assert f"units.toml:{line}:" in message, message
    for w in words:
        assert w in message, message


def test_a_kinetic_energy_without_its_mass_is_refused_as_the_issue_says():
    text = """
    [parameters]
    m = "2 kg"
    g = "9.81 m/s^2"
    [coordinates]
    y = { initial = "1 m", velocity = 0 }
    [lagrangian]
    T = "1/2*y'^2"
    V = "m*g*y"
    """
    with pytest.raises(ProblemFileError) as info:
        lamech.loads(text.replace("\n    ", "\n"), "fall.toml")
    assert str(info.value).startswith(
        "fall.toml:8: lagrangian.T: T has dimension L^2/T^2 (energy/mass), V has M*L^2/T^2 "
        "(energy): is a mass missing from T?"
    )


def test_a_term_of_t_without_its_mass_is_named_though_its_coordinate_has_no_unit():
    """x appears in T alone: taking T as an energy would make x of dimension M^(1/2)*L."""
    text = """
    [parameters]
    m = "2 kg"
    g = "9.81 m/s^2"
    [coordinates]
    x = { initial = 0, velocity = 0 }
    y = { initial = 0, velocity = 0, unit = "m" }
    [lagrangian]
    T = "1/2*x'^2 + m/2*y'^2"
    V = "m*g*y"
    """
    with pytest.raises(ProblemFileError) as info:
        lamech.loads(text.replace("\n    ", "\n"), "free.toml")
    assert str(info.value).startswith(
        "free.toml:9: lagrangian.T: the term `x'^2/2` of T has dimension dim(x)^2/T^2, V has "
        "M*L^2/T^2 (energy): is a mass missing from `x'^2/2`?"
    )


def test_the_mistakes_are_ten_or_more():
    assert len({m[0] for m in MISTAKES}) >= 10


# ----- files without units ----------------------------------------------------------
def test_a_file_without_units_has_no_units_and_prints_no_unit():
    s = lamech.load("cylinder")
    assert s.units is None
    data = json.loads(_cli("solve", "cylinder", "--json").stdout)
    assert "units" not in data
    assert "[N]" not in _cli("solve", "cylinder").stdout


def test_a_string_expression_of_parameters_still_works_beside_units():
    text = _with_units().replace('R2 = "50 cm"', 'R2 = "50 cm"\nR3 = "R1 + R2"')
    s = lamech.loads(text)
    r3 = next(p for p in s.parameters if p.name == "R3")
    assert r3.numeric == pytest.approx(1.5)
    assert s.units.of("R3") == Dimension.of(L=1)


# ----- loads ------------------------------------------------------------------------
LOADS = """title = "A pushed block on a spring"
[parameters]
m = "2 kg"
k = "200 N/m"
F = "3 N"
[coordinates]
x = { initial = "1 cm", velocity = 0 }
[[bodies]]
name = "block"
mass = "m"
position = ["x", 0]
[[loads]]
name = "push"
body = "block"
force = ["F", 0]
[[loads]]
name = "spring"
spring = { from = [0, 0], to = ["x", 0], k = "k" }
"""


def test_loads_in_units_hold_the_block_where_the_hand_says():
    s = lamech.loads(LOADS)
    assert s.units.of("x") == Dimension.of(L=1)
    sol = lamech.solve(s)
    x = s.coordinate("x")
    acc = s.numeric(sol.closed.accelerations[x.acceleration])
    assert sp.simplify(acc.subs(x.symbol, sp.Rational(3, 200))) == 0  # F/k = 1.5 cm


@pytest.mark.parametrize(
    "old, new, line, words",
    [
        ('F = "3 N"', 'F = "3 kg"', 15, ["loads[1] `push` force", "M (mass)", "a force needs"]),
        ('k = "200 N/m"', 'k = "200 N"', 18, ["loads[2] `spring` spring", "a stiffness (N/m)"]),
    ],
    ids=["a load's force of a mass", "a spring's stiffness in N"],
)
def test_a_load_of_the_wrong_dimension_is_refused_at_its_line(old, new, line, words):
    with pytest.raises(ProblemFileError) as info:
        lamech.loads(LOADS.replace(old, new, 1), "loads.toml")
    message = str(info.value)
    assert f"loads.toml:{line}:" in message, message
    for w in words:
        assert w in message, message


@pytest.mark.slow  # 2 s or more in the default set (2026-11-29)
def test_a_sweep_takes_quantities_in_si_and_refuses_another_dimension(tmp_path):
    path = tmp_path / "cylinder_units.toml"
    path.write_text(_with_units(), encoding="utf-8")
    args = ["--initial", "theta1=1 deg", "--measure", "liftoff", "--t-end", "3"]
    out = _cli("sweep", str(path), "--param", "R2=40 cm:60 cm:2", *args, "--engine", "scipy")
    assert out.returncode == 0, out.stderr
    rows = [line.split(",") for line in out.stdout.splitlines()[1:]]
    assert [float(r[1]) for r in rows] == [0.4, 0.6]
    assert [float(r[3]) for r in rows] == pytest.approx([1.4, 1.6])  # r = R1 + R2 at lift-off
    bad = _cli("sweep", str(path), "--param", "R2=40 kg:60 kg:2", *args)
    assert bad.returncode == 2
    assert "'40 kg' has dimension M (mass), but the problem file gives it L (length)" in bad.stderr
