"""The initial state as numbers: the coordinates' initial expressions at a parameter
vector, values held by name with the others moved onto the constraints
(:func:`consistent_initial`: the loop's consistent start,
the engine's ``lm_consistent``, ``lamech.numeric._crules``), and the arrays or dicts a caller
overrides them with (:func:`initial_state`)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import sympy as sp

from ._options import INITIAL_TOLERANCE, SimulationError

__all__ = ["expression_values", "initial_state", "consistent_initial", "initial_residuals"]


_VALUES: dict[tuple[int, bytes], tuple] = {}
"""(id(system), parameter bytes) -> (system, q0, v0): the last starts computed (SymPy's
subs costs about 1.5 ms a run on the 5-link chain, a third of a short compiled run)."""


def expression_values(ns, p: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(q0, v0) from the coordinates' initial expressions at parameters ``p``."""
    system = ns.system
    p = ns.parameters if p is None else p
    key = (id(system), np.asarray(p, dtype=float).tobytes())
    known = _VALUES.get(key)
    if known is not None and known[0] is system:
        return known[1].copy(), known[2].copy()
    env = {par.symbol: float(val) for par, val in zip(system.parameters, p)}
    q0 = np.array([float(sp.sympify(c.initial).subs(env)) for c in system.coordinates])
    v0 = np.array([float(sp.sympify(c.initial_velocity).subs(env)) for c in system.coordinates])
    if len(_VALUES) >= 64:
        _VALUES.clear()
    _VALUES[key] = (system, q0.copy(), v0.copy())
    return q0, v0


def initial_residuals(ns, p, t: float, q: np.ndarray, v: np.ndarray):
    """(f, F, tol): the constraint values f and velocity forms F = A v + b at (t, q, v),
    and the tolerance INITIAL_TOLERANCE (1 + max |q|) within which a start meets them."""
    f, A, b = ns.constraints(t, q, p)
    tol = INITIAL_TOLERANCE * (1 + float(np.max(np.abs(q), initial=0.0)))
    return f, A @ v + b, tol


def consistent_initial(ns, p: np.ndarray, initial: Sequence[tuple[str, float]]):
    """The initial state at ``p`` with the named coordinates/velocities (``x'``) set and
    held; the other coordinates moved onto the constraints that the problem's own initial
    state meets, and likewise the velocities (the simulator's projection, in the
    mass-matrix metric over the coordinates that are not held)."""
    q, v = expression_values(ns, p)
    if not initial:
        return q, v
    from ._run import ConstraintKinds, rules

    names = ns.coordinate_names
    hold_q, hold_v = np.zeros(ns.n, dtype=np.bool_), np.zeros(ns.n, dtype=np.bool_)
    value_q, value_v = np.zeros(ns.n), np.zeros(ns.n)
    for name, value in initial:
        if name.endswith("'"):
            i = names.index(name[:-1])
            hold_v[i], value_v[i] = True, value
        else:
            i = names.index(name)
            hold_q[i], value_q[i] = True, value
    kinds = ConstraintKinds.of(ns.system).array()
    p = np.asarray(p, dtype=float)
    rules(ns).ev_consistent(q, v, p, hold_q, hold_v, value_q, value_v, kinds, INITIAL_TOLERANCE)
    return q, v


def initial_state(ns, p: np.ndarray, initial: dict | None = None, q0=None, qd0=None) -> np.ndarray:
    """y0 = [q0; q0'] of a run: :func:`consistent_initial` with ``initial``
    {coordinate or ``x'``: value} held, then ``q0``/``qd0`` (dicts by coordinate name, or
    arrays in coordinate order) set as given. Raises :class:`SimulationError` for unknown
    names, values that are not numbers, and a state that is not finite."""
    q, v = consistent_initial(ns, p, _held(ns, initial or {}))
    for arr, val, what in ((q, q0, "coordinates"), (v, qd0, "velocities")):
        _override(arr, _as_vector(val, ns.coordinate_names, what), ns.coordinate_names)
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
        raise SimulationError("the initial state is not finite")
    return np.concatenate((q, v))


def _held(ns, initial: dict) -> list[tuple[str, float]]:
    known = list(ns.coordinate_names) + [c + "'" for c in ns.coordinate_names]
    held = []
    for name, value in initial.items():
        if name not in known:
            raise SimulationError(
                f"initial value for unknown coordinate `{name}`; known: {', '.join(known)}"
            )
        try:
            held.append((name, float(value)))
        except (TypeError, ValueError):
            raise SimulationError(
                f"initial value of `{name}` must be a number, got {value!r}"
            ) from None
    return held


def _override(arr: np.ndarray, val, names: list[str]) -> None:
    if isinstance(val, dict):
        for k, x in val.items():
            arr[names.index(k.rstrip("'"))] = float(x)
    elif val is not None:
        arr[:] = val


def _as_vector(value, names: list[str], what: str):
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
