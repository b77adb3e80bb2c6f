"""One BLAS thread while a run integrates (issue 16).

The hot path makes thousands of small dense solves and products (a KKT matrix of a few
hundred rows at most). OpenBLAS splits each one over its helper threads, which then wait
for one another: on the 2-core machine, when other work wants a core, a helper is
descheduled and every solve waits for it. With the test suite running beside it, 0.5 s
of the 40-link chain took 51 s with the default threads against 0.7 s with
``OPENBLAS_NUM_THREADS=1`` (60 links: 72 against 1.0 s); beside two busy processes, 10 s
of the 100-link chain took 271 s, and 13 s with one thread. On an idle machine the
second thread gains nothing at these sizes and doubles the CPU time. So
:func:`one_blas_thread` limits the BLAS libraries that NumPy and SciPy loaded to one
thread (threadpoolctl) for the run, entered once per run, and restores the previous
limits after it.

Runs may overlap in threads of one process (a Dask worker's threads). A BLAS whose limit
is per thread (MKL, OpenBLAS on OpenMP) is limited and restored by each run in its own
thread. One whose thread pool is process-wide (OpenBLAS on pthreads, the PyPI wheels';
BLIS) is limited by the first run to start and restored by the last to end, to the
limits found by the first: restoring per run would leave the pool at one thread when
runs end in another order than they began. threadpoolctl (3.8 on) lets only one Python
thread change OpenBLAS's process-wide limit and ignores the others silently; lamech's
changes are serialised by a lock, and each is made after releasing that control.

threadpoolctl is imported on first use (``lamech --help`` stays light) and scans the
libraries loaded then (1.5 ms; setting a limit then costs microseconds); it scans again
if SciPy's linear algebra (with its own OpenBLAS) has been loaded since. lamech does not
load SciPy's linear algebra for this: neither the compiled loop (its products are loops,
the engine's arrays.c), with or without callbacks, uses it, and importing
it cost 0.2 s of CPU per process (measured 2026-11-27). A run on SciPy's integrators
(whose stiff methods' LU use SciPy's BLAS) loads it before it enters the limit
(:func:`lamech.numeric.simulate`): a library loaded inside the block is not limited until
the next run. A BLAS loaded later by something other than NumPy and SciPy is not
limited.
"""

from __future__ import annotations

import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["one_blas_thread"]

_lock = threading.Lock()
_shared: dict = {"depth": 0, "saved": [], "controller": None, "scipy_blas": False}


@contextmanager
def one_blas_thread() -> Iterator[None]:
    """BLAS limited to one thread inside the block; the previous limits after it."""
    blas = [lc for lc in _controller().lib_controllers if lc.user_api == "blas"]
    local = [lc for lc in blas if _per_thread(lc)]
    with _lock:
        if _shared["depth"] == 0:
            _shared["saved"] = [(lc, lc.num_threads) for lc in blas if not _per_thread(lc)]
            for lc, _ in _shared["saved"]:
                _set_process_wide(lc, 1)
        _shared["depth"] += 1
    saved = [(lc, lc.num_threads) for lc in local]
    for lc in local:
        lc.set_num_threads(1)
    try:
        yield
    finally:
        for lc, n in saved:
            lc.set_num_threads(n)
        with _lock:
            _shared["depth"] -= 1
            if _shared["depth"] == 0:
                for lc, n in _shared["saved"]:
                    _set_process_wide(lc, n)
                _shared["saved"] = []


def _per_thread(lc) -> bool:
    """Whether threadpoolctl sets this library's limit for the calling thread only."""
    return lc.internal_api == "mkl" or getattr(lc, "threading_layer", None) == "openmp"


def _set_process_wide(lc, n: int) -> None:
    """Set a process-wide pool's limit from this thread, whichever thread threadpoolctl
    (3.8 on) let control OpenBLAS until now, and release that control again."""
    release = getattr(type(lc), "clear_controlling_thread", None)
    if release is not None:
        release(force=True)
    lc.set_num_threads(n)
    if release is not None:
        release(force=True)


def _controller():
    """threadpoolctl's view of the loaded libraries: made on first use, and again once
    SciPy's linear algebra has been loaded since (its OpenBLAS is another library than
    NumPy's, used by SciPy's stiff integrators)."""
    scipy_blas = "scipy.linalg" in sys.modules
    if _shared["controller"] is None or (scipy_blas and not _shared["scipy_blas"]):
        from threadpoolctl import ThreadpoolController

        _shared["controller"] = ThreadpoolController()
        _shared["scipy_blas"] = scipy_blas
    return _shared["controller"]
