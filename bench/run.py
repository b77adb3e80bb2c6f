"""lamech's benchmarks, each side by side with its peers in this one process.

    .venv/bin/python -m bench            # the full suite (about 20 minutes on 2 cores)
    .venv/bin/python -m bench --quick    # smaller sizes and caps (about 4 minutes)

Needs the optional extra ``bench`` (``pip install -e '.[bench]'``: mujoco, pydy, Cython,
casadi; a C compiler for PyDy, for CasADi's JIT and for lamech's own functions, which its
engine in C, built at install, calls). The model everywhere is the
planar N-link pendulum chain (point masses m = 1, links l = 1, g = 9.81, all links 30°
from the vertical at rest): in maximal coordinates (x_i, y_i, one length constraint per
link) for lamech, SymPy, PyDy and CasADi, as a hinge chain for MuJoCo.

Timing: lamech's runs and its peers' are interleaved (:func:`interleave`: every case
once per round, 3 rounds, the order reversed every other round), and each row gives the
min / median / max of wall and CPU time (``time.process_time``: the process's, all its
threads; B1's runs are forked children and time themselves); ratios are of medians.

B1  derivation + code generation: model -> first numeric (q'', lambda), every repeat in
    a forked child on an empty SymPy cache.
B2  one dynamics evaluation (q'' and lambda), microseconds per call.
B3  work-precision: wall time against the error of the rod tensions and the positions
    at t = 10 s, against a tight lamech reference run (rtol 1e-13), with lamech's
    ``simulate`` and compiled loop, MuJoCo, SymPy + solve_ivp and CasADi + CVODES; the
    same read at equal error (:func:`at_error`); then the long chains, N = 60 and 100
    (``--quick``: 60), with wall and CPU time.
B4  ensembles: trajectories per second over many initial conditions.
B5  symbolic: derivation to the multipliers (equations -> every lambda in closed form),
    lamech's ``lamech.symbolic.multipliers`` against SymPy's LagrangesMethod +
    form_lagranges_equations() + solve_multipliers() on the same Lagrangian and
    constraints, each from the loaded System, every repeat in a forked child on an
    empty SymPy cache; beside them lamech's whole report (load + solve); for the
    four-bar linkage, the rolling disc and the double pendulum (polar and Cartesian);
    runs alone with ``--only B5`` (or ``--only symbolic``).
B9  whole process (bench/solve.py): `lamech solve FILE` against a SymPy script
    (LagrangesMethod + solve_multipliers) on the same problem, CPU time of each child
    process, interleaved, beside `python -c "import sympy"`.
B10 a map of regimes (bench/map.py): `lamech.map` from the closed forms, points per CPU
    second after start-up, beside `lamech sweep` simulating B6's cases.
B7  ensembles with events (bench/events.py): 1000 balls dropped on a floor (first
    contact) and 1000 cylinders rolling off the lecture's fixed cylinder (lift-off),
    lamech's ``integrate_events`` against ``mujoco.rollout``, runs/s at equal accuracy of
    the event times (true times in closed form and by quadrature).

Results go to stdout (with lamech/peer ratios) and to bench/RESULTS.md (date, CPU,
versions); B3 also draws bench/work_precision.png.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import math
import multiprocessing as mp
import os
import platform
import statistics
import sys
import time
import timeit
from pathlib import Path
from typing import NamedTuple

import numpy as np

HERE = Path(__file__).resolve().parent
L, G = 1.0, 9.81
ANGLE = math.radians(30.0)
_COLOURS = {
    "lamech": "tab:red",
    "lamech kernel": "tab:purple",
    "MuJoCo Euler": "tab:blue",
    "MuJoCo RK4": "tab:orange",
    "SymPy+solve_ivp": "tab:green",
}


# ----- models -------------------------------------------------------------------------
def lamech_chain(n: int):
    import lamech
    from lamech.problem import chain_toml

    return lamech.loads(chain_toml(n))


def sympy_chain(n: int):
    """The same chain for sympy.physics.mechanics: (LagrangesMethod, q, params)."""
    import sympy as sp
    from sympy.physics.mechanics import LagrangesMethod, dynamicsymbols

    x = dynamicsymbols(f"x1:{n + 1}")
    y = dynamicsymbols(f"y1:{n + 1}")
    m, g, l = sp.symbols("m g l", positive=True)
    t = dynamicsymbols._t
    T = m / 2 * sum(sp.diff(a, t) ** 2 + sp.diff(b, t) ** 2 for a, b in zip(x, y))
    V = m * g * sum(y)
    hol = [
        (x[i] - (x[i - 1] if i else 0)) ** 2 + (y[i] - (y[i - 1] if i else 0)) ** 2 - l**2
        for i in range(n)
    ]
    q = [c for pair in zip(x, y) for c in pair]
    return LagrangesMethod(T - V, q, hol_coneqs=hol), q, (m, g, l)


def chain_state(n: int, angles=None):
    """Positions (x1, y1, x2, y2, ...) of the chain with link angles ``angles`` (from the
    vertical), at rest."""
    angles = np.full(n, ANGLE) if angles is None else np.asarray(angles, float)
    xs = np.cumsum(L * np.sin(angles))
    ys = -np.cumsum(L * np.cos(angles))
    return np.column_stack((xs, ys)).ravel()


def mujoco_chain(n: int, integrator: str = "RK4", dt: float = 1e-3):
    """A hinge chain in the x-z plane: each body's joint at the previous mass, its mass
    (1, inertia 1e-12: a point) one unit further down."""
    import mujoco

    body = ""
    for i in range(n, 0, -1):
        pos = "0 0 0" if i == 1 else "0 0 -1"
        body = (
            f'<body name="b{i}" pos="{pos}"><joint type="hinge" axis="0 1 0"/>'
            f'<inertial pos="0 0 -1" mass="1" diaginertia="1e-12 1e-12 1e-12"/>{body}</body>'
        )
    xml = (
        f'<mujoco><option gravity="0 0 -{G}" timestep="{dt}" integrator="{integrator}">'
        f'<flag contact="disable"/></option><worldbody>{body}</worldbody></mujoco>'
    )
    model = mujoco.MjModel.from_xml_string(xml)
    return model, mujoco.MjData(model)


def mujoco_angles(angles: np.ndarray) -> np.ndarray:
    """Hinge angles (relative, about +y) for absolute link angles from the vertical
    (lamech's x = +sin: a rotation about +y by -a)."""
    a = -np.asarray(angles, float)
    return np.concatenate(([a[0]], np.diff(a)))


def mujoco_masses(model, data, n: int) -> np.ndarray:
    return np.array(
        [data.xpos[i] + data.xmat[i].reshape(3, 3) @ (0.0, 0.0, -1.0) for i in range(1, n + 1)]
    )


def mujoco_tensions(model, data, n: int) -> np.ndarray:
    """Rod tensions from the joint reactions: cfrc_int (force part) of each body, the
    force its parent exerts on it, projected on the link towards the pivot. With a
    massless link and a hinge that force lies along the link."""
    import mujoco

    mujoco.mj_forward(model, data)  # accelerations at this state (after RK4, the
    mujoco.mj_rnePostConstraint(model, data)  # stored ones are from the last stage)
    P = mujoco_masses(model, data, n)
    pivots = np.vstack(([0.0, 0.0, 0.0], P[:-1]))
    out = np.empty(n)
    for i in range(n):
        u = pivots[i] - P[i]
        out[i] = data.cfrc_int[i + 1][3:6] @ (u / np.linalg.norm(u))
    return out


def casadi_chain(n: int):
    """The same maximal-coordinate chain in CasADi's SX: ``(x, p, ode, lam)`` with the
    state x = (q, q'), q = (x1, y1, ..., xn, yn), parameters p = (m, g, l), ode = (q',
    q'') and lam lamech's multipliers. The index-1 DAE as an ODE: with M = m I the KKT
    system M q'' - A^T lam = Q, A q'' = -gamma (A = df/dq, gamma = (A q')' q') is
    solved through its Schur complement, (A A^T) lam = -m gamma - A Q (CasADi's
    symbolic ``solve``; the full 3N-square KKT solve gives the same numbers, with 10x the
    nodes at N = 5 and 47x at N = 20), q'' = (Q + A^T lam) / m."""
    import casadi as ca

    q, v = ca.SX.sym("q", 2 * n), ca.SX.sym("v", 2 * n)
    m, g, l = ca.SX.sym("m"), ca.SX.sym("g"), ca.SX.sym("l")
    f = ca.vertcat(
        *[
            (q[2 * i] - (q[2 * i - 2] if i else 0)) ** 2
            + (q[2 * i + 1] - (q[2 * i - 1] if i else 0)) ** 2
            - l**2
            for i in range(n)
        ]
    )
    A = ca.jacobian(f, q)
    gamma = ca.jtimes(A @ v, q, v)
    Q = ca.vertcat(*[0 if k % 2 == 0 else -m * g for k in range(2 * n)])
    lam = ca.solve(A @ A.T, -m * gamma - A @ Q)
    qdd = (Q + A.T @ lam) / m
    return ca.vertcat(q, v), ca.vertcat(m, g, l), ca.vertcat(v, qdd), lam


def casadi_jit_works() -> bool:
    """Whether CasADi's JIT (the shell compiler: the system's cc) compiles here."""
    import shutil

    return shutil.which(os.environ.get("CC", "gcc")) is not None or shutil.which("cc") is not None


class CasadiChain:
    """CasADi's peer: ``(q'', lam)`` of :func:`casadi_chain` as one CasADi Function and
    CVODES (Adams–Moulton, functional iteration: no Jacobian, as for a non-stiff ODE)
    integrators over [0, t_end], one per tolerance. With ``jit`` the right-hand side is
    compiled to C by CasADi's JIT (the shell compiler, gcc -O2: 0.5 s for the 20-link
    chain's 3000-node function, where -O3 took 337 s and ran 2-4% faster) and called by
    the integrator through an MX wrapper (as fast as a JIT of the integrator's own
    functions, or parameters folded in as constants); otherwise CasADi's SX virtual
    machine evaluates it (1.5x the time on the 5-link chain)."""

    FLAGS = "-O2"

    def __init__(self, n: int, jit: bool):
        import shutil
        import tempfile
        import weakref

        import casadi as ca

        self.n, self.jit = n, jit
        x, p, ode, lam = casadi_chain(n)
        self.params = np.array([1.0, G, L])
        self.accel = ca.Function("chain_accel", [x, p], [ode, lam])
        if jit:
            self._dir = tempfile.mkdtemp(prefix="lamech-bench-casadi-")
            weakref.finalize(self, shutil.rmtree, self._dir, True)
            # the folder removed with this object (CasADi's own clean-up off: it would
            # warn about the files removed under it; the loaded library stays mapped)
            opts = {
                "jit": True,
                "compiler": "shell",
                "jit_cleanup": False,
                "jit_name": "chain_rhs",
                "jit_options": {
                    "flags": [self.FLAGS],
                    "verbose": False,
                    "directory": self._dir + os.sep,
                    "cleanup": False,
                },
            }
            rhs = ca.Function("chain_rhs", [x, p], [ode], opts)
            X, P = ca.MX.sym("x", x.shape[0]), ca.MX.sym("p", p.shape[0])
            self._dae = {"x": X, "p": P, "ode": rhs(X, P)}
        else:
            self._dae = {"x": x, "p": p, "ode": ode}
        self._integrators = {}

    @property
    def label(self) -> str:
        return (
            f"CasADi CVODES Adams (JIT gcc {self.FLAGS})"
            if self.jit
            else "CasADi CVODES Adams (SX VM)"
        )

    def tensions(self, y) -> np.ndarray:
        """Rod tensions -2 l lam at the state y (lamech's sign and scaling)."""
        return -2 * L * np.asarray(self.accel(y, self.params)[1], dtype=float).ravel()

    def integrator(self, t_end: float, rtol: float, atol: float | None = None):
        """CVODES over [0, t_end] at (rtol, atol) (atol = rtol / 100 unless given),
        built once."""
        import casadi as ca

        atol = rtol * 1e-2 if atol is None else atol
        key = (t_end, rtol, atol)
        if key not in self._integrators:
            self._integrators[key] = ca.integrator(
                "chain",
                "cvodes",
                self._dae,
                0.0,
                t_end,
                {
                    "reltol": rtol,
                    "abstol": atol,
                    "linear_multistep_method": "adams",
                    "nonlinear_solver_iteration": "functional",
                    "max_num_steps": 10**8,
                },
            )
        return self._integrators[key]

    def run(self, y0, t_end: float, rtol: float, atol: float | None = None):
        """(wall, CPU, positions, tensions) at t_end from y0 (the integrator built
        beforehand, outside the time)."""
        F = self.integrator(t_end, rtol, atol)
        w0, c0 = time.perf_counter(), time.process_time()
        yT = np.asarray(F(x0=y0, p=self.params)["xf"], dtype=float).ravel()
        T = self.tensions(yT)
        wall, cpu = time.perf_counter() - w0, time.process_time() - c0
        return wall, cpu, yT[: 2 * self.n], T

    def ensemble(self, Y0, t_end: float, rtol: float, atol: float | None, threads: int):
        """Final states of every row of Y0: the integrator mapped over the batch
        (``Function.map(count, "thread", threads)``, CasADi's threads)."""
        F = self.integrator(t_end, rtol, atol)
        key = ("map", len(Y0), t_end, rtol, atol, threads)
        if key not in self._integrators:
            self._integrators[key] = F.map(len(Y0), "thread", threads)
        out = self._integrators[key](
            x0=np.asarray(Y0).T, p=np.tile(self.params[:, None], (1, len(Y0)))
        )
        return np.asarray(out["xf"], dtype=float).T


# ----- helpers ------------------------------------------------------------------------
def _capped(fn, args, cap: float, cold: bool = False):
    """Run fn(*args) in a forked process: (result, wall seconds, CPU seconds of the child,
    all its threads), or (None, None, None) past ``cap``. ``cold``: SymPy's cache cleared
    in the child first (outside the time), so each run pays for its own expressions."""
    ctx = mp.get_context("fork")
    queue = ctx.Queue()

    def target():
        if cold:
            from sympy.core.cache import clear_cache

            clear_cache()
        t0, c0 = time.perf_counter(), time.process_time()
        try:
            res = fn(*args)
        except Exception as exc:  # report, don't hang
            queue.put(("error", repr(exc), time.perf_counter() - t0, None))
            return
        queue.put(("ok", res, time.perf_counter() - t0, time.process_time() - c0))

    proc = ctx.Process(target=target)
    proc.start()
    proc.join(cap)
    if proc.is_alive():
        proc.kill()
        proc.join()
        return None, None, None
    kind, res, sec, cpu = queue.get(timeout=5)
    if kind == "error":
        raise RuntimeError(res)
    return res, sec, cpu


class Spread(NamedTuple):
    """min / median / max of repeated measurements."""

    min: float
    median: float
    max: float


def spread(values) -> Spread:
    values = [float(v) for v in values]
    return Spread(min(values), statistics.median(values), max(values))


class Timed(NamedTuple):
    """One case's repeated runs: wall and CPU time (min / median / max) and the results
    of its last run (the same every run: the methods are deterministic)."""

    wall: Spread
    cpu: Spread
    result: tuple
    runs: int


def interleave(cases, repeats: int = 3, alone_after: float | None = None) -> dict:
    """Run every case of ``cases`` ((key, fn) pairs; fn() returns (wall, cpu, *results),
    or None when it was stopped at a cap) once per round, ``repeats`` rounds, the order
    reversed every other round (A B C, C B A, A B C): load that comes and goes on a
    shared machine falls on lamech's and the peers' runs alike, and a slow drift cancels
    out. A case that was stopped, or whose first run took longer than ``alone_after``
    seconds, is not repeated. Returns {key: Timed, or None if stopped}."""
    cases = list(cases)
    runs: dict = {key: [] for key, _ in cases}
    stopped: set = set()
    for r in range(repeats):
        for key, fn in cases if r % 2 == 0 else cases[::-1]:
            if key in stopped or (
                r and alone_after is not None and runs[key] and runs[key][0][0] > alone_after
            ):
                continue
            out = fn()
            if out is None:
                stopped.add(key)
                continue
            runs[key].append(tuple(out))
    result = {}
    for key, got in runs.items():
        if key in stopped or not got:
            result[key] = None
            continue
        result[key] = Timed(
            spread(g[0] for g in got), spread(g[1] for g in got), got[-1][2:], len(got)
        )
    return result


def at_error(points, target: float) -> float | None:
    """A method's time at ``target`` error, interpolated log-log between the two
    settings around it on the method's Pareto front (the settings that no other setting
    beats in both time and error); None outside the errors it reached. ``points``:
    (time, error) pairs."""
    pts = sorted((e, t) for t, e in points if e > 0 and t > 0)
    front: list = []
    for e, t in pts:  # by error, ascending: keep the ever faster
        if not front or t < front[-1][1]:
            front.append((e, t))
    if not front or not front[0][0] <= target <= front[-1][0]:
        return None
    for (e0, t0), (e1, t1) in zip(front, front[1:]):
        if e0 <= target <= e1:
            w = math.log(target / e0) / math.log(e1 / e0)
            return math.exp(math.log(t0) + w * math.log(t1 / t0))
    return front[0][1]  # a single point, exactly at the target


def _fmt_spread(sp: Spread | None) -> str:
    """min / median / max in the median's unit."""
    if sp is None:
        return "—"
    if sp.median >= 0.01:
        return f"{sp.min:.3g} / {sp.median:.3g} / {sp.max:.3g} s"
    return f"{sp.min * 1e3:.3g} / {sp.median * 1e3:.3g} / {sp.max * 1e3:.3g} ms"


def _fmt_s(x):
    return "—" if x is None else (f"{x:.3g} s" if x >= 0.01 else f"{x * 1e3:.3g} ms")


def _compiled() -> bool:
    """Whether lamech's engine in C (built at install) and a C compiler for each
    problem's functions are there."""
    from lamech.numeric import compiled_available

    return bool(compiled_available())


def kernel_inputs(ns):
    m = ns.m
    q, v = ns.initial_state()
    y = np.concatenate((q, v))
    rows = np.arange(m, dtype=np.int64)
    empty = np.zeros(0, dtype=np.int64)
    return y, ns.parameters, rows, empty, empty, np.zeros(0)


def lamech_qdd_lambda(ns):
    """(q'', lambda) at the initial state, from the compiled KKT solve."""
    y, p, *_ = kernel_inputs(ns)
    sol = ns.accelerations(0.0, y, p)
    return sol[: ns.n], sol[ns.n :]


# ----- B1 -----------------------------------------------------------------------------
def lamech_b1(n: int, jit: bool):
    from lamech.numeric import compile_system

    t0 = time.perf_counter()
    ns = compile_system(lamech_chain(n), jit=jit)
    y, p, *_ = kernel_inputs(ns)
    out = ns.accelerations(0.0, y, p)
    return time.perf_counter() - t0, np.asarray(out)[: ns.n]


def sympy_b1(n: int, cse: bool):
    import sympy as sp
    from sympy.physics.mechanics import dynamicsymbols

    lm, q, (m, g, l) = sympy_chain(n)
    lm.form_lagranges_equations()
    rhs = lm.rhs()
    qd = [c.diff(dynamicsymbols._t) for c in q]
    f = sp.lambdify((q, qd, (m, g, l)), list(rhs), cse=cse)
    out = np.array(f(chain_state(n), np.zeros(2 * n), (1.0, G, L)), dtype=float).ravel()
    return out[2 * n : 4 * n]


def _lamech_b1_first(n: int, jit: bool, root: str):
    """(q'') of :func:`lamech_b1`; with ``jit`` the compiled-system cache in a new folder
    under ``root`` ($LAMECH_CACHE_DIR), so every repeat compiles, as for a new model,
    and none loads an earlier repeat's machine code."""
    if jit:
        import tempfile

        os.environ["LAMECH_CACHE_DIR"] = tempfile.mkdtemp(dir=root)
    return lamech_b1(n, jit)[1]


B1_METHODS = [
    ("lamech", "lamech `compile_system` + first `accelerations`"),
    ("lamech (C)", "lamech, engine in C (`jit=True`: its C compiled, cache empty)"),
    ("SymPy", "SymPy `LagrangesMethod` + `rhs()` + `lambdify`"),
    ("SymPy cse", "same, `lambdify(cse=True)`"),
]


def bench_b1(sizes, cap: float, lines: list[str], repeats: int = 3, alone_after: float = 30.0):
    import shutil
    import tempfile

    print("\nB1  derivation + code generation: model -> first (q'', lambda)")
    lines += [
        "## B1 derivation and code generation",
        "",
        "Time from the model (problem text) to the first numeric evaluation of (q'', "
        "λ). SymPy: `LagrangesMethod(L, q, hol_coneqs)`, `form_lagranges_equations()`, "
        "`rhs()`, `lambdify` (default printer, and `cse=True`). Every run in its own "
        "forked process on an empty SymPy cache (`clear_cache()`, lamech and SymPy "
        "alike; modules imported beforehand); lamech's C runs each with an empty "
        f"compiled-system cache. {repeats} interleaved repeats (per N: lamech, "
        "C, SymPy, SymPy cse, then the other way round); a run over "
        f"{alone_after:.0f} s is not repeated; each capped at {cap:.0f} s, and a "
        "SymPy variant past the cap is not run at larger N. Wall time min / median "
        "/ max; CPU time of the child process (all threads); ratio of medians. "
        "Both sides' q'' agree at the initial state before a time counts.",
        "",
        "| N | method | wall min / median / max | CPU min / median / max | runs "
        "| median / lamech's |",
        "|---|---|---|---|---|---|",
    ]
    jit = _compiled()
    lamech_b1(2, jit=False)  # imports (lamech, SymPy) outside the time
    sympy_b1(2, cse=True)
    root = tempfile.mkdtemp(prefix="lamech-bench-b1-")
    past_cap: dict = {}  # SymPy variant -> the N where it passed the cap

    def case(fn, *args):
        def run():
            res, sec, cpu = _capped(fn, args, cap, cold=True)
            return None if res is None else (sec, cpu, res)

        return run

    try:
        for n in sizes:
            cases = [("lamech", case(_lamech_b1_first, n, False, root))]
            if jit:
                cases.append(("lamech (C)", case(_lamech_b1_first, n, True, root)))
            for key, cse in (("SymPy", False), ("SymPy cse", True)):
                if key not in past_cap:
                    cases.append((key, case(sympy_b1, n, cse)))
            got = interleave(cases, repeats, alone_after)
            qdd = got["lamech"].result[0]
            for key in ("SymPy", "SymPy cse"):
                if got.get(key) is None and key in got:
                    past_cap[key] = n
                elif key in got and not np.allclose(got[key].result[0], qdd, rtol=1e-8, atol=1e-9):
                    raise AssertionError(f"B1 N={n}: {key} and lamech disagree on q''")
            base = got["lamech"].wall.median
            for key, label in B1_METHODS:
                if key == "lamech (C)" and not jit:
                    continue
                t = got.get(key)
                if t is not None:
                    ratio = "—" if key == "lamech" else f"{t.wall.median / base:.3g}×"
                    row = (
                        f"| {n} | {label} | {_fmt_spread(t.wall)} | {_fmt_spread(t.cpu)} "
                        f"| {t.runs} | {ratio} |"
                    )
                else:
                    why = "" if key in got else f" (not run: past the cap at N = {past_cap[key]})"
                    row = f"| {n} | {label} | > {cap:.0f} s{why} | — | — | > {cap / base:.3g}× |"
                print("  " + row)
                lines.append(row)
    finally:
        shutil.rmtree(root, ignore_errors=True)
    lines.append("")


# ----- B2 -----------------------------------------------------------------------------
def _per_call_case(fn, budget=0.2):
    """A case for :func:`interleave`: ``fn`` called in a loop for about ``budget`` s,
    returning (wall, CPU) seconds per call, the better of 3 such loops."""
    number = max(1, int(timeit.Timer(fn).autorange()[0] * budget / 0.2))

    def case():
        best = None
        for _ in range(3):
            w, c = time.perf_counter(), time.process_time()
            for _ in range(number):
                fn()
            got = ((time.perf_counter() - w) / number, (time.process_time() - c) / number)
            best = got if best is None or got[0] < best[0] else best
        return best

    return case


def pydy_chain(n: int):
    """PyDy's Cython back end on SymPy's chain: ``(f, N)`` with ``f(x, v, c)`` returning the
    solution [q'; q''; lambda] of the full system M_full z = F_full (PyDy's
    ``CythonMatrixGenerator`` evaluates the matrices, ``numpy.linalg.solve`` solves them,
    as ``pydy.codegen.ode_function_generators`` does). None when pydy or Cython is
    missing, or no C compiler works."""
    import tempfile

    import sympy as sp
    from sympy.physics.mechanics import dynamicsymbols

    try:
        from pydy.codegen.cython_code import CythonMatrixGenerator
    except ImportError:
        return None
    lm, q, (m, g, l) = sympy_chain(n)
    lm.form_lagranges_equations()
    t = dynamicsymbols._t
    qs, us = sp.symbols(f"q0:{2 * n}"), sp.symbols(f"u0:{2 * n}")
    plain = {**dict(zip([c.diff(t) for c in q], us)), **dict(zip(q, qs))}
    MM, FF = lm.mass_matrix_full.subs(plain), lm.forcing_full.subs(plain)
    try:
        fm = CythonMatrixGenerator([qs, us, (m, g, l)], [MM, FF]).compile(
            tmp_dir=tempfile.mkdtemp(prefix="lamech-bench-pydy-")
        )
    except Exception as exc:  # noqa: BLE001 - a missing compiler shows up here
        print(f"  (PyDy's Cython back end unavailable: {exc})")
        return None
    N = MM.shape[0]
    Mo, Fo = np.empty(N * N), np.empty(N)

    def f(x, v, c):
        Mv, Fv = fm(x, v, c, Mo, Fo)
        return np.linalg.solve(Mv.reshape(N, N), Fv)

    return f, N


def bench_b2(sizes, lines: list[str], repeats: int = 3):
    import sympy as sp
    from sympy.physics.mechanics import dynamicsymbols

    from lamech.numeric import compile_system

    print("\nB2  one dynamics evaluation (q'' and lambda), µs per call")
    lines += [
        "## B2 one dynamics evaluation",
        "",
        "One evaluation of (q'', λ) at the initial state, called from Python. Each "
        f"method is timed in a loop of about 0.2 s (the best of 3 loops), in {repeats} "
        "interleaved rounds (every method once per round, the order reversed every "
        "other round); cells give the median wall time per call, in brackets the "
        "median CPU time, then the min–max wall time over the rounds. lamech: "
        "`NumericSystem.accelerations(t, y, p)` (NumPy: generated M, Q − h, A, γ "
        "plus `numpy.linalg.solve` of the KKT matrix; C: the generated functions "
        "compiled to C, the KKT solve in lamech's engine in C, M diagonal so λ from the Schur "
        "complement A M⁻¹ Aᵀ over the structural nonzeros of M and A, which the "
        "generated code gives as vectors: nothing of size N² is filled per call). "
        "Peers: `lambdify(cse=True)` of SymPy's `LagrangesMethod.rhs()` (N ≤ 8; "
        "larger `rhs()` does not finish); PyDy's Cython back end "
        "(`CythonMatrixGenerator` for `mass_matrix_full`, `forcing_full`, then "
        "`numpy.linalg.solve`, as PyDy's ODE function does). Every peer's q'' and λ "
        "agree with lamech's before a time counts.",
        "",
        "| N | lamech NumPy | lamech C | SymPy lambdify(cse=True) | PyDy Cython "
        "| lambdify/lamech C | PyDy/lamech C |",
        "|---|---|---|---|---|---|---|",
    ]
    for n in sizes:
        ns = compile_system(lamech_chain(n))
        y, p, *_ = kernel_inputs(ns)
        ref = ns.accelerations(0.0, y, p)
        cases = [("numpy", lambda ns=ns: ns.accelerations(0.0, y, p))]
        if _compiled():
            nj = compile_system(lamech_chain(n), jit=True)
            nj.accelerations(0.0, y, p)
            cases.append(("C", lambda: nj.accelerations(0.0, y, p)))
        x0, v0, c0 = chain_state(n), np.zeros(2 * n), (1.0, G, L)

        def agree(out, who):
            out = np.asarray(out, dtype=float).ravel()
            qdd, lam = out[2 * n : 4 * n], out[4 * n : 5 * n]
            if not (
                np.allclose(qdd, ref[: 2 * n], rtol=1e-8, atol=1e-9)
                and np.allclose(lam, ref[2 * n :], rtol=1e-8, atol=1e-9)
            ):
                raise AssertionError(f"B2 N={n}: {who} and lamech disagree on (q'', λ)")

        if n <= 8:
            lm, q, (m, g, l) = sympy_chain(n)
            lm.form_lagranges_equations()
            t = dynamicsymbols._t
            f = sp.lambdify((q, [c.diff(t) for c in q], (m, g, l)), list(lm.rhs()), cse=True)
            agree(f(x0, v0, c0), "SymPy")
            cases.append(("sympy", lambda f=f: f(x0, v0, c0)))
            built = pydy_chain(n)
            if built is not None:
                fp, _ = built
                c_arr = np.array(c0)
                agree(fp(x0, v0, c_arr), "PyDy")
                cases.append(("pydy", lambda fp=fp: fp(x0, v0, c_arr)))
        got = interleave([(k, _per_call_case(fn)) for k, fn in cases], repeats)

        def us(key):
            timed = got.get(key)
            if timed is None:
                return "—"
            w, c = timed.wall, timed.cpu
            return (
                f"{w.median * 1e6:.3g} µs ({c.median * 1e6:.3g}); "
                f"{w.min * 1e6:.3g}–{w.max * 1e6:.3g}"
            )

        def ratio(key):
            if got.get(key) is None or got.get("C") is None:
                return "—"
            return f"{got[key].wall.median / got['C'].wall.median:.1f}×"

        row = (
            f"| {n} | {us('numpy')} | {us('C')} | {us('sympy')} | {us('pydy')} "
            f"| {ratio('sympy')} | {ratio('pydy')} |"
        )
        print("  " + row)
        lines.append(row)
    lines.append("")


# ----- B3 -----------------------------------------------------------------------------
class _Clock:
    """Wall and CPU time (the process's, all its threads) of a ``with`` block."""

    def __enter__(self):
        self._w, self._c = time.perf_counter(), time.process_time()
        return self

    def __exit__(self, *exc):
        self.wall = time.perf_counter() - self._w
        self.cpu = time.process_time() - self._c


def lamech_run(system, t_end, rtol, jit, ns=None):
    """lamech's ``simulate``: (wall, CPU, positions, tensions) at t_end."""
    from lamech.numeric import simulate

    with _Clock() as clock:
        tr = simulate(
            ns if ns is not None else system,
            t_end,
            rtol=rtol,
            atol=min(1e-12, rtol * 1e-2),
            samples=2,
            jit=jit,
        )
    if tr.status != "ok":
        raise RuntimeError(tr.message)
    return clock.wall, clock.cpu, tr.q[-1], -2 * L * tr.lambdas[-1]


def _kernel_run(ns, y0, t_end, rtol):
    """lamech's compiled loop on one trajectory (``integrate_batch`` of a batch of one:
    the serial loop, no thread to wake): (wall, CPU, positions, tensions)."""
    from lamech.numeric import integrate_batch

    with _Clock() as clock:
        res = integrate_batch(ns, y0, t_end, rtol=rtol, atol=min(1e-12, rtol * 1e-2))
    return clock.wall, clock.cpu, res.q[0], -2 * L * res.lambdas[0]


def mujoco_run(n, angles, integrator, dt, t_end):
    """MuJoCo, ``mj_step`` at fixed dt: (wall, CPU, positions, tensions) at t_end. The
    positions and tensions after ``mj_forward`` at the final state: after ``mj_step``
    the stored body positions are those its last (RK4: last stage's) forward pass
    computed, not the new state's."""
    import mujoco

    model, data = mujoco_chain(n, integrator, dt)
    data.qpos[:] = mujoco_angles(angles)
    mujoco.mj_forward(model, data)
    steps = int(round(t_end / dt))
    if abs(steps * dt - t_end) > 1e-9 * t_end:
        raise ValueError(f"dt = {dt} does not divide t_end = {t_end}")
    with _Clock() as clock:
        for _ in range(steps):
            mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    P = mujoco_masses(model, data, n)
    return clock.wall, clock.cpu, P[:, [0, 2]].ravel(), mujoco_tensions(model, data, n)


def _sympy_ivp_run(f, n, t_end, rtol):
    """SymPy's lambdified rhs() under solve_ivp(DOP853): (wall, CPU, positions,
    tensions); LagrangesMethod's multipliers have lamech's sign and scaling."""
    from scipy.integrate import solve_ivp

    y0 = np.concatenate((chain_state(n), np.zeros(2 * n)))

    def rhs(t, y):
        out = np.asarray(f(y[: 2 * n], y[2 * n :], (1.0, G, L)), dtype=float).ravel()
        return out[: 4 * n]

    with _Clock() as clock:
        sol = solve_ivp(rhs, (0, t_end), y0, method="DOP853", rtol=rtol, atol=rtol * 1e-2)
    yT = sol.y[:, -1]
    lam = np.asarray(f(yT[: 2 * n], yT[2 * n :], (1.0, G, L)), dtype=float).ravel()[4 * n :]
    return clock.wall, clock.cpu, yT[: 2 * n], -2 * L * lam


def casadi_peer(n: int, ns):
    """CasADi's chain, checked against lamech's: its tensions at the initial state agree
    with lamech's (else AssertionError). None when casadi is not installed."""
    try:
        import casadi  # noqa: F401
    except ImportError:
        return None
    peer = CasadiChain(n, jit=casadi_jit_works())
    _, lam = lamech_qdd_lambda(ns)
    y0 = np.concatenate((chain_state(n), np.zeros(2 * n)))
    if not np.allclose(peer.tensions(y0), -2 * L * lam, rtol=1e-9, atol=1e-9):
        raise AssertionError(f"N={n}: CasADi's and lamech's tensions disagree at the start")
    return peer


# CasADi's settings: reltol with abstol = reltol / 100 (lamech's rule), and every other
# decade with abstol = reltol (cheaper at a given reltol; the curve takes the best of both)
CASADI_SETTINGS = [
    (r, r * 1e-2) for r in (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13, 1e-14)
] + [(r, r) for r in (1e-6, 1e-8, 1e-10, 1e-12, 1e-14)]
CASADI_QUICK = [(1e-6, 1e-8), (1e-9, 1e-11), (1e-12, 1e-14), (1e-14, 1e-16)]
B3_TARGETS = (1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12)
B3_PEERS = ("lamech", "CasADi", "MuJoCo RK4", "SymPy+solve_ivp")


def bench_b3(sizes, t_end, quick, lines: list[str], repeats: int = 3):
    import sympy as sp
    from sympy.physics.mechanics import dynamicsymbols

    from lamech.numeric import compile_system

    print(f"\nB3  work-precision: {t_end:g} simulated seconds")
    head = [
        "## B3 work–precision",
        "",
        f"{t_end:g} simulated seconds from rest at 30°; errors at t = {t_end:g} s "
        "against a lamech reference run at rtol = 1e-13: the rod tensions (max "
        "relative error) and the positions (max absolute error, in link lengths). "
        "lamech: DOP853 with projection (`simulate` on lamech's engine in C: the loop "
        "with events, `lm_ev_segment`); "
        "lamech kernel: `lamech.numeric.integrate_batch` on one trajectory, the same "
        "method as one compiled loop (a batch smaller than the engine's thread count runs "
        "serially); MuJoCo: hinge chain, Euler and RK4 at fixed steps, positions and "
        "tensions after `mj_forward` at the final state, tensions from the joint "
        "reactions (`mj_rnePostConstraint`, `cfrc_int`); SymPy: "
        "`LagrangesMethod.rhs()` lambdified with cse, `solve_ivp(DOP853)`, no "
        "projection; CasADi: the same maximal-coordinate chain in SX, the KKT system "
        "solved symbolically for (q'', λ) (Schur complement), the index-1 DAE "
        "integrated as an ODE by CVODES (Adams, functional iteration) at the "
        "tolerances shown (rtol, atol), no projection; the options used are in the "
        "method's name. Every peer's tensions agree with lamech's at the initial state "
        f"before a time counts. {repeats} interleaved repeats (each round runs every "
        "row once, the order reversed every other round), without code generation, "
        "compilation and integrator set-up; wall and CPU time (the process's) "
        "min / median / max.",
        "",
        "| N | method | setting | wall min / median / max | CPU min / median / max "
        "| tension error | position error |",
        "|---|---|---|---|---|---|---|",
    ]
    lines += head
    curves: dict = {}
    jit = _compiled()
    rtols = (1e-6, 1e-9, 1e-12) if quick else (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12)
    dts = (1e-3, 1e-4) if quick else (1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4)
    for n in sizes:
        system = lamech_chain(n)
        ns = compile_system(system, jit=jit)
        _, _, ref_pos, ref_T = lamech_run(system, t_end, 1e-13, jit, ns)
        angles = np.full(n, ANGLE)
        y0 = np.concatenate(ns.initial_state())[None]
        cases = []  # ((method, setting), fn)
        for rtol in rtols:
            cases.append(
                (("lamech", f"rtol {rtol:g}"), lambda r=rtol: lamech_run(system, t_end, r, jit, ns))
            )
        if jit:
            from lamech.numeric import integrate_batch

            integrate_batch(ns, y0, 0.01)  # compile outside the timing
            for rtol in rtols:
                cases.append(
                    (
                        ("lamech kernel", f"rtol {rtol:g}"),
                        lambda r=rtol: _kernel_run(ns, y0, t_end, r),
                    )
                )
        try:
            import mujoco  # noqa: F401

            for integrator in ("Euler", "RK4"):
                for dt in dts:
                    cases.append(
                        (
                            (f"MuJoCo {integrator}", f"dt {dt:g}"),
                            lambda i=integrator, d=dt: mujoco_run(n, angles, i, d, t_end),
                        )
                    )
        except ImportError:
            pass
        if n <= 5:
            lm, q, (m, g, l) = sympy_chain(n)
            lm.form_lagranges_equations()
            t = dynamicsymbols._t
            f = sp.lambdify((q, [c.diff(t) for c in q], (m, g, l)), list(lm.rhs()), cse=True)
            for rtol in (1e-6, 1e-9) if quick else (1e-6, 1e-8, 1e-10, 1e-12):
                cases.append(
                    (
                        ("SymPy+solve_ivp", f"rtol {rtol:g}"),
                        lambda r=rtol: _sympy_ivp_run(f, n, t_end, r),
                    )
                )
        peer = casadi_peer(n, ns)
        if peer is not None:
            ystart = np.concatenate((chain_state(n), np.zeros(2 * n)))
            for rtol, atol in CASADI_QUICK if quick else CASADI_SETTINGS:
                peer.integrator(t_end, rtol, atol)  # set up outside the timing
                cases.append(
                    (
                        (peer.label, f"rtol {rtol:g}, atol {atol:g}"),
                        lambda r=rtol, a=atol: peer.run(ystart, t_end, r, a),
                    )
                )
        got = interleave(cases, repeats)
        for method, timed, eT in _accuracy_rows(n, cases, got, ref_pos, ref_T, lines):
            curves.setdefault((n, method), []).append((timed.wall.median, eT, timed.cpu.median))
    lines.append("")
    lines += b3_equal_error(curves, sizes)
    bench_long_chains([60] if quick else [60, 100], t_end, quick, lines)
    _draw(curves, sizes, t_end)
    return curves


def _accuracy_rows(n, cases, got, ref_pos, ref_T, lines: list[str]) -> list:
    """One table row per timed case (medians and spreads of wall and CPU time, the
    tension error relative to the largest reference tension, the position error),
    printed and appended to ``lines``; [(method, timed, tension error)]."""
    scale = np.max(np.abs(ref_T))
    out = []
    for (method, setting), _ in cases:
        timed = got[(method, setting)]
        pos, T = timed.result
        eT = float(np.max(np.abs(T - ref_T)) / scale)
        eP = float(np.max(np.abs(pos - ref_pos)))
        row = (
            f"| {n} | {method} | {setting} | {_fmt_spread(timed.wall)} | "
            f"{_fmt_spread(timed.cpu)} | {eT:.2e} | {eP:.2e} |"
        )
        print("  " + row)
        lines.append(row)
        out.append((method, timed, eT))
    return out


def b3_equal_error(curves: dict, sizes) -> list[str]:
    """B3 read at equal tension error: each method's median wall (and CPU) time
    interpolated log-log on its Pareto front (:func:`at_error`), and each peer's time
    over lamech's compiled loop's (a ratio above 1: lamech's loop is faster)."""
    methods = {m for (_, m) in curves}
    peers = [
        m
        for p in B3_PEERS
        for m in sorted(methods)
        if m.startswith(p) and m != "lamech kernel" and (p != "lamech" or m == p)
    ]
    short = {
        m: "lamech simulate" if m == "lamech" else m.split(" (")[0].split(" CVODES")[0]
        for m in peers
    }
    out = [
        "## B3 at equal accuracy",
        "",
        "The rows above read at a given tension error: each method's median wall time "
        "(CPU time in brackets), interpolated log-log between the two settings around "
        "that error on the method's Pareto front; — where the method's settings do not "
        "reach that error (no extrapolation). Ratio: the peer's median over lamech "
        "kernel's (above 1: lamech's compiled loop is faster), wall (CPU). "
        + "; ".join(f"{short[m]}: the rows named {m}" for m in peers if short[m] != m)
        + ".",
        "",
        "| N | tension error | lamech kernel | "
        + " | ".join(short[p] for p in peers)
        + " | "
        + " | ".join(f"{short[p]} / kernel" for p in peers)
        + " |",
        "|" + "---|" * (3 + 2 * len(peers)),
    ]

    def ms(x):
        return "—" if x is None else f"{x * 1e3:.3g} ms"

    for n in sizes:
        base = curves.get((n, "lamech kernel"))
        if not base:
            continue
        for target in B3_TARGETS:
            kw = at_error([(w, e) for w, e, _ in base], target)
            kc = at_error([(c, e) for _, e, c in base], target)
            cells, ratios = [], []
            for p in peers:
                pts = curves.get((n, p), [])
                pw = at_error([(w, e) for w, e, _ in pts], target)
                pc = at_error([(c, e) for _, e, c in pts], target)
                cells.append("—" if pw is None else f"{ms(pw)} ({ms(pc)})")
                # the CPU times' Pareto front may miss an error the wall times' reaches
                cpu = "—" if pc is None or kc is None else f"{pc / kc:.2g}×"
                ratios.append("—" if pw is None or kw is None else f"{pw / kw:.2g}× ({cpu})")
            if kw is None and all(c == "—" for c in cells):
                continue
            row = (
                f"| {n} | {target:.0e} | "
                + ("—" if kw is None else f"{ms(kw)} ({ms(kc)})")
                + " | "
                + " | ".join(cells)
                + " | "
                + " | ".join(ratios)
                + " |"
            )
            print("  " + row)
            out.append(row)
    out.append("")
    return out


def _draw(curves: dict, sizes, t_end: float) -> None:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return
    fig, axes = plt.subplots(1, len(sizes), figsize=(6 * len(sizes), 4.5), squeeze=False)
    for ax, n in zip(axes[0], sizes):
        for (nn, method), pts in sorted(curves.items()):
            if nn != n:
                continue
            pts = sorted(pts, key=lambda p: p[1])
            colour = _COLOURS.get(method, "tab:brown" if method.startswith("CasADi") else None)
            ax.loglog([p[1] for p in pts], [p[2] for p in pts], "o-", label=method, color=colour)
        ax.set_xlabel(f"tension error at t = {t_end:g} s (relative)")
        # CPU time: on a shared machine the wall time's medians still zigzag
        ax.set_ylabel("CPU time, median of 3 (s)")
        ax.set_title(f"{n}-link chain, {t_end:g} s")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(PICTURE, dpi=110)
    plt.close(fig)


def bench_long_chains(sizes, t_end, quick, lines: list[str], repeats: int = 3):
    """B3's long chains (issue 16): lamech's ``simulate`` on its engine in C (each chain's
    functions compiled to C in a few seconds; until the engine was C these rows ran SciPy's
    DOP853 on the NumPy kernels, numba taking minutes to compile a chain this long)
    against MuJoCo at dt = 1e-3, with wall and CPU time. With OpenBLAS's helper threads
    the 60-link run took 4-70 times as long on 2 cores: a wall time far above the CPU
    time, or a CPU time far above this table's, is that."""
    from lamech.numeric import compile_system

    jit = _compiled()
    road = "the engine in C" if jit else "the NumPy kernels (no C compiler)"
    print(f"\nB3  long chains: {t_end:g} simulated seconds, lamech on {road}")
    lines += [
        "## B3 long chains",
        "",
        f"As B3, {t_end:g} simulated seconds, with N = {', '.join(map(str, sizes))}; "
        "errors against a lamech reference run at rtol = 1e-12. lamech: `simulate` "
        f"on {road}; MuJoCo at dt = 1e-3. "
        f"{1 if quick else repeats} interleaved repeats, wall and CPU time (the "
        "process's) min / median / max, without code generation.",
        "",
        "| N | method | setting | wall min / median / max | CPU min / median / max | "
        "tension error | position error |",
        "|---|---|---|---|---|---|---|",
    ]
    for n in sizes:
        system = lamech_chain(n)
        ns = compile_system(system, jit=jit)
        _, _, ref_pos, ref_T = lamech_run(system, t_end, 1e-12, jit, ns)
        angles = np.full(n, ANGLE)
        cases = [
            (("lamech", f"rtol {rtol:g}"), lambda r=rtol: lamech_run(system, t_end, r, jit, ns))
            for rtol in ((1e-9,) if quick else (1e-6, 1e-9))
        ]
        try:
            import mujoco  # noqa: F401

            cases += [
                ((f"MuJoCo {i}", "dt 0.001"), lambda i=i: mujoco_run(n, angles, i, 1e-3, t_end))
                for i in ("Euler", "RK4")
            ]
        except ImportError:
            pass
        got = interleave(cases, 1 if quick else repeats)
        _accuracy_rows(n, cases, got, ref_pos, ref_T, lines)
    lines.append("")


# ----- B4 -----------------------------------------------------------------------------
def bench_b4(count_lamech, count, count_mujoco, t_end, lines: list[str], repeats: int = 3):
    """Ensembles of the 5-link chain: ``count_lamech`` runs of ``simulate`` in a loop,
    ``count`` of lamech's batch and CasADi's mapped integrator, ``count_mujoco`` of
    ``mujoco.rollout`` (a tenth of it at dt = 1e-4); trajectories per second from the
    median of ``repeats`` interleaved rounds."""
    from lamech.numeric import compile_system, simulate

    n = 5
    threads = (
        len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    )
    rng = np.random.default_rng(1)
    angles = ANGLE + rng.uniform(-0.1, 0.1, size=(max(count_lamech, count, count_mujoco), n))
    print(f"\nB4  ensembles: 5-link chain, {t_end:g} s each")
    lines += [
        "## B4 ensembles",
        "",
        f"Random initial angles (30° ± 0.1 rad), at rest, {t_end:g} s each, one core "
        f"unless said. {repeats} interleaved rounds (every row once per round, the "
        "order reversed every other round); wall and CPU time (the process's, all "
        "threads) min / median / max; trajectories per second from the median wall "
        "time; the last column: lamech `integrate_batch`'s trajectories per second "
        "over the row's. The tension error of each method's first run against a "
        "lamech run at rtol 1e-13.",
        "",
        "| method | runs | wall min / median / max | CPU min / median / max "
        "| trajectories/s | batch / this | tension error (first run) |",
        "|---|---|---|---|---|---|---|",
    ]
    jit = _compiled()
    ns = compile_system(lamech_chain(n), jit=jit)
    # accuracy of each method on the first initial condition, against a tight reference
    q_first = dict(zip(ns.coordinate_names, chain_state(n, angles[0])))
    ref = simulate(ns, t_end, q0=q_first, samples=2, rtol=1e-13, atol=1e-14)
    ref_T = -2 * L * ref.lambdas[-1]

    def error(T):
        return f"{np.max(np.abs(T - ref_T)) / np.max(np.abs(ref_T)):.1e}"

    cases, rows = [], []  # rows: (key, label, runs, error)

    def simulate_loop():
        with _Clock() as clock:
            for k in range(count_lamech):
                q0 = dict(zip(ns.coordinate_names, chain_state(n, angles[k])))
                tr = simulate(ns, t_end, q0=q0, samples=2, rtol=1e-10, atol=1e-12)
                assert tr.status == "ok", tr.message
        return clock.wall, clock.cpu

    mine = simulate(ns, t_end, q0=q_first, samples=2, rtol=1e-10, atol=1e-12)
    cases.append(("simulate", simulate_loop))
    rows.append(
        (
            "simulate",
            "lamech simulate (rtol 1e-10, one process)",
            count_lamech,
            error(-2 * L * mine.lambdas[-1]),
        )
    )
    Y0 = np.array(
        [np.concatenate((chain_state(n, angles[k]), np.zeros(2 * n))) for k in range(count)]
    )
    if jit:
        from lamech.numeric import integrate_batch

        integrate_batch(ns, Y0[:threads], 0.01)  # compile outside the timing
        res = integrate_batch(ns, Y0[:1], t_end, rtol=1e-10, atol=1e-12)

        def batch():
            with _Clock() as clock:
                out = integrate_batch(ns, Y0, t_end, rtol=1e-10, atol=1e-12)
            assert out.ok.all()
            return clock.wall, clock.cpu

        cases.append(("batch", batch))
        rows.append(
            (
                "batch",
                f"lamech integrate_batch (rtol 1e-10, engine in C, {threads} threads)",
                count,
                error(-2 * L * res.lambdas[0]),
            )
        )
    peer = casadi_peer(n, ns)
    if peer is not None:
        rtol, atol = 1e-11, 1e-13
        first = peer.ensemble(Y0[:1], t_end, rtol, atol, 1)
        peer.ensemble(Y0, t_end, rtol, atol, threads)  # set up the map outside the time

        def casadi_map():
            with _Clock() as clock:
                peer.ensemble(Y0, t_end, rtol, atol, threads)
            return clock.wall, clock.cpu

        cases.append(("casadi", casadi_map))
        rows.append(
            (
                "casadi",
                f"{peer.label} rtol {rtol:g}, atol {atol:g}, `map` over {threads} threads",
                count,
                error(peer.tensions(first[0])),
            )
        )
    try:
        import mujoco
        from mujoco import rollout
    except ImportError:
        mujoco = None
    if mujoco is not None:
        for integrator, dt in (("RK4", 2e-3), ("Euler", 2e-3), ("RK4", 1e-4)):
            runs = count_mujoco if dt > 1e-3 else max(10, count_mujoco // 10)
            model, data = mujoco_chain(n, integrator, dt)
            nstate = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS)
            init = np.zeros((runs, nstate))
            for k in range(runs):
                data.qpos[:] = mujoco_angles(angles[k])
                data.qvel[:] = 0
                data.time = 0
                mujoco.mj_getState(model, data, init[k], mujoco.mjtState.mjSTATE_FULLPHYSICS)
            steps = int(round(t_end / dt))
            datas = [mujoco.MjData(model) for _ in range(threads)]

            def roll(model=model, datas=datas, init=init, steps=steps):
                with _Clock() as clock:
                    rollout.rollout(model, datas, init, nstep=steps)
                return clock.wall, clock.cpu

            key = f"mujoco {integrator} {dt:g}"
            cases.append((key, roll))
            rows.append(
                (
                    key,
                    f"mujoco.rollout {integrator} dt {dt:g} ({threads} threads)",
                    runs,
                    error(mujoco_run(n, angles[0], integrator, dt, t_end)[3]),
                )
            )
    got = interleave(cases, repeats)
    batch_rate = (count / got["batch"].wall.median) if "batch" in got else None
    for key, label, runs, err in rows:
        timed = got[key]
        rate = runs / timed.wall.median
        vs = f"{batch_rate / rate:.2g}×" if batch_rate else "—"
        row = (
            f"| {label} | {runs} | {_fmt_spread(timed.wall)} | {_fmt_spread(timed.cpu)} "
            f"| {rate:.3g} | {vs} | {err} |"
        )
        print("  " + row)
        lines.append(row)
    lines.append("")


# ----- B5 -----------------------------------------------------------------------------
DOUBLE_PENDULUM_POLAR = """
title = "Double pendulum, polar"
[parameters]
m1 = 1.0
m2 = 1.0
l1 = 1.0
l2 = 1.0
g = 9.81
[coordinates]
r1 = { initial = "l1", velocity = 0 }
th1 = { initial = 0.6, velocity = 0 }
r2 = { initial = "l2", velocity = 0 }
th2 = { initial = 0.3, velocity = 0 }
[[constraints]]
name = "rod1"
f = "l1 - r1"
[[constraints]]
name = "rod2"
f = "l2 - r2"
[[bodies]]
name = "bob1"
mass = "m1"
position = ["r1*sin(th1)", "-r1*cos(th1)"]
[[bodies]]
name = "bob2"
mass = "m2"
position = ["r1*sin(th1) + r2*sin(th2)", "-r1*cos(th1) - r2*cos(th2)"]
[gravity]
acceleration = "g"
"""

DOUBLE_PENDULUM_CARTESIAN = """
title = "Double pendulum, Cartesian"
[parameters]
m1 = 1.0
m2 = 1.0
l1 = 1.0
l2 = 1.0
g = 9.81
[coordinates]
x1 = { initial = 0.6, velocity = 0 }
y1 = { initial = -0.8, velocity = 0 }
x2 = { initial = 1.2, velocity = 0 }
y2 = { initial = -1.6, velocity = 0 }
[[constraints]]
name = "rod1"
f = "x1^2 + y1^2 - l1^2"
[[constraints]]
name = "rod2"
f = "(x2 - x1)^2 + (y2 - y1)^2 - l2^2"
[[bodies]]
name = "bob1"
mass = "m1"
position = ["x1", "y1"]
[[bodies]]
name = "bob2"
mass = "m2"
position = ["x2", "y2"]
[gravity]
acceleration = "g"
"""

# (label, bundled example name or problem text)
B5_PROBLEMS = [
    ("four-bar linkage", "four_bar"),
    ("rolling disc (3-1-2 angles)", "rolling_disc"),
    ("double pendulum, polar (r, theta)", DOUBLE_PENDULUM_POLAR),
    ("double pendulum, Cartesian", DOUBLE_PENDULUM_CARTESIAN),
]


def _lamech_problem(source: str):
    import lamech

    return lamech.loads(source) if "\n" in source else lamech.load(source)


def sympy_lagranges(system):
    """SymPy's inputs for lamech's ``system``: (L, q, holonomic f, velocity g, names in
    SymPy's multiplier order). The same L = T - V and the same constraints as written
    (never normalised), in ``dynamicsymbols``; parameters stay lamech's symbols."""
    import sympy as sp
    from sympy.physics.mechanics import dynamicsymbols

    if any(sp.sympify(f) != 0 for f in system.forces):
        raise ValueError("B5 compares conservative systems only (no [forces])")
    t = dynamicsymbols._t
    q = [dynamicsymbols(c.name) for c in system.coordinates]
    rep = {system.t: t}
    for c, f in zip(system.coordinates, q):
        rep[c.velocity] = f.diff(t)
        rep[c.symbol] = f
    hol = [c for c in system.constraints if c.holonomic]
    vel = [c for c in system.constraints if not c.holonomic]
    return (
        sp.sympify(system.L).xreplace(rep),
        q,
        [c.expr.xreplace(rep) for c in hol],
        [c.expr.xreplace(rep) for c in vel],
        [c.name for c in hol + vel],
    )


def sympy_b5(system, lagranges=None) -> tuple[dict, float, float]:
    """SymPy's path to the multipliers in closed form: LagrangesMethod,
    form_lagranges_equations(), solve_multipliers() (symbolic, no operating point).
    Returns (lamech's multipliers evaluated at the initial state, SymPy's sign turned:
    lambda_lamech = -lambda_SymPy; seconds to form the equations; seconds to solve)."""
    values, _, _, t_form, t_solve = sympy_b5_timed(system, lagranges)
    return values, t_form, t_solve


def sympy_b5_timed(system, lagranges=None) -> tuple[dict, float, float, float, float]:
    """:func:`sympy_b5` with the whole time: (multipliers at the initial state, wall and
    CPU seconds of form + solve, seconds to form, seconds to solve). Evaluating the
    multipliers at the initial state is outside the time."""
    from sympy.physics.mechanics import LagrangesMethod, dynamicsymbols, msubs

    L, q, hol, vel, names = lagranges or sympy_lagranges(system)
    c0 = time.process_time()
    t0 = time.perf_counter()
    lm = LagrangesMethod(L, q, hol_coneqs=hol or None, nonhol_coneqs=vel or None)
    lm.form_lagranges_equations()
    t1 = time.perf_counter()
    lam = lm.solve_multipliers(sol_type="Matrix")
    t2 = time.perf_counter()
    cpu = time.process_time() - c0
    t = dynamicsymbols._t
    op = dict(system.parameter_values)
    for c, f in zip(system.coordinates, q):
        op[f.diff(t)] = float(system.numeric(c.initial_velocity))
        op[f] = float(system.numeric(c.initial))
    values = {n: -float(msubs(v, op).evalf()) for n, v in zip(names, lam)}
    return values, t2 - t0, cpu, t1 - t0, t2 - t1


def _at_start(system, exprs: dict) -> dict:
    """Each expression at the system's initial state and parameter values (30 digits:
    the raw closed forms are long), as floats."""
    import sympy as sp

    vals = {**system.parameter_values, system.t: 0.0}
    # a solve may give its results in a chart's angles (a circle among the constraints:
    # the Cartesian double pendulum's theta1, theta2), whose start the chart gives
    for c in (*system.coordinates, *system.chart_coordinates):
        vals[c.symbol] = float(system.numeric(c.initial))
        vals[c.velocity] = float(system.numeric(c.initial_velocity))
    vals = {k: sp.Float(v, 30) for k, v in vals.items()}
    return {n: float(sp.N(sp.sympify(e).xreplace(vals), 30)) for n, e in exprs.items()}


def lamech_b5(source: str) -> tuple[dict, float]:
    """lamech's whole report: problem text -> Solution (load + solve). Returns
    (multipliers at the initial state, seconds)."""
    values, sec, _, _ = lamech_b5_full(source)
    return values, sec


def lamech_b5_full(source: str) -> tuple[dict, float, float, float]:
    """lamech's whole report, problem text -> Solution (load + solve: readable
    equations, reduction, tidy closed forms, integrals, shells, lift-off, forces).
    Returns (multipliers at the initial state, wall and CPU seconds of load + solve,
    seconds of the load alone)."""
    import lamech

    c0 = time.process_time()
    t0 = time.perf_counter()
    system = _lamech_problem(source)
    t1 = time.perf_counter()
    sol = lamech.solve(system)
    t2 = time.perf_counter()
    cpu = time.process_time() - c0
    return _at_start(sol.system, sol.multipliers), t2 - t0, cpu, t1 - t0


def lamech_b5_fast(system) -> tuple[dict, float, float]:
    """lamech's derivation to the multipliers, the like-for-like of SymPy's form +
    solve_multipliers: ``lamech.symbolic.multipliers`` on the loaded System (the
    Euler-Lagrange equations with lambda, then every lambda in closed form, raw).
    Returns (multipliers at the initial state, wall and CPU seconds)."""
    from lamech.symbolic import multipliers

    c0 = time.process_time()
    t0 = time.perf_counter()
    lam = multipliers(system)
    sec, cpu = time.perf_counter() - t0, time.process_time() - c0
    return _at_start(system, lam), sec, cpu


def _agree(label: str, what: str, got: dict, lam: dict) -> None:
    """lamech's multipliers (``got``) against SymPy's (``lam``) at the initial state."""
    missing = sorted(set(lam) - set(got))
    if missing:
        print(f"  {label}: {what} gave no closed form for {', '.join(missing)}")
    for n in set(lam) & set(got):
        if not math.isclose(lam[n], got[n], rel_tol=1e-8, abs_tol=1e-9):
            raise AssertionError(f"B5 {label}: lambda_{n} {what} {got[n]} != SymPy {lam[n]}")


def _fmt_wall(t) -> str:
    """median (min–max) of a case's wall time, or — when it was stopped."""
    if t is None:
        return "—"
    w = t.wall
    return f"{_fmt_s(w.median)} ({_fmt_s(w.min)}–{_fmt_s(w.max)})"


def bench_b5(cap: float, lines: list[str], repeats: int = 3):
    print("\nB5  symbolic: derivation to the multipliers")
    lines += [
        "## B5 derivation to the multipliers",
        "",
        "From the equations of motion to every multiplier in closed form. lamech: "
        "`lamech.symbolic.multipliers(system)` on the loaded System (M, h, A, γ and "
        "the Euler-Lagrange equations with λ, then every λ as one expression, raw: "
        "the KKT system solved by its structure, λ = (A M⁻¹ Aᵀ)⁻¹ (A M⁻¹ (h − Q) − "
        "γ) with M⁻¹ by a symbolic LDLᵀ). SymPy: `LagrangesMethod(L, q, "
        "hol_coneqs, nonhol_coneqs)` on the same L and constraints (built from the "
        "same System, outside the time), `form_lagranges_equations()`, "
        "`solve_multipliers()` (symbolic, raw). Beside them, lamech's whole report: "
        "`lamech.load` (or `loads`, the problem text → System, its own column) + "
        "`lamech.solve` (readable equations, elimination, tidy closed forms, "
        "integrals, energy shell, lift-off and slip, forces). Every run in its own "
        f"forked process on an empty SymPy cache (modules imported beforehand), "
        f"{repeats} interleaved repeats (lamech, SymPy, lamech load + solve, then "
        f"the other way round), each capped at {cap:.0f} s; wall time median (min–"
        "max), ratio of medians; SymPy's split (form; solve) and lamech's load time "
        "are the last run's. Both sides' multipliers agree at the initial state "
        "(to 1e-8) before a time counts.",
        "",
        "| problem | lamech `multipliers` | SymPy form + solve_multipliers (form; "
        "solve) | SymPy / lamech | lamech load | lamech load + solve |",
        "|---|---|---|---|---|---|",
    ]

    import sympy.physics.mechanics  # noqa: F401

    import lamech.symbolic  # noqa: F401  (imports outside the time, both sides)

    def case(fn, *args):
        def run():
            res, _, _ = _capped(fn, args, cap, cold=True)
            return None if res is None else (res[1], res[2], *res)

        return run

    for label, source in B5_PROBLEMS:
        system = _lamech_problem(source)
        got = interleave(
            [
                ("lamech", case(lamech_b5_fast, system)),
                ("SymPy", case(sympy_b5_timed, system, sympy_lagranges(system))),
                ("full", case(lamech_b5_full, source)),
            ],
            repeats,
        )
        fast, peer, full = got["lamech"], got["SymPy"], got["full"]
        if peer is not None:
            lam = peer.result[0]
            if fast is not None:
                _agree(label, "lamech multipliers", fast.result[0], lam)
            if full is not None:
                _agree(label, "lamech solve", full.result[0], lam)
        if peer is None:
            sympy_cell = f"> {cap:.0f} s"
        else:
            sympy_cell = f"{_fmt_wall(peer)} ({_fmt_s(peer.result[3])}; {_fmt_s(peer.result[4])})"
        if fast and peer:
            ratio = f"{peer.wall.median / fast.wall.median:.3g}×"
        elif fast:
            ratio = f"> {cap / fast.wall.median:.3g}×"
        else:
            ratio = "—"
        load = _fmt_s(full.result[3]) if full else "—"
        row = (
            f"| {label} | {_fmt_wall(fast) if fast else f'> {cap:.0f} s'} | {sympy_cell} "
            f"| {ratio} | {load} | {_fmt_wall(full) if full else f'> {cap:.0f} s'} |"
        )
        print("  " + row)
        lines.append(row)
    lines.append("")


# ----- main ---------------------------------------------------------------------------
def _machine() -> list[str]:
    cpu = platform.processor() or "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    import scipy
    import sympy

    versions = [
        f"Python {platform.python_version()}",
        f"SymPy {sympy.__version__}",
        f"NumPy {np.__version__}",
        f"SciPy {scipy.__version__}",
    ]
    from lamech.numeric import compiled_available

    versions.append(
        "lamech's engine: C" if compiled_available() else "lamech's engine in C: not available"
    )
    for mod in ("mujoco", "pydy", "Cython", "casadi"):
        try:
            versions.append(f"{mod} {__import__(mod).__version__}")
        except ImportError:
            versions.append(f"{mod} not installed")
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return [
        f"- date: {_dt.datetime.now(_dt.timezone.utc):%Y-%m-%d %H:%M} UTC",
        f"- machine: {cpu}, {cores} cores usable, {platform.system()} {platform.machine()}",
        "- versions: " + ", ".join(versions),
    ]


PICTURE = HERE / "work_precision.png"


def bench_startup(repeats: int, lines: list[str]) -> None:
    """Whole-process start-up: `lamech --help` and `lamech examples` against
    `python -c "import sympy"` and an empty interpreter, interleaved (each round runs all
    four), wall time min / median / max."""
    import statistics
    import subprocess
    import time

    exe = sys.executable
    cases = [
        ("lamech --help", [exe, "-m", "lamech", "--help"]),
        ("lamech examples", [exe, "-m", "lamech", "examples"]),
        ('python -c "import sympy"', [exe, "-c", "import sympy"]),
        ('python -c "pass"', [exe, "-c", "pass"]),
    ]
    times: dict[str, list[float]] = {name: [] for name, _ in cases}
    for _ in range(repeats):
        for name, cmd in cases:
            t0 = time.perf_counter()
            subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
            times[name].append(time.perf_counter() - t0)
    out = [
        "## Start-up (whole process, wall time)",
        "",
        f"{repeats} interleaved rounds; target: `lamech --help` and `lamech examples` under 0.4 s.",
        "",
        "| command | min | median | max |",
        "|---|---|---|---|",
    ]
    for name, ts in times.items():
        out.append(
            f"| `{name}` | {min(ts):.3f} s | {statistics.median(ts):.3f} s | {max(ts):.3f} s |"
        )
    out.append("")
    print("\n".join(out))
    lines += out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench", description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="small sizes and caps (~4 minutes)")
    ap.add_argument(
        "--only",
        choices=[
            "startup",
            "B1",
            "B2",
            "B3",
            "B4",
            "B5",
            "B6",
            "B7",
            "B9",
            "B10",
            "symbolic",
            "solve",
            "map",
        ],
        action="append",
        help="run only these benchmarks (repeatable; symbolic is B5)",
    )
    ap.add_argument(
        "--out",
        default=None,
        help="where to write the table (default bench/RESULTS.md; with --quick "
        "bench/quick/RESULTS.md, with --only bench/partial/RESULTS.md, both "
        "untracked, so a quick or partial run never overwrites the published "
        "results)",
    )
    args = ap.parse_args(argv)
    # a quick or partial run never overwrites the published table (untracked folders)
    folder = HERE / "quick" if args.quick else HERE / "partial" if args.only else HERE
    folder.mkdir(exist_ok=True)
    args.out = args.out or str(folder / "RESULTS.md")
    global PICTURE
    PICTURE = folder / "work_precision.png"
    want = {
        {"symbolic": "B5", "solve": "B9", "map": "B10"}.get(w, w)
        for w in (args.only or ["startup", "B1", "B2", "B3", "B4", "B5", "B6", "B7", "B9", "B10"])
    }
    lines = [
        "# lamech benchmark results",
        "",
        f"Written by `python -m bench{' --quick' if args.quick else ''}`. Timings on a "
        "shared machine are noisy (±20% and more while other work runs): the runs of "
        "lamech and its peers are interleaved, each row gives min / median / max of "
        "its repeats and the CPU time beside the wall time, and ratios are of "
        "medians from the same process.",
        "",
    ]
    lines += _machine() + [""]
    print("\n".join(lines))
    if "startup" in want:
        bench_startup(3 if args.quick else 7, lines)
    if "B1" in want:
        bench_b1(
            [2, 4, 8] if args.quick else [2, 4, 8, 12, 16, 30], 20.0 if args.quick else 120.0, lines
        )
    if "B2" in want:
        bench_b2([2, 8] if args.quick else [2, 8, 30, 100], lines, 1 if args.quick else 3)
    if "B3" in want:
        bench_b3([5] if args.quick else [5, 20], 10.0, args.quick, lines)
    if "B4" in want:
        bench_b4(
            10 if args.quick else 50,
            100 if args.quick else 1000,
            100 if args.quick else 500,
            10.0,
            lines,
        )
    if "B5" in want:
        bench_b5(60.0 if args.quick else 300.0, lines)
    if "B9" in want:
        from .solve import bench_solve

        bench_solve(lines, 1 if args.quick else 3, 60.0 if args.quick else 300.0, args.quick)
    if "B6" in want:
        from .sweep import bench_b6

        bench_b6(lines, 1 if args.quick else 3, args.quick)
    if "B7" in want:
        from .events import bench_b7

        bench_b7(100 if args.quick else 1000, args.quick, lines, 1 if args.quick else 3)
    if "B10" in want:
        from .map import bench_b10

        bench_b10(lines, 1 if args.quick else 3, args.quick)
    Path(args.out).write_text("\n".join(lines) + "\n", encoding="utf-8")
    print(f"\nwrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
