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

A state on another piece of the manifold than the one a constant-root elimination chose
(r = -l for a string r^2 = l^2) is not reachable by the motion and is skipped; a state
that an eliminated coordinate's expression misses (a chart's other half) is a
disagreement.
"""

from __future__ import annotations

import math
import random
from dataclasses import dataclass

import numpy as np
import sympy as sp

from .._errors import LamechError
from ..expr import to_text
from ..model._chart import chart_initial
from ..model._checks import initial_values, numeric_matrix
from ._derive import DegenerateConstraintsError, Dynamics, kkt_numeric

__all__ = [
    "ClosedFormError",
    "Disagreement",
    "manifold_states",
    "check_forms",
    "printed_forms",
    "check_along",
]

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
    chart_miss: bool = False  # the file's chart does not reach this state

    def __str__(self) -> str:
        at = ", ".join(f"{k} = {v:.6g}" for k, v in self.state.items())
        return (
            f"{self.result}: the printed form gives {self.printed:.10g}, the KKT system "
            f"{self.kkt:.10g} at {at}"
        )


class ClosedFormError(LamechError, ValueError):
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


def check_forms(
    dyn: Dynamics, red, forms: dict, states: list[dict]
) -> tuple[list[Disagreement], int]:
    """(The disagreements, the number of values compared) of ``forms`` with the KKT
    system at ``states`` (full states, :func:`manifold_states`). An eliminated
    coordinate whose expression misses a state (the chart y = +sqrt(l^2 - x^2) at y < 0)
    is a disagreement too, by its own name.

    ``forms`` is {label: (expr, kind, index)}: kind "lambda" with the constraint's index
    or "acc" with the coordinate's index, each expression in the independent coordinates
    of the reduction ``red``. States on another piece of the manifold than the
    eliminations chose (r = -l where r = l was chosen: the motion cannot reach it) are
    skipped; so are states where the KKT matrix is singular or a form is not finite (a
    pole: said by the form's own domain, not a disagreement)."""
    system = dyn.system
    pv = system.parameter_values
    sub = red.substitution
    rows: list[tuple[str, float, float, dict]] = []
    moving = set(system.q) | set(system.chart.symbols if system.chart is not None else ())
    for st in states:
        env = {**pv, **st}
        missed: list[tuple[str, float, float]] = []
        other_piece = False
        if system.chart is not None:  # the chart's coordinates of this state, if any
            found = chart_initial(system, dict(st))
            if isinstance(found, str):
                rows.append(("[parametrisation]", math.nan, 0.0, st))
                continue
            env.update(found)
        for c, e in red.eliminated:
            for sym in (c.symbol, c.velocity):
                want = st[sym]
                try:
                    got = float(sp.sympify(sub[sym]).xreplace(_floats(env)).evalf())
                except (TypeError, ValueError):
                    continue  # not real here: the form's own domain
                if not math.isfinite(got) or abs(got - want) <= 1e-8 * (1 + abs(want)):
                    continue
                if not sp.sympify(e).free_symbols & moving:
                    other_piece = True  # r = l chosen, the state has r = -l: unreachable
                else:  # a chart that does not cover this state
                    missed.append((f"{sym} (eliminated: {c.name} = {to_text(e)})", got, want))
        if other_piece:
            continue
        for label, got, want in missed:
            rows.append((label, got, want, st))
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
    out = []
    for label, a, b, st in _beyond(rows, RTOL):  # NaN too: a state the chart misses
        named = {str(k): float(v) for k, v in st.items()}
        out.append(Disagreement(label, named, a, b, label == "[parametrisation]"))
    return out, len(rows)


def _beyond(rows: list, rtol: float) -> list:
    """The rows (label, printed, truth, where) whose two values differ by more than
    ``rtol`` times (1 + the largest finite value of that label over all rows), or are
    not both numbers."""
    scale: dict[str, float] = {}
    for label, a, b, _ in rows:
        scale[label] = max([scale.get(label, 0.0), *(abs(v) for v in (a, b) if math.isfinite(v))])
    return [r for r in rows if not abs(r[1] - r[2]) <= rtol * (1 + scale[r[0]])]


def printed_forms(system, red, forms) -> dict:
    """The closed forms a solve prints, as :func:`check_forms` takes them: each readable
    multiplier ("lambda_<name>") and each reduced acceleration of an original coordinate
    ("<name>''"); those too long to print are not checked."""
    checked: dict = {}
    for j, c in enumerate(system.constraints):
        if c.name in forms.readable_multipliers:
            checked[f"lambda_{c.name}"] = (forms.multipliers[c.name], "lambda", j)
    index = {s: i for i, s in enumerate(system.qdd)}
    for coord in red.independent:
        a = coord.acceleration
        if a in forms.accelerations and a in index and not forms.is_long(a):
            checked[f"{coord.name}''"] = (forms.accelerations[a], "acc", index[a])
    return checked


def _floats(env: dict) -> dict:
    return {k: sp.Float(v, 30) if not isinstance(v, sp.Basic) else v for k, v in env.items()}


ALONG_RTOL = 1e-5
"""Largest disagreement allowed along a simulated motion, relative to the size of the
result over the samples compared: the integrator's multipliers carry its own error
(rtol 1e-9 by default), a form on the wrong chart is off by its whole size."""


def check_along(
    solution, t, q, qd, lambdas, until: float | None = None, samples: int = 40
) -> list[Disagreement]:
    """The disagreements of the multipliers ``solution`` prints with those a simulation
    solved for, at up to ``samples`` of its samples (``t`` (N,), ``q`` and ``qd`` (N, n),
    ``lambdas`` (N, m) in the order of the system's constraints), before ``until`` (the
    first event: after a lift-off or a slip the active constraints are others than
    those the closed forms are of) and before the first sample where a multiplier is
    NaN (a contact open). Results in a file's own chart are not
    checked here (each sample would need the chart's coordinates found by Newton's
    method); every solve checks them at random states (:func:`check_forms`)."""
    system = solution.system
    if system.chart is not None:
        return []
    names = [c.name for c in system.constraints]
    printed = {
        name: expr
        for name, expr in solution.closed.readable_multipliers.items()
        if name in names and sp.sympify(expr).free_symbols
    }
    if not printed or len(t) == 0:
        return []
    lam = np.asarray(lambdas, dtype=float)
    open_ = np.where(~np.all(np.isfinite(lam), axis=1))[0]
    end = int(open_[0]) if len(open_) else len(t)
    if until is not None:
        end = min(end, int(np.searchsorted(np.asarray(t), until, side="left")))
    if end == 0:
        return []
    picks = sorted({int(i) for i in np.linspace(0, end - 1, min(samples, end))})
    pv = system.parameter_values
    rows = []
    for name, expr in printed.items():
        j = names.index(name)
        f = sp.lambdify(
            [system.t, *system.q, *system.qd], sp.sympify(expr).xreplace(pv), modules="numpy"
        )
        for i in picks:
            with np.errstate(all="ignore"):
                value = complex(f(t[i], *q[i], *qd[i]))
            if not np.isfinite(value):
                continue
            rows.append((f"lambda_{name}", value.real, float(lam[i, j]), i))
    out = []
    for label, a, b, i in _beyond(rows, ALONG_RTOL):
        state = {"t": float(t[i])}
        state.update({c.name: float(x) for c, x in zip(system.coordinates, q[i])})
        out.append(Disagreement(label, state, a, b))
    return out
