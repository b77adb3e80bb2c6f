"""The rules a system obeys at the numbers of its initial state: the state meets every
constraint (a unilateral contact may start open), T, V and the forces are finite there
and T is not negative, the constraints that hold are independent, and a massless body
has its motion given by the constraints to something with inertia.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
import sympy as sp

from ..expr import to_text
from ._base import Issues
from ._checks import (
    INITIAL_TOLERANCE,
    dependent_constraints,
    holding_at_start,
    initial_values,
    massless,
    numeric_matrix,
    value,
    without_inertia,
)
from ._hints import zero_masses
from ._kinematics import constraint_jacobian, gradient, jacobian, time_derivative

if TYPE_CHECKING:  # pragma: no cover
    from ._system import System

__all__ = ["initial_issues", "dependent_issues"]


def initial_issues(s: System) -> Issues:
    """The initial state meets every constraint (a unilateral contact may start open, see
    :func:`~lamech.model._checks.open_at_start`, not on its forbidden side)."""

    out: Issues = []
    pv = s.parameter_values
    state = {}
    for c in s.coordinates:
        for sym, expr, label in (
            (c.symbol, c.initial, "initial"),
            (c.velocity, c.initial_velocity, "velocity"),
        ):
            try:
                state[sym] = value(expr, pv)
            except (TypeError, ValueError):
                state[sym] = float("nan")
            if not math.isfinite(state[sym]):
                out.append(
                    (
                        f"coordinates.{c.name}.{label}",
                        "the initial value is not a finite real number at the parameter values",
                    )
                )
    if out:
        return out
    scale = 1 + max((abs(v) for v in state.values()), default=0.0)
    tol = INITIAL_TOLERANCE * scale
    # Floats once, not in each value() call (the 30-link chain: 120 entries, 60 calls).
    env = {sym: sp.Float(v, 30) for sym, v in {**pv, **state, s.t: 0.0}.items()}
    out += _energy_at_start_issues(s, env, state)
    for i, con in enumerate(s.constraints):
        where = f"constraints[{i + 1}] `{con.name}`"
        try:
            if con.holonomic:
                res = value(con.expr, env)
                vres = value(time_derivative(con.expr, s), env)
            else:
                res, vres = 0.0, value(con.expr, env)
        except (TypeError, ValueError):
            out.append(
                (
                    where,
                    "cannot evaluate the constraint at the initial state "
                    "(complex or undefined value)",
                )
            )
            continue
        if con.unilateral and con.holonomic and (res > tol or (abs(res) <= tol and vres > tol)):
            continue  # an open (or opening) contact: allowed, see open_at_start
        if con.unilateral and con.holonomic and res < -tol:
            out.append(
                (
                    where,
                    f"the initial state is on the forbidden side of the "
                    f"unilateral constraint: f = {res:.6g} < 0 (f >= 0 is "
                    "allowed); change the coordinates' initial values",
                )
            )
        elif abs(res) > tol:
            out.append(
                (
                    where,
                    f"the initial state violates the constraint: f = {res:.6g} "
                    "(should be 0); change the coordinates' initial values",
                )
            )
        elif abs(vres) > tol:
            label = "df/dt" if con.holonomic else "the constraint"
            out.append(
                (
                    where,
                    f"the initial velocities violate the constraint: {label} = "
                    f"{vres:.6g} (should be 0); change the coordinates' initial "
                    "velocities",
                )
            )
    return out


def _energy_at_start_issues(s: System, env: dict, state: dict) -> Issues:
    """T, V and the generalized forces are finite real numbers at the initial state (a
    pole there, V = 1/(theta - 1/2) at theta = 1/2, would make every multiplier zoo)."""

    out: Issues = []
    parts = [("lagrangian.T", "T", s.T), ("lagrangian.V", "V", s.V)]
    parts += [
        (f"forces.{c.name}", f"the force on {c.name}", Q)
        for c, Q in zip(s.coordinates, s.forces)
        if Q != 0
    ]
    for where, label, expr in parts:
        try:
            x = value(expr, env)
        except (TypeError, ValueError, ArithmeticError):
            x = float("nan")
        if math.isfinite(x):
            continue
        at = ", ".join(f"{sym} = {state[sym]:.6g}" for sym in state if expr.has(sym))
        out.append(
            (
                where,
                f"{label} is not a finite real number at the initial state"
                f"{f' ({at})' if at else ''}: a pole or a complex value there; start "
                f"elsewhere or correct {label}",
            )
        )
    if not out:
        out += _negative_kinetic_issues(s, env)
    return out


def _negative_kinetic_issues(s: System, env: dict) -> Issues:
    """T is never negative: its mass matrix d^2T/dq'^2 at the initial state has no
    negative eigenvalue (zero ones are a massless coordinate, allowed where the
    constraints give it inertia)."""

    qd = [c.velocity for c in s.coordinates if s.T.has(c.velocity)]
    if not qd:
        return []
    try:
        M = numeric_matrix(jacobian(gradient(s.T, qd), qd), env)
    except (TypeError, ValueError, ArithmeticError):
        return []
    if not np.all(np.isfinite(M)):
        return []
    w, v = np.linalg.eigh((M + M.T) / 2)
    if w[0] >= -1e-12 * max(1.0, float(np.abs(w).max())):
        return []
    along = qd[int(np.argmax(np.abs(v[:, 0])))]
    return [
        (
            "lagrangian.T",
            f"T is negative for some velocities at the initial state (its mass matrix "
            f"d^2T/dq'^2 has the eigenvalue {w[0]:.6g}, mostly along {along}): a kinetic "
            "energy is never negative; check the signs and the masses in T",
        )
    ]


def dependent_issues(s: System) -> Issues:
    """The KKT matrix at the start: constraints that are dependent there, else a
    massless body whose motion nothing gives inertia (:func:`_massless_issues`)."""

    out: Issues = []
    for group, singular in dependent_constraints(s):
        idx = [c.name for c in s.constraints].index(group[0])
        where = f"constraints[{idx + 1}] `{group[0]}`"
        names = (
            " and ".join(f"`{n}`" for n in group)
            if len(group) <= 2
            else ", ".join(f"`{n}`" for n in group)
        )
        if singular:
            out.append(
                (
                    where,
                    f"constraints {names} are dependent at the initial state (a "
                    "singular configuration): forces cannot be uniquely "
                    "determined there; start elsewhere",
                )
            )
        else:
            out.append(
                (
                    where,
                    f"constraints {names} are dependent: forces cannot be "
                    "uniquely determined; remove the redundant one",
                )
            )
    return out or _massless_issues(s)


def _massless_issues(s: System) -> Issues:
    """A massless body (mass 0 at the parameter values), or a parameter that is 0 and is a
    coordinate's mass in T (:func:`lamech.model._hints.zero_masses`: m = 0 in
    T = m/2*x'^2), that leaves a motion the constraints allow without inertia at the
    initial state: the KKT matrix is singular and the accelerations cannot be found.
    The issue is placed at the body's mass, or at the parameter's line. Only systems
    with a massless body or a zero mass pay for this check (M at numbers)."""

    pv = s.parameter_values
    light = zero_masses(s)
    if not massless(s, pv) and not light:
        return []
    try:
        env = {**pv, **initial_values(s), s.t: 0.0}
        qd = sp.Matrix(s.qd)
        M = numeric_matrix(jacobian(gradient(s.L, qd), qd), env)
        A = numeric_matrix(constraint_jacobian(holding_at_start(s))[0], env)
    except (TypeError, ValueError):
        return []  # not numbers at the start: reported elsewhere, or left to solve
    weak = without_inertia(s, M, A.reshape(-1, len(s.coordinates)), env)
    if weak is None:
        return []
    named = [(p, c) for p, c in light if c.name in weak.coordinates]
    if not weak.massless and named:
        p, c = named[0]
        return [
            (
                f"parameters.{p.name}",
                f"parameter `{p.name}` = 0 is the mass of `{c.name}` (d^2T/d{c.name}'^2 = "
                f"{to_text(sp.diff(s.T, c.velocity, 2))}), so {weak.describe(s)} and the "
                "accelerations cannot be found (the KKT matrix is singular at the initial "
                f"state); give `{p.name}` its value (a mass > 0), or a constraint that ties "
                f"`{c.name}` to something with mass",
            )
        ]
    if not weak.massless:
        return []  # no massless body in it: solve names the coordinate
    i = weak.massless[0]
    return [
        (
            f"bodies[{i + 1}] `{s.bodies[i].name}` mass",
            f"{weak.describe(s)}, so the accelerations cannot be found (the KKT "
            "matrix is singular at the initial state); give the body a mass, or a "
            "constraint that ties its motion to a body with one",
        )
    ]
