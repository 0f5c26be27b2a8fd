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

use crate::model::{Damping, Model};
use crate::sparse::lower_triangle;
use faer::{c64, MatMut, MatRef};

/// Lower-triangle union pattern of M, K, D with per-matrix coefficient arrays.
#[derive(Clone, Debug)]
pub struct Pencil {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    m: Vec<f64>,
    k: Vec<f64>,
    d: DampingValues,
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
        Pencil {
            n,
            col_ptr,
            row_idx,
            m,
            k,
            d,
        }
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

    /// True when D = 0: A(iω) = K − ω²M is real.
    pub fn is_real(&self) -> bool {
        matches!(self.d, DampingValues::Zero)
    }

    /// The stiffness values on the pattern (A(0) = K).
    pub fn stiffness_values(&self) -> &[f64] {
        &self.k
    }

    /// max_i |K_ii| (the first entry of each column is its diagonal).
    pub fn stiffness_diagonal_max(&self) -> f64 {
        (0..self.n)
            .filter(|&j| {
                self.col_ptr[j] < self.col_ptr[j + 1] && self.row_idx[self.col_ptr[j]] == j
            })
            .map(|j| self.k[self.col_ptr[j]].abs())
            .fold(0.0, f64::max)
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

    /// re ← K − ω²M, im ← ωD: the values of A(iω) ([`Self::value`] of every entry).
    pub fn fill_complex(&self, omega: f64, re: &mut [f64], im: &mut [f64]) {
        for (p, (r, i)) in re.iter_mut().zip(im.iter_mut()).enumerate() {
            let v = self.value(omega, p);
            (*r, *i) = (v.re, v.im);
        }
    }

    /// Entry `p` of A(iω) on the lower pattern: K − ω²M (as [`Self::fill_real`]) + i ωD, with
    /// ωD = (ωα)M + (ωβ)K for Rayleigh damping. The factorizations that read the values once
    /// compute them here instead of keeping a copy per frequency.
    #[inline]
    pub fn value(&self, omega: f64, p: usize) -> c64 {
        let (k, m) = (self.k[p], self.m[p]);
        let im = match &self.d {
            DampingValues::Zero => 0.0,
            DampingValues::Rayleigh { alpha, beta } => (omega * alpha) * m + (omega * beta) * k,
            DampingValues::Matrix(d) => omega * d[p],
        };
        c64::new(k - (omega * omega) * m, im)
    }

    /// y ← A(iω) x for the symmetric A stored by its lower triangle.
    pub fn apply(&self, omega: f64, x: MatRef<'_, c64>, mut y: MatMut<'_, c64>) {
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
