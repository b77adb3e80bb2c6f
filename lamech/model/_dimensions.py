"""Dimensions inferred and checked (issue 46): where a problem gives any quantity a unit,
the dimension of every parameter, coordinate and velocity that has none is inferred from
where it appears, and every rule of dimensional homogeneity is checked.

The rules (each an equation between the dimensions of two expressions):

* every term of a sum, both sides of a comparison, the arguments of ``min``, ``max``,
  ``atan2`` and the values of a ``piecewise`` have one dimension;
* the arguments of sin, cos, tan, their inverses, sinh, cosh, tanh, exp and log are
  dimensionless (an angle in radians is), and so is a symbolic exponent;
* each term of V has the dimension of energy, and so has each term of T (said against
  V's: "T has dimension L^2/T^2, V has M*L^2/T^2 (energy): is a mass missing from T?");
* a body's position and a force's point are lengths, its mass a mass, its inertia a mass
  times a length squared, gravity an acceleration; a load's force a force, its torque an
  energy (N*m), a spring's k a force per length and its damping a force per speed;
* a generalized force on x has the dimension of energy over x's, a coefficient of
  friction and of restitution is dimensionless;
* a parameter given as an expression has that expression's dimension; t is a time, and a
  velocity x' the dimension of x over a time.

Numbers are dimensionless in products and fit any dimension in a sum (``x^2 + y^2 - 1``
with x in metres reads the 1 as 1 m^2, as Modelica reads a literal). The equations are
solved by propagation, the most trusted first (parameters' values; the constraints, the
bodies, the loads and gravity; V; T; the generalized forces): every equation with no
unknown dimension left is checked, then the first with one unknown left gives it, and
again until none does. A sum is compared with the term of it whose dimensions are best
given, and a sum (or V, T and the loads together) that fails gives no dimension, so one
mistake is said once. A conflict is reported with where it is, both dimensions and the
probable mistake; a dimension found with a fractional power (M^(1/2)*L, what T = x'^2/2
taken as an energy would give x) is a conflict too. The result, :class:`Units`, gives
each multiplier's unit: energy over the unit of its f (N for f in metres, N*m for f in
radians, N/m for f in m^2; a velocity constraint's f times a time).
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field
from fractions import Fraction
from typing import TYPE_CHECKING

import sympy as sp

from ..expr import Table
from ..expr._units import (
    DIMENSIONLESS,
    ENERGY,
    FORCE,
    LENGTH,
    MASS,
    TIME,
    Dimension,
)
from ._base import ModelError

if TYPE_CHECKING:
    from ._system import System

__all__ = ["Units", "infer_units", "result_units"]

ACCELERATION = LENGTH / TIME**2
_DIMENSIONLESS_ARGUMENT = (
    sp.sin, sp.cos, sp.tan, sp.cot, sp.asin, sp.acos, sp.atan, sp.sinh, sp.cosh,
    sp.tanh, sp.exp, sp.log,
)  # fmt: skip


@dataclass(frozen=True)
class Units:
    """A system's dimensions, where its file uses units: by name, those of its parameters,
    coordinates (``x``) and velocities (``x'``) and ``t`` that are known (given or
    inferred), each constraint's multiplier and Cartesian force (by constraint name).
    A name missing had its dimension undetermined (it appears nowhere that fixes it)."""

    symbols: tuple[tuple[str, Dimension], ...] = ()
    multipliers: tuple[tuple[str, Dimension], ...] = ()
    forces: tuple[tuple[str, Dimension], ...] = ()
    angles: tuple[str, ...] = ()
    """The parameters the file gives in a unit of angle (``"30 deg"``, ``"2 rad/s"``):
    rad where their dimension is 1, rad/s where it is 1/s."""

    def of(self, name: str) -> Dimension | None:
        return dict(self.symbols).get(name)

    def multiplier(self, constraint: str) -> Dimension | None:
        return dict(self.multipliers).get(constraint)

    def force(self, constraint: str) -> Dimension | None:
        return dict(self.forces).get(constraint)


# ----- dimensions linear in the unknown ones ----------------------------------------
@dataclass(frozen=True)
class _Lin:
    """const * prod(dim(s)^p for s, p in unknown): an expression's dimension."""

    const: Dimension = DIMENSIONLESS
    unknown: tuple[tuple[sp.Symbol, Fraction], ...] = ()

    @staticmethod
    def of(const: Dimension, unknown: Mapping[sp.Symbol, Fraction] | None = None) -> _Lin:
        kept = {s: p for s, p in (unknown or {}).items() if p != 0}
        return _Lin(const, tuple(sorted(kept.items(), key=lambda kv: kv[0].name)))

    def __mul__(self, other: _Lin) -> _Lin:
        u = dict(self.unknown)
        for s, p in other.unknown:
            u[s] = u.get(s, Fraction(0)) + p
        return _Lin.of(self.const * other.const, u)

    def __pow__(self, p: Fraction) -> _Lin:
        return _Lin.of(self.const**p, {s: q * p for s, q in self.unknown})

    def __truediv__(self, other: _Lin) -> _Lin:
        return self * other ** Fraction(-1)

    def known(self, dims: Mapping[sp.Symbol, Dimension]) -> _Lin:
        c, u = self.const, {}
        for s, p in self.unknown:
            if s in dims:
                c = c * dims[s] ** p
            else:
                u[s] = p
        return _Lin.of(c, u)

    def text(self, names: Mapping[sp.Symbol, str]) -> str:
        if not self.unknown:
            return self.const.described()
        parts = []
        for s, p in self.unknown:
            n = f"dim({names.get(s, s.name)})"
            parts.append(n if p == 1 else f"{n}^{p}" if p.denominator == 1 else f"{n}^({p})")
        text = "*".join(parts)
        const = "" if self.const.dimensionless else str(self.const)
        return text + const[1:] if const.startswith("1/") else "*".join(filter(None, [text, const]))


_NUMBER = None
"""A number: dimensionless in a product, any dimension in a sum."""
_UNKNOWN = "unknown"
"""An expression whose dimension cannot be told (a tabulated input's)."""


@dataclass
class _Equation:
    lhs: _Lin
    rhs: _Lin
    where: str
    say: Callable[[str, str, Dimension | None], str]  # (lhs text, rhs text, ratio) -> message
    rank: int
    group: int  # the equations of one sum: none gives a dimension once one has failed
    done: bool = False


@dataclass
class _Rules:
    """The equations found in a system's expressions, with where each comes from."""

    symbols: dict[sp.Symbol, _Lin]
    names: dict[sp.Symbol, str]
    given: dict[sp.Symbol, Dimension]
    equations: list[_Equation] = field(default_factory=list)

    def add(self, lhs, rhs, where: str, say, rank: int, group: int | None = None) -> None:
        if isinstance(lhs, _Lin) and isinstance(rhs, _Lin):
            group = len(self.equations) if group is None else group
            self.equations.append(_Equation(lhs, rhs, where, say, rank, -1 - group))

    def walk(self, e: sp.Basic, where: str, rank: int):
        """The dimension of ``e`` (a :class:`_Lin`, :data:`_NUMBER` or :data:`_UNKNOWN`),
        adding the equations its sums and functions need."""
        if isinstance(e, sp.Symbol):
            return self.symbols.get(e, _UNKNOWN)
        if e.is_number:
            return _NUMBER
        if isinstance(e, Table):
            return _UNKNOWN
        if isinstance(e, sp.Add) or isinstance(e, (sp.Min, sp.Max)):
            return self._same(
                list(e.args),
                where,
                rank,
                "terms of a sum" if e.is_Add else "arguments of min or max",
            )
        if isinstance(e, sp.Mul):
            out = _Lin()
            for a in e.args:
                d = self.walk(a, where, rank)
                if d is _UNKNOWN:
                    return _UNKNOWN
                if d is not _NUMBER:
                    out = out * d
            return out
        if isinstance(e, sp.Pow):
            base, exp = e.args
            if exp.is_Rational:
                d = self.walk(base, where, rank)
                if d is _NUMBER or d is _UNKNOWN:
                    return d
                return d ** Fraction(int(exp.p), int(exp.q))
            for part, what in ((base, "the base"), (exp, "the exponent")):
                what = f"{what} of a power with a symbolic exponent"
                self._dimensionless(part, where, rank, what)
            return _Lin()
        if isinstance(e, _DIMENSIONLESS_ARGUMENT):
            name = type(e).__name__
            self._dimensionless(e.args[0], where, rank, f"the argument of {name}")
            return _Lin()
        if isinstance(e, sp.atan2):
            self._same(list(e.args), where, rank, "arguments of atan2")
            return _Lin()
        if isinstance(e, sp.Abs):
            return self.walk(e.args[0], where, rank)
        if isinstance(e, (sp.sign, sp.Heaviside)):
            self.walk(e.args[0], where, rank)
            return _Lin()
        if isinstance(e, sp.Piecewise):
            for _, cond in e.args:
                self.walk(cond, where, rank)
            return self._same([v for v, _ in e.args], where, rank, "values of piecewise")
        if isinstance(e, sp.core.relational.Relational):
            self._same(list(e.args), where, rank, "sides of a comparison")
            return _NUMBER
        if isinstance(e, (sp.And, sp.Or, sp.Not)):
            for a in e.args:
                self.walk(a, where, rank)
            return _NUMBER
        return _UNKNOWN

    def _same(self, items: list, where: str, rank: int, what: str):
        dims = [(a, self.walk(a, where, rank)) for a in items]
        kept = [(a, d) for a, d in dims if isinstance(d, _Lin)]
        if not kept:
            return _UNKNOWN if any(d is _UNKNOWN for _, d in dims) else _NUMBER
        # the reference: a term with the fewest unknown dimensions, so that terms whose
        # dimensions are given are compared with each other before any is inferred
        ref = min(range(len(kept)), key=lambda i: len(kept[i][1].known(self.given).unknown))
        first, d0 = kept[ref]
        group = len(self.equations)
        for i, (a, d) in enumerate(kept):
            if i != ref:
                self.add(d, d0, where, _terms(what, a, first), rank, group)
        return d0

    def _dimensionless(self, e: sp.Basic, where: str, rank: int, what: str) -> None:
        d = self.walk(e, where, rank)
        self.add(d, _Lin(), where, _argument(what, e), rank)


# ----- messages ------------------------------------------------------------------------
def _short(e: sp.Basic) -> str:
    from ..expr import to_text

    text = to_text(e)
    return text if len(text) <= 60 else text[:57] + "..."


def _cause(ratio: Dimension | None, what: str) -> str:
    """What probably went wrong when ``what`` has ``ratio`` times the dimension it needs."""
    if ratio is None:
        return ""
    causes = {
        MASS**-1: f"is a mass missing from {what}?",
        MASS: f"is there a mass too many in {what}?",
        LENGTH**-1: f"is a length missing from {what} (a radius, a height)?",
        LENGTH: f"is there a length too many in {what}?",
        LENGTH**-2: f"is a length squared missing from {what} (a moment of inertia m*R^2)?",
        TIME: f"is a position in {what} where a velocity was meant (x for x')?",
        TIME**-1: f"is a velocity in {what} where a position was meant (x' for x)?",
    }
    return causes.get(ratio, f"they differ by a factor of dimension {ratio}")


def _terms(what: str, a: sp.Basic, b: sp.Basic):
    def say(da: str, db: str, ratio: Dimension | None) -> str:
        hint = _cause(ratio, f"`{_short(a)}`")
        angle = "dimensionless" in da or "dimensionless" in db
        if angle and ratio is not None and (ratio == LENGTH or ratio == LENGTH**-1):
            hint = (
                "a length and an angle (dimensionless) cannot be added: is a radius "
                "missing (R*theta)?"
            )
        return (
            f"`{_short(a)}` and `{_short(b)}` ({what}) differ in dimension: "
            f"`{_short(a)}` has {da}, `{_short(b)}` has {db}; {hint}"
        )

    return say


def _argument(what: str, e: sp.Basic):
    def say(da: str, db: str, ratio: Dimension | None) -> str:
        return (
            f"{what}, `{_short(e)}`, has dimension {da}; it must be dimensionless (an angle "
            "in radians is): divide it by a quantity of that dimension, or give the "
            'symbol the unit it is meant to have (an angle: unit = "rad")'
        )

    return say


def _needs(what: str, needed: str):
    def say(da: str, db: str, ratio: Dimension | None) -> str:
        return f"{what} has dimension {da}; {needed} needs {db}; {_cause(ratio, what)}".rstrip("; ")

    return say


def _friction(da: str, db: str, ratio: Dimension | None) -> str:
    return (
        f"mu has dimension {da}; a coefficient of friction is a ratio of two forces "
        "(|F_t| <= mu N), dimensionless: give it without a unit"
    )


def _energies(term: str | None):
    """T, or its term ``term``, against V's energy."""
    what = "T" if term is None else f"the term `{term}` of T"
    where = "T" if term is None else f"`{term}`"

    def say(da: str, db: str, ratio: Dimension | None) -> str:
        return f"{what} has dimension {da}, V has {db}: {_cause(ratio, where)}"

    return say


# ----- the rules of a system -----------------------------------------------------------
def _rules(
    system: System, given: Mapping[str, Dimension], where_T: str, where_V: str, loads: tuple
) -> _Rules:
    symbols: dict[sp.Symbol, _Lin] = {}
    names: dict[sp.Symbol, str] = {}
    for p in system.parameters:
        symbols[p.symbol] = _Lin.of(DIMENSIONLESS, {p.symbol: Fraction(1)})
        names[p.symbol] = p.name
    time = _Lin(TIME)
    for c in system.coordinates:
        x = _Lin.of(DIMENSIONLESS, {c.symbol: Fraction(1)})
        symbols[c.symbol] = x
        symbols[c.velocity] = x / time
        symbols[c.acceleration] = x / time ** Fraction(2)
        names[c.symbol] = c.name
    symbols[system.t] = time
    by_name = {n: s for s, n in names.items()}
    rules = _Rules(symbols, names, {by_name[n]: d for n, d in given.items() if n in by_name})
    for p in system.parameters:
        if p.value.free_symbols:
            d = rules.walk(p.value, f"parameters.{p.name}", 0)
            rules.add(
                symbols[p.symbol], d, f"parameters.{p.name}",
                _needs(f"parameter `{p.name}`", "its value"), 0,
            )  # fmt: skip
    for j, con in enumerate(system.constraints, 1):
        where = f"constraints[{j}] `{con.name}`"
        rules.walk(con.expr, f"{where} {'f' if con.holonomic else 'velocity'}", 1)
        if con.friction is not None:
            mu = rules.walk(con.friction.mu, f"{where} friction.mu", 1)
            rules.add(mu, _Lin(), f"{where} friction.mu", _friction, 1)
        restitution = rules.walk(con.restitution, f"{where} restitution", 1)
        say = _needs("the restitution", "a coefficient of restitution (a ratio of speeds)")
        rules.add(restitution, _Lin(), f"{where} restitution", say, 1)
        if con.force is not None:
            for x in con.force.at:
                d = rules.walk(x, f"{where} force.at", 1)
                rules.add(d, _Lin(LENGTH), f"{where} force.at", _needs("the point", "a point"), 1)
    for j, b in enumerate(system.bodies, 1):
        where = f"bodies[{j}] `{b.name}`"
        for x in b.position:
            d = rules.walk(x, f"{where} position", 1)
            rules.add(d, _Lin(LENGTH), f"{where} position", _needs("the position", "a position"), 1)
        d = rules.walk(b.mass, f"{where} mass", 1)
        rules.add(d, _Lin(MASS), f"{where} mass", _needs("the mass", "a mass"), 1)
        moments = b.inertia if isinstance(b.inertia, tuple) else (b.inertia,)
        moments = tuple(x for row in moments for x in (row if isinstance(row, tuple) else (row,)))
        for x in moments:
            if isinstance(x, sp.Expr):
                d = rules.walk(x, f"{where} inertia", 1)
                inertia = _Lin(MASS * LENGTH**2)
                rules.add(d, inertia, f"{where} inertia", _needs("the inertia", "an inertia"), 1)
    # the loads' equations, V's, T's and the generalized forces' are one group: V and the
    # forces hold what the loads make, so a load said wrong is not said again in them
    energy = len(rules.equations)
    _load_rules(rules, loads, energy)
    if system.gravity is not None:
        d = rules.walk(system.gravity, "gravity.acceleration", 1)
        rules.add(d, _Lin(ACCELERATION), "gravity.acceleration", _needs("g", "gravity"), 1)
    # each term of V an energy, and each term of T: a term is named where it is wrong;
    # in one group, so that T is not judged by a wrong V
    terms = sp.Add.make_args(system.V)
    for a in terms:
        d = rules.walk(a, where_V, 2)
        what = "V" if len(terms) == 1 else f"the term `{_short(a)}` of V"
        rules.add(d, _Lin(ENERGY), where_V, _needs(what, "an energy"), 2, energy)
    terms = sp.Add.make_args(system.T)
    for a in terms:
        d = rules.walk(a, where_T, 3)
        say = _energies(None if len(terms) == 1 else _short(a))
        rules.add(d, _Lin(ENERGY), where_T, say, 3, energy)
    for c, Q in zip(system.coordinates, system.forces):
        where = f"forces.{c.name}"
        d = rules.walk(Q, where, 5)
        need = _Lin(ENERGY) / symbols[c.symbol]
        rules.add(
            d, need, where,
            _needs(f"the generalized force on {c.name}", f"a force on {c.name} (energy/{c.name})"),
            5, energy,
        )  # fmt: skip
    return rules


def _load_rules(rules: _Rules, loads: tuple, group: int) -> None:
    """A load's force is a force, its point a length, a torque an energy (N*m), a spring's
    ends lengths, its stiffness a force per length and its damping a force per speed."""
    from ._loads import AppliedForce, Spring, Torque

    def need(exprs, dimension: Dimension, where: str, what: str, needed: str) -> None:
        for x in exprs:
            d = rules.walk(x, where, 1)
            rules.add(d, _Lin(dimension), where, _needs(what, needed), 1, group)

    for j, load in enumerate(loads, 1):
        where = f"loads[{j}] `{load.name}`"
        if isinstance(load, AppliedForce):
            need(load.force, FORCE, f"{where} force", "the force", "a force")
            need(load.at or (), LENGTH, f"{where} at", "the point", "a point")
        elif isinstance(load, Torque):
            tau = load.torque if isinstance(load.torque, tuple) else (load.torque,)
            need(tau, ENERGY, f"{where} torque", "the torque", "a torque (N*m)")
        elif isinstance(load, Spring):
            spring = f"{where} spring"
            need(load.start + load.end, LENGTH, spring, "the spring's end", "a point")
            need((load.length,), LENGTH, spring, "the spring's length", "a length")
            need((load.k,), FORCE / LENGTH, spring, "k", "a stiffness (N/m)")
            need((load.damping,), FORCE * TIME / LENGTH, spring, "the damping", "N*s/m")


def infer_units(
    system: System,
    given: Mapping[str, Dimension],
    where_T: str = "lagrangian.T",
    where_V: str = "lagrangian.V",
    loads: tuple = (),
) -> Units:
    """The dimensions of ``system``'s symbols from those ``given`` (by parameter or
    coordinate name), checked by the rules of the module docstring; ``loads`` (the
    :class:`~lamech.model.AppliedForce`, ``Torque`` and ``Spring`` that made part of its
    V and forces, as ``[[loads]]``) are checked where they are written.

    Raises
    ------
    ModelError
        Every conflict: (where, the two dimensions and the probable mistake).
    """
    rules = _rules(system, given, where_T, where_V, tuple(loads))
    dims: dict[sp.Symbol, Dimension] = dict(rules.given)
    issues: dict[str, str] = {}  # one conflict in each place: the others follow from it
    ranks: dict[str, int] = {}
    order = sorted(rules.equations, key=lambda q: q.rank)

    def fail(eq: _Equation) -> None:
        # in one place, the most specific conflict (a sum's terms before T against V)
        if eq.where not in issues or eq.rank < ranks[eq.where]:
            issues[eq.where], ranks[eq.where] = _message(eq, dims, rules.names), eq.rank
        for other in order:  # a sum whose terms disagree gives no dimension
            if other.group == eq.group:
                other.done = True

    while True:
        # the checks first (equations with no unknown left), then one inference
        for eq in order:
            if not eq.done and not (eq.lhs / eq.rhs).known(dims).unknown:
                eq.done = True
                if not (eq.lhs / eq.rhs).known(dims).const.dimensionless:
                    fail(eq)
        for eq in order:
            diff = (eq.lhs / eq.rhs).known(dims)
            if eq.done or len(diff.unknown) != 1:
                continue
            ((s, p),) = diff.unknown
            found = diff.const ** (-1 / p)
            if any(q.denominator != 1 for _, q in found.powers):
                eq.done = True
                fail(eq)
                continue
            dims[s] = found
            eq.done = True
            break
        else:
            break
    ModelError.check(list(issues.items()))
    return _units(system, dims, rules)


def _message(eq: _Equation, dims, names) -> str:
    """The equation's message, with ``ratio`` = lhs / rhs (what the left side has over
    what it needs) where both are known."""
    lhs, rhs = eq.lhs.known(dims), eq.rhs.known(dims)
    ratio = None
    if not lhs.unknown and not rhs.unknown:
        ratio = lhs.const / rhs.const
    else:  # an unknown coordinate carries no mass: judge by the mass alone
        m = lhs.const.power("M") - rhs.const.power("M")
        ratio = MASS**m if m else None
    return eq.say(lhs.text(names), rhs.text(names), ratio)


def _units(system: System, dims: dict[sp.Symbol, Dimension], rules: _Rules) -> Units:
    symbols = []
    for p in system.parameters:
        if p.symbol in dims:
            symbols.append((p.name, dims[p.symbol]))
    for c in system.coordinates:
        if c.symbol in dims:
            symbols.append((c.name, dims[c.symbol]))
            symbols.append((c.name + "'", dims[c.symbol] / TIME))
    symbols.append(("t", TIME))
    multipliers, forces = [], []
    for con in system.constraints:
        d = rules.walk(con.expr, "", 9)
        if not isinstance(d, _Lin) or d.known(dims).unknown:
            continue
        f = d.known(dims).const if con.holonomic else d.known(dims).const * TIME
        multipliers.append((con.name, ENERGY / f))
        points = [rules.walk(x, "", 9) for x in (con.force.at if con.force else ())]
        point = next((p.known(dims) for p in points if isinstance(p, _Lin)), None)
        if point is not None and not point.unknown:
            forces.append((con.name, ENERGY / point.const))
    return Units(tuple(symbols), tuple(multipliers), tuple(forces))


def _with_rad(text: str) -> str:
    """``1`` -> ``rad``, ``1/s`` -> ``rad/s``: an angle's unit, and its rate's."""
    return "rad" if text == "1" else "rad" + text[1:] if text.startswith("1/") else text


def result_units(system: System, forces: Iterable[str] | None = None) -> dict[str, str]:
    """The SI unit of every named quantity of ``system`` whose dimension is known, by the
    names the results use (issue 46): each parameter (``"m": "kg"``, ``"g": "m/s^2"``;
    ``"rad"`` for one given in degrees), ``"t": "s"``, each coordinate and velocity
    (``"r": "m"``, ``"r'": "m/s"``; an angle ``"rad"``, ``"rad/s"``), each multiplier
    ``"lambda:<constraint>"`` (N, N*m, N/m, ...), each Cartesian force component
    ``"force:<constraint>:<direction>"`` (N) and the ``"energy"`` (J). ``forces`` names
    the force components as ``"<constraint>:<direction>"`` (default: the directions of
    each constraint's ``force``, or x, y, z). Empty where the file gives no units."""
    units = system.units
    if units is None:
        return {}
    out: dict[str, str] = {}
    for p in system.parameters:
        d = units.of(p.name)
        if d is not None:
            out[p.name] = _with_rad(d.si()) if p.name in units.angles else d.si()
    out["t"] = "s"
    for c in system.coordinates:
        for name in (c.name, c.name + "'"):
            d = units.of(name)
            if d is not None:
                out[name] = _with_rad(d.si())
    chart = system.chart
    mapped = chart.map if chart is not None else ()
    args = [a for _, e in mapped for f in e.atoms(sp.sin, sp.cos) for a in f.args]
    for c in chart.coordinates if chart is not None else ():
        # a chart's angle (a circle solved in its angle: x = l*sin(theta)) is in rad
        if c.name not in out and any(c.symbol in a.free_symbols for a in args):
            out[c.name], out[c.name + "'"] = "rad", "rad/s"
    for name, d in units.multipliers:
        out[f"lambda:{name}"] = d.si()
    if forces is None:
        forces = []
        for con in system.constraints:
            if con.force is not None:
                dirs = [n for n, _ in con.force.along] or list("xyz"[: len(con.force.at)])
                forces += [f"{con.name}:{d}" for d in dirs]
    for key in forces:
        d = units.force(key.split(":")[0])
        if d is not None:
            out[f"force:{key}"] = d.si()
    out["energy"] = "J"
    return out
