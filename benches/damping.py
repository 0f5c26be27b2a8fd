"""Damping variants of a sparsemor model directory, for the damping kinds of docs/design.md §3.12.

From a model directory with `[rayleigh]` damping (e.g. one written by benches/parts.py), writes
next to each other:
  file       the same D = alpha M + beta K as an explicit `D.mtx` (17 significant digits), as an
             FE code exports it;
  dashpots   D = alpha M + beta K plus COUNT axial dashpots of C N s/m between far node pairs
             (each c n n^T on the two nodes' x, y, z DoFs, n the unit vector between them, so
             rigid motion does not load them), as `D.mtx`;
  eta        the `[rayleigh]` damping plus a uniform loss factor `[structural] eta = ETA`.
M, K, nodes and the scene are shared (the variants' model.toml point at the original files by
relative path). The dashpot pairs are chosen reproducibly: node pairs farther apart than half
the body's largest extent, drawn with a fixed seed.

Run:
  python3 benches/damping.py MODEL_DIR --out ROOT [--count 6] [--c 2000] [--eta 0.02]

Needs: numpy, scipy.
"""

import argparse
import os
import pathlib
import re

import numpy as np
import scipy.io
import scipy.sparse as sp


def rayleigh(toml):
    """(alpha, beta) of the [rayleigh] table."""
    table = re.search(r"\[rayleigh\]\s*\n((?:[a-z]+\s*=.*\n)+)", toml)
    if not table:
        raise SystemExit("the model has no [rayleigh] table to start from")
    values = dict(re.findall(r"([a-z]+)\s*=\s*(\S+)", table.group(1)))
    return float(values.get("alpha", 0.0)), float(values.get("beta", 0.0))


def dashpots(nodes, count, c, seed=7):
    """COUNT axial dashpots c n n^T between far node pairs, as (rows, cols, values) (full storage)."""
    rng = np.random.default_rng(seed)
    extent = np.max(np.ptp(nodes, axis=0))
    rows, cols, vals, pairs = [], [], [], []
    while len(pairs) < count:
        a, b = rng.integers(0, len(nodes), size=2)
        d = nodes[b] - nodes[a]
        if np.linalg.norm(d) < 0.5 * extent:
            continue
        n = d / np.linalg.norm(d)
        block = c * np.outer(n, n)
        for (p, q, s) in ((a, a, 1.0), (b, b, 1.0), (a, b, -1.0), (b, a, -1.0)):
            for i in range(3):
                for j in range(3):
                    rows.append(3 * p + i)
                    cols.append(3 * q + j)
                    vals.append(s * block[i, j])
        pairs.append((int(a), int(b)))
    return rows, cols, vals, pairs


def variant(src, out, name, toml, extra_toml="", damping_file=None):
    out.mkdir(parents=True, exist_ok=True)
    rel = os.path.relpath(src, out)
    text = toml
    for key in ("mass", "stiffness", "nodes"):
        text = re.sub(rf'^{key} = "([^"]+)"', lambda m: f'{key} = "{rel}/{m.group(1)}"', text,
                      flags=re.M)
    if damping_file:
        text = re.sub(r"\[rayleigh\]\s*\n(?:[a-z]+\s*=.*\n)+", "", text)
        text = text.replace('dofs_per_node', f'damping = "{damping_file}"\ndofs_per_node', 1)
    text = text.replace("\n[scene]", extra_toml + "\n[scene]", 1)
    text = re.sub(r'^name = "([^"]+)"', lambda m: f'name = "{m.group(1)} {name}"', text, count=1)
    (out / "model.toml").write_text(text)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("model", type=pathlib.Path)
    ap.add_argument("--out", type=pathlib.Path, required=True)
    ap.add_argument("--count", type=int, default=6)
    ap.add_argument("--c", type=float, default=2000.0)
    ap.add_argument("--eta", type=float, default=0.02)
    a = ap.parse_args()
    toml = (a.model / "model.toml").read_text()
    alpha, beta = rayleigh(toml)
    K = scipy.io.mmread(a.model / "K.mtx").tocsc()
    M = scipy.io.mmread(a.model / "M.mtx").tocsc()
    nodes = np.loadtxt(a.model / "nodes.csv", delimiter=",", skiprows=1)
    # mmread gives a symmetric file's matrix in full
    D = (alpha * M + beta * K).tocsc()

    out = variant(a.model, a.out / "file", "D file", toml, damping_file="D.mtx")
    scipy.io.mmwrite(out / "D.mtx", sp.tril(D).tocoo(), symmetry="symmetric", precision=17)

    r, c, v, pairs = dashpots(nodes, a.count, a.c)
    Dd = (D + sp.csc_matrix((v, (r, c)), shape=D.shape)).tocsc()
    out = variant(a.model, a.out / "dashpots", f"{a.count} dashpots", toml, damping_file="D.mtx")
    scipy.io.mmwrite(out / "D.mtx", sp.tril(Dd).tocoo(), symmetry="symmetric", precision=17)
    print(f"dashpots {a.c:g} N s/m between nodes {pairs}")

    variant(a.model, a.out / "eta", f"eta {a.eta:g}", toml,
            extra_toml=f"\n[structural]\neta = {a.eta!r}\n")
    print(f"wrote {a.out}/{{file,dashpots,eta}} (alpha {alpha:g}, beta {beta:g})")


if __name__ == "__main__":
    main()
