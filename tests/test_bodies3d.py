"""Rigid bodies in space (issue 13, items 1 and 2): a body oriented by a sequence of
turns (or a rotation matrix) with its inertia in its own axes, T built from it, and the
partial velocities of its material points including omega x r. Each against an
independent truth: the textbook T of the heavy top and of the rolling disc (the bundled
example's hand-written T), the top's steady precession in a simulation, the torque-free
body's conserved energy and angular momentum (computed here from finite differences of
the rotation matrix, not from lamech's angular velocity) and the growth rate of a spin
about its intermediate axis, and finite differences of a material point's position."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

import lamech
from lamech.model._kinematics import angular_velocity, body_rotation, partial_velocities

DISC = """
title = "Disc rolling on a plane, described as a body"
[parameters]
m = 1.0
g = 9.81
r = 0.3
theta0 = 0.3
Omega = -2.0
w0 = "-5*Omega*sin(theta0)/6 - 2*g*tan(theta0)/(3*Omega*r)"
[coordinates]
x     = { initial = 0, velocity = "r*w0" }
y     = { initial = 0, velocity = 0 }
psi   = { initial = 0, velocity = "Omega" }
theta = { initial = "theta0", velocity = 0 }
phi   = { initial = 0, velocity = "w0" }
[[bodies]]
name = "disc"
mass = "m"
position = ["x + r*sin(psi)*sin(theta)", "y - r*cos(psi)*sin(theta)", "r*cos(theta)"]
rotation = ["z:psi", "x:theta", "y:phi"]
inertia = ["m*r^2/4", "m*r^2/2", "m*r^2/4"]
[gravity]
acceleration = "g"
[[constraints]]
name = "roll_x"
velocity = "x' - r*cos(psi)*phi'"
[[constraints]]
name = "roll_y"
velocity = "y' - r*sin(psi)*phi'"
"""


def _free_body(inertia: str, spin: float, wobble: float) -> str:
    """A torque-free body turning by body-fixed x-y-z turns (a, b, c), spinning at
    ``spin`` about its z axis, with a small angular velocity ``wobble`` about x."""
    return f"""
title = "torque-free body"
[parameters]
m = 1
[coordinates]
a = {{ initial = 0, velocity = {wobble} }}
b = {{ initial = 0, velocity = 0 }}
c = {{ initial = 0, velocity = {spin} }}
[[bodies]]
name = "brick"
mass = "m"
position = [0, 0, 0]
rotation = ["x:a", "y:b", "z:c"]
inertia = {inertia}
"""


def _same(a, b) -> bool:
    return sp.simplify(sp.expand(a - b)) == 0


@pytest.mark.slow
def test_the_rolling_disc_described_as_a_body_is_the_hand_derived_one():
    body = lamech.loads(DISC)
    hand = lamech.load("rolling_disc")
    names = {s: hand.symbols[str(s)] for s in body.T.free_symbols if str(s) in hand.symbols}
    assert _same(body.T.xreplace(names), hand.T)
    assert _same(body.V.xreplace(names), hand.V)
    lam = lamech.solve(body).initial_multipliers
    assert lam["roll_x"] == pytest.approx(0.0, abs=1e-12)
    assert lam["roll_y"] == pytest.approx(-1.96395503111, rel=1e-10)


@pytest.mark.slow
def test_the_heavy_tops_T_is_the_textbooks():
    system = lamech.load("heavy_top")
    S = system.symbols
    A, C, m, l, g = S["A"], S["C"], S["m"], S["l"], S["g"]
    th, psid, thd, phid = S["theta"], S["psi'"], S["theta'"], S["phi'"]
    textbook = (A + m * l**2) / 2 * (thd**2 + psid**2 * sp.sin(th) ** 2) + C / 2 * (
        phid + psid * sp.cos(th)
    ) ** 2
    assert _same(system.T, textbook)
    assert _same(system.V, m * g * l * sp.cos(th))
    # the body frame's angular velocity: Euler's kinematic equations for z-x-z
    w_world, w_body = angular_velocity(system, system.body("top"))
    phi, psi = S["phi"], S["psi"]
    euler = sp.Matrix(
        [
            psid * sp.sin(th) * sp.sin(phi) + thd * sp.cos(phi),
            psid * sp.sin(th) * sp.cos(phi) - thd * sp.sin(phi),
            psid * sp.cos(th) + phid,
        ]
    )
    assert all(_same(w_body[i], euler[i]) for i in range(3))
    R = body_rotation(system.body("top"))
    assert all(_same(x, y) for x, y in zip(R * w_body, w_world))
    assert _same((R.T * R)[0, 0], 1) and _same((R.T * R)[0, 1], 0)
    _ = psi


@pytest.mark.slow
def test_the_heavy_top_precesses_steadily_where_the_textbook_says():
    system = lamech.load("heavy_top")
    pv = {str(k): float(v) for k, v in system.parameter_values.items()}
    traj = lamech.simulate(system, 3.0, samples=301, rtol=1e-11, atol=1e-12)
    assert traj.status == "ok"
    theta = traj.coordinate("theta")
    assert np.max(np.abs(theta - pv["theta0"])) < 1e-7
    assert np.max(np.abs(traj.velocity("psi") - pv["Omega"])) < 1e-7
    assert abs(traj.energy_error) < 1e-9
    # the energy shell: theta'^2 as a function of theta has a double root at theta0
    sol = lamech.solve(system)
    assert sol.shell is not None and sol.shell.coordinate.name == "theta"
    f = sp.lambdify(system.symbols["theta"], sol.shell.speed_squared.subs(system.parameter_values))
    t0, h = pv["theta0"], 1e-4
    assert abs(f(t0)) < 1e-9
    # a double root: f ~ -k (theta - theta0)^2, the same a step either side
    assert abs(f(t0 + h) - f(t0 - h)) < 1e-2 * abs(f(t0 + h))
    assert f(t0 + 0.05) < 0 and f(t0 - 0.05) < 0  # a maximum: theta cannot leave theta0


def _rotation(a, b, c) -> np.ndarray:
    def rx(t):
        return np.array([[1, 0, 0], [0, math.cos(t), -math.sin(t)], [0, math.sin(t), math.cos(t)]])

    def ry(t):
        return np.array([[math.cos(t), 0, math.sin(t)], [0, 1, 0], [-math.sin(t), 0, math.cos(t)]])

    def rz(t):
        return np.array([[math.cos(t), -math.sin(t), 0], [math.sin(t), math.cos(t), 0], [0, 0, 1]])

    return rx(a) @ ry(b) @ rz(c)


def _body_rates(traj) -> tuple[np.ndarray, np.ndarray]:
    """(t, omega in the body frame) from central differences of R(t): independent of
    lamech's angular velocity."""
    Rs = [_rotation(*q) for q in traj.q]
    dt = traj.t[1] - traj.t[0]
    out = []
    for k in range(1, len(Rs) - 1):
        dR = (Rs[k + 1] - Rs[k - 1]) / (2 * dt)
        W = Rs[k].T @ dR
        out.append([W[2, 1], W[0, 2], W[1, 0]])
    return traj.t[1:-1], np.array(out)


@pytest.mark.parametrize("case", [pytest.param("major", marks=pytest.mark.slow), "intermediate"])
def test_a_torque_free_body_keeps_its_energy_and_angular_momentum(case):
    inertia = {"major": [1.0, 2.0, 3.0], "intermediate": [1.0, 3.0, 2.0]}[case]
    system = lamech.loads(_free_body(str([str(x) for x in inertia]), 1.0, 1e-4))
    traj = lamech.simulate(system, 10.0, samples=10001, rtol=1e-12, atol=1e-13)
    assert traj.status == "ok"
    t, w = _body_rates(traj)
    I = np.array(inertia)
    energy = 0.5 * np.sum(I * w**2, axis=1)
    L = np.array([_rotation(*q) @ (I * wk) for q, wk in zip(traj.q[1:-1], w)])
    assert np.ptp(energy) < 1e-6 * energy[0]
    assert np.max(np.linalg.norm(L - L[0], axis=1)) < 1e-5 * np.linalg.norm(L[0])
    wobble = np.hypot(w[:, 0], w[:, 1])  # the body rate off the spin axis
    if case == "major":
        assert wobble.max() < 3e-4  # a spin about the major axis stays put
    else:
        # about the intermediate axis a small wobble grows as exp(s t), s = Omega
        # sqrt((I3 - I1)(I2 - I3)/(I1 I2)) (Euler's equations linearised)
        s = math.sqrt((I[2] - I[0]) * (I[1] - I[2]) / (I[0] * I[1]))
        k4, k9 = np.searchsorted(t, 4.0), np.searchsorted(t, 9.0)
        rate = math.log(wobble[k9] / wobble[k4]) / (t[k9] - t[k4])
        assert rate == pytest.approx(s, rel=0.03)
        assert wobble[-1] > 100 * wobble[0]


@pytest.mark.slow
def test_partial_velocities_of_a_point_on_a_turning_body_include_omega_cross_r():
    """dr_P/dq of the material point at the top's rim, against finite differences of
    c(q) + R(q) p with p, the point in the body frame, held."""
    system = lamech.load("heavy_top")
    body = system.body("top")
    S = system.symbols
    pv = system.parameter_values
    R = body_rotation(body).subs(pv)
    c = sp.Matrix(body.position).subs(pv)
    q0 = {S["psi"]: 0.3, S["theta"]: 0.7, S["phi"]: -0.4}
    p_body = sp.Matrix([0.05, 0.0, 0.1])  # a point of the top, in its own axes
    point = (c + R * p_body).subs(q0)  # where that material point is now
    # the point as expressions of q: the partial velocities at q0
    rim = tuple(c + R * p_body)
    J = partial_velocities(system, body, rim).subs(pv).subs(q0)

    def where(qs):
        return np.array((c + R * p_body).subs(qs).evalf(), dtype=float).ravel()

    h = 1e-6
    for i, coord in enumerate(system.coordinates):
        up = dict(q0)
        dn = dict(q0)
        up[coord.symbol] += h
        dn[coord.symbol] -= h
        fd = (where(up) - where(dn)) / (2 * h)
        assert np.allclose(np.array(J[:, i].evalf(), dtype=float).ravel(), fd, atol=1e-8)
    assert point.shape == (3, 1)
