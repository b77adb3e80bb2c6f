"""Parameter sweeps: every combination of parameter values simulated, a few numbers
measured per case, one row per case.

The system is compiled once (:func:`lamech.numeric.compile_system`) and every case only
passes a different parameter vector ``p`` to the same generated functions. Cases run in
this process, in local worker processes (:class:`concurrent.futures.ProcessPoolExecutor`)
or on a Dask cluster (``dask.distributed``); each worker compiles the system once.

Measures (the text a user writes, and the columns it gives):

``liftoff`` / ``liftoff:<constraint>``
    the first lift-off event (of any or of the named unilateral constraint):
    ``liftoff:t`` and ``liftoff:<coordinate>`` for every coordinate; NaN when none.
``slip``, ``stick``, ``contact``, ``impact`` (optionally ``:<constraint>``)
    the first event of that kind, same columns.
``max:<series>``, ``min:<series>``, ``final:<series>``
    over the sampled trajectory; a series is a coordinate ``x``, a velocity ``x'``,
    ``lambda:<constraint>``, ``force:<constraint>:<direction>``, ``energy`` or
    ``residual`` (the columns of ``lamech simulate --out``). ``max``/``min`` ignore NaN
    (a released constraint has no multiplier) and see the samples only (``samples``).

Sweepable names are the problem's parameters, and the friction coefficients of its
friction constraints as ``mu:<constraint>`` (or ``mu`` when there is exactly one and no
parameter is called ``mu``): the coefficient is turned into a parameter before compiling.

How a case runs: by the compiled loop with events (:func:`lamech.numeric.integrate_events`,
in this process, over the cores) when every measure is an event measure or
``final:`` of a coordinate or velocity, the method is DOP853 and nothing in the system
depends on t explicitly (``engine="auto"``);
numba-compiled when it is installed and the system's loop is in the cache on disk or the
sweep has at least :data:`COMPILED_CASES` cases (the first compile of a problem costs
about a minute), else the same loop as Python; impacts are applied in it. A case whose
run meets what that loop leaves to the simulator (a failure, more than 64 events, an
impact it cannot apply: see :data:`lamech.numeric.EVENT_FALLBACKS`) and every case of
any other sweep runs
:func:`lamech.numeric.simulate`, as before (``engine="scipy"`` for all cases). Both
give the same event times (to about 1e-14 on the cylinder; the tests hold them to 1e-9).

Completed rows are appended to the output table as they finish (flushed), so an
interrupted sweep, or one whose worker died, keeps them; ``resume=True`` reads the
table back and runs only the missing cases. At the end the table is rewritten sorted by
case, so a resumed sweep gives the same file as a fresh one.
"""

from __future__ import annotations

import hashlib
import itertools
import math
import os
import pickle
import sys
import time
import types
import uuid
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..model import System
from ..numeric import consistent_initial, friction_names, with_friction_parameters
from ..numeric._engines import engine_name
from ._parse import (
    EVENT_MEASURES,
    MAX_CASES,
    Measure,
    SweepError,
    number,
    parse_measure,
    parse_values,
)
from ._table import Table

__all__ = ["sweep", "run_sweep", "SweepRun", "sweepable_names"]


# ----- the system prepared for sweeping ---------------------------------------------
def sweepable_names(system: System) -> list[str]:
    return [p.name for p in system.parameters] + list(friction_names(system))


def _with_friction_parameters(system: System, names: Iterable[str]) -> System:
    try:
        return with_friction_parameters(system, names)
    except ValueError as exc:
        raise SweepError(str(exc)) from None


# ----- one case -----------------------------------------------------------------------
@dataclass(frozen=True)
class _Plan:
    """Everything a worker needs besides the case's parameter values (picklable)."""

    system: System
    measures: tuple[Measure, ...]
    t_end: float
    initial: tuple[tuple[str, float], ...]
    samples: int
    rtol: float
    atol: float
    max_step: float | None
    columns: tuple[str, ...]
    method: str = "DOP853"


_COMPILED: dict[str, object] = {}  # token -> NumericSystem, one per worker process


def _numeric(token: str, plan: _Plan):
    ns = _COMPILED.get(token)
    if ns is None:
        from ..numeric import compile_system

        ns = _COMPILED[token] = compile_system(plan.system)
    return ns


def _measure_values(m: Measure, traj, coords: Sequence[str], series: dict) -> list[float]:
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


def _run_case(ns, plan: _Plan, case: int, values: Mapping[str, float]) -> dict:
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
            samples=plan.samples,
            rtol=plan.rtol,
            atol=plan.atol,
            max_step=plan.max_step,
            method=plan.method,
        )
    except Exception as exc:  # a bad case is a row with its reason, not a dead sweep
        for m in plan.measures:
            for col in m.columns(coords):
                row[col] = math.nan
        row["status"], row["message"] = "error", f"{type(exc).__name__}: {exc}"
        return row
    series = dict(traj.columns())
    for m in plan.measures:
        row.update(zip(m.columns(coords), _measure_values(m, traj, coords, series)))
    row["status"], row["message"] = str(traj.status), traj.message
    return row


def _worker_init(token: str, blob: bytes, sweep: int) -> None:
    global _WORKER_PLAN
    _die_with_sweep(sweep)
    plan = pickle.loads(blob)
    _WORKER_PLAN = (token, plan)
    _numeric(token, plan)


def _die_with_sweep(sweep: int) -> None:
    """A worker ends when the sweep that started it (process ``sweep``) does: SIGTERM and
    SIGHUP take their default action here (a forked worker inherits the command's
    handlers, which would turn them into a row marked interrupted), and a thread ends
    the process once the sweep is gone (killed with SIGKILL, say) instead of running on
    as an orphan that holds the sweep's output pipe open. The sweep is the parent of a
    forked worker, the grandparent of one started by the fork server (whose workers
    keep it alive: it cannot be the one watched)."""
    import signal
    import threading

    for name in ("SIGTERM", "SIGHUP"):
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), signal.SIG_DFL)
    parent = os.getppid()

    def alive() -> bool:
        if parent == sweep and os.getppid() != parent:
            return False  # forked, and the sweep has gone: this process was re-parented
        try:
            os.kill(sweep, 0)
        except ProcessLookupError:
            return False
        except PermissionError:  # pragma: no cover - the pid is another user's now
            return False
        return True

    def watch() -> None:
        while alive():
            time.sleep(PARENT_POLL)
        os._exit(1)

    threading.Thread(target=watch, name="lamech-sweep-watch", daemon=True).start()


COMPILED_CASES = 500
"""From this many cases a sweep compiles its loop with numba even when the compiled code is
not yet in the cache on disk (a minute, once per machine); smaller sweeps run
the loop as Python unless it is cached."""
SYSTEM_CASES = 16
"""With the loop compiled on this machine (once, for every system), the cases from which
``auto`` compiles a new system's own functions (a few seconds) to run them compiled."""
CHUNK = 256
"""Cases per call of the compiled loop: rows are recorded (and Ctrl-C is seen) between
calls."""

PARENT_POLL = 0.2
"""Seconds between a worker's checks that its parent is alive."""
IN_FLIGHT = 4
"""Cases submitted ahead per worker: a sweep of a million cases holds a few futures at a
time, not a million (2.5 GB in the parent before)."""


_WORKER_PLAN: tuple[str, _Plan] | None = None


def _pool_case(case: int, values: dict) -> dict:
    token, plan = _WORKER_PLAN  # type: ignore[misc]
    return _run_case(_numeric(token, plan), plan, case, values)


def _dask_case(token: str, blob: bytes, case: int, values: dict) -> dict:
    plan = pickle.loads(blob)
    return _run_case(_numeric(token, plan), plan, case, values)


# ----- the run ----------------------------------------------------------------------------
@dataclass
class SweepRun:
    """The result of :func:`run_sweep`: rows sorted by case, and how they were obtained.

    ``ran`` cases (``ran_cases``) were simulated now, ``kept`` read back from the table
    (resume), ``retried`` of them run again because their row there was not ``ok``;
    ``interrupted`` is True after Ctrl-C (or a KeyboardInterrupt raised by a signal
    handler: the command's SIGTERM and SIGHUP), the workers ended; ``stopped`` says why a
    run ended before every case was done otherwise (a worker process died, the cluster
    failed); in both cases the table on disk holds the finished rows and ``resume=True``
    completes it.
    """

    parameters: dict[str, np.ndarray]
    measures: list[Measure]
    columns: list[str]
    rows: list[dict]
    ran: int = 0
    kept: int = 0
    seconds: float = 0.0
    compile_seconds: float = 0.0
    backend: str = ""
    interrupted: bool = False
    stopped: str = ""
    path: Path | None = None
    notes: list[str] = field(default_factory=list)
    ran_cases: list[int] = field(default_factory=list)  # the cases simulated now, in order
    retried: int = 0  # rows of the table whose status was not ok, run again

    @property
    def measure_columns(self) -> list[str]:
        return [
            c
            for c in self.columns
            if c not in self.parameters and c not in ("case", "status", "message")
        ]

    @property
    def counts(self) -> dict[str, int]:
        out: dict[str, int] = {}
        for r in self.rows:
            out[r["status"]] = out.get(r["status"], 0) + 1
        return out

    def records(self) -> list[dict]:
        return [dict(r) for r in self.rows]

    def _repr_html_(self) -> str:
        # Jupyter's display protocol: the one import against the layer order (sweeps ->
        # present), declared in the import-linter contract.
        from ..present import sweep_html

        return sweep_html(self)

    def to_dataframe(self):
        try:
            import pandas as pd
        except ImportError:
            raise ImportError("to_dataframe needs pandas: pip install pandas") from None
        return pd.DataFrame(self.rows, columns=self.columns)

    def to_xarray(self):
        """An xarray Dataset with one dimension per swept parameter (needs pandas and
        xarray)."""
        try:
            import xarray  # noqa: F401
        except ImportError:
            raise ImportError("to_xarray needs xarray: pip install xarray") from None
        df = self.to_dataframe().drop(columns=["case"])
        return df.set_index(list(self.parameters)).to_xarray()


def _grid(params: Mapping[str, object]) -> tuple[dict[str, np.ndarray], _Cases]:
    if not params:
        raise SweepError("no parameters to sweep; give at least one (NAME=A:B:N)")
    values: dict[str, np.ndarray] = {}
    for name, spec in params.items():
        if isinstance(spec, str):
            arr = parse_values(spec, name)
        else:
            arr = np.atleast_1d(np.asarray(spec, dtype=float))
            if arr.ndim != 1 or not len(arr) or not np.all(np.isfinite(arr)):
                raise SweepError(
                    f"parameter `{name}`: values must be a non-empty sequence of finite numbers"
                )
        values[name] = arr
    total = math.prod(len(a) for a in values.values())
    if total > MAX_CASES:
        raise SweepError(f"{total} cases exceed the limit of {MAX_CASES}")
    return values, _Cases(values)


class _Cases(Sequence):
    """The grid's cases in order (the last name varying fastest), each {name: value},
    made when asked for: a million cases need no million dicts in the parent."""

    def __init__(self, values: dict[str, np.ndarray]):
        self.names, self.arrays = list(values), list(values.values())
        self.shape = tuple(len(a) for a in self.arrays)
        self.size = math.prod(self.shape)

    def __len__(self) -> int:
        return self.size

    def __getitem__(self, i):
        if not isinstance(i, (int, np.integer)) or not 0 <= i < self.size:
            raise IndexError(i)
        at = np.unravel_index(int(i), self.shape)
        return {n: float(a[k]) for n, a, k in zip(self.names, self.arrays, at)}


def _spec(problem, plan: _Plan, values: dict[str, np.ndarray]) -> dict:
    """What made the table: recorded beside it, checked on resume (:mod:`._table`)."""
    from .._version import __version__

    return {
        "lamech": __version__,
        "problem": problem.title if isinstance(problem, System) else str(problem),
        "problem_sha256": _digest(problem),
        "parameters": {k: [float(x) for x in v] for k, v in values.items()},
        "measures": [m.text for m in plan.measures],
        "t_end": plan.t_end,
        "initial": dict(plan.initial),
        "samples": plan.samples,
        "rtol": plan.rtol,
        "atol": plan.atol,
        "max_step": plan.max_step,
        "method": plan.method,
    }


def _digest(problem) -> str:
    """SHA-256 of the problem file's bytes (a bundled example's file for its name), or of
    a System's text when the problem was given as one."""
    if isinstance(problem, System):
        return hashlib.sha256(repr(problem).encode()).hexdigest()
    from ..problem import example_names, example_path

    path = Path(problem)
    if not path.exists() and not path.suffix and str(problem) in example_names():
        path = example_path(str(problem))
    with open(path, "rb") as fh:  # the loader has read it: a regular file of at most 1 MB
        return hashlib.sha256(fh.read(2_000_000)).hexdigest()


class _Bar:
    """Cases done, on stderr, only on a terminal."""

    def __init__(self, total: int, kept: int):
        self.total, self.done, self.start = total, kept, time.monotonic()
        self.shown, self.last = False, 0.0

    def __call__(self, n: int = 1) -> None:
        self.done += n
        now = time.monotonic()
        if self.shown and now - self.last < 0.1 and self.done < self.total:
            return  # at most ten redraws a second
        self.last = now
        frac = self.done / self.total if self.total else 1.0
        bar = "#" * int(25 * frac)
        elapsed = now - self.start
        sys.stderr.write(f"\r  sweep [{bar:<25}] {self.done}/{self.total}  {elapsed:.0f} s")
        sys.stderr.flush()
        self.shown = True

    def close(self) -> None:
        if self.shown:
            sys.stderr.write("\r" + " " * 70 + "\r")
            sys.stderr.flush()


def run_sweep(
    problem,
    params: Mapping[str, object],
    measures: Sequence[str] = ("liftoff",),
    *,
    t_end: float,
    initial: Mapping[str, float | str] | None = None,
    out: str | os.PathLike | None = None,
    resume: bool = False,
    workers: int | None = None,
    scheduler=None,
    samples: int = 1001,
    rtol: float | None = None,
    atol: float | None = None,
    max_step: float | None = None,
    method: str = "DOP853",
    progress: bool | Callable[[int, int], None] | None = None,
    engine: str = "auto",
) -> SweepRun:
    """Run every combination of ``params`` and measure each case; see the module docstring.

    Parameters
    ----------
    problem : System, or a problem file path or bundled example name
    params : {name: "A:B:N" | "a,b" | sequence of floats}; the grid is their product,
        the last name varying fastest.
    measures : measure texts (``liftoff``, ``slip``, ``max:lambda:<c>``, ``final:<x>``, ...),
        or one as a string
    t_end : end time of every simulation (start at t = 0).
    initial : {coordinate or ``x'``: value} set for every case; the other coordinates
        (velocities) are moved to meet the constraints (holding these).
    out : the table (CSV; Parquet when the name ends ``.parquet``), appended as cases
        finish; ``resume`` reads it back and skips its cases.
    workers : local processes (default: the CPU count; 1 runs in this process).
    scheduler : a ``dask.distributed`` scheduler address or ``Client``; overrides
        ``workers``.
    method : the integrator (``"DOP853"``; ``"Radau"`` or ``"BDF"`` for stiff systems).
    progress : True/False, or a callable(done, total); default: a bar on a terminal.
    engine : ``"auto"`` (the compiled loop with events where the measures allow it, see the
        module docstring), ``"compiled"`` (the same, with numba whenever it is installed),
        ``"python"`` (the same loop as Python), ``"scipy"`` (every case by simulate; the
        older name ``"simulate"`` is accepted).
    """
    from ..numeric import DEFAULT_ATOL, DEFAULT_RTOL, SimulationError, check_options
    from ..problem import as_system

    system = as_system(problem, "sweep", "problem")
    if isinstance(measures, str):
        measures = [measures]  # one measure, not its letters
    if not isinstance(params, Mapping):
        raise TypeError(
            "sweep: params must be a dict {name: values} (e.g. {'mu': '0.1:0.5:5'}); "
            f"got {type(params).__name__}"
        )
    try:
        check_options(
            t_end,
            0.0,
            DEFAULT_RTOL if rtol is None else rtol,
            DEFAULT_ATOL if atol is None else atol,
            max_step,
            samples,
            None,
            method,
        )
    except SimulationError as exc:
        raise SweepError(str(exc)) from None
    engine = engine_name(engine, SweepError)
    values, cases = _grid(params)
    system = _with_friction_parameters(system, list(values))
    ms = [parse_measure(m, system) for m in measures]
    if not ms:
        raise SweepError(
            "no measures; give at least one (e.g. liftoff, slip, "
            "max:lambda:<constraint>, final:<coordinate>)"
        )
    if len({m.text for m in ms}) != len(ms):
        raise SweepError("a measure is given twice: " + ", ".join(m.text for m in ms))
    coords = [c.name for c in system.coordinates]
    init: list[tuple[str, float]] = []
    for name, x in (initial or {}).items():
        if name.rstrip("'") not in coords or name.count("'") > 1:
            raise SweepError(
                f"initial value for unknown coordinate `{name}`; known: "
                + ", ".join(coords + [c + "'" for c in coords])
            )
        init.append((name, number(str(x), f"initial `{name}`")))
    columns = ["case", *values]
    for m in ms:
        columns += m.columns(coords)
    columns += ["status", "message"]
    plan = _Plan(
        system,
        tuple(ms),
        float(t_end),
        tuple(init),
        int(samples),
        DEFAULT_RTOL if rtol is None else float(rtol),
        DEFAULT_ATOL if atol is None else float(atol),
        max_step,
        tuple(columns),
        method,
    )

    if scheduler is not None and isinstance(scheduler, str):
        try:
            import distributed  # noqa: F401
        except ImportError:
            raise SweepError(
                "a Dask scheduler needs dask.distributed: pip install 'lamech[dask]'"
            ) from None
    path = Path(out) if out is not None else None
    table = Table(path, columns, _spec(problem, plan, values))
    table.lock()  # one sweep per table
    try:
        return _run_cases(
            table, resume, system, plan, values, cases, workers, scheduler, progress, engine
        )
    finally:
        table.unlock()


def _run_cases(
    table: Table,
    resume: bool,
    system: System,
    plan: _Plan,
    values: dict[str, np.ndarray],
    cases: Sequence[dict],
    workers: int | None,
    scheduler,
    progress,
    engine: str = "auto",
) -> SweepRun:
    """The cases not in the table (all but its ``ok`` rows, on resume), run and recorded."""
    ms, columns, path = list(plan.measures), list(plan.columns), table.path
    found = table.read(cases, list(values)) if resume else {}
    done = {i: row for i, row in found.items() if row["status"] == "ok"}
    todo = [i for i in range(len(cases)) if i not in done]

    t0 = time.perf_counter()
    token = uuid.uuid4().hex
    from ..numeric import compile_system

    ns = _COMPILED[token] = compile_system(system)  # checks the model before any worker starts
    compile_seconds = time.perf_counter() - t0
    ns.parameter_vector(cases[0])  # overrides checked once, before any worker starts
    run = SweepRun(
        values,
        ms,
        columns,
        [],
        kept=len(done),
        retried=len(found) - len(done),
        path=path,
        compile_seconds=compile_seconds,
    )
    if progress is None:
        progress = sys.stderr.isatty()
    bar: Callable[[int], None] | None
    if callable(progress):
        total = len(cases)
        count = [len(done)]

        def bar(n: int = 1) -> None:
            count[0] += n
            progress(count[0], total)
    elif progress:
        bar = _Bar(len(cases), len(done))
    else:
        bar = None

    table.open(done[i] for i in sorted(done))
    results = dict(done)

    def record(row: dict) -> None:
        if row["status"] == "interrupted":
            raise KeyboardInterrupt
        if row["case"] in results:  # recomputed after a worker died: already recorded
            return
        results[row["case"]] = row
        table.append(row)
        run.ran += 1
        run.ran_cases.append(row["case"])
        if bar is not None:
            bar(1)

    try:
        compiled = ""
        if scheduler is None and engine != "scipy" and todo:
            todo, compiled = _run_compiled(ns, plan, cases, todo, record, workers, engine)
        if not todo:
            run.backend = compiled
        elif scheduler is not None:
            run.backend = _run_dask(scheduler, token, plan, cases, todo, record)
        elif (workers or _cpus()) <= 1 or len(todo) <= 1:
            run.backend = "this process"
            for i in todo:
                record(_run_case(ns, plan, i, cases[i]))
        else:
            run.backend = _run_pool(workers or _cpus(), token, plan, cases, todo, record)
        if compiled and todo:
            run.backend = f"{compiled}; {len(todo)} by simulate on {run.backend}"
    except KeyboardInterrupt:
        run.interrupted = True
    except Exception as exc:  # a worker process died, the scheduler went away, ...
        run.stopped = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
    finally:
        if isinstance(bar, _Bar):
            bar.close()
        _COMPILED.pop(token, None)
        run.rows = [results[i] for i in sorted(results)]
        if len(results) == len(cases):
            table.finish(run.rows)
        else:  # interrupted or a failure: the journal keeps what is done, for resume
            table.close()
        run.seconds = time.perf_counter() - t0
    return run


def _compiled_measures(plan: _Plan, ns) -> tuple[list, bool] | None:
    """(the events the measures want [(kind, constraint or None)], whether the runs must
    go on to t_end) when the compiled loop can give every measure, else None."""
    if plan.method != "DOP853" or len(ns.switch_slots) or ns.explicit_time:
        # the loop does not look inside its steps for a force that rises and falls
        # (simulate's force_dips), which only a system with t in it can have
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


def _run_compiled(ns, plan: _Plan, cases, todo, record, workers, engine) -> tuple[list, str]:
    """The cases ``todo`` by the compiled loop with events, in chunks of :data:`CHUNK`, each
    row recorded as its chunk ends; returns (the cases left to simulate, the backend)."""
    from ..numeric import (
        initial_states,
        integrate_events,
        jit_is_cached,
        numba_available,
        parameter_rows,
    )

    how = _compiled_measures(plan, ns)
    if how is None:
        return todo, ""
    want, to_end = how
    jit = engine == "compiled" and numba_available()
    if engine == "auto":  # numba imported only where it will be used (0.3 s)
        # the loop is compiled once per machine; a system's own functions cost seconds
        jit = jit_is_cached(ns, "ev_run_one") or (
            len(todo) >= (SYSTEM_CASES if jit_is_cached(None, "ev_run_one") else COMPILED_CASES)
            and numba_available()
        )
    names = list(cases[todo[0]])
    coords, n = ns.coordinate_names, ns.n
    threads = workers or _cpus()  # threads of the compiled loop (it releases the GIL)
    left: list[int] = []
    for start in range(0, len(todo), CHUNK):
        chunk = todo[start : start + CHUNK]
        vals = np.array([[cases[i][k] for k in names] for i in chunk], dtype=float)
        try:
            P = parameter_rows(ns, names, vals)
            Y0 = initial_states(ns, P, plan.initial, jit=jit)
            ok = np.all(np.isfinite(Y0), axis=1)
            res = integrate_events(
                ns,
                Y0[ok],
                plan.t_end,
                params=P[ok],
                rtol=plan.rtol,
                atol=plan.atol,
                max_step=plan.max_step,
                want=want,
                to_end=to_end,
                threads=threads,
                jit=jit,
                impacts=True,  # applied in the loop as simulate applies them
                max_events=64,  # a bouncing case with more falls back to simulate
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
                    row.update(zip(m.columns(coords), _measure_values(m, events, coords, series)))
                row["status"], row["message"] = "ok", ""
                record(row)
            b += 1
    how_run = f"numba, {threads} threads" if jit and threads > 1 else "numba" if jit else "Python"
    return left, f"the compiled loop with events ({how_run})"


def _cpus() -> int:
    """The CPUs this process may use (its affinity mask where the OS has one)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - macOS, Windows
        return os.cpu_count() or 1


def _run_pool(workers: int, token: str, plan: _Plan, cases, todo, record) -> str:
    """The cases on local processes, :data:`IN_FLIGHT` per worker submitted at a time;
    on any exception (Ctrl-C, SIGTERM, a dead worker) the workers are ended at once."""
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    workers = min(workers, len(todo))
    blob = pickle.dumps(plan)
    pool = ProcessPoolExecutor(
        max_workers=workers,
        mp_context=_pool_context(),
        initializer=_worker_init,
        initargs=(token, blob, os.getpid()),
    )
    waiting = iter(todo)
    pending: set = set()
    try:
        while True:
            for i in itertools.islice(waiting, IN_FLIGHT * workers - len(pending)):
                pending.add(pool.submit(_pool_case, i, cases[i]))
            if not pending:
                break
            done, pending = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                record(fut.result())
    except BaseException:
        _end_pool(pool)
        raise
    pool.shutdown()
    return f"{workers} local processes"


def _pool_context():
    """How local workers start. By forking this process when it runs a single thread
    (the command line, a plain script): at once, nothing imported again. Otherwise
    from a fork server (started once, single-threaded, lamech imported in it): forking a
    process that runs other threads (a notebook's, a test runner's, Dask's) copies locks
    those threads may hold, and a worker can wait on one forever, so that the sweep
    never ends. Each worker compiles the system from the plan (milliseconds). Spawn
    where neither exists (Windows)."""
    import multiprocessing as mp
    import threading

    methods = mp.get_all_start_methods()
    if threading.active_count() == 1 and "fork" in methods:
        return mp.get_context("fork")
    if "forkserver" in methods:
        ctx = mp.get_context("forkserver")
        ctx.set_forkserver_preload([__name__, "lamech.numeric"])
        return ctx
    return mp.get_context("spawn")  # pragma: no cover - Windows


def _end_pool(pool) -> None:
    """Cancel the cases not started and end the workers now: a case may run for minutes,
    and a worker left running would outlive the sweep."""
    terminate = getattr(pool, "terminate_workers", None)  # Python 3.14
    if terminate is not None:
        terminate()
        return
    processes = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in processes:
        if proc.is_alive():
            proc.terminate()
    for proc in processes:
        proc.join(timeout=5)


def _run_dask(scheduler, token: str, plan: _Plan, cases, todo, record) -> str:
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise SweepError(
            "a Dask scheduler needs dask.distributed: pip install 'lamech[dask]'"
        ) from None
    own = not isinstance(scheduler, Client)
    client = Client(scheduler) if own else scheduler
    try:
        blob = client.scatter(pickle.dumps(plan), broadcast=True)

        def submit(i: int):
            return client.submit(
                _dask_case,
                token,
                blob,
                i,
                cases[i],
                pure=False,
                retries=2,
                key=f"lamech-case-{token}-{i}",
            )

        # a bounded number ahead of the cluster: one more submitted as each finishes
        ahead = IN_FLIGHT * max(len(client.scheduler_info().get("workers", {})), 2) * 4
        waiting = iter(todo)
        running = as_completed([submit(i) for i in itertools.islice(waiting, ahead)])
        try:
            for fut in running:
                record(fut.result())
                fut.release()
                for i in itertools.islice(waiting, 1):
                    running.add(submit(i))
        except BaseException:
            client.cancel(list(running.futures))
            raise
        n = len(client.scheduler_info().get("workers", {}))
        return f"Dask at {client.scheduler.address} ({n} workers)"
    finally:
        if own:
            client.close()


def sweep(
    problem,
    params: Mapping[str, object],
    measures: Sequence[str] = ("liftoff",),
    *,
    output: str = "auto",
    **options,
):
    """Run a sweep (:func:`run_sweep`, same arguments) and return its table.

    ``output``: ``"auto"`` (a pandas DataFrame when pandas is installed, else a list of
    dicts), ``"dataframe"``, ``"records"``, or ``"xarray"`` (a Dataset with one dimension
    per parameter).
    """
    if output not in ("auto", "dataframe", "records", "xarray"):
        raise SweepError(f"unknown output {output!r}; one of auto, dataframe, records, xarray")
    run = run_sweep(problem, params, measures, **options)
    if run.interrupted:
        raise KeyboardInterrupt
    if run.stopped:
        where = (
            f"; the finished rows are in {run.path}, resume=True completes it" if run.path else ""
        )
        raise SweepError(
            f"the sweep stopped ({run.stopped}) after {len(run.rows)} of "
            f"{math.prod(len(a) for a in run.parameters.values())} cases{where}"
        )
    if output == "records":
        return run.records()
    if output == "xarray":
        return run.to_xarray()
    if output == "dataframe":
        return run.to_dataframe()
    try:
        return run.to_dataframe()
    except ImportError:
        return run.records()
