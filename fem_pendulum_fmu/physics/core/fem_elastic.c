/* The FE step form's stress term at its integration points, as one loop.
 *
 * The same computation as ElasticTerms in fem/residual.py with
 * fem/material_points.py: the deformation gradients F0 (step start) and F1 (step
 * end) at Q points from the sparse gradient matrix G of the scalar basis
 * (CSR, 2Q rows: d/dx at the points, then d/dy), the discrete-gradient second
 * Piola-Kirchhoff stress averaged along C0 -> C1 by a Gauss rule, P = F_mid S,
 * and the residual G^T (weight P) added to out. Plain C, no Python API.
 */
#include <math.h>

#include "femp_core.h"

/* grad[p] = (du_x/dx, du_x/dy, du_y/dx, du_y/dy) at point p; u = (u_x (nS), u_y (nS)). The d/dy row holds
 * the d/dx row's columns in the same order (ElasticTerms checks it): each u entry is read once for both
 * rows, the four sums made in the order of the rows as before. */
static void gradients_at(int p, int q, const int *indptr, const int *indices, const double *data, int nS,
                         const double *u, double g[4]) {
    const int *idx = indices + indptr[p];
    const double *gx = data + indptr[p], *gy = data + indptr[q + p];
    int m = indptr[p + 1] - indptr[p];
    double g0 = 0.0, g1 = 0.0, g2 = 0.0, g3 = 0.0;
    for (int k = 0; k < m; ++k) {
        double ux = u[idx[k]], uy = u[nS + idx[k]];
        g0 += gx[k] * ux;
        g2 += gx[k] * uy;
        g1 += gy[k] * ux;
        g3 += gy[k] * uy;
    }
    g[0] = g0, g[1] = g1, g[2] = g2, g[3] = g3;
}

/* F (4 per point: 00 01 10 11) and C = F^T F (3 per point: 00 01 11) of the displacement u */
double femp_deformation(int q, const int *indptr, const int *indices, const double *data, int nS, const double *u,
                        double *F, double *C) {
    double smallest = INFINITY; /* det F, as femp_min_det counts it */
    for (int p = 0; p < q; ++p) {
        double g[4];
        gradients_at(p, q, indptr, indices, data, nS, u, g);
        double f00 = 1.0 + g[0], f01 = g[1], f10 = g[2], f11 = 1.0 + g[3];
        double det = f00 * f11 - f01 * f10;
        if (det < smallest) smallest = det;
        F[4 * p] = f00;
        F[4 * p + 1] = f01;
        F[4 * p + 2] = f10;
        F[4 * p + 3] = f11;
        C[3 * p] = f00 * f00 + f10 * f10;
        C[3 * p + 1] = f00 * f01 + f10 * f11;
        C[3 * p + 2] = f01 * f01 + f11 * f11;
    }
    return smallest;
}

/* out[0:2 nS] += G^T (weights P(F0, F1(u))), the stress term's residual at the end displacement u */
void femp_stress_residual(int q, const int *indptr, const int *indices, const double *data, int nS,
                          const double *u, const double *F0, const double *C0, const double *weights, double lame_lambda,
                          double mu, int n_gauss, const double *gauss_s, const double *gauss_w, double *out) {
    for (int p = 0; p < q; ++p) {
        double g[4];
        gradients_at(p, q, indptr, indices, data, nS, u, g);
        double f00 = 1.0 + g[0], f01 = g[1], f10 = g[2], f11 = 1.0 + g[3];
        double c1[3] = {f00 * f00 + f10 * f10, f00 * f01 + f10 * f11, f01 * f01 + f11 * f11};
        const double *c0 = C0 + 3 * p;
        /* S = mu I + (lame_lambda/2 ln det C - mu) C^-1, averaged over the Gauss points of C0 -> C1 */
        double a00 = 0.0, a01 = 0.0, a11 = 0.0;
        for (int i = 0; i < n_gauss; ++i) {
            double s = gauss_s[i];
            double c00 = c0[0] + s * (c1[0] - c0[0]);
            double c01 = c0[1] + s * (c1[1] - c0[1]);
            double c11 = c0[2] + s * (c1[2] - c0[2]);
            double det = c00 * c11 - c01 * c01;
            double scale = gauss_w[i] * (lame_lambda * 0.5 * log(det) - mu) / det;
            a00 += scale * c11;
            a01 -= scale * c01;
            a11 += scale * c00;
        }
        double s00 = mu + a00, s01 = a01, s11 = mu + a11;
        const double *f0 = F0 + 4 * p;
        double m00 = 0.5 * (f0[0] + f00), m01 = 0.5 * (f0[1] + f01), m10 = 0.5 * (f0[2] + f10),
               m11 = 0.5 * (f0[3] + f11);
        double w = weights[p];
        double p00 = w * (m00 * s00 + m01 * s01), p01 = w * (m00 * s01 + m01 * s11);
        double p10 = w * (m10 * s00 + m11 * s01), p11 = w * (m10 * s01 + m11 * s11);
        /* each entry gets the d/dx row's term, then the d/dy row's, as two loops over the rows would add them;
         * read and written once (through pointers the compiler cannot tell apart, four read-modify-writes
         * would each wait for the store before: 4 % of the kernel's time) */
        const int *idx = indices + indptr[p];
        const double *gx = data + indptr[p], *gy = data + indptr[q + p];
        for (int k = 0, m = indptr[p + 1] - indptr[p]; k < m; ++k) {
            double *ox = out + idx[k], *oy = out + nS + idx[k];
            double x = *ox, y = *oy;
            x += gx[k] * p00;
            y += gx[k] * p10;
            x += gy[k] * p01;
            y += gy[k] * p11;
            *ox = x;
            *oy = y;
        }
    }
}

/* out += a * A x for a CSR matrix A with n rows */
void femp_csr_axpy(int n, const int *indptr, const int *indices, const double *data, double a, const double *x,
                   double *out) {
    for (int r = 0; r < n; ++r) {
        double sum = 0.0;
        for (int k = indptr[r]; k < indptr[r + 1]; ++k) sum += data[k] * x[indices[k]];
        out[r] += a * sum;
    }
}

/* The kernel's own factors by supernodes: runs of columns [s, e) of L where column j holds rows j+1 .. e-1 and
 * then the rows of column e - 1 (fem/lu.py, `supernodes`). L + U's pattern is symmetric, so row i of U holds
 * the columns column i of L holds as rows; Ur keeps U's strict part so, row i at Lp[i] (femp_lu_factor writes
 * it). The rows below a supernode are then read once for all its columns (forward) and its rows (backward),
 * where the column-by-column solve read and wrote each of them once per column: on the 0.005 m mesh
 * (171k entries in L, 1319 supernodes of 3.7 columns, 959 of them a node's x and y) the solves take 39 % fewer
 * instructions. sn: the count, then the starts. */
#define SOLVE_CHUNK 256   /* the rows below a supernode, taken this many at a time in a local array */
#define SUPERNODE_MOST 64 /* the widest supernode (fem/lu.py, supernodes, keeps to it) */

static void forward_supernodal(const int *sn, const int *Lp, const int *Li, const double *Lx, double *work) {
    double acc[SOLVE_CHUNK];
    for (int b = 0; b < sn[0]; ++b) {
        int s = sn[1 + b], e = sn[2 + b], last = e - 1;
        if (e - s == 2) { /* a node's x and y, the commonest: both columns in one pass, no chunks */
            double y0 = work[s];
            work[last] -= Lx[Lp[s]] * y0;
            double y1 = work[last];
            const double *l0 = Lx + Lp[s] + 1, *l1 = Lx + Lp[last];
            const int *rows = Li + Lp[last];
            for (int t = 0, below = Lp[e] - Lp[last]; t < below; ++t) work[rows[t]] -= l0[t] * y0 + l1[t] * y1;
            continue;
        }
        for (int j = s; j < last; ++j) { /* within the supernode: the dense unit lower triangle */
            double yj = work[j];
            for (int i = j + 1; i < e; ++i) work[i] -= Lx[Lp[j] + (i - j - 1)] * yj;
        }
        const int *rows = Li + Lp[last];
        int below = Lp[e] - Lp[last];
        for (int c0 = 0; c0 < below; c0 += SOLVE_CHUNK) { /* column by column into acc: independent, vectorised */
            int m = below - c0 < SOLVE_CHUNK ? below - c0 : SOLVE_CHUNK;
            for (int t = 0; t < m; ++t) acc[t] = 0.0;
            for (int j = s; j < e; ++j) {
                const double *lx = Lx + Lp[j] + (last - j) + c0;
                double yj = work[j];
                for (int t = 0; t < m; ++t) acc[t] += lx[t] * yj;
            }
            for (int t = 0; t < m; ++t) work[rows[c0 + t]] -= acc[t];
        }
    }
}

static void backward_supernodal(const int *sn, const int *Lp, const int *Li, const double *Ur, const double *u_diag,
                                double *work) {
    double y[SOLVE_CHUNK], sums[SUPERNODE_MOST];
    for (int b = sn[0] - 1; b >= 0; --b) {
        int s = sn[1 + b], e = sn[2 + b], last = e - 1;
        const int *cols = Li + Lp[last];
        int beyond = Lp[e] - Lp[last];
        if (e - s == 2) { /* both rows in one pass over the unknowns beyond */
            const double *r0 = Ur + Lp[s] + 1, *r1 = Ur + Lp[last];
            double sum0 = 0.0, sum1 = 0.0;
            for (int t = 0; t < beyond; ++t) {
                double yt = work[cols[t]];
                sum0 += r0[t] * yt;
                sum1 += r1[t] * yt;
            }
            double y1 = (work[last] - sum1) / u_diag[last];
            work[last] = y1;
            sum0 += Ur[Lp[s]] * y1;
            work[s] = (work[s] - sum0) / u_diag[s];
            continue;
        }
        for (int i = s; i < e; ++i) sums[i - s] = 0.0;
        for (int c0 = 0; c0 < beyond; c0 += SOLVE_CHUNK) { /* the solved unknowns beyond, gathered once */
            int m = beyond - c0 < SOLVE_CHUNK ? beyond - c0 : SOLVE_CHUNK;
            for (int t = 0; t < m; ++t) y[t] = work[cols[c0 + t]];
            for (int i = s; i < e; ++i) {
                const double *row = Ur + Lp[i] + (last - i) + c0;
                double p0 = 0.0, p1 = 0.0, p2 = 0.0, p3 = 0.0; /* four partial sums, in a fixed order */
                int t = 0;
                for (; t + 4 <= m; t += 4) {
                    p0 += row[t] * y[t];
                    p1 += row[t + 1] * y[t + 1];
                    p2 += row[t + 2] * y[t + 2];
                    p3 += row[t + 3] * y[t + 3];
                }
                for (; t < m; ++t) p0 += row[t] * y[t];
                sums[i - s] += (p0 + p1) + (p2 + p3);
            }
        }
        for (int i = last; i >= s; --i) { /* within the supernode: the dense upper triangle */
            const double *row = Ur + Lp[i];
            double sum = sums[i - s];
            for (int k = i + 1; k < e; ++k) sum += row[k - i - 1] * work[k];
            work[i] = (work[i] - sum) / u_diag[i];
        }
    }
}

/* x[free[i]] = (A^-1 b)[free[i]] from the factors of the free block scaled, S A S with S = diag(scale),
 * Pr S A S Pc = L U (the kernel's own, femp_lu_factor, or scipy's splu): L unit lower and U upper, both
 * CSC and strict (no diagonal entries: lu.py strips SuperLU's); u_diag the diagonal of U; work has n entries.
 * With supernodes (sn not NULL: the kernel's own factors) U is read by rows from Ur. */
void femp_lu_solve(int n, const int *free_dofs, const double *scale, const int *perm_r, const int *perm_c,
                   const int *Lp, const int *Li, const double *Lx, const int *Up, const int *Ui, const double *Ux,
                   const double *u_diag, const int *sn, const double *Ur, const double *b, double *work, double *x) {
    for (int i = 0; i < n; ++i) work[perm_r[i]] = scale[i] * b[free_dofs[i]];
    if (sn != 0) {
        forward_supernodal(sn, Lp, Li, Lx, work);
        backward_supernodal(sn, Lp, Li, Ur, u_diag, work);
    } else {
        for (int j = 0; j < n; ++j) {
            double yj = work[j];
            for (int k = Lp[j]; k < Lp[j + 1]; ++k) work[Li[k]] -= Lx[k] * yj;
        }
        for (int j = n - 1; j >= 0; --j) {
            double yj = work[j] / u_diag[j];
            work[j] = yj;
            for (int k = Up[j]; k < Up[j + 1]; ++k) work[Ui[k]] -= Ux[k] * yj;
        }
    }
    for (int i = 0; i < n; ++i) x[free_dofs[i]] = scale[i] * work[perm_c[i]];
}

/* turn the vectors (vec[ix[i]], vec[iy[i]]) by the angle whose cosine and sine are c and s */
void femp_turn(int n, const int *ix, const int *iy, double c, double s, double *vec) {
    for (int i = 0; i < n; ++i) {
        double vx = vec[ix[i]], vy = vec[iy[i]];
        vec[ix[i]] = c * vx - s * vy;
        vec[iy[i]] = s * vx + c * vy;
    }
}

/* w -= corr over n entries; returns max |corr| over the first n_max entries, or -1 if any is not finite */
double femp_update(int n, int n_max, const double *corr, double *w) {
    double biggest = 0.0;
    for (int i = 0; i < n; ++i) {
        double ci = corr[i];
        if (!isfinite(ci)) return -1.0;
        w[i] -= ci;
        if (i < n_max && fabs(ci) > biggest) biggest = fabs(ci);
    }
    return biggest;
}

/* the smallest det F of the displacement u at the Q points */
double femp_min_det(int q, const int *indptr, const int *indices, const double *data, int nS, const double *u) {
    double smallest = INFINITY;
    for (int p = 0; p < q; ++p) {
        double g[4];
        gradients_at(p, q, indptr, indices, data, nS, u, g);
        double det = (1.0 + g[0]) * (1.0 + g[3]) - g[1] * g[2];
        if (det < smallest) smallest = det;
    }
    return smallest;
}

/* femp_strain_energy from C as femp_deformation keeps it (3 per point): the same sums, without the gradients */
double femp_strain_energy_of(int q, const double *C, const double *weights, double lame_lambda, double mu) {
    double total = 0.0;
    for (int p = 0; p < q; ++p) {
        double c00 = C[3 * p], c01 = C[3 * p + 1], c11 = C[3 * p + 2];
        double log_j = 0.5 * log(c00 * c11 - c01 * c01);
        total += weights[p] * (0.5 * mu * (c00 + c11 - 2.0 - 2.0 * log_j) + 0.5 * lame_lambda * log_j * log_j);
    }
    return total;
}

/* sum over the Q points of weight psi(C), psi the Neo-Hookean energy of material.py */
double femp_strain_energy(int q, const int *indptr, const int *indices, const double *data, int nS, const double *u,
                          const double *weights, double lame_lambda, double mu) {
    double total = 0.0;
    for (int p = 0; p < q; ++p) {
        double g[4];
        gradients_at(p, q, indptr, indices, data, nS, u, g);
        double f00 = 1.0 + g[0], f01 = g[1], f10 = g[2], f11 = 1.0 + g[3];
        double c00 = f00 * f00 + f10 * f10, c01 = f00 * f01 + f10 * f11, c11 = f01 * f01 + f11 * f11;
        double log_j = 0.5 * log(c00 * c11 - c01 * c01);
        total += weights[p] * (0.5 * mu * (c00 + c11 - 2.0 - 2.0 * log_j) + 0.5 * lame_lambda * log_j * log_j);
    }
    return total;
}

/* Equilibrate and factorise a matrix without pivoting on a fill structure computed beforehand
 * (fem/lu.py, `Symbolic`): A (n x n, CSC, rows sorted) scaled to S A S, S = diag(scale) with
 * scale[c] = 1 / sqrt(max |A[:, c]|), then permuted, B[pos[r], pos[c]] = (S A S)[r, c], and B = L U with L
 * unit lower (strict part, CSC, Lp/Li) and U upper (strict part CSC, Up/Ui, rows increasing; diagonal
 * u_diag), the pattern of L + U that of B's symbolic factorisation. Left-looking, one column at a time in
 * the dense scratch x (n entries, all zero on entry and on return). Returns 0, or j + 1 when column j's
 * pivot is under pivot_min times the largest entry below it (or not finite): SuperLU then pivots instead. */
double femp_lu_factor(int n, const int *Ap, const int *Ai, const double *Ax, const int *pos, const int *order,
                   const int *Lp, const int *Li, double *Lx, const int *Up, const int *Ui, double *Ux,
                   double *u_diag, double *scale, const int *u_rows, double *Ur, double pivot_min, double *x) {
    for (int c = 0; c < n; ++c) {
        double largest = 0.0;
        for (int k = Ap[c]; k < Ap[c + 1]; ++k)
            if (fabs(Ax[k]) > largest) largest = fabs(Ax[k]);
        scale[c] = 1.0 / sqrt(largest > 0.0 ? largest : 1.0);
    }
    for (int j = 0; j < n; ++j) {
        int c = order[j];
        for (int k = Ap[c]; k < Ap[c + 1]; ++k) x[pos[Ai[k]]] = Ax[k] * scale[Ai[k]] * scale[c];
        for (int t = Up[j]; t < Up[j + 1]; ++t) {
            int k = Ui[t];
            double ukj = x[k];
            Ux[t] = ukj;
            Ur[u_rows[t]] = ukj; /* U by rows, for the supernodal solve */
            x[k] = 0.0;
            for (int s = Lp[k]; s < Lp[k + 1]; ++s) x[Li[s]] -= Lx[s] * ukj;
        }
        double pivot = x[j], below = 0.0;
        x[j] = 0.0;
        for (int s = Lp[j]; s < Lp[j + 1]; ++s)
            if (fabs(x[Li[s]]) > below) below = fabs(x[Li[s]]);
        if (!(fabs(pivot) >= pivot_min * below) || pivot == 0.0 || !isfinite(pivot) || !isfinite(below)) {
            for (int i = 0; i < n; ++i) x[i] = 0.0;
            return (double)(j + 1);
        }
        u_diag[j] = pivot;
        for (int s = Lp[j]; s < Lp[j + 1]; ++s) {
            Lx[s] = x[Li[s]] / pivot;
            x[Li[s]] = 0.0;
        }
    }
    return 0.0;
}

/* The stress term's Jacobian in the end displacement u, the derivative of femp_stress_residual's sum, added
 * into the entries of a sparse matrix: at point p the local unknowns are its row's basis functions' x
 * components, then their y components (2 m of them, m the row's length, at most 32, the d/dy row holding
 * the same columns in the same order), and the entry of local pair (i, j) is out[slots[start[p] + 2 m i + j]].
 * Consecutive points with the same start (an element's) are summed in a local block first, which is then
 * added to out once.
 * dP/dF1 = 1/2 dF1 S + F_mid dS, dS = sum_g w_g s_g DS(C_g)[dC1], DS(C)[E] = lame_lambda/2 tr(C^-1 E) C^-1
 * - (lame_lambda/2 ln det C - mu) C^-1 E C^-1 and dC1 = dF1^T F1 + F1^T dF1. */
void femp_stress_tangent(int q, const int *indptr, const int *indices, const double *data, int nS, const double *u,
                         const double *F0, const double *C0, const double *weights, double lame_lambda, double mu,
                         int n_gauss, const double *gauss_s, const double *gauss_w, const int *start,
                         const int *slots, double *out) {
    double block[64 * 64];
    for (int p = 0; p < q; ++p) {
        double g[4];
        gradients_at(p, q, indptr, indices, data, nS, u, g);
        double f[2][2] = {{1.0 + g[0], g[1]}, {g[2], 1.0 + g[3]}};
        double c1[3] = {f[0][0] * f[0][0] + f[1][0] * f[1][0], f[0][0] * f[0][1] + f[1][0] * f[1][1],
                        f[0][1] * f[0][1] + f[1][1] * f[1][1]};
        const double *c0 = C0 + 3 * p;
        const double *f0 = F0 + 4 * p;
        double fm[2][2] = {{0.5 * (f0[0] + f[0][0]), 0.5 * (f0[1] + f[0][1])},
                           {0.5 * (f0[2] + f[1][0]), 0.5 * (f0[3] + f[1][1])}};
        /* the averaged S and, for each (k, L) of dF1, dS: ds[k][L][M][J] */
        double s_avg[2][2] = {{mu, 0.0}, {0.0, mu}};
        double ds[2][2][2][2] = {{{{0.0}}}};
        for (int i = 0; i < n_gauss; ++i) {
            double s = gauss_s[i], wg = gauss_w[i];
            double c00 = c0[0] + s * (c1[0] - c0[0]);
            double c01 = c0[1] + s * (c1[1] - c0[1]);
            double c11 = c0[2] + s * (c1[2] - c0[2]);
            double det = c00 * c11 - c01 * c01;
            double beta = lame_lambda * 0.5 * log(det) - mu;
            double ci[2][2] = {{c11 / det, -c01 / det}, {-c01 / det, c00 / det}};
            for (int a = 0; a < 2; ++a)
                for (int b = 0; b < 2; ++b) s_avg[a][b] += wg * beta * ci[a][b];
            for (int k = 0; k < 2; ++k)
                for (int l = 0; l < 2; ++l) {
                    /* E = dC1 for dF1 = e_k e_l^T: E[M][N] = d(N,l) F1[k][M] + d(M,l) F1[k][N] */
                    double e[2][2];
                    for (int m = 0; m < 2; ++m)
                        for (int n = 0; n < 2; ++n) e[m][n] = (n == l ? f[k][m] : 0.0) + (m == l ? f[k][n] : 0.0);
                    double tr = ci[0][0] * e[0][0] + ci[0][1] * e[1][0] + ci[1][0] * e[0][1] + ci[1][1] * e[1][1];
                    double cie[2][2], ciec[2][2];
                    for (int m = 0; m < 2; ++m)
                        for (int n = 0; n < 2; ++n) cie[m][n] = ci[m][0] * e[0][n] + ci[m][1] * e[1][n];
                    for (int m = 0; m < 2; ++m)
                        for (int n = 0; n < 2; ++n) ciec[m][n] = cie[m][0] * ci[0][n] + cie[m][1] * ci[1][n];
                    for (int m = 0; m < 2; ++m)
                        for (int n = 0; n < 2; ++n)
                            ds[k][l][m][n] += wg * s * (0.5 * lame_lambda * tr * ci[m][n] - beta * ciec[m][n]);
                }
        }
        /* a[i][J][k][L] = w dP_iJ / dF1_kL */
        double w = weights[p], a[2][2][2][2];
        for (int i = 0; i < 2; ++i)
            for (int J = 0; J < 2; ++J)
                for (int k = 0; k < 2; ++k)
                    for (int L = 0; L < 2; ++L) {
                        double v = (i == k ? 0.5 * s_avg[L][J] : 0.0);
                        v += fm[i][0] * ds[k][L][0][J] + fm[i][1] * ds[k][L][1][J];
                        a[i][J][k][L] = w * v;
                    }
        int m = indptr[p + 1] - indptr[p];
        const double *gx = data + indptr[p], *gy = data + indptr[q + p];
        if (p == 0 || start[p] != start[p - 1])
            for (int t = 0; t < 4 * m * m; ++t) block[t] = 0.0;
        for (int ia = 0; ia < 2 * m; ++ia) {
            int i = ia / m, ai = ia % m;
            /* b[k][L] = sum_J g_aJ a[i][J][k][L] */
            double b[2][2];
            for (int k = 0; k < 2; ++k)
                for (int L = 0; L < 2; ++L) b[k][L] = gx[ai] * a[i][0][k][L] + gy[ai] * a[i][1][k][L];
            for (int jb = 0; jb < 2 * m; ++jb) {
                int k = jb / m, bj = jb % m;
                block[2 * m * ia + jb] += b[k][0] * gx[bj] + b[k][1] * gy[bj];
            }
        }
        if (p == q - 1 || start[p + 1] != start[p]) {
            const int *slot = slots + start[p];
            for (int t = 0; t < 4 * m * m; ++t) out[slot[t]] += block[t];
        }
    }
}

/* The iterations with a held Jacobian are a fixed-point map g(x) = x - corr(x) that contracts linearly;
 * the Anderson step combines the last iterates: x+ = g - sum_j gamma_j dg_j, with dg_j the differences of
 * the last `kept` g and gamma minimising |f - sum_j gamma_j df_j| over the displacements, f = -corr and df_j
 * its differences. Depth 1 is the secant step, gamma = (df . f) / (df . df). The normal equations are
 * solved by LDL^T; a difference whose pivot falls under ANDERSON_PIVOT of its own square (nearly a
 * combination of the newer ones) ends the combination there. Returns the correction's largest
 * displacement entry as femp_update does (-1 if not finite). A combination with a coefficient beyond
 * SECANT_LARGEST (a contraction slower than 0.99, or none) is not taken. */
#define SECANT_LARGEST 100.0
#define ANDERSON_MOST 4
#define ANDERSON_PIVOT 1e-10
static double dot(int n, const double *a, const double *b) {
    double sum = 0.0;
    for (int i = 0; i < n; ++i) sum += a[i] * b[i];
    return sum;
}

/* shift the kept differences one place older and put the newest, f - f_last and g - g_last, first */
static void anderson_push(struct femp_iteration *it, const double *corr, const double *g) {
    int n = it->n_disp, size = it->size, most = it->depth;
    int kept = it->kept < most ? it->kept + 1 : most;
    for (int j = kept - 1; j > 0; --j) {
        for (int i = 0; i < n; ++i) it->df[j * n + i] = it->df[(j - 1) * n + i];
        for (int i = 0; i < size; ++i) it->dg[j * size + i] = it->dg[(j - 1) * size + i];
        for (int k = kept - 1; k > 0; --k) it->gram[j * ANDERSON_MOST + k] = it->gram[(j - 1) * ANDERSON_MOST + k - 1];
    }
    for (int i = 0; i < n; ++i) it->df[i] = -corr[i] - it->f_last[i];
    for (int i = 0; i < size; ++i) it->dg[i] = g[i] - it->g_last[i];
    for (int k = 0; k < kept; ++k) it->gram[k] = it->gram[k * ANDERSON_MOST] = dot(n, it->df, it->df + k * n);
    it->kept = kept;
}

/* gamma of the kept differences (how many it uses: fewer where a pivot fails) */
static int anderson_gamma(const struct femp_iteration *it, const double *corr, double *gamma) {
    int n = it->n_disp, m = it->kept;
    double L[ANDERSON_MOST][ANDERSON_MOST], d[ANDERSON_MOST], y[ANDERSON_MOST];
    for (int j = 0; j < m; ++j) {
        double num = 0.0;
        const double *df = it->df + j * n;
        for (int i = 0; i < n; ++i) num += df[i] * -corr[i];
        y[j] = num;
    }
    for (int j = 0; j < m; ++j) {
        double dj = it->gram[j * ANDERSON_MOST + j];
        for (int k = 0; k < j; ++k) dj -= L[j][k] * L[j][k] * d[k];
        if (!(dj > ANDERSON_PIVOT * it->gram[j * ANDERSON_MOST + j])) {
            m = j;
            break;
        }
        d[j] = dj;
        for (int r = j + 1; r < m; ++r) {
            double v = it->gram[r * ANDERSON_MOST + j];
            for (int k = 0; k < j; ++k) v -= L[r][k] * L[j][k] * d[k];
            L[r][j] = v / dj;
        }
    }
    for (int j = 0; j < m; ++j)
        for (int k = 0; k < j; ++k) y[j] -= L[j][k] * y[k];
    for (int j = m - 1; j >= 0; --j) {
        gamma[j] = y[j] / d[j];
        for (int k = j + 1; k < m; ++k) gamma[j] -= L[k][j] * gamma[k];
    }
    for (int j = 0; j < m; ++j)
        if (!(fabs(gamma[j]) <= SECANT_LARGEST)) return 0;
    return m;
}

static double secant_step(struct femp_iteration *it) {
    int size = it->size, n = it->n_disp;
    double *w = it->w, *f_last = it->f_last, *g_last = it->g_last;
    const double *corr = it->corr;
    double biggest = femp_update(size, n, corr, w), gamma[ANDERSON_MOST];
    if (biggest < 0.0) return biggest;
    int m = 0;
    if (it->has_last) {
        anderson_push(it, corr, w);
        m = anderson_gamma(it, corr, gamma);
    } else {
        it->kept = 0;
    }
    for (int i = 0; i < n; ++i) f_last[i] = -corr[i];
    for (int i = 0; i < size; ++i) g_last[i] = w[i];
    for (int j = 0; j < m; ++j) {
        const double *dg = it->dg + j * size;
        for (int i = 0; i < size; ++i) w[i] -= gamma[j] * dg[i];
    }
    it->has_last = 1;
    return biggest;
}

static void csr_axpy(const struct femp_csr *m, double a, const double *x, double *out) {
    femp_csr_axpy(m->n, m->indptr, m->indices, m->data, a, x, out);
}

/* M of struct femp_low_rank at the iterate w, into lr->K, the normals turned into the held frame by the angle
 * whose cosine and sine are cs and sn; 0 where no listed point is pushed (no update) */
static int low_rank_prepare(const struct femp_iteration *it, double cs, double sn) {
    struct femp_low_rank *lr = it->low_rank;
    int m = lr->m, n = lr->n_points, pushed = 0;
    double *K = lr->K, *B = lr->B, *a = lr->y;
    if (!femp_rigid_contact_stiffness(it->contact, it->w, n, lr->c, lr->gx, lr->gy)) return 0;
    for (int i = 0; i < m * m; ++i) K[i] = 0.0;
    for (int j = 0; j < n; ++j) {
        double cj = lr->c[j];
        if (!(cj > 0.0)) continue;
        pushed = 1;
        double tx = cs * lr->gx[j] + sn * lr->gy[j], ty = cs * lr->gy[j] - sn * lr->gx[j];
        for (int r = 0; r < m; ++r) a[r] = tx * lr->ex[(long)j * m + r] + ty * lr->ey[(long)j * m + r];
        for (int r = 0; r < m; ++r)
            for (int q = 0; q < m; ++q) K[r * m + q] += cj * a[r] * a[q];
    }
    if (!pushed) return 0;
    for (int r = 0; r < m; ++r) /* B = I + K S */
        for (int q = 0; q < m; ++q) {
            double sum = r == q ? 1.0 : 0.0;
            for (int k = 0; k < m; ++k) sum += K[r * m + k] * lr->S[k * m + q];
            B[r * m + q] = sum;
        }
    for (int col = 0; col < m; ++col) { /* B M = K by elimination with partial pivoting, M over K */
        int p = col;
        for (int r = col + 1; r < m; ++r)
            if (fabs(B[r * m + col]) > fabs(B[p * m + col])) p = r;
        if (!(fabs(B[p * m + col]) > 0.0)) return 0;
        if (p != col)
            for (int q = 0; q < m; ++q) {
                double t = B[p * m + q];
                B[p * m + q] = B[col * m + q], B[col * m + q] = t;
                t = K[p * m + q];
                K[p * m + q] = K[col * m + q], K[col * m + q] = t;
            }
        for (int r = col + 1; r < m; ++r) {
            double f = B[r * m + col] / B[col * m + col];
            if (f == 0.0) continue;
            for (int q = col; q < m; ++q) B[r * m + q] -= f * B[col * m + q];
            for (int q = 0; q < m; ++q) K[r * m + q] -= f * K[col * m + q];
        }
    }
    for (int r = m - 1; r >= 0; --r)
        for (int q = 0; q < m; ++q) {
            double sum = K[r * m + q];
            for (int k = r + 1; k < m; ++k) sum -= B[r * m + k] * K[k * m + q];
            K[r * m + q] = sum / B[r * m + r];
        }
    return 1;
}

/* z -= G M z[dofs] (M in lr->K, low_rank_prepare) */
static void low_rank_update(const struct femp_iteration *it, double *z) {
    const struct femp_low_rank *lr = it->low_rank;
    int m = lr->m, size = it->size;
    double *zf = lr->y, *y = lr->y + m;
    for (int j = 0; j < m; ++j) zf[j] = z[lr->dofs[j]];
    for (int r = 0; r < m; ++r) y[r] = dot(m, lr->K + (long)r * m, zf);
    for (int j = 0; j < m; ++j) {
        const double *g = lr->G + (long)j * size;
        double yj = y[j];
        for (int i = 0; i < size; ++i) z[i] -= g[i] * yj;
    }
}

/* corr = Q(d) A^-1 Q(-d) res (with turn; A^-1 res without), Q(d) turning the pairs (ix, iy) by the angle d
 * (cos d = c, sin d = s), A^-1 updated for the contact between the solve and the turn back where `update` is
 * given (low_rank_update); turned is scratch of the size of res */
static void held_frame_solve(const struct femp_factors *f, int nturn, const int *ix, const int *iy, int turn,
                             double c, double s, const double *res, double *turned, double *corr, int size,
                             const struct femp_iteration *update) {
    const double *rhs = res;
    if (turn) {
        for (int i = 0; i < size; ++i) turned[i] = res[i];
        femp_turn(nturn, ix, iy, c, -s, turned);
        rhs = turned;
    }
    femp_lu_solve(f->n, f->free_dofs, f->scale, f->perm_r, f->perm_c, f->Lp, f->Li, f->Lx, f->Up, f->Ui, f->Ux,
                  f->u_diag, f->sn, f->Ur, rhs, f->work, corr);
    if (update) low_rank_update(update, corr);
    if (turn) femp_turn(nturn, ix, iy, c, s, corr);
}

/* corr = Q(d) A^-1 Q(-d) res, the held_frame_solve of the unfused path (fem/newton.py); the LU arguments as
 * femp_lu_solve's */
void femp_turned_solve(int nturn, const int *ix, const int *iy, double c, double s, int n, const int *free_dofs,
                       const double *scale, const int *perm_r, const int *perm_c, const int *Lp, const int *Li,
                       const double *Lx, const int *Up, const int *Ui, const double *Ux, const double *u_diag,
                       const int *sn, const double *Ur, const double *res, double *turned, double *work, double *corr,
                       int size) {
    struct femp_factors f = {n, free_dofs, scale, perm_r, perm_c, Lp, Li, Lx, Up, Ui, Ux, u_diag, sn, Ur, work};
    held_frame_solve(&f, nturn, ix, iy, 1, c, s, res, turned, corr, size, 0);
}

/* res_holds_contact: 1 if res holds the contact term, 0 if there is none, 2 to make the compiled rigid-wall
 * term here (fem/rigid_contact.py) */
/* One Newton iteration of the energy-momentum step form in a single call (fem/iteration.py fills the
 * struct): the residual's linear terms and stress term added to res (which holds the wall contact term, or is
 * overwritten), the correction of the held factors turned by the angle whose cosine and sine are c and s
 * (turn 0: not turned), and w -= the correction. The same operations in the same order as the separate
 * kernels above, so the results are the same bit for bit; what it saves is the Python between them. */
double femp_iterate(struct femp_iteration *it, int res_holds_contact, int turn, double c, double s) {
    int size = it->size;
    double *res = it->res;
    if (res_holds_contact == 2) res_holds_contact = femp_rigid_contact(it->contact, it->w, size, res);
    if (res_holds_contact)
        for (int i = 0; i < size; ++i) res[i] += it->constant[i];
    else
        for (int i = 0; i < size; ++i) res[i] = it->constant[i];
    for (int i = 0; i < size; ++i) it->moved[i] = it->w[i] - it->wv[i];
    csr_axpy(&it->mass, it->inertia, it->moved, res);
    csr_axpy(&it->hinge, 1.0, it->w, res);
    if (it->half_torque != 0.0) csr_axpy(&it->torque, it->half_torque, it->w, res);
    for (int b = 0; b < it->n_bodies; ++b) {
        const struct femp_body *y = &it->bodies[b];
        femp_stress_residual(y->q, y->indptr, y->indices, y->data, it->nS, it->w, y->F0, y->C0, y->weights, y->lame_lambda,
                             y->mu, y->n_gauss, y->gauss_s, y->gauss_w, res);
    }
    int update = it->low_rank != 0 && it->contact != 0 && low_rank_prepare(it, c, s);
    held_frame_solve(&it->lu, it->nturn, it->ix, it->iy, turn, c, s, res, it->turned, it->corr, size,
                     update ? it : 0);
    return secant_step(it);
}
