/* lamech's engine: the problem-independent hot path in C99, built once when lamech is
 * installed (setup.py: the extension module lamech.numeric._cengine_lib), loaded by ctypes
 * (lamech/numeric/_cengine.py).
 *
 * It is the one implementation of the rules (the mode, the events, the projection, the
 * KKT solves, the loops), used by every road: the loop with events, the batch loop, and
 * SciPy's integrators through rules.c. Comments name each function's former Python
 * kernel (lamech/numeric/_kernels/, of which codes.py, the codes, remains). A system whose
 * functions are not compiled hands them over as callbacks (lamech/numeric/_cengine.py)
 * with the same signatures.
 *
 * Conventions
 * - Arrays are row-major doubles or int64_t, as NumPy's C-contiguous arrays; booleans are
 *   uint8_t (NumPy's bool_).
 * - Every function takes the context ``cx`` first: the system (its generated functions,
 *   compiled per problem by the machine's C compiler, lamech/numeric/_cc.py, and handed
 *   over as function pointers; its sparsity pattern), DOP853's tables, and the scratch
 *   arena all temporary arrays come from (lm_alloc). Nothing here calls malloc but the
 *   arena; an arena that cannot grow jumps back to the entry point (lm_fail), which
 *   returns LM_ST_MEMORY: no input makes the process crash.
 * - Scratch: a function that returns arena memory to its caller does not release it; a
 *   loop releases what an iteration allocated with lm_mark / lm_release.
 */
#ifndef LAMECH_ENGINE_H
#define LAMECH_ENGINE_H

#include <setjmp.h>
#include <stddef.h>
#include <stdint.h>

#include "codes.h"

/* ------------------------------------------------------------------------------------
 * The system's generated functions (lamech/numeric/_codegen.py's C, _cc.py's FUNCTIONS):
 * each fills arrays its caller zeroed; matrices row-major.
 */
typedef void (*lm_dynamics_fn)(double t, const double *q, const double *v, const double *p,
                               double *M, double *rhs, double *A, double *gam, double *mu);
/* dynamics_sparse: the same signature; M's diagonal (n), rhs (n), A's structural
 * nonzeros in CSR order (nnz), gamma (m), mu (m) */
typedef void (*lm_constraints_fn)(double t, const double *q, const double *p, double *f,
                                  double *A, double *b);
typedef void (*lm_energy_fn)(double t, const double *q, const double *v, const double *p,
                             double *E);
typedef void (*lm_restitution_fn)(double t, const double *q, const double *p, double *e);
typedef void (*lm_switches_fn)(double t, const double *q, const double *v, const double *p,
                               double *s);

/* The system record (_kernels.SYSTEM_FIELDS). */
typedef struct {
    int64_t n;        /* coordinates */
    int64_t m;        /* constraints */
    int64_t np;       /* parameters (length of p) */
    int64_t diagonal; /* 1: M is diagonal (known from the symbolic M) */
    /* the sparsity pattern of A (_kkt.sparsity): by row PTR (m + 1), IDX (nnz); by column
     * CPTR (n + 1), CROW (nnz), CPOS (nnz: each entry's position in the row order) */
    const int64_t *PTR, *IDX, *CPTR, *CROW, *CPOS;
    int64_t nnz;
    lm_dynamics_fn dynamics;
    lm_dynamics_fn dynamics_sparse;
    lm_constraints_fn constraints;
    lm_energy_fn energy;
    lm_restitution_fn restitution;
    lm_switches_fn switches;
    const int64_t *slots; /* where in p each input switch's branch is held (0 or 1) */
    int64_t nslots;
} lm_system;

/* DOP853's tables (_tableau._tables): A (12 x 12), B (12), C (12), E3 (13), E5 (13), then
 * the dense output's AX (3 x 16), CX (3), D (4 x 16). */
#define LM_STAGES 12
#define LM_EXTENDED 16 /* stages with the dense output's 3 extra (K has 16 rows) */
#define LM_DENSE_ROWS 4
typedef struct {
    const double *A, *B, *C, *E3, *E5, *AX, *CX, *D;
} lm_tables;

/* ------------------------------------------------------------------------------------
 * The scratch arena: blocks chained, bump allocation, released to a mark.
 */
typedef struct lm_block {
    struct lm_block *next;
    size_t size; /* bytes of data */
    size_t used;
    /* data follows, 16-byte aligned */
} lm_block;

typedef struct {
    lm_block *head; /* first block */
    lm_block *cur;  /* the block allocations come from */
} lm_arena;

typedef struct {
    lm_block *blk;
    size_t used;
} lm_mark;

typedef struct {
    const lm_system *sy;
    const lm_tables *tab;
    lm_arena ar;
    jmp_buf fail; /* lm_alloc jumps here when memory runs out */
} lm_ctx;

void lm_ctx_init(lm_ctx *cx, const lm_system *sy, const lm_tables *tab);
void lm_ctx_free(lm_ctx *cx);
void *lm_alloc(lm_ctx *cx, size_t bytes); /* uninitialised; never NULL (jumps instead) */
double *lm_doubles(lm_ctx *cx, int64_t count);       /* uninitialised */
double *lm_zeros(lm_ctx *cx, int64_t count);         /* zeroed */
int64_t *lm_ints(lm_ctx *cx, int64_t count);         /* uninitialised */
uint8_t *lm_bools(lm_ctx *cx, int64_t count);        /* zeroed */
double *lm_copy(lm_ctx *cx, const double *x, int64_t count);
lm_mark lm_mark_now(lm_ctx *cx);
void lm_release(lm_ctx *cx, lm_mark mark);

/* ------------------------------------------------------------------------------------
 * Records (lamech/numeric/_kernels/codes.py describes them).
 */

/* the mode: kinds (3, m) int64 rows unilateral, holonomic, normal (-1: not friction);
 * imode (4, m) rows engaged, friction state (LM_FR_*), contact armed, stick armed; fmode
 * (5, m) rows sigma, sN, offset, accumulation time (NaN: none), last impact (NaN: none) */
typedef struct {
    int64_t m;
    const int64_t *kinds;
    int64_t *imode;
    double *fmode;
} lm_mode;
#define LM_KIND(md, r, j) ((md)->kinds[(r) * (md)->m + (j)])
#define LM_IMODE(md, r, j) ((md)->imode[(r) * (md)->m + (j)])
#define LM_FMODE(md, r, j) ((md)->fmode[(r) * (md)->m + (j)])

/* the mode's active set (modes.ev_mode): rows (na), hrows (nh: the holonomic ones),
 * slip_j, slip_k, slip_c (ns). The arrays hold m entries each (capacity): lm_act_new. */
typedef struct {
    int64_t na, nh, ns;
    int64_t *rows, *hrows, *slip_j, *slip_k;
    double *slip_c;
} lm_act;
lm_act lm_act_new(lm_ctx *cx, int64_t m);         /* empty, with capacity m */
lm_act lm_act_all(lm_ctx *cx, int64_t m);         /* every row active, none by name
                                                   * holonomic, no slips (the batch's) */

/* the watched events (modes.ev_watch): kinds wk and constraints wj (nw <= 2m). */
typedef struct {
    int64_t nw;
    int64_t *wk, *wj;
} lm_watch;

/* the event record: kind, j, t (cap), y (cap, N), x (cap, 4: detail code and 3 values);
 * the wanted events want (2, nwant) and found (nwant). */
typedef struct {
    int64_t cap, N;
    int64_t *kind, *j;
    double *t, *y, *x;
    int64_t nwant;
    const int64_t *want;
    uint8_t *found;
} lm_log;

/* the samples: output times TS (S), states SY (S, N), multipliers SL (S, m), residuals and
 * energy SR (S, 4). */
typedef struct {
    int64_t S, N, m;
    const double *TS;
    double *SY, *SL, *SR;
} lm_samples;

/* a step's dense output (dop853.ev_dense_stages): F (LM_DENSE_ROWS + 3 = 7, N) */
typedef struct {
    double t_old, h;
    const double *y_old;
    const double *F;
    int64_t N;
} lm_dense;
#define LM_DENSE_F 7

/* ------------------------------------------------------------------------------------
 * linalg.c (lamech/linalg.py: gauss_inplace, cholesky_inplace)
 */
void lm_gauss(double *K, double *x, int64_t N);           /* x <- K^-1 x; NaN if singular */
int lm_cholesky(lm_ctx *cx, double *K, double *x, int64_t N); /* 0: not positive definite */

/* arrays.c (_kernels/arrays.py) */
double lm_max_abs(const double *x, int64_t count);
double lm_max_abs_diff(const double *a, const double *b, int64_t count);
int lm_all_finite(const double *x, int64_t count);
int lm_any_nonzero(const double *x, int64_t count);
double lm_rms_scaled(const double *x, const double *scale, int64_t count);
double lm_rms_diff_scaled(const double *a, const double *b, const double *scale, int64_t count);

/* kkt.c (_kernels/kkt.py): the system's functions, each output zeroed first, then filled */
void lm_dynamics(lm_ctx *cx, double t, const double *q, const double *v, const double *p,
                 double *M, double *rhs, double *A, double *gam, double *mu);
void lm_constraints(lm_ctx *cx, double t, const double *q, const double *p, double *f,
                    double *A, double *b);
void lm_energy(lm_ctx *cx, double t, const double *q, const double *v, const double *p,
               double *E);
void lm_restitution(lm_ctx *cx, double t, const double *q, const double *p, double *e);
void lm_switches(lm_ctx *cx, double t, const double *q, const double *v, const double *p,
                 double *s);
/* kkt.kkt_solve: [q''; lambda on the active rows] (n + act->na) into out; slips from act */
void lm_kkt_solve(lm_ctx *cx, const double *M, const double *rhs, const double *A,
                  const double *gam, const double *mu, const lm_act *act, double *out);
/* kkt.kkt_state at (t, q, v): the same, from the system's functions */
void lm_kkt_state(lm_ctx *cx, double t, const double *q, const double *v, const double *p,
                  const lm_act *act, double *out);
/* kkt.rhs_into / rhs_kernel: y' = [v; q''] (N = 2n) on the active set into out */
void lm_rhs(lm_ctx *cx, double t, const double *y, const double *p, const lm_act *act,
            double *out);
/* kkt.accelerations: [q''; lambda] (n + m) with every constraint active into out */
void lm_accelerations(lm_ctx *cx, double t, const double *y, const double *p, double *out);

/* dop853.c (_kernels/dop853.py). K is (LM_EXTENDED, N). */
double lm_dop853_trial(lm_ctx *cx, double t, const double *y, const double *f, double h,
                       const double *p, const lm_act *act, const double *tl, double *K,
                       double *ynew);
/* dop853_step: returns t_new; *h the step taken, *h_next the next size, *trials (<= 0: a
 * collapse, no step) */
double lm_dop853_step(lm_ctx *cx, double t, const double *y, const double *f, double h_abs,
                      double bound, const double *p, const lm_act *act, const double *tl,
                      double *K, double *ynew, double *h, double *h_next, int64_t *trials);
double lm_first_step(lm_ctx *cx, double t, const double *y, const double *f, const double *p,
                     const lm_act *act, double t_end, const double *tl);
void lm_dense_at(double s, const lm_dense *dn, double *y); /* dense_into */
/* ev_dense_stages: the 3 more stages into K, the coefficients into F (LM_DENSE_F, N) */
void lm_dense_stages(lm_ctx *cx, double t, const double *y, const double *ynew, double h,
                     const double *p, const lm_act *act, double *K, double *F);

/* project.c (_kernels/project.py) */
void lm_project(lm_ctx *cx, double t, double *y, const double *p, const lm_act *act,
                const double *offset); /* ev_project: rows and hrows from act */
void lm_batch_project(lm_ctx *cx, double t, double *y, const double *p);
void lm_consistent(lm_ctx *cx, double *q, double *v, const double *p, const uint8_t *hold_q,
                   const uint8_t *hold_v, const double *value_q, const double *value_v,
                   const int64_t *kinds, double tol);

/* ------------------------------------------------------------------------------------
 * Entry points, called from Python (ctypes releases the GIL for the call). Each makes
 * its own context and returns LM_ST_MEMORY (or -LM_ST_MEMORY where noted) when memory
 * ran out. Shapes are checked by the Python side (lamech/numeric/_cengine.py).
 */
int64_t lm_abi_version(void);

/* loop.ev_segment: returns the status; t, nev and steps through the pointers */
int64_t lm_ev_segment(const lm_system *sy, const lm_tables *tab, double *p, lm_mode *md,
                      const double *tl, const int64_t *lim, lm_log *lg, int64_t nev,
                      lm_samples *smp, double *y, int64_t *io, double *fo, double *t_out,
                      int64_t *nev_out, int64_t *steps_out);

/* loop.ev_run over B runs: Y0 (B, N), P (B, np), kinds (3, m), IM (B, 4, m), FM (B, 5, m),
 * hold (2, n), value (2, n), tl, lim, want (2, nwant); the logs EK, EJ (B, cap), ET (B,
 * cap), EY (B, cap, N), EX (B, cap, 4); the results YOUT (B, N), TOUT, STATUS, NEV, STEPS
 * (B). Returns 0, or LM_ST_MEMORY. */
int64_t lm_ev_run(const lm_system *sy, const lm_tables *tab, int64_t B, double *Y0, double *P,
                  const int64_t *kinds, int64_t *IM, double *FM, const uint8_t *hold,
                  const double *value, const double *tl, const int64_t *lim,
                  const int64_t *want, int64_t nwant, int64_t cap, int64_t *EK, int64_t *EJ,
                  double *ET, double *EY, double *EX, double *YOUT, double *TOUT,
                  int64_t *STATUS, int64_t *NEV, int64_t *STEPS);

/* project.ev_starts: Q, V (B, n), P (B, np), in place. Returns 0 or LM_ST_MEMORY. */
int64_t lm_ev_starts(const lm_system *sy, int64_t B, double *Q, double *V, const double *P,
                     const uint8_t *hold_q, const uint8_t *hold_v, const double *value_q,
                     const double *value_v, const int64_t *kinds, double tol);

/* batch.batch_run: Y0 (B, N), P (B, np), tl, lim; out (B, N), steps (B). 0 or MEMORY. */
int64_t lm_batch_run(const lm_system *sy, const lm_tables *tab, int64_t B, const double *Y0,
                     const double *P, const double *tl, const int64_t *lim, double *out,
                     int64_t *steps);

/* kkt.rhs_kernel: y (N), the active set given as arrays; out (N). 0 or MEMORY. */
int64_t lm_rhs_kernel(const lm_system *sy, double t, const double *y, const double *p,
                      const int64_t *rows, int64_t na, const int64_t *slip_j,
                      const int64_t *slip_k, const double *slip_c, int64_t ns, double *out);
/* kkt.accelerations: out (n + m). 0 or MEMORY. */
int64_t lm_accelerations_entry(const lm_system *sy, double t, const double *y, const double *p,
                               double *out);
/* kkt.kkt_solve: M (n, n), rhs (n), A (m, n), gam, mu (m), the active set; out (n + na). */
int64_t lm_kkt_solve_entry(const lm_system *sy, const double *M, const double *rhs,
                           const double *A, const double *gam, const double *mu,
                           const int64_t *rows, int64_t na, const int64_t *slip_j,
                           const int64_t *slip_k, const double *slip_c, int64_t ns,
                           double *out);

/* ------------------------------------------------------------------------------------
 * rules.c: the mode's rules, for the roads that step outside the loop (SciPy's
 * integrators). Those calling the system's functions return 0 or LM_ST_MEMORY, their
 * results in res (the kernel's integers, in its order) or out.
 */
int64_t lm_rule_start(const lm_system *sy, double t, double *y, const double *p, lm_mode *md,
                      const double *tl, lm_log *lg, int64_t nev, int64_t *res);
int64_t lm_rule_settle(const lm_system *sy, double t, double *y, const double *p, lm_mode *md,
                       const double *tl, lm_log *lg, int64_t nev, int64_t *res);
int64_t lm_rule_apply(const lm_system *sy, double t, double *y, double *p, int64_t kind,
                      int64_t j, const int64_t *rows, int64_t na, const int64_t *hrows,
                      int64_t nh, const int64_t *slip_j, const int64_t *slip_k,
                      const double *slip_c, int64_t ns, lm_mode *md, const double *tl,
                      const int64_t *lim, lm_log *lg, int64_t nev, int64_t *res);
int64_t lm_rule_switch(const lm_system *sy, double t, double *y, double *p, int64_t k,
                       lm_mode *md, const double *tl, lm_log *lg, int64_t nev, int64_t *res);
int64_t lm_rule_values(const lm_system *sy, double t, const double *y, const double *p,
                       const int64_t *wk, const int64_t *wj, int64_t nw, const lm_mode *md,
                       const int64_t *rows, int64_t na, const int64_t *hrows, int64_t nh,
                       const int64_t *slip_j, const int64_t *slip_k, const double *slip_c,
                       int64_t ns, const double *tl, double *out);
int64_t lm_rule_arm(const lm_system *sy, double t, const double *y, const double *p,
                    const int64_t *wk, const int64_t *wj, int64_t nw, lm_mode *md,
                    const double *tl, int64_t *res);
int64_t lm_rule_project(const lm_system *sy, double t, double *y, const double *p,
                        const int64_t *rows, int64_t na, const int64_t *hrows, int64_t nh,
                        const double *offset);
int64_t lm_rule_accumulated(const lm_system *sy, double t, const double *y, const double *p,
                            lm_mode *md, lm_log *lg, int64_t nev, int64_t *res);
int64_t lm_rule_dips(const lm_system *sy, double t, double t_new, const double *YS, int64_t S,
                     const double *p, const int64_t *wk, const int64_t *wj, int64_t nw,
                     const lm_mode *md, const int64_t *rows, int64_t na, const int64_t *hrows,
                     int64_t nh, const int64_t *slip_j, const int64_t *slip_k,
                     const double *slip_c, int64_t ns, const double *tl, const double *g_a,
                     const double *g_b, double *upper, int64_t *res);
int64_t lm_rule_lock(const lm_system *sy, double t, const double *y, double *p);
int64_t lm_rule_crossed(const lm_system *sy, double t, const double *y, const double *p,
                        int64_t *out, int64_t *res);
void lm_rule_mode(const lm_mode *md, int64_t *rows, int64_t *hrows, int64_t *slip_j,
                  int64_t *slip_k, double *slip_c, int64_t *counts);
int64_t lm_rule_watch(const lm_mode *md, int64_t *wk, int64_t *wj);
void lm_rule_functions(const int64_t *wk, const int64_t *wj, int64_t nw, const lm_mode *md,
                       const double *tl, const double *y, int64_t n, const double *lam,
                       const double *mu, const double *f, const double *A, const double *b,
                       double *out);
double lm_rule_bound(double t_end, const lm_mode *md);
double lm_rule_depth(const double *tl, const double *q, int64_t n);
double lm_rule_dip_time(double t, double t_new, int64_t c, int64_t samples);
int64_t lm_rule_again(int64_t kind, int64_t j, double r, double xb, const lm_mode *md);

#endif
