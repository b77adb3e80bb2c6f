"""The numeric layer: code generated from the derivation and compiled (NumPy, or numba
when installed), every KKT solve of the hot path, the simulator with its contact and
friction events, the compiled batch integrator, and the :class:`Trajectory` they give.

SciPy is imported by the simulator only when a simulation runs.
"""

from ._batch import BatchResult, integrate_batch
from ._codegen import NumericSystem, compile_system, kkt_solve_numpy, numba_available
from ._simulate import (DEFAULT_ATOL, DEFAULT_RTOL, SimulationError, check_options,
                        consistent_initial, friction_names, simulate,
                        with_friction_parameters)
from ._trajectory import Trajectory

__all__ = ["NumericSystem", "compile_system", "numba_available", "kkt_solve_numpy", "simulate",
           "SimulationError", "DEFAULT_RTOL", "DEFAULT_ATOL", "check_options",
           "consistent_initial", "friction_names", "with_friction_parameters", "Trajectory",
           "integrate_batch", "BatchResult"]
