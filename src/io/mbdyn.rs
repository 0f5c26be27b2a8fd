//! The MBDyn modal FEM file of a ROM's elastic basis (docs/design.md §3.9, §4): the ASCII
//! file MBDyn's `modal` joint reads (MBDyn input manual, "Modal Element", "FEM File Format";
//! checked against the reader in MBDyn's `struct/modal.cc`), written by [`write`] as
//! `body.fem`:
//!
//! | record group | contents |
//! |---|---|
//! | 1 | header: `REV0 NNODES NMODES 0 0 0` (normal modes only) |
//! | 2 | node labels: the grid ids of [`crate::io::dmig::grids`] (node i → i + 1 without a DoF map) |
//! | 3, 4 | initial modal displacements and velocities: zeros |
//! | 5, 6, 7 | node X, Y, Z |
//! | 8 | per mode, per node: the 6 components of Φ (rotations 0 for 3 DoFs per node) |
//! | 9, 10 | generalized mass ΦᵀMΦ and stiffness ΦᵀKΦ |
//! | 12 | rigid-body inertia: total mass, centre of mass, inertia tensor about the centre of mass |
//! | 13 | generalized damping ΦᵀDΦ, when not zero |
//!
//! Φ is the rigid-free elastic basis of [`crate::reduce::flexible`]: the modal node carries
//! the rigid motion. The rigid-body properties come from M and the node coordinates
//! ([`crate::rigid::inertia`]: one pass over M's entries).
//!
//! **Remote points** (a ROM of a coupled model, docs/design.md §3.11; [`PointNode`]): each
//! point is one more FEM node after the mesh nodes, labelled after the largest grid id in
//! point order ([`crate::io::dmig::point_grids`]), at the point's position, its six mode
//! components the point's three translations and three small rotations R_p Φ — the node an
//! MBDyn joint (e.g. a `total joint` to a structural node at the point) attaches to. It is
//! massless: the rigid-body inertia and the generalized matrices are the original body's
//! (Φ on the mesh nodes is TΦ, [`crate::reduce::flexible`]). Record group 11 (lumped nodal masses,
//! from which MBDyn builds the coupling invariants) is not written: the models carry
//! consistent masses, and a lumped diagonal would be a different body.

use crate::io::atomic;
use crate::io::dmig::{grids, point_grids};
use crate::io::import::Dof;
use crate::model::Model;
use crate::reduce::flexible::{ElasticBasis, PointNode};
use crate::rigid::inertia;
use crate::{Error, Result};
use faer::MatRef;
use std::fmt::Write as _;
use std::path::Path;

/// The file [`write`] writes.
pub const FEM_FILE: &str = "body.fem";

fn matrix(s: &mut String, a: MatRef<'_, f64>) {
    for i in 0..a.nrows() {
        let line: Vec<String> = (0..a.ncols())
            .map(|j| format!("{:.16e}", a[(i, j)]))
            .collect();
        let _ = writeln!(s, "{}", line.join(" "));
    }
}

/// Writes `body.fem` (see the module doc) for the elastic basis `flex` of a ROM of `model`,
/// with `points` as more nodes after the mesh nodes, into the new directory `dir`.
///
/// # Errors
/// [`Error::InvalidSetting`] if `dir` exists and is not empty (naming it), as [`inertia`],
/// [`grids`] and [`point_grids`], or when Φ does not have the model's N rows or a point's
/// shapes are not 6 × r; I/O errors.
pub fn write(
    dir: &Path,
    model: &Model,
    flex: &ElasticBasis,
    dof_map: Option<&[Dof]>,
    points: &[PointNode],
) -> Result<()> {
    let rb = inertia(model)?;
    let labels = grids(model, dof_map)?;
    let point_ids = point_grids(&labels, points.len())?;
    let nodes = model.nodes.as_deref().unwrap_or_default();
    let dpn = model.dofs_per_node;
    let phi = flex.phi.as_ref();
    if phi.nrows() != model.n() {
        return Err(Error::InvalidSetting(format!(
            "the elastic basis has {} rows, model '{}' has N = {}",
            phi.nrows(),
            model.name,
            model.n()
        )));
    }
    let rom = &flex.rom;
    let modes = phi.ncols();
    if let Some(p) = points
        .iter()
        .find(|p| (p.shapes.nrows(), p.shapes.ncols()) != (6, modes))
    {
        return Err(Error::InvalidSetting(format!(
            "remote point {}: its shapes are {} × {}, not 6 × {modes}",
            p.name,
            p.shapes.nrows(),
            p.shapes.ncols()
        )));
    }
    let e = |v: f64| format!("{v:.16e}");
    let mut s = String::new();
    let _ = writeln!(
        s,
        "** MBDyn MODAL DATA FILE\n** sparsemor {}: {} ROM of model '{}', {} elastic modes ({} Hz)",
        env!("CARGO_PKG_VERSION"),
        rom.method(),
        model.name,
        modes,
        flex.eigenfrequencies_hz
            .iter()
            .map(|f| format!("{f:.6e}"))
            .collect::<Vec<_>>()
            .join(" ")
    );
    let _ = writeln!(
        s,
        "** RECORD GROUP 1, HEADER\n**   REVISION, NODES, NORMAL, ATTACHMENT, CONSTRAINT, REJECTED MODES\nREV0 {} {modes} 0 0 0\n**",
        nodes.len() + points.len()
    );
    let _ = writeln!(s, "** RECORD GROUP 2, FINITE ELEMENT NODE LIST");
    let ids: Vec<u64> = (0..nodes.len())
        .map(|p| labels[p * dpn].0)
        .chain(point_ids)
        .collect();
    for chunk in ids.chunks(6) {
        let line: Vec<String> = chunk.iter().map(u64::to_string).collect();
        let _ = writeln!(s, "{}", line.join(" "));
    }
    for (g, what) in [(3, "DISPLACEMENTS"), (4, "VELOCITIES")] {
        let _ = writeln!(s, "**\n** RECORD GROUP {g}, INITIAL MODAL {what}");
        for _ in 0..modes {
            let _ = writeln!(s, "{}", e(0.0));
        }
    }
    for (k, axis) in ["X", "Y", "Z"].iter().enumerate() {
        let _ = writeln!(s, "**\n** RECORD GROUP {}, NODAL {axis} COORDINATES", 5 + k);
        for p in nodes.iter().chain(points.iter().map(|p| &p.position)) {
            let _ = writeln!(s, "{}", e(p[k]));
        }
    }
    let _ = writeln!(s, "**\n** RECORD GROUP 8, NON-ORTHOGONALIZED MODE SHAPES");
    for k in 0..modes {
        let _ = writeln!(s, "**    NORMAL MODE SHAPE # {}", k + 1);
        for p in 0..nodes.len() {
            let line: Vec<String> = (0..6)
                .map(|a| e(if a < dpn { phi[(p * dpn + a, k)] } else { 0.0 }))
                .collect();
            let _ = writeln!(s, "{}", line.join(" "));
        }
        for p in points {
            let line: Vec<String> = (0..6).map(|a| e(p.shapes[(a, k)])).collect();
            let _ = writeln!(s, "{}", line.join(" "));
        }
    }
    let _ = writeln!(
        s,
        "**\n** RECORD GROUP 9, MODAL MASS MATRIX.  COLUMN-MAJOR FORM"
    );
    matrix(&mut s, rom.mr.as_ref());
    let _ = writeln!(
        s,
        "**\n** RECORD GROUP 10, MODAL STIFFNESS MATRIX.  COLUMN-MAJOR FORM"
    );
    matrix(&mut s, rom.kr.as_ref());
    let _ = writeln!(
        s,
        "**\n** RECORD GROUP 12, RIGID BODY INERTIA: MASS, CENTER OF MASS, INERTIA ABOUT IT\n{}\n{}",
        e(rb.mass),
        rb.center.map(e).join(" ")
    );
    for r in rb.inertia {
        let _ = writeln!(s, "{}", r.map(e).join(" "));
    }
    if rom.dr.col_iter().any(|c| c.iter().any(|&v| v != 0.0)) {
        let _ = writeln!(
            s,
            "**\n** RECORD GROUP 13, MODAL DAMPING MATRIX.  COLUMN-MAJOR FORM"
        );
        matrix(&mut s, rom.dr.as_ref());
    }
    let _ = writeln!(s, "**\n** END OF FILE");
    atomic::write_dir(dir, |tmp| atomic::write_bytes(&tmp.join(FEM_FILE), s))
}
