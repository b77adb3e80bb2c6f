"""The contact and friction mode: the active rows, the watched events and their
functions, an event's location on the dense output (Brent), the event record, and the
settling of a mode (a constraint that pulls is released, friction beyond mu N slips).
"""

import numpy as np

from .arrays import all_finite, max_abs
from .codes import (
    DT_INITIAL,
    DT_MULTIPLIER,
    DT_RATIO,
    EV_CONTACT,
    EV_LIFT_OFF,
    EV_SLIP,
    EV_STICK,
    FR_OFF,
    FR_SLIP,
    FR_STICK,
    ST_EVENTS,
    ST_SETTLE,
    ST_SINGULAR,
    ST_START,
    TL_ARM_POS,
    TL_ARM_VEL,
    TL_PEN,
    TL_TOL,
)
from .dop853 import ev_dense
from .kkt import constraints, dynamics, kkt_solve, switches
from .project import ev_project


# KERNELS
def ev_active(j, kinds, imode):
    """Constraint j's row is in the KKT system: an engaged unilateral or a bilateral one;
    a friction constraint while it sticks and its normal's row is in."""
    for _ in range(kinds.shape[1] + 1):
        k = kinds[2, j]
        if k < 0:
            if kinds[0, j] == 1:
                return imode[0, j] == 1
            return True
        if imode[1, j] != FR_STICK:
            return False
        j = k
    return False


def ev_mode(kinds, imode, fmode):
    """(rows, hrows, slip_j, slip_k, slip_c) of the mode (friction on a
    released normal goes off, and sticks again when it engages)."""
    m = kinds.shape[1]
    rows = np.empty(m, dtype=np.int64)
    na = 0
    for j in range(m):
        k = kinds[2, j]
        if k >= 0:
            if not ev_active(k, kinds, imode):
                imode[1, j] = FR_OFF
            elif imode[1, j] == FR_OFF:
                imode[1, j] = FR_STICK
            if imode[1, j] == FR_STICK:
                rows[na] = j
                na += 1
        elif ev_active(j, kinds, imode):
            rows[na] = j
            na += 1
    pos = np.full(m, -1, dtype=np.int64)
    nh = 0
    for a in range(na):
        pos[rows[a]] = a
        if kinds[1, rows[a]] == 1:
            nh += 1
    hrows = np.empty(nh, dtype=np.int64)
    nh = 0
    for a in range(na):
        if kinds[1, rows[a]] == 1:
            hrows[nh] = rows[a]
            nh += 1
    ns = 0
    for j in range(m):
        if kinds[2, j] >= 0 and imode[1, j] == FR_SLIP:
            ns += 1
    slip_j = np.empty(ns, dtype=np.int64)
    slip_k = np.empty(ns, dtype=np.int64)
    slip_c = np.empty(ns)
    ns = 0
    for j in range(m):
        if kinds[2, j] >= 0 and imode[1, j] == FR_SLIP:
            slip_j[ns] = j
            slip_k[ns] = pos[kinds[2, j]]
            slip_c[ns] = fmode[1, j] * fmode[0, j]
            ns += 1
    return rows[:na].copy(), hrows, slip_j, slip_k, slip_c


def ev_watch(kinds, imode):
    """(kinds, constraints) of the events the mode watches: lift-off of an engaged
    unilateral constraint, contact of a released one, slip of sticking friction, stick of
    slipping friction."""
    m = kinds.shape[1]
    wk = np.empty(2 * m, dtype=np.int64)
    wj = np.empty(2 * m, dtype=np.int64)
    nw = 0
    for j in range(m):
        if kinds[0, j] == 1:
            wk[nw] = EV_LIFT_OFF if imode[0, j] == 1 else EV_CONTACT
            wj[nw] = j
            nw += 1
        if kinds[2, j] >= 0:
            if imode[1, j] == FR_STICK:
                wk[nw] = EV_SLIP
                wj[nw] = j
                nw += 1
            elif imode[1, j] == FR_SLIP:
                wk[nw] = EV_STICK
                wj[nw] = j
                nw += 1
    return wk[:nw].copy(), wj[:nw].copy()


def ev_lam(sy, t, y, p, m, act):
    """(q'', lambda (m,): NaN where inactive, the kinetic friction where slipping, mu)
    on the mode's active set ``act`` (Run.kkt)."""
    rows, slip_j, slip_k, slip_c = act[0], act[2], act[3], act[4]
    n = y.shape[0] // 2
    q = y[:n].copy()
    v = y[n:].copy()
    M, rhs, A, gam, mu = dynamics(sy, t, q, v, p)
    sol = kkt_solve(sy, M, rhs, A, gam, mu, rows, slip_j, slip_k, slip_c)
    lam = np.full(m, np.nan)
    for a in range(rows.shape[0]):
        lam[rows[a]] = sol[n + a]
    for s in range(slip_j.shape[0]):
        lam[slip_j[s]] = -mu[slip_j[s]] * slip_c[s] * sol[n + slip_k[s]]
    return sol[:n].copy(), lam, mu


def ev_values(sy, t, y, p, watch, md, act, tl):
    """The watched events' functions at (t, y) (``watch`` (kinds, constraints):
    :func:`ev_watch`): :func:`ev_functions` of the mode's KKT solve there."""
    n = y.shape[0] // 2
    m = md[0].shape[1]
    if watch[0].shape[0] == 0:
        return np.empty(0)
    qdd, lam, mu = ev_lam(sy, t, y, p, m, act)
    f, A, b = constraints(sy, t, y[:n].copy(), p)
    return ev_functions(watch, md, tl, y, lam, mu, f, A, b)


def ev_functions(watch, md, tl, y, lam, mu, f, A, b):
    """The watched events' functions of the multipliers ``lam`` (NaN where inactive, the
    kinetic friction where slipping: :func:`ev_lam`), ``mu`` and the constraints (f, A,
    b) at the state y: lambda_j of an engaged unilateral (lift-off), f_j of a released
    one (contact), mu sN N - |lambda_j| of sticking friction (slip), sigma s_j of
    slipping friction (stick); a disarmed contact or stick shifted up by its threshold.
    Each is positive while nothing happens; its event is where it crosses zero."""
    wk, wj = watch
    kinds, imode, fmode = md
    arm_pos, arm_vel = tl[TL_ARM_POS], tl[TL_ARM_VEL]
    nw = wk.shape[0]
    out = np.empty(nw)
    n = y.shape[0] // 2
    for i in range(nw):
        kind = wk[i]
        j = wj[i]
        if kind == EV_LIFT_OFF:
            out[i] = lam[j]
        elif kind == EV_CONTACT:
            out[i] = f[j] + (0.0 if imode[2, j] == 1 else arm_pos)
        elif kind == EV_SLIP:
            out[i] = mu[j] * fmode[1, j] * lam[kinds[2, j]] - abs(lam[j])
        else:
            s = b[j]
            for c in range(n):
                s += A[j, c] * y[n + c]
            out[i] = fmode[0, j] * s + (0.0 if imode[3, j] == 1 else arm_vel)
    return out


def ev_depth(tl, q):
    """How far below zero a released gap may be before it is a penetration (a body
    through a surface): 10 tl[TL_ARM_POS] (a contact is located at a gap of at most
    that arming distance below zero), or the start's tolerance tl[TL_PEN] (1 + max |q|)
    where that is larger."""
    return max(tl[TL_PEN] * (1.0 + max_abs(q)), 10.0 * tl[TL_ARM_POS])


def ev_lock(sy, t, y, p):
    """Hold every input switch on the branch it is on at (t, y): its slot in p (sy[13])
    1 where its s >= 0, else 0, each evaluated with every switch free (NaN) first."""
    slots = sy[13]
    if slots.shape[0] == 0:
        return
    n = y.shape[0] // 2
    for k in range(slots.shape[0]):
        p[slots[k]] = np.nan
    s = switches(sy, t, y[:n].copy(), y[n:].copy(), p)
    for k in range(slots.shape[0]):
        p[slots[k]] = 1.0 if s[k] >= 0.0 else 0.0


def ev_crossed(sy, t, y, p):
    """The input switches whose s at (t, y) is on the other side of their held branch."""
    slots = sy[13]
    out = np.empty(slots.shape[0], dtype=np.int64)
    if slots.shape[0] == 0:
        return out
    n = y.shape[0] // 2
    s = switches(sy, t, y[:n].copy(), y[n:].copy(), p)
    nc = 0
    for k in range(slots.shape[0]):
        if (s[k] >= 0.0) != (p[slots[k]] == 1.0):
            out[nc] = k
            nc += 1
    return out[:nc].copy()


def ev_g(sy, i, x, dn, p, watch, md, act, tl):
    """At x on the dense output ``dn``: watched event i's function (:func:`ev_values`),
    or for i < 0 input switch -1 - i's s."""
    y = ev_dense(x, dn)
    if i >= 0:
        return ev_values(sy, x, y, p, watch, md, act, tl)[i]
    n = y.shape[0] // 2
    return switches(sy, x, y[:n].copy(), y[n:].copy(), p)[-1 - i]


def ev_switch_time(sy, t, t_new, dn, p, watch, md, act, tl, crossed):
    """(ts, k): the first of the input switches ``crossed`` (:func:`ev_crossed`) in the
    step from t to t_new, located on its dense output ``dn`` (t itself where its s is
    across its held branch there already)."""
    slots = sy[13]
    ts = t_new
    ks = -1
    y = ev_dense(t, dn)
    n = y.shape[0] // 2
    s_a = switches(sy, t, y[:n].copy(), y[n:].copy(), p)
    for c in range(crossed.shape[0]):
        k = crossed[c]
        if (s_a[k] >= 0.0) != (p[slots[k]] == 1.0):
            r = t
        else:
            r = ev_brent(sy, -1 - k, t, t_new, dn, p, watch, md, act, tl)
        if r < ts or ks < 0:
            ts = r
            ks = k
    return ts, ks


def ev_brent(sy, i, xa, xb, dn, p, watch, md, act, tl):
    """Where event i's function (:func:`ev_g`: an input switch's s for i < 0) crosses
    zero on the dense output ``dn`` (:func:`.dop853.ev_dense`) in [xa, xb]: Brent's method
    as scipy.optimize.brentq (xtol 1e-15 max(1, |xb|), rtol 4 eps, 200 iterations:
    the simulator's own location, _detect._root); xb where the ends have one sign."""
    xtol = 1e-15 * max(1.0, abs(xb))
    rtol = 4.0 * 2.220446049250313e-16
    xpre = xa
    xcur = xb
    fpre = ev_g(sy, i, xpre, dn, p, watch, md, act, tl)
    fcur = ev_g(sy, i, xcur, dn, p, watch, md, act, tl)
    if fpre == 0.0:
        return xpre
    if fcur == 0.0:
        return xcur
    if (fpre < 0.0) == (fcur < 0.0):
        return xb
    xblk = 0.0
    fblk = 0.0
    spre = 0.0
    scur = 0.0
    for _ in range(200):
        if fpre != 0.0 and fcur != 0.0 and (fpre < 0.0) != (fcur < 0.0):
            xblk = xpre
            fblk = fpre
            spre = xcur - xpre
            scur = spre
        if abs(fblk) < abs(fcur):
            xpre = xcur
            xcur = xblk
            xblk = xpre
            fpre = fcur
            fcur = fblk
            fblk = fpre
        delta = (xtol + rtol * abs(xcur)) / 2.0
        sbis = (xblk - xcur) / 2.0
        if fcur == 0.0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:
                stry = -fcur * (xcur - xpre) / (fcur - fpre)
            else:
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2.0 * abs(stry) < min(abs(spre), 3.0 * abs(sbis) - delta):
                spre = scur
                scur = stry
            else:
                spre = sbis
                scur = sbis
        else:
            spre = sbis
            scur = sbis
        xpre = xcur
        fpre = fcur
        if abs(scur) > delta:
            xcur += scur
        else:
            xcur += delta if sbis > 0.0 else -delta
        fcur = ev_g(sy, i, xcur, dn, p, watch, md, act, tl)
    return xcur


def ev_again(kind, j, r, xb, fmode):
    """Whether the root r (in a step ending at xb) of the watched event (kind, j) is the
    root of contact j's last impact found again: a contact located at the time of that
    impact (fmode[4, j]) to the location's tolerance (:func:`ev_brent`'s). It is no new
    contact: the step begins on the root just applied. A bounce met at the disarmed
    threshold (f = -arm_pos: the gap still closing after an impact, which a b that is
    not df/dt makes) leaves the gap on that threshold, its function positive or negative
    by rounding; where positive, the next step's crossing was located at its start and
    the impact applied again at the same time, F+ = -e F- back and forth some forty
    times until the bounce was too small and the contact engaged, below the surface,
    with status ok. Both loops drop such a root: no event, and the gap below the
    surface at the step's end is a penetration."""
    if kind != EV_CONTACT:
        return False
    return r - fmode[4, j] <= 1e-15 * max(1.0, abs(xb)) + 4.0 * 2.220446049250313e-16 * abs(r)


def ev_log(lg, kind, j, t, y, code, value, nev):
    """Record event (kind, j) at (t, y) in the event record ``lg`` with its detail
    (``code``: DT_*, ``value``); mark the wanted events it is; the new count, or -1 when
    the record is full."""
    ev_kind, ev_j, ev_t, ev_y, ev_x, want, found = lg
    if nev >= ev_kind.shape[0]:
        return -1
    ev_kind[nev] = kind
    ev_j[nev] = j
    ev_t[nev] = t
    ev_y[nev, :] = y
    ev_x[nev, 0] = code
    ev_x[nev, 1] = value
    for c in range(2, ev_x.shape[1]):
        ev_x[nev, c] = 0.0
    for w in range(want.shape[1]):
        if want[0, w] == kind and (want[1, w] < 0 or want[1, w] == j):
            found[w] = True
    return nev + 1


def ev_start(sy, t, y, p, md, tl, lg, nev):
    """The mode the start (t, y) is in, set in ``md`` (every constraint engaged and
    sticking before): a unilateral constraint open (f > 0) or opening (f = 0, F > 0)
    starts released (its contact armed where the gap is beyond tl[TL_ARM_POS]), a
    friction constraint with a slip velocity starts slipping (logged, DT_INITIAL).
    (count, 0), or (count, ST_START) where an active constraint is not met (|f| or |F|
    beyond tl[TL_TOL] (1 + max |q|)), or (0, ST_EVENTS)."""
    kinds, imode, fmode = md
    n = y.shape[0] // 2
    m = kinds.shape[1]
    f0, A0, b0 = constraints(sy, t, y[:n].copy(), p)
    tol_q = tl[TL_TOL] * (1.0 + max_abs(y[:n]))
    F0 = np.empty(m)
    for j in range(m):
        F0[j] = b0[j]
        for c in range(n):
            F0[j] += A0[j, c] * y[n + c]
    for j in range(m):
        if kinds[0, j] == 1 and (f0[j] > tol_q or (abs(f0[j]) <= tol_q and F0[j] > tol_q)):
            imode[0, j] = 0
            imode[2, j] = 1 if f0[j] > tl[TL_ARM_POS] else 0
    rows = ev_mode(kinds, imode, fmode)[0]
    for a in range(rows.shape[0]):
        j = rows[a]
        if kinds[2, j] >= 0 and abs(F0[j]) > tol_q:
            imode[1, j] = FR_SLIP
            fmode[0, j] = np.copysign(1.0, F0[j])
            imode[3, j] = 0
            ev_mode(kinds, imode, fmode)
            nev = ev_log(lg, EV_SLIP, j, t, y, DT_INITIAL, 0.0, nev)
            if nev < 0:
                return 0, ST_EVENTS
    rows = ev_mode(kinds, imode, fmode)[0]
    for a in range(rows.shape[0]):
        j = rows[a]
        if (kinds[1, j] == 1 and abs(f0[j]) > tol_q) or abs(F0[j]) > tol_q:
            return nev, ST_START
    return nev, 0


def ev_settle(sy, t, y, p, md, tl, lg, nev):
    """Make the mode ``md`` consistent at (t, y), in place: release the
    unilateral constraint pulling hardest, else let the friction furthest beyond mu N
    slip, logging each in ``lg``; (count, 0) or (count, ST_EVENTS / ST_SETTLE /
    ST_SINGULAR)."""
    kinds, imode, fmode = md
    arm_vel = tl[TL_ARM_VEL]
    n = y.shape[0] // 2
    m = kinds.shape[1]
    for _ in range(4 * m + 4):
        act = ev_mode(kinds, imode, fmode)
        rows = act[0]
        ev_project(sy, t, y, p, rows, act[1], fmode[2])
        qdd, lam, mu = ev_lam(sy, t, y, p, m, act)
        if not all_finite(qdd):
            return nev, ST_SINGULAR
        scale = 0.0
        for j in range(m):
            if np.isfinite(lam[j]):
                scale = max(scale, abs(lam[j]))
        scale += 1.0
        for a in range(rows.shape[0]):
            j = rows[a]
            k = kinds[2, j]
            if k >= 0 and kinds[0, k] == 0 and lam[k] != 0.0:
                fmode[1, j] = np.copysign(1.0, lam[k])
        worst = 0.0
        jw = -1
        for a in range(rows.shape[0]):
            j = rows[a]
            if kinds[0, j] == 1 and lam[j] < -1e-12 * scale and lam[j] < worst:
                worst = lam[j]
                jw = j
        if jw >= 0:
            imode[0, jw] = 0
            imode[2, jw] = 0
            fmode[3, jw] = np.nan  # a pending accumulation is dropped
            nev = ev_log(lg, EV_LIFT_OFF, jw, t, y, DT_MULTIPLIER, worst, nev)
            if nev < 0:
                return 0, ST_EVENTS
            continue
        worst = 0.0
        jw = -1
        for a in range(rows.shape[0]):
            j = rows[a]
            k = kinds[2, j]
            if k >= 0:
                excess = abs(lam[j]) - mu[j] * fmode[1, j] * lam[k]
                if excess > 1e-12 * scale and excess > worst:
                    worst = excess
                    jw = j
        if jw >= 0:
            ratio = abs(lam[jw]) / max(abs(mu[jw] * lam[kinds[2, jw]]), 1e-300)
            f, A, b = constraints(sy, t, y[:n].copy(), p)
            s = b[jw]
            for c in range(n):
                s += A[jw, c] * y[n + c]
            if abs(s) <= arm_vel:
                fmode[0, jw] = -np.copysign(1.0, lam[jw])
            else:
                fmode[0, jw] = np.copysign(1.0, s)
            imode[1, jw] = FR_SLIP
            imode[3, jw] = 0
            nev = ev_log(lg, EV_SLIP, jw, t, y, DT_RATIO, ratio, nev)
            if nev < 0:
                return 0, ST_EVENTS
            continue
        return nev, 0
    return nev, ST_SETTLE


def ev_all(found, to_end):
    """Every wanted event found (and no need to go on to t_end)."""
    if to_end or found.shape[0] == 0:
        return False
    for w in range(found.shape[0]):
        if not found[w]:
            return False
    return True
