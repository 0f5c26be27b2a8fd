"""SciPy reference for `sparsemor bench modes`: the lowest C eigenpairs of K phi = lambda M phi
by ARPACK shift-invert (scipy.sparse.linalg.eigsh, SuperLU factor of K - sigma M), the way a
SciPy user computes them.

    python3 benches/eigsh_reference.py MODEL_DIR COUNT [SIGMA] [--out FILE]

MODEL_DIR is a sparsemor model directory (model.toml with K.mtx and M.mtx, full or lower
triangle). SIGMA defaults to -0.01 * (2 pi * 1000)^2 (below the spectrum, so K - sigma M is
positive definite on a free body). Prints one JSON line: n, count, sigma, seconds (factor +
iteration, as eigsh reports them together), and the eigenvalues in ascending order (also
written to FILE as text, one per line, when --out is given). SciPy is a reference here, not a
dependency of sparsemor.
"""

import json
import sys
import time

import numpy as np
import scipy.io
import scipy.sparse as sp
import scipy.sparse.linalg as sla

try:
    import tomllib
except ImportError:  # Python < 3.11
    import tomli as tomllib


def read_symmetric(path):
    a = sp.csc_matrix(scipy.io.mmread(path))
    lower = sp.tril(a, -1)
    upper = sp.triu(a, 1)
    # a file holding one triangle becomes the full symmetric matrix
    if upper.nnz == 0 and lower.nnz > 0:
        a = a + lower.T
    return sp.csc_matrix(a)


def main():
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    out = None
    if "--out" in sys.argv:
        out = sys.argv[sys.argv.index("--out") + 1]
        args = [a for a in args if a != out]
    model_dir, count = args[0], int(args[1])
    sigma = float(args[2]) if len(args) > 2 else -0.01 * (2 * np.pi * 1000.0) ** 2
    with open(f"{model_dir}/model.toml", "rb") as f:
        manifest = tomllib.load(f)
    k = read_symmetric(f"{model_dir}/{manifest['stiffness']}")
    m = read_symmetric(f"{model_dir}/{manifest['mass']}")
    start = time.perf_counter()
    vals = sla.eigsh(k, k=count, M=m, sigma=sigma, which="LM", return_eigenvectors=False)
    seconds = time.perf_counter() - start
    vals = np.sort(vals)
    if out:
        np.savetxt(out, vals, fmt="%.17g")
    print(json.dumps({"n": k.shape[0], "count": count, "sigma": sigma, "seconds": seconds,
                      "lambdas": vals.tolist()}))


if __name__ == "__main__":
    main()
