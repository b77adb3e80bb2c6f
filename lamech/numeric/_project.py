"""The projection onto the constraints: one rule for the simulator (after every step, at
events, ``project_initial``) and for :func:`lamech.numeric.consistent_initial`.

Positions move onto f_rows = target by Gauss-Newton, velocities onto
A_rows q' + b_rows = 0, each correction dx the smallest in the mass-matrix metric
(dx^T M dx subject to the linearised constraints: :func:`lamech.linalg.min_norm_correction`).
Where that KKT matrix is singular (M singular on the motions the constraints allow) the
metric falls back to the Euclidean one for good (:class:`Metric`), and where that is
singular too, to least squares. Held coordinates (``free`` given) do not move: the
correction is over the free ones.

:func:`lamech.numeric.integrate_batch` has the compiled twin of this projection
(Euclidean metric, the same iteration cap :data:`PROJECTION_ITERATIONS`).
"""

from __future__ import annotations

import numpy as np

from ..linalg import min_norm_correction

__all__ = ["PROJECTION_ITERATIONS", "Metric", "project_positions", "project_velocities"]

PROJECTION_ITERATIONS = 6
"""Gauss-Newton iterations at most per position projection (it converges quadratically:
after a step one or two suffice)."""


class Metric:
    """The metric of the corrections: the mass matrix at the state, or the identity from
    the first time the mass-matrix KKT matrix is singular on (``euclidean``)."""

    def __init__(self, ns, p: np.ndarray):
        self.ns, self.p = ns, p
        self.euclidean = False

    def matrix(self, t: float, q: np.ndarray, v: np.ndarray) -> np.ndarray:
        if self.euclidean:
            return np.eye(self.ns.n)
        return self.ns.dynamics(t, q, v, self.p)[0]

    def correction(self, W: np.ndarray, A: np.ndarray, r: np.ndarray) -> np.ndarray:
        """dx minimising dx^T W dx subject to A dx = r (see the module docstring)."""
        try:
            dx = min_norm_correction(W, A, r)
            if np.all(np.isfinite(dx)):
                return dx
        except np.linalg.LinAlgError:
            pass
        if not self.euclidean:
            self.euclidean = True
            return self.correction(np.eye(W.shape[0]), A, r)
        dx, *_ = np.linalg.lstsq(A, r, rcond=None)
        return dx


def _restrict(W, A, rows, free):
    """W and A[rows] on the free coordinates (all when ``free`` is None)."""
    if free is None:
        return W, A[rows]
    return W[np.ix_(free, free)], A[np.ix_(rows, free)]


def _movable(A, rows, free):
    """The rows the free coordinates can change (all when every coordinate is free)."""
    if free is None:
        return rows
    return np.array([j for j in rows if np.any(A[j, free] != 0)], dtype=int)


def project_positions(
    ns, p, metric: Metric, t: float, q: np.ndarray, v: np.ndarray, rows, target, free=None
) -> tuple[np.ndarray, float]:
    """(q moved onto f_rows = target (Gauss-Newton), the largest |dq| of a step); ``q``
    is moved in place. ``free``: the indices of the coordinates allowed to move."""
    moved = 0.0
    W = None
    for _ in range(PROJECTION_ITERATIONS):
        f, A, _ = ns.constraints(t, q, p)
        act = _movable(A, rows, free)
        if not len(act):
            break
        r = f[act] - target[act]
        scale = 1.0 + float(np.max(np.abs(q), initial=0.0))
        if np.max(np.abs(r)) <= 2e-16 * scale * max(1.0, float(np.abs(A).max())):
            break
        if W is None:
            W = metric.matrix(t, q, v)
        Wf, Af = _restrict(W, A, act, free)
        dq = metric.correction(Wf, Af, -r)
        _move(q, dq, free)
        moved = max(moved, float(np.max(np.abs(dq))))
        if np.max(np.abs(dq)) <= 1e-16 * scale:
            break
    return q, moved


def project_velocities(
    ns, p, metric: Metric, t: float, q: np.ndarray, v: np.ndarray, rows, free=None
) -> tuple[np.ndarray, float]:
    """(v moved onto A_rows v + b_rows = 0, |dv| max); ``v`` is moved in place."""
    _, A, b = ns.constraints(t, q, p)
    act = _movable(A, rows, free)
    if not len(act):
        return v, 0.0
    r = A[act] @ v + b[act]
    if not np.any(r != 0):
        return v, 0.0
    W = metric.matrix(t, q, v)
    Wf, Af = _restrict(W, A, act, free)
    dv = metric.correction(Wf, Af, -r)
    _move(v, dv, free)
    return v, float(np.max(np.abs(dv)))


def _move(x: np.ndarray, dx: np.ndarray, free) -> None:
    """x += dx in place, on the ``free`` entries only when given."""
    if free is None:
        x += dx
    else:
        x[free] += dx
