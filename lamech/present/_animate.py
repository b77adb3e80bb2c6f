"""Animations of a :class:`~lamech.numeric.Trajectory` (matplotlib).

Everything drawn comes from the problem file, for any problem: each body by its
``shape`` (a circle with a radius line that turns with ``angle``, a rod along ``angle``,
a point), a trail of each body's centre, the Cartesian force of every active constraint
that names a point (``force = { at, along }``) as an arrow there, the track of each
contact point while the contact holds (the part of the fixed surface the motion
touches), the problem's ``[[scenery]]`` (fixed cylinders, pivots, walls, strings and
rods between bodies: points, lines and circles that may move with the coordinates), the
time, and each event (lift-off, impact, slip, ...) flashed as it happens.
The view is fitted once to the whole motion. Bodies in space (3-component positions) are
drawn in a 3-D view (z up, equal scales; :mod:`._view3d`): a rod along its body's shape
axis, a circle as a disc about it, each turning body with its frame (x, y, z arrows),
trails with their shadows on the floor, the scenery and the forces in 3-D.

Writers: ``.gif`` (Pillow), ``.mp4`` (ffmpeg, when it is on PATH), ``.html`` (one
self-contained page, matplotlib's ``to_jshtml``).
"""

from __future__ import annotations

import shutil
from collections.abc import Callable
from pathlib import Path
from typing import cast

import numpy as np
import sympy as sp

from ..outputs import atomic_output, write_output
from ._plain import drawn

__all__ = ["animate", "Scene", "FORMATS"]

FORMATS = (".gif", ".mp4", ".html")
_EVENT_COLOURS = {
    "lift-off": "tab:red",
    "contact": "tab:green",
    "impact": "tab:purple",
    "slip": "tab:orange",
    "stick": "tab:blue",
}


def _lambdify(system, params: dict | None, exprs):
    """A numeric function f(t, q) of ``exprs`` with the parameter values substituted."""
    values = dict(system.parameter_values)
    for p in system.parameters:
        if params and p.name in params:
            values[p.symbol] = float(params[p.name])
    q = [c.symbol for c in system.coordinates]
    body = [sp.sympify(e).xreplace(values) for e in exprs]
    return sp.lambdify((system.t, q), body, modules="numpy")


def _series(fn, t: np.ndarray, q: np.ndarray) -> np.ndarray:
    """fn evaluated at every sample: shape (N, k)."""
    out = [
        np.broadcast_to(np.asarray(fn(ti, qi), dtype=float), (len(fn(ti, qi)),))
        for ti, qi in zip(t, q)
    ]
    return np.array(out, dtype=float)


def _plane(points: np.ndarray) -> np.ndarray:
    """(N, 2) plane coordinates: x, y as given; of a point in space, x and z."""
    return points[:, [0, 2]] if points.shape[1] == 3 else points[:, :2]


def _space(points: np.ndarray) -> np.ndarray:
    """(N, 3) coordinates in space: x, y, z as given; a point given in the plane at z = 0."""
    if points.shape[1] == 3:
        return points
    return np.column_stack((points[:, :2], np.zeros(len(points))))


_RIM = 48  # segments of a circle drawn in space
_CORNERS = ((1, 0), (-1, 0), (0, 1), (0, -1))


class Scene:
    """Numbers for every frame, computed once: body poses, force arrows, contact tracks.

    In the plane (``space`` False) points are (x, y). In space (bodies with 3-component
    positions) they are (x, y, z), and ``rotations[i]`` holds body i's axes in the world
    at every frame (shape (n_frames, 3, 3), columns x, y, z; None for a body that does not
    turn), from its ``rotation`` or ``orientation``; ``shape_axes[i]`` is the body axis
    (0, 1, 2) its rod lies along or its circle turns about, and ``axis_lengths[i]`` how
    long its frame's arrows are drawn. :meth:`outline` and :meth:`frame_tips` are the
    points drawn."""

    def __init__(self, traj, system, params, frames: np.ndarray):
        from ..model._kinematics import body_rotation

        self.traj = traj
        self.frames = frames
        t, q = traj.t[frames], traj.q[frames]
        self.t = t
        self.space = bool(system.bodies) and len(system.bodies[0].position) == 3
        view = _space if self.space else _plane
        self.bodies = []
        self.rotations: list[np.ndarray | None] = []
        self.shape_axes: list[int] = []
        for b in system.bodies:
            pos = view(_series(_lambdify(system, params, b.position), t, q))
            angle = (
                _series(_lambdify(system, params, [b.angle]), t, q)[:, 0]
                if b.angle is not None and not self.space
                else None
            )
            R = body_rotation(b) if self.space else None
            turns = (
                _series(_lambdify(system, params, list(R)), t, q).reshape(-1, 3, 3)
                if R is not None
                else None
            )
            kind, size = b.shape
            size = (
                float(np.asarray(_lambdify(system, params, [size])(t[0], q[0]))[0])
                if size is not None and kind in ("circle", "rod")
                else 0.0
            )
            if kind == "rod" and angle is None and turns is None:
                kind = "point"  # a rod needs an angle (or a rotation) to be drawn as one
            self.bodies.append((b.name, kind, size, pos, angle))
            self.rotations.append(turns)
            self.shape_axes.append("xyz".index(b.shape_axis) if self.space else 2)
        self.arrows = []  # (name, points (F,dim), vectors (F,dim))
        self.tracks = []  # (name, points (F,dim)) while engaged
        dim = 3 if self.space else 2
        for j, c in enumerate(system.constraints):
            spec = c.force
            if spec is None:
                continue
            at = view(_series(_lambdify(system, params, spec.at), t, q))
            lam = traj.lambdas[frames, j]
            engaged = np.isfinite(lam)
            if c.unilateral:
                track = np.where(engaged[:, None], at, np.nan)
                self.tracks.append((c.name, track))
            if not spec.along:
                continue
            dirs = [view(_series(_lambdify(system, params, d), t, q)) for _, d in spec.along]
            comps = np.column_stack(
                [
                    traj.forces.get(f"{c.name}:{name}", np.full(len(traj.t), np.nan))[frames]
                    for name, _ in spec.along
                ]
            )
            vec = np.full((len(frames), dim), np.nan)
            for k in range(len(frames)):
                D = np.array([d[k] / (np.linalg.norm(d[k]) or 1.0) for d in dirs])
                ck = comps[k]
                ok = np.isfinite(ck)
                if ok.any() and engaged[k]:
                    # components are F·d/|d|: F is the least-squares solution over them
                    vec[k], *_ = np.linalg.lstsq(D[ok], ck[ok], rcond=None)
            self.arrows.append((c.name, at, vec))
        # (kind, points (F, k, 2), radius (F,) or None): scenery at every frame
        self.scenery = []
        for g in system.scenery:
            pts = np.stack(
                [view(_series(_lambdify(system, params, p), t, q)) for p in g.points], axis=1
            )
            radius = (
                _series(_lambdify(system, params, [g.radius]), t, q)[:, 0]
                if g.radius is not None
                else None
            )
            self.scenery.append((g.kind.value, pts, radius))
        self.axis_lengths: list[float | None] = [
            self._axis_length(i) if R is not None else None for i, R in enumerate(self.rotations)
        ]

    # ----- in the plane --------------------------------------------------------------------
    def plane_shape(self, i: int, k: int) -> tuple:
        """What is drawn of body i at frame k in the plane: ``("circle", centre, radius,
        spoke end)`` (the spoke turns with ``angle``), ``("rod", end, end)`` along its
        angle, or ``("point", centre)``; points as (x, y). The animation and the report's
        drawing of the initial state (:mod:`._figure`) both draw these."""
        _, kind, size, pos, angle = self.bodies[i]
        x, y = pos[k][:2]
        if kind == "circle":
            a = angle[k] if angle is not None else 0.0
            return ("circle", (x, y), size, (x + size * np.cos(a), y + size * np.sin(a)))
        if kind == "rod" and angle is not None:  # a rod has an angle
            dx, dy = 0.5 * size * np.cos(angle[k]), 0.5 * size * np.sin(angle[k])
            return ("rod", (x - dx, y - dy), (x + dx, y + dy))
        return ("point", (x, y))

    def arrow_scale(self, span: float) -> float:
        """Length per unit of force: the largest force of the whole motion drawn 0.15 of
        the view's ``span`` long (0 when no force is known)."""
        peak = max(
            (
                np.nanmax(np.linalg.norm(v, axis=1))
                for _, _, v in self.arrows
                if np.isfinite(v).any()
            ),
            default=0.0,
        )
        return 0.15 * span / peak if peak > 0 else 0.0

    # ----- in space ----------------------------------------------------------------------
    def orientation(self, i: int) -> np.ndarray:
        """(n_frames, 3, 3): body i's axes in the world (columns), the world's own for a
        body that does not turn."""
        R = self.rotations[i]
        return R if R is not None else np.broadcast_to(np.eye(3), (len(self.t), 3, 3))

    def outline(self, i: int) -> np.ndarray:
        """(n_frames, P, 3): the points drawn for body i in space at every frame: its
        centre (a point), the two ends of a rod along its shape axis, or the closed rim of
        a circle about that axis (in the plane of the other two body axes)."""
        _, kind, size, pos, _ = self.bodies[i]
        R, a = self.orientation(i), self.shape_axes[i]
        if kind == "rod":
            half = 0.5 * size * R[:, :, a]
            return np.stack((pos - half, pos + half), axis=1)
        if kind == "circle":
            s = np.linspace(0.0, 2 * np.pi, _RIM + 1)[None, :, None]
            u, v = R[:, None, :, (a + 1) % 3], R[:, None, :, (a + 2) % 3]
            return pos[:, None, :] + size * (np.cos(s) * u + np.sin(s) * v)
        return pos[:, None, :]

    def frame_tips(self, i: int) -> np.ndarray:
        """(n_frames, 3, 3): the tips of body i's frame arrows (x, y, z), each
        ``axis_lengths[i]`` from its centre along its axis."""
        length = self.axis_lengths[i]
        if length is None:
            raise ValueError(f"body `{self.bodies[i][0]}` does not turn: it has no frame")
        pos = self.bodies[i][3]
        return pos[:, None, :] + length * np.swapaxes(self.orientation(i), 1, 2)

    def _reach(self) -> float:
        """The size of the motion: the largest extent of the centres and the scenery."""
        pts = [b[3] for b in self.bodies] + [p.reshape(-1, p.shape[-1]) for _, p, _ in self.scenery]
        allp = np.concatenate(pts)
        if not np.isfinite(allp).any():
            return 0.0
        return float(np.max(np.nanmax(allp, axis=0) - np.nanmin(allp, axis=0)))

    def _axis_length(self, i: int) -> float:
        """A frame's arrows reach past the body's rim (a circle) or along half a rod, or
        a quarter of the motion's size for a point (1 when nothing moves)."""
        _, kind, size, _, _ = self.bodies[i]
        if kind == "circle" and size > 0:
            return 1.3 * size
        if kind == "rod" and size > 0:
            return 0.6 * size
        reach = self._reach()
        return 0.25 * reach if reach > 1e-9 else 0.5

    def _limits_space(self) -> tuple[float, ...]:
        pts = [self.outline(i).reshape(-1, 3) for i in range(len(self.bodies))]
        pts += [self.frame_tips(i).reshape(-1, 3) for i, L in enumerate(self.axis_lengths) if L]
        for kind, p, radius in self.scenery:
            p = p.reshape(-1, 3)
            if kind == "circle" and radius is not None:  # in the horizontal plane
                r = np.abs(radius)
                pts += [p + np.column_stack((sx * r, sy * r, 0 * r)) for sx, sy in _CORNERS]
            else:
                pts.append(p)
        pts += [track for _, track in self.tracks]
        allp = np.concatenate(pts)
        lo, hi = np.nanmin(allp, axis=0), np.nanmax(allp, axis=0)
        span = max(float(np.max(hi - lo)), 1e-9)
        m = (0.18 if self.arrows else 0.08) * span
        lo, hi = lo - m, hi + m
        wide = 0.6 * float(np.max(hi - lo))  # no sliver of a box
        out: list[float] = []
        for a, b in zip(lo, hi):
            if b - a < wide:
                c = 0.5 * (a + b)
                a, b = c - wide / 2, c + wide / 2
            out += [float(a), float(b)]
        return tuple(out)

    def limits(self) -> tuple[float, ...]:
        """The view, fitted once to the whole motion: (x0, x1, y0, y1) in the plane,
        (x0, x1, y0, y1, z0, z1) in space (drawn with equal scales on all axes)."""
        if self.space:
            return self._limits_space()
        xs, ys = [], []
        for _, kind, size, pos, _ in self.bodies:
            pad = size if kind == "circle" else size / 2 if kind == "rod" else 0.0
            xs += [np.nanmin(pos[:, 0]) - pad, np.nanmax(pos[:, 0]) + pad]
            ys += [np.nanmin(pos[:, 1]) - pad, np.nanmax(pos[:, 1]) + pad]
        for _, pts, radius in self.scenery:
            pad = np.abs(radius)[:, None] if radius is not None else 0.0
            xs += [np.nanmin(pts[:, :, 0] - pad), np.nanmax(pts[:, :, 0] + pad)]
            ys += [np.nanmin(pts[:, :, 1] - pad), np.nanmax(pts[:, :, 1] + pad)]
        for _, track in self.tracks:
            if np.isfinite(track).any():
                xs += [np.nanmin(track[:, 0]), np.nanmax(track[:, 0])]
                ys += [np.nanmin(track[:, 1]), np.nanmax(track[:, 1])]
        if not xs:
            return -1.0, 1.0, -1.0, 1.0
        x0, x1, y0, y1 = min(xs), max(xs), min(ys), max(ys)
        span = max(x1 - x0, y1 - y0, 1e-9)
        # room for the force arrows (drawn up to 0.15 of the span long) at the edges
        m = (0.18 if self.arrows else 0.12) * span
        x0, x1, y0, y1 = x0 - m, x1 + m, y0 - m, y1 + m
        # no sliver of a view: each side at least 0.6 of the other (the Atwood machine)
        wide = 0.6 * max(x1 - x0, y1 - y0)
        if x1 - x0 < wide:
            c = 0.5 * (x0 + x1)
            x0, x1 = c - wide / 2, c + wide / 2
        if y1 - y0 < wide:
            c = 0.5 * (y0 + y1)
            y0, y1 = c - wide / 2, c + wide / 2
        return x0, x1, y0, y1


def playing_time(t_span: float, duration: float | None = None) -> float:
    """How long an animation of ``t_span`` simulated seconds plays: ``duration`` when
    given, else real time clamped to 2..20 s (a 1000-period run is not shown in real
    time, a 0.1 s impact is slowed down to be seen)."""
    if duration is not None:
        if not (duration > 0 and np.isfinite(duration)):
            raise ValueError(
                f"the animation's duration must be a positive number of seconds (got {duration})"
            )
        return float(duration)
    return float(min(max(t_span, 2.0), 20.0))


def animate(
    traj,
    system,
    path: str | Path,
    *,
    params: dict | None = None,
    fps: int = 20,
    duration: float | None = None,
    max_frames: int = 600,
    dpi: int = 100,
) -> Path:
    """Write an animation of ``traj`` (a run of ``system``) to ``path``.

    ``params`` are the parameter overrides the run used (sizes and positions depend on
    them). The animation plays for ``duration`` seconds (default: real time, clamped to
    2..20 s) at ``fps`` frames a second, frames evenly spaced in simulated
    time (at most ``max_frames``, and no more than the trajectory's samples); the picture
    says the time scale (e.g. "0.5x real time"). ``.html`` is one self-contained page
    that works offline (JPEG frames; the player's icons are plain characters, not a web
    font). Raises ValueError for an extension other than .gif, .mp4, .html, or .mp4
    without ffmpeg. The heading is the trajectory's title (``traj.title``; another with
    ``dataclasses.replace(traj, title=...)``), else the system's.
    """
    import matplotlib
    from matplotlib import animation
    from matplotlib.figure import Figure

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in FORMATS:
        raise ValueError(
            f"cannot write an animation as {path.name!r}: use a name ending in {', '.join(FORMATS)}"
        )
    if suffix == ".mp4" and shutil.which("ffmpeg") is None:
        raise ValueError(
            "writing .mp4 needs ffmpeg on PATH (e.g. apt install ffmpeg); or write .gif or .html"
        )
    if not system.bodies:
        raise ValueError(
            "nothing to draw: the problem declares no [[bodies]] (add them "
            "with position and shape to animate it)"
        )
    if len(traj.t) < 2:
        raise ValueError("the trajectory has fewer than 2 samples: nothing to animate")
    if not (isinstance(fps, (int, float)) and 1 <= fps <= 120):
        raise ValueError(f"fps must be between 1 and 120 (got {fps})")
    t_span = float(traj.t[-1] - traj.t[0])
    play = playing_time(t_span, duration)
    count = int(min(len(traj.t), max(2, max_frames), max(2, round(play * fps) + 1)))
    frames = np.unique(np.linspace(0, len(traj.t) - 1, count).round().astype(int))
    rate = max(1.0, (len(frames) - 1) / play)  # frames a second: they fill the playing time
    # matplotlib's stubs type ``fps`` as int; its writers and to_jshtml take a float.
    fps_arg = cast(int, rate)
    speed = t_span / play
    scene = Scene(traj, system, params, frames)

    fig = Figure(figsize=(6.4, 6.4), dpi=dpi)  # no pyplot: the caller's backend stays
    heading = getattr(traj, "title", "") or system.title
    if scene.space:
        from ._view3d import space_view

        place = space_view(fig, scene, heading)
    else:
        place = _plane_view(fig, scene, heading)
    # the clock and the event flash under the title, in the figure (a narrow view, the
    # Atwood machine's, has no room for them inside the axes)
    clock = fig.text(0.03, 0.955, "", va="top", fontsize=10)
    flash = fig.text(0.97, 0.955, "", va="top", ha="right", fontsize=10, fontweight="bold")
    events = [(e.t, e.kind, e.constraint) for e in traj.events if not e.initial]
    hold = 0.06 * (scene.t[-1] - scene.t[0])

    def draw(k: int):
        place(k)
        tk = scene.t[k]
        clock.set_text(f"t = {tk:.3f} s   ({speed:.3g}x real time)")
        recent = [e for e in events if e[0] <= tk < e[0] + hold]
        if recent:
            te, kind, con = recent[-1]
            flash.set_text(drawn(f"{kind} ({con})" if con else kind))
            flash.set_color(_EVENT_COLOURS.get(kind, "black"))
        else:
            flash.set_text("")
        return []

    anim = animation.FuncAnimation(fig, draw, frames=len(frames), interval=1000 / rate, blit=False)
    if suffix in (".gif", ".mp4"):  # a temporary file renamed when complete
        writer = animation.PillowWriter if suffix == ".gif" else animation.FFMpegWriter
        with atomic_output(path, FORMATS, "`path=`") as tmp:
            anim.save(str(tmp), writer=writer(fps=fps_arg), dpi=dpi)
    else:
        with matplotlib.rc_context(
            {"animation.frame_format": "jpeg", "animation.embed_limit": 200.0}
        ):
            page = anim.to_jshtml(fps=fps_arg, default_mode="once")
        write_output(path, offline_page(page), FORMATS, "`path=`")
    return path


def _plane_view(fig, scene: Scene, heading: str) -> Callable[[int], None]:
    """Draw the planar scene into ``fig``: returns what places everything at frame k."""
    import matplotlib
    from matplotlib.lines import Line2D
    from matplotlib.patches import Circle, FancyArrowPatch

    ax = fig.subplots()
    x0, x1, y0, y1 = scene.limits()
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.grid(True, alpha=0.25)
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_title(drawn(heading), fontsize=10)
    span = max(x1 - x0, y1 - y0)

    scenery: list[tuple[str, Circle | Line2D, np.ndarray, np.ndarray | None]] = []
    for kind, pts, radius in scene.scenery:
        if kind == "circle":
            assert radius is not None  # a circle has one
            disc = Circle(
                tuple(pts[0, 0]), abs(radius[0]), facecolor="0.88", edgecolor="0.35", lw=1.5
            )
            ax.add_patch(disc)
            scenery.append((kind, disc, pts, radius))
        else:
            style = {"marker": "o", "ms": 6, "ls": "none"} if kind == "point" else {"lw": 1.5}
            (art,) = ax.plot([], [], color="0.25", zorder=2.5, **style)
            scenery.append((kind, art, pts, None))
    for _name, track in scene.tracks:
        ax.plot(track[:, 0], track[:, 1], color="0.55", lw=3, alpha=0.6, zorder=1)
    colours = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    # (kind, main artist: a Circle for "circle" else a Line2D, the circle's spoke, trail)
    artists: list[tuple[str, Circle | Line2D, Line2D | None, Line2D]] = []
    for i, (_name, kind, size, pos, _angle) in enumerate(scene.bodies):
        colour = colours[i % len(colours)]
        (trail,) = ax.plot([], [], color=colour, lw=1, alpha=0.5, zorder=2)
        if kind == "circle":
            patch = Circle((pos[0, 0], pos[0, 1]), size, fill=False, lw=2, color=colour, zorder=3)
            ax.add_patch(patch)
            (spoke,) = ax.plot([], [], color=colour, lw=1.5, zorder=3)
            artists.append(("circle", patch, spoke, trail))
        elif kind == "rod":
            (line,) = ax.plot([], [], color=colour, lw=4, solid_capstyle="round", zorder=3)
            artists.append(("rod", line, None, trail))
        else:
            (dot,) = ax.plot([], [], "o", color=colour, ms=9, zorder=3)
            artists.append(("point", dot, None, trail))
    scale = scene.arrow_scale(span)
    quivers = []
    for _name, at, vec in scene.arrows:
        arrow = FancyArrowPatch(
            (0, 0),
            (0, 0),
            arrowstyle="-|>",
            mutation_scale=14,
            color="tab:red",
            lw=2,
            zorder=4,
            visible=False,
        )
        ax.add_patch(arrow)
        quivers.append((arrow, at, vec))

    def place(k: int) -> None:
        for _kind, art, pts, radius in scenery:
            if isinstance(art, Circle):
                assert radius is not None
                art.center = tuple(pts[k, 0])
                art.set_radius(abs(radius[k]))
            else:
                art.set_data(pts[k, :, 0], pts[k, :, 1])
        for i, (kind, main, spoke, trail) in enumerate(artists):
            pos = scene.bodies[i][3]
            trail.set_data(pos[: k + 1, 0], pos[: k + 1, 1])
            shape = scene.plane_shape(i, k)
            if kind == "circle":
                assert isinstance(main, Circle) and spoke is not None
                _, centre, _, end = shape
                main.center = centre
                spoke.set_data([centre[0], end[0]], [centre[1], end[1]])
            else:
                assert isinstance(main, Line2D)
                ends = shape[1:]
                main.set_data([p[0] for p in ends], [p[1] for p in ends])
        for arrow, at, vec in quivers:
            v = vec[k] * scale
            visible = bool(
                np.isfinite(v).all() and np.isfinite(at[k]).all() and np.hypot(*v) > 1e-3 * span
            )
            arrow.set_visible(visible)
            if visible:
                arrow.set_positions(tuple(at[k]), tuple(at[k] + v))

    return place


# matplotlib's player draws its buttons with Font Awesome loaded from a CDN: offline they
# are blank. Plain characters instead (the page then needs nothing from the network).
_ICONS = {
    "fa-minus": "&minus;",
    "fa-fast-backward": "&#9198;",
    "fa-step-backward": "&#9664;|",
    "fa-play fa-flip-horizontal": "&#9664;",
    "fa-pause": "&#10074;&#10074;",
    "fa-play": "&#9654;",
    "fa-step-forward": "|&#9654;",
    "fa-fast-forward": "&#9197;",
    "fa-plus": "+",
}


def offline_page(page: str) -> str:
    """An HTML page from ``to_jshtml`` with no external resource (see ``_ICONS``)."""
    import re

    page = re.sub(r'<link rel="stylesheet"\s*href="https?://[^"]*font-awesome[^"]*">', "", page)
    for cls, char in sorted(_ICONS.items(), key=lambda kv: -len(kv[0])):
        page = page.replace(f'<i class="fa {cls}"></i>', f"<span>{char}</span>")
    return page
