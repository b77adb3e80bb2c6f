"""The force or torque of each drive (``[[drives]]``, :class:`lamech.model.Drive`) in
closed form, and, where the drives leave no freedom, its extreme values over a cycle.

A drive is a rheonomic constraint f(q, t) = 0 (f = q_c - motion(t) for a drive of
coordinate q_c); its generalized force on q_c is lambda df/dq_c (:mod:`lamech.model`'s
sign convention: positive when it pushes q_c forward). Its closed form is the
multiplier's, times df/dq_c.

Where the holonomic constraints leave no freedom (as many independent ones as
coordinates: a slider-crank or a four-bar driven by its crank) and one drive turns its
coordinate at a constant rate omega while nothing else depends on t, the motion repeats
with each turn of q_c (2 pi), and the torque is a function of q_c alone: along the
motion q(t) solves f(q, t) = 0, q' = -A^-1 df/dt and q'' = -A^-1 gamma, and
d tau/dt = tau_q q' + tau_q' q'' + tau_t from the closed form's exact derivatives. Its
extreme values over a turn are the roots of that derivative, each bracketed on a grid
and found by Brent's method; the configuration between grid points follows the branch
the motion starts on (Newton's method from the nearest grid point).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import sympy as sp

if TYPE_CHECKING:
    from ._solution import Solution

__all__ = ["DriveForce", "DriveCycle", "Extreme", "drive_forces", "turns"]

_GRID = 720  # points per turn where the derivative's sign changes are looked for
_NEWTON = 30


@dataclass(frozen=True)
class Extreme:
    """An extreme value of a drive's force or torque over a cycle: ``value``, where
    (``angle``, the drive coordinate's value, in [start, start + 2 pi)) and when (``t``,
    in the first cycle)."""

    value: float
    angle: float
    t: float


@dataclass(frozen=True)
class DriveCycle:
    """A drive's force or torque over one turn of its coordinate (the drives leave no
    freedom): its ``max`` and ``min`` (:class:`Extreme`), ``period`` (the time of a turn)
    and ``start`` (the coordinate at t = 0). :meth:`at` evaluates it at values of the
    coordinate."""

    coordinate: str
    period: float
    start: float
    max: Extreme
    min: Extreme
    _follow: Any = field(default=None, repr=False, compare=False)

    def at(self, angle: float) -> float:
        """The force or torque where the drive coordinate is ``angle`` (any turn)."""
        t = (float(angle) - self.start) / (2 * math.pi) * self.period
        return float(self._follow.torque(t % self.period))

    def rate(self, angle: float) -> float:
        """Its derivative with respect to the drive coordinate at ``angle``."""
        t = (float(angle) - self.start) / (2 * math.pi) * self.period
        return float(self._follow.rate(t % self.period)) * self.period / (2 * math.pi)


@dataclass(frozen=True)
class DriveForce:
    """One drive: its ``name``, the ``coordinate`` it drives (None for a general f),
    ``expr`` the force or torque lambda df/dq_c (the multiplier itself without a
    coordinate) in the state, ``cycle`` its extremes over a turn where the drives leave
    no freedom (else None, and ``note`` says why)."""

    name: str
    coordinate: str | None
    expr: sp.Expr | None
    cycle: DriveCycle | None = None
    note: str = ""


def turns(system, name: str) -> bool:
    """Whether drive ``name``'s coordinate turns: the system repeats after 2 pi of it
    (it appears in the Lagrangian, the forces and the other constraints only inside
    sin, cos and tan, and somewhere), so that a turn is a cycle."""
    con = system.constraint(name)
    if con.drive is None or con.drive.coordinate is None:
        return False
    q = system.symbols[con.drive.coordinate]
    exprs = [system.T, system.V, *system.forces]
    exprs += [c.expr for c in system.constraints if c.name != name]
    trig = (sp.sin, sp.cos, sp.tan)
    seen = False
    for e in exprs:
        e = sp.sympify(e)
        if not e.has(q):
            continue
        seen = True
        stripped = e.replace(lambda x: isinstance(x, trig) and x.has(q), lambda x: sp.Dummy())
        if stripped.has(q):
            return False
    return seen


def drive_forces(sol: Solution) -> dict[str, DriveForce]:
    """The :class:`DriveForce` of each drive of ``sol.system``, by name."""
    system = sol.system
    out: dict[str, DriveForce] = {}
    for j, c in enumerate(system.constraints):
        if c.drive is None:
            continue
        lam = sol.multipliers.get(c.name)
        coord = c.drive.coordinate
        factor: sp.Expr = sp.Integer(1)
        if coord is not None:
            factor = sp.diff(c.expr, system.symbols[coord])
        expr = None if lam is None else sp.expand(lam * sol.reduction.apply(factor))
        if lam is not None and factor == 1:
            expr = lam
        cycle, note = None, ""
        if expr is None:
            note = "no closed form of its multiplier (see the notes)"
        else:
            cycle, note = _cycle(sol, j, expr)
        out[c.name] = DriveForce(c.name, coord, expr, cycle, note)
    return out


def _cycle(sol: Solution, j: int, expr: sp.Expr) -> tuple[DriveCycle | None, str]:
    """The extremes over a turn, or (None, why there are none)."""
    system = sol.system
    con = system.constraints[j]
    t = system.t
    coords = [c.symbol for c in system.coordinates]
    n = len(coords)
    if con.drive is None or con.drive.coordinate is None:
        return None, "a general f: no coordinate to turn"
    if any(not c.holonomic or c.unilateral or c.friction for c in system.constraints):
        return None, "the cycle is found for holonomic, bilateral constraints only"
    if len(system.constraints) != n:
        return None, "the drives leave freedom: the force depends on the motion, see simulate"
    if not turns(system, con.name):
        return None, "the system does not repeat after a turn of its coordinate (not an angle)"
    others = [c for i, c in enumerate(system.constraints) if i != j]
    if any(t in c.expr.free_symbols for c in others) or (
        t in system.T.free_symbols or t in system.V.free_symbols
    ):
        return None, "another constraint or the Lagrangian depends on t: no repeating cycle"
    qc = system.symbols[con.drive.coordinate]
    dfdc = sp.diff(con.expr, qc)
    dfdt = sp.diff(con.expr, t)
    if (
        dfdc.free_symbols
        or sp.diff(dfdt, t) != 0
        or dfdt.free_symbols - set(system.parameter_values)
    ):
        return None, "its coordinate does not turn at a constant rate"
    values = system.parameter_values
    omega = float(-(dfdt / dfdc).subs(values))
    if omega == 0:
        return None, "its coordinate does not turn"
    follow = _Follow.of(sol, expr, values)
    if follow is None:
        return None, "the constraints are singular at the start"
    period = 2 * math.pi / abs(omega)
    ic = coords.index(qc)
    start = follow.q0[ic]
    grid = np.linspace(0.0, period, _GRID + 1)
    follow.walk(grid)
    rates = np.array([follow.rate(s) for s in grid])
    roots = []
    from scipy.optimize import brentq

    for k in range(_GRID):
        a, b = rates[k], rates[k + 1]
        if a == 0:
            roots.append(grid[k])
        elif a * b < 0:
            roots.append(brentq(follow.rate, grid[k], grid[k + 1], xtol=1e-15, rtol=1e-15))
    if not roots:  # constant: every point an extreme
        roots = [0.0]
    found = [Extreme(follow.torque(s), float(start + omega * s), float(s)) for s in roots]
    hi = max(found, key=lambda e: e.value)
    lo = min(found, key=lambda e: e.value)
    name = con.drive.coordinate
    return DriveCycle(name, period, start, hi, lo, follow), ""


class _Follow:
    """The state along the driven motion: q(t) on the branch the motion starts on, q',
    q'', the torque and its time derivative there."""

    def __init__(self, F, A, b, gam, tau, grad, q0):
        self.F, self.A, self.b, self.gam, self.tau, self.grad = F, A, b, gam, tau, grad
        self.q0 = q0
        self.ts = np.array([0.0])
        self.qs = q0[None, :].copy()

    @classmethod
    def of(cls, sol: Solution, expr: sp.Expr, values: dict) -> _Follow | None:
        system = sol.system
        t = system.t
        q = [c.symbol for c in system.coordinates]
        v = [c.velocity for c in system.coordinates]
        f = sp.Matrix([c.expr for c in system.constraints]).subs(values)
        A = f.jacobian(q)
        b = f.diff(t)
        vv = sp.Matrix(v)
        Fdot = A * vv + b
        gam = Fdot.jacobian(q) * vv + Fdot.diff(t)
        tau = sp.sympify(expr).subs(values)
        args = (*q, *v, t)
        grad = [sp.diff(tau, s) for s in args]
        mods = ["numpy"]
        F_ = sp.lambdify((q, t), list(f), mods)
        A_ = sp.lambdify((q, t), A, mods)
        b_ = sp.lambdify((q, t), list(b), mods)
        g_ = sp.lambdify((q, v, t), list(gam), mods)
        tau_ = sp.lambdify((q, v, t), tau, mods)
        grad_ = sp.lambdify((q, v, t), grad, mods)
        from ..model._checks import initial_values  # noqa: I001

        start = initial_values(system)
        q0 = np.array([float(start[s]) for s in q])
        self = cls(F_, A_, b_, g_, tau_, grad_, q0)
        try:
            self.qs[0] = self._newton(q0, 0.0)
        except np.linalg.LinAlgError:
            return None
        return self

    def _newton(self, q: np.ndarray, t: float) -> np.ndarray:
        q = np.array(q, dtype=float)
        for _ in range(_NEWTON):
            r = np.array(self.F(q, t), dtype=float)
            dq = np.linalg.solve(np.array(self.A(q, t), dtype=float), -r)
            q = q + dq
            if np.max(np.abs(dq)) <= 1e-15 * (1 + np.max(np.abs(q))):
                break
        return q

    def walk(self, grid: np.ndarray) -> None:
        """Follow the branch over ``grid`` (increasing from 0): the states kept."""
        qs = [self.qs[0]]
        for s in grid[1:]:
            prev = qs[-1]
            if len(qs) >= 2:  # a linear predictor
                prev = 2 * qs[-1] - qs[-2]
            qs.append(self._newton(prev, float(s)))
        self.ts, self.qs = np.asarray(grid, dtype=float), np.array(qs)

    def state(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        k = int(np.clip(np.searchsorted(self.ts, t), 0, len(self.ts) - 1))
        if k > 0 and abs(self.ts[k - 1] - t) < abs(self.ts[k] - t):
            k -= 1
        q = self._newton(self.qs[k], t)
        A = np.array(self.A(q, t), dtype=float)
        v = np.linalg.solve(A, -np.array(self.b(q, t), dtype=float))
        a = np.linalg.solve(A, -np.array(self.gam(q, v, t), dtype=float))
        return q, v, a

    def torque(self, t: float) -> float:
        q, v, _ = self.state(t)
        return float(self.tau(q, v, t))

    def rate(self, t: float) -> float:
        q, v, a = self.state(t)
        g = np.array(self.grad(q, v, t), dtype=float)
        n = len(q)
        return float(g[:n] @ v + g[n : 2 * n] @ a + g[2 * n])
