"""The pyMOR reductor with general B and Cp (docs/python.md): a clamped 3-D truss lattice
with a pressure load over its top face and the average displacement over the same face (the
two are proportional: one functional for sparsemor), a unit force and a displacement read in
millimetres (a scaled unit vector). pyMOR's own error of the reduced SecondOrderModel is
compared with the error sparsemor reports, on the same definition (docs/design.md eq. 23):
ε(f) = ‖Ĥ(iω) − Ĥr(iω)‖_F / ‖Ĥ(iω)‖_F, Ĥ the transfer function between sparsemor's
normalized functionals."""

import numpy as np
import pytest
import scipy.sparse as sp

pytest.importorskip("pymor")
from pymor.models.iosys import SecondOrderModel  # noqa: E402

import sparsemor  # noqa: E402
from models import truss  # noqa: E402
from sparsemor.pymor import SparsemorReductor  # noqa: E402

BETA = 1e-5
BAND = (0.0, 2000.0)
TOL = 1e-3


@pytest.fixture(scope="module")
def lattice():
    """The 3×3×10 truss (N = 243 after clamping its base), its top face's nodes with their
    tributary weights (1/4 corner, 1/2 edge, 1 centre), and the fom."""
    M, K, nodes = truss(nx=3, ny=3, nz=10)
    keep = np.flatnonzero(np.repeat(nodes[:, 2] > 0.0, 3))
    index = {int(d): i for i, d in enumerate(keep)}
    M, K = M[keep][:, keep].tocsc(), K[keep][:, keep].tocsc()
    n = M.shape[0]
    top = np.flatnonzero(np.isclose(nodes[:, 2], nodes[:, 2].max()))
    edge = [np.isclose(nodes[top, a], nodes[top, a].min()) | np.isclose(nodes[top, a],
                                                                         nodes[top, a].max())
            for a in (0, 1)]
    weights = 0.5 ** (edge[0].astype(int) + edge[1].astype(int))
    z_dofs = [index[3 * int(i) + 2] for i in top]
    pressure, area = 2.0e3, 0.1 * 0.1  # Pa, m² of a full cell
    b = np.zeros((n, 2))
    b[z_dofs, 0] = -pressure * area * weights        # the pressure's nodal forces
    corner = index[3 * int(top[0])]                  # a unit x force at a top corner
    b[corner, 1] = 1.0
    c = np.zeros((2, n))
    c[0, z_dofs] = weights / weights.sum()           # the face's average z displacement
    mid = int(np.flatnonzero(np.isclose(nodes[:, 2], 0.5))[4])
    c[1, index[3 * mid]] = 1e3                       # x displacement of a mid node, in mm
    fom = SecondOrderModel.from_matrices(M, BETA * K, K, sp.csc_matrix(b), sp.csc_matrix(c),
                                         name="lattice")
    return fom


def normalized_h(h, scaling):
    """Ĥ: the fom's H (outputs × inputs) as sparsemor's H between its distinct normalized
    functionals, in the ROM's order (column j of B = s_j × functional p_j, likewise Cp)."""
    cols, rows = {}, {}
    for j, (p, s) in enumerate(scaling["inputs"]):
        cols.setdefault(p, (j, s))
    for i, (p, t) in enumerate(scaling["outputs"]):
        rows.setdefault(p, (i, t))
    out = np.empty((len(rows), len(cols)), complex)
    for p, (i, t) in rows.items():
        for q, (j, s) in cols.items():
            out[p, q] = h[i, j] / (t * s)
    return out


def test_general_b_and_cp_give_the_rom_of_the_fom(lattice):
    fom = lattice
    reductor = SparsemorReductor(fom, BAND, tolerance=TOL)
    rom = reductor.reduce()
    assert isinstance(rom, SecondOrderModel)
    assert (rom.dim_input, rom.dim_output) == (2, 2)
    # the pressure and the face average are one functional: 3 for sparsemor, not 4
    last = reductor.last_rom
    assert (last.n_inputs, last.n_outputs) == (2, 2)
    assert reductor.scaling["inputs"][0][0] == 1 and reductor.scaling["outputs"][0][0] == 1
    model = reductor.model
    faces = [model.coordinate(d) for d in last.dofs[:2]]
    assert faces == [("dof", faces[0][1]), ("input_column", 0)], faces

    grid = np.linspace(BAND[1] / 100, BAND[1], 100)
    lib_eps, _ = last.transfer_error(model, grid)
    eps_fom, eps_lib = [], []
    for f in grid:
        s = 2j * np.pi * f
        h, hr = fom.transfer_function.eval_tf(s), rom.transfer_function.eval_tf(s)
        eps_fom.append(np.linalg.norm(h - hr) / np.linalg.norm(h))
        hn = normalized_h(h, reductor.scaling)
        eps_lib.append(np.linalg.norm(hn - normalized_h(hr, reductor.scaling))
                       / np.linalg.norm(hn))
    eps_fom, eps_lib = np.array(eps_fom), np.array(eps_lib)
    reported = last.sampling["error"]
    agreement = np.max(np.abs(eps_lib - lib_eps))
    print(f"order {rom.order}; sparsemor's verified error {reported:.3e} (tol {TOL:g}); on 100 "
          f"points: pyMOR eps of sparsemor's functionals max {eps_lib.max():.3e}, sparsemor's "
          f"own eps max {lib_eps.max():.3e} (they differ by {agreement:.1e}); pyMOR eps of the "
          f"fom's B, Cp max {eps_fom.max():.3e}")
    assert last.sampling["converged"] and reported <= TOL
    # the same quantity computed twice (pyMOR's dense/sparse solves vs sparsemor's)
    assert agreement <= 1e-8
    # the verified error is a lower bound of the max over the band; on this grid the max is
    # the same (measured: both 6.681e-4 at order 7)
    assert reported / 3 <= eps_lib.max() <= TOL
    # the fom's own B and Cp weight the entries of H differently (the pressure's 20 N scale,
    # the millimetre output's 1e3): pyMOR's ε of the fom is not what sparsemor bounds
    # (measured max 2.27e-3, 2.3× the tolerance); the same order is all that holds
    assert eps_fom.max() <= 10 * TOL

    # V is in the fom's DoFs: Cp V = Cpr and Vᵀ B = Br (a clamped body: no inertia relief)
    V = last.V
    assert V.shape == (fom.order, rom.order)
    cpr, br = rom.Cp.matrix, rom.B.matrix
    assert np.linalg.norm(fom.Cp.matrix @ V - cpr) <= 1e-12 * np.linalg.norm(cpr)
    assert np.linalg.norm(V.T @ fom.B.matrix - br) <= 1e-12 * np.linalg.norm(br)
    u = rom.solution_space.from_numpy(np.arange(1.0, rom.order + 1.0)[:, None])
    x = reductor.reconstruct(u)
    assert x in fom.solution_space
    np.testing.assert_allclose(x.to_numpy()[:, 0], V @ u.to_numpy()[:, 0], rtol=1e-14)


def test_unit_vectors_keep_the_plain_scene_bit_for_bit(lattice):
    """Unit-vector B and Cp go through the DoF scene exactly as before the general path
    existed: the ROM equals sparsemor's own on that scene; scaled unit vectors give the same
    ROM with Br, Cpr scaled."""
    fom = lattice
    n = fom.order
    dofs_in, dofs_out = [10, 100, 200], [200, 5]
    b = sp.csc_matrix((np.ones(3), (dofs_in, range(3))), shape=(n, 3))
    c = sp.csc_matrix((np.ones(2), (range(2), dofs_out)), shape=(2, n))
    M, E, K = fom.M.matrix, fom.E.matrix, fom.K.matrix
    unit = SecondOrderModel.from_matrices(M, E, K, b, c)
    settings = dict(reference_frequencies=[300.0, 900.0, 1700.0], outputs_plus=4, threads=1)
    rom = SparsemorReductor(unit, BAND, **settings).reduce()
    model = sparsemor.Model(M, K, D=E)
    model.set_scene(dofs_in, dofs_out, BAND)
    direct = sparsemor.reduce_linefit(model, reference_frequencies=[300.0, 900.0, 1700.0],
                                      outputs_plus=4, threads=1)
    for name, got, want in (("M", rom.M, direct.Mr), ("E", rom.E, direct.Dr),
                            ("K", rom.K, direct.Kr), ("B", rom.B, direct.Br),
                            ("Cp", rom.Cp, direct.Cr)):
        np.testing.assert_array_equal(got.matrix, want, err_msg=name)
    scale_b, scale_c = np.array([2.0, -0.5, 3.0]), np.array([1e3, -4.0])
    scaled = SecondOrderModel.from_matrices(M, E, K, sp.csc_matrix(b @ sp.diags(scale_b)),
                                            sp.csc_matrix(sp.diags(scale_c) @ c))
    rom2 = SparsemorReductor(scaled, BAND, **settings).reduce()
    np.testing.assert_array_equal(rom2.K.matrix, direct.Kr)
    np.testing.assert_array_equal(rom2.B.matrix, direct.Br * scale_b)
    np.testing.assert_array_equal(rom2.Cp.matrix, scale_c[:, None] * direct.Cr)
