"""A system's functions compiled by the machine's C compiler, for lamech's engine in C.

The engine (``lamech.numeric._cengine``, built when lamech is installed) calls each system's
functions through their addresses. They are printed by SymPy's C printer from the same
common subexpressions as the NumPy functions (:func:`._codegen._c_function`) and compiled
in a fraction of a second on a problem's first compiled run, into a shared library kept
in the cache folder (loaded by :mod:`ctypes`) and loaded on later runs.

No library does this part: SymPy's ``autowrap`` builds a Python extension per expression
through Cython or f2py (seconds, and Python's headers needed), and cffi's API mode also
builds an extension; the loop needs plain C functions of a fixed signature, which one
call of the compiler gives.

The C functions fill arrays the caller zeroed (``void c_dynamics(double t, const double
*q, const double *v, const double *p, double *M, double *rhs, ...)``, matrices
row-major); the loop calls them with its arrays' addresses.

``$LAMECH_CC``: the compiler command (default ``$CC``, else ``cc``, ``gcc`` or ``clang``,
the first found); ``0`` or ``none``: no C (the system runs on NumPy and SciPy, or the
engine with their NumPy functions called back).
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import shlex
import shutil
import subprocess
import tempfile
from pathlib import Path

from ._integrity import digest, mismatch, read_record, replace_durably, say_rebuilt, write_record
from ._trust import cache_place, file_problem, process_dir, user_cache_dir

__all__ = [
    "FLAGS", "FUNCTIONS", "CACHE_ENV", "cache_dir", "compiler", "library_path", "load",
    "CompileFailed",
]  # fmt: skip

FUNCTIONS = (
    "c_dynamics", "c_dynamics_sparse", "c_constraints", "c_energy", "c_restitution",
    "c_switches",
)  # fmt: skip
"""The functions of a system's library, in the order of the system record's fields."""

# -ffp-contract=off: no fused multiply-add where the source has a product and a sum, as
# the NumPy functions compute it; -O2 without -march=native: a cache folder shared by
# machines (a cluster's home) must not hold code another processor cannot run.
FLAGS = ("-O2", "-std=c99", "-ffp-contract=off", "-fPIC", "-shared")

_LIBRARIES: dict[str, ctypes.CDLL] = {}  # path -> the library (kept loaded)

CACHE_ENV = "LAMECH_CACHE_DIR"
"""The environment variable that sets the cache directory (see :func:`cache_dir`)."""


def cache_dir() -> Path:
    """Where compiled systems are kept: ``$LAMECH_CACHE_DIR`` (the ``kernels`` folder in
    it), else ``$XDG_CACHE_HOME/lamech``, else ``~/.cache/lamech``, where the trust rule
    allows it (:func:`._trust.cache_place`)."""
    env = os.environ.get(CACHE_ENV)
    if env:
        return Path(env).expanduser() / "kernels"
    return user_cache_dir()


class CompileFailed(RuntimeError):
    """The compiler did not make the library (its message in the text)."""


def compiler() -> list[str] | None:
    """The C compiler's command, or None where there is none (or ``$LAMECH_CC`` says
    not to use one)."""
    chosen = os.environ.get("LAMECH_CC")
    if chosen is not None and chosen.strip().lower() in ("", "0", "none", "no", "false"):
        return None
    for text in (chosen, os.environ.get("CC"), "cc", "gcc", "clang"):
        if not text:
            continue
        try:
            command = shlex.split(text)
        except ValueError:
            continue
        if command and shutil.which(command[0]):
            return command
    return None


def library_path(c_source: str, folder: Path) -> Path:
    """Where the library of ``c_source`` is kept in ``folder``: named by a hash of the
    source, the flags and the compiler's command."""
    key = "\n".join([c_source, " ".join(FLAGS), " ".join(compiler() or ())])
    digest = hashlib.sha1(key.encode()).hexdigest()
    return folder / f"lamech_c_{digest}.so"


def is_built(c_source: str, folder: Path) -> bool:
    """Whether the library of ``c_source`` is in the place ``folder`` gives
    (:func:`._trust.cache_place`), whole by its recorded size (and a compiler is in use).
    """
    if compiler() is None:
        return False
    place = cache_place(folder, make=False)
    if place.path is None:
        return False
    return _damage(library_path(c_source, place.path), hash_it=False) is None


def record_path(library: Path) -> Path:
    """The record of ``library``'s size and SHA-256 (:mod:`._integrity`), beside it."""
    return library.with_suffix(".json")


def _damage(library: Path, hash_it: bool = True) -> str | None:
    """Why ``library`` may not be loaded (None: it may): missing, not to be trusted
    (:func:`._trust.file_problem`), or not what its record says was written."""
    problem = file_problem(library)
    if problem is not None:
        return problem
    files = read_record(record_path(library))
    return mismatch(library, None if files is None else files.get(library.name), hash_it)


def _build(c_source: str, target: Path) -> None:
    """Compile ``c_source`` into the shared library ``target`` (built in a private folder
    beside it, its record written, then the library renamed into place once on the disk:
    two processes may build it at once, and a crash leaves no library cut short)."""
    command = compiler()
    if command is None:
        raise CompileFailed("no C compiler")
    with tempfile.TemporaryDirectory(dir=target.parent, prefix=".build-") as tmp:
        (Path(tmp) / "system.c").write_text(c_source, encoding="utf-8")
        try:  # names relative to the build folder: the same bytes from every build
            done = subprocess.run(
                [*command, *FLAGS, "-o", target.name, "system.c", "-lm"],
                capture_output=True,
                text=True,
                timeout=600,
                check=False,
                cwd=tmp,
            )
        except (OSError, subprocess.SubprocessError) as exc:
            raise CompileFailed(str(exc)) from exc
        out = Path(tmp) / target.name
        if done.returncode != 0 or not out.is_file():
            raise CompileFailed(done.stderr[-2000:])
        write_record(record_path(target), {target.name: digest(out)})
        replace_durably(out, target, mode=0o700)


def _whole(library: Path, writable: bool) -> bool:
    """Whether ``library`` is there to load as it is; one that is there but damaged or
    not to be trusted (:func:`_damage`) is said on stderr, once, and is a miss."""
    if not (library.exists() or library.is_symlink()):
        return False
    problem = _damage(library)
    if problem is None:
        return True
    say_rebuilt(
        library, problem, "building it again" if writable else "building it for this process"
    )
    return False


def _built_in_place(c_source: str, library: Path) -> bool:
    """Build ``library`` in the cache folder; False where the folder cannot be written
    after all (a full disk, a read-only mount): the caller builds it elsewhere."""
    try:
        _build(c_source, library)
    except OSError:
        return False
    return True


def load(c_source: str, folder: Path) -> tuple[ctypes.CDLL, tuple[int, ...], str]:
    """(the library, the addresses of :data:`FUNCTIONS`, "loaded" or "compiled" or
    "memory") of ``c_source``: from the place ``folder`` gives
    (:func:`._trust.cache_place`: ``folder`` where it may be trusted, shared read-only
    included) where it was built before, whole (:func:`_damage`); else built there now
    (a damaged one said on stderr and built again); else (no place, a read-only one
    without it, a folder that cannot be written) built in this process's temporary
    folder and loaded from there. Raises :class:`CompileFailed`."""
    place = cache_place(folder)
    path = None if place.path is None else library_path(c_source, place.path)
    if path is not None and _whole(path, place.writable):
        state = "loaded"
    elif path is not None and place.writable and _built_in_place(c_source, path):
        state = "compiled"
    else:
        path = library_path(c_source, process_dir())
        if not path.is_file():
            _build(c_source, path)
        state = "memory"
    lib = _LIBRARIES.get(str(path))
    if lib is None:
        try:
            lib = ctypes.CDLL(str(path))
        except OSError as exc:  # not a library this machine can load
            raise CompileFailed(str(exc)) from exc
        _LIBRARIES[str(path)] = lib
    addresses = tuple(ctypes.cast(getattr(lib, f), ctypes.c_void_p).value or 0 for f in FUNCTIONS)
    if not all(addresses):
        raise CompileFailed("a function is missing from the library")
    return lib, addresses, state
