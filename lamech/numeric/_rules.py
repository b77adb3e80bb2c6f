"""The kernels (:mod:`._kernels`) as Python around a system's NumPy functions: the one
implementation of the rules, run without numba. :mod:`._batch`'s engine "python" runs
its loops this way; the SciPy-stepped path (:mod:`._run`, :mod:`._initial`) calls the
same projection and consistent start (:func:`rules`)."""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:  # _codegen imports _initial, which imports this module
    from ._codegen import NumericSystem

__all__ = ["python_namespace", "bound", "rules", "kinds_array"]


def python_namespace(ns: NumericSystem) -> dict:
    """The kernels as Python around the system's NumPy functions: one namespace of their
    functions where the KKT solve and the right-hand sides are the NumPy ones of ``ns``
    (no numba: the same loop the compiled system runs, slowly), and ``"sy"`` the system
    record they take."""
    from ._kernels import python_namespace as kernels

    namespace = kernels()
    namespace["kkt_solve"] = lambda sy, *args: ns.kkt_solve(*args)
    namespace["rhs_kernel"] = lambda sy, *args: ns.rhs_kernel(*args)
    namespace["accelerations"] = lambda sy, *args: ns.accelerations(*args)
    arrays = tuple(np.ascontiguousarray(a, dtype=np.int64) for a in ns.pattern)
    namespace["sy"] = (
        bool(ns.mass_diagonal), *arrays, ns.dynamics, None, ns.constraints, ns.energy,
        ns.restitution,
    )  # fmt: skip
    return namespace


def bound(namespace: dict, names) -> dict:
    """The functions ``names`` of a namespace with its system record bound."""
    return {name: functools.partial(namespace[name], namespace["sy"]) for name in names}


def _lapack_gauss(K: np.ndarray, x: np.ndarray) -> None:
    """linalg.gauss_inplace's contract (x becomes the solution, NaN where K is singular)
    by LAPACK: as Python the kernels' elimination costs a Python loop per entry, which on
    a chain's (n + k)-square KKT system is most of a SciPy step's time."""
    try:
        x[:] = np.linalg.solve(K, x)
    except np.linalg.LinAlgError:
        x[:] = np.nan


def rules(ns: NumericSystem) -> dict:
    """The rule functions a SciPy-stepped run calls, the system record bound: the
    projection ``ev_project(t, y, p, rows, hrows, offset)`` and the consistent start
    ``ev_consistent(q, v, p, hold_q, hold_v, value_q, value_v, kinds, tol)``."""
    namespace = python_namespace(ns)
    namespace["gauss_inplace"] = _lapack_gauss
    return bound(namespace, ("ev_project", "ev_consistent"))


def kinds_array(system) -> np.ndarray:
    """(3, m) int64, the constraints' kinds as the kernels take them: unilateral,
    holonomic, normal index (-1 where not friction)."""
    names = [c.name for c in system.constraints]
    out = np.zeros((3, len(names)), dtype=np.int64)
    for j, c in enumerate(system.constraints):
        out[0, j] = int(c.unilateral)
        out[1, j] = int(c.holonomic)
        out[2, j] = names.index(c.friction.normal) if c.friction else -1
    return out
