"""Maps of regimes: the closed-form event angles over a grid of parameters, without
simulating (:func:`parameter_map`, ``lamech map``).

For a motion of one degree of freedom, :func:`lamech.solve` gives each multiplier on the
energy shell as a function of the shell's coordinate x and the parameters, and finds
where a unilateral constraint lets go (lambda = 0) and where a friction constraint
starts to slip (|lambda_f| = mu lambda_N) along the range the motion reaches
(:mod:`lamech.symbolic._conditions`; the report's sliders evaluate the same closed forms,
:mod:`lamech.present._live`). Here the same functions, compiled with NumPy, are
evaluated at every point of the grid at once:

- the range reached: from x0 in the direction of the initial velocity (of the initial
  acceleration at rest; increasing at rest at an equilibrium) to the first turning
  point (x'^2 = 0 on the shell) or one revolution of an angle;
- each condition's first root there: its sign change bracketed on a grid of
  :data:`COARSE` points (the same for every case where x0 does not depend on the
  parameters swept), then Newton's method inside the bracket, with bisection when a
  step would leave it, to the last bits;
- "at the start" where the condition is already lost at x0 (lambda_N < 0: lets go; a
  friction ratio above mu: slips);
- which comes first along the motion.

Each measure's angle is where it happens if the motion up to there is the shell's: true
for the first event (``first``); the later ones are where they would be had the first
constraint still held. The rest of the row (the other coordinates at the event) comes
from the reduction (eliminated coordinates are functions of x and the parameters). The
time of an event has no closed form here: its column (``slip:t``) is NaN; ``lamech
sweep`` simulates it.

A double root (a condition that touches zero without changing sign) between two grid
points is not seen; nor is a root on the way back, after a turning point.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np
import sympy as sp

from ._parse import EVENT_MEASURES, SweepError, parse_values

if TYPE_CHECKING:
    from ..model import System

__all__ = ["MapResult", "parameter_map", "MAP_MEASURES"]

COARSE = 96
"""Points of the bracketing grid along the reached range."""
CHUNK = 1 << 16
"""Grid points evaluated at once (memory: COARSE x CHUNK doubles per array)."""
MAP_MEASURES = ("slip", "liftoff")
"""The measures with a closed form (``lamech sweep`` has the others)."""


@dataclass
class MapResult:
    """A map's table: ``columns`` {name: array (N,)} in order (the parameters swept, each
    measure's ``<measure>:t`` and ``<measure>:<coordinate>`` as :func:`lamech.sweep`
    names them, ``<measure>:start`` (1.0 where it happens at the start), then
    ``first``: the event met first, ``"<measure>"``, ``"<measure> at the start"`` or
    ``"none"``); ``notes`` what has no closed form and why; ``seconds``: the CPU time
    of the evaluation (after the closed forms were compiled). :func:`lamech.to_csv` gives
    it as CSV (what ``lamech map`` writes)."""

    parameters: list[str]
    measures: list[str]
    columns: dict[str, np.ndarray]
    coordinate: str
    notes: list[str] = field(default_factory=list)
    seconds: float = 0.0

    def __len__(self) -> int:
        return len(self.columns["first"])

    def to_csv(self) -> str:
        """The table as CSV: deprecated, :func:`lamech.to_csv` gives it (the present
        layer formats; this calls it, the one import of this method against the layer
        order, declared in the import-linter contract)."""
        warnings.warn(
            "MapResult.to_csv() is deprecated: lamech.to_csv(result) gives the same text",
            DeprecationWarning,
            stacklevel=2,
        )
        from ..present._table import map_csv

        return map_csv(self)


@dataclass(frozen=True)
class _Condition:
    """One event's condition F(x, P) (its root is the event; F > 0 past it), its
    derivative by x, and where it is already lost at the start."""

    measure: str
    constraint: str
    expr: sp.Expr
    F: object
    dF: object
    valid_expr: sp.Expr | None = None  # lambda_N: the condition means something where > 0
    valid: object | None = None


def parameter_map(
    system: System | str,
    params: Mapping[str, str | np.ndarray],
    measures: list[str] | None = None,
) -> MapResult:
    """The map of ``system`` (a System, a problem file or a bundled example's name) over
    the grid of ``params`` ({name: "A:B:N", "a,b,c" or an array}, every combination),
    for ``measures`` (default: ``("slip", "liftoff")``): a :class:`MapResult`. A measure
    with no closed form (stick, contact, impact, a series) is refused, pointing to
    :func:`lamech.sweep`. See the module docstring.

    >>> import lamech
    >>> m = lamech.map("cylinder", {"mu": "0.1:0.5:5"})
    >>> [round(float(x), 6) for x in m.columns["slip:theta1"]]
    [0.276865, 0.466923, 0.584296, 0.659546, 0.7108]
    >>> sorted(set(m.columns["first"]))
    ['slip']
    """
    import time

    from ..problem import load
    from ..symbolic import solve

    if isinstance(system, str):
        system = load(system)
    from ..symbolic._sensitivity import free_parameters, friction_mu, in_free_parameters

    measures = list(measures or MAP_MEASURES)
    for m in measures:
        kind = m.partition(":")[0]
        if kind not in MAP_MEASURES:
            why = (
                "it happens after an event that changes the motion"
                if kind in EVENT_MEASURES
                else "it is known only along a simulated motion"
            )
            raise SweepError(
                f"measure {m!r} has no closed form to map ({why}); use `lamech sweep`, "
                f"which simulates every case; the map knows: {', '.join(MAP_MEASURES)}"
            )
    sol = solve(system)
    shell = sol.shell
    if shell is None:
        raise SweepError(
            f"no closed form to map: {sol.shell_reason or 'no energy shell'} (the map needs "
            "a motion of one degree of freedom with an energy integral); use `lamech sweep`"
        )
    free = free_parameters(sol.system)
    known = {name: (sym, value) for name, sym, value in free}
    unknown = [n for n in params if n not in known]
    if unknown:
        raise SweepError(
            f"unknown parameter `{unknown[0]}`; the map takes: "
            + ", ".join(known)
            + " (a parameter written as an expression of others follows them)"
        )
    units = sol.system.units
    grids = [
        np.asarray(
            parse_values(v, n, units.of(n) if units is not None else None)
            if isinstance(v, str)
            else v,
            dtype=float,
        ).ravel()
        for n, v in params.items()
    ]
    names = list(params)
    x = shell.coordinate.symbol
    syms = [sym for _, sym, _ in free]
    args = [x, *syms]

    def compile_(expr: sp.Expr):
        e = in_free_parameters(sol.system, expr)
        return sp.lambdify(args, e, modules="numpy")

    conditions: list[_Condition] = []
    notes: list[str] = []
    for m in measures:
        kind, _, target = m.partition(":")
        for c in sol.system.constraints:
            if target and c.name != target:
                continue
            if kind == "liftoff" and c.unilateral and c.name in shell.multipliers:
                lam = shell.multipliers[c.name]
                conditions.append(
                    _Condition(m, c.name, -lam, compile_(-lam), compile_(-sp.diff(lam, x)))
                )
            if kind == "slip" and c.friction is not None:
                lf = shell.multipliers.get(c.name)
                ln = shell.multipliers.get(c.friction.normal)
                if lf is None or ln is None:
                    notes.append(f"slip of `{c.name}`: no closed form of its multipliers")
                    continue
                mu = friction_mu(sol.system, c.name)
                g = sp.Abs(lf) - mu * ln  # |lambda_f| = mu lambda_N, either way
                dg = sp.sign(lf) * sp.diff(lf, x) - mu * sp.diff(ln, x)
                conditions.append(
                    _Condition(m, c.name, g, compile_(g), compile_(dg), ln, compile_(ln))
                )
    for m in measures:
        if not any(c.measure == m for c in conditions):
            what = "unilateral constraint" if m.startswith("liftoff") else "friction constraint"
            notes.append(f"{m}: no {what} with a closed form on the energy shell (never)")
    x0e, v0e = shell.coordinate.initial, shell.coordinate.initial_velocity
    Ke = shell.speed_squared
    x0f, v0f, K, dK = (compile_(e) for e in (x0e, v0e, Ke, sp.diff(Ke, x)))
    minus_K, minus_dK = compile_(-Ke), compile_(-sp.diff(Ke, x))
    from ..symbolic._conditions import is_angle

    angle = is_angle(sol.system, x)
    others = {c.name: compile_(e) for c, e in sol.reduction.eliminated}
    coords = [c.name for c in sol.system.coordinates]
    swept = {sym: name for name, sym, _ in free if name in names}

    def deps(*exprs) -> set[str]:
        out: set[str] = set()
        for e in exprs:
            out |= {swept[s] for s in in_free_parameters(sol.system, e).free_symbols if s in swept}
        return out

    grid = _Grid(names, grids, free)
    start_deps = deps(x0e, v0e, sp.diff(Ke, x))
    started = time.process_time()
    turn = grid.evaluate(
        start_deps | deps(Ke),
        lambda P, n: _first_root(minus_K, minus_dK, None, x0f, v0f, dK, angle, P, n, turning=True)[
            0
        ],
    )
    out: dict[str, np.ndarray] = {n: v for n, v in zip(names, grid.mesh)}
    found = {m: (np.full(grid.size, np.nan), np.zeros(grid.size)) for m in measures}
    x0_all = grid.evaluate(start_deps, lambda P, n: _start(x0f, v0f, dK, P, n)[0])
    d_all = grid.evaluate(start_deps, lambda P, n: _start(x0f, v0f, dK, P, n)[1])
    # one direction for every case (the usual): the roots need not depend on what
    # decides it (the parameters in the initial acceleration)
    same = float(d_all[0]) if grid.size and np.ptp(d_all) == 0 else None
    root_deps = deps(x0e) if same is not None else start_deps
    for cond in conditions:
        exprs = [cond.expr] + ([cond.valid_expr] if cond.valid_expr is not None else [])
        both = grid.evaluate(
            root_deps | deps(*exprs),
            lambda P, n, c=cond: np.concatenate(
                _first_root(c.F, c.dF, c.valid, x0f, v0f, dK, angle, P, n, direction=same)
            ),
            width=2,
        )
        dist, now = both[0], both[1]
        at, start = found[cond.measure]
        dist = np.where(dist <= turn, dist, np.nan)  # met before the motion turns back
        old = d_all * (at - x0_all)
        better = np.isfinite(dist) & (np.isnan(at) | (dist < old)) & (start == 0)
        at[better] = (x0_all + d_all * dist)[better]
        lost = now > 0
        start[lost] = 1.0
        at[lost] = x0_all[lost]
    P_all = [grid.mesh[names.index(n)] if n in names else v for n, _, v in free]
    order = []
    for m in measures:
        at, start = found[m]
        out[f"{m}:t"] = np.full(grid.size, np.nan)
        with np.errstate(all="ignore"):
            for name in coords:
                if name == shell.coordinate.name:
                    value = at
                elif name in others:
                    value = np.broadcast_to(others[name](at, *P_all), (grid.size,)).astype(float)
                else:
                    value = np.full(grid.size, np.nan)
                out[f"{m}:{name}"] = np.where(np.isnan(at), np.nan, value)
        out[f"{m}:start"] = start
        order.append(m)
    out["first"] = _first(order, found, x0_all, d_all, grid.size)
    seconds = time.process_time() - started
    notes.append(
        "the time of an event has no closed form here (its :t column is nan); "
        "`lamech sweep` simulates it"
    )
    return MapResult(names, measures, out, shell.coordinate.name, notes, seconds)


class _Grid:
    """The full grid (every combination of the swept values, the first parameter
    slowest) and the evaluation of a function on the sub-grid of the parameters it
    depends on, spread over the rest: a condition that depends on mu alone is solved
    once per value of mu, however many values of R2 the grid has."""

    def __init__(self, names, grids, free):
        self.names, self.grids, self.free = names, grids, free
        self.shape = tuple(len(g) for g in grids)
        self.size = int(np.prod(self.shape)) if grids else 1
        self.mesh = [a.ravel() for a in np.meshgrid(*grids, indexing="ij")] if grids else []

    def evaluate(self, depends: set[str], fn, width: int = 1) -> np.ndarray:
        """``fn(P, n)`` (P: every free parameter, arrays of n for those in ``depends``)
        on the sub-grid, in chunks, spread to the full grid: (size,), or (width, size)."""
        axes = [i for i, n in enumerate(self.names) if n in depends]
        sub = [self.grids[i] for i in axes]
        mesh = [a.ravel() for a in np.meshgrid(*sub, indexing="ij")] if sub else []
        m = len(mesh[0]) if mesh else 1
        parts = []
        for lo in range(0, m, CHUNK):
            hi = min(m, lo + CHUNK)
            P = []
            for name, _, value in self.free:
                if name in self.names and self.names.index(name) in axes:
                    P.append(mesh[axes.index(self.names.index(name))][lo:hi])
                elif name in self.names:
                    P.append(float(self.grids[self.names.index(name)][0]))  # not used
                else:
                    P.append(value)
            parts.append(np.asarray(fn(P, hi - lo), dtype=float).reshape(width, hi - lo))
        res = np.concatenate(parts, axis=1)
        shape = [len(g) if i in axes else 1 for i, g in enumerate(self.grids)]
        spread = np.broadcast_to(res.reshape(width, *shape), (width, *self.shape))
        out = spread.reshape(width, self.size)
        return out[0] if width == 1 else out


def _start(x0f, v0f, dK, P, n):
    """x0 and the direction of the motion (+1 or -1) per case: the initial velocity's
    sign, else the initial acceleration's (dK/dx at x0), +1 at an equilibrium."""
    with np.errstate(all="ignore"):
        x0 = np.broadcast_to(np.asarray(x0f(0.0, *P), dtype=float), (n,))
        v0 = np.broadcast_to(np.asarray(v0f(0.0, *P), dtype=float), (n,))
        slope = np.broadcast_to(np.asarray(dK(x0, *P), dtype=float), (n,))
    d = np.where(slope < -1e-12, -1.0, 1.0)
    return x0, np.where(v0 > 0, 1.0, np.where(v0 < 0, -1.0, d)), v0


def _first_root(F, dF, valid, x0f, v0f, dK, angle, P, n, turning=False, direction=None):
    """The distance along the motion (d (x - x0) >= 0) to the first root of F, F going
    from <= 0 to > 0 (NaN where none in the span; inf for a turning point never met),
    and 1.0 where F > 0 at the start already (0.0 else). ``direction``: the motion's
    (+1 or -1) where it is the same for every case, else None (found per case)."""
    if direction is None:
        x0, d, v0 = _start(x0f, v0f, dK, P, n)
    else:
        with np.errstate(all="ignore"):
            x0 = np.broadcast_to(np.asarray(x0f(0.0, *P), dtype=float), (n,))
        d, v0 = np.full(n, float(direction)), np.zeros(n)
    span = np.broadcast_to(2 * math.pi if angle else 100.0 * (1.0 + np.abs(x0)), (n,))
    shared = np.ptp(x0) == 0 and np.ptp(d) == 0 and np.ptp(span) == 0
    step = d * span / (COARSE - 1)
    live = np.arange(n)  # the cases whose first crossing is still looked for
    prev = np.empty(n)
    a = np.full(n, np.nan)
    fa, fb = np.full(n, np.nan), np.full(n, np.nan)
    now = np.zeros(n, dtype=bool)
    tol = np.zeros(n)

    def f_at(k: int, idx: np.ndarray) -> np.ndarray:
        xk = x0[0] + k * step[0] if shared else x0[idx] + k * step[idx]
        Pk = [p if np.ndim(p) == 0 else p[idx] for p in P]
        with np.errstate(all="ignore"):
            out = np.asarray(F(xk, *Pk), dtype=float) * np.ones(len(idx))
            if turning:  # -K: a turning point where K goes below zero (beyond rounding)
                out = out - tol[idx]
            if valid is not None:
                ok = np.asarray(valid(xk, *Pk), dtype=float) * np.ones(len(idx)) > 0
                out = np.where(ok, out, np.nan)
        return out

    if turning:
        with np.errstate(all="ignore"):
            k0 = np.asarray(F(x0, *P), dtype=float) * np.ones(n)
        tol = 1e-12 * np.maximum(np.abs(k0), np.maximum(v0**2, 1e-300))
        prev[:] = -np.inf  # the start is never a turning point
    else:
        prev[:] = f_at(0, live)
        now = prev > 0
        live = live[~now]
    for k in range(1, COARSE):
        if not len(live):
            break
        fk = f_at(k, live)
        crossed = (prev[live] <= 0) & (fk > 0)
        hit = live[crossed]
        a[hit] = x0[hit] + (k - 1) * step[hit]
        fa[hit], fb[hit] = prev[hit], fk[crossed]
        prev[live] = fk
        live = live[~crossed]
    has = np.isfinite(a)
    with np.errstate(all="ignore"):  # the secant's point in the bracket
        w = np.where(np.isfinite(fa) & np.isfinite(fb), fa / (fa - fb), 0.5)
    guess = a + np.clip(w, 0.0, 1.0) * step
    root = _refine(F, dF, a, a + step, P, tol if turning else None, guess)
    if turning:
        root = np.where(has & np.isnan(root), a, root)
        return np.where(has, d * (root - x0), np.inf), now.astype(float)
    return np.where(has, d * (root - x0), np.nan), now.astype(float)


def _refine(F, dF, a: np.ndarray, b: np.ndarray, P, shift=None, guess=None) -> np.ndarray:
    """The root of F in each bracket [a, b] (F(a) <= 0 < F(b), a and b in the
    motion's order; NaN: none): Newton's method from ``guess`` (default the midpoint), a
    bisection where a step would leave the bracket, until the bracket or the step is
    below 2e-15 max(|x|, 1). The work is on the cases still iterating only."""
    x = 0.5 * (a + b) if guess is None else guess.copy()
    live = np.nonzero(np.isfinite(x))[0]
    lo, hi = a[live], b[live]
    with np.errstate(all="ignore"):
        for _ in range(60):
            if not len(live):
                break
            Pl = [p if np.ndim(p) == 0 else p[live] for p in P]
            xl = x[live]
            f = np.asarray(F(xl, *Pl), dtype=float) * np.ones_like(xl)
            if shift is not None:
                f = f - shift[live]
            df = np.asarray(dF(xl, *Pl), dtype=float) * np.ones_like(xl)
            past = f > 0
            hi = np.where(past, xl, hi)
            lo = np.where(past, lo, xl)
            step = xl - f / df
            inside = np.isfinite(step) & ((step - lo) * (step - hi) < 0)
            new = np.where(inside, step, 0.5 * (lo + hi))
            near = 2e-15 * np.maximum(np.abs(xl), 1.0)
            done = (np.abs(new - xl) <= near) | (np.abs(hi - lo) <= near) | (f == 0)
            x[live] = np.where(f == 0, xl, new)
            keep = ~done
            live, lo, hi = live[keep], lo[keep], hi[keep]
    return x


def _first(order, found, x0, d, n) -> np.ndarray:
    """Which event comes first along the motion, per case: ``"<measure>"``,
    ``"<measure> at the start"`` or ``"none"``."""
    best = np.full(n, np.inf)
    code = np.zeros(n, dtype=np.int64)
    labels = ["none"]
    for m in order:
        at, start = found[m]
        dist = np.where(start > 0, -1.0, d * (at - x0))
        better = np.isfinite(dist) & (dist < best)
        best[better] = dist[better]
        code[better] = np.where(start[better] > 0, len(labels) + 1, len(labels))
        labels += [m, f"{m} at the start"]
    return np.array(labels, dtype=object)[code]
