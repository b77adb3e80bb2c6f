"""What is true of a :class:`~lamech.model.System` at numbers: its initial state, the
contacts open at the start, dependent constraints, a motion without inertia.

Numbers here come from substituting Floats (``xreplace``, 30 digits), never from
evaluating user text.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import sympy as sp

from ._kinematics import constraint_jacobian, time_derivative

if TYPE_CHECKING:  # pragma: no cover
    from ._system import System

__all__ = [
    "INITIAL_TOLERANCE",
    "value",
    "numeric_matrix",
    "initial_values",
    "open_at_start",
    "holding_at_start",
    "dependent_constraints",
    "dependent_group",
    "Inertialess",
    "massless",
    "without_inertia",
    "probe_states",
]

INITIAL_TOLERANCE = 1e-10
"""An initial state violates a constraint when |f| > INITIAL_TOLERANCE*(1 + |q|)."""


def initial_values(system: System, parameters: dict | None = None) -> dict:
    """The initial coordinates and velocities as floats, {symbol: value}, at the
    parameter values (``parameters`` {symbol: value} overrides them). The one place
    where the initial state becomes numbers."""
    pv = system.parameter_values if parameters is None else parameters
    return {s: value(e, pv) for s, e in system.initial_state.items()}


def probe_states(system: System, count: int = 2, seed: int = 11, spread: float = 0.3) -> list[dict]:
    """Seeded numeric environments near the initial state, {symbol: value}: parameters at
    their values, every coordinate and velocity moved by a random amount up to
    ``spread``, t in (0.1, 1). Used wherever a property is checked "at random states"
    (dependent constraints, force directions): the same states for the same seed."""
    pv = system.parameter_values
    try:
        init = initial_values(system)
    except (TypeError, ValueError):
        init = {s: 0.0 for s in system.initial_state}
    rng = np.random.default_rng(seed)
    envs = []
    for _ in range(count):
        envs.append(
            {
                **pv,
                system.t: float(rng.uniform(0.1, 1.0)),
                **{s: v + float(rng.uniform(-spread, spread)) for s, v in init.items()},
            }
        )
    return envs


def open_at_start(system: System) -> dict[str, float]:
    """Unilateral contacts open (f > 0) or opening (f = 0, df/dt > 0) at the initial state.

    {constraint name: f at the start}. The symbolic results (multipliers, forces) hold
    while a contact is closed; energy shells from an open start do not.
    """
    values = dict(system.parameter_values)
    state = initial_values(system)
    scale = 1 + max((abs(v) for v in state.values()), default=0.0)
    env = {**values, **state, system.t: 0.0}
    out = {}
    for c in system.constraints:
        if not (c.unilateral and c.holonomic):
            continue
        try:
            res = value(c.expr, env)
            vres = value(time_derivative(c.expr, system), env)
        except (TypeError, ValueError):
            continue
        tol = INITIAL_TOLERANCE * scale
        if res > tol or (abs(res) <= tol and vres > tol):
            out[c.name] = res
    return out


def holding_at_start(system: System) -> System:
    """The system with only the constraints that hold at the start: without the contacts
    :func:`open_at_start` and the friction constraints on them (their multipliers are 0
    until they close). ``system`` itself when every constraint holds."""
    opened = open_at_start(system)
    if not opened:
        return system
    kept = tuple(
        c
        for c in system.constraints
        if c.name not in opened and not (c.friction is not None and c.friction.normal in opened)
    )
    return dataclasses.replace(system, constraints=kept)


def value(expr, env: dict) -> float:
    """``expr`` at the numbers ``env`` ({symbol: value}), as a float.

    ``xreplace`` with Floats, not ``subs``: subs walks the whole expression once per
    entry of ``env`` (7 s for the initial check of a 30-link chain, against 0.05 s).
    Raises TypeError when the value is complex or undefined.
    """
    values = {s: v if isinstance(v, sp.Basic) else sp.Float(v, 30) for s, v in env.items()}
    return float(sp.sympify(expr).xreplace(values).evalf(30))


def numeric_matrix(expr: sp.Matrix, env: dict) -> np.ndarray:
    # xreplace with numbers, not subs: subs re-simplifies at every node (10 s for the
    # 30-link chain's A against 0.1 s).
    # Entry by entry, the zeros skipped: a chain's A is N x 2N with 4N nonzeros.
    values = {s: sp.Float(v, 30) if not isinstance(v, sp.Basic) else v for s, v in env.items()}
    if not isinstance(expr, sp.MatrixBase):
        return np.array(sp.sympify(expr).xreplace(values).evalf(), dtype=float)
    out = np.zeros(expr.shape)
    for (i, j), e in expr.todok().items():
        out[i, j] = float(e.xreplace(values).evalf())
    return out


def dependent_constraints(system: System) -> list[tuple[tuple[str, ...], bool]]:
    """Groups of constraints whose rows of A are linearly dependent.

    A is evaluated at the initial state and at two seeded random states; a group that
    is dependent at the random states is redundant, one dependent only at the initial
    state marks a singular configuration (flag True). Only the constraints that hold at
    the start count: a contact open there (a stop at the pulley of an Atwood machine,
    which can never close together with the other stop and the string) is checked by
    the simulation when it closes.
    """
    holding = holding_at_start(system).constraints
    rows = [i for i, c in enumerate(system.constraints) if c in holding]
    if not rows:
        return []
    A, _ = constraint_jacobian(system)
    A = A[rows, :]
    names = [system.constraints[i].name for i in rows]
    pv = system.parameter_values
    try:
        init = initial_values(system)
    except (TypeError, ValueError):
        return []
    envs = [{**pv, **init, system.t: 0.0}] + probe_states(system, count=2, seed=7)
    groups = []
    for k, env in enumerate(envs):
        try:
            a = numeric_matrix(A, env)
        except (TypeError, ValueError):
            continue
        group = dependent_group(a, names)
        if group:
            groups.append((group, k == 0))
    if not groups:
        return []
    random_groups = [g for g, first in groups if not first]
    if random_groups:
        return [(random_groups[0], False)]
    return [groups[0]]


def dependent_group(a: np.ndarray, names: list[str]) -> tuple[str, ...] | None:
    """Names of the constraints in one linear dependency among the rows of ``a``."""
    scale = max(1.0, float(np.abs(a).max(initial=0.0)))
    u, s, vt = np.linalg.svd(a.T, full_matrices=True)
    tol = 1e-9 * scale * max(a.shape)
    rank = int((s > tol).sum())
    if rank == a.shape[0]:
        return None
    null = vt[rank:] if vt.shape[0] > rank else vt[-1:]
    combo = null[0]
    return tuple(n for n, c in zip(names, combo) if abs(c) > 1e-6)


class Inertialess(NamedTuple):
    """A motion the constraints allow that the mass matrix gives no inertia: the
    coordinates it moves, the massless bodies among the bodies it moves, and whether
    those are all of them (``only``)."""

    coordinates: tuple[str, ...]
    massless: tuple[int, ...]
    only: bool

    def describe(self, system: System) -> str:
        """'coordinate `phi` has no inertia: it moves only the massless body `bead`'."""
        names = self.coordinates
        if len(names) == 1:
            what = f"coordinate `{names[0]}` has no inertia"
        else:
            what = (
                "the motion of coordinates "
                + ", ".join(f"`{x}`" for x in names)
                + " together has no inertia"
            )
        if not self.massless:
            return what
        kind = "body" if len(self.massless) == 1 else "bodies"
        light = ", ".join(f"`{system.bodies[i].name}`" for i in self.massless)
        return f"{what}: it moves {'only ' if self.only else ''}the massless {kind} {light}"


def massless(system: System, env: dict) -> list[int]:
    """The indices of the bodies whose mass is 0 at the numbers ``env``."""
    out = []
    for i, b in enumerate(system.bodies):
        try:
            if value(b.mass, env) == 0:
                out.append(i)
        except (TypeError, ValueError):
            continue
    return out


def without_inertia(system: System, M: np.ndarray, A: np.ndarray, env: dict) -> Inertialess | None:
    """The motion that makes the KKT matrix [[M, -A^T], [A, 0]] singular (numbers; ``A``
    the rows that hold) because M gives it no inertia: v with A v = 0 and v^T M v = 0 (to
    1e-12 of M), as the coordinates it moves and the massless bodies (mass 0 at the
    numbers ``env``) among the bodies those move. None when every motion the constraints
    allow has inertia (a singular KKT matrix then has dependent constraints)."""
    n = M.shape[0]
    basis = np.eye(n)
    if A.shape[0]:
        _, s, vt = np.linalg.svd(A)
        rank = int((s > 1e-9 * max(1.0, float(s[0])) * max(A.shape)).sum())
        basis = vt[rank:].T
    if basis.shape[1] == 0:
        return None
    w, vecs = np.linalg.eigh(basis.T @ ((M + M.T) / 2) @ basis)
    k = int(np.argmin(np.abs(w)))
    if abs(w[k]) > 1e-12 * float(np.abs(M).max(initial=0.0)):
        return None  # (relative to M: a milligram is not massless)
    v = basis @ vecs[:, k]
    moved = [i for i in range(n) if abs(v[i]) > 1e-6 * float(np.abs(v).max())]
    symbols = {system.coordinates[i].symbol for i in moved}
    bodies = [
        i
        for i, b in enumerate(system.bodies)
        if any(e is not None and e.free_symbols & symbols for e in (*b.position, b.angle))
    ]
    light = [i for i in massless(system, env) if i in bodies]
    return Inertialess(
        tuple(system.coordinates[i].name for i in moved),
        tuple(light),
        bool(light) and len(light) == len(bodies),
    )
