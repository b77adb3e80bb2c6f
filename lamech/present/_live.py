"""The report's sliders: the closed forms of a solution, compiled once to JavaScript,
re-evaluated in the browser as the reader moves a parameter (offline, no server).

What is compiled (:func:`live_model`), every expression in the free parameters
(:func:`lamech.symbolic._sensitivity.free_parameters`: a parameter written as an expression of
others follows them; a friction coefficient written as a number gets a slider of its
own) and the shell's coordinate x: the initial x0 and x0', the speed x'^2(x) on the
energy shell and its slope, each multiplier on the shell with its derivatives by x and
by each parameter, each friction coefficient with its gradient, and omega^2 of each
equilibrium with a closed form. The printer is SymPy's JavaScript code printer, fed
SymPy expressions (the problem file was parsed by :mod:`lamech.expr`); no text from
the file reaches the page's code: names go in as JSON strings, symbols are renamed to
``x`` and ``P[i]`` before printing, and an expression with anything else left is not
compiled.

In the page, :data:`RUNTIME` finds the range the motion reaches and the roots the way
:mod:`lamech.symbolic._conditions` does (a grid of :data:`GRID` points, then bisection),
the verdict at the start, the sensitivities dx*/dp = -F_p / F_x at each root, and
draws the multipliers against x in an inline SVG.
"""

from __future__ import annotations

import html
import json
from dataclasses import dataclass

import sympy as sp
from sympy.printing.jscode import JavascriptCodePrinter

from .._errors import LamechError
from ..expr import to_text
from ..model import result_units
from ..symbolic._conditions import is_angle
from ..symbolic._sensitivity import free_parameters, friction_mu, in_free_parameters
from ._svgplot import TICKS_JS

__all__ = ["LiveError", "to_javascript", "live_model", "live_section"]

GRID = 4001
"""Grid points per segment for turning points and roots (as the Python side)."""

RANGE = (0.1, 3.0)
"""A slider's default range: these multiples of the file's value (-1..1 for zero); the
problem file's ``[sliders]`` section gives others (``mu = [0.05, 1.0]``), widened to
hold the value itself."""


class LiveError(LamechError, ValueError):
    """An expression that cannot be compiled to JavaScript (a function the printer does
    not know, or a symbol other than the coordinate and the parameters)."""


_X = sp.Symbol("x")


def to_javascript(expr: sp.Expr, names: dict[sp.Symbol, str]) -> str:
    """``expr`` as a JavaScript expression, each symbol renamed by ``names`` (to ``x`` or
    ``P[i]``); :class:`LiveError` if any other symbol is left or the printer cannot
    write a function."""
    renamed = sp.sympify(expr).xreplace({s: sp.Symbol(n) for s, n in names.items()})
    left = renamed.free_symbols - {sp.Symbol(n) for n in names.values()}
    if left:
        raise LiveError(
            "depends on " + ", ".join(sorted(str(s) for s in left)) + " besides the parameters"
        )
    printer = JavascriptCodePrinter({"strict": True})
    try:
        code = printer.doprint(renamed)
    except (TypeError, ValueError, NotImplementedError, AttributeError) as exc:
        raise LiveError(f"cannot be written in JavaScript ({exc})") from exc
    if getattr(printer, "_not_supported", None) or "//" in code:
        raise LiveError("uses a function JavaScript's Math does not have")
    return " ".join(code.split())


@dataclass(frozen=True)
class LiveModel:
    """The compiled solution: ``script`` (a JavaScript object literal), the ``params``
    (name, value, min, max) of the sliders, and ``skipped``: what could not be compiled."""

    script: str
    params: tuple[tuple[str, float, float, float], ...]
    skipped: tuple[str, ...]
    units: tuple[tuple[str, str], ...] = ()
    """Where the file gives units (issue 46): each slider's SI unit, by name."""


def _range(value: float) -> tuple[float, float]:
    if value == 0:
        return -1.0, 1.0
    a, b = float(f"{RANGE[0] * value:.6g}"), float(f"{RANGE[1] * value:.6g}")
    return (min(a, b), max(a, b))


def live_model(sol, equilibria=None) -> LiveModel:
    """The sliders' model of ``sol`` (it needs an energy shell: :class:`LiveError`
    without one); ``equilibria`` (:func:`lamech.modes`' ``equilibria``) add their
    frequencies."""
    shell = sol.shell
    if shell is None:
        raise LiveError(f"no energy shell ({sol.shell_reason})")
    system = sol.system
    free = free_parameters(system)
    x = shell.coordinate.symbol
    names = {s: f"P[{i}]" for i, (_, s, _) in enumerate(free)}
    xnames = {**names, x: "x"}

    def fn(expr, with_x: bool = True) -> str:
        e = in_free_parameters(system, expr)
        body = to_javascript(e, xnames if with_x else names)
        return f"function (x, P) {{ return {body}; }}"

    def grad(expr) -> str:
        e = in_free_parameters(system, expr)
        return "[" + ", ".join(fn(sp.diff(e, s)) for _, s, _ in free) + "]"

    parts = {
        "coord": json.dumps(shell.coordinate.name),
        "angle": "true" if is_angle(system, x) else "false",
        "x0": fn(shell.coordinate.initial, False),
        "v0": fn(shell.coordinate.initial_velocity, False),
        "K": fn(shell.speed_squared),
        "dK": fn(sp.diff(shell.speed_squared, x)),
    }
    skipped: list[str] = []
    lam, compiled = [], set()
    for name, expr in shell.multipliers.items():
        try:
            lam.append(
                f"{json.dumps(name)}: {{f: {fn(expr)}, dx: {fn(sp.diff(expr, x))}, "
                f"dp: {grad(expr)}}}"
            )
        except LiveError as exc:
            skipped.append(f"lambda_{name} {exc}")
        else:
            compiled.add(name)
    parts["lam"] = "{" + ", ".join(lam) + "}"
    unilateral = [
        c.name
        for c in system.constraints
        if c.unilateral and c.name in sol.vanishes and c.name in compiled
    ]
    parts["unilateral"] = json.dumps(unilateral)
    friction = []
    for c in system.constraints:
        fr = c.friction
        if fr is None or c.name not in sol.slips:
            continue
        if c.name not in compiled or fr.normal not in compiled:
            continue
        mu = friction_mu(system, c.name)
        try:
            friction.append(
                f"{{name: {json.dumps(c.name)}, normal: {json.dumps(fr.normal)}, "
                f"mu: {fn(mu, False)}, dmu: {grad(mu)}}}"
            )
        except LiveError as exc:
            skipped.append(f"mu of {c.name} {exc}")
    parts["friction"] = "[" + ", ".join(friction) + "]"
    modes = []
    for eq in equilibria or ():
        if not eq.exists:
            continue
        at = ", ".join(f"{k} = {to_text(v)}" for k, v in eq.at.items())
        if not eq.holds and eq.note:
            at += f" (no equilibrium of the real system: {eq.note})"
        for m in eq.modes:
            if m.squared is None:
                continue
            try:
                modes.append(f"{{at: {json.dumps(at)}, w2: {fn(m.squared, False)}}}")
            except LiveError as exc:
                skipped.append(f"omega^2 at {at} {exc}")
    parts["modes"] = "[" + ", ".join(modes) + "]"
    given = {name: (low, high) for name, low, high in system.sliders}
    params = tuple(
        (n, v, min(given[n][0], v), max(given[n][1], v)) if n in given else (n, v, *_range(v))
        for n, _, v in free
    )
    units = result_units(system)
    slider_units = {n: units[n] for n, *_ in params if n in units}
    parts["params"] = json.dumps(
        [
            {"name": n, "value": v, "min": lo, "max": hi}
            | (
                {"unit": slider_units[n], "accept": typed_units(system, n)}
                if n in slider_units
                else {}
            )
            for n, v, lo, hi in params
        ]
    )
    if units:  # the results' units: each multiplier's and the coordinate's
        shown = {k: u for k, u in units.items() if k.startswith("lambda:")}
        if shell.coordinate.name in units:
            shown[shell.coordinate.name] = units[shell.coordinate.name]
        parts["units"] = json.dumps(shown)
    script = "{\n" + ",\n".join(f"  {k}: {v}" for k, v in parts.items()) + "\n}"
    return LiveModel(
        script.replace("</", "<\\/"), params, tuple(skipped), tuple(slider_units.items())
    )


TYPED_UNITS = (
    "m", "cm", "mm", "km", "um", "in", "ft", "kg", "g", "mg", "s", "ms", "min", "h",
    "N", "kN", "mN", "J", "kJ", "N*m", "N/m", "N/cm", "N/mm", "kg*m^2", "g*cm^2",
    "m/s", "cm/s", "km/h", "m/s^2", "cm/s^2", "rad", "deg", "rad/s", "deg/s", "rpm",
    "Hz", "1/s", "N*s/m", "kg/m", "kg/m^3", "g/cm^3",
)  # fmt: skip
"""The units a slider's box takes typed after the number (``30 cm``), those of its
dimension: a short list, so that the page needs no unit parser of its own."""


def typed_units(system, name: str) -> dict[str, float]:
    """{unit: factor to SI} of :data:`TYPED_UNITS` that fit parameter ``name``'s
    dimension (rad and deg for a parameter of dimension 1 given as an angle; none for
    another of dimension 1)."""
    from ..expr import unit

    units = system.units
    dimension = units.of(name) if units is not None else None
    if dimension is None or (dimension.dimensionless and name not in units.angles):
        return {}
    out = {}
    for text in TYPED_UNITS:
        factor, d = unit(text)
        if d == dimension:
            out[text] = float(factor)
    return out


def _slider_rows(params, units: dict[str, str] | None = None) -> str:
    """The sliders' rows; a slider with a unit (``units``) shows it after its box, which
    takes text: a number in that unit, or a number and another unit of its dimension
    (``30 cm``)."""
    units = units or {}
    rows = []
    for i, (name, value, lo, hi) in enumerate(params):
        n = html.escape(name)
        unit = units.get(name)
        kind, step = (
            ('type="text" inputmode="decimal"', "") if unit else ('type="number"', 'step="any" ')
        )
        rows.append(
            f'<tr><td><label for="live-p{i}">{n}</label></td>'
            f'<td><input type="range" id="live-p{i}" name="{n}" data-index="{i}" '
            f'min="{lo!r}" max="{hi!r}" step="any" value="{value!r}"></td>'
            f'<td><input {kind} name="{n}-value" aria-label="{n}" data-index="{i}" '
            f'{step}value="{value!r}"></td>'
            + (f'<td class="live-unit">{html.escape(unit)}</td>' if unit else "")
            + f'<td class="live-bad" id="live-bad{i}"></td></tr>'
        )
    return '<table class="live-sliders">' + "".join(rows) + "</table>"


LIVE_STYLE = """
.live-sliders td { padding: .1rem .5rem; }
.live-sliders input[type=range] { width: 18rem; }
.live-sliders input[type=number], .live-sliders input[type=text] { width: 7rem; }
.live-unit { color: #444; }
.live-bad { color: #a00; font-size: .85rem; }
.live-event { margin: .25rem 0; }
.live-sens { color: #555; font-size: .85rem; margin-left: 1.5rem; }
#live-plot { width: 100%; max-width: 40rem; height: auto; border: 1px solid #ddd; }
#live-plot text { font-size: 11px; fill: #444; }
#live-plot .axis-title, svg.plot .axis-title { font-size: 12px; fill: #222; }
svg.plot { width: 100%; max-width: 40rem; height: auto; border: 1px solid #ddd; }
svg.plot text { font-size: 11px; fill: #444; }
"""


def live_section(sol, equilibria=None, root_id: str = "live") -> tuple[str, str]:
    """(the section's HTML, its script) for the page; a note instead when there is
    nothing to move (no energy shell). The script works inside the element ``root_id``
    (which the caller wraps the HTML in), so that several can share a document (a
    notebook's outputs)."""
    try:
        model = live_model(sol, equilibria)
    except LiveError as exc:
        why = html.escape(str(exc))
        return f'<p class="note" id="live-none">No sliders: {why}.</p>', ""
    note = (
        "The closed forms above, compiled to JavaScript: move a parameter (or type its "
        "value) and the multipliers on the energy shell, the lift-off and slip angles with "
        "their sensitivities and the small-oscillation frequencies follow, in this page, "
        "with no server. The range of each slider is the file's [sliders] entry, or 0.1 to "
        "3 times the file's value; a typed value outside it widens it."
    )
    if model.units:
        note += (
            " Each value is in the SI unit shown beside it; a box also takes another unit "
            "of its kind typed after the number (30 cm, 500 g, 10 deg)."
        )
    skipped = "".join(f'<p class="note">not compiled: {html.escape(s)}</p>' for s in model.skipped)
    body = (
        f'<p class="note">{note}</p>{_slider_rows(model.params, dict(model.units))}'
        '<p><button type="button" id="live-reset">the file\'s values</button></p>'
        '<div id="live-events"></div><div id="live-simulated"></div>'
        '<svg id="live-plot" viewBox="0 0 640 256" role="img" '
        'aria-label="multipliers on the energy shell"></svg>'
        f'<div id="live-modes"></div>{skipped}'
    )
    root = json.dumps(root_id)
    return body, f"{RUNTIME}({model.script}, document.getElementById({root}));\n"


RUNTIME = r"""
(function (LIVE, root) {
  var M = LIVE, N = 4001, inputs = root.querySelectorAll("input");
  function byId(id) { return root.querySelector("#" + id); }
  var P = M.params.map(function (p) { return p.value; });
  var COLORS = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b"];
  function fmt(v) { return isFinite(v) ? Number(v.toPrecision(6)).toString() : String(v); }
  function deg(x) { return (x * 180 / Math.PI).toFixed(2) + "\u00b0"; }
  // with units (issue 46): " N" after a multiplier's value, " m" after a length
  function unit(key) { var u = (M.units || {})[key]; return u ? " " + u : ""; }
  function at(x) {
    return M.coord + " = " + x.toFixed(6) + (M.angle ? " rad (" + deg(x) + ")" : unit(M.coord));
  }
  function bisect(F, a, b) {
    var fa = F(a);
    for (var k = 0; k < 200; k++) {
      var m = 0.5 * (a + b);
      if (m === a || m === b) break;
      var fm = F(m);
      if (fm === 0) return m;
      if ((fm < 0) === (fa < 0)) { a = m; fa = fm; } else { b = m; }
    }
    return 0.5 * (a + b);
  }
  function grid(a, b) {
    var xs = new Array(N);
    for (var i = 0; i < N; i++) xs[i] = a + (b - a) * i / (N - 1);
    return xs;
  }
  function segments() {
    var x0 = M.x0(0, P), v0 = M.v0(0, P);
    var big = P.reduce(function (m, v) { return Math.max(m, Math.abs(v)); }, 1);
    var span = M.angle ? 2 * Math.PI : 100 * (1 + Math.abs(x0) + big);
    var dir;
    if (v0 !== 0) dir = v0 > 0 ? 1 : -1;
    else { var s = M.dK(x0, P); dir = (isFinite(s) && s < -1e-12) ? -1 : 1; }
    var scale = Math.max(v0 * v0, 1e-300);
    function K(x) { return M.K(x, P); }
    function turning(d) {
      var xs = grid(x0, x0 + d * span), ks = xs.map(K), top = 1;
      ks.forEach(function (k) { if (isFinite(k)) top = Math.max(top, Math.abs(k)); });
      var tol = 1e-12 * Math.max(scale, top);
      for (var i = 1; i < N; i++) {
        if (!(ks[i] >= -tol)) {
          return isFinite(ks[i]) ? bisect(K, xs[i - 1], xs[i]) : xs[i - 1];
        }
      }
      return null;
    }
    var end = turning(dir);
    if (end === null) return {x0: x0, segs: [[x0, x0 + dir * span]]};
    var other = turning(-dir);
    return {x0: x0, segs: [[x0, end], [x0, other !== null ? other : x0 - dir * span]]};
  }
  function roots(F, segs) {
    var seen = [];
    segs.forEach(function (s) {
      if (s[0] === s[1]) return;
      var xs = grid(s[0], s[1]), ys = xs.map(F);
      for (var i = 0; i < N - 1; i++) {
        var y0 = ys[i], y1 = ys[i + 1], r = null;
        if (!(isFinite(y0) && isFinite(y1))) continue;
        if (y0 === 0 && i > 0) r = xs[i];
        else if (y0 * y1 < 0) r = bisect(F, xs[i], xs[i + 1]);
        if (r !== null && seen.every(function (q) { return Math.abs(q - r) > 1e-9; })) seen.push(r);
      }
    });
    return seen;
  }
  function sensitivity(Fx, Fp, x) {
    // dx*/dp = -F_p / F_x; a value below rounding (|dx*/dp| |p| < 1e-10 (1 + |x|)) is 0
    return M.params.map(function (p, i) {
      var d = -Fp[i] / Fx;
      if (!isFinite(d) || Fx === 0) return p.name + ": undefined";
      if (Math.abs(d) * Math.abs(P[i]) < 1e-10 * (1 + Math.abs(x))) d = 0;
      return "d" + M.coord + "/d" + p.name + " = " + fmt(d);
    }).join(", ");
  }
  function event(kind, name, when, text, x, sens) {
    var div = document.createElement("div");
    div.className = "live-event";
    div.id = "live-" + kind + "-" + name;
    div.setAttribute("data-when", when);
    if (x !== null) {
      div.setAttribute("data-value", String(x));
      if (M.angle) div.setAttribute("data-degrees", String(x * 180 / Math.PI));
    }
    div.textContent = text;
    if (sens) {
      var s = document.createElement("div");
      s.className = "live-sens";
      s.textContent = "sensitivity: " + sens;
      div.appendChild(s);
    }
    return div;
  }
  function letsGo(name, seg) {
    var L = M.lam[name], x0 = seg.x0, lam0 = L.f(x0, P);
    var scale = 1e-12 * (1 + P.reduce(function (m, v) { return Math.max(m, Math.abs(v)); }, 0));
    var label = name + " (lambda_" + name + ")";
    if (!isFinite(lam0)) {
      return event("lets-go", name, "not determined", label + ": not defined at these values",
        null);
    }
    if (lam0 < -scale) {
      return event("lets-go", name, "at the start", label + " lets go at the start: lambda_" +
        name + " = " + fmt(lam0) + unit("lambda:" + name) + " < 0 at the initial state", null);
    }
    var rs = roots(function (x) { return L.f(x, P); }, seg.segs);
    if (!rs.length) {
      return event("lets-go", name, "never", label + " holds (lambda_" + name + " = " +
        fmt(lam0) + unit("lambda:" + name) + " > 0 at the start) in the whole range the " +
        "motion reaches", null);
    }
    var r = rs[0], Fp = L.dp.map(function (g) { return g(r, P); });
    return event("lets-go", name, "at the roots", label + " holds (lambda_" + name + " = " +
      fmt(lam0) + unit("lambda:" + name) + " > 0 at the start) until it lets go at " + at(r), r,
      sensitivity(L.dx(r, P), Fp, r));
  }
  function slips(fr, seg) {
    var Lf = M.lam[fr.name], Ln = M.lam[fr.normal], x0 = seg.x0, mu = fr.mu(0, P);
    var f0 = Lf.f(x0, P), n0 = Ln.f(x0, P), label = fr.name + " (mu = " + fmt(mu) + ")";
    if (!(n0 > 0)) {
      return event("slips", fr.name, "not determined", label + ": not determined, the normal " +
        "force lambda_" + fr.normal + " = " + fmt(n0) + unit("lambda:" + fr.normal) +
        " is not positive at the start", null);
    }
    if (Math.abs(f0) / n0 > mu * (1 + 1e-12)) {
      return event("slips", fr.name, "at the start", label + " slips at the start: |lambda_" +
        fr.name + "|/lambda_" + fr.normal + " = " + fmt(Math.abs(f0) / n0) + " > mu", null);
    }
    var G = function (x) {
      var n = Ln.f(x, P);
      return n > 0 ? Math.abs(Lf.f(x, P)) - mu * n : NaN;
    };
    var rs = roots(G, seg.segs);
    if (!rs.length) {
      return event("slips", fr.name, "never", label + " sticks in the whole range the motion " +
        "reaches", null);
    }
    var r = rs[0], s = Lf.f(r, P) >= 0 ? 1 : -1, ln = Ln.f(r, P);
    var Fx = s * Lf.dx(r, P) - mu * Ln.dx(r, P);
    var Fp = M.params.map(function (_, i) {
      return s * Lf.dp[i](r, P) - fr.dmu[i](r, P) * ln - mu * Ln.dp[i](r, P);
    });
    return event("slips", fr.name, "at the roots", label + " sticks until it starts to slip at " +
      at(r), r, sensitivity(Fx, Fp, r));
  }
  @TICKS@
  function svg(tag, attrs, text) {
    var e = document.createElementNS("http://www.w3.org/2000/svg", tag);
    for (var k in attrs) e.setAttribute(k, attrs[k]);
    if (text !== undefined) e.textContent = text;
    return e;
  }
  function plot(seg, marks) {
    var el = byId("live-plot");
    while (el.firstChild) el.removeChild(el.firstChild);
    var a = seg.segs[0][0], b = seg.segs[0][1], names = Object.keys(M.lam);
    if (!(isFinite(a) && isFinite(b)) || a === b || !names.length) return;
    var lo = Math.min(a, b), hi = Math.max(a, b), n = 240, xs = [], ymin = 0, ymax = 0;
    for (var i = 0; i <= n; i++) xs.push(lo + (hi - lo) * i / n);
    var ys = names.map(function (k) {
      return xs.map(function (x) {
        var y = M.lam[k].f(x, P);
        if (isFinite(y)) { ymin = Math.min(ymin, y); ymax = Math.max(ymax, y); }
        return y;
      });
    });
    if (ymax === ymin) ymax = ymin + 1;
    var pad = 0.05 * (ymax - ymin);
    ymin -= pad; ymax += pad;
    var L = 70, R = 630, T = 22, B = 212;
    function X(x) { return L + (R - L) * (x - lo) / (hi - lo); }
    function Y(y) { return B - (B - T) * (y - ymin) / (ymax - ymin); }
    el.appendChild(svg("rect", {x: L, y: T, width: R - L, height: B - T, fill: "none",
      stroke: "#999"}));
    // ticks: round values (degrees for an angle), a faint grid line at each
    var k = M.angle ? 180 / Math.PI : 1;
    ticks(lo * k, hi * k, 6, M.angle).forEach(function (v) {
      var px = X(v / k);
      el.appendChild(svg("line", {x1: px, x2: px, y1: T, y2: B, stroke: "#eee",
        "class": "tick"}));
      el.appendChild(svg("text", {x: px, y: B + 14, "text-anchor": "middle"}, fmt(v)));
    });
    ticks(ymin, ymax, 6).forEach(function (v) {
      el.appendChild(svg("line", {x1: L, x2: R, y1: Y(v), y2: Y(v), stroke: "#eee",
        "class": "tick"}));
      el.appendChild(svg("text", {x: L - 5, y: Y(v) + 4, "text-anchor": "end"}, fmt(v)));
    });
    if (ymin < 0 && ymax > 0) {
      el.appendChild(svg("line", {x1: L, x2: R, y1: Y(0), y2: Y(0), stroke: "#999"}));
    }
    marks.forEach(function (m) {
      if (m >= lo && m <= hi) {
        el.appendChild(svg("line", {x1: X(m), x2: X(m), y1: T, y2: B, stroke: "#555",
          "stroke-dasharray": "4 3", "class": "live-mark"}));
      }
    });
    var us = {};
    ys.forEach(function (col, j) {
      var d = "", pen = false;
      col.forEach(function (y, i) {
        if (!isFinite(y)) { pen = false; return; }
        d += (pen ? "L" : "M") + X(xs[i]).toFixed(1) + " " + Y(y).toFixed(1);
        pen = true;
      });
      el.appendChild(svg("path", {d: d, fill: "none", stroke: COLORS[j % COLORS.length],
        "stroke-width": 2, "data-multiplier": names[j]}));
      us[unit("lambda:" + names[j]).trim()] = true;
      var u = unit("lambda:" + names[j]).trim();
      el.appendChild(svg("text", {x: L + 130 * j, y: T - 7,
        fill: COLORS[j % COLORS.length]}, "lambda_" + names[j] + (u ? " [" + u + "]" : "")));
    });
    var yu = Object.keys(us).filter(function (u) { return u; });
    var xu = M.angle ? "deg" : unit(M.coord).trim();
    el.appendChild(svg("text", {x: (L + R) / 2, y: B + 34, "text-anchor": "middle",
      "class": "axis-title"}, M.coord + (xu ? " [" + xu + "]" : "") +
      " (the coordinate along the motion)"));
    el.appendChild(svg("text", {transform: "translate(14 " + (T + B) / 2 + ") rotate(-90)",
      "text-anchor": "middle", "class": "axis-title"}, "multiplier on the energy shell" +
      (yu.length === 1 ? " [" + yu[0] + "]" : "")));
  }
  function modes() {
    var el = byId("live-modes");
    el.textContent = "";
    M.modes.forEach(function (m) {
      var w2 = m.w2(0, P), p = document.createElement("div"), text;
      if (!isFinite(w2)) text = "not defined at these values";
      else if (w2 > 0) text = "omega = " + fmt(Math.sqrt(w2)) + " rad/s (omega^2 = " + fmt(w2) +
        ")";
      else if (w2 < 0) text = "unstable: growth rate " + fmt(Math.sqrt(-w2)) + " 1/s (omega^2 = " +
        fmt(w2) + ")";
      else text = "omega^2 = 0 (marginal)";
      p.className = "live-mode";
      p.textContent = "small oscillations about " + m.at + ": " + text;
      el.appendChild(p);
    });
  }
  function update() {
    var box = byId("live-events");
    box.textContent = "";
    var seg = segments(), marks = [];
    if (!isFinite(seg.x0) || seg.segs.some(function (s) { return !isFinite(s[1]); })) {
      box.textContent = "the initial state is not defined at these values";
    } else {
      M.unilateral.forEach(function (k) { box.appendChild(letsGo(k, seg)); });
      M.friction.forEach(function (fr) { box.appendChild(slips(fr, seg)); });
      box.querySelectorAll("[data-value]").forEach(function (e) {
        marks.push(Number(e.getAttribute("data-value")));
      });
      plot(seg, marks);
    }
    modes();
    var count = Number(root.getAttribute("data-updates") || 0) + 1;
    root.setAttribute("data-updates", String(count));
  }
  function typed(inp, i) {
    // a slider's box with a unit takes "0.3" (in its unit) or "30 cm" (a unit it lists)
    var t = inp.value.trim(), p = M.params[i];
    if (inp.type !== "text") return Number(t === "" ? NaN : t);
    var m = /^([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*)$/.exec(t);
    if (!m) return NaN;
    if (!m[2] || m[2] === p.unit) return Number(m[1]);
    var f = (p.accept || {})[m[2]];
    return f === undefined ? NaN : Number(m[1]) * f;
  }
  function set(i, v, from) {
    var range = root.querySelector('input[type=range][data-index="' + i + '"]');
    var num = root.querySelector('input:not([type=range])[data-index="' + i + '"]');
    var bad = byId("live-bad" + i), p = M.params[i];
    if (!isFinite(v)) {
      bad.textContent = p.unit ? "give a number in " + p.unit + ", or with a unit: " +
        Object.keys(p.accept || {}).join(", ") : "not a number";
      return;
    }
    bad.textContent = "";
    if (v < Number(range.min)) range.min = String(v);
    if (v > Number(range.max)) range.max = String(v);
    if (from !== range) range.value = String(v);
    if (from !== num) num.value = String(v);
    P[i] = v;
    update();
    tellParent();
  }
  // in `lamech serve` the page sits in a frame: the server's page may re-run the
  // simulation at the slider's values and send back its events (numbers and text only)
  function values() {
    var out = {};
    M.params.forEach(function (p, i) { out[p.name] = P[i]; });
    return out;
  }
  function tellParent() {
    if (window.parent === window) return;
    window.parent.postMessage({lamech: "params", params: values()}, "*");
  }
  window.addEventListener("message", function (ev) {
    var d = ev.data, now = values();
    if (window.parent === window || ev.source !== window.parent) return;
    if (!d || d.lamech !== "simulated" || typeof d.text !== "string" || !d.params) return;
    for (var k in now) if (d.params[k] !== now[k]) return;  // stale: the sliders moved on
    var box = byId("live-simulated");
    box.textContent = d.text;
    box.setAttribute("data-state", String(d.state));
  });
  inputs.forEach(function (inp) {
    var i = Number(inp.getAttribute("data-index"));
    inp.addEventListener("input", function () {
      if (inp.type === "number" && inp.value === "") return;
      if (inp.type === "text" && !isFinite(typed(inp, i))) return;  // still being typed
      set(i, inp.type === "text" ? typed(inp, i) : Number(inp.value), inp);
    });
    inp.addEventListener("change", function () {
      set(i, typed(inp, i), inp);
    });
  });
  byId("live-reset").addEventListener("click", function () {
    M.params.forEach(function (p, i) { set(i, p.value, null); });
  });
  update();
})
"""
RUNTIME = RUNTIME.replace("  @TICKS@\n", TICKS_JS.lstrip("\n"), 1)
