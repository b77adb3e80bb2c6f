"""A system's compiled functions as the loop receives them: plain addresses.

The loop (:mod:`._kernels`, compiled once per machine by :mod:`._jitcache`) takes each
system's functions in the system record as integers, the addresses of their numba cfuncs,
and turns each back into a first-class function of its fixed signature here. Passing the
cfunc objects themselves works too, but numba then asks Python for each function's address
on every call from Python (170-200 us a call of the right-hand side; 5 us this way), and
typing a tuple of them took 0.65 ms.
"""

from __future__ import annotations

from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

__all__ = [
    "SIGNATURES",
    "as_dynamics",
    "as_dynamics_sparse",
    "as_constraints",
    "as_energy",
    "as_restitution",
    "as_switches",
    "as_c3",
    "as_c4",
    "as_c5",
    "as_c8",
    "borrowed",
]

_A1, _A2, _F = types.float64[::1], types.float64[:, ::1], types.float64
SIGNATURES = {
    "c_dynamics": types.Tuple((_A2, _A1, _A2, _A1, _A1))(_F, _A1, _A1, _A1),
    "c_dynamics_sparse": types.Tuple((_A1, _A1, _A1, _A1, _A1))(_F, _A1, _A1, _A1),
    "c_constraints": types.Tuple((_A1, _A2, _A1))(_F, _A1, _A1),
    "c_energy": _A1(_F, _A1, _A1, _A1),
    "c_restitution": _A1(_F, _A1, _A1),
    "c_switches": _A1(_F, _A1, _A1, _A1),
}
"""The cfuncs' signatures, one for every system (C-contiguous float64 arrays)."""


def _caster(signature):
    """An intrinsic: an address (int64) -> the first-class function of ``signature``."""
    ftype = types.FunctionType(signature)

    @intrinsic
    def cast(typingctx, addr):
        if not isinstance(addr, types.Integer):
            return None

        def codegen(context, builder, sig, args):
            fn = cgutils.create_struct_proxy(ftype)(context, builder)
            fn.c_addr = builder.inttoptr(args[0], cgutils.voidptr_t)
            fn.jit_addr = cgutils.get_null_value(cgutils.voidptr_t)
            fn.py_addr = cgutils.get_null_value(context.get_value_type(types.voidptr))
            return fn._getvalue()

        return ftype(addr), codegen

    return cast


as_dynamics = _caster(SIGNATURES["c_dynamics"])
as_dynamics_sparse = _caster(SIGNATURES["c_dynamics_sparse"])
as_constraints = _caster(SIGNATURES["c_constraints"])
as_energy = _caster(SIGNATURES["c_energy"])
as_restitution = _caster(SIGNATURES["c_restitution"])
as_switches = _caster(SIGNATURES["c_switches"])


def _c_signature(pointers: int):
    """A C function ``void f(double t, double *a1, ..., double *ak)`` (:mod:`._cc`), its
    pointers passed as the arrays' addresses (``a.ctypes.data``)."""
    return types.none(_F, *([types.uintp] * pointers))


as_c3 = _caster(_c_signature(3))  # restitution: q, p, e
as_c4 = _caster(_c_signature(4))  # energy, switches: q, v, p, E or s
as_c5 = _caster(_c_signature(5))  # constraints: q, p, f, A, b
as_c8 = _caster(_c_signature(8))  # dynamics, dynamics_sparse: q, v, p and five outputs


@intrinsic
def borrowed(typingctx, a):
    """The array ``a`` with no meminfo: the same data, shape and strides, but numba's
    reference counts on it (an atomic add and subtract at every call that passes it, about
    10 ns each) become a test for NULL. Only for arrays whose owner outlives every use of
    the view: a function's arguments (its caller holds them for the call), or a view of
    an array the function made while another view of that array is used later (numba
    frees a variable after its last use: a DOP853 trial's ``err3`` keeps its space
    alive). Never returned, nor kept past the call. The loop's Python twin is the
    identity (:func:`lamech.numeric._kernels.codes.borrowed`). A change here changes the
    loop's cache key (:func:`._jitcache.engine_text`)."""
    if not isinstance(a, types.Array):
        return None

    def codegen(context, builder, sig, args):
        src = cgutils.create_struct_proxy(a)(context, builder, value=args[0])
        out = cgutils.create_struct_proxy(a)(context, builder)
        for field in ("parent", "nitems", "itemsize", "data", "shape", "strides"):
            setattr(out, field, getattr(src, field))
        out.meminfo = cgutils.get_null_value(out.meminfo.type)
        return out._getvalue()

    return a(a), codegen
