//! Sparsity patterns the backends factor, all derived from the pencil's N×N lower pattern.
//!
//! The pencil A(iω) = K − ω²M + iωD is symmetric and stored by its lower triangle
//! (row ≥ column, rows sorted). The backends read it in three forms:
//! - [`lower`]: the pencil's own lower pattern, as a faer view (the symmetric factorizations
//!   of the real N×N matrix: LBLᵀ, LLᵀ, the inertia count);
//! - [`interleaved`]: the lower pattern of the real symmetric 2N×2N form
//!   [[Ar, Ai], [Ai, −Ar]] with the two unknowns of each DoF interleaved (LBLᵀ, damped);
//! - [`full`]: both triangles, for the unsymmetric LU backends (faer LU, UMFPACK), with the
//!   position of every entry in the lower pattern so the values are gathered per frequency.
//!
//! Two products on the lower pattern serve the residuals of iterative refinement:
//! [`symmetric_mul_sub`] (r ← r − A x) and [`symmetric_norm_inf`] (‖A‖∞).

use crate::pencil::Pencil;
use faer::sparse::{SymbolicSparseColMat, SymbolicSparseColMatRef};
use faer::{MatMut, MatRef};

/// The pencil's N×N lower pattern as a faer view, without re-checking it (this runs for
/// every factorization).
pub(super) fn lower(pencil: &Pencil) -> SymbolicSparseColMatRef<'_, usize> {
    let n = pencil.n();
    // SAFETY: `Pencil::new` builds this CSC pattern itself: `col_ptr` has n + 1 entries,
    // starts at 0, is non-decreasing and ends at `row_idx.len()`; each column's rows come
    // from a sorted merge of the sorted row lists of M, K (and D), each row taken once, so
    // they are strictly increasing, and they are row indices of N×N matrices, so < n. The
    // pencil is immutable afterwards.
    unsafe {
        SymbolicSparseColMatRef::new_unchecked(n, n, pencil.col_ptr(), None, pencil.row_idx())
    }
}

/// Lower pattern of the interleaved 2N×2N form: block (i, j) of the N×N lower pattern
/// becomes rows 2i, 2i+1 of columns 2j, 2j+1 (only 2j+1 for the diagonal of column 2j+1).
pub(super) fn interleaved(pencil: &Pencil) -> SymbolicSparseColMat<usize> {
    let n = pencil.n();
    let (cp, ri) = (pencil.col_ptr(), pencil.row_idx());
    let mut col_ptr = Vec::with_capacity(2 * n + 1);
    let mut row_idx = Vec::with_capacity(4 * ri.len());
    col_ptr.push(0);
    for j in 0..n {
        for &i in &ri[cp[j]..cp[j + 1]] {
            row_idx.extend([2 * i, 2 * i + 1]);
        }
        col_ptr.push(row_idx.len());
        for &i in &ri[cp[j]..cp[j + 1]] {
            if i == j {
                row_idx.push(2 * i + 1);
            } else {
                row_idx.extend([2 * i, 2 * i + 1]);
            }
        }
        col_ptr.push(row_idx.len());
    }
    SymbolicSparseColMat::new_checked(2 * n, 2 * n, col_ptr, None, row_idx)
}

/// Full (both triangles) pattern from the pencil's lower pattern, with the source position
/// of every entry in the lower pattern ([`crate::sparse::mirror_lower`]).
pub(super) fn full(pencil: &Pencil) -> (SymbolicSparseColMat<usize>, Vec<usize>) {
    let n = pencil.n();
    let (col_ptr, row_idx, src) =
        crate::sparse::mirror_lower(n, pencil.col_ptr(), pencil.row_idx());
    (
        SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx),
        src,
    )
}

/// r ← r − A x for the symmetric A whose lower triangle has the values `vals` on the
/// pencil's pattern.
pub(super) fn symmetric_mul_sub(
    pencil: &Pencil,
    vals: &[f64],
    x: MatRef<'_, f64>,
    mut r: MatMut<'_, f64>,
) {
    let (cp, ri) = (pencil.col_ptr(), pencil.row_idx());
    for c in 0..x.ncols() {
        for j in 0..pencil.n() {
            let xj = x[(j, c)];
            let mut acc = 0.0;
            for p in cp[j]..cp[j + 1] {
                let (i, a) = (ri[p], vals[p]);
                r[(i, c)] -= a * xj;
                if i != j {
                    acc += a * x[(i, c)];
                }
            }
            r[(j, c)] -= acc;
        }
    }
}

/// ‖A‖∞ (max row sum of |a_ij|) of the symmetric A whose lower triangle has the values `vals`
/// on the pencil's pattern.
pub(super) fn symmetric_norm_inf(pencil: &Pencil, vals: &[f64]) -> f64 {
    let (cp, ri) = (pencil.col_ptr(), pencil.row_idx());
    let mut rows = vec![0.0f64; pencil.n()];
    for j in 0..pencil.n() {
        for p in cp[j]..cp[j + 1] {
            let (i, a) = (ri[p], vals[p].abs());
            rows[i] += a;
            if i != j {
                rows[j] += a;
            }
        }
    }
    rows.into_iter().fold(0.0, f64::max)
}
