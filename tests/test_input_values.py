"""Issue 29, item 5: impossible inputs refused with their line (clip with lo > hi, an
inertia no body has, a negative radius, a division by an expression identically zero),
min/max of many arguments handled without recursion, a problem too big refused at once,
and one bad value not hiding the next."""

from __future__ import annotations

import pytest

import lamech

TOP = """
title = "a top"
[parameters]
m = 1.0
g = 9.81
[coordinates]
phi = {{ initial = 0, velocity = 1 }}
[lagrangian]
V = "0"
[[bodies]]
name = "top"
mass = "m"
position = ["0", "0", "1"]
rotation = ["z:phi"]
inertia = {inertia}
"""


def _error(text: str) -> str:
    with pytest.raises(lamech.ProblemFileError) as err:
        lamech.loads(text)
    return str(err.value)


def _line(text: str, start: str) -> int:
    return next(i for i, ln in enumerate(text.splitlines(), 1) if ln.startswith(start))


@pytest.mark.parametrize(
    "inertia, words",
    [
        ('["1", "1", "3"]', "triangle"),
        ('["1", "2", "3.5"]', "triangle"),
        ('[["1", "0", "0"], ["0", "1", "0"], ["0", "0", "3"]]', "triangle"),
        ('[["1", "2", "0"], ["2", "1", "0"], ["0", "0", "1"]]', "positive"),
    ],
)
def test_an_inertia_no_body_has_is_refused_at_its_line(inertia, words):
    text = TOP.format(inertia=inertia)
    err = _error(text)
    assert words in err and f":{_line(text, 'inertia')}:" in err, err


@pytest.mark.parametrize(
    "inertia",
    [
        '["1", "1", "2"]',
        '["0.5", "0.5", "1"]',
        '["0", "1", "1"]',
        '[["2", "1", "0"], ["1", "2", "0"], ["0", "0", "2"]]',
    ],
)
def test_a_possible_inertia_is_accepted(inertia):
    lamech.loads(TOP.format(inertia=inertia))  # a disc, a flat plate, a rod, a tilted box


CART = """
title = "a cart"
[parameters]
m = 1.0
[coordinates]
x = {{ initial = 0, velocity = 0 }}
[lagrangian]
T = "m/2*x'^2"
V = "0"
[forces]
x = "{force}"
{extra}
"""


def test_clip_with_lo_above_hi_is_refused_at_its_line():
    text = CART.format(force="clip(t, 1, -1)", extra="")
    err = _error(text)
    line = _line(text, 'x = "clip')
    assert "clip" in err and "lo <= hi" in err and f":{line}:" in err, err
    lamech.loads(CART.format(force="clip(t, -1, 1)", extra=""))


@pytest.mark.parametrize(
    "extra, start",
    [
        ('[[scenery]]\nname = "ring"\ncircle = { center = [0, 0], radius = "-1" }', "circle"),
        (
            '[[bodies]]\nname = "ball"\nmass = "m"\nposition = ["x", "0"]\n'
            'shape = { circle = "-0.5" }',
            "shape",
        ),
    ],
)
def test_a_negative_radius_is_refused_at_its_line(extra, start):
    text = CART.format(force="0", extra=extra)
    err = _error(text)
    assert "radius" in err and ">= 0" in err and f":{_line(text, start)}:" in err, err


@pytest.mark.parametrize("n", [pytest.param(16, marks=pytest.mark.slow), 200, 350])
def test_min_and_max_of_many_arguments_do_not_recurse(n):
    args = ",".join(f"x^2+{i}*x" for i in range(n))
    text = CART.format(force=f"max({args})", extra="")
    try:
        system = lamech.loads(text)
    except lamech.ProblemFileError as exc:  # refused with a word, not a RecursionError
        assert "arguments" in str(exc) and "at most" in str(exc)
        return
    traj = lamech.simulate(system, 0.2, samples=3)
    assert traj.status == "ok"


def test_a_max_of_many_arguments_switches_at_the_right_times():
    # max(t - 0.1, 0, ..., t - k/10 ...): the largest is t - 0.1 once t > 0.1
    args = ", ".join(["0"] + [f"t - {k / 10}" for k in range(1, 40)])
    text = CART.format(force=f"max({args})", extra="")
    traj = lamech.simulate(lamech.loads(text), 0.5, samples=6)
    import numpy as np

    # x'' = max(0, t - 0.1): x(0.5) = 0.4^3 / 6
    assert np.isclose(traj.q[-1, 0], 0.4**3 / 6, rtol=1e-6), traj.q[-1, 0]


PENDULUM = lamech.problem.example_path("pendulum").read_text(encoding="utf-8")


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


@pytest.mark.parametrize(
    "divisor",
    ["sin(x)^2 + cos(x)^2 - 1", "cosh(x)^2 - sinh(x)^2 - 1", "(1 + tan(x)^2)*cos(x)^2 - 1"],
)
def test_a_division_by_an_expression_identically_zero_is_refused_with_its_line(divisor):
    text = (
        'title = "zero"\n[parameters]\nm = 1.0\n[coordinates]\n'
        "x = { initial = 0.3, velocity = 0 }\n[lagrangian]\n"
        f'T = "m/2*x\'^2"\nV = "m*x^2/({divisor})"\n'
    )
    with pytest.raises(lamech.ProblemFileError) as err:
        lamech.loads(text)
    message = str(err.value)
    assert ":8:" in message and "lagrangian.V" in message
    assert f"division by zero: `{divisor}` is 0 whatever the values of x" in message
    # a divisor that only looks alike is accepted, and one zero at one point too
    for fine in ("sin(x)^2 + cos(x)^2", "sin(x)^2 + cos(x)^2 - 1 + x", "sin(x)"):
        lamech.loads(text.replace(divisor, fine))


def test_a_power_of_an_identically_zero_base_to_a_negative_exponent_is_refused():
    import sympy as sp

    from lamech.expr import ExpressionError, parse

    x = sp.Symbol("x", real=True)
    with pytest.raises(ExpressionError, match=r"`sin\(x\)\^2 \+ cos\(x\)\^2 - 1` is 0"):
        parse("(sin(x)^2 + cos(x)^2 - 1)^(-2)", {"x": x}, "test")
