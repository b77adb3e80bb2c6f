"""A sweep's cases in this process by the compiled loop with events
(:func:`lamech.numeric.integrate_events`, lamech's engine in C over the cores, or the same
loop with the problem's NumPy functions called back), in chunks; the cases it cannot finish
as :func:`lamech.numeric.simulate` would are handed back to run by simulate (see
:mod:`lamech.sweeps._run`)."""

from __future__ import annotations

import types

import numpy as np

from ._case import Plan, measure_values
from ._local import cpus
from ._parse import EVENT_MEASURES

__all__ = ["run_compiled", "CHUNK"]

CHUNK = 256
"""Cases per call of the compiled loop: rows are recorded (and Ctrl-C is seen) between
calls."""


def _compiled_measures(plan: Plan, ns) -> tuple[list, bool] | None:
    """(the events the measures want [(kind, constraint or None)], whether the runs must
    go on to t_end) when the compiled loop can give every measure, else None."""
    if plan.options.method != "DOP853":
        return None
    coords = ns.coordinate_names
    want, to_end = [], False
    for m in plan.measures:
        if m.kind in EVENT_MEASURES:
            want.append((EVENT_MEASURES[m.kind], m.target or None))
        elif m.kind == "final" and m.target.count("'") <= 1 and m.target.rstrip("'") in coords:
            to_end = True
        else:
            return None
    return want, to_end


def run_compiled(ns, plan: Plan, cases, todo, record, workers, engine) -> tuple[list, str]:
    """The cases ``todo`` by the compiled loop with events, in chunks of :data:`CHUNK`, each
    row recorded as its chunk ends; returns (the cases left to simulate, the backend)."""
    from ..numeric import compiled_available, initial_states, integrate_events, parameter_rows

    how = _compiled_measures(plan, ns)
    if how is None:
        return todo, ""
    want, to_end = how
    # the engine in C is built at install; a system's own C compiles in a fraction of a
    # second (lamech.numeric._cc): "auto" runs compiled wherever it can
    jit = engine in ("compiled", "auto") and compiled_available()
    names = list(cases[todo[0]])
    coords, n = ns.coordinate_names, ns.n
    threads = workers or cpus()  # threads of the compiled loop (it releases the GIL)
    left: list[int] = []
    for start in range(0, len(todo), CHUNK):
        chunk = todo[start : start + CHUNK]
        vals = np.array([[cases[i][k] for k in names] for i in chunk], dtype=float)
        try:
            P = parameter_rows(ns, names, vals)
            Y0 = initial_states(ns, P)  # made consistent in the runs (initial=, below)
            ok = np.all(np.isfinite(Y0), axis=1)
            res = integrate_events(
                ns,
                Y0[ok],
                plan.t_end,
                params=P[ok],
                rtol=plan.options.rtol,
                atol=plan.options.atol,
                max_step=plan.options.max_step,
                want=want,
                to_end=to_end,
                threads=threads,
                jit=jit,
                impacts=True,  # applied in the loop as simulate applies them
                max_events=64,  # a bouncing case with more falls back to simulate
                initial=plan.initial,
            )
        except Exception:  # e.g. an expression out of its domain (the Python loop raises):
            left.extend(chunk)  # simulate runs these cases and says what went wrong
            continue
        b = 0
        for i, fine in zip(chunk, ok):
            if not fine:
                left.append(i)
                continue
            if res.fallback[b]:
                left.append(i)
            else:
                final = res.y[b]
                series = {c: final[k : k + 1] for k, c in enumerate(coords)}
                series.update({c + "'": final[n + k : n + k + 1] for k, c in enumerate(coords)})
                row: dict = {"case": i, **{k: float(x) for k, x in cases[i].items()}}
                events = types.SimpleNamespace(events=res.events[b])
                for m in plan.measures:
                    row.update(zip(m.columns(coords), measure_values(m, events, coords, series)))
                row["status"], row["message"] = "ok", ""
                record(row)
            b += 1
    how_run = f"C, {threads} threads" if jit and threads > 1 else "C" if jit else "Python"
    return left, f"the compiled loop with events ({how_run})"
