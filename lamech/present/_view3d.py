"""The 3-D view of an animation: bodies in space drawn with matplotlib's mplot3d.

z is up, the three axes have equal scales (orthographic projection, box proportional to
the limits), and the view is fitted once to the whole motion (:meth:`Scene.limits`).
Each body is drawn by its shape (a point, a rod along its shape axis, a translucent disc
about it), each body that turns with its frame (arrows x, y, z in red, green, blue), each
centre with its trail and the trail's shadow on the floor of the box (it tells height
from depth), the scenery in 3-D (a circle lies in the horizontal plane through its
centre), the contact tracks and the constraint forces as arrows.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

from ._plain import drawn

if TYPE_CHECKING:  # the annotation only: _animate imports this module to draw in space
    from ._animate import Scene

__all__ = ["space_view", "FRAME_COLOURS"]

FRAME_COLOURS = ("tab:red", "tab:green", "tab:blue")  # a body's axes x, y, z
# the colour cycle without the frame's colours: a body is not mistaken for an axis
_SKIP = {"#1f77b4", "#2ca02c", "#d62728"}


def _arrow_class() -> type:
    """A FancyArrowPatch between two points in space, projected at each draw."""
    from matplotlib.patches import FancyArrowPatch
    from mpl_toolkits.mplot3d import proj3d

    class Arrow3D(FancyArrowPatch):
        def __init__(self, **kwargs: Any) -> None:
            super().__init__((0, 0), (0, 0), **kwargs)
            self.ends = np.zeros((2, 3))

        def do_3d_projection(self, renderer: Any = None) -> float:
            axes: Any = self.axes  # an Axes3D: its projection matrix M
            xs, ys, zs = proj3d.proj_transform(*self.ends.T, axes.M)
            self.set_positions((xs[0], ys[0]), (xs[1], ys[1]))
            return float(np.min(zs))

    return Arrow3D


def space_view(fig, scene: Scene, heading: str) -> Callable[[int], None]:
    """Draw the scene in space into ``fig``: returns what places everything at frame k."""
    import matplotlib
    from matplotlib.colors import to_hex, to_rgba
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    Arrow3D = _arrow_class()
    ax = fig.add_axes((0.0, 0.02, 1.0, 0.86), projection="3d", computed_zorder=False)
    x0, x1, y0, y1, z0, z1 = scene.limits()
    ax.set_proj_type("ortho")
    ax.view_init(elev=22, azim=-58)
    fig.suptitle(drawn(heading), y=0.9, va="top", fontsize=10)
    for axis, label in zip((ax.xaxis, ax.yaxis, ax.zaxis), "xyz"):
        axis.set_label_text(label)
        axis.set_tick_params(labelsize=7)
    span = max(x1 - x0, y1 - y0, z1 - z0)
    floor = z0

    def segment(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return points[:, 0], points[:, 1], points[:, 2]

    def arrow(colour: str, lw: float, scale: float) -> Any:
        art = Arrow3D(
            arrowstyle="-|>", mutation_scale=scale, color=colour, lw=lw, zorder=5, visible=False
        )
        ax.add_patch(art)
        return art

    scenery: list[tuple[str, Any, np.ndarray, np.ndarray | None]] = []
    ring = np.linspace(0.0, 2 * np.pi, 65)
    for kind, pts, radius in scene.scenery:
        if kind == "circle":
            disc = Poly3DCollection([np.zeros((3, 3))], facecolor="0.88", edgecolor="0.35")
            disc.set_linewidth(1.5)
            ax.add_collection3d(disc)
            scenery.append((kind, disc, pts, radius))
        else:
            style = {"marker": "o", "ms": 6, "ls": "none"} if kind == "point" else {"lw": 1.5}
            (art,) = ax.plot([], [], [], color="0.25", zorder=2.5, **style)
            scenery.append((kind, art, pts, None))
    for _name, track in scene.tracks:
        ax.plot(*segment(track), color="0.55", lw=3, alpha=0.6, zorder=1)
    cycle = matplotlib.rcParams["axes.prop_cycle"].by_key()["color"]
    colours = [c for c in cycle if to_hex(c) not in _SKIP] or list(cycle)
    bodies: list[tuple[str, Any, Any, Any, list[tuple[Any, Any]]]] = []
    for i, (_name, kind, _size, _pos, _angle) in enumerate(scene.bodies):
        colour = colours[i % len(colours)]
        (shadow,) = ax.plot([], [], [], color="0.6", lw=1, alpha=0.6, zorder=1)
        (trail,) = ax.plot([], [], [], color=colour, lw=1, alpha=0.6, zorder=2)
        main: Any
        if kind == "circle":
            main = Poly3DCollection(
                [np.zeros((3, 3))], facecolor=to_rgba(colour, 0.3), edgecolor=colour
            )
            main.set_linewidth(2)
            main.set_zorder(3)
            ax.add_collection3d(main)
        elif kind == "rod":
            (main,) = ax.plot([], [], [], color=colour, lw=4, solid_capstyle="round", zorder=3)
        else:
            (main,) = ax.plot([], [], [], "o", color=colour, ms=9, zorder=3)
        axes = []
        if scene.axis_lengths[i] is not None:
            for c, name in zip(FRAME_COLOURS, "xyz"):
                label = ax.text(0, 0, 0, name, color=c, fontsize=8, zorder=6)
                axes.append((arrow(c, 1.8, 10), label))
        bodies.append((kind, main, trail, shadow, axes))
    peak = max(
        (np.nanmax(np.linalg.norm(v, axis=1)) for _, _, v in scene.arrows if np.isfinite(v).any()),
        default=0.0,
    )
    scale = 0.15 * span / peak if peak > 0 else 0.0
    forces = [(arrow("tab:red", 2, 14), at, vec) for _name, at, vec in scene.arrows]
    # limits last: the artists added above leave them alone
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_zlim(z0, z1)
    ax.set_box_aspect((x1 - x0, y1 - y0, z1 - z0), zoom=0.95)  # equal scales
    ax.set_autoscale_on(False)
    outlines = [scene.outline(i) for i in range(len(bodies))]
    tips = [scene.frame_tips(i) if axes else None for i, (*_, axes) in enumerate(bodies)]

    def place(k: int) -> None:
        for kind, art, pts, radius in scenery:
            if kind == "circle":
                assert radius is not None  # a circle has one
                c, r = pts[k, 0], abs(radius[k])
                rim = np.column_stack(
                    (c[0] + r * np.cos(ring), c[1] + r * np.sin(ring), np.full(len(ring), c[2]))
                )
                art.set_verts([rim])
            else:
                art.set_data_3d(*segment(pts[k]))
        for i, (kind, main, trail, shadow, axes) in enumerate(bodies):
            pos = scene.bodies[i][3]
            trail.set_data_3d(*segment(pos[: k + 1]))
            shadow.set_data_3d(pos[: k + 1, 0], pos[: k + 1, 1], np.full(k + 1, floor))
            shape = outlines[i][k]
            if kind == "circle":
                main.set_verts([shape])
            else:
                main.set_data_3d(*segment(shape))
            ends = tips[i]
            if ends is not None:
                for (art, label), tip in zip(axes, ends[k]):
                    art.ends = np.array([pos[k], tip])
                    art.set_visible(True)
                    label.set_position_3d(pos[k] + 1.12 * (tip - pos[k]))
        for art, at, vec in forces:
            v = vec[k] * scale
            visible = bool(
                np.isfinite(v).all()
                and np.isfinite(at[k]).all()
                and np.linalg.norm(v) > 1e-3 * span
            )
            art.set_visible(visible)
            if visible:
                art.ends = np.array([at[k], at[k] + v])

    return place
