//! Craig–Bampton through the C ABI: the paper bar reduced by `sparsemor_reduce_craig_bampton`
//! equals the library's ROM bit for bit (one thread), its report and fixed-interface
//! frequencies come through, and bad settings are refused with their status.

use crate::common::{last_error, model_with_nodes, options, rom_matrix};
use sparsemor::body::Body;
use sparsemor::fe::{bar_model, paper_scene, BoxSpec};
use sparsemor::reduce::craig_bampton::{self, CraigBamptonOptions};
use sparsemor::reduce::linefit::Interface;
use sparsemor_ffi::*;
use std::ptr::null_mut;

#[test]
fn bar_craig_bampton_equals_the_library() {
    let spec = BoxSpec::paper_bar();
    let (model, scene) = (bar_model(&spec).unwrap(), paper_scene(&spec));
    let h = model_with_nodes(&model, 1e-5);
    unsafe {
        let io = &scene.inputs;
        assert_eq!(
            sparsemor_model_set_scene(h, io.as_ptr(), io.len(), io.as_ptr(), io.len(), 0.0, 1000.0),
            SparsemorStatus::Ok
        );
    }
    let o = options();
    let mut rom = null_mut();
    unsafe {
        assert_eq!(sparsemor_options_set_threads(o, 1), SparsemorStatus::Ok);
        // no mode count yet
        assert_eq!(
            sparsemor_reduce_craig_bampton(h, o, None, null_mut(), &mut rom),
            SparsemorStatus::InvalidArgument
        );
        assert!(last_error().contains("sparsemor_options_set_craig_bampton_modes"));
        assert_eq!(
            sparsemor_options_set_craig_bampton_modes(o, 4),
            SparsemorStatus::Ok
        );
        // default boundary = the outputs: three nodes on one edge do not hold the free bar
        assert_eq!(
            sparsemor_reduce_craig_bampton(h, o, None, null_mut(), &mut rom),
            SparsemorStatus::InvalidArgument
        );
        assert!(rom.is_null());
        assert!(last_error().contains("non-collinear"), "{}", last_error());
        assert_eq!(
            sparsemor_options_set_interface_outputs_plus(o, 1),
            SparsemorStatus::Ok
        );
        assert_eq!(
            sparsemor_reduce_craig_bampton(h, o, None, null_mut(), &mut rom),
            SparsemorStatus::Ok,
            "{}",
            last_error()
        );
    }
    let mut opts = CraigBamptonOptions::new(Interface::OutputsPlus(1), 4, 1000.0);
    opts.threads = 1;
    // the C ABI runs in a one-thread pool: so does the reference
    let lib = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| craig_bampton::reduce(&Body::new(&model).unwrap(), &scene, &opts))
        .unwrap();
    for (which, mat) in [
        (SPARSEMOR_MATRIX_MR, &lib.mr),
        (SPARSEMOR_MATRIX_KR, &lib.kr),
        (SPARSEMOR_MATRIX_DR, &lib.dr),
        (SPARSEMOR_MATRIX_BR, &lib.br),
        (SPARSEMOR_MATRIX_CR, &lib.cr),
    ] {
        let (r, c, v) = rom_matrix(rom, which);
        assert_eq!((r, c), (mat.nrows(), mat.ncols()));
        for j in 0..c {
            for i in 0..r {
                assert_eq!(
                    v[i + j * r].to_bits(),
                    mat[(i, j)].to_bits(),
                    "matrix {which} ({i}, {j})"
                );
            }
        }
    }
    let (mut method, mut rep) = (u32::MAX, SparsemorCraigBamptonReport::default());
    let mut need = 0;
    unsafe {
        assert_eq!(sparsemor_rom_method(rom, &mut method), SparsemorStatus::Ok);
        assert_eq!(method, SPARSEMOR_METHOD_CRAIG_BAMPTON);
        assert_eq!(
            sparsemor_rom_craig_bampton_report(rom, &mut rep),
            SparsemorStatus::Ok
        );
        assert_eq!(
            sparsemor_rom_fixed_interface_frequencies(rom, null_mut(), 0, &mut need),
            SparsemorStatus::Ok
        );
    }
    let mut f = vec![0.0; need];
    unsafe {
        assert_eq!(
            sparsemor_rom_fixed_interface_frequencies(rom, f.as_mut_ptr(), need, null_mut()),
            SparsemorStatus::Ok
        );
    }
    let cb = lib.craig_bampton().unwrap();
    assert_eq!((rep.boundary, rep.modes, rep.cholesky), (10, 4, 1));
    assert!(rep.pivot_ratio.is_nan());
    assert_eq!(rep.static_residual, cb.static_residual);
    assert_eq!(f, cb.fixed_interface_hz);
    println!("C ABI Craig–Bampton: {rep:?}, fixed-interface {f:?} Hz");
    unsafe {
        let mut c = 0.0;
        assert_eq!(
            sparsemor_rom_serep_cond(rom, &mut c),
            SparsemorStatus::NotAvailable
        );
        assert_eq!(sparsemor_rom_free(rom), SparsemorStatus::Ok);
        assert_eq!(sparsemor_options_free(o), SparsemorStatus::Ok);
        assert_eq!(sparsemor_model_free(h), SparsemorStatus::Ok);
    }
}
