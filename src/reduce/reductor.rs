//! The one entry of every reduction (docs/design.md §3.3–3.8): a method with its options
//! ([`Reductor`]), what the caller already has ([`Context`]), and [`reduce`], which the
//! command, the C ABI and the benchmarks call alike.

use super::craig_bampton::{self, CraigBamptonOptions};
use super::linefit::{self, LineFitOptions};
use super::rom::Rom;
use super::serep::{self, SerepOptions};
use crate::body::Body;
use crate::eigen::Modes;
use crate::scene::Scene;
use crate::sweep::{no_progress, ProgressFn};
use crate::Result;

/// A reduction method and its settings.
#[derive(Clone, Debug)]
pub enum Reductor {
    /// Line-fitting, V = Πᵀ[I; W] (§3.3–3.5).
    LineFit(LineFitOptions),
    /// SEREP, V from the chosen eigenpairs (§3.6).
    Serep(SerepOptions),
    /// Craig–Bampton, V = Πᵀ[[I, 0]; [Ψ, Φ_c]] (§3.8).
    CraigBampton(CraigBamptonOptions),
}

/// What a reduction may use beside the body and the scene.
#[derive(Clone, Copy)]
pub struct Context<'a> {
    /// Eigenpairs of the body the caller already has, lowest first: SEREP takes its modes
    /// from them and line-fitting its resonances ([`linefit::References::Count`]) when they
    /// cover what is asked; Craig–Bampton's fixed-interface modes are not the body's.
    pub known_modes: Option<&'a Modes>,
    /// Called after each solved frequency of line-fitting; false cancels the run.
    pub progress: ProgressFn<'a>,
}

impl Default for Context<'_> {
    fn default() -> Self {
        Context {
            known_modes: None,
            progress: &no_progress,
        }
    }
}

/// Reduces `body` for the scene's inputs, outputs and band with `reductor`.
///
/// # Errors
/// As the method's own entry: [`linefit::reduce`], [`serep::reduce`],
/// [`craig_bampton::reduce`].
pub fn reduce(
    body: &Body,
    scene: &Scene,
    reductor: &Reductor,
    context: &Context<'_>,
) -> Result<Rom> {
    match reductor {
        Reductor::LineFit(o) => {
            linefit::reduce(body, scene, o, context.known_modes, context.progress)
        }
        Reductor::Serep(o) => serep::reduce(body, scene, o, context.known_modes),
        Reductor::CraigBampton(o) => craig_bampton::reduce(body, scene, o),
    }
}
