"""lamech's engine in C (issue 45): the loop with events, the batch loop, the KKT solves
and the starts, built once when lamech is installed (``setup.py``: the extension module
``lamech.numeric._cengine_lib``, sources in ``lamech/numeric/_engine/``), each problem's
own functions compiled by the machine's C compiler at first use (:mod:`._cc`) and handed
to it as function pointers.

The C is the one implementation of the rules, used by every road: the loops here,
SciPy's integrators through ``rules.c`` (``lamech.numeric._crules``), and systems without compiled
functions, whose NumPy functions the engine calls back (``lamech.numeric._crules.callback_kernels``:
the engine ``"python"``). This module holds the records the C reads (:class:`_System`
and the others, mirrors of ``engine.h``'s structs), checks every array Python hands over
(dtype, order, shape, and the indices the engine follows: a wrong one is a ValueError here, never a
crash there), and gives the engine's entry points the former kernels' Python signatures
(:func:`c_kernels`), so that callers cannot tell the roads apart but by speed.

ctypes, not the CPython API: the engine then needs no Python headers beyond the empty
module that proves it was built (``module.c``), and ctypes releases the GIL for each call,
so a batch's slices run in parallel threads (:func:`_parallel`).
"""

from __future__ import annotations

import ctypes
import importlib.util
import os
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from ._kernels import codes

__all__ = [
    "ABI_VERSION",
    "LIBRARY_ENV",
    "EngineMissing",
    "available",
    "why_missing",
    "library_path",
    "c_kernels",
    "CKernels",
]

ABI_VERSION = 2
"""The version of ``engine.h``'s records this module writes (``lm_abi_version``)."""
LIBRARY_ENV = "LAMECH_ENGINE_LIBRARY"
"""An environment variable naming another build of the engine to load instead of the
installed one (the tests' build with AddressSanitizer; a developer's own). Like
``LD_PRELOAD``, it is the user's own choice of code to run."""

_I64 = ctypes.c_int64
_D = ctypes.c_double
_P = ctypes.c_void_p


class EngineMissing(RuntimeError):
    """The engine was not built (lamech installed without a C compiler), or cannot be
    loaded: the reason in the text."""


class _System(ctypes.Structure):
    _fields_ = [
        ("n", _I64), ("m", _I64), ("np", _I64), ("diagonal", _I64),
        ("PTR", _P), ("IDX", _P), ("CPTR", _P), ("CROW", _P), ("CPOS", _P), ("nnz", _I64),
        ("dynamics", _P), ("dynamics_sparse", _P), ("constraints", _P), ("energy", _P),
        ("restitution", _P), ("switches", _P), ("slots", _P), ("nslots", _I64),
    ]  # fmt: skip


class _Tables(ctypes.Structure):
    _fields_ = [(name, _P) for name in ("A", "B", "C", "E3", "E5", "AX", "CX", "D")]


class _Mode(ctypes.Structure):
    _fields_ = [("m", _I64), ("kinds", _P), ("imode", _P), ("fmode", _P)]


class _Log(ctypes.Structure):
    _fields_ = [
        ("cap", _I64), ("N", _I64), ("kind", _P), ("j", _P), ("t", _P), ("y", _P), ("x", _P),
        ("nwant", _I64), ("want", _P), ("found", _P),
    ]  # fmt: skip


class _Samples(ctypes.Structure):
    _fields_ = [
        ("S", _I64), ("N", _I64), ("m", _I64), ("TS", _P), ("SY", _P), ("SL", _P), ("SR", _P),
    ]  # fmt: skip


_REF = ctypes.POINTER
_SIGNATURES = {
    "lm_abi_version": (_I64, []),
    "lm_ev_segment": (_I64, [
        _REF(_System), _REF(_Tables), _P, _REF(_Mode), _P, _P, _REF(_Log), _I64,
        _REF(_Samples), _P, _P, _P, _P, _P, _P,
    ]),
    "lm_ev_run": (_I64, [
        _REF(_System), _REF(_Tables), _I64, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P, _I64,
        _I64, _P, _P, _P, _P, _P, _P, _P, _P, _P, _P,
    ]),
    "lm_ev_starts": (_I64, [_REF(_System), _I64, _P, _P, _P, _P, _P, _P, _P, _P, _D]),
    "lm_batch_run": (_I64, [_REF(_System), _REF(_Tables), _I64, _P, _P, _P, _P, _P, _P]),
    "lm_rhs_kernel": (_I64, [_REF(_System), _D, _P, _P, _P, _I64, _P, _P, _P, _I64, _P]),
    "lm_accelerations_entry": (_I64, [_REF(_System), _D, _P, _P, _P]),
    "lm_kkt_solve_entry": (_I64, [
        _REF(_System), _P, _P, _P, _P, _P, _P, _I64, _P, _P, _P, _I64, _P,
    ]),
    # rules.c
    "lm_rule_start": (_I64, [_REF(_System), _D, _P, _P, _REF(_Mode), _P, _REF(_Log), _I64, _P]),
    "lm_rule_settle": (_I64, [_REF(_System), _D, _P, _P, _REF(_Mode), _P, _REF(_Log), _I64, _P]),
    "lm_rule_apply": (_I64, [
        _REF(_System), _D, _P, _P, _I64, _I64, _P, _I64, _P, _I64, _P, _P, _P, _I64,
        _REF(_Mode), _P, _P, _REF(_Log), _I64, _P,
    ]),
    "lm_rule_switch": (_I64, [
        _REF(_System), _D, _P, _P, _I64, _REF(_Mode), _P, _REF(_Log), _I64, _P,
    ]),
    "lm_rule_values": (_I64, [
        _REF(_System), _D, _P, _P, _P, _P, _I64, _REF(_Mode), _P, _I64, _P, _I64, _P, _P, _P,
        _I64, _P, _P,
    ]),
    "lm_rule_arm": (_I64, [_REF(_System), _D, _P, _P, _P, _P, _I64, _REF(_Mode), _P, _P]),
    "lm_rule_project": (_I64, [_REF(_System), _D, _P, _P, _P, _I64, _P, _I64, _P]),
    "lm_rule_accumulated": (_I64, [
        _REF(_System), _D, _P, _P, _REF(_Mode), _REF(_Log), _I64, _P,
    ]),
    "lm_rule_dips": (_I64, [
        _REF(_System), _D, _D, _P, _I64, _P, _P, _P, _I64, _REF(_Mode), _P, _I64, _P, _I64,
        _P, _P, _P, _I64, _P, _P, _P, _P, _P,
    ]),
    "lm_rule_lock": (_I64, [_REF(_System), _D, _P, _P]),
    "lm_rule_crossed": (_I64, [_REF(_System), _D, _P, _P, _P, _P]),
    "lm_rule_mode": (None, [_REF(_Mode), _P, _P, _P, _P, _P, _P]),
    "lm_rule_watch": (_I64, [_REF(_Mode), _P, _P]),
    "lm_rule_functions": (None, [
        _P, _P, _I64, _REF(_Mode), _P, _P, _I64, _P, _P, _P, _P, _P, _P,
    ]),
    "lm_rule_bound": (_D, [_D, _REF(_Mode)]),
    "lm_rule_depth": (_D, [_P, _P, _I64]),
    "lm_rule_dip_time": (_D, [_D, _D, _I64, _I64]),
    "lm_rule_again": (_I64, [_I64, _I64, _D, _D, _REF(_Mode)]),
}  # fmt: skip

_LIB: dict[str, object] = {}
_LIB_LOCK = threading.Lock()


def library_path() -> Path | None:
    """The engine's built library (the extension module's file), or None where lamech
    was installed without it."""
    spec = importlib.util.find_spec("lamech.numeric._cengine_lib")
    if spec is None or not spec.origin:
        return None
    return Path(spec.origin)


def _library() -> ctypes.CDLL:
    """The engine, loaded once (its entry points typed); raises :class:`EngineMissing`."""
    with _LIB_LOCK:
        lib = _LIB.get("lib")
        if isinstance(lib, ctypes.CDLL):
            return lib
        if "error" in _LIB:
            raise EngineMissing(str(_LIB["error"]))
        try:
            path = library_path()
            other = os.environ.get(LIBRARY_ENV)
            if other:  # the tests' sanitizer build, or a developer's own
                path = Path(other)
            else:
                import lamech.numeric._cengine_lib as module  # noqa: F401  (built at install)
            if path is None:  # pragma: no cover - imported, yet no file
                raise ImportError("the engine's file is not found")
            lib = ctypes.CDLL(str(path))
            for name, (restype, argtypes) in _SIGNATURES.items():
                fn = getattr(lib, name)
                fn.restype, fn.argtypes = restype, argtypes
            version = lib.lm_abi_version()
            if version != ABI_VERSION:
                raise ImportError(
                    f"the engine's records are version {version}, this lamech writes "
                    f"{ABI_VERSION}: reinstall lamech (pip install -e . or ./run-tests)"
                )
        except (ImportError, OSError, AttributeError) as exc:
            _LIB["error"] = (
                f"lamech's C engine is not available ({exc}); it is built when lamech is "
                "installed, which needs a C compiler (gcc or clang): install one and "
                "reinstall lamech"
            )
            raise EngineMissing(str(_LIB["error"])) from exc
        _LIB["lib"] = lib
        return lib


def _fast_module():
    """The extension module's own functions of a right-hand side (``module.c``), or None
    where another build of the engine is loaded (:data:`LIBRARY_ENV`: it has only the
    ctypes entry points) or the module has none."""
    if os.environ.get(LIBRARY_ENV):
        return None
    try:
        import lamech.numeric._cengine_lib as module
    except ImportError:  # pragma: no cover - _library() imported it already
        return None
    return module if hasattr(module, "rhs") and hasattr(module, "accelerations") else None


def available() -> bool:
    """Whether the engine was built and loads."""
    try:
        _library()
    except EngineMissing:
        return False
    return True


def why_missing() -> str | None:
    """Why the engine is not available (None where it is)."""
    try:
        _library()
    except EngineMissing as exc:
        return str(exc)
    return None


# ----- checks of what Python hands over -------------------------------------------------
def _addr(a, dtype, shape, name: str, writable: bool = False) -> int:
    """The address of array ``a`` after checking it: an ndarray of ``dtype``, C order,
    of ``shape`` (None: any length on that axis), writable where the engine writes it."""
    if not isinstance(a, np.ndarray) or a.dtype != dtype:
        raise ValueError(f"engine: {name} must be a NumPy array of {np.dtype(dtype)}")
    if a.ndim != len(shape) or any(s is not None and s != d for s, d in zip(shape, a.shape)):
        raise ValueError(f"engine: {name} has shape {a.shape}, expected {shape}")
    if not a.flags.c_contiguous:
        raise ValueError(f"engine: {name} must be C-contiguous")
    if writable and not a.flags.writeable:
        raise ValueError(f"engine: {name} must be writable")
    return a.ctypes.data


def _in_range(a: np.ndarray, low: int, high: int, name: str) -> None:
    """Every entry of the integer array ``a`` in [low, high)."""
    if a.size and (int(a.min()) < low or int(a.max()) >= high):
        raise ValueError(f"engine: {name} holds an index outside [{low}, {high})")


_F, _I, _B = np.float64, np.int64, np.bool_


class _Tabled:
    """DOP853's tables as the engine's record, made once per tuple of tables (the
    arrays kept alive with it)."""

    def __init__(self, tab: tuple):
        shapes = [(12, 12), (12,), (12,), (13,), (13,), (3, 16), (3,), (4, 16)]
        names = ("A", "B", "C", "E3", "E5", "A_EXTRA", "C_EXTRA", "D")
        if len(tab) != 8:
            raise ValueError("engine: DOP853's tables are 8 arrays")
        self.arrays = tab
        addresses = [_addr(a, _F, s, n) for a, s, n in zip(tab, shapes, names)]
        self.record = _Tables(*addresses)


_TABLES: dict[int, _Tabled] = {}


def _tables_record(tab: tuple) -> _Tables:
    known = _TABLES.get(id(tab[0]))
    if known is None or known.arrays[0] is not tab[0] or known.arrays is not tab:
        known = _TABLES[id(tab[0])] = _Tabled(tab)
    return known.record


class CKernels:
    """A system's functions on the C engine: ``functions`` {name: callable} with the
    kernels' Python signatures (the system record bound), ``cache`` where the system's
    own library came from (:func:`._cc.load`: ``"loaded"``, ``"compiled"`` or
    ``"memory"``), ``path`` that library's file in the cache folder (None: in memory)."""

    def __init__(self, pattern, diagonal: bool, n: int, m: int, nparams: int, addresses,
                 slots, keep, cache: str, path: Path | None, calls=None):  # fmt: skip
        lib = _library()
        # ``calls``: the system's functions are Python called back (``lamech.numeric._crules``); an
        # exception one raised comes back here after the entry point returns
        self.lib = lib if calls is None else _Checked(lib, calls)
        self.parallel = calls is None  # a callback holds the GIL: one thread
        PTR, IDX, CPTR, CROW, CPOS = (np.ascontiguousarray(a, dtype=_I) for a in pattern)
        slots = np.ascontiguousarray(slots, dtype=_I).reshape(-1)
        if PTR.shape != (m + 1,) or CPTR.shape != (n + 1,):
            raise ValueError("engine: the sparsity pattern does not fit the system")
        nnz = int(PTR[-1]) if m else 0
        if PTR[0] != 0 or np.any(np.diff(PTR) < 0) or IDX.shape != (nnz,):
            raise ValueError("engine: the sparsity pattern's rows are not CSR")
        columns_ok = CROW.shape == CPOS.shape == (nnz,)
        if CPTR[0] != 0 or np.any(np.diff(CPTR) < 0) or not columns_ok:
            raise ValueError("engine: the sparsity pattern's columns are not CSC")
        if int(CPTR[-1]) != nnz:
            raise ValueError("engine: the sparsity pattern's rows and columns disagree")
        _in_range(IDX, 0, max(n, 1), "the pattern's columns")
        _in_range(CROW, 0, max(m, 1), "the pattern's rows")
        _in_range(CPOS, 0, max(nnz, 1), "the pattern's positions")
        _in_range(slots, 0, max(nparams, 1), "the switches' slots")
        if len(addresses) != 6 or not all(addresses):
            raise ValueError("engine: a system needs its 6 functions")
        self.n, self.m, self.np = n, m, nparams
        self.arrays = (PTR, IDX, CPTR, CROW, CPOS, slots)
        self.keep = keep  # the system's library: its functions' addresses stay valid
        self.record = _System(
            n, m, nparams, int(bool(diagonal)),
            PTR.ctypes.data, IDX.ctypes.data, CPTR.ctypes.data, CROW.ctypes.data,
            CPOS.ctypes.data, nnz, *addresses, slots.ctypes.data, slots.shape[0],
        )  # fmt: skip
        self.ref = ctypes.byref(self.record)
        self.address = ctypes.addressof(self.record)
        # the extension's own right-hand side; not with callbacks (their exceptions are
        # raised again by _Checked around the ctypes calls)
        self.fast = _fast_module() if calls is None else None
        self.cache, self.path = cache, path
        self.functions = {
            "kkt_solve": self.kkt_solve,
            "rhs_kernel": self.rhs_kernel,
            "accelerations": self.accelerations,
            "batch_run": self.batch_run,
            "batch_run_serial": self.batch_run_serial,
            "ev_run": self.ev_run,
            "ev_starts": self.ev_starts,
            "ev_segment": self.ev_segment,
            "dynamics": None,  # called by the engine only
            "constraints": None,
        }

    @staticmethod
    def _status(code: int) -> None:
        if code == codes.ST_MEMORY:
            raise MemoryError("lamech's engine could not allocate its scratch memory")

    # --- the KKT solves and right-hand sides -----------------------------------------
    def _act(self, rows, slip_j, slip_k, slip_c):
        m = self.m
        ns = slip_j.shape[0] if isinstance(slip_j, np.ndarray) else 0
        a = (
            _addr(rows, _I, (None,), "rows"),
            _addr(slip_j, _I, (ns,), "slip_j"),
            _addr(slip_k, _I, (ns,), "slip_k"),
            _addr(slip_c, _F, (ns,), "slip_c"),
        )
        na = rows.shape[0]
        if na > m:
            raise ValueError("engine: more active rows than constraints")
        _in_range(rows, 0, max(m, 1), "rows")
        _in_range(slip_j, 0, max(m, 1), "slip_j")
        _in_range(slip_k, 0, max(na, 1), "slip_k")
        return a, na, ns

    def rhs_kernel(self, t, y, p, rows, slip_j, slip_k, slip_c):
        """y' = [v; q''] on the active rows (the kernel ``rhs_kernel``)."""
        N = 2 * self.n
        if self.fast is not None:  # the extension's own function: checked in C
            out = np.empty(N)
            y = np.ascontiguousarray(y, dtype=_F)
            self._status(
                self.fast.rhs(self.address, float(t), y, p, rows, slip_j, slip_k, slip_c, out)
            )
            return out
        (r, sj, sk, sc), na, ns = self._act(rows, slip_j, slip_k, slip_c)
        y = np.ascontiguousarray(y, dtype=_F)
        out = np.empty(N)
        self._status(self.lib.lm_rhs_kernel(
            self.ref, float(t), _addr(y, _F, (N,), "y"), _addr(p, _F, (self.np,), "p"),
            r, na, sj, sk, sc, ns, out.ctypes.data,
        ))  # fmt: skip
        return out

    def accelerations(self, t, y, p):
        """[q''; lambda] with every constraint active (the kernel ``accelerations``)."""
        y = np.ascontiguousarray(y, dtype=_F)
        out = np.empty(self.n + self.m)
        if self.fast is not None:  # the extension's own function: checked in C
            self._status(self.fast.accelerations(self.address, float(t), y, p, out))
            return out
        self._status(self.lib.lm_accelerations_entry(
            self.ref, float(t), _addr(y, _F, (2 * self.n,), "y"),
            _addr(p, _F, (self.np,), "p"), out.ctypes.data,
        ))  # fmt: skip
        return out

    def kkt_solve(self, M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c):
        """[q''; lambda on the active rows] (the kernel ``kkt_solve``)."""
        n, m = self.n, self.m
        M, rhs, A, gam, mu = (np.ascontiguousarray(x, dtype=_F) for x in (M, rhs, A, gam, mu))
        (r, sj, sk, sc), na, ns = self._act(rows, slip_j, slip_k, slip_c)
        out = np.empty(n + na)
        self._status(self.lib.lm_kkt_solve_entry(
            self.ref, _addr(M, _F, (n, n), "M"), _addr(rhs, _F, (n,), "rhs"),
            _addr(A, _F, (m, n), "A"), _addr(gam, _F, (m,), "gamma"),
            _addr(mu, _F, (m,), "mu"), r, na, sj, sk, sc, ns, out.ctypes.data,
        ))  # fmt: skip
        return out

    # --- the loops -------------------------------------------------------------------
    def _check_kinds(self, kinds) -> int:
        m = self.m
        a = _addr(kinds, _I, (3, m), "kinds")
        _in_range(kinds[:2], 0, 2, "kinds' flags")
        _in_range(kinds[2], -1, max(m, 1), "kinds' normals")
        return a

    def batch_run(self, Y0, P, tab, tl, lim, out, steps):
        """Every row of Y0 to t_end (the kernel ``batch_run``), slices in parallel threads."""
        B = Y0.shape[0] if isinstance(Y0, np.ndarray) else 0
        self._batch_checks(Y0, P, tab, tl, lim, out, steps)
        if not self.parallel:
            self._batch_part(Y0, P, tab, tl, lim, out, steps, 0, B)
            return
        _parallel(B, lambda a, b: self._batch_part(Y0, P, tab, tl, lim, out, steps, a, b))

    def batch_run_serial(self, Y0, P, tab, tl, lim, out, steps):
        """:meth:`batch_run` in this thread."""
        self._batch_checks(Y0, P, tab, tl, lim, out, steps)
        self._batch_part(Y0, P, tab, tl, lim, out, steps, 0, Y0.shape[0])

    def _batch_checks(self, Y0, P, tab, tl, lim, out, steps) -> None:
        N = 2 * self.n
        B = Y0.shape[0] if isinstance(Y0, np.ndarray) and Y0.ndim == 2 else -1
        _addr(Y0, _F, (None, N), "Y0")
        _addr(P, _F, (B, self.np), "P")
        _addr(tl, _F, (codes.TL_SIZE,), "tl")
        _addr(lim, _I, (codes.LM_SIZE,), "lim")
        _addr(out, _F, (B, N), "out", True)
        _addr(steps, _I, (B,), "steps", True)
        _tables_record(tab)

    def _batch_part(self, Y0, P, tab, tl, lim, out, steps, a: int, b: int) -> None:
        if b <= a:
            return
        self._status(self.lib.lm_batch_run(
            self.ref, ctypes.byref(_tables_record(tab)), b - a, Y0[a:b].ctypes.data,
            P[a:b].ctypes.data, tl.ctypes.data, lim.ctypes.data, out[a:b].ctypes.data,
            steps[a:b].ctypes.data,
        ))  # fmt: skip

    def ev_starts(self, Q, V, P, hold_q, hold_v, value_q, value_v, kinds, tol):
        """Every row of Q, V made consistent in place (the kernel ``ev_starts``)."""
        n = self.n
        B = Q.shape[0] if isinstance(Q, np.ndarray) and Q.ndim == 2 else -1
        self._status(self.lib.lm_ev_starts(
            self.ref, B, _addr(Q, _F, (B, n), "Q", True), _addr(V, _F, (B, n), "V", True),
            _addr(P, _F, (B, self.np), "P"), _addr(hold_q, _B, (n,), "hold_q"),
            _addr(hold_v, _B, (n,), "hold_v"), _addr(value_q, _F, (n,), "value_q"),
            _addr(value_v, _F, (n,), "value_v"), self._check_kinds(kinds), float(tol),
        ))  # fmt: skip

    def mode_record(self, md) -> _Mode:
        """The mode (kinds, imode, fmode) checked, as the engine's record."""
        m = self.m
        kinds, imode, fmode = md
        mode = _Mode(m, self._check_kinds(kinds), _addr(imode, _I, (4, m), "imode", True),
                     _addr(fmode, _F, (5, m), "fmode", True))  # fmt: skip
        _in_range(imode[1], 0, 4, "imode's friction states")
        return mode

    def log_record(self, lg, nev) -> _Log:
        """The event record lg (kinds, constraints, times, states, details, want, found)
        checked, with the count ``nev`` of events in it, as the engine's record."""
        m, N = self.m, 2 * self.n
        EK, EJ, ET, EY, EX, want, found = lg
        cap = EK.shape[0] if isinstance(EK, np.ndarray) and EK.ndim == 1 else -1
        w = want.shape[1] if isinstance(want, np.ndarray) and want.ndim == 2 else -1
        _in_range(want[1], -1, max(m, 1), "want's constraints")
        log = _Log(
            cap, N, _addr(EK, _I, (cap,), "EK", True), _addr(EJ, _I, (cap,), "EJ", True),
            _addr(ET, _F, (cap,), "ET", True), _addr(EY, _F, (cap, N), "EY", True),
            _addr(EX, _F, (cap, 4), "EX", True), w, _addr(want, _I, (2, w), "want"),
            _addr(found, _B, (w,), "found", True),
        )  # fmt: skip
        if not 0 <= int(nev) <= cap:
            raise ValueError("engine: nev outside the event record")
        return log

    def ev_segment(self, p, tab, md, tl, lim, lg, nev, smp, y, io, fo):
        """The loop with events from (fo[FO_T], y) (the kernel ``ev_segment``): (t,
        status, events logged, steps)."""
        m, N = self.m, 2 * self.n
        mode = self.mode_record(md)
        log = self.log_record(lg, nev)
        TS, SY, SL, SR = smp
        S = TS.shape[0] if isinstance(TS, np.ndarray) and TS.ndim == 1 else -1
        samples = _Samples(
            S, N, m, _addr(TS, _F, (S,), "TS"), _addr(SY, _F, (S, N), "SY", True),
            _addr(SL, _F, (S, m), "SL", True), _addr(SR, _F, (S, 4), "SR", True),
        )  # fmt: skip
        _addr(io, _I, (codes.IO_SIZE,), "io", True)
        if not 0 <= int(io[codes.IO_NEXT]) <= S:
            raise ValueError("engine: the next sample is outside the samples")
        t, nev_out, steps = _D(), _I64(), _I64()
        status = self.lib.lm_ev_segment(
            self.ref, ctypes.byref(_tables_record(tab)), _addr(p, _F, (self.np,), "p", True),
            ctypes.byref(mode), _addr(tl, _F, (codes.TL_SIZE,), "tl"),
            _addr(lim, _I, (codes.LM_SIZE,), "lim"), ctypes.byref(log), int(nev),
            ctypes.byref(samples), _addr(y, _F, (N,), "y", True), io.ctypes.data,
            _addr(fo, _F, (codes.FO_SIZE,), "fo", True), ctypes.byref(t),
            ctypes.byref(nev_out), ctypes.byref(steps),
        )  # fmt: skip
        self._status(status)
        return t.value, int(status), nev_out.value, steps.value

    def ev_run(self, Y0, P, tab, modes, start, tl, lim, want, logs, outs):
        """Every row of Y0 through the loop with events (the kernel ``ev_run``), in this
        thread (the caller spreads slices over threads)."""
        n, m, N = self.n, self.m, 2 * self.n
        B = Y0.shape[0] if isinstance(Y0, np.ndarray) and Y0.ndim == 2 else -1
        kinds, IM, FM = modes
        hold, value = start
        EK, EJ, ET, EY, EX = logs
        YOUT, TOUT, STATUS, NEV, STEPS = outs
        cap = EK.shape[1] if isinstance(EK, np.ndarray) and EK.ndim == 2 else -1
        w = want.shape[1] if isinstance(want, np.ndarray) and want.ndim == 2 else -1
        _in_range(IM[:, 1, :] if isinstance(IM, np.ndarray) and IM.ndim == 3 else np.zeros(0, _I),
                  0, 4, "IM's friction states")  # fmt: skip
        _in_range(want[1], -1, max(m, 1), "want's constraints")
        self._status(self.lib.lm_ev_run(
            self.ref, ctypes.byref(_tables_record(tab)), B, _addr(Y0, _F, (B, N), "Y0", True),
            _addr(P, _F, (B, self.np), "P", True), self._check_kinds(kinds),
            _addr(IM, _I, (B, 4, m), "IM", True), _addr(FM, _F, (B, 5, m), "FM", True),
            _addr(hold, _B, (2, n), "hold"), _addr(value, _F, (2, n), "value"),
            _addr(tl, _F, (codes.TL_SIZE,), "tl"), _addr(lim, _I, (codes.LM_SIZE,), "lim"),
            _addr(want, _I, (2, w), "want"), w, cap,
            _addr(EK, _I, (B, cap), "EK", True), _addr(EJ, _I, (B, cap), "EJ", True),
            _addr(ET, _F, (B, cap), "ET", True), _addr(EY, _F, (B, cap, N), "EY", True),
            _addr(EX, _F, (B, cap, 4), "EX", True), _addr(YOUT, _F, (B, N), "YOUT", True),
            _addr(TOUT, _F, (B,), "TOUT", True), _addr(STATUS, _I, (B,), "STATUS", True),
            _addr(NEV, _I, (B,), "NEV", True), _addr(STEPS, _I, (B,), "STEPS", True),
        ))  # fmt: skip


class _Checked:
    """The engine's library for a system whose functions are called back in Python: each
    entry point run, then the first exception a callback raised (``calls.error``; the
    callback returned NaN instead) raised here."""

    def __init__(self, lib, calls):
        self._lib, self._calls = lib, calls

    def __getattr__(self, name: str):
        fn = getattr(self._lib, name)
        calls = self._calls

        def call(*args):
            calls.error = None
            try:
                return fn(*args)
            finally:
                error, calls.error = calls.error, None
                if error is not None:
                    raise error

        return call


def _threads() -> int:
    """The CPUs this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - macOS, Windows
        return os.cpu_count() or 1


def _parallel(B: int, part) -> None:
    """part(a, b) over slices of B rows in as many threads as CPUs (the engine runs
    without the GIL); one slice in this thread where B is smaller than that."""
    k = max(1, min(_threads(), B))
    if k == 1:
        part(0, B)
        return
    cuts = np.linspace(0, B, k + 1).astype(int)
    with ThreadPoolExecutor(k) as pool:
        list(pool.map(part, cuts[:-1], cuts[1:]))


_KERNELS: dict[tuple, CKernels] = {}
_KERNELS_LOCK = threading.Lock()


def c_kernels(ns_pattern, diagonal: bool, n: int, m: int, nparams: int, c_source: str,
              slots=()) -> CKernels:  # fmt: skip
    """The system whose C is ``c_source`` on the engine: its library from the cache
    folder, or compiled now (:func:`._cc.load`), once per process and cache folder.
    Raises :class:`EngineMissing` or :class:`._cc.CompileFailed`."""
    from . import _cc
    from ._cc import cache_dir

    _library()
    folder = cache_dir()
    key = (str(folder), c_source, tuple(_cc.compiler() or ()))
    with _KERNELS_LOCK:
        known = _KERNELS.get(key)
        if known is not None:
            return known
        lib, addresses, state = _cc.load(c_source, folder)
        from ._trust import cache_place

        place = cache_place(folder, make=False).path
        path = _cc.library_path(c_source, place) if state != "memory" and place else None
        kernels = CKernels(ns_pattern, diagonal, n, m, nparams, addresses, slots, lib, state, path)
        _KERNELS[key] = kernels
        return kernels
