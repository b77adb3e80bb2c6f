"""The compiled ensemble loop gives simulate()'s numbers and keeps the invariants."""

from __future__ import annotations

import numpy as np
import pytest

import lamech
from lamech.numeric import compile_system, integrate_batch, numba_available, simulate
from lamech.problem import chain_toml


def _starts(ns, count, seed=3):
    """Consistent initial states: the chain at random link angles, at rest."""
    rng = np.random.default_rng(seed)
    n_links = ns.n // 2
    out = []
    for _ in range(count):
        a = 0.5 + rng.uniform(-0.3, 0.3, n_links)
        xy = np.column_stack((np.cumsum(np.sin(a)), -np.cumsum(np.cos(a)))).ravel()
        out.append(np.concatenate((xy, np.zeros(ns.n))))
    return np.array(out)


@pytest.fixture(scope="module")
def chain3():
    return compile_system(lamech.loads(chain_toml(3)), jit=False)


@pytest.mark.slow
def test_batch_matches_simulate_and_keeps_invariants(chain3):
    ns = chain3
    Y0 = _starts(ns, 3)
    res = integrate_batch(ns, Y0, 2.0, rtol=1e-10, atol=1e-12)
    assert res.ok.all() and (res.steps > 10).all()
    for b in range(len(Y0)):
        q0 = dict(zip(ns.coordinate_names, Y0[b, : ns.n]))
        ref = simulate(ns, 2.0, q0=q0, samples=2, rtol=1e-13, atol=1e-14)
        assert np.max(np.abs(res.q[b] - ref.q[-1])) < 1e-8
        lam_ref = ref.lambdas[-1]
        assert np.max(np.abs(res.lambdas[b] - lam_ref)) < 1e-7 * np.max(np.abs(lam_ref))
        f, A, bb = ns.constraints(2.0, res.q[b], ns.parameters)
        assert np.max(np.abs(f)) < 1e-13 and np.max(np.abs(A @ res.qd[b] + bb)) < 1e-12
        T0, V0 = ns.energy(0.0, Y0[b, : ns.n], Y0[b, ns.n :], ns.parameters)
        T1, V1 = ns.energy(2.0, res.q[b], res.qd[b], ns.parameters)
        assert abs((T1 + V1) - (T0 + V0)) < 1e-9 * max(abs(T0 + V0), 1.0)


def test_batch_refuses_events_and_bad_input(chain3):
    cyl = compile_system(lamech.load("cylinder"))
    with pytest.raises(ValueError, match="bilateral constraints only"):
        integrate_batch(cyl, np.zeros((1, 6)), 1.0)
    with pytest.raises(ValueError, match="entries"):
        integrate_batch(chain3, np.zeros((1, 5)), 1.0)
    with pytest.raises(ValueError, match="t_end"):
        integrate_batch(chain3, _starts(chain3, 1), -1.0)


@pytest.mark.slow
@pytest.mark.shared_cache
@pytest.mark.skipif(not numba_available(), reason="numba not installed")
def test_compiled_batch_gives_the_same_numbers(chain3):
    jitted = compile_system(lamech.loads(chain_toml(3)), jit=True)
    Y0 = _starts(chain3, 4)
    a = integrate_batch(chain3, Y0, 1.0)
    b = integrate_batch(jitted, Y0, 1.0)
    assert (a.steps == b.steps).all()
    assert np.allclose(a.q, b.q, rtol=0, atol=1e-12)
    assert np.allclose(a.lambdas, b.lambdas, rtol=1e-10)
    # a batch smaller than numba's thread count runs the serial loop: the same numbers
    one = integrate_batch(jitted, Y0[:1], 1.0)
    assert one.steps[0] == b.steps[0]
    assert np.allclose(one.q[0], b.q[0], rtol=0, atol=1e-14)


def test_batch_over_parameters_matches_simulate():
    """One dict of parameters per run: pendulums of three lengths in one batch, each equal
    to its own simulate() run; a mismatched count is refused."""
    ns = compile_system(lamech.loads(chain_toml(1)), jit=False)
    Y0 = np.repeat(_starts(ns, 1), 3, axis=0)
    lengths = [0.5, 1.0, 2.0]
    names = ns.parameter_names
    assert "l" in names, names
    for y, ell in zip(Y0, lengths):  # the start on each pendulum's circle
        y[:2] *= ell
    res = integrate_batch(ns, Y0, 1.5, params=[{"l": ell} for ell in lengths])
    assert res.ok.all()
    finals = []
    for b, ell in enumerate(lengths):
        q0 = dict(zip(ns.coordinate_names, Y0[b, : ns.n]))
        ref = simulate(ns, 1.5, q0=q0, samples=2, params={"l": ell}, rtol=1e-13, atol=1e-14)
        assert np.max(np.abs(res.q[b] - ref.q[-1])) < 1e-8
        assert abs(res.lambdas[b, 0] - ref.lambdas[-1, 0]) < 1e-7 * abs(ref.lambdas[-1, 0])
        finals.append(res.q[b])
    assert not np.allclose(finals[0] / 0.5, finals[2] / 2.0)  # the length mattered
    with pytest.raises(ValueError, match="parameter sets"):
        integrate_batch(ns, Y0, 1.0, params=[{"l": 1.0}])


def _correction():
    from lamech.numeric._kernels import python_namespace

    return python_namespace()["ev_correction"]


def test_the_projection_is_the_smallest_in_the_mass_metric():
    """The KKT correction minimises dx^T W dx on A dx = r: W^-1 A^T w for a diagonal W
    (the Schur path) and a full one (the KKT elimination)."""
    rng = np.random.default_rng(5)
    A, r = rng.normal(size=(2, 4)), rng.normal(size=2)
    for W in (np.diag([1.0, 2.0, 3.0, 4.0]), np.eye(4) + 0.3 * np.ones((4, 4))):
        dx = _correction()(W, A, r)
        w = np.linalg.solve(A @ np.linalg.solve(W, A.T), r)
        assert np.allclose(dx, np.linalg.solve(W, A.T @ w), rtol=1e-12, atol=1e-14)


def test_a_singular_metric_falls_back_to_the_euclidean_correction():
    """M singular on the motions A allows (a massless coordinate): dx = A^T (A A^T)^-1 r."""
    W = np.diag([1.0, 0.0, 0.0])
    A, r = np.array([[0.0, 1.0, 1.0]]), np.array([0.5])
    dx = _correction()(W, A, r)
    assert np.allclose(dx, [0.0, 0.25, 0.25], rtol=0, atol=1e-15)


@pytest.mark.parametrize("consistent", [True, False])
def test_dependent_rows_get_numpys_least_squares_correction(consistent):
    """A repeated constraint row (A A^T singular): the minimum-norm least-squares dx,
    numpy.linalg.lstsq's, in the Euclidean metric where M is singular as well."""
    rng = np.random.default_rng(7)
    a = rng.normal(size=(2, 5))
    A = np.vstack((a, a[0] + 2 * a[1]))
    r = rng.normal(size=3)
    if consistent:
        r[2] = r[0] + 2 * r[1]
    want = np.linalg.lstsq(A, r, rcond=None)[0]
    for W in (np.eye(5), np.zeros((5, 5))):
        dx = _correction()(W, A, r)
        assert np.allclose(dx, want, rtol=1e-12, atol=1e-13)
