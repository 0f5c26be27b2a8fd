//! The importers (`io::import::read`: ANSYS `.full`, ANSYS APDL-Math Matrix Market or
//! Harwell–Boeing + DoF mapping vector + node table, Abaqus `*MATRIX OUTPUT` + `.inp` deck,
//! Nastran OP4 + DoF map), from one input in the
//! archive format of the shared code; the format is detected from the files' content as the
//! command does. On success the import re-validates: one DoF-map entry per DoF, nodes (if
//! any) matching N, and `into_model` accepts it (a valid §1 model).
#![no_main]

use libfuzzer_sys::fuzz_target;
use sparsemor::io::import;
use sparsemor_fuzz::{check_bound, declared_in, input_bytes, measured, unpack, DECLARED_MAX};

const NAMES: &[&str] = &[
    "file.full",
    "K.mtx",
    "M.mtx",
    "rotor_STIF1.mtx",
    "rotor_MASS1.mtx",
    "rotor.inp",
    "mapping.txt",
    "nodes.txt",
    "K.hb",
    "M.hb",
    "model.op4",
    "dofmap.txt",
];

fuzz_target!(|data: &[u8]| {
    let (_dir, files) = unpack(data, NAMES);
    if files.is_empty() {
        return;
    }
    let declared = declared_in(&files, false);
    if declared > DECLARED_MAX {
        return;
    }
    let (result, peak) = measured(|| import::read(&files));
    check_bound("import::read", peak, input_bytes(&files), declared);
    let Ok(imported) = result else {
        return;
    };
    let n = imported.n();
    for a in [&imported.mass, &imported.stiffness] {
        assert_eq!((a.nrows(), a.ncols()), (n, n), "one DoF-map entry per DoF");
        assert!(
            a.val().iter().all(|v| v.is_finite()),
            "non-finite matrix entry"
        );
    }
    if let Some(nodes) = &imported.nodes {
        assert_eq!(
            nodes.len() * imported.dofs_per_node,
            n,
            "nodes x DoFs per node != N"
        );
    }
    let (model, _) = match imported.into_model("fuzz".into()) {
        Ok(m) => m,
        Err(_) => return,
    };
    assert_eq!(model.n(), n);
});
