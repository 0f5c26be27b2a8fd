//! A second built-in geometry: a free-free L-shaped bracket of 8-node hexahedra — not a bar,
//! so that accuracy claims are checked on a body with a corner, two arms and coupled
//! bending/torsion.
//!
//! # The model
//!
//! On a uniform grid of cubic cells of edge h, the bracket is the L-shaped profile in the x–z
//! plane extruded along y: a horizontal flange (x ∈ [0, L_x], z ∈ [0, t]) and a vertical
//! flange (x ∈ [0, t], z ∈ [0, L_z]), width w in y. A cell (i, j, k) is part of the body when
//! i < t/h or k < t/h. Nodes are the grid points touched by an active cell, numbered in grid
//! order (x fastest, then y, then z); node i owns DoFs 3i..3i+2 (x, y, z). The element is the
//! rectangular trilinear hexahedron of [`super`] (consistent mass, 2×2×2 Gauss, exact for
//! this element); the element matrices are scattered cell by cell and summed. No DoF is
//! constrained: K has the six rigid-body modes as its null space.
//!
//! The default [`BracketSpec::steel`] (legs 200 × 150 mm, 20 mm thick, 50 mm wide, 10 mm
//! cells) has 330 elements, 612 nodes, N = 1836 DoFs.

use super::bar::PAPER_RAYLEIGH_BETA;
use super::hex8::Hex8;
use crate::model::{Damping, Model};
use crate::scene::Scene;
use crate::sparse::Csc;
use crate::{Error, Result};
use faer::sparse::{SparseColMat, Triplet};

/// What to mesh: the L-shaped bracket of the module doc.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BracketSpec {
    /// Leg lengths (L_x, L_z) in metres.
    pub legs_m: [f64; 2],
    /// Flange thickness t (m).
    pub thickness_m: f64,
    /// Width w along y (m).
    pub width_m: f64,
    /// Cell edge h (m); every length must be a whole number of cells.
    pub cell_m: f64,
    /// Young's modulus E (Pa).
    pub young_pa: f64,
    /// Poisson's ratio ν.
    pub poisson: f64,
    /// Density ρ (kg/m³).
    pub density: f64,
}

impl BracketSpec {
    /// A steel bracket: legs 200 × 150 mm, 20 mm thick, 50 mm wide, 10 mm cells,
    /// E = 210 GPa, ν = 0.3, ρ = 7850 kg/m³.
    pub fn steel() -> Self {
        BracketSpec {
            legs_m: [0.2, 0.15],
            thickness_m: 0.02,
            width_m: 0.05,
            cell_m: 0.01,
            young_pa: 2.1e11,
            poisson: 0.3,
            density: 7850.0,
        }
    }

    /// Cells along x, y, z and the flange thickness in cells.
    ///
    /// # Errors
    /// [`Error::InvalidSetting`] when a length is not a positive whole number of cells, the
    /// thickness is not below both legs, or a material constant is out of range.
    fn cells(&self) -> Result<([usize; 3], usize)> {
        let h = self.cell_m;
        let count = |len: f64, what: &str| -> Result<usize> {
            let c = len / h;
            if !(h > 0.0 && (1.0..=1e5).contains(&c) && (c - c.round()).abs() <= 1e-9 * c) {
                return Err(Error::InvalidSetting(format!(
                    "bracket {what} = {len} m is not a whole number (1..1e5) of {h} m cells"
                )));
            }
            Ok(c.round() as usize)
        };
        let (nx, nz) = (
            count(self.legs_m[0], "leg x")?,
            count(self.legs_m[1], "leg z")?,
        );
        let (ny, t) = (
            count(self.width_m, "width")?,
            count(self.thickness_m, "thickness")?,
        );
        if t >= nx || t >= nz {
            return Err(Error::InvalidSetting(format!(
                "bracket thickness {} m must be below both legs ({:?} m)",
                self.thickness_m, self.legs_m
            )));
        }
        if !(self.young_pa > 0.0 && self.density > 0.0 && (0.0..0.5).contains(&self.poisson)) {
            return Err(Error::InvalidSetting(
                "bracket material: need E > 0, density > 0 and 0 <= nu < 0.5".into(),
            ));
        }
        Ok(([nx, ny, nz], t))
    }
}

/// The assembled bracket (validated model) and its scene: inputs = outputs = the x, y, z DoFs
/// of three nodes on the mid-width line y = w/2 (rounded down to a grid line) — the tip of
/// the horizontal leg (x = L_x, z = 0), the outer corner (0, 0) and the tip of the vertical
/// leg (0, L_z) — and the band [0, 6000] Hz, which holds the bracket's first deformation
/// modes (6 for [`BracketSpec::steel`]: 855 to 5400 Hz). Rayleigh damping β = 10⁻⁵ s as the paper's bar.
///
/// # Errors
/// As [`BracketSpec`]'s checks; [`Model::new`]'s validation.
pub fn bracket_model(spec: &BracketSpec) -> Result<(Model, Scene)> {
    let ([nx, ny, nz], t) = spec.cells()?;
    let active = |i: usize, k: usize| i < t || k < t;
    // grid point (i, j, k) → node number, for points touched by an active cell
    let grid = |i: usize, j: usize, k: usize| i + (nx + 1) * (j + (ny + 1) * k);
    let mut node_of = vec![usize::MAX; (nx + 1) * (ny + 1) * (nz + 1)];
    let mut nodes = Vec::new();
    for k in 0..=nz {
        for j in 0..=ny {
            for i in 0..=nx {
                let touched = (i.saturating_sub(1)..=i.min(nx - 1))
                    .any(|ci| (k.saturating_sub(1)..=k.min(nz - 1)).any(|ck| active(ci, ck)));
                if touched {
                    node_of[grid(i, j, k)] = nodes.len();
                    let h = spec.cell_m;
                    nodes.push([i as f64 * h, j as f64 * h, k as f64 * h]);
                }
            }
        }
    }
    let n = 3 * nodes.len();
    let el = Hex8::new([spec.cell_m; 3], spec.young_pa, spec.poisson, spec.density);
    let (mut kt, mut mt) = (Vec::new(), Vec::new());
    for k in 0..nz {
        for j in 0..ny {
            for i in (0..nx).filter(|&i| active(i, k)) {
                // local node a = ia + 2 ja + 4 ka (the element's numbering)
                let dof = |a: usize, d: usize| {
                    3 * node_of[grid(i + (a & 1), j + ((a >> 1) & 1), k + (a >> 2))] + d
                };
                for p in 0..24 {
                    for q in 0..24 {
                        kt.push(Triplet::new(
                            dof(p / 3, p % 3),
                            dof(q / 3, q % 3),
                            el.k[p][q],
                        ));
                    }
                }
                for a in 0..8 {
                    for b in 0..8 {
                        for d in 0..3 {
                            mt.push(Triplet::new(dof(a, d), dof(b, d), el.m[a][b]));
                        }
                    }
                }
            }
        }
    }
    let csc = |t: &[Triplet<usize, usize, f64>]| -> Result<Csc> {
        SparseColMat::try_new_from_triplets(n, n, t)
            .map_err(|e| Error::InvalidModel(format!("bracket assembly: {e:?}")))
    };
    let (stiffness, mass) = (csc(&kt)?, csc(&mt)?);
    drop((kt, mt));
    let jm = ny / 2;
    let io: Vec<usize> = [(nx, jm, 0), (0, jm, 0), (0, jm, nz)]
        .iter()
        .flat_map(|&(i, j, k)| (0..3).map(move |d| (i, j, k, d)))
        .map(|(i, j, k, d)| 3 * node_of[grid(i, j, k)] + d)
        .collect();
    let scene = Scene {
        inputs: io.clone(),
        outputs: io,
        band_hz: [0.0, 6000.0],
    };
    let name = format!("bracket {nx}x{ny}x{nz} (t = {t} cells)");
    let damping = Damping::Rayleigh {
        alpha: 0.0,
        beta: PAPER_RAYLEIGH_BETA,
    };
    let (model, _) = Model::new(name, mass, stiffness, damping, Some(nodes), 3)?;
    scene.validate(model.n(), "bracket scene")?;
    Ok((model, scene))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn steel_bracket_counts_mass_and_rigid_modes() {
        let spec = BracketSpec::steel();
        let (model, scene) = bracket_model(&spec).unwrap();
        // 330 cells; nodes: 21·6·3 (flange) + 3·6·13 (vertical above it) = 378 + 234 = 612
        assert_eq!(model.n(), 3 * 612);
        // total mass = ρ · volume, in each direction: Σ_ij M_ij over x DoFs
        let volume = spec.width_m
            * (spec.legs_m[0] * spec.thickness_m
                + (spec.legs_m[1] - spec.thickness_m) * spec.thickness_m);
        let ones_x: Vec<f64> = (0..model.n()).map(|r| f64::from(r % 3 == 0)).collect();
        let mut mx = 0.0;
        for c in 0..model.n() {
            for (p, &r) in model
                .mass
                .symbolic()
                .row_idx_of_col_raw(c)
                .iter()
                .enumerate()
            {
                mx += ones_x[r] * model.mass.val_of_col(c)[p] * ones_x[c];
            }
        }
        let want = spec.density * volume;
        assert!((mx - want).abs() <= 1e-12 * want, "mass {mx} vs {want}");
        let body = crate::body::Body::new(&model).unwrap();
        assert!(body.rigid().is_some(), "a free body: K V0 = 0");
        assert_eq!(scene.inputs.len(), 9);
    }

    #[test]
    fn bad_specs_are_errors() {
        let mut s = BracketSpec::steel();
        s.cell_m = 0.03; // 0.2 / 0.03 is not whole
        assert!(bracket_model(&s).is_err());
        let mut s = BracketSpec::steel();
        s.thickness_m = 0.15;
        assert!(bracket_model(&s).is_err());
    }
}
