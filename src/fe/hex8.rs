//! The rectangular trilinear hexahedron (8 nodes) of the built-in models: its stiffness and
//! consistent mass for an isotropic linear-elastic material.
//!
//! **Element.** In natural coordinates $\xi = (\xi_1,\xi_2,\xi_3)\in[-1,1]^3$ the
//! eight trilinear shape functions are
//! $$N_a(\xi) = \tfrac18 (1+s_{a1}\xi_1)(1+s_{a2}\xi_2)(1+s_{a3}\xi_3),\qquad
//!   s_a\in\{-1,+1\}^3,$$
//! the local node $a = i_a + 2 j_a + 4 k_a$ sitting at $s_a = (2i_a-1, 2j_a-1, 2k_a-1)$.
//! The map to the element is affine, $x_d = x_{0d} + \tfrac{h_d}{2}(\xi_d+1)$, so the
//! Jacobian is $J = \mathrm{diag}(h/2)$, $\det J = h_xh_yh_z/8$ and
//! $\partial N_a/\partial x_d = (2/h_d)\,\partial N_a/\partial\xi_d$.
//!
//! **Strain.** With Voigt strain $\varepsilon = (\varepsilon_{xx}, \varepsilon_{yy},
//! \varepsilon_{zz}, \gamma_{xy}, \gamma_{yz}, \gamma_{zx})$ and $N_{a,d} =
//! \partial N_a/\partial x_d$, the $6\times 3$ block of node $a$ in $B$ ($6\times 24$) is
//! $$B_a = \begin{pmatrix} N_{a,x}&0&0\\ 0&N_{a,y}&0\\ 0&0&N_{a,z}\\
//!   N_{a,y}&N_{a,x}&0\\ 0&N_{a,z}&N_{a,y}\\ N_{a,z}&0&N_{a,x}\end{pmatrix}.$$
//!
//! **Material.** Isotropic, with Lamé constants $\lambda = E\nu/((1+\nu)(1-2\nu))$ and
//! $\mu = E/(2(1+\nu))$:
//! $$D = \begin{pmatrix}\lambda+2\mu&\lambda&\lambda&&&\\ \lambda&\lambda+2\mu&\lambda&&&\\
//!   \lambda&\lambda&\lambda+2\mu&&&\\ &&&\mu&&\\ &&&&\mu&\\ &&&&&\mu\end{pmatrix}.$$
//!
//! **Integration.** $2\times2\times2$ Gauss–Legendre: points $\xi_d = \pm 1/\sqrt3$, weights 1:
//! $$K_e = \sum_{g=1}^{8} B(\xi_g)^\top D\, B(\xi_g)\,\det J,\qquad
//!   M_e = \rho \sum_{g=1}^{8} N(\xi_g)^\top N(\xi_g)\,\det J \otimes I_3,$$
//! with $\rho = m/(L_xL_yL_z)$. Both are exact for the rectangular element (the integrands
//! are at most quadratic in each $\xi_d$); the mass is the *consistent* one, which equals
//! $\rho V_e/216\cdot\prod_d (1 + [s_{ad} = s_{bd}])$.
//! Full integration of the hexahedron is free of hourglass modes but stiff in bending
//! (shear locking): bending frequencies of a coarse mesh are overestimated.

/// Element matrices of the rectangular trilinear hexahedron (local node a = i + 2j + 4k).
#[derive(Debug, Clone)]
pub(super) struct Hex8 {
    /// 24×24 stiffness, DoF 3a + d; exactly symmetric.
    pub k: [[f64; 24]; 24],
    /// 8×8 scalar consistent mass (the 24×24 mass is this ⊗ I3); exactly symmetric.
    pub m: [[f64; 8]; 8],
}

impl Hex8 {
    // Index loops mirror the matrix formulas (B, D, Bᵀ D B) one to one.
    #[allow(clippy::needless_range_loop)]
    pub fn new(h: [f64; 3], young: f64, nu: f64, rho: f64) -> Self {
        let lambda = young * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        let mu = young / (2.0 * (1.0 + nu));
        let mut dmat = [[0.0; 6]; 6];
        for p in 0..3 {
            for q in 0..3 {
                dmat[p][q] = lambda;
            }
            dmat[p][p] = lambda + 2.0 * mu;
            dmat[p + 3][p + 3] = mu;
        }
        let det_j = h[0] * h[1] * h[2] / 8.0;
        let g = 1.0 / 3f64.sqrt();
        let sign = |a: usize, d: usize| if (a >> d) & 1 == 1 { 1.0 } else { -1.0 };

        let mut k = [[0.0; 24]; 24];
        let mut m = [[0.0; 8]; 8];
        for gp in 0..8 {
            let xi: [f64; 3] = std::array::from_fn(|d| sign(gp, d) * g);
            // Shape functions and their x-derivatives at the Gauss point.
            let mut shape = [0.0; 8];
            let mut grad = [[0.0; 3]; 8];
            for a in 0..8 {
                let f: [f64; 3] = std::array::from_fn(|d| 1.0 + sign(a, d) * xi[d]);
                shape[a] = f[0] * f[1] * f[2] / 8.0;
                for d in 0..3 {
                    let others: f64 = (0..3).filter(|&e| e != d).map(|e| f[e]).product();
                    grad[a][d] = sign(a, d) * others / 8.0 * (2.0 / h[d]);
                }
            }
            // B (6×24).
            let mut b = [[0.0; 24]; 6];
            for a in 0..8 {
                let [nx, ny, nz] = grad[a];
                let c = 3 * a;
                b[0][c] = nx;
                b[1][c + 1] = ny;
                b[2][c + 2] = nz;
                b[3][c] = ny;
                b[3][c + 1] = nx;
                b[4][c + 1] = nz;
                b[4][c + 2] = ny;
                b[5][c] = nz;
                b[5][c + 2] = nx;
            }
            // D B (6×24), then K += Bᵀ (D B) det J (weights are 1), upper triangle only.
            let mut db = [[0.0; 24]; 6];
            for p in 0..6 {
                for q in 0..24 {
                    db[p][q] = (0..6).map(|r| dmat[p][r] * b[r][q]).sum();
                }
            }
            for p in 0..24 {
                for q in p..24 {
                    let s: f64 = (0..6).map(|r| b[r][p] * db[r][q]).sum();
                    k[p][q] += s * det_j;
                }
            }
            for a in 0..8 {
                for bb in a..8 {
                    m[a][bb] += rho * shape[a] * shape[bb] * det_j;
                }
            }
        }
        // Mirror the upper triangle: exact symmetry.
        for p in 0..24 {
            for q in 0..p {
                k[p][q] = k[q][p];
            }
        }
        for a in 0..8 {
            for bb in 0..a {
                m[a][bb] = m[bb][a];
            }
        }
        Hex8 { k, m }
    }
}
