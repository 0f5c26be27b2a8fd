"""MKL PARDISO reference for `sparsemor bench sweep`: factors the same complex-symmetric
A(i omega) = K - omega^2 M + i omega (alpha M + beta K) with PARDISO, matrix type 6 (complex
symmetric), default iparm from pardisoinit (METIS ordering, Bunch-Kaufman pivoting with
perturbation), and times its phases 11 (analysis), 22 (factor) and 33 (solve) separately.

    python3 benches/pardiso_reference.py MODEL_DIR FREQ_HZ NRHS [THREADS]

MODEL_DIR is a sparsemor model directory with Rayleigh damping. PARDISO comes from the
`mkl_rt` library of the PyPI wheel `pypardiso` (called through ctypes, not through its
Python solver, which supports real matrices only). Prints one JSON line: n, threads, the
phase times (s; phase 22 twice, the second as "factor_s", the first as "factor_cold_s"),
nnz of the factor (iparm[17]), PARDISO's peak memory (KB, iparm[14]
and iparm[15] + iparm[16]) and the relative residual of the solve. Exit status 2 with a
message on stderr when pypardiso is not installed. PARDISO is a reference here, not a
dependency of sparsemor.

    python3 benches/pardiso_reference.py --real MATRIX.mtx MTYPE NRHS [THREADS]

factors a real symmetric matrix instead (`sparsemor bench real`): the lower triangle in
MATRIX.mtx (Matrix Market, symmetric), with matrix type MTYPE 2 (Cholesky; the matrix must be
positive definite) or -2 (Bunch-Kaufman LDL^T with perturbed pivots; the JSON line then also
holds its inertia, iparm[21] positive and iparm[22] negative eigenvalues, and iparm[13], the
pivots it perturbed).
"""

import ctypes
import json
import os
import sys
import time

import numpy as np
import scipy.sparse as sp

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from eigsh_reference import read_symmetric, tomllib  # noqa: E402


def mkl():
    try:
        import pypardiso
    except ImportError:
        sys.stderr.write("pypardiso is not installed (pip install pypardiso)\n")
        sys.exit(2)
    # a handle of our own: pypardiso sets argument types on its handle's `pardiso`
    return ctypes.CDLL(pypardiso.PyPardisoSolver().libmkl._name)


def complex_system(model_dir, freq):
    """(A, mtype) for the complex-symmetric A(i omega) of a model directory."""
    with open(f"{model_dir}/model.toml", "rb") as f:
        manifest = tomllib.load(f)
    k = read_symmetric(f"{model_dir}/{manifest['stiffness']}")
    m = read_symmetric(f"{model_dir}/{manifest['mass']}")
    ray = manifest.get("rayleigh", {})
    alpha, beta = ray.get("alpha", 0.0), ray.get("beta", 0.0)
    w = 2 * np.pi * freq
    return (k - w * w * m).astype(np.complex128) + 1j * w * (alpha * m + beta * k), 6


def main():
    if sys.argv[1] == "--real":
        a, mtype_value = read_symmetric(sys.argv[2]), int(sys.argv[3])
        if mtype_value not in (2, -2):
            sys.stderr.write(f"matrix type {mtype_value}: the real mode takes 2 or -2\n")
            sys.exit(1)
        rest = sys.argv[4:]
    else:
        a, mtype_value = complex_system(sys.argv[1], float(sys.argv[2]))
        rest = sys.argv[3:]
    nrhs = int(rest[0])
    threads = int(rest[1]) if len(rest) > 1 else 2
    lib = mkl()
    lib.MKL_Set_Num_Threads(ctypes.c_int(threads))
    dtype = a.dtype
    upper = sp.triu(sp.csr_matrix(a), format="csr")
    upper.sort_indices()
    n = upper.shape[0]
    vals = np.ascontiguousarray(upper.data, dtype=dtype)
    ia = np.ascontiguousarray(upper.indptr + 1, dtype=np.int32)
    ja = np.ascontiguousarray(upper.indices + 1, dtype=np.int32)
    rng = np.random.default_rng(1)
    b = rng.standard_normal((n, nrhs))
    if dtype == np.complex128:
        b = b + 1j * rng.standard_normal((n, nrhs))
    b = np.asfortranarray(b)
    x = np.zeros_like(b, order="F")

    pt = np.zeros(64, dtype=np.int64)
    iparm = np.zeros(64, dtype=np.int32)
    mtype = ctypes.c_int32(mtype_value)
    lib.pardisoinit(pt.ctypes.data_as(ctypes.c_void_p), ctypes.byref(mtype),
                    iparm.ctypes.data_as(ctypes.c_void_p))
    iparm[17] = -1  # report nnz of the factor
    err = ctypes.c_int32(0)

    def phase(p):
        lib.pardiso(pt.ctypes.data_as(ctypes.c_void_p), ctypes.byref(ctypes.c_int32(1)),
                    ctypes.byref(ctypes.c_int32(1)), ctypes.byref(mtype),
                    ctypes.byref(ctypes.c_int32(p)), ctypes.byref(ctypes.c_int32(n)),
                    vals.ctypes.data_as(ctypes.c_void_p), ia.ctypes.data_as(ctypes.c_void_p),
                    ja.ctypes.data_as(ctypes.c_void_p), ctypes.c_void_p(),
                    ctypes.byref(ctypes.c_int32(nrhs)), iparm.ctypes.data_as(ctypes.c_void_p),
                    ctypes.byref(ctypes.c_int32(0)), b.ctypes.data_as(ctypes.c_void_p),
                    x.ctypes.data_as(ctypes.c_void_p), ctypes.byref(err))
        if err.value != 0:
            sys.stderr.write(f"PARDISO phase {p} failed with error {err.value}\n")
            sys.exit(1)

    # phase 22 twice: "factor_s" is the second, a refactorization into memory the first
    # already touched, as every frequency of a sweep after the first sees it
    times = {}
    for p, name in [(11, "analysis_s"), (22, "factor_cold_s"), (22, "factor_s"), (33, "solve_s")]:
        start = time.perf_counter()
        phase(p)
        times[name] = time.perf_counter() - start
    residual = np.linalg.norm(b - a @ x) / np.linalg.norm(b)
    out = {"n": n, "threads": threads, "mtype": mtype_value, **times,
           "nnz_l": int(iparm[17]),
           "peak_kb": int(max(iparm[14], iparm[15] + iparm[16])),
           "residual": float(residual)}
    if mtype_value == -2:
        out.update(positive=int(iparm[21]), negative=int(iparm[22]), perturbed=int(iparm[13]))
    phase(-1)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
