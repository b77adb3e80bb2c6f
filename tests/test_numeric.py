"""Generated dynamics: the NumPy and numba KKT kernels give the same numbers, and the
multiplier from the numeric KKT solve equals the closed form (pendulum tension)."""
import math

import numpy as np
import pytest

import lamech
from lamech.examples_gen import chain_toml
from lamech.numeric import compile_system, numba_available
from lamech.problem import loads


def _kkt(ns, q, v, p):
    """(q'', lambda) from the compiled dynamics with all constraints active (NumPy solve)."""
    M, rhs, A, gam, _mu = ns.dynamics(0.0, q, v, p)
    n, m = ns.n, A.shape[0]
    K = np.zeros((n + m, n + m))
    K[:n, :n], K[:n, n:], K[n:, :n] = M, -A.T, A
    sol = np.linalg.solve(K, np.concatenate((rhs, -gam)))
    return sol[:n], sol[n:]


def test_pendulum_tension_is_the_closed_form():
    ns = compile_system(lamech.load("pendulum"))
    p = ns.parameters
    m, g, l = (p[ns.parameter_names.index(k)] for k in ("m", "g", "l"))
    rng = np.random.default_rng(1)
    for _ in range(20):
        th, w = rng.uniform(-3, 3), rng.uniform(-5, 5)
        q = np.array([l, th]) if ns.coordinate_names[0] == "r" else np.array([th, l])
        v = np.array([0.0, w]) if ns.coordinate_names[0] == "r" else np.array([w, 0.0])
        acc, lam = _kkt(ns, q, v, p)
        tension = m * l * w**2 + m * g * math.cos(th)
        assert abs(lam[0] - tension) <= 1e-12 * max(1.0, abs(tension))
        ith = ns.coordinate_names.index("theta")
        assert abs(acc[ith] + g / l * math.sin(th)) <= 1e-12 * g / l


@pytest.mark.slow
@pytest.mark.skipif(not numba_available(), reason="numba not installed")
@pytest.mark.parametrize("n", [2, 8])
def test_numba_kernel_matches_numpy(n):
    system = loads(chain_toml(n, keep=True))
    a = compile_system(system)
    b = compile_system(system, jit=True)
    assert b.jit and not a.jit
    rng = np.random.default_rng(n)
    rows = np.arange(a.m, dtype=np.int64)
    e = np.zeros(0, dtype=np.int64)
    for _ in range(20):
        y = rng.normal(size=2 * a.n)
        ya = a.rhs_kernel(0.0, y, a.parameters, rows, e, e, np.zeros(0))
        yb = b.rhs_kernel(0.0, y, b.parameters, rows, e, e, np.zeros(0))
        assert np.all(np.abs(ya - yb) <= 1e-12 * np.maximum(1.0, np.abs(ya)))
