"""Where a bilateral constraint's multiplier changes sign along a simulated motion.

A particle on a sphere written without ``unilateral = true`` is held on it both ways:
the motion goes on through the point where the contact's push turns into a pull. With
one degree of freedom :func:`lamech.solve` says where, on the energy shell; with more
(the sphere in x, y, z) only the motion can: this module reads the multipliers the
integrator solved for and says when the sign changed, for the constraints a student
may have meant as one-sided (see :func:`contact_like`).
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from ..model import System

__all__ = ["contact_like", "sign_change_notes"]


def contact_like(system: System, name: str) -> bool:
    """Constraint ``name`` is bilateral and could have been meant as a contact or a
    string: holonomic, fixed in time, no friction (and no friction's normal), and a
    quadric with a constant, nonzero, semidefinite Hessian in the coordinates (a sphere,
    a circle, an ellipse, a distance |r1 - r2| = l, a paraboloid). A loop closure or a
    parametric definition (x - a (s + sin(s))) is not, and gets no note."""
    con = system.constraint(name)
    if con.unilateral or not con.holonomic or con.friction is not None:
        return False
    if con.expr.has(system.t):
        return False
    if any(c.friction is not None and c.friction.normal == name for c in system.constraints):
        return False
    xs = [x for x in system.q if con.expr.has(x)]
    if not xs:
        return False
    H = sp.hessian(con.expr, xs)
    if any(e.free_symbols & set(system.q) for e in H):
        return False
    try:
        values = np.linalg.eigvalsh(np.array(H.xreplace(system.parameter_values), dtype=float))
    except (TypeError, ValueError):
        return False
    scale = float(np.abs(values).max(initial=0.0))
    if scale == 0.0:
        return False
    return bool(values.min() >= -1e-12 * scale or values.max() <= 1e-12 * scale)


def sign_change_notes(
    system: System, names, t: np.ndarray, q: np.ndarray, lam: np.ndarray
) -> list[str]:
    """One note for each contact-like bilateral constraint (:func:`contact_like`) whose
    multiplier (column of ``lam``, shape (n_samples, n_constraints)) changes sign along
    the samples: the first time, found by a cubic through the four samples around it, and
    the coordinates there."""
    notes: list[str] = []
    if len(t) < 2:
        return notes
    for j, name in enumerate(names):
        col = np.asarray(lam[:, j], dtype=float)
        if not np.all(np.isfinite(col)):
            continue
        tol = 1e-6 * float(np.abs(col).max(initial=0.0))
        signs = np.where(col > tol, 1, np.where(col < -tol, -1, 0))
        nz = np.flatnonzero(signs)
        changed = np.flatnonzero(signs[nz[1:]] != signs[nz[:-1]])
        # the samples first (NumPy), the constraint's form only where they flip: a
        # Hessian in SymPy for every constraint of every run cost a 60-link chain's
        # simulate 0.1 s of its 0.09 s
        if not len(changed) or not contact_like(system, name):
            continue
        flips = [int(nz[i + 1]) for i in changed]
        k = flips[0]
        when = _crossing(t, col, k)
        i = int(np.clip(np.searchsorted(t, when), 1, len(t) - 1))
        w = (when - t[i - 1]) / (t[i] - t[i - 1]) if t[i] > t[i - 1] else 0.0
        at = (1 - w) * q[i - 1] + w * q[i]
        where = ", ".join(f"{c.name} = {v:.6g}" for c, v in zip(system.coordinates, at))
        start = "positive" if col[nz[0]] > 0 else "negative"
        notes.append(
            f"`{name}` is bilateral and lambda_{name} changes sign along the motion: "
            f"{start} at the start, 0 at t = {when:.8g} ({where}), the other sign after. "
            "A rod, or a bead threaded on a wire, holds both ways; a string or a one-sided "
            f"contact would let go there. If `{name}` is one, write f with its allowed "
            "side f >= 0 and set unilateral = true: the run then follows the flight"
        )
    return notes


def _crossing(t: np.ndarray, y: np.ndarray, k: int) -> float:
    """The root of y between samples k - 1 and k (signs differ), by the cubic through
    the four samples around it (linear where there are fewer)."""
    lo = k - 1
    while lo > 0 and y[lo] == 0:
        lo -= 1
    a, b = max(lo - 1, 0), min(k + 2, len(t))
    ts, ys = t[a:b], y[a:b]
    t0, t1 = t[lo], t[k]
    lin = t0 - y[lo] * (t1 - t0) / (y[k] - y[lo])
    if len(ts) < 4:
        return float(lin)
    c = np.polyfit(ts - t0, ys, 3)
    roots = [r.real + t0 for r in np.roots(c) if abs(r.imag) < 1e-12]
    inside = [r for r in roots if t0 - 1e-12 <= r <= t1 + 1e-12]
    return float(min(inside, key=lambda r: abs(r - lin))) if inside else float(lin)
