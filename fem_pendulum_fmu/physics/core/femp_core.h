/* The compiled physics core: every function and struct the Python side calls, declared once.
 *
 * The package's build compiles the sources of this folder into one extension module (cffi_build.py reads
 * this header as its declarations), so a host needs no compiler. NGSolve builds the model's data (mesh,
 * spaces, matrices, modes); the core runs the loops over it. Arrays are C-contiguous, matrices in CSR form
 * with int indices, sizes in entries. Sums run in a fixed order and the build keeps multiply-adds apart
 * (-ffp-contract=off), so a run gives the same bits every time.
 *
 * Lines starting with '#' are left out of the declarations cffi parses.
 */
#ifndef FEMP_CORE_H
#define FEMP_CORE_H

/* ---- the FE model's elastic term (fem_elastic.c) ---- */

/* A sparse matrix in CSR form. */
struct femp_csr {
    int n;
    const int *indptr, *indices;
    const double *data;
};

/* One body's integration points: the gradient matrix of the scalar basis (2 q rows, d/dx then d/dy), the
 * step start's deformation F0 and C0 = F0^T F0, the weights, the material and the Gauss rule along C. */
struct femp_body {
    int q;
    const int *indptr, *indices;
    const double *data;
    const double *F0, *C0, *weights;
    double lame_lambda, mu;
    int n_gauss;
    const double *gauss_s, *gauss_w;
};

/* The held Jacobian's sparse LU factors (fem/lu.py), with the scratch its solve uses. */
struct femp_factors {
    int n;
    const int *free_dofs;
    const double *scale;
    const int *perm_r, *perm_c, *Lp, *Li;
    const double *Lx;
    const int *Up, *Ui;
    const double *Ux, *u_diag;
    const int *sn;
    const double *Ur;
    double *work;
};

/* The rigid wall's contact term over the head's boundary points (fem_rigid_contact.c). */
struct femp_rigid_contact {
    int n; /* listed points */
    const int *points;
    int P; /* all points */
    const int *indptr, *indices;
    const double *data, *X, *p0, *weights, *block; /* X and p0: the P x coordinates, then the y */
    double k;
};

/* The held Jacobian A (assembled without the contact) updated for the rigid wall's contact term, whose
 * Jacobian is V K V^T on the m unknowns dofs of the contact set's elements (fem/contact_update.py): the
 * correction z = A^-1 r becomes z - G M V^T z with G = A^-1 V and M = (I + K S)^-1 K, S = V^T G, all in
 * the held Jacobian's frame. K is made at each iterate from the term's stiffness at the listed points,
 * c_j g_j g_j^T in their positions X_j + E_j u, whose rows of E on dofs are ex and ey. */
struct femp_low_rank {
    int m, n_points;
    const int *dofs;
    const double *G, *S, *ex, *ey; /* G: m rows of size; S: m x m; ex, ey: n_points x m (all by rows) */
    double *c, *gx, *gy;           /* n_points each */
    double *K, *B, *y;             /* m x m, m x m, 2 m */
};

/* What one Newton iteration of the FE step form reads and writes (fem/iteration.py fills it). */
struct femp_iteration {
    int size, n_disp, nS, n_bodies;
    struct femp_body bodies[2];
    struct femp_csr mass, hinge, torque;
    const double *constant, *wv;
    double inertia, half_torque;
    struct femp_factors lu;
    int nturn;
    const int *ix, *iy;
    double *res, *moved, *turned, *corr, *w;
    const struct femp_rigid_contact *contact; /* NULL: none compiled */
    double *f_last, *g_last; /* the last iteration's -corr (n_disp) and updated w (size) */
    int has_last;            /* 0: no iteration yet with this Jacobian */
    int depth, kept;         /* differences the Anderson step combines at most, and holds now */
    double *df, *dg;         /* the kept differences of f (n_disp each) and of g (size each), newest first */
    double *gram;            /* their inner products, 4 x 4 */
    struct femp_low_rank *low_rank; /* the held Jacobian's update for the rigid wall's contact (NULL: none) */
};

double femp_deformation(int q, const int *indptr, const int *indices, const double *data, int nS, const double *u,
                        double *F, double *C);
void femp_stress_residual(int q, const int *indptr, const int *indices, const double *data, int nS,
                          const double *u, const double *F0, const double *C0, const double *weights, double lame_lambda,
                          double mu, int n_gauss, const double *gauss_s, const double *gauss_w, double *out);
void femp_stress_tangent(int q, const int *indptr, const int *indices, const double *data, int nS, const double *u,
                         const double *F0, const double *C0, const double *weights, double lame_lambda, double mu,
                         int n_gauss, const double *gauss_s, const double *gauss_w, const int *start,
                         const int *slots, double *out);
double femp_min_det(int q, const int *indptr, const int *indices, const double *data, int nS, const double *u);
double femp_strain_energy_of(int q, const double *C, const double *weights, double lame_lambda, double mu);
double femp_strain_energy(int q, const int *indptr, const int *indices, const double *data, int nS, const double *u,
                          const double *weights, double lame_lambda, double mu);
void femp_csr_axpy(int n, const int *indptr, const int *indices, const double *data, double a, const double *x,
                   double *out);
double femp_lu_factor(int n, const int *Ap, const int *Ai, const double *Ax, const int *pos, const int *order,
                      const int *Lp, const int *Li, double *Lx, const int *Up, const int *Ui, double *Ux,
                      double *u_diag, double *scale, const int *u_rows, double *Ur, double pivot_min, double *x);
void femp_lu_solve(int n, const int *free_dofs, const double *scale, const int *perm_r, const int *perm_c,
                   const int *Lp, const int *Li, const double *Lx, const int *Up, const int *Ui, const double *Ux,
                   const double *u_diag, const int *sn, const double *Ur, const double *b, double *work, double *x);
void femp_turned_solve(int nturn, const int *ix, const int *iy, double c, double s, int n, const int *free_dofs,
                       const double *scale, const int *perm_r, const int *perm_c, const int *Lp, const int *Li,
                       const double *Lx, const int *Up, const int *Ui, const double *Ux, const double *u_diag,
                       const int *sn, const double *Ur, const double *res, double *turned, double *work, double *corr,
                       int size);
double femp_update(int n, int n_max, const double *corr, double *w);
double femp_iterate(struct femp_iteration *it, int res_holds_contact, int turn, double c, double s);

/* ---- the FE model's rigid wall (fem_rigid_contact.c) ---- */

int femp_rigid_contact(const struct femp_rigid_contact *c, const double *u, int size, double *res);
void femp_rigid_contact_resultant(const struct femp_rigid_contact *c, const double *p0, const double *p1,
                                  double *out);
int femp_rigid_contact_stiffness(const struct femp_rigid_contact *c, const double *u, int n, double *cj, double *gx,
                                 double *gy);

/* ---- the FE model's start iterate (fem_start_iterate.c) ---- */

int femp_misses_predict(int n, int k, double *block, int depth, int window, double ridge, double fit_left);
int femp_misses_record(int n, int k_old, const double *old_block, int k_new, double *new_block, int depth, int window,
                       double ridge, double fit_left);

/* ---- the FE model's mass moments (fem_mass_moments.c) ---- */

void femp_mass_moments(int n, const int *indptr, const int *indices, const double *data, const double *a,
                       const double *b, double *out);

/* ---- the reduced model's step (reduced_step.c) ---- */

/* The reduced model's data (reduced/kernel.py fills it); z = (theta, q) has m + 1 entries. */
struct femp_reduced {
    int m; /* modes */
    double inertia0, g, hk;
    const double *gyro;         /* (m, m) */
    const double *a;            /* (m) */
    const double *first_moment; /* (2) */
    const double *moment_modes; /* (2, m) */
    const double *q_unit;       /* (m + 1): generalised force of a unit torque */
    const double *omega2;       /* (m) */
    int neo;                    /* 1: Neo-Hookean strain at nqp points, 0: quadratic */
    int nqp;
    const double *GT;   /* (m, nqp, 4): d w_i / d x_j of mode m at each point, i j = 00 01 10 11 */
    const double *qw;   /* (nqp) weights times thickness */
    const double *k_mu; /* (m, m): mu sum_p qw_p GT_p^T GT_p, the constant part of the tangent */
    double lame_lambda, mu;
    double *work;       /* (nqp (4 + 10 m)) scratch of the strain terms */
    int contact_on;
    double x_min, x_max, y_min, y_max;
    double head_cx, head_cy, head_radius;
    const double *phi_peak; /* (m) */
    int P;
    const double *head_X;   /* (P, 2) */
    const double *head_phi; /* (P, 2, m) */
    const double *head_w;   /* (P) */
    int groups;
    const int *group_start;       /* (groups + 1): runs of consecutive head points */
    const double *group_centre;   /* (groups, 2) */
    const double *group_radius;   /* (groups) */
    const double *group_peak;     /* (groups, m) */
    int max_it;
    double update_tol, energy_tol, stall_tol;
    double *potential_memo; /* (m + 3): 1 once set, the potential energy, the z it is of; kept across advances */
};

double femp_reduced_strain_energy(const struct femp_reduced *R, const double *q);
void femp_reduced_strain_gradient(const struct femp_reduced *R, const double *q, double *grad);
void femp_reduced_strain_hessian(const struct femp_reduced *R, const double *q, double *hess);
double femp_reduced_gap(const struct femp_reduced *R, const double *z);
void femp_reduced_contact(const struct femp_reduced *R, const double *z, double *out);
int femp_reduced_step(const struct femp_reduced *R, const double *z0, const double *p0, double V0, double dt,
                      double torque, double *z1, double *p1, double *out);

/* ---- the step control every fidelity's advance runs on (stepping.c; physics/stepping.py states its rules) ---- */

struct femp_step_control {
    double max_step, tolerance, min_step;
    int max_onset_iterations, max_substeps, timing_rule, even_contact_steps;
    /* the rules' constants (physics/stepping.py names them and says why) */
    int min_steps_per_contact;
    double held_contacts, held_force, step_kept, hold_decay;
};

/* T(s) = value + rate s + curvature s^2 / 2, s the time since the advance's start */
struct femp_torque {
    double value, rate, curvature;
};

enum { FEMP_ADVANCE_DONE = 0, FEMP_ADVANCE_STOPPED = 1, FEMP_ADVANCE_FAILED = -1, FEMP_ADVANCE_TOO_MANY_STEPS = -2 };

/* One advance: what it starts from (the contact's hold and force, the angle and the load's terms for the
 * held-contact test), and what it did (status one of FEMP_ADVANCE_*). */
struct femp_advance {
    double t_start, t_end, hold, force_now, theta, gravity_moment, head_centre_depth, gap_start;
    int status, substeps, rejected;
    double t_reached, min_gap, force_max, impulse_x, impulse_y;
};

/* asked after every internal step but the last: nonzero ends the advance there */
typedef int (*femp_stop_fn)(void *context, double t, double gap_before, double gap_after);

/* ---- the rigid fidelity (rigid_model.c, rigid_advance.c; physics/rigid/model.py fills the struct) ---- */

struct femp_rigid {
    double inertia, mgd, hk;            /* about the pivot; m g d; thickness times the penalty stiffness */
    double depth, radius, reach;        /* the head centre's depth, the head's radius, depth + radius */
    double arc_offset, arc_length;      /* the head's outer arc (without the rod joint), from its centre */
    double flat_law;                    /* C of E = C delta^2.5, a circle pressed into a flat face */
    int contact_on;
    double x_min, x_max, y_min, y_max;
    const double *gl_x, *gl_w;          /* 8 Gauss-Legendre points and weights on [-1, 1] */
    int series_terms;                   /* the segment series' terms (10) */
    const double *s_series, *c_series;  /* their coefficients, lowest first */
    const double *phi_limits;           /* the largest phi served by the first n + 1 terms */
};

/* out = (energy, fx, fy, dE/dtheta, d2E/dtheta2) of the contact at theta (zeros with contact off) */
void femp_rigid_penalty(const struct femp_rigid *R, double theta, double *out);
/* out = (gap, d gap / d theta) of the head's arc at theta: the clearance, or minus the deepest depth */
void femp_rigid_gap(const struct femp_rigid *R, double theta, double *out);
/* The rigid model's advance: x = (theta, omega, torque work); a->gap_start the gap at its start. */
int femp_rigid_advance(const struct femp_rigid *R, const struct femp_step_control *control,
                       const struct femp_torque *torque, double *x, struct femp_advance *a, femp_stop_fn stop,
                       void *context);

/* A model the step control advances: its state is `size` doubles; each function reads states and writes
 * only its outputs. The fidelities' models are C; a Python model's functions are the binding's callbacks. */
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

/* The reduced model's advance (reduced_advance.c): x = (z, p, torque work), 2 (m + 1) + 1 entries. */
int femp_reduced_advance(const struct femp_reduced *R, const struct femp_step_control *control,
                         const struct femp_torque *torque, double *x, struct femp_advance *a, femp_stop_fn stop,
                         void *context);

#endif
