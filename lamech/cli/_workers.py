"""The work behind ``lamech serve``: each piece (check, solve, simulate, sweep) runs in a
child process from a fork server, bounded in time, in a :class:`Lane` of a few slots
and a bounded queue (full: :class:`Busy`, the server's 503), and ended, its process
killed, when its client goes away or the server stops.

SymPy cannot be interrupted inside a server thread, but a process can be killed: a
hostile expression costs one process, never the server.
"""

from __future__ import annotations

import asyncio
import errno
import math
import multiprocessing as mp
import os
import time
from collections import deque
from typing import Any

__all__ = ["Busy", "Lane", "Runner", "errors", "limit_memory", "start_in_si"]


class Busy(Exception):
    """A lane's slots are taken and its queue is full (the server's 503)."""


def errors(exc: BaseException) -> list[dict]:
    """An exception as the page shows it: its issues with their lines, or one message."""
    problems = getattr(exc, "problems", None)
    if problems:
        return [
            {"line": p.line, "where": p.where, "message": p.message, "text": p.text}
            for p in problems
        ]
    return [{"line": None, "where": "", "message": str(exc), "text": None}]


def _failed(message: str) -> dict:
    return {"ok": False, "errors": errors(RuntimeError(message))}


# ----- the work, in a child process ----------------------------------------------------
def _number(x: Any) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


def _events(traj, angles: set[str]) -> list[dict]:
    """The simulated event log as JSON: time, kind, constraint, and the coordinates (an
    angle also in degrees)."""
    out = []
    for e in traj.events:
        coords = {k: _number(v) for k, v in e.coordinates.items() if not k.endswith("'")}
        out.append(
            {
                "t": _number(e.t),
                "kind": str(e.kind),
                "constraint": e.constraint,
                "coordinates": coords,
                "degrees": {
                    k: None if v is None else math.degrees(v)
                    for k, v in coords.items()
                    if k in angles
                },
            }
        )
    return out


def start_in_si(system, initial: dict) -> dict:
    """The page's partial initial state with each text read as ``--initial`` reads its
    VALUE (:func:`lamech.cli._args.evaluate_assignments`): a quantity (``"10 deg"``,
    ``"2 deg/s"``) in SI, of the dimension the problem gives the coordinate, or an
    expression of the parameters; a ValueError names the entry."""
    from ._args import evaluate_assignments

    texts = [(k, v) for k, v in initial.items() if isinstance(v, str)]
    return {**initial, **evaluate_assignments(texts, system, "initial")} if texts else initial


def _refused(exc: BaseException) -> dict:
    """The answer to a start the problem cannot take (a wrong dimension, an unknown
    unit): the server's 400."""
    return {"ok": False, "errors": errors(exc), "refused": 400}


def _work(kind: str, text: str, options: dict) -> dict:
    """Check, or solve (and simulate) the problem ``text``: a JSON-able answer. With
    ``options["initial"]`` ({coordinate or ``x'``: value}) the simulation starts there,
    the coordinates not named moved onto the constraints (the library's completion of a
    partial initial state, :func:`lamech.simulate`'s ``initial``)."""
    import matplotlib

    matplotlib.use("Agg")
    from ..model import ModelError, result_units
    from ..numeric import SimulationError, simulate
    from ..present import report_page
    from ..problem import ProblemFileError, loads
    from ..symbolic import DegenerateConstraintsError, solve, steps
    from ..symbolic._conditions import is_angle

    try:
        system = loads(text, name="problem.toml")  # text: no folder, so it names no files
        if kind == "check":
            return {"ok": True, "title": system.title}
        if options.get("events_only"):
            return _simulated(system, options)
    except (ProblemFileError, ModelError, ValueError) as exc:
        return {"ok": False, "errors": errors(exc)}
    try:
        initial = start_in_si(system, options.get("initial") or {}) or None
    except ValueError as exc:
        return _refused(exc)
    try:
        sol = solve(system)
        derivation = steps(sol)
    except (ProblemFileError, DegenerateConstraintsError, ModelError, ValueError) as exc:
        return {"ok": False, "errors": errors(exc)}
    traj, note = None, ""
    if options.get("simulate"):
        try:
            traj = simulate(system, float(options["t_end"]), initial=initial)
        except (SimulationError, ValueError, KeyError) as exc:
            if initial:  # the user's start: say it as an error at the start field
                return {"ok": False, "errors": errors(ValueError(f"initial state: {exc}"))}
            note = f"no simulation: {exc}"
    lift = [
        {
            "constraint": k,
            "coordinate": r[0].coordinate,
            "value": r[0].value,
            "degrees": r[0].degrees,
        }
        for k, r in sol.vanishes.items()
        if r
    ]
    answer: dict[str, Any] = {
        "ok": True,
        "title": system.title,
        "page": report_page(sol, derivation, text, traj, None, note, options.get("nonce")),
        "lets_go": lift,
        "status": None if traj is None else str(traj.status),
        "note": note,
    }
    if traj is not None:
        angles = {c.name for c in system.coordinates if is_angle(system, c.symbol)}
        answer["message"] = traj.message
        answer["events"] = _events(traj, angles)
        answer["start"] = {
            **{n: _number(v) for n, v in zip(traj.coordinates, traj.q[0])},
            **{n + "'": _number(v) for n, v in zip(traj.coordinates, traj.qd[0])},
        }
    units = result_units(system)
    if units:  # issue 46: the unit of each value the page shows
        answer["units"] = units
    return answer


def _simulated(system, options: dict) -> dict:
    """A page's slider moved: the simulation alone, at ``options["params"]`` (parameter
    values, ``mu`` or ``mu:<constraint>`` for a friction coefficient, as ``--param``),
    its events and status, without solving again or making a page."""
    from ..model import ModelError, result_units, with_values
    from ..numeric import SimulationError, simulate
    from ..symbolic._conditions import is_angle

    params = options.get("params") or {}
    try:
        system = with_values(system, parameters=params) if params else system
    except (ModelError, ValueError) as exc:
        return {"ok": False, "errors": errors(exc)}
    try:
        initial = start_in_si(system, options.get("initial") or {}) or None
    except ValueError as exc:
        return _refused(exc)
    try:
        traj = simulate(system, float(options["t_end"]), initial=initial)
    except (SimulationError, ModelError, ValueError, KeyError) as exc:
        return {"ok": False, "errors": errors(exc)}
    angles = {c.name for c in system.coordinates if is_angle(system, c.symbol)}
    units = result_units(system)
    return {
        "ok": True,
        "title": system.title,
        "params": params,
        **({"units": units} if units else {}),
        "status": str(traj.status),
        "message": traj.message,
        "events": _events(traj, angles),
        "start": {
            **{n: _number(v) for n, v in zip(traj.coordinates, traj.q[0])},
            **{n + "'": _number(v) for n, v in zip(traj.coordinates, traj.qd[0])},
        },
    }


def _sweep(conn, text: str, options: dict) -> dict:
    """Run a sweep in this (child) process, sending ("progress", done, total) as cases
    finish: the table and the plot as HTML."""
    import matplotlib

    matplotlib.use("Agg")
    from ..numeric import Options
    from ..present._notebook import sweep_html
    from ..problem import ProblemFileError, loads
    from ..sweeps import SweepError
    from ..sweeps._run import execute

    try:
        system = loads(text, name="problem.toml")
        run = execute(
            system,
            options["params"],
            options["measures"],
            t_end=options["t_end"],
            options=Options(samples=201),
            workers=1,  # this process is the worker: a daemon process has no children
            progress=lambda done, total: conn.send(("progress", done, total)),
        )
    except (ProblemFileError, SweepError, ValueError) as exc:
        return {"ok": False, "errors": errors(exc)}
    return {"ok": True, "html": sweep_html(run), "counts": run.counts}


def _niceness() -> int:
    """How much slow work yields: 10, or ``LAMECH_SERVE_NICE`` (0-19). The browser tests
    set 0: beside a test run's full-priority compiles, niced work starved for minutes."""
    try:
        return min(19, max(0, int(os.environ.get("LAMECH_SERVE_NICE", "10"))))
    except ValueError:
        return 10


def limit_memory(gb: float | None) -> None:
    """Bound this process's address space to ``gb`` GB (``RLIMIT_AS``; inherited by the
    processes it starts, a C compiler's included): past it an allocation fails, as a
    :class:`MemoryError` in Python, instead of the machine swapping. None, or a
    platform without ``resource``, leaves it unbounded."""
    if gb is None:
        return
    try:
        import resource
    except ImportError:  # pragma: no cover - not POSIX
        return
    limit = int(gb * 1e9)
    _, hard = resource.getrlimit(resource.RLIMIT_AS)
    if hard != resource.RLIM_INFINITY:
        limit = min(limit, hard)
    resource.setrlimit(resource.RLIMIT_AS, (limit, hard))


def _short_of_memory(exc: BaseException) -> bool:
    """Whether ``exc`` is what an allocation past the limit raises: a MemoryError, or a
    library that could not be mapped (an ImportError "failed to map segment", ENOMEM)."""
    if isinstance(exc, MemoryError):
        return True
    if isinstance(exc, OSError) and exc.errno == errno.ENOMEM:
        return True
    return isinstance(exc, ImportError) and "failed to map segment" in str(exc)


def _out_of_memory(gb: float | None) -> str:
    return (
        f"out of memory: the work needed more than {gb:g} GB of address space (the "
        "server's --memory); the problem is too large for the page: try `lamech solve` "
        "in a terminal, or a larger --memory"
    )


def _child(conn, kind: str, text: str, options: dict, memory_gb: float | None = None) -> None:
    limit_memory(memory_gb)
    if kind != "check":
        try:  # slow work yields the processor to the checks one types
            os.nice(_niceness())
        except (AttributeError, OSError):  # pragma: no cover - no nice here
            pass
    try:
        if kind == "sweep":
            conn.send(("done", _sweep(conn, text, options)))
            return
        conn.send(("done", _work(kind, text, options)))
    except BaseException as exc:  # noqa: BLE001 - whatever it is, say it, not a hang
        if memory_gb is not None and _short_of_memory(exc):
            conn.send(("done", _failed(_out_of_memory(memory_gb))))
        else:
            conn.send(("done", _failed(f"internal error: {type(exc).__name__}: {exc}")))
    finally:
        conn.close()


# ----- slots, queue, processes -----------------------------------------------------------
class Lane:
    """At most ``slots`` pieces of work at once and ``queue`` waiting in order; one more
    is :class:`Busy`. A waiter that is cancelled (its client gone) leaves the queue."""

    def __init__(self, slots: int, queue: int):
        self.slots, self.queue = slots, queue
        self.running = 0
        self.waiting: deque[asyncio.Future] = deque()

    def full(self) -> bool:
        return self.running >= self.slots and len(self.waiting) >= self.queue

    async def acquire(self) -> None:
        if self.running < self.slots and not self.waiting:
            self.running += 1
            return
        if len(self.waiting) >= self.queue:
            raise Busy
        fut = asyncio.get_running_loop().create_future()
        self.waiting.append(fut)
        try:
            await fut  # release() hands its slot over
        except asyncio.CancelledError:
            if fut.done() and not fut.cancelled():
                self.release()  # handed over, but no longer wanted
            elif fut in self.waiting:
                self.waiting.remove(fut)
            raise

    def release(self) -> None:
        while self.waiting:
            fut = self.waiting.popleft()
            if not fut.done():
                fut.set_result(None)
                return
        self.running -= 1


async def _first(aw, gone: asyncio.Event, timeout: float | None) -> str:
    """Wait for ``aw``, ``gone`` or ``timeout``: "done", "gone" or "timeout"."""
    task = asyncio.ensure_future(aw)
    watch = asyncio.ensure_future(gone.wait())
    done, _ = await asyncio.wait(
        {task, watch},
        timeout=None if timeout is None else max(timeout, 0.0),
        return_when=asyncio.FIRST_COMPLETED,
    )
    for t in (task, watch):
        if t not in done:
            t.cancel()
    if task in done:
        task.result()
        return "done"
    return "gone" if watch in done else "timeout"


class Runner:
    """Runs the work in child processes (a fork server with lamech loaded): ``work`` for
    solves, simulations and sweeps, ``checks`` for the checks as one types (their own
    slots, so a check is answered while slow work runs). Every live process is known,
    so :meth:`stop` ends them all at once. Each child's address space is bounded to
    ``memory_gb`` GB (:func:`limit_memory`; None: unbounded)."""

    def __init__(self, work: Lane, checks: Lane, memory_gb: float | None = None):
        self.work, self.checks = work, checks
        self.memory_gb = memory_gb  # each child's address space (limit_memory)
        self.live: set = set()
        self.stopping = False
        self.ctx: Any
        try:
            self.ctx = mp.get_context("forkserver")
            self.ctx.set_forkserver_preload(["lamech.cli._workers", "lamech.symbolic"])
        except ValueError:  # pragma: no cover - no fork server on this platform
            self.ctx = mp.get_context("spawn")

    def stop(self) -> None:
        """End every child process now (the server is stopping)."""
        self.stopping = True
        for proc in list(self.live):
            try:
                proc.kill()
            except (OSError, ValueError, AttributeError):  # pragma: no cover - ended
                pass

    async def run(
        self,
        lane: Lane,
        kind: str,
        text: str,
        options: dict,
        gone: asyncio.Event,
        bound: float,
        job: dict | None = None,
    ) -> dict:
        """The answer of ``kind`` on ``text``; :class:`Busy` when ``lane`` is full.
        Waits in the lane's queue, then runs in a child process killed past ``bound``
        seconds, or as soon as ``gone`` is set (the client went away). ``job``, if given,
        is updated with a sweep's progress."""
        if self.stopping:
            raise Busy
        started = time.perf_counter()
        if await _first(lane.acquire(), gone, None) != "done":
            return cancelled_answer()
        if gone.is_set():  # the slot came with the cancel: start nothing
            lane.release()
            return cancelled_answer()
        try:
            if job is not None:
                job["queued"] = False
            answer = await self._child(kind, text, options, gone, bound, job)
        finally:
            lane.release()
        answer["seconds"] = round(time.perf_counter() - started, 3)
        return answer

    async def _child(self, kind, text, options, gone, bound, job) -> dict:
        loop = asyncio.get_running_loop()
        here, there = self.ctx.Pipe(duplex=False)
        proc = self.ctx.Process(
            target=_child, args=(there, kind, text, options, self.memory_gb), daemon=True
        )
        await asyncio.to_thread(proc.start)
        there.close()
        self.live.add(proc)
        if self.stopping or gone.is_set():
            proc.kill()
        deadline = loop.time() + bound
        ready = asyncio.Event()
        loop.add_reader(here.fileno(), ready.set)
        try:
            while True:
                ready.clear()
                if not here.poll():
                    why = await _first(ready.wait(), gone, deadline - loop.time())
                    if why == "gone":
                        return cancelled_answer()
                    if why == "timeout":
                        return _failed(_too_long(kind, bound))
                try:
                    msg = await asyncio.to_thread(here.recv)
                except (EOFError, OSError):
                    if gone.is_set():
                        return cancelled_answer()
                    if self.stopping:
                        return _failed("stopped: the server is shutting down")
                    return _failed("the worker ended without an answer")
                if msg[0] == "progress":
                    if job is not None:
                        job["done"], job["total"] = msg[1], msg[2]
                    continue
                return msg[1]
        finally:
            loop.remove_reader(here.fileno())
            if proc.is_alive():
                proc.kill()
            await asyncio.to_thread(proc.join, 5)
            here.close()
            self.live.discard(proc)


def cancelled_answer() -> dict:
    """The answer of work cancelled (its client or page gone)."""
    return {**_failed("cancelled: the client went away"), "cancelled": True}


def _too_long(kind: str, bound: float) -> str:
    if kind == "sweep":
        return (
            f"the sweep was stopped after {bound:g} s (ten times the server's --timeout); "
            "run it with `lamech sweep` in a terminal, which has no bound and can resume"
        )
    return (
        f"stopped after {bound:g} s (the server's --timeout): the problem is too large "
        "or an expression too hard to simplify; try `lamech solve` in a terminal"
    )
