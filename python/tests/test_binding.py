"""The package's binding of the C ABI: models given as scipy.sparse matrices, reduced by
line-fitting, SEREP and Craig–Bampton, the ROMs' transfer functions checked against dense
solves of the full models, and every failure raised as an exception with the library's
message."""

import os

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

import sparsemor
from models import chain, dense_h, eps, rigid_h0, truss


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


def test_craig_bampton_reproduces_the_fixed_interface_frequencies():
    M, K = chain(150)
    model = sparsemor.Model(M, K, rayleigh=(0.0, 1e-4))
    model.set_scene([149], [149], (0.0, 50.0))
    rom = sparsemor.reduce_craig_bampton(model, 6, keep_basis=True)
    assert rom.method == "craig_bampton" and rom.order == 7 and list(rom.dofs) == [149]
    report = rom.craig_bampton_report
    assert (report["boundary"], report["modes"], report["cholesky"]) == (1, 6, 1)
    assert rom.fit_report is None and rom.serep_cond is None and rom.sampling is None
    # K_ii: the chain with DoF 149 held
    keep = np.arange(149)
    kii, mii = K.toarray()[np.ix_(keep, keep)], M.toarray()[np.ix_(keep, keep)]
    fixed = np.sqrt(sla.eigh(kii, mii, eigvals_only=True)[:6]) / (2 * np.pi)
    got = rom.fixed_interface_frequencies
    print(f"fixed-interface frequencies {got} Hz; dense {fixed}")
    np.testing.assert_allclose(got, fixed, rtol=1e-10)
    # the static constraint mode: V's first column solves K_ii psi = -K_ib
    v = rom.V
    assert v[149, 0] == 1.0
    np.testing.assert_allclose(kii @ v[keep, 0], -K.toarray()[keep, 149], atol=1e-9 * 4e4)


def test_tolerance_drives_the_sampling_loop_and_reports_it():
    M, K = chain(300)
    model = sparsemor.Model(M, K, rayleigh=(0.0, 2e-4))
    lam = sla.eigh(K.toarray(), M.toarray(), eigvals_only=True)
    band = (0.0, 0.5 * np.sqrt(lam[5] * lam[6]) / (2 * np.pi))  # six resonances
    model.set_scene([299, 150], [299, 150, 75], band)
    rom = sparsemor.reduce_linefit(model, tolerance=1e-4, outputs_plus=3)
    s = rom.sampling
    assert s["tolerance"] == 1e-4 and s["converged"] and s["error"] <= 1e-4
    assert s["factorizations"] >= 1 and len(s["steps"]) >= 1
    assert s["factorizations_in_all"] >= s["factorizations"]
    assert s["steps"][-1]["order"] == rom.order
    grid = np.linspace(band[1] / 150, band[1], 150)
    D = 2e-4 * K
    e = [eps(dense_h(M, D, K, [299, 150], [299, 150, 75], f), rom.transfer(f)) for f in grid]
    print(f"tolerance 1e-4: order {rom.order}, {s['factorizations']} factorizations, stored "
          f"error {s['error']:.2e}, max over 150 dense points {max(e):.2e}")
    # the stored error is a lower bound of the band's maximum; the ROM meets the tolerance
    # on an independent grid up to the indicator's resolution between the sampled points
    assert max(e) <= 3e-4


def test_model_from_ansys_full_equals_the_independent_extraction():
    """The ANSYS .full read by the library (C ABI) against K.mtx, M.mtx that ansys-mapdl-reader
    extracted from the same file, read by scipy: the same SEREP ROM."""
    data = os.path.join(os.path.dirname(os.path.abspath(__file__)),
                        "../../../shared/data/ansys_example_full")
    if not os.path.exists(os.path.join(data, "file.full")):
        pytest.skip("../shared/data/ansys_example_full not found")
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


def test_errors_raise_python_exceptions_naming_the_field():
    M, K = chain(20)
    bad = K.tolil()
    bad[0, 1] *= 2.0  # unsymmetric
    with pytest.raises(sparsemor.InvalidInputError) as e:
        sparsemor.Model(M, bad.tocsc())
    assert e.value.status_name == "INVALID_MODEL" and "not symmetric" in e.value.message
    assert isinstance(e.value, ValueError)
    with pytest.raises(ValueError, match="K is 20x19, expected 20x20"):
        sparsemor.Model(M, K[:, :19])
    model = sparsemor.Model(M, K, rayleigh=(0.0, 1e-4))
    with pytest.raises(sparsemor.InvalidInputError, match="set_scene"):
        sparsemor.reduce_linefit(model, reference_frequencies=[1.0])
    with pytest.raises(sparsemor.InvalidInputError, match="outputs"):
        model.set_scene([19], [25], (0.0, 10.0))
    with pytest.raises(ValueError, match="inputs: need non-negative integers"):
        model.set_scene([-1], [19], (0.0, 10.0))
    model.set_scene([19], [19], (0.0, 10.0))
    with pytest.raises(sparsemor.InvalidInputError) as e:
        sparsemor.reduce_linefit(model, reference_frequencies=[float("nan")])
    print(f"NaN frequency: {e.value.message}")
    with pytest.raises(sparsemor.CancelledError):
        sparsemor.reduce_linefit(model, reference_frequencies=[1.0, 5.0],
                                 progress=lambda d, t, f: False)
    rom = sparsemor.reduce_linefit(model, reference_frequencies=[1.0, 5.0])
    with pytest.raises(sparsemor.NotAvailableError):
        rom.V

    def boom(done, total, f):
        raise KeyError("from the callback")

    with pytest.raises(KeyError):
        sparsemor.reduce_linefit(model, reference_frequencies=[1.0, 5.0], progress=boom)
    seen = []
    sparsemor.reduce_linefit(model, reference_frequencies=[1.0, 5.0, 7.0],
                             progress=lambda d, t, f: seen.append((d, t)))
    assert sorted(seen) == [(1, 3), (2, 3), (3, 3)]


def test_calls_release_the_gil():
    """While the library works in one thread, Python code runs in another: the longest pause
    of a loop in the main thread stays far below the call's duration (with the GIL held
    through the call it would equal it). The call: ε at 240 frequencies of a long stiff chain
    (two resonances in the band), about 0.6 s on a 2-core VM in 2026-11. It needs only to be
    long beside the loop's 1 ms sleeps and the scheduler's jitter (> 50 ms), so the test tells
    the two cases apart on a machine 10x faster too."""
    import threading
    import time

    M, K = chain(100000)
    model = sparsemor.Model(M, 1e8 * K, rayleigh=(0.0, 1e-6))
    model.set_scene([99999], [99999, 50000], (0.0, 30.0))
    rom = sparsemor.reduce_linefit(model, reference_frequencies=[5.0, 15.0, 25.0], outputs_plus=4)
    span = {}

    def work():
        span["start"] = time.perf_counter()
        rom.transfer_error(model, np.linspace(0.5, 30.0, 240))
        span["end"] = time.perf_counter()

    worker = threading.Thread(target=work)
    worker.start()
    last, longest = time.perf_counter(), 0.0
    while worker.is_alive():
        now = time.perf_counter()
        longest, last = max(longest, now - last), now
        time.sleep(0.001)
    worker.join()
    duration = span["end"] - span["start"]
    print(f"call {duration:.3f} s; longest pause of the main thread {longest * 1e3:.1f} ms")
    assert duration > 0.05, "the call is too short to tell"
    assert longest < 0.25 * duration


def test_general_scene_with_a_remote_point_and_sparse_b_and_c():
    """A distributing point on the top of a grounded truss, a load column B and an output row
    C: an exact line-fit (interface 2·p·z) reproduces C A⁻¹ B of the original model (the
    point's row from its definition, dense solves); V comes back in the original DoFs; bad
    scenes raise naming the argument."""
    M, K, nodes = truss(nx=2, ny=2, nz=8)
    base = np.repeat(nodes[:, 2] == 0.0, 3)
    K = (K + sp.diags(1e7 * base.astype(float))).tocsc()
    n, beta = M.shape[0], 1e-4
    model = sparsemor.Model(M, K, rayleigh=(0.0, beta), nodes=nodes)
    top = np.flatnonzero(np.isclose(nodes[:, 2], nodes[:, 2].max()))
    at = nodes[top].mean(axis=0) + [0.0, 0.0, 0.02]
    assert model.add_remote_point(top, position=at) == 0
    # the point's x row: x_ref = A⁻¹ Σ G_iᵀ u_i, A = Σ G_iᵀ G_i, G(r) = [I, −[r]×]
    g = [np.hstack([np.eye(3), -np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]],
                                          [-r[1], r[0], 0]])]) for r in nodes[top] - at]
    w = np.linalg.solve(sum(gi.T @ gi for gi in g), np.eye(6)[:, 0])
    wx = np.zeros(n)
    for i, gi in zip(top, g):
        wx[3 * i:3 * i + 3] = gi @ w
    b = np.zeros((n, 1))
    b[[20, 27, 35], 0] = [0.5, -1.25, 2.0]
    c = np.zeros((1, n))
    c[0, [30, 31, 50]] = [1.0, -0.4, 0.3]
    model.set_scene_general((0.0, 1000.0), input_points=[(0, "x")], B=sp.csc_matrix(b),
                            output_dofs=[70], output_points=[(0, "x")], C=sp.csr_matrix(c))
    assert model.coordinate_count == n
    freqs = [150.0, 600.0]
    rom = sparsemor.reduce_linefit(model, reference_frequencies=freqs, outputs_plus=5,
                                   keep_basis=True, threads=1)
    assert rom.order == 8 and not rom.fit_report["truncated"]
    B = np.column_stack([wx, b[:, 0]])
    C = np.vstack([np.eye(n)[70], wx, c[0]])
    for f in freqs:
        w_ = 2 * np.pi * f
        a = K.toarray() - w_ * w_ * M.toarray() + 1j * w_ * beta * K.toarray()
        h = C @ np.linalg.solve(a, B)
        assert eps(h, rom.transfer(f)) <= 1e-8
    assert rom.V.shape == (n, 8)
    np.testing.assert_allclose(C @ rom.V, rom.Cr, atol=1e-12 * np.abs(rom.Cr).max())
    assert [model.coordinate(d) for d in rom.dofs[:3]] == [("dof", 70), ("point", 0, "x"),
                                                          ("output_row", 0)]
    with pytest.raises(sparsemor.InvalidInputError, match=r"inputs.point_dofs\[0\] = 6"):
        model.set_scene_general((0.0, 1.0), input_points=[(1, "x")], output_dofs=[0])
    with pytest.raises(sparsemor.InvalidInputError, match="B must be N×p"):
        model.set_scene_general((0.0, 1.0), B=np.ones((n - 1, 1)), output_dofs=[0])
    with pytest.raises(sparsemor.InvalidInputError, match="n_nodes = 0"):
        model.add_remote_point([], position=(0, 0, 0))
    # the failed calls kept the scene; the DoF scene returns to the plain model
    assert model.coordinate(rom.dofs[2]) == ("output_row", 0)
    model.set_scene([70], [70], (0.0, 1000.0))
    assert model.coordinate(0) == ("dof", 0)
