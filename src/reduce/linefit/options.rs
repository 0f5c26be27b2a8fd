//! The settings of line-fitting: the interface, how the reference frequencies are chosen
//! (explicit, a count placed beside the resonances, or a tolerance for the adaptive loop of
//! docs/design.md §3.5) and how the loop may grow the interface.

use crate::lsq::LsqOptions;
use crate::reduce::interface::Interface;
use crate::sweep::SweepOptions;

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
            lsq: LsqOptions::default(),
        }
    }
}

/// How the interface grows when frequencies stop helping.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Growth {
    /// The non-interface DoF with the largest relative fit residual (eq. 22).
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
    /// Budget of factorizations (frequencies solved).
    pub max_points: usize,
    /// Largest order the interface may grow to; `None` = [`SamplingOptions::auto_max_order`].
    /// At most the initial order keeps the order fixed.
    pub max_order: Option<usize>,
    /// Verification: full solves at this many points spread evenly over the band after the
    /// loop, whose max ε is reported as the verified error of the returned ROM; `None` =
    /// ⌈F/3⌉ for F factorizations of the loop (≈ 25 % of the run), `Some(0)` = none.
    pub verify_points: Option<usize>,
    /// Candidate grid size of the indicator.
    pub candidates: usize,
    /// Interface growth rule. Default: the largest fit residual, which reaches tol = 1e-3 on
    /// the paper bar at order 17 with 22 factorizations where Q-DEIM needs order 18 and 23
    /// (docs/performance.md, "Speed and accuracy"), and needs no SVD of the snapshots.
    pub growth: Growth,
    /// Memory for kept snapshots (bytes); `None` = a quarter of the available memory.
    pub snapshot_memory: Option<usize>,
}

impl SamplingOptions {
    /// Defaults for a tolerance: 60 factorizations, growth up to
    /// [`Self::auto_max_order`], 2000 candidates, residual growth, automatic verification.
    pub fn new(tol: f64) -> Self {
        SamplingOptions {
            tol,
            seeds_hz: Vec::new(),
            max_points: 60,
            max_order: None,
            verify_points: None,
            candidates: 2000,
            growth: Growth::Residual,
            snapshot_memory: None,
        }
    }
}

impl SamplingOptions {
    /// The default cap of the order for an initial order n0, N DoFs, `threads` workers and
    /// `memory` bytes available: min(max(3·n0, 40), N/2, M/(32·threads·N)) — three times the
    /// initial order (at least 40: the paper bar reaches tol 1e-4 at order 21–22 from 14,
    /// docs/performance.md), never more than half the DoFs, and the workers' streamed-QR
    /// states (n·N doubles each) within a quarter of the memory. Never below n0.
    pub fn auto_max_order(n0: usize, n: usize, threads: usize, memory: usize) -> usize {
        let by_memory = memory / (32 * threads.max(1) * n.max(1));
        (3 * n0).max(40).min(n / 2).min(by_memory).max(n0)
    }
}
