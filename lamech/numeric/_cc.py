"""A system's functions compiled by the machine's C compiler, for the compiled loop.

The loop (:mod:`._kernels`, compiled by numba once per machine) calls each system's
functions through their addresses (:mod:`._fnptr`). numba compiling a system's five
functions costs 3-4.5 s of CPU, mostly its type inference, even for the lecture's
cylinder; the C compiler compiles the same functions, printed by SymPy's C printer from
the same common subexpressions (:func:`._codegen._c_function`), in a fraction of a
second. So where a C compiler is found, a system's functions are C, in a shared library
kept in the cache folder beside numba's files (loaded by :mod:`ctypes`), and numba
compiles only the loop, once; elsewhere numba compiles them as before.

No library does this part: SymPy's ``autowrap`` builds a Python extension per expression
through Cython or f2py (seconds, and Python's headers needed), and cffi's API mode also
builds an extension; the loop needs plain C functions of a fixed signature, which one
call of the compiler gives.

The C functions fill arrays the caller zeroed (``void c_dynamics(double t, const double
*q, const double *v, const double *p, double *M, double *rhs, ...)``, matrices
row-major); the loop calls them with its arrays' addresses.

``$LAMECH_CC``: the compiler command (default ``$CC``, else ``cc``, ``gcc`` or ``clang``,
the first found); ``0`` or ``none``: no C (numba compiles the system's functions).
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

__all__ = ["FLAGS", "FUNCTIONS", "compiler", "library_path", "load", "CompileFailed"]

FUNCTIONS = (
    "c_dynamics", "c_dynamics_sparse", "c_constraints", "c_energy", "c_restitution",
    "c_switches",
)  # fmt: skip
"""The functions of a system's library, in the order of the system record's fields."""

# -ffp-contract=off: no fused multiply-add where the source has a product and a sum, as
# numba (and NumPy) compute it; -O2 without -march=native: a cache folder shared by
# machines (a cluster's home) must not hold code another processor cannot run.
FLAGS = ("-O2", "-std=c99", "-ffp-contract=off", "-fPIC", "-shared")

_LIBRARIES: dict[str, ctypes.CDLL] = {}  # path -> the library (kept loaded)


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
    """Whether the library of ``c_source`` is in ``folder`` (and a compiler is in use)."""
    return compiler() is not None and library_path(c_source, folder).is_file()


def _build(c_source: str, target: Path) -> None:
    """Compile ``c_source`` into the shared library ``target`` (written under another
    name and renamed into place: two processes may build it at once)."""
    command = compiler()
    if command is None:
        raise CompileFailed("no C compiler")
    target.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=target.parent, prefix=".build-") as tmp:
        src, out = Path(tmp) / "system.c", Path(tmp) / target.name
        src.write_text(c_source, encoding="utf-8")
        try:
            done = subprocess.run(
                [*command, *FLAGS, "-o", str(out), str(src), "-lm"],
                capture_output=True,
                text=True,
                timeout=600,
                check=False,
            )
        except (OSError, subprocess.SubprocessError) as exc:
            raise CompileFailed(str(exc)) from exc
        if done.returncode != 0 or not out.is_file():
            raise CompileFailed(done.stderr[-2000:])
        os.replace(out, target)


def load(c_source: str, folder: Path) -> tuple[ctypes.CDLL, tuple[int, ...], str]:
    """(the library, the addresses of :data:`FUNCTIONS`, "loaded" or "compiled" or
    "memory") of ``c_source``: from ``folder`` where it was built before, else built
    there now, else (the folder not writable) built in a temporary folder and loaded
    from there. Raises :class:`CompileFailed`."""
    path = library_path(c_source, folder)
    state = "loaded"
    if not path.is_file():
        try:
            _build(c_source, path)
            state = "compiled"
        except OSError:  # the folder cannot be written: build it in a private folder
            # of this process's (never a shared one, where another user could plant it)
            path = library_path(c_source, Path(tempfile.mkdtemp(prefix="lamech-c-")))
            _build(c_source, path)
            state = "memory"
    lib = _LIBRARIES.get(str(path))
    if lib is None:
        try:
            lib = ctypes.CDLL(str(path))
        except OSError as exc:  # a damaged file in the cache: build it again
            raise CompileFailed(str(exc)) from exc
        _LIBRARIES[str(path)] = lib
    addresses = tuple(ctypes.cast(getattr(lib, f), ctypes.c_void_p).value or 0 for f in FUNCTIONS)
    if not all(addresses):
        raise CompileFailed("a function is missing from the library")
    return lib, addresses, state
