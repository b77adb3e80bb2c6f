"""Generated problems for tests and benchmarks (not user input: built from numbers)."""

from __future__ import annotations

import math

__all__ = ["chain_toml"]


def chain_toml(n: int, angle_deg: float = 30.0, keep: bool = False) -> str:
    """TOML for the planar ``n``-link pendulum chain in maximal coordinates: point masses
    m at (x_i, y_i), links of length l, one length constraint per link, all links
    ``angle_deg`` from the vertical at rest. ``keep`` keeps every coordinate (no
    elimination)."""
    a = math.radians(angle_deg)
    lines = [
        f'title = "{n}-link pendulum chain (maximal coordinates)"',
        "[parameters]",
        "m = 1.0",
        "g = 9.81",
        "l = 1.0",
        "[coordinates]",
    ]
    for i in range(1, n + 1):
        x0, y0 = i * math.sin(a), -i * math.cos(a)
        k = ", keep = true" if keep else ""
        lines.append(f'x{i} = {{ initial = "{x0!r}*l", velocity = 0{k} }}')
        lines.append(f'y{i} = {{ initial = "{y0!r}*l", velocity = 0{k} }}')
    T = " + ".join(f"x{i}'^2 + y{i}'^2" for i in range(1, n + 1))
    V = " + ".join(f"y{i}" for i in range(1, n + 1))
    lines += ["[lagrangian]", f'T = "m/2*({T})"', f'V = "m*g*({V})"']
    for i in range(1, n + 1):
        px, py = (f"x{i - 1}", f"y{i - 1}") if i > 1 else ("0", "0")
        lines += [
            "[[constraints]]",
            f'name = "link{i}"',
            f'f = "(x{i} - {px})^2 + (y{i} - {py})^2 - l^2"',
        ]
    return "\n".join(lines) + "\n"
