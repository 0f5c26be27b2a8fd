//! A general scene through the C ABI (docs/design.md §3.11, §6): a distributing remote point,
//! a general column of B and a general row of C on a small bar grounded at its base. An exact
//! line-fit (interface size n = 2·p·z) reproduces C A⁻¹ B of the original model, computed
//! here by dense solves with the point's row built from its definition; the basis comes back
//! in the original DoFs (C V = Cr, Vᵀ B = Br); recoupling starts from the original model; bad
//! arguments are refused by name.

use crate::common::*;
use faer::c64;
use faer::linalg::solvers::Solve;
use faer::Mat;
use sparsemor::fe::{bar_model, BoxSpec};
use sparsemor::model::Model;
use sparsemor::sparse::Csc;
use sparsemor_ffi::*;
use std::ptr::{null, null_mut};

const BETA: f64 = 1e-5;
const GROUND: f64 = 1e8;

/// The small bar (N = 90, 30 nodes) with ground springs on its base's DoFs, so the body is
/// constrained and H is the ROM's whole transfer function.
fn grounded_bar() -> Model {
    let mut model = bar_model(&BoxSpec::small()).unwrap();
    let nodes = model.nodes.clone().unwrap();
    let n = model.n();
    let dense = model.stiffness.as_ref().to_dense();
    let mut k = Mat::<f64>::from_fn(n, n, |i, j| dense[(i, j)]);
    for (i, x) in nodes.iter().enumerate() {
        if x[2] < 1e-9 {
            for d in 0..3 {
                k[(3 * i + d, 3 * i + d)] += GROUND;
            }
        }
    }
    model.stiffness = csc_of(&k);
    model
}

fn csc_of(a: &Mat<f64>) -> Csc {
    let (mut cp, mut ri, mut v) = (vec![0], vec![], vec![]);
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            if a[(i, j)] != 0.0 {
                ri.push(i);
                v.push(a[(i, j)]);
            }
        }
        cp.push(ri.len());
    }
    sparsemor::sparse::from_parts(a.nrows(), a.ncols(), cp, ri, v)
}

/// Owned arrays of a `SparsemorSparse` (columns of `dense`, nonzeros only).
struct Sparse {
    nrows: usize,
    ncols: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
}

impl Sparse {
    fn from_dense(a: &Mat<f64>) -> Self {
        let c = csc_of(a);
        Sparse {
            nrows: a.nrows(),
            ncols: a.ncols(),
            col_ptr: c.symbolic().col_ptr().to_vec(),
            row_idx: c.symbolic().row_idx().to_vec(),
            values: c.val().to_vec(),
        }
    }
    fn view(&self) -> SparsemorSparse {
        SparsemorSparse {
            nrows: self.nrows,
            ncols: self.ncols,
            nnz: self.values.len(),
            col_ptr: self.col_ptr.as_ptr(),
            row_idx: self.row_idx.as_ptr(),
            values: self.values.as_ptr(),
        }
    }
}

fn part(dofs: &[usize], points: &[usize], matrix: Option<&SparsemorSparse>) -> SparsemorScenePart {
    SparsemorScenePart {
        dofs: if dofs.is_empty() {
            null()
        } else {
            dofs.as_ptr()
        },
        n_dofs: dofs.len(),
        point_dofs: if points.is_empty() {
            null()
        } else {
            points.as_ptr()
        },
        n_point_dofs: points.len(),
        matrix: matrix.map_or(null(), |m| m as *const _),
    }
}

/// `sparsemor_model_add_remote_point` on `h` (no weights given when `weights` is empty): its
/// status and the index it wrote.
fn add_point(
    h: *mut SparsemorModel,
    kind: u32,
    at: &[f64; 3],
    nodes: &[usize],
    weights: &[f64],
) -> (SparsemorStatus, usize) {
    let mut index = usize::MAX;
    let w = if weights.is_empty() {
        null()
    } else {
        weights.as_ptr()
    };
    let st = unsafe {
        sparsemor_model_add_remote_point(
            h,
            kind,
            at.as_ptr(),
            nodes.as_ptr(),
            nodes.len(),
            w,
            &mut index,
        )
    };
    (st, index)
}

/// Row `dir` of a distributing point with equal weights, from its definition: the point's
/// motion x = A⁻¹ Σ G(r_i)ᵀ u_i with A = Σ G(r_i)ᵀ G(r_i), G(r) = [I, −[r]×].
fn distributing_row(
    nodes: &[[f64; 3]],
    set: &[usize],
    at: [f64; 3],
    n: usize,
    dir: usize,
) -> Mat<f64> {
    let g = |r: [f64; 3]| {
        let mut g = Mat::<f64>::zeros(3, 6);
        for d in 0..3 {
            g[(d, d)] = 1.0;
        }
        // u = t + θ × r: the θ part is −[r]× θ
        g[(0, 4)] = r[2];
        g[(0, 5)] = -r[1];
        g[(1, 3)] = -r[2];
        g[(1, 5)] = r[0];
        g[(2, 3)] = r[1];
        g[(2, 4)] = -r[0];
        g
    };
    let offsets: Vec<[f64; 3]> = set
        .iter()
        .map(|&i| std::array::from_fn(|d| nodes[i][d] - at[d]))
        .collect();
    let mut a = Mat::<f64>::zeros(6, 6);
    for &r in &offsets {
        let gi = g(r);
        for i in 0..6 {
            for j in 0..6 {
                a[(i, j)] += (0..3).map(|d| gi[(d, i)] * gi[(d, j)]).sum::<f64>();
            }
        }
    }
    let e = Mat::<f64>::from_fn(6, 1, |i, _| f64::from(i == dir));
    let w = a.partial_piv_lu().solve(&e); // A symmetric: e_dirᵀ A⁻¹ = (A⁻¹ e_dir)ᵀ
    let mut row = Mat::<f64>::zeros(1, n);
    for (&i, &r) in set.iter().zip(&offsets) {
        let gi = g(r);
        for d in 0..3 {
            row[(0, 3 * i + d)] = (0..6).map(|k| w[(k, 0)] * gi[(d, k)]).sum();
        }
    }
    row
}

/// H(iω) = C (K + iωβK − ω²M)⁻¹ B, dense.
fn dense_h(model: &Model, b: &Mat<f64>, c: &Mat<f64>, f: f64) -> Mat<c64> {
    dense_h_structural(model, None, b, c, f)
}

/// H(iω) = C (K + i(ωβK + H) − ω²M)⁻¹ B with a dense structural damping H (none: 0).
fn dense_h_structural(
    model: &Model,
    h: Option<&Mat<f64>>,
    b: &Mat<f64>,
    c: &Mat<f64>,
    f: f64,
) -> Mat<c64> {
    let w = 2.0 * std::f64::consts::PI * f;
    let (k, m) = (
        model.stiffness.as_ref().to_dense(),
        model.mass.as_ref().to_dense(),
    );
    let a = Mat::<c64>::from_fn(k.nrows(), k.ncols(), |i, j| {
        let hij = h.map_or(0.0, |h| h[(i, j)]);
        c64::new(k[(i, j)] - w * w * m[(i, j)], w * BETA * k[(i, j)] + hij)
    });
    let bc = Mat::<c64>::from_fn(b.nrows(), b.ncols(), |i, j| c64::new(b[(i, j)], 0.0));
    let x = a.partial_piv_lu().solve(&bc);
    Mat::<c64>::from_fn(c.nrows(), c.ncols(), |i, j| c64::new(c[(i, j)], 0.0)) * x
}

/// The scene of these tests: inputs = (point 0's x, B's column); outputs = (DoF 70, point 0's
/// x, C's row), as dense B (N×2) and C (3×N) of the original model.
struct Fixture {
    model: Model,
    h: *mut SparsemorModel,
    b_col: Sparse,
    c_row: Sparse,
    b: Mat<f64>,
    c: Mat<f64>,
}

const OUT_DOF: usize = 70;

fn fixture() -> Fixture {
    let model = grounded_bar();
    let n = model.n();
    let nodes = model.nodes.clone().unwrap();
    let top: Vec<usize> = (0..nodes.len()).filter(|&i| nodes[i][2] > 0.199).collect();
    let at = [0.01, 0.015, 0.21];
    let h = model_with_nodes(&model, BETA);
    let (st, index) = add_point(h, SPARSEMOR_POINT_DISTRIBUTING, &at, &top, &[]);
    assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
    assert_eq!(index, 0);
    // a load pattern over a few DoFs in the middle, and an output row elsewhere
    let mut b1 = Mat::<f64>::zeros(n, 1);
    for (d, v) in [(40, 0.5), (47, -1.25), (55, 2.0), (58, 0.75)] {
        b1[(d, 0)] = v;
    }
    let mut c1 = Mat::<f64>::zeros(1, n);
    for (d, v) in [(30, 1.0), (31, -0.4), (62, 0.3)] {
        c1[(0, d)] = v;
    }
    let wx = distributing_row(&nodes, &top, at, n, 0);
    let b = Mat::from_fn(n, 2, |i, j| if j == 0 { wx[(0, i)] } else { b1[(i, 0)] });
    let c = Mat::from_fn(3, n, |i, j| match i {
        0 => f64::from(j == OUT_DOF),
        1 => wx[(0, j)],
        _ => c1[(0, j)],
    });
    Fixture {
        model,
        h,
        b_col: Sparse::from_dense(&b1),
        c_row: Sparse::from_dense(&c1),
        b,
        c,
    }
}

fn set_scene(fx: &Fixture) -> SparsemorStatus {
    let (bv, cv) = (fx.b_col.view(), fx.c_row.view());
    let inputs = part(&[], &[0], Some(&bv));
    let outputs = part(&[OUT_DOF], &[0], Some(&cv));
    unsafe { sparsemor_model_set_scene_general(fx.h, &inputs, &outputs, 0.0, 3000.0) }
}

#[test]
fn exact_line_fit_reproduces_c_a_inverse_b_of_the_original_model() {
    let fx = fixture();
    assert_eq!(set_scene(&fx), SparsemorStatus::Ok, "{}", last_error());
    let n = fx.model.n();
    let mut count = 0;
    unsafe { sparsemor_model_coordinate_count(fx.h, &mut count) };
    assert_eq!(count, n, "a distributing point adds no DoF");

    // p = 2 inputs, z = 2 frequencies: interface 2·p·z = 8 = 3 outputs + 5
    let freqs = [400.0, 2100.0];
    let o = options();
    unsafe {
        assert_eq!(sparsemor_options_set_threads(o, 1), SparsemorStatus::Ok);
        assert_eq!(
            sparsemor_options_set_reference_frequencies(o, freqs.as_ptr(), 2),
            SparsemorStatus::Ok
        );
        assert_eq!(
            sparsemor_options_set_interface_outputs_plus(o, 5),
            SparsemorStatus::Ok
        );
        assert_eq!(sparsemor_options_set_keep_basis(o, 1), SparsemorStatus::Ok);
    }
    let mut rom = null_mut();
    let st = unsafe { sparsemor_reduce_linefit(fx.h, o, None, null_mut(), &mut rom) };
    assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
    let mut worst: f64 = 0.0;
    for f in freqs {
        let e = rel(&rom_transfer(rom, f), &dense_h(&fx.model, &fx.b, &fx.c, f));
        println!("{f} Hz: ROM vs dense C A^-1 B of the original: {e:.2e}");
        worst = worst.max(e);
    }
    assert!(worst <= 1e-8, "relative difference {worst:e}");
    // and between the reference frequencies the ROM is an approximation, not garbage
    let mid = rel(
        &rom_transfer(rom, 1200.0),
        &dense_h(&fx.model, &fx.b, &fx.c, 1200.0),
    );
    println!("1200 Hz (not a reference): {mid:.2e}");
    assert!(mid < 0.5);

    // ε of the ABI (against the coupled model) agrees
    let (mut e1, mut e2) = ([0.0; 2], [0.0; 2]);
    let st = unsafe {
        sparsemor_rom_transfer_error(
            fx.h,
            rom,
            freqs.as_ptr(),
            2,
            e1.as_mut_ptr(),
            e2.as_mut_ptr(),
        )
    };
    assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
    assert!(e1.iter().all(|&e| e <= 1e-8), "{e1:?}");

    // V in the original DoFs: C V = Cr and Vᵀ B = Br
    let (vr, vc, v) = rom_matrix(rom, SPARSEMOR_MATRIX_V);
    assert_eq!(vr, n);
    let v = col_major(vr, vc, &v);
    let (r, c, cr) = rom_matrix(rom, SPARSEMOR_MATRIX_CR);
    let cr = col_major(r, c, &cr);
    let (r, c, br) = rom_matrix(rom, SPARSEMOR_MATRIX_BR);
    let br = col_major(r, c, &br);
    let dc = (&(&fx.c * &v) - &cr).norm_l2() / cr.norm_l2();
    let db = (&(v.transpose() * &fx.b) - &br).norm_l2() / br.norm_l2();
    println!("C V vs Cr: {dc:.1e}; V^T B vs Br: {db:.1e}");
    assert!(dc <= 1e-12 && db <= 1e-12);

    // the ROM's coordinates are the coupled model's: outputs first, named by kind
    let mut dofs = vec![0usize; vc];
    let mut need = 0;
    unsafe { sparsemor_rom_dofs(rom, dofs.as_mut_ptr(), vc, &mut need) };
    let kinds: Vec<(u32, usize, usize)> = dofs[..3]
        .iter()
        .map(|&d| {
            let (mut k, mut a, mut b) = (u32::MAX, 0, 0);
            let st = unsafe { sparsemor_model_coordinate(fx.h, d, &mut k, &mut a, &mut b) };
            assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
            (k, a, b)
        })
        .collect();
    assert_eq!(
        kinds,
        [
            (SPARSEMOR_COORDINATE_DOF, OUT_DOF, 0),
            (SPARSEMOR_COORDINATE_POINT, 0, 0),
            (SPARSEMOR_COORDINATE_OUTPUT_ROW, 0, 0),
        ]
    );
    // with the DoF scene back, the ROM of the coupled model is refused, not misread
    let io = [OUT_DOF];
    unsafe { sparsemor_model_set_scene(fx.h, io.as_ptr(), 1, io.as_ptr(), 1, 0.0, 100.0) };
    let st = unsafe {
        sparsemor_rom_transfer_error(
            fx.h,
            rom,
            freqs.as_ptr(),
            2,
            e1.as_mut_ptr(),
            e2.as_mut_ptr(),
        )
    };
    refused(st, "the ROM is one of a general scene");

    unsafe {
        sparsemor_rom_free(rom);
        sparsemor_options_free(o);
        sparsemor_model_free(fx.h);
    }
}

#[test]
fn each_call_couples_the_original_model_again() {
    let fx = fixture();
    let n = fx.model.n();
    let count = || {
        let mut c = 0;
        assert_eq!(
            unsafe { sparsemor_model_coordinate_count(fx.h, &mut c) },
            SparsemorStatus::Ok
        );
        c
    };
    // a rigid point on the 6 base nodes: their 18 DoFs leave, the point's 6 enter
    let nodes = fx.model.nodes.clone().unwrap();
    let base: Vec<usize> = (0..nodes.len()).filter(|&i| nodes[i][2] < 1e-9).collect();
    let at = [0.01, 0.015, -0.01];
    let (st, index) = add_point(fx.h, SPARSEMOR_POINT_RIGID, &at, &base, &[]);
    assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
    assert_eq!(index, 1);
    assert_eq!(set_scene(&fx), SparsemorStatus::Ok, "{}", last_error());
    assert_eq!(count(), n - 3 * base.len() + 6);
    let coupled = count();
    // twice: the same coupled model, not a coupling of the coupled one
    assert_eq!(set_scene(&fx), SparsemorStatus::Ok, "{}", last_error());
    assert_eq!(count(), coupled);
    // a failing call keeps the scene it had
    let bad = part(&[n], &[], None);
    let ok = part(&[0], &[], None);
    let st = unsafe { sparsemor_model_set_scene_general(fx.h, &bad, &ok, 0.0, 100.0) };
    assert_eq!(st, SparsemorStatus::InvalidArgument);
    assert_eq!(count(), coupled);
    // the DoF scene returns to the original model
    let io = [OUT_DOF];
    let st = unsafe { sparsemor_model_set_scene(fx.h, io.as_ptr(), 1, io.as_ptr(), 1, 0.0, 100.0) };
    assert_eq!(st, SparsemorStatus::Ok);
    assert_eq!(count(), n);
    let mut nn = 0;
    unsafe { sparsemor_model_n(fx.h, &mut nn) };
    assert_eq!(nn, n);
    unsafe { sparsemor_model_free(fx.h) };
}

#[track_caller]
fn refused(st: SparsemorStatus, needle: &str) {
    let msg = last_error();
    assert_eq!(st, SparsemorStatus::InvalidArgument, "{msg}");
    assert!(msg.contains(needle), "{msg:?} lacks {needle:?}");
    println!("refused: {msg}");
}

#[test]
fn bad_scenes_and_points_are_refused_by_name() {
    let fx = fixture();
    let n = fx.model.n();
    let at = [0.0; 3];
    let add = |kind, nodes: &[usize], weights: &[f64]| add_point(fx.h, kind, &at, nodes, weights).0;
    refused(add(SPARSEMOR_POINT_DISTRIBUTING, &[], &[]), "n_nodes = 0");
    refused(add(7, &[1, 2, 3], &[]), "kind = 7");
    refused(
        add(SPARSEMOR_POINT_DISTRIBUTING, &[1, 2, 300], &[]),
        "nodes[2] = 300",
    );
    refused(
        add(SPARSEMOR_POINT_RIGID, &[1, 2, 3], &[1.0, 1.0, 1.0]),
        "weights: a rigid point",
    );
    refused(
        add(SPARSEMOR_POINT_DISTRIBUTING, &[1, 7, 13], &[1.0, -1.0, 1.0]),
        "weights[1] = -1",
    );
    // the nodes on the edge x = y = 0 lie on one line: no rotation about it is defined
    let nodes = fx.model.nodes.clone().unwrap();
    let edge: Vec<usize> = (0..nodes.len())
        .filter(|&i| nodes[i][0].abs() < 1e-12 && nodes[i][1].abs() < 1e-12)
        .collect();
    assert_eq!(edge.len(), 5);
    let off = [0.05, 0.05, 0.1];
    let (st, _) = add_point(fx.h, SPARSEMOR_POINT_DISTRIBUTING, &off, &edge, &[]);
    refused(st, "lie on one line");
    let st = unsafe {
        sparsemor_model_add_remote_point(fx.h, 0, null(), [0usize].as_ptr(), 1, null(), null_mut())
    };
    assert_eq!(st, SparsemorStatus::NullPointer);

    let ok = part(&[OUT_DOF], &[], None);
    let set = |i: &SparsemorScenePart, o: &SparsemorScenePart| unsafe {
        sparsemor_model_set_scene_general(fx.h, i, o, 0.0, 100.0)
    };
    // point DoF codes
    refused(set(&part(&[], &[6], None), &ok), "inputs.point_dofs[0] = 6");
    // wrong shapes: B with N − 1 rows, C with N + 1 columns (given as B's transpose)
    let short = Sparse::from_dense(&Mat::from_fn(n - 1, 1, |i, _| f64::from(i == 3)));
    let sv = short.view();
    refused(
        set(&part(&[], &[], Some(&sv)), &ok),
        "B must be N×p with N = 90",
    );
    let wide = Sparse::from_dense(&Mat::from_fn(1, n + 1, |_, j| f64::from(j == 3)));
    let wv = wide.view();
    refused(
        set(&ok, &part(&[], &[], Some(&wv))),
        "outputs.matrix is 1×91",
    );
    // a zero column
    let zero = Sparse {
        nrows: n,
        ncols: 1,
        col_ptr: vec![0, 1],
        row_idx: vec![5],
        values: vec![0.0],
    };
    let zv = zero.view();
    refused(
        set(&part(&[], &[], Some(&zv)), &ok),
        "column 0 has no nonzero entry",
    );
    // an unsorted column
    let unsorted = Sparse {
        nrows: n,
        ncols: 1,
        col_ptr: vec![0, 2],
        row_idx: vec![5, 3],
        values: vec![1.0, 2.0],
    };
    let uv = unsorted.view();
    refused(set(&part(&[], &[], Some(&uv)), &ok), "strictly increasing");
    // DoF out of range; nothing at all
    refused(set(&part(&[n], &[], None), &ok), "inputs.dofs[0] = 90");
    refused(set(&ok, &part(&[], &[], None)), "outputs: no DoF");
    // B's column proportional but not equal to C's row: dependent
    let b = Sparse::from_dense(&Mat::from_fn(n, 1, |i, _| {
        if i == 40 {
            2.0
        } else if i == 41 {
            1.0
        } else {
            0.0
        }
    }));
    let c = Sparse::from_dense(&Mat::from_fn(1, n, |_, j| {
        if j == 40 {
            1.0
        } else if j == 41 {
            0.5
        } else {
            0.0
        }
    }));
    let (bv, cv) = (b.view(), c.view());
    refused(
        set(&part(&[], &[], Some(&bv)), &part(&[], &[], Some(&cv))),
        "linearly dependent",
    );
    // equal: one functional, accepted
    let c2 = Sparse::from_dense(&Mat::from_fn(1, n, |_, j| {
        if j == 40 {
            2.0
        } else if j == 41 {
            1.0
        } else {
            0.0
        }
    }));
    let c2v = c2.view();
    let st = set(&part(&[], &[], Some(&bv)), &part(&[], &[], Some(&c2v)));
    assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
    // band
    let st = unsafe { sparsemor_model_set_scene_general(fx.h, &ok, &ok, 10.0, 5.0) };
    refused(st, "band");
    // remote points need nodes
    let (m, k) = mk_chain();
    let h = model_from(&m, &k, 1e-4);
    let (st, _) = add_point(h, SPARSEMOR_POINT_RIGID, &at, &[0], &[]);
    refused(st, "no node coordinates");
    unsafe {
        sparsemor_model_free(h);
        sparsemor_model_free(fx.h);
    }
}

fn mk_chain() -> (CscArrays, CscArrays) {
    let (m, k) = chain(4);
    (CscArrays::from_dense(4, &m), CscArrays::from_dense(4, &k))
}

/// Structural damping and a general scene in either order (docs/design.md §3.11, §3.12):
/// given after the scene, the handle couples the scene again from the new body; given before,
/// the coupling carries it. Either way an exact line-fit reproduces
/// C (K + i(ωβK + ηK + K₄) − ω²M)⁻¹ B of the original model (dense solve) at its reference
/// frequencies, and the two handles' coupled models and ROMs are the same bit for bit.
#[test]
fn structural_damping_survives_the_general_scene_in_either_order() {
    const ETA: f64 = 0.02;
    let (before, after) = (fixture(), fixture());
    let n = before.model.n();
    // K₄ = ηK plus a hysteretic damper c (e_a − e_b)(e_a − e_b)ᵀ between two DoFs
    let k = before.model.stiffness.as_ref().to_dense();
    let (a, b) = (20, 23);
    let c = 0.05 * k[(a, a)];
    let mut damper = Mat::<f64>::zeros(n, n);
    damper[(a, a)] = c;
    damper[(b, b)] = c;
    damper[(a, b)] = -c;
    damper[(b, a)] = -c;
    let k4 = CscArrays::from_csc(&csc_of(&damper));
    let h = Mat::<f64>::from_fn(n, n, |i, j| ETA * k[(i, j)] + damper[(i, j)]);
    let set =
        |fx: &Fixture| unsafe { sparsemor_model_set_structural_damping(fx.h, ETA, &k4.view()) };
    assert_eq!(set(&before), SparsemorStatus::Ok, "{}", last_error());
    assert_eq!(set_scene(&before), SparsemorStatus::Ok, "{}", last_error());
    assert_eq!(set_scene(&after), SparsemorStatus::Ok, "{}", last_error());
    assert_eq!(set(&after), SparsemorStatus::Ok, "{}", last_error());

    let freqs = [400.0, 2100.0];
    let o = options();
    unsafe {
        assert_eq!(sparsemor_options_set_threads(o, 1), SparsemorStatus::Ok);
        assert_eq!(
            sparsemor_options_set_reference_frequencies(o, freqs.as_ptr(), 2),
            SparsemorStatus::Ok
        );
        assert_eq!(
            sparsemor_options_set_interface_outputs_plus(o, 5),
            SparsemorStatus::Ok
        );
    }
    let reduce = |fx: &Fixture| {
        let mut rom = null_mut();
        let st = unsafe { sparsemor_reduce_linefit(fx.h, o, None, null_mut(), &mut rom) };
        assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
        let mut has = 0;
        unsafe { sparsemor_rom_has_structural_damping(rom, &mut has) };
        assert_eq!(has, 1, "the ROM carries K4r");
        let mut info = SparsemorDampingInfo::default();
        let st = unsafe { sparsemor_model_damping_info(fx.h, &mut info) };
        assert_eq!(st, SparsemorStatus::Ok, "{}", last_error());
        println!("coupled model's damping: {info:?}");
        assert_ne!(info.kind, SPARSEMOR_DAMPING_NONE);
        (rom, info)
    };
    let ((r1, i1), (r2, i2)) = (reduce(&before), reduce(&after));
    assert_eq!(i1, i2, "the same coupled model");
    for which in [
        SPARSEMOR_MATRIX_MR,
        SPARSEMOR_MATRIX_DR,
        SPARSEMOR_MATRIX_KR,
        SPARSEMOR_MATRIX_K4R,
        SPARSEMOR_MATRIX_BR,
        SPARSEMOR_MATRIX_CR,
    ] {
        let (a, b) = (rom_matrix(r1, which).2, rom_matrix(r2, which).2);
        let same = a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(same && a.len() == b.len(), "matrix {which} differs");
    }
    for f in freqs {
        let want = dense_h_structural(&before.model, Some(&h), &before.b, &before.c, f);
        let (e1, e2) = (
            rel(&rom_transfer(r1, f), &want),
            rel(&rom_transfer(r2, f), &want),
        );
        println!("{f} Hz: ROM vs dense C A^-1 B with H: set before {e1:.2e}, after {e2:.2e}");
        assert!(e1 <= 1e-8 && e2 <= 1e-8, "{e1:e} {e2:e}");
    }
    unsafe {
        sparsemor_rom_free(r1);
        sparsemor_rom_free(r2);
        sparsemor_options_free(o);
        sparsemor_model_free(before.h);
        sparsemor_model_free(after.h);
    }
}
