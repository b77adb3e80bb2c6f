"""``lamech report``: one self-contained HTML page that opens offline (issue 15, item 2),
checked as text and, where Chromium is installed, rendered in a real headless browser
through Playwright with every network request refused (item 4, for the report file)."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from lamech.cli import main

ROOT = Path(__file__).resolve().parents[1]
ARTEFACTS = ROOT / "tests" / "artefacts"


def _lamech(*args, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "lamech", *args], capture_output=True, text=True, cwd=cwd
    )


@pytest.fixture(scope="module")
def cylinder_page(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("report") / "cylinder.html"
    run = _lamech("report", "cylinder", "-o", str(out), "--initial", "theta1=0.01")
    assert run.returncode == 0, run.stderr
    assert run.stdout.startswith(f"wrote {out} (")
    return out


@pytest.mark.slow
def test_the_page_holds_everything_and_needs_nothing_outside(cylinder_page):
    page = cylinder_page.read_text(encoding="utf-8")
    assert cylinder_page.stat().st_size < 2_000_000  # issue 15: under 2 MB for the cylinder
    # no resource from outside: every src/href is a data URI or a fragment
    markup = re.sub(r"<script>.*?</script>", "", page, flags=re.S)  # KaTeX's own code
    assert page.count("<script>") == 3  # KaTeX, the call that renders the blocks, the sliders
    for attr in re.findall(r'(?:src|href)\s*=\s*"([^"]*)"', markup):
        assert attr.startswith(("data:", "#")), attr
    assert "<link" not in page and "@import" not in page
    assert "url(fonts/" not in page  # KaTeX's fonts inlined
    assert page.count("url(data:font/woff2;base64,") == 20
    assert "Copyright (c) 2013-2020 Khan Academy" in page  # the licence kept
    # the problem file, the results, the steps, the motion
    assert "f = &quot;r - (R1 + R2)&quot;" in page
    assert r"\frac{4}{7}" in page and "55.15" in page
    assert page.count('<h3 id="step-') == 13
    assert 'class="note correction"' in page and "(R1 + R2) dtheta1" in page
    assert page.count("data:image/png;base64,") == 1 and page.count("data:image/gif;base64,") == 1
    summary = page.rsplit("<pre>", 2)[1]  # the simulation summary (before the licence)
    assert "lift-off" in summary and "contact" in summary  # rolled off the top, let go


@pytest.mark.slow
def test_report_errors_say_where_and_lose_nothing(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(
        'title = "x"\n[coordinates]\nx = { initial = 0, velocity = 0 }\n'
        '[lagrangian]\nT = "x\'^2/2"\nV = "x^^2"\n',
        encoding="utf-8",
    )
    run = _lamech("report", str(bad), "-o", str(tmp_path / "r.html"))
    assert run.returncode == 2 and "Traceback" not in run.stderr
    assert f"{bad}:6:" in run.stderr
    assert not (tmp_path / "r.html").exists()
    # the page may not replace the problem file
    good = tmp_path / "p.toml"
    good.write_text((ROOT / "lamech" / "examples" / "pendulum.toml").read_text(), encoding="utf-8")
    before = good.read_bytes()
    run = _lamech("report", str(good), "-o", str(good))
    assert run.returncode == 2 and "--out" in run.stderr
    assert good.read_bytes() == before


@pytest.mark.slow
def test_report_without_simulation_and_with_a_param(tmp_path):
    out = tmp_path / "p.html"
    run = _lamech("report", "pendulum", "-o", str(out), "--no-simulate", "--param", "theta0=1")
    assert run.returncode == 0, run.stderr
    page = out.read_text(encoding="utf-8")
    assert 'id="motion"' not in page and "data:image/gif" not in page
    assert "Step 1. The Lagrangian" in page
    # without a simulation the drawing takes the closed forms at the file's start
    drawing = page.split('<svg id="drawing"', 1)[1].split("</svg>", 1)[0]
    assert 'class="body"' in drawing and 'class="force"' in drawing
    assert 'class="label"' not in drawing  # pivot, string and bob on one line, apart


@pytest.mark.slow
def test_a_drawing_on_one_line_names_its_links_apart(tmp_path):
    """The slider-crank at phi = 0 lies on one line: crank, rod and guide on top of one
    another. Each named link and body is labelled, its extent drawn in a lane of its own
    beside the line, the lanes apart from one another and inside the drawing."""
    import xml.etree.ElementTree as ET

    out = tmp_path / "p.html"
    run = _lamech("report", "slider_crank", "-o", str(out), "--no-simulate")
    assert run.returncode == 0, run.stderr
    page = out.read_text(encoding="utf-8")
    drawing = page.split('<svg id="drawing"', 1)[1].split("</svg>", 1)[0]
    svg = ET.fromstring('<svg id="drawing"' + drawing + "</svg>")
    ns = "{http://www.w3.org/2000/svg}"
    width, height = (float(v) for v in svg.get("viewBox").split()[2:])
    lanes = {g.get("data-name"): g for g in svg.iter(ns + "g") if g.get("class") == "label"}
    assert set(lanes) == {"crank pivot", "crank", "rod", "guide", "slider"}, lanes
    spots = set()
    for name, g in lanes.items():
        text = g.find(ns + "text")
        assert text is not None and text.text == name
        x, y = float(text.get("x")), float(text.get("y"))
        assert 0 <= x <= width and 0 <= y <= height, (name, x, y)
        spots.add((round(x), round(y)))
    assert len(spots) == len(lanes)  # no two labels at one place
    # a link's lane spans the link: the rod from the crank pin (r) to the slider (r + l)
    rod = lanes["rod"].find(ns + "line")
    crank = lanes["crank"].find(ns + "line")
    r, l = 0.1, 0.3
    scale = (float(rod.get("x2")) - float(rod.get("x1"))) / l
    assert scale > 0
    assert abs((float(crank.get("x2")) - float(crank.get("x1"))) / r - scale) < 0.01 * scale
    assert abs(float(rod.get("x1")) - float(crank.get("x2"))) < 0.5  # joined at the pin


@pytest.mark.slow
def test_the_drawing_escapes_the_title(tmp_path):
    problem = tmp_path / "p.toml"
    text = (ROOT / "lamech" / "examples" / "pendulum.toml").read_text(encoding="utf-8")
    title = next(line for line in text.splitlines() if line.startswith("title"))
    problem.write_text(
        text.replace(title, 'title = "<script>alert(1)</script> & co"'), encoding="utf-8"
    )
    out = tmp_path / "p.html"
    run = _lamech("report", str(problem), "-o", str(out), "--no-simulate")
    assert run.returncode == 0, run.stderr
    page = out.read_text(encoding="utf-8")
    assert "<script>alert" not in page
    label = "&lt;script&gt;alert(1)&lt;/script&gt; &amp; co at its initial state"
    assert f'aria-label="{label}"' in page


@pytest.mark.slow
@pytest.mark.shared_cache
def test_the_report_renders_offline_in_headless_chromium(cylinder_page, chromium):
    requested: list[str] = []
    page = chromium.new_page(viewport={"width": 1100, "height": 1400})

    def refuse(route):
        if not route.request.url.startswith(("file:", "data:")):
            requested.append(route.request.url)
            route.abort()
        else:
            route.continue_()

    page.route("**/*", refuse)
    page.goto(cylinder_page.as_uri())
    page.wait_for_selector("body[data-rendered]", timeout=30_000)
    blocks = page.locator(".math, .tex").count()
    rendered = page.locator(".katex").count()
    assert blocks > 100 and rendered == blocks  # every block typeset by KaTeX
    assert page.locator(".katex-error").count() == 0
    # the rendered lift-off row: cos(theta1) = 4/7 with its angle
    lift = page.locator("tr", has_text="contact lets go").first
    assert "55.15" in lift.inner_text()
    assert lift.locator(".katex .mfrac").count() == 1
    # the KaTeX fonts were loaded from the page itself
    fonts = page.evaluate(
        "Array.from(document.fonts).filter(f => f.status === 'loaded').map(f => f.family)"
    )
    assert any("KaTeX" in f for f in fonts)
    ARTEFACTS.mkdir(exist_ok=True)
    page.screenshot(path=str(ARTEFACTS / "report-cylinder.png"), full_page=False)
    page.close()
    assert requested == []  # nothing asked of the network


@pytest.mark.slow
@pytest.mark.shared_cache
def test_the_report_runs_under_its_own_policy_in_headless_chromium(cylinder_page, chromium):
    """Issue 44, item 6: the page's Content-Security-Policy (a <meta>: a file has no
    headers) lets its own scripts, styles, images and fonts work, without one console
    error, and refuses anything else: a script added later, a request to the network."""
    text = cylinder_page.read_text(encoding="utf-8")
    head = text.split("</head>", 1)[0]
    policy = re.search(r'<meta http-equiv="Content-Security-Policy" content="([^"]*)">', head)
    assert policy is not None and head.index(policy.group(0)) < head.index("<style")
    directives = policy.group(1).replace("&#x27;", "'")
    assert directives.startswith("default-src 'none'; script-src 'sha256-")
    assert directives.count("'sha256-") == 3 + 2  # three scripts, two styles
    assert "unsafe" not in directives and "http" not in directives
    assert '<meta name="referrer" content="no-referrer">' in head
    page = chromium.new_page()
    console: list[str] = []
    page.on("console", lambda m: console.append(f"{m.type}: {m.text}"))
    page.on("pageerror", lambda e: console.append(f"pageerror: {e}"))
    page.goto(cylinder_page.as_uri())
    page.wait_for_selector("body[data-rendered]", timeout=30_000)
    page.wait_for_selector("#live[data-updates]", timeout=30_000)
    blocks = page.locator(".math, .tex").count()
    assert blocks > 100 and page.locator(".katex").count() == blocks
    widths = page.locator("img").evaluate_all("xs => xs.map(x => x.complete && x.naturalWidth)")
    assert len(widths) == 2 and all(w > 0 for w in widths)  # the plot and the animation
    assert console == [], console
    refused = page.evaluate(
        """() => new Promise(done => {
             const seen = [];
             document.addEventListener("securitypolicyviolation", e => {
               seen.push(e.effectiveDirective);
               if (seen.length === 2) done(seen.sort());
             });
             const s = document.createElement("script");
             s.textContent = "document.body.dataset.ran = 1";
             document.body.appendChild(s);
             const i = document.createElement("img");
             i.src = "http://127.0.0.1:9/x.png";
             document.body.appendChild(i);
           })"""
    )
    assert refused == ["img-src", "script-src-elem"]
    assert page.locator("body[data-ran]").count() == 0
    page.close()


FIRST_SCREEN = {  # issue 48: the page opens on the drawing and the key results
    "cylinder": ("--initial", "theta1=0.01"),
    "pendulum": (),
    "slider_crank": (),
    "robot_arm": (),  # multipliers of some 400 terms: the results table must not widen the page
    str(ROOT / "tests" / "problems" / "trammel.toml"): (),
}


@pytest.mark.slow
@pytest.mark.shared_cache
@pytest.mark.parametrize("problem", list(FIRST_SCREEN))
def test_the_first_screen_shows_the_system_and_its_results(problem, chromium, tmp_path):
    """The first 800 px of the page: a drawing of the system at its start (an <svg> with
    its bodies and at least one force arrow) and the key results; the problem file
    folded at the end; every plot's axes titled, with ticks between their ends."""
    out = tmp_path / "page.html"
    run = _lamech("report", problem, "-o", str(out), *FIRST_SCREEN[problem])
    assert run.returncode == 0, run.stderr
    page = chromium.new_page(viewport={"width": 1100, "height": 800})
    console: list[str] = []
    page.on("console", lambda m: console.append(f"{m.type}: {m.text}"))
    page.on("pageerror", lambda e: console.append(f"pageerror: {e}"))
    page.goto(out.as_uri())
    page.wait_for_selector("body[data-rendered]", timeout=30_000)

    def bottom(selector: str) -> float:
        box = page.locator(selector).first.bounding_box()
        assert box is not None, selector
        return box["y"] + box["height"]

    drawing = page.locator("#first svg#drawing")
    assert drawing.count() == 1
    assert drawing.locator("g.body").count() >= 1
    if problem != "robot_arm":  # its drives give no force = {at, along} to draw
        assert drawing.locator("g.force line").count() >= 1
    assert bottom("#first svg#drawing") <= 800
    assert page.locator(".keys li").count() >= 1 and bottom(".keys li") <= 800
    assert page.locator(".key-lambda").count() >= 1
    # the problem file: folded, after everything else
    details = page.locator("details#problem-file")
    assert details.count() == 1 and details.get_attribute("open") is None
    assert page.locator("#problem-file pre").is_visible() is False
    # the plots: axis titles and ticks
    if page.locator("#live-plot").count():
        page.wait_for_selector("#live[data-updates]", timeout=30_000)
        assert page.locator("#live-plot .axis-title").count() == 2
        assert page.locator("#live-plot line.tick").count() >= 6
    # nothing wider than the window: a long formula scrolls inside its cell
    assert page.evaluate("document.documentElement.scrollWidth") <= 1100
    for table in page.locator("table.eqs").all():
        box = table.bounding_box()
        assert box is not None and box["x"] + box["width"] <= 1100, box
    if "slider_crank" in problem:  # on one line at phi = 0: the labels apart, inside
        frame = page.locator("#first svg#drawing").bounding_box()
        boxes = [t.bounding_box() for t in drawing.locator("g.label text").all()]
        assert len(boxes) == 5 and all(b is not None for b in boxes)
        for i, a in enumerate(boxes):
            assert frame["x"] <= a["x"] and a["x"] + a["width"] <= frame["x"] + frame["width"]
            for b in boxes[:i]:
                apart = (
                    a["x"] + a["width"] <= b["x"] or b["x"] + b["width"] <= a["x"]
                    or a["y"] + a["height"] <= b["y"] or b["y"] + b["height"] <= a["y"]
                )  # fmt: skip
                assert apart, (a, b)
    if "slider_crank" in problem:
        plot = page.locator("svg#drive-motor")
        titles = plot.locator(".axis-title").all_text_contents()
        assert titles == ["phi [deg]", "torque of motor"]
        assert plot.locator("line.tick").count() >= 6
    shot = tmp_path / "first.png"
    page.screenshot(path=str(shot), full_page=False)
    assert shot.stat().st_size > 10_000
    ARTEFACTS.mkdir(exist_ok=True)
    (ARTEFACTS / f"report-first-{Path(problem).stem}.png").write_bytes(shot.read_bytes())
    page.close()
    assert console == [], console


@pytest.mark.slow
def test_the_report_without_matplotlib_is_written_and_says_it_has_no_plots(
    tmp_path, monkeypatch, capsys
):
    import sys

    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import matplotlib fails
    out = tmp_path / "report.html"
    assert main(["report", "pendulum", "-o", str(out), "--t-end", "0.2"]) == 0
    err = capsys.readouterr().err
    assert "no plot or animation: they need matplotlib" in err
    page = out.read_text(encoding="utf-8")
    assert "no plot and no animation: they need matplotlib" in page
    assert "data:image/png" not in page and "final state" in page


def test_a_file_without_bodies_with_numbered_points_is_drawn(tmp_path):
    """The Cartesian double pendulum (x1, y1, x2, y2, no [[bodies]]): the drawing makes a
    point of each pair, named so a body may be (it stopped with a traceback: body `1`
    is not a valid name); both points are drawn."""
    from lamech.cli import main

    out = tmp_path / "dp.html"
    path = ROOT / "tests" / "problems" / "double_pendulum_xy.toml"
    assert main(["report", str(path), "-o", str(out), "--no-simulate"]) == 0
    page = out.read_text(encoding="utf-8")
    assert "point1" in page and "point2" in page
