"""Impacts: Newton's law with restitution on the active rows, the contact engaging with
its friction sticking or slipping through the impact, and the Zeno accumulation (the
bounces' time to rest, whose contact is logged at that time).
"""

import numpy as np

from ...linalg import gauss_inplace
from .arrays import all_finite
from .codes import (
    DT_ACCUMULATION,
    DT_IMPACT,
    DT_IMPULSE,
    EV_CONTACT,
    EV_IMPACT,
    EV_SLIP,
    FR_SLIP,
    FR_STICK,
    ST_CONTACT,
    ST_EVENTS,
    TL_ARM_POS,
    TL_ARM_VEL,
)
from .kkt import constraints, dynamics, kkt_solve, restitution
from .modes import ev_log, ev_mode


# KERNELS
def ev_impulses(M, A, b, v, mu, act, j, target, extra, through):
    """(q'+, impulses (m,): NaN where none) of the impact's solve: the velocity
    jump on the active rows (the mode's active set ``act``), j (its velocity form brought
    to ``target`` - b_j) and the rows ``extra``; the mode's slips and the friction rows
    ``through`` = (sj2, sc2) slipping through the impact on j (signs sc2) take mu times
    their normal's impulse. NaN where the matrix is singular."""
    rows, slip_j, slip_k, slip_c = act[0], act[2], act[3], act[4]
    sj2, sc2 = through
    n = M.shape[0]
    m = A.shape[0]
    na = rows.shape[0]
    k = na + 1 + extra.shape[0]
    R = np.empty(k, dtype=np.int64)
    for a in range(na):
        R[a] = rows[a]
    R[na] = j
    for a in range(extra.shape[0]):
        R[na + 1 + a] = extra[a]
    G = np.empty((k, n))
    for a in range(k):
        for c in range(n):
            G[a, c] = A[R[a], c]
    for s in range(slip_j.shape[0]):
        for c in range(n):
            G[slip_k[s], c] -= mu[slip_j[s]] * slip_c[s] * A[slip_j[s], c]
    for s in range(sj2.shape[0]):
        for c in range(n):
            G[na, c] -= mu[sj2[s]] * sc2[s] * A[sj2[s], c]
    K = np.zeros((n + k, n + k))
    x = np.zeros(n + k)
    for i in range(n):
        for c in range(n):
            K[i, c] = M[i, c]
            x[i] += M[i, c] * v[c]
    for a in range(k):
        x[n + a] = -b[R[a]]
        for c in range(n):
            K[c, n + a] = -G[a, c]
            K[n + a, c] = A[R[a], c]
    x[n + na] = target
    gauss_inplace(K, x)
    imp = np.full(m, np.nan)
    for a in range(k):
        imp[R[a]] = x[n + a]
    for s in range(slip_j.shape[0]):
        imp[slip_j[s]] = -mu[slip_j[s]] * slip_c[s] * x[n + slip_k[s]]
    for s in range(sj2.shape[0]):
        imp[sj2[s]] = -mu[sj2[s]] * sc2[s] * x[n + na]
    return x[:n].copy(), imp


def ev_impact(sy, t, y, p, j, md, tl, lg, nev):
    """Released unilateral j closes its gap at (t, y) (Newton's law): the impulse on
    the active rows and j gives F_j+ = -e F_j-; it bounces (EV_IMPACT, the contact
    disarmed) or, when e = 0 or the bounce is too small to resolve, engages (EV_CONTACT)
    with its friction sticking or slipping through the impact; a Zeno sequence (0 < e <
    1, pressed back onto the surface) logs the bounce, engages, and keeps its
    accumulation time in fmode[3, j] for :func:`ev_accumulated`; every impact's time
    goes in fmode[4, j] (for that, and :func:`.modes.ev_again`). y's velocities jump
    in place. (count, 0), or (count, ST_CONTACT) with nothing changed where the
    simulator must apply it (a singular matrix), or (0, ST_EVENTS). ``md`` the mode,
    ``lg`` the event record."""
    kinds, imode, fmode = md
    arm_pos, arm_vel = tl[TL_ARM_POS], tl[TL_ARM_VEL]
    ev_x = lg[4]
    n = y.shape[0] // 2
    m = kinds.shape[1]
    q = y[:n].copy()
    v = y[n:].copy()
    f, A, b = constraints(sy, t, q, p)
    e = restitution(sy, t, q, p)[j]
    Fm = b[j]
    for c in range(n):
        Fm += A[j, c] * v[c]
    act = ev_mode(kinds, imode, fmode)
    rows, slip_j, slip_k, slip_c = act[0], act[2], act[3], act[4]
    M, rhs, Ad, gam, mu = dynamics(sy, t, q, v, p)
    qdd = kkt_solve(sy, M, rhs, Ad, gam, mu, rows, slip_j, slip_k, slip_c)[:n].copy()
    if not all_finite(qdd):
        return nev, ST_CONTACT
    a_gap = gam[j]
    for c in range(n):
        a_gap += A[j, c] * qdd[c]
    a_gap = abs(a_gap)
    v_small = 2.0 * np.sqrt(2.0 * a_gap * arm_pos) + 10.0 * arm_vel
    engage = e == 0.0 or e * abs(Fm) <= v_small
    nf = 0
    if engage:
        for i in range(m):
            if kinds[2, i] == j:
                nf += 1
    frows = np.empty(nf, dtype=np.int64)
    nf = 0
    if engage:
        for i in range(m):
            if kinds[2, i] == j:
                frows[nf] = i
                nf += 1
    target = (0.0 if engage else -e * Fm) - b[j]
    none_i = np.zeros(0, dtype=np.int64)
    none_f = np.zeros(0)
    vp, imp = ev_impulses(M, A, b, v, mu, act, j, target, frows, (none_i, none_f))
    if not all_finite(vp):
        return nev, ST_CONTACT
    trial = imp.copy()
    ns2 = 0
    for a in range(nf):
        i = frows[a]
        if abs(imp[i]) > mu[i] * imp[j] * (1.0 + 1e-9):
            ns2 += 1
    sj2 = np.empty(ns2, dtype=np.int64)
    sc2 = np.empty(ns2)
    stay = np.empty(nf - ns2, dtype=np.int64)
    ns2 = 0
    nst = 0
    for a in range(nf):
        i = frows[a]
        if abs(imp[i]) > mu[i] * imp[j] * (1.0 + 1e-9):
            sj2[ns2] = i
            sc2[ns2] = -np.copysign(1.0, imp[i])
            ns2 += 1
        else:
            stay[nst] = i
            nst += 1
    if ns2 > 0:
        vp, imp = ev_impulses(M, A, b, v, mu, act, j, target, stay, (sj2, sc2))
        if not all_finite(vp):
            return nev, ST_CONTACT
    rest = -1.0
    vb = vp
    ib = 0.0
    if engage and 0.0 < e < 1.0:  # the bounces' time to rest
        M2, rhs2, A2, gam2, mu2 = dynamics(sy, t, q, vp, p)
        qdd2 = kkt_solve(sy, M2, rhs2, A2, gam2, mu2, rows, slip_j, slip_k, slip_c)[:n].copy()
        a_n = gam2[j]
        for c in range(n):
            a_n += A[j, c] * qdd2[c]
        if a_n < 0.0:
            rest = 2.0 * e * abs(Fm) / (-a_n * (1.0 - e))
            vb, imb = ev_impulses(M, A, b, v, mu, act, j, -e * Fm - b[j], none_i, (none_i, none_f))
            if not all_finite(vb):
                return nev, ST_CONTACT
            ib = imb[j]
    fmode[4, j] = t  # its last impact (:func:`.modes.ev_again`, ev_accumulated)
    yb = y.copy()
    yb[n:] = vb
    y[n:] = vp
    if not engage:
        imode[2, j] = 0
        nev = ev_log(lg, EV_IMPACT, j, t, y, DT_IMPACT, imp[j], nev)
        if nev < 0:
            return 0, ST_EVENTS
        ev_x[nev - 1, 2] = Fm
        ev_x[nev - 1, 3] = e
        return nev, 0
    if rest >= 0.0:
        nev = ev_log(lg, EV_IMPACT, j, t, yb, DT_IMPACT, ib, nev)
        if nev < 0:
            return 0, ST_EVENTS
        ev_x[nev - 1, 2] = Fm
        ev_x[nev - 1, 3] = e
    # j engages, its friction sticks (f held where it is), or slips on
    imode[0, j] = 1
    ev_mode(kinds, imode, fmode)
    for a in range(nf):
        i = frows[a]
        fmode[2, i] = f[i] if kinds[1, i] == 1 else 0.0
        imode[1, i] = FR_STICK
    for s in range(ns2):
        i = sj2[s]
        sv = b[i]
        for c in range(n):
            sv += A[i, c] * vp[c]
        if abs(sv) <= arm_vel:
            fmode[0, i] = -np.copysign(1.0, trial[i])
        else:
            fmode[0, i] = np.copysign(1.0, sv)
        imode[1, i] = FR_SLIP
        imode[3, i] = 0
    ev_mode(kinds, imode, fmode)
    if rest < 0.0:
        nev = ev_log(lg, EV_CONTACT, j, t, y, DT_IMPACT, imp[j], nev)
        if nev < 0:
            return 0, ST_EVENTS
        ev_x[nev - 1, 2] = Fm
        ev_x[nev - 1, 3] = e
    else:
        fmode[3, j] = t + rest
    for s in range(ns2):
        i = sj2[s]
        nev = ev_log(lg, EV_SLIP, i, t, y, DT_IMPULSE, imp[i], nev)
        if nev < 0:
            return 0, ST_EVENTS
    return nev, 0


def ev_bound(t_end, fmode):
    """The end of the next stretch: t_end, or an earlier accumulation time (the Zeno
    sequences' contacts to log: _simulate._segment's bound)."""
    bound = t_end
    for j in range(fmode.shape[1]):
        if fmode[3, j] < bound:  # NaN: none
            bound = fmode[3, j]
    return bound


def ev_accumulated(sy, t, y, p, fmode, lg, nev):
    """Log EV_CONTACT in ``lg`` for each constraint whose bounces have accumulated by t, in
    the order of their accumulation times (_simulate._accumulated); the new count, or
    -1."""
    ev_x = lg[4]
    n = y.shape[0] // 2
    while True:
        jn = -1
        for j in range(fmode.shape[1]):
            if fmode[3, j] <= t and (jn < 0 or fmode[3, j] < fmode[3, jn]):
                jn = j
        if jn < 0:
            return nev
        fmode[3, jn] = np.nan
        e = restitution(sy, t, y[:n].copy(), p)[jn]
        nev = ev_log(lg, EV_CONTACT, jn, t, y, DT_ACCUMULATION, e, nev)
        if nev < 0:
            return -1
        ev_x[nev - 1, 2] = t - fmode[4, jn]
