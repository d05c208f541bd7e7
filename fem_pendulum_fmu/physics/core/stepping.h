/* The step control's view of a model (stepping.c): internal to the core, not part of femp_core.h's API.
 * A model's state is `size` doubles; each function reads states and writes only its outputs. */
#ifndef FEMP_STEPPING_H
#define FEMP_STEPPING_H

#include "femp_core.h"

#define FEMP_PI 3.14159265358979323846 /* Python's math.pi, which the C99 library need not name */

struct femp_steppable {
    void *self;
    int size;
    /* one energy-consistent step of size dt from x0 into x1; 0 where the nonlinear solve failed */
    int (*step)(void *self, const double *x0, double dt, double torque, double *x1);
    /* the smallest signed gap (m, negative inside) and its time derivative */
    void (*gap_and_rate)(void *self, const double *x, double *gap, double *rate);
    /* the contact's estimated duration (s) and largest depth (m); (inf, 0) with none in view */
    void (*contact_scales)(void *self, const double *x, double *t_contact, double *d_max);
    /* the resultant contact force's magnitude (N) */
    double (*contact_force)(void *self, const double *x);
    /* the step's contact impulse on the pendulum (N.s, a 2-vector), as the scheme applies it */
    void (*contact_impulse)(void *self, const double *x0, const double *x1, double dt, double *j);
};

/* Integrate x (in place) from a->t_start to a->t_end; the result in a (femp_core.h). */
int femp_advance(const struct femp_steppable *m, const struct femp_step_control *c, const struct femp_torque *T,
                 double *x, struct femp_advance *a, femp_stop_fn stop, void *context);

#endif
