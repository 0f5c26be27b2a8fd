"""Tests of the ctypes binding: models given as scipy.sparse matrices, reduced through the C
ABI, and the ROM's transfer function checked against a dense scipy/numpy solve of the full
model.

Run:  python3 -m pytest ffi/python/test_sparsemor.py     or     python3 ffi/python/test_sparsemor.py
(needs numpy, scipy and the built library: cargo build -p sparsemor-ffi, or SPARSEMOR_LIB).
"""

import os
import sys

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import sparsemor  # noqa: E402


# ---- models ---------------------------------------------------------------------------------

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


# ---- tests ----------------------------------------------------------------------------------

def test_version():
    major, minor, patch, abi = sparsemor.version()
    assert abi == sparsemor.ABI_VERSION
    print(f"sparsemor {major}.{minor}.{patch}, ABI {abi}")


def test_linefit_transfer_function_matches_dense_solve():
    M, K = chain(200)
    beta = 2e-4
    D = beta * K
    lam = sla.eigh(K.toarray(), M.toarray(), eigvals_only=True)
    fn = np.sqrt(lam) / (2 * np.pi)
    band = (0.0, 0.5 * (fn[3] + fn[4]))  # four resonances in the band
    inputs, outputs = [199, 100], [199, 100, 50]
    model = sparsemor.Model(M, K, rayleigh=(0.0, beta))
    assert model.n == 200 and not model.is_free
    model.set_scene(inputs, outputs, band)
    rom = sparsemor.reduce_linefit(model, reference_count=12, outputs_plus=5, keep_basis=True)
    assert rom.method == "linefit"
    assert (rom.order, rom.n_inputs, rom.n_outputs) == (8, 2, 3)
    assert rom.V.shape == (200, 8)
    assert list(rom.dofs[:3]) == outputs
    assert rom.fit_report["rank"] == 8 and rom.serep_cond is None
    assert all(spd for spd, _, _ in rom.definiteness.values())
    grid = np.linspace(band[1] / 200, band[1], 200)
    e = np.array([eps(dense_h(M, D, K, inputs, outputs, f), rom.transfer(f)) for f in grid])
    lib_el, lib_tot = rom.transfer_error(model, grid)
    print(f"line-fitting, N = 200, order 8, band [0, {band[1]:.1f}] Hz with resonances "
          f"{np.round(fn[:4], 2)} Hz: max eps vs dense solve {e.max():.3e} (mean {e.mean():.3e}); "
          f"library eps agrees to {np.max(np.abs(lib_el - e)):.1e} (absolute)")
    assert e.max() < 3e-2
    # same quantity, sparse vs dense solves of A(iω): each H carries a relative error up to
    # about ε·κ(A(iω)), which enters eps additively; allow 10 ε κ per grid point on top of a
    # relative 1e-6 (measured: at most 0.12 ε κ)
    w = 2 * np.pi * grid
    kappa = np.array([np.linalg.cond(K.toarray() - x * x * M.toarray() + 1j * x * D.toarray()) for x in w])
    bound = 1e-6 * e + 10 * np.finfo(float).eps * kappa
    print(f"largest |lib - dense| / bound: {np.max(np.abs(lib_el - e) / bound):.2e}")
    assert np.all(np.abs(lib_el - e) <= bound)
    np.testing.assert_array_equal(lib_el, lib_tot)  # constrained body: one variant


def test_exact_fit_interpolates_at_the_reference_frequencies():
    # 2pz = n (p = 2 inputs, z = 3 frequencies, n = 12 interface DoFs): the fit is exact and
    # the Galerkin ROM reproduces H at every reference frequency (docs/design.md §3.4)
    M, K = chain(120)
    beta = 1e-4
    inputs, outputs = [119, 60], [119, 60, 30]
    model = sparsemor.Model(M, K, rayleigh=(0.0, beta))
    model.set_scene(inputs, outputs, (0.0, 30.0))
    refs = [4.0, 12.0, 25.0]
    rom = sparsemor.reduce_linefit(model, reference_frequencies=refs, outputs_plus=9)
    assert rom.order == 12 and rom.fit_report["rows"] == 12
    errs = [eps(dense_h(M, beta * K, K, inputs, outputs, f), rom.transfer(f)) for f in refs]
    print(f"exact fit (2pz = n = 12): eps at the reference frequencies {np.array(errs)}")
    assert max(errs) < 1e-7


def test_explicit_damping_matrix_and_lower_storage():
    M, K = chain(60)
    alpha, beta = 0.5, 1e-4
    D = alpha * M + beta * K
    a = sparsemor.Model(M, K, rayleigh=(alpha, beta))
    b = sparsemor.Model(M, K, D=D)
    c = sparsemor.Model(M, K, rayleigh=(alpha, beta), lower_only=True)
    roms = []
    for m in (a, b, c):
        m.set_scene([59], [59, 30], (0.0, 20.0))
        roms.append(sparsemor.reduce_linefit(m, reference_frequencies=[2.0, 8.0, 15.0],
                                             outputs_plus=2, threads=1))
    np.testing.assert_allclose(roms[1].Dr, roms[0].Dr, rtol=1e-10, atol=1e-12 * abs(roms[0].Dr).max())
    np.testing.assert_array_equal(roms[2].Kr, roms[0].Kr)  # lower triangle mirrored exactly
    np.testing.assert_array_equal(roms[2].Dr, roms[0].Dr)


def test_free_body_elastic_and_total_transfer_function():
    M, K, nodes = truss()
    beta = 1e-4
    D = beta * K
    n = M.shape[0]
    inputs, outputs = [0, 1, n - 1], [0, 1, n - 1, n - 2]
    model = sparsemor.Model(M, K, rayleigh=(0.0, beta), nodes=nodes, dofs_per_node=3)
    assert model.is_free
    lam = sla.eigh(K.toarray(), M.toarray(), eigvals_only=True)
    fn = np.unique(np.round(np.sqrt(np.abs(lam[6:])) / (2 * np.pi), 6))  # symmetric: pairs
    band = (0.0, 0.5 * (fn[3] + fn[4]))
    model.set_scene(inputs, outputs, band)
    rom = sparsemor.reduce_linefit(model, reference_count=12, outputs_plus=8)
    grid = np.linspace(band[1] / 100, band[1], 100)
    e_el, e_tot = [], []
    for f in grid:
        h = dense_h(M, D, K, inputs, outputs, f)
        h0 = rigid_h0(M, nodes, inputs, outputs, f)
        hr = rom.transfer(f)
        e_el.append(eps(h - h0, hr))
        e_tot.append(eps(h, h0 + hr))
    e_el, e_tot = np.array(e_el), np.array(e_tot)
    lib_el, lib_tot = rom.transfer_error(model, grid)
    print(f"free truss, N = {n}, order {rom.order}: max eps elastic {e_el.max():.3e}, "
          f"total {e_tot.max():.3e} vs dense solve (band [0, {band[1]:.0f}] Hz, resonances "
          f"{np.round(fn[:4])} Hz); library agrees to {np.max(np.abs(lib_el - e_el)):.1e} / "
          f"{np.max(np.abs(lib_tot - e_tot)):.1e} (absolute)")
    assert e_el.max() < 3e-2 and e_tot.max() < 3e-2
    # the dense H - H0 loses digits to cancellation at low f
    np.testing.assert_allclose(lib_el, e_el, rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(lib_tot, e_tot, rtol=1e-6, atol=1e-9)


def test_serep_reproduces_the_retained_eigenfrequencies():
    M, K = chain(150)
    model = sparsemor.Model(M, K, rayleigh=(0.0, 1e-4))
    retained = [149, 110, 75, 40]
    model.set_scene([149], [149], (0.0, 50.0))
    rom = sparsemor.reduce_serep(model, retained=retained, keep_basis=True)
    assert rom.method == "serep" and rom.order == 4 and rom.fit_report is None
    assert rom.serep_cond is not None and rom.V.shape == (150, 4)
    full = sla.eigh(K.toarray(), M.toarray(), eigvals_only=True)[:4]
    red = sla.eigh(rom.Kr, rom.Mr, eigvals_only=True)
    rel = np.abs(red - full) / full
    print(f"SEREP c = r = 4: relative eigenvalue error {rel}")
    assert rel.max() < 1e-9


def test_model_from_ansys_full_equals_the_independent_extraction():
    """The ANSYS .full read by the library (C ABI) against K.mtx, M.mtx that ansys-mapdl-reader
    extracted from the same file, read by scipy: the same SEREP ROM."""
    data = os.path.join(os.path.dirname(os.path.abspath(__file__)),
                        "../../../shared/data/ansys_example_full")
    if not os.path.exists(os.path.join(data, "file.full")):
        print("note: ../shared/data/ansys_example_full not found; skipped")
        return
    import scipy.io
    imported = sparsemor.Model.from_files(os.path.join(data, "file.full"))
    assert imported.n == 900
    assert [imported.dof(i)[1] for i in range(3)] == ["x", "y", "z"]

    def full(path):
        a = sp.csc_matrix(scipy.io.mmread(path))
        return sp.csc_matrix(a + sp.tril(a, -1).T) if sp.triu(a, 1).nnz == 0 else a

    extracted = sparsemor.Model(full(os.path.join(data, "M.mtx")), full(os.path.join(data, "K.mtx")))
    roms = []
    for model in (imported, extracted):
        model.set_scene([897, 898, 899], [897, 898, 899], (0.0, 12000.0))
        roms.append(sparsemor.reduce_serep(model, modes=3))
    for which in ("Mr", "Kr"):
        a, b = getattr(roms[0], which), getattr(roms[1], which)
        rel = np.abs(a - b).max() / np.abs(b).max()
        print(f"{which}: imported vs extracted {rel:.1e}")
        assert rel <= 1e-12, which


def test_errors_raise_with_status_and_message():
    M, K = chain(20)
    bad = K.tolil()
    bad[0, 1] *= 2.0  # unsymmetric
    try:
        sparsemor.Model(M, bad.tocsc())
        raise AssertionError("no error")
    except sparsemor.SparsemorError as e:
        assert e.status_name == "INVALID_MODEL" and "not symmetric" in e.message, e
    model = sparsemor.Model(M, K, rayleigh=(0.0, 1e-4))
    try:
        sparsemor.reduce_linefit(model, reference_frequencies=[1.0])
        raise AssertionError("no error")
    except sparsemor.SparsemorError as e:
        assert e.status_name == "INVALID_ARGUMENT" and "set_scene" in e.message, e
    model.set_scene([19], [19], (0.0, 10.0))
    for kwargs, status in (
        (dict(reference_frequencies=[float("nan")]), "INVALID_ARGUMENT"),
        (dict(reference_frequencies=[1.0, 5.0], progress=lambda d, t, f: False), "CANCELLED"),
    ):
        try:
            sparsemor.reduce_linefit(model, **kwargs)
            raise AssertionError(f"no error for {kwargs}")
        except sparsemor.SparsemorError as e:
            assert e.status_name == status, e
            print(f"{status}: {e.message}")
    rom = sparsemor.reduce_linefit(model, reference_frequencies=[1.0, 5.0])
    try:
        rom.V
        raise AssertionError("no error")
    except sparsemor.SparsemorError as e:
        assert e.status_name == "NOT_AVAILABLE", e

    def boom(done, total, f):
        raise KeyError("from the callback")

    try:
        sparsemor.reduce_linefit(model, reference_frequencies=[1.0, 5.0], progress=boom)
        raise AssertionError("no error")
    except KeyError:
        pass
    seen = []
    sparsemor.reduce_linefit(model, reference_frequencies=[1.0, 5.0, 7.0],
                             progress=lambda d, t, f: seen.append((d, t)))
    assert sorted(seen) == [(1, 3), (2, 3), (3, 3)]


if __name__ == "__main__":
    tests = [(k, v) for k, v in sorted(globals().items()) if k.startswith("test_")]
    failed = 0
    for name, fn in tests:
        try:
            fn()
            print(f"ok     {name}")
        except Exception as e:  # noqa: BLE001
            failed += 1
            print(f"FAILED {name}: {type(e).__name__}: {e}")
    print(f"{len(tests) - failed} passed, {failed} failed")
    sys.exit(1 if failed else 0)
