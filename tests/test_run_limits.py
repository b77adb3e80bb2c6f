"""Runs that would never end, or end badly, answered cleanly (issue 17, items 6-9):
bounded options, a pace estimate and the implicit methods for stiff systems, signals that
keep what was computed and take a sweep's workers along, chattering contacts stopped, and
the last state reached reported. (A sweep's resume: tests/test_sweep_resume.py.)"""

from __future__ import annotations

import csv
import dataclasses
import math
import queue
import re
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import lamech
from lamech.cli import main
from lamech.numeric import SimulationError, simulate
from lamech.numeric._options import check_options
from lamech.numeric._pace import PILOT_STEPS, Pace, Projection
from lamech.sweeps import sweep

G = 9.81
HERE = Path(__file__).parent

# A bead on the rail y = x/2 held by a spring k and a damper c along x:
# (5/4) m x'' + c x' + k x = 0, stiff when c^2 >> k m (time scales 5m/4c and c/k).
DAMPER = """
title = "Bead on a rail, spring and damper"
[parameters]
m = 1.0
k = 100.0
c = 10000.0
[coordinates]
x = { initial = 1, velocity = 0 }
y = { initial = "1/2", velocity = 0 }
[lagrangian]
T = "m/2*(x'^2 + y'^2)"
V = "k/2*x^2"
[[constraints]]
name = "rail"
f = "y - x/2"
[forces]
x = "-c*x'"
"""


def _damper_x(t, m=1.0, k=100.0, c=1e4):
    """x(t) from x = 1, x' = 0: the two decay rates r1 r2 = k/M, r1 + r2 = -c/M."""
    M = 1.25 * m
    r1 = (-c - math.sqrt(c * c - 4 * M * k)) / (2 * M)
    r2 = k / M / r1  # the slow root, without cancellation
    return (r1 * np.exp(r2 * t) - r2 * np.exp(r1 * t)) / (r1 - r2)


BLOW_UP = (HERE / "problems" / "blow_up.toml").read_text(encoding="utf-8")

BALL = (HERE / "problems" / "ball.toml").read_text(encoding="utf-8").replace("e = 0.5", "e = 0.95")


# ----- item 9: chatter and the last state reached ------------------------------------
def test_blow_up_between_samples_reports_the_last_time_reached():
    # two samples (t = 0 and 2): the run fails near t = 1, between them
    tr = simulate(lamech.loads(BLOW_UP), 2.0, samples=2)
    assert tr.status == "failed" and "grows without bound" in tr.message
    assert list(tr.t) == [0.0]
    assert 0.999 < tr.final_time < 1.0
    # x' = (1/(1 - t)^2 - 1)/2.5 (mass 5/4 along x): the final state is the state there
    t = tr.final_time
    xd = lamech.to_json(tr)["final"]["x'"]
    assert xd == pytest.approx((1 / (1 - t) ** 2 - 1) / 2.5, rel=1e-6)
    assert lamech.to_json(tr)["final_time"] == t


def test_chattering_contact_stops_with_a_clear_status():
    # a negative mass: released, the cylinder falls back at once; lift-off, contact and
    # slip every 4.5 microseconds, for ever (22,109 events in 20 s before). params={"m":
    # -1} is refused now (issue 28 item 7): the compiled system's own vector is changed
    with pytest.raises(lamech.SimulationError, match="parameter `m` is 1 in the file"):
        simulate(lamech.load("cylinder"), 20.0, params={"m": -1})
    ns = lamech.compile_system(lamech.load("cylinder"))
    p = ns.parameter_vector()
    p[ns.parameter_names.index("m")] = -1.0
    started = time.monotonic()
    tr = simulate(dataclasses.replace(ns, parameters=p), 20.0, initial={"theta1": 0.01})
    assert time.monotonic() - started < 10
    assert tr.status == "failed"
    assert tr.message.startswith("chattering: the last 100 events")
    assert "lift-off of `contact`" in tr.message and "check the masses" in tr.message
    assert len(tr.events) <= 200
    assert tr.final_time == pytest.approx(tr.events[-1].t, abs=1e-5) and tr.final_time < 1e-3


@pytest.mark.slow
def test_a_bouncing_ball_comes_to_rest_without_being_called_chatter():
    # e = 0.95: 200 bounces accumulating at t1 (1 + e)/(1 - e), then resting contact
    tr = simulate(lamech.loads(BALL), 20.0, samples=11)
    assert tr.status == "ok", tr.message
    t1 = math.sqrt(2 / G)
    assert tr.events[-1].kind == "contact" and len(tr.events) > 150
    assert tr.events[-1].t == pytest.approx(t1 * 1.95 / 0.05, rel=1e-4)


# ----- item 6: runs that would never end ---------------------------------------------
def test_a_max_step_that_forces_endless_steps_is_refused():
    ns = lamech.load("pendulum")
    for bad in (1e-300, 1e-9):
        with pytest.raises(SimulationError, match=r"max_step .* too small: it forces at least"):
            simulate(ns, 10.0, max_step=bad)
    check_options(10.0, 0.0, lamech.Options(max_step=1e-7))  # 1e8 steps: the limit


def test_cli_refuses_a_max_step_with_the_reason(capsys):
    rc = main(["simulate", "pendulum", "--t-end", "10", "--max-step", "1e-300"])
    err = capsys.readouterr().err
    assert rc == 2
    assert "at least 1e+301 steps" in err and "give max_step >= 1e-07" in err


@pytest.mark.parametrize("method", ["Radau", "BDF"])
def test_implicit_methods_follow_a_stiff_damper(method):
    # time scales 1.25e-4 s and 100 s: DOP853 would need ~1e4 steps a second of motion
    tr = simulate(lamech.loads(DAMPER), 2.0, method=method, rtol=1e-9, atol=1e-12, samples=41)
    assert tr.status == "ok", tr.message
    assert tr.steps < 2000
    assert np.max(np.abs(tr.coordinate("x") - _damper_x(tr.t))) < 1e-7
    assert np.max(tr.residual_position) < 1e-10  # projected onto the rail as always


def test_the_pace_says_a_run_is_long_and_whether_it_is_stiff():
    seen: list[Pace] = []

    def stop(p: Pace) -> None:
        seen.append(p)
        raise KeyboardInterrupt

    stiff = lamech.loads(DAMPER)
    tr = simulate(stiff, 1e3, params={"c": 1e8, "k": 1e4}, pace=stop)
    assert tr.status == "interrupted" and len(seen) == 1
    p = seen[0]
    assert p.stiff and p.stiffness > 1 and p.fastest == pytest.approx(1.25e-8, rel=1e-3)
    assert p.estimate > 3600 and p.remaining > 0 and p.t == pytest.approx(tr.final_time)
    # Radau takes the steps the motion allows: 1000 s in about a second (DOP853: hours)
    tr = simulate(stiff, 1e3, params={"c": 1e8, "k": 1e4}, method="Radau", samples=11)
    assert tr.status == "ok" and tr.steps < 1000
    assert np.max(np.abs(tr.coordinate("x") - _damper_x(tr.t, k=1e4, c=1e8))) < 1e-9
    seen.clear()
    tr = simulate(lamech.load("pendulum"), 1e9, pace=stop)
    p = seen[0]
    # hours on the engine in C (days on SciPy's): long, not stiff
    assert not p.stiff and p.stiffness < 1 and p.estimate > 3600


# ----- items 6 and 7 through the command: the estimate, then a signal -------------------
# the command with one more thread running (as in a notebook): its sweeps' workers come
# from a fork server, not from forking it
THREADED = (
    "import sys, threading, time; "
    "threading.Thread(target=time.sleep, args=(1e6,), daemon=True).start(); "
    "from lamech.cli import main; sys.exit(main(sys.argv[1:]))"
)


def _lamech(*args: str, cwd, threaded: bool = False) -> subprocess.Popen:
    start = ["-c", THREADED] if threaded else ["-m", "lamech"]
    return subprocess.Popen(
        [sys.executable, *start, *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=cwd,
    )


def _lines(stream) -> queue.Queue:
    """The stream's lines, read on a thread (a test waits for one with a timeout)."""
    lines: queue.Queue = queue.Queue()

    def read():
        for line in stream:
            lines.put(line)
        lines.put(None)

    threading.Thread(target=read, daemon=True).start()
    return lines


def _wait_for(lines: queue.Queue, text: str, seconds: float) -> list[str]:
    seen: list[str] = []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        try:
            line = lines.get(timeout=max(end - time.monotonic(), 0.01))
        except queue.Empty:
            break
        if line is None:
            break
        seen.append(line)
        if text in line:
            return seen
    raise AssertionError(f"no line with {text!r} within {seconds} s: {seen}")


@pytest.mark.slow
@pytest.mark.shared_cache
@pytest.mark.parametrize("name", ["SIGTERM", "SIGHUP"])
def test_a_long_simulation_says_so_and_a_signal_keeps_its_trajectory(tmp_path, name):
    signum = getattr(signal, name, None)
    if signum is None:
        pytest.skip(f"no {name} on this platform")
    out = tmp_path / "traj.csv"
    # 1e9 s of pendulum: hours on the engine in C (about 4e4 s of motion per second of
    # CPU), a sample every 1000 s
    proc = _lamech(
        "simulate",
        "pendulum",
        "--t-end",
        "1e9",
        "--samples",
        "1000001",
        "--out",
        str(out),
        cwd=tmp_path,
    )
    try:
        err = _lines(proc.stderr)
        said = _wait_for(err, "a long run: about", 30)[-1]
        assert "Ctrl-C, SIGTERM or SIGHUP stop it and keep the trajectory so far" in said
        assert "stiff" not in said
        # the signal lands in the integration; how far it got by then is the machine's
        # speed, so the rows are checked against the times the run itself reports
        # the pilot's time is printed to 4 significant digits (136.884 as 136.9): at
        # most half a unit of the 4th digit above the time the run had reached
        piloted = float(said.split("(t = ")[1].split(" of ")[0]) * (1 - 5e-4)
        proc.send_signal(signum)
        rc = proc.wait(timeout=20)
        stdout = proc.stdout.read()
    finally:
        proc.kill()
    assert rc == 128 + signum
    last = _wait_for(err, f"lamech: stopped by {name} at t = ", 5)[-1]
    assert f"the trajectory up to there is in {out}" in last
    assert f"status: interrupted (stopped by {name} at t = " in stdout
    with open(out, newline="") as fh:
        rows = list(csv.DictReader(fh))
    stopped_at = float(last.split(" at t = ")[1].split(";")[0])
    assert stopped_at >= piloted  # the trajectory so far: at least the pilot's
    assert len(rows) == int(stopped_at // 1000) + 1  # every sample up to there kept
    assert float(rows[-1]["t"]) == 1000 * (len(rows) - 1)
    th = np.array([float(r["theta"]) for r in rows])
    assert np.all(np.abs(th) <= 0.5 + 1e-9)  # the pendulum still swings within theta0


@pytest.mark.slow
@pytest.mark.shared_cache
def test_a_stiff_run_is_told_to_use_an_implicit_method(tmp_path):
    problem = tmp_path / "damper.toml"
    problem.write_text(DAMPER.replace("c = 10000.0", "c = 1e8"), encoding="utf-8")
    proc = _lamech("simulate", str(problem), "--t-end", "100", cwd=tmp_path)
    try:
        err = _lines(proc.stderr)
        said = _wait_for(err, "--method Radau", 30)
        assert "a long run: about" in said[-2]
        assert (
            "held down by stability" in said[-1] and "fastest time scale is 1.25e-08 s" in said[-1]
        )
        proc.send_signal(signal.SIGINT)
        assert proc.wait(timeout=20) == 130
    finally:
        proc.kill()
    rc = main(["simulate", str(problem), "--t-end", "100", "--method", "Radau", "--json"])
    assert rc == 0


# ----- item 7: a sweep's workers end with it; item 6: bounded submission ---------------
def _descendants(pid: int) -> list[int]:
    """The processes started by ``pid``, their children, and so on (Linux: /proc)."""
    parents: dict[int, int] = {}
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
            except OSError:
                continue
            parents[int(d.name)] = int(stat.rsplit(")", 1)[1].split()[1])
    out, todo = [], [pid]
    while todo:
        here = todo.pop()
        kids = [c for c, p in parents.items() if p == here]
        out += kids
        todo += kids
    return out


def _parent(pid: int) -> int | None:
    try:
        return int(Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[1])
    except OSError:
        return None


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode()
    except OSError:
        return ""


def _alive(pid: int) -> bool:
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat.rsplit(")", 1)[1].split()[0] not in ("Z", "X")  # a zombie has ended


@pytest.mark.slow
@pytest.mark.shared_cache
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads /proc (Linux)")
@pytest.mark.parametrize(
    "name, threaded", [("SIGTERM", False), ("SIGKILL", False), ("SIGKILL", True)]
)
def test_killing_a_sweep_ends_its_workers_and_its_output(tmp_path, name, threaded):
    out = tmp_path / "t.csv"
    proc = _lamech(
        "sweep",
        "cylinder",
        "--param",
        "mu=0.1:0.6:400",
        "--initial",
        "theta1=0.01",
        "--measure",
        "slip",
        "--t-end",
        "2.7",
        "--samples",
        "11",
        "--workers",
        "2",
        "--engine",  # worker processes (the compiled loop with events runs in the sweep's)
        "simulate",
        "--out",
        str(out),
        cwd=tmp_path,
        threaded=threaded,
    )
    try:
        err, stdout = _lines(proc.stderr), _lines(proc.stdout)
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and (
            not out.exists() or len(out.read_text().splitlines()) < 3
        ):
            time.sleep(0.05)
        workers = _descendants(proc.pid)
        # multiprocessing's own: the resource tracker, the fork server (not the workers it
        # starts, which share its command line)
        helpers = [
            w for w in workers if _parent(w) == proc.pid and "from multiprocessing." in _cmdline(w)
        ]
        server = [w for w in helpers if "forkserver" in _cmdline(w)]
        assert bool(server) == threaded  # a fork server only when other threads run
        assert len(set(workers) - set(helpers)) >= 2  # running cases: two rows are in
        proc.send_signal(getattr(signal, name))
        rc = proc.wait(timeout=20)
        deadline = time.monotonic() + 10
        while time.monotonic() < deadline and any(_alive(w) for w in workers):
            time.sleep(0.05)
        assert [w for w in workers if _alive(w)] == []
        # no process holds the output pipe any more: `lamech sweep ... | tail` ends
        end = time.monotonic() + 5
        while time.monotonic() < end:
            try:
                if stdout.get(timeout=0.1) is None:
                    break
            except queue.Empty:
                pass
        else:
            raise AssertionError("the sweep's standard output is still open")
    finally:
        proc.kill()
    if name == "SIGTERM":
        assert rc == 143
        said = _wait_for(err, "lamech: stopped by SIGTERM: ", 5)[-1]
        done = int(said.split("SIGTERM: ")[1].split(" of ")[0])
        assert f"of 400 cases done and kept in {out}; rerun with --resume to finish" in said
        with open(out, newline="") as fh:
            assert len(list(csv.DictReader(fh))) == done
    else:
        assert rc == -signal.SIGKILL


@pytest.mark.parametrize("threaded", [False, pytest.param(True, marks=pytest.mark.slow)])
def test_a_sweep_submits_a_few_cases_ahead_not_all(monkeypatch, threaded):
    """Also: with another thread running (a notebook's), the workers come from a fork
    server; forking this process could copy a lock that thread holds, and hang."""
    from concurrent.futures import ProcessPoolExecutor

    release = threading.Event()
    if threaded:
        threading.Thread(target=release.wait, daemon=True).start()

    lock, pending, most = threading.Lock(), [0], [0]
    submit = ProcessPoolExecutor.submit

    def finished(_):
        with lock:
            pending[0] -= 1

    def counting(self, *args, **kwargs):
        fut = submit(self, *args, **kwargs)
        with lock:
            pending[0] += 1
            most[0] = max(most[0], pending[0])
        fut.add_done_callback(finished)
        return fut

    monkeypatch.setattr(ProcessPoolExecutor, "submit", counting)
    try:
        run = sweep(
            "pendulum", {"theta0": "0.1:0.5:300"}, ["max:theta"], t_end=0.01, samples=2, workers=2
        )
    finally:
        release.set()
    assert run.counts == {"ok": 300} and run.backend == "2 local processes"
    assert most[0] <= 8  # four per worker, not 300
    assert [r["max:theta"] for r in run.rows] == pytest.approx(list(np.linspace(0.1, 0.5, 300)))


# ----- issue 44, item 8: a run that cannot end says so from its first steps -------------
RUNAWAY = """title = "runaway"
[coordinates]
x = { initial = 1, velocity = 0 }
y = { initial = 1, velocity = 0 }
[lagrangian]
T = "x'^2/2 + y'^2/2"
V = "-x^2/2 + 500*y^2"
"""
"""x grows as e^t (the run stops itself, blown up, at t = 29), while y's oscillation
(period 0.28) keeps the step small: about 3,600 steps, the first 1000 to t = 8, so that
t_end = 1e12 projects 1.3e14 steps. It ends on its own: the tests need no signal."""


def test_the_projection_is_made_from_steps_after_the_pilot_steps_only():
    system = lamech.loads(RUNAWAY)
    seen: list[Projection] = []
    traj = simulate(system, 1e12, samples=2, engine="scipy", projection=seen.append)
    assert traj.status == "failed" and "grows without bound" in traj.message
    assert len(seen) == 1
    p = seen[0]
    assert PILOT_STEPS <= p.steps < traj.steps
    assert p.total == pytest.approx(p.steps * 1e12 / p.t)
    assert 1e13 < p.total < 1e15  # about 125 steps per unit of time
    short: list[Projection] = []
    traj = simulate(lamech.load("pendulum"), 3.0, projection=short.append)
    assert traj.status == "ok" and traj.steps < PILOT_STEPS and short == []


@pytest.mark.slow
def test_a_run_that_cannot_end_is_said_with_its_steps_and_how_to_go_on(tmp_path):
    problem = tmp_path / "runaway.toml"
    problem.write_text(RUNAWAY, encoding="utf-8")
    said = {}
    for extra in ([], ["--long-run"]):
        run = subprocess.run(
            [sys.executable, "-m", "lamech", "simulate", str(problem), "--t-end", "1e12", *extra],
            capture_output=True,
            text=True,
            cwd=tmp_path,
            timeout=600,
        )
        assert "grows without bound" in run.stdout, run.stderr
        said[bool(extra)] = run.stderr
    line = next(x for x in said[False].splitlines() if "steps, more than can be waited" in x)
    found = re.match(r"lamech: a run of about (\S+) steps, .* over its first (\d+) steps", line)
    assert found is not None, line
    assert 1e13 < float(found.group(1)) < 1e15  # the same on any machine: counts, no clock
    assert int(found.group(2)) >= PILOT_STEPS  # the compiled loop reports after its first chunk
    assert "Ctrl-C, SIGTERM or SIGHUP stop it" in line and "--long-run goes on" in line
    assert "more than can be waited" not in said[True] and "a long run" not in said[True]
