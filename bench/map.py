"""B10: a map of regimes from the closed forms (``lamech.map``) beside the sweep that
simulates every case (``lamech sweep``, B6's problem and grid).

The lecture's cylinder set down at rest at theta0 = 0.01 rad, over R2 (0.2 to 1) and mu
(0.1 to 0.6): the map evaluates the slip and lift-off angles and which comes first at
every grid point from the closed forms, vectorised; the sweep simulates each case. The
truth for both: the root of sin(theta) = mu (7 cos(theta) - 4 cos(theta0))
(:func:`bench.sweep.slip_truth`).

Timed: the map's evaluation in this process (CPU time after start-up: the solve and the
compilation of the closed forms, timed apart), on a 1000 x 1000 grid (the slip angle
depends on mu alone: solved once per mu, spread over R2) and on 10^6 distinct values of
mu (every point solved); the sweep as a whole process on a 20 x 20 grid (B6's
``_lamech_sweep``), its CPU per case.
"""

from __future__ import annotations

import os
import tempfile
import time
from importlib import resources
from pathlib import Path

import numpy as np

from .sweep import MU_RANGE, R2_RANGE, ROOT, THETA0, _lamech_sweep, slip_truth


def _problem() -> str:
    text = (resources.files("lamech") / "examples" / "cylinder.toml").read_text()
    text = text.replace(
        "theta1 = { initial = 0, velocity = 0 }", f"theta1 = {{ initial = {THETA0}, velocity = 0 }}"
    )
    return text.replace(
        "theta2 = { initial = 0, velocity = 0 }",
        f'theta2 = {{ initial = "(R1 + R2)*{THETA0}/R2", velocity = 0 }}',
    )


def _map(system, grid: dict) -> tuple[float, float, object]:
    import lamech

    t0 = time.process_time()
    result = lamech.map(system, grid)
    total = time.process_time() - t0
    return total - result.seconds, result.seconds, result


def bench_b10(lines: list[str], repeats: int = 3, quick: bool = False) -> None:
    """Append B10's table to ``lines`` (the module docstring says what is run)."""
    import lamech

    print("\nB10 a map of regimes from the closed forms, beside the sweep")
    system = lamech.loads(_problem(), "cylinder_theta0.toml")
    n = 300 if quick else 1000
    grids = {
        f"map, {n} x {n} grid (mu x R2)": {
            "mu": f"{MU_RANGE[0]}:{MU_RANGE[1]}:{n}",
            "R2": f"{R2_RANGE[0]}:{R2_RANGE[1]}:{n}",
        },
        f"map, {n * n} distinct mu": {"mu": np.linspace(*MU_RANGE, n * n)},
    }
    rows = []
    rates = {}
    for label, grid in grids.items():
        runs = [_map(system, grid) for _ in range(repeats)]
        start = sorted(r[0] for r in runs)[len(runs) // 2]
        cpu = sorted(r[1] for r in runs)[len(runs) // 2]
        result = runs[-1][2]
        mu = np.unique(result.columns["mu"])
        pick = mu[:: max(1, len(mu) // 200)]
        truth = {m: slip_truth(float(m)) for m in pick}
        theta = result.columns["slip:theta1"]
        err = max(
            float(np.max(np.abs(theta[result.columns["mu"] == m] - t))) for m, t in truth.items()
        )
        rates[label] = len(result) / cpu
        rows.append(
            f"| {label} | {len(result)} | {cpu:.3f} s | {len(result) / cpu:.3g} | "
            f"{start:.2f} s | {err:.1e} |"
        )
        print(rows[-1])
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    mid = (5, 4) if quick else (20, 20)
    with tempfile.TemporaryDirectory(prefix="lamech-b10-") as tmp:
        out = Path(tmp) / "sweep.csv"
        env["LAMECH_CACHE_DIR"] = os.environ.get("LAMECH_CACHE_DIR") or str(Path(tmp) / "cache")
        _lamech_sweep(4, 4, ["slip", "liftoff"], "compiled", out, env)  # warm-up
        runs = [_lamech_sweep(*mid, ["slip", "liftoff"], "auto", out, env) for _ in range(repeats)]
    cpu = sorted(c for _, c, _ in runs)[len(runs) // 2]
    cases = mid[0] * mid[1]
    sweep_rate = cases / cpu
    rows.append(
        f"| sweep, {mid[0]} x {mid[1]} (whole process, simulated) | {cases} | {cpu:.2f} s | "
        f"{sweep_rate:.3g} | in the CPU | {runs[-1][2]['slip']:.1e} |"
    )
    print(rows[-1])
    lines += [
        "## B10 a map of regimes from the closed forms, beside the sweep",
        "",
        "The cylinder from rest at theta0 = 0.01 over mu and R2 (`bench/map.py`): the map "
        "evaluates the slip and lift-off angles and the event met first from the closed "
        "forms (CPU after start-up: median of the runs; start-up is the solve and the "
        "compilation); the sweep simulates each case (a whole process). Error: the slip "
        "angle against the energy integral's root.",
        "",
        "| run | points | CPU | points per CPU second | start-up | slip error |",
        "|---|---|---|---|---|---|",
        *rows,
        "",
        *[f"- {k} / sweep, points per CPU second: {v / sweep_rate:.3g}x" for k, v in rates.items()],
        "",
    ]
