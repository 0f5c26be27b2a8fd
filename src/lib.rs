//! sparsemor: model order reduction of large sparse structural FE models.
//!
//! The full model M q'' + D q' + K q = B u, y = C q (docs/design.md §1, eq. 3) is reduced to
//! Mr q̈ + Dr q̇ + Kr q = Br u, y = Cr q by a projection q ≈ V q̃ that reproduces the
//! transfer function H(iω) = C (K − ω²M + iωD)⁻¹ B over a band. Nothing of size N × N is
//! ever formed. Each algorithm has one module; docs/design.md states the math.
//!
//! | step | entry point | design |
//! |---|---|---|
//! | load a model | [`io::model_dir::read`] (model + its default [`scene::Scene`]), [`io::matrix_market`], built-in [`fe::bar_model`] | §4 |
//! | validate | [`model::Model::new`] | §1, §4 |
//! | prepare once | [`body::Body::new`]: pencil ([`pencil`]), rigid part ([`rigid`]), symbolic analysis | §2, §3.1, §3.2 |
//! | factor A(iω) | [`factor::Analysis`], [`factor::Numeric`] (faer LBLᵀ / LU, UMFPACK) | §3.1 |
//! | sweep frequencies | [`frf::transfer_function`], [`sweep::Solver`] | §3.1 |
//! | streamed least squares | [`lsq::StreamedQr`] | §3.3 |
//! | reduce (any method) | [`reduce::reduce`] with a [`reduce::Reductor`] and a [`reduce::Context`] | §3.3–§3.8 |
//! | line-fitting | [`reduce::linefit::reduce`] with [`reduce::linefit::References`] (explicit, count, tolerance: the adaptive loop) | §3.3–§3.5 |
//! | eigenpairs | [`eigen::eigenpairs`] (shift-invert Krylov–Schur; ARPACK feature) | §3.6 |
//! | SEREP | [`reduce::serep::reduce`] | §3.6 |
//! | Craig–Bampton | [`reduce::craig_bampton::reduce`] | §3.8 |
//! | projection, the ROM | [`reduce::project`], [`reduce::Rom`] with its [`reduce::Provenance`] | §3.4 |
//! | metrics | [`metrics::Reference`] (ε(f)), [`metrics::modal_comparison`] (frequency error, MAC) | §3.7 |
//! | write a ROM | [`io::rom_dir::write`] (`.mtx` + `rom.npz`) | §4 |
//! | export a flexible body | [`reduce::flexible::elastic_basis`], [`io::exudyn::write`] | §3.9 |
//!
//! Library code never prints: progress goes through a callback ([`sweep::ProgressFn`]),
//! results and diagnostics are returned, failures are a typed [`Error`].
//!
//! ```
//! use sparsemor::body::Body;
//! use sparsemor::fe::{bar_model, paper_scene, BoxSpec};
//! use sparsemor::metrics::{ErrorCurve, Reference};
//! use sparsemor::reduce::interface::Interface;
//! use sparsemor::reduce::linefit::{LineFitOptions, References, SamplingOptions};
//! use sparsemor::reduce::{reduce, Context, Reductor};
//! use sparsemor::sweep::{no_progress, SweepOptions};
//!
//! // the paper's bar (N = 1656) and its scene: 9 inputs = outputs, band [0, 1000] Hz
//! let spec = BoxSpec::paper_bar();
//! let (model, scene) = (bar_model(&spec)?, paper_scene(&spec));
//! let body = Body::new(&model)?;
//! // ask for an accuracy; the reference frequencies are chosen by the sampling loop
//! let opts = LineFitOptions::new(Interface::Auto, References::Tolerance(SamplingOptions::new(1e-2)));
//! let rom = reduce(&body, &scene, &Reductor::LineFit(opts), &Context::default())?;
//! let report = rom.sampling().expect("a tolerance-driven ROM");
//! assert!(report.error <= 1e-2);
//! // check it independently on 200 points: eq. 23 against full solves
//! let grid: Vec<f64> = (0..200).map(|k| 1.0 + 999.0 * k as f64 / 199.0).collect();
//! let reference = Reference::compute(&body, &scene, &grid, &SweepOptions::default(), None, &no_progress)?;
//! let (max_eps, _) = ErrorCurve::max_mean(&reference.error(&rom)?.eps_elastic);
//! assert!(max_eps <= 1e-2, "order {}: {max_eps:.2e}", rom.order());
//! # Ok::<(), sparsemor::Error>(())
//! ```
#![warn(missing_docs)]
// `!(x > 0.0)` and friends are deliberate: unlike `x <= 0.0` they also reject NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
// Sparse kernels walk CSC arrays by index; iterator rewrites hide the structure.
#![allow(clippy::needless_range_loop)]

pub mod body;
pub mod coupled;
pub mod coupling;
pub mod dense;
pub mod eigen;
pub mod engine;
pub mod error;
pub mod factor;
pub mod fe;
pub mod frf;
pub mod grid;
pub mod io;
pub(crate) mod linearized_space;
pub mod lsq;
pub mod memory;
pub mod metrics;
pub mod model;
pub mod pencil;
pub mod pool;
pub mod proportional;
pub(crate) mod random;
pub mod reduce;
pub mod report;
pub mod rigid;
pub mod scene;
pub(crate) mod shifted_space;
pub(crate) mod snapshots;
pub mod sparse;
pub mod sweep;
pub mod units;

pub use error::{Error, Result};
