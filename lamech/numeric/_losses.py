"""The kinetic energy an impact loses, T- - T+, from its logged state (the velocities
after it), its impulse and its gap velocity before it.

The log keeps the state after the impact. The velocities before it are recovered from
the impact law: the jump is along the constraint rows that carried impulses,
M (v+ - v-) = A_R^T P_R, where R is the impacting constraint j and the rows that hold
through the impact (their constraint, and for a holonomic one its value, satisfied at
v+ within the tolerance); v- satisfies those rows' velocity form and A_j v- + b_j = F-
(the logged ``velocity_before``). The recovered impulse on j is checked against the
logged one: where they disagree (an impulse on a row that does not hold, a slipping
friction row of another contact) the loss is left unknown (None) rather than guessed.
"""

from __future__ import annotations

import numpy as np

from ._events import Event, EventKind

__all__ = ["with_energy_lost"]

_HOLD = 1e-7  # a row holds when |A_r v + b_r| (and |f_r|) is below this times its scale
_AGREE = 1e-6  # the recovered impulse on j agrees with the logged one to this, relative


def _lost(ns, p: np.ndarray, normals: np.ndarray, ev: Event) -> float | None:
    if ev.impulse is None or ev.velocity_before is None:
        return None
    impulse, before = float(ev.impulse), float(ev.velocity_before)
    names = list(ns.coordinate_names)
    q = np.array([ev.coordinates[c] for c in names], dtype=float)
    v = np.array([ev.coordinates[c + "'"] for c in names], dtype=float)
    j = list(ns.constraint_names).index(ev.constraint)
    t = float(ev.t)
    M = np.asarray(ns.dynamics(t, q, v, p)[0], dtype=float)
    f, A, b = (np.asarray(x, dtype=float) for x in ns.constraints(t, q, p))
    scale = 1.0 + float(np.max(np.abs(v), initial=0.0))
    rows = [j]
    for r in range(len(f)):
        if r == j or normals[r] == j:
            continue
        size = scale * (1.0 + float(np.max(np.abs(A[r]), initial=0.0))) + abs(b[r])
        if abs(A[r] @ v + b[r]) <= _HOLD * size and abs(f[r]) <= _HOLD * (1.0 + abs(f[r])):
            rows.append(r)
    AR = A[rows]
    target = np.zeros(len(rows))
    target[0] = before - b[j]
    for k, r in enumerate(rows[1:], start=1):
        target[k] = -b[r]
    MinvAt = np.linalg.solve(M, AR.T)
    # A_R (v+ - M^-1 A_R^T P) = target
    P = np.linalg.lstsq(AR @ MinvAt, AR @ v - target, rcond=None)[0]
    if not np.isclose(P[0], impulse, rtol=_AGREE, atol=_AGREE * abs(impulse) + 1e-300):
        return None
    vm = v - MinvAt @ P
    T_after = float(ns.energy(t, q, v, p)[0])
    T_before = float(ns.energy(t, q, vm, p)[0])
    return T_before - T_after


def with_energy_lost(ns, p: np.ndarray, events: list[Event]) -> list[Event]:
    """``events`` with each impact's ``energy_lost`` (T- - T+, None where it cannot be
    recovered: see the module docstring)."""
    import dataclasses

    from ._run import ConstraintKinds

    normals = ConstraintKinds.of(ns.system).normal
    out = []
    for ev in events:
        if ev.kind == EventKind.IMPACT:
            try:
                lost = _lost(ns, p, normals, ev)
            except (np.linalg.LinAlgError, ValueError, KeyError, ArithmeticError):
                lost = None
            ev = dataclasses.replace(ev, energy_lost=lost)
        out.append(ev)
    return out
