//! What a factorization backend is (docs/design.md §3.1): the [`Backend`] names and the
//! measured rule of [`Backend::Auto`], the two traits a backend file implements — its
//! once-per-model analysis ([`SymbolicFactorization`]) and its numeric factorization
//! ([`Factorization`]) — the values of A(iω) they read ([`Values`]), the footprint an analysis
//! predicts, and the helpers the backends share (fallible allocation, split real solves, the
//! singular-pivot error).
//!
//! This file imports no backend: each backend file imports it, and `factor/mod.rs` lists the
//! backends in its registry ([`super::analyse`]).

use super::pattern;
use crate::pencil::Pencil;
use crate::{Error, Result};
use faer::dyn_stack::{MemBuffer, StackReq};
use faer::sparse::linalg::cholesky::SymbolicCholesky;
use faer::sparse::SymbolicSparseColMatRef;
use faer::{c64, Mat, MatMut, Par};
use std::sync::Arc;

/// Largest N for which [`Backend::Auto`] picks faer LU for an undamped (real) pencil.
/// On the bars of `sparsemor bench sweep` faer LU is as fast as the LBLᵀ at N = 1656 and
/// sweeps 1.5× faster at N = 12 060, where its solve is about 2× cheaper; at 10⁵ DoF LU's
/// COLAMD fill explodes on 3-D pencils (docs/design.md §3.1), so above this size Auto uses
/// LBLᵀ. Damped pencils always take the complex LDLᵀ, which factors faster than both at every
/// size of the bench (docs/performance.md, "Factorization against MKL PARDISO").
pub const LU_MAX_N: usize = 15_000;

/// Which sparse factorization to use.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// The measured rule of [`Backend::resolved`]: complex LDLᵀ when damped; faer LU up to
    /// [`LU_MAX_N`] and faer LBLᵀ above when undamped.
    Auto,
    /// Complex-symmetric supernodal LDLᵀ with static pivoting (damped pencils; an undamped
    /// pencil takes the real N×N LBLᵀ).
    Ldlt,
    /// faer supernodal LBLᵀ (real N×N undamped, interleaved real 2N×2N damped).
    FaerLblt,
    /// faer sparse LU (COLAMD), real or complex.
    FaerLu,
    /// UMFPACK (SuiteSparse), real or complex; needs the `umfpack` feature.
    Umfpack,
    /// MUMPS, complex symmetric, in core or out of core, in this process or shared by the
    /// ranks of `mpirun`; needs the `mumps` feature.
    Mumps,
}

impl std::str::FromStr for Backend {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        if let Some((b, _)) = Backend::NAMES.iter().find(|(_, names)| names.contains(&s)) {
            return Ok(*b);
        }
        let shown: Vec<&str> = Backend::NAMES.iter().map(|(_, names)| names[0]).collect();
        let (last, rest) = shown.split_last().expect("backends are named");
        Err(Error::InvalidSetting(format!(
            "backend '{s}': choose {} or {last}",
            rest.join(", ")
        )))
    }
}

impl Backend {
    /// Every backend with its names, the first the one it is shown by (`--backend`, `info`).
    const NAMES: [(Backend, &'static [&'static str]); 6] = [
        (Backend::Auto, &["auto"]),
        (Backend::Ldlt, &["ldlt"]),
        (Backend::FaerLblt, &["faer-lblt", "lblt"]),
        (Backend::FaerLu, &["faer-lu", "lu"]),
        (Backend::Umfpack, &["umfpack"]),
        (Backend::Mumps, &["mumps"]),
    ];

    /// The backend a factorization of an N-DoF pencil uses, `real` when it is undamped
    /// (D = 0): [`Backend::Auto`] becomes the complex LDLᵀ when damped, faer LU up to
    /// [`LU_MAX_N`] and faer LBLᵀ above when real; [`Backend::Ldlt`] of a real pencil is the
    /// real LBLᵀ (the real path has no complex arithmetic to save); the others stay. The one
    /// place that decides (the analysis and `sparsemor info` both ask it).
    pub fn resolved(self, n: usize, real: bool) -> Backend {
        match self {
            Backend::Auto if !real => Backend::Ldlt,
            Backend::Auto if n <= LU_MAX_N => Backend::FaerLu,
            Backend::Auto | Backend::Ldlt if real => Backend::FaerLblt,
            b => b,
        }
    }
}

impl std::fmt::Display for Backend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (_, names) = Backend::NAMES
            .iter()
            .find(|(b, _)| b == self)
            .expect("every backend is named");
        f.write_str(names[0])
    }
}

/// Where an analysis' factorizations keep their factors.
#[derive(Clone, Copy, Debug)]
pub struct Storage<'a> {
    /// A directory for the factors (of the sweep: backend `mumps` only; a real LDLᵀ,
    /// `RealLdlt`, then keeps L there); `None`: in memory while one factorization fits
    /// `budget`.
    pub dir: Option<&'a std::path::Path>,
    /// Bytes one factorization may take in memory; beyond it MUMPS and the real LDLᵀ keep
    /// their factors in the temporary directory (the sweep's other backends have no such
    /// choice).
    pub budget: usize,
}

impl Storage<'_> {
    /// In memory, whatever the size.
    pub const IN_CORE: Storage<'static> = Storage {
        dir: None,
        budget: usize::MAX,
    };

    /// In memory while a factorization fits half the memory available now
    /// ([`crate::memory::default_budget`]), else in the temporary directory: the other half is
    /// left to the rest of the run, which on a large body holds about as much again (the
    /// 10⁶-DoF tet10 crank: a 10.7 GB factor, 19.5 GB at the peak; docs/performance.md).
    pub fn available() -> Storage<'static> {
        Storage {
            dir: None,
            budget: crate::memory::default_budget(2),
        }
    }
}

/// What a backend's analysis predicts for one numeric factorization.
pub(super) struct Footprint {
    /// Stored entries of the factor (0 if known only after the numeric phase).
    pub(super) factor_nnz: usize,
    /// Bytes of one numeric factorization incl. workspace.
    pub(super) bytes: usize,
}

impl Footprint {
    /// An LU of the full pattern (`nnz` entries), whose fill is known only after the numeric
    /// phase: estimated at 4× the pattern's scalars.
    pub(super) fn full_pattern(real: bool, nnz: usize) -> Self {
        let scalar = if real { 8 } else { 16 };
        Footprint {
            factor_nnz: 0,
            bytes: scalar * nnz * 4,
        }
    }
}

/// A backend's once-per-model analysis of the pencil; every numeric factorization it
/// allocates borrows it.
pub(super) trait SymbolicFactorization: Send + Sync {
    /// The backend this analysis is of (a backend may hand a pattern it does not support to
    /// another: the LDLᵀ gives a diagonal pattern to the LBLᵀ).
    fn backend(&self) -> Backend;
    /// Allocates the buffers of one numeric factorization of `pencil` (the pencil the
    /// analysis was made on).
    fn numeric(&self, pencil: &Pencil) -> Result<Box<dyn Factorization + '_>>;
    /// The ordered symbolic Cholesky of the N×N pattern that a pivoting fallback reuses, for
    /// a backend that pivots statically (the complex LDLᵀ); `None` for those that pivot
    /// themselves.
    fn pivoting_structure(&self) -> Option<Arc<SymbolicCholesky<usize>>> {
        None
    }
    /// Whether the factors are kept on disk (MUMPS out of core).
    fn out_of_core(&self) -> bool {
        false
    }
    /// The MPI ranks that hold a part of each factorization (MUMPS shared over `mpirun`'s
    /// ranks); 1 for a factorization held by this process alone.
    fn ranks(&self) -> usize {
        1
    }
}

/// A backend's analysis with what it predicts for one numeric factorization.
pub(super) type Analysed = (Box<dyn SymbolicFactorization>, Footprint);

/// The ordered symbolic Cholesky of the pencil's N×N pattern, computed on demand: only the
/// backends built on it ask (a prepared body shares its one analysis this way).
pub(super) type SymbolicN<'a> = Box<dyn FnOnce() -> Result<Arc<SymbolicCholesky<usize>>> + 'a>;

/// A(iω) on the pencil's lower pattern: what every backend factors. The backends that
/// read arrays get `re`/`im` gathered; the complex LDLᵀ reads each entry once while it
/// assembles and computes it from the pencil ([`Values::entry`]), which saves two arrays of
/// the pencil's size per factorization (0.65 GB on the 10⁶-DoF bar, docs/design.md §3.1).
pub(super) struct Values<'a> {
    pub(super) pattern: SymbolicSparseColMatRef<'a, usize>,
    pub(super) pencil: &'a Pencil,
    pub(super) omega: f64,
    /// The values gathered, or empty when not (`im` also empty on the real path, D = 0).
    pub(super) re: &'a [f64],
    pub(super) im: &'a [f64],
}

impl<'a> Values<'a> {
    /// The values at ω: `re`/`im` when gathered (else empty), the pencil otherwise.
    pub(super) fn new(pencil: &'a Pencil, omega: f64, re: &'a [f64], im: &'a [f64]) -> Self {
        Values {
            pattern: pattern::lower(pencil),
            pencil,
            omega,
            re,
            im,
        }
    }

    /// Entry p: gathered when there are arrays (the supported K is only there), else from
    /// the pencil.
    #[inline]
    pub(super) fn entry(&self, p: usize) -> c64 {
        if self.re.is_empty() {
            self.pencil.value(self.omega, p)
        } else {
            lower_entry(self.re, self.im, p)
        }
    }
}

/// One backend's numeric factorization, bound to the symbolic analysis it was allocated
/// for (so it cannot be used with another).
pub(super) trait Factorization: Send {
    /// Factors A(iω); `freq_hz` names the frequency in a singularity error.
    fn factor(&mut self, a: &Values<'_>, freq_hz: f64, par: Par) -> Result<()>;
    /// Solves A(iω) X = B in place with the last factorization.
    fn solve(&mut self, rhs: MatMut<'_, c64>, par: Par);
    /// min |pivot| / max |pivot| of the last factorization, as the backend reports it.
    fn pivot_ratio(&self) -> f64;
    /// Pivots the last factorization replaced by a static perturbation (LDLᵀ only).
    fn perturbed(&self) -> usize {
        0
    }
    /// Whether the backend reads the values as arrays ([`Values`]); only the LDLᵀ does not.
    fn reads_arrays(&self) -> bool {
        true
    }
}

/// Entry p of the factored matrix on the pencil's lower pattern (`im` empty: real).
pub(super) fn lower_entry(re: &[f64], im: &[f64], p: usize) -> c64 {
    c64::new(re[p], im.get(p).copied().unwrap_or(0.0))
}

/// Solves a complex block with a real factorization: [Re B | Im B] (N × 2k) in one solve.
pub(super) fn solve_split(mut rhs: MatMut<'_, c64>, solve: impl FnOnce(MatMut<'_, f64>)) {
    let (n, k) = (rhs.nrows(), rhs.ncols());
    let mut u = Mat::<f64>::from_fn(n, 2 * k, |r, c| {
        if c < k {
            rhs[(r, c)].re
        } else {
            rhs[(r, c - k)].im
        }
    });
    solve(u.as_mut());
    for c in 0..k {
        for i in 0..n {
            rhs[(i, c)] = c64::new(u[(i, c)], u[(i, c + k)]);
        }
    }
}

/// [`Error::Singular`] at `freq_hz` saying `detail` unless the pivot ratio of a factorization
/// is positive (a zero or non-finite pivot gives 0 or NaN).
pub(super) fn require_pivots(ratio: f64, freq_hz: f64, detail: &str) -> Result<()> {
    if ratio > 0.0 {
        Ok(())
    } else {
        Err(Error::Singular {
            freq_hz,
            detail: detail.into(),
        })
    }
}

/// A zeroed vector of `len` entries, or [`Error::Factor`] if it cannot be allocated.
pub(super) fn try_vec<T: Clone + Default>(len: usize) -> Result<Vec<T>> {
    let mut v = Vec::new();
    v.try_reserve_exact(len)
        .map_err(|_| Error::Factor(format!("cannot allocate {len} factor entries")))?;
    v.resize(len, T::default());
    Ok(v)
}

/// The workspace `req`, or [`Error::Factor`] if it cannot be allocated.
pub(super) fn workspace(req: StackReq) -> Result<MemBuffer> {
    MemBuffer::try_new(req).map_err(|_| {
        Error::Factor(format!(
            "cannot allocate {} bytes of factorization workspace",
            req.size_bytes()
        ))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every backend reads back from the name it shows and from its aliases; an unknown name
    /// lists the shown names.
    #[test]
    fn names_round_trip() {
        for (b, names) in Backend::NAMES {
            assert_eq!(b.to_string(), names[0]);
            for name in names {
                assert_eq!(name.parse::<Backend>().unwrap(), b);
            }
        }
        let err = "x".parse::<Backend>().unwrap_err().to_string();
        assert!(
            err.contains("backend 'x': choose auto, ldlt, faer-lblt, faer-lu, umfpack or mumps"),
            "{err}"
        );
    }
}
