"""Results in units (issue 46): simulate's times, angles, multipliers and forces, the
frequencies of ``lamech modes``, the Python API's overrides in units and the ``units``
mappings of its results, and a unit that spells a parameter's name."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest
import sympy as sp

import lamech
from lamech.problem import example_path

CYLINDER = example_path("cylinder").read_text(encoding="utf-8")
UNITS = {
    "m = 1.0": 'm = "2 kg"',
    "g = 9.81": 'g = "9.81 m/s^2"',
    "R1 = 1.0": 'R1 = "1 m"',
    "R2 = 0.5": 'R2 = "50 cm"',
}
PENDULUM = """
title = "Pendulum in units"
[parameters]
m = "200 g"
g = "9.81 m/s^2"
l = "50 cm"
[coordinates]
x = { initial = "l*sin(0.1)", velocity = 0 }
y = { initial = "-l*cos(0.1)", velocity = 0 }
[lagrangian]
T = "m/2*(x'^2 + y'^2)"
V = "m*g*y"
[[constraints]]
name = "rod"
f = "l - sqrt(x^2 + y^2)"
"""


def _with_units(text: str = CYLINDER) -> str:
    for old, new in UNITS.items():
        assert f"\n{old}\n" in text
        text = text.replace(f"\n{old}\n", f"\n{new}\n")
    return text


def _cli(*args: str, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "lamech", *args], capture_output=True, text=True, cwd=cwd
    )


@pytest.fixture(scope="module")
def cylinder_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("units") / "cylinder_units.toml"
    path.write_text(_with_units(), encoding="utf-8")
    return path


# ----- simulate ---------------------------------------------------------------------
RUN = ("--initial", "theta1=0.01", "--t-end", "3", "--engine", "scipy")


def test_simulate_prints_times_in_s_and_event_angles_in_rad_and_degrees(cylinder_file):
    out = _cli("simulate", str(cylinder_file), *RUN)
    assert out.returncode == 0, out.stderr
    plain = _cli("simulate", "cylinder", *RUN).stdout
    slip = next(line for line in out.stdout.splitlines() if " slip " in line)
    slip_plain = next(line for line in plain.splitlines() if " slip " in line)
    t = float(slip_plain.split()[2])  # the same time as the unit-free run
    theta1 = float(slip_plain.split("theta1 = ")[1].split(",")[0])
    assert slip.startswith(f"    t = {t:.12g} s  slip")
    assert f"r = 1.5 m, theta1 = {theta1:.10g} rad ({math.degrees(theta1):.2f}°)" in slip
    assert math.degrees(theta1) == pytest.approx(33.48, abs=0.01)  # sin = mu (7 cos - 4)
    assert "theta1' = " in out.stdout and " rad/s" in out.stdout
    assert "lambda:contact N, lambda:rolling N, force:contact:normal N" in out.stdout
    assert " rad" not in plain and " s " not in plain.split("events")[1]


@pytest.mark.slow
def test_simulate_json_carries_the_units_and_each_event_angle_in_degrees(cylinder_file):
    data = json.loads(_cli("simulate", str(cylinder_file), *RUN, "--json").stdout)
    units = data["units"]
    assert units["t"] == "s" and units["r"] == "m" and units["r'"] == "m/s"
    assert units["theta1"] == "rad" and units["theta1'"] == "rad/s"
    assert units["lambda:contact"] == "N" and units["force:rolling:tangent"] == "N"
    assert units["energy"] == "J" and units["m"] == "kg" and units["g"] == "m/s^2"
    for event in data["events"]:
        for name, deg in event["degrees"].items():
            assert deg == pytest.approx(math.degrees(event["coordinates"][name]), rel=1e-15)
    plain = json.loads(_cli("simulate", "cylinder", *RUN, "--json").stdout)
    assert "units" not in plain and all("degrees" not in e for e in plain["events"])


def test_a_trajectory_in_units_has_a_unit_for_each_of_its_columns(cylinder_file):
    traj = lamech.simulate(lamech.load(cylinder_file), 0.5, initial={"theta1": 0.01})
    names = [name for name, _ in traj.columns()]
    assert [n for n in names if n not in traj.units] == ["residual"]  # |f| of m and rad
    assert traj.units["force:contact:normal"] == "N"
    # lambda_contact in N equals m g cos(theta1) - m (R1 + R2) theta1'^2 with m = 2 kg
    th, w = traj.coordinate("theta1"), traj.velocity("theta1")
    lam = traj.multiplier("contact")
    assert lam == pytest.approx(2 * 9.81 * np.cos(th) - 2 * 1.5 * w**2, abs=1e-9)
    assert lamech.simulate(lamech.load("cylinder"), 0.1).units == {}


# ----- modes ------------------------------------------------------------------------
@pytest.mark.slow  # 2 s or more in the default set (2026-11-29)
def test_a_pendulum_of_50_cm_oscillates_at_sqrt_g_over_half_a_metre_rad_per_s(tmp_path):
    md = lamech.modes(lamech.loads(PENDULUM))
    omega = md.equilibria[0].modes[0].frequency
    assert omega == pytest.approx(math.sqrt(9.81 / 0.5), rel=1e-12)
    assert md.units["frequency"] == "rad/s" and md.units["lambda:rod"] == "N"
    path = tmp_path / "pendulum.toml"
    path.write_text(PENDULUM, encoding="utf-8")
    out = _cli("modes", str(path))
    assert out.returncode == 0, out.stderr
    assert f"omega = {math.sqrt(9.81 / 0.5):.6g} rad/s" in out.stdout
    assert f"lambda_rod = {0.2 * 9.81:.6g} N" in out.stdout  # m g at rest, m = 200 g
    assert "y = -0.5 m" in out.stdout
    assert "at the values: thetarod = 0 rad (0°)" in out.stdout  # lamech's chart: an angle
    data = json.loads(_cli("modes", str(path), "--json").stdout)
    assert data["units"]["frequency"] == "rad/s" and data["units"]["period"] == "s"
    assert "units" not in json.loads(_cli("modes", "pendulum", "--json").stdout)


# ----- overrides in units: --param, sweeps, the Python API ----------------------------
def test_param_in_cm_on_a_file_without_units_gives_the_numbers_of_metres():
    a = json.loads(_cli("solve", "cylinder", "--json", "--param", "R2=30 cm").stdout)
    b = json.loads(_cli("solve", "cylinder", "--json", "--param", "R2=0.3").stdout)
    assert a["initial_multipliers"] == b["initial_multipliers"]
    assert a["vanishes"] == b["vanishes"]


@pytest.mark.parametrize("command", ["solve", "simulate"])
def test_a_param_of_another_dimension_is_refused_naming_it_and_both_dimensions(
    command, cylinder_file
):
    extra = ["--t-end", "1"] if command == "simulate" else []
    bad = _cli(command, str(cylinder_file), "--param", "R2=30 kg", *extra)
    assert bad.returncode == 2
    assert "--param R2=30 kg: has dimension M (mass), but `R2` has L (length)" in bad.stderr
    # a file without units: the dimensions its equations give R2 once R2 is a mass
    bad = _cli(command, "cylinder", "--param", "R2=30 kg", *extra)
    assert bad.returncode == 2
    assert "--param R2=30 kg: the problem gives this no unit, and with `R2` in M (mass)" in (
        bad.stderr
    )
    assert "a position needs L (length)" in bad.stderr


@pytest.mark.slow
def test_simulate_with_r2_in_cm_runs_as_with_r2_in_metres(cylinder_file):
    a = json.loads(
        _cli("simulate", str(cylinder_file), *RUN, "--json", "--param", "R2=40cm").stdout
    )
    b = json.loads(_cli("simulate", str(cylinder_file), *RUN, "--json", "--param", "R2=0.4").stdout)
    assert [e["t"] for e in a["events"]] == [e["t"] for e in b["events"]]
    assert a["events"][0]["coordinates"]["r"] == pytest.approx(1.4, abs=1e-12)


@pytest.mark.slow  # 2 s or more in the default set (2026-11-29)
def test_a_sweep_of_a_file_without_units_takes_a_range_in_cm_and_refuses_kg():
    args = ["--initial", "theta1=1 deg", "--measure", "liftoff", "--t-end", "3"]
    out = _cli("sweep", "cylinder", "--param", "R2=40cm:60cm:2", *args, "--engine", "scipy")
    assert out.returncode == 0, out.stderr
    rows = [line.split(",") for line in out.stdout.splitlines()[1:]]
    assert [float(r[1]) for r in rows] == [0.4, 0.6]
    bad = _cli("sweep", "cylinder", "--param", "R2=40kg:60kg:2", *args)
    assert bad.returncode == 2
    assert "the problem gives this no unit, and with `R2` in M (mass)" in bad.stderr


def test_load_with_r2_in_cm_leaves_where_the_unit_free_cylinder_does():
    pint = pytest.importorskip("pint")
    ureg = pint.UnitRegistry()
    for r2 in ("50 cm", 50 * ureg.cm, 0.5 * ureg.m, 500 * ureg.mm):
        sol = lamech.solve(lamech.load("cylinder", params={"R2": r2}))
        assert {p.name: p.value for p in sol.system.parameters}["R2"] == sp.Rational(1, 2)
        assert sol.vanishes["contact"][0].value == pytest.approx(math.acos(4 / 7), abs=1e-12)
    with pytest.raises(lamech.ProblemFileError, match=r"params\['R2'\] = '50 s': has dim"):
        lamech.loads(_with_units(), params={"R2": "50 s"})


def test_a_pendulum_loaded_with_l_in_cm_oscillates_at_sqrt_g_over_l():
    pint = pytest.importorskip("pint")
    ureg = pint.UnitRegistry()
    md = lamech.modes(lamech.load("pendulum", params={"l": 50 * ureg.cm}))
    assert md.equilibria[0].modes[0].frequency == pytest.approx(math.sqrt(9.81 / 0.5), rel=1e-12)


def test_simulate_and_sweep_take_quantities_and_their_results_carry_units(cylinder_file):
    pint = pytest.importorskip("pint")
    ureg = pint.UnitRegistry()
    traj = lamech.simulate(
        "pendulum", 0.2, params={"l": 50 * ureg.cm, "theta0": "10 deg"}, samples=3
    )
    assert traj.q[0] == pytest.approx([0.5, math.pi / 18], rel=1e-15)
    with pytest.raises(lamech.SimulationError, match=r"params\['l'\] = <Quantity\(50, 'kilo"):
        lamech.simulate("pendulum", 0.2, params={"l": 50 * ureg.kg})
    res = lamech.sweep(
        lamech.load(cylinder_file),
        {"R2": [40, 60] * ureg.cm},
        ["liftoff", "max:lambda:contact"],
        t_end=3,
        initial={"theta1": 1 * ureg.deg},
        engine="scipy",
    )
    assert list(res.column("R2")) == pytest.approx([0.4, 0.6])
    assert list(res.column("liftoff:r")) == pytest.approx([1.4, 1.6])
    assert res.units["R2"] == "m" and res.units["liftoff:t"] == "s"
    assert res.units["liftoff:theta1"] == "rad" and res.units["max:lambda:contact"] == "N"
    sol = lamech.solve(lamech.load(cylinder_file))
    assert sol.units["lambda:contact"] == "N" and sol.units["force:contact:normal"] == "N"
    assert sol.units["R2"] == "m" and lamech.solve(lamech.load("cylinder")).units == {}


# ----- a unit that spells a parameter's name ---------------------------------------------
PUSHED = """
title = "a block pushed"
[parameters]
m = "2 kg"
g = "9.81 m/s^2"
a = "2 g"
[coordinates]
x = { initial = 0, velocity = 0, unit = "m" }
[lagrangian]
T = "m/2*x'^2"
V = "m*g*x - m*a*x"
"""


def test_two_g_beside_a_parameter_g_is_two_grams_and_a_conflict_says_so_at_its_line():
    assert lamech.expr.quantity("2 g").value == sp.Rational(1, 500)  # kg
    with pytest.raises(lamech.ProblemFileError) as info:
        lamech.loads(PUSHED, "pushed.toml")
    message = str(info.value)
    assert "pushed.toml:11: lagrangian.V: the term `-a*m*x` of V has dimension M^2*L" in message
    assert (
        'pushed.toml:6: parameters.a: in the quantity "2 g", `g` is the unit gram, not the '
        'parameter g: write "2*g" for 2 times the parameter'
    ) in message
    assert "parameters.g" not in message  # "9.81 m/s^2" beside a mass m: no word alone
    fixed = lamech.loads(PUSHED.replace('a = "2 g"', 'a = "2*g"'))
    assert {p.name: p.numeric for p in fixed.parameters}["a"] == pytest.approx(2 * 9.81)


def test_two_g_that_no_check_can_tell_from_twice_g_is_warned_of():
    text = PUSHED.replace('a = "2 g"', 'a = "2 g"\nb = "a"').replace(" - m*a*x", "")
    system = lamech.loads(text)
    (note,) = [n for n in system.notes if "parameters.a" in n]
    assert '"2 g", `g` is the unit gram, not the parameter g' in note
    assert "nothing else in the file fixes the dimension of `a`" in note
    # a unit spelling a parameter where the checks fix the dimension: no warning
    assert not [n for n in lamech.loads(PENDULUM).notes if "unit" in n]  # m = "200 g"
    assert not [n for n in lamech.loads(_with_units()).notes if "unit" in n]  # R1 = "1 m"


def test_a_param_of_two_g_beside_a_parameter_g_is_refused_with_the_reason(tmp_path):
    path = tmp_path / "pushed.toml"
    path.write_text(PUSHED.replace('a = "2 g"', 'a = "2 m/s^2"'), encoding="utf-8")
    bad = _cli("solve", str(path), "--param", "a=3 g")
    assert bad.returncode == 2
    assert "--param a=3 g: has dimension M (mass), but `a` has L/T^2 (acceleration)" in bad.stderr
    assert '`g` is the unit gram, not the parameter g: write "3*g"' in bad.stderr
    good = _cli("solve", str(path), "--param", "a=3*g", "--json")
    assert good.returncode == 0, good.stderr


# ----- the report's sliders in units ---------------------------------------------------
@pytest.mark.slow
def test_the_sliders_show_their_units_and_take_a_typed_unit(cylinder_file, tmp_path, chromium):
    path = tmp_path / "cylinder.html"
    run = _cli("report", str(cylinder_file), "-o", str(path), "--no-simulate")
    assert run.returncode == 0, run.stderr
    errors: list[str] = []
    page = chromium.new_page()
    page.route(
        "**/*",
        lambda r: r.continue_() if r.request.url.startswith(("file:", "data:")) else r.abort(),
    )
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(path.as_uri())
    page.wait_for_selector("#live[data-updates]", timeout=30_000)
    assert page.locator("#live .live-unit").all_inner_texts() == ["kg", "m/s^2", "m", "m"]
    # lambda_contact at the top is m g = 2 kg * 9.81 m/s^2, in N
    lift = page.inner_text("#live-lets-go-contact")
    assert f"lambda_contact = {2 * 9.81:.6g} N > 0" in lift and "55.15°" in lift
    assert "lambda_contact [N]" in page.text_content("#live-plot")
    # R2 typed in cm: omega^2 = 2 g / (3 (R1 + R2)) about the bottom, R1 + R2 = 2 m
    page.fill("#live input[name='R2-value']", "100 cm")
    page.dispatch_event("#live input[name='R2-value']", "change")
    assert float(page.input_value("#live input[type=range][name='R2']")) == 1.0
    assert f"omega = {math.sqrt(2 * 9.81 / (3 * 2.0)):.6g} rad/s" in page.inner_text("#live-modes")
    page.fill("#live input[name='R2-value']", "3 furlongs")
    page.dispatch_event("#live input[name='R2-value']", "change")
    assert page.inner_text("#live-bad3").startswith("give a number in m, or with a unit: m, cm")
    page.close()
    assert errors == []


@pytest.mark.slow
def test_the_served_page_gets_the_units_of_what_it_shows():
    pytest.importorskip("starlette", reason="lamech[serve] not installed")
    pytest.importorskip("httpx", reason="Starlette's test client needs httpx")
    from starlette.testclient import TestClient

    from lamech.cli import make_app

    app = make_app(timeout=500, token="t", port=8765)
    with TestClient(
        app, base_url="http://127.0.0.1:8765", headers={"Authorization": "token t"}
    ) as client:
        answer = client.post("/api/run", json={"text": _with_units()}).json()
        assert answer["ok"] is True, answer
        assert answer["units"]["r"] == "m" and answer["units"]["lambda:contact"] == "N"
        assert '<td class="live-unit">m/s^2</td>' in answer["page"]
        assert "[N]" in answer["page"]  # the text report's multipliers
        plain = client.post("/api/run", json={"text": CYLINDER}).json()
        assert "units" not in plain and '<td class="live-unit">' not in plain["page"]


@pytest.mark.slow  # 2 s or more in the default set (2026-11-29)
def test_a_sweep_in_units_says_the_unit_of_each_column(cylinder_file):
    args = ["--initial", "theta1=1 deg", "--measure", "liftoff", "--t-end", "3"]
    out = _cli("sweep", str(cylinder_file), "--param", "R2=40cm:60cm:2", *args, "--engine", "scipy")
    assert out.returncode == 0, out.stderr
    assert "  units (SI): R2 m, liftoff:t s, liftoff:r m, liftoff:theta1 rad" in out.stderr
    plain = _cli("sweep", "cylinder", "--param", "R2=0.4:0.6:2", *args, "--engine", "scipy")
    assert "units" not in plain.stderr


# ----- solve --json: the flat map of units the other commands give ---------------------
@pytest.mark.slow  # 2 s or more in the default set (2026-11-29)
def test_solve_json_gives_the_same_flat_units_as_simulate(cylinder_file, tmp_path):
    solved = json.loads(_cli("solve", str(cylinder_file), "--json").stdout)["units"]
    run = json.loads(_cli("simulate", str(cylinder_file), "--t-end", "0.1", "--json").stdout)
    assert solved["lambda:contact"] == "N" and solved["force:contact:normal"] == "N"
    assert solved["theta1"] == "rad" and solved["theta1'"] == "rad/s"
    assert solved["R2"] == "m" and solved["t"] == "s" and solved["energy"] == "J"
    assert {k: v for k, v in run["units"].items() if k in solved} == {
        k: v for k, v in solved.items() if k in run["units"]
    }
    assert set(run["units"]) <= set(solved)
    # the nested maps of before, kept (deprecated) beside the flat one
    assert solved["multipliers"] == {"contact": "N", "rolling": "N"}
    assert solved["coordinates"]["theta1"] == "rad"
    # the angle lamech picks itself for a circle (x = l sin(thetarod)) is in rad
    path = tmp_path / "pendulum.toml"
    path.write_text(PENDULUM, encoding="utf-8")
    units = json.loads(_cli("solve", str(path), "--json").stdout)["units"]
    assert units["thetarod"] == "rad" and units["thetarod'"] == "rad/s"
    assert units["lambda:rod"] == "N" and units["x"] == "m"
    # the Python API's JSON is the command's
    api = lamech.to_json(lamech.solve(lamech.load(cylinder_file)))["units"]
    assert api == solved


@pytest.mark.slow  # 2 s or more in the default set (2026-11-29)
def test_a_quantity_given_to_a_file_without_units_leaves_the_results_unit_free():
    """A file without units gives its results without units, even where a --param or
    params= value carries one (converted to SI; docs/tutorials/units.md): one quantity
    does not say the units of the rest of the file."""
    solved = json.loads(_cli("solve", "cylinder", "--json", "--param", "R2=30 cm").stdout)
    assert "units" not in solved
    text = _cli("solve", "cylinder", "--param", "R2=30 cm").stdout
    assert "[N]" not in text and "lambda_contact = " in text
    run = json.loads(
        _cli("simulate", "cylinder", "--t-end", "0.1", "--json", "--param", "R2=30 cm").stdout
    )
    assert "units" not in run and run["final"]["r"] == pytest.approx(1.3, abs=1e-12)
    system = lamech.load("cylinder", params={"R2": "30 cm"})
    assert lamech.solve(system).units == {}
    assert lamech.simulate("cylinder", 0.1, params={"R2": "30 cm"}).units == {}
