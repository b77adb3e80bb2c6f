"""The samples of a run at the output times, and the :class:`Trajectory` assembled from
them."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ._events import Status
from ._run import Run
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
    return Trajectory(
        coordinates=list(ns.coordinate_names),
        constraints=list(ns.constraint_names),
        t=tt,
        q=q,
        qd=v,
        lambdas=np.array([s.lam for s in out]).reshape(N, m),
        forces=_forces(run, out),
        energy=np.array([s.T + s.V for s in out]),
        residual_position=np.array([s.rp for s in out]),
        residual_velocity=np.array([s.rv for s in out]),
        events=run.events,
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
    )


def _forces(run: Run, out: list[Sample]) -> dict[str, np.ndarray]:
    """The Cartesian constraint forces "<constraint>:<direction>" by virtual work."""
    ns, p = run.setup.ns, run.setup.p
    forces = {
        f"{ns.constraint_names[j]}:{d}": np.full(len(out), np.nan)
        for j, dirs in ns.force_specs
        for d in dirs
    }
    if not ns.force_specs:
        return forces
    for r, s in enumerate(out):
        _, A, _ = ns.constraints(s.t, s.q, p)
        jac = ns.force_jacobians(s.t, s.q, p)
        for (j, dirs), (J, D) in zip(ns.force_specs, jac):
            if np.isfinite(s.lam[j]):
                for d, value in _components(J, D, dirs, s.lam[j] * A[j]):
                    forces[f"{ns.constraint_names[j]}:{d}"][r] = value
    return forces


def _components(J, D, dirs, Q):
    """(direction, component) of the Cartesian force F with J^T F = Q (least squares)
    along each direction of D the partial velocities J can represent."""
    F, _, rank, _ = np.linalg.lstsq(J.T, Q, rcond=None)
    for d, dvec in zip(dirs, D):
        norm = float(np.linalg.norm(dvec))
        if norm == 0:
            continue
        if rank < J.shape[0]:
            c, *_ = np.linalg.lstsq(J, dvec, rcond=None)
            if np.linalg.norm(J @ c - dvec) > 1e-8 * (1 + norm):
                continue
        yield d, float(F @ dvec) / norm
