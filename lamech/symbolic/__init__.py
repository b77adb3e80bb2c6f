"""The symbolic layer: derivation (M, h, A, gamma, the KKT system), elimination of
constrained coordinates, closed forms of the accelerations and multipliers (tidy; or
raw and fast, :func:`multipliers`), first integrals and the energy shell, where a
constraint lets go or slips, and the generalized and Cartesian constraint forces; all
gathered by :func:`solve` into a frozen :class:`Solution`. Every function here is a
pure function of a :class:`~lamech.model.System`; the sign convention is stated in
:mod:`lamech.model`.
"""

from ._budget import count_ops
from ._conditions import (
    Root,
    Verdict,
    is_angle,
    lets_go_verdict,
    slip_points,
    slip_verdict,
    vanishing_points,
)
from ._derive import DegenerateConstraintsError, Dynamics, dynamics, kkt_numeric
from ._forces import cartesian_forces, generalized_forces
from ._integrals import Integrals, Shell, energy_shell, integrals
from ._modes import Equilibrium, Linear, Mode, Modes, check_modes, modes
from ._multipliers import multipliers
from ._normal import is_zero, normal, to_rational
from ._reduce import (
    CLOSED_FORM_LIMIT,
    KKT_OPS,
    READABLE_OPS,
    ClosedForms,
    Reduction,
    closed_forms,
    eliminate,
    tidy,
)
from ._sensitivity import free_parameters, friction_mu, friction_parameters, in_free_parameters
from ._solution import Solution, readable, solve
from ._steps import CORRECTION, Derivation, Line, Step, Term, steps
from ._work import DEFAULT_BUDGET, OverBudget, Work, work_budget

__all__ = [
    "Dynamics",
    "dynamics",
    "kkt_numeric",
    "multipliers",
    "DegenerateConstraintsError",
    "Reduction",
    "eliminate",
    "ClosedForms",
    "closed_forms",
    "tidy",
    "CLOSED_FORM_LIMIT",
    "KKT_OPS",
    "READABLE_OPS",
    "DEFAULT_BUDGET",
    "Work",
    "work_budget",
    "OverBudget",
    "normal",
    "is_zero",
    "to_rational",
    "count_ops",
    "Integrals",
    "integrals",
    "Shell",
    "energy_shell",
    "Root",
    "Verdict",
    "lets_go_verdict",
    "slip_verdict",
    "vanishing_points",
    "slip_points",
    "is_angle",
    "free_parameters",
    "friction_parameters",
    "friction_mu",
    "in_free_parameters",
    "generalized_forces",
    "cartesian_forces",
    "Solution",
    "solve",
    "readable",
    "modes",
    "Modes",
    "Equilibrium",
    "Mode",
    "Linear",
    "check_modes",
    "steps",
    "Derivation",
    "Step",
    "Line",
    "Term",
    "CORRECTION",
]
