"""The numeric layer: code generated from the derivation and compiled (NumPy, and C
for lamech's engine in C built at install), every KKT solve of the hot path, the
simulator with its contact and friction events, the compiled batch integrator (and its
twin with events for sweeps), and the :class:`Trajectory` they give, with its typed
:class:`Event` log and :class:`Status`.

SciPy is imported by the simulator only when a simulation runs.
"""

from .._moved import moved
from ._batch import (
    BatchResult,
    EventBatchResult,
    initial_states,
    integrate_batch,
    integrate_events,
    parameter_rows,
)
from ._cc import cache_dir as jit_cache_dir
from ._codegen import NumericSystem, compile_system, compiled_available
from ._events import Event, EventKind, FrictionState, Status
from ._initial import consistent_initial
from ._options import DEFAULT_ATOL, DEFAULT_RTOL, METHODS, Options, SimulationError
from ._simulate import simulate
from ._trajectory import Trajectory

__all__ = [
    "simulate",
    "Options",
    "Trajectory",
    "SimulationError",
    "Event",
    "EventKind",
    "FrictionState",
    "Status",
    "compile_system",
    "NumericSystem",
    "compiled_available",
    "jit_cache_dir",
    "integrate_batch",
    "BatchResult",
    "integrate_events",
    "EventBatchResult",
    "parameter_rows",
    "initial_states",
    "consistent_initial",
    "DEFAULT_RTOL",
    "DEFAULT_ATOL",
    "METHODS",
]

# The plumbing this face exported before: lamech's own code imports it from the private
# modules; other code still finds it here, with a DeprecationWarning.
_INTERNAL = "internal to lamech.numeric"
__getattr__ = moved(
    __name__,
    {
        "EVENT_FALLBACKS": ("_batch:FALLBACKS", _INTERNAL),
        "jit_is_cached": ("_batch", _INTERNAL),
        "numba_available": (
            "_codegen:compiled_available",
            "lamech's engine is C now, not numba: use compiled_available",
        ),
        "kkt_solve_numpy": ("_kkt", _INTERNAL),
        "IMPLICIT": ("_options", _INTERNAL),
        "MAX_STEPS": ("_options", _INTERNAL),
        "check_options": ("_options", _INTERNAL),
        "PILOT_SECONDS": ("_pace", _INTERNAL),
        "Pace": ("_pace", _INTERNAL),
        "friction_names": ("_params", _INTERNAL),
        "with_friction_parameters": ("_params", _INTERNAL),
    },
)
del moved
