"""The benchmark compares like with like: the peers' models are lamech's model."""

from __future__ import annotations

import numpy as np
import pytest

from bench.run import (B5_PROBLEMS, kernel_inputs, lamech_b1, lamech_b5, lamech_qdd_lambda,
                       sympy_b1, sympy_b5, sympy_lagranges, chain_state, lamech_chain,
                       mujoco_angles, mujoco_chain, mujoco_masses, mujoco_tensions)
from lamech.numeric import compile_system


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
    assert np.allclose(mujoco_masses(model, data, n)[:, [0, 2]].ravel(), chain_state(n, angles),
                       atol=1e-14)
    ns = compile_system(lamech_chain(n))
    q = chain_state(n, angles)
    M, rhs, A, gam, _ = ns.dynamics(0.0, q, np.zeros(2 * n), ns.parameters)
    K = np.block([[M, -A.T], [A, np.zeros((n, n))]])
    lam = np.linalg.solve(K, np.concatenate((rhs, -gam)))[2 * n:]
    assert np.allclose(mujoco_tensions(model, data, n), -2 * lam, rtol=1e-9)


def test_reference_helper_matches_the_kernel():
    """B1/B2 time `accelerations`; the integrator uses `rhs_kernel`: the same q''."""
    ns = compile_system(lamech_chain(2))
    qdd, lam = lamech_qdd_lambda(ns)
    y, p, rows, e, _, c = kernel_inputs(ns)
    assert np.allclose(qdd, ns.rhs_kernel(0.0, y, p, rows, e, e, c)[ns.n:], rtol=1e-12)
    _, qdd_b1 = lamech_b1(2, jit=False)
    assert np.allclose(qdd, qdd_b1, rtol=1e-12)
    assert np.all(lam < 0)     # links in tension: lambda < 0 for f = |d|^2 - l^2


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


def test_symbolic_benchmark_problems_load():
    import lamech
    for _, source in B5_PROBLEMS:
        system = lamech.loads(source) if "\n" in source else lamech.load(source)
        _, q, _, _, names = sympy_lagranges(system)
        assert len(q) == len(system.coordinates) and len(names) == len(system.constraints)
