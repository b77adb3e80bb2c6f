"""lamech: constrained mechanics by Lagrange multipliers.

>>> import lamech
>>> sol = lamech.solve(lamech.load("cylinder"))
>>> sol.multipliers["rolling"]
-g*m*sin(theta1)/3
"""

from .derive import DegenerateConstraintsError, Dynamics, dynamics
from .expr import ExpressionError
from .model import Body, Constraint, Coordinate, Parameter, System
from .problem import ProblemFileError, example_names, from_dict, load, loads
from .solve import Solution, solve
from .sweep import SweepError, sweep  # the function shadows the module name: use
#   importlib.import_module("lamech.sweep") for run_sweep, plot_sweep, ...

__all__ = ["load", "loads", "from_dict", "solve", "dynamics", "example_names", "System",
           "Solution", "Dynamics", "Body", "Constraint", "Coordinate", "Parameter",
           "ProblemFileError", "ExpressionError", "DegenerateConstraintsError",
           "sweep", "SweepError"]
__version__ = "0.1.0"
