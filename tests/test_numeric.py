"""Generated dynamics: the NumPy and C KKT kernels give the same numbers, and the
multiplier from the numeric KKT solve equals the closed form (pendulum tension)."""

import math

import numpy as np
import pytest

import lamech
from lamech.model._checks import holding_at_start
from lamech.numeric import compile_system, compiled_available
from lamech.problem import chain_toml, loads


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
@pytest.mark.shared_cache
@pytest.mark.skipif(not compiled_available(), reason="no C compiler or engine")
@pytest.mark.parametrize("n", [2, 8])
def test_c_kernel_matches_numpy(n):
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


_MASSLESS = """
title = "mass on a massless slider"
[parameters]
m = 2.0
g = 9.81
[coordinates]
x = { initial = 0, velocity = 1 }
s = { initial = 0, velocity = 1 }
[lagrangian]
T = "m/2*x'^2"
V = "m*g*x"
[[constraints]]
name = "link"
f = "x - s"
"""


def _same(a, b, tol=1e-11):
    """Equal to tol relative to the largest entry (a linear solve is accurate in norm, not
    entry by entry); NaN in both (a singular mode) counts as equal."""
    both = np.isnan(a) & np.isnan(b)
    close = np.abs(a - b) <= tol * max(1.0, np.nanmax(np.abs(a), initial=0.0))
    return bool(np.all(both | close))


def _dense_mode(ns, y, mode):
    """y' from the full (n + m)-square KKT matrix of a mode, written out here as the
    reference for both compiled solves (NaN where singular)."""
    rows, slip_j, slip_k, slip_c = mode
    n = ns.n
    M, rhs, A, gam, mu = ns.dynamics(0.0, y[:n], y[n:], ns.parameters)
    na = len(rows)
    K = np.zeros((n + na, n + na))
    K[:n, :n], K[:n, n:], K[n:, :n] = M, -A[rows].T, A[rows]
    for j, k, c in zip(slip_j, slip_k, slip_c):
        K[:n, n + k] += mu[j] * c * A[j]
    try:
        acc = np.linalg.solve(K, np.concatenate((rhs, -gam[rows])))[:n]
    except np.linalg.LinAlgError:
        acc = np.full(n, np.nan)
    return np.concatenate((y[n:], acc))


def _modes(ns):
    """Active-row sets to try: all, each single row dropped, none, and for each friction
    constraint its slipping mode (friction row out, kinetic friction on its normal)."""
    m = ns.m
    rows = np.arange(m, dtype=np.int64)
    e = np.zeros(0, dtype=np.int64)
    modes = [(rows, e, e, np.zeros(0)), (rows[:0], e, e, np.zeros(0))]
    modes += [(np.delete(rows, k), e, e, np.zeros(0)) for k in range(m)]
    for j, c in enumerate(ns.system.constraints):
        if c.friction is not None:
            k = ns.constraint_names.index(c.friction.normal)
            active = np.array([r for r in rows if r != j], dtype=np.int64)
            pos = int(np.flatnonzero(active == k)[0])
            for sign in (1.0, -1.0):
                modes.append((active, np.array([j]), np.array([pos]), np.array([sign])))
    return modes


@pytest.mark.slow
@pytest.mark.shared_cache
@pytest.mark.skipif(not compiled_available(), reason="no C compiler or engine")
@pytest.mark.parametrize(
    "name",
    [
        "cylinder",
        "pendulum",
        "atwood",
        "double_atwood",
        "incline_disk",
        "knife_edge",
        "ladder",
        "andrews_squeezer",
        "chain3",
        "massless",
    ],
)
def test_structured_kkt_solve_matches_dense(name):
    """Both solves (C: Schur complement over A's nonzeros with Cholesky or elimination
    when M is diagonal; NumPy: the Schur complement with LAPACK; each falling back to the
    full KKT matrix where an M_ii is zero) equal the full KKT solve in every mode: all
    rows, rows dropped, none, and slipping friction."""
    if name == "chain3":
        system = loads(chain_toml(3, keep=True))
    elif name == "massless":
        system = loads(_MASSLESS)
    else:
        # the stops of the Atwood machines (open at the start) can never all close with
        # the strings: "all rows" is a mode of the constraints that hold at the start
        system = holding_at_start(lamech.load(name))
    a = compile_system(system)
    b = compile_system(system, jit=True)
    assert b.jit
    if name in ("cylinder", "chain3", "massless", "atwood"):
        assert b.mass_diagonal  # these exercise the Schur path (massless: its fallback)
    rng = np.random.default_rng(7)
    q0, _ = a.initial_state()
    for _ in range(10):
        y = np.concatenate((q0 + 0.1 * rng.normal(size=a.n), rng.normal(size=a.n)))
        for mode in _modes(a):
            ref = _dense_mode(a, y, mode)
            ya = a.rhs_kernel(0.0, y, a.parameters, *mode)
            yb = b.rhs_kernel(0.0, y, b.parameters, *mode)
            assert _same(ref, ya) and _same(ref, yb), mode
        sa = a.accelerations(0.0, y, a.parameters)
        sb = b.accelerations(0.0, y, b.parameters)
        assert _same(sa, sb)
    if name == "massless":
        acc = b.accelerations(0.0, np.array([0.1, 0.1, 1.0, 1.0]), b.parameters)
        assert np.allclose(acc, [-9.81, -9.81, 0.0], atol=1e-14)


@pytest.mark.skipif(not compiled_available(), reason="no C compiler or engine")
def test_gauss_elimination_banded_and_pivoting():
    """The hand-written elimination: a random dense system, a tridiagonal one (the band
    shortcut), one that needs row swaps, and a singular one (NaN)."""
    from lamech.linalg import gauss_inplace

    rng = np.random.default_rng(3)
    for K in (
        rng.normal(size=(9, 9)),
        np.diag(rng.uniform(1, 2, 12))
        + np.diag(rng.normal(size=11), 1)
        + np.diag(rng.normal(size=11), -1),
        np.array([[0.0, 1.0, 2.0], [1.0, 0.0, 0.0], [3.0, 1.0, 0.0]]),
    ):
        x = rng.normal(size=K.shape[0])
        got = x.copy()
        gauss_inplace(K.copy(), got)
        assert np.allclose(got, np.linalg.solve(K, x), rtol=1e-12, atol=1e-12)
    x = np.ones(2)
    gauss_inplace(np.array([[1.0, 2.0], [2.0, 4.0]]), x)
    assert np.all(np.isnan(x))


def test_cholesky_envelope_solve():
    """The envelope Cholesky used for A M^-1 A^T: SPD dense and banded systems (a chain's
    tridiagonal one, an arrow-shaped one with a late envelope), and False where K is not
    positive definite (singular, indefinite)."""
    from lamech.linalg import cholesky_inplace

    rng = np.random.default_rng(5)
    B = rng.normal(size=(7, 7))
    tri = np.diag(np.full(10, 2.0)) - np.diag(np.ones(9), 1) - np.diag(np.ones(9), -1)
    arrow = np.eye(6) * 4.0
    arrow[5, :5] = arrow[:5, 5] = 1.0
    for K in (B @ B.T + 0.1 * np.eye(7), tri, arrow):
        x = rng.normal(size=K.shape[0])
        got = x.copy()
        assert cholesky_inplace(K.copy(), got)
        assert np.allclose(got, np.linalg.solve(K, x), rtol=1e-12, atol=1e-12)
    for K in (np.array([[1.0, 2.0], [2.0, 4.0]]), np.array([[1.0, 2.0], [2.0, 1.0]])):
        assert not cholesky_inplace(K.copy(), np.ones(2))


def test_numpy_schur_solve_matches_full_kkt():
    """NumPy's Schur-complement path (taken for a diagonal M above 32 unknowns) equals the
    full KKT solve: all rows, a slipping row folded into its normal, no rows; and a zero
    M_ii sends it to the full matrix."""
    from lamech.numeric._kkt import kkt_solve_numpy

    rng = np.random.default_rng(11)
    n, m = 30, 10
    M = np.diag(rng.uniform(0.5, 2.0, n))
    A = rng.normal(size=(m, n)) * (rng.uniform(size=(m, n)) < 0.3)
    A[np.arange(m), np.arange(m)] = 1.0  # independent rows
    rhs, gam, mu = rng.normal(size=n), rng.normal(size=m), np.full(m, 0.4)
    e = np.zeros(0, dtype=np.int64)
    schur, full = kkt_solve_numpy(True), kkt_solve_numpy(False)
    rows = np.arange(m, dtype=np.int64)
    modes = [
        (rows, e, e, np.zeros(0)),
        (rows[1:], np.array([0]), np.array([2]), np.array([-1.0])),
        (rows[:0], e, e, np.zeros(0)),
    ]
    for mode in modes:
        a = schur(M, rhs, A, gam, mu, *mode)
        b = full(M, rhs, A, gam, mu, *mode)
        assert a.shape == b.shape == (n + len(mode[0]),)
        assert np.allclose(a, b, rtol=1e-10, atol=1e-12)
    M[3, 3] = 0.0  # massless: the full matrix decides
    a = schur(M, rhs, A, gam, mu, *modes[0])
    assert np.allclose(a, full(M, rhs, A, gam, mu, *modes[0]), rtol=1e-10, atol=1e-12)
