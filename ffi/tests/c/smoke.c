/*
 * C client of the sparsemor C ABI, driven by tests/c_client.rs.
 *
 *   smoke FIXTURE OUTPUT
 *
 * FIXTURE (written by the Rust test; little-endian u64 / f64):
 *   "SMORFIX1", n,
 *   M: nnz, col_ptr[n+1], row_idx[nnz], values[nnz]   (full symmetric storage)
 *   K: same
 *   rayleigh alpha, beta, n_nodes, xyz[3 n_nodes], dofs_per_node,
 *   n_in, inputs[], n_out, outputs[], band_lo, band_hi,
 *   threads, interface_plus_k, n_reference, serep_modes, n_eval, eval_freqs[]
 *
 * The program builds the model from these arrays (M in full storage, K as its lower triangle
 * to exercise SPARSEMOR_STORAGE_LOWER), reduces it by line-fitting and SEREP, checks the
 * error paths it can reach (unsupported tolerance, cancellation, short buffers, V not kept,
 * fit report of a SEREP ROM), and writes to OUTPUT for each ROM:
 *   n, p, q, N (u64), Mr, Dr, Kr, Br, Cr, V (column-major f64), n_ref (u64), ref_freqs[],
 *   eps_elastic[n_eval], eps_total[n_eval]
 * The Rust test compares these bit for bit with the Rust API's results.
 */
#include "sparsemor.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void die(const char *what)
{
    fprintf(stderr, "smoke.c: %s\n", what);
    exit(2);
}

/* Prints the failing call, its status and the library's message, then exits. */
static void fail(const char *call, SparsemorStatus st)
{
    size_t len = sparsemor_last_error_length();
    char *msg = (char *)malloc(len ? len : 1);
    if (!msg)
        die("out of memory");
    msg[0] = '\0';
    if (len)
        sparsemor_last_error_message(msg, len);
    fprintf(stderr, "smoke.c: %s failed with status %d: %s\n", call, (int)st, msg);
    free(msg);
    exit(1);
}

#define CHECK(call)                                                                            \
    do {                                                                                       \
        SparsemorStatus st_ = (call);                                                          \
        if (st_ != SPARSEMOR_STATUS_OK)                                                        \
            fail(#call, st_);                                                                  \
    } while (0)

/* Expects `call` to fail with `want` and a non-empty message. */
#define EXPECT_STATUS(call, want)                                                              \
    do {                                                                                       \
        SparsemorStatus st_ = (call);                                                          \
        if (st_ != (want)) {                                                                   \
            fprintf(stderr, "smoke.c: %s returned %d, expected %d\n", #call, (int)st_,         \
                    (int)(want));                                                              \
            exit(1);                                                                           \
        }                                                                                      \
        if (sparsemor_last_error_length() < 2) {                                               \
            fprintf(stderr, "smoke.c: %s failed without a message\n", #call);                  \
            exit(1);                                                                           \
        }                                                                                      \
        print_last_error(#want);                                                               \
    } while (0)

static void print_last_error(const char *what)
{
    char buf[512];
    SparsemorStatus st = sparsemor_last_error_message(buf, sizeof buf);
    if (st != SPARSEMOR_STATUS_OK && st != SPARSEMOR_STATUS_BUFFER_TOO_SMALL)
        die("sparsemor_last_error_message failed");
    printf("expected %s: %s\n", what, buf);
}

/* ---- fixture reading ---------------------------------------------------------------- */

static FILE *fixture;

static uint64_t read_u64(void)
{
    uint64_t v;
    if (fread(&v, sizeof v, 1, fixture) != 1)
        die("fixture truncated");
    return v;
}

static double read_f64(void)
{
    double v;
    if (fread(&v, sizeof v, 1, fixture) != 1)
        die("fixture truncated");
    return v;
}

static void *xmalloc(size_t bytes)
{
    void *p = malloc(bytes ? bytes : 1);
    if (!p)
        die("out of memory");
    return p;
}

static size_t *read_index_array(size_t len)
{
    size_t *a = (size_t *)xmalloc(len * sizeof *a);
    size_t i;
    for (i = 0; i < len; i++)
        a[i] = (size_t)read_u64();
    return a;
}

static double *read_f64_array(size_t len)
{
    double *a = (double *)xmalloc(len * sizeof *a);
    size_t i;
    for (i = 0; i < len; i++)
        a[i] = read_f64();
    return a;
}

typedef struct {
    size_t nnz;
    size_t *col_ptr;
    size_t *row_idx;
    double *values;
} Csc;

static Csc read_csc(size_t n)
{
    Csc c;
    c.nnz = (size_t)read_u64();
    c.col_ptr = read_index_array(n + 1);
    c.row_idx = read_index_array(c.nnz);
    c.values = read_f64_array(c.nnz);
    return c;
}

/* The lower triangle (row >= column) of a full-storage CSC matrix. */
static Csc lower_triangle(const Csc *a, size_t n)
{
    Csc l;
    size_t j, p, k = 0;
    l.col_ptr = (size_t *)xmalloc((n + 1) * sizeof(size_t));
    l.row_idx = (size_t *)xmalloc(a->nnz * sizeof(size_t));
    l.values = (double *)xmalloc(a->nnz * sizeof(double));
    l.col_ptr[0] = 0;
    for (j = 0; j < n; j++) {
        for (p = a->col_ptr[j]; p < a->col_ptr[j + 1]; p++) {
            if (a->row_idx[p] >= j) {
                l.row_idx[k] = a->row_idx[p];
                l.values[k] = a->values[p];
                k++;
            }
        }
        l.col_ptr[j + 1] = k;
    }
    l.nnz = k;
    return l;
}

static void free_csc(Csc *c)
{
    free(c->col_ptr);
    free(c->row_idx);
    free(c->values);
}

/* ---- output ------------------------------------------------------------------------- */

static FILE *out;

static void write_u64(uint64_t v)
{
    if (fwrite(&v, sizeof v, 1, out) != 1)
        die("write failed");
}

static void write_f64s(const double *v, size_t len)
{
    if (len && fwrite(v, sizeof *v, len, out) != len)
        die("write failed");
}

/* ---- progress callbacks --------------------------------------------------------------- */

typedef struct {
    size_t calls;
    size_t last_total;
} Counter;

static int32_t count_progress(size_t done, size_t total, double freq_hz, void *user_data)
{
    Counter *c = (Counter *)user_data;
    (void)freq_hz;
    c->calls++;
    c->last_total = total;
    if (done > total)
        die("progress: done > total");
    return 0;
}

static int32_t cancel_at_once(size_t done, size_t total, double freq_hz, void *user_data)
{
    (void)done;
    (void)total;
    (void)freq_hz;
    (void)user_data;
    return 1;
}

/* ---- ROM output ----------------------------------------------------------------------- */

/* Copies one ROM matrix into a fresh buffer (size query first, then the copy). */
static double *copy_matrix(const SparsemorRom *rom, uint32_t which, size_t *len_out)
{
    size_t need = 0, rows = 0, cols = 0;
    double *buf;
    CHECK(sparsemor_rom_matrix_shape(rom, which, &rows, &cols));
    CHECK(sparsemor_rom_copy_matrix(rom, which, NULL, 0, &need));
    if (need != rows * cols)
        die("required length != rows * cols");
    buf = (double *)xmalloc(need * sizeof(double));
    if (need > 0) {
        size_t again = 0;
        EXPECT_STATUS(sparsemor_rom_copy_matrix(rom, which, buf, need - 1, &again),
                      SPARSEMOR_STATUS_BUFFER_TOO_SMALL);
        if (again != need)
            die("BUFFER_TOO_SMALL did not report the required length");
    }
    CHECK(sparsemor_rom_copy_matrix(rom, which, buf, need, NULL));
    *len_out = need;
    return buf;
}

static void report_rom(const SparsemorRom *rom, const char *name, const SparsemorModel *model,
                       const double *eval, size_t n_eval)
{
    static const uint32_t ids[] = {SPARSEMOR_MATRIX_MR, SPARSEMOR_MATRIX_DR, SPARSEMOR_MATRIX_KR,
                                   SPARSEMOR_MATRIX_BR, SPARSEMOR_MATRIX_CR, SPARSEMOR_MATRIX_V};
    size_t order, p, q, n_full, i, count, n_ref = 0;
    double *eps_el = (double *)xmalloc(n_eval * sizeof(double));
    double *eps_tot = (double *)xmalloc(n_eval * sizeof(double));
    double *ref, max_el = 0.0, max_tot = 0.0;
    SparsemorDefiniteness md, kd;

    CHECK(sparsemor_rom_order(rom, &order));
    CHECK(sparsemor_rom_n_inputs(rom, &p));
    CHECK(sparsemor_rom_n_outputs(rom, &q));
    CHECK(sparsemor_model_n(model, &n_full));
    printf("%s: order %zu, %zu inputs, %zu outputs\n", name, order, p, q);
    write_u64(order);
    write_u64(p);
    write_u64(q);
    write_u64(n_full);
    for (i = 0; i < sizeof ids / sizeof ids[0]; i++) {
        size_t len;
        double *m = copy_matrix(rom, ids[i], &len);
        write_f64s(m, len);
        free(m);
    }
    CHECK(sparsemor_rom_reference_frequencies(rom, NULL, 0, &n_ref));
    ref = (double *)xmalloc(n_ref * sizeof(double));
    CHECK(sparsemor_rom_reference_frequencies(rom, ref, n_ref, NULL));
    write_u64(n_ref);
    write_f64s(ref, n_ref);
    free(ref);

    CHECK(sparsemor_rom_definiteness(rom, &md, &kd));
    printf("%s: Mr SPD %d (eig %.3e..%.3e), Kr SPD %d (eig %.3e..%.3e)\n", name,
           md.positive_definite, md.min_eig, md.max_eig, kd.positive_definite, kd.min_eig,
           kd.max_eig);
    CHECK(sparsemor_rom_timing_count(rom, &count));
    for (i = 0; i < count; i++) {
        char label[128];
        size_t need;
        double secs;
        CHECK(sparsemor_rom_timing(rom, i, label, sizeof label, &need, &secs));
        printf("%s: timing %s = %.4f s\n", name, label, secs);
    }
    CHECK(sparsemor_rom_warning_count(rom, &count));
    for (i = 0; i < count; i++) {
        size_t need = 0;
        char *w;
        CHECK(sparsemor_rom_warning(rom, i, NULL, 0, &need));
        w = (char *)xmalloc(need);
        CHECK(sparsemor_rom_warning(rom, i, w, need, NULL));
        printf("%s: warning: %s\n", name, w);
        free(w);
    }

    CHECK(sparsemor_rom_transfer_error(model, rom, eval, n_eval, eps_el, eps_tot));
    for (i = 0; i < n_eval; i++) {
        if (eps_el[i] > max_el)
            max_el = eps_el[i];
        if (eps_tot[i] > max_tot)
            max_tot = eps_tot[i];
    }
    printf("%s: max eps elastic %.3e, max eps total %.3e over %zu frequencies\n", name, max_el,
           max_tot, n_eval);
    write_f64s(eps_el, n_eval);
    write_f64s(eps_tot, n_eval);
    free(eps_el);
    free(eps_tot);
}

int main(int argc, char **argv)
{
    uint32_t major, minor, patch, abi;
    size_t n, n_nodes, dpn, n_in, n_out, threads, plus_k, n_ref, serep_c, n_eval;
    size_t *inputs, *outputs;
    double alpha, beta, band_lo, band_hi, *xyz, *eval;
    char magic[8];
    Csc m, k, k_lower;
    SparsemorCsc mc, kc;
    SparsemorModel *model = NULL;
    SparsemorOptions *opts = NULL;
    SparsemorRom *rom = NULL, *serep = NULL;
    Counter counter = {0, 0};
    SparsemorFitReport fit;
    double cond;
    int is_free = -1;

    if (argc != 3)
        die("usage: smoke FIXTURE OUTPUT");

    CHECK(sparsemor_version(&major, &minor, &patch, &abi));
    printf("sparsemor %u.%u.%u, ABI %u\n", major, minor, patch, abi);
    if (abi != SPARSEMOR_ABI_VERSION)
        die("ABI version of the library differs from the header's");

    fixture = fopen(argv[1], "rb");
    if (!fixture)
        die("cannot open the fixture");
    if (fread(magic, 1, 8, fixture) != 8 || memcmp(magic, "SMORFIX1", 8) != 0)
        die("not a fixture file");
    n = (size_t)read_u64();
    m = read_csc(n);
    k = read_csc(n);
    alpha = read_f64();
    beta = read_f64();
    n_nodes = (size_t)read_u64();
    xyz = read_f64_array(3 * n_nodes);
    dpn = (size_t)read_u64();
    n_in = (size_t)read_u64();
    inputs = read_index_array(n_in);
    n_out = (size_t)read_u64();
    outputs = read_index_array(n_out);
    band_lo = read_f64();
    band_hi = read_f64();
    threads = (size_t)read_u64();
    plus_k = (size_t)read_u64();
    n_ref = (size_t)read_u64();
    serep_c = (size_t)read_u64();
    n_eval = (size_t)read_u64();
    eval = read_f64_array(n_eval);
    fclose(fixture);

    /* M in full storage, K as its lower triangle */
    k_lower = lower_triangle(&k, n);
    mc.n = n;
    mc.nnz = m.nnz;
    mc.col_ptr = m.col_ptr;
    mc.row_idx = m.row_idx;
    mc.values = m.values;
    mc.storage = SPARSEMOR_STORAGE_FULL;
    kc.n = n;
    kc.nnz = k_lower.nnz;
    kc.col_ptr = k_lower.col_ptr;
    kc.row_idx = k_lower.row_idx;
    kc.values = k_lower.values;
    kc.storage = SPARSEMOR_STORAGE_LOWER;
    CHECK(sparsemor_model_new(&mc, &kc, NULL, alpha, beta, xyz, n_nodes, dpn, &model));
    /* the library copied everything: release the caller's arrays right away */
    free_csc(&m);
    free_csc(&k);
    free_csc(&k_lower);
    free(xyz);
    CHECK(sparsemor_model_is_free(model, &is_free));
    printf("model: N = %zu, free body %d\n", n, is_free);

    CHECK(sparsemor_options_new(&opts));
    EXPECT_STATUS(sparsemor_reduce_linefit(model, opts, NULL, NULL, &rom),
                  SPARSEMOR_STATUS_INVALID_ARGUMENT); /* no scene yet */
    if (rom != NULL)
        die("rom_out not NULL after a failure");
    CHECK(sparsemor_model_set_scene(model, inputs, n_in, outputs, n_out, band_lo, band_hi));
    CHECK(sparsemor_options_set_threads(opts, threads));
    CHECK(sparsemor_options_set_interface_outputs_plus(opts, plus_k));
    CHECK(sparsemor_options_set_reference_count(opts, n_ref));
    CHECK(sparsemor_options_set_keep_basis(opts, 1));

    /* tolerance-driven sampling: the library chooses the frequencies */
    {
        int sampled = 0, converged = 0;
        size_t steps = 0, order = 0, facts = 0;
        CHECK(sparsemor_options_set_tolerance(opts, 5e-2));
        CHECK(sparsemor_reduce_linefit(model, opts, NULL, NULL, &rom));
        CHECK(sparsemor_rom_sampling_converged(rom, &sampled, &converged));
        CHECK(sparsemor_rom_step_count(rom, &steps));
        /* convergence itself is the library's business (tests/sampling.rs); here: the API */
        if (!sampled || (converged != 0 && converged != 1) || steps < 2)
            die("sampling loop: bad step log");
        CHECK(sparsemor_rom_step(rom, steps - 1, &order, NULL, NULL, NULL, NULL, &facts, NULL));
        if (order == 0 || facts == 0)
            die("empty sampling step");
        sparsemor_rom_free(rom);
        rom = NULL;
        CHECK(sparsemor_options_set_tolerance(opts, 0.0));
    }

    /* cancellation through the progress callback */
    EXPECT_STATUS(sparsemor_reduce_linefit(model, opts, cancel_at_once, NULL, &rom),
                  SPARSEMOR_STATUS_CANCELLED);
    if (rom != NULL)
        die("rom_out not NULL after cancellation");

    CHECK(sparsemor_reduce_linefit(model, opts, count_progress, &counter, &rom));
    if (counter.calls != n_ref || counter.last_total != n_ref)
        die("progress callback: expected one call per reference frequency");
    if (sparsemor_last_error_length() != 0)
        die("last error not cleared by a successful call");
    CHECK(sparsemor_rom_fit_report(rom, &fit));
    printf("linefit: cond %.3e raw / %.3e equilibrated, rank %zu, truncated %d, rows %zu, "
           "residual max %.3e mean %.3e at DoF %zu\n",
           fit.cond_raw, fit.cond_equilibrated, fit.rank, (int)fit.truncated, fit.rows,
           fit.residual_max, fit.residual_mean, fit.residual_argmax_dof);
    EXPECT_STATUS(sparsemor_rom_serep_cond(rom, &cond), SPARSEMOR_STATUS_NOT_AVAILABLE);

    out = fopen(argv[2], "wb");
    if (!out)
        die("cannot open the output");
    report_rom(rom, "linefit", model, eval, n_eval);

    CHECK(sparsemor_options_set_serep_modes(opts, serep_c));
    counter.calls = 0;
    CHECK(sparsemor_reduce_serep(model, opts, count_progress, &counter, &serep));
    if (counter.calls != 2)
        die("SEREP progress: expected 2 calls");
    CHECK(sparsemor_rom_serep_cond(serep, &cond));
    printf("serep: cond(U_cr) %.3e\n", cond);
    EXPECT_STATUS(sparsemor_rom_fit_report(serep, &fit), SPARSEMOR_STATUS_NOT_AVAILABLE);
    report_rom(serep, "serep", model, eval, n_eval);
    if (fclose(out) != 0)
        die("closing the output failed");

    /* V is only there when kept */
    CHECK(sparsemor_options_set_keep_basis(opts, 0));
    CHECK(sparsemor_rom_free(serep));
    CHECK(sparsemor_reduce_serep(model, opts, NULL, NULL, &serep));
    EXPECT_STATUS(sparsemor_rom_copy_matrix(serep, SPARSEMOR_MATRIX_V, NULL, 0, NULL),
                  SPARSEMOR_STATUS_NOT_AVAILABLE);

    CHECK(sparsemor_rom_free(rom));
    CHECK(sparsemor_rom_free(serep));
    CHECK(sparsemor_options_free(opts));
    CHECK(sparsemor_model_free(model));
    CHECK(sparsemor_model_free(NULL));
    free(inputs);
    free(outputs);
    free(eval);
    printf("smoke.c: OK\n");
    return 0;
}
