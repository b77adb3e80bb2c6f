"""The model: a constrained mechanical system as plain frozen data, and what is true of it.

The canonical equations, stated once (see :mod:`lamech.model._system`)::

    d/dt dL/dq'_r - dL/dq_r - sum_j lambda_j dF_j/dq'_r = Q^nc_r      (r = 1..n)

with F_j = df_j/dt for a holonomic constraint f_j(q, t) = 0 and F_j = g_j for a
velocity constraint; a unilateral constraint holds on the side f_j >= 0, where
lambda_j >= 0 pushes the system back.

A System is read from a problem file by :mod:`lamech.problem`, or built in Python from its
parts (:func:`parameter`, :func:`coordinate`, :class:`Body`, :class:`Constraint`, ...);
:func:`assemble` then does the modelling a file's sections imply: T and V from the bodies
where they are not given, an L split into T and V, and the applied loads
(:class:`AppliedForce`, :class:`Torque`, :class:`Spring`) as generalized forces.
"""

from .._moved import moved
from ._assemble import assemble, split_lagrangian
from ._base import ConstraintKind, ModelError, SceneryKind, ShapeKind
from ._chart import Chart, ChartProposal, circle_chart, with_chart
from ._dimensions import Units, infer_units, result_units
from ._kinematics import body_energy
from ._loads import AppliedForce, Load, Spring, Torque, load_terms
from ._overrides import check_dimensions, in_si
from ._parts import (
    Body,
    Constraint,
    Coordinate,
    Drive,
    ForceSpec,
    Friction,
    Parameter,
    Scenery,
    coordinate,
    parameter,
    parameters,
)
from ._system import System
from ._values import with_values

__all__ = [
    "System",
    "Parameter",
    "Coordinate",
    "Constraint",
    "Friction",
    "Drive",
    "Body",
    "ForceSpec",
    "Scenery",
    "ModelError",
    "ConstraintKind",
    "ShapeKind",
    "SceneryKind",
    "Chart",
    "ChartProposal",
    "circle_chart",
    "with_chart",
    "with_values",
    "parameter",
    "parameters",
    "coordinate",
    "AppliedForce",
    "Torque",
    "Spring",
    "Load",
    "assemble",
    "split_lagrangian",
    "load_terms",
    "body_energy",
    "Units",
    "infer_units",
    "result_units",
    "in_si",
    "check_dimensions",
]

# The kinematics, the checks and the rules' vocabulary are lamech's own plumbing: they
# still resolve here, with a DeprecationWarning naming the private module that holds them.
_INTERNAL = "internal to lamech.model"
__getattr__ = moved(
    __name__,
    {
        "FIELDS": ("_base", _INTERNAL),
        "INITIAL_TOLERANCE": ("_checks", _INTERNAL),
        "Inertialess": ("_checks", _INTERNAL),
        "angular_velocity": ("_kinematics", _INTERNAL),
        "body_rotation": ("_kinematics", _INTERNAL),
        "constraint_jacobian": ("_kinematics", _INTERNAL),
        "contact_partial_velocities": ("_kinematics", _INTERNAL),
        "dependent_constraints": ("_checks", _INTERNAL),
        "dependent_group": ("_checks", _INTERNAL),
        "gradient": ("_kinematics", _INTERNAL),
        "holding_at_start": ("_checks", _INTERNAL),
        "inertia_matrix": ("_kinematics", _INTERNAL),
        "initial_values": ("_checks", _INTERNAL),
        "jacobian": ("_kinematics", _INTERNAL),
        "massless": ("_checks", _INTERNAL),
        "name_problem": ("_base", _INTERNAL),
        "numeric_matrix": ("_checks", _INTERNAL),
        "open_at_start": ("_checks", _INTERNAL),
        "parameter_numbers": ("_parts", _INTERNAL),
        "partial_velocities": ("_kinematics", _INTERNAL),
        "probe_states": ("_checks", _INTERNAL),
        "satisfied_by_chart": ("_chart", _INTERNAL),
        "signed_symbol": ("_parts", _INTERNAL),
        "skeleton": ("_assemble", _INTERNAL),
        "time_derivative": ("_kinematics", _INTERNAL),
        "value": ("_checks", _INTERNAL),
        "velocity_form": ("_kinematics", _INTERNAL),
        "without_inertia": ("_checks", _INTERNAL),
    },
)
del moved
