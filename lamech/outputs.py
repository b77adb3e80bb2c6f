"""Every file lamech writes (a trajectory's CSV, a plot, an animation, a report, a
sweep's table) goes through here, so that all of them:

- go to regular files only: a device, FIFO, socket, directory or symlink at the path is
  refused with a message, never replaced (``-``, standard output, where the caller
  allows it);
- have the format their suffix names, or are refused (``--out x.parquet`` is not CSV
  text under a Parquet name);
- are written to a temporary file in the same folder and renamed over the path only
  when complete: a kill, a full disk or an error leaves the old file or none, never a
  short GIF under the final name;
- get the ordinary mode a new file gets (0666 less the umask), not the temporary
  file's 0600.
"""

from __future__ import annotations

import os
import stat
import tempfile
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

from ._errors import LamechError
from .expr import printable

__all__ = ["OutputError", "check_output", "atomic_output", "write_output"]


class OutputError(LamechError, ValueError):
    """An output path lamech will not write: what is there, or its suffix."""


def _what(mode: int) -> str | None:
    for test, name in (
        (stat.S_ISDIR, "a directory"),
        (stat.S_ISLNK, "a symbolic link"),
        (stat.S_ISFIFO, "a FIFO (named pipe)"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    ):
        if test(mode):
            return name
    return None if stat.S_ISREG(mode) else "not a regular file"


def check_output(
    path: str | os.PathLike, formats: Iterable[str], flag: str = "`path=`", stdout: bool = False
) -> Path | None:
    """The path to write, checked; None for ``-`` (standard output) when ``stdout``.

    ``flag`` names the path in a message: the library's argument (`` `path=` ``, what
    :func:`lamech.plot_trajectory` and the others call it), or the command's flag.

    Raises
    ------
    OutputError
        The suffix is not one of ``formats`` (".csv", ...), or something other than a
        regular file is at the path (a device, FIFO, socket, directory or symlink).
    """
    formats = tuple(f.lower() for f in formats)
    shown = printable(os.fspath(path))
    if os.fspath(path) == "-":
        if stdout:
            return None
        raise OutputError(f"{flag} -: this output cannot go to standard output; give a file name")
    p = Path(path)
    try:
        what = _what(p.lstat().st_mode)
    except FileNotFoundError:
        what = None
    except OSError as exc:
        raise OutputError(f"{flag} {shown}: cannot be written: {exc.strerror}") from None
    if what is not None:
        raise OutputError(
            f"{flag} {shown} is {what}: lamech writes only regular files and will not "
            "replace it; give the path of a new or regular file"
        )
    if p.suffix.lower() not in formats:
        raise OutputError(
            f"{flag} {shown}: the format follows the suffix; use a name ending in "
            + ", ".join(formats)
            + (" (or - for standard output)" if stdout else "")
        )
    return p


def _file_mode() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return 0o666 & ~mask


@contextmanager
def atomic_output(
    path: str | os.PathLike, formats: Iterable[str] | None = None, flag: str = "`path=`"
) -> Iterator[Path]:
    """A temporary path in ``path``'s folder, with its suffix (matplotlib picks a format
    by it), to write; renamed over ``path`` when the block ends without error, removed
    otherwise (a KeyboardInterrupt or SIGTERM included). ``path`` is checked
    (:func:`check_output`, with ``formats``, default: its own suffix) before and again
    just before the rename. Its folder is made if missing."""
    target = Path(path)
    kinds = (target.suffix,) if formats is None else tuple(formats)
    check_output(target, kinds, flag)
    folder = target.parent
    folder.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(
        dir=folder, prefix=f".{target.name}.", suffix=f".part{target.suffix}"
    )
    os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        check_output(target, kinds, flag)  # nothing put there meanwhile
        os.chmod(tmp, _file_mode())
        os.replace(tmp, target)
    finally:
        tmp.unlink(missing_ok=True)


def write_output(
    path: str | os.PathLike,
    content: str | bytes | Callable[[Path], None],
    formats: Iterable[str] | None = None,
    flag: str = "`path=`",
) -> None:
    """Write ``content`` (text, bytes, or a function writing the temporary path it is
    given) to ``path`` by :func:`atomic_output`."""
    with atomic_output(path, formats, flag) as tmp:
        if callable(content):
            content(tmp)
        elif isinstance(content, bytes):
            tmp.write_bytes(content)
        else:
            with open(tmp, "w", encoding="utf-8", newline="") as fh:
                fh.write(content)
