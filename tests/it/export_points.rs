//! The exports of a coupled model (docs/design.md §3.9, §3.11): every remote point an
//! interface node of the SID_FEM, MBDyn, EXUDYN and DMIG outputs. Each file is read back and
//! its point nodes checked against the points' motion computed here from the mesh nodes'
//! shapes in the same file — a rigid point: u_i = t + θ × (x_i − x_p) on its nodes; a
//! distributing point: the weighted least-squares rigid fit of its nodes (a 6 × 6 dense
//! solve) — and the body's mass invariants against the same bar exported without points.

use crate::common::dense;
use crate::export_nastran::{group, has_pynastran, parse_matrices, python};
use crate::export_sid::parse;
use crate::remote_points::{bar, directory, face, g, write_mtx};
use faer::linalg::solvers::Solve;
use faer::Mat;
use sparsemor::body::Body;
use sparsemor::coupled::{Coordinate, Joints};
use sparsemor::io::{dmig, exudyn, mbdyn, model_dir, sid};
use sparsemor::model::Model;
use sparsemor::reduce::flexible::{elastic_basis, ElasticBasis, PointNode};
use sparsemor::reduce::linefit::{self, Interface, LineFitOptions, References};
use sparsemor::reduce::Rom;
use sparsemor::rigid;
use sparsemor::scene::Scene;
use sparsemor::sweep::no_progress;
use std::path::PathBuf;

const BASE_AT: [f64; 3] = [0.01, 0.015, -0.01];
/// Off the face's centre, so that the fit couples translations and rotations.
const TIP_AT: [f64; 3] = [0.012, 0.014, 0.21];
const TIP_WEIGHTS: [f64; 6] = [1.0, 2.0, 0.5, 3.0, 1.5, 2.5];

/// The small bar with a rigid point at its base and a weighted distributing point at its
/// tip; the scene names only some of the points' DoFs, a mesh DoF and a row of C.
fn coupled_bar(name: &str) -> PathBuf {
    let dir = directory(
        name,
        &format!(
            "[scene]\n\
             inputs = [\"tip:x\", \"tip:rz\", \"base:y\"]\n\
             outputs = [\"tip:x\", \"tip:rz\", \"base:y\", \"base:rx\", 40]\n\
             output_matrix = \"C.mtx\"\nband_hz = [0.0, 6000.0]\n\
             [[remote_points]]\nname = \"base\"\nkind = \"rigid\"\nposition = {BASE_AT:?}\n\
             box = {{ min = [-1, -1, -1e-6], max = [1, 1, 1e-6] }}\n\
             [[remote_points]]\nname = \"tip\"\nkind = \"distributing\"\nposition = {TIP_AT:?}\n\
             box = {{ min = [-1, -1, 0.1999], max = [1, 1, 1] }}\nweights = {TIP_WEIGHTS:?}\n"
        ),
    );
    let mut c = Mat::<f64>::zeros(1, 90);
    for (d, v) in [(45, 1.0), (47, -0.5), (52, 2.0)] {
        c[(0, d)] = v;
    }
    write_mtx(&dir.join("C.mtx"), &c);
    dir
}

/// A line-fitting ROM with its basis.
fn reduce(model: &Model, scene: &Scene) -> Rom {
    let body = Body::new(model).unwrap();
    let mut opts = LineFitOptions::new(
        Interface::OutputsPlus(3),
        References::Explicit(vec![300.0, 1500.0, 4000.0]),
    );
    opts.keep_basis = true;
    linefit::reduce(&body, scene, &opts, None, &no_progress).unwrap()
}

/// The coupled bar: its joints, its ROM, the elastic basis on the mesh and the point nodes.
struct Coupled {
    joints: Joints,
    model: Model,
    rom: Rom,
    on_mesh: ElasticBasis,
    points: Vec<PointNode>,
}

fn coupled(name: &str) -> Coupled {
    let (loaded, joints) = model_dir::load_with_joints(&coupled_bar(name)).unwrap();
    let joints = joints.unwrap();
    let rom = reduce(&loaded.model, &loaded.scene);
    let flex = elastic_basis(&Body::new(&loaded.model).unwrap(), &loaded.scene, &rom).unwrap();
    let (on_mesh, points) = flex.on_original(&joints).unwrap();
    assert_eq!(points.len(), 2);
    Coupled {
        joints,
        model: loaded.model,
        rom,
        on_mesh,
        points,
    }
}

/// The same bar without points, and the elastic basis of a ROM of it.
fn plain() -> (Model, ElasticBasis) {
    let model = bar();
    let scene = Scene {
        inputs: vec![2, 40],
        outputs: vec![2, 40, 88],
        band_hz: [0.0, 6000.0],
    };
    let rom = reduce(&model, &scene);
    let flex = elastic_basis(&Body::new(&model).unwrap(), &scene, &rom).unwrap();
    (model, flex)
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// max over the modes and the rigid point's nodes of |u_i − (t + θ × (x_i − x_p))| / max |u_i|,
/// with `u(node, dir, mode)` the mesh shapes and `s` the point's 6 × r shapes, from one file.
fn rigid_error(u: &dyn Fn(usize, usize, usize) -> f64, s: &Mat<f64>) -> f64 {
    let model = bar();
    let x = model.nodes.as_ref().unwrap();
    let set = face(&model, 0.0);
    let mut worst = 0.0f64;
    for k in 0..s.ncols() {
        let (t, th) = ([0, 1, 2].map(|a| s[(a, k)]), [3, 4, 5].map(|a| s[(a, k)]));
        let (mut e, mut scale) = (0.0f64, 0.0f64);
        for &i in &set {
            let w = cross(th, [0, 1, 2].map(|a| x[i][a] - BASE_AT[a]));
            for a in 0..3 {
                e = e.max((u(i, a, k) - t[a] - w[a]).abs());
                scale = scale.max(u(i, a, k).abs());
            }
        }
        worst = worst.max(e / scale);
    }
    worst
}

/// The distributing point's motion in each mode as the weighted least-squares rigid fit of
/// its nodes' shapes, min Σ w_i |u_i − G(r_i) x|² (rotations scaled by the mean radius ℓ),
/// against `s`: max over the modes of max(|Δt|, ℓ|Δθ|) / max(|t|, ℓ|θ|).
fn distributing_error(u: &dyn Fn(usize, usize, usize) -> f64, s: &Mat<f64>) -> f64 {
    let model = bar();
    let x = model.nodes.as_ref().unwrap();
    let set = face(&model, 0.2);
    assert_eq!(set.len(), TIP_WEIGHTS.len());
    let r = |i: usize| [0, 1, 2].map(|a| x[i][a] - TIP_AT[a]);
    let ell = set
        .iter()
        .map(|&i| r(i).iter().map(|v| v * v).sum::<f64>().sqrt())
        .sum::<f64>()
        / set.len() as f64;
    let gs = |i: usize| {
        let mut m = g(r(i));
        for a in 0..3 {
            for j in 3..6 {
                m[(a, j)] /= ell;
            }
        }
        m
    };
    let mut a = Mat::<f64>::zeros(6, 6);
    for (&i, w) in set.iter().zip(TIP_WEIGHTS) {
        let gi = gs(i);
        a += Mat::<f64>::from_fn(6, 6, |p, q| {
            w * (0..3).map(|m| gi[(m, p)] * gi[(m, q)]).sum::<f64>()
        });
    }
    let lu = a.partial_piv_lu();
    let mut worst = 0.0f64;
    for k in 0..s.ncols() {
        let mut b = Mat::<f64>::zeros(6, 1);
        for (&i, w) in set.iter().zip(TIP_WEIGHTS) {
            let gi = gs(i);
            b += Mat::<f64>::from_fn(6, 1, |p, _| {
                w * (0..3).map(|m| gi[(m, p)] * u(i, m, k)).sum::<f64>()
            });
        }
        let xs = lu.solve(&b);
        let (mut e, mut scale) = (0.0f64, 0.0f64);
        for d in 0..6 {
            // x_s = (t, ℓθ): compare t and ℓθ
            let got = if d < 3 { s[(d, k)] } else { ell * s[(d, k)] };
            e = e.max((got - xs[(d, 0)]).abs());
            scale = scale.max(xs[(d, 0)].abs());
        }
        worst = worst.max(e / scale);
    }
    worst
}

/// |a − b| / |b| for scalars and the largest entry of arrays.
fn rel(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = b.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    a.iter()
        .zip(b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / scale
}

#[test]
fn sid_writes_each_remote_point_as_a_node_with_its_rigid_motion() {
    let c = coupled("export_sid_points");
    let model = &c.joints.original;
    let (nn, r) = (30, c.on_mesh.phi.ncols());
    let tmp = tempfile::tempdir().unwrap();
    sid::write(&tmp.path().join("sid"), model, &c.on_mesh, None, &c.points).unwrap();
    let p = parse(&std::fs::read_to_string(tmp.path().join("sid").join(sid::SID_FILE)).unwrap());
    assert_eq!(p.header, (nn + 2, r));
    let ids: Vec<u64> = p.nodes.iter().map(|n| n.0).collect();
    assert_eq!(ids, (1..=32).collect::<Vec<u64>>());
    // the mesh nodes' shapes are TΦ, bit for bit
    let u = |i: usize, a: usize, k: usize| p.nodes[i].1["phi"].m0[(a, k)];
    for i in 0..nn {
        for a in 0..3 {
            for k in 0..r {
                assert_eq!(u(i, a, k), c.on_mesh.phi[(3 * i + a, k)]);
            }
        }
    }
    // the point nodes: position, phi and psi, AP = I + Σ skew(psi_k) q_k
    let shapes: Vec<Mat<f64>> = (0..2)
        .map(|q| {
            let b = &p.nodes[nn + q].1;
            assert_eq!(b["origin"].m0[(0, 0)], [BASE_AT, TIP_AT][q][0]);
            assert_eq!((b["AP"].order, b["AP"].m1.len()), (1, r));
            for k in 0..r {
                let psi = [0, 1, 2].map(|a| b["psi"].m0[(a, k)]);
                for j in 0..3 {
                    let e = std::array::from_fn(|a| f64::from(a == j));
                    for (a, v) in cross(psi, e).into_iter().enumerate() {
                        assert_eq!(b["AP"].m1[k][(a, j)], v);
                    }
                }
            }
            Mat::from_fn(6, r, |d, k| {
                if d < 3 {
                    b["phi"].m0[(d, k)]
                } else {
                    b["psi"].m0[(d - 3, k)]
                }
            })
        })
        .collect();
    assert_eq!(shapes[0], c.points[0].shapes);
    assert_eq!(shapes[1], c.points[1].shapes);
    let (er, ed) = (
        rigid_error(&u, &shapes[0]),
        distributing_error(&u, &shapes[1]),
    );
    // the mass invariants: the body's, unchanged by its massless points
    let (plain_model, plain_flex) = plain();
    sid::write(
        &tmp.path().join("plain"),
        &plain_model,
        &plain_flex,
        None,
        &[],
    )
    .unwrap();
    let q = parse(&std::fs::read_to_string(tmp.path().join("plain").join(sid::SID_FILE)).unwrap());
    let m0 = |p: &crate::export_sid::Parsed, name: &str| -> Vec<f64> {
        p.body[name].m0.col(0).iter().copied().collect()
    };
    let em = rel(&[p.mass], &[q.mass]);
    let ec = rel(&m0(&p, "mdCM"), &m0(&q, "mdCM"));
    let ej = rel(&m0(&p, "J"), &m0(&q, "J"));
    // Me, Ke of the file (the coupled ROM's ΦᵀM'Φ, ΦᵀK'Φ) against dense (TΦ)ᵀM(TΦ),
    // (TΦ)ᵀK(TΦ) of the original body, and the mean-axis conditions Ct0 = (TΦ)ᵀ M T_a = 0 on it
    let phi = Mat::from_fn(3 * nn, r, |d, k| u(d / 3, d % 3, k));
    let (m, k) = (dense(&model.mass), dense(&model.stiffness));
    let me = phi.transpose() * &m * &phi;
    let ke = phi.transpose() * &k * &phi;
    let e_me = (&me - &p.body["Me"].m0).norm_max() / me.norm_max();
    let e_ke = (&ke - &p.body["Ke"].m0).norm_max() / ke.norm_max();
    let ct = p.body["Ct"].m0.norm_max() / p.mass.sqrt();
    println!(
        "sid points: rigid point {er:.2e}, distributing point {ed:.2e}; vs the bar without \
         points: mass {em:.2e}, m·c {ec:.2e}, J {ej:.2e}; Me {e_me:.2e}, Ke {e_ke:.2e} vs \
         dense (TΦ)ᵀM(TΦ), (TΦ)ᵀK(TΦ); Ct0 {ct:.2e}"
    );
    assert!(er <= 1e-12 && ed <= 1e-12, "{er:e} {ed:e}");
    assert!(em <= 1e-12 && ec <= 1e-12 && ej <= 1e-12);
    assert!(e_me <= 1e-12 && e_ke <= 1e-12 && ct <= 1e-10);
    assert_eq!(p.body["Me"].m0, c.rom_me());
}

impl Coupled {
    /// The projected ROM's Mr, which the SID writes as Me.
    fn rom_me(&self) -> Mat<f64> {
        self.on_mesh.rom.mr.clone()
    }
}

#[test]
fn mbdyn_writes_each_remote_point_as_a_node_with_six_components() {
    let c = coupled("export_mbdyn_points");
    let model = &c.joints.original;
    let (nn, r) = (30, c.on_mesh.phi.ncols());
    let tmp = tempfile::tempdir().unwrap();
    mbdyn::write(&tmp.path().join("m"), model, &c.on_mesh, None, &c.points).unwrap();
    let text = std::fs::read_to_string(tmp.path().join("m").join(mbdyn::FEM_FILE)).unwrap();
    assert!(text.contains(&format!("\nREV0 {} {r} 0 0 0\n", nn + 2)));
    let labels = group(&text, 2);
    assert_eq!(labels.len(), nn + 2);
    assert_eq!(&labels[nn..], &[31.0, 32.0]);
    let (x, y, z) = (group(&text, 5), group(&text, 6), group(&text, 7));
    for (q, at) in [BASE_AT, TIP_AT].iter().enumerate() {
        assert_eq!([x[nn + q], y[nn + q], z[nn + q]], *at);
    }
    // group 8: per mode, per node, six components
    let g8 = group(&text, 8);
    assert_eq!(g8.len(), r * (nn + 2) * 6);
    let at = |node: usize, a: usize, k: usize| g8[(k * (nn + 2) + node) * 6 + a];
    let u = |i: usize, a: usize, k: usize| at(i, a, k);
    for i in 0..nn {
        for k in 0..r {
            assert_eq!([at(i, 3, k), at(i, 4, k), at(i, 5, k)], [0.0; 3]);
            for a in 0..3 {
                assert_eq!(u(i, a, k), c.on_mesh.phi[(3 * i + a, k)]);
            }
        }
    }
    let shapes: Vec<Mat<f64>> = (0..2)
        .map(|q| Mat::from_fn(6, r, |d, k| at(nn + q, d, k)))
        .collect();
    assert_eq!(shapes[0], c.points[0].shapes);
    assert_eq!(shapes[1], c.points[1].shapes);
    let (er, ed) = (
        rigid_error(&u, &shapes[0]),
        distributing_error(&u, &shapes[1]),
    );
    // group 12 against the bar without points
    let (plain_model, plain_flex) = plain();
    mbdyn::write(&tmp.path().join("p"), &plain_model, &plain_flex, None, &[]).unwrap();
    let plain_text = std::fs::read_to_string(tmp.path().join("p").join(mbdyn::FEM_FILE)).unwrap();
    let (g12, p12) = (group(&text, 12), group(&plain_text, 12));
    assert_eq!(g12.len(), 13);
    let (em, ec, ej) = (
        rel(&g12[..1], &p12[..1]),
        rel(&g12[1..4], &p12[1..4]),
        rel(&g12[4..], &p12[4..]),
    );
    // group 9, 10: ΦᵀMΦ and ΦᵀKΦ of the original body with the mesh shapes of the file
    let phi = Mat::from_fn(3 * nn, r, |d, k| u(d / 3, d % 3, k));
    let me = phi.transpose() * dense(&model.mass) * &phi;
    let g9 = group(&text, 9);
    let e9 = (0..r * r).fold(0.0f64, |e, i| e.max((g9[i] - me[(i / r, i % r)]).abs()));
    println!(
        "mbdyn points: rigid point {er:.2e}, distributing point {ed:.2e}; vs the bar without \
         points: mass {em:.2e}, centre {ec:.2e}, inertia {ej:.2e}; group 9 vs dense \
         (TΦ)ᵀM(TΦ) {e9:.2e}"
    );
    assert!(er <= 1e-12 && ed <= 1e-12, "{er:e} {ed:e}");
    assert!(em <= 1e-12 && ec <= 1e-12 && ej <= 1e-12);
    assert!(e9 <= 1e-12);
    let rb = rigid::inertia(model).unwrap();
    assert!((rb.mass - 0.1).abs() <= 1e-14);
}

const PY_NPZ: &str = r#"
import sys
import numpy as np
z = np.load(sys.argv[1] + "/flexible_body.npz")
for name in ["modeBasis", "nodes", "point_modes", "point_positions", "point_weights",
             "point_nodes", "point_nodes_ptr", "input_node", "input_dir", "output_node",
             "output_dir", "massMatrix_data"]:
    a = np.atleast_2d(np.asarray(z[name], dtype=np.float64))
    print("matrix", name, a.shape[0], a.shape[1])
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            print(i, j, float(a[i, j]).hex())
print("names", z["point_names"].item().replace("\n", ","))
"#;

#[test]
fn exudyn_writes_each_remote_point_as_a_node_set_with_its_modes() {
    let c = coupled("export_exudyn_points");
    let model = &c.joints.original;
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("ex");
    exudyn::write(
        &dir,
        model,
        &c.on_mesh,
        None,
        &c.points,
        Some(&c.joints.coordinates),
    )
    .unwrap();
    let toml: toml::Value =
        toml::from_str(&std::fs::read_to_string(dir.join("export.toml")).unwrap()).unwrap();
    let points = toml["points"].as_array().unwrap();
    assert_eq!(points[0]["name"].as_str(), Some("base"));
    assert_eq!(points[1]["kind"].as_str(), Some("distributing"));
    assert_eq!(points[1]["nodes"].as_integer(), Some(6));
    if !crate::export::python_has("numpy") {
        return;
    }
    let out = python(PY_NPZ, &[&dir]);
    assert!(out.contains("names base,tip"), "{out}");
    let z = parse_matrices(&out);
    let phi = &z["modeBasis"];
    let r = phi.ncols();
    assert_eq!(phi, &c.on_mesh.phi);
    assert_eq!(z["massMatrix_data"].ncols(), model.mass.compute_nnz());
    let pm = &z["point_modes"];
    assert_eq!((pm.nrows(), pm.ncols()), (12, r));
    let shapes: Vec<Mat<f64>> = (0..2)
        .map(|q| Mat::from_fn(6, r, |d, k| pm[(6 * q + d, k)]))
        .collect();
    let u = |i: usize, a: usize, k: usize| phi[(3 * i + a, k)];
    let (er, ed) = (
        rigid_error(&u, &shapes[0]),
        distributing_error(&u, &shapes[1]),
    );
    // the node sets and weights for MarkerSuperElementRigid
    let model_bar = bar();
    let ptr: Vec<usize> = z["point_nodes_ptr"]
        .row(0)
        .iter()
        .map(|&v| v as usize)
        .collect();
    let set: Vec<usize> = z["point_nodes"]
        .row(0)
        .iter()
        .map(|&v| v as usize)
        .collect();
    assert_eq!(ptr, [0, 6, 12]);
    assert_eq!(&set[..6], face(&model_bar, 0.0).as_slice());
    assert_eq!(&set[6..], face(&model_bar, 0.2).as_slice());
    let w: Vec<f64> = z["point_weights"].row(0).iter().copied().collect();
    assert_eq!(&w[..6], &[1.0; 6]);
    assert_eq!(&w[6..], &TIP_WEIGHTS);
    let pos = &z["point_positions"];
    assert_eq!([pos[(1, 0)], pos[(1, 1)], pos[(1, 2)]], TIP_AT);
    // inputs: tip:x, tip:rz, base:y → point nodes 31, 30 (0-based after the 30 mesh nodes)
    let node: Vec<f64> = z["input_node"].row(0).iter().copied().collect();
    let dir_: Vec<f64> = z["input_dir"].row(0).iter().copied().collect();
    assert_eq!(node, [31.0, 31.0, 30.0]);
    assert_eq!(dir_, [0.0, 5.0, 1.0]);
    // outputs: ..., DoF 40 (node 13, y), the row of C (no node: −1)
    let onode: Vec<f64> = z["output_node"].row(0).iter().copied().collect();
    assert_eq!(&onode[4..], &[13.0, -1.0]);
    println!(
        "exudyn points: rigid point {er:.2e}, distributing point {ed:.2e} (point_modes against \
         modeBasis)"
    );
    assert!(er <= 1e-12 && ed <= 1e-12, "{er:e} {ed:e}");
    if !crate::export::python_has("numpy, scipy, exudyn") {
        return;
    }
    // EXUDYN's MarkerSuperElementRigid on each point's node set and weights, on the body
    // deflected by modal coordinates q: its rotation is the point's, its position moves with
    // the point's motion taken to the set's weighted centroid
    let script = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples");
    let out = crate::export::python(&[
        "-c",
        PY_EXUDYN_MARKERS,
        script.to_str().unwrap(),
        dir.to_str().unwrap(),
    ]);
    let j: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    for name in ["base", "tip"] {
        let (t, r) = (
            j[name]["translation"].as_f64().unwrap(),
            j[name]["rotation"].as_f64().unwrap(),
        );
        println!(
            "exudyn points: MarkerSuperElementRigid at {name}, q ~ 1e-8: translation {t:.2e}, \
             rotation {r:.2e} (rel.)"
        );
        assert!(t <= 1e-8 && r <= 1e-8, "{name}: {t:e} {r:e}");
    }
}

const PY_EXUDYN_MARKERS: &str = r#"
import sys, json
sys.path.insert(0, sys.argv[1])
import numpy as np
import exudyn as exu
from exudyn.itemInterface import MarkerSuperElementRigid
from exudyn_flexible_body import load_export, build

z, fem = load_export(sys.argv[2])
pm, ptr, pos = z["point_modes"], z["point_nodes_ptr"], z["point_positions"]
names = z["point_names"].item().split("\n")
q = 1e-8 * np.random.default_rng(1).standard_normal(pm.shape[1])
SC, mbs, body, cms = build(fem, modal=q)
sets = []
for p in range(len(names)):
    nodes = z["point_nodes"][ptr[p]:ptr[p + 1]]
    w = z["point_weights"][ptr[p]:ptr[p + 1]]
    w = w / w.sum()
    m = mbs.AddMarker(MarkerSuperElementRigid(
        bodyNumber=body["oFFRFreducedOrder"], meshNodeNumbers=[int(i) for i in nodes],
        weightingFactors=list(w), useAlternativeApproach=True, rotationsExponentialMap=2))
    sets.append((m, w @ z["nodes"][nodes]))
mbs.Assemble()
out = {}
for p, (m, c) in enumerate(sets):
    cfg = exu.ConfigurationType.Current
    x = np.array(mbs.GetMarkerOutput(m, exu.OutputVariableType.Position, cfg))
    a = np.array(mbs.GetMarkerOutput(m, exu.OutputVariableType.RotationMatrix, cfg)).reshape(3, 3)
    theta = np.array([a[2, 1] - a[1, 2], a[0, 2] - a[2, 0], a[1, 0] - a[0, 1]]) / 2
    u = pm[6 * p:6 * p + 6] @ q
    t = u[:3] + np.cross(u[3:], c - pos[p])
    out[names[p]] = {
        "translation": float(np.abs(x - c - t).max() / np.abs(t).max()),
        "rotation": float(np.abs(theta - u[3:]).max() / np.abs(u[3:]).max()),
    }
print(json.dumps(out))
"#;

const PY_DMIG_GRIDS: &str = r#"
import sys
import numpy as np
if not hasattr(np, 'in1d'):
    np.in1d = np.isin  # pyNastran 1.4.1 calls np.in1d, removed in NumPy 2.4
from pyNastran.bdf.bdf import BDF
model = BDF(debug=None)
model.read_bdf(sys.argv[1], punch=True, xref=False)
print("spoints", " ".join(str(s) for s in sorted(model.spoints)))
for nid in sorted(model.nodes):
    print("grid", nid, " ".join(float(x).hex() for x in model.nodes[nid].xyz))
for name in sorted(model.dmig):
    m = model.dmig[name]
    a, rows, cols = m.get_matrix(is_sparse=False, apply_symmetry=True)
    for i in range(a.shape[0]):
        g, c = rows[i] if isinstance(rows[i], tuple) else (rows[i], 0)
        print("key", name, i, g, c)
    print("matrix", name, a.shape[0], a.shape[1])
    for j in range(a.shape[1]):
        for i in range(a.shape[0]):
            if a[i, j] != 0.0:
                print(i, j, float(a[i, j]).hex())
"#;

#[test]
fn dmig_keys_point_dofs_by_a_grid_at_the_point() {
    let c = coupled("export_dmig_points");
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("dmig");
    dmig::write(&dir, &c.rom, &c.model, None, Some(&c.joints)).unwrap();
    let keys = dmig::coordinates(&c.rom, &c.model, None, Some(&c.joints)).unwrap();
    assert_eq!(keys.len(), c.rom.order());
    let csv = std::fs::read_to_string(dir.join(dmig::MAP_FILE)).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    let (mut points, mut rows) = (0, 0);
    for (r, k) in keys.iter().enumerate() {
        let d = c.rom.dofs[r];
        let (want, kind) = match &c.joints.coordinates[d] {
            Coordinate::Dof(q) => (((q / 3) as u64 + 1, (q % 3) as u8 + 1), "grid"),
            Coordinate::Point { point, dir } => {
                points += 1;
                ((31 + *point as u64, *dir as u8 + 1), "point")
            }
            Coordinate::Row(_) => {
                rows += 1;
                ((32 + rows, 0), "spoint")
            }
        };
        assert_eq!((k.id, k.component), want, "ROM coordinate {r}");
        assert_eq!(
            lines[r + 1],
            format!("{r},{},{},{kind},{d}", k.id, k.component)
        );
    }
    // tip:x, tip:rz, base:y, base:rx (and any of base's DoFs line-fitting added) and the row
    // of C
    assert!(points >= 4 && rows == 1, "{points} {rows}");
    let bdf = std::fs::read_to_string(dir.join(dmig::BULK_FILE)).unwrap();
    assert!(bdf.contains("$ remote point tip: grid 32\n"), "{bdf}");
    assert!(bdf.contains("SPOINT  33      \n"), "{bdf}");
    if !has_pynastran() {
        return;
    }
    let out = python(PY_DMIG_GRIDS, &[&dir.join(dmig::BULK_FILE)]);
    assert!(out.contains("spoints 33\n"), "{out}");
    let hex = |s: &str| -> f64 {
        let t = format!("matrix x 1 1\n0 0 {s}\n");
        parse_matrices(&t)["x"][(0, 0)]
    };
    let mut grids = Vec::new();
    for l in out.lines().filter(|l| l.starts_with("grid ")) {
        let t: Vec<&str> = l.split_whitespace().collect();
        grids.push((
            t[1].parse::<u64>().unwrap(),
            [hex(t[2]), hex(t[3]), hex(t[4])],
        ));
    }
    assert_eq!(grids, [(31, BASE_AT), (32, TIP_AT)]);
    let index: std::collections::HashMap<(u64, u8), usize> = keys
        .iter()
        .enumerate()
        .map(|(r, k)| ((k.id, k.component), r))
        .collect();
    let py = parse_matrices(&out);
    for (name, a) in [("MAAX", &c.rom.mr), ("KAAX", &c.rom.kr)] {
        let mut perm = vec![usize::MAX; c.rom.order()];
        for l in out
            .lines()
            .filter(|l| l.starts_with(&format!("key {name} ")))
        {
            let t: Vec<&str> = l.split_whitespace().collect();
            perm[t[2].parse::<usize>().unwrap()] =
                index[&(t[3].parse().unwrap(), t[4].parse().unwrap())];
        }
        let b = &py[name];
        let mut e = 0.0f64;
        for i in 0..perm.len() {
            for j in 0..perm.len() {
                e = e.max((b[(i, j)] - a[(perm[i], perm[j])]).abs());
            }
        }
        let e = e / a.norm_max();
        println!("dmig points: pyNastran {name} rel. error {e:.2e}, grids 31, 32 at the points");
        assert!(e <= 1e-12, "{name}: {e:e}");
    }
}
