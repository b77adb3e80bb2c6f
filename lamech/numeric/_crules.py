"""The rules of the contact and friction mode on lamech's engine in C, for every road
(issue 45: one implementation of every rule): :class:`CRules` gives ``rules.c``'s entry
points the Python signatures SciPy's road calls (:func:`._run.rules`), and
:func:`engine_kernels` the engine for any system: its compiled functions where it has
them (``lamech.numeric._cengine.c_kernels``), else its NumPy functions called back from C
(:class:`Callbacks`: a system run with ``jit=False``, without a C compiler, whose C
failed to compile, or with a function replaced, :attr:`NumericSystem.replaced`).

A callback fills the arrays the engine hands it, as the generated C does (``engine.h``'s
``lm_dynamics_fn`` and the others). A function evaluated out of an expression's domain
(ValueError, ArithmeticError: ``math.sqrt(-1)``, an overflow, a division by zero)
fills NaN, as the compiled C does (``sqrt(-1)`` is NaN there): the engine then rejects
the trial step or reports the failure, and the Python side names the cause
(:meth:`._run.Run.kkt`). Any other exception (a replaced function's own error, Ctrl-C)
is kept, the calls after it return NaN, and it is raised again in Python when the entry
point returns (``lamech.numeric._cengine._Checked``).
"""

from __future__ import annotations

import ctypes
import threading

import numpy as np

from ._cengine import _F, _I, CKernels, _addr, _in_range, _library, _Mode, c_kernels
from ._kernels import codes

__all__ = ["CRules", "Callbacks", "engine_kernels", "callback_kernels", "rules_of"]

_D = ctypes.c_double
_P = ctypes.c_void_p
_DYNAMICS = ctypes.CFUNCTYPE(None, _D, _P, _P, _P, _P, _P, _P, _P, _P)
_CONSTRAINTS = ctypes.CFUNCTYPE(None, _D, _P, _P, _P, _P, _P)
_ENERGY = ctypes.CFUNCTYPE(None, _D, _P, _P, _P, _P)  # also the switches'
_RESTITUTION = ctypes.CFUNCTYPE(None, _D, _P, _P, _P)


_ARRAYS: dict[int, type] = {}


def _view(address, count: int) -> np.ndarray:
    """The engine's ``count`` doubles at ``address`` as a NumPy array (no copy)."""
    if not count or not address:
        return np.zeros(0)
    kind = _ARRAYS.get(count)
    if kind is None:
        kind = _ARRAYS[count] = _D * count  # ctypes makes the type anew each time: 1.3 us
    return np.frombuffer(kind.from_address(address), dtype=np.float64)  # type: ignore[attr-defined]


class Callbacks:
    """The NumPy functions of ``ns`` as C function pointers (``addresses``, in the order
    of ``lm_system``'s fields: dynamics, dynamics_sparse, constraints, energy,
    restitution, switches); ``error`` the first exception one raised since the engine's
    entry point was entered, in the calling thread (threads may share the system)."""

    def __init__(self, ns):
        n, m, K = ns.n, ns.m, len(ns.switch_names)
        npar = len(ns.parameters)
        PTR, IDX = (np.asarray(a, dtype=np.int64) for a in ns.pattern[:2])
        erow = np.repeat(np.arange(m), np.diff(PTR)) if m else np.zeros(0, dtype=np.int64)
        nnz = IDX.shape[0]
        self._local = threading.local()  # a callback runs in the thread that called the engine
        f_dyn, f_con, f_en = ns.dynamics, ns.constraints, ns.energy
        f_res, f_sw = ns.restitution, ns.switches

        def args(t, q, v, p):
            return float(t), _view(q, n).copy(), _view(v, n).copy(), _view(p, npar).copy()

        def fill(pairs) -> None:
            for address, count, value in pairs:
                if count:
                    _view(address, count)[:] = np.ravel(np.asarray(value, dtype=float))

        def nan(pairs) -> None:
            for address, count in pairs:
                if count:
                    _view(address, count)[:] = np.nan

        def guarded(body, outputs):
            def call(*a):
                if self.error is None:
                    try:
                        body(*a)
                        return
                    except (ValueError, ArithmeticError):
                        pass  # out of an expression's domain: NaN, as the compiled C gives
                    except BaseException as exc:  # noqa: BLE001 - raised again after the call
                        self.error = exc
                nan(outputs(*a))

            return call

        def dynamics(t, q, v, p, M, rhs, A, gam, mu):
            out = f_dyn(*args(t, q, v, p))
            fill(zip((M, rhs, A, gam, mu), (n * n, n, m * n, m, m), out))

        def dynamics_sparse(t, q, v, p, Md, rhs, Av, gam, mu):
            M, r, A, g, u = f_dyn(*args(t, q, v, p))
            M, A = np.asarray(M, dtype=float), np.asarray(A, dtype=float).reshape(m, n)
            fill(zip((Md, rhs, Av, gam, mu), (n, n, nnz, m, m),
                     (np.diagonal(M), r, A[erow, IDX], g, u)))  # fmt: skip

        def constraints(t, q, p, f, A, b):
            out = f_con(float(t), _view(q, n).copy(), _view(p, npar).copy())
            fill(zip((f, A, b), (m, m * n, m), out))

        def energy(t, q, v, p, E):
            fill([(E, 2, f_en(*args(t, q, v, p)))])

        def restitution(t, q, p, e):
            fill([(e, m, f_res(float(t), _view(q, n).copy(), _view(p, npar).copy()))])

        def switches(t, q, v, p, s):
            if K:
                fill([(s, K, f_sw(*args(t, q, v, p)))])

        def dyn_out(t, q, v, p, M, rhs, A, gam, mu):
            return [(M, n * n), (rhs, n), (A, m * n), (gam, m), (mu, m)]

        def sparse_out(t, q, v, p, Md, rhs, Av, gam, mu):
            return [(Md, n), (rhs, n), (Av, nnz), (gam, m), (mu, m)]

        self.pointers = (
            _DYNAMICS(guarded(dynamics, dyn_out)),
            _DYNAMICS(guarded(dynamics_sparse, sparse_out)),
            _CONSTRAINTS(guarded(constraints, lambda t, q, p, f, A, b: [(f, m), (A, m * n),
                                                                        (b, m)])),
            _ENERGY(guarded(energy, lambda t, q, v, p, E: [(E, 2)])),
            _RESTITUTION(guarded(restitution, lambda t, q, p, e: [(e, m)])),
            _ENERGY(guarded(switches, lambda t, q, v, p, s: [(s, K)])),
        )  # fmt: skip
        self.addresses = [ctypes.cast(f, _P).value for f in self.pointers]

    @property
    def error(self) -> BaseException | None:
        """The first exception a callback raised in this thread since it was cleared."""
        return getattr(self._local, "error", None)

    @error.setter
    def error(self, value: BaseException | None) -> None:
        self._local.error = value


_CALLED: dict[int, tuple] = {}
_CALLED_LOCK = threading.Lock()


def callback_kernels(ns) -> CKernels:
    """The engine with ``ns``' NumPy functions called back (:class:`Callbacks`), once per
    system. Raises ``lamech.numeric._cengine.EngineMissing`` where the engine was not built."""
    with _CALLED_LOCK:
        known = _CALLED.get(id(ns))
        if known is not None and known[0] is ns and known[2] == ns._own_functions():
            return known[1]
        calls = Callbacks(ns)
        kernels = CKernels(
            ns.pattern, ns.mass_diagonal, ns.n, ns.m, len(ns.parameters), calls.addresses,
            ns.switch_slots, calls, "python", None, calls=calls,
        )  # fmt: skip
        if len(_CALLED) >= 32:
            _CALLED.clear()
        _CALLED[id(ns)] = (ns, kernels, ns._own_functions())
        return kernels


def engine_kernels(ns, jit: bool | None = None) -> CKernels:
    """The engine for ``ns``: its compiled functions where ``jit`` (default ``ns.jit``)
    and it has them, none replaced since (:attr:`NumericSystem.replaced`) and they
    compile; else its NumPy functions called back (:func:`callback_kernels`)."""
    from ._codegen import compiled_available

    use = bool(ns.jit if jit is None else jit) and not ns.replaced and bool(ns.c_source)
    if use and compiled_available():
        from ._cc import CompileFailed
        from ._cengine import EngineMissing

        try:
            return c_kernels(
                ns.pattern, ns.mass_diagonal, ns.n, ns.m, len(ns.parameters), ns.c_source,
                ns.switch_slots,
            )  # fmt: skip
        except (EngineMissing, CompileFailed):
            pass
    return callback_kernels(ns)


def rules_of(ns) -> CRules:
    """The rules on the engine of ``ns`` (:func:`engine_kernels`), made once per engine."""
    kernels = engine_kernels(ns)
    rules = getattr(kernels, "rules", None)
    if rules is None:
        rules = CRules(kernels)
        kernels.rules = rules  # type: ignore[attr-defined]
    return rules


_EMPTY_I = np.zeros(0, dtype=_I)
_EMPTY_F = np.zeros(0)


class CRules:
    """``rules.c``'s entry points with the signatures of the rules SciPy's road applies
    (:func:`._run.rules`), every array checked (dtype, C order, shape, indices) before the
    engine reads it."""

    def __init__(self, kernels: CKernels):
        self.k = kernels
        self.lib = kernels.lib
        self.ref = kernels.ref
        self.n, self.m, self.np = kernels.n, kernels.m, kernels.np
        self.raw = _library()  # for the rules that call none of the system's functions

    # ----- checks -------------------------------------------------------------------
    def _y(self, y, writable: bool = False) -> int:
        return _addr(y, _F, (2 * self.n,), "y", writable)

    def _p(self, p, writable: bool = False) -> int:
        return _addr(p, _F, (self.np,), "p", writable)

    def _tl(self, tl) -> int:
        return _addr(tl, _F, (codes.TL_SIZE,), "tl")

    def _act(self, act) -> tuple:
        rows, hrows, slip_j, slip_k, slip_c = act
        (r, sj, sk, sc), na, ns = self.k._act(rows, slip_j, slip_k, slip_c)
        nh = hrows.shape[0] if isinstance(hrows, np.ndarray) else 0
        h = _addr(hrows, _I, (nh,), "hrows")
        _in_range(hrows, 0, max(self.m, 1), "hrows")
        return (r, na, h, nh, sj, sk, sc, ns)

    def _watch(self, watch) -> tuple:
        wk, wj = watch
        nw = wk.shape[0] if isinstance(wk, np.ndarray) else -1
        if nw > 2 * self.m:
            raise ValueError("engine: more watched events than 2 m")
        a = (_addr(wk, _I, (nw,), "wk"), _addr(wj, _I, (nw,), "wj"), nw)
        _in_range(wk, 0, len(codes.EVENT_KINDS), "wk")
        _in_range(wj, 0, max(self.m, 1), "wj")
        return a

    def _fmode_only(self, fmode) -> _Mode:
        """A mode record of which the engine reads fmode only (the accumulation times)."""
        return _Mode(self.m, None, None, _addr(fmode, _F, (5, self.m), "fmode", True))

    def _status(self, code: int) -> None:
        self.k._status(code)

    # ----- the rules that call the system's functions ----------------------------------
    def ev_start(self, t, y, p, md, tl, lg, nev):
        res = np.zeros(2, dtype=_I)
        self._status(self.lib.lm_rule_start(
            self.ref, float(t), self._y(y, True), self._p(p), ctypes.byref(self.k.mode_record(md)),
            self._tl(tl), ctypes.byref(self.k.log_record(lg, nev)), int(nev), res.ctypes.data,
        ))  # fmt: skip
        return int(res[0]), int(res[1])

    def ev_settle(self, t, y, p, md, tl, lg, nev):
        res = np.zeros(2, dtype=_I)
        self._status(self.lib.lm_rule_settle(
            self.ref, float(t), self._y(y, True), self._p(p), ctypes.byref(self.k.mode_record(md)),
            self._tl(tl), ctypes.byref(self.k.log_record(lg, nev)), int(nev), res.ctypes.data,
        ))  # fmt: skip
        return int(res[0]), int(res[1])

    def _kind_j(self, kind, j) -> tuple[int, int]:
        if not (0 <= int(kind) < len(codes.EVENT_KINDS)) or not (0 <= int(j) < self.m):
            raise ValueError("engine: an event's kind or constraint is out of range")
        return int(kind), int(j)

    def ev_apply(self, t, y, p, kind, j, act, md, tl, lim, lg, nev):
        res = np.zeros(3, dtype=_I)
        kind, j = self._kind_j(kind, j)
        self._status(self.lib.lm_rule_apply(
            self.ref, float(t), self._y(y, True), self._p(p, True), kind, j, *self._act(act),
            ctypes.byref(self.k.mode_record(md)), self._tl(tl),
            _addr(lim, _I, (codes.LM_SIZE,), "lim"), ctypes.byref(self.k.log_record(lg, nev)),
            int(nev), res.ctypes.data,
        ))  # fmt: skip
        return int(res[0]), int(res[1]), bool(res[2])

    def ev_switch(self, t, y, p, k, md, tl, lg, nev):
        if not 0 <= int(k) < self.k.arrays[5].shape[0]:
            raise ValueError("engine: no such input switch")
        res = np.zeros(3, dtype=_I)
        self._status(self.lib.lm_rule_switch(
            self.ref, float(t), self._y(y, True), self._p(p, True), int(k),
            ctypes.byref(self.k.mode_record(md)), self._tl(tl),
            ctypes.byref(self.k.log_record(lg, nev)), int(nev), res.ctypes.data,
        ))  # fmt: skip
        return int(res[0]), int(res[1]), bool(res[2])

    def ev_values(self, t, y, p, watch, md, act, tl):
        wk, wj, nw = self._watch(watch)
        out = np.empty(nw)
        self._status(self.lib.lm_rule_values(
            self.ref, float(t), self._y(y), self._p(p), wk, wj, nw,
            ctypes.byref(self.k.mode_record(md)), *self._act(act), self._tl(tl),
            out.ctypes.data,
        ))  # fmt: skip
        return out

    def ev_arm(self, t, y, p, watch, md, tl):
        res = np.zeros(1, dtype=_I)
        self._status(self.lib.lm_rule_arm(
            self.ref, float(t), self._y(y), self._p(p), *self._watch(watch),
            ctypes.byref(self.k.mode_record(md)), self._tl(tl), res.ctypes.data,
        ))  # fmt: skip
        return bool(res[0])

    def ev_project(self, t, y, p, rows, hrows, offset):
        r, na, h, nh = self._act((rows, hrows, _EMPTY_I, _EMPTY_I, _EMPTY_F))[:4]
        self._status(self.lib.lm_rule_project(
            self.ref, float(t), self._y(y, True), self._p(p), r, na, h, nh,
            _addr(offset, _F, (self.m,), "offset"),
        ))  # fmt: skip

    def ev_accumulated(self, t, y, p, fmode, lg, nev):
        res = np.zeros(1, dtype=_I)
        self._status(self.lib.lm_rule_accumulated(
            self.ref, float(t), self._y(y), self._p(p), ctypes.byref(self._fmode_only(fmode)),
            ctypes.byref(self.k.log_record(lg, nev)), int(nev), res.ctypes.data,
        ))  # fmt: skip
        return int(res[0])

    def ev_consistent(self, q, v, p, hold_q, hold_v, value_q, value_v, kinds, tol):
        n = self.n
        for a, name in ((q, "q"), (v, "v")):
            _addr(a, _F, (n,), name, True)
        self.k.ev_starts(q.reshape(1, n), v.reshape(1, n), np.ascontiguousarray(p).reshape(1, -1),
                         hold_q, hold_v, value_q, value_v, kinds, tol)  # fmt: skip

    def ev_dips(self, t, t_new, YS, p, watch, md, act, tl, g_a, g_b, upper):
        wk, wj, nw = self._watch(watch)
        S = YS.shape[0] if isinstance(YS, np.ndarray) and YS.ndim == 2 else -1
        res = np.zeros(1, dtype=_I)
        self._status(self.lib.lm_rule_dips(
            self.ref, float(t), float(t_new), _addr(YS, _F, (S, 2 * self.n), "YS"), S,
            self._p(p), wk, wj, nw, ctypes.byref(self.k.mode_record(md)), *self._act(act),
            self._tl(tl), _addr(g_a, _F, (nw,), "g_a"), _addr(g_b, _F, (nw,), "g_b"),
            _addr(upper, _F, (nw,), "upper", True), res.ctypes.data,
        ))  # fmt: skip
        return bool(res[0])

    def ev_lock(self, t, y, p):
        self._status(self.lib.lm_rule_lock(self.ref, float(t), self._y(y), self._p(p, True)))

    def ev_crossed(self, t, y, p):
        out = np.empty(max(self.k.arrays[5].shape[0], 1), dtype=_I)
        res = np.zeros(1, dtype=_I)
        self._status(self.lib.lm_rule_crossed(
            self.ref, float(t), self._y(y), self._p(p), out.ctypes.data, res.ctypes.data,
        ))  # fmt: skip
        return out[: int(res[0])].copy()

    # ----- the rules that call none of them --------------------------------------------
    def ev_mode(self, kinds, imode, fmode):
        m = self.m
        mode = self.k.mode_record((kinds, imode, fmode))
        rows, hrows, slip_j, slip_k = (np.empty(max(m, 1), dtype=_I) for _ in range(4))
        slip_c = np.empty(max(m, 1))
        counts = np.zeros(3, dtype=_I)
        self.raw.lm_rule_mode(
            ctypes.byref(mode),
            rows.ctypes.data,
            hrows.ctypes.data,
            slip_j.ctypes.data,
            slip_k.ctypes.data,
            slip_c.ctypes.data,
            counts.ctypes.data,
        )
        na, nh, ns = (int(c) for c in counts)
        return rows[:na].copy(), hrows[:nh].copy(), slip_j[:ns].copy(), slip_k[:ns].copy(), \
            slip_c[:ns].copy()  # fmt: skip

    def _mode_of(self, kinds, imode) -> _Mode:
        m = self.m
        mode = _Mode(m, self.k._check_kinds(kinds), _addr(imode, _I, (4, m), "imode", True),
                     None)  # fmt: skip
        _in_range(imode[1], 0, 4, "imode's friction states")
        return mode

    def ev_watch(self, kinds, imode):
        m = self.m
        wk, wj = np.empty(max(2 * m, 1), dtype=_I), np.empty(max(2 * m, 1), dtype=_I)
        nw = self.raw.lm_rule_watch(
            ctypes.byref(self._mode_of(kinds, imode)), wk.ctypes.data, wj.ctypes.data
        )
        return wk[:nw].copy(), wj[:nw].copy()

    def ev_functions(self, watch, md, tl, y, lam, mu, f, A, b):
        n, m = self.n, self.m
        wk, wj, nw = self._watch(watch)
        lam, mu, f, A, b, y = (np.ascontiguousarray(x, dtype=_F) for x in (lam, mu, f, A, b, y))
        out = np.empty(nw)
        self.raw.lm_rule_functions(
            wk,
            wj,
            nw,
            ctypes.byref(self.k.mode_record(md)),
            self._tl(tl),
            self._y(y),
            n,
            _addr(lam, _F, (m,), "lam"),
            _addr(mu, _F, (m,), "mu"),
            _addr(f, _F, (m,), "f"),
            _addr(A, _F, (m, n), "A"),
            _addr(b, _F, (m,), "b"),
            out.ctypes.data,
        )
        return out

    def ev_bound(self, t_end, fmode):
        return float(self.raw.lm_rule_bound(float(t_end), ctypes.byref(self._fmode_only(fmode))))

    def ev_depth(self, tl, q):
        q = np.ascontiguousarray(q, dtype=_F)
        return float(self.raw.lm_rule_depth(self._tl(tl), _addr(q, _F, (self.n,), "q"), self.n))

    def dip_time(self, t, t_new, c, samples):
        return float(self.raw.lm_rule_dip_time(float(t), float(t_new), int(c), int(samples)))

    def ev_again(self, kind, j, r, xb, fmode):
        if not 0 <= int(j) < self.m:
            raise ValueError("engine: no such constraint")
        return bool(self.raw.lm_rule_again(
            int(kind), int(j), float(r), float(xb), ctypes.byref(self._fmode_only(fmode)),
        ))  # fmt: skip
