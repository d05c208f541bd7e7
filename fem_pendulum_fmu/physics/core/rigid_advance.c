/* The rigid model's step and advance: the scalar equation of one discrete-gradient step,
 *
 *     G(u) = c (u - dt w0) - T + (V(q0 + u) - V(q0)) / u = 0,   c = 2 I / dt^2, V = gravity + contact,
 *
 * solved by a bracketed Newton iteration (physics/rigid/model.py states the rules and why), and the
 * advance: a single free-flight step where the head provably stays off the block, else the shared step
 * control (stepping.c) with this model's gap, contact scales, force and impulse.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "femp_core.h"
#include "rigid_internal.h"
#include "stepping.h"

#define NEWTON_MAX_IT 80
#define ENERGY_ROUNDOFF 1e-15 /* relative energy imbalance per step accepted as converged */
#define NEWTON_MARGIN 10.0    /* how much larger than quadratic convergence predicts the next update is taken */
#define SMALL_STEP 1e-9       /* |u| below which the contact quotient is a derivative */
#define EXACT_DERIVATIVE 1e-6 /* |u| above which the contact quotient's derivative is exact */
#define APPROACH_SPEED_FLOOR 1e-3
#define NEAR_FRACTION 1.0
#define FREE_MARGIN 1e-9
#define ARM_FLOOR 1e-3

static Penalty penalty_at(const Rigid *R, double q) {
    Piece pieces[MAX_PIECES];
    int count;
    return femp_rg_contact_at(R, q, pieces, &count);
}

/* (V(q0 + u) - V(q0)) / u of gravity and its u-derivative, free of cancellation */
static void gravity_quotient(double mgd, double q0, double u, double *quot, double *dquot) {
    double h = 0.5 * u, sinc, dsinc;
    if (fabs(h) > 1e-4) {
        double sin_h = sin(h);
        sinc = sin_h / h, dsinc = (h * cos(h) - sin_h) / (h * h);
    } else {
        double h2 = h * h;
        sinc = 1.0 - h2 / 6.0 + h2 * h2 / 120.0, dsinc = h * (-1.0 / 3.0 + h2 / 30.0);
    }
    double s_m = sin(q0 + h), c_m = cos(q0 + h);
    *quot = mgd * s_m * sinc, *dquot = 0.5 * mgd * (c_m * sinc + s_m * dsinc);
}

static double next_update(double du, double last) {
    if (!(last > du)) return INFINITY;
    double ratio = du / last;
    return NEWTON_MARGIN * du * ratio * ratio;
}

static int converged(double du, double size, double c, double scale) {
    return du <= 1e-15 * size + 1e-20 || c * du * size <= ENERGY_ROUNDOFF * scale;
}

static double free_newton_gain(double c, double mgd) {
    if (!(c > mgd)) return INFINITY;
    double lo = c - 0.5 * mgd, hi = c + 0.5 * mgd;
    return mgd / 3.0 / (2.0 * lo) * pow(hi / lo, 2.0);
}

/* the contact's quotient (E(q0 + u) - E(q0)) / u and its u-derivative */
static void contact_quotient(const Rigid *R, double q0, double u, double e0, double *qc, double *dqc) {
    Penalty pen = penalty_at(R, q0 + u);
    if (fabs(u) > SMALL_STEP) {
        *qc = (pen.energy - e0) / u;
        *dqc = fabs(u) > EXACT_DERIVATIVE ? (pen.d_energy - *qc) / u : 0.5 * pen.d2_energy;
    } else {
        *qc = pen.d_energy - 0.5 * u * pen.d2_energy, *dqc = 0.5 * pen.d2_energy;
    }
}

/* one Newton update from the explicit predictor, where the next update is bounded small enough; 0 if not */
static int solve_free(const Rigid *R, double q0, double w0, double dt, double torque, double *u_out) {
    double inertia = R->inertia, mgd = R->mgd, c = 2.0 * inertia / (dt * dt), half_dt2 = 0.5 * dt * dt;
    double gain = free_newton_gain(c, fabs(mgd)), quot, dquot;
    double u = dt * w0 + half_dt2 * (torque - mgd * sin(q0)) / inertia;
    gravity_quotient(mgd, q0, u, &quot, &dquot);
    double g = c * (u - dt * w0) - torque + quot, dg = c + dquot;
    if (!(dg > 0.0 && isfinite(g) && isfinite(dg))) return 0;
    if (g == 0.0) return *u_out = u, 1;
    double u_new = u - g / dg, du = fabs(u_new - u), size = fabs(u_new), bound = gain * du * du;
    if (bound < du) du = bound;
    if (du <= 1e-15 * size + 1e-20) return *u_out = u_new, 1;
    double scale = mgd + 0.5 * inertia * w0 * w0 + fabs(torque * u);
    if (c * du * size <= ENERGY_ROUNDOFF * scale) return *u_out = u_new, 1;
    return 0;
}

/* the increment u = q1 - q0 solving G(u) = 0; `contact` 0 leaves the contact energy out; 0 on failure */
static int solve(const Rigid *R, double q0, double w0, double dt, double torque, int contact, double *u_out) {
    if (!contact && solve_free(R, q0, w0, dt, torque, u_out)) return 1;
    double c = 2.0 * R->inertia / (dt * dt), mgd = R->mgd;
    Penalty pen0 = {0.0, 0.0, 0.0, 0.0, 0.0};
    if (contact) pen0 = penalty_at(R, q0);
    double e0 = pen0.energy, force0 = torque - mgd * sin(q0) - (contact ? pen0.d_energy : 0.0);
    double stiff = contact && pen0.d2_energy > 0.0 ? 0.5 * (mgd * cos(q0) + pen0.d2_energy) : 0.0;
    double explicit_u = dt * w0 + 0.5 * dt * dt * force0 / R->inertia;
    double u0 = stiff > 0.0 ? (c * dt * w0 + force0) / (c + stiff) : explicit_u, u = u0;
    double scale = mgd + 0.5 * R->inertia * w0 * w0 + e0 + fabs(torque * u);
    double lo = -INFINITY, hi = INFINITY, span = 0.0, last = 0.0;
    for (int it = 0; it < NEWTON_MAX_IT; ++it) {
        double quot, dquot, qc, dqc;
        gravity_quotient(mgd, q0, u, &quot, &dquot);
        if (contact) {
            contact_quotient(R, q0, u, e0, &qc, &dqc);
            quot += qc, dquot += dqc;
        }
        double g = c * (u - dt * w0) - torque + quot, dg = c + dquot;
        if (!(isfinite(g) && isfinite(dg))) return 0;
        if (g == 0.0) return *u_out = u, 1;
        if (g < 0.0) lo = u;
        else hi = u;
        double u_new = dg > 0.0 ? u - g / dg : NAN;
        if (lo <= u_new && u_new <= hi) {
            double du = fabs(u_new - u);
            int exact = !contact || fabs(u) > EXACT_DERIVATIVE;
            double ahead = exact ? next_update(du, last) : INFINITY;
            if (converged(du < ahead ? du : ahead, fabs(u_new), c, scale)) return *u_out = u_new, 1;
            last = exact ? du : 0.0;
        }
        if (!(lo < u_new && u_new < hi)) {
            last = 0.0;
            if (isfinite(lo) && isfinite(hi)) {
                u_new = 0.5 * (lo + hi);
                if (u_new == lo || u_new == hi || converged(0.5 * (hi - lo), fabs(u_new), c, scale))
                    return *u_out = u_new, 1;
            } else {
                double first = fmax(fmax(fabs(u0), dt * fabs(w0)), 1e-12);
                span = 2.0 * (span != 0.0 ? span : first);
                u_new = g < 0.0 ? u + span : u - span;
            }
        }
        u = u_new;
    }
    return 0;
}

/* ---------------------------------------------------------------- the step control's view of the model */

static int step(void *self, const double *x0, double dt, double torque, double *x1) {
    const Rigid *R = self;
    double u;
    if (!solve(R, x0[0], x0[1], dt, torque, R->contact_on, &u)) return 0;
    x1[0] = x0[0] + u, x1[1] = 2.0 * u / dt - x0[1], x1[2] = x0[2] + torque * u;
    return 1;
}

static void gap_and_rate(void *self, const double *x, double *gap, double *rate) {
    const Rigid *R = self;
    if (!R->contact_on) {
        *gap = INFINITY, *rate = 0.0;
        return;
    }
    double slope;
    femp_rg_signed_gap(R, x[0], gap, &slope);
    *rate = slope * x[1];
}

static void contact_scales(void *self, const double *x, double *t_contact, double *d_max) {
    const Rigid *R = self;
    *t_contact = INFINITY, *d_max = 0.0;
    if (!R->contact_on) return;
    double gap, slope;
    femp_rg_signed_gap(R, x[0], &gap, &slope);
    double rate = slope * x[1];
    if (gap > NEAR_FRACTION * R->radius && rate >= 0.0) return;
    double arm = fmax(fabs(slope), ARM_FLOOR * R->depth), m_eff = R->inertia / (arm * arm);
    double energy = penalty_at(R, x[0]).energy;
    double law = gap < 0.0 && energy > 0.0 ? energy / pow(-gap, 2.5) : R->flat_law;
    double floor2 = APPROACH_SPEED_FLOOR * APPROACH_SPEED_FLOOR, speed2 = rate * rate > floor2 ? rate * rate : floor2;
    double available = energy + 0.5 * m_eff * speed2, delta = pow(available / law, 0.4);
    double k_sec = 2.0 * law * sqrt(delta);
    *t_contact = FEMP_PI * sqrt(m_eff / k_sec);
    *d_max = delta;
}

static double contact_force(void *self, const double *x) {
    Penalty pen = penalty_at(self, x[0]);
    return hypot(pen.fx, pen.fy);
}

/* the contact force at q up to a positive factor: (fx, fy, dE/dtheta) (rigid/model.py, _force_line) */
static void force_line(const Rigid *R, double q, double out[3]) {
    Arc arc = femp_rg_arc_at(R, q);
    Piece pieces[MAX_PIECES];
    int count = femp_rg_inside_pieces(R, &arc, pieces);
    if (count == 1 && pieces[0].whole) {
        double c, gx, gy;
        femp_rg_face(R, pieces[0].face, &c, &gx, &gy);
        out[0] = -gx, out[1] = -gy, out[2] = gy * arc.cx - gx * arc.cy;
        return;
    }
    Penalty pen = penalty_at(R, q);
    out[0] = pen.fx, out[1] = pen.fy, out[2] = pen.d_energy;
}

static void contact_impulse(void *self, const double *x0, const double *x1, double dt, double *j) {
    const Rigid *R = self;
    j[0] = j[1] = 0.0;
    if (!R->contact_on) return;
    double q0 = x0[0], q1 = x1[0], qc, dqc, line[3];
    contact_quotient(R, q0, q1 - q0, penalty_at(R, q0).energy, &qc, &dqc);
    const double at[3] = {0.5 * (q0 + q1), q1, q0};
    for (int i = 0; i < 3; ++i) {
        force_line(R, at[i], line);
        if (line[2] != 0.0) {
            double scale = dt * (qc / line[2]);
            j[0] = scale * line[0], j[1] = scale * line[1];
            return;
        }
    }
}

/* The advance as one free-flight step when no arc point can reach the block during it (rigid/model.py,
 * _free_step): 1 with x and a updated, else 0 and nothing changed. */
static int free_step(const Rigid *R, const struct femp_step_control *c, double torque, double *x,
                     struct femp_advance *a, femp_stop_fn stop, void *context) {
    double dt = a->t_end - a->t_start, gap0 = a->gap_start, u;
    if (dt > c->max_step || (R->contact_on && !(gap0 > FREE_MARGIN))) return 0;
    if (!solve_free(R, x[0], x[1], dt, torque, &u) && !solve(R, x[0], x[1], dt, torque, 0, &u)) return 0;
    if (R->contact_on && !(gap0 > R->reach * fabs(u) + FREE_MARGIN)) return 0;
    x[2] = x[2] + torque * u, x[1] = 2.0 * u / dt - x[1], x[0] = x[0] + u;
    a->status = FEMP_ADVANCE_DONE, a->substeps = 1, a->rejected = 0, a->t_reached = a->t_end;
    a->min_gap = R->contact_on ? gap0 : INFINITY, a->force_max = a->impulse_x = a->impulse_y = a->force_now = 0.0;
    a->hold = femp_decayed_hold(c, a->hold, dt);
    if (stop != NULL) {
        double gap1[2];
        femp_rigid_gap(R, x[0], gap1);
        stop(context, a->t_end, gap0, gap1[0]);
    }
    return 1;
}

int femp_rigid_advance(const struct femp_rigid *R, const struct femp_step_control *control,
                       const struct femp_torque *torque, double *x, struct femp_advance *a, femp_stop_fn stop,
                       void *context) {
    double s = a->t_end - a->t_start, T = torque->value;
    if (torque->rate != 0.0 || torque->curvature != 0.0) /* the profile's mean over the whole advance */
        T = torque->value + 0.5 * s * torque->rate + (s * s) * torque->curvature / 6.0;
    if (free_step(R, control, T, x, a, stop, context)) return a->status;
    struct femp_steppable model = {(void *)R, 3, step, gap_and_rate, contact_scales, contact_force, contact_impulse};
    return femp_advance(&model, control, torque, x, a, stop, context);
}
