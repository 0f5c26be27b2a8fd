//! Solved responses X (N × p) kept by the frequency engine for a later pass — line-fitting's
//! sampling loop refits from them after its interface grows (docs/design.md §3.5, steps 6–7).
//! A response from the shifted Krylov space (§3.10) is kept as its coefficients c in the
//! space's basis Q (X = Q c, k × p numbers); a factored one whole, in memory or spilled to a
//! temporary file and streamed back.
//!
//! Responses in the span of Q need no pass over N × 2pz numbers: their streamed QR is built
//! from c ([`crate::lsq::Split::state_in_span`]) and Q-DEIM's R of S is Lᵀ C, with
//! QᵀQ = L Lᵀ (kept as Q grows) and C = [Re c_1, Im c_1, …]: S = Q C has SᵀS = Cᵀ L Lᵀ C.
//!
//! Q-DEIM growth ([`SnapshotStore::qdeim_next`]) never forms the N × 2pz snapshot matrix
//! S = [Re X_1, Im X_1, …] (nor its N × r left singular vectors): it streams S in row blocks,
//! twice.
//! 1. R of a QR of S, merged block by block (TSQR: R ← R of [R; S_block]), and the rows of S
//!    at the interface. The SVD R = U_R Σ Vᵀ gives S = (Q U_R) Σ Vᵀ, so the left singular
//!    vectors are U = S V Σ⁻¹, row by row, on the numerical rank r (σ_k > 10⁻¹² σ_max).
//! 2. The rows u_j of U are scored against the interface: with Q an orthonormal basis of the
//!    span of the interface rows {u_i : i ∈ I}, score_j = ‖u_j‖² − ‖Qᵀu_j‖² is the squared
//!    part of u_j that the interface does not already capture; the DoF of largest score is
//!    the next interface DoF. This is the next pivot of a column-pivoted QR of Uᵀ whose
//!    first pivots are the current interface (Q-DEIM continued from the interface). For
//!    several DoFs at once the rows of the largest scores are kept (8 per DoF, at least 64)
//!    with their parts outside the span, and the pivoted QR goes on among them (pivoted
//!    Gram–Schmidt).
//!
//! Memory: O(block · 2pz + (2pz)² + kept rows · 2pz) besides the stored snapshots.

use crate::lsq::{Split, StreamedQr};
use crate::{Error, Result};
use faer::linalg::matmul::matmul;
use faer::{c64, Accum, Mat, MatRef, Par};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::PathBuf;

/// Rows of S per block in the Q-DEIM passes.
const BLOCK_ROWS: usize = 4096;

/// A Q-DEIM pick must add at least this fraction of the first pick's squared score outside
/// the span of the interface and the picks before it (a norm ratio of 10⁻⁴): rows below it
/// repeat directions T_o already has. Without it, a growth forced to a tenth of the order
/// took six DoFs of one cross-section of the 3 m bar, and T_o lost rank (80 of 86 at tol
/// 1e-3; 76 of 105 on the 10⁶-DoF bar).
const NEW_DIRECTION: f64 = 1e-8;

/// How many DoFs [`SnapshotStore::qdeim_next`] adds (docs/design.md §3.5, step 7): as many as
/// bring the interface to the numerical rank of the snapshots at `rank_tol` — each
/// frequency's columns scaled to unit norm, so that a relative error of `rank_tol` at any
/// sampled frequency needs the direction — within [`at_least`, `at_most`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GrowBy {
    pub at_least: usize,
    pub at_most: usize,
    pub rank_tol: f64,
}

impl GrowBy {
    /// Exactly `count` DoFs.
    #[cfg(test)]
    pub fn exactly(count: usize) -> Self {
        GrowBy {
            at_least: count,
            at_most: count,
            rank_tol: 1.0,
        }
    }

    /// The count for an interface of `order` DoFs and snapshots of numerical rank `rank`.
    fn count(&self, order: usize, rank: usize) -> usize {
        rank.saturating_sub(order)
            .clamp(self.at_least, self.at_most.max(self.at_least))
    }
}

/// Kept responses: those in the span of the Krylov basis as coefficients, the others whole.
pub(crate) struct SnapshotStore {
    full: Full,
    /// c_k of X_k = Q c_k (k_k × p; Q the basis of the engine's shifted Krylov space).
    span: Vec<Mat<c64>>,
    /// QᵀQ of the basis's leading columns, extended as the basis grows.
    gram: Mat<f64>,
}

/// Whole responses (N × p, complex) in memory or in an unnamed temporary file.
enum Full {
    Memory(Vec<Mat<c64>>),
    File {
        /// The directory that holds the file (the file has no name: for messages).
        path: PathBuf,
        file: std::fs::File,
        shapes: Vec<(usize, usize)>,
    },
}

/// How many snapshots of `bytes_each` bytes the file system of the spill file (the
/// temporary directory) has room for now, if its free space is known: in nine tenths of the
/// free space, so that the spill file does not leave the disk full for everything else.
pub(crate) fn spill_room(bytes_each: usize) -> Option<usize> {
    let free = crate::memory::free_disk_bytes(&std::env::temp_dir())?;
    Some(usize::try_from(free / 10 * 9 / bytes_each.max(1) as u64).unwrap_or(usize::MAX))
}

impl SnapshotStore {
    /// An empty store; `spill` puts the whole responses in a temporary file.
    pub fn new(spill: bool) -> Result<Self> {
        let full = if spill {
            // an unnamed file (O_TMPFILE, or unlinked as soon as it is open): the system
            // reclaims it when it is closed, however the process ends, even when it is killed
            let path = std::env::temp_dir();
            let file = tempfile::tempfile_in(&path).map_err(|e| Error::io(&path, e))?;
            Full::File {
                path,
                file,
                shapes: Vec::new(),
            }
        } else {
            Full::Memory(Vec::new())
        };
        Ok(SnapshotStore {
            full,
            span: Vec::new(),
            gram: Mat::zeros(0, 0),
        })
    }

    /// True when the whole responses live in a file.
    pub fn spilled(&self) -> bool {
        matches!(self.full, Full::File { .. })
    }

    /// Appends a response X = Q c by its coefficients c (k × p) in the Krylov basis Q.
    pub fn push_span(&mut self, c: Mat<c64>) {
        self.span.push(c);
    }

    /// Appends whole responses.
    pub fn extend(&mut self, snaps: impl Iterator<Item = Mat<c64>>) -> Result<()> {
        match &mut self.full {
            Full::Memory(v) => v.extend(snaps),
            Full::File { path, file, shapes } => {
                file.seek(SeekFrom::End(0))
                    .map_err(|e| Error::io(&*path, e))?;
                let mut w = std::io::BufWriter::new(&*file);
                for x in snaps {
                    for j in 0..x.ncols() {
                        for i in 0..x.nrows() {
                            let z = x[(i, j)];
                            w.write_all(&z.re.to_le_bytes())
                                .and_then(|_| w.write_all(&z.im.to_le_bytes()))
                                .map_err(|e| Error::io(&*path, e))?;
                        }
                    }
                    shapes.push((x.nrows(), x.ncols()));
                }
                w.flush().map_err(|e| Error::io(&*path, e))?;
            }
        }
        Ok(())
    }

    /// The streamed QR of every kept response for `split` (responses of p columns): the
    /// whole ones absorbed again, the ones in the span of `basis` built from their
    /// coefficients, and the two merged.
    ///
    /// # Errors
    /// [`Error::InvalidSetting`] when responses in a span are kept but no basis is given;
    /// as [`Split::absorb`], [`Split::state_in_span`]; I/O errors of a spill file.
    pub fn regrow(
        &mut self,
        split: &Split,
        p: usize,
        basis: Option<MatRef<'_, f64>>,
    ) -> Result<StreamedQr> {
        let mut w = split.state(p);
        self.for_each_full(|x| split.absorb(&mut w, x))?;
        if self.span.is_empty() {
            return Ok(w.qr);
        }
        let q = self.basis_for_span(basis)?;
        w.qr.merge(split.state_in_span(q, &self.span)?)
    }

    /// `basis` when it is there and covers every kept coefficient block.
    fn basis_for_span<'b>(&self, basis: Option<MatRef<'b, f64>>) -> Result<MatRef<'b, f64>> {
        let k = self.span.iter().map(|c| c.nrows()).max().unwrap_or(0);
        match basis {
            Some(q) if q.ncols() >= k => Ok(q),
            _ => Err(Error::InvalidSetting(format!(
                "responses kept by their coefficients in a Krylov basis of {k} vectors, but \
                 that basis is not there"
            ))),
        }
    }

    /// Calls `f` on every whole response in the order they were added.
    fn for_each_full(&mut self, mut f: impl FnMut(MatRef<'_, c64>) -> Result<()>) -> Result<()> {
        match &mut self.full {
            Full::Memory(v) => v.iter().try_for_each(|x| f(x.as_ref())),
            Full::File { path, file, shapes } => {
                file.seek(SeekFrom::Start(0))
                    .map_err(|e| Error::io(&*path, e))?;
                let mut r = std::io::BufReader::with_capacity(1 << 20, &*file);
                let mut bytes = Vec::new();
                for &(n, p) in shapes.iter() {
                    let mut x = Mat::<c64>::zeros(n, p);
                    for j in 0..p {
                        read_column(&mut r, &mut bytes, n, |i, z| x[(i, j)] = z)
                            .map_err(|e| Error::io(&*path, e))?;
                    }
                    f(x.as_ref())?;
                }
                Ok(())
            }
        }
    }

    /// The columns p of every kept response: those in the span first, then the whole ones
    /// (the order of the columns of S in the Q-DEIM passes).
    fn widths(&self) -> Vec<usize> {
        let full: Vec<usize> = match &self.full {
            Full::Memory(v) => v.iter().map(|x| x.ncols()).collect(),
            Full::File { shapes, .. } => shapes.iter().map(|s| s.1).collect(),
        };
        self.span.iter().map(|c| c.ncols()).chain(full).collect()
    }

    /// Rows N of the whole responses, when there are any.
    fn full_rows(&self) -> Option<usize> {
        match &self.full {
            Full::Memory(v) => v.first().map(|x| x.nrows()),
            Full::File { shapes, .. } => shapes.first().map(|s| s.0),
        }
    }

    /// The column scaling D that gives each snapshot's columns [Re X_k, Im X_k] unit
    /// Frobenius norm (every frequency weighs the same, as the relative error does), from
    /// a matrix R with RᵀR = SᵀS (the column norms of S are those of R).
    fn frequency_scaling(&self, r: &Mat<f64>) -> Vec<f64> {
        let mut d = vec![1.0; r.ncols()];
        let mut c = 0;
        for p in self.widths() {
            let cols = c..c + 2 * p;
            let norm = cols
                .clone()
                .map(|j| r.col(j).squared_norm_l2())
                .sum::<f64>()
                .sqrt();
            if norm > 0.0 {
                cols.for_each(|j| d[j] = 1.0 / norm);
            }
            c += 2 * p;
        }
        d
    }

    /// QᵀQ of `q` (k × k), from the kept one extended by the basis's new columns.
    fn gram(&mut self, q: MatRef<'_, f64>) -> MatRef<'_, f64> {
        let (k0, k) = (self.gram.nrows(), q.ncols());
        if k > k0 {
            let mut new = Mat::<f64>::zeros(k, k - k0);
            let added = q.subcols(k0, k - k0);
            matmul(
                new.as_mut(),
                Accum::Replace,
                q.transpose(),
                added,
                1.0,
                Par::rayon(0),
            );
            self.gram.resize_with(k, k, |i, j| {
                if j >= k0 {
                    new[(i, j - k0)]
                } else {
                    new[(j, i - k0)]
                }
            });
        }
        self.gram.as_ref()
    }

    /// Calls `f(start, block)` for consecutive row blocks of the whole responses'
    /// columns of S, [Re X_1, Im X_1, …] (block: rows × their 2p's; no columns when every
    /// response is in the span), over `n` rows.
    fn for_each_row_block(
        &mut self,
        n: usize,
        mut f: impl FnMut(usize, MatRef<'_, f64>) -> Result<()>,
    ) -> Result<()> {
        let span_cols: usize = self.span.iter().map(|c| 2 * c.ncols()).sum();
        let cols = 2 * self.widths().iter().sum::<usize>() - span_cols;
        let mut start = 0;
        while start < n {
            let rows = BLOCK_ROWS.min(n - start);
            let mut block = Mat::<f64>::zeros(rows, cols);
            match &mut self.full {
                Full::Memory(v) => {
                    let mut c = 0;
                    for x in v.iter() {
                        for j in 0..x.ncols() {
                            for i in 0..rows {
                                let z = x[(start + i, j)];
                                block[(i, c)] = z.re;
                                block[(i, c + 1)] = z.im;
                            }
                            c += 2;
                        }
                    }
                }
                Full::File { path, file, shapes } => {
                    let (mut offset, mut c) = (0u64, 0);
                    let mut bytes = Vec::new();
                    for &(nr, p) in shapes.iter() {
                        for _ in 0..p {
                            file.seek(SeekFrom::Start(offset + 16 * start as u64))
                                .map_err(|e| Error::io(&*path, e))?;
                            read_column(&mut *file, &mut bytes, rows, |i, z| {
                                block[(i, c)] = z.re;
                                block[(i, c + 1)] = z.im;
                            })
                            .map_err(|e| Error::io(&*path, e))?;
                            offset += 16 * nr as u64;
                            c += 2;
                        }
                    }
                }
            }
            f(start, block.as_ref())?;
            start += rows;
        }
        Ok(())
    }

    /// A matrix R with RᵀR = SᵀS, and the rows of S at `interface`: from the span when
    /// [`Self::triangle_in_span`] can, otherwise the R of a QR of S merged over row blocks
    /// (TSQR: R ← R of [R; S_block]), the span's columns formed block by block as Q_b C.
    fn triangle(
        &mut self,
        n: usize,
        interface: &[usize],
        span: Option<(MatRef<'_, f64>, &Mat<f64>)>,
    ) -> Result<(Mat<f64>, Mat<f64>)> {
        let cols = 2 * self.widths().iter().sum::<usize>();
        if let Some((q, c)) = span.filter(|(q, c)| cols - c.ncols() <= q.ncols()) {
            if let Some(found) = self.triangle_in_span(n, interface, q, c)? {
                return Ok(found);
            }
        }
        let mut r = Mat::<f64>::zeros(0, cols);
        let mut pos = vec![usize::MAX; n];
        for (k, &d) in interface.iter().enumerate() {
            pos[d] = k;
        }
        let mut s_i = Mat::<f64>::zeros(interface.len(), cols);
        self.for_each_row_block(n, |start, full| {
            let block = match span {
                Some((q, c)) => {
                    let sb = q.subrows(start, full.nrows()) * c;
                    Mat::from_fn(full.nrows(), cols, |i, j| {
                        if j < sb.ncols() {
                            sb[(i, j)]
                        } else {
                            full[(i, j - sb.ncols())]
                        }
                    })
                }
                None => full.to_owned(),
            };
            for i in 0..block.nrows() {
                if let Some(&k) = pos.get(start + i).filter(|&&k| k != usize::MAX) {
                    for c in 0..cols {
                        s_i[(k, c)] = block[(i, c)];
                    }
                }
            }
            let stacked = Mat::<f64>::from_fn(r.nrows() + block.nrows(), cols, |i, j| {
                if i < r.nrows() {
                    r[(i, j)]
                } else {
                    block[(i - r.nrows(), j)]
                }
            });
            r = stacked.qr().thin_R().to_owned();
            Ok(())
        })?;
        Ok((r, s_i))
    }

    /// [`Self::triangle`] for S = [Q C, F], F the whole responses' columns (at most k of
    /// them): with QᵀQ = LLᵀ, Q = Q_o Lᵀ (Q_o orthonormal), and F = Q a + F⊥ (two classical
    /// Gram–Schmidt passes, a = (QᵀQ)⁻¹QᵀF),
    ///
    /// ```text
    /// S = [Q_o  F⊥/R_F] [ LᵀC  Lᵀa ]      R = [ LᵀC  Lᵀa ]
    ///                   [  0   R_F ],          [  0   R_F ]
    /// ```
    ///
    /// with R_F the triangle of F⊥: O(N·k·|F|) besides the Gram matrix's new columns.
    /// `None` when QᵀQ has no Cholesky factor (the generic path decides then).
    fn triangle_in_span(
        &mut self,
        n: usize,
        interface: &[usize],
        q: MatRef<'_, f64>,
        c: &Mat<f64>,
    ) -> Result<Option<(Mat<f64>, Mat<f64>)>> {
        use faer::linalg::solvers::Solve;
        let Ok(llt) = self.gram(q).llt(faer::Side::Lower) else {
            return Ok(None);
        };
        let (k, cs) = (q.ncols(), c.ncols());
        let cf = 2 * self.widths().iter().sum::<usize>() - cs;
        let mut f = Mat::<f64>::zeros(n, cf);
        if cf > 0 {
            self.for_each_row_block(n, |start, block| {
                f.as_mut()
                    .subrows_mut(start, block.nrows())
                    .copy_from(block);
                Ok(())
            })?;
        }
        let s_i = Mat::<f64>::from_fn(interface.len(), cs + cf, |i, j| {
            let d = interface[i];
            if j < cs {
                (0..k).map(|l| q[(d, l)] * c[(l, j)]).sum()
            } else {
                f[(d, j - cs)]
            }
        });
        let mut a = Mat::<f64>::zeros(k, cf);
        for _ in 0..2 {
            let mut w = Mat::<f64>::zeros(k, cf);
            matmul(
                w.as_mut(),
                Accum::Replace,
                q.transpose(),
                f.as_ref(),
                1.0,
                Par::rayon(0),
            );
            let x = llt.solve(w.as_ref());
            matmul(f.as_mut(), Accum::Add, q, x.as_ref(), -1.0, Par::rayon(0));
            a += &x;
        }
        let rf = if cf > 0 {
            f.qr().thin_R().to_owned()
        } else {
            Mat::zeros(0, 0)
        };
        let lt = llt.L().transpose().to_owned();
        let (top_c, top_a) = (&lt * c, &lt * &a);
        let r = Mat::<f64>::from_fn(k + rf.nrows(), cs + cf, |i, j| match (i < k, j < cs) {
            (true, true) => top_c[(i, j)],
            (true, false) => top_a[(i, j - cs)],
            (false, true) => 0.0,
            (false, false) => rf[(i - k, j - cs)],
        });
        Ok(Some((r, s_i)))
    }

    /// Q-DEIM continued from `interface` for as many pivots as `by` asks: the DoF outside it
    /// whose row of the snapshots' left singular vectors adds the most to the span of the
    /// interface rows (module doc), then the DoF that adds the most to the span with that one, and so
    /// on. The later pivots are chosen among the rows of the largest first scores (8 per
    /// pivot, at least 64): each pivot's row is taken out of the others (pivoted Gram–Schmidt),
    /// so rows that repeat a chosen one's direction — its neighbours on the body — drop back.
    /// The singular vectors are those of S D (each frequency weighing the same, as in the
    /// count), the leading interface + count of them. When the pool's rows add no direction
    /// before `count` picks (a slender body's few cross-sections), another pass measures every
    /// row against the interface and the picks so far. Picking stops early when no row adds
    /// [`NEW_DIRECTION`] of the first pick's score, so fewer DoFs than `by.at_least` may come
    /// back (never none). `basis` is the Krylov basis of the responses kept in its span.
    ///
    /// # Errors
    /// [`Error::Factor`] when the SVD does not converge; [`Error::InvalidSetting`] when no
    /// DoF is left outside the interface, the snapshots are empty or the basis is missing;
    /// I/O errors of a spill file.
    pub fn qdeim_next(
        &mut self,
        interface: &[usize],
        by: GrowBy,
        basis: Option<MatRef<'_, f64>>,
    ) -> Result<Vec<usize>> {
        let q = if self.span.is_empty() {
            None
        } else {
            Some(self.basis_for_span(basis)?)
        };
        let n = self.full_rows().or(q.map(|q| q.nrows())).unwrap_or(0);
        let cols = 2 * self.widths().iter().sum::<usize>();
        if cols == 0 || interface.len() + by.at_least > n {
            return Err(Error::InvalidSetting(
                "Q-DEIM found no DoF outside the interface".into(),
            ));
        }
        // the span's columns of S are Q C
        let c = q.map(|q| crate::lsq::stacked_coefficients(&self.span, q.ncols()));
        let span = q.zip(c.as_ref());
        // pass 1: R of S and the interface rows of S
        let (r, s_i) = self.triangle(n, interface, span)?;
        let mut pos = vec![usize::MAX; n];
        for (k, &d) in interface.iter().enumerate() {
            pos[d] = k;
        }
        // S D = U Σ Vᵀ, each frequency weighing the same; the numerical rank at rank_tol sets
        // the count, and the leading interface + count directions of U are the ones the
        // interface must see (textbook Q-DEIM: as many directions as DoFs; the trailing ones
        // down to rounding would draw picks that T_o cannot tell apart)
        let d = self.frequency_scaling(&r);
        let rd = Mat::<f64>::from_fn(r.nrows(), cols, |i, j| r[(i, j)] * d[j]);
        let svd = rd
            .thin_svd()
            .map_err(|_| Error::Factor("SVD of the snapshots did not converge".into()))?;
        let sv = svd.S();
        let smax = (0..sv.dim()).map(|k| sv[k]).fold(0.0, f64::max);
        let rank = (0..sv.dim())
            .filter(|&k| sv[k] > by.rank_tol * smax)
            .count();
        let count = by.count(interface.len(), rank).min(n - interface.len());
        let keep: Vec<usize> = (0..sv.dim())
            .filter(|&k| sv[k] > 1e-12 * smax)
            .take(interface.len() + count)
            .collect();
        if keep.is_empty() {
            return Err(Error::InvalidSetting(
                "Q-DEIM: the snapshots are all zero".into(),
            ));
        }
        // U = S T with T = D V_r Σ_r⁻¹ (cols × r)
        let t = Mat::<f64>::from_fn(cols, keep.len(), |i, k| {
            d[i] * svd.V()[(i, keep[k])] / sv[keep[k]]
        });
        // orthonormal basis of the interface rows' span (r × q), by a QR of U_Iᵀ
        let u_i_t = (&s_i * &t).transpose().to_owned();
        let qr = u_i_t.qr();
        let (rr, qi) = (qr.thin_R(), qr.compute_thin_Q());
        let rmax = (0..rr.nrows().min(rr.ncols()))
            .map(|k| rr[(k, k)].abs())
            .fold(0.0, f64::max);
        let basis: Vec<usize> = (0..rr.nrows().min(rr.ncols()))
            .filter(|&k| rr[(k, k)].abs() > 1e-12 * rmax)
            .collect();
        let mut qi = Mat::<f64>::from_fn(keep.len(), basis.len(), |i, k| qi[(i, basis[k])]);
        // pass 2: the part of each row of U outside span(Q); the rows of largest part kept.
        // The span's rows of U are Q_b (C T_span): O(k r) per row instead of O(2pz r)
        let span_cols = c.as_ref().map_or(0, |c| c.ncols());
        let ct = c.as_ref().map(|c| c * t.subrows(0, span_cols));
        let t_full = t.subrows(span_cols, cols - span_cols);
        let pool = (8 * count).max(64);
        let mut chosen = Vec::with_capacity(count);
        let mut first = None;
        // rounds of pass 2: the pool holds the rows of largest part, and on a slender body
        // they are a few cross-sections whose directions the first picks exhaust; the next
        // round measures every row against the picks' directions too
        while chosen.len() < count {
            let mut top: Vec<(f64, usize, Vec<f64>)> = Vec::with_capacity(pool + 1);
            self.for_each_row_block(n, |start, block| {
                let mut u = block * t_full;
                if let (Some(q), Some(ct)) = (q, ct.as_ref()) {
                    u += q.subrows(start, block.nrows()) * ct;
                }
                let outside = &u - &u * &qi * qi.transpose();
                for i in 0..u.nrows() {
                    if pos[start + i] != usize::MAX {
                        continue;
                    }
                    let row: Vec<f64> = (0..outside.ncols()).map(|k| outside[(i, k)]).collect();
                    let score = row.iter().map(|x| x * x).sum::<f64>();
                    if top.len() < pool || score > top[top.len() - 1].0 {
                        let at = top.partition_point(|e| e.0 >= score);
                        top.insert(at, (score, start + i, row));
                        top.truncate(pool);
                    }
                }
                Ok(())
            })?;
            let first = *first.get_or_insert(top.first().map_or(0.0, |t| t.0));
            // pivoted Gram–Schmidt on the kept rows; each pivot, normalized, extends Q
            let mut directions = Vec::new();
            while chosen.len() < count {
                let Some(best) = (0..top.len())
                    .filter(|&i| top[i].0 > NEW_DIRECTION * first)
                    .max_by(|&a, &b| top[a].0.total_cmp(&top[b].0))
                else {
                    break;
                };
                let (_, dof, pivot) = top.swap_remove(best);
                pos[dof] = interface.len() + chosen.len();
                chosen.push(dof);
                let norm = pivot.iter().map(|x| x * x).sum::<f64>().sqrt();
                for (score, _, row) in &mut top {
                    let c = row.iter().zip(&pivot).map(|(a, b)| a * b).sum::<f64>() / norm;
                    for (x, p) in row.iter_mut().zip(&pivot) {
                        *x -= c * p / norm;
                    }
                    *score = row.iter().map(|x| x * x).sum();
                }
                directions.push(pivot.into_iter().map(|x| x / norm).collect::<Vec<f64>>());
            }
            if directions.is_empty() {
                break;
            }
            let b = qi.ncols();
            qi = Mat::from_fn(qi.nrows(), b + directions.len(), |i, k| {
                if k < b {
                    qi[(i, k)]
                } else {
                    directions[k - b][i]
                }
            });
        }
        if chosen.is_empty() {
            return Err(Error::InvalidSetting(
                "Q-DEIM found no DoF outside the interface".into(),
            ));
        }
        Ok(chosen)
    }
}

/// Reads `n` little-endian complex numbers (re, im) with one read into `bytes`, and hands
/// each to `put(i, z)`.
fn read_column(
    r: &mut impl Read,
    bytes: &mut Vec<u8>,
    n: usize,
    mut put: impl FnMut(usize, c64),
) -> std::io::Result<()> {
    bytes.resize(16 * n, 0);
    r.read_exact(bytes)?;
    for (i, z) in bytes.chunks_exact(16).enumerate() {
        let (re, im) = z.split_at(8);
        let le = |b: &[u8]| f64::from_le_bytes(b.try_into().unwrap_or([0; 8]));
        put(i, c64::new(le(re), le(im)));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The growth count is the rank of the snapshots with every frequency weighing the same:
    /// a response 10¹² times smaller than another still asks for its two directions (Re, Im),
    /// which the unscaled singular values would put below 1e-3; and it is clamped.
    #[test]
    fn growth_count_is_the_rank_of_the_scaled_snapshots() {
        let n = 500;
        let mut rng = crate::random::Xorshift::new(3);
        let mut rnd = || rng.next_centred();
        let big = Mat::from_fn(n, 1, |_, _| c64::new(1e6 * rnd(), 1e6 * rnd()));
        let small = Mat::from_fn(n, 1, |_, _| c64::new(1e-6 * rnd(), 1e-6 * rnd()));
        let mut store = SnapshotStore::new(false).unwrap();
        store.extend([big, small].into_iter()).unwrap();
        let by = |at_least, at_most| GrowBy {
            at_least,
            at_most,
            rank_tol: 1e-3,
        };
        assert_eq!(store.qdeim_next(&[], by(1, 10), None).unwrap().len(), 4);
        assert_eq!(store.qdeim_next(&[7], by(1, 10), None).unwrap().len(), 3);
        assert_eq!(store.qdeim_next(&[], by(1, 2), None).unwrap().len(), 2);
        assert_eq!(
            store
                .qdeim_next(&[7, 8, 9, 10], by(1, 10), None)
                .unwrap()
                .len(),
            1
        );
    }

    /// A growth asked for more DoFs than the snapshots have directions returns only the
    /// DoFs that add one: one snapshot column (Re and Im, rank 2) gives 2 of 5 asked, and
    /// with one of its DoFs already in the interface, 1.
    #[test]
    fn qdeim_picks_stop_when_no_row_adds_a_direction() {
        let n = 300;
        let mut rng = crate::random::Xorshift::new(11);
        let x = Mat::from_fn(n, 1, |_, _| {
            c64::new(rng.next_centred(), rng.next_centred())
        });
        let mut store = SnapshotStore::new(false).unwrap();
        store.extend([x].into_iter()).unwrap();
        assert_eq!(
            store
                .qdeim_next(&[], GrowBy::exactly(5), None)
                .unwrap()
                .len(),
            2
        );
        assert_eq!(
            store
                .qdeim_next(&[17], GrowBy::exactly(5), None)
                .unwrap()
                .len(),
            1
        );
    }

    /// The pool of a round holds the rows of largest score; when they all repeat a few
    /// directions (the cross-sections of a slender body), the first picks exhaust them and
    /// the next round measures every other row against the picks: 5 DoFs come back of 5
    /// asked, two from the 100 dominant rows (rank 2) and three from the rest, where one
    /// round returned the two alone.
    #[test]
    fn qdeim_picks_go_past_a_pool_of_repeated_directions() {
        let n = 2000;
        let mut rng = crate::random::Xorshift::new(13);
        let mut rnd = || rng.next_centred();
        let (a, b) = ([rnd(), rnd(), rnd()], [rnd(), rnd(), rnd()]);
        let rows: Vec<[f64; 6]> = (0..n)
            .map(|i| {
                if i < 100 {
                    let (s, t) = (100.0 * rnd(), 100.0 * rnd());
                    let mut r = [0.0; 6];
                    for k in 0..3 {
                        r[k] = s * a[k] + t * b[k];
                    }
                    r
                } else {
                    [rnd(), rnd(), rnd(), rnd(), rnd(), rnd()]
                }
            })
            .collect();
        let x = Mat::from_fn(n, 3, |i, j| c64::new(rows[i][2 * j], rows[i][2 * j + 1]));
        let mut store = SnapshotStore::new(false).unwrap();
        store.extend([x].into_iter()).unwrap();
        let picks = store.qdeim_next(&[], GrowBy::exactly(5), None).unwrap();
        assert_eq!(picks.len(), 5, "{picks:?}");
        assert_eq!(picks.iter().filter(|&&d| d < 100).count(), 2, "{picks:?}");
    }

    /// Responses kept by their coefficients in a basis Q (X_i = Q c_i, c_i with k_i ≤ k
    /// rows, as a growing Krylov basis leaves them) refit and grow as the same responses kept
    /// whole: W and the per-DoF fit residuals agree to rounding, the rows absorbed and the
    /// Q-DEIM picks exactly; also with one response whole and outside the span (a factored
    /// frequency, spilled).
    #[test]
    fn responses_in_a_span_refit_and_grow_as_whole_ones() {
        let (n, k, p, z) = (3000, 40, 3, 6);
        let mut rng = crate::random::Xorshift::new(5);
        let mut rnd = || rng.next_centred();
        let q = Mat::<f64>::from_fn(n, k, |_, _| rnd());
        let coefs: Vec<Mat<c64>> = (0..z)
            .map(|i| Mat::from_fn(20 + 4 * i, p, |_, _| c64::new(rnd(), rnd())))
            .collect();
        let xs: Vec<Mat<c64>> = coefs
            .iter()
            .map(|c| {
                let qk = q.as_ref().subcols(0, c.nrows());
                Mat::from_fn(n, p, |i, j| {
                    (0..c.nrows()).map(|l| c[(l, j)] * qk[(i, l)]).sum::<c64>()
                })
            })
            .collect();
        // a factored response: near the span, not in it
        let factored = Mat::from_fn(n, p, |i, j| {
            xs[2][(i, j)] + c64::new(1e-3 * rnd(), 1e-3 * rnd())
        });
        let interface = vec![5, 700, 1500, 2999, 42, 1234, 2222];
        let split = Split::from_interface(n, interface.clone());
        let opts = crate::lsq::LsqOptions::default();
        for mixed in [false, true] {
            let mut ys = xs.clone();
            if mixed {
                ys[2] = factored.clone();
            }
            let mut whole = SnapshotStore::new(false).unwrap();
            whole.extend(ys.iter().cloned()).unwrap();
            let want = whole
                .regrow(&split, p, None)
                .unwrap()
                .finish(&opts)
                .unwrap();
            let picks = whole
                .qdeim_next(&interface, GrowBy::exactly(3), None)
                .unwrap();
            let mut store = SnapshotStore::new(mixed).unwrap();
            for (i, c) in coefs.iter().enumerate() {
                if mixed && i == 2 {
                    store.extend([factored.clone()].into_iter()).unwrap();
                } else {
                    store.push_span(c.clone());
                }
            }
            let got = store
                .regrow(&split, p, Some(q.as_ref()))
                .unwrap()
                .finish(&opts)
                .unwrap();
            let scale = want.w.norm_max();
            assert!(
                (&got.w - &want.w).norm_max() <= 1e-11 * scale,
                "mixed {mixed}"
            );
            for (a, b) in got.residual.iter().zip(&want.residual) {
                assert!((a - b).abs() <= 1e-10, "mixed {mixed}: residual {a} vs {b}");
            }
            assert_eq!(got.rows, want.rows);
            assert_eq!(
                store
                    .qdeim_next(&interface, GrowBy::exactly(3), Some(q.as_ref()))
                    .unwrap(),
                picks,
                "mixed {mixed}"
            );
        }
        // without the basis the coefficients mean nothing: an error, not a guess
        let mut store = SnapshotStore::new(false).unwrap();
        store.push_span(coefs[0].clone());
        assert!(store.regrow(&split, p, None).is_err());
    }

    /// The streamed, interface-continued Q-DEIM picks the DoFs a dense computation picks:
    /// U from a dense SVD of S D (each snapshot's columns scaled to unit norm), its leading
    /// interface + 3 columns, the residual of each row against the span of the interface
    /// rows, the best row added to the interface, three times.
    #[test]
    fn streamed_qdeim_matches_a_dense_reference() {
        let (n, z) = (9000, 3);
        let mut rng = crate::random::Xorshift::new(7);
        let mut rnd = || rng.next_centred();
        let snaps: Vec<Mat<c64>> = (0..z)
            .map(|_| Mat::from_fn(n, 2, |_, _| c64::new(rnd(), rnd())))
            .collect();
        let interface = vec![5, 4000, 8999];
        // dense reference
        let s = Mat::<f64>::from_fn(n, 4 * z, |i, c| {
            let x = snaps[c / 4][(i, (c % 4) / 2)];
            if c % 2 == 0 {
                x.re
            } else {
                x.im
            }
        });
        let mut s = s;
        for k in 0..z {
            let norm = s.as_ref().subcols(4 * k, 4).norm_l2();
            for c in 4 * k..4 * k + 4 {
                s.col_mut(c).iter_mut().for_each(|x| *x /= norm);
            }
        }
        let full = s.thin_svd().unwrap().U().to_owned();
        let u = full.as_ref().subcols(0, interface.len() + 3).to_owned();
        let mut grown = interface.clone();
        let mut want = Vec::new();
        for _ in 0..3 {
            let ui_t = Mat::<f64>::from_fn(u.ncols(), grown.len(), |k, c| u[(grown[c], k)]);
            let q = ui_t.qr().compute_thin_Q();
            let proj = &u * &q;
            let score = |i: usize| {
                (0..u.ncols()).map(|k| u[(i, k)].powi(2)).sum::<f64>()
                    - (0..q.ncols()).map(|k| proj[(i, k)].powi(2)).sum::<f64>()
            };
            let next = (0..n)
                .filter(|i| !grown.contains(i))
                .max_by(|&a, &b| score(a).total_cmp(&score(b)))
                .unwrap();
            grown.push(next);
            want.push(next);
        }
        for spill in [false, true] {
            let mut store = SnapshotStore::new(spill).unwrap();
            store.extend(snaps.iter().cloned()).unwrap();
            assert_eq!(
                store
                    .qdeim_next(&interface, GrowBy::exactly(3), None)
                    .unwrap(),
                want,
                "spill {spill}"
            );
        }
    }
}
