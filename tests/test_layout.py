"""The shape of the package: the layer order holds (import-linter, module- and
function-level imports), the command line starts without the heavy libraries, and the
tests use only public names."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
HEAVY = ("sympy", "numpy", "scipy", "matplotlib", "numba")


def _loaded_after(code: str) -> list[str]:
    """The heavy top-level packages a fresh interpreter has imported after ``code``."""
    probe = (
        f"{code}\nimport sys, json\n"
        f"print(json.dumps(sorted(m for m in sys.modules if m in {HEAVY!r})))"
    )
    out = subprocess.run(
        [sys.executable, "-c", probe], capture_output=True, text=True, cwd=ROOT, check=True
    )
    return json.loads(out.stdout.splitlines()[-1])


def test_layers_are_kept():
    exe = shutil.which("lint-imports", path=str(Path(sys.executable).parent))
    if exe is None:
        pytest.skip("import-linter is not installed (it is in the test extra)")
    out = subprocess.run([exe, "--no-cache"], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0, out.stdout + out.stderr
    assert "Contracts: 3 kept, 0 broken" in out.stdout, out.stdout  # layers, model, expr


def test_the_command_line_starts_without_heavy_imports():
    quiet = (
        "import contextlib, io, lamech.cli\n"
        "with contextlib.redirect_stdout(io.StringIO()):\n"
        "    try:\n        lamech.cli.main({args})\n"
        "    except SystemExit:\n        pass"
    )
    assert _loaded_after(quiet.format(args="['--help']")) == []
    assert _loaded_after(quiet.format(args="['examples']")) == []
    assert _loaded_after(quiet.format(args="['simulate', '--help']")) == []


def test_import_lamech_is_light_and_solve_needs_no_plotting():
    assert _loaded_after("import lamech") == []
    loaded = _loaded_after("import lamech; lamech.solve(lamech.load('pendulum'))")
    assert "matplotlib" not in loaded and "numba" not in loaded
    assert {"sympy", "numpy"} <= set(loaded)


def test_examples_lists_every_bundled_problem_with_its_title():
    import lamech

    out = subprocess.run(
        [sys.executable, "-m", "lamech", "examples"], capture_output=True, text=True, cwd=ROOT
    )
    assert out.returncode == 0
    names = [line.split()[0] for line in out.stdout.splitlines()]
    assert names == lamech.example_names()
    assert "cylinder           Solid cylinder rolling on a fixed cylinder" in out.stdout


def test_tests_use_public_names_only():
    """Tests use what a module declares: no underscore name, and from a private module
    (plumbing that the sub-packages' faces leave out, e.g. ``lamech.symbolic._normal``)
    only the names its ``__all__`` lists; no ``lamech.x._y`` reached by attribute."""
    import ast
    import importlib

    private = re.compile(
        r"lamech(\.\w+)*\._(?!_)\w|import lamech[\w.]*\._(?!_)|"
        r"from bench[\w.]* import [^\n#]*\b_(?!_)\w"
    )
    for path in sorted((ROOT / "tests").glob("*.py")):
        if path.name == "test_layout.py":
            continue
        text = path.read_text(encoding="utf-8")
        for node in ast.walk(ast.parse(text)):
            if not isinstance(node, ast.ImportFrom) or not (node.module or "").startswith("lamech"):
                continue
            names = [a.name for a in node.names]
            where = f"{path.name}:{node.lineno}: from {node.module} import {', '.join(names)}"
            assert not [n for n in names if n.startswith("_")], where
            if any(part.startswith("_") for part in node.module.split(".")):
                declared = getattr(importlib.import_module(node.module), "__all__", ())
                assert set(names) <= set(declared), f"{where}: not in its __all__"
        for number, line in enumerate(text.splitlines(), 1):
            if not line.lstrip().startswith("from lamech"):
                assert not private.search(line), f"{path.name}:{number}: {line.strip()}"


def _tool(name: str) -> str:
    exe = shutil.which(name, path=str(Path(sys.executable).parent))
    if exe is None:
        pytest.skip(f"{name} is not installed (it is in the test extra)")
    return exe


def test_ruff_check_and_format_are_clean():
    for args in (["check", "lamech", "bench", "tests"], ["format", "--check", "lamech", "tests"]):
        out = subprocess.run([_tool("ruff"), *args], capture_output=True, text=True, cwd=ROOT)
        assert out.returncode == 0, out.stdout + out.stderr


@pytest.mark.slow
def test_mypy_is_clean():
    out = subprocess.run([_tool("mypy")], capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 0, out.stdout + out.stderr


def test_the_version_is_in_one_place():
    import lamech

    text = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    assert 'dynamic = ["version"]' in text and "lamech._version.__version__" in text
    assert re.fullmatch(r"\d+\.\d+\.\d+", lamech.__version__)
    assert (ROOT / "LICENSE").read_text(encoding="utf-8").startswith("MIT License")
