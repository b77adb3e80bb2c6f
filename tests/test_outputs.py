"""Issue 29, item 4: every output (simulate --out/--plot/--animate, report -o, sweep
--out/--plot) goes to a regular file only, by a temporary file renamed when complete,
in the format its suffix names, with the ordinary file mode."""

from __future__ import annotations

import os
import signal
import stat
import subprocess
import sys
from pathlib import Path

import pytest

from lamech.cli import main
from lamech.outputs import OutputError, atomic_output, check_output

FAST = ["--t-end", "0.2", "--samples", "11"]


@pytest.fixture
def umask_022():
    old = os.umask(0o022)
    yield
    os.umask(old)


def _not_regular(tmp_path: Path) -> dict[str, Path]:
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    target = tmp_path / "precious.csv"
    target.write_text("keep me\n")
    link = tmp_path / "link.csv"
    link.symlink_to(target)
    folder = tmp_path / "folder.csv"
    folder.mkdir()
    # a device node of its own (the null device's numbers), never /dev's: a writer that
    # replaces what is at the path would replace only this one
    device = tmp_path / "device.csv"
    try:
        os.mknod(device, 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    except (PermissionError, AttributeError):
        device = None  # type: ignore[assignment]
    return {
        "a FIFO": fifo,
        "a symbolic link": link,
        "a directory": folder,
        "a character device": device,
    }


@pytest.mark.parametrize("what", ["a FIFO", "a symbolic link", "a directory", "a character device"])
def test_simulate_out_refuses_what_is_not_a_regular_file(tmp_path, capsys, what):
    path = _not_regular(tmp_path)[what]
    if path is None:
        pytest.skip("making a device node needs root")
    before = path.lstat()
    assert main(["simulate", "pendulum", *FAST, "--out", str(path)]) == 2
    err = capsys.readouterr().err
    assert f"is {what}" in err and "Traceback" not in err
    after = path.lstat()
    assert stat.S_IFMT(after.st_mode) == stat.S_IFMT(before.st_mode)
    assert (tmp_path / "precious.csv").read_text() == "keep me\n"
    if what == "a character device":  # refused before any work: no file anywhere
        assert not list(tmp_path.glob(".*part*"))


@pytest.mark.parametrize(
    "flag, name",
    [("--plot", "p.png"), ("--animate", "a.gif")],
)
def test_plots_and_animations_refuse_a_symlink(tmp_path, capsys, flag, name):
    real = tmp_path / "real.bin"
    real.write_bytes(b"x")
    (tmp_path / name).symlink_to(real)
    assert main(["simulate", "pendulum", *FAST, flag, str(tmp_path / name)]) == 2
    assert "is a symbolic link" in capsys.readouterr().err
    assert real.read_bytes() == b"x" and (tmp_path / name).is_symlink()


def test_the_format_follows_the_suffix(tmp_path, capsys):
    assert main(["simulate", "pendulum", *FAST, "--out", str(tmp_path / "x.parquet")]) == 2
    err = capsys.readouterr().err
    assert "the format follows the suffix" in err and ".csv" in err
    assert not (tmp_path / "x.parquet").exists()
    assert main(["report", "pendulum", "--no-simulate", "-o", str(tmp_path / "r.pdf")]) == 2
    assert "the format follows the suffix" in capsys.readouterr().err


@pytest.mark.slow
def test_outputs_get_the_ordinary_mode_and_no_temporary_is_left(tmp_path, umask_022, capsys):
    out, plot = tmp_path / "t.csv", tmp_path / "t.png"
    assert main(["simulate", "pendulum", *FAST, "--out", str(out), "--plot", str(plot)]) == 0
    report = tmp_path / "r.html"
    assert main(["report", "pendulum", "--no-simulate", "-o", str(report)]) == 0
    for p in (out, plot, report):
        assert stat.S_IMODE(p.stat().st_mode) == 0o644, p
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.html", "t.csv", "t.png"]


def test_out_dash_is_standard_output(capsys):
    assert main(["simulate", "pendulum", *FAST, "--out", "-"]) == 0
    out, err = capsys.readouterr()
    assert out.splitlines()[0].startswith("t,") and len(out.splitlines()) == 12
    assert "status" in err  # the summary goes beside, to stderr


def test_sweep_out_refuses_a_symlink_and_a_fifo(tmp_path, capsys):
    paths = _not_regular(tmp_path)
    for what in ("a symbolic link", "a FIFO"):
        code = main(
            [
                "sweep",
                "pendulum",
                "--param",
                "l=1,2",
                "--measure",
                "final:theta",
                "--t-end",
                "0.1",
                "--out",
                str(paths[what]),
            ]
        )
        assert code == 2 and f"is {what}" in capsys.readouterr().err
    assert (tmp_path / "precious.csv").read_text() == "keep me\n"


def test_an_interrupted_write_leaves_the_old_file_and_no_temporary(tmp_path):
    target = tmp_path / "a.gif"
    target.write_bytes(b"old")
    with pytest.raises(KeyboardInterrupt):
        with atomic_output(target) as tmp:
            tmp.write_bytes(b"half")
            raise KeyboardInterrupt
    assert target.read_bytes() == b"old" and os.listdir(tmp_path) == ["a.gif"]
    with pytest.raises(OutputError, match="is a directory"):
        check_output(tmp_path, [""])


# ``python -m lamech`` (runpy, as ``-m`` runs it) with Pillow's save held until the test's
# signal: matplotlib's GIF writer keeps the frames in memory and writes the file only at
# the end, so a test that waited for the file's first bytes raced the encoder (a fast
# machine finished the file before the signal came)
HELD_IN_SAVE = """
import runpy, sys, time
from PIL import Image

save = Image.Image.save

def held(self, *args, **kwargs):
    print("saving", file=sys.stderr, flush=True)
    time.sleep(120)  # until the signal
    return save(self, *args, **kwargs)

Image.Image.save = held
sys.argv = ["lamech", *sys.argv[1:]]
runpy.run_module("lamech", run_name="__main__", alter_sys=True)
"""


@pytest.mark.slow
@pytest.mark.shared_cache
def test_sigterm_during_an_animation_leaves_no_short_gif(tmp_path):
    gif = tmp_path / "run.gif"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-c",
            HELD_IN_SAVE,
            "simulate",
            "double_pendulum",
            "--t-end",
            "5",
            "--animate",
            str(gif),
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        for line in proc.stderr:  # lamech's own lines, then the save's
            if line == "saving\n":
                break
        assert proc.poll() is None, "the animation finished before it could be stopped"
        proc.send_signal(signal.SIGTERM)  # while the GIF is being written
        proc.wait(30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode != 0
    assert not gif.exists() and list(tmp_path.iterdir()) == []
