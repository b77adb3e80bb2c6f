"""The kernels of the hot path as Python: one module a concept, and the twin of each in
lamech's engine in C (``lamech/numeric/_engine/*.c``, ``lamech.numeric._cengine``), which computes
the same terms in the same order.

- :mod:`.codes`: the loop's integer codes (events, friction states, statuses, details),
  defined once (``_engine/codes.h`` holds the same values, checked by the tests);
- :mod:`.arrays`: small array operations (largest entry, finiteness, products with the
  constraint matrix);
- :mod:`.kkt`: the system's functions and the KKT solves, the right-hand sides;
- :mod:`.dop853`: DOP853's step, its step-size control and dense output (both loops');
- :mod:`.project`: the projections onto the constraints and the consistent starts;
- :mod:`.modes`: the contact and friction mode, the event functions, their location,
  the settling of a mode;
- :mod:`.impacts`: impacts with restitution and the Zeno accumulation;
- :mod:`.loop`: the loop with events (``simulate`` and ``sweep``);
- :mod:`.batch`: the batch loop without events (:func:`lamech.numeric.integrate_batch`).

Every kernel takes the system record ``sy`` (:data:`SYSTEM_FIELDS`) first: the system's
generated functions and its sparsity pattern arrive as arguments, not as module globals.
:mod:`.._batch` runs them as Python around the system's NumPy functions
(:func:`python_namespace`: the engine ``"python"``, and the rules SciPy's road applies);
the engine in C takes the same records as structs.
"""

from __future__ import annotations

import builtins
import types

from . import arrays, batch, codes, dop853, impacts, kkt, loop, modes, project
from .dop853 import STAGES
from .project import PROJECTION_ITERATIONS

__all__ = [
    "codes",
    "python_namespace",
    "SYSTEM_FIELDS",
    "STAGES",
    "PROJECTION_ITERATIONS",
    "MODULES",
]

MODULES = (arrays, kkt, dop853, project, modes, impacts, loop, batch)
"""The kernels' modules, in the order their text is compiled."""

SYSTEM_FIELDS = (
    "diagonal",
    "PTR",
    "IDX",
    "CPTR",
    "CROW",
    "CPOS",
    "dynamics",
    "dynamics_sparse",
    "constraints",
    "energy",
    "restitution",
    "switches",
    "c",
    "slots",
)
"""The system record ``sy`` every kernel takes first, a tuple in this order: whether M
is diagonal, the sparsity pattern of A (:func:`.._kkt.sparsity`), and the generated
functions of :mod:`.._codegen` (``dynamics(t, q, v, p)`` -> (M, rhs, A, gamma,
mu); ``dynamics_sparse`` -> (M's diagonal, rhs, A's nonzeros in CSR order, gamma, mu);
``constraints(t, q, p)`` -> (f, A, b); ``energy(t, q, v, p)`` -> (T, V) as an array;
``restitution(t, q, p)`` -> e; ``switches(t, q, v, p)`` -> s, the inputs' switching
functions), ``c`` (False here: the functions are Python; the engine in C calls the C
ones of :mod:`.._cc` through pointers in its own record, ``engine.h``'s ``lm_system``),
and ``slots``: where in p each switch's branch is held (0 or 1)."""


def python_namespace() -> dict:
    """The kernels as Python in one namespace, each function's globals that namespace:
    replacing a function there (the NumPy KKT solve for the loops') replaces it for every
    caller."""
    namespace: dict = {"__builtins__": builtins}
    for module in (codes, *MODULES):
        namespace.update(
            (k, v) for k, v in vars(module).items() if not k.startswith("__") and k != "annotations"
        )
    for module in MODULES:
        for name, f in vars(module).items():
            if isinstance(f, types.FunctionType) and f.__module__ == module.__name__:
                namespace[name] = types.FunctionType(f.__code__, namespace, name)
    for module in MODULES:  # whole-array twins of the loops (NumPy's speed as Python)
        namespace.update(getattr(module, "PYTHON", {}))
    return namespace
