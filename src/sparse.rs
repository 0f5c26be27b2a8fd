//! Small CSC helpers shared by the model, pencil and reduction code: symmetry check, lower
//! triangle extraction, products with full-storage symmetric matrices.
//!
//! Matrices are faer [`SparseColMat<usize, f64>`] in full storage (both triangles) with sorted
//! row indices per column, as produced by `io::matrix_market::read_sparse` and `fe`.

use faer::sparse::{SparseColMat, SparseColMatRef, SymbolicSparseColMat};
use faer::{Mat, MatRef};

/// Full-storage real sparse matrix, the crate's matrix type.
pub type Csc = SparseColMat<usize, f64>;

/// Largest |a_ij − a_ji| over all entries (a missing entry counts as zero), and max |a_ij|.
pub fn asymmetry(a: SparseColMatRef<'_, usize, f64>) -> (f64, f64) {
    let at = a
        .transpose()
        .to_col_major()
        .expect("transpose of a valid CSC matrix");
    let mut max_abs = 0.0f64;
    let mut max_diff = 0.0f64;
    for j in 0..a.ncols() {
        let (ra, va) = (a.symbolic().row_idx_of_col_raw(j), a.val_of_col(j));
        let (rt, vt) = (at.symbolic().row_idx_of_col_raw(j), at.val_of_col(j));
        let (mut p, mut q) = (0, 0);
        while p < ra.len() || q < rt.len() {
            let ia = ra.get(p).copied().unwrap_or(usize::MAX);
            let it = rt.get(q).copied().unwrap_or(usize::MAX);
            let d = if ia == it {
                let d = va[p] - vt[q];
                max_abs = max_abs.max(va[p].abs());
                p += 1;
                q += 1;
                d
            } else if ia < it {
                max_abs = max_abs.max(va[p].abs());
                p += 1;
                va[p - 1]
            } else {
                q += 1;
                vt[q - 1]
            };
            max_diff = max_diff.max(d.abs());
        }
    }
    (max_diff, max_abs)
}

/// The lower triangle (row ≥ column) of a full-storage matrix, as (col_ptr, row_idx, values).
pub fn lower_triangle(a: SparseColMatRef<'_, usize, f64>) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
    let n = a.ncols();
    let mut col_ptr = Vec::with_capacity(n + 1);
    let mut row_idx = Vec::new();
    let mut val = Vec::new();
    col_ptr.push(0);
    for j in 0..n {
        for (i, &v) in a
            .symbolic()
            .row_idx_of_col_raw(j)
            .iter()
            .zip(a.val_of_col(j))
        {
            if *i >= j {
                row_idx.push(*i);
                val.push(v);
            }
        }
        col_ptr.push(row_idx.len());
    }
    (col_ptr, row_idx, val)
}

/// y = A x for a full-storage sparse A and a dense real block x (faer's sparse × dense).
pub fn mul_dense(a: SparseColMatRef<'_, usize, f64>, x: MatRef<'_, f64>) -> Mat<f64> {
    let mut y = Mat::<f64>::zeros(a.nrows(), x.ncols());
    faer::sparse::linalg::matmul::sparse_dense_matmul(
        y.as_mut(),
        faer::Accum::Replace,
        a,
        x,
        1.0,
        faer::Par::Seq,
    );
    y
}

/// Builds a CSC matrix from parts that are known to be valid (sorted, in range).
///
/// # Errors
/// None in practice; the parts are checked by faer (a violation is a programming error).
pub fn from_parts(
    n_rows: usize,
    n_cols: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    val: Vec<f64>,
) -> Csc {
    SparseColMat::new(
        SymbolicSparseColMat::new_checked(n_rows, n_cols, col_ptr, None, row_idx),
        val,
    )
}
