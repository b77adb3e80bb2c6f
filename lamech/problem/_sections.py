"""Reading the sections that are lists of parts: ``[[bodies]]``, ``[[constraints]]``
(with friction and where their force acts), ``[[scenery]]`` and ``[[loads]]``, each
entry into the model's part that checks itself."""

from __future__ import annotations

from typing import Any

from ..model import (
    AppliedForce,
    Body,
    Constraint,
    ConstraintKind,
    Coordinate,
    Drive,
    ForceSpec,
    Friction,
    Scenery,
    ShapeKind,
    Spring,
    Torque,
)
from ._reader import Reader


class PartsReader(Reader):
    """The readers of the list sections (``[[bodies]]`` and the like)."""

    def _bodies(self) -> list[Body]:
        raw = self.data.get("bodies", [])
        if not isinstance(raw, list):
            self.problem(
                "bodies",
                "bodies are an array of tables: each starts with `[[bodies]]`",
                (None, None, "bodies"),
            )
            return []
        out = []
        for i, spec in enumerate(raw):
            loc0 = ("bodies", i, None)
            if not isinstance(spec, dict):
                self.problem(f"bodies[{i + 1}]", "must be a table", loc0)
                continue
            name = spec.get("name", f"body{i + 1}")
            where = f"bodies[{i + 1}] `{name}`"
            before = len(self.problems)
            keys = {"name", "mass", "position", "angle", "inertia", "shape"}
            keys |= {"rotation", "rotation_frame", "orientation"}
            extra = set(spec) - keys
            if extra:
                self.problem(
                    where,
                    f"unknown key `{sorted(extra)[0]}`; a body takes name, mass, position, "
                    "angle, inertia, shape, and in space rotation, rotation_frame or "
                    "orientation",
                    loc0,
                )
            if "mass" not in spec:
                self.problem(where, "missing `mass`", loc0)
                continue
            parts: dict[str, Any] = {}
            for key in ("mass", "angle"):
                if key in spec:
                    parts[key] = self.field(spec[key], key, f"{where} {key}", ("bodies", i, key))
            if "inertia" in spec:
                parts["inertia"] = self._inertia(spec["inertia"], where, ("bodies", i, "inertia"))
            if "rotation" in spec:
                parts["rotation"] = self._rotation(
                    spec["rotation"], where, ("bodies", i, "rotation")
                )
            if "rotation_frame" in spec:
                parts["rotation_frame"] = spec["rotation_frame"]
            if "orientation" in spec:
                parts["orientation"] = self._matrix(
                    spec["orientation"],
                    "angle",
                    f"{where} orientation",
                    ("bodies", i, "orientation"),
                )
            parts["position"] = self._vector(
                spec.get("position"), "position", f"{where} position", ("bodies", i, "position")
            )
            shape = spec.get("shape")
            if isinstance(shape, dict) and "axis" in shape:  # in space: the rod's or axle's
                parts["shape_axis"] = shape["axis"]
                shape = {k: v for k, v in shape.items() if k != "axis"}
            parts["shape"] = self._shape(shape, where, ("bodies", i, "shape"))
            if len(self.problems) == before:
                body = self.make(Body, name, part=where, **parts)
                if body is not None:
                    out.append(body)
        return out

    def _rotation(self, value, where: str, loc: tuple):
        """``["z:psi", "x:theta", "z:phi"]``: turns (axis, angle expression)."""
        if not isinstance(value, list) or not value:
            self.problem(
                f"{where} rotation",
                'give a list of turns "axis:angle", e.g. ["z:psi", "x:theta", "z:phi"]',
                loc,
            )
            return None
        turns = []
        for item in value:
            axis, sep, angle = str(item).partition(":") if isinstance(item, str) else ("", "", "")
            axis = axis.strip().lower()
            if not sep or axis not in ("x", "y", "z") or not angle.strip():
                self.problem(
                    f"{where} rotation",
                    f'each turn is "axis:angle" with axis x, y or z (e.g. "z:psi"); got {item!r}',
                    loc,
                )
                return None
            expr = self.field(angle.strip(), "angle", f"{where} rotation", loc)
            if expr is None:
                return None
            turns.append((axis, expr))
        return tuple(turns)

    def _inertia(self, value, where: str, loc: tuple):
        """One moment, the 3 principal moments, or 3 rows of 3 (the tensor)."""
        if isinstance(value, list) and value and all(isinstance(r, list) for r in value):
            return self._matrix(value, "inertia", f"{where} inertia", loc)
        if isinstance(value, list):
            if len(value) != 3:
                self.problem(
                    f"{where} inertia",
                    "give one moment, the 3 principal moments, or 3 rows of 3 (the tensor)",
                    loc,
                )
                return None
            parts = [self.field(x, "inertia", f"{where} inertia", loc) for x in value]
            return None if any(p is None for p in parts) else tuple(parts)
        return self.field(value, "inertia", f"{where} inertia", loc)

    def _shape(self, spec, where, loc) -> tuple | None:
        if spec is None:
            return (ShapeKind.POINT, None)
        if not isinstance(spec, dict) or len(spec) != 1:
            self.problem(
                where,
                'shape is one of { circle = "R" }, { rod = "l" }, { point = true } (in space '
                'with axis = "x", "y" or "z": the rod\'s body axis, the circle\'s axle)',
                loc,
            )
            return None
        ((kind, value),) = spec.items()
        if kind == ShapeKind.POINT or kind not in [k.value for k in ShapeKind]:
            return (kind, None)  # an unknown kind is the model's to report
        size = self.field(value, "shape", where + " shape", loc)
        return None if size is None else (kind, size)

    def _scenery(self) -> list[Scenery]:
        """``[[scenery]]``: drawn geometry, each entry a point, a line or a circle."""
        raw = self.data.get("scenery", [])
        forms = (
            "point = [x, y], line = [[x1, y1], [x2, y2], ...] "
            'or circle = { center = [x, y], radius = "R" }'
        )
        if not isinstance(raw, list):
            self.problem(
                "scenery",
                "scenery is an array of tables: each starts with `[[scenery]]`",
                (None, None, "scenery"),
            )
            return []
        out = []
        for i, spec in enumerate(raw):
            loc0 = ("scenery", i, None)
            if not isinstance(spec, dict):
                self.problem(f"scenery[{i + 1}]", "must be a table", loc0)
                continue
            name = spec.get("name", f"scenery{i + 1}")
            where = f"scenery[{i + 1}] `{name}`"
            extra = sorted(set(spec) - {"name", "point", "line", "circle"})
            kinds = [k for k in ("point", "line", "circle") if k in spec]
            if extra:
                self.problem(
                    where, f"unknown key `{extra[0]}`; a scenery entry takes name and {forms}", loc0
                )
                continue
            if len(kinds) != 1:
                self.problem(where, f"give exactly one of {forms}", loc0)
                continue
            kind = kinds[0]
            value, loc, at = spec[kind], ("scenery", i, kind), f"{where} {kind}"
            before, radius = len(self.problems), None
            if kind == "circle":
                if not isinstance(value, dict) or set(value) != {"center", "radius"}:
                    self.problem(at, 'a circle is { center = [x, y], radius = "R" }', loc)
                    continue
                radius = self.field(value["radius"], "scenery", at, loc)
                points = [value["center"]]
            elif kind == "line":
                if not isinstance(value, list) or not all(isinstance(p, list) for p in value):
                    self.problem(at, "a line is a list of points: [[x1, y1], [x2, y2], ...]", loc)
                    continue
                points = value
            else:
                points = [value]
            if not all(isinstance(p, list) for p in points):
                self.problem(at, "a point is a list of 2 or 3 expressions: [x, y]", loc)
                continue
            parsed = [tuple(self.field(x, "scenery", at, loc) for x in p) for p in points]
            if len(self.problems) == before:
                item = self.make(Scenery, str(name), kind, tuple(parsed), radius, part=where)
                if item is not None:
                    out.append(item)
        return out

    def _constraints(self) -> list[Constraint]:
        raw = self.data.get("constraints", [])
        if not isinstance(raw, list):
            self.problem(
                "constraints",
                "constraints are an array of tables: each starts with `[[constraints]]`",
                (None, None, "constraints"),
            )
            return []
        out = []
        for i, spec in enumerate(raw):
            loc0 = ("constraints", i, None)
            if not isinstance(spec, dict):
                self.problem(f"constraints[{i + 1}]", "must be a table", loc0)
                continue
            name = spec.get("name", f"c{i + 1}")
            where = f"constraints[{i + 1}] `{name}`"
            before = len(self.problems)
            extra = set(spec) - {
                "name",
                "f",
                "velocity",
                "unilateral",
                "friction",
                "force",
                "restitution",
            }
            if extra:
                self.problem(
                    where,
                    f"unknown key `{sorted(extra)[0]}`; a constraint takes "
                    "name, f or velocity, unilateral, friction, force, restitution",
                    loc0,
                )
            if ("f" in spec) == ("velocity" in spec):
                self.problem(
                    where,
                    "give exactly one of `f` (holonomic, f(q, t) = 0) or "
                    "`velocity` (linear in the velocities, a(q,t).q' + b = 0)",
                    loc0,
                )
                continue
            key = "f" if "f" in spec else "velocity"
            kind = ConstraintKind.HOLONOMIC if key == "f" else ConstraintKind.VELOCITY
            e = self.field(spec[key], key, f"{where} {key}", ("constraints", i, key))
            friction = self._friction(spec.get("friction"), where, ("constraints", i, "friction"))
            force = self._force_spec(spec.get("force"), where, ("constraints", i, "force"))
            restitution = self.field(
                spec.get("restitution", 0),
                "restitution",
                f"{where} restitution",
                ("constraints", i, "restitution"),
            )
            if len(self.problems) == before:
                constraint = self.make(
                    Constraint,
                    name,
                    e,
                    kind,
                    spec.get("unilateral", False),
                    friction,
                    force,
                    restitution,
                    part=where,
                )
                if constraint is not None:
                    out.append(constraint)
        return out

    def _drives(self, coords: list[Coordinate]) -> list[Constraint]:
        """``[[drives]]``: each a prescribed motion, made a holonomic constraint whose
        multiplier is the drive's force or torque (:class:`lamech.model.Drive`):
        ``coordinate`` with ``motion`` (f = q - motion(t)) or ``speed`` (a constant rate
        from the coordinate's initial value: f = q - q0 - speed t), or a general ``f``."""
        raw = self.data.get("drives", [])
        if not isinstance(raw, list):
            self.problem(
                "drives",
                "drives are an array of tables: each starts with `[[drives]]`",
                (None, None, "drives"),
            )
            return []
        by_name = {c.name: c for c in coords}
        out = []
        for i, spec in enumerate(raw):
            loc0 = ("drives", i, None)
            if not isinstance(spec, dict):
                self.problem(f"drives[{i + 1}]", "must be a table", loc0)
                continue
            name = spec.get("name", f"drive{i + 1}")
            where = f"drives[{i + 1}] `{name}`"
            extra = set(spec) - {"name", "coordinate", "motion", "speed", "f"}
            if extra:
                self.problem(
                    where,
                    f"unknown key `{sorted(extra)[0]}`; a drive takes name, and coordinate "
                    "with motion or speed, or a general f (with a coordinate or not)",
                    loc0,
                )
                continue
            given = [k for k in ("motion", "speed", "f") if k in spec]
            if len(given) != 1:
                self.problem(
                    where,
                    "give exactly one of `motion` (the coordinate as a function of t), "
                    "`speed` (a constant rate) or `f` (a general f(q, t) = 0)",
                    loc0,
                )
                continue
            key = given[0]
            coordinate = spec.get("coordinate")
            if coordinate is None and key != "f":
                self.problem(
                    where, f"`{key}` needs the `coordinate` it prescribes", ("drives", i, key)
                )
                continue
            if coordinate is not None and coordinate not in by_name:
                self.problem(
                    where,
                    f"unknown coordinate `{coordinate}`; known: " + ", ".join(by_name),
                    ("drives", i, "coordinate"),
                )
                continue
            e = self.field(spec[key], "f", f"{where} {key}", ("drives", i, key))
            if e is None:
                continue
            if coordinate is not None and key != "f":
                c = by_name[coordinate]
                if key == "speed":
                    if e.free_symbols & {self.t, *(k.symbol for k in coords)}:
                        self.problem(
                            where,
                            "`speed` is a constant rate (parameters only); write a motion "
                            "that varies as `motion` (the coordinate as a function of t)",
                            ("drives", i, key),
                        )
                        continue
                    e = c.initial + e * self.t
                e = c.symbol - e
            drive = Drive(coordinate)
            made = self.make(Constraint, name, e, ConstraintKind.HOLONOMIC, drive=drive, part=where)
            if made is not None:
                out.append(made)
        return out

    def _friction(self, spec, where, loc) -> Friction | None:
        if spec is None:
            return None
        if not isinstance(spec, dict) or set(spec) != {"mu", "normal"}:
            self.problem(
                where,
                'friction is { mu = <coefficient>, normal = "<name of the normal constraint>" }',
                loc,
            )
            return None
        mu = self.field(spec["mu"], "mu", where + " friction.mu", loc)
        return None if mu is None else self.make(Friction, mu, spec["normal"], part=where)

    def _force_spec(self, spec, where, loc) -> ForceSpec | None:
        if spec is None:
            return None
        if (
            not isinstance(spec, dict)
            or not {"body", "at"} <= set(spec)
            or set(spec) - {"body", "at", "along"}
        ):
            self.problem(
                where,
                'force is { body = "<body>" (or ["a", "b"]), at = [x, y], '
                "along = { name = [dx, dy] } }",
                loc,
            )
            return None
        before = len(self.problems)
        names = spec["body"] if isinstance(spec["body"], list) else [spec["body"]]
        at = self._vector(spec["at"], "at", where + " force.at", loc)
        along = []
        raw_along = spec.get("along", {})
        if not isinstance(raw_along, dict):
            self.problem(
                where,
                "force.along is a table of named directions, e.g. "
                '{ normal = ["sin(x)", "cos(x)"] }',
                loc,
            )
            return None
        for dname, vec in raw_along.items():
            v = self._vector(vec, "along", where + f" force.along.{dname}", loc)
            along.append((dname, v))
        if len(self.problems) > before:
            return None
        return self.make(ForceSpec, tuple(names), at, tuple(along), part=where)

    def _loads(self) -> list:
        """``[[loads]]``: forces at material points, torques on bodies, springs and
        dampers between points (:class:`lamech.model.AppliedForce`, ``Torque``,
        ``Spring``; the model finds their generalized forces and energy)."""
        raw = self.data.get("loads", [])
        if not isinstance(raw, list):
            self.problem(
                "loads",
                "loads are an array of tables: each starts with `[[loads]]`",
                (None, None, "loads"),
            )
            return []
        kinds = ("force", "torque", "spring")
        out = []
        for i, spec in enumerate(raw):
            loc0 = ("loads", i, None)
            if not isinstance(spec, dict):
                self.problem(f"loads[{i + 1}]", "must be a table", loc0)
                continue
            name = str(spec.get("name", f"load{i + 1}"))
            where = f"loads[{i + 1}] `{name}`"
            given = [k for k in kinds if k in spec]
            extra = sorted(set(spec) - {"name", "body", "at", "frame", *kinds})
            if extra or len(given) != 1:
                self.problem(
                    where,
                    (f"unknown key `{extra[0]}`; " if extra else "")
                    + "a load is one of: force = [Fx, Fy(, Fz)] with body and at (a point of "
                    "the body; default its centre), torque with body, or spring = { from = "
                    '[...], to = [...], k = "k", length = "L0", damping = "c" }',
                    loc0,
                )
                continue
            frame = spec.get("frame", "world")
            if frame not in ("world", "body"):
                self.problem(where, 'frame is "world" (default) or "body"', ("loads", i, "frame"))
                continue
            kind, loc = given[0], ("loads", i, given[0])
            if kind == "spring":
                load = self._spring(spec["spring"], name, where, loc)
            elif kind == "force":
                F = self._vector(spec["force"], "forces", f"{where} force", loc)
                at = (
                    self._vector(spec["at"], "at", f"{where} at", ("loads", i, "at"))
                    if "at" in spec
                    else None
                )
                if F is None or ("at" in spec and at is None):
                    continue
                load = self.make(AppliedForce, spec.get("body", ""), F, at, frame, name, part=where)
            else:
                value = spec["torque"]
                tau = (
                    self._vector(value, "forces", f"{where} torque", loc)
                    if isinstance(value, list)
                    else self.field(value, "forces", f"{where} torque", loc)
                )
                if tau is None:
                    continue
                load = self.make(Torque, spec.get("body", ""), tau, frame, name, part=where)
            if load is not None:
                out.append(load)
        return out

    def _spring(self, spec, name: str, where: str, loc: tuple) -> Spring | None:
        """``spring = { from = [...], to = [...], k = "k", length = "L0", damping = "c" }``."""
        if not isinstance(spec, dict) or not {"from", "to", "k"} <= set(spec):
            self.problem(
                where,
                'spring = { from = [...], to = [...], k = "k", length = "L0", '
                'damping = "c" } (length and damping optional)',
                loc,
            )
            return None
        a = self._vector(spec["from"], "at", f"{where} spring.from", loc)
        b = self._vector(spec["to"], "at", f"{where} spring.to", loc)
        k = self.field(spec["k"], "spring", f"{where} spring.k", loc)
        L0 = self.field(spec.get("length", 0), "spring", f"{where} spring.length", loc)
        c = self.field(spec.get("damping", 0), "spring", f"{where} spring.damping", loc)
        if a is None or b is None or k is None or L0 is None or c is None:
            return None
        return self.make(Spring, a, b, k, L0, c, name, part=where)
