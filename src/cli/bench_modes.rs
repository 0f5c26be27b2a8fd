//! `sparsemor bench modes`: the eigensolver table of docs/design.md §8 — the lowest c modes
//! of generated bodies (cubes with repeated eigenvalues, the L-shaped bracket, a slender bar)
//! and of model directories given with `--models` (the tet10 parts of `benches/parts.py`),
//! per phase, with the
//! peak memory and SciPy's `eigsh` (ARPACK + SuperLU shift-invert, `benches/eigsh_reference.py`)
//! measured in the same run on the same files. SciPy is a reference, not a dependency: when
//! `python3 -c "import scipy"` fails its columns say so. Timings are single runs.

use super::args::human_bytes;
use sparsemor::body::Body;
use sparsemor::eigen::{eigenpairs, EigenOptions, Modes, Request};
use sparsemor::fe::bracket::{bracket_model, BracketSpec};
use sparsemor::fe::{bar_model, paper_scene, BoxSpec};
use sparsemor::io::model_dir;
use sparsemor::model::Model;
use sparsemor::scene::Scene;
use sparsemor::{memory, Error, Result};
use std::path::{Path, PathBuf};
use std::process::Command;

/// A generated body of the table.
enum Body3d {
    /// A hex8 box (cube or bar): elements and size.
    Box([usize; 3], [f64; 3]),
    /// The steel bracket with this cell size (m).
    Bracket(f64),
}

impl Body3d {
    /// The model and its scene, or `None` when it has more than `max_n` DoFs (a box is
    /// counted before it is meshed).
    fn generate(&self, max_n: usize) -> Result<Option<(Model, Scene)>> {
        let (model, scene) = match *self {
            Body3d::Box(elements, size_m) => {
                let spec = BoxSpec {
                    elements,
                    size_m,
                    ..BoxSpec::paper_bar()
                };
                if spec.n_dofs() > max_n {
                    return Ok(None);
                }
                (bar_model(&spec)?, paper_scene(&spec))
            }
            Body3d::Bracket(cell_m) => bracket_model(&BracketSpec {
                cell_m,
                ..BracketSpec::steel()
            })?,
        };
        Ok((model.n() <= max_n).then_some((model, scene)))
    }
}

/// (name, body, mode counts).
type Case = (&'static str, Body3d, &'static [usize]);

const CASES: [Case; 5] = [
    (
        "cube 10^3",
        Body3d::Box([10, 10, 10], [0.1; 3]),
        &[106, 306],
    ),
    (
        "cube 14^3",
        Body3d::Box([14, 14, 14], [0.1; 3]),
        &[106, 306],
    ),
    ("bracket 5 mm", Body3d::Bracket(0.005), &[106, 306]),
    (
        "bar 3x4x200",
        Body3d::Box([3, 4, 200], [0.006, 0.008, 0.3]),
        &[20, 106],
    ),
    (
        "bar 4x6x9520",
        Body3d::Box([4, 6, 9520], [0.006, 0.008, 3.0]),
        &[20],
    ),
];

/// SciPy's result for one case: seconds and ascending eigenvalues.
struct Reference {
    seconds: f64,
    lambdas: Vec<f64>,
}

/// Modes asked of a model directory given with `--models`.
const MODEL_COUNTS: [usize; 1] = [306];

/// Prints the table for every case with N ≤ `max_n`, then for the model directories `models`;
/// SciPy runs for N ≤ `scipy_max_n`.
pub fn run(max_n: usize, scipy_max_n: usize, models: &[PathBuf], threads: &[usize]) -> Result<()> {
    let scipy = Command::new("python3")
        .args(["-c", "import scipy"])
        .status()
        .is_ok_and(|s| s.success());
    println!("| model | N | modes | threads | slices | factorizations | solves per mode | restarts | inertia counts s | factor s | Krylov s | wall s | peak RSS | SciPy eigsh s | sparsemor ÷ SciPy | max rel. λ diff vs SciPy |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let tmp = std::env::temp_dir().join(format!("sparsemor-bench-modes-{}", std::process::id()));
    for (name, body3d, counts) in CASES {
        let Some((model, scene)) = body3d.generate(max_n)? else {
            continue;
        };
        let dir = tmp.join(name.replace([' ', '^'], "_"));
        let use_scipy = scipy && model.n() <= scipy_max_n;
        if use_scipy {
            model_dir::write(&dir, &model, &scene)?;
        }
        let body = Body::new(&model)?;
        let case = Measured {
            name,
            body: &body,
            band_end_hz: scene.band_hz[1],
            scipy_dir: use_scipy.then_some(dir.as_path()),
        };
        for &c in counts {
            case.rows(c, threads)?;
        }
    }
    let _ = std::fs::remove_dir_all(&tmp);
    for dir in models {
        let (body, scene) = model_dir::read_body(dir)?;
        if body.n() > max_n {
            continue;
        }
        let name = dir.file_name().map_or_else(
            || dir.display().to_string(),
            |f| f.to_string_lossy().into_owned(),
        );
        let case = Measured {
            name: &name,
            body: &body,
            band_end_hz: scene.band_hz[1],
            scipy_dir: (scipy && body.n() <= scipy_max_n).then_some(dir.as_path()),
        };
        for c in MODEL_COUNTS {
            case.rows(c, threads)?;
        }
    }
    Ok(())
}

/// One body of the table: its name, the body, the scene's band end (the first shift, as
/// `modes` takes it) and the model directory SciPy reads, if it runs.
struct Measured<'a> {
    name: &'a str,
    body: &'a Body,
    band_end_hz: f64,
    scipy_dir: Option<&'a Path>,
}

impl Measured<'_> {
    /// The rows of the c lowest modes, one per thread count.
    fn rows(&self, c: usize, threads: &[usize]) -> Result<()> {
        let reference = self.scipy_dir.map(|d| eigsh(d, c)).transpose()?;
        for &t in threads {
            memory::reset_peak_rss();
            let opts = EigenOptions {
                threads: t,
                ..EigenOptions::for_band(self.band_end_hz)
            };
            let m = eigenpairs(self.body, Request::Lowest(c), &opts)?;
            let peak = memory::peak_rss_bytes().unwrap_or(0);
            let st = &m.stats;
            let (scipy_s, ratio, diff) = match &reference {
                Some(r) => (
                    format!("{:.2}", r.seconds),
                    format!("{:.3}", st.wall_s / r.seconds),
                    format!("{:.1e}", max_rel_diff(&m, &r.lambdas)),
                ),
                None => ("—".into(), "—".into(), "—".into()),
            };
            println!(
                "| {} | {} | {c} | {t} | {} | {} | {:.2} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {} | {scipy_s} | {ratio} | {diff} |",
                self.name,
                self.body.n(),
                st.slices.len(),
                st.factorizations,
                st.solves as f64 / c as f64,
                st.restarts,
                st.count_s,
                st.factor_s,
                st.iterate_s,
                st.wall_s,
                human_bytes(peak as f64),
            );
        }
        Ok(())
    }
}

fn max_rel_diff(m: &Modes, reference: &[f64]) -> f64 {
    (m.rigid..m.lambdas.len().min(reference.len()))
        .map(|k| (m.lambdas[k] - reference[k]).abs() / reference[k].abs())
        .fold(0.0, f64::max)
}

/// The number under `"key": ` in the one-line JSON a reference script printed.
pub(super) fn json_number(stdout: &str, key: &str) -> Option<f64> {
    stdout
        .split(&format!("\"{key}\": "))
        .nth(1)
        .and_then(|s| s.split([',', '}']).next())
        .and_then(|s| s.trim().parse::<f64>().ok())
}

/// Runs `benches/eigsh_reference.py` on the model directory for the lowest `c` modes.
fn eigsh(dir: &Path, c: usize) -> Result<Reference> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/eigsh_reference.py");
    let out = dir.join("eigsh.txt");
    let run = Command::new("python3")
        .arg(&script)
        .arg(dir)
        .arg(c.to_string())
        .arg("--out")
        .arg(&out)
        .output()
        .map_err(|e| Error::io(&script, e))?;
    let fail = |what: &str| {
        Error::InvalidSetting(format!(
            "{}: {what}: {}",
            script.display(),
            String::from_utf8_lossy(&run.stderr)
        ))
    };
    if !run.status.success() {
        return Err(fail("failed"));
    }
    let stdout = String::from_utf8_lossy(&run.stdout);
    let seconds =
        json_number(&stdout, "seconds").ok_or_else(|| fail("no \"seconds\" in its output"))?;
    let text = std::fs::read_to_string(&out).map_err(|e| Error::io(&out, e))?;
    let lambdas = text
        .lines()
        .map(|l| l.trim().parse::<f64>())
        .collect::<std::result::Result<Vec<_>, _>>()
        .map_err(|_| fail("unreadable eigenvalues"))?;
    Ok(Reference { seconds, lambdas })
}
