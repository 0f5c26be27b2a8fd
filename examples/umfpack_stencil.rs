//! Times UMFPACK symbolic/numeric/solve on a 3-D 27-point-stencil pattern.
//!
//! `cargo run --release --features umfpack --example umfpack_stencil -- [m] [amd|metis]
//! [real|complex|both]` uses an `m x m x m` grid (default 46, i.e. 97 336 unknowns), the
//! given ordering (default amd, UMFPACK's default) and value kinds (default both).

use sparsemor::factor::umfpack::{UmfpackNumeric, UmfpackOrdering, UmfpackSymbolic};
use std::time::Instant;

fn main() -> sparsemor::Result<()> {
    let m: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(46);
    let ordering = match std::env::args().nth(2).as_deref() {
        Some("metis") => UmfpackOrdering::Metis,
        Some("cholmod") => UmfpackOrdering::Cholmod,
        Some("best") => UmfpackOrdering::Best,
        _ => UmfpackOrdering::Amd,
    };
    let kinds: &[bool] = match std::env::args().nth(3).as_deref() {
        Some("real") => &[false],
        Some("complex") => &[true],
        _ => &[false, true],
    };
    let n = m * m * m;
    let id = |x: usize, y: usize, z: usize| (z * m + y) * m + x;

    // CSC pattern (rows sorted within each column) with real and complex values:
    // real  A = 27-point "Laplacian" shifted to be nonsingular, slightly nonsymmetric;
    // complex A = K - w^2 M + i w C style (diagonal and off-diagonal imaginary parts).
    let (mut col_ptr, mut row_idx) = (Vec::with_capacity(n + 1), Vec::with_capacity(27 * n));
    let (mut re_r, mut re_c, mut im_c) = (Vec::new(), Vec::new(), Vec::new());
    col_ptr.push(0);
    for z in 0..m {
        for y in 0..m {
            for x in 0..m {
                let j = id(x, y, z);
                for dz in -1i64..=1 {
                    for dy in -1i64..=1 {
                        for dx in -1i64..=1 {
                            let (xx, yy, zz) = (x as i64 + dx, y as i64 + dy, z as i64 + dz);
                            let mi = m as i64;
                            if xx < 0 || yy < 0 || zz < 0 || xx >= mi || yy >= mi || zz >= mi {
                                continue;
                            }
                            let i = id(xx as usize, yy as usize, zz as usize);
                            row_idx.push(i);
                            if i == j {
                                re_r.push(26.5);
                                re_c.push(26.0 - 3.0);
                                im_c.push(0.4);
                            } else {
                                let skew = if i < j { 0.02 } else { -0.02 };
                                re_r.push(-1.0 + skew);
                                re_c.push(-1.0 + skew);
                                im_c.push(-0.01);
                            }
                        }
                    }
                }
                col_ptr.push(row_idx.len());
            }
        }
    }
    println!("n = {n}, nnz = {}, ordering {ordering:?}", row_idx.len());

    for &complex in kinds {
        let t = Instant::now();
        let sym = UmfpackSymbolic::with_ordering(n, &col_ptr, &row_idx, complex, ordering)?;
        let t_sym = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let num = if complex {
            UmfpackNumeric::complex(&sym, &re_c, &im_c)?
        } else {
            UmfpackNumeric::real(&sym, &re_r)?
        };
        let t_num = t.elapsed().as_secs_f64();
        let b: Vec<f64> = (0..n).map(|i| ((i % 7) as f64) - 3.0).collect();
        let (mut xr, mut xi) = (vec![0.0; n], vec![0.0; n]);
        let t = Instant::now();
        let si = if complex {
            num.solve_complex_info(&b, &b, &mut xr, &mut xi)?
        } else {
            num.solve_real_info(&b, &mut xr)?
        };
        let t_sol = t.elapsed().as_secs_f64();
        println!(
            "{}: symbolic {t_sym:.2} s, numeric {t_num:.2} s (UMFPACK wall {:.2} s, {:.2} GFlop), \
             solve {t_sol:.3} s (IR steps {}, omega1 {:.1e}), rcond {:.2e}, LU nnz {:.3e}, \
             peak {:.2} GiB, singular {}",
            if complex { "complex" } else { "real" },
            num.walltime(),
            num.flops() * 1e-9,
            si.ir_steps,
            si.omega1,
            num.rcond(),
            num.lu_nnz() as f64,
            num.peak_memory_bytes() / (1u64 << 30) as f64,
            num.status_singular(),
        );
    }
    Ok(())
}
