"""Animations in space: what the 3-D view draws is the problem's geometry, checked against
rotations and positions computed here by hand (NumPy), not against lamech's own code."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import lamech
from lamech.present import animate
from lamech.present._animate import Scene

PIL = pytest.importorskip("PIL.Image", reason="Pillow (a matplotlib dependency) missing")

HERE = Path(__file__).parent
TOP = Path(lamech.__file__).parent / "examples" / "heavy_top.toml"


def _turn(axis: str, a: float) -> np.ndarray:
    c, s = np.cos(a), np.sin(a)
    return {
        "x": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]),
        "z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]),
    }[axis]


def _euler_zxz(psi: float, theta: float, phi: float) -> np.ndarray:
    """World from body for body-fixed turns z(psi), x(theta), z(phi)."""
    return _turn("z", psi) @ _turn("x", theta) @ _turn("z", phi)


@pytest.fixture(scope="module")
def top_run():
    system = lamech.load("heavy_top")
    traj = lamech.simulate(system, 0.4, samples=9)
    return system, traj, Scene(traj, system, None, np.arange(len(traj.t)))


def test_top_frame_is_the_euler_rotation(top_run):
    """The frame arrows at every frame run along the columns of R = Rz(psi) Rx(theta)
    Rz(phi) computed by hand; the centre is where the position expression puts it, and the
    body's z axis is the stem from the tip (the origin) to the centre."""
    system, traj, scene = top_run
    p = {s.name: float(v) for s, v in system.parameter_values.items()}
    m, stem, C = p["m"], p["l"], p["C"]
    name, kind, size, pos, _ = scene.bodies[0]
    assert (name, kind) == ("top", "circle")
    assert size == pytest.approx(np.sqrt(2 * C / m))
    assert scene.axis_lengths[0] == pytest.approx(1.3 * size)
    psi, theta, phi = traj.coordinate("psi"), traj.coordinate("theta"), traj.coordinate("phi")
    assert np.ptp(phi) > 1.0  # the spin turns the frame a good deal over the run
    want = stem * np.column_stack(
        (np.sin(psi) * np.sin(theta), -np.cos(psi) * np.sin(theta), np.cos(theta))
    )
    assert np.allclose(pos, want, atol=1e-14)
    tips = scene.frame_tips(0)
    for k in (0, 4, 8):
        R = _euler_zxz(psi[k], theta[k], phi[k])
        for j in range(3):
            assert np.allclose(tips[k, j] - pos[k], scene.axis_lengths[0] * R[:, j], atol=1e-12)
        assert np.allclose(R[:, 2], pos[k] / stem, atol=1e-12)


def test_top_disc_lies_about_its_axle(top_run):
    """The disc's rim: every point at the radius from the centre, at right angles to the
    body z axis (the axle), and the rim goes all the way round."""
    _, traj, scene = top_run
    rim = scene.outline(0)
    _, _, size, pos, _ = scene.bodies[0]
    k = 5
    R = _euler_zxz(*traj.q[k])
    rel = rim[k] - pos[k]
    assert np.allclose(np.linalg.norm(rel, axis=1), size, atol=1e-12)
    assert np.allclose(rel @ R[:, 2], 0.0, atol=1e-12)
    assert np.allclose(rim[k, 0], rim[k, -1])  # closed
    assert np.allclose(rel[0], size * R[:, 0], atol=1e-12)  # starts on the body x axis


def test_view_holds_the_whole_motion(top_run):
    """The 3-D limits enclose every drawn point of every frame (rim, frame arrows,
    scenery) with a margin, and no side of the box is a sliver."""
    _, _, scene = top_run
    x0, x1, y0, y1, z0, z1 = scene.limits()
    lo, hi = np.array([x0, y0, z0]), np.array([x1, y1, z1])
    drawn = [scene.outline(0).reshape(-1, 3), scene.frame_tips(0).reshape(-1, 3)]
    drawn += [pts.reshape(-1, 3) for _, pts, _ in scene.scenery]
    drawn_all = np.concatenate(drawn)
    assert (drawn_all > lo).all() and (drawn_all < hi).all()
    assert [kind for kind, _, _ in scene.scenery] == ["point", "line"]
    assert np.allclose(scene.scenery[0][1], 0.0)  # the tip, at the origin
    sides = hi - lo
    assert sides.min() >= 0.6 * sides.max() - 1e-12


@pytest.mark.slow
def test_rod_lies_along_its_shape_axis(tmp_path):
    """``shape = { rod = "h", axis = "x" }``: the rod's ends are the centre plus and minus
    h/2 along the body x axis; a planar body is given no axis."""
    text = TOP.read_text(encoding="utf-8").replace(
        'shape = { circle = "sqrt(2*C/m)", axis = "z" }', 'shape = { rod = "0.3", axis = "x" }'
    )
    assert 'axis = "x"' in text
    path = tmp_path / "rod_top.toml"
    path.write_text(text, encoding="utf-8")
    system = lamech.load(path)
    traj = lamech.simulate(system, 0.2, samples=5)
    scene = Scene(traj, system, None, np.arange(len(traj.t)))
    ends = scene.outline(0)
    pos = scene.bodies[0][3]
    for k in range(len(traj.t)):
        x_axis = _euler_zxz(*traj.q[k])[:, 0]
        assert np.allclose(ends[k], [pos[k] - 0.15 * x_axis, pos[k] + 0.15 * x_axis])
    assert scene.axis_lengths[0] == pytest.approx(0.6 * 0.3)

    planar = (HERE / "bad" / "valid" / "scenery.toml").read_text(encoding="utf-8")
    line = 'position = ["l*sin(theta)", "-l*cos(theta)"]\n'
    assert line in planar
    bad = tmp_path / "axis_in_plane.toml"
    bad.write_text(
        planar.replace(line, line + 'shape = { rod = "l", axis = "y" }\n'), encoding="utf-8"
    )
    with pytest.raises(lamech.ProblemFileError, match="an axis orients a shape in space"):
        lamech.load(bad)


def test_spherical_pendulum_force_in_space():
    """A point mass in space: no frame, and the string's tension drawn at the bob towards
    the pivot, as long as the multiplier (3 components, not a side view)."""
    system = lamech.load("spherical_pendulum")
    traj = lamech.simulate(system, 0.5, samples=11)
    scene = Scene(traj, system, None, np.arange(len(traj.t)))
    assert scene.space and scene.axis_lengths == [None]
    with pytest.raises(ValueError, match="no frame"):
        scene.frame_tips(0)
    pos = scene.bodies[0][3]
    th, ph = traj.coordinate("theta"), traj.coordinate("phi")
    bob = np.column_stack((np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), -np.cos(th)))
    assert np.allclose(pos, bob, atol=1e-12)
    ((_, at, vec),) = scene.arrows
    tension = traj.multiplier("string")
    assert np.allclose(at, bob, atol=1e-12)
    assert np.allclose(vec, -tension[:, None] * bob, rtol=1e-9, atol=1e-12)
    x0, x1, y0, y1, z0, z1 = scene.limits()
    lo, hi = np.array([x0, y0, z0]), np.array([x1, y1, z1])
    for point in (*bob, np.zeros(3)):  # the bob all along, the pivot
        assert (point > lo).all() and (point < hi).all()


@pytest.mark.slow
def test_cli_writes_the_top_in_3d(tmp_path, capsys):
    """``lamech simulate heavy_top --animate top.gif``: one GIF frame per sample, 6.4 in
    at 100 dpi, and the picture changes as the top turns."""
    from lamech.cli import main

    out = tmp_path / "top.gif"
    code = main(
        ["simulate", "heavy_top", "--t-end", "0.3", "--samples", "5", "--animate", str(out)]
    )
    assert code == 0, capsys.readouterr().err
    assert f"wrote {out}" in capsys.readouterr().out
    with PIL.open(out) as im:
        assert im.n_frames == 5
        assert im.size == (640, 640)
        first = np.asarray(im.convert("RGB"))
        im.seek(4)
        last = np.asarray(im.convert("RGB"))
    assert (first != last).any()


@pytest.mark.slow
def test_html_in_space(top_run, tmp_path):
    system, traj, _ = top_run
    out = animate(traj, system, tmp_path / "top.html", max_frames=4, dpi=30)
    assert out.read_text(encoding="utf-8").count("data:image/jpeg;base64") == 4
