//! Regression tests for what the fuzz targets (`fuzz/`, issue 13) found: each input that made
//! a target fail, reduced by hand, with the behaviour now required.

use sparsemor::io::matrix_market::{parse_bytes, MtxData};
use sparsemor::Error;
use std::path::Path;

/// `mtx`: duplicate entries are summed (FE assembly), and two finite values can sum to Inf;
/// the reader returned a matrix holding Inf although it refuses `inf` and `1e400` literals.
#[test]
fn duplicate_entries_whose_sum_overflows_are_refused() {
    for (symmetry, entries) in [
        ("general", "1 1 1e308\n1 1 1e308\n"),
        ("general", "2 1 -1.7e308\n2 1 -1.7e308\n"),
        // a symmetric file: the two stored (2, 1) entries sum, and so do their mirrors
        ("symmetric", "2 1 1e308\n2 1 1e308\n"),
    ] {
        let text = format!("%%MatrixMarket matrix coordinate real {symmetry}\n2 2 2\n{entries}");
        match parse_bytes(text.as_bytes(), Path::new("dup.mtx")) {
            Err(Error::Parse { msg, .. }) => {
                assert!(
                    msg.contains("duplicate entries") && msg.contains("not finite"),
                    "{msg}"
                )
            }
            other => panic!("{symmetry} {entries:?}: expected a parse error, got {other:?}"),
        }
    }
    // finite sums are still summed
    let text = "%%MatrixMarket matrix coordinate real general\n1 1 2\n1 1 1e308\n1 1 -1e308\n";
    let m = parse_bytes(text.as_bytes(), Path::new("dup.mtx")).unwrap();
    match m.data {
        MtxData::Sparse(a) => assert_eq!(a.val(), &[0.0]),
        MtxData::Dense(_) => panic!("a coordinate file gives a sparse matrix"),
    }
}

/// `rom_dir`: `rom.toml` with a `dofs` list shorter than `order` (or a V of the wrong shape)
/// was read into a ROM whose `dofs[i]` readers index out of range.
#[test]
fn rom_directory_with_inconsistent_dof_list_or_basis_is_refused() {
    use sparsemor::eigen::EigenOptions;
    use sparsemor::fe::{bar_model, paper_scene, BoxSpec};
    use sparsemor::reduce::serep::{self, ModeChoice, SerepOptions};
    let spec = BoxSpec {
        elements: [1, 1, 4],
        ..BoxSpec::paper_bar()
    };
    let (model, scene) = (bar_model(&spec).unwrap(), paper_scene(&spec));
    let body = sparsemor::body::Body::new(&model).unwrap();
    let o = SerepOptions {
        modes: ModeChoice::LowestDeformation(scene.outputs.len()),
        retain: None,
        keep_basis: true,
        eigen: EigenOptions::for_band(scene.band_hz[1]),
    };
    let rom = serep::reduce(&body, &scene, &o, None).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let good = dir.path().join("rom");
    sparsemor::io::rom_dir::write(&good, &rom).unwrap();
    sparsemor::io::rom_dir::read(&good).unwrap();
    let toml = std::fs::read_to_string(good.join("rom.toml")).unwrap();
    let dofs_line = toml.lines().find(|l| l.starts_with("dofs = ")).unwrap();
    std::fs::write(good.join("rom.toml"), toml.replace(dofs_line, "dofs = [0]")).unwrap();
    let e = sparsemor::io::rom_dir::read(&good).unwrap_err().to_string();
    assert!(
        e.contains("`dofs` lists 1 DoFs") && e.contains("but order"),
        "{e}"
    );
    // V with one column too few
    std::fs::write(good.join("rom.toml"), &toml).unwrap();
    let v = sparsemor::io::matrix_market::read_dense(&good.join("V.mtx")).unwrap();
    let cut = v.as_ref().subcols(0, v.ncols() - 1);
    std::fs::remove_file(good.join("V.mtx")).unwrap();
    sparsemor::io::matrix_market::write_array(&good.join("V.mtx"), cut).unwrap();
    let e = sparsemor::io::rom_dir::read(&good).unwrap_err().to_string();
    assert!(
        e.contains("V.mtx is") && e.contains("full_n x order"),
        "{e}"
    );
}

/// `model_dir`: a `model.toml` naming `/dev/zero` (or any device or directory) as a matrix or
/// node file made the reader allocate until the process was killed.
#[test]
fn model_files_must_be_regular_files() {
    use sparsemor::fe::{bar_model, paper_scene, BoxSpec};
    let spec = BoxSpec {
        elements: [1, 1, 2],
        ..BoxSpec::paper_bar()
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().join("m");
    sparsemor::io::model_dir::write(&d, &bar_model(&spec).unwrap(), &paper_scene(&spec)).unwrap();
    let toml = std::fs::read_to_string(d.join("model.toml")).unwrap();
    for (from, to) in [
        ("mass = \"M.mtx\"", "mass = \"/dev/zero\""),
        ("nodes = \"nodes.csv\"", "nodes = \".\""),
    ] {
        assert!(toml.contains(from), "{toml}");
        std::fs::write(d.join("model.toml"), toml.replace(from, to)).unwrap();
        let e = sparsemor::io::model_dir::read(&d).unwrap_err().to_string();
        assert!(e.contains("not a regular file"), "{to}: {e}");
    }
}
