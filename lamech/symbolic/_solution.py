"""``solve``: everything the Lagrange-multiplier method gives for a system, in one
frozen :class:`Solution` (a pure function of the :class:`~lamech.model.System`)."""

from __future__ import annotations

import functools
from dataclasses import dataclass, field, replace
from functools import cached_property

import numpy as np
import sympy as sp

from ..expr import to_text
from ..model import ModelError, System, circle_chart, result_units, with_chart
from ..model._checks import holding_at_start, initial_values, numeric_matrix, open_at_start
from ._budget import count_ops
from ._conditions import (
    Root,
    Verdict,
    closing_points,
    lets_go_verdict,
    sign_change_note,
    slip_points,
    slip_verdict,
    vanishing_points,
)
from ._derive import DegenerateConstraintsError, Dynamics, dynamics, kkt_numeric
from ._drives import drive_forces
from ._forces import cartesian_forces, generalized_forces, residual_notes
from ._integrals import Integrals, Shell, energy_shell, integrals
from ._normal import normal
from ._reduce import (
    CLOSED_FORM_LIMIT,
    SIMPLIFY_OPS,
    ClosedForms,
    Reduction,
    closed_forms,
    eliminate,
    spatial_angles,
)
from ._selfcheck import ClosedFormError, check_forms, manifold_states, printed_forms
from ._singular import singular_notes
from ._work import interrupted, labelled, work_budget

__all__ = ["Solution", "solve"]


@dataclass(frozen=True)
class Solution:
    """The results for one system; expressions are SymPy, in the independent coordinates.

    See :mod:`lamech.model` for the sign convention of every multiplier.
    """

    system: System
    dynamics: Dynamics
    reduction: Reduction
    closed: ClosedForms
    integrals: Integrals
    shell: Shell | None
    shell_reason: str | None
    vanishes: dict
    slips: dict
    generalized_forces: dict
    forces: dict
    initial_multipliers: dict = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    lets_go: dict = field(default_factory=dict)  # unilateral constraint -> Verdict
    slipping: dict = field(default_factory=dict)  # friction constraint -> Verdict
    readable_equations: tuple = ()  # the equations as a student would simplify them
    closes: dict = field(default_factory=dict)  # contact open at the start -> [Root] (f = 0)
    work: tuple = (0, 0)  # (units spent, budget) of the normal forms (_work.Work)
    untidied: tuple[str, ...] = ()  # results shown as derived: the budget ran out
    partial: bool = False  # interrupted (Ctrl-C) while simplifying: see the notes
    drives: dict = field(default_factory=dict)  # drive -> DriveForce (_drives)

    # ----- the public face --------------------------------------------------------
    @property
    def symbols(self) -> dict[str, sp.Symbol]:
        return self.system.symbols

    @property
    def coordinates(self) -> list[str]:
        return [c.name for c in self.system.coordinates]

    @property
    def units(self) -> dict[str, str]:
        """Where the file gives units (issue 46), the SI unit of each parameter, ``t``,
        coordinate, velocity, multiplier (``"lambda:<constraint>"``: N, N*m, N/m, ...)
        and Cartesian force component (``"force:<constraint>:<direction>"``), by the
        names a :class:`~lamech.numeric.Trajectory`'s columns use
        (:func:`lamech.model.result_units`); empty for a file without units. The
        expressions themselves are in SI, as every value in them is."""
        return result_units(self.system)

    @property
    def independent(self) -> list[str]:
        return [c.name for c in self.reduction.independent]

    @property
    def equations(self) -> list[sp.Expr]:
        """The Euler-Lagrange equations with multipliers (each = 0), simplified where that
        shortens them markedly (:func:`readable`); ``dynamics.equations`` as derived."""
        return list(self.readable_equations or self.dynamics.equations)

    @property
    def reduced_equations(self) -> list[sp.Expr]:
        return [
            c.acceleration - self.closed.accelerations[c.acceleration]
            for c in self.reduction.independent
            if c.acceleration in self.closed.accelerations
        ]

    @property
    def multipliers(self) -> dict[str, sp.Expr]:
        return dict(self.closed.multipliers)

    @property
    def energy(self) -> sp.Expr | None:
        return self.integrals.energy

    @property
    def conserved(self) -> list[sp.Expr]:
        return self.integrals.conserved

    @property
    def on_energy_shell(self) -> dict[str, sp.Expr]:
        return dict(self.shell.multipliers) if self.shell else {}

    @property
    def M(self) -> sp.Matrix:
        return self.dynamics.M

    @property
    def h(self) -> sp.Matrix:
        return self.dynamics.h

    @property
    def A(self) -> sp.Matrix:
        return self.dynamics.A

    @property
    def gamma(self) -> sp.Matrix:
        return self.dynamics.gamma

    @cached_property
    def equilibria(self) -> tuple:
        """Where the system can rest, each with its stability, normal modes and linear
        system: :func:`lamech.modes` of this solution (found on first use, then kept)."""
        from ._modes import modes  # _modes builds on this module

        return modes(self).equilibria

    def _repr_latex_(self) -> str:
        # Jupyter's display protocol calls this method on the object itself, so it is the
        # one import against the layer order (symbolic -> present), declared as an
        # exception in the import-linter contract. Everywhere else: lamech.to_latex(sol).
        from ..present import to_latex

        return to_latex(self, standalone_math=True)

    def _repr_html_(self) -> str:
        # Jupyter prefers HTML to LaTeX: the LaTeX results, and beside them the report
        # page's sliders (the same exception to the layer order as _repr_latex_)
        from ..present._notebook import solution_html

        return solution_html(self)

    def __repr__(self) -> str:
        return (
            f"<Solution of {self.system.title!r}: {len(self.coordinates)} coordinates, "
            f"{len(self.system.constraints)} constraints>"
        )


def solve(system: System | str, *, budget: int | None = None) -> Solution:
    """Derive equations, multipliers, integrals, vanishing/slip points and forces.

    ``budget`` bounds the work of simplification, in units counted by the normal forms
    (``lamech.symbolic._normal``; ``DEFAULT_BUDGET`` of ``lamech.symbolic._work`` by default),
    never in time: the same system and budget give the same results, written the same
    way, on any machine and in any thread. The multipliers straight from the KKT solve
    are always delivered; tidying goes to the multipliers first, then the conditions,
    the energy shell, the forces and the equations, while the budget lasts. What was
    left as derived is listed in ``untidied`` and in a note.

    A unilateral contact open at the start (f > 0) has lambda = 0 until it closes: the
    closed forms, the energy shell, the lift-off and slip points and the forces are
    those of the constraints that hold at the start, and for the open contact the
    points where it would close (f = 0) on that shell. The Euler-Lagrange equations
    shown keep every multiplier.

    ``system``: a System, or a problem file's path or a bundled example's name
    (``solve("pendulum")`` is ``solve(lamech.load("pendulum"))``); another type is a
    TypeError."""
    from ..problem._coerce import as_system

    given = as_system(system, "solve")
    system = in_circle_angles(given)
    if budget is not None and (
        isinstance(budget, bool) or not isinstance(budget, int) or budget <= 0
    ):
        raise ValueError(f"budget must be a positive whole number of work units, got {budget!r}")
    with work_budget(budget) as work, labelled("the equations of motion"):
        sol = _solve(system)
    untidied = tuple(dict.fromkeys(work.untidied))
    notes = sol.notes if system is given else (_chart_note(system),) + sol.notes
    if interrupted():
        notes += (
            "partial: interrupted (Ctrl-C) while simplifying; "
            + (", ".join(untidied) if untidied else "the rest")
            + " shown as derived, not tidied; run again without interrupting for "
            "the tidy forms",
        )
    elif untidied:
        notes += (
            f"the simplification budget ({work.limit} work units) ran out: "
            f"{', '.join(untidied)} shown as derived, not tidied; a larger budget "
            f"(budget={2 * work.limit}) tidies them",
        )
    return replace(
        sol, work=(work.used, work.limit), untidied=untidied, notes=notes, partial=interrupted()
    )


def in_circle_angles(system: System) -> System:
    """``system`` in the angle of each circle among its constraints (|r - c|^2 = R^2 in two
    coordinates: r = c + R (sin theta, -cos theta), :func:`lamech.model.circle_chart`),
    when the file gives no [parametrisation] and the closed forms stay within
    :data:`._reduce.CLOSED_FORM_LIMIT` unknowns; else ``system`` itself.

    A circle's angle covers all of it, where solving x^2 + y^2 = l^2 for y takes one
    sign of a square root and covers half (the elimination refuses that, and the
    results would keep x and y); in the angle the trammel, the Cartesian pendulum or a
    bead on a hoop has one degree of freedom left, so the energy shell, where a contact
    lets go and the equilibria follow. Contacts that hold at the start are charted too
    (the results hold while they do, as for any eliminated contact); spheres are not
    (their angles are singular at the poles): they keep their coordinates."""
    if system.chart is not None:
        return system
    holding = holding_at_start(system)
    proposal = circle_chart(holding, unilateral=True, spheres=False)
    if proposal is None:
        return system
    mapped = {name for name, _ in proposal.map}
    independent = (
        len(proposal.coordinates)
        + sum(1 for c in system.coordinates if c.name not in mapped)
        - sum(1 for c in holding.constraints if c.holonomic and c.name not in proposal.constraints)
    )
    if independent + len(system.constraints) > CLOSED_FORM_LIMIT:
        return system
    try:
        charted = with_chart(system, proposal, automatic=True)  # placed at the start
    except ModelError:
        return system
    return charted


def _chart_note(system: System) -> str:
    """What :func:`in_circle_angles` did, in one note."""
    chart = system.chart
    names = ", ".join(c.name for c in chart.coordinates)
    where = "; ".join(f"{k} = {to_text(e)}" for k, e in chart.map)
    return (
        f"results in the angle of each circle among the constraints, from the downward "
        f"vertical ({names}: {where}), which covers all of it; a [parametrisation] in "
        "the file chooses other coordinates"
    )


def _solve(system: System) -> Solution:
    dyn = dynamics(system)
    opened = open_at_start(system)
    holding = holding_at_start(system)
    dyn_h = dynamics(holding) if holding is not system else dyn
    red = eliminate(holding)
    forms = closed_forms(dyn_h, red)
    checked_notes = []
    if not forms.skipped:
        with labelled("self-check"):
            checked_notes = _self_check(dyn_h, red, forms) + singular_notes(holding, red, forms)
    with labelled("energy"):
        ints = integrals(dyn_h, red)
    notes = list(system.notes) + list(red.notes) + checked_notes
    proposal = circle_chart(system)
    if proposal is not None:
        circles = ", ".join(f"`{n}`" for n in proposal.constraints)
        angles = ", ".join(proposal.coordinates)
        notes.append(
            f"{circles} {'is a circle' if len(proposal.constraints) == 1 else 'are circles'}"
            " (or spheres): `with_chart(system, circle_chart(system))` (from lamech.model)"
            f" gives every result in {angles}, as this "
            "[parametrisation] in the file would: " + proposal.toml().replace("\n", "; ")
        )
    initial = {}
    resting = False  # at rest in equilibrium at the start: the state never changes
    shell: Shell | None
    why: str | None  # the reason there is no shell
    if forms.singular:
        raise DegenerateConstraintsError(_singular_message(holding, dyn_h))
    if forms.skipped:
        notes.append(
            forms.skipped + "; M, h, A, gamma are given and the multipliers are "
            "evaluated numerically at the initial state"
        )
    if system.constraints:
        # numbers beside the closed forms (a check, and the value of one too long to
        # read), or in place of the missing ones
        state = {**system.parameter_values, system.t: 0.0, **initial_values(system)}
        try:
            acc, lam = kkt_numeric(dyn_h, state)
            initial = {c.name: float(v) for c, v in zip(holding.constraints, lam)}
            resting = _in_equilibrium(dyn_h, state, acc)
        except DegenerateConstraintsError as exc:
            if forms.skipped:
                notes.append(str(exc))
    if forms.skipped:
        shell, why = None, "closed forms were skipped"
    else:
        with labelled("energy shell"):
            shell, why = energy_shell(dyn_h, red, ints, forms)
    if opened:
        listed = ", ".join(f"`{k}` (f = {v:.6g})" for k, v in opened.items())
        off = [c.name for c in system.constraints if c not in holding.constraints]
        notes.append(
            f"contact {listed} is open at the start: lambda = 0 until it closes, so the "
            "multipliers, the energy shell, the lift-off and slip points and the forces "
            f"are those of the other constraints (without {', '.join(off)}); lamech "
            "simulate follows the motion through the landing"
        )
    vanishes: dict[str, list[Root]] = {}
    slips: dict[str, list[Root]] = {}
    closes: dict[str, list[Root]] = {}
    undecided: set[str] = set()  # open contacts whose closing the shell cannot follow
    with labelled("conditions"):
        for c in system.constraints:
            if c.name in opened:
                vanishes[c.name] = []
                found = closing_points(holding, shell, c.expr, red) if shell else None
                closes[c.name] = found or []
                if found is None:
                    undecided.add(c.name)
                continue
            if c.unilateral:
                vanishes[c.name] = vanishing_points(holding, shell, c.name) if shell else []
            elif shell and (said := sign_change_note(holding, shell, c.name, initial.get(c.name))):
                notes.append(said)  # a string or contact written bilateral: where it lets go
            if c.friction is not None:
                slips[c.name] = slip_points(holding, shell, c.name) if shell else []
    if shell:
        for name, reason in shell.omitted.items():
            notes.append(f"lambda_{name} on the energy shell omitted: {reason}")
    with labelled("conditions"):
        lets_go, slipping = _verdicts(
            system,
            forms,
            initial,
            opened,
            vanishes,
            slips,
            closes,
            undecided,
            None if shell else why,
            resting,
        )
    with labelled("forces"):
        gen = generalized_forces(dyn_h, red, forms.multipliers, forms.manifold)
        cart = cartesian_forces(dyn_h, red, forms.multipliers)
        notes += residual_notes(dyn_h, red, cart)  # a residual: which bodies to name
    with labelled("equations"):
        equations = tuple(readable(e, system) for e in dyn.equations)
    sol = Solution(
        system,
        dyn,
        red,
        forms,
        ints,
        shell,
        why,
        vanishes,
        slips,
        gen,
        cart,
        initial,
        tuple(notes),
        lets_go,
        slipping,
        equations,
        closes,
    )
    if any(c.drive is not None for c in system.constraints):
        with labelled("drives"):
            sol = replace(sol, drives=drive_forces(sol))
    return sol


def _self_check(dyn: Dynamics, red: Reduction, forms: ClosedForms) -> list[str]:
    """Raise :class:`._selfcheck.ClosedFormError` when a printed multiplier or reduced
    acceleration disagrees with the KKT system at random states over the whole manifold
    (:mod:`._selfcheck`); the note that the file's [parametrisation] misses part of the
    manifold when it does (the results then hold where it reaches)."""
    checked = printed_forms(dyn.system, red, forms)
    if not checked:
        return []
    bad, _ = check_forms(dyn, red, checked, manifold_states(dyn))
    misses = [d for d in bad if d.chart_miss]
    if len(misses) < len(bad):
        raise ClosedFormError([d for d in bad if not d.chart_miss], f"for {dyn.system.title!r}")
    if not misses:
        return []
    at = ", ".join(f"{k} = {v:.4g}" for k, v in misses[0].state.items() if k != "t")
    return [
        f"the [parametrisation] does not reach every state on the constraints (not "
        f"{at}, for one): the results hold only where it does; an angle covers a whole "
        "circle"
    ]


def readable(equation: sp.Expr, system: System) -> sp.Expr:
    """An equation as a student would tidy it: expanded, collected by accelerations and
    multipliers, each coefficient and the rest trig-simplified (sin^2 + cos^2 = 1) and
    common factors pulled out. Kept only when it is markedly shorter (by a quarter), so
    short textbook forms stay as derived; bounded by size (:data:`SIMPLIFY_OPS`)."""
    ops = count_ops(equation)
    if ops > 4 * SIMPLIFY_OPS:
        return equation
    syms = system.qdd + system.multipliers
    spatial = spatial_angles(system)
    angles = tuple(q for q in system.q if q not in spatial)
    try:
        expanded = sp.expand(equation)
        coefficient = functools.partial(_coefficient, angles=angles)
        new = sp.collect(expanded, syms, func=coefficient)
        # the rest (gravity, the velocities' terms) is tidied whole; grouped by its
        # products of velocities, each group's coefficient tidied on its own, it may read
        # shorter (a relative-angle chain: g sin(q1 + q2) beside -sin(q2) q1' q2', where
        # tidied whole the gravity term is written in q1 and q2 too)
        kept = [a for a in sp.Add.make_args(new) if a.has(*syms)]
        rest = sp.Add(*[a for a in sp.Add.make_args(new) if not a.has(*syms)])
        groups: dict = {}
        for term in sp.Add.make_args(expanded):
            if not term.has(*syms):
                c, v = term.as_independent(*system.qd, as_Add=False)
                groups[v] = groups.get(v, sp.Integer(0)) + c
        grouped = sp.factor_terms(sp.Add(*[coefficient(c) * v for v, c in groups.items()]))
        if count_ops(grouped) < count_ops(rest):
            new = sp.Add(*kept) + grouped
    except (TypeError, ValueError, RecursionError, NotImplementedError):
        return equation
    return new if count_ops(new) <= 0.75 * ops else equation


@functools.lru_cache(maxsize=1024)
def _coefficient(c: sp.Expr, angles: tuple = ()) -> sp.Expr:
    """A coefficient of :func:`readable`, trig-simplified with common factors pulled out;
    remembered, since the equations share theirs (M is symmetric, and sin(theta) alone
    is the coefficient of many terms: 7 ms of ``trigsimp`` each time), and left alone
    when it is a symbol or a function of one (``trigsimp`` gives it back)."""
    if c.is_Atom or (c.is_Function and all(a.is_Atom for a in c.args)):
        return c
    return sp.factor_terms(normal(c, angles=angles))


def _verdicts(
    system: System,
    forms: ClosedForms,
    initial: dict,
    opened: dict,
    vanishes: dict,
    slips: dict,
    closes: dict,
    undecided: set,
    shell_reason: str | None,
    resting: bool = False,
) -> tuple[dict[str, Verdict], dict[str, Verdict]]:
    """Does each unilateral constraint let go, each friction constraint slip: at the
    start, never, at the roots, open at the start, or not determined (see
    :class:`Verdict`)."""
    lets_go: dict[str, Verdict] = {}
    slipping: dict[str, Verdict] = {}
    for c in system.constraints:
        if c.name in opened:
            lets_go[c.name] = _open_verdict(
                c.name, opened[c.name], closes[c.name], c.name in undecided
            )
            continue
        if c.friction is not None and c.friction.normal in opened:
            slipping[c.name] = Verdict(
                "slips",
                "open at the start",
                f"its normal constraint `{c.friction.normal}` is open at the start: no "
                "friction until it closes",
            )
            continue
        if c.unilateral:
            if forms.multipliers:
                lets_go[c.name] = lets_go_verdict(
                    system,
                    c.name,
                    forms.multipliers[c.name],
                    vanishes[c.name],
                    shell_reason,
                    resting,
                )
            elif c.name in initial and initial[c.name] < 0:
                lets_go[c.name] = Verdict(
                    "lets go",
                    "at the start",
                    f"lambda_{c.name} = {initial[c.name]:.6g} < 0 at the initial state (numeric)",
                )
        if c.friction is not None and forms.multipliers:
            slipping[c.name] = slip_verdict(
                system, c.name, forms.multipliers, slips[c.name], shell_reason, resting
            )
    return lets_go, slipping


def _in_equilibrium(dyn, state: dict, acc) -> bool:
    """Whether the system is locked at rest: no freedom left (the constraints' Jacobian
    of full rank), at rest with no acceleration, and nothing in it depending on time.
    Then it stays at its initial state and every multiplier keeps its initial value (a
    ladder held by a wall and a rough floor). A system with freedom left, at rest in an
    equilibrium, is not: the lecture's cylinder released at the top of the other
    (unstable) is followed as it rolls off, as a nudge would start it."""
    system = dyn.system
    n = len(system.coordinates)
    A = numeric_matrix(dyn.A, state).reshape(dyn.A.rows, n) if dyn.A.rows else np.zeros((0, n))
    if dyn.A.rows < n or np.linalg.matrix_rank(A) < n:
        return False
    if any(abs(state.get(v, 0.0)) > 0 for v in system.qd):
        return False
    parts = (dyn.M, dyn.h, dyn.Q, dyn.A, dyn.gamma)
    if any(system.t in sp.Matrix(p).free_symbols for p in parts):
        return False
    scale = 1.0 + max((abs(float(v)) for v in state.values()), default=1.0)
    return bool(np.all(np.abs(np.asarray(acc, dtype=float)) <= 1e-10 * scale))


def _open_verdict(name: str, gap: float, roots: list[Root], undecided: bool) -> Verdict:
    """A contact open at the start: lambda = 0 until it closes, where f = 0 (if the
    other constraints still hold there), or never in the range the motion reaches."""
    if roots:
        r = roots[0]
        deg = f" ({r.degrees:.2f}°)" if r.degrees is not None else ""
        where = (
            f"; it closes where {r.equation}: {r.coordinate} = {r.value:.10g}{deg}, if the "
            "other constraints still hold there"
        )
    elif not undecided:
        where = "; it never closes in the range the motion reaches"
    else:
        where = ""
    return Verdict(
        "lets go",
        "open at the start",
        f"f = {gap:.6g} > 0 at the initial state: lambda_{name} = 0 until it closes{where}",
    )


def _singular_message(system: System, dyn: Dynamics) -> str:
    """Why the KKT matrix is singular, naming what to fix: a coordinate whose velocity is
    missing from T (the commonest typo: theta^2 for theta'^2), else the dependent
    constraints or the motion without inertia found at the initial state."""
    state = {**system.parameter_values, system.t: 0.0, **initial_values(system)}
    try:
        kkt_numeric(dyn, state)
        detail = "the KKT matrix is singular for every state"
    except DegenerateConstraintsError as exc:
        detail = str(exc)
    missing = [c for c in system.coordinates if not system.T.has(c.velocity)]
    if missing:
        names = ", ".join(f"`{c.name}'`" for c in missing)
        detail += (
            f"; {names} does not appear in T, so nothing gives "
            f"`{missing[0].name}` inertia: check T for a missing prime "
            f"(e.g. {missing[0].name}'^2 where {missing[0].name}^2 was written)"
        )
    return "the equations of motion cannot be solved for the accelerations: " + detail
