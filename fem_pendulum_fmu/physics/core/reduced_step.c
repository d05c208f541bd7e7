/* The reduced fidelity's step as one compiled call (reduced/kernel.py).
 *
 * The same computation as NewtonStep.step in reduced/step.py, with the
 * strain energy of reduced/strain.py and the wall contact of
 * WallContact.evaluate (reduced/contact.py): the linearised midpoint predictor, Newton on
 * the discrete-gradient equations with the Jacobian of first order in the step,
 * and the energy-balance test. A step is 13 unknowns by default, so numpy's
 * per-call overhead was most of its cost (docs/notes/reduced.md). Plain C, no
 * Python API.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "femp_core.h"

#include "reduced_internal.h"

double femp_r_dot(int k, const double *x, const double *y) {
    double s = 0.0;
    for (int i = 0; i < k; ++i) s += x[i] * y[i];
    return s;
}

/* out_j = sum_i q_i gyro_ij  (c = q @ gyro) */
void femp_r_left_gyro(const Reduced *R, const double *q, double *out) {
    int m = R->m;
    for (int j = 0; j < m; ++j) out[j] = 0.0;
    for (int i = 0; i < m; ++i)
        for (int j = 0; j < m; ++j) out[j] += q[i] * R->gyro[i * m + j];
}

/* out_i = sum_j gyro_ij v_j  (gyro @ v) */
static void right_gyro(const Reduced *R, const double *v, double *out) {
    int m = R->m;
    for (int i = 0; i < m; ++i) out[i] = femp_r_dot(m, R->gyro + i * m, v);
}

/* 2 a.q + q.q, the moment of inertia's growth */
double femp_r_inertia_growth(const Reduced *R, const double *q) {
    double s = 0.0;
    for (int i = 0; i < R->m; ++i) s += (2.0 * R->a[i] + q[i]) * q[i];
    return s;
}

/* ------------------------------------------------------------------ potentials */
static void first_moment(const Reduced *R, const double *q, double S[2]) {
    S[0] = R->first_moment[0] + femp_r_dot(R->m, R->moment_modes, q);
    S[1] = R->first_moment[1] + femp_r_dot(R->m, R->moment_modes + R->m, q);
}

double femp_r_gravity_energy(const Reduced *R, const double *z) {
    double S[2];
    first_moment(R, z + 1, S);
    return R->g * (sin(z[0]) * S[0] + cos(z[0]) * S[1]);
}

static void gravity_gradient(const Reduced *R, const double *z, double *grad) {
    double S[2], s = sin(z[0]), c = cos(z[0]), g = R->g;
    first_moment(R, z + 1, S);
    grad[0] = g * (c * S[0] - s * S[1]);
    for (int j = 0; j < R->m; ++j) grad[1 + j] = (g * s) * R->moment_modes[j] + (g * c) * R->moment_modes[R->m + j];
}

/* x . y with four partial sums (lanes p mod 4, added at the end): the compiler may run them as
 * vector lanes without reordering any sum, so the result is the same on every run. */
static double dot4(int k, const double *x, const double *y) {
    double s[4] = {0.0, 0.0, 0.0, 0.0};
    int i = 0;
    for (; i + 4 <= k; i += 4)
        for (int l = 0; l < 4; ++l) s[l] += x[i + l] * y[i + l];
    for (; i < k; ++i) s[0] += x[i] * y[i];
    return (s[0] + s[1]) + (s[2] + s[3]);
}

/* F = I + sum_j q_j GT_j at every point into R->work (4 per point: 00 01 10 11) */
static double *deformations(const Reduced *R, const double *q) {
    int k = 4 * R->nqp;
    double *F = R->work;
    for (int i = 0; i < k; ++i) F[i] = (i % 4 == 0 || i % 4 == 3) ? 1.0 : 0.0;
    for (int j = 0; j < R->m; ++j) {
        const double *Gj = R->GT + (size_t)j * k;
        double qj = q[j];
        for (int i = 0; i < k; ++i) F[i] += qj * Gj[i];
    }
    return F;
}

double femp_reduced_strain_energy(const Reduced *R, const double *q) {
    if (!R->neo) {
        double e = 0.0;
        for (int j = 0; j < R->m; ++j) e += R->omega2[j] * q[j] * q[j];
        return 0.5 * e;
    }
    const double *F = deformations(R, q);
    double e = 0.0;
    for (int p = 0; p < R->nqp; ++p) {
        const double *f = F + 4 * p;
        double lj = log(f[0] * f[3] - f[1] * f[2]), ff = f[0] * f[0] + f[1] * f[1] + f[2] * f[2] + f[3] * f[3];
        e += R->qw[p] * (0.5 * R->mu * (ff - 2.0 - 2.0 * lj) + 0.5 * R->lame_lambda * lj * lj);
    }
    return e;
}

/* F^-1 (rows 00 01 10 11) and ln J of one point's F */
static double inverse_and_log(const double *F, double inv[4]) {
    double J = F[0] * F[3] - F[1] * F[2];
    inv[0] = F[3] / J;
    inv[1] = -F[1] / J;
    inv[2] = -F[2] / J;
    inv[3] = F[0] / J;
    return log(J);
}

void femp_reduced_strain_gradient(const Reduced *R, const double *q, double *grad) {
    int m = R->m;
    if (!R->neo) {
        for (int j = 0; j < m; ++j) grad[j] = R->omega2[j] * q[j];
        return;
    }
    double *F = deformations(R, q), *P = F; /* the weighted first Piola-Kirchhoff stress, in place of F */
    for (int p = 0; p < R->nqp; ++p) {
        double inv[4], lj = inverse_and_log(F + 4 * p, inv);
        for (int r = 0; r < 4; ++r) {
            double inv_t = inv[(r % 2) * 2 + r / 2]; /* (F^-T)_ij = (F^-1)_ji */
            P[4 * p + r] = R->qw[p] * (R->mu * (F[4 * p + r] - inv_t) + R->lame_lambda * lj * inv_t);
        }
    }
    for (int j = 0; j < m; ++j) grad[j] = dot4(4 * R->nqp, P, R->GT + (size_t)j * 4 * R->nqp);
}

/* The exact tangent sum_p w_p X_j : A_p : X_k over the points, X_j = dF/dq_j and A the Neo-Hookean
 * elasticity tensor mu d_ik d_JL + (mu - lame_lambda ln J) Fi_Li Fi_Jk + lame_lambda Fi_Ji Fi_Lk (Fi = F^-1). With
 * Y_j = X_j Fi that is mu X_j : X_k (constant: R->k_mu) + (mu - lame_lambda ln J) tr(Y_j Y_k)
 * + lame_lambda tr(Y_j) tr(Y_k): five products per point and pair, summed as dot products over the points. */
void femp_reduced_strain_hessian(const Reduced *R, const double *q, double *hess) {
    int m = R->m, n5 = 5 * R->nqp;
    if (!R->neo) {
        memset(hess, 0, sizeof(double) * m * m);
        for (int j = 0; j < m; ++j) hess[j * m + j] = R->omega2[j];
        return;
    }
    double *F = deformations(R, q), *Y = F + 4 * R->nqp, *Z = Y + (size_t)m * n5;
    for (int p = 0; p < R->nqp; ++p) {
        double inv[4], lj = inverse_and_log(F + 4 * p, inv);
        double wc = R->qw[p] * (R->mu - R->lame_lambda * lj), wl = R->qw[p] * R->lame_lambda;
        for (int j = 0; j < m; ++j) {
            const double *X = R->GT + (size_t)j * 4 * R->nqp + 4 * p;
            double y00 = X[0] * inv[0] + X[1] * inv[2], y01 = X[0] * inv[1] + X[1] * inv[3];
            double y10 = X[2] * inv[0] + X[3] * inv[2], y11 = X[2] * inv[1] + X[3] * inv[3];
            double *Yj = Y + (size_t)j * n5 + 5 * p, *Zj = Z + (size_t)j * n5 + 5 * p;
            Yj[0] = y00, Yj[1] = y01, Yj[2] = y10, Yj[3] = y11, Yj[4] = y00 + y11;
            Zj[0] = wc * y00, Zj[1] = wc * y10, Zj[2] = wc * y01, Zj[3] = wc * y11, Zj[4] = wl * (y00 + y11);
        }
    }
    for (int i = 0; i < m; ++i)
        for (int j = i; j < m; ++j)
            hess[i * m + j] = hess[j * m + i] = R->k_mu[i * m + j] + dot4(n5, Z + (size_t)i * n5, Y + (size_t)j * n5);
}

/* ------------------------------------------------------------------ the wall */
double femp_r_box_distance(const Reduced *R, double px, double py) {
    double hx = 0.5 * (R->x_max - R->x_min), hy = 0.5 * (R->y_max - R->y_min);
    double qx = fabs(px - 0.5 * (R->x_min + R->x_max)) - hx, qy = fabs(py - 0.5 * (R->y_min + R->y_max)) - hy;
    return hypot(fmax(qx, 0.0), fmax(qy, 0.0)) + fmin(fmax(qx, qy), 0.0);
}

int femp_r_circle_may_touch(const Reduced *R, double cx, double cy, double radius) {
    double qx = fmin(fmax(cx, R->x_min), R->x_max), qy = fmin(fmax(cy, R->y_min), R->y_max);
    double r2 = radius * radius;
    if ((qx - cx) * (qx - cx) + (qy - cy) * (qy - cy) > r2) return 0;
    double fx = fmax(fabs(R->x_min - cx), fabs(R->x_max - cx)), fy = fmax(fabs(R->y_min - cy), fabs(R->y_max - cy));
    return fx * fx + fy * fy >= r2;
}

double femp_r_abs_dot(int k, const double *x, const double *q) {
    double s = 0.0;
    for (int i = 0; i < k; ++i) s += x[i] * fabs(q[i]);
    return s;
}

/* world position of head point i at (c, s, q) */
void femp_r_head_point(const Reduced *R, int i, double c, double s, const double *q, double *px, double *py) {
    const double *phi = R->head_phi + (size_t)i * 2 * R->m;
    double lx = R->head_X[2 * i] + femp_r_dot(R->m, phi, q), ly = R->head_X[2 * i + 1] + femp_r_dot(R->m, phi + R->m, q);
    *px = lx * c - ly * s;
    *py = lx * s + ly * c;
}

/* signed distance of group k's centre to the block, and its reach (radius + largest modal displacement) */
double femp_r_group_gap(const Reduced *R, int k, double c, double s, const double *q, double *reach) {
    double X = R->group_centre[2 * k], Y = R->group_centre[2 * k + 1];
    *reach = R->group_radius[k] + femp_r_abs_dot(R->m, R->group_peak + (size_t)k * R->m, q);
    return femp_r_box_distance(R, X * c - Y * s, X * s + Y * c);
}

/* The smallest signed distance of the head points to the block (the gap output). */
double femp_reduced_gap(const Reduced *R, const double *z) {
    double c = cos(z[0]), s = sin(z[0]), cutoff = INFINITY, best = INFINITY;
    const double *q = z + 1;
    double *gap = malloc(sizeof(double) * 2 * R->groups), *reach = gap + R->groups;
    for (int k = 0; k < R->groups; ++k) {
        gap[k] = femp_r_group_gap(R, k, c, s, q, &reach[k]);
        cutoff = fmin(cutoff, gap[k] + reach[k]);
    }
    for (int k = 0; k < R->groups; ++k) {
        if (!(gap[k] - reach[k] <= cutoff)) continue;
        for (int i = R->group_start[k]; i < R->group_start[k + 1]; ++i) {
            double px, py;
            femp_r_head_point(R, i, c, s, q, &px, &py);
            best = fmin(best, femp_r_box_distance(R, px, py));
        }
    }
    free(gap);
    return best;
}

/* One head point inside the block: its penalty terms added to C (with `terms` CONTACT_GRADIENT the gradient
 * in z too, CONTACT_HESSIAN also the Gauss-Newton Hessian). */
static void add_point(const Reduced *R, int i, double px, double py, double c, double s, int terms, Contact *C,
                      double *row) {
    int n = R->m + 1;
    double ex = px - 0.5 * (R->x_min + R->x_max), ey = py - 0.5 * (R->y_min + R->y_max);
    double qx = fabs(ex) - 0.5 * (R->x_max - R->x_min), qy = fabs(ey) - 0.5 * (R->y_max - R->y_min);
    int x_face = qx >= qy;
    double depth = -fmax(qx, qy);
    double nx = x_face ? (double)((ex > 0) - (ex < 0)) : 0.0, ny = x_face ? 0.0 : (double)((ey > 0) - (ey < 0));
    double w = R->head_w[i] * R->hk, wd = w * depth;
    C->active = 1;
    C->energy += 0.5 * w * depth * depth;
    C->fx += wd * nx;
    C->fy += wd * ny;
    if (terms == CONTACT_ENERGY) return;
    const double *phi = R->head_phi + (size_t)i * 2 * R->m;
    double rx = nx * c + ny * s, ry = -nx * s + ny * c; /* R^T n */
    row[0] = nx * py - ny * px;
    for (int j = 0; j < R->m; ++j) row[1 + j] = -(rx * phi[j] + ry * phi[R->m + j]);
    for (int a = 0; a < n; ++a) C->grad[a] += row[a] * wd;
    if (terms != CONTACT_HESSIAN) return;
    for (int a = 0; a < n; ++a) {
        double wa = w * row[a];
        for (int b = 0; b < n; ++b) C->hess[a * n + b] += wa * row[b];
    }
}

/* The wall contact at z: energy and force, and as `terms` asks its gradient and Hessian. */
void femp_r_contact_at(const Reduced *R, const double *z, int terms, Contact *C, double *row) {
    int n = R->m + 1;
    C->active = 0;
    C->energy = C->fx = C->fy = 0.0;
    if (terms != CONTACT_ENERGY) memset(C->grad, 0, sizeof(double) * n);
    if (terms == CONTACT_HESSIAN) memset(C->hess, 0, sizeof(double) * n * n);
    if (!R->contact_on) return;
    const double *q = z + 1;
    double c = cos(z[0]), s = sin(z[0]);
    double cx = c * R->head_cx - s * R->head_cy, cy = s * R->head_cx + c * R->head_cy;
    if (!femp_r_circle_may_touch(R, cx, cy, R->head_radius + femp_r_abs_dot(R->m, R->phi_peak, q))) return;
    for (int k = 0; k < R->groups; ++k) {
        double reach, gap = femp_r_group_gap(R, k, c, s, q, &reach);
        if (!(gap - reach <= 0.0)) continue;
        for (int i = R->group_start[k]; i < R->group_start[k + 1]; ++i) {
            double px, py;
            femp_r_head_point(R, i, c, s, q, &px, &py);
            if (px < R->x_max && px > R->x_min && py < R->y_max && py > R->y_min)
                add_point(R, i, px, py, c, s, terms, C, row);
        }
    }
}

/* out = (active, energy, force x, force y, gradient (n), Hessian (n, n)) */
void femp_reduced_contact(const Reduced *R, const double *z, double *out) {
    int n = R->m + 1;
    double *row = malloc(sizeof(double) * n);
    Contact C = {0, 0.0, 0.0, 0.0, out + 4, out + 4 + n};
    femp_r_contact_at(R, z, CONTACT_HESSIAN, &C, row);
    free(row);
    out[0] = C.active;
    out[1] = C.energy;
    out[2] = C.fx;
    out[3] = C.fy;
}

/* ------------------------------------------------------------------ the step */
typedef struct { /* what a step's Newton iterations share (NewtonStep.start) */
    const double *z0, *p0;
    double *c0, *S0, *Q;
    double s0, c0c0, c0p0, p0p0, t00, V0;
} Start;

typedef struct { /* scratch of a step: n or m doubles each, and the contact terms */
    double *p1, *dz, *zm, *cm, *c1, *tmp, *tmp2, *row, *jac, *K, *delta;
    Contact contact;
} Scratch;

static double potential(const Reduced *R, const double *z, Scratch *w, double parts[3]) {
    femp_r_contact_at(R, z, CONTACT_ENERGY, &w->contact, w->row);
    parts[0] = femp_r_gravity_energy(R, z);
    parts[1] = w->contact.energy;
    parts[2] = femp_reduced_strain_energy(R, z + 1);
    return parts[0] + parts[1] + parts[2];
}

/* p1 = 2 x - p0 with 1/2 (M(q0)^-1 + M(q1)^-1) x = b (NewtonStep._end_momentum) */
static void end_momentum(const Reduced *R, const Start *S, const double *b, const double *c1, double s1, double c0c1,
                         double c1c1, double *p1) {
    int m = R->m;
    double b0 = b[0], r0 = b0 - femp_r_dot(m, S->c0, b + 1), r1 = b0 - femp_r_dot(m, c1, b + 1);
    double A = 2.0 * S->s0 + 1.0 + S->c0c0, B = 1.0 + c0c1, D = 2.0 * s1 + 1.0 + c1c1;
    double y0 = (r0 - r1 - (B - D) * b0) / (A - 2.0 * B + D), y1 = b0 - y0, y2 = r0 - A * y0 - B * y1;
    p1[0] = 2.0 * (b0 - y0 - y1 - y2) - S->p0[0];
    for (int j = 0; j < m; ++j) p1[1 + j] = 2.0 * b[1 + j] - S->p0[1 + j] + (2.0 * y0) * S->c0[j] + (2.0 * y1) * c1[j];
}

/* (p1, |energy change - torque work|) of the step ending at z1; the end's potential parts in V1 */
static double energy_balance(const Reduced *R, const Start *S, const double *z1, double dt, Scratch *w,
                             double V1[3]) {
    int m = R->m, n = m + 1;
    for (int i = 0; i < n; ++i) {
        w->dz[i] = z1[i] - S->z0[i];
        w->tmp[i] = w->dz[i] / dt;
    }
    femp_r_left_gyro(R, z1 + 1, w->c1);
    double c1c1 = femp_r_dot(m, w->c1, w->c1), s1 = R->inertia0 + femp_r_inertia_growth(R, z1 + 1) - c1c1;
    end_momentum(R, S, w->tmp, w->c1, s1, femp_r_dot(m, S->c0, w->c1), c1c1, w->p1);
    double pq = femp_r_dot(m, w->p1 + 1, w->p1 + 1), u = w->p1[0] - femp_r_dot(m, w->c1, w->p1 + 1);
    double kinetic = 0.5 * (pq + u * u / s1) - 0.5 * S->t00;
    double V = potential(R, z1, w, V1);
    return fabs(kinetic + V - S->V0 - femp_r_dot(n, S->Q, w->dz));
}

/* The discrete-gradient equations at z1 (NewtonStep.residual) into r; V1 is the potential at z1.
 * Leaves dz, zm, cm in w and M(zm)'s corner in *mm, the contact at zm in w->contact. */
static void residual(const Reduced *R, const Start *S, const double *z1, double V1, double dt, Scratch *w, double *r,
                     double *mm_out) {
    int m = R->m, n = m + 1;
    const double *z0 = S->z0, *p0 = S->p0, *p0q = p0 + 1;
    for (int i = 0; i < n; ++i) {
        w->dz[i] = z1[i] - z0[i];
        w->zm[i] = z0[i] + 0.5 * w->dz[i];
        w->tmp[i] = w->dz[i] / dt;
    }
    const double *q1 = z1 + 1, *qm = w->zm + 1, *dq = w->dz + 1;
    double dth = w->dz[0];
    femp_r_left_gyro(R, q1, w->c1);
    for (int j = 0; j < m; ++j) w->cm[j] = 0.5 * (S->c0[j] + w->c1[j]);
    double c1c1 = femp_r_dot(m, w->c1, w->c1), c0c1 = femp_r_dot(m, S->c0, w->c1);
    double s1 = R->inertia0 + femp_r_inertia_growth(R, q1) - c1c1;
    double mm = R->inertia0 + femp_r_inertia_growth(R, qm);
    double sm = mm - 0.25 * (S->c0c0 + 2.0 * c0c1 + c1c1);
    double *p1 = w->p1;
    end_momentum(R, S, w->tmp, w->c1, s1, c0c1, c1c1, p1);
    const double *p1q = p1 + 1;
    double p10 = p1[0], c1p0 = femp_r_dot(m, w->c1, p0q), c1p1 = femp_r_dot(m, w->c1, p1q), c0p1 = femp_r_dot(m, S->c0, p1q);
    double p1p1 = femp_r_dot(m, p1q, p1q);
    double va = (p0[0] - 0.5 * (S->c0p0 + c1p0)) / sm, vb = (p10 - 0.5 * (c0p1 + c1p1)) / sm, k2 = va * va + vb * vb;
    double *grad_T = w->tmp2; /* kinetic energy's q difference */
    for (int j = 0; j < m; ++j) w->tmp[j] = va * p0q[j] + vb * p1q[j] - k2 * w->cm[j];
    right_gyro(R, w->tmp, grad_T);
    for (int j = 0; j < m; ++j) grad_T[j] = -0.5 * (k2 * (R->a[j] + qm[j]) + grad_T[j]);
    double dq2 = femp_r_dot(m, dq, dq);
    if (dq2 > 0.0) {
        double t0 = 0.25 * (S->t00 + p1p1 + (p10 - c0p1) * (p10 - c0p1) / S->s0);
        double t1 = 0.25 * (S->p0p0 + (p0[0] - c1p0) * (p0[0] - c1p0) / s1 + p1p1 + (p10 - c1p1) * (p10 - c1p1) / s1);
        double k = (t1 - t0 - femp_r_dot(m, grad_T, dq)) / dq2;
        for (int j = 0; j < m; ++j) grad_T[j] += k * dq[j];
    }
    /* gravity + contact + strain at the midpoint, Gonzalez's correction in the mass metric M(zm) */
    double g = R->g, sn = sin(w->zm[0]), cs = cos(w->zm[0]), Sm[2];
    first_moment(R, q1, Sm);
    Sm[0] = 0.5 * (S->S0[0] + Sm[0]);
    Sm[1] = 0.5 * (S->S0[1] + Sm[1]);
    double *g_q = w->tmp;
    femp_reduced_strain_gradient(R, qm, g_q);
    for (int j = 0; j < m; ++j) g_q[j] += (g * sn) * R->moment_modes[j] + (g * cs) * R->moment_modes[m + j];
    double g_th = g * (cs * Sm[0] - sn * Sm[1]);
    femp_r_contact_at(R, w->zm, CONTACT_HESSIAN, &w->contact, w->row);
    if (w->contact.active) {
        g_th += w->contact.grad[0];
        for (int j = 0; j < m; ++j) g_q[j] += w->contact.grad[1 + j];
    }
    double cm_dq = femp_r_dot(m, w->cm, dq), W0 = mm * dth + cm_dq, denom = dth * W0 + cm_dq * dth + dq2;
    double k = denom > 0.0 ? (V1 - S->V0 - g_th * dth - femp_r_dot(m, g_q, dq)) / denom : 0.0;
    r[0] = p10 - p0[0] + dt * (g_th + k * W0 - S->Q[0]);
    for (int j = 0; j < m; ++j)
        r[1 + j] = p1q[j] - p0q[j] + dt * (g_q[j] + k * (dq[j] + dth * w->cm[j]) - S->Q[1 + j] + grad_T[j]);
    *mm_out = mm;
}

/* The residual's Jacobian in z1 (NewtonStep.jacobian), with the contact at zm already in w */
static void jacobian(const Reduced *R, const double *K, double mm, double dt, Scratch *w) {
    int m = R->m, n = m + 1;
    double h = 2.0 / dt, half = 0.5 * dt, *jac = w->jac;
    memset(jac, 0, sizeof(double) * n * n);
    for (int i = 0; i < n; ++i) jac[i * n + i] = h;
    for (int i = 0; i < m; ++i)
        for (int j = 0; j < m; ++j) jac[(1 + i) * n + 1 + j] += half * K[i * m + j];
    if (w->contact.active)
        for (int i = 0; i < n * n; ++i) jac[i] += half * w->contact.hess[i];
    double g = R->g, om = w->dz[0] / dt, sn = sin(w->zm[0]), cs = cos(w->zm[0]);
    jac[0] += h * (mm - 1.0) - half * femp_r_gravity_energy(R, w->zm);
    for (int j = 0; j < m; ++j) w->tmp[j] = w->dz[1 + j] / dt;
    right_gyro(R, w->tmp, w->tmp2);
    for (int j = 0; j < m; ++j) {
        double symmetric = h * w->cm[j] + (half * g * cs) * R->moment_modes[j] - (half * g * sn) * R->moment_modes[m + j];
        double skew = (2.0 * om) * (R->a[j] + w->zm[1 + j]) + w->tmp2[j];
        jac[1 + j] += symmetric + skew;
        jac[(1 + j) * n] += symmetric - skew;
    }
    for (int i = 0; i < m; ++i)
        for (int j = 0; j < m; ++j)
            jac[(1 + i) * n + 1 + j] -= (2.0 * om) * R->gyro[i * m + j] + (i == j ? half * om * om : 0.0);
}

/* Solve A x = b in place (A (n, n) destroyed, b becomes x), partial pivoting; 0 if singular */
static int solve(int n, double *A, double *b) {
    for (int k = 0; k < n; ++k) {
        int p = k;
        for (int i = k + 1; i < n; ++i)
            if (fabs(A[i * n + k]) > fabs(A[p * n + k])) p = i;
        if (A[p * n + k] == 0.0) return 0;
        if (p != k) {
            for (int j = 0; j < n; ++j) {
                double t = A[k * n + j];
                A[k * n + j] = A[p * n + j];
                A[p * n + j] = t;
            }
            double t = b[k];
            b[k] = b[p];
            b[p] = t;
        }
        for (int i = k + 1; i < n; ++i) {
            double f = A[i * n + k] / A[k * n + k];
            if (f == 0.0) continue;
            for (int j = k + 1; j < n; ++j) A[i * n + j] -= f * A[k * n + j];
            b[i] -= f * b[k];
        }
    }
    for (int k = n - 1; k >= 0; --k) {
        double s = b[k];
        for (int j = k + 1; j < n; ++j) s -= A[k * n + j] * b[j];
        b[k] = s / A[k * n + k];
    }
    return 1;
}

/* The midpoint rule linearised at z0 (NewtonStep.predict) into z1; the strain tangent at q0 in K */
static int predict(const Reduced *R, const Start *S, double dt, Scratch *w, double *z1) {
    int m = R->m, n = m + 1;
    const double *z0 = S->z0, *q0 = z0 + 1;
    double h = 2.0 / (dt * dt), g = R->g, sn = sin(z0[0]), cs = cos(z0[0]);
    femp_reduced_strain_hessian(R, q0, w->K);
    double *v0 = w->p1, *rhs = w->delta, *border = w->cm, *force_q = w->tmp;
    v0[0] = (S->p0[0] - femp_r_dot(m, S->c0, S->p0 + 1)) / S->s0;
    for (int j = 0; j < m; ++j) v0[1 + j] = S->p0[1 + j] - v0[0] * S->c0[j];
    femp_r_contact_at(R, z0, CONTACT_HESSIAN, &w->contact, w->row);
    gravity_gradient(R, z0, w->zm);
    double om = v0[0];
    right_gyro(R, v0 + 1, w->tmp2);
    femp_reduced_strain_gradient(R, q0, force_q);
    for (int i = 0; i < n; ++i) rhs[i] = (2.0 / dt) * S->p0[i] + S->Q[i] - w->zm[i] - w->contact.grad[i];
    for (int j = 0; j < m; ++j) rhs[1 + j] += (om * om) * (R->a[j] + q0[j]) + om * w->tmp2[j] - force_q[j];
    double corner = h * (S->s0 + S->c0c0) - 0.5 * femp_r_gravity_energy(R, z0);
    for (int j = 0; j < m; ++j)
        border[j] = h * S->c0[j] + (0.5 * g * cs) * R->moment_modes[j] - (0.5 * g * sn) * R->moment_modes[m + j];
    if (!w->contact.active && !R->neo) { /* diagonal on the modes plus the border: eliminate theta */
        double num = rhs[0], den = corner;
        for (int j = 0; j < m; ++j) {
            double diagonal = h + 0.5 * R->omega2[j], scaled = border[j] / diagonal;
            num -= scaled * rhs[1 + j];
            den -= scaled * border[j];
        }
        double dth = num / den;
        z1[0] = z0[0] + dth;
        for (int j = 0; j < m; ++j) z1[1 + j] = z0[1 + j] + (rhs[1 + j] - dth * border[j]) / (h + 0.5 * R->omega2[j]);
        return 1;
    }
    double *A = w->jac;
    memset(A, 0, sizeof(double) * n * n);
    for (int i = 0; i < n; ++i) A[i * n + i] = (1.0 / dt) * (2.0 / dt);
    for (int i = 0; i < m; ++i)
        for (int j = 0; j < m; ++j) A[(1 + i) * n + 1 + j] += (1.0 / dt) * ((0.5 * dt) * w->K[i * m + j]);
    if (w->contact.active)
        for (int i = 0; i < n * n; ++i) A[i] += 0.5 * w->contact.hess[i];
    A[0] += corner - h;
    for (int j = 0; j < m; ++j) {
        A[1 + j] += border[j];
        A[(1 + j) * n] += border[j];
    }
    if (!solve(n, A, rhs)) return 0;
    for (int i = 0; i < n; ++i) z1[i] = z0[i] + rhs[i];
    return 1;
}

static double max_abs(int n, const double *x) {
    double s = 0.0;
    for (int i = 0; i < n; ++i) s = fmax(s, fabs(x[i]));
    return s;
}

/* One discrete-gradient step from (z0, p0) with potential V0 (NewtonStep.step). Returns 1 and
 * z1, p1, out = (torque work of the step, gravity, contact and strain energy at z1), or 0 when
 * Newton does not converge (the stepper halves the step). */
int femp_reduced_step(const Reduced *R, const double *z0, const double *p0, double V0, double dt, double torque,
                      double *z1, double *p1, double *out) {
    int m = R->m, n = m + 1;
    double *mem = calloc((size_t)(16 * n + 3 * m + 2 * n * n + m * m), sizeof(double));
    if (!mem) return 0;
    double *c0 = mem, *S0 = c0 + m, *Q = S0 + 2, *r = Q + n;
    Scratch w = {r + n, r + 2 * n, r + 3 * n, r + 4 * n, r + 5 * n, r + 6 * n, r + 7 * n, r + 8 * n, r + 9 * n,
                 r + 9 * n + n * n, r + 9 * n + n * n + m * m, {0, 0.0, 0.0, 0.0, r + 10 * n + n * n + m * m,
                                                                 r + 11 * n + n * n + m * m}};
    Start S = {z0, p0, c0, S0, Q, 0.0, 0.0, 0.0, 0.0, 0.0, V0};
    const double *q0 = z0 + 1, *p0q = p0 + 1;
    femp_r_left_gyro(R, q0, c0);
    double m00 = R->inertia0 + 2.0 * femp_r_dot(m, R->a, q0) + femp_r_dot(m, q0, q0);
    S.s0 = m00 - femp_r_dot(m, c0, c0);
    S.c0c0 = m00 - S.s0;
    S.c0p0 = femp_r_dot(m, c0, p0q);
    S.p0p0 = femp_r_dot(m, p0q, p0q);
    S.t00 = S.p0p0 + (p0[0] - S.c0p0) * (p0[0] - S.c0p0) / S.s0;
    first_moment(R, q0, S0);
    for (int i = 0; i < n; ++i) Q[i] = torque * R->q_unit[i];
    double scale = 0.5 * fabs(S.t00) + fabs(V0) + 1e-12, parts[3], mm;
    int ok = 0;
    if (predict(R, &S, dt, &w, z1)) {
        double V1 = potential(R, z1, &w, parts);
        for (int it = 0; it < R->max_it && !ok; ++it) {
            residual(R, &S, z1, V1, dt, &w, r, &mm);
            if (!isfinite(femp_r_dot(n, r, r))) break;
            jacobian(R, w.K, mm, dt, &w);
            if (!solve(n, w.jac, r)) break;
            for (int i = 0; i < n; ++i) z1[i] -= r[i];
            double imbalance = energy_balance(R, &S, z1, dt, &w, parts);
            if (!isfinite(imbalance)) break;
            V1 = parts[0] + parts[1] + parts[2];
            int converged = max_abs(n, r) <= R->update_tol * max_abs(n, w.dz);
            ok = (converged && imbalance <= R->energy_tol * scale) ||
                 (it == R->max_it - 1 && imbalance <= R->stall_tol * scale);
        }
    }
    if (ok) {
        memcpy(p1, w.p1, sizeof(double) * n);
        out[0] = femp_r_dot(n, Q, w.dz);
        out[1] = parts[0];
        out[2] = parts[1];
        out[3] = parts[2];
    }
    free(mem);
    return ok;
}
