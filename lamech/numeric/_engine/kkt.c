/* The system's functions and the KKT solves at a state, the right-hand sides: the C twins
 * of _kernels/kkt.py.
 *
 * The KKT system  M q'' - A_r^T lambda + sum_s c_s A_{j_s}^T lambda_{k_s} = rhs,
 * A_r q'' = -gamma_r  on the active rows (a slipping friction row j_s on the normal row
 * at position k_s adds its kinetic friction, c_s = mu_j * slip_c[s]). Where M is
 * diagonal (sy->diagonal) and every M_ii nonzero, by the Schur complement
 * S = A_r M^-1 G^T over A's structural nonzeros (Cholesky where S is symmetric positive
 * definite, else elimination); a zero M_ii, or dependent rows Cholesky finds, fall back
 * to the full KKT matrix. Every function writing into ``out`` releases its scratch.
 */
#include <string.h>

#include "engine.h"

static void zero(double *x, int64_t count)
{
    for (int64_t i = 0; i < count; i++)
        x[i] = 0.0;
}

/* kkt.dynamics: (M, rhs, A, gamma, mu), zeroed, then filled */
void lm_dynamics(lm_ctx *cx, double t, const double *q, const double *v, const double *p,
                 double *M, double *rhs, double *A, double *gam, double *mu)
{
    int64_t n = cx->sy->n, m = cx->sy->m;
    zero(M, n * n);
    zero(rhs, n);
    zero(A, m * n);
    zero(gam, m);
    zero(mu, m);
    cx->sy->dynamics(t, q, v, p, M, rhs, A, gam, mu);
}

/* kkt.dynamics_sparse_in: (M's diagonal, rhs, A's nonzeros in CSR order, gamma, mu) */
static void dynamics_sparse(lm_ctx *cx, double t, const double *q, const double *v,
                            const double *p, double *Md, double *rhs, double *Av, double *gam,
                            double *mu)
{
    int64_t n = cx->sy->n, m = cx->sy->m;
    zero(Md, n);
    zero(rhs, n);
    zero(Av, cx->sy->nnz);
    zero(gam, m);
    zero(mu, m);
    cx->sy->dynamics_sparse(t, q, v, p, Md, rhs, Av, gam, mu);
}

/* kkt.constraints: (f, A, b) with F = A v + b */
void lm_constraints(lm_ctx *cx, double t, const double *q, const double *p, double *f,
                    double *A, double *b)
{
    int64_t n = cx->sy->n, m = cx->sy->m;
    zero(f, m);
    zero(A, m * n);
    zero(b, m);
    cx->sy->constraints(t, q, p, f, A, b);
}

/* kkt.energy: (T, V) */
void lm_energy(lm_ctx *cx, double t, const double *q, const double *v, const double *p,
               double *E)
{
    zero(E, 2);
    cx->sy->energy(t, q, v, p, E);
}

/* kkt.restitution: e per constraint */
void lm_restitution(lm_ctx *cx, double t, const double *q, const double *p, double *e)
{
    zero(e, cx->sy->m);
    cx->sy->restitution(t, q, p, e);
}

/* kkt.switches: the inputs' switching functions (a branch switches where one crosses 0) */
void lm_switches(lm_ctx *cx, double t, const double *q, const double *v, const double *p,
                 double *s)
{
    zero(s, cx->sy->nslots);
    cx->sy->switches(t, q, v, p, s);
}

/* kkt.kkt_dense: the full KKT matrix by elimination with partial pivoting; n + na into
 * out */
static void kkt_dense(lm_ctx *cx, const double *M, const double *rhs, const double *A,
                      const double *gam, const double *mu, const lm_act *act, double *out)
{
    int64_t n = cx->sy->n, na = act->na, N = n + act->na;
    lm_mark mark = lm_mark_now(cx);
    double *K = lm_zeros(cx, N * N);
    double *r = lm_zeros(cx, N);
    for (int64_t i = 0; i < n; i++) {
        r[i] = rhs[i];
        for (int64_t k = 0; k < n; k++)
            K[i * N + k] = M[i * n + k];
    }
    for (int64_t a = 0; a < na; a++) {
        int64_t j = act->rows[a];
        r[n + a] = -gam[j];
        for (int64_t i = 0; i < n; i++) {
            K[i * N + n + a] = -A[j * n + i];
            K[(n + a) * N + i] = A[j * n + i];
        }
    }
    for (int64_t s = 0; s < act->ns; s++) {
        int64_t j = act->slip_j[s];
        double c = mu[j] * act->slip_c[s];
        for (int64_t i = 0; i < n; i++)
            K[i * N + n + act->slip_k[s]] += c * A[j * n + i];
    }
    lm_gauss(K, r, N);
    memcpy(out, r, (size_t)N * sizeof(double));
    lm_release(cx, mark);
}

/* kkt.dense_matrices: M (n x n) and A (m x n) from their structural nonzeros, into the
 * arena */
static void dense_matrices(lm_ctx *cx, const double *Md, const double *Av, double **M,
                           double **A)
{
    const lm_system *sy = cx->sy;
    int64_t n = sy->n, m = sy->m;
    *M = lm_zeros(cx, n * n);
    for (int64_t i = 0; i < n; i++)
        (*M)[i * n + i] = Md[i];
    *A = lm_zeros(cx, m * n);
    for (int64_t j = 0; j < m; j++)
        for (int64_t e = sy->PTR[j]; e < sy->PTR[j + 1]; e++)
            (*A)[j * n + sy->IDX[e]] = Av[e];
}

/* kkt.kkt_dense on M and A given by their structural nonzeros (a zero M_ii, or dependent
 * rows: the full KKT matrix may be regular where M or S is not) */
static void kkt_dense_sparse(lm_ctx *cx, const double *Md, const double *rhs,
                             const double *Av, const double *gam, const double *mu,
                             const lm_act *act, double *out)
{
    lm_mark mark = lm_mark_now(cx);
    double *M, *A;
    dense_matrices(cx, Md, Av, &M, &A);
    kkt_dense(cx, M, rhs, A, gam, mu, act, out);
    lm_release(cx, mark);
}

/* kkt.kkt_schur_sparse (and _in): the Schur complement over the structural nonzeros, M's
 * diagonal Md and A's nonzeros Av (by row PTR, IDX; by column CPTR, CROW, CPOS their
 * positions in Av); n + na into out */
static void kkt_schur_sparse(lm_ctx *cx, const double *Md, const double *rhs,
                             const double *Av, const double *gam, const double *mu,
                             const lm_act *act, double *out)
{
    const lm_system *sy = cx->sy;
    const int64_t *PTR = sy->PTR, *IDX = sy->IDX, *CPTR = sy->CPTR, *CROW = sy->CROW,
                  *CPOS = sy->CPOS;
    int64_t n = sy->n, m = sy->m, na = act->na, ns = act->ns;
    lm_mark mark = lm_mark_now(cx);
    double *minv = lm_doubles(cx, n);
    int positive = 1;
    for (int64_t i = 0; i < n; i++) {
        if (Md[i] == 0.0) {
            lm_release(cx, mark);
            kkt_dense_sparse(cx, Md, rhs, Av, gam, mu, act, out);
            return;
        }
        minv[i] = 1.0 / Md[i];
        positive = positive && Md[i] > 0.0;
    }
    for (int64_t i = 0; i < n; i++)
        out[i] = rhs[i];
    if (na == 0) {
        for (int64_t i = 0; i < n; i++)
            out[i] *= minv[i];
        lm_release(cx, mark);
        return;
    }
    int64_t *pos = lm_ints(cx, m); /* position of each constraint among the rows */
    for (int64_t j = 0; j < m; j++)
        pos[j] = -1;
    for (int64_t a = 0; a < na; a++)
        pos[act->rows[a]] = a;
    double *S = lm_zeros(cx, na * na);
    double *r = lm_doubles(cx, na);
    for (int64_t a = 0; a < na; a++) {
        int64_t j = act->rows[a];
        double acc = -gam[j];
        for (int64_t e = PTR[j]; e < PTR[j + 1]; e++) {
            int64_t i = IDX[e];
            double w = Av[e] * minv[i];
            acc -= w * rhs[i];
            for (int64_t f = CPTR[i]; f < CPTR[i + 1]; f++) {
                int64_t b = pos[CROW[f]];
                if (b >= 0)
                    S[a * na + b] += w * Av[CPOS[f]];
            }
            for (int64_t s = 0; s < ns; s++) {
                int64_t js = act->slip_j[s];
                /* A[js, i]: row js's entry in column i, if it has one */
                for (int64_t g = PTR[js]; g < PTR[js + 1]; g++)
                    if (IDX[g] == i)
                        S[a * na + act->slip_k[s]] -= w * mu[js] * act->slip_c[s] * Av[g];
            }
        }
        r[a] = acc;
    }
    if (ns == 0 && positive) {
        /* S = A_r M^-1 A_r^T symmetric positive definite: Cholesky */
        if (!lm_cholesky(cx, S, r, na)) { /* dependent rows: let the full KKT decide */
            lm_release(cx, mark);
            kkt_dense_sparse(cx, Md, rhs, Av, gam, mu, act, out);
            return;
        }
    } else {
        lm_gauss(S, r, na); /* r becomes lambda */
    }
    for (int64_t a = 0; a < na; a++) {
        int64_t j = act->rows[a];
        out[n + a] = r[a];
        for (int64_t e = PTR[j]; e < PTR[j + 1]; e++)
            out[IDX[e]] += Av[e] * r[a];
    }
    for (int64_t s = 0; s < ns; s++) {
        int64_t j = act->slip_j[s];
        double c = mu[j] * act->slip_c[s] * r[act->slip_k[s]];
        for (int64_t e = PTR[j]; e < PTR[j + 1]; e++)
            out[IDX[e]] -= c * Av[e];
    }
    for (int64_t i = 0; i < n; i++)
        out[i] *= minv[i];
    lm_release(cx, mark);
}

/* kkt.kkt_schur: kkt_schur_sparse on dense M and A */
static void kkt_schur(lm_ctx *cx, const double *M, const double *rhs, const double *A,
                      const double *gam, const double *mu, const lm_act *act, double *out)
{
    const lm_system *sy = cx->sy;
    int64_t n = sy->n, m = sy->m;
    lm_mark mark = lm_mark_now(cx);
    double *Md = lm_doubles(cx, n);
    for (int64_t i = 0; i < n; i++)
        Md[i] = M[i * n + i];
    double *Av = lm_doubles(cx, sy->nnz);
    for (int64_t j = 0; j < m; j++)
        for (int64_t e = sy->PTR[j]; e < sy->PTR[j + 1]; e++)
            Av[e] = A[j * n + sy->IDX[e]];
    kkt_schur_sparse(cx, Md, rhs, Av, gam, mu, act, out);
    lm_release(cx, mark);
}

/* kkt.kkt_solve: kkt_schur where M is diagonal, else kkt_dense */
void lm_kkt_solve(lm_ctx *cx, const double *M, const double *rhs, const double *A,
                  const double *gam, const double *mu, const lm_act *act, double *out)
{
    if (cx->sy->diagonal)
        kkt_schur(cx, M, rhs, A, gam, mu, act, out);
    else
        kkt_dense(cx, M, rhs, A, gam, mu, act, out);
}

/* kkt.kkt_state: [q''; lambda_rows] at (t, q, v), over the structural nonzeros where M is
 * diagonal */
void lm_kkt_state(lm_ctx *cx, double t, const double *q, const double *v, const double *p,
                  const lm_act *act, double *out)
{
    const lm_system *sy = cx->sy;
    int64_t n = sy->n, m = sy->m;
    lm_mark mark = lm_mark_now(cx);
    if (sy->diagonal) {
        double *Md = lm_doubles(cx, n), *rhs = lm_doubles(cx, n);
        double *Av = lm_doubles(cx, sy->nnz);
        double *gam = lm_doubles(cx, m), *mu = lm_doubles(cx, m);
        dynamics_sparse(cx, t, q, v, p, Md, rhs, Av, gam, mu);
        kkt_schur_sparse(cx, Md, rhs, Av, gam, mu, act, out);
    } else {
        double *M = lm_doubles(cx, n * n), *rhs = lm_doubles(cx, n);
        double *A = lm_doubles(cx, m * n);
        double *gam = lm_doubles(cx, m), *mu = lm_doubles(cx, m);
        lm_dynamics(cx, t, q, v, p, M, rhs, A, gam, mu);
        kkt_dense(cx, M, rhs, A, gam, mu, act, out);
    }
    lm_release(cx, mark);
}

/* kkt.rhs_into (rhs_kernel): y' = [v; q''] on the active set into out (2n) */
void lm_rhs(lm_ctx *cx, double t, const double *y, const double *p, const lm_act *act,
            double *out)
{
    int64_t n = cx->sy->n;
    lm_mark mark = lm_mark_now(cx);
    double *yc = lm_copy(cx, y, 2 * n); /* q and v contiguous; out may be y */
    double *sol = lm_doubles(cx, n + act->na);
    lm_kkt_state(cx, t, yc, yc + n, p, act, sol);
    for (int64_t i = 0; i < n; i++) {
        out[i] = yc[n + i];
        out[n + i] = sol[i];
    }
    lm_release(cx, mark);
}

/* kkt.accelerations: [q''; lambda] (n + m) with every constraint active */
void lm_accelerations(lm_ctx *cx, double t, const double *y, const double *p, double *out)
{
    int64_t n = cx->sy->n;
    lm_mark mark = lm_mark_now(cx);
    lm_act act = lm_act_all(cx, cx->sy->m);
    lm_kkt_state(cx, t, y, y + n, p, &act, out);
    lm_release(cx, mark);
}

/* an active set of the arrays an entry point was given (no holonomic rows by name) */
static lm_act given_act(const int64_t *rows, int64_t na, const int64_t *slip_j,
                        const int64_t *slip_k, const double *slip_c, int64_t ns)
{
    lm_act act;
    act.na = na;
    act.nh = 0;
    act.ns = ns;
    act.rows = (int64_t *)rows;
    act.hrows = NULL;
    act.slip_j = (int64_t *)slip_j;
    act.slip_k = (int64_t *)slip_k;
    act.slip_c = (double *)slip_c;
    return act;
}

/* entry point of kkt.rhs_kernel */
int64_t lm_rhs_kernel(const lm_system *sy, double t, const double *y, const double *p,
                      const int64_t *rows, int64_t na, const int64_t *slip_j,
                      const int64_t *slip_k, const double *slip_c, int64_t ns, double *out)
{
    lm_ctx cx;
    lm_ctx_init(&cx, sy, NULL);
    if (setjmp(cx.fail)) {
        lm_ctx_free(&cx);
        return LM_ST_MEMORY;
    }
    lm_act act = given_act(rows, na, slip_j, slip_k, slip_c, ns);
    lm_rhs(&cx, t, y, p, &act, out);
    lm_ctx_free(&cx);
    return 0;
}

/* entry point of kkt.accelerations */
int64_t lm_accelerations_entry(const lm_system *sy, double t, const double *y, const double *p,
                               double *out)
{
    lm_ctx cx;
    lm_ctx_init(&cx, sy, NULL);
    if (setjmp(cx.fail)) {
        lm_ctx_free(&cx);
        return LM_ST_MEMORY;
    }
    lm_accelerations(&cx, t, y, p, out);
    lm_ctx_free(&cx);
    return 0;
}

/* entry point of kkt.kkt_solve */
int64_t lm_kkt_solve_entry(const lm_system *sy, const double *M, const double *rhs,
                           const double *A, const double *gam, const double *mu,
                           const int64_t *rows, int64_t na, const int64_t *slip_j,
                           const int64_t *slip_k, const double *slip_c, int64_t ns,
                           double *out)
{
    lm_ctx cx;
    lm_ctx_init(&cx, sy, NULL);
    if (setjmp(cx.fail)) {
        lm_ctx_free(&cx);
        return LM_ST_MEMORY;
    }
    lm_act act = given_act(rows, na, slip_j, slip_k, slip_c, ns);
    lm_kkt_solve(&cx, M, rhs, A, gam, mu, &act, out);
    lm_ctx_free(&cx);
    return 0;
}
