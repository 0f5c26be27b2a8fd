//! `sparsemor export`: a ROM as a flexible body for a multibody code, or its matrices for
//! Nastran (docs/design.md §3.9). The elastic basis, the checks and the writers are library
//! calls; this module prints what they did.

use super::args::hz_list;
use super::evaluate::evaluation_band;
use super::progress::with_progress;
use sparsemor::body::Body;
use sparsemor::grid::linspace;
use sparsemor::io::exudyn::{self, TransferCheck, NO_SURFACE};
use sparsemor::io::{atomic, dmig, mbdyn, model_dir, op4, rom_dir, sid};
use sparsemor::metrics::{ErrorCurve, Reference};
use sparsemor::reduce::flexible::{elastic_basis, DEPENDENT_RTOL};
use sparsemor::rigid;
use sparsemor::scene::Scene;
use sparsemor::sweep::SweepOptions;
use sparsemor::{Error, Result};
use std::path::PathBuf;

/// Export targets.
#[derive(Clone, Copy, Debug, clap::ValueEnum)]
pub enum Format {
    /// EXUDYN's ObjectFFRFreducedOrder (flexible_body.npz + export.toml).
    Exudyn,
    /// Nastran OUTPUT4 ASCII file of Mr, Dr, Kr, Br, Cr and K4r (rom.op4); V not needed.
    Op4,
    /// Nastran DMIG bulk data of Mr, Kr, Dr by grid/component (dmig.bdf + coordinates.csv);
    /// V not needed.
    Dmig,
    /// MBDyn modal joint FEM file of the elastic basis (body.fem).
    Mbdyn,
    /// SID_FEM (Wallrapp's Standard Input Data: FEMBS, Simpack, Modelica EMBS) of the
    /// elastic basis (body.SID_FEM).
    Sid,
}

#[derive(clap::Args)]
pub struct ExportArgs {
    /// ROM directory (reduced with --keep-basis for exudyn, mbdyn and sid: they need V).
    rom: PathBuf,
    /// The model directory the ROM was reduced from.
    #[arg(long)]
    model: PathBuf,
    /// Target format.
    #[arg(long, value_enum, default_value = "exudyn")]
    format: Format,
    /// Output directory (must not exist or be empty).
    #[arg(long)]
    out: PathBuf,
    /// Band LO:HI in Hz of the ε check before/after the projection (default: the model's).
    #[arg(long)]
    band: Option<String>,
    /// Grid points of the ε check (0 skips it).
    #[arg(long, default_value_t = 200)]
    points: usize,
    /// Worker threads (0 = all cores).
    #[arg(long, default_value_t = 0)]
    threads: usize,
}

pub fn export(a: &ExportArgs) -> Result<()> {
    atomic::check_dir_free(&a.out)?;
    // a coupled model (remote points or scene matrices, docs/design.md §3.11) comes with its
    // joints: the original model and q = T z, so the exports write the mesh nodes' shapes TΦ
    // and each remote point as one more interface node
    let (loaded, joints) = model_dir::load_with_joints(&a.model)?;
    let (model, scene) = (loaded.model, loaded.scene);
    let rom = rom_dir::read(&a.rom)?;
    rom.check_model(model.n())
        .map_err(|e| Error::InvalidSetting(format!("{}: {e}", a.rom.display())))?;
    let dof_map = model_dir::read_dof_map(&a.model)?;
    match a.format {
        Format::Op4 => {
            op4::write_rom(&a.out, &rom)?;
            println!(
                "op4              {}: {} (ASCII, real double, 1P,3E23.16), order {}",
                op4::ROM_FILE,
                op4::ROM_MATRICES
                    .iter()
                    .take(rom.matrices().len())
                    .map(|(n, _)| *n)
                    .collect::<Vec<_>>()
                    .join(" "),
                rom.order()
            );
            eprintln!("wrote {}", a.out.display());
            return Ok(());
        }
        Format::Dmig => {
            let j = joints.as_ref();
            dmig::write(&a.out, &rom, &model, dof_map.as_deref(), j)?;
            let keys = dmig::coordinates(&rom, &model, dof_map.as_deref(), j)?;
            let spoints = keys.iter().filter(|c| c.component == 0).count();
            println!(
                "dmig             {}: MAAX, KAAX{}{} over {} grid components and {spoints} scalar points; rows in {}",
                dmig::BULK_FILE,
                if rom.dr.col_iter().any(|c| c.iter().any(|&v| v != 0.0)) {
                    ", BAAX"
                } else {
                    ""
                },
                if rom.k4r.is_some() { ", K4AAX" } else { "" },
                keys.len() - spoints,
                dmig::MAP_FILE
            );
            if let Some(j) = j {
                let ids = dmig::point_grids(
                    &dmig::grids(&j.original, dof_map.as_deref())?,
                    j.points.len(),
                )?;
                for (p, id) in j.points.iter().zip(ids) {
                    println!(
                        "point {} -> grid {id} (GRID* in {})",
                        p.name,
                        dmig::BULK_FILE
                    );
                }
            }
            eprintln!("wrote {}", a.out.display());
            return Ok(());
        }
        Format::Exudyn | Format::Mbdyn | Format::Sid => {
            if rom.k4r.is_some() {
                // a flexible body in the time domain: hysteretic damping has no time-domain form
                return Err(Error::InvalidSetting(format!(
                    "{}: the ROM has structural (hysteretic) damping K4r, which {:?} cannot \
                     carry (a multibody body runs in the time domain, where a loss factor has \
                     no equivalent); `--format op4` or `--format dmig` write it, or reduce the \
                     model without [structural] / structural_damping (an equivalent viscous \
                     damping, e.g. [rayleigh] beta = eta / omega at a frequency of interest)",
                    a.rom.display(),
                    a.format
                )));
            }
        }
    }
    let body = Body::new(&model)?;
    let rom_scene = Scene {
        inputs: rom.inputs.clone(),
        outputs: rom.outputs.clone(),
        band_hz: evaluation_band(&scene, a.band.as_deref())?,
    };
    let flex = elastic_basis(&body, &rom_scene, &rom)
        .map_err(|e| Error::InvalidSetting(format!("{}: {e}", a.rom.display())))?;
    let check = match a.points {
        0 => None,
        1 => return Err(Error::InvalidSetting("--points must be 0 or >= 2".into())),
        points => {
            let freqs = linspace(rom_scene.band_hz, points);
            let opts = SweepOptions {
                threads: a.threads,
                ..Default::default()
            };
            let reference = with_progress(freqs.len(), "export check", |cb| {
                Reference::compute(&body, &rom_scene, &freqs, &opts, None, cb)
            })?;
            let max_mean = |r| -> Result<[f64; 2]> {
                let (max, mean) = ErrorCurve::max_mean(&reference.error(r)?.eps_elastic);
                Ok([max, mean])
            };
            Some(TransferCheck {
                band_hz: rom_scene.band_hz,
                points,
                eps_before: max_mean(&rom)?,
                eps_after: max_mean(&flex.rom)?,
            })
        }
    };
    drop(body);
    // a coupled model's basis on the original DoFs, TΦ, and its points as interface nodes
    let (model, flex, points) = match &joints {
        Some(j) => {
            let (on_mesh, points) = flex.on_original(j)?;
            (&j.original, on_mesh, points)
        }
        None => (&model, flex, Vec::new()),
    };
    let node_ids = || -> Result<Vec<u64>> {
        dmig::point_grids(&dmig::grids(model, dof_map.as_deref())?, points.len())
    };
    match a.format {
        Format::Mbdyn => {
            mbdyn::write(&a.out, model, &flex, dof_map.as_deref(), &points)?;
            let rb = rigid::inertia(model)?;
            println!(
                "mbdyn            {}: total mass {:.6e}, centre of mass [{:.6e}, {:.6e}, {:.6e}]",
                mbdyn::FEM_FILE,
                rb.mass,
                rb.center[0],
                rb.center[1],
                rb.center[2]
            );
            for (p, id) in points.iter().zip(node_ids()?) {
                println!("point {} -> node {id}", p.name);
            }
        }
        Format::Sid => {
            sid::write(&a.out, model, &flex, dof_map.as_deref(), &points)?;
            let rb = rigid::inertia(model)?;
            println!(
                "sid              {}: total mass {:.6e}, centre of mass [{:.6e}, {:.6e}, {:.6e}], \
                 {} nodes; inertia invariants only (no geometric stiffening)",
                sid::SID_FILE,
                rb.mass,
                rb.center[0],
                rb.center[1],
                rb.center[2],
                model.nodes.as_ref().map_or(0, Vec::len) + points.len()
            );
            for (p, id) in points.iter().zip(node_ids()?) {
                println!("point {} -> node {id}", p.name);
            }
        }
        _ => {
            let coordinates = joints.as_ref().map(|j| j.coordinates.as_slice());
            exudyn::write(&a.out, model, &flex, check.as_ref(), &points, coordinates)?;
            for p in &points {
                println!(
                    "point {} -> MarkerSuperElementRigid over {} mesh nodes at [{:.6e}, {:.6e}, \
                     {:.6e}] (point_nodes, point_weights in flexible_body.npz)",
                    p.name,
                    p.nodes.len(),
                    p.position[0],
                    p.position[1],
                    p.position[2]
                );
            }
        }
    }
    println!(
        "elastic basis    {} modes from {} columns of V",
        flex.phi.ncols(),
        rom.order()
    );
    if flex.dropped > 0 {
        println!(
            "dropped          {} columns: after removing the rigid part their M-norm² was \
             below {DEPENDENT_RTOL:e} of the largest ({}): V spans rigid motion there",
            flex.dropped,
            flex.dropped_rel_norms
                .iter()
                .map(|x| format!("{x:.1e}"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    match flex.rigid_coupling {
        Some(c) => println!("rigid coupling   max M-cosine(V0, Phi) = {c:.2e}"),
        None => println!("rigid coupling   none: the body is constrained (no rigid modes)"),
    }
    println!(
        "eigenfreqs       {} Hz",
        hz_list(&flex.eigenfrequencies_hz, 2, " ")
    );
    if let Some(c) = &check {
        println!(
            "eps elastic      before max {:.3e} mean {:.3e}   after max {:.3e} mean {:.3e}   \
             ({} points in [{}, {}] Hz)",
            c.eps_before[0],
            c.eps_before[1],
            c.eps_after[0],
            c.eps_after[1],
            c.points,
            c.band_hz[0],
            c.band_hz[1]
        );
    }
    if matches!(a.format, Format::Exudyn) {
        println!("surface          {NO_SURFACE}");
    }
    eprintln!("wrote {}", a.out.display());
    Ok(())
}
