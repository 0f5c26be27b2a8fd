//! What one eigensolve did: per-slice progress ([`EigenProgress`]) and the measurements of each
//! slice ([`SliceStats`]) and of the whole solve ([`EigenStats`]) (docs/design.md §3.6).

use super::options::EigenBackend;

/// Progress of one slice, passed to the callback of [`eigenpairs_with_progress`] after each
/// restart of its iteration.
#[derive(Clone, Copy, Debug)]
pub struct EigenProgress {
    /// The slice (0-based) and how many there are.
    pub slice: usize,
    /// Slices in this solve.
    pub slices: usize,
    /// Modes of the slice converged so far.
    pub found: usize,
    /// Modes in the slice (its inertia count).
    pub wanted: usize,
    /// The slice's frequency range (Hz; 0 for the bottom slice's open lower end).
    pub lo_hz: f64,
    /// Upper end (Hz).
    pub hi_hz: f64,
}

/// What one slice did.
#[derive(Clone, Debug, Default)]
pub struct SliceStats {
    /// Frequency range (Hz) (lo = 0 for the bottom slice).
    pub lo_hz: f64,
    /// Upper end (Hz).
    pub hi_hz: f64,
    /// Shift used.
    pub sigma: f64,
    /// ν(σ) from the LBLᵀ inertia (0 for a shift below the spectrum).
    pub below_sigma: usize,
    /// Modes counted (and found) in the slice.
    pub count: usize,
    /// Krylov dimension.
    pub krylov_dim: usize,
    /// nnz of the factor.
    pub factor_nnz: usize,
    /// Factorization time (the shift's, and its moves), s.
    pub factor_s: f64,
    /// Iteration time (with a probe's estimating expansion, kept or not), s.
    pub iterate_s: f64,
    /// Applications of S.
    pub solves: usize,
    /// Restarts.
    pub restarts: usize,
    /// Fresh starts after missed copies of multiple eigenvalues.
    pub fresh_starts: usize,
    /// Iterative-refinement steps of the interior shift's LBLᵀ solves (0 when every solve
    /// met its backward-error target at once; see `factor::ShiftedIndefinite`): a large number
    /// means the factor at this shift grew and each solve cost up to four.
    pub refinements: usize,
    /// Times the interior shift was moved because its factor grew (largest |l_ij| of its
    /// LBLᵀ above the limit of docs/design.md §3.6): 0, 1 or 2.
    pub shift_moves: usize,
    /// Largest relative Ritz residual ‖S x − θ x‖_M / |θ| of a returned pair: the requested
    /// tolerance, or up to 100 times it where the solves' rounding held a pair above it
    /// (docs/design.md §3.6).
    pub residual: f64,
}

/// What the eigensolver did.
#[derive(Clone, Debug, Default)]
pub struct EigenStats {
    /// The iteration used.
    pub backend: EigenBackend,
    /// Factorizations of the slices (summed over slices), s.
    pub factor_s: f64,
    /// Iterations (summed over slices), s.
    pub iterate_s: f64,
    /// Inertia counts (summed), s.
    pub count_s: f64,
    /// Wall-clock time of the whole solve, s.
    pub wall_s: f64,
    /// Applications of S (all slices).
    pub solves: usize,
    /// Restarts (all slices).
    pub restarts: usize,
    /// Largest Krylov dimension of a slice.
    pub krylov_dim: usize,
    /// Shift of the first slice.
    pub sigma: f64,
    /// nnz of the Cholesky/LBLᵀ factor.
    pub factor_nnz: usize,
    /// Sparse factorizations in all: one per slice, one per moved shift and one per counted
    /// bound.
    pub factorizations: usize,
    /// Largest relative Ritz residual of a returned pair, over all slices (see
    /// [`SliceStats::residual`]).
    pub residual: f64,
    /// Neighbouring slices whose vectors needed the Rayleigh–Ritz step to be M-orthonormal.
    pub repaired_bounds: usize,
    /// Per slice, in ascending order.
    pub slices: Vec<SliceStats>,
    /// Modes below the ones returned (ν(lo) of a [`Request::Band`], else 0): the first
    /// returned mode is mode number `modes_below + 1` of the body.
    pub modes_below: usize,
}
