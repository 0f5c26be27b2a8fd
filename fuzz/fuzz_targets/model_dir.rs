//! The model directory (`model.toml` + matrices + `nodes.csv` + the import's DoF lists), from
//! one input in the archive format of the shared code (`=== NAME` sections). On success the
//! model re-validates: the scene fits N, and writing the directory and reading it back gives
//! the same matrices bit-exactly. Memory is bounded by the input, except a coupled
//! directory's dense blocks (below).
#![no_main]

use libfuzzer_sys::fuzz_target;
use sparsemor::io::model_dir;
use sparsemor_fuzz::{check_bound, declared_in, input_bytes, measured, unpack, DECLARED_MAX};

const NAMES: &[&str] = &[
    "model.toml",
    "M.mtx",
    "K.mtx",
    "D.mtx",
    "M.mtx.gz",
    "K.mtx.gz",
    "nodes.csv",
    "dofs.csv",
    "removed.csv",
];

fuzz_target!(|data: &[u8]| {
    let (dir, files) = unpack(data, NAMES);
    let declared = declared_in(&files, false);
    if declared > DECLARED_MAX {
        return;
    }
    let (result, peak) = measured(|| model_dir::read(dir.path()));
    // a coupled directory's dense blocks grow with its node sets, not with the input's bytes:
    // they are bounded by `coupled::MAX_FILL_ENTRIES` and `MAX_ELIMINATION_ENTRIES`
    // (docs/design.md §3.11), stated rather than fuzzed
    let coupled = model_dir::read_manifest(dir.path()).is_ok_and(|m| {
        !m.remote_points.is_empty()
            || m.scene.input_matrix.is_some()
            || m.scene.output_matrix.is_some()
    });
    if !coupled {
        check_bound("model_dir::read", peak, input_bytes(&files), declared);
    }
    let Ok((model, scene, _)) = result else {
        return;
    };
    scene
        .validate(model.n(), "scene")
        .expect("the scene read fits the model");
    let out = dir.path().join("back");
    model_dir::write(&out, &model, &scene).expect("write back");
    let (again, scene2, _) = model_dir::read(&out).expect("read back");
    assert_eq!(scene2.inputs, scene.inputs);
    assert_eq!(scene2.outputs, scene.outputs);
    for (a, b) in [
        (&model.mass, &again.mass),
        (&model.stiffness, &again.stiffness),
    ] {
        assert_eq!(a.symbolic().col_ptr(), b.symbolic().col_ptr());
        assert_eq!(a.symbolic().row_idx(), b.symbolic().row_idx());
        assert!(a
            .val()
            .iter()
            .zip(b.val())
            .all(|(x, y)| x.to_bits() == y.to_bits()));
    }
});
