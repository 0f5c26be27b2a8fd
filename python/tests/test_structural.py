"""Structural damping through the package (docs/design.md §3.12): `Model.set_structural_damping`
(H = eta K + K4), the ROM's `k4r` and `Model.damping_info`. A ROM of a model with a loss
factor reproduces scipy's dense solve of (K(1 + iη) − ω²M) x = b; K4 = ηK gives the same ROM
as η; bad arguments raise InvalidInputError naming the argument."""

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

import sparsemor
from models import chain, eps

ETA = 0.02
INPUTS, OUTPUTS = [119, 60], [119, 60, 30]
REFS = [4.0, 12.0, 25.0]  # p = 2 inputs, z = 3 frequencies: an exact fit at order 2pz = 12


def dense_h_structural(M, K, H, inputs, outputs, f):
    """H(iω) = C (K + iH − ω²M)⁻¹ B by scipy's dense solve (H: all of A's imaginary part)."""
    w = 2 * np.pi * f
    a = K.toarray() + 1j * H.toarray() - w * w * M.toarray()
    b = np.zeros((M.shape[0], len(inputs)), complex)
    b[inputs, range(len(inputs))] = 1.0
    return sla.solve(a, b)[outputs, :]


def exact_linefit(model):
    return sparsemor.reduce_linefit(model, reference_frequencies=REFS, outputs_plus=9,
                                    threads=1)


def test_a_loss_factor_rom_reproduces_the_dense_solve():
    M, K = chain(120)
    model = sparsemor.Model(M, K)
    assert model.damping_info["kind"] == "none"
    model.set_structural_damping(eta=ETA)
    info = model.damping_info
    assert info == {"kind": "proportional", "alpha": 0.0, "beta": 0.0, "eta": ETA,
                    "gamma": 0.0, "remainder_rank": 0, "remainder_dofs": 0}
    model.set_scene(INPUTS, OUTPUTS, (0.0, 30.0))
    rom = exact_linefit(model)
    assert rom.order == 12 and rom.k4r.shape == (12, 12)
    np.testing.assert_allclose(rom.k4r, ETA * rom.Kr, rtol=0, atol=1e-12 * abs(rom.Kr).max())
    errs = np.array([eps(dense_h_structural(M, K, ETA * K, INPUTS, OUTPUTS, f), rom.transfer(f))
                     for f in REFS])
    # without its iK4r term the ROM would be the undamped one: far off
    w = 2 * np.pi * REFS[1]
    undamped = rom.Cr @ np.linalg.solve(rom.Kr - w * w * rom.Mr, rom.Br)
    miss = eps(dense_h_structural(M, K, ETA * K, INPUTS, OUTPUTS, REFS[1]), undamped)
    lib_el, _ = rom.transfer_error(model, REFS)
    print(f"eta = {ETA}: eps vs scipy's dense solve at the reference frequencies {errs}; "
          f"library eps {lib_el}; without iK4r {miss:.2e}")
    assert errs.max() < 1e-7
    assert lib_el.max() < 1e-7
    assert miss > 1e-3


def test_k4_equal_to_eta_k_gives_the_rom_of_the_loss_factor():
    M, K = chain(120)
    a, b = sparsemor.Model(M, K), sparsemor.Model(M, K)
    a.set_structural_damping(eta=ETA)
    b.set_structural_damping(k4=ETA * K, lower_only=True)
    assert b.damping_info["kind"] == "proportional"
    assert abs(b.damping_info["eta"] - ETA) <= 1e-12 * ETA
    for m in (a, b):
        m.set_scene(INPUTS, OUTPUTS, (0.0, 30.0))
    ra, rb = exact_linefit(a), exact_linefit(b)
    grid = np.linspace(0.5, 30.0, 25)
    d = max(eps(ra.transfer(f), rb.transfer(f)) for f in grid)
    print(f"eta vs K4 = eta K: ROM transfer functions differ by {d:.2e} (max over 25 f)")
    assert d <= 1e-10


def test_a_damper_in_k4_and_its_removal():
    M, K = chain(120)
    k4 = sp.lil_matrix(K.shape)
    c = 0.1 * K[50, 50]
    k4[50, 50] = k4[80, 80] = c
    k4[50, 80] = k4[80, 50] = -c
    k4 = sp.csc_matrix(k4)
    model = sparsemor.Model(M, K, rayleigh=(0.0, 1e-4))
    model.set_structural_damping(eta=ETA, k4=k4)
    print(f"eta and a damper: {model.damping_info}")
    model.set_scene(INPUTS, OUTPUTS, (0.0, 30.0))
    rom = exact_linefit(model)
    errs = []
    for f in REFS:
        # iH + iωD = i(ηK + K4 + ω·1e-4 K)
        imag = ETA * K + k4 + 2 * np.pi * f * 1e-4 * K
        errs.append(eps(dense_h_structural(M, K, imag, INPUTS, OUTPUTS, f), rom.transfer(f)))
    print(f"eta and a damper in K4: eps at the reference frequencies {np.array(errs)}")
    assert max(errs) < 1e-7
    model.set_structural_damping()  # removed again
    assert model.damping_info["kind"] == "proportional"
    assert model.damping_info["eta"] == 0.0
    assert exact_linefit(model).k4r is None


def test_bad_structural_damping_is_refused_by_name():
    M, K = chain(20)
    model = sparsemor.Model(M, K)
    for eta, needle in ((float("nan"), "eta = NaN"), (-0.1, "eta = -0.1")):
        with pytest.raises(sparsemor.InvalidInputError, match=needle):
            model.set_structural_damping(eta=eta)
    with pytest.raises(sparsemor.InvalidInputError, match="k4 is 19x19, expected 20x20"):
        model.set_structural_damping(k4=K[:19, :19])
    skew = sp.csc_matrix(K, copy=True)
    skew[3, 4] = 7.0
    with pytest.raises(sparsemor.InvalidInputError, match="k4: .*not symmetric") as e:
        model.set_structural_damping(k4=skew)
    assert e.value.status_name == "INVALID_MODEL"
    assert model.damping_info["kind"] == "none"  # unchanged
    model.set_scene([19], [19], (0.0, 30.0))
    assert exact_linefit_small(model).k4r is None


def exact_linefit_small(model):
    return sparsemor.reduce_linefit(model, reference_frequencies=[5.0], outputs_plus=1,
                                    threads=1)
