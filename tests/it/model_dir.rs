//! The model directory (docs/design.md §4): bit-exact round trips, the real ANSYS example, and
//! one test per kind of bad input (error variant + a message that names the problem).

use crate::common::{dense_h, random_model, random_scene, rel_err, sparse};
use faer::Mat;
use sparsemor::fe::{bar_model, paper_scene, BoxSpec};
use sparsemor::frf::{transfer_function, Part};
use sparsemor::io::{atomic, model_dir};
use sparsemor::model::{Damping, Model};
use sparsemor::scene::Scene;
use sparsemor::sparse::Csc;
use sparsemor::sweep::{no_progress, SweepOptions};
use sparsemor::Error;
use std::path::{Path, PathBuf};

// ---------------------------------------------------------------------------------------------
// Helpers

/// A fresh, empty directory `<CARGO_TARGET_TMPDIR>/model_dir/<name>` (removed first if present).
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("model_dir")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create scratch dir");
    dir
}

fn put(dir: &Path, file: &str, text: &str) {
    std::fs::write(dir.join(file), text).expect("write fixture file");
}

/// `text` with `old` replaced by `new`; `old` must occur (so a fixture change cannot make a
/// test vacuous).
fn edit(text: &str, old: &str, new: &str) -> String {
    assert!(text.contains(old), "fixture does not contain {old:?}");
    text.replacen(old, new, 1)
}

/// A valid 6-DoF model (2 nodes × 3 DoFs): M = I, K tridiagonal (2, −1), Rayleigh damping.
const TOML: &str = "\
name = \"tiny\"
mass = \"M.mtx\"
stiffness = \"K.mtx\"
nodes = \"nodes.csv\"
dofs_per_node = 3
[rayleigh]
alpha = 0.0
beta = 1e-5
[scene]
inputs = [0, 1]
outputs = [2, 3]
band_hz = [0.0, 100.0]
";

const M_MTX: &str = "\
%%MatrixMarket matrix coordinate real symmetric
6 6 6
1 1 1.0
2 2 1.0
3 3 1.0
4 4 1.0
5 5 1.0
6 6 1.0
";

const K_MTX: &str = "\
%%MatrixMarket matrix coordinate real symmetric
6 6 11
1 1 2.0
2 1 -1.0
2 2 2.0
3 2 -1.0
3 3 2.0
4 3 -1.0
4 4 2.0
5 4 -1.0
5 5 2.0
6 5 -1.0
6 6 2.0
";

const NODES: &str = "x,y,z\n0,0,0\n1,0,0\n";

/// The tiny model directory with one file replaced.
fn tiny(name: &str, file: &str, text: &str) -> PathBuf {
    let dir = scratch(name);
    put(&dir, "model.toml", TOML);
    put(&dir, "M.mtx", M_MTX);
    put(&dir, "K.mtx", K_MTX);
    put(&dir, "nodes.csv", NODES);
    put(&dir, file, text);
    dir
}

fn read_err(dir: &Path) -> Error {
    match model_dir::read(dir) {
        Ok(_) => panic!(
            "{}: expected an error, the model was accepted",
            dir.display()
        ),
        Err(e) => e,
    }
}

/// Asserts that the message contains every needle.
fn says(e: &Error, needles: &[&str]) {
    let msg = e.to_string();
    for n in needles {
        assert!(msg.contains(n), "{n:?} not in the message {msg:?}");
    }
}

fn assert_same_csc(a: &Csc, b: &Csc, what: &str) {
    assert_eq!(
        (a.nrows(), a.ncols()),
        (b.nrows(), b.ncols()),
        "{what}: shape"
    );
    assert_eq!(
        a.symbolic().col_ptr(),
        b.symbolic().col_ptr(),
        "{what}: col_ptr"
    );
    assert_eq!(
        a.symbolic().row_idx(),
        b.symbolic().row_idx(),
        "{what}: row_idx"
    );
    let bits = |m: &Csc| m.val().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(a), bits(b), "{what}: values (bitwise)");
}

fn assert_same_model(a: &Model, b: &Model) {
    assert_eq!(a.name, b.name);
    assert_same_csc(&a.mass, &b.mass, "M");
    assert_same_csc(&a.stiffness, &b.stiffness, "K");
    match (&a.damping, &b.damping) {
        (Damping::None, Damping::None) => {}
        (
            Damping::Rayleigh {
                alpha: a0,
                beta: b0,
            },
            Damping::Rayleigh {
                alpha: a1,
                beta: b1,
            },
        ) => {
            assert_eq!(
                (a0.to_bits(), b0.to_bits()),
                (a1.to_bits(), b1.to_bits()),
                "Rayleigh coefficients"
            );
        }
        (Damping::Matrix(d0), Damping::Matrix(d1)) => assert_same_csc(d0, d1, "D"),
        (x, y) => panic!("damping changed: {x:?} -> {y:?}"),
    }
    let bits = |n: &Option<Vec<[f64; 3]>>| {
        n.as_ref()
            .map(|n| n.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>())
    };
    assert_eq!(bits(&a.nodes), bits(&b.nodes), "nodes (bitwise)");
    assert_eq!(a.dofs_per_node, b.dofs_per_node);
}

fn round_trip(name: &str, model: &Model, scene: &Scene) {
    let dir = scratch(name).join("model");
    model_dir::write(&dir, model, scene).expect("write");
    let (back, back_scene, _) = model_dir::read(&dir).expect("read back");
    assert_same_model(model, &back);
    assert_eq!(scene, &back_scene);
}

/// Names in `parent` that start with `.{name}.tmp-` (leftovers of [`atomic::write_dir`]).
fn tmp_siblings(parent: &Path, name: &str) -> Vec<String> {
    let prefix = format!(".{name}.tmp-");
    std::fs::read_dir(parent)
        .expect("list parent")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(&prefix))
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Round trips

#[test]
fn round_trip_paper_bar_is_bit_exact() {
    let model = bar_model(&BoxSpec::paper_bar()).expect("bar");
    assert!(model.nodes.is_some() && matches!(model.damping, Damping::Rayleigh { .. }));
    round_trip("rt_bar", &model, &paper_scene(&BoxSpec::paper_bar()));
}

#[test]
fn round_trip_explicit_damping_matrix_without_nodes_is_bit_exact() {
    // An arbitrary symmetric D with "ugly" values (no short decimal form).
    let n = 30;
    let mut d = Mat::<f64>::zeros(n, n);
    for i in 0..n {
        d[(i, i)] = 1.0 / (i as f64 + 3.0);
        if i + 2 < n {
            let v = -std::f64::consts::PI * 1e-7 * (i as f64 + 1.0).sqrt();
            d[(i, i + 2)] = v;
            d[(i + 2, i)] = v;
        }
    }
    let model = random_model(n, 3, 7, Damping::Matrix(sparse(&d)));
    assert!(model.nodes.is_none());
    round_trip("rt_dmatrix", &model, &random_scene(n));
}

#[test]
fn round_trip_undamped_without_nodes_is_bit_exact() {
    let model = random_model(24, 2, 11, Damping::None);
    round_trip("rt_none", &model, &random_scene(24));
}

#[test]
fn tiny_fixture_is_valid() {
    let dir = tiny("tiny_ok", "nodes.csv", NODES);
    let (m, _, _) = model_dir::read(&dir).expect("the base fixture must be valid");
    assert_eq!(m.n(), 6);
    assert_eq!(m.nodes.as_ref().map(Vec::len), Some(2));
}

// ---------------------------------------------------------------------------------------------
// The real ANSYS data

#[test]
fn ansys_example_reads_and_sweeps_like_a_dense_solve() {
    let src = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../shared/data/ansys_example_full"
    ));
    if !src.join("K.mtx").exists() {
        println!(
            "note: {} not found; skipping the ANSYS example test",
            src.display()
        );
        return;
    }
    let dir = scratch("ansys");
    for f in ["K.mtx", "M.mtx", "nodes.csv"] {
        std::fs::copy(src.join(f), dir.join(f)).expect("copy ANSYS file");
    }
    // Scene as in model.json (no damping: rayleigh alpha = beta = 0 there; here no [rayleigh]).
    put(
        &dir,
        "model.toml",
        "name = \"ansys_example_full\"
mass = \"M.mtx\"
stiffness = \"K.mtx\"
nodes = \"nodes.csv\"
dofs_per_node = 3
[scene]
inputs = [0, 1, 2, 90, 91, 92, 78, 79, 80]
outputs = [0, 1, 2, 90, 91, 92, 78, 79, 80]
band_hz = [0.0, 12207.14]
",
    );
    let (model, scene, report) = model_dir::read(&dir).expect("read the ANSYS model");
    assert_eq!(model.n(), 900);
    assert_eq!(model.nodes.as_ref().map(Vec::len), Some(300));
    assert!(matches!(model.damping, Damping::None));
    assert!(report.mass_diagonal[0] > 0.0);
    // Away from the eigenfrequencies 1283.2 (×2), 5782.0, 6919.4 (×2), 10172.6.
    let freqs = [0.0, 100.0, 3000.0, 8000.0, 12000.0];
    let (inputs, outputs) = (&scene.inputs, &scene.outputs);
    let opts = SweepOptions {
        threads: 2,
        ..Default::default()
    };
    let body = sparsemor::body::Body::new(&model).expect("prepare");
    let frf = transfer_function(
        &body,
        &scene,
        &freqs,
        Part::Total,
        &opts,
        None,
        &no_progress,
    )
    .expect("sweep");
    for (f, h) in freqs.iter().zip(&frf.h) {
        let err = rel_err(h, &dense_h(&model, *f, inputs, outputs));
        assert!(
            err <= 1e-9,
            "f = {f} Hz: relative error {err:.2e} against the dense solve"
        );
    }
}

// ---------------------------------------------------------------------------------------------
// Bad inputs: manifest

#[test]
fn missing_manifest_is_an_io_error_naming_model_toml() {
    let dir = scratch("no_manifest");
    put(&dir, "M.mtx", M_MTX);
    let e = read_err(&dir);
    assert!(
        matches!(&e, Error::Io { path, .. } if path.ends_with("model.toml")),
        "{e:?}"
    );
    says(&e, &["model.toml"]);
}

#[test]
fn toml_syntax_error_names_the_line() {
    // line 8: `beta = = 1e-5`
    let dir = tiny(
        "toml_syntax",
        "model.toml",
        &edit(TOML, "beta = 1e-5", "beta = = 1e-5"),
    );
    let e = read_err(&dir);
    assert!(
        matches!(&e, Error::Parse { path, line: 8, .. } if path.ends_with("model.toml")),
        "{e:?}"
    );
    says(&e, &["model.toml:8:"]);
}

#[test]
fn unknown_key_is_an_error_naming_the_key_and_its_line() {
    // line 3: `stifness = "K.mtx"` (typo)
    let dir = tiny(
        "toml_typo",
        "model.toml",
        &edit(TOML, "stiffness =", "stifness ="),
    );
    let e = read_err(&dir);
    assert!(
        matches!(&e, Error::Parse { path, line: 3, .. } if path.ends_with("model.toml")),
        "{e:?}"
    );
    says(&e, &["model.toml:3:", "stifness"]);
}

#[test]
fn unknown_key_in_a_table_is_an_error() {
    // line 11: `output = [2, 3]` in [scene]
    let dir = tiny(
        "toml_typo_scene",
        "model.toml",
        &edit(TOML, "outputs =", "output ="),
    );
    let e = read_err(&dir);
    assert!(matches!(&e, Error::Parse { line: 11, .. }), "{e:?}");
    says(&e, &["model.toml:11:", "output"]);
}

// ---------------------------------------------------------------------------------------------
// Bad inputs: matrices

#[test]
fn missing_matrix_file_is_an_io_error_naming_it() {
    let dir = tiny(
        "missing_mtx",
        "model.toml",
        &edit(TOML, "\"K.mtx\"", "\"K_missing.mtx\""),
    );
    let e = read_err(&dir);
    assert!(
        matches!(&e, Error::Io { path, .. } if path.ends_with("K_missing.mtx")),
        "{e:?}"
    );
    says(&e, &["K_missing.mtx"]);
}

#[test]
fn malformed_mtx_names_the_file_and_line() {
    // line 5 of K.mtx: `2 2 2.0` -> `2 2 two`
    let dir = tiny("bad_mtx", "K.mtx", &edit(K_MTX, "2 2 2.0", "2 2 two"));
    let e = read_err(&dir);
    assert!(
        matches!(&e, Error::Parse { path, line: 5, .. } if path.ends_with("K.mtx")),
        "{e:?}"
    );
    says(&e, &["K.mtx:5:", "two"]);
}

#[test]
fn matrices_of_different_sizes_are_rejected() {
    let k5 = "%%MatrixMarket matrix coordinate real symmetric\n5 5 5\n1 1 2\n2 2 2\n3 3 2\n4 4 2\n5 5 2\n";
    let dir = tiny("size_mismatch", "K.mtx", k5);
    let e = read_err(&dir);
    assert!(matches!(e, Error::InvalidModel(_)), "{e:?}");
    says(&e, &["stiffness matrix K", "5×5", "N = 6"]);
}

#[test]
fn non_square_matrix_is_rejected() {
    let m65 =
        "%%MatrixMarket matrix coordinate real general\n6 5 5\n1 1 1\n2 2 1\n3 3 1\n4 4 1\n5 5 1\n";
    let dir = tiny("non_square", "M.mtx", m65);
    let e = read_err(&dir);
    assert!(matches!(e, Error::InvalidModel(_)), "{e:?}");
    says(&e, &["mass matrix M", "6×5", "not square"]);
}

#[test]
fn nan_in_stiffness_file_names_the_file_and_line() {
    // line 7 of K.mtx: `3 3 2.0` -> `3 3 NaN`
    let dir = tiny("nan_k_file", "K.mtx", &edit(K_MTX, "3 3 2.0", "3 3 NaN"));
    let e = read_err(&dir);
    assert!(
        matches!(&e, Error::Parse { path, line: 7, .. } if path.ends_with("K.mtx")),
        "{e:?}"
    );
    says(&e, &["K.mtx:7:", "NaN"]);
}

#[test]
fn nan_in_stiffness_matrix_is_rejected_by_validation() {
    // The same check for a model built in memory (Model::new).
    let base = random_model(9, 2, 3, Damping::None);
    let mut k = crate::common::dense(&base.stiffness);
    k[(4, 4)] = f64::NAN;
    let e = Model::new(
        "nan".into(),
        base.mass.clone(),
        sparse(&k),
        Damping::None,
        None,
        3,
    )
    .expect_err("NaN must be rejected");
    assert!(matches!(e, Error::InvalidModel(_)), "{e:?}");
    says(&e, &["stiffness matrix K", "NaN", "column 4"]);
}

#[test]
fn unsymmetric_stiffness_is_rejected() {
    // general file: K[1,0] = -1 but K[0,1] = -1.5
    let k = "%%MatrixMarket matrix coordinate real general
6 6 8
1 1 2.0
2 1 -1.0
1 2 -1.5
2 2 2.0
3 3 2.0
4 4 2.0
5 5 2.0
6 6 2.0
";
    let dir = tiny("unsym", "K.mtx", k);
    let e = read_err(&dir);
    assert!(matches!(e, Error::InvalidModel(_)), "{e:?}");
    says(&e, &["stiffness matrix K", "not symmetric"]);
}

#[test]
fn zero_or_negative_mass_diagonal_is_rejected() {
    for (case, val) in [("zero", "0.0"), ("negative", "-1.0")] {
        let dir = tiny(
            &format!("mass_diag_{case}"),
            "M.mtx",
            &edit(M_MTX, "4 4 1.0", &format!("4 4 {val}")),
        );
        let e = read_err(&dir);
        assert!(matches!(e, Error::InvalidModel(_)), "{case}: {e:?}");
        says(&e, &["mass matrix M", "DoF 3", "positive diagonal"]);
    }
    // A missing diagonal entry counts as zero.
    let no_diag = "%%MatrixMarket matrix coordinate real symmetric\n6 6 5\n1 1 1\n2 2 1\n3 3 1\n5 5 1\n6 6 1\n";
    let e = read_err(&tiny("mass_diag_missing", "M.mtx", no_diag));
    assert!(matches!(e, Error::InvalidModel(_)), "{e:?}");
    says(&e, &["DoF 3 is 0"]);
}

// ---------------------------------------------------------------------------------------------
// Bad inputs: scene

#[test]
fn input_dof_out_of_range_is_rejected() {
    let dir = tiny(
        "input_range",
        "model.toml",
        &edit(TOML, "inputs = [0, 1]", "inputs = [0, 6]"),
    );
    let e = read_err(&dir);
    assert!(e.is_invalid_setting(), "{e:?}");
    says(
        &e,
        &["model.toml", "inputs", "DoF 6", "out of range", "0..5"],
    );
}

#[test]
fn duplicated_output_dof_is_rejected() {
    let dir = tiny(
        "output_dup",
        "model.toml",
        &edit(TOML, "outputs = [2, 3]", "outputs = [2, 3, 2]"),
    );
    let e = read_err(&dir);
    assert!(matches!(e, Error::InvalidSetting(_)), "{e:?}");
    says(&e, &["model.toml", "outputs", "DoF 2", "twice"]);
}

#[test]
fn empty_or_reversed_band_is_rejected() {
    for (case, band) in [
        ("empty", "[5.0, 5.0]"),
        ("reversed", "[10.0, 1.0]"),
        ("negative", "[-1.0, 10.0]"),
    ] {
        let dir = tiny(
            &format!("band_{case}"),
            "model.toml",
            &edit(TOML, "[0.0, 100.0]", band),
        );
        let e = read_err(&dir);
        assert!(matches!(e, Error::InvalidSetting(_)), "{case}: {e:?}");
        says(&e, &["model.toml", "band_hz", "f_lo < f_hi"]);
    }
}

// ---------------------------------------------------------------------------------------------
// Bad inputs: nodes, dofs_per_node, damping

#[test]
fn nodes_with_wrong_header_are_rejected() {
    let dir = tiny("nodes_header", "nodes.csv", "X;Y;Z\n0,0,0\n1,0,0\n");
    let e = read_err(&dir);
    assert!(
        matches!(&e, Error::Parse { path, line: 1, .. } if path.ends_with("nodes.csv")),
        "{e:?}"
    );
    says(&e, &["nodes.csv:1:", "x,y,z"]);
}

#[test]
fn nodes_with_a_bad_number_name_the_line() {
    let dir = tiny("nodes_number", "nodes.csv", "x,y,z\n0,0,0\n1,zero,0\n");
    let e = read_err(&dir);
    assert!(
        matches!(&e, Error::Parse { path, line: 3, .. } if path.ends_with("nodes.csv")),
        "{e:?}"
    );
    says(&e, &["nodes.csv:3:", "zero"]);
}

#[test]
fn node_count_must_match_n() {
    let dir = tiny("nodes_count", "nodes.csv", "x,y,z\n0,0,0\n1,0,0\n2,0,0\n");
    let e = read_err(&dir);
    assert!(matches!(e, Error::InvalidModel(_)), "{e:?}");
    says(&e, &["nodes", "3 nodes", "N = 6"]);
}

#[test]
fn four_dofs_per_node_are_rejected() {
    let dir = tiny(
        "dpn4",
        "model.toml",
        &edit(TOML, "dofs_per_node = 3", "dofs_per_node = 4"),
    );
    let e = read_err(&dir);
    assert!(matches!(e, Error::InvalidModel(_)), "{e:?}");
    says(&e, &["dofs_per_node = 4", "3", "6"]);
}

#[test]
fn negative_rayleigh_beta_is_rejected() {
    let dir = tiny(
        "beta_neg",
        "model.toml",
        &edit(TOML, "beta = 1e-5", "beta = -1e-5"),
    );
    let e = read_err(&dir);
    assert!(matches!(e, Error::InvalidModel(_)), "{e:?}");
    says(&e, &["model.toml", "rayleigh", "beta = -0.00001", ">= 0"]);
}

// ---------------------------------------------------------------------------------------------
// Writing

#[test]
fn write_into_a_non_empty_directory_fails_and_leaves_it_untouched() {
    let parent = scratch("write_nonempty");
    let dir = parent.join("out");
    std::fs::create_dir(&dir).expect("mkdir");
    put(&dir, "keep.txt", "precious");
    let model = random_model(9, 2, 5, Damping::None);
    let e = model_dir::write(&dir, &model, &random_scene(9))
        .expect_err("must refuse a non-empty directory");
    assert!(matches!(e, Error::InvalidSetting(_)), "{e:?}");
    says(&e, &["out", "not empty"]);
    let names: Vec<_> = std::fs::read_dir(&dir)
        .expect("list")
        .map(|e| e.expect("entry").file_name())
        .collect();
    assert_eq!(names, ["keep.txt"]);
    assert_eq!(
        std::fs::read_to_string(dir.join("keep.txt")).expect("read"),
        "precious"
    );
    assert!(tmp_siblings(&parent, "out").is_empty());
}

#[test]
fn write_into_an_existing_empty_directory_works() {
    let dir = scratch("write_empty_existing");
    let model = random_model(9, 2, 5, Damping::None);
    model_dir::write(&dir, &model, &random_scene(9)).expect("an empty directory may be reused");
    let (back, _, _) = model_dir::read(&dir).expect("read back");
    assert_same_model(&model, &back);
}

#[test]
fn failed_write_leaves_no_directory_behind() {
    // A model that cannot be written: a NaN in K, bypassing Model::new (fields are public).
    let parent = scratch("write_fails");
    let mut model = random_model(9, 2, 5, Damping::None);
    let mut k = crate::common::dense(&model.stiffness);
    k[(8, 8)] = f64::NAN;
    model.stiffness = sparse(&k);
    let dir = parent.join("out");
    let e = model_dir::write(&dir, &model, &random_scene(9)).expect_err("writing a NaN must fail");
    assert!(matches!(e, Error::InvalidModel(_)), "{e:?}");
    says(&e, &["K.mtx", "NaN"]);
    assert!(!dir.exists(), "a partial {} was left behind", dir.display());
    assert!(
        tmp_siblings(&parent, "out").is_empty(),
        "temporary directory left behind"
    );
}

#[test]
fn atomic_write_dir_removes_the_temporary_directory_on_error() {
    let parent = scratch("write_atomically");
    let dir = parent.join("rom");
    let e = atomic::write_dir(&dir, |tmp| {
        std::fs::write(tmp.join("half.mtx"), "%%MatrixMarket").expect("write into tmp");
        std::fs::create_dir(tmp.join("sub")).expect("mkdir in tmp");
        Err(Error::InvalidSetting("injected failure".into()))
    })
    .expect_err("the fill error must propagate");
    says(&e, &["injected failure"]);
    assert!(!dir.exists());
    assert!(
        tmp_siblings(&parent, "rom").is_empty(),
        "temporary directory left behind"
    );
    // The same for an existing empty target: it stays, empty.
    std::fs::create_dir(&dir).expect("mkdir");
    let _ = atomic::write_dir(&dir, |_| Err(Error::InvalidSetting("again".into())));
    assert!(dir.is_dir() && std::fs::read_dir(&dir).expect("list").next().is_none());
    assert!(tmp_siblings(&parent, "rom").is_empty());
    // And success renames the temporary directory to the final name.
    std::fs::remove_dir(&dir).expect("rmdir");
    atomic::write_dir(&dir, |tmp| {
        std::fs::write(tmp.join("a"), "1").map_err(|e| Error::io(tmp, e))
    })
    .expect("ok");
    assert_eq!(std::fs::read_to_string(dir.join("a")).expect("read"), "1");
    assert!(tmp_siblings(&parent, "rom").is_empty());
}
