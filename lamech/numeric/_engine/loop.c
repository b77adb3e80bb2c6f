/* The loop with events (integrate_events and simulate's loop): the DOP853 loop with a
 * contact and friction mode, applying lift-off, slip, stick (its re-check and reversal),
 * impacts and contacts with restitution and the Zeno accumulation, input switches, and
 * stopping with a fallback status where the simulator must take over. Twin of
 * lamech/numeric/_kernels/loop.py; the entry points lm_ev_segment and lm_ev_run.
 */
#include <math.h>
#include <string.h>

#include "events.h"

static void copy_state(double *to, const double *from, int64_t N)
{
    memcpy(to, from, (size_t)N * sizeof(double));
}

/* loop.ev_sample: sample k at (t, y) into smp: the state, lambda of the mode's KKT solve,
 * the residuals max |f_h - offset_h| and max |A_r v + b_r|, T and V */
static void ev_sample(lm_ctx *cx, double t, const double *y, const double *p,
                      const lm_act *act, const double *offset, int64_t k, lm_samples *smp)
{
    int64_t n = cx->sy->n, m = smp->m, N = smp->N;
    lm_mark mk = lm_mark_now(cx);
    copy_state(smp->SY + k * N, y, N);
    double *qdd = lm_doubles(cx, n);
    double *mu = lm_doubles(cx, m);
    ev_lam(cx, t, y, p, act, qdd, smp->SL + k * m, mu);
    double rp = 0.0, rv = 0.0;
    if (act->na > 0) {
        double *f = lm_doubles(cx, m);
        double *Ac = lm_doubles(cx, m * n);
        double *b = lm_doubles(cx, m);
        lm_constraints(cx, t, y, p, f, Ac, b);
        for (int64_t a = 0; a < act->nh; a++) {
            int64_t h = act->hrows[a];
            rp = lm_pymax(rp, fabs(f[h] - offset[h]));
        }
        for (int64_t a = 0; a < act->na; a++) {
            int64_t j = act->rows[a];
            double s = b[j];
            for (int64_t c = 0; c < n; c++)
                s += Ac[j * n + c] * y[n + c];
            rv = lm_pymax(rv, fabs(s));
        }
    }
    double E[2];
    lm_energy(cx, t, y, y + n, p, E);
    double *SR = smp->SR + k * 4;
    SR[0] = rp;
    SR[1] = rv;
    SR[2] = E[0];
    SR[3] = E[1];
    lm_release(cx, mk);
}

/* loop.ev_grazes: whether a released gap turns within the step from (t, y) to (t_new,
 * yb): its velocity form changes sign (simulate's inside_step) */
static int ev_grazes(lm_ctx *cx, double t, const double *y, double t_new, const double *yb,
                     const double *p, const lm_watch *w, const lm_mode *md)
{
    int64_t n = cx->sy->n, m = md->m;
    lm_mark mk = lm_mark_now(cx);
    double *fa = lm_doubles(cx, m), *Aa = lm_doubles(cx, m * n), *ba = lm_doubles(cx, m);
    double *fb = lm_doubles(cx, m), *Ab = lm_doubles(cx, m * n), *bb = lm_doubles(cx, m);
    lm_constraints(cx, t, y, p, fa, Aa, ba);
    lm_constraints(cx, t_new, yb, p, fb, Ab, bb);
    int out = 0;
    for (int64_t i = 0; i < w->nw && !out; i++) {
        if (w->wk[i] == LM_EV_CONTACT) {
            int64_t j = w->wj[i];
            double ra = ba[j], rb = bb[j];
            for (int64_t c = 0; c < n; c++) {
                ra += Aa[j * n + c] * y[n + c];
                rb += Ab[j * n + c] * yb[n + c];
            }
            int64_t armed = LM_IMODE(md, 2, j);
            if ((armed == 0 && ra > 0.0 && 0.0 > rb) || (armed == 1 && ra < 0.0 && 0.0 < rb))
                out = 1;
        }
    }
    lm_release(cx, mk);
    return out;
}

/* loop.ev_arm: arm the disarmed contacts whose gap opened beyond tl[TL_ARM_POS] and the
 * disarmed sticks whose slip velocity grew beyond tl[TL_ARM_VEL] at (t, y); whether any */
int ev_arm(lm_ctx *cx, double t, const double *y, const double *p, const lm_watch *w,
                  lm_mode *md, const double *tl)
{
    int64_t n = cx->sy->n, m = md->m;
    lm_mark mk = lm_mark_now(cx);
    double *fb = NULL, *Ab = NULL, *bb = NULL;
    int armed = 0;
    for (int64_t i = 0; i < w->nw; i++) {
        int64_t j = w->wj[i];
        if ((w->wk[i] == LM_EV_CONTACT && LM_IMODE(md, 2, j) == 0) ||
            (w->wk[i] == LM_EV_STICK && LM_IMODE(md, 3, j) == 0)) {
            if (fb == NULL) { /* the same values at each: evaluated once */
                fb = lm_doubles(cx, m);
                Ab = lm_doubles(cx, m * n);
                bb = lm_doubles(cx, m);
                lm_constraints(cx, t, y, p, fb, Ab, bb);
            }
            if (w->wk[i] == LM_EV_CONTACT) {
                if (fb[j] > tl[LM_TL_ARM_POS]) {
                    LM_IMODE(md, 2, j) = 1;
                    armed = 1;
                }
            } else {
                double s = bb[j];
                for (int64_t c = 0; c < n; c++)
                    s += Ab[j * n + c] * y[n + c];
                if (LM_FMODE(md, 0, j) * s > tl[LM_TL_ARM_VEL]) {
                    LM_IMODE(md, 3, j) = 1;
                    armed = 1;
                }
            }
        }
    }
    lm_release(cx, mk);
    return armed;
}

/* loop.dip_time: the c-th (from 0) of samples evenly spaced interior points of a step */
double dip_time(double t, double t_new, int64_t c, int64_t samples)
{
    return t + (t_new - t) * (double)(c + 1) / (double)(samples + 1);
}

/* loop.ev_dips: force events (lift-off, slip) positive at both ends of the step (g_a,
 * g_b) that go through zero inside it: at the states YS (S, N) of the dense output at its
 * S interior points, the first point where one is <= 0 set in upper; whether any was */
int ev_dips(lm_ctx *cx, double t, double t_new, const double *YS, int64_t S,
                   const double *p, const lm_watch *w, const lm_mode *md, const lm_act *act,
                   const double *tl, const double *g_a, const double *g_b, double *upper)
{
    int64_t N = 2 * cx->sy->n;
    int found = 0;
    lm_mark mk = lm_mark_now(cx);
    double *gs = lm_doubles(cx, w->nw);
    for (int64_t c = 0; c < S; c++) {
        double s = dip_time(t, t_new, c, S);
        ev_values(cx, s, YS + c * N, p, w, md, act, tl, gs);
        for (int64_t i = 0; i < w->nw; i++) {
            int force = w->wk[i] == LM_EV_LIFT_OFF || w->wk[i] == LM_EV_SLIP;
            if (force && g_a[i] > 0.0 && g_b[i] > 0.0 && upper[i] == t_new && gs[i] <= 0.0) {
                upper[i] = s;
                found = 1;
            }
        }
    }
    lm_release(cx, mk);
    return found;
}

/* loop.ev_apply: apply the located event (kind, j) at (te, ye) in the mode md (its active
 * set act), in place, log it and settle the mode: lift-off, slip, stick (or slip on, a
 * reversal where the direction changes), a contact's impact. The status: 0, ST_CONTACT
 * (nothing changed: below the surface, impacts not in the loop, singular), or the
 * settling's failure; *settled where the mode was settled (ye the settled state). */
int64_t ev_apply(lm_ctx *cx, double te, double *ye, double *p, int64_t kind, int64_t j,
                        const lm_act *act, lm_mode *md, const double *tl, const int64_t *lim,
                        lm_log *lg, int64_t *nev, int *settled)
{
    int64_t n = cx->sy->n, m = md->m;
    int64_t logged = kind;
    *settled = 0;
    lm_mark mk = lm_mark_now(cx);
    if (kind == LM_EV_CONTACT) {
        /* a gap that jumped below zero is the simulator's to report */
        double *fc = lm_doubles(cx, m), *A = lm_doubles(cx, m * n), *b = lm_doubles(cx, m);
        lm_constraints(cx, te, ye, p, fc, A, b);
        if (fc[j] < -ev_depth(tl, ye, n) || lim[LM_LM_IMPACTS] == 0) {
            lm_release(cx, mk);
            return LM_ST_CONTACT;
        }
        int64_t st = ev_impact(cx, te, ye, p, j, md, tl, lg, nev);
        if (st != 0) { /* ST_CONTACT: not applied, the simulator applies it */
            lm_release(cx, mk);
            return st;
        }
        logged = -1;
    }
    int64_t code = LM_DT_NONE;
    double value = 0.0;
    if (kind == LM_EV_STICK) {
        double sigma = LM_FMODE(md, 0, j);
        double *f = lm_doubles(cx, m), *A = lm_doubles(cx, m * n), *b = lm_doubles(cx, m);
        lm_constraints(cx, te, ye, p, f, A, b);
        LM_FMODE(md, 2, j) = LM_KIND(md, 1, j) == 1 ? f[j] : 0.0;
        LM_IMODE(md, 1, j) = LM_FR_STICK;
        lm_act act2 = lm_act_new(cx, m);
        ev_mode(md, &act2);
        lm_project(cx, te, ye, p, &act2, md->fmode + 2 * m);
        double *qdd = lm_doubles(cx, n), *lam2 = lm_doubles(cx, m), *mu2 = lm_doubles(cx, m);
        ev_lam(cx, te, ye, p, &act2, qdd, lam2, mu2);
        int64_t kn = LM_KIND(md, 2, j);
        if (!(fabs(lam2[j]) <= mu2[j] * LM_FMODE(md, 1, j) * lam2[kn] * (1.0 + 1e-9))) {
            LM_FMODE(md, 0, j) = -copysign(1.0, lam2[j]);
            LM_IMODE(md, 1, j) = LM_FR_SLIP;
            LM_IMODE(md, 3, j) = 0;
            logged = LM_EV_SLIP;
            code = LM_DT_REVERSAL;
            value = LM_FMODE(md, 0, j) != sigma ? 1.0 : 0.0;
        }
    } else if (kind == LM_EV_LIFT_OFF) {
        LM_IMODE(md, 0, j) = 0;
        LM_IMODE(md, 2, j) = 0;
        LM_FMODE(md, 3, j) = NAN; /* a pending accumulation is dropped */
    } else if (kind == LM_EV_SLIP) {
        double *qdd = lm_doubles(cx, n), *lam = lm_doubles(cx, m), *mu = lm_doubles(cx, m);
        ev_lam(cx, te, ye, p, act, qdd, lam, mu);
        LM_FMODE(md, 0, j) = -copysign(1.0, lam[j]);
        LM_IMODE(md, 1, j) = LM_FR_SLIP;
        LM_IMODE(md, 3, j) = 0;
    }
    lm_release(cx, mk);
    if (logged >= 0) {
        *nev = ev_log(lg, logged, j, te, ye, code, value, *nev);
        if (*nev < 0) {
            *nev = 0;
            return LM_ST_EVENTS;
        }
    }
    int64_t st = ev_settle(cx, te, ye, p, md, tl, lg, nev);
    *settled = 1;
    return st;
}

/* loop.ev_switch: input switch k takes its other branch from ts on (its slot in p
 * flipped), logged, and the mode settled at (ts, ys): as ev_apply's */
int64_t ev_switch(lm_ctx *cx, double ts, double *ys, double *p, int64_t k, lm_mode *md,
                         const double *tl, lm_log *lg, int64_t *nev, int *settled)
{
    int64_t slot = cx->sy->slots[k];
    *settled = 0;
    p[slot] = 1.0 - p[slot];
    *nev = ev_log(lg, LM_EV_SWITCH, k, ts, ys, LM_DT_NONE, 0.0, *nev);
    if (*nev < 0) {
        *nev = 0;
        return LM_ST_EVENTS;
    }
    int64_t st = ev_settle(cx, ts, ys, p, md, tl, lg, nev);
    *settled = 1;
    return st;
}

#define SEGMENT_RETURN(T, ST, NEV, STEPS)                                                     \
    do {                                                                                      \
        *t_out = (T);                                                                         \
        *nev_out = (NEV);                                                                     \
        *steps_out = (STEPS);                                                                 \
        return (ST);                                                                          \
    } while (0)

/* loop.ev_segment: the loop with events from (fo[FO_T], y) in the mode md, settled, to
 * tl[TL_T_END]: DOP853 steps (the first of size fo[FO_H], or scipy's initial step where
 * that is 0), the projection, the watched events located and applied, each stretch ending
 * at the next accumulation time of a Zeno sequence (its contact logged there); the output
 * times from io[IO_NEXT] on sampled into smp, the events into lg from nev on. Returns the
 * status, with *t_out, *nev_out, *steps_out and y the state at *t_out: ST_END; ST_CONTACT
 * (io[IO_CONTACT] its constraint, before it is applied); ST_BUDGET (go on from there with
 * the step size fo[FO_H]); ST_FOUND; the others at the last accepted state.
 * fo[FO_MOVED]: the largest projection; io[IO_EVALUATIONS]: right-hand sides. The mode's
 * act, watch and g arrays are made once at capacity and refilled on mode changes; a
 * step's scratch is released at its end. */
int64_t ev_segment(lm_ctx *cx, double *p, lm_mode *md, const double *tl, const int64_t *lim,
                   lm_log *lg, int64_t nev, lm_samples *smp, double *y_out, int64_t *io,
                   double *fo, double *t_out, int64_t *nev_out, int64_t *steps_out)
{
    const lm_system *sy = cx->sy;
    const double *TS = smp->TS;
    int64_t S = smp->S;
    double t = fo[LM_FO_T];
    double h_abs = fo[LM_FO_H];
    double t_end = tl[LM_TL_T_END];
    int to_end = lim[LM_LM_TO_END] == 1;
    int64_t n = sy->n, N = 2 * n, m = md->m;
    int64_t wcap = 2 * m > 0 ? 2 * m : 1;
    double *offset = md->fmode + 2 * m;
    double *y = lm_copy(cx, y_out, N);
    double *yb = lm_zeros(cx, N);
    double *ynew = lm_zeros(cx, N);
    double *f = lm_zeros(cx, N);
    double *K = lm_zeros(cx, LM_EXTENDED * N);
    double *F = lm_zeros(cx, LM_DENSE_F * N);
    double *g_old = lm_zeros(cx, wcap);
    double *g_new = lm_zeros(cx, wcap);
    double *upper = lm_zeros(cx, wcap);
    int64_t *crossed = lm_ints(cx, sy->nslots > 0 ? sy->nslots : 1);
    lm_act act = lm_act_new(cx, m);
    lm_watch w;
    w.nw = 0;
    w.wk = lm_ints(cx, wcap);
    w.wj = lm_ints(cx, wcap);
    ev_mode(md, &act);
    ev_watch(md, &w);
    lm_rhs(cx, t, y, p, &act, f);
    io[LM_IO_EVALUATIONS] += 1;
    double bound = ev_bound(t_end, md);
    if (bound <= t && t < t_end) { /* accumulated already: a fresh start */
        nev = ev_accumulated(cx, t, y, p, md, lg, nev);
        if (nev < 0)
            SEGMENT_RETURN(t, LM_ST_EVENTS, 0, 0);
        if (ev_all(lg, to_end))
            SEGMENT_RETURN(t, LM_ST_FOUND, nev, 0);
        bound = ev_bound(t_end, md);
        h_abs = 0.0;
    }
    if (h_abs <= 0.0) {
        h_abs = lm_first_step(cx, t, y, f, p, &act, bound, tl);
        io[LM_IO_EVALUATIONS] += 1;
    }
    ev_values(cx, t, y, p, &w, md, &act, tl, g_old);
    int64_t steps = 0;
    int64_t room = 4 * m + 8; /* the events one step may log (an event and its settling) */
    while (t < t_end) {
        lm_mark mk = lm_mark_now(cx);
        fo[LM_FO_H] = h_abs;
        if (steps >= lim[LM_LM_MAX_STEPS] || nev + room > lg->cap)
            SEGMENT_RETURN(t, LM_ST_BUDGET, nev, steps);
        double h = 0.0, h_next = 0.0;
        int64_t trials = 0;
        double t_new = lm_dop853_step(cx, t, y, f, h_abs, bound, p, &act, tl, K, ynew, &h,
                                      &h_next, &trials);
        h_abs = h_next;
        io[LM_IO_EVALUATIONS] += LM_STAGES * (trials < 0 ? -trials : trials);
        if (trials <= 0)
            SEGMENT_RETURN(t, LM_ST_STEP, nev, steps);
        steps += 1;
        double big = lm_max_abs(ynew, N);
        if (!isfinite(big) || big > tl[LM_TL_BLOW_UP])
            SEGMENT_RETURN(t, LM_ST_GROWTH, nev, steps);
        copy_state(yb, ynew, N);
        lm_project(cx, t_new, yb, p, &act, offset);
        ev_values(cx, t_new, yb, p, &w, md, &act, tl, g_new);
        int released = 0;
        for (int64_t i = 0; i < w.nw; i++)
            if (w.wk[i] == LM_EV_CONTACT)
                released = 1;
        if (released && ev_grazes(cx, t, y, t_new, yb, p, &w, md))
            SEGMENT_RETURN(t, LM_ST_GRAZE, nev, steps);
        int hit = 0;
        for (int64_t i = 0; i < w.nw; i++)
            if (g_old[i] > 0.0 && g_new[i] <= 0.0)
                hit = 1;
        int dips = !hit && lim[LM_LM_DIPS] > 0 && w.nw > 0;
        int64_t nc = ev_crossed(cx, t_new, yb, p, crossed);
        int64_t k = io[LM_IO_NEXT];
        if (hit || dips || nc > 0 || (k < S && TS[k] < t_new)) {
            lm_dense_stages(cx, t, y, ynew, h, p, &act, K, F);
            io[LM_IO_EVALUATIONS] += 3;
        }
        lm_dense dn;
        dn.t_old = t;
        dn.h = h;
        dn.y_old = y;
        dn.F = F;
        dn.N = N;
        for (int64_t i = 0; i < w.nw; i++)
            upper[i] = t_new; /* where each event's crossing is sought */
        if (dips) {
            int64_t D = lim[LM_LM_DIPS];
            double *YS = lm_doubles(cx, D * N);
            for (int64_t c = 0; c < D; c++)
                lm_dense_at(dip_time(t, t_new, c, D), &dn, YS + c * N);
            hit = ev_dips(cx, t, t_new, YS, D, p, &w, md, &act, tl, g_old, g_new, upper);
        }
        double te = t_new;
        int64_t ie = -1;
        if (hit) {
            for (int64_t i = 0; i < w.nw; i++) {
                if ((g_old[i] > 0.0 && g_new[i] <= 0.0) || upper[i] < t_new) {
                    double r = ev_brent(cx, i, t, upper[i], &dn, p, &w, md, &act, tl);
                    if (ev_again(w.wk[i], w.wj[i], r, t_new, md))
                        continue; /* the impact just applied: no event */
                    if (r < te || ie < 0) {
                        te = r;
                        ie = i;
                    }
                }
            }
        }
        int64_t sw = -1; /* an input switches first: its new branch from te on */
        if (nc > 0) {
            int64_t ks = -1;
            double ts = ev_switch_time(cx, t, t_new, &dn, p, &w, md, &act, tl, crossed, nc, &ks);
            if (ie < 0 || ts <= te) {
                te = ts;
                sw = ks;
            }
        }
        if (ie >= 0 || sw >= 0) {
            /* the samples up to the event, on the dense output */
            double *ys = lm_doubles(cx, N);
            while (k < S && TS[k] <= te) {
                lm_dense_at(TS[k], &dn, ys);
                ev_sample(cx, TS[k], ys, p, &act, offset, k, smp);
                k++;
            }
            io[LM_IO_NEXT] = k;
            double *ye = lm_doubles(cx, N);
            lm_dense_at(te, &dn, ye);
            lm_project(cx, te, ye, p, &act, offset);
            copy_state(y_out, ye, N);
            int64_t st;
            int settled = 0;
            if (sw >= 0) {
                st = ev_switch(cx, te, ye, p, sw, md, tl, lg, &nev, &settled);
            } else {
                int64_t j = w.wj[ie];
                st = ev_apply(cx, te, ye, p, w.wk[ie], j, &act, md, tl, lim, lg, &nev,
                              &settled);
                if (st == LM_ST_CONTACT)
                    io[LM_IO_CONTACT] = j;
            }
            if (settled)
                copy_state(y_out, ye, N);
            if (st != 0)
                SEGMENT_RETURN(te, st, nev, steps);
            if (ev_all(lg, to_end))
                SEGMENT_RETURN(te, LM_ST_FOUND, nev, steps);
            t = te;
            copy_state(y, ye, N);
            ev_mode(md, &act);
            ev_watch(md, &w);
            lm_rhs(cx, t, y, p, &act, f);
            bound = ev_bound(t_end, md);
            if (bound <= t) { /* accumulated at the event's time: logged before going on */
                nev = ev_accumulated(cx, t, y, p, md, lg, nev);
                if (nev < 0)
                    SEGMENT_RETURN(t, LM_ST_EVENTS, 0, steps);
                if (ev_all(lg, to_end))
                    SEGMENT_RETURN(t, LM_ST_FOUND, nev, steps);
                bound = ev_bound(t_end, md);
            }
            h_abs = lm_first_step(cx, t, y, f, p, &act, bound, tl);
            io[LM_IO_EVALUATIONS] += 2;
            ev_values(cx, t, y, p, &w, md, &act, tl, g_old);
            lm_release(cx, mk);
            continue;
        }
        if (released) { /* a body through a surface (simulate's _check_penetration) */
            double *fb = lm_doubles(cx, m), *Ab = lm_doubles(cx, m * n);
            double *bb = lm_doubles(cx, m);
            lm_constraints(cx, t_new, yb, p, fb, Ab, bb);
            double depth = ev_depth(tl, yb, n);
            for (int64_t i = 0; i < w.nw; i++)
                if (w.wk[i] == LM_EV_CONTACT && fb[w.wj[i]] < -depth)
                    SEGMENT_RETURN(t, LM_ST_PENETRATION, nev, steps);
        }
        /* the samples up to the step's end: on the dense output, at t_new the projected
         * state */
        if (k < S && TS[k] <= t_new) {
            double *ys = lm_doubles(cx, N);
            while (k < S && TS[k] <= t_new) {
                if (TS[k] == t_new) {
                    ev_sample(cx, TS[k], yb, p, &act, offset, k, smp);
                } else {
                    lm_dense_at(TS[k], &dn, ys);
                    ev_sample(cx, TS[k], ys, p, &act, offset, k, smp);
                }
                k++;
            }
        }
        io[LM_IO_NEXT] = k;
        double moved = lm_max_abs_diff(yb, ynew, N);
        if (moved > fo[LM_FO_MOVED])
            fo[LM_FO_MOVED] = moved;
        if (ev_arm(cx, t_new, yb, p, &w, md, tl)) {
            ev_values(cx, t_new, yb, p, &w, md, &act, tl, g_old);
        } else {
            double *tmp = g_old;
            g_old = g_new;
            g_new = tmp;
        }
        t = t_new;
        double *tmp = y; /* y = yb; the old y's array is the next step's yb */
        y = yb;
        yb = tmp;
        copy_state(y_out, y, N);
        lm_rhs(cx, t, y, p, &act, f);
        io[LM_IO_EVALUATIONS] += 1;
        if (!lm_all_finite(f, N))
            SEGMENT_RETURN(t, LM_ST_SINGULAR, nev, steps);
        if (t >= bound) { /* the bounces accumulated: their contacts logged, a fresh start */
            nev = ev_accumulated(cx, t, y, p, md, lg, nev);
            if (nev < 0)
                SEGMENT_RETURN(t, LM_ST_EVENTS, 0, steps);
            if (ev_all(lg, to_end))
                SEGMENT_RETURN(t, LM_ST_FOUND, nev, steps);
            if (t < t_end) {
                bound = ev_bound(t_end, md);
                h_abs = lm_first_step(cx, t, y, f, p, &act, bound, tl);
                io[LM_IO_EVALUATIONS] += 1;
            }
        }
        lm_release(cx, mk);
    }
    fo[LM_FO_H] = h_abs;
    copy_state(y_out, y, N);
    SEGMENT_RETURN(t, LM_ST_END, nev, steps);
}

/* loop.ev_run_one: one run from t = 0 to tl[TL_T_END] in the mode md (every constraint
 * engaged and sticking), the events into lg: the status, with *t_out the time reached,
 * *nev_out the events logged, *steps_out the steps; y_out the state at *t_out.
 * tl[TL_BLOW_UP] is a factor of 1 + max |y0| here. */
int64_t ev_run_one(lm_ctx *cx, const double *y0, double *p, lm_mode *md, const double *tl,
                   const int64_t *lim, lm_log *lg, double *y_out, double *t_out,
                   int64_t *nev_out, int64_t *steps_out)
{
    int64_t N = 2 * cx->sy->n, m = md->m;
    double *y = lm_copy(cx, y0, N);
    double t = 0.0;
    int64_t nev = 0;
    copy_state(y_out, y, N);
    *t_out = t;
    *steps_out = 0;
    int64_t st = ev_start(cx, t, y, p, md, tl, lg, &nev);
    *nev_out = nev;
    if (st != 0)
        return st;
    st = ev_settle(cx, t, y, p, md, tl, lg, &nev);
    *nev_out = nev;
    copy_state(y_out, y, N);
    if (st != 0)
        return st;
    ev_lock(cx, t, y, p); /* each input switch held on its branch at the start */
    if (ev_all(lg, lim[LM_LM_TO_END] == 1))
        return LM_ST_FOUND;
    double *bounds = lm_copy(cx, tl, LM_TL_SIZE);
    bounds[LM_TL_BLOW_UP] = tl[LM_TL_BLOW_UP] * (1.0 + lm_max_abs(y, N));
    lm_samples smp;
    smp.S = 0;
    smp.N = N;
    smp.m = m;
    smp.TS = NULL;
    smp.SY = smp.SL = smp.SR = NULL;
    int64_t io[LM_IO_SIZE] = {0, 0, 0};
    double fo[LM_FO_SIZE] = {0.0, 0.0, 0.0};
    fo[LM_FO_T] = t;
    st = ev_segment(cx, p, md, bounds, lim, lg, nev, &smp, y_out, io, fo, t_out, nev_out,
                    steps_out);
    if (st == LM_ST_BUDGET)
        st = LM_ST_STEP;
    return st;
}

/* loop.ev_run: every row of Y0 (parameters P) through ev_run_one, the mode of run b in
 * IM[b], FM[b], its events in row b of EK, EJ, ET, EY, EX, its results in row b of YOUT,
 * TOUT, STATUS, NEV, STEPS. With lim[LM_STARTS], each row of Y0 is first made consistent
 * in place (hold, value (2, n): the held coordinates and velocities); a start then not
 * finite ends its run with ST_START. */
void ev_run(lm_ctx *cx, int64_t B, double *Y0, double *P, const int64_t *kinds, int64_t *IM,
            double *FM, const uint8_t *hold, const double *value, const double *tl,
            const int64_t *lim, const int64_t *want, int64_t nwant, int64_t cap, int64_t *EK,
            int64_t *EJ, double *ET, double *EY, double *EX, double *YOUT, double *TOUT,
            int64_t *STATUS, int64_t *NEV, int64_t *STEPS)
{
    const lm_system *sy = cx->sy;
    int64_t n = sy->n, N = 2 * n, m = sy->m, npar = sy->np;
    for (int64_t b = 0; b < B; b++) {
        lm_mark mk = lm_mark_now(cx);
        double *y0 = Y0 + b * N;
        if (lim[LM_LM_STARTS] == 1) {
            lm_consistent(cx, y0, y0 + n, P + b * npar, hold, hold + n, value, value + n,
                          kinds, tl[LM_TL_TOL]);
            if (!lm_all_finite(y0, N)) {
                copy_state(YOUT + b * N, y0, N);
                TOUT[b] = 0.0;
                STATUS[b] = LM_ST_START;
                NEV[b] = 0;
                STEPS[b] = 0;
                lm_release(cx, mk);
                continue;
            }
        }
        lm_log lg;
        lg.cap = cap;
        lg.N = N;
        lg.kind = EK + b * cap;
        lg.j = EJ + b * cap;
        lg.t = ET + b * cap;
        lg.y = EY + b * cap * N;
        lg.x = EX + b * cap * 4;
        lg.nwant = nwant;
        lg.want = want;
        lg.found = lm_bools(cx, nwant);
        lm_mode md;
        md.m = m;
        md.kinds = kinds;
        md.imode = IM + b * 4 * m;
        md.fmode = FM + b * 5 * m;
        STATUS[b] = ev_run_one(cx, y0, P + b * npar, &md, tl, lim, &lg, YOUT + b * N, &TOUT[b],
                               &NEV[b], &STEPS[b]);
        lm_release(cx, mk);
    }
}

/* the entry point of loop.ev_segment (engine.h) */
int64_t lm_ev_segment(const lm_system *sy, const lm_tables *tab, double *p, lm_mode *md,
                      const double *tl, const int64_t *lim, lm_log *lg, int64_t nev,
                      lm_samples *smp, double *y, int64_t *io, double *fo, double *t_out,
                      int64_t *nev_out, int64_t *steps_out)
{
    lm_ctx cx;
    lm_ctx_init(&cx, sy, tab);
    if (setjmp(cx.fail)) {
        lm_ctx_free(&cx);
        return LM_ST_MEMORY;
    }
    int64_t st = ev_segment(&cx, p, md, tl, lim, lg, nev, smp, y, io, fo, t_out, nev_out,
                            steps_out);
    lm_ctx_free(&cx);
    return st;
}

/* the entry point of loop.ev_run (engine.h) */
int64_t lm_ev_run(const lm_system *sy, const lm_tables *tab, int64_t B, double *Y0, double *P,
                  const int64_t *kinds, int64_t *IM, double *FM, const uint8_t *hold,
                  const double *value, const double *tl, const int64_t *lim,
                  const int64_t *want, int64_t nwant, int64_t cap, int64_t *EK, int64_t *EJ,
                  double *ET, double *EY, double *EX, double *YOUT, double *TOUT,
                  int64_t *STATUS, int64_t *NEV, int64_t *STEPS)
{
    lm_ctx cx;
    lm_ctx_init(&cx, sy, tab);
    if (setjmp(cx.fail)) {
        lm_ctx_free(&cx);
        return LM_ST_MEMORY;
    }
    ev_run(&cx, B, Y0, P, kinds, IM, FM, hold, value, tl, lim, want, nwant, cap, EK, EJ, ET,
           EY, EX, YOUT, TOUT, STATUS, NEV, STEPS);
    lm_ctx_free(&cx);
    return 0;
}
