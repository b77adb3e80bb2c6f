"""A two-link planar robot arm held on a trajectory by two drives (issue 47): each
motor's torque against the manipulator equation tau = M(q) q'' + C(q, q') q' + G(q),
written here by hand with NumPy (Spong, Hutchinson & Vidyasagar, "Robot Modeling and
Control", 2006, section 7.4) and evaluated along the prescribed motion
q1 = q10 + A1 sin(w1 t), q2 = q20 + A2 sin(w2 t)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

import lamech


@pytest.fixture(scope="module")
def arm():
    system = lamech.load("robot_arm")
    return system, {p.name: float(p.value) for p in system.parameters}


def _motion(p: dict, t):
    """q, q', q'' of both joints along the prescribed motion."""
    t = np.asarray(t, dtype=float)
    q = [p["q10"] + p["A1"] * np.sin(p["w1"] * t), p["q20"] + p["A2"] * np.sin(p["w2"] * t)]
    qd = [p["A1"] * p["w1"] * np.cos(p["w1"] * t), p["A2"] * p["w2"] * np.cos(p["w2"] * t)]
    qdd = [
        -p["A1"] * p["w1"] ** 2 * np.sin(p["w1"] * t),
        -p["A2"] * p["w2"] ** 2 * np.sin(p["w2"] * t),
    ]
    return q, qd, qdd


def _joint_torques(p: dict, t):
    """The manipulator equation for two uniform rods (centre of mass at l/2, inertia
    m l^2/12 about it), gravity along -y, q1 from the horizontal, q2 relative."""
    (q1, q2), (v1, v2), (a1, a2) = _motion(p, t)
    m1, m2, l1, l2, g = p["m1"], p["m2"], p["l1"], p["l2"], p["g"]
    c1, c2 = l1 / 2, l2 / 2
    i1, i2 = m1 * l1**2 / 12, m2 * l2**2 / 12
    m11 = i1 + i2 + m1 * c1**2 + m2 * (l1**2 + c2**2 + 2 * l1 * c2 * np.cos(q2))
    m12 = i2 + m2 * (c2**2 + l1 * c2 * np.cos(q2))
    m22 = i2 + m2 * c2**2
    h = m2 * l1 * c2 * np.sin(q2)
    g1 = (m1 * c1 + m2 * l1) * g * np.cos(q1) + m2 * c2 * g * np.cos(q1 + q2)
    g2 = m2 * c2 * g * np.cos(q1 + q2)
    tau1 = m11 * a1 + m12 * a2 - h * (2 * v1 * v2 + v2**2) + g1
    tau2 = m12 * a1 + m22 * a2 + h * v1**2 + g2
    return tau1, tau2


def test_the_parameters_are_in_si(arm):
    _, p = arm
    assert p["q10"] == pytest.approx(-math.pi / 6) and p["A1"] == pytest.approx(math.radians(40))
    assert p["l1"] == 0.5 and p["g"] == pytest.approx(9.81)


def test_solves_closed_form_torques_are_the_manipulator_equations(arm):
    system, p = arm
    sol = lamech.solve(system)
    rng = np.random.default_rng(47)
    ts = rng.uniform(0.0, 10.0, 25)
    hand = _joint_torques(p, ts)
    for name, truth in zip(("shoulder", "elbow"), hand):
        expr = sol.drives[name].expr
        t = next(s for s in expr.free_symbols if s.name == "t")
        values = {s: p[s.name] for s in expr.free_symbols if s.name in p}
        f = sp.lambdify(t, expr.subs(values), "numpy")
        got = np.array([float(f(x)) for x in ts])
        assert np.max(np.abs(got - truth)) <= 1e-12 * np.max(np.abs(truth))
    assert sol.units["lambda:shoulder"] == "N*m" and sol.units["lambda:elbow"] == "N*m"


def test_simulates_joint_torques_are_the_manipulator_equations(arm):
    system, p = arm
    period = 2 * math.pi  # w1 = 2, w2 = 3: both repeat after 2 pi
    traj = lamech.simulate(system, period, samples=2001)
    assert traj.status == "ok", traj.message
    q, _, _ = _motion(p, traj.t)
    assert np.allclose(traj.coordinate("q1"), q[0], atol=1e-9)
    hand = _joint_torques(p, traj.t)
    for name, truth in zip(("shoulder", "elbow"), hand):
        err = np.max(np.abs(traj.drive_forces[name] - truth))
        assert err <= 1e-9 * np.max(np.abs(truth)), (name, err)
    summary = lamech.to_json(traj)["drives"]
    for name, truth in zip(("shoulder", "elbow"), hand):
        d = summary[name]
        assert d["unit"] == "N*m" and d["power_unit"] == "W" and d["work_unit"] == "J"
        # the peak refined between the samples: at least the sampled one, and the hand
        # torque at its time is as large
        assert d["peak"] >= np.max(np.abs(truth)) - 1e-12
        at_t = np.abs(_joint_torques(p, d["at"]["t"])[0 if name == "shoulder" else 1])
        assert d["peak"] == pytest.approx(float(at_t), rel=1e-8)
    # over a whole period of the motion the arm's energy comes back (gravity is
    # conservative): what one motor puts in, the other takes out
    shoulder, elbow = summary["shoulder"]["mean_power"], summary["elbow"]["mean_power"]
    assert abs(shoulder) > 1e-3 and abs(shoulder + elbow) <= 1e-8 * abs(shoulder)
