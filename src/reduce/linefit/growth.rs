//! How much the interface grows when the sampling loop stagnates, and which DoFs the
//! residual rule adds (docs/design.md §3.5, step 6; the Q-DEIM rule is in
//! [`crate::snapshots`]): g = max(1, ⌊n/10⌋, c − c′) DoFs at once, c the body's elastic
//! modes in the band ([`elastic_modes_below`]) and c′ the ROM's ([`missing_modes`]).

use super::options::Growth;
use crate::body::Body;
use crate::engine::Engine;
use crate::factor::{count_eigenvalues_below_with, off_an_eigenfrequency};
use crate::reduce::rom::{FitReport, Rom};
use crate::reduce::spectrum::rom_spectrum;
use crate::snapshots::GrowBy;
use crate::sweep::Response;
use crate::units::hz_to_lambda;
use crate::Result;

/// The number of elastic eigenfrequencies of the body below `f_hz`, exactly, from the
/// inertia of K − (2πf)²M: the factor of the `engine`'s shifted Krylov space when one
/// answers the run's elastic responses to `inputs` (made about that shift,
/// [`Engine::count_below`]: no factorization of its own), else one real factorization
/// ([`count_eigenvalues_below_with`]); less the rigid modes. Also returns the
/// factorizations it took outside the engine (0 or 1). A band end that is an
/// eigenfrequency to working precision is counted a millionth higher.
pub(super) fn elastic_modes_below(
    body: &Body,
    engine: &mut Engine<'_>,
    inputs: &[usize],
    f_hz: f64,
) -> Result<(usize, usize)> {
    let (below, outside) = match engine.count_below(Response::Elastic, inputs, f_hz)? {
        Some(below) => (below, 0),
        None => {
            let sym = body.symbolic()?;
            let below = off_an_eigenfrequency(f_hz, |f| {
                count_eigenvalues_below_with(
                    &sym,
                    body.pencil(),
                    hz_to_lambda(f),
                    body.factor_storage(),
                )
            })?;
            (below, 1)
        }
    };
    let rigid = if body.rigid().is_some() { 6 } else { 0 };
    Ok((below.saturating_sub(rigid), outside))
}

/// How many of the body's `c` elastic eigenfrequencies below `top_hz` (`modes_in_band`)
/// the ROM lacks: c less the ROM's own elastic eigenfrequencies there, c′. A ROM reproduces
/// the band's c resonances only with c eigenfrequencies in the band, and an interface DoF
/// adds one eigenvalue, so c − c′ is the least growth that can give it them. The ROM is a
/// Galerkin projection (Mr = VᵀMV, Kr = VᵀKV): its k-th eigenvalue is at least the body's
/// k-th (Courant–Fischer), so c′ is at most c plus the rigid modes. 0 when c is unknown
/// (explicit interface and order cap) or the ROM's spectrum is not computable.
pub(super) fn missing_modes(modes_in_band: Option<usize>, rom: &Rom, top_hz: f64) -> usize {
    let Some(c) = modes_in_band else {
        return 0;
    };
    let Ok(spectrum) = rom_spectrum(rom) else {
        return 0;
    };
    let below = spectrum
        .freqs_hz
        .iter()
        .filter(|&&f| f > 0.0 && f <= top_hz)
        .count();
    c.saturating_sub(below)
}

/// The DoFs one growth adds to an interface of `order` DoFs: at least a tenth of the order
/// (so that a large interface does not grow one DoF per step), at least one, at least the
/// `missing` resonances, at most the `room` left below the order cap. Q-DEIM adds more, up
/// to the snapshots' numerical rank at tol, when that is more.
pub(super) fn dofs_to_add(order: usize, missing: usize, room: usize) -> usize {
    (order / 10).max(1).max(missing).min(room)
}

/// The residual rule's DoFs ([`super::Growth::Residual`]): the `g` DoFs of largest fit
/// residual, one per node, or the DoF of largest residual when the fit kept none (DoF 0
/// without a fit report).
pub(super) fn largest_residuals(fit: Option<&FitReport>, g: usize) -> Vec<usize> {
    let mut d: Vec<usize> = fit
        .map(|f| f.growth_candidates.iter().copied().take(g).collect())
        .unwrap_or_default();
    if d.is_empty() {
        d.push(fit.map(|f| f.residual_argmax_dof).unwrap_or(0));
    }
    d
}

/// The DoFs one growth adds to `interface` by the resolved `rule`: the `g` of largest fit
/// residual of `rom` ([`largest_residuals`]), or Q-DEIM continued from the interface over
/// the `engine`'s kept snapshots, at least `g` and at most the `room` below the order cap,
/// up to the snapshots' numerical rank at `tol`.
///
/// # Errors
/// Those of the engine's Q-DEIM pass.
pub(super) fn dofs(
    rule: Growth,
    engine: &mut Engine<'_>,
    interface: &[usize],
    rom: &Rom,
    [g, room]: [usize; 2],
    tol: f64,
) -> Result<Vec<usize>> {
    match rule {
        Growth::Residual | Growth::Auto => Ok(largest_residuals(rom.fit(), g)),
        Growth::QDeim => {
            let by = GrowBy {
                at_least: g,
                at_most: room,
                rank_tol: tol,
            };
            engine.qdeim_next(interface, by)
        }
    }
}

/// The growth step's action: why it grew, the DoFs added and the new order.
pub(super) fn action(missing: usize, dofs: &[usize], order: usize) -> String {
    format!(
        "{}: grow interface by DoF{} {} (order {}), refit from kept snapshots",
        match missing {
            0 => "stagnated".to_string(),
            m => format!("lacks {m} of the band's resonances"),
        },
        if dofs.len() > 1 { "s" } else { "" },
        dofs.iter()
            .map(|x| x.to_string())
            .collect::<Vec<_>>()
            .join(", "),
        order
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fe::{bar_model, paper_scene, BoxSpec};
    use crate::reduce::interface::Interface;
    use crate::reduce::linefit::{LineFitOptions, References};

    /// The elastic modes of `body` below `f`, counted by the factor of a fresh engine's
    /// shifted space (no factorization outside it), which must agree with the inertia of a
    /// factorization of its own.
    fn counted(body: &Body, inputs: &[usize], f: f64) -> usize {
        let opts = crate::sweep::SweepOptions::default();
        let mut engine = Engine::new(body, &opts, None);
        let (c, outside) = elastic_modes_below(body, &mut engine, inputs, f).unwrap();
        assert_eq!(outside, 0, "{f} Hz: counted outside the space");
        let sym = body.symbolic().unwrap();
        let own = count_eigenvalues_below_with(
            &sym,
            body.pencil(),
            hz_to_lambda(f),
            crate::factor::Storage::IN_CORE,
        )
        .unwrap();
        let rigid = if body.rigid().is_some() { 6 } else { 0 };
        assert_eq!(c, own - rigid, "{f} Hz: the space's count");
        c
    }

    /// A line-fitting ROM never has more eigenfrequencies below f than the body (inertia
    /// count, rigid modes included), at any f, and the count it lacks at the band's top is
    /// the body's elastic count less its own: the free bar of 1.5 m (22 elastic modes below
    /// 1000 Hz) fitted at order 14.
    #[test]
    fn a_rom_has_no_more_eigenfrequencies_below_f_than_the_body() {
        let spec = BoxSpec {
            elements: [1, 2, 150],
            size_m: [0.006, 0.008, 1.5],
            ..BoxSpec::paper_bar()
        };
        let model = bar_model(&spec).unwrap();
        let body = Body::new(&model).unwrap();
        let scene = paper_scene(&spec);
        let refs = References::Explicit(vec![10.0, 300.0, 700.0, 1000.0]);
        let opts = LineFitOptions::new(Interface::OutputsPlus(5), refs);
        let rom =
            super::super::reduce(&body, &scene, &opts, None, &crate::sweep::no_progress).unwrap();
        let rigid = if body.rigid().is_some() { 6 } else { 0 };
        let spectrum = rom_spectrum(&rom).unwrap();
        for f in [50.0, 200.0, 500.0, 1000.0, 3000.0] {
            let rom_below = spectrum.freqs_hz.iter().filter(|&&x| x <= f).count();
            let body_below = counted(&body, &scene.inputs, f) + rigid;
            assert!(
                rom_below <= body_below,
                "{f} Hz: {rom_below} > {body_below}"
            );
        }
        let c = counted(&body, &scene.inputs, 1000.0);
        assert_eq!(c, 22);
        let elastic_below = spectrum
            .freqs_hz
            .iter()
            .filter(|&&x| x > 0.0 && x <= 1000.0)
            .count();
        assert!(elastic_below < c);
        assert_eq!(missing_modes(Some(c), &rom, 1000.0), c - elastic_below);
        assert_eq!(missing_modes(None, &rom, 1000.0), 0);
    }

    #[test]
    fn a_growth_adds_a_tenth_of_the_order_or_the_missing_resonances_within_the_cap() {
        assert_eq!(dofs_to_add(30, 0, 100), 3);
        assert_eq!(dofs_to_add(9, 0, 100), 1);
        assert_eq!(dofs_to_add(30, 16, 100), 16);
        assert_eq!(dofs_to_add(30, 16, 5), 5);
    }

    #[test]
    fn the_residual_rule_takes_the_largest_residuals_or_the_largest_one() {
        let fit = |candidates: Vec<usize>| FitReport {
            cond_raw: 1.0,
            cond_equilibrated: 1.0,
            rank: 4,
            truncated: false,
            residual_max: 0.1,
            residual_mean: 0.01,
            residual_argmax_dof: 42,
            growth_candidates: candidates,
            rows: 8,
            solves: Default::default(),
        };
        assert_eq!(largest_residuals(Some(&fit(vec![7, 3, 9])), 2), [7, 3]);
        assert_eq!(largest_residuals(Some(&fit(Vec::new())), 2), [42]);
        assert_eq!(largest_residuals(None, 2), [0]);
        assert_eq!(
            action(0, &[7, 3], 12),
            "stagnated: grow interface by DoFs 7, 3 (order 12), refit from kept snapshots"
        );
        assert_eq!(
            action(2, &[7], 11),
            "lacks 2 of the band's resonances: grow interface by DoF 7 (order 11), refit from \
             kept snapshots"
        );
    }
}
