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
//! Two products on the lower pattern serve the residuals of iterative refinement (`refine`):
//! [`symmetric_residual`] (b − A x and |A||x| + |b|) and [`symmetric_norm_inf`] (‖A‖∞), real or
//! complex.

use crate::pencil::Pencil;
use faer::sparse::{SymbolicSparseColMat, SymbolicSparseColMatRef};
use faer::{MatMut, MatRef, Par};

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

/// The entry types of the products below: real (the eigensolver's K − σM) and complex
/// (A(iω)).
pub(crate) trait Scalar:
    faer::traits::ComplexField
    + Copy
    + Send
    + Sync
    + std::ops::Mul<Output = Self>
    + std::ops::AddAssign
    + std::ops::SubAssign
{
    /// |Re a| + |Im a| (LAPACK's CABS1: within √2 of |a|, without a square root).
    fn abs1(self) -> f64;
}

impl Scalar for f64 {
    fn abs1(self) -> f64 {
        self.abs()
    }
}

impl Scalar for faer::c64 {
    fn abs1(self) -> f64 {
        self.re.abs() + self.im.abs()
    }
}

/// r ← b − A x, and with `s` also s ← |A| |x| + |b| (magnitudes by [`Scalar::abs1`]), for the
/// symmetric A whose lower triangle has the entries `entry(p)` (position p in the pencil's
/// pattern); columns in parallel under `par`. s is the denominator of the componentwise
/// backward error; the normwise one needs r only, and skipping s halves the work (this runs
/// after every solve of the eigensolver's interior shifts).
pub(super) fn symmetric_residual<T: Scalar>(
    pencil: &Pencil,
    entry: &(impl Fn(usize) -> T + Sync),
    b: MatRef<'_, T>,
    x: MatRef<'_, T>,
    r: MatMut<'_, T>,
    s: Option<MatMut<'_, f64>>,
    par: Par,
) {
    let column = |c: usize, r: faer::ColMut<'_, T>, s: Option<faer::ColMut<'_, f64>>| {
        let (mut bt, mut xt) = (Vec::new(), Vec::new());
        residual_column(
            pencil,
            entry,
            contiguous(b.col(c), &mut bt),
            contiguous(x.col(c), &mut xt),
            r.try_as_col_major_mut()
                .expect("a column of an owned Mat is contiguous")
                .as_slice_mut(),
            s.map(|s| {
                s.try_as_col_major_mut()
                    .expect("a column of an owned Mat is contiguous")
                    .as_slice_mut()
            }),
        );
    };
    use rayon::prelude::*;
    let parallel = par.degree() > 1 && x.ncols() > 1;
    match s {
        Some(s) if parallel => r
            .par_col_iter_mut()
            .zip(s.par_col_iter_mut())
            .enumerate()
            .for_each(|(c, (r, s))| column(c, r, Some(s))),
        Some(s) => r
            .col_iter_mut()
            .zip(s.col_iter_mut())
            .enumerate()
            .for_each(|(c, (r, s))| column(c, r, Some(s))),
        None if parallel => r
            .par_col_iter_mut()
            .enumerate()
            .for_each(|(c, r)| column(c, r, None)),
        None => r
            .col_iter_mut()
            .enumerate()
            .for_each(|(c, r)| column(c, r, None)),
    }
}

/// The entries of `v` as a slice: borrowed when contiguous, else copied into `tmp`.
fn contiguous<'a, T: Copy>(v: faer::ColRef<'a, T>, tmp: &'a mut Vec<T>) -> &'a [T] {
    match v.try_as_col_major() {
        Some(v) => v.as_slice(),
        None => {
            tmp.extend(v.iter().copied());
            tmp
        }
    }
}

/// One column of [`symmetric_residual`] on slices.
fn residual_column<T: Scalar>(
    pencil: &Pencil,
    entry: &impl Fn(usize) -> T,
    b: &[T],
    x: &[T],
    r: &mut [T],
    s: Option<&mut [f64]>,
) {
    let (cp, ri) = (pencil.col_ptr(), pencil.row_idx());
    r.copy_from_slice(b);
    for (j, &xj) in x.iter().enumerate() {
        let mut acc = T::zero_impl();
        for p in cp[j]..cp[j + 1] {
            let (i, a) = (ri[p], entry(p));
            r[i] -= a * xj;
            if i != j {
                acc += a * x[i];
            }
        }
        r[j] -= acc;
    }
    if let Some(s) = s {
        for (s, b) in s.iter_mut().zip(b) {
            *s = b.abs1();
        }
        for (j, &xj) in x.iter().enumerate() {
            let (xa, mut acc) = (xj.abs1(), 0.0);
            for p in cp[j]..cp[j + 1] {
                let (i, a) = (ri[p], entry(p).abs1());
                s[i] += a * xa;
                if i != j {
                    acc += a * x[i].abs1();
                }
            }
            s[j] += acc;
        }
    }
}

/// ‖A‖∞ (max row sum of [`Scalar::abs1`]) of the symmetric A whose lower triangle has the
/// entries `entry(p)` on the pencil's pattern.
pub(super) fn symmetric_norm_inf<T: Scalar>(pencil: &Pencil, entry: impl Fn(usize) -> T) -> f64 {
    let (cp, ri) = (pencil.col_ptr(), pencil.row_idx());
    let mut rows = vec![0.0f64; pencil.n()];
    for j in 0..pencil.n() {
        for p in cp[j]..cp[j + 1] {
            let (i, a) = (ri[p], entry(p).abs1());
            rows[i] += a;
            if i != j {
                rows[j] += a;
            }
        }
    }
    rows.into_iter().fold(0.0, f64::max)
}
