"""``SLOW_CASES`` (tests/conftest.py) names only cases that exist: a test renamed, or a
parameter's id changed, would otherwise put its slow cases back in the default set with
nothing to say so."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _collect(files: list[str]) -> dict[str, set]:
    """The cases of ``files`` by test, as ``pytest --collect-only`` lists them."""
    out = subprocess.run(
        [sys.executable, "-m", "pytest", "--collect-only", "-q", "-n", "0"]
        + ["-p", "no:cacheprovider", *(f"tests/{f}" for f in files)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        check=False,
    )
    assert out.returncode == 0, out.stdout[-2000:] + out.stderr[-2000:]
    cases: dict[str, set] = {}
    for line in out.stdout.splitlines():
        if line.startswith("tests/") and "::" in line:
            test, _, case = line.removeprefix("tests/").partition("[")
            cases.setdefault(test, set()).add(case[:-1])
    return cases


def test_every_slow_case_names_a_collected_test(slow_cases_collected):
    slow, collected, whole = slow_cases_collected
    # the files this run did not collect whole are collected here, by themselves
    others = sorted({test.partition("::")[0] for test in slow} - whole)
    if others:
        collected = {**collected, **_collect(others)}
    stale = [
        f"{test}[{case}]"
        for test, cases in sorted(slow.items())
        for case in sorted(cases - collected.get(test, set()))
    ]
    assert not stale, "SLOW_CASES in tests/conftest.py names cases no test has: " + ", ".join(stale)
