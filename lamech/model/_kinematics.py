"""Kinematics of a :class:`~lamech.model.System`: time derivatives along the motion, the
energy of its bodies, and the partial velocities of their material points."""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

import sympy as sp

from ._parts import Body

if TYPE_CHECKING:  # pragma: no cover
    from ._system import System

__all__ = [
    "time_derivative",
    "body_energy",
    "body_rotation",
    "angular_velocity",
    "inertia_matrix",
    "partial_velocities",
    "contact_partial_velocities",
    "velocity_form",
    "constraint_jacobian",
    "jacobian",
    "gradient",
    "polar_radii",
]


def time_derivative(expr: sp.Expr, system: System, order: int = 1) -> sp.Expr:
    """Total time derivative along the motion: sum dE/dq q' + dE/dq' q'' + dE/dt."""
    kin = _kin(system)
    out = sp.sympify(expr)
    for _ in range(order):
        out = _derivative(out, system.t, kin)
    return out


def _kin(system: System) -> tuple:
    """(q, q', q'') of every coordinate: all a time derivative needs of a system."""
    return tuple(
        (c.symbol, c.velocity, c.acceleration)
        for c in system.coordinates + system.chart_coordinates
    )


@functools.lru_cache(maxsize=4096)
def _derivative(expr: sp.Expr, t: sp.Symbol, kin: tuple) -> sp.Expr:
    """One total time derivative, remembered: the loader's checks and the derivation ask
    for the same constraints' velocity forms (24 derivatives for the 8-link chain, each
    taken once)."""
    total = sp.diff(expr, t)
    free = expr.free_symbols
    for q, v, a in kin:
        if q in free:
            total += sp.diff(expr, q) * v
        if v in free:
            total += sp.diff(expr, v) * a
    return total


def _turn(axis: str, angle: sp.Expr) -> sp.Matrix:
    """The rotation by ``angle`` about the x, y or z axis (active, right-handed)."""
    c, s = sp.cos(angle), sp.sin(angle)
    return {
        "x": sp.Matrix([[1, 0, 0], [0, c, -s], [0, s, c]]),
        "y": sp.Matrix([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
        "z": sp.Matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]]),
    }[axis]


TRIGSIMP_OPS = 400
"""A body's rotational energy longer than this is kept expanded (not trig-simplified)."""

_AXES = {"x": sp.Matrix([1, 0, 0]), "y": sp.Matrix([0, 1, 0]), "z": sp.Matrix([0, 0, 1])}


def body_rotation(body: Body) -> sp.Matrix | None:
    """R, world from body (its columns are the body axes in the world frame), of a body
    in space; None for a point or a planar body. Body-fixed turns compose as
    R = R_1 R_2 R_3 (each about the axes the ones before left), space-fixed ones as
    R = R_3 R_2 R_1."""
    if body.orientation is not None:
        return sp.Matrix(body.orientation)
    if body.rotation is None:
        return None
    turns = [_turn(axis, angle) for axis, angle in body.rotation]
    if body.rotation_frame == "space":
        turns = turns[::-1]
    R = sp.eye(3)
    for m in turns:
        R = R * m
    return R


def angular_velocity(system: System, body: Body) -> tuple[sp.Matrix, sp.Matrix] | None:
    """(omega in the world frame, omega in the body frame) of a body in space, linear in
    the velocities; None for a point or a planar body.

    For a sequence of turns the angular velocity is the sum of each turn's rate about its
    own axis, carried to the frame asked for (no simplification needed: Euler's
    kinematic equations); for an ``orientation`` matrix, vee(R^T dR/dt). Remembered for
    the last few (system, body) pairs: the body frame's form is trig-simplified, and the
    partial velocities of every contact ask for it again."""
    spin = _angular_velocity(system.t, _kin(system), body)
    return None if spin is None else (spin[0].copy(), spin[1].copy())


@functools.lru_cache(maxsize=32)
def _angular_velocity(t: sp.Symbol, kin: tuple, body: Body) -> tuple[sp.Matrix, sp.Matrix] | None:
    """Keyed by what it depends on (the time, the coordinates and the body), not by the
    system: the solve's system (the contacts holding at the start) is another object
    than the loader's, and the trig-simplified body-frame form costs a rolling sphere
    0.3 s each time."""
    R = body_rotation(body)
    if R is None:
        return None

    def rate(e):
        return _derivative(sp.sympify(e), t, kin)

    if body.rotation is None:
        dR = R.applyfunc(rate)
        W = R.T * dR  # skew: (omega_body)^
        w_body = sp.Matrix([W[2, 1] - W[1, 2], W[0, 2] - W[2, 0], W[1, 0] - W[0, 1]]) / 2
        w_body = w_body.applyfunc(lambda e: sp.trigsimp(sp.expand(e)))
        return R * w_body, w_body
    turns = list(body.rotation)
    w_world = sp.zeros(3, 1)
    w_body = sp.zeros(3, 1)
    # each turn's rate about its own axis, that axis carried to the world and to the
    # body frame by the turns around it (a turn leaves its own axis where it is), so
    # neither frame's form needs simplifying (Euler's kinematic equations)
    for i, (axis, angle) in enumerate(turns):
        before = [_turn(a, q) for a, q in turns[:i]]
        after = [_turn(a, q) for a, q in turns[i + 1 :]]
        if body.rotation_frame == "space":
            # R = R_k ... R_1: in the world R_k ... R_{i+1} e_i, in the body
            # (R_k ... R_1)^T R_k ... R_{i+1} e_i = R_1^T ... R_{i-1}^T e_i
            to_world = _product(after[::-1])
            to_body = _product([m.T for m in before])
        else:
            # R = R_1 ... R_k: in the world R_1 ... R_{i-1} e_i, in the body
            # (R_{i+1} ... R_k)^T e_i
            to_world = _product(before)
            to_body = _product(after).T
        w_world += to_world * _AXES[axis] * rate(angle)
        w_body += to_body * _AXES[axis] * rate(angle)
    return w_world.applyfunc(sp.expand), w_body.applyfunc(sp.expand)


def _product(matrices: list) -> sp.Matrix:
    out = sp.eye(3)
    for m in matrices:
        out = out * m
    return out


def inertia_matrix(body: Body) -> sp.Matrix:
    """The 3 x 3 inertia tensor about the centre, in the body axes."""
    i = body.inertia
    if isinstance(i, tuple) and len(i) == 3 and isinstance(i[0], tuple):
        return sp.Matrix(i)
    if isinstance(i, tuple):
        return sp.diag(*i)
    return sp.eye(3) * (i if i is not None else 0)


def body_energy(
    system: System, bodies: tuple[Body, ...], gravity: sp.Expr | None
) -> tuple[sp.Expr, sp.Expr]:
    """Kinetic and gravitational potential energy of ``bodies`` (gravity along -y or -z):
    m v^2/2 of the centre, plus I phi'^2/2 (planar) or omega^T I omega/2 (in space, body
    frame)."""
    T = sp.Integer(0)
    V = sp.Integer(0)
    kin = _kin(system)
    for b in bodies:
        Tb, Vb = _body_energy(system.t, kin, b, gravity)
        T += Tb
        V += Vb
    return T, V


@functools.lru_cache(maxsize=64)
def _body_energy(t: sp.Symbol, kin: tuple, b: Body, gravity: sp.Expr | None) -> tuple:
    """One body's (T, V), remembered by what they depend on: the loader builds the
    system more than once (its checks, the contacts holding at the start), and a body
    in space costs a trig simplification each time (0.2 s for a rolling sphere)."""
    T = sp.Integer(0)
    V = sp.Integer(0)
    vel = [_derivative(sp.sympify(x), t, kin) for x in b.position]
    T += b.mass * sum(v**2 for v in vel) / 2
    if b.angle is not None and b.inertia is not None:
        T += b.inertia * _derivative(sp.sympify(b.angle), t, kin) ** 2 / 2
    spin = _angular_velocity(t, kin, b)
    if spin is not None:
        w = spin[1]
        rot = sp.expand((w.T * inertia_matrix(b) * w)[0, 0] / 2)
        # sin^2 + cos^2 of the turns the inertia does not see (a disc's spin about
        # its axle): merged while short; a long form is the same function
        T += sp.trigsimp(rot) if sp.count_ops(rot) < TRIGSIMP_OPS else rot
    if gravity is not None:
        V += b.mass * gravity * b.position[-1]
    return T, V


def partial_velocities(system: System, body: Body, point: tuple[sp.Expr, ...]) -> sp.Matrix:
    """J_P, shape (dim, n_coords): the partial velocities dr_P/dq of the material point of
    ``body`` that sits at ``point`` now: dc/dq + (partial angular velocity) x (P - c), with
    dphi/dq z for a planar body and d omega/dq' for a body in space."""
    dim = len(body.position)
    spin = angular_velocity(system, body) if dim == 3 else None
    rel3 = sp.Matrix([point[k] - body.position[k] for k in range(3)]) if spin else None
    rows = []
    for c in system.coordinates:
        col = [sp.diff(x, c.symbol) for x in body.position]
        if body.angle is not None and dim == 2:
            w = sp.diff(body.angle, c.symbol)
            rel = [point[0] - body.position[0], point[1] - body.position[1]]
            col = [col[0] - w * rel[1], col[1] + w * rel[0]]
        if spin is not None and rel3 is not None:
            w3 = spin[0].applyfunc(lambda e, v=c.velocity: sp.diff(e, v))
            turn = w3.cross(rel3)
            col = [col[k] + turn[k] for k in range(3)]
        rows.append(col)
    return sp.Matrix(rows).T


def contact_partial_velocities(system: System, spec) -> sp.Matrix:
    """J = J_Pa - J_Pb of a constraint's ``force`` spec: the partial velocities of the
    material point it acts on (of body a, less those of body b's point for a contact
    between two movable bodies), so that Q = J^T F."""
    bodies = [system.body(name) for name in spec.bodies]
    J = partial_velocities(system, bodies[0], spec.at)
    if len(bodies) == 2:
        J = J - partial_velocities(system, bodies[1], spec.at)
    return J


def velocity_form(system: System, constraint) -> sp.Expr:
    """F_j: df/dt for a holonomic constraint, g for a velocity constraint."""
    if constraint.holonomic:
        return time_derivative(constraint.expr, system)
    return constraint.expr


def jacobian(exprs, symbols) -> sp.Matrix:
    """d exprs_i / d symbols_j, differentiating each expression only by the symbols it
    contains. SymPy's ``Matrix.jacobian`` differentiates every entry by every symbol: for
    a chain of N links in Cartesian coordinates that is N x 2N derivatives of which 4N are
    not zero (3.9 s at N = 100, 0.05 s this way)."""
    exprs = [sp.sympify(e) for e in exprs]
    symbols = list(symbols)
    out = sp.zeros(len(exprs), len(symbols))
    column = {s: j for j, s in enumerate(symbols)}
    for i, e in enumerate(exprs):
        for s in e.free_symbols & column.keys():
            out[i, column[s]] = sp.diff(e, s)
    return out


def gradient(expr, symbols) -> list[sp.Expr]:
    """[d expr / d s for s in symbols], the same expressions as ``sp.diff`` gives, each
    term of a sum differentiated only by the symbols it contains: for a T of N squared
    velocities ``sp.diff`` by each symbol costs N^2 term derivatives (4.6 s for the check
    of the 100-link chain's T), this N. A constant times a sum (T = m/2*(x1'^2 + ...))
    is the constant times the sum's gradient, as ``sp.diff`` writes it."""
    symbols = list(symbols)
    wanted = set(symbols)

    def walk(e: sp.Expr) -> dict:
        free = e.free_symbols & wanted
        if not free:
            return {}
        if isinstance(e, sp.Add):
            parts: dict = {}
            for term in e.args:
                for s, d in walk(term).items():
                    parts.setdefault(s, []).append(d)
            return {s: sp.Add(*ds) for s, ds in parts.items()}
        if isinstance(e, sp.Mul):
            inner = [f for f in e.args if f.free_symbols & free]
            if len(inner) == 1 and isinstance(inner[0], sp.Add):
                rest = sp.Mul(*[f for f in e.args if f is not inner[0]])
                return {s: rest * d for s, d in walk(inner[0]).items()}
        return {s: sp.diff(e, s) for s in free}

    found = walk(sp.sympify(expr))
    return [found.get(s, sp.Integer(0)) for s in symbols]


def constraint_jacobian(system: System) -> tuple[sp.Matrix, sp.Matrix]:
    """(A, F): A = dF/dq' (m, n) and the velocity forms F (m, 1)."""
    F = sp.Matrix([velocity_form(system, c) for c in system.constraints])
    if not system.constraints:
        return sp.zeros(0, len(system.coordinates)), F
    return jacobian(F, system.qd), F


def polar_radii(system: System) -> dict[sp.Symbol, sp.Symbol]:
    """{radius: angle}: the coordinates that are a polar (or spherical) radius, each with
    an angle it is the radius of. A coordinate r is the radius of coordinate theta when
    T's d^2T/dtheta'^2 is r^2 times something without r (m r^2 in m/2 (r'^2 +
    r^2 theta'^2), m r^2 sin(theta)^2 for the azimuth of a sphere, m r^2 for the lecture's
    cylinder beside its own spin): a distance from the centre, which a configuration
    never has negative. T is the system's own (given, or made from the bodies)."""
    T = sp.sympify(system.T)
    coords = [c for c in system.coordinates if T.has(c.symbol)]
    out: dict[sp.Symbol, sp.Symbol] = {}
    for angle in system.coordinates:
        entry = sp.expand(sp.diff(T, angle.velocity, 2))
        if entry == 0:
            continue
        for r in coords:
            if r is angle or r.symbol in out or not entry.has(r.symbol):
                continue
            rest = sp.expand(entry / r.symbol**2)
            if rest != 0 and not rest.has(r.symbol):
                out[r.symbol] = angle.symbol
    return out
