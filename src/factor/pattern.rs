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
/// symmetric A whose lower triangle has the entries `entry(p)` on the pencil's pattern.
/// s is the denominator of the componentwise backward error; the normwise one needs r only,
/// and skipping s halves the work (this runs after every solve of the eigensolver's interior
/// shifts).
///
/// The columns go in blocks of up to [`RESIDUAL_BLOCK`], interleaved row by row, so one pass
/// over the pattern serves a whole block: the pass is memory-bound (measured on the 10⁶-DoF
/// bar, ten right-hand sides column by column: 1.3 s per residual, which made the sweep's
/// refinement cost twice the factorization). Blocks run in parallel under `par`. Every entry
/// of r and s is computed by the same operations in the same order as column by column.
pub(super) fn symmetric_residual<T: Scalar, F: Fn(usize) -> T + Sync>(
    a: Lower<'_, F>,
    b: MatRef<'_, T>,
    x: MatRef<'_, T>,
    mut r: MatMut<'_, T>,
    mut s: Option<MatMut<'_, f64>>,
    scratch: &mut ResidualScratch<T>,
    par: Par,
) {
    let k = x.ncols();
    if k == 0 {
        return;
    }
    let threads = par.degree().max(1);
    let width = k.div_ceil(threads).clamp(1, RESIDUAL_BLOCK);
    let blocks = k.div_ceil(width);
    if scratch.blocks.len() < blocks {
        scratch.blocks.resize_with(blocks, BlockScratch::default);
    }
    let with_s = s.is_some();
    let run = |(bi, ws): (usize, &mut BlockScratch<T>)| {
        let (c0, w) = (bi * width, width.min(k - bi * width));
        residual_block(a, b.subcols(c0, w), x.subcols(c0, w), with_s, ws);
    };
    let used = &mut scratch.blocks[..blocks];
    if threads > 1 && blocks > 1 {
        use rayon::prelude::*;
        used.par_iter_mut().enumerate().for_each(run);
    } else {
        used.iter_mut().enumerate().for_each(run);
    }
    for (bi, ws) in used.iter().enumerate() {
        let (c0, w) = (bi * width, width.min(k - bi * width));
        deinterleave(&ws.rt, r.as_mut().subcols_mut(c0, w));
        if let Some(s) = s.as_mut() {
            deinterleave(&ws.st, s.as_mut().subcols_mut(c0, w));
        }
    }
}

/// Rows per tile when columns are copied to and from the interleaved layout: the tile's
/// rows stay in cache while each column streams through it (column by column over all
/// rows, every column re-read the whole interleaved buffer: 4.6 s of the 10⁶-DoF bar's
/// 20-frequency sweep went to the copy back alone).
const TILE: usize = 512;

/// The entries of `m` mapped by `f` into `v`, row by row: entry (i, c) at i·w + c.
fn interleave<T: Copy, U: Copy>(m: MatRef<'_, T>, v: &mut Vec<U>, f: impl Fn(T) -> U) {
    let (n, w) = (m.nrows(), m.ncols());
    if n * w == 0 {
        return v.clear();
    }
    if v.len() != n * w {
        v.clear();
        v.resize(n * w, f(m[(0, 0)]));
    }
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

/// The row-interleaved buffers of [`symmetric_residual`], kept by the caller between calls:
/// the residuals of a sweep's refinements then allocate once per worker, not per frequency
/// (fresh pages of this size cost as much as the products here).
pub(super) struct ResidualScratch<T> {
    blocks: Vec<BlockScratch<T>>,
}

impl<T> Default for ResidualScratch<T> {
    fn default() -> Self {
        ResidualScratch { blocks: Vec::new() }
    }
}

/// x, r (and s, |x|) of one column block, entry (i, c) at i·w + c.
struct BlockScratch<T> {
    xt: Vec<T>,
    rt: Vec<T>,
    st: Vec<f64>,
    xa: Vec<f64>,
}

impl<T> Default for BlockScratch<T> {
    fn default() -> Self {
        BlockScratch {
            xt: Vec::new(),
            rt: Vec::new(),
            st: Vec::new(),
            xa: Vec::new(),
        }
    }
}

/// [`symmetric_residual`] of one block of w ≤ [`RESIDUAL_BLOCK`] columns into `ws`: each
/// pattern entry updates w adjacent values of r (and of s, in the same pass: the pass is
/// memory-bound, and one pass instead of two cut the solve phase of a refined frequency of
/// the 10⁶-DoF bar, three residuals of ten columns, from 8.66 to 7.74 s; same numbers).
fn residual_block<T: Scalar, F: Fn(usize) -> T>(
    a: Lower<'_, F>,
    b: MatRef<'_, T>,
    x: MatRef<'_, T>,
    with_s: bool,
    ws: &mut BlockScratch<T>,
) {
    let w = x.ncols();
    interleave(x, &mut ws.xt, |v| v);
    interleave(b, &mut ws.rt, |v| v);
    if with_s {
        interleave(b, &mut ws.st, T::abs1);
        interleave(x, &mut ws.xa, T::abs1);
        residual_pass::<T, F, true>(a, w, ws);
    } else {
        residual_pass::<T, F, false>(a, w, ws);
    }
}

/// The pass of [`residual_block`] over the pattern: r ← r − A x and, when `S`,
/// s ← s + |A||x| (r, s holding b and |b| on entry).
fn residual_pass<T: Scalar, F: Fn(usize) -> T, const S: bool>(
    a: Lower<'_, F>,
    w: usize,
    ws: &mut BlockScratch<T>,
) {
    let (cp, ri, entry) = (a.pencil.col_ptr(), a.pencil.row_idx(), a.entry);
    let BlockScratch { xt, rt, st, xa } = ws;
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
            if i != j {
                let xi = &xt[i * w..(i + 1) * w];
                for c in 0..w {
                    acc[c] += v * xi[c];
                }
            }
            if S {
                let v = v.abs1();
                let s_i = &mut st[i * w..(i + 1) * w];
                let xaj = &xa[j * w..(j + 1) * w];
                for c in 0..w {
                    s_i[c] += v * xaj[c];
                }
                if i != j {
                    let xai = &xa[i * w..(i + 1) * w];
                    for c in 0..w {
                        acc_s[c] += v * xai[c];
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
