"""The lowest elastic modes of two meshes of one part, compared at their remote points.

For each model directory: the lowest 6 + MODES eigenpairs of K, M (scipy eigsh, shift-invert
just below zero; the first 6 are the free body's rigid modes), mass-normalised, and each elastic
mode's motion at the remote points, W phi (W: the points' RBE3 rows, built as
benches/remote_reference.py builds them; distributing points only). Prints per mode both
eigenfrequencies, their relative difference, and the worst relative difference of the points'
translations and of their rotations (sign-aligned; over the entries above 1 % of the largest of
their kind over the compared modes, B the reference).

Run:
  python3 benches/point_modes.py COARSE_DIR FINE_DIR [--modes 3]
"""

import argparse
import math

import numpy as np
import scipy.sparse.linalg as sla

from remote_reference import rbe3_rows, read_model

SIGMA = -1e3
RIGID = 6


def point_modes(directory, count):
    """Elastic eigenfrequencies (Hz) and W phi (6 P x count) of a model directory."""
    m = read_model(directory)
    if any(q["kind"] != "distributing" for q in m["points"]):
        raise ValueError("distributing points only")
    lam, V = sla.eigsh(m["K"].tocsc(), k=RIGID + count, M=m["M"].tocsc(), sigma=SIGMA,
                       which="LM")
    order = np.argsort(lam)
    lam, V = lam[order][RIGID:], V[:, order][:, RIGID:]
    W = np.vstack([rbe3_rows(q, m["nodes"], m["per"]).toarray() for q in m["points"]])
    return np.sqrt(lam) / (2 * math.pi), W @ V


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("a", help="model directory to check (coarse)")
    ap.add_argument("b", help="reference model directory (fine)")
    ap.add_argument("--modes", type=int, default=3, help="elastic modes to compare")
    args = ap.parse_args()
    fa, Ca = point_modes(args.a, args.modes)
    fb, Cb = point_modes(args.b, args.modes)
    P = Cb.shape[0] // 6
    t = np.concatenate([6 * k + np.arange(3) for k in range(P)])
    r = t + 3
    print("| mode | f Hz (A) | f Hz (B) | difference | translations | rotations |")
    print("|---|---|---|---|---|---|")
    for k in range(args.modes):
        a, b = Ca[:, k], Cb[:, k]
        a = -a if a @ b < 0 else a
        cells = []
        for idx in (t, r):
            big = np.abs(b[idx]) > 0.01 * np.abs(Cb[idx]).max()
            cells.append(f"{100 * np.max(np.abs(a - b)[idx][big] / np.abs(b[idx][big])):.2g} %"
                         if big.any() else "—")
        print(f"| {k + 1} | {fa[k]:.1f} | {fb[k]:.1f} | {100 * (fa[k] / fb[k] - 1):.2f} % | "
              + " | ".join(cells) + " |")


if __name__ == "__main__":
    main()
