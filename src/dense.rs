//! Small dense symmetric matrices — projected, reduced and Ritz matrices of order up to a few
//! hundred: their symmetric part and their eigendecomposition; and the modal superpositions
//! A diag(d) C of such a decomposition at many frequencies at once.
//!
//! **Why a wrapper.** faer 0.24 computes symmetric eigenvectors by tridiagonal divide and
//! conquer from order 128 on, and deflates there with the tolerance 8ε·max(|d|_max, |z|_max),
//! where z is a *unit* vector: the tolerance is absolute, about 2e-15, while LAPACK's `dstedc`
//! first scales the tridiagonal matrix to unit norm. For a matrix of norm 1e-9 (the Ritz
//! matrix of S = (K − σM)⁻¹M in SI units) it merges eigenvalues that differ by 1e-6 of the
//! norm and returns vectors with residuals ‖Ty − θy‖ ≈ 1e-6‖T‖ (measured: 1.7e-6 on a
//! 148 × 148 Ritz matrix of the 14³ cube; 1.1e-15 after scaling). Every
//! matrix is therefore scaled to max |a_ij| = 1 before the decomposition and the eigenvalues
//! scaled back — exact in binary floating point up to the one rounding of the scale factor.

use faer::{c64, Mat, MatRef, Side};

/// sym(A) = ½(A + Aᵀ) of a small dense square matrix.
pub fn sym(a: MatRef<'_, f64>) -> Mat<f64> {
    Mat::from_fn(a.nrows(), a.ncols(), |i, j| 0.5 * (a[(i, j)] + a[(j, i)]))
}

/// Eigenvalues (ascending) and orthonormal eigenvectors of sym(A); `None` when the dense
/// eigensolver does not converge (or A holds a NaN).
pub fn sym_eigen(a: MatRef<'_, f64>) -> Option<(Vec<f64>, Mat<f64>)> {
    let (scaled, scale) = scaled_sym(a);
    let e = scaled.self_adjoint_eigen(Side::Lower).ok()?;
    let values = (0..e.S().dim()).map(|i| e.S()[i] * scale).collect();
    Some((values, e.U().to_owned()))
}

/// Eigenvalues (ascending) of sym(A); `None` when the dense eigensolver does not converge.
pub fn sym_eigenvalues(a: MatRef<'_, f64>) -> Option<Vec<f64>> {
    let (scaled, scale) = scaled_sym(a);
    let values = scaled.self_adjoint_eigenvalues(Side::Lower).ok()?;
    Some(values.into_iter().map(|v| v * scale).collect())
}

/// sym(A)/s and s = max |a_ij| (s = 1 for a zero or non-finite maximum, which the
/// decomposition then reports or returns as is).
fn scaled_sym(a: MatRef<'_, f64>) -> (Mat<f64>, f64) {
    let mut max = 0.0f64;
    for j in 0..a.ncols() {
        for x in a.col(j).iter() {
            max = max.max(x.abs());
        }
    }
    let s = if max > 0.0 && max.is_finite() {
        max
    } else {
        1.0
    };
    (sym(a) * (1.0 / s), s)
}

/// A diag(d_f) C for each row d_f of D (frequencies × k, complex), for real A (m × k) and
/// C (k × p), as two real matrices (mp × frequencies: column f holds the product's real or
/// imaginary part, entry (i, c) at row i·p + c): with E[i·p + c, j] = A[i, j] C[j, c]
/// (mp × k) they are E (Re Dᵀ) and E (Im Dᵀ), so every frequency costs a share of two real
/// products instead of two small ones of its own, and reads its own contiguous column.
pub fn scaled_product_parts(
    a: MatRef<'_, f64>,
    d: &Mat<c64>,
    c: MatRef<'_, f64>,
) -> (Mat<f64>, Mat<f64>) {
    let (p, k) = (c.ncols(), a.ncols());
    let e = Mat::<f64>::from_fn(a.nrows() * p, k, |ic, j| a[(ic / p, j)] * c[(j, ic % p)]);
    let re = &e * Mat::<f64>::from_fn(k, d.nrows(), |j, f| d[(f, j)].re);
    let im = &e * Mat::<f64>::from_fn(k, d.nrows(), |j, f| d[(f, j)].im);
    (re, im)
}

/// [`scaled_product_parts`] as one complex m × p matrix per frequency.
pub fn scaled_products(a: MatRef<'_, f64>, d: &Mat<c64>, c: MatRef<'_, f64>) -> Vec<Mat<c64>> {
    let (m, p) = (a.nrows(), c.ncols());
    let (re, im) = scaled_product_parts(a, d, c);
    (0..d.nrows())
        .map(|f| {
            let (re, im) = (re.col(f), im.col(f));
            Mat::from_fn(m, p, |i, col| c64::new(re[i * p + col], im[i * p + col]))
        })
        .collect()
}
