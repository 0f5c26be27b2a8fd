//! Reduced models (docs/design.md §3.4): the [`Rom`] type with its [`Provenance`]
//! (`rom.rs`; the sampling loop's report in `sampling_report.rs`), the shared Galerkin
//! projection with its definiteness check ([`project`], [`Definiteness`]),
//! and the methods that build V: [`linefit`] (§3.3, §3.5), [`serep`] (§3.6) and
//! [`craig_bampton`] (§3.8), behind one entry, [`reduce`] with a [`Reductor`]. Every
//! reductor takes a prepared [`crate::body::Body`] and a [`crate::scene::Scene`] and ends in
//! [`project`]; `spectrum.rs` gives a ROM's eigenpairs; [`interface`] chooses the physical DoFs of line-fitting and Craig–Bampton. [`flexible`] turns any ROM's basis into the rigid-free elastic basis a
//! floating-frame multibody code needs (§3.9).

pub mod craig_bampton;
pub mod flexible;
pub mod interface;
pub mod linefit;
pub(crate) mod projection;
mod reductor;
pub(crate) mod rom;
pub(crate) mod sampling_report;
pub mod serep;
pub(crate) mod spectrum;
mod transfer;

pub use projection::{project, Definiteness, Projected};
pub use reductor::{reduce, Context, Reductor};
pub use rom::{CraigBamptonReport, FitReport, Method, Provenance, Rom, Timing};
