"""Small models for the package's tests, given as scipy.sparse matrices, and dense
references: the transfer function by a dense solve and the rigid-body part of a free body."""

import numpy as np
import scipy.sparse as sp


def chain(n=200):
    """A constrained chain: DoF 0 grounded, springs to the next and next-but-one DoF
    (pentadiagonal K), consistent-like tridiagonal M. Returns scipy.sparse (M, K)."""
    k1, k2 = 4.0e4, 1.0e4
    main = np.full(n, 2 * k1 + 2 * k2)
    main[-1] = k1 + k2
    main[-2] = 2 * k1 + k2
    K = sp.diags([main, -k1 * np.ones(n - 1), -k1 * np.ones(n - 1),
                  -k2 * np.ones(n - 2), -k2 * np.ones(n - 2)], [0, 1, -1, 2, -2])
    m = 1.0 + 0.2 * np.sin(np.arange(n))  # uneven masses
    M = sp.diags([4 * m, np.ones(n - 1), np.ones(n - 1)], [0, 1, -1]) / 6.0
    return sp.csc_matrix(M), sp.csc_matrix(K)


def truss(nx=2, ny=2, nz=10, h=0.1, ea=1e6, mass=0.5):
    """A free 3-D truss: nodes on an nx×ny×nz grid, bars between every pair of nodes at most
    a body diagonal apart (axial stiffness EA/L e eᵀ), lumped masses. Its stiffness
    annihilates the 6 rigid-body modes exactly. Returns (M, K, nodes)."""
    grid = np.array([[i, j, k] for k in range(nz) for j in range(ny) for i in range(nx)], float)
    nodes = grid * h
    n = 3 * len(nodes)
    rows, cols, vals = [], [], []
    for a in range(len(nodes)):
        for b in range(a + 1, len(nodes)):
            d = nodes[b] - nodes[a]
            length = np.linalg.norm(d)
            if length > np.sqrt(3) * h * 1.0001:
                continue
            e = d / length
            ke = ea / length * np.outer(e, e)
            for (p, q, s) in ((a, a, 1), (b, b, 1), (a, b, -1), (b, a, -1)):
                for r in range(3):
                    for c in range(3):
                        rows.append(3 * p + r)
                        cols.append(3 * q + c)
                        vals.append(s * ke[r, c])
    K = sp.csc_matrix((vals, (rows, cols)), shape=(n, n))
    M = sp.identity(n, format="csc") * (mass / len(nodes))
    return sp.csc_matrix(M), K, nodes


def dense_h(M, D, K, inputs, outputs, f):
    """H(iω) = C (K − ω²M + iωD)⁻¹ B by a dense solve."""
    w = 2 * np.pi * f
    a = K.toarray() - w * w * M.toarray() + 1j * w * D.toarray()
    b = np.zeros((M.shape[0], len(inputs)), complex)
    b[inputs, range(len(inputs))] = 1.0
    return np.linalg.solve(a, b)[outputs, :]


def rigid_h0(M, nodes, inputs, outputs, f):
    """H0(iω) = −(1/ω²) C V0 M0⁻¹ V0ᵀ B of an undamped rigid part (Rayleigh α = 0)."""
    n = M.shape[0]
    c = nodes - nodes.mean(axis=0)
    v0 = np.zeros((n, 6))
    for i, (x, y, z) in enumerate(c):
        v0[3 * i:3 * i + 3, :3] = np.eye(3)
        v0[3 * i:3 * i + 3, 3:] = [[0, z, -y], [-z, 0, x], [y, -x, 0]]
    m0 = v0.T @ (M @ v0)
    w = 2 * np.pi * f
    return -(v0[outputs] @ np.linalg.solve(m0, v0[inputs].T)) / (w * w)


def eps(h, hr):
    return np.linalg.norm(h - hr) / np.linalg.norm(h)
