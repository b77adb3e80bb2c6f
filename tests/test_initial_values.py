"""Values given by the user: ``lamech solve`` takes ``--param`` and ``--initial`` as
``simulate`` does, and a parameter's name is a value wherever a number is (an initial
value, a point of ``lamech modes``)."""

from __future__ import annotations

import subprocess
import sys

import pytest

import lamech
from lamech.cli import main


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


# ----- a parameter's name as a value -----------------------------------------------------
@pytest.mark.parametrize(
    "command, by_name, by_number",
    [
        (["simulate", "pendulum", "--t-end", "0.2", "--samples", "3"], "theta=theta0", "theta=0.5"),
        pytest.param(["solve", "pendulum"], "theta=l", "theta=1", marks=pytest.mark.slow),
    ],
)
def test_a_parameters_name_as_an_initial_value_is_its_value(command, by_name, by_number, capsys):
    assert main([*command, "--initial", by_name]) == 0
    named = capsys.readouterr()
    assert main([*command, "--initial", by_number]) == 0
    numbered = capsys.readouterr()
    assert "Traceback" not in named.err and named.out == numbered.out


@pytest.mark.slow
def test_a_parameters_name_as_a_point_of_modes_is_its_value(capsys):
    assert main(["modes", "pendulum", "--at", "theta=theta0"]) == 0
    named = capsys.readouterr()
    assert main(["modes", "pendulum", "--at", "theta=0.5"]) == 0
    assert named.out == capsys.readouterr().out and "Traceback" not in named.err
    assert main(["modes", "pendulum", "--at", "theta=m*x"]) == 2
    assert "--at theta=m*x" in capsys.readouterr().err
