"""Compare two transfer-function CSVs of one scene (a coarse and a fine mesh), entry by entry.

Reads the CSVs of benches/remote_reference.py or `sparsemor sweep` (f_hz,output,input,re,im)
for the same frequencies, outputs and inputs in the same order, and prints per frequency the worst relative difference

    max |H_a(i, j) - H_b(i, j)| / |H_b(i, j)|   over the entries with |H_b(i, j)| > 1 % of
                                                sqrt(|H_b(i, i)| |H_b(j, j)|)

(B, the second file, is the reference: the fine mesh), over all entries and over the blocks
whose outputs and inputs are both translations (x, y, z) or both rotations (rx, ry, rz) of
remote points (`POINT:DIR` names). Small entries are skipped because a relative difference of
an entry near zero (a cross term the symmetry nearly cancels) says nothing about convergence.

Run:
  python3 benches/h_compare.py COARSE.csv FINE.csv
"""

import argparse
import csv
from collections import defaultdict

import numpy as np

TRANSLATIONS = ("x", "y", "z")
ROTATIONS = ("rx", "ry", "rz")


def read(path):
    """{f: (names, H)} with H[i, j] = output i, input j (the scene must be square)."""
    data = defaultdict(dict)
    with open(path) as f:
        for row in csv.DictReader(f):
            data[float(row["f_hz"])][(row["output"], row["input"])] = complex(
                float(row["re"]), float(row["im"]))
    out = {}
    for f, entries in data.items():
        names = list(dict.fromkeys(o for o, _ in entries))
        H = np.array([[entries[(o, i)] for i in names] for o in names])
        out[f] = (names, H)
    return out


def worst(Ha, Hb, keep):
    """The worst relative difference over the kept entries above 1 % of sqrt(|Hii Hjj|)."""
    d = np.sqrt(np.abs(np.outer(np.diag(Hb), np.diag(Hb))))
    big = (np.abs(Hb) > 0.01 * d) & keep
    return float(np.max(np.abs(Ha - Hb)[big] / np.abs(Hb)[big]))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("a", help="CSV of the mesh to check (coarse)")
    ap.add_argument("b", help="CSV of the reference mesh (fine)")
    args = ap.parse_args()
    a, b = read(args.a), read(args.b)
    print("| f Hz | all entries | translations | rotations |")
    print("|---|---|---|---|")
    for f in sorted(b):
        names, Hb = b[f]
        names_a, Ha = a[f]
        # `sparsemor sweep` names a remote point's DoF by its coupled DoF index; both list the
        # scene in its order, so the names of the file that has POINT:DIR names serve both
        if all(n.isdigit() for n in names):
            names = names_a
        assert len(names_a) == len(names) and all(
            m == n or m.isdigit() for m, n in zip(names_a, names)), (names_a, names)
        dirs = np.array([n.rpartition(":")[2] for n in names])
        t = np.isin(dirs, TRANSLATIONS)
        r = np.isin(dirs, ROTATIONS)
        cells = [worst(Ha, Hb, np.ones_like(Hb, dtype=bool)),
                 worst(Ha, Hb, np.outer(t, t)), worst(Ha, Hb, np.outer(r, r))]
        print(f"| {f:g} | " + " | ".join(f"{100 * c:.3g} %" for c in cells) + " |")


if __name__ == "__main__":
    main()
