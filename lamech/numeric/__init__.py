"""The numeric layer: code generated from the derivation and compiled (NumPy, or numba
when installed), every KKT solve of the hot path, the simulator with its contact and
friction events, the compiled batch integrator (and its twin with events for sweeps),
and the :class:`Trajectory` they give,
with its typed :class:`Event` log and :class:`Status`.

SciPy is imported by the simulator only when a simulation runs.
"""

from ._batch import FALLBACKS as EVENT_FALLBACKS
from ._batch import (
    BatchResult,
    EventBatchResult,
    initial_states,
    integrate_batch,
    integrate_events,
    jit_is_cached,
    parameter_rows,
)
from ._codegen import NumericSystem, compile_system, numba_available
from ._events import Event, EventKind, FrictionState, Status
from ._initial import consistent_initial
from ._jitcache import cache_dir as jit_cache_dir
from ._kkt import kkt_solve_numpy
from ._options import (
    DEFAULT_ATOL,
    DEFAULT_RTOL,
    IMPLICIT,
    MAX_STEPS,
    METHODS,
    SimulationError,
    check_options,
)
from ._pace import PILOT_SECONDS, Pace
from ._params import friction_names, with_friction_parameters
from ._simulate import simulate
from ._trajectory import Trajectory

__all__ = [
    "NumericSystem",
    "compile_system",
    "numba_available",
    "jit_cache_dir",
    "kkt_solve_numpy",
    "simulate",
    "SimulationError",
    "DEFAULT_RTOL",
    "DEFAULT_ATOL",
    "check_options",
    "METHODS",
    "IMPLICIT",
    "MAX_STEPS",
    "Pace",
    "PILOT_SECONDS",
    "consistent_initial",
    "friction_names",
    "with_friction_parameters",
    "Trajectory",
    "Event",
    "EventKind",
    "FrictionState",
    "Status",
    "integrate_batch",
    "BatchResult",
    "integrate_events",
    "EventBatchResult",
    "EVENT_FALLBACKS",
    "parameter_rows",
    "initial_states",
    "jit_is_cached",
]
