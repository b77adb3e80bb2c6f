"""The loop with events (:func:`lamech.numeric.integrate_events` and ``simulate``'s
:mod:`.._loop`): the DOP853 loop with a contact and friction mode, the twin of
:func:`lamech.numeric.simulate` for the events it can apply (lift-off, slip, stick with
its re-check and slip reversal, impact and contact with restitution and the Zeno
accumulation; the initial mode and each event's settling), stopping with a fallback
status where simulate's rules are not mirrored here (a singular impact matrix or a gap
met below the surface (ST_CONTACT), an inside-step graze, too many events, a start off
the constraints, a failure), so that the caller runs simulate for that case. The mode's
arrays are described in :mod:`.codes`.
"""

import numpy as np

from .codes import (
    DT_INITIAL,
    DT_NONE,
    DT_REVERSAL,
    EV_CONTACT,
    EV_LIFT_OFF,
    EV_SLIP,
    EV_STICK,
    FR_SLIP,
    FR_STICK,
    ST_BUDGET,
    ST_CONTACT,
    ST_END,
    ST_EVENTS,
    ST_FOUND,
    ST_GRAZE,
    ST_GROWTH,
    ST_PENETRATION,
    ST_SINGULAR,
    ST_START,
    ST_STEP,
)
from .dop853 import STAGES, dop853_trial, ev_dense, ev_dense_stages, ev_first_step
from .impacts import ev_accumulated, ev_bound, ev_impact
from .kkt import constraints, energy, rhs_kernel
from .modes import ev_all, ev_brent, ev_lam, ev_log, ev_mode, ev_settle, ev_values, ev_watch
from .project import ev_project


# KERNELS
def ev_run_one(
    sy,
    y0,
    p,
    t_end,
    rtol,
    atol,
    max_step,
    max_steps,
    tab,
    kinds,
    imode,
    fmode,
    arm_pos,
    arm_vel,
    blow,
    pen,
    tol,
    want,
    to_end,
    impacts,
    ev_kind,
    ev_j,
    ev_t,
    ev_y,
    ev_x,
    y_out,
):
    """One run from t = 0, every constraint engaged and sticking: (t reached, status
    ST_*, events logged, steps); y_out the state at t. ``impacts``: apply impacts in
    the loop (else a located contact stops the run with ST_CONTACT)."""
    N = y0.shape[0]
    n = N // 2
    m = kinds.shape[1]
    y = y0.copy()
    t = 0.0
    y_out[:] = y
    found = np.zeros(want.shape[1], dtype=np.bool_)
    # the start (_switch.initial_mode): a unilateral constraint open or opening starts
    # released, friction with a slip velocity starts slipping; a start off the
    # constraints is left to simulate (which refuses it with the values)
    f0, A0, b0 = constraints(sy, t, y[:n].copy(), p)
    tol_q = tol * (1.0 + np.max(np.abs(y[:n])))
    F0 = np.empty(m)
    for j in range(m):
        F0[j] = b0[j]
        for c in range(n):
            F0[j] += A0[j, c] * y[n + c]
    for j in range(m):
        if kinds[0, j] == 1 and (f0[j] > tol_q or (abs(f0[j]) <= tol_q and F0[j] > tol_q)):
            imode[0, j] = 0
            imode[2, j] = 1 if f0[j] > arm_pos else 0
    rows = ev_mode(kinds, imode, fmode)[0]
    nev = 0
    for a in range(rows.shape[0]):
        j = rows[a]
        if kinds[2, j] >= 0 and abs(F0[j]) > tol_q:
            imode[1, j] = FR_SLIP
            fmode[0, j] = np.copysign(1.0, F0[j])
            imode[3, j] = 0
            ev_mode(kinds, imode, fmode)
            nev = ev_log(
                EV_SLIP, j, t, y, want, found, ev_kind, ev_j, ev_t, ev_y, ev_x, DT_INITIAL, 0.0,
                nev,
            )  # fmt: skip
            if nev < 0:
                return t, ST_EVENTS, 0, 0
    rows = ev_mode(kinds, imode, fmode)[0]
    for a in range(rows.shape[0]):
        j = rows[a]
        if (kinds[1, j] == 1 and abs(f0[j]) > tol_q) or abs(F0[j]) > tol_q:
            return t, ST_START, nev, 0
    nev, st = ev_settle(
        sy, t, y, p, kinds, imode, fmode, arm_vel, want, found, ev_kind, ev_j, ev_t, ev_y, ev_x, nev
    )
    y_out[:] = y
    if st != 0:
        return t, st, nev, 0
    if ev_all(found, to_end):
        return t, ST_FOUND, nev, 0
    blow_up = blow * (1.0 + np.max(np.abs(y)))
    none = np.zeros(0)
    io = np.zeros(4, dtype=np.int64)
    fo = np.zeros(2)
    t, st, nev, steps = ev_segment(
        sy,
        t, y, 0.0, t_end, p, rtol, atol, max_step, max_steps, tab,
        kinds, imode, fmode, arm_pos, arm_vel, blow_up, pen, want, found, to_end, impacts,
        ev_kind, ev_j, ev_t, ev_y, ev_x, nev, none, np.zeros((0, N)), np.zeros((0, m)),
        np.zeros((0, 4)), io, fo, y_out,
    )  # fmt: skip
    if st == ST_BUDGET:
        st = ST_STEP
    return t, st, nev, steps


def ev_sample(sy, t, y, p, m, rows, hrows, slip_j, slip_k, slip_c, offset, k, SY, SL, SR):
    """Sample k of a simulation at (t, y) (_record.Recorder.record): the state, lambda of
    the mode's KKT solve, the residuals max |f_h - offset_h| and max |A_r v + b_r|, T and
    V."""
    n = y.shape[0] // 2
    SY[k, :] = y
    SL[k, :] = ev_lam(sy, t, y, p, m, rows, slip_j, slip_k, slip_c)[1]
    q = y[:n].copy()
    v = y[n:].copy()
    rp = 0.0
    rv = 0.0
    if rows.shape[0] > 0:
        f, Ac, b = constraints(sy, t, q, p)
        for a in range(hrows.shape[0]):
            rp = max(rp, abs(f[hrows[a]] - offset[hrows[a]]))
        for a in range(rows.shape[0]):
            j = rows[a]
            s = b[j]
            for c in range(n):
                s += Ac[j, c] * v[c]
            rv = max(rv, abs(s))
    E = energy(sy, t, q, v, p)
    SR[k, 0] = rp
    SR[k, 1] = rv
    SR[k, 2] = E[0]
    SR[k, 3] = E[1]


def ev_segment(
    sy,
    t,
    y,
    h_abs,
    t_end,
    p,
    rtol,
    atol,
    max_step,
    max_steps,
    tab,
    kinds,
    imode,
    fmode,
    arm_pos,
    arm_vel,
    blow_up,
    pen,
    want,
    found,
    to_end,
    impacts,
    ev_kind,
    ev_j,
    ev_t,
    ev_y,
    ev_x,
    nev,
    TS,
    SY,
    SL,
    SR,
    io,
    fo,
    y_out,
):
    """The loop with events from (t, y) in the mode (imode, fmode), settled: DOP853 steps
    (the first of size h_abs, or scipy's initial step where h_abs is 0), the projection,
    the watched events located and lift-off, slip, stick and impacts (:func:`ev_impact`)
    applied, each stretch ending at the next accumulation time of a Zeno sequence, whose
    contact is logged there (:func:`ev_bound`, :func:`ev_accumulated`); the output times
    TS from io[0] on sampled into SY, SL, SR (:func:`ev_sample`). Returns (t, status,
    events logged, steps) with y_out the state at t: at t_end (ST_END); at a located
    contact the loop cannot apply, before it is applied (ST_CONTACT, io[1] its
    constraint: the simulator applies it); after ``max_steps`` steps,
    or with the event record nearly full (ST_BUDGET: go on from there with h_abs =
    fo[0]); ST_FOUND; and for the other statuses the last accepted state, from which
    the simulator takes over. Without ``impacts`` every located contact returns
    ST_CONTACT. fo[1]: the largest projection; io[2]: right-hand sides. ``tab``: DOP853's
    tables (A, B, C, E3, E5, then the dense output's A_EXTRA, C_EXTRA, D: _batch)."""
    A, B, C, E3, E5, AX, CX, D = tab
    N = y.shape[0]
    n = N // 2
    m = kinds.shape[1]
    y = y.copy()
    y_out[:] = y
    rows, hrows, slip_j, slip_k, slip_c = ev_mode(kinds, imode, fmode)
    wk, wj = ev_watch(kinds, imode)
    f = rhs_kernel(sy, t, y, p, rows, slip_j, slip_k, slip_c)
    io[2] += 1
    bound = ev_bound(t_end, fmode)
    if bound <= t < t_end:  # accumulated already (_simulate._segment): a fresh start
        nev = ev_accumulated(sy, t, y, p, fmode, want, found, ev_kind, ev_j, ev_t, ev_y, ev_x, nev)
        if nev < 0:
            return t, ST_EVENTS, 0, 0
        if ev_all(found, to_end):
            return t, ST_FOUND, nev, 0
        bound = ev_bound(t_end, fmode)
        h_abs = 0.0
    if h_abs <= 0.0:
        h_abs = ev_first_step(
            sy, t, y, f, p, rows, slip_j, slip_k, slip_c, bound, max_step, rtol, atol
        )
        io[2] += 1
    g_old = ev_values(
        sy, t, y, p, wk, wj, kinds, imode, fmode, rows, slip_j, slip_k, slip_c, arm_pos, arm_vel
    )
    K = np.zeros((D.shape[1], N))
    F = np.zeros((7, N))
    ynew = np.zeros(N)
    steps = 0
    room = 4 * m + 8  # the events one step may log (an event and its settling)
    while t < t_end:
        fo[0] = h_abs
        if steps >= max_steps or nev + room > ev_kind.shape[0]:
            return t, ST_BUDGET, nev, steps
        min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
        if h_abs > max_step:
            h_abs = max_step
        elif h_abs < min_step:
            h_abs = min_step
        rejected = False
        t_new = t
        h = 0.0
        while True:
            if h_abs < min_step:
                return t, ST_STEP, nev, steps
            t_new = t + h_abs
            if t_new > bound:
                t_new = bound
            h = t_new - t
            h_abs = abs(h)
            err = dop853_trial(
                sy,
                t,
                y,
                f,
                h,
                p,
                rows,
                slip_j,
                slip_k,
                slip_c,
                rtol,
                atol,
                A,
                B,
                C,
                E3,
                E5,
                K,
                ynew,
            )
            io[2] += STAGES
            if err < 1.0:
                factor = 10.0 if err == 0.0 else min(10.0, 0.9 * err ** (-1.0 / 8.0))
                if rejected:
                    factor = min(1.0, factor)
                h_abs *= factor
                break
            shrink = 0.9 * err ** (-1.0 / 8.0)
            if not shrink > 0.2:  # also NaN, as max(0.2, nan) in scipy
                shrink = 0.2
            h_abs *= shrink
            rejected = True
        steps += 1
        big = np.max(np.abs(ynew))
        if not np.isfinite(big) or big > blow_up:
            return t, ST_GROWTH, nev, steps
        yb = ynew.copy()
        ev_project(sy, t_new, yb, p, rows, hrows, fmode[2])
        g_new = ev_values(
            sy,
            t_new, yb, p, wk, wj, kinds, imode, fmode, rows, slip_j, slip_k, slip_c, arm_pos,
            arm_vel,
        )  # fmt: skip
        released = False
        for i in range(wk.shape[0]):
            if wk[i] == EV_CONTACT:
                released = True
        if released:  # a gap that turns within the step: simulate's inside_step
            fa, Aa, ba = constraints(sy, t, y[:n].copy(), p)
            fb, Ab, bb = constraints(sy, t_new, yb[:n].copy(), p)
            for i in range(wk.shape[0]):
                if wk[i] == EV_CONTACT:
                    j = wj[i]
                    ra = ba[j]
                    rb = bb[j]
                    for c in range(n):
                        ra += Aa[j, c] * y[n + c]
                        rb += Ab[j, c] * yb[n + c]
                    if (imode[2, j] == 0 and ra > 0.0 > rb) or (imode[2, j] == 1 and ra < 0.0 < rb):
                        return t, ST_GRAZE, nev, steps
        hit = False
        for i in range(wk.shape[0]):
            if g_old[i] > 0.0 and g_new[i] <= 0.0:
                hit = True
        k = io[0]
        dense = hit or (k < TS.shape[0] and TS[k] < t_new)
        if dense:
            ev_dense_stages(sy, t, y, ynew, h, p, rows, slip_j, slip_k, slip_c, K, AX, CX, D, F)
            io[2] += 3
        if hit:
            te = t_new
            ie = -1
            for i in range(wk.shape[0]):
                if g_old[i] > 0.0 and g_new[i] <= 0.0:
                    r = ev_brent(
                        sy,
                        i, t, t_new, t, h, y, F, p, wk, wj, kinds, imode, fmode, rows, slip_j,
                        slip_k, slip_c, arm_pos, arm_vel,
                    )  # fmt: skip
                    if r < te or ie < 0:
                        te = r
                        ie = i
            # the samples up to the event, on the dense output (Recorder.up_to)
            while k < TS.shape[0] and TS[k] <= te:
                ys = ev_dense(TS[k], t, h, y, F)
                ev_sample(sy, TS[k], ys, p, m, rows, hrows, slip_j, slip_k, slip_c, fmode[2], k,
                          SY, SL, SR)  # fmt: skip
                k += 1
            io[0] = k
            ye = ev_dense(te, t, h, y, F)
            ev_project(sy, te, ye, p, rows, hrows, fmode[2])
            y_out[:] = ye
            kind = wk[ie]
            j = wj[ie]
            logged = kind
            if kind == EV_CONTACT:
                # _simulate._check_penetration where the contact is met: a gap that jumped
                # below zero is the simulator's to report
                fc = constraints(sy, te, ye[:n].copy(), p)[0]
                depth = max(pen * (1.0 + np.max(np.abs(ye[:n]))), 10.0 * arm_pos)
                if fc[j] < -depth:
                    io[1] = j
                    return te, ST_CONTACT, nev, steps
                if not impacts:  # left to the caller (integrate_events' default)
                    io[1] = j
                    return te, ST_CONTACT, nev, steps
                nev, st = ev_impact(
                    sy,
                    te, ye, p, j, kinds, imode, fmode, arm_pos, arm_vel, want, found, ev_kind,
                    ev_j, ev_t, ev_y, ev_x, nev,
                )  # fmt: skip
                if st == ST_CONTACT:  # not applied: the simulator applies it
                    io[1] = j
                    return te, ST_CONTACT, nev, steps
                if st != 0:
                    return te, st, nev, steps
                logged = -1
            code = DT_NONE
            value = 0.0
            if kind == EV_STICK:
                # _switch._stick: it sticks, f held where it is, if mu N can hold it;
                # else it slips on (a reversal when the direction changes)
                sigma = fmode[0, j]
                fj = constraints(sy, te, ye[:n].copy(), p)[0][j]
                fmode[2, j] = fj if kinds[1, j] == 1 else 0.0
                imode[1, j] = FR_STICK
                r2, h2, sj2, sk2, sc2 = ev_mode(kinds, imode, fmode)
                ev_project(sy, te, ye, p, r2, h2, fmode[2])
                lam2, mu2 = ev_lam(sy, te, ye, p, m, r2, sj2, sk2, sc2)[1:]
                kn = kinds[2, j]
                if not abs(lam2[j]) <= mu2[j] * fmode[1, j] * lam2[kn] * (1.0 + 1e-9):
                    fmode[0, j] = -np.copysign(1.0, lam2[j])
                    imode[1, j] = FR_SLIP
                    imode[3, j] = 0
                    logged = EV_SLIP
                    code = DT_REVERSAL
                    value = 1.0 if fmode[0, j] != sigma else 0.0
            elif kind == EV_LIFT_OFF:
                imode[0, j] = 0
                imode[2, j] = 0
                fmode[3, j] = np.nan  # Mode.release: a pending accumulation is dropped
            elif kind == EV_SLIP:
                lam_j = ev_lam(sy, te, ye, p, m, rows, slip_j, slip_k, slip_c)[1][j]
                fmode[0, j] = -np.copysign(1.0, lam_j)
                imode[1, j] = FR_SLIP
                imode[3, j] = 0
            if logged >= 0:
                nev = ev_log(
                    logged, j, te, ye, want, found, ev_kind, ev_j, ev_t, ev_y, ev_x, code, value,
                    nev,
                )  # fmt: skip
                if nev < 0:
                    return te, ST_EVENTS, 0, steps
            nev, st = ev_settle(
                sy,
                te, ye, p, kinds, imode, fmode, arm_vel, want, found, ev_kind, ev_j, ev_t, ev_y,
                ev_x, nev,
            )  # fmt: skip
            y_out[:] = ye
            if st != 0:
                return te, st, nev, steps
            if ev_all(found, to_end):
                return te, ST_FOUND, nev, steps
            t = te
            y = ye
            rows, hrows, slip_j, slip_k, slip_c = ev_mode(kinds, imode, fmode)
            wk, wj = ev_watch(kinds, imode)
            f = rhs_kernel(sy, t, y, p, rows, slip_j, slip_k, slip_c)
            bound = ev_bound(t_end, fmode)
            if bound <= t:  # accumulated at the event's time: logged before going on
                nev = ev_accumulated(sy, t, y, p, fmode, want, found, ev_kind, ev_j, ev_t, ev_y,
                                     ev_x, nev)  # fmt: skip
                if nev < 0:
                    return t, ST_EVENTS, 0, steps
                if ev_all(found, to_end):
                    return t, ST_FOUND, nev, steps
                bound = ev_bound(t_end, fmode)
            h_abs = ev_first_step(
                sy, t, y, f, p, rows, slip_j, slip_k, slip_c, bound, max_step, rtol, atol
            )
            io[2] += 2
            g_old = ev_values(
                sy,
                t,
                y,
                p,
                wk,
                wj,
                kinds,
                imode,
                fmode,
                rows,
                slip_j,
                slip_k,
                slip_c,
                arm_pos,
                arm_vel,
            )
            continue
        if released:  # a body through a surface (simulate's _check_penetration)
            fb = constraints(sy, t_new, yb[:n].copy(), p)[0]
            depth = max(pen * (1.0 + np.max(np.abs(yb[:n]))), 10.0 * arm_pos)
            for i in range(wk.shape[0]):
                if wk[i] == EV_CONTACT and fb[wj[i]] < -depth:
                    return t, ST_PENETRATION, nev, steps
        # the samples up to the step's end: on the dense output, at t_new the projected
        # state (Recorder.up_to)
        while k < TS.shape[0] and TS[k] <= t_new:
            ys = yb if TS[k] == t_new else ev_dense(TS[k], t, h, y, F)
            ev_sample(sy, TS[k], ys, p, m, rows, hrows, slip_j, slip_k, slip_c, fmode[2], k,
                      SY, SL, SR)  # fmt: skip
            k += 1
        io[0] = k
        moved = np.max(np.abs(yb - ynew))
        if moved > fo[1]:
            fo[1] = moved
        armed = False
        for i in range(wk.shape[0]):
            j = wj[i]
            if (wk[i] == EV_CONTACT and imode[2, j] == 0) or (
                wk[i] == EV_STICK and imode[3, j] == 0
            ):
                fb, Ab, bb = constraints(sy, t_new, yb[:n].copy(), p)
                if wk[i] == EV_CONTACT:
                    if fb[j] > arm_pos:
                        imode[2, j] = 1
                        armed = True
                else:
                    s = bb[j]
                    for c in range(n):
                        s += Ab[j, c] * yb[n + c]
                    if fmode[0, j] * s > arm_vel:
                        imode[3, j] = 1
                        armed = True
        if armed:
            g_old = ev_values(
                sy,
                t_new, yb, p, wk, wj, kinds, imode, fmode, rows, slip_j, slip_k, slip_c,
                arm_pos, arm_vel,
            )  # fmt: skip
        else:
            g_old = g_new
        t = t_new
        y = yb
        y_out[:] = y
        f = rhs_kernel(sy, t, y, p, rows, slip_j, slip_k, slip_c)
        io[2] += 1
        if not np.all(np.isfinite(f)):
            return t, ST_SINGULAR, nev, steps
        if t >= bound:  # the bounces accumulated: their contacts logged, a fresh start
            nev = ev_accumulated(sy, t, y, p, fmode, want, found, ev_kind, ev_j, ev_t, ev_y, ev_x,
                                 nev)  # fmt: skip
            if nev < 0:
                return t, ST_EVENTS, 0, steps
            if ev_all(found, to_end):
                return t, ST_FOUND, nev, steps
            if t < t_end:
                bound = ev_bound(t_end, fmode)
                h_abs = ev_first_step(
                    sy, t, y, f, p, rows, slip_j, slip_k, slip_c, bound, max_step, rtol, atol
                )
                io[2] += 1
    fo[0] = h_abs
    y_out[:] = y
    return t, ST_END, nev, steps


def ev_run(
    sy,
    Y0,
    P,
    t_end,
    rtol,
    atol,
    max_step,
    max_steps,
    tab,
    kinds,
    IM,
    FM,
    arm_pos,
    arm_vel,
    blow,
    pen,
    tol,
    want,
    to_end,
    impacts,
    EK,
    EJ,
    ET,
    EY,
    EX,
    YOUT,
    TOUT,
    STATUS,
    NEV,
    STEPS,
):
    """Every row of Y0 (parameters P, modes IM, FM) through :func:`ev_run_one`, in one
    thread (compiled with ``nogil``: the caller spreads slices of a batch over threads)."""
    for b in range(Y0.shape[0]):
        t, st, nev, steps = ev_run_one(
            sy,
            Y0[b],
            P[b],
            t_end,
            rtol,
            atol,
            max_step,
            max_steps,
            tab,
            kinds,
            IM[b],
            FM[b],
            arm_pos,
            arm_vel,
            blow,
            pen,
            tol,
            want,
            to_end,
            impacts,
            EK[b],
            EJ[b],
            ET[b],
            EY[b],
            EX[b],
            YOUT[b],
        )
        TOUT[b] = t
        STATUS[b] = st
        NEV[b] = nev
        STEPS[b] = steps
