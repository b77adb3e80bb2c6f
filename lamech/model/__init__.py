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

from ._assemble import assemble, skeleton, split_lagrangian
from ._base import FIELDS, ConstraintKind, ModelError, SceneryKind, ShapeKind, name_problem
from ._chart import Chart, ChartProposal, circle_chart, satisfied_by_chart, with_chart
from ._checks import (
    INITIAL_TOLERANCE,
    Inertialess,
    dependent_constraints,
    dependent_group,
    holding_at_start,
    initial_values,
    massless,
    numeric_matrix,
    open_at_start,
    probe_states,
    value,
    without_inertia,
)
from ._kinematics import (
    angular_velocity,
    body_energy,
    body_rotation,
    constraint_jacobian,
    contact_partial_velocities,
    gradient,
    inertia_matrix,
    jacobian,
    partial_velocities,
    time_derivative,
    velocity_form,
)
from ._loads import AppliedForce, Load, Spring, Torque, load_terms
from ._parts import (
    Body,
    Constraint,
    Coordinate,
    ForceSpec,
    Friction,
    Parameter,
    Scenery,
    coordinate,
    parameter,
    parameter_numbers,
    parameters,
    signed_symbol,
)
from ._system import System
from ._values import with_values

__all__ = [
    "angular_velocity",
    "body_rotation",
    "inertia_matrix",
    "Parameter",
    "Chart",
    "ChartProposal",
    "circle_chart",
    "satisfied_by_chart",
    "with_chart",
    "Coordinate",
    "Friction",
    "ForceSpec",
    "Constraint",
    "Body",
    "Scenery",
    "SceneryKind",
    "System",
    "ModelError",
    "ConstraintKind",
    "ShapeKind",
    "FIELDS",
    "name_problem",
    "time_derivative",
    "body_energy",
    "partial_velocities",
    "contact_partial_velocities",
    "velocity_form",
    "constraint_jacobian",
    "jacobian",
    "gradient",
    "INITIAL_TOLERANCE",
    "value",
    "numeric_matrix",
    "initial_values",
    "probe_states",
    "holding_at_start",
    "open_at_start",
    "dependent_constraints",
    "dependent_group",
    "Inertialess",
    "massless",
    "without_inertia",
    "with_values",
    "parameter",
    "parameters",
    "parameter_numbers",
    "signed_symbol",
    "coordinate",
    "AppliedForce",
    "Torque",
    "Spring",
    "Load",
    "load_terms",
    "assemble",
    "skeleton",
    "split_lagrangian",
]
