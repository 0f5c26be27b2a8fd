//! `sparsemor generate`: a built-in model (the paper bar or the L-shaped bracket) as a model
//! directory.

use super::args::parse_triple;
use sparsemor::fe::bracket::{bracket_model, BracketSpec};
use sparsemor::fe::BoxSpec;
use sparsemor::io::model_dir;
use sparsemor::{Error, Result};
use std::path::Path;
use std::time::Instant;

pub fn generate(
    kind: &str,
    elements: Option<&str>,
    size: Option<&str>,
    cell: Option<f64>,
    out: &Path,
) -> Result<()> {
    let t = Instant::now();
    let (model, scene) = match kind {
        "bar" => {
            let mut spec = BoxSpec::paper_bar();
            if let Some(e) = elements {
                spec.elements = parse_triple(e, "--elements")?;
            }
            if let Some(s) = size {
                spec.size_m = parse_triple(s, "--size")?;
            }
            (
                sparsemor::fe::bar_model(&spec)?,
                sparsemor::fe::paper_scene(&spec),
            )
        }
        "bracket" => {
            let mut spec = BracketSpec::steel();
            if let Some(h) = cell {
                spec.cell_m = h;
            }
            bracket_model(&spec)?
        }
        _ => {
            return Err(Error::InvalidSetting(format!(
                "generate '{kind}': the built-in models are `bar` and `bracket`"
            )))
        }
    };
    let t_asm = t.elapsed().as_secs_f64();
    let t = Instant::now();
    model_dir::write(out, &model, &scene)?;
    eprintln!(
        "wrote {} (N = {}, nnz(M)+nnz(K) = {}; assembled in {:.2} s, written in {:.2} s)",
        out.display(),
        model.n(),
        model.nnz(),
        t_asm,
        t.elapsed().as_secs_f64()
    );
    Ok(())
}
