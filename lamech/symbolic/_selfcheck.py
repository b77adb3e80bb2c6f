"""The printed closed forms checked against the KKT system, on every run.

A closed form is printed for a reader to trust; one that is right on part of the
constraint manifold only (a chart's half of a circle, a form that divides by cos(w t))
is the worst thing lamech could print. So every :func:`~lamech.symbolic.solve` checks
the multipliers and the reduced accelerations it delivers against the KKT system solved
numerically (:func:`._derive.kkt_numeric`) at seeded random states spread over the whole
manifold, far from the start (:func:`manifold_states`: random coordinates projected onto
the constraints by Newton's method, so both signs of every root are met; velocities
projected onto the constraints' velocity forms; random t where the problem moves). A
disagreement beyond :data:`RTOL` is a :class:`ClosedFormError` naming the result, the
state and both values. :func:`check_along` does the same along a simulated motion.

The states are generated on the coordinates that hold at the start; a point that lands
on another piece of the manifold than the one a constant-root elimination chose (r = -l
for a string r^2 = l^2) is not reachable by the motion and is skipped.
"""

from __future__ import annotations

import random
from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..model._checks import initial_values, numeric_matrix
from ._derive import DegenerateConstraintsError, Dynamics, kkt_numeric

__all__ = ["ClosedFormError", "Disagreement", "manifold_states", "check_forms"]

RTOL = 1e-6
"""Largest disagreement allowed, relative to the size of the result over all states
checked (the forms are exact: only rounding separates them from the KKT solve)."""
POINTS = 5
"""Random states checked by every solve."""


@dataclass(frozen=True)
class Disagreement:
    """A printed closed form that differs from the KKT system at one state."""

    result: str  # "lambda_hoop", "x''"
    state: dict  # name -> value (coordinates, velocities, t)
    printed: float
    kkt: float

    def __str__(self) -> str:
        at = ", ".join(f"{k} = {v:.6g}" for k, v in self.state.items())
        return (
            f"{self.result}: the printed form gives {self.printed:.10g}, the KKT system "
            f"{self.kkt:.10g} at {at}"
        )


class ClosedFormError(ArithmeticError):
    """A printed closed form disagrees with the KKT system (a defect of lamech: please
    report it with the problem file). ``disagreements`` lists each."""

    def __init__(self, disagreements: list[Disagreement], where: str):
        self.disagreements = list(disagreements)
        lines = "\n  ".join(str(d) for d in self.disagreements[:6])
        super().__init__(
            f"self-check failed {where}: a closed form disagrees with the KKT system solved "
            f"numerically; it is not printed as true. This is a defect of lamech: please "
            f"report it with the problem file.\n  {lines}"
        )


def _holonomic(dyn: Dynamics) -> tuple[sp.Matrix, sp.Matrix]:
    rows = [j for j, c in enumerate(dyn.system.constraints) if c.holonomic]
    f = sp.Matrix([dyn.system.constraints[j].expr for j in rows])
    A = sp.Matrix([[dyn.A[j, k] for k in range(dyn.A.cols)] for j in rows])
    return f, A


def manifold_states(dyn: Dynamics, count: int = POINTS, seed: int = 23) -> list[dict]:
    """Seeded states on the constraint manifold, {symbol: float}: coordinates moved far
    from the start (by up to 1.5 (1 + |q0|) each) and brought back onto the holonomic
    constraints by Newton's method (least squares), velocities moved likewise and
    projected onto the velocity forms of every constraint, t in (0, 2) where anything
    depends on it. Parameters at their values. Points where Newton fails are dropped."""
    system = dyn.system
    rng = random.Random(seed)
    pv = system.parameter_values
    start = initial_values(system)
    q, qd = system.q, system.qd
    q0 = np.array([start[s] for s in q], dtype=float)
    v0 = np.array([start[s] for s in qd], dtype=float)
    f, Ah = _holonomic(dyn)
    F = dyn.velocity_forms  # A q' + b
    b = F.xreplace({v: 0 for v in qd})
    moves = bool(
        system.t in (f.free_symbols | F.free_symbols | dyn.h.free_symbols | dyn.Q.free_symbols)
    )
    out = []
    for _ in range(count):
        t = rng.uniform(0.1, 2.0) if moves else 0.0
        x = q0 + np.array([rng.uniform(-1.5, 1.5) * (1 + abs(a)) for a in q0])
        env = {**pv, system.t: t}
        ok = not f.rows
        for _ in range(60):
            if not f.rows:
                break
            here = {**env, **dict(zip(q, x))}
            try:
                r = numeric_matrix(f, here).reshape(-1)
                J = numeric_matrix(Ah, here).reshape(f.rows, len(q))
            except (TypeError, ValueError, ZeroDivisionError):
                break
            if not (np.all(np.isfinite(r)) and np.all(np.isfinite(J))):
                break
            if np.abs(r).max() < 1e-13 * (1 + np.abs(x).max()):
                ok = True
                break
            step, *_ = np.linalg.lstsq(J, -r, rcond=None)
            x = x + step
        if not ok:
            continue
        here = {**env, **dict(zip(q, x))}
        v = v0 + np.array([rng.uniform(-1.0, 1.0) * (1 + abs(a)) for a in v0])
        if F.rows:
            try:
                A = numeric_matrix(dyn.A, here).reshape(F.rows, len(q))
                bb = numeric_matrix(b, here).reshape(-1)
            except (TypeError, ValueError, ZeroDivisionError):
                continue
            if not (np.all(np.isfinite(A)) and np.all(np.isfinite(bb))):
                continue
            fix, *_ = np.linalg.lstsq(A, A @ v + bb, rcond=None)
            v = v - fix
        out.append({**dict(zip(q, x)), **dict(zip(qd, v)), system.t: t})
    return out


def check_forms(dyn: Dynamics, red, forms: dict, states: list[dict]) -> list[Disagreement]:
    """The disagreements of ``forms`` ({label: (expr, kind, index)}, kind "lambda" with the
    constraint's index or "acc" with the coordinate's index; expressions in the
    independent coordinates of the reduction ``red``) with the KKT system at ``states``
    (full states, :func:`manifold_states`). States on another piece of the manifold than
    the eliminations chose are skipped; so are states where the KKT matrix is singular or
    a form is not finite (a pole: said by the form's own domain, not a disagreement)."""
    system = dyn.system
    pv = system.parameter_values
    sub = red.substitution
    rows: list[tuple[str, float, float, dict]] = []
    for st in states:
        env = {**pv, **st}
        reached = True
        for c, _ in red.eliminated:
            for sym in (c.symbol, c.velocity):
                want = st[sym]
                try:
                    got = float(sp.sympify(sub[sym]).xreplace(_floats(env)).evalf())
                except (TypeError, ValueError):
                    reached = False
                    break
                if not abs(got - want) <= 1e-8 * (1 + abs(want)):
                    reached = False
                    break
        if not reached:
            continue
        try:
            acc, lam = kkt_numeric(dyn, env)
        except (DegenerateConstraintsError, np.linalg.LinAlgError):
            continue
        for label, (expr, kind, index) in forms.items():
            truth = float(lam[index]) if kind == "lambda" else float(acc[index])
            try:
                value = complex(sp.sympify(expr).xreplace(_floats(env)).evalf())
            except (TypeError, ValueError, ZeroDivisionError):
                continue
            if not np.isfinite(value) or abs(value.imag) > 1e-9 * (1 + abs(value.real)):
                continue
            rows.append((label, value.real, truth, st))
    scale: dict[str, float] = {}
    for label, a, b, _ in rows:
        scale[label] = max(scale.get(label, 0.0), abs(a), abs(b))
    out = []
    for label, a, b, st in rows:
        if abs(a - b) > RTOL * (1 + scale[label]):
            named = {str(k): float(v) for k, v in st.items()}
            out.append(Disagreement(label, named, a, b))
    return out


def _floats(env: dict) -> dict:
    return {k: sp.Float(v, 30) if not isinstance(v, sp.Basic) else v for k, v in env.items()}
