/* The start iterate's misses and their recurrence (fem/start_iterate.py).
 *
 * At the steel scene's 302 unknowns a step's iteration costs about 35 us; numpy spent more than that on the
 * inner products, the normal equations and their solve in per-call overhead. femp_misses_record makes a
 * step's record and the next prediction in one call. The sums run in a fixed order.
 */
#include <math.h>

#include "femp_core.h"

#define MAX_DEPTH 16

/* A block of k misses: e (k x n, newest first), their inner products g (k x k), then the next miss predicted
 * (n). femp_misses_predict sets it to sum_j c_j e[j] (j < depth) with the c of the least-squares fit of each
 * of the window newest rows of e by the depth rows after it, from g (k >= window + depth): the normal
 * equations with a ridge of ridge times their largest diagonal entry, by Cholesky. Returns 1, or 0 (the
 * prediction left as it was) where the fit leaves more than fit_left of the window's squared size, or
 * cannot be made. */
int femp_misses_predict(int n, int k, double *block, int depth, int window, double ridge, double fit_left) {
    const double *e = block, *g = block + (long)k * n;
    double *out = block + (long)k * n + (long)k * k;
    double a[MAX_DEPTH][MAX_DEPTH], b[MAX_DEPTH], c[MAX_DEPTH], total = 0.0, largest = 0.0;
    if (depth > MAX_DEPTH || k < window + depth) return 0;
    for (int i = 0; i < depth; ++i) {
        b[i] = 0.0;
        for (int j = 0; j < depth; ++j) a[i][j] = 0.0;
    }
    for (int m = 0; m < window; ++m) {
        total += g[m * k + m];
        for (int i = 0; i < depth; ++i) {
            b[i] += g[(m + 1 + i) * k + m];
            for (int j = 0; j < depth; ++j) a[i][j] += g[(m + 1 + i) * k + (m + 1 + j)];
        }
    }
    for (int i = 0; i < depth; ++i)
        if (a[i][i] > largest) largest = a[i][i];
    if (!(largest > 0.0)) return 0;
    double l[MAX_DEPTH][MAX_DEPTH];
    for (int j = 0; j < depth; ++j) { /* a + ridge largest I = l l^T */
        double d = a[j][j] + ridge * largest;
        for (int p = 0; p < j; ++p) d -= l[j][p] * l[j][p];
        if (!(d > 0.0)) return 0;
        l[j][j] = sqrt(d);
        for (int i = j + 1; i < depth; ++i) {
            double s = a[i][j];
            for (int p = 0; p < j; ++p) s -= l[i][p] * l[j][p];
            l[i][j] = s / l[j][j];
        }
    }
    for (int i = 0; i < depth; ++i) { /* l y = b, then l^T c = y */
        double s = b[i];
        for (int p = 0; p < i; ++p) s -= l[i][p] * c[p];
        c[i] = s / l[i][i];
    }
    for (int i = depth - 1; i >= 0; --i) {
        double s = c[i];
        for (int p = i + 1; p < depth; ++p) s -= l[p][i] * c[p];
        c[i] = s / l[i][i];
    }
    double left = total; /* sum over the window of |e_m - sum_j c_j e_{m+1+j}|^2 */
    for (int i = 0; i < depth; ++i) {
        double ac = 0.0;
        for (int j = 0; j < depth; ++j) ac += a[i][j] * c[j];
        left += c[i] * (ac - 2.0 * b[i]);
    }
    if (!(left <= fit_left * total)) return 0;
    for (int i = 0; i < n; ++i) {
        double s = 0.0;
        for (int j = 0; j < depth; ++j) s += c[j] * e[j * n + i];
        out[i] = s;
    }
    return 1;
}

/* new_block (k_new misses) from its first row, the new miss, as written by the caller, and old_block (k_old
 * misses): the rows after the first are the old block's first k_new - 1, their inner products the old ones;
 * then the next miss predicted (femp_misses_predict, whose result this returns) */
int femp_misses_record(int n, int k_old, const double *old_block, int k_new, double *new_block, int depth, int window,
                       double ridge, double fit_left) {
    const double *old_g = old_block + (long)k_old * n, *miss = new_block;
    double *new_g = new_block + (long)k_new * n;
    for (int r = 1; r < k_new; ++r)
        for (int i = 0; i < n; ++i) new_block[(long)r * n + i] = old_block[(long)(r - 1) * n + i];
    for (int r = 0; r < k_new; ++r) {
        const double *e = new_block + (long)r * n;
        double s[4] = {0.0, 0.0, 0.0, 0.0}; /* four running sums: the loop is not bound by one sum's latency */
        int i = 0;
        for (; i + 4 <= n; i += 4)
            for (int j = 0; j < 4; ++j) s[j] += miss[i + j] * e[i + j];
        for (; i < n; ++i) s[0] += miss[i] * e[i];
        double sum = (s[0] + s[1]) + (s[2] + s[3]);
        new_g[r] = sum;
        new_g[r * k_new] = sum;
    }
    for (int r = 1; r < k_new; ++r)
        for (int c = 1; c < k_new; ++c) new_g[r * k_new + c] = old_g[(r - 1) * k_old + (c - 1)];
    return k_new >= depth + window ? femp_misses_predict(n, k_new, new_block, depth, window, ridge, fit_left) : 0;
}
