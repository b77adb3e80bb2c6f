"""The compiled ensemble loop gives simulate()'s numbers and keeps the invariants."""

from __future__ import annotations

import numpy as np
import pytest

import lamech
from lamech.numeric import compile_system, compiled_available, integrate_batch, simulate
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
@pytest.mark.skipif(not compiled_available(), reason="no C compiler or engine")
def test_compiled_batch_gives_the_same_numbers(chain3):
    jitted = compile_system(lamech.loads(chain_toml(3)), jit=True)
    Y0 = _starts(chain3, 4)
    a = integrate_batch(chain3, Y0, 1.0)
    b = integrate_batch(jitted, Y0, 1.0)
    assert (a.steps == b.steps).all()
    assert np.allclose(a.q, b.q, rtol=0, atol=1e-12)
    assert np.allclose(a.lambdas, b.lambdas, rtol=1e-10)
    # a batch of one runs in this thread: the same numbers
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


@pytest.mark.slow
@pytest.mark.shared_cache
@pytest.mark.skipif(not compiled_available(), reason="no C compiler or engine")
def test_an_array_the_compiled_solve_returns_stays_its_own():
    """The compiled Schur solve works in a space it makes, borrowed where a DOP853 trial
    lends it; the solution it returns to Python must keep its memory: later solves, which
    make and free spaces of the same size, do not change it."""
    ns = compile_system(lamech.load("cylinder"), jit=True)
    assert ns.mass_diagonal
    p = ns.parameter_vector()
    y = np.array([3.0, 0.01, 0.0, 0.0, 0.0, 0.0])[: 2 * ns.n]
    first = ns.accelerations(0.0, y, p)
    kept = first.copy()
    others = [ns.accelerations(0.0, y * (1.0 + 1e-2 * k), p) for k in range(1, 200)]
    assert np.array_equal(first, kept)
    assert not np.array_equal(others[-1], kept)  # the later solves differ: a real test
