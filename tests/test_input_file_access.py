"""Issue 29, item 1: a problem file reads no file outside its own folder (symlinks
followed; ``--data-dir`` widens it), never echoes a file that is not a table, never tells
whether a path outside exists; a problem given as text (the page's) names no files."""

from __future__ import annotations

import os

import pytest

import lamech
from lamech.cli import main

PROBLEM = """
title = "a rotor driven by a tabulated torque"
[parameters]
I = 0.5
[coordinates]
phi = {{ initial = 0, velocity = 0 }}
[inputs]
tau = {{ csv = "{csv}", column = "tau" }}
[lagrangian]
T = "I/2*phi'^2"
V = "0"
[forces]
phi = "tau"
"""
SECRET = "API_KEY=hunter2-the-secret\nOTHER=1\nTHIRD=2\n"


@pytest.fixture
def tree(tmp_path):
    """tmp/problem/ (the problem's folder), tmp/outside/.env (a secret), tmp/data/ (a
    table elsewhere)."""
    (tmp_path / "problem").mkdir()
    (tmp_path / "outside").mkdir()
    (tmp_path / "outside" / ".env").write_text(SECRET)
    (tmp_path / "data").mkdir()
    (tmp_path / "data" / "torque.csv").write_text("t,tau\n0,0\n1,2\n2,0\n")
    return tmp_path


def _refusal(tree, csv: str) -> str:
    path = tree / "problem" / "rotor.toml"
    path.write_text(PROBLEM.format(csv=csv))
    with pytest.raises(lamech.ProblemFileError) as err:
        lamech.load(path)
    text = str(err.value)
    assert "hunter2" not in text and "API_KEY" not in text
    assert "inputs.tau" in text and ":8:" in text  # the input's line
    return text


@pytest.mark.parametrize("csv", ["../outside/.env", "{tree}/outside/.env", "/etc/passwd"])
def test_a_file_outside_the_problems_folder_is_refused_unread(tree, csv):
    text = _refusal(tree, csv.format(tree=tree))
    assert "outside the problem file's folder" in text and "with `data_dir=`" in text


def test_whether_a_path_outside_exists_is_not_told(tree):
    there = _refusal(tree, "../outside/.env")
    absent = _refusal(tree, "../outside/no-such.env")
    assert there.replace(".env", "X") == absent.replace("no-such.env", "X")


def test_a_symlink_out_of_the_folder_is_followed_and_refused(tree):
    os.symlink(tree / "outside" / ".env", tree / "problem" / "torque.csv")
    assert "outside the problem file's folder" in _refusal(tree, "torque.csv")


def test_a_file_inside_that_is_not_a_table_is_not_echoed(tree):
    (tree / "problem" / ".env").write_text(SECRET)
    text = _refusal(tree, ".env")
    assert "not a table of numbers" in text
    (tree / "problem" / "bin.csv").write_bytes(b"t,tau\n\xff\xfe secret \x00\n1,2\n")
    assert "secret" not in _refusal(tree, "bin.csv")


def test_a_problem_given_as_text_names_no_files(tree):
    with pytest.raises(lamech.ProblemFileError) as err:
        lamech.loads(PROBLEM.format(csv="../outside/.env"), name="problem.toml")
    text = str(err.value)
    assert "names no files" in text and "hunter2" not in text


def test_data_dir_widens_the_folder(tree, capsys):
    path = tree / "problem" / "rotor.toml"
    path.write_text(PROBLEM.format(csv="../data/torque.csv"))
    _refusal(tree, "../data/torque.csv")
    system = lamech.load(path, data_dir=tree / "data")
    assert "tau" in str(system.forces)
    assert main(["solve", str(path)]) == 2
    assert "holds it with --data-dir" in capsys.readouterr().err  # the library's data_dir=
    assert main(["solve", str(path), "--data-dir", str(tree / "data")]) == 0
    # the wider folder is not everything: the secret stays out
    path.write_text(PROBLEM.format(csv="../outside/.env"))
    assert main(["solve", str(path), "--data-dir", str(tree / "data")]) == 2
    assert "hunter2" not in capsys.readouterr().err
