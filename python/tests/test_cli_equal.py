"""The package and the `sparsemor` command are one library: on the built-in bar (read by scipy
from the files the command wrote) the Python ROM equals the command's ROM bit for bit.
(two threads each: for a thread count the library's results are the same on every run)."""

import numpy as np
import pytest

import sparsemor
from bar import built_in_bar, run

CASES = {
    "reference frequencies": (
        ["--method", "linefit", "--ref-freqs", "90,300,520,800", "--extra-interface", "3"],
        lambda m: sparsemor.reduce_linefit(m, reference_frequencies=[90, 300, 520, 800],
                                           outputs_plus=3, threads=2)),
    "tolerance": (
        ["--method", "linefit", "--tol", "1e-3", "--extra-interface", "5", "--verify", "0"],
        lambda m: sparsemor.reduce_linefit(m, tolerance=1e-3, outputs_plus=5, threads=2)),
    "serep": (
        ["--method", "serep", "--modes", "9"],
        lambda m: sparsemor.reduce_serep(m, modes=9, threads=2)),
    "craig-bampton": (
        ["--method", "craig-bampton", "--modes", "6", "--extra-interface", "1"],
        lambda m: sparsemor.reduce_craig_bampton(m, 6, outputs_plus=1, threads=2)),
}


@pytest.fixture(scope="module")
def bar(tmp_path_factory):
    """The bar's directory and two models of it: read by scipy and passed as matrices, and
    read by the library from the directory."""
    directory = tmp_path_factory.mktemp("bar") / "bar"
    M, K, rayleigh, nodes, scene = built_in_bar(directory)
    model = sparsemor.Model(M, K, rayleigh=rayleigh, nodes=nodes, dofs_per_node=3)
    model.set_scene(scene["inputs"], scene["outputs"], tuple(scene["band_hz"]))
    return directory, {"matrices": model, "directory": sparsemor.Model.from_dir(directory)}


@pytest.mark.parametrize("source", ["matrices", "directory"])
@pytest.mark.parametrize("case", CASES)
def test_python_rom_equals_the_commands_rom_bit_for_bit(bar, tmp_path, case, source):
    directory, models = bar
    model = models[source]
    args, reduce = CASES[case]
    run("reduce", directory, *args, "--threads", "2", "--out", tmp_path / "rom")
    cli = np.load(tmp_path / "rom" / "rom.npz")
    rom = reduce(model)
    print(f"{case}, model from {source}: order {rom.order}")
    np.testing.assert_array_equal(rom.dofs, cli["dofs"])
    for name in ("Mr", "Dr", "Kr", "Br", "Cr"):
        np.testing.assert_array_equal(getattr(rom, name), cli[name], err_msg=name)


def test_a_directory_that_is_not_a_model_is_refused_by_name(tmp_path):
    with pytest.raises(sparsemor.SparsemorError, match="model.toml"):
        sparsemor.Model.from_dir(tmp_path)
