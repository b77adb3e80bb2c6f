/* The projections onto the constraints and the consistent starts: the C twins of
 * _kernels/project.py (after a step, the batch loop's in the Euclidean metric, the loop
 * with events' in the mass-matrix metric on the mode's rows), with arrays.py's products
 * with the constraint matrix (their one user). */
#include <math.h>
#include <string.h>

#include "engine.h"

#define PROJECTION_ITERATIONS 6 /* project.PROJECTION_ITERATIONS */

/* arrays.a_bt: A B^T (k x j) of A (k x n) and B (j x n), skipping A's zeros */
static double *a_bt(lm_ctx *cx, const double *A, int64_t k, int64_t n, const double *B,
                    int64_t j)
{
    double *G = lm_zeros(cx, k * j);
    for (int64_t i = 0; i < k; i++)
        for (int64_t c = 0; c < n; c++) {
            double a = A[i * n + c];
            if (a != 0.0)
                for (int64_t r = 0; r < j; r++)
                    G[i * j + r] += a * B[r * n + c];
        }
    return G;
}

/* arrays.at_v: A^T w (n) of A (k x n) and w (k) */
static double *at_v(lm_ctx *cx, const double *A, int64_t k, int64_t n, const double *w)
{
    double *out = lm_zeros(cx, n);
    for (int64_t i = 0; i < k; i++) {
        double wi = w[i];
        for (int64_t c = 0; c < n; c++)
            out[c] += A[i * n + c] * wi;
    }
    return out;
}

/* arrays.a_v: A v (k) of A (k x n) and v (n) */
static double *a_v(lm_ctx *cx, const double *A, int64_t k, int64_t n, const double *v)
{
    double *out = lm_doubles(cx, k);
    for (int64_t i = 0; i < k; i++) {
        double s = 0.0;
        for (int64_t c = 0; c < n; c++)
            s += A[i * n + c] * v[c];
        out[i] = s;
    }
    return out;
}

/* arrays.diagonal_weights: W's diagonal where W (n x n) is diagonal and positive there,
 * else NULL */
static double *diagonal_weights(lm_ctx *cx, const double *W, int64_t n)
{
    double *d = lm_doubles(cx, n);
    for (int64_t i = 0; i < n; i++)
        for (int64_t c = 0; c < n; c++) {
            if (c == i) {
                if (!(W[i * n + i] > 0.0))
                    return NULL;
                d[i] = W[i * n + i];
            } else if (W[i * n + c] != 0.0) {
                return NULL;
            }
        }
    return d;
}

/* kkt.batch_solve: K x = r by elimination, K and r kept */
static double *batch_solve(lm_ctx *cx, const double *K, const double *r, int64_t N)
{
    double *x = lm_copy(cx, r, N);
    lm_gauss(lm_copy(cx, K, N * N), x, N);
    return x;
}

/* project.ev_correction: dx (n) minimising dx^T W dx subject to Ar dx = r (Ar k x n):
 * by the Schur complement where W is diagonal and positive, else the KKT system by
 * elimination; Euclidean least squares where that is singular */
static void ev_correction(lm_ctx *cx, const double *W, const double *Ar, const double *r,
                          int64_t n, int64_t k, double *dx)
{
    lm_mark mark = lm_mark_now(cx);
    double *d = diagonal_weights(cx, W, n);
    if (d != NULL) {
        double *ArW = lm_doubles(cx, k * n);
        for (int64_t a = 0; a < k; a++)
            for (int64_t c = 0; c < n; c++)
                ArW[a * n + c] = Ar[a * n + c] / d[c];
        double *w = batch_solve(cx, a_bt(cx, ArW, k, n, Ar, k), r, k);
        if (lm_all_finite(w, k)) {
            memcpy(dx, at_v(cx, ArW, k, n, w), (size_t)n * sizeof(double));
            lm_release(cx, mark);
            return;
        }
    }
    int64_t N = n + k;
    double *K = lm_zeros(cx, N * N);
    double *x = lm_zeros(cx, N);
    for (int64_t i = 0; i < n; i++)
        for (int64_t c = 0; c < n; c++)
            K[i * N + c] = W[i * n + c];
    for (int64_t a = 0; a < k; a++) {
        for (int64_t i = 0; i < n; i++) {
            K[i * N + n + a] = Ar[a * n + i];
            K[(n + a) * N + i] = Ar[a * n + i];
        }
        x[n + a] = r[a];
    }
    lm_gauss(K, x, N);
    if (lm_all_finite(x, N)) {
        memcpy(dx, x, (size_t)n * sizeof(double));
    } else {
        double *w = batch_solve(cx, a_bt(cx, Ar, k, n, Ar, k), r, k);
        memcpy(dx, at_v(cx, Ar, k, n, w), (size_t)n * sizeof(double));
    }
    lm_release(cx, mark);
}

/* the rows ``rows`` (count) of A (m x n) */
static double *rows_of(lm_ctx *cx, const double *A, int64_t n, const int64_t *rows,
                       int64_t count)
{
    double *out = lm_doubles(cx, count * n);
    for (int64_t a = 0; a < count; a++)
        memcpy(out + a * n, A + rows[a] * n, (size_t)n * sizeof(double));
    return out;
}

/* project.ev_project: y onto the mode's manifold in place, in the mass-matrix metric:
 * positions onto f_h = offset_h (Gauss-Newton, act's hrows), velocities onto
 * A_r v + b_r = 0 (act's rows) */
void lm_project(lm_ctx *cx, double t, double *y, const double *p, const lm_act *act,
                const double *offset)
{
    int64_t n = cx->sy->n, m = cx->sy->m, nh = act->nh, na = act->na;
    lm_mark mark = lm_mark_now(cx);
    double *q = lm_copy(cx, y, n), *v = lm_copy(cx, y + n, n);
    double *f = lm_doubles(cx, m), *A = lm_doubles(cx, m * n), *b = lm_doubles(cx, m);
    double *W = lm_zeros(cx, n * n);
    if (nh > 0) {
        double *rhs = lm_doubles(cx, n), *Ad = lm_doubles(cx, m * n);
        double *gam = lm_doubles(cx, m), *mu = lm_doubles(cx, m);
        double *r = lm_doubles(cx, nh), *Ah = lm_doubles(cx, nh * n), *dq = lm_doubles(cx, n);
        int have_w = 0;
        for (int it = 0; it < PROJECTION_ITERATIONS; it++) {
            lm_constraints(cx, t, q, p, f, A, b);
            double big = 0.0;
            for (int64_t a = 0; a < nh; a++) {
                int64_t h = act->hrows[a];
                r[a] = -(f[h] - offset[h]);
                if (fabs(r[a]) > big)
                    big = fabs(r[a]);
            }
            double scale = 1.0 + lm_max_abs(q, n);
            double mA = lm_max_abs(A, m * n);
            if (big <= 2e-16 * scale * (mA > 1.0 ? mA : 1.0))
                break;
            if (!have_w) {
                lm_dynamics(cx, t, q, v, p, W, rhs, Ad, gam, mu);
                have_w = 1;
            }
            for (int64_t a = 0; a < nh; a++)
                memcpy(Ah + a * n, A + act->hrows[a] * n, (size_t)n * sizeof(double));
            ev_correction(cx, W, Ah, r, n, nh, dq);
            for (int64_t i = 0; i < n; i++)
                q[i] += dq[i];
            if (lm_max_abs(dq, n) <= 1e-16 * scale)
                break;
        }
    }
    if (na > 0) {
        lm_constraints(cx, t, q, p, f, A, b);
        double *Ar = rows_of(cx, A, n, act->rows, na);
        double *r = a_v(cx, Ar, na, n, v);
        for (int64_t a = 0; a < na; a++)
            r[a] = -(r[a] + b[act->rows[a]]);
        if (lm_any_nonzero(r, na)) {
            double *rhs = lm_doubles(cx, n), *Ad = lm_doubles(cx, m * n);
            double *gam = lm_doubles(cx, m), *mu = lm_doubles(cx, m);
            double *dv = lm_doubles(cx, n);
            lm_dynamics(cx, t, q, v, p, W, rhs, Ad, gam, mu);
            ev_correction(cx, W, Ar, r, n, na, dv);
            for (int64_t i = 0; i < n; i++)
                v[i] += dv[i];
        }
    }
    memcpy(y, q, (size_t)n * sizeof(double));
    memcpy(y + n, v, (size_t)n * sizeof(double));
    lm_release(cx, mark);
}

/* project.batch_project: positions onto f = 0 (Gauss-Newton, minimum norm, at most
 * PROJECTION_ITERATIONS steps), then velocities onto A v + b = 0; in place, Euclidean */
void lm_batch_project(lm_ctx *cx, double t, double *y, const double *p)
{
    int64_t n = cx->sy->n, m = cx->sy->m;
    lm_mark mark = lm_mark_now(cx);
    double *q = lm_copy(cx, y, n);
    double *f = lm_doubles(cx, m), *A = lm_doubles(cx, m * n), *b = lm_doubles(cx, m);
    for (int it = 0; it < PROJECTION_ITERATIONS; it++) {
        lm_constraints(cx, t, q, p, f, A, b);
        double big = 0.0;
        for (int64_t j = 0; j < m; j++)
            if (fabs(f[j]) > big)
                big = fabs(f[j]);
        if (big <= 1e-15 * (1.0 + lm_max_abs(q, n)))
            break;
        lm_mark step = lm_mark_now(cx);
        double *w = batch_solve(cx, a_bt(cx, A, m, n, A, m), f, m);
        double *dq = at_v(cx, A, m, n, w);
        for (int64_t i = 0; i < n; i++)
            q[i] -= dq[i];
        lm_release(cx, step);
    }
    lm_constraints(cx, t, q, p, f, A, b);
    double *v = lm_copy(cx, y + n, n);
    double *r = a_v(cx, A, m, n, v);
    for (int64_t j = 0; j < m; j++)
        r[j] = r[j] + b[j];
    double *w = batch_solve(cx, a_bt(cx, A, m, n, A, m), r, m);
    double *dv = at_v(cx, A, m, n, w);
    for (int64_t i = 0; i < n; i++)
        v[i] -= dv[i];
    memcpy(y, q, (size_t)n * sizeof(double));
    memcpy(y + n, v, (size_t)n * sizeof(double));
    lm_release(cx, mark);
}

/* project.ev_restricted: one correction of the start onto the constraints ``rows`` over
 * the free coordinates (mask), the mass-matrix metric restricted to them; ``what`` 0
 * positions (f = 0), 1 velocities (A v + b = 0). dx over all coordinates (0 on the held
 * ones) into dx; the residual's size, the movable rows, the step's size through the
 * pointers. */
static void ev_restricted(lm_ctx *cx, double t, const double *q, const double *v,
                          const double *p, const int64_t *rows, int64_t nrows,
                          const uint8_t *free, int what, double *dx, double *big_out,
                          int64_t *na_out, double *step_out)
{
    int64_t n = cx->sy->n, m = cx->sy->m;
    lm_mark mark = lm_mark_now(cx);
    double *f = lm_doubles(cx, m), *A = lm_doubles(cx, m * n), *b = lm_doubles(cx, m);
    lm_constraints(cx, t, q, p, f, A, b);
    int64_t nf = 0;
    for (int64_t i = 0; i < n; i++)
        if (free[i])
            nf++;
    int64_t *idx = lm_ints(cx, nf);
    nf = 0;
    for (int64_t i = 0; i < n; i++)
        if (free[i])
            idx[nf++] = i;
    int64_t *act = lm_ints(cx, nrows);
    int64_t na = 0;
    for (int64_t a = 0; a < nrows; a++)
        for (int64_t c = 0; c < nf; c++)
            if (A[rows[a] * n + idx[c]] != 0.0) {
                act[na++] = rows[a];
                break;
            }
    for (int64_t i = 0; i < n; i++)
        dx[i] = 0.0;
    *big_out = 0.0;
    *na_out = na;
    *step_out = 0.0;
    if (na == 0) {
        lm_release(cx, mark);
        return;
    }
    double *r = lm_doubles(cx, na);
    double big = 0.0;
    for (int64_t a = 0; a < na; a++) {
        int64_t j = act[a];
        if (what == 0) {
            r[a] = -f[j];
        } else {
            double s = b[j];
            for (int64_t c = 0; c < n; c++)
                s += A[j * n + c] * v[c];
            r[a] = -s;
        }
        if (fabs(r[a]) > big)
            big = fabs(r[a]);
    }
    *big_out = big;
    double *Af = lm_doubles(cx, na * nf);
    for (int64_t a = 0; a < na; a++)
        for (int64_t c = 0; c < nf; c++)
            Af[a * nf + c] = A[act[a] * n + idx[c]];
    double mA = lm_max_abs(A, m * n);
    if ((what == 0 && big <= 2e-16 * (1.0 + lm_max_abs(q, n)) * (mA > 1.0 ? mA : 1.0))
        || (what == 1 && big == 0.0)) {
        lm_release(cx, mark);
        return;
    }
    double *M = lm_doubles(cx, n * n), *rhs = lm_doubles(cx, n), *Ad = lm_doubles(cx, m * n);
    double *gam = lm_doubles(cx, m), *mu = lm_doubles(cx, m);
    lm_dynamics(cx, t, q, v, p, M, rhs, Ad, gam, mu);
    double *W = lm_doubles(cx, nf * nf);
    for (int64_t a = 0; a < nf; a++)
        for (int64_t c = 0; c < nf; c++)
            W[a * nf + c] = M[idx[a] * n + idx[c]];
    double *d = lm_doubles(cx, nf);
    ev_correction(cx, W, Af, r, nf, na, d);
    double step = 0.0;
    for (int64_t c = 0; c < nf; c++) {
        dx[idx[c]] = d[c];
        if (fabs(d[c]) > step)
            step = fabs(d[c]);
    }
    *step_out = step;
    lm_release(cx, mark);
}

/* project.ev_consistent: the start with the held coordinates and velocities set and the
 * others moved onto the constraints the unheld start meets, in place; kinds (3, m) */
void lm_consistent(lm_ctx *cx, double *q, double *v, const double *p, const uint8_t *hold_q,
                   const uint8_t *hold_v, const double *value_q, const double *value_v,
                   const int64_t *kinds, double tol)
{
    int64_t n = cx->sy->n, m = cx->sy->m;
    lm_mark mark = lm_mark_now(cx);
    double *f = lm_doubles(cx, m), *A = lm_doubles(cx, m * n), *b = lm_doubles(cx, m);
    lm_constraints(cx, 0.0, q, p, f, A, b);
    double tol_q = tol * (1.0 + lm_max_abs(q, n));
    uint8_t *inq = lm_bools(cx, m);
    int64_t nq = 0, nv = 0;
    for (int64_t j = 0; j < m; j++)
        if (kinds[m + j] == 1 && fabs(f[j]) <= tol_q) {
            inq[j] = 1;
            nq++;
        }
    int64_t *rows_q = lm_ints(cx, nq), *rows_v = lm_ints(cx, m);
    nq = 0;
    for (int64_t j = 0; j < m; j++) {
        if (inq[j])
            rows_q[nq++] = j;
        double s = b[j];
        for (int64_t c = 0; c < n; c++)
            s += A[j * n + c] * v[c];
        if (fabs(s) <= tol_q && (kinds[m + j] == 0 || inq[j]))
            rows_v[nv++] = j;
    }
    uint8_t *free_q = lm_bools(cx, n), *free_v = lm_bools(cx, n);
    int any_q = 0, any_v = 0;
    for (int64_t i = 0; i < n; i++) {
        free_q[i] = free_v[i] = 1;
        if (hold_q[i]) {
            q[i] = value_q[i];
            free_q[i] = 0;
        }
        if (hold_v[i]) {
            v[i] = value_v[i];
            free_v[i] = 0;
        }
        any_q = any_q || free_q[i];
        any_v = any_v || free_v[i];
    }
    double *dx = lm_doubles(cx, n);
    double big, step;
    int64_t na;
    if (nq > 0 && any_q) {
        for (int it = 0; it < PROJECTION_ITERATIONS; it++) {
            ev_restricted(cx, 0.0, q, v, p, rows_q, nq, free_q, 0, dx, &big, &na, &step);
            if (na == 0 || step == 0.0)
                break;
            for (int64_t i = 0; i < n; i++)
                q[i] += dx[i];
            if (step <= 1e-16 * (1.0 + lm_max_abs_diff(q, dx, n)))
                break;
        }
    }
    if (nv > 0 && any_v) {
        ev_restricted(cx, 0.0, q, v, p, rows_v, nv, free_v, 1, dx, &big, &na, &step);
        for (int64_t i = 0; i < n; i++)
            v[i] += dx[i];
    }
    lm_release(cx, mark);
}

/* entry point of project.ev_starts: lm_consistent for every row of Q, V (B, n),
 * parameters P (B, np), in place */
int64_t lm_ev_starts(const lm_system *sy, int64_t B, double *Q, double *V, const double *P,
                     const uint8_t *hold_q, const uint8_t *hold_v, const double *value_q,
                     const double *value_v, const int64_t *kinds, double tol)
{
    lm_ctx cx;
    lm_ctx_init(&cx, sy, NULL);
    if (setjmp(cx.fail)) {
        lm_ctx_free(&cx);
        return LM_ST_MEMORY;
    }
    int64_t n = sy->n;
    for (int64_t b = 0; b < B; b++)
        lm_consistent(&cx, Q + b * n, V + b * n, P + b * sy->np, hold_q, hold_v, value_q,
                      value_v, kinds, tol);
    lm_ctx_free(&cx);
    return 0;
}
