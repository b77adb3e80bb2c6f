"""Presenting a :class:`~lamech.symbolic.Solution`: readable text, LaTeX, and JSON.

Nothing is computed here; expressions print in the problem-file grammar
(:func:`lamech.expr.to_text`) so that JSON strings parse back.
"""

from __future__ import annotations

import math
import re

import sympy as sp

from ..expr import ExpressionError, latex, parse
from ..expr import to_text as _expr_text
from ..symbolic._budget import count_ops, graph_symbols
from ..symbolic._reduce import READABLE_OPS
from ._drives import drive_lines, drives_json
from ._plain import tex_comment, tex_label, tex_text

__all__ = ["to_text", "to_latex", "to_json"]


def _unit(dimension) -> str:
    """`` [N]``: a result's unit in SI symbols, beside it in the text; "" when unknown."""
    return "" if dimension is None else f" [{dimension.si()}]"


def _tex_unit(dimension) -> str:
    r"""``\,\mathrm{N}``, ``\,\mathrm{N\,m}``, ``\,\mathrm{N/m}``: a result's unit after
    it in LaTeX; "" when unknown."""
    if dimension is None:
        return ""
    text = dimension.si()
    text = re.sub(
        r"\^\(?(-?\d+)(?:/(\d+))?\)?", lambda m: "^{" + m.group(0)[1:].strip("()") + "}", text
    )
    return r"\,\mathrm{" + text.replace("*", r"\,") + "}"


def _units_json(system) -> dict:
    """``"units"`` of ``--json`` (issue 46): the unit of each multiplier and Cartesian
    force, and of each coordinate and velocity whose dimension is known (an angle, of
    dimension 1, in rad), in SI symbols."""
    u = system.units
    coordinates = {}
    for c in system.coordinates:
        for name in (c.name, c.name + "'"):
            d = u.of(name)
            if d is not None:
                text = d.si()
                coordinates[name] = "rad" if text == "1" else "rad/s" if text == "1/s" else text
    return {
        "multipliers": {k: d.si() for k, d in u.multipliers},
        "forces": {k: d.si() for k, d in u.forces},
        "coordinates": coordinates,
    }


CONVENTION = (
    "d/dt dL/dq' - dL/dq - sum_j lambda_j df_j/dq = Q  (unilateral: f >= 0 holds while lambda >= 0)"
)


def _t(expr) -> str:
    return _t_whole(expr)


def _t_whole(expr) -> str:
    if expr is None:
        return "null"
    try:
        return _expr_text(expr)
    except ValueError:
        return str(expr)


def _ops(expr) -> int:
    return 0 if expr is None else count_ops(expr)  # remembered from the solve


CSE_OPS = 3_000_000
"""Beyond this many operations (counted as a tree) a result is summarised, not printed."""
CSE_CHARS = 40_000
"""The most characters the named subexpressions of one report may take."""


class _Named:
    """The long results of a report written with named common subexpressions: one
    SymPy ``cse`` over all of them (the multipliers, accelerations and forces of a
    mechanism share most of their parts: the four-bar's 270,000-character multipliers
    come to 3,500 characters of definitions, in a quarter of a second), the names
    (w1, w2, ...) chosen apart from every name in the results. ``shown`` gives a result
    in these names, or a summary when the definitions would not fit
    :data:`CSE_CHARS`; ``definitions`` lists them in order, each using only the ones
    before it."""

    def __init__(
        self,
        exprs: list,
        above: int = READABLE_OPS,
        upto: float = CSE_OPS,
        chars: float = CSE_CHARS,
    ) -> None:
        self.reduced: dict[int, sp.Expr] = {}
        self.definitions: list[tuple[sp.Symbol, sp.Expr]] = []
        longs = []
        for e in exprs:
            if e is not None and above < _ops(e) <= upto and id(e) not in self.reduced:
                self.reduced[id(e)] = e
                longs.append(e)
        if not longs:
            return
        taken = {str(x) for x in graph_symbols(longs)}
        prefix = "w"
        while any(n.startswith(prefix) for n in taken):
            prefix += "w"
        try:
            reps, rest = sp.cse(
                longs, symbols=sp.numbered_symbols(prefix, start=1), order="none", list=True
            )
        except (RecursionError, TypeError, ValueError):
            self.reduced = {}
            return
        if sum(len(_t(b)) for _, b in reps) > chars:
            self.reduced = {}
            return
        self.definitions = reps
        self.reduced = {id(e): r for e, r in zip(longs, rest)}

    def get(self, expr):
        return self.reduced.get(id(expr))

    def shown(self, expr, value: float | None = None) -> str:
        """``expr`` as text; when longer than :data:`READABLE_OPS` operations, in the
        named subexpressions, or a short summary (its size, its value at the initial
        state where known). The full form is in ``--json`` and the Python API."""
        ops = _ops(expr)
        if ops <= READABLE_OPS:
            return _t(expr)
        at = f"{value:.12g} at the initial state" if value is not None else ""
        reduced = self.get(expr)
        if reduced is not None:
            return _t(reduced) + (f"   (= {at})" if at else "")
        return f"<closed form of {ops} operations{'; ' + at if at else ''}; in full: --json>"


def _long_results(sol) -> list:
    """The results a report may print in named subexpressions, in report order."""
    out = [sol.closed.accelerations.get(k) for k in sol.closed.sizes if not isinstance(k, str)]
    out += list(sol.multipliers.values())
    out += [e for comps in sol.forces.values() for e in comps.values()]
    return out


def _long_note(sol) -> str | None:
    """The note that says which closed forms are summarised, and where they are whole."""
    long = {k: n for k, n in sol.closed.sizes.items() if isinstance(k, str)}
    long_acc = [k for k in sol.closed.sizes if not isinstance(k, str)]
    if not long and not long_acc:
        return None
    parts = [f"lambda_{k} ({n} operations)" for k, n in long.items()]
    parts += [f"{_t(k)} ({sol.closed.sizes[k]} operations)" for k in long_acc]
    return (
        f"closed forms over {READABLE_OPS} operations: " + ", ".join(parts) + "; printed "
        "with named common subexpressions (see 'Named subexpressions') where they fit, "
        "else summarised; `lamech solve --json` and the Python API "
        "(solution.multipliers, solution.reduced_equations) give them whole"
    )


def _json_expr(expr):
    return None if expr is None else _t(expr)


def _initial_text(sol) -> str:
    parts = []
    for c in sol.reduction.independent:
        parts.append(f"{c.name} = {_t(c.initial)}, {c.name}' = {_t(c.initial_velocity)}")
    return "; ".join(parts)


JSON_WHOLE_OPS = 10_000
"""Results up to this many operations (about 25,000 characters) are written whole in
``--json``; larger ones in named common subexpressions listed under
``"subexpressions"``. Every bundled example's results are whole; SymPy's four-bar in
relative joint angles has multipliers of 270,000 characters whole (SymPy's own raw
forms: 132,000) and reduced equations of a million, which share most of their parts:
in its 3,500 characters of definitions the whole document is a few pages, printed in
a fraction of the 20 s the whole forms took."""


def _json_results(sol) -> list:
    """Every expression ``--json`` may write in named subexpressions: the report's long
    results, the reduced equations, the generalized forces and the shell's multipliers."""
    out = _long_results(sol) + list(sol.reduced_equations)
    out += [e for row in sol.generalized_forces.values() for e in row.values()]
    if sol.shell is not None:
        out += list(sol.shell.multipliers.values())
    return out


def to_json(sol) -> dict:
    """The ``--json`` object (schema in docs/reference/json.md)."""
    system = sol.system
    named = _Named(_json_results(sol), above=JSON_WHOLE_OPS, upto=math.inf, chars=math.inf)

    def _t(expr) -> str:
        reduced = named.get(expr)
        return _t_whole(expr if reduced is None else reduced)

    def _json_expr(expr):
        return None if expr is None else _t(expr)

    out: dict = {
        "title": system.title,
        "coordinates": sol.coordinates,
        "independent": sol.independent,
        "equations": [_t(e) for e in sol.equations],
        "reduced_equations": [_t(e) for e in sol.reduced_equations],
        "multipliers": {k: _t(v) for k, v in sol.multipliers.items()},
        "energy": _json_expr(sol.energy),
        "conserved": [_t(e) for e in sol.conserved],
    }
    if getattr(sol, "partial", False):
        out["partial"] = True  # interrupted while simplifying: see "notes"
    if sol.shell is not None:
        out["on_energy_shell"] = {k: _t(v) for k, v in sol.shell.multipliers.items()}
    out["vanishes"] = {k: [r.to_json() for r in v] for k, v in sol.vanishes.items()}
    out["slips"] = {k: [r.to_json() for r in v] for k, v in sol.slips.items()}
    if sol.closes:
        out["closes"] = {k: [r.to_json() for r in v] for k, v in sol.closes.items()}
    out["lets_go"] = {k: v.to_json() for k, v in sol.lets_go.items()}
    out["slipping"] = {k: v.to_json() for k, v in sol.slipping.items()}
    out["generalized_forces"] = {
        k: {q: _t(e) for q, e in v.items()} for k, v in sol.generalized_forces.items()
    }
    out["forces"] = {k: {d: _json_expr(e) for d, e in v.items()} for k, v in sol.forces.items()}
    if sol.initial_multipliers:
        out["initial_multipliers"] = sol.initial_multipliers
    if named.definitions:
        out["subexpressions"] = {_t_whole(w): _t_whole(e) for w, e in named.definitions}
    if system.units is not None:
        # the flat map every command gives (Solution.units: "lambda:contact": "N", a
        # chart's angle, each parameter), then the nested keys kept for old readers
        old = _units_json(system)
        flat = dict(getattr(sol, "units", None) or {})
        out["units"] = {**flat, **{k: v for k, v in old.items() if k not in flat}}
    if getattr(sol, "drives", None):
        out["drives"] = drives_json(sol)
    out["notes"] = list(sol.notes)
    return out


def _root_text(r) -> str:
    deg = f" ({r.degrees:.2f}°)" if r.degrees is not None else ""
    return f"{r.equation}:  {r.coordinate} = {r.value:.10g}{deg}"


def sensitivity_text(r) -> str:
    """A root's derivatives by the parameters, the nonzero ones by name and the rest
    grouped: "d theta1/d mu = 0.92282; 0 for m, g, R1, R2"."""
    parts, zero, undefined = [], [], []
    for p, v in r.sensitivity.items():
        if v is None:
            undefined.append(p)
        elif v == 0:
            zero.append(p)
        else:
            parts.append(f"d {r.coordinate}/d {p} = {v:.6g}")
    if zero:
        parts.append(("0 for " if parts else f"d {r.coordinate}/d p = 0 for ") + ", ".join(zero))
    if undefined:
        parts.append("undefined (a double root) for " + ", ".join(undefined))
    return "; ".join(parts)


def _condition_lines(sol, table: dict, verdicts: dict) -> list[str]:
    """The answer per constraint: at the start, never (with the reason), the roots in the
    order the motion meets them, or not determined; the parameter condition and a hint
    where they help."""
    lines = []
    for k, roots in table.items():
        v = verdicts.get(k)
        pad = " " * len(k)
        if v is not None and v.when == "open at the start":
            lines.append(f"  {k}: open at the start ({v.reason})")
        elif v is not None and (v.when == "at the start" or v.constant):
            lines.append(f"  {k}: {v.when} ({v.reason})")
            if v.condition and (v.when == "at the start" or v.kind == "slips"):
                holds = "sticks" if v.kind == "slips" else "stays on"
                # a constant ratio (or a system at rest in equilibrium) holds for all time
                when = "" if v.constant else " at the start"
                lines.append(f"  {pad}  {holds}{when} while {v.condition}")
            if v.hint:
                lines.append(f"  {pad}  note: {v.hint}")
        elif roots:
            lines += [f"  {k}: {_root_text(r)}" for r in roots[:1]]
            if roots[0].sensitivity:
                lines.append(f"  {pad}  sensitivity: {sensitivity_text(roots[0])}")
            lines += [f"  {pad}  later, had it still held: {_root_text(r)}" for r in roots[1:]]
        elif sol.shell:
            lines.append(f"  {k}: never in the range the motion reaches")
        else:
            lines.append(f"  {k}: not determined ({sol.shell_reason})")
    return lines


def to_text(sol) -> str:
    """The readable report printed by ``lamech solve``."""
    s = sol.system
    named = _Named(_long_results(sol))
    _shown = named.shown
    units = s.units

    def unit(constraint: str, force: bool = False) -> str:
        if units is None:
            return ""
        return _unit(units.force(constraint) if force else units.multiplier(constraint))

    lines: list[str] = [s.title, "=" * len(s.title), ""]
    if getattr(sol, "partial", False):
        lines += [
            "PARTIAL: interrupted (Ctrl-C) while simplifying; what was not yet tidied is "
            "shown as derived (see the notes)",
            "",
        ]
    # What the loader found suspicious (a T that disagrees with the bodies) comes first:
    # it may invalidate everything below.
    warnings = [n for n in sol.notes if n in s.notes]
    lines += [f"warning: {n}" for n in warnings] + ([""] if warnings else [])
    lines.append(
        "coordinates: "
        + ", ".join(sol.coordinates)
        + (
            f"   independent: {', '.join(sol.independent)}"
            if sol.independent != sol.coordinates
            else ""
        )
    )
    for coord, expr in sol.reduction.eliminated:
        lines.append(f"  eliminated: {coord.name} = {_t(expr)}")
    lines += ["", "Euler-Lagrange equations with multipliers", "  convention: " + CONVENTION]
    width = max((len(c) for c in sol.coordinates), default=1)
    for name, e in zip(sol.coordinates, sol.equations):
        lines.append(f"  {name:<{width}} : {_t(e)} = 0")
    if s.constraints:
        lines += ["", "Constraints"]
        for c in s.constraints:
            tags = []
            if c.unilateral:
                tags.append("unilateral, holds while f >= 0")
            if not c.holonomic:
                tags.append("non-holonomic")
            if c.friction is not None:
                tags.append(f"friction mu = {_t(c.friction.mu)} on `{c.friction.normal}`")
            tag = f"   ({'; '.join(tags)})" if tags else ""
            lhs = "f" if c.holonomic else "g"
            lines.append(f"  {c.name}: {lhs} = {_t(c.expr)} = 0{tag}")
    if sol.reduced_equations:
        lines += ["", "Reduced equations of motion"]
        for c in sol.reduction.independent:  # by coordinate (some may have none)
            a = sol.closed.accelerations.get(c.acceleration)
            if a is None:
                continue
            if c.acceleration in sol.closed.sizes:
                lines.append(f"  {_t(c.acceleration)} = {_shown(a)}")
            else:
                lines.append(f"  {_t(c.acceleration - a)} = 0")
    if sol.multipliers:
        lines += ["", "Multipliers (on the constraint manifold)"]
        lines += [
            f"  lambda_{k} = {_shown(v, sol.initial_multipliers.get(k))}{unit(k)}"
            for k, v in sol.multipliers.items()
        ]
    elif sol.initial_multipliers:
        lines += ["", "Multipliers at the initial state (numeric)"]
        lines += [f"  lambda_{k} = {v:.12g}{unit(k)}" for k, v in sol.initial_multipliers.items()]
    lines += ["", "Conserved quantities"]
    if sol.energy is not None:
        label = "Jacobi integral" if sol.integrals.is_jacobi else "energy"
        lines.append(f"  {label}: {_t(sol.energy)}")
    elif sol.integrals.reason:
        lines.append(f"  energy: not conserved ({sol.integrals.reason})")
    for k, p in sol.integrals.momenta.items():
        lines.append(f"  momentum of cyclic {k}: {_t(p)}")
    if sol.shell is not None:
        sh = sol.shell
        x = sh.coordinate.name
        lines += [
            "",
            f"On the energy shell (initial state {_initial_text(sol)})",
            f"  {x}'^2 = {_t(sh.speed_squared)}",
        ]
        lines += [f"  lambda_{k} = {_t(v)}{unit(k)}" for k, v in sh.multipliers.items()]
        lines += [f"  lambda_{k}: omitted, {why}" for k, why in sh.omitted.items()]
    if sol.vanishes:
        lines += ["", "Where a unilateral constraint lets go (lambda = 0)"]
        lines += _condition_lines(sol, sol.vanishes, sol.lets_go)
    if sol.slips:
        lines += ["", "Where a friction constraint starts to slip (|lambda| = mu lambda_normal)"]
        lines += _condition_lines(sol, sol.slips, sol.slipping)
    if sol.generalized_forces:
        lines += ["", "Generalized constraint forces Q^(j) = lambda_j df_j/dq"]
        for j, (k, comps) in enumerate(sol.generalized_forces.items()):
            if k in sol.closed.sizes:  # lambda_k too long: Q = lambda_k dF/dq' as it stands
                lam = s.constraints[j].multiplier
                comps = {q: sol.reduction.apply(sol.A[j, i]) * lam for i, q in enumerate(comps)}
            if all(_ops(e) <= READABLE_OPS for e in comps.values()):
                body = ", ".join(f"{q}: {_t(e)}" for q, e in comps.items())
                lines.append(f"  {k}: {body}")
            else:  # one per line
                lines.append(f"  {k}:")
                lines += [f"    {q}: {_shown(e)}" for q, e in comps.items()]
    if sol.forces:
        lines += ["", "Cartesian constraint forces (virtual work on the material point)"]
        for k, comps in sol.forces.items():
            c = s.constraint(k)
            where = " on " + " / ".join(c.force.bodies) if c.force else ""
            lines.append(f"  {k}{where}:")
            for d, e in comps.items():
                value = (
                    "undetermined (the point's motion cannot do work along it)"
                    if e is None
                    else _shown(e) + unit(k, force=True)
                )
                lines.append(f"    {d} = {value}")
    lines += drive_lines(sol, _shown, unit)
    if named.definitions:
        lines += ["", "Named subexpressions (in the results above; each uses only those before it)"]
        lines += [f"  {_t(w)} = {_t(e)}" for w, e in named.definitions]
    rest = [n for n in sol.notes if n not in s.notes]
    long = _long_note(sol)
    rest += [long] if long else []
    if rest:
        lines += ["", "Notes"] + [f"  - {n}" for n in rest]
    return "\n".join(lines) + "\n"


def _latex_names(sol) -> dict:
    return latex_names(sol.system)


def latex_names(system) -> dict:
    """{symbol: LaTeX}: dotted velocities and accelerations, lambda_{name} multipliers."""
    names = {}
    for c in system.coordinates + system.chart_coordinates:
        base = sp.latex(c.symbol)
        names[c.velocity] = rf"\dot{{{base}}}"
        names[c.acceleration] = rf"\ddot{{{base}}}"
    for c in system.constraints:
        names[c.multiplier] = rf"\lambda_{{{tex_label(c.name)}}}"
    return names


def _tex(expr, names) -> str:
    return latex(expr, symbol_names=names)


def to_latex(sol, standalone_math: bool = False) -> str:
    """A LaTeX fragment (amsmath ``align*``) with the main results; paste into a document."""
    names = _latex_names(sol)
    rows: list[str] = []

    def add(label: str, lhs: str, rhs: str) -> None:
        rows.append(rf"{lhs} &= {rhs} && \text{{{tex_text(label)}}}")

    for name, e in zip(sol.coordinates, sol.equations):
        add(f"EL, {name}", _tex(e, names), "0")

    named = _Named(_long_results(sol))

    def tex_or_size(e) -> str:
        ops = _ops(e)
        if ops <= READABLE_OPS:
            return _tex(e, names)
        reduced = named.get(e)
        if reduced is not None:
            return _tex(reduced, names)
        return rf"\text{{({ops} operations; in full: --json)}}"

    for e in sol.reduced_equations:
        if _ops(e) <= READABLE_OPS:
            add("reduced", _tex(e, names), "0")
    units = sol.system.units

    def unit(k: str, force: bool = False) -> str:
        if units is None:
            return ""
        return _tex_unit(units.force(k) if force else units.multiplier(k))

    def tex_with_unit(e, tex: str, k: str, force: bool = False) -> str:
        """``tex`` and the unit of ``k``'s result; a sum in parentheses before its unit."""
        u = unit(k, force)
        if u and isinstance(e, sp.Add):
            return rf"\left({tex}\right){u}"
        return tex + u

    for k, v in sol.multipliers.items():
        lhs = names[sol.system.constraint(k).multiplier]
        add("multiplier", lhs, tex_with_unit(v, tex_or_size(v), k))
    if sol.energy is not None:
        label = "Jacobi integral" if sol.integrals.is_jacobi else "energy"
        add(label, "E", _tex(sol.energy, names))
    if sol.shell is not None:
        for k, v in sol.shell.multipliers.items():
            lhs = names[sol.system.constraint(k).multiplier]
            add("on the energy shell", lhs, tex_with_unit(v, _tex(v, names), k))
    for kind, table, verdicts in (
        ("lets go", sol.vanishes, sol.lets_go),
        ("slips", sol.slips, sol.slipping),
    ):
        for k, roots in table.items():
            v = verdicts.get(k)
            if v is not None and (v.when in ("at the start", "open at the start") or v.constant):
                add(
                    f"{k} {kind}: {v.when}",
                    rf"\text{{{tex_text(k)}}}",
                    rf"\text{{{tex_text(v.when)}: {tex_text(v.reason)}}}",
                )
                continue
            for i, r in enumerate(roots):
                # only the first root is an event; later ones are where the constraint
                # would have let go had it still held (as the text report says)
                label = f"{k} {kind}" if i == 0 else f"{k}: later, had it still held"
                lhs, rhs = r.equation.split(" = ", 1)
                try:
                    L = parse(lhs, sol.symbols, "output")
                    R = parse(rhs, sol.symbols, "output")
                except ExpressionError:
                    continue
                deg = rf"\quad({r.degrees:.2f}^\circ)" if r.degrees is not None else ""
                add(
                    f"{label}: {r.coordinate} = {r.value:.6g}", _tex(L, names), _tex(R, names) + deg
                )
    for k, comps in sol.forces.items():
        for d, e in comps.items():
            if e is not None:
                rhs = tex_with_unit(e, tex_or_size(e), k, True)
                add(f"{k} force", rf"F_{{{tex_label(d)}}}", rhs)
    for w, e in named.definitions:
        add("named subexpression", _tex(w, names), _tex(e, names))
    body = " \\\\\n".join(rows)
    if standalone_math:
        return "$$\\begin{aligned}\n" + body.replace("&&", "&\\quad") + "\n\\end{aligned}$$"
    title = sol.system.title
    return (
        f"% lamech: {tex_comment(title)}\n% requires \\usepackage{{amsmath}}\n"
        f"\\subsection*{{{tex_text(title)}}}\n\\begin{{align*}}\n{body}\n\\end{{align*}}\n"
    )
