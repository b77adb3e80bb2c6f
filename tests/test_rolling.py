"""Bodies rolling without slipping, and a body's angular velocity by name (issue 13,
item 1). Each against an independent truth: the rolling disc's accelerations against
SymPy's KanesMethod on the disc of its documentation (generalized speeds the angular
velocity in the lean frame, a different method and other coordinates); Chaplygin's
ball (``rolling_sphere``, an uneven ball rolling on a plane) simulated and held to its
conserved energy and angular momentum about the contact point, its contact point at
rest and Newton's law for its centre, all computed here from the Euler angles by hand
(not from lamech's angular velocity)."""

from __future__ import annotations

import math
import random

import numpy as np
import pytest
import sympy as sp
from sympy.physics.mechanics import (
    KanesMethod,
    Point,
    ReferenceFrame,
    RigidBody,
    dynamicsymbols,
    inertia,
)

import lamech
from lamech.problem import example_path

# The disc of tests/test_bodies3d.py, its rolling written with its angular velocity by
# name: the material point at the contact, P = c - r L_z (L_z = (sin(psi) sin(theta),
# -cos(psi) sin(theta), cos(theta)), from the contact up to the centre), is at rest:
# v_P = v_c + omega x (P - c) = 0, its x and y components.
ROLL_X = (  # v_c,x + (omega x (-r L_z))_x
    "x' + r*(psi'*cos(psi)*sin(theta) + theta'*sin(psi)*cos(theta))"
    " - r*(disc.wy*cos(theta) + disc.wz*cos(psi)*sin(theta))"
)
ROLL_Y = (
    "y' + r*(psi'*sin(psi)*sin(theta) - theta'*cos(psi)*cos(theta))"
    " + r*(disc.wx*cos(theta) - disc.wz*sin(psi)*sin(theta))"
)
DISC_BY_NAME = f"""
title = "Disc rolling on a plane, its rolling by its angular velocity"
[parameters]
m = 1.0
g = 9.81
r = 0.3
[coordinates]
x     = {{ initial = 0, velocity = "r*2" }}
y     = {{ initial = 0, velocity = 0 }}
psi   = {{ initial = 0, velocity = 0 }}
theta = {{ initial = 0.3, velocity = 0 }}
phi   = {{ initial = 0, velocity = 2 }}
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
velocity = "{ROLL_X}"
[[constraints]]
name = "roll_y"
velocity = "{ROLL_Y}"
"""


def _kane_disc():
    """SymPy's documented rolling disc (sympy.physics.mechanics, "A rolling disc, with
    Kane's method"): q1, q2, q3 yaw, lean, spin; u1, u2, u3 the angular velocity in the
    lean frame L; the contact point C at rest. Returns f(q, u, m, g, r) -> u'."""
    q1, q2, q3, u1, u2, u3 = dynamicsymbols("q1 q2 q3 u1 u2 u3")
    r, m, g = sp.symbols("r m g")
    N = ReferenceFrame("N")
    Y = N.orientnew("Y", "Axis", [q1, N.z])
    L = Y.orientnew("L", "Axis", [q2, Y.x])
    R = L.orientnew("R", "Axis", [q3, L.y])
    w_R_N_qd = R.ang_vel_in(N)
    R.set_ang_vel(N, u1 * L.x + u2 * L.y + u3 * L.z)
    C = Point("C")
    C.set_vel(N, 0)
    Dmc = C.locatenew("Dmc", r * L.z)
    Dmc.v2pt_theory(C, N, R)
    inertia_L = inertia(L, m / 4 * r**2, m / 2 * r**2, m / 4 * r**2)
    kd = [(R.ang_vel_in(N) - w_R_N_qd).dot(uv) for uv in L]
    disc = RigidBody("disc", Dmc, R, m, (inertia_L, Dmc))
    km = KanesMethod(N, q_ind=[q1, q2, q3], u_ind=[u1, u2, u3], kd_eqs=kd)
    km.kanes_equations([disc], [(Dmc, -m * g * Y.z)])
    args = [q1, q2, q3, u1, u2, u3, m, g, r]
    mass = sp.lambdify(args, km.mass_matrix)
    forcing = sp.lambdify(args, km.forcing.subs(km.kindiffdict()))

    def rates(q, u, m_, g_, r_):
        a = (*q, *u, m_, g_, r_)
        mm, f = np.array(mass(*a), dtype=float), np.array(forcing(*a), dtype=float)
        return np.linalg.solve(mm, f).ravel()

    return rates


@pytest.mark.slow
@pytest.mark.parametrize("case", ["rolling_disc", "by_name"])
def test_the_rolling_disc_accelerates_as_sympys_kanes_method_says(case):
    """At random states: u' from KanesMethod against lamech's q'' carried to the same
    speeds, u = (theta', psi' sin(theta) + phi', psi' cos(theta)) (the angular
    velocity in the lean frame), u' its time derivative."""
    system = lamech.load("rolling_disc") if case == "rolling_disc" else lamech.loads(DISC_BY_NAME)
    ns = lamech.compile_system(system)
    names = ns.coordinate_names
    kane = _kane_disc()
    rng = random.Random(13)
    for _ in range(12):
        p = {"m": rng.uniform(0.5, 2), "g": 9.81, "r": rng.uniform(0.1, 0.5)}
        pvec = ns.parameter_vector({k: v for k, v in p.items() if k in ns.parameter_names})
        psi, th, phi = rng.uniform(-3, 3), rng.uniform(-1.2, 1.2), rng.uniform(-3, 3)
        u = np.array([rng.uniform(-3, 3) for _ in range(3)])
        thd, psid = u[0], u[2] / math.cos(th)
        phid = u[1] - psid * math.sin(th)
        q = dict(x=0.3, y=-0.2, psi=psi, theta=th, phi=phi)
        qd = dict(
            x=p["r"] * math.cos(psi) * phid,
            y=p["r"] * math.sin(psi) * phid,
            psi=psid,
            theta=thd,
            phi=phid,
        )
        y = np.array([q[n] for n in names] + [qd[n] for n in names])
        acc = dict(zip(names, ns.accelerations(0.0, y, pvec)[: len(names)]))
        ours = np.array(
            [
                acc["theta"],
                acc["psi"] * math.sin(th) + psid * thd * math.cos(th) + acc["phi"],
                acc["psi"] * math.cos(th) - psid * thd * math.sin(th),
            ]
        )
        theirs = kane((psi, th, phi), u, p["m"], p["g"], p["r"])
        assert np.allclose(ours, theirs, rtol=1e-9, atol=1e-9 * (1 + np.abs(theirs).max()))


@pytest.mark.slow
def test_the_disc_rolling_by_its_angular_velocity_is_the_hand_written_rolling():
    """roll_x and roll_y written with disc.wx, disc.wy, disc.wz are the example's
    x' - r cos(psi) phi' and y' - r sin(psi) phi'."""
    system = lamech.loads(DISC_BY_NAME)
    S = system.symbols
    r, psi, phid = S["r"], S["psi"], S["phi'"]
    hand = [S["x'"] - r * sp.cos(psi) * phid, S["y'"] - r * sp.sin(psi) * phid]
    for c, h in zip(system.constraints, hand):
        assert sp.simplify(c.expr - h) == 0


def _turns(psi: float, theta: float, phi: float) -> np.ndarray:
    """Rz(psi) Rx(theta) Rz(phi): the ball's axes in the world frame."""

    def rz(a):
        return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])

    def rx(a):
        return np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])

    return rz(psi) @ rx(theta) @ rz(phi)


def _omega(q: dict, qd: dict) -> np.ndarray:
    """The world-frame angular velocity of z-x-z turns, by hand: psi' about z, theta'
    about the once-turned x axis, phi' about the body's z axis."""
    psi, th = q["psi"], q["theta"]
    return (
        qd["psi"] * np.array([0.0, 0.0, 1.0])
        + qd["theta"] * np.array([math.cos(psi), math.sin(psi), 0.0])
        + qd["phi"]
        * np.array([math.sin(psi) * math.sin(th), -math.cos(psi) * math.sin(th), math.cos(th)])
    )


TENSOR_ROWS = [
    ["0.0035", "0.0004", "-0.0002"],
    ["0.0004", "0.0042", "0.0003"],
    ["-0.0002", "0.0003", "0.0045"],
]
TENSOR = "[" + ", ".join("[" + ", ".join(f'"{x}"' for x in r) + "]" for r in TENSOR_ROWS) + "]"


def _sphere(case: str) -> lamech.System:
    if case == "principal":
        return lamech.load("rolling_sphere")
    path = example_path("rolling_sphere")
    text = path.read_text().replace('inertia = ["A", "B", "C"]', f"inertia = {TENSOR}")
    assert TENSOR in text
    return lamech.loads(text)


@pytest.mark.slow
@pytest.mark.parametrize("case", ["principal", "tensor"])
def test_chaplygins_ball_keeps_its_energy_and_contact_momentum_and_rolls(case):
    system = _sphere(case)
    pv = {str(k): float(v) for k, v in system.parameter_values.items()}
    m, g, R = pv["m"], pv["g"], pv["R"]
    if case == "principal":
        I_body = np.diag([pv["A"], pv["B"], pv["C"]])
    else:
        I_body = np.array([[float(x) for x in row] for row in TENSOR_ROWS])
    traj = lamech.simulate(system, 3.0, samples=3001, rtol=1e-11, atol=1e-12)
    assert traj.status == "ok", traj.message
    names = traj.coordinates
    energy, momentum, slip = [], [], []
    for qk, vk in zip(traj.q, traj.qd):
        q, qd = dict(zip(names, qk)), dict(zip(names, vk))
        w = _omega(q, qd)
        Rm = _turns(q["psi"], q["theta"], q["phi"])
        I_world = Rm @ I_body @ Rm.T
        v = np.array([qd["x"], qd["y"], qd["z"]])
        energy.append(m * v @ v / 2 + w @ I_world @ w / 2 + m * g * q["z"])
        momentum.append(I_world @ w + m * np.cross([0.0, 0.0, R], v))
        slip.append(v + np.cross(w, [0.0, 0.0, -R]))
    energy, momentum, slip = np.array(energy), np.array(momentum), np.array(slip)
    speed = np.max(np.abs(traj.qd[:, names.index("x")]))
    assert np.max(np.abs(slip)) < 1e-8 * speed  # the contact point at rest
    kinetic = energy - m * g * R
    assert np.ptp(energy) < 1e-8 * kinetic[0]
    assert np.max(np.linalg.norm(momentum - momentum[0], axis=1)) < 1e-8 * np.linalg.norm(
        momentum[0]
    )
    # it does move about: the momentum is conserved in a motion that turns the ball
    theta = traj.coordinate("theta")
    assert np.ptp(theta) > 0.2 and np.ptp(traj.velocity("y")) > 0.01

    # Newton on the centre: the floor's force (the three constraints' Cartesian forces at
    # the contact, by virtual work) is m a_c - m g, a_c from differences of the velocity
    F = np.array(
        [sum(traj.forces[f"{c}:{axis}"] for c in ("floor", "roll_x", "roll_y")) for axis in "xyz"]
    ).T
    dt = traj.t[1] - traj.t[0]
    a = np.array([np.gradient(traj.velocity(n), dt) for n in ("x", "y", "z")]).T
    newton = m * a + np.array([0.0, 0.0, m * g])
    inner = slice(2, -2)  # one-sided differences at the ends are first order
    friction = np.max(np.abs(newton[:, :2]))  # about 0.1 N
    assert np.max(np.abs(F[inner] - newton[inner])) < 1e-4 * friction
    assert np.allclose(traj.multiplier("floor"), m * g, rtol=1e-10)
    # each rolling constraint's force is along its own axis
    assert np.max(np.abs(traj.forces["roll_x:y"])) < 1e-10
    assert np.max(np.abs(traj.forces["roll_y:x"])) < 1e-10


@pytest.mark.slow
def test_the_angular_velocity_by_name_is_the_bodys_in_both_frames():
    """top.wx..wz and top.w1..w3 in a generalized force are R omega_body and Euler's
    kinematic equations for z-x-z turns (the heavy top)."""
    path = example_path("heavy_top")
    text = path.read_text() + (
        '\n[forces]\npsi = "top.wx + 2*top.wy + 3*top.wz"\nphi = "top.w1 + 2*top.w2 + 3*top.w3"\n'
    )
    system = lamech.loads(text)
    S = system.symbols
    psi, th, phi = S["psi"], S["theta"], S["phi"]
    psid, thd, phid = S["psi'"], S["theta'"], S["phi'"]
    body = sp.Matrix(
        [
            psid * sp.sin(th) * sp.sin(phi) + thd * sp.cos(phi),
            psid * sp.sin(th) * sp.cos(phi) - thd * sp.sin(phi),
            psid * sp.cos(th) + phid,
        ]
    )
    world = psid * sp.Matrix([0, 0, 1]) + thd * sp.Matrix([sp.cos(psi), sp.sin(psi), 0])
    world += phid * sp.Matrix([sp.sin(psi) * sp.sin(th), -sp.cos(psi) * sp.sin(th), sp.cos(th)])
    weights = sp.Matrix([1, 2, 3])
    Q = {c.name: f for c, f in zip(system.coordinates, system.forces)}
    assert sp.simplify(Q["psi"] - weights.dot(world)) == 0
    assert sp.simplify(Q["phi"] - weights.dot(body)) == 0
