"""One simulation run, in the spirit of MuJoCo's mjModel/mjData: :class:`Setup` holds the
constants (the compiled system, the parameter vector, the options, the constraints'
kinds, the event thresholds), :class:`Run` the data that change (the :class:`ContactMode`, the
projection's metric, the counters and the event log) with the evaluations at a state:
the KKT solve, the right-hand side, the projection and the residuals."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..linalg import kkt_matrix, kkt_rhs
from ..model._checks import without_inertia
from ._codegen import NumericSystem
from ._events import Event, EventKind
from ._kkt import slip_directions
from ._mode import ConstraintKinds, ContactMode, slip_sign
from ._options import Options, Stop
from ._project import Metric, project_positions, project_velocities

__all__ = ["Setup", "Run", "Accel"]


@dataclass(frozen=True)
class Setup:
    """The constants of a run. ``arm_pos`` and ``arm_vel``: how far a gap or a slip
    velocity must move from zero before its contact or stick event may fire again (and
    the slip speed below which a slip starts from rest)."""

    ns: NumericSystem
    p: np.ndarray
    options: Options
    kinds: ConstraintKinds
    arm_pos: float
    arm_vel: float

    @classmethod
    def of(cls, ns: NumericSystem, p: np.ndarray, options: Options) -> Setup:
        return cls(ns, p, options, ConstraintKinds.of(ns.system), options.arm, options.arm)

    @property
    def n(self) -> int:
        return self.ns.n

    @property
    def m(self) -> int:
        return self.ns.m


class Accel(NamedTuple):
    """The KKT solve at a state: q'', lam (m,) (NaN where inactive, the kinetic friction
    where slipping), and the A, gamma, mu it came from; M, the active ``rows`` and their
    directions G make the KKT matrix :attr:`K` on demand."""

    qdd: np.ndarray
    lam: np.ndarray
    A: np.ndarray
    gam: np.ndarray
    mu: np.ndarray
    M: np.ndarray
    rows: np.ndarray
    G: np.ndarray

    @property
    def K(self) -> np.ndarray:
        """The KKT matrix of the solve (built when asked: the conditioning check)."""
        return kkt_matrix(self.M, self.A[self.rows], self.G)


class Run:
    """The data of one run: ``mode``, ``metric`` (mass matrix, or Euclidean once M is
    singular), ``evaluations`` (KKT solves), ``dissipative`` (a slip or an inelastic
    impact happened), ``events`` and ``handed_back`` (the contacts and segments the loop
    with events left to the simulator's own code)."""

    def __init__(self, setup: Setup):
        self.setup = setup
        self.mode = ContactMode(setup.kinds)
        self.metric = Metric(setup.ns, setup.p)
        self.evaluations = 0
        self.dissipative = False
        self.events: list[Event] = []
        self.handed_back = 0  # what the loop with events left to the simulator (_loop)

    def constraints(self, t: float, q: np.ndarray):
        """(f, A, b) at (t, q)."""
        return self.setup.ns.constraints(t, q, self.setup.p)

    # ----- evaluations --------------------------------------------------------------
    def kkt(self, t: float, q: np.ndarray, v: np.ndarray) -> Accel:
        """The KKT solve on the mode's rows; :class:`Stop` where it cannot be done."""
        self.evaluations += 1
        M, rhs, A, gam, mu = self._dynamics(t, q, v)
        mode = self.mode
        rows = mode.rows
        slip_c = np.array([mode.sN[j] * mode.sigma[j] for j, _ in mode.slips], dtype=float)
        slip_j, slip_k = mode.kernel_args[1], mode.kernel_args[2]
        G = slip_directions(A, rows, mu, slip_j, slip_k, slip_c)
        # The right-hand side's structured solve (a Schur complement where M is diagonal,
        # compiled with jit), not the full LU: 60-link chain, a 60-square banded system
        # instead of a 180-square dense one, at every sample (issue 16). Where it fails
        # (NaN: singular, or NaN in the dynamics) the full LU says which.
        sol = self.setup.ns.kkt_solve(
            M, rhs, A, gam, mu, mode.kernel_args[0], slip_j, slip_k, slip_c
        )
        if not np.all(np.isfinite(sol)):
            sol = self._dense_solve(t, M, rhs, A, gam, rows, G)
        n = self.setup.n
        lam = np.full(self.setup.m, np.nan)
        lam[rows] = sol[n:]
        for j, k in mode.slips:
            lam[j] = -mu[j] * mode.sN[j] * mode.sigma[j] * lam[k]
        return Accel(sol[:n], lam, A, gam, mu, M, rows, G)

    def _dense_solve(self, t, M, rhs, A, gam, rows, G) -> np.ndarray:
        """The KKT system by LAPACK's LU; :class:`Stop` where it is singular or not
        finite."""
        try:
            sol = np.linalg.solve(kkt_matrix(M, A[rows], G), kkt_rhs(rhs, gam[rows]))
        except np.linalg.LinAlgError:
            raise Stop(self._singular(t, M, A[rows])) from None
        if not np.all(np.isfinite(sol)):
            raise Stop(
                f"non-finite accelerations or multipliers at t = {t:.12g} "
                "(NaN/inf in the dynamics: a coordinate left the domain of an "
                "expression, or the KKT matrix is singular)"
            )
        return sol

    def pole(self, t: float, q: np.ndarray) -> str:
        """Where the mass matrix loses rank because a coordinate's inertia vanishes with
        another coordinate (m r^2 as r -> 0: the pole of a polar or spherical chart,
        where the angle is undefined): a sentence saying so ("" elsewhere)."""
        from ..expr import to_text

        ns, n = self.setup.ns, self.setup.n
        try:
            M = np.asarray(ns.dynamics(t, q, np.zeros(n), self.setup.p)[0], dtype=float)
            w, V = np.linalg.eigh(0.5 * (M + M.T))
        except (ValueError, ArithmeticError, np.linalg.LinAlgError):
            return ""
        big = float(np.abs(w).max(initial=0.0))
        if not np.all(np.isfinite(w)) or big == 0 or w[0] > 1e-9 * big:
            return ""
        k = int(np.argmax(np.abs(V[:, 0])))
        inertia = ns.dyn.M[k, k]
        q0 = ns.initial_state(self.setup.p)[0]
        near = [
            (c.name, float(q[i]))
            for i, c in enumerate(ns.system.coordinates)
            if i != k
            and c.symbol in inertia.free_symbols
            and abs(q[i]) <= 1e-3 * (1.0 + abs(q0[i]))
        ]
        if not near:
            return ""
        name, value = near[0]
        angle = ns.coordinate_names[k]
        return (
            f"`{angle}` has no inertia there: its mass matrix entry {to_text(inertia)} "
            f"vanishes as {name} -> 0 ({name} = {value:.3g}), the pole of the polar (or "
            f"spherical) coordinates, where `{angle}` is undefined: the motion passes "
            f"through the origin of {name}. To follow it through, write the problem in "
            "Cartesian coordinates; or start it so that it misses the pole"
        )

    def _singular(self, t: float, M: np.ndarray, A: np.ndarray) -> str:
        """Why the KKT matrix is singular at t, naming the coordinate without inertia
        (and the massless bodies it moves) when that is the cause."""
        system = self.setup.ns.system
        env = {p.symbol: float(v) for p, v in zip(system.parameters, self.setup.p)}
        weak = without_inertia(system, M, A, env)
        if weak:
            return (
                f"singular KKT matrix at t = {t:.12g}: {weak.describe(system)}; give it a mass or "
                "a constraint that ties it to something with inertia"
            )
        return (
            f"singular KKT matrix at t = {t:.12g}: the constraints are "
            "dependent here (a singular configuration) or a motion they allow "
            "has no inertia; start elsewhere or remove a redundant "
            "constraint"
        )

    def _dynamics(self, t, q, v):
        try:
            return self.setup.ns.dynamics(t, q, v, self.setup.p)
        except (ValueError, ArithmeticError) as exc:
            raise Stop(
                f"the dynamics cannot be evaluated at t = {t:.12g} ({exc}): a "
                "coordinate, parameter or time left the domain of an expression "
                "(sqrt or log of a negative number, division by zero); check the "
                "expressions, the parameters and the initial state"
            ) from None

    def fun(self, t: float, y: np.ndarray) -> np.ndarray:
        """The right-hand side; NaN where the KKT system fails, so that the integrator
        rejects the trial step and shrinks it (a failure at an accepted state stops the
        run with the cause)."""
        self.evaluations += 1
        try:
            return self.setup.ns.rhs_kernel(t, y, self.setup.p, *self.mode.kernel_args)
        except (ValueError, ArithmeticError):  # e.g. sqrt of a negative number
            return np.full(y.shape, np.nan)

    def project(self, t: float, y: np.ndarray) -> tuple[np.ndarray, float]:
        """y projected onto the mode's manifold (:mod:`._project`); also the size of the
        correction."""
        ns, p, n, mode = self.setup.ns, self.setup.p, self.setup.n, self.mode
        q, v = y[:n].copy(), y[n:].copy()
        moved = 0.0
        if len(mode.hrows):
            q, moved = project_positions(ns, p, self.metric, t, q, v, mode.hrows, mode.offset)
        if len(mode.rows):
            v, moved_v = project_velocities(ns, p, self.metric, t, q, v, mode.rows)
            moved = max(moved, moved_v)
        return np.concatenate((q, v)), moved

    def residuals(self, t: float, q: np.ndarray, v: np.ndarray) -> tuple[float, float]:
        """(max |f - offset|, max |F|) over the mode's rows."""
        mode = self.mode
        if not len(mode.rows):
            return 0.0, 0.0
        f, A, b = self.constraints(t, q)
        h = mode.hrows
        rp = float(np.max(np.abs(f[h] - mode.offset[h]), initial=0.0)) if len(h) else 0.0
        rv = float(np.max(np.abs(A[mode.rows] @ v + b[mode.rows]), initial=0.0))
        return rp, rv

    # ----- switches that need numbers -------------------------------------------
    def start_slip(self, j: int, lam_j: float, s: float = 0.0) -> None:
        """Friction j starts slipping (slip velocity s, or from rest against lam_j)."""
        self.mode.start_slip(j, slip_sign(lam_j, s, self.setup.arm_vel))
        self.dissipative = True

    def stick(self, t: float, y: np.ndarray, j: int) -> None:
        """Friction j sticks from now on: its f is held at its present value."""
        f, _, _ = self.constraints(t, y[: self.setup.n])
        self.mode.stick(j, f[j] if self.setup.kinds.holonomic[j] else 0.0)

    def log(self, t: float, y: np.ndarray, kind: EventKind, j: int, **details) -> None:
        """Record an event at (t, y)."""
        n, names = self.setup.n, self.setup.ns.coordinate_names
        coords = {c: float(y[i]) for i, c in enumerate(names)}
        coords.update({c + "'": float(y[n + i]) for i, c in enumerate(names)})
        self.events.append(
            Event(float(t), EventKind(kind), self.setup.ns.constraint_names[j], coords, **details)
        )
