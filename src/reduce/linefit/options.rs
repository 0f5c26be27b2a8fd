//! The settings of line-fitting: the interface, how the reference frequencies are chosen
//! (explicit, a count placed beside the resonances, or a tolerance for the adaptive loop of
//! docs/design.md §3.5) and how the loop may grow the interface.

use crate::engine::Cluster;
use crate::lsq::LsqOptions;
use crate::reduce::interface::Interface;
use crate::sweep::SweepOptions;
use std::sync::Arc;

/// How the reference frequencies are chosen.
#[derive(Clone, Debug)]
pub enum References {
    /// These frequencies (Hz), each > 0 on a free body.
    Explicit(Vec<f64>),
    /// This many, placed beside the resonances of the scene's band by
    /// [`super::place_reference_frequencies`] (the modes are computed, or taken from the caller).
    Count(usize),
    /// As many as the adaptive sampling loop needs to reach a tolerance (docs/design.md §3.5).
    Tolerance(SamplingOptions),
}

/// Settings of a line-fitting reduction.
#[derive(Clone, Debug)]
pub struct LineFitOptions {
    /// The interface (the initial one when the sampling loop may grow it).
    pub interface: Interface,
    /// The reference frequencies.
    pub references: References,
    /// Keep V (N×n) in the result.
    pub keep_basis: bool,
    /// Sweep settings (threads, backend, memory).
    pub sweep: SweepOptions,
    /// The ranks the reference frequencies are spread over (docs/design.md §9); `None` = this
    /// process alone.
    pub cluster: Option<Arc<dyn Cluster>>,
    /// Least-squares settings (rank truncation).
    pub lsq: LsqOptions,
}

impl LineFitOptions {
    /// Defaults (all threads, automatic backend, default rank rule, no basis kept) for an
    /// interface and a choice of reference frequencies.
    pub fn new(interface: Interface, references: References) -> Self {
        LineFitOptions {
            interface,
            references,
            keep_basis: false,
            sweep: SweepOptions::default(),
            cluster: None,
            lsq: LsqOptions::default(),
        }
    }
}

/// How the interface grows when frequencies stop helping (by a tenth of the order at a time,
/// at least one DoF, or by the band's resonances the ROM misses when that is more).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Growth {
    /// The default: [`Self::QDeim`] in one process, [`Self::Residual`] over the ranks of a
    /// distributed run (whose snapshots stay on their ranks).
    Auto,
    /// The non-interface DoFs with the largest relative fit residual (eq. 22), one per node.
    Residual,
    /// Q-DEIM continued from the interface: the DoF whose row of the snapshots' left
    /// singular vectors adds the most to the span of the interface rows (see
    /// `src/snapshots.rs`).
    QDeim,
}

/// Settings of the sampling loop ([`References::Tolerance`]).
#[derive(Clone, Debug)]
pub struct SamplingOptions {
    /// Target: max true elastic ε (eq. 23) at the newly picked and the sampled points.
    pub tol: f64,
    /// Extra seed frequencies (Hz).
    pub seeds_hz: Vec<f64>,
    /// Budget of full solves (frequencies solved); `None` = 60 when every frequency is
    /// factored, 8 × the order cap when the responses come from a shifted Krylov space
    /// (docs/design.md §3.10: one factorization serves them all).
    pub max_points: Option<usize>,
    /// Largest order the interface may grow to; `None` = [`SamplingOptions::auto_max_order`].
    /// At most the initial order keeps the order fixed.
    pub max_order: Option<usize>,
    /// Verification: full solves at this many points spread evenly over the band after the
    /// loop, whose max ε is reported as the verified error of the returned ROM; `None` =
    /// ⌈F/3⌉ for F factorizations of the loop (≈ 25 % of the run), `Some(0)` = none.
    pub verify_points: Option<usize>,
    /// Candidate grid size of the indicator.
    pub candidates: usize,
    /// Interface growth rule. Default [`Growth::Auto`]: Q-DEIM spreads the DoFs it adds at
    /// once over the body where the largest residuals cluster at one place (on the 3 m bar,
    /// tol 1e-2 at order 60 against 79; docs/design.md §3.5).
    pub growth: Growth,
    /// Memory for kept snapshots (bytes); `None` = a quarter of the available memory.
    pub snapshot_memory: Option<usize>,
}

impl SamplingOptions {
    /// Defaults for a tolerance: the automatic budget of full solves, growth up to
    /// [`Self::auto_max_order`], 2000 candidates, automatic growth rule and verification.
    pub fn new(tol: f64) -> Self {
        SamplingOptions {
            tol,
            seeds_hz: Vec::new(),
            max_points: None,
            max_order: None,
            verify_points: None,
            candidates: 2000,
            growth: Growth::Auto,
            snapshot_memory: None,
        }
    }
}

impl SamplingOptions {
    /// The default cap of the order for an initial order n0, q outputs, c elastic modes in
    /// the band, N DoFs, `threads` workers and `memory` bytes available:
    /// min(max(3·n0, 40, q + 2c), N/2, M/(32·threads·N)) — three times the initial order (at
    /// least 40: the paper bar reaches tol 1e-4 at order 21–22 from 14, docs/performance.md)
    /// and room for two interface DoFs per resonance in the band (the 3 m bar, 42 modes in
    /// [0, 1000] Hz, needs order 61 at tol 1e-2), never more than half the DoFs, and the
    /// workers' streamed-QR states (n·N doubles each) within a quarter of the memory. Never
    /// below n0.
    pub fn auto_max_order(
        n0: usize,
        outputs: usize,
        modes_in_band: usize,
        n: usize,
        threads: usize,
        memory: usize,
    ) -> usize {
        let by_memory = memory / (32 * threads.max(1) * n.max(1));
        (3 * n0)
            .max(40)
            .max(outputs + 2 * modes_in_band)
            .min(n / 2)
            .min(by_memory)
            .max(n0)
    }

    /// The default budget of full solves ([`Self::max_points`] = `None`): 60 when every
    /// frequency is factored, 8 × `max_order` when the responses come from a shifted Krylov
    /// space.
    pub fn auto_max_points(max_order: usize, krylov: bool) -> usize {
        if krylov {
            (8 * max_order).max(60)
        } else {
            60
        }
    }
}
