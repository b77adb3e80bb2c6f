"""Compile once: a system compiled with numba is cached on disk, a second process loads it
instead of compiling it again, two processes may compile it at once, a changed source
gets a new file, and an unusable cache directory compiles in memory, silently."""

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
from lamech.numeric import compile_system, jit_cache_dir, numba_available, simulate
from lamech.numeric._cc import compiler, library_path
from lamech.problem import chain_toml, example_path

needs_numba = pytest.mark.skipif(not numba_available(), reason="numba not installed")

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
stats, batch = [], np.zeros((1, 0))
if sys.argv[1:] == ["batch"]:  # one row: the serial loop (with two or more threads)
    batch = integrate_batch(ns, [np.concatenate([traj.q[0], traj.qd[0]])], 0.5).q
    stats = [f.engine_function.stats for f in ns.batch_loops]
print(json.dumps({
    "jit": ns.jit, "cache": ns.jit_cache, "seconds": seconds,
    "final": traj.q[-1].tolist() + traj.qd[-1].tolist(), "batch": batch.tolist(),
    "batch_hits": sum(sum(s.cache_hits.values()) for s in stats),
    "batch_misses": sum(sum(s.cache_misses.values()) for s in stats),
    # imported only by numba's set-up to compile (its typing and lowering registries),
    # which a load from the cache skips (_jitcache._quick_cache_class)
    "registries": "numba.typed.typeddict" in sys.modules,
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
    # the first compile on a machine compiles the whole loop (3-4 minutes of CPU; two at
    # once on a busy 2-core machine take longer than that in wall time)
    out, err = proc.communicate(timeout=1500)
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


@needs_numba
@pytest.mark.slow
@pytest.mark.shared_cache
def test_a_second_process_loads_the_compiled_system_and_two_may_compile_at_once(tmp_path):
    cache = tmp_path / "cache"
    # two processes compile the same system at once (a sweep's workers do): both finish,
    # with the same numbers, and leave one module file of the system (and one of the
    # loop, the same for every system: engine_*.py)
    first = [_start(cache, "batch"), _start(cache)]
    a, b = (_result(p) for p in first)
    assert a["jit"] and b["jit"]
    assert {a["cache"], b["cache"]} <= {"compiled", "loaded"}
    assert a["final"] == b["final"]
    # the system's file: its C library, or numba's module where there is no C compiler
    # (beside it, the record of its size and SHA-256 that lamech checks before loading)
    files = sorted(p for p in (cache / "kernels").glob("lamech_*") if p.suffix != ".json")
    assert len(files) == 1, files
    assert len(list((cache / "kernels").glob("engine_*.py"))) == 1
    assert not list((cache / "kernels").glob("*.tmp"))  # no temporary file left behind
    # a later process compiles nothing: the kernels and the batch loop come from the cache
    t0 = time.perf_counter()
    c = _result(_start(cache, "batch"))
    wall = time.perf_counter() - t0
    assert c["cache"] == "loaded", c
    assert c["batch_hits"] > 0 and c["batch_misses"] == 0, c
    if compiler():  # the system in C: nothing of numba's is compiled, only loaded
        assert not c["registries"], c  # loaded without numba's compiler set up
    assert c["final"] == a["final"] and c["batch"] == a["batch"]
    # compiling the loop takes about a minute here, loading it and the system 1-2 s
    assert c["seconds"] < max(a["seconds"], b["seconds"]) / 4, (a, b, c)
    assert wall < 30.0


@needs_numba
@pytest.mark.slow
@pytest.mark.shared_cache
def test_an_unusable_cache_directory_compiles_in_memory_silently(tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a directory\n")
    proc = _start(blocker / "cache")  # under a regular file: cannot be created
    result = _result(proc)
    assert result["jit"] and result["cache"] == "memory"
    reference = simulate(compile_system(lamech.loads(chain_toml(2))), 1.0, samples=11)
    final = np.concatenate([reference.q[-1], reference.qd[-1]])
    assert np.allclose(result["final"], final, rtol=1e-9, atol=1e-12)


@needs_numba
@pytest.mark.slow
@pytest.mark.shared_cache
@pytest.mark.parametrize("route", ["c", "numba"])
def test_a_changed_source_gets_a_new_file(tmp_path, monkeypatch, route, compiled_loop_in):
    compiled_loop_in(tmp_path)  # the loop as a machine that ran lamech before has it
    monkeypatch.setenv("LAMECH_CACHE_DIR", str(tmp_path))
    if route == "numba":
        monkeypatch.setenv("LAMECH_CC", "none")
    elif compiler() is None:
        pytest.skip("no C compiler")
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
    if route == "c":
        assert a.c_source != b.c_source
        folder = tmp_path / "kernels"
        if not list(folder.glob("lamech_c_*.so")):  # e.g. a compiler without math.h
            pytest.skip("the C compiler did not build the library (numba's route ran)")
        libraries = {p.name for p in folder.glob("lamech_c_*.so")}
        assert libraries == {library_path(ns.c_source, folder).name for ns in (a, b)}
        assert not list((tmp_path / "kernels").glob("lamech_*.py"))
        assert {a.jit_cache, b.jit_cache} <= {"compiled", "loaded"}
        return
    files = [p.read_text(encoding="utf-8") for p in (tmp_path / "kernels").glob("lamech_*.py")]
    assert len(files) == 2
    for ns in (a, b):  # each file holds its own generated dynamics
        dynamics = ns.source[ns.source.index("def dynamics") : ns.source.index("def constraints")]
        assert sum(dynamics.strip() in t for t in files) == 1
    assert {a.jit_cache, b.jit_cache} <= {"compiled", "loaded"}


QUICK = """
import json, sys
import numba
from lamech.numeric._jitcache import quick_load
sys.path.insert(0, sys.argv[1])  # numba caches only functions of a real file
from lamech_quick_probe import f
f = numba.njit(cache=True)(f)
quick_load(f)
out = {"value": f(2.0)}
out["registries"] = "numba.typed.typeddict" in sys.modules
if sys.argv[2:] == ["miss"]:  # a signature not in the cache: compiled as numba always does
    out["int"] = f(3)
print(json.dumps({**out, "hits": sum(f.stats.cache_hits.values())}))
"""


@needs_numba
def test_a_function_in_the_cache_loads_without_numbas_compiler_and_a_miss_still_compiles(
    tmp_path,
):
    # numba's own load sets its whole compiler up first (0.2-0.3 s of CPU per process);
    # a function of lamech's loads its machine code without that, and the numbers are the
    # same; a signature not in the cache still compiles, in the same process
    source = tmp_path / "lamech_quick_probe.py"
    source.write_text("import numpy as np\n\ndef f(x):\n    return np.sin(x) * np.ones(3).sum()\n")

    def run(*extra):
        done = subprocess.run(
            [sys.executable, "-c", QUICK, str(tmp_path), *extra],
            capture_output=True, text=True, timeout=600,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr
        return json.loads(done.stdout.splitlines()[-1])

    first, second, third = run(), run(), run("miss")
    assert first["hits"] == 0 and first["registries"]  # compiled: numba set up
    assert second["hits"] == 1 and not second["registries"], second  # loaded only
    assert second["value"] == first["value"] == pytest.approx(3 * np.sin(2.0), rel=1e-15)
    assert third["int"] == pytest.approx(3 * np.sin(3.0), rel=1e-15) and third["hits"] == 1


HOLD = """
import sys, time
from lamech.numeric._jitcache import compile_lock
with compile_lock("engine_probe"):
    print("held", flush=True)
    time.sleep(float(sys.argv[1]))
"""


@pytest.mark.skipif(sys.platform == "win32", reason="no fcntl: no lock, both compile")
def test_a_second_process_waits_for_the_first_ones_compile_of_the_loop(tmp_path, monkeypatch):
    # two processes that need the loop on a new machine: one compiles it, the other waits
    # and then loads it (not compiles it too); a process stopped mid-compile is waited for
    # only so long
    from lamech.numeric._jitcache import compile_lock

    monkeypatch.setenv("LAMECH_CACHE_DIR", str(tmp_path))
    jit_cache_dir().mkdir(parents=True)

    def holder(seconds: float) -> subprocess.Popen:
        proc = subprocess.Popen(
            [sys.executable, "-c", HOLD, str(seconds)], stdout=subprocess.PIPE, text=True
        )
        assert proc.stdout.readline().strip() == "held"
        return proc

    proc = holder(2.0)
    t0 = time.monotonic()
    with compile_lock("engine_probe"):
        waited = time.monotonic() - t0
    proc.wait(timeout=60)
    assert waited > 1.0, waited  # it waited for the holder to finish
    proc = holder(30.0)
    t0 = time.monotonic()
    with compile_lock("engine_probe", wait=0.5):
        waited = time.monotonic() - t0
    proc.kill()
    proc.wait(timeout=60)
    assert 0.4 < waited < 10.0, waited  # gave up waiting, went on without the lock
    # a file system without locks (ENOLCK, e.g. some network mounts): no wait at all
    import errno
    import fcntl

    def no_locks(*args):
        raise OSError(errno.ENOLCK, "No locks available")

    monkeypatch.setattr(fcntl, "flock", no_locks)
    t0 = time.monotonic()
    with compile_lock("engine_probe"):
        assert time.monotonic() - t0 < 1.0


def test_the_loops_key_follows_the_intrinsics_it_is_compiled_with():
    """The loop is compiled with the intrinsics of ``lamech/numeric/_fnptr.py``
    (``borrowed``, the function casts), which numba's cache does not watch: their text's
    hash is in the engine's text, so a changed intrinsic gets a new cache key."""
    import hashlib
    from pathlib import Path

    import lamech.numeric
    from lamech.numeric._jitcache import engine_text

    path = Path(lamech.numeric.__file__).with_name("_fnptr.py")
    assert hashlib.sha256(path.read_bytes()).hexdigest()[:16] in engine_text()


LINKED = """
import json, sys
import numba
from lamech.numeric._jitcache import quick_load
sys.path.insert(0, sys.argv[1])
from lamech_link_probe import f
f = numba.njit(cache=True)(f)
quick_load(f)
out = {"value": f(2.0), "hits": sum(f.stats.cache_hits.values())}
library = next(iter(f.overloads.values())).library
out["lazy"] = type(library).__name__ == "LazyLinking"
out["parsed_at_load"] = "_lazy_bitcode" not in vars(library)
g = numba.njit(lambda x: f(x) + 1.0)  # compiled now: links f's library into its own
out["linked"] = g(2.0)
out["parsed_to_link"] = "_lazy_bitcode" not in vars(library)
print(json.dumps(out))
"""


@needs_numba
def test_a_function_loaded_without_parsing_its_bitcode_runs_and_links_into_code_compiled_later(
    tmp_path,
):
    # numba parses the bitcode it keeps beside the machine code at every load, to list the
    # symbols the code defines (0.09 s of CPU for the loop's entry point); lamech lists
    # them from the object's own symbol table and parses the bitcode only when code
    # compiled later links the library (a cfunc calling a loaded function, a new
    # signature's callers)
    source = tmp_path / "lamech_link_probe.py"
    source.write_text("import math\n\ndef f(x):\n    return math.sin(x) * 3.0\n")

    def run():
        done = subprocess.run(
            [sys.executable, "-c", LINKED, str(tmp_path)],
            capture_output=True, text=True, timeout=600,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr
        return json.loads(done.stdout.splitlines()[-1])

    first, second = run(), run()
    assert first["hits"] == 0 and not first["lazy"]  # compiled in that process
    assert second["hits"] == 1 and second["lazy"], second
    assert not second["parsed_at_load"] and second["parsed_to_link"]
    for out in (first, second):
        assert out["value"] == pytest.approx(3 * np.sin(2.0), rel=1e-15)
        assert out["linked"] == pytest.approx(3 * np.sin(2.0) + 1.0, rel=1e-15)
