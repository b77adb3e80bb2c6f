"""Issue 29, item 5: impossible inputs refused with their line (clip with lo > hi, an
inertia no body has, a negative radius), and min/max of many arguments handled
without recursion."""

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
