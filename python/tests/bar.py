"""The `sparsemor` command for the tests that compare with it, and the built-in bar it
generates, read back as scipy.sparse matrices."""

import os
import subprocess
import tomllib

import numpy as np
import pytest
import scipy.io
import scipy.sparse as sp

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def cli():
    """The command: $SPARSEMOR_CLI, else the cargo target directory's build."""
    env = os.environ.get("SPARSEMOR_CLI")
    if env:
        return env
    target = os.environ.get("CARGO_TARGET_DIR", os.path.join(REPO, "target"))
    for profile in ("release", "debug"):
        exe = os.path.join(target, profile, "sparsemor")
        if os.path.exists(exe):
            return exe
    pytest.skip("the sparsemor command was not found: cargo build --release, or set "
                "SPARSEMOR_CLI")


def run(*args):
    out = subprocess.run([cli(), *map(str, args)], capture_output=True, text=True)
    assert out.returncode == 0, f"sparsemor {' '.join(map(str, args))}: {out.stderr}"
    return out.stdout + out.stderr


def built_in_bar(directory):
    """`sparsemor generate bar` in `directory`: (M, K, rayleigh, nodes, scene) with the scene
    a dict of inputs, outputs and band_hz."""
    run("generate", "bar", "--out", directory)
    with open(os.path.join(directory, "model.toml"), "rb") as f:
        meta = tomllib.load(f)
    # scipy expands a `symmetric` Matrix Market file to both triangles
    M = sp.csc_matrix(scipy.io.mmread(os.path.join(directory, meta["mass"])))
    K = sp.csc_matrix(scipy.io.mmread(os.path.join(directory, meta["stiffness"])))
    nodes = np.loadtxt(os.path.join(directory, meta["nodes"]), delimiter=",", skiprows=1)
    rayleigh = (meta["rayleigh"]["alpha"], meta["rayleigh"]["beta"])
    return M, K, rayleigh, nodes, meta["scene"]
