"""The derivation as a lecture writes it, step by step, for any problem.

:func:`steps` turns a :class:`Solution` into a :class:`Derivation`: the Lagrangian with
every coordinate free; for each coordinate dL/dq, d/dt dL/dq' and each df/dq, and its
Euler-Lagrange equation with multipliers; the constraints and their time derivatives;
the elimination and the equations it leaves; the multipliers solved (first in terms of
the remaining accelerations, from the equations that hold them, as a student would,
then in closed form); the energy integral with its constant from the initial state;
each multiplier on the energy shell; where a contact lets go or slips; and the
generalized and Cartesian forces with the virtual-work step. Where a step is one the
lecture notes get wrong, the correction is stated beside it, in the lecture's own problems
(:func:`is_lecture`).

Nothing here formats: the lines hold SymPy expressions and :class:`Term` labels
(``lamech.present`` writes them as text or LaTeX). Every simplification is bounded in
time (:func:`tidy`), and a step whose expressions are too long to read says so and
gives the closed forms only.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..expr import ExpressionError, parse
from ..model import System
from ..model._checks import holding_at_start
from ..model._kinematics import contact_partial_velocities
from ._derive import dynamics
from ._reduce import READABLE_OPS, SIMPLIFY_OPS, _probe, tidy

__all__ = ["Term", "Line", "Step", "Derivation", "steps", "CORRECTION"]

STEP_OPS = 4 * SIMPLIFY_OPS
"""Equations longer than this skip the by-hand solution for the multipliers (the closed
forms of :func:`solve` are given instead)."""

TIDY_OPS = 120
"""Lines longer than this are printed as derived (``factor_terms`` only): ``simplify`` of
one costs seconds on a linkage's trigonometric terms and rarely shortens it much."""

TIDY_LINES = 80
"""At most this many lines are simplified (the first ones, in the order of the steps);
a count, not a time, so that the same problem prints the same steps on any machine."""


class _Simplifier:
    """:func:`tidy` for short lines (the first :data:`TIDY_LINES`; its work is counted
    against the solve's budget); else ``factor_terms`` (cheap, bounded by size)."""

    def __init__(self) -> None:
        self.left = TIDY_LINES

    def __call__(self, expr):
        expr = sp.sympify(expr)
        if expr.is_Atom:
            return expr
        ops = sp.count_ops(expr)
        if ops <= TIDY_OPS and self.left > 0:
            self.left -= 1
            return tidy(expr)
        if ops > 4 * TIDY_OPS:
            return expr
        return sp.factor_terms(expr)


@dataclass(frozen=True)
class Term:
    """A quantity named on the left of a line: ``op`` applied to ``of``.

    ``op``: ``""`` (``of`` itself), ``"d/dq"`` (partial by the symbol ``by``),
    ``"d/dt d/dq'"`` (the time derivative of the partial by the velocity ``by``),
    ``"d/dt"`` and ``"d2/dt2"`` (total time derivatives), ``"Q"`` (constraint ``of``'s
    generalized force on coordinate ``by``), ``"F"`` (constraint ``of``'s Cartesian force
    along the direction named ``by``), ``"|.|"`` (absolute value), ``"p"`` (the momentum of
    the cyclic coordinate named ``of``). ``of`` is ``"L"``,
    ``"T"``, ``"V"``, ``"E"``, ``"f_<name>"``/``"g_<name>"`` (a constraint's function),
    ``"r_<name>"`` (the point a constraint's force acts on), or a SymPy expression.
    """

    op: str
    of: str | sp.Expr
    by: sp.Expr | str | None = None


@dataclass(frozen=True)
class Line:
    """``lhs = rhs``, with a ``label`` (an equation number, where it comes from)."""

    lhs: Term | sp.Expr
    rhs: sp.Expr | sp.Matrix
    label: str = ""


@dataclass(frozen=True)
class Step:
    """One step: a ``title``, its ``lines``, and ``notes`` (how it was done; corrections
    to the lecture start with :data:`CORRECTION`)."""

    title: str
    lines: tuple[Line, ...]
    notes: tuple[str, ...] = ()


CORRECTION = "correction to the lecture notes: "

LECTURE_EXAMPLES = ("pendulum", "cylinder")
"""The bundled examples that are the lecture's own problems: only their steps carry the
corrections to the lecture notes (:data:`CORRECTION`); another problem's reader is not
following the notes."""


def is_lecture(system: System) -> bool:
    """Whether ``system`` is one of the lecture's problems (:data:`LECTURE_EXAMPLES`),
    whatever its parameter values: the same Lagrangian and constraints, symbol for
    symbol."""
    return _form(system) in _lecture_forms()


def _form(system: System) -> tuple:
    return (sp.srepr(system.L), tuple((c.name, sp.srepr(c.expr)) for c in system.constraints))


@functools.cache
def _lecture_forms() -> frozenset:
    from ..problem import load

    return frozenset(_form(load(name)) for name in LECTURE_EXAMPLES)


@dataclass(frozen=True)
class Derivation:
    """The steps of one problem's solution, in the lecture's order."""

    system: System
    steps: tuple[Step, ...]

    @property
    def title(self) -> str:
        return self.system.title

    def step(self, title_start: str) -> Step:
        """The first step whose title starts with ``title_start``."""
        for s in self.steps:
            if s.title.startswith(title_start):
                return s
        raise KeyError(title_start)


def steps(sol) -> Derivation:
    """The derivation of ``sol`` (a :class:`~lamech.Solution`; a System, file
    or example name is solved first) in steps."""
    from ._solution import Solution, solve

    if not isinstance(sol, Solution):
        sol = solve(sol)
    system = sol.system
    holding = holding_at_start(system)
    dyn = sol.dynamics
    dyn_h = dyn if holding is system else dynamics(holding)
    red = sol.reduction
    simp = _Simplifier()
    out: list[Step] = [_lagrangian(system)]
    out += _per_coordinate(sol, dyn, simp)
    out.append(_equations(sol))
    if system.constraints:
        out.append(_constraints(system, dyn, simp))
    if red.eliminated:
        out.append(_elimination(sol, dyn_h, simp))
    if sol.multipliers or sol.reduced_equations:
        out.append(_solved(sol, dyn_h, simp))
    if sol.energy is not None or sol.integrals.momenta or sol.integrals.reason:
        out.append(_integral(sol, simp))
    if sol.shell is not None and (sol.shell.multipliers or sol.shell.omitted):
        out.append(_on_shell(sol))
    if sol.vanishes or sol.slips:
        out.append(_conditions(sol))
    if sol.generalized_forces:
        out.append(_generalized(sol))
    if sol.forces:
        out.append(_cartesian(sol, dyn, simp))
    return Derivation(system, tuple(out))


# ----- the steps ------------------------------------------------------------------------
def _lagrangian(system) -> Step:
    lines = [
        Line(Term("", "T"), system.T),
        Line(Term("", "V"), system.V),
        Line(Term("", "L"), system.L, "L = T - V"),
    ]
    notes = [
        "every coordinate is treated as free, the constrained ones included: the "
        "constraints enter through one multiplier each"
    ]
    if system.forces and any(f != 0 for f in system.forces):
        for c, f in zip(system.coordinates, system.forces):
            if f != 0:
                lines.append(Line(Term("Q", "nc", c.symbol), f, "non-conservative force"))
    return Step("The Lagrangian, every coordinate free", tuple(lines), tuple(notes))


def _per_coordinate(sol, dyn, simp) -> list[Step]:
    system = sol.system
    L = system.L
    q, qd, qdd = system.q, system.qd, system.qdd
    out = []
    for i, c in enumerate(system.coordinates):
        p = sp.diff(L, qd[i])
        dp = (
            sum((sp.diff(p, q[k]) * qd[k] for k in range(len(q))), sp.Integer(0))
            + sum((sp.diff(p, qd[k]) * qdd[k] for k in range(len(q))), sp.Integer(0))
            + sp.diff(p, system.t)
        )
        lines = [
            Line(Term("d/dq", "L", c.velocity), simp(p)),
            Line(Term("d/dt d/dq'", "L", c.velocity), simp(dp)),
            Line(Term("d/dq", "L", c.symbol), simp(sp.diff(L, q[i]))),
        ]
        for j, con in enumerate(system.constraints):
            if con.holonomic:
                lines.append(Line(Term("d/dq", f"f_{con.name}", c.symbol), simp(dyn.A[j, i])))
            else:
                lines.append(Line(Term("d/dq", f"g_{con.name}", c.velocity), simp(dyn.A[j, i])))
        lines.append(Line(sol.equations[i], sp.Integer(0), f"({i + 1})"))
        out.append(Step(f"Coordinate {c.name}", tuple(lines)))
    return out


def _equations(sol) -> Step:
    system = sol.system
    lines = tuple(
        Line(e, sp.Integer(0), f"({i + 1}) {c.name}")
        for i, (c, e) in enumerate(zip(system.coordinates, sol.equations))
    )
    notes = [
        "d/dt dL/dq' - dL/dq - sum_j lambda_j df_j/dq = Q for each coordinate q: the "
        "generalized constraint force of constraint j is Q^(j) = lambda_j df_j/dq",
    ]
    if is_lecture(system):
        notes += [
            CORRECTION + "the first variational integral is written with + d/dt dL/dq'; "
            "the sign is -, as in the equations here",
            CORRECTION + "some lines label d/dt dL/dr' as dL/dr; each line above names what "
            "it is, and the boxed equations of the notes are right",
        ]
    return Step("Euler-Lagrange equations with multipliers", lines, tuple(notes))


def _constraints(system, dyn, simp) -> Step:
    lines: list[Line] = []
    notes: list[str] = []
    n = len(system.coordinates)
    for j, c in enumerate(system.constraints):
        k = len(system.coordinates) + j + 1
        name = ("f_" if c.holonomic else "g_") + c.name
        lines.append(Line(Term("", name), c.expr, f"({k})"))
        acc = sum((dyn.A[j, i] * system.qdd[i] for i in range(n)), sp.Integer(0))
        if c.holonomic:
            lines.append(Line(Term("d/dt", name), simp(dyn.velocity_forms[j])))
        lines.append(
            Line(Term("d2/dt2" if c.holonomic else "d/dt", name), simp(acc + dyn.gamma[j]))
        )
        if c.unilateral:
            notes.append(
                f"`{c.name}` is unilateral: it holds while f >= 0 and lambda_{c.name} >= 0, "
                "so lambda > 0 pushes towards f > 0 (written the other way round, lambda "
                "would change sign: the lecture's pendulum writes f = r - l and finds "
                "lambda = -T)"
            )
    notes.append(
        "each constraint and its time derivatives vanish along the motion; the second "
        "derivative, A q'' + gamma = 0, closes the system for q'' and lambda"
    )
    return Step("The constraints and their time derivatives", tuple(lines), tuple(notes))


def _elimination(sol, dyn_h, simp) -> Step:
    red = sol.reduction
    lines: list[Line] = []
    for coord, expr in red.eliminated:
        lines.append(Line(coord.symbol, expr, "solved from the constraints"))
        for s in (coord.velocity, coord.acceleration):
            if s in red.substitution:
                lines.append(Line(s, simp(red.substitution[s])))
    names = [c.name for c in dyn_h.system.coordinates]
    for i, e in enumerate(dyn_h.equations):
        sub = red.apply(e)
        lines.append(Line(simp(sub), sp.Integer(0), f"({i + 1}) {names[i]}, substituted"))
    notes = [
        "the eliminated coordinates, their velocities and accelerations put into the "
        "equations: what is left holds the multipliers and the remaining accelerations"
    ]
    indep = ", ".join(c.name for c in red.independent)
    if indep:
        notes.append(f"remaining coordinates: {indep}")
    return Step("The elimination", tuple(lines), tuple(notes))


def _solved(sol, dyn_h, simp) -> Step:
    system = sol.system
    red = sol.reduction
    lines: list[Line] = []
    notes: list[str] = []
    by_hand = _by_hand(sol, dyn_h, simp)
    if by_hand is not None:
        lines += by_hand
        notes.append(
            "each multiplier from the equation that holds it, in terms of the remaining "
            "accelerations; the other equations, with the multipliers put in, are the "
            "reduced equations of motion; then the accelerations put back into the "
            "multipliers"
        )
    else:
        notes.append(
            "solved from the KKT system [M, -A^T; A, 0] [q''; lambda] = [Q - h; -gamma] "
            "(M = d^2L/dq'^2, A = df/dq, gamma from the constraints' second derivative)"
        )
    for c in red.independent:
        if c.acceleration in sol.closed.accelerations:
            lines.append(Line(c.acceleration, sol.closed.accelerations[c.acceleration], "reduced"))
    for k, v in sol.multipliers.items():
        lines.append(Line(system.constraint(k).multiplier, v, "on the constraint manifold"))
    if not sol.multipliers and sol.initial_multipliers:
        for k, x in sol.initial_multipliers.items():
            lines.append(
                Line(system.constraint(k).multiplier, sp.Float(x, 12), "at the initial state")
            )
    return Step("The multipliers solved", tuple(lines), tuple(notes))


def _by_hand(sol, dyn_h, simp) -> list[Line] | None:
    """The lecture's way: with every constraint eliminated, the substituted equations are
    linear in the multipliers and the remaining accelerations. Each multiplier is taken
    from the shortest equations that determine it (rows chosen independent at a generic
    point), the remaining equations become the reduced equations once they are put in.
    None when a constraint is kept or the equations are too long to read."""
    system = dyn_h.system
    red = sol.reduction
    cons = system.constraints
    if not cons or set(red.eliminated_constraints) != {c.name for c in cons}:
        return None
    eqs = [simp(red.apply(e)) for e in dyn_h.equations]
    if any(sp.count_ops(e) > STEP_OPS for e in eqs):
        return None
    lams = [c.multiplier for c in cons]
    C = sp.Matrix(eqs).jacobian(lams)
    env = _probe(system, red, C.free_symbols)
    try:
        N = np.array(C.subs(env).evalf(), dtype=complex)
    except (TypeError, ValueError):
        return None
    order = sorted(range(len(eqs)), key=lambda i: (sp.count_ops(eqs[i]), i))
    rows: list[int] = []
    for i in order:
        if np.linalg.matrix_rank(N[rows + [i]], tol=1e-9) == len(rows) + 1:
            rows.append(i)
        if len(rows) == len(lams):
            break
    if len(rows) < len(lams):
        return None
    rows.sort()
    try:
        found = sp.solve([eqs[i] for i in rows], lams, dict=True)
    except (NotImplementedError, ValueError, TypeError):
        return None
    if found is None or len(found) != 1:
        return None
    values = {k: simp(v) for k, v in found[0].items()}
    names = [c.name for c in system.coordinates]
    lines = []
    for lam in lams:
        src = ", ".join(f"({i + 1}) {names[i]}" for i in rows if C[i, lams.index(lam)] != 0)
        lines.append(Line(lam, values[lam], f"from {src}"))
    for i in range(len(eqs)):
        if i in rows:
            continue
        rest = simp(eqs[i].xreplace(values))
        if rest != 0:
            lines.append(Line(rest, sp.Integer(0), f"({i + 1}) {names[i]}, multipliers put in"))
    return lines


def _integral(sol, simp) -> Step:
    system = sol.system
    ints = sol.integrals
    lines: list[Line] = []
    notes: list[str] = []
    if ints.energy is not None:
        what = "Jacobi integral" if ints.is_jacobi else "energy"
        lines.append(Line(Term("", "E"), ints.energy, what))
        e0 = simp(ints.energy.subs(system.initial_state))
        lines.append(Line(Term("", "E"), e0, "its constant, from the initial state"))
        notes.append(
            "dE/dt = 0 along the motion: multiply each reduced equation by its velocity "
            "and sum, as the lecture does with theta1'"
            + (
                "; the constraints move, so the conserved quantity is the Jacobi integral "
                "sum q' dL/dq' - L, not T + V"
                if ints.is_jacobi
                else ""
            )
        )
    elif ints.reason:
        notes.append(f"no energy integral: {ints.reason}")
    for k, p in ints.momenta.items():
        lines.append(Line(Term("p", k), p, f"momentum of the cyclic coordinate {k}"))
    sh = sol.shell
    if sh is not None:
        for s, v in sh.velocities.items():
            lines.append(Line(s, v, "from the conserved momentum"))
        lines.append(Line(sh.coordinate.velocity**2, sh.speed_squared, "on the energy shell"))
    elif sol.shell_reason and ints.energy is not None:
        notes.append(f"no energy shell: {sol.shell_reason}")
    return Step("The energy integral", tuple(lines), tuple(notes))


def _on_shell(sol) -> Step:
    system = sol.system
    sh = sol.shell
    x = sh.coordinate.name
    lines = [
        Line(system.constraint(k).multiplier, v, f"{x}'^2 put in")
        for k, v in sh.multipliers.items()
    ]
    notes = [f"lambda_{k}: omitted, {why}" for k, why in sh.omitted.items()]
    return Step(f"The multipliers as functions of {x}", tuple(lines), tuple(notes))


def _root_lines(sol, roots) -> list[Line]:
    out = []
    for i, r in enumerate(roots):
        where = f"{r.coordinate} = {r.value:.10g}" + (
            f" ({r.degrees:.2f} deg)" if r.degrees is not None else ""
        )
        if i:
            where = "later, had it still held: " + where
        lhs, _, rhs = r.equation.partition(" = ")
        try:
            left = parse(lhs, sol.symbols, "output")
            right = parse(rhs, sol.symbols, "output")
        except ExpressionError:
            continue
        out.append(Line(left, right, where))
    return out


def _conditions(sol) -> Step:
    system = sol.system
    lines: list[Line] = []
    notes: list[str] = []
    for table, verdicts, kind in (
        (sol.vanishes, sol.lets_go, "lets go"),
        (sol.slips, sol.slipping, "slips"),
    ):
        for k, roots in table.items():
            con = system.constraint(k)
            if kind == "lets go":
                lines.append(Line(con.multiplier, sp.Integer(0), f"where `{k}` lets go"))
            else:
                normal = system.constraint(con.friction.normal).multiplier
                lines.append(
                    Line(
                        Term("|.|", con.multiplier),
                        con.friction.mu * normal,
                        f"where `{k}` starts to slip",
                    )
                )
            v = verdicts.get(k)
            if v is not None and (v.when in ("at the start", "open at the start") or v.constant):
                notes.append(f"`{k}` {kind}: {v.when} ({v.reason})")
            elif roots:
                lines += _root_lines(sol, roots)
            elif sol.shell is not None:
                notes.append(f"`{k}` {kind}: never in the range the motion reaches")
            else:
                notes.append(f"`{k}` {kind}: not determined ({sol.shell_reason})")
    return Step("Where a constraint lets go or slips", tuple(lines), tuple(notes))


def _generalized(sol) -> Step:
    system = sol.system
    lines = []
    for k, comps in sol.generalized_forces.items():
        for q, e in comps.items():
            if e != 0:
                lines.append(Line(Term("Q", k, system.symbols[q]), e))
    notes = [
        "Q^(j)_q = lambda_j df_j/dq: the force constraint j exerts along each coordinate "
        "(zero components omitted)"
    ]
    return Step("Generalized constraint forces", tuple(lines), tuple(notes))


def _cartesian(sol, dyn, simp) -> Step:
    system = sol.system
    red = sol.reduction
    lecture = is_lecture(system)
    lines: list[Line] = []
    notes = [
        "virtual work: a displacement dq that breaks constraint j lets its force work, "
        "sum_q Q^(j)_q dq = F . dr_P = sum_q F . (dr_P/dq) dq for every dq, so "
        "F . dr_P/dq = Q^(j)_q for each coordinate q; dr_P/dq is the partial velocity of "
        "the material point P the force acts on (its body's rotation included)"
    ]
    for k, comps in sol.forces.items():
        c = system.constraint(k)
        spec = c.force
        J = contact_partial_velocities(system, spec).applyfunc(red.apply)
        point = sp.Matrix(spec.at).applyfunc(red.apply)
        lines.append(Line(Term("", f"r_{k}"), point.applyfunc(tidy), f"on {spec.bodies[0]}"))
        for i, coord in enumerate(system.coordinates):
            col = J[:, i].applyfunc(tidy)
            if any(x != 0 for x in col):
                lines.append(Line(Term("d/dq", f"r_{k}", coord.symbol), col))
        for d, e in comps.items():
            if d == "residual":
                lines.append(
                    Line(Term("", f"residual_{k}"), e, "|Q - J^T F|: zero when P carries it")
                )
            elif e is not None:
                lines.append(Line(Term("F", k, d), e))
            else:
                notes.append(f"`{k}` along {d}: undetermined (P's motion cannot do work along it)")
        bodies = [system.body(b) for b in spec.bodies]
        if c.friction is not None and any(b.angle is not None for b in bodies) and lecture:
            notes.append(
                CORRECTION + f"`{k}` acts on the material point of a turning body, which "
                "moves with the body's rotation; the lecture's cylinder converts the "
                "friction with the arc length R1 dtheta1 on the fixed cylinder and gets "
                "-(1/3) (R1 + R2)/R1 m g sin(theta1); the point of the rolling cylinder "
                "moves (R1 + R2) dtheta1 (theta2 held), which gives the force here "
                "(Newton-Euler on the rolling cylinder agrees)"
            )
    return Step("Cartesian constraint forces by virtual work", tuple(lines), tuple(notes))


def too_long(expr) -> bool:
    """Whether a line's expression is summarised rather than printed."""
    if isinstance(expr, sp.MatrixBase):
        return any(too_long(e) for e in expr)
    return sp.count_ops(expr) > READABLE_OPS
