"""sparsemor ROM -> pyMOR SecondOrderModel, compared with the full model in pyMOR.

    pip install pymor numpy scipy
    cargo build --release -p sparsemor-ffi
    python3 ffi/python/example_pymor.py

Builds a constrained chain model (scipy.sparse), reduces it by line-fitting through the C ABI,
wraps the reduced matrices in `SecondOrderModel.from_matrices(Mr, Dr, Kr, Br, Cr)` and the
full matrices in the same pyMOR class, and compares their transfer functions
H(s) = C (s^2 M + s D + K)^-1 B on a frequency grid with pyMOR's `eval_tf`. Exits non-zero
when the relative error exceeds 3e-2 or pyMOR disagrees with sparsemor's own error.
"""

import os
import sys

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import sparsemor  # noqa: E402
from test_sparsemor import chain  # noqa: E402

from pymor.models.iosys import SecondOrderModel  # noqa: E402


def selector(n, dofs):
    """n × len(dofs) unit columns (B) — its transpose selects outputs (C)."""
    return sp.csc_matrix((np.ones(len(dofs)), (dofs, range(len(dofs)))), shape=(n, len(dofs)))


def main():
    n, beta = 200, 2e-4
    M, K = chain(n)
    D = beta * K
    inputs, outputs = [199, 100], [199, 100, 50]
    lam = sla.eigh(K.toarray(), M.toarray(), eigvals_only=True)
    fn = np.sqrt(lam) / (2 * np.pi)
    band = (0.0, 0.5 * (fn[3] + fn[4]))

    model = sparsemor.Model(M, K, rayleigh=(0.0, beta))
    model.set_scene(inputs, outputs, band)
    rom = sparsemor.reduce_linefit(model, reference_count=12, outputs_plus=5)

    fom = SecondOrderModel.from_matrices(M, D, K, selector(n, inputs),
                                         selector(n, outputs).T.tocsc())
    rom_pymor = SecondOrderModel.from_matrices(rom.Mr, rom.Dr, rom.Kr, rom.Br, rom.Cr)
    print(f"full model: {fom.order} DoFs -> ROM order {rom_pymor.order} "
          f"({rom_pymor.dim_input} inputs, {rom_pymor.dim_output} outputs)")

    grid = np.linspace(band[1] / 200, band[1], 200)
    eps = []
    for f in grid:
        s = 2j * np.pi * f
        h = fom.transfer_function.eval_tf(s)
        hr = rom_pymor.transfer_function.eval_tf(s)
        eps.append(np.linalg.norm(h - hr) / np.linalg.norm(h))
    eps = np.array(eps)
    lib_eps, _ = rom.transfer_error(model, grid)
    agree = np.max(np.abs(eps - lib_eps))
    print(f"band [0, {band[1]:.2f}] Hz: pyMOR max relative error {eps.max():.3e} "
          f"(mean {eps.mean():.3e}); sparsemor's own eps agrees to {agree:.1e}")
    ok = eps.max() < 3e-2 and agree < 1e-8
    print("example_pymor: OK" if ok else "example_pymor: FAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
