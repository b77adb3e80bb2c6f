"""lamech's benchmarks, each side by side with its peers in this one process.

    .venv/bin/python -m bench            # the full suite (about 15 minutes on 2 cores)
    .venv/bin/python -m bench --quick    # smaller sizes and caps (about 2 minutes)

Needs the optional extra ``bench`` (``pip install -e '.[bench]'``: mujoco, numba, pydy,
Cython; a C compiler for PyDy). The model everywhere is the planar N-link pendulum chain
(point masses m = 1, links l = 1, g = 9.81, all links 30° from the vertical at rest): in
maximal coordinates (x_i, y_i, one length constraint per link) for lamech, SymPy and PyDy,
as a hinge chain for MuJoCo.

B1  derivation + code generation: model -> first numeric (q'', lambda).
B2  one dynamics evaluation (q'' and lambda), microseconds per call.
B3  work-precision: wall time against the error of the rod tensions and the positions
    at t = 10 s, against a tight lamech reference run (rtol 1e-13); then the long
    chains, N = 60 and 100 (``--quick``: 60), with wall and CPU time.
B4  ensembles: trajectories per second over many initial conditions.
B5  symbolic: derivation to the multipliers (problem text -> lambda in closed form),
    lamech's load + solve against SymPy's LagrangesMethod + form_lagranges_equations()
    + solve_multipliers() on the same Lagrangian and constraints, for the four-bar
    linkage, the rolling disc and the double pendulum (polar and Cartesian); runs alone
    with ``--only B5`` (or ``--only symbolic``).

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
import sys
import time
import timeit
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
L, G = 1.0, 9.81
ANGLE = math.radians(30.0)
_COLOURS = {"lamech": "tab:red", "lamech kernel": "tab:purple", "MuJoCo Euler": "tab:blue",
            "MuJoCo RK4": "tab:orange", "SymPy+solve_ivp": "tab:green"}


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
    hol = [(x[i] - (x[i - 1] if i else 0)) ** 2 + (y[i] - (y[i - 1] if i else 0)) ** 2 - l ** 2
           for i in range(n)]
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
        body = (f'<body name="b{i}" pos="{pos}"><joint type="hinge" axis="0 1 0"/>'
                f'<inertial pos="0 0 -1" mass="1" diaginertia="1e-12 1e-12 1e-12"/>{body}</body>')
    xml = (f'<mujoco><option gravity="0 0 -{G}" timestep="{dt}" integrator="{integrator}">'
           f'<flag contact="disable"/></option><worldbody>{body}</worldbody></mujoco>')
    model = mujoco.MjModel.from_xml_string(xml)
    return model, mujoco.MjData(model)


def mujoco_angles(angles: np.ndarray) -> np.ndarray:
    """Hinge angles (relative, about +y) for absolute link angles from the vertical
    (lamech's x = +sin: a rotation about +y by -a)."""
    a = -np.asarray(angles, float)
    return np.concatenate(([a[0]], np.diff(a)))


def mujoco_masses(model, data, n: int) -> np.ndarray:
    return np.array([data.xpos[i] + data.xmat[i].reshape(3, 3) @ (0.0, 0.0, -1.0)
                     for i in range(1, n + 1)])


def mujoco_tensions(model, data, n: int) -> np.ndarray:
    """Rod tensions from the joint reactions: cfrc_int (force part) of each body, the
    force its parent exerts on it, projected on the link towards the pivot. With a
    massless link and a hinge that force lies along the link."""
    import mujoco
    mujoco.mj_forward(model, data)          # accelerations at this state (after RK4, the
    mujoco.mj_rnePostConstraint(model, data)  # stored ones are from the last stage)
    P = mujoco_masses(model, data, n)
    pivots = np.vstack(([0.0, 0.0, 0.0], P[:-1]))
    out = np.empty(n)
    for i in range(n):
        u = pivots[i] - P[i]
        out[i] = data.cfrc_int[i + 1][3:6] @ (u / np.linalg.norm(u))
    return out


# ----- helpers ------------------------------------------------------------------------
def _capped(fn, args, cap: float):
    """Run fn(*args) in a forked process; (result, seconds) or (None, None) past ``cap``."""
    ctx = mp.get_context("fork")
    queue = ctx.Queue()

    def target():
        t0 = time.perf_counter()
        try:
            res = fn(*args)
        except Exception as exc:  # report, don't hang
            queue.put(("error", repr(exc), time.perf_counter() - t0))
            return
        queue.put(("ok", res, time.perf_counter() - t0))

    proc = ctx.Process(target=target)
    proc.start()
    proc.join(cap)
    if proc.is_alive():
        proc.kill()
        proc.join()
        return None, None
    kind, res, sec = queue.get(timeout=5)
    if kind == "error":
        raise RuntimeError(res)
    return res, sec


def _best(fn, *args, repeat=3):
    """fn(*args) -> (seconds, ...) run ``repeat`` times: the fastest time, the last
    results (the machine is shared: the minimum is the least disturbed run)."""
    runs = [fn(*args) for _ in range(repeat)]
    return (min(r[0] for r in runs),) + tuple(runs[-1][1:])


def _fmt_s(x):
    return "—" if x is None else (f"{x:.3g} s" if x >= 0.01 else f"{x * 1e3:.3g} ms")


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
    return sol[:ns.n], sol[ns.n:]


# ----- B1 -----------------------------------------------------------------------------
def lamech_b1(n: int, jit: bool):
    from lamech.numeric import compile_system
    t0 = time.perf_counter()
    ns = compile_system(lamech_chain(n), jit=jit)
    y, p, *_ = kernel_inputs(ns)
    out = ns.accelerations(0.0, y, p)
    return time.perf_counter() - t0, np.asarray(out)[:ns.n]


def sympy_b1(n: int, cse: bool):
    import sympy as sp
    from sympy.physics.mechanics import dynamicsymbols
    lm, q, (m, g, l) = sympy_chain(n)
    lm.form_lagranges_equations()
    rhs = lm.rhs()
    qd = [c.diff(dynamicsymbols._t) for c in q]
    f = sp.lambdify((q, qd, (m, g, l)), list(rhs), cse=cse)
    out = np.array(f(chain_state(n), np.zeros(2 * n), (1.0, G, L)), dtype=float).ravel()
    return out[2 * n: 4 * n]


def bench_b1(sizes, cap: float, lines: list[str]):
    print("\nB1  derivation + code generation: model -> first (q'', lambda)")
    head = ("| N | lamech | lamech (numba) | SymPy LagrangesMethod + lambdify | same, cse=True "
            "| ratio default/lamech | ratio cse/lamech |")
    lines += ["## B1 derivation and code generation", "",
              "Time from the model (problem text) to the first numeric evaluation of (q'', "
              "λ). SymPy: `LagrangesMethod(L, q, hol_coneqs)`, `form_lagranges_equations()`, "
              f"`rhs()`, `lambdify` (default printer, and `cse=True`); each capped at "
              f"{cap:.0f} s. Both sides' q'' agree at the initial state before a time counts.",
              "", head, "|" + "---|" * 7]
    for n in sizes:
        t_l, qdd = lamech_b1(n, jit=False)
        t_j = None
        try:
            import numba  # noqa: F401
            t_j, _ = lamech_b1(n, jit=True)
        except ImportError:
            pass
        peers = []
        for cse in (False, True):
            res, sec = _capped(sympy_b1, (n, cse), cap)
            if res is not None and not np.allclose(res, qdd, rtol=1e-8, atol=1e-9):
                raise AssertionError(f"B1 N={n}: SymPy and lamech disagree on q''")
            peers.append(sec)
        r = [f"{p / t_l:.0f}×" if p else f"> {cap / t_l:.0f}×" for p in peers]
        row = (f"| {n} | {_fmt_s(t_l)} | {_fmt_s(t_j)} | "
               f"{_fmt_s(peers[0]) if peers[0] else f'> {cap:.0f} s'} | "
               f"{_fmt_s(peers[1]) if peers[1] else f'> {cap:.0f} s'} | {r[0]} | {r[1]} |")
        print("  " + row)
        lines.append(row)
    lines.append("")


# ----- B2 -----------------------------------------------------------------------------
def _per_call(fn, repeat=5, budget=0.3) -> float:
    timer = timeit.Timer(fn)
    number, _ = timer.autorange()
    number = max(1, int(number * budget / 0.2))
    return min(timer.repeat(repeat=repeat, number=number)) / number


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
            tmp_dir=tempfile.mkdtemp(prefix="lamech-bench-pydy-"))
    except Exception as exc:  # noqa: BLE001 - a missing compiler shows up here
        print(f"  (PyDy's Cython back end unavailable: {exc})")
        return None
    N = MM.shape[0]
    Mo, Fo = np.empty(N * N), np.empty(N)

    def f(x, v, c):
        Mv, Fv = fm(x, v, c, Mo, Fo)
        return np.linalg.solve(Mv.reshape(N, N), Fv)

    return f, N


def bench_b2(sizes, lines: list[str]):
    import sympy as sp
    from sympy.physics.mechanics import dynamicsymbols

    from lamech.numeric import compile_system
    print("\nB2  one dynamics evaluation (q'' and lambda), µs per call")
    lines += ["## B2 one dynamics evaluation", "",
              "One evaluation of (q'', λ) at the initial state, called from Python, best "
              "of 5 timeit runs. lamech: `NumericSystem.accelerations(t, y, p)` (NumPy: "
              "generated M, Q − h, A, γ plus `numpy.linalg.solve` of the KKT matrix; numba: "
              "the same source compiled, M diagonal so λ from the Schur complement "
              "A M⁻¹ Aᵀ over A's structural nonzeros). Peers: `lambdify(cse=True)` of "
              "SymPy's `LagrangesMethod.rhs()` (N ≤ 8; larger `rhs()` does not finish); "
              "PyDy's Cython back end (`CythonMatrixGenerator` for `mass_matrix_full`, "
              "`forcing_full`, then `numpy.linalg.solve`, as PyDy's ODE function does). "
              "Every peer's q'' and λ agree with lamech's before a time counts.", "",
              "| N | lamech NumPy | lamech numba | SymPy lambdify(cse=True) | PyDy Cython "
              "| lambdify/lamech numba | PyDy/lamech numba |",
              "|---|---|---|---|---|---|---|"]
    for n in sizes:
        ns = compile_system(lamech_chain(n))
        y, p, *_ = kernel_inputs(ns)
        ref = ns.accelerations(0.0, y, p)
        t_np = _per_call(lambda: ns.accelerations(0.0, y, p))
        t_nb = None
        try:
            import numba  # noqa: F401
            nj = compile_system(lamech_chain(n), jit=True)
            t_nb = _per_call(lambda: nj.accelerations(0.0, y, p))
        except ImportError:
            pass
        x0, v0, c0 = chain_state(n), np.zeros(2 * n), (1.0, G, L)

        def agree(out, who):
            out = np.asarray(out, dtype=float).ravel()
            qdd, lam = out[2 * n:4 * n], out[4 * n:5 * n]
            if not (np.allclose(qdd, ref[:2 * n], rtol=1e-8, atol=1e-9)
                    and np.allclose(lam, ref[2 * n:], rtol=1e-8, atol=1e-9)):
                raise AssertionError(f"B2 N={n}: {who} and lamech disagree on (q'', λ)")

        t_sp = None
        if n <= 8:
            lm, q, (m, g, l) = sympy_chain(n)
            lm.form_lagranges_equations()
            t = dynamicsymbols._t
            f = sp.lambdify((q, [c.diff(t) for c in q], (m, g, l)), list(lm.rhs()), cse=True)
            agree(f(x0, v0, c0), "SymPy")
            t_sp = _per_call(lambda: f(x0, v0, c0))
        t_pd = None
        if n <= 8:
            built = pydy_chain(n)
            if built is not None:
                fp, _ = built
                c_arr = np.array(c0)
                agree(fp(x0, v0, c_arr), "PyDy")
                t_pd = _per_call(lambda: fp(x0, v0, c_arr))
        us = lambda s: "—" if s is None else f"{s * 1e6:.3g} µs"  # noqa: E731
        ratio = lambda peer: f"{peer / t_nb:.1f}×" if peer and t_nb else "—"  # noqa: E731
        row = (f"| {n} | {us(t_np)} | {us(t_nb)} | {us(t_sp)} | {us(t_pd)} | {ratio(t_sp)} "
               f"| {ratio(t_pd)} |")
        print("  " + row)
        lines.append(row)
    lines.append("")


# ----- B3 -----------------------------------------------------------------------------
def _lamech_run(system, t_end, rtol, jit, ns=None):
    from lamech.numeric import simulate
    t0 = time.perf_counter()
    tr = simulate(ns if ns is not None else system, t_end, rtol=rtol,
                  atol=min(1e-12, rtol * 1e-2), samples=2, jit=jit)
    sec = time.perf_counter() - t0
    if tr.status != "ok":
        raise RuntimeError(tr.message)
    pos = tr.q[-1]
    tension = -2 * L * tr.lambdas[-1]
    return sec, pos, tension


def _mujoco_run(n, angles, integrator, dt, t_end):
    import mujoco
    model, data = mujoco_chain(n, integrator, dt)
    data.qpos[:] = mujoco_angles(angles)
    mujoco.mj_forward(model, data)
    steps = int(round(t_end / dt))
    if abs(steps * dt - t_end) > 1e-9 * t_end:
        raise ValueError(f"dt = {dt} does not divide t_end = {t_end}")
    t0 = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    sec = time.perf_counter() - t0
    P = mujoco_masses(model, data, n)
    return sec, P[:, [0, 2]].ravel(), mujoco_tensions(model, data, n)


def _sympy_ivp_run(f, n, t_end, rtol):
    from scipy.integrate import solve_ivp
    y0 = np.concatenate((chain_state(n), np.zeros(2 * n)))

    def rhs(t, y):
        out = np.asarray(f(y[:2 * n], y[2 * n:], (1.0, G, L)), dtype=float).ravel()
        return out[:4 * n]

    t0 = time.perf_counter()
    sol = solve_ivp(rhs, (0, t_end), y0, method="DOP853", rtol=rtol, atol=rtol * 1e-2)
    sec = time.perf_counter() - t0
    yT = sol.y[:, -1]
    lam = np.asarray(f(yT[:2 * n], yT[2 * n:], (1.0, G, L)), dtype=float).ravel()[4 * n:]
    return sec, yT[:2 * n], lam


def bench_b3(sizes, t_end, quick, lines: list[str]):
    import sympy as sp
    from sympy.physics.mechanics import dynamicsymbols

    from lamech.numeric import compile_system
    print(f"\nB3  work-precision: {t_end:g} simulated seconds")
    lines += ["## B3 work–precision", "",
              f"{t_end:g} simulated seconds from rest at 30°; errors at t = {t_end:g} s "
              "against a lamech reference run at rtol = 1e-13: the rod tensions (max "
              "relative error) and the positions (max absolute error, in link lengths). "
              "lamech: DOP853 with projection (`simulate`, numba kernel when installed); "
              "lamech kernel: `lamech.numeric.integrate_batch`, the same method as one "
              "compiled loop; "
              "MuJoCo: hinge chain, Euler and RK4 at fixed steps, tensions from the joint "
              "reactions (`mj_rnePostConstraint`, `cfrc_int`); SymPy: "
              "`LagrangesMethod.rhs()` lambdified with cse, `solve_ivp(DOP853)`, no "
              "projection. Wall time: the fastest of 3 runs, without code generation and "
              "compilation.", "",
              "| N | method | setting | wall time | tension error | position error |",
              "|---|---|---|---|---|---|"]
    curves = {}
    try:
        import numba  # noqa: F401
        jit = True
    except ImportError:
        jit = False
    for n in sizes:
        system = lamech_chain(n)
        ns = compile_system(system, jit=jit)
        _, ref_pos, ref_T = _lamech_run(system, t_end, 1e-13, jit, ns)
        Tscale = np.max(np.abs(ref_T))

        def add(method, setting, sec, pos, T):
            eT = float(np.max(np.abs(T - ref_T)) / Tscale)
            eP = float(np.max(np.abs(pos - ref_pos)))
            row = f"| {n} | {method} | {setting} | {_fmt_s(sec)} | {eT:.2e} | {eP:.2e} |"
            print("  " + row)
            lines.append(row)
            curves.setdefault((n, method), []).append((sec, eT))

        for rtol in ((1e-6, 1e-9, 1e-12) if quick else (1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10,
                                                        1e-11, 1e-12)):
            sec, pos, T = _best(_lamech_run, system, t_end, rtol, jit, ns)
            add("lamech", f"rtol {rtol:g}", sec, pos, T)
        if jit:
            from lamech.numeric import integrate_batch
            y0 = np.concatenate(ns.initial_state())[None]
            integrate_batch(ns, y0, 0.01)           # compile outside the timing

            def kernel_run(rtol):
                t0 = time.perf_counter()
                res = integrate_batch(ns, y0, t_end, rtol=rtol, atol=min(1e-12, rtol * 1e-2))
                return time.perf_counter() - t0, res.q[0], -2 * L * res.lambdas[0]

            for rtol in ((1e-6, 1e-9, 1e-12) if quick else (1e-5, 1e-6, 1e-7, 1e-8, 1e-9,
                                                            1e-10, 1e-11, 1e-12)):
                sec, pos, T = _best(kernel_run, rtol)
                add("lamech kernel", f"rtol {rtol:g}", sec, pos, T)
        angles = np.full(n, ANGLE)
        for integrator in ("Euler", "RK4"):
            for dt in ((1e-3, 1e-4) if quick else (1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4)):
                try:
                    sec, pos, T = _best(_mujoco_run, n, angles, integrator, dt, t_end)
                except ImportError:
                    break
                add(f"MuJoCo {integrator}", f"dt {dt:g}", sec, pos, T)
        if n <= 5:
            lm, q, (m, g, l) = sympy_chain(n)
            lm.form_lagranges_equations()
            t = dynamicsymbols._t
            f = sp.lambdify((q, [c.diff(t) for c in q], (m, g, l)), list(lm.rhs()), cse=True)
            for rtol in ((1e-6, 1e-9) if quick else (1e-6, 1e-8, 1e-10, 1e-12)):
                sec, pos, lam = _best(_sympy_ivp_run, f, n, t_end, rtol)
                # LagrangesMethod's multipliers have lamech's sign and scaling
                add("SymPy+solve_ivp", f"rtol {rtol:g}", sec, pos, -2 * L * lam)
    lines.append("")
    bench_long_chains([60] if quick else [60, 100], t_end, quick, lines)
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, axes = plt.subplots(1, len(sizes), figsize=(6 * len(sizes), 4.5), squeeze=False)
        for ax, n in zip(axes[0], sizes):
            for (nn, method), pts in sorted(curves.items()):
                if nn != n:
                    continue
                pts = sorted(pts)
                ax.loglog([p[1] for p in pts], [p[0] for p in pts], "o-", label=method,
                          color=_COLOURS.get(method))
            ax.set_xlabel(f"tension error at t = {t_end:g} s (relative)")
            ax.set_ylabel("wall time (s)")
            ax.set_title(f"{n}-link chain, {t_end:g} s")
            ax.grid(True, which="both", alpha=0.3)
            ax.legend()
        fig.tight_layout()
        fig.savefig(PICTURE, dpi=110)
        plt.close(fig)
    except ImportError:
        pass
    return curves


def _cpu_timed(fn, *args):
    """(wall seconds, CPU seconds of the process, fn's results after its seconds)."""
    c0 = time.process_time()
    out = fn(*args)
    return (out[0], time.process_time() - c0) + tuple(out[1:])


def bench_long_chains(sizes, t_end, quick, lines: list[str]):
    """B3's long chains (issue 16): lamech's ``simulate`` on NumPy's kernels (no numba:
    the path where NumPy's dense solves run, and seconds of code generation instead of
    minutes of numba compilation) against MuJoCo at dt = 1e-3, with wall and CPU time.
    With OpenBLAS's helper threads the 60-link run took 4-70 times as long on 2 cores:
    a wall time far above the CPU time, or a CPU time far above this table's, is that."""
    from lamech.numeric import compile_system
    print(f"\nB3  long chains: {t_end:g} simulated seconds, lamech without numba")
    lines += ["## B3 long chains", "",
              f"As B3, {t_end:g} simulated seconds, with N = {', '.join(map(str, sizes))}; "
              "errors against a lamech reference run at rtol = 1e-12. lamech: `simulate` "
              "on the NumPy kernels (no numba); MuJoCo at dt = 1e-3. Wall and CPU time "
              "(the process's): the fastest of 3 runs (CPU time of that run), without "
              "code generation.", "",
              "| N | method | setting | wall time | CPU time | tension error | "
              "position error |", "|---|---|---|---|---|---|---|"]
    for n in sizes:
        system = lamech_chain(n)
        ns = compile_system(system)
        _, ref_pos, ref_T = _lamech_run(system, t_end, 1e-12, False, ns)
        Tscale = np.max(np.abs(ref_T))

        def add(method, setting, runs):
            sec, cpu, pos, T = min(runs, key=lambda r: r[0])
            eT = float(np.max(np.abs(T - ref_T)) / Tscale)
            eP = float(np.max(np.abs(pos - ref_pos)))
            row = (f"| {n} | {method} | {setting} | {_fmt_s(sec)} | {_fmt_s(cpu)} | "
                   f"{eT:.2e} | {eP:.2e} |")
            print("  " + row)
            lines.append(row)

        for rtol in ((1e-9,) if quick else (1e-6, 1e-9)):
            add("lamech", f"rtol {rtol:g}",
                [_cpu_timed(_lamech_run, system, t_end, rtol, False, ns) for _ in range(3)])
        angles = np.full(n, ANGLE)
        for integrator in ("Euler", "RK4"):
            try:
                runs = [_cpu_timed(_mujoco_run, n, angles, integrator, 1e-3, t_end)
                        for _ in range(1 if quick else 3)]
            except ImportError:
                break
            add(f"MuJoCo {integrator}", "dt 0.001", runs)
    lines.append("")


# ----- B4 -----------------------------------------------------------------------------
def bench_b4(count_lamech, count_mujoco, t_end, lines: list[str]):
    from lamech.numeric import compile_system
    from lamech.numeric import simulate
    n = 5
    rng = np.random.default_rng(1)
    angles = ANGLE + rng.uniform(-0.1, 0.1, size=(max(count_lamech, count_mujoco), n))
    print(f"\nB4  ensembles: 5-link chain, {t_end:g} s each")
    lines += ["## B4 ensembles", "",
              f"Random initial angles (30° ± 0.1 rad), at rest, {t_end:g} s each, one core "
              "unless said.", "",
              "| method | runs | wall time | trajectories/s | tension error (first run) |",
              "|---|---|---|---|---|"]
    try:
        import numba  # noqa: F401
        jit = True
    except ImportError:
        jit = False
    ns = compile_system(lamech_chain(n), jit=jit)
    # accuracy of each method on the first initial condition, against a tight reference
    q_first = dict(zip(ns.coordinate_names, chain_state(n, angles[0])))
    ref = simulate(ns, t_end, q0=q_first, samples=2, rtol=1e-13, atol=1e-14)
    ref_T = -2 * L * ref.lambdas[-1]

    def error(T):
        return f"{np.max(np.abs(T - ref_T)) / np.max(np.abs(ref_T)):.1e}"

    mine = simulate(ns, t_end, q0=q_first, samples=2, rtol=1e-10, atol=1e-12)
    lamech_error = error(-2 * L * mine.lambdas[-1])
    t0 = time.perf_counter()
    for k in range(count_lamech):
        pos = chain_state(n, angles[k])
        q0 = dict(zip(ns.coordinate_names, pos))
        tr = simulate(ns, t_end, q0=q0, samples=2, rtol=1e-10, atol=1e-12)
        assert tr.status == "ok", tr.message
    sec = time.perf_counter() - t0
    row = (f"| lamech simulate (rtol 1e-10, one process) | {count_lamech} | {_fmt_s(sec)} | "
           f"{count_lamech / sec:.3g} | {lamech_error} |")
    print("  " + row)
    lines.append(row)
    if jit:
        from lamech.numeric import integrate_batch
        count = max(count_lamech, count_mujoco)
        Y0 = np.array([np.concatenate((chain_state(n, angles[k]), np.zeros(2 * n)))
                       for k in range(count)])
        integrate_batch(ns, Y0[:1], 0.01)           # compile outside the timing
        t0 = time.perf_counter()
        res = integrate_batch(ns, Y0, t_end, rtol=1e-10, atol=1e-12)
        sec = time.perf_counter() - t0
        assert res.ok.all()
        row = (f"| lamech integrate_batch (rtol 1e-10, {os.cpu_count()} cores) | {count} | "
               f"{_fmt_s(sec)} | {count / sec:.3g} | {error(-2 * L * res.lambdas[0])} |")
        print("  " + row)
        lines.append(row)
    try:
        import mujoco
        from mujoco import rollout
    except ImportError:
        lines.append("")
        return
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
        datas = [mujoco.MjData(model) for _ in range(os.cpu_count() or 1)]
        t0 = time.perf_counter()
        rollout.rollout(model, datas, init, nstep=steps)
        sec = time.perf_counter() - t0
        row = (f"| mujoco.rollout {integrator} dt {dt:g} ({len(datas)} threads) | "
               f"{runs} | {_fmt_s(sec)} | {runs / sec:.3g} | "
               f"{error(_mujoco_run(n, angles[0], integrator, dt, t_end)[2])} |")
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
B5_PROBLEMS = [("four-bar linkage", "four_bar"),
               ("rolling disc (3-1-2 angles)", "rolling_disc"),
               ("double pendulum, polar (r, theta)", DOUBLE_PENDULUM_POLAR),
               ("double pendulum, Cartesian", DOUBLE_PENDULUM_CARTESIAN)]


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
    return (sp.sympify(system.L).xreplace(rep), q, [c.expr.xreplace(rep) for c in hol],
            [c.expr.xreplace(rep) for c in vel], [c.name for c in hol + vel])


def sympy_b5(system, lagranges=None) -> tuple[dict, float, float]:
    """SymPy's path to the multipliers in closed form: LagrangesMethod,
    form_lagranges_equations(), solve_multipliers() (symbolic, no operating point).
    Returns (lamech's multipliers evaluated at the initial state, SymPy's sign turned:
    lambda_lamech = -lambda_SymPy; seconds to form the equations; seconds to solve)."""
    from sympy.physics.mechanics import LagrangesMethod, dynamicsymbols, msubs
    L, q, hol, vel, names = lagranges or sympy_lagranges(system)
    t0 = time.perf_counter()
    lm = LagrangesMethod(L, q, hol_coneqs=hol or None, nonhol_coneqs=vel or None)
    lm.form_lagranges_equations()
    t1 = time.perf_counter()
    lam = lm.solve_multipliers(sol_type="Matrix")
    t2 = time.perf_counter()
    t = dynamicsymbols._t
    op = dict(system.parameter_values)
    for c, f in zip(system.coordinates, q):
        op[f.diff(t)] = float(system.numeric(c.initial_velocity))
        op[f] = float(system.numeric(c.initial))
    values = {n: -float(msubs(v, op).evalf()) for n, v in zip(names, lam)}
    return values, t1 - t0, t2 - t1


def lamech_b5(source: str) -> tuple[dict, float]:
    """lamech's path: problem text -> Solution (load + solve). Returns (multipliers at
    the initial state, seconds)."""
    import lamech
    t0 = time.perf_counter()
    sol = lamech.solve(_lamech_problem(source))
    sec = time.perf_counter() - t0
    system = sol.system
    vals = {**system.parameter_values, system.t: 0.0}
    for c in system.coordinates:
        vals[c.symbol] = float(system.numeric(c.initial))
        vals[c.velocity] = float(system.numeric(c.initial_velocity))
    out = {n: float(e.xreplace(vals).evalf()) for n, e in sol.multipliers.items()}
    return out, sec


def _cold(fn, *args):
    """fn(*args) on an empty SymPy cache (each side pays for its own expressions)."""
    from sympy.core.cache import clear_cache
    clear_cache()
    return fn(*args)


def bench_b5(cap: float, lines: list[str]):
    print("\nB5  symbolic: derivation to the multipliers")
    lines += ["## B5 derivation to the multipliers", "",
              "From the problem to every multiplier in closed form, each side on an empty "
              "SymPy cache in its own forked process, capped at "
              f"{cap:.0f} s. lamech: `lamech.load` (or `loads`) + `lamech.solve` (the "
              "Solution: equations, reduction, closed forms, integrals, forces). SymPy: "
              "`LagrangesMethod(L, q, hol_coneqs, nonhol_coneqs)` on the same L and "
              "constraints, `form_lagranges_equations()`, `solve_multipliers()` "
              "(symbolic). Both sides' multipliers agree at the initial state before a "
              "time counts.", "",
              "| problem | lamech load + solve | SymPy form | SymPy solve_multipliers "
              "| SymPy total | ratio SymPy/lamech |", "|---|---|---|---|---|---|"]
    for label, source in B5_PROBLEMS:
        system = _lamech_problem(source)
        mine, _ = _capped(_cold, (lamech_b5, source), cap)
        theirs, _ = _capped(_cold, (sympy_b5, system, sympy_lagranges(system)), cap)
        t_l = mine[1] if mine else None
        t_form, t_solve = (theirs[1], theirs[2]) if theirs else (None, None)
        if mine and theirs:
            lam, got = theirs[0], mine[0]
            missing = sorted(set(lam) - set(got))
            if missing:
                print(f"  {label}: lamech gave no closed form for {', '.join(missing)}")
            for n in set(lam) & set(got):
                if not math.isclose(lam[n], got[n], rel_tol=1e-8, abs_tol=1e-9):
                    raise AssertionError(f"B5 {label}: lambda_{n} lamech {got[n]} != "
                                         f"SymPy {lam[n]}")
        total = t_form + t_solve if theirs else None
        over = f"> {cap:.0f} s"
        if t_l and total:
            ratio = f"{total / t_l:.2g}×"
        elif t_l:
            ratio = f"> {cap / t_l:.2g}×"
        else:
            ratio = "—"
        row = (f"| {label} | {_fmt_s(t_l) if t_l else over} | {_fmt_s(t_form)} "
               f"| {_fmt_s(t_solve) if theirs else over + ' (with form)'} "
               f"| {_fmt_s(total) if theirs else over} | {ratio} |")
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
    versions = [f"Python {platform.python_version()}", f"SymPy {sympy.__version__}",
                f"NumPy {np.__version__}", f"SciPy {scipy.__version__}"]
    for mod in ("numba", "mujoco", "pydy", "Cython"):
        try:
            versions.append(f"{mod} {__import__(mod).__version__}")
        except ImportError:
            versions.append(f"{mod} not installed")
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return [f"- date: {_dt.datetime.now(_dt.timezone.utc):%Y-%m-%d %H:%M} UTC",
            f"- machine: {cpu}, {cores} cores usable, {platform.system()} {platform.machine()}",
            "- versions: " + ", ".join(versions)]


PICTURE = HERE / "work_precision.png"


def bench_startup(repeats: int, lines: list[str]) -> None:
    """Whole-process start-up: `lamech --help` and `lamech examples` against
    `python -c "import sympy"` and an empty interpreter, interleaved (each round runs all
    four), wall time min / median / max."""
    import statistics
    import subprocess
    import time

    exe = sys.executable
    cases = [("lamech --help", [exe, "-m", "lamech", "--help"]),
             ("lamech examples", [exe, "-m", "lamech", "examples"]),
             ('python -c "import sympy"', [exe, "-c", "import sympy"]),
             ('python -c "pass"', [exe, "-c", "pass"])]
    times: dict[str, list[float]] = {name: [] for name, _ in cases}
    for _ in range(repeats):
        for name, cmd in cases:
            t0 = time.perf_counter()
            subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                           check=True)
            times[name].append(time.perf_counter() - t0)
    out = ["## Start-up (whole process, wall time)", "",
           f"{repeats} interleaved rounds; target: `lamech --help` and `lamech examples` "
           "under 0.4 s.", "", "| command | min | median | max |", "|---|---|---|---|"]
    for name, ts in times.items():
        out.append(f"| `{name}` | {min(ts):.3f} s | {statistics.median(ts):.3f} s | "
                   f"{max(ts):.3f} s |")
    out.append("")
    print("\n".join(out))
    lines += out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench", description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="small sizes and caps (~2 minutes)")
    ap.add_argument("--only", choices=["startup", "B1", "B2", "B3", "B4", "B5", "symbolic"],
                    action="append",
                    help="run only these benchmarks (repeatable; symbolic is B5)")
    ap.add_argument("--out", default=None,
                    help="where to write the table (default bench/RESULTS.md; with --quick "
                         "bench/quick/RESULTS.md, with --only bench/partial/RESULTS.md, both "
                         "untracked, so a quick or partial run never overwrites the published "
                         "results)")
    args = ap.parse_args(argv)
    # a quick or partial run never overwrites the published table (untracked folders)
    folder = HERE / "quick" if args.quick else HERE / "partial" if args.only else HERE
    folder.mkdir(exist_ok=True)
    args.out = args.out or str(folder / "RESULTS.md")
    global PICTURE
    PICTURE = folder / "work_precision.png"
    want = {"B5" if w == "symbolic" else w
            for w in (args.only or ["startup", "B1", "B2", "B3", "B4", "B5"])}
    lines = ["# lamech benchmark results", "",
             f"Written by `python -m bench{' --quick' if args.quick else ''}`. Timings on a "
             "shared machine are noisy (±20%); ratios are from the same process.", ""]
    lines += _machine() + [""]
    print("\n".join(lines))
    if "startup" in want:
        bench_startup(3 if args.quick else 7, lines)
    if "B1" in want:
        bench_b1([2, 4, 8] if args.quick else [2, 4, 8, 12, 16, 30],
                 20.0 if args.quick else 120.0, lines)
    if "B2" in want:
        bench_b2([2, 8] if args.quick else [2, 8, 30], lines)
    if "B3" in want:
        bench_b3([5] if args.quick else [5, 20], 10.0, args.quick, lines)
    if "B4" in want:
        bench_b4(10 if args.quick else 100, 100 if args.quick else 1000, 10.0, lines)
    if "B5" in want:
        bench_b5(60.0 if args.quick else 300.0, lines)
    Path(args.out).write_text("\n".join(lines) + "\n", encoding="utf-8")
    print(f"\nwrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
