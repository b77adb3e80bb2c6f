"""Equilibria in the file's own coordinates: those the search on every branch of the
constraints finds (:meth:`~._rest.RestTest.search`) and the reduced equations of
:mod:`._modes` do not give, and those where the reduced equations are singular or too
long to differentiate, as :class:`~._equilibria.Equilibrium` objects linearised on the
constraints' tangent space (:meth:`~._rest.RestTest.linearised`), with the multipliers
of the KKT solve at rest and the linear system in the coordinates regular there.
"""

from __future__ import annotations

import numpy as np

from ..expr import to_text
from ._modes import (
    Equilibrium,
    Linear,
    Mode,
    _holding,
    _pick,
    _real,
    _snapped,
    _spectrum,
    _tangent_check,
)
from ._rest import RestTest

__all__ = ["full_equilibrium", "other_branches"]


def other_branches(sol, pv, rest: RestTest, found) -> list[Equilibrium]:
    """The equilibria the search in the file's coordinates finds
    (:meth:`~._rest.RestTest.search`: every branch of the constraints, every constraint
    active) that the reduced equations did not give (the trammel hanging at y = -l while
    y = +sqrt(l^2 - x^2) was eliminated), linearised in the file's coordinates
    (:func:`full_equilibrium`): the reduced equations' closed forms hold on their
    branch and with the start's contacts only."""
    system, red = sol.system, sol.reduction
    names = [c.name for c in system.coordinates]
    try:
        init = np.array([_real(c.initial, pv) for c in system.coordinates])
    except (TypeError, ValueError):
        init = np.zeros(len(names))
    known = [
        np.array([e.values[n] for n in names])
        for e in found
        if e.exists and all(n in e.values for n in names)
    ]
    out = []
    for q, lam in rest.search(init):
        if any(rest.same(q, k) for k in known):
            continue
        known.append(q)
        env = {**pv, system.t: 0.0, **dict(zip(system.q, q))}
        off = _off_branch(red, env) if system.chart is None else []  # (a chart: in u)
        if off:
            why = "off the branch the reduced equations take (" + "; ".join(off) + ")"
        else:
            why = "not a solution the reduced equations gave"
        why += ": found and linearised in the file's coordinates, every constraint kept"
        out.append(full_equilibrium(sol, rest, q, lam, None, None, why))
    return out


def _off_branch(red, env: dict) -> list[str]:
    """The eliminated coordinates whose elimination (a branch of a root) does not give
    their value in ``env`` (a point of the constraints), as "y = sqrt(l^2 - x^2)"."""
    out = []
    for c, expr in red.eliminated:
        try:
            v = _real(red.position_substitution[c.symbol], env)
        except (TypeError, ValueError):
            v = float("nan")
        if not abs(v - env[c.symbol]) <= 1e-7 * (1 + abs(env[c.symbol])):
            out.append(f"{c.name} = {to_text(expr)}")
    return out


def full_equilibrium(sol, rest: RestTest, q, lam, condition, point, why: str) -> Equilibrium:
    """The equilibrium at q (every coordinate; multipliers ``lam`` from the KKT solve)
    linearised in the file's coordinates with every constraint kept
    (:meth:`~._rest.RestTest.linearised`), where the reduced equations do not reach, are
    singular or too long (``why`` says which, in the note); ``point`` its independent
    coordinates (None: every coordinate, as found)."""
    system = sol.system
    names = [c.name for c in system.coordinates]
    if point is None:
        at = {n: _snapped(float(v)) for n, v in zip(names, q)}
    else:
        at = {str(x): v for x, v in point.items()}
    values = {n: float(_snapped(float(v))) + 0.0 for n, v in zip(names, q)}  # no 1e-17
    notes = [why]
    multipliers = {c.name: float(x) for c, x in zip(system.constraints, lam)}
    multipliers, holds = _holding(system, multipliers, notes)
    lin = rest.linearised(np.asarray(q, dtype=float), np.asarray(lam, dtype=float))
    stability: str | None = None
    found: tuple[Mode, ...] = ()
    linear, check = None, None
    if lin is not None:
        J, N = lin
        w, Y = np.linalg.eig(J)
        stability, found = _spectrum(names, w, Y, N, N.shape[1], [], {})
        linear = _full_named(rest, np.asarray(q, dtype=float), J, N, names)
        # the same law by SymPy's Jacobians, evaluated apart from the generated code
        check = _tangent_check(sol, dict(zip(names, map(float, q))), multipliers, found)
        if check is not None and check.startswith("DISAGREES"):
            notes.append(check)
            check = None
    return Equilibrium(
        at,
        values,
        condition,
        True,
        multipliers,
        holds,
        "; ".join(notes),
        stability,
        found,
        linear,
        check,
    )


def _full_named(
    rest: RestTest, q: np.ndarray, J: np.ndarray, N: np.ndarray, names
) -> Linear | None:
    """The linear system J (in (z, z'), q = q0 + N z) in the coordinates regular at q0
    (picked from N), with each multiplier's first-order change from the KKT solve
    (central differences)."""
    d = N.shape[1]
    S = _pick(N)
    Tp = N[S]
    if d and np.linalg.cond(Tp) > 1e10:
        return None
    T = np.block([[Tp, np.zeros((d, d))], [np.zeros((d, d)), Tp]])
    Ti = np.linalg.inv(T) if d else np.zeros((0, 0))
    A = T @ J @ Ti
    eps = 1e-6 * (1.0 + float(np.abs(q).max(initial=0.0)))
    rows = []
    for i in range(2 * d):
        z = Ti[:, i]
        dq, dqd = N @ z[:d], N @ z[d:]
        plus = rest.solve(q + eps * dq, eps * dqd)[1]
        minus = rest.solve(q - eps * dq, -eps * dqd)[1]
        rows.append((plus - minus) / (2 * eps))
    lam = {}
    if rows:
        G = np.array(rows).T  # (n_constraints, 2 d)
        for c, row in zip(rest.system.constraints, G):
            if np.isfinite(row).all():
                lam[c.name] = tuple(float(round(x, 9)) + 0.0 for x in row)
    state = tuple(names[i] for i in S) + tuple(names[i] + "'" for i in S)
    return Linear(state, tuple(tuple(float(round(x, 12)) + 0.0 for x in r) for r in A), lam)
