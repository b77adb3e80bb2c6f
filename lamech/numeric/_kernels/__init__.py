"""The loop's integer codes (:mod:`.codes`), defined once: ``_engine/codes.h`` holds the
same values (checked by the tests), and Python reads the engine's results through its
maps.

The rules themselves (the mode, the events, the projection, the KKT solves, DOP853 and
the loops) were Python kernels here, each with its twin in C; they are now written once,
in C (``lamech/numeric/_engine/*.c``, ``lamech.numeric._cengine``), used by every road: the loop
with events, the batch loop, and SciPy's integrators (``lamech.numeric._crules``). A system
without compiled functions has its NumPy functions called back by the engine.
"""

from __future__ import annotations

from . import codes

__all__ = ["codes", "STAGES"]

STAGES = 12
"""DOP853's number of stages (the engine's ``LM_STAGES``, checked against SciPy's by
:mod:`.._tableau`)."""
