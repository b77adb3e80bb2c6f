"""Kinematics of a :class:`~lamech.model.System`: time derivatives along the motion, the
energy of its bodies, and the partial velocities of their material points."""

from __future__ import annotations

import sympy as sp

from ._system import Body, System

__all__ = [
    "time_derivative",
    "body_energy",
    "partial_velocities",
    "contact_partial_velocities",
    "velocity_form",
    "constraint_jacobian",
]


def time_derivative(expr: sp.Expr, system: System, order: int = 1) -> sp.Expr:
    """Total time derivative along the motion: sum dE/dq q' + dE/dq' q'' + dE/dt."""
    out = sp.sympify(expr)
    for _ in range(order):
        total = sp.diff(out, system.t)
        for c in system.coordinates + system.chart_coordinates:
            if out.has(c.symbol):
                total += sp.diff(out, c.symbol) * c.velocity
            if out.has(c.velocity):
                total += sp.diff(out, c.velocity) * c.acceleration
        out = total
    return out


def body_energy(
    system: System, bodies: tuple[Body, ...], gravity: sp.Expr | None
) -> tuple[sp.Expr, sp.Expr]:
    """Kinetic and gravitational potential energy of ``bodies`` (gravity along -y or -z)."""
    T = sp.Integer(0)
    V = sp.Integer(0)
    for b in bodies:
        vel = [time_derivative(x, system) for x in b.position]
        T += b.mass * sum(v**2 for v in vel) / 2
        if b.angle is not None and b.inertia is not None:
            T += b.inertia * time_derivative(b.angle, system) ** 2 / 2
        if gravity is not None:
            V += b.mass * gravity * b.position[-1]
    return T, V


def partial_velocities(system: System, body: Body, point: tuple[sp.Expr, ...]) -> sp.Matrix:
    """J_P, shape (dim, n_coords): the partial velocities dr_P/dq of the material point of
    ``body`` that sits at ``point`` now (rigid planar body: dc/dq + dphi/dq z x (P - c))."""
    dim = len(body.position)
    rows = []
    for c in system.coordinates:
        col = [sp.diff(x, c.symbol) for x in body.position]
        if body.angle is not None and dim == 2:
            w = sp.diff(body.angle, c.symbol)
            rel = [point[0] - body.position[0], point[1] - body.position[1]]
            col = [col[0] - w * rel[1], col[1] + w * rel[0]]
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


def constraint_jacobian(system: System) -> tuple[sp.Matrix, sp.Matrix]:
    """(A, F): A = dF/dq' (m, n) and the velocity forms F (m, 1)."""
    F = sp.Matrix([velocity_form(system, c) for c in system.constraints])
    if not system.constraints:
        return sp.zeros(0, len(system.coordinates)), F
    return F.jacobian(sp.Matrix(system.qd)), F
