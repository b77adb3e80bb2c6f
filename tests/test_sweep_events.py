"""The compiled loop with events (lamech.numeric.integrate_events) against simulate: the
cylinder's slip and lift-off at the same times (to 1e-9, against the energy integral's
slip angle to 1e-9), the sweeps' engines giving the same rows, the cases it leaves to
simulate (an impact) run by simulate, the batch's parameters and starts as the
case-by-case ones, and the engine in C the same numbers as the loop as Python."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import brentq

import lamech
from lamech.numeric import (
    compile_system,
    compiled_available,
    consistent_initial,
    initial_states,
    integrate_events,
    parameter_rows,
    simulate,
)
from lamech.numeric._batch import jit_is_cached
from lamech.numeric._params import with_friction_parameters
from lamech.sweeps import SweepError, sweep

THETA_S = 0.01


def _slip_angle(mu: float, ths: float = THETA_S) -> float:
    """sin th = mu (7 cos th - 4 cos ths): the energy integral's slip angle (test_sweep)."""
    top = math.acos(4 / 7 * math.cos(ths))
    return brentq(
        lambda th: math.sin(th) - mu * (7 * math.cos(th) - 4 * math.cos(ths)), ths, top, xtol=1e-15
    )


def _cylinder(jit=False):
    return compile_system(with_friction_parameters(lamech.load("cylinder"), ["mu"]), jit=jit)


GRID = np.array([[mu, R2] for mu in (0.1, 0.35, 1e6) for R2 in (0.3, 1.0)])


def _batch(ns, **kw):
    P = parameter_rows(ns, ["mu", "R2"], GRID)
    Y0 = initial_states(ns, P, [("theta1", THETA_S)])
    return P, Y0, integrate_events(ns, Y0, 3.0, params=P, **kw)


@pytest.mark.slow
def test_cylinder_events_match_simulate_and_the_energy_integral():
    ns = _cylinder()
    P, Y0, res = _batch(ns)
    assert res.status == ["end"] * len(GRID) and not res.fallback.any()
    for (mu, R2), y0, events, y_end in zip(GRID, Y0, res.events, res.y):
        traj = simulate(ns, 3.0, params={"mu": mu, "R2": R2}, q0=y0[:3], qd0=y0[3:], samples=11)
        assert traj.status == "ok"
        assert (
            [(e.kind, e.constraint) for e in events]
            == [(e.kind, e.constraint) for e in traj.events]
            == [("slip", "rolling"), ("lift-off", "contact")]
        )
        for a, b in zip(events, traj.events):
            assert abs(a.t - b.t) < 1e-9
            assert all(abs(a.coordinates[k] - b.coordinates[k]) < 1e-9 for k in a.coordinates)
        slip = events[0]
        assert abs(slip.coordinates["theta1"] - _slip_angle(mu)) < 1e-9
        assert abs(slip.coordinates["theta2"] - (1 + R2) / R2 * slip.coordinates["theta1"]) < 1e-9
        # after lift-off the wheel flies freely to t = 3: the same final state
        assert np.max(np.abs(y_end - np.concatenate((traj.final_q, traj.final_qd)))) < 1e-7


@pytest.mark.slow
def test_the_loop_stops_once_the_wanted_events_are_found():
    ns = _cylinder()
    _, _, res = _batch(ns, want=[("slip", None), ("lift-off", "contact")], to_end=False)
    assert res.status == ["found"] * len(GRID)
    assert all(abs(t - e[-1].t) == 0 for t, e in zip(res.t, res.events))
    _, _, slip_only = _batch(ns, want=[("slip", "rolling")], to_end=False)
    assert all([e.kind for e in evs] == ["slip"] for evs in slip_only.events)


@pytest.mark.slow
def test_parameters_and_starts_as_case_by_case():
    ns = _cylinder()
    P, Y0, _ = _batch(ns, want=[("slip", None)], to_end=False)
    for (mu, R2), p, y0 in zip(GRID, P, Y0):
        p1 = ns.parameter_vector({"mu": mu, "R2": R2})
        assert np.array_equal(p, p1)
        q, v = consistent_initial(ns, p1, [("theta1", THETA_S)])
        assert np.max(np.abs(y0 - np.concatenate((q, v)))) < 1e-15
    # a parameter written as an expression of the swept ones follows them
    top = compile_system(lamech.load("heavy_top"))
    vals = np.array([[0.3, 20.0], [0.5, 35.0]])
    rows = parameter_rows(top, ["theta0", "Omega"], vals)
    for v, row in zip(vals, rows):
        ref = top.parameter_vector({"theta0": v[0], "Omega": v[1]})
        assert np.allclose(row, ref, rtol=1e-14, atol=0)
    with pytest.raises(KeyError, match="unknown parameter"):
        parameter_rows(top, ["nope"], [[1.0]])


@pytest.mark.slow
def test_sweep_engines_give_the_same_rows():
    params = {"mu": [0.1, 0.45], "R2": [0.3, 0.8]}
    measures = ["slip", "liftoff", "final:theta1", "final:r'"]
    kw = dict(t_end=2.9, samples=11, workers=1, initial={"theta1": THETA_S})
    fast = sweep("cylinder", params, measures, engine="python", **kw)
    slow = sweep("cylinder", params, measures, engine="scipy", **kw)
    assert fast.backend == "the compiled loop with events (Python)"
    assert slow.backend == "this process"
    assert fast.counts == slow.counts == {"ok": 4}
    for a, b in zip(fast.rows, slow.rows):
        assert a.keys() == b.keys()
        for k in a:
            if isinstance(a[k], float) and k.startswith(("slip", "liftoff")):
                assert abs(a[k] - b[k]) < 1e-9, k
            elif isinstance(a[k], float):
                assert abs(a[k] - b[k]) < 1e-7, k  # final: the last sample
            else:
                assert a[k] == b[k]
        assert abs(a["slip:theta1"] - _slip_angle(a["mu"])) < 1e-9
    # a measure the loop cannot give: every case by simulate
    run = sweep("cylinder", {"mu": [0.3]}, ["slip", "max:lambda:contact"], engine="python", **kw)
    assert run.backend == "this process"
    with pytest.raises(SweepError, match="engine must be one of auto, compiled, python, scipy"):
        sweep("cylinder", {"mu": [0.3]}, ["slip"], engine="fast", **kw)


BALL = {
    "title": "A ball on a floor pushed up by a force that comes and goes",
    "parameters": {"m": 1.0, "g": 9.81, "A": 20.0, "w": 3.0},
    "coordinates": {"y": {"initial": 0, "velocity": 0}},
    "lagrangian": {"T": "m/2*y'^2", "V": "m*g*y"},
    "constraints": [{"name": "floor", "f": "y", "unilateral": True}],
    "forces": {"y": "A*sin(w*t)"},
}


@pytest.mark.slow
def test_an_impact_is_applied_in_the_loop_and_a_force_with_t_is_seen_inside_a_step():
    ball = lamech.from_dict(BALL)
    ns = compile_system(ball)
    # resting on the floor the state does not move, and one step spans the force's whole
    # rise: the loop looks at the force events inside each step of a system with t in it
    res = integrate_events(ns, [[0.0, 0.0]], 3.0, params={"A": 20.0})
    assert res.status == ["contact"] and res.fallback[0]
    lift = res.events[0][0]
    # lifts off where A sin(w t) = m g
    assert lift.kind == "lift-off" and abs(lift.t - math.asin(9.81 / 20) / 3) < 1e-9
    # the sweep of a system with t in it runs on the loop, with simulate's events
    params = {"A": [5.0, 20.0, 30.0]}  # 5 < m g: stays on the floor
    kw = dict(t_end=3.0, samples=11, workers=1)
    fast = sweep(ball, params, ["liftoff", "contact"], engine="python", **kw)
    slow = sweep(ball, params, ["liftoff", "contact"], engine="scipy", **kw)
    assert fast.backend == "the compiled loop with events (Python)"
    assert slow.backend == "this process"
    for a, b in zip(fast.rows, slow.rows):
        assert a.keys() == b.keys()
        for k in a:
            if isinstance(a[k], float) and math.isnan(a[k]):
                assert math.isnan(b[k]), k
            elif isinstance(a[k], float):
                assert abs(a[k] - b[k]) < 1e-9, k
            else:
                assert a[k] == b[k], k
    assert math.isnan(fast.rows[0]["liftoff:t"]) and fast.rows[1]["contact:t"] > 0
    assert abs(fast.rows[1]["liftoff:t"] - math.asin(9.81 / 20) / 3) < 1e-9
    # a ball dropped from h: the loop applies the impact itself, as simulate does
    drop = lamech.from_dict(
        {
            **BALL,
            "parameters": {"m": 1.0, "g": 9.81, "h": 1.0},
            "coordinates": {"y": {"initial": "h", "velocity": 0}},
            "forces": {"y": "0"},
        }
    )
    params = {"h": [0.5, 1.0]}
    fast = sweep(drop, params, ["contact", "final:y'"], engine="python", **kw)
    slow = sweep(drop, params, ["contact", "final:y'"], engine="scipy", **kw)
    assert fast.backend == "the compiled loop with events (Python)"  # none left to simulate
    for a, b in zip(fast.rows, slow.rows):
        assert a.keys() == b.keys() and a["status"] == b["status"] == "ok"
        for k in a:
            if isinstance(a[k], float) and not math.isnan(a[k]):
                assert abs(a[k] - b[k]) <= 1e-9, (k, a[k], b[k])
    assert abs(fast.rows[1]["contact:t"] - math.sqrt(2 / 9.81)) < 1e-9
    # only a lift-off wanted, and there is none: the loop runs to the end, nothing left
    only = sweep(drop, params, ["liftoff"], engine="python", t_end=0.2, samples=11, workers=1)
    assert only.backend == "the compiled loop with events (Python)"
    assert all(math.isnan(r["liftoff:t"]) for r in only.rows)


@pytest.mark.slow
def test_inputs_that_switch_switch_in_the_loop_where_their_s_crosses_zero():
    # pushed up by A from t = 1, by A + B from t = 1.5 (A < m g < A + B): the switch at
    # t = 1.5 lifts the ball off at once, and it rises under (A + B - m g) / m
    ball = lamech.from_dict(
        {**BALL, "parameters": {**BALL["parameters"], "B": 10.0},
         "forces": {"y": "A*step(t - 1) + B*step(t - 3/2)"}}
    )  # fmt: skip
    ns = compile_system(ball)
    res = integrate_events(ns, [[0.0, 0.0]], 2.0, params={"A": 5.0}, jit=False)
    lift = [e for e in res.events[0] if e.kind == "lift-off"]
    assert len(lift) == 1 and abs(lift[0].t - 1.5) < 1e-12
    switches = [e for e in res.events[0] if e.kind == "switch"]
    assert [round(e.t, 12) for e in switches] == [1.0, 1.5]
    assert switches[0].constraint == "step(t - 1)"
    # simulate: the loop (as Python) and SciPy's steps give the same run
    a = simulate(ns, 2.0, params={"A": 5.0}, engine="python", samples=21)
    b = simulate(ns, 2.0, params={"A": 5.0}, engine="scipy", samples=21)
    assert a.engine == "loop (Python)" and a.status == b.status == "ok"
    assert [(e.kind, e.constraint) for e in a.events] == [(e.kind, e.constraint) for e in b.events]
    assert all(abs(x.t - y.t) < 1e-12 for x, y in zip(a.events, b.events))
    assert np.max(np.abs(a.q - b.q)) < 1e-9
    # the y(t) of the flight after t = 1.5: (A + B - m g) / m (t - 1.5)^2 / 2
    after = a.t > 1.5
    exact = (15.0 - 9.81) / 2 * (a.t[after] - 1.5) ** 2
    assert np.max(np.abs(a.q[after, 0] - exact)) < 1e-9
    # the sweep runs it on the loop
    run = sweep(ball, {"A": [5.0, 20.0]}, ["liftoff"], t_end=2.0, samples=11, workers=1,
                engine="python")  # fmt: skip
    assert run.backend == "the compiled loop with events (Python)"
    assert [round(r["liftoff:t"], 12) for r in run.rows] == [1.5, 1.0]


@pytest.mark.slow
@pytest.mark.shared_cache
@pytest.mark.skipif(not compiled_available(), reason="no C compiler or engine")
def test_the_c_loop_gives_the_python_loop_numbers():
    py = _cylinder()
    jit = _cylinder(jit=True)
    _, Y0, a = _batch(py)
    _, Y1, b = _batch(jit)
    assert np.max(np.abs(Y0 - Y1)) < 1e-15
    assert a.status == b.status
    for ea, eb in zip(a.events, b.events):
        assert [(e.kind, e.constraint) for e in ea] == [(e.kind, e.constraint) for e in eb]
        assert max(abs(x.t - y.t) for x, y in zip(ea, eb)) < 1e-12
    assert np.max(np.abs(a.y - b.y)) < 1e-10
    assert jit_is_cached(jit, "ev_run_one")
    # the sweep: the engine in C, over two threads
    kw = dict(t_end=2.9, samples=11, initial={"theta1": THETA_S})
    run = sweep(
        "cylinder", {"mu": [0.1, 0.45], "R2": [0.3, 0.8]}, ["slip", "liftoff"], workers=2, **kw
    )
    assert run.backend == "the compiled loop with events (C, 2 threads)"
    ref = sweep(
        "cylinder",
        {"mu": [0.1, 0.45], "R2": [0.3, 0.8]},
        ["slip", "liftoff"],
        workers=1,
        engine="python",
        **kw,
    )
    for x, y in zip(run.rows, ref.rows):
        assert abs(x["slip:t"] - y["slip:t"]) < 1e-12
        assert abs(x["liftoff:theta1"] - y["liftoff:theta1"]) < 1e-12


@pytest.mark.slow
@pytest.mark.shared_cache
@pytest.mark.skipif(not compiled_available(), reason="no C compiler or engine")
def test_compiled_loop_switches_inputs_and_sees_force_dips_as_the_python_loop():
    """An input that switches and a force with t in it, on the engine in C: the same
    events as the loop as Python."""
    ball = lamech.from_dict(
        {**BALL, "parameters": {**BALL["parameters"], "B": 10.0},
         "forces": {"y": "A*step(t - 1) + B*step(t - 3/2) + A*sin(w*t)/4"}}
    )  # fmt: skip
    py, jit = compile_system(ball), compile_system(ball, jit=True)
    assert jit.jit
    for params in ({"A": 5.0}, {"A": 50.0}):
        a = integrate_events(py, [[0.0, 0.0]], 2.0, params=params, impacts=True)
        b = integrate_events(jit, [[0.0, 0.0]], 2.0, params=params, impacts=True)
        ea, eb = a.events[0], b.events[0]
        assert a.status == b.status and len(ea) >= 1
        assert [(e.kind, e.constraint) for e in ea] == [(e.kind, e.constraint) for e in eb]
        assert max(abs(x.t - y.t) for x, y in zip(ea, eb)) < 1e-12
        s1 = simulate(jit, 2.0, params=params, engine="compiled", samples=21)
        s2 = simulate(py, 2.0, params=params, engine="python", samples=21)
        assert s1.engine == "loop (C)" and s1.status == s2.status == "ok"
        assert {"switch", "lift-off"} <= {e.kind for e in s1.events}
        assert [e.kind for e in s1.events] == [e.kind for e in s2.events]
        assert max(abs(x.t - y.t) for x, y in zip(s1.events, s2.events)) < 1e-12
        assert np.max(np.abs(s1.q - s2.q)) < 1e-10


def test_a_case_the_loop_cannot_evaluate_is_left_to_simulate():
    # sqrt of a negative number once y > h: the Python loop raises; simulate stops the run
    # with its reason, and the sweep's row says so, as before
    ball = lamech.from_dict(
        {
            **BALL,
            "parameters": {**BALL["parameters"], "h": 0.05},
            "coordinates": {"y": {"initial": 0, "velocity": 2}},
            "forces": {"y": "A - sqrt(h - y)"},
        }
    )
    kw = dict(t_end=1.0, samples=11, workers=1, max_step=0.01)
    fast = sweep(ball, {"A": [30.0]}, ["liftoff", "contact"], engine="python", **kw)
    slow = sweep(ball, {"A": [30.0]}, ["liftoff", "contact"], engine="scipy", **kw)
    assert "by simulate" in fast.backend
    assert fast.rows == slow.rows and fast.rows[0]["status"] == "failed"


@pytest.mark.slow
def test_slip_at_the_start_then_stick_and_a_slip_that_cannot_stick():
    # a disk set down sliding (s' = v0, theta' = 0) on a level floor: kinetic friction
    # mu m g slows the slide and spins the disk up until s' = R theta', at t = v0/(3 mu g)
    ns = compile_system(lamech.load("incline_disk"))
    vals = np.array([[0.0, 0.1], [0.0, 0.3], [0.3, 0.1]])
    P = parameter_rows(ns, ["alpha", "mu"], vals)
    Y0 = initial_states(ns, P, [("s'", 2.0), ("theta'", 0.0)])
    Y0[2, 3:] = [0.0, 0.0, 5.0]  # on the slope, spinning forward: slips backward first
    res = integrate_events(ns, Y0, 2.0, params=P)
    assert res.status == ["end"] * 3
    for (alpha, mu), y0, events in zip(vals, Y0, res.events):
        traj = simulate(
            ns, 2.0, params={"alpha": alpha, "mu": mu}, q0=y0[:3], qd0=y0[3:], samples=11
        )
        assert [(e.kind, e.constraint) for e in events] == [
            (e.kind, e.constraint) for e in traj.events
        ]
        assert max(abs(a.t - b.t) for a, b in zip(events, traj.events)) < 1e-9
    assert [e.kind for e in res.events[0]] == ["slip", "stick"]
    assert abs(res.events[0][1].t - 2.0 / (3 * 0.1 * 9.81)) < 1e-9
    assert abs(res.events[1][1].t - 2.0 / (3 * 0.3 * 9.81)) < 1e-9
    # tan(alpha)/3 > mu: where the backward slip stops it cannot stick, it slips on forward
    assert [e.kind for e in res.events[2]] == ["slip", "slip"]
    kw = dict(t_end=2.0, samples=11, workers=1, initial={"s'": 2.0, "theta'": 0.0})
    grid = {"alpha": [0.0, 0.3], "mu": [0.1, 0.3]}
    fast = sweep("incline_disk", grid, ["stick", "final:s"], engine="python", **kw)
    slow = sweep("incline_disk", grid, ["stick", "final:s"], engine="scipy", **kw)
    assert fast.backend == "the compiled loop with events (Python)"
    for a, b in zip(fast.rows, slow.rows):
        assert a["status"] == b["status"] == "ok"
        assert math.isnan(a["stick:t"]) == math.isnan(b["stick:t"])
        if not math.isnan(a["stick:t"]):
            assert abs(a["stick:t"] - b["stick:t"]) < 1e-9
        assert abs(a["final:s"] - b["final:s"]) < 1e-7


def test_starts_made_in_the_runs_are_the_starts_initial_states_makes():
    """A sweep's starts are made consistent inside the loop's runs (``initial=``, in the
    runs' threads, no entry point of their own to load): the same starts and runs as
    initial_states' starts given to the loop, the caller's array untouched, and a start
    that cannot be made (not finite) left to simulate as "start"."""
    ns = _cylinder()
    held = [("theta1", THETA_S)]
    P = parameter_rows(ns, ["mu", "R2"], GRID[:3])
    made = initial_states(ns, P, held)
    raw = initial_states(ns, P)
    assert not np.allclose(raw, made)  # the projection moves the problem's own start
    before = raw.copy()
    a = integrate_events(ns, made, 0.5, params=P)
    b = integrate_events(ns, raw, 0.5, params=P, initial=held)
    assert np.array_equal(raw, before)
    assert a.status == b.status == ["end"] * 3
    assert np.array_equal(a.y, b.y) and np.array_equal(a.t, b.t)
    assert [[(e.kind, e.t) for e in x] for x in a.events] == [
        [(e.kind, e.t) for e in x] for x in b.events
    ]
    raw[1, 0] = np.nan
    c = integrate_events(ns, raw, 0.5, params=P, initial=held)
    assert c.status == ["end", "start", "end"] and c.fallback.tolist() == [False, True, False]
    assert np.array_equal(c.y[[0, 2]], b.y[[0, 2]])
