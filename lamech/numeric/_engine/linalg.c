/* Dense linear algebra of the KKT system: the C twins of lamech/linalg.py's loops. */
#include <math.h>

#include "engine.h"

/* linalg.cholesky_inplace: K y = x for a symmetric positive definite K, x becomes y and
 * K's lower triangle L (K = L L^T), each row of L from the first nonzero of K's (its
 * envelope: a banded K costs O(N) band rows). 0, x undefined, where K is not positive
 * definite to working precision; else 1. */
int lm_cholesky(lm_ctx *cx, double *K, double *x, int64_t N)
{
    lm_mark mark = lm_mark_now(cx);
    int64_t *first = lm_ints(cx, N);
    for (int64_t i = 0; i < N; i++) {
        int64_t f = 0;
        while (f < i && K[i * N + f] == 0.0)
            f++;
        first[i] = f;
        for (int64_t j = f; j < i; j++) {
            double acc = K[i * N + j];
            int64_t k0 = f > first[j] ? f : first[j];
            for (int64_t k = k0; k < j; k++)
                acc -= K[i * N + k] * K[j * N + k];
            K[i * N + j] = acc / K[j * N + j];
        }
        double acc = K[i * N + i];
        for (int64_t k = f; k < i; k++)
            acc -= K[i * N + k] * K[i * N + k];
        if (!(acc > 0.0)) {
            lm_release(cx, mark);
            return 0;
        }
        K[i * N + i] = sqrt(acc);
    }
    for (int64_t i = 0; i < N; i++) { /* L y = x */
        double acc = x[i];
        for (int64_t k = first[i]; k < i; k++)
            acc -= K[i * N + k] * x[k];
        x[i] = acc / K[i * N + i];
    }
    for (int64_t i = N - 1; i >= 0; i--) { /* L^T z = y */
        x[i] /= K[i * N + i];
        for (int64_t k = first[i]; k < i; k++)
            x[k] -= K[i * N + k] * x[i];
    }
    lm_release(cx, mark);
    return 1;
}

/* linalg.gauss_inplace: K y = x by elimination with partial pivoting, x becomes y (NaN
 * where K is singular), K destroyed; row operations stop at the pivot row's last
 * nonzero (a banded K costs O(N) rows of its band). */
void lm_gauss(double *K, double *x, int64_t N)
{
    for (int64_t c = 0; c < N; c++) {
        int64_t piv = c;
        double big = fabs(K[c * N + c]);
        for (int64_t i = c + 1; i < N; i++) {
            if (fabs(K[i * N + c]) > big) {
                big = fabs(K[i * N + c]);
                piv = i;
            }
        }
        if (big == 0.0) {
            for (int64_t i = 0; i < N; i++)
                x[i] = NAN;
            return;
        }
        if (piv != c) {
            for (int64_t k = 0; k < N; k++) {
                double tmp = K[c * N + k];
                K[c * N + k] = K[piv * N + k];
                K[piv * N + k] = tmp;
            }
            double tmp = x[c];
            x[c] = x[piv];
            x[piv] = tmp;
        }
        int64_t last = N - 1; /* the pivot row's last nonzero */
        while (K[c * N + last] == 0.0)
            last--;
        double inv = 1.0 / K[c * N + c];
        for (int64_t i = c + 1; i < N; i++) {
            if (K[i * N + c] != 0.0) {
                double f = K[i * N + c] * inv;
                for (int64_t k = c; k <= last; k++)
                    K[i * N + k] -= f * K[c * N + k];
                x[i] -= f * x[c];
            }
        }
    }
    for (int64_t i = N - 1; i >= 0; i--) {
        double s = x[i];
        for (int64_t k = i + 1; k < N; k++)
            s -= K[i * N + k] * x[k];
        x[i] = s / K[i * N + i];
    }
}
