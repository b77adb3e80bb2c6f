"""Constraint forces: generalized, and Cartesian by virtual work.

Constraint j's generalized force is Q^(j) = lambda_j dF_j/dq' (the canonical equations
of :mod:`lamech.model`). If that force is a Cartesian force F acting on the material
point P of a body (with reaction -F on a second body's material point), virtual work
gives J^T F = Q^(j) with J = J_Pa - J_Pb the partial velocities
(:func:`lamech.model._kinematics.partial_velocities`). lamech reports the minimum-norm F, its
components along the named directions (null where J cannot determine them) and the
residual |Q^(j) - J^T F|: a nonzero residual means the named point cannot carry that
constraint's force.
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from ..model import System
from ..model._kinematics import contact_partial_velocities
from ._budget import count_ops
from ._derive import Dynamics
from ._reduce import Reduction, angles_of, tidy

__all__ = ["generalized_forces", "cartesian_forces", "residual_notes"]


TIDY_PRODUCT_OPS = 150
"""A multiplier longer than this is multiplied out without another ``simplify`` (which
costs tens of seconds on a few hundred operations and rarely shortens a product)."""


LONG_OPS = 1500
"""A multiplier longer than this enters the Cartesian forces last (see there)."""


def generalized_forces(dyn: Dynamics, red: Reduction, multipliers: dict, on_manifold=None) -> dict:
    """{constraint: {coordinate: Q^(j)_r}} on the manifold, every coordinate listed.
    ``on_manifold`` (:func:`._manifold.manifold_simplifier`) writes them with the kept
    constraints' values (sqrt(x1^2 + y1^2) -> l1)."""
    out = {}
    # In two or more angles, simplify costs seconds per product and a tidy multiplier
    # times its tidy dF/dq' is already in its shortest form (the double pendulum's).
    chain = len(angles_of(dyn.system, red)) >= 2
    for j, c in enumerate(dyn.system.constraints):
        lam = multipliers.get(c.name, c.multiplier)
        long = chain or count_ops(lam) > TIDY_PRODUCT_OPS
        row = {}
        for i, coord in enumerate(dyn.system.coordinates):
            Q = lam * tidy(red.apply(dyn.A[j, i])) if chain else red.apply(lam * dyn.A[j, i])
            if on_manifold is not None:
                Q = on_manifold.radicals_replaced(Q) if long else on_manifold(tidy(Q))
            row[coord.name] = Q if long else tidy(Q)
        out[c.name] = row
    return out


def _probe_states(system: System, red: Reduction, count: int = 2) -> list[dict]:
    """Numeric environments (parameters, independent coordinates) near the initial state."""
    pv = system.parameter_values
    rng = np.random.default_rng(11)
    envs = []
    for k in range(count):
        env = dict(pv)
        env[system.t] = 0.3 * k
        for c in red.independent:
            env[c.symbol] = (
                float(sp.sympify(c.initial).subs(pv))
                + 0.37 * (k + 1)
                + 0.05 * float(rng.standard_normal())
            )
            env[c.velocity] = 0.4 + 0.1 * k
        envs.append(env)
    return envs


def cartesian_forces(dyn: Dynamics, red: Reduction, multipliers: dict) -> dict:
    """{constraint: {direction: component or None, "residual": norm}} for every
    constraint with a ``force`` spec; x/y(/z) components when no direction is named.

    F is linear in lambda: it is found for lambda as a symbol, where every intermediate
    (the metric J^T B, the solve, the residual) is geometry alone and short, and the
    closed form is put in last. Only the results are simplified: each component once,
    with lambda in (none when lambda is longer than :data:`LONG_OPS`; a product's size
    then decides, as for the generalized forces). Simplifying the intermediates with
    lambda in them cost the lecture's cylinder 0.9 s of its 2.7 s."""
    system = dyn.system
    out = {}
    for j, c in enumerate(system.constraints):
        if c.force is None:
            continue
        unit = _unit_forces(dyn, red, j)
        lam = multipliers.get(c.name, c.multiplier)
        if lam == c.multiplier:
            out[c.name] = unit
            continue
        long = count_ops(lam) > LONG_OPS
        comps: dict = {}
        for k, v in unit.items():
            if v is None or v == 0:
                comps[k] = v
            elif k == "residual":
                # |Q - J^T F| = |lambda| |Q_1 - J^T F_1|: never zero by lambda's form
                comps[k] = v.xreplace({c.multiplier: lam})
            else:
                comps[k] = (
                    v.xreplace({c.multiplier: lam})
                    if long
                    else tidy(v.xreplace({c.multiplier: lam}))
                )
        out[c.name] = comps
    return out


def _unit_forces(dyn: Dynamics, red: Reduction, j: int) -> dict:
    """:func:`cartesian_forces` of constraint ``j`` with its multiplier a symbol."""
    system = dyn.system
    c = system.constraints[j]
    spec = c.force
    assert spec is not None  # cartesian_forces asks only for constraints with one
    J = contact_partial_velocities(system, spec).applyfunc(red.apply)
    Q = (dyn.A[j, :].T * c.multiplier).applyfunc(red.apply)
    dim = J.rows
    square = _square_forces(J, dyn.A[j, :].T.applyfunc(red.apply), system, red)
    if square is not None:
        return _components(square * c.multiplier, spec, dim, red, sp.Integer(0))
    basis = _range_basis(J, system, red)
    if basis is None:
        return {"residual": tidy(sp.sqrt(sum(e**2 for e in Q)))}
    B = basis
    # F = B y minimises |J^T B y - Q|; F is then the minimum-norm solution. B holds
    # columns of J itself, so J^T B is a block of the metric J^T J (partial velocities
    # dotted together), which simplifies to short forms (diag(1, r^2, r^2 sin^2)
    # for spherical coordinates) where the Cartesian Gram matrix J J^T does not.
    JB = (J.T * B).applyfunc(tidy)
    if JB.rows == JB.cols:
        y = JB.LUsolve(Q).applyfunc(tidy)
    else:
        G = (JB.T * JB).applyfunc(tidy)
        y = G.LUsolve(JB.T * Q).applyfunc(tidy)
    F = (B * y).applyfunc(tidy)
    res_vec = (Q - J.T * F).applyfunc(tidy)
    residual = tidy(sp.sqrt(sum((e**2 for e in res_vec), sp.Integer(0))))
    return _components(F, spec, dim, red, residual, lambda d: _in_range(B, d, system, red))


def _components(F: sp.Matrix, spec, dim: int, red: Reduction, residual, determined=None) -> dict:
    """F's components along the spec's named directions (x, y(, z) when none is named),
    None along a direction ``determined`` says J cannot determine, and the residual."""
    directions = spec.along or tuple(
        (axis, tuple(sp.Integer(1 if k == i else 0) for k in range(dim)))
        for i, axis in enumerate("xyz"[:dim])
    )
    comps: dict = {}
    for name, d in directions:
        dvec = sp.Matrix(d).applyfunc(red.apply)
        if determined is not None and not determined(dvec):
            comps[name] = None
            continue
        comps[name] = tidy((F.T * dvec)[0] / sp.sqrt(sum(e**2 for e in dvec)))
    comps["residual"] = residual
    return comps


def _square_forces(J: sp.Matrix, Q: sp.Matrix, system: System, red: Reduction):
    """F with J^T F = Q from ``dim`` of its rows, when J (dim x n) has full row rank at
    generic states and the F so found satisfies every row there: F is then the one
    solution, and the least squares (four products of partial velocities, seconds of
    tidying for a linkage's loop) is not needed. None otherwise (a point that cannot
    carry the force, a rank-deficient J, a state where it cannot be evaluated)."""
    dim = J.rows
    envs = _probe_states(system, red)
    evaluated = [_numeric(J, e) for e in envs]
    mats = [m for m in evaluated if m is not None]
    if len(mats) < len(evaluated) or not mats:
        return None
    if any(np.linalg.matrix_rank(m, tol=1e-9 * max(1.0, np.abs(m).max())) < dim for m in mats):
        return None
    rows: list[int] = []  # coordinates whose rows of J^T are independent at every probe
    for k in range(J.cols):
        trial = rows + [k]
        if all(np.linalg.matrix_rank(m[:, trial], tol=1e-9) == len(trial) for m in mats):
            rows = trial
        if len(rows) == dim:
            break
    if len(rows) < dim:
        return None
    JS = sp.Matrix([[J[i, k] for i in range(dim)] for k in rows])
    QS = sp.Matrix([Q[k] for k in rows])
    try:
        F = JS.LUsolve(QS).applyfunc(tidy)
    except (ValueError, ZeroDivisionError):  # NonInvertibleMatrixError is a ValueError
        return None
    res = Q - J.T * F
    for env in envs:
        r, q = _numeric(res, env), _numeric(Q, env)
        if r is None or q is None:
            return None
        if np.linalg.norm(r) > 1e-9 * max(1.0, float(np.linalg.norm(q))):
            return None
    return F


def _numeric(M: sp.Matrix, env: dict) -> np.ndarray | None:
    try:
        return np.array(M.subs(env).evalf(), dtype=float)
    except (TypeError, ValueError):
        return None


def _range_basis(J: sp.Matrix, system: System, red: Reduction) -> sp.Matrix | None:
    """Columns of J (d x n) itself spanning its range, chosen independent at probe
    states (None when J vanishes)."""
    dim = J.rows
    envs = _probe_states(system, red)
    mats = [m for m in (_numeric(J, e) for e in envs) if m is not None]
    if not mats:
        return sp.eye(dim)
    ranks = [np.linalg.matrix_rank(m, tol=1e-9 * max(1.0, np.abs(m).max())) for m in mats]
    if max(ranks) == 0:
        return None
    m = mats[0]
    chosen: list[int] = []
    for k in range(m.shape[1]):
        trial = chosen + [k]
        if np.linalg.matrix_rank(m[:, trial], tol=1e-9) == len(trial):
            chosen = trial
        if len(chosen) == ranks[0]:
            break
    return sp.Matrix.hstack(*[J[:, k] for k in chosen])


def _in_range(B: sp.Matrix, d: sp.Matrix, system: System, red: Reduction) -> bool:
    if B.cols == B.rows:
        return True
    for env in _probe_states(system, red):
        b, v = _numeric(B, env), _numeric(d, env)
        if b is None or v is None:
            continue
        coef, *_ = np.linalg.lstsq(b, v, rcond=None)
        if np.linalg.norm(b @ coef - v) > 1e-8 * (1 + np.linalg.norm(v)):
            return False
    return True


def residual_notes(dyn: Dynamics, red: Reduction, forces: dict) -> list[str]:
    """What to do about a residual: a constraint's force named on one body whose
    residual is not zero, where naming the two bodies it joins leaves none (a string
    between a bob and a cart named on the bob alone), says which bodies to name; any
    other nonzero residual says that the named point cannot carry the force. Checked
    numerically at probe states (a residual of 1e-9 |Q| or less is zero)."""
    import dataclasses

    system = dyn.system
    envs = _probe_states(system, red)
    out = []
    for j, c in enumerate(system.constraints):
        spec = c.force
        residual = forces.get(c.name, {}).get("residual")
        if spec is None or residual is None or residual == 0:
            continue
        if _residual_at(dyn, red, j, spec, envs) <= 1e-9:
            continue
        first = spec.bodies[0]
        if len(spec.bodies) == 1:
            pairs = [
                dataclasses.replace(spec, bodies=(first, b.name))
                for b in system.bodies
                if b.name != first
            ]
            fits = [s.bodies[1] for s in pairs if _residual_at(dyn, red, j, s, envs) <= 1e-9]
            if fits:
                out.append(
                    f"`{c.name}` joins `{first}` and `{fits[0]}` (it moves both): its force "
                    f"named on `{first}` alone leaves a residual, and its components are not "
                    f'the force; name both, body = ["{first}", "{fits[0]}"] (the force on '
                    "the second is the opposite), and the residual is 0"
                )
                continue
        out.append(
            f"`{c.name}`: the named point of `{first}` cannot carry the constraint's force "
            "(the residual is not 0), so its components are not the force; name the body "
            "(or the two bodies the constraint joins) and the point where it acts"
        )
    return out


def _residual_at(dyn: Dynamics, red: Reduction, j: int, spec, envs: list[dict]) -> float:
    """max over ``envs`` of |Q - J^T F| / |Q| for the least-squares F (lambda = 1), with
    the force acting as ``spec`` says (inf where it cannot be evaluated)."""
    system = dyn.system
    try:
        J = contact_partial_velocities(system, spec).applyfunc(red.apply)
    except (ValueError, KeyError, TypeError):
        return float("inf")
    Q = dyn.A[j, :].T.applyfunc(red.apply)
    worst = 0.0
    for env in envs:
        Jn, Qn = _numeric(J, env), _numeric(Q, env)
        if Jn is None or Qn is None:
            return float("inf")
        Qn = Qn.reshape(-1)
        F, *_ = np.linalg.lstsq(Jn.T, Qn, rcond=None)
        scale = max(float(np.linalg.norm(Qn)), 1e-300)
        worst = max(worst, float(np.linalg.norm(Qn - Jn.T @ F)) / scale)
    return worst
