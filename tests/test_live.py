"""Issue 33: the closed forms move with the parameters.

The sensitivities (d theta*/d p by implicit differentiation) against finite differences
of roots found independently (SciPy's brentq on the textbook conditions); the JavaScript
printing against SymPy's own numbers (run by Node where installed); and the report's
sliders in headless Chromium: the cylinder's slip angle for mu = 0.2 and 0.45 against
the root of sin(theta) = mu (7 cos(theta) - 4), the lift-off unmoved at 55.15°, a
contact let go at the start, and no request leaving the page.
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest
import sympy as sp
from scipy.optimize import brentq

import lamech
from lamech.present._live import LiveError, live_model, to_javascript
from lamech.symbolic import solve
from lamech.symbolic._sensitivity import free_parameters

ROOT = Path(__file__).resolve().parents[1]


def _lamech(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "lamech", *args], capture_output=True, text=True)


def slip_angle(mu: float) -> float:
    """The cylinder's slip angle: the first root of sin(theta) = mu (7 cos(theta) - 4)
    from the top (before the lift-off at cos(theta) = 4/7)."""
    return brentq(lambda t: math.sin(t) - mu * (7 * math.cos(t) - 4), 1e-9, math.acos(4 / 7))


# sphere_slide with a start along the top at speed v0: N = m (g cos(theta) - v^2 / R)
# on the shell v^2 = v0^2 + 2 g R (1 - cos(theta)), N = m (g (3 cos - 2) - v0^2 / R):
# lets go where cos(theta) = (2 + v0^2 / (g R)) / 3, at the start when v0^2 > g R.
LAUNCH = """
title = "Particle launched along the top of a sphere"
[parameters]
m = 1.0
g = 9.81
R = 1.0
v0 = 1.0
[coordinates]
r     = { initial = "R", velocity = 0 }
theta = { initial = 0, velocity = "v0/R" }
[lagrangian]
T = "m/2*(r'^2 + r^2*theta'^2)"
V = "m*g*r*cos(theta)"
[[constraints]]
name = "contact"
f = "r - R"
unilateral = true
"""


def launch_angle(v0: float, g: float = 9.81, R: float = 1.0) -> float:
    return math.acos((2 + v0**2 / (g * R)) / 3)


@pytest.fixture(scope="module")
def cylinder():
    return solve("cylinder")


@pytest.fixture(scope="module")
def launch_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("live") / "launch.toml"
    path.write_text(LAUNCH, encoding="utf-8")
    return path


# ----- sensitivities ------------------------------------------------------------------
def test_slip_sensitivity_to_mu_is_the_finite_difference_of_the_root(cylinder):
    slip = cylinder.slips["rolling"][0]
    assert slip.value == pytest.approx(slip_angle(0.3), abs=1e-12)
    h = 1e-6
    fd = (slip_angle(0.3 + h) - slip_angle(0.3 - h)) / (2 * h)
    assert slip.sensitivity["mu"] == pytest.approx(fd, rel=1e-7)
    # the slip angle depends on mu alone: m, g, R1, R2 cancel
    assert {k: slip.sensitivity[k] for k in ("m", "g", "R1", "R2")} == dict.fromkeys(
        ("m", "g", "R1", "R2"), 0.0
    )
    # the lift-off (cos = 4/7) depends on none of them
    lift = cylinder.vanishes["contact"][0]
    assert set(lift.sensitivity) == {"m", "g", "R1", "R2", "mu"}
    assert all(v == 0.0 for v in lift.sensitivity.values())


def test_lift_off_sensitivity_to_a_launch_speed(launch_file):
    sol = solve(str(launch_file))
    root = sol.vanishes["contact"][0]
    assert root.value == pytest.approx(launch_angle(1.0), abs=1e-12)
    h = 1e-6
    for name, f in (
        ("v0", lambda d: launch_angle(1.0 + d)),
        ("g", lambda d: launch_angle(1.0, g=9.81 + d)),
        ("R", lambda d: launch_angle(1.0, R=1.0 + d)),
    ):
        fd = (f(h) - f(-h)) / (2 * h)
        assert root.sensitivity[name] == pytest.approx(fd, rel=1e-6), name
    assert root.sensitivity["m"] == 0.0


def test_the_ladder_leaves_the_wall_later_from_higher_up():
    # the textbook: it leaves the wall where sin(phi) = (2/3) sin(phi0), whatever m, g, l
    root = solve("ladder").vanishes["wall"][0]
    phi0 = 1.2
    assert math.sin(root.value) == pytest.approx(2 / 3 * math.sin(phi0), abs=1e-12)
    h = 1e-6
    fd = (math.asin(2 / 3 * math.sin(phi0 + h)) - math.asin(2 / 3 * math.sin(phi0 - h))) / (2 * h)
    assert root.sensitivity["phi0"] == pytest.approx(fd, rel=1e-7)
    assert root.sensitivity["m"] == root.sensitivity["g"] == root.sensitivity["l"] == 0.0


def test_a_parameter_that_follows_others_is_not_differentiated_by():
    # vertical_circle: v0 = sqrt(3 g l), so the string slackens at cos(theta) = -1/3
    # whatever g and l: both sensitivities are 0 and v0 has none of its own
    sol = solve("vertical_circle")
    root = sol.vanishes["string"][0]
    assert math.cos(root.value) == pytest.approx(-1 / 3, abs=1e-12)
    assert [n for n, _, _ in free_parameters(sol.system)] == ["m", "g", "l"]
    assert root.sensitivity == {"m": 0.0, "g": 0.0, "l": 0.0}


@pytest.mark.slow
def test_sensitivities_in_the_text_and_the_json():
    run = _lamech("solve", "cylinder")
    assert run.returncode == 0, run.stderr
    assert "sensitivity: d theta1/d mu = 0.92282; 0 for m, g, R1, R2" in run.stdout
    assert "sensitivity: d theta1/d p = 0 for m, g, R1, R2, mu" in run.stdout
    run = _lamech("solve", "cylinder", "--json")
    assert run.returncode == 0, run.stderr
    data = json.loads(run.stdout)
    first = data["slips"]["rolling"][0]
    assert first["sensitivity"]["mu"] == pytest.approx(0.92282025, rel=1e-7)


# ----- the problem file's slider ranges ----------------------------------------------
CYLINDER = (ROOT / "lamech" / "examples" / "cylinder.toml").read_text(encoding="utf-8")


def test_the_file_may_give_a_sliders_range():
    system = lamech.loads(CYLINDER + "\n[sliders]\nmu = [0.05, 0.6]\nR2 = [0.6, 2]\n")
    assert system.sliders == (("mu", 0.05, 0.6), ("R2", 0.6, 2.0))
    model = live_model(solve(system))
    ranges = {n: (lo, hi) for n, _, lo, hi in model.params}
    assert ranges["mu"] == (0.05, 0.6)
    assert ranges["R2"] == (0.5, 2.0)  # widened to hold the file's value, 0.5
    assert ranges["g"] == (0.981, 29.43)  # the default: 0.1 to 3 times


@pytest.mark.parametrize(
    "entry, words",
    [
        (
            "nu = [0, 1]",
            "no slider `nu`: a slider is a parameter given as a number or a "
            "friction coefficient given as a number; known: R1, R2, g, m, mu",
        ),
        ("mu = [0.5, 0.1]", "needs low < high (got [0.5, 0.1])"),
        ('mu = ["a", 1]', "a slider's range is [low, high], two numbers"),
        ("mu = 0.3", "a slider's range is [low, high], two numbers"),
    ],
)
def test_a_bad_slider_range_is_said_at_its_line(entry, words):
    text = CYLINDER + "\n[sliders]\n" + entry + "\n"
    with pytest.raises(lamech.ProblemFileError) as err:
        lamech.loads(text, name="c.toml")
    line = text.splitlines().index(entry) + 1
    assert f"c.toml:{line}:" in str(err.value) and words in str(err.value), str(err.value)


# ----- JavaScript printing ------------------------------------------------------------
def _node(code: str) -> str:
    node = shutil.which("node") or shutil.which("nodejs")
    if node is None:
        pytest.skip("no Node.js to run the generated JavaScript (Debian: apt-get install nodejs)")
    out = subprocess.run([node, "-e", code], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    return out.stdout


def test_javascript_printing_gives_sympys_numbers():
    x, a, b = sp.symbols("x a b", real=True)
    exprs = [
        a * (7 * sp.cos(x) - 4) / 3,
        -sp.Rational(7, 3) * a * b * sp.sin(x),
        sp.sqrt(a) * x**2 / (b + sp.cos(x) ** 2),
        x ** sp.Rational(3, 2) - sp.atan2(x, a) + sp.exp(-b * x),
        sp.Abs(sp.sin(x)) - a * sp.tan(x) ** 3 + sp.pi,
    ]
    names = {x: "x", a: "P[0]", b: "P[1]"}
    points = [(0.3, 1.7, 0.4), (1.1, 0.2, 2.5), (2.9, 3.0, 0.01)]
    body = ",".join(f"function (x, P) {{ return {to_javascript(e, names)}; }}" for e in exprs)
    calls = ",".join(f"[{xv}, [{av}, {bv}]]" for xv, av, bv in points)
    out = _node(
        f"var F = [{body}]; var pts = [{calls}];"
        "console.log(JSON.stringify(F.map(f => pts.map(p => f(p[0], p[1])))));"
    )
    got = json.loads(out)
    for e, row in zip(exprs, got):
        for (xv, av, bv), v in zip(points, row):
            want = float(e.subs({x: xv, a: av, b: bv}))
            assert v == pytest.approx(want, rel=1e-13, abs=1e-13), (e, xv)


def test_javascript_printing_refuses_what_it_cannot_write():
    x, a, t = sp.symbols("x a t")
    with pytest.raises(LiveError, match="depends on t"):
        to_javascript(a * x + t, {x: "x", a: "P[0]"})
    with pytest.raises(LiveError):
        to_javascript(sp.besselj(0, x), {x: "x"})


def test_the_model_names_go_in_as_strings_and_only_compiled_code_as_code(cylinder):
    model = live_model(cylinder)
    assert [p[0] for p in model.params] == ["m", "g", "R1", "R2", "mu"]
    assert model.params[4] == ("mu", 0.3, 0.03, 0.9)  # x0.1 to x3 of the file's value
    assert model.skipped == ()
    # every parameter and the coordinate renamed: the compiled bodies hold x, P[i],
    # Math's functions and numbers only; the file's names are JSON strings
    bodies = re.findall(r"return (.*?); }", model.script)
    assert len(bodies) > 20
    for b in bodies:
        rest = re.sub(r"Math\.\w+|P\[\d+\]|\bx\b|\d+(\.\d+)?(e[-+]?\d+)?", "", b)
        assert re.fullmatch(r"[-+*/(), ?:<>=!&|]*", rest), b
    with pytest.raises(LiveError, match="no energy shell"):
        live_model(solve("double_pendulum"))


def test_the_compiled_model_finds_the_roots_python_finds(cylinder, tmp_path):
    """The page's own search (the runtime) run by Node on the compiled model, without a
    browser: the same roots and sensitivities as the Python side."""
    from lamech.present import report_page
    from lamech.symbolic import steps

    page = report_page(cylinder, steps(cylinder), None)
    script = page.rsplit("<script>", 1)[1].split("</script>", 1)[0]
    assert script.lstrip().startswith("(function (LIVE, root) {")
    # a minimal document for the runtime: enough elements to write into
    dom = """
    function El(tag) { this.tag = tag; this.children = []; this.attrs = {}; this.textContent = "";
      this.style = {}; }
    El.prototype.appendChild = function (c) { this.children.push(c); return c; };
    El.prototype.removeChild = function (c) { this.children.splice(this.children.indexOf(c), 1); };
    Object.defineProperty(El.prototype, "firstChild", {get: function () {
      return this.children[0] || null; }});
    El.prototype.setAttribute = function (k, v) { this.attrs[k] = String(v); };
    El.prototype.getAttribute = function (k) { return k in this.attrs ? this.attrs[k] : null; };
    El.prototype.addEventListener = function () {};
    El.prototype.querySelector = function (sel) {
      return sel[0] === "#" ? document.getElementById(sel.slice(1)) : null; };
    El.prototype.querySelectorAll = function (sel) {
      var out = [];
      (function walk(e) { e.children.forEach(function (c) {
        if (typeof c === "object") {
          if ("data-value" in c.attrs) out.push(c); walk(c); } }); })(this);
      return out; };
    var ids = {};
    var window = {addEventListener: function () {}};
    window.parent = window;
    var document = {
      getElementById: function (id) { return ids[id] || (ids[id] = new El("div")); },
      querySelectorAll: function () { return []; },
      querySelector: function () { return null; },
      createElement: function (t) { return new El(t); },
      createElementNS: function (ns, t) { return new El(t); },
    };
    """
    out = _node(
        dom
        + script
        + """
        var box = ids["live-events"], res = {};
        box.children.forEach(function (e) { res[e.id] = [e.attrs["data-when"],
          Number(e.attrs["data-value"]), e.children.length ? e.children[0].textContent : ""]; });
        console.log(JSON.stringify(res));
        """
    )
    res = json.loads(out)
    lift, slip = res["live-lets-go-contact"], res["live-slips-rolling"]
    assert lift[0] == "at the roots" and lift[1] == pytest.approx(math.acos(4 / 7), abs=1e-12)
    assert slip[0] == "at the roots" and slip[1] == pytest.approx(slip_angle(0.3), abs=1e-12)
    assert "dtheta1/dmu = 0.92282" in slip[2]


# ----- the page in headless Chromium --------------------------------------------------
@pytest.fixture(scope="module")
def pages(tmp_path_factory, launch_file) -> dict[str, Path]:
    out = tmp_path_factory.mktemp("live-pages")
    made = {}
    for name, problem in (("cylinder", "cylinder"), ("launch", str(launch_file))):
        path = out / f"{name}.html"
        run = _lamech("report", problem, "-o", str(path), "--no-simulate")
        assert run.returncode == 0, run.stderr
        made[name] = path
    return made


def _open(chromium, path: Path, ready: str = "#live[data-updates]"):
    requested: list[str] = []
    errors: list[str] = []
    page = chromium.new_page()

    def refuse(route):
        if not route.request.url.startswith(("file:", "data:")):
            requested.append(route.request.url)
            route.abort()
        else:
            route.continue_()

    page.route("**/*", refuse)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(path.as_uri())
    page.wait_for_selector(ready, timeout=30_000)
    return page, requested, errors


def _event(page, element_id: str) -> dict:
    loc = page.locator(f"#{element_id}")
    return {
        "when": loc.get_attribute("data-when"),
        "degrees": loc.get_attribute("data-degrees"),
        "text": loc.inner_text(),
    }


def _slide(page, name: str, value: float) -> None:
    """Move the slider (the range input) as a hand would: value set, then `input`."""
    page.evaluate(
        "([n, v]) => { const r = document.querySelector(`#live input[type=range][name='${n}']`);"
        " r.value = String(v); r.dispatchEvent(new Event('input')); }",
        [name, value],
    )


@pytest.mark.slow
def test_moving_mu_moves_the_slip_angle_and_not_the_lift_off(pages, chromium):
    page, requested, errors = _open(chromium, pages["cylinder"])
    assert page.locator("#live input[type=range]").count() == 5
    for name in ("m", "g", "R1", "R2", "mu"):
        assert page.locator(f"#live input[type=range][name='{name}']").count() == 1
    lift = _event(page, "live-lets-go-contact")
    assert "55.15°" in lift["text"] and lift["when"] == "at the roots"
    assert "33.48°" in _event(page, "live-slips-rolling")["text"]
    for mu, shown in ((0.2, "26.75°"), (0.45, "39.39°")):
        _slide(page, "mu", mu)
        slip = _event(page, "live-slips-rolling")
        assert shown in slip["text"], slip
        assert float(slip["degrees"]) == pytest.approx(math.degrees(slip_angle(mu)), abs=1e-9)
        assert f"{math.degrees(slip_angle(mu)):.2f}°" == shown  # the truth, not the page
        # the number box follows the slider
        assert float(page.input_value("#live input[name='mu-value']")) == mu
        lift = _event(page, "live-lets-go-contact")
        assert "55.15°" in lift["text"]
        assert float(lift["degrees"]) == pytest.approx(math.degrees(math.acos(4 / 7)), abs=1e-9)
        # the sensitivity beside it, against a finite difference of the root
        h = 1e-6
        fd = (slip_angle(mu + h) - slip_angle(mu - h)) / (2 * h)
        sens = slip["text"].split("dtheta1/dmu = ")[1].split(",")[0].strip()
        assert float(sens) == pytest.approx(fd, rel=1e-5)
    # the plot: one curve per multiplier, a mark at each event
    assert page.locator("#live-plot path[data-multiplier]").count() == 2
    assert page.locator("#live-plot .live-mark").count() == 2
    # typing a value works as sliding; a blank box says so and changes nothing
    page.fill("#live input[name='mu-value']", "0.2")
    page.dispatch_event("#live input[name='mu-value']", "change")
    assert "26.75°" in _event(page, "live-slips-rolling")["text"]
    page.fill("#live input[name='g-value']", "")
    page.dispatch_event("#live input[name='g-value']", "change")
    assert page.inner_text("#live-bad1") == "not a number"
    assert "26.75°" in _event(page, "live-slips-rolling")["text"]
    # small oscillations: omega^2 = 2 g / (3 (R1 + R2)) about the bottom
    _slide(page, "R2", 1.0)
    modes = page.inner_text("#live-modes")
    assert f"omega = {math.sqrt(2 * 9.81 / (3 * 2.0)):.6g} rad/s" in modes
    page.click("#live-reset")
    assert "33.48°" in _event(page, "live-slips-rolling")["text"]
    page.close()
    assert errors == [] and requested == []


@pytest.mark.slow
def test_a_launch_too_fast_lets_go_at_the_start(pages, chromium, launch_file):
    page, requested, errors = _open(chromium, pages["launch"])
    lift = _event(page, "live-lets-go-contact")
    assert lift["when"] == "at the roots"
    assert float(lift["degrees"]) == pytest.approx(math.degrees(launch_angle(1.0)), abs=1e-9)
    _slide(page, "v0", 2.5)
    lift = _event(page, "live-lets-go-contact")
    assert float(lift["degrees"]) == pytest.approx(math.degrees(launch_angle(2.5)), abs=1e-9)
    # v0^2 > g R: the sphere cannot hold it even at the top (beyond the slider: typed)
    page.fill("#live input[name='v0-value']", "3.5")
    page.dispatch_event("#live input[name='v0-value']", "change")
    lift = _event(page, "live-lets-go-contact")
    assert lift["when"] == "at the start" and "lets go at the start" in lift["text"]
    assert lift["degrees"] is None
    assert float(page.get_attribute("#live input[type=range][name='v0']", "max")) == 3.5
    page.close()
    assert errors == [] and requested == []
    # the Python side says the same at that value
    run = _lamech("solve", str(launch_file), "--param", "v0=3.5", "--json")
    assert run.returncode == 0, run.stderr
    assert json.loads(run.stdout)["lets_go"]["contact"]["when"] == "at the start"


@pytest.mark.slow
def test_the_page_stays_small_and_offline(pages):
    text = pages["cylinder"].read_text(encoding="utf-8")
    assert pages["cylinder"].stat().st_size < 1_000_000
    live = text.rsplit("<script>", 1)[1]
    assert "fetch(" not in live and "XMLHttpRequest" not in live and "eval(" not in live
    assert "new Function" not in live


# ----- lamech serve: a slider re-runs the simulation ----------------------------------
def slip_angle_from(mu: float, theta0: float) -> float:
    """Released at theta0 at rest: sin(theta) = mu (7 cos(theta) - 4 cos(theta0))."""
    return brentq(
        lambda t: math.sin(t) - mu * (7 * math.cos(t) - 4 * math.cos(theta0)),
        theta0,
        math.acos(4 / 7 * math.cos(theta0)),
    )


@pytest.mark.slow
def test_serve_runs_the_simulation_at_a_sliders_values():
    pytest.importorskip("starlette", reason="lamech[serve] not installed")
    pytest.importorskip("httpx", reason="Starlette's test client needs httpx")
    from starlette.testclient import TestClient

    from lamech.cli import make_app

    text = (ROOT / "lamech" / "examples" / "cylinder.toml").read_text(encoding="utf-8")
    app = make_app(timeout=500, token="t", port=8765)
    with TestClient(
        app, base_url="http://127.0.0.1:8765", headers={"Authorization": "token t"}
    ) as client:
        body = {"text": text, "simulate": True, "t_end": 3.0, "initial": {"theta1": 0.01}}
        r = client.post("/api/run", json={**body, "params": {"mu": 0.2}, "events_only": True})
        answer = r.json()
        assert r.status_code == 200 and answer["ok"], answer
        assert "page" not in answer and answer["params"] == {"mu": 0.2}
        slip = next(e for e in answer["events"] if e["kind"] == "slip")
        assert slip["coordinates"]["theta1"] == pytest.approx(slip_angle_from(0.2, 0.01), abs=1e-6)
        # what is wrong is said: a value, a name, params without a simulation
        r = client.post("/api/run", json={**body, "params": {"mu": "a lot"}})
        assert r.status_code == 400 and "`mu` must be a finite number" in r.text
        r = client.post("/api/run", json={**body, "params": {"nu": 1.0}, "events_only": True})
        assert r.status_code == 200 and not r.json()["ok"] and "nu" in r.text
        r = client.post("/api/run", json={"text": text, "params": {"mu": 0.2}})
        assert r.status_code == 400 and "simulate" in r.text


@pytest.mark.slow
def test_serve_sliders_rerun_the_simulation_debounced(chromium):
    port = _free_port()
    server = subprocess.Popen(
        [sys.executable, "-m", "lamech", "serve", "--port", str(port), "--token", "t"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env=dict(os.environ, LAMECH_SERVE_NICE="0"),  # niced work starves beside compiles
    )
    try:
        url = f"http://127.0.0.1:{port}/"
        for _ in range(150):
            try:
                socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
                break
            except OSError:
                time.sleep(0.2)
        page = chromium.new_page(viewport={"width": 1400, "height": 900})
        outside: list[str] = []
        runs: list[str] = []
        page.on(
            "request",
            lambda r: (
                outside.append(r.url) if not r.url.startswith((url, "data:", "about:")) else None
            ),
        )
        page.on(
            "request",
            lambda r: runs.append(r.post_data or "") if r.url.endswith("/api/run") else None,
        )
        page.goto(url + "?token=t")
        text = (ROOT / "lamech" / "examples" / "cylinder.toml").read_text(encoding="utf-8")
        page.fill("#editor", text)
        page.fill("#initial", "theta1=0.01")
        page.click("#simulate")
        page.wait_for_function(
            "() => document.getElementById('status').textContent.startsWith('done')",
            timeout=400_000,
        )
        frame = page.frame_locator("#result")
        frame.locator("#live[data-updates]").wait_for(timeout=30_000)
        before = len(runs)
        # three moves in quick succession: one simulation, at the last values
        for mu in (0.3, 0.25, 0.2):
            frame.locator("#live input[type=range][name='mu']").evaluate(
                "(r, v) => { r.value = String(v); r.dispatchEvent(new Event('input')); }", mu
            )
        assert "26.75°" in frame.locator("#live-slips-rolling").inner_text()  # closed form
        frame.locator("#live-simulated[data-state='done']").wait_for(timeout=400_000)
        said = frame.locator("#live-simulated").inner_text()
        want = math.degrees(slip_angle_from(0.2, 0.01))
        shown = float(said.split("rolling slip")[1].split("theta1 = ")[1].split("°")[0])
        assert shown == pytest.approx(want, abs=0.006), said
        sent = [json.loads(b) for b in runs[before:]]
        assert len(sent) == 1 and sent[0]["params"]["mu"] == 0.2 and sent[0]["events_only"]
        assert outside == []
    finally:
        server.terminate()
        server.wait(10)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# ----- the notebook: a Solution shows the page's own controls ------------------------
def test_a_solution_in_a_notebook_has_its_own_sliders(cylinder, launch_file, chromium, tmp_path):
    """Jupyter calls ``_repr_html_``; two outputs in one document move independently."""
    one, two = cylinder._repr_html_(), solve(str(launch_file))._repr_html_()
    assert "$$\\begin{aligned}" in one and '<input type="range"' in one
    assert one.count("<script>") == 1  # no KaTeX: the notebook typesets the math
    doc = tmp_path / "notebook.html"
    doc.write_text(
        f"<!DOCTYPE html><meta charset='utf-8'><body>{one}<hr>{two}</body>", encoding="utf-8"
    )
    page, requested, errors = _open(chromium, doc, "[id^='lamech-live-'][data-updates]")
    roots = page.locator("[id^='lamech-live-']")
    assert roots.count() == 2
    cyl, launch = roots.nth(0), roots.nth(1)
    cyl.locator("input[name='mu-value']").fill("0.45")
    cyl.locator("input[name='mu-value']").dispatch_event("change")
    assert "39.39°" in cyl.locator("#live-slips-rolling").inner_text()
    want = f"{math.degrees(launch_angle(1.0)):.2f}°"
    assert want in launch.locator("#live-lets-go-contact").inner_text()  # untouched
    launch.locator("input[name='v0-value']").fill("2.5")
    launch.locator("input[name='v0-value']").dispatch_event("change")
    want = f"{math.degrees(launch_angle(2.5)):.2f}°"
    assert want in launch.locator("#live-lets-go-contact").inner_text()
    assert "39.39°" in cyl.locator("#live-slips-rolling").inner_text()
    page.close()
    assert errors == [] and requested == []
