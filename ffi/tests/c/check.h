/* Helpers shared by the C test programs (define TEST_NAME, the program's name for its
 * messages, before including): failure counting, the library's last error, CHECK (exit on a
 * status other than OK), a dense complex solve for the references, and a ROM matrix copied out. */
#ifndef SPARSEMOR_TEST_CHECK_H
#define SPARSEMOR_TEST_CHECK_H

#include "sparsemor.h"

#include <complex.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int failures = 0;

static void fail(const char *what) {
    fprintf(stderr, TEST_NAME ": FAILED: %s\n", what);
    failures++;
}

static const char *last_error(void) {
    static char buf[4096];
    buf[0] = 0;
    sparsemor_last_error_message(buf, sizeof buf);
    return buf;
}

#define CHECK(call)                                                                          \
    do {                                                                                     \
        SparsemorStatus st_ = (call);                                                        \
        if (st_ != SPARSEMOR_STATUS_OK) {                                                    \
            fprintf(stderr, TEST_NAME ": %s -> %d: %s\n", #call, (int)st_, last_error());        \
            exit(1);                                                                         \
        }                                                                                    \
    } while (0)

/* solves a x = b in place (a n×n column-major, b n×m), partial pivoting; 0 if singular */
static int solve_complex(double complex *a, double complex *b, size_t n, size_t m) {
    size_t i, j, k, p;
    for (k = 0; k < n; k++) {
        p = k;
        for (i = k + 1; i < n; i++)
            if (cabs(a[i + k * n]) > cabs(a[p + k * n])) p = i;
        if (cabs(a[p + k * n]) == 0.0) return 0;
        if (p != k) {
            for (j = 0; j < n; j++) {
                double complex t = a[k + j * n];
                a[k + j * n] = a[p + j * n];
                a[p + j * n] = t;
            }
            for (j = 0; j < m; j++) {
                double complex t = b[k + j * n];
                b[k + j * n] = b[p + j * n];
                b[p + j * n] = t;
            }
        }
        for (i = k + 1; i < n; i++) {
            double complex f = a[i + k * n] / a[k + k * n];
            if (f == 0.0) continue;
            for (j = k; j < n; j++) a[i + j * n] -= f * a[k + j * n];
            for (j = 0; j < m; j++) b[i + j * n] -= f * b[k + j * n];
        }
    }
    for (j = 0; j < m; j++) {
        for (k = n; k-- > 0;) {
            double complex s = b[k + j * n];
            for (i = k + 1; i < n; i++) s -= a[k + i * n] * b[i + j * n];
            b[k + j * n] = s / a[k + k * n];
        }
    }
    return 1;
}

static double *rom_matrix(SparsemorRom *rom, uint32_t which, size_t *rows, size_t *cols) {
    size_t need = 0;
    double *v;
    CHECK(sparsemor_rom_matrix_shape(rom, which, rows, cols));
    CHECK(sparsemor_rom_copy_matrix(rom, which, NULL, 0, &need));
    v = malloc(sizeof(double) * (need ? need : 1));
    CHECK(sparsemor_rom_copy_matrix(rom, which, v, need, NULL));
    return v;
}

/* a refused call: the status and a message naming the argument */
static void expect_refused(SparsemorStatus st, SparsemorStatus want, const char *needle,
                           const char *what) {
    const char *msg = last_error();
    if (st != want || strstr(msg, needle) == NULL) {
        fprintf(stderr, TEST_NAME ": %s: status %d, message \"%s\" (want %d, \"%s\")\n", what,
                (int)st, msg, (int)want, needle);
        fail(what);
    } else {
        printf("refused (%s): %s\n", what, msg);
    }
}

#endif
