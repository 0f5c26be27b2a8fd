//! What [`super::eigenpairs`] is asked for and how it computes it: the [`Request`], the
//! iteration ([`EigenBackend`]) and the solver's settings ([`EigenOptions`]) (docs/design.md
//! §3.6).

/// Which eigenpairs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Request {
    /// The c lowest modes, rigid ones included.
    Lowest(usize),
    /// Every mode with frequency ≤ f_hi (Hz), rigid ones included, counted exactly by inertia.
    UpTo(f64),
    /// Every mode with lo ≤ f ≤ hi (Hz), counted exactly by inertia; only these are computed
    /// (lo ≤ 0 includes the rigid modes).
    Band(f64, f64),
}

/// Which iteration computes the eigenpairs (the slicing and factorizations are the same).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum EigenBackend {
    /// Our Krylov–Schur in the M-inner product (pure Rust, always available).
    #[default]
    Krylov,
    /// ARPACK `dsaupd`/`dseupd`, mode 3; needs the cargo feature `arpack` (libarpack2-dev).
    Arpack,
}

impl std::fmt::Display for EigenBackend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            EigenBackend::Krylov => "krylov",
            EigenBackend::Arpack => "arpack",
        })
    }
}

/// Settings of the eigensolver.
#[derive(Clone, Debug)]
pub struct EigenOptions {
    /// Shift σ < 0 of the bottom slice; `None` = −b/100 with b the slice's upper bound (or
    /// −0.01·(2π [`Self::band_end_hz`])² while the bound of [`Request::Lowest`] is unknown; without
    /// a band end at least 10⁻⁸ · max K_ii/M_ii in magnitude, which keeps K − σM conditioned).
    pub sigma: Option<f64>,
    /// The frequency scale (Hz) of the first shift for [`Request::Lowest`]: the end of the
    /// scene's band, where the wanted modes lie below; `None` = 1 Hz.
    pub band_end_hz: Option<f64>,
    /// Convergence: Ritz residual ≤ tol·|θ| + 4ε·θ_max (module `krylov`; ARPACK: its `tol`).
    pub tol: f64,
    /// Krylov dimension per slice (ARPACK: `ncv`); `None` = max(2c, c + 40) for a slice of c
    /// modes, capped at N.
    pub krylov_dim: Option<usize>,
    /// Restart limit per slice (ARPACK: `iparam(3)`, its update iterations).
    pub max_restarts: usize,
    /// Restarts in a row without a newly converged mode, and without halving the leading
    /// pair's residual, after which a slice gives up.
    pub patience: usize,
    /// Target number of modes per slice; smaller when the Krylov bases of the slices that run
    /// at once would take more than half the memory budget (module `slicing`).
    pub slice_size: usize,
    /// Block size of the Krylov–Schur iteration: vectors solved at once (a block solve costs
    /// far less than as many single ones) and the largest multiplicity resolved without a
    /// fresh start.
    pub block: usize,
    /// Worker threads (slices at once, or threads inside a lone factorization); 0 = all cores.
    pub threads: usize,
    /// Memory the concurrent slices may use (bytes); `None` = what the body's budget for the
    /// run ([`crate::body::Body::with_memory_budget`]) leaves beside what the process holds
    /// when the slicing starts, or half of MemAvailable.
    pub memory_budget: Option<usize>,
    /// The iteration.
    pub backend: EigenBackend,
}

impl EigenOptions {
    /// The defaults with the shift scale of a scene band ending at `band_end_hz`.
    pub fn for_band(band_end_hz: f64) -> Self {
        EigenOptions {
            band_end_hz: Some(band_end_hz),
            ..Default::default()
        }
    }
}

impl Default for EigenOptions {
    fn default() -> Self {
        EigenOptions {
            sigma: None,
            band_end_hz: None,
            tol: 1e-14,
            krylov_dim: None,
            max_restarts: 500,
            patience: 60,
            slice_size: 192,
            block: 4,
            threads: 0,
            memory_budget: None,
            backend: EigenBackend::Krylov,
        }
    }
}
