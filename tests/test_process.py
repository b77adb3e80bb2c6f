"""The ``lamech`` command's own process: NumPy and SciPy load with one BLAS thread (their
OpenBLAS helper threads spin for about 0.1 s of CPU each as they start), unless the
user's environment says otherwise, and the collector does not walk every object again
as the process ends; a call of ``main`` from Python changes neither. A closed pipe
ends it quietly (141), Ctrl-C with one line (130), even while it starts up."""

from __future__ import annotations

import gc
import json
import os
import subprocess
import sys

import pytest

import lamech
from lamech.cli import main

_AS_THE_COMMAND = """
import gc, json, sys
sys.argv = ["lamech", "examples"]
from lamech.cli import main
before = gc.get_freeze_count()
status = main()
frozen = gc.get_freeze_count()
import numpy, scipy.linalg
from threadpoolctl import threadpool_info
blas = sorted({d["num_threads"] for d in threadpool_info() if d["user_api"] == "blas"})
print(json.dumps([status, before, frozen, blas]))
"""


def _as_the_command(**env) -> list:
    environ = {k: v for k, v in os.environ.items() if k != "OPENBLAS_NUM_THREADS"}
    out = subprocess.run(
        [sys.executable, "-c", _AS_THE_COMMAND],
        env={**environ, **env},
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    ).stdout
    return json.loads(out.strip().splitlines()[-1])


@pytest.mark.skipif((os.cpu_count() or 1) < 2, reason="OpenBLAS starts one thread anyway")
def test_the_command_loads_blas_with_one_thread_and_freezes_the_collector_as_it_ends():
    status, before, frozen, blas = _as_the_command()
    assert status == 0
    assert blas == [1]
    assert before == 0 and frozen > 1000  # every object then alive: SymPy's not even loaded


def test_the_users_own_blas_threads_are_kept():
    status, _, _, blas = _as_the_command(OPENBLAS_NUM_THREADS="2")
    assert status == 0 and blas == [2]


def test_main_called_from_python_leaves_the_process_alone(capsys):
    blas = os.environ.get("OPENBLAS_NUM_THREADS")
    before = gc.get_freeze_count()
    assert main(["examples"]) == 0
    assert gc.get_freeze_count() == before
    assert os.environ.get("OPENBLAS_NUM_THREADS") == blas
    assert "cylinder" in capsys.readouterr().out


_WHAT_LOADS = """
import json, sys
engine, modules = sys.argv[1], sys.argv[2:]
sys.argv = ["lamech", "simulate", "cylinder", "--initial", "theta1=0.01", "--t-end", "0.5",
            "--engine", engine]
from lamech.cli import main
status = main()
print(json.dumps([status] + [m in sys.modules for m in modules]))
"""


@pytest.mark.parametrize("engine", ["compiled", "python"])
def test_a_run_on_the_loop_does_not_load_scipys_linear_algebra(engine, tmp_path):
    """Neither the loop run as Python (NumPy's BLAS) nor the engine in C needs SciPy's
    linear algebra, whose import cost 0.2 s of CPU per process, or SciPy's integrators;
    the BLAS threads are limited without it."""
    environ = {**os.environ, "LAMECH_CACHE_DIR": str(tmp_path)}
    modules = ["scipy.linalg", "scipy.integrate", "numba"]
    out = subprocess.run(
        [sys.executable, "-c", _WHAT_LOADS, engine, *modules],
        env=environ,
        capture_output=True,
        text=True,
        timeout=600,
        check=True,
    ).stdout
    status, *loaded = json.loads(out.strip().splitlines()[-1])
    assert status == 0
    assert ("engine: loop (Python)" in out) == (engine == "python"), out
    assert ("engine: loop (C)" in out) == (engine == "compiled"), out
    assert dict(zip(modules, loaded)) == {
        "scipy.linalg": False,
        "scipy.integrate": False,
        "numba": False,
    }


def _closed_pipe_run(args: list[str]) -> subprocess.CompletedProcess:
    """Run ``lamech ARGS`` with its standard output a pipe nobody reads (closed)."""
    read, write = os.pipe()
    os.close(read)
    try:
        return subprocess.run(
            [sys.executable, "-m", "lamech", *args],
            stdout=write,
            stderr=subprocess.PIPE,
            text=True,
            timeout=120,
        )
    finally:
        os.close(write)


@pytest.mark.parametrize(
    "args", [["examples"], pytest.param(["solve", "pendulum"], marks=pytest.mark.slow)]
)
def test_a_closed_pipe_ends_quietly(args):
    out = _closed_pipe_run(args)
    assert "Traceback" not in out.stderr and "BrokenPipeError" not in out.stderr
    assert out.returncode == 141


@pytest.mark.slow
def test_sweep_into_a_closed_pipe_ends_quietly():
    out = _closed_pipe_run(
        [
            "sweep",
            "pendulum",
            "--param",
            "l=0.5,1",
            "--measure",
            "max:lambda:string",
            "--t-end",
            "0.2",
            "--samples",
            "3",
            "--workers",
            "1",
        ]
    )
    assert "Traceback" not in out.stderr and "BrokenPipeError" not in out.stderr
    assert out.returncode == 141


def test_ctrl_c_where_no_command_handles_it_is_one_line_and_130(monkeypatch, capsys):
    """Ctrl-C while SymPy loads or the problem is read: no traceback, the shell's 130."""
    from lamech.cli import main

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(lamech.problem, "load", interrupted)
    assert main(["solve", "pendulum"]) == 130
    out, err = capsys.readouterr()
    assert (out, err) == ("", "lamech: interrupted\n")


# ``python -m lamech`` as run by ``-m`` (runpy, sys.argv the command's), with an import
# hook that stops the import of SymPy until the test's signal comes: the signal lands
# while lamech is starting up, whatever the machine's speed (a fixed sleep before the
# signal once let a fast machine finish starting and interrupt the solve instead)
PAUSED_AT_SYMPY = """
import importlib.abc, runpy, sys, time

class PauseAtSympy(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name == "sympy":
            sys.meta_path.remove(self)
            print("importing sympy", file=sys.stderr, flush=True)
            time.sleep(120)  # until the signal
        return None

sys.meta_path.insert(0, PauseAtSympy())
sys.argv = ["lamech", *sys.argv[1:]]
runpy.run_module("lamech", run_name="__main__", alter_sys=True)
"""


def test_ctrl_c_during_start_up_of_the_real_command():
    import signal

    proc = subprocess.Popen(
        [sys.executable, "-c", PAUSED_AT_SYMPY, "solve", "cylinder"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    try:
        assert proc.stderr.readline() == "importing sympy\n"  # lamech is starting up
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert "Traceback" not in err
    assert (proc.returncode, out, err) == (130, "", "lamech: interrupted\n")
