"""The samples of a run at the output times, and the :class:`Trajectory` assembled from
them."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from ..model import result_units
from ..symbolic._drives import turns
from ._events import Status
from ._losses import with_energy_lost
from ._run import Run
from ._signs import sign_change_notes
from ._trajectory import Trajectory

__all__ = ["Sample", "Recorder", "Progress", "assemble"]


@dataclass
class Sample:
    t: float
    q: np.ndarray
    v: np.ndarray
    lam: np.ndarray
    rp: float
    rv: float
    T: float
    V: float


@dataclass
class Progress:
    """Where the run is: the last accepted (t, y), the steps taken and the largest
    projection so far."""

    t: float
    y: np.ndarray
    steps: int = 0
    max_projection: float = 0.0


@dataclass
class Recorder:
    """Samples (state, multipliers, residuals, energy) at the output ``times``, in
    order; ``next`` is the index of the next time to sample."""

    run: Run
    times: np.ndarray
    samples: list[Sample] = field(default_factory=list)
    next: int = 0

    @property
    def pending(self) -> bool:
        return self.next < len(self.times)

    def drop_after(self, t: float) -> None:
        """Forget the samples past t (a run stopped by a signal after a chunk of the loop
        recorded its samples, before the time it reached was taken: what is kept ends
        where the run says it stopped)."""
        while self.samples and self.samples[-1].t > t:
            self.samples.pop()
            self.next -= 1

    def start(self, t0: float, y: np.ndarray) -> None:
        """The sample at the start, the first output time."""
        self.record(t0, y)
        self.next = 1

    def record(self, t: float, y: np.ndarray) -> None:
        """Sample at (t, y) (the state on the manifold)."""
        n, setup = self.run.setup.n, self.run.setup
        q, v = y[:n], y[n:]
        lam = self.run.kkt(t, q, v).lam
        rp, rv = self.run.residuals(t, q, v)
        T, V = setup.ns.energy(t, q, v, setup.p)
        self.samples.append(Sample(float(t), q.copy(), v.copy(), lam, rp, rv, float(T), float(V)))

    def up_to(self, t: float, dense_output, y_at_t: np.ndarray | None = None) -> None:
        """Sample every pending time <= t on the step's dense output (``dense_output()``
        makes it, once, if needed; ``y_at_t`` at t itself, when given)."""
        dense = None  # made before the first sample, as its evaluations count
        while self.pending and self.times[self.next] <= t:
            if dense is None:
                dense = dense_output()
            ts = self.times[self.next]
            self.record(ts, y_at_t if y_at_t is not None and ts == t else dense(ts))
            self.next += 1


def assemble(
    run: Run,
    rec: Recorder,
    notes: list[str],
    status: Status,
    message: str,
    t_end: float,
    at: Progress,
    engine: str = "",
) -> Trajectory:
    """The :class:`Trajectory` of the samples so far; its final time and state are the
    last ones reached (``at``), which may lie after the last sample when the run stopped
    between samples."""
    ns, n, m = run.setup.ns, run.setup.n, run.setup.m
    out = rec.samples
    N = len(out)
    tt = np.array([s.t for s in out])
    q = np.array([s.q for s in out]).reshape(N, n)
    v = np.array([s.v for s in out]).reshape(N, n)
    conserved = ns.conservative and not ns.time_dependent and not run.dissipative
    forces = _forces(run, out)
    lambdas = np.array([s.lam for s in out]).reshape(N, m)
    drive_forces, drive_power, drive_coordinates, drive_units = _drives(run, tt, q, v, lambdas)
    drive_turns = {name: turns(ns.system, name) for name in drive_forces}
    notes = notes + sign_change_notes(ns.system, ns.constraint_names, tt, q, lambdas)
    return Trajectory(
        coordinates=list(ns.coordinate_names),
        constraints=list(ns.constraint_names),
        t=tt,
        q=q,
        qd=v,
        lambdas=lambdas,
        forces=forces,
        energy=np.array([s.T + s.V for s in out]),
        residual_position=np.array([s.rp for s in out]),
        residual_velocity=np.array([s.rv for s in out]),
        events=with_energy_lost(ns, run.setup.p, run.events),
        status=status,
        message=message,
        t_end=float(t_end),
        final_time=float(at.t),
        final_q=np.array(at.y[:n], dtype=float),
        final_qd=np.array(at.y[n:], dtype=float),
        energy_conserved=conserved,
        max_projection=at.max_projection,
        steps=at.steps,
        evaluations=run.evaluations,
        notes=notes,
        title=ns.system.title,
        kinetic=np.array([s.T for s in out]),
        engine=engine,
        handed_back=run.handed_back,
        units=result_units(ns.system, forces),
        drive_forces=drive_forces,
        drive_power=drive_power,
        drive_coordinates=drive_coordinates,
        drive_units=drive_units,
        drive_turns=drive_turns,
    )


def _drives(run: Run, t: np.ndarray, q: np.ndarray, v: np.ndarray, lam: np.ndarray):
    """Per drive ([[drives]]), at the samples: the force or torque on its coordinate,
    lambda_j df_j/dq_c (lambda_j for a general f), and the power of the drive's
    generalized force, lambda_j A_j q'; the coordinate each drives and its unit."""
    ns, p = run.setup.ns, run.setup.p
    drives = [(j, c) for j, c in enumerate(ns.system.constraints) if c.drive is not None]
    forces: dict[str, np.ndarray] = {}
    power: dict[str, np.ndarray] = {}
    coords: dict[str, str | None] = {}
    if not drives:
        return forces, power, coords, {}
    rows = np.array(
        [np.asarray(ns.constraints(t[k], q[k], p)[1], dtype=float) for k in range(len(t))]
    )
    names = list(ns.coordinate_names)
    for j, c in drives:
        Aj = rows[:, j, :].reshape(len(t), len(names))
        coord = c.drive.coordinate if c.drive is not None else None
        factor = Aj[:, names.index(coord)] if coord is not None else 1.0
        forces[c.name] = lam[:, j] * factor
        power[c.name] = lam[:, j] * np.einsum("ki,ki->k", Aj, v)
        coords[c.name] = coord
    return forces, power, coords, _drive_units(ns.system, [c for _, c in drives])


def _drive_units(system, drives) -> dict[str, str]:
    """The SI unit of each drive's force or torque where the file has units: its
    multiplier's, where df/dq_c = 1 (a motion or a speed) or it drives no coordinate."""
    out: dict[str, str] = {}
    if system.units is None:
        return out
    for c in drives:
        d = system.units.multiplier(c.name)
        coord = c.drive.coordinate
        if d is not None and (coord is None or sp.diff(c.expr, system.symbols[coord]) == 1):
            out[c.name] = d.si()
    return out


def _forces(run: Run, out: list[Sample]) -> dict[str, np.ndarray]:
    """The Cartesian constraint forces "<constraint>:<direction>" by virtual work: at each
    sample, F with J^T F = lambda_j A_j (least squares), along each direction the partial
    velocities J can represent; the least squares of all samples at once
    (:func:`_least_squares`)."""
    ns, p = run.setup.ns, run.setup.p
    forces = {
        f"{ns.constraint_names[j]}:{d}": np.full(len(out), np.nan)
        for j, dirs in ns.force_specs
        for d in dirs
    }
    if not ns.force_specs or not out:
        return forces
    A_at = [ns.constraints(s.t, s.q, p)[1] for s in out]
    jac_at = [ns.force_jacobians(s.t, s.q, p) for s in out]
    for k, (j, dirs) in enumerate(ns.force_specs):
        lam = np.array([s.lam[j] for s in out])
        rows = np.nonzero(np.isfinite(lam))[0]
        if not len(rows):
            continue
        J = np.array([jac_at[r][k][0] for r in rows], dtype=float)  # (R, dim, n)
        D = np.array([jac_at[r][k][1] for r in rows], dtype=float)  # (R, directions, dim)
        Q = lam[rows, None] * np.array([A_at[r][j] for r in rows], dtype=float)
        F, rank = _least_squares(np.swapaxes(J, 1, 2), Q)
        for i, d in enumerate(dirs):
            dvec = D[:, i, :]
            norm = np.linalg.norm(dvec, axis=1)
            ok = norm != 0
            for r in np.nonzero(ok & (rank < J.shape[1]))[0]:
                # a rank-deficient J: only the directions it can represent
                c, *_ = np.linalg.lstsq(J[r], dvec[r], rcond=None)
                ok[r] = np.linalg.norm(J[r] @ c - dvec[r]) <= 1e-8 * (1 + norm[r])
            value = np.einsum("rd,rd->r", F, dvec) / np.where(ok, norm, 1.0)
            forces[f"{ns.constraint_names[j]}:{d}"][rows[ok]] = value[ok]
    return forces


def _least_squares(M: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The minimum-norm least-squares x of M[r] x = b[r] for a stack M (R, a, c), with
    numpy.linalg.lstsq's cut-off (singular values below eps max(a, c) times the largest
    count as zero), and each one's rank: by one stacked SVD, since lstsq solves one
    system a call (1001 samples of the cylinder's two forces: 23 ms of lstsq, half a
    compiled run)."""
    U, S, Vt = np.linalg.svd(M, full_matrices=False)
    keep = S > np.finfo(float).eps * max(M.shape[1:]) * S[:, :1]
    inverse = np.where(keep, 1.0 / np.where(keep, S, 1.0), 0.0)
    x = np.einsum("rkc,rk,rak,ra->rc", Vt, inverse, U, b)
    return x, keep.sum(axis=1)
