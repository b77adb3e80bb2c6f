"""The benchmark compares like with like: the peers' models are lamech's model."""

from __future__ import annotations

import numpy as np
import pytest

from bench.run import (kernel_inputs, lamech_b1, lamech_qdd_lambda, sympy_b1,
                       chain_state, lamech_chain, mujoco_angles, mujoco_chain, mujoco_masses,
                       mujoco_tensions)
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
