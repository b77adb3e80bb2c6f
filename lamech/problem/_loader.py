"""Problem files (TOML) and plain dicts to a checked :class:`~lamech.model.System`.

Every problem found is collected and reported at once in a :class:`ProblemFileError`
naming the file, line, offending text and the fix, so a user mends a file in one pass.
Expressions go through :func:`lamech.expr.parse` only: nothing in a file is executed.
See the problem-file reference (docs/reference/problem-file.md) for the format.
"""

from __future__ import annotations

import dataclasses
import math
import re
import stat
import sys
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import sympy as sp

from ..expr import MAX_NUMBER_DIGITS, RESERVED, printable, tabulated, to_text
from ..model import (
    Body,
    Chart,
    Coordinate,
    ModelError,
    Parameter,
    System,
    assemble,
    coordinate,
    infer_units,
)
from ..model._assemble import skeleton
from ..model._base import FIELDS, name_problem
from ..model._kinematics import angular_velocity, time_derivative
from ..model._parts import parameter_numbers, signed_symbol
from ._examples import example_names, example_path
from ._files import LIMITS, MAX_BYTES, Issue, ProblemFileError, read_table, repeated_key
from ._quantities import coordinate_values, overridden, parameter_value, spelled_units
from ._sections import PartsReader

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

__all__ = ["ProblemFileError", "Issue", "load", "loads", "from_dict"]

_KNOWN_SECTIONS = {
    "title",
    "parameters",
    "coordinates",
    "lagrangian",
    "constraints",
    "drives",
    "bodies",
    "gravity",
    "forces",
    "description",
    "scenery",
    "parametrisation",
    "loads",
    "inputs",
    "sliders",
}


def load(
    path: str | Path,
    data_dir: str | Path | None = None,
    *,
    params: Mapping[str, Any] | None = None,
) -> System:
    """Load a problem file, or a bundled example by name (``"cylinder"``).

    A file the problem names (an ``[inputs]`` table) must lie, symlinks followed, in the
    problem file's folder or in ``data_dir``. ``params`` overrides parameter values by
    name, as ``--param`` does: each a number in SI or a quantity, text (``"30 cm"``) or a
    pint Quantity, converted to SI and checked against the parameter's dimension (the
    file's, given or inferred; issue 46).

    Raises
    ------
    ProblemFileError
        Everything wrong with the file, each with its line and the fix; a value of
        ``params`` that does not fit its parameter.
    """
    p = Path(path)
    if not p.exists() and not p.suffix and str(path) in example_names():
        p = example_path(str(path))
    if not p.exists():
        hint = ", ".join(example_names())
        raise ProblemFileError(
            str(path),
            [
                Issue(
                    "",
                    f"no such file; give a path to a .toml problem file or a bundled example "
                    f"({hint})",
                )
            ],
        )
    if p.is_dir():
        raise ProblemFileError(str(path), [Issue("", "is a directory, not a problem file")])
    try:
        if not stat.S_ISREG(p.stat().st_mode):
            # /dev/zero would be read forever, a FIFO would block: neither is a file
            raise ProblemFileError(
                str(path),
                [Issue("", "is not a regular file (a device, pipe or socket); give a .toml file")],
            )
        with p.open("rb") as fh:
            raw = fh.read(MAX_BYTES + 1)  # never more than the limit, whatever the file
        if len(raw) > MAX_BYTES:
            raise ProblemFileError(str(path), [Issue("", "file too large (over 1 MB)")])
        text = raw.decode("utf-8-sig")  # a byte-order mark is not part of the TOML
    except (OSError, UnicodeDecodeError) as exc:
        raise ProblemFileError(str(path), [Issue("", f"cannot read the file: {exc}")]) from None
    folders = [p.resolve().parent]
    if data_dir is not None:
        folders.append(Path(data_dir).resolve())
    system = _parse(text.replace("\r\n", "\n"), str(path), tuple(folders))
    return overridden(system, params, str(path)) if params else system


def loads(text: str, name: str = "<string>", *, params: Mapping[str, Any] | None = None) -> System:
    """Load a problem from TOML text; ``name`` is used in error messages. A problem
    given as text has no folder: it may name no files (an ``[inputs]`` table is refused;
    save it as a file and :func:`load` that). ``params``: as :func:`load`'s."""
    system = _parse(text, name, None)
    return overridden(system, params, name) if params else system


def _parse(text: str, name: str, folders: tuple[Path, ...] | None) -> System:
    if len(text) > MAX_BYTES:
        raise ProblemFileError(name, [Issue("", "file too large (over 1 MB)")])
    text = text.removeprefix("\ufeff")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        msg = str(exc)
        m = re.search(r"\(at line (\d+), column (\d+)\)", msg)
        line = int(m.group(1)) if m else None
        bare = re.sub(r"\s*\(at line \d+, column \d+\)", "", msg)
        hint = "check quoting (expressions go in double quotes) and that each line is `key = value`"
        if "overwrite" in bare or "twice" in bare:
            found = repeated_key(text)
            if found:
                line, key, first = found
                bare = f"`{key}` is defined twice (first on line {first})"
                hint = "each key may appear once in a table: remove or rename one of them"
        offending = text.splitlines()[line - 1] if line and line <= len(text.splitlines()) else None
        raise ProblemFileError(
            name, [Issue("", f"TOML syntax error: {bare}; {hint}", line, offending)]
        ) from None
    except ValueError:
        # tomllib's int() of an integer longer than Python converts (4300 digits)
        lines = text.splitlines()
        line = next((i for i, ln in enumerate(lines, 1) if _LONG_NUMBER.search(ln)), None)
        raise ProblemFileError(
            name,
            [
                Issue(
                    "",
                    f"a number with more than {_INT_DIGITS} digits; numbers "
                    f"in a problem file have at most {MAX_NUMBER_DIGITS} digits",
                    line,
                    lines[line - 1][:60] + "..." if line else None,
                )
            ],
        ) from None
    except RecursionError:
        raise ProblemFileError(
            name, [Issue("", "TOML nested too deeply (arrays or tables inside each other)")]
        ) from None
    return _Loader(data, name, text, folders).build()


_LONG_NUMBER = re.compile(r"[0-9_]{1000,}")
_INT_DIGITS = getattr(sys, "get_int_max_str_digits", lambda: 4300)()


def from_dict(data: dict[str, Any], name: str = "<dict>", text: str | None = None) -> System:
    """Build a checked :class:`System` from a dict in the problem-file layout.

    Values that are expressions may be strings in the grammar, numbers, or SymPy
    expressions whose symbols carry declared names.
    """
    return _Loader(data, name, text).build()


class _Loader(PartsReader):
    """Parses a problem (TOML shapes, expressions) into the model's parts and calls the
    model to assemble them (:func:`lamech.model.assemble`); the model checks them, and
    each issue it finds is reported here with the file's line."""

    def build(self) -> System:
        if not isinstance(self.data, dict):
            raise ProblemFileError(self.source, [Issue("", "a problem must be a table")])
        for key in self.data:
            if key not in _KNOWN_SECTIONS:
                self.problem(
                    key,
                    f"unknown section or key `{key}`; known: " + ", ".join(sorted(_KNOWN_SECTIONS)),
                    (None, None, key),
                )
        for section, limit in LIMITS.items():
            items = self.data.get(section)
            if isinstance(items, (dict, list)) and len(items) > limit:
                self.problem(
                    section,
                    f"{len(items)} {section}: a problem file may have at most {limit} "
                    "(the symbolic derivation grows faster than the system: n coordinates "
                    "make an n x n mass matrix); describe a smaller system",
                    (section, 0, None) if isinstance(items, list) else (section, None, None),
                )
        self.fail_if_any()
        title = self.data.get("title", Path(self.source).stem)
        if not isinstance(title, str):
            self.problem("title", "title must be a string", (None, None, "title"))
            title = str(title)
        elif printable(title) != title:
            bad = next(c for c in title if printable(c) != c)
            self.problem(
                "title",
                f"the title contains the control character {printable(bad)}; a title is "
                "one line of plain text",
                (None, None, "title"),
            )
        params = self._parameters()
        self.scopes["parameters"] = {p.name: p.symbol for p in params}
        coords = self._coordinates()
        declared = self.data.get("coordinates")
        if not coords or not isinstance(declared, dict) or len(coords) != len(declared):
            # A coordinate missing would make each use of it an 'unknown name'. With all
            # of them made (a bad value replaced), go on: the next error is reported too.
            self.fail_if_any()

        positions = {"t": self.t, **self.scopes["parameters"]}
        for c in coords:
            positions[c.name] = c.symbol
        velocities = dict(positions)
        for c in coords:
            velocities[c.name + "'"] = c.velocity
        self.scopes.update(positions=positions, velocities=velocities)
        for name, value in self._inputs(positions).items():
            positions[name] = velocities[name] = value
        # The coordinates and parameters alone (checked as such): the bodies' angular
        # velocities, named in T and the forces, are found on it.
        frame = self.make(skeleton, title, tuple(params), tuple(coords), self.t)
        if frame is None:
            self.fail_if_any()

        gravity = self._gravity()
        bodies = self._bodies()
        self._angular_velocities(frame, bodies)
        energies = self._lagrangian(bodies)
        constraints = self._constraints() + self._drives(coords)
        forces = self._forces(coords)
        loads = self._loads()
        scenery = self._scenery()
        sliders = self._sliders(params, constraints)
        self.fail_if_any()
        chart = self._chart(coords)
        self.fail_if_any()
        # the modelling (T and V from the bodies, L split, the loads' forces) is the model's
        system = self.make(
            assemble,
            title,
            tuple(params),
            tuple(coords),
            tuple(constraints),
            **energies,
            bodies=tuple(bodies),
            gravity=gravity,
            forces=tuple(forces),
            loads=tuple(loads),
            t=self.t,
            source=self.source,
            scenery=tuple(scenery),
            chart=chart,
            sliders=tuple(sliders),
        )
        self.fail_if_any()
        if self.dimensions:
            system = self._units(system, tuple(loads))
        return system

    def _units(self, system: System, loads: tuple) -> System:
        """The system with its dimensions inferred and checked (issue 46): where the file
        gives any quantity a unit; each conflict reported at its line."""
        table = self.data.get("lagrangian")
        table = table if isinstance(table, dict) else {}
        where_T = "lagrangian.T" if "T" in table else "lagrangian.L" if "L" in table else "bodies"
        where_V = "lagrangian.V" if "V" in table else "lagrangian.L" if "L" in table else "bodies"
        try:
            units = infer_units(system, self.dimensions, where_T, where_V, loads)
        except ModelError as exc:
            self.model_problems(exc)
            # "2 g" beside a parameter g, where a conflict names it: said there too
            spelled_units(self, system, None, [m for _, m in exc.issues])
            self.fail_if_any()
            raise
        units = dataclasses.replace(units, angles=tuple(sorted(self.angles)))
        notes = tuple(spelled_units(self, system, units))
        return dataclasses.replace(system, units=units, notes=system.notes + notes)

    def _chart(self, coords: list[Coordinate]) -> Chart | None:
        """``[parametrisation]``: ``coordinates = ["theta1", ...]`` (the new ones) and
        ``x1 = "l1*sin(theta1)"`` for each coordinate parametrised."""
        table = self.table("parametrisation")
        if table is None:
            return None
        loc = ("parametrisation", None, "coordinates")
        names = table.get("coordinates")
        if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
            self.problem(
                "parametrisation.coordinates",
                'list the new coordinates: `coordinates = ["theta1", "theta2"]`',
                loc if "coordinates" in table else ("parametrisation", None, None),
            )
            return None
        new = []
        taken = set(self.scopes["positions"])
        for n in names:
            problem = name_problem(n)
            if problem is None and n in taken:
                problem = (
                    f"`{n}` is already a parameter or a coordinate; new coordinates need new names"
                )
            if problem is not None:
                self.problem("parametrisation.coordinates", problem, loc)
                continue
            new.append(coordinate(n))
        by_name = {c.name: c for c in coords}
        scope = dict(self.scopes["positions"])
        scope.update({c.name: c.symbol for c in new})
        pairs = []
        for key, value in table.items():
            if key == "coordinates":
                continue
            where = f"parametrisation.{key}"
            kloc = ("parametrisation", None, key)
            if key not in by_name:
                self.problem(
                    where,
                    f"`{key}` is not a coordinate; the parametrisation gives coordinates "
                    "(known: " + ", ".join(by_name) + ") as expressions of the new ones",
                    kloc,
                )
                continue
            if not isinstance(value, (str, int, float)) or isinstance(value, bool):
                self.problem(where, 'an expression string, e.g. "l1*sin(theta1)"', kloc)
                continue
            e = self.expr(value, scope, where, kloc, "a parametrised coordinate")
            if e is not None:
                pairs.append((by_name[key].symbol, e))
        if not pairs:
            self.problem(
                "parametrisation",
                "give at least one coordinate as an expression of the new ones "
                '(x1 = "l1*sin(theta1)")',
                ("parametrisation", None, None),
            )
            return None
        return Chart(tuple(new), tuple(pairs))

    def _inputs(self, taken: dict) -> dict[str, sp.Expr]:
        """``[inputs]``: tabulated inputs, ``name = { csv = "file.csv", column = "tau" }``
        (``time = "t"``: the time column, by default the first), a function of t
        interpolated linearly between the rows (:func:`lamech.expr.tabulated`)."""
        table = self.table("inputs") or {}
        out: dict[str, sp.Expr] = {}
        for name, spec in table.items():
            where, loc = f"inputs.{name}", ("inputs", None, name)
            if (
                name in taken
                or name in RESERVED
                or not re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name)
            ):
                self.problem(
                    where,
                    f"`{name}` cannot name an input: it is taken or not a plain name",
                    loc,
                )
                continue
            if not isinstance(spec, dict) or "csv" not in spec:
                self.problem(
                    where,
                    'an input is a table: name = { csv = "file.csv", column = "name" }',
                    loc,
                )
                continue
            extra = sorted(set(spec) - {"csv", "column", "time"})
            if extra:
                self.problem(where, f"unknown key `{extra[0]}`; known: csv, column, time", loc)
                continue
            read = read_table(self.folders, spec)
            if isinstance(read, str):
                self.problem(where, read, loc)
                read = ([0.0, 1.0], [0.0, 0.0])  # a stand-in: its uses are no further error
            out[name] = tabulated(name, *read, self.t)
        return out

    def _parameters(self) -> list[Parameter]:
        table = self.table("parameters") or {}
        raw: dict[str, Any] = {}
        for name, value in table.items():
            problem = name_problem(name)
            if problem is not None:
                self.problem(f"parameters.{name}", problem, ("parameters", None, name))
            else:
                raw[name] = value
        symbols = {n: sp.Symbol(n, real=True) for n in raw}
        exprs: dict[str, sp.Expr] = {}
        for n, value in raw.items():
            if isinstance(value, bool) or not isinstance(value, (int, float, str, sp.Basic)):
                self.problem(
                    f"parameters.{n}",
                    f"value must be a number or an expression string, not {type(value).__name__}",
                    ("parameters", None, n),
                )
                continue
            read = parameter_value(self, n, value)
            if read is None:
                continue
            value = read
            e = self.expr(
                value,
                symbols,
                f"parameters.{n}",
                ("parameters", None, n),
                FIELDS["parameter value"][1],
            )
            if e is not None:
                exprs[n] = e
        # values in dependency order (the model's rule); a cycle is reported at its line
        numeric, cycle = parameter_numbers(exprs)
        if cycle:
            self.problem(
                "parameters",
                f"parameter values refer to each other in a cycle ({', '.join(cycle)}); "
                "give at least one of them a number",
                ("parameters", None, cycle[0]),
            )
        final = {symbols[n]: signed_symbol(n, numeric.get(n, float("nan"))) for n in raw}
        out = []
        for n in raw:
            p = None
            if n in numeric:
                p = self.make(Parameter, n, final[symbols[n]], exprs[n].xreplace(final), numeric[n])
            # On an error (recorded), keep the name known so that later expressions
            # using it do not report a misleading 'unknown name'.
            out.append(p or Parameter(n, symbols[n], symbols[n], 1.0))
        return out

    def _coordinates(self) -> list[Coordinate]:
        table = self.table("coordinates", required=True)
        if not table:
            if table is not None:
                self.problem(
                    "coordinates",
                    "[coordinates] is empty; declare at least one "
                    "coordinate as `x = { initial = 0, velocity = 0 }`",
                    ("coordinates", None, None),
                )
            return []
        out = []
        for name, spec in table.items():
            loc = ("coordinates", None, name)
            where = f"coordinates.{name}"
            if not isinstance(spec, dict):
                self.problem(
                    where,
                    f"a coordinate is an inline table: `{name} = {{ initial = 0, velocity = 0 }}`",
                    loc,
                )
                continue
            extra = set(spec) - {"initial", "velocity", "keep", "unit"}
            if extra:
                self.problem(
                    where,
                    f"unknown key `{sorted(extra)[0]}`; a coordinate takes "
                    "initial, velocity, keep and unit",
                    loc,
                )
            if "initial" not in spec:
                self.problem(
                    where,
                    "missing `initial` (the initial value, a number or an "
                    "expression of parameters)",
                    loc,
                )
                continue
            raw_q0, raw_v0 = coordinate_values(self, name, spec)
            q0 = self.field(raw_q0, "initial", where + ".initial", loc)
            v0 = self.field(raw_v0, "initial velocity", where + ".velocity", loc)
            keep = spec.get("keep", False)
            if not isinstance(keep, bool):
                self.problem(where + ".keep", "`keep` must be true or false", loc)
            # a bad value is reported; 0 and False stand in for it, so that the rest of
            # the file is still read and its errors are reported with this one
            q0 = sp.Integer(0) if q0 is None else q0
            v0 = sp.Integer(0) if v0 is None else v0
            made = self.make(coordinate, name, q0, v0, keep if isinstance(keep, bool) else False)
            if made is not None:
                out.append(made)
        return out

    def _gravity(self) -> sp.Expr | None:
        table = self.table("gravity")
        if table is None:
            return None
        if "acceleration" not in table:
            self.problem(
                "gravity",
                'missing `acceleration` (e.g. acceleration = "g")',
                ("gravity", None, None),
            )
            return None
        return self.field(
            table["acceleration"],
            "gravity",
            "gravity.acceleration",
            ("gravity", None, "acceleration"),
        )

    def _angular_velocities(self, skeleton: System, bodies: list[Body]) -> None:
        """``top.wx, top.wy, top.wz`` (world axes) and ``top.w1, top.w2, top.w3`` (the
        body's own axes) into the velocities' names, for each body in space that turns
        (T from the bodies asks for the same, remembered); and what `disc.wx` says for
        a planar body, a point or a body whose description failed."""
        for name in self._body_names():
            self.spin_hints[name] = "this body's description has errors (see above)"
        for body in bodies:
            if body.rotation is not None or body.orientation is not None:
                self.spin_hints.pop(body.name, None)
                spin = angular_velocity(skeleton, body)
                if spin is None:
                    continue
                for k, axis in enumerate("xyz"):
                    self.scopes["velocities"][f"{body.name}.w{axis}"] = spin[0][k]
                    self.scopes["velocities"][f"{body.name}.w{k + 1}"] = spin[1][k]
            elif body.angle is not None:
                rate = to_text(time_derivative(body.angle, skeleton))
                self.spin_hints[body.name] = (
                    f"{body.name} is a planar body: its angular velocity is the rate of its "
                    f"angle, {rate} (counterclockwise); write that"
                )
            else:
                self.spin_hints[body.name] = (
                    f"{body.name} does not turn: a point mass has no angular velocity "
                    "(give a body in space a `rotation` or `orientation`)"
                )

    def _sliders(self, params: list[Parameter], constraints: list) -> list:
        """``[sliders]``: ``NAME = [low, high]``, the range of the report's slider of a
        parameter given as a number, or of a friction coefficient given as a number
        (``mu``, or ``"mu:<constraint>"`` when there are several, as ``--param``)."""
        table = self.table("sliders") or {}
        friction = [c for c in constraints if c.friction is not None]
        names = {p.name for p in params if sp.sympify(p.value).is_Number}
        literal = [c for c in friction if sp.sympify(c.friction.mu).is_Number]
        if len(friction) == 1 and "mu" not in {p.name for p in params}:
            names |= {"mu"} if literal else set()
        else:
            names |= {f"mu:{c.name}" for c in literal}
        out = []
        for name, value in table.items():
            where, loc = f"sliders.{name}", ("sliders", None, name)
            if name not in names:
                self.problem(
                    where,
                    f"no slider `{name}`: a slider is a parameter given as a number or a "
                    "friction coefficient given as a number; known: "
                    + (", ".join(sorted(names)) or "none"),
                    loc,
                )
                continue
            ok = (
                isinstance(value, list)
                and len(value) == 2
                and all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                    for v in value
                )
            )
            if not ok:
                self.problem(where, "a slider's range is [low, high], two numbers", loc)
                continue
            low, high = float(value[0]), float(value[1])
            if not low < high:
                self.problem(
                    where, f"a slider's range needs low < high (got [{low:g}, {high:g}])", loc
                )
                continue
            out.append((name, low, high))
        return out

    def _lagrangian(self, bodies: list[Body]) -> dict[str, sp.Expr]:
        """``[lagrangian]``: {"T": ..., "V": ...} or {"L": ...}, what the file gives (the
        model makes the rest from the bodies, :func:`lamech.model.assemble`)."""
        table = self.table("lagrangian")
        loc = ("lagrangian", None, None)
        described = bool(bodies) or bool(self.data.get("bodies"))  # bodies with problems: said
        if table is None:
            if not described:
                self.problem(
                    "lagrangian",
                    "missing [lagrangian] (T and V, or L) and no [[bodies]] to compute them from",
                    (None, None, None),
                )
            return {}
        extra = set(table) - {"T", "V", "L"}
        if extra:
            self.problem("lagrangian", f"unknown key `{sorted(extra)[0]}`; give T and V, or L", loc)
        if "L" in table and ("T" in table or "V" in table):
            self.problem("lagrangian", "give either L, or T and V, not both", loc)
            return {}
        if "T" not in table and "L" not in table and not described:
            self.problem(
                "lagrangian",
                "missing T (the kinetic energy); give T and V, or L, or describe [[bodies]]",
                loc,
            )
        out = {}
        for key in ("T", "V", "L"):
            if key in table:
                out[key] = self.field(
                    table[key], key, f"lagrangian.{key}", ("lagrangian", None, key)
                )
        return out

    def _forces(self, coords) -> list[sp.Expr]:
        table = self.table("forces") or {}
        by_name = {c.name: i for i, c in enumerate(coords)}
        out = [sp.Integer(0)] * len(coords)
        for name, value in table.items():
            if name not in by_name:
                self.problem(
                    f"forces.{name}",
                    f"`{name}` is not a coordinate; known: " + ", ".join(by_name),
                    ("forces", None, name),
                )
                continue
            e = self.field(value, "forces", f"forces.{name}", ("forces", None, name))
            if e is not None:
                out[by_name[name]] = e
        return out
