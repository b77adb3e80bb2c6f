"""The files numba keeps for a compiled module in lamech's cache, as code to be trusted:
checked before numba reads them (size, and SHA-256 of the small indexes, against the
record written when they were made; ownership and modes by :mod:`._trust`), recorded after
a compile and again at exit (numba rewrites an index when it adds a signature), and
copied, checked, out of a shared read-only folder. A damaged or untrusted file is
removed with one line, so numba misses and compiles again (no numba internal is
touched). Used by :mod:`._jitcache`."""

from __future__ import annotations

import atexit
import contextlib
import os
import shutil
from pathlib import Path

from ._integrity import digest, mismatch, read_record, say_rebuilt, write_record
from ._trust import file_problem, folder_problem, say_once

__all__ = [
    "record_path",
    "machine_code",
    "checked_machine_code",
    "record_machine_code",
    "record_at_exit",
    "copy_checked",
]


def record_path(folder: Path, name: str) -> Path:
    """The record (:mod:`._integrity`) of the files numba keeps for the module ``name``."""
    return folder / f"{name}.files.json"


def machine_code(folder: Path, name: str) -> list[Path]:
    """The files numba (and Python) keep for the module ``name`` in ``folder``: its
    functions' indexes and machine code, its bytecode; not one still being written."""
    cache = folder / "__pycache__"
    return sorted(p for p in cache.glob(f"{name}.*") if ".tmp" not in p.name)


def checked_machine_code(folder: Path, name: str) -> None:
    """Remove (saying so, one line each) the files of the module ``name`` in ``folder``
    that are damaged (not the size recorded when they were written; an index, small, not
    the bytes either) or not to be trusted (:func:`._trust.file_problem`): numba then
    misses and compiles those functions again, as it does where there is no file. A file
    written but not yet recorded (its process still compiling, or ended first) is left
    to numba."""
    cache = folder / "__pycache__"
    if folder_problem(cache) is not None:  # numba made it with the umask's mode: ours
        with contextlib.suppress(OSError):
            os.chmod(cache, 0o700)
    files = read_record(record_path(folder, name)) or {}
    for path in machine_code(folder, name):
        problem = file_problem(path)
        if problem is None and path.name in files:
            problem = mismatch(path, files[path.name], hash_it=path.suffix == ".nbi")
        if problem is not None:
            say_rebuilt(path, problem, "compiling it again")
            path.unlink()


def record_machine_code(folder: Path, name: str) -> None:
    """Record the size and SHA-256 of every file numba (and Python) now keeps for the
    module ``name`` in ``folder``, each made ``0o600`` (numba writes them with the
    umask's mode); the files recorded before and unchanged are not read again."""
    try:
        record = record_path(folder, name)
        old = read_record(record) or {}
        since = record.stat().st_mtime_ns if old else 0
        files = {}
        for path in machine_code(folder, name):
            st = path.stat()
            if st.st_mode & 0o077:
                os.chmod(path, 0o600)
            known = old.get(path.name)
            same = st.st_mtime_ns <= since and not mismatch(path, known, False)
            files[path.name] = known if known and same else digest(path)
        if files != old:
            write_record(record, files)
    except OSError:  # a folder that cannot be written: nothing recorded, nothing lost
        pass


_AT_EXIT: set[tuple[Path, str]] = set()  # (folder, module) recorded again at exit


def record_at_exit(folder: Path, name: str) -> None:
    """Record the module ``name``'s files in ``folder`` again when the process ends: numba
    rewrites a function's index when it compiles a signature it lacked, and the record
    must follow (else the next process takes the index for a damaged one)."""
    if not _AT_EXIT:
        owner = os.getpid()

        def record_all() -> None:
            if os.getpid() == owner:  # not a forked worker's exit
                for where, module in _AT_EXIT:
                    record_machine_code(where, module)

        atexit.register(record_all)
    _AT_EXIT.add((folder, name))


def copy_checked(source: Path, target: Path, name: str) -> None:
    """Copy the module ``name`` and numba's files for it from the shared read-only
    folder ``source`` into ``target`` (times kept: numba checks the module's), each
    checked against the record (size and SHA-256, read once as it is copied) and to be
    trusted; a damaged one is left behind, said (numba compiles it in ``target``)."""
    module = source / f"{name}.py"
    if file_problem(module) is not None or (target / module.name).exists():
        return
    shutil.copy2(module, target / module.name)
    files = read_record(record_path(source, name)) or {}
    (target / "__pycache__").mkdir(mode=0o700, exist_ok=True)
    problem = folder_problem(source / "__pycache__")
    if not (source / "__pycache__").is_dir():
        return
    if problem is not None:  # none of it copied: numba compiles it in ``target``
        say_once(f"lamech: not loading compiled code from {source / '__pycache__'}: it {problem}")
        return
    for path in machine_code(source, name):
        problem = file_problem(path) or mismatch(path, files.get(path.name))
        if problem is not None:
            say_rebuilt(path, problem, "compiling it for this process")
            continue
        shutil.copy2(path, target / "__pycache__" / path.name)
