"""Every multiplier of systems whose closed forms are long, against SymPy and Newton.

Issue 11: ``lamech solve`` gave no multipliers for the four-bar linkage, the disc
rolling on a plane (3-1-2 Euler angles, non-holonomic), the snakeboard and the double
pendulum in Cartesian coordinates, where SymPy's ``LagrangesMethod.solve_multipliers``
gives them. Each multiplier in ``lamech.solve(system).multipliers`` is checked here at
seeded random states on the constraint manifold (and at the file's initial state)
against

- SymPy's own ``LagrangesMethod(...).form_lagranges_equations()`` and
  ``solve_multipliers(op_point=...)``, on a model built here independently (with the
  frames and points of ``sympy.physics.mechanics`` where the kinematics is in space),
  after checking that its T, V and constraints are lamech's, term for term: the same
  scaling and sign, as no constraint is ever normalised;
- Newton-Euler where that is short to write: the rod tensions of the double pendulum
  (Cartesian and polar), the pin force of the four-bar, the centripetal friction on the
  disc in a steady turn.

Sign: SymPy's equations are eom = d/dt dL/dq' - dL/dq + A^T lambda - Q = 0 (its
``lam_coeffs`` is -A, ``lagrange.py``), and ``solve_multipliers`` returns that lambda;
lamech's is d/dt dL/dq' - dL/dq - A^T lambda = Q (README, "Sign convention"), so
lambda_lamech = -lambda_SymPy.

Where lamech eliminates coordinates (the double pendulums), the state is built in full
(every coordinate and velocity) and the eliminated ones are checked against
``solution.reduction`` first, so both sides are evaluated at the same state.
"""

from __future__ import annotations

import functools
import math
import random
from dataclasses import dataclass

import numpy as np
import pytest
import sympy as sp
from sympy.physics.mechanics import (
    LagrangesMethod,
    Point,
    ReferenceFrame,
    dynamicsymbols,
    inertia,
)

import lamech
from bench.run import DOUBLE_PENDULUM_CARTESIAN as CARTESIAN_DOUBLE_PENDULUM
from bench.run import DOUBLE_PENDULUM_POLAR as POLAR_DOUBLE_PENDULUM
from lamech.model._chart import chart_initial

TIME = dynamicsymbols._t
STATES = 6  # random states per problem, besides the initial one
RTOL = 1e-8

# ----------------------------------------------------------------- problems (inline)

# The snakeboard of Ostrowski et al. as in Moore, "Learn Multibody Dynamics", chapters
# "Nonholonomic Constraints" (section Snakeboard) and "Equations of Motion with
# Nonholonomic Constraints": a board (A, centre (q1, q2), heading q3) with a truck at
# each end, +-l/2 along the board, turned by q4 (front, B) and q5 (back, C) relative to
# it; the three bodies have the same mass m and central moment of inertia J (the book's
# I); the wheels cannot slide sideways: v(Bo) . b_y = 0, v(Co) . c_y = 0. Initial state
# as in the book's simulation: q4 = 5 deg, q5 = -5 deg, u3 = l q3'/2 = 0.1,
# q4' = 0.01, q5' = -0.01, q1' and q2' from the constraints.
SNAKEBOARD = """
title = "Snakeboard"
[parameters]
m = 1.0
J = 0.1
l = 0.7
u30 = 0.1
q40 = "pi/36"
[coordinates]
q1 = { initial = 0, velocity = "u30*cos(q40)/sin(q40)" }
q2 = { initial = 0, velocity = 0 }
q3 = { initial = 0, velocity = "2*u30/l" }
q4 = { initial = "q40", velocity = 0.01 }
q5 = { initial = "-q40", velocity = -0.01 }
[[constraints]]
name = "front"
velocity = "-sin(q3 + q4)*q1' + cos(q3 + q4)*q2' + l/2*cos(q4)*q3'"
[[constraints]]
name = "back"
velocity = "-sin(q3 + q5)*q1' + cos(q3 + q5)*q2' - l/2*cos(q5)*q3'"
[[bodies]]
name = "board"
mass = "m"
position = ["q1", "q2"]
angle = "q3"
inertia = "J"
[[bodies]]
name = "front_truck"
mass = "m"
position = ["q1 + l/2*cos(q3)", "q2 + l/2*sin(q3)"]
angle = "q3 + q4"
inertia = "J"
[[bodies]]
name = "back_truck"
mass = "m"
position = ["q1 - l/2*cos(q3)", "q2 - l/2*sin(q3)"]
angle = "q3 + q5"
inertia = "J"
"""

# The double pendulums are benchmark B5's (bench/run.py), one text for both: Cartesian
# bobs with rods f = |d|^2 - l^2 (a rod's multiplier is -T/(2 l), T its tension), and
# polar coordinates with strings f = l - r (each multiplier a tension).

SOURCES = {
    "four_bar": lambda: lamech.load("four_bar"),
    "rolling_disc": lambda: lamech.load("rolling_disc"),
    "snakeboard": lambda: lamech.loads(SNAKEBOARD),
    "cartesian_double_pendulum": lambda: lamech.loads(CARTESIAN_DOUBLE_PENDULUM),
    "polar_double_pendulum": lambda: lamech.loads(POLAR_DOUBLE_PENDULUM),
}
NAMES = list(SOURCES)
# The default set (`-m "not slow"`) checks one problem, CI all five: solving each, and its
# peer in SymPy, takes seconds.
DEFAULT = "cartesian_double_pendulum"


def cases(names):
    return [n if n == DEFAULT else pytest.param(n, marks=pytest.mark.slow) for n in names]


@functools.cache
def solved(name: str):
    return lamech.solve(SOURCES[name]())


# ------------------------------------------------------------ the peers, in SymPy alone


@dataclass(frozen=True)
class Peer:
    """A model in ``sympy.physics.mechanics`` terms: coordinates (dynamicsymbols, by
    lamech's name, in lamech's order), parameters (by name), T, V, and the constraints
    by lamech's name: holonomic f(q) or velocity g(q, q'), as SymPy takes them."""

    q: dict
    params: dict
    T: sp.Expr
    V: sp.Expr
    holonomic: dict
    velocity: dict


def _planar(angle):
    return sp.Matrix([sp.cos(angle), sp.sin(angle)])


def four_bar_peer() -> Peer:
    th1, th2, th3 = dynamicsymbols("th1:4")
    m1, m2, m3, a, b, c, d, g = sp.symbols("m1 m2 m3 a b c d g", positive=True)
    centres = [
        a / 2 * _planar(th1),
        a * _planar(th1) + b / 2 * _planar(th2),
        sp.Matrix([d, 0]) + c / 2 * _planar(th3),
    ]
    masses, lengths, angles = (m1, m2, m3), (a, b, c), (th1, th2, th3)
    T = sum(
        m / 2 * p.diff(TIME).dot(p.diff(TIME)) + m * L**2 / 12 / 2 * th.diff(TIME) ** 2
        for m, L, th, p in zip(masses, lengths, angles, centres)
    )
    V = g * sum(m * p[1] for m, p in zip(masses, centres))
    B_crank_side = a * _planar(th1) + b * _planar(th2)
    B_rocker_side = sp.Matrix([d, 0]) + c * _planar(th3)
    loop = B_crank_side - B_rocker_side
    return Peer(
        dict(th1=th1, th2=th2, th3=th3),
        dict(m1=m1, m2=m2, m3=m3, a=a, b=b, c=c, d=d, g=g),
        T,
        V,
        dict(loopx=loop[0], loopy=loop[1]),
        {},
    )


def rolling_disc_peer() -> Peer:
    """SymPy's rolling disc (tests/test_lagrange.py, test_rolling_disc: yaw, lean, spin as
    3-1-2 body-fixed rotations, inertia m r^2/4, m r^2/2, m r^2/4 in the lean frame),
    with the contact point (x, y) as coordinates and its material point at rest."""
    x, y, psi, theta, phi = dynamicsymbols("x y psi theta phi")
    m, g, r = sp.symbols("m g r", positive=True)
    N = ReferenceFrame("N")
    Y = N.orientnew("Y", "Axis", [psi, N.z])
    L = Y.orientnew("L", "Axis", [theta, Y.x])
    R = L.orientnew("R", "Axis", [phi, L.y])
    origin = Point("O")
    origin.set_vel(N, 0)
    contact = origin.locatenew("C", x * N.x + y * N.y)
    centre = contact.locatenew("D", r * L.z)
    v = centre.pos_from(origin).dt(N)
    w = R.ang_vel_in(N)
    T = m / 2 * v.dot(v) + w.dot(inertia(L, m * r**2 / 4, m * r**2 / 2, m * r**2 / 4).dot(w)) / 2
    V = m * g * centre.pos_from(origin).dot(N.z)
    slip = v + w.cross(-r * L.z)  # velocity of the disc's material point at the contact
    return Peer(
        dict(x=x, y=y, psi=psi, theta=theta, phi=phi),
        dict(m=m, g=g, r=r),
        T,
        V,
        {},
        dict(roll_x=slip.dot(N.x), roll_y=slip.dot(N.y)),
    )


def snakeboard_peer() -> Peer:
    """Moore's snakeboard, written as the book writes it (see SNAKEBOARD)."""
    q1, q2, q3, q4, q5 = dynamicsymbols("q1:6")
    m, J, length = sp.symbols("m J l", positive=True)
    N, A, B, C = sp.symbols("N A B C", cls=ReferenceFrame)
    A.orient_axis(N, N.z, q3)
    B.orient_axis(A, A.z, q4)
    C.orient_axis(A, A.z, q5)
    origin, Ao, Bo, Co = Point("O"), Point("Ao"), Point("Bo"), Point("Co")
    Ao.set_pos(origin, q1 * N.x + q2 * N.y)
    Bo.set_pos(Ao, length / 2 * A.x)
    Co.set_pos(Ao, -length / 2 * A.x)
    origin.set_vel(N, 0)
    Ao.set_vel(N, Ao.pos_from(origin).dt(N))
    Bo.v2pt_theory(Ao, N, A)
    Co.v2pt_theory(Ao, N, A)
    T = sum(m / 2 * P.vel(N).dot(P.vel(N)) for P in (Ao, Bo, Co)) + sum(
        J / 2 * F.ang_vel_in(N).dot(N.z) ** 2 for F in (A, B, C)
    )
    return Peer(
        dict(q1=q1, q2=q2, q3=q3, q4=q4, q5=q5),
        dict(m=m, J=J, l=length),
        T,
        sp.Integer(0),
        {},
        dict(front=Bo.vel(N).dot(B.y), back=Co.vel(N).dot(C.y)),
    )


def cartesian_double_pendulum_peer() -> Peer:
    x1, y1, x2, y2 = dynamicsymbols("x1 y1 x2 y2")
    m1, m2, l1, l2, g = sp.symbols("m1 m2 l1 l2 g", positive=True)
    T = (
        m1 * (x1.diff(TIME) ** 2 + y1.diff(TIME) ** 2)
        + m2 * (x2.diff(TIME) ** 2 + y2.diff(TIME) ** 2)
    ) / 2
    V = g * (m1 * y1 + m2 * y2)
    return Peer(
        dict(x1=x1, y1=y1, x2=x2, y2=y2),
        dict(m1=m1, m2=m2, l1=l1, l2=l2, g=g),
        T,
        V,
        dict(rod1=x1**2 + y1**2 - l1**2, rod2=(x2 - x1) ** 2 + (y2 - y1) ** 2 - l2**2),
        {},
    )


def polar_double_pendulum_peer() -> Peer:
    r1, th1, r2, th2 = dynamicsymbols("r1 th1 r2 th2")
    m1, m2, l1, l2, g = sp.symbols("m1 m2 l1 l2 g", positive=True)
    down = lambda th: sp.Matrix([sp.sin(th), -sp.cos(th)])  # noqa: E731
    p1 = r1 * down(th1)
    p2 = p1 + r2 * down(th2)
    T = (m1 * p1.diff(TIME).dot(p1.diff(TIME)) + m2 * p2.diff(TIME).dot(p2.diff(TIME))) / 2
    V = g * (m1 * p1[1] + m2 * p2[1])
    return Peer(
        dict(r1=r1, th1=th1, r2=r2, th2=th2),
        dict(m1=m1, m2=m2, l1=l1, l2=l2, g=g),
        T,
        V,
        dict(rod1=l1 - r1, rod2=l2 - r2),
        {},
    )


PEERS = {
    "four_bar": four_bar_peer,
    "rolling_disc": rolling_disc_peer,
    "snakeboard": snakeboard_peer,
    "cartesian_double_pendulum": cartesian_double_pendulum_peer,
    "polar_double_pendulum": polar_double_pendulum_peer,
}


@functools.cache
def peer_method(name: str):
    """(Peer, LagrangesMethod with its equations formed)."""
    peer = PEERS[name]()
    lm = LagrangesMethod(
        peer.T - peer.V,
        list(peer.q.values()),
        hol_coneqs=list(peer.holonomic.values()) or None,
        nonhol_coneqs=list(peer.velocity.values()) or None,
    )
    lm.form_lagranges_equations()
    return peer, lm


def sympy_multipliers(name: str, state: dict, params: dict, method=None) -> dict:
    """lamech's multipliers from SymPy's ``solve_multipliers`` at a numeric state
    (names -> floats): SymPy's lambda with its sign turned (module docstring).
    ``method``: a (Peer, LagrangesMethod) of :func:`peer_method` to reuse."""
    peer, lm = method or peer_method(name)
    op = {}
    for q_name, q in peer.q.items():
        op[q.diff(TIME)] = state[q_name + "'"]
        op[q] = state[q_name]
    op.update({p: params[p_name] for p_name, p in peer.params.items()})
    lam = lm.solve_multipliers(op_point=op, sol_type="Matrix")
    # SymPy orders its multipliers: the holonomic constraints, then the velocity ones
    names = list(peer.holonomic) + list(peer.velocity)
    return {n: -float(v) for n, v in zip(names, lam)}


def in_lamech_symbols(expr: sp.Expr, name: str, system) -> sp.Expr:
    """A peer's expression in lamech's symbols (velocities first: q' inside q(t))."""
    peer, _ = peer_method(name)
    S = system.symbols
    expr = sp.sympify(expr).xreplace({q.diff(TIME): S[n + "'"] for n, q in peer.q.items()})
    expr = expr.xreplace({q: S[n] for n, q in peer.q.items()})
    return expr.xreplace({p: S[n] for n, p in peer.params.items()})


# ------------------------------------------------------------------------ states


def value(expr, vals: dict) -> float:
    """``expr`` at ``vals`` (lamech symbols -> floats), with 30 digits so that long,
    unsimplified closed forms do not lose the comparison to cancellation."""
    out = sp.sympify(expr).xreplace({s: sp.Float(v, 30) for s, v in vals.items()})
    return float(sp.N(out, 30))


def symbol_values(system, state: dict, params: dict) -> dict:
    S = system.symbols
    vals = {S[k]: v for k, v in params.items()}
    vals.update({S[k]: v for k, v in state.items()})
    vals[system.t] = 0.0
    return vals


def file_params(system) -> dict:
    return {p.name: float(p.numeric) for p in system.parameters}


def initial_state(system) -> dict:
    pv = system.parameter_values
    out = {}
    for c in system.coordinates:
        out[c.name] = float(sp.sympify(c.initial).subs(pv))
        out[c.name + "'"] = float(sp.sympify(c.initial_velocity).subs(pv))
    return out


def four_bar_state(rng: random.Random, p: dict) -> dict:
    """Crank angle and rate at random; the coupler and rocker where the loop closes (B on
    the same side of A -> D as in the file's initial state), their rates from the loop's
    velocity constraints (Norton ch. 6)."""
    a, b, c, d = p["a"], p["b"], p["c"], p["d"]
    th1, w1 = rng.uniform(0, 2 * math.pi), rng.uniform(-3, 3)
    ax, ay = a * math.cos(th1), a * math.sin(th1)
    e = math.hypot(d - ax, ay)
    th2 = math.atan2(-ay, d - ax) + math.acos((b * b + e * e - c * c) / (2 * b * e))
    th3 = math.atan2(ay, ax - d) - math.acos((c * c + e * e - b * b) / (2 * c * e))
    w2 = a * w1 * math.sin(th1 - th3) / (b * math.sin(th3 - th2))
    w3 = a * w1 * math.sin(th1 - th2) / (c * math.sin(th3 - th2))
    return {"th1": th1, "th2": th2, "th3": th3, "th1'": w1, "th2'": w2, "th3'": w3}


def four_bar_params(rng: random.Random) -> dict:
    # a + d < b + c and d - a > |b - c| for every draw: the linkage assembles at every
    # crank angle and B is never in line with A and D
    return {
        "m1": rng.uniform(0.5, 2),
        "m2": rng.uniform(0.5, 2),
        "m3": rng.uniform(0.5, 2),
        "a": rng.uniform(0.8, 1.2),
        "b": rng.uniform(1.8, 2.2),
        "c": rng.uniform(1.8, 2.2),
        "d": rng.uniform(1.8, 2.2),
        "g": 9.81,
    }


def rolling_disc_state(rng: random.Random, p: dict) -> dict:
    s = {
        "x": rng.uniform(-1, 1),
        "y": rng.uniform(-1, 1),
        "psi": rng.uniform(-3, 3),
        "theta": rng.uniform(-1.2, 1.2),
        "phi": rng.uniform(-3, 3),
        "psi'": rng.uniform(-3, 3),
        "theta'": rng.uniform(-3, 3),
        "phi'": rng.uniform(-5, 5),
    }
    s["x'"] = p["r"] * math.cos(s["psi"]) * s["phi'"]
    s["y'"] = p["r"] * math.sin(s["psi"]) * s["phi'"]
    return s


def rolling_disc_params(rng: random.Random) -> dict:
    return {"m": rng.uniform(0.5, 2), "r": rng.uniform(0.1, 1), "g": rng.uniform(5, 15)}


def snakeboard_state(rng: random.Random, p: dict) -> dict:
    """q3, q4, q5 and their rates at random; q1', q2' from the two wheel constraints."""
    s = {
        "q1": rng.uniform(-1, 1),
        "q2": rng.uniform(-1, 1),
        "q3": rng.uniform(-3, 3),
        "q4": rng.uniform(-0.8, 0.8),
        "q5": rng.uniform(-0.8, 0.8),
        "q3'": rng.uniform(-2, 2),
        "q4'": rng.uniform(-2, 2),
        "q5'": rng.uniform(-2, 2),
    }
    h = p["l"] / 2
    f, b = s["q3"] + s["q4"], s["q3"] + s["q5"]
    A = np.array([[-math.sin(f), math.cos(f)], [-math.sin(b), math.cos(b)]])
    rhs = -np.array([h * math.cos(s["q4"]) * s["q3'"], -h * math.cos(s["q5"]) * s["q3'"]])
    s["q1'"], s["q2'"] = np.linalg.solve(A, rhs)
    return s


def snakeboard_params(rng: random.Random) -> dict:
    return {"m": rng.uniform(0.5, 2), "J": rng.uniform(0.02, 0.5), "l": rng.uniform(0.3, 1.2)}


def _angles(rng: random.Random) -> tuple[float, float, float, float]:
    """Both rods below their pivots (the branch of the file's initial state)."""
    return (rng.uniform(-1.2, 1.2), rng.uniform(-1.2, 1.2), rng.uniform(-3, 3), rng.uniform(-3, 3))


def cartesian_double_pendulum_at(t1, t2, w1, w2, p: dict) -> dict:
    l1, l2 = p["l1"], p["l2"]
    x1, y1 = l1 * math.sin(t1), -l1 * math.cos(t1)
    v1x, v1y = l1 * math.cos(t1) * w1, l1 * math.sin(t1) * w1
    return {
        "x1": x1,
        "y1": y1,
        "x2": x1 + l2 * math.sin(t2),
        "y2": y1 - l2 * math.cos(t2),
        "x1'": v1x,
        "y1'": v1y,
        "x2'": v1x + l2 * math.cos(t2) * w2,
        "y2'": v1y + l2 * math.sin(t2) * w2,
    }


def polar_double_pendulum_at(t1, t2, w1, w2, p: dict) -> dict:
    return {
        "r1": p["l1"],
        "th1": t1,
        "r2": p["l2"],
        "th2": t2,
        "r1'": 0.0,
        "th1'": w1,
        "r2'": 0.0,
        "th2'": w2,
    }


def cartesian_double_pendulum_state(rng: random.Random, p: dict) -> dict:
    return cartesian_double_pendulum_at(*_angles(rng), p)


def polar_double_pendulum_state(rng: random.Random, p: dict) -> dict:
    return polar_double_pendulum_at(*_angles(rng), p)


def double_pendulum_params(rng: random.Random) -> dict:
    return {
        "m1": rng.uniform(0.5, 2),
        "m2": rng.uniform(0.5, 2),
        "l1": rng.uniform(0.5, 2),
        "l2": rng.uniform(0.5, 2),
        "g": rng.uniform(5, 15),
    }


STATE = {
    "four_bar": (four_bar_state, four_bar_params),
    "rolling_disc": (rolling_disc_state, rolling_disc_params),
    "snakeboard": (snakeboard_state, snakeboard_params),
    "cartesian_double_pendulum": (cartesian_double_pendulum_state, double_pendulum_params),
    "polar_double_pendulum": (polar_double_pendulum_state, double_pendulum_params),
}


def states(name: str, count: int = STATES, seed: int = 11):
    """The file's initial state, then ``count`` random states on the constraint
    manifold, each with parameters (the file's, then random draws)."""
    system = SOURCES[name]()
    yield initial_state(system), file_params(system)
    make_state, make_params = STATE[name]
    rng = random.Random(seed)
    for _ in range(count):
        params = {**file_params(system), **make_params(rng)}
        yield make_state(rng, params), params


def assert_on_manifold(system, vals: dict, tol: float = 1e-12) -> None:
    """f = 0 and df/dt = 0 for every holonomic constraint, g = 0 for a velocity one."""
    for c in system.constraints:
        residuals = [c.expr]
        if c.holonomic:
            residuals.append(sum(sp.diff(c.expr, q) * v for q, v in zip(system.q, system.qd)))
        for r in residuals:
            assert abs(value(r, vals)) < tol, f"{c.name}: {r} = {value(r, vals)} at {vals}"


def assert_eliminated_agree(solution, vals: dict, tol: float = 1e-10) -> None:
    """The coordinates and velocities lamech eliminated take the state's values there
    (so both sides are compared at one state, on the branch lamech chose). Where lamech
    solved in a chart (a circle's angle), ``vals`` gains the chart's coordinates of the
    state (found as lamech places a chart's start)."""
    if solution.system.chart is not None:
        found = chart_initial(solution.system, vals)
        assert not isinstance(found, str), found
        vals.update(found)
    velocities = set(solution.system.qd)
    for key, expr in solution.reduction.substitution.items():
        if key in vals and (key in solution.system.q or key in velocities):
            got = value(expr, vals)
            assert abs(got - vals[key]) < tol * (1 + abs(vals[key])), (key, expr, got, vals)


def lamech_multiplier(solution, name: str, vals: dict) -> float:
    delivered = solution.multipliers
    assert name in delivered, (
        f"no closed form for lambda_{name}: multipliers delivered {sorted(delivered)}; "
        f"notes: {solution.notes}"
    )
    return value(delivered[name], vals)


# ------------------------------------------------------------------------ the tests


def test_the_bundled_files_start_on_their_constraints():
    """The four-bar's start is exact (law of cosines: |f| ~ 1e-16); the disc starts in
    its steady turn (theta'' = psi'' = phi'' = 0 there, by lamech's own equations)."""
    for name in ("four_bar", "rolling_disc"):
        system = SOURCES[name]()
        vals = symbol_values(system, initial_state(system), file_params(system))
        assert_on_manifold(system, vals, tol=1e-15)


@pytest.mark.parametrize("name", cases(NAMES))
def test_the_sympy_model_is_lamechs(name):
    """T, V and every constraint of the peer equal lamech's at random points (all
    symbols drawn at random: as functions, not only on the manifold)."""
    system = SOURCES[name]()
    peer, _ = peer_method(name)
    pairs = [
        (in_lamech_symbols(peer.T, name, system), system.T, "T"),
        (in_lamech_symbols(peer.V, name, system), system.V, "V"),
    ]
    for c in system.constraints:
        mine = {**peer.holonomic, **peer.velocity}[c.name]
        pairs.append((in_lamech_symbols(mine, name, system), c.expr, c.name))
    rng = random.Random(5)
    symbols = set(system.symbols.values())
    for _ in range(4):
        vals = {s: rng.uniform(0.3, 1.7) for s in symbols}
        for got, expected, what in pairs:
            a, b = value(got, vals), value(expected, vals)
            assert abs(a - b) <= 1e-12 * (1 + abs(b)), (name, what, a, b)


@pytest.mark.parametrize("name", cases(NAMES))
def test_every_multiplier_is_delivered(name):
    solution = solved(name)
    names = {c.name for c in solution.system.constraints}
    assert set(solution.multipliers) == names, (
        f"{name}: multipliers delivered {sorted(solution.multipliers)} of {sorted(names)}; "
        f"notes: {solution.notes}"
    )


@pytest.mark.parametrize("name", cases(NAMES))
def test_multipliers_agree_with_sympy(name):
    solution = solved(name)
    system = solution.system
    for state, params in states(name):
        vals = symbol_values(system, state, params)
        assert_on_manifold(system, vals)
        assert_eliminated_agree(solution, vals)
        theirs = sympy_multipliers(name, state, params)
        for c in system.constraints:
            mine = lamech_multiplier(solution, c.name, vals)
            assert mine == pytest.approx(theirs[c.name], rel=RTOL, abs=RTOL), (
                f"{name}: lambda_{c.name} = {mine}, SymPy {theirs[c.name]} at {state}, {params}"
            )


# ------------------------------------------ the fast path: lamech.multipliers (raw)


@functools.cache
def raw(name: str) -> dict:
    """``lamech.multipliers``: every lambda with nothing eliminated or simplified (the
    lamech column of benchmark B5)."""
    return lamech.multipliers(SOURCES[name]())


@pytest.mark.parametrize("name", cases(NAMES))
def test_raw_multipliers_agree_with_sympy_and_the_tidy_ones(name):
    """At the initial state and random states on the constraint manifold, each raw
    multiplier equals SymPy's ``solve_multipliers`` (sign turned: lambda_lamech =
    -lambda_SymPy) and ``lamech.solve``'s tidy one (``Solution.multipliers``, in the
    independent coordinates where the double pendulums eliminate some)."""
    fast = raw(name)
    solution = solved(name)
    system = solution.system
    assert set(fast) == {c.name for c in system.constraints}
    method = peer_method(name)
    for state, params in states(name):
        vals = symbol_values(system, state, params)
        assert_on_manifold(system, vals)
        assert_eliminated_agree(solution, vals)
        theirs = sympy_multipliers(name, state, params, method)
        for c in system.constraints:
            mine = value(fast[c.name], vals)
            tidy = lamech_multiplier(solution, c.name, vals)
            assert mine == pytest.approx(theirs[c.name], rel=RTOL, abs=RTOL), (
                f"{name}: raw lambda_{c.name} = {mine}, SymPy {theirs[c.name]} at {state}"
            )
            assert mine == pytest.approx(tidy, rel=RTOL, abs=RTOL), (
                f"{name}: raw lambda_{c.name} = {mine}, tidy {tidy} at {state}"
            )


@pytest.mark.parametrize("name", cases(NAMES))
def test_raw_multipliers_hold_off_the_constraint_manifold(name):
    """Nothing in the raw multipliers uses the constraints (no elimination, no
    simplification on the manifold): they equal SymPy's at states that break every
    constraint, with every coordinate and velocity drawn at random."""
    system = SOURCES[name]()
    fast = raw(name)
    method = peer_method(name)
    rng = random.Random(3)
    make_params = STATE[name][1]
    for _ in range(3):
        params = {**file_params(system), **make_params(rng)}
        state = {}
        for c in system.coordinates:
            state[c.name] = rng.uniform(0.2, 1.4) * rng.choice((-1, 1))
            state[c.name + "'"] = rng.uniform(-2, 2)
        vals = symbol_values(system, state, params)
        assert any(abs(value(c.expr, vals)) > 1e-3 for c in system.constraints)
        theirs = sympy_multipliers(name, state, params, method)
        for c in system.constraints:
            mine = value(fast[c.name], vals)
            assert mine == pytest.approx(theirs[c.name], rel=RTOL, abs=RTOL), (
                f"{name}: raw lambda_{c.name} = {mine}, SymPy {theirs[c.name]} at {state}"
            )


# ----------------------------------------------------------- Newton: double pendulum


def double_pendulum_tensions(t1, t2, w1, w2, p):
    """Rod tensions by Newton's second law on each bob, with the angular accelerations
    of the textbook equations of the double pendulum (absolute angles from the downward
    vertical; e.g. Neumann, myPhysicsLab "Double Pendulum"). Returns (T1, T2) and the
    force residuals across the rods (zero when the accelerations are right)."""
    m1, m2, l1, l2, g = (p[k] for k in ("m1", "m2", "l1", "l2", "g"))
    den = 2 * m1 + m2 - m2 * math.cos(2 * t1 - 2 * t2)
    a1 = (
        -g * (2 * m1 + m2) * math.sin(t1)
        - m2 * g * math.sin(t1 - 2 * t2)
        - 2 * math.sin(t1 - t2) * m2 * (w2**2 * l2 + w1**2 * l1 * math.cos(t1 - t2))
    ) / (l1 * den)
    a2 = (
        2
        * math.sin(t1 - t2)
        * (
            w1**2 * l1 * (m1 + m2)
            + g * (m1 + m2) * math.cos(t1)
            + w2**2 * l2 * m2 * math.cos(t1 - t2)
        )
    ) / (l2 * den)

    def acc(r, t, w, alpha):  # of a point at r (sin t, -cos t) about a fixed pivot
        return np.array(
            [
                r * (alpha * math.cos(t) - w**2 * math.sin(t)),
                r * (alpha * math.sin(t) + w**2 * math.cos(t)),
            ]
        )

    acc1 = acc(l1, t1, w1, a1)
    acc2 = acc1 + acc(l2, t2, w2, a2)
    gravity = np.array([0.0, -g])
    u1 = np.array([-math.sin(t1), math.cos(t1)])  # from bob 1 to the pivot
    u2 = np.array([-math.sin(t2), math.cos(t2)])  # from bob 2 to bob 1
    need2 = m2 * (acc2 - gravity)  # = T2 u2
    T2 = need2 @ u2
    need1 = m1 * (acc1 - gravity) + T2 * u2  # = T1 u1
    T1 = need1 @ u1
    across = (abs(need2 @ np.array([u2[1], -u2[0]])), abs(need1 @ np.array([u1[1], -u1[0]])))
    return T1, T2, across


@pytest.mark.parametrize("name", cases(["cartesian_double_pendulum", "polar_double_pendulum"]))
def test_double_pendulum_tensions_by_newton(name):
    """Cartesian: f = |d|^2 - l^2, so lambda = -T/(2 l); polar: f = l - r, lambda = T."""
    solution = solved(name)
    system = solution.system
    cartesian = name.startswith("cartesian")
    at = cartesian_double_pendulum_at if cartesian else polar_double_pendulum_at
    rng = random.Random(7)
    for _ in range(STATES):
        params = {**file_params(system), **double_pendulum_params(rng)}
        t1, t2, w1, w2 = _angles(rng)
        vals = symbol_values(system, at(t1, t2, w1, w2, params), params)
        assert_eliminated_agree(solution, vals)
        T1, T2, across = double_pendulum_tensions(t1, t2, w1, w2, params)
        assert max(across) < 1e-9 * (1 + abs(T1) + abs(T2))
        if cartesian:
            expected = {"rod1": -T1 / (2 * params["l1"]), "rod2": -T2 / (2 * params["l2"])}
        else:
            expected = {"rod1": T1, "rod2": T2}
        for rod, lam in expected.items():
            assert lamech_multiplier(solution, rod, vals) == pytest.approx(lam, rel=1e-9)


# ------------------------------------------------------------- Newton-Euler: four-bar


def four_bar_pin_forces(state: dict, p: dict) -> np.ndarray:
    """Newton-Euler on each link (Norton ch. 11), numerically: unknowns the angular
    accelerations al1, al2, al3 and the pin forces O (ground on crank), A (crank on
    coupler), B (rocker on coupler), D (ground on rocker); equations: force and moment
    about the centre of each link (9) and the loop's acceleration constraint (2).
    Returns (al1, al2, al3, Ox, Oy, Ax, Ay, Bx, By, Dx, Dy)."""
    m = [p["m1"], p["m2"], p["m3"]]
    a, b, c, d, g = p["a"], p["b"], p["c"], p["d"], p["g"]
    th = [state["th1"], state["th2"], state["th3"]]
    w = [state["th1'"], state["th2'"], state["th3'"]]
    I_ = [m[0] * a**2 / 12, m[1] * b**2 / 12, m[2] * c**2 / 12]
    e = [np.array([math.cos(t), math.sin(t)]) for t in th]
    n = [np.array([-math.sin(t), math.cos(t)]) for t in th]  # d e/d th
    # accelerations are affine in al = (al1, al2, al3): acc = J al + k
    crank_end_J, crank_end_k = np.outer(a * n[0], [1, 0, 0]), -a * w[0] ** 2 * e[0]
    G = [
        (np.outer(a / 2 * n[0], [1, 0, 0]), -a / 2 * w[0] ** 2 * e[0]),
        (crank_end_J + np.outer(b / 2 * n[1], [0, 1, 0]), crank_end_k - b / 2 * w[1] ** 2 * e[1]),
        (np.outer(c / 2 * n[2], [0, 0, 1]), -c / 2 * w[2] ** 2 * e[2]),
    ]
    pos = {"O": np.zeros(2), "A": a * e[0], "B": a * e[0] + b * e[1], "D": np.array([d, 0.0])}
    centre = [a / 2 * e[0], a * e[0] + b / 2 * e[1], pos["D"] + c / 2 * e[2]]
    # which pin forces act on which link, with which sign
    acting = [[("O", 1), ("A", -1)], [("A", 1), ("B", 1)], [("D", 1), ("B", -1)]]
    column = {"O": 3, "A": 5, "B": 7, "D": 9}
    K, rhs = np.zeros((11, 11)), np.zeros(11)

    def cross(r, col, sign, row):  # moment r x F of the force in columns col, col + 1
        K[row, col] += -sign * r[1]
        K[row, col + 1] += sign * r[0]

    for i in range(3):
        J, k = G[i]
        for axis in range(2):  # m acc - sum F = m g
            row = 3 * i + axis
            K[row, :3] = m[i] * J[axis]
            for pin, sign in acting[i]:
                K[row, column[pin] + axis] -= sign
            rhs[row] = -m[i] * k[axis] + (-m[i] * g if axis == 1 else 0.0)
        row = 3 * i + 2  # I al - sum (r x F) = 0 about the centre
        K[row, i] = I_[i]
        for pin, sign in acting[i]:
            cross(-(pos[pin] - centre[i]), column[pin], sign, row)
    # the loop closes at every instant: B's acceleration the same both ways
    J_loop = crank_end_J + np.outer(b * n[1], [0, 1, 0]) - np.outer(c * n[2], [0, 0, 1])
    k_loop = crank_end_k - b * w[1] ** 2 * e[1] + c * w[2] ** 2 * e[2]
    K[9:, :3] = J_loop
    rhs[9:] = -k_loop
    return np.linalg.solve(K, rhs)


@pytest.mark.slow
def test_four_bar_multipliers_are_the_pin_force_by_newton_euler():
    """(lambda_loopx, lambda_loopy) is the force of the rocker on the coupler at B (the
    four_bar.toml header), at the initial state and at random states."""
    solution = solved("four_bar")
    system = solution.system
    for state, params in states("four_bar", count=4, seed=13):
        vals = symbol_values(system, state, params)
        sol = four_bar_pin_forces(state, params)
        Bx, By = sol[7], sol[8]
        scale = 1 + abs(Bx) + abs(By)
        assert lamech_multiplier(solution, "loopx", vals) == pytest.approx(Bx, abs=1e-9 * scale)
        assert lamech_multiplier(solution, "loopy", vals) == pytest.approx(By, abs=1e-9 * scale)


def test_four_bar_newton_euler_keeps_the_energy():
    """The Newton-Euler helper on its own: its accelerations make d/dt (T + V) = 0 at
    moving states (the pins do no work), which a wrong sign or lever arm would break."""
    for state, p in list(states("four_bar", count=3, seed=17))[1:]:
        al = four_bar_pin_forces(state, p)[:3]
        a, b, c = p["a"], p["b"], p["c"]
        th = [state["th1"], state["th2"], state["th3"]]
        w = [state["th1'"], state["th2'"], state["th3'"]]
        e = [np.array([math.cos(t), math.sin(t)]) for t in th]
        n = [np.array([-math.sin(t), math.cos(t)]) for t in th]
        vel = [a / 2 * w[0] * n[0], a * w[0] * n[0] + b / 2 * w[1] * n[1], c / 2 * w[2] * n[2]]
        tip = a * (al[0] * n[0] - w[0] ** 2 * e[0])
        acc = [
            tip / 2,
            tip + b / 2 * (al[1] * n[1] - w[1] ** 2 * e[1]),
            c / 2 * (al[2] * n[2] - w[2] ** 2 * e[2]),
        ]
        mass = [p["m1"], p["m2"], p["m3"]]
        moment = [mass[0] * a**2 / 12, mass[1] * b**2 / 12, mass[2] * c**2 / 12]
        power = sum(
            m * (v @ ac) + i * wi * ali + m * p["g"] * v[1]
            for m, v, ac, i, wi, ali in zip(mass, vel, acc, moment, w, al)
        )
        kinetic = sum(m * (v @ v) + i * wi**2 for m, v, i, wi in zip(mass, vel, moment, w))
        assert abs(power) < 1e-10 * (1 + kinetic) * (1 + max(abs(x) for x in w))


# -------------------------------------------------------- the disc's steady turn


@pytest.mark.slow
def test_rolling_disc_steady_turn_friction_is_centripetal():
    """In a steady turn (lean theta0, yaw rate Omega, spin phi' = -5 Omega sin(theta0)/6
    - 2 g tan(theta0)/(3 Omega r)) lamech's theta'', psi'', phi'' vanish, and the
    friction (lambda_roll_x, lambda_roll_y) is m times the centripetal acceleration of
    the centre, whose circle has radius r (sin(theta0) + phi'/Omega):
    m r Omega (Omega sin(theta0) + phi') (-sin(psi), cos(psi))."""
    solution = solved("rolling_disc")
    system = solution.system
    S = system.symbols
    rng = random.Random(3)
    reduced = {
        c: eq
        for c in solution.independent
        for eq in solution.reduced_equations
        if S[c + "''"] in eq.free_symbols
    }
    for _ in range(4):
        p = {**file_params(system), **rolling_disc_params(rng)}
        th0 = rng.choice((-1, 1)) * rng.uniform(0.1, 1.0)
        Om = rng.choice((-1, 1)) * rng.uniform(1.0, 3.0)
        spin = -5 * Om * math.sin(th0) / 6 - 2 * p["g"] * math.tan(th0) / (3 * Om * p["r"])
        psi = rng.uniform(-3, 3)
        state = {
            "x": rng.uniform(-1, 1),
            "y": rng.uniform(-1, 1),
            "psi": psi,
            "theta": th0,
            "phi": rng.uniform(-3, 3),
            "psi'": Om,
            "theta'": 0.0,
            "phi'": spin,
            "x'": p["r"] * math.cos(psi) * spin,
            "y'": p["r"] * math.sin(psi) * spin,
        }
        vals = symbol_values(system, state, p)
        for coordinate in ("theta", "psi", "phi"):
            assert coordinate in reduced, (
                f"no closed form for {coordinate}''; notes: {solution.notes}"
            )
            at_rest = {**vals, S[coordinate + "''"]: 0.0}
            assert abs(value(reduced[coordinate], at_rest)) < 1e-9 * p["g"] / p["r"]
        force = p["m"] * p["r"] * Om * (Om * math.sin(th0) + spin)
        assert lamech_multiplier(solution, "roll_x", vals) == pytest.approx(
            -force * math.sin(psi), abs=1e-9 * (1 + abs(force))
        )
        assert lamech_multiplier(solution, "roll_y", vals) == pytest.approx(
            force * math.cos(psi), abs=1e-9 * (1 + abs(force))
        )


# ----- every simplification bounded by counted work: see tests/test_normal.py ----------
