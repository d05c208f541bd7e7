/* The rigid wall's contact term of the energy-momentum step residual (fem/rigid_contact.py).
 *
 * The same law as the coefficient functions of fem/contact_law.py, branch for branch: the depth below the
 * nearest face of the block and its normal, the discrete gradient (Phi(d1) - Phi(d0)) / (d1 - d0) of the
 * penalty energy Phi(d) = k/2 max(d, 0)^2 and Gonzalez's correction of the midpoint normal. At each listed
 * head point i the end position is X_i + (E u)_i (E: CSR, 2P rows, x components then y), the force f_i is
 * that law's from p0_i to it, and res gets -w_i f_i . E_i (w_i: the ds weight times the thickness).
 */
#include "femp_core.h"

/* depth below the nearest face of the block (x_min, x_max, y_min, y_max) and that face's inward normal's
 * opposite, in contact_law.depth_and_gradient's order of faces and comparisons */
static double depth(const double *block, double px, double py, double *gx, double *gy) {
    double d = block[1] - px, e;
    *gx = -1.0, *gy = 0.0;
    e = px - block[0];
    if (d - e > 0.0) d = e, *gx = 1.0, *gy = 0.0;
    e = block[3] - py;
    if (d - e > 0.0) d = e, *gx = 0.0, *gy = -1.0;
    e = py - block[2];
    if (d - e > 0.0) d = e, *gx = 0.0, *gy = 1.0;
    return d;
}

static double penalty(double d, double k) { return d > 0.0 ? 0.5 * k * d * d : 0.0; }

/* contact_law.discrete_gradient_force from (x0, y0) to (x1, y1) into f */
static void dg_force(const double *block, double k, double x0, double y0, double x1, double y1, double *f) {
    double gx, gy, mx, my;
    double d0 = depth(block, x0, y0, &gx, &gy), d1 = depth(block, x1, y1, &gx, &gy);
    double dm = depth(block, 0.5 * (x0 + x1), 0.5 * (y0 + y1), &mx, &my);
    double jump = d1 - d0, distinct = jump * jump - 1e-28;
    double slope = distinct > 0.0 ? (penalty(d1, k) - penalty(d0, k)) / jump : (dm > 0.0 ? k * dm : 0.0);
    double dx = x1 - x0, dy = y1 - y0, len2 = dx * dx + dy * dy;
    double c = len2 - 1e-30 > 0.0 ? (jump - (mx * dx + my * dy)) / len2 : 0.0;
    f[0] = -slope * (mx + c * dx);
    f[1] = -slope * (my + c * dy);
}

static double row_dot(const int *indptr, const int *indices, const double *data, int r, const double *u) {
    double sum = 0.0;
    for (int k = indptr[r]; k < indptr[r + 1]; ++k) sum += data[k] * u[indices[k]];
    return sum;
}


/* If points are listed: res = the contact term at the displacement u (the first entries of w) over them, zero
 * elsewhere (size entries), and 1; else res untouched, and 0 */
int femp_rigid_contact(const struct femp_rigid_contact *c, const double *u, int size, double *res) {
    if (c->n == 0) return 0;
    int P = c->P;
    const int *indptr = c->indptr, *indices = c->indices;
    const double *data = c->data;
    for (int i = 0; i < size; ++i) res[i] = 0.0;
    for (int j = 0; j < c->n; ++j) {
        int i = c->points[j];
        double f[2];
        double x1 = c->X[i] + row_dot(indptr, indices, data, i, u);
        double y1 = c->X[P + i] + row_dot(indptr, indices, data, P + i, u);
        dg_force(c->block, c->k, c->p0[i], c->p0[P + i], x1, y1, f);
        for (int comp = 0; comp < 2; ++comp) {
            int r = comp * P + i;
            double a = -c->weights[i] * f[comp];
            for (int q = indptr[r]; q < indptr[r + 1]; ++q) res[indices[q]] += a * data[q];
        }
    }
    return 1;
}

/* out = the resultant of the term's forces from the positions p0 to p1 (each P x 2, interleaved) over all P
 * points: the force of the wall on the body that the step applies (p0 = p1: the penalty force at them) */
void femp_rigid_contact_resultant(const struct femp_rigid_contact *c, const double *p0, const double *p1,
                                  double *out) {
    double fx = 0.0, fy = 0.0;
    for (int i = 0; i < c->P; ++i) {
        double f[2];
        dg_force(c->block, c->k, p0[2 * i], p0[2 * i + 1], p1[2 * i], p1[2 * i + 1], f);
        fx += c->weights[i] * f[0];
        fy += c->weights[i] * f[1];
    }
    out[0] = fx;
    out[1] = fy;
}

/* The term's stiffness at the listed points for the held Jacobian's contact update (fem/contact_update.py):
 * for the j-th listed point, c[j] = w d/dd1 of the discrete gradient (Phi(d1) - Phi(d0)) / (d1 - d0) at the
 * displacement u (the midpoint's k/2 where d1 ~ d0), and (gx[j], gy[j]) the gradient of d1 at its end position,
 * so that the term's Jacobian there is c g g^T in the point's position (Gonzalez's correction and the
 * turning of the normal left out: both vanish while a point stays on one face's side). n: the listed points
 * the arrays hold; 0 (nothing written) if that is not the contact set's count, else 1. */
int femp_rigid_contact_stiffness(const struct femp_rigid_contact *c, const double *u, int n, double *cj, double *gx,
                                 double *gy) {
    int P = c->P;
    if (c->n != n) return 0; /* the arrays are sized for another contact set: nothing written */
    for (int j = 0; j < c->n; ++j) {
        int i = c->points[j];
        double x1 = c->X[i] + row_dot(c->indptr, c->indices, c->data, i, u);
        double y1 = c->X[P + i] + row_dot(c->indptr, c->indices, c->data, P + i, u);
        double ux, uy, mx, my;
        double d0 = depth(c->block, c->p0[i], c->p0[P + i], &ux, &uy);
        double d1 = depth(c->block, x1, y1, &gx[j], &gy[j]);
        double dm = depth(c->block, 0.5 * (c->p0[i] + x1), 0.5 * (c->p0[P + i] + y1), &mx, &my);
        double jump = d1 - d0, k = c->k, s;
        if (jump * jump - 1e-28 > 0.0) {
            double slope1 = d1 > 0.0 ? k * d1 : 0.0;
            s = (slope1 * jump - (penalty(d1, k) - penalty(d0, k))) / (jump * jump);
        } else {
            s = dm > 0.0 ? 0.5 * k : 0.0;
        }
        cj[j] = c->weights[i] * s;
    }
    return 1;
}
