/* What rigid_model.c (the arc's contact law) and rigid_advance.c (the step and the advance) share:
 * internal to the core, not part of femp_core.h's API. */
#ifndef FEMP_RIGID_INTERNAL_H
#define FEMP_RIGID_INTERNAL_H

#include "femp_core.h"
#include "stepping.h"

#define TWO_PI (2.0 * FEMP_PI)
#define MAX_PIECE 0.5        /* rad: Gauss-Legendre on pieces no wider (8 points: exact to round-off there) */
#define SEGMENT_PHI_MAX 0.5  /* a whole segment's half angle up to which its closed form is used */
#define MAX_PIECES 16

typedef struct femp_rigid Rigid;
typedef struct { double cx, cy, radius, start, length; } Arc;  /* counter-clockwise from start over length */
typedef struct { double a, b; int face, whole; } Piece;        /* angles inside the block, nearest `face` */
typedef struct { double energy, fx, fy, d_energy, d2_energy; } Penalty;

Arc femp_rg_arc_at(const Rigid *R, double theta);
void femp_rg_face(const Rigid *R, int j, double *c, double *gx, double *gy);
int femp_rg_inside_pieces(const Rigid *R, const Arc *arc, Piece *pieces);
Penalty femp_rg_contact_at(const Rigid *R, double theta, Piece *pieces, int *count);
void femp_rg_signed_gap(const Rigid *R, double theta, double *gap, double *slope);

#endif
