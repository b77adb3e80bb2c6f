"""Parameter sweeps: every combination of parameter values simulated, a few numbers
measured per case, one row per case.

The system is compiled once (:func:`lamech.numeric.compile_system`) and every case only
passes a different parameter vector ``p`` to the same generated functions. This module
makes the grid, checks the input, keeps the table (:mod:`._table`) and hands the cases
to a backend: the compiled loop with events in this process (:mod:`._compiled`), local
worker processes (:mod:`._local`) or a Dask cluster (:mod:`._dask`), each worker
compiling the system once and running a case as :mod:`._case` says.

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
on lamech's engine in C (built at install; each problem's own functions compiled in a
fraction of a second), else the same loop with the problem's NumPy functions called
back; impacts are applied in it. A case whose
run meets what that loop leaves to the simulator (a failure, more than 64 events, an
impact it cannot apply: see :data:`lamech.numeric._batch.FALLBACKS`) and every case of
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
import math
import os
import re
import sys
import time
import uuid
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..expr import ExpressionError, as_quantity, is_quantity
from ..model import ModelError, System, in_si, result_units
from ..numeric._engines import engine_name
from ..numeric._options import Options
from ..numeric._params import friction_names, with_friction_parameters
from ._case import COMPILED, Plan, run_case
from ._compiled import run_compiled
from ._dask import run_dask
from ._local import cpus, run_local
from ._parse import EVENT_MEASURES, MAX_CASES, SweepError, number, parse_measure, parse_values
from ._result import SweepResult
from ._table import Table

__all__ = ["sweep", "run_sweep", "execute", "sweepable_names"]


# ----- the system prepared for sweeping ---------------------------------------------
def sweepable_names(system: System) -> list[str]:
    return [p.name for p in system.parameters] + list(friction_names(system))


def _with_friction_parameters(system: System, names: Iterable[str]) -> System:
    try:
        return with_friction_parameters(system, names)
    except ValueError as exc:
        raise SweepError(str(exc)) from None


def _grid(params: Mapping[str, object], system: System) -> tuple[dict[str, np.ndarray], _Cases]:
    """The grid's values by name, each in SI: ``"A:B:N"``, ``"a,b,c"`` or a sequence of
    numbers, where a number may be a quantity (``"10 cm:50 cm:5"``; a pint Quantity or
    an array of them) of the dimension the problem gives or infers for it."""
    if not params:
        raise SweepError("no parameters to sweep; give at least one (NAME=A:B:N)")
    units = system.units
    values: dict[str, np.ndarray] = {}
    for name, spec in params.items():
        spec = _in_si(system, name, spec)
        if isinstance(spec, str):
            arr = parse_values(spec, name, units.of(name) if units is not None else None)
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


def _in_si(system: System, name: str, spec: object) -> object:
    """``spec`` with a pint Quantity (or a sequence of them) in SI, and a text's
    quantities checked against the problem's dimensions (:func:`lamech.model.in_si`)."""
    what = f"parameter `{name}`: {{value!r}}"
    try:
        if isinstance(spec, str):
            first = next((p for p in re.split(r"[:,]", spec) if is_quantity(p)), None)
            known = system.units is not None and system.units.of(name) is not None
            if first is not None and not known:  # parse_values checks against a known one
                in_si(system, {name: first.strip()}, what)
            return spec
        if isinstance(spec, (list, tuple)) and spec and as_quantity(spec[0]) is not None:
            return [in_si(system, {name: x}, what)[name] for x in spec]
        return in_si(system, {name: spec}, what)[name]
    except (ModelError, ExpressionError) as exc:
        raise SweepError(str(exc).removeprefix(": ")) from None


def _column_units(system: System, measures: list, columns: list[str]) -> dict[str, str]:
    """The SI unit of each column whose dimension the problem gives or infers (issue 46):
    a parameter's, an event's time (s) and coordinates, a series' (N for a multiplier in
    N); empty for a problem without units."""
    units = result_units(system)
    if not units:
        return {}
    out = {c: units[c] for c in columns if c in units}  # the swept parameters
    for m in measures:
        if m.kind in EVENT_MEASURES:
            for c in columns:
                head, _, tail = c.rpartition(":")
                if head == m.text and (tail == "t" or tail in units):
                    out[c] = "s" if tail == "t" else units[tail]
        elif m.target in units:
            out[m.text] = units[m.target]
    return out


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


def _spec(problem, plan: Plan, values: dict[str, np.ndarray]) -> dict:
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
        "samples": _samples(plan.options),
        "rtol": plan.options.rtol,
        "atol": plan.options.atol,
        "max_step": plan.options.max_step if plan.options.max_step < math.inf else None,
        "method": plan.options.method,
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


def execute(
    problem,
    params: Mapping[str, object],
    measures: Sequence[str] = ("liftoff",),
    *,
    t_end: float,
    options: Options,
    initial: Mapping[str, float | str] | None = None,
    out: str | os.PathLike | None = None,
    resume: bool = False,
    workers: int | None = None,
    scheduler=None,
    progress: bool | Callable[[int, int], None] | None = None,
) -> SweepResult:
    """What :func:`sweep` does, with its ``options`` made already, returning the result
    also when the sweep did not finish: interrupted (``result.interrupted``) or stopped
    (``result.stopped``), the rows done so far in it. For the command line and the
    server, which report a partial sweep themselves; :func:`sweep` raises instead."""
    from ..numeric import SimulationError
    from ..numeric._options import check_options
    from ..problem._coerce import as_system

    system = as_system(problem, "sweep", "problem")
    if isinstance(measures, str):
        measures = [measures]  # one measure, not its letters
    if not isinstance(params, Mapping):
        raise TypeError(
            "sweep: params must be a dict {name: values} (e.g. {'mu': '0.1:0.5:5'}); "
            f"got {type(params).__name__}"
        )
    if not isinstance(options, Options):
        raise TypeError(f"sweep: options must be a lamech.Options (got {type(options).__name__})")
    _refuse_simulate_only(options)
    try:
        check_options(t_end, 0.0, options)
    except SimulationError as exc:
        raise SweepError(str(exc)) from None
    engine = engine_name(options.engine, SweepError)
    values, cases = _grid(params, system)
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
        dimension = system.units.of(name) if system.units is not None else None
        value: object = x
        if dimension is None or not isinstance(x, str):  # text of a known one: number checks
            value = _in_si(system, name, x)
        init.append((name, number(str(value), f"initial `{name}`", dimension)))
    columns = ["case", *values]
    for m in ms:
        columns += m.columns(coords)
    columns += ["status", "message"]
    plan = Plan(system, tuple(ms), float(t_end), tuple(init), tuple(columns), options)

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


def _samples(options: Options) -> int:
    """The samples of each case's run (a sweep's default 1001, as ``simulate``'s)."""
    return 1001 if options.samples is None else int(options.samples)


def _refuse_simulate_only(options: Options) -> None:
    """The options a sweep does not take (SweepError naming each)."""
    if options.dt is not None:
        raise SweepError(f"a sweep samples its runs by samples, not dt (got dt={options.dt})")
    if options.project_initial:
        raise SweepError(
            "a sweep makes each case's initial state consistent itself: project_initial "
            "is simulate's"
        )
    if options.jit is not None:
        raise SweepError(
            "a sweep chooses the compiled engine by its engine ('compiled'), not jit "
            f"(got jit={options.jit})"
        )


def _run_cases(
    table: Table,
    resume: bool,
    system: System,
    plan: Plan,
    values: dict[str, np.ndarray],
    cases: Sequence[dict],
    workers: int | None,
    scheduler,
    progress,
    engine: str = "auto",
) -> SweepResult:
    """The cases not in the table (all but its ``ok`` rows, on resume), run and recorded."""
    ms, columns, path = list(plan.measures), list(plan.columns), table.path
    found = table.read(cases, list(values)) if resume else {}
    done = {i: row for i, row in found.items() if row["status"] == "ok"}
    todo = [i for i in range(len(cases)) if i not in done]

    t0 = time.perf_counter()
    token = uuid.uuid4().hex
    from ..numeric import compile_system

    ns = COMPILED[token] = compile_system(system)  # checks the model before any worker starts
    compile_seconds = time.perf_counter() - t0
    ns.parameter_vector(cases[0])  # overrides checked once, before any worker starts
    run = SweepResult(
        values,
        ms,
        columns,
        [],
        kept=len(done),
        retried=len(found) - len(done),
        path=path,
        compile_seconds=compile_seconds,
        units=_column_units(system, ms, columns),
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
            todo, compiled = run_compiled(ns, plan, cases, todo, record, workers, engine)
        if not todo:
            run.backend = compiled
        elif scheduler is not None:
            run.backend = run_dask(scheduler, token, plan, cases, todo, record)
        elif (workers or cpus()) <= 1 or len(todo) <= 1:
            run.backend = "this process"
            for i in todo:
                record(run_case(ns, plan, i, cases[i]))
        else:
            run.backend = run_local(workers or cpus(), token, plan, cases, todo, record)
        if compiled and todo:
            run.backend = f"{compiled}; {len(todo)} by simulate on {run.backend}"
    except KeyboardInterrupt:
        run.interrupted = True
    except Exception as exc:  # a worker process died, the scheduler went away, ...
        run.stopped = f"{type(exc).__name__}: {exc}" if str(exc) else type(exc).__name__
    finally:
        if isinstance(bar, _Bar):
            bar.close()
        COMPILED.pop(token, None)
        run.rows = [results[i] for i in sorted(results)]
        if len(results) == len(cases):
            table.finish(run.rows)
        else:  # interrupted or a failure: the journal keeps what is done, for resume
            table.close()
        run.seconds = time.perf_counter() - t0
    return run


_HOW = ("resume", "workers", "scheduler", "progress")
"""``sweep``'s keyword arguments about where and how its cases run (:func:`execute`'s)."""


def sweep(
    problem,
    params: Mapping[str, object],
    measures: Sequence[str] = ("liftoff",),
    *,
    t_end: float,
    initial: Mapping[str, float | str] | None = None,
    out: str | os.PathLike | None = None,
    options: Options | None = None,
    **more: Any,
) -> SweepResult:
    r"""Simulate every combination of parameter values and measure each case: one row
    per case.

    The system is compiled once and every case passes its own parameter vector to the
    same generated functions. Where every measure is an event or ``final:`` of a
    coordinate or velocity, the cases run through the compiled loop with events in this
    process, over the cores; otherwise (and for the cases that loop leaves) by
    :func:`lamech.simulate`, on local processes or a Dask cluster. The measures and the
    engines: :doc:`/guide/sweeps`.

    Parameters
    ----------
    problem : System or str or path-like
        A :class:`~lamech.System`, a problem file, or a bundled example's name.
    params : dict of str to str or sequence of float
        Each swept name and its values: ``"A:B:N"`` (N values, both ends included),
        ``"a,b,c"``, or a sequence of numbers. A name is a parameter of the problem, or
        ``mu:<constraint>`` (``mu`` when there is one) for a friction coefficient. The
        grid is their product, the last name varying fastest. A value may be a quantity
        (``"10 cm:50 cm:5"``, a pint Quantity or a list of them, ``[10, 30] * ureg.cm``),
        converted to SI and checked against the name's dimension in the problem.
    measures : str or sequence of str, default ("liftoff",)
        ``liftoff``, ``slip``, ``stick``, ``contact``, ``impact`` (the first such event,
        each optionally ``:<constraint>``: its time and coordinates, NaN when none),
        ``max:<series>``, ``min:<series>``, ``final:<series>`` (a series is a coordinate
        ``x``, a velocity ``x'``, ``lambda:<constraint>``,
        ``force:<constraint>:<direction>``, ``energy`` or ``residual``).
    t_end : float
        End time of every simulation (each starts at t = 0).
    initial : dict of str to float, optional
        Coordinates (or velocities ``x'``) set for every case; the others move to meet
        the constraints, holding these. A value may be a quantity (``"1 deg"``).
    out : str or path-like, optional
        The table on disk: CSV, or Parquet when the name ends ``.parquet``. Rows are
        appended as cases finish; beside it ``<out>.sweep.json`` records what made it.
    options : Options, optional
        As for :func:`lamech.simulate`: samples per run (for ``max:``, ``min:``,
        ``final:``; default 1001), tolerances, the largest step, the integrator
        (``"DOP853"``; ``"Radau"`` or ``"BDF"`` for stiff systems), the engine (below).
        ``dt``, ``jit`` and ``project_initial`` are simulate's only (refused here).

    Other Parameters
    ----------------
    resume : bool, default False
        Read ``out`` back and run only its missing cases and those whose status was not
        ``ok``; refused when the table was made with other arguments or another problem.
    workers : int, optional
        Local worker processes (threads of the compiled loop); default the CPU count, 1
        runs in this process.
    scheduler : str or dask.distributed.Client, optional
        A Dask scheduler's address or a client: the cases run on that cluster
        (overrides ``workers``).
    progress : bool or callable, optional
        A bar on stderr (default: when stderr is a terminal), or a function called as
        ``progress(done, total)`` after each case.
    samples, rtol, atol, max_step, method, engine
        Each replaces that field of ``options`` (the keyword arguments of earlier
        versions, still accepted). ``engine`` is one of {"auto", "compiled", "python",
        "scipy"}, default "auto".
        ``auto`` and ``compiled``: the loop with events on lamech's engine in C where the
        measures allow it (else, or without a C compiler, the same loop with the
        problem's NumPy functions called back); ``python``: that loop with them called
        back; ``scipy``:
        every case by :func:`lamech.simulate` (``"simulate"``, its older name, is
        accepted).
    output : str, optional
        Deprecated: lamech 0.2 returned a DataFrame (``"dataframe"``), a list of dicts
        (``"records"``) or an xarray Dataset (``"xarray"``) as asked; use the result's
        :meth:`~SweepResult.to_dataframe`, :meth:`~SweepResult.records`,
        :meth:`~SweepResult.to_xarray`.

    Returns
    -------
    SweepResult
        The table, one row per case sorted by case: ``case``, the parameters, each
        measure's columns, ``status`` (``ok``, or why the case failed) and ``message``.

    Raises
    ------
    SweepError
        Bad input (names, ranges, measures, a table that does not fit), before any case
        runs; or the sweep stopped (a worker died, the cluster failed): the finished rows
        are then in ``out``, and ``resume=True`` completes it.
    KeyboardInterrupt
        Ctrl-C: the workers are ended, the finished rows kept in ``out``.

    Examples
    --------
    >>> import lamech
    >>> res = lamech.sweep("cylinder", {"mu": [0.2, 0.4]}, "slip", t_end=2.7,
    ...                    initial={"theta1": 0.01}, options=lamech.Options(samples=11))
    >>> res.column("slip:theta1").round(4)
    array([0.4669, 0.6596])
    """
    how = {k: more.pop(k) for k in _HOW if k in more}
    output = more.pop("output", None)
    try:
        options = Options.merged(options, **more)
    except TypeError as exc:
        raise TypeError(f"sweep: {exc}; or {', '.join(_HOW)}") from None
    except ValueError as exc:  # SimulationError: a bad option
        raise SweepError(str(exc)) from None
    if output is not None:
        if output not in ("auto", "dataframe", "records", "xarray"):
            raise SweepError(f"unknown output {output!r}; one of dataframe, records, xarray")
        warnings.warn(
            "sweep(output=...) is deprecated: sweep returns a SweepResult; use its "
            ".to_dataframe(), .records() or .to_xarray()",
            DeprecationWarning,
            stacklevel=2,
        )
    result = execute(
        problem, params, measures, t_end=t_end, initial=initial, out=out, options=options, **how
    )
    if result.interrupted:
        raise KeyboardInterrupt
    if result.stopped:
        where = (
            f"; the finished rows are in {result.path}, resume=True completes it"
            if result.path
            else ""
        )
        raise SweepError(
            f"the sweep stopped ({result.stopped}) after {len(result.rows)} of "
            f"{result.cases} cases{where}"
        )
    return result if output is None else _old_output(result, output)


def _old_output(result: SweepResult, output: str) -> Any:
    """What ``sweep(output=...)`` returned in lamech 0.2."""
    if output == "records":
        return result.records()
    if output == "xarray":
        return result.to_xarray()
    if output == "dataframe":
        return result.to_dataframe()
    try:  # "auto"
        return result.to_dataframe()
    except ImportError:
        return result.records()


def run_sweep(problem, params, measures=("liftoff",), **options) -> SweepResult:
    """Deprecated: use :func:`sweep`, which returns the same :class:`SweepResult` (and
    raises when the sweep is interrupted or stops, where this returns the rows done)."""
    warnings.warn(
        "lamech.run_sweep is deprecated; use lamech.sweep, which returns the same SweepResult",
        DeprecationWarning,
        stacklevel=2,
    )
    how = {k: options.pop(k) for k in (*_HOW, "t_end", "initial", "out") if k in options}
    try:
        merged = Options.merged(options.pop("options", None), **options)
    except ValueError as exc:
        raise SweepError(str(exc)) from None
    return execute(problem, params, measures, options=merged, **how)
