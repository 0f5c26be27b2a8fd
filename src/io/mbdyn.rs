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
//! ([`crate::rigid::inertia`]: one pass over M's entries). Record group 11 (lumped nodal masses,
//! from which MBDyn builds the coupling invariants) is not written: the models carry
//! consistent masses, and a lumped diagonal would be a different body.

use crate::io::atomic;
use crate::io::dmig::grids;
use crate::io::import::Dof;
use crate::model::Model;
use crate::reduce::flexible::ElasticBasis;
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

/// Writes `body.fem` (see the module doc) for the elastic basis `flex` of a ROM of `model`
/// into the new directory `dir`.
///
/// # Errors
/// [`Error::InvalidSetting`] if `dir` exists and is not empty (naming it), as [`inertia`]
/// and [`grids`], or when Φ does not have the model's N rows; I/O errors.
pub fn write(
    dir: &Path,
    model: &Model,
    flex: &ElasticBasis,
    dof_map: Option<&[Dof]>,
) -> Result<()> {
    let rb = inertia(model)?;
    let labels = grids(model, dof_map)?;
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
        nodes.len()
    );
    let _ = writeln!(s, "** RECORD GROUP 2, FINITE ELEMENT NODE LIST");
    for chunk in (0..nodes.len()).collect::<Vec<_>>().chunks(6) {
        let line: Vec<String> = chunk
            .iter()
            .map(|&p| labels[p * dpn].0.to_string())
            .collect();
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
        for p in nodes {
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
