"""The compiled cache is code (issue 44): lamech loads from a cache folder only where no
one else can write it (`numeric/_trust.py`), a damaged file in it is a miss that is built
again with one line said (`numeric/_integrity.py`), a read-only folder is loaded from
without compiling and without leaving temporary folders, and a wait for another
process's compile says so.

The tests run as root here, which passes every permission check: "others can write" and
"read-only" are the mode bits, which is what lamech decides by."""

from __future__ import annotations

import ctypes
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

import lamech
from lamech.numeric import compile_system, compiled_available
from lamech.numeric._cc import FUNCTIONS, CompileFailed, compiler, library_path, load
from lamech.problem import example_path


def _cc_works() -> bool:
    if compiler() is None:
        return False
    body = "#include <math.h>\n" + "\n".join(f"void {f}(void) {{}}" for f in FUNCTIONS)
    with tempfile.TemporaryDirectory() as tmp:
        try:
            load(body, Path(tmp) / "kernels")
        except CompileFailed:
            return False
    return True


needs_cc = pytest.mark.skipif(not _cc_works(), reason="no working C compiler")
needs_engine = pytest.mark.skipif(not compiled_available(), reason="no C compiler or engine")


def _cylinder_c() -> str:
    text = example_path("cylinder").read_text(encoding="utf-8")
    return compile_system(lamech.loads(text), jit=False).c_source


def _energy(lib) -> float:
    """The cylinder's c_energy at one state: the library works."""
    out = np.zeros(2)
    # r, theta1, theta2 and their rates; m, g, R1, R2
    q, v, p = np.array([1.5, 0.2, 0.3]), np.array([0.0, 0.1, 0.2]), np.ones(4)
    f = lib.c_energy
    f.restype = None
    f(ctypes.c_double(0.0), *(ctypes.c_void_p(a.ctypes.data) for a in (q, v, p, out)))
    return float(out[0])


PLANT = """
#include <stdio.h>
__attribute__((constructor)) static void planted(void) {
    FILE *f = fopen("%s", "w");
    if (f) { fputs("ran\\n", f); fclose(f); }
}
"""


@needs_cc
def test_a_library_planted_in_a_folder_others_can_write_never_runs(tmp_path, monkeypatch, capfd):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "own"))
    marker = tmp_path / "marker"
    c_source = _cylinder_c()
    folder = tmp_path / "shared" / "kernels"
    folder.mkdir(parents=True)
    for f in (folder, folder.parent):
        os.chmod(f, 0o777)  # anyone on the machine can put a file here
    planted = library_path(c_source, folder)
    src = tmp_path / "plant.c"
    src.write_text(PLANT % marker)
    subprocess.run([*compiler(), "-shared", "-fPIC", "-o", str(planted), str(src)], check=True)
    lib, addresses, state = load(c_source, folder)
    assert not marker.exists(), "the planted library's constructor ran"
    assert all(addresses) and np.isfinite(_energy(lib))
    assert state == "compiled"  # in the user's own folder instead, made private
    own = tmp_path / "own" / "lamech" / "kernels"
    assert library_path(c_source, own).is_file()
    assert (own.stat().st_mode & 0o777) == 0o700
    err = capfd.readouterr().err.strip().splitlines()
    # the first folder refused: the one above kernels (LAMECH_CACHE_DIR itself)
    assert len(err) == 1 and f"{folder.parent} can be written by" in err[0], err
    assert "chmod go-w" in err[0]
    assert "LAMECH_CACHE_DIR" in err[0] and f"using {own} instead" in err[0]
    load(c_source, folder)  # said once per process
    assert capfd.readouterr().err == ""


@needs_cc
def test_a_library_of_another_user_or_writable_by_others_is_not_loaded(tmp_path, capfd):
    c_source = _cylinder_c()
    folder = tmp_path / "kernels"
    _, _, first = load(c_source, folder)
    path = library_path(c_source, folder)
    assert first == "compiled" and (folder.stat().st_mode & 0o777) == 0o700
    assert (path.stat().st_mode & 0o777) == 0o700
    os.chmod(path, 0o777)
    lib, _, state = load(c_source, folder)
    assert state == "compiled" and np.isfinite(_energy(lib))  # built again, not loaded
    err = capfd.readouterr().err
    assert str(path) in err and "others" in err and len(err.strip().splitlines()) == 1


@needs_cc
@pytest.mark.parametrize("damage", ["truncated", "empty"])
def test_a_damaged_library_is_built_again_and_said_once(tmp_path, damage, capfd):
    c_source = _cylinder_c()
    folder = tmp_path / "kernels"
    lib, _, first = load(c_source, folder)
    want = _energy(lib)
    path = library_path(c_source, folder)
    data = path.read_bytes()
    cut = data[: len(data) // 2] if damage == "truncated" else b""
    # a new process (one process keeps a library loaded): this one cut short or empty
    probe = f"""
import ctypes, json, sys
import numpy as np
from pathlib import Path
sys.path.insert(0, {str(Path(__file__).parent)!r})
from test_cache_trust import _energy
from lamech.numeric._cc import load
lib, _, state = load(sys.stdin.read(), Path({str(folder)!r}))
print(json.dumps({{"state": state, "energy": _energy(lib)}}))
"""
    path.write_bytes(cut)
    runs = []
    for _ in range(2):
        done = subprocess.run(
            [sys.executable, "-c", probe], input=c_source, capture_output=True, text=True,
            timeout=300,
        )  # fmt: skip
        assert done.returncode == 0, (done.returncode, done.stderr)
        runs.append((json.loads(done.stdout), done.stderr))
    (first_run, said), (second_run, quiet) = runs
    assert first_run["state"] == "compiled" and first_run["energy"] == want
    lines = said.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0] and "building it again" in lines[0], said
    assert second_run["state"] == "loaded" and second_run["energy"] == want and quiet == ""
    assert path.read_bytes() == data  # the same bytes as the first build


@needs_cc
def test_a_read_only_folder_is_loaded_from_and_leaves_no_temporary_folder(tmp_path, capfd):
    c_source = _cylinder_c()
    folder = tmp_path / "kernels"
    load(c_source, folder)
    os.chmod(folder, 0o555)
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    probe = f"""
import json, sys
from pathlib import Path
from lamech.numeric._cc import load
_, _, state = load(sys.stdin.read(), Path({str(folder)!r}))
print(json.dumps({{"state": state}}))
"""
    env = dict(os.environ, TMPDIR=str(tmp))
    done = subprocess.run(
        [sys.executable, "-c", probe], input=c_source, capture_output=True, text=True, env=env,
        timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["state"] == "loaded" and done.stderr == ""
    assert list(tmp.iterdir()) == []
    # another problem, not in the read-only folder: built for the process, then removed
    other = c_source + "\n/* another */\n"
    done = subprocess.run(
        [sys.executable, "-c", probe], input=other, capture_output=True, text=True, env=env,
        timeout=300,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["state"] == "memory"
    assert list(tmp.iterdir()) == []  # no lamech-c-* left behind
    assert sorted(p.name for p in folder.iterdir()) == sorted(
        [library_path(c_source, folder).name, library_path(c_source, folder).stem + ".json"]
    )


def _simulate(cache: Path, tmp: Path | None = None) -> tuple[dict, str]:
    """``lamech simulate cylinder`` on the compiled loop in a new process: (its JSON
    summary, its stderr)."""
    env = dict(os.environ, LAMECH_CACHE_DIR=str(cache))
    if tmp is not None:
        env["TMPDIR"] = str(tmp)
    done = subprocess.run(
        [sys.executable, "-m", "lamech", "simulate", "cylinder", "--t-end", "3",
         "--initial", "theta1=0.01", "--engine", "compiled", "--json"],
        capture_output=True, text=True, env=env, timeout=1500,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr
    return json.loads(done.stdout), done.stderr


def _files(folder: Path) -> dict[str, tuple[int, int]]:
    return {str(p): (p.stat().st_size, p.stat().st_mtime_ns) for p in folder.rglob("*")}


@needs_engine
@pytest.mark.slow
def test_a_read_only_cache_is_loaded_from_and_nothing_is_left_in_tmp(tmp_path):
    cache = tmp_path / "cache"
    want, _ = _simulate(cache)  # the cylinder's library built in the cache folder
    for folder in (cache / "kernels", cache):
        os.chmod(folder, 0o555)  # an administrator's cache, a container image
    before = _files(cache)
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    try:
        got, said = _simulate(cache, tmp)
    finally:
        for folder in (cache, cache / "kernels"):
            os.chmod(folder, 0o700)
    assert got == want and said == ""
    assert got["engine"] == "loop (C)", got
    assert list(tmp.iterdir()) == []  # no lamech-c-* folder left behind
    assert _files(cache) == before  # nothing written in the read-only folder
