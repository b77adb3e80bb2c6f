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

from .arrays import all_finite, max_abs, max_abs_diff
from .codes import (
    DT_NONE,
    DT_REVERSAL,
    EV_CONTACT,
    EV_LIFT_OFF,
    EV_SLIP,
    EV_STICK,
    EV_SWITCH,
    FO_H,
    FO_MOVED,
    FO_SIZE,
    FO_T,
    FR_SLIP,
    FR_STICK,
    IO_CONTACT,
    IO_EVALUATIONS,
    IO_NEXT,
    IO_SIZE,
    LM_DIPS,
    LM_IMPACTS,
    LM_MAX_STEPS,
    LM_STARTS,
    LM_TO_END,
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
    TL_ARM_POS,
    TL_ARM_VEL,
    TL_BLOW_UP,
    TL_T_END,
    TL_TOL,
    borrowed,
)
from .dop853 import (
    STAGES,
    borrowed_tables,
    dop853_step,
    ev_dense,
    ev_dense_stages,
    ev_first_step,
)
from .impacts import ev_accumulated, ev_bound, ev_impact
from .kkt import borrowed_record, constraints, energy, rhs_kernel
from .modes import (
    ev_again,
    ev_all,
    ev_brent,
    ev_crossed,
    ev_depth,
    ev_lam,
    ev_lock,
    ev_log,
    ev_mode,
    ev_settle,
    ev_start,
    ev_switch_time,
    ev_values,
    ev_watch,
)
from .project import ev_consistent, ev_project


# KERNELS
def borrowed_mode(md):
    """The mode record borrowed (:func:`.codes.borrowed`): for a function whose caller holds
    it for the call."""
    return (borrowed(md[0]), borrowed(md[1]), borrowed(md[2]))


def borrowed_log(lg):
    """The event record borrowed (:func:`.codes.borrowed`), as :func:`borrowed_mode`."""
    return (borrowed(lg[0]), borrowed(lg[1]), borrowed(lg[2]), borrowed(lg[3]),
            borrowed(lg[4]), borrowed(lg[5]), borrowed(lg[6]))  # fmt: skip


def ev_run(sy, Y0, P, tab, modes, start, tl, lim, want, logs, outs):
    """Every row of Y0 (parameters P) through :func:`ev_run_one`, in one thread (compiled
    with ``nogil``: the caller spreads slices of a batch over threads): ``modes`` the
    constraints' kinds and each run's mode (kinds, IM, FM), ``logs`` the event records
    (kinds, constraints, times, states, details) and ``outs`` the results (states, times,
    statuses, event counts, steps), a row per run. With ``lim[LM_STARTS]``, each row of
    Y0 is first made consistent in place (:func:`.project.ev_consistent`: ``start`` the
    held coordinates and velocities and their values, (2, n) each), and a start that is
    then not finite ends its run with ST_START (``simulate`` says what is wrong); a
    sweep's starts are so made in its runs' threads, with no entry point of their own
    to load (:func:`.project.ev_starts`, 0.1 s of CPU per process)."""
    kinds, IM, FM = modes
    hold, value = start
    n = Y0.shape[1] // 2
    EK, EJ, ET, EY, EX = logs
    YOUT, TOUT, STATUS, NEV, STEPS = outs
    for b in range(Y0.shape[0]):
        if lim[LM_STARTS] == 1:
            y0 = Y0[b]
            q, v = y0[:n], y0[n:]
            ev_consistent(sy, q, v, P[b], hold[0], hold[1], value[0], value[1], kinds, tl[TL_TOL])
            if not all_finite(y0):
                YOUT[b] = y0
                TOUT[b], STATUS[b], NEV[b], STEPS[b] = 0.0, ST_START, 0, 0
                continue
        found = np.zeros(want.shape[1], dtype=np.bool_)
        lg = (EK[b], EJ[b], ET[b], EY[b], EX[b], want, found)
        md = (kinds, IM[b], FM[b])
        t, st, nev, steps = ev_run_one(sy, Y0[b], P[b], tab, md, tl, lim, lg, YOUT[b])
        TOUT[b] = t
        STATUS[b] = st
        NEV[b] = nev
        STEPS[b] = steps


def ev_run_one(sy, y0, p, tab, md, tl, lim, lg, y_out):
    """One run from t = 0 to tl[TL_T_END] in the mode ``md`` (every constraint engaged and
    sticking), the events into ``lg``: (t reached, status ST_*, events logged, steps);
    y_out the state at t. tl[TL_BLOW_UP] is a factor of 1 + max |y0| here."""
    sy, tab, md, lg = borrowed_record(sy), borrowed_tables(tab), borrowed_mode(md), borrowed_log(lg)
    y0, p, tl, lim, y_out = borrowed(y0), borrowed(p), borrowed(tl), borrowed(lim), borrowed(y_out)
    kinds, imode, fmode = md
    N = y0.shape[0]
    m = kinds.shape[1]
    y = y0.copy()
    t = 0.0
    y_out[:] = y
    nev, st = ev_start(sy, t, y, p, md, tl, lg, 0)
    if st != 0:
        return t, st, nev, 0
    nev, st = ev_settle(sy, t, y, p, md, tl, lg, nev)
    y_out[:] = y
    if st != 0:
        return t, st, nev, 0
    ev_lock(sy, t, y, p)  # each input switch held on its branch at the start
    if ev_all(lg[6], lim[LM_TO_END] == 1):
        return t, ST_FOUND, nev, 0
    bounds = tl.copy()
    bounds[TL_BLOW_UP] = tl[TL_BLOW_UP] * (1.0 + max_abs(y))
    smp = (np.zeros(0), np.zeros((0, N)), np.zeros((0, m)), np.zeros((0, 4)))
    io = np.zeros(IO_SIZE, dtype=np.int64)
    fo = np.zeros(FO_SIZE)
    fo[FO_T] = t
    t, st, nev, steps = ev_segment(sy, p, tab, md, bounds, lim, lg, nev, smp, y_out, io, fo)
    if st == ST_BUDGET:
        st = ST_STEP
    return t, st, nev, steps


def ev_sample(sy, t, y, p, act, offset, k, smp):
    """Sample k of a simulation at (t, y) into ``smp`` (_record.Recorder.record): the
    state, lambda of the mode's KKT solve, the residuals max |f_h - offset_h| and
    max |A_r v + b_r|, T and V."""
    SY, SL, SR = smp[1], smp[2], smp[3]
    rows, hrows = act[0], act[1]
    n = y.shape[0] // 2
    SY[k, :] = y
    SL[k, :] = ev_lam(sy, t, y, p, SL.shape[1], act)[1]
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


def ev_grazes(sy, t, y, t_new, yb, p, watch, imode):
    """Whether a released gap turns within the step from (t, y) to (t_new, yb): its
    velocity form changes sign (simulate's inside_step, which the loop leaves to it)."""
    wk, wj = watch
    n = y.shape[0] // 2
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
                return True
    return False


def ev_arm(sy, t, y, p, watch, md, tl):
    """Arm the disarmed contacts whose gap opened beyond tl[TL_ARM_POS] and the disarmed
    sticks whose slip velocity grew beyond tl[TL_ARM_VEL] at the accepted (t, y); whether
    any was."""
    wk, wj = watch
    kinds, imode, fmode = md
    n = y.shape[0] // 2
    armed = False
    for i in range(wk.shape[0]):
        j = wj[i]
        if (wk[i] == EV_CONTACT and imode[2, j] == 0) or (wk[i] == EV_STICK and imode[3, j] == 0):
            fb, Ab, bb = constraints(sy, t, y[:n].copy(), p)
            if wk[i] == EV_CONTACT:
                if fb[j] > tl[TL_ARM_POS]:
                    imode[2, j] = 1
                    armed = True
            else:
                s = bb[j]
                for c in range(n):
                    s += Ab[j, c] * y[n + c]
                if fmode[0, j] * s > tl[TL_ARM_VEL]:
                    imode[3, j] = 1
                    armed = True
    return armed


def ev_dips(sy, t, t_new, YS, p, watch, md, act, tl, g_a, g_b, upper):
    """Force events (lift-off: lambda_j; slip: mu N - |lambda_j|) that go through zero and
    back inside the step from t to t_new, which its ends cannot see: at the states ``YS``
    (S, 2n) of the step's dense output at its S evenly spaced interior points
    (:func:`dip_times`), for each such event positive at both ends (``g_a``, ``g_b``)
    the first point where it is <= 0 set in ``upper`` (the end of the bracket its
    crossing is sought in); whether any was.

    The step size follows the state's error only, and a multiplier is not part of the
    state: a block resting on a floor under F sin(w t) has a state that stands still, so
    a single step may span the whole rise and fall of the force, and the lift-off where
    F sin(w t) first exceeds m g would never be seen. Asked for only where the system
    depends on t explicitly (the only way a multiplier can change while the state stands
    still: lim[LM_DIPS] points); it costs that many KKT solves a step."""
    wk = watch[0]
    found = False
    for c in range(YS.shape[0]):
        s = dip_time(t, t_new, c, YS.shape[0])
        gs = ev_values(sy, s, YS[c], p, watch, md, act, tl)
        for i in range(wk.shape[0]):
            force = wk[i] == EV_LIFT_OFF or wk[i] == EV_SLIP
            if force and g_a[i] > 0.0 and g_b[i] > 0.0 and upper[i] == t_new and gs[i] <= 0.0:
                upper[i] = s
                found = True
    return found


def dip_time(t, t_new, c, samples):
    """The c-th (from 0) of ``samples`` evenly spaced interior points of a step."""
    return t + (t_new - t) * (c + 1) / (samples + 1)


def ev_apply(sy, te, ye, p, kind, j, act, md, tl, lim, lg, nev):
    """Apply the located event (kind, constraint j) at (te, ye) in the mode ``md`` (its
    active set ``act``), in place, log it and settle the mode: lift-off, slip, stick (it
    sticks, f held where it is, if mu N can hold it; else it slips on, a reversal when the
    direction changes), and a contact's impact (:func:`ev_impact`).
    (status, count, settled): status 0 (applied), ST_CONTACT (a contact left to the
    simulator, nothing changed: met below the surface, impacts not in the loop, or a
    singular impact matrix), or a failure of the settling; ``settled`` where the mode was
    settled (ye is then the settled state)."""
    kinds, imode, fmode = md
    n = ye.shape[0] // 2
    m = kinds.shape[1]
    logged = kind
    if kind == EV_CONTACT:
        # _simulate._check_penetration where the contact is met: a gap that jumped below
        # zero is the simulator's to report
        fc = constraints(sy, te, ye[:n].copy(), p)[0]
        # (no impacts: integrate_events' default)
        if fc[j] < -ev_depth(tl, ye[:n]) or lim[LM_IMPACTS] == 0:
            return ST_CONTACT, nev, False
        nev, st = ev_impact(sy, te, ye, p, j, md, tl, lg, nev)
        if st != 0:  # ST_CONTACT: not applied, the simulator applies it
            return st, nev, False
        logged = -1
    code = DT_NONE
    value = 0.0
    if kind == EV_STICK:
        sigma = fmode[0, j]
        fj = constraints(sy, te, ye[:n].copy(), p)[0][j]
        fmode[2, j] = fj if kinds[1, j] == 1 else 0.0
        imode[1, j] = FR_STICK
        act2 = ev_mode(kinds, imode, fmode)
        ev_project(sy, te, ye, p, act2[0], act2[1], fmode[2])
        lam2, mu2 = ev_lam(sy, te, ye, p, m, act2)[1:]
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
        fmode[3, j] = np.nan  # a pending accumulation is dropped
    elif kind == EV_SLIP:
        lam_j = ev_lam(sy, te, ye, p, m, act)[1][j]
        fmode[0, j] = -np.copysign(1.0, lam_j)
        imode[1, j] = FR_SLIP
        imode[3, j] = 0
    if logged >= 0:
        nev = ev_log(lg, logged, j, te, ye, code, value, nev)
        if nev < 0:
            return ST_EVENTS, 0, False
    nev, st = ev_settle(sy, te, ye, p, md, tl, lg, nev)
    return st, nev, True


def ev_switch(sy, ts, ys, p, k, md, tl, lg, nev):
    """Input switch k takes its other branch from ts on (its slot in p flipped), logged,
    and the mode settled at (ts, ys) (a force that jumps may lift a contact off): (status,
    count, settled) as :func:`ev_apply`'s."""
    slot = sy[13][k]
    p[slot] = 1.0 - p[slot]
    nev = ev_log(lg, EV_SWITCH, k, ts, ys, DT_NONE, 0.0, nev)
    if nev < 0:
        return ST_EVENTS, 0, False
    nev, st = ev_settle(sy, ts, ys, p, md, tl, lg, nev)
    return st, nev, True


def ev_segment(sy, p, tab, md, tl, lim, lg, nev, smp, y, io, fo):
    """The loop with events from (fo[FO_T], y) in the mode ``md``, settled, to
    tl[TL_T_END]: DOP853 steps (:func:`.dop853.dop853_step`; the first of size fo[FO_H],
    or scipy's initial step where that is 0), the projection, the watched events located
    and lift-off, slip, stick and impacts applied (:func:`ev_apply`), each stretch ending
    at the next accumulation time of a Zeno sequence, whose contact is logged there
    (:func:`.impacts.ev_bound`, :func:`.impacts.ev_accumulated`); the output times
    ``smp[0]`` from io[IO_NEXT] on sampled into ``smp`` (:func:`ev_sample`), the events
    into ``lg`` from ``nev`` on. Returns (t, status, events logged, steps) with ``y`` the
    state at t: at t_end (ST_END); at a located contact the loop cannot apply, before it
    is applied (ST_CONTACT, io[IO_CONTACT] its constraint: the simulator applies it);
    after lim[LM_MAX_STEPS] steps, or with the event record nearly full (ST_BUDGET: go on
    from there with the step size fo[FO_H]); ST_FOUND; and for the other statuses the
    last accepted state, from which the simulator takes over. Without lim[LM_IMPACTS]
    every located contact returns ST_CONTACT. fo[FO_MOVED]: the largest projection;
    io[IO_EVALUATIONS]: right-hand sides; tl[TL_BLOW_UP]: the size of a blow-up."""
    sy, tab, md, lg = borrowed_record(sy), borrowed_tables(tab), borrowed_mode(md), borrowed_log(lg)
    p, tl, lim, y = borrowed(p), borrowed(tl), borrowed(lim), borrowed(y)
    io, fo = borrowed(io), borrowed(fo)
    smp = (borrowed(smp[0]), borrowed(smp[1]), borrowed(smp[2]), borrowed(smp[3]))
    kinds, imode, fmode = md
    TS = smp[0]
    t = fo[FO_T]
    h_abs = fo[FO_H]
    t_end = tl[TL_T_END]
    found = lg[6]
    to_end = lim[LM_TO_END] == 1
    N = y.shape[0]
    n = N // 2
    m = kinds.shape[1]
    y_out = y
    y = y.copy()
    act = ev_mode(kinds, imode, fmode)
    watch = ev_watch(kinds, imode)
    f = rhs_kernel(sy, t, y, p, act[0], act[2], act[3], act[4])
    io[IO_EVALUATIONS] += 1
    bound = ev_bound(t_end, fmode)
    if bound <= t < t_end:  # accumulated already (_simulate._segment): a fresh start
        nev = ev_accumulated(sy, t, y, p, fmode, lg, nev)
        if nev < 0:
            return t, ST_EVENTS, 0, 0
        if ev_all(found, to_end):
            return t, ST_FOUND, nev, 0
        bound = ev_bound(t_end, fmode)
        h_abs = 0.0
    if h_abs <= 0.0:
        h_abs = ev_first_step(sy, t, y, f, p, act, bound, tl)
        io[IO_EVALUATIONS] += 1
    g_old = ev_values(sy, t, y, p, watch, md, act, tl)
    K = np.zeros((tab[7].shape[1], N))
    F = np.zeros((7, N))
    ynew = np.zeros(N)
    steps = 0
    room = 4 * m + 8  # the events one step may log (an event and its settling)
    while t < t_end:
        fo[FO_H] = h_abs
        if steps >= lim[LM_MAX_STEPS] or nev + room > lg[0].shape[0]:
            return t, ST_BUDGET, nev, steps
        t_new, h, h_abs, trials = dop853_step(sy, t, y, f, h_abs, bound, p, act, tl, tab, K, ynew)
        io[IO_EVALUATIONS] += STAGES * abs(trials)
        if trials <= 0:
            return t, ST_STEP, nev, steps
        steps += 1
        big = max_abs(ynew)
        if not np.isfinite(big) or big > tl[TL_BLOW_UP]:
            return t, ST_GROWTH, nev, steps
        yb = ynew.copy()
        ev_project(sy, t_new, yb, p, act[0], act[1], fmode[2])
        g_new = ev_values(sy, t_new, yb, p, watch, md, act, tl)
        wk = watch[0]
        released = False
        for i in range(wk.shape[0]):
            if wk[i] == EV_CONTACT:
                released = True
        if released and ev_grazes(sy, t, y, t_new, yb, p, watch, imode):
            return t, ST_GRAZE, nev, steps
        hit = False
        for i in range(wk.shape[0]):
            if g_old[i] > 0.0 and g_new[i] <= 0.0:
                hit = True
        dips = not hit and lim[LM_DIPS] > 0 and wk.shape[0] > 0
        crossed = ev_crossed(sy, t_new, yb, p)
        k = io[IO_NEXT]
        if hit or dips or crossed.shape[0] > 0 or (k < TS.shape[0] and TS[k] < t_new):
            ev_dense_stages(sy, t, y, ynew, h, p, act, tab, K, F)
            io[IO_EVALUATIONS] += 3
        dn = (t, h, y, F)
        upper = np.full(wk.shape[0], t_new)  # where each event's crossing is sought
        if dips:
            YS = np.empty((lim[LM_DIPS], N))
            for c in range(lim[LM_DIPS]):
                YS[c] = ev_dense(dip_time(t, t_new, c, lim[LM_DIPS]), dn)
            hit = ev_dips(sy, t, t_new, YS, p, watch, md, act, tl, g_old, g_new, upper)
        te = t_new
        ie = -1
        if hit:
            for i in range(wk.shape[0]):
                if (g_old[i] > 0.0 and g_new[i] <= 0.0) or upper[i] < t_new:
                    r = ev_brent(sy, i, t, upper[i], dn, p, watch, md, act, tl)
                    if ev_again(wk[i], watch[1][i], r, t_new, fmode):
                        continue  # the impact just applied: no event
                    if r < te or ie < 0:
                        te = r
                        ie = i
        switch = -1  # an input switches first: its new branch from te on
        if crossed.shape[0] > 0:
            ts, ks = ev_switch_time(sy, t, t_new, dn, p, watch, md, act, tl, crossed)
            if ie < 0 or ts <= te:
                te = ts
                switch = ks
        if ie >= 0 or switch >= 0:
            # the samples up to the event, on the dense output (Recorder.up_to)
            while k < TS.shape[0] and TS[k] <= te:
                ev_sample(sy, TS[k], ev_dense(TS[k], dn), p, act, fmode[2], k, smp)
                k += 1
            io[IO_NEXT] = k
            ye = ev_dense(te, dn)
            ev_project(sy, te, ye, p, act[0], act[1], fmode[2])
            y_out[:] = ye
            if switch >= 0:
                st, nev, settled = ev_switch(sy, te, ye, p, switch, md, tl, lg, nev)
            else:
                j = watch[1][ie]
                st, nev, settled = ev_apply(sy, te, ye, p, wk[ie], j, act, md, tl, lim, lg, nev)
                if st == ST_CONTACT:
                    io[IO_CONTACT] = j
            if settled:
                y_out[:] = ye
            if st != 0:
                return te, st, nev, steps
            if ev_all(found, to_end):
                return te, ST_FOUND, nev, steps
            t = te
            y = ye
            act = ev_mode(kinds, imode, fmode)
            watch = ev_watch(kinds, imode)
            f = rhs_kernel(sy, t, y, p, act[0], act[2], act[3], act[4])
            bound = ev_bound(t_end, fmode)
            if bound <= t:  # accumulated at the event's time: logged before going on
                nev = ev_accumulated(sy, t, y, p, fmode, lg, nev)
                if nev < 0:
                    return t, ST_EVENTS, 0, steps
                if ev_all(found, to_end):
                    return t, ST_FOUND, nev, steps
                bound = ev_bound(t_end, fmode)
            h_abs = ev_first_step(sy, t, y, f, p, act, bound, tl)
            io[IO_EVALUATIONS] += 2
            g_old = ev_values(sy, t, y, p, watch, md, act, tl)
            continue
        if released:  # a body through a surface (simulate's _check_penetration)
            fb = constraints(sy, t_new, yb[:n].copy(), p)[0]
            depth = ev_depth(tl, yb[:n])
            for i in range(wk.shape[0]):
                if wk[i] == EV_CONTACT and fb[watch[1][i]] < -depth:
                    return t, ST_PENETRATION, nev, steps
        # the samples up to the step's end: on the dense output, at t_new the projected
        # state (Recorder.up_to)
        while k < TS.shape[0] and TS[k] <= t_new:
            ys = yb if TS[k] == t_new else ev_dense(TS[k], dn)
            ev_sample(sy, TS[k], ys, p, act, fmode[2], k, smp)
            k += 1
        io[IO_NEXT] = k
        moved = max_abs_diff(yb, ynew)
        if moved > fo[FO_MOVED]:
            fo[FO_MOVED] = moved
        if ev_arm(sy, t_new, yb, p, watch, md, tl):
            g_old = ev_values(sy, t_new, yb, p, watch, md, act, tl)
        else:
            g_old = g_new
        t = t_new
        y = yb
        y_out[:] = y
        f = rhs_kernel(sy, t, y, p, act[0], act[2], act[3], act[4])
        io[IO_EVALUATIONS] += 1
        if not all_finite(f):
            return t, ST_SINGULAR, nev, steps
        if t >= bound:  # the bounces accumulated: their contacts logged, a fresh start
            nev = ev_accumulated(sy, t, y, p, fmode, lg, nev)
            if nev < 0:
                return t, ST_EVENTS, 0, steps
            if ev_all(found, to_end):
                return t, ST_FOUND, nev, steps
            if t < t_end:
                bound = ev_bound(t_end, fmode)
                h_abs = ev_first_step(sy, t, y, f, p, act, bound, tl)
                io[IO_EVALUATIONS] += 1
    fo[FO_H] = h_abs
    y_out[:] = y
    return t, ST_END, nev, steps
