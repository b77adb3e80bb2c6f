"""Loads as the user thinks of them (issue 13, item 3): a force at a material point, a
torque on a body, a spring and a damper between two points, turned into generalized
forces by virtual work (the partial velocities of the point, the partial angular
velocities of the body) and shown in the equations. Each against the generalized force
written by hand, or a closed-form motion."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

import lamech

PENDULUM = """
title = "pendulum pushed sideways"
[parameters]
m = 1
g = 9.81
l = 1
F = 2
[coordinates]
r     = { initial = "l", velocity = 0 }
theta = { initial = 0.2, velocity = 0 }
[[constraints]]
name = "rod"
f = "l - r"
[[bodies]]
name = "bob"
mass = "m"
position = ["r*sin(theta)", "-r*cos(theta)"]
[gravity]
acceleration = "g"
[[loads]]
name = "push"
body = "bob"
force = ["F", 0]
"""


def _same(a, b) -> bool:
    return sp.simplify(sp.expand(a - b)) == 0


@pytest.mark.slow
def test_a_force_at_a_point_is_F_dot_the_partial_velocity():
    system = lamech.loads(PENDULUM)
    S = system.symbols
    F, r, th = S["F"], S["r"], S["theta"]
    assert _same(system.forces[0], F * sp.sin(th))  # Q_r
    assert _same(system.forces[1], F * r * sp.cos(th))  # Q_theta
    # it shows in the equations, and the pendulum hangs at tan(theta) = F/(m g)
    sol = lamech.solve(system)
    assert any(e.has(F) for e in sol.equations)
    (eq,) = [e for e in lamech.modes(sol).equilibria if e.stability == "stable"]
    assert math.tan(eq.values["theta"]) == pytest.approx(2 / 9.81, rel=1e-9)
    assert math.cos(eq.values["theta"]) > 0


def test_a_force_in_the_body_frame_turns_with_the_body():
    text = """
title = "a disc spun by a tangential push"
[parameters]
m = 2
R = 0.5
P = 3
[coordinates]
phi = { initial = 0, velocity = 0 }
[[bodies]]
name = "disc"
mass = "m"
position = [0, 0]
angle = "phi"
inertia = "m*R^2/2"
[[loads]]
name = "push"
body = "disc"
at = ["R*cos(phi)", "R*sin(phi)"]
force = [0, "P"]
frame = "body"
"""
    system = lamech.loads(text)
    # the body-frame y push at the body-frame x point is always tangential: Q = P R
    assert _same(system.forces[0], system.symbols["P"] * system.symbols["R"])
    traj = lamech.simulate(system, 1.0, samples=11)
    alpha = 3 * 0.5 / (2 * 0.5**2 / 2)
    assert traj.coordinate("phi")[-1] == pytest.approx(alpha / 2, rel=1e-9)


@pytest.mark.slow
def test_a_torque_on_a_body_in_space_uses_its_partial_angular_velocities():
    text = (
        open(lamech.problem.example_path("heavy_top")).read()
        + """
[[loads]]
name = "motor"
body = "top"
torque = [0, 0, "tau"]
frame = "body"
"""
    )
    text = text.replace("[parameters]\n", "[parameters]\ntau = 0.01\n", 1)
    system = lamech.loads(text)
    S = system.symbols
    tau, th = S["tau"], S["theta"]
    Q = dict(zip([c.name for c in system.coordinates], system.forces))
    assert _same(Q["psi"], tau * sp.cos(th))
    assert _same(Q["theta"], 0)
    assert _same(Q["phi"], tau)


def test_a_spring_and_a_damper_between_two_points():
    text = """
title = "mass on a damped spring"
[parameters]
m = 2
k = 8
c = 0.4
[coordinates]
x = { initial = 0.1, velocity = 0 }
[[bodies]]
name = "mass"
mass = "m"
position = ["x", 0]
[[loads]]
name = "spring"
spring = { from = [0, 0], to = ["x", 0], k = "k", damping = "c" }
"""
    system = lamech.loads(text)
    S = system.symbols
    assert _same(system.V, S["k"] * S["x"] ** 2 / 2)
    assert _same(system.forces[0], -S["c"] * S["x'"])
    traj = lamech.simulate(system, 3.0, samples=301, rtol=1e-11, atol=1e-12)
    # the damped oscillator: x = A e^(-z t) cos(w t) + B e^(-z t) sin(w t)
    z = 0.4 / (2 * 2)
    w = math.sqrt(8 / 2 - z**2)
    t = traj.t
    exact = 0.1 * np.exp(-z * t) * (np.cos(w * t) + z / w * np.sin(w * t))
    assert np.max(np.abs(traj.coordinate("x") - exact)) < 1e-8


@pytest.mark.slow
def test_a_spring_with_a_natural_length_in_the_plane():
    text = PENDULUM.replace('f = "l - r"', 'f = "l - r"\nunilateral = true').split("[[loads]]")[0]
    text += """
[[loads]]
name = "spring"
spring = { from = [0, 0], to = ["r*sin(theta)", "-r*cos(theta)"], k = "F", length = "l/2" }
"""
    system = lamech.loads(text)
    S = system.symbols
    r, l, F = S["r"], S["l"], S["F"]
    spring = F * (r - l / 2) ** 2 / 2
    extra = system.V - (-S["m"] * S["g"] * r * sp.cos(S["theta"]))
    for rv, tv in ((0.7, 0.3), (1.3, -2.0)):  # r > 0: |r| = r
        at = {r: rv, S["theta"]: tv, F: 2, l: 1}
        assert float(extra.subs(at)) == pytest.approx(float(spring.subs(at)), rel=1e-12)
    # at rest the stretched spring pulls the bob in by F (l - l/2): the rod's tension,
    # m g cos(theta) along the rod, is that much less
    lam = lamech.solve(system).initial_multipliers["rod"]
    assert lam == pytest.approx(9.81 * math.cos(0.2) - 2 * 0.5, rel=1e-9)


SLIDER = """
title = "Slider on a rail, a spring and a push"
[parameters]
m = 1.0
g = 9.81
k = 5.0
h = 0.5
F = 2.0
P = 1.0
[coordinates]
x = { initial = 0.3, velocity = 0 }
y = { initial = 0, velocity = 0 }
[[constraints]]
name = "rail"
f = "y"
[[bodies]]
name = "slider"
mass = "m"
position = ["x", "y"]
[gravity]
acceleration = "g"
[[loads]]
name = "spring"
spring = { from = [0, "h"], to = ["x", "y"], k = "k" }
[[loads]]
name = "push"
body = "slider"
force = ["F", "-P"]
"""

WHEEL = """
title = "Wheel on a track: L given, a motor, a damped spring"
[parameters]
m = 2.0
R = 0.5
k = 40.0
L0 = 0.25
c = 0.3
tau = 1.5
[coordinates]
x = { initial = 0.5, velocity = -0.1 }
phi = { initial = 0, velocity = 0.2 }
[lagrangian]
L = "m/2*x'^2 + m*R^2/4*phi'^2"
[[constraints]]
name = "rolling"
velocity = "x' + R*phi'"
[[bodies]]
name = "wheel"
mass = "m"
position = ["x", "R"]
angle = "phi"
inertia = "m*R^2/2"
shape = { circle = "R" }
[[loads]]
name = "motor"
body = "wheel"
torque = "tau"
[[loads]]
name = "tether"
spring = { from = [0, 0], to = ["x", "R"], k = "k", length = "L0", damping = "c" }
"""


def _slider() -> lamech.System:
    """SLIDER, built in Python (lamech.model.assemble)."""
    from lamech.model import (
        AppliedForce,
        Body,
        Constraint,
        Spring,
        assemble,
        coordinate,
        parameters,
    )

    params = parameters(dict(zip("m g k h F P".split(), (1.0, 9.81, 5, 0.5, 2, 1))))
    m, g, k, h, F, P = (p.symbol for p in params)
    coords = [coordinate("x", 0.3), coordinate("y", 0)]
    x, y = (c.symbol for c in coords)
    zero = sp.Integer(0)
    return assemble(
        "Slider on a rail, a spring and a push",
        params,
        coords,
        [Constraint("rail", y)],
        bodies=[Body("slider", m, (x, y))],
        gravity=g,
        loads=[
            Spring((zero, h), (x, y), k, name="spring"),
            AppliedForce("slider", (F, -P), name="push"),
        ],
    )


def _wheel() -> lamech.System:
    """WHEEL, built in Python: L split into T and V, a torque, a damped spring."""
    from lamech.model import Body, Constraint, Spring, Torque, assemble, coordinate, parameter

    values = {"m": 2.0, "R": 0.5, "k": 40, "L0": 0.25, "c": 0.3, "tau": 1.5}
    params = [parameter(n, v) for n, v in values.items()]
    m, R, k, L0, c, tau = (p.symbol for p in params)
    coords = [coordinate("x", 0.5, velocity=-0.1), coordinate("phi", 0, velocity=0.2)]
    (x, xd), (phi, phid) = ((q.symbol, q.velocity) for q in coords)
    return assemble(
        "Wheel on a track: L given, a motor, a damped spring",
        params,
        coords,
        [Constraint("rolling", xd + R * phid, kind="velocity")],
        L=m / 2 * xd**2 + m * R**2 / 4 * phid**2,
        bodies=[Body("wheel", m, (x, R), angle=phi, inertia=m * R**2 / 2, shape=("circle", R))],
        loads=[
            Torque("wheel", tau, name="motor"),
            Spring((sp.Integer(0),) * 2, (x, R), k, length=L0, damping=c, name="tether"),
        ],
    )


@pytest.mark.parametrize(("text", "build"), [(SLIDER, _slider), (WHEEL, _wheel)])
def test_a_system_built_in_python_is_the_file_s(text, build):
    """lamech.model.assemble models as the loader does: the same System (T and V from the
    bodies or L split, the loads' forces and energy) and the same multipliers."""
    import dataclasses

    loaded, built = lamech.loads(text), build()
    assert dataclasses.replace(loaded, source=None) == built
    assert built.V.has(built.symbols["k"]) and any(Q != 0 for Q in built.forces)
    lam_loaded, lam_built = lamech.solve(loaded).multipliers, lamech.solve(built).multipliers
    assert lam_built == lam_loaded and all(lam != 0 for lam in lam_built.values())


def test_assemble_refuses_loads_the_file_would():
    """A load built in Python is held to a file's rules: its expressions in the symbols
    their field allows, its body one of the bodies."""
    from lamech.model import AppliedForce, Body, ModelError, Spring, assemble, coordinate, parameter

    m, k = parameter("m", 2.0), parameter("k", 50.0)
    x = coordinate("x", initial=0.1)
    zero = sp.Integer(0)
    block = Body("block", m.symbol, (x.symbol, zero))
    cases = [
        (Spring((zero, zero), (x.symbol, zero), k.symbol * x.symbol), "spring.k", "coordinates"),
        (AppliedForce("block", (sp.Symbol("Q"), zero), name="push"), "force", "unknown name `Q`"),
        (AppliedForce("blok", (k.symbol, zero), name="push"), "body", "one of the [[bodies]]"),
    ]
    for load, field, message in cases:
        with pytest.raises(ModelError) as info:
            assemble("t", (m, k), (x,), bodies=(block,), loads=(load,))
        ((where, said),) = info.value.issues
        assert where == f"loads[1] `{load.name}` {field}" and message in said
