"""The shape of the package: the layer order holds (import-linter, module- and
function-level imports), the command line starts without the heavy libraries, and the
tests use only public names."""

from __future__ import annotations

import ast
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


# ----- the numeric layer's kernels (issue 31) ----------------------------------------
KERNELS = ROOT / "lamech" / "numeric" / "_kernels"


def test_the_kernels_codes_are_defined_once_and_the_engine_reads_the_same_values():
    """The loop's integer codes (issue 31): one definition, the engine in C's copy the
    same values (codes.h), and Python's maps of the results."""
    from lamech.numeric import EventKind, FrictionState
    from lamech.numeric._batch import FALLBACKS
    from lamech.numeric._kernels import codes

    engine = ROOT / "lamech" / "numeric" / "_engine"
    header = (engine / "codes.h").read_text(encoding="utf-8")
    assigned = dict(re.findall(r"^#define LM_([A-Z][A-Z_]+) (\d+)$", header, flags=re.M))
    values = codes.constants()
    assert {k: int(v) for k, v in assigned.items()} == values
    # no other file of the engine spells a code as a number of its own
    for path in sorted(engine.glob("*.[ch]")):
        if path.name != "codes.h":
            source = path.read_text(encoding="utf-8")
            assert not re.search(r"#define LM_(EV|FR|ST|DT|TL|LM|IO|FO)_", source), path.name
    # the rules are written once, in C: of the Python kernels only the codes remain
    assert sorted(p.name for p in KERNELS.glob("*.py")) == ["__init__.py", "codes.py"]
    # the maps Python reads the results by cover every code, in both directions
    events = {v for k, v in values.items() if k.startswith("EV_")}
    assert set(codes.EVENT_KINDS) == events
    assert {codes.EVENT_CODES[k] for k in codes.EVENT_KINDS.values()} == events
    assert set(codes.FRICTION) == {None, *FrictionState}
    assert {codes.FRICTION_STATES[c] for c in codes.FRICTION.values()} == {None, *FrictionState}
    # ST_BUDGET is internal; ST_MEMORY the C engine's, raised as MemoryError by its binding
    internal = {codes.ST_BUDGET, codes.ST_MEMORY}
    statuses = {v for k, v in values.items() if k.startswith("ST_")} - internal
    assert set(codes.STATUS_NAMES) == statuses and FALLBACKS == codes.FALLBACKS
    assert set(codes.EVENT_CODES) == set(EventKind)  # every kind, input switches too
    details = {v for k, v in values.items() if k.startswith("DT_")} - {codes.DT_NONE}
    assert set(codes.DETAILS) == details


def test_no_kernel_takes_more_than_a_dozen_parameters_and_no_module_is_long():
    """A kernel takes records (tuples and arrays), not dozens of loose values."""
    for path in sorted(KERNELS.glob("*.py")):
        source = path.read_text(encoding="utf-8")
        assert len(source.splitlines()) < 600, path.name
        for node in ast.walk(ast.parse(source)):
            if isinstance(node, ast.FunctionDef):
                count = len(node.args.args) + len(node.args.kwonlyargs)
                assert count <= 12, (path.name, node.name, count)


def test_the_one_step_control_does_not_grow_a_step_right_after_a_rejection():
    """The batch loop and the loop with events step with one DOP853 step control (the
    engine's lm_dop853_step), with SciPy's rule that a step does not grow right after a
    rejection."""
    engine = ROOT / "lamech" / "numeric" / "_engine"
    control = (engine / "dop853.c").read_text(encoding="utf-8")
    assert "if (rejected && !(factor < 1.0))" in control
    for name in ("batch.c", "loop.c"):
        source = (engine / name).read_text(encoding="utf-8")
        assert "lm_dop853_step(" in source and "pow(err" not in source


def test_no_public_function_takes_more_than_eight_parameters():
    # diffrax and SciPy pass configuration as small objects: lamech's is lamech.Options.
    # A class's fields (a record: System, Trajectory) are not counted; *args / **kwargs
    # count as one each.
    import inspect

    import lamech

    long = {}
    for name in lamech.__all__:
        value = getattr(lamech, name)
        if inspect.isfunction(value):
            count = len(inspect.signature(value).parameters)
            if count > 8:
                long[name] = count
    assert not long, long


# Below the present layer, writing a format: a CSV writer, JSON text, a DataFrame or a
# figure saved. Reading is not writing (csv.reader, json.load, pandas.read_parquet).
WRITERS = {"csv.writer", "csv.DictWriter", "json.dump", "json.dumps"}
WRITER_METHODS = {"to_csv", "to_parquet", "to_excel", "savefig", "writerow", "writerows"}
RECORDS = {
    # the record of a sweep beside its table (<table>.sweep.json), read back on resume to
    # refuse a table made with other options
    ("lamech/sweeps/_table.py", "json.dumps"),
    # the manifest of the engine's build cache (file hashes), read back to check it
    ("lamech/numeric/_integrity.py", "json.dumps"),
}


def _format_writes(source: str) -> list[tuple[int, str]]:
    """(line, what) of each format written in ``source`` (see WRITERS)."""
    tree = ast.parse(source)
    alias = {}  # a local name -> the dotted name it stands for
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                top = a.name.split(".")[0]
                alias[a.asname or top] = a.name if a.asname else top
                if top == "matplotlib":
                    found.append((node.lineno, "import matplotlib"))
        elif isinstance(node, ast.ImportFrom) and node.module and not node.level:
            if node.module.split(".")[0] == "matplotlib":
                found.append((node.lineno, f"from {node.module} import"))
            for a in node.names:
                alias[a.asname or a.name] = f"{node.module}.{a.name}"
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        func = node.func
        if isinstance(func, ast.Attribute) and func.attr in WRITER_METHODS:
            found.append((node.lineno, f".{func.attr}()"))
        elif isinstance(func, ast.Attribute) and isinstance(func.value, ast.Name):
            name = f"{alias.get(func.value.id, func.value.id)}.{func.attr}"
            if name in WRITERS:
                found.append((node.lineno, name))
        elif isinstance(func, ast.Name) and alias.get(func.id) in WRITERS:
            found.append((node.lineno, str(alias[func.id])))
    return found


def test_only_the_present_layer_writes_formats():
    """CSV, JSON and plots have one home, ``lamech/present/`` (``lamech.to_csv``,
    ``lamech.to_json``, ``plot_*``); the CLI above it prints what present gives. Below it
    (sweeps, numeric, symbolic, problem, model, expr, linalg) the result types hold data:
    no module there calls ``csv.writer``/``csv.DictWriter``, ``json.dump``/``json.dumps``,
    a ``to_csv``/``to_parquet``/``to_excel``/``savefig``/``writerow`` method, or imports
    matplotlib. A sweep's table on disk is written by ``sweeps/_table.py`` as the cases
    finish, its rows' text made by ``present/_table.py`` (the import declared in
    pyproject.toml). Exceptions: records lamech writes for itself and reads back, never
    results (``RECORDS``: the sweep's ``.sweep.json`` beside its table, the engine cache's
    manifest). Reading a file (``csv.reader``, ``json.load``) is allowed anywhere, and so
    is building a plain dict (``Event.to_json``)."""
    lamech = ROOT / "lamech"
    found = []
    for path in sorted(lamech.rglob("*.py")):
        if path.relative_to(lamech).parts[0] in ("present", "cli", "__main__.py"):
            continue
        rel = path.relative_to(ROOT).as_posix()
        for line, what in _format_writes(path.read_text(encoding="utf-8")):
            if (rel, what) not in RECORDS:
                found.append(f"{rel}:{line}: {what}")
    assert not found, found
    assert all((ROOT / rel).exists() for rel, _ in RECORDS)  # no stale exception
