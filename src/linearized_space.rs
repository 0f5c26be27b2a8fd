//! Responses of a body with any damping — material-wise viscous or structural damping, a
//! full-rank D that is not αM + βK, a structural damping ηK + K₄ that is not a multiple of
//! K — at every
//! frequency from one factorization (docs/design.md §3.13).
//!
//! The pencil Q(s) = s²M + sD + K + iG (s = iω, G = ηK + K₄ the structural damping, H
//! below the projected matrix) is linearized about a real s₀ > 0. With
//! K₀ = Q(s₀) = K + iG + s₀D + s₀²M — real and positive definite without structural damping
//! (M is, K and D are semi-definite: a Cholesky factor), complex symmetric with a positive
//! definite real part with it (an LDLᵀ whose pivots all exist) — and the operator on pairs of
//! N-vectors
//!
//! ```text
//! Op [u; v] = [a; a + u/s₀],     a = −K₀⁻¹((D + s₀M) u + s₀M v),
//! ```
//!
//! the response x = Q(s)⁻¹b is the first half of z = [x; (s/s₀) x], the solution of
//!
//! ```text
//! (I − τ Op) z = z₀ = [K₀⁻¹b; K₀⁻¹b],     τ = s − s₀
//! ```
//!
//! (the first half reads K₀⁻¹(K₀ + τD + τ(s + s₀)M) x = K₀⁻¹Q(s) x = K₀⁻¹b; the second
//! then holds). So the Krylov space K_k(Op, z₀) does not depend on s, as the shifted space's
//! does not on μ (§3.10): one space answers every frequency. Its block Arnoldi basis V keeps
//!
//! ```text
//! Op V = V H + W E_lastᵀ,     z₀ = V E₁ R₀,
//! ```
//!
//! W the part of the last block's image outside the space. The Galerkin solution z = V y,
//! (I − τH) y = E₁R₀, has the residual (I − τOp) z − z₀ = −τ W y_last, whose norm
//! |τ| ‖R y_last‖ (W = Q_W R) is known at every frequency from the k × k matrices alone;
//! with H = XΛX⁻¹, y(τ) = X (I − τΛ)⁻¹ X⁻¹E₁R₀ costs O(kp) per frequency. The space grows
//! until that estimate is ≤ [`GROW_TO`](crate::shifted_space::GROW_TO) relative to ‖z₀‖ at
//! the frequencies asked; each response is then certified by its true residual b − A(iω)x
//! with the exact pencil, as every response of the shifted space is.
//!
//! Both halves of every basis vector lie in the span of one M-orthonormal basis Q of
//! N-vectors (the second half of Op's image is a combination of its first half and of u):
//! V = [Q A; Q B] with small coefficient matrices A and B (the two-level orthogonal Arnoldi,
//! TOAR: Lu, Su & Bai, "A Two-Level Orthogonal Arnoldi Procedure for Solving Quadratic
//! Eigenvalue Problems", 2016). The inner product ⟨[Qa; Qb], [Qa'; Qb']⟩ = aᴴa' + bᴴb' (the
//! M-inner product on both halves) is Euclidean on the coefficients, so the Arnoldi
//! orthogonalization is O(k²) small work per vector; Q grows by one N-vector per direction,
//! as the shifted space's does, and x = Q (A y) is what the sweep's snapshots carry. Q is
//! real: with a complex K₀ the coefficients are complex and each complex direction adds its
//! real and imaginary parts to Q (about twice the vectors of a real K₀'s space).
//!
//! Against the shifted space: the linearization has a conjugate pair of eigenvalues per mode,
//! so the space holds about twice as many vectors for the same band, each costing a solve
//! with K₀; H is not symmetric. On a free body D and G must not couple the rigid motion to the
//! elastic (D V₀ in the span of M V₀, as for Rayleigh damping of each material): then Op
//! keeps the elastic responses elastic.

use crate::dense::MatStack;
use crate::eigen::project_once;
use crate::factor::{Cholesky, ComplexLdlt, FactorPlace, RealLdlt};
use crate::pencil::{Coefficient, Pencil};
use crate::rigid::RigidBody;
use crate::shifted_space::{
    append_columns, complex_product, lift, m_orthonormalize, Growth, Lifted, ResponseSpace, Rows,
    RowsAnswer, Solution, SolutionBuffers, DEFLATE, GROW_TO,
};
use crate::units::hz_to_omega;
use crate::{Error, Result};
use faer::linalg::matmul::matmul;
use faer::linalg::solvers::Solve;
use faer::{c64, Accum, Mat, MatRef, Par};
use std::sync::Arc;

/// D couples the rigid motion of a free body to the elastic when ‖D V₀ − M V₀ (V₀ᵀDV₀)‖ is
/// above this fraction of ‖D V₀‖ + ‖D‖_F‖V₀‖ (V₀ M-orthonormal); so does the structural
/// damping G when ‖G V₀‖ is above this fraction of ‖G‖_F‖V₀‖.
const RIGID_COUPLING: f64 = 1e-8;

/// The eigendecomposition H = XΛX⁻¹ and the coefficients X⁻¹E₁R₀.
struct Ritz {
    lambda: Vec<c64>,
    x: Mat<c64>,
    c: Mat<c64>,
}

/// The factor of K₀: real without structural damping, complex symmetric with it.
enum K0 {
    Real(Cholesky),
    Complex(ComplexLdlt),
}

/// A block of N-vectors X = R + iI by its real parts; `im` is `None` while X is real (on a
/// body without structural damping every block is, and costs no second part).
struct Parts {
    re: Mat<f64>,
    im: Option<Mat<f64>>,
}

impl Parts {
    /// s Q C for a real Q and a complex C (Q Re C, and Q Im C when Im C ≠ 0).
    fn product(q: MatRef<'_, f64>, c: MatRef<'_, c64>, s: f64, par: Par) -> Parts {
        let im = c.col_iter().any(|col| col.iter().any(|x| x.im != 0.0));
        Parts {
            re: product(q, c.map(|x| x.re).as_ref(), s, par),
            im: im.then(|| product(q, c.map(|x| x.im).as_ref(), s, par)),
        }
    }

    /// X + Y.
    fn add(mut self, y: Parts) -> Parts {
        self.re += &y.re;
        self.im = match (self.im, y.im) {
            (Some(a), Some(b)) => Some(a + b),
            (a, b) => a.or(b),
        };
        self
    }

    /// f(R) + i f(I) for a real linear map f.
    fn map(&self, f: impl Fn(MatRef<'_, f64>) -> Mat<f64>) -> Parts {
        Parts {
            re: f(self.re.as_ref()),
            im: self.im.as_ref().map(|m| f(m.as_ref())),
        }
    }

    /// [R I] (N × 2b), or R alone while X is real.
    fn columns(self) -> Mat<f64> {
        match self.im {
            None => self.re,
            Some(im) => {
                let (n, b) = (self.re.nrows(), self.re.ncols());
                Mat::from_fn(n, 2 * b, |i, j| {
                    if j < b {
                        self.re[(i, j)]
                    } else {
                        im[(i, j - b)]
                    }
                })
            }
        }
    }

    /// The parts of the complex block `x`.
    fn from_complex(x: MatRef<'_, c64>) -> Parts {
        Parts {
            re: x.map(|v| v.re),
            im: Some(x.map(|v| v.im)),
        }
    }
}

/// The growing linearized Krylov space of one body and load; see the module doc.
pub(crate) struct LinearizedSpace<'a> {
    pencil: &'a Pencil,
    factor: K0,
    rigid: Option<&'a RigidBody>,
    s0: f64,
    /// P B (N × p), real.
    load: Mat<f64>,
    /// M-orthonormal real basis of both halves (N × η) and M Q.
    q: Mat<f64>,
    mq: Mat<f64>,
    /// V = [Q A; Q B]: the coefficients of each half (η × k).
    a: Mat<c64>,
    b: Mat<c64>,
    /// H = VᴴOp V (k × k, block upper Hessenberg).
    h: Mat<c64>,
    /// E₁R₀: z₀'s coefficients (k × p; only the first block's rows are non-zero).
    r0: Mat<c64>,
    /// First column of the last block.
    last: usize,
    /// W's halves' coefficients (η × b each): the last block's image outside the space.
    next_a: Mat<c64>,
    next_b: Mat<c64>,
    /// The norm of each column of the image W came from (of z₀ for the first block): the
    /// scale of the deflation test.
    next_scale: Vec<f64>,
    ritz: Option<Ritz>,
    max_dim: usize,
    /// Columns Q and MQ have room for ([`append_columns`]).
    capacity: usize,
    block_solves: usize,
    par: Par,
    answered: Option<RowsAnswer>,
}

impl<'a> LinearizedSpace<'a> {
    /// Factors K₀ = K + iG + s₀D + s₀²M (s₀ > 0; real without structural damping G) and
    /// starts the space from z₀ = [K₀⁻¹b; K₀⁻¹b], b = `load` (P B, rigid-free on a free
    /// body). Q holds at most `max_dim` vectors.
    ///
    /// # Errors
    /// [`Error::InvalidSetting`] for s₀ ≤ 0, or a D or G that couples a free body's rigid
    /// motion to the elastic; [`Error::Factor`] when K₀ is not positive definite (D not
    /// semi-definite?), a complex K₀ needs a perturbed pivot, or memory is short.
    pub fn new(
        body: &'a crate::body::Body,
        load: Mat<f64>,
        s0: f64,
        max_dim: usize,
        par: Par,
    ) -> Result<Self> {
        let pencil = body.pencil();
        if !(s0 > 0.0) {
            return Err(Error::InvalidSetting(format!(
                "linearization point s0 = {s0}: must be > 0 (K + s0 D + s0^2 M positive definite)"
            )));
        }
        if let Some(rb) = body.rigid() {
            let e = rigid_coupling(pencil, rb.modes());
            if !(e <= RIGID_COUPLING) {
                return Err(Error::InvalidSetting(format!(
                    "the damping couples the free body's rigid motion to the elastic ({e:.1e} \
                     relative): its elastic response is not a response of the linearized space"
                )));
            }
        }
        // on the factored pencil's pattern (through the coupling, A₁'s: §3.11)
        let mut vals = vec![0.0; pencil.factored().nnz()];
        pencil.factored().fill_quadratic(s0, &mut vals);
        let p = load.ncols();
        let not_definite = |e: Error| {
            Error::Factor(format!(
                "K + s0 D + s0^2 M (s0 = {s0:.3e}) is not positive definite ({e}): is D \
                 positive semi-definite?"
            ))
        };
        let factor = if pencil.structural() == (0.0, false) {
            let mut factor =
                Cholesky::with_rhs(pencil, body.symbolic()?, par, p, body.factor_storage())?;
            factor
                .factor_values(pencil, &vals, par)
                .map_err(not_definite)?;
            K0::Real(factor)
        } else {
            let budget = body.factor_storage().budget;
            let mut factor =
                ComplexLdlt::new(pencil, body.symbolic()?, p, budget)?.ok_or_else(|| {
                    Error::InvalidSetting(
                        "a pattern without off-diagonal entries: its frequencies are factored"
                            .into(),
                    )
                })?;
            let mut im = vec![0.0; pencil.factored().nnz()];
            pencil.factored().fill_structural(&mut im);
            let perturbed = factor.factor(&vals, &im, par).map_err(not_definite)?;
            if perturbed > 0 {
                return Err(Error::Factor(format!(
                    "K + iG + s0 D + s0^2 M (s0 = {s0:.3e}) needed {perturbed} perturbed \
                     pivots: its frequencies are factored"
                )));
            }
            K0::Complex(factor)
        };
        drop(vals);
        let n = pencil.n();
        let mut space = LinearizedSpace {
            pencil,
            factor,
            rigid: body.rigid(),
            s0,
            load,
            q: Mat::zeros(n, 0),
            mq: Mat::zeros(n, 0),
            a: Mat::zeros(0, 0),
            b: Mat::zeros(0, 0),
            h: Mat::zeros(0, 0),
            r0: Mat::zeros(0, p),
            last: 0,
            next_a: Mat::zeros(0, 0),
            next_b: Mat::zeros(0, 0),
            next_scale: Vec::new(),
            ritz: None,
            max_dim: max_dim.min(n),
            capacity: 0,
            block_solves: 0,
            par,
            answered: None,
        };
        let x = space.solve_k0(Parts {
            re: space.load.clone(),
            im: None,
        });
        let (c, scale) = space.add_directions(x);
        space.next_scale = scale.iter().map(|s| s * std::f64::consts::SQRT_2).collect();
        space.next_a = c.clone();
        space.next_b = c;
        space.extend();
        Ok(space)
    }

    /// K₀⁻¹X without its rigid part.
    fn solve_k0(&mut self, x: Parts) -> Parts {
        let mut x = match &mut self.factor {
            K0::Real(factor) => {
                let b = x.re.ncols();
                let two = x.im.is_some();
                let mut all = x.columns();
                factor.solve_block(all.as_mut(), self.par);
                if two {
                    Parts {
                        re: all.subcols(0, b).to_owned(),
                        im: Some(all.subcols(b, b).to_owned()),
                    }
                } else {
                    Parts { re: all, im: None }
                }
            }
            K0::Complex(factor) => {
                let (re, im) = (&x.re, x.im.as_ref());
                let mut all = Mat::<c64>::from_fn(re.nrows(), re.ncols(), |i, j| {
                    c64::new(re[(i, j)], im.map_or(0.0, |m| m[(i, j)]))
                });
                factor.solve(all.as_mut(), self.par);
                Parts::from_complex(all.as_ref())
            }
        };
        self.block_solves += 1;
        if let Some(rb) = self.rigid {
            rb.project_response_real(x.re.as_mut());
            if let Some(im) = x.im.as_mut() {
                rb.project_response_real(im.as_mut());
            }
        }
        x
    }

    /// Writes the columns of `x` in the basis Q, adding the directions Q lacks (two passes
    /// of M-orthogonalization of their real and imaginary parts, then [`m_orthonormalize`]):
    /// returns the coefficients C (η × columns, η the new dimension; x = Q C) and each
    /// column's M-norm.
    fn add_directions(&mut self, x: Parts) -> (Mat<c64>, Vec<f64>) {
        let eta = self.q.ncols();
        let b = x.re.ncols();
        let mut x = x.columns();
        let mut c = project_once(self.q.as_ref(), self.mq.as_ref(), &mut x, self.par);
        c += project_once(self.q.as_ref(), self.mq.as_ref(), &mut x, self.par);
        // M of what is left, in one blocked pass rather than one pass per column
        let mx = self.pencil.mul(Coefficient::Mass, x.as_ref());
        // ‖x‖²_M = ‖c‖² + ‖x − Qc‖²_M (Q M-orthonormal), without a product with M before
        // the projection; a complex column's, its parts' sum; each part deflated against it
        let norm2: Vec<f64> = (0..x.ncols())
            .map(|j| c.col(j).squared_norm_l2() + (x.col(j).transpose() * mx.col(j)).max(0.0))
            .collect();
        let scale: Vec<f64> = (0..b)
            .map(|j| (norm2[j] + norm2.get(b + j).copied().unwrap_or(0.0)).sqrt())
            .collect();
        let part_scale: Vec<f64> = (0..x.ncols()).map(|j| scale[j % b]).collect();
        let (qn, mqn, rn) =
            m_orthonormalize(self.pencil, x.as_ref(), Some(mx.as_ref()), &part_scale);
        let e = qn.ncols();
        append_columns(
            [&mut self.q, &mut self.mq],
            [qn.as_ref(), mqn.as_ref()],
            &mut self.capacity,
            self.max_dim,
        );
        for m in [&mut self.a, &mut self.b, &mut self.next_a, &mut self.next_b] {
            let cols = m.ncols();
            m.resize_with(eta + e, cols, |_, _| c64::new(0.0, 0.0));
        }
        let real = |i: usize, j: usize| {
            if i < eta {
                c[(i, j)]
            } else {
                rn[(i - eta, j)]
            }
        };
        let two = x.ncols() > b;
        let all = Mat::from_fn(eta + e, b, |i, j| {
            c64::new(real(i, j), if two { real(i, b + j) } else { 0.0 })
        });
        (all, scale)
    }

    /// Adds the columns of W (orthonormalized, deflated) as a new block and computes its
    /// image; returns false when nothing was added (the space is invariant or full).
    fn extend(&mut self) -> bool {
        let k = self.a.ncols();
        if !self.can_grow() {
            return false;
        }
        let w = stack(self.next_a.as_ref(), self.next_b.as_ref());
        let (vn, coef) = orthonormalize_coefficients(w.as_ref(), &self.next_scale);
        let bn = vn.ncols();
        let eta = self.q.ncols();
        let zero = c64::new(0.0, 0.0);
        if bn == 0 {
            self.next_a = Mat::zeros(eta, 0);
            self.next_b = Mat::zeros(eta, 0);
            return false;
        }
        let kn = k + bn;
        self.h.resize_with(kn, kn, |_, _| zero);
        self.r0.resize_with(kn, self.r0.ncols(), |_, _| zero);
        if k == 0 {
            self.r0.as_mut().subrows_mut(0, bn).copy_from(&coef);
        } else {
            let prev = k - self.last;
            self.h
                .as_mut()
                .submatrix_mut(k, self.last, bn, prev)
                .copy_from(&coef);
        }
        self.a.resize_with(eta, kn, |i, j| vn[(i, j - k)]);
        self.b.resize_with(eta, kn, |i, j| vn[(eta + i, j - k)]);
        self.last = k;
        // Op [Q a; Q b] = [x; x + Q a/s₀], x = −K₀⁻¹(D Q a + s₀ M Q (a + b))
        let (na, nb) = (
            self.a.subcols(k, bn).to_owned(),
            self.b.subcols(k, bn).to_owned(),
        );
        let u = Parts::product(self.q.as_ref(), na.as_ref(), 1.0, self.par);
        let x = u
            .map(|m| {
                let mut dm = self.pencil.mul(Coefficient::Damping, m);
                dm *= faer::Scale(-1.0);
                dm
            })
            .add(Parts::product(
                self.mq.as_ref(),
                (&na + &nb).as_ref(),
                -self.s0,
                self.par,
            ));
        let x = self.solve_k0(x);
        let (top, _) = self.add_directions(x);
        let eta = self.q.ncols();
        let bottom = Mat::from_fn(eta, bn, |i, j| {
            top[(i, j)]
                + if i < na.nrows() {
                    na[(i, j)] * (1.0 / self.s0)
                } else {
                    zero
                }
        });
        // the image against the whole basis, two passes of classical Gram–Schmidt on the
        // coefficients; H's new columns are their sums
        let mut image = stack(top.as_ref(), bottom.as_ref());
        let scale: Vec<f64> = (0..bn).map(|j| image.col(j).norm_l2()).collect();
        let v = stack(self.a.as_ref(), self.b.as_ref());
        for _ in 0..2 {
            let c = v.adjoint() * &image;
            image -= &v * &c;
            let mut hc = self.h.as_mut().subcols_mut(k, bn);
            hc += &c;
        }
        self.next_a = image.subrows(0, eta).to_owned();
        self.next_b = image.subrows(eta, eta).to_owned();
        self.next_scale = scale;
        self.ritz = None;
        true
    }

    /// Decomposes the current H = XΛX⁻¹ (once per basis; in real arithmetic while H is
    /// real).
    fn decompose(&mut self) -> Result<()> {
        if self.ritz.is_some() {
            return Ok(());
        }
        let failed = || {
            Error::NotConverged(
                "the dense eigensolver failed on the linearized space's projected matrix (NaN \
                 in the Krylov basis?)"
                    .into(),
            )
        };
        let s = self
            .h
            .col_iter()
            .flat_map(|c| c.iter().map(|x| x.norm()).collect::<Vec<_>>())
            .fold(0.0, f64::max);
        let s = if s > 0.0 && s.is_finite() { s } else { 1.0 };
        let real = self.h.col_iter().all(|c| c.iter().all(|x| x.im == 0.0));
        let e = if real {
            self.h.map(|x| x.re / s).eigen()
        } else {
            self.h.map(|x| x * (1.0 / s)).eigen()
        }
        .map_err(|_| failed())?;
        let lambda: Vec<c64> = (0..self.h.nrows())
            .map(|i| e.S().column_vector()[i] * s)
            .collect();
        let x = e.U().to_owned();
        let c = x.partial_piv_lu().solve(&self.r0);
        if !c.is_all_finite() {
            return Err(failed());
        }
        self.ritz = Some(Ritz { lambda, x, c });
        Ok(())
    }

    /// τ = iω − s₀.
    fn tau(&self, omega: f64) -> c64 {
        c64::new(-self.s0, omega)
    }

    /// L diag(1/(1 − τλ_j)) C at each of `freqs_hz` for a complex L (m × k): the rows L of
    /// the Galerkin solutions y(τ).
    fn superposed(&self, ritz: &Ritz, left: MatRef<'_, c64>, freqs_hz: &[f64]) -> MatStack {
        let (m, p) = (left.nrows(), ritz.c.ncols());
        let one = c64::new(1.0, 0.0);
        MatStack::from_fn(m, p, freqs_hz.len(), |f| {
            let tau = self.tau(hz_to_omega(freqs_hz[f]));
            let dc = Mat::<c64>::from_fn(ritz.c.nrows(), p, |j, c| {
                ritz.c[(j, c)] / (one - tau * ritz.lambda[j])
            });
            left * &dc
        })
    }

    /// The estimated relative residual ‖(I − τOp)z − z₀‖/‖z₀‖ (worst column) at each of
    /// `freqs_hz` (module doc); infinite before the space was decomposed.
    fn estimates(&self, freqs_hz: &[f64]) -> Vec<f64> {
        let Some(ritz) = &self.ritz else {
            return vec![f64::INFINITY; freqs_hz.len()];
        };
        if self.next_a.ncols() == 0 {
            return vec![0.0; freqs_hz.len()];
        }
        // ‖W y‖ = ‖R y‖ for W = Q_W R: R times the last block's rows of X
        let w = stack(self.next_a.as_ref(), self.next_b.as_ref());
        let r = w.qr().thin_R().to_owned();
        if !r.is_all_finite() {
            return vec![f64::INFINITY; freqs_hz.len()];
        }
        let last = self.a.ncols() - self.last;
        let left = &r * ritz.x.subrows(self.last, last);
        let norms: Vec<f64> = (0..self.r0.ncols())
            .map(|c| self.r0.col(c).norm_l2())
            .collect();
        let residuals = self.superposed(ritz, left.as_ref(), freqs_hz);
        (0..freqs_hz.len())
            .map(|f| {
                let tau = self.tau(hz_to_omega(freqs_hz[f])).norm();
                let r = residuals.get(f);
                norms
                    .iter()
                    .enumerate()
                    .filter(|(_, &n)| n > 0.0)
                    .map(|(c, &n)| tau * r.col(c).norm_l2() / n)
                    .fold(0.0, f64::max)
            })
            .collect()
    }
}

impl ResponseSpace for LinearizedSpace<'_> {
    fn basis(&self) -> MatRef<'_, f64> {
        self.q.as_ref()
    }

    fn dim(&self) -> usize {
        self.q.ncols()
    }

    /// Q holds at most `max_dim` vectors (and one block more: a block's new directions are
    /// all kept, or the space would not be a Krylov space).
    fn can_grow(&self) -> bool {
        self.next_a.ncols() > 0 && self.dim() < self.max_dim
    }

    /// Made about s₀ = √−σ > 0, a real shift of the linearization: never inside the
    /// spectrum.
    fn interior(&self) -> bool {
        false
    }

    fn into_basis(self: Box<Self>) -> Mat<f64> {
        self.q
    }

    fn block_solves(&self) -> usize {
        self.block_solves
    }

    /// [`Growth::grow`] over the Arnoldi vectors.
    fn grow_for(&mut self, freqs_hz: &[f64], target: f64) -> Result<()> {
        let growth = Growth {
            decompose: Self::decompose,
            estimates: Self::estimates,
            extend: Self::extend,
            sizes: |s: &Self| (s.next_a.ncols(), s.a.ncols()),
        };
        growth.grow(self, freqs_hz, target)?;
        match &self.factor {
            K0::Real(f) => f.in_house().map_or(Ok(()), RealLdlt::check_solves),
            K0::Complex(_) => Ok(()),
        }
    }

    /// The real factor's place; a complex factor is in memory.
    fn factor_place(&self) -> FactorPlace {
        match &self.factor {
            K0::Real(f) => f.in_house().map(RealLdlt::place).unwrap_or_default(),
            K0::Complex(_) => FactorPlace::default(),
        }
    }

    /// y = (I − τH)⁻¹E₁R₀ by a dense LU (not the eigendecomposition: H is not normal), and
    /// X = Q A y certified with the exact pencil.
    fn solve(&self, freq_hz: f64, par: Par, buffers: &mut SolutionBuffers) -> Result<Solution> {
        let omega = hz_to_omega(freq_hz);
        let tau = self.tau(omega);
        let ritz = self.ritz.as_ref().ok_or_else(|| {
            Error::NotConverged("the linearized space was not decomposed (grow_for first)".into())
        })?;
        let k = self.h.nrows();
        let lhs = Mat::<c64>::from_fn(k, k, |i, j| {
            let d = if i == j { 1.0 } else { 0.0 };
            c64::new(d, 0.0) - tau * self.h[(i, j)]
        });
        let y = lhs.partial_piv_lu().solve(&self.r0);
        let coefficients = &self.a * &y;
        let one = c64::new(1.0, 0.0);
        let amplification = ritz
            .lambda
            .iter()
            .map(|&l| (tau * l).norm() / (one - tau * l).norm())
            .fold(0.0, f64::max);
        let certificate = lift(
            Lifted {
                pencil: self.pencil,
                q: self.q.as_ref(),
                rigid: self.rigid,
                load: self.load.as_ref(),
            },
            omega,
            coefficients.as_ref(),
            par,
            buffers,
        );
        Ok(Solution {
            coefficients,
            certificate,
            amplification,
        })
    }

    /// C Q A X (I − τΛ)⁻¹ X⁻¹E₁R₀: O(q k p) per frequency after one q × k product.
    fn rows_at(&mut self, freqs_hz: &[f64], rows: &[usize]) -> Arc<Rows> {
        let k = self.a.ncols();
        let Some(ritz) = &self.ritz else {
            return Arc::new(Rows::new(MatStack::default(), vec![false; freqs_hz.len()]));
        };
        let q = Mat::<f64>::from_fn(rows.len(), self.q.ncols(), |i, j| self.q[(rows[i], j)]);
        let left = complex_product(q.as_ref(), self.a.as_ref()) * &ritz.x;
        let h = self.superposed(ritz, left.as_ref(), freqs_hz);
        let answered = self
            .estimates(freqs_hz)
            .into_iter()
            .map(|e| e <= GROW_TO)
            .collect();
        let h = Arc::new(Rows::new(h, answered));
        self.answered = Some(RowsAnswer {
            freqs_hz: freqs_hz.to_vec(),
            rows: rows.to_vec(),
            dim: k,
            h: Arc::clone(&h),
        });
        h
    }

    fn answer(&self, freqs_hz: &[f64], rows: &[usize]) -> Option<Arc<Rows>> {
        self.answered
            .as_ref()
            .and_then(|a| a.same(freqs_hz, rows, self.a.ncols()))
    }
}

/// The larger of ‖D V₀ − M V₀ (V₀ᵀDV₀)‖_F relative to ‖D V₀‖_F + ‖D‖_F‖V₀‖_F for
/// M-orthonormal V₀, and of ‖G V₀‖_F relative to ‖G‖_F‖V₀‖_F for the structural damping G: 0
/// to rounding when the damping keeps the rigid motion apart from the elastic (e.g.
/// D = Σ β_i K_i, G = Σ η_i K_i).
fn rigid_coupling(pencil: &Pencil, v0: MatRef<'_, f64>) -> f64 {
    let structural = if pencil.structural() == (0.0, false) {
        0.0
    } else {
        let hv = pencil.mul(Coefficient::Structural, v0);
        let scale = pencil.norm_fro(Coefficient::Structural) * v0.norm_l2();
        if scale > 0.0 {
            hv.norm_l2() / scale
        } else {
            0.0
        }
    };
    viscous_rigid_coupling(pencil, v0).max(structural)
}

/// The viscous part of [`rigid_coupling`].
fn viscous_rigid_coupling(pencil: &Pencil, v0: MatRef<'_, f64>) -> f64 {
    let dv = pencil.mul(Coefficient::Damping, v0);
    let mv = pencil.mul(Coefficient::Mass, v0);
    let gram = v0.transpose() * &mv;
    // V₀'s M-Gram matrix may differ from I: project with its inverse
    let within = &mv * gram.partial_piv_lu().solve(&(v0.transpose() * &dv));
    let scale = dv.norm_l2() + pencil.norm_fro(Coefficient::Damping) * v0.norm_l2();
    if !(scale > 0.0) {
        return 0.0;
    }
    (&dv - &within).norm_l2() / scale
}

/// s A B, on the threads of `par`.
fn product(a: MatRef<'_, f64>, b: MatRef<'_, f64>, s: f64, par: Par) -> Mat<f64> {
    let mut out = Mat::zeros(a.nrows(), b.ncols());
    matmul(out.as_mut(), Accum::Replace, a, b, s, par);
    out
}

/// [X; Y] of two matrices with the same columns.
fn stack(x: MatRef<'_, c64>, y: MatRef<'_, c64>) -> Mat<c64> {
    let r = x.nrows();
    Mat::from_fn(r + y.nrows(), x.ncols(), |i, j| {
        if i < r {
            x[(i, j)]
        } else {
            y[(i - r, j)]
        }
    })
}

/// Orthonormalizes the columns of `w` (coefficient vectors, orthogonal to the basis's
/// already) against each other in the Euclidean inner product: two passes of Gram–Schmidt
/// per column against the new columns, a column left with less than [`DEFLATE`] of its
/// `scale` dropped. Returns the new columns and the coefficients C with w = W_new C (rows:
/// kept columns).
fn orthonormalize_coefficients(w: MatRef<'_, c64>, scale: &[f64]) -> (Mat<c64>, Mat<c64>) {
    let (n, b) = (w.nrows(), w.ncols());
    let mut kept = Mat::<c64>::zeros(n, 0);
    let mut coef = Mat::<c64>::zeros(b, b);
    for j in 0..b {
        let mut v = w.col(j).to_owned();
        for _ in 0..2 {
            let c = kept.adjoint() * &v;
            v -= &kept * &c;
            for (i, &x) in c.iter().enumerate() {
                coef[(i, j)] += x;
            }
        }
        let norm = v.norm_l2();
        if !(norm > DEFLATE * scale[j]) {
            continue;
        }
        let i = kept.ncols();
        kept.resize_with(n, i + 1, |r, _| v[r] * (1.0 / norm));
        coef[(i, j)] = c64::new(norm, 0.0);
    }
    let k = kept.ncols();
    (kept, coef.subrows(0, k).to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fe::{assemble, BoxSpec};
    use crate::model::{Damping, Model, Structural};
    use crate::shifted_space::tests::{
        bar_with, krylov_vs_factored_body, krylov_vs_factored_within, responses,
    };
    use crate::sparse::{linear_combination, Csc, Triplets};
    use crate::sweep::SolveMethod;
    use proptest::prelude::*;

    /// The test bar of [`bar_with`]: 1 × 2 × 24 elements along z.
    fn spec() -> BoxSpec {
        BoxSpec {
            elements: [1, 2, 24],
            ..BoxSpec::paper_bar()
        }
    }

    /// The stiffness of the bar's far half (elements 12..24 along z) alone, on the whole
    /// bar's DoFs: what a second material's Rayleigh term is proportional to.
    fn far_half_stiffness(n: usize) -> Csc {
        let whole = spec();
        let [nx, ny, nz] = whole.elements;
        let half = BoxSpec {
            elements: [nx, ny, nz / 2],
            size_m: [whole.size_m[0], whole.size_m[1], whole.size_m[2] / 2.0],
            mass_kg: whole.mass_kg / 2.0,
            ..whole
        };
        let k = assemble(&half).unwrap().stiffness;
        // node (i, j, k) of the half is node (i, j, k + nz/2) of the bar
        let per_layer = (nx + 1) * (ny + 1);
        let dof = |d: usize| 3 * (d / 3 + per_layer * (nz / 2)) + d % 3;
        let mut t = Triplets::default();
        for j in 0..k.ncols() {
            let rows = k.symbolic().row_idx_of_col_raw(j);
            for (&i, &v) in rows.iter().zip(k.val_of_col(j)) {
                t.push(dof(i), dof(j), v);
            }
        }
        t.into_csc(n, false)
    }

    /// The bar with D = β₁K + (β₂ − β₁)K_far: Rayleigh damping β₁ on the near half and β₂ on
    /// the far half, as a body of two materials has (plus `alpha` M on the whole bar).
    fn two_materials(alpha: f64, beta1: f64, beta2: f64) -> impl FnOnce(&mut Model) {
        move |m: &mut Model| {
            let far = far_half_stiffness(m.n());
            let scaled = linear_combination(0.0, &far, beta2 - beta1, &far, None);
            m.damping = Damping::Matrix(linear_combination(
                alpha,
                &m.mass,
                beta1,
                &m.stiffness,
                Some(&scaled),
            ));
        }
    }

    /// Material-wise damping (β 10× apart between the halves, with and without α M) is not
    /// a low-rank update of a proportional one; the linearized space answers every frequency
    /// with certified responses equal to factored ones, none of them factored.
    #[test]
    fn material_wise_damping_is_answered_by_the_linearized_space() {
        let freqs = [3.0, 117.0, 410.5, 640.0, 999.0];
        for (alpha, beta1, beta2) in [(0.0, 1e-6, 1e-5), (3.0, 2e-5, 2e-6)] {
            let (body, inputs) = bar_with(two_materials(alpha, beta1, beta2));
            assert!(
                body.pencil().proportional().is_none(),
                "the split took {alpha} M + ({beta1}, {beta2}) K for proportional"
            );
            let d = krylov_vs_factored_body(&body, &inputs, &freqs);
            assert!(
                d <= 1e-8,
                "alpha {alpha}, beta {beta1}/{beta2}: difference {d:.2e}"
            );
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(6))]
        /// Over damping levels and ratios between the materials (damping ratios βω/2 up to
        /// 0.3 in the band).
        #[test]
        fn certified_responses_equal_factored_ones(
            beta1 in 1e-7f64..1e-5,
            ratio in 2.0f64..10.0,
            f in 1.0f64..1000.0,
        ) {
            let (body, inputs) = bar_with(two_materials(0.0, beta1, beta1 * ratio));
            prop_assume!(body.pencil().proportional().is_none());
            let d = krylov_vs_factored_body(&body, &inputs, &[f, 0.5 * f]);
            prop_assert!(d <= 1e-8, "difference {:.2e}", d);
        }
    }

    /// A D that couples the rigid motion to the elastic (mass-proportional damping on one
    /// half of a free body) has no elastic response in the space: the space is refused and
    /// every frequency factored, with the same responses.
    #[test]
    fn a_damping_that_loads_rigid_motion_is_factored() {
        let (body, inputs) = bar_with(|m| {
            let n = m.n();
            let far = far_half_stiffness(n);
            // M on the far half's DoFs: the principal submatrix of M where K_far has a row
            let on: Vec<bool> = (0..n)
                .map(|j| far.val_of_col(j).iter().any(|&v| v != 0.0))
                .collect();
            let mut t = Triplets::default();
            for j in 0..n {
                let rows = m.mass.symbolic().row_idx_of_col_raw(j);
                for (&i, &v) in rows.iter().zip(m.mass.val_of_col(j)) {
                    if on[i] && on[j] {
                        t.push(i, j, 50.0 * v);
                    }
                }
            }
            let half_mass = t.into_csc(n, false);
            m.damping = Damping::Matrix(linear_combination(
                0.0,
                &m.mass,
                1e-6,
                &m.stiffness,
                Some(&half_mass),
            ));
        });
        assert!(body.pencil().proportional().is_none());
        let e = rigid_coupling(body.pencil(), body.rigid().unwrap().modes());
        assert!(e > 100.0 * RIGID_COUPLING, "rigid coupling {e:.1e}");
        let freqs = [117.0, 640.0];
        let (x, stats) = responses(&body, &inputs, &freqs, SolveMethod::Auto);
        let (x0, _) = responses(&body, &inputs, &freqs, SolveMethod::Factored);
        for (s, (a, b)) in stats.iter().zip(x.iter().zip(&x0)) {
            assert!(!s.from_space(), "{} Hz came from a space", s.freq_hz);
            assert!((a - b).norm_l2() <= 1e-12 * b.norm_l2());
        }
    }

    /// The outputs' rows from the eigendecomposition of H equal the rows of the lifted
    /// Galerkin responses (a dense LU of I − τH), at the band's frequencies.
    #[test]
    fn rows_at_equal_the_lifted_responses() {
        let (body, inputs) = bar_with(two_materials(0.0, 1e-6, 1e-5));
        let load = body.elastic_load(&inputs);
        let freqs = [30.0, 333.0, 777.0, 990.0];
        let s0 = crate::units::hz_to_omega(250.0);
        let mut space = LinearizedSpace::new(&body, load, s0, body.n(), Par::Seq).unwrap();
        let mut buffers = SolutionBuffers::default();
        // grown as the sweep grows it: a target 100× tighter while a certificate fails
        let certified = crate::sweep::growth_targets().any(|t| {
            space.grow_for(&freqs, t).unwrap();
            freqs.iter().all(|&f| {
                let solution = space.solve(f, Par::Seq, &mut buffers).unwrap();
                solution.certified()
            })
        });
        assert!(certified);
        let rows = [0, 7, body.n() - 1];
        let h = space.rows_at(&freqs, &rows);
        for (k, &f) in freqs.iter().enumerate() {
            space.solve(f, Par::Seq, &mut buffers).unwrap();
            let x = buffers.x();
            let lifted = Mat::<c64>::from_fn(rows.len(), x.ncols(), |i, j| x[(rows[i], j)]);
            let from_rows = h.get(k).expect("answered");
            let d = (&lifted - from_rows).norm_l2() / lifted.norm_l2();
            assert!(d <= 1e-9, "{f} Hz: {d:.2e}");
        }
    }

    /// The bar with the structural damping η₁K + (η₂ − η₁)K_far, a loss factor η₁ on the near half and η₂ on
    /// the far half, as K₄ (material-wise structural damping).
    fn two_loss_factors(eta1: f64, eta2: f64) -> impl FnOnce(&mut Model) {
        move |m: &mut Model| {
            let far = far_half_stiffness(m.n());
            m.structural = Structural {
                eta: 0.0,
                matrix: Some(linear_combination(
                    0.0,
                    &m.mass,
                    eta1,
                    &m.stiffness,
                    Some(&linear_combination(0.0, &far, eta2 - eta1, &far, None)),
                )),
            };
        }
    }

    /// A complex space's real basis holds the real and the imaginary parts of its vectors:
    /// on the test bar (N = 450) about twice the real space's 120, so the test asks for
    /// fewer than two thirds of the DoFs, not half.
    fn complex_max(body: &crate::body::Body) -> usize {
        2 * body.n() / 3
    }

    /// Structural damping makes K₀ = K + iG + s₀D + s₀²M complex: with material-wise viscous
    /// damping and a uniform loss factor, with Rayleigh damping and loss factors that differ
    /// by material, and with both material-wise, the complex space answers every frequency
    /// with certified responses equal to factored ones, none of them factored.
    #[test]
    fn structural_damping_is_answered_by_a_complex_space() {
        let freqs = [3.0, 117.0, 410.5, 640.0, 999.0];
        let check = |name: &str, (body, inputs): (crate::body::Body, Vec<usize>)| {
            assert!(
                body.pencil().proportional().is_none(),
                "{name}: proportional"
            );
            let d = krylov_vs_factored_within(&body, &inputs, &freqs, complex_max(&body));
            assert!(d <= 1e-8, "{name}: difference {d:.2e}");
        };
        check(
            "material-wise D, uniform eta",
            bar_with(|m| {
                two_materials(0.0, 1e-6, 1e-5)(m);
                m.structural = Structural {
                    eta: 0.02,
                    matrix: None,
                };
            }),
        );
        check(
            "Rayleigh D, material-wise K4",
            bar_with(|m| {
                m.damping = Damping::Rayleigh {
                    alpha: 0.0,
                    beta: 1e-5,
                };
                two_loss_factors(0.002, 0.02)(m);
            }),
        );
        check(
            "material-wise D and K4",
            bar_with(|m| {
                two_materials(3.0, 2e-5, 2e-6)(m);
                two_loss_factors(0.03, 0.001)(m);
            }),
        );
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(6))]
        /// Over loss factors and their ratios between the materials, with material-wise
        /// viscous damping.
        #[test]
        fn complex_space_responses_equal_factored_ones(
            eta1 in 1e-3f64..0.05,
            ratio in 0.1f64..10.0,
            f in 1.0f64..1000.0,
        ) {
            let (body, inputs) = bar_with(|m| {
                two_materials(0.0, 1e-6, 1e-5)(m);
                two_loss_factors(eta1, eta1 * ratio)(m);
            });
            let d = krylov_vs_factored_within(&body, &inputs, &[f, 0.5 * f], complex_max(&body));
            prop_assert!(d <= 1e-8, "difference {:.2e}", d);
        }
    }
}
