"""Numeric functions of a :class:`~lamech.model.System`, generated from its derivation.

:func:`compile_system` turns :func:`lamech.symbolic.dynamics` into plain Python source
(common subexpressions eliminated in one :func:`sympy.cse` pass over all the matrices of
a function together), compiles it once, and wraps it in a :class:`NumericSystem`:

``dynamics(t, q, v, p)``
    ``(M, rhs, A, gamma, mu)``: the mass matrix M (n, n), ``rhs = Q - h`` (n,), the
    constraint rows A (m, n), gamma (m,) (so that A q'' + gamma = 0 along the motion),
    and the friction coefficients mu (m,) (NaN for a constraint without friction).
    This is the hot path: one call per right-hand side evaluation.
``constraints(t, q, p)``
    ``(f, A, b)``: the holonomic constraint values f (m,) (0 for a velocity
    constraint), A (m, n), and b (m,) so that the velocity form is F = A v + b.
``accelerations(t, y, p)``
    ``[q''; lambda]`` (n + m,) at the state ``y = [q; q']``: the KKT solve with every
    constraint active (NaN where the KKT matrix is singular). ``rhs_kernel`` is the same
    solve on a mode's active rows.
``energy(t, q, v, p)``
    ``(T, V)``.
``restitution(t, q, p)``
    the coefficients of restitution e (m,).
``force_jacobians(t, q, p)``
    for each constraint with a ``force`` spec, ``(J, D)``: the partial velocities
    J = J_Pa - J_Pb (dim, n) of the material point(s) it acts on, and the named
    directions D (k, dim) (unit length not assumed).

Arguments: ``t`` a float, ``q`` and ``v`` sequences of n floats in the order of
``system.coordinates``, ``p`` a sequence of floats in the order of
``system.parameters`` (so a sweep passes a different ``p`` without regenerating
anything). The generated source (``NumericSystem.source``) names the order in each
function's docstring. Only code printed by SymPy from the derived expressions is ever
compiled; no user text reaches ``exec``.

``compile_system(system, jit=True)`` runs the system on lamech's engine in C
(``lamech.numeric._cengine``, built when lamech is installed): the system's functions
are printed as C from the same common subexpressions and compiled by the machine's C
compiler (``lamech.numeric._cc``, a fraction of a second, kept in the cache folder:
``NumericSystem.jit_cache`` says whether it was loaded), and the engine's KKT solves,
loops and events call them. The NumPy/``math`` version is the reference and gives the
same numbers.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import sympy as sp
from sympy.printing.c import C99CodePrinter
from sympy.printing.pycode import PythonCodePrinter

from ..expr import switch_form, table_knots, to_text
from ..model import System
from ..model._kinematics import contact_partial_velocities
from ..symbolic import Dynamics
from ..symbolic import dynamics as derive_dynamics
from ._initial import expression_values
from ._kkt import numpy_kernels, sparsity

__all__ = ["NumericSystem", "compile_system", "compiled_available"]


class _Printer(PythonCodePrinter):
    """Python source with the ``math`` module; floats printed exactly (repr)."""

    def __init__(self):
        super().__init__({"fully_qualified_modules": True, "standard": "python3"})

    def _print_Float(self, expr):
        return repr(float(expr))

    def _print_Rational(self, expr):
        return f"({int(expr.p)}/{int(expr.q)})"

    def _print_Branch(self, expr):
        lock, s = (self._print(a) for a in expr.args)
        return f"({lock} if {lock} == {lock} else (1.0 if {s} >= 0.0 else 0.0))"

    def _print_Pow(self, expr, rational=False):
        base, exp = expr.as_base_exp()
        if exp.is_Integer and 1 < int(exp) <= 4:
            b = self.parenthesize(base, 1000)  # x*x*x is faster than x**3 for floats
            return "(" + "*".join([b] * int(exp)) + ")"
        if exp == sp.Rational(1, 2):
            return f"math.sqrt({self._print(base)})"
        if exp == -1:
            return f"(1.0/{self.parenthesize(base, 1000)})"
        return super()._print_Pow(expr, rational=rational)


class _CPrinter(C99CodePrinter):
    """C of the same expressions (``lamech.numeric._cc`` compiles it): floats exact, and powers,
    rationals and branches written as :class:`_Printer` writes them, so that the C and
    the Python do the same operations. What it cannot print is in ``_not_supported``
    (the system then has no C form)."""

    def _print_Float(self, expr):
        x = float(expr)
        if math.isnan(x):
            return "NAN"
        if math.isinf(x):
            return "INFINITY" if x > 0 else "(-INFINITY)"
        return repr(x)

    def _print_Integer(self, expr):
        return f"{int(expr)}.0"  # never C's integer division

    def _print_Rational(self, expr):
        return f"({int(expr.p)}.0/{int(expr.q)}.0)"

    def _print_NaN(self, expr):
        return "NAN"

    def _print_Branch(self, expr):
        lock, s = (self._print(a) for a in expr.args)
        return f"(({lock} == {lock}) ? {lock} : (({s} >= 0.0) ? 1.0 : 0.0))"

    def _print_Pow(self, expr, rational=False):
        base, exp = expr.as_base_exp()
        b = self.parenthesize(base, 1000)
        if exp.is_Integer and 1 < int(exp) <= 4:
            return "(" + "*".join([b] * int(exp)) + ")"
        if exp == sp.Rational(1, 2):
            return f"sqrt({self._print(base)})"
        if exp == sp.Rational(-1, 2):
            return f"(1.0/sqrt({self._print(base)}))"
        if exp == -1:
            return f"(1.0/{b})"
        return f"pow({self._print(base)}, {self._print(exp)})"


class Branch(sp.Function):
    """``Branch(lock, s)``: step(s), 1 where the switching function s >= 0, else 0 -- or
    ``lock`` (0 or 1) when it is a number: the simulator holds each switch's branch fixed
    between the events where its s crosses 0 (so the step in which an input switches is
    located, never stepped over); NaN (the default) leaves it free."""

    nargs = 2


class _Switches:
    """The input functions of a system's expressions written through locked branches
    (:func:`lamech.expr.switch_form`): one lock symbol per distinct switching function,
    in the order met."""

    def __init__(self) -> None:
        self.functions: list[sp.Expr] = []
        self.locks: list[sp.Symbol] = []
        self._index: dict[sp.Expr, int] = {}
        self.quiet: set = set()  # the rows of tables: corners, not events to log

    def _branch(self, s: sp.Expr) -> sp.Expr:
        if s.could_extract_minus_sign():  # step(-s) is 1 - step(s): one switch, not two
            return 1 - self._branch(-s)
        k = self._index.get(s)
        if k is None:
            k = self._index[s] = len(self.functions)
            self.functions.append(s)
            self.locks.append(sp.Symbol(f"lock__{k}", real=True))
        return Branch(self.locks[k], s)

    def matrix(self, mat: sp.Matrix) -> sp.Matrix:
        for e in mat:
            self.quiet |= table_knots(e)
        return mat.applyfunc(lambda e: switch_form(e, self._branch))

    def names(self) -> list[str]:
        """How each switch reads: step(s), with its s in free form."""
        free = {Branch(lk, s): sp.Heaviside(s, 1) for lk, s in zip(self.locks, self.functions)}
        out = []
        for s in self.functions:
            if s in self.quiet:
                out.append("")
                continue
            for _ in range(len(free)):  # inner switches first
                s = s.xreplace(free)
            try:
                out.append(to_text(sp.Heaviside(s, 1)))
            except ValueError:
                out.append(f"step({s})")
        return out


def compiled_available() -> bool:
    """Whether systems can run compiled: lamech's engine in C was built at install
    (``lamech.numeric._cengine``) and a C compiler is there for each system's own functions
    (``lamech.numeric._cc``)."""
    from . import _cc, _cengine

    return _cc.compiler() is not None and _cengine.available()


@dataclass
class NumericSystem:
    """Compiled numeric functions of one system (see the module docstring)."""

    system: System
    dyn: Dynamics
    coordinate_names: list[str]
    constraint_names: list[str]
    parameter_names: list[str]
    parameters: np.ndarray
    dynamics: Callable[..., Any]
    constraints: Callable[..., Any]
    energy: Callable[..., Any]
    restitution: Callable[..., Any]
    force_jacobians: Callable[..., Any]
    force_specs: list = field(default_factory=list)  # [(constraint index, [direction names])]
    # switches(t, q, v, p) -> s (K,): the inputs' switching functions; each branch's lock
    # is p[len(parameters) - K + k] (NaN: free; 0 or 1: held), see Branch
    switches: Callable[..., Any] = None  # type: ignore[assignment]
    switch_names: list = field(default_factory=list)  # step(s) of each, as text
    rhs_kernel: Callable[..., Any] = None  # type: ignore[assignment]
    accelerations: Callable[..., Any] = None  # type: ignore[assignment]  # (t, y, p) -> [q''; lambda]
    # solve(M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c) -> [q''; lambda_rows]: the
    # kernels' structured KKT solve (compiled with jit), NaN where it fails (see _kkt)
    kkt_solve: Callable[..., Any] = None  # type: ignore[assignment]
    # the compiled batch loop (over the cores, serial) of lamech.integrate_batch, with jit
    batch_loops: tuple = ()
    pattern: tuple = ()  # structural nonzeros of A (see _kkt.sparsity)
    mass_diagonal: bool = False  # M diagonal symbolically: KKT solved by Schur complement
    source: str = ""
    # the C of the functions the compiled loop calls (lamech.numeric._cc), "" where none
    c_source: str = ""
    jit: bool = False
    # with jit, where the compiled code came from: "loaded" (the cache on disk, nothing
    # compiled), "compiled" (compiled in this process and cached), "memory" (no usable
    # cache directory: compiled for this process only); "" without jit
    jit_cache: str = ""
    time_dependent: bool = False
    explicit_time: bool = False  # L, a constraint or a generalized force has t in it
    conservative: bool = True
    generation_seconds: float = 0.0
    # the functions as compile_system made them (see ``replaced``)
    generated: tuple = ()

    @property
    def replaced(self) -> bool:
        """Whether a function was replaced after :func:`compile_system` made this system
        (``dataclasses.replace(ns, constraints=...)``): the compiled loops (the loop with
        events, the batch loops), built from ``source``, would not run the replacement,
        so they are not used for it (its own functions run, called back from C)."""
        now = self._own_functions()
        return len(now) != len(self.generated) or any(
            a is not b for a, b in zip(now, self.generated)
        )

    def _own_functions(self) -> tuple:
        return (self.dynamics, self.constraints, self.energy, self.restitution,
                self.rhs_kernel, self.accelerations, self.kkt_solve)  # fmt: skip

    @property
    def n(self) -> int:
        return len(self.coordinate_names)

    @property
    def m(self) -> int:
        return len(self.constraint_names)

    @property
    def switch_slots(self) -> np.ndarray:
        """Where in ``p`` each switch's lock is (after the parameters)."""
        first = len(self.system.parameters)
        return np.arange(first, first + len(self.switch_names))

    def parameter_vector(self, overrides: dict | None = None) -> np.ndarray:
        """The parameter array with ``overrides`` {name: value}; parameters whose value is
        an expression of others are recomputed from the overridden ones."""
        if not overrides:
            return self.parameters.copy()
        unknown = set(overrides) - set(self.parameter_names)
        if unknown:
            raise KeyError(
                f"unknown parameter(s) {sorted(unknown)}; known: {', '.join(self.parameter_names)}"
            )
        env = {
            p.symbol: sp.Float(float(overrides[p.name]))
            for p in self.system.parameters
            if p.name in overrides
        }
        out = []
        for p in self.system.parameters:
            if p.name in overrides:
                out.append(float(overrides[p.name]))
                continue
            val = sp.sympify(p.value)
            for _ in range(len(self.system.parameters) + 1):
                nxt = val.subs(env)
                if nxt == val:
                    break
                val = nxt
            val = val.subs(self.system.parameter_values)
            out.append(float(val))
        return np.array(out + [math.nan] * len(self.switch_names), dtype=float)

    def initial_state(self, p: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(q0, v0) from the coordinates' initial expressions at parameters ``p``
        (:func:`lamech.numeric.consistent_initial` holds some of them)."""
        return expression_values(self, p)


def _rename(system: System):
    """Map every symbol to a safe identifier: q_i, v_i, p_i, t."""
    mapping: dict[sp.Symbol, sp.Symbol] = {}
    for i, s in enumerate(system.q):
        mapping[s] = sp.Symbol(f"q_{i}", real=True)
    for i, s in enumerate(system.qd):
        mapping[s] = sp.Symbol(f"v_{i}", real=True)
    for i, par in enumerate(system.parameters):
        mapping[par.symbol] = sp.Symbol(f"p_{i}", real=True)
    mapping[system.t] = sp.Symbol("t", real=True)
    return mapping


_VECTORS = {"rhs", "gamma", "mu", "f", "b", "E", "e", "s", "Md", "Av"}


def _function_source(
    name: str,
    args: str,
    doc: str,
    outputs: list[tuple[str, sp.Matrix]],
    mapping: dict,
    n: int,
    m: int,
    used_inputs: tuple[str, ...],
    c_out: list | None = None,
) -> str:
    """Source of one function computing several matrices with a shared CSE; its C twin
    (or None: not printable) appended to ``c_out`` where given."""
    printer = _Printer()
    exprs: list[sp.Expr] = []
    slots: list[tuple[str, int, int]] = []
    for oname, mat in outputs:
        for i in range(mat.rows):
            for j in range(mat.cols):
                e = sp.sympify(mat[i, j]).xreplace(mapping)
                if e != 0 or oname in ("mu",):
                    exprs.append(e)
                    slots.append((oname, i, j))
    allowed = set(mapping.values())
    for e in exprs:
        extra = e.free_symbols - allowed
        if extra:
            raise ValueError(
                f"{name}: unexpected symbols {sorted(map(str, extra))} in the derived expressions"
            )
    # The "basic" pre-pass costs 40% of code generation on the chains but makes the numba
    # kernel faster (8-link chain: 3.3 us against 4.4-5.2 us without it): kept.
    repl, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("c_"), optimizations="basic")
    lines = [f"def {name}({args}):", f'    """{doc}"""']
    for var in used_inputs:
        if var == "q" or var == "v":
            for i in range(n):
                lines.append(f"    {var}_{i} = {var}[{i}]")
        elif var == "p":
            for i in range(len([s for s in mapping.values() if s.name.startswith("p_")])):
                lines.append(f"    p_{i} = p[{i}]")
    for sym, e in repl:
        lines.append(f"    {sym} = {printer.doprint(e)}")
    for oname, mat in outputs:
        shape = (mat.rows, mat.cols)
        if oname == "mu":
            lines.append(f"    {oname} = numpy.full({shape[0]}, numpy.nan)")
        elif oname in _VECTORS:
            lines.append(f"    {oname} = numpy.zeros({shape[0]})")
        else:
            lines.append(f"    {oname} = numpy.zeros(({shape[0]}, {shape[1]}))")
    for (oname, i, j), e in zip(slots, reduced):
        mat = dict(outputs)[oname]
        if oname == "mu" and e is sp.nan:
            continue
        target = f"{oname}[{i}]" if oname in _VECTORS else f"{oname}[{i}, {j}]"
        lines.append(f"    {target} = {printer.doprint(e)}")
    lines.append(f"    return {', '.join(o for o, _ in outputs)}")
    if c_out is not None:
        c_out.append(_c_function(name, args, outputs, slots, repl, reduced, mapping))
    return "\n".join(lines)


def _c_function(name, args, outputs, slots, repl, reduced, mapping) -> str | None:
    """The C twin of one generated function (``lamech.numeric._cc``): ``void c_<name>(double t,
    const double *q, ..., double *<output>, ...)`` writing each output's nonzero entries
    (row-major) into arrays the caller zeroed; None where the C printer cannot print an
    expression."""
    printer = _CPrinter()
    failed = []

    def c(e) -> str:
        text = printer.doprint(e)
        failed.extend(printer._not_supported)  # reset by each doprint
        return text

    inputs = [a.strip() for a in args.split(",")[1:]]
    params = ["double t"] + [f"const double *{a}" for a in inputs]
    params += [f"double *{o}" for o, _ in outputs]
    lines = [f"void c_{name}({', '.join(params)}) {{"]
    used = {str(x) for x in mapping.values()}
    for var in inputs:
        count = sum(1 for u in used if u.startswith(var + "_") and u[len(var) + 1 :].isdigit())
        lines += [f"    const double {var}_{i} = {var}[{i}];" for i in range(count)]
    for sym, e in repl:
        lines.append(f"    const double {sym} = {c(e)};")
    cols = dict((o, mat.cols) for o, mat in outputs)
    for (oname, i, j), e in zip(slots, reduced):
        lines.append(f"    {oname}[{i * cols[oname] + j}] = {c(e)};")
    lines.append("}")
    if failed:
        return None
    return "\n".join(lines)


def _scatter_source(n: int, m: int, nonzero: list[tuple[int, int]]) -> str:
    """``dynamics`` of a diagonal M from ``dynamics_sparse``: the matrices filled."""
    lines = [
        "def dynamics(t, q, v, p):",
        '    """(M, rhs = Q - h, A, gamma, mu) of the system (from dynamics_sparse)."""',
        "    Md, rhs, Av, gamma, mu = dynamics_sparse(t, q, v, p)",
        f"    M = numpy.zeros(({n}, {n}))",
        f"    for i in range({n}):",
        "        M[i, i] = Md[i]",
        f"    A = numpy.zeros(({m}, {n}))",
    ]
    lines += [f"    A[{j}, {i}] = Av[{e}]" for e, (j, i) in enumerate(nonzero)]
    lines.append("    return M, rhs, A, gamma, mu")
    return "\n".join(lines)


def _gather_source(n: int, nonzero: list[tuple[int, int]]) -> str:
    """``dynamics_sparse`` from ``dynamics`` (a full M: the compiled solve uses
    ``dynamics``; this one only keeps the kernels' names defined)."""
    lines = [
        "def dynamics_sparse(t, q, v, p):",
        '    """(diagonal of M, rhs = Q - h, nonzeros of A by row, gamma, mu)."""',
        "    M, rhs, A, gamma, mu = dynamics(t, q, v, p)",
        f"    Md = numpy.empty({n})",
        f"    for i in range({n}):",
        "        Md[i] = M[i, i]",
        f"    Av = numpy.empty({len(nonzero)})",
    ]
    lines += [f"    Av[{e}] = A[{j}, {i}]" for e, (j, i) in enumerate(nonzero)]
    lines.append("    return Md, rhs, Av, gamma, mu")
    return "\n".join(lines)


def _c_derived(n: int, m: int, nonzero: list[tuple[int, int]], diagonal: bool) -> str:
    """The C twin of :func:`_scatter_source` (``diagonal``: ``c_dynamics`` from
    ``c_dynamics_sparse``) or :func:`_gather_source` (the other way round), through
    two scratch arrays; where they cannot be allocated, rhs is NaN (the solve fails,
    and the loop says so)."""
    args = "double t, const double *q, const double *v, const double *p"
    if diagonal:
        head = "c_dynamics({args}, double *M, double *rhs, double *A, double *gamma, double *mu)"
        one, two, sizes, inner = "Md", "Av", (n, len(nonzero)), "c_dynamics_sparse"
        moves = [f"    M[{i * n + i}] = Md[{i}];" for i in range(n)]
        moves += [f"    A[{j * n + i}] = Av[{e}];" for e, (j, i) in enumerate(nonzero)]
    else:
        head = (
            "c_dynamics_sparse({args}, double *Md, double *rhs, double *Av, double *gamma, "
            "double *mu)"
        )
        one, two, sizes, inner = "M", "A", (n * n, m * n), "c_dynamics"
        moves = [f"    Md[{i}] = M[{i * n + i}];" for i in range(n)]
        moves += [f"    Av[{e}] = A[{j * n + i}];" for e, (j, i) in enumerate(nonzero)]
    lines = [
        "void " + head.format(args=args) + " {",
        f"    double *{one} = calloc({sizes[0] or 1}, sizeof(double));",
        f"    double *{two} = calloc({sizes[1] or 1}, sizeof(double));",
        f"    if (!{one} || !{two}) {{",
        f"        for (int i = 0; i < {n}; i++) rhs[i] = NAN;",
        f"        free({one});",
        f"        free({two});",
        "        return;",
        "    }",
        f"    {inner}(t, q, v, p, {'Md, rhs, Av' if diagonal else 'M, rhs, A'}, gamma, mu);",
        *moves,
        f"    free({one});",
        f"    free({two});",
        "}",
    ]
    return "\n".join(lines)


def _kernels(
    fns: dict, diagonal: bool, pattern, jit: bool | None, c_source: str, slots, sizes: tuple
):
    """(rhs_kernel, accelerations, kkt_solve, batch loops, compiled state): on the engine
    in C (``lamech.numeric._cengine``) when ``jit`` (None: wherever it can) and the system has C
    (``c_source``) and a compiler compiles it, the state where its library came from
    (:func:`._cc.load`); else NumPy (no batch loops: :mod:`._batch` runs the engine's
    with the NumPy functions called back;
    state ""). ``sizes``: (n, m, the length of p)."""
    if jit is None or jit:
        if c_source and compiled_available():
            from ._cc import CompileFailed
            from ._cengine import EngineMissing, c_kernels

            try:
                n, m, nparams = sizes
                k = c_kernels(pattern, diagonal, n, m, nparams, c_source, slots)
            except (EngineMissing, CompileFailed):
                pass
            else:
                f = k.functions
                loops = (f["batch_run"], f["batch_run_serial"])
                return f["rhs_kernel"], f["accelerations"], f["kkt_solve"], loops, k.cache
    return (*numpy_kernels(fns["dynamics"], diagonal), (), "")


def _force_geometry(system: System):
    """(force_specs [(constraint index, [direction names])], [(name, matrix)]): the
    partial velocities J_k and directions D_k of each constraint with a ``force`` spec."""
    force_specs: list[tuple[int, list[str]]] = []
    outputs = []
    for j, c in enumerate(system.constraints):
        spec = c.force
        if spec is None:
            continue
        J = contact_partial_velocities(system, spec)
        dim = J.rows
        dirs = spec.along or tuple(
            (axis, tuple(sp.Integer(1 if k == i else 0) for k in range(dim)))
            for i, axis in enumerate("xyz"[:dim])
        )
        D = sp.Matrix([list(d) for _, d in dirs])
        k = len(force_specs)
        force_specs.append((j, [name for name, _ in dirs]))
        outputs += [(f"J{k}", J), (f"D{k}", D)]
    return force_specs, outputs


def _source(system: System, dyn: Dynamics, c: bool = True):
    """(source, C source, A, force_specs, switch names): the generated module of the
    system's functions and, with ``c``, the C of those the compiled loop calls (""
    where an expression has no C form)."""
    n, m = len(system.coordinates), len(system.constraints)
    mapping = _rename(system)
    sw = _Switches()
    qd0 = {v: sp.Integer(0) for v in system.qd}
    F = dyn.velocity_forms
    A = dyn.A if m else sp.zeros(0, n)
    b = sp.Matrix([F[j].xreplace(qd0) for j in range(m)]) if m else sp.zeros(0, 1)
    f = (
        sp.Matrix([c.expr if c.holonomic else 0 for c in system.constraints])
        if m
        else sp.zeros(0, 1)
    )
    mu = (
        sp.Matrix([c.friction.mu if c.friction is not None else sp.nan for c in system.constraints])
        if m
        else sp.zeros(0, 1)
    )
    e = sp.Matrix([c.restitution for c in system.constraints]) if m else sp.zeros(0, 1)
    rhs = dyn.Q - dyn.h
    force_specs, jac_outputs = _force_geometry(system)
    M, rhs, gamma = sw.matrix(dyn.M), sw.matrix(rhs), sw.matrix(dyn.gamma if m else sp.zeros(0, 1))
    A_locked, f, b, e = sw.matrix(A), sw.matrix(f), sw.matrix(b), sw.matrix(e)
    energy = sw.matrix(sp.Matrix([system.T, system.V]))
    jac_outputs = [(name, sw.matrix(mat)) for name, mat in jac_outputs]
    switches = sp.Matrix(sw.functions) if sw.functions else sp.zeros(0, 1)
    P = len(system.parameters)
    for k, lock in enumerate(sw.locks):
        mapping[lock] = sp.Symbol(f"p_{P + k}", real=True)
    order = (
        f"q = [{', '.join(c.name for c in system.coordinates)}]; "
        f"v = [{', '.join(c.name + chr(39) for c in system.coordinates)}]; "
        f"p = [{', '.join(p.name for p in system.parameters)}]; "
        f"constraints = [{', '.join(c.name for c in system.constraints)}]"
    )
    # The compiled solve reads M and A by their structural nonzeros (``dynamics_sparse``:
    # M's diagonal and A's nonzeros in the order of _kkt.sparsity); ``dynamics`` gives the
    # matrices. One is generated, the other reads it: one CSE, never two.
    nonzero = sorted(A.todok()) if m else []
    c_parts: list | None = [] if c else None
    if dyn.M.is_diagonal():
        Md = sp.Matrix([M[i, i] for i in range(n)])
        Av = sp.Matrix([A_locked[j, i] for j, i in nonzero]) if nonzero else sp.zeros(0, 1)
        dynamics_srcs = [
            _function_source(
                "dynamics_sparse",
                "t, q, v, p",
                "(diagonal of M, rhs = Q - h, nonzeros of A by row, gamma, mu). " + order,
                [("Md", Md), ("rhs", rhs), ("Av", Av), ("gamma", gamma), ("mu", mu)],
                mapping,
                n,
                m,
                ("q", "v", "p"),
                c_parts,
            ),
            _scatter_source(n, m, nonzero),
        ]
    else:
        dynamics_srcs = [
            _function_source(
                "dynamics",
                "t, q, v, p",
                # never the title: it is the user's text (a backslash or a NUL in it would
                # break the source); the names in `order` are identifiers, checked
                "(M, rhs = Q - h, A, gamma, mu) of the system. " + order,
                [("M", M), ("rhs", rhs), ("A", A_locked), ("gamma", gamma), ("mu", mu)],
                mapping,
                n,
                m,
                ("q", "v", "p"),
                c_parts,
            ),
            _gather_source(n, nonzero),
        ]
    srcs = [
        *dynamics_srcs,
        _function_source(
            "constraints",
            "t, q, p",
            "(f, A, b) with F = A v + b. " + order,
            [("f", f), ("A", A_locked), ("b", b)],
            mapping,
            n,
            m,
            ("q", "p"),
            c_parts,
        ),
        _function_source(
            "energy",
            "t, q, v, p",
            "(T, V). " + order,
            [("E", energy)],
            mapping,
            n,
            m,
            ("q", "v", "p"),
            c_parts,
        ),
        _function_source(
            "restitution",
            "t, q, p",
            "e per constraint. " + order,
            [("e", e)],
            mapping,
            n,
            m,
            ("q", "p"),
            c_parts,
        ),
    ]
    srcs.append(
        _function_source(
            "switches",
            "t, q, v, p",
            "the inputs' switching functions s (a branch switches where one crosses 0). " + order,
            [("s", switches)],
            mapping,
            n,
            m,
            ("q", "v", "p"),
            c_parts,
        )
    )
    if jac_outputs:
        srcs.append(
            _function_source(
                "force_jacobians_flat",
                "t, q, p",
                "J0, D0, J1, D1, ... " + order,
                jac_outputs,
                mapping,
                n,
                m,
                ("q", "p"),
            )
        )
    else:
        srcs.append("def force_jacobians_flat(t, q, p):\n    return ()")
    source = "import math\nimport numpy\n\n" + "\n\n\n".join(srcs) + "\n"
    c_source = ""
    if c_parts is not None and all(part is not None for part in c_parts):
        derived = _c_derived(n, m, nonzero, bool(dyn.M.is_diagonal()))
        c_source = (
            "\n\n".join(
                [
                    C_HEADER
                    + order.replace("*/", "* /")
                    + " */\n#include <math.h>\n#include <stdlib.h>\n"
                    + C_CONSTANTS,
                    c_parts[0],
                    derived,
                    *c_parts[1:],
                ]
            )
            + "\n"
        )
    return source, c_source, A, force_specs, sw.names()


C_HEADER = "/* lamech: the compiled functions of one system (generated; safe to delete). "
# SymPy's C printer writes pi and E as M_PI and M_E, which <math.h> defines only beyond
# strict C99 (-std=c99 hides them): the problem's own C defines them where it must
C_CONSTANTS = (
    "#ifndef M_PI\n#define M_PI 3.14159265358979323846264338327950288\n#endif\n"
    "#ifndef M_E\n#define M_E 2.71828182845904523536028747135266250\n#endif"
)


def compile_system(system: System, jit: bool | None = False) -> NumericSystem:
    """Generate and compile the numeric functions of ``system`` (see the module docstring).

    ``jit=True`` or ``None`` runs it on lamech's engine in C where it can (the engine
    built at install and a C compiler for the system's own functions, compiled in a
    fraction of a second or loaded from the cache folder: ``lamech.numeric._cengine``), else with
    NumPy, silently; ``jit=False``: NumPy.
    """
    import time as _time

    t0 = _time.perf_counter()
    dyn = derive_dynamics(system)
    source, c_source, A, force_specs, switch_names = _source(system, dyn)
    namespace: dict = {"math": math, "numpy": np}
    exec(compile(source, "<lamech generated>", "exec"), namespace)

    fns = {
        k: namespace[k]
        for k in (
            "dynamics",
            "dynamics_sparse",
            "constraints",
            "energy",
            "restitution",
            "force_jacobians_flat",
            "switches",
        )
    }
    locks = [math.nan] * len(switch_names)
    diagonal = bool(dyn.M.is_diagonal())
    pattern = sparsity(A)
    P = len(system.parameters)
    slots = np.arange(P, P + len(switch_names))
    sizes = (len(system.coordinates), len(system.constraints), P + len(switch_names))
    kernel, accel, solve, loops, jit_cache = _kernels(
        fns, diagonal, pattern, jit, c_source, slots, sizes
    )

    flat = fns["force_jacobians_flat"]

    def force_jacobians(t, q, p):
        out = flat(t, q, p)
        return [(out[2 * k], out[2 * k + 1]) for k in range(len(out) // 2)]

    t_sym = system.t
    time_dependent = bool(system.L.has(t_sym) or any(c.expr.has(t_sym) for c in system.constraints))
    conservative = all(sp.sympify(x) == 0 for x in (system.forces or ()))
    params = np.array([p.numeric for p in system.parameters] + locks, dtype=float)
    ns = NumericSystem(
        system=system,
        dyn=dyn,
        coordinate_names=[c.name for c in system.coordinates],
        constraint_names=[c.name for c in system.constraints],
        parameter_names=[p.name for p in system.parameters],
        parameters=params,
        dynamics=fns["dynamics"],
        constraints=fns["constraints"],
        energy=fns["energy"],
        restitution=fns["restitution"],
        force_jacobians=force_jacobians,
        force_specs=force_specs,
        switches=fns["switches"],
        switch_names=switch_names,
        source=source,
        c_source=c_source,
        jit=bool(jit_cache),
        jit_cache=jit_cache,
        rhs_kernel=kernel,
        mass_diagonal=diagonal,
        accelerations=accel,
        kkt_solve=solve,
        batch_loops=loops,
        pattern=pattern,
        time_dependent=time_dependent,
        explicit_time=time_dependent or any(sp.sympify(f).has(t_sym) for f in system.forces),
        conservative=conservative,
        generation_seconds=_time.perf_counter() - t0,
    )
    ns.generated = ns._own_functions()
    return ns
