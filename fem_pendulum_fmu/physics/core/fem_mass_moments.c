/* The quadratic forms of the mass that the outputs read at every step (fem/mass_moments.py).
 *
 * A two-component field's mass is diag(S, S) with S the scalar mass (the x components' dofs first, then the
 * y components'), and the cross form a.C b = int rho h (a_y b_x - a_x b_y) is a_y.S b_x - a_x.S b_y. Three
 * products with the assembled 2n x 2n matrices read S six times; this reads it once. The sums run in a fixed
 * order.
 */

#include "femp_core.h"

/* out[0] = a.M a; with b (else NULL): out[1] = b.M b and out[2] = a.C b. a and b hold 2n entries. */
void femp_mass_moments(int n, const int *indptr, const int *indices, const double *data, const double *a,
                       const double *b, double *out) {
    const double *ay = a + n;
    double aa = 0.0, bb = 0.0, ab = 0.0;
    if (b == 0) {
        for (int r = 0; r < n; ++r) {
            double sx = 0.0, sy = 0.0;
            for (int k = indptr[r]; k < indptr[r + 1]; ++k) {
                sx += data[k] * a[indices[k]];
                sy += data[k] * ay[indices[k]];
            }
            aa += a[r] * sx + ay[r] * sy;
        }
        out[0] = aa;
        return;
    }
    const double *by = b + n;
    for (int r = 0; r < n; ++r) {
        double sax = 0.0, say = 0.0, sbx = 0.0, sby = 0.0;
        for (int k = indptr[r]; k < indptr[r + 1]; ++k) {
            double s = data[k];
            int c = indices[k];
            sax += s * a[c];
            say += s * ay[c];
            sbx += s * b[c];
            sby += s * by[c];
        }
        aa += a[r] * sax + ay[r] * say;
        bb += b[r] * sbx + by[r] * sby;
        ab += ay[r] * sbx - a[r] * sby;
    }
    out[0] = aa;
    out[1] = bb;
    out[2] = ab;
}
