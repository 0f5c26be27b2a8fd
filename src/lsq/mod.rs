//! Line-fitting least squares with a streamed QR / TSQR state (docs/design.md §3.3, paper eq. 18–22).
//!
//! # Problem
//!
//! The line-fitting matrix `W` (m × n, m = N − n non-interface DoFs, n interface DoFs) solves
//!
//! ```text
//!     min_W ‖T_oᵀ Wᵀ − T_nᵀ‖_F,    T_oᵀ = [G_1; …; G_z]  (rows × n),
//!                                   T_nᵀ = [F_1; …; F_z]  (rows × m),
//! ```
//!
//! where block k holds the q_k = 2p rows of frequency k (real and imaginary parts of the
//! snapshot). `rows = Σ q_k = 2pz` is small (tens to thousands), `n` is small (≤ a few hundred)
//! but `m` can be 10⁶–10⁷, so the stacked `T_nᵀ` is never formed.
//!
//! # State and invariant
//!
//! A [`StreamedQr`] holds `R` (n × n upper triangular), `Y` (n × m) and `e` (m).
//! After blocks with `rows` rows in total have been absorbed there is an orthogonal `Q` (never
//! stored) with
//!
//! ```text
//!     Qᵀ [0    0  ]   [R  Y]
//!        [T_oᵀ T_nᵀ] = [0  B],     e_j = ‖B e_j‖²
//! ```
//!
//! (the leading n zero rows are the empty starting state). Because `Q` is orthogonal, for every
//! column j and every x ∈ Rⁿ:  ‖T_oᵀ x − T_nᵀ e_j‖² = ‖R x − Y e_j‖² + e_j. So `R`, `Y`, `e`
//! carry everything the least-squares problem needs, in O(n·m) memory. In particular
//! `‖T_nᵀ e_j‖² = ‖Y e_j‖² + e_j` (x = 0), so the column norms of `T_nᵀ` that the relative
//! residual needs are not accumulated separately: a sum of two nonnegative terms, as accurate
//! as accumulating ‖F e_j‖² block by block, and 8·m bytes and one pass per block cheaper.
//!
//! * [`StreamedQr::absorb`] — Householder QR of `[R; G]`, the same reflectors applied
//!   (transposed) to `[Y; F]`: the top n rows become the new `Y`, the squares of the bottom
//!   rows add to `e`. The reflectors exploit that `R` is triangular: reflector j touches only
//!   row j of `R`/`Y` and the q rows of `G`/`F` (LAPACK's `dtpqrt` structure), so absorbing a
//!   block costs ≈ 4·n·q + 2·n·min(n, 32) flops per column of `F` (the second term for the
//!   compact-WY `T` factors), independent of how many rows were absorbed before.
//! * [`StreamedQr::merge`] — the same operation on `[R1; R2]`, `[Y1; Y2]` (a TSQR reduction
//!   step); `e` adds.
//! * [`StreamedQr::finish`] — column equilibration, SVD of the small `R·S`, rank decision,
//!   truncated-SVD solve, per-column fit residuals.

mod qr;
mod split;

pub use qr::{LsqOptions, LsqSolution, StreamedQr};
pub use split::{stacked_coefficients, Split, SplitState};
