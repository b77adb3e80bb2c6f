"""Applied loads: a force at a material point of a body, a torque on a body, a spring
(with a damper) between two points. Each is a frozen part that checks itself, like the
parts of :mod:`._parts`; :func:`load_terms` turns them into what the equations of motion
take, by virtual work: generalized forces Q_r = F . dr_P/dq_r and tau . domega/dq'_r,
a spring's energy k (d - L0)^2 / 2 (joins V) and its damper's -c d' dd/dq_r (joins Q).

A problem file's ``[[loads]]`` are read into these (:mod:`lamech.problem`), and
:func:`lamech.model.assemble` takes them for a system built in Python.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Union

import sympy as sp

from ._base import Issues, ModelError, as_tuple, is_expr, join, not_expr
from ._kinematics import angular_velocity, body_rotation, partial_velocities, time_derivative
from ._parts import Body

if TYPE_CHECKING:  # pragma: no cover
    from ._system import System

__all__ = ["AppliedForce", "Torque", "Spring", "Load", "load_terms"]

_FRAMES = ("world", "body")


def _vector_issue(value: Any, where: str) -> tuple[str, str] | None:
    """What is wrong with ``value`` as a point or a vector (2 or 3 expressions)."""
    if not isinstance(value, tuple) or len(value) not in (2, 3):
        n = len(value) if isinstance(value, tuple) else 1
        return (where, f"must be a list of 2 or 3 expressions (x, y[, z]); got {n}")
    for x in value:
        if not is_expr(x):
            return (where, not_expr(x, "each component"))
    return None


def _frame_issues(load: Any, where: str) -> Issues:
    out: Issues = []
    if not isinstance(load.name, str):
        out.append((join(where, "name"), "a name must be a string"))
    if not isinstance(load.body, str):
        out.append((join(where, "body"), "must name a body (a string)"))
    if load.frame not in _FRAMES:
        out.append((join(where, "frame"), 'frame is "world" (default) or "body"'))
    return out


@dataclass(frozen=True)
class AppliedForce:
    """A force on ``body`` at one of its material points.

    ``force`` (2 or 3 components, like the body's position) may depend on the
    coordinates, their velocities and t; ``at`` is the point (positions and t), by
    default the body's centre; ``frame`` "body" turns the force with the body (its
    components along the body's axes), "world" (default) does not. Its generalized force
    is Q_r = F . dr_P/dq_r with dr_P/dq_r the partial velocity of the material point at
    ``at`` (``partial_velocities`` of ``lamech.model._kinematics``).
    """

    body: str
    force: tuple[sp.Expr, ...]
    at: tuple[sp.Expr, ...] | None = None
    frame: str = "world"
    name: str = "load"

    def __post_init__(self) -> None:
        as_tuple(self, "force", "at")
        where = f"load `{self.name}`"
        out = _frame_issues(self, where)
        for field, value in (("force", self.force), ("at", self.at)):
            if value is not None and (issue := _vector_issue(value, join(where, field))):
                out.append(issue)
        ModelError.check(out)


@dataclass(frozen=True)
class Torque:
    """A torque on ``body``: one expression (counterclockwise) on a planar body with an
    angle, 3 components on a body in space with a rotation or orientation (``frame``
    "body": along the body's axes). Its generalized force is tau . domega/dq'_r."""

    body: str
    torque: Any  # an Expr (planar), or 3 Exprs (in space)
    frame: str = "world"
    name: str = "load"

    def __post_init__(self) -> None:
        as_tuple(self, "torque")
        where = f"load `{self.name}`"
        out = _frame_issues(self, where)
        tau = self.torque
        if isinstance(tau, tuple):
            if len(tau) != 3 or not all(is_expr(x) for x in tau):
                out.append((join(where, "torque"), "a torque in space is 3 expressions"))
        elif not is_expr(tau):
            out.append((join(where, "torque"), not_expr(tau, "the torque")))
        ModelError.check(out)


@dataclass(frozen=True)
class Spring:
    """A linear spring of stiffness ``k`` and natural length ``length`` (0: a zero-length
    spring, energy ``k d.d / 2``), with a damper ``damping``, between the points ``start``
    and ``end`` (each 2 or 3 expressions in the coordinates and t, so either end may move
    with the bodies; d = end - start). k, length and damping are expressions of the
    parameters. The energy ``k (|d| - L0)^2 / 2`` joins V, the damper's generalized force
    ``-c (d|d|/dt) d|d|/dq_r`` joins Q."""

    start: tuple[sp.Expr, ...]
    end: tuple[sp.Expr, ...]
    k: sp.Expr
    length: sp.Expr = sp.Integer(0)
    damping: sp.Expr = sp.Integer(0)
    name: str = "spring"

    def __post_init__(self) -> None:
        as_tuple(self, "start", "end")
        where = f"load `{self.name}`"
        out: Issues = []
        if not isinstance(self.name, str):
            out.append((join(where, "name"), "a name must be a string"))
        for field, value in (("spring.from", self.start), ("spring.to", self.end)):
            if issue := _vector_issue(value, join(where, field)):
                out.append(issue)
        if not out and len(self.start) != len(self.end):
            out.append((join(where, "spring"), "from and to need the same number of components"))
        for field, value in (("k", self.k), ("length", self.length), ("damping", self.damping)):
            if not is_expr(value):
                out.append((join(where, f"spring.{field}"), not_expr(value, field)))
        ModelError.check(out)


Load = Union[AppliedForce, Torque, Spring]
"""Any applied load."""


def load_terms(
    system: System, bodies: Sequence[Body], loads: Sequence[Load]
) -> tuple[tuple[sp.Expr, ...], sp.Expr]:
    """(Q, V): the generalized forces of ``loads``, one per coordinate of ``system``, and
    the springs' energy.

    ``system`` gives the coordinates and t (its T and V are not used; the skeleton of
    :func:`lamech.model.assemble` will do); ``bodies`` are the bodies the loads name.

    Raises
    ------
    ModelError
        Every load that does not fit the bodies: an unknown body, a force or point of
        the wrong size, a body frame of a point mass, a torque on a body that does not
        turn. ``where`` is ``loads[i] `name` field``.
    """
    n = len(system.coordinates)
    Q = [sp.Integer(0)] * n
    V = sp.Integer(0)
    issues: Issues = []
    by_name = {b.name: b for b in bodies}
    for i, load in enumerate(loads):
        where = f"loads[{i + 1}] `{load.name}`"
        if isinstance(load, Spring):
            energy, damping = _spring(system, load)
            V += energy
            Q = [a + b for a, b in zip(Q, damping)]
            continue
        if not isinstance(load, (AppliedForce, Torque)):
            issues.append((where, "a load is an AppliedForce, a Torque or a Spring"))
            continue
        body = by_name.get(load.body)
        if body is None:
            issues.append(
                (
                    f"{where} body",
                    f"`body` must name one of the [[bodies]] ({', '.join(by_name) or 'none'})",
                )
            )
            continue
        R = body_rotation(body)
        if load.frame == "body" and R is None and body.angle is None:
            issues.append((f"{where} frame", "a point mass has no body frame"))
            continue
        terms = (
            _force(system, body, load, R, where)
            if isinstance(load, AppliedForce)
            else _torque(system, body, load, R, where)
        )
        if isinstance(terms, tuple):
            issues.append(terms)
        else:
            Q = [a + b for a, b in zip(Q, terms)]
    ModelError.check(issues)
    return tuple(Q), V


def _force(
    system: System, body: Body, load: AppliedForce, R: sp.Matrix | None, where: str
) -> list | tuple[str, str]:
    dim = len(body.position)
    at = load.at if load.at is not None else body.position
    if len(load.force) != dim or len(at) != dim:
        return (f"{where} force", f"force and at need {dim} components, as the body's position")
    Fw = sp.Matrix(load.force)
    if load.frame == "body":
        Fw = (R if R is not None else _planar_turn(body.angle)) * Fw
    J = partial_velocities(system, body, tuple(at))
    return [(Fw.T * J[:, k])[0] for k in range(len(system.coordinates))]


def _torque(
    system: System, body: Body, load: Torque, R: sp.Matrix | None, where: str
) -> list | tuple[str, str]:
    tau = load.torque
    if len(body.position) == 2:
        if body.angle is None:
            return (f"{where} torque", "a torque needs a body that turns (an angle)")
        if isinstance(tau, tuple):
            return (f"{where} torque", "a torque on a planar body is one expression")
        return [tau * sp.diff(body.angle, c.symbol) for c in system.coordinates]
    spin = angular_velocity(system, body)
    if spin is None or not isinstance(tau, tuple):
        return (
            f"{where} torque",
            "a torque in space needs 3 components and a body with a rotation or orientation",
        )
    tw = sp.Matrix(tau)
    if load.frame == "body" and R is not None:
        tw = R * tw
    return [(tw.T * spin[0].diff(c.velocity))[0] for c in system.coordinates]


def _spring(system: System, spring: Spring) -> tuple[sp.Expr, list[sp.Expr]]:
    """(energy, generalized damping forces) of a spring (and damper) between two points
    given as expressions (each may move with the coordinates)."""
    k, L0, c = spring.k, spring.length, spring.damping
    d = sp.Matrix(spring.end) - sp.Matrix(spring.start)
    length = sp.sqrt(sum(x**2 for x in d)) if L0 != 0 else None
    if length is None:  # a zero-length spring: k |d|^2 / 2, no square root
        energy = k * sum(x**2 for x in d) / 2
        rate = sum(x * time_derivative(x, system) for x in d)  # |d| |d|'
        Q = [
            -c * rate * sum(x * sp.diff(x, q.symbol) for x in d) / sum(x**2 for x in d)
            if c != 0
            else sp.Integer(0)
            for q in system.coordinates
        ]
        return energy, Q
    energy = k * (length - L0) ** 2 / 2
    rate = time_derivative(length, system)
    Q = [
        -c * rate * sp.diff(length, q.symbol) if c != 0 else sp.Integer(0)
        for q in system.coordinates
    ]
    return energy, Q


def _planar_turn(angle: sp.Expr) -> sp.Matrix:
    """The plane rotation by ``angle`` (a planar body's frame)."""
    return sp.Matrix([[sp.cos(angle), -sp.sin(angle)], [sp.sin(angle), sp.cos(angle)]])
