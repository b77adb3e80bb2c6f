/* The contact and friction mode: the active rows, the watched events and their functions,
 * an event's location on the dense output (Brent), the event record, the settling of a
 * mode. Twin of lamech/numeric/_kernels/modes.py (engine.h: conventions; events.h: this
 * layer's functions).
 */
#include <math.h>

#include "events.h"

/* modes.ev_active: constraint j's row is in the KKT system: an engaged unilateral or a
 * bilateral one; a friction constraint while it sticks and its normal's row is in */
int ev_active(int64_t j, const lm_mode *md)
{
    for (int64_t it = 0; it < md->m + 1; it++) {
        int64_t k = LM_KIND(md, 2, j);
        if (k < 0) {
            if (LM_KIND(md, 0, j) == 1)
                return LM_IMODE(md, 0, j) == 1;
            return 1;
        }
        if (LM_IMODE(md, 1, j) != LM_FR_STICK)
            return 0;
        j = k;
    }
    return 0;
}

/* modes.ev_mode: the mode's active set into act (capacity m); friction on a released
 * normal goes off, and sticks again when it engages (imode changed in place) */
void ev_mode(const lm_mode *md, lm_act *act)
{
    int64_t m = md->m;
    int64_t na = 0;
    for (int64_t j = 0; j < m; j++) {
        int64_t k = LM_KIND(md, 2, j);
        if (k >= 0) {
            if (!ev_active(k, md))
                LM_IMODE(md, 1, j) = LM_FR_OFF;
            else if (LM_IMODE(md, 1, j) == LM_FR_OFF)
                LM_IMODE(md, 1, j) = LM_FR_STICK;
            if (LM_IMODE(md, 1, j) == LM_FR_STICK)
                act->rows[na++] = j;
        } else if (ev_active(j, md)) {
            act->rows[na++] = j;
        }
    }
    act->na = na;
    int64_t nh = 0;
    for (int64_t a = 0; a < na; a++)
        if (LM_KIND(md, 1, act->rows[a]) == 1)
            act->hrows[nh++] = act->rows[a];
    act->nh = nh;
    int64_t ns = 0;
    for (int64_t j = 0; j < m; j++) {
        if (LM_KIND(md, 2, j) >= 0 && LM_IMODE(md, 1, j) == LM_FR_SLIP) {
            int64_t kn = LM_KIND(md, 2, j);
            int64_t pos = -1; /* the normal's position among the rows */
            for (int64_t a = 0; a < na; a++)
                if (act->rows[a] == kn) {
                    pos = a;
                    break;
                }
            act->slip_j[ns] = j;
            act->slip_k[ns] = pos;
            act->slip_c[ns] = LM_FMODE(md, 1, j) * LM_FMODE(md, 0, j);
            ns++;
        }
    }
    act->ns = ns;
}

/* modes.ev_watch: the events the mode watches into w (capacity 2m): lift-off of an
 * engaged unilateral, contact of a released one, slip of sticking friction, stick of
 * slipping friction */
void ev_watch(const lm_mode *md, lm_watch *w)
{
    int64_t nw = 0;
    for (int64_t j = 0; j < md->m; j++) {
        if (LM_KIND(md, 0, j) == 1) {
            w->wk[nw] = LM_IMODE(md, 0, j) == 1 ? LM_EV_LIFT_OFF : LM_EV_CONTACT;
            w->wj[nw] = j;
            nw++;
        }
        if (LM_KIND(md, 2, j) >= 0) {
            if (LM_IMODE(md, 1, j) == LM_FR_STICK) {
                w->wk[nw] = LM_EV_SLIP;
                w->wj[nw] = j;
                nw++;
            } else if (LM_IMODE(md, 1, j) == LM_FR_SLIP) {
                w->wk[nw] = LM_EV_STICK;
                w->wj[nw] = j;
                nw++;
            }
        }
    }
    w->nw = nw;
}

/* modes.ev_lam: q'' (n), lambda (m: NaN where inactive, the kinetic friction where
 * slipping) and mu (m) on the active set act */
void ev_lam(lm_ctx *cx, double t, const double *y, const double *p, const lm_act *act,
            double *qdd, double *lam, double *mu)
{
    const lm_system *sy = cx->sy;
    int64_t n = sy->n, m = sy->m;
    lm_mark mk = lm_mark_now(cx);
    double *M = lm_doubles(cx, n * n);
    double *rhs = lm_doubles(cx, n);
    double *A = lm_doubles(cx, m * n);
    double *gam = lm_doubles(cx, m);
    lm_dynamics(cx, t, y, y + n, p, M, rhs, A, gam, mu);
    double *sol = lm_doubles(cx, n + act->na);
    lm_kkt_solve(cx, M, rhs, A, gam, mu, act, sol);
    for (int64_t j = 0; j < m; j++)
        lam[j] = NAN;
    for (int64_t a = 0; a < act->na; a++)
        lam[act->rows[a]] = sol[n + a];
    for (int64_t s = 0; s < act->ns; s++)
        lam[act->slip_j[s]] = -mu[act->slip_j[s]] * act->slip_c[s] * sol[n + act->slip_k[s]];
    for (int64_t i = 0; i < n; i++)
        qdd[i] = sol[i];
    lm_release(cx, mk);
}

/* modes.ev_values: the watched events' functions at (t, y) into out (w->nw) */
void ev_values(lm_ctx *cx, double t, const double *y, const double *p, const lm_watch *w,
               const lm_mode *md, const lm_act *act, const double *tl, double *out)
{
    const lm_system *sy = cx->sy;
    int64_t n = sy->n, m = md->m;
    if (w->nw == 0)
        return;
    lm_mark mk = lm_mark_now(cx);
    double *qdd = lm_doubles(cx, n);
    double *lam = lm_doubles(cx, m);
    double *mu = lm_doubles(cx, m);
    ev_lam(cx, t, y, p, act, qdd, lam, mu);
    double *f = lm_doubles(cx, m);
    double *A = lm_doubles(cx, m * n);
    double *b = lm_doubles(cx, m);
    lm_constraints(cx, t, y, p, f, A, b);
    ev_functions(w, md, tl, y, n, lam, mu, f, A, b, out);
    lm_release(cx, mk);
}

/* modes.ev_functions: lambda_j of an engaged unilateral (lift-off), f_j of a released one
 * (contact), mu sN N - |lambda_j| of sticking friction (slip), sigma s_j of slipping
 * friction (stick); a disarmed contact or stick shifted up by its threshold. Positive
 * while nothing happens. */
void ev_functions(const lm_watch *w, const lm_mode *md, const double *tl, const double *y,
                  int64_t n, const double *lam, const double *mu, const double *f,
                  const double *A, const double *b, double *out)
{
    double arm_pos = tl[LM_TL_ARM_POS], arm_vel = tl[LM_TL_ARM_VEL];
    for (int64_t i = 0; i < w->nw; i++) {
        int64_t kind = w->wk[i];
        int64_t j = w->wj[i];
        if (kind == LM_EV_LIFT_OFF) {
            out[i] = lam[j];
        } else if (kind == LM_EV_CONTACT) {
            out[i] = f[j] + (LM_IMODE(md, 2, j) == 1 ? 0.0 : arm_pos);
        } else if (kind == LM_EV_SLIP) {
            out[i] = mu[j] * LM_FMODE(md, 1, j) * lam[LM_KIND(md, 2, j)] - fabs(lam[j]);
        } else {
            double s = b[j];
            for (int64_t c = 0; c < n; c++)
                s += A[j * n + c] * y[n + c];
            out[i] = LM_FMODE(md, 0, j) * s + (LM_IMODE(md, 3, j) == 1 ? 0.0 : arm_vel);
        }
    }
}

/* modes.ev_depth: how far below zero a released gap may be before it is a penetration */
double ev_depth(const double *tl, const double *q, int64_t n)
{
    return lm_pymax(tl[LM_TL_PEN] * (1.0 + lm_max_abs(q, n)), 10.0 * tl[LM_TL_ARM_POS]);
}

/* modes.ev_lock: hold every input switch on the branch it is on at (t, y) (its slot in p
 * 1 where s >= 0, else 0; s evaluated with every switch free, NaN) */
void ev_lock(lm_ctx *cx, double t, const double *y, double *p)
{
    const lm_system *sy = cx->sy;
    if (sy->nslots == 0)
        return;
    int64_t n = sy->n;
    for (int64_t k = 0; k < sy->nslots; k++)
        p[sy->slots[k]] = NAN;
    lm_mark mk = lm_mark_now(cx);
    double *s = lm_doubles(cx, sy->nslots);
    lm_switches(cx, t, y, y + n, p, s);
    for (int64_t k = 0; k < sy->nslots; k++)
        p[sy->slots[k]] = s[k] >= 0.0 ? 1.0 : 0.0;
    lm_release(cx, mk);
}

/* modes.ev_crossed: the input switches whose s at (t, y) is across their held branch,
 * into out (nslots); their count */
int64_t ev_crossed(lm_ctx *cx, double t, const double *y, const double *p, int64_t *out)
{
    const lm_system *sy = cx->sy;
    if (sy->nslots == 0)
        return 0;
    lm_mark mk = lm_mark_now(cx);
    double *s = lm_doubles(cx, sy->nslots);
    lm_switches(cx, t, y, y + sy->n, p, s);
    int64_t nc = 0;
    for (int64_t k = 0; k < sy->nslots; k++)
        if ((s[k] >= 0.0) != (p[sy->slots[k]] == 1.0))
            out[nc++] = k;
    lm_release(cx, mk);
    return nc;
}

/* modes.ev_g: at x on the dense output dn, watched event i's function, or for i < 0
 * input switch -1 - i's s */
double ev_g(lm_ctx *cx, int64_t i, double x, const lm_dense *dn, const double *p,
            const lm_watch *w, const lm_mode *md, const lm_act *act, const double *tl)
{
    const lm_system *sy = cx->sy;
    lm_mark mk = lm_mark_now(cx);
    double *y = lm_doubles(cx, dn->N);
    lm_dense_at(x, dn, y);
    double out;
    if (i >= 0) {
        double *g = lm_doubles(cx, w->nw);
        ev_values(cx, x, y, p, w, md, act, tl, g);
        out = g[i];
    } else {
        double *s = lm_doubles(cx, sy->nslots);
        lm_switches(cx, x, y, y + dn->N / 2, p, s);
        out = s[-1 - i];
    }
    lm_release(cx, mk);
    return out;
}

/* modes.ev_switch_time: (the time, *ks) of the first of the input switches crossed in the
 * step from t to t_new, on its dense output (t where s is across its branch there) */
double ev_switch_time(lm_ctx *cx, double t, double t_new, const lm_dense *dn, const double *p,
                      const lm_watch *w, const lm_mode *md, const lm_act *act,
                      const double *tl, const int64_t *crossed, int64_t nc, int64_t *ks)
{
    const lm_system *sy = cx->sy;
    double ts = t_new;
    *ks = -1;
    lm_mark mk = lm_mark_now(cx);
    double *y = lm_doubles(cx, dn->N);
    lm_dense_at(t, dn, y);
    double *s_a = lm_doubles(cx, sy->nslots);
    lm_switches(cx, t, y, y + dn->N / 2, p, s_a);
    for (int64_t c = 0; c < nc; c++) {
        int64_t k = crossed[c];
        double r;
        if ((s_a[k] >= 0.0) != (p[sy->slots[k]] == 1.0))
            r = t;
        else
            r = ev_brent(cx, -1 - k, t, t_new, dn, p, w, md, act, tl);
        if (r < ts || *ks < 0) {
            ts = r;
            *ks = k;
        }
    }
    lm_release(cx, mk);
    return ts;
}

/* modes.ev_brent: where event i's function crosses zero on the dense output in [xa, xb]:
 * Brent's method as scipy.optimize.brentq (xtol 1e-15 max(1, |xb|), rtol 4 eps, 200
 * iterations); xb where the ends have one sign */
double ev_brent(lm_ctx *cx, int64_t i, double xa, double xb, const lm_dense *dn,
                const double *p, const lm_watch *w, const lm_mode *md, const lm_act *act,
                const double *tl)
{
    double xtol = 1e-15 * lm_pymax(1.0, fabs(xb));
    double rtol = 4.0 * 2.220446049250313e-16;
    double xpre = xa, xcur = xb;
    double fpre = ev_g(cx, i, xpre, dn, p, w, md, act, tl);
    double fcur = ev_g(cx, i, xcur, dn, p, w, md, act, tl);
    if (fpre == 0.0)
        return xpre;
    if (fcur == 0.0)
        return xcur;
    if ((fpre < 0.0) == (fcur < 0.0))
        return xb;
    double xblk = 0.0, fblk = 0.0, spre = 0.0, scur = 0.0;
    for (int it = 0; it < 200; it++) {
        if (fpre != 0.0 && fcur != 0.0 && (fpre < 0.0) != (fcur < 0.0)) {
            xblk = xpre;
            fblk = fpre;
            spre = xcur - xpre;
            scur = spre;
        }
        if (fabs(fblk) < fabs(fcur)) {
            xpre = xcur;
            xcur = xblk;
            xblk = xpre;
            fpre = fcur;
            fcur = fblk;
            fblk = fpre;
        }
        double delta = (xtol + rtol * fabs(xcur)) / 2.0;
        double sbis = (xblk - xcur) / 2.0;
        if (fcur == 0.0 || fabs(sbis) < delta)
            return xcur;
        if (fabs(spre) > delta && fabs(fcur) < fabs(fpre)) {
            double stry;
            if (xpre == xblk) {
                stry = -fcur * (xcur - xpre) / (fcur - fpre);
            } else {
                double dpre = (fpre - fcur) / (xpre - xcur);
                double dblk = (fblk - fcur) / (xblk - xcur);
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre));
            }
            if (2.0 * fabs(stry) < lm_pymin(fabs(spre), 3.0 * fabs(sbis) - delta)) {
                spre = scur;
                scur = stry;
            } else {
                spre = sbis;
                scur = sbis;
            }
        } else {
            spre = sbis;
            scur = sbis;
        }
        xpre = xcur;
        fpre = fcur;
        if (fabs(scur) > delta)
            xcur += scur;
        else
            xcur += sbis > 0.0 ? delta : -delta;
        fcur = ev_g(cx, i, xcur, dn, p, w, md, act, tl);
    }
    return xcur;
}

/* modes.ev_again: whether the root r (in a step ending at xb) of the watched event (kind,
 * j) is contact j's last impact found again (to the location's tolerance): no event */
int ev_again(int64_t kind, int64_t j, double r, double xb, const lm_mode *md)
{
    if (kind != LM_EV_CONTACT)
        return 0;
    return r - LM_FMODE(md, 4, j) <=
           1e-15 * lm_pymax(1.0, fabs(xb)) + 4.0 * 2.220446049250313e-16 * fabs(r);
}

/* modes.ev_log: record event (kind, j) at (t, y) with its detail (code, value), mark the
 * wanted events it is; the new count, or -1 when the record is full */
int64_t ev_log(lm_log *lg, int64_t kind, int64_t j, double t, const double *y, int64_t code,
               double value, int64_t nev)
{
    if (nev >= lg->cap)
        return -1;
    lg->kind[nev] = kind;
    lg->j[nev] = j;
    lg->t[nev] = t;
    for (int64_t c = 0; c < lg->N; c++)
        lg->y[nev * lg->N + c] = y[c];
    double *x = lg->x + nev * 4;
    x[0] = (double)code;
    x[1] = value;
    x[2] = 0.0;
    x[3] = 0.0;
    for (int64_t w = 0; w < lg->nwant; w++) {
        int64_t wk = lg->want[w], wj = lg->want[lg->nwant + w];
        if (wk == kind && (wj < 0 || wj == j))
            lg->found[w] = 1;
    }
    return nev + 1;
}

/* modes.ev_start: the mode the start (t, y) is in, set in md (every constraint engaged and
 * sticking before): a unilateral open or opening starts released (armed beyond
 * tl[TL_ARM_POS]), friction with a slip velocity slips (logged, DT_INITIAL). 0, or
 * ST_START where an active constraint is not met (beyond tl[TL_TOL] (1 + max |q|)), or
 * ST_EVENTS (*nev 0) */
int64_t ev_start(lm_ctx *cx, double t, double *y, const double *p, lm_mode *md,
                 const double *tl, lm_log *lg, int64_t *nev)
{
    int64_t n = cx->sy->n, m = md->m;
    lm_mark mk = lm_mark_now(cx);
    double *f0 = lm_doubles(cx, m);
    double *A0 = lm_doubles(cx, m * n);
    double *b0 = lm_doubles(cx, m);
    lm_constraints(cx, t, y, p, f0, A0, b0);
    double tol_q = tl[LM_TL_TOL] * (1.0 + lm_max_abs(y, n));
    double *F0 = lm_doubles(cx, m);
    for (int64_t j = 0; j < m; j++) {
        F0[j] = b0[j];
        for (int64_t c = 0; c < n; c++)
            F0[j] += A0[j * n + c] * y[n + c];
    }
    for (int64_t j = 0; j < m; j++) {
        if (LM_KIND(md, 0, j) == 1 &&
            (f0[j] > tol_q || (fabs(f0[j]) <= tol_q && F0[j] > tol_q))) {
            LM_IMODE(md, 0, j) = 0;
            LM_IMODE(md, 2, j) = f0[j] > tl[LM_TL_ARM_POS] ? 1 : 0;
        }
    }
    lm_act act = lm_act_new(cx, m);
    lm_act act2 = lm_act_new(cx, m);
    ev_mode(md, &act);
    for (int64_t a = 0; a < act.na; a++) {
        int64_t j = act.rows[a];
        if (LM_KIND(md, 2, j) >= 0 && fabs(F0[j]) > tol_q) {
            LM_IMODE(md, 1, j) = LM_FR_SLIP;
            LM_FMODE(md, 0, j) = copysign(1.0, F0[j]);
            LM_IMODE(md, 3, j) = 0;
            ev_mode(md, &act2);
            *nev = ev_log(lg, LM_EV_SLIP, j, t, y, LM_DT_INITIAL, 0.0, *nev);
            if (*nev < 0) {
                *nev = 0;
                lm_release(cx, mk);
                return LM_ST_EVENTS;
            }
        }
    }
    ev_mode(md, &act2);
    for (int64_t a = 0; a < act2.na; a++) {
        int64_t j = act2.rows[a];
        if ((LM_KIND(md, 1, j) == 1 && fabs(f0[j]) > tol_q) || fabs(F0[j]) > tol_q) {
            lm_release(cx, mk);
            return LM_ST_START;
        }
    }
    lm_release(cx, mk);
    return 0;
}

/* modes.ev_settle: make the mode consistent at (t, y), in place: release the unilateral
 * constraint pulling hardest, else let the friction furthest beyond mu N slip, each
 * logged; 0, or ST_EVENTS (*nev 0) / ST_SETTLE / ST_SINGULAR */
int64_t ev_settle(lm_ctx *cx, double t, double *y, const double *p, lm_mode *md,
                  const double *tl, lm_log *lg, int64_t *nev)
{
    int64_t n = cx->sy->n, m = md->m;
    double arm_vel = tl[LM_TL_ARM_VEL];
    for (int64_t it = 0; it < 4 * m + 4; it++) {
        lm_mark mk = lm_mark_now(cx);
        lm_act act = lm_act_new(cx, m);
        ev_mode(md, &act);
        lm_project(cx, t, y, p, &act, md->fmode + 2 * m);
        double *qdd = lm_doubles(cx, n);
        double *lam = lm_doubles(cx, m);
        double *mu = lm_doubles(cx, m);
        ev_lam(cx, t, y, p, &act, qdd, lam, mu);
        if (!lm_all_finite(qdd, n)) {
            lm_release(cx, mk);
            return LM_ST_SINGULAR;
        }
        double scale = 0.0;
        for (int64_t j = 0; j < m; j++)
            if (isfinite(lam[j]))
                scale = lm_pymax(scale, fabs(lam[j]));
        scale += 1.0;
        for (int64_t a = 0; a < act.na; a++) {
            int64_t j = act.rows[a];
            int64_t k = LM_KIND(md, 2, j);
            if (k >= 0 && LM_KIND(md, 0, k) == 0 && lam[k] != 0.0)
                LM_FMODE(md, 1, j) = copysign(1.0, lam[k]);
        }
        double worst = 0.0;
        int64_t jw = -1;
        for (int64_t a = 0; a < act.na; a++) {
            int64_t j = act.rows[a];
            if (LM_KIND(md, 0, j) == 1 && lam[j] < -1e-12 * scale && lam[j] < worst) {
                worst = lam[j];
                jw = j;
            }
        }
        if (jw >= 0) {
            LM_IMODE(md, 0, jw) = 0;
            LM_IMODE(md, 2, jw) = 0;
            LM_FMODE(md, 3, jw) = NAN; /* a pending accumulation is dropped */
            *nev = ev_log(lg, LM_EV_LIFT_OFF, jw, t, y, LM_DT_MULTIPLIER, worst, *nev);
            lm_release(cx, mk);
            if (*nev < 0) {
                *nev = 0;
                return LM_ST_EVENTS;
            }
            continue;
        }
        worst = 0.0;
        jw = -1;
        for (int64_t a = 0; a < act.na; a++) {
            int64_t j = act.rows[a];
            int64_t k = LM_KIND(md, 2, j);
            if (k >= 0) {
                double excess = fabs(lam[j]) - mu[j] * LM_FMODE(md, 1, j) * lam[k];
                if (excess > 1e-12 * scale && excess > worst) {
                    worst = excess;
                    jw = j;
                }
            }
        }
        if (jw >= 0) {
            double ratio =
                fabs(lam[jw]) / lm_pymax(fabs(mu[jw] * lam[LM_KIND(md, 2, jw)]), 1e-300);
            double *f = lm_doubles(cx, m);
            double *A = lm_doubles(cx, m * n);
            double *b = lm_doubles(cx, m);
            lm_constraints(cx, t, y, p, f, A, b);
            double s = b[jw];
            for (int64_t c = 0; c < n; c++)
                s += A[jw * n + c] * y[n + c];
            if (fabs(s) <= arm_vel)
                LM_FMODE(md, 0, jw) = -copysign(1.0, lam[jw]);
            else
                LM_FMODE(md, 0, jw) = copysign(1.0, s);
            LM_IMODE(md, 1, jw) = LM_FR_SLIP;
            LM_IMODE(md, 3, jw) = 0;
            *nev = ev_log(lg, LM_EV_SLIP, jw, t, y, LM_DT_RATIO, ratio, *nev);
            lm_release(cx, mk);
            if (*nev < 0) {
                *nev = 0;
                return LM_ST_EVENTS;
            }
            continue;
        }
        lm_release(cx, mk);
        return 0;
    }
    return LM_ST_SETTLE;
}

/* modes.ev_all: every wanted event found (and no need to go on to t_end) */
int ev_all(const lm_log *lg, int to_end)
{
    if (to_end || lg->nwant == 0)
        return 0;
    for (int64_t w = 0; w < lg->nwant; w++)
        if (!lg->found[w])
            return 0;
    return 1;
}
