"""Simulation: the constrained motion, kept on the constraint manifold, with its
multipliers, contact changes (lift-off, impact, contact), and friction (slip, stick).

The motion is the index-3 DAE of :mod:`lamech.derive`. At each evaluation the KKT system

    [ M  -A_a^T ] [ q'' ]   [ Q - h    ]
    [ A_a   0   ] [ lam ] = [ -gamma_a ]

is solved for the active constraints a (M is never inverted alone); SciPy's DOP853
integrates (q, q') step by step and after every accepted step the state is projected
back onto the manifold: positions onto f_a = 0 by Gauss-Newton in the mass-matrix metric
(Euclidean where M is singular), velocities onto A_a q' + b_a = 0. A slipping friction
constraint j on normal k is not in a; its generalized force -mu N sign(s) dF_j/dq'
(s = F_j, the slip velocity; N = lambda_k) enters the KKT matrix as an extra term in the
column of lambda_k, so N stays exact.

Events are sign changes, checked at every step and located by root finding (Brent) on
the step's dense output:

* ``lift-off``: an engaged unilateral lambda crosses zero: the constraint and the
  friction constraints that name it as their normal are released;
* ``impact`` / ``contact``: a released unilateral f reaches zero from f > 0: the
  generalized impulse on the active set plus this constraint gives F_j+ = -e F_j-
  (Newton's law, ``restitution`` e); it bounces (``impact``) or, when e = 0 or the
  bounce is too small to resolve, engages (``contact``);
* ``slip``: |lambda_friction| reaches mu N: the friction constraint is removed and
  kinetic friction applied, opposing the slip velocity;
* ``stick``: the slip velocity reaches zero and sticking can hold (else the slip
  reverses, logged as ``slip``).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np
import sympy as sp

from ..model import Parameter, System
from ._codegen import NumericSystem, compile_system
from ._trajectory import Trajectory

__all__ = ["simulate", "SimulationError", "DEFAULT_RTOL", "DEFAULT_ATOL"]

DEFAULT_RTOL = 1e-11
DEFAULT_ATOL = 1e-12
INITIAL_TOLERANCE = 1e-10
BLOW_UP = 1e12
"""A run stops as failed when max(|q|, |q'|) exceeds BLOW_UP (1 + its size at the start)."""
_METHODS = ("DOP853", "RK45", "Radau")
"""SciPy's integrators by name (SciPy is imported when a simulation runs, not before)."""


def _method(name: str):
    import scipy.integrate
    return getattr(scipy.integrate, name)


class SimulationError(ValueError):
    """Bad options or an inconsistent initial state (nothing was integrated)."""


class _Stop(Exception):
    """Stop the run: ``cause`` names the time, the reason and what to try."""

    def __init__(self, cause: str):
        super().__init__(cause)
        self.cause = cause


@dataclass
class _Sample:
    t: float
    q: np.ndarray
    v: np.ndarray
    lam: np.ndarray
    rp: float
    rv: float
    T: float
    V: float


class _Engine:
    def __init__(self, ns: NumericSystem, p: np.ndarray, rtol: float, atol: float,
                 max_step: float, method: str):
        self.ns, self.p = ns, p
        self.kernel = ns.rhs_kernel
        self.n, self.m = ns.n, ns.m
        self.rtol, self.atol, self.max_step = rtol, atol, max_step
        self.method = _method(method)
        sys_ = ns.system
        names = ns.constraint_names
        self.unilateral = np.array([c.unilateral for c in sys_.constraints], dtype=bool)
        self.holonomic = np.array([c.holonomic for c in sys_.constraints], dtype=bool)
        self.normal = np.array([names.index(c.friction.normal) if c.friction else -1
                                for c in sys_.constraints], dtype=int)
        self.engaged = np.ones(self.m, dtype=bool)      # for unilateral constraints
        self.fstate = ["stick" if k >= 0 else "" for k in self.normal]  # stick/slip/off
        self.sigma = np.zeros(self.m)
        self.sN = np.ones(self.m)
        self.offset = np.zeros(self.m)   # f_j held at this value while friction j sticks
        self.armed: dict[tuple[str, int], bool] = {}
        self.events: list[dict] = []
        self.evaluations = 0
        self.dissipative = False
        self.euclidean = False
        self.arm_pos = max(100.0 * atol, 1e-13)
        self.arm_vel = max(100.0 * atol, 1e-13)
        self._rebuild()

    # ----- the mode ------------------------------------------------------------------
    def _rebuild(self) -> None:
        rows = []
        for j in range(self.m):
            k = self.normal[j]
            if k >= 0:
                if not self._row_active(k):
                    self.fstate[j] = "off"
                elif self.fstate[j] == "off":
                    self.fstate[j] = "stick"
                if self.fstate[j] == "stick":
                    rows.append(j)
            elif self._row_active(j):
                rows.append(j)
        self.rows = np.array(rows, dtype=int)
        self.hrows = np.array([j for j in rows if self.holonomic[j]], dtype=int)
        self.pos = {j: i for i, j in enumerate(rows)}
        self.slips = [(j, int(self.normal[j])) for j in range(self.m)
                      if self.normal[j] >= 0 and self.fstate[j] == "slip"]
        self._mode_arrays = (
            self.rows.astype(np.int64),
            np.array([j for j, _ in self.slips], dtype=np.int64),
            np.array([self.pos[k] for _, k in self.slips], dtype=np.int64),
            np.array([self.sN[j] * self.sigma[j] for j, _ in self.slips], dtype=float))
        # event list: (kind, j)
        ev = []
        for j in range(self.m):
            if self.unilateral[j]:
                ev.append(("lift-off", j) if self.engaged[j] else ("contact", j))
            if self.normal[j] >= 0:
                if self.fstate[j] == "stick":
                    ev.append(("slip", j))
                elif self.fstate[j] == "slip":
                    ev.append(("stick", j))
        self.event_list = ev

    def _row_active(self, j: int) -> bool:
        if self.normal[j] >= 0:
            return self.fstate[j] == "stick" and self._row_active(int(self.normal[j]))
        return bool(self.engaged[j]) if self.unilateral[j] else True

    # ----- the dynamics -----------------------------------------------------------
    def kkt(self, t: float, q: np.ndarray, v: np.ndarray):
        """(q'', lam (m,) NaN where inactive, kinetic friction where slipping, A, gamma)."""
        self.evaluations += 1
        try:
            M, rhs, A, gam, mu = self.ns.dynamics(t, q, v, self.p)
        except (ValueError, ArithmeticError) as exc:
            raise _Stop(f"the dynamics cannot be evaluated at t = {t:.12g} ({exc}): a "
                        "coordinate, parameter or time left the domain of an expression "
                        "(sqrt or log of a negative number, division by zero); check the "
                        "expressions, the parameters and the initial state") from None
        n, rows = self.n, self.rows
        na = len(rows)
        if na == 0:
            K, r = M, rhs
        else:
            K = np.zeros((n + na, n + na))
            K[:n, :n] = M
            Ar = A[rows]
            K[:n, n:] = -Ar.T
            K[n:, :n] = Ar
            for j, k in self.slips:
                K[:n, n + self.pos[k]] += mu[j] * self.sN[j] * self.sigma[j] * A[j]
            r = np.concatenate((rhs, -gam[rows]))
        try:
            sol = np.linalg.solve(K, r)
        except np.linalg.LinAlgError:
            raise _Stop(f"singular KKT matrix at t = {t:.12g}: the constraints are "
                        "dependent here (a singular configuration) or a motion they allow "
                        "has no inertia; start elsewhere or remove a redundant "
                        "constraint") from None
        if not np.all(np.isfinite(sol)):
            raise _Stop(f"non-finite accelerations or multipliers at t = {t:.12g} "
                        "(NaN/inf in the dynamics: a coordinate left the domain of an "
                        "expression, or the KKT matrix is singular)")
        lam = np.full(self.m, np.nan)
        if na:
            lam[rows] = sol[n:]
        for j, k in self.slips:
            lam[j] = -mu[j] * self.sN[j] * self.sigma[j] * lam[k]
        return sol[:n], lam, A, gam, mu, K

    def fun(self, t: float, y: np.ndarray) -> np.ndarray:
        """The right-hand side; NaN where the KKT system fails, so that the integrator
        rejects the trial step and shrinks it (a failure at an accepted state stops the
        run with the cause)."""
        self.evaluations += 1
        try:
            return self.kernel(t, y, self.p, *self._mode_arrays)
        except (ValueError, ArithmeticError):    # e.g. sqrt of a negative number
            return np.full(y.shape, np.nan)

    # ----- projection --------------------------------------------------------------
    def _metric(self, t, q, v):
        if self.euclidean:
            return np.eye(self.n)
        return self.ns.dynamics(t, q, v, self.p)[0]

    def _solve_min_norm(self, W, A, r):
        """dx minimising dx^T W dx subject to A dx = r."""
        n, k = self.n, A.shape[0]
        K = np.zeros((n + k, n + k))
        K[:n, :n] = W
        K[:n, n:] = A.T
        K[n:, :n] = A
        rhs = np.concatenate((np.zeros(n), r))
        try:
            sol = np.linalg.solve(K, rhs)
            if np.all(np.isfinite(sol)):
                return sol[:n]
        except np.linalg.LinAlgError:
            pass
        if not self.euclidean:
            self.euclidean = True
            return self._solve_min_norm(np.eye(n), A, r)
        dx, *_ = np.linalg.lstsq(A, r, rcond=None)
        return dx

    def project(self, t: float, y: np.ndarray, positions: bool = True) -> tuple[np.ndarray, float]:
        """y projected onto the active manifold; also the size of the correction."""
        n = self.n
        q, v = y[:n].copy(), y[n:].copy()
        moved = 0.0
        if positions and len(self.hrows):
            W = None
            for _ in range(6):
                f, A, b = self.ns.constraints(t, q, self.p)
                r = f[self.hrows] - self.offset[self.hrows]
                scale = 1.0 + float(np.max(np.abs(q), initial=0.0))
                if np.max(np.abs(r)) <= 2e-16 * scale * max(1.0, float(np.abs(A).max())):
                    break
                if W is None:
                    W = self._metric(t, q, v)
                dq = self._solve_min_norm(W, A[self.hrows], -r)
                q += dq
                moved = max(moved, float(np.max(np.abs(dq))))
                if np.max(np.abs(dq)) <= 1e-16 * scale:
                    break
        if len(self.rows):
            f, A, b = self.ns.constraints(t, q, self.p)
            r = A[self.rows] @ v + b[self.rows]
            if np.any(r != 0):
                W = self._metric(t, q, v)
                dv = self._solve_min_norm(W, A[self.rows], -r)
                v += dv
                moved = max(moved, float(np.max(np.abs(dv))))
        return np.concatenate((q, v)), moved

    def residuals(self, t, q, v) -> tuple[float, float]:
        if not len(self.rows):
            return 0.0, 0.0
        f, A, b = self.ns.constraints(t, q, self.p)
        rp = float(np.max(np.abs(f[self.hrows] - self.offset[self.hrows]), initial=0.0)) \
            if len(self.hrows) else 0.0
        rv = float(np.max(np.abs(A[self.rows] @ v + b[self.rows]), initial=0.0))
        return rp, rv

    # ----- events ------------------------------------------------------------------
    def event_values(self, t: float, y: np.ndarray, lam=None) -> np.ndarray:
        if not self.event_list:
            return np.zeros(0)
        n = self.n
        q, v = y[:n], y[n:]
        if lam is None:
            _, lam, _, _, mu, _ = self.kkt(t, q, v)
        else:
            lam, mu = lam
        f, A, b = self.ns.constraints(t, q, self.p)
        out = np.empty(len(self.event_list))
        for i, (kind, j) in enumerate(self.event_list):
            if kind == "lift-off":
                out[i] = lam[j]
            elif kind == "contact":
                out[i] = f[j] + (0.0 if self.armed.get((kind, j), True) else self.arm_pos)
            elif kind == "slip":
                k = self.normal[j]
                out[i] = mu[j] * self.sN[j] * lam[k] - abs(lam[j])
            else:  # stick: the slip velocity reaching zero
                s = float(A[j] @ v + b[j])
                out[i] = self.sigma[j] * s + (0.0 if self.armed.get((kind, j), True)
                                             else self.arm_vel)
        return out

    def update_arming(self, t, y) -> None:
        n = self.n
        f, A, b = self.ns.constraints(t, y[:n], self.p)
        for kind, j in self.event_list:
            key = (kind, j)
            if self.armed.get(key, True):
                continue
            if kind == "contact" and f[j] > self.arm_pos:
                self.armed[key] = True
            elif kind == "stick" and self.sigma[j] * float(A[j] @ y[n:] + b[j]) > self.arm_vel:
                self.armed[key] = True

    def log(self, t, y, kind, j, **extra) -> None:
        n = self.n
        coords = {c: float(y[i]) for i, c in enumerate(self.ns.coordinate_names)}
        coords.update({c + "'": float(y[n + i])
                       for i, c in enumerate(self.ns.coordinate_names)})
        self.events.append({"t": float(t), "kind": kind,
                            "constraint": self.ns.constraint_names[j], "coordinates": coords,
                            **extra})

    # ----- mode switches -----------------------------------------------------------
    def release(self, j: int) -> None:
        self.engaged[j] = False
        self.armed[("contact", j)] = False
        self._rebuild()

    def start_slip(self, j: int, lam_j: float, s: float = 0.0) -> None:
        self.fstate[j] = "slip"
        self.sigma[j] = -math.copysign(1.0, lam_j) if abs(s) <= self.arm_vel \
            else math.copysign(1.0, s)
        self.armed[("stick", j)] = False
        self.dissipative = True
        self._rebuild()

    def stick(self, t: float, y: np.ndarray, j: int) -> None:
        """Friction j sticks from now on: its f is held at its present value."""
        f, _, _ = self.ns.constraints(t, y[:self.n], self.p)
        self.offset[j] = f[j] if self.holonomic[j] else 0.0
        self.fstate[j] = "stick"
        self._rebuild()

    def settle(self, t: float, y: np.ndarray) -> np.ndarray:
        """Make the mode consistent at (t, y): release unilateral constraints pulling
        (lambda < 0), let friction beyond mu N slip; log each change."""
        n = self.n
        for _ in range(4 * self.m + 4):
            y, _ = self.project(t, y)
            _, lam, A, gam, mu, _ = self.kkt(t, y[:n], y[n:])
            scale = 1.0 + float(np.nanmax(np.abs(lam), initial=0.0))
            for j in self.rows:
                k = self.normal[j]
                if k >= 0 and not self.unilateral[k] and lam[k] != 0:
                    self.sN[j] = math.copysign(1.0, lam[k])   # a bilateral normal: mu |N|
            worst, jw = 0.0, -1
            for j in self.rows:
                if self.unilateral[j] and lam[j] < -1e-12 * scale and lam[j] < worst:
                    worst, jw = lam[j], int(j)
            if jw >= 0:
                self.release(jw)
                self.log(t, y, "lift-off", jw, multiplier=float(worst))
                continue
            worst, jw = 0.0, -1
            for j in self.rows:
                k = self.normal[j]
                if k >= 0:
                    limit = mu[j] * self.sN[j] * lam[k]
                    excess = abs(lam[j]) - limit
                    if excess > 1e-12 * scale and excess > worst:
                        worst, jw = excess, int(j)
            if jw >= 0:
                f, Af, b = self.ns.constraints(t, y[:n], self.p)
                self.start_slip(jw, lam[jw], float(Af[jw] @ y[n:] + b[jw]))
                self.log(t, y, "slip", jw, ratio=float(abs(lam[jw]) / max(
                    abs(mu[jw] * lam[self.normal[jw]]), 1e-300)))
                continue
            return y
        raise _Stop(f"the contact mode does not settle at t = {t:.12g} (constraints switch "
                    "back and forth); the configuration may be degenerate")

    def apply(self, t: float, y: np.ndarray, kind: str, j: int) -> np.ndarray:
        n = self.n
        if kind == "lift-off":
            self.release(j)
            self.log(t, y, "lift-off", j)
        elif kind == "slip":
            _, lam, _, _, mu, _ = self.kkt(t, y[:n], y[n:])
            self.start_slip(j, lam[j])
            self.log(t, y, "slip", j)
        elif kind == "stick":
            sigma = self.sigma[j]
            self.stick(t, y, j)
            y, _ = self.project(t, y)
            _, lam, _, _, mu, _ = self.kkt(t, y[:n], y[n:])
            k = self.normal[j]
            if abs(lam[j]) <= mu[j] * self.sN[j] * lam[k] * (1 + 1e-9):
                self.log(t, y, "stick", j)
            else:
                self.start_slip(j, lam[j])
                self.log(t, y, "slip", j, reversal=bool(self.sigma[j] != sigma))
        elif kind == "contact":
            y = self.impact(t, y, j)
        return self.settle(t, y)

    def impact(self, t: float, y: np.ndarray, j: int) -> np.ndarray:
        n = self.n
        q, v = y[:n], y[n:]
        f, A, b = self.ns.constraints(t, q, self.p)
        e = float(self.ns.restitution(t, q, self.p)[j])
        Fm = float(A[j] @ v + b[j])
        qdd, lam, _, gam, mu, _ = self.kkt(t, q, v)
        a_gap = abs(float(A[j] @ qdd + gam[j]))
        v_small = 2.0 * math.sqrt(2.0 * a_gap * self.arm_pos) + 10 * self.arm_vel
        engage = e == 0 or e * abs(Fm) <= v_small
        frows = [i for i in range(self.m) if self.normal[i] == j] if engage else []
        M = self.ns.dynamics(t, q, v, self.p)[0]
        self.dissipative = self.dissipative or e < 1 or engage

        def solve(extra):
            rows = list(self.rows) + [j] + extra
            k = len(rows)
            K = np.zeros((n + k, n + k))
            K[:n, :n] = M
            K[:n, n:] = -A[rows].T
            K[n:, :n] = A[rows]
            target = -b[rows]
            target[len(self.rows)] = (0.0 if engage else -e * Fm) - b[j]
            sol = np.linalg.solve(K, np.concatenate((M @ v, target)))
            return sol[:n], dict(zip(rows, sol[n:]))

        slipping: list[int] = []
        try:
            vp, imp = solve(frows)
            slipping = [i for i in frows if abs(imp[i]) > mu[i] * imp[j] * (1 + 1e-9)]
            if slipping:
                frows = [i for i in frows if i not in slipping]
                vp, imp = solve(frows)
        except np.linalg.LinAlgError:
            raise _Stop(f"singular impact matrix at t = {t:.12g} (constraint "
                        f"`{self.ns.constraint_names[j]}`)") from None
        y = np.concatenate((q, vp))
        extra = {"impulse": float(imp[j]), "velocity_before": Fm, "restitution": e}
        if engage:
            self.engaged[j] = True
            self._rebuild()
            for i in range(self.m):
                if self.normal[i] == j:
                    self.stick(t, y, i)
            for i in slipping:
                s = float(A[i] @ vp + b[i])
                self.start_slip(i, imp[i], s)
            self.log(t, y, "contact", j, **extra)
        else:
            self.armed[("contact", j)] = False
            self.log(t, y, "impact", j, **extra)
        return y


# ----- overrides: parameters, friction coefficients, initial values -------------------
def friction_names(system: System) -> dict[str, str]:
    """Sweepable friction names -> constraint name."""
    fr = [c.name for c in system.constraints if c.friction is not None]
    out = {f"mu:{c}": c for c in fr}
    if len(fr) == 1 and "mu" not in {p.name for p in system.parameters}:
        out["mu"] = fr[0]
    return out


def with_friction_parameters(system: System, names: Iterable[str]) -> System:
    """``system`` with the friction coefficients named in ``names`` made parameters."""
    params = {p.name for p in system.parameters}
    friction = friction_names(system)
    known = [p.name for p in system.parameters] + list(friction)
    unknown = [n for n in names if n not in params and n not in friction]
    if unknown:
        raise ValueError(f"unknown parameter{'s' if len(unknown) > 1 else ''} "
                         f"{', '.join('`%s`' % n for n in unknown)}; known: {', '.join(known)}")
    new_params = list(system.parameters)
    constraints = list(system.constraints)
    taken = {str(s) for s in system.symbols.values()}
    done: set[str] = set()
    for name in names:
        if name in params or friction[name] in done:
            continue
        cname = friction[name]
        done.add(cname)
        j = next(i for i, c in enumerate(constraints) if c.name == cname)
        c = constraints[j]
        sym_name = f"mu_{cname}"
        while sym_name in taken:
            sym_name += "_"
        taken.add(sym_name)
        sym = sp.Symbol(sym_name, positive=True)
        value = c.friction.mu
        new_params.append(Parameter(name, sym, value, float(system.numeric(value))))
        constraints[j] = dataclasses.replace(
            c, friction=dataclasses.replace(c.friction, mu=sym))
    if not done:
        return system
    return dataclasses.replace(system, parameters=tuple(new_params),
                               constraints=tuple(constraints))


def consistent_initial(ns, p: np.ndarray, initial: Sequence[tuple[str, float]]):
    """The initial state at ``p`` with the named coordinates/velocities set and held; the
    other coordinates moved (least squares, Gauss-Newton) to meet the constraints that
    the problem's own initial state meets, and likewise the velocities."""
    q, v = ns.initial_state(p)
    if not initial:
        return q, v
    names = ns.coordinate_names
    n = len(names)
    f0, A0, b0 = ns.constraints(0.0, q, p)
    F0 = A0 @ v + b0
    tol = 1e-10 * (1 + float(np.max(np.abs(q), initial=0.0)))
    hol = [c.holonomic for c in ns.system.constraints]
    rows_q = [j for j in range(ns.m) if hol[j] and abs(f0[j]) <= tol]
    rows_v = [j for j in range(ns.m) if abs(F0[j]) <= tol and (not hol[j] or j in rows_q)]
    fixed_q, fixed_v = set(), set()
    for name, value in initial:
        if name.endswith("'"):
            i = names.index(name[:-1])
            v[i] = value
            fixed_v.add(i)
        else:
            i = names.index(name)
            q[i] = value
            fixed_q.add(i)
    free_q = [i for i in range(n) if i not in fixed_q]
    if rows_q and free_q:
        for _ in range(60):
            f, A, _ = ns.constraints(0.0, q, p)
            rows = [j for j in rows_q if np.any(A[j, free_q] != 0)]
            if not rows:
                break
            r = f[rows]
            if np.max(np.abs(r)) <= 1e-15 * (1 + float(np.max(np.abs(q)))):
                break
            dq, *_ = np.linalg.lstsq(A[np.ix_(rows, free_q)], -r, rcond=None)
            q[free_q] += dq
            if np.max(np.abs(dq)) <= 1e-16 * (1 + float(np.max(np.abs(q)))):
                break
    free_v = [i for i in range(n) if i not in fixed_v]
    if rows_v and free_v:
        _, A, b = ns.constraints(0.0, q, p)
        rows = [j for j in rows_v if np.any(A[j, free_v] != 0)]
        if rows:
            r = A[rows] @ v + b[rows]
            dv, *_ = np.linalg.lstsq(A[np.ix_(rows, free_v)], -r, rcond=None)
            v[free_v] += dv
    return q, v



def _as_vector(value, names: list[str], what: str) -> np.ndarray | None:
    if value is None:
        return None
    if isinstance(value, dict):
        unknown = set(value) - set(names)
        if unknown:
            raise SimulationError(f"unknown {what} {sorted(unknown)}; known: {', '.join(names)}")
        return value
    arr = np.asarray(value, dtype=float)
    if arr.shape != (len(names),):
        raise SimulationError(f"{what}: expected {len(names)} values ({', '.join(names)})")
    return arr


def check_options(t_end, t0, rtol, atol, max_step, samples, dt) -> None:
    def bad(x):
        return not isinstance(x, (int, float, np.floating, np.integer)) or not math.isfinite(x)
    if bad(t_end) or bad(t0) or t_end <= t0:
        raise SimulationError(f"t_end must be a finite number after the start time {t0} "
                              f"(got {t_end})")
    if bad(rtol) or rtol <= 0 or rtol >= 1:
        raise SimulationError(f"rtol must be in (0, 1) (got {rtol}); default {DEFAULT_RTOL}")
    if rtol < 1e-14:
        raise SimulationError(f"rtol {rtol} is below 1e-14, which double precision cannot "
                              "honour; use rtol >= 1e-14")
    if bad(atol) or atol <= 0:
        raise SimulationError(f"atol must be positive (got {atol}); default {DEFAULT_ATOL}")
    if max_step is not None and (not isinstance(max_step, (int, float)) or
                                 math.isnan(max_step) or max_step <= 0):
        raise SimulationError(f"max_step must be positive (got {max_step})")
    if samples is not None and dt is not None:
        raise SimulationError("give samples or dt, not both")
    if samples is not None and (not isinstance(samples, (int, np.integer)) or samples < 2):
        raise SimulationError(f"samples counts both ends and must be an integer >= 2 "
                              f"(got {samples})")
    if dt is not None and (bad(dt) or dt <= 0):
        raise SimulationError(f"dt must be a positive number (got {dt})")


def simulate(system: System | NumericSystem, t_end: float, *, t0: float = 0.0,
             samples: int | None = None, dt: float | None = None,
             rtol: float = DEFAULT_RTOL, atol: float = DEFAULT_ATOL,
             max_step: float | None = None, params: dict | None = None,
             q0=None, qd0=None, initial: dict | None = None,
             project_initial: bool = False, method: str = "DOP853",
             progress=None, jit: bool = False) -> Trajectory:
    """Simulate ``system`` from ``t0`` to ``t_end``; see the module docstring.

    ``samples`` (default 1001, both ends counted) or ``dt`` set the output times (dense
    output). ``params`` overrides parameter values by name; ``q0``/``qd0`` override the
    initial state (dicts by coordinate name, or arrays in coordinate order), as given.
    ``initial`` {coordinate or ``x'``: value} sets those values and holds them while the
    other coordinates and velocities move (least squares) to meet the constraints the
    problem's own initial state meets: ``initial={"theta1": 0.01}`` starts the cylinder
    just off the top, with r and theta2 following. ``params`` may also name a friction
    coefficient (``"mu:<constraint>"``, or ``"mu"`` when there is one). An initial
    state off the constraints (|f| or |F| > 1e-10 (1 + max |q|)) raises
    :class:`SimulationError` unless ``project_initial``, which moves it to the nearest
    consistent state (mass-matrix metric) and says what changed in ``notes``. A
    unilateral constraint with f > 0 at the start begins released.

    A singular KKT matrix, NaN, a step-size collapse or Ctrl-C stop the run: the
    trajectory computed so far is returned with ``status`` "failed" or "interrupted"
    and a ``message`` naming the time and cause.
    """
    from scipy.optimize import brentq as _brentq

    check_options(t_end, t0, rtol, atol, max_step, samples, dt)
    if method not in _METHODS:
        raise SimulationError(f"unknown method {method!r}; one of {', '.join(_METHODS)}")
    if params and not isinstance(system, NumericSystem):
        extra = [k for k in params if k not in {par.name for par in system.parameters}]
        if extra:
            try:
                system = with_friction_parameters(system, extra)
            except ValueError as exc:
                raise SimulationError(str(exc)) from None
    ns = system if isinstance(system, NumericSystem) else compile_system(system, jit=jit)
    try:
        p = ns.parameter_vector(params)
    except KeyError as exc:
        raise SimulationError(str(exc.args[0])) from None
    except (TypeError, ValueError) as exc:
        raise SimulationError(f"parameter values must be numbers: {exc}") from None
    n = ns.n
    if initial:
        known = list(ns.coordinate_names) + [c + "'" for c in ns.coordinate_names]
        held = []
        for name, value in initial.items():
            if name not in known:
                raise SimulationError(f"initial value for unknown coordinate `{name}`; "
                                      f"known: {', '.join(known)}")
            try:
                held.append((name, float(value)))
            except (TypeError, ValueError):
                raise SimulationError(f"initial value of `{name}` must be a number, "
                                      f"got {value!r}") from None
        qi, vi = consistent_initial(ns, p, held)
    else:
        qi, vi = ns.initial_state(p)
    for arr, val, names, what in ((qi, q0, ns.coordinate_names, "coordinates"),
                                  (vi, qd0, ns.coordinate_names, "velocities")):
        val = _as_vector(val, names, what)
        if isinstance(val, dict):
            for k, x in val.items():
                arr[names.index(k.rstrip("'"))] = float(x)
        elif val is not None:
            arr[:] = val
    if not (np.all(np.isfinite(qi)) and np.all(np.isfinite(vi))):
        raise SimulationError("the initial state is not finite")
    if dt is not None:
        count = int(math.floor((t_end - t0) / dt + 1e-9))
        times = t0 + dt * np.arange(count + 1)
        if times[-1] < t_end - 1e-12 * max(1.0, abs(t_end)):
            times = np.append(times, t_end)
    else:
        times = np.linspace(t0, t_end, 1001 if samples is None else int(samples))
    eng = _Engine(ns, p, rtol, atol, max_step if max_step else np.inf, method)
    notes: list[str] = []
    y = np.concatenate((qi, vi))
    y = _initial_mode(eng, t0, y, project_initial, notes)

    out: list[_Sample] = []
    status, message = "ok", ""
    steps = 0
    max_proj = 0.0
    t = t0

    def record(ts, ys):
        qs, vs = ys[:n], ys[n:]
        _, lam, *_ = eng.kkt(ts, qs, vs)
        rp, rv = eng.residuals(ts, qs, vs)
        T, V = ns.energy(ts, qs, vs, p)
        out.append(_Sample(float(ts), qs.copy(), vs.copy(), lam, rp, rv, float(T), float(V)))

    k = 0
    # Trial states the integrator rejects may overflow or give NaN (that is how they are
    # rejected); a failure at an accepted state stops the run with its cause. NumPy's
    # warnings about them are noise: off for the run (set once: per call it costs 1 us).
    saved = np.seterr(invalid="ignore", over="ignore", divide="ignore")
    try:
        y = eng.settle(t0, y)
        record(t0, y)
        # A state 1e12 times its start (in size) is a blow-up, not physics to follow with
        # ever smaller steps (a 1/(1 - t)^3 force took 175 000 steps to fail otherwise).
        blow_up = BLOW_UP * (1.0 + float(np.max(np.abs(y), initial=0.0)))
        k = 1
        last_event_t, burst = None, 0
        while t < t_end and k < len(times):
            solver = eng.method(eng.fun, t, y, t_end, rtol=rtol, atol=atol,
                                max_step=eng.max_step)
            g_old = eng.event_values(t, y)
            restart = False
            while solver.status == "running":
                msg = solver.step()
                steps += 1
                if solver.status == "failed":
                    raise _Stop(_diagnose_failure(eng, solver.t, solver.y, msg))
                t_a, t_b = solver.t_old, solver.t
                big = float(np.max(np.abs(solver.y)))
                if not math.isfinite(big) or big > blow_up:
                    raise _Stop(f"the state grows without bound at t = {t_b:.12g} (max |q|, "
                                f"|q'| = {big:.3g}): a force or a singularity that blows up; "
                                "check [forces], the parameters and the initial state")
                yb, moved = eng.project(t_b, solver.y)
                max_proj = max(max_proj, moved)
                qdd, lam, A, gam, mu, K = eng.kkt(t_b, yb[:n], yb[n:])
                g_new = eng.event_values(t_b, yb, (lam, mu))
                hit = np.nonzero((g_old > 0) & (g_new <= 0))[0]
                dense = None
                if len(hit):
                    dense = solver.dense_output()
                    te, ie = t_b, -1
                    for i in hit:
                        def g(s, i=i):
                            return eng.event_values(s, dense(s))[i]
                        try:
                            r = _brentq(g, t_a, t_b, xtol=1e-15 * max(1.0, abs(t_b)),
                                       rtol=4 * np.finfo(float).eps, maxiter=200)
                        except ValueError:
                            r = t_b
                        if r < te or ie < 0:
                            te, ie = r, int(i)
                    while k < len(times) and times[k] <= te:
                        record(times[k], dense(times[k]))
                        k += 1
                    ye, _ = eng.project(te, dense(te))
                    kind, j = eng.event_list[ie]
                    if last_event_t is not None and te - last_event_t <= 1e-12 * max(1, abs(te)):
                        burst += 1
                        if burst > 50:
                            raise _Stop(f"more than 50 events at t = {te:.12g} (Zeno "
                                        "behaviour or chattering contact); try a smaller "
                                        "restitution or check the friction data")
                    else:
                        burst = 0
                    last_event_t = te
                    y = eng.apply(te, ye, kind, j)
                    t = te
                    restart = True
                    break
                # no event: accept the projected state
                while k < len(times) and times[k] <= t_b:
                    if dense is None:
                        dense = solver.dense_output()
                    ts = times[k]
                    record(ts, yb if ts == t_b else dense(ts))
                    k += 1
                if steps % 8 == 1 and np.linalg.cond(K) > 1e13:
                    raise _Stop(f"the KKT matrix is nearly singular at t = {t_b:.12g} "
                                f"(condition number {np.linalg.cond(K):.3g}): a singular "
                                "configuration (dependent constraints) or a motion without "
                                "inertia; forces there are not determined. Try "
                                "starting elsewhere, a shorter --t-end, or removing "
                                "a redundant constraint")
                if not all(eng.armed.values()):
                    eng.update_arming(t_b, yb)
                g_old = eng.event_values(t_b, yb, (lam, mu))
                solver.y = yb
                solver.f = np.concatenate((yb[n:], qdd))
                t, y = t_b, yb
                if progress is not None:
                    progress(t)
            if not restart and solver.status == "finished":
                t = t_end
    except _Stop as stop:
        status, message = "failed", stop.cause
    except KeyboardInterrupt:
        status, message = "interrupted", f"interrupted at t = {t:.12g}; the trajectory " \
                                         "up to there is kept"
    finally:
        np.seterr(**saved)
    traj = _assemble(eng, out, notes, status, message, t_end, t, y, steps, max_proj)
    return traj


def _initial_mode(eng: _Engine, t0, y, project_initial, notes) -> np.ndarray:
    ns, n = eng.ns, eng.n
    q, v = y[:n], y[n:]
    f, A, b = ns.constraints(t0, q, eng.p)
    F = A @ v + b
    tol = INITIAL_TOLERANCE * (1 + float(np.max(np.abs(q), initial=0.0)))
    for j in range(eng.m):
        if eng.unilateral[j]:
            if f[j] > tol or (abs(f[j]) <= tol and F[j] > tol):
                eng.engaged[j] = False
                eng.armed[("contact", j)] = f[j] > eng.arm_pos
    eng._rebuild()
    for j in list(eng.rows):
        if eng.normal[j] >= 0 and abs(F[j]) > tol:
            eng.fstate[j] = "slip"
            eng.sigma[j] = math.copysign(1.0, F[j])
            eng.armed[("stick", j)] = False
            eng.dissipative = True
            eng._rebuild()
            eng.log(t0, y, "slip", int(j), initial=True)
    bad = []
    for j in eng.rows:
        if eng.holonomic[j] and abs(f[j]) > tol:
            bad.append(f"`{ns.constraint_names[j]}` f = {f[j]:.6g}")
        elif abs(F[j]) > tol:
            bad.append(f"`{ns.constraint_names[j]}` df/dt = {F[j]:.6g}" if eng.holonomic[j]
                       else f"`{ns.constraint_names[j]}` g = {F[j]:.6g}")
    if not bad:
        return y
    if not project_initial:
        raise SimulationError("the initial state violates the constraints: " + "; ".join(bad)
                              + " (tolerance 1e-10 (1 + max |q|)); fix the initial values "
                              "or use project_initial=True (--project-initial)")
    y2, _ = eng.project(t0, y)
    changes = [f"{name}{s}: {a:.12g} -> {b_:.12g}"
               for i, name in enumerate(ns.coordinate_names)
               for s, a, b_ in (("", y[i], y2[i]), ("'", y[n + i], y2[n + i]))
               if abs(a - b_) > 0]
    notes.append("initial state projected onto the constraints (" + "; ".join(bad) + "): "
                 + ", ".join(changes))
    return y2


def _diagnose_failure(eng: _Engine, t, y, msg) -> str:
    n = eng.n
    extra = ""
    try:
        *_, K = eng.kkt(t, y[:n], y[n:])
        c = np.linalg.cond(K)
        if c > 1e10:
            extra = f"; the KKT matrix is nearly singular there (condition {c:.3g})"
    except _Stop as s:
        extra = "; " + s.cause
    if not extra:
        probe = eng.fun(t + 1e-9 * max(1.0, abs(t)), y)
        if not np.all(np.isfinite(probe)):
            extra = ("; the dynamics are NaN or undefined just after it (an expression "
                     "left its domain, e.g. sqrt or log of a negative number)")
    return (f"step size collapsed at t = {t:.12g} ({msg}){extra}; try a looser rtol/atol, "
            "or check for a singular configuration or a force that blows up")


def _assemble(eng: _Engine, out, notes, status, message, t_end, t, y, steps, max_proj):
    ns, n, m = eng.ns, eng.n, eng.m
    N = len(out)
    tt = np.array([s.t for s in out])
    q = np.array([s.q for s in out]).reshape(N, n)
    v = np.array([s.v for s in out]).reshape(N, n)
    lam = np.array([s.lam for s in out]).reshape(N, m)
    forces = {}
    for j, dirs in ns.force_specs:
        for d in dirs:
            forces[f"{ns.constraint_names[j]}:{d}"] = np.full(N, np.nan)
    for r, s in enumerate(out):
        if not ns.force_specs:
            break
        _, A, _ = ns.constraints(s.t, s.q, eng.p)
        jac = ns.force_jacobians(s.t, s.q, eng.p)
        for (j, dirs), (J, D) in zip(ns.force_specs, jac):
            if not np.isfinite(s.lam[j]):
                continue
            Q = s.lam[j] * A[j]
            F, _, rank, _ = np.linalg.lstsq(J.T, Q, rcond=None)
            for d, dvec in zip(dirs, D):
                norm = float(np.linalg.norm(dvec))
                if norm == 0:
                    continue
                if rank < J.shape[0]:
                    c, *_ = np.linalg.lstsq(J, dvec, rcond=None)
                    if np.linalg.norm(J @ c - dvec) > 1e-8 * (1 + norm):
                        continue
                forces[f"{ns.constraint_names[j]}:{d}"][r] = float(F @ dvec) / norm
    conserved = ns.conservative and not ns.time_dependent and not eng.dissipative
    traj = Trajectory(
        coordinates=list(ns.coordinate_names), constraints=list(ns.constraint_names),
        t=tt, q=q, qd=v, lambdas=lam, forces=forces,
        energy=np.array([s.T + s.V for s in out]),
        residual_position=np.array([s.rp for s in out]),
        residual_velocity=np.array([s.rv for s in out]),
        events=eng.events, status=status, message=message, t_end=float(t_end),
        final_time=float(tt[-1]) if N else float(t), final_q=q[-1] if N else y[:n],
        final_qd=v[-1] if N else y[n:], energy_conserved=conserved,
        max_projection=max_proj, steps=steps, evaluations=eng.evaluations, notes=notes,
        title=ns.system.title, kinetic=np.array([s.T for s in out]))
    return traj
