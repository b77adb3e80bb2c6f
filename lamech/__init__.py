"""lamech: constrained mechanics by Lagrange multipliers.

The package is layered; each layer imports only the ones below it (checked in CI by
import-linter, see ``pyproject.toml``)::

    cli       the ``lamech`` command (argument parsing only)
    present   text, LaTeX, JSON, CSV, plots, animations: the only layer that formats or draws
              (the result types below it hold data)
    sweeps    parameter sweeps on local processes or Dask
    numeric   generated code, the KKT solves, the simulator, the batch integrator
    symbolic  derivation, elimination, closed forms, integrals, conditions, forces
    problem   TOML files and dicts -> model; the bundled examples
    model     frozen, self-checking definitions (System, Constraint, Body, ...)
    expr, linalg   the safe expression parser/printer; dense KKT linear algebra

``import lamech`` is cheap: the names below are imported from their layer on first use,
so ``lamech --help`` starts without SymPy.

>>> import lamech
>>> sol = lamech.solve(lamech.load("cylinder"))
>>> sol.multipliers["rolling"]
-g*m*sin(theta1)/3
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from ._errors import LamechError
from ._version import __version__

_PUBLIC = {
    # model
    "System": "model",
    "Parameter": "model",
    "Coordinate": "model",
    "Constraint": "model",
    "Body": "model",
    "Friction": "model",
    "ForceSpec": "model",
    "ModelError": "model",
    # problem
    "load": "problem",
    "loads": "problem",
    "from_dict": "problem",
    "example_names": "problem",
    "ProblemFileError": "problem",
    # expressions
    "ExpressionError": "expr",
    # symbolic
    "solve": "symbolic",
    "multipliers": "symbolic",
    "modes": "symbolic",
    "steps": "symbolic",
    "Solution": "symbolic",
    "dynamics": "symbolic",
    "Dynamics": "symbolic",
    "DegenerateConstraintsError": "symbolic",
    # numeric
    "simulate": "numeric",
    "Options": "numeric",
    "Trajectory": "numeric",
    "SimulationError": "numeric",
    "compile_system": "numeric",
    "integrate_batch": "numeric",
    # sweep
    "sweep": "sweeps",
    "map": "sweeps",
    "MapResult": "sweeps",
    "SweepResult": "sweeps",
    "SweepError": "sweeps",
    "run_sweep": "sweeps",  # deprecated: warns when called; use sweep
    # present
    "to_text": "present",
    "to_latex": "present",
    "to_json": "present",
    "to_csv": "present",
    "plot_trajectory": "present",
    "animate": "present",
}

__all__ = [
    "LamechError",
    "Body",
    "MapResult",
    "Constraint",
    "Coordinate",
    "DegenerateConstraintsError",
    "Dynamics",
    "ExpressionError",
    "ForceSpec",
    "Friction",
    "ModelError",
    "Options",
    "Parameter",
    "ProblemFileError",
    "SimulationError",
    "Solution",
    "SweepError",
    "SweepResult",
    "System",
    "Trajectory",
    "animate",
    "compile_system",
    "dynamics",
    "example_names",
    "from_dict",
    "integrate_batch",
    "load",
    "loads",
    "map",
    "modes",
    "multipliers",
    "plot_trajectory",
    "simulate",
    "solve",
    "steps",
    "sweep",
    "to_csv",
    "to_json",
    "to_latex",
    "to_text",
    "__version__",
]


_LAYERS = ("cli", "present", "sweeps", "numeric", "symbolic", "problem", "model", "expr", "linalg")


def __getattr__(name: str) -> Any:
    if name in _LAYERS:
        return importlib.import_module(f"lamech.{name}")
    layer = _PUBLIC.get(name)
    if layer is None:
        raise AttributeError(f"module 'lamech' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"lamech.{layer}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_PUBLIC))


if TYPE_CHECKING:  # for type checkers and IDEs: the same names, eagerly
    from .expr import ExpressionError
    from .model import (
        Body,
        Constraint,
        Coordinate,
        ForceSpec,
        Friction,
        ModelError,
        Parameter,
        System,
    )
    from .numeric import (
        Options,
        SimulationError,
        Trajectory,
        compile_system,
        integrate_batch,
        simulate,
    )
    from .present import animate, plot_trajectory, to_csv, to_json, to_latex, to_text
    from .problem import ProblemFileError, example_names, from_dict, load, loads
    from .sweeps import MapResult, SweepError, SweepResult, sweep
    from .sweeps import map as map
    from .sweeps import run_sweep as run_sweep  # deprecated
    from .symbolic import (
        DegenerateConstraintsError,
        Dynamics,
        Solution,
        dynamics,
        multipliers,
        solve,
        steps,
    )
