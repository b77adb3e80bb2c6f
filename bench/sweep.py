"""B6: a parameter sweep, the whole ``lamech sweep`` command, against SymPy + SciPy.

The lecture's cylinder (``cylinder.toml``) set down at rest at theta0 = 0.01 rad, swept
over R2 (0.2 to 1) and the friction coefficient mu (0.1 to 0.6), each case run to t = 3
and measured: the first slip and the lift-off (time and angle).

Truth, independent of both programs: on the energy shell of the rolling motion the
friction is m g sin(theta)/3 and the normal force m g (7 cos(theta) - 4 cos(theta0))/3,
whatever R2 (the lecture's problem, DESIGN.md's correction), so the slip angle is the
root of sin(theta) = mu (7 cos(theta) - 4 cos(theta0)) below the lift-off angle
(cos(theta) = 4 cos(theta0)/7), found by ``scipy.optimize.brentq``.

Timed, each as a whole process (``resource.getrusage`` of the children: CPU time beside
the wall time, the machine being shared), min / median / max of the repeats:

- lamech, the 50 x 50 grid (2,500 cases), slip and lift-off, ``--engine auto`` (the
  engine in C, built at install, on the problem's functions compiled to C) and
  ``--engine python`` (the same loop as plain Python, one thread), on a 20 x 20 grid
  (400 cases);
- issue 31's and 45's target: a 400-case sweep costs at most 1.5x a one-case sweep, both
  with the problem's own compiled functions new (the engine built at install);
- the peer, SymPy + SciPy, its strongest route for this job: ``LagrangesMethod`` on the
  same L and constraints, the (n + m)-square system of q'' and the multipliers
  lambdified once with common subexpressions, ``solve_ivp`` (DOP853, rtol 1e-10) per
  case with the slip (mu N - |F|) and lift-off (N) as terminal events. It measures the
  slip only (after the slip the motion changes mode, which SymPy + SciPy would need
  written by hand), so lamech is also timed measuring the slip only, on the same
  20 x 20 grid. The peer runs as its own script (``python -m bench.sweep peer``), a
  whole process like lamech's command, its imports and derivation included.
"""

from __future__ import annotations

import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

THETA0 = 0.01
T_END = 3.0
R2_RANGE = (0.2, 1.0)
MU_RANGE = (0.1, 0.6)
ROOT = Path(__file__).resolve().parents[1]


def slip_truth(mu: float, theta0: float = THETA0) -> float:
    """The slip angle from the energy integral (module docstring); nan past lift-off."""
    from scipy.optimize import brentq

    c0 = math.cos(theta0)
    lift = math.acos(4 * c0 / 7)
    h = lambda th: math.sin(th) - mu * (7 * math.cos(th) - 4 * c0)  # noqa: E731
    return brentq(h, theta0, lift, xtol=1e-15) if h(theta0) < 0 < h(lift) else math.nan


def lift_truth(theta0: float = THETA0) -> float:
    return math.acos(4 * math.cos(theta0) / 7)


def _grid(n_r2: int, n_mu: int) -> tuple[np.ndarray, np.ndarray]:
    return np.linspace(*R2_RANGE, n_r2), np.linspace(*MU_RANGE, n_mu)


def _timed(argv: list[str], env: dict) -> tuple[float, float, subprocess.CompletedProcess]:
    """Run a whole process: (wall s, CPU s of it and its children, the result)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run(argv, capture_output=True, text=True, env=env, timeout=3600)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if done.returncode != 0:
        raise RuntimeError(f"{argv[:4]} failed:\n{done.stderr[-2000:]}")
    return wall, cpu, done


def _lamech_sweep(n_r2, n_mu, measures, engine, out: Path, env) -> tuple[float, float, dict]:
    r2, mu = _grid(n_r2, n_mu)
    rng = lambda a, n: f"{a[0]}:{a[-1]}:{n}" if n > 1 else f"{a[0]}"  # noqa: E731
    argv = [
        sys.executable,
        "-m",
        "lamech",
        "sweep",
        "cylinder",
        "--param",
        f"R2={rng(r2, n_r2)}",
        "--param",
        f"mu={rng(mu, n_mu)}",
        "--initial",
        f"theta1={THETA0}",
        "--t-end",
        str(T_END),
        "--engine",
        engine,
        "--out",
        str(out),
    ]
    for m in measures:
        argv += ["--measure", m]
    if out.exists():
        out.unlink()
    wall, cpu, _ = _timed(argv, env)
    import csv

    with out.open(newline="") as fh:
        rows = list(csv.DictReader(fh))
    return wall, cpu, _errors(rows)


def _errors(rows: list[dict]) -> dict:
    """Largest slip- and lift-off-angle errors against the truth, and the statuses."""
    slip = lift = 0.0
    statuses: dict = {}
    for row in rows:
        statuses[row["status"]] = statuses.get(row["status"], 0) + 1
        want = slip_truth(float(row["mu"]))
        got = float(row.get("slip:theta1") or "nan")
        if not math.isnan(want):
            slip = max(slip, abs(got - want)) if not math.isnan(got) else math.inf
        if "liftoff:theta1" in row and math.isnan(want):  # lift-off only where it rolls
            lift = max(lift, abs(float(row["liftoff:theta1"]) - lift_truth()))
    return {"cases": len(rows), "slip": slip, "lift": lift, "statuses": statuses}


def _drop_problem_functions(cache: Path) -> None:
    """Forget the problem's own compiled functions (``lamech_<key>.py``, its C library
    ``lamech_c_<key>.so`` and their records): the next run compiles them again."""
    for path in cache.rglob("lamech_*"):
        if path.is_file():
            path.unlink()


# ----- the peer: SymPy + SciPy, run as its own process ------------------------------
def peer(n_r2: int, n_mu: int) -> dict:
    """SymPy's LagrangesMethod + lambdify + solve_ivp over the grid: the slip of every
    case (module docstring). Returns the cases' slip angles and the error against the
    truth."""
    import sympy as sp
    from scipy.integrate import solve_ivp
    from sympy.physics.mechanics import LagrangesMethod, dynamicsymbols

    m, g, R1, R2 = sp.symbols("m g R1 R2", positive=True)
    r, th1, th2 = dynamicsymbols("r theta1 theta2")
    t = dynamicsymbols._t
    L = m / 2 * (r.diff(t) ** 2 + r**2 * th1.diff(t) ** 2) + m * R2**2 / 4 * th2.diff(t) ** 2
    L -= m * g * r * sp.cos(th1)
    hol = [r - (R1 + R2), (R1 + R2) * th1 - R2 * th2]
    lm = LagrangesMethod(L, [r, th1, th2], hol_coneqs=hol)
    lm.form_lagranges_equations()
    n = 3
    # rows n.. of the full system: [M -A^T; A 0] [q''; lam] = [f; -A' q'], unknowns q'', lam
    Mf = lm.mass_matrix_full[n:, n:]
    ff = lm.forcing_full[n:, :]
    qs, us = [r, th1, th2], [c.diff(t) for c in (r, th1, th2)]
    Q, U = sp.symbols("q0:3"), sp.symbols("u0:3")
    rep = dict(zip(us, U)) | dict(zip(qs, Q))
    Mf, ff = Mf.xreplace(rep), ff.xreplace(rep)
    fn = sp.lambdify((Q, U, (m, g, R1, R2)), [Mf, ff], modules="numpy", cse=True)

    def solve(y, p):
        M, f = fn(y[:3], y[3:], p)
        return np.linalg.solve(np.asarray(M, float), np.asarray(f, float).ravel())

    r2s, mus = _grid(n_r2, n_mu)
    slips, worst = [], 0.0
    for R2v in r2s:
        p = (1.0, 9.81, 1.0, float(R2v))
        R = 1.0 + R2v
        y0 = np.array([R, THETA0, R * THETA0 / R2v, 0.0, 0.0, 0.0])
        for muv in mus:

            def rhs(_t, y, p=p):
                return np.concatenate([y[3:], solve(y, p)[:3]])

            def slip(_t, y, p=p, muv=muv):
                x = solve(y, p)
                return muv * x[3] - abs(x[4])

            def lift(_t, y, p=p):
                return solve(y, p)[3]

            slip.terminal = lift.terminal = True
            sol = solve_ivp(
                rhs, (0.0, T_END), y0, method="DOP853", rtol=1e-10, atol=1e-12, events=(slip, lift)
            )
            got = sol.y_events[0][0][1] if len(sol.t_events[0]) else math.nan
            want = slip_truth(float(muv))
            if not math.isnan(want):
                worst = max(worst, abs(got - want)) if not math.isnan(got) else math.inf
            slips.append(got)
    return {"cases": len(slips), "slip": worst}


def _peer_run(n_r2, n_mu, env) -> tuple[float, float, dict]:
    argv = [sys.executable, "-m", "bench.sweep", "peer", str(n_r2), str(n_mu)]
    wall, cpu, done = _timed(argv, env)
    return wall, cpu, json.loads(done.stdout.strip().splitlines()[-1])


# ----- the section ------------------------------------------------------------------
def _med(xs):
    return sorted(xs)[len(xs) // 2]


def _row(label, runs, extra="") -> tuple[str, float, float]:
    walls, cpus = [w for w, _, _ in runs], [c for _, c, _ in runs]
    info = runs[-1][2]
    err = f"slip error {info['slip']:.1e}"
    if info.get("lift"):
        err += f", lift-off {info['lift']:.1e}"
    if info.get("statuses"):
        err += ", " + ", ".join(f"{k} {v}" for k, v in sorted(info["statuses"].items()))
    line = (
        f"| {label} | {min(walls):.2f} / {_med(walls):.2f} / {max(walls):.2f} s | "
        f"{min(cpus):.2f} / {_med(cpus):.2f} / {max(cpus):.2f} s | {info['cases']} | "
        f"{err}{extra} |"
    )
    return line, _med(walls), _med(cpus)


def bench_b6(lines: list[str], repeats: int = 3, quick: bool = False) -> None:
    """Append B6's table to ``lines`` (the module docstring says what is run)."""
    print("\nB6  a sweep: the cylinder over R2 and mu, the whole `lamech sweep` command")
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    big = (10, 10) if quick else (50, 50)
    mid = (5, 4) if quick else (20, 20)
    rows: list[str] = []
    with tempfile.TemporaryDirectory(prefix="lamech-b6-") as tmp:
        tmp = Path(tmp)
        out = tmp / "sweep.csv"
        cache = Path(os.environ.get("LAMECH_CACHE_DIR") or tmp / "cache")
        env["LAMECH_CACHE_DIR"] = str(cache)
        both = ["slip", "liftoff"]
        # warm-up: the loop and the problem's functions compiled (not timed)
        _lamech_sweep(4, 4, both, "compiled", out, env)
        runs = [_lamech_sweep(*big, both, "auto", out, env) for _ in range(repeats)]
        line, w_big, c_big = _row(
            f"lamech, {big[0]}x{big[1]}, slip + lift-off, auto (compiled loop, cached)", runs
        )
        rows.append(line)
        print(line)
        runs = [_lamech_sweep(*mid, both, "python", out, env) for _ in range(1)]
        line, _, c_py = _row(
            f"lamech, {mid[0]}x{mid[1]}, slip + lift-off, the same loop as Python (one run)", runs
        )
        rows.append(line)
        print(line)
        # issue 31: 400 cases against one, the problem's own functions new each run
        one, many = [], []
        for _ in range(repeats):
            _drop_problem_functions(cache)
            one.append(_lamech_sweep(1, 1, both, "auto", out, env))
            _drop_problem_functions(cache)
            many.append(_lamech_sweep(*mid, both, "auto", out, env))
        line1, _, c_one = _row("lamech, 1 case, the problem's functions new", one)
        line2, _, c_many = _row(
            f"lamech, {mid[0] * mid[1]} cases, the problem's functions new", many
        )
        rows += [line1, line2]
        print(line1)
        print(line2)
        # the peer against lamech on the same grid, slip only
        mine = [_lamech_sweep(*mid, ["slip"], "auto", out, env) for _ in range(repeats)]
        theirs = [_peer_run(*mid, env) for _ in range(repeats)]
        line_m, w_m, c_m = _row(f"lamech, {mid[0]}x{mid[1]}, slip only, auto", mine)
        line_p, w_p, c_p = _row(
            f"SymPy + SciPy, {mid[0]}x{mid[1]}, slip only "
            "(LagrangesMethod, lambdify cse, solve_ivp DOP853 events)",
            theirs,
        )
        rows += [line_m, line_p]
        print(line_m)
        print(line_p)
    lines += [
        "## B6 a sweep, the whole command",
        "",
        "The cylinder from rest at theta0 = 0.01, R2 in 0.2–1, mu in 0.1–0.6, to t = 3 "
        "(`bench/sweep.py`). Each row a whole process: wall and CPU time min / median / "
        "max of the runs; errors of the slip and lift-off angles against the energy "
        "integral's roots.",
        "",
        "| run | wall | CPU | cases | result |",
        "|---|---|---|---|---|",
        *rows,
        "",
        f"- {mid[0] * mid[1]} cases / 1 case, the problem's functions new, CPU: "
        f"{c_many / c_one:.2f}x (issue 31's target: at most 1.5x)",
        f"- SymPy + SciPy / lamech on the same {mid[0] * mid[1]} cases (slip only): "
        f"{w_p / w_m:.1f}x wall, {c_p / c_m:.1f}x CPU",
        f"- the same loop as Python / compiled, per case, CPU: "
        f"{(c_py / (mid[0] * mid[1])) / (c_big / (big[0] * big[1])):.0f}x",
        "",
    ]


if __name__ == "__main__":
    if sys.argv[1:2] == ["peer"]:
        print(json.dumps(peer(int(sys.argv[2]), int(sys.argv[3]))))
    else:
        sys.exit("usage: python -m bench.sweep peer N_R2 N_MU (B6 runs from python -m bench)")
