"""Maps of regimes from the closed forms (issue 47 item 2), against independent truths:
the lecture's cylinder slips where sin(theta) = mu (7 cos(theta) - 4) (released from the
top; Newton-Euler on the rolling cylinder gives F = m g sin(theta)/3 and
N = m g (7 cos(theta) - 4)/3) and would leave the fixed cylinder at cos(theta) = 4/7;
and, released from theta0, the simulation (`lamech sweep`) meets the same event first.
"""

from __future__ import annotations

import csv
import io
import math
from importlib import resources

import numpy as np
import pytest
from scipy.optimize import brentq

import lamech


def _released_from(th0_default: float = 0.1) -> str:
    """The bundled cylinder released at rest from theta1 = th0 (a parameter)."""
    text = (resources.files("lamech") / "examples" / "cylinder.toml").read_text()
    text = text.replace("R2 = 0.5\n", f"R2 = 0.5\nth0 = {th0_default}\n")
    text = text.replace(
        "theta1 = { initial = 0, velocity = 0 }", 'theta1 = { initial = "th0", velocity = 0 }'
    )
    return text.replace(
        "theta2 = { initial = 0, velocity = 0 }",
        'theta2 = { initial = "(R1 + R2)*th0/R2", velocity = 0 }',
    )


def test_every_slip_angle_is_the_root_of_the_lectures_equation():
    m = lamech.map("cylinder", {"mu": "0.05:0.6:400", "R2": "0.1:1:25"})
    assert len(m) == 400 * 25
    mu, theta = m.columns["mu"], m.columns["slip:theta1"]
    assert np.all(np.isfinite(theta)) and set(m.columns["first"]) == {"slip"}
    edge = math.acos(4 / 7)
    for k in np.random.default_rng(47).choice(len(m), 200, replace=False):
        c = float(mu[k])
        root = brentq(lambda t, c=c: math.sin(t) - c * (7 * math.cos(t) - 4), 0.0, edge, xtol=1e-15)
        assert abs(theta[k] - root) <= 1e-10, (mu[k], theta[k], root)
    residual = np.sin(theta) - mu * (7 * np.cos(theta) - 4)
    assert np.max(np.abs(residual)) <= 1e-10
    assert np.allclose(m.columns["liftoff:theta1"], edge, rtol=0, atol=1e-12)
    # the other coordinates from the constraints: r = R1 + R2, theta2 = (R1 + R2) theta1/R2
    R2 = m.columns["R2"]
    assert np.allclose(m.columns["slip:r"], 1.0 + R2, rtol=1e-14)
    assert np.allclose(m.columns["slip:theta2"], (1.0 + R2) * theta / R2, rtol=1e-13)
    assert np.all(np.isnan(m.columns["slip:t"]))  # no time in closed form


def test_the_map_and_the_simulation_agree_on_what_comes_first(tmp_path):
    path = tmp_path / "released.toml"
    path.write_text(_released_from(), encoding="utf-8")
    grid = {"mu": "0.1,0.3,0.6", "th0": "0.05,0.2,0.4"}
    m = lamech.map(str(path), grid)
    s = lamech.sweep(str(path), grid, ["slip", "liftoff"], t_end=4.0)
    assert len(s.rows) == len(m) == 9
    for k, row in enumerate(s.rows):
        assert (row["mu"], row["th0"]) == (m.columns["mu"][k], m.columns["th0"][k])
        times = {e: row[f"{e}:t"] for e in ("slip", "liftoff") if np.isfinite(row[f"{e}:t"])}
        first = min(times, key=times.get) if times else "none"
        if times and times[first] == 0.0:
            first += " at the start"
        assert m.columns["first"][k] == first, (row, m.columns["first"][k])
        if first == "slip":  # where: the same angle, simulated and in closed form
            assert abs(m.columns["slip:theta1"][k] - row["slip:theta1"]) <= 1e-7
    assert "slip at the start" in set(m.columns["first"])


def test_a_measure_without_a_closed_form_points_to_sweep():
    with pytest.raises(lamech.SweepError, match="no closed form.*lamech sweep"):
        lamech.map("cylinder", {"mu": "0.1:0.5:3"}, ["stick"])
    with pytest.raises(lamech.SweepError, match="lamech sweep"):
        lamech.map("double_pendulum", {"m1": "1:2:3"})  # two degrees of freedom
    with pytest.raises(lamech.SweepError, match="unknown parameter `M`"):
        lamech.map("cylinder", {"M": "1:2:3"})


def test_the_cli_writes_the_table_and_the_picture(tmp_path, capsys):
    from lamech.cli import main

    out = tmp_path / "map.csv"
    assert main(["map", "cylinder", "--param", "mu=0.1:0.5:5", "--param", "R2=0.5,1",
                 "--out", str(out)]) == 0  # fmt: skip
    lines = out.read_text().splitlines()
    assert lines[0].startswith("mu,R2,slip:t,slip:r,slip:theta1,slip:theta2,slip:start")
    assert lines[0].endswith(",first") and len(lines) == 11
    err = capsys.readouterr().err
    assert "10 points in" in err and "points/s" in err and "first event: slip: 10" in err
    png = tmp_path / "map.png"
    assert main(["map", "cylinder", "--param", "mu=0.1:0.5:5", "--param", "R2=0.5,1",
                 "--out", str(png)]) == 0  # fmt: skip
    assert png.read_bytes()[:4] == b"\x89PNG"
    assert main(["map", "cylinder", "--param", "mu=0.1:0.5:3", "--measure", "impact"]) == 2
    assert "lamech sweep" in capsys.readouterr().err


def test_to_csv_gives_what_the_cli_writes_and_reads_back_exactly(tmp_path):
    """lamech.to_csv is the one home of a map's CSV: the command writes it, every number
    reads back as the same float; MapResult.to_csv() still gives it, warning."""
    from lamech.cli import main

    grid = {"mu": "0.1:0.5:3", "R2": "0.5,1"}
    m = lamech.map("cylinder", grid)
    text = lamech.to_csv(m)
    out = tmp_path / "map.csv"
    assert main(["map", "cylinder", "--param", "mu=0.1:0.5:3", "--param", "R2=0.5,1",
                 "--out", str(out)]) == 0  # fmt: skip
    assert out.read_text(encoding="utf-8") == text
    rows = list(csv.DictReader(io.StringIO(text)))
    assert len(rows) == len(m) == 6 and list(rows[0]) == list(m.columns)
    for name, values in m.columns.items():
        read = [r[name] for r in rows]
        if name == "first":
            assert read == list(values)
        else:
            np.testing.assert_array_equal(np.array(read, dtype=float), values)
    with pytest.warns(DeprecationWarning, match=r"lamech.to_csv\(result\) gives the same"):
        assert m.to_csv() == text
