//! Export of a ROM as a floating-frame flexible body for EXUDYN (docs/design.md §3.9, §4).
//!
//! EXUDYN's `FEM.ObjectFFRFreducedOrderInterface(fem)` builds its reduced-order body
//! (`ObjectFFRFreducedOrder`) from an `FEMinterface` `fem` holding the node positions
//! (`fem.nodes['Position']`, 3 translational DoFs per node, node-major), the mode basis
//! (`fem.modeBasis['matrix']`, N × r, rigid-free), the full mass and stiffness matrices
//! (`fem.massMatrix`, `fem.stiffnessMatrix`, scipy CSR: the body's inertia terms are integrals
//! over all nodes) and the surface triangles (`fem.surface`). [`write()`] puts exactly these
//! into `flexible_body.npz`, with the DoF → (node, direction) map of the inputs and outputs
//! for markers (`MarkerSuperElementPosition` on mesh node `node`), Rayleigh damping as
//! `rayleigh` = [α, β] (EXUDYN's mass- and stiffness-proportional damping of the modal
//! coordinates; an explicit D only as `dampingMatrixReduced`), and the checks into
//! `export.toml`. `examples/exudyn_flexible_body.py` reads the directory.
//!
//! Surface triangles are written only when the model knows its elements; a model directory
//! holds none (§4), so the export says so instead of inventing a surface.

use crate::io::{atomic, npz};
use crate::model::{Damping, Model};
use crate::reduce::flexible::ElasticBasis;
use crate::sparse::Csc;
use crate::{Error, Result};
use serde::Serialize;
use std::io::{Seek, Write};
use std::path::Path;

/// The elastic transfer functions before and after the rigid-part projection (§3.9): ε
/// (eq. 23, elastic variant) of the ROM and of the projected ROM on one grid.
#[derive(Clone, Debug, Serialize)]
pub struct TransferCheck {
    /// Band of the grid (Hz).
    pub band_hz: [f64; 2],
    /// Grid points.
    pub points: usize,
    /// [max, mean] ε of the ROM as reduced.
    pub eps_before: [f64; 2],
    /// [max, mean] ε of the ROM projected onto the elastic basis.
    pub eps_after: [f64; 2],
}

/// `export.toml`.
#[derive(Serialize)]
struct Manifest<'a> {
    sparsemor_version: &'a str,
    format: &'a str,
    method: String,
    modes: usize,
    nodes: usize,
    dropped_columns: usize,
    dropped_rel_norms: &'a [f64],
    /// Largest M-cosine between the rigid modes and the exported basis (free bodies only).
    #[serde(skip_serializing_if = "Option::is_none")]
    rigid_coupling: Option<f64>,
    eigenfrequencies_hz: &'a [f64],
    surface: &'a str,
    inputs: &'a [usize],
    outputs: &'a [usize],
    #[serde(skip_serializing_if = "Option::is_none")]
    transfer_check: Option<&'a TransferCheck>,
}

/// What `export.toml` says about the surface of a model without elements.
pub const NO_SURFACE: &str =
    "none: the model directory has no elements, so no surface triangles are known";

fn sparse<W: Write + Seek>(z: &mut npz::Npz<W>, name: &str, a: &Csc) -> std::io::Result<()> {
    // symmetric, full storage: the CSC arrays are also the CSR arrays of the same matrix
    let s = a.symbolic();
    z.vector(&format!("{name}_data"), a.val())?;
    z.indices(&format!("{name}_indices"), s.row_idx())?;
    z.indices(&format!("{name}_indptr"), s.col_ptr())
}

/// Writes the EXUDYN export of `body` (see the module doc) into the new directory `dir`.
///
/// # Errors
/// [`Error::InvalidSetting`] when the model has no node coordinates or not 3 DoFs per node
/// (EXUDYN's body has 3 translational DoFs per mesh node), or `dir` is not empty; I/O errors.
pub fn write(
    dir: &Path,
    model: &Model,
    body: &ElasticBasis,
    check: Option<&TransferCheck>,
) -> Result<()> {
    let nodes = model.nodes.as_ref().ok_or_else(|| {
        Error::InvalidSetting(format!(
            "model '{}' has no node coordinates (nodes.csv): an EXUDYN body needs them",
            model.name
        ))
    })?;
    if model.dofs_per_node != 3 {
        return Err(Error::InvalidSetting(format!(
            "model '{}' has dofs_per_node = {}: EXUDYN's ObjectFFRFreducedOrder takes 3 \
             translational DoFs per mesh node",
            model.name, model.dofs_per_node
        )));
    }
    let rom = &body.rom;
    let man = Manifest {
        sparsemor_version: env!("CARGO_PKG_VERSION"),
        format: "exudyn",
        method: rom.method().to_string(),
        modes: body.phi.ncols(),
        nodes: nodes.len(),
        dropped_columns: body.dropped,
        dropped_rel_norms: &body.dropped_rel_norms,
        rigid_coupling: body.rigid_coupling,
        eigenfrequencies_hz: &body.eigenfrequencies_hz,
        surface: NO_SURFACE,
        inputs: &rom.inputs,
        outputs: &rom.outputs,
        transfer_check: check,
    };
    let text = toml::to_string(&man)
        .map_err(|e| Error::InvalidSetting(format!("cannot serialize export.toml: {e}")))?;
    atomic::write_dir(dir, |tmp| {
        npz::write(&tmp.join("flexible_body.npz"), |z| {
            z.matrix("modeBasis", body.phi.as_ref())?;
            z.rows("nodes", nodes.as_flattened(), 3)?;
            sparse(z, "massMatrix", &model.mass)?;
            sparse(z, "stiffnessMatrix", &model.stiffness)?;
            z.matrix("massMatrixReduced", rom.mr.as_ref())?;
            z.matrix("stiffnessMatrixReduced", rom.kr.as_ref())?;
            z.matrix("dampingMatrixReduced", rom.dr.as_ref())?;
            z.matrix("Br", rom.br.as_ref())?;
            z.matrix("Cr", rom.cr.as_ref())?;
            z.vector("eigenfrequencies_hz", &body.eigenfrequencies_hz)?;
            if let Damping::Rayleigh { alpha, beta } = model.damping {
                z.vector("rayleigh", &[alpha, beta])?;
            }
            for (name, dofs) in [("input", &rom.inputs), ("output", &rom.outputs)] {
                z.indices(&format!("{name}s"), dofs)?;
                let node: Vec<usize> = dofs.iter().map(|&d| d / 3).collect();
                let dir: Vec<usize> = dofs.iter().map(|&d| d % 3).collect();
                z.indices(&format!("{name}_node"), &node)?;
                z.indices(&format!("{name}_dir"), &dir)?;
            }
            z.text("metadata", &text)
        })?;
        atomic::write_bytes(&tmp.join("export.toml"), &text)
    })
}
