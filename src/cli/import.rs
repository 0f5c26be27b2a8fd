//! `import`: a model directory from the files an FE code wrote (ANSYS, Abaqus).

use super::args::parse_band;
use sparsemor::io::import;
use sparsemor::io::model_dir::{self, DofNames, Source, SourceToml};
use sparsemor::{Error, Result};
use std::path::PathBuf;

/// `sparsemor import SOURCE... --out MODEL_DIR`.
#[derive(clap::Args)]
pub struct ImportArgs {
    /// The files: an ANSYS .full (+ node table); an APDL Math export (K, M, DoF mapping
    /// vector, node table); Abaqus *_STIF*.mtx, *_MASS*.mtx (+ .inp). Prefix K=/M= when the
    /// names do not tell which matrix is which.
    #[arg(required = true)]
    sources: Vec<PathBuf>,
    /// Output model directory (must not exist or be empty).
    #[arg(long)]
    out: PathBuf,
    /// Model name (default: the output directory's name).
    #[arg(long)]
    name: Option<String>,
    /// Multiply K by S (e.g. 1e-2 for EXUDYN's Abaqus rotor).
    #[arg(long)]
    scale_stiffness: Option<f64>,
    /// Length unit of the source's consistent unit system: `m` (m-kg-s-N, kept) or `mm`
    /// (mm-t-s-N, converted to m-kg-s-N).
    #[arg(long, default_value = "m")]
    length_unit: String,
    /// Band LO:HI in Hz for the default scene (the files do not say; check with `modes`).
    #[arg(long, default_value = "0:1000")]
    band: String,
    /// Input DoFs of the default scene as NODE:DIR (e.g. 17:x,17:y); default: the
    /// translations of the first node.
    #[arg(long)]
    inputs: Option<String>,
    /// Output DoFs as NODE:DIR; default: the inputs.
    #[arg(long)]
    outputs: Option<String>,
}

pub fn import(a: &ImportArgs) -> Result<()> {
    let mut imp = import::read(&a.sources)?;
    if let Some(s) = a.scale_stiffness {
        imp.scale_stiffness(s)?;
    }
    imp.convert_length_unit(&a.length_unit)
        .map_err(|e| Error::InvalidSetting(format!("--length-unit: {e}")))?;
    let mut scene = imp.default_scene(parse_band(&a.band)?);
    let names = DofNames::from_map(&imp.dofs);
    if let Some(i) = &a.inputs {
        scene.inputs = names.indices(i, "--inputs")?;
        scene.outputs = scene.inputs.clone();
    }
    if let Some(o) = &a.outputs {
        scene.outputs = names.indices(o, "--outputs")?;
    }
    let name = a.name.clone().unwrap_or_else(|| {
        a.out
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "imported".into())
    });
    println!("format    {} ({})", imp.format.name(), imp.producer);
    println!("units     {}", imp.units);
    for n in &imp.notes {
        println!("note      {n}");
    }
    let (dofs, removed) = (imp.dofs.clone(), imp.removed.clone());
    let toml = SourceToml {
        format: imp.format.name().into(),
        producer: imp.producer.clone(),
        units: imp.units.clone(),
        files: imp.files.iter().map(|p| p.display().to_string()).collect(),
        dof_map: String::new(),
        removed: None,
    };
    let (model, report) = imp.into_model(name)?;
    model_dir::write_with_source(
        &a.out,
        &model,
        &scene,
        Some(&Source {
            toml,
            dofs: &dofs,
            removed: &removed,
        }),
    )?;
    let label = |v: &[usize]| {
        v.iter()
            .map(|&i| dofs[i].to_string())
            .collect::<Vec<_>>()
            .join(",")
    };
    println!(
        "model     N = {}, {} nodes with coordinates, {} constrained DoFs removed, mass diagonal [{:.4e}, {:.4e}]",
        model.n(),
        model.nodes.as_ref().map_or(0, Vec::len),
        removed.len(),
        report.mass_diagonal[0],
        report.mass_diagonal[1]
    );
    println!(
        "scene     inputs {}, outputs {}, band {:?} Hz (a default: the files give no band; `sparsemor modes` shows the eigenfrequencies)",
        label(&scene.inputs),
        label(&scene.outputs),
        scene.band_hz
    );
    println!("wrote     {}", a.out.display());
    Ok(())
}
