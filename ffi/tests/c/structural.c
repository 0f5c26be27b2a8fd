/*
 * Structural damping through the C ABI (docs/design.md §3.12, §6), self-contained: a
 * grounded spring-mass chain of N DoFs, undamped but for structural damping H = eta K + K4
 * with eta = 0.02 (sparsemor_model_set_structural_damping) and K4 a hysteretic damper
 * c (e_a - e_b)(e_a - e_b)^T given by its lower triangle. Line-fitting with a tolerance
 * (the library chooses the frequencies) must give a ROM with K4r whose transfer function
 * Hr = Cr (Kr + i K4r - w^2 Mr + i w Dr)^-1 Br matches the dense
 * H = C (K + i H - w^2 M)^-1 B computed here to <= 1e-6 relative at every reference
 * frequency. Bad arguments are refused by name; the damping split is reported.
 *
 * Built and run by tests/it/c_client.rs (also under valgrind when installed).
 * Prints "structural.c: OK" on success; exits 1 with the reason otherwise.
 */
#include "sparsemor.h"

#include <complex.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define TEST_NAME "structural.c"
#include "check.h"

#define N 30
#define TOL 1e-8
#define BAND_HI 2.0 /* Hz: the chain's resonances at 0.29, 0.90 and 1.51 Hz */
#define ETA 0.02
#define DAMP_A (N / 3)
#define DAMP_B (N / 2 + 3)
#define PI 3.14159265358979323846

/* a dense column-major n×n matrix as CSC (nonzeros only; the lower triangle if `lower`) */
typedef struct {
    size_t col_ptr[N + 1];
    size_t row_idx[N * N];
    double values[N * N];
    size_t nnz;
} Csc;

static void to_csc(const double *a, int lower, Csc *c) {
    size_t i, j;
    c->nnz = 0;
    c->col_ptr[0] = 0;
    for (j = 0; j < N; j++) {
        for (i = lower ? j : 0; i < N; i++) {
            if (a[i + j * N] != 0.0) {
                c->row_idx[c->nnz] = i;
                c->values[c->nnz] = a[i + j * N];
                c->nnz++;
            }
        }
        c->col_ptr[j + 1] = c->nnz;
    }
}

static SparsemorCsc view(const Csc *c, uint32_t storage) {
    SparsemorCsc v;
    v.n = N;
    v.nnz = c->nnz;
    v.col_ptr = c->col_ptr;
    v.row_idx = c->row_idx;
    v.values = c->values;
    v.storage = storage;
    return v;
}

/* h (q×p) = rows `outputs` of (k + i hs - w^2 m + i w d)^-1 [e_inputs], all n×n dense */
static void transfer(const double *m, const double *d, const double *k, const double *hs,
                     size_t n, const double *b, size_t p, const double *c, size_t q, double f,
                     double complex *h) {
    double w = 2.0 * PI * f;
    double complex *a = malloc(sizeof(double complex) * n * n);
    double complex *x = malloc(sizeof(double complex) * n * p);
    size_t i, j, l;
    for (i = 0; i < n * n; i++) a[i] = k[i] - w * w * m[i] + I * (w * d[i] + hs[i]);
    for (i = 0; i < n * p; i++) x[i] = b[i];
    if (!solve_complex(a, x, n, p)) fail("solve: singular");
    for (i = 0; i < q; i++)
        for (j = 0; j < p; j++) {
            double complex s = 0;
            for (l = 0; l < n; l++) s += c[i + l * q] * x[l + j * n];
            h[i + j * q] = s;
        }
    free(a);
    free(x);
}

static double rel(const double complex *a, const double complex *b, size_t len) {
    double num = 0, den = 0;
    size_t i;
    for (i = 0; i < len; i++) {
        num += pow(cabs(a[i] - b[i]), 2);
        den += pow(cabs(b[i]), 2);
    }
    return sqrt(num / den);
}

int main(void) {
    static double k[N * N], m[N * N], d[N * N], k4[N * N], hs[N * N], b[N * 2], c[3 * N];
    static Csc kc, mc, k4c;
    const size_t inputs[2] = {N - 1, N / 2}, outputs[3] = {N - 1, N / 2, N / 4};
    SparsemorModel *model = NULL;
    SparsemorOptions *opts = NULL;
    SparsemorRom *rom = NULL;
    SparsemorDampingInfo info;
    SparsemorCsc k4v, wrong;
    size_t i, j;
    double damper;

    /* a chain grounded at DoF 0: tridiagonal K and M */
    for (i = 0; i < N; i++) {
        m[i + i * N] = 4.0 + 0.1 * (double)i;
        k[i + i * N] = i + 1 < N ? 2.0e4 : 1.0e4;
        if (i + 1 < N) {
            m[i + (i + 1) * N] = m[(i + 1) + i * N] = 1.0;
            k[i + (i + 1) * N] = k[(i + 1) + i * N] = -1.0e4;
        }
    }
    damper = 0.1 * k[DAMP_A + DAMP_A * N];
    k4[DAMP_A + DAMP_A * N] = k4[DAMP_B + DAMP_B * N] = damper;
    k4[DAMP_A + DAMP_B * N] = k4[DAMP_B + DAMP_A * N] = -damper;
    for (i = 0; i < N * N; i++) hs[i] = ETA * k[i] + k4[i];
    for (j = 0; j < 2; j++) b[inputs[j] + j * N] = 1.0;
    for (i = 0; i < 3; i++) c[i + 3 * outputs[i]] = 1.0;
    to_csc(k, 0, &kc);
    to_csc(m, 0, &mc);
    to_csc(k4, 1, &k4c);
    {
        SparsemorCsc mv = view(&mc, SPARSEMOR_STORAGE_FULL);
        SparsemorCsc kv = view(&kc, SPARSEMOR_STORAGE_FULL);
        CHECK(sparsemor_model_new(&mv, &kv, NULL, 0.0, 0.0, NULL, 0, 0, &model));
    }
    CHECK(sparsemor_model_damping_info(model, &info));
    if (info.kind != SPARSEMOR_DAMPING_NONE) fail("an undamped model reports NONE");

    /* bad arguments, refused by name; the handle stays undamped */
    k4v = view(&k4c, SPARSEMOR_STORAGE_LOWER);
    expect_refused(sparsemor_model_set_structural_damping(model, -0.02, NULL),
                   SPARSEMOR_STATUS_INVALID_ARGUMENT, "eta = -0.02", "a negative eta");
    expect_refused(sparsemor_model_set_structural_damping(model, NAN, NULL),
                   SPARSEMOR_STATUS_INVALID_ARGUMENT, "eta = NaN", "a NaN eta");
    wrong = k4v;
    wrong.n = N - 1;
    wrong.nnz = k4c.col_ptr[N - 1];
    expect_refused(sparsemor_model_set_structural_damping(model, ETA, &wrong),
                   SPARSEMOR_STATUS_INVALID_ARGUMENT, "k4 (structural damping matrix K4) is",
                   "K4 of the wrong size");
    wrong = k4v;
    wrong.storage = SPARSEMOR_STORAGE_FULL; /* the lower triangle alone is not symmetric */
    expect_refused(sparsemor_model_set_structural_damping(model, ETA, &wrong),
                   SPARSEMOR_STATUS_INVALID_MODEL,
                   "k4: invalid model: structural damping matrix K4 is not symmetric",
                   "an unsymmetric K4");
    CHECK(sparsemor_model_damping_info(model, &info));
    if (info.kind != SPARSEMOR_DAMPING_NONE) fail("a refused call changed the model");

    CHECK(sparsemor_model_set_structural_damping(model, ETA, &k4v));
    CHECK(sparsemor_model_damping_info(model, &info));
    printf("damping: kind %u, alpha %g, beta %g, eta %g, gamma %g, remainder rank %zu on %zu "
           "DoFs\n",
           info.kind, info.alpha, info.beta, info.eta, info.gamma, info.remainder_rank,
           info.remainder_dofs);
    if (info.kind == SPARSEMOR_DAMPING_NONE) fail("structural damping reported as none");
    CHECK(sparsemor_model_set_scene(model, inputs, 2, outputs, 3, 0.0, BAND_HI));

    CHECK(sparsemor_options_new(&opts));
    CHECK(sparsemor_options_set_threads(opts, 1));
    CHECK(sparsemor_options_set_tolerance(opts, TOL));
    CHECK(sparsemor_reduce_linefit(model, opts, NULL, NULL, &rom));
    {
        size_t n, n2, p, q, r_, c_, n_ref = 0, f;
        int32_t has = -1, sampled = 0, converged = 0;
        double *mr = rom_matrix(rom, SPARSEMOR_MATRIX_MR, &n, &n2);
        double *dr = rom_matrix(rom, SPARSEMOR_MATRIX_DR, &r_, &c_);
        double *kr = rom_matrix(rom, SPARSEMOR_MATRIX_KR, &r_, &c_);
        double *k4r;
        double *br = rom_matrix(rom, SPARSEMOR_MATRIX_BR, &r_, &p);
        double *cr = rom_matrix(rom, SPARSEMOR_MATRIX_CR, &q, &c_);
        double *refs, *eps_el, *eps_tot, worst = 0.0, tol = 0, err = 0;
        size_t loop_factorizations = 0, in_all = 0;
        double complex hf[6], hr[6];
        CHECK(sparsemor_rom_has_structural_damping(rom, &has));
        if (has != 1) fail("the ROM has structural damping");
        k4r = rom_matrix(rom, SPARSEMOR_MATRIX_K4R, &r_, &c_);
        if (r_ != n || c_ != n) fail("K4r is n x n");
        if (n2 != n || p != 2 || q != 3) fail("ROM shape");
        CHECK(sparsemor_rom_sampling_converged(rom, &sampled, &converged));
        CHECK(sparsemor_rom_sampling_result(rom, &tol, &err, &loop_factorizations));
        CHECK(sparsemor_rom_factorizations_in_all(rom, &in_all));
        printf("line-fitting with tol %.0e: order %zu, converged %d, error reached %.2e, %zu "
               "factorizations (%zu in all)\n",
               tol, n, (int)converged, err, loop_factorizations, in_all);
        if (loop_factorizations < 1 || in_all < loop_factorizations)
            fail("every factorization of the run is counted, the loop's among them");
        if (!sampled || !converged) fail("the sampling loop did not reach its tolerance");
        CHECK(sparsemor_rom_reference_frequencies(rom, NULL, 0, &n_ref));
        refs = malloc(sizeof(double) * (n_ref ? n_ref : 1));
        eps_el = malloc(sizeof(double) * (n_ref ? n_ref : 1));
        eps_tot = malloc(sizeof(double) * (n_ref ? n_ref : 1));
        CHECK(sparsemor_rom_reference_frequencies(rom, refs, n_ref, NULL));
        for (f = 0; f < n_ref; f++) {
            double e;
            transfer(m, d, k, hs, N, b, 2, c, 3, refs[f], hf);
            transfer(mr, dr, kr, k4r, n, br, p, cr, q, refs[f], hr);
            e = rel(hr, hf, 6);
            if (e > worst) worst = e;
        }
        printf("%zu reference frequencies: ROM (with K4r) vs dense C A^-1 B, max %.2e\n", n_ref,
               worst);
        if (n_ref == 0 || !(worst <= 1e-6)) fail("the ROM misses H at its reference frequencies");
        /* and without its i K4r term it would miss by far */
        {
            static double zero[N * N];
            transfer(m, d, k, hs, N, b, 2, c, 3, refs[0], hf);
            transfer(mr, dr, kr, zero, n, br, p, cr, q, refs[0], hr);
            printf("%g Hz without i K4r: %.2e\n", refs[0], rel(hr, hf, 6));
            if (!(rel(hr, hf, 6) > 1e-3)) fail("K4r makes no difference");
        }
        CHECK(sparsemor_rom_transfer_error(model, rom, refs, n_ref, eps_el, eps_tot));
        worst = 0.0;
        for (f = 0; f < n_ref; f++)
            if (eps_el[f] > worst) worst = eps_el[f];
        printf("library eps at the reference frequencies: max %.2e\n", worst);
        if (!(worst <= 1e-6)) fail("library eps");
        free(mr);
        free(dr);
        free(kr);
        free(k4r);
        free(br);
        free(cr);
        free(refs);
        free(eps_el);
        free(eps_tot);
    }
    CHECK(sparsemor_rom_free(rom));
    CHECK(sparsemor_options_free(opts));
    CHECK(sparsemor_model_free(model));
    if (failures) return 1;
    printf("structural.c: OK\n");
    return 0;
}
