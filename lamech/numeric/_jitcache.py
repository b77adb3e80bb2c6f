"""Compile once: each system's kernels as a module file on disk, compiled by numba with
its own on-disk cache, so that a second run of the same problem loads the machine code
instead of compiling it again (3-9 s per system before).

numba caches (``cache=True``) only functions defined in a real source file, at module
level: a function created by ``exec`` has no file, and a closure's cache key includes
its cells, where another compiled function pickles differently in every process. So
the generated source of a system (:mod:`._codegen`), its sparsity pattern as module
constants and the kernels of :mod:`._kernels` are written as one module,
``lamech_<key>.py``, in :func:`cache_dir`, imported by file, and compiled with
``cache=True``; numba keeps the machine code next to it (``__pycache__``, or under
``NUMBA_CACHE_DIR`` when that is set). The key is a SHA-256 of the module's text and of
the versions of lamech, numba, NumPy and Python and the CPU, so any change to the
generated code or to the compiler gives a new file (numba also checks the source's hash
and the CPU itself).

Two processes may write the same file at once (a sweep's workers): a file is written
under a temporary name and renamed into place (atomic), and both write the same text.
Where the directory cannot be created or written, the module runs from memory (``exec``)
and numba compiles it in this process only, silently: as before the cache existed.

Within one process, the same text is compiled once (:data:`_LOADED`): compiling a system
again (the same problem with other parameter values) reuses its compiled functions.
"""

from __future__ import annotations

import hashlib
import importlib.util
import inspect
import os
import sys
import tempfile
import threading
import warnings
from pathlib import Path

import numpy as np

from ..linalg import cholesky_inplace, gauss_inplace
from ._kernels import (
    BATCH_NAMES,
    EVENT_NAMES,
    KERNEL_NAMES,
    PROJECTION_ITERATIONS,
    STAGES,
    kernel_text,
)

__all__ = ["cache_dir", "module_text", "compiled_kernels", "Kernels", "is_cached"]

CACHE_ENV = "LAMECH_CACHE_DIR"
"""The environment variable that sets the cache directory (see :func:`cache_dir`)."""


def cache_dir() -> Path:
    """Where compiled systems are kept: ``$LAMECH_CACHE_DIR``, else
    ``$XDG_CACHE_HOME/lamech``, else ``~/.cache/lamech`` (the ``kernels`` folder in it)."""
    env = os.environ.get(CACHE_ENV)
    if env:
        return Path(env).expanduser() / "kernels"
    xdg = os.environ.get("XDG_CACHE_HOME")
    base = Path(xdg).expanduser() if xdg and os.path.isabs(xdg) else Path.home() / ".cache"
    return base / "lamech" / "kernels"


def _array(name: str, a: np.ndarray) -> str:
    return f"{name} = numpy.array({[int(x) for x in a]!r}, dtype=numpy.int64)"


def module_text(source: str, pattern, diagonal: bool) -> str:
    """The module of one system's compiled kernels: ``source`` (the generated functions,
    :func:`._codegen.compile_system`), the loops of :mod:`lamech.linalg` it calls, the
    sparsity ``pattern`` (:func:`._kkt.sparsity`) and ``diagonal`` as constants, and the
    kernels and the batch loop of :mod:`._kernels`."""
    body = source.removeprefix("import math\nimport numpy\n")
    ptr, idx, cptr, crow, cpos = pattern
    return "\n".join(
        [
            '"""lamech: the compiled kernels of one system (generated; safe to delete)."""',
            "",
            "import math",
            "",
            "import numpy",
            "import numpy as np",
            "from numba import prange",
            "",
            body.strip("\n"),
            "",
            "",
            inspect.getsource(gauss_inplace),
            "",
            inspect.getsource(cholesky_inplace),
            "",
            _array("PTR", ptr),
            _array("IDX", idx),
            _array("CPTR", cptr),
            _array("CROW", crow),
            _array("CPOS", cpos),
            f"DIAGONAL = {bool(diagonal)!r}",
            f"STAGES = {STAGES!r}",
            f"PROJECTION_ITERATIONS = {PROJECTION_ITERATIONS!r}",
            "",
            "",
            kernel_text("KERNELS"),
            kernel_text("BATCH"),
        ]
    )


def _versions() -> str:
    import platform

    from .._version import __version__

    numba_version = _numba_version()

    try:
        from llvmlite import binding

        cpu = f"{binding.get_host_cpu_name()} {binding.get_host_cpu_features().flatten()}"
    except Exception:  # pragma: no cover - llvmlite always comes with numba
        cpu = platform.processor()
    return "\n".join(
        [
            f"lamech {__version__}",
            f"numba {numba_version}",
            f"numpy {np.__version__}",
            f"python {sys.version}",
            f"machine {platform.machine()} {cpu}",
        ]
    )


def _numba_version() -> str:
    """numba's version from its installed metadata (importing numba to ask costs 0.3 s: a
    sweep asks whether its loop is cached before it decides to use numba)."""
    try:
        from importlib.metadata import version

        return version("numba")
    except Exception:  # pragma: no cover - numba without metadata
        import numba

        return str(numba.__version__)


def module_key(text: str) -> str:
    """The name of ``text``'s file: a hash of the text and the versions it is compiled
    with (lamech, numba, NumPy, Python, the CPU)."""
    digest = hashlib.sha256((_versions() + "\n\n" + text).encode("utf-8")).hexdigest()
    return "lamech_" + digest[:40]


def _write(path: Path, text: str) -> None:
    """``text`` to ``path`` atomically (a temporary file in the same folder, renamed):
    a reader sees the whole file or none, and two writers of the same text both win."""
    path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)  # the user's own: it is run
    fd, tmp = tempfile.mkstemp(prefix=path.stem + ".", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise


def _import(path: Path, name: str) -> dict:
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise ImportError(f"cannot import {path}")
    module = importlib.util.module_from_spec(spec)
    # numba finds a cached function's module by name when it loads it
    sys.modules[name] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        sys.modules.pop(name, None)
        raise
    return module.__dict__


def _on_disk(text: str, name: str) -> dict | None:
    """The module's namespace imported from its file in :func:`cache_dir` (written first
    if missing), or None where the cache cannot be used."""
    try:
        path = cache_dir() / f"{name}.py"
        if not (path.is_file() and path.read_text(encoding="utf-8") == text):
            _write(path, text)
        if not os.access(path.parent, os.W_OK):  # numba's cache would go elsewhere
            return None
        return _import(path, name)
    except Exception:  # unwritable, unreadable, full disk, ...: compile in memory
        return None


class Kernels:
    """A system's compiled functions: ``functions`` {name: dispatcher} (``dynamics``,
    ``constraints``, ``kkt_solve``, ``rhs_kernel``, ``accelerations``, and the batch
    loop ``batch_run`` (parallel) and ``batch_run_serial``, the loop with events ``ev_run``
    and the batch's starts ``ev_starts``) and where the hot path's
    machine code came from, ``cache``: ``"loaded"`` (numba's cache on disk, nothing
    compiled), ``"compiled"`` (compiled now and written to the cache), ``"memory"``
    (no usable cache directory: compiled for this process only), ``"lazy"`` (from the
    cache directory, not warmed up: each function loaded or compiled when first called)."""

    def __init__(self, functions: dict, cache: str, path: Path | None):
        self.functions = functions
        self.cache = cache
        self.path = path


_LOADED: dict[str, Kernels] = {}
_LOCK = threading.Lock()


def _new_lock() -> None:
    global _LOCK
    _LOCK = threading.Lock()


# a process forked while another thread compiles would inherit the lock held, forever
if hasattr(os, "register_at_fork"):  # not on Windows (no fork there)
    os.register_at_fork(after_in_child=_new_lock)

_COMPILED = (
    "dynamics",
    "constraints",
    "energy",
    "restitution",
    "gauss_inplace",
    "cholesky_inplace",
    *KERNEL_NAMES,
    *BATCH_NAMES,
    "batch_run_serial",
    *EVENT_NAMES,
)
_CALLED = (
    "dynamics",
    "constraints",
    "kkt_solve",
    *KERNEL_NAMES,
    "batch_run",
    "batch_run_serial",
    "ev_run",
    "ev_starts",
    "ev_segment",
)


def _jit(namespace: dict, cache: bool) -> dict:
    """numba-compile the module's functions (lazily: on their first call) in
    ``namespace``, which their globals resolve in."""
    import numba

    with warnings.catch_warnings():
        # a function numba cannot cache is compiled anyway (NumbaWarning): not an error
        warnings.simplefilter("ignore")
        for fn in _COMPILED:
            namespace[fn] = numba.njit(cache=cache)(namespace[fn])
        namespace["batch_run"] = numba.njit(parallel=True, cache=cache)(namespace["batch_run"])
        # the loop with events releases the GIL: a batch's slices run in threads
        namespace["ev_run"] = numba.njit(nogil=True, cache=cache)(namespace["ev_run"])
    namespace["kkt_solve"] = namespace["kkt_schur" if namespace["DIAGONAL"] else "kkt_dense"]
    return {k: namespace[k] for k in _CALLED}


def _warm_up(functions: dict, n: int, p: np.ndarray) -> None:
    """Call the functions once with the hot path's argument types: each is compiled (or
    loaded) now, so a numba failure shows here, not mid-run."""
    q0 = np.zeros(n)
    none = np.zeros(0, dtype=np.int64)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        functions["dynamics"](0.0, q0, q0, p)
        functions["constraints"](0.0, q0, p)
        functions["rhs_kernel"](0.0, np.zeros(2 * n), p, none, none, none, np.zeros(0))
        functions["accelerations"](0.0, np.zeros(2 * n), p)


def _cache_state(functions: dict) -> str:
    """ "loaded" when the warmed-up functions all came from numba's cache, else
    "compiled"."""
    hits = misses = 0
    for f in functions.values():
        stats = getattr(f, "stats", None)
        if stats is not None:
            hits += sum(stats.cache_hits.values())
            misses += sum(stats.cache_misses.values())
    return "loaded" if hits and not misses else "compiled"


def compiled_kernels(text: str, n: int, p: np.ndarray, warm: bool = True) -> Kernels:
    """The compiled functions of the module ``text`` (:func:`module_text`) for a system of
    ``n`` coordinates with parameters like ``p``: from this process's earlier compile,
    from the cache on disk, or compiled now (and cached where the directory is
    writable). Raises what numba raises when it cannot compile the source.

    ``warm=False`` (the sweeps' loop with events) skips the warm-up: each function is
    loaded or compiled on its first call, and the loop's machine code, which holds the
    kernels it calls, is loaded without loading them too (0.4 s less on the 2-core
    machine); ``cache`` is ``"lazy"`` until a later call with ``warm`` warms it up."""
    name = module_key(text)
    with _LOCK:
        known = _LOADED.get(name)
        if known is not None:
            if warm and known.cache == "lazy":
                _warm_up(known.functions, n, p)
                known.cache = _cache_state(known.functions)
            return known
        namespace = _on_disk(text, name)
        path = None if namespace is None else Path(namespace["__file__"])
        functions = None
        if namespace is not None:
            try:
                functions = _jit(namespace, cache=True)
                state = "lazy"
                if warm:
                    _warm_up(functions, n, p)
                    state = _cache_state(functions)
            except Exception:  # numba could not use the cache: compile in memory
                sys.modules.pop(name, None)
                functions = None
        if functions is None:
            namespace = {"__builtins__": __builtins__}
            exec(compile(text, f"<lamech generated {name}>", "exec"), namespace)
            functions = _jit(namespace, cache=False)
            _warm_up(functions, n, p)
            state, path = "memory", None
        kernels = Kernels(functions, state, path)
        _LOADED[name] = kernels
        return kernels


def is_cached(text: str, function: str) -> bool:
    """Whether numba's cache on disk holds machine code of ``function`` of the module
    ``text`` (:func:`module_text`), so that using it costs a load, not a compile."""
    name = module_key(text)
    try:
        numba_dir = os.environ.get("NUMBA_CACHE_DIR")
        if numba_dir:
            return any(Path(numba_dir).rglob(f"{name}.{function}-*.nbi"))
        return any((cache_dir() / "__pycache__").glob(f"{name}.{function}-*.nbi"))
    except OSError:
        return False
