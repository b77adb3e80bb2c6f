"""Parameter sweeps: every combination of parameter values simulated with one compiled
system, a few numbers measured per case, one row per case; in this process, on local
worker processes, or on a Dask cluster, with resume (see :mod:`lamech.sweeps._run`).
"""

from ._parse import (
    EVENT_MEASURES,
    MAX_CASES,
    SERIES_MEASURES,
    Measure,
    SweepError,
    parse_assignment,
    parse_measure,
    parse_values,
)
from ._run import SweepRun, run_sweep, sweep, sweepable_names
from ._table import format_value

__all__ = [
    "sweep",
    "run_sweep",
    "SweepRun",
    "SweepError",
    "Measure",
    "parse_values",
    "parse_assignment",
    "parse_measure",
    "sweepable_names",
    "format_value",
    "EVENT_MEASURES",
    "SERIES_MEASURES",
    "MAX_CASES",
]
