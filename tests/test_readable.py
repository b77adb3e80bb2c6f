"""Readable closed forms (issue 30): a table of textbook results whose short form is
known. Each printed form must equal the textbook's at random states (parameters and
coordinates drawn at random, so no value of the file helps) and be no more than 1.5x
its operation count. The textbook forms are written here by hand from the sources named
in each example file, not taken from lamech."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import lamech


def _shell(s, name):
    return s.on_energy_shell[name]


def _lam(s, name):
    return s.multipliers[name]


# (example, which result, getter, textbook form as text in the example's names)
TABLE = [
    ("pendulum", "string tension", _lam, "string", "m*(g*cos(theta) + l*theta'^2)"),
    ("pendulum", "tension on the shell", _shell, "string", "m*g*(3*cos(theta) - 2*cos(theta0))"),
    ("cylinder", "normal force", _lam, "contact", "m*g*cos(theta1) - m*(R1 + R2)*theta1'^2"),
    ("cylinder", "friction", _lam, "rolling", "-m*g*sin(theta1)/3"),
    ("cylinder", "normal force on the shell", _shell, "contact", "m*g*(7*cos(theta1) - 4)/3"),
    ("sphere_slide", "normal force on the shell", _shell, "contact", "m*g*(3*cos(theta) - 2)"),
    ("atwood", "string tension", _lam, "string", "2*g*m1*m2/(m1 + m2)"),
    (
        "wedge",
        "normal force on the block",
        _lam,
        "contact",
        "M*m*g*cos(alpha)/(M + m*sin(alpha)^2)",
    ),
    ("double_atwood", "upper string", _lam, "upper", "8*g*m1*m2*m3/(m1*m2 + m1*m3 + 4*m2*m3)"),
    ("incline_disk", "friction on a rolling disk", _lam, "rolling", "-m*g*sin(alpha)/3"),
    (
        "spherical_pendulum",
        "string tension",
        _lam,
        "string",
        "m*(g*cos(theta) + l*theta'^2 + l*sin(theta)^2*phi'^2)",
    ),
    (
        "spherical_pendulum",
        "tension on the shell",
        _shell,
        "string",
        "m*(3*g*cos(theta) - 2*g*cos(theta0) + l*Omega^2*sin(theta0)^2)",
    ),
    (
        "vertical_circle",
        "tension on the shell",
        _shell,
        "string",
        "m*(v0^2/l + g*(3*cos(theta) - 2))",
    ),
    (
        "hoop_bead",
        "the hoop's normal force",
        _lam,
        "hoop",
        "-m*(g*cos(theta) + R*theta'^2 + R*omega^2*sin(theta)^2)",
    ),
]


@pytest.mark.parametrize(
    "example, what, get, name, textbook", TABLE, ids=[f"{r[0]}: {r[1]}" for r in TABLE]
)
def test_the_printed_form_is_the_textbooks(example, what, get, name, textbook):
    from lamech.expr import parse

    s = lamech.solve(lamech.load(example))
    got = get(s, name)
    known = parse(textbook, s.symbols)
    symbols = sorted(got.free_symbols | known.free_symbols, key=str)
    assert set(map(str, got.free_symbols)) <= set(map(str, known.free_symbols)) | {"t"}
    f_got, f_known = sp.lambdify(symbols, got), sp.lambdify(symbols, known)
    rng = np.random.default_rng(30)
    for values in rng.uniform(0.3, 1.7, size=(6, len(symbols))):
        a, b = float(f_got(*values)), float(f_known(*values))
        assert a == pytest.approx(b, rel=1e-10, abs=1e-12), (what, got)
    assert sp.count_ops(got) <= 1.5 * sp.count_ops(known), (what, got, known)


@pytest.mark.slow
def test_the_double_pendulums_tensions_are_written_in_the_angle_between_the_rods():
    """The double pendulum with strings as constraints: the second rod's tension over
    m1 + m2 sin^2(theta1 - theta2), as a textbook writes it, and equal to the KKT
    system solved numerically at random states."""
    from lamech.symbolic import kkt_numeric

    s = lamech.solve(lamech.load("double_pendulum"))
    S = s.symbols
    rod2 = s.multipliers["rod2"]
    delta = S["theta1"] - S["theta2"]
    assert rod2.has(sp.sin(delta)) or rod2.has(sp.sin(-delta))
    assert sp.count_ops(rod2) <= 40
    rng = np.random.default_rng(2)
    names = ["theta1", "theta2", "theta1'", "theta2'"]
    dyn = s.dynamics
    for values in rng.uniform(-2, 2, size=(4, 4)):
        env = {**s.system.parameter_values, s.system.t: 0.0}
        env.update({S[n]: v for n, v in zip(names, values)})
        full = dict(env)
        # the eliminated coordinates and their velocities on the constraints
        for c, _ in s.reduction.eliminated:
            for x in (c.symbol, c.velocity):
                full[x] = float(s.reduction.substitution[x].xreplace(env))
        _, lam = kkt_numeric(dyn, full)
        k = [c.name for c in s.system.constraints].index("rod2")
        assert float(rod2.xreplace(env)) == pytest.approx(lam[k], rel=1e-9)
