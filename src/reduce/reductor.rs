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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::eigen::EigenOptions;
    use crate::fe::{bar_model, paper_scene, BoxSpec};
    use crate::reduce::interface::Interface;
    use crate::reduce::linefit::References;
    use crate::reduce::serep::ModeChoice;

    /// The entry is the method's own entry: the same ROM, bit for bit, for each method (one
    /// thread: with more, line-fitting's workers merge their QR states in the order they
    /// finish).
    #[test]
    fn the_entry_gives_each_methods_own_rom() {
        let spec = BoxSpec::paper_bar();
        let (model, scene) = (bar_model(&spec).unwrap(), paper_scene(&spec));
        let body = Body::new(&model).unwrap();
        let mut lf = LineFitOptions::new(
            Interface::OutputsPlus(5),
            References::Explicit(vec![50.0, 150.0, 400.0, 800.0, 1000.0]),
        );
        lf.sweep.threads = 1;
        let serep = SerepOptions {
            modes: ModeChoice::LowestDeformation(9),
            retain: None,
            keep_basis: false,
            eigen: EigenOptions::for_band(scene.band_hz[1]),
        };
        let mut cb = CraigBamptonOptions::new(Interface::OutputsPlus(1), 4, scene.band_hz[1]);
        cb.threads = 1;
        let pairs = [
            (
                reduce(
                    &body,
                    &scene,
                    &Reductor::LineFit(lf.clone()),
                    &Context::default(),
                ),
                linefit::reduce(&body, &scene, &lf, None, &no_progress),
            ),
            (
                reduce(
                    &body,
                    &scene,
                    &Reductor::Serep(serep.clone()),
                    &Context::default(),
                ),
                serep::reduce(&body, &scene, &serep, None),
            ),
            (
                reduce(
                    &body,
                    &scene,
                    &Reductor::CraigBampton(cb.clone()),
                    &Context::default(),
                ),
                craig_bampton::reduce(&body, &scene, &cb),
            ),
        ];
        for (entry, own) in pairs {
            let (entry, own) = (entry.unwrap(), own.unwrap());
            assert_eq!(entry.method(), own.method());
            assert_eq!(entry.dofs, own.dofs);
            for (a, b) in [(&entry.mr, &own.mr), (&entry.kr, &own.kr)] {
                let bits = |m: &faer::Mat<f64>| -> Vec<u64> {
                    (0..m.ncols())
                        .flat_map(|j| (0..m.nrows()).map(move |i| (i, j)))
                        .map(|(i, j)| m[(i, j)].to_bits())
                        .collect()
                };
                assert_eq!(bits(a), bits(b), "{}", entry.method());
            }
        }
    }
}
