"""One case of a sweep, by :func:`lamech.numeric.simulate`: the plan every backend hands
its workers, the system compiled once per process, and the row a case gives (the
measures of :mod:`lamech.sweeps._run`, or the reason it failed)."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..model import System
from ..numeric import Options, consistent_initial
from ._parse import EVENT_MEASURES, Measure

__all__ = ["Plan", "COMPILED", "numeric_system", "measure_values", "run_case"]


@dataclass(frozen=True)
class Plan:
    """Everything a worker needs besides the case's parameter values (picklable)."""

    system: System
    measures: tuple[Measure, ...]
    t_end: float
    initial: tuple[tuple[str, float], ...]
    columns: tuple[str, ...]
    options: Options
    """The sweep's options, checked (its engine chose the backend: :mod:`._run`)."""

    @property
    def simulate_options(self) -> Options:
        """The options of a case run by :func:`lamech.simulate`: the sweep's, with
        simulate's own engine choice (its default: the sweep's engine has chosen
        simulate for this case already)."""
        return replace(self.options, engine="auto", jit=None)


COMPILED: dict[str, object] = {}  # token -> NumericSystem, one per worker process


def numeric_system(token: str, plan: Plan):
    """The plan's system compiled, once per process and sweep (``token``)."""
    ns = COMPILED.get(token)
    if ns is None:
        from ..numeric import compile_system

        ns = COMPILED[token] = compile_system(plan.system)
    return ns


def measure_values(m: Measure, traj, coords: Sequence[str], series: dict) -> list[float]:
    """The values of measure ``m`` (its columns, in order) from a run's events
    (``traj.events``) and its sampled ``series`` ({column name: samples})."""
    if m.kind in EVENT_MEASURES:
        kind = EVENT_MEASURES[m.kind]
        for e in traj.events:
            if e.kind == kind and (not m.target or e.constraint == m.target):
                return [float(e.t)] + [float(e.coordinates[c]) for c in coords]
        return [math.nan] * (1 + len(coords))
    arr = np.asarray(series[m.target], dtype=float)
    if m.kind == "final":
        return [float(arr[-1]) if len(arr) else math.nan]
    finite = arr[np.isfinite(arr)]
    if not len(finite):
        return [math.nan]
    return [float(finite.max() if m.kind == "max" else finite.min())]


def run_case(ns, plan: Plan, case: int, values: Mapping[str, float]) -> dict:
    """One row: case index, parameter values, measures, status, message."""
    from ..numeric import simulate

    coords = ns.coordinate_names
    row: dict = {"case": case, **{k: float(x) for k, x in values.items()}}
    try:
        p = ns.parameter_vector(dict(values))
        q0, v0 = consistent_initial(ns, p, plan.initial)
        traj = simulate(
            ns,
            plan.t_end,
            params=dict(values),
            q0=q0,
            qd0=v0,
            options=plan.simulate_options,
        )
    except Exception as exc:  # a bad case is a row with its reason, not a dead sweep
        for m in plan.measures:
            for col in m.columns(coords):
                row[col] = math.nan
        row["status"], row["message"] = "error", f"{type(exc).__name__}: {exc}"
        return row
    series = dict(traj.columns())
    for m in plan.measures:
        row.update(zip(m.columns(coords), measure_values(m, traj, coords, series)))
    row["status"], row["message"] = str(traj.status), traj.message
    return row
