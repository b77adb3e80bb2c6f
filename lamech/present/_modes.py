"""The ``lamech modes`` report: equilibria, stability and normal modes, as text and
LaTeX (the JSON is :meth:`lamech.symbolic.Modes.to_json`)."""

from __future__ import annotations

import math

import sympy as sp

from ..expr import to_text as _expr_text

__all__ = ["modes_text", "modes_latex"]


def _t(expr) -> str:
    try:
        return _expr_text(sp.sympify(expr))
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
    else:
        head = "neutral: eigenvalue 0 (a free direction: no restoring force)"
    shape = ", ".join(f"{k} {v + 0.0:.6g}" for k, v in m.shape.items())  # no "-0"
    return [head, f"  shape: {shape}"]


def modes_text(md) -> str:
    """The readable ``lamech modes`` report of a :class:`~lamech.symbolic.Modes`."""
    title = f"Small oscillations: {md.system.title}"
    lines = [title, "=" * len(title), ""]
    lines.append(
        "independent coordinates: " + (", ".join(md.independent) or "(none)") + "  (at rest)"
    )
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
        lines.append("  at the values: " + ", ".join(f"{k} = {v:.6g}" for k, v in e.values.items()))
        if e.multipliers:
            lines.append(
                "  multipliers at rest: "
                + ", ".join(f"lambda_{k} = {v:.6g}" for k, v in e.multipliers.items())
            )
        if e.note:
            lines.append(f"  note: {e.note}")
        if not e.holds:
            lines.append("  not an equilibrium of the system as written (a contact lets go)")
        if e.stability is None:
            lines.append("  stability: not determined (the linearisation has no numbers here)")
            continue
        lines.append(f"  {e.stability}: {len(e.modes)} mode(s)")
        for m in e.modes:
            first, *rest = _mode_line(m)
            lines.append(f"    - {first}")
            lines += [f"      {r}" for r in rest]
    return "\n".join(lines) + "\n"


def modes_latex(md) -> str:
    """A LaTeX fragment (amsmath ``align*``): each equilibrium and its omega^2."""
    rows = []
    for i, e in enumerate(md.equilibria, 1):
        if not e.exists:
            continue
        for k, v in e.at.items():
            rows.append(rf"{sp.latex(sp.Symbol(k))} &= {sp.latex(v)} && \text{{equilibrium {i}}}")
        for m in e.modes:
            if m.squared is not None:
                label = "oscillation" if m.frequency is not None else "growth: $-\\omega^2$"
                rows.append(rf"\omega^2 &= {sp.latex(m.squared)} && \text{{{label}}}")
    return "\\begin{align*}\n" + " \\\\\n".join(rows) + "\n\\end{align*}\n"
