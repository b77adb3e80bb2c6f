/* The engine's scratch memory: one arena per entry point's call (engine.h).
 *
 * The kernels (lamech/numeric/_kernels/) make small arrays freely, as NumPy code does;
 * here they come from blocks allocated once and reused: a step's temporaries are released
 * to a mark at the end of the step, so a run of a million steps touches the same few
 * kilobytes. Written by hand because no library of C's standard one does this and the
 * engine needs nothing else; malloc failing jumps back to the entry point (lm_fail).
 */
#include <stdlib.h>
#include <string.h>

#include "engine.h"

#define LM_ALIGN 16
#define LM_BLOCK_MIN ((size_t)1 << 16)

static size_t header_size(void)
{
    return (sizeof(lm_block) + LM_ALIGN - 1) & ~(size_t)(LM_ALIGN - 1);
}

static unsigned char *block_data(lm_block *b) { return (unsigned char *)b + header_size(); }

static lm_block *new_block(lm_ctx *cx, size_t size)
{
    if (size > ((size_t)-1) / 2)
        longjmp(cx->fail, 1);
    lm_block *b = (lm_block *)malloc(header_size() + size);
    if (b == NULL)
        longjmp(cx->fail, 1);
    b->next = NULL;
    b->size = size;
    b->used = 0;
    return b;
}

void lm_ctx_init(lm_ctx *cx, const lm_system *sy, const lm_tables *tab)
{
    cx->sy = sy;
    cx->tab = tab;
    cx->ar.head = NULL;
    cx->ar.cur = NULL;
}

void lm_ctx_free(lm_ctx *cx)
{
    lm_block *b = cx->ar.head;
    while (b != NULL) {
        lm_block *next = b->next;
        free(b);
        b = next;
    }
    cx->ar.head = NULL;
    cx->ar.cur = NULL;
}

void *lm_alloc(lm_ctx *cx, size_t bytes)
{
    size_t need = (bytes + LM_ALIGN - 1) & ~(size_t)(LM_ALIGN - 1);
    if (need < bytes)
        longjmp(cx->fail, 1);
    if (need == 0)
        need = LM_ALIGN;
    lm_block *b = cx->ar.cur;
    if (b == NULL) {
        size_t size = need > LM_BLOCK_MIN ? need : LM_BLOCK_MIN;
        b = cx->ar.head = cx->ar.cur = new_block(cx, size);
    }
    /* this block, or the next ones kept from before a release, or a new one */
    while (b->size - b->used < need) {
        if (b->next == NULL) {
            size_t size = 2 * b->size;
            if (size < need)
                size = need;
            b->next = new_block(cx, size);
        }
        b = b->next;
        b->used = 0;
        cx->ar.cur = b;
    }
    void *out = block_data(b) + b->used;
    b->used += need;
    return out;
}

double *lm_doubles(lm_ctx *cx, int64_t count)
{
    if (count < 0)
        longjmp(cx->fail, 1);
    return (double *)lm_alloc(cx, (size_t)count * sizeof(double));
}

double *lm_zeros(lm_ctx *cx, int64_t count)
{
    double *x = lm_doubles(cx, count);
    for (int64_t i = 0; i < count; i++)
        x[i] = 0.0;
    return x;
}

int64_t *lm_ints(lm_ctx *cx, int64_t count)
{
    if (count < 0)
        longjmp(cx->fail, 1);
    return (int64_t *)lm_alloc(cx, (size_t)count * sizeof(int64_t));
}

uint8_t *lm_bools(lm_ctx *cx, int64_t count)
{
    if (count < 0)
        longjmp(cx->fail, 1);
    uint8_t *x = (uint8_t *)lm_alloc(cx, (size_t)count);
    memset(x, 0, (size_t)count);
    return x;
}

double *lm_copy(lm_ctx *cx, const double *x, int64_t count)
{
    double *out = lm_doubles(cx, count);
    for (int64_t i = 0; i < count; i++)
        out[i] = x[i];
    return out;
}

lm_mark lm_mark_now(lm_ctx *cx)
{
    lm_mark mark;
    mark.blk = cx->ar.cur;
    mark.used = cx->ar.cur == NULL ? 0 : cx->ar.cur->used;
    return mark;
}

void lm_release(lm_ctx *cx, lm_mark mark)
{
    if (mark.blk == NULL) {
        /* nothing was allocated at the mark: everything is free again, blocks kept */
        if (cx->ar.head != NULL) {
            cx->ar.cur = cx->ar.head;
            cx->ar.head->used = 0;
        }
        return;
    }
    cx->ar.cur = mark.blk;
    mark.blk->used = mark.used;
}

lm_act lm_act_new(lm_ctx *cx, int64_t m)
{
    lm_act act;
    int64_t cap = m > 0 ? m : 1;
    act.na = act.nh = act.ns = 0;
    act.rows = lm_ints(cx, cap);
    act.hrows = lm_ints(cx, cap);
    act.slip_j = lm_ints(cx, cap);
    act.slip_k = lm_ints(cx, cap);
    act.slip_c = lm_doubles(cx, cap);
    return act;
}

lm_act lm_act_all(lm_ctx *cx, int64_t m)
{
    lm_act act = lm_act_new(cx, m);
    for (int64_t j = 0; j < m; j++)
        act.rows[j] = j;
    act.na = m;
    return act;
}

int64_t lm_abi_version(void) { return 2; }
