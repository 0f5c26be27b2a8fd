//! Remote points and general inputs and outputs in a model directory (docs/design.md §3.11,
//! §4): the coupled model's transfer function against a dense Lagrange-multiplier solve
//! (rigid points) and the weighted-average definition (distributing points) computed here,
//! the tolerance-driven line-fitting on it, and one test per kind of bad input.

use crate::common::{dense, rel_err};
use faer::linalg::solvers::Solve;
use faer::{c64, Mat};
use sparsemor::body::Body;
use sparsemor::fe::{bar_model, BoxSpec};
use sparsemor::frf::{transfer_function, Part};
use sparsemor::io::model_dir;
use sparsemor::model::Model;
use sparsemor::scene::Scene;
use sparsemor::sweep::{no_progress, SweepOptions};
use std::path::{Path, PathBuf};

pub(crate) const BETA: f64 = 2e-5;

/// The 90-DoF bar (1 × 2 × 4 hexahedra, 0.02 × 0.03 × 0.2 m), free, Rayleigh damped.
pub(crate) fn bar() -> Model {
    let mut m = bar_model(&BoxSpec::small()).unwrap();
    m.damping = sparsemor::model::Damping::Rayleigh {
        alpha: 0.0,
        beta: BETA,
    };
    m
}

/// A directory with the bar's files and a `model.toml` whose remote points and scene are
/// `joints` (TOML text after the common keys).
pub(crate) fn directory(name: &str, joints: &str) -> PathBuf {
    directory_of(name, &bar(), joints)
}

/// [`directory`] with the files of `model` (Rayleigh damped as the bar).
fn directory_of(name: &str, model: &Model, joints: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("remote_points")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.parent().unwrap()).unwrap();
    let scene = Scene {
        inputs: vec![0],
        outputs: vec![0],
        band_hz: [0.0, 2000.0],
    };
    model_dir::write(&dir, model, &scene).unwrap();
    let toml = format!(
        "name = \"bar\"\nmass = \"M.mtx\"\nstiffness = \"K.mtx\"\nnodes = \"nodes.csv\"\n\
         dofs_per_node = 3\n[rayleigh]\nbeta = {BETA}\n{joints}"
    );
    std::fs::write(dir.join("model.toml"), toml).unwrap();
    dir
}

/// A Matrix Market `coordinate real general` file of the dense matrix `a` (nonzeros only).
pub(crate) fn write_mtx(path: &Path, a: &Mat<f64>) {
    let mut s = String::from("%%MatrixMarket matrix coordinate real general\n");
    let entries: Vec<_> = (0..a.ncols())
        .flat_map(|j| (0..a.nrows()).map(move |i| (i, j)))
        .filter(|&(i, j)| a[(i, j)] != 0.0)
        .collect();
    s += &format!("{} {} {}\n", a.nrows(), a.ncols(), entries.len());
    for (i, j) in entries {
        s += &format!("{} {} {:e}\n", i + 1, j + 1, a[(i, j)]);
    }
    std::fs::write(path, s).unwrap();
}

/// The nodes of `model` with z = `z`.
pub(crate) fn face(model: &Model, z: f64) -> Vec<usize> {
    let nodes = model.nodes.as_ref().unwrap();
    (0..nodes.len())
        .filter(|&i| (nodes[i][2] - z).abs() < 1e-9)
        .collect()
}

/// G(r) = [I, −[r]×]: a node's translation under the rigid motion (t, θ) of a point at offset
/// −r from it.
pub(crate) fn g(r: [f64; 3]) -> Mat<f64> {
    let mut g = Mat::<f64>::zeros(3, 6);
    for a in 0..3 {
        g[(a, a)] = 1.0;
    }
    // θ × r
    g[(0, 4)] = r[2];
    g[(0, 5)] = -r[1];
    g[(1, 3)] = -r[2];
    g[(1, 5)] = r[0];
    g[(2, 3)] = r[1];
    g[(2, 4)] = -r[0];
    g
}

/// The distributing point's six functionals by their definition: the least-squares rigid
/// motion of the nodes, W = (Σ GᵢᵀGᵢ)⁻¹ [G₁ᵀ … Gₖᵀ] on the nodes' translations (6 × N).
fn weighted_average(model: &Model, nodes: &[usize], at: [f64; 3]) -> Mat<f64> {
    let xyz = model.nodes.as_ref().unwrap();
    let r = |i: usize| [0, 1, 2].map(|a| xyz[i][a] - at[a]);
    let mut a = Mat::<f64>::zeros(6, 6);
    let mut rhs = Mat::<f64>::zeros(6, model.n());
    for &i in nodes {
        let gi = g(r(i));
        a += gi.transpose() * &gi;
        for m in 0..3 {
            for j in 0..6 {
                rhs[(j, 3 * i + m)] = gi[(m, j)];
            }
        }
    }
    a.partial_piv_lu().solve(&rhs)
}

/// H(iω) of the bar with a rigid point over `rigid` at `at` by a dense Lagrange-multiplier
/// solve: unknowns [q; x; λ], constraints u_i − G(r_i) x = 0. `b` (N+6 rows: the body's DoFs,
/// then the point's) and `c` (N+6 columns) are the loads and measurements. Without `rigid`
/// nodes there is no point: `b` has N rows, `c` N columns.
fn lagrange_h(
    model: &Model,
    rigid: &[usize],
    at: [f64; 3],
    b: &Mat<f64>,
    c: &Mat<f64>,
    f: f64,
) -> Mat<c64> {
    let (n, k) = (model.n(), 3 * rigid.len());
    let x = if rigid.is_empty() { 0 } else { 6 };
    let w = 2.0 * std::f64::consts::PI * f;
    let (mm, kk) = (dense(&model.mass), dense(&model.stiffness));
    let size = n + x + k;
    let mut a = Mat::<c64>::zeros(size, size);
    for i in 0..n {
        for j in 0..n {
            a[(i, j)] = c64::new(kk[(i, j)] - w * w * mm[(i, j)], w * BETA * kk[(i, j)]);
        }
    }
    let xyz = model.nodes.as_ref().unwrap();
    for (row, &i) in rigid.iter().enumerate() {
        let gi = g([0, 1, 2].map(|d| xyz[i][d] - at[d]));
        for m in 0..3 {
            let l = n + x + 3 * row + m;
            a[(l, 3 * i + m)] = c64::new(1.0, 0.0);
            a[(3 * i + m, l)] = c64::new(1.0, 0.0);
            for j in 0..6 {
                a[(l, n + j)] = c64::new(-gi[(m, j)], 0.0);
                a[(n + j, l)] = c64::new(-gi[(m, j)], 0.0);
            }
        }
    }
    let bb = Mat::<c64>::from_fn(size, b.ncols(), |i, j| {
        c64::new(if i < n + x { b[(i, j)] } else { 0.0 }, 0.0)
    });
    let sol = a.partial_piv_lu().solve(&bb);
    Mat::from_fn(c.nrows(), b.ncols(), |o, j| {
        (0..n + x).map(|i| sol[(i, j)] * c[(o, i)]).sum()
    })
}

/// Every kind of input and output at once — a rigid point's DoFs, a distributing point's, a
/// node DoF, a column of B and a row of C — swept on the coupled directory, against the
/// dense references built here from the definitions (≤ 1e-9).
#[test]
fn coupled_directory_sweeps_like_lagrange_multipliers_and_weighted_averages() {
    let model = bar();
    let n = model.n();
    let (base, tip) = (face(&model, 0.0), face(&model, 0.2));
    let (at_base, at_tip) = ([0.01, 0.015, -0.01], [0.01, 0.015, 0.21]);
    // a general load over the middle of the bar and a general measurement
    let mut bmat = Mat::<f64>::zeros(n, 1);
    for (d, v) in [(30, 1.0), (31, -0.5), (45, 2.0), (61, 0.25)] {
        bmat[(d, 0)] = v;
    }
    let mut cmat = Mat::<f64>::zeros(1, n);
    for (d, v) in [(33, 0.5), (47, 1.5), (48, -1.0)] {
        cmat[(0, d)] = v;
    }
    let dir = directory(
        "every_kind",
        "[scene]\n\
         inputs = [\"base:x\", \"base:rz\", \"tip:z\", \"tip:rx\", \"9:y\"]\n\
         outputs = [\"base:x\", \"base:ry\", \"tip:z\", \"tip:rx\", \"tip:ry\", 40]\n\
         input_matrix = \"B.mtx\"\noutput_matrix = \"C.mtx\"\nband_hz = [0.0, 2000.0]\n\
         [[remote_points]]\nname = \"base\"\nkind = \"rigid\"\nposition = [0.01, 0.015, -0.01]\n\
         box = { min = [-1, -1, -1e-6], max = [1, 1, 1e-6] }\n\
         [[remote_points]]\nname = \"tip\"\nkind = \"distributing\"\n\
         position = [0.01, 0.015, 0.21]\ncylinder = { center = [0.01, 0.015, 0.2], axis = [0, 0, 1], \
         radius = 0.0, length = 1e-6, tol = 1.0 }\n",
    );
    write_mtx(&dir.join("B.mtx"), &bmat);
    write_mtx(&dir.join("C.mtx"), &cmat);
    let loaded = model_dir::load(&dir).unwrap();
    assert_eq!(loaded.scene.inputs.len(), 6);
    assert_eq!(loaded.scene.outputs.len(), 7);
    // the references: loads and measurements on [q; x_base]
    let w = weighted_average(&model, &tip, at_tip);
    let unit = |k: usize| Mat::<f64>::from_fn(n + 6, 1, |i, _| f64::from(i == k));
    let on_q = |v: &dyn Fn(usize) -> f64| {
        Mat::<f64>::from_fn(n + 6, 1, |i, _| if i < n { v(i) } else { 0.0 })
    };
    let cols = [
        unit(n),
        unit(n + 5),
        on_q(&|i| w[(2, i)]),
        on_q(&|i| w[(3, i)]),
        unit(3 * 9 + 1),
        on_q(&|i| bmat[(i, 0)]),
    ];
    let b = Mat::<f64>::from_fn(n + 6, cols.len(), |i, j| cols[j][(i, 0)]);
    let rows = [
        unit(n),
        unit(n + 4),
        on_q(&|i| w[(2, i)]),
        on_q(&|i| w[(3, i)]),
        on_q(&|i| w[(4, i)]),
        unit(40),
        on_q(&|i| cmat[(0, i)]),
    ];
    let c = Mat::<f64>::from_fn(rows.len(), n + 6, |o, i| rows[o][(i, 0)]);
    let body = Body::new(&loaded.model).unwrap();
    assert!(body.rigid().is_some(), "the coupled bar is still free");
    // not far below 300 Hz: the free bar's dense saddle-point matrix has a condition number
    // growing like 1/ω², and the reference loses digits (1.4e-9 apart at 37 Hz, 2.9e-11 at 300)
    let freqs = [300.0, 1800.0, 3100.0];
    let frf = transfer_function(
        &body,
        &loaded.scene,
        &freqs,
        Part::Total,
        &SweepOptions::default(),
        None,
        &no_progress,
    )
    .unwrap();
    for (k, &f) in freqs.iter().enumerate() {
        let want = lagrange_h(&model, &base, at_base, &b, &c, f);
        let e = rel_err(&frf.h[k], &want);
        assert!(e < 1e-10, "{f} Hz: relative difference {e:e}");
    }
}

/// Line-fitting by tolerance on the coupled bar: the ROM it certifies reproduces the
/// remote points' transfer functions within the tolerance on a fresh grid.
#[test]
fn line_fitting_reaches_its_tolerance_at_remote_points() {
    use sparsemor::reduce::linefit::{
        self, Interface, LineFitOptions, References, SamplingOptions,
    };
    let dir = directory(
        "linefit",
        "[scene]\n\
         inputs = [\"base:x\", \"base:y\", \"base:z\", \"base:rx\", \"base:ry\", \"base:rz\", \"tip:y\"]\n\
         outputs = [\"base:x\", \"base:y\", \"base:z\", \"base:rx\", \"base:ry\", \"base:rz\", \"tip:y\"]\n\
         band_hz = [0.0, 3000.0]\n\
         [[remote_points]]\nname = \"base\"\nkind = \"distributing\"\n\
         box = { min = [-1, -1, -1e-6], max = [1, 1, 1e-6] }\nposition = [0.01, 0.015, -0.01]\n\
         [[remote_points]]\nname = \"tip\"\nkind = \"rigid\"\n\
         box = { min = [-1, -1, 0.199], max = [1, 1, 1] }\nposition = [0.01, 0.015, 0.21]\n",
    );
    let loaded = model_dir::load(&dir).unwrap();
    let body = Body::new(&loaded.model).unwrap();
    let tol = 1e-4;
    let opts = LineFitOptions::new(
        Interface::OutputsPlus(0),
        References::Tolerance(SamplingOptions::new(tol)),
    );
    let rom = linefit::reduce(&body, &loaded.scene, &opts, None, &no_progress).unwrap();
    let grid: Vec<f64> = (0..300).map(|k| 3.0 + 2990.0 * k as f64 / 299.0).collect();
    let reference = crate::common::full_reference(&body, &loaded.scene, &grid);
    let err = reference.error(&rom).unwrap().eps_elastic;
    let max = err.iter().copied().fold(0.0, f64::max);
    assert!(max <= tol, "max error {max:e} > tol {tol:e}");
}

/// A distributing point over every node of the bar gives the coupled matrices a dense block
/// larger than the bar's own, so the body's products go through the coupling (docs/design.md
/// §3.11): the certified responses equal those of the formed matrices, and line-fitting by
/// tolerance meets its tolerance on a fresh grid.
#[test]
fn a_point_over_the_whole_body_multiplies_through_the_coupling() {
    use sparsemor::reduce::linefit::{
        self, Interface, LineFitOptions, References, SamplingOptions,
    };
    // 2 × 2 × 12 hexahedra: 351 DoFs, so the point's dense block (its rows over every DoF)
    // outweighs K
    let mut model = bar_model(&BoxSpec {
        elements: [2, 2, 12],
        ..BoxSpec::small()
    })
    .unwrap();
    model.damping = sparsemor::model::Damping::Rayleigh {
        alpha: 0.0,
        beta: BETA,
    };
    let dir = directory_of(
        "through",
        &model,
        "[scene]\n\
         inputs = [\"all:x\", \"all:rz\", \"tip:y\"]\n\
         outputs = [\"all:x\", \"all:rz\", \"tip:y\"]\n\
         band_hz = [0.0, 3000.0]\n\
         [[remote_points]]\nname = \"all\"\nkind = \"distributing\"\n\
         box = { min = [-1, -1, -1], max = [1, 1, 1] }\nposition = [0.013, 0.017, 0.104]\n\
         [[remote_points]]\nname = \"tip\"\nkind = \"rigid\"\n\
         box = { min = [-1, -1, 0.199], max = [1, 1, 1] }\nposition = [0.01, 0.015, 0.21]\n",
    );
    let loaded = model_dir::load(&dir).unwrap();
    let body = Body::new(&loaded.model).unwrap();
    let (through, formed_entries) = body.pencil().through_coupling().unwrap();
    assert!(
        2 * through <= formed_entries,
        "{through} against {formed_entries}"
    );
    let formed = Body::new(&Model {
        coupling: None,
        ..loaded.model.clone()
    })
    .unwrap();
    assert!(formed.pencil().through_coupling().is_none());
    let grid: Vec<f64> = (0..300).map(|k| 3.0 + 2990.0 * k as f64 / 299.0).collect();
    let reference = crate::common::full_reference(&body, &loaded.scene, &grid);
    let want = crate::common::full_reference(&formed, &loaded.scene, &grid);
    for (a, b) in reference.h.iter().zip(&want.h) {
        assert!((a - b).norm_l2() <= 1e-10 * b.norm_l2());
    }
    let tol = 1e-4;
    let opts = LineFitOptions::new(
        Interface::OutputsPlus(0),
        References::Tolerance(SamplingOptions::new(tol)),
    );
    let rom = linefit::reduce(&body, &loaded.scene, &opts, None, &no_progress).unwrap();
    let err = reference.error(&rom).unwrap().eps_elastic;
    let max = err.iter().copied().fold(0.0, f64::max);
    assert!(max <= tol, "max error {max:e} > tol {tol:e}");
}

/// One bad input each, refused with a message that names the point or file and the fix.
#[test]
fn bad_remote_points_and_scene_matrices_are_refused_by_name() {
    let base_scene = "[scene]\ninputs = [\"p:x\"]\noutputs = [\"p:x\"]\nband_hz = [0.0, 100.0]\n";
    let cases: [(&str, String, &[&str]); 8] = [
        (
            "empty",
            "[[remote_points]]\nname = \"p\"\nkind = \"rigid\"\nbox = { min = [5, 5, 5], max = [6, 6, 6] }\n".into(),
            &["'p'", "selection holds no node"],
        ),
        (
            "line",
            // the tip's three nodes at x = 0: a line along y
            "[[remote_points]]\nname = \"p\"\nkind = \"distributing\"\nposition = [0.01, 0.0, 0.21]\n\
             box = { min = [-1e-6, -1, 0.1999], max = [1e-6, 1, 1] }\n".into(),
            &["remote point p", "one line"],
        ),
        (
            "on_node",
            "[[remote_points]]\nname = \"p\"\nkind = \"rigid\"\nposition = [0.0, 0.0, 0.2]\n\
             box = { min = [-1, -1, 0.1999], max = [1, 1, 1] }\n".into(),
            &["remote point p", "coincides with coupled node"],
        ),
        (
            "two_rigid",
            "[[remote_points]]\nname = \"p\"\nkind = \"rigid\"\nposition = [0.01, 0.015, 0.21]\n\
             box = { min = [-1, -1, 0.1999], max = [1, 1, 1] }\n\
             [[remote_points]]\nname = \"q\"\nkind = \"rigid\"\nposition = [0.01, 0.015, 0.25]\n\
             box = { min = [-1, -1, 0.1999], max = [1, 0.016, 1] }\n".into(),
            &["remote points p and q", "overconstrains"],
        ),
        (
            "kind",
            "[[remote_points]]\nname = \"p\"\nkind = \"glued\"\nnodes = [1, 2, 3]\n".into(),
            &["'p'", "kind = \"glued\"", "rigid", "distributing"],
        ),
        (
            "two_selections",
            "[[remote_points]]\nname = \"p\"\nkind = \"rigid\"\nnodes = [1, 2, 3]\n\
             box = { min = [-1, -1, 0.1999], max = [1, 1, 1] }\n".into(),
            &["'p'", "exactly one node selection"],
        ),
        (
            "rigid_weights",
            "[[remote_points]]\nname = \"p\"\nkind = \"rigid\"\nposition = [0.01, 0.015, 0.21]\n\
             box = { min = [-1, -1, 0.1999], max = [1, 1, 1] }\nweights = [1, 1, 1, 1, 1, 1]\n".into(),
            &["'p'", "weights apply to a distributing point"],
        ),
        (
            "bad_dir",
            "[[remote_points]]\nname = \"p\"\nkind = \"rigid\"\nposition = [0.01, 0.015, 0.21]\n\
             box = { min = [-1, -1, 0.1999], max = [1, 1, 1] }\n".into(),
            &["unknown DoF direction 'w'"],
        ),
    ];
    for (name, points, needles) in cases {
        let scene = if name == "bad_dir" {
            base_scene.replace("\"p:x\"]\noutputs", "\"p:w\"]\noutputs")
        } else {
            base_scene.to_string()
        };
        let dir = directory(name, &format!("{scene}{points}"));
        let msg = model_dir::load(&dir).unwrap_err().to_string();
        for n in needles {
            assert!(msg.contains(n), "{name}: {n:?} not in {msg:?}");
        }
        assert!(
            msg.contains("model.toml"),
            "{name}: {msg:?} does not name model.toml"
        );
    }
    // a C file of the wrong width
    let dir = directory(
        "c_size",
        "[scene]\ninputs = [0]\noutputs = [0]\noutput_matrix = \"C.mtx\"\nband_hz = [0.0, 100.0]\n",
    );
    write_mtx(
        &dir.join("C.mtx"),
        &Mat::<f64>::from_fn(1, 7, |_, j| j as f64),
    );
    let msg = model_dir::load(&dir).unwrap_err().to_string();
    assert!(msg.contains("C.mtx: 1 × 7 but C must be q × 90"), "{msg}");
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(12))]

    /// Any independent sparse functionals: the coupled model's response at their pivots is
    /// C A⁻¹ Cᵀ of the original (dense solves, ≤ 1e-10), whatever the rows' supports overlap.
    #[test]
    fn any_functionals_become_exact_coordinates(
        rows in proptest::collection::vec(
            proptest::collection::btree_map(0usize..90, -2.0f64..2.0, 1..8), 1..5),
        f in 400.0f64..4000.0,
    ) {
        use sparsemor::coupled::{couple, Functional};
        use sparsemor::coupling::SparseRow;
        let model = bar();
        let rows: Vec<SparseRow> = rows
            .iter()
            .map(|r| SparseRow {
                idx: r.keys().copied().collect(),
                val: r.values().map(|v| if *v == 0.0 { 1.0 } else { *v }).collect(),
            })
            .collect();
        let functionals: Vec<Functional> = rows
            .iter()
            .enumerate()
            .map(|(k, r)| Functional::Row(format!("row {k}"), r.clone()))
            .collect();
        let cp = match couple(&model, &[], &functionals, &functionals) {
            Ok(cp) => cp,
            Err(e) => {
                // random rows may be dependent (or repeat): refusing them is the contract
                let msg = e.to_string();
                proptest::prop_assert!(
                    msg.contains("linearly dependent") || msg.contains("same functional"),
                    "{msg}"
                );
                return Ok(());
            }
        };
        let c = Mat::<f64>::from_fn(rows.len(), model.n(), |i, j| {
            rows[i].idx.iter().position(|&d| d == j).map_or(0.0, |p| rows[i].val[p])
        });
        let b = c.transpose().to_owned();
        let want = lagrange_h(&model, &[], [0.0; 3], &b, &c, f);
        let got = crate::common::dense_h(&cp.model, f, &cp.inputs, &cp.outputs);
        let e = rel_err(&got, &want);
        proptest::prop_assert!(e < 1e-10, "{f} Hz: {e:e}");
    }
}

/// The command on a coupled directory: `info` reports the points and the size change,
/// `reduce --method linefit --tol` and `evaluate` run, and every export writes the remote
/// points as interface nodes and names them.
#[test]
fn the_command_reduces_and_exports_a_coupled_directory() {
    use crate::cli::{ok, run};
    let dir = directory(
        "command",
        "[scene]\ninputs = [\"tip:x\", \"tip:rz\"]\noutputs = [\"tip:x\", \"tip:rz\", \"base:y\"]\n\
         band_hz = [0.0, 3000.0]\n\
         [[remote_points]]\nname = \"base\"\nkind = \"rigid\"\n\
         box = { min = [-1, -1, -1e-6], max = [1, 1, 1e-6] }\nposition = [0.01, 0.015, -0.01]\n\
         [[remote_points]]\nname = \"tip\"\nkind = \"distributing\"\n\
         box = { min = [-1, -1, 0.199], max = [1, 1, 1] }\n",
    );
    let info = ok(&dir, &["info", "."]);
    for needle in [
        "remote point base: rigid (RBE2) over 6 nodes",
        "remote point tip: distributing (RBE3) over 6 nodes at (1.000000e-2, 1.500000e-2, 2.000000e-1)",
        "coupled model: N 90 -> 78",
        "6: free body",
    ] {
        assert!(info.contains(needle), "{needle:?} not in\n{info}");
    }
    for sub in ["rom", "romv", "ex_sid", "ex_mbdyn", "ex_exudyn", "ex_dmig"] {
        let _ = std::fs::remove_dir_all(dir.join(sub));
    }
    ok(
        &dir,
        &[
            "reduce", ".", "--method", "linefit", "--tol", "1e-3", "--out", "rom",
        ],
    );
    ok(&dir, &["evaluate", ".", "rom"]);
    ok(
        &dir,
        &[
            "reduce",
            ".",
            "--method",
            "linefit",
            "--tol",
            "1e-3",
            "--keep-basis",
            "--out",
            "romv",
        ],
    );
    for (format, needles) in [
        ("sid", ["point base -> node 31", "point tip -> node 32"]),
        ("mbdyn", ["point base -> node 31", "point tip -> node 32"]),
        (
            "exudyn",
            [
                "point base -> MarkerSuperElementRigid over 6 mesh nodes",
                "point tip -> MarkerSuperElementRigid over 6 mesh nodes",
            ],
        ),
        ("dmig", ["point base -> grid 31", "point tip -> grid 32"]),
    ] {
        let out = ok(
            &dir,
            &[
                "export",
                "romv",
                "--model",
                ".",
                "--format",
                format,
                "--points",
                "20",
                "--out",
                &format!("ex_{format}"),
            ],
        );
        for n in needles {
            assert!(out.contains(n), "{format}: {n:?} not in\n{out}");
        }
    }
    let sid = std::fs::read_to_string(dir.join("ex_sid").join("body.SID_FEM")).unwrap();
    assert!(sid.starts_with("   32 "), "{}", &sid[..80]);
    // without the basis: the ROM directory and the fix are named, nothing is written
    let out = run(
        &dir,
        &[
            "export", "rom", "--model", ".", "--format", "sid", "--out", "ex",
        ],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("--keep-basis"),
        "{err}"
    );
    assert!(
        !dir.join("ex").exists(),
        "a refused export left a directory"
    );
}
