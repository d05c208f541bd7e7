/* What reduced_step.c and reduced_advance.c share: internal to the core, not part of femp_core.h's API. */
#ifndef FEMP_REDUCED_INTERNAL_H
#define FEMP_REDUCED_INTERNAL_H

#include "femp_core.h"

typedef struct femp_reduced Reduced;

typedef struct {
    int active; /* some head point inside the block */
    double energy, fx, fy;
    double *grad; /* (n) */
    double *hess; /* (n, n) */
} Contact;

double femp_r_dot(int k, const double *x, const double *y);
void femp_r_left_gyro(const Reduced *R, const double *q, double *out);      /* c = q @ gyro */
double femp_r_inertia_growth(const Reduced *R, const double *q);           /* 2 a.q + q.q */
double femp_r_gravity_energy(const Reduced *R, const double *z);
double femp_r_box_distance(const Reduced *R, double px, double py);          /* signed, negative inside */
int femp_r_circle_may_touch(const Reduced *R, double cx, double cy, double radius);
double femp_r_abs_dot(int k, const double *x, const double *q);              /* x . |q| */
void femp_r_head_point(const Reduced *R, int i, double c, double s, const double *q, double *px, double *py);
double femp_r_group_gap(const Reduced *R, int k, double c, double s, const double *q, double *reach);
enum { CONTACT_ENERGY = 0, CONTACT_GRADIENT = 1, CONTACT_HESSIAN = 2 }; /* what femp_r_contact_at makes */
void femp_r_contact_at(const Reduced *R, const double *z, int terms, Contact *C, double *row);

#endif
