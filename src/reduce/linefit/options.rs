//! The settings of line-fitting: the interface, how the reference frequencies are chosen
//! (explicit, a count placed beside the resonances, or a tolerance for the adaptive loop of
//! docs/design.md §3.5) and how the loop may grow the interface.

use crate::lsq::LsqOptions;
use crate::sweep::SweepOptions;

/// How the interface (the ROM's DoFs, order n) is chosen.
#[derive(Clone, Debug, PartialEq)]
pub enum Interface {
    /// These DoFs (must contain every output).
    Explicit(Vec<usize>),
    /// The outputs plus k DoFs spread along the body by [`super::spread_dofs`].
    OutputsPlus(usize),
}

/// How the reference frequencies are chosen.
#[derive(Clone, Debug)]
pub enum References {
    /// These frequencies (Hz), each > 0 on a free body.
    Explicit(Vec<f64>),
    /// This many, placed beside the resonances of the scene's band by
    /// [`super::place_reference_frequencies`] (the modes are computed, or taken from the caller).
    Count(usize),
    /// As many as the adaptive sampling loop needs to reach a tolerance (DESIGN.md §3.5).
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
    /// [`super::snapshots`]).
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
    /// Largest order; > the initial order lets the interface grow.
    pub max_order: usize,
    /// Candidate grid size of the indicator.
    pub candidates: usize,
    /// Interface growth rule. Default: the largest fit residual — measured on the paper bar
    /// for tol = 1e-3 it needs order 17 and 21 factorizations where Q-DEIM needs 18 and 22
    /// (both reach the tolerance; see the README), and it needs no SVD of the snapshots.
    pub growth: Growth,
    /// Memory for kept snapshots (bytes); `None` = a quarter of the available memory.
    pub snapshot_memory: Option<usize>,
}

impl SamplingOptions {
    /// Defaults for a tolerance: 60 factorizations, no order growth, 2000 candidates,
    /// residual growth.
    pub fn new(tol: f64) -> Self {
        SamplingOptions {
            tol,
            seeds_hz: Vec::new(),
            max_points: 60,
            max_order: 0,
            candidates: 2000,
            growth: Growth::Residual,
            snapshot_memory: None,
        }
    }
}
