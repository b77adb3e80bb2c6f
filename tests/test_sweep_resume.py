"""A sweep's resume checks what it resumes (issue 17, item 8): other options, a changed
problem file, a second sweep on the same table and a damaged table are refused, naming
what differs; the failed rows are run again."""

from __future__ import annotations

import csv

import pytest

import lamech
from lamech.cli import main
from lamech.sweeps import SweepError, sweep


# ----- a resume checks what it resumes ---------------------------------------------------
def _cylinder_sweep(out, params=None, **kw):
    kw.setdefault("t_end", 2.7)
    kw.setdefault("samples", 11)
    kw.setdefault("workers", 1)
    return sweep(
        kw.pop("problem", "cylinder"),
        params or {"mu": [0.2, 0.3, 0.4]},
        kw.pop("measures", ["slip"]),
        initial=kw.pop("initial", {"theta1": 0.01}),
        out=out,
        **kw,
    )


@pytest.mark.parametrize(
    "change, said",
    [
        ({"t_end": 3.0}, "`t_end=` differs: the table was made with 2.7, this sweep has 3;"),
        ({"samples": 21}, "`samples=` differs: the table was made with 11, this sweep has 21"),
        ({"rtol": 1e-9}, "`rtol=` differs: the table was made with 1e-11, this sweep has 1e-09"),
        ({"method": "Radau"}, "`method=` differs: the table was made with DOP853, this sweep has"),
        ({"initial": {"theta1": 0.02}}, "`initial=` differs: the table was made with theta1=0.01"),
        ({"max_step": 0.1}, "`max_step=` differs: the table was made with none (the default)"),
        (
            {"params": {"mu": [0.2, 0.3, 0.45]}},
            "`params=` `mu` differs: the table was made with 0.2,0.3,0.4, "
            "this sweep has 0.2,0.3,0.45",
        ),
    ],
)
def test_a_resume_with_other_options_is_refused_naming_the_option(tmp_path, change, said):
    out = tmp_path / "t.csv"
    _cylinder_sweep(out)
    made = out.read_text()
    with pytest.raises(SweepError) as exc:
        _cylinder_sweep(out, resume=True, **change)
    assert said in str(exc.value)
    assert "run without `resume=True` to start a new table" in str(exc.value)
    assert out.read_text() == made  # the table is left as it was


def test_a_resume_after_the_problem_file_changed_is_refused(tmp_path):
    problem = tmp_path / "p.toml"
    problem.write_text(lamech.problem.example_path("pendulum").read_text(), encoding="utf-8")
    out = tmp_path / "t.csv"
    args = dict(problem=str(problem), params={"theta0": [0.2, 0.3]}, measures=["max:theta"])
    _cylinder_sweep(out, initial={}, t_end=0.5, **args)
    _cylinder_sweep(out, initial={}, t_end=0.5, resume=True, **args)  # unchanged: fine
    problem.write_text(problem.read_text().replace("g = 9.81", "g = 1.62"), encoding="utf-8")
    with pytest.raises(SweepError, match="the problem has changed since the table was made"):
        _cylinder_sweep(out, initial={}, t_end=0.5, resume=True, **args)
    (tmp_path / "t.csv.sweep.json").unlink()  # a table with no record of what made it
    with pytest.raises(SweepError, match=r"no record of the sweep that made it \(t.csv.sweep"):
        _cylinder_sweep(out, initial={}, t_end=0.5, resume=True, **args)


def test_two_sweeps_on_one_table_the_second_is_refused(tmp_path):
    out = tmp_path / "t.csv"
    refused = []

    def start_another(done, total):
        if done == 1:
            with pytest.raises(SweepError) as exc:
                _cylinder_sweep(out, {"mu": [0.5, 0.6]})
            refused.append(str(exc.value))

    run = _cylinder_sweep(out, progress=start_another)
    assert run.counts == {"ok": 3} and len(refused) == 1
    assert "is being written by another lamech sweep (pid " in refused[0]
    with open(out, newline="") as fh:
        assert [float(r["mu"]) for r in csv.DictReader(fh)] == [0.2, 0.3, 0.4]
    assert not (tmp_path / "t.csv.lock").exists()
    _cylinder_sweep(out, {"mu": [0.5, 0.6]})  # one after the other: fine


@pytest.mark.parametrize(
    "damage, said",
    [
        (lambda ln: ln.replace(",ok,", ",ok,extra,"), "line 3: 9 fields where the table has 8"),
        (lambda ln: "3" + ln[1:4] + "x" + ln[5:], "line 3, column `mu`: '0.x' is not a number"),
        (lambda ln: ln.replace(",ok,", ",okay,"), "line 3: status 'okay' is not one of ok"),
        (lambda ln: "7" + ln[1:], "line 3: case '7' is not a case of this sweep (0 to 2)"),
        (lambda ln: "0" + ln[1:], "line 3: case 0 again (first on line 2)"),
    ],
)
def test_a_damaged_table_is_refused_with_its_line(tmp_path, damage, said):
    out = tmp_path / "t.csv"
    _cylinder_sweep(out)
    lines = out.read_text().splitlines(keepends=True)
    lines[2] = damage(lines[2])
    out.write_text("".join(lines))
    with pytest.raises(SweepError) as exc:
        _cylinder_sweep(out, resume=True)
    assert said in str(exc.value)


def test_a_resume_runs_the_failed_rows_again(tmp_path, capsys):
    out = tmp_path / "t.csv"
    _cylinder_sweep(out)
    fresh = out.read_text()
    lines = fresh.splitlines(keepends=True)
    fields = lines[2].split(",")
    lines[2] = ",".join(fields[:2] + ["nan"] * 4 + ["failed", "step size collapsed\n"])
    out.write_text("".join(lines))
    run = _cylinder_sweep(out, resume=True)
    assert run.ran_cases == [1] and run.kept == 2 and run.retried == 1
    assert out.read_text() == fresh
    out.write_text("".join(lines))
    rc = main(
        [
            "sweep",
            "cylinder",
            "--param",
            "mu=0.2,0.3,0.4",
            "--initial",
            "theta1=0.01",
            "--measure",
            "slip",
            "--t-end",
            "2.7",
            "--samples",
            "11",
            "--workers",
            "1",
            "--out",
            str(out),
            "--resume",
        ]
    )
    assert rc == 0
    assert "ran 1, kept 2 from the table, retried 1 that had failed" in capsys.readouterr().out
