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
        return subprocess.run([sys.executable, "-m", "lamech", *args], stdout=write,
                              stderr=subprocess.PIPE, text=True, timeout=120)
    finally:
        os.close(write)


@pytest.mark.parametrize("args", [["examples"], ["solve", "pendulum"]])
def test_a_closed_pipe_ends_quietly(args):
    out = _closed_pipe_run(args)
    assert "Traceback" not in out.stderr and "BrokenPipeError" not in out.stderr
    assert out.returncode == 141


def test_sweep_into_a_closed_pipe_ends_quietly():
    out = _closed_pipe_run(["sweep", "pendulum", "--param", "l=0.5,1", "--measure",
                            "max:lambda:string", "--t-end", "0.2", "--samples", "3",
                            "--workers", "1"])
    assert "Traceback" not in out.stderr and "BrokenPipeError" not in out.stderr
    assert out.returncode == 141


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
    out = subprocess.run([sys.executable, "-m", "lamech", "solve", str(path)],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 2 and "Traceback" not in out.stderr
    assert "missing prime" in out.stderr
