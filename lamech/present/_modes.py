"""The ``lamech modes`` report: equilibria, stability and normal modes, as text and
LaTeX (the JSON is :meth:`lamech.symbolic.Modes.to_json`)."""

from __future__ import annotations

import math

import sympy as sp

from ..expr import latex
from ..expr import to_text as _expr_text

__all__ = ["modes_text", "modes_latex"]


def _t(expr) -> str:
    expr = sp.sympify(expr)
    if isinstance(expr, sp.Float):  # a root found numerically: its 12 digits, not 17
        return f"{float(expr):.12g}"
    try:
        return _expr_text(expr)
    except (ValueError, TypeError):
        return str(expr)


def _mode_line(m) -> list[str]:
    if m.frequency is not None:
        period = 2 * math.pi / m.frequency
        head = f"oscillates: omega = {m.frequency:.6g} rad/s (period {period:.6g} s)"
        if m.growth is not None:
            head += f", growing at {m.growth:.6g} /s"
        if m.squared is not None:
            head += f"; omega^2 = {_t(m.squared)}"
    elif m.growth is not None:
        head = f"grows: rate {m.growth:.6g} /s (e-folding time {1 / m.growth:.6g} s)"
        if m.squared is not None:
            head += f"; rate^2 = {_t(-m.squared)}"
    elif isinstance(m, _Neutral):
        head = f"neutral: eigenvalue 0, {m.count} times (free directions: no restoring force)"
        return [head] + [f"  direction: {s}" for s in m.shapes]
    else:
        head = "neutral: eigenvalue 0 (a free direction: no restoring force)"
    shape = ", ".join(
        f"{k} {v + 0.0:.6g}"  # + 0.0: no "-0"
        + (f" (phase {m.phases[k]:.4g} deg)" if m.phases and k in m.phases else "")
        for k, v in m.shape.items()
    )
    return [head, f"  shape: {shape}"]


def _with_unit(name: str, x: float, units: dict[str, str]) -> str:
    """``x = 0.5``; with units ``x = 0.5 m``, ``theta = 0.5236 rad (30°)``."""
    unit = units.get(name)
    text = f"{name} = {x:.6g}"
    if unit == "rad":
        return f"{text} rad ({math.degrees(x):.4g}°)"
    return f"{text} {unit}" if unit else text


def modes_text(md) -> str:
    """The readable ``lamech modes`` report of a :class:`~lamech.symbolic.Modes`; where
    the file gives units, each value with its unit (an angle in degrees too)."""
    units = md.units
    title = f"Small oscillations: {md.system.title}"
    lines = [title, "=" * len(title), ""]
    lines.append(
        "independent coordinates: " + (", ".join(md.independent) or "(none)") + "  (at rest)"
    )
    if md.frame:
        lines.append(f"relative equilibria: {md.frame}")
    if md.free:
        lines.append(f"free: {md.free}")
    if md.reason:
        lines += ["", f"no equilibria given: {md.reason}"]
    for i, e in enumerate(md.equilibria, 1):
        where = ", ".join(f"{k} = {_t(v)}" for k, v in e.at.items())
        lines += ["", f"Equilibrium {i}: {where}"]
        if e.condition:
            lines.append(f"  exists while {e.condition}")
        if not e.exists:
            lines.append(f"  not at these parameter values ({e.note})")
            continue
        lines.append(
            "  at the values: " + ", ".join(_with_unit(k, v, units) for k, v in e.values.items())
        )
        if e.multipliers:
            lines.append(
                (
                    "  multipliers there: "
                    if any(k.endswith("'") for k in e.at)
                    else "  multipliers at rest: "
                )
                + ", ".join(
                    _with_unit(f"lambda_{k}", v, {f"lambda_{k}": units.get(f"lambda:{k}", "")})
                    for k, v in e.multipliers.items()
                )
            )
        if e.note:
            lines.append(f"  note: {e.note}")
        if not e.holds:
            lines.append("  not an equilibrium of the system as written (a contact lets go)")
        if e.stability is None:
            lines.append(
                "  stability: not determined: these coordinates are singular here (the "
                "mass matrix loses rank, as at the pole of spherical coordinates); to "
                "linearise, write the problem in coordinates regular at this point"
            )
            continue
        if not e.modes and e.linear is not None and not e.linear.state:
            lines.append("  locked: the constraints leave no motion there (no modes)")
            continue
        lines.append(f"  {e.stability}: {len(e.modes)} mode(s)")
        for label, m in _merged(e.modes):
            first, *rest = _mode_line(m)
            lines.append(f"    {label}: {first}")
            lines += [f"      {r}" for r in rest]
        if e.check:
            lines.append(f"  check: {e.check}")
        if e.linear is not None and e.linear.state:  # (a system locked there has none)
            lines += _linear_lines(e)
    return "\n".join(lines) + "\n"


def _merged(modes) -> list[tuple[str, object]]:
    """The modes with their numbers ("mode 2"), the neutral ones (eigenvalue 0, repeated
    for every free direction and its drift) as one entry ("modes 1-5") whose shape lists
    the free directions."""
    neutral = [i for i, m in enumerate(modes) if m.frequency is None and m.growth is None]
    if len(neutral) < 2 or neutral != list(range(neutral[0], neutral[-1] + 1)):
        return [(f"mode {i}", m) for i, m in enumerate(modes, 1)]
    shapes: list[str] = []
    for i in neutral:
        text = ", ".join(f"{k} {v + 0.0:.6g}" for k, v in modes[i].shape.items())
        if text not in shapes:
            shapes.append(text)
    out = [(f"mode {i}", m) for i, m in enumerate(modes[: neutral[0]], 1)]
    out.append((f"modes {neutral[0] + 1}-{neutral[-1] + 1}", _Neutral(len(neutral), shapes)))
    out += [(f"mode {i}", m) for i, m in enumerate(modes[neutral[-1] + 1 :], neutral[-1] + 2)]
    return out


class _Neutral:
    frequency = growth = None

    def __init__(self, count: int, shapes: list[str]):
        self.count, self.shapes = count, shapes


def _combination(coefficients, state) -> str:
    """sum c_i x_i as text, zero terms left out ("0" when all are)."""
    parts = []
    for c, x in zip(coefficients, state):
        if abs(c) < 1e-12:
            continue
        sign = "-" if c < 0 else "+"
        mag = "" if abs(abs(c) - 1) < 1e-12 else f"{abs(c):.6g}*"
        parts.append(f"{sign} {mag}d{x}")
    if not parts:
        return "0"
    text = " ".join(parts)
    return text[2:] if text.startswith("+ ") else "-" + text[2:]


def _linear_lines(e) -> list[str]:
    """The linearised equations, one per state entry, and the multipliers to first order."""
    lin = e.linear
    lines = [f"  linearised (dx: the change from here), in {', '.join(lin.state)}:"]
    width = max(len(x) for x in lin.state) + 1
    for x, row in zip(lin.state, lin.A):
        lines.append(f"    d/dt d{x}{' ' * (width - len(x))}= {_combination(row, lin.state)}")
    for name, row in lin.multipliers.items():
        base = e.multipliers.get(name, 0.0)
        change = _combination(row, lin.state)
        if change == "0":
            text = f"{base:.6g}"
        elif abs(base) < 1e-12:
            text = change
        elif change.startswith("-"):
            text = f"{base:.6g} - {change[1:]}"
        else:
            text = f"{base:.6g} + {change}"
        lines.append(f"    lambda_{name} = {text}")
    return lines


def modes_latex(md) -> str:
    """A LaTeX fragment (amsmath ``align*``): each equilibrium and its omega^2."""
    rows = []
    for i, e in enumerate(md.equilibria, 1):
        if not e.exists:
            continue
        for k, v in e.at.items():
            rows.append(rf"{sp.latex(sp.Symbol(k))} &= {latex(v)} && \text{{equilibrium {i}}}")
        for m in e.modes:
            if m.squared is not None:
                label = "oscillation" if m.frequency is not None else "growth: $-\\omega^2$"
                rows.append(rf"\omega^2 &= {latex(m.squared)} && \text{{{label}}}")
    return "\\begin{align*}\n" + " \\\\\n".join(rows) + "\n\\end{align*}\n"
