"""The model checks itself: a System built in Python gets the same checks and messages
as one loaded from a problem file (which adds the file and line), every issue at once,
and again on ``dataclasses.replace``."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import sympy as sp

import lamech
from lamech.expr import TimeDerivative
from lamech.model import (
    Body,
    Constraint,
    ConstraintKind,
    Coordinate,
    ForceSpec,
    Friction,
    ModelError,
    Parameter,
    ShapeKind,
    System,
    coordinate,
    parameters,
    with_values,
)

PENDULUM = """\
title = "Simple pendulum on a cord"
[parameters]
m = 1.0
g = 9.81
l = 1.0
[coordinates]
r = { initial = "l", velocity = 0 }
theta = { initial = 0.5, velocity = 0 }
[lagrangian]
T = "m/2*(r'^2 + r^2*theta'^2)"
V = "-m*g*r*cos(theta)"
[[constraints]]
name = "cord"
f = "r - l"
unilateral = true
FORCE
[[bodies]]
name = "bob"
mass = "m"
position = ["r*sin(theta)", "-r*cos(theta)"]
shape = { point = true }
[gravity]
acceleration = "g"
""".replace(
    "FORCE",
    'force = { body = "bob", at = ["r*sin(theta)", "-r*cos(theta)"], '
    'along = { tension = ["-sin(theta)", "cos(theta)"] } }',
)

m, g, ell = (sp.Symbol(n, positive=True) for n in ("m", "g", "l"))
r, th = sp.Symbol("r", real=True), sp.Symbol("theta", real=True)
# velocities and accelerations as the loader makes them (they print as dots in LaTeX)
rd, thd = TimeDerivative("r'", real=True), TimeDerivative("theta'", real=True)
rdd, thdd = TimeDerivative("r''", real=True), TimeDerivative("theta''", real=True)
t = sp.Symbol("t", real=True)
POSITION = (r * sp.sin(th), -r * sp.cos(th))


def cord(**change) -> Constraint:
    force = ForceSpec(("bob",), POSITION, (("tension", (-sp.sin(th), sp.cos(th))),))
    return Constraint(
        **{"name": "cord", "expr": r - ell, "unilateral": True, "force": force, **change}
    )


def pendulum(**change) -> System:
    """The PENDULUM file, built in Python (``change`` replaces System fields)."""
    fields = dict(
        title="Simple pendulum on a cord",
        parameters=(
            Parameter("m", m, sp.Integer(1), 1.0),
            Parameter("g", g, sp.Rational(981, 100), 9.81),
            Parameter("l", ell, sp.Integer(1), 1.0),
        ),
        coordinates=(
            Coordinate("r", r, rd, rdd, ell, sp.Integer(0)),
            Coordinate("theta", th, thd, thdd, sp.Rational(1, 2), sp.Integer(0)),
        ),
        T=m / 2 * (rd**2 + r**2 * thd**2),
        V=-m * g * r * sp.cos(th),
        constraints=(cord(),),
        bodies=(Body("bob", m, POSITION, shape=("point", None)),),
        gravity=g,
        t=t,
    )
    fields.update(change)
    return System(**fields)


def model_error(make, *args, **kwargs) -> ModelError:
    with pytest.raises(ModelError) as info:
        make(*args, **kwargs)
    return info.value


def same_as_file(error: ModelError, text: str) -> None:
    """Each issue the model reports is the loader's for ``text``: same place, same message
    (the loader adds the file, the line, and for a parse error the column)."""
    with pytest.raises(lamech.ProblemFileError) as info:
        lamech.loads(text, "p.toml")
    problems = info.value.problems
    assert len(problems) == len(error.issues), (error, info.value)
    for (where, message), problem in zip(error.issues, problems):
        assert problem.where == where, (error, info.value)
        assert problem.message.startswith(message), (error, info.value)
        assert problem.line is not None
        assert f"p.toml:{problem.line}: {where}: {message}" in str(info.value)


@pytest.mark.slow
def test_the_python_system_is_the_loaded_one_and_solves_alike():
    built, loaded = pendulum(), lamech.loads(PENDULUM)
    assert built.T == loaded.T and built.V == loaded.V
    assert [c.expr for c in built.constraints] == [c.expr for c in loaded.constraints]
    lam_built = lamech.solve(built).multipliers["cord"]
    lam_loaded = lamech.solve(loaded).multipliers["cord"]
    assert sp.simplify(lam_built - lam_loaded) == 0
    assert sp.simplify(lam_built - (-g * m * sp.cos(th) - ell * m * thd**2)) == 0


def test_unknown_symbol_in_a_constraint():
    R3 = sp.Symbol("R3", positive=True)
    error = model_error(pendulum, constraints=(cord(expr=r - R3),))
    assert error.issues == [
        ("constraints[1] `cord` f", "unknown name `R3`; known: g, l, m, r, t, theta")
    ]
    same_as_file(error, PENDULUM.replace('f = "r - l"', 'f = "r - R3"'))


def test_negative_mass():
    error = model_error(pendulum, bodies=(Body("bob", -m, POSITION),))
    assert error.issues == [
        ("bodies[1] `bob` mass", "must be >= 0 (0 for a massless body), got -1")
    ]
    same_as_file(error, PENDULUM.replace('mass = "m"', 'mass = "-m"'))


def test_velocity_in_V():
    error = model_error(pendulum, V=-m * g * r * sp.cos(th) + rd)
    assert error.issues == [
        ("lagrangian.V", "`r'`: velocities are not allowed in V (positions only)")
    ]
    same_as_file(
        error, PENDULUM.replace('V = "-m*g*r*cos(theta)"', 'V = "-m*g*r*cos(theta) + r\'"')
    )


def test_duplicate_constraint_name():
    error = model_error(
        pendulum,
        constraints=(cord(), cord(expr=th - sp.Rational(1, 2), unilateral=False, force=None)),
    )
    assert error.issues == [
        (
            "constraints[2] `cord` name",
            "the name `cord` is already used "
            "by constraints[1]; each constraint needs a unique name",
        )
    ]
    same_as_file(
        error,
        PENDULUM.replace(
            "[[bodies]]", '[[constraints]]\nname = "cord"\nf = "theta - 0.5"\n[[bodies]]'
        ),
    )


@pytest.mark.parametrize(
    "unilateral, initial, expected",
    [
        (False, sp.Integer(2), "the initial state violates the constraint: f = 1 (should be 0)"),
        (
            True,
            sp.Rational(1, 2),
            "the initial state is on the forbidden side of the unilateral constraint: f = -0.5 < 0",
        ),
    ],
)
def test_initial_state_off_a_constraint(unilateral, initial, expected):
    coords = (
        Coordinate("r", r, rd, rdd, initial, sp.Integer(0)),
        Coordinate("theta", th, thd, thdd, sp.Rational(1, 2), sp.Integer(0)),
    )
    error = model_error(pendulum, coordinates=coords, constraints=(cord(unilateral=unilateral),))
    ((where, message),) = error.issues
    assert where == "constraints[1] `cord`" and message.startswith(expected)
    text = PENDULUM.replace('r = { initial = "l"', f'r = {{ initial = "{initial}"')
    if not unilateral:
        text = text.replace("unilateral = true\n", "")
    same_as_file(error, text)


def test_every_issue_is_reported_at_once():
    R3 = sp.Symbol("R3")
    error = model_error(
        pendulum,
        V=-m * g * r * sp.cos(th) + rd,
        constraints=(cord(), cord(expr=r * R3, unilateral=False, force=None)),
        bodies=(Body("bob", -m, POSITION),),
    )
    assert [w for w, _ in error.issues] == [
        "constraints[2] `cord` name",
        "lagrangian.V",
        "constraints[2] `cord` f",
        "bodies[1] `bob` mass",
    ]
    # A part checked on its own lists all of its issues too.
    error = model_error(Body, "wheel", m, (r,), angle=th, shape=("ellipse", ell))
    assert [w for w, _ in error.issues] == [
        "body `wheel` position",
        "body `wheel` angle",
        "body `wheel` shape",
    ]
    assert "2 or 3" in str(error) and "inertia" in str(error) and "`ellipse`" in str(error)


def test_replace_checks_again():
    system = pendulum()
    assert dataclasses.replace(system, title="again").title == "again"
    with pytest.raises(ModelError, match="velocities are not allowed in V"):
        dataclasses.replace(system, V=system.V + rd)
    heavy = dataclasses.replace(system.bodies[0], mass=-m)  # fine alone: m's value is known
    with pytest.raises(ModelError, match="must be >= 0"):
        dataclasses.replace(system, bodies=(heavy,))
    with pytest.raises(ModelError, match="only holonomic constraints"):
        dataclasses.replace(system.constraints[0], kind=ConstraintKind.VELOCITY)


def test_parameters_are_made_as_a_file_makes_them():
    """lamech.model.parameters: values in dependency order, each symbol signed as its
    value, a float as the decimal written; the file's [parameters] give the same."""
    text = PENDULUM.replace("l = 1.0", 'I = "m*l^2/12"\nl = 1.0\nd = -0.5')
    made = parameters({"m": 1.0, "g": 9.81, "I": m * ell**2 / 12, "l": 1.0, "d": -0.5})
    assert made == lamech.loads(text).parameters
    assert made[2].numeric == pytest.approx(1 / 12) and made[4].symbol.is_negative
    with pytest.raises(ModelError, match="in a cycle"):
        parameters({"a": sp.Symbol("b"), "b": sp.Symbol("a")})


def test_a_copy_is_checked_again_only_where_it_changed(monkeypatch):
    """A copy re-runs only the checks that read a field it changed: a new title, source or
    note runs no check at the numbers of the initial state (counted by the SVDs of the
    constraints' Jacobian that look for dependent constraints there); new parameter
    values, a fresh system with other numbers, run them again."""
    system = pendulum()
    svd, calls = np.linalg.svd, []

    def counted(*args, **kwargs):
        calls.append(args[0].shape)
        return svd(*args, **kwargs)

    monkeypatch.setattr(np.linalg, "svd", counted)
    copy = dataclasses.replace(system, title="again", source="elsewhere", notes=("a note",))
    assert copy.notes == ("a note",) + system.notes and calls == []
    assert with_values(system, parameters={"g": 9.7}).parameter_values[g] == 9.7
    assert calls, "new values are checked again"
    calls.clear()
    fresh = pendulum(coordinates=(system.coordinates[0], coordinate("theta", 0.25)))
    assert fresh.initial_state[th] == sp.Rational(1, 4) and calls


@pytest.mark.parametrize(
    "name, expected",
    [
        ("t", "`t` is reserved"),
        ("sin", "`sin` is a function"),
        ("lambda_x", "lambda_"),
        ("2x", "not a valid name"),
    ],
)
def test_parameter_names_follow_the_loaders_rule(name, expected):
    error = model_error(Parameter, name, sp.Symbol(name), sp.Integer(1), 1.0)
    ((where, message),) = error.issues
    assert where == f"parameters.{name}" and expected in message
    if name != "2x":
        same_as_file(error, PENDULUM.replace("l = 1.0", f"l = 1.0\n{name} = 1.0"))


def test_parts_check_themselves():
    assert "not a finite real number" in str(
        model_error(Parameter, "a", sp.Symbol("a"), sp.Integer(1), float("inf"))
    )
    assert "`r'`" in str(model_error(Coordinate, "r", r, sp.Symbol("rdot"), rdd, ell, 0 * ell))
    assert "kind `sliding`" in str(model_error(Constraint, "c", r - ell, "sliding"))
    assert "SymPy expression" in str(model_error(Constraint, "c", r - ell, restitution=0.5))
    assert "SymPy expression" in str(model_error(Friction, 0.3, "cord"))
    assert "identically zero" in str(model_error(Constraint, "c", sp.Integer(0)))
    assert "planar" in str(model_error(Body, "b", m, (r, r, r), angle=th, inertia=m))
    assert "`residual`" in str(model_error(ForceSpec, ("b",), (r, r), (("residual", (r, r)),)))
    assert "zero vector" in str(model_error(ForceSpec, ("b",), (r, r), (("n", (0 * r, 0 * r)),)))


def test_enums_are_strings_and_strings_become_enums():
    c = Constraint("c", r - ell, "holonomic")
    assert c.kind is ConstraintKind.HOLONOMIC and c.kind == "holonomic" and c.holonomic
    assert f"{c.kind}" == "holonomic" and str(ConstraintKind.VELOCITY) == "velocity"
    assert c.multiplier == sp.Symbol("lambda_c", real=True)
    b = Body("b", m, (r, th), shape=("circle", ell))
    assert b.shape == (ShapeKind.CIRCLE, ell) and b.shape[0] == "circle"
    loaded = lamech.load("cylinder")
    assert {c.kind for c in loaded.constraints} == {ConstraintKind.HOLONOMIC}
    assert loaded.bodies[0].shape[0] is ShapeKind.CIRCLE


def test_system_level_rules():
    assert "T has no velocity" in str(model_error(pendulum, T=m * r**2))
    assert "not another constraint; known: (none)" in str(
        model_error(pendulum, constraints=(cord(friction=Friction(sp.Rational(1, 2), "floor")),))
    )
    assert "must be a coefficient of friction >= 0" in str(
        model_error(
            pendulum,
            constraints=(
                cord(),
                cord(
                    name="c2",
                    expr=th - sp.Rational(1, 2),
                    unilateral=False,
                    force=None,
                    friction=Friction(-ell, "cord"),
                ),
            ),
        )
    )
    assert "unknown body 'bobb'" in str(
        model_error(pendulum, constraints=(cord(force=ForceSpec(("bobb",), POSITION)),))
    )
    assert "linear in the velocities" in str(
        model_error(pendulum, constraints=(cord(), Constraint("v", thd**2 - 1, "velocity")))
    )
    assert "declared both as a parameter and as a coordinate" in str(
        model_error(
            pendulum,
            parameters=(
                Parameter("m", m, sp.Integer(1), 1.0),
                Parameter("g", g, sp.Integer(1), 1.0),
                Parameter("l", ell, sp.Integer(1), 1.0),
                Parameter("theta", sp.Symbol("theta", positive=True), sp.Integer(1), 1.0),
            ),
        )
    )
    assert "dependent" in str(
        model_error(pendulum, constraints=(cord(), cord(name="wire", unilateral=False, force=None)))
    )
