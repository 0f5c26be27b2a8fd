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
//!
//! **Remote points** (a ROM of a coupled model, docs/design.md §3.11; [`PointNode`]). The
//! body's mesh nodes carry three translational DoFs each, so a point's rotations cannot be
//! one more node of `ObjectFFRFreducedOrder`. The mesh nodes' shapes are TΦ (the rigid
//! points' nodes follow their point rigidly in every mode; [`crate::reduce::flexible`]), and
//! each point is written as what EXUDYN attaches a joint to: its node set and weights for a
//! `MarkerSuperElementRigid` (`point_nodes` from `point_nodes_ptr[p]` to `point_nodes_ptr[p +
//! 1]`, `point_weights`, reference position `point_positions[p]`), with its exact motion in
//! each mode, the six rows R_p Φ, as `point_modes` (rows 6p..6p + 6: x, y, z, rx, ry, rz).
//! EXUDYN's marker (`useAlternativeApproach=True`) turns with the point's rotation and moves
//! with the fitted rigid motion at the set's weighted centroid c_w — the point's motion moved
//! to c_w, t + θ × (c_w − x_p) — for either kind; its `offset` is not turned by the elastic
//! rotation, so a marker offset to x_p moves by θ × (x_p − c_w) less than the point
//! (docs/design.md §3.9). An input or output that is a point's DoF is listed with node
//! `nodes + p` and direction 0–5, one given as a matrix row or column with node and
//! direction −1.

use crate::coupled::Coordinate;
use crate::io::{atomic, npz};
use crate::model::{Damping, Model};
use crate::reduce::flexible::{ElasticBasis, PointNode};
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
    /// The remote points, in order (module doc).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    points: Vec<PointToml<'a>>,
}

/// A remote point in `export.toml`.
#[derive(Serialize)]
struct PointToml<'a> {
    name: &'a str,
    kind: &'a str,
    position: [f64; 3],
    nodes: usize,
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

/// Writes the EXUDYN export of `body` (see the module doc) into the new directory `dir`. For
/// a ROM of a coupled model, `model` is the original model, `body` the basis on its DoFs,
/// `points` the remote points and `coordinates` what each DoF of the coupled model is (the
/// ROM's inputs and outputs are those DoFs); `&[]` and `None` otherwise.
///
/// # Errors
/// [`Error::InvalidSetting`] when the model has no node coordinates or not 3 DoFs per node
/// (EXUDYN's body has 3 translational DoFs per mesh node), a point's shapes are not 6 × r,
/// an input or output is not a DoF of `coordinates`, or `dir` is not empty; I/O errors.
pub fn write(
    dir: &Path,
    model: &Model,
    body: &ElasticBasis,
    check: Option<&TransferCheck>,
    points: &[PointNode],
    coordinates: Option<&[Coordinate]>,
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
    let r = body.phi.ncols();
    if let Some(p) = points
        .iter()
        .find(|p| (p.shapes.nrows(), p.shapes.ncols()) != (6, r))
    {
        return Err(Error::InvalidSetting(format!(
            "remote point {}: its shapes are {} × {}, not 6 × {r}",
            p.name,
            p.shapes.nrows(),
            p.shapes.ncols()
        )));
    }
    // (node, direction) of each input and output DoF: a mesh DoF's, a point's (node after the
    // mesh nodes), or none (usize::MAX, −1 in the file) for a matrix functional
    let node_dir = |d: usize| -> Result<(usize, usize)> {
        match coordinates.map(|c| c.get(d)) {
            None => Ok((d / 3, d % 3)),
            Some(Some(Coordinate::Dof(q))) => Ok((q / 3, q % 3)),
            Some(Some(Coordinate::Point { point, dir })) => Ok((nodes.len() + point, *dir)),
            Some(Some(Coordinate::Row(_))) => Ok((usize::MAX, usize::MAX)),
            Some(None) => Err(Error::InvalidSetting(format!(
                "ROM DoF {d} is not a DoF of the coupled model"
            ))),
        }
    };
    let mut io = Vec::new();
    for (name, dofs) in [("input", &rom.inputs), ("output", &rom.outputs)] {
        let pairs = dofs
            .iter()
            .map(|&d| node_dir(d))
            .collect::<Result<Vec<_>>>()?;
        io.push((name, dofs, pairs));
    }
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
        points: points
            .iter()
            .map(|p| PointToml {
                name: &p.name,
                kind: match p.kind {
                    crate::coupling::Kind::Rigid => "rigid",
                    crate::coupling::Kind::Distributing => "distributing",
                },
                position: p.position,
                nodes: p.nodes.len(),
            })
            .collect(),
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
            for (name, dofs, pairs) in &io {
                z.indices(&format!("{name}s"), dofs)?;
                let node: Vec<usize> = pairs.iter().map(|p| p.0).collect();
                let dir: Vec<usize> = pairs.iter().map(|p| p.1).collect();
                z.indices(&format!("{name}_node"), &node)?;
                z.indices(&format!("{name}_dir"), &dir)?;
            }
            if !points.is_empty() {
                let positions: Vec<f64> = points.iter().flat_map(|p| p.position).collect();
                z.rows("point_positions", &positions, 3)?;
                let modes = faer::Mat::from_fn(6 * points.len(), r, |i, k| {
                    points[i / 6].shapes[(i % 6, k)]
                });
                z.matrix("point_modes", modes.as_ref())?;
                let mut ptr = vec![0];
                for p in points {
                    ptr.push(ptr[ptr.len() - 1] + p.nodes.len());
                }
                let set: Vec<usize> = points.iter().flat_map(|p| p.nodes.clone()).collect();
                let weights: Vec<f64> = points.iter().flat_map(|p| p.weights.clone()).collect();
                z.indices("point_nodes", &set)?;
                z.indices("point_nodes_ptr", &ptr)?;
                z.vector("point_weights", &weights)?;
                let names: Vec<&str> = points.iter().map(|p| p.name.as_str()).collect();
                z.text("point_names", &names.join("\n"))?;
            }
            z.text("metadata", &text)
        })?;
        atomic::write_bytes(&tmp.join("export.toml"), &text)
    })
}
