"""A sweep's cases on a Dask cluster (``dask.distributed``): the plan scattered once to
every worker, each compiling the system on its first case, a bounded number of cases
submitted ahead of the cluster."""

from __future__ import annotations

import itertools
import pickle

from ._case import Plan, numeric_system, run_case
from ._local import IN_FLIGHT
from ._parse import SweepError

__all__ = ["run_dask"]


def _dask_case(token: str, blob: bytes, case: int, values: dict) -> dict:
    plan = pickle.loads(blob)
    return run_case(numeric_system(token, plan), plan, case, values)


def run_dask(scheduler, token: str, plan: Plan, cases, todo, record) -> str:
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
        where = getattr(client.scheduler, "address", "a cluster")  # None once closed
        return f"Dask at {where} ({n} workers)"
    finally:
        if own:
            client.close()
