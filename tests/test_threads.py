"""BLAS runs on one thread while lamech integrates (issue 16: OpenBLAS's helper threads
made the 40- to 100-link chains 4-70 times slower on 2 cores), and the limits the caller
had are back after the run, also when runs nest or overlap in threads."""

from __future__ import annotations

import dataclasses
import threading

import numpy as np
import pytest
import scipy.linalg  # noqa: F401  (SciPy's BLAS loaded before the limits are read)
from threadpoolctl import threadpool_info, threadpool_limits

import lamech
from lamech.problem import chain_toml


def _blas_threads() -> list[int]:
    return sorted({d["num_threads"] for d in threadpool_info() if d["user_api"] == "blas"})


@pytest.fixture(scope="module")
def chain():
    return lamech.compile_system(lamech.loads(chain_toml(3), "chain.toml"))


@pytest.fixture
def two_threads():
    """BLAS at two threads around the test, so that one thread inside is the run's."""
    with threadpool_limits(limits=2, user_api="blas"):
        if _blas_threads() != [2]:
            pytest.skip(f"this BLAS cannot be set to 2 threads: {threadpool_info()}")
        yield


def test_a_run_uses_one_blas_thread_and_restores_the_limits(chain, two_threads):
    seen: list[list[int]] = []
    traj = lamech.simulate(chain, 0.05, progress=lambda t: seen.append(_blas_threads()))
    assert traj.status == "ok"
    assert seen and all(s == [1] for s in seen)
    assert _blas_threads() == [2]


def test_a_failed_run_restores_the_limits_too(chain, two_threads):
    def stop(t):
        raise KeyboardInterrupt

    traj = lamech.simulate(chain, 0.05, progress=stop)
    assert traj.status == "interrupted"
    assert _blas_threads() == [2]


@pytest.mark.slow
def test_a_run_inside_a_run_keeps_the_outer_run_at_one_thread(chain, two_threads):
    seen: list[list[int]] = []

    def progress(t):
        if not seen:
            assert lamech.simulate(chain, 0.01).status == "ok"
        seen.append(_blas_threads())

    assert lamech.simulate(chain, 0.05, progress=progress).status == "ok"
    assert len(seen) > 1 and all(s == [1] for s in seen)
    assert _blas_threads() == [2]


@pytest.mark.slow
def test_overlapping_runs_in_threads_restore_the_limits_at_the_end(chain, two_threads):
    """Run a (a thread) starts, run b (the main thread) starts, a ends, b ends: both run
    at one thread, b also after a ended, and the limits are back after b (restoring per
    run would leave one thread for good: a would restore 2 inside b, b then its 1)."""
    a_inside, b_inside = threading.Event(), threading.Event()
    seen: list[list[int]] = []

    def run_a():
        def progress(t):
            seen.append(_blas_threads())
            a_inside.set()
            b_inside.wait(timeout=60)

        lamech.simulate(chain, 0.01, progress=progress)

    a = threading.Thread(target=run_a)
    a.start()
    assert a_inside.wait(timeout=60)

    def progress_b(t):
        if not b_inside.is_set():
            b_inside.set()
            a.join(timeout=60)
            assert not a.is_alive()
        seen.append(_blas_threads())

    assert lamech.simulate(chain, 0.05, progress=progress_b).status == "ok"
    assert len(seen) > 1 and all(s == [1] for s in seen)
    assert _blas_threads() == [2]


def test_the_batch_integrator_uses_one_blas_thread(chain, two_threads):
    seen: list[list[int]] = []
    accelerations = chain.accelerations

    def watched(t, y, p):
        seen.append(_blas_threads())
        return accelerations(t, y, p)

    ns = dataclasses.replace(chain, accelerations=watched)
    y0 = np.concatenate(ns.initial_state())[None]
    res = lamech.integrate_batch(ns, y0, 0.01, rtol=1e-6, atol=1e-9)
    assert res.ok.all()
    assert seen and all(s == [1] for s in seen)
    assert _blas_threads() == [2]


_SCIPY_LOADED_BY_THE_RUN = """
import json, sys
from threadpoolctl import threadpool_info, threadpool_limits
import lamech
from lamech.problem import chain_toml
assert "scipy.linalg" not in sys.modules
ns = lamech.compile_system(lamech.loads(chain_toml(3), "chain.toml"))
seen = []
def progress(t):
    seen.append(sorted({(d["filepath"].split("/site-packages/")[-1].split("/")[0],
                         d["num_threads"]) for d in threadpool_info() if d["user_api"] == "blas"}))
with threadpool_limits(limits=2, user_api="blas"):
    traj = lamech.simulate(ns, 0.05, method="Radau", progress=progress)
print(json.dumps([traj.status, "scipy.linalg" in sys.modules, seen]))
"""


def test_a_run_that_loads_scipys_blas_runs_it_at_one_thread_too():
    """lamech no longer imports scipy.linalg to find SciPy's OpenBLAS (0.2 s a process);
    a run on SciPy's integrators loads it before the limit is set, so that SciPy's BLAS
    (its stiff methods' LU) runs at one thread too, as NumPy's."""
    import json
    import os
    import subprocess
    import sys

    environ = {k: v for k, v in os.environ.items() if not k.endswith("_NUM_THREADS")}
    out = subprocess.run(
        [sys.executable, "-c", _SCIPY_LOADED_BY_THE_RUN],
        env=environ, capture_output=True, text=True, timeout=300, check=True,
    ).stdout  # fmt: skip
    status, loaded, seen = json.loads(out.strip().splitlines()[-1])
    assert status == "ok" and loaded
    libraries = {name for s in seen for name, _ in s}
    assert len(libraries) >= 2, seen  # NumPy's and SciPy's OpenBLAS
    assert seen and all(n == 1 for s in seen for _, n in s), seen
