"""A sweep's cases on local worker processes (:class:`concurrent.futures.ProcessPoolExecutor`):
each worker compiles the system once from the plan and runs its cases by
:func:`lamech.numeric.simulate`; a few cases per worker are in flight at a time, and the
workers end with the sweep (Ctrl-C, SIGTERM, a killed parent)."""

from __future__ import annotations

import itertools
import os
import pickle
import time

from ._case import Plan, numeric_system, run_case

__all__ = ["run_local", "cpus", "IN_FLIGHT"]

PARENT_POLL = 0.2
"""Seconds between a worker's checks that its parent is alive."""
IN_FLIGHT = 4
"""Cases submitted ahead per worker: a sweep of a million cases holds a few futures at a
time, not a million (2.5 GB in the parent before)."""

_WORKER_PLAN: tuple[str, Plan] | None = None
"""In a worker process: the sweep's token and plan, set once by :func:`_worker_init`."""


def _worker_init(token: str, blob: bytes, sweep: int) -> None:
    global _WORKER_PLAN
    _die_with_sweep(sweep)
    plan = pickle.loads(blob)
    _WORKER_PLAN = (token, plan)
    numeric_system(token, plan)


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


def _pool_case(case: int, values: dict) -> dict:
    token, plan = _WORKER_PLAN  # type: ignore[misc]
    return run_case(numeric_system(token, plan), plan, case, values)


def cpus() -> int:
    """The CPUs this process may use (its affinity mask where the OS has one)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - macOS, Windows
        return os.cpu_count() or 1


def run_local(workers: int, token: str, plan: Plan, cases, todo, record) -> str:
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
