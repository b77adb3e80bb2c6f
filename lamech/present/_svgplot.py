"""Small line plots as inline SVG for the report: axis titles with units, ticks with
round values, marks (the report's drive torque against the crank angle).

The ticks are those of :data:`TICKS_JS`, the same rule in the page's script (the
sliders' plot, :mod:`._live`): steps of 1, 2 or 5 times a power of ten, about five.
"""

from __future__ import annotations

import html
import math

import numpy as np

__all__ = ["nice_ticks", "line_plot", "TICKS_JS"]


DEGREE_STEPS = (15, 30, 45, 90, 180, 360)
"""Steps of the ticks of an angle in degrees, beyond 10 degrees."""


def nice_ticks(lo: float, hi: float, count: int = 5, degrees: bool = False) -> list[float]:
    """Round values between ``lo`` and ``hi``: a step of 1, 2 or 5 times a power of ten
    giving about ``count`` of them (of an angle in ``degrees`` beyond 10 degrees, one of
    :data:`DEGREE_STEPS`)."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi <= lo:
        return [lo]
    raw = (hi - lo) / count
    power = 10 ** math.floor(math.log10(raw))
    step = next(m * power for m in (1, 2, 5, 10) if m * power >= raw)
    if degrees and raw > 10:
        step = next((s for s in DEGREE_STEPS if s >= raw), step)
    first = math.ceil(lo / step - 1e-9)
    out = []
    k = first
    while k * step <= hi + 1e-9 * step:
        out.append(round(k * step, 12))
        k += 1
    return out


TICKS_JS = (
    """
  var DEGREE_STEPS = """
    + str(list(DEGREE_STEPS))
    + """;
  function ticks(lo, hi, count, degrees) {
    if (!(isFinite(lo) && isFinite(hi)) || hi <= lo) return [lo];
    var raw = (hi - lo) / count, power = Math.pow(10, Math.floor(Math.log10(raw)));
    var step = [1, 2, 5, 10].map(function (m) { return m * power; })
      .filter(function (s) { return s >= raw; })[0], out = [];
    if (degrees && raw > 10) {
      step = DEGREE_STEPS.filter(function (s) { return s >= raw; }).concat([step])[0];
    }
    for (var k = Math.ceil(lo / step - 1e-9); k * step <= hi + 1e-9 * step; k++) {
      out.push(Number((k * step).toPrecision(12)));
    }
    return out;
  }
"""
)

_W, _H = 640, 280
_L, _R, _T, _B = 70, 625, 22, 225


def _label(v: float) -> str:
    return f"{v:.6g}"


def line_plot(
    x: np.ndarray,
    ys: list[tuple[str, np.ndarray]],
    xlabel: str,
    ylabel: str,
    marks: list[tuple[float, str]] = (),  # type: ignore[assignment]
    plot_id: str = "",
    x_degrees: bool = False,
) -> str:
    """An SVG plot of each (name, y) against ``x``, with ticks and axis titles
    (``xlabel``, ``ylabel``: plain text, escaped here) and ``marks`` (x, label) as
    dashed vertical lines; ``x_degrees``: x is an angle in degrees (ticks every 15, 30,
    45 or 90)."""
    x = np.asarray(x, dtype=float)
    finite = [np.asarray(y, dtype=float) for _, y in ys]
    values = np.concatenate([y[np.isfinite(y)] for y in finite] + [np.zeros(1)])
    y0, y1 = float(values.min()), float(values.max())
    if y1 == y0:
        y1 = y0 + 1.0
    pad = 0.05 * (y1 - y0)
    y0, y1 = y0 - pad, y1 + pad
    x0, x1 = float(np.nanmin(x)), float(np.nanmax(x))
    if x1 == x0:
        x1 = x0 + 1.0

    def X(v: float) -> float:
        return _L + (_R - _L) * (v - x0) / (x1 - x0)

    def Y(v: float) -> float:
        return _B - (_B - _T) * (v - y0) / (y1 - y0)

    ident = f' id="{html.escape(plot_id)}"' if plot_id else ""
    out = [
        f'<svg{ident} class="plot" xmlns="http://www.w3.org/2000/svg" '
        f'viewBox="0 0 {_W} {_H}" role="img" aria-label="{html.escape(ylabel)} against '
        f'{html.escape(xlabel)}">',
        f'<rect x="{_L}" y="{_T}" width="{_R - _L}" height="{_B - _T}" fill="none" stroke="#999"/>',
    ]
    for v in nice_ticks(x0, x1, 6, degrees=x_degrees):
        px = X(v)
        out.append(
            f'<line class="tick" x1="{px:.1f}" x2="{px:.1f}" y1="{_T}" y2="{_B}" '
            f'stroke="#eee"/><text x="{px:.1f}" y="{_B + 15}" text-anchor="middle">'
            f"{_label(v)}</text>"
        )
    for v in nice_ticks(y0, y1, 6):
        py = Y(v)
        out.append(
            f'<line class="tick" x1="{_L}" x2="{_R}" y1="{py:.1f}" y2="{py:.1f}" '
            f'stroke="#eee"/><text x="{_L - 5}" y="{py + 4:.1f}" text-anchor="end">'
            f"{_label(v)}</text>"
        )
    if y0 < 0 < y1:
        out.append(f'<line x1="{_L}" x2="{_R}" y1="{Y(0):.1f}" y2="{Y(0):.1f}" stroke="#999"/>')
    for v, text in marks:
        if x0 <= v <= x1:
            out.append(
                f'<line class="mark" x1="{X(v):.1f}" x2="{X(v):.1f}" y1="{_T}" y2="{_B}" '
                f'stroke="#555" stroke-dasharray="4 3"><title>{html.escape(text)}</title></line>'
                f'<text x="{X(v):.1f}" y="{_T - 6}" text-anchor="middle">{html.escape(text)}</text>'
            )
    colours = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd")
    for j, ((name, _), y) in enumerate(zip(ys, finite)):
        d, pen = [], False
        for xv, yv in zip(x, y):
            if not (np.isfinite(xv) and np.isfinite(yv)):
                pen = False
                continue
            d.append(f"{'L' if pen else 'M'}{X(xv):.1f} {Y(yv):.1f}")
            pen = True
        colour = colours[j % len(colours)]
        out.append(
            f'<path d="{"".join(d)}" fill="none" stroke="{colour}" stroke-width="2" '
            f'data-name="{html.escape(name)}"/>'
        )
        if len(ys) > 1:
            out.append(
                f'<text x="{_L + 120 * j}" y="{_T - 6}" fill="{colour}">{html.escape(name)}</text>'
            )
    out.append(
        f'<text class="axis-title" x="{(_L + _R) / 2:.0f}" y="{_H - 8}" '
        f'text-anchor="middle">{html.escape(xlabel)}</text>'
        f'<text class="axis-title" transform="translate(14 {(_T + _B) / 2:.0f}) rotate(-90)" '
        f'text-anchor="middle">{html.escape(ylabel)}</text></svg>'
    )
    return "".join(out)
