"""The library's messages name its arguments (`` `max_step=` ``); the command line says
its flags (``--max-step``) for the same messages (the command line's terms module)."""

from __future__ import annotations

import re

import pytest

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
