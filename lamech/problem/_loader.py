"""Issue files (TOML) and plain dicts to a checked :class:`~lamech.model.System`.

Every problem found is collected and reported at once in a :class:`ProblemFileError`
naming the file, line, offending text and the fix, so a user mends a file in one pass.
Expressions go through :func:`lamech.expr.parse` only: nothing in a file is executed.
See the README's "Issue files" section for the format.
"""

from __future__ import annotations

import math
import random
import re
import sys
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import sympy as sp

from ._examples import example_names, example_path
from ..expr import FUNCTIONS, RESERVED, ExpressionError, parse, to_text
from ..model import (INITIAL_TOLERANCE, Body, Constraint, Coordinate, ForceSpec, Friction,
                     Parameter, System, body_energy, dependent_constraints, initial_values,
                     time_derivative)
from ..model import value as number_at

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["ProblemFileError", "Issue", "load", "loads", "from_dict"]

_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")
_KNOWN_SECTIONS = {"title", "parameters", "coordinates", "lagrangian", "constraints", "bodies",
                   "gravity", "forces", "description"}


@dataclass(frozen=True)
class Issue:
    """One thing wrong in a problem file: where (``where`` like ``constraints[2].f``,
    ``line``), what (``message``, with the fix) and the offending ``text``."""

    where: str
    message: str
    line: int | None = None
    text: str | None = None

    def format(self, source: str) -> str:
        head = f"{source}:{self.line}:" if self.line else f"{source}:"
        out = f"{head} {self.where}: {self.message}" if self.where else f"{head} {self.message}"
        if self.text:
            out += f"\n    {self.text}"
        return out


_KEY_LINE = re.compile(r"""^\s*("[^"]*"|'[^']*'|[A-Za-z0-9_.\-]+)\s*=""")
_TABLE_LINE = re.compile(r"^\s*\[\[?\s*([^\]]+?)\s*\]\]?")


def _repeated_key(text: str) -> tuple[int, str, int] | None:
    """(line, key, first line) of a key repeated within one table, for the message only.

    tomllib says "Cannot overwrite a value", sometimes "at end of document": this scan
    finds which key and where. The file is still parsed by tomllib alone.
    """
    seen: dict[str, int] = {}
    tables: dict[str, int] = {}
    for number, line in enumerate(text.splitlines(), 1):
        if m := _TABLE_LINE.match(line):
            name = m.group(1)
            if not line.lstrip().startswith("[[") and name in tables:
                return number, f"[{name}]", tables[name]
            tables[name] = number
            seen = {}
        elif m := _KEY_LINE.match(line):
            key = m.group(1).strip("\"'")
            if key in seen:
                return number, key, seen[key]
            seen[key] = number
    return None


class ProblemFileError(ValueError):
    """A problem file (or dict) cannot be used; ``problems`` lists everything wrong."""

    def __init__(self, source: str, problems: list[Issue]):
        self.source = source
        self.problems = list(problems)
        super().__init__("\n".join(p.format(source) for p in problems))


class _Lines:
    """Find the line of a key in TOML text (tomllib keeps no positions)."""

    _HEADER = re.compile(r"^\s*(\[\[?)\s*([A-Za-z0-9_.\"' -]+?)\s*\]\]?\s*(#.*)?$")

    def __init__(self, text: str | None):
        self.lines = text.splitlines() if text else []

    def find(self, table: str | None, index: int | None, key: str | None) -> int | None:
        """Line (1-based) of ``key`` in ``[table]`` (the ``index``-th ``[[table]]``)."""
        if not self.lines:
            return None
        current, count, header_line = None, -1, None
        key_re = re.compile(r"^\s*[\"']?" + re.escape(key) + r"[\"']?\s*=") if key else None
        for i, line in enumerate(self.lines, start=1):
            m = self._HEADER.match(line)
            if m:
                name = m.group(2).strip()
                if m.group(1) == "[[":
                    count = count + 1 if name == table else count
                    current = (name, count)
                else:
                    current = (name, None)
                if current == (table, index) and key is None:
                    return i
                if current == (table, index):
                    header_line = i
                continue
            in_table = (current == (table, index)) if table else current is None
            if in_table and key_re and key_re.match(line):
                return i
        return header_line


def load(path: str | Path) -> System:
    """Load a problem file, or a bundled example by name (``"cylinder"``).

    Raises
    ------
    ProblemFileError
        Everything wrong with the file, each with its line and the fix.
    """
    p = Path(path)
    if not p.exists() and not p.suffix and str(path) in example_names():
        p = example_path(str(path))
    if not p.exists():
        hint = ", ".join(example_names())
        raise ProblemFileError(str(path), [Issue(
            "", f"no such file; give a path to a .toml problem file or a bundled example "
                f"({hint})")])
    if p.is_dir():
        raise ProblemFileError(str(path), [Issue("", "is a directory, not a problem file")])
    try:
        text = p.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ProblemFileError(str(path), [Issue("", f"cannot read the file: {exc}")]) from None
    return loads(text, name=str(path))


def loads(text: str, name: str = "<string>") -> System:
    """Load a problem from TOML text; ``name`` is used in error messages."""
    if len(text) > 1_000_000:
        raise ProblemFileError(name, [Issue("", "file too large (over 1 MB)")])
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc)
        m = re.search(r"\(at line (\d+), column (\d+)\)", msg)
        line = int(m.group(1)) if m else None
        bare = re.sub(r"\s*\(at line \d+, column \d+\)", "", msg)
        hint = "check quoting (expressions go in double quotes) and that each line is " \
            "`key = value`"
        if "overwrite" in bare or "twice" in bare:
            found = _repeated_key(text)
            if found:
                line, key, first = found
                bare = f"`{key}` is defined twice (first on line {first})"
                hint = "each key may appear once in a table: remove or rename one of them"
        offending = text.splitlines()[line - 1] if line and line <= len(text.splitlines()) \
            else None
        raise ProblemFileError(name, [Issue(
            "", f"TOML syntax error: {bare}; {hint}", line, offending)]) from None
    return from_dict(data, name=name, text=text)


def from_dict(data: dict[str, Any], name: str = "<dict>", text: str | None = None) -> System:
    """Build a checked :class:`System` from a dict in the problem-file layout.

    Values that are expressions may be strings in the grammar, numbers, or SymPy
    expressions whose symbols carry declared names.
    """
    return _Loader(data, name, text).build()


class _Loader:
    def __init__(self, data: Any, name: str, text: str | None):
        self.data = data
        self.source = name
        self.lines = _Lines(text)
        self.problems: list[Issue] = []
        self.t = sp.Symbol("t", real=True)

    # ----- reporting -----------------------------------------------------------------
    def problem(self, where: str, message: str, loc: tuple = (None, None, None),
                text: str | None = None) -> None:
        line = self.lines.find(*loc)
        if text is None and line and self.lines.lines:
            text = self.lines.lines[line - 1].strip()
        self.problems.append(Issue(where, message, line, text))

    def expr(self, value: Any, names: dict[str, sp.Expr], where: str, loc: tuple,
             what: str) -> sp.Expr | None:
        if isinstance(value, sp.Basic):
            return self._sympy_value(value, names, where, loc)
        try:
            return parse(value, names, what)
        except ExpressionError as exc:
            shown = str(value) if len(str(value)) <= 120 else str(value)[:117] + "..."
            col = f" (column {exc.column})" if exc.column else ""
            self.problem(where, exc.message + col, loc, None if self.lines.lines else shown)
            return None

    def _sympy_value(self, value: sp.Basic, names: dict[str, sp.Expr], where: str,
                     loc: tuple) -> sp.Expr | None:
        by_name = {str(s): s for s in value.free_symbols}
        unknown = sorted(n for n in by_name if n not in names)
        if unknown:
            self.problem(where, f"unknown name `{unknown[0]}`; known: "
                         + ", ".join(sorted(n for n in names if "'" not in n)), loc)
            return None
        return value.xreplace({s: names[n] for n, s in by_name.items()})

    def table(self, key: str, required: bool = False) -> dict | None:
        value = self.data.get(key)
        if value is None:
            if required:
                self.problem(key, f"missing section [{key}]; see the README's problem-file "
                             "format")
            return None
        if not isinstance(value, dict):
            self.problem(key, f"[{key}] must be a table (`[{key}]` followed by `name = ...` "
                         f"lines), not {type(value).__name__}", (None, None, key))
            return None
        return value

    # ----- build -------------------------------------------------------------------
    def build(self) -> System:
        if not isinstance(self.data, dict):
            raise ProblemFileError(self.source, [Issue("", "a problem must be a table")])
        for key in self.data:
            if key not in _KNOWN_SECTIONS:
                self.problem(key, f"unknown section or key `{key}`; known: "
                             + ", ".join(sorted(_KNOWN_SECTIONS)), (None, None, key))
        title = self.data.get("title", Path(self.source).stem)
        if not isinstance(title, str):
            self.problem("title", "title must be a string", (None, None, "title"))
            title = str(title)
        params = self._parameters()
        self.params = params
        names: dict[str, sp.Expr] = {"t": self.t, **{p.name: p.symbol for p in params}}
        coords = self._coordinates(params, names)
        self.fail_if_any()

        pos_names = dict(names)
        for c in coords:
            pos_names[c.name] = c.symbol
        vel_names = dict(pos_names)
        for c in coords:
            vel_names[c.name + "'"] = c.velocity
        skeleton = System(title=title, parameters=tuple(params), coordinates=tuple(coords),
                          T=sp.Integer(0), V=sp.Integer(0), constraints=(), t=self.t)

        gravity = self._gravity(names)
        bodies = self._bodies(pos_names, names)
        T, V = self._lagrangian(pos_names, vel_names, skeleton, bodies, gravity)
        constraints = self._constraints(pos_names, vel_names, bodies)
        forces = self._forces(coords, vel_names)
        self.fail_if_any()
        notes = self._compare_energy(skeleton, bodies, gravity, T, V)
        system = System(title=title, parameters=tuple(params), coordinates=tuple(coords),
                        T=T, V=V, constraints=tuple(constraints), bodies=tuple(bodies),
                        gravity=gravity, forces=tuple(forces), t=self.t, source=self.source,
                        notes=tuple(notes))
        self._check_initial(system)
        self._check_dependent(system)
        self.fail_if_any()
        return system

    def fail_if_any(self) -> None:
        if self.problems:
            raise ProblemFileError(self.source, self.problems)

    def check_name(self, name: Any, where: str, loc: tuple) -> bool:
        if not isinstance(name, str) or not _IDENT.match(name):
            self.problem(where, f"`{name}` is not a valid name (letters, digits and _, not "
                         "starting with a digit)", loc)
            return False
        if name in RESERVED:
            kind = "a function" if name in FUNCTIONS else "reserved"
            self.problem(where, f"`{name}` is {kind} and cannot be a parameter or coordinate "
                         "name; rename it", loc)
            return False
        if name.startswith("lambda_") or "__" in name:
            self.problem(where, f"`{name}`: names starting with `lambda_` or containing `__` "
                         "are reserved (lambda_<constraint> names the multipliers); rename it",
                         loc)
            return False
        return True

    def _parameters(self) -> list[Parameter]:
        table = self.table("parameters") or {}
        raw: dict[str, Any] = {}
        for name, value in table.items():
            loc = ("parameters", None, name)
            if self.check_name(name, f"parameters.{name}", loc):
                raw[name] = value
        symbols = {n: sp.Symbol(n, real=True) for n in raw}
        names = {"t": self.t, **symbols}
        exprs: dict[str, sp.Expr] = {}
        for n, value in raw.items():
            if isinstance(value, bool) or not isinstance(value, (int, float, str, sp.Basic)):
                self.problem(f"parameters.{n}", f"value must be a number or an expression "
                             f"string, not {type(value).__name__}", ("parameters", None, n))
                continue
            e = self.expr(value, {k: v for k, v in names.items() if k != "t"},
                          f"parameters.{n}", ("parameters", None, n), "parameter values")
            if e is not None:
                exprs[n] = e
        numeric: dict[str, float] = {}
        # Resolve values in dependency order; a cycle is reported, not looped on.
        pending = dict(exprs)
        while pending:
            progress = False
            for n, e in list(pending.items()):
                deps = {str(s) for s in e.free_symbols}
                if deps <= set(numeric):
                    try:
                        val = float(e.subs({symbols[d]: numeric[d] for d in deps}).evalf(30))
                    except (TypeError, ValueError):
                        val = float("nan")
                    if not math.isfinite(val):
                        self.problem(f"parameters.{n}", "value is not a finite real number",
                                     ("parameters", None, n))
                        val = 1.0
                    numeric[n] = val
                    del pending[n]
                    progress = True
            if not progress:
                cyc = ", ".join(sorted(pending))
                self.problem("parameters", f"parameter values refer to each other in a cycle "
                             f"({cyc}); give at least one of them a number",
                             ("parameters", None, sorted(pending)[0]))
                break
        out = []
        for n in raw:
            if n not in numeric:
                # Its error is recorded; keep the name known so that later expressions
                # using it do not report a misleading 'unknown name'.
                out.append(Parameter(n, symbols[n], symbols[n], 1.0))
                continue
            v = numeric[n]
            sym = sp.Symbol(n, positive=True) if v > 0 else (
                sp.Symbol(n, negative=True) if v < 0 else sp.Symbol(n, real=True))
            out.append(Parameter(n, sym, exprs[n], v))
        # Re-express values in the final (assumption-carrying) symbols.
        final = {symbols[p.name]: p.symbol for p in out}
        return [Parameter(p.name, p.symbol, p.value.xreplace(final), p.numeric) for p in out]

    def _coordinates(self, params: list[Parameter], names: dict[str, sp.Expr]
                     ) -> list[Coordinate]:
        table = self.table("coordinates", required=True)
        if not table:
            if table is not None:
                self.problem("coordinates", "[coordinates] is empty; declare at least one "
                             "coordinate as `x = { initial = 0, velocity = 0 }`",
                             ("coordinates", None, None))
            return []
        pnames = {p.name for p in params}
        init_names = {k: v for k, v in names.items() if k != "t"}
        out = []
        for name, spec in table.items():
            loc = ("coordinates", None, name)
            where = f"coordinates.{name}"
            if not self.check_name(name, where, loc):
                continue
            if name in pnames:
                self.problem(where, f"`{name}` is declared both as a parameter and as a "
                             "coordinate; rename one", loc)
                continue
            if not isinstance(spec, dict):
                self.problem(where, "a coordinate is an inline table: "
                             f"`{name} = {{ initial = 0, velocity = 0 }}`", loc)
                continue
            extra = set(spec) - {"initial", "velocity", "keep"}
            if extra:
                self.problem(where, f"unknown key `{sorted(extra)[0]}`; a coordinate takes "
                             "initial, velocity and keep", loc)
            if "initial" not in spec:
                self.problem(where, "missing `initial` (the initial value, a number or an "
                             "expression of parameters)", loc)
                continue
            q0 = self.expr(spec["initial"], init_names, where + ".initial", loc,
                           "initial values (parameters only)")
            v0 = self.expr(spec.get("velocity", 0), init_names, where + ".velocity", loc,
                           "initial velocities (parameters only)")
            keep = spec.get("keep", False)
            if not isinstance(keep, bool):
                self.problem(where, "`keep` must be true or false", loc)
                keep = False
            if q0 is None or v0 is None:
                continue
            out.append(Coordinate(name, sp.Symbol(name, real=True),
                                  sp.Symbol(name + "'", real=True),
                                  sp.Symbol(name + "''", real=True), q0, v0, keep))
        return out

    def _gravity(self, names: dict[str, sp.Expr]) -> sp.Expr | None:
        table = self.table("gravity")
        if table is None:
            return None
        if "acceleration" not in table:
            self.problem("gravity", "missing `acceleration` (e.g. acceleration = \"g\")",
                         ("gravity", None, None))
            return None
        return self.expr(table["acceleration"], {k: v for k, v in names.items() if k != "t"},
                         "gravity.acceleration", ("gravity", None, "acceleration"),
                         "gravity (parameters only)")

    def _positive(self, e: sp.Expr, where: str, loc: tuple, what: str, allow_zero=False
                  ) -> None:
        try:
            value = float(e.subs({p.symbol: p.numeric for p in self.params}))
        except (TypeError, ValueError):
            self.problem(where, f"{what} must be a number or an expression of parameters", loc)
            return
        if not math.isfinite(value) or value < 0 or (value == 0 and not allow_zero):
            self.problem(where, f"{what} must be positive, got {value:g}", loc)

    def _bodies(self, pos_names: dict[str, sp.Expr], names: dict[str, sp.Expr]) -> list[Body]:
        raw = self.data.get("bodies", [])
        self.broken_bodies: set[str] = set()
        if not isinstance(raw, list):
            self.problem("bodies", "bodies are an array of tables: each starts with "
                         "`[[bodies]]`", (None, None, "bodies"))
            return []
        out = []
        pnames = {k: v for k, v in names.items() if k != "t"}
        seen = set()
        for i, spec in enumerate(raw):
            loc0 = ("bodies", i, None)
            if not isinstance(spec, dict):
                self.problem(f"bodies[{i + 1}]", "must be a table", loc0)
                continue
            name = spec.get("name", f"body{i + 1}")
            where = f"bodies[{i + 1}] `{name}`"
            if not isinstance(name, str) or not _IDENT.match(name) or name in seen:
                self.problem(where, "each body needs a unique `name` (an identifier)",
                             ("bodies", i, "name"))
                continue
            seen.add(name)
            extra = set(spec) - {"name", "mass", "position", "angle", "inertia", "shape"}
            if extra:
                self.problem(where, f"unknown key `{sorted(extra)[0]}`; a body takes name, "
                             "mass, position, angle, inertia, shape", loc0)
            if "mass" not in spec:
                self.problem(where, "missing `mass`", loc0)
                self.broken_bodies.add(name)
                continue
            mass = self.expr(spec["mass"], pnames, where + " mass", ("bodies", i, "mass"),
                             "masses (parameters only)")
            if mass is not None:
                self._positive(mass, where + " mass", ("bodies", i, "mass"), "mass")
            position = self._vector(spec.get("position"), pos_names, where + " position",
                                    ("bodies", i, "position"), "positions")
            angle = inertia = None
            if "angle" in spec:
                angle = self.expr(spec["angle"], pos_names, where + " angle",
                                  ("bodies", i, "angle"), "angles")
                if "inertia" not in spec:
                    self.problem(where, "a body with an `angle` needs its `inertia` about the "
                                 "centre of mass (e.g. inertia = \"m*R^2/2\")", loc0)
            if "inertia" in spec:
                inertia = self.expr(spec["inertia"], pnames, where + " inertia",
                                    ("bodies", i, "inertia"), "inertia (parameters only)")
                if inertia is not None:
                    self._positive(inertia, where + " inertia", ("bodies", i, "inertia"),
                                   "inertia")
            shape = self._shape(spec.get("shape"), pnames, where, ("bodies", i, "shape"))
            if position is not None and len(position) == 3 and angle is not None:
                self.problem(where, "rigid bodies (with an angle) must be planar: give a "
                             "2-component position", ("bodies", i, "angle"))
            if mass is None or position is None:
                self.broken_bodies.add(name)   # reported above; forces naming it stay quiet
                continue
            out.append(Body(name, mass, position, angle, inertia, shape))
        dims = {len(b.position) for b in out}
        if len(dims) > 1:
            self.problem("bodies", "all bodies must have positions of the same size (2 for "
                         "a plane, 3 for space)", ("bodies", 0, "position"))
        return out

    def _shape(self, spec, names, where, loc):
        if spec is None:
            return ("point", None)
        if not isinstance(spec, dict) or len(spec) != 1:
            self.problem(where, "shape is one of { circle = \"R\" }, { rod = \"l\" }, "
                         "{ point = true }", loc)
            return ("point", None)
        (kind, value), = spec.items()
        if kind == "point":
            return ("point", None)
        if kind not in ("circle", "rod"):
            self.problem(where, f"unknown shape `{kind}`; use circle, rod or point", loc)
            return ("point", None)
        size = self.expr(value, names, where + " shape", loc, "shapes (parameters only)")
        return (kind, size)

    def _vector(self, value, names, where, loc, what, dims=(2, 3)) -> tuple | None:
        if value is None:
            self.problem(where, f"missing (a list of {' or '.join(map(str, dims))} "
                         "expressions)", loc)
            return None
        if not isinstance(value, (list, tuple)) or len(value) not in dims:
            n = len(value) if isinstance(value, (list, tuple)) else 1
            self.problem(where, f"must be a list of {' or '.join(map(str, dims))} expressions "
                         f"(x, y[, z]); got {n}", loc)
            return None
        parts = [self.expr(v, names, where, loc, what) for v in value]
        if any(p is None for p in parts):
            return None
        return tuple(parts)

    def _lagrangian(self, pos_names, vel_names, skeleton, bodies, gravity):
        table = self.table("lagrangian")
        loc = ("lagrangian", None, None)
        if table is not None:
            extra = set(table) - {"T", "V", "L"}
            if extra:
                self.problem("lagrangian", f"unknown key `{sorted(extra)[0]}`; give T and V, "
                             "or L", loc)
            if "L" in table and ("T" in table or "V" in table):
                self.problem("lagrangian", "give either L, or T and V, not both", loc)
                return sp.Integer(0), sp.Integer(0)
            if "L" in table:
                L = self.expr(table["L"], vel_names, "lagrangian.L",
                              ("lagrangian", None, "L"), "L")
                if L is None:
                    return sp.Integer(0), sp.Integer(0)
                # Split L into T (terms with velocities) and V (the rest, negated).
                qd = skeleton.qd
                poly = sp.expand(L)
                T = sum((a for a in sp.Add.make_args(poly) if a.has(*qd)), sp.Integer(0))
                return T, sp.expand(T - L)
            if "T" not in table:
                if not bodies:
                    self.problem("lagrangian", "missing T (the kinetic energy); give T and V, "
                                 "or L, or describe [[bodies]]", loc)
                    return sp.Integer(0), sp.Integer(0)
                T = body_energy(skeleton, tuple(bodies), gravity)[0]
            else:
                T = self.expr(table["T"], vel_names, "lagrangian.T",
                              ("lagrangian", None, "T"), "T")
            V = sp.Integer(0)
            if "V" in table:
                V = self.expr(table["V"], pos_names, "lagrangian.V",
                              ("lagrangian", None, "V"), "V (positions only)")
            elif gravity is not None and bodies:
                V = body_energy(skeleton, tuple(bodies), gravity)[1]
            if T is None or V is None:
                return sp.Integer(0), sp.Integer(0)
            if T == 0 or not T.has(*skeleton.qd):
                self.problem("lagrangian.T", "T has no velocity in it; write velocities as x'",
                             ("lagrangian", None, "T"))
            return T, V
        if not bodies:
            self.problem("lagrangian", "missing [lagrangian] (T and V, or L) and no "
                         "[[bodies]] to compute them from", (None, None, None))
            return sp.Integer(0), sp.Integer(0)
        return body_energy(skeleton, tuple(bodies), gravity)

    def _constraints(self, pos_names, vel_names, bodies) -> list[Constraint]:
        raw = self.data.get("constraints", [])
        if not isinstance(raw, list):
            self.problem("constraints", "constraints are an array of tables: each starts "
                         "with `[[constraints]]`", (None, None, "constraints"))
            return []
        names = [s.get("name") if isinstance(s, dict) else None for s in raw]
        body_names = {b.name: b for b in bodies}
        dim = max((len(b.position) for b in bodies), default=2)
        qd = [v for k, v in vel_names.items() if k.endswith("'")]
        out = []
        for i, spec in enumerate(raw):
            loc0 = ("constraints", i, None)
            if not isinstance(spec, dict):
                self.problem(f"constraints[{i + 1}]", "must be a table", loc0)
                continue
            name = spec.get("name", f"c{i + 1}")
            where = f"constraints[{i + 1}] `{name}`"
            if not isinstance(name, str) or not _IDENT.match(name) or names.count(name) > 1:
                self.problem(where, "each constraint needs a unique `name` (an identifier)",
                             ("constraints", i, "name"))
                continue
            extra = set(spec) - {"name", "f", "velocity", "unilateral", "friction", "force",
                                 "restitution"}
            if extra:
                self.problem(where, f"unknown key `{sorted(extra)[0]}`; a constraint takes "
                             "name, f or velocity, unilateral, friction, force, restitution",
                             loc0)
            if ("f" in spec) == ("velocity" in spec):
                self.problem(where, "give exactly one of `f` (holonomic, f(q, t) = 0) or "
                             "`velocity` (linear in the velocities, a(q,t).q' + b = 0)", loc0)
                continue
            if "f" in spec:
                kind = "holonomic"
                e = self.expr(spec["f"], pos_names, where + " f", ("constraints", i, "f"),
                              "a holonomic constraint f (positions only; use `velocity = "
                              "\"...\"` for a velocity constraint)")
            else:
                kind = "velocity"
                e = self.expr(spec["velocity"], vel_names, where + " velocity",
                              ("constraints", i, "velocity"), "velocity constraints")
                if e is not None:
                    if not e.has(*qd):
                        self.problem(where, "a velocity constraint must contain a velocity "
                                     "(x'); for a constraint on positions use `f`",
                                     ("constraints", i, "velocity"))
                    elif any(sp.diff(e, a, b) != 0 for a in qd for b in qd if e.has(a)):
                        self.problem(where, "a non-holonomic constraint must be linear in the "
                                     "velocities (a(q,t).q' + b = 0)",
                                     ("constraints", i, "velocity"))
            if e is None:
                continue
            if e == 0:
                self.problem(where, "the constraint is identically zero", loc0)
                continue
            unilateral = spec.get("unilateral", False)
            if not isinstance(unilateral, bool):
                self.problem(where, "`unilateral` must be true or false",
                             ("constraints", i, "unilateral"))
                unilateral = False
            if unilateral and kind != "holonomic":
                self.problem(where, "only holonomic constraints (f) can be unilateral",
                             ("constraints", i, "unilateral"))
            friction = self._friction(spec.get("friction"), names, name, where, pos_names,
                                      ("constraints", i, "friction"))
            force = self._force_spec(spec.get("force"), body_names, dim, pos_names, where,
                                     ("constraints", i, "force"))
            rest = spec.get("restitution", 0)
            restitution = self.expr(rest, {k: v for k, v in pos_names.items()
                                           if k in {p for p in pos_names}},
                                    where + " restitution", ("constraints", i, "restitution"),
                                    "restitution")
            out.append(Constraint(name, e, kind, unilateral, friction, force,
                                  restitution if restitution is not None else sp.Integer(0),
                                  sp.Symbol("lambda_" + name, real=True)))
        return out

    def _friction(self, spec, names, own, where, pos_names, loc) -> Friction | None:
        if spec is None:
            return None
        if not isinstance(spec, dict) or set(spec) != {"mu", "normal"}:
            self.problem(where, "friction is { mu = <coefficient>, normal = \"<name of the "
                         "normal constraint>\" }", loc)
            return None
        normal = spec["normal"]
        if normal not in [n for n in names if n != own]:
            known = ", ".join(str(n) for n in names if n and n != own) or "(none)"
            self.problem(where, f"friction.normal `{normal}` is not another constraint; "
                         f"known: {known}", loc)
            return None
        mu = self.expr(spec["mu"], {k: v for k, v in pos_names.items()},
                       where + " friction.mu", loc, "mu")
        if mu is None:
            return None
        if mu.free_symbols <= {p.symbol for p in self.params}:
            try:
                value = number_at(mu, {p.symbol: p.numeric for p in self.params})
            except (TypeError, ValueError):
                value = float("nan")
            if not (math.isfinite(value) and value >= 0):
                self.problem(where, f"friction.mu must be a coefficient of friction >= 0, got "
                             f"{value:g}", loc)
                return None
        return Friction(mu, normal)

    def _force_spec(self, spec, bodies, dim, pos_names, where, loc) -> ForceSpec | None:
        if spec is None:
            return None
        if not isinstance(spec, dict) or not {"body", "at"} <= set(spec) or \
                set(spec) - {"body", "at", "along"}:
            self.problem(where, "force is { body = \"<body>\" (or [\"a\", \"b\"]), at = [x, y], "
                         "along = { name = [dx, dy] } }", loc)
            return None
        names = spec["body"] if isinstance(spec["body"], list) else [spec["body"]]
        if any(isinstance(n, str) and n in self.broken_bodies for n in names):
            return None   # the body's own error says what is wrong
        if len(names) not in (1, 2) or any(n not in bodies for n in names):
            known = ", ".join(bodies) or "(none: declare [[bodies]])"
            self.problem(where, f"force.body {spec['body']!r}: unknown body; known: {known}",
                         loc)
            return None
        body_dim = len(bodies[names[0]].position)
        at = self._vector(spec["at"], pos_names, where + " force.at", loc, "positions",
                          (body_dim,))
        along = []
        raw_along = spec.get("along", {})
        if not isinstance(raw_along, dict):
            self.problem(where, "force.along is a table of named directions, e.g. "
                         "{ normal = [\"sin(x)\", \"cos(x)\"] }", loc)
            return None
        for dname, vec in raw_along.items():
            if dname == "residual":
                self.problem(where, "a direction may not be called `residual` (that name "
                             "reports what the point cannot carry); rename it", loc)
                continue
            v = self._vector(vec, pos_names, where + f" force.along.{dname}", loc, "directions",
                             (body_dim,))
            if v is not None and all(c.is_zero for c in v):
                self.problem(where, f"force.along.{dname} is the zero vector; give the "
                             "direction to project the force on, e.g. [\"sin(x)\", "
                             "\"cos(x)\"]", loc)
            elif v is not None:
                along.append((dname, v))
        if at is None:
            return None
        return ForceSpec(tuple(names), at, tuple(along))

    def _forces(self, coords, vel_names) -> list[sp.Expr]:
        table = self.table("forces") or {}
        by_name = {c.name: i for i, c in enumerate(coords)}
        out = [sp.Integer(0)] * len(coords)
        for name, value in table.items():
            if name not in by_name:
                self.problem(f"forces.{name}", f"`{name}` is not a coordinate; known: "
                             + ", ".join(by_name), ("forces", None, name))
                continue
            e = self.expr(value, vel_names, f"forces.{name}", ("forces", None, name),
                          "generalized forces")
            if e is not None:
                out[by_name[name]] = e
        return out

    # ----- whole-system checks ---------------------------------------------------------
    def _compare_energy(self, skeleton, bodies, gravity, T, V) -> list[str]:
        table = self.data.get("lagrangian")
        if not bodies or not isinstance(table, dict):
            return []
        Tb, Vb = body_energy(skeleton, tuple(bodies), gravity)
        notes = []
        checks = [("T", T, Tb)]
        if gravity is not None:
            checks.append(("V", V, Vb))
        for label, given, kin in checks:
            if "L" in table or (label not in table):
                continue
            if _numerically_equal(given, kin, skeleton):
                continue
            diff = sp.simplify(given - kin) if sp.count_ops(given - kin) < 200 else given - kin
            if label == "T":
                notes.append(f"[lagrangian] T differs from the kinetic energy of [[bodies]] by "
                             f"{to_text(diff)}; check for a missing term (T is used as given)")
            else:
                notes.append(f"[lagrangian] V differs from the gravitational energy of "
                             f"[[bodies]] by {to_text(diff)} (fine if that is a spring or "
                             "other potential; V is used as given)")
        return notes

    def _check_initial(self, system: System) -> None:
        values = {**system.parameter_values}
        state = initial_values(system)
        scale = 1 + max((abs(v) for v in state.values()), default=0.0)
        env = {**values, **state, system.t: 0.0}
        for i, c in enumerate(system.constraints):
            loc = ("constraints", i, "f" if c.holonomic else "velocity")
            where = f"constraints[{i + 1}] `{c.name}`"
            try:
                if c.holonomic:
                    res = number_at(c.expr, env)
                    vres = number_at(time_derivative(c.expr, system), env)
                else:
                    res, vres = 0.0, number_at(c.expr, env)
            except (TypeError, ValueError):
                self.problem(where, "cannot evaluate the constraint at the initial state "
                             "(complex or undefined value)", loc)
                continue
            tol = INITIAL_TOLERANCE * scale
            if c.unilateral and c.holonomic and (res > tol or (abs(res) <= tol and vres > tol)):
                continue   # an open (or opening) contact: allowed, see open_at_start
            if c.unilateral and c.holonomic and res < -tol:
                self.problem(where, f"the initial state is on the forbidden side of the "
                             f"unilateral constraint: f = {res:.6g} < 0 (f >= 0 is allowed); "
                             "change the coordinates' initial values", loc)
            elif abs(res) > tol:
                self.problem(where, f"the initial state violates the constraint: f = {res:.6g} "
                             "(should be 0); change the coordinates' initial values", loc)
            elif abs(vres) > INITIAL_TOLERANCE * scale:
                label = "df/dt" if c.holonomic else "the constraint"
                self.problem(where, f"the initial velocities violate the constraint: {label} = "
                             f"{vres:.6g} (should be 0); change the coordinates' initial "
                             "velocities", loc)

    def _check_dependent(self, system: System) -> None:
        for group, where_singular in dependent_constraints(system):
            idx = system.constraints.index(system.constraint(group[0]))
            names = " and ".join(f"`{n}`" for n in group) if len(group) <= 2 else \
                ", ".join(f"`{n}`" for n in group)
            if where_singular:
                self.problem("constraints", f"constraints {names} are dependent at the initial "
                             "state (a singular configuration): forces cannot be uniquely "
                             "determined there; start elsewhere", ("constraints", idx, "name"))
            else:
                self.problem("constraints", f"constraints {names} are dependent: forces cannot "
                             "be uniquely determined; remove the redundant one",
                             ("constraints", idx, "name"))


def _numerically_equal(a: sp.Expr, b: sp.Expr, system: System, tries: int = 3) -> bool:
    """Compare two expressions at a few seeded random states (parameters at their values)."""
    rng = random.Random(1234)
    symbols = sorted(a.free_symbols | b.free_symbols, key=str)
    pv = system.parameter_values
    for _ in range(tries):
        env = {s: pv.get(s, rng.uniform(0.3, 1.3)) for s in symbols}
        try:
            da, db = complex(a.subs(env).evalf()), complex(b.subs(env).evalf())
        except (TypeError, ValueError):
            return False
        if abs(da - db) > 1e-9 * (1 + abs(da) + abs(db)):
            return False
    return True
