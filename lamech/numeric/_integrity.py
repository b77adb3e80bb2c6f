"""A damaged file in the cache folder is a miss: files written durably, their sizes and
SHA-256 recorded, checked before anything loads them.

A file renamed into place before its data reached the disk (a crash, a full disk, a
copy cut short) is there with its name and without its bytes: a C library cut short
crashed every later run (``Bus error`` as ``dlopen`` mapped it), an empty one was never
rebuilt, a compiled function's index cut in half raised ``UnpicklingError`` on every run.
So lamech ``fsync``\\ s a file before renaming it into place (and the folder after), and
records what it wrote (size and SHA-256, :func:`digest`) in a small JSON record of its
own, written the same way (:func:`write_record`); a caller checks a file against its
record before loading it (:func:`mismatch`) and builds it again where it does not match
(:func:`say_rebuilt`: one line on stderr naming the file).

Nothing here knows the C compiler: :mod:`._cc` asks.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import tempfile
from pathlib import Path

from ._trust import file_problem, say_once

__all__ = [
    "digest",
    "mismatch",
    "read_record",
    "replace_durably",
    "say_rebuilt",
    "write_durably",
    "write_record",
]


def digest(path: Path) -> tuple[int, str]:
    """(size in bytes, SHA-256 in hex) of the file ``path``."""
    h = hashlib.sha256()
    size = 0
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
            size += len(block)
    return size, h.hexdigest()


def replace_durably(source: Path, target: Path, mode: int = 0o600) -> None:
    """Rename the finished file ``source`` to ``target`` (the same folder) once its data
    is on the disk: ``source`` set to ``mode`` and ``fsync``\\ ed, renamed, the folder
    ``fsync``\\ ed (the rename itself on the disk)."""
    os.chmod(source, mode)
    fd = os.open(source, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)
    os.replace(source, target)
    _sync_folder(target.parent)


def _sync_folder(folder: Path) -> None:
    with contextlib.suppress(OSError):  # a file system that cannot sync a folder
        fd = os.open(folder, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def write_durably(path: Path, data: bytes, mode: int = 0o600) -> None:
    """``data`` to ``path`` atomically and durably: a temporary file in the same folder,
    ``fsync``\\ ed, renamed (:func:`replace_durably`); a reader sees the whole file or
    none, and two writers of the same bytes both win."""
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        replace_durably(Path(tmp), path, mode)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def write_record(record: Path, files: dict[str, tuple[int, str]]) -> None:
    """The record ``record`` (JSON) of ``files``: {file name: (size, SHA-256)}."""
    text = json.dumps({"files": {k: list(v) for k, v in sorted(files.items())}}, indent=1)
    write_durably(record, text.encode("utf-8"))


def read_record(record: Path) -> dict[str, tuple[int, str]] | None:
    """The files of the record ``record``, or None where it is missing, damaged or not
    to be trusted (:func:`._trust.file_problem`)."""
    if file_problem(record) is not None:
        return None
    try:
        files = json.loads(record.read_text(encoding="utf-8"))["files"]
        return {str(k): (int(v[0]), str(v[1])) for k, v in files.items()}
    except (OSError, ValueError, KeyError, TypeError, IndexError, AttributeError):
        return None


def mismatch(path: Path, recorded: tuple[int, str] | None, hash_it: bool = True) -> str | None:
    """Why the file ``path`` is not what was recorded (None: it is): no record, another
    size, other bytes (``hash_it``: SHA-256 compared, else the size only), unreadable."""
    if recorded is None:
        return "has no record of what was written"
    try:
        size = os.stat(path).st_size
        if size != recorded[0]:
            return f"is {size} bytes, {recorded[0]} were written"
        if hash_it and digest(path) != recorded:
            return "is not the bytes written (SHA-256)"
    except OSError as exc:
        return f"cannot be read ({exc.strerror})"
    return None


def say_rebuilt(path: Path, why: str, what: str = "building it again") -> None:
    """One line on stderr: the damaged file ``path``, ``why``, and ``what`` lamech does."""
    say_once(f"lamech: the cached file {path} {why}: {what}")
