"""The symbolic layer: derivation (M, h, A, gamma, the KKT system), elimination of
constrained coordinates, closed forms of the accelerations and multipliers (tidy; or
raw and fast, :func:`multipliers`), first integrals and the energy shell, where a
constraint lets go or slips, and the generalized and Cartesian constraint forces; all
gathered by :func:`solve` into a frozen :class:`Solution`. Every function here is a
pure function of a :class:`~lamech.model.System`; the sign convention is stated in
:mod:`lamech.model`.
"""

from .._moved import moved
from ._conditions import Root, slip_points, vanishing_points
from ._derive import DegenerateConstraintsError, Dynamics, dynamics
from ._forces import cartesian_forces, generalized_forces
from ._integrals import Integrals, Shell, energy_shell, integrals
from ._modes import Equilibrium, Mode, Modes, modes
from ._multipliers import multipliers
from ._reduce import Reduction, eliminate
from ._selfcheck import ClosedFormError
from ._solution import Solution, solve
from ._steps import Derivation, steps

__all__ = [
    "solve",
    "Solution",
    "multipliers",
    "dynamics",
    "Dynamics",
    "DegenerateConstraintsError",
    "ClosedFormError",
    "modes",
    "Modes",
    "Equilibrium",
    "Mode",
    "steps",
    "Derivation",
    "eliminate",
    "Reduction",
    "integrals",
    "Integrals",
    "energy_shell",
    "Shell",
    "vanishing_points",
    "slip_points",
    "Root",
    "generalized_forces",
    "cartesian_forces",
]

# The plumbing this face exported before: lamech's own code imports it from the private
# modules; other code still finds it here, with a DeprecationWarning.
_INTERNAL = "internal to lamech.symbolic"
__getattr__ = moved(
    __name__,
    {
        "count_ops": ("_budget", _INTERNAL),
        "Verdict": ("_conditions", _INTERNAL),
        "is_angle": ("_conditions", _INTERNAL),
        "lets_go_verdict": ("_conditions", _INTERNAL),
        "slip_verdict": ("_conditions", _INTERNAL),
        "kkt_numeric": ("_derive", _INTERNAL),
        "Linear": ("_modes", _INTERNAL),
        "check_modes": ("_modes", _INTERNAL),
        "is_zero": ("_normal", _INTERNAL),
        "normal": ("_normal", _INTERNAL),
        "to_rational": ("_normal", _INTERNAL),
        "CLOSED_FORM_LIMIT": ("_reduce", _INTERNAL),
        "ClosedForms": ("_reduce", _INTERNAL),
        "KKT_OPS": ("_reduce", _INTERNAL),
        "READABLE_OPS": ("_reduce", _INTERNAL),
        "closed_forms": ("_reduce", _INTERNAL),
        "tidy": ("_reduce", _INTERNAL),
        "free_parameters": ("_sensitivity", _INTERNAL),
        "friction_mu": ("_sensitivity", _INTERNAL),
        "friction_parameters": ("_sensitivity", _INTERNAL),
        "in_free_parameters": ("_sensitivity", _INTERNAL),
        "readable": ("_solution", _INTERNAL),
        "CORRECTION": ("_steps", _INTERNAL),
        "Line": ("_steps", _INTERNAL),
        "Step": ("_steps", _INTERNAL),
        "Term": ("_steps", _INTERNAL),
        "DEFAULT_BUDGET": ("_work", _INTERNAL),
        "OverBudget": ("_work", _INTERNAL),
        "Work": ("_work", _INTERNAL),
        "work_budget": ("_work", _INTERNAL),
    },
)
del moved
