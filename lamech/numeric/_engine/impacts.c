/* Impacts: Newton's law with restitution on the active rows, the contact engaging with its
 * friction sticking or slipping through the impact, the Zeno accumulation (the bounces'
 * time to rest, whose contact is logged at that time). Twin of
 * lamech/numeric/_kernels/impacts.py.
 */
#include <math.h>

#include "events.h"

/* impacts.ev_impulses: q'+ into vp (n) and the impulses into imp (m: NaN where none) of
 * the impact's solve: the velocity jump on the active rows, j (its velocity form brought
 * to target - b_j) and the rows extra; the mode's slips and the rows sj2 slipping through
 * the impact on j (signs sc2) take mu times their normal's impulse. NaN where singular. */
void ev_impulses(lm_ctx *cx, const double *M, const double *A, const double *b,
                 const double *v, const double *mu, const lm_act *act, int64_t j,
                 double target, const int64_t *extra, int64_t nextra, const int64_t *sj2,
                 const double *sc2, int64_t ns2, double *vp, double *imp)
{
    int64_t n = cx->sy->n, m = cx->sy->m;
    int64_t na = act->na;
    int64_t k = na + 1 + nextra;
    int64_t nk = n + k;
    lm_mark mk = lm_mark_now(cx);
    int64_t *R = lm_ints(cx, k);
    for (int64_t a = 0; a < na; a++)
        R[a] = act->rows[a];
    R[na] = j;
    for (int64_t a = 0; a < nextra; a++)
        R[na + 1 + a] = extra[a];
    double *G = lm_doubles(cx, k * n);
    for (int64_t a = 0; a < k; a++)
        for (int64_t c = 0; c < n; c++)
            G[a * n + c] = A[R[a] * n + c];
    for (int64_t s = 0; s < act->ns; s++) {
        int64_t js = act->slip_j[s];
        for (int64_t c = 0; c < n; c++)
            G[act->slip_k[s] * n + c] -= mu[js] * act->slip_c[s] * A[js * n + c];
    }
    for (int64_t s = 0; s < ns2; s++)
        for (int64_t c = 0; c < n; c++)
            G[na * n + c] -= mu[sj2[s]] * sc2[s] * A[sj2[s] * n + c];
    double *K = lm_zeros(cx, nk * nk);
    double *x = lm_zeros(cx, nk);
    for (int64_t i = 0; i < n; i++)
        for (int64_t c = 0; c < n; c++) {
            K[i * nk + c] = M[i * n + c];
            x[i] += M[i * n + c] * v[c];
        }
    for (int64_t a = 0; a < k; a++) {
        x[n + a] = -b[R[a]];
        for (int64_t c = 0; c < n; c++) {
            K[c * nk + n + a] = -G[a * n + c];
            K[(n + a) * nk + c] = A[R[a] * n + c];
        }
    }
    x[n + na] = target;
    lm_gauss(K, x, nk);
    for (int64_t i = 0; i < m; i++)
        imp[i] = NAN;
    for (int64_t a = 0; a < k; a++)
        imp[R[a]] = x[n + a];
    for (int64_t s = 0; s < act->ns; s++)
        imp[act->slip_j[s]] = -mu[act->slip_j[s]] * act->slip_c[s] * x[n + act->slip_k[s]];
    for (int64_t s = 0; s < ns2; s++)
        imp[sj2[s]] = -mu[sj2[s]] * sc2[s] * x[n + na];
    for (int64_t i = 0; i < n; i++)
        vp[i] = x[i];
    lm_release(cx, mk);
}

/* the impact's detail: impulse (set by ev_log), velocity before, restitution */
static void detail(lm_log *lg, int64_t nev, double Fm, double e)
{
    lg->x[(nev - 1) * 4 + 2] = Fm;
    lg->x[(nev - 1) * 4 + 3] = e;
}

/* impacts.ev_impact: released unilateral j closes its gap at (t, y): the impulse on the
 * active rows and j gives F_j+ = -e F_j-; it bounces (EV_IMPACT, disarmed) or, when e = 0
 * or the bounce is too small, engages (EV_CONTACT) with its friction sticking or slipping
 * through the impact; a Zeno sequence (0 < e < 1, pressed back) logs the bounce, engages
 * and keeps its accumulation time in fmode[3, j]; every impact's time in fmode[4, j].
 * y's velocities jump in place. 0, or ST_CONTACT with nothing changed (singular), or
 * ST_EVENTS (*nev 0). */
int64_t ev_impact(lm_ctx *cx, double t, double *y, const double *p, int64_t j, lm_mode *md,
                  const double *tl, lm_log *lg, int64_t *nev)
{
    int64_t n = cx->sy->n, m = md->m;
    double arm_pos = tl[LM_TL_ARM_POS], arm_vel = tl[LM_TL_ARM_VEL];
    lm_mark mk = lm_mark_now(cx);
    double *q = lm_copy(cx, y, n);
    double *v = lm_copy(cx, y + n, n);
    double *f = lm_doubles(cx, m);
    double *A = lm_doubles(cx, m * n);
    double *b = lm_doubles(cx, m);
    lm_constraints(cx, t, q, p, f, A, b);
    double *es = lm_doubles(cx, m);
    lm_restitution(cx, t, q, p, es);
    double e = es[j];
    double Fm = b[j];
    for (int64_t c = 0; c < n; c++)
        Fm += A[j * n + c] * v[c];
    lm_act act = lm_act_new(cx, m);
    ev_mode(md, &act);
    double *M = lm_doubles(cx, n * n);
    double *rhs = lm_doubles(cx, n);
    double *Ad = lm_doubles(cx, m * n);
    double *gam = lm_doubles(cx, m);
    double *mu = lm_doubles(cx, m);
    lm_dynamics(cx, t, q, v, p, M, rhs, Ad, gam, mu);
    double *sol = lm_doubles(cx, n + act.na);
    lm_kkt_solve(cx, M, rhs, Ad, gam, mu, &act, sol);
    if (!lm_all_finite(sol, n)) {
        lm_release(cx, mk);
        return LM_ST_CONTACT;
    }
    double a_gap = gam[j];
    for (int64_t c = 0; c < n; c++)
        a_gap += A[j * n + c] * sol[c];
    a_gap = fabs(a_gap);
    double v_small = 2.0 * sqrt(2.0 * a_gap * arm_pos) + 10.0 * arm_vel;
    int engage = e == 0.0 || e * fabs(Fm) <= v_small;
    int64_t *frows = lm_ints(cx, m > 0 ? m : 1);
    int64_t nf = 0;
    if (engage)
        for (int64_t i = 0; i < m; i++)
            if (LM_KIND(md, 2, i) == j)
                frows[nf++] = i;
    double target = (engage ? 0.0 : -e * Fm) - b[j];
    double *vp = lm_doubles(cx, n);
    double *imp = lm_doubles(cx, m);
    ev_impulses(cx, M, A, b, v, mu, &act, j, target, frows, nf, NULL, NULL, 0, vp, imp);
    if (!lm_all_finite(vp, n)) {
        lm_release(cx, mk);
        return LM_ST_CONTACT;
    }
    double *trial = lm_copy(cx, imp, m);
    int64_t *sj2 = lm_ints(cx, nf > 0 ? nf : 1);
    double *sc2 = lm_doubles(cx, nf > 0 ? nf : 1);
    int64_t *stay = lm_ints(cx, nf > 0 ? nf : 1);
    int64_t ns2 = 0, nst = 0;
    for (int64_t a = 0; a < nf; a++) {
        int64_t i = frows[a];
        if (fabs(imp[i]) > mu[i] * imp[j] * (1.0 + 1e-9)) {
            sj2[ns2] = i;
            sc2[ns2] = -copysign(1.0, imp[i]);
            ns2++;
        } else {
            stay[nst++] = i;
        }
    }
    if (ns2 > 0) {
        ev_impulses(cx, M, A, b, v, mu, &act, j, target, stay, nst, sj2, sc2, ns2, vp, imp);
        if (!lm_all_finite(vp, n)) {
            lm_release(cx, mk);
            return LM_ST_CONTACT;
        }
    }
    double rest = -1.0;
    double *vb = vp;
    double ib = 0.0;
    if (engage && 0.0 < e && e < 1.0) { /* the bounces' time to rest */
        double *M2 = lm_doubles(cx, n * n);
        double *rhs2 = lm_doubles(cx, n);
        double *A2 = lm_doubles(cx, m * n);
        double *gam2 = lm_doubles(cx, m);
        double *mu2 = lm_doubles(cx, m);
        lm_dynamics(cx, t, q, vp, p, M2, rhs2, A2, gam2, mu2);
        double *sol2 = lm_doubles(cx, n + act.na);
        lm_kkt_solve(cx, M2, rhs2, A2, gam2, mu2, &act, sol2);
        double a_n = gam2[j];
        for (int64_t c = 0; c < n; c++)
            a_n += A[j * n + c] * sol2[c];
        if (a_n < 0.0) {
            rest = 2.0 * e * fabs(Fm) / (-a_n * (1.0 - e));
            vb = lm_doubles(cx, n);
            double *imb = lm_doubles(cx, m);
            ev_impulses(cx, M, A, b, v, mu, &act, j, -e * Fm - b[j], NULL, 0, NULL, NULL, 0,
                        vb, imb);
            if (!lm_all_finite(vb, n)) {
                lm_release(cx, mk);
                return LM_ST_CONTACT;
            }
            ib = imb[j];
        }
    }
    LM_FMODE(md, 4, j) = t; /* its last impact (ev_again, ev_accumulated) */
    double *yb = lm_copy(cx, y, 2 * n);
    for (int64_t c = 0; c < n; c++) {
        yb[n + c] = vb[c];
        y[n + c] = vp[c];
    }
    if (!engage) {
        LM_IMODE(md, 2, j) = 0;
        *nev = ev_log(lg, LM_EV_IMPACT, j, t, y, LM_DT_IMPACT, imp[j], *nev);
        if (*nev < 0) {
            *nev = 0;
            lm_release(cx, mk);
            return LM_ST_EVENTS;
        }
        detail(lg, *nev, Fm, e);
        lm_release(cx, mk);
        return 0;
    }
    if (rest >= 0.0) {
        *nev = ev_log(lg, LM_EV_IMPACT, j, t, yb, LM_DT_IMPACT, ib, *nev);
        if (*nev < 0) {
            *nev = 0;
            lm_release(cx, mk);
            return LM_ST_EVENTS;
        }
        detail(lg, *nev, Fm, e);
    }
    /* j engages, its friction sticks (f held where it is), or slips on */
    LM_IMODE(md, 0, j) = 1;
    lm_act act2 = lm_act_new(cx, m);
    ev_mode(md, &act2);
    for (int64_t a = 0; a < nf; a++) {
        int64_t i = frows[a];
        LM_FMODE(md, 2, i) = LM_KIND(md, 1, i) == 1 ? f[i] : 0.0;
        LM_IMODE(md, 1, i) = LM_FR_STICK;
    }
    for (int64_t s = 0; s < ns2; s++) {
        int64_t i = sj2[s];
        double sv = b[i];
        for (int64_t c = 0; c < n; c++)
            sv += A[i * n + c] * vp[c];
        if (fabs(sv) <= arm_vel)
            LM_FMODE(md, 0, i) = -copysign(1.0, trial[i]);
        else
            LM_FMODE(md, 0, i) = copysign(1.0, sv);
        LM_IMODE(md, 1, i) = LM_FR_SLIP;
        LM_IMODE(md, 3, i) = 0;
    }
    ev_mode(md, &act2);
    if (rest < 0.0) {
        *nev = ev_log(lg, LM_EV_CONTACT, j, t, y, LM_DT_IMPACT, imp[j], *nev);
        if (*nev < 0) {
            *nev = 0;
            lm_release(cx, mk);
            return LM_ST_EVENTS;
        }
        detail(lg, *nev, Fm, e);
    } else {
        LM_FMODE(md, 3, j) = t + rest;
    }
    for (int64_t s = 0; s < ns2; s++) {
        int64_t i = sj2[s];
        *nev = ev_log(lg, LM_EV_SLIP, i, t, y, LM_DT_IMPULSE, imp[i], *nev);
        if (*nev < 0) {
            *nev = 0;
            lm_release(cx, mk);
            return LM_ST_EVENTS;
        }
    }
    lm_release(cx, mk);
    return 0;
}

/* impacts.ev_bound: the end of the next stretch: t_end, or an earlier accumulation time */
double ev_bound(double t_end, const lm_mode *md)
{
    double bound = t_end;
    for (int64_t j = 0; j < md->m; j++)
        if (LM_FMODE(md, 3, j) < bound) /* NaN: none */
            bound = LM_FMODE(md, 3, j);
    return bound;
}

/* impacts.ev_accumulated: log EV_CONTACT for each constraint whose bounces have
 * accumulated by t, in the order of their accumulation times; the new count, or -1 */
int64_t ev_accumulated(lm_ctx *cx, double t, const double *y, const double *p, lm_mode *md,
                       lm_log *lg, int64_t nev)
{
    int64_t m = md->m;
    for (;;) {
        int64_t jn = -1;
        for (int64_t j = 0; j < m; j++)
            if (LM_FMODE(md, 3, j) <= t && (jn < 0 || LM_FMODE(md, 3, j) < LM_FMODE(md, 3, jn)))
                jn = j;
        if (jn < 0)
            return nev;
        LM_FMODE(md, 3, jn) = NAN;
        lm_mark mk = lm_mark_now(cx);
        double *es = lm_doubles(cx, m);
        lm_restitution(cx, t, y, p, es);
        double e = es[jn];
        lm_release(cx, mk);
        nev = ev_log(lg, LM_EV_CONTACT, jn, t, y, LM_DT_ACCUMULATION, e, nev);
        if (nev < 0)
            return -1;
        lg->x[(nev - 1) * 4 + 2] = t - LM_FMODE(md, 4, jn);
    }
}
