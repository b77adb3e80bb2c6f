"""``simulate`` on the loop with events (engine "loop": the compiled DOP853 loop, run here
as Python, the same rules and numbers) against ``simulate`` on SciPy's
DOP853 (engine "scipy"), in every contact mode: the same events at the same times, the
same samples, multipliers, forces and energy; and each against its closed form where
one exists."""

from __future__ import annotations

import math
import subprocess
import sys
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

import lamech
from lamech.numeric import SimulationError, compile_system, compiled_available, simulate

G = 9.81
HERE = Path(__file__).parent

BALL = (HERE / "problems" / "ball.toml").read_text(encoding="utf-8")


def _example(name: str, old: str = "", new: str = "") -> str:
    text = (resources.files("lamech") / "examples" / f"{name}.toml").read_text()
    assert old in text
    return text.replace(old, new)


# (problem text, t_end, simulate's options): every mode the loop mirrors or hands back
CASES = {
    # slip then lift-off (the lecture's question), from just off the top
    "cylinder": (_example("cylinder"), 6.0, {"initial": {"theta1": 0.01}}),
    # lift-off from the wall, then the top lands on the floor (a contact the simulator
    # applies, e = 0)
    "ladder": (_example("ladder"), 3.0, {}),
    # impacts with restitution and the Zeno accumulation: handed to the simulator
    "ball": (BALL, 3.0, {}),
    # a sliding disk on a level floor: slip at the start, then stick
    "stick": (
        _example("incline_disk", "alpha = 0.5", "alpha = 0.0"),
        1.0,
        {"qd0": {"s": 2.0, "theta": 0.0}},
    ),
    # spinning forward on a slope: slips backward, then cannot stick (a reversal)
    "reversal": (
        _example("incline_disk", "alpha = 0.5", "alpha = 0.3"),
        2.0,
        {"params": {"mu": 0.1}, "qd0": {"s": 0.0, "theta": 5.0}},
    ),
    "pendulum": (_example("pendulum"), 5.0, {}),
    "four_bar": (_example("four_bar"), 2.0, {}),
    "knife_edge": (_example("knife_edge"), 2.0, {}),
    "wedge": (_example("wedge"), 2.0, {}),
}


def _pair(name):
    text, t_end, kw = CASES[name]
    ns = compile_system(lamech.loads(text))
    return (simulate(ns, t_end, engine="scipy", **kw), simulate(ns, t_end, engine="python", **kw))


# the cases of 2 s or more: left out of the default set
SLOW_RUNS = {
    "cylinder",
    "four_bar",
    "knife_edge",
    "ladder",
    "pendulum",
    "reversal",
    "stick",
    "wedge",
}
assert SLOW_RUNS <= set(CASES), SLOW_RUNS - set(CASES)


@pytest.mark.parametrize(
    "name",
    [pytest.param(n, marks=pytest.mark.slow) if n in SLOW_RUNS else n for n in sorted(CASES)],
)
def test_the_loop_gives_simulates_events_samples_and_forces(name):
    a, b = _pair(name)
    assert a.engine == "SciPy DOP853" and b.engine == "loop (Python)"
    assert a.status == b.status == "ok", (a.message, b.message)
    assert [(e.kind, e.constraint) for e in a.events] == [(e.kind, e.constraint) for e in b.events]
    for ea, eb in zip(a.events, b.events):
        assert abs(ea.t - eb.t) <= 1e-10
        for detail in ("multiplier", "ratio", "impulse", "restitution", "velocity_before"):
            x, y = getattr(ea, detail), getattr(eb, detail)
            assert (x is None) == (y is None), (ea, eb)
            assert x is None or abs(x - y) <= 1e-9 * (1 + abs(x))
        assert (ea.reversal, ea.initial, ea.accumulation is None) == (
            eb.reversal,
            eb.initial,
            eb.accumulation is None,
        )
    assert np.array_equal(a.t, b.t)
    assert np.max(np.abs(a.q - b.q)) <= 1e-9 and np.max(np.abs(a.qd - b.qd)) <= 1e-9
    assert np.array_equal(np.isnan(a.lambdas), np.isnan(b.lambdas))
    assert np.nanmax(np.abs(a.lambdas - b.lambdas), initial=0.0) <= 1e-9
    for key in a.forces:
        assert np.nanmax(np.abs(a.forces[key] - b.forces[key]), initial=0.0) <= 1e-9
    assert np.max(np.abs(a.energy - b.energy)) <= 1e-9
    assert np.max(b.residual) <= 1e-9
    assert a.final_time == b.final_time and np.allclose(a.final_q, b.final_q, atol=1e-9)
    assert a.energy_conserved == b.energy_conserved


@pytest.mark.slow
def test_the_loops_stick_and_reversal_are_the_closed_forms():
    _, b = _pair("stick")
    assert [e.kind for e in b.events] == ["slip", "stick"] and b.events[0].initial
    assert abs(b.events[1].t - 2.0 / (3 * 0.3 * G)) <= 1e-9  # v0 - mu g t = R w = 2 mu g t
    _, r = _pair("reversal")
    assert [e.kind for e in r.events] == ["slip", "slip"]
    assert r.events[1].reversal is True


@pytest.mark.slow
def test_the_ball_bounces_and_rests_through_the_loop():
    """The loop hands each impact to the simulator and goes on: the bounce times
    t1 (1 + 2 e (1 - e^k) / (1 - e)) and the rest from the accumulation time."""
    _, b = _pair("ball")
    e, t1 = 0.5, math.sqrt(2 / G)
    impacts = [ev for ev in b.events if ev.kind == "impact"]
    for k, ev in enumerate(impacts[:8]):
        assert abs(ev.t - t1 * (1 + 2 * e * (1 - e**k) / (1 - e))) <= 1e-9
    assert b.events[-1].kind == "contact"
    assert abs(b.events[-1].t - t1 * (1 + e) / (1 - e)) <= 1e-6
    assert abs(b.final_q[0]) <= 1e-9 and abs(b.final_qd[0]) <= 1e-9


@pytest.mark.slow
def test_the_loop_is_refused_where_it_cannot_run_and_auto_falls_back(tmp_path, monkeypatch):
    system = lamech.load("pendulum")
    with pytest.raises(SimulationError, match="engine 'python' cannot run this problem: method "):
        simulate(system, 1.0, engine="python", method="Radau")
    with pytest.raises(
        SimulationError, match="engine must be one of auto, compiled, python, scipy"
    ):
        simulate(system, 1.0, engine="cvode")
    # t in the problem: the loop runs it (it seeks force events inside its steps too)
    shaken = lamech.loads(_example("pendulum", 'V = "', 'V = "sin(t) + '))
    a, b = simulate(shaken, 1.0, engine="python"), simulate(shaken, 1.0, engine="scipy")
    assert a.engine == "loop (Python)" and a.status == b.status == "ok"
    assert np.max(np.abs(a.q[-1] - b.q[-1])) < 1e-8
    tr = simulate(system, 1.0, method="Radau")
    assert tr.engine == "SciPy Radau" and tr.status == "ok"
    # the default where the problem was never compiled: compiled now, on the engine in C
    monkeypatch.setenv("LAMECH_CACHE_DIR", str(tmp_path))
    assert simulate(system, 1.0, samples=3).engine == "loop (C)"
    assert simulate(system, 1.0, samples=3, jit=False).engine == "SciPy DOP853"


@pytest.mark.slow
def test_progress_is_called_between_the_loops_chunks():
    seen = []
    tr = simulate(
        lamech.load("pendulum"),
        1000.0,
        engine="python",
        samples=11,
        rtol=1e-8,
        atol=1e-10,
        progress=seen.append,
    )
    assert tr.status == "ok" and tr.steps > 4000
    assert len(seen) >= tr.steps // 2000 and seen == sorted(seen) and seen[-1] == 1000.0


@pytest.mark.slow
@pytest.mark.shared_cache
@pytest.mark.skipif(not compiled_available(), reason="no C compiler or engine")
def test_the_engine_is_the_default_from_the_first_run_with_scipys_numbers(tmp_path, monkeypatch):
    """A problem never run before runs on the engine in C by default (jit=None: its own
    functions compiled now, in a fraction of a second, and cached), in this process and
    in a new one, with SciPy's path's numbers. The same problem compiled earlier in this
    process under another cache folder changes nothing: the folder in force is written
    all the same."""
    text, t_end, kw = CASES["cylinder"]
    assert simulate(lamech.loads(text), 0.1, jit=True, **kw).engine == "loop (C)"
    monkeypatch.setenv("LAMECH_CACHE_DIR", str(tmp_path / "now"))
    a = simulate(lamech.loads(text), t_end, jit=False, **kw)
    b = simulate(lamech.loads(text), t_end, **kw)
    assert list((tmp_path / "now" / "kernels").glob("lamech_c_*.so"))
    assert a.engine == "SciPy DOP853" and b.engine == "loop (C)"
    assert [e.kind for e in a.events] == [e.kind for e in b.events] == ["slip", "lift-off"]
    assert max(abs(ea.t - eb.t) for ea, eb in zip(a.events, b.events)) <= 1e-10
    assert np.max(np.abs(a.q - b.q)) <= 1e-10
    assert np.nanmax(np.abs(a.lambdas - b.lambdas)) <= 1e-9
    assert simulate(lamech.loads(text), t_end, **kw).engine == "loop (C)"
    code = (
        "import sys, lamech\n"
        "tr = lamech.simulate(lamech.loads(sys.stdin.read()), 6.0, initial={'theta1': 0.01})\n"
        "print(tr.engine, tr.events[-1].t)"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        input=text,
        capture_output=True,
        text=True,
        timeout=600,
        check=True,
    )
    engine, t_lift = out.stdout.rsplit(" ", 1)
    assert engine == "loop (C)" and abs(float(t_lift) - b.events[-1].t) <= 1e-12


# ----- impacts in the loop (issue 14 item 1) ---------------------------------------------
def _spinning_disk(restitution: str | None = None) -> str:
    """The incline disk dropped from 5 cm above the slope, spinning (theta' = 20 with mu =
    0.1 below): it lands with more slip than mu times the normal impulse can stop."""
    text = _example(
        "incline_disk",
        'n     = { initial = "R", velocity = 0 }',
        'n     = { initial = "R + 0.05", velocity = 0 }',
    )
    if restitution is not None:
        rule = f'unilateral = true\nrestitution = "{restitution}"\n'
        text = text.replace("unilateral = true\n", rule, 1)
    return text


ZENO_INCLINE = (HERE / "problems" / "ball_on_incline.toml").read_text(encoding="utf-8")


def _zeno_problem(name: str) -> str:
    """tests/test_zeno.py's BALL (e = 0.8) and INCLINE."""
    return {"ball": BALL.replace("e = 0.5", "e = 0.8"), "incline": ZENO_INCLINE}[name]


IMPACT_CASES = {
    # e = 0.8, 40-odd bounces and the contact at their accumulation time
    "zeno ball": (lambda: _zeno_problem("ball"), 10.0, {}),
    # bounces on a frictionless incline, then sliding down it in contact
    "incline": (lambda: _zeno_problem("incline"), 3.0, {}),
    # e = 0: the contact engages and its friction slips through the impact
    "slip through": (_spinning_disk, 1.0, {"params": {"mu": 0.1}, "qd0": {"theta": 20.0}}),
    # e = 0.5: bounces, then a Zeno sequence whose engaging friction slips through
    "zeno slip": (
        lambda: _spinning_disk("0.5"),
        1.5,
        {"params": {"mu": 0.1}, "qd0": {"theta": 20.0}},
    ),
}


def _same_runs(a, b, tol=1e-9):
    assert a.status == b.status == "ok", (a.message, b.message)
    assert [(e.kind, e.constraint) for e in a.events] == [(e.kind, e.constraint) for e in b.events]
    for ea, eb in zip(a.events, b.events):
        assert abs(ea.t - eb.t) <= 1e-10
        for detail in (
            "impulse",
            "restitution",
            "velocity_before",
            "accumulation",
            "ratio",
            "multiplier",
        ):
            x, y = getattr(ea, detail), getattr(eb, detail)
            assert (x is None) == (y is None), (detail, ea, eb)
            assert x is None or abs(x - y) <= tol * (1 + abs(x)), (detail, ea, eb)
        assert (ea.reversal, ea.initial) == (eb.reversal, eb.initial)
    assert np.array_equal(a.t, b.t)
    assert np.max(np.abs(a.q - b.q)) <= tol and np.max(np.abs(a.qd - b.qd)) <= tol
    assert np.nanmax(np.abs(a.lambdas - b.lambdas), initial=0.0) <= tol
    assert np.max(np.abs(a.energy - b.energy)) <= tol
    assert a.final_time == b.final_time and a.energy_conserved == b.energy_conserved


# the cases of 2 s or more: left out of the default set
SLOW_IMPACTS = {"incline", "zeno ball", "zeno slip"}
assert SLOW_IMPACTS <= set(IMPACT_CASES), SLOW_IMPACTS - set(IMPACT_CASES)


@pytest.mark.parametrize(
    "name",
    [
        pytest.param(n, marks=pytest.mark.slow) if n in SLOW_IMPACTS else n
        for n in sorted(IMPACT_CASES)
    ],
)
def test_the_loop_applies_impacts_contacts_and_the_zeno_accumulation_itself(name):
    """The loop applies each impact as the simulator does (the bounce, the contact with
    its friction sticking or slipping through the impact, the accumulation's contact at
    its time): SciPy's events with their details, samples and forces; and no contact is
    handed to the simulator (no simulator segment runs, no event is applied in Python),
    except after a gap that turns within one step (small bounces on the incline and of
    the disk: a simulator segment each, as before)."""
    make, t_end, kw = IMPACT_CASES[name]
    ns = compile_system(lamech.loads(make()))
    a = simulate(ns, t_end, engine="scipy", **kw)
    b = simulate(ns, t_end, engine="python", **kw)
    _same_runs(a, b)
    impacts = [e for e in b.events if e.kind == "impact"]
    contacts = [e for e in b.events if e.kind == "contact"]
    assert contacts and contacts[-1].restitution is not None
    if name in ("incline", "zeno slip"):
        # the handed-back segments (small bounces whose gap turns within a step) apply what
        # they meet; the loop applied the rest
        assert 0 < b.handed_back < len(impacts)
    else:
        assert b.handed_back == 0
    if name.startswith("zeno") or name == "incline":
        assert impacts and contacts[-1].accumulation is not None
        assert abs(contacts[-1].t - contacts[-1].accumulation - impacts[-1].t) <= 1e-12
    if name == "slip through":
        # Coulomb: the friction impulse is mu times the normal one, against the slip
        i = next(k for k, e in enumerate(b.events) if e.kind == "slip")
        slip, hit = b.events[i], b.events[i - 1]
        assert slip.constraint == "rolling" and slip.t == hit.t
        assert abs(abs(slip.impulse) - 0.1 * abs(hit.impulse)) <= 1e-12 * abs(hit.impulse)


def test_the_zeno_bounces_rest_at_the_accumulation_time_through_the_loop():
    """The bouncing ball (e = 0.8) on the loop: bounce k at t1 (1 + 2 e (1 - e^k) /
    (1 - e)), the contact at t1 (1 + e) / (1 - e) (to the accumulation of the bounces
    too small to resolve), at rest on the floor after it."""
    ns = compile_system(lamech.loads(_zeno_problem("ball")))
    b = simulate(ns, 10.0, engine="python")
    e, t1 = 0.8, math.sqrt(2 / G)
    impacts = [ev for ev in b.events if ev.kind == "impact"]
    for k, ev in enumerate(impacts[:10]):
        assert abs(ev.t - t1 * (1 + 2 * e * (1 - e**k) / (1 - e))) <= 1e-9
        assert abs(ev.velocity_before + G * t1 * e**k) <= 1e-8 and ev.restitution == e
        assert abs(ev.impulse - (1 + e) * G * t1 * e**k) <= 1e-8
    assert [ev.kind for ev in b.events[-1:]] == ["contact"]
    assert abs(b.events[-1].t - t1 * (1 + e) / (1 - e)) <= 1e-6
    assert abs(b.final_q[0]) <= 1e-9 and abs(b.final_qd[0]) <= 1e-9


@pytest.mark.slow
def test_integrate_events_applies_impacts_in_the_loop_when_asked():
    """integrate_events(impacts=True) (the sweeps' loop, as Python here) gives simulate's
    bounces, the accumulation's contact and the slip through an impact; by default a
    contact still stops the run for simulate (status "contact")."""
    from lamech.numeric import integrate_events

    for name in ("zeno ball", "slip through"):
        make, t_end, kw = IMPACT_CASES[name]
        ns = compile_system(lamech.loads(make()))
        tr = simulate(ns, t_end, engine="python", **kw)
        params = kw.get("params")
        y0 = np.concatenate((tr.q[0], tr.qd[0]))
        res = integrate_events(ns, [y0], t_end, params=params, max_events=128, impacts=True)
        assert res.status == ["end"]
        assert [(e.kind, e.constraint) for e in res.events[0]] == [
            (e.kind, e.constraint) for e in tr.events
        ]
        for ea, eb in zip(tr.events, res.events[0]):
            assert abs(ea.t - eb.t) <= 1e-10
            for detail in ("impulse", "restitution", "velocity_before", "accumulation"):
                x, y = getattr(ea, detail), getattr(eb, detail)
                assert (x is None) == (y is None) and (x is None or abs(x - y) <= 1e-9)
        first = integrate_events(
            ns, [y0], t_end, params=params, want=[("impact", None)], to_end=False, impacts=True
        )
        assert first.status == (["found"] if name == "zeno ball" else ["end"])
        old = integrate_events(ns, [y0], t_end, params=params)
        assert old.status == ["contact"] and old.fallback[0]


@pytest.mark.slow
@pytest.mark.shared_cache
@pytest.mark.skipif(not compiled_available(), reason="no C compiler or engine")
def test_the_compiled_loop_applies_the_impacts_with_the_same_numbers():
    """jit=True: the engine in C applies the impacts (the Zeno ball, the disk whose friction
    slips through the landing) and gives the Python loop's numbers."""
    for name in ("zeno ball", "slip through"):
        make, t_end, kw = IMPACT_CASES[name]
        a = simulate(compile_system(lamech.loads(make())), t_end, engine="python", **kw)
        b = simulate(lamech.loads(make()), t_end, jit=True, **kw)
        assert a.engine == "loop (Python)" and b.engine == "loop (C)"
        _same_runs(a, b, tol=1e-12)
