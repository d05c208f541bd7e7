/* The FE step form's stress term at its integration points, as one loop (loaded by native.py).
 *
 * The same computation as ElasticTerms in models/fem_residual.py with
 * material_points.py: the deformation gradients F0 (step start) and F1 (step
 * end) at Q points from the sparse gradient matrix G of the scalar basis
 * (CSR, 2Q rows: d/dx at the points, then d/dy), the discrete-gradient second
 * Piola-Kirchhoff stress averaged along C0 -> C1 by a Gauss rule, P = F_mid S,
 * and the residual G^T (weight P) added to out. Plain C, no Python API: it is
 * called through ctypes.
 */
#include <math.h>

/* grad[p] = (du_x/dx, du_x/dy, du_y/dx, du_y/dy) at point p; u = (u_x (nS), u_y (nS)) */
static void gradients_at(int p, int q, const int *indptr, const int *indices, const double *data, int nS,
                         const double *u, double g[4]) {
    g[0] = g[1] = g[2] = g[3] = 0.0;
    for (int k = indptr[p]; k < indptr[p + 1]; ++k) {
        g[0] += data[k] * u[indices[k]];
        g[2] += data[k] * u[nS + indices[k]];
    }
    for (int k = indptr[q + p]; k < indptr[q + p + 1]; ++k) {
        g[1] += data[k] * u[indices[k]];
        g[3] += data[k] * u[nS + indices[k]];
    }
}

/* F (4 per point: 00 01 10 11) and C = F^T F (3 per point: 00 01 11) of the displacement u */
void femp_deformation(int q, const int *indptr, const int *indices, const double *data, int nS, const double *u,
                      double *F, double *C) {
    for (int p = 0; p < q; ++p) {
        double g[4];
        gradients_at(p, q, indptr, indices, data, nS, u, g);
        double f00 = 1.0 + g[0], f01 = g[1], f10 = g[2], f11 = 1.0 + g[3];
        F[4 * p] = f00;
        F[4 * p + 1] = f01;
        F[4 * p + 2] = f10;
        F[4 * p + 3] = f11;
        C[3 * p] = f00 * f00 + f10 * f10;
        C[3 * p + 1] = f00 * f01 + f10 * f11;
        C[3 * p + 2] = f01 * f01 + f11 * f11;
    }
}

/* out[0:2 nS] += G^T (weights P(F0, F1(u))), the stress term's residual at the end displacement u */
void femp_stress_residual(int q, const int *indptr, const int *indices, const double *data, int nS,
                          const double *u, const double *F0, const double *C0, const double *weights, double lam,
                          double mu, int n_gauss, const double *gauss_s, const double *gauss_w, double *out) {
    for (int p = 0; p < q; ++p) {
        double g[4];
        gradients_at(p, q, indptr, indices, data, nS, u, g);
        double f00 = 1.0 + g[0], f01 = g[1], f10 = g[2], f11 = 1.0 + g[3];
        double c1[3] = {f00 * f00 + f10 * f10, f00 * f01 + f10 * f11, f01 * f01 + f11 * f11};
        const double *c0 = C0 + 3 * p;
        /* S = mu I + (lam/2 ln det C - mu) C^-1, averaged over the Gauss points of C0 -> C1 */
        double a00 = 0.0, a01 = 0.0, a11 = 0.0;
        for (int i = 0; i < n_gauss; ++i) {
            double s = gauss_s[i];
            double c00 = c0[0] + s * (c1[0] - c0[0]);
            double c01 = c0[1] + s * (c1[1] - c0[1]);
            double c11 = c0[2] + s * (c1[2] - c0[2]);
            double det = c00 * c11 - c01 * c01;
            double scale = gauss_w[i] * (lam * 0.5 * log(det) - mu) / det;
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
        for (int k = indptr[p]; k < indptr[p + 1]; ++k) {
            out[indices[k]] += data[k] * p00;
            out[nS + indices[k]] += data[k] * p10;
        }
        for (int k = indptr[q + p]; k < indptr[q + p + 1]; ++k) {
            out[indices[k]] += data[k] * p01;
            out[nS + indices[k]] += data[k] * p11;
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

/* x[free[i]] = (A^-1 b)[free[i]] from SuperLU's factors of the free block scaled, S A S with S = diag(scale),
 * Pr S A S Pc = L U (scipy's splu): L unit lower and U upper, both CSC; u_diag the diagonal of U; work has
 * n entries */
void femp_lu_solve(int n, const int *free_dofs, const double *scale, const int *perm_r, const int *perm_c,
                   const int *Lp, const int *Li, const double *Lx, const int *Up, const int *Ui, const double *Ux,
                   const double *u_diag, const double *b, double *work, double *x) {
    for (int i = 0; i < n; ++i) work[perm_r[i]] = scale[i] * b[free_dofs[i]];
    for (int j = 0; j < n; ++j) {
        double yj = work[j];
        for (int k = Lp[j]; k < Lp[j + 1]; ++k)
            if (Li[k] > j) work[Li[k]] -= Lx[k] * yj;
    }
    for (int j = n - 1; j >= 0; --j) {
        double yj = work[j] / u_diag[j];
        work[j] = yj;
        for (int k = Up[j]; k < Up[j + 1]; ++k)
            if (Ui[k] < j) work[Ui[k]] -= Ux[k] * yj;
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

/* corr = Q(d) A^-1 Q(-d) res, Q(d) turning the pairs (ix, iy) by the angle d (cos d = c, sin d = s);
 * the LU arguments as femp_lu_solve's; turned is scratch of the size of res */
void femp_turned_solve(int nturn, const int *ix, const int *iy, double c, double s, int n, const int *free_dofs,
                       const double *scale, const int *perm_r, const int *perm_c, const int *Lp, const int *Li,
                       const double *Lx, const int *Up, const int *Ui, const double *Ux, const double *u_diag,
                       const double *res, double *turned, double *work, double *corr, int size) {
    for (int i = 0; i < size; ++i) turned[i] = res[i];
    femp_turn(nturn, ix, iy, c, -s, turned);
    femp_lu_solve(n, free_dofs, scale, perm_r, perm_c, Lp, Li, Lx, Up, Ui, Ux, u_diag, turned, work, corr);
    femp_turn(nturn, ix, iy, c, s, corr);
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

/* sum over the Q points of weight psi(C), psi the Neo-Hookean energy of material.py */
double femp_strain_energy(int q, const int *indptr, const int *indices, const double *data, int nS, const double *u,
                          const double *weights, double lam, double mu) {
    double total = 0.0;
    for (int p = 0; p < q; ++p) {
        double g[4];
        gradients_at(p, q, indptr, indices, data, nS, u, g);
        double f00 = 1.0 + g[0], f01 = g[1], f10 = g[2], f11 = 1.0 + g[3];
        double c00 = f00 * f00 + f10 * f10, c01 = f00 * f01 + f10 * f11, c11 = f01 * f01 + f11 * f11;
        double log_j = 0.5 * log(c00 * c11 - c01 * c01);
        total += weights[p] * (0.5 * mu * (c00 + c11 - 2.0 - 2.0 * log_j) + 0.5 * lam * log_j * log_j);
    }
    return total;
}
