/* DOP853, the one stepper of both loops: the C twins of _kernels/dop853.py (SciPy's
 * tableau, error norm and step-size control, its initial step, and the 7th-order dense
 * output with its 3 extra stages). K holds the stages, LM_EXTENDED rows of N = 2n; a trial
 * allocates only from the arena, released when it ends. */
#include <math.h>
#include <string.h>

#include "engine.h"

/* dop853.combine: out = sum over k < count of coef[k] K[k], in order of k (skip: the
 * terms with coef[k] = 0 left out) */
static void combine(double *out, const double *coef, const double *K, int64_t count, int skip,
                    int64_t N)
{
    for (int64_t i = 0; i < N; i++) {
        double acc = 0.0;
        for (int64_t k = 0; k < count; k++)
            if (!skip || coef[k] != 0.0)
                acc += coef[k] * K[k * N + i];
        out[i] = acc;
    }
}

/* dop853.advance: out = y + h d */
static void advance(double *out, const double *y, double h, const double *d, int64_t N)
{
    for (int64_t i = 0; i < N; i++)
        out[i] = y[i] + h * d[i];
}

/* dop853.error_norm: SciPy's DOP853 error norm of a step of size h from y to ynew (< 1:
 * accept); max as Python's (the first unless the second is greater) */
static double error_norm(const double *y, const double *ynew, const double *err5,
                         const double *err3, double h, double rtol, double atol, int64_t N)
{
    double e5 = 0.0, e3 = 0.0;
    for (int64_t i = 0; i < N; i++) {
        double a = fabs(y[i]), b = fabs(ynew[i]);
        double scale = atol + (b > a ? b : a) * rtol;
        double u5 = err5[i] / scale, u3 = err3[i] / scale;
        e5 += u5 * u5;
        e3 += u3 * u3;
    }
    if (e5 == 0.0 && e3 == 0.0)
        return 0.0;
    return fabs(h) * e5 / sqrt((e5 + 0.01 * e3) * (double)N);
}

/* dop853.dop853_trial: one step of size h from (t, y), y' = f there, on the active set:
 * the stages into K, the solution into ynew; returns the error norm (< 1: accept) */
double lm_dop853_trial(lm_ctx *cx, double t, const double *y, const double *f, double h,
                       const double *p, const lm_act *act, const double *tl, double *K,
                       double *ynew)
{
    const lm_tables *tab = cx->tab;
    int64_t N = 2 * cx->sy->n;
    if (K != f)
        memmove(K, f, (size_t)N * sizeof(double));
    lm_mark mark = lm_mark_now(cx);
    double *dy = lm_doubles(cx, N), *ys = lm_doubles(cx, N), *err3 = lm_doubles(cx, N);
    for (int64_t s = 1; s < LM_STAGES; s++) {
        combine(dy, tab->A + s * LM_STAGES, K, s, 1, N);
        advance(ys, y, h, dy, N);
        lm_rhs(cx, t + tab->C[s] * h, ys, p, act, K + s * N);
    }
    combine(dy, tab->B, K, LM_STAGES, 0, N);
    advance(ynew, y, h, dy, N);
    lm_rhs(cx, t + h, ynew, p, act, K + LM_STAGES * N);
    combine(dy, tab->E5, K, LM_STAGES + 1, 0, N);
    combine(err3, tab->E3, K, LM_STAGES + 1, 0, N);
    double err = error_norm(y, ynew, dy, err3, h, tl[LM_TL_RTOL], tl[LM_TL_ATOL], N);
    lm_release(cx, mark);
    return err;
}

/* dop853.dop853_step: one accepted step from (t, y), trying h_abs first, ending at bound
 * at the latest (SciPy's control: max_step; a rejected step shrinks by 0.9 err^(-1/8), to
 * no less than 0.2 of it, also where err is NaN; an accepted one grows by at most 10, not
 * at all right after a rejection). Returns t_new; *trials <= 0 (minus the trials made)
 * where the step fell below 10 units in the last place of t (a collapse: no step). */
double lm_dop853_step(lm_ctx *cx, double t, const double *y, const double *f, double h_abs,
                      double bound, const double *p, const lm_act *act, const double *tl,
                      double *K, double *ynew, double *h, double *h_next, int64_t *trials)
{
    double min_step = 10.0 * fabs(nextafter(t, INFINITY) - t);
    if (h_abs > tl[LM_TL_MAX_STEP])
        h_abs = tl[LM_TL_MAX_STEP];
    else if (h_abs < min_step)
        h_abs = min_step;
    int rejected = 0;
    int64_t count = 0;
    for (;;) {
        if (h_abs < min_step) {
            *h = 0.0;
            *h_next = h_abs;
            *trials = -count;
            return t;
        }
        double t_new = t + h_abs;
        if (t_new > bound)
            t_new = bound;
        double step = t_new - t;
        h_abs = fabs(step);
        double err = lm_dop853_trial(cx, t, y, f, step, p, act, tl, K, ynew);
        count++;
        if (err < 1.0) {
            double factor = 10.0;
            if (err != 0.0) { /* min(10, 0.9 err^(-1/8)) */
                double grow = 0.9 * pow(err, -1.0 / 8.0);
                if (grow < factor)
                    factor = grow;
            }
            if (rejected && !(factor < 1.0)) /* min(1, factor) */
                factor = 1.0;
            *h = step;
            *h_next = h_abs * factor;
            *trials = count;
            return t_new;
        }
        double shrink = 0.9 * pow(err, -1.0 / 8.0);
        if (!(shrink > 0.2)) /* also NaN, as max(0.2, nan) in scipy */
            shrink = 0.2;
        h_abs *= shrink;
        rejected = 1;
    }
}

/* dop853.ev_first_step: SciPy's select_initial_step for DOP853 (error estimator order 7),
 * on the active set, towards t_end; min and max as Python's */
double lm_first_step(lm_ctx *cx, double t, const double *y, const double *f, const double *p,
                     const lm_act *act, double t_end, const double *tl)
{
    int64_t N = 2 * cx->sy->n;
    double rtol = tl[LM_TL_RTOL], atol = tl[LM_TL_ATOL];
    double interval = fabs(t_end - t);
    if (interval == 0.0)
        return 0.0;
    lm_mark mark = lm_mark_now(cx);
    double *scale = lm_doubles(cx, N), *y1 = lm_doubles(cx, N), *f1 = lm_doubles(cx, N);
    for (int64_t i = 0; i < N; i++)
        scale[i] = atol + fabs(y[i]) * rtol;
    double d0 = lm_rms_scaled(y, scale, N);
    double d1 = lm_rms_scaled(f, scale, N);
    double h0 = (d0 < 1e-5 || d1 < 1e-5) ? 1e-6 : 0.01 * d0 / d1;
    if (interval < h0)
        h0 = interval;
    for (int64_t i = 0; i < N; i++)
        y1[i] = y[i] + h0 * f[i];
    lm_rhs(cx, t + h0, y1, p, act, f1);
    double d2 = lm_rms_diff_scaled(f1, f, scale, N) / h0;
    double h1;
    if (d1 <= 1e-15 && d2 <= 1e-15) {
        h1 = 1e-6;
        if (h0 * 1e-3 > h1)
            h1 = h0 * 1e-3;
    } else {
        double d = d2 > d1 ? d2 : d1;
        h1 = pow(0.01 / d, 1.0 / 8.0);
    }
    lm_release(cx, mark);
    double out = 100.0 * h0; /* min(100 h0, h1, interval, max_step) */
    if (h1 < out)
        out = h1;
    if (interval < out)
        out = interval;
    if (tl[LM_TL_MAX_STEP] < out)
        out = tl[LM_TL_MAX_STEP];
    return out;
}

/* dop853.dense_into: the dense output at s (SciPy's Dop853DenseOutput) of the step dn */
void lm_dense_at(double s, const lm_dense *dn, double *y)
{
    int64_t N = dn->N;
    double x = (s - dn->t_old) / dn->h;
    for (int64_t j = 0; j < N; j++) {
        double acc = 0.0;
        for (int64_t i = 0; i < LM_DENSE_F; i++) {
            acc += dn->F[(LM_DENSE_F - 1 - i) * N + j];
            if (i % 2 == 0)
                acc *= x;
            else
                acc *= 1.0 - x;
        }
        y[j] = acc + dn->y_old[j];
    }
}

/* dop853.dense_rows: F's rows (the dense output's coefficients) from the stages K; dy
 * scratch */
static void dense_rows(double *F, const double *y, const double *ynew, double h,
                       const double *K, const double *D, double *dy, int64_t N)
{
    for (int64_t i = 0; i < N; i++) {
        double d0 = ynew[i] - y[i];
        F[i] = d0;
        F[N + i] = h * K[i] - d0;
        F[2 * N + i] = 2.0 * d0 - h * (K[LM_STAGES * N + i] + K[i]);
    }
    for (int64_t r = 0; r < LM_DENSE_ROWS; r++) {
        combine(dy, D + r * LM_EXTENDED, K, LM_EXTENDED, 0, N);
        for (int64_t i = 0; i < N; i++)
            F[(3 + r) * N + i] = h * dy[i];
    }
}

/* dop853.ev_dense_stages: the step's 3 more stages into K, its dense output into F */
void lm_dense_stages(lm_ctx *cx, double t, const double *y, const double *ynew, double h,
                     const double *p, const lm_act *act, double *K, double *F)
{
    const lm_tables *tab = cx->tab;
    int64_t N = 2 * cx->sy->n;
    lm_mark mark = lm_mark_now(cx);
    double *dy = lm_doubles(cx, N), *ys = lm_doubles(cx, N);
    for (int64_t s = LM_STAGES + 1; s < LM_EXTENDED; s++) {
        int64_t x = s - LM_STAGES - 1;
        combine(dy, tab->AX + x * LM_EXTENDED, K, s, 1, N);
        advance(ys, y, h, dy, N);
        lm_rhs(cx, t + tab->CX[x] * h, ys, p, act, K + s * N);
    }
    dense_rows(F, y, ynew, h, K, tab->D, dy, N);
    lm_release(cx, mark);
}
