/* The kernels' small array operations: the C twins of _kernels/arrays.py (its products
 * with the constraint matrix, a_bt, at_v, a_v and diagonal_weights, are static in
 * project.c, their one user). */
#include <math.h>

#include "engine.h"

/* arrays.max_abs: the largest |x_i| (NaN where an entry is NaN: kept, as no later entry
 * compares greater); 0 for none */
double lm_max_abs(const double *x, int64_t count)
{
    double m = 0.0;
    for (int64_t i = 0; i < count; i++) {
        double a = fabs(x[i]);
        if (a > m || a != a)
            m = a;
    }
    return m;
}

/* arrays.max_abs_diff: the largest |a_i - b_i| */
double lm_max_abs_diff(const double *a, const double *b, int64_t count)
{
    double m = 0.0;
    for (int64_t i = 0; i < count; i++) {
        double d = fabs(a[i] - b[i]);
        if (d > m || d != d)
            m = d;
    }
    return m;
}

/* arrays.all_finite: whether every entry is finite */
int lm_all_finite(const double *x, int64_t count)
{
    for (int64_t i = 0; i < count; i++)
        if (!isfinite(x[i]))
            return 0;
    return 1;
}

/* arrays.any_nonzero: whether an entry is not 0 (NaN is not 0) */
int lm_any_nonzero(const double *x, int64_t count)
{
    for (int64_t i = 0; i < count; i++)
        if (x[i] != 0.0)
            return 1;
    return 0;
}

/* arrays.rms_scaled: sqrt(mean((x / scale)^2)), the terms summed in order */
double lm_rms_scaled(const double *x, const double *scale, int64_t count)
{
    double s = 0.0;
    for (int64_t i = 0; i < count; i++) {
        double u = x[i] / scale[i];
        s += u * u;
    }
    return sqrt(s / (double)count);
}

/* arrays.rms_diff_scaled: sqrt(mean(((a - b) / scale)^2)) */
double lm_rms_diff_scaled(const double *a, const double *b, const double *scale, int64_t count)
{
    double s = 0.0;
    for (int64_t i = 0; i < count; i++) {
        double u = (a[i] - b[i]) / scale[i];
        s += u * u;
    }
    return sqrt(s / (double)count);
}
