//! The proportional part of a body's damping and what is left of it (docs/design.md §3.12).
//!
//! With viscous damping D and structural damping H = ηK + K₄ (§3.1),
//!
//! ```text
//! A(iω) = K + iH − ω²M + iωD
//!       = (1 + iη' + iωβ) K − (ω² − iωα − iγ) M  +  iωE + iF,
//! ```
//!
//! where D ≈ αM + βK and K₄ ≈ γM + η₄K are fitted by least squares on the pencil's pattern
//! (η' = η + η₄) and E = D − αM − βK, F = K₄ − γM − η₄K are the remainders. The proportional
//! part is a shift of the one real pencil K − μM, μ = (ω² − iωα − iγ)/(1 + iη' + iωβ), which
//! one shifted Krylov space answers at every frequency (§3.10). [`split`] sorts a damping
//! into:
//! - [`Split::Proportional`]: the remainders vanish to rounding (every entry within
//!   [`ROUNDING`] of the entry's own scale): Rayleigh damping, a loss factor, or a damping
//!   file that is αM + βK as an FE code exports it;
//! - [`Split::LowRank`]: the remainders live on few DoFs J (dashpots, bushings, a damped
//!   joint): E = P_J W Ê Wᵀ P_Jᵀ and F = P_J W F̂ Wᵀ P_Jᵀ with W (|J| × r) an orthonormal basis
//!   of their ranges, r ≤ [`MAX_RANK`]. With U = P_J W and A_p the proportional part,
//!   Sherman–Morrison–Woodbury gives the exact response from the proportional one:
//!
//!   ```text
//!   A⁻¹b = Z_b − Z_u w,   w = (I + G Uᵀ Z_u)⁻¹ G Uᵀ Z_b,   Z_b = A_p⁻¹ b,  Z_u = A_p⁻¹ U,
//!   G(ω) = iωÊ + iF̂ (r × r),
//!   ```
//!
//!   so the space answers U's r columns beside the loads and an r × r solve per frequency
//!   does the rest ([`Remainder::correction`]), with or without structural damping;
//! - [`Split::General`]: a remainder on many DoFs (material-wise damping): the linearized
//!   space answers it (§3.13, [`crate::linearized_space`]), with a complex factor when there
//!   is structural damping.
//!
//! The fit is robust to the remainder's entries: it is refitted on the entries its residual
//! leaves within a tightening threshold ([`THRESHOLDS`]), so a few dashpot entries do not
//! bend α and β away from the proportional part of the rest.

use faer::linalg::solvers::Solve;
use faer::{c64, Mat, MatRef};

/// An entry is proportional when |x − a m − b k| ≤ `ROUNDING` (|x| + |a m| + |b k|): what a
/// matrix computed as αM + βK and written with 17 significant digits meets.
pub const ROUNDING: f64 = 1e-12;

/// The thresholds of the robust fit, loosest first: after each, the fit is redone on the
/// entries within it. The last is repeated: a remainder entry a little above rounding that
/// the previous fit kept bends it by about that much, and the refit without it is exact.
const THRESHOLDS: [f64; 7] = [1e-2, 1e-5, 1e-8, 1e-10, ROUNDING, ROUNDING, ROUNDING];

/// The entries [`sampled_fit`] fits first.
const SAMPLE: usize = 1 << 16;

/// A singular value of the remainder [E F] on J below this fraction of the largest is
/// rounding (of the fit or of the file's digits), not damping.
const RANK_RTOL: f64 = 1e-10;

/// The most DoFs a low-rank remainder may touch (E_JJ is held dense).
pub const MAX_DOFS: usize = 600;

/// The highest rank of a low-rank remainder (its U adds as many columns to the space's load).
pub const MAX_RANK: usize = 96;

/// The proportional part: A_p(iω) = (1 + iη + iωβ) K − (ω² − iωα − iγ) M.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Proportional {
    /// Viscous, mass-proportional α (1/s).
    pub alpha: f64,
    /// Viscous, stiffness-proportional β (s).
    pub beta: f64,
    /// Structural, mass-proportional γ.
    pub gamma: f64,
    /// Structural loss factor η on K.
    pub eta: f64,
}

impl Proportional {
    /// (c_k, c_m) with A_p(iω) = c_k K − c_m M.
    pub fn coefficients(&self, omega: f64) -> (c64, c64) {
        (
            c64::new(1.0, self.eta + omega * self.beta),
            c64::new(omega * omega, -(omega * self.alpha + self.gamma)),
        )
    }
}

/// The remainder of a low-rank split (module doc): iωE + iF = U G(ω) Uᵀ, U = P_J W.
#[derive(Clone, Debug)]
pub struct Remainder {
    /// J, ascending.
    pub dofs: Vec<usize>,
    /// W (|J| × r), orthonormal.
    pub basis: Mat<f64>,
    /// Ê = WᵀE_JJW (r × r).
    pub viscous: Mat<f64>,
    /// F̂ = WᵀF_JJW (r × r).
    pub structural: Mat<f64>,
}

impl Remainder {
    /// The rank r.
    pub fn rank(&self) -> usize {
        self.basis.ncols()
    }

    /// U = P_J W (N × r), dense.
    pub fn loads(&self, n: usize) -> Mat<f64> {
        let mut u = Mat::zeros(n, self.rank());
        for (i, &d) in self.dofs.iter().enumerate() {
            for c in 0..self.rank() {
                u[(d, c)] = self.basis[(i, c)];
            }
        }
        u
    }

    /// E = U Ê Uᵀ and F = U F̂ Uᵀ as sparse N × N matrices (full storage, on J × J); `None`
    /// for a part that is zero.
    pub fn matrices(&self, n: usize) -> (Option<crate::sparse::Csc>, Option<crate::sparse::Csc>) {
        let full = |core: &Mat<f64>| {
            if core.norm_l2() == 0.0 {
                return None;
            }
            let x = &self.basis * core * self.basis.transpose();
            let mut t = crate::sparse::Triplets::default();
            for (b, &j) in self.dofs.iter().enumerate() {
                for (a, &i) in self.dofs.iter().enumerate() {
                    t.push(i, j, 0.5 * (x[(a, b)] + x[(b, a)]));
                }
            }
            Some(t.into_csc(n, false))
        };
        (full(&self.viscous), full(&self.structural))
    }

    /// E X = U Ê Uᵀ X (N × c): zero but at J.
    pub fn viscous_product(&self, x: MatRef<'_, f64>) -> Mat<f64> {
        let x_j = Mat::<f64>::from_fn(self.dofs.len(), x.ncols(), |i, c| x[(self.dofs[i], c)]);
        let e_j = &self.basis * (&self.viscous * (self.basis.transpose() * &x_j));
        let mut y = Mat::zeros(x.nrows(), x.ncols());
        for (i, &d) in self.dofs.iter().enumerate() {
            for c in 0..x.ncols() {
                y[(d, c)] = e_j[(i, c)];
            }
        }
        y
    }

    /// Uᵀ X for X given by its rows at J (|J| × c).
    pub fn project(&self, x_j: MatRef<'_, c64>) -> Mat<c64> {
        let w = &self.basis;
        Mat::from_fn(self.rank(), x_j.ncols(), |a, c| {
            (0..self.dofs.len()).map(|i| x_j[(i, c)] * w[(i, a)]).sum()
        })
    }

    /// w = (I + G Uᵀ Z_u)⁻¹ G Uᵀ Z_b (r × p) at ω, from Uᵀ Z_b (r × p) and Uᵀ Z_u (r × r)
    /// ([`Self::project`]); the response is then Z_b − Z_u w.
    pub fn correction(&self, omega: f64, uzb: MatRef<'_, c64>, uzu: MatRef<'_, c64>) -> Mat<c64> {
        let r = self.rank();
        let g = Mat::<c64>::from_fn(r, r, |i, j| {
            c64::new(0.0, omega * self.viscous[(i, j)] + self.structural[(i, j)])
        });
        let mut lhs = &g * uzu;
        for i in 0..r {
            lhs[(i, i)] += c64::new(1.0, 0.0);
        }
        let rhs = &g * uzb;
        lhs.partial_piv_lu().solve(&rhs)
    }

    /// max over the rigid modes' rows at J of ‖Ê Wᵀ V0_J‖ and ‖F̂ Wᵀ V0_J‖, relative to
    /// ‖Ê‖‖V0_J‖ (resp. F̂): 0 to rounding when the remainder does not load rigid motion (a
    /// damper inside the body), which the elastic response of a free body needs.
    pub fn rigid_load(&self, v0: MatRef<'_, f64>) -> f64 {
        let v0j = Mat::<f64>::from_fn(self.dofs.len(), v0.ncols(), |i, c| v0[(self.dofs[i], c)]);
        let wv = self.basis.transpose() * &v0j;
        let norm = v0j.norm_l2();
        [&self.viscous, &self.structural]
            .iter()
            .filter(|x| x.norm_l2() > 0.0)
            .map(|x| (*x * &wv).norm_l2() / (x.norm_l2() * norm).max(f64::MIN_POSITIVE))
            .fold(0.0, f64::max)
    }
}

/// A body's damping sorted by what answers it (module doc).
#[derive(Clone, Debug)]
pub enum Split {
    /// Proportional to rounding.
    Proportional(Proportional),
    /// Proportional but for a remainder on few DoFs.
    LowRank(Proportional, Remainder),
    /// A remainder on many DoFs, or a fit that leaves half the entries out; the proportional
    /// part found and the number of DoFs the remainder touches.
    General(Proportional, usize),
}

impl Split {
    /// The proportional part.
    pub fn proportional(&self) -> &Proportional {
        match self {
            Split::Proportional(p) | Split::LowRank(p, _) | Split::General(p, _) => p,
        }
    }
}

/// The pattern of a symmetric matrix's lower triangle (CSC, sorted rows).
#[derive(Clone, Copy)]
pub struct Pattern<'a> {
    /// Column pointers (N + 1).
    pub col_ptr: &'a [usize],
    /// Row indices.
    pub row_idx: &'a [usize],
}

/// The viscous damping as a body holds it.
#[derive(Clone, Copy, Debug)]
pub enum Viscous<'a> {
    /// D = αM + βK, exact as given.
    Rayleigh(f64, f64),
    /// D's values on the pattern.
    Matrix(&'a [f64]),
}

/// Splits the damping with viscous part `viscous`, loss factor `eta` and structural values
/// `k4` on `pattern`, whose M and K values are `m` and `k` (module doc).
pub fn split(
    pattern: Pattern<'_>,
    m: &[f64],
    k: &[f64],
    viscous: Viscous<'_>,
    eta: f64,
    k4: Option<&[f64]>,
) -> Split {
    let (d, given) = match viscous {
        Viscous::Rayleigh(a, b) => (
            None,
            Fit {
                a,
                b,
                outliers: Vec::new(),
            },
        ),
        Viscous::Matrix(d) => (Some(d), Fit::default()),
    };
    let viscous = d.map_or(Ok(given), |x| fit(m, k, x));
    let structural = k4.map_or(Ok(Fit::default()), |x| fit(m, k, x));
    let (viscous, structural) = match (viscous, structural) {
        (Ok(v), Ok(s)) => (v, s),
        (v, s) => {
            let (v, s) = (v.unwrap_or_else(|f| f), s.unwrap_or_else(|f| f));
            return Split::General(proportional(&v, &s, eta), usize::MAX);
        }
    };
    let p = proportional(&viscous, &structural, eta);
    if viscous.outliers.is_empty() && structural.outliers.is_empty() {
        return Split::Proportional(p);
    }
    // J: the rows and columns of the entries the fits leave out
    let n = pattern.col_ptr.len() - 1;
    let mut column = vec![0usize; pattern.row_idx.len()];
    for j in 0..n {
        column[pattern.col_ptr[j]..pattern.col_ptr[j + 1]].fill(j);
    }
    let mut dofs: Vec<usize> = viscous
        .outliers
        .iter()
        .chain(&structural.outliers)
        .flat_map(|&q| [pattern.row_idx[q], column[q]])
        .collect();
    dofs.sort_unstable();
    dofs.dedup();
    if dofs.len() > MAX_DOFS {
        return Split::General(p, dofs.len());
    }
    let mut pos = vec![usize::MAX; n];
    for (i, &dof) in dofs.iter().enumerate() {
        pos[dof] = i;
    }
    let block = |x: Option<&[f64]>, f: &Fit| {
        let s = dofs.len();
        let mut e = Mat::<f64>::zeros(s, s);
        if let Some(x) = x {
            for &j in &dofs {
                for q in pattern.col_ptr[j]..pattern.col_ptr[j + 1] {
                    let i = pos[pattern.row_idx[q]];
                    if i != usize::MAX {
                        let r = x[q] - f.a * m[q] - f.b * k[q];
                        e[(i, pos[j])] = r;
                        e[(pos[j], i)] = r;
                    }
                }
            }
        }
        e
    };
    let (e, f) = (block(d, &viscous), block(k4, &structural));
    // W: the range of [E F], its left singular vectors above rounding
    let s = dofs.len();
    let both = Mat::<f64>::from_fn(
        s,
        2 * s,
        |i, j| if j < s { e[(i, j)] } else { f[(i, j - s)] },
    );
    let Ok(svd) = both.thin_svd() else {
        return Split::General(p, s);
    };
    let sigma = svd.S().column_vector();
    let top = sigma.iter().copied().fold(0.0, f64::max);
    let keep: Vec<usize> = (0..sigma.nrows())
        .filter(|&i| sigma[i] > RANK_RTOL * top)
        .collect();
    if keep.len() > MAX_RANK {
        return Split::General(p, s);
    }
    let vectors = svd.U();
    let basis = Mat::<f64>::from_fn(dofs.len(), keep.len(), |i, c| vectors[(i, keep[c])]);
    let core = |x: &Mat<f64>| {
        let c = basis.transpose() * x * &basis;
        Mat::from_fn(c.nrows(), c.ncols(), |i, j| 0.5 * (c[(i, j)] + c[(j, i)]))
    };
    let (viscous, structural) = (core(&e), core(&f));
    Split::LowRank(
        p,
        Remainder {
            dofs,
            basis,
            viscous,
            structural,
        },
    )
}

/// The proportional part of two fits and a uniform loss factor.
fn proportional(viscous: &Fit, structural: &Fit, eta: f64) -> Proportional {
    Proportional {
        alpha: viscous.a,
        beta: viscous.b,
        gamma: structural.a,
        eta: eta + structural.b,
    }
}

/// x ≈ a m + b k and the pattern positions left out at [`ROUNDING`].
#[derive(Clone, Debug, Default)]
struct Fit {
    a: f64,
    b: f64,
    outliers: Vec<usize>,
}

/// The robust fit of x ≈ a m + b k (module doc), or a = b = 0 when that leaves fewer entries
/// out (a matrix that is zero but for a few dampers: its nonzero entries alone would fit a
/// spurious b). `Err` with the last fit when fewer than half of the entries stay within the
/// thresholds (no proportional part to speak of).
fn fit(m: &[f64], k: &[f64], x: &[f64]) -> Result<Fit, Fit> {
    let fitted = sampled_fit(m, k, x).map_or_else(|| robust_fit(m, k, x), Ok);
    let nonzero = x.iter().filter(|&&v| v != 0.0).count();
    match fitted {
        Ok(f) if f.outliers.len() <= nonzero => Ok(f),
        Err(f) if 2 * nonzero >= x.len() => Err(f),
        _ => Ok(Fit {
            a: 0.0,
            b: 0.0,
            outliers: (0..x.len()).filter(|&q| x[q] != 0.0).collect(),
        }),
    }
}

/// The robust fit of every `stride`-th entry (about [`SAMPLE`] of them), kept when it leaves
/// at most 1 % of all the entries out at [`ROUNDING`]: a proportional damping, with or without
/// dampers, then costs one pass over the pattern instead of a refit per threshold (on the
/// 77 229-DoF coupled crank, 14 M entries). The fit is checked on every entry, so what it
/// keeps meets what the full fit would: the entries it does not leave out are proportional
/// to rounding. `None` for a small pattern, or when the sample's fit leaves more out (a
/// remainder on many entries): then the full fit decides.
fn sampled_fit(m: &[f64], k: &[f64], x: &[f64]) -> Option<Fit> {
    let stride = x.len() / SAMPLE;
    if stride < 2 {
        return None;
    }
    let pick = |v: &[f64]| v.iter().step_by(stride).copied().collect::<Vec<f64>>();
    let f = robust_fit(&pick(m), &pick(k), &pick(x)).ok()?;
    let outliers: Vec<usize> = (0..x.len())
        .filter(|&q| !within(f.a, f.b, m[q], k[q], x[q], ROUNDING))
        .collect();
    (100 * outliers.len() <= x.len()).then_some(Fit { outliers, ..f })
}

/// |x − a m − b k| ≤ t (|x| + |a m| + |b k|): the entry is a m + b k to the relative
/// threshold t.
fn within(a: f64, b: f64, m: f64, k: f64, x: f64, t: f64) -> bool {
    let (am, bk) = (a * m, b * k);
    (x - am - bk).abs() <= t * (x.abs() + am.abs() + bk.abs())
}

/// [`fit`]'s robust least squares (module doc).
fn robust_fit(m: &[f64], k: &[f64], x: &[f64]) -> Result<Fit, Fit> {
    let total = x.len();
    let mut inliers: Vec<usize> = (0..total).collect();
    let mut fitted = Fit::default();
    // each entry weighted by its scale (|x| + |a m| + |b k| of the previous fit, |x| first):
    // the fit of the entries' relative residuals, which determines a coefficient whose part is
    // small against the other's in most entries (α beside βK)
    let mut weight: Vec<f64> = x.iter().map(|v| inverse(v.abs())).collect();
    // the weighted columns, filled anew by every refit: kept, not allocated each time (on the
    // 77 229-DoF coupled crank a refit's columns are 0.45 GB of fresh pages)
    let mut columns = Columns::default();
    for t in THRESHOLDS {
        (fitted.a, fitted.b) = least_squares(m, k, x, &inliers, &weight, &mut columns);
        // a coefficient whose whole contribution is rounding is 0 (D = βK gives α = 0)
        let xmax = x.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        let am = m.iter().fold(0.0f64, |s, v| s.max((fitted.a * v).abs()));
        let bk = k.iter().fold(0.0f64, |s, v| s.max((fitted.b * v).abs()));
        if am <= ROUNDING * xmax && fitted.a != 0.0 {
            fitted.a = 0.0;
            fitted.b = single(k, x, &inliers, &weight);
        } else if bk <= ROUNDING * xmax && fitted.b != 0.0 {
            fitted.b = 0.0;
            fitted.a = single(m, x, &inliers, &weight);
        }
        for (q, w) in weight.iter_mut().enumerate() {
            *w = inverse(x[q].abs() + (fitted.a * m[q]).abs() + (fitted.b * k[q]).abs());
        }
        let within = |q: usize| within(fitted.a, fitted.b, m[q], k[q], x[q], t);
        inliers.clear();
        inliers.extend((0..total).filter(|&q| within(q)));
        if 2 * inliers.len() < total {
            fitted.outliers = (0..total).filter(|&q| !within(q)).collect();
            return Err(fitted);
        }
    }
    let within: Vec<bool> = {
        let mut w = vec![false; total];
        inliers.iter().for_each(|&q| w[q] = true);
        w
    };
    fitted.outliers = (0..total).filter(|&q| !within[q]).collect();
    Ok(fitted)
}

/// 1/s, or 0 for s = 0 (an entry without scale does not count).
fn inverse(s: f64) -> f64 {
    if s > 0.0 {
        1.0 / s
    } else {
        0.0
    }
}

/// The least-squares (a, b) of w ∘ x ≈ w ∘ (a m + b k) over the entries `at`, by a QR of the
/// two weighted columns (Gram–Schmidt, twice): m and k are nearly parallel on entries where
/// one dominates, and normal equations would square that condition. A column of zeros gets 0;
/// k parallel to m to rounding takes all of it.
fn least_squares(
    m: &[f64],
    k: &[f64],
    x: &[f64],
    at: &[usize],
    w: &[f64],
    columns: &mut Columns,
) -> (f64, f64) {
    let Columns { u: q1, v, y } = columns;
    for (c, from) in [(&mut *q1, m), (&mut *v, k), (&mut *y, x)] {
        c.clear();
        c.extend(at.iter().map(|&q| w[q] * from[q]));
    }
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(a, b)| a * b).sum::<f64>();
    let r11 = dot(q1, q1).sqrt();
    let vnorm = dot(v, v).sqrt();
    if !(r11 > 0.0) || !(vnorm > 0.0) {
        return (single(m, x, at, w), single(k, x, at, w));
    }
    q1.iter_mut().for_each(|u| *u /= r11);
    let (q1, v, y) = (&*q1, v, &*y);
    let mut r12 = 0.0;
    for _ in 0..2 {
        let c = dot(q1, v);
        r12 += c;
        v.iter_mut().zip(q1.iter()).for_each(|(v, q)| *v -= c * q);
    }
    let r22 = dot(v, v).sqrt();
    if !(r22 > 1e-14 * vnorm) {
        return (0.0, single(k, x, at, w));
    }
    let b = dot(v, y) / (r22 * r22);
    ((dot(q1, y) - r12 * b) / r11, b)
}

/// [`least_squares`]'s weighted columns w ∘ m, w ∘ k and w ∘ x over the entries fitted.
#[derive(Default)]
struct Columns {
    u: Vec<f64>,
    v: Vec<f64>,
    y: Vec<f64>,
}

/// The least-squares b of w ∘ x ≈ b w ∘ y over the entries `at`.
fn single(y: &[f64], x: &[f64], at: &[usize], w: &[f64]) -> f64 {
    let (yy, yx) = at.iter().fold((0.0, 0.0), |(a, b), &q| {
        let w2 = w[q] * w[q];
        (a + w2 * y[q] * y[q], b + w2 * y[q] * x[q])
    });
    if yy > 0.0 {
        yx / yy
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fe::{bar_model, BoxSpec};
    use crate::sparse::lower_triangle;

    /// The small bar's lower-triangle pattern with M and K on it (K's pattern holds M's).
    fn bar() -> (Vec<usize>, Vec<usize>, Vec<f64>, Vec<f64>) {
        let model = bar_model(&BoxSpec::small()).unwrap();
        let (cp, ri, k) = lower_triangle(model.stiffness.as_ref());
        let (mcp, mri, mv) = lower_triangle(model.mass.as_ref());
        let mut m = vec![0.0; k.len()];
        for j in 0..cp.len() - 1 {
            for q in mcp[j]..mcp[j + 1] {
                let p = (cp[j]..cp[j + 1]).find(|&p| ri[p] == mri[q]).unwrap();
                m[p] = mv[q];
            }
        }
        (cp, ri, m, k)
    }

    #[test]
    fn a_rayleigh_matrix_is_proportional_with_its_coefficients() {
        let (cp, ri, m, k) = bar();
        let pattern = Pattern {
            col_ptr: &cp,
            row_idx: &ri,
        };
        for (alpha, beta) in [(3.0, 2e-5), (0.0, 1e-6), (5.0, 0.0)] {
            let d: Vec<f64> = m
                .iter()
                .zip(&k)
                .map(|(m, k)| alpha * m + beta * k)
                .collect();
            let Split::Proportional(p) = split(pattern, &m, &k, Viscous::Matrix(&d), 0.01, None)
            else {
                panic!("not proportional");
            };
            // each coefficient to what the entries determine: its error's part in D is
            // rounding of D (α M is 2e-5 of β K here, so α itself has fewer digits)
            let top = |v: &[f64]| v.iter().fold(0.0f64, |s, x| s.max(x.abs()));
            let dmax = top(&d);
            assert!((p.alpha - alpha).abs() * top(&m) <= 1e-12 * dmax, "{p:?}");
            assert!((p.beta - beta).abs() * top(&k) <= 1e-12 * dmax, "{p:?}");
            assert_eq!(p.eta, 0.01);
            // a coefficient that is not there is exactly 0
            assert!(alpha != 0.0 || p.alpha == 0.0);
            assert!(beta != 0.0 || p.beta == 0.0);
        }
    }

    /// A structural damping matrix that is zero but for one damper: no proportional part
    /// (not the b its few nonzero entries alone would fit), a rank-1 remainder.
    #[test]
    fn a_matrix_of_a_damper_alone_has_no_proportional_part() {
        let (cp, ri, m, k) = bar();
        let pattern = Pattern {
            col_ptr: &cp,
            row_idx: &ri,
        };
        let mut k4 = vec![0.0; k.len()];
        let at = |i: usize, j: usize| (cp[j]..cp[j + 1]).find(|&q| ri[q] == i).unwrap();
        let (a, b, c) = (ri[cp[3] + 2], 3, 1.0e3);
        k4[at(a, a)] += c;
        k4[at(b, b)] += c;
        k4[at(a, b)] -= c;
        let Split::LowRank(p, r) = split(
            pattern,
            &m,
            &k,
            Viscous::Rayleigh(0.0, 1e-6),
            0.02,
            Some(&k4),
        ) else {
            panic!("not low rank");
        };
        assert_eq!((p.gamma, p.eta, p.beta), (0.0, 0.02, 1e-6));
        assert_eq!((r.rank(), r.dofs.clone()), (1, vec![b, a]));
        assert!(r.viscous.norm_l2() == 0.0);
    }

    /// The sampled fit keeps a fit that leaves few entries out, with the entries the full
    /// fit leaves out, and hands a remainder on many entries to the full fit.
    #[test]
    fn the_sampled_fit_finds_the_dampers_and_defers_a_broad_remainder() {
        let n = 8 * SAMPLE;
        // M positive, K of both signs over four decades, some entries of K zero
        let m: Vec<f64> = (0..n).map(|q| 1e-6 * (1 + q % 7) as f64).collect();
        let k: Vec<f64> = (0..n)
            .map(|q| 1e4 * 10f64.powi((q % 5) as i32) * ((q * 37 % 101) as f64 - 50.0))
            .collect();
        let (alpha, beta) = (3.0, 2e-6);
        let mut d: Vec<f64> = m
            .iter()
            .zip(&k)
            .map(|(m, k)| alpha * m + beta * k)
            .collect();
        let dampers = vec![5, 77_777, n - 3];
        for &q in &dampers {
            d[q] += 40.0;
        }
        let sampled = sampled_fit(&m, &k, &d).expect("three entries left out");
        let full = robust_fit(&m, &k, &d).unwrap();
        assert_eq!(sampled.outliers, dampers);
        assert_eq!(full.outliers, dampers);
        assert!((sampled.a - alpha).abs() <= 1e-9 * alpha, "{sampled:?}");
        assert!((sampled.b - beta).abs() <= 1e-12 * beta, "{sampled:?}");
        // a second material, ten times stiffer-damped, on a tenth of the entries
        for q in (0..n).step_by(10) {
            d[q] = alpha * m[q] + 10.0 * beta * k[q];
        }
        assert!(sampled_fit(&m, &k, &d).is_none());
    }

    #[test]
    fn a_dashpot_is_a_rank_one_remainder_that_reproduces_the_matrix() {
        let (cp, ri, m, k) = bar();
        let pattern = Pattern {
            col_ptr: &cp,
            row_idx: &ri,
        };
        let beta = 2e-6;
        let mut d: Vec<f64> = k.iter().map(|k| beta * k).collect();
        // a dashpot c (e_a − e_b)(e_a − e_b)ᵀ between DoFs a > b that K couples
        let (a, b, c) = (ri[cp[3] + 2], 3, 4.0e2);
        assert!(a > b);
        let at = |i: usize, j: usize| (cp[j]..cp[j + 1]).find(|&q| ri[q] == i).unwrap();
        d[at(a, a)] += c;
        d[at(b, b)] += c;
        d[at(a, b)] -= c;
        let Split::LowRank(p, r) = split(pattern, &m, &k, Viscous::Matrix(&d), 0.0, None) else {
            panic!("not low rank");
        };
        assert!((p.beta - beta).abs() <= 1e-12 * beta, "{p:?}");
        assert_eq!(p.alpha, 0.0);
        assert_eq!(r.dofs, vec![b, a]);
        assert_eq!(r.rank(), 1);
        // U Ê Uᵀ = c (e_a − e_b)(e_a − e_b)ᵀ
        let e = &r.basis * &r.viscous * r.basis.transpose();
        let want = [[c, -c], [-c, c]];
        for i in 0..2 {
            for j in 0..2 {
                assert!((e[(i, j)] - want[i][j]).abs() <= 1e-9 * c, "{e:?}");
            }
        }
    }
}
