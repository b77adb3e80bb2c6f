/* The batch loop of lamech.numeric.integrate_batch: the C twin of _kernels/batch.py
 * (DOP853 with the projection onto the constraints after every accepted step, every
 * constraint active, no events). Serial over the rows: the Python side splits a batch
 * over threads. */
#include <math.h>
#include <string.h>

#include "engine.h"

/* batch.batch_deriv: out = [v; q''] with every constraint active */
static void batch_deriv(lm_ctx *cx, double t, const double *y, const double *p, double *out)
{
    int64_t n = cx->sy->n;
    lm_mark mark = lm_mark_now(cx);
    double *sol = lm_doubles(cx, n + cx->sy->m);
    lm_accelerations(cx, t, y, p, sol);
    for (int64_t i = 0; i < n; i++) {
        out[i] = y[n + i];
        out[n + i] = sol[i];
    }
    lm_release(cx, mark);
}

/* batch.batch_run_one: one run from t = 0 to tl[LM_TL_T_END], the final state into out;
 * returns the steps, or -1 (out NaN) where the step size collapsed or the steps ran out */
static int64_t batch_run_one(lm_ctx *cx, const double *y0, const double *p, const double *tl,
                             const int64_t *lim, double *out)
{
    int64_t N = 2 * cx->sy->n;
    lm_mark mark = lm_mark_now(cx);
    double *y = lm_copy(cx, y0, N);
    double t = 0.0, t_end = tl[LM_TL_T_END];
    double *K = lm_zeros(cx, LM_EXTENDED * N);
    double *f = lm_zeros(cx, N);
    batch_deriv(cx, t, y, p, f);
    /* every constraint active, none holonomic by name (the batch projection takes all) */
    lm_act act = lm_act_all(cx, cx->sy->m);
    double h = lm_first_step(cx, t, y, f, p, &act, t_end, tl);
    int64_t steps = 0;
    double *ynew = lm_zeros(cx, N);
    int failed = 0;
    while (t < t_end) {
        double taken;
        int64_t trials;
        if (steps >= lim[LM_LM_MAX_STEPS]) {
            failed = 1;
            break;
        }
        t = lm_dop853_step(cx, t, y, f, h, t_end, p, &act, tl, K, ynew, &taken, &h, &trials);
        if (trials <= 0) {
            failed = 1;
            break;
        }
        memcpy(y, ynew, (size_t)N * sizeof(double));
        lm_batch_project(cx, t, y, p);
        batch_deriv(cx, t, y, p, f);
        steps++;
    }
    for (int64_t i = 0; i < N; i++)
        out[i] = failed ? y[i] * NAN : y[i];
    lm_release(cx, mark);
    return failed ? -1 : steps;
}

/* entry point of batch.batch_run: every row of Y0 (B, N), parameters P (B, np), to
 * t_end; the final states into out (B, N), the steps (-1: failed) into steps (B) */
int64_t lm_batch_run(const lm_system *sy, const lm_tables *tab, int64_t B, const double *Y0,
                     const double *P, const double *tl, const int64_t *lim, double *out,
                     int64_t *steps)
{
    lm_ctx cx;
    lm_ctx_init(&cx, sy, tab);
    if (setjmp(cx.fail)) {
        lm_ctx_free(&cx);
        return LM_ST_MEMORY;
    }
    int64_t N = 2 * sy->n;
    for (int64_t b = 0; b < B; b++)
        steps[b] = batch_run_one(&cx, Y0 + b * N, P + b * sy->np, tl, lim, out + b * N);
    lm_ctx_free(&cx);
    return 0;
}
