"""Slowness is marked at the test (``pytest.param(..., marks=pytest.mark.slow)``), and
every parametrized test keeps at least one case in the default set (``-m "not slow"``):
tests/conftest.py refuses, when it collects the file, a test whose every case is slow
and that is not marked slow as a whole."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent

ALL_SLOW = """
import pytest

@pytest.mark.parametrize("n", [pytest.param(1, marks=pytest.mark.slow), 2])
def test_one_slow(n):
    pass

@pytest.mark.slow
@pytest.mark.parametrize("n", [pytest.param(1, marks=pytest.mark.slow)])
def test_slow_as_a_whole(n):
    pass

@pytest.mark.parametrize("n", [pytest.param(1, marks=pytest.mark.slow)])
def test_every_case_slow(n):
    pass
"""


def _collect(tmp_path: Path, text: str) -> subprocess.CompletedProcess:
    shutil.copy(HERE / "conftest.py", tmp_path / "conftest.py")
    (tmp_path / "test_it.py").write_text(text, encoding="utf-8")
    return subprocess.run(
        [sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider"]
        + ["-p", "no:xdist", "-m", "not slow", "test_it.py"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        check=False,
    )


@pytest.mark.slow
def test_a_test_whose_every_case_is_slow_is_refused_unless_marked_whole(tmp_path):
    out = _collect(tmp_path, ALL_SLOW)
    assert out.returncode != 0
    assert "test_it.py::test_every_case_slow: every case of 'n' is marked slow" in out.stdout
    assert "test_one_slow" not in out.stdout and "test_slow_as_a_whole" not in out.stdout
    fixed = ALL_SLOW.rpartition("\n@pytest.mark.parametrize")[0]  # test_every_case_slow gone
    out = _collect(tmp_path, fixed)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "test_it.py::test_one_slow[2]" in out.stdout and "test_slow_as_a_whole" not in out.stdout
