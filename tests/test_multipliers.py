"""``lamech.multipliers``: every lambda in closed form, raw, for every bundled problem.

The raw closed forms (no elimination, no simplification; the KKT system solved by its
block structure, see ``lamech/symbolic/_multipliers.py``) against the KKT system solved
numerically at seeded random states, which is the definition of the multipliers: the
problems with a singular mass matrix (massless pulleys: the M + A^T A path), the ones
whose contacts are open at the start (left out, as ``lamech.solve`` leaves them), and
the Andrews squeezer (seven bodies, six constraints). Against SymPy and the tidy
``Solution.multipliers``: tests/test_closed_forms.py.
"""

from __future__ import annotations

import mpmath
import numpy as np
import pytest
import sympy as sp

import lamech
from lamech.model._checks import holding_at_start, probe_states
from lamech.symbolic import DegenerateConstraintsError, dynamics, multipliers
from lamech.symbolic._derive import kkt_numeric
from lamech.symbolic._selfcheck import manifold_states


def at(expr: sp.Expr, env: dict) -> complex:
    """``expr`` at ``env`` with 30 digits, each shared subexpression once: the raw closed
    forms share their factors, and written out as a tree (what ``xreplace``, ``evalf``
    and ``lambdify`` walk) the Andrews squeezer's run to millions of operations."""
    memo: dict = {}
    funcs = {sp.sin: mpmath.sin, sp.cos: mpmath.cos, sp.tan: mpmath.tan, sp.exp: mpmath.exp}

    def ev(e):
        if e in memo:
            return memo[e]
        if e.is_Symbol:
            r = mpmath.mpf(env[e])
        elif e.is_Rational:
            r = mpmath.mpf(e.p) / e.q
        elif e.is_Number:
            r = mpmath.mpf(float(e))
        elif e.is_Add:
            r = mpmath.fsum(ev(a) for a in e.args)
        elif e.is_Mul:
            r = mpmath.fprod(ev(a) for a in e.args)
        elif e.is_Pow:
            r = ev(e.base) ** ev(e.exp)
        else:
            r = funcs[e.func](*(ev(a) for a in e.args))
        memo[e] = r
        return r

    with mpmath.workdps(30):
        return complex(ev(sp.sympify(expr)))


# the cases of 2 s or more: left out of the default set
SLOW = {
    "andrews_squeezer",
    "heavy_top",
    "rolling_sphere",
}
assert SLOW <= set(lamech.example_names()), SLOW - set(lamech.example_names())


@pytest.mark.parametrize(
    "name",
    [pytest.param(n, marks=pytest.mark.slow) if n in SLOW else n for n in lamech.example_names()],
)
def test_raw_multipliers_solve_the_kkt_system(name):
    system = lamech.load(name)
    holding = holding_at_start(system)
    lam = lamech.multipliers(system)
    assert list(lam) == [c.name for c in holding.constraints]
    dyn = dynamics(holding)
    # on the constraint manifold, where the multipliers are reduced modulo the constraints
    # (a mechanism the drives leave no freedom, the slider-crank, has no other states)
    for state in manifold_states(dyn, count=2, seed=3):
        env = {**system.parameter_values, **state}
        _, expected = kkt_numeric(dyn, env)
        for c, want in zip(holding.constraints, expected):
            got = at(lam[c.name], env)
            assert abs(got.imag) < 1e-12
            assert got.real == pytest.approx(want, rel=1e-9, abs=1e-9), (name, c.name)


@pytest.mark.slow
def test_a_singular_mass_matrix_takes_the_augmented_path():
    """The double Atwood machine's massless pulley: M is singular, the KKT matrix is
    not; the multipliers are the tidy ones of ``lamech.solve`` at random states."""
    system = lamech.load("double_atwood")
    dyn = dynamics(holding_at_start(system))
    n = len(system.q)
    M = np.array(dyn.M.xreplace(system.parameter_values).evalf(), dtype=float).reshape(n, n)
    assert np.linalg.matrix_rank(M) < n
    raw = lamech.multipliers(system)
    tidy = lamech.solve(system).multipliers
    assert set(raw) == set(tidy)
    for env in probe_states(system, count=2, seed=5):
        for k in raw:
            assert at(raw[k], env).real == pytest.approx(at(tidy[k], env).real, rel=1e-9)


def test_dependent_constraints_are_refused():
    """Every constraint of a Dynamics is taken as holding: the Atwood machine's string
    and both stops on its two coordinates are dependent."""
    with pytest.raises(DegenerateConstraintsError, match="dependent"):
        multipliers(dynamics(lamech.load("atwood")))


@pytest.mark.slow
def test_no_constraints_no_multipliers():
    assert lamech.multipliers(lamech.load("heavy_top")) == {}


@pytest.mark.parametrize("name", ["pendulum", "knife_edge"])
def test_the_benchmark_times_what_sympy_computes(name):
    """B5's lamech column (``lamech_b5_fast``) and its SymPy peer give the same
    multipliers at the initial state (the benchmark checks that too, before a time
    counts), and the whole report's agree with them."""
    from bench.run import lamech_b5_fast, lamech_b5_full, sympy_b5_timed

    system = lamech.load(name)
    fast, wall, cpu = lamech_b5_fast(system)
    theirs = sympy_b5_timed(system)[0]
    full = lamech_b5_full(name)[0]
    assert wall > 0 and cpu > 0
    assert set(fast) == set(theirs) == set(full) == {c.name for c in system.constraints}
    for k, v in fast.items():
        assert abs(v) > 0.1
        assert v == pytest.approx(theirs[k], rel=1e-10)
        assert v == pytest.approx(full[k], rel=1e-10)
