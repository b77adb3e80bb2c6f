/* The rules of the contact and friction mode as entry points of their own, for the roads
 * that step outside the loop with events (SciPy's integrators: lamech/numeric/_run.py,
 * _detect.py, _initial.py): the start's mode, the settling, an event applied, an input
 * switch, the watched events and their functions, arming, the projection, the Zeno
 * accumulation, the force dips, the switches' locks. Each wraps the loop's own function
 * (modes.c, impacts.c, loop.c, project.c): one implementation of every rule, whichever
 * road runs it.
 *
 * Each entry point that calls the system's functions makes its own context and returns
 * 0, or LM_ST_MEMORY when memory ran out; its results come back through the pointers
 * (res: the integers a kernel returned, in the kernel's order). The active set arrives
 * as arrays (rows, na, hrows, nh, slip_j, slip_k, slip_c, ns), the watched events as
 * (wk, wj, nw). Shapes and indices are checked by lamech/numeric/_cengine.py.
 */
#include "events.h"

/* an active set over the caller's arrays (read only: the casts drop const for the record) */
static lm_act act_of(const int64_t *rows, int64_t na, const int64_t *hrows, int64_t nh,
                     const int64_t *slip_j, const int64_t *slip_k, const double *slip_c,
                     int64_t ns)
{
    lm_act act;
    act.na = na;
    act.nh = nh;
    act.ns = ns;
    act.rows = (int64_t *)rows;
    act.hrows = (int64_t *)hrows;
    act.slip_j = (int64_t *)slip_j;
    act.slip_k = (int64_t *)slip_k;
    act.slip_c = (double *)slip_c;
    return act;
}

static lm_watch watch_of(const int64_t *wk, const int64_t *wj, int64_t nw)
{
    lm_watch w;
    w.nw = nw;
    w.wk = (int64_t *)wk;
    w.wj = (int64_t *)wj;
    return w;
}

#define ENTER(CX, SY)                                                                         \
    lm_ctx CX;                                                                                \
    lm_ctx_init(&CX, (SY), NULL);                                                             \
    if (setjmp(CX.fail)) {                                                                    \
        lm_ctx_free(&CX);                                                                     \
        return LM_ST_MEMORY;                                                                  \
    }

/* modes.ev_start: res = (count, status) */
int64_t lm_rule_start(const lm_system *sy, double t, double *y, const double *p, lm_mode *md,
                      const double *tl, lm_log *lg, int64_t nev, int64_t *res)
{
    ENTER(cx, sy)
    int64_t st = ev_start(&cx, t, y, p, md, tl, lg, &nev);
    res[0] = nev;
    res[1] = st;
    lm_ctx_free(&cx);
    return 0;
}

/* modes.ev_settle: res = (count, status) */
int64_t lm_rule_settle(const lm_system *sy, double t, double *y, const double *p, lm_mode *md,
                       const double *tl, lm_log *lg, int64_t nev, int64_t *res)
{
    ENTER(cx, sy)
    int64_t st = ev_settle(&cx, t, y, p, md, tl, lg, &nev);
    res[0] = nev;
    res[1] = st;
    lm_ctx_free(&cx);
    return 0;
}

/* loop.ev_apply: res = (status, count, settled) */
int64_t lm_rule_apply(const lm_system *sy, double t, double *y, double *p, int64_t kind,
                      int64_t j, const int64_t *rows, int64_t na, const int64_t *hrows,
                      int64_t nh, const int64_t *slip_j, const int64_t *slip_k,
                      const double *slip_c, int64_t ns, lm_mode *md, const double *tl,
                      const int64_t *lim, lm_log *lg, int64_t nev, int64_t *res)
{
    ENTER(cx, sy)
    lm_act act = act_of(rows, na, hrows, nh, slip_j, slip_k, slip_c, ns);
    int settled = 0;
    int64_t st = ev_apply(&cx, t, y, p, kind, j, &act, md, tl, lim, lg, &nev, &settled);
    res[0] = st;
    res[1] = nev;
    res[2] = settled;
    lm_ctx_free(&cx);
    return 0;
}

/* loop.ev_switch: res = (status, count, settled) */
int64_t lm_rule_switch(const lm_system *sy, double t, double *y, double *p, int64_t k,
                       lm_mode *md, const double *tl, lm_log *lg, int64_t nev, int64_t *res)
{
    ENTER(cx, sy)
    int settled = 0;
    int64_t st = ev_switch(&cx, t, y, p, k, md, tl, lg, &nev, &settled);
    res[0] = st;
    res[1] = nev;
    res[2] = settled;
    lm_ctx_free(&cx);
    return 0;
}

/* modes.ev_values: out (nw) */
int64_t lm_rule_values(const lm_system *sy, double t, const double *y, const double *p,
                       const int64_t *wk, const int64_t *wj, int64_t nw, const lm_mode *md,
                       const int64_t *rows, int64_t na, const int64_t *hrows, int64_t nh,
                       const int64_t *slip_j, const int64_t *slip_k, const double *slip_c,
                       int64_t ns, const double *tl, double *out)
{
    ENTER(cx, sy)
    lm_act act = act_of(rows, na, hrows, nh, slip_j, slip_k, slip_c, ns);
    lm_watch w = watch_of(wk, wj, nw);
    if (nw > 0)
        ev_values(&cx, t, y, p, &w, md, &act, tl, out);
    lm_ctx_free(&cx);
    return 0;
}

/* loop.ev_arm: res = (whether any was armed) */
int64_t lm_rule_arm(const lm_system *sy, double t, const double *y, const double *p,
                    const int64_t *wk, const int64_t *wj, int64_t nw, lm_mode *md,
                    const double *tl, int64_t *res)
{
    ENTER(cx, sy)
    lm_watch w = watch_of(wk, wj, nw);
    res[0] = ev_arm(&cx, t, y, p, &w, md, tl);
    lm_ctx_free(&cx);
    return 0;
}

/* project.ev_project: y onto the rows (positions onto the hrows' offsets), in place */
int64_t lm_rule_project(const lm_system *sy, double t, double *y, const double *p,
                        const int64_t *rows, int64_t na, const int64_t *hrows, int64_t nh,
                        const double *offset)
{
    ENTER(cx, sy)
    lm_act act = act_of(rows, na, hrows, nh, NULL, NULL, NULL, 0);
    lm_project(&cx, t, y, p, &act, offset);
    lm_ctx_free(&cx);
    return 0;
}

/* impacts.ev_accumulated: res = (the new count, or -1); reads md's fmode only */
int64_t lm_rule_accumulated(const lm_system *sy, double t, const double *y, const double *p,
                            lm_mode *md, lm_log *lg, int64_t nev, int64_t *res)
{
    ENTER(cx, sy)
    res[0] = ev_accumulated(&cx, t, y, p, md, lg, nev);
    lm_ctx_free(&cx);
    return 0;
}

/* loop.ev_dips: upper changed in place; res = (whether any dip was found) */
int64_t lm_rule_dips(const lm_system *sy, double t, double t_new, const double *YS, int64_t S,
                     const double *p, const int64_t *wk, const int64_t *wj, int64_t nw,
                     const lm_mode *md, const int64_t *rows, int64_t na, const int64_t *hrows,
                     int64_t nh, const int64_t *slip_j, const int64_t *slip_k,
                     const double *slip_c, int64_t ns, const double *tl, const double *g_a,
                     const double *g_b, double *upper, int64_t *res)
{
    ENTER(cx, sy)
    lm_act act = act_of(rows, na, hrows, nh, slip_j, slip_k, slip_c, ns);
    lm_watch w = watch_of(wk, wj, nw);
    res[0] = ev_dips(&cx, t, t_new, YS, S, p, &w, md, &act, tl, g_a, g_b, upper);
    lm_ctx_free(&cx);
    return 0;
}

/* modes.ev_lock: every switch's slot in p held on its branch at (t, y) */
int64_t lm_rule_lock(const lm_system *sy, double t, const double *y, double *p)
{
    ENTER(cx, sy)
    ev_lock(&cx, t, y, p);
    lm_ctx_free(&cx);
    return 0;
}

/* modes.ev_crossed: out (nslots); res = (its count) */
int64_t lm_rule_crossed(const lm_system *sy, double t, const double *y, const double *p,
                        int64_t *out, int64_t *res)
{
    ENTER(cx, sy)
    res[0] = ev_crossed(&cx, t, y, p, out);
    lm_ctx_free(&cx);
    return 0;
}

/* ----- the rules that call none of the system's functions ------------------------------ */

/* modes.ev_mode: the active set into the arrays (capacity m each; imode changed in place);
 * counts = (na, nh, ns) */
void lm_rule_mode(const lm_mode *md, int64_t *rows, int64_t *hrows, int64_t *slip_j,
                  int64_t *slip_k, double *slip_c, int64_t *counts)
{
    lm_act act = act_of(rows, 0, hrows, 0, slip_j, slip_k, slip_c, 0);
    ev_mode(md, &act);
    counts[0] = act.na;
    counts[1] = act.nh;
    counts[2] = act.ns;
}

/* modes.ev_watch: wk, wj (capacity 2m); returns their count */
int64_t lm_rule_watch(const lm_mode *md, int64_t *wk, int64_t *wj)
{
    lm_watch w = watch_of(wk, wj, 0);
    ev_watch(md, &w);
    return w.nw;
}

/* modes.ev_functions: out (nw) from lam, mu (m) and f, A, b at y (N = 2n) */
void lm_rule_functions(const int64_t *wk, const int64_t *wj, int64_t nw, const lm_mode *md,
                       const double *tl, const double *y, int64_t n, const double *lam,
                       const double *mu, const double *f, const double *A, const double *b,
                       double *out)
{
    lm_watch w = watch_of(wk, wj, nw);
    ev_functions(&w, md, tl, y, n, lam, mu, f, A, b, out);
}

/* impacts.ev_bound */
double lm_rule_bound(double t_end, const lm_mode *md) { return ev_bound(t_end, md); }

/* modes.ev_depth */
double lm_rule_depth(const double *tl, const double *q, int64_t n) { return ev_depth(tl, q, n); }

/* loop.dip_time */
double lm_rule_dip_time(double t, double t_new, int64_t c, int64_t samples)
{
    return dip_time(t, t_new, c, samples);
}

/* modes.ev_again */
int64_t lm_rule_again(int64_t kind, int64_t j, double r, double xb, const lm_mode *md)
{
    return ev_again(kind, j, r, xb, md);
}
