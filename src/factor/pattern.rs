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
//! [`symmetric_residual`] (b − A x and the componentwise backward error) and
//! [`symmetric_norm_inf`] (‖A‖∞), real or complex.

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

/// r ← b − A x for the symmetric A whose lower triangle has the entries `entry(p)` on the
/// pencil's pattern, in the N × k block of `scratch` ([`ResidualScratch::block`]), which holds
/// b on entry. With `componentwise`, also returns the componentwise backward error
/// maxᵢ,c |r|ᵢc / (|A||x| + |b|)ᵢc over the entries whose denominator is positive (magnitudes
/// by [`Scalar::abs1`]); without, returns 0 and skips the denominator, which halves the work
/// (this runs after every solve of the eigensolver's interior shifts, whose refinement stops
/// by a normwise error).
///
/// The columns go in blocks of up to [`RESIDUAL_BLOCK`], interleaved row by row, so one pass
/// over the pattern serves a whole block: the pass is memory-bound (measured on the 10⁶-DoF
/// bar, ten right-hand sides column by column: 1.3 s per residual, which made the sweep's
/// refinement cost twice the factorization). Blocks run in parallel under `par`. Every entry
/// of r is computed by the same operations in the same order as column by column.
///
/// Memory: a block's columns of the N × k block hold b, then the interleaved x, then r, so
/// beside it the residual needs only the interleaved r and |A||x| + |b| of each block (N × k
/// values and N × k magnitudes in all); no copy of b and no column-major denominator (on the
/// 10⁶-DoF bar's sweep, ten columns: 0.48 GB less than a block each for b, r, s, x and |x|).
pub(super) fn symmetric_residual<T: Scalar, F: Fn(usize) -> T + Sync>(
    a: Lower<'_, F>,
    x: MatRef<'_, T>,
    componentwise: bool,
    scratch: &mut ResidualScratch<T>,
    par: Par,
) -> f64 {
    let (n, k) = (x.nrows(), x.ncols());
    if k == 0 {
        return 0.0;
    }
    assert_eq!(scratch.xr.len(), n * k, "the residual block is N × k");
    let threads = par.degree().max(1);
    let width = k.div_ceil(threads).clamp(1, RESIDUAL_BLOCK);
    let blocks = k.div_ceil(width);
    if scratch.blocks.len() < blocks {
        scratch.blocks.resize_with(blocks, BlockScratch::default);
    }
    let run = |(bi, (xr, ws)): (usize, (&mut [T], &mut BlockScratch<T>))| {
        let (c0, w) = (bi * width, width.min(k - bi * width));
        residual_block(a, x.subcols(c0, w), xr, componentwise, ws)
    };
    let parts = scratch
        .xr
        .chunks_mut(n * width)
        .zip(&mut scratch.blocks[..blocks]);
    let worst = if threads > 1 && blocks > 1 {
        use rayon::prelude::*;
        let parts: Vec<_> = parts.collect();
        parts
            .into_par_iter()
            .enumerate()
            .map(run)
            .reduce(|| 0.0, f64::max)
    } else {
        parts.enumerate().map(run).fold(0.0, f64::max)
    };
    scratch.columns.clear();
    for b in &scratch.blocks[..blocks] {
        scratch.columns.extend_from_slice(&b.columns);
    }
    worst
}

/// Rows per tile when columns are copied to and from the interleaved layout: the tile's
/// rows stay in cache while each column streams through it (column by column over all
/// rows, every column re-read the whole interleaved buffer: 4.6 s of the 10⁶-DoF bar's
/// 20-frequency sweep went to the copy back alone).
const TILE: usize = 512;

/// The entries of `m` mapped by `f` into `v` (of length n·w), row by row: entry (i, c) at
/// i·w + c.
fn interleave<T: Copy, U: Copy>(m: MatRef<'_, T>, v: &mut [U], f: impl Fn(T) -> U) {
    let (n, w) = (m.nrows(), m.ncols());
    for i0 in (0..n).step_by(TILE) {
        let i1 = (i0 + TILE).min(n);
        for (c, col) in m.col_iter().enumerate() {
            for i in i0..i1 {
                v[i * w + c] = f(col[i]);
            }
        }
    }
}

/// The inverse of [`interleave`] (without a map): entry i·w + c of `v` into `m[(i, c)]`.
fn deinterleave<U: Copy>(v: &[U], mut m: MatMut<'_, U>) {
    let (n, w) = (m.nrows(), m.ncols());
    for i0 in (0..n).step_by(TILE) {
        let i1 = (i0 + TILE).min(n);
        for c in 0..w {
            for i in i0..i1 {
                m[(i, c)] = v[i * w + c];
            }
        }
    }
}

/// The symmetric matrix whose lower triangle has the entries `entry(p)` on the pencil's
/// pattern (A(iω), K − σM, … without a copy of its values).
pub(super) struct Lower<'a, F> {
    pub pencil: &'a Pencil,
    pub entry: &'a F,
}

impl<F> Clone for Lower<'_, F> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<F> Copy for Lower<'_, F> {}

/// Columns per pass of [`symmetric_residual`].
pub(super) const RESIDUAL_BLOCK: usize = 16;

/// The buffers of [`symmetric_residual`], kept by the caller between calls: the residuals of
/// a sweep's refinements then allocate once per worker, not per frequency (fresh pages of
/// this size cost as much as the products here).
pub(super) struct ResidualScratch<T> {
    /// The N × k block, column-major: b in, r out (and the blocks' interleaved x between).
    xr: Vec<T>,
    blocks: Vec<BlockScratch<T>>,
    /// The componentwise backward error of each column of the last call (0 without
    /// `componentwise`).
    columns: Vec<f64>,
}

impl<T> Default for ResidualScratch<T> {
    fn default() -> Self {
        ResidualScratch {
            xr: Vec::new(),
            blocks: Vec::new(),
            columns: Vec::new(),
        }
    }
}

impl<T> ResidualScratch<T> {
    /// The componentwise backward error of each column of the last [`symmetric_residual`]
    /// (its return value is their maximum).
    pub(super) fn column_errors(&self) -> &[f64] {
        &self.columns
    }
}

impl<T: Scalar> ResidualScratch<T> {
    /// The N × k block that holds b before [`symmetric_residual`] and r after it (its values
    /// are kept while N and k stay the same).
    pub(super) fn block(&mut self, n: usize, k: usize) -> MatMut<'_, T> {
        if self.xr.len() != n * k {
            self.xr.clear();
            self.xr.resize(n * k, T::zero_impl());
        }
        MatMut::from_column_major_slice_mut(&mut self.xr, n, k)
    }
}

/// The interleaved r and s = |A||x| + |b| of one column block, entry (i, c) at i·w + c, and
/// the block's componentwise backward error per column.
struct BlockScratch<T> {
    rt: Vec<T>,
    st: Vec<f64>,
    columns: Vec<f64>,
}

impl<T> Default for BlockScratch<T> {
    fn default() -> Self {
        BlockScratch {
            rt: Vec::new(),
            st: Vec::new(),
            columns: Vec::new(),
        }
    }
}

/// [`symmetric_residual`] of one block of w ≤ [`RESIDUAL_BLOCK`] columns: `xr` holds the
/// block's columns of b on entry (column-major), the interleaved x during the pass and r on
/// exit. Each pattern entry updates w adjacent values of r (and of s, in the same pass: the
/// pass is memory-bound, and one pass instead of two cut the solve phase of a refined
/// frequency of the 10⁶-DoF bar, three residuals of ten columns, from 8.66 to 7.74 s; same
/// numbers). Returns the block's componentwise backward error and keeps each column's in
/// `ws` (0 without `componentwise`).
fn residual_block<T: Scalar, F: Fn(usize) -> T>(
    a: Lower<'_, F>,
    x: MatRef<'_, T>,
    xr: &mut [T],
    componentwise: bool,
    ws: &mut BlockScratch<T>,
) -> f64 {
    let (n, w) = (x.nrows(), x.ncols());
    let BlockScratch { rt, st, columns } = ws;
    columns.clear();
    columns.resize(w, 0.0);
    rt.resize(n * w, T::zero_impl());
    st.resize(if componentwise { n * w } else { 0 }, 0.0);
    let b = MatRef::from_column_major_slice(xr, n, w);
    interleave(b, rt, |v| v);
    if componentwise {
        interleave(b, st, T::abs1);
    }
    interleave(x, xr, |v| v);
    let worst = if componentwise {
        // one column, the sweep's backward error of every probe solve: with w a constant the
        // loops over the columns vanish (10⁵-DoF bar: 0.035 → 0.024 s per frequency)
        if w == 1 {
            residual_pass::<T, F, true>(a, 1, xr, rt, st);
        } else {
            residual_pass::<T, F, true>(a, w, xr, rt, st);
        }
        for (r, s) in rt.chunks_exact(w).zip(st.chunks_exact(w)) {
            for ((e, r), &s) in columns.iter_mut().zip(r).zip(s) {
                if s > 0.0 {
                    *e = e.max(r.abs1() / s);
                }
            }
        }
        columns.iter().fold(0.0f64, |m, &e| m.max(e))
    } else {
        residual_pass::<T, F, false>(a, w, xr, rt, st);
        0.0
    };
    deinterleave(rt, MatMut::from_column_major_slice_mut(xr, n, w));
    worst
}

/// The pass of [`residual_block`] over the pattern: r ← r − A x and, when `S`,
/// s ← s + |A||x| (r, s holding b and |b| on entry; |x| is taken from x as it is read).
#[inline(always)]
fn residual_pass<T: Scalar, F: Fn(usize) -> T, const S: bool>(
    a: Lower<'_, F>,
    w: usize,
    xt: &[T],
    rt: &mut [T],
    st: &mut [f64],
) {
    let (cp, ri, entry) = (a.pencil.col_ptr(), a.pencil.row_idx(), a.entry);
    let zero = T::zero_impl();
    let mut acc = [zero; RESIDUAL_BLOCK];
    let mut acc_s = [0.0f64; RESIDUAL_BLOCK];
    for j in 0..cp.len() - 1 {
        let xj = &xt[j * w..(j + 1) * w];
        acc[..w].fill(zero);
        if S {
            acc_s[..w].fill(0.0);
        }
        for p in cp[j]..cp[j + 1] {
            let (i, v) = (ri[p], entry(p));
            let r_i = &mut rt[i * w..(i + 1) * w];
            for c in 0..w {
                r_i[c] -= v * xj[c];
            }
            let xi = &xt[i * w..(i + 1) * w];
            if i != j {
                for c in 0..w {
                    acc[c] += v * xi[c];
                }
            }
            if S {
                let v = v.abs1();
                let s_i = &mut st[i * w..(i + 1) * w];
                for c in 0..w {
                    s_i[c] += v * xj[c].abs1();
                }
                if i != j {
                    for c in 0..w {
                        acc_s[c] += v * xi[c].abs1();
                    }
                }
            }
        }
        for c in 0..w {
            rt[j * w + c] -= acc[c];
        }
        if S {
            for c in 0..w {
                st[j * w + c] += acc_s[c];
            }
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
