"""A pyMOR reductor backed by sparsemor: a `SecondOrderModel` M x'' + E x' + K x = B u,
y = Cp x whose operators are `NumpyMatrixOperator`s over scipy.sparse (or numpy) matrices,
reduced by line-fitting, SEREP or Craig–Bampton to a `SecondOrderModel` of the matrices
Mr, Er, Kr, Br, Cpr that sparsemor returns.

    from sparsemor.pymor import SparsemorReductor
    reductor = SparsemorReductor(fom, band_hz=(0.0, 1000.0), tolerance=1e-3)
    rom = reductor.reduce()                  # a pyMOR SecondOrderModel
    x = reductor.reconstruct(rom.solve(...)) # V x_r in fom.solution_space

B and Cp may be any matrices (a pressure load over a face, the average displacement over
it): each column of B and row of Cp is normalized by its signed entry of largest magnitude,
normalized vectors that agree to 1e-12 are one functional (a pressure load and the average
over the same face are proportional: their normalized forms are equal), sparsemor reduces the
model with that set of functionals (`sparsemor.Model.set_scene_general`), and the ROM's Br
columns and Cpr rows are scaled back, so the reduced `SecondOrderModel` is the ROM of the
given fom. When every column of B and row of Cp is a unit vector (one entry, 1), the model's
scene is plain DoFs, exactly as before. Functionals that are linearly dependent in another
way (a column of B that is a combination of others) are refused by sparsemor. Cv and the
feedthrough D must be zero.

The reduction's numerics (fit report, sampling log, warnings) stay available as
`reductor.last_rom` (a `sparsemor.Rom`), the full model as `reductor.model` (a
`sparsemor.Model`, e.g. for `last_rom.transfer_error(reductor.model, freqs_hz)`). Both speak
of sparsemor's functionals, the normalized ones: ε(f) = ‖Ĥ − Ĥr‖_F / ‖Ĥ‖_F with Ĥ the
transfer function between the distinct normalized inputs and outputs (`reductor.scaling`
says which fom column and row is which functional times which factor).
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


#: Normalized vectors (largest entry 1) whose entries differ by at most this are one
#: functional.
SAME = 1e-12


class _Functionals:
    """The distinct normalized functionals of B's columns and Cp's rows.

    `vectors[k]` = (indices, values) of functional k, normalized so that its entry of largest
    magnitude is 1; `inputs[j]` = (k, s): column j of B is s times functional k;
    `outputs[i]` = (k, t): row i of Cp is t times functional k."""

    def __init__(self):
        self.vectors = []
        self.inputs = []
        self.outputs = []

    def _add(self, idx, val, what: str):
        if idx.size == 0:
            raise _invalid(f"{what} is zero; every input and output needs a nonzero entry")
        big = int(np.argmax(np.abs(val)))
        factor = float(val[big])
        normalized = val / factor
        for k, (i2, v2) in enumerate(self.vectors):
            if i2.size == idx.size and np.array_equal(i2, idx) \
                    and np.max(np.abs(v2 - normalized)) <= SAME:
                return k, factor
        self.vectors.append((idx, normalized))
        return len(self.vectors) - 1, factor

    @classmethod
    def of(cls, b, cp) -> "_Functionals":
        f = cls()
        for a, name, what, out in ((sp.csc_matrix(b), "B", "column", f.inputs),
                                   (sp.csr_matrix(cp), "Cp", "row", f.outputs)):
            a = a.astype(np.float64)
            a.sum_duplicates()
            a.eliminate_zeros()
            a.sort_indices()
            for j in range(a.shape[0] if what == "row" else a.shape[1]):
                lo, hi = a.indptr[j], a.indptr[j + 1]
                out.append(f._add(a.indices[lo:hi].astype(np.int64), a.data[lo:hi].copy(),
                                  f"fom.{name}: {what} {j}"))
        return f

    def is_unit(self, k: int) -> bool:
        idx, val = self.vectors[k]
        return idx.size == 1 and val[0] == 1.0

    def side(self, entries) -> tuple:
        """The distinct functionals of one side in the order sparsemor's ROM lists them
        (unit vectors as DoFs first, then the matrix's columns/rows) and each one's
        position in that order."""
        distinct = list(dict.fromkeys(k for k, _ in entries))
        units = [k for k in distinct if self.is_unit(k)]
        general = [k for k in distinct if not self.is_unit(k)]
        order = units + general
        return units, general, {k: p for p, k in enumerate(order)}

    def matrix(self, ks, n: int, rows: bool):
        """The functionals `ks` as the columns of an n × len(ks) matrix (rows=False) or the
        rows of a len(ks) × n one."""
        if not ks:
            return None
        idx = np.concatenate([self.vectors[k][0] for k in ks])
        val = np.concatenate([self.vectors[k][1] for k in ks])
        pos = np.concatenate([np.full(self.vectors[k][0].size, p) for p, k in enumerate(ks)])
        a = sp.csc_matrix((val, (idx, pos)), shape=(n, len(ks)))
        return a.T.tocsc() if rows else a


class SparsemorReductor(BasicObject):
    """Reduces a pyMOR `SecondOrderModel` with sparsemor.

    Parameters
    ----------
    fom
        The full-order `SecondOrderModel` (not parametric; M, E, K, B, Cp as
        `NumpyMatrixOperator`s, E may be zero; Cv and D zero). B's columns and Cp's rows may
        be any vectors (module doc).
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
        if _matrix(fom.Cv, "Cv") is not None:
            raise _invalid("fom.Cv: must be zero (sparsemor's outputs are functionals of the "
                           "displacement; a velocity output would need the ROM of s·C, which "
                           "its line-fitting and error checks do not model)")
        if _matrix(fom.D, "D") is not None:
            raise _invalid("fom.D: must be zero (sparsemor's ROMs have no feedthrough)")
        self.__auto_init(locals())
        self.bases = {}
        self.scaling: Optional[dict] = None
        self.model: Optional[Model] = None
        self.last_rom: Optional[Rom] = None

    def _model(self) -> Model:
        fom = self.fom
        M, E, K = (_matrix(getattr(fom, n), n) for n in ("M", "E", "K"))
        if M is None or K is None:
            raise _invalid("fom.M and fom.K: must not be zero")
        model = Model(M, K, D=E, nodes=self.nodes, dofs_per_node=self.dofs_per_node)
        f = _Functionals.of(_matrix(fom.B, "B"), _matrix(fom.Cp, "Cp"))
        ins, in_general, in_pos = f.side(f.inputs)
        outs, out_general, out_pos = f.side(f.outputs)
        dof = [int(f.vectors[k][0][0]) for k in ins], [int(f.vectors[k][0][0]) for k in outs]
        if not in_general and not out_general:
            model.set_scene(dof[0], dof[1], tuple(self.band_hz))
        else:
            n = M.shape[0]
            model.set_scene_general(tuple(self.band_hz), input_dofs=dof[0],
                                    B=f.matrix(in_general, n, rows=False),
                                    output_dofs=dof[1], C=f.matrix(out_general, n, rows=True))
        # fom column j = s_j × ROM column in_pos[k_j]; fom row i = t_i × ROM row out_pos[k_i]
        self.scaling = {
            "inputs": [(in_pos[k], s) for k, s in f.inputs],
            "outputs": [(out_pos[k], t) for k, t in f.outputs],
        }
        return model

    def _scaled(self, br, cr):
        """Br, Cr of sparsemor's functionals as those of the fom's B and Cp (identical arrays
        when every column and row is its own unit-vector functional)."""
        ins, outs = self.scaling["inputs"], self.scaling["outputs"]
        if [p for p, _ in ins] != list(range(br.shape[1])) or any(s != 1.0 for _, s in ins):
            br = np.column_stack([s * br[:, p] for p, s in ins])
        if [p for p, _ in outs] != list(range(cr.shape[0])) or any(t != 1.0 for _, t in outs):
            cr = np.vstack([t * cr[p, :] for p, t in outs])
        return br, cr

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
        br, cr = self._scaled(rom.Br, rom.Cr)
        return SecondOrderModel.from_matrices(rom.Mr, rom.Dr, rom.Kr, br, cr,
                                              name=f"{self.fom.name}_sparsemor_{self.method}")

    def reconstruct(self, u):
        """V u: reduced coordinates (a VectorArray of the ROM's space) lifted to the full
        model's solution space (V is in the fom's own DoFs, also for general B and Cp)."""
        if "V" not in self.bases:
            raise _invalid("reconstruct: call reduce() first")
        return self.bases["V"].lincomb(u.to_numpy())
