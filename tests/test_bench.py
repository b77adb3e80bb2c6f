"""The benchmark compares like with like: the peers' models are lamech's model."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bench.run import (
    B5_PROBLEMS,
    chain_state,
    kernel_inputs,
    lamech_b1,
    lamech_b5,
    lamech_chain,
    lamech_qdd_lambda,
    mujoco_angles,
    mujoco_chain,
    mujoco_masses,
    mujoco_tensions,
    sympy_b1,
    sympy_b5,
    sympy_lagranges,
)
from lamech.numeric import compile_system


@pytest.mark.slow
def test_sympy_peer_is_the_same_chain():
    _, qdd = lamech_b1(3, jit=False)
    assert np.allclose(sympy_b1(3, cse=True), qdd, rtol=1e-10, atol=1e-12)


def test_mujoco_peer_is_the_same_chain():
    mujoco = pytest.importorskip("mujoco", reason="mujoco not installed (extra `bench`)")
    n = 4
    angles = np.array([0.5, 0.3, -0.2, 0.1])
    model, data = mujoco_chain(n)
    data.qpos[:] = mujoco_angles(angles)
    mujoco.mj_forward(model, data)
    assert np.allclose(
        mujoco_masses(model, data, n)[:, [0, 2]].ravel(), chain_state(n, angles), atol=1e-14
    )
    ns = compile_system(lamech_chain(n))
    q = chain_state(n, angles)
    M, rhs, A, gam, _ = ns.dynamics(0.0, q, np.zeros(2 * n), ns.parameters)
    K = np.block([[M, -A.T], [A, np.zeros((n, n))]])
    lam = np.linalg.solve(K, np.concatenate((rhs, -gam)))[2 * n :]
    assert np.allclose(mujoco_tensions(model, data, n), -2 * lam, rtol=1e-9)


def test_reference_helper_matches_the_kernel():
    """B1/B2 time `accelerations`; the integrator uses `rhs_kernel`: the same q''."""
    ns = compile_system(lamech_chain(2))
    qdd, lam = lamech_qdd_lambda(ns)
    y, p, rows, e, _, c = kernel_inputs(ns)
    assert np.allclose(qdd, ns.rhs_kernel(0.0, y, p, rows, e, e, c)[ns.n :], rtol=1e-12)
    _, qdd_b1 = lamech_b1(2, jit=False)
    assert np.allclose(qdd, qdd_b1, rtol=1e-12)
    assert np.all(lam < 0)  # links in tension: lambda < 0 for f = |d|^2 - l^2


@pytest.mark.parametrize("name", ["pendulum", "knife_edge"])
def test_symbolic_peer_solves_lamechs_problem(name):
    """B5: SymPy's LagrangesMethod gets lamech's L and constraints as written (holonomic
    and velocity ones), and its solve_multipliers, sign turned, is lamech's lambda."""
    import lamech

    system = lamech.load(name)
    theirs, _, _ = sympy_b5(system)
    mine, _ = lamech_b5(name)
    assert set(theirs) == set(mine) == {c.name for c in system.constraints}
    for n, lam in mine.items():
        assert abs(lam) > 0.1
        assert np.isclose(theirs[n], lam, rtol=1e-10)


@pytest.mark.slow
@pytest.mark.parametrize("source", [s for _, s in B5_PROBLEMS])
def test_b5s_whole_report_and_raw_multipliers_agree_at_the_start(source):
    """B5's three columns are compared at the initial state before a time counts; the
    whole report may give its results in a chart's angles (the Cartesian double
    pendulum in theta1, theta2), which the start values must include (the full run
    stopped there: 'Cannot convert expression to float')."""
    import lamech
    from bench.run import lamech_b5_fast, lamech_b5_full

    system = lamech.loads(source) if "\n" in source else lamech.load(source)
    fast = lamech_b5_fast(system)[0]
    full = lamech_b5_full(source)[0]
    assert fast.keys() == full.keys()
    for name, value in fast.items():
        assert full[name] == pytest.approx(value, rel=1e-8)


@pytest.mark.slow
def test_symbolic_benchmark_problems_load():
    import lamech

    for _, source in B5_PROBLEMS:
        system = lamech.loads(source) if "\n" in source else lamech.load(source)
        _, q, _, _, names = sympy_lagranges(system)
        assert len(q) == len(system.coordinates) and len(names) == len(system.constraints)


def test_interleave_alternates_the_order_and_keeps_min_median_max():
    from bench.run import interleave

    order = []

    def case(name, wall):
        def run():
            order.append(name)
            return wall.pop(0), 0.5, name

        return run

    got = interleave(
        [("a", case("a", [3.0, 1.0, 2.0])), ("b", case("b", [5.0, 4.0, 6.0]))], repeats=3
    )
    assert order == ["a", "b", "b", "a", "a", "b"]  # reversed every other round
    assert got["a"].wall == (1.0, 2.0, 3.0) and got["b"].wall == (4.0, 5.0, 6.0)
    assert got["a"].cpu == (0.5, 0.5, 0.5) and got["a"].result == ("a",)
    assert got["a"].runs == 3


def test_interleave_runs_slow_and_capped_cases_once():
    from bench.run import interleave

    calls = {"slow": 0, "capped": 0, "fast": 0}

    def run(name, wall):
        def f():
            calls[name] += 1
            return None if wall is None else (wall, wall)

        return f

    got = interleave(
        [("slow", run("slow", 40.0)), ("capped", run("capped", None)), ("fast", run("fast", 1.0))],
        repeats=3,
        alone_after=30.0,
    )
    assert calls == {"slow": 1, "capped": 1, "fast": 3}
    assert got["capped"] is None and got["slow"].runs == 1 and got["fast"].runs == 3


def test_at_error_interpolates_on_the_pareto_front():
    from bench.run import at_error

    # time = err^(-1/8): interpolation in log-log is exact on the front
    pts = [(e ** (-1 / 8), e) for e in (1e-4, 1e-6, 1e-8, 1e-10)]
    assert np.isclose(at_error(pts, 1e-7), 1e-7 ** (-1 / 8), rtol=1e-12)
    assert np.isclose(at_error(pts, 1e-10), 1e-10 ** (-1 / 8), rtol=1e-12)
    assert at_error(pts, 1e-11) is None and at_error(pts, 1e-3) is None
    # a setting both slower and less accurate than another is not on the front
    assert np.isclose(at_error(pts + [(100.0, 1e-5)], 1e-5), 1e-5 ** (-1 / 8), rtol=1e-12)


def test_mujoco_positions_are_the_final_states():
    """B3 reads MuJoCo's positions after mj_forward: RK4 at dt 1 ms over 0.2 s is within
    1e-9 of lamech's tight run (the stored positions of the last step's forward pass
    would be a step behind: about 1e-3 off)."""
    pytest.importorskip("mujoco", reason="mujoco not installed (extra `bench`)")
    from bench.run import ANGLE, lamech_run, mujoco_run

    n = 2
    system = lamech_chain(n)
    _, _, ref_pos, ref_T = lamech_run(system, 0.2, 1e-12, False)
    _, _, pos, T = mujoco_run(n, np.full(n, ANGLE), "RK4", 1e-3, 0.2)
    assert np.max(np.abs(pos - ref_pos)) < 1e-9
    assert np.max(np.abs(T - ref_T)) < 1e-7 * np.max(np.abs(ref_T))


def test_casadi_peer_is_the_same_chain():
    """B3/B4's CasADi model: its tensions at the start are lamech's (the check the
    benchmark makes), and CVODES on it follows lamech's run."""
    pytest.importorskip("casadi", reason="casadi not installed (extra `bench`)")
    from bench.run import CasadiChain, casadi_peer, lamech_run

    n = 3
    ns = compile_system(lamech_chain(n))
    _, lam = lamech_qdd_lambda(ns)
    peer = CasadiChain(n, jit=False)
    y0 = np.concatenate((chain_state(n), np.zeros(2 * n)))
    assert np.allclose(peer.tensions(y0), -2 * lam, rtol=1e-12)
    assert casadi_peer(n, ns) is not None  # the benchmark's own check passes
    _, _, ref_pos, ref_T = lamech_run(ns.system, 0.5, 1e-12, False, ns)
    _, _, pos, T = peer.run(y0, 0.5, 1e-12, 1e-14)
    assert np.max(np.abs(pos - ref_pos)) < 1e-8
    assert np.max(np.abs(T - ref_T)) < 1e-7 * np.max(np.abs(ref_T))


def test_b7_peers_are_the_ball_and_the_lecture_wheel():
    """B7: MuJoCo's sphere touches the plane where qpos (the distance B7 reads) is 0;
    its hinge wheel has the rolling wheel's theta'' = 2 g sin(theta) / (3 (R1 + R2)) and
    its force sensor reads the normal force N = m g cos(theta) - m (R1 + R2) theta'^2;
    the true lift-off time by quad is mpmath's; the crossing is exact on a cubic."""
    mujoco = pytest.importorskip("mujoco", reason="mujoco not installed (extra `bench`)")
    from bench import events as ev

    model, data = ev.mujoco_ball("RK4", 1e-3)
    data.qpos[0] = 0.01
    mujoco.mj_forward(model, data)
    assert data.ncon == 0
    data.qpos[0] = -0.01
    mujoco.mj_forward(model, data)
    assert data.ncon == 1 and np.isclose(data.contact[0].dist, -0.01, atol=1e-12)
    model, data = ev.mujoco_cylinder("RK4", 1e-3)
    R = ev.R1 + ev.R2
    data.qpos[0], data.qvel[0] = 0.4, 1.3
    mujoco.mj_forward(model, data)
    assert np.isclose(data.qacc[0], 2 * ev.G * np.sin(0.4) / (3 * R), rtol=1e-12)
    assert np.isclose(data.sensordata[2], ev.G * np.cos(0.4) - R * 1.3**2, rtol=1e-12)
    assert abs(ev.liftoff_time(0.05) - ev.liftoff_time_mpmath(0.05)) < 1e-13
    # samples of (0.37 - t)(1 + t^2) dt = 0.1 apart: the cubic finds 0.37 to rounding
    t = np.arange(8) * 0.1
    V = ((0.37 - t) * (1 + t**2))[None, :]
    lin, cub = ev.crossing(V, np.array([4]), np.zeros(1), 0.1)
    assert abs(cub[0] - 0.37) < 1e-14 and 0.3 < lin[0] < 0.4 and abs(lin[0] - 0.37) > 1e-4


@pytest.mark.parametrize("name", ["pendulum", pytest.param("atwood", marks=pytest.mark.slow)])
def test_b9s_sympy_script_runs_and_prints_a_multiplier_per_constraint(name, tmp_path):
    """B9's SymPy side is a script written from lamech's model (its multipliers are
    checked against lamech's in test_symbolic_peer_solves_lamechs_problem): it renders,
    runs, and prints one multiplier per constraint."""
    import subprocess
    import sys

    import lamech
    from bench.solve import sympy_script

    system = lamech.load(name)
    script = tmp_path / "peer.py"
    script.write_text(sympy_script(system))
    done = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    printed = [line for line in done.stdout.splitlines() if line.startswith("lam")]
    assert len(printed) == len(system.constraints), done.stdout


def test_b6_truth_and_the_sympy_scipy_peer_agree_on_the_slip_angle():
    """B6's truth is the energy integral's root (the cylinder's file: mu = 0.3 slips at
    33.48 deg from the top); SymPy + SciPy's slip angles, found by solve_ivp's events on
    LagrangesMethod's multipliers, agree with it."""
    from bench.sweep import lift_truth, peer, slip_truth

    assert math.degrees(slip_truth(0.3, 0.0)) == pytest.approx(33.48, abs=5e-3)
    assert math.cos(lift_truth(0.0)) == pytest.approx(4 / 7, abs=1e-15)
    got = peer(2, 2)
    assert got["cases"] == 4 and got["slip"] < 1e-8
