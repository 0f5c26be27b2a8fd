"""The binding of sparsemor's C ABI (ffi/include/sparsemor.h) over cffi: models given as
scipy.sparse matrices, ROMs returned as numpy arrays, every failing call raised as a
`SparsemorError` carrying the library's message.

The C functions run with the GIL released (cffi releases it around every foreign call); the
progress callback takes it back while it runs.
"""

from __future__ import annotations

import os
from typing import Callable, Optional, Sequence, Union

import numpy as np
import scipy.sparse as sp

from ._native import ffi, lib

#: The C ABI version this binding was written for (SPARSEMOR_ABI_VERSION in sparsemor.h).
ABI_VERSION = 1

Progress = Callable[[int, int, float], Optional[bool]]
"""progress(done, total, freq_hz): called after each reference frequency of line-fitting
(before and after the work for SEREP and Craig–Bampton); returning False cancels."""

_PREFIX = "SPARSEMOR_STATUS_"
STATUS_NAMES = {getattr(lib, n): n[len(_PREFIX):] for n in dir(lib) if n.startswith(_PREFIX)}
DAMPING_KINDS = {
    lib.SPARSEMOR_DAMPING_NONE: "none",
    lib.SPARSEMOR_DAMPING_PROPORTIONAL: "proportional",
    lib.SPARSEMOR_DAMPING_LOW_RANK: "low_rank",
    lib.SPARSEMOR_DAMPING_GENERAL: "general",
}
METHOD_NAMES = {
    lib.SPARSEMOR_METHOD_LINEFIT: "linefit",
    lib.SPARSEMOR_METHOD_SEREP: "serep",
    lib.SPARSEMOR_METHOD_CRAIG_BAMPTON: "craig_bampton",
}


class SparsemorError(RuntimeError):
    """A failed sparsemor call: `status` (int), `status_name` (e.g. "INVALID_ARGUMENT") and
    the library's `message`, which names the field at fault and the fix."""

    def __init__(self, status: int, message: str):
        self.status = status
        self.status_name = STATUS_NAMES.get(status, str(status))
        self.message = message
        super().__init__(f"{self.status_name}: {message}")


class InvalidInputError(SparsemorError, ValueError):
    """Bad arguments or a bad model (status INVALID_ARGUMENT or INVALID_MODEL)."""


class NotAvailableError(SparsemorError, LookupError):
    """The ROM does not hold the requested quantity (status NOT_AVAILABLE)."""


class CancelledError(SparsemorError):
    """The progress callback returned False (status CANCELLED)."""


_ERROR_CLASSES = {
    lib.SPARSEMOR_STATUS_INVALID_ARGUMENT: InvalidInputError,
    lib.SPARSEMOR_STATUS_INVALID_MODEL: InvalidInputError,
    lib.SPARSEMOR_STATUS_NOT_AVAILABLE: NotAvailableError,
    lib.SPARSEMOR_STATUS_CANCELLED: CancelledError,
}


def _last_error() -> str:
    n = lib.sparsemor_last_error_length()
    if n == 0:
        return ""
    buf = ffi.new("char[]", n)
    lib.sparsemor_last_error_message(buf, n)
    return ffi.string(buf).decode("utf-8", "replace")


def _check(status: int) -> None:
    if status != lib.SPARSEMOR_STATUS_OK:
        raise _ERROR_CLASSES.get(status, SparsemorError)(status, _last_error())


def _out(ctype: str):
    return ffi.new(ctype + " *")


def _index_array(values, what: str):
    """Non-negative integers as a contiguous size_t array and its cffi pointer."""
    a = np.ascontiguousarray(np.asarray(values).reshape(-1))
    if a.size and (not np.issubdtype(a.dtype, np.integer) or a.min() < 0):
        raise InvalidInputError(lib.SPARSEMOR_STATUS_INVALID_ARGUMENT,
                                f"{what}: need non-negative integers")
    a = a.astype(np.uintp)
    return a, ffi.from_buffer("size_t[]", a)


def _f64_array(values):
    a = np.ascontiguousarray(np.asarray(values, dtype=np.float64).reshape(-1))
    return a, ffi.from_buffer("double[]", a)


def version() -> tuple:
    """(major, minor, patch, abi) of the loaded library."""
    v = [_out("uint32_t") for _ in range(4)]
    _check(lib.sparsemor_version(*v))
    return tuple(x[0] for x in v)


def _csc_buffers(a):
    """The CSC arrays of `a` (size_t indices, doubles) and the cffi buffers over them; the
    caller keeps both alive for the call."""
    arrays = (
        np.ascontiguousarray(a.indptr, dtype=np.uintp),
        np.ascontiguousarray(a.indices, dtype=np.uintp),
        np.ascontiguousarray(a.data, dtype=np.float64),
    )
    buffers = (
        ffi.from_buffer("size_t[]", arrays[0]),
        ffi.from_buffer("size_t[]", arrays[1]),
        ffi.from_buffer("double[]", arrays[2]),
    )
    return arrays, buffers


class _Csc:
    """A scipy.sparse matrix as the C ABI's SparsemorCsc, its arrays kept alive for one
    call."""

    def __init__(self, a, n: int, what: str, lower: bool = False):
        a = sp.csc_matrix(a, dtype=np.float64)
        if a.shape != (n, n):
            raise InvalidInputError(lib.SPARSEMOR_STATUS_INVALID_ARGUMENT,
                                    f"{what} is {a.shape[0]}x{a.shape[1]}, expected {n}x{n}")
        a.sum_duplicates()
        a.sort_indices()
        if lower:
            a = sp.tril(a, format="csc")
            a.sort_indices()
        self._arrays, self._buffers = _csc_buffers(a)
        values = self._arrays[2]
        storage = lib.SPARSEMOR_STORAGE_LOWER if lower else lib.SPARSEMOR_STORAGE_FULL
        self.ptr = ffi.new("SparsemorCsc *", {
            "n": n, "nnz": values.size, "col_ptr": self._buffers[0],
            "row_idx": self._buffers[1], "values": self._buffers[2], "storage": storage})


class _Sparse:
    """A scipy.sparse (or dense) matrix as the C ABI's SparsemorSparse (any shape), its arrays
    kept alive for one call."""

    def __init__(self, a, what: str):
        a = sp.csc_matrix(a, dtype=np.float64)
        a.sum_duplicates()
        a.sort_indices()
        self._arrays, self._buffers = _csc_buffers(a)
        values = self._arrays[2]
        self.ptr = ffi.new("SparsemorSparse *", {
            "nrows": a.shape[0], "ncols": a.shape[1], "nnz": values.size,
            "col_ptr": self._buffers[0], "row_idx": self._buffers[1],
            "values": self._buffers[2]})


_DIRECTIONS = ("x", "y", "z", "rx", "ry", "rz")


def _point_code(p, what: str) -> int:
    """(point, dir) with dir 0..5 or 'x' ... 'rz' as the ABI's code 6·point + dir."""
    try:
        point, d = p
    except (TypeError, ValueError):
        raise InvalidInputError(lib.SPARSEMOR_STATUS_INVALID_ARGUMENT,
                                f"{what}: {p!r}; give (point, direction) pairs") from None
    if isinstance(d, str):
        if d not in _DIRECTIONS:
            raise InvalidInputError(lib.SPARSEMOR_STATUS_INVALID_ARGUMENT,
                                    f"{what}: direction {d!r}; use one of {_DIRECTIONS}")
        d = _DIRECTIONS.index(d)
    if not (0 <= int(d) < 6) or int(point) < 0:
        raise InvalidInputError(lib.SPARSEMOR_STATUS_INVALID_ARGUMENT,
                                f"{what}: {p!r}; point >= 0 and direction 0..5")
    return 6 * int(point) + int(d)


class _ScenePart:
    """One side of a general scene as the C ABI's SparsemorScenePart, kept alive for a call."""

    def __init__(self, dofs, points, matrix, what: str):
        self._d = _index_array(list(dofs), f"{what} dofs")
        codes = [_point_code(p, f"{what} points") for p in points]
        self._p = _index_array(codes, f"{what} points")
        self._m = None if matrix is None else _Sparse(matrix, f"{what} matrix")
        self.ptr = ffi.new("SparsemorScenePart *", {
            "dofs": self._d[1] if self._d[0].size else ffi.NULL, "n_dofs": self._d[0].size,
            "point_dofs": self._p[1] if self._p[0].size else ffi.NULL,
            "n_point_dofs": self._p[0].size,
            "matrix": ffi.NULL if self._m is None else self._m.ptr})


class Model:
    """The full-order model M q'' + D q' + K q = B u, y = C q (docs/design.md §2).

    M, K (and D): square symmetric scipy.sparse matrices (or anything
    `scipy.sparse.csc_matrix` accepts). Damping: an explicit `D`, or `rayleigh=(alpha, beta)`
    for D = alpha M + beta K, or neither (undamped). `nodes`: optional (n_nodes, 3)
    coordinates with `dofs_per_node` (3 or 6) DoFs per node; they let the library detect a
    free body and separate its rigid part. `lower_only=True` passes only the lower triangles
    (the library mirrors them). B and C select DoFs: `set_scene(inputs, outputs, band_hz)`;
    or, with remote points (`add_remote_point`) and a sparse B and C,
    `set_scene_general(...)` (docs/design.md §3.11).
    """

    def __init__(self, M, K, D=None, rayleigh: tuple = (0.0, 0.0), nodes=None,
                 dofs_per_node: int = 3, lower_only: bool = False):
        self._h = None
        n = M.shape[0]
        m = _Csc(M, n, "M", lower_only)
        k = _Csc(K, n, "K", lower_only)
        d = None if D is None else _Csc(D, n, "D", lower_only)
        alpha, beta = rayleigh
        self._nodes = None
        if nodes is not None:
            xyz, xyz_p = _f64_array(nodes)
            if xyz.size % 3:
                raise InvalidInputError(lib.SPARSEMOR_STATUS_INVALID_ARGUMENT,
                                        "nodes: need an (n_nodes, 3) array")
            n_nodes = xyz.size // 3
            self._nodes = xyz.reshape(n_nodes, 3).copy()
        else:
            xyz_p, n_nodes, dofs_per_node = ffi.NULL, 0, 0
        h = _out("SparsemorModel *")
        _check(lib.sparsemor_model_new(m.ptr, k.ptr, ffi.NULL if d is None else d.ptr,
                                       float(alpha), float(beta), xyz_p, n_nodes,
                                       dofs_per_node, h))
        self._adopt(h[0])

    def _adopt(self, handle) -> None:
        self._h = handle
        if not hasattr(self, "_nodes"):
            self._nodes = None
        self._free = lib.sparsemor_model_free  # still there at interpreter shutdown

    @classmethod
    def from_files(cls, *paths: Union[str, os.PathLike], stiffness_scale: float = 1.0,
                   mm_t_s: bool = False) -> "Model":
        """A model read from the files an FE code wrote (ANSYS .full; APDL-Math exports with
        their mapping vector and node table; Abaqus *MATRIX GENERATE output with its .inp
        deck), as `sparsemor import` reads them. `stiffness_scale` multiplies K;
        `mm_t_s=True` converts a mm-t-s-N model to m-kg-s-N. Undamped, no scene yet;
        `dof(i)` names DoF i."""
        if not paths:
            raise InvalidInputError(lib.SPARSEMOR_STATUS_INVALID_ARGUMENT,
                                    "from_files: give the files to read")
        encoded = [ffi.new("char[]", os.fsencode(p)) for p in paths]
        arr = ffi.new("char *[]", encoded)
        units = lib.SPARSEMOR_UNITS_MM_T_S if mm_t_s else lib.SPARSEMOR_UNITS_AS_IS
        h = _out("SparsemorModel *")
        _check(lib.sparsemor_model_from_files(arr, len(encoded), float(stiffness_scale),
                                              units, h))
        self = cls.__new__(cls)
        self._adopt(h[0])
        return self

    @classmethod
    def from_dir(cls, path: Union[str, os.PathLike]) -> "Model":
        """A model directory (`model.toml` with M, K, optional D and nodes, as `sparsemor
        generate` and `sparsemor import` write it; docs/formats.md), validated as the command
        reads it, with its scene set (`inputs`, `outputs`, `band_hz` from `[scene]`)."""
        h = _out("SparsemorModel *")
        _check(lib.sparsemor_model_from_dir(ffi.new("char[]", os.fsencode(path)), h))
        self = cls.__new__(cls)
        self._adopt(h[0])
        return self

    def dof(self, i: int) -> tuple:
        """(node number, direction 'x'|'y'|'z'|'rx'|'ry'|'rz') of DoF i."""
        node, d = _out("uint64_t"), _out("uint32_t")
        _check(lib.sparsemor_model_dof(self._h, int(i), node, d))
        return node[0], ("x", "y", "z", "rx", "ry", "rz")[d[0] - 1]

    def set_scene(self, inputs: Sequence[int], outputs: Sequence[int],
                  band_hz: tuple) -> None:
        """Input DoFs (unit forces: B's columns), output DoFs (C's rows), band
        (f_lo, f_hi) in Hz."""
        i, ip = _index_array(inputs, "inputs")
        o, op = _index_array(outputs, "outputs")
        _check(lib.sparsemor_model_set_scene(self._h, ip, i.size, op, o.size,
                                             float(band_hz[0]), float(band_hz[1])))
        self.inputs, self.outputs, self.band_hz = list(i), list(o), tuple(band_hz)

    def set_structural_damping(self, eta: float = 0.0, k4=None,
                               lower_only: bool = False) -> None:
        """Structural (hysteretic) damping H = eta K + K4 (docs/design.md §3.12):
        A(iω) = K + iH − ω²M + iωD, a frequency-domain model. `eta`: the loss factor on K
        (finite, >= 0; Nastran's G); `k4`: None or a symmetric N×N scipy.sparse matrix
        (Nastran's K4; `lower_only=True` passes its lower triangle). Replaces any structural
        damping the model had (eta=0, k4=None removes it); the scene, remote points and a
        general scene stay (its coupled model gets TᵀK4T). ROMs reduced afterwards carry
        `Rom.k4r`."""
        k = None if k4 is None else _Csc(k4, self.n, "k4", lower_only)
        _check(lib.sparsemor_model_set_structural_damping(self._h, float(eta),
                                                           ffi.NULL if k is None else k.ptr))

    @property
    def damping_info(self) -> dict:
        """How the damping of the model the reductions work on is answered (docs/design.md
        §3.12): A(iω) = (1 + iη + iωβ)K − (ω² − iωα − iγ)M plus a remainder. `kind`:
        "none", "proportional" (one shifted real pencil answers every frequency), "low_rank"
        (plus a correction of rank `remainder_rank` on `remainder_dofs` DoFs) or "general"
        (one linearized space, §3.13, with a complex factor under structural damping;
        `remainder_dofs` None when the fit found no proportional part); `alpha`, `beta`,
        `eta`, `gamma` of the proportional part."""
        r = _out("SparsemorDampingInfo")
        _check(lib.sparsemor_model_damping_info(self._h, r))
        i = r[0]
        dofs = None if i.remainder_dofs == int(ffi.cast("size_t", -1)) else i.remainder_dofs
        return {"kind": DAMPING_KINDS.get(i.kind, str(i.kind)), "alpha": i.alpha,
                "beta": i.beta, "eta": i.eta, "gamma": i.gamma,
                "remainder_rank": i.remainder_rank, "remainder_dofs": dofs}

    def add_remote_point(self, nodes: Sequence[int], kind: str = "distributing",
                         position=None, weights=None) -> int:
        """A reference point with six DoFs tied to `nodes` (0-based node indices; the model
        needs node coordinates): `kind` "distributing" (RBE3: it moves as the weighted
        least-squares rigid motion of its nodes, its forces spread over them; optional
        `weights`, one per node) or "rigid" (RBE2: the nodes follow it). `position`: the
        reference point, default the nodes' centroid. Returns its index (0, 1, ...), by
        which `set_scene_general` names it."""
        kinds = {"rigid": lib.SPARSEMOR_POINT_RIGID,
                 "distributing": lib.SPARSEMOR_POINT_DISTRIBUTING}
        if kind not in kinds:
            raise InvalidInputError(lib.SPARSEMOR_STATUS_INVALID_ARGUMENT,
                                    f"kind: {kind!r}; use 'rigid' or 'distributing'")
        d, dp = _index_array(nodes, "nodes")
        if position is None and d.size == 0:
            position = (0.0, 0.0, 0.0)  # the library refuses the empty node set by name
        elif position is None:
            if self._nodes is None:
                raise InvalidInputError(lib.SPARSEMOR_STATUS_INVALID_ARGUMENT,
                                        "position: give it (this Model was not created with "
                                        "node coordinates here)")
            if d.max() >= len(self._nodes):
                raise InvalidInputError(lib.SPARSEMOR_STATUS_INVALID_ARGUMENT,
                                        f"nodes: {int(d.max())} is not a node (0.."
                                        f"{len(self._nodes) - 1})")
            position = self._nodes[d.astype(np.int64)].mean(axis=0)
        pos, pp = _f64_array(position)
        if pos.size != 3:
            raise InvalidInputError(lib.SPARSEMOR_STATUS_INVALID_ARGUMENT,
                                    "position: need 3 coordinates")
        if weights is None:
            wp = ffi.NULL
        else:
            w, wp = _f64_array(weights)
            if w.size != d.size:
                raise InvalidInputError(lib.SPARSEMOR_STATUS_INVALID_ARGUMENT,
                                        f"weights: {w.size} for {d.size} nodes; one per node")
        index = _out("size_t")
        _check(lib.sparsemor_model_add_remote_point(self._h, kinds[kind], pp,
                                                    dp if d.size else ffi.NULL, d.size, wp,
                                                    index))
        return index[0]

    def set_scene_general(self, band_hz: tuple, input_dofs: Sequence[int] = (),
                          input_points: Sequence = (), B=None, output_dofs: Sequence[int] = (),
                          output_points: Sequence = (), C=None) -> None:
        """A scene of general inputs and outputs (docs/design.md §3.11): DoFs (unit forces,
        displacements), remote points' DoFs as (point, direction) pairs (direction 0..5 or
        'x', 'y', 'z', 'rx', 'ry', 'rz'; a force or moment on the point, its motion), and a
        load matrix `B` (N × p: each column a load pattern) and an output matrix `C` (q × N:
        each row a functional, e.g. an average over a face), scipy.sparse or numpy.

        The ROM's Br columns are input_dofs, input_points, then B's columns; its Cr rows
        output_dofs, output_points, then C's rows. A column of B equal to a row of C is one
        functional (allowed); linearly dependent ones (e.g. proportional but not equal) are
        refused. The model is coupled with every remote point added so far; the ROM's
        `dofs` are then DoFs of the coupled model (`coordinate(i)` names them) and its `V`
        is in the original DoFs. `set_scene` returns to the plain model."""
        i = _ScenePart(input_dofs, input_points, B, "inputs")
        o = _ScenePart(output_dofs, output_points, C, "outputs")
        _check(lib.sparsemor_model_set_scene_general(self._h, i.ptr, o.ptr, float(band_hz[0]),
                                                     float(band_hz[1])))
        self.inputs = self.outputs = None
        self.band_hz = tuple(band_hz)

    @property
    def coordinate_count(self) -> int:
        """N' of the model the reductions work on (the coupled model of a general scene),
        else N."""
        v = _out("size_t")
        _check(lib.sparsemor_model_coordinate_count(self._h, v))
        return v[0]

    def coordinate(self, i: int) -> tuple:
        """What DoF i of the model the reductions work on is: ('dof', original DoF),
        ('point', point, direction name), ('input_column', k) of B or ('output_row', k) of
        C."""
        kind, a, b = _out("uint32_t"), _out("size_t"), _out("size_t")
        _check(lib.sparsemor_model_coordinate(self._h, int(i), kind, a, b))
        if kind[0] == lib.SPARSEMOR_COORDINATE_POINT:
            return ("point", a[0], _DIRECTIONS[b[0]])
        name = {lib.SPARSEMOR_COORDINATE_DOF: "dof",
                lib.SPARSEMOR_COORDINATE_INPUT_COLUMN: "input_column",
                lib.SPARSEMOR_COORDINATE_OUTPUT_ROW: "output_row"}[kind[0]]
        return (name, a[0])

    @property
    def n(self) -> int:
        v = _out("size_t")
        _check(lib.sparsemor_model_n(self._h, v))
        return v[0]

    @property
    def is_free(self) -> bool:
        v = _out("int32_t")
        _check(lib.sparsemor_model_is_free(self._h, v))
        return bool(v[0])

    def close(self) -> None:
        if getattr(self, "_h", None):
            self._free(self._h)
            self._h = None

    __del__ = close


class Rom:
    """A reduced model Mr q'' + Dr q' + Kr q = Br u, y = Cr q (in the frequency domain with
    + iK4r q when the model has structural damping), with the numerics of its reduction (fit
    report, conditioning, definiteness, timings, warnings)."""

    def __init__(self, handle):
        self._h = handle
        self._free = lib.sparsemor_rom_free  # still there at interpreter shutdown

    def _size(self, fn) -> int:
        v = _out("size_t")
        _check(fn(self._h, v))
        return v[0]

    order = property(lambda self: self._size(lib.sparsemor_rom_order))
    n_inputs = property(lambda self: self._size(lib.sparsemor_rom_n_inputs))
    n_outputs = property(lambda self: self._size(lib.sparsemor_rom_n_outputs))

    @property
    def method(self) -> str:
        """"linefit", "serep" or "craig_bampton"."""
        v = _out("uint32_t")
        _check(lib.sparsemor_rom_method(self._h, v))
        return METHOD_NAMES.get(v[0], str(v[0]))

    def matrix(self, which: int) -> np.ndarray:
        """A ROM matrix (lib.SPARSEMOR_MATRIX_MR ... _V) as a (rows, cols) numpy array."""
        rows, cols = _out("size_t"), _out("size_t")
        _check(lib.sparsemor_rom_matrix_shape(self._h, which, rows, cols))
        buf = np.empty(rows[0] * cols[0], dtype=np.float64)
        _check(lib.sparsemor_rom_copy_matrix(self._h, which, ffi.from_buffer("double[]", buf),
                                             buf.size, ffi.NULL))
        return buf.reshape((rows[0], cols[0]), order="F")

    Mr = property(lambda self: self.matrix(lib.SPARSEMOR_MATRIX_MR))
    Dr = property(lambda self: self.matrix(lib.SPARSEMOR_MATRIX_DR))
    Kr = property(lambda self: self.matrix(lib.SPARSEMOR_MATRIX_KR))
    Br = property(lambda self: self.matrix(lib.SPARSEMOR_MATRIX_BR))
    Cr = property(lambda self: self.matrix(lib.SPARSEMOR_MATRIX_CR))
    V = property(lambda self: self.matrix(lib.SPARSEMOR_MATRIX_V))
    """The basis V (N × order) in the DoFs of the model as created (for a general scene T V,
    the coupled model's basis mapped back): only when reduced with `keep_basis=True`."""

    @property
    def k4r(self) -> Optional[np.ndarray]:
        """The reduced structural damping K4r = VᵀHV, H = ηK + K4 (order × order), of a
        model with structural damping (docs/design.md §3.12); None without it."""
        return self._optional(lambda: self.matrix(lib.SPARSEMOR_MATRIX_K4R))

    def _copy(self, fn, dtype, ctype: str) -> np.ndarray:
        need = _out("size_t")
        _check(fn(self._h, ffi.NULL, 0, need))
        buf = np.empty(need[0], dtype=dtype)
        _check(fn(self._h, ffi.from_buffer(ctype + "[]", buf), buf.size, ffi.NULL))
        return buf

    @property
    def dofs(self) -> np.ndarray:
        """The full-model DoF of each interface coordinate of the ROM (of a general scene:
        DoFs of the coupled model, named by `Model.coordinate`)."""
        return self._copy(lib.sparsemor_rom_dofs, np.uintp, "size_t").astype(np.int64)

    @property
    def reference_frequencies(self) -> np.ndarray:
        """Line-fitting's reference frequencies in Hz."""
        return self._copy(lib.sparsemor_rom_reference_frequencies, np.float64, "double")

    @property
    def fixed_interface_frequencies(self) -> Optional[np.ndarray]:
        """Craig–Bampton's fixed-interface mode frequencies in Hz; None for other methods."""
        return self._optional(lambda: self._copy(lib.sparsemor_rom_fixed_interface_frequencies,
                                                 np.float64, "double"))

    @staticmethod
    def _optional(read):
        try:
            return read()
        except NotAvailableError:
            return None

    def _struct(self, fn, ctype: str) -> Optional[dict]:
        def read():
            r = _out(ctype)
            _check(fn(self._h, r))
            return {name: getattr(r[0], name) for name, _ in ffi.typeof(r[0]).fields}
        return self._optional(read)

    @property
    def fit_report(self) -> Optional[dict]:
        """Line-fitting's least-squares numerics (condition numbers raw and equilibrated,
        rank, truncation, residuals; docs/design.md §3.4); None for other methods."""
        return self._struct(lib.sparsemor_rom_fit_report, "SparsemorFitReport")

    @property
    def craig_bampton_report(self) -> Optional[dict]:
        """Craig–Bampton's numerics (boundary size, modes, K_ii factorization, residuals;
        docs/design.md §3.8); None for other methods."""
        return self._struct(lib.sparsemor_rom_craig_bampton_report,
                            "SparsemorCraigBamptonReport")

    @property
    def serep_cond(self) -> Optional[float]:
        """cond(U_cr) of a SEREP ROM; None for other methods."""
        def read():
            c = _out("double")
            _check(lib.sparsemor_rom_serep_cond(self._h, c))
            return c[0]
        return self._optional(read)

    @property
    def definiteness(self) -> dict:
        """{'Mr': (positive_definite, min_eig, max_eig), 'Kr': (...)}."""
        m, k = _out("SparsemorDefiniteness"), _out("SparsemorDefiniteness")
        _check(lib.sparsemor_rom_definiteness(self._h, m, k))
        return {name: (bool(d.positive_definite), d.min_eig, d.max_eig)
                for name, d in (("Mr", m[0]), ("Kr", k[0]))}

    @property
    def sampling(self) -> Optional[dict]:
        """For a ROM reduced with a tolerance (docs/design.md §3.5): the tolerance, the error
        reached, whether it converged, the factorizations the loop spent (the inertia count's
        included) and the run's in all (the verification's too), and the step log; None
        otherwise."""
        def read():
            tol, err, facts = _out("double"), _out("double"), _out("size_t")
            _check(lib.sparsemor_rom_sampling_result(self._h, tol, err, facts))
            sampled, converged = _out("int32_t"), _out("int32_t")
            _check(lib.sparsemor_rom_sampling_converged(self._h, sampled, converged))
            in_all = _out("size_t")
            _check(lib.sparsemor_rom_factorizations_in_all(self._h, in_all))
            return {"tolerance": tol[0], "error": err[0], "converged": bool(converged[0]),
                    "factorizations": facts[0], "factorizations_in_all": in_all[0],
                    "steps": self._steps()}
        return self._optional(read)

    def _steps(self) -> list:
        names = ("order", "n_points", "indicator_max", "true_error", "sampled_error",
                 "factorizations", "seconds")
        types = ("size_t", "size_t", "double", "double", "double", "size_t", "double")
        steps = []
        for i in range(self._size(lib.sparsemor_rom_step_count)):
            outs = [_out(t) for t in types]
            _check(lib.sparsemor_rom_step(self._h, i, *outs))
            steps.append({name: o[0] for name, o in zip(names, outs)})
        return steps

    def _text(self, fn, index: int, *rest) -> str:
        need = _out("size_t")
        _check(fn(self._h, index, ffi.NULL, 0, need, *rest))
        buf = ffi.new("char[]", need[0])
        _check(fn(self._h, index, buf, need[0], ffi.NULL, *rest))
        return ffi.string(buf).decode("utf-8", "replace")

    @property
    def timings(self) -> list:
        """[(phase, seconds), ...] of the reduction."""
        out = []
        for i in range(self._size(lib.sparsemor_rom_timing_count)):
            secs = _out("double")
            name = self._text(lib.sparsemor_rom_timing, i, secs)
            out.append((name, secs[0]))
        return out

    @property
    def warnings(self) -> list:
        """The reduction's warnings (ill-conditioning, rank truncation, indefinite Mr/Kr)."""
        return [self._text(lib.sparsemor_rom_warning, i)
                for i in range(self._size(lib.sparsemor_rom_warning_count))]

    def transfer(self, freq_hz: float) -> np.ndarray:
        """Hr(iω) = Cr (Kr + iK4r − ω² Mr + iω Dr)⁻¹ Br (outputs × inputs), dense; K4r
        only with structural damping."""
        w = 2.0 * np.pi * freq_hz
        a = self.Kr - w * w * self.Mr + 1j * w * self.Dr
        k4r = self.k4r
        if k4r is not None:
            a = a + 1j * k4r
        return self.Cr @ np.linalg.solve(a, self.Br.astype(complex))

    def transfer_error(self, model: Model, freqs_hz) -> tuple:
        """ε(f) = ‖H − Hr‖_F / ‖H‖_F against the full model (eq. 23; one sparse
        factorization per frequency): (eps_elastic, eps_total) arrays."""
        f, fp = _f64_array(freqs_hz)
        e1, e2 = np.empty(f.size), np.empty(f.size)
        _check(lib.sparsemor_rom_transfer_error(model._h, self._h, fp, f.size,
                                                ffi.from_buffer("double[]", e1),
                                                ffi.from_buffer("double[]", e2)))
        return e1, e2

    def close(self) -> None:
        if getattr(self, "_h", None):
            self._free(self._h)
            self._h = None

    __del__ = close


class _Options:
    """A SparsemorOptions handle for the duration of one reduction."""

    def __enter__(self):
        h = _out("SparsemorOptions *")
        _check(lib.sparsemor_options_new(h))
        self._h = h[0]
        return self._h

    def __exit__(self, *exc):
        lib.sparsemor_options_free(self._h)


def _set_interface(o, interface, outputs_plus: int) -> None:
    if interface is not None:
        d, dp = _index_array(interface, "interface")
        _check(lib.sparsemor_options_set_interface(o, dp, d.size))
    else:
        _check(lib.sparsemor_options_set_interface_outputs_plus(o, outputs_plus))


def _run(fn, model: Model, opts, progress: Optional[Progress]) -> Rom:
    """Calls a reduction, the GIL released, with an optional progress callable: returning
    False cancels; an exception in it cancels and is re-raised here."""
    raised = []

    def trampoline(done, total, freq_hz, _user):
        try:
            return 1 if progress(done, total, freq_hz) is False else 0
        except BaseException as e:  # noqa: BLE001 - handed back to the caller below
            raised.append(e)
            return 1

    cb = ffi.callback("SparsemorProgressFn", trampoline) if progress is not None else ffi.NULL
    h = _out("SparsemorRom *")
    st = fn(model._h, opts, cb, ffi.NULL, h)
    if raised:
        raise raised[0]
    _check(st)
    return Rom(h[0])


def reduce_linefit(model: Model, reference_frequencies=None,
                   reference_count: Optional[int] = None, interface=None,
                   outputs_plus: int = 0, threads: int = 0, keep_basis: bool = False,
                   tolerance: Optional[float] = None, max_points: int = 0, max_order: int = 0,
                   progress: Optional[Progress] = None) -> Rom:
    """Line-fitting (docs/design.md §3.3): V = Πᵀ[I; W], W fitted by least squares so that the
    elastic transfer functions at the reference frequencies are reproduced, then the Galerkin
    projection Mr = Vᵀ M V, ...

    Give `reference_frequencies` (Hz), or `reference_count` (the library places that many
    points from the in-band resonances), or a `tolerance` on ε(f) over the band: the sampling
    loop (§3.5) then chooses the frequencies, within `max_points` full solves and order
    `max_order` (0: the library's defaults); given frequencies become seeds. Interface: an
    explicit DoF list, else the outputs plus `outputs_plus` spread DoFs. `threads` = 0 uses
    every core."""
    with _Options() as o:
        _check(lib.sparsemor_options_set_threads(o, threads))
        _set_interface(o, interface, outputs_plus)
        if reference_frequencies is not None:
            f, fp = _f64_array(reference_frequencies)
            _check(lib.sparsemor_options_set_reference_frequencies(o, fp, f.size))
        if reference_count is not None:
            _check(lib.sparsemor_options_set_reference_count(o, reference_count))
        if tolerance is not None:
            _check(lib.sparsemor_options_set_tolerance(o, tolerance))
            _check(lib.sparsemor_options_set_sampling_limits(o, max_points, max_order))
        _check(lib.sparsemor_options_set_keep_basis(o, int(bool(keep_basis))))
        return _run(lib.sparsemor_reduce_linefit, model, o, progress)


def reduce_serep(model: Model, modes: Optional[int] = None, mode_numbers=None,
                 retained=None, threads: int = 0, keep_basis: bool = False,
                 progress: Optional[Progress] = None) -> Rom:
    """SEREP (docs/design.md §3.6): V = U_c U_cr⁺ with the `modes` lowest deformation modes
    (or the 1-based `mode_numbers`), retaining the DoFs `retained` (default: the outputs;
    default modes: as many as retained DoFs)."""
    with _Options() as o:
        _check(lib.sparsemor_options_set_threads(o, threads))
        if modes is not None:
            _check(lib.sparsemor_options_set_serep_modes(o, modes))
        if mode_numbers is not None:
            d, dp = _index_array(mode_numbers, "mode_numbers")
            _check(lib.sparsemor_options_set_serep_mode_numbers(o, dp, d.size))
        if retained is not None:
            d, dp = _index_array(retained, "retained")
            _check(lib.sparsemor_options_set_serep_retained(o, dp, d.size))
        _check(lib.sparsemor_options_set_keep_basis(o, int(bool(keep_basis))))
        return _run(lib.sparsemor_reduce_serep, model, o, progress)


def reduce_craig_bampton(model: Model, modes: int, interface=None, outputs_plus: int = 0,
                         threads: int = 0, keep_basis: bool = False,
                         progress: Optional[Progress] = None) -> Rom:
    """Craig–Bampton (docs/design.md §3.8): V = [I 0; Ψ Φ_c] with the static constraint modes
    Ψ = −K_ii⁻¹ K_ib of the boundary DoFs (the interface: explicit, else the outputs plus
    `outputs_plus` spread DoFs) and the `modes` lowest fixed-interface modes Φ_c."""
    with _Options() as o:
        _check(lib.sparsemor_options_set_threads(o, threads))
        _set_interface(o, interface, outputs_plus)
        _check(lib.sparsemor_options_set_craig_bampton_modes(o, modes))
        _check(lib.sparsemor_options_set_keep_basis(o, int(bool(keep_basis))))
        return _run(lib.sparsemor_reduce_craig_bampton, model, o, progress)


if version()[3] != ABI_VERSION:
    raise ImportError(f"the sparsemor library has ABI version {version()[3]}, this package "
                      f"expects {ABI_VERSION}: reinstall the package")
