"""Compile once: the loop once per machine, each system's own functions once per system,
both as module files on disk compiled by numba with its on-disk cache.

The loop (DOP853, the projection, the events and the contact rules: :mod:`._kernels`) is
the same for every system: it takes the system record ``sy``
(:data:`._kernels.SYSTEM_FIELDS`), whose functions are numba cfuncs of one signature for
every system, which the loop calls as first-class functions. So the loop's module,
``engine_<key>.py`` (:func:`engine_text`), is compiled the first time numba runs on a
machine, every entry point at once (:func:`_precompile`: 2-3 minutes of CPU, once), and
loaded from the cache afterwards; a system compiles only its own functions: by the
machine's C compiler into ``lamech_c_<key>.so`` where there is one (:mod:`._cc`, 0.3 s),
else by numba as the module ``lamech_<key>.py`` (:func:`system_text`: the generated
functions and their cfunc wrappers, a few seconds), and loads them on its second run.
Measured on the 2-core machine, whole process CPU (2026-11-27, ``lamech simulate
cylinder --t-end 3``): a problem never run before simulates on the compiled loop in
1.17 s (the loop cached; ``python -c "import sympy"`` 0.39 s in the same rounds), its
second run in 1.11 s; the loop loads without numba's compiler set up
(:func:`_quick_cache_class`), one entry point a run (:func:`loaded_entry_points`).

numba caches (``cache=True``) only functions defined in a real source file, at module
level: a function created by ``exec`` has no file, and a closure's cache key includes
its cells. So both modules are written in :func:`cache_dir`, imported by file, and
compiled with ``cache=True``; numba keeps the machine code next to them (``__pycache__``,
or under ``NUMBA_CACHE_DIR`` when that is set). A key is a SHA-256 of the module's text
and of the versions of lamech, numba, NumPy and Python and the CPU, so any change to the
code or to the compiler gives a new file (numba also checks the source's hash and the CPU
itself).

Two processes may write the same file at once (a sweep's workers): a file is written
under a temporary name and renamed into place (atomic), and both write the same text.
The loop itself is compiled by one process at a time (:func:`compile_lock`): another
that needs it meanwhile waits, then loads it.
The folder is code: it is used only where the trust rule allows (:mod:`._trust`: no one
else can write it), and numba's files are checked against the sizes and hashes recorded
when they were written before numba reads them (:mod:`._integrity`): a damaged one is
removed, said, and compiled again. A shared read-only folder (an administrator's) is
loaded from: its files are checked and copied into the process's temporary folder, as
numba keeps its cache only where it can write. Where no folder can be used, the modules
run from memory (``exec``) and numba compiles them in this process only, silently.

Within one process, the same text is compiled once (:data:`_LOADED`, :data:`_ENGINE`):
compiling a system again (the same problem with other parameter values) reuses its
compiled functions.
"""

from __future__ import annotations

import contextlib
import errno
import functools
import hashlib
import importlib.util
import inspect
import os
import struct
import sys
import threading
import time
import warnings
from pathlib import Path

import numpy as np

from ..linalg import cholesky_inplace, gauss_inplace
from ._integrity import mismatch, read_record, say_rebuilt, write_durably
from ._kernels import INLINE, PROJECTION_ITERATIONS, STAGES, SYSTEM_FIELDS, kernel_text
from ._numba_files import (
    checked_machine_code,
    copy_checked,
    record_at_exit,
    record_machine_code,
    record_path,
)
from ._trust import (
    Place,
    cache_place,
    file_problem,
    process_dir,
    user_cache_dir,
)

__all__ = [
    "cache_dir",
    "engine_text",
    "system_text",
    "compiled_kernels",
    "Kernels",
    "is_cached",
    "engine_is_cached",
    "module_key",
    "quick_load",
    "compile_lock",
    "COMPILE_WAIT",
    "loaded_entry_points",
]

CACHE_ENV = "LAMECH_CACHE_DIR"
"""The environment variable that sets the cache directory (see :func:`cache_dir`)."""


def cache_dir() -> Path:
    """Where compiled systems are kept: ``$LAMECH_CACHE_DIR``, else
    ``$XDG_CACHE_HOME/lamech``, else ``~/.cache/lamech`` (the ``kernels`` folder in it),
    where the trust rule allows it (:func:`._trust.cache_place`, :func:`_place`)."""
    env = os.environ.get(CACHE_ENV)
    if env:
        return Path(env).expanduser() / "kernels"
    return user_cache_dir()


def _place(make: bool = True) -> Place:
    """The place compiled code is kept this process (:func:`._trust.cache_place` of
    :func:`cache_dir`, made where missing if ``make``): a folder lamech writes in, one
    shared read-only, or none."""
    return cache_place(cache_dir(), make)


def engine_text() -> str:
    """The module of the problem-independent kernels (compiled once per installation):
    the loops of :mod:`lamech.linalg` they call, their constants, and the kernels, the
    batch loop and the loop with events of :mod:`._kernels`, each taking the system
    record ``sy`` (:data:`._kernels.SYSTEM_FIELDS`) first."""
    return "\n".join(
        [
            '"""lamech: the compiled loop, the same for every system (generated; safe to',
            'delete)."""',
            "",
            "import math",
            "",
            "import numpy",
            "import numpy as np",
            "from numba import prange",
            "",
            "",
            inspect.getsource(gauss_inplace),
            "",
            inspect.getsource(cholesky_inplace),
            "",
            # in the text, so that the cache's key changes with the set
            f"# inlined by numba: {', '.join(sorted(INLINE))}",
            f"# the intrinsics (lamech/numeric/_fnptr.py): {_intrinsics_digest()}",
            f"STAGES = {STAGES!r}",
            f"PROJECTION_ITERATIONS = {PROJECTION_ITERATIONS!r}",
            "",
            "",
            _compiled_accessors(kernel_text()),
        ]
    )


def _intrinsics_digest() -> str:
    """A hash of :mod:`._fnptr`'s text, read as a file (importing it imports numba): the
    intrinsics the loop is compiled with (``borrowed``, the function casts) live there,
    not in the engine's text, and numba's cache watches only the engine's own file; a
    changed intrinsic must not load machine code compiled with the old one."""
    return hashlib.sha256(Path(__file__).with_name("_fnptr.py").read_bytes()).hexdigest()[:16]


_ACCESSORS = {
    "sy[6](t, q, v, p)": "as_dynamics(sy[6])(t, q, v, p)",
    "sy[7](t, q, v, p)": "as_dynamics_sparse(sy[7])(t, q, v, p)",
    "sy[8](t, q, p)": "as_constraints(sy[8])(t, q, p)",
    "sy[9](t, q, v, p)": "as_energy(sy[9])(t, q, v, p)",
    "sy[10](t, q, p)": "as_restitution(sy[10])(t, q, p)",
    "sy[11](t, q, v, p)": "as_switches(sy[11])(t, q, v, p)",
    # the C functions (:mod:`._cc`), the arrays passed by address
    "sy[6](t, q.ctypes": "as_c8(sy[6])(t, q.ctypes",
    "sy[7](t, q.ctypes": "as_c8(sy[7])(t, q.ctypes",
    "sy[8](t, q.ctypes": "as_c5(sy[8])(t, q.ctypes",
    "sy[9](t, q.ctypes": "as_c4(sy[9])(t, q.ctypes",
    "sy[10](t, q.ctypes": "as_c3(sy[10])(t, q.ctypes",
    "sy[11](t, q.ctypes": "as_c4(sy[11])(t, q.ctypes",
}


def _compiled_accessors(text: str) -> str:
    """The kernels' text with the system's functions, addresses in the compiled record,
    cast back to first-class functions (:mod:`._fnptr`)."""
    for a, b in _ACCESSORS.items():
        assert text.count(a) == 1, a
        text = text.replace(a, b)
    imports = (
        "from lamech.numeric._fnptr import (\n    as_c3,\n    as_c4,\n    as_c5,\n"
        "    as_c8,\n    as_constraints,\n    as_dynamics,\n    as_dynamics_sparse,\n"
        "    as_energy,\n    as_restitution,\n    as_switches,\n    borrowed,\n)\n\n\n"
    )
    return imports + text


# the system's functions the loop calls, as cfuncs: (name, generated function, signature)
_CFUNCS = (
    ("c_dynamics", "dynamics", "t, q, v, p"),
    ("c_dynamics_sparse", "dynamics_sparse", "t, q, v, p"),
    ("c_constraints", "constraints", "t, q, p"),
    ("c_energy", "energy", "t, q, v, p"),
    ("c_restitution", "restitution", "t, q, p"),
    ("c_switches", "switches", "t, q, v, p"),
)
_JITTED = ("dynamics", "dynamics_sparse", "constraints", "energy", "restitution", "switches")


def system_text(source: str) -> str:
    """The module of one system's compiled functions: ``source`` (the generated functions,
    :func:`._codegen.compile_system`) and, for each function the loop calls, a wrapper
    ``c_<name>`` that numba compiles as a cfunc (the loop calls it as a first-class
    function)."""
    body = source.removeprefix("import math\nimport numpy\n")
    wrappers = [f"def {c}({args}):\n    return {f}({args})" for c, f, args in _CFUNCS]
    return "\n".join(
        [
            '"""lamech: the compiled functions of one system (generated; safe to delete)."""',
            "",
            "import math",
            "",
            "import numpy",
            "",
            body.strip("\n"),
            "",
            "",
            "\n\n\n".join(wrappers),
            "",
        ]
    )


def _signatures() -> dict:
    """The cfuncs' signatures: one for every system (C-contiguous float64 arrays)."""
    from ._fnptr import SIGNATURES

    return SIGNATURES


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


def module_key(text: str, prefix: str = "lamech_") -> str:
    """The name of ``text``'s file: ``prefix`` and a hash of the text and the versions it
    is compiled with (lamech, numba, NumPy, Python, the CPU)."""
    digest = hashlib.sha256((_versions() + "\n\n" + text).encode("utf-8")).hexdigest()
    return prefix + digest[:40]


def _write(path: Path, text: str) -> None:
    """``text`` to ``path`` atomically and durably (:func:`._integrity.write_durably`,
    mode ``0o600``): a reader sees the whole file or none, and two writers of the same
    text both win."""
    write_durably(path, text.encode("utf-8"))


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
    """The module's namespace imported from its file in the cache folder (:func:`_place`;
    written first if missing), numba's files for it checked first
    (:func:`._numba_files.checked_machine_code`); from a shared read-only folder, the module and its
    files copied into this process's temporary folder (numba keeps its cache only in a
    folder it can write); None where there is no cache folder to use."""
    try:
        place = _place()
        if place.path is None:
            return None
        folder = place.path if place.writable else process_dir()
        path = folder / f"{name}.py"
        if not place.writable:
            copy_checked(place.path, folder, name)
        if not (file_problem(path) is None and path.read_text(encoding="utf-8") == text):
            _write(path, text)
        (folder / "__pycache__").mkdir(mode=0o700, exist_ok=True)
        checked_machine_code(folder, name)
        if place.writable:
            record_at_exit(folder, name)
        return _import(path, name)
    except Exception:  # unwritable, unreadable, full disk, ...: compile in memory
        return None


class Kernels:
    """A system's compiled functions: ``functions`` {name: callable} (``dynamics``,
    ``constraints``, ``kkt_solve``, ``rhs_kernel``, ``accelerations``, the batch loop
    ``batch_run`` (parallel) and ``batch_run_serial``, the loop with events ``ev_run``
    and ``ev_segment``, the batch's starts ``ev_starts``: the engine's, with the system
    record bound), the record ``sy`` itself, and where the system's machine code came
    from, ``cache``: ``"loaded"`` (numba's cache on disk, nothing compiled),
    ``"compiled"`` (compiled now and written to the cache), ``"memory"`` (no usable cache
    directory: compiled for this process only). The engine (the loop, the same for every
    system) is compiled once and kept in the cache too; its functions are loaded (or
    compiled, the first time on a machine) when first called."""

    def __init__(self, functions: dict, sy: tuple, cache: str, path: Path | None):
        self.functions = functions
        self.sy = sy
        self.cache = cache
        self.path = path
        self.namespace: dict = {}  # the system's module: it keeps the cfuncs sy points to


# both by cache folder: a process that changes $LAMECH_CACHE_DIR (the tests do) gets the
# system and the engine written and cached there too, so that the folder then holds what
# a new process (or :func:`engine_is_cached`) looks for
_LOADED: dict[tuple, Kernels] = {}  # (cache folder, module name, compiler) -> kernels
_ENGINE: dict[tuple[str, str], dict] = {}  # (cache folder, module name) -> namespace
_LOCK = threading.Lock()


def _new_lock() -> None:
    global _LOCK
    _LOCK = threading.Lock()


# a process forked while another thread compiles would inherit the lock held, forever
if hasattr(os, "register_at_fork"):  # not on Windows (no fork there)
    os.register_at_fork(after_in_child=_new_lock)


# The loop calls each system's functions as first-class functions, which numba flags as
# experimental whenever it compiles a call of one (lazily, at the loop's first call):
# that is the design here, not a problem for the user to see.
warnings.filterwarnings("ignore", message="First-class function type feature is experimental")


@functools.cache
def _quick_cache_class():
    """numba's on-disk cache of a function, loaded without numba's compiler set up; None
    where this numba lacks the pieces (then numba's own cache is kept, only slower).

    numba's ``Cache.load_overload`` first calls ``target_context.refresh()``, which
    imports and registers every typing and lowering implementation numba has: 0.2-0.3 s
    of CPU per process (measured 2026-11-27: ``lamech simulate cylinder --t-end 3``,
    the loop cached, 2.25 s of CPU for the whole process against 1.94 s without it).
    Those are needed to compile, not to link machine code compiled before. What loaded
    code needs at run time is numba's runtime (NRT: its allocator and reference counts,
    initialized here as ``refresh`` would), the helper symbols (installed when the
    target context is made) and the function's own ``reload_init`` (run by numba's
    rebuild). A miss still compiles as before: numba's compiler refreshes the context
    itself (``CompilerBase.__init__``). numba has no option for this; the override is
    this one method, on lamech's own functions only (:func:`quick_load`). The machine
    code itself is linked as numba links it, without parsing its bitcode
    (:func:`_quick_unserialize`)."""
    try:
        from numba.core.caching import FunctionCache
        from numba.core.runtime import rtsys
    except ImportError:
        return None
    needed = ("load_overload", "_load_overload", "_guard_against_spurious_io_errors")
    if not all(hasattr(FunctionCache, a) for a in needed):
        return None

    class QuickLoadCache(FunctionCache):
        def load_overload(self, sig, target_context):
            rtsys.initialize(target_context)
            codegen = target_context.codegen()
            numbas = codegen.unserialize_library

            def unserialize(serialized):
                library = _quick_unserialize(codegen, serialized)
                return numbas(serialized) if library is None else library

            # numba holds its compiler lock around a load: no other thread unserializes
            with contextlib.suppress(AttributeError):  # a codegen without a __dict__
                codegen.unserialize_library = unserialize
            try:
                with self._guard_against_spurious_io_errors():
                    return self._load_overload(sig, target_context)
            finally:
                with contextlib.suppress(AttributeError):
                    del codegen.unserialize_library

    return QuickLoadCache


def _quick_unserialize(codegen, serialized):
    """A code library from numba's cache, as numba's ``CPUCodeLibrary._unserialize``
    makes it, without parsing the bitcode numba keeps beside the machine code; None
    where this is not an ELF object (numba's own way then).

    numba parses that bitcode at every load to list the symbols the machine code defines
    (and keeps it to link the library into code compiled later): the loop's entry point
    is 1,386 symbols, parsed and walked through llvmlite in 0.09 s of CPU (measured
    2026-11-27, ``lamech sweep cylinder``: 0.06 s parsing, 0.03 s listing). The object's
    own symbol table lists the same 1,386 names in 1.5 ms (:func:`_elf_symbols`); the
    bitcode is parsed only if code compiled later links this library
    (:func:`_lazy_linking_class`)."""
    try:
        name, kind, data = serialized
        if kind != "object":
            return None
        object_code, bitcode = data
        names = _elf_symbols(object_code)
        engine = codegen._engine
        if names is None or not isinstance(getattr(engine, "_defined_symbols", None), set):
            return None
        library = codegen.create_library(name)
        lazy = _lazy_linking_class(type(library))
        if lazy is None:
            return None
    except Exception:  # another numba's internals: its own way
        return None
    library.__class__ = lazy
    library._lazy_bitcode = bitcode
    library.enable_object_caching()
    library._set_compiled_object(object_code)
    library._finalize_final_module()
    engine._defined_symbols |= names  # numba's _load_defined_symbols, from the object
    return library


@functools.cache
def _lazy_linking_class(base):
    """``base`` (numba's code library) whose module for linking is parsed from the bitcode
    when first asked for (numba's ``_get_module_for_linking``), not as it loads; None
    where ``base`` lacks what :func:`_quick_unserialize` calls."""
    needed = ("enable_object_caching", "_set_compiled_object", "_finalize_final_module")
    if not all(hasattr(base, a) for a in needed) or "_shared_module" in vars(base):
        return None
    from llvmlite import binding as ll

    class LazyLinking(base):
        @property
        def _shared_module(self):
            d = self.__dict__
            if d.get("_shared_module") is None and d.get("_lazy_bitcode") is not None:
                d["_shared_module"] = ll.parse_bitcode(d.pop("_lazy_bitcode"))
            return d.get("_shared_module")

        @_shared_module.setter
        def _shared_module(self, value):
            self.__dict__["_shared_module"] = value

    return LazyLinking


def _elf_symbols(obj: bytes) -> set[str] | None:
    """The names of the symbols a 64-bit little-endian ELF object defines (functions and
    data; not sections, files or undefined ones), or None for another format (Mach-O,
    COFF, 32-bit). Read here from the section headers and the symbol table because
    llvmlite's object file lists sections, not symbols, and a library for it (pyelftools)
    would be a dependency for these lines."""
    if len(obj) < 64 or obj[:4] != b"\x7fELF" or obj[4] != 2 or obj[5] != 1:
        return None
    try:
        (shoff,) = struct.unpack_from("<Q", obj, 0x28)
        shentsize, shnum = struct.unpack_from("<HH", obj, 0x3A)
        # each section: name, type, flags, addr, offset, size, link, info, align, entsize
        sections = [
            struct.unpack_from("<IIQQQQIIQQ", obj, shoff + i * shentsize) for i in range(shnum)
        ]
        names = set()
        for _, kind, _, _, offset, size, link, *_ in sections:
            if kind != 2:  # SHT_SYMTAB
                continue
            strings = sections[link][4]
            for k in range(size // 24):
                at, info, _, shndx, _, _ = struct.unpack_from("<IBBHQQ", obj, offset + 24 * k)
                # defined (not SHN_UNDEF), named, not a section's or a file's symbol
                if shndx == 0 or at == 0 or (info & 0xF) in (3, 4):
                    continue
                end = obj.index(b"\0", strings + at)
                names.add(obj[strings + at : end].decode("utf-8"))
        return names
    except (struct.error, ValueError, IndexError, UnicodeDecodeError):
        return None


def quick_load(dispatcher) -> None:
    """Load ``dispatcher``'s cached machine code without numba's compiler set up
    (:func:`_quick_cache_class`)."""
    cls = _quick_cache_class()
    cache = getattr(dispatcher, "_cache", None)
    if cls is not None and type(cache) is cls.__bases__[0]:
        cache.__class__ = cls  # the same state, one method different: no second set-up


def _jit_engine(namespace: dict, cache: bool) -> dict:
    """numba-compile (lazily: on their first call) every function of the engine module
    in ``namespace``, which their globals resolve in."""
    import numba

    names = [
        k
        for k, v in namespace.items()
        if inspect.isfunction(v) and v.__module__ == namespace["__name__"]
    ]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for fn in names:
            if fn == "batch_run":
                namespace[fn] = numba.njit(parallel=True, cache=cache)(namespace[fn])
            elif fn == "ev_run":  # releases the GIL: a batch's slices run in threads
                namespace[fn] = numba.njit(nogil=True, cache=cache)(namespace[fn])
            elif fn in INLINE:  # numba inlines these where they are called
                namespace[fn] = numba.njit(cache=cache, inline="always")(namespace[fn])
            else:
                namespace[fn] = numba.njit(cache=cache)(namespace[fn])
            if cache:
                quick_load(namespace[fn])
    return namespace


def _engine() -> dict:
    """The engine's namespace of compiled functions (this process's, or imported from the
    cache directory, or from memory where that cannot be written). Called under _LOCK."""
    text = engine_text()
    name = module_key(text, "engine_")
    # by folder too: a process that changes $LAMECH_CACHE_DIR (the tests do) gets the
    # engine written and cached there, so a new process reading that folder finds it
    key = (str(cache_dir()), name)
    known = _ENGINE.get(key)
    if known is not None:
        return known
    namespace = _on_disk(text, name)
    if namespace is not None:
        namespace = _jit_engine(namespace, cache=True)
    else:
        namespace = {"__builtins__": __builtins__, "__name__": name}
        exec(compile(text, f"<lamech engine {name}>", "exec"), namespace)
        namespace = _jit_engine(namespace, cache=False)
    _ENGINE[key] = namespace
    return namespace


def _jit_system(namespace: dict, cache: bool) -> None:
    """numba-compile the system module's functions in ``namespace``: the generated ones
    (lazily), and the cfuncs the loop calls (now: their signature is fixed)."""
    import numba

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for fn in _JITTED:
            namespace[fn] = numba.njit(cache=cache)(namespace[fn])
            if cache:
                quick_load(namespace[fn])
        for c, sig in _signatures().items():
            namespace[c] = numba.cfunc(sig, cache=cache)(namespace[c])


def _cache_state(cfuncs: list) -> str:
    """ "loaded" when the system's cfuncs all came from numba's cache, else "compiled"."""
    hits = sum(int(getattr(f, "cache_hits", 0)) for f in cfuncs)
    return "loaded" if hits == len(cfuncs) else "compiled"


_CHECKED_ENTRIES: set[tuple[str, str]] = set()  # (engine's file, entry point)


def _checked_entry(engine: dict, entry: str) -> None:
    """Check the machine code of the engine's entry point ``entry`` against the SHA-256
    recorded (:func:`._numba_files.record_machine_code`) just before numba loads it, once
    per process: :func:`._numba_files.checked_machine_code` checks every file's size
    before numba sees the module, but hashes only the (small) indexes; the entry point a
    run loads is 1-3 MB, hashed here in 1-3 ms. Damaged: its files removed, said, and
    numba compiles it again."""
    where = engine.get("__file__")
    if where is None or (where, entry) in _CHECKED_ENTRIES:
        return
    _CHECKED_ENTRIES.add((where, entry))
    folder, name = Path(where).parent, engine["__name__"]
    files = read_record(record_path(folder, name)) or {}
    cache = folder / "__pycache__"
    for path in sorted(cache.glob(f"{name}.{entry}-*.nbc")):
        problem = mismatch(path, files[path.name]) if path.name in files else None
        if problem is not None:
            say_rebuilt(path, problem, "compiling it again")
            for stale in cache.glob(f"{name}.{entry}-*"):
                with contextlib.suppress(OSError):
                    stale.unlink()


def _bind(engine: dict, sy: tuple, namespace: dict) -> dict:
    """The functions callers use, the system record bound to the engine's."""

    def bound(k):
        f = engine[k]
        first = [True]

        def call(*args):
            if first[0]:  # compiled or loaded now: numba's notices silenced (see above)
                _checked_entry(engine, k)
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    out = f(sy, *args)
                first[0] = False
                return out
            return f(sy, *args)

        call.__name__ = getattr(f, "__name__", "kernel")
        call.engine_function = f
        return call

    out = {k: bound(k) for k in (
        "kkt_solve", "rhs_kernel", "accelerations", "batch_run", "batch_run_serial", "ev_run",
        "ev_starts", "ev_segment",
    )}  # fmt: skip
    out["dynamics"], out["constraints"] = namespace["dynamics"], namespace["constraints"]
    return out


def _record(functions: tuple, pattern, diagonal: bool, c: bool, slots) -> tuple:
    """The system record (:data:`._kernels.SYSTEM_FIELDS`): the system's functions as
    their addresses (:mod:`._fnptr`; their module or library keeps them alive), ``c``
    where they are C functions (:mod:`._cc`), else numba cfuncs; ``slots`` where in p
    the switches' branches are held."""
    arrays = tuple(np.ascontiguousarray(a, dtype=np.int64) for a in pattern)
    held = np.ascontiguousarray(slots, dtype=np.int64)
    sy = (bool(diagonal), *arrays, *(int(f) for f in functions), bool(c), held)
    assert len(sy) == len(SYSTEM_FIELDS)
    return sy


ENTRY_POINTS = (
    "ev_segment", "ev_run", "ev_starts", "batch_run", "batch_run_serial", "rhs_kernel",
    "accelerations", "kkt_solve",
)  # fmt: skip
"""The engine's functions its callers call (:func:`_entry_arguments`)."""


def loaded_entry_points() -> list[str]:
    """The engine's entry points this process has loaded (or compiled), sorted: each is
    its own machine code to load, 0.07-0.17 s of CPU (2026-11-27)."""
    return sorted(
        {
            f
            for space in _ENGINE.values()
            for f in ENTRY_POINTS
            if getattr(space[f], "overloads", None)
        }
    )


def _entry_arguments(sy: tuple) -> dict:
    """Arguments of the types the callers pass to each of the engine's entry points
    (:mod:`._loop`, :mod:`._batch`, :mod:`._run`): values that are never run, only typed,
    so that the whole engine is compiled at once."""
    from ._tableau import _tables

    f1, f2, f3 = np.zeros(2), np.zeros((1, 2)), np.zeros((1, 1, 2))
    i1, i2, i3 = (
        np.zeros(1, dtype=np.int64),
        np.zeros((3, 1), dtype=np.int64),
        np.zeros((1, 4, 1), dtype=np.int64),
    )
    b1, b2 = np.zeros(1, dtype=np.bool_), np.zeros((2, 1), dtype=np.bool_)
    tab = _tables()
    x = 0.0
    # the records of :mod:`._kernels.codes`: the mode, an event record, the samples
    md, lg, smp = (i2, i2, f2), (i1, i1, f1, f2, f2, i2, b1), (f1, f2, f2, f2)
    return {
        "ev_segment": (f1, tab, md, f1, i1, lg, 0, smp, f1, i1, f1),
        "ev_run": (
            f2, f2, tab, (i2, i3, f3), (b2, f2), f1, i1, i2, (i2, i2, f2, f3, f3),
            (f2, f1, i1, i1, i1),
        ),
        "ev_starts": (f2, f2, f2, b1, b1, f1, f1, i2, x),
        "batch_run": (f2, f2, tab, f1, i1, f2, i1),
        "batch_run_serial": (f2, f2, tab, f1, i1, f2, i1),
        "rhs_kernel": (x, f1, f1, i1, i1, i1, f1),
        "accelerations": (x, f1, f1),
        "kkt_solve": (f2, f1, f2, f1, f1, i1, i1, i1, f1),
    }  # fmt: skip


COMPILE_WAIT = 1200.0
"""Seconds a process waits for another's compile of the loop (:func:`compile_lock`)."""


@contextlib.contextmanager
def compile_lock(name: str, wait: float | None = None, folder: Path | None = None):
    """Held while this process compiles the loop into the cache folder (``folder``,
    default :func:`cache_dir`), so that another process needing it meanwhile (a sweep's
    workers on a new machine, two terminals) waits and then loads it, instead of
    compiling it too (2.5 minutes of CPU and about 0.5 GB each). The holder writes its
    process id in the lock file; a process that waits says so on stderr, once: for which
    process, and how not to wait (:func:`_say_waiting`). The operating system releases
    the lock of a process that dies. After ``wait`` seconds (default
    :data:`COMPILE_WAIT`: a process stopped mid-compile), or where there is no ``fcntl``
    (Windows) or no lock file can be made, no lock: both compile, each writing the same
    files, as numba's cache allows."""
    path = (cache_dir() if folder is None else folder) / f"{name}.lock"
    try:
        import fcntl

        handle = os.fdopen(os.open(path, os.O_RDWR | os.O_CREAT, 0o600), "r+")
    except (ImportError, OSError):
        yield
        return
    held = False
    try:
        limit = COMPILE_WAIT if wait is None else wait
        deadline = time.monotonic() + limit
        said = False
        while True:
            try:
                fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
                held = True
                break
            except OSError as exc:
                # held by another process: wait; a file system without locks: go on
                if exc.errno not in (errno.EAGAIN, errno.EACCES, errno.EWOULDBLOCK):
                    break
                if time.monotonic() > deadline:
                    break
                if not said:
                    _say_waiting(path, handle, limit)
                    said = True
                time.sleep(0.25)
        if held:
            with contextlib.suppress(OSError):  # who holds it, for those who wait
                handle.seek(0)
                handle.truncate()
                handle.write(f"{os.getpid()}\n")
                handle.flush()
        yield
    finally:
        if held:
            fcntl.flock(handle, fcntl.LOCK_UN)
        handle.close()


def _say_waiting(lock: Path, handle, limit: float) -> None:
    """One line on stderr: this process waits for the one holding ``lock`` (its id as it
    wrote it in the file, where it did), how long at most, and how not to wait."""
    try:
        handle.seek(0)
        pid = handle.read(32).strip()
    except (OSError, ValueError):
        pid = ""
    who = f"process {pid}" if pid.isdigit() else "another process"
    print(
        f"lamech: waiting for {who} to finish compiling the loop into {lock.parent} (it "
        f"holds {lock.name}; at most {limit / 60:.0f} min), then loading it; not to wait: "
        "--engine scipy, or LAMECH_CACHE_DIR set to another folder (which compiles the "
        "loop again there)",
        file=sys.stderr,
        flush=True,
    )


def _precompile(engine: dict, sy: tuple) -> None:
    """Compile (or load) every entry point of the engine not yet in the cache on disk:
    the loop is compiled once per machine, whichever of simulate, a sweep or the batch
    loop runs first, and by one process at a time (:func:`compile_lock`); what numba
    wrote is then recorded (:func:`._numba_files.record_machine_code`). Types only: nothing runs."""
    import numba

    if "__file__" not in engine:  # compiled in memory: no cache to fill
        return
    name, folder = engine["__name__"], Path(engine["__file__"]).parent
    entries = _entry_arguments(sy)
    assert tuple(entries) == ENTRY_POINTS
    if all(_nbi(name, entry, folder) for entry in entries):
        return
    with compile_lock(name, folder=folder), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for entry, args in entries.items():
            if not _nbi(name, entry, folder):  # another process may have compiled it
                engine[entry].compile(tuple(numba.typeof(a) for a in (sy, *args)))
        record_machine_code(folder, name)


def compiled_kernels(source: str, pattern, diagonal: bool, c_source: str = "", slots=()) -> Kernels:
    """The compiled functions of the system whose generated ``source`` (and the C of its
    loop's functions, ``c_source``) is given, with its sparsity ``pattern``
    (:func:`._kkt.sparsity`), ``diagonal`` M and its switches' ``slots`` in p
    (:attr:`._codegen.NumericSystem.switch_slots`): the system's own functions from this
    process's earlier compile, from the cache on disk, or compiled now (and cached where
    the directory is writable), by the C compiler where there is one (:mod:`._cc`), else
    by numba; the engine's functions around them. Raises what numba raises when it
    cannot compile the source."""
    text = system_text(source)
    name = module_key(text)
    from ._cc import compiler

    with _LOCK:
        # by the C compiler in force too ($LAMECH_CC may change): C or numba's functions
        key = (str(cache_dir()), name, tuple(compiler() or ()) if c_source else ())
        known = _LOADED.get(key)
        if known is not None:
            return known
        engine = _engine()
        kernels = _c_kernels(engine, c_source, pattern, diagonal, slots)
        if kernels is not None:
            _LOADED[key] = kernels
            return kernels
        namespace = _on_disk(text, name)
        path = None if namespace is None else Path(namespace["__file__"])
        state = "memory"
        if namespace is not None:
            try:
                _jit_system(namespace, cache=True)
                state = _cache_state([namespace[c] for c, _, _ in _CFUNCS])
                if path is not None:
                    record_machine_code(path.parent, name)
            except Exception:  # numba could not use the cache: compile in memory
                sys.modules.pop(name, None)
                namespace = None
        if namespace is None:
            namespace = {"__builtins__": __builtins__, "__name__": name}
            exec(compile(text, f"<lamech generated {name}>", "exec"), namespace)
            _jit_system(namespace, cache=False)
            state, path = "memory", None
        addresses = tuple(namespace[c].address for c, _, _ in _CFUNCS)
        sy = _record(addresses, pattern, diagonal, False, slots)
        if path is not None:  # a cache on disk: the whole engine, once per machine
            _precompile(engine, sy)
        kernels = Kernels(_bind(engine, sy, namespace), sy, state, path)
        kernels.namespace = namespace
        _LOADED[key] = kernels
        return kernels


def _c_kernels(engine: dict, c_source: str, pattern, diagonal: bool, slots) -> Kernels | None:
    """The system's functions as C (:mod:`._cc`), the engine around them; None where
    there is no C source or compiler, or the compiler failed (numba compiles them)."""
    from . import _cc

    if not c_source or _cc.compiler() is None:
        return None
    folder = cache_dir()
    try:
        lib, addresses, state = _cc.load(c_source, folder)
    except _cc.CompileFailed:
        return None
    sy = _record(addresses, pattern, diagonal, True, slots)
    if state != "memory":  # a cache on disk: the whole engine, once per machine
        _precompile(engine, sy)
    place = _place().path
    path = _cc.library_path(c_source, place) if state != "memory" and place else None
    kernels = Kernels(_bind(engine, sy, {"dynamics": None, "constraints": None}), sy, state, path)
    kernels.namespace = {"library": lib}  # keeps it loaded
    return kernels


def _nbi(name: str, function: str, folder: Path | None = None) -> bool:
    """Whether numba's index of the module ``name``'s ``function`` is on disk, in
    ``folder``'s ``__pycache__`` (default: the cache folder's, :func:`_place`)."""
    numba_dir = os.environ.get("NUMBA_CACHE_DIR")
    if numba_dir:
        return any(Path(numba_dir).rglob(f"{name}.{function}-*.nbi"))
    if folder is None:
        folder = _place(make=False).path
        if folder is None:
            return False
    return any((folder / "__pycache__").glob(f"{name}.{function}-*.nbi"))


def engine_is_cached(function: str = "ev_segment") -> bool:
    """Whether the engine (the loop, the same for every system) is at hand for the cache
    folder in force: compiled in this process already, or ``function`` and every entry
    point in numba's cache on disk (using it then costs a load, not a compile; while
    another process is still compiling it, not yet)."""
    name = module_key(engine_text(), "engine_")
    if (str(cache_dir()), name) in _ENGINE:
        return True
    try:  # every entry point: one still being compiled by another process is not at hand
        return all(_nbi(name, f) for f in (function, *ENTRY_POINTS))
    except OSError:
        return False


def is_cached(source: str, function: str = "ev_segment", c_source: str = "") -> bool:
    """Whether numba's cache on disk holds the engine's ``function`` and the compiled
    functions of the system whose generated ``source`` (and C, ``c_source``) is given:
    running it compiled then costs loads, no compile."""
    from . import _cc

    try:
        if not engine_is_cached(function):
            return False
        if c_source and _cc.compiler() is not None:
            return _cc.is_built(c_source, cache_dir())
        return _nbi(module_key(system_text(source)), "c_dynamics")
    except OSError:
        return False
