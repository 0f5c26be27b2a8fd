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

/// A diag(d_f) C for each frequency f, for real A (m × k) and C (k × p) and complex rows d_f
/// (length k) that `row(f, d_f)` writes: `visit(f, d_f, re, im, slot)` gets d_f, the
/// product's real and imaginary parts (length mp, entry (i, c) at c·m + i, column-major as a
/// faer matrix) and the f-th `width` entries of `out`, whose length sets the number of
/// frequencies. With E[c·m + i, j] = A[i, j] C[j, c] (mp × k) a block of frequencies takes
/// two real products, E (Re Dᵀ) and E (Im Dᵀ), instead of two small ones per frequency. The
/// blocks are sized so that each product stays within 128 KiB, in cache, and run on rayon's
/// threads, each thread reusing its buffers; a frequency's numbers do not depend on the
/// thread count (on the paper bar, 2000 frequencies at m = p = 9, k = 14: 3.4 ms in one
/// block, 1.6 ms in blocks on one thread).
pub fn scaled_products_into<T: Send>(
    a: MatRef<'_, f64>,
    c: MatRef<'_, f64>,
    row: impl Fn(usize, &mut [c64]) + Sync,
    out: &mut [T],
    width: usize,
    visit: impl Fn(usize, &[c64], &[f64], &[f64], &mut [T]) + Sync,
) {
    use rayon::prelude::*;
    let (m, p, k) = (a.nrows(), c.ncols(), a.ncols());
    let mp = m * p;
    if width == 0 || out.is_empty() {
        return;
    }
    let e = Mat::<f64>::from_fn(mp, k, |ci, j| a[(ci % m, j)] * c[(j, ci / m)]);
    let block = (SCALED_BLOCK_BYTES / (8 * mp.max(1))).max(1);
    out.par_chunks_mut(block * width).enumerate().for_each_init(
        || Block {
            d: Vec::new(),
            re: Mat::new(),
            im: Mat::new(),
        },
        |buf, (b, slots)| {
            let (start, len) = (b * block, slots.len() / width);
            buf.d.resize(len * k, c64::new(0.0, 0.0));
            for (i, d) in buf.d.chunks_exact_mut(k.max(1)).enumerate().take(len) {
                row(start + i, d);
            }
            for (part, out) in [(0, &mut buf.re), (1, &mut buf.im)] {
                out.resize_with(mp, len, |_, _| 0.0);
                let dt = Mat::<f64>::from_fn(k, len, |j, i| match part {
                    0 => buf.d[i * k + j].re,
                    _ => buf.d[i * k + j].im,
                });
                faer::linalg::matmul::matmul(
                    out.as_mut(),
                    faer::Accum::Replace,
                    e.as_ref(),
                    dt.as_ref(),
                    1.0,
                    faer::Par::Seq,
                );
            }
            for (i, slot) in slots.chunks_exact_mut(width).enumerate() {
                visit(
                    start + i,
                    &buf.d[i * k..(i + 1) * k],
                    buf.re.col_as_slice(i),
                    buf.im.col_as_slice(i),
                    slot,
                );
            }
        },
    );
}

/// One thread's buffers of [`scaled_products_into`]: a block's rows of D and its products.
struct Block {
    d: Vec<c64>,
    re: Mat<f64>,
    im: Mat<f64>,
}

/// The most bytes one real part of a block of [`scaled_products_into`] takes.
const SCALED_BLOCK_BYTES: usize = 128 << 10;

/// Complex m × p matrices, one per frequency, in one allocation (each column-major): many
/// frequencies' responses without an allocation per frequency (2000 of them at m = p = 9
/// took 2.7 ms to allocate as matrices, against 1.7 ms for the products themselves).
#[derive(Debug, Default)]
pub struct MatStack {
    m: usize,
    p: usize,
    data: Vec<c64>,
}

impl MatStack {
    /// A diag(d_f) C for `freqs` frequencies, d_f written by `row(f, d_f)`
    /// ([`scaled_products_into`]).
    pub fn scaled_products(
        a: MatRef<'_, f64>,
        c: MatRef<'_, f64>,
        freqs: usize,
        row: impl Fn(usize, &mut [c64]) + Sync,
    ) -> Self {
        let (m, p) = (a.nrows(), c.ncols());
        let mut data = vec![c64::new(0.0, 0.0); m * p * freqs];
        scaled_products_into(a, c, row, &mut data, m * p, |_, _, re, im, out| {
            for ((z, &r), &i) in out.iter_mut().zip(re).zip(im) {
                *z = c64::new(r, i);
            }
        });
        MatStack { m, p, data }
    }

    /// The `count` m × p matrices `f(k)`, k = 0..count.
    pub fn from_fn(m: usize, p: usize, count: usize, f: impl Fn(usize) -> Mat<c64>) -> Self {
        let mut data = Vec::with_capacity(m * p * count);
        for k in 0..count {
            let x = f(k);
            debug_assert_eq!((x.nrows(), x.ncols()), (m, p));
            data.extend(
                x.col_iter()
                    .flat_map(|c| c.iter().copied().collect::<Vec<_>>()),
            );
        }
        MatStack { m, p, data }
    }

    /// The number of matrices.
    pub fn len(&self) -> usize {
        self.data.len() / (self.m * self.p).max(1)
    }

    /// Whether the stack holds no matrix.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// The k-th matrix.
    pub fn get(&self, k: usize) -> MatRef<'_, c64> {
        let mp = self.m * self.p;
        MatRef::from_column_major_slice(&self.data[k * mp..(k + 1) * mp], self.m, self.p)
    }
}

/// The complex m × p matrix whose real and imaginary parts are `re` and `im`, entry (i, c)
/// at c·m + i (the layout of [`scaled_products_into`]).
pub fn from_parts(m: usize, p: usize, re: &[f64], im: &[f64]) -> Mat<c64> {
    Mat::from_fn(m, p, |i, c| c64::new(re[c * m + i], im[c * m + i]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::Xorshift;

    /// A diag(d_f) C for one frequency, entry by entry.
    fn product(a: &Mat<f64>, d: &Mat<c64>, c: &Mat<f64>, f: usize) -> Mat<c64> {
        Mat::from_fn(a.nrows(), c.ncols(), |i, col| {
            (0..a.ncols())
                .map(|j| d[(f, j)] * (a[(i, j)] * c[(j, col)]))
                .sum()
        })
    }

    /// Random A (m × k), C (k × p) and D (nf × k, complex).
    fn operands(m: usize, k: usize, p: usize, nf: usize) -> (Mat<f64>, Mat<c64>, Mat<f64>) {
        let mut rng = Xorshift::new(7);
        let a = Mat::<f64>::from_fn(m, k, |_, _| rng.next_centred());
        let c = Mat::<f64>::from_fn(k, p, |_, _| rng.next_centred());
        let d = Mat::<c64>::from_fn(nf, k, |_, _| {
            c64::new(rng.next_centred(), rng.next_centred())
        });
        (a, d, c)
    }

    /// `row` writing the rows of D.
    fn row_of(d: &Mat<c64>) -> impl Fn(usize, &mut [c64]) + Sync + '_ {
        |f, out| out.iter_mut().enumerate().for_each(|(j, x)| *x = d[(f, j)])
    }

    fn assert_close(got: MatRef<'_, c64>, want: &Mat<c64>, f: usize) {
        assert_eq!((got.nrows(), got.ncols()), (want.nrows(), want.ncols()));
        for i in 0..want.nrows() {
            for col in 0..want.ncols() {
                let (g, w) = (got[(i, col)], want[(i, col)]);
                assert!((g - w).norm() <= 1e-13 * (1.0 + w.norm()), "{f}: {g} {w}");
            }
        }
    }

    /// Every frequency, across several blocks and the last partial one, gets A diag(d_f) C
    /// as a per-frequency product computes it, in ascending order.
    #[test]
    fn blockwise_products_equal_each_frequencys_own() {
        let (m, k, p, nf) = (9, 14, 9, 1000);
        let (a, d, c) = operands(m, k, p, nf);
        assert!(nf * 8 * m * p > 3 * SCALED_BLOCK_BYTES);
        let mut seen = vec![0usize; nf];
        scaled_products_into(
            a.as_ref(),
            c.as_ref(),
            row_of(&d),
            &mut seen,
            1,
            |f, df, re, im, slot| {
                assert!((0..k).all(|j| df[j] == d[(f, j)]), "{f}: d_f");
                assert_close(
                    from_parts(m, p, re, im).as_ref(),
                    &product(&a, &d, &c, f),
                    f,
                );
                slot[0] += 1;
            },
        );
        assert!(seen.iter().all(|&n| n == 1));
    }

    /// A frequency's product does not depend on the thread count: the blocks are the same
    /// on any pool, bit for bit.
    #[test]
    fn products_are_the_same_on_any_thread_count() {
        let (m, k, p, nf) = (9, 14, 9, 1000);
        let (a, d, c) = operands(m, k, p, nf);
        let on = |threads: usize| {
            crate::pool::with_pool(threads, || {
                MatStack::scaled_products(a.as_ref(), c.as_ref(), nf, row_of(&d))
            })
            .unwrap()
        };
        let (one, three) = (on(1), on(3));
        assert!((0..nf).all(|f| one.get(f) == three.get(f)));
    }

    /// The stack holds each frequency's product, rows and columns in place (m ≠ p), across
    /// several blocks.
    #[test]
    fn a_stack_holds_each_frequencys_product() {
        let (m, k, p, nf) = (5, 11, 3, 4000);
        let (a, d, c) = operands(m, k, p, nf);
        assert!(nf * 8 * m * p > 3 * SCALED_BLOCK_BYTES);
        let stack = MatStack::scaled_products(a.as_ref(), c.as_ref(), nf, row_of(&d));
        assert_eq!(stack.len(), nf);
        for f in 0..nf {
            assert_close(stack.get(f), &product(&a, &d, &c, f), f);
        }
    }
}
