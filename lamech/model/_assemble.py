"""A :class:`~lamech.System` from what a physicist writes: T and V given, or L
(split into T and V), or neither (the bodies' kinetic and gravitational energy), plus
generalized forces and applied loads (forces at points, torques, springs and dampers).

This is the modelling a problem file's sections imply (:mod:`lamech.problem` parses a
file and calls :func:`assemble`); a system built in Python gets the same by calling it:

>>> import sympy as sp
>>> from lamech.model import Body, Spring, assemble, coordinate, parameters
>>> m, k = parameters({"m": 2.0, "k": 50.0})
>>> x = coordinate("x", initial=0.1)
>>> s = assemble(
...     "Mass on a spring", (m, k), (x,),
...     bodies=(Body("block", m.symbol, (x.symbol, sp.Integer(0))),),
...     loads=(Spring((sp.Integer(0), sp.Integer(0)), (x.symbol, sp.Integer(0)), k.symbol),),
... )
>>> s.T, s.V
(m*x'**2/2, k*x**2/2)
"""

from __future__ import annotations

import random
from collections.abc import Mapping, Sequence
from typing import Any

import sympy as sp

from ..expr import to_text
from ._base import Issues, ModelError
from ._kinematics import body_energy
from ._loads import AppliedForce, Load, Spring, Torque, load_terms
from ._parts import Body, Constraint, Coordinate, Parameter
from ._system import System
from ._whole import Scope

__all__ = ["assemble", "skeleton", "split_lagrangian", "energy_notes"]

T_SYMBOL = sp.Symbol("t", real=True)


def skeleton(
    title: str,
    parameters: Sequence[Parameter],
    coordinates: Sequence[Coordinate],
    t: sp.Symbol = T_SYMBOL,
) -> System:
    """The coordinates and parameters alone, checked as such: a System for the kinematics
    of bodies and loads (time derivatives need only q and t). Its T is a stand-in, the
    sum of the squared velocities, and it has no constraints."""
    return System(
        title=title,
        parameters=tuple(parameters),
        coordinates=tuple(coordinates),
        T=sum((c.velocity**2 for c in coordinates), sp.Integer(0)),
        V=sp.Integer(0),
        constraints=(),
        t=t,
    )


def split_lagrangian(L: sp.Expr, velocities: Sequence[sp.Symbol]) -> tuple[sp.Expr, sp.Expr]:
    """(T, V) of a Lagrangian: T the terms of the expanded ``L`` with a velocity in them,
    V = T - L the rest, negated."""
    poly = sp.expand(L)
    T = sum((a for a in sp.Add.make_args(poly) if a.has(*velocities)), sp.Integer(0))
    return T, sp.expand(T - L)


def energy_notes(
    frame: System,
    bodies: Sequence[Body],
    gravity: sp.Expr | None,
    T: sp.Expr | None,
    V: sp.Expr | None,
) -> list[str]:
    """Warnings where a T (or, with gravity, a V) given alongside bodies differs from
    the bodies' own energy: a missing term is likely. None compares nothing."""
    if not bodies:
        return []
    Tb, Vb = body_energy(frame, tuple(bodies), gravity)
    notes = []
    checks = [("T", T, Tb)]
    if gravity is not None:
        checks.append(("V", V, Vb))
    for label, given, kin in checks:
        if given is None or _numerically_equal(given, kin, frame):
            continue
        diff = sp.simplify(given - kin) if sp.count_ops(given - kin) < 200 else given - kin
        if label == "T":
            notes.append(
                f"[lagrangian] T differs from the kinetic energy of [[bodies]] by "
                f"{to_text(diff)}; check for a missing term (T is used as given)"
            )
        else:
            notes.append(
                f"[lagrangian] V differs from the gravitational energy of "
                f"[[bodies]] by {to_text(diff)} (fine if that is a spring or "
                "other potential; V is used as given)"
            )
    return notes


def assemble(
    title: str,
    parameters: Sequence[Parameter],
    coordinates: Sequence[Coordinate],
    constraints: Sequence[Constraint] = (),
    *,
    T: sp.Expr | None = None,
    V: sp.Expr | None = None,
    L: sp.Expr | None = None,
    bodies: Sequence[Body] = (),
    gravity: sp.Expr | None = None,
    forces: Mapping[str, sp.Expr] | Sequence[sp.Expr] | None = None,
    loads: Sequence[Load] = (),
    t: sp.Symbol = T_SYMBOL,
    **fields: Any,
) -> System:
    """A checked :class:`~lamech.System`, modelled as a problem file is.

    Parameters
    ----------
    title, parameters, coordinates, constraints
        As the System's fields.
    T, V, L
        The energies: T and V (each may be left out), or L alone, which is split into T
        (its terms with a velocity) and V (the rest, negated; :func:`split_lagrangian`).
        T left out is the kinetic energy of ``bodies`` (:func:`lamech.model.body_energy`),
        V left out their gravitational energy when there is ``gravity``, else 0. A T or V
        given beside bodies that differs from theirs is said in the System's ``notes``.
    bodies, gravity
        The bodies (:class:`~lamech.Body`) and the acceleration of gravity (along
        -y, or -z in space).
    forces
        Generalized forces Q^nc, by coordinate name (a mapping) or one per coordinate.
    loads
        :class:`~lamech.model.AppliedForce`, :class:`~lamech.model.Torque` and
        :class:`~lamech.model.Spring` loads: their generalized forces join ``forces``,
        the springs' energy joins V (:func:`lamech.model.load_terms`).
    t
        The time symbol.
    **fields
        The System's other fields (``scenery``, ``chart``, ``sliders``, ``source``,
        ``notes``).

    Raises
    ------
    ModelError
        Everything wrong: a System's own checks, L given with T or V, no T and no
        bodies, a load that does not fit the bodies.
    """
    frame = skeleton(title, parameters, coordinates, t)
    given_T, given_V = (T, V) if L is None else (None, None)
    T, V = _energies(frame, bodies, gravity, T, V, L)
    Q = _forces(coordinates, forces)
    if loads:
        ModelError.check(_load_issues(frame, loads))
        extra_Q, extra_V = load_terms(frame, bodies, loads)
        Q = [f + q for f, q in zip(Q, extra_Q)]
        V = V + extra_V
    # a given V is compared with the spring energy in it: the note says it may be a spring
    notes = energy_notes(
        frame,
        bodies,
        gravity,
        T if given_T is not None else None,
        V if given_V is not None else None,
    )
    fields["notes"] = tuple(fields.get("notes", ())) + tuple(notes)
    return System(
        title=title,
        parameters=tuple(parameters),
        coordinates=tuple(coordinates),
        T=T,
        V=V,
        constraints=tuple(constraints),
        bodies=tuple(bodies),
        gravity=gravity,
        forces=tuple(Q),
        t=t,
        **fields,
    )


def _energies(
    frame: System,
    bodies: Sequence[Body],
    gravity: sp.Expr | None,
    T: sp.Expr | None,
    V: sp.Expr | None,
    L: sp.Expr | None,
) -> tuple[sp.Expr, sp.Expr]:
    """(T, V) as :func:`assemble` says: L split, or each of T and V given or the bodies'."""
    if L is not None:
        if T is not None or V is not None:
            raise ModelError([("lagrangian", "give either L, or T and V, not both")])
        return split_lagrangian(L, frame.qd)
    if T is None and not bodies:
        raise ModelError(
            [("lagrangian.T", "missing T (the kinetic energy); give T and V, or L, or bodies")]
        )
    if T is None:
        T = body_energy(frame, tuple(bodies), gravity)[0]
    if V is None:
        V = (
            body_energy(frame, tuple(bodies), gravity)[1]
            if gravity is not None and bodies
            else sp.Integer(0)
        )
    return T, V


def _forces(
    coordinates: Sequence[Coordinate], forces: Mapping[str, sp.Expr] | Sequence[sp.Expr] | None
) -> list[sp.Expr]:
    """One generalized force per coordinate, 0 where none is given."""
    n = len(coordinates)
    if forces is None:
        return [sp.Integer(0)] * n
    if not isinstance(forces, Mapping):
        if len(forces) != n:
            raise ModelError(
                [("forces", "forces are one generalized force per coordinate (or none)")]
            )
        return list(forces)
    by_name = {c.name: i for i, c in enumerate(coordinates)}
    out: list[sp.Expr] = [sp.Integer(0)] * n
    issues = []
    for name, value in forces.items():
        if name not in by_name:
            known = ", ".join(by_name)
            issues.append((f"forces.{name}", f"`{name}` is not a coordinate; known: {known}"))
        else:
            out[by_name[name]] = value
    ModelError.check(issues)
    return out


def _load_issues(frame: System, loads: Sequence[Load]) -> Issues:
    """Each load's expressions in the symbols their field allows (a problem file's parser
    allows no other): a force in the velocities, points in the positions, a spring's
    constants in the parameters."""
    scope = Scope(frame)
    out: Issues = []
    for i, load in enumerate(loads):
        where = f"loads[{i + 1}] `{getattr(load, 'name', '')}`"
        fields: list[tuple[str, str, tuple]] = []
        if isinstance(load, AppliedForce):
            fields = [("forces", "force", load.force), ("at", "at", load.at or ())]
        elif isinstance(load, Torque):
            tau = load.torque
            fields = [("forces", "torque", tau if isinstance(tau, tuple) else (tau,))]
        elif isinstance(load, Spring):
            fields = [("at", "spring.from", load.start), ("at", "spring.to", load.end)]
            fields += [
                ("spring", f"spring.{name}", (getattr(load, name),))
                for name in ("k", "length", "damping")
            ]
        for field, label, exprs in fields:
            problem = next((p for e in exprs if (p := scope.problem(e, field))), None)
            if problem is not None:
                out.append((f"{where} {label}", problem))
    return out


def _numerically_equal(a: sp.Expr, b: sp.Expr, system: System, tries: int = 3) -> bool:
    """Compare two expressions at a few seeded random states (parameters at their values)."""
    rng = random.Random(1234)
    symbols = sorted(a.free_symbols | b.free_symbols, key=str)
    pv = system.parameter_values
    for _ in range(tries):
        env = {s: sp.sympify(pv.get(s, rng.uniform(0.3, 1.3))) for s in symbols}
        try:
            # xreplace, not subs: a plain swap of symbols for numbers, ten times faster
            da, db = complex(a.xreplace(env).evalf()), complex(b.xreplace(env).evalf())
        except (TypeError, ValueError):
            return False
        if abs(da - db) > 1e-9 * (1 + abs(da) + abs(db)):
            return False
    return True
