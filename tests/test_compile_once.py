"""Compile once: a system's functions compiled by the C compiler are cached on disk, a
second process loads them instead of compiling them again, two processes may compile them
at once, a changed source gets a new file, and an unusable cache directory compiles in
memory, silently. (The engine itself is built at install: nothing of it is compiled at
run time.)"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import lamech
from lamech.numeric import compile_system, compiled_available, jit_cache_dir, simulate
from lamech.numeric._cc import library_path
from lamech.problem import chain_toml, example_path

needs_engine = pytest.mark.skipif(not compiled_available(), reason="no C compiler or engine")

# One run in a fresh process: compile a 2-link chain with jit, integrate it (simulate and
# the batch loop), and report where the compiled code came from, how long compile_system
# took, and the final states.
PROBE = """
import json, sys, time
import numpy as np
import lamech
from lamech.numeric import compile_system, integrate_batch, simulate
from lamech.problem import chain_toml
system = lamech.loads(chain_toml(2))
t0 = time.perf_counter()
ns = compile_system(system, jit=True)
traj = simulate(ns, 1.0, samples=11)
seconds = time.perf_counter() - t0  # the system's functions and the loop: compiled or loaded
batch = np.zeros((1, 0))
if sys.argv[1:] == ["batch"]:
    batch = integrate_batch(ns, [np.concatenate([traj.q[0], traj.qd[0]])], 0.5).q
print(json.dumps({
    "jit": ns.jit, "cache": ns.jit_cache, "seconds": seconds, "engine": traj.engine,
    "final": traj.q[-1].tolist() + traj.qd[-1].tolist(), "batch": batch.tolist(),
}))
"""


def _start(cache: Path, *args: str) -> subprocess.Popen:
    env = dict(os.environ, LAMECH_CACHE_DIR=str(cache))
    return subprocess.Popen(
        [sys.executable, "-c", PROBE, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )


def _result(proc: subprocess.Popen) -> dict:
    out, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, err
    assert "Warning" not in err, err  # silent, in every case
    return json.loads(out.splitlines()[-1])


def test_the_cache_directory_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv("LAMECH_CACHE_DIR", str(tmp_path / "mine"))
    assert jit_cache_dir() == tmp_path / "mine" / "kernels"
    monkeypatch.delenv("LAMECH_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert jit_cache_dir() == tmp_path / "xdg" / "lamech" / "kernels"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/ignored")  # the XDG spec: absolute only
    assert jit_cache_dir() == Path.home() / ".cache" / "lamech" / "kernels"
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert jit_cache_dir() == Path.home() / ".cache" / "lamech" / "kernels"


@needs_engine
def test_a_second_process_loads_the_compiled_system_and_two_may_compile_at_once(tmp_path):
    cache = tmp_path / "cache"
    # two processes compile the same system at once (a sweep's workers do): both finish,
    # on the engine, with the same numbers, and leave one library of the system (beside
    # it, the record of its size and SHA-256 that lamech checks before loading)
    first = [_start(cache, "batch"), _start(cache)]
    a, b = (_result(p) for p in first)
    assert a["jit"] and b["jit"] and a["engine"] == b["engine"] == "loop (C)"
    assert {a["cache"], b["cache"]} <= {"compiled", "loaded"}
    assert a["final"] == b["final"]
    files = sorted(p for p in (cache / "kernels").glob("lamech_*") if p.suffix != ".json")
    assert len(files) == 1 and files[0].suffix == ".so", files
    assert not list((cache / "kernels").glob("*.tmp"))  # no temporary file left behind
    assert not list((cache / "kernels").glob(".build-*"))
    # a later process compiles nothing: the system's library comes from the cache
    t0 = time.perf_counter()
    c = _result(_start(cache, "batch"))
    wall = time.perf_counter() - t0
    assert c["cache"] == "loaded", c
    assert c["final"] == a["final"] and c["batch"] == a["batch"]
    assert wall < 60.0


@needs_engine
def test_an_unusable_cache_directory_compiles_in_memory_silently(tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a directory\n")
    proc = _start(blocker / "cache")  # under a regular file: cannot be created
    result = _result(proc)
    assert result["jit"] and result["cache"] == "memory"
    reference = simulate(compile_system(lamech.loads(chain_toml(2))), 1.0, samples=11)
    final = np.concatenate([reference.q[-1], reference.qd[-1]])
    assert np.allclose(result["final"], final, rtol=1e-9, atol=1e-12)


@needs_engine
def test_a_changed_source_gets_a_new_file(tmp_path, monkeypatch):
    monkeypatch.setenv("LAMECH_CACHE_DIR", str(tmp_path))
    # two variants of the pendulum no other test compiles (one process compiles a text
    # once, so a system compiled before in this worker would not be written here)
    text = example_path("pendulum").read_text(encoding="utf-8")
    one, two = (
        text.replace('V = "-m*g*r*cos(theta)"', f'V = "-{k}*m*g*r*cos(theta)"') for k in (1.25, 1.5)
    )
    assert one != text and two != text
    a = compile_system(lamech.loads(one), jit=True)
    b = compile_system(lamech.loads(two), jit=True)
    assert a.source != b.source
    assert a.c_source != b.c_source
    folder = tmp_path / "kernels"
    libraries = {p.name for p in folder.glob("lamech_c_*.so")}
    assert libraries == {library_path(ns.c_source, folder).name for ns in (a, b)}
    assert {a.jit_cache, b.jit_cache} <= {"compiled", "loaded"}
