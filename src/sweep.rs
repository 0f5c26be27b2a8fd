//! Parallel frequency sweep of A(iω) = K − ω²M + iωD (docs/design.md §3.1–3.2).
//!
//! [`Solver`] prepares everything that does not depend on the frequency — pencil pattern,
//! symbolic analysis, rigid modes, the (projected) load — once. [`Solver::run`] then factors
//! A(iω_k) for each frequency, solves for the p load columns and hands the full-state
//! response X_k (N×p) to a caller-supplied step that folds it into a per-worker state (the
//! streamed QR of a row split, or the response at chosen rows: `crate::frf`).
//!
//! Schedule: frequencies are independent. When `workers × bytes_per_factor` fits the memory
//! budget, `workers = min(threads, frequencies)` threads each own one numeric factorization
//! and take frequencies from a shared counter (each factorization sequential inside, until a
//! worker runs out of frequencies: its thread then joins the phases the others start);
//! otherwise frequencies run one at a time with all threads inside the factorization. The
//! decision uses the symbolic analysis' size of the factor, known before any numeric work.
//!
//! Verification: every factorization is checked by a probe solve: z is a fixed random vector
//! (made elastic, Pᵀz = z, on a free body), b = A(iω)z is solved with the load, and
//! ‖Pᵀ(x − z)‖/‖z‖ must stay below [`SweepOptions::probe_tol`]; otherwise the frequency is
//! reported as numerically singular ([`Error::Singular`]). On a free body only the elastic
//! part is checked: the rigid part of a solve at low frequency is ill-conditioned by nature
//! and removed by Pᵀ (or is dominated by the analytic H0). A probe error above 1e-10 means
//! digits were lost — the LDLᵀ pivots statically and the LBLᵀ inside supernodes only, and
//! A(iω) of a large model near a lightly damped resonance is ill-conditioned — and all columns
//! are then refined with the exact A(iω) ([`Numeric::refine`]) before the check;
//! [`FreqStats::refinement_steps`] reports the steps. The probe's error is a lower bound of
//! the loads' error, so refining on its signal matters: on the 10⁶-DoF bar at 5 Hz
//! (β = 1e-5) the point-load responses' first correction is 1.2e-4 relative where the probe
//! shows 2.6e-6, and refinement brings both to the conditioning floor of double precision
//! there (docs/design.md §3.1).

use crate::body::Body;
use crate::factor::{
    off_an_eigenfrequency, Analysis, Backend, FactorPlace, Numeric, Storage, SymbolicStats,
};
use crate::linearized_space::LinearizedSpace;
use crate::random::Xorshift;
use crate::rigid::RigidBody;
use crate::shifted_space::{ResponseSpace, Rows, ShiftedSpace, SolutionBuffers, GROW_TO};
pub use crate::shifted_space::{
    CERTIFIED_BACKWARD_ERROR, CERTIFIED_NORMWISE_BACKWARD_ERROR, CERTIFIED_RELATIVE_RESIDUAL,
};
use crate::{Error, Result};
use faer::{c64, Mat, MatRef, Par};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// Probe errors above this trigger iterative refinement (see the module doc).
const REFINE_ABOVE: f64 = 1e-10;

/// Default [`SweepOptions::probe_tol`].
pub const DEFAULT_PROBE_TOL: f64 = 1e-6;

/// Options of a sweep.
#[derive(Clone, Debug)]
pub struct SweepOptions {
    /// Worker threads; 0 = all available cores.
    pub threads: usize,
    /// Factorization backend.
    pub backend: Backend,
    /// Memory the concurrent factorizations may use (bytes); `None` = half of MemAvailable.
    pub memory_budget: Option<usize>,
    /// Largest accepted relative probe error of a solve (see module doc).
    pub probe_tol: f64,
    /// How a frequency's response is computed ([`SolveMethod`]).
    pub method: SolveMethod,
    /// A directory for the factors (backend `mumps`): each factorization is written there
    /// and read back by its solves, so it need not fit in memory; every frequency is then
    /// factored (the shifted Krylov space keeps its factor in memory). `None` = in core.
    pub out_of_core: Option<std::path::PathBuf>,
}

impl SweepOptions {
    /// The thread count these options run with: [`Self::threads`], or all cores for 0.
    pub fn resolved_threads(&self) -> usize {
        crate::pool::resolve_threads(self.threads)
    }
}

impl Default for SweepOptions {
    fn default() -> Self {
        SweepOptions {
            threads: 0,
            backend: Backend::Auto,
            memory_budget: None,
            probe_tol: DEFAULT_PROBE_TOL,
            method: SolveMethod::Auto,
            out_of_core: None,
        }
    }
}

/// How the responses are computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SolveMethod {
    /// From one Krylov space: shifted when the damping is proportional but for a low-rank
    /// remainder ([`crate::shifted_space`], docs/design.md §3.10, §3.12), linearized for any
    /// other ([`crate::linearized_space`], §3.13). One factorization serves every frequency,
    /// each response certified by its residual; a frequency whose response does not pass is
    /// factored, and so is every frequency when the space does not apply (a damping that
    /// couples a free body's rigid motion to the elastic, a total response of a free body).
    #[default]
    Auto,
    /// Factor A(iω) at every frequency.
    Factored,
}

impl std::str::FromStr for SolveMethod {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        match s {
            "auto" => Ok(Self::Auto),
            "factor" => Ok(Self::Factored),
            _ => Err(Error::InvalidSetting(format!(
                "solve method `{s}`: expected auto (one Krylov space for every frequency where the damping allows) or factor (factor A(iw) at every frequency)"
            ))),
        }
    }
}

/// Which response the solver produces.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Response {
    /// X = A⁻¹B (eq. 14).
    Total,
    /// X = Pᵀ A⁻¹ P B (eq. 17 without cancellation; equals Total on a constrained body).
    Elastic,
}

/// How the frequencies were scheduled.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Schedule {
    /// `workers` frequencies at once, each factorization sequential.
    FrequencyParallel {
        /// Concurrent factorizations.
        workers: usize,
    },
    /// One frequency at a time, `threads` threads inside the factorization.
    FactorParallel {
        /// Threads inside each factorization.
        threads: usize,
    },
}

/// Per-frequency measurements.
#[derive(Clone, Debug)]
pub struct FreqStats {
    /// Frequency (Hz).
    pub freq_hz: f64,
    /// Numeric factorization time (s).
    pub factor_s: f64,
    /// Solve time for the load and the probe (s).
    pub solve_s: f64,
    /// ‖Pᵀ(x − z)‖/‖z‖ of the probe solve (after refinement).
    pub probe_error: f64,
    /// Componentwise backward error of the probe solve (after refinement),
    /// maxᵢ |b − A x|ᵢ / (|A||x| + |b|)ᵢ ([`Numeric::backward_error`]): about ε when the
    /// factorization's solves are backward stable.
    pub backward_error: f64,
    /// Iterative refinement steps of the solves, plus the solves of the GMRES that follows
    /// where refinement ends at its step limit (0 when the first solve was backward stable).
    pub refinement_steps: usize,
    /// min/max pivot magnitude (LBLᵀ, LDLᵀ), rcond (UMFPACK) or NaN (faer LU).
    pub pivot_ratio: f64,
    /// True when the complex LDLᵀ's static pivoting was not enough and the frequency was
    /// factored again by the pivoting LBLᵀ ([`Numeric::factor_with_pivoting`]).
    pub pivoted: bool,
    /// 0 when A(iω) was factored; else the dimension of the shifted Krylov space the response
    /// came from (no factorization, no probe: `probe_error`, `pivot_ratio` are NaN and
    /// `backward_error` is the worst column's of the loads).
    pub space_dim: usize,
    /// The worst load column's ‖b − A x‖₂/‖b‖₂ of a response from the Krylov space (NaN when
    /// factored: the probe measures those).
    pub relative_residual: f64,
    /// The worst load column's normwise backward error bound maxᵢ |b − A x|ᵢ / maxᵢ (|A||x| +
    /// |b|)ᵢ of a response from the Krylov space (NaN when factored).
    pub normwise_backward_error: f64,
    /// Real factorizations and block solves spent on the shifted Krylov space by the run
    /// before its frequencies were solved, carried by the run's first frequency (0 on the
    /// others), so that summing the stats counts them once.
    pub space_cost: (usize, usize),
}

impl FreqStats {
    /// The response came from the shifted Krylov space, not a factorization.
    pub fn from_space(&self) -> bool {
        self.space_dim > 0
    }
}

/// What [`Solver::solve_checked`] measured of one frequency's solves.
struct Checked {
    probe_error: f64,
    backward_error: f64,
    refinement_steps: usize,
}

/// The accuracy a [`Solver`]'s factorizations showed over all its runs: reported with a ROM
/// so the user sees how accurate the full-model solves behind it were. In `rom.toml` the
/// shifted space's fields keep the keys the format has always had (`from_krylov`,
/// `shift_factorizations`, `krylov_block_solves`, `krylov_dim`): ROM files stay readable.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SolveAccuracy {
    /// Frequencies solved (factored or from the shifted Krylov space).
    pub frequencies: usize,
    /// Of them, responses from the shifted Krylov space (docs/design.md §3.10).
    #[serde(default, rename = "from_krylov")]
    pub from_space: usize,
    /// Real factorizations of K − σM made for the shifted Krylov space.
    #[serde(default, rename = "shift_factorizations")]
    pub space_factorizations: usize,
    /// Block solves with those factorizations.
    #[serde(default, rename = "krylov_block_solves")]
    pub space_block_solves: usize,
    /// Largest dimension of the shifted Krylov space.
    #[serde(default, rename = "krylov_dim")]
    pub space_dim: usize,
    /// Bytes of the spaces' real factors written to disk (0: every factor in memory; this
    /// rank's spaces), docs/design.md §3.1, "Factor out of core".
    #[serde(default)]
    pub space_disk_written: u64,
    /// Bytes of them read back by the spaces' block solves.
    #[serde(default)]
    pub space_disk_read: u64,
    /// Largest relative residual of a response from it (its certificate).
    #[serde(default)]
    pub relative_residual_max: f64,
    /// Largest probe error ([`FreqStats::probe_error`], after refinement).
    pub probe_error_max: f64,
    /// Largest backward error ([`FreqStats::backward_error`]; 0 when read from a ROM file
    /// that does not record it).
    #[serde(default)]
    pub backward_error_max: f64,
    /// Frequencies whose solves were refined.
    pub refined: usize,
    /// Frequencies the complex LDLᵀ handed to the pivoting LBLᵀ ([`FreqStats::pivoted`]).
    #[serde(default)]
    pub pivoted: usize,
}

impl SolveAccuracy {
    /// Factorizations in all: one per factored frequency and one per shifted Krylov space.
    pub fn factorizations(&self) -> usize {
        self.frequencies - self.from_space + self.space_factorizations
    }

    /// Adds (factorizations, block solves) spent on a shifted Krylov space.
    pub(crate) fn add_space_cost(&mut self, (factorizations, block_solves): (usize, usize)) {
        self.space_factorizations += factorizations;
        self.space_block_solves += block_solves;
    }

    pub(crate) fn add(&mut self, s: &FreqStats) {
        self.frequencies += 1;
        if s.from_space() {
            self.from_space += 1;
            self.space_dim = self.space_dim.max(s.space_dim);
            self.relative_residual_max = self.relative_residual_max.max(s.relative_residual);
        }
        self.add_space_cost(s.space_cost);
        self.probe_error_max = self.probe_error_max.max(s.probe_error);
        self.backward_error_max = self.backward_error_max.max(s.backward_error);
        self.refined += usize::from(s.refinement_steps > 0);
        self.pivoted += usize::from(s.pivoted);
    }
}

/// Progress report passed to the caller's callback after each frequency.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    /// Frequencies finished.
    pub done: usize,
    /// Frequencies in this run.
    pub total: usize,
    /// The frequency just finished (Hz).
    pub freq_hz: f64,
}

/// Progress callback: return `false` to cancel the run ([`Error::Cancelled`]).
pub type ProgressFn<'a> = &'a (dyn Fn(Progress) -> bool + Sync);

/// The rows `rows` of a response X (N × p): H at the outputs from a full-state snapshot.
pub(crate) fn rows_of(rows: &[usize], x: MatRef<'_, c64>) -> Mat<c64> {
    Mat::from_fn(rows.len(), x.ncols(), |o, j| x[(rows[o], j)])
}

/// A no-op progress callback.
pub fn no_progress(_: Progress) -> bool {
    true
}

/// The response at one frequency, handed to the step of [`Solver::run`].
pub struct Snapshot<'a> {
    /// Position of the frequency in the run's list.
    pub index: usize,
    /// Frequency (Hz).
    pub freq_hz: f64,
    /// Full-state response X (N × p).
    pub x: MatRef<'a, c64>,
    /// X = Q c in the basis Q of [`Solver::with_basis`], when the solver's shifted Krylov
    /// space answered and Q is its basis (not after the sweep replaced that space,
    /// docs/design.md §3.10): c (k × p).
    pub coefficients: Option<MatRef<'a, c64>>,
}

/// Frequency-independent preparation of a sweep; see the module doc.
pub struct Solver<'a> {
    body: &'a Body,
    /// The symbolic analysis of the per-frequency factorizations: made here, or, for the
    /// in-house LDLᵀ in memory, by the first factorization (a run the shifted Krylov space
    /// answers never needs it; through a coupling it is an analysis of its own, §3.11).
    analysis: std::sync::OnceLock<Analysis>,
    /// The backend of a lazily made analysis.
    backend: Backend,
    response: Response,
    inputs: Vec<usize>,
    /// B or P B (N×p), real.
    load: Mat<f64>,
    probe: Mat<c64>,
    threads: usize,
    memory_budget: usize,
    probe_tol: f64,
    /// A free body's six support DoFs for 0 Hz and their diagonal (the largest |K_ii|, so the
    /// supported K keeps its scale); chosen once here, not per solve.
    supports: Option<(Vec<usize>, f64)>,
    accuracy: Mutex<SolveAccuracy>,
    /// The shifted Krylov space ([`SolveMethod::Auto`] on a proportionally damped body; made
    /// by the first run that has a frequency > 0); `None` when every frequency is factored.
    space: Option<Mutex<Space<'a>>>,
    /// The basis of the space about line-fitting's interior shift once the sweep replaced
    /// that space (§3.10; its factor dropped): the coefficients of the responses it answered
    /// refer to it ([`Self::with_basis`]); its successor's responses are handed out whole.
    retired: Mutex<Option<Mat<f64>>>,
}

/// Rounds of growing the Krylov space for responses that failed their certificate (the
/// target 100× tighter each round) before their frequencies are factored.
const KRYLOV_ROUNDS: usize = 4;

/// The estimates a Krylov space is grown to, round by round, for the responses the sweep
/// certifies: [`GROW_TO`], then 100× tighter for those whose certificate failed (§3.10).
pub(crate) fn growth_targets() -> impl Iterator<Item = f64> {
    (0..KRYLOV_ROUNDS).map(|round| GROW_TO / 100f64.powi(round as i32))
}

/// Why a frequency's response did not come from the Krylov space.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Fallback {
    /// It failed its certificate: a larger space may pass.
    Grow,
    /// The space cannot answer it (0 Hz, or ill-conditioned: next to an undamped
    /// eigenvalue): factor it.
    Factor,
}

/// What the workers of one [`Solver::run`] share.
struct Run<'r, S, I, F> {
    freqs_hz: &'r [f64],
    init: &'r I,
    step: &'r F,
    progress: ProgressFn<'r>,
    stop: AtomicBool,
    done: AtomicUsize,
    first_error: Mutex<Option<Error>>,
    stats: Mutex<Vec<Option<FreqStats>>>,
    /// The workers' states by worker number, handed from one phase's worker w to the next's.
    states: Mutex<Vec<Option<S>>>,
}

impl<S, I, F> Run<'_, S, I, F> {
    /// Stops the run on its first error.
    fn fail(&self, e: Error) {
        self.stop.store(true, Ordering::Relaxed);
        self.first_error
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .get_or_insert(e);
    }

    /// Records a finished frequency and reports progress.
    fn finished(&self, k: usize, st: FreqStats) {
        let f = st.freq_hz;
        self.stats.lock().unwrap_or_else(|p| p.into_inner())[k] = Some(st);
        let done = self.done.fetch_add(1, Ordering::Relaxed) + 1;
        if !(self.progress)(Progress {
            done,
            total: self.freqs_hz.len(),
            freq_hz: f,
        }) {
            self.fail(Error::Cancelled);
        }
    }
}

/// The state of a [`Solver`]'s shifted Krylov space.
enum Space<'a> {
    /// Not made yet.
    Unmade,
    Made(Box<dyn ResponseSpace + 'a>),
    /// K − σM could not be factored (M not positive definite?): every frequency is factored.
    Failed,
}

impl<'a> Solver<'a> {
    /// Prepares a solver of `body` for unit loads at `inputs`.
    ///
    /// # Errors
    /// Bad settings ([`Error::InvalidSetting`]) and analysis failures ([`Error::Factor`]).
    pub fn new(
        body: &'a Body,
        inputs: &[usize],
        response: Response,
        opts: &SweepOptions,
    ) -> Result<Self> {
        let n = body.n();
        crate::scene::check_dofs(inputs, n, "inputs")?;
        if !(opts.probe_tol > 0.0) {
            return Err(Error::InvalidSetting(format!(
                "probe_tol = {}: must be > 0",
                opts.probe_tol
            )));
        }
        let threads = opts.resolved_threads();
        let memory_budget = opts
            .memory_budget
            .unwrap_or_else(|| crate::memory::default_budget(2));
        let storage = Storage {
            dir: opts.out_of_core.as_deref(),
            budget: memory_budget,
        };
        let analysis = std::sync::OnceLock::new();
        let lazy = storage.dir.is_none()
            && opts.backend.resolved(n, body.pencil().is_real()) == Backend::Ldlt;
        if !lazy {
            let made = Self::analyse(body, opts.backend, inputs.len(), storage)?;
            let _ = analysis.set(made);
        }
        let load = match response {
            Response::Elastic => body.elastic_load(inputs),
            Response::Total => body.unit_load(inputs),
        };
        // fixed pseudo-random probe (xorshift), elastic on a free body
        let mut rng = Xorshift::new(0x9e3779b97f4a7c15);
        let mut probe = Mat::<c64>::from_fn(n, 1, |_, _| c64::new(rng.next_centred(), 0.0));
        if let Some(rb) = body.rigid() {
            rb.project_response(probe.as_mut());
        }
        Ok(Solver {
            body,
            analysis,
            backend: opts.backend,
            response,
            inputs: inputs.to_vec(),
            load,
            probe,
            threads,
            memory_budget,
            probe_tol: opts.probe_tol,
            supports: body
                .rigid()
                .map(|rb| (rb.supports(), body.pencil().stiffness_diagonal_max())),
            accuracy: Mutex::new(SolveAccuracy::default()),
            space: space_applies(body, response, opts).then(|| Mutex::new(Space::Unmade)),
            retired: Mutex::new(None),
        })
    }

    /// The accuracy of every factorization of every run so far.
    pub fn accuracy(&self) -> SolveAccuracy {
        *self.accuracy.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Where the real factor of this solver's response space is, and the bytes it moved
    /// (in memory when there is no space).
    pub(crate) fn factor_place(&self) -> FactorPlace {
        match self.space.as_ref().map(|c| c.lock()) {
            Some(Ok(space)) => match &*space {
                Space::Made(s) => s.factor_place(),
                Space::Unmade | Space::Failed => FactorPlace::default(),
            },
            Some(Err(_)) | None => FactorPlace::default(),
        }
    }

    /// The symbolic analysis' measurements, once it is made (`None` while every frequency
    /// came from a shifted Krylov space).
    pub fn symbolic_stats(&self) -> Option<&SymbolicStats> {
        self.analysis.get().map(Analysis::stats)
    }

    /// The analysis of the per-frequency factorizations of `body` with `backend` for
    /// `inputs` right-hand sides and a probe, kept where `storage` says.
    fn analyse(
        body: &Body,
        backend: Backend,
        inputs: usize,
        storage: Storage<'_>,
    ) -> Result<Analysis> {
        Analysis::with_storage(
            body.pencil(),
            backend,
            inputs + 1,
            || body.formed_symbolic(),
            storage,
        )
    }

    /// The analysis, made on the first call when it was left for the first factorization.
    fn analysis(&self) -> Result<&Analysis> {
        if let Some(a) = self.analysis.get() {
            return Ok(a);
        }
        let storage = Storage {
            dir: None,
            budget: self.memory_budget,
        };
        let made = Self::analyse(self.body, self.backend, self.inputs.len(), storage)?;
        Ok(self.analysis.get_or_init(|| made))
    }

    /// The rigid body, if the model is free.
    pub fn rigid(&self) -> Option<&RigidBody> {
        self.body.rigid()
    }

    /// The input DoFs.
    pub fn inputs(&self) -> &[usize] {
        &self.inputs
    }

    /// The prepared body.
    pub fn body(&self) -> &'a Body {
        self.body
    }

    /// The schedule [`Self::run`] uses for `n_freqs` frequencies.
    pub fn schedule(&self, n_freqs: usize) -> Schedule {
        let workers = self.threads.min(n_freqs).max(1);
        // no analysis yet: nothing was factored, and the workers hold a response each
        let bytes = self
            .analysis
            .get()
            .map_or(0, |a| a.stats().bytes_per_factor);
        if workers > 1 && workers.saturating_mul(bytes) <= self.memory_budget {
            Schedule::FrequencyParallel { workers }
        } else {
            Schedule::FactorParallel {
                threads: self.threads,
            }
        }
    }

    /// Solves at every frequency of `freqs_hz` and folds each [`Snapshot`] into a per-worker
    /// state made by `init`; returns the states (in worker order) and per-frequency stats in
    /// the order of `freqs_hz`. Worker w folds a fixed share of the frequencies in a fixed
    /// order, so for a given thread count the states are the same on every run.
    ///
    /// # Errors
    /// Frequencies < 0, or ≤ 0 on a free body ([`Error::InvalidSetting`]); a numerically
    /// singular A(iω) ([`Error::Singular`]); the step's own errors; [`Error::Cancelled`].
    pub fn run<S, I, F>(
        &self,
        freqs_hz: &[f64],
        init: I,
        step: F,
        progress: ProgressFn<'_>,
    ) -> Result<(Vec<S>, Vec<FreqStats>)>
    where
        S: Send,
        I: Fn() -> S + Sync,
        F: Fn(&mut S, Snapshot<'_>) -> Result<()> + Sync,
    {
        for &f in freqs_hz {
            if !f.is_finite() || f < 0.0 {
                return Err(Error::InvalidSetting(format!(
                    "frequency {f} Hz: must be finite and >= 0"
                )));
            }
            if f == 0.0 && self.body.rigid().is_some() && self.response == Response::Total {
                return Err(zero_hz_total());
            }
        }
        let run = Run {
            freqs_hz,
            init: &init,
            step: &step,
            progress,
            stop: AtomicBool::new(false),
            done: AtomicUsize::new(0),
            first_error: Mutex::new(None),
            stats: Mutex::new(vec![None; freqs_hz.len()]),
            states: Mutex::new(Vec::new()),
        };
        let mut pending: Vec<usize> = (0..freqs_hz.len()).collect();
        let mut space_cost = (0, 0);
        if let Some(cell) = &self.space {
            let mut space = cell.lock().unwrap_or_else(|p| p.into_inner());
            let mut factor = Vec::new();
            let mut answer = |space: &mut Space<'a>| {
                self.answer_from_space(&run, space, &mut pending, &mut factor, &mut space_cost)
            };
            // the space about line-fitting's interior shift gives way to one below the
            // spectrum when its responses fail their certificates at every target (§3.10)
            if answer(&mut space)? && matches!(&*space, Space::Made(s) if s.interior()) {
                if let Space::Made(old) = std::mem::replace(&mut *space, Space::Unmade) {
                    *self.retired.lock().unwrap_or_else(|p| p.into_inner()) =
                        Some(old.into_basis());
                }
                answer(&mut space)?;
            }
            pending.extend(factor);
        }
        if !pending.is_empty() {
            self.phase(&run, &pending, None)?;
        }
        let mut stats: Vec<FreqStats> = run
            .stats
            .into_inner()
            .unwrap_or_else(|p| p.into_inner())
            .into_iter()
            .map(|s| s.expect("every frequency finished"))
            .collect();
        if let Some(first) = stats.first_mut() {
            first.space_cost = space_cost;
        }
        let mut acc = self.accuracy.lock().unwrap_or_else(|p| p.into_inner());
        stats.iter().for_each(|s| acc.add(s));
        drop(acc);
        Ok((
            run.states
                .into_inner()
                .unwrap_or_else(|p| p.into_inner())
                .into_iter()
                .flatten()
                .collect(),
            stats,
        ))
    }

    /// Answers the frequencies `pending` (indices into the run's list) from the space, made by
    /// the first call, growing it for the responses that fail their certificates with a
    /// target 100× tighter each round ([`growth_targets`]): the answered leave `pending`,
    /// those the space cannot answer move to `factor`. Returns whether some still fail their
    /// certificates after the last round or with the space full (they stay in `pending`).
    fn answer_from_space<S, I, F>(
        &self,
        run: &Run<'_, S, I, F>,
        space: &mut Space<'a>,
        pending: &mut Vec<usize>,
        factor: &mut Vec<usize>,
        cost: &mut (usize, usize),
    ) -> Result<bool>
    where
        S: Send,
        I: Fn() -> S + Sync,
        F: Fn(&mut S, Snapshot<'_>) -> Result<()> + Sync,
    {
        for target in growth_targets() {
            let wanted: Vec<usize> = pending
                .iter()
                .copied()
                .filter(|&k| run.freqs_hz[k] > 0.0)
                .collect();
            if wanted.is_empty() {
                return Ok(false);
            }
            let f: Vec<f64> = wanted.iter().map(|&k| run.freqs_hz[k]).collect();
            let made = self.grow_space(space, &f, target)?;
            *cost = (cost.0 + made.0, cost.1 + made.1);
            let Space::Made(s) = &*space else {
                return Ok(false);
            };
            let failed = self.phase(run, &wanted, Some(s.as_ref()))?;
            pending.retain(|k| {
                !wanted.contains(k)
                    || failed
                        .iter()
                        .any(|&(j, why)| j == *k && why == Fallback::Grow)
            });
            factor.extend(
                failed
                    .iter()
                    .filter(|&&(_, why)| why == Fallback::Factor)
                    .map(|&(k, _)| k),
            );
            if !failed.iter().any(|&(_, why)| why == Fallback::Grow) {
                return Ok(false);
            }
            if !s.can_grow() {
                return Ok(true);
            }
        }
        Ok(true)
    }

    /// Solves the frequencies `items` (indices into the run's list) on parallel workers:
    /// from the Krylov space `space` when given — returning the items it did not answer, not
    /// stepped, and why — else by factorization (returning none).
    fn phase<S, I, F>(
        &self,
        run: &Run<'_, S, I, F>,
        items: &[usize],
        space: Option<&dyn ResponseSpace>,
    ) -> Result<Vec<(usize, Fallback)>>
    where
        S: Send,
        I: Fn() -> S + Sync,
        F: Fn(&mut S, Snapshot<'_>) -> Result<()> + Sync,
    {
        let schedule = match space {
            // no factorization: the workers need no memory beyond a response each
            Some(_) => Schedule::FrequencyParallel {
                workers: self.threads.min(items.len()).max(1),
            },
            None => {
                self.analysis()?;
                self.schedule(items.len())
            }
        };
        // Frequency-parallel, a worker that runs out of frequencies lends its thread to the
        // others: each phase of a frequency (factorization, solves, residuals) asks how many
        // are idle and runs on that many more threads, taken up by rayon's work stealing. The
        // phases give the same numbers on any thread count, so the results do not change.
        let idle = AtomicUsize::new(0);
        let (workers, par): (usize, &(dyn Fn() -> Par + Sync)) = match schedule {
            Schedule::FrequencyParallel { workers } => {
                (workers, &|| match idle.load(Ordering::Relaxed) {
                    0 => Par::Seq,
                    n => Par::rayon(n + 1),
                })
            }
            Schedule::FactorParallel { threads } => (
                1,
                if threads > 1 {
                    &move || Par::rayon(threads)
                } else {
                    &|| Par::Seq
                },
            ),
        };
        // Worker w takes the items w, w + workers, ... and state w: every state absorbs the
        // same frequencies in the same order on every run, so the result (e.g. line-fitting's
        // streamed QR, merged in worker order) is reproducible bit for bit for a thread count.
        {
            let mut states = run.states.lock().unwrap_or_else(|p| p.into_inner());
            let len = states.len().max(workers);
            states.resize_with(len, || None);
        }
        let failed = Mutex::new(Vec::new());
        // coefficients refer to the basis of `with_basis`: none once the space was replaced
        let spanned = self
            .retired
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .is_none();
        let worker = |w: usize| {
            let mut state = run.states.lock().unwrap_or_else(|p| p.into_inner())[w]
                .take()
                .unwrap_or_else(run.init);
            let mut factored = None;
            let mut spaced = SolutionBuffers::default();
            let mut mine = items.iter().skip(w).step_by(workers);
            while !run.stop.load(Ordering::Relaxed) {
                let Some(&k) = mine.next() else {
                    idle.fetch_add(1, Ordering::Relaxed);
                    break;
                };
                let f = run.freqs_hz[k];
                let r = match space {
                    Some(sp) => match self.space_response(sp, f, par(), &mut spaced) {
                        Ok((r, st)) => (run.step)(
                            &mut state,
                            Snapshot {
                                index: k,
                                freq_hz: f,
                                x: spaced.x(),
                                coefficients: spanned.then(|| r.coefficients.as_ref()),
                            },
                        )
                        .map(|()| Some(st)),
                        Err(why) => {
                            failed
                                .lock()
                                .unwrap_or_else(|p| p.into_inner())
                                .push((k, why));
                            Ok(None)
                        }
                    },
                    None => self.factored(&mut factored, f, par).and_then(|(x, st)| {
                        (run.step)(
                            &mut state,
                            Snapshot {
                                index: k,
                                freq_hz: f,
                                x,
                                coefficients: None,
                            },
                        )?;
                        Ok(Some(st))
                    }),
                };
                match r {
                    Ok(Some(st)) => run.finished(k, st),
                    Ok(None) => {}
                    Err(e) => run.fail(e),
                }
            }
            run.states.lock().unwrap_or_else(|p| p.into_inner())[w] = Some(state);
        };
        let worker = &worker;
        crate::pool::with_pool(self.threads, || {
            rayon::scope(|s| {
                for w in 0..workers {
                    s.spawn(move |_| worker(w));
                }
            })
        })?;
        if let Some(e) = run
            .first_error
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .take()
        {
            return Err(e);
        }
        Ok(failed.into_inner().unwrap_or_else(|p| p.into_inner()))
    }

    /// Factors at `f` and solves, in the worker's factorization `slot` (allocated on its first
    /// use, with its right-hand-side blocks): the response's view and the stats.
    fn factored<'s, 'w>(
        &'s self,
        slot: &'w mut Option<(Numeric<'s>, Mat<c64>, Mat<c64>)>,
        f: f64,
        par: &dyn Fn() -> Par,
    ) -> Result<(faer::MatRef<'w, c64>, FreqStats)> {
        if slot.is_none() {
            let numeric = self.analysis()?.numeric(self.body.pencil())?;
            let n = self.body.n();
            // the load and probe columns, and the probe's right-hand side A(iω) z (for refinement)
            *slot = Some((
                numeric,
                Mat::zeros(n, self.inputs.len() + 1),
                Mat::zeros(n, 1),
            ));
        }
        let (numeric, rhs, az) = slot.as_mut().expect("allocated above");
        let st = self.solve_one(numeric, f, rhs, az, par)?;
        Ok((rhs.as_ref().subcols(0, self.inputs.len()), st))
    }

    /// Factors at `f`, solves load + probe into `rhs`, checks the probe, projects; each phase
    /// on the threads `par()` gives when it starts.
    fn solve_one(
        &self,
        numeric: &mut Numeric,
        f: f64,
        rhs: &mut Mat<c64>,
        az: &mut Mat<c64>,
        par: &dyn Fn() -> Par,
    ) -> Result<FreqStats> {
        let omega = 2.0 * std::f64::consts::PI * f;
        let p = self.inputs.len();
        let t0 = Instant::now();
        // the elastic response of a free body at 0 Hz: K is singular, so solve with the body
        // held at six support DoFs and let Pᵀ remove the rigid motion (docs/design.md §3.2)
        let held = self.supports.as_ref().filter(|_| f == 0.0);
        match held {
            Some((s, scale)) => numeric.factor_supported(self.body.pencil(), s, *scale, par())?,
            None => numeric.factor(self.body.pencil(), omega, par())?,
        }
        let mut factor_s = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        // the probe's right-hand side, once per frequency (a pivoting refactorization reuses it)
        self.body
            .pencil()
            .apply(omega, self.probe.as_ref(), az.as_mut());
        let mut checked = self.solve_checked(numeric, held.is_some(), rhs, az, par);
        // the complex LDLᵀ pivots statically: when its solves stay inaccurate, the pivoting
        // LBLᵀ gets the frequency
        if !(checked.probe_error <= self.probe_tol) && held.is_none() {
            let t = Instant::now();
            if numeric.factor_with_pivoting(self.body.pencil(), par())? {
                factor_s += t.elapsed().as_secs_f64();
                checked = self.solve_checked(numeric, false, rhs, az, par);
            }
        }
        let Checked {
            probe_error,
            backward_error,
            refinement_steps,
        } = checked;
        let solve_s = t1.elapsed().as_secs_f64();
        if let (Some(rb), Response::Elastic) = (self.body.rigid(), self.response) {
            rb.project_response(rhs.as_mut().subcols_mut(0, p));
        }
        let finite = rhs.as_ref().subcols(0, p).is_all_finite();
        if !(probe_error <= self.probe_tol) || !finite {
            return Err(Error::Singular {
                freq_hz: f,
                detail: format!(
                    "probe solve error {probe_error:.2e} > {:.0e} (the probe tolerance; pivot ratio {:.1e}, \
                     {refinement_steps} refinement steps). At or very near an eigenfrequency of an \
                     undamped or lightly damped model, or an ill-conditioned large one: move the \
                     frequency, add damping, or accept solves this accurate with a larger probe \
                     tolerance (--probe-tol)",
                    self.probe_tol,
                    numeric.pivot_ratio()
                ),
            });
        }
        Ok(FreqStats {
            freq_hz: f,
            factor_s,
            solve_s,
            probe_error,
            backward_error,
            refinement_steps,
            pivot_ratio: numeric.pivot_ratio(),
            pivoted: numeric.pivoted(),
            space_dim: 0,
            relative_residual: f64::NAN,
            normwise_backward_error: f64::NAN,
            space_cost: (0, 0),
        })
    }

    /// Makes the shifted Krylov space on the first run with a frequency > 0 and grows it
    /// for `freqs_hz` to the estimated relative residual `target` (docs/design.md §3.10);
    /// returns the factorizations and block solves this cost. The shift σ = −(2π f_max/4)²
    /// lies below the spectrum (K − σM positive definite), near enough to the band that the
    /// band's modes are the space's first: any σ < 0 gives the same responses, up to the
    /// space's size. A space made by [`Self::count_below`] keeps its σ.
    fn grow_space(
        &self,
        space: &mut Space<'a>,
        freqs_hz: &[f64],
        target: f64,
    ) -> Result<(usize, usize)> {
        let mut cost = (0, 0);
        if matches!(space, Space::Unmade) {
            let top = freqs_hz.iter().copied().fold(0.0, f64::max);
            let sigma = -crate::units::hz_to_lambda(top / 4.0);
            // shifts of K − σM (§3.10, §3.12), or the linearization about s₀ = √−σ (§3.13)
            let made = self.with_space_threads(|par| {
                if self.body.pencil().shifted_space_applies() {
                    self.shifted_space(sigma, par)
                        .map(|s| Box::new(s) as Box<dyn ResponseSpace + 'a>)
                } else {
                    let max_dim = self.max_space_dim();
                    LinearizedSpace::new(
                        self.body,
                        self.load.clone(),
                        (-sigma).sqrt(),
                        max_dim,
                        par,
                    )
                    .map(|s| Box::new(s) as Box<dyn ResponseSpace + 'a>)
                }
            })?;
            *space = match made {
                Ok(s) => {
                    cost = (1, s.block_solves());
                    Space::Made(s)
                }
                Err(_) => Space::Failed,
            };
        }
        if let Space::Made(s) = space {
            let before = s.block_solves();
            crate::pool::with_pool(self.threads, || s.grow_for(freqs_hz, target))??;
            cost.1 += s.block_solves() - before;
        }
        Ok(cost)
    }

    /// The eigenvalues of K − λM below λ = (2π `f_hz`)², rigid ones included, from the
    /// inertia of the factor of the shifted Krylov space, made here about σ = λ (§3.10): the
    /// count and every response of the run from one factorization. A top that is an
    /// eigenfrequency to working precision is moved a millionth higher. Also returns what
    /// making the space cost (factorizations, block solves), which is added to
    /// [`Self::accuracy`]. `None` when no shifted space answers this solver's frequencies
    /// (general damping, a total response) or its space is made already.
    ///
    /// # Errors
    /// The factorization's errors but [`Error::Singular`] at `f_hz`.
    pub(crate) fn count_below(&self, f_hz: f64) -> Result<Option<(usize, (usize, usize))>> {
        let Some(cell) = &self.space else {
            return Ok(None);
        };
        let mut space = cell.lock().unwrap_or_else(|p| p.into_inner());
        if !matches!(*space, Space::Unmade) || !self.body.pencil().shifted_space_applies() {
            return Ok(None);
        }
        let made = self.with_space_threads(|par| {
            off_an_eigenfrequency(f_hz, |f| {
                self.shifted_space(crate::units::hz_to_lambda(f), par)
            })
        })??;
        let below = made.below();
        let cost = (1, made.block_solves());
        *space = Space::Made(Box::new(made));
        self.accuracy
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .add_space_cost(cost);
        Ok(Some((below, cost)))
    }

    /// The shifted Krylov space of this solver's load about `sigma` ([`ShiftedSpace::new`]).
    fn shifted_space(&self, sigma: f64, par: Par) -> Result<ShiftedSpace<'a>> {
        ShiftedSpace::new(
            self.body,
            self.load.clone(),
            sigma,
            self.max_space_dim(),
            par,
        )
    }

    /// A space's basis and M times it within half the memory budget, at most 3000 vectors.
    fn max_space_dim(&self) -> usize {
        (self.memory_budget / (32 * self.body.n().max(1))).clamp(1, 3000)
    }

    /// `make` with this solver's threads, in its pool.
    fn with_space_threads<R: Send>(&self, make: impl FnOnce(Par) -> R + Send) -> Result<R> {
        let par = if self.threads > 1 {
            Par::rayon(self.threads)
        } else {
            Par::Seq
        };
        crate::pool::with_pool(self.threads, || make(par))
    }

    /// Calls `f` with the basis Q of this solver's shifted Krylov space (N × k, the one
    /// [`Snapshot::coefficients`] refer to; the replaced space's once the sweep replaced it),
    /// or with `None` when it has none.
    pub(crate) fn with_basis<R>(&self, f: impl FnOnce(Option<MatRef<'_, f64>>) -> R) -> R {
        if let Some(q) = &*self.retired.lock().unwrap_or_else(|p| p.into_inner()) {
            return f(Some(q.as_ref()));
        }
        let Some(cell) = &self.space else {
            return f(None);
        };
        let space = cell.lock().unwrap_or_else(|p| p.into_inner());
        match &*space {
            Space::Made(s) => f(Some(s.basis())),
            _ => f(None),
        }
    }

    /// The response at the rows `rows` at each of `freqs_hz` from the shifted Krylov space
    /// (made and grown for them if needed; [`ShiftedSpace::rows_at`]), not certified: `None`
    /// when this solver has no space, `None` entries where the space does not answer. Also
    /// returns what growing the space cost (factorizations, block solves), which is added to
    /// [`Self::accuracy`].
    ///
    /// # Errors
    /// The space's factorization and growth errors.
    #[allow(clippy::type_complexity)]
    pub(crate) fn rows_from_space(
        &self,
        freqs_hz: &[f64],
        rows: &[usize],
    ) -> Result<(Option<Arc<Rows>>, (usize, usize))> {
        let Some(cell) = &self.space else {
            return Ok((None, (0, 0)));
        };
        let mut space = cell.lock().unwrap_or_else(|p| p.into_inner());
        // asked again before the space grew: the answer it gave (no estimate to redo)
        if let Space::Made(s) = &*space {
            if let Some(h) = s.answer(freqs_hz, rows) {
                return Ok((Some(h), (0, 0)));
            }
        }
        let wanted: Vec<f64> = freqs_hz.iter().copied().filter(|&f| f > 0.0).collect();
        // grown as far as the rows are answered, not to the certified responses' target
        let cost = self.grow_space(&mut space, &wanted, GROW_TO)?;
        self.accuracy
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .add_space_cost(cost);
        let rows = match &mut *space {
            Space::Made(s) => Some(s.rows_at(freqs_hz, rows)),
            _ => None,
        };
        Ok((rows, cost))
    }

    /// The response at `f` from the Krylov space (X in `buffers`), when the answer passes
    /// its certificate and its forward error estimate is within the probe tolerance (else
    /// the frequency is factored, where the probe decides: at an undamped eigenfrequency it
    /// is refused as singular).
    fn space_response(
        &self,
        space: &dyn ResponseSpace,
        f: f64,
        par: Par,
        buffers: &mut SolutionBuffers,
    ) -> std::result::Result<(crate::shifted_space::Solution, FreqStats), Fallback> {
        if !(f > 0.0) {
            return Err(Fallback::Factor);
        }
        let t = Instant::now();
        let r = space.solve(f, par, buffers).map_err(|_| Fallback::Factor)?;
        if !r.certified() {
            return Err(Fallback::Grow);
        }
        if !(r.forward_error_estimate() <= self.probe_tol) {
            return Err(Fallback::Factor);
        }
        let worst = |v: &[f64]| v.iter().copied().fold(0.0, f64::max);
        let stats = FreqStats {
            freq_hz: f,
            factor_s: 0.0,
            solve_s: t.elapsed().as_secs_f64(),
            probe_error: f64::NAN,
            backward_error: worst(&r.certificate.backward_error),
            refinement_steps: 0,
            pivot_ratio: f64::NAN,
            pivoted: false,
            space_dim: space.dim(),
            relative_residual: worst(&r.certificate.relative_residual),
            normwise_backward_error: worst(&r.certificate.normwise_backward_error),
            space_cost: (0, 0),
        };
        Ok((r, stats))
    }

    /// Solves load + probe into `rhs` with the current factorization, refines all columns when
    /// the probe shows lost digits (not with the supported K at 0 Hz) and measures the probe
    /// solve's backward error. `az` (N × 1) is the probe's right-hand side A(iω) z, from which
    /// with the load the refinement and the backward error form the right-hand sides again.
    fn solve_checked(
        &self,
        numeric: &mut Numeric,
        held: bool,
        rhs: &mut Mat<c64>,
        az: &Mat<c64>,
        par: &dyn Fn() -> Par,
    ) -> Checked {
        let p = self.inputs.len();
        // with the body held, the held rows of every right-hand side are 0
        let held_dofs: &[usize] = match &self.supports {
            Some((s, _)) if held => s,
            _ => &[],
        };
        let probe_rhs = |mut out: faer::MatMut<'_, c64>| {
            out.copy_from(az);
            for &d in held_dofs {
                out[(d, 0)] = c64::new(0.0, 0.0);
            }
        };
        let right_hand_sides = |mut out: faer::MatMut<'_, c64>| {
            let (mut load, probe) = out.as_mut().split_at_col_mut(p);
            probe_rhs(probe);
            for (o, l) in load.as_mut().col_iter_mut().zip(self.load.col_iter()) {
                o.iter_mut()
                    .zip(l.iter())
                    .for_each(|(o, &l)| *o = c64::new(l, 0.0));
            }
            for &d in held_dofs {
                load.as_mut().row_mut(d).fill(c64::new(0.0, 0.0));
            }
        };
        right_hand_sides(rhs.as_mut());
        numeric.solve(rhs.as_mut(), par());
        let mut probe_error = self.probe_error(rhs.as_ref().col(p));
        let mut refinement_steps = 0;
        let mut measured = None;
        if probe_error > REFINE_ABOVE && !held {
            let done = numeric.refine(self.body.pencil(), right_hand_sides, rhs.as_mut(), par());
            refinement_steps = done.steps + done.gmres_solves;
            measured = done.backward_errors.map(|e| e[p]);
            probe_error = self.probe_error(rhs.as_ref().col(p));
        }
        // the refinement's last residual has it; else one column (over all of them the
        // residual's scalar products cost half a solve)
        let backward_error = measured.unwrap_or_else(|| {
            numeric.backward_error(
                self.body.pencil(),
                probe_rhs,
                rhs.as_ref().subcols(p, 1),
                par(),
            )
        });
        Checked {
            probe_error,
            backward_error,
            refinement_steps,
        }
    }

    /// ‖Pᵀ(x − z)‖/‖z‖: the relative error of the probe solve `x` (elastic part on a free body).
    fn probe_error(&self, x: faer::ColRef<'_, c64>) -> f64 {
        let mut err = Mat::<c64>::from_fn(x.nrows(), 1, |i, _| x[i] - self.probe[(i, 0)]);
        if let Some(rb) = self.body.rigid() {
            rb.project_response(err.as_mut());
        }
        err.norm_l2() / self.probe.norm_l2()
    }
}

/// Whether a solver of `body` for `response` with `opts` answers frequencies from a
/// shifted Krylov space ([`SolveMethod::Auto`], docs/design.md §3.10): the factors are kept
/// in memory and whole in this process ([`crate::factor::held_whole`]), the damping is
/// proportional but for a low-rank remainder (§3.12), and the response is elastic or the body
/// constrained (a free body's total response keeps its rigid part, which the space leaves
/// out).
pub(crate) fn space_applies(body: &Body, response: Response, opts: &SweepOptions) -> bool {
    opts.method == SolveMethod::Auto
        && opts.out_of_core.is_none()
        && crate::factor::held_whole(opts.backend)
        && (body.pencil().shifted_space_applies() || body.pencil().linearized_space_applies())
        && (response == Response::Elastic || body.rigid().is_none())
}

/// The refusal of the total response at 0 Hz on a free body.
pub(crate) fn zero_hz_total() -> Error {
    Error::InvalidSetting(
        "frequency 0 Hz on a free body: the total response H(0) is infinite (the rigid part \
         grows like 1/ω²); the elastic part is finite at 0 Hz (part elastic), or use \
         frequencies > 0 (e.g. a band starting at 1 Hz)"
            .into(),
    )
}
