"""B7: ensembles with events, lamech's compiled loop with events against ``mujoco.rollout``
at equal accuracy of the event times.

(a) 1000 balls dropped from heights h (0.5 to 2 m), the event the first contact with the
    floor, true time sqrt(2 h / g). lamech: a point on a unilateral floor (``y >= 0``),
    ``integrate_events(want=[("contact", None)], to_end=False)``: the run stops at the
    located contact. MuJoCo: a sphere (radius 0.1) on a slide joint over a plane, contacts
    on; the contact distance (the sphere's lowest point above the plane, ``qpos``) read
    from the rolled-out states after every step.
(b) 1000 solid cylinders of the lecture's problem (``cylinder.toml``: radius R2 = 0.5
    rolling on a fixed cylinder R1 = 1) set down at rest at angles theta0 (0.02 to 0.2
    rad) from the top, rolling without slipping (the file's friction limit removed, so the
    rolling constraint holds to the end), the event the lift-off, where the normal force
    N = m g cos(theta) - m (R1 + R2) theta'^2 reaches zero: at cos(theta) = 4/7
    cos(theta0). True time from the energy integral, theta'^2 = 4 g (cos(theta0) -
    cos(theta)) / (3 (R1 + R2)), by ``scipy.integrate.quad`` (checked against mpmath at
    30 digits). lamech: ``integrate_events(want=[("lift-off", None)], to_end=False)``.
    MuJoCo: the rolling wheel in generalised coordinates, one hinge at the fixed
    cylinder's axis carrying the wheel's centre at R1 + R2 with the rolling wheel's
    kinetic energy (its inertia about the centre m (R1 + R2)^2 / 2: the arm turns at
    theta', the wheel at (R1 + R2) / R2 theta'), N read by MuJoCo's own ``force`` sensor
    (the force the hinge exerts on the wheel, along the arm). MuJoCo has no rigid
    unilateral constraint (its contacts and joint limits are soft, with a time constant
    of their own), so the hinge never lets go: like lamech's run, a run stops at the
    first lift-off, and only the time is compared.

MuJoCo's event time is the first sample where the signal (distance, N) is <= 0, placed
inside the step by linear interpolation between the two samples around the sign change,
and by the cubic through the last four samples (both reported; the comparison at equal
accuracy takes the better). ``rollout`` has no early stop: it runs in chunks of a tenth
of the longest event time, each chunk only the runs whose event has not happened yet,
so MuJoCo, like lamech, stops (to within a chunk) where each run's event is. The search
for the crossing is inside the time.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

G = 9.81
BALL_RADIUS = 0.1
R1, R2 = 1.0, 0.5
ROUNDING = 1e-14  # event-time errors below this (times of about 1 s) count as equal

BALL_DROP = f"""
title = "A ball dropped on a floor"
[parameters]
m = 1.0
g = {G}
h = 1.0
[coordinates]
y = {{ initial = "h", velocity = 0 }}
[lagrangian]
T = "m/2*y'^2"
V = "m*g*y"
[[constraints]]
name = "floor"
f = "y"
unilateral = true
"""


def lamech_ball():
    import lamech

    return lamech.loads(BALL_DROP)


def rolling_cylinder_text() -> str:
    """The lecture's ``cylinder.toml`` with the friction limit of the rolling constraint
    removed (rolling without slipping to the end: lift-off at cos(theta) = 4/7 from rest
    at the top, where with any finite mu the wheel slips first)."""
    import lamech

    text = (Path(lamech.__file__).parent / "examples" / "cylinder.toml").read_text()
    lines = text.splitlines()
    kept = [line for line in lines if not line.startswith("friction =")]
    if len(kept) != len(lines) - 1:
        raise RuntimeError("cylinder.toml: expected one friction line to remove")
    return "\n".join(kept) + "\n"


def lamech_cylinder():
    import lamech

    return lamech.loads(rolling_cylinder_text())


def cylinder_states(theta0) -> np.ndarray:
    """lamech's states (r, theta1, theta2, r', theta1', theta2') at rest at theta0, on the
    constraints (r = R1 + R2, (R1 + R2) theta1 = R2 theta2)."""
    theta0 = np.asarray(theta0, dtype=float)
    Y = np.zeros((theta0.size, 6))
    Y[:, 0] = R1 + R2
    Y[:, 1] = theta0
    Y[:, 2] = (R1 + R2) / R2 * theta0
    return Y


def liftoff_time(theta0: float, g: float = G, R: float = R1 + R2) -> float:
    """The lift-off time of the wheel set down at rest at theta0: the energy integral
    t = int d(theta) / theta' from theta0 to acos(4/7 cos(theta0)), with theta = theta0
    + s^2 (the 1/sqrt singularity at theta0 removed) and cos(theta0) - cos(theta) =
    2 sin(theta0 + s^2/2) sin(s^2/2) (no cancellation), by scipy's quad."""
    from scipy.integrate import quad

    k = 4.0 * g / (3.0 * R)
    end = math.sqrt(math.acos(4.0 / 7.0 * math.cos(theta0)) - theta0)

    def f(s):
        if s == 0.0:
            return 2.0 / math.sqrt(k * math.sin(theta0))
        u = s * s
        return 2.0 * s / math.sqrt(2.0 * k * math.sin(theta0 + u / 2) * math.sin(u / 2))

    return quad(f, 0.0, end, epsabs=0.0, epsrel=1e-13, limit=200)[0]


def liftoff_time_mpmath(theta0: float, g: float = G, R: float = R1 + R2, dps: int = 30):
    """The same integral by mpmath at ``dps`` digits (a check of :func:`liftoff_time`)."""
    import mpmath as mp

    with mp.workdps(dps):
        th0 = mp.mpf(theta0)
        k = 4 * mp.mpf(g) / (3 * mp.mpf(R))
        end = mp.sqrt(mp.acos(mp.mpf(4) / 7 * mp.cos(th0)) - th0)

        def f(s):
            u = s * s
            return 2 * s / mp.sqrt(2 * k * mp.sin(th0 + u / 2) * mp.sin(u / 2))

        return float(mp.quad(f, [0, end / 4, end]))


# ----- MuJoCo -------------------------------------------------------------------------
def mujoco_ball(integrator: str, dt: float):
    """A sphere of radius 0.1 on a slide joint (z) over a plane; qpos is the height of its
    lowest point above the plane, the contact distance."""
    import mujoco

    r = BALL_RADIUS
    xml = (
        f'<mujoco><option gravity="0 0 -{G}" timestep="{dt}" integrator="{integrator}"/>'
        '<worldbody><geom name="floor" type="plane" size="5 5 0.1"/>'
        f'<body name="ball" pos="0 0 {r}"><joint name="z" type="slide" axis="0 0 1"/>'
        f'<geom name="ball" type="sphere" size="{r}" mass="1"/></body></worldbody></mujoco>'
    )
    model = mujoco.MjModel.from_xml_string(xml)
    return model, mujoco.MjData(model)


def mujoco_cylinder(integrator: str, dt: float):
    """The wheel rolling on the fixed cylinder in generalised coordinates: a hinge (about
    y) at the fixed cylinder's axis, the wheel's centre at R1 + R2 along the arm, mass 1
    and inertia m (R1 + R2)^2 / 2 about its centre (the rolling wheel's kinetic energy,
    3/4 m (R1 + R2)^2 theta'^2); the ``force`` sensor at the centre gives the force the
    hinge exerts on the wheel in the arm's frame, its z component the normal force N."""
    import mujoco

    R = R1 + R2
    inertia = R * R / 2
    xml = (
        f'<mujoco><option gravity="0 0 -{G}" timestep="{dt}" integrator="{integrator}">'
        '<flag contact="disable"/></option><worldbody><body name="wheel">'
        '<joint name="theta" type="hinge" axis="0 1 0"/>'
        f'<inertial pos="0 0 {R}" mass="1" diaginertia="{inertia} {inertia} {inertia}"/>'
        f'<site name="centre" pos="0 0 {R}"/></body></worldbody>'
        '<sensor><force site="centre"/></sensor></mujoco>'
    )
    model = mujoco.MjModel.from_xml_string(xml)
    return model, mujoco.MjData(model)


def mujoco_states(model, data, qpos) -> np.ndarray:
    """Full-physics states, at rest, one per row of ``qpos``."""
    import mujoco

    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    qpos = np.asarray(qpos, dtype=float).reshape(len(qpos), -1)
    out = np.zeros((len(qpos), mujoco.mj_stateSize(model, spec)))
    for k, q in enumerate(qpos):
        mujoco.mj_resetData(model, data)
        data.qpos[:] = q
        mujoco.mj_getState(model, data, out[k], spec)
    return out


def crossing(V: np.ndarray, j: np.ndarray, t0: np.ndarray, dt: float):
    """Where each row of V (samples dt apart, sample i at t0 + i dt) goes from > 0 to
    <= 0 between samples j - 1 and j: (linear, cubic) times. Linear: between the two
    samples. Cubic: the root in that step of the cubic through samples j - 3 ... j (by
    bisection; the linear time where those samples are not there)."""
    rows = np.arange(len(j))
    a, b = V[rows, j - 1], V[rows, j]
    lin = a / (a - b)
    cub = lin.copy()
    ok = j >= 3
    if ok.any():
        W = np.stack([V[rows[ok], j[ok] + d] for d in (-3, -2, -1, 0)], axis=1)
        ok_rows = np.flatnonzero(ok)
        good = np.isfinite(W).all(axis=1)
        W, ok_rows = W[good], ok_rows[good]
        # the cubic p(s) through s = -2, -1, 0, 1 (s = 0 at sample j - 1)
        S = np.array([[1, s, s * s, s**3] for s in (-2.0, -1.0, 0.0, 1.0)])
        C = W @ np.linalg.inv(S).T
        lo, hi = np.zeros(len(W)), np.ones(len(W))
        for _ in range(55):
            mid = (lo + hi) / 2
            p = C[:, 0] + mid * (C[:, 1] + mid * (C[:, 2] + mid * C[:, 3]))
            above = p > 0
            lo = np.where(above, mid, lo)
            hi = np.where(above, hi, mid)
        cub[ok_rows] = (lo + hi) / 2
    base = t0 + (j - 1) * dt
    return base + lin * dt, base + cub * dt


def mujoco_events(model, datas, init, dt, t_max, signal, chunk: int):
    """First crossings of ``signal`` through zero from above, run by ``rollout`` in chunks
    of ``chunk`` steps over ``datas`` (one per thread), each chunk only the runs still
    going: (linear, cubic) times, NaN where none by ``t_max``. ``signal`` is
    ``"distance"`` (qpos after each step, the start's prepended) or ``"force"`` (the
    sensor's z, sample i at the time of the chunk's i-th state)."""
    from mujoco import rollout

    B = len(init)
    lin = np.full(B, np.nan)
    cub = np.full(B, np.nan)
    active = np.arange(B)
    state = np.array(init)
    hist = np.full((B, 3), np.nan)  # the last samples before the chunk
    if signal == "distance":
        hist[:, -1] = state[:, 1]
    k0 = 0
    steps = int(math.ceil(t_max / dt))
    while active.size and k0 < steps:
        st, sens = rollout.rollout(model, datas, state, nstep=chunk)
        if signal == "distance":
            vals, first = st[:, :, 1], k0 + 1  # sample i after step k0 + i
        else:
            vals, first = sens[:, :, 2], k0
        V = np.concatenate((hist, vals), axis=1)
        t0 = (first - 3) * dt  # the time of V's column 0
        hit = (V[:, 1:] <= 0) & (V[:, :-1] > 0)
        found = hit.any(axis=1)
        if found.any():
            j = np.argmax(hit[found], axis=1) + 1
            a, b = crossing(V[found], j, np.full(found.sum(), t0), dt)
            lin[active[found]], cub[active[found]] = a, b
        keep = ~found
        active, state = active[keep], st[keep, -1, :]
        hist = V[keep, -3:]
        k0 += chunk
    return lin, cub


# ----- the benchmark ------------------------------------------------------------------
def _threads() -> int:
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def _lamech_case(ns, Y0, t_end, rtol, want, threads):
    """A timed run of ``integrate_events`` over Y0: (wall, CPU, event times)."""
    from lamech.numeric import integrate_events

    from .run import _Clock

    kind = want[0][0]

    def run():
        with _Clock() as clock:
            res = integrate_events(
                ns, Y0, t_end, rtol=rtol, atol=rtol * 1e-2, want=want, to_end=False,
                threads=threads,
            )  # fmt: skip
            if kind == "contact":  # the loop stops at the impact (status "contact")
                times = np.where([s == "contact" for s in res.status], res.t, np.nan)
            else:
                times = np.array(
                    [next((e.t for e in ev if e.kind == kind), np.nan) for ev in res.events]
                )
        return clock.wall, clock.cpu, times

    return run


def _mujoco_case(model, threads, init, dt, t_max, signal):
    import mujoco

    from .run import _Clock

    datas = [mujoco.MjData(model) for _ in range(threads)]
    chunk = max(1, int(math.ceil(t_max / 10 / dt)))

    def run():
        with _Clock() as clock:
            lin, cub = mujoco_events(model, datas, init, dt, 1.2 * t_max, signal, chunk)
        return clock.wall, clock.cpu, lin, cub

    return run


def _table(title, got, rows, truth, lines):
    """rows: (key, method, setting, runs, is lamech). Errors: max |t - truth| over the
    runs (NaN, no event found, counts as missed)."""
    from .run import _fmt_spread

    def err(times, runs):
        d = np.abs(np.asarray(times)[:runs] - truth[:runs])
        return float("inf") if np.isnan(d).any() else float(d.max())

    done = []
    for key, method, setting, runs, mine in rows:
        timed = got[key]
        rate = runs / timed.wall.median
        errs = [err(x, runs) for x in timed.result]
        done.append((key, method, setting, runs, mine, timed, rate, errs))
    ours = [(min(e), rate, setting) for _, _, setting, _, mine, _, rate, e in done if mine]
    out = [
        f"### {title}",
        "",
        "| method | setting | runs | wall min / median / max | CPU min / median / max "
        "| runs/s | max \\|t − t_true\\| | lamech at ≤ this error: setting, runs/s | "
        "lamech / this |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for _, method, setting, runs, mine, timed, rate, errs in done:
        if mine:
            error = f"{errs[0]:.1e}"
            best = same = "—"
        else:
            error = f"linear {errs[0]:.1e}; cubic {errs[1]:.1e}"
            fits = [(r, s) for e, r, s in ours if e <= max(min(errs), ROUNDING)]
            if fits:
                r, s = max(fits)
                best, same = f"{s}: {r:.3g}", f"{r / rate:.3g}×"
            else:
                best, same = "none as accurate", "—"
        out.append(
            f"| {method} | {setting} | {runs} | {_fmt_spread(timed.wall)} "
            f"| {_fmt_spread(timed.cpu)} | {rate:.3g} | {error} | {best} | {same} |"
        )
    out.append("")
    print("\n".join("  " + line for line in out))
    lines += out


def bench_b7(count: int, quick: bool, lines: list[str], repeats: int = 3) -> None:
    """B7 (this module's docstring): ``count`` runs of each ensemble (a tenth of it for
    MuJoCo's finest steps), ``repeats`` interleaved rounds."""
    import mujoco

    from lamech.numeric import compile_system

    from .run import interleave

    threads = min(2, _threads())
    small = max(10, count // 10)
    rng = np.random.default_rng(7)
    h = rng.uniform(0.5, 2.0, count)
    theta0 = rng.uniform(0.02, 0.2, count)
    print("\nB7  ensembles with events: balls dropped on a floor, cylinders lifting off")
    ball_ns = compile_system(lamech_ball(), jit=True)
    cyl_ns = compile_system(lamech_cylinder(), jit=True)
    for ns in (ball_ns, cyl_ns):
        if not ns.jit:
            print(f"  {ns.system.title!r} runs as Python: no C compiler for its functions")
    # (a) balls
    truth_a = np.sqrt(2 * h / G)
    Y0 = np.column_stack((h, np.zeros(count)))
    want_a = [("contact", None)]
    # compile / load outside the time; a run at h: contact at sqrt(2 h / g)
    _lamech_case(ball_ns, Y0[:2], 5.0, 1e-6, want_a, threads)()
    rtols_a = (1e-6, 1e-10) if quick else (1e-3, 1e-6, 1e-10)
    cases, rows = [], []
    for rtol in rtols_a:
        key = f"lamech {rtol:g}"
        cases.append((key, _lamech_case(ball_ns, Y0, 5.0, rtol, want_a, threads)))
        rows.append(
            (key, f"lamech `integrate_events` ({threads} threads)", f"rtol {rtol:g}", count, True)
        )
    mj_a = (
        [("Euler", 1e-3, True), ("RK4", 1e-3, True), ("RK4", 1e-2, False)]
        if quick
        else [
            ("Euler", 1e-3, True),
            ("Euler", 1e-4, True),
            ("RK4", 1e-2, True),
            ("RK4", 1e-3, True),
            ("RK4", 1e-4, True),
            ("RK4", 1e-2, False),
            ("RK4", 1e-3, False),
        ]
    )
    for integrator, dt, contact in mj_a:
        runs = count if dt >= 1e-3 else small
        model, data = mujoco_ball(integrator, dt)
        if not contact:
            model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
        init = mujoco_states(model, data, h[:runs, None])
        key = f"mujoco {integrator} {dt:g} {contact}"
        cases.append((key, _mujoco_case(model, threads, init, dt, truth_a.max(), "distance")))
        what = "sphere on a plane" if contact else "contacts off (a falling point)"
        rows.append(
            (key, f"`mujoco.rollout` ({threads} threads), {what}", f"{integrator} dt {dt:g}",
             runs, False)
        )  # fmt: skip
    got = interleave(cases, repeats)
    lines += [
        "## B7 ensembles with events",
        "",
        f"{count} runs each (MuJoCo's steps under 1 ms: {small}), {repeats} interleaved "
        "rounds (every row once per round, the order reversed every other round); wall and "
        "CPU time (the process's, all threads) min / median / max; runs/s from the median "
        f"wall time; {threads} threads on both sides (lamech's `integrate_events` slices "
        "the batch over a thread pool, the compiled loop releases the GIL; `rollout` gets "
        f"{threads} MjData). lamech's rows run each case to its located event (`want`, "
        "`to_end=False`), atol = rtol/100. MuJoCo's event: the first sample where the "
        "contact distance or the normal force is ≤ 0, placed inside the step linearly "
        "between the two samples around the sign change and by the cubic through the "
        "last four samples (both errors given; the comparison takes the better); "
        "`rollout` in chunks of a tenth of the longest event time, each chunk only the "
        "runs not yet done (it has no stop of its own); the crossing search is in the "
        "time. Last two columns: lamech's fastest row at an event-time error no larger "
        "than this row's (errors under 1e-14, rounding for times of about a second, count as "
        "equal), and lamech's runs/s over this row's.",
        "",
    ]
    _table(
        "(a) balls dropped from h in 0.5–2 m, the first contact; t_true = sqrt(2h/g)",
        got, rows, truth_a, lines,
    )  # fmt: skip
    # (b) cylinders
    from .run import _Clock

    with _Clock() as clock:
        truth_b = np.array([liftoff_time(a) for a in theta0])
    check = max(abs(liftoff_time(a) - liftoff_time_mpmath(a)) for a in (0.02, 0.1, 0.2))
    Y0 = cylinder_states(theta0)
    want_b = [("lift-off", None)]
    _lamech_case(cyl_ns, Y0[:2], 10.0, 1e-6, want_b, threads)()
    rtols_b = (1e-6, 1e-10) if quick else (1e-4, 1e-6, 1e-8, 1e-10, 1e-12, 1e-14)
    cases, rows = [], []
    for rtol in rtols_b:
        key = f"lamech {rtol:g}"
        cases.append((key, _lamech_case(cyl_ns, Y0, 10.0, rtol, want_b, threads)))
        rows.append(
            (key, f"lamech `integrate_events` ({threads} threads)", f"rtol {rtol:g}", count, True)
        )
    mj_b = (
        [("RK4", 1e-2), ("RK4", 1e-3)]
        if quick
        else [
            ("Euler", 1e-3),
            ("Euler", 1e-4),
            ("RK4", 1e-2),
            ("RK4", 3e-3),
            ("RK4", 1e-3),
            ("RK4", 1e-4),
        ]
    )
    for integrator, dt in mj_b:
        runs = count if dt >= 1e-3 else small
        model, data = mujoco_cylinder(integrator, dt)
        init = mujoco_states(model, data, theta0[:runs, None])
        key = f"mujoco {integrator} {dt:g}"
        cases.append((key, _mujoco_case(model, threads, init, dt, truth_b.max(), "force")))
        rows.append(
            (key, f"`mujoco.rollout` ({threads} threads), hinge + force sensor",
             f"{integrator} dt {dt:g}", runs, False)
        )  # fmt: skip
    got = interleave(cases, repeats)
    lines += [
        f"True lift-off times of (b) by `quad` ({clock.wall:.2g} s for {count}, outside "
        f"the time), within {check:.1e} of mpmath at 30 digits at theta0 = 0.02, 0.1, 0.2.",
        "",
    ]
    _table(
        "(b) cylinders rolling on the fixed cylinder from rest at theta0 in 0.02–0.2 rad, "
        "the lift-off; t_true from the energy integral",
        got, rows, truth_b, lines,
    )  # fmt: skip
