/* The reduced model's whole advance: the shared step control (stepping.c) over the reduced step
 * (reduced_step.c) and what step control asks of the model about the wall (reduced/approach.py and
 * reduced/contact.py state the rules): the gap and its rate, from the head's bounding circle far from the
 * block and from the closest head point near it; the contact's duration and depth from the penalty law on
 * the head points near the closest (physics/contact_time.py); the contact force and the step's impulse.
 *
 * The state is x = (z, p, torque work): z = (theta, q) and its momenta p, n = m + 1 entries each.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "femp_core.h"
#include "reduced_internal.h"
#include "stepping.h"

#define SCALE_BAND 0.02 /* m: the scales consider head points at most this far behind the closest */
#define FAR_GAP 0.01    /* m: beyond this the head's bounding circle answers */
#define ARM_FLOOR 1e-3  /* share of the head centre's depth below which a normal's moment arm is not trusted */

typedef struct {
    const Reduced *R;
    int n;
    double max_step;
    double *v, *c;              /* velocity and c = q @ gyro (n, m) */
    int *points;                /* the candidate head points (P) */
    double *dist, *behind, *w;  /* their distances, and the scales' scratch (P each) */
    double *grad, *hess, *row;  /* contact terms with derivatives (n, n n, n) */
    double *group_gap, *reach;  /* each run's centre gap and reach at the last state closest() saw (groups) */
    double *near_x;             /* the state (z, p) closest() last saw (2 n), whose result `near` holds */
    int has_near;
    struct closest_point { int count, index; double gap, rate, arm; } near;
} Model;

/* M(q)'s border c = q @ gyro into m->c, and its corner m00 = I0 + 2 a.q + q.q (reduced/dynamics.py,
 * ModalMass.parts, in its order of sums) */
static double mass_border(Model *m, const double *q) {
    const Reduced *R = m->R;
    int k = R->m;
    femp_r_left_gyro(R, q, m->c);
    double two_aq = 0.0;
    for (int i = 0; i < k; ++i) two_aq += 2.0 * R->a[i] * q[i];
    return R->inertia0 + two_aq + femp_r_dot(k, q, q);
}

/* M(q)^-1 p into m->v (reduced/dynamics.py, ModalMass.velocity) */
static void velocity(Model *m, const double *z, const double *p) {
    const Reduced *R = m->R;
    int k = R->m;
    const double *q = z + 1;
    double m00 = mass_border(m, q), s = m00 - femp_r_dot(k, m->c, m->c);
    double v0 = (p[0] - femp_r_dot(k, m->c, p + 1)) / s;
    m->v[0] = v0;
    for (int j = 0; j < k; ++j) m->v[1 + j] = p[1 + j] - v0 * m->c[j];
}

/* the head's bounding circle's gap to the block and its rate (approach.py, circle_gap) */
static void circle_gap(Model *m, const double *x, double *gap, double *rate) {
    const Reduced *R = m->R;
    const double *z = x, *q = z + 1;
    double c = cos(z[0]), s = sin(z[0]);
    double cx = c * R->head_cx - s * R->head_cy, cy = s * R->head_cx + c * R->head_cy;
    double radius = R->head_radius + femp_r_abs_dot(R->m, R->phi_peak, q);
    double qx = cx < R->x_min ? R->x_min : cx > R->x_max ? R->x_max : cx;
    double qy = cy < R->y_min ? R->y_min : cy > R->y_max ? R->y_max : cy;
    double d = hypot(cx - qx, cy - qy);
    if (d <= 0.0) {
        *gap = -radius, *rate = 0.0;
        return;
    }
    velocity(m, z, x + m->n);
    *gap = d - radius;
    *rate = m->v[0] * (-cy * (cx - qx) / d + cx * (cy - qy) / d);
}

/* the block's outward normal at a point (box.py, Box.normal) */
static void box_normal(const Reduced *R, double px, double py, double *nx, double *ny) {
    double bx = 0.5 * (R->x_min + R->x_max), by = 0.5 * (R->y_min + R->y_max);
    double qx = fabs(px - bx) - 0.5 * (R->x_max - R->x_min), qy = fabs(py - by) - 0.5 * (R->y_max - R->y_min);
    double ox = fmax(qx, 0.0), oy = fmax(qy, 0.0), outside = hypot(ox, oy);
    if (outside > 0.0) *nx = ox / outside, *ny = oy / outside;
    else *nx = qx >= qy, *ny = qy > qx;
    *nx *= (px > bx) - (px < bx);
    *ny *= (py > by) - (py < by);
}

/* candidate points (m->points, m->dist), the closest among them; its gap, its rate, the normal's moment arm */
typedef struct closest_point Closest;

/* the head point closest to the block among the runs within SCALE_BAND of it (approach.py, closest) */
static Closest closest(Model *m, const double *x) {
    int n = m->n;
    if (m->has_near && memcmp(m->near_x, x, sizeof(double) * 2 * n) == 0) return m->near; /* step control asks again */
    const Reduced *R = m->R;
    const double *z = x, *q = z + 1;
    double c = cos(z[0]), s = sin(z[0]), cutoff = INFINITY;
    for (int k = 0; k < R->groups; ++k) {
        m->group_gap[k] = femp_r_group_gap(R, k, c, s, q, &m->reach[k]);
        cutoff = fmin(cutoff, m->group_gap[k] + m->reach[k]);
    }
    cutoff += SCALE_BAND;
    Closest out = {0, 0, INFINITY, 0.0, 0.0};
    double best_x = 0.0, best_y = 0.0;
    for (int k = 0; k < R->groups; ++k) {
        if (!(m->group_gap[k] - m->reach[k] <= cutoff)) continue;
        for (int i = R->group_start[k]; i < R->group_start[k + 1]; ++i) {
            double px, py;
            femp_r_head_point(R, i, c, s, q, &px, &py);
            double d = femp_r_box_distance(R, px, py);
            if (d < out.gap) out.gap = d, out.index = out.count, best_x = px, best_y = py;
            m->points[out.count] = i, m->dist[out.count++] = d;
        }
    }
    double nx, ny;
    box_normal(R, best_x, best_y, &nx, &ny);
    velocity(m, z, x + m->n);
    const double *phi = R->head_phi + (size_t)m->points[out.index] * 2 * R->m;
    double ex = femp_r_dot(R->m, phi, m->v + 1), ey = femp_r_dot(R->m, phi + R->m, m->v + 1), w = m->v[0];
    out.rate = nx * (-w * best_y + c * ex - s * ey) + ny * (w * best_x + s * ex + c * ey);
    out.arm = best_x * ny - best_y * nx;
    memcpy(m->near_x, x, sizeof(double) * 2 * n);
    m->near = out, m->has_near = 1;
    return out;
}

static void gap_and_rate(void *self, const double *x, double *gap, double *rate) {
    Model *m = self;
    if (!m->R->contact_on) {
        *gap = INFINITY, *rate = 0.0;
        return;
    }
    circle_gap(m, x, gap, rate);
    if (*gap > FAR_GAP) return;
    Closest near = closest(m, x);
    *gap = near.gap, *rate = near.rate;
}

/* the delta with sum_i w_i max(delta - behind_i, 0)^2 = target (contact_time.py, _depth_holding) */
static double depth_holding(double *behind, double *w, int count, double target) {
    int closest = 0;
    for (int i = 1; i < count; ++i)
        if (behind[i] < behind[closest]) closest = i;
    double reach = sqrt(target / w[closest]);
    int kept = 0;
    for (int i = 0; i < count; ++i)
        if (behind[i] < reach) behind[kept] = behind[i], w[kept++] = w[i];
    for (int i = 1; i < kept; ++i) { /* insertion sort: stable, and the points are few */
        double b = behind[i], wi = w[i];
        int j = i - 1;
        for (; j >= 0 && behind[j] > b; --j) behind[j + 1] = behind[j], w[j + 1] = w[j];
        behind[j + 1] = b, w[j + 1] = wi;
    }
    double W = 0.0, S = 0.0, Q = 0.0;
    for (int j = 0; j < kept; ++j) {
        W += w[j], S += w[j] * behind[j], Q += w[j] * behind[j] * behind[j];
        if (j + 1 < kept) {
            double b = behind[j + 1];
            if (W * (b * b) - 2.0 * S * b + Q >= target) break;
        }
    }
    return (S + sqrt(fmax(S * S - W * (Q - target), 0.0))) / W;
}

/* (duration, largest depth) of the contact in view (contact_time.py, contact_time_scale; no body in series) */
static void time_scale(Model *m, int count, const double *gaps, const double *weights, double m_eff, double rate,
                       double *t_contact, double *d_max) {
    double k = m->R->hk, g_min = INFINITY, e_now = 0.0;
    for (int i = 0; i < count; ++i) g_min = fmin(g_min, gaps[i]);
    for (int i = 0; i < count; ++i) {
        double pen = fmax(-gaps[i], 0.0);
        e_now += weights[i] * (pen * pen);
    }
    e_now *= 0.5 * k;
    double approach = g_min > 0 ? fmin(rate, 0.0) * fmin(rate, 0.0) : rate * rate;
    double e_avail = e_now + 0.5 * m_eff * approach;
    *t_contact = INFINITY, *d_max = 0.0;
    if (e_avail <= 0.0) return;
    for (int i = 0; i < count; ++i) m->behind[i] = gaps[i] - g_min, m->w[i] = weights[i];
    double delta = depth_holding(m->behind, m->w, count, 2.0 * e_avail / k);
    if (delta > 1.0) return;
    double k_sec = 2.0 * e_avail / (delta * delta);
    *t_contact = FEMP_PI * sqrt(m_eff / k_sec);
    *d_max = delta;
}

static void contact_scales(void *self, const double *x, double *t_contact, double *d_max) {
    Model *m = self;
    const Reduced *R = m->R;
    *t_contact = INFINITY, *d_max = 0.0;
    if (!R->contact_on) return;
    double gap, rate;
    circle_gap(m, x, &gap, &rate);
    if (gap > FAR_GAP && gap + 2.0 * m->max_step * fmin(rate, 0.0) > 0.0) return;
    Closest near = closest(m, x);
    double depth = -R->head_cy, arm = fmax(fabs(near.arm), ARM_FLOOR * depth), m_eff = R->inertia0 / (arm * arm);
    double *gaps = malloc(sizeof(double) * 2 * near.count), *weights = gaps + near.count;
    int count = 0;
    for (int i = 0; i < near.count; ++i)
        if (m->dist[i] < m->dist[near.index] + SCALE_BAND) gaps[count] = m->dist[i], weights[count++] = R->head_w[m->points[i]];
    time_scale(m, count, gaps, weights, m_eff, near.rate, t_contact, d_max);
    free(gaps);
}

/* the contact terms at z: `what` of reduced_internal.h (the gradient into m->grad) */
static Contact terms(Model *m, const double *z, int what) {
    Contact C = {0, 0.0, 0.0, 0.0, m->grad, m->hess};
    femp_r_contact_at(m->R, z, what, &C, m->row);
    return C;
}

static double contact_force(void *self, const double *x) {
    Model *m = self;
    Contact C = {0, 0.0, 0.0, 0.0, m->grad, m->hess};
    femp_r_contact_at(m->R, x, 0, &C, m->row);
    return hypot(C.fx, C.fy);
}

/* the step's contact impulse as the discrete gradient applies it (reduced/contact.py, WallContact.impulse) */
static void contact_impulse(void *self, const double *x0, const double *x1, double dt, double *j) {
    Model *m = self;
    int n = m->n, k = m->R->m;
    j[0] = j[1] = 0.0;
    if (!m->R->contact_on) return;
    double *dz = malloc(sizeof(double) * 3 * n), *zm = dz + n, *Wdz = dz + 2 * n;
    for (int i = 0; i < n; ++i) dz[i] = x1[i] - x0[i], zm[i] = 0.5 * (x0[i] + x1[i]);
    double m00 = mass_border(m, zm + 1);
    Wdz[0] = m00 * dz[0] + femp_r_dot(k, m->c, dz + 1);
    for (int i = 0; i < k; ++i) Wdz[1 + i] = m->c[i] * dz[0] + dz[1 + i];
    double denom = femp_r_dot(n, dz, Wdz);
    double e1 = terms(m, x1, CONTACT_ENERGY).energy, e0 = terms(m, x0, CONTACT_ENERGY).energy;
    Contact cm = terms(m, zm, CONTACT_GRADIENT);
    double gc0 = cm.grad[0];
    if (denom > 0.0) gc0 = cm.grad[0] + ((e1 - e0 - femp_r_dot(n, cm.grad, dz)) / denom) * Wdz[0];
    const double *at[3] = {zm, x1, x0};
    for (int i = 0; i < 3; ++i) {
        Contact C = i == 0 ? cm : terms(m, at[i], CONTACT_GRADIENT);
        if (C.grad[0] != 0.0) {
            double scale = dt * (gc0 / C.grad[0]);
            j[0] = scale * C.fx, j[1] = scale * C.fy;
            break;
        }
    }
    free(dz);
}

/* gravity + contact + strain at z, the step's start energy (reduced/potential.py): the last step's end's, kept
 * in the model's memo across advances (an advance's first step starts where the last one ended) */
static double potential(Model *m, const double *z) {
    const double *memo = m->R->potential_memo;
    if (memo[0] != 0.0 && memcmp(memo + 2, z, sizeof(double) * m->n) == 0) return memo[1];
    Contact C = {0, 0.0, 0.0, 0.0, m->grad, m->hess};
    femp_r_contact_at(m->R, z, 0, &C, m->row);
    return femp_r_gravity_energy(m->R, z) + C.energy + femp_reduced_strain_energy(m->R, z + 1);
}

static int step(void *self, const double *x0, double dt, double torque, double *x1) {
    Model *m = self;
    int n = m->n;
    double out[4];
    if (!femp_reduced_step(m->R, x0, x0 + n, potential(m, x0), dt, torque, x1, x1 + n, out)) return 0;
    x1[2 * n] = x0[2 * n] + out[0];
    double *memo = m->R->potential_memo;
    memo[0] = 1.0, memo[1] = out[1] + out[2] + out[3];
    memcpy(memo + 2, x1, sizeof(double) * n);
    return 1;
}

int femp_reduced_advance(const struct femp_reduced *R, const struct femp_step_control *control,
                         const struct femp_torque *torque, double *x, struct femp_advance *a, femp_stop_fn stop,
                         void *context) {
    int n = R->m + 1, P = R->P;
    double *work = malloc(sizeof(double) * (2 * n + 3 * P + n + n * n + n + 2 * R->groups + 2 * n));
    int *points = malloc(sizeof(int) * P);
    Model m = {.R = R, .n = n, .max_step = control->max_step};
    m.v = work, m.c = work + n, m.dist = work + 2 * n, m.behind = m.dist + P, m.w = m.behind + P;
    m.grad = m.w + P, m.hess = m.grad + n, m.row = m.hess + n * n, m.points = points;
    m.group_gap = m.row + n, m.reach = m.group_gap + R->groups, m.near_x = m.reach + R->groups;
    struct femp_steppable model = {&m, 2 * n + 1, step, gap_and_rate, contact_scales, contact_force, contact_impulse};
    int status = femp_advance(&model, control, torque, x, a, stop, context);
    free(points);
    free(work);
    return status;
}
