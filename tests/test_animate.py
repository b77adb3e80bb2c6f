"""Animations: written in each format, with the frames and markup they should have."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

import lamech
from lamech.present import animate
from lamech.present._animate import Scene

PIL = pytest.importorskip("PIL.Image", reason="Pillow (a matplotlib dependency) missing")


@pytest.fixture(scope="module")
def cylinder_run():
    system = lamech.load("cylinder")
    return system, lamech.simulate(system, 2.7, initial={"theta1": 0.05}, samples=61)


@pytest.mark.slow
def test_gif_has_frames(tmp_path, cylinder_run):
    system, traj = cylinder_run
    out = animate(traj, system, tmp_path / "c.gif", max_frames=12, dpi=40)
    with PIL.open(out) as im:
        assert im.n_frames == 12
        assert im.size == (256, 256)  # 6.4 in at 40 dpi


def test_scene_follows_the_bodies_and_forces(cylinder_run):
    """What is drawn is the problem's geometry: the wheel's centre at r (sin θ, cos θ),
    the normal force along the contact normal with the magnitude of λ_contact."""
    system, traj = cylinder_run
    frames = np.arange(len(traj.t))
    scene = Scene(traj, system, None, frames)
    name, kind, size, pos, angle = scene.bodies[0]
    assert (name, kind, size) == ("wheel", "circle", 0.5)
    r, th = traj.coordinate("r"), traj.coordinate("theta1")
    assert np.allclose(pos, np.column_stack((r * np.sin(th), r * np.cos(th))), atol=1e-12)
    assert np.allclose(angle, -traj.coordinate("theta2"))
    (_, at, normal), _ = scene.arrows
    on = np.isfinite(traj.multiplier("contact"))
    assert np.allclose(
        np.linalg.norm(normal[on], axis=1), np.abs(traj.multiplier("contact")[on]), rtol=1e-9
    )
    assert np.allclose(at[on], np.column_stack((np.sin(th), np.cos(th)))[on], atol=1e-12)
    # after lift-off there is no contact force and no contact track
    assert not np.isfinite(normal[~on]).any()


@pytest.mark.slow
def test_html_is_self_contained(tmp_path):
    system = lamech.load("pendulum")
    traj = lamech.simulate(system, 1.0, samples=6)
    out = animate(traj, system, tmp_path / "p.html", max_frames=6, dpi=30)
    text = out.read_text()
    # JPEG frames (the page stays small), no web font from a CDN: it works offline
    assert "<script" in text and text.count("data:image/jpeg;base64") == 6


def test_bad_extension_and_missing_ffmpeg(tmp_path, cylinder_run, monkeypatch):
    system, traj = cylinder_run
    with pytest.raises(ValueError, match=r"\.gif, \.mp4, \.html"):
        animate(traj, system, tmp_path / "c.avi")
    monkeypatch.setattr(shutil, "which", lambda name: None)
    with pytest.raises(ValueError, match="ffmpeg"):
        animate(traj, system, tmp_path / "c.mp4")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.slow
def test_cli_animate(tmp_path, capsys):
    from lamech.cli import main

    out = tmp_path / "pend.gif"
    code = main(["simulate", "pendulum", "--t-end", "0.5", "--samples", "5", "--animate", str(out)])
    assert code == 0, capsys.readouterr().err
    assert f"wrote {out}" in capsys.readouterr().out
    with PIL.open(out) as im:
        assert im.n_frames == 5
    assert (
        main(["simulate", "pendulum", "--t-end", "0.5", "--animate", str(tmp_path / "x.bmp")]) == 2
    )
    assert "use a name ending in" in capsys.readouterr().err


@pytest.mark.slow
def test_pendulum_gif_frames_sampled_evenly(tmp_path):
    """max_frames thins the samples evenly; the bob drawn at (l sin θ, -l cos θ)."""
    system = lamech.load("pendulum")
    traj = lamech.simulate(system, 1.0, samples=101)
    out = animate(traj, system, tmp_path / "p.gif", max_frames=6, dpi=30)
    with PIL.open(out) as im:
        assert im.n_frames == 6
        assert im.size == (192, 192)  # 6.4 in at 30 dpi
    frames = np.unique(np.linspace(0, 100, 6).round().astype(int))
    scene = Scene(traj, system, None, frames)
    assert np.allclose(np.diff(scene.t), 0.2)
    pos = scene.bodies[0][3]
    th = traj.coordinate("theta")[frames]
    assert np.allclose(pos, np.column_stack((np.sin(th), -np.cos(th))), atol=1e-12)


def test_scenery_is_drawn_where_the_file_puts_it(tmp_path):
    """``[[scenery]]``: the pivot stays at the origin, the string runs from it to the bob
    at every frame (it moves with the coordinates), the ring has radius l and the view
    holds all of it."""
    from pathlib import Path

    system = lamech.load(Path(__file__).parent / "bad" / "valid" / "scenery.toml")
    assert [(g.name, g.kind.value, len(g.points)) for g in system.scenery] == [
        ("pivot", "point", 1),
        ("string", "line", 2),
        ("ring", "circle", 1),
    ]
    traj = lamech.simulate(system, 1.0, samples=21)
    scene = Scene(traj, system, None, np.arange(len(traj.t)))
    (pk, pivot, _), (sk, string, _), (ck, centre, radius) = scene.scenery
    assert (pk, sk, ck) == ("point", "line", "circle")
    assert np.allclose(pivot, 0.0) and np.allclose(centre, 0.0)
    bob = scene.bodies[0][3]
    assert np.allclose(string[:, 0], 0.0) and np.allclose(string[:, 1], bob, atol=1e-12)
    assert np.allclose(radius, 1.0)
    x0, x1, y0, y1 = scene.limits()
    assert x0 < -1 and x1 > 1 and y0 < -1 and y1 > 1  # the whole ring, not just the swing
    out = animate(traj, system, tmp_path / "s.gif", max_frames=4, dpi=30)
    assert out.stat().st_size > 0


@pytest.mark.slow
def test_every_example_declares_its_fixed_geometry():
    """Each bundled example with bodies draws something besides them (a pivot, a floor,
    the fixed cylinder): a body moving in empty space is not what the file describes."""
    for name in lamech.example_names():
        system = lamech.load(name)
        if system.bodies:
            assert system.scenery, f"example {name!r} declares no [[scenery]]"


@pytest.mark.slow
def test_the_html_animation_works_offline_and_is_small(tmp_path):
    """It loaded an icon font from a CDN (blank buttons offline) and was 13.5 MB for
    1.5 s of motion with 300 frames whatever the length."""
    from lamech.present import animate

    system = lamech.load("cylinder")
    traj = lamech.simulate(system, 1.5, initial={"theta1": 0.3}, samples=301)
    page = animate(traj, system, tmp_path / "m.html").read_text(encoding="utf-8")
    assert "http://" not in page and "https://" not in page
    assert 'class="fa ' not in page
    assert (tmp_path / "m.html").stat().st_size < 2_000_000
    assert page.count("data:image/jpeg") == 2 * 20 + 1  # 2 s of play at 20 frames/s
    gif = animate(traj, system, tmp_path / "m.gif", duration=1.0, fps=10)
    from PIL import Image

    with Image.open(gif) as im:
        assert im.n_frames == 11
