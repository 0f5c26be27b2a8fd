//! The pencil A(s) = s²M + sD + K on one sparsity pattern (docs/design.md §3.1).
//!
//! [`Pencil::new`] builds the union pattern of the lower triangles of M, K (and D) once and
//! scatters their values into arrays aligned with that pattern (the index maps are applied
//! once, here). Per frequency, [`Pencil::fill_real`] / [`Pencil::fill_complex`] write the
//! values of A(iω) = K − ω²M + iωD in O(nnz) with no allocation and no pattern work.
//!
//! The pattern is the lower triangle (row ≥ column) with sorted rows, diagonal first: the form
//! the symmetric factorizations read. [`Pencil::apply`] multiplies the symmetric A(iω) by a
//! block of complex vectors (used for the residual/probe checks of every factorization).
//!
//! The pencil is where a [`crate::body::Body`] holds the model's matrices: every product with
//! M, K or D after the body is built ([`Pencil::mul`]: projections, rigid modes, eigenpair
//! residuals) reads these lower triangles, so the model's full-storage matrices can be dropped
//! (docs/design.md §2: on the 10⁶-DoF bar they are 1.36 GB beside the pencil's 0.77 GB).
//! Products with M, the most frequent (Krylov spaces, M-inner products), read a copy of M by
//! rows on its own nonzeros, made at the first one (the 10⁶-DoF bar: 21.2 M entries, 254 MB).
//!
//! A coupled model (§3.11) may carry its coupling ([`crate::model::Coupling`], made
//! [`Congruent`] here): its products are then X'z = Tᵀ(X₁(T z)) with the model before its
//! functionals became coordinates, which reads far fewer entries than the formed X' = TᵀX₁T
//! when distributing points give X' dense blocks, and its real factorizations take X₁
//! ([`Pencil::factored`]). The formed values stay the pattern the per-frequency
//! factorizations fill and the certificates read.

use crate::model::{Damping, Model};
use crate::proportional::{split, Pattern, Proportional, Remainder, Split, Viscous};
use crate::sparse::{from_parts, lower_triangle, mirror_lower, Csc};
use faer::{c64, Mat, MatMut, MatRef};
use std::borrow::Cow;
use std::sync::{Arc, OnceLock};

/// Columns per pass of [`Pencil::mul_to`] over the matrix.
const BLOCK: usize = 4;

/// A column as a block of width 1.
fn cast(x: &[f64]) -> &[[f64; 1]] {
    bytemuck::cast_slice(x)
}

/// A column as a block of width 1, to write.
fn cast_mut(y: &mut [f64]) -> &mut [[f64; 1]] {
    bytemuck::cast_slice_mut(y)
}

/// One coefficient matrix of the pencil A(s) = s²M + sD + K.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coefficient {
    /// M.
    Mass,
    /// K.
    Stiffness,
    /// D (zero without damping, αM + βK for Rayleigh damping).
    Damping,
    /// The structural damping H = ηK + K₄ (zero without it; §3.1).
    Structural,
}

/// Lower-triangle union pattern of M, K, D with per-matrix coefficient arrays.
#[derive(Clone, Debug)]
pub struct Pencil {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    m: Vec<f64>,
    k: Vec<f64>,
    d: DampingValues,
    /// The loss factor η of H = ηK + K₄.
    eta: f64,
    /// K₄ on the pattern, if any.
    k4: Option<Vec<f64>>,
    /// The damping's proportional part and remainder (docs/design.md §3.12).
    split: Split,
    /// M by rows on its own nonzeros (built at the first product with M).
    mass_rows: OnceLock<Option<Rows>>,
    /// The coupling the products go through, when the model carries one that agrees with
    /// the formed values ([`Congruent`]).
    through: Option<Arc<Congruent>>,
}

/// A coupled model's products and factorizations through its coupling (docs/design.md
/// §3.11). The coupled X' = TᵀX₁T, with X₁ ∈ {M, K, D, H} the model's after its rigid points'
/// elimination and T = S⁻¹ the change of variables that makes the functionals coordinates
/// (N' × N', S the identity with the pivot rows replaced by the functionals):
/// - products X'z = Tᵀ(X₁(T z)). A distributing point over s DoFs gives X' a dense s × s
///   block, while T has s entries in each of the point's rows: a product reads
///   nnz(X₁) + 2·nnz(T) entries instead of nnz(X') (the 77k-DoF crank's two bores: K 5.6 M and
///   T 0.1 M entries against the formed K' 28.4 M);
/// - solves A'⁻¹ = S A₁⁻¹ Sᵀ: the real factorizations take A₁ ([`Pencil::factored`]), which
///   has no dense block and, being congruent to A', the same inertia.
///
/// Built by [`Pencil::new`] from the model's [`crate::model::Coupling`], which
/// [`crate::coupled::couple`] sets when it pays ([`Congruent::pays`]), and used only if probe
/// products agree with the formed matrices and S inverts T on the probe.
#[derive(Debug)]
pub struct Congruent {
    /// The pencil of A₁, with the damping whose congruence is the coupled model's.
    inner: Pencil,
    /// T by columns: (Tᵀy)_j is column j of T times y.
    t: Csc,
    /// Tᵀ by columns, i.e. T by rows: (Tz)_i is column i of Tᵀ times z.
    t_rows: Csc,
    /// S = T⁻¹ by columns: (Sᵀy)_j is column j of S times y.
    s: Csc,
    /// Sᵀ by columns: (Sz)_i is column i of Sᵀ times z.
    s_rows: Csc,
}

impl Congruent {
    /// The products and solves of `first`'s matrices (A₁) through T = `t` and its inverse
    /// S = `s` (both N' × N', N' = `first`'s N). `first` must carry the damping whose
    /// congruence is the coupled model's (an explicit D, or the proportional part and
    /// remainder it was split into).
    ///
    /// # Errors
    /// [`crate::Error::InvalidSetting`] when T or S does not match the model;
    /// [`crate::Error::Factor`] when their transposes cannot be stored.
    fn new(first: &Model, t: &Csc, s: &Csc) -> crate::Result<Congruent> {
        let n = first.n();
        if [t.nrows(), t.ncols(), s.nrows(), s.ncols()] != [n; 4] {
            return Err(crate::Error::InvalidSetting(format!(
                "coupling: T is {}×{} and S {}×{} for a model of N = {n}",
                t.nrows(),
                t.ncols(),
                s.nrows(),
                s.ncols()
            )));
        }
        let transposed = |a: &Csc| {
            a.as_ref()
                .transpose()
                .to_col_major()
                .map_err(|e| crate::Error::Factor(format!("coupling: a transpose: {e:?}")))
        };
        Ok(Congruent {
            inner: Pencil::new(first),
            t: t.clone(),
            t_rows: transposed(t)?,
            s: s.clone(),
            s_rows: transposed(s)?,
        })
    }

    /// True when a product through T reads at most half the entries of one with the formed
    /// X' (`formed`: the stored entries of K' in full storage), from the stored entries of
    /// the body's own K (`original`) and of T (`t`): original + 2·t ≤ formed / 2.
    pub fn pays(original: usize, t: usize, formed: usize) -> bool {
        2 * (original + 2 * t) <= formed
    }

    /// Stored entries a product reads: the first pencil's lower pattern and T twice.
    fn entries(&self) -> usize {
        self.inner.nnz() + 2 * self.t.compute_nnz()
    }

    /// y ← Tᵀ(X₁(T x)) for W interleaved columns, X₁'s lower values `vals` on the first
    /// pencil's pattern.
    fn product<const W: usize>(
        &self,
        which: Coefficient,
        vals: &[f64],
        x: &[[f64; W]],
        y: &mut [[f64; W]],
    ) {
        let mut tx = vec![[0.0; W]; self.t.nrows()];
        gather(&self.t_rows, x, &mut tx);
        let mut xtx = vec![[0.0; W]; self.t.nrows()];
        self.inner.block_product(which, vals, &tx, &mut xtx);
        gather(&self.t, &xtx, y);
    }

    /// X ← S(solve(SᵀX)): A'⁻¹X from `solve`, X ← A₁⁻¹X.
    fn solve<T: Through>(&self, mut x: MatMut<'_, T>, solve: impl FnOnce(MatMut<'_, T>)) {
        each_column(&self.s, x.as_mut());
        solve(x.as_mut());
        each_column(&self.s_rows, x);
    }
}

/// X ← A'⁻¹X from `solve`, which does X ← A⁻¹X with the matrix of [`Pencil::factored`]:
/// through `coupling` when there is one (S(solve(SᵀX)), [`Congruent`]), else `solve` itself.
pub(crate) fn solve_through<T: Through>(
    coupling: Option<&Congruent>,
    x: MatMut<'_, T>,
    solve: impl FnOnce(MatMut<'_, T>),
) {
    match coupling {
        Some(c) => c.solve(x, solve),
        None => solve(x),
    }
}

/// The scalars a solve goes through the coupling with: f64 and c64.
pub(crate) trait Through:
    Copy + Default + std::ops::Mul<f64, Output = Self> + std::ops::AddAssign + 'static
{
}
impl Through for f64 {}
impl Through for c64 {}

/// x ← (column j of `a` times x for every j) = aᵀx, column by column of X.
fn each_column<T: Through>(a: &Csc, mut x: MatMut<'_, T>) {
    let n = x.nrows();
    let (mut col, mut out) = (vec![[T::default()]; n], vec![[T::default()]; a.ncols()]);
    for c in 0..x.ncols() {
        col.iter_mut()
            .zip(x.as_ref().col(c).iter())
            .for_each(|(a, &b)| a[0] = b);
        gather(a, &col, &mut out);
        x.as_mut()
            .col_mut(c)
            .iter_mut()
            .zip(&out)
            .for_each(|(a, b)| *a = b[0]);
    }
}

/// out_j ← Σ_i a_ij x_i: column j of `a` times the interleaved block `x`, for every column.
fn gather<T: Through, const W: usize>(a: &Csc, x: &[[T; W]], out: &mut [[T; W]]) {
    for (j, o) in out.iter_mut().enumerate() {
        let mut sum = [T::default(); W];
        for (&i, &v) in a.row_idx_of_col_raw(j).iter().zip(a.val_of_col(j)) {
            for k in 0..W {
                sum[k] += x[i][k] * v;
            }
        }
        *o = sum;
    }
}

/// A symmetric matrix in full storage by rows, its nonzeros only, columns ascending in each
/// row: y = X x is one gather per row. M's own pattern is a third of the union pattern on
/// elasticity models (its three displacement components do not couple: the 10⁵-DoF tet10
/// shaft has 2.5 M nonzeros of M against 7.5 M of K), and the product is the eigensolver's
/// and the shifted Krylov space's most frequent one.
#[derive(Clone, Debug)]
struct Rows {
    ptr: Vec<usize>,
    col: Vec<u32>,
    val: Vec<f64>,
}

impl Rows {
    /// The nonzeros of the symmetric matrix whose lower triangle is `vals` on the pattern
    /// (`col_ptr`, `row_idx`), or `None` when N does not fit 32-bit column indices.
    fn new(n: usize, col_ptr: &[usize], row_idx: &[usize], vals: &[f64]) -> Option<Rows> {
        u32::try_from(n).ok()?;
        // row i: its entries left of the diagonal (from the columns j < i), the diagonal,
        // then the ones right of it (column i's entries below the diagonal)
        let mut left = vec![0usize; n];
        let mut ptr = vec![0usize; n + 1];
        for j in 0..n {
            for p in col_ptr[j]..col_ptr[j + 1] {
                if vals[p] != 0.0 {
                    let i = row_idx[p];
                    ptr[j + 1] += 1;
                    if i != j {
                        ptr[i + 1] += 1;
                        left[i] += 1;
                    }
                }
            }
        }
        for i in 0..n {
            ptr[i + 1] += ptr[i];
        }
        let mut col = vec![0u32; ptr[n]];
        let mut val = vec![0.0; ptr[n]];
        // the next free place left of the diagonal in each row
        let mut next: Vec<usize> = ptr[..n].to_vec();
        for j in 0..n {
            // row j's own part starts after its left entries, which columns < j have filled
            let mut own = ptr[j] + left[j];
            for p in col_ptr[j]..col_ptr[j + 1] {
                if vals[p] == 0.0 {
                    continue;
                }
                let i = row_idx[p];
                (col[own], val[own]) = (i as u32, vals[p]);
                own += 1;
                if i != j {
                    (col[next[i]], val[next[i]]) = (j as u32, vals[p]);
                    next[i] += 1;
                }
            }
        }
        Some(Rows { ptr, col, val })
    }

    /// y ← X x for W interleaved columns, each row summed in ascending columns.
    fn product<const W: usize>(&self, x: &[[f64; W]], y: &mut [[f64; W]]) {
        for (i, yi) in y.iter_mut().enumerate() {
            let r = self.ptr[i]..self.ptr[i + 1];
            let mut sum = [0.0; W];
            for (&c, &a) in self.col[r.clone()].iter().zip(&self.val[r]) {
                let xc = x[c as usize];
                for k in 0..W {
                    sum[k] += a * xc[k];
                }
            }
            *yi = sum;
        }
    }
}

#[derive(Clone, Debug)]
enum DampingValues {
    Zero,
    Rayleigh { alpha: f64, beta: f64 },
    Matrix(Vec<f64>),
}

impl Pencil {
    /// Builds the union pattern of the lower triangles of M, K and D (if explicit) and the
    /// aligned coefficient arrays. Memory O(nnz).
    pub fn new(model: &Model) -> Self {
        let n = model.n();
        let mut parts = vec![
            lower_triangle(model.mass.as_ref()),
            lower_triangle(model.stiffness.as_ref()),
        ];
        if let Damping::Matrix(d) = &model.damping {
            parts.push(lower_triangle(d.as_ref()));
        }
        if let Some(k4) = &model.structural.matrix {
            parts.push(lower_triangle(k4.as_ref()));
        }
        // union pattern, column by column (sorted merge of the sorted row lists)
        let mut col_ptr = Vec::with_capacity(n + 1);
        let mut row_idx = Vec::new();
        col_ptr.push(0);
        let mut cursor = vec![0usize; parts.len()];
        for j in 0..n {
            for (c, p) in cursor.iter_mut().zip(&parts) {
                *c = p.0[j];
            }
            loop {
                let next = parts
                    .iter()
                    .zip(&cursor)
                    .filter(|(p, &c)| c < p.0[j + 1])
                    .map(|(p, &c)| p.1[c])
                    .min();
                let Some(i) = next else { break };
                row_idx.push(i);
                for (c, p) in cursor.iter_mut().zip(&parts) {
                    if *c < p.0[j + 1] && p.1[*c] == i {
                        *c += 1;
                    }
                }
            }
            col_ptr.push(row_idx.len());
        }
        // scatter each matrix into arrays aligned with the union pattern
        let scatter = |p: &(Vec<usize>, Vec<usize>, Vec<f64>)| {
            let mut out = vec![0.0; row_idx.len()];
            for j in 0..n {
                let mut q = col_ptr[j];
                for t in p.0[j]..p.0[j + 1] {
                    while row_idx[q] != p.1[t] {
                        q += 1;
                    }
                    out[q] = p.2[t];
                }
            }
            out
        };
        let m = scatter(&parts[0]);
        let k = scatter(&parts[1]);
        let k4 = model
            .structural
            .matrix
            .as_ref()
            .map(|_| scatter(parts.last().expect("K4 was pushed last")));
        let d = match &model.damping {
            Damping::Matrix(_) => DampingValues::Matrix(scatter(&parts[2])),
            Damping::Rayleigh { alpha, beta } if !model.damping.is_zero() => {
                DampingValues::Rayleigh {
                    alpha: *alpha,
                    beta: *beta,
                }
            }
            _ => DampingValues::Zero,
        };
        let eta = model.structural.eta;
        let pattern = Pattern {
            col_ptr: &col_ptr,
            row_idx: &row_idx,
        };
        let split = match &d {
            DampingValues::Matrix(dv) => {
                split(pattern, &m, &k, Viscous::Matrix(dv), eta, k4.as_deref())
            }
            DampingValues::Rayleigh { alpha, beta } => split(
                pattern,
                &m,
                &k,
                Viscous::Rayleigh(*alpha, *beta),
                eta,
                k4.as_deref(),
            ),
            DampingValues::Zero => split(
                pattern,
                &m,
                &k,
                Viscous::Rayleigh(0.0, 0.0),
                eta,
                k4.as_deref(),
            ),
        };
        let mut pencil = Pencil {
            n,
            col_ptr,
            row_idx,
            m,
            k,
            d,
            eta,
            k4,
            split,
            mass_rows: OnceLock::new(),
            through: None,
        };
        pencil.through = model
            .coupling
            .as_ref()
            .and_then(|c| Congruent::new(&c.first, &c.t, &c.s).ok())
            .filter(|c| pencil.agrees_with(c))
            .map(Arc::new);
        pencil
    }

    /// True when the products through `c` equal the formed matrices' on a probe vector x
    /// (uniform in [−½, ½)) to 10⁻¹² ‖X'‖₁‖x‖_∞, for M, K, D and H, and S(Tx) = x to
    /// 10⁻¹²‖x‖_∞: a coupling that no longer matches the model (a matrix changed after
    /// coupling) is not used.
    fn agrees_with(&self, c: &Congruent) -> bool {
        if c.t.ncols() != self.n {
            return false;
        }
        let mut random = crate::random::Xorshift::new(0x5eed);
        let x: Vec<[f64; 1]> = (0..self.n).map(|_| [random.next_centred()]).collect();
        let x_max = x.iter().fold(0.0f64, |m, v| m.max(v[0].abs()));
        let coefficients = [
            Coefficient::Mass,
            Coefficient::Stiffness,
            Coefficient::Damping,
            Coefficient::Structural,
        ];
        let (mut tx, mut stx) = (vec![[0.0]; self.n], vec![[0.0]; self.n]);
        gather(&c.t_rows, &x, &mut tx);
        gather(&c.s_rows, &tx, &mut stx);
        let inverts = x
            .iter()
            .zip(&stx)
            .all(|(a, b)| (a[0] - b[0]).abs() <= 1e-12 * x_max);
        inverts
            && coefficients.into_iter().all(|which| {
                let (mut formed, mut through) = (vec![[0.0]; self.n], vec![[0.0]; self.n]);
                self.scatter_product(&self.values(which), &x, &mut formed);
                c.product(which, &c.inner.values(which), &x, &mut through);
                let bound = 1e-12 * self.norm_1(which) * x_max;
                formed
                    .iter()
                    .zip(&through)
                    .all(|(a, b)| (a[0] - b[0]).abs() <= bound)
            })
    }

    /// The stored entries a product reads through the model's coupling, beside the formed
    /// pattern's, when the products go through it ([`Congruent`]).
    pub fn through_coupling(&self) -> Option<(usize, usize)> {
        self.through.as_ref().map(|c| (c.entries(), self.nnz()))
    }

    /// The pencil whose pattern and values the real factorizations take: A₁ before the
    /// functionals became coordinates when the products go through the coupling (the same
    /// N, congruent to this one: the same inertia; its solves go through
    /// [`Self::solve_through`]), else this one.
    pub fn factored(&self) -> &Pencil {
        self.through.as_ref().map_or(self, |c| &c.inner)
    }

    /// The coupling a factor of [`Self::factored`] keeps for its solves.
    pub(crate) fn coupling(&self) -> Option<Arc<Congruent>> {
        self.through.clone()
    }

    /// Dimension N.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Column pointers of the lower-triangle union pattern.
    pub fn col_ptr(&self) -> &[usize] {
        &self.col_ptr
    }

    /// Row indices of the lower-triangle union pattern (sorted, diagonal first).
    pub fn row_idx(&self) -> &[usize] {
        &self.row_idx
    }

    /// Stored entries of the lower-triangle pattern.
    pub fn nnz(&self) -> usize {
        self.row_idx.len()
    }

    /// True when D = 0 and H = 0: A(iω) = K − ω²M is real.
    pub fn is_real(&self) -> bool {
        matches!(self.d, DampingValues::Zero) && self.eta == 0.0 && self.k4.is_none()
    }

    /// The damping's proportional part and remainder (docs/design.md §3.12).
    pub fn split(&self) -> &Split {
        &self.split
    }

    /// The proportional part A_p(iω) = (1 + iη + iωβ)K − (ω² − iωα − iγ)M when the rest
    /// of A(iω) is zero or of low rank: a shift of one real pencil (§3.10, §3.12). `None`
    /// when a remainder on many DoFs is left.
    pub fn proportional(&self) -> Option<&Proportional> {
        match &self.split {
            Split::Proportional(p) | Split::LowRank(p, _) => Some(p),
            Split::General(..) => None,
        }
    }

    /// One shifted real pencil answers every frequency (§3.10, §3.12): a proportional
    /// damping, or one with a low-rank remainder (dampers), which a correction of r × r per
    /// frequency answers from the same space (on the 77k-DoF crank with six dashpots, 2
    /// factorizations in 58 s against the linearized space's 2 in 74 s).
    pub fn shifted_space_applies(&self) -> bool {
        matches!(self.split, Split::Proportional(_) | Split::LowRank(..))
    }

    /// The linearized space answers every frequency (§3.13): a damping whose remainder
    /// after the proportional fit is not of low rank (material-wise viscous or structural
    /// damping).
    pub fn linearized_space_applies(&self) -> bool {
        matches!(self.split, Split::General(..))
    }

    /// The low-rank remainder of the damping, if there is one (§3.12).
    pub fn remainder(&self) -> Option<&Remainder> {
        match &self.split {
            Split::LowRank(_, r) => Some(r),
            _ => None,
        }
    }

    /// (α, β) of the body's own Rayleigh damping ((0, 0) without viscous damping), `None`
    /// for an explicit D.
    pub fn rayleigh(&self) -> Option<(f64, f64)> {
        match self.d {
            DampingValues::Zero => Some((0.0, 0.0)),
            DampingValues::Rayleigh { alpha, beta } => Some((alpha, beta)),
            DampingValues::Matrix(_) => None,
        }
    }

    /// η and whether the body has a structural damping matrix K₄ (H = ηK + K₄).
    pub fn structural(&self) -> (f64, bool) {
        (self.eta, self.k4.is_some())
    }

    /// True when D is an explicit matrix (not zero, not Rayleigh).
    pub fn has_damping_matrix(&self) -> bool {
        matches!(self.d, DampingValues::Matrix(_))
    }

    /// The values of M, K or D on the pattern (D computed for Rayleigh damping, zeros without
    /// damping; M, K and an explicit D borrowed).
    fn values(&self, which: Coefficient) -> Cow<'_, [f64]> {
        match (which, &self.d) {
            (Coefficient::Mass, _) => Cow::Borrowed(&self.m),
            (Coefficient::Stiffness, _) => Cow::Borrowed(&self.k),
            (Coefficient::Damping, DampingValues::Matrix(d)) => Cow::Borrowed(d),
            (Coefficient::Damping, DampingValues::Zero) => Cow::Owned(vec![0.0; self.nnz()]),
            (Coefficient::Damping, DampingValues::Rayleigh { alpha, beta }) => Cow::Owned(
                self.m
                    .iter()
                    .zip(&self.k)
                    .map(|(m, k)| alpha * m + beta * k)
                    .collect(),
            ),
            (Coefficient::Structural, _) => match &self.k4 {
                None => Cow::Owned(self.k.iter().map(|k| self.eta * k).collect()),
                Some(k4) => Cow::Owned(
                    self.k
                        .iter()
                        .zip(k4)
                        .map(|(k, h)| self.eta * k + h)
                        .collect(),
                ),
            },
        }
    }

    /// Y = X·x for X ∈ {M, K, D} (see [`Self::mul_to`]).
    pub fn mul(&self, which: Coefficient, x: MatRef<'_, f64>) -> Mat<f64> {
        let mut y = Mat::<f64>::zeros(self.n, x.ncols());
        self.mul_to(which, x, y.as_mut());
        y
    }

    /// y ← X·x for X ∈ {M, K, D} symmetric, stored by its lower triangle: each off-diagonal
    /// entry a_ij (i > j) adds a_ij x_j to y_i and a_ij x_i to y_j. Cost O(nnz · columns):
    /// the columns go [`BLOCK`] at a time through one pass over the matrix, the blocks on
    /// rayon's threads (the projection's M V and K V, the eigenpairs' residuals, the Krylov
    /// space's M W). Every column's sums are those of a product with that column alone.
    pub fn mul_to(&self, which: Coefficient, x: MatRef<'_, f64>, mut y: MatMut<'_, f64>) {
        use rayon::prelude::*;
        let vals = match &self.through {
            Some(c) => c.inner.values(which),
            None => self.values(which),
        };
        // one contiguous column (the eigensolver's M x, once per Krylov step): in place
        if x.ncols() == 1 {
            if let (Some(xc), Some(yc)) = (
                x.col(0).try_as_col_major(),
                y.as_mut().col_mut(0).try_as_col_major_mut(),
            ) {
                let (xs, ys) = (xc.as_slice(), yc.as_slice_mut());
                self.block_product::<1>(which, &vals, cast(xs), cast_mut(ys));
                return;
            }
        }
        // as many blocks at a time as rayon has threads, each into its own interleaved
        // buffers (the extra memory is 2·N·BLOCK per thread)
        let (n, ncols) = (self.n, x.ncols());
        let width = BLOCK * rayon::current_num_threads().max(1);
        for c0 in (0..ncols).step_by(width) {
            let starts: Vec<usize> = (c0..(c0 + width).min(ncols)).step_by(BLOCK).collect();
            let blocks: Vec<Vec<[f64; BLOCK]>> = starts
                .par_iter()
                .map(|&b0| {
                    let mut xb = vec![[0.0; BLOCK]; n];
                    for c in 0..BLOCK.min(ncols - b0) {
                        for (row, v) in xb.iter_mut().zip(x.col(b0 + c).iter()) {
                            row[c] = *v;
                        }
                    }
                    let mut yb = vec![[0.0; BLOCK]; n];
                    self.block_product::<BLOCK>(which, &vals, &xb, &mut yb);
                    yb
                })
                .collect();
            for (&b0, yb) in starts.iter().zip(&blocks) {
                for c in 0..BLOCK.min(ncols - b0) {
                    for (d, s) in y.as_mut().col_mut(b0 + c).iter_mut().zip(yb) {
                        *d = s[c];
                    }
                }
            }
        }
    }

    /// y ← X x for W interleaved columns (row i of the block is `x[i]`), X given by its lower
    /// values `vals`: row j of X is summed in ascending columns, as a product with both
    /// triangles would sum it. M is multiplied by its own rows ([`Rows`]; the same sums
    /// without the union pattern's zeros). Through the coupling, when there is one, `vals`
    /// are those of the pencil before its functionals became coordinates (A₁'s).
    fn block_product<const W: usize>(
        &self,
        which: Coefficient,
        vals: &[f64],
        x: &[[f64; W]],
        y: &mut [[f64; W]],
    ) {
        if let Some(c) = &self.through {
            c.product(which, vals, x, y);
            return;
        }
        if which == Coefficient::Mass {
            let rows = self
                .mass_rows
                .get_or_init(|| Rows::new(self.n, &self.col_ptr, &self.row_idx, &self.m));
            if let Some(rows) = rows {
                rows.product(x, y);
                return;
            }
        }
        self.scatter_product(vals, x, y);
    }

    /// y ← X x on the union pattern's lower triangle: each entry adds to two rows. Row j,
    /// whose columns left of j are summed when column j is reached, takes column j's entries
    /// in registers and is stored once (the same sums in the same order as adding each to
    /// y_j in memory).
    fn scatter_product<const W: usize>(&self, vals: &[f64], x: &[[f64; W]], y: &mut [[f64; W]]) {
        y.fill([0.0; W]);
        for j in 0..self.n {
            let xj = x[j];
            let range = self.col_ptr[j]..self.col_ptr[j + 1];
            let mut own = y[j];
            for (&i, &a) in self.row_idx[range.clone()].iter().zip(&vals[range]) {
                if i == j {
                    for c in 0..W {
                        own[c] += a * xj[c];
                    }
                } else {
                    let xi = x[i];
                    for c in 0..W {
                        y[i][c] += a * xj[c];
                        own[c] += a * xi[c];
                    }
                }
            }
            y[j] = own;
        }
    }

    /// The damping counterpart of a mass term `m` and a stiffness term `k` (the same
    /// operation applied to M and K, e.g. VᵀMV and VᵀKV, or MV and KV): 0 without damping,
    /// α m + β k for Rayleigh damping or an explicit D whose split is proportional (§3.12),
    /// α m + β k plus `apply` with E for a low-rank remainder E = UÊUᵀ (a product on its DoFs J
    /// alone), and `apply` with D's own product for any other D. `apply` performs the
    /// operation given X ↦ D X (or E X). The one place where the damping model is applied to
    /// products; the split's terms are D's to its rounding (§3.12).
    pub fn damping_term(
        &self,
        m: &Mat<f64>,
        k: &Mat<f64>,
        apply: impl FnOnce(&dyn Fn(MatRef<'_, f64>) -> Mat<f64>) -> Mat<f64>,
    ) -> Mat<f64> {
        let proportional = |alpha: f64, beta: f64| {
            Mat::from_fn(m.nrows(), m.ncols(), |i, j| {
                alpha * m[(i, j)] + beta * k[(i, j)]
            })
        };
        match (&self.d, &self.split) {
            (DampingValues::Zero, _) => Mat::zeros(m.nrows(), m.ncols()),
            (DampingValues::Rayleigh { alpha, beta }, _) => proportional(*alpha, *beta),
            (DampingValues::Matrix(_), Split::Proportional(p)) => proportional(p.alpha, p.beta),
            (DampingValues::Matrix(_), Split::LowRank(p, r)) => {
                let e = apply(&|x| r.viscous_product(x));
                proportional(p.alpha, p.beta) + e
            }
            (DampingValues::Matrix(_), Split::General(..)) => {
                apply(&|x| self.mul(Coefficient::Damping, x))
            }
        }
    }

    /// The structural counterpart of a stiffness term `k` (e.g. VᵀKV): `None` without
    /// structural damping, η k for a loss factor alone, `explicit()` (the operation applied to
    /// H through [`Self::mul`] with [`Coefficient::Structural`]) with a K₄.
    pub fn structural_term(
        &self,
        k: &Mat<f64>,
        explicit: impl FnOnce() -> Mat<f64>,
    ) -> Option<Mat<f64>> {
        match (&self.k4, self.eta) {
            (None, 0.0) => None,
            (None, eta) => Some(Mat::from_fn(k.nrows(), k.ncols(), |i, j| eta * k[(i, j)])),
            (Some(_), _) => Some(explicit()),
        }
    }

    /// The diagonal of M, K or D (0 where the pattern has no diagonal entry).
    pub fn diagonal(&self, which: Coefficient) -> Vec<f64> {
        let vals = self.values(which);
        (0..self.n)
            .map(|j| self.diagonal_position(j).map_or(0.0, |p| vals[p]))
            .collect()
    }

    /// ‖X‖₁ = max column sum of |x_ij| of the symmetric M, K or D (= ‖X‖_∞ ≥ ‖X‖₂).
    pub fn norm_1(&self, which: Coefficient) -> f64 {
        let vals = self.values(which);
        let mut sums = vec![0.0f64; self.n];
        for j in 0..self.n {
            for p in self.col_ptr[j]..self.col_ptr[j + 1] {
                let i = self.row_idx[p];
                sums[j] += vals[p].abs();
                if i != j {
                    sums[i] += vals[p].abs();
                }
            }
        }
        sums.into_iter().fold(0.0, f64::max)
    }

    /// ‖X‖_F of the symmetric M, K or D (off-diagonal entries counted twice).
    pub fn norm_fro(&self, which: Coefficient) -> f64 {
        let vals = self.values(which);
        let mut sum = 0.0;
        for j in 0..self.n {
            for p in self.col_ptr[j]..self.col_ptr[j + 1] {
                let w = if self.row_idx[p] == j { 1.0 } else { 2.0 };
                sum += w * vals[p] * vals[p];
            }
        }
        sum.sqrt()
    }

    /// The undamped pencil of the principal submatrices M_kk, K_kk on the kept DoFs `keep`
    /// (ascending; `pos[i]` the new index of DoF i, `usize::MAX` for a dropped one): the
    /// pattern restricted to the kept rows and columns, its values copied. The map is
    /// increasing, so rows stay sorted with the diagonal first. Memory O(nnz).
    pub fn restricted(&self, pos: &[usize], keep: &[usize]) -> Pencil {
        let mut col_ptr = Vec::with_capacity(keep.len() + 1);
        col_ptr.push(0);
        let (mut row_idx, mut m, mut k) = (Vec::new(), Vec::new(), Vec::new());
        for &j in keep {
            for p in self.col_ptr[j]..self.col_ptr[j + 1] {
                let r = pos[self.row_idx[p]];
                if r != usize::MAX {
                    row_idx.push(r);
                    m.push(self.m[p]);
                    k.push(self.k[p]);
                }
            }
            col_ptr.push(row_idx.len());
        }
        Pencil {
            n: keep.len(),
            col_ptr,
            row_idx,
            m,
            k,
            d: DampingValues::Zero,
            eta: 0.0,
            k4: None,
            split: Split::Proportional(Proportional::default()),
            mass_rows: OnceLock::new(),
            through: None,
        }
    }

    /// The rows `keep` (new index `pos[i]`, `usize::MAX` for a dropped row) of the columns
    /// `cols` (in that order) of the symmetric M, K or D, in full storage: e.g. K_ii, M_ii and
    /// K_ib of a Craig–Bampton partition. `pos` must be increasing on the kept rows (rows stay
    /// sorted). Memory: one full-storage index map of the pattern while it runs.
    pub fn submatrix(&self, which: Coefficient, pos: &[usize], cols: &[usize]) -> Csc {
        let vals = self.values(which);
        let (full_ptr, full_row, src) = mirror_lower(self.n, &self.col_ptr, &self.row_idx);
        let n_rows = pos.iter().filter(|&&p| p != usize::MAX).count();
        let mut col_ptr = Vec::with_capacity(cols.len() + 1);
        col_ptr.push(0);
        let (mut row_idx, mut val) = (Vec::new(), Vec::new());
        for &j in cols {
            for q in full_ptr[j]..full_ptr[j + 1] {
                let r = pos[full_row[q]];
                if r != usize::MAX {
                    row_idx.push(r);
                    val.push(vals[src[q]]);
                }
            }
            col_ptr.push(row_idx.len());
        }
        from_parts(n_rows, cols.len(), col_ptr, row_idx, val)
    }

    /// max_i |K_ii| (the first entry of each column is its diagonal).
    pub fn stiffness_diagonal_max(&self) -> f64 {
        (0..self.n)
            .filter_map(|j| self.diagonal_position(j))
            .map(|p| self.k[p].abs())
            .fold(0.0, f64::max)
    }

    /// The position of entry (j, j) in the pattern: the first of column j, if stored.
    fn diagonal_position(&self, j: usize) -> Option<usize> {
        let p = self.col_ptr[j];
        (p < self.col_ptr[j + 1] && self.row_idx[p] == j).then_some(p)
    }

    /// re ← K − ω²M (the real part of A(iω)).
    pub fn fill_real(&self, omega: f64, re: &mut [f64]) {
        self.fill_shifted(omega * omega, re);
    }

    /// out ← K − σM (σ < 0 gives an SPD matrix for a free body: the eigensolver's shift).
    pub fn fill_shifted(&self, sigma: f64, out: &mut [f64]) {
        for ((r, &k), &m) in out.iter_mut().zip(&self.k).zip(&self.m) {
            *r = k - sigma * m;
        }
    }

    /// out ← K + sD + s²M, A(s) at a real s without structural damping, its real part with
    /// it (the linearized space's K₀ at s₀ > 0: positive definite when M is and K, D are
    /// semi-definite; §3.13).
    pub fn fill_quadratic(&self, s: f64, out: &mut [f64]) {
        let d = self.values(Coefficient::Damping);
        for (((r, &k), &m), &d) in out.iter_mut().zip(&self.k).zip(&self.m).zip(d.iter()) {
            *r = k + s * d + (s * s) * m;
        }
    }

    /// out ← H = ηK + K₄, the structural damping: the imaginary part of A(s) at a real s.
    pub fn fill_structural(&self, out: &mut [f64]) {
        out.copy_from_slice(&self.values(Coefficient::Structural));
    }

    /// re ← K − ω²M, im ← ωD + H: the values of A(iω) ([`Self::value`] of every entry).
    pub fn fill_complex(&self, omega: f64, re: &mut [f64], im: &mut [f64]) {
        for (p, (r, i)) in re.iter_mut().zip(im.iter_mut()).enumerate() {
            let v = self.value(omega, p);
            (*r, *i) = (v.re, v.im);
        }
    }

    /// Entry `p` of A(iω) on the lower pattern: K − ω²M (as [`Self::fill_real`]) + i(ωD + H),
    /// with ωD = (ωα)M + (ωβ)K for Rayleigh damping and H = ηK + K₄. The factorizations that read the values once
    /// compute them here instead of keeping a copy per frequency.
    #[inline]
    pub fn value(&self, omega: f64, p: usize) -> c64 {
        let (k, m) = (self.k[p], self.m[p]);
        let im = match &self.d {
            DampingValues::Zero => 0.0,
            DampingValues::Rayleigh { alpha, beta } => (omega * alpha) * m + (omega * beta) * k,
            DampingValues::Matrix(d) => omega * d[p],
        };
        let h = self.eta * k + self.k4.as_ref().map_or(0.0, |k4| k4[p]);
        c64::new(k - (omega * omega) * m, im + h)
    }

    /// y ← A(iω) x for the symmetric A stored by its lower triangle (through the coupling,
    /// Tᵀ(A₁(iω)(T x)) with the factored pencil's A₁, when the products go through it).
    pub fn apply(&self, omega: f64, x: MatRef<'_, c64>, mut y: MatMut<'_, c64>) {
        if let Some(c) = &self.through {
            let mut tx = x.to_owned();
            each_column(&c.t_rows, tx.as_mut());
            c.inner.apply(omega, tx.as_ref(), y.as_mut());
            each_column(&c.t, y);
            return;
        }
        y.fill(c64::new(0.0, 0.0));
        for c in 0..x.ncols() {
            for j in 0..self.n {
                for p in self.col_ptr[j]..self.col_ptr[j + 1] {
                    let i = self.row_idx[p];
                    let a = self.value(omega, p);
                    y[(i, c)] += a * x[(j, c)];
                    if i != j {
                        y[(j, c)] += a * x[(i, c)];
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fe::{bar_model, BoxSpec};
    use proptest::prelude::*;

    /// A free 1×1×6 bar (N = 84) with damping `d`: Rayleigh, or an explicit D = a·M + b·K
    /// with its own values (mass-like diagonal shift so that D differs from both).
    fn model(explicit: bool, a: f64, b: f64) -> Model {
        if explicit {
            let diagonal = |i: usize, j: usize| if i == j { 0.5 } else { 0.0 };
            return explicit_model([1, 1, 6], a, b, diagonal);
        }
        let mut m = bar([1, 1, 6]);
        m.damping = Damping::Rayleigh { alpha: a, beta: b };
        m
    }

    fn bar(elements: [usize; 3]) -> Model {
        let spec = BoxSpec {
            elements,
            ..BoxSpec::paper_bar()
        };
        bar_model(&spec).unwrap()
    }

    /// The bar with `elements` and an explicit D = a·M + b·K + E on K's pattern, E's entries
    /// `extra(i, j)`.
    fn explicit_model(
        elements: [usize; 3],
        a: f64,
        b: f64,
        extra: impl Fn(usize, usize) -> f64,
    ) -> Model {
        let mut m = bar(elements);
        let mut d = m.stiffness.clone();
        let (mass, stiff) = (m.mass.to_dense(), m.stiffness.to_dense());
        for j in 0..d.ncols() {
            let rows = d.symbolic().row_idx_of_col_raw(j).to_vec();
            for (v, i) in d.val_of_col_mut(j).iter_mut().zip(rows) {
                *v = a * mass[(i, j)] + b * stiff[(i, j)] + extra(i, j);
            }
        }
        m.damping = Damping::Matrix(d);
        m
    }

    /// The damping term of the operation X ↦ X x is D x to rounding whichever way the split
    /// takes it: α M x + β K x for a proportional D, plus E x on J for a low-rank remainder,
    /// D's own product otherwise.
    #[test]
    fn the_damping_term_is_the_product_with_d_for_every_split() {
        let (a, b) = (3.0, 2e-5);
        // a dashpot of 40 N·s/m between DoFs 0 and 3 (one element couples them)
        let dashpot = |i: usize, j: usize| match (i, j) {
            (0, 0) | (3, 3) => 40.0,
            (0, 3) | (3, 0) => -40.0,
            _ => 0.0,
        };
        type Extra<'a> = &'a dyn Fn(usize, usize) -> f64;
        let cases: [(Extra, &str); 3] = [
            (&|_, _| 0.0, "proportional"),
            (&dashpot, "low rank"),
            (&|i, j| if i == j { 0.5 } else { 0.0 }, "general"),
        ];
        for (extra, kind) in cases {
            let model = explicit_model([2, 2, 10], a, b, extra);
            let pencil = Pencil::new(&model);
            let found = match pencil.split() {
                Split::Proportional(_) => "proportional",
                Split::LowRank(..) => "low rank",
                Split::General(..) => "general",
            };
            assert_eq!(found, kind);
            let n = model.n();
            let x = Mat::from_fn(n, 3, |i, j| ((i * 7 + j * 13) % 17) as f64 - 8.0);
            let (mx, kx) = (
                pencil.mul(Coefficient::Mass, x.as_ref()),
                pencil.mul(Coefficient::Stiffness, x.as_ref()),
            );
            let term = pencil.damping_term(&mx, &kx, |d| d(x.as_ref()));
            let want = dense(&model, Coefficient::Damping) * &x;
            assert!(rel(&term, &want) <= 1e-13, "{kind}: {}", rel(&term, &want));
        }
    }

    fn dense(model: &Model, which: Coefficient) -> Mat<f64> {
        let (mass, stiff) = (model.mass.to_dense(), model.stiffness.to_dense());
        match (which, &model.damping) {
            (Coefficient::Mass, _) => mass,
            (Coefficient::Stiffness, _) => stiff,
            (Coefficient::Damping, Damping::Matrix(d)) => d.to_dense(),
            (Coefficient::Damping, Damping::Rayleigh { alpha, beta }) => {
                Mat::from_fn(mass.nrows(), mass.ncols(), |i, j| {
                    alpha * mass[(i, j)] + beta * stiff[(i, j)]
                })
            }
            (Coefficient::Damping, Damping::None) => Mat::zeros(mass.nrows(), mass.ncols()),
            (Coefficient::Structural, _) => {
                let eta = model.structural.eta;
                let k4 = model.structural.matrix.as_ref().map(|k4| k4.to_dense());
                Mat::from_fn(mass.nrows(), mass.ncols(), |i, j| {
                    eta * stiff[(i, j)] + k4.as_ref().map_or(0.0, |k4| k4[(i, j)])
                })
            }
        }
    }

    /// ‖a − b‖ / ‖b‖, and ‖a − b‖ itself for an empty or zero b.
    fn rel(a: &Mat<f64>, b: &Mat<f64>) -> f64 {
        let diff = (a - b).norm_l2();
        if b.norm_l2() > 0.0 {
            diff / b.norm_l2()
        } else {
            diff
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        /// The products, norms, diagonal and submatrices read from the lower triangles equal
        /// those of the dense full matrices (M, K, Rayleigh and explicit D).
        #[test]
        fn lower_triangle_products_equal_dense_ones(
            explicit in any::<bool>(),
            a in 0.0f64..10.0,
            b in 1e-6f64..1e-3,
            cols in 0usize..4,
            seed in 0u64..1000,
        ) {
            let model = model(explicit, a, b);
            let pencil = Pencil::new(&model);
            let n = model.n();
            let x = Mat::from_fn(n, cols, |i, j| {
                (((i * 7 + j * 13) as u64 + seed) % 17) as f64 - 8.0
            });
            // M by its own rows: the union pattern's sums without its zeros, to the bit
            let xs: Vec<f64> = (0..n).map(|i| ((i as u64 * 5 + seed) % 11) as f64 - 5.0).collect();
            let (mut by_rows, mut scattered) = (vec![0.0; n], vec![0.0; n]);
            pencil.block_product(Coefficient::Mass, &pencil.m, cast(&xs), cast_mut(&mut by_rows));
            pencil.scatter_product(&pencil.m, cast(&xs), cast_mut(&mut scattered));
            prop_assert_eq!(by_rows, scattered);
            // the rows skip the union pattern's zeros of M (its components do not couple)
            let full = 2 * pencil.nnz() - n;
            prop_assert!(pencil.mass_rows.get().unwrap().as_ref().unwrap().val.len() < full);
            for which in [Coefficient::Mass, Coefficient::Stiffness, Coefficient::Damping] {
                let want = dense(&model, which);
                let y = pencil.mul(which, x.as_ref());
                prop_assert!(rel(&y, &(&want * &x)) <= 1e-14);
                // strided columns (row-major storage) go through copies: the same numbers
                let xt = x.transpose().to_owned();
                let mut yt = Mat::<f64>::zeros(cols, n);
                pencil.mul_to(which, xt.transpose(), yt.as_mut().transpose_mut());
                prop_assert!(yt.transpose() == y);
                let sums = (0..n).map(|j| (0..n).map(|i| want[(i, j)].abs()).sum::<f64>());
                let norm_1 = sums.fold(0.0, f64::max);
                prop_assert!((pencil.norm_1(which) - norm_1).abs() <= 1e-14 * norm_1);
                let fro = want.norm_l2();
                prop_assert!((pencil.norm_fro(which) - fro).abs() <= 1e-14 * fro);
                let diag = pencil.diagonal(which);
                prop_assert!((0..n).all(|i| diag[i] == want[(i, i)]));
                // drop every third DoF from the rows; columns in a shuffled order
                let mut pos = vec![usize::MAX; n];
                let mut k = 0;
                for (i, p) in pos.iter_mut().enumerate() {
                    if (i as u64 + seed) % 3 != 0 {
                        *p = k;
                        k += 1;
                    }
                }
                let cols: Vec<usize> = (0..n).rev().step_by(2).collect();
                let sub = pencil.submatrix(which, &pos, &cols).to_dense();
                for (c, &j) in cols.iter().enumerate() {
                    for i in (0..n).filter(|&i| pos[i] != usize::MAX) {
                        prop_assert_eq!(sub[(pos[i], c)], want[(i, j)]);
                    }
                }
            }
            if !explicit {
                let (m, k) = (Mat::from_fn(2, 2, |i, j| (i + j) as f64), Mat::identity(2, 2));
                let term = pencil.damping_term(&m, &k, |_| Mat::full(2, 2, 7.0));
                prop_assert_eq!(term, &m * a + &k * b);
            }
        }
    }
}
