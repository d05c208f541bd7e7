/* The penalty law of contact.py evaluated exactly for the rigid head's circular arc against the wall block:
 * the arc is split where it crosses the block's faces and where the nearest face changes, each inside piece
 * (one linear depth) integrated by Gauss-Legendre, a whole segment beyond one face in closed form; and the
 * signed gap. physics/rigid/model.py states the rules; the tables the law needs (Gauss-Legendre points, the
 * segment series and their ranges) come from Python.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "femp_core.h"
#include "rigid_internal.h"

/* Python's float modulo: the result takes the divisor's sign */
static double py_mod(double x, double y) {
    double m = fmod(x, y);
    if (m != 0.0) {
        if ((y < 0) != (m < 0)) m += y;
    } else {
        m = copysign(0.0, y);
    }
    return m;
}

Arc femp_rg_arc_at(const Rigid *R, double theta) {
    Arc arc = {R->depth * sin(theta), -R->depth * cos(theta), R->radius, theta + R->arc_offset, R->arc_length};
    return arc;
}

/* face j's depth c + gx px + gy py: right, left, top, bottom */
void femp_rg_face(const Rigid *R, int j, double *c, double *gx, double *gy) {
    static const double G[4][2] = {{-1.0, 0.0}, {1.0, 0.0}, {0.0, -1.0}, {0.0, 1.0}};
    double C[4] = {R->x_max, -R->x_min, R->y_max, -R->y_min};
    *c = C[j], *gx = G[j][0], *gy = G[j][1];
}

static int circle_may_touch(const Rigid *R, double cx, double cy, double radius) {
    double dx = cx < R->x_min ? R->x_min - cx : cx > R->x_max ? cx - R->x_max : 0.0;
    double dy = cy < R->y_min ? R->y_min - cy : cy > R->y_max ? cy - R->y_max : 0.0;
    double r2 = radius * radius;
    if (dx * dx + dy * dy > r2) return 0;
    double fx = cx - R->x_min > R->x_max - cx ? cx - R->x_min : R->x_max - cx;
    double fy = cy - R->y_min > R->y_max - cy ? cy - R->y_min : R->y_max - cy;
    return fx * fx + fy * fy >= r2;
}

static double offset(const Arc *arc, double angle) { return py_mod(angle - arc->start, TWO_PI); }

/* the inside pieces of a circle crossing one face away from its ends: their count (0 or 1), or -1 for
 * the general split (arc_contact.py, _one_face_piece) */
static int one_face_piece(const Rigid *R, const Arc *arc, Piece *out) {
    for (int j = 0; j < 4; ++j) {
        double c, gx, gy;
        femp_rg_face(R, j, &c, &gx, &gy);
        double centre_depth = c + gx * arc->cx + gy * arc->cy;
        if (centre_depth >= 0.0) continue;
        double delta = arc->radius + centre_depth, lo, hi, t, thick;
        if (delta <= 0.0) return 0;
        if (gx != 0.0) lo = R->y_min, hi = R->y_max, t = arc->cy, thick = R->x_max - R->x_min;
        else lo = R->x_min, hi = R->x_max, t = arc->cx, thick = R->y_max - R->y_min;
        double half_chord = sqrt(delta * (2.0 * arc->radius - delta));
        if (!(lo + delta < t - half_chord && t + half_chord < hi - delta && thick > 2.0 * delta)) return -1;
        double peak = atan2(gy, gx), half = acos(-centre_depth / arc->radius), s0 = offset(arc, peak - half);
        if (s0 + 2.0 * half > arc->length) return -1;
        Piece p = {arc->start + s0, arc->start + s0 + 2.0 * half, j, 1};
        out[0] = p;
        return 1;
    }
    return -1;
}

static int compare_doubles(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* the lines (beta, nx, ny, C) along which the nearest face or the depth's sign can change */
static void split_line(const Rigid *R, int k, double line[4]) {
    double s = sqrt(0.5), xc = 0.5 * (R->x_min + R->x_max), yc = 0.5 * (R->y_min + R->y_max);
    double raw[10][3] = {
        {1.0, 0.0, R->x_max}, {1.0, 0.0, R->x_min}, {0.0, 1.0, R->y_max}, {0.0, 1.0, R->y_min},
        {1.0, 0.0, xc}, {0.0, 1.0, yc}, {-s, s, s * (R->y_max - R->x_max)}, {s, s, s * (R->x_max + R->y_min)},
        {s, s, s * (R->x_min + R->y_max)}, {-s, s, s * (R->y_min - R->x_min)},
    };
    line[0] = atan2(raw[k][1], raw[k][0]), line[1] = raw[k][0], line[2] = raw[k][1], line[3] = raw[k][2];
}

/* the parts of the arc strictly inside the block, split where the nearest face changes; their count */
int femp_rg_inside_pieces(const Rigid *R, const Arc *arc, Piece *pieces) {
    double cx = arc->cx, cy = arc->cy, r = arc->radius;
    if (!circle_may_touch(R, cx, cy, r)) return 0;
    int fast = one_face_piece(R, arc, pieces);
    if (fast >= 0) return fast;
    double slack = 1e-9 * (R->x_max - R->x_min + R->y_max - R->y_min);
    double x_lo = R->x_min - slack, x_hi = R->x_max + slack, y_lo = R->y_min - slack, y_hi = R->y_max + slack;
    double cuts[2 + 20];
    int n_cuts = 2, count = 0;
    cuts[0] = 0.0, cuts[1] = arc->length;
    for (int k = 0; k < 10; ++k) {
        double line[4];
        split_line(R, k, line);
        double cos_arg = (line[3] - line[1] * cx - line[2] * cy) / r;
        if (!(-1.0 < cos_arg && cos_arg < 1.0)) continue;
        double half = acos(cos_arg), angles[2] = {line[0] - half, line[0] + half};
        for (int i = 0; i < 2; ++i) {
            double px = cx + r * cos(angles[i]), py = cy + r * sin(angles[i]);
            if (x_lo <= px && px <= x_hi && y_lo <= py && py <= y_hi) {
                double s = offset(arc, angles[i]);
                if (s < arc->length) cuts[n_cuts++] = s;
            }
        }
    }
    qsort(cuts, n_cuts, sizeof(double), compare_doubles);
    for (int i = 0; i + 1 < n_cuts; ++i) {
        double s0 = cuts[i], s1 = cuts[i + 1];
        if (s1 <= s0) continue;
        double mid = arc->start + 0.5 * (s0 + s1), px = cx + r * cos(mid), py = cy + r * sin(mid);
        double depth = INFINITY;
        int nearest = -1;
        for (int j = 0; j < 4; ++j) {
            double c, gx, gy;
            femp_rg_face(R, j, &c, &gx, &gy);
            double d = c + gx * px + gy * py;
            if (d < depth) depth = d, nearest = j;
        }
        if (depth <= 0.0) continue;
        double a = arc->start + s0, b = arc->start + s1;
        if (count && pieces[count - 1].face == nearest && pieces[count - 1].b == a) {
            pieces[count - 1].b = b, pieces[count - 1].whole = 0;
        } else if (count < MAX_PIECES) {
            Piece p = {a, b, nearest, 0};
            pieces[count++] = p;
        }
    }
    return count;
}

/* a whole segment beyond one face in closed form; 0 beyond SEGMENT_PHI_MAX (arc_contact.py, _segment_penalty) */
static int segment_penalty(const Rigid *R, const Arc *arc, int j, Penalty *out) {
    double c, gx, gy, r = arc->radius;
    femp_rg_face(R, j, &c, &gx, &gy);
    double delta = r + (c + gx * arc->cx + gy * arc->cy);
    double phi = 2.0 * asin(sqrt((delta > 0.0 ? delta : 0.0) / (2.0 * r)));
    if (phi > SEGMENT_PHI_MAX) return 0;
    double x = 2.0 * phi, p2 = phi * phi, x2 = x * x, s_sum = 0.0, c_sum = 0.0;
    int terms = 0;
    while (terms < R->series_terms - 1 && R->phi_limits[terms] < phi) ++terms;
    for (int k = terms; k >= 0; --k) {
        s_sum = s_sum * x2 + R->s_series[k];
        c_sum = c_sum * p2 + R->c_series[k];
    }
    double energy = 0.5 * R->hk * (r * r * r) * (x2 * x2 * x) * s_sum;
    double force = R->hk * r * r * (p2 * phi) * c_sum, lever = gy * arc->cx - gx * arc->cy;
    double d2 = R->hk * 2.0 * r * phi * lever * lever - force * (gx * arc->cx + gy * arc->cy);
    Penalty p = {energy, -force * gx, -force * gy, force * lever, d2};
    *out = p;
    return 1;
}

/* the energy h k/2 int d^2 ds over the pieces, the force, and the energy's rotation derivatives */
static Penalty penalty(const Rigid *R, const Arc *arc, const Piece *pieces, int count) {
    Penalty zero = {0.0, 0.0, 0.0, 0.0, 0.0}, p = zero;
    if (count == 0) return zero;
    if (count == 1 && pieces[0].whole && segment_penalty(R, arc, pieces[0].face, &p)) return p;
    double cx = arc->cx, cy = arc->cy, r = arc->radius;
    for (int i = 0; i < count; ++i) {
        double c, gx, gy, a = pieces[i].a, b = pieces[i].b;
        femp_rg_face(R, pieces[i].face, &c, &gx, &gy);
        int n_sub = (int)ceil((b - a) / MAX_PIECE);
        n_sub = n_sub > 1 ? n_sub : 1;
        double width = (b - a) / n_sub, half = 0.5 * width, s_d = 0.0, s_dd = 0.0, s_dj = 0.0, s_h = 0.0;
        for (int k = 0; k < n_sub; ++k) {
            double mid = a + (k + 0.5) * width;
            for (int g = 0; g < 8; ++g) {
                double ang = mid + half * R->gl_x[g], wi = R->gl_w[g];
                double px = cx + r * cos(ang), py = cy + r * sin(ang);
                double d = c + gx * px + gy * py, jd = gy * px - gx * py;
                s_d += wi * d;
                s_dd += wi * d * d;
                s_dj += wi * d * jd;
                s_h += wi * (jd * jd - d * (gx * px + gy * py));
            }
        }
        double scale = R->hk * half * r;
        p.energy += 0.5 * scale * s_dd;
        p.fx -= scale * s_d * gx;
        p.fy -= scale * s_d * gy;
        p.d_energy += scale * s_dj;
        p.d2_energy += scale * s_h;
    }
    return p;
}

/* the contact at theta: its pieces (into `pieces`, their count in *count) and their penalty */
Penalty femp_rg_contact_at(const Rigid *R, double theta, Piece *pieces, int *count) {
    Arc arc = femp_rg_arc_at(R, theta);
    *count = femp_rg_inside_pieces(R, &arc, pieces);
    return penalty(R, &arc, pieces, *count);
}

static void point_box(const Rigid *R, double px, double py, double *dist, double *qx, double *qy) {
    *qx = px < R->x_min ? R->x_min : px > R->x_max ? R->x_max : px;
    *qy = py < R->y_min ? R->y_min : py > R->y_max ? R->y_max : py;
    *dist = hypot(px - *qx, py - *qy);
}

/* the deepest arc point among the pieces: (depth, px, py, face) (arc_contact.py, deepest_point) */
static double deepest_point(const Rigid *R, const Arc *arc, const Piece *pieces, int count, double *px, double *py,
                            int *face_of) {
    double best = -INFINITY;
    for (int i = 0; i < count; ++i) {
        double c, gx, gy, a = pieces[i].a, b = pieces[i].b;
        femp_rg_face(R, pieces[i].face, &c, &gx, &gy);
        double peak = atan2(gy, gx);
        peak += TWO_PI * ceil((a - peak) / TWO_PI);
        double candidates[3];
        int n = 0;
        if (peak > b) candidates[n++] = a, candidates[n++] = b;
        else if (pieces[i].whole) candidates[n++] = peak;
        else candidates[n++] = a, candidates[n++] = b, candidates[n++] = peak;
        for (int k = 0; k < n; ++k) {
            double x = arc->cx + arc->radius * cos(candidates[k]), y = arc->cy + arc->radius * sin(candidates[k]);
            double d = c + gx * x + gy * y;
            if (d > best) best = d, *px = x, *py = y, *face_of = pieces[i].face;
        }
    }
    return best;
}

/* the exact distance of an arc with no point inside the block: (dist, px, py, nx, ny) (outside_distance) */
static double outside_distance(const Rigid *R, const Arc *arc, double *px, double *py, double *nx, double *ny) {
    double cx = arc->cx, cy = arc->cy, r = arc->radius, best = INFINITY, bqx = 0.0, bqy = 0.0;
    double feet[8][2] = {{R->x_min, R->y_min}, {R->x_max, R->y_min}, {R->x_min, R->y_max}, {R->x_max, R->y_max}};
    int n = 4;
    if (R->x_min < cx && cx < R->x_max) {
        feet[n][0] = cx, feet[n][1] = R->y_min, feet[n + 1][0] = cx, feet[n + 1][1] = R->y_max;
        n += 2;
    }
    if (R->y_min < cy && cy < R->y_max) {
        feet[n][0] = R->x_min, feet[n][1] = cy, feet[n + 1][0] = R->x_max, feet[n + 1][1] = cy;
        n += 2;
    }
    *px = *py = 0.0;
    for (int k = 0; k < n; ++k) {
        double qx = feet[k][0], qy = feet[k][1], rx = qx - cx, ry = qy - cy, rho = hypot(rx, ry);
        if (rho == 0.0 || !(offset(arc, atan2(ry, rx)) <= arc->length)) continue;
        double dist = fabs(rho - r);
        if (dist < best) best = dist, *px = cx + r * rx / rho, *py = cy + r * ry / rho, bqx = qx, bqy = qy;
    }
    double ends[2] = {arc->start, arc->start + arc->length};
    for (int k = 0; k < 2; ++k) {
        double x = cx + r * cos(ends[k]), y = cy + r * sin(ends[k]), dist, qx, qy;
        point_box(R, x, y, &dist, &qx, &qy);
        if (dist < best) best = dist, *px = x, *py = y, bqx = qx, bqy = qy;
    }
    if (best > 0.0) {
        *nx = (*px - bqx) / best, *ny = (*py - bqy) / best;
    } else {
        double rx = cx - bqx, ry = cy - bqy, rho = hypot(rx, ry);
        rho = rho != 0.0 ? rho : 1.0;
        *nx = rx / rho, *ny = ry / rho;
    }
    return best;
}

/* (gap, d gap / d theta) of the arc at theta (arc_contact.py, signed_gap) */
void femp_rg_signed_gap(const Rigid *R, double theta, double *gap, double *slope) {
    Arc arc = femp_rg_arc_at(R, theta);
    double dist_c, qx, qy;
    point_box(R, arc.cx, arc.cy, &dist_c, &qx, &qy);
    if (dist_c > arc.radius) {
        double rx = qx - arc.cx, ry = qy - arc.cy;
        if (offset(&arc, atan2(ry, rx)) <= arc.length) {
            double nx = -rx / dist_c, ny = -ry / dist_c, px = arc.cx - arc.radius * nx, py = arc.cy - arc.radius * ny;
            *gap = dist_c - arc.radius, *slope = ny * px - nx * py;
            return;
        }
    }
    Piece pieces[MAX_PIECES];
    int count = femp_rg_inside_pieces(R, &arc, pieces);
    double px, py, nx, ny;
    if (count) {
        int j;
        double c, gx, gy, depth = deepest_point(R, &arc, pieces, count, &px, &py, &j);
        femp_rg_face(R, j, &c, &gx, &gy);
        *gap = -depth, *slope = -(gy * px - gx * py);
        return;
    }
    *gap = outside_distance(R, &arc, &px, &py, &nx, &ny);
    *slope = ny * px - nx * py;
}

void femp_rigid_penalty(const struct femp_rigid *R, double theta, double *out) {
    Piece pieces[MAX_PIECES];
    int count;
    Penalty p = {0.0, 0.0, 0.0, 0.0, 0.0};
    if (R->contact_on) p = femp_rg_contact_at(R, theta, pieces, &count);
    out[0] = p.energy, out[1] = p.fx, out[2] = p.fy, out[3] = p.d_energy, out[4] = p.d2_energy;
}

void femp_rigid_gap(const struct femp_rigid *R, double theta, double *out) { femp_rg_signed_gap(R, theta, out, out + 1); }
