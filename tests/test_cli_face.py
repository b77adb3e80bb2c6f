"""The command's face for a newcomer (issue 48): --version, a bundled example printed to
copy and change, and one base class for every refusal."""

from __future__ import annotations

import pytest

import lamech
from lamech.cli import main


def test_version_is_the_packages(capsys):
    with pytest.raises(SystemExit) as done:
        main(["--version"])
    assert done.value.code == 0
    assert capsys.readouterr().out.strip() == f"lamech {lamech.__version__}"


def test_examples_name_prints_the_bundled_file_that_loads_as_itself(capsys, tmp_path):
    assert main(["examples", "pendulum"]) == 0
    text = capsys.readouterr().out
    assert lamech.loads(text).title == lamech.load("pendulum").title
    copy = tmp_path / "mine.toml"
    copy.write_text(text)
    assert lamech.solve(lamech.load(str(copy))).multipliers == lamech.solve("pendulum").multipliers


def test_examples_with_an_unknown_name_lists_the_known_ones(capsys):
    assert main(["examples", "pendulun"]) == 2
    err = capsys.readouterr().err
    assert "no bundled example `pendulun`" in err and "pendulum" in err


@pytest.mark.parametrize(
    "name",
    [
        "ProblemFileError",
        "ModelError",
        "ExpressionError",
        "DegenerateConstraintsError",
        "SimulationError",
        "SweepError",
    ],
)
def test_every_public_refusal_is_a_lamech_error_and_a_value_error(name):
    cls = getattr(lamech, name)
    assert issubclass(cls, lamech.LamechError) and issubclass(cls, ValueError)


def test_a_typo_in_a_file_is_caught_as_a_lamech_error():
    with pytest.raises(lamech.LamechError, match=r"<string>:3: coordinates\.x\.initial"):
        lamech.loads('title = "t"\n[coordinates]\nx = { initial = "2*" }\n')


def test_a_long_solve_says_its_stages_into_a_log_too(capsys, monkeypatch):
    """Not on a terminal (a batch job's log): a line per stage once the solve has run
    $LAMECH_PROGRESS_AFTER seconds (-1 here, so no clock decides the test)."""
    monkeypatch.setenv("LAMECH_PROGRESS_AFTER", "-1")
    assert main(["solve", "pendulum"]) == 0
    err = capsys.readouterr().err.splitlines()
    stages = [line for line in err if line.startswith("lamech: solving: ")]
    assert stages and len(stages) == len(set(stages))
    assert "lamech: solving: the equations of motion ..." in stages


def test_an_error_shows_at_most_200_characters_of_its_line():
    """A 10 kB expression refused for its length: the message names the line, and its
    echo is cut (it printed the whole line, 28 kB for a 40-link chain's T)."""
    long_t = "m/2*(" + " + ".join(f"x'^2*{i}" for i in range(1500)) + ")"
    text = 'title = "t"\n[parameters]\nm = 1.0\n[coordinates]\nx = { initial = 0 }\n'
    text += f'[lagrangian]\nT = "{long_t}"\nV = "0"\n'
    with pytest.raises(lamech.LamechError) as info:
        lamech.loads(text, "long.toml")
    message = str(info.value)
    assert "long.toml:7: lagrangian.T: expression too long" in message
    assert max(len(line) for line in message.splitlines()) < 260
