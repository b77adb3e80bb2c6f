"""The kernels of the hot path, as plain Python that numba compiles: one module a concept.

- :mod:`.codes`: the loop's integer codes (events, friction states, statuses, details);
- :mod:`.arrays`: small array operations as loops (largest entry, finiteness, products
  with the constraint matrix);
- :mod:`.kkt`: the system's functions and the KKT solves, the right-hand sides;
- :mod:`.dop853`: DOP853's step, its step-size control and dense output (both loops');
- :mod:`.project`: the projections onto the constraints and the consistent starts;
- :mod:`.modes`: the contact and friction mode, the event functions, their location,
  the settling of a mode;
- :mod:`.impacts`: impacts with restitution and the Zeno accumulation;
- :mod:`.loop`: the loop with events (``simulate`` and ``sweep``);
- :mod:`.batch`: the batch loop without events (:func:`lamech.numeric.integrate_batch`).

Every kernel takes the system record ``sy`` (:data:`SYSTEM_FIELDS`) first: the system's
generated functions and its sparsity pattern arrive as arguments, not as module globals,
so that the same compiled code serves every system. :mod:`.._jitcache` compiles the text
of these modules, each from its ``KERNELS`` line on, in the order of :data:`MODULES`, as
one module (:func:`kernel_text`), once per machine (numba's cache on disk), with each
system's functions as numba cfuncs (first-class functions of one signature);
:mod:`.._batch` runs the same functions as Python around the NumPy ones
(:func:`python_namespace`: the same numbers, slowly).
"""

from __future__ import annotations

import builtins
import inspect
import types

from . import arrays, batch, codes, dop853, impacts, kkt, loop, modes, project
from .dop853 import STAGES
from .project import PROJECTION_ITERATIONS

__all__ = [
    "INLINE",
    "kernel_text",
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
functions), ``c``, and ``slots``: where in p each switch's branch is held (0 or 1).
Compiled, the functions are the addresses of numba cfuncs of one signature for every
system (:mod:`.._jitcache`, :mod:`.._fnptr`), so that the loop is compiled once, not per
system; ``c`` says they are C functions instead (:mod:`.._cc`), which fill arrays passed
by address (:mod:`.kkt`)."""

INLINE = frozenset(name for module in MODULES for name in getattr(module, "INLINE", ()))
"""The kernels numba inlines where they are called (each module's ``INLINE``): a call
passes its arrays with a reference count taken and dropped for each, which in the
right-hand side's chain of small calls cost a third of a step's time (perf, 2026-11-27)."""

MARK = "\n# KERNELS\n"


def _kernels_of(module: types.ModuleType) -> str:
    """A module's text from its ``KERNELS`` line on."""
    text = inspect.getsource(module)
    return text[text.index(MARK) + 1 :]


def kernel_text() -> str:
    """The kernels as one module's text (:func:`.._jitcache.engine_text` compiles it): the
    codes, then each of :data:`MODULES` from its ``KERNELS`` line on."""
    parts = [codes.constants_text()] + [_kernels_of(m) for m in MODULES]
    return "\n\n\n".join(part.strip("\n") for part in parts) + "\n"


def python_namespace() -> dict:
    """The kernels as Python in one namespace, each function's globals that namespace (as
    in the compiled module, where they all share one): replacing a function there (the
    NumPy KKT solve for the compiled one) replaces it for every caller."""
    # A module's globals hold __builtins__; numba's dispatchers (a compiled system's
    # functions in ``sy``) look it up in their caller's globals (KeyError without it).
    namespace: dict = {"__builtins__": builtins}
    for module in (codes, *MODULES):
        namespace.update(
            (k, v) for k, v in vars(module).items() if not k.startswith("__") and k != "annotations"
        )
    for module in MODULES:
        for name, f in vars(module).items():
            if isinstance(f, types.FunctionType) and f.__module__ == module.__name__:
                namespace[name] = types.FunctionType(f.__code__, namespace, name)
    for module in MODULES:  # whole-array twins of loops written for numba
        namespace.update(getattr(module, "PYTHON", {}))
    return namespace
