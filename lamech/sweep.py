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

Completed rows are appended to the output table as they finish (flushed), so an
interrupted sweep, or one whose worker died, keeps them; ``resume=True`` reads the
table back and runs only the missing cases. At the end the table is rewritten sorted by
case, so a resumed sweep gives the same file as a fresh one.
"""

from __future__ import annotations

import csv
import itertools
import math
import os
import pickle
import sys
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable, Mapping, Sequence

import numpy as np

from .model import System
from .simulate import consistent_initial, friction_names, with_friction_parameters

__all__ = ["sweep", "run_sweep", "SweepRun", "SweepError", "Measure", "parse_values",
           "parse_measure", "parse_assignment", "plot_sweep", "EVENT_MEASURES"]

EVENT_MEASURES = {"liftoff": "lift-off", "slip": "slip", "stick": "stick",
                  "contact": "contact", "impact": "impact"}
SERIES_MEASURES = ("max", "min", "final")
MAX_CASES = 1_000_000


class SweepError(ValueError):
    """Bad sweep input (names, ranges, measures, a table that does not fit); nothing ran."""


# ----- parsing ------------------------------------------------------------------------
def _number(text: str, what: str) -> float:
    try:
        x = float(text.strip())
    except ValueError:
        raise SweepError(f"{what}: {text.strip()!r} is not a number") from None
    if not math.isfinite(x):
        raise SweepError(f"{what}: {text.strip()!r} is not a finite number")
    return x


def parse_values(text: str, name: str = "value") -> np.ndarray:
    """``"A:B:N"`` (N values from A to B, both included), ``"a,b,c"`` or ``"a"``.

    Numbers only (``float``); no expression is evaluated.
    """
    what = f"parameter `{name}`"
    text = str(text).strip()
    if not text:
        raise SweepError(f"{what}: no values (write A:B:N, a,b,c or a single number)")
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise SweepError(f"{what}: range {text!r} must be A:B:N (start, stop, count), "
                             "e.g. 0.1:1.0:50")
        a, b = _number(parts[0], what), _number(parts[1], what)
        try:
            count = int(parts[2].strip())
        except ValueError:
            raise SweepError(f"{what}: count {parts[2].strip()!r} in {text!r} is not an "
                             "integer") from None
        if count < 1 or (count == 1 and a != b):
            raise SweepError(f"{what}: range {text!r} needs a count >= 2 (or A = B)")
        if count > MAX_CASES:
            raise SweepError(f"{what}: count {count} exceeds {MAX_CASES}")
        # 15 significant digits: 0.3, not linspace's 0.30000000000000004
        return np.array([float(f"{x:.15g}") for x in np.linspace(a, b, count)])
    values = [_number(part, what) for part in text.split(",")]
    return np.array(values, dtype=float)


def parse_assignment(text: str, what: str = "--param") -> tuple[str, str]:
    """``"NAME=VALUE"`` -> (NAME, VALUE), both stripped."""
    name, sep, value = str(text).partition("=")
    if not sep or not name.strip() or not value.strip():
        raise SweepError(f"{what} {text!r}: write NAME=VALUE")
    return name.strip(), value.strip()


@dataclass(frozen=True)
class Measure:
    """One measured quantity of a case (see the module docstring); ``text`` as written."""

    kind: str        # liftoff, slip, stick, contact, impact, max, min, final
    target: str      # a constraint ("" = any) for events; a series for max/min/final
    text: str

    def columns(self, coordinates: Sequence[str]) -> list[str]:
        if self.kind in EVENT_MEASURES:
            return [f"{self.text}:t"] + [f"{self.text}:{c}" for c in coordinates]
        return [self.text]


def _series_names(system: System) -> list[str]:
    names = [c.name for c in system.coordinates] + [c.name + "'" for c in system.coordinates]
    names += ["lambda:" + c.name for c in system.constraints]
    for c in system.constraints:
        if c.force is not None:
            dirs = [d for d, _ in c.force.along] or list("xyz"[:system.dimension])
            names += [f"force:{c.name}:{d}" for d in dirs]
    return names + ["energy", "residual"]


def parse_measure(text: str, system: System) -> Measure:
    """Check ``text`` against ``system``; a :class:`SweepError` names the known choices."""
    text = str(text).strip()
    kind, _, rest = text.partition(":")
    kinds = list(EVENT_MEASURES) + [k + ":<series>" for k in SERIES_MEASURES]
    if kind in EVENT_MEASURES:
        if rest:
            known = [c.name for c in system.constraints]
            if rest not in known:
                raise SweepError(f"measure {text!r}: unknown constraint `{rest}`; known: "
                                 f"{', '.join(known)}")
        return Measure(kind, rest, text)
    if kind in SERIES_MEASURES:
        known = _series_names(system)
        if rest not in known:
            raise SweepError(f"measure {text!r}: unknown series `{rest}`; known: "
                             f"{', '.join(known)}")
        return Measure(kind, rest, text)
    raise SweepError(f"unknown measure {text!r}; known: {', '.join(kinds)}")


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


_COMPILED: dict[str, object] = {}   # token -> NumericSystem, one per worker process


def _numeric(token: str, plan: _Plan):
    ns = _COMPILED.get(token)
    if ns is None:
        from .numeric import compile_system
        ns = _COMPILED[token] = compile_system(plan.system)
    return ns


def _measure_values(m: Measure, traj, coords: Sequence[str], series: dict) -> list[float]:
    if m.kind in EVENT_MEASURES:
        kind = EVENT_MEASURES[m.kind]
        for e in traj.events:
            if e["kind"] == kind and (not m.target or e["constraint"] == m.target):
                return [float(e["t"])] + [float(e["coordinates"][c]) for c in coords]
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
    from .simulate import simulate

    coords = ns.coordinate_names
    row: dict = {"case": case, **{k: float(x) for k, x in values.items()}}
    try:
        p = ns.parameter_vector(dict(values))
        q0, v0 = consistent_initial(ns, p, plan.initial)
        traj = simulate(ns, plan.t_end, params=dict(values), q0=q0, qd0=v0,
                        samples=plan.samples, rtol=plan.rtol, atol=plan.atol,
                        max_step=plan.max_step)
    except Exception as exc:    # a bad case is a row with its reason, not a dead sweep
        for m in plan.measures:
            for col in m.columns(coords):
                row[col] = math.nan
        row["status"], row["message"] = "error", f"{type(exc).__name__}: {exc}"
        return row
    series = dict(traj.columns())
    for m in plan.measures:
        row.update(zip(m.columns(coords), _measure_values(m, traj, coords, series)))
    row["status"], row["message"] = traj.status, traj.message
    return row


def _worker_init(token: str, blob: bytes) -> None:
    global _WORKER_PLAN
    plan = pickle.loads(blob)
    _WORKER_PLAN = (token, plan)
    _numeric(token, plan)


_WORKER_PLAN: tuple[str, _Plan] | None = None


def _pool_case(case: int, values: dict) -> dict:
    token, plan = _WORKER_PLAN  # type: ignore[misc]
    return _run_case(_numeric(token, plan), plan, case, values)


def _dask_case(token: str, blob: bytes, case: int, values: dict) -> dict:
    plan = pickle.loads(blob)
    return _run_case(_numeric(token, plan), plan, case, values)


# ----- the table on disk ----------------------------------------------------------------
def _fmt(x) -> str:
    if isinstance(x, str):
        return x
    if isinstance(x, (int, np.integer)):
        return str(int(x))
    x = float(x)
    return "nan" if math.isnan(x) else repr(x)


class _Table:
    """The output table: rows appended (flushed) as cases finish; read back on resume."""

    def __init__(self, path: Path | None, columns: Sequence[str]):
        self.path = path
        self.columns = list(columns)
        self.parquet = path is not None and path.suffix.lower() == ".parquet"
        self.journal = (path.with_name(path.name + ".partial.csv") if self.parquet
                        else path)
        self._fh = None

    def read(self, cases: list[dict], names: list[str]) -> dict[int, dict]:
        """Rows already in the table (resume), checked against this sweep's grid."""
        if self.path is None:
            raise SweepError("resume needs an output table (out=... / --out)")
        rows: list[dict] = []
        source = None
        if self.journal.exists():
            source = self.journal
            with open(self.journal, newline="", encoding="utf-8") as fh:
                text = fh.read()
            complete = text if text.endswith("\n") else text[:text.rfind("\n") + 1]
            reader = csv.reader(complete.splitlines())
            header = next(reader, None)
            if header is None:
                return {}
            if header != self.columns:
                raise SweepError(f"cannot resume from {source}: its columns "
                                 f"({', '.join(header)}) are not this sweep's "
                                 f"({', '.join(self.columns)})")
            for rec in reader:
                if len(rec) == len(self.columns):
                    rows.append(dict(zip(self.columns, rec)))
        elif self.parquet and self.path.exists():
            source = self.path
            import pandas as pd
            df = pd.read_parquet(self.path)
            if list(df.columns) != self.columns:
                raise SweepError(f"cannot resume from {source}: its columns "
                                 f"({', '.join(df.columns)}) are not this sweep's "
                                 f"({', '.join(self.columns)})")
            rows = df.to_dict("records")
        done: dict[int, dict] = {}
        for rec in rows:
            row = {}
            for k, x in rec.items():
                row[k] = x if k in ("status", "message") else float(x)
            row["message"] = "" if row["message"] is None else str(row["message"])
            case = int(row["case"])
            if not 0 <= case < len(cases) or any(row[n] != cases[case][n] for n in names):
                raise SweepError(f"cannot resume from {source}: case {case} has "
                                 + ", ".join(f"{n} = {row[n]!r}" for n in names)
                                 + ", not a point of this sweep's grid (a different sweep?)")
            row["case"] = case
            done[case] = row
        return done

    def open(self, kept: Iterable[dict]) -> None:
        if self.journal is None:
            return
        self.journal.parent.mkdir(parents=True, exist_ok=True)
        self._fh = open(self.journal, "w", newline="", encoding="utf-8")
        self._writer = csv.writer(self._fh, lineterminator="\n")
        self._writer.writerow(self.columns)
        for row in kept:
            self._writer.writerow([_fmt(row[c]) for c in self.columns])
        self._fh.flush()

    def append(self, row: dict) -> None:
        if self._fh is not None:
            self._writer.writerow([_fmt(row[c]) for c in self.columns])
            self._fh.flush()

    def close(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None

    def finish(self, rows: list[dict]) -> None:
        """Rewrite the table sorted by case (atomically); Parquet from the journal."""
        self.close()
        if self.path is None:
            return
        if self.parquet:
            import pandas as pd
            pd.DataFrame(rows, columns=self.columns).to_parquet(self.path, index=False)
            self.journal.unlink(missing_ok=True)
            return
        tmp = self.path.with_name(self.path.name + ".tmp")
        with open(tmp, "w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh, lineterminator="\n")
            w.writerow(self.columns)
            for row in rows:
                w.writerow([_fmt(row[c]) for c in self.columns])
        os.replace(tmp, self.path)


# ----- the run ----------------------------------------------------------------------------
@dataclass
class SweepRun:
    """The result of :func:`run_sweep`: rows sorted by case, and how they were obtained.

    ``ran`` cases were simulated now, ``kept`` read back from the table (resume);
    ``interrupted`` is True after Ctrl-C; ``stopped`` says why a run ended before every
    case was done otherwise (a worker process died, the cluster failed); in both cases
    the table on disk holds the finished rows and ``resume=True`` completes it.
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

    @property
    def measure_columns(self) -> list[str]:
        return [c for c in self.columns
                if c not in self.parameters and c not in ("case", "status", "message")]

    @property
    def counts(self) -> dict[str, int]:
        out: dict[str, int] = {}
        for r in self.rows:
            out[r["status"]] = out.get(r["status"], 0) + 1
        return out

    def records(self) -> list[dict]:
        return [dict(r) for r in self.rows]

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


def _grid(params: Mapping[str, object]) -> tuple[dict[str, np.ndarray], list[dict]]:
    if not params:
        raise SweepError("no parameters to sweep; give at least one (NAME=A:B:N)")
    values: dict[str, np.ndarray] = {}
    for name, spec in params.items():
        if isinstance(spec, str):
            arr = parse_values(spec, name)
        else:
            arr = np.atleast_1d(np.asarray(spec, dtype=float))
            if arr.ndim != 1 or not len(arr) or not np.all(np.isfinite(arr)):
                raise SweepError(f"parameter `{name}`: values must be a non-empty "
                                 "sequence of finite numbers")
        values[name] = arr
    total = math.prod(len(a) for a in values.values())
    if total > MAX_CASES:
        raise SweepError(f"{total} cases exceed the limit of {MAX_CASES}")
    names = list(values)
    cases = [dict(zip(names, (float(x) for x in combo)))
             for combo in itertools.product(*values.values())]
    return values, cases


class _Bar:
    """Cases done, on stderr, only on a terminal."""

    def __init__(self, total: int, kept: int):
        self.total, self.done, self.start = total, kept, time.monotonic()
        self.shown, self.last = False, 0.0

    def __call__(self, n: int = 1) -> None:
        self.done += n
        now = time.monotonic()
        if self.shown and now - self.last < 0.1 and self.done < self.total:
            return      # at most ten redraws a second
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


def run_sweep(problem, params: Mapping[str, object], measures: Sequence[str] = ("liftoff",),
              *, t_end: float, initial: Mapping[str, float] | None = None,
              out: str | os.PathLike | None = None, resume: bool = False,
              workers: int | None = None, scheduler=None, samples: int = 1001,
              rtol: float | None = None, atol: float | None = None,
              max_step: float | None = None,
              progress: bool | Callable[[int, int], None] | None = None) -> SweepRun:
    """Run every combination of ``params`` and measure each case; see the module docstring.

    Parameters
    ----------
    problem : System, or a problem file path or bundled example name
    params : {name: "A:B:N" | "a,b" | sequence of floats}; the grid is their product,
        the last name varying fastest.
    measures : measure texts (``liftoff``, ``slip``, ``max:lambda:<c>``, ``final:<x>``, ...)
    t_end : end time of every simulation (start at t = 0).
    initial : {coordinate or ``x'``: value} set for every case; the other coordinates
        (velocities) are moved to meet the constraints (holding these).
    out : the table (CSV; Parquet when the name ends ``.parquet``), appended as cases
        finish; ``resume`` reads it back and skips its cases.
    workers : local processes (default: the CPU count; 1 runs in this process).
    scheduler : a ``dask.distributed`` scheduler address or ``Client``; overrides
        ``workers``.
    progress : True/False, or a callable(done, total); default: a bar on a terminal.
    """
    from .problem import load
    from .simulate import DEFAULT_ATOL, DEFAULT_RTOL, SimulationError, _check_options

    system = problem if isinstance(problem, System) else load(problem)
    try:
        _check_options(t_end, 0.0, DEFAULT_RTOL if rtol is None else rtol,
                       DEFAULT_ATOL if atol is None else atol, max_step, samples, None)
    except SimulationError as exc:
        raise SweepError(str(exc)) from None
    values, cases = _grid(params)
    system = _with_friction_parameters(system, list(values))
    ms = [parse_measure(m, system) for m in measures]
    if not ms:
        raise SweepError("no measures; give at least one (e.g. liftoff, slip, "
                         "max:lambda:<constraint>, final:<coordinate>)")
    if len({m.text for m in ms}) != len(ms):
        raise SweepError("a measure is given twice: " + ", ".join(m.text for m in ms))
    coords = [c.name for c in system.coordinates]
    init: list[tuple[str, float]] = []
    for name, x in (initial or {}).items():
        if name.rstrip("'") not in coords or name.count("'") > 1:
            raise SweepError(f"initial value for unknown coordinate `{name}`; known: "
                             + ", ".join(coords + [c + "'" for c in coords]))
        init.append((name, _number(str(x), f"initial `{name}`")))
    columns = ["case", *values]
    for m in ms:
        columns += m.columns(coords)
    columns += ["status", "message"]
    plan = _Plan(system, tuple(ms), float(t_end), tuple(init), int(samples),
                 DEFAULT_RTOL if rtol is None else float(rtol),
                 DEFAULT_ATOL if atol is None else float(atol), max_step, tuple(columns))

    if scheduler is not None and isinstance(scheduler, str):
        try:
            import distributed  # noqa: F401
        except ImportError:
            raise SweepError("a Dask scheduler needs dask.distributed: "
                             "pip install 'lamech[dask]'") from None
    path = Path(out) if out is not None else None
    table = _Table(path, columns)
    done = table.read(cases, list(values)) if resume else {}
    todo = [i for i in range(len(cases)) if i not in done]

    t0 = time.perf_counter()
    token = uuid.uuid4().hex
    from .numeric import compile_system
    ns = _COMPILED[token] = compile_system(system)   # checks the model; forked workers reuse it
    compile_seconds = time.perf_counter() - t0
    ns.parameter_vector(cases[0])     # overrides checked once, before any worker starts
    run = SweepRun(values, ms, columns, [], kept=len(done), path=path,
                   compile_seconds=compile_seconds)
    if progress is None:
        progress = sys.stderr.isatty()
    bar: Callable[[int], None] | None
    if callable(progress):
        total = len(cases)
        count = [len(done)]

        def bar(n: int = 1) -> None:
            count[0] += n
            progress(count[0], total)  # type: ignore[operator]
    elif progress:
        bar = _Bar(len(cases), len(done))
    else:
        bar = None

    table.open(done[i] for i in sorted(done))
    results = dict(done)

    def record(row: dict) -> None:
        if row["status"] == "interrupted":
            raise KeyboardInterrupt
        if row["case"] in results:    # recomputed after a worker died: already recorded
            return
        results[row["case"]] = row
        table.append(row)
        run.ran += 1
        if bar is not None:
            bar(1)

    try:
        if scheduler is not None:
            run.backend = _run_dask(scheduler, token, plan, cases, todo, record)
        elif (workers or _cpus()) <= 1 or len(todo) <= 1:
            run.backend = "this process"
            for i in todo:
                record(_run_case(ns, plan, i, cases[i]))
        else:
            run.backend = _run_pool(workers or _cpus(), token, plan, cases, todo, record)
    except KeyboardInterrupt:
        run.interrupted = True
    except Exception as exc:    # a worker process died, the scheduler went away, ...
        run.stopped = (f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__)
    finally:
        if isinstance(bar, _Bar):
            bar.close()
        _COMPILED.pop(token, None)
        run.rows = [results[i] for i in sorted(results)]
        if len(results) == len(cases):
            table.finish(run.rows)
        else:   # interrupted or a failure: the journal keeps what is done, for resume
            table.close()
        run.seconds = time.perf_counter() - t0
    return run


def _cpus() -> int:
    """The CPUs this process may use (its affinity mask where the OS has one)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - macOS, Windows
        return os.cpu_count() or 1


def _run_pool(workers: int, token: str, plan: _Plan, cases, todo, record) -> str:
    from concurrent.futures import ProcessPoolExecutor, as_completed

    workers = min(workers, len(todo))
    blob = pickle.dumps(plan)
    pool = ProcessPoolExecutor(max_workers=workers, initializer=_worker_init,
                               initargs=(token, blob))
    try:
        futures = [pool.submit(_pool_case, i, cases[i]) for i in todo]
        for fut in as_completed(futures):
            record(fut.result())
    except BaseException:
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()
    return f"{workers} local processes"


def _run_dask(scheduler, token: str, plan: _Plan, cases, todo, record) -> str:
    try:
        from distributed import Client, as_completed
    except ImportError:
        raise SweepError("a Dask scheduler needs dask.distributed: "
                         "pip install 'lamech[dask]'") from None
    own = not isinstance(scheduler, Client)
    client = Client(scheduler) if own else scheduler
    try:
        blob = client.scatter(pickle.dumps(plan), broadcast=True)
        futures = [client.submit(_dask_case, token, blob, i, cases[i], pure=False,
                                 retries=2, key=f"lamech-case-{token}-{i}")
                   for i in todo]
        try:
            for fut in as_completed(futures):
                record(fut.result())
                fut.release()
        except BaseException:
            client.cancel(futures)
            raise
        n = len(client.scheduler_info().get("workers", {}))
        return f"Dask at {client.scheduler.address} ({n} workers)"
    finally:
        if own:
            client.close()


def sweep(problem, params: Mapping[str, object], measures: Sequence[str] = ("liftoff",),
          *, output: str = "auto", **options):
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
        where = f"; the finished rows are in {run.path}, resume=True completes it" \
            if run.path else ""
        raise SweepError(f"the sweep stopped ({run.stopped}) after {len(run.rows)} of "
                         f"{math.prod(len(a) for a in run.parameters.values())} cases{where}")
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


# ----- the picture ------------------------------------------------------------------------
def plot_sweep(run: SweepRun, path: str | os.PathLike, max_panels: int = 9) -> None:
    """A line plot per measure column over one swept parameter, a heat map over two."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    swept = [n for n, a in run.parameters.items() if len(a) > 1]
    if len(swept) not in (1, 2):
        raise SweepError(f"a picture needs 1 or 2 parameters with several values (got "
                         f"{len(swept)}: {', '.join(swept) or 'none'})")
    cols = []   # the columns that vary (a constant one, e.g. r at a slip, says nothing)
    for c in run.measure_columns:
        vals = np.array([r[c] for r in run.rows], dtype=float)
        if np.any(np.isfinite(vals)) and np.nanmax(vals) != np.nanmin(vals):
            cols.append(c)
    cols = cols[:max_panels] or run.measure_columns[:1]
    k = len(cols)
    ncol = min(k, 3)
    nrow = math.ceil(k / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.6 * ncol, 3.6 * nrow), squeeze=False)
    fixed = {n: float(a[0]) for n, a in run.parameters.items() if len(a) == 1}
    for ax, c in zip(axes.flat, cols):
        if len(swept) == 1:
            x = np.array([r[swept[0]] for r in run.rows], dtype=float)
            y = np.array([r[c] for r in run.rows], dtype=float)
            order = np.argsort(x)
            ax.plot(x[order], y[order], "o-", ms=3)
            ax.set_xlabel(swept[0])
            ax.set_ylabel(c)
        else:
            a, b = swept
            xa, xb = run.parameters[a], run.parameters[b]
            Z = np.full((len(xb), len(xa)), np.nan)
            ia = {float(v): i for i, v in enumerate(xa)}
            ib = {float(v): i for i, v in enumerate(xb)}
            for r in run.rows:
                Z[ib[r[b]], ia[r[a]]] = r[c]
            mesh = ax.pcolormesh(_edges(xa), _edges(xb), np.ma.masked_invalid(Z),
                                 shading="flat")
            fig.colorbar(mesh, ax=ax)
            ax.set_xlabel(a)
            ax.set_ylabel(b)
        ax.set_title(c, fontsize=9)
    for ax in list(axes.flat)[k:]:
        ax.set_visible(False)
    title = run.path.name if run.path else "sweep"
    if fixed:
        title += "  (" + ", ".join(f"{n} = {v:g}" for n, v in fixed.items()) + ")"
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _edges(x: np.ndarray) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    if len(x) == 1:
        return np.array([x[0] - 0.5, x[0] + 0.5])
    mid = (x[1:] + x[:-1]) / 2
    return np.concatenate(([2 * x[0] - mid[0]], mid, [2 * x[-1] - mid[-1]]))
