//! The streamed QR / TSQR state [`StreamedQr`] of line-fitting's least squares and its solve
//! (docs/design.md §3.3; the problem, the state and its invariant are in the module doc of
//! [`crate::lsq`]).

use crate::error::{Error, Result};
use faer::linalg::matmul::matmul;
use faer::prelude::{Reborrow, ReborrowMut};
use faer::{Accum, Mat, MatMut, MatRef, Par};
use rayon::prelude::*;

/// Number of reflectors applied together as one compact-WY block `I − V T Vᵀ`.
const PANEL: usize = 32;

/// Default columns per parallel task. For n = 14, q = 18 the absorb time is flat (within
/// ±5 %) from 1024 to 16384 columns; 4096 keeps the per-worker buffers ≈ 1.5 MB there.
const DEFAULT_CHUNK_COLS: usize = 4096;

/// Options of [`StreamedQr::finish`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LsqOptions {
    /// Relative singular-value threshold of the rank decision (docs/design.md §3.3 "below a
    /// relative threshold truncate").
    ///
    /// Singular values σ_i of the equilibrated triangle `R·S` with
    /// `σ_i ≤ τ · σ_max` are dropped, where
    ///
    /// ```text
    ///     τ = max(rcond_tol, max(rows, n) · f64::EPSILON)
    /// ```
    ///
    /// The second term is the rounding floor (the rule of LAPACK's `xGELSS` callers, NumPy's
    /// `lstsq` and MATLAB's `rank`): the backward error of the Householder QR of the
    /// equilibrated `T_oᵀ` is of that size, so singular values below it carry no information
    /// and a solve through them only amplifies rounding. The default `rcond_tol = 0.0` uses
    /// exactly that floor; raise it (e.g. to the relative accuracy of the snapshots, 1e-10 for
    /// a factorization with that residual) to regularize a nearly dependent interface set.
    /// The threshold actually applied is reported in [`LsqSolution::rcond_used`]. Must lie
    /// in [0, 1).
    pub rcond_tol: f64,
}

impl Default for LsqOptions {
    fn default() -> Self {
        LsqOptions { rcond_tol: 0.0 }
    }
}

impl LsqOptions {
    /// The rounding floor `max(rows, n) · ε` of the rank threshold (see [`LsqOptions::rcond_tol`]).
    pub fn rounding_floor(rows: usize, n: usize) -> f64 {
        rows.max(n) as f64 * f64::EPSILON
    }

    /// The threshold `τ` actually used for `rows` absorbed rows and `n` unknowns.
    pub fn effective_tol(&self, rows: usize, n: usize) -> f64 {
        self.rcond_tol.max(Self::rounding_floor(rows, n))
    }
}

/// Result of [`StreamedQr::finish`] (docs/design.md §3.3).
#[derive(Clone, Debug)]
pub struct LsqSolution {
    /// The line-fitting matrix `W` (m × n): `Wᵀ = S·(R S)⁺·Y`, the (truncated) least-squares
    /// solution of `T_oᵀ Wᵀ ≈ T_nᵀ`. With full rank it is *the* least-squares solution. When
    /// truncated it is the solution of minimum `‖S⁻¹ Wᵀ‖` (minimum norm in the equilibrated
    /// variables); this is the ordinary minimum-norm solution whenever the dependent interface
    /// columns have equal norms (e.g. duplicated columns).
    pub w: Mat<f64>,
    /// Singular values of the equilibrated triangle `R·S` (= those of `T_oᵀ S`), nonincreasing.
    pub singular_values: Vec<f64>,
    /// Column norms of `T_oᵀ` (= of `R`); `S = diag(1 / col_norms)` (zero columns get 1).
    pub col_norms: Vec<f64>,
    /// cond₂(T_oᵀ) = σ_max(R)/σ_min(R) before equilibration (∞ if singular).
    pub cond_raw: f64,
    /// cond₂(T_oᵀ S) after column equilibration (∞ if singular) — the number that governs the
    /// accuracy of `W`.
    pub cond_equilibrated: f64,
    /// Numerical rank: number of kept singular values.
    pub rank: usize,
    /// `true` if singular values were dropped (`rank < n`).
    pub truncated: bool,
    /// The relative threshold τ applied (see [`LsqOptions::rcond_tol`]).
    pub rcond_used: f64,
    /// Per-column relative fit residual `‖T_oᵀ w_j − t_j‖ / ‖t_j‖`, t_j = column j of `T_nᵀ`
    /// (= row j of T_n, the paper's residuum of eq. 22 for non-interface DoF j); 0 when
    /// `t_j = 0`. Exact for the returned `W`, truncated or not: the truncated directions'
    /// contribution `‖U_dropᵀ Y e_j‖²` is added to the accumulated `e_j`.
    pub residual: Vec<f64>,
    /// max_j residual_j (0 if m = 0).
    pub residual_max: f64,
    /// mean_j residual_j (0 if m = 0).
    pub residual_mean: f64,
    /// A column j with residual_j = residual_max — where an extra interface DoF helps most.
    pub residual_argmax: usize,
    /// Rows absorbed (2pz).
    pub rows: usize,
}

/// Streamed QR / TSQR state of the line-fitting least-squares problem (docs/design.md §3.3).
///
/// See the [module documentation](self) for the invariant. Memory: `8·(n² + n·m + m)` bytes
/// plus the chunk buffers of [`absorb`](StreamedQr::absorb), at most
/// [`absorb_workspace_bytes`](StreamedQr::absorb_workspace_bytes) — O((q + n)·chunk) per
/// thread, independent of m — which are kept for reuse by the next absorb.
#[derive(Clone)]
pub struct StreamedQr {
    n: usize,
    m: usize,
    r: Mat<f64>,
    /// `Y`, column-major n × m without padding (column j at `y[j·n .. (j+1)·n]`).
    y: Vec<f64>,
    e: Vec<f64>,
    rows: usize,
    chunk_cols: usize,
    /// Chunk buffers of the last absorb, reused by the next one (≤ one per rayon worker).
    pool: WorkspacePool,
}

impl std::fmt::Debug for StreamedQr {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("StreamedQr")
            .field("n", &self.n)
            .field("m", &self.m)
            .field("rows", &self.rows)
            .field("chunk_cols", &self.chunk_cols)
            .finish_non_exhaustive()
    }
}

/// Per-worker buffers of the chunked application (reused across chunks and blocks).
#[derive(Default)]
struct Workspace {
    /// Copy of the F chunk, transformed in place into the bottom rows (q × chunk, ld q).
    f: Vec<f64>,
    /// `Vᵀ [Y; F]` for one panel (nb × chunk, ld nb).
    w: Vec<f64>,
}

impl Workspace {
    fn bytes(&self) -> usize {
        8 * (self.f.capacity() + self.w.capacity())
    }
}

/// Idle [`Workspace`]s. Cloning a state does not clone its buffers.
#[derive(Default)]
struct WorkspacePool(std::sync::Mutex<Vec<Workspace>>);

impl Clone for WorkspacePool {
    fn clone(&self) -> Self {
        WorkspacePool::default()
    }
}

impl WorkspacePool {
    /// An idle workspace (or a new one) with at least the given buffer lengths.
    fn take(&self, f: usize, w: usize) -> PooledWorkspace<'_> {
        let mut ws = self
            .0
            .lock()
            .ok()
            .and_then(|mut p| p.pop())
            .unwrap_or_default();
        for (buf, len) in [(&mut ws.f, f), (&mut ws.w, w)] {
            if buf.len() < len {
                buf.resize(len, 0.0);
            }
        }
        PooledWorkspace { ws, pool: self }
    }

    fn bytes(&self) -> usize {
        self.0
            .lock()
            .map(|p| p.iter().map(Workspace::bytes).sum())
            .unwrap_or(0)
    }
}

/// A workspace on loan; returned to the pool on drop.
struct PooledWorkspace<'a> {
    ws: Workspace,
    pool: &'a WorkspacePool,
}

impl Drop for PooledWorkspace<'_> {
    fn drop(&mut self) {
        let ws = std::mem::take(&mut self.ws);
        if let Ok(mut p) = self.pool.0.lock() {
            p.push(ws);
        }
    }
}

/// The reflectors of one absorbed block in compact-WY form.
struct Reflectors {
    /// Essential parts of the reflectors (q × n): reflector j is `I − τ_j v_j v_jᵀ` with
    /// `v_j = e_j` on the top n rows and `vg.col(j)` on the q bottom rows.
    vg: Mat<f64>,
    /// Upper-triangular `T` factors, one per panel of `PANEL` reflectors (stored in a
    /// PANEL × n matrix: panel b occupies columns `b·PANEL ..`).
    t: Mat<f64>,
    /// `vg · Tᵀ` per panel (q × n, panel b in columns `b·PANEL ..`), so that the update of the
    /// bottom rows `F −= vg (Tᵀ W)` is one product `F −= (vg Tᵀ) W`.
    vgt: Mat<f64>,
}

impl StreamedQr {
    /// An empty state for `n` interface unknowns and `m` right-hand-side columns
    /// (allocates `R`, `Y`, `e`: 8·(n² + n·m + m) bytes).
    pub fn new(n: usize, m: usize) -> Self {
        StreamedQr {
            n,
            m,
            r: Mat::zeros(n, n),
            y: vec![0.0; n * m],
            e: vec![0.0; m],
            rows: 0,
            chunk_cols: DEFAULT_CHUNK_COLS,
            pool: WorkspacePool::default(),
        }
    }

    /// A state from its parts, as [`Self::parts`] returns them (another process's state,
    /// docs/design.md §9): `R` (n × n), `Y` (n × m column-major), `e` (m), rows absorbed.
    pub(crate) fn from_parts(r: Mat<f64>, y: Vec<f64>, e: Vec<f64>, rows: usize) -> Result<Self> {
        let (n, m) = (r.nrows(), e.len());
        if r.ncols() != n || y.len() != n * m {
            return Err(Error::InvalidSetting(format!(
                "least-squares state parts of inconsistent shapes: R {}×{}, Y {} values, e {}",
                r.nrows(),
                r.ncols(),
                y.len(),
                m
            )));
        }
        Ok(StreamedQr {
            n,
            m,
            r,
            y,
            e,
            rows,
            chunk_cols: DEFAULT_CHUNK_COLS,
            pool: WorkspacePool::default(),
        })
    }

    /// `R`, `Y` (column-major), `e` and the rows absorbed: everything a merge needs.
    pub(crate) fn parts(&self) -> (MatRef<'_, f64>, &[f64], &[f64], usize) {
        (self.r.as_ref(), &self.y, &self.e, self.rows)
    }

    /// Number of unknowns per column (columns of `T_oᵀ`, interface DoFs).
    pub fn n(&self) -> usize {
        self.n
    }

    /// Number of right-hand-side columns (columns of `T_nᵀ`).
    pub fn m(&self) -> usize {
        self.m
    }

    /// Rows absorbed so far (2pz).
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// The current triangle `R` (n × n, upper triangular; `RᵀR = T_o T_oᵀ`).
    pub fn r(&self) -> MatRef<'_, f64> {
        self.r.as_ref()
    }

    /// The current `Y` (n × m) of the invariant in the [module documentation](self).
    pub fn y(&self) -> MatRef<'_, f64> {
        self.y_ref()
    }

    fn y_ref(&self) -> MatRef<'_, f64> {
        MatRef::from_column_major_slice(&self.y, self.n, self.m)
    }

    /// Maximum columns of `Y`/`F` per parallel task (default 4096).
    pub fn chunk_cols(&self) -> usize {
        self.chunk_cols
    }

    /// Sets the maximum number of columns per parallel task (≥ 1; the buffers of
    /// [`absorb`](Self::absorb) are (q + min(n, 32))·chunk values per thread).
    pub fn set_chunk_cols(&mut self, cols: usize) {
        self.chunk_cols = cols.max(1);
    }

    /// Columns per task actually used: `chunk_cols`, reduced for small m so that every rayon
    /// thread gets about four tasks (load balance), but not below 256 columns.
    fn task_cols(&self) -> usize {
        let balanced = self.m.div_ceil(4 * rayon::current_num_threads()).max(256);
        self.chunk_cols.min(balanced)
    }

    /// Bytes held by the state: `R`, `Y`, `e` (8·(n² + n·m + m) up to faer's
    /// column padding of `R`) and the idle chunk buffers kept for the next
    /// [`absorb`](Self::absorb) (≤ one [`absorb_workspace_bytes`](Self::absorb_workspace_bytes)
    /// worker share per rayon thread).
    pub fn memory_bytes(&self) -> usize {
        let f = std::mem::size_of::<f64>();
        let r = self.r.col_stride().unsigned_abs() * self.r.ncols() * f;
        r + (self.y.capacity() + self.e.capacity()) * f + self.pool.bytes()
    }

    /// Upper bound of the transient bytes one [`absorb`](Self::absorb) of a q-row block
    /// allocates: the reflectors (2·q·n + 32·n) plus, per rayon worker, the chunk buffers
    /// ((q + min(n, 32))·chunk).
    pub fn absorb_workspace_bytes(&self, q: usize) -> usize {
        let nb = self.n.min(PANEL);
        let chunk = self.task_cols().min(self.m);
        let per_worker = (q + nb) * chunk;
        8 * (2 * q * self.n + nb * self.n + self.n + rayon::current_num_threads() * per_worker)
    }

    /// Absorbs one block of rows: `g` (q × n, rows of `T_oᵀ`) and `f` (q × m, the same rows of
    /// `T_nᵀ`), any q ≥ 0 (docs/design.md §3.3 "to absorb a block").
    ///
    /// Householder QR of `[R; G]` gives the new `R`; the same reflectors, transposed, are
    /// applied to `[Y; F]`: the top n rows are the new `Y`, the squared column norms of the
    /// bottom q rows add to `e`. `F` is processed in column chunks in parallel (rayon); the
    /// blocks may be dropped afterwards.
    ///
    /// Errors (`Error::InvalidSetting`, state unchanged): `g.ncols() != n`, `f.ncols() != m`,
    /// `g.nrows() != f.nrows()`, a NaN or ±∞ entry.
    pub fn absorb(&mut self, g: MatRef<'_, f64>, f: MatRef<'_, f64>) -> Result<()> {
        if g.ncols() != self.n {
            return Err(Error::InvalidSetting(format!(
                "least-squares block G has {} columns, but the state has n = {} interface \
                 unknowns",
                g.ncols(),
                self.n
            )));
        }
        if f.ncols() != self.m {
            return Err(Error::InvalidSetting(format!(
                "least-squares block F has {} columns, but the state has m = {} right-hand-side \
                 columns",
                f.ncols(),
                self.m
            )));
        }
        if g.nrows() != f.nrows() {
            return Err(Error::InvalidSetting(format!(
                "least-squares blocks G and F must have the same rows: G has {}, F has {}",
                g.nrows(),
                f.nrows()
            )));
        }
        check_finite("G", g, self.task_cols())?;
        check_finite("F", f, self.task_cols())?;
        self.absorb_unchecked(g, f);
        self.rows += g.nrows();
        Ok(())
    }

    /// TSQR step: combines two states built from disjoint row sets into the state of all their
    /// rows — the QR of `[R1; R2]` applied to `[Y1; Y2]`; `e` and `rows` add.
    ///
    /// Errors: different `n` or `m` (`Error::InvalidSetting`).
    pub fn merge(mut self, other: StreamedQr) -> Result<StreamedQr> {
        if self.n != other.n || self.m != other.m {
            return Err(Error::InvalidSetting(format!(
                "cannot merge least-squares states of different shapes: n×m = {}×{} and {}×{}",
                self.n, self.m, other.n, other.m
            )));
        }
        if other.rows == 0 {
            return Ok(self);
        }
        if self.rows == 0 {
            let chunk_cols = self.chunk_cols;
            let mut other = other;
            other.chunk_cols = chunk_cols;
            return Ok(other);
        }
        self.absorb_unchecked(other.r.as_ref(), other.y_ref());
        let chunk = self.task_cols();
        self.e
            .par_chunks_mut(chunk)
            .zip(other.e.par_chunks(chunk))
            .for_each(|(e1, e2)| e1.iter_mut().zip(e2).for_each(|(a, b)| *a += b));
        self.rows += other.rows;
        Ok(self)
    }

    /// The core of absorb/merge: `[R; G]`, `[Y; F]` → new `R`, `Y`, `e`. Inputs validated.
    fn absorb_unchecked(&mut self, g: MatRef<'_, f64>, f: MatRef<'_, f64>) {
        let q = g.nrows();
        if q == 0 {
            return;
        }
        let refl = self.factor_block(g);
        if self.m == 0 {
            return;
        }
        let n = self.n;
        let m = self.m;
        let chunk = self.task_cols();
        let ceff = chunk.min(m);
        let nb = n.min(PANEL);
        let refl = &refl;
        let pool = &self.pool;
        // Column chunks of Y (contiguous, n·chunk values each); with n = 0 every chunk is empty.
        let ychunks: Vec<&mut [f64]> = if n == 0 {
            (0..m.div_ceil(chunk))
                .map(|_| <&mut [f64]>::default())
                .collect()
        } else {
            self.y.chunks_mut(n * chunk).collect()
        };
        ychunks
            .into_par_iter()
            .zip(self.e.par_chunks_mut(chunk))
            .enumerate()
            .for_each_init(
                || pool.take(q * ceff, nb * ceff),
                |ws, (idx, (y, e))| {
                    let c0 = idx * chunk;
                    let f = f.subcols(c0, e.len());
                    apply_chunk(refl, n, y, f, e, &mut ws.ws);
                },
            );
    }

    /// Householder QR of `[R; G]` in place: `R` becomes the new triangle, the returned
    /// reflectors hold the essential parts (in a copy of `G`) and the compact-WY `T` factors.
    fn factor_block(&mut self, g: MatRef<'_, f64>) -> Reflectors {
        let n = self.n;
        let q = g.nrows();
        let mut vg = Mat::<f64>::zeros(q, n);
        vg.as_mut().copy_from(g);
        let mut tau = vec![0.0; n];
        for (j, tau_j) in tau.iter_mut().enumerate() {
            let (left, mut right) = vg.as_mut().split_at_col_mut(j + 1);
            let mut vj = left.col_mut(j);
            let xnorm = vj.rb().norm_l2();
            if xnorm == 0.0 {
                // G's column j is already zero below R[j, j]: the reflector is the identity.
                continue;
            }
            let alpha = self.r[(j, j)];
            // LAPACK dlarfg: β = −sign(α)·‖(α, x)‖, τ = (β − α)/β, v = x/(α − β).
            let beta = -alpha.signum() * alpha.hypot(xnorm);
            let beta = if alpha == 0.0 { -xnorm } else { beta };
            let t = (beta - alpha) / beta;
            let denom = alpha - beta;
            for x in vj.rb_mut().iter_mut() {
                *x /= denom;
            }
            self.r[(j, j)] = beta;
            *tau_j = t;
            let vj = vj.rb();
            for c in 0..n - j - 1 {
                let mut gc = right.rb_mut().col_mut(c);
                let dot = self.r[(j, j + 1 + c)] + dot_col(vj, gc.rb());
                let s = t * dot;
                self.r[(j, j + 1 + c)] -= s;
                for (x, v) in gc.rb_mut().iter_mut().zip(vj.iter()) {
                    *x -= s * v;
                }
            }
        }
        // Compact-WY T factor per panel (LAPACK dlarft, forward, columnwise): for the panel's
        // reflectors H_a ⋯ H_{a+nb−1} = I − V T Vᵀ with V = [E; vg_panel]; the top parts of two
        // different reflectors are orthogonal unit vectors, so Vᵀ V's off-diagonal comes from
        // vg alone.
        let nbmax = n.min(PANEL);
        let mut t = Mat::<f64>::zeros(nbmax, n);
        let mut tmp = vec![0.0; nbmax];
        let mut p0 = 0;
        while p0 < n {
            let nb = PANEL.min(n - p0);
            for i in 0..nb {
                let ti = tau[p0 + i];
                t[(i, p0 + i)] = ti;
                if ti == 0.0 {
                    continue;
                }
                let vi = vg.col(p0 + i);
                for (k, tk) in tmp.iter_mut().enumerate().take(i) {
                    *tk = -ti * dot_col(vg.col(p0 + k), vi);
                }
                // T[0..i, i] = T[0..i, 0..i] · tmp (upper triangular).
                for r in 0..i {
                    let mut s = 0.0;
                    for (k, tk) in tmp.iter().enumerate().take(i).skip(r) {
                        s += t[(r, p0 + k)] * tk;
                    }
                    t[(r, p0 + i)] = s;
                }
            }
            p0 += nb;
        }
        let mut vgt = Mat::<f64>::zeros(q, n);
        let mut p0 = 0;
        while p0 < n {
            let nb = PANEL.min(n - p0);
            matmul(
                vgt.as_mut().subcols_mut(p0, nb),
                Accum::Replace,
                vg.as_ref().subcols(p0, nb),
                t.as_ref().submatrix(0, p0, nb, nb).transpose(),
                1.0,
                Par::Seq,
            );
            p0 += nb;
        }
        Reflectors { vg, t, vgt }
    }

    /// Solves the least-squares problem from the state (docs/design.md §3.3 "Finish").
    ///
    /// 1. Column equilibration: the column norms of `T_oᵀ` equal those of `R` (`Q` is
    ///    orthogonal), and QR commutes with column scaling, so with `S = diag(1/‖R e_j‖)` the
    ///    triangle of the equilibrated problem `T_oᵀ S` is `R·S` — no second pass over the
    ///    data. (Householder QR is column-wise backward stable, so `R·S` is as accurate as if
    ///    the data had been scaled before the QR.)
    /// 2. SVD `R·S = U Σ Vᵀ` (n × n); `cond_equilibrated = σ_max/σ_min`; `cond_raw` from the
    ///    singular values of `R`.
    /// 3. Rank: keep σ_i > τ·σ_max, τ from [`LsqOptions::rcond_tol`].
    /// 4. `Wᵀ = S V_r Σ_r⁻¹ U_rᵀ Y`, returned as `W = Yᵀ (U_r Σ_r⁻¹ V_rᵀ S)` (m × n).
    /// 5. Residual: `‖T_oᵀ w_j − t_j‖² = e_j + ‖U_dropᵀ Y e_j‖²` (the second term only when
    ///    truncated), reported relative to `‖t_j‖ = (‖Y e_j‖² + e_j)^½`.
    ///
    /// Errors (`Error::InvalidSetting`): fewer rows than unknowns (2pz < n), `n = 0`,
    /// all-zero `T_oᵀ`, `rcond_tol` outside [0, 1). `Error::Factor` if the SVD fails.
    pub fn finish(&self, opts: &LsqOptions) -> Result<LsqSolution> {
        let n = self.n;
        let m = self.m;
        if !(0.0..1.0).contains(&opts.rcond_tol) {
            return Err(Error::InvalidSetting(format!(
                "least-squares rcond_tol must be in [0, 1) (relative to σ_max), got {}",
                opts.rcond_tol
            )));
        }
        if n == 0 {
            return Err(Error::InvalidSetting(
                "least squares with n = 0 interface unknowns: choose at least one interface DoF"
                    .into(),
            ));
        }
        if self.rows < n {
            return Err(Error::InvalidSetting(format!(
                "least squares needs 2pz ≥ n rows: {} rows absorbed, at least n = {} needed \
                 ({} more; add reference frequencies or inputs, or use fewer interface DoFs)",
                self.rows,
                n,
                n - self.rows
            )));
        }
        let col_norms: Vec<f64> = (0..n).map(|j| self.r.col(j).norm_l2()).collect();
        if col_norms.iter().all(|&x| x == 0.0) {
            return Err(Error::InvalidSetting(format!(
                "least squares: T_oᵀ is all zero ({} rows absorbed) — the interface DoFs do not \
                 respond to the inputs at the reference frequencies",
                self.rows
            )));
        }
        if col_norms.iter().any(|x| !x.is_finite()) {
            return Err(Error::InvalidSetting(
                "least squares: the triangle R overflowed (|T_oᵀ| entries near f64::MAX); \
                 rescale the snapshots"
                    .into(),
            ));
        }
        let scale: Vec<f64> = col_norms
            .iter()
            .map(|&d| if d > 0.0 { 1.0 / d } else { 1.0 })
            .collect();
        let rs = Mat::<f64>::from_fn(n, n, |i, j| self.r[(i, j)] * scale[j]);
        let svd = rs
            .thin_svd()
            .map_err(|e| Error::Factor(format!("SVD of the equilibrated R failed: {e:?}")))?;
        let sigma: Vec<f64> = (0..n).map(|i| svd.S()[i]).collect();
        let sigma_raw = self
            .r
            .singular_values()
            .map_err(|e| Error::Factor(format!("SVD of R failed: {e:?}")))?;
        let cond = |s: &[f64]| {
            let (max, min) = (s[0], s[s.len() - 1]);
            if min > 0.0 {
                max / min
            } else {
                f64::INFINITY
            }
        };
        let cond_raw = cond(&sigma_raw);
        let cond_equilibrated = cond(&sigma);
        let tol = opts.effective_tol(self.rows, n);
        let smax = sigma[0];
        let rank = sigma.iter().take_while(|&&s| s > tol * smax).count();
        let truncated = rank < n;

        // M = U_r Σ_r⁻¹ V_rᵀ S (n × n), W = Yᵀ M.
        let u = svd.U();
        let v = svd.V();
        let ur_scaled = Mat::<f64>::from_fn(n, rank, |i, k| u[(i, k)] / sigma[k]);
        let vs = Mat::<f64>::from_fn(rank, n, |k, j| v[(j, k)] * scale[j]);
        let mut mm = Mat::<f64>::zeros(n, n);
        matmul(
            mm.as_mut(),
            Accum::Replace,
            ur_scaled.as_ref(),
            vs.as_ref(),
            1.0,
            Par::Seq,
        );
        let mut w = Mat::<f64>::zeros(m, n);
        matmul(
            w.as_mut(),
            Accum::Replace,
            self.y_ref().transpose(),
            mm.as_ref(),
            1.0,
            Par::rayon(0),
        );

        // Residuals: e_j (+ ‖U_dropᵀ Y e_j‖² when truncated).
        let chunk = self.task_cols();
        let mut residual = vec![0.0; m];
        let udrop = u.subcols(rank, n - rank);
        residual
            .par_chunks_mut(chunk)
            .enumerate()
            .for_each(|(idx, res)| {
                let c0 = idx * chunk;
                let c = res.len();
                let extra = truncated.then(|| {
                    let mut z = Mat::<f64>::zeros(n - rank, c);
                    matmul(
                        z.as_mut(),
                        Accum::Replace,
                        udrop.transpose(),
                        self.y_ref().subcols(c0, c),
                        1.0,
                        Par::Seq,
                    );
                    z
                });
                for (j, r) in res.iter_mut().enumerate() {
                    let e = self.e[c0 + j];
                    // ‖t_j‖² = ‖Y e_j‖² + e_j (module docs).
                    let t2 = sum_sq(&self.y[(c0 + j) * n..(c0 + j + 1) * n]) + e;
                    let res2 = match &extra {
                        Some(z) => e + sum_sq(z.col_as_slice(j)),
                        None => e,
                    };
                    *r = if t2 > 0.0 { (res2 / t2).sqrt() } else { 0.0 };
                }
            });
        let (mut residual_max, mut residual_argmax) = (0.0, 0);
        for (j, &r) in residual.iter().enumerate() {
            if r > residual_max {
                residual_max = r;
                residual_argmax = j;
            }
        }
        let residual_mean = if m > 0 {
            residual.iter().sum::<f64>() / m as f64
        } else {
            0.0
        };
        Ok(LsqSolution {
            w,
            singular_values: sigma,
            col_norms,
            cond_raw,
            cond_equilibrated,
            rank,
            truncated,
            rcond_used: tol,
            residual,
            residual_max,
            residual_mean,
            residual_argmax,
            rows: self.rows,
        })
    }
}

/// Applies the block's reflectors (transposed) to one column chunk: `[y; f] ← Qᵀ [y; f]`,
/// `e += ‖new bottom rows‖²` per column. `y` is the
/// chunk of `Y` (n × c, ld n), `f` the same columns of the block (q × c, any strides).
fn apply_chunk(
    refl: &Reflectors,
    n: usize,
    y: &mut [f64],
    f: MatRef<'_, f64>,
    e: &mut [f64],
    ws: &mut Workspace,
) {
    let c = e.len();
    let q = f.nrows();
    let fb = &mut ws.f[..q * c];
    copy_to_col_major(f, fb);
    let mut p0 = 0;
    while p0 < n {
        let nb = PANEL.min(n - p0);
        let vg = refl.vg.subcols(p0, nb);
        let t = refl.t.submatrix(0, p0, nb, nb);
        let w = &mut ws.w[..nb * c];
        // W = Vᵀ [Y; F] = Y[panel rows] + vgᵀ F
        if nb == n {
            w.copy_from_slice(y);
        } else {
            for (wj, yj) in w.chunks_exact_mut(nb).zip(y.chunks_exact(n)) {
                wj.copy_from_slice(&yj[p0..p0 + nb]);
            }
        }
        matmul(
            MatMut::from_column_major_slice_mut(&mut *w, nb, c),
            Accum::Add,
            vg.transpose(),
            MatRef::from_column_major_slice(&*fb, q, c),
            1.0,
            Par::Seq,
        );
        let w = MatRef::from_column_major_slice(&*w, nb, c);
        // [Y; F] −= V Tᵀ W:  Y[panel rows] −= Tᵀ W,  F −= (vg Tᵀ) W
        matmul(
            MatMut::from_column_major_slice_with_stride_mut(&mut y[p0..], nb, c, n),
            Accum::Add,
            t.transpose(),
            w,
            -1.0,
            Par::Seq,
        );
        matmul(
            MatMut::from_column_major_slice_mut(&mut *fb, q, c),
            Accum::Add,
            refl.vgt.subcols(p0, nb),
            w,
            -1.0,
            Par::Seq,
        );
        p0 += nb;
    }
    for (x, col) in e.iter_mut().zip(fb.chunks_exact(q)) {
        *x += sum_sq(col);
    }
}

/// Copies `src` (q × c, any strides) into the column-major `dst` (ld q).
fn copy_to_col_major(src: MatRef<'_, f64>, dst: &mut [f64]) {
    let (q, c) = src.shape();
    if q == 0 {
        return;
    }
    if src.row_stride() == 1 && src.col_stride() == q as isize {
        // SAFETY: with unit row stride and column stride q the q·c entries of `src` occupy
        // exactly the q·c consecutive f64 starting at `as_ptr()`, all valid for reads for the
        // lifetime of the borrow (a MatRef guarantees every (i, j) entry is readable).
        let s = unsafe { std::slice::from_raw_parts(src.as_ptr(), q * c) };
        dst.copy_from_slice(s);
    } else if src.row_stride() == 1 {
        for (j, d) in dst.chunks_exact_mut(q).enumerate() {
            let col = src.col(j).try_as_col_major().expect("unit row stride");
            d.copy_from_slice(col.as_slice());
        }
    } else {
        MatMut::from_column_major_slice_mut(dst, q, c).copy_from(src);
    }
}

/// Σ x², with four independent accumulators (vectorizes).
fn sum_sq(x: &[f64]) -> f64 {
    let mut lanes = [0.0f64; 4];
    let mut it = x.chunks_exact(4);
    for ch in &mut it {
        for (l, v) in lanes.iter_mut().zip(ch) {
            *l += v * v;
        }
    }
    let mut s = (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
    for v in it.remainder() {
        s += v * v;
    }
    s
}

fn dot_col(a: faer::ColRef<'_, f64>, b: faer::ColRef<'_, f64>) -> f64 {
    a.iter().zip(b.iter()).map(|(x, y)| x * y).sum()
}

/// `Err` naming the first NaN/±∞ entry of `a`; the scan runs over column chunks in parallel.
fn check_finite(name: &str, a: MatRef<'_, f64>, chunk: usize) -> Result<()> {
    if a.nrows() == 0 || a.ncols() == 0 {
        return Ok(());
    }
    let bad = (0..a.ncols().div_ceil(chunk)).into_par_iter().any(|idx| {
        let c0 = idx * chunk;
        let c = chunk.min(a.ncols() - c0);
        !all_finite(a.subcols(c0, c))
    });
    if !bad {
        return Ok(());
    }
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            let x = a[(i, j)];
            if !x.is_finite() {
                return Err(Error::InvalidSetting(format!(
                    "least-squares block {name} has a non-finite entry {x} at row {i}, column \
                     {j}"
                )));
            }
        }
    }
    Ok(())
}

/// `true` if every entry is finite: `x·0` is 0 for finite x and NaN otherwise, summed with
/// independent accumulators so the loop vectorizes.
fn all_finite(a: MatRef<'_, f64>) -> bool {
    let mut acc = 0.0f64;
    for j in 0..a.ncols() {
        let col = a.col(j);
        if let Some(s) = col.try_as_col_major() {
            let s = s.as_slice();
            let mut lanes = [0.0f64; 4];
            let mut it = s.chunks_exact(4);
            for ch in &mut it {
                for k in 0..4 {
                    lanes[k] += ch[k] * 0.0;
                }
            }
            for &x in it.remainder() {
                lanes[0] += x * 0.0;
            }
            acc += lanes.iter().sum::<f64>();
        } else {
            acc += col.iter().map(|x| x * 0.0).sum::<f64>();
        }
    }
    acc == 0.0
}
