"""Bad problem files: each gives a clear ProblemFileError, executes nothing, and returns fast.

Every ``tests/bad/NN-name.toml`` has one thing wrong and starts with header comments:

``# expect: <text>``  (one or more) text the message must contain, case-insensitive;
``# reject: <text>``  text it must not contain (a misleading follow-on error);
``# line: <n>``       the 1-based line the message must name, as ``:<n>:``;
``# xfail: <why>``    a known loader problem: the test is expected to fail (strictly,
                      so a fix shows up as XPASS and the header line is then removed).

``tests/bad/valid/`` holds the files the bad ones were made from; they must load, so
that each bad file fails for its own reason.
"""

from __future__ import annotations

import re
import signal
from contextlib import contextmanager
from pathlib import Path
from typing import NamedTuple

import pytest

import lamech

BAD = Path(__file__).parent / "bad"
FILES = sorted(BAD.glob("*.toml"))
VALID = sorted((BAD / "valid").glob("*.toml"))
TIME_LIMIT = 10  # seconds per file: a hang is a failure, not a stuck suite


class Header(NamedTuple):
    expects: list[str]
    rejects: list[str]
    line: int | None
    xfail: str | None


def header(path: Path) -> Header:
    """What a bad file's header comments say its error must (not) contain."""
    fields: dict[str, list[str]] = {"expect": [], "reject": [], "line": [], "xfail": []}
    for raw in path.read_text(encoding="utf-8").splitlines():
        if not raw.startswith("#"):
            break
        if m := re.match(r"#\s*(expect|reject|line|xfail):\s*(.*?)\s*$", raw):
            fields[m.group(1)].append(m.group(2))
    line = int(fields["line"][0]) if fields["line"] else None
    xfail = fields["xfail"][0] if fields["xfail"] else None
    return Header(fields["expect"], fields["reject"], line, xfail)


# the files of 2 s or more: left out of the default set
SLOW = {
    "120-angular-velocity-unknown-body",
    "121-angular-velocity-unknown-component",
    "122-angular-velocity-in-f",
    "123-angular-velocity-rate",
}
assert SLOW <= {p.stem for p in FILES}, SLOW - {p.stem for p in FILES}


def cases(paths):
    for path in paths:
        xfail = header(path).xfail
        marks = [pytest.mark.xfail(strict=True, reason=xfail)] if xfail else []
        if path.stem in SLOW:
            marks.append(pytest.mark.slow)
        yield pytest.param(path, id=path.stem, marks=marks)


class Timeout(Exception):
    pass


@contextmanager
def time_limit(seconds: float):
    def on_alarm(signum, frame):
        raise Timeout(f"no answer within {seconds} s")

    previous = signal.signal(signal.SIGALRM, on_alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def tree(path: Path) -> set[str]:
    return {str(p.relative_to(path)) for p in path.rglob("*")}


def load_error(load, *args, tmp_path: Path, monkeypatch, capfd) -> lamech.ProblemFileError:
    """Run ``load(*args)`` in an empty working directory; it must raise, create nothing,
    print nothing."""
    monkeypatch.chdir(tmp_path)
    before = tree(BAD)
    with time_limit(TIME_LIMIT):
        with pytest.raises(lamech.ProblemFileError) as info:
            load(*args)
    assert list(tmp_path.iterdir()) == [], "loading created files"
    assert tree(BAD) == before, "loading changed tests/bad"
    out, err = capfd.readouterr()
    assert out == "" and err == "", f"loading printed: {out!r} {err!r}"
    return info.value


def check_message(message: str, name: str, expected: Header) -> None:
    assert name in message, f"the message does not name the file {name}:\n{message}"
    # The file name must not satisfy an expectation by itself ("...-residual.toml").
    body = message.replace(name, "").lower()
    for text in expected.expects:
        assert text.lower() in body, f"expected {text!r} in:\n{message}"
    for text in expected.rejects:
        assert text.lower() not in body, f"misleading {text!r} in:\n{message}"
    if expected.line is not None:
        line = expected.line
        assert f":{line}:" in message, f"expected line {line} (`:{line}:`) in:\n{message}"


def test_corpus_is_complete():
    assert len(FILES) >= 35
    for path in FILES:
        assert re.fullmatch(r"\d{2,3}-[a-z0-9-]+-?[A-Za-z0-9-]*\.toml", path.name), path.name
        assert header(path).expects, f"{path.name} has no '# expect:' line"


def test_problem_file_error_is_a_value_error():
    assert issubclass(lamech.ProblemFileError, ValueError)


@pytest.mark.parametrize("path", VALID, ids=lambda p: p.stem)
def test_valid_bases_load(path, tmp_path, monkeypatch):
    """The files the corpus was made from load: each bad file has exactly its own fault."""
    monkeypatch.chdir(tmp_path)
    with time_limit(TIME_LIMIT):
        lamech.load(path)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("path", list(cases(FILES)))
def test_bad_file(path, tmp_path, monkeypatch, capfd):
    error = load_error(lamech.load, path, tmp_path=tmp_path, monkeypatch=monkeypatch, capfd=capfd)
    check_message(str(error), path.name, header(path))


@pytest.mark.parametrize(
    "stem",
    [
        "05-unknown-name-in-f",
        "11-velocity-in-V",
        "27-inject-import-os",
        "35-exponent-tower",
        "01-toml-unclosed-string",
    ],
)
def test_bad_text_through_loads(stem, tmp_path, monkeypatch, capfd):
    """The Python API gives the same error for the same text, under the name it is given."""
    path = BAD / f"{stem}.toml"
    error = load_error(
        lamech.loads,
        path.read_text(encoding="utf-8"),
        "x.toml",
        tmp_path=tmp_path,
        monkeypatch=monkeypatch,
        capfd=capfd,
    )
    check_message(str(error), "x.toml", header(path))


def test_load_accepts_a_string_path(tmp_path, monkeypatch, capfd):
    path = BAD / "05-unknown-name-in-f.toml"
    error = load_error(
        lamech.load, str(path), tmp_path=tmp_path, monkeypatch=monkeypatch, capfd=capfd
    )
    check_message(str(error), path.name, header(path))


def test_missing_file(tmp_path, monkeypatch, capfd):
    error = load_error(
        lamech.load,
        tmp_path / "nowhere.toml",
        tmp_path=tmp_path,
        monkeypatch=monkeypatch,
        capfd=capfd,
    )
    assert "nowhere.toml" in str(error)


# ------------------------------------------------- files that are not files, outputs


def test_a_device_or_a_pipe_is_refused_without_reading_it(tmp_path):
    """/dev/zero would be read forever and a FIFO would block: both refused at once."""
    import os

    fifo = tmp_path / "pipe.toml"
    os.mkfifo(fifo)
    for path in ("/dev/zero", fifo):
        with pytest.raises(lamech.ProblemFileError, match="is not a regular file"):
            with time_limit(TIME_LIMIT):
                lamech.load(path)


def test_a_file_over_the_limit_is_refused_after_reading_only_the_limit(tmp_path):
    big = tmp_path / "big.toml"
    big.write_bytes(b"# " + b"x" * 2_000_000 + b"\n")
    with pytest.raises(lamech.ProblemFileError, match="file too large"):
        lamech.load(big)


def test_a_byte_order_mark_is_not_part_of_the_toml(tmp_path):
    text = (Path(lamech.__file__).parent / "examples" / "pendulum.toml").read_text("utf-8")
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + text.replace("\n", "\r\n").encode("utf-8"))
    assert lamech.load(path).title == lamech.load("pendulum").title


@pytest.mark.parametrize(
    "command",
    [
        ["simulate", "{p}", "--t-end", "0.1", "--out", "{o}"],
        ["simulate", "{p}", "--t-end", "0.1", "--plot", "{o}"],
        ["sweep", "{p}", "--param", "m=1:2:2", "--t-end", "0.1", "--out", "{o}"],
    ],
)
def test_an_output_never_replaces_the_problem_file(command, tmp_path, monkeypatch, capsys):
    """By its own name, through a symlink, or as ./name: refused, the file untouched."""
    from lamech.cli import main

    problem = tmp_path / "q.toml"
    problem.write_text(
        (Path(lamech.__file__).parent / "examples" / "pendulum.toml").read_text("utf-8"),
        encoding="utf-8",
    )
    (tmp_path / "link.toml").symlink_to(problem)
    before = problem.read_bytes()
    monkeypatch.chdir(tmp_path)
    for target in ("q.toml", "link.toml", "./q.toml"):
        argv = [a.format(p="q.toml", o=target) for a in command]
        assert main(argv) == 2
        assert "is the problem file itself" in capsys.readouterr().err
    assert problem.read_bytes() == before


def test_the_trajectory_csv_is_written_whole_or_not_at_all(tmp_path):
    """Written beside the target and renamed over it: no temporary file is left."""
    out = tmp_path / "run.csv"
    out.write_text("old", encoding="utf-8")
    traj = lamech.simulate(lamech.load("pendulum"), 0.1, samples=11)
    from lamech.present import trajectory_csv

    trajectory_csv(traj, out)
    assert out.read_text("utf-8").startswith("t,")
    assert [p.name for p in tmp_path.iterdir()] == ["run.csv"]


@pytest.mark.parametrize(
    "options, message",
    [
        (["--dt", "1e-12"], "1e+12 output times (about 6.4e+04 GB) is more than lamech keeps"),
        (["--samples", "1000000000"], "1e+09 output times"),
        (
            ["--plot", "out.txt"],
            "--plot out.txt: the format follows the suffix; use a name ending in .png",
        ),
    ],
)
def test_outputs_that_cannot_be_made_are_refused_before_the_run(
    options, message, capsys, tmp_path, monkeypatch
):
    from lamech.cli import main

    monkeypatch.chdir(tmp_path)
    with time_limit(TIME_LIMIT):
        assert main(["simulate", "pendulum", "--t-end", "1", *options]) == 2
    assert message in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
