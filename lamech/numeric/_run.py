"""One simulation run, in the spirit of MuJoCo's mjModel/mjData: :class:`Setup` holds the
constants (the compiled system, the parameter vector, the options, the constraints'
kinds, the event thresholds), :class:`Run` the data that change (the contact and
friction mode, the counters and the event log) with the evaluations at a state: the KKT
solve, the right-hand side, the projection and the residuals.

The mode is the loop's own (:mod:`._kernels.codes`: the arrays ``imode`` and ``fmode``), and
every rule that reads or changes it is the loop's code, the engine's in C, called here
through :func:`rules` (``rules.c``, ``lamech.numeric._crules``): the start's mode, the event
functions, arming, the projection, the settling, lift-off, slip, stick and impacts with the
Zeno accumulation, the input switches. Where SciPy's integrators step (a method other than
DOP853, ``engine="scipy"``, a system not compiled, or a segment the compiled loop hands
back), they apply the very rules the compiled loop applies."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..linalg import kkt_matrix, kkt_rhs
from ..model._checks import without_inertia
from ._codegen import NumericSystem
from ._events import Event, EventKind
from ._kernels import codes
from ._kkt import python_side_solve, slip_directions
from ._options import INITIAL_TOLERANCE, Options, Stop

__all__ = ["Setup", "Run", "Accel", "ConstraintKinds", "rules"]


@dataclass(frozen=True)
class ConstraintKinds:
    """Per constraint: ``unilateral``, ``holonomic``, and ``normal`` (the index of the
    normal constraint a friction constraint names, -1 for the others)."""

    unilateral: np.ndarray
    holonomic: np.ndarray
    normal: np.ndarray

    @classmethod
    def of(cls, system) -> ConstraintKinds:
        names = [c.name for c in system.constraints]
        return cls(
            unilateral=np.array([c.unilateral for c in system.constraints], dtype=bool),
            holonomic=np.array([c.holonomic for c in system.constraints], dtype=bool),
            normal=np.array(
                [names.index(c.friction.normal) if c.friction else -1 for c in system.constraints],
                dtype=int,
            ),
        )

    @property
    def m(self) -> int:
        return len(self.normal)

    def array(self) -> np.ndarray:
        """(3, m) int64, the kernels' ``kinds``: unilateral, holonomic, normal index."""
        return np.stack([self.unilateral, self.holonomic, self.normal]).astype(np.int64)


def rules(ns: NumericSystem):
    """The loop's rules on lamech's engine in C (``lamech.numeric._crules.CRules``: ``rules.c``),
    around the system's compiled functions where it runs compiled, else its NumPy
    functions called back (``lamech.numeric._crules.engine_kernels``): the very code the loop with
    events runs."""
    from ._crules import rules_of

    return rules_of(ns)


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
    """The data of one run: the mode ``md`` = (kinds, imode, fmode) (:mod:`._kernels.codes`)
    with its active set ``act`` and watched events ``watch`` (:meth:`rebuild`),
    ``evaluations`` (KKT solves), ``dissipative`` (a slip or an inelastic impact
    happened), ``events`` and ``handed_back`` (the contacts and segments the loop with
    events left to the simulator's own steps). ``rules``: the loop's rules (the engine's)
    (:func:`rules`), with the tolerances ``tl``, limits ``lim`` and event record ``lg``
    they take."""

    def __init__(self, setup: Setup):
        self.setup = setup
        self.rules = rules(setup.ns)
        kinds = setup.kinds.array()
        n, m = setup.n, setup.m
        imode = np.zeros((4, m), dtype=np.int64)
        imode[0] = 1  # engaged
        imode[1] = np.where(kinds[2] >= 0, codes.FR_STICK, codes.FR_NONE)
        imode[2:] = 1  # contact and stick events armed
        fmode = np.full((5, m), np.nan)  # sigma, sN, offset, Zeno t_acc and t_impact
        fmode[0], fmode[1], fmode[2] = 0.0, 1.0, 0.0
        self.md = (kinds, imode, fmode)
        opts = setup.options
        self.tl = codes.tolerances(
            rtol=float(opts.rtol), atol=float(opts.atol), t_end=float("inf"),
            max_step=float(opts.max_step), arm_pos=setup.arm_pos, arm_vel=setup.arm_vel,
            pen=INITIAL_TOLERANCE, tol=INITIAL_TOLERANCE,
        )  # fmt: skip
        self.lim = codes.limits(max_steps=0, impacts=True)
        cap = 8 * m + 32  # an event with its impact and settling logs at most 5 m + 7
        self.lg = (
            np.zeros(cap, dtype=np.int64), np.zeros(cap, dtype=np.int64), np.zeros(cap),
            np.zeros((cap, 2 * n)), np.zeros((cap, 4)), np.zeros((2, 0), dtype=np.int64),
            np.zeros(0, dtype=np.bool_),
        )  # fmt: skip
        self.evaluations = 0
        self.dissipative = False
        self.events: list[Event] = []
        self.solve = setup.ns.kkt_solve  # :meth:`kkt`'s (:meth:`solve_few`)
        self.handed_back = 0  # what the loop with events left to the simulator (_loop)
        self.rebuild()

    def rebuild(self) -> None:
        """The mode's active set and watched events, after it changed."""
        kinds, imode, fmode = self.md
        self.act = self.rules.ev_mode(kinds, imode, fmode)
        self.watch = self.rules.ev_watch(kinds, imode)
        act = self.act
        self.kernel_args = (act[0], act[2], act[3], act[4])

    @property
    def released(self) -> bool:
        """A unilateral constraint is released (its contact is watched)."""
        return bool(np.any(self.watch[0] == codes.EV_CONTACT))

    def constraints(self, t: float, q: np.ndarray):
        """(f, A, b) at (t, q)."""
        return self.setup.ns.constraints(t, q, self.setup.p)

    # ----- the rules ------------------------------------------------------------------
    def logged(self, count: int) -> list[Event]:
        """The first ``count`` events of the event record ``lg`` (a rule's), added to
        ``events``; the mode rebuilt."""
        from ._batch import logged_events

        self.rebuild()
        if count < 0:
            raise Stop("more events at one time than the event record holds")
        new = logged_events(self.setup.ns, *self.lg[:5], count)
        self.events.extend(new)
        if any(dissipative(e) for e in new):
            self.dissipative = True
        return new

    def start(self, t: float, y: np.ndarray) -> bool:
        """The mode of the start (t, y) (the engine's ``ev_start``); whether every
        active constraint is met there."""
        nev, st = self.rules.ev_start(t, y, self.setup.p, self.md, self.tl, self.lg, 0)
        self.logged(nev)
        return st == 0

    def settle(self, t: float, y: np.ndarray) -> np.ndarray:
        """y projected and the mode made consistent at (t, y)
        (the engine's ``ev_settle``: release unilateral constraints pulling,
        let friction beyond mu N slip); :class:`Stop` where it cannot be."""
        y = np.array(y, dtype=float)
        nev, st = self.rules.ev_settle(t, y, self.setup.p, self.md, self.tl, self.lg, 0)
        self.logged(nev)
        if st:
            raise Stop(self._failure(st, t, y))
        return y

    def apply(self, t: float, y: np.ndarray, kind: int, j: int) -> np.ndarray:
        """The event (``EV_*`` kind, constraint j) applied at (t, y) and the mode settled
        (the engine's ``ev_apply``); the state after it."""
        y = np.array(y, dtype=float)
        st, nev, _ = self.rules.ev_apply(
            t, y, self.setup.p, kind, j, self.act, self.md, self.tl, self.lim, self.lg, 0
        )
        self.logged(nev)
        if st == codes.ST_CONTACT:
            raise Stop(
                f"singular impact matrix at t = {t:.12g} (constraint "
                f"`{self.setup.ns.constraint_names[j]}`)"
            )
        if st:
            raise Stop(self._failure(st, t, y))
        return y

    def switch(self, t: float, y: np.ndarray, k: int) -> np.ndarray:
        """Input switch k takes its other branch from t on, and the mode is settled
        (the engine's ``ev_switch``); the state after it."""
        y = np.array(y, dtype=float)
        st, nev, _ = self.rules.ev_switch(t, y, self.setup.p, k, self.md, self.tl, self.lg, 0)
        self.logged(nev)
        if st:
            raise Stop(self._failure(st, t, y))
        return y

    def values(self, t: float, y: np.ndarray, acc: Accel | None = None) -> np.ndarray:
        """The watched events' functions at (t, y) (the engine's ``ev_functions``;
        ``acc`` the KKT solve there, if known)."""
        if not len(self.watch[0]):
            return np.zeros(0)
        n = self.setup.n
        if acc is None:
            acc = self.kkt(t, y[:n], y[n:])
        f, A, b = self.constraints(t, y[:n])
        return self.rules.ev_functions(self.watch, self.md, self.tl, y, acc.lam, acc.mu, f, A, b)

    def arm(self, t: float, y: np.ndarray) -> bool:
        """Arm the contact and stick events that moved far enough from zero at the
        accepted (t, y) (the engine's ``ev_arm``); whether any was."""
        return bool(self.rules.ev_arm(t, y, self.setup.p, self.watch, self.md, self.tl))

    def bound(self, t_end: float) -> float:
        """t_end, or the earlier accumulation time of a Zeno sequence's contact."""
        return float(self.rules.ev_bound(t_end, self.md[2]))

    def accumulated(self, t: float, y: np.ndarray) -> None:
        """Log the contacts whose bounces have accumulated by t."""
        self.logged(self.rules.ev_accumulated(t, y, self.setup.p, self.md[2], self.lg, 0))

    def depth(self, q: np.ndarray) -> float:
        """How far below zero a released gap may be before it is a penetration."""
        return float(self.rules.ev_depth(self.tl, q))

    def _failure(self, st: int, t: float, y: np.ndarray) -> str:
        """Why a rule could not be applied at (t, y) (its status ``st``)."""
        if st == codes.ST_SETTLE:
            return (
                f"the contact mode does not settle at t = {t:.12g} (constraints switch "
                "back and forth); the configuration may be degenerate"
            )
        if st == codes.ST_SINGULAR:
            n = self.setup.n
            self.kkt(t, y[:n], y[n:])  # its Stop says why
            return f"singular KKT matrix at t = {t:.12g}"
        return f"the contact mode cannot be applied at t = {t:.12g} ({codes.STATUS_NAMES[st]})"

    # ----- evaluations --------------------------------------------------------------
    def solve_few(self) -> None:
        """:meth:`kkt` by the Python side's solve (:func:`._kkt.python_side_solve`): for a
        run the loop integrates, which solves here only at its first sample and a segment
        handed back; SciPy's steps solve at every sample and keep the system's own."""
        self.solve = python_side_solve(self.setup.ns)

    def kkt(self, t: float, q: np.ndarray, v: np.ndarray) -> Accel:
        """The KKT solve on the mode's rows; :class:`Stop` where it cannot be done."""
        self.evaluations += 1
        M, rhs, A, gam, mu = self._dynamics(t, q, v)
        rows, slip_j, slip_k, slip_c = self.kernel_args
        G = slip_directions(A, rows, mu, slip_j, slip_k, slip_c)
        # The right-hand side's structured solve (a Schur complement where M is diagonal,
        # compiled with jit), not the full LU: 60-link chain, a 60-square banded system
        # instead of a 180-square dense one, at every sample (issue 16). Where it fails
        # (NaN: singular, or NaN in the dynamics) the full LU says which.
        sol = self.solve(M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c)
        if not np.all(np.isfinite(sol)):
            sol = self._dense_solve(t, M, rhs, A, gam, rows, G)
        n = self.setup.n
        lam = np.full(self.setup.m, np.nan)
        lam[rows] = sol[n:]
        lam[slip_j] = -mu[slip_j] * slip_c * sol[n + slip_k]  # the kinetic friction
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
            return self.setup.ns.rhs_kernel(t, y, self.setup.p, *self.kernel_args)
        except (ValueError, ArithmeticError):  # e.g. sqrt of a negative number
            return np.full(y.shape, np.nan)

    def project(self, t: float, y: np.ndarray) -> tuple[np.ndarray, float]:
        """y projected onto the mode's manifold (the engine's ``ev_project``:
        positions onto f_h = offset_h by Gauss-Newton, then velocities onto
        A_r v + b_r = 0, each correction the smallest in the mass-matrix metric); also the
        size of the correction."""
        yp = np.array(y, dtype=float)
        act = self.act
        self.rules.ev_project(t, yp, self.setup.p, act[0], act[1], self.md[2][2])
        return yp, float(np.max(np.abs(yp - y), initial=0.0))

    def residuals(self, t: float, q: np.ndarray, v: np.ndarray) -> tuple[float, float]:
        """(max |f - offset|, max |F|) over the mode's rows."""
        rows, h = self.act[0], self.act[1]
        if not len(rows):
            return 0.0, 0.0
        f, A, b = self.constraints(t, q)
        offset = self.md[2][2]
        rp = float(np.max(np.abs(f[h] - offset[h]), initial=0.0)) if len(h) else 0.0
        rv = float(np.max(np.abs(A[rows] @ v + b[rows]), initial=0.0))
        return rp, rv


def dissipative(event) -> bool:
    """An event after which energy need not be conserved (a slip, an impact with e < 1,
    a contact engaged)."""
    if event.kind == EventKind.IMPACT:
        return event.restitution is not None and event.restitution < 1
    return event.kind in (EventKind.SLIP, EventKind.CONTACT)
