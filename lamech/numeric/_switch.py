"""The mode switches: the initial mode, the events (lift-off, impact, contact, slip,
stick) and :func:`settle`, which makes the mode consistent after each of them. Each
change is logged as an :class:`~lamech.numeric.Event`."""

from __future__ import annotations

import math

import numpy as np

from ..linalg import solve_kkt
from ._events import EventKind
from ._initial import initial_residuals
from ._kkt import slip_directions
from ._options import SimulationError, Stop
from ._run import Run

__all__ = ["initial_mode", "settle", "apply", "impact"]


# ----- the start ------------------------------------------------------------------
def initial_mode(
    run: Run, t0: float, y: np.ndarray, project_initial: bool, notes: list[str]
) -> np.ndarray:
    """Set the mode the initial state is in: a unilateral constraint open (f > 0) or
    opening starts released, a friction constraint with a slip velocity starts slipping.
    Returns y, projected onto the constraints when ``project_initial`` (else a state off
    them raises :class:`SimulationError`)."""
    setup, mode = run.setup, run.mode
    kinds, n = setup.kinds, setup.n
    f, F, tol = initial_residuals(setup.ns, setup.p, t0, y[:n], y[n:])
    for j in range(setup.m):
        if kinds.unilateral[j] and (f[j] > tol or (abs(f[j]) <= tol and F[j] > tol)):
            mode.open_at_start(j, f[j] > setup.arm_pos)
    mode.rebuild()
    for j in list(mode.rows):
        if kinds.normal[j] >= 0 and abs(F[j]) > tol:
            mode.start_slip(int(j), math.copysign(1.0, F[j]))
            run.dissipative = True
            run.log(t0, y, EventKind.SLIP, int(j), initial=True)
    bad = _violations(run, f, F, tol)
    if not bad:
        return y
    if not project_initial:
        raise SimulationError(
            "the initial state violates the constraints: "
            + "; ".join(bad)
            + " (tolerance 1e-10 (1 + max |q|)); fix the initial values "
            "or use `project_initial=True`"
        )
    y2, _ = run.project(t0, y)
    names = setup.ns.coordinate_names
    changes = [
        f"{name}{s}: {a:.12g} -> {b_:.12g}"
        for i, name in enumerate(names)
        for s, a, b_ in (("", y[i], y2[i]), ("'", y[n + i], y2[n + i]))
        if abs(a - b_) > 0
    ]
    notes.append(
        "initial state projected onto the constraints ("
        + "; ".join(bad)
        + "): "
        + ", ".join(changes)
    )
    return y2


def _violations(run: Run, f, F, tol) -> list[str]:
    """The active constraints the initial state does not meet, with their values."""
    names, hol = run.setup.ns.constraint_names, run.setup.kinds.holonomic
    bad = []
    for j in run.mode.rows:
        if hol[j] and abs(f[j]) > tol:
            bad.append(f"`{names[j]}` f = {f[j]:.6g}")
        elif abs(F[j]) > tol:
            bad.append(
                f"`{names[j]}` df/dt = {F[j]:.6g}" if hol[j] else f"`{names[j]}` g = {F[j]:.6g}"
            )
    return bad


# ----- settling -------------------------------------------------------------------
def settle(run: Run, t: float, y: np.ndarray) -> np.ndarray:
    """Make the mode consistent at (t, y): release unilateral constraints pulling
    (lambda < 0), let friction beyond mu N slip; log each change."""
    n = run.setup.n
    for _ in range(4 * run.setup.m + 4):
        y, _ = run.project(t, y)
        acc = run.kkt(t, y[:n], y[n:])
        lam, mu = acc.lam, acc.mu
        scale = 1.0 + float(np.nanmax(np.abs(lam), initial=0.0))
        _bilateral_normal_signs(run, lam)
        jw, worst = _most_pulling(run, lam, scale)
        if jw >= 0:
            run.mode.release(jw)
            run.log(t, y, EventKind.LIFT_OFF, jw, multiplier=float(worst))
            continue
        jw = _most_overloaded(run, lam, mu, scale)
        if jw >= 0:
            f, Af, b = run.constraints(t, y[:n])
            run.start_slip(jw, lam[jw], float(Af[jw] @ y[n:] + b[jw]))
            normal = run.setup.kinds.normal[jw]
            run.log(
                t,
                y,
                EventKind.SLIP,
                jw,
                ratio=float(abs(lam[jw]) / max(abs(mu[jw] * lam[normal]), 1e-300)),
            )
            continue
        return y
    raise Stop(
        f"the contact mode does not settle at t = {t:.12g} (constraints switch "
        "back and forth); the configuration may be degenerate"
    )


def _bilateral_normal_signs(run: Run, lam) -> None:
    """On a bilateral normal the friction limit is mu |N|: keep sign(N) (``sN``)."""
    kinds, mode = run.setup.kinds, run.mode
    for j in mode.rows:
        k = kinds.normal[j]
        if k >= 0 and not kinds.unilateral[k] and lam[k] != 0:
            mode.sN[j] = math.copysign(1.0, lam[k])


def _most_pulling(run: Run, lam, scale: float) -> tuple[int, float]:
    """(j, lambda_j) of the engaged unilateral constraint pulling hardest, or (-1, 0)."""
    worst, jw = 0.0, -1
    for j in run.mode.rows:
        if run.setup.kinds.unilateral[j] and lam[j] < -1e-12 * scale and lam[j] < worst:
            worst, jw = lam[j], int(j)
    return jw, worst


def _most_overloaded(run: Run, lam, mu, scale: float) -> int:
    """The sticking friction constraint furthest beyond mu N, or -1."""
    worst, jw = 0.0, -1
    for j in run.mode.rows:
        k = run.setup.kinds.normal[j]
        if k >= 0:
            excess = abs(lam[j]) - mu[j] * run.mode.sN[j] * lam[k]
            if excess > 1e-12 * scale and excess > worst:
                worst, jw = excess, int(j)
    return jw


# ----- events -----------------------------------------------------------------------
def apply(run: Run, t: float, y: np.ndarray, kind: EventKind, j: int) -> np.ndarray:
    """The switch of event (kind, j) at (t, y), then :func:`settle`."""
    n = run.setup.n
    if kind == EventKind.LIFT_OFF:
        run.mode.release(j)
        run.log(t, y, EventKind.LIFT_OFF, j)
    elif kind == EventKind.SLIP:
        acc = run.kkt(t, y[:n], y[n:])
        run.start_slip(j, acc.lam[j])
        run.log(t, y, EventKind.SLIP, j)
    elif kind == EventKind.STICK:
        y = _stick(run, t, y, j)
    elif kind == EventKind.CONTACT:
        y = impact(run, t, y, j)
    return settle(run, t, y)


def _stick(run: Run, t: float, y: np.ndarray, j: int) -> np.ndarray:
    """The slip velocity of friction j reached zero: it sticks if mu N can hold it, else
    it slips on (``reversal`` when the slip changes direction)."""
    n, mode = run.setup.n, run.mode
    sigma = mode.sigma[j]
    run.stick(t, y, j)
    y, _ = run.project(t, y)
    acc = run.kkt(t, y[:n], y[n:])
    k = run.setup.kinds.normal[j]
    if abs(acc.lam[j]) <= acc.mu[j] * mode.sN[j] * acc.lam[k] * (1 + 1e-9):
        run.log(t, y, EventKind.STICK, j)
    else:
        run.start_slip(j, acc.lam[j])
        run.log(t, y, EventKind.SLIP, j, reversal=bool(mode.sigma[j] != sigma))
    return y


def impact(run: Run, t: float, y: np.ndarray, j: int) -> np.ndarray:
    """Released unilateral j closes its gap: the impulse on the active rows and j gives
    F_j+ = -e F_j- (Newton's law). It bounces (``impact``) or, when e = 0 or the bounce
    is too small to resolve, engages (``contact``) with its friction sticking, or
    slipping where the impulse needed exceeds mu times the normal impulse.

    A bounce too small to resolve with 0 < e < 1, pressed back onto the surface (the
    gap's acceleration a_n < 0 with j free), begins a Zeno sequence: bounces of
    velocity e^k |F_j-|, each in flight 2 e^k |F_j-| / |a_n|, accumulating after
    2 e |F_j-| / (|a_n| (1 - e)). The impact is logged as the bounce it is; the motion
    goes on in contact from here (the bounces' heights, below 4 ``arm_pos``, are below
    what the integrator resolves, and their impulses sum to the contact's) and the
    ``contact`` is logged at the accumulation time (:attr:`ContactMode.accumulating`)."""
    setup = run.setup
    n = setup.n
    q, v = y[:n], y[n:]
    f, A, b = run.constraints(t, q)
    e = float(setup.ns.restitution(t, q, setup.p)[j])
    Fm = float(A[j] @ v + b[j])
    acc = run.kkt(t, q, v)
    a_gap = abs(float(A[j] @ acc.qdd + acc.gam[j]))
    v_small = 2.0 * math.sqrt(2.0 * a_gap * setup.arm_pos) + 10 * setup.arm_vel
    engage = e == 0 or e * abs(Fm) <= v_small
    frows = [i for i in range(setup.m) if setup.kinds.normal[i] == j] if engage else []
    M = setup.ns.dynamics(t, q, v, setup.p)[0]
    run.dissipative = run.dissipative or e < 1 or engage
    target = (0.0 if engage else -e * Fm) - b[j]
    vp, imp, slipping = _impulses(run, t, j, target, M, A, b, v, acc.mu, frows)
    details = {"impulse": float(imp[j]), "velocity_before": Fm, "restitution": e}
    y = np.concatenate((q, vp))
    if not engage:
        run.mode.disarm(EventKind.CONTACT, j)
        run.log(t, y, EventKind.IMPACT, j, **details)
        return y
    rest = _accumulation(run, t, q, vp, j, e, Fm) if 0 < e < 1 else None
    if rest is not None:  # log the bounce Newton's law gives, then go on in contact
        vb, ib, _ = _impulses(run, t, j, -e * Fm - b[j], M, A, b, v, acc.mu, [])
        bounce = np.concatenate((q, vb))
        run.log(t, bounce, EventKind.IMPACT, j, **{**details, "impulse": float(ib[j])})
    _engage(run, t, y, j, A, b, slipping)
    if rest is None:
        run.log(t, y, EventKind.CONTACT, j, **details)
    else:
        run.mode.accumulating[j] = (t, t + rest)
    for i in slipping:
        run.log(t, y, EventKind.SLIP, i, impulse=float(imp[i]))
    return y


def _accumulation(run: Run, t: float, q, vp, j: int, e: float, Fm: float) -> float | None:
    """The time the bounces of unilateral j after an impact of gap velocity ``Fm`` take
    to accumulate, 2 e |Fm| / (|a_n| (1 - e)), with a_n the gap's acceleration with j
    free at the velocities ``vp`` of the contact that follows (None where a_n >= 0: the
    motion moves off the surface by itself, no Zeno sequence)."""
    acc = run.kkt(t, q, vp)
    _, A, b = run.constraints(t, q)
    a_n = float(A[j] @ acc.qdd + acc.gam[j])
    if not a_n < 0:
        return None
    return 2.0 * e * abs(Fm) / (-a_n * (1.0 - e))


def _impulses(run: Run, t, j, target, M, A, b, v, mu, frows):
    """(q'+, {row: impulse}, {friction row: trial impulse}): the velocity jump on the
    active rows, j (its velocity form brought to ``target`` - b_j) and the friction rows
    ``frows``. A friction row whose sticking impulse would exceed mu times j's slips
    through the impact (Coulomb): its impulse is mu times j's, against the slip, and the
    returned trial impulse (the one sticking would need) gives the slip its direction.
    Friction already slipping on an active normal takes its share of that normal's
    impulse the same way."""
    mode = run.mode
    active = list(mode.rows)
    slip_j, slip_k, slip_c = (list(a) for a in mode.kernel_args[1:])

    def solve(extra, slips):
        rows = active + [j] + extra
        goal = -b[rows]
        goal[len(active)] = target
        pj, pk, pc = list(slip_j), list(slip_k), list(slip_c)
        for i, sigma in slips.items():
            pj.append(i)
            pk.append(len(active))
            pc.append(sigma)
        G = slip_directions(
            A,
            np.array(rows, dtype=np.int64),
            mu,
            np.array(pj, dtype=np.int64),
            np.array(pk, dtype=np.int64),
            np.array(pc, dtype=float),
        )
        vp, imp = solve_kkt(M, M @ v, A[rows], -goal, G)
        out = dict(zip(rows, imp))
        for i, k, c in zip(pj, pk, pc):
            out[i] = -mu[i] * c * imp[k]
        return vp, out

    slipping: dict[int, float] = {}
    try:
        vp, imp = solve(frows, {})
        slipping = {i: imp[i] for i in frows if abs(imp[i]) > mu[i] * imp[j] * (1 + 1e-9)}
        if slipping:
            sigma = {i: -math.copysign(1.0, p) for i, p in slipping.items()}
            vp, imp = solve([i for i in frows if i not in slipping], sigma)
    except np.linalg.LinAlgError:
        raise Stop(
            f"singular impact matrix at t = {t:.12g} (constraint "
            f"`{run.setup.ns.constraint_names[j]}`)"
        ) from None
    return vp, imp, slipping


def _engage(run: Run, t, y, j, A, b, slipping) -> None:
    """Unilateral j engages: its friction constraints stick, or slip through the impact
    and on (``slipping``: their trial impulses give the direction)."""
    n = run.setup.n
    run.mode.engage(j)
    for i in range(run.setup.m):
        if run.setup.kinds.normal[i] == j:
            run.stick(t, y, i)
    for i, trial in slipping.items():
        s = float(A[i] @ y[n:] + b[i])
        run.start_slip(i, trial, s)
