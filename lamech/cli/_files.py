"""Files the commands read and write: ``--data-dir`` (where a problem's tables may be)
and :func:`write_output`, the one way every output is written (regular files only, a
temporary file in the same folder renamed when complete, the format by the suffix)."""

from __future__ import annotations

import argparse

__all__ = ["add_data_dir"]


def add_data_dir(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--data-dir",
        metavar="DIR",
        default=None,
        help="a folder the problem's tables ([inputs] csv files) may also be in; by "
        "default only the problem file's own folder (symlinks followed) is read",
    )
