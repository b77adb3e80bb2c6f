/* The event layer's shared functions (modes.c, impacts.c, loop.c): internal to the
 * engine, twins of lamech/numeric/_kernels/modes.py, impacts.py and loop.py.
 *
 * Conventions beyond engine.h's: a kernel that returns (count, status) returns the status
 * and keeps the count in *nev; a kernel that returns arrays fills the caller's (the
 * sizes noted); each function releases the scratch it took before returning, unless it
 * says otherwise.
 */
#ifndef LAMECH_EVENTS_H
#define LAMECH_EVENTS_H

#include "engine.h"

/* Python's max(a, b) and min(a, b) on floats: the first unless the second compares
 * greater (smaller), so a NaN first is kept and a NaN second is dropped. */
static inline double lm_pymax(double a, double b) { return b > a ? b : a; }
static inline double lm_pymin(double a, double b) { return b < a ? b : a; }

/* modes.c */
int ev_active(int64_t j, const lm_mode *md);
void ev_mode(const lm_mode *md, lm_act *act); /* act of capacity m */
void ev_watch(const lm_mode *md, lm_watch *w); /* w of capacity 2m */
/* qdd (n), lam (m), mu (m) */
void ev_lam(lm_ctx *cx, double t, const double *y, const double *p, const lm_act *act,
            double *qdd, double *lam, double *mu);
/* out (w->nw) */
void ev_values(lm_ctx *cx, double t, const double *y, const double *p, const lm_watch *w,
               const lm_mode *md, const lm_act *act, const double *tl, double *out);
void ev_functions(const lm_watch *w, const lm_mode *md, const double *tl, const double *y,
                  int64_t n, const double *lam, const double *mu, const double *f,
                  const double *A, const double *b, double *out);
double ev_depth(const double *tl, const double *q, int64_t n);
void ev_lock(lm_ctx *cx, double t, const double *y, double *p);
/* out (nslots); returns the count */
int64_t ev_crossed(lm_ctx *cx, double t, const double *y, const double *p, int64_t *out);
double ev_g(lm_ctx *cx, int64_t i, double x, const lm_dense *dn, const double *p,
            const lm_watch *w, const lm_mode *md, const lm_act *act, const double *tl);
double ev_switch_time(lm_ctx *cx, double t, double t_new, const lm_dense *dn, const double *p,
                      const lm_watch *w, const lm_mode *md, const lm_act *act,
                      const double *tl, const int64_t *crossed, int64_t nc, int64_t *ks);
double ev_brent(lm_ctx *cx, int64_t i, double xa, double xb, const lm_dense *dn,
                const double *p, const lm_watch *w, const lm_mode *md, const lm_act *act,
                const double *tl);
int ev_again(int64_t kind, int64_t j, double r, double xb, const lm_mode *md);
int64_t ev_log(lm_log *lg, int64_t kind, int64_t j, double t, const double *y, int64_t code,
               double value, int64_t nev);
int64_t ev_start(lm_ctx *cx, double t, double *y, const double *p, lm_mode *md,
                 const double *tl, lm_log *lg, int64_t *nev);
int64_t ev_settle(lm_ctx *cx, double t, double *y, const double *p, lm_mode *md,
                  const double *tl, lm_log *lg, int64_t *nev);
int ev_all(const lm_log *lg, int to_end);

/* impacts.c */
/* vp (n), imp (m) */
void ev_impulses(lm_ctx *cx, const double *M, const double *A, const double *b,
                 const double *v, const double *mu, const lm_act *act, int64_t j,
                 double target, const int64_t *extra, int64_t nextra, const int64_t *sj2,
                 const double *sc2, int64_t ns2, double *vp, double *imp);
int64_t ev_impact(lm_ctx *cx, double t, double *y, const double *p, int64_t j, lm_mode *md,
                  const double *tl, lm_log *lg, int64_t *nev);
double ev_bound(double t_end, const lm_mode *md);
int64_t ev_accumulated(lm_ctx *cx, double t, const double *y, const double *p, lm_mode *md,
                       lm_log *lg, int64_t nev);

/* loop.c */
void ev_run(lm_ctx *cx, int64_t B, double *Y0, double *P, const int64_t *kinds, int64_t *IM,
            double *FM, const uint8_t *hold, const double *value, const double *tl,
            const int64_t *lim, const int64_t *want, int64_t nwant, int64_t cap, int64_t *EK,
            int64_t *EJ, double *ET, double *EY, double *EX, double *YOUT, double *TOUT,
            int64_t *STATUS, int64_t *NEV, int64_t *STEPS);
int64_t ev_run_one(lm_ctx *cx, const double *y0, double *p, lm_mode *md, const double *tl,
                   const int64_t *lim, lm_log *lg, double *y_out, double *t_out,
                   int64_t *nev_out, int64_t *steps_out);
/* the rules SciPy's road applies too (rules.c's entry points) */
int ev_arm(lm_ctx *cx, double t, const double *y, const double *p, const lm_watch *w,
           lm_mode *md, const double *tl);
double dip_time(double t, double t_new, int64_t c, int64_t samples);
int ev_dips(lm_ctx *cx, double t, double t_new, const double *YS, int64_t S, const double *p,
            const lm_watch *w, const lm_mode *md, const lm_act *act, const double *tl,
            const double *g_a, const double *g_b, double *upper);
int64_t ev_apply(lm_ctx *cx, double te, double *ye, double *p, int64_t kind, int64_t j,
                 const lm_act *act, lm_mode *md, const double *tl, const int64_t *lim,
                 lm_log *lg, int64_t *nev, int *settled);
int64_t ev_switch(lm_ctx *cx, double ts, double *ys, double *p, int64_t k, lm_mode *md,
                  const double *tl, lm_log *lg, int64_t *nev, int *settled);
int64_t ev_segment(lm_ctx *cx, double *p, lm_mode *md, const double *tl, const int64_t *lim,
                   lm_log *lg, int64_t nev, lm_samples *smp, double *y, int64_t *io,
                   double *fo, double *t_out, int64_t *nev_out, int64_t *steps_out);

#endif
