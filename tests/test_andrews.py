"""Andrews' squeezing mechanism (lamech/examples/andrews_squeezer.toml): a 7-body,
3-loop planar mechanism with 6 constraints and a driving torque, the multibody benchmark
of Hairer & Wanner (Solving ODEs II, sec. VII.7) and of the Bari/CWI IVP test set.

Checked against (1) the test set's published reference solution at t = 0.03 s,
(2) the book's hand-written M(q), f(q, q'), G(q), g(q) (cross-implementation: lamech
derives them from T, V and the constraints), and (3) invariants: constraint residual and
the energy balance E(t) - E(0) = mom (beta(t) - beta(0)) (the spring is in V).
"""

from __future__ import annotations

import numpy as np
import pytest

import lamech
from lamech.numeric import compile_system, simulate

# Bari/CWI test set, problem "andrews", reference solution at t = 0.03 (PSIDE, tol 1e-14)
Q_REF = np.array(
    [
        0.1581077119629904e2,
        -0.1575637105984298e2,
        0.4082224013073101e-1,
        -0.5347301163226948e0,
        0.5244099658805304e0,
        0.5347301163226948e0,
        0.1048080741042263e1,
    ]
)
V_REF = np.array(
    [
        0.1139920302151208e4,
        -0.1424379294994111e4,
        0.1103291221937134e2,
        0.1929337464421385e2,
        0.5735699284790808e0,
        -0.1929337464421385e2,
        0.3231791658026955e0,
    ]
)
# the test set writes M q'' = f - G^T lambda; lamech M q'' + h = A^T lambda + Q: opposite
LAM_REF = -np.array(
    [
        0.1991753333731910e3,
        -0.2975531228015052e2,
        0.2306654119098399e2,
        0.3145271365475927e2,
        0.2264249232082739e2,
        0.1161740700019673e2,
    ]
)

P = dict(
    m1=0.04325,
    m2=0.00365,
    m3=0.02373,
    m4=0.00706,
    m5=0.07050,
    m6=0.00706,
    m7=0.05498,
    I1=2.194e-6,
    I2=4.410e-7,
    I3=5.255e-6,
    I4=5.667e-7,
    I5=1.169e-5,
    I6=5.667e-7,
    I7=1.912e-5,
    xa=-0.06934,
    ya=-0.00227,
    xb=-0.03635,
    yb=0.03273,
    xc=0.014,
    yc=0.072,
    d=28e-3,
    da=115e-4,
    e=2e-2,
    ea=1421e-5,
    rr=7e-3,
    ra=92e-5,
    ss=35e-3,
    sa=1874e-5,
    sb=1043e-5,
    sc=18e-3,
    sd=2e-2,
    ta=2308e-5,
    tb=916e-5,
    u=4e-2,
    ua=1228e-5,
    ub=449e-5,
    zf=2e-2,
    zt=4e-2,
    fa=1421e-5,
    mom=33e-3,
    c0=4530.0,
    l0=7785e-5,
)


def book_model(q, v):
    """The book's M (7x7), f (7,), G = dg/dq (6x7), g (6,), written from its formulas."""
    p = type("P", (), P)
    be, th, ga, ph, de, om, ep = q
    bep, thp, _, php, dep, omp, epp = v
    s, c = np.sin, np.cos
    ee, zz = p.e - p.ea, p.zf - p.fa
    M = np.zeros((7, 7))
    M[0, 0] = p.m1 * p.ra**2 + p.m2 * (p.rr**2 - 2 * p.da * p.rr * c(th) + p.da**2) + p.I1 + p.I2
    M[1, 0] = M[0, 1] = p.m2 * (p.da**2 - p.da * p.rr * c(th)) + p.I2
    M[1, 1] = p.m2 * p.da**2 + p.I2
    M[2, 2] = p.m3 * (p.sa**2 + p.sb**2) + p.I3
    M[3, 3] = p.m4 * ee**2 + p.I4
    M[4, 3] = M[3, 4] = p.m4 * (ee**2 + p.zt * ee * s(ph)) + p.I4
    M[4, 4] = (
        p.m4 * (p.zt**2 + 2 * p.zt * ee * s(ph) + ee**2) + p.m5 * (p.ta**2 + p.tb**2) + p.I4 + p.I5
    )
    M[5, 5] = p.m6 * zz**2 + p.I6
    M[6, 5] = M[5, 6] = p.m6 * (zz**2 - p.u * zz * s(om)) + p.I6
    M[6, 6] = (
        p.m6 * (zz**2 - 2 * p.u * zz * s(om) + p.u**2) + p.m7 * (p.ua**2 + p.ub**2) + p.I6 + p.I7
    )
    xd = p.sd * c(ga) + p.sc * s(ga) + p.xb
    yd = p.sd * s(ga) - p.sc * c(ga) + p.yb
    L = np.hypot(xd - p.xc, yd - p.yc)
    k = -p.c0 * (L - p.l0) / L
    f = np.array(
        [
            p.mom - p.m2 * p.da * p.rr * thp * (thp + 2 * bep) * s(th),
            p.m2 * p.da * p.rr * bep**2 * s(th),
            k * (xd - p.xc) * (p.sc * c(ga) - p.sd * s(ga))
            + k * (yd - p.yc) * (p.sd * c(ga) + p.sc * s(ga)),
            p.m4 * p.zt * ee * dep**2 * c(ph),
            -p.m4 * p.zt * ee * php * (php + 2 * dep) * c(ph),
            -p.m6 * p.u * zz * epp**2 * c(om),
            p.m6 * p.u * zz * omp * (omp + 2 * epp) * c(om),
        ]
    )
    crank_x = [-p.rr * s(be) + p.d * s(be + th), p.d * s(be + th)]
    crank_y = [p.rr * c(be) - p.d * c(be + th), -p.d * c(be + th)]
    G = np.zeros((6, 7))
    G[0::2, :2] = crank_x
    G[1::2, :2] = crank_y
    G[0, 2], G[1, 2] = -p.ss * c(ga), -p.ss * s(ga)
    G[2, 3], G[2, 4] = -p.e * c(ph + de), -p.e * c(ph + de) + p.zt * s(de)
    G[3, 3], G[3, 4] = -p.e * s(ph + de), -p.e * s(ph + de) - p.zt * c(de)
    G[4, 5], G[4, 6] = p.zf * s(om + ep), p.zf * s(om + ep) - p.u * c(ep)
    G[5, 5], G[5, 6] = -p.zf * c(om + ep), -p.zf * c(om + ep) - p.u * s(ep)
    cx = p.rr * c(be) - p.d * c(be + th)
    cy = p.rr * s(be) - p.d * s(be + th)
    g = np.array(
        [
            cx - p.ss * s(ga) - p.xb,
            cy + p.ss * c(ga) - p.yb,
            cx - p.e * s(ph + de) - p.zt * c(de) - p.xa,
            cy + p.e * c(ph + de) - p.zt * s(de) - p.ya,
            cx - p.zf * c(om + ep) - p.u * s(ep) - p.xa,
            cy - p.zf * s(om + ep) + p.u * c(ep) - p.ya,
        ]
    )
    return M, f, G, g


@pytest.fixture(scope="module")
def squeezer():
    return compile_system(lamech.load("andrews_squeezer"))


def test_derived_model_equals_the_books(squeezer):
    ns = squeezer
    assert (ns.n, ns.m) == (7, 6)
    rng = np.random.default_rng(7)
    for _ in range(5):
        q = rng.uniform(-3, 3, 7)
        v = rng.uniform(-50, 50, 7)
        M, rhs, A, gam, _ = ns.dynamics(0.0, q, v, ns.parameters)
        f, A2, b = ns.constraints(0.0, q, ns.parameters)
        Mb, fb, Gb, gb = book_model(q, v)
        assert np.allclose(M, Mb, rtol=1e-13, atol=1e-19)
        assert np.allclose(rhs, fb, rtol=1e-12, atol=1e-12 * np.max(np.abs(fb)))
        assert np.allclose(A, Gb, rtol=1e-13, atol=1e-16) and np.array_equal(A, A2)
        assert np.allclose(f, gb, rtol=1e-13, atol=1e-16)
        # gamma = d/dt (G v) at q'' = 0, checked by a finite difference along the motion
        h = 1e-7
        Gp = book_model(q + h * v, v)[2]
        Gm = book_model(q - h * v, v)[2]
        assert np.allclose(gam, (Gp - Gm) @ v / (2 * h), rtol=1e-6, atol=1e-6 * np.max(np.abs(gam)))
    q0, v0 = ns.initial_state()
    assert np.max(np.abs(book_model(q0, v0)[3])) < 1e-15  # consistent start


@pytest.mark.slow
def test_reference_solution_at_30_ms(squeezer):
    tr = simulate(squeezer, 0.03, samples=301)
    assert tr.status == "ok", tr.message
    # measured: angles 1.4e-9 (abs), velocities 5e-8 and multipliers 1.3e-6 (relative),
    # the same with DOP853 at 1e-13 and Radau: the rest is the reference's own error
    assert np.max(np.abs(tr.final_q - Q_REF)) < 1e-8
    assert np.max(np.abs(tr.final_qd - V_REF) / np.abs(V_REF)) < 1e-6
    assert np.max(np.abs(tr.lambdas[-1] - LAM_REF) / np.abs(LAM_REF)) < 1e-5
    # invariants along the way: on the manifold, and energy balance with the torque's work
    assert np.max(tr.residual) < 1e-9
    beta = tr.coordinate("beta")
    work = P["mom"] * (beta - beta[0])
    assert np.max(np.abs(tr.energy - tr.energy[0] - work)) < 1e-9 * np.max(np.abs(work))
