"""Parameter sweeps: every combination of parameter values simulated with one compiled
system, a few numbers measured per case, one row per case (:func:`sweep`, giving a
:class:`SweepResult`); in this process by the compiled loop with events, on local worker
processes, or on a Dask cluster, with resume (see :mod:`lamech.sweeps._run`).
"""

from .._moved import moved
from ._map import MapResult, parameter_map
from ._map import parameter_map as map  # lamech.map
from ._parse import Measure, SweepError
from ._result import SweepResult
from ._run import run_sweep as run_sweep  # deprecated: warns when called
from ._run import sweep

__all__ = ["sweep", "SweepResult", "SweepError", "Measure", "map", "parameter_map", "MapResult"]

_INTERNAL = "internal to lamech.sweeps"
__getattr__ = moved(
    __name__,
    {
        "SweepRun": ("_result:SweepResult", "renamed lamech.SweepResult"),
        "parse_values": ("_parse", _INTERNAL),
        "parse_assignment": ("_parse", _INTERNAL),
        "parse_measure": ("_parse", _INTERNAL),
        "sweepable_names": ("_run", _INTERNAL),
        # a table's cell text moved to the layer that formats (lamech.to_csv writes a table)
        "format_value": ("lamech.present._table:cell", "internal to lamech.present"),
        "EVENT_MEASURES": ("_parse", _INTERNAL),
        "SERIES_MEASURES": ("_parse", _INTERNAL),
        "MAX_CASES": ("_parse", _INTERNAL),
    },
)
del moved
