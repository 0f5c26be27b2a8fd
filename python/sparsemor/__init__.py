"""sparsemor: model order reduction of large sparse structural FE models.

M q'' + D q' + K q = B u, y = C q with N up to millions of DoFs becomes a ROM of order 10–100,
Mr, Dr, Kr, Br, Cr (numpy arrays), by line-fitting (a least-squares fit of the elastic
transfer functions at reference frequencies, chosen for a tolerance), SEREP or Craig–Bampton.

    import scipy.sparse as sp, sparsemor
    model = sparsemor.Model(M, K, rayleigh=(0.0, 1e-5))      # scipy.sparse, symmetric
    model.set_scene(inputs=[0, 1, 2], outputs=[0, 1, 2], band_hz=(0.0, 1000.0))
    rom = sparsemor.reduce_linefit(model, tolerance=1e-3)
    rom.Mr, rom.Kr, rom.Br, rom.sampling["error"]

Failing calls raise `SparsemorError` (or its subclasses `InvalidInputError`,
`NotAvailableError`, `CancelledError`) with the library's message. Nothing is printed: pass
`progress=callable(done, total, freq_hz)` to follow a reduction. `sparsemor.pymor` holds a
pyMOR reductor. The C functions themselves are `sparsemor.lib` (cffi; see sparsemor.h).
"""

from ._core import (
    ABI_VERSION,
    CancelledError,
    InvalidInputError,
    Model,
    NotAvailableError,
    Rom,
    SparsemorError,
    reduce_craig_bampton,
    reduce_linefit,
    reduce_serep,
    version,
)
from ._native import ffi, lib

__version__ = "{}.{}.{}".format(*version()[:3])

__all__ = [
    "ABI_VERSION",
    "CancelledError",
    "InvalidInputError",
    "Model",
    "NotAvailableError",
    "Rom",
    "SparsemorError",
    "ffi",
    "lib",
    "reduce_craig_bampton",
    "reduce_linefit",
    "reduce_serep",
    "version",
]
