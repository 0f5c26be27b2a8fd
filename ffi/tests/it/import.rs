//! `sparsemor_model_from_files` and `sparsemor_model_dof` on the real ANSYS file of
//! `../shared/data/ansys_example_full` (called from Rust exactly as C would), and their bad
//! input.

use crate::common::*;
use sparsemor_ffi::*;
use std::ffi::CString;
use std::path::Path;
use std::ptr::null_mut;

fn ansys_full() -> Option<CString> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/ansys_example_full/file.full");
    if p.exists() {
        Some(CString::new(p.to_str().unwrap()).unwrap())
    } else {
        println!("note: {} not found; skipped", p.display());
        None
    }
}

fn from_files(
    paths: &[&CString],
    scale: f64,
    units: u32,
) -> (SparsemorStatus, *mut SparsemorModel) {
    let ptrs: Vec<*const std::ffi::c_char> = paths.iter().map(|c| c.as_ptr()).collect();
    let mut h: *mut SparsemorModel = std::ptr::dangling_mut();
    let st = unsafe { sparsemor_model_from_files(ptrs.as_ptr(), ptrs.len(), scale, units, &mut h) };
    if st != SparsemorStatus::Ok {
        assert!(h.is_null(), "model_out not set to NULL on failure");
    }
    (st, h)
}

fn dof(h: *const SparsemorModel, i: usize) -> Result<(u64, u32), String> {
    let (mut node, mut dir) = (0u64, 0u32);
    match unsafe { sparsemor_model_dof(h, i, &mut node, &mut dir) } {
        SparsemorStatus::Ok => Ok((node, dir)),
        _ => Err(last_error()),
    }
}

/// The `.full` file: 900 free DoFs (63 constrained removed), node numbers ascending with x, y, z
/// each, and a reduction runs on the imported model.
#[test]
fn ansys_full_imports_with_its_dof_map() {
    let Some(full) = ansys_full() else { return };
    let (st, h) = from_files(&[&full], 1.0, SPARSEMOR_UNITS_AS_IS);
    assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
    let mut n = 0usize;
    assert_eq!(unsafe { sparsemor_model_n(h, &mut n) }, SparsemorStatus::Ok);
    assert_eq!(n, 900);
    let mut prev = 0u64;
    for i in 0..n {
        let (node, dir) = dof(h, i).unwrap();
        assert_eq!(dir, (i % 3) as u32 + 1, "DoF {i}");
        assert!(
            node >= prev && node > 0,
            "DoF {i}: node {node} after {prev}"
        );
        prev = node;
    }
    assert!(dof(h, n).unwrap_err().contains("0..899"));
    // a SEREP of 4 modes at the first node's three DoFs runs on it
    let io = [0usize, 1, 2];
    let st = unsafe { sparsemor_model_set_scene(h, io.as_ptr(), 3, io.as_ptr(), 3, 0.0, 12000.0) };
    assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
    let o = options();
    let mut rom: *mut SparsemorRom = null_mut();
    unsafe {
        assert_eq!(sparsemor_options_set_serep_modes(o, 3), SparsemorStatus::Ok);
        let st = sparsemor_reduce_serep(h, o, None, null_mut(), &mut rom);
        assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
        let mut order = 0usize;
        assert_eq!(sparsemor_rom_order(rom, &mut order), SparsemorStatus::Ok);
        assert_eq!(order, 3);
        sparsemor_rom_free(rom);
        sparsemor_options_free(o);
        sparsemor_model_free(h);
    }
}

#[test]
fn bad_imports_are_clear_errors() {
    let missing = CString::new("/nonexistent/dir/file.full").unwrap();
    let (st, _) = from_files(&[&missing], 1.0, 0);
    assert_eq!(st, SparsemorStatus::Io);
    assert!(
        last_error().contains("/nonexistent/dir/file.full"),
        "{}",
        last_error()
    );
    let Some(full) = ansys_full() else { return };
    let (st, _) = from_files(&[&full], 1.0, 7);
    assert_eq!(st, SparsemorStatus::InvalidArgument);
    assert!(last_error().contains("units = 7"), "{}", last_error());
    let (st, _) = from_files(&[&full], -1.0, 0);
    assert_eq!(st, SparsemorStatus::InvalidArgument);
    assert!(last_error().contains("stiffness scale"), "{}", last_error());
    let mut h: *mut SparsemorModel = null_mut();
    let st = unsafe { sparsemor_model_from_files(std::ptr::null(), 1, 1.0, 0, &mut h) };
    assert_eq!(st, SparsemorStatus::NullPointer);
    let ptrs = [std::ptr::null::<std::ffi::c_char>()];
    let st = unsafe { sparsemor_model_from_files(ptrs.as_ptr(), 1, 1.0, 0, &mut h) };
    assert_eq!(st, SparsemorStatus::NullPointer);
    assert!(last_error().contains("paths[0]"), "{}", last_error());
    let st = unsafe { sparsemor_model_from_files(ptrs.as_ptr(), 0, 1.0, 0, &mut h) };
    assert_eq!(st, SparsemorStatus::InvalidArgument);
}

/// A model from `sparsemor_model_new` without nodes has no DoF map, and the error says so.
#[test]
fn dof_map_of_models_built_from_arrays() {
    let h = chain_model(6);
    let msg = dof(h, 0).unwrap_err();
    assert!(msg.contains("no DoF map"), "{msg}");
    unsafe { sparsemor_model_free(h) };
}

/// A model directory written by the library reads back with its scene and node-based DoF
/// names; a directory that is not one is refused by name.
#[test]
fn model_directory_reads_with_its_scene() {
    use sparsemor::fe::{bar_model, paper_scene, BoxSpec};
    let spec = BoxSpec {
        elements: [1, 1, 8],
        ..BoxSpec::paper_bar()
    };
    let (model, scene) = (bar_model(&spec).unwrap(), paper_scene(&spec));
    let dir = scratch("model_from_dir");
    let _ = std::fs::remove_dir_all(&dir);
    sparsemor::io::model_dir::write(&dir, &model, &scene).unwrap();
    let path = CString::new(dir.to_str().unwrap()).unwrap();
    let mut h: *mut SparsemorModel = std::ptr::dangling_mut();
    let st = unsafe { sparsemor_model_from_dir(path.as_ptr(), &mut h) };
    assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
    let mut n = 0usize;
    assert_eq!(unsafe { sparsemor_model_n(h, &mut n) }, SparsemorStatus::Ok);
    assert_eq!(n, model.n());
    // node-based names: DoF 3k + d is node k, direction d + 1
    assert_eq!(dof(h, 7).unwrap(), (2, 2));
    // the scene is set: a reduction runs without sparsemor_model_set_scene
    let mut o: *mut SparsemorOptions = null_mut();
    assert_eq!(
        unsafe { sparsemor_options_new(&mut o) },
        SparsemorStatus::Ok
    );
    let freqs = [200.0, 600.0];
    unsafe {
        assert_eq!(
            sparsemor_options_set_reference_frequencies(o, freqs.as_ptr(), 2),
            SparsemorStatus::Ok
        );
        assert_eq!(
            sparsemor_options_set_interface_outputs_plus(o, 2),
            SparsemorStatus::Ok
        );
    }
    let mut rom: *mut SparsemorRom = null_mut();
    let st = unsafe { sparsemor_reduce_linefit(h, o, None, null_mut(), &mut rom) };
    assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
    let mut order = 0usize;
    assert_eq!(
        unsafe { sparsemor_rom_order(rom, &mut order) },
        SparsemorStatus::Ok
    );
    assert_eq!(order, scene.outputs.len() + 2);
    unsafe {
        sparsemor_rom_free(rom);
        sparsemor_options_free(o);
        sparsemor_model_free(h);
    }
    // not a model directory: the message names model.toml
    let empty = scratch("model_from_dir_empty");
    std::fs::create_dir_all(&empty).unwrap();
    let path = CString::new(empty.to_str().unwrap()).unwrap();
    let st = unsafe { sparsemor_model_from_dir(path.as_ptr(), &mut h) };
    assert_ne!(st, SparsemorStatus::Ok);
    assert!(h.is_null());
    assert!(last_error().contains("model.toml"), "{}", last_error());
    let st = unsafe { sparsemor_model_from_dir(std::ptr::null(), &mut h) };
    assert_eq!(st, SparsemorStatus::NullPointer);
}
