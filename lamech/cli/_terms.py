"""The library's messages in the command line's terms.

A message raised or recorded by the library names the Python argument that changes the
outcome, written as a keyword in backticks: `` `max_step=` ``, `` `at=` ``,
`` `method="Radau"` ``, `` `project_initial=True` ``. A Python user has those; a user of
the command has its flags, so the CLI renders each such keyword as the flag that sets it
(``--max-step``, ``--at``, ``--method Radau``, ``--project-initial``) before it prints
a message, a report or an error. Keywords without a flag are left as they are.
"""

from __future__ import annotations

import re

__all__ = ["FLAGS", "in_flags"]

FLAGS = {
    "at": "--at",
    "t_end": "--t-end",
    "max_step": "--max-step",
    "method": "--method",
    "project_initial": "--project-initial",
    "data_dir": "--data-dir",
    "params": "--param",
    "initial": "--initial",
    "measures": "--measure",
    "samples": "--samples",
    "rtol": "--rtol",
    "atol": "--atol",
    "out": "--out",
    "resume": "--resume",
    "engine": "--engine",
}
"""Each library argument a message may name, and the flag that sets it."""

PHRASES = {
    # solve's note on a circle constraint: what --angles does, said in Python
    "`with_chart(system, circle_chart(system))` (from lamech.model)": "`--angles`",
}
"""Library phrases that are one flag on the command line."""

_KEYWORD = re.compile(r"`([a-z_]+)=([^`\n]*)`")


def _flag(match: re.Match) -> str:
    flag = FLAGS.get(match.group(1))
    if flag is None:
        return match.group(0)
    value = match.group(2).strip()
    if value in ("", "True"):
        return flag
    return f"{flag} {value.strip(chr(34) + chr(39))}"


def in_flags(text: str) -> str:
    """``text`` with each library keyword it names (`` `max_step=` ``) replaced by the
    command's flag (``--max-step``); the rest unchanged."""
    for phrase, flag in PHRASES.items():
        text = text.replace(phrase, flag)
    return _KEYWORD.sub(_flag, text)
