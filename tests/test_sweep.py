"""Parameter sweeps (lamech.sweep, ``lamech sweep``): physics against closed forms,
resume after an interruption, local processes and Dask against the in-process run,
bad input named."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest
from scipy.optimize import brentq

import lamech
from lamech.cli import main
from lamech.sweeps import SweepError, SweepResult, sweep
from lamech.sweeps._parse import parse_values

THETA_S = 0.01  # the cylinder starts just off the top, at rest


def _slip_angle(mu: float, ths: float = THETA_S) -> float:
    """Closed form (energy integral): N = m g (7 cos th - 4 cos ths)/3, F = -m g sin th/3;
    slip where sin th = mu (7 cos th - 4 cos ths), before lift-off."""
    top = math.acos(4 / 7 * math.cos(ths))
    return brentq(
        lambda th: math.sin(th) - mu * (7 * math.cos(th) - 4 * math.cos(ths)), ths, top, xtol=1e-15
    )


def _cylinder(params, measures, **kw):
    kw.setdefault("t_end", 2.7)
    kw.setdefault("samples", 11)
    kw.setdefault("workers", 1)
    return sweep("cylinder", params, measures, initial={"theta1": THETA_S}, **kw)


@pytest.mark.slow
def test_slip_angle_matches_energy_integral_over_mu_and_R2():
    mus = [0.1, 0.25, 0.4, 0.6]
    run = _cylinder({"mu": mus, "R2": [0.3, 0.5]}, ["slip", "liftoff"])
    assert len(run.rows) == 8 and run.counts == {"ok": 8}
    for row in run.rows:
        mu, R2 = row["mu"], row["R2"]
        th = _slip_angle(mu)
        assert abs(row["slip:theta1"] - th) < 1e-9, (mu, R2)
        # rolling held until the slip: (R1 + R2) theta1 = R2 theta2, contact r = R1 + R2
        assert abs(row["slip:theta2"] - (1 + R2) / R2 * th) < 1e-9
        assert abs(row["slip:r"] - (1 + R2)) < 1e-12
        assert row["slip:t"] < row["liftoff:t"] < 2.7
    # the start: theta1 set, theta2 moved to meet the rolling constraint (not the file's 0)
    assert run.columns[:3] == ["case", "mu", "R2"]


@pytest.mark.filterwarnings("ignore:overflow:RuntimeWarning")  # rejected trial steps
def test_liftoff_angle_when_friction_barely_lets_go():
    # N -> 0 at lift-off while F = -m g sin/3 does not, so any finite mu slips just before;
    # with mu = 1e6 that happens ~1e-7 rad before cos th = (4/7) cos ths.
    run = _cylinder({"mu": [1e6], "m": [1.0, 3.0]}, ["liftoff", "slip"], t_end=2.6)
    top = math.acos(4 / 7 * math.cos(THETA_S))
    for row in run.rows:
        assert row["status"] == "ok", row["message"]
        assert abs(row["slip:theta1"] - _slip_angle(1e6)) < 1e-9
        assert abs(row["liftoff:theta1"] - top) < 1e-7
    assert abs(run.rows[0]["liftoff:t"] - run.rows[1]["liftoff:t"]) < 1e-9  # m drops out


@pytest.mark.slow
def test_series_measures_against_pendulum_closed_forms():
    # released at rest from theta0: string tension m g (3 cos th - 2 cos th0), min at the
    # start (m g cos th0), max at the bottom (m g (3 - 2 cos th0)); energy conserved.
    th0 = [0.3, 0.8]
    run = sweep(
        "pendulum",
        {"theta0": th0, "m": [2.0]},
        ["min:lambda:string", "max:lambda:string", "final:energy", "max:theta", "liftoff"],
        t_end=2.0,
        samples=4001,
        workers=1,
    )
    g = 9.81
    for row in run.rows:
        c0 = math.cos(row["theta0"])
        assert abs(row["min:lambda:string"] - 2 * g * c0) < 1e-9
        # the samples see the bottom within dt: relative error O((omega dt theta0)^2)
        assert abs(row["max:lambda:string"] / (2 * g * (3 - 2 * c0)) - 1) < 1e-5
        assert abs(row["final:energy"] + 2 * g * c0) < 1e-9
        assert abs(row["max:theta"] - row["theta0"]) < 1e-6
        assert math.isnan(row["liftoff:t"])  # the string never slackens


def _read(path):
    return path.read_text(encoding="utf-8")


@pytest.mark.slow
def test_resume_runs_only_missing_cases_and_gives_the_fresh_table(tmp_path, monkeypatch):
    params = {"mu": "0.1:0.6:3", "R2": "0.3,0.5"}
    fresh = tmp_path / "fresh.csv"
    _cylinder(params, ["slip", "max:lambda:contact"], out=fresh)
    text = _read(fresh)
    lines = text.splitlines(keepends=True)
    assert len(lines) == 1 + 6
    # a run killed mid-write: 3 complete rows (not in case order) and half a line
    part = tmp_path / "part.csv"
    part.write_text(lines[0] + lines[2] + lines[5] + lines[3] + lines[6][:17], "utf-8")
    # with the record of the sweep that made it, written when it started
    (tmp_path / "part.csv.sweep.json").write_text(_read(tmp_path / "fresh.csv.sweep.json"))
    run = _cylinder(params, ["slip", "max:lambda:contact"], out=part, resume=True)
    assert sorted(run.ran_cases) == [0, 3, 5] and run.ran == 3 and run.kept == 3
    assert _read(part) == text


@pytest.mark.slow
def test_interrupted_sweep_keeps_finished_rows(tmp_path):
    out = tmp_path / "t.csv"
    params = {"mu": [0.2, 0.3, 0.4, 0.5]}

    def stop_after_two(done, total):
        if done == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):  # the workers ended, the finished rows kept
        _cylinder(params, ["slip"], out=out, progress=stop_after_two)
    with open(out, newline="") as fh:
        assert len(list(csv.reader(fh))) == 3  # header + the two finished rows
    again = _cylinder(params, ["slip"], out=out, resume=True)
    assert again.ran == 2 and again.kept == 2 and not again.interrupted
    fresh = tmp_path / "f.csv"
    _cylinder(params, ["slip"], out=fresh)
    assert _read(out) == _read(fresh)


def test_resume_refuses_a_table_of_another_sweep(tmp_path):
    out = tmp_path / "t.csv"
    _cylinder({"mu": [0.2, 0.3]}, ["slip"], out=out)
    with pytest.raises(SweepError, match="`params=` `mu` differs: the table was made with 0.2,0.3"):
        _cylinder({"mu": [0.2, 0.35]}, ["slip"], out=out, resume=True)
    with pytest.raises(SweepError, match="`measures=` differs: the table was made with slip"):
        _cylinder({"mu": [0.2, 0.3]}, ["liftoff"], out=out, resume=True)


def test_the_command_names_its_flags_where_the_library_names_arguments(tmp_path, capsys):
    out = tmp_path / "t.csv"
    _cylinder({"mu": [0.2, 0.3]}, ["slip"], out=out)
    sweep = ["sweep", "cylinder", "--param", "mu=0.2,0.3", "--t-end", "2.7", "--out", str(out)]
    assert main([*sweep, "--measure", "liftoff", "--resume"]) == 2
    err = capsys.readouterr().err
    assert "--measure differs: the table was made with slip, this sweep has liftoff" in err
    assert "or run without --resume to start a new table" in err and "=`" not in err


@pytest.mark.slow
def test_local_processes_match_in_process(tmp_path):
    params = {"mu": [0.15, 0.3, 0.45], "R2": [0.4]}
    # the processes run simulate: the compiled loop with events runs in this process
    one = _cylinder(params, ["slip", "final:theta1"], engine="scipy")
    two = _cylinder(
        params, ["slip", "final:theta1"], workers=2, out=tmp_path / "p.csv", engine="scipy"
    )
    assert two.backend == "2 local processes"
    assert two.rows == one.rows


@pytest.mark.slow
@pytest.mark.shared_cache
def test_dask_local_cluster_matches_in_process(tmp_path, capsys):
    distributed = pytest.importorskip(
        "distributed", reason="dask.distributed not installed (pip install 'lamech[dask]')"
    )
    params = {"mu": [0.15, 0.3, 0.45]}
    one = _cylinder(params, ["slip"], engine="scipy")  # Dask's workers run simulate
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=False, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        run = _cylinder(params, ["slip"], scheduler=client)
    assert run.backend.startswith("Dask") and "(2 workers)" in run.backend
    assert run.rows == one.rows


@pytest.mark.slow
@pytest.mark.shared_cache
def test_dask_worker_processes_through_the_cli(tmp_path, capsys):
    distributed = pytest.importorskip(
        "distributed", reason="dask.distributed not installed (pip install 'lamech[dask]')"
    )
    args = [
        "sweep",
        "cylinder",
        "--param",
        "mu=0.1:0.6:4",
        "--param",
        "R2=0.3,0.5",
        "--initial",
        "theta1=0.01",
        "--measure",
        "slip",
        "--measure",
        "liftoff",
        "--t-end",
        "2.7",
        "--samples",
        "11",
    ]
    local = tmp_path / "local.csv"
    assert main(args + ["--workers", "1", "--engine", "scipy", "--out", str(local)]) == 0
    remote = tmp_path / "dask.csv"
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        rc = main(args + ["--scheduler", cluster.scheduler_address, "--out", str(remote)])
    text = capsys.readouterr().out
    assert rc == 0 and "on Dask at tcp://" in text and "(2 workers)" in text, text
    assert _read(remote) == _read(local)


@pytest.mark.slow
@pytest.mark.shared_cache
def test_dask_worker_killed_mid_sweep_is_rescheduled(tmp_path):
    distributed = pytest.importorskip(
        "distributed", reason="dask.distributed not installed (pip install 'lamech[dask]')"
    )
    import os

    params = {"mu": [0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45]}
    one = _cylinder(params, ["slip"], engine="scipy")
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        killed = []

        def kill_a_worker(done, total):
            if done == 2 and not killed:
                victim = sorted(client.scheduler_info()["workers"])[0]
                killed.append(victim)
                # its connection drops: which error says so depends on when Dask notices
                with pytest.raises(Exception):  # noqa: B017
                    client.run(os._exit, 1, workers=[victim])

        run = _cylinder(
            params, ["slip"], scheduler=client, progress=kill_a_worker, out=tmp_path / "t.csv"
        )
    assert killed and not run.stopped and run.ran == 8
    assert run.rows == one.rows


def test_sweep_returns_one_result_type():
    res = _cylinder({"mu": [0.2, 0.3]}, ["slip"])
    assert isinstance(res, SweepResult) and len(res) == 2 and res.complete
    assert list(res.column("mu")) == [0.2, 0.3]
    assert res.column("case").tolist() == [0, 1]
    assert res.column("status").tolist() == ["ok", "ok"]
    assert np.allclose(res.column("slip:theta1"), [_slip_angle(0.2), _slip_angle(0.3)], atol=1e-9)
    assert repr(res) == (
        "<SweepResult: 2 cases (mu: 2); ok 2; columns case, mu, slip:t, slip:r, "
        "slip:theta1, slip:theta2, status, message>"
    )
    with pytest.raises(KeyError, match="no column 'slip'; the columns: case, mu, slip:t"):
        res.column("slip")
    # code written for 0.2's DataFrame is told what to call
    with pytest.raises(AttributeError, match=r"to_dataframe\(\) gives one"):
        res.round(4)
    with pytest.raises(TypeError, match=r"result.column\(name\)"):
        res["mu"]
    assert res.records() == res.rows and res.records()[0] is not res.rows[0]


def test_dataframe_and_the_deprecated_names():
    pd = pytest.importorskip("pandas", reason="pandas not installed")
    res = _cylinder({"mu": [0.2, 0.3]}, ["slip"])
    df = res.to_dataframe()
    assert isinstance(df, pd.DataFrame) and list(df.columns) == res.columns
    assert list(df["slip:theta1"]) == list(res.column("slip:theta1"))
    with pytest.warns(DeprecationWarning, match=r"sweep\(output=...\) is deprecated"):
        rec = _cylinder({"mu": [0.3]}, ["slip"], output="records")
    assert rec[0]["slip:theta1"] == df["slip:theta1"][1]
    with pytest.warns(DeprecationWarning, match="use lamech.sweep"):
        old = lamech.run_sweep(
            "cylinder",
            {"mu": [0.3]},
            ["slip"],
            t_end=2.7,
            samples=11,
            workers=1,
            initial={"theta1": THETA_S},
        )
    assert isinstance(old, SweepResult) and old.rows[0]["slip:theta1"] == rec[0]["slip:theta1"]
    with pytest.warns(DeprecationWarning, match="SweepRun is deprecated: renamed"):
        assert lamech.sweeps.SweepRun is SweepResult
    with pytest.warns(DeprecationWarning, match="parse_values is deprecated: internal"):
        assert lamech.sweeps.parse_values is parse_values
    with pytest.raises(SweepError, match="unknown output 'table'"):
        _cylinder({"mu": [0.3]}, ["slip"], output="table")


def test_to_csv_gives_the_table_the_sweep_writes(tmp_path):
    """lamech.to_csv is the one home of a sweep's CSV: the table on disk (written row by
    row as the cases finish, then sorted) is its text, and every number reads back as
    the same float."""
    out = tmp_path / "t.csv"
    res = _cylinder({"mu": [0.2, 0.3]}, ["slip", "liftoff"], out=out)
    text = lamech.to_csv(res)
    assert out.read_text(encoding="utf-8") == text
    rows = list(csv.DictReader(text.splitlines()))
    assert list(rows[0]) == res.columns and len(rows) == len(res) == 2
    for row, kept in zip(rows, res.rows):
        assert row["case"] == str(kept["case"]) and row["status"] == kept["status"]
        for name in res.measure_columns + ["mu"]:
            same = float(row[name]) == kept[name]
            assert same or (math.isnan(kept[name]) and row[name] == "nan"), name
    with pytest.warns(DeprecationWarning, match=r"format_value is deprecated: internal to lam"):
        assert lamech.sweeps.format_value(0.1) == "0.1"


def test_xarray_dataset():
    pytest.importorskip("xarray", reason="xarray not installed (optional)")
    ds = _cylinder({"mu": [0.2, 0.3], "R2": [0.3, 0.5]}, ["slip"]).to_xarray()
    assert ds["slip:theta1"].dims == ("mu", "R2")
    assert abs(float(ds["slip:theta1"].sel(mu=0.3, R2=0.5)) - _slip_angle(0.3)) < 1e-9


def test_parquet_table(tmp_path):
    pytest.importorskip("pyarrow", reason="pyarrow not installed (optional)")
    pd = pytest.importorskip("pandas", reason="pandas not installed")
    out = tmp_path / "t.parquet"
    run = _cylinder({"mu": [0.2, 0.3]}, ["slip"], out=out)
    df = pd.read_parquet(out)
    assert list(df["slip:theta1"]) == [r["slip:theta1"] for r in run.rows]
    again = _cylinder({"mu": [0.2, 0.3]}, ["slip"], out=out, resume=True)
    assert again.ran == 0 and again.kept == 2


def test_values_syntax():
    assert np.allclose(parse_values("0.1:1.0:10"), np.linspace(0.1, 1.0, 10), rtol=1e-15)
    assert list(parse_values("0.1:0.6:6")) == [0.1, 0.2, 0.3, 0.4, 0.5, 0.6]
    assert list(parse_values("0.1, 0.2,3")) == [0.1, 0.2, 3.0]
    assert list(parse_values("2")) == [2.0]
    assert list(parse_values("0.3:0.3:1")) == [0.3]  # one point: the one value
    assert list(parse_values("10 cm:10 cm:1")) == [0.1]
    for bad, msg in [
        ("0.1:1", "A:B:N"),
        ("a:1:3", "not a number"),
        ("0:1:x", "integer"),
        ("0:1:1", r"one value but two ends: write mu=0 for that value, or 0:1:N with N >= 2"),
        ("0:0:0", "count 0: a range has at least 1 value"),
        ("0.1,,0.2", "not a number"),
        ("nan", "finite"),
        ("__import__('os')", "not a number"),
        ("", "no values"),
    ]:
        with pytest.raises(SweepError, match=msg):
            parse_values(bad, "mu")


@pytest.mark.parametrize(
    "kw, msg",
    [
        ({"params": {"R3": [1.0]}}, r"unknown parameter `R3`; known: m, g, R1, R2, mu:rolling, mu"),
        ({"measures": ["liftof"]}, r"unknown measure 'liftof'; known: liftoff, slip"),
        (
            {"measures": ["max:lambda:contakt"]},
            r"unknown series `lambda:contakt`; known: .*"
            r"lambda:contact",
        ),
        (
            {"measures": ["slip:friction"]},
            r"unknown constraint `friction`; known: contact, rolling",
        ),
        ({"initial": {"theta3": 0.1}}, r"unknown coordinate `theta3`; known: r, theta1"),
        ({"params": {"mu": "0.1:0.5"}}, r"parameter `mu`: range '0.1:0.5' must be A:B:N"),
    ],
)
def test_bad_input_is_named(kw, msg):
    args = {"params": {"mu": [0.3]}, "measures": ["slip"], "t_end": 1.0, "workers": 1}
    args.update(kw)
    with pytest.raises(SweepError, match=msg):
        sweep("cylinder", **args)


@pytest.mark.slow
def test_cli_table_plot_and_errors(tmp_path, capsys):
    out, png = tmp_path / "s.csv", tmp_path / "s.png"
    rc = main(
        [
            "sweep",
            "cylinder",
            "--param",
            "mu=0.2:0.4:3",
            "--measure",
            "slip",
            "--initial",
            "theta1=0.01",
            "--t-end",
            "2.7",
            "--samples",
            "11",
            "--workers",
            "1",
            "--out",
            str(out),
            "--plot",
            str(png),
        ]
    )
    text = capsys.readouterr().out
    assert rc == 0, text
    assert "3 cases (mu: 3): ok 3; ran 3" in text
    with open(out, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [float(r["mu"]) for r in rows] == [0.2, 0.3, 0.4]
    for r in rows:
        assert abs(float(r["slip:theta1"]) - _slip_angle(float(r["mu"]))) < 1e-9
    assert png.stat().st_size > 1000
    rc = main(["sweep", "cylinder", "--param", "R3=1:2:3", "--t-end", "1"])
    err = capsys.readouterr().err
    assert rc == 2 and "unknown parameter `R3`" in err and "known: m, g, R1, R2" in err
    rc = main(["sweep", "cylinder", "--param", "mu=0.3", "--t-end", "1", "--resume"])
    assert rc == 2 and "--resume needs --out" in capsys.readouterr().err


def test_a_grid_of_one_point(capsys):
    """``A:A:1`` is the one value A, on the command line of sweep and map; ``A:B:1``
    with A != B is refused saying what to write (which of the two ends is meant is not
    known), with the commands' status 2 for bad input."""
    rc = main(["sweep", "cylinder", "--param", "mu=0.3:0.3:1", "--t-end", "0.1"])
    out, err = capsys.readouterr()
    assert rc == 0 and "1 cases (mu: 1)" in err and out.splitlines()[1].startswith("0,0.3,")
    rc = main(["map", "cylinder", "--param", "mu=0.3:0.3:1"])
    out, err = capsys.readouterr()
    assert rc == 0 and "1 points in" in err and out.splitlines()[1].startswith("0.3,")
    for command in (["sweep", "cylinder", "--t-end", "0.1"], ["map", "cylinder"]):
        assert main([*command, "--param", "mu=0.2:0.5:1"]) == 2
        err = capsys.readouterr().err
        assert "range '0.2:0.5:1' has one value but two ends" in err, err
        assert "write mu=0.2 for that value, or 0.2:0.5:N with N >= 2" in err, err


@pytest.mark.slow
def test_a_dead_worker_keeps_finished_rows_and_resume_completes(tmp_path):
    import multiprocessing

    if multiprocessing.get_start_method() != "fork":
        pytest.skip("needs fork start method to plant the crash in the worker processes")
    import os
    import signal

    params = {"mu": [0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45, 0.5]}

    def kill_a_worker(done, total):
        if done == 2:  # a worker process dies (as with a segfault or OOM kill)
            os.kill(multiprocessing.active_children()[0].pid, signal.SIGKILL)

    out = tmp_path / "t.csv"
    with pytest.raises(SweepError, match=r"stopped \(BrokenProcessPool.* resume=True completes"):
        _cylinder(params, ["slip"], out=out, workers=2, progress=kill_a_worker, engine="scipy")
    with open(out, newline="") as fh:
        kept = {int(r["case"]) for r in csv.DictReader(fh)}
    assert 2 <= len(kept) < 8
    again = _cylinder(params, ["slip"], out=out, resume=True, engine="scipy")
    assert again.ran == 8 - len(kept) and not again.stopped
    fresh = tmp_path / "f.csv"
    _cylinder(params, ["slip"], out=fresh, engine="scipy")
    assert _read(out) == _read(fresh)
