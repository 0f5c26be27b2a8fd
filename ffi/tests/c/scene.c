/*
 * A general scene through the C ABI (docs/design.md §3.11, §6), self-contained: a 3-D truss
 * lattice grounded at its base, a distributing remote point on its top face, an input that
 * is the point's x force plus a general load column of B, outputs that are a DoF, the
 * point's x motion and a general row of C. An exact line-fit (interface 2·p·z) must
 * reproduce C A^-1 B of the original model at its reference frequencies; A^-1 is a dense
 * complex solve here and the point's row is built from its definition (the weighted
 * least-squares rigid motion of its nodes). Bad arguments must be refused by name.
 *
 * Built and run by tests/it/c_client.rs (also under valgrind when installed).
 * Prints "scene.c: OK" on success; exits 1 with the reason otherwise.
 */
#include "sparsemor.h"

#include <complex.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define TEST_NAME "scene.c"
#include "check.h"

#define NX 2
#define NY 3
#define NZ 5
#define NODES (NX * NY * NZ)
#define N (3 * NODES)
#define BETA 1e-4
#define OUT_DOF 70
#define PI 3.14159265358979323846

/* a dense column-major matrix as full-storage CSC (nonzeros only) */
typedef struct {
    size_t col_ptr[N + 1];
    size_t row_idx[N * N];
    double values[N * N];
    size_t nnz;
} Csc;

static void to_csc(const double *a, size_t rows, size_t cols, Csc *c) {
    size_t i, j;
    c->nnz = 0;
    c->col_ptr[0] = 0;
    for (j = 0; j < cols; j++) {
        for (i = 0; i < rows; i++) {
            if (a[i + j * rows] != 0.0) {
                c->row_idx[c->nnz] = i;
                c->values[c->nnz] = a[i + j * rows];
                c->nnz++;
            }
        }
        c->col_ptr[j + 1] = c->nnz;
    }
}

/* G(r) = [I, -[r]x]: the translation of a node at offset r under the rigid motion (t, theta) */
static void rigid_rows(const double r[3], double g[3][6]) {
    memset(g, 0, sizeof(double) * 18);
    g[0][0] = g[1][1] = g[2][2] = 1.0;
    g[0][4] = r[2];
    g[0][5] = -r[1];
    g[1][3] = -r[2];
    g[1][5] = r[0];
    g[2][3] = r[1];
    g[2][4] = -r[0];
}

/* H = C (K - w^2 M + i w beta K)^-1 B, dense: c q×N, b N×p (column-major), h q×p */
static void dense_h(const double *k, const double *m, const double *b, size_t p,
                    const double *c, size_t q, double f, double complex *h) {
    double w = 2.0 * PI * f;
    double complex *a = malloc(sizeof(double complex) * N * N);
    double complex *x = malloc(sizeof(double complex) * N * p);
    size_t i, j, l;
    for (i = 0; i < (size_t)N * N; i++) a[i] = k[i] - w * w * m[i] + I * w * BETA * k[i];
    for (i = 0; i < (size_t)N * p; i++) x[i] = b[i];
    if (!solve_complex(a, x, N, p)) fail("dense solve: singular");
    for (i = 0; i < q; i++)
        for (j = 0; j < p; j++) {
            double complex s = 0;
            for (l = 0; l < N; l++) s += c[i + l * q] * x[l + j * N];
            h[i + j * q] = s;
        }
    free(a);
    free(x);
}

/* Hr = Cr (Kr - w^2 Mr + i w Dr)^-1 Br */
static void rom_h(const double *mr, const double *dr, const double *kr, const double *br,
                  const double *cr, size_t n, size_t p, size_t q, double f, double complex *h) {
    double w = 2.0 * PI * f;
    double complex *a = malloc(sizeof(double complex) * n * n);
    double complex *x = malloc(sizeof(double complex) * n * p);
    size_t i, j, l;
    for (i = 0; i < n * n; i++) a[i] = kr[i] - w * w * mr[i] + I * w * dr[i];
    for (i = 0; i < n * p; i++) x[i] = br[i];
    if (!solve_complex(a, x, n, p)) fail("ROM solve: singular");
    for (i = 0; i < q; i++)
        for (j = 0; j < p; j++) {
            double complex s = 0;
            for (l = 0; l < n; l++) s += cr[i + l * q] * x[l + j * n];
            h[i + j * q] = s;
        }
    free(a);
    free(x);
}

int main(void) {
    static double k[N * N], m[N * N], b[N * 2], c[3 * N], bcol[N], crow[N];
    static Csc kc, mc;
    static Csc bc, cc; /* the general column and row as sparse matrices */
    double xyz[NODES * 3], at[3] = {0, 0, 0};
    size_t top[NODES], n_top = 0, i, j, d, a_, b_;
    const double h = 0.02, hz = 0.05, ea = 2e5, mass = 0.01, ground = 1e7;
    SparsemorModel *model = NULL;
    SparsemorOptions *opts = NULL;
    SparsemorRom *rom = NULL;
    size_t index = 99;
    double freqs[2] = {300.0, 900.0}; /* between the modes at 118, 195, 411, 729, 1052 Hz */
    double wx[N];

    /* nodes on the grid, x fastest */
    for (i = 0; i < NODES; i++) {
        xyz[3 * i] = h * (double)(i % NX);
        xyz[3 * i + 1] = h * (double)((i / NX) % NY);
        xyz[3 * i + 2] = hz * (double)(i / (NX * NY));
    }
    /* bars between nodes at most one grid step apart in each direction */
    for (a_ = 0; a_ < NODES; a_++) {
        for (b_ = a_ + 1; b_ < NODES; b_++) {
            double dv[3], len = 0.0;
            int near = 1;
            for (d = 0; d < 3; d++) {
                dv[d] = xyz[3 * b_ + d] - xyz[3 * a_ + d];
                len += dv[d] * dv[d];
            }
            near = fabs(dv[0]) < 1.5 * h && fabs(dv[1]) < 1.5 * h && fabs(dv[2]) < 1.5 * hz;
            if (!near) continue;
            len = sqrt(len);
            for (i = 0; i < 3; i++)
                for (j = 0; j < 3; j++) {
                    double kij = ea / len * (dv[i] / len) * (dv[j] / len);
                    k[(3 * a_ + i) + (3 * a_ + j) * N] += kij;
                    k[(3 * b_ + i) + (3 * b_ + j) * N] += kij;
                    k[(3 * a_ + i) + (3 * b_ + j) * N] -= kij;
                    k[(3 * b_ + i) + (3 * a_ + j) * N] -= kij;
                }
        }
    }
    for (i = 0; i < NODES; i++) {
        for (d = 0; d < 3; d++) m[(3 * i + d) * (N + 1)] = mass;
        if (xyz[3 * i + 2] == 0.0)
            for (d = 0; d < 3; d++) k[(3 * i + d) * (N + 1)] += ground;
        if (xyz[3 * i + 2] > hz * (NZ - 1) - 1e-12) top[n_top++] = i;
    }
    to_csc(k, N, N, &kc);
    to_csc(m, N, N, &mc);
    {
        SparsemorCsc mv = {N, mc.nnz, mc.col_ptr, mc.row_idx, mc.values, SPARSEMOR_STORAGE_FULL};
        SparsemorCsc kv = {N, kc.nnz, kc.col_ptr, kc.row_idx, kc.values, SPARSEMOR_STORAGE_FULL};
        CHECK(sparsemor_model_new(&mv, &kv, NULL, 0.0, BETA, xyz, NODES, 3, &model));
    }

    /* the point: above the top face's centroid */
    for (i = 0; i < n_top; i++)
        for (d = 0; d < 3; d++) at[d] += xyz[3 * top[i] + d] / (double)n_top;
    at[2] += 0.01;
    expect_refused(sparsemor_model_add_remote_point(model, SPARSEMOR_POINT_DISTRIBUTING, at, top,
                                                    0, NULL, &index),
                   SPARSEMOR_STATUS_INVALID_ARGUMENT, "n_nodes = 0", "a point without nodes");
    if (index != 99) fail("index_out written on failure");
    CHECK(sparsemor_model_add_remote_point(model, SPARSEMOR_POINT_DISTRIBUTING, at, top, n_top,
                                           NULL, &index));
    if (index != 0) fail("first point index");

    /* its x row from the definition: x_ref = A^-1 sum G_i^T u_i, A = sum G_i^T G_i */
    {
        double a6[36] = {0}, g[3][6], r[3];
        double complex amat[36], e[6] = {1, 0, 0, 0, 0, 0};
        size_t s, t;
        for (i = 0; i < n_top; i++) {
            for (d = 0; d < 3; d++) r[d] = xyz[3 * top[i] + d] - at[d];
            rigid_rows(r, g);
            for (s = 0; s < 6; s++)
                for (t = 0; t < 6; t++)
                    for (d = 0; d < 3; d++) a6[s + 6 * t] += g[d][s] * g[d][t];
        }
        for (s = 0; s < 36; s++) amat[s] = a6[s];
        if (!solve_complex(amat, e, 6, 1)) fail("6x6 solve");
        memset(wx, 0, sizeof wx);
        for (i = 0; i < n_top; i++) {
            for (d = 0; d < 3; d++) r[d] = xyz[3 * top[i] + d] - at[d];
            rigid_rows(r, g);
            for (d = 0; d < 3; d++) {
                double v = 0;
                for (s = 0; s < 6; s++) v += creal(e[s]) * g[d][s];
                wx[3 * top[i] + d] = v;
            }
        }
    }

    /* a load column and an output row away from the point's nodes */
    memset(bcol, 0, sizeof bcol);
    memset(crow, 0, sizeof crow);
    bcol[40] = 0.5;
    bcol[47] = -1.25;
    bcol[55] = 2.0;
    bcol[58] = 0.75;
    crow[30] = 1.0;
    crow[31] = -0.4;
    crow[62] = 0.3;
    to_csc(bcol, N, 1, &bc);
    to_csc(crow, 1, N, &cc);
    /* dense B = [Wx^T, b] and C = [e_OUT; Wx; c] in the scene parts' order */
    for (i = 0; i < N; i++) {
        b[i] = wx[i];
        b[i + N] = bcol[i];
        c[0 + 3 * i] = (i == OUT_DOF) ? 1.0 : 0.0;
        c[1 + 3 * i] = wx[i];
        c[2 + 3 * i] = crow[i];
    }

    {
        size_t point_x = 6 * 0 + 0, bad_code = 6 * 1 + 0, out_dof = OUT_DOF;
        SparsemorSparse bsp = {N, 1, bc.nnz, bc.col_ptr, bc.row_idx, bc.values};
        SparsemorSparse bshort = {N - 1, 1, bc.nnz, bc.col_ptr, bc.row_idx, bc.values};
        SparsemorSparse csp = {1, N, cc.nnz, cc.col_ptr, cc.row_idx, cc.values};
        SparsemorScenePart in = {NULL, 0, &point_x, 1, &bsp};
        SparsemorScenePart out = {&out_dof, 1, &point_x, 1, &csp};
        SparsemorScenePart in_bad_shape = {NULL, 0, &point_x, 1, &bshort};
        SparsemorScenePart in_bad_code = {NULL, 0, &bad_code, 1, &bsp};
        size_t count = 0;
        expect_refused(sparsemor_model_set_scene_general(model, &in_bad_shape, &out, 0.0, 1000.0),
                       SPARSEMOR_STATUS_INVALID_ARGUMENT, "B must be N\xc3\x97p", "B with N - 1 rows");
        expect_refused(sparsemor_model_set_scene_general(model, &in_bad_code, &out, 0.0, 1000.0),
                       SPARSEMOR_STATUS_INVALID_ARGUMENT, "inputs.point_dofs[0] = 6", "a point DoF of a point not added");
        CHECK(sparsemor_model_set_scene_general(model, &in, &out, 0.0, 1000.0));
        CHECK(sparsemor_model_coordinate_count(model, &count));
        if (count != N) fail("a distributing point adds no DoF");
    }

    /* p = 2 inputs, z = 2 frequencies: interface 2 p z = 8 = 3 outputs + 5 */
    CHECK(sparsemor_options_new(&opts));
    CHECK(sparsemor_options_set_threads(opts, 1));
    CHECK(sparsemor_options_set_reference_frequencies(opts, freqs, 2));
    CHECK(sparsemor_options_set_interface_outputs_plus(opts, 5));
    CHECK(sparsemor_options_set_keep_basis(opts, 1));
    CHECK(sparsemor_reduce_linefit(model, opts, NULL, NULL, &rom));
    {
        size_t n, n2, p, q, vr, vc, r_, c_;
        double *mr = rom_matrix(rom, SPARSEMOR_MATRIX_MR, &n, &n2);
        double *dr = rom_matrix(rom, SPARSEMOR_MATRIX_DR, &r_, &c_);
        double *kr = rom_matrix(rom, SPARSEMOR_MATRIX_KR, &r_, &c_);
        double *br = rom_matrix(rom, SPARSEMOR_MATRIX_BR, &r_, &p);
        double *cr = rom_matrix(rom, SPARSEMOR_MATRIX_CR, &q, &c_);
        double *v = rom_matrix(rom, SPARSEMOR_MATRIX_V, &vr, &vc);
        double complex hf[6], hr[6];
        double eps_el[2], eps_tot[2], worst = 0.0;
        size_t f;
        SparsemorFitReport fit;
        if (n != 8 || n2 != 8 || p != 2 || q != 3) fail("ROM shape");
        CHECK(sparsemor_rom_fit_report(rom, &fit));
        printf("fit: cond %.2e (equilibrated %.2e), rank %zu of %zu rows, truncated %d\n",
               fit.cond_raw, fit.cond_equilibrated, fit.rank, fit.rows, fit.truncated);
        if (fit.truncated) fail("the fit was truncated: not an exact line-fit");
        if (vr != N || vc != n) fail("V is N x n in the original DoFs");
        for (f = 0; f < 2; f++) {
            double num = 0, den = 0, e;
            dense_h(k, m, b, 2, c, 3, freqs[f], hf);
            rom_h(mr, dr, kr, br, cr, n, p, q, freqs[f], hr);
            for (i = 0; i < 6; i++) {
                num += pow(cabs(hf[i] - hr[i]), 2);
                den += pow(cabs(hf[i]), 2);
            }
            e = sqrt(num / den);
            printf("%g Hz: ROM vs dense C A^-1 B of the original model: %.2e\n", freqs[f], e);
            if (e > worst) worst = e;
        }
        if (!(worst <= 1e-8)) fail("exact line-fit does not reproduce C A^-1 B");
        CHECK(sparsemor_rom_transfer_error(model, rom, freqs, 2, eps_el, eps_tot));
        printf("library eps at the reference frequencies: %.2e %.2e\n", eps_el[0], eps_el[1]);
        if (!(eps_el[0] <= 1e-8 && eps_el[1] <= 1e-8)) fail("library eps");
        free(mr);
        free(dr);
        free(kr);
        free(br);
        free(cr);
        free(v);
    }
    CHECK(sparsemor_rom_free(rom));
    CHECK(sparsemor_options_free(opts));
    CHECK(sparsemor_model_free(model));
    if (failures) return 1;
    printf("scene.c: OK\n");
    return 0;
}
