"""Rest in the file's own coordinates: the KKT test of an equilibrium, the search for
equilibria on every branch of the constraint manifold, and the linearisation there.

The reduced equations :mod:`._modes` starts from live on a chart: the elimination
solves each constraint for one coordinate on the branch through the initial state
(y = +sqrt(l^2 - x^2)), so they miss the rest points on the other branches (the trammel
hanging at y = -l) and are wrong where the chart is singular (the parametric
tautochrone's cusp, where dx/ds = dy/ds = 0, or a rod in a bowl stood on end). Here
every constraint is kept and the coordinates q are the ones the user wrote, where
neither happens. With the KKT system of :mod:`._derive`,

.. math::

    M\\,\\ddot q - A^T\\lambda = Q - h, \\qquad A\\,\\ddot q = -\\gamma,

* :meth:`RestTest.check` solves it numerically at a state and compares q'' with the
  accelerations the state should have (0 at an equilibrium, those of the steady motion
  at a relative one): within 1e-10 of the acceleration scale (the forces and their
  change across the size of q, over the largest mass) it passes.
  Where the KKT matrix is singular (the coordinates are: the pole of spherical
  coordinates, the tautochrone's cusp) it looks at regular points nearby on the
  constraints: the accelerations must vanish as the distance does (the pole: q'' ~ g
  delta), else the point is no equilibrium (the cusp: y'' -> -g).
* :meth:`RestTest.search` finds equilibria as the roots of

  .. math::

      h(q, 0) - Q(q, 0) - A(q)^T\\lambda = 0, \\qquad f(q) = 0

  in (q, lambda), by Levenberg-Marquardt from seeded starts spread over the coordinates'
  range (a periodic coordinate over a turn), each root then put to the KKT test. Only
  for autonomous systems with holonomic constraints; roots on a continuum (a free
  coordinate: a singular Jacobian) are left to the reduced equations.
* :meth:`RestTest.linearised`: d/dt [z, z'] = J [z, z'] on the constraints' tangent
  space at an equilibrium (q = q0 + N z, N an orthonormal basis of the null space of
  A): N^T M N z'' + N^T C N z' + N^T K N z = 0 with K = d/dq (h - Q - A^T lambda_0) and
  C = d/dq' (h - Q) at rest, the constraints' curvature entering through lambda_0.

Every evaluation of the generated functions runs with NumPy's floating-point warnings
off: a NaN or an infinity is read as "not here", never printed.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..linalg import kkt_matrix, kkt_rhs
from ..model import System
from ._derive import Dynamics

__all__ = ["Rest", "RestTest", "periodic_coordinates", "rest_test"]

SINGULAR_COND = 1e13
"""A KKT matrix with a larger condition number is singular here (as kkt_numeric)."""
REST_TOL = 1e-10
"""q'' within this fraction of the acceleration scale (forces over masses) is zero."""
SEARCH_OPS = 20000
"""Systems whose h, A and f together are larger than this (operations) are not searched
in full coordinates (the reduced equations' candidates are still checked)."""


@dataclass(frozen=True)
class Rest:
    """The KKT test at one state: ``ok`` when the accelerations are the expected ones,
    ``accelerations`` q'' (shape (n_coords,)) and ``multipliers`` lambda (shape
    (n_constraints,)) from the KKT solve (NaN where it is singular), ``singular`` when
    it is, ``residual`` |q'' - expected| over the acceleration ``scale``."""

    ok: bool
    accelerations: np.ndarray
    multipliers: np.ndarray
    singular: bool
    residual: float
    scale: float


def periodic_coordinates(system: System) -> list[bool]:
    """For each coordinate: it enters L, the forces and the constraints only through
    sin, cos and tan (an angle, read modulo 2 pi), and enters somewhere."""
    trig = (sp.sin, sp.cos, sp.tan)
    exprs = [system.L, *system.forces, *(c.expr for c in system.constraints)]

    def inside_trig_only(e: sp.Expr, x: sp.Symbol) -> bool:
        stripped = e.replace(lambda a: isinstance(a, trig) and a.has(x), lambda a: sp.Dummy())
        return not stripped.has(x)

    out = []
    for x in system.q:
        used = [sp.sympify(e) for e in exprs if sp.sympify(e).has(x)]
        out.append(bool(used) and all(inside_trig_only(e, x) for e in used))
    return out


def _quiet(f: Callable, shape: tuple[int, ...]) -> Callable:
    """``f`` returning a float array of ``shape``, with NumPy's warnings off: a
    generated function evaluated where it is NaN or infinite says nothing, and gives NaN
    (also where it raises), which the caller reads as "not here"."""

    def call(*args):
        with np.errstate(all="ignore"), warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            try:
                out = np.asarray(f(*args), dtype=float)
            except (ZeroDivisionError, OverflowError, ValueError, TypeError):
                return np.full(shape, np.nan)
        return out.reshape(shape) if out.size == int(np.prod(shape)) else np.full(shape, np.nan)

    return call


@dataclass(frozen=True)
class RestTest:
    """The KKT system of a system as numeric functions of (q, q', t) at its parameter
    values (:func:`rest_test` builds it), and the tests on them (module docstring)."""

    system: System
    periodic: tuple[bool, ...]
    holonomic: tuple[bool, ...]
    autonomous: bool
    M: Callable
    force: Callable  # Q - h, of (q, q', t)
    A: Callable
    gamma: Callable
    f: Callable  # the holonomic constraints, of (q, t)
    residual: Callable | None  # h - Q - A^T lambda and f at rest, of (q, lambda)
    jacobian: Callable | None
    stiffness: Callable | None  # d/dq (h - Q - A^T lambda) at rest, of (q, lambda)
    damping: Callable | None  # d/dq' (h - Q) at rest, of q

    @property
    def n(self) -> int:
        return len(self.periodic)

    def wrap(self, q: np.ndarray) -> np.ndarray:
        """``q`` with each periodic coordinate read in (-pi, pi]."""
        q = np.array(q, dtype=float)
        for i, p in enumerate(self.periodic):
            if p:
                q[i] = -((-q[i] + np.pi) % (2 * np.pi) - np.pi)
        return q

    def same(self, a: np.ndarray, b: np.ndarray, tol: float = 1e-7) -> bool:
        """Whether two configurations are the same point (periodic ones modulo 2 pi)."""
        d = np.asarray(a, dtype=float) - np.asarray(b, dtype=float)
        for i, p in enumerate(self.periodic):
            if p:
                d[i] = (d[i] + np.pi) % (2 * np.pi) - np.pi
        return bool(np.all(np.abs(d) <= tol * (1 + np.abs(a))))

    def solve(self, q, qd, t: float = 0.0) -> tuple[np.ndarray, np.ndarray, float, float]:
        """(q'', lambda, condition number, scale) of the KKT system at (q, q', t)."""
        n = self.n
        M = self.M(q, qd, t)
        rhs = self.force(q, qd, t)
        m = len(self.holonomic)
        A = self.A(q, qd, t).reshape(m, n) if m else np.zeros((0, n))
        g = self.gamma(q, qd, t).reshape(m) if m else np.zeros(0)
        scale = self._force_scale(q, qd, t, rhs, A) / max(float(np.abs(M).max(initial=0.0)), 1e-300)
        K = kkt_matrix(M, A)
        b = kkt_rhs(rhs, g)
        if not (np.isfinite(K).all() and np.isfinite(b).all()):
            return np.full(n, np.nan), np.full(m, np.nan), np.inf, scale
        cond = float(np.linalg.cond(K))
        if not np.isfinite(cond) or cond > SINGULAR_COND:
            return np.full(n, np.nan), np.full(m, np.nan), cond, scale
        x = np.linalg.solve(K, b)
        return x[:n], x[n:], cond, scale

    def _force_scale(self, q, qd, t, rhs, A) -> float:
        """The size of the forces about q: |Q - h| there and its change over the size
        of q (1 + max |q|) along each coordinate (at an equilibrium the forces balance,
        so their value alone says nothing: the double pendulum's are 0 hanging)."""
        size = 1.0 + float(np.abs(q).max(initial=0.0))
        out = float(np.abs(rhs).max(initial=0.0))
        step = 1e-4 * size
        for i in range(self.n):
            e = np.zeros(self.n)
            e[i] = step
            d = (self.force(q + e, qd, t) - self.force(q - e, qd, t)) / (2 * step)
            if np.isfinite(d).all():
                out = max(out, float(np.abs(d).max(initial=0.0)) * size)
        return out

    def check(self, q, qd=None, t: float = 0.0, expected=None) -> Rest:
        """The KKT test at (q, q', t): q'' equal to ``expected`` (default 0: at rest)."""
        n = self.n
        q = np.asarray(q, dtype=float)
        qd = np.zeros(n) if qd is None else np.asarray(qd, dtype=float)
        want = np.zeros(n) if expected is None else np.asarray(expected, dtype=float)
        qdd, lam, cond, scale = self.solve(q, qd, t)
        tol = REST_TOL * max(scale, 1e-300)
        if np.isfinite(cond) and cond <= SINGULAR_COND:
            err = float(np.abs(qdd - want).max(initial=0.0))
            return Rest(err <= tol, qdd, lam, False, err / max(scale, 1e-300), scale)
        ok = expected is None and not np.any(qd) and self._vanishes_nearby(q, t)
        return Rest(ok, qdd, lam, True, np.nan, scale)

    def _vanishes_nearby(self, q: np.ndarray, t: float) -> bool:
        """At a point where the KKT matrix is singular: whether the accelerations at rest
        at regular points nearby on the constraints go to zero with the distance (the
        pendulum's pole: q'' ~ g delta), so that the point is an equilibrium in the
        limit. Directions along which every point nearby is singular too are not
        judged; with none left, the point is given the benefit of the doubt."""
        n = self.n
        m = len(self.holonomic)
        A = self.A(q, np.zeros(n), t).reshape(m, n)[list(self.holonomic)] if m else None
        N = _null_basis(A if A is not None and A.size else np.zeros((0, n)), n)
        size = 1.0 + float(np.abs(q).max(initial=0.0))
        for k in range(N.shape[1]):
            for sign in (1.0, -1.0):
                norms = []
                for delta in (1e-3, 1e-4):
                    p = self._onto(q + sign * delta * size * N[:, k], t)
                    if p is None:
                        break
                    qdd, _, cond, scale = self.solve(p, np.zeros(n), t)
                    if not np.isfinite(cond) or cond > SINGULAR_COND:
                        break
                    norms.append(float(np.abs(qdd).max(initial=0.0)))
                if len(norms) < 2:
                    continue
                if norms[1] > 0.3 * norms[0] + REST_TOL * max(scale, 1e-300):
                    return False
        return True  # every direction judged vanishes (or none could be judged)

    def _onto(self, q: np.ndarray, t: float) -> np.ndarray | None:
        """``q`` moved onto the holonomic constraints (Newton, least change), or None."""
        n = self.n
        if not any(self.holonomic):
            return q
        rows = list(self.holonomic)
        for _ in range(30):
            f = self.f(q, t).reshape(-1)
            A = self.A(q, np.zeros(n), t).reshape(len(rows), n)[rows]
            if not (np.isfinite(f).all() and np.isfinite(A).all()):
                return None
            if np.abs(f).max(initial=0.0) <= 1e-14 * (1 + np.abs(q).max(initial=0.0)):
                return q
            q = q - np.linalg.lstsq(A, f, rcond=None)[0]
        return None

    def search(self, initial: np.ndarray, seeds: int | None = None) -> list[tuple]:
        """Equilibria (q, lambda) found from ``initial`` and ``seeds`` seeded starts
        (module docstring) in the region |q_i| <= 2 (1 + max |initial|), periodic
        coordinates over a turn; each passes :meth:`check`. [] where the search does not
        apply (a time-dependent or non-holonomic system)."""
        if self.residual is None or self.jacobian is None:
            return []
        from scipy.optimize import least_squares

        n, m = self.n, len(self.holonomic)
        count = seeds if seeds is not None else min(96, 24 + 8 * n)
        rng = np.random.default_rng(43)
        reach = 2.0 * (1.0 + float(np.abs(initial).max(initial=0.0)))
        starts = [np.asarray(initial, dtype=float)]
        for _ in range(count):
            starts.append(
                np.array(
                    [
                        rng.uniform(-np.pi, np.pi) if p else rng.uniform(-reach, reach)
                        for p in self.periodic
                    ]
                )
            )
        found: list[tuple] = []
        for q0 in starts:
            A0 = self.A(q0, np.zeros(n), 0.0).reshape(m, n) if m else np.zeros((0, n))
            F0 = self.force(q0, np.zeros(n), 0.0).reshape(n)
            if not (np.isfinite(A0).all() and np.isfinite(F0).all()):
                continue
            lam0 = np.linalg.lstsq(A0.T, -F0, rcond=None)[0] if m else np.zeros(0)
            x0 = np.concatenate([q0, lam0])
            with np.errstate(all="ignore"), warnings.catch_warnings():
                warnings.simplefilter("ignore")
                try:
                    r = least_squares(
                        self.residual,
                        x0,
                        jac=self.jacobian,
                        method="lm",
                        xtol=1e-15,
                        ftol=1e-15,
                        gtol=1e-15,
                        max_nfev=100 * (n + m),
                    )
                except (ValueError, np.linalg.LinAlgError):
                    continue
            if not np.all(np.isfinite(r.fun)):
                continue
            q = self.wrap(r.x[:n])
            gap = self.f(q, 0.0)
            if not np.all(np.abs(gap) <= 1e-9 * (1.0 + float(np.abs(q).max(initial=0.0))) ** 2):
                continue  # not on the constraints: the search stopped short
            if np.any(np.abs(q[~np.array(self.periodic, dtype=bool)]) > reach):
                continue  # outside the region searched (the tautochrone's next arch)
            if any(self.same(q, p) for p, _ in found):
                continue
            J = self.jacobian(r.x)
            if (
                not np.isfinite(J).all()
                or np.linalg.matrix_rank(J, tol=1e-9 * (1 + np.abs(J).max(initial=0.0))) < n + m
            ):
                continue  # a continuum (or a singular point): for the reduced equations
            verdict = self.check(q)
            if verdict.ok and not verdict.singular:
                found.append((q, verdict.multipliers))
        return found

    def linearised(self, q: np.ndarray, lam: np.ndarray):
        """(J, N) at the equilibrium q with multipliers lam: J (2 d, 2 d) the linear
        system in (z, z'), N (n, d) the tangent basis (q = q0 + N z); None where it does
        not apply (a system not searched) or the mass on the tangent space is singular."""
        if self.stiffness is None or self.damping is None:
            return None
        n, m = self.n, len(self.holonomic)
        A = self.A(q, np.zeros(n), 0.0).reshape(m, n) if m else np.zeros((0, n))
        N = _null_basis(A, n)
        M = self.M(q, np.zeros(n), 0.0).reshape(n, n)
        K = self.stiffness(np.concatenate([q, lam])).reshape(n, n)
        C = self.damping(q).reshape(n, n)
        if not (np.isfinite(K).all() and np.isfinite(C).all() and np.isfinite(M).all()):
            return None
        Mt, Kt, Ct = N.T @ M @ N, N.T @ K @ N, N.T @ C @ N
        d = N.shape[1]
        if d and np.linalg.cond(Mt) > 1e12:
            return None
        inv = np.linalg.inv(Mt) if d else np.zeros((0, 0))
        J = np.block([[np.zeros((d, d)), np.eye(d)], [-inv @ Kt, -inv @ Ct]])
        return J, N


def _null_basis(G: np.ndarray, n: int) -> np.ndarray:
    """Orthonormal basis (n, k) of the null space of G (rows: constraints)."""
    if G.size == 0:
        return np.eye(n)
    _, s, vt = np.linalg.svd(G)
    rank = int((s > 1e-10 * max(1.0, s.max(initial=0.0))).sum())
    return vt[rank:].T


def rest_test(dyn: Dynamics) -> RestTest | None:
    """The :class:`RestTest` of a system's dynamics, or None where its functions cannot
    be generated (a function NumPy does not know)."""
    system = dyn.system
    t = system.t
    q, qd = list(system.q), list(system.qd)
    pv = system.parameter_values
    n, m = len(q), len(system.constraints)

    def num(e):
        return sp.sympify(e).xreplace(pv)

    M = dyn.M.applyfunc(num)
    force = (dyn.Q - dyn.h).applyfunc(num)
    A = dyn.A.applyfunc(num) if m else sp.zeros(0, n)
    gamma = dyn.gamma.applyfunc(num) if m else sp.zeros(0, 1)
    hol = tuple(c.holonomic for c in system.constraints)
    f = sp.Matrix([num(c.expr) for c in system.constraints if c.holonomic])
    args = (q, qd, t)
    try:
        fM = _quiet(sp.lambdify(args, M, modules="numpy", cse=True), (n, n))
        fF = _quiet(sp.lambdify(args, force, modules="numpy", cse=True), (n,))
        fA = _quiet(sp.lambdify(args, A, modules="numpy", cse=True), (m, n))
        fG = _quiet(sp.lambdify(args, gamma, modules="numpy", cse=True), (m,))
        ff = _quiet(sp.lambdify((q, t), f, modules="numpy", cse=True), (f.rows,))
    except (NameError, TypeError, ValueError, SyntaxError):
        return None
    timed = [dyn.M, dyn.h, dyn.Q, dyn.A, system.L] + [c.expr for c in system.constraints]
    autonomous = not any(sp.sympify(e).has(t) for e in timed)
    residual = jacobian = stiffness = damping = None
    size = sum(sp.count_ops(e) for e in (*dyn.h, *dyn.Q, *A, *f))
    if autonomous and all(hol) and size <= SEARCH_OPS:
        lam = sp.Matrix([sp.Dummy(f"lambda{j}") for j in range(m)]) if m else sp.zeros(0, 1)
        rest = {v: 0 for v in qd}
        tangential = (-force).xreplace(rest) - (A.T * lam if m else sp.zeros(n, 1))
        R = sp.Matrix.vstack(tangential, f) if m else tangential
        x = list(q) + list(lam)
        try:
            fR = sp.lambdify((x,), R, modules="numpy", cse=True)
            fJ = sp.lambdify((x,), R.jacobian(x), modules="numpy", cse=True)
            fK = sp.lambdify((x,), tangential.jacobian(q), modules="numpy", cse=True)
            fC = sp.lambdify((q,), (-force).jacobian(qd).xreplace(rest), modules="numpy", cse=True)
        except (NameError, TypeError, ValueError, SyntaxError):
            pass
        else:
            residual = _quiet(fR, (n + f.rows,))
            jacobian = _quiet(fJ, (n + f.rows, n + m))
            stiffness, damping = _quiet(fK, (n, n)), _quiet(fC, (n, n))
    return RestTest(
        system,
        tuple(periodic_coordinates(system)),
        hol,
        autonomous,
        fM,
        fF,
        fA,
        fG,
        ff,
        residual,
        jacobian,
        stiffness,
        damping,
    )
