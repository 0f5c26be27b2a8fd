//! The built-in hex8 box generator (`sparsemor::fe`) checked against physics: mass and
//! inertia, rigid-body null space, a dense generalized eigen-analysis, and the analytic
//! axial frequency of the paper's bar.

use faer::linalg::solvers::Solve;
use faer::sparse::SparseColMat;
use faer::{Mat, Side};
use sparsemor::fe::{assemble, paper_io_dofs, BoxSpec, PAPER_BAND_HZ};
use sparsemor::rigid::rigid_modes;

/// `A · X` for a CSC `A` and a dense `X`, written out (no dependence on operator overloads).
fn spmm(a: &SparseColMat<usize, f64>, x: &Mat<f64>) -> Mat<f64> {
    let (sym, val) = a.parts();
    let (ptr, row) = (sym.col_ptr(), sym.row_idx());
    let mut y = Mat::<f64>::zeros(a.nrows(), x.ncols());
    for c in 0..x.ncols() {
        for j in 0..a.ncols() {
            let xj = x[(j, c)];
            for p in ptr[j]..ptr[j + 1] {
                y[(row[p], c)] += val[p] * xj;
            }
        }
    }
    y
}

fn frob_sparse(a: &SparseColMat<usize, f64>) -> f64 {
    a.parts().1.iter().map(|v| v * v).sum::<f64>().sqrt()
}

fn frob(a: &Mat<f64>) -> f64 {
    let mut s = 0.0;
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            s += a[(i, j)] * a[(i, j)];
        }
    }
    s.sqrt()
}

/// Every stored entry (r, c) has a stored twin (c, r) with the bit-identical value, and
/// row indices are strictly increasing in every column.
fn assert_exactly_symmetric(a: &SparseColMat<usize, f64>, name: &str) {
    let (sym, val) = a.parts();
    let (ptr, row) = (sym.col_ptr(), sym.row_idx());
    for c in 0..a.ncols() {
        let rows = &row[ptr[c]..ptr[c + 1]];
        assert!(
            rows.windows(2).all(|w| w[0] < w[1]),
            "{name}: column {c} not sorted"
        );
        for (p, &r) in rows.iter().enumerate() {
            let twin = &row[ptr[r]..ptr[r + 1]];
            let q = twin
                .binary_search(&c)
                .unwrap_or_else(|_| panic!("{name}: ({r},{c}) stored but ({c},{r}) is not"));
            assert_eq!(
                val[ptr[c] + p].to_bits(),
                val[ptr[r] + q].to_bits(),
                "{name}: ({r},{c}) != ({c},{r})"
            );
        }
    }
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// The dense generalized symmetric eigenproblem K φ = λ M φ in standard form: with
/// M = L Lᵀ, A = L⁻¹ K L⁻ᵀ has the same eigenvalues, and φ = L⁻ᵀ z for A z = λ z.
struct DenseStandardForm {
    /// Cholesky factor of M.
    l: Mat<f64>,
    /// L⁻¹ K L⁻ᵀ, symmetrized.
    a: Mat<f64>,
    /// Eigenvalues of A, ascending.
    lambda: Vec<f64>,
}

impl DenseStandardForm {
    fn new(k: &SparseColMat<usize, f64>, m: &SparseColMat<usize, f64>) -> Self {
        let l = m
            .to_dense()
            .llt(Side::Lower)
            .expect("M must be positive definite")
            .L()
            .to_owned();
        let mut x = k.to_dense();
        l.solve_lower_triangular_in_place(&mut x); // L⁻¹ K
        let mut a = x.transpose().to_owned();
        l.solve_lower_triangular_in_place(&mut a); // L⁻¹ K L⁻ᵀ
        let n = a.nrows();
        let a = Mat::<f64>::from_fn(n, n, |i, j| 0.5 * (a[(i, j)] + a[(j, i)]));
        // Eigenvalues only: faer 0.24.4's `self_adjoint_eigen` (with vectors) returns a
        // decomposition with ||AU - US|| / ||A|| ~ 5e-4 on this matrix (rigid modes come
        // out at -2.6e4 and a spurious mode at 137 Hz), while the values-only path is
        // accurate (|λ_rigid| ~ 1e-15 λ_max). Vectors come from inverse iteration instead.
        let lambda = a
            .self_adjoint_eigenvalues(Side::Lower)
            .expect("eigenvalues");
        DenseStandardForm { l, a, lambda }
    }

    /// The eigenvector φ (M-normalized) of eigenvalue `lambda[j]` by two steps of inverse
    /// iteration on A − σI, σ 1e-11·λ_max off λ_j; also returns the relative residual
    /// ||A z − λ_j z|| / ||A||_F, which certifies λ_j independently of the eigensolver.
    fn mode(&self, j: usize) -> (Mat<f64>, f64) {
        let n = self.a.nrows();
        let lam = self.lambda[j];
        let scale = self.lambda.last().unwrap().abs();
        let sigma = lam + 1e-11 * scale.max(1.0) * if lam >= 0.0 { 1.0 } else { -1.0 };
        let shifted = Mat::<f64>::from_fn(n, n, |r, c| {
            self.a[(r, c)] - if r == c { sigma } else { 0.0 }
        });
        let fact = shifted.lblt(Side::Lower);
        let mut z = Mat::<f64>::from_fn(n, 1, |i, _| 1.0 + ((i * 7919) % 104) as f64 / 104.0);
        for _ in 0..3 {
            fact.solve_in_place(&mut z);
            let nz = frob(&z);
            for i in 0..n {
                z[(i, 0)] /= nz;
            }
        }
        let mut r = &self.a * &z;
        for i in 0..n {
            r[(i, 0)] -= lam * z[(i, 0)];
        }
        let res = frob(&r) / frob(&self.a);
        let mut phi = z;
        self.l.transpose().solve_upper_triangular_in_place(&mut phi);
        (phi, res)
    }
}

fn fmt_e(v: &[f64]) -> String {
    let parts: Vec<String> = v.iter().map(|x| format!("{x:.2e}")).collect();
    format!("[{}]", parts.join(", "))
}

fn hz(lambda: f64) -> f64 {
    lambda.max(0.0).sqrt() / (2.0 * std::f64::consts::PI)
}

#[test]
fn paper_bar_size_mass_symmetry() {
    let spec = BoxSpec::paper_bar();
    let body = assemble(&spec).unwrap();
    let n = spec.n_dofs();
    assert_eq!(n, 1656);
    assert_eq!(body.mass.nrows(), n);
    assert_eq!(body.stiffness.ncols(), n);
    assert_eq!(body.nodes.len(), 552);

    assert_exactly_symmetric(&body.mass, "M");
    assert_exactly_symmetric(&body.stiffness, "K");

    // Total mass per direction: sum of M over the rows and columns of the d-DoFs.
    let (sym, val) = body.mass.parts();
    let mut per_dir = [0.0f64; 3];
    let mut diag_ok = vec![false; n];
    for c in 0..n {
        let range = sym.col_ptr()[c]..sym.col_ptr()[c + 1];
        for (&r, &v) in sym.row_idx()[range.clone()].iter().zip(&val[range]) {
            if r % 3 == c % 3 {
                per_dir[c % 3] += v;
            } else {
                assert_eq!(v, 0.0, "M couples different directions at ({r},{c})");
            }
            if r == c {
                diag_ok[c] = v > 0.0;
            }
        }
    }
    for (d, m) in per_dir.iter().enumerate() {
        assert!(rel(*m, 0.1) <= 1e-12, "direction {d}: total mass {m}");
    }
    assert!(
        diag_ok.iter().all(|&b| b),
        "M diagonal must be stored and > 0"
    );
}

#[test]
fn paper_bar_rigid_modes_null_space_and_inertia() {
    let spec = BoxSpec::paper_bar();
    let body = assemble(&spec).unwrap();
    let v0 = rigid_modes(&body.nodes, 3);
    assert_eq!((v0.nrows(), v0.ncols()), (1656, 6));

    let kv = spmm(&body.stiffness, &v0);
    let ratio = frob(&kv) / (frob_sparse(&body.stiffness) * frob(&v0));
    println!("||K V0||_F / (||K||_F ||V0||_F) = {ratio:.3e}");
    assert!(
        ratio <= 1e-10,
        "rigid modes not in the null space of K: {ratio:e}"
    );

    // V0ᵀ M V0 = diag(m, m, m) ⊕ inertia tensor about the centroid of a homogeneous box.
    let mv = spmm(&body.mass, &v0);
    let m0 = v0.transpose() * &mv;
    let m = spec.mass_kg;
    let [a, b, c] = spec.size_m;
    let mut expect = [[0.0; 6]; 6];
    for (d, row) in expect.iter_mut().enumerate().take(3) {
        row[d] = m;
    }
    expect[3][3] = m * (b * b + c * c) / 12.0;
    expect[4][4] = m * (a * a + c * c) / 12.0;
    expect[5][5] = m * (a * a + b * b) / 12.0;
    println!("V0^T M V0 =");
    for i in 0..6 {
        let row: Vec<String> = (0..6).map(|j| format!("{:12.5e}", m0[(i, j)])).collect();
        println!("  {}", row.join(" "));
    }
    for i in 0..6 {
        for j in 0..6 {
            let scale = (expect[i][i] * expect[j][j]).sqrt();
            let err = (m0[(i, j)] - expect[i][j]).abs() / scale;
            assert!(
                err <= 1e-12,
                "V0^T M V0 ({i},{j}) = {} vs {}",
                m0[(i, j)],
                expect[i][j]
            );
        }
    }
}

#[test]
fn small_boxes_have_exactly_six_rigid_modes() {
    for elements in [[1, 1, 2], [2, 2, 4]] {
        let spec = BoxSpec {
            elements,
            size_m: [0.02, 0.03, 0.1],
            mass_kg: 0.5,
            young_pa: 7e10,
            poisson: 0.33,
        };
        let body = assemble(&spec).unwrap();
        let lambda = DenseStandardForm::new(&body.stiffness, &body.mass).lambda;
        let lmax = *lambda.last().unwrap();
        let zero = lambda.iter().filter(|l| l.abs() <= 1e-8 * lmax).count();
        println!(
            "{elements:?}: N = {}, lambda_max = {lmax:.3e}, lowest = {}",
            lambda.len(),
            fmt_e(&lambda[..8])
        );
        assert_eq!(zero, 6, "{elements:?}: {zero} near-zero eigenvalues");
        assert!(
            lambda[6] > 1e-8 * lmax,
            "{elements:?}: 7th eigenvalue {}",
            lambda[6]
        );
    }
}

#[test]
fn paper_bar_dense_spectrum() {
    let spec = BoxSpec::paper_bar();
    let body = assemble(&spec).unwrap();
    let dense = DenseStandardForm::new(&body.stiffness, &body.mass);
    let lambda = &dense.lambda;
    let lmax = *lambda.last().unwrap();

    // Six rigid modes at rounding level. On this mesh the first elastic λ is ~1e-7 λ_max,
    // so the usual 1e-8 λ_max threshold would be too close; the rigid λ are ~1e-15 λ_max.
    println!("lambda_max = {lmax:.4e} (f_max = {:.1} Hz)", hz(lmax));
    println!("six lowest lambda: {}", fmt_e(&lambda[..6]));
    for (i, l) in lambda[..6].iter().enumerate() {
        assert!(
            l.abs() <= 1e-12 * lmax,
            "mode {i}: lambda = {l:e} is not rigid"
        );
    }
    assert!(lambda[6] > 1e-8 * lmax, "7th lambda {}", lambda[6]);

    // z-share of a mode's kinetic energy (M has no direction coupling, so φᵀ M φ splits
    // exactly into x, y, z parts).
    let z_share = |phi: &Mat<f64>| -> f64 {
        let mphi = spmm(&body.mass, phi);
        let (mut z, mut all) = (0.0, 0.0);
        for i in 0..phi.nrows() {
            let e = phi[(i, 0)] * mphi[(i, 0)];
            all += e;
            if i % 3 == 2 {
                z += e;
            }
        }
        z / all
    };

    // Elastic modes in the paper band [0, 1000] Hz.
    let in_band: Vec<usize> = (6..lambda.len())
        .filter(|&j| hz(lambda[j]) >= PAPER_BAND_HZ[0] && hz(lambda[j]) <= PAPER_BAND_HZ[1])
        .collect();
    println!("elastic eigenfrequencies (Hz), inverse-iteration residual, z-energy share:");
    let n_show = in_band.last().map_or(8, |&j| j + 3);
    for (j, &lam) in lambda.iter().enumerate().take(n_show).skip(6) {
        let (phi, res) = dense.mode(j);
        println!(
            "  mode {:2}: {:9.2} Hz  residual {res:.1e}  z-share {:.3}{}",
            j + 1,
            hz(lam),
            z_share(&phi),
            if in_band.contains(&j) {
                "  (in band)"
            } else {
                ""
            }
        );
        assert!(
            res <= 1e-12,
            "mode {j}: eigenvalue not confirmed, residual {res:e}"
        );
    }
    println!(
        "elastic modes in [0, 1000] Hz: {} (paper: 6)",
        in_band.len()
    );
    assert_eq!(
        in_band.len(),
        6,
        "elastic eigenfrequencies in the paper band"
    );

    // First axial (longitudinal) free-free mode: f = sqrt(E/ρ) / (2L). Candidates: the
    // modes within ±25 % of it; the axial one is the candidate with the largest z-share.
    let rho = spec.density();
    let f_axial = (spec.young_pa / rho).sqrt() / (2.0 * spec.size_m[2]);
    let (j_axial, share, res) = (6..lambda.len())
        .filter(|&j| (hz(lambda[j]) / f_axial - 1.0).abs() <= 0.25)
        .map(|j| {
            let (phi, res) = dense.mode(j);
            (j, z_share(&phi), res)
        })
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .expect("no mode within 25 % of the analytic axial frequency");
    let f_fe = hz(lambda[j_axial]);
    let dev = f_fe / f_axial - 1.0;
    println!(
        "axial: FE mode {} at {f_fe:.2} Hz (z-share {share:.4}, residual {res:.1e}), \
         analytic {f_axial:.2} Hz, relative deviation {dev:+.3e}",
        j_axial + 1
    );
    assert!(
        share > 0.9,
        "no clearly longitudinal mode (best z-share {share})"
    );
    // Tolerance 1e-3: with 45 linear elements and consistent mass the 1-D rod estimate of
    // the discretisation error is +(πh/L)²/24 ≈ +2.0e-4 (consistent mass overestimates);
    // the lateral (Poisson) inertia of Rayleigh–Love theory lowers f by ν²π²r_p²/(2L²)
    // ≈ −4e-5 (r_p² = (a²+b²)/12). Both are well inside 1e-3, which still catches any
    // error in E, ρ, L or the mass matrix (those show up at the percent level).
    assert!(dev.abs() <= 1e-3, "axial frequency off by {dev:e}");
}

#[test]
fn paper_io_dofs_exact() {
    let spec = BoxSpec::paper_bar();
    let mid = spec.node_index(0, 0, 22);
    let top = spec.node_index(0, 0, 45);
    assert_eq!((mid, top), (22 * 3 * 4, 45 * 3 * 4));
    assert_eq!(
        paper_io_dofs(&spec),
        vec![0, 1, 2, 792, 793, 794, 1620, 1621, 1622]
    );
    let body = assemble(&spec).unwrap();
    assert_eq!(body.nodes[0], [0.0, 0.0, 0.0]);
    assert!((body.nodes[mid][2] - 0.3 * 22.0 / 45.0).abs() < 1e-15);
    assert_eq!(body.nodes[top], [0.0, 0.0, 0.3]);
}
