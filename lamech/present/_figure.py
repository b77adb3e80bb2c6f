"""The report's first picture: the system at its initial state, as an inline SVG.

The geometry is the animation's (:class:`._animate.Scene`, one sample): each body by its
shape, the scenery, the contact points, and the Cartesian force of each constraint with a
``force = {at, along}`` spec as an arrow at its point. A constraint without one is drawn
on the drawn points by virtual work: its generalized force lambda df/dq carried to the
points' positions p(q) (J^T F = lambda df/dq, J = dp/dq; :func:`_carriers`), which is the
force itself for a point in Cartesian coordinates. A file without ``[[bodies]]`` whose
coordinates are Cartesian pairs (x, y; x1, y1; ...) is drawn as those points.

Numbers at the initial state come from the simulation's first sample when there is one,
else from the closed forms at the file's initial state.
"""

from __future__ import annotations

import html
import re
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

__all__ = ["initial_svg", "InitialState", "initial_state"]

_COLOURS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd", "#8c564b", "#e377c2")
_W, _H = 460, 360  # the drawing's size in CSS pixels


@dataclass
class InitialState:
    """One sample, shaped as a :class:`~lamech.numeric.Trajectory`'s arrays (what
    :class:`._animate.Scene` reads): ``t`` (1,), ``q`` and ``qd`` (1, n_coords),
    ``lambdas`` (1, n_constraints), ``forces`` {"constraint:component": (1,)}."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    lambdas: np.ndarray
    forces: dict = field(default_factory=dict)


def _number(expr, values: dict) -> float:
    try:
        v = complex(sp.sympify(sp.sympify(expr).xreplace(values)).evalf())
    except (TypeError, ValueError, AttributeError):
        return float("nan")
    return v.real if abs(v.imag) <= 1e-12 * (1 + abs(v.real)) else float("nan")


def _start_values(system) -> dict:
    """{symbol: number} at the file's initial state: parameters, t = 0, each coordinate
    and its velocity."""
    values = dict(system.parameter_values)
    values[system.t] = sp.Integer(0)
    for c in system.coordinates:
        values[c.symbol] = sp.Float(_number(c.initial, values))
    for c in system.coordinates:
        values[c.velocity] = sp.Float(_number(c.initial_velocity, values))
    return values


def initial_state(sol, traj=None) -> InitialState:
    """The initial state: ``traj``'s first sample, else the file's initial state with the
    multipliers and Cartesian forces of the closed forms there."""
    system = sol.system
    if traj is not None and len(traj.t):
        forces = {k: np.asarray(v)[:1] for k, v in traj.forces.items()}
        return InitialState(traj.t[:1], traj.q[:1], traj.qd[:1], traj.lambdas[:1], forces)
    values = _start_values(system)
    q = np.array([[float(values[c.symbol]) for c in system.coordinates]])
    qd = np.array([[float(values[c.velocity]) for c in system.coordinates]])
    lam = []
    for c in system.constraints:
        x = sol.initial_multipliers.get(c.name)
        if x is None and c.name in sol.multipliers:
            x = _number(sol.multipliers[c.name], values)
        lam.append(float("nan") if x is None else float(x))
    values.update(
        {c.multiplier: sp.Float(v) for c, v in zip(system.constraints, lam) if np.isfinite(v)}
    )
    forces = {
        f"{k}:{d}": np.array([_number(e, values) if e is not None else float("nan")])
        for k, comps in sol.forces.items()
        for d, e in comps.items()
    }
    return InitialState(np.zeros(1), q, qd, np.array([lam]), forces)


def _cartesian_points(system) -> list[tuple[str, list]]:
    """(name, [x, y]) of each Cartesian pair of coordinates (x, y; x1, y1; ...), for a
    file without bodies; in space (x, y, z), x and z."""
    names = {c.name: c.symbol for c in system.coordinates}
    out = []
    for name, sym in names.items():
        m = re.fullmatch(r"x(\w*)", name)
        if not m:
            continue
        tail = m.group(1)
        other = names.get("y" + tail)
        if other is None:
            continue
        up = names.get("z" + tail)
        label = tail if tail[:1].isalpha() else "point" + tail  # x1: point1 (a body's name)
        out.append((label, [sym, up] if up is not None else [sym, other]))
    return out


def _virtual_work_arrows(system, params, state: InitialState, points) -> list:
    """(name, at (2,), F (2,)) for each constraint without a ``force`` spec: lambda df/dq
    carried to the drawn ``points`` ([position exprs] in the plane) by least squares."""
    if not points:
        return []
    q = [c.symbol for c in system.coordinates]
    values = dict(system.parameter_values)
    for p in system.parameters:
        if params and p.name in params:
            values[p.symbol] = float(params[p.name])
    values.update({s: float(v) for s, v in zip(q, state.q[0])})
    values.update({c.velocity: float(v) for c, v in zip(system.coordinates, state.qd[0])})
    values[system.t] = float(state.t[0])
    J = np.array([[_number(sp.diff(e, s), values) for s in q] for p in points for e in p])
    at = np.array([[_number(e, values) for e in p] for p in points])
    out = []
    if not np.isfinite(J).all() or not np.isfinite(at).all():
        return []
    for j, c in enumerate(system.constraints):
        lam = state.lambdas[0, j]
        if c.force is not None or not c.holonomic or not np.isfinite(lam) or lam == 0:
            continue
        grad = np.array([lam * _number(sp.diff(c.expr, s), values) for s in q])
        if not np.isfinite(grad).all():
            continue
        for i, f in _carriers(J, grad):
            out.append((c.name, at[i], f))
    return out


def _carriers(J: np.ndarray, Q: np.ndarray) -> list[tuple[int, np.ndarray]]:
    """(point, force) that do the virtual work ``Q`` (J^T F = Q, J the stacked (2 per
    point) Jacobian of the points' positions): the one point that carries it with the
    least force (a drive pushing a cart carries a pendulum hung from it: the cart), else
    all points together where they carry it exactly; none where they cannot."""
    scale = 1e-9 * (1.0 + float(np.abs(Q).max()))
    best = None
    for i in range(J.shape[0] // 2):
        Ji = J[2 * i : 2 * i + 2]
        F, *_ = np.linalg.lstsq(Ji.T, Q, rcond=None)
        if np.abs(Ji.T @ F - Q).max() <= scale and (
            best is None or np.hypot(*F) < np.hypot(*best[1])
        ):
            best = (i, F)
    if best is not None:
        return [best]
    F, *_ = np.linalg.lstsq(J.T, Q, rcond=None)
    if np.abs(J.T @ F - Q).max() > scale:
        return []
    return [(i, f) for i, f in enumerate(F.reshape(-1, 2)) if np.hypot(*f) > scale]


class _Canvas:
    """World (x, y up) to SVG (pixels, y down), equal scales, fitted to a box."""

    def __init__(self, box: tuple[float, float, float, float]):
        x0, x1, y0, y1 = box
        span = max(x1 - x0, y1 - y0, 1e-9)
        m = 0.08 * span
        x0, x1, y0, y1 = x0 - m, x1 + m, y0 - m, y1 + m
        self.s = min((_W - 20) / (x1 - x0), (_H - 20) / (y1 - y0))
        self.cx, self.cy = 0.5 * (x0 + x1), 0.5 * (y0 + y1)
        self.span = span

    def __call__(self, p) -> tuple[float, float]:
        return (_W / 2 + self.s * (p[0] - self.cx), _H / 2 - self.s * (p[1] - self.cy))


def _f(x: float) -> str:
    return f"{x:.1f}"


def _unit_text(units, name: str, force: bool) -> str:
    if units is None:
        return ""
    d = units.force(name) if force else units.multiplier(name)
    return "" if d is None else " " + d.si()


def _parts(sol, traj, params):
    """What the drawing holds, in the plane (of a scene in space: x and z): the bodies'
    shapes, the scenery, the force arrows (name, at, F) and the contact points; None when
    there is nothing to draw."""
    from ._animate import Scene

    system = sol.system
    state = initial_state(sol, traj)
    bodies = list(system.bodies)
    shown = system
    if not bodies:
        pairs = _cartesian_points(system)
        if not pairs:
            return None
        from ..model import Body

        bodies = [Body(name=n, mass=sp.Integer(1), position=tuple(p)) for n, p in pairs]
        shown = _with_bodies(system, bodies)
    scene = Scene(state, shown, params, np.array([0]))
    space = scene.space
    prims: list = []  # (kind, points, extra)
    for i in range(len(scene.bodies)):
        if space:
            pts = scene.outline(i)[0][:, [0, 2]]
            prims.append(("body", i, pts))
        else:
            prims.append(("body", i, scene.plane_shape(i, 0)))
    scenery = []
    for kind, pts, radii in scene.scenery:
        p = pts[0][:, [0, 2]] if space else pts[0][:, :2]
        scenery.append((kind, p, None if radii is None else abs(float(radii[0]))))
    arrows = []
    for name, at, vec in scene.arrows:
        a, v = at[0], vec[0]
        if space:
            a, v = a[[0, 2]], v[[0, 2]]
        if np.isfinite(a).all() and np.isfinite(v).all():
            arrows.append((name, a[:2], v[:2]))
    points_drawn = [
        [sp.sympify(e) for e in (b.position if len(b.position) == 2 else b.position[::2])]
        for b in bodies
        if b.shape[0].value == "point"
    ]
    arrows += _virtual_work_arrows(shown, params, state, points_drawn)
    contacts = [
        track[0, [0, 2]] if space else track[0, :2]
        for _, track in scene.tracks
        if np.isfinite(track[0]).all()
    ]
    return scene, space, prims, scenery, arrows, contacts


def initial_svg(sol, traj=None, params=None) -> str:
    """The SVG (a string) of ``sol``'s system at its initial state, with its constraint
    forces as arrows; "" when there is nothing to draw."""
    parts = _parts(sol, traj, params)
    if parts is None:
        return ""
    scene, space, prims, scenery, arrows, contacts = parts
    system = sol.system
    # the box: every drawn point
    xy = []
    for _, _i, shape in prims:
        if space:
            xy += list(shape)
        elif shape[0] == "circle":
            c, r = np.array(shape[1]), shape[2]
            xy += [c - r, c + r]
        else:
            xy += [np.array(p) for p in shape[1:]]
    for _kind, p, size in scenery:
        r = size or 0.0
        xy += [row - r for row in p] + [row + r for row in p]
    xy += [a for _, a, _ in arrows] + contacts
    xy = [np.asarray(p, dtype=float) for p in xy if np.isfinite(p).all()]
    if not xy:
        return ""
    origin = not scenery  # nothing fixed drawn: the origin and the axes' directions
    if origin:
        xy.append(np.zeros(2))
    allp = np.array(xy)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    span0 = max(float(np.max(hi - lo)), 1e-9)
    peak = max((float(np.hypot(*v)) for _, _, v in arrows), default=0.0)
    scale = 0.25 * span0 / peak if peak > 0 else 0.0
    for _, a, v in arrows:
        allp = np.vstack([allp, a + scale * v])
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    cv = _Canvas((lo[0], hi[0], lo[1], hi[1]))
    out = [
        f'<svg id="drawing" xmlns="http://www.w3.org/2000/svg" viewBox="0 0 {_W} {_H}" '
        f'width="{_W}" height="{_H}" role="img" '
        f'aria-label="{html.escape(system.title)} at its initial state">',
        '<defs><marker id="arrowhead" viewBox="0 0 10 10" refX="9" refY="5" markerWidth="7" '
        'markerHeight="7" orient="auto-start-reverse"><path d="M0 0L10 5L0 10z" '
        'fill="#d62728"/></marker></defs>',
    ]
    if origin:
        (ox, oy), r = cv((0.0, 0.0)), 0.12 * min(_W, _H)
        out.append(
            f'<g class="origin" stroke="#aaa" stroke-width="1"><title>the origin; x to the '
            f"right, {'z' if space else 'y'} up</title>"
            f'<line x1="{_f(ox)}" y1="{_f(oy)}" x2="{_f(ox + r)}" y2="{_f(oy)}"/>'
            f'<line x1="{_f(ox)}" y1="{_f(oy)}" x2="{_f(ox)}" y2="{_f(oy - r)}"/></g>'
            f'<text x="{_f(ox + r + 3)}" y="{_f(oy + 4)}" font-size="11" fill="#888">x</text>'
            f'<text x="{_f(ox - 3)}" y="{_f(oy - r - 4)}" font-size="11" fill="#888">'
            f"{'z' if space else 'y'}</text>"
        )
    out += _scenery_svg(cv, scenery)
    out += _bodies_svg(cv, scene, prims, space)
    names = [scene.bodies[i][0] for _, i, _ in prims] + [g.name for g in system.scenery]
    out += _lanes_svg(cv, list(zip(names, _extents(prims, scenery, space))))
    for p in contacts:
        x, y = cv(p)
        out.append(
            f'<circle class="contact" cx="{_f(x)}" cy="{_f(y)}" r="3.5" fill="#fff" '
            'stroke="#000" stroke-width="1.5"/>'
        )
    units = system.units
    for name, a, v in arrows:
        (x1, y1), (x2, y2) = cv(a), cv(a + scale * v)
        if np.hypot(x2 - x1, y2 - y1) < 2:
            continue
        size = float(np.hypot(*v))
        label = html.escape(f"{name}: |F| = {size:.4g}{_unit_text(units, name, True)}")
        out.append(
            f'<g class="force" data-constraint="{html.escape(name)}"><title>{label}</title>'
            f'<line x1="{_f(x1)}" y1="{_f(y1)}" x2="{_f(x2)}" y2="{_f(y2)}" stroke="#d62728" '
            'stroke-width="2.5" marker-end="url(#arrowhead)"/>'
            f'<text x="{_f(x2 + 4)}" y="{_f(y2 - 4)}" font-size="12" fill="#d62728">'
            f"{html.escape(name)}</text></g>"
        )
    out.append("</svg>")
    return "".join(out)


def _scenery_svg(cv: _Canvas, scenery: list) -> list[str]:
    """The scenery's elements: fixed circles under the lines, the lines' joints under
    the points."""
    out: list[str] = []
    layer = {"circle": 0, "point": 2}
    for kind, p, size in sorted(scenery, key=lambda g: layer.get(g[0], 1)):
        pts = [cv(x) for x in p]
        if kind == "circle" and size is not None:
            x, y = pts[0]
            out.append(
                f'<circle class="scenery" cx="{_f(x)}" cy="{_f(y)}" r="{_f(size * cv.s)}" '
                'fill="#e0e0e0" stroke="#595959" stroke-width="1.5"/>'
            )
        elif kind == "point":
            for x, y in pts:
                out.append(f'<circle class="scenery" cx="{_f(x)}" cy="{_f(y)}" r="4" fill="#444"/>')
        else:
            d = " ".join(f"{_f(x)},{_f(y)}" for x, y in pts)
            out.append(
                f'<polyline class="scenery" points="{d}" fill="none" stroke="#404040" '
                'stroke-width="2"/>'
            )
            # the joints: each end (a crank's pin shows on a rod lying along it)
            for x, y in (pts[0], pts[-1]):
                out.append(
                    f'<circle class="joint" cx="{_f(x)}" cy="{_f(y)}" r="3" fill="#fff" '
                    'stroke="#404040" stroke-width="1.5"/>'
                )
    return out


def _bodies_svg(cv: _Canvas, scene, prims: list, space: bool) -> list[str]:
    """Each body, by its shape, in a group named after it."""
    out: list[str] = []
    for _, i, shape in prims:
        colour = _COLOURS[i % len(_COLOURS)]
        name = html.escape(scene.bodies[i][0])
        out.append(f'<g class="body" data-body="{name}"><title>{name}</title>')
        if space:
            d = " ".join(f"{_f(x)},{_f(y)}" for x, y in (cv(p) for p in shape))
            if len(shape) == 1:
                x, y = cv(shape[0])
                out.append(f'<circle cx="{_f(x)}" cy="{_f(y)}" r="6" fill="{colour}"/>')
            else:
                out.append(
                    f'<polyline points="{d}" fill="none" stroke="{colour}" stroke-width="3"/>'
                )
        elif shape[0] == "circle":
            (x, y), (ex, ey) = cv(shape[1]), cv(shape[3])
            out.append(
                f'<circle cx="{_f(x)}" cy="{_f(y)}" r="{_f(shape[2] * cv.s)}" fill="none" '
                f'stroke="{colour}" stroke-width="2.5"/>'
                f'<line x1="{_f(x)}" y1="{_f(y)}" x2="{_f(ex)}" y2="{_f(ey)}" '
                f'stroke="{colour}" stroke-width="1.5"/>'
            )
        elif shape[0] == "rod":
            (x1, y1), (x2, y2) = cv(shape[1]), cv(shape[2])
            out.append(
                f'<line x1="{_f(x1)}" y1="{_f(y1)}" x2="{_f(x2)}" y2="{_f(y2)}" '
                f'stroke="{colour}" stroke-width="5" stroke-linecap="round"/>'
            )
        else:
            x, y = cv(shape[1])
            out.append(f'<circle cx="{_f(x)}" cy="{_f(y)}" r="7" fill="{colour}"/>')
        out.append("</g>")
    return out


def _extents(prims: list, scenery: list, space: bool) -> list[list]:
    """The world points that place each body (in ``prims``' order) then each piece of
    scenery: a point, a rod's ends, a line's points; a circle of some size gives its
    centre and two opposite rims (so it is never "on one line")."""
    out = []
    for _, _i, shape in prims:
        if space:
            out.append(list(shape))
        elif shape[0] == "circle":
            c, r = np.array(shape[1], dtype=float), float(shape[2])
            out.append([c, c - r, c + np.array([r, -r])])
        else:
            out.append([np.array(p, dtype=float) for p in shape[1:]])
    for _kind, p, size in scenery:
        pts = [np.asarray(x, dtype=float) for x in p]
        r = size or 0.0
        out.append(pts + ([pts[0] - r, pts[0] + np.array([r, -r])] if r else []))
    return out


_LANE, _CHAR, _GAP = 22.0, 6.5, 6.0  # px between lanes, per character of a label, apart


def _lanes_svg(cv: _Canvas, elements: list[tuple[str, list]]) -> list[str]:
    """Where every body and piece of scenery lies on one straight line and two links
    overlap there (the slider-crank at phi = 0: the rod over the guide), each element
    (name, world points) is named in a lane beside the line (:func:`_label_svg`); lanes
    alternate above and below, a name taking the nearest lane where it overlaps no other.
    Nothing when the drawing has breadth of its own or its links only meet end to end (a
    pendulum hanging straight): the joints tell them apart."""
    line = _on_one_line(cv, elements)
    if line is None:
        return []
    base, u, items = line
    lanes: dict[int, list[tuple[float, float]]] = {}
    out: list[str] = []
    for a, b, name in sorted(items):
        reach = abs(_CHAR * len(name) * u[0]) + abs(12 * u[1])  # the label along the line
        mid = 0.5 * (a + b)
        span = (min(a, mid - reach / 2), max(b, mid + reach / 2))
        k = next(
            k
            for k in (j * sign for j in range(1, 100) for sign in (1, -1))
            if all(span[1] + _GAP <= lo or hi + _GAP <= span[0] for lo, hi in lanes.get(k, []))
        )
        lanes.setdefault(k, []).append(span)
        out += _label_svg(base, u, k, (a, b), name)
    return out


def _on_one_line(cv: _Canvas, elements: list[tuple[str, list]]):
    """(base, u, [(a, b, name)]): the screen point and unit direction (left to right, or
    top down) of the line every element lies on and each element's extent along it in
    pixels from ``base``; None when they are not on one line or no two links overlap."""
    placed = [
        (name, [np.asarray(p, dtype=float) for p in pts if np.isfinite(p).all()])
        for name, pts in elements
    ]
    placed = [(name, pts) for name, pts in placed if pts]
    allp = np.array([p for _, pts in placed for p in pts]).reshape(-1, 2)
    if len(placed) < 2 or len(allp) < 2:
        return None
    centre = allp.mean(axis=0)
    _, sv, vt = np.linalg.svd(allp - centre)
    if sv[0] <= 0 or sv[1] > 0.02 * sv[0]:
        return None
    base, tip = np.array(cv(centre)), np.array(cv(centre + vt[0]))
    u = (tip - base) / np.hypot(*(tip - base))
    if u[0] < 0 or (abs(u[0]) < 1e-9 and u[1] < 0):
        u = -u
    items = []
    for name, pts in placed:
        s = [float(np.dot(np.array(cv(p)) - base, u)) for p in pts]
        items.append((min(s), max(s), name))
    links = [(a, b) for a, b, _ in items if b - a > 1]
    if not any(
        min(b1, b2) - max(a1, a2) > 2 for i, (a1, b1) in enumerate(links) for a2, b2 in links[:i]
    ):
        return None
    return base, u, items


def _label_svg(base, u, k: int, extent: tuple[float, float], name: str) -> list[str]:
    """The label of one element in lane ``k`` (above the line for k > 0, below for k <
    0, on the screen): a thin line over its extent (a link), dashed leaders from its ends
    back to the line, its name at the middle, kept inside the drawing."""
    a, b = extent
    n = np.array([u[1], -u[0]])  # the normal on the screen: up (or right)
    off = _LANE * k
    width = _CHAR * len(name)
    tip = base + 0.5 * (a + b) * u + (off + (4 if k > 0 else -13)) * n
    tx = min(max(tip[0], width / 2 + 2), _W - width / 2 - 2)
    ty = min(max(tip[1], 12), _H - 2)
    shown = html.escape(name)
    out = [f'<g class="label" data-name="{shown}"><title>{shown}</title>']
    if b - a > 1:
        (x1, y1), (x2, y2) = base + a * u + off * n, base + b * u + off * n
        out.append(
            f'<line x1="{_f(x1)}" y1="{_f(y1)}" x2="{_f(x2)}" y2="{_f(y2)}" stroke="#777" '
            'stroke-width="1.5"/>'
        )
    for s in sorted({a, b}):
        (x1, y1), (x2, y2) = base + s * u, base + s * u + off * n
        out.append(
            f'<line x1="{_f(x1)}" y1="{_f(y1)}" x2="{_f(x2)}" y2="{_f(y2)}" stroke="#999" '
            'stroke-width="1" stroke-dasharray="2 2"/>'
        )
    out.append(
        f'<text x="{_f(tx)}" y="{_f(ty)}" font-size="11" fill="#333" text-anchor="middle">'
        f"{shown}</text></g>"
    )
    return out


class _WithBodies:
    """``system`` as the drawing sees it, with ``bodies`` of its own (the points its
    Cartesian coordinates place): nothing else of it changes."""

    def __init__(self, system, bodies):
        self._system = system
        self.bodies = tuple(bodies)

    def __getattr__(self, name: str):
        return getattr(self._system, name)


def _with_bodies(system, bodies):
    return _WithBodies(system, bodies)
