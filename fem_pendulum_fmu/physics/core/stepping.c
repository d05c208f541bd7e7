/* The adaptive internal step control every fidelity shares (physics/stepping.py states the rules and why),
 * over a model given as a table of functions on its state (struct femp_steppable, core/stepping.h).
 *
 * The same decisions in the same order as stepping.advance: the step size from the gap, its rate and the
 * contact's scales (asked only when a step needs them), the onset located by regula falsi, equal steps in
 * contact where the model asks for them, a held contact stepped as free flight, a failed step halved, the
 * contact tallied over the accepted steps.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "femp_core.h"
#include "stepping.h"

static int ceil_int(double x) { return (int)ceil(x); }

/* steps per contact by the phase rule, never fewer than 8 */
static int steps_per_contact(const struct femp_step_control *c) {
    int most = ceil_int(FEMP_PI / sqrt(12.0 * c->tolerance));
    return most > 8 ? most : 8;
}

static int contact_steps(const struct femp_step_control *c, double t_contact) {
    int most = steps_per_contact(c);
    if (!c->timing_rule || !(t_contact < INFINITY)) return most;
    int needed = ceil_int(FEMP_PI * sqrt(t_contact / (12.0 * c->tolerance * c->max_step)));
    int n = needed > c->min_steps_per_contact ? needed : c->min_steps_per_contact;
    return n < most ? n : most;
}

/* the contact scales of one state, made when first asked (stepping.py, _ContactView) */
typedef struct {
    const struct femp_steppable *model;
    const double *x;
    const struct femp_step_control *control;
    int made;
    double t_contact, dt_contact, pen_tol;
} View;

static void view_make(View *v) {
    if (v->made) return;
    double t_contact = INFINITY, d_max = 0.0; /* as a model that writes nothing (a failed callback) says */
    v->model->contact_scales(v->model->self, v->x, &t_contact, &d_max);
    int n = contact_steps(v->control, t_contact);
    v->t_contact = t_contact, v->dt_contact = t_contact / n, v->pen_tol = d_max / n;
    v->made = 1;
}

static double torque_at(const struct femp_torque *T, double s) {
    if (T->rate == 0.0 && T->curvature == 0.0) return T->value;
    return T->value + s * (T->rate + 0.5 * s * T->curvature);
}

/* the exact mean of the torque over [s0, s1] (physics/torque.py, TorqueProfile.mean) */
static double torque_mean(const struct femp_torque *T, double s0, double s1) {
    if (T->rate == 0.0 && T->curvature == 0.0) return T->value;
    return T->value + 0.5 * (s0 + s1) * T->rate + (s0 * s0 + s0 * s1 + s1 * s1) * T->curvature / 6.0;
}

static double torque_largest(const struct femp_torque *T, double s0, double s1) {
    if (T->rate == 0.0 && T->curvature == 0.0) return fabs(T->value);
    double found = fmax(fabs(torque_at(T, s0)), fabs(torque_at(T, s1)));
    if (T->curvature != 0.0) {
        double vertex = -T->rate / T->curvature;
        if (s0 < vertex && vertex < s1) found = fmax(found, fabs(torque_at(T, vertex)));
    }
    return found;
}

double femp_decayed_hold(const struct femp_step_control *c, double hold, double dt) {
    double decayed = hold - c->hold_decay * dt;
    return decayed > 0.0 ? decayed : 0.0;
}

static double hold_after(const struct femp_step_control *c, double hold, double gap0, double gap1, double dt) {
    if (gap0 < 0.0 && gap1 < 0.0) return hold + dt;
    if (gap0 >= 0.0 && gap1 >= 0.0) return femp_decayed_hold(c, hold, dt);
    double inside = dt * (gap1 < 0.0 ? gap1 / (gap1 - gap0) : gap0 / (gap0 - gap1));
    return fmax(hold + inside - c->hold_decay * (dt - inside), 0.0);
}

/* count an accepted step from x0 (gap gap0) to x1 (stepping.py, ContactTally.add) */
static void tally(const struct femp_steppable *m, const struct femp_step_control *c, struct femp_advance *a,
                  const double *x0, const double *x1, double dt, double gap0) {
    double gap1 = INFINITY, rate = 0.0, j[2] = {0.0, 0.0};
    m->gap_and_rate(m->self, x1, &gap1, &rate);
    a->hold = hold_after(c, a->hold, gap0, gap1, dt);
    a->force_now = 0.0;
    if (gap0 >= 0.0 && gap1 >= 0.0) return;
    m->contact_impulse(m->self, x0, x1, dt, j);
    a->impulse_x += j[0];
    a->impulse_y += j[1];
    if (gap1 < 0.0) {
        a->force_now = m->contact_force(m->self, x1);
        a->force_max = fmax(a->force_max, a->force_now);
    }
}

static double even_step(double step_kept, double longest, double remaining, double last) {
    if (step_kept * longest <= last && last <= longest) {
        double count = remaining / last;
        if (fabs(count - round(count)) <= 1e-9 * count) return last;
        longest = last;
    }
    double count = ceil(remaining / longest * (1.0 - 1e-12));
    return count > 1 ? remaining / count : remaining;
}

static double step_size(View *v, const struct femp_step_control *c, double gap, double rate, double longest,
                        double remaining, double last_contact_dt, int held) {
    double dt = longest;
    if (held) {
    } else if (gap < 0.0) {
        view_make(v);
        dt = fmin(dt, v->dt_contact);
        if (c->even_contact_steps) dt = even_step(c->step_kept, dt, remaining, last_contact_dt);
    } else if (rate < 0.0 && gap / -rate < dt) {
        view_make(v);
        double t_hit = (gap + v->pen_tol) / -rate;
        dt = fmin(dt, fmax(t_hit, v->dt_contact));
    }
    dt = fmax(dt, c->min_step);
    return remaining - dt < c->min_step ? remaining : dt;
}

/* One step from x into out, re-aimed at the contact's onset where it plunges deeper than pen_tol
 * (stepping.py, _step_locating_onset). Returns 1 with the step taken in *dt, or 0 (the solve failed,
 * *dt the size that failed); *fails counts the rejected trials. trial and lo are scratch states. */
static int step_locating_onset(const struct femp_steppable *m, const double *x, double *dt, const struct femp_torque *T,
                               double s, double gap0, View *v, const struct femp_step_control *c, double *out,
                               double *trial, double *lo_x, int *fails) {
    int size = m->size;
    double rate = 0.0;
    *fails = 0;
    if (!m->step(m->self, x, *dt, torque_mean(T, s, s + *dt), out)) return *fails = 1, 0;
    if (gap0 < 0.0) return 1;
    double g_hi = INFINITY;
    m->gap_and_rate(m->self, out, &g_hi, &rate);
    if (g_hi >= 0.0) return 1;
    view_make(v);
    double pen_tol = v->pen_tol, dt_contact = v->dt_contact;
    if (*dt <= dt_contact || g_hi >= -pen_tol) return 1;
    double lo = 0.0, g_lo = gap0, hi = *dt;
    int have_lo = 0;
    *fails = 1;
    for (int k = 0; k < c->max_onset_iterations; ++k) {
        if (hi - lo <= dt_contact) break;
        double trial_dt = lo + (hi - lo) * g_lo / (g_lo - g_hi);
        trial_dt = fmin(fmax(trial_dt, lo + 0.05 * (hi - lo)), hi - 0.05 * (hi - lo));
        if (!m->step(m->self, x, trial_dt, torque_mean(T, s, s + trial_dt), trial)) {
            *dt = trial_dt, *fails += 1;
            return 0;
        }
        double g = INFINITY;
        m->gap_and_rate(m->self, trial, &g, &rate);
        if (-pen_tol <= g && g <= pen_tol) {
            memcpy(out, trial, sizeof(double) * size);
            *dt = trial_dt;
            return 1;
        }
        if (g > pen_tol) {
            lo = trial_dt, g_lo = g, have_lo = 1;
            memcpy(lo_x, trial, sizeof(double) * size);
        } else {
            hi = trial_dt, g_hi = g;
        }
        *fails += 1;
    }
    if (have_lo) {
        memcpy(out, lo_x, sizeof(double) * size);
        *dt = lo;
        return 1;
    }
    *dt = fmax(fmin(hi, dt_contact), c->min_step);
    return m->step(m->self, x, *dt, torque_mean(T, s, s + *dt), out);
}

/* the force the torque and gravity can press the head on a face with (stepping.py, _load_force) */
static double load_force(const struct femp_advance *a, const struct femp_torque *T, double s0, double s1) {
    return (torque_largest(T, s0, s1) + a->gravity_moment * fabs(sin(a->theta))) / a->head_centre_depth;
}

/* whether the contact is held now (stepping.py, advance); *load is made once, when first needed */
static int is_held(const struct femp_advance *a, View *v, const struct femp_torque *T, double s, double *load) {
    if (!(a->hold > 0.0)) return 0;
    view_make(v);
    if (!(a->hold > v->control->held_contacts * v->t_contact)) return 0;
    if (isnan(*load)) *load = load_force(a, T, s, a->t_end - a->t_start);
    if (!(a->force_now <= v->control->held_force * *load)) return 0;
    v->dt_contact = INFINITY; /* a held contact: free-flight steps, and no onset to locate */
    return 1;
}

int femp_advance(const struct femp_steppable *m, const struct femp_step_control *c, const struct femp_torque *T,
                 double *x, struct femp_advance *a, femp_stop_fn stop, void *context) {
    int size = m->size;
    double *scratch = malloc(sizeof(double) * 4 * size), *x_new = scratch, *trial = scratch + size;
    double *lo_x = scratch + 2 * size;
    double t = a->t_start, t_end = a->t_end, dt_cap = c->max_step, load = NAN, last_contact_dt = 0.0;
    double gap = INFINITY, rate = 0.0;
    a->substeps = a->rejected = 0, a->status = FEMP_ADVANCE_DONE;
    a->min_gap = INFINITY, a->force_max = a->impulse_x = a->impulse_y = 0.0;
    while (t_end - t > 0.0) {
        double remaining = t_end - t, s = t - a->t_start;
        m->gap_and_rate(m->self, x, &gap, &rate);
        a->min_gap = fmin(a->min_gap, gap);
        View v = {m, x, c, 0, 0.0, 0.0, 0.0};
        int held = is_held(a, &v, T, s, &load), fails;
        double dt = step_size(&v, c, gap, rate, fmin(c->max_step, dt_cap), remaining, last_contact_dt, held);
        int ok = step_locating_onset(m, x, &dt, T, s, gap, &v, c, x_new, trial, lo_x, &fails);
        a->rejected += fails;
        if (!ok) {
            dt_cap = dt / 2.0;
            if (dt_cap < c->min_step) {
                a->status = FEMP_ADVANCE_FAILED, a->t_reached = t;
                break;
            }
            continue;
        }
        tally(m, c, a, x, x_new, dt, gap);
        last_contact_dt = gap < 0.0 && !held ? dt : 0.0;
        memcpy(x, x_new, sizeof(double) * size);
        t = dt >= remaining ? t_end : t + dt;
        a->substeps += 1;
        if (stop != NULL && t < t_end) {
            double gap1 = INFINITY;
            m->gap_and_rate(m->self, x, &gap1, &rate);
            if (stop(context, t, gap, gap1)) {
                a->status = FEMP_ADVANCE_STOPPED;
                break;
            }
        }
        if (c->max_substeps && a->substeps >= c->max_substeps && t < t_end) {
            a->status = FEMP_ADVANCE_TOO_MANY_STEPS;
            break;
        }
        dt_cap = fmin(c->max_step, 2.0 * dt_cap);
    }
    if (a->status != FEMP_ADVANCE_FAILED) {
        m->gap_and_rate(m->self, x, &gap, &rate);
        a->min_gap = fmin(a->min_gap, gap);
        a->t_reached = t;
    }
    free(scratch);
    return a->status;
}
