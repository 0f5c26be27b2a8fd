"""A pyMOR reductor backed by sparsemor: a `SecondOrderModel` M x'' + E x' + K x = B u,
y = Cp x whose operators are `NumpyMatrixOperator`s over scipy.sparse (or numpy) matrices,
reduced by line-fitting, SEREP or Craig–Bampton to a `SecondOrderModel` of the matrices
Mr, Er, Kr, Br, Cpr that sparsemor returns.

    from sparsemor.pymor import SparsemorReductor
    reductor = SparsemorReductor(fom, band_hz=(0.0, 1000.0), tolerance=1e-3)
    rom = reductor.reduce()                  # a pyMOR SecondOrderModel
    x = reductor.reconstruct(rom.solve(...)) # V x_r in fom.solution_space

sparsemor's inputs and outputs are DoFs: every column of B and every row of Cp must be a unit
vector (a force on one DoF, a displacement read at one DoF); Cv and the feedthrough D must be
zero. The reduction's numerics (fit report, sampling log, warnings) stay available as
`reductor.last_rom` (a `sparsemor.Rom`), the full model as `reductor.model` (a
`sparsemor.Model`, e.g. for `last_rom.transfer_error(reductor.model, freqs_hz)`).
"""

from __future__ import annotations

from typing import Optional, Sequence

import numpy as np
import scipy.sparse as sp
from pymor.core.base import BasicObject
from pymor.models.iosys import SecondOrderModel
from pymor.operators.constructions import ZeroOperator
from pymor.operators.numpy import NumpyMatrixOperator

from ._core import (
    InvalidInputError,
    Model,
    Progress,
    Rom,
    lib,
    reduce_craig_bampton,
    reduce_linefit,
    reduce_serep,
)

METHODS = ("linefit", "serep", "craig_bampton")


def _invalid(message: str) -> InvalidInputError:
    return InvalidInputError(lib.SPARSEMOR_STATUS_INVALID_ARGUMENT, message)


def _matrix(op, name: str):
    """The matrix of operator `name` of the model, or None for a zero operator."""
    if isinstance(op, ZeroOperator):
        return None
    if not isinstance(op, NumpyMatrixOperator):
        raise _invalid(f"fom.{name}: need a NumpyMatrixOperator (scipy.sparse or numpy "
                       f"matrix), got {type(op).__name__}")
    return op.matrix


def _unit_positions(a, name: str, axis: int) -> list:
    """The DoF of each unit column (axis 0) or unit row (axis 1) of a selector matrix."""
    a = sp.csc_matrix(a) if axis == 0 else sp.csr_matrix(a)
    a.eliminate_zeros()
    a.sum_duplicates()
    what = "column" if axis == 0 else "row"
    dofs = []
    for j in range(a.shape[1 - axis]):
        lo, hi = a.indptr[j], a.indptr[j + 1]
        if hi - lo != 1 or a.data[lo] != 1.0:
            raise _invalid(f"fom.{name}: {what} {j} is not a unit vector; sparsemor's inputs "
                           f"and outputs are DoFs (B's columns and Cp's rows select one DoF "
                           f"each with value 1)")
        dofs.append(int(a.indices[lo]))
    return dofs


class SparsemorReductor(BasicObject):
    """Reduces a pyMOR `SecondOrderModel` with sparsemor.

    Parameters
    ----------
    fom
        The full-order `SecondOrderModel` (not parametric; M, E, K, B, Cp as
        `NumpyMatrixOperator`s, E may be zero; Cv and D zero).
    band_hz
        The frequency band (f_lo, f_hi) in Hz the ROM must reproduce.
    method
        "linefit" (default), "serep" or "craig_bampton".
    tolerance, reference_frequencies, reference_count, max_points, max_order
        Line-fitting: a tolerance on the relative transfer-function error ε(f) over the band
        (the sampling loop chooses the frequencies), or the reference frequencies themselves
        (or their count). See `sparsemor.reduce_linefit`.
    modes
        SEREP: the number of lowest deformation modes (default: one per retained DoF);
        Craig–Bampton: the number of fixed-interface modes (required).
    interface, outputs_plus
        Line-fitting's interface and Craig–Bampton's boundary DoFs: an explicit list, else
        the outputs plus `outputs_plus` spread DoFs. SEREP retains `interface` (default: the
        outputs).
    nodes, dofs_per_node
        Optional node coordinates ((n_nodes, 3)) and DoFs per node: with them sparsemor
        detects a free body and separates its rigid part.
    threads
        Worker threads (0: every core).
    progress
        Optional callable(done, total, freq_hz); returning False cancels.
    """

    def __init__(self, fom: SecondOrderModel, band_hz: Sequence[float], method: str = "linefit",
                 tolerance: Optional[float] = None, reference_frequencies=None,
                 reference_count: Optional[int] = None, max_points: int = 0,
                 max_order: int = 0, modes: Optional[int] = None, interface=None,
                 outputs_plus: int = 0, nodes=None, dofs_per_node: int = 3, threads: int = 0,
                 progress: Optional[Progress] = None):
        if not isinstance(fom, SecondOrderModel):
            raise _invalid(f"fom: need a pyMOR SecondOrderModel, got {type(fom).__name__}")
        if fom.parametric:
            raise _invalid("fom: a parametric model; assemble it for one parameter value "
                           "first (fom.with_(...) / operator.assemble(mu))")
        if method not in METHODS:
            raise _invalid(f"method: {method!r}; choose one of {', '.join(METHODS)}")
        if method == "craig_bampton" and modes is None:
            raise _invalid("modes: Craig–Bampton needs the number of fixed-interface modes")
        for name in ("Cv", "D"):
            if _matrix(getattr(fom, name), name) is not None:
                raise _invalid(f"fom.{name}: must be zero (sparsemor's outputs are "
                               f"displacements, without feedthrough)")
        self.__auto_init(locals())
        self.bases = {}
        self.model: Optional[Model] = None
        self.last_rom: Optional[Rom] = None

    def _model(self) -> Model:
        fom = self.fom
        M, E, K = (_matrix(getattr(fom, n), n) for n in ("M", "E", "K"))
        if M is None or K is None:
            raise _invalid("fom.M and fom.K: must not be zero")
        model = Model(M, K, D=E, nodes=self.nodes, dofs_per_node=self.dofs_per_node)
        inputs = _unit_positions(_matrix(fom.B, "B"), "B", 0)
        outputs = _unit_positions(_matrix(fom.Cp, "Cp"), "Cp", 1)
        model.set_scene(inputs, outputs, tuple(self.band_hz))
        return model

    def reduce(self) -> SecondOrderModel:
        """The reduced `SecondOrderModel` (Mr, Er, Kr, Br, Cpr); V goes to `bases['V']`."""
        self.model = model = self._model()
        common = dict(threads=self.threads, keep_basis=True, progress=self.progress)
        if self.method == "linefit":
            rom = reduce_linefit(model, reference_frequencies=self.reference_frequencies,
                                 reference_count=self.reference_count,
                                 interface=self.interface, outputs_plus=self.outputs_plus,
                                 tolerance=self.tolerance, max_points=self.max_points,
                                 max_order=self.max_order, **common)
        elif self.method == "serep":
            rom = reduce_serep(model, modes=self.modes, retained=self.interface, **common)
        else:
            rom = reduce_craig_bampton(model, self.modes, interface=self.interface,
                                       outputs_plus=self.outputs_plus, **common)
        self.last_rom = rom
        self.bases["V"] = self.fom.solution_space.from_numpy(rom.V)
        return SecondOrderModel.from_matrices(rom.Mr, rom.Dr, rom.Kr, rom.Br, rom.Cr,
                                              name=f"{self.fom.name}_sparsemor_{self.method}")

    def reconstruct(self, u):
        """V u: reduced coordinates (a VectorArray of the ROM's space) lifted to the full
        model's solution space."""
        if "V" not in self.bases:
            raise _invalid("reconstruct: call reduce() first")
        return self.bases["V"].lincomb(u.to_numpy())
