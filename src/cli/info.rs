//! `sparsemor info`: what a model is and what a sweep of it will do.

use super::args::human_bytes;
use sparsemor::factor::{Analysis, Backend};
use sparsemor::io::model_dir;
use sparsemor::pencil::Pencil;
use sparsemor::proportional::{Proportional, Split};
use sparsemor::rigid::{rigid_modes, RigidBody};
use sparsemor::Result;
use std::path::Path;
use std::time::Instant;

pub fn info(dir: &Path) -> Result<()> {
    let t = Instant::now();
    let model_dir::Loaded {
        model,
        scene,
        report,
        notes,
        ..
    } = model_dir::load(dir)?;
    let t_read = t.elapsed().as_secs_f64();
    println!("model            {} ({})", model.name, dir.display());
    println!("N                {}", model.n());
    println!(
        "nnz              M {}  K {}  (full storage)",
        model.mass.compute_nnz(),
        model.stiffness.compute_nnz()
    );
    println!(
        "symmetry         |M-Mᵀ|/|M| = {:.1e}  |K-Kᵀ|/|K| = {:.1e}  (tolerance {:.0e})",
        report.mass_asymmetry,
        report.stiffness_asymmetry,
        sparsemor::model::SYMMETRY_RTOL
    );
    println!(
        "diag(M)          min {:.3e}  max {:.3e}",
        report.mass_diagonal[0], report.mass_diagonal[1]
    );
    println!("dofs per node    {}", model.dofs_per_node);
    println!("damping          {}", describe_damping(&model.damping));
    let pencil = Pencil::new(&model);
    if let Some(text) = describe_structural(&model.structural) {
        println!("structural       {text}");
    }
    println!("damping path     {}", describe_split(&pencil));
    if let Some((through, formed)) = pencil.through_coupling() {
        println!(
            "products         through the coupling, Tᵀ(X(T z)): {through} stored entries per product, against {formed} formed"
        );
    }
    let v0 = match (&model.rigid_modes, &model.nodes) {
        (Some(v0), _) => {
            println!("nodes            none: a coupled model, rigid modes from its couplings");
            Some(v0.clone())
        }
        (None, Some(nodes)) => {
            println!("nodes            {}", nodes.len());
            Some(rigid_modes(nodes, model.dofs_per_node))
        }
        (None, None) => {
            println!(
                "nodes            none (rigid part cannot be separated; fine for constrained bodies)"
            );
            None
        }
    };
    if let Some(v0) = v0 {
        let rb = RigidBody::from_modes(&pencil, v0)?;
        let free = rb.stiffness_residual <= sparsemor::rigid::FREE_BODY_RTOL;
        println!(
            "rigid modes      {} (|K V0| / |K||V0| = {:.1e})",
            if free {
                "6: free body, elastic part separated by inertia relief"
            } else {
                "none: constrained body"
            },
            rb.stiffness_residual
        );
    }
    for note in &notes {
        println!("note             {note}");
    }
    println!(
        "scene            {} inputs, {} outputs, band {:?} Hz",
        scene.inputs.len(),
        scene.outputs.len(),
        scene.band_hz
    );
    let t_order = Instant::now();
    let (chol, ordering) = sparsemor::factor::symbolic_cholesky_ordered(&pencil)?;
    let t_order = t_order.elapsed().as_secs_f64();
    // what `sweep`, `reduce` and `evaluate` will do: the same decision (Backend::resolved)
    let backend = Backend::Auto.resolved(model.n(), pencil.is_real());
    let an = Analysis::with_symbolic(&pencil, backend, scene.inputs.len() + 1, || {
        Ok(std::sync::Arc::new(chol))
    })?;
    let s = an.stats();
    let path = match (s.backend, s.real) {
        (Backend::FaerLblt, true) => "faer LBLᵀ of the real N×N pencil (D = 0)",
        (Backend::FaerLblt, false) => {
            "faer LBLᵀ of the complex pencil as its interleaved 2N×2N real form"
        }
        (Backend::Ldlt, _) => {
            "complex-symmetric supernodal LDLᵀ (static pivoting) of the complex pencil"
        }
        (Backend::FaerLu, true) => "faer LU (COLAMD) of the real pencil (D = 0)",
        (Backend::FaerLu, false) => "faer LU (COLAMD) of the complex pencil",
        (_, true) => "UMFPACK, real",
        (_, false) => "UMFPACK, complex",
    };
    println!(
        "factorization    {} (backend auto → {}: {}); ordering {}; factor {}, ~{} per factorization",
        path,
        s.backend,
        if !s.real {
            "damped".to_string()
        } else {
            let lu_max = sparsemor::factor::LU_MAX_N;
            let cmp = if model.n() <= lu_max { "<=" } else { ">" };
            format!("undamped, N {cmp} {lu_max}")
        },
        ordering,
        if s.factor_nnz > 0 {
            format!("{} entries", s.factor_nnz)
        } else {
            "entries known after the first numeric factorization".to_string()
        },
        human_bytes(s.bytes_per_factor as f64)
    );
    if pencil.through_coupling().is_some() {
        let (_, first) = sparsemor::factor::symbolic_cholesky_ordered(pencil.factored())?;
        println!(
            "real factors     through the coupling, of the pencil before its functionals became coordinates: ordering {first}"
        );
    }
    println!(
        "read in          {t_read:.2} s; ordering + symbolic analysis {:.2} s",
        t_order + s.seconds
    );
    Ok(())
}

fn describe_structural(s: &sparsemor::model::Structural) -> Option<String> {
    match (s.eta, &s.matrix) {
        (0.0, None) => None,
        (eta, None) => Some(format!("loss factor eta = {eta:e}: H = eta K")),
        (eta, Some(k4)) => Some(format!(
            "H = {eta:e} K + K4 (K4 {} entries)",
            k4.compute_nnz()
        )),
    }
}

/// How the damping is answered (docs/design.md §3.12, §3.13), with the fitted coefficients.
fn describe_split(pencil: &sparsemor::pencil::Pencil) -> String {
    let coefficients = |p: &Proportional| {
        format!(
            "alpha = {:e}, beta = {:e}, eta = {:e}{}",
            p.alpha,
            p.beta,
            p.eta,
            if p.gamma != 0.0 {
                format!(", gamma = {:e}", p.gamma)
            } else {
                String::new()
            }
        )
    };
    match pencil.split() {
        Split::Proportional(p) => format!(
            "proportional ({}): one shifted Krylov space answers every frequency",
            coefficients(p)
        ),
        Split::LowRank(p, r) => format!(
            "proportional ({}) + a rank-{} remainder on {} DoFs (dampers): one shifted Krylov \
             space and a {}x{} correction per frequency",
            coefficients(p),
            r.rank(),
            r.dofs.len(),
            r.rank(),
            r.rank()
        ),
        Split::General(p, dofs) => format!(
            "not proportional: the remainder after the fit ({}) touches {} DoFs; one \
             linearized Krylov space answers every frequency ({} factor; when the damping \
             keeps a free body's rigid motion apart)",
            coefficients(p),
            if *dofs == usize::MAX {
                "most".to_string()
            } else {
                dofs.to_string()
            },
            if pencil.structural() == (0.0, false) {
                "a real"
            } else {
                "a complex"
            }
        ),
    }
}

fn describe_damping(d: &sparsemor::model::Damping) -> String {
    match d {
        sparsemor::model::Damping::None => "none (real pencil)".into(),
        sparsemor::model::Damping::Rayleigh { alpha, beta } => {
            format!("Rayleigh alpha = {alpha:e}, beta = {beta:e}")
        }
        sparsemor::model::Damping::Matrix(m) => format!("explicit D ({} entries)", m.compute_nnz()),
    }
}
