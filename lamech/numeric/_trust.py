"""Whether lamech may load what is in a cache folder: the trust rule for compiled code.

What the cache folder holds is code: the systems' C libraries (loaded by ``dlopen``,
whose constructors run as they load), the loop's module and the machine code and pickles
of its compiled functions. Anyone who can write the folder, or replace a file in it,
runs code in every lamech process that uses it. So, as OpenSSH checks ``~/.ssh`` and pip
its cache, lamech loads from a folder only where

- the folder, and the folder above it that lamech makes (``$LAMECH_CACHE_DIR`` or
  ``~/.cache/lamech``, holding ``kernels``), are directories owned by the current user
  or by root, and writable by neither group nor others (the mode's ``0o022`` bits);
- every file loaded is a regular file with the same owners and no such bits.

The mode bits and the owner decide, not :func:`os.access`: root (tests, containers)
passes every access check. A folder owned by root (an administrator's cluster cache, a
container image) or by the user without the owner's write bit is *shared read-only*:
lamech loads from it and writes nothing there. Any other folder is refused, once per
process with one line on stderr that names it and the fix, and lamech uses the user's
own folder instead (:func:`user_cache_dir`, made ``0o700``), or none at all (the code
compiled for this process only) where that one is refused too.

Nothing here knows the C compiler: :mod:`._cc` asks.
"""

from __future__ import annotations

import atexit
import os
import shutil
import stat
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

__all__ = [
    "Place",
    "cache_place",
    "file_problem",
    "folder_problem",
    "process_dir",
    "say_once",
    "user_cache_dir",
]

_SAID: set[str] = set()
_PROCESS_DIR: list[Path] = []  # this process's temporary folder, removed at its exit


@dataclass(frozen=True)
class Place:
    """Where lamech keeps compiled code this process: ``path`` (None: nowhere on disk,
    compiled in memory) and whether lamech writes there (``writable``; a shared read-only
    folder is loaded from only)."""

    path: Path | None
    writable: bool


def user_cache_dir() -> Path:
    """The user's own cache folder: ``$XDG_CACHE_HOME/lamech/kernels``, else
    ``~/.cache/lamech/kernels`` (the XDG spec: an absolute ``XDG_CACHE_HOME`` only)."""
    xdg = os.environ.get("XDG_CACHE_HOME")
    base = Path(xdg).expanduser() if xdg and os.path.isabs(xdg) else Path.home() / ".cache"
    return base / "lamech" / "kernels"


def _owner_ok(st: os.stat_result) -> bool:
    return st.st_uid in (os.geteuid(), 0) if hasattr(os, "geteuid") else True


def folder_problem(path: Path) -> str | None:
    """Why the existing folder ``path`` may not be loaded from (None: it may)."""
    return _problem(path, stat.S_ISDIR, "is not a folder")


def file_problem(path: Path) -> str | None:
    """Why the file ``path`` may not be loaded (None: it may): missing, not a regular
    file, another user's, or writable by group or others."""
    return _problem(path, stat.S_ISREG, "is not a regular file")


def _problem(path: Path, kind_ok, wrong_kind: str) -> str | None:
    """The rule of both: of the right kind, the user's or root's, and not writable by
    group or others (as OpenSSH checks ~/.ssh)."""
    try:
        st = os.stat(path)
    except OSError as exc:
        return f"cannot be read ({exc.strerror})"
    if not kind_ok(st.st_mode):
        return wrong_kind
    if not _owner_ok(st):
        return f"belongs to another user (uid {st.st_uid})"
    if st.st_mode & 0o022:
        return f"can be written by {_whom(st.st_mode)} (mode {stat.S_IMODE(st.st_mode):04o})"
    return None


def _whom(mode: int) -> str:
    return " and ".join(w for w, bit in (("its group", 0o020), ("others", 0o002)) if mode & bit)


def _writable(path: Path) -> bool:
    """Whether lamech writes in the trusted folder ``path``: the user's own, with the
    owner's write bit (decided by the bits: root passes :func:`os.access` everywhere)."""
    st = os.stat(path)
    mine = st.st_uid == os.geteuid() if hasattr(os, "geteuid") else True
    return mine and bool(st.st_mode & stat.S_IWUSR) and os.access(path, os.W_OK | os.X_OK)


def _make(path: Path) -> None:
    """``path`` and the folders above it that are missing, each made ``0o700`` (the
    mode set after ``mkdir``, which the umask narrows but does not widen)."""
    missing = []
    at = path
    while not at.exists():
        missing.append(at)
        if at.parent == at:
            break
        at = at.parent
    for folder in reversed(missing):
        try:
            folder.mkdir(mode=0o700)
        except FileExistsError:  # made meanwhile by another process
            continue
        os.chmod(folder, 0o700)


def _checked(folder: Path, make: bool = True) -> tuple[Place | None, str | None]:
    """(the place ``folder`` gives, or None, and why it is refused, or None); ``make``:
    made where missing, else a missing folder gives no place."""
    try:
        if make:
            _make(folder)
        elif not folder.is_dir():
            return None, None
    except OSError:  # under a file, no permission: no folder here (not a trust problem)
        return None, None
    for path in (folder.parent, folder):  # the root lamech made, then ``kernels``
        problem = folder_problem(path)
        if problem is not None:
            return None, f"{path} {problem}"
    return Place(folder, _writable(folder)), None


def cache_place(folder: Path, make: bool = True) -> Place:
    """The place to keep compiled code, ``folder`` asked for (made ``0o700`` where
    missing, if ``make``; a caller that only asks what is there passes False):
    ``folder`` itself where the trust rule allows it (writable or shared read-only),
    else the user's own folder (:func:`user_cache_dir`) where that is a different one
    and allowed, else ``Place(None, False)``: compile in memory. A refused folder is
    said once per process, on stderr, with the fix."""
    place, problem = _checked(folder, make)
    if place is not None:
        return place
    if problem is None:
        return Place(None, False)
    own = user_cache_dir()
    fallback, own_problem = _checked(own, make) if own != folder else (None, None)
    instead = f"using {own} instead" if fallback is not None else "compiling in memory"
    say_once(
        f"lamech: not loading compiled code from the cache folder {problem}: anyone who "
        f"can write it runs code in lamech; {instead}. Fix: chmod go-w (and chown to "
        "yourself) that folder, or set LAMECH_CACHE_DIR to a folder of your own"
    )
    if fallback is None and own_problem is not None:
        say_once(f"lamech: not loading compiled code from the cache folder {own_problem}")
    return fallback if fallback is not None else Place(None, False)


def say_once(text: str) -> None:
    """``text`` on stderr, once per process (a sweep's many runs say it once)."""
    if text in _SAID:
        return
    _SAID.add(text)
    print(text, file=sys.stderr, flush=True)


def process_dir() -> Path:
    """A folder of this process's own (``0o700``, under ``$TMPDIR``), for what is
    compiled where no cache folder keeps it (or copied from a read-only one); removed
    when the process ends, by this process only (a forked child's exit leaves it).
    multiprocessing's finalizers run at the end of the main process (at exit) and of a
    sweep's worker, which ends by ``os._exit`` (no ``atexit`` there)."""
    if not _PROCESS_DIR:
        from multiprocessing import util

        folder = Path(tempfile.mkdtemp(prefix="lamech-c-"))
        owner = os.getpid()

        def remove() -> None:
            if os.getpid() == owner:
                shutil.rmtree(folder, ignore_errors=True)

        util.Finalize(None, remove, exitpriority=0)
        atexit.register(remove)  # where multiprocessing's own exit hook is not reached
        _PROCESS_DIR.append(folder)
    return _PROCESS_DIR[0]
