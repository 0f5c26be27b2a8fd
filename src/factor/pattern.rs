//! Sparsity patterns the backends factor, all derived from the pencil's N×N lower pattern
//! (docs/design.md §3.1).
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
    + bytemuck::Pod
    + std::ops::Mul<Output = Self>
    + std::ops::AddAssign
    + std::ops::SubAssign
{
    /// Whether the type has an imaginary part: the reals per value of the split rows of
    /// [`symmetric_residual`] are 1 + `COMPLEX`.
    const COMPLEX: bool;
    /// |Re a| + |Im a| (LAPACK's CABS1: within √2 of |a|, without a square root).
    fn abs1(self) -> f64;
    /// (Re a, Im a).
    fn parts(self) -> (f64, f64);
    /// The value with these parts (the imaginary one ignored when real).
    fn from_parts(re: f64, im: f64) -> Self;
}

impl Scalar for f64 {
    const COMPLEX: bool = false;
    fn abs1(self) -> f64 {
        self.abs()
    }
    fn parts(self) -> (f64, f64) {
        (self, 0.0)
    }
    fn from_parts(re: f64, _: f64) -> Self {
        re
    }
}

impl Scalar for faer::c64 {
    const COMPLEX: bool = true;
    fn abs1(self) -> f64 {
        self.re.abs() + self.im.abs()
    }
    fn parts(self) -> (f64, f64) {
        (self.re, self.im)
    }
    fn from_parts(re: f64, im: f64) -> Self {
        faer::c64::new(re, im)
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
/// The columns go in blocks of up to [`RESIDUAL_BLOCK`], row by row ([`split`]), so one pass
/// over the pattern serves a whole block instead of one pass per column (docs/design.md §3.1).
/// Blocks run in parallel under `par`. Every entry of r is computed by the same operations in
/// the same order as column by column in complex arithmetic.
///
/// Memory: a block's columns of the N × k block hold b, then the split x, then r, so beside
/// it the residual needs only the split r and |A||x| + |b| of each block (N × k values and
/// N × k magnitudes in all); no copy of b and no column-major denominator (on the 10⁶-DoF
/// bar's sweep, ten columns: 0.40 GB, against 0.88 GB with a block each for b, r, s, x and
/// |x|; docs/design.md §3.1).
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
    let run = |(bi, (xr, ws)): (usize, (&mut [T], &mut BlockScratch))| {
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
    scratch.normwise.clear();
    for b in &scratch.blocks[..blocks] {
        scratch.columns.extend_from_slice(&b.columns);
        scratch.normwise.extend_from_slice(&b.normwise);
    }
    worst
}

/// Rows per tile when columns are copied to and from the split rows: the tile's rows stay
/// in cache while each column streams through it (column by column over all rows, every
/// column re-reads the whole row-major buffer, and the copy back alone takes 4.6 s of the
/// 10⁶-DoF bar's 20-frequency sweep; docs/design.md §3.1).
const TILE: usize = 512;

/// Calls `f(i, c)` for every entry of an n × w block, tile by tile of [`TILE`] rows and
/// column by column inside a tile (the order of the copies between column-major and
/// row-major layouts).
fn by_tiles(n: usize, w: usize, mut f: impl FnMut(usize, usize)) {
    for i0 in (0..n).step_by(TILE) {
        for c in 0..w {
            for i in i0..(i0 + TILE).min(n) {
                f(i, c);
            }
        }
    }
}

/// Reals per row of a w-column block in the split layout: w, or 2w when complex.
fn row_len<T: Scalar>(w: usize) -> usize {
    if T::COMPLEX {
        2 * w
    } else {
        w
    }
}

/// The entries of `m` (n × w) into split rows: row i at i·q ([`row_len`]) holds the w real
/// parts, then (when complex) the w imaginary parts, so the products below run over the
/// columns in real arithmetic, which the compiler vectorizes.
fn split<T: Scalar>(m: MatRef<'_, T>, v: &mut [f64]) {
    let (n, w) = (m.nrows(), m.ncols());
    let q = row_len::<T>(w);
    by_tiles(n, w, |i, c| {
        let (re, im) = m[(i, c)].parts();
        v[i * q + c] = re;
        if T::COMPLEX {
            v[i * q + w + c] = im;
        }
    });
}

/// The inverse of [`split`].
fn unsplit<T: Scalar>(v: &[f64], mut m: MatMut<'_, T>) {
    let (n, w) = (m.nrows(), m.ncols());
    let q = row_len::<T>(w);
    by_tiles(n, w, |i, c| {
        let im = if T::COMPLEX { v[i * q + w + c] } else { 0.0 };
        m[(i, c)] = T::from_parts(v[i * q + c], im);
    });
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
    /// The N × k block, column-major: b in, r out (and the blocks' split x between).
    xr: Vec<T>,
    blocks: Vec<BlockScratch>,
    /// The componentwise backward error of each column of the last call (0 without
    /// `componentwise`).
    columns: Vec<f64>,
    /// maxᵢ |r|ᵢ / maxᵢ (|A||x| + |b|)ᵢ of each column of the last call (0 without
    /// `componentwise`).
    normwise: Vec<f64>,
}

impl<T> Default for ResidualScratch<T> {
    fn default() -> Self {
        ResidualScratch {
            xr: Vec::new(),
            blocks: Vec::new(),
            columns: Vec::new(),
            normwise: Vec::new(),
        }
    }
}

impl<T> ResidualScratch<T> {
    /// The componentwise backward error of each column of the last [`symmetric_residual`]
    /// (its return value is their maximum).
    pub(super) fn column_errors(&self) -> &[f64] {
        &self.columns
    }

    /// maxᵢ |r|ᵢ / maxᵢ (|A||x| + |b|)ᵢ of each column of the last [`symmetric_residual`]: an
    /// upper bound of the normwise backward error ‖r‖∞ / (‖A‖∞‖x‖∞ + ‖b‖∞).
    pub(super) fn column_normwise(&self) -> &[f64] {
        &self.normwise
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

/// The split r and the row-major s = |A||x| + |b| of one column block (entry (i, c) of s
/// at i·w + c), and the block's componentwise backward error per column.
#[derive(Default)]
struct BlockScratch {
    rt: Vec<f64>,
    st: Vec<f64>,
    columns: Vec<f64>,
    normwise: Vec<f64>,
}

/// [`symmetric_residual`] of one block of w ≤ [`RESIDUAL_BLOCK`] columns: `xr` holds the
/// block's columns of b on entry (column-major), the split x during the pass and r on exit.
/// Each pattern entry updates the w adjacent values of r (and of s, in the same pass, so the
/// pattern and x are read once; the numbers are those of two passes). Returns the block's
/// componentwise backward error and keeps each column's in `ws` (0 without
/// `componentwise`).
fn residual_block<T: Scalar, F: Fn(usize) -> T>(
    a: Lower<'_, F>,
    x: MatRef<'_, T>,
    xr: &mut [T],
    componentwise: bool,
    ws: &mut BlockScratch,
) -> f64 {
    let (n, w) = (x.nrows(), x.ncols());
    let q = row_len::<T>(w);
    let BlockScratch {
        rt,
        st,
        columns,
        normwise,
    } = ws;
    columns.clear();
    columns.resize(w, 0.0);
    normwise.clear();
    normwise.resize(w, 0.0);
    rt.resize(n * q, 0.0);
    st.resize(if componentwise { n * w } else { 0 }, 0.0);
    let b = MatRef::from_column_major_slice(xr, n, w);
    split(b, rt);
    if componentwise {
        by_tiles(n, w, |i, c| st[i * w + c] = b[(i, c)].abs1());
    }
    let xt: &mut [f64] = bytemuck::cast_slice_mut(xr);
    split(x, xt);
    let worst = if componentwise {
        vectorized(Pass::<T, F, true>::new(a, w, xt, rt, st));
        // per column: the largest |r|ᵢ and (|A||x| + |b|)ᵢ (w ≤ RESIDUAL_BLOCK)
        let mut largest = [(0.0f64, 0.0f64); RESIDUAL_BLOCK];
        for (r, s) in rt.chunks_exact(q).zip(st.chunks_exact(w)) {
            for (c, (e, &s)) in columns.iter_mut().zip(s).enumerate() {
                let im = if T::COMPLEX { r[w + c] } else { 0.0 };
                let ri = T::from_parts(r[c], im).abs1();
                if s > 0.0 {
                    *e = e.max(ri / s);
                }
                largest[c] = (largest[c].0.max(ri), largest[c].1.max(s));
            }
        }
        for (nw, &(r, s)) in normwise.iter_mut().zip(&largest[..w]) {
            *nw = if s > 0.0 { r / s } else { 0.0 };
        }
        columns.iter().fold(0.0f64, |m, &e| m.max(e))
    } else {
        vectorized(Pass::<T, F, false>::new(a, w, xt, rt, st));
        0.0
    };
    unsplit(rt, MatMut::from_column_major_slice_mut(xr, n, w));
    worst
}

/// [`residual_pass`] with its arguments, for [`vectorized`] (a closure would not be inlined
/// into the AVX2 function, and the pass would run at baseline speed).
struct Pass<'a, 'b, T, F, const S: bool> {
    a: Lower<'a, F>,
    w: usize,
    xt: &'b [f64],
    rt: &'b mut [f64],
    st: &'b mut [f64],
    scalar: std::marker::PhantomData<T>,
}

impl<'a, 'b, T, F, const S: bool> Pass<'a, 'b, T, F, S> {
    fn new(a: Lower<'a, F>, w: usize, xt: &'b [f64], rt: &'b mut [f64], st: &'b mut [f64]) -> Self {
        let scalar = std::marker::PhantomData;
        Pass {
            a,
            w,
            xt,
            rt,
            st,
            scalar,
        }
    }
}

impl<T: Scalar, F: Fn(usize) -> T, const S: bool> pulp::NullaryFnOnce for Pass<'_, '_, T, F, S> {
    type Output = ();
    #[inline(always)]
    fn call(self) {
        let Pass {
            a, w, xt, rt, st, ..
        } = self;
        // one column, the sweep's backward error of every probe solve: with w a constant the
        // loops over the columns vanish (its cost per frequency: docs/design.md §3.1)
        if w == 1 {
            residual_pass::<T, F, S>(a, 1, xt, rt, st)
        } else {
            residual_pass::<T, F, S>(a, w, xt, rt, st)
        }
    }
}

/// Runs `pass` compiled for AVX2 when the processor has it (pulp's runtime dispatch, as
/// faer's kernels do; the default build targets baseline x86-64), else as it is: the pass
/// then runs four reals per instruction instead of two (the 10⁶-DoF bar's timings with and
/// without AVX2 are in docs/design.md §3.1). No FMA is formed without fast-math, so the
/// numbers are the same either way.
fn vectorized<P: pulp::NullaryFnOnce<Output = ()>>(pass: P) {
    #[cfg(target_arch = "x86_64")]
    if let Some(simd) = pulp::x86::V3::try_new() {
        return simd.vectorize(pass);
    }
    pass.call()
}

/// The pass of [`residual_block`] over the pattern, on split rows: r ← r − A x and, when
/// `S`, s ← s + |A||x| (r, s holding b and |b| on entry; |x| is taken from x as it is read).
/// Every value is formed by the operations of the complex product in the same order as
/// column by column in complex arithmetic, so the numbers are those of that product.
#[inline(always)]
fn residual_pass<T: Scalar, F: Fn(usize) -> T, const S: bool>(
    a: Lower<'_, F>,
    w: usize,
    xt: &[f64],
    rt: &mut [f64],
    st: &mut [f64],
) {
    let (cp, ri, entry) = (a.pencil.col_ptr(), a.pencil.row_idx(), a.entry);
    let q = row_len::<T>(w);
    let mut acc = [0.0f64; 2 * RESIDUAL_BLOCK];
    let mut acc_s = [0.0f64; RESIDUAL_BLOCK];
    for j in 0..cp.len() - 1 {
        let xj = &xt[j * q..(j + 1) * q];
        acc[..q].fill(0.0);
        if S {
            acc_s[..w].fill(0.0);
        }
        for p in cp[j]..cp[j + 1] {
            let (i, v) = (ri[p], entry(p));
            let (vr, vi) = v.parts();
            multiply_add::<T, true>(vr, vi, xj, &mut rt[i * q..(i + 1) * q]);
            let xi = &xt[i * q..(i + 1) * q];
            if i != j {
                multiply_add::<T, false>(vr, vi, xi, &mut acc[..q]);
            }
            if S {
                let v = v.abs1();
                magnitude_add::<T>(v, xj, &mut st[i * w..(i + 1) * w]);
                if i != j {
                    magnitude_add::<T>(v, xi, &mut acc_s[..w]);
                }
            }
        }
        for (r, a) in rt[j * q..(j + 1) * q].iter_mut().zip(&acc[..q]) {
            *r -= a;
        }
        if S {
            for (s, a) in st[j * w..(j + 1) * w].iter_mut().zip(&acc_s[..w]) {
                *s += a;
            }
        }
    }
}

/// y − v x (`SUB`) or y + v x into `y`, for the split rows x, y and v = vr + i·vi: the
/// complex product as (vr·xr − vi·xi) + i·(vr·xi + vi·xr), real when `T` is.
#[inline(always)]
fn multiply_add<T: Scalar, const SUB: bool>(vr: f64, vi: f64, x: &[f64], y: &mut [f64]) {
    let add = |y: &mut f64, p: f64| {
        if SUB {
            *y -= p
        } else {
            *y += p
        }
    };
    if T::COMPLEX {
        let w = x.len() / 2;
        let (xr, xi) = x.split_at(w);
        let (yr, yi) = y.split_at_mut(w);
        for (((yr, yi), &xr), &xi) in yr.iter_mut().zip(yi).zip(xr).zip(xi) {
            add(yr, vr * xr - vi * xi);
            add(yi, vr * xi + vi * xr);
        }
    } else {
        for (y, &x) in y.iter_mut().zip(x) {
            add(y, vr * x);
        }
    }
}

/// s + v·|x| into `s` for the split row x, |x| by [`Scalar::abs1`].
#[inline(always)]
fn magnitude_add<T: Scalar>(v: f64, x: &[f64], s: &mut [f64]) {
    if T::COMPLEX {
        let (xr, xi) = x.split_at(s.len());
        for ((s, xr), xi) in s.iter_mut().zip(xr).zip(xi) {
            *s += v * (xr.abs() + xi.abs());
        }
    } else {
        for (s, x) in s.iter_mut().zip(x) {
            *s += v * x.abs();
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
