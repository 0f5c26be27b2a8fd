"""Thin ctypes binding of the sparsemor C ABI (numpy + scipy.sparse).

    import scipy.sparse as sp, sparsemor
    model = sparsemor.Model(M, K, rayleigh=(0.0, 1e-4))          # scipy.sparse, symmetric
    model.set_scene(inputs=[9], outputs=[9, 5], band_hz=(0.0, 40.0))
    rom = sparsemor.reduce_linefit(model, reference_frequencies=[5.0, 20.0, 35.0],
                                   outputs_plus=3)
    rom.Mr, rom.Dr, rom.Kr, rom.Br, rom.Cr                        # numpy arrays
    eps_elastic, eps_total = rom.transfer_error(model, [1.0, 10.0, 30.0])

The shared library is taken from $SPARSEMOR_LIB, else from the cargo target directory
($CARGO_TARGET_DIR or <repo>/target, release before debug). Build it with
`cargo build --release -p sparsemor-ffi`.

Every failing call raises `SparsemorError` with the library's status name and message.
The C functions are available as `sparsemor.lib` for anything not wrapped here.
"""

import ctypes
import os
from ctypes import POINTER, c_char, c_char_p, c_double, c_int32, c_size_t, c_uint32, c_void_p

import numpy as np
import scipy.sparse as sp

__all__ = [
    "ABI_VERSION",
    "Model",
    "Rom",
    "SparsemorError",
    "reduce_linefit",
    "reduce_serep",
    "version",
    "lib",
]

#: The C ABI version this binding was written for (SPARSEMOR_ABI_VERSION in sparsemor.h).
ABI_VERSION = 1

STATUS_NAMES = {
    0: "OK",
    1: "NULL_POINTER",
    2: "INVALID_ARGUMENT",
    3: "INVALID_MODEL",
    4: "BUFFER_TOO_SMALL",
    5: "NOT_AVAILABLE",
    7: "SINGULAR",
    8: "NUMERICAL",
    9: "CANCELLED",
    10: "IO",
    11: "PANIC",
}

STORAGE_FULL, STORAGE_LOWER = 0, 1
MATRIX_MR, MATRIX_DR, MATRIX_KR, MATRIX_BR, MATRIX_CR, MATRIX_V = range(6)
METHOD_NAMES = {0: "linefit", 1: "serep"}


class SparsemorError(RuntimeError):
    """A failed sparsemor call: `status` (int), `status_name` and the library's message."""

    def __init__(self, status, message):
        self.status = status
        self.status_name = STATUS_NAMES.get(status, str(status))
        self.message = message
        super().__init__(f"{self.status_name}: {message}")


def _find_library():
    env = os.environ.get("SPARSEMOR_LIB")
    if env:
        return env
    here = os.path.dirname(os.path.abspath(__file__))
    repo = os.path.dirname(os.path.dirname(here))
    targets = [os.environ.get("CARGO_TARGET_DIR"), os.path.join(repo, "target")]
    for target in filter(None, targets):
        for profile in ("release", "debug"):
            for sub in ("", "deps"):
                p = os.path.join(target, profile, sub, "libsparsemor_ffi.so")
                if os.path.exists(p):
                    return p
    raise OSError(
        "libsparsemor_ffi.so not found: build it with `cargo build --release -p sparsemor-ffi` "
        "or point SPARSEMOR_LIB at it"
    )


lib = ctypes.CDLL(_find_library())


class _Csc(ctypes.Structure):
    _fields_ = [
        ("n", c_size_t),
        ("nnz", c_size_t),
        ("col_ptr", POINTER(c_size_t)),
        ("row_idx", POINTER(c_size_t)),
        ("values", POINTER(c_double)),
        ("storage", c_uint32),
    ]


class FitReport(ctypes.Structure):
    """Numerics of the line-fitting least-squares fit (SparsemorFitReport)."""

    _fields_ = [
        ("cond_raw", c_double),
        ("cond_equilibrated", c_double),
        ("rank", c_size_t),
        ("truncated", c_int32),
        ("residual_max", c_double),
        ("residual_mean", c_double),
        ("residual_argmax_dof", c_size_t),
        ("rows", c_size_t),
    ]

    def as_dict(self):
        return {name: getattr(self, name) for name, _ in self._fields_}


class _Definiteness(ctypes.Structure):
    _fields_ = [("positive_definite", c_int32), ("min_eig", c_double), ("max_eig", c_double)]


PROGRESS = ctypes.CFUNCTYPE(c_int32, c_size_t, c_size_t, c_double, c_void_p)

_P = c_void_p  # opaque handles
_ST = c_int32  # SparsemorStatus (a C enum: int)
_size_p = POINTER(c_size_t)
_dbl_p = POINTER(c_double)

_SIGNATURES = {
    "sparsemor_version": [POINTER(c_uint32)] * 4,
    "sparsemor_last_error_message": [POINTER(c_char), c_size_t],
    "sparsemor_model_new": [POINTER(_Csc), POINTER(_Csc), POINTER(_Csc), c_double, c_double,
                            _dbl_p, c_size_t, c_size_t, POINTER(_P)],
    "sparsemor_model_from_files": [POINTER(c_char_p), c_size_t, c_double, c_uint32, POINTER(_P)],
    "sparsemor_model_dof": [_P, c_size_t, POINTER(ctypes.c_uint64), POINTER(c_uint32)],
    "sparsemor_model_free": [_P],
    "sparsemor_model_n": [_P, _size_p],
    "sparsemor_model_is_free": [_P, POINTER(c_int32)],
    "sparsemor_model_set_scene": [_P, _size_p, c_size_t, _size_p, c_size_t, c_double, c_double],
    "sparsemor_options_new": [POINTER(_P)],
    "sparsemor_options_free": [_P],
    "sparsemor_options_set_threads": [_P, c_size_t],
    "sparsemor_options_set_tolerance": [_P, c_double],
    "sparsemor_options_set_interface": [_P, _size_p, c_size_t],
    "sparsemor_options_set_interface_outputs_plus": [_P, c_size_t],
    "sparsemor_options_set_reference_frequencies": [_P, _dbl_p, c_size_t],
    "sparsemor_options_set_reference_count": [_P, c_size_t],
    "sparsemor_options_set_serep_modes": [_P, c_size_t],
    "sparsemor_options_set_serep_mode_numbers": [_P, _size_p, c_size_t],
    "sparsemor_options_set_serep_retained": [_P, _size_p, c_size_t],
    "sparsemor_options_set_keep_basis": [_P, c_int32],
    "sparsemor_reduce_linefit": [_P, _P, PROGRESS, c_void_p, POINTER(_P)],
    "sparsemor_reduce_serep": [_P, _P, PROGRESS, c_void_p, POINTER(_P)],
    "sparsemor_rom_free": [_P],
    "sparsemor_rom_method": [_P, POINTER(c_uint32)],
    "sparsemor_rom_order": [_P, _size_p],
    "sparsemor_rom_n_inputs": [_P, _size_p],
    "sparsemor_rom_n_outputs": [_P, _size_p],
    "sparsemor_rom_matrix_shape": [_P, c_uint32, _size_p, _size_p],
    "sparsemor_rom_copy_matrix": [_P, c_uint32, _dbl_p, c_size_t, _size_p],
    "sparsemor_rom_dofs": [_P, _size_p, c_size_t, _size_p],
    "sparsemor_rom_reference_frequencies": [_P, _dbl_p, c_size_t, _size_p],
    "sparsemor_rom_fit_report": [_P, POINTER(FitReport)],
    "sparsemor_rom_serep_cond": [_P, _dbl_p],
    "sparsemor_rom_definiteness": [_P, POINTER(_Definiteness), POINTER(_Definiteness)],
    "sparsemor_rom_timing_count": [_P, _size_p],
    "sparsemor_rom_timing": [_P, c_size_t, POINTER(c_char), c_size_t, _size_p, _dbl_p],
    "sparsemor_rom_warning_count": [_P, _size_p],
    "sparsemor_rom_warning": [_P, c_size_t, POINTER(c_char), c_size_t, _size_p],
    "sparsemor_rom_transfer_error": [_P, _P, _dbl_p, c_size_t, _dbl_p, _dbl_p],
}
for _name, _args in _SIGNATURES.items():
    _f = getattr(lib, _name)
    _f.argtypes = _args
    _f.restype = _ST
lib.sparsemor_last_error_length.argtypes = []
lib.sparsemor_last_error_length.restype = c_size_t


def _last_error():
    n = lib.sparsemor_last_error_length()
    if n == 0:
        return ""
    buf = ctypes.create_string_buffer(n)
    lib.sparsemor_last_error_message(buf, n)
    return buf.value.decode("utf-8", "replace")


def _check(status):
    if status != 0:
        raise SparsemorError(status, _last_error())


def _index_array(values, what):
    a = np.ascontiguousarray(np.asarray(values).reshape(-1))
    if a.size and (not np.issubdtype(a.dtype, np.integer) or a.min() < 0):
        raise ValueError(f"{what}: need non-negative integers")
    a = a.astype(np.uintp)
    return a, a.ctypes.data_as(_size_p)


def _f64_array(values):
    a = np.ascontiguousarray(np.asarray(values, dtype=np.float64).reshape(-1))
    return a, a.ctypes.data_as(_dbl_p)


def version():
    """(major, minor, patch, abi) of the loaded library."""
    v = [c_uint32() for _ in range(4)]
    _check(lib.sparsemor_version(*[ctypes.byref(x) for x in v]))
    return tuple(x.value for x in v)


class _CscArrays:
    """A scipy.sparse matrix as CSC arrays kept alive for one call."""

    def __init__(self, a, n, what, lower=False):
        a = sp.csc_matrix(a, dtype=np.float64)
        if a.shape != (n, n):
            raise ValueError(f"{what} is {a.shape[0]}x{a.shape[1]}, expected {n}x{n}")
        a.sum_duplicates()
        a.sort_indices()
        if lower:
            a = sp.tril(a, format="csc")
            a.sort_indices()
        self.col_ptr = np.ascontiguousarray(a.indptr, dtype=np.uintp)
        self.row_idx = np.ascontiguousarray(a.indices, dtype=np.uintp)
        self.values = np.ascontiguousarray(a.data, dtype=np.float64)
        self.struct = _Csc(
            n,
            self.values.size,
            self.col_ptr.ctypes.data_as(_size_p),
            self.row_idx.ctypes.data_as(_size_p),
            self.values.ctypes.data_as(_dbl_p),
            STORAGE_LOWER if lower else STORAGE_FULL,
        )


class Model:
    """The full-order model M q'' + D q' + K q = B u, y = C q (a `SparsemorModel` handle).

    M, K (and D): square symmetric scipy.sparse matrices (or anything `scipy.sparse.csc_matrix`
    accepts). Damping: an explicit `D`, or `rayleigh=(alpha, beta)` for D = alpha M + beta K,
    or neither (undamped). `nodes`: optional (n_nodes, 3) coordinates with `dofs_per_node`
    (3 or 6) DoFs per node; they let the library detect a free body and separate its rigid
    part. `lower_only=True` passes only the lower triangles (the library mirrors them).
    """

    def __init__(self, M, K, D=None, rayleigh=(0.0, 0.0), nodes=None, dofs_per_node=3,
                 lower_only=False):
        self._h = None
        n = M.shape[0]
        m = _CscArrays(M, n, "M", lower_only)
        k = _CscArrays(K, n, "K", lower_only)
        d = None if D is None else _CscArrays(D, n, "D", lower_only)
        alpha, beta = rayleigh
        if nodes is not None:
            xyz, xyz_p = _f64_array(nodes)
            if xyz.size % 3:
                raise ValueError("nodes: need an (n_nodes, 3) array")
            n_nodes = xyz.size // 3
        else:
            xyz_p, n_nodes, dofs_per_node = None, 0, 0
        h = _P()
        _check(lib.sparsemor_model_new(
            ctypes.byref(m.struct), ctypes.byref(k.struct),
            None if d is None else ctypes.byref(d.struct),
            float(alpha), float(beta), xyz_p, n_nodes, dofs_per_node, ctypes.byref(h)))
        self._h = h
        self._free = lib.sparsemor_model_free  # still there at interpreter shutdown

    @classmethod
    def from_files(cls, *paths, stiffness_scale=1.0, mm_t_s=False):
        """A model read from the files an FE code wrote (ANSYS .full; APDL-Math exports with
        their mapping vector and node table; Abaqus *MATRIX GENERATE output with its .inp deck),
        as `sparsemor import` reads them. `stiffness_scale` multiplies K; `mm_t_s=True`
        converts a mm-t-s-N model to m-kg-s-N. Undamped, no scene yet; `dof(i)` names DoF i."""
        if not paths:
            raise ValueError("from_files: give the files to read")
        encoded = [os.fsencode(p) for p in paths]
        arr = (c_char_p * len(encoded))(*encoded)
        h = _P()
        _check(lib.sparsemor_model_from_files(arr, len(encoded), float(stiffness_scale),
                                              1 if mm_t_s else 0, ctypes.byref(h)))
        self = cls.__new__(cls)
        self._h = h
        self._free = lib.sparsemor_model_free
        return self

    def dof(self, i):
        """(node number, direction 'x'|'y'|'z'|'rx'|'ry'|'rz') of DoF i."""
        node, d = ctypes.c_uint64(), c_uint32()
        _check(lib.sparsemor_model_dof(self._h, int(i), ctypes.byref(node), ctypes.byref(d)))
        return node.value, ("x", "y", "z", "rx", "ry", "rz")[d.value - 1]

    def set_scene(self, inputs, outputs, band_hz):
        """Input DoFs (unit forces), output DoFs, band (f_lo, f_hi) in Hz."""
        i, ip = _index_array(inputs, "inputs")
        o, op = _index_array(outputs, "outputs")
        _check(lib.sparsemor_model_set_scene(self._h, ip, i.size, op, o.size,
                                             float(band_hz[0]), float(band_hz[1])))
        self.inputs, self.outputs, self.band_hz = list(i), list(o), tuple(band_hz)

    @property
    def n(self):
        v = c_size_t()
        _check(lib.sparsemor_model_n(self._h, ctypes.byref(v)))
        return v.value

    @property
    def is_free(self):
        v = c_int32()
        _check(lib.sparsemor_model_is_free(self._h, ctypes.byref(v)))
        return bool(v.value)

    def close(self):
        if getattr(self, "_h", None):
            self._free(self._h)
            self._h = None

    __del__ = close


class Rom:
    """A reduced model Mr q'' + Dr q' + Kr q = Br u, y = Cr q (a `SparsemorRom` handle)."""

    def __init__(self, handle):
        self._h = handle
        self._free = lib.sparsemor_rom_free  # still there at interpreter shutdown

    def _size(self, fn):
        v = c_size_t()
        _check(fn(self._h, ctypes.byref(v)))
        return v.value

    order = property(lambda self: self._size(lib.sparsemor_rom_order))
    n_inputs = property(lambda self: self._size(lib.sparsemor_rom_n_inputs))
    n_outputs = property(lambda self: self._size(lib.sparsemor_rom_n_outputs))

    @property
    def method(self):
        v = c_uint32()
        _check(lib.sparsemor_rom_method(self._h, ctypes.byref(v)))
        return METHOD_NAMES.get(v.value, str(v.value))

    def matrix(self, which):
        """A ROM matrix (MATRIX_MR ... MATRIX_V) as a (rows, cols) numpy array."""
        rows, cols = c_size_t(), c_size_t()
        _check(lib.sparsemor_rom_matrix_shape(self._h, which, ctypes.byref(rows),
                                              ctypes.byref(cols)))
        buf = np.empty(rows.value * cols.value, dtype=np.float64)
        _check(lib.sparsemor_rom_copy_matrix(self._h, which, buf.ctypes.data_as(_dbl_p),
                                             buf.size, None))
        return buf.reshape((rows.value, cols.value), order="F")

    Mr = property(lambda self: self.matrix(MATRIX_MR))
    Dr = property(lambda self: self.matrix(MATRIX_DR))
    Kr = property(lambda self: self.matrix(MATRIX_KR))
    Br = property(lambda self: self.matrix(MATRIX_BR))
    Cr = property(lambda self: self.matrix(MATRIX_CR))
    V = property(lambda self: self.matrix(MATRIX_V))

    def _copy(self, fn, dtype, ptr_type):
        need = c_size_t()
        _check(fn(self._h, None, 0, ctypes.byref(need)))
        buf = np.empty(need.value, dtype=dtype)
        _check(fn(self._h, buf.ctypes.data_as(ptr_type), buf.size, None))
        return buf

    @property
    def dofs(self):
        """Full-model DoF of each ROM coordinate."""
        return self._copy(lib.sparsemor_rom_dofs, np.uintp, _size_p).astype(np.int64)

    @property
    def reference_frequencies(self):
        return self._copy(lib.sparsemor_rom_reference_frequencies, np.float64, _dbl_p)

    @property
    def fit_report(self):
        """Line-fitting fit diagnostics (dict); None for SEREP."""
        r = FitReport()
        st = lib.sparsemor_rom_fit_report(self._h, ctypes.byref(r))
        if st == 5:  # NOT_AVAILABLE
            return None
        _check(st)
        return r.as_dict()

    @property
    def serep_cond(self):
        """cond(U_cr) of a SEREP ROM; None for line-fitting."""
        c = c_double()
        st = lib.sparsemor_rom_serep_cond(self._h, ctypes.byref(c))
        if st == 5:
            return None
        _check(st)
        return c.value

    @property
    def definiteness(self):
        """{'Mr': (spd, min_eig, max_eig), 'Kr': (...)}."""
        m, k = _Definiteness(), _Definiteness()
        _check(lib.sparsemor_rom_definiteness(self._h, ctypes.byref(m), ctypes.byref(k)))
        return {name: (bool(d.positive_definite), d.min_eig, d.max_eig)
                for name, d in (("Mr", m), ("Kr", k))}

    def _string(self, fn, *args):
        need = c_size_t()
        _check(fn(self._h, *args, None, 0, ctypes.byref(need)))
        buf = ctypes.create_string_buffer(need.value)
        _check(fn(self._h, *args, buf, need.value, None))
        return buf.value.decode("utf-8", "replace")

    @property
    def timings(self):
        """[(phase, seconds), ...]."""
        out = []
        for i in range(self._size(lib.sparsemor_rom_timing_count)):
            secs = c_double()
            need = c_size_t()
            _check(lib.sparsemor_rom_timing(self._h, i, None, 0, ctypes.byref(need), None))
            buf = ctypes.create_string_buffer(need.value)
            _check(lib.sparsemor_rom_timing(self._h, i, buf, need.value, None,
                                            ctypes.byref(secs)))
            out.append((buf.value.decode("utf-8", "replace"), secs.value))
        return out

    @property
    def warnings(self):
        return [self._string(lib.sparsemor_rom_warning, i)
                for i in range(self._size(lib.sparsemor_rom_warning_count))]

    def transfer(self, freq_hz):
        """Hr(i w) = Cr (Kr - w^2 Mr + i w Dr)^-1 Br (numpy, outputs x inputs)."""
        w = 2.0 * np.pi * freq_hz
        a = self.Kr - w * w * self.Mr + 1j * w * self.Dr
        return self.Cr @ np.linalg.solve(a, self.Br.astype(complex))

    def transfer_error(self, model, freqs_hz):
        """The library's eps(f) against the full model: (eps_elastic, eps_total) arrays."""
        f, fp = _f64_array(freqs_hz)
        e1 = np.empty(f.size)
        e2 = np.empty(f.size)
        _check(lib.sparsemor_rom_transfer_error(model._h, self._h, fp, f.size,
                                                e1.ctypes.data_as(_dbl_p),
                                                e2.ctypes.data_as(_dbl_p)))
        return e1, e2

    def close(self):
        if getattr(self, "_h", None):
            self._free(self._h)
            self._h = None

    __del__ = close


class _Options:
    def __init__(self):
        self._h = _P()
        _check(lib.sparsemor_options_new(ctypes.byref(self._h)))

    def __enter__(self):
        return self._h

    def __exit__(self, *exc):
        lib.sparsemor_options_free(self._h)


def _run(fn, model, opts, progress):
    """Calls a reduction with an optional Python progress callable(done, total, freq_hz):
    returning False cancels; an exception in it cancels and is re-raised here."""
    raised = []

    def trampoline(done, total, freq_hz, _user):
        try:
            return 1 if progress(done, total, freq_hz) is False else 0
        except BaseException as e:  # noqa: BLE001 - handed back to the caller below
            raised.append(e)
            return 1

    cb = PROGRESS(trampoline) if progress is not None else PROGRESS()
    h = _P()
    st = fn(model._h, opts, cb, None, ctypes.byref(h))
    if raised:
        raise raised[0]
    _check(st)
    return Rom(h)


def reduce_linefit(model, reference_frequencies=None, reference_count=None, interface=None,
                   outputs_plus=0, threads=0, keep_basis=False, tolerance=None, progress=None):
    """Line-fitting reduction. Give `reference_frequencies` (Hz) or `reference_count` (the
    library places that many points from the in-band resonances). Interface: an explicit
    DoF list, else the outputs plus `outputs_plus` spread DoFs. With `tolerance` the library
    chooses the reference frequencies itself (docs/design.md §3.5); given frequencies become seeds."""
    with _Options() as o:
        _check(lib.sparsemor_options_set_threads(o, threads))
        if interface is not None:
            d, dp = _index_array(interface, "interface")
            _check(lib.sparsemor_options_set_interface(o, dp, d.size))
        else:
            _check(lib.sparsemor_options_set_interface_outputs_plus(o, outputs_plus))
        if reference_frequencies is not None:
            f, fp = _f64_array(reference_frequencies)
            _check(lib.sparsemor_options_set_reference_frequencies(o, fp, f.size))
        if reference_count is not None:
            _check(lib.sparsemor_options_set_reference_count(o, reference_count))
        if tolerance is not None:
            _check(lib.sparsemor_options_set_tolerance(o, tolerance))
        _check(lib.sparsemor_options_set_keep_basis(o, int(bool(keep_basis))))
        return _run(lib.sparsemor_reduce_linefit, model, o, progress)


def reduce_serep(model, modes=None, mode_numbers=None, retained=None, threads=0,
                 keep_basis=False, progress=None):
    """SEREP reduction with the `modes` lowest deformation modes (or 1-based
    `mode_numbers`), retaining `retained` DoFs (default: the outputs; default modes: as many
    as retained DoFs)."""
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


if version()[3] != ABI_VERSION:
    raise ImportError(
        f"libsparsemor_ffi has ABI version {version()[3]}, this binding expects {ABI_VERSION}")
