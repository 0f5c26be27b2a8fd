//! The SID_FEM export (docs/design.md §3.9, §4): the file parsed back by a reader of its
//! taylor blocks written here (every block's order, nrow, ncol, nq and structure against its
//! entries), the rigid-body properties against a dense reference from M and the node
//! coordinates, Me, Ke against dense ΦᵀMΦ, ΦᵀKΦ, the frequencies of refmod, and the coupling
//! invariants (Ct, Cr, J1, Gr, Ge, Oe) against dense formulas and central differences of the
//! inertia of the deformed body; the command end to end.

use crate::cli::{ok, run};
use crate::common::dense;
use crate::export_nastran::{bar_and_roms, linefit_rom, model_scene};
use faer::Mat;
use sparsemor::body::Body;
use sparsemor::io::sid;
use sparsemor::model::Model;
use sparsemor::reduce::flexible::{elastic_basis, ElasticBasis};
use std::collections::HashMap;

/// The small free bar of the Nastran export tests and the elastic basis of its line-fitting
/// ROM.
fn model_flex() -> (Model, ElasticBasis) {
    let (model, scene) = model_scene();
    let rom = linefit_rom(&model, &scene);
    let flex = elastic_basis(&Body::new(&model).unwrap(), &scene, &rom).unwrap();
    (model, flex)
}

/// One parsed taylor block.
#[derive(Debug)]
pub(crate) struct Block {
    pub(crate) order: usize,
    pub(crate) nq: usize,
    pub(crate) structure: usize,
    pub(crate) m0: Mat<f64>,
    pub(crate) m1: Vec<Mat<f64>>,
}

/// What the reader found.
pub(crate) struct Parsed {
    pub(crate) header: (usize, usize),
    pub(crate) mass: f64,
    pub(crate) nelastq: usize,
    pub(crate) freqs: Vec<f64>,
    pub(crate) nodes: Vec<(u64, HashMap<String, Block>)>,
    pub(crate) body: HashMap<String, Block>,
}

fn num(s: &str) -> f64 {
    s.trim().replace('D', "e").parse().unwrap()
}

fn key_value(l: &str) -> (String, String) {
    let (k, v) = l.split_once('=').unwrap();
    (k.trim().to_string(), v.trim().to_string())
}

/// Indices of `m0( i, j)` / `m1( i, k, j)`, 1-based.
fn indices(k: &str) -> Vec<usize> {
    let inner = k.split_once('(').unwrap().1.trim_end_matches(')');
    inner
        .split(',')
        .map(|t| t.trim().parse().unwrap())
        .collect()
}

/// Reads a taylor block after its name line, up to `end NAME`; checks every entry against
/// the dimensions and structure the block declares.
fn block<'a>(lines: &mut impl Iterator<Item = &'a str>, name: &str) -> Block {
    let mut head = HashMap::new();
    for key in ["order", "nrow", "ncol", "nq", "nqn", "structure"] {
        let (k, v) = key_value(lines.next().unwrap());
        assert_eq!(k, key, "{name}");
        head.insert(key, v.parse::<usize>().unwrap());
    }
    let (order, nrow, ncol, nq) = (head["order"], head["nrow"], head["ncol"], head["nq"]);
    let structure = head["structure"];
    assert_eq!(head["nqn"], 0, "{name}");
    assert!(order <= 1 && [0, 3].contains(&structure), "{name}");
    let mut m0 = Mat::zeros(nrow, ncol);
    let mut m1 = vec![Mat::zeros(nrow, ncol); if order == 1 { nq } else { 0 }];
    let mut entries = 0;
    for l in lines.by_ref() {
        if l.trim() == format!("end {name}") {
            break;
        }
        let (k, v) = key_value(l);
        let ix = indices(&k);
        entries += 1;
        assert_eq!(
            structure, 3,
            "{name}: entries in a block of structure {structure}"
        );
        if k.starts_with("m0") {
            assert_eq!(ix.len(), 2);
            assert!(
                (1..=nrow).contains(&ix[0]) && (1..=ncol).contains(&ix[1]),
                "{name} {k}"
            );
            m0[(ix[0] - 1, ix[1] - 1)] = num(&v);
        } else {
            assert!(k.starts_with("m1") && order == 1, "{name} {k}");
            assert_eq!(ix.len(), 3);
            let (i, q, j) = (ix[0], ix[1], ix[2]);
            assert!(
                (1..=nrow).contains(&i) && (1..=nq).contains(&q) && (1..=ncol).contains(&j),
                "{name} {k}"
            );
            m1[q - 1][(i - 1, j - 1)] = num(&v);
        }
    }
    if structure == 3 {
        assert!(entries > 0, "{name}: structure 3 without entries");
    }
    Block {
        order,
        nq,
        structure,
        m0,
        m1,
    }
}

pub(crate) fn parse(text: &str) -> Parsed {
    let mut lines = text.lines();
    let first: Vec<&str> = lines.next().unwrap().split_whitespace().collect();
    let header = (first[0].parse().unwrap(), first[1].parse().unwrap());
    assert_eq!(lines.next().unwrap().trim(), "part");
    assert_eq!(key_value(lines.next().unwrap()).0, "new modal");
    assert_eq!(lines.next().unwrap().trim(), "refmod");
    let (mut mass, mut nelastq, mut freqs) = (0.0, 0, Vec::new());
    for l in lines.by_ref() {
        if l.trim() == "end refmod" {
            break;
        }
        let (k, v) = key_value(l);
        match k.as_str() {
            "mass" => mass = num(&v),
            "nelastq" => nelastq = v.parse().unwrap(),
            _ => {
                assert_eq!(indices(&k), vec![freqs.len() + 1], "{k}");
                let f = v.split_once(':').unwrap().1.trim_end_matches("Hz");
                freqs.push(f.trim().parse::<f64>().unwrap());
            }
        }
    }
    assert_eq!(lines.next().unwrap().trim(), "frame");
    let mut nodes = Vec::new();
    loop {
        let l = lines.next().unwrap();
        if l.trim() == "end frame" {
            break;
        }
        let (k, v) = key_value(l);
        assert_eq!(k, "new node");
        let id: u64 = v.parse().unwrap();
        assert_eq!(
            key_value(lines.next().unwrap()),
            ("rframe".into(), "body ref".into())
        );
        let mut blocks = HashMap::new();
        loop {
            let name = lines.next().unwrap().trim().to_string();
            if name == "end node" {
                break;
            }
            let b = block(&mut lines, &name);
            blocks.insert(name, b);
        }
        nodes.push((id, blocks));
    }
    let mut body = HashMap::new();
    loop {
        let name = lines.next().unwrap().trim().to_string();
        if name == "end modal" {
            break;
        }
        let b = block(&mut lines, &name);
        body.insert(name, b);
    }
    assert_eq!(lines.next().unwrap().trim(), "end part");
    assert!(lines.next().is_none());
    Parsed {
        header,
        mass,
        nelastq,
        freqs,
        nodes,
        body,
    }
}

/// max |a − b| / scale.
fn err(a: &Mat<f64>, b: &Mat<f64>, scale: f64) -> f64 {
    assert_eq!((a.nrows(), a.ncols()), (b.nrows(), b.ncols()));
    let mut e = 0.0f64;
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            e = e.max((a[(i, j)] - b[(i, j)]).abs());
        }
    }
    e / scale
}

fn max_abs(a: &Mat<f64>) -> f64 {
    a.col_iter()
        .flat_map(|c| c.iter().copied().collect::<Vec<_>>())
        .fold(0.0f64, |m, v| m.max(v.abs()))
}

/// Mass, m·c and the inertia tensor about the origin of the body with nodes at `y`, from
/// dense M: ∫ρ over the direction-diagonal blocks (averaged over the three directions).
fn dense_inertia(m: &Mat<f64>, y: &[[f64; 3]]) -> (f64, [f64; 3], [[f64; 3]; 3]) {
    let n = m.nrows();
    let (mut mass, mut s, mut q) = (0.0, [0.0; 3], [[0.0; 3]; 3]);
    for j in 0..n {
        for i in 0..n {
            if i % 3 != j % 3 || m[(i, j)] == 0.0 {
                continue;
            }
            let (pi, pj) = (y[i / 3], y[j / 3]);
            let v = m[(i, j)] / 3.0;
            mass += v;
            for a in 0..3 {
                s[a] += v * pj[a];
                for b in 0..3 {
                    q[a][b] += v * pi[a] * pj[b];
                }
            }
        }
    }
    let tr = q[0][0] + q[1][1] + q[2][2];
    let j = std::array::from_fn(|a| {
        std::array::from_fn(|b| (if a == b { tr } else { 0.0 }) - 0.5 * (q[a][b] + q[b][a]))
    });
    (mass, s, j)
}

/// The SID order of J (xx, yy, zz, xy, xz, yz) and of Oe's columns (ω1², ω2², ω3², ω1ω2,
/// ω2ω3, ω1ω3), as the EMBS library's reader uses them.
fn j6(j: &[[f64; 3]; 3]) -> Mat<f64> {
    let v = [j[0][0], j[1][1], j[2][2], j[0][1], j[0][2], j[1][2]];
    Mat::from_fn(6, 1, |i, _| v[i])
}

fn oe6(d: &[[f64; 3]; 3]) -> [f64; 6] {
    [
        d[0][0],
        d[1][1],
        d[2][2],
        d[0][1] + d[1][0],
        d[1][2] + d[2][1],
        d[0][2] + d[2][0],
    ]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[test]
fn sid_export_parses_back_and_matches_dense_invariants() {
    let (model, flex) = model_flex();
    let nodes = model.nodes.clone().unwrap();
    let (nn, n) = (nodes.len(), model.n());
    let phi = &flex.phi;
    let r = phi.ncols();
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("sid");
    sid::write(&dir, &model, &flex, None, &[]).unwrap();
    let text = std::fs::read_to_string(dir.join(sid::SID_FILE)).unwrap();
    let p = parse(&text);
    let inv = sid::invariants(&model, &flex).unwrap();

    // self-consistency: counts, every block's nq, the node blocks against Φ and the nodes
    assert_eq!(p.header, (nn, r));
    assert_eq!((p.nelastq, p.nodes.len()), (r, nn));
    for (k, (id, b)) in p.nodes.iter().enumerate() {
        assert_eq!(*id, k as u64 + 1);
        let mut names: Vec<&str> = b.keys().map(|s| s.as_str()).collect();
        names.sort_unstable();
        assert_eq!(names, ["AP", "origin", "phi", "psi"]);
        assert!(b.values().all(|t| t.nq == r));
        let o = &b["origin"];
        assert_eq!((o.order, o.structure), (1, 3));
        for a in 0..3 {
            assert_eq!(o.m0[(a, 0)], nodes[k][a]);
            for q in 0..r {
                assert_eq!(o.m1[q][(a, 0)], phi[(3 * k + a, q)]);
                assert_eq!(b["phi"].m0[(a, q)], phi[(3 * k + a, q)]);
            }
        }
        assert_eq!((b["psi"].structure, b["psi"].m0.ncols()), (0, r));
        assert_eq!((b["AP"].structure, &b["AP"].m0), (3, &Mat::identity(3, 3)));
    }
    let mut names: Vec<&str> = p.body.keys().map(|s| s.as_str()).collect();
    names.sort_unstable();
    assert_eq!(
        names,
        ["Cr", "Ct", "De", "Ge", "Gr", "J", "Ke", "Me", "Oe", "ksigma", "mdCM"]
    );
    assert!(p.body.values().all(|t| t.nq == r));
    assert_eq!(p.body["ksigma"].structure, 0);
    // the file holds the library's invariants to the last bit (17 significant digits)
    for (name, t) in inv.named() {
        let b = &p.body[name];
        assert_eq!(b.order, t.order(), "{name}");
        assert_eq!(b.m0, t.m0, "{name}");
        assert_eq!(b.m1, t.m1, "{name}");
    }

    // rigid-body properties against dense M
    let m = dense(&model.mass);
    let k = dense(&model.stiffness);
    let (mass, mc, j0) = dense_inertia(&m, &nodes);
    let em = (p.mass - mass).abs() / mass;
    let mdcm = &p.body["mdCM"];
    let ec = (0..3).fold(0.0f64, |e, a| e.max((mdcm.m0[(a, 0)] - mc[a]).abs()))
        / (mass * nodes.iter().flatten().fold(0.0f64, |x, v| x.max(v.abs())));
    let j0d = j6(&j0);
    let ej = err(&p.body["J"].m0, &j0d, max_abs(&j0d));
    println!("sid: mass {em:.3e}, m·c {ec:.3e}, J about the origin {ej:.3e} (rel. to dense M)");
    assert!(
        em <= 1e-12 && ec <= 1e-12 && ej <= 1e-12,
        "{em:e} {ec:e} {ej:e}"
    );
    assert!((p.mass - 0.1).abs() <= 1e-14);

    // Me, Ke against dense ΦᵀMΦ, ΦᵀKΦ; the frequencies of refmod
    let me = phi.transpose() * &m * phi;
    let ke = phi.transpose() * &k * phi;
    let e_me = err(&p.body["Me"].m0, &me, max_abs(&me));
    let e_ke = err(&p.body["Ke"].m0, &ke, max_abs(&ke));
    let e_f = (0..r).fold(0.0f64, |e, q| {
        let f = flex.eigenfrequencies_hz[q];
        let fk = ke[(q, q)].sqrt() / (2.0 * std::f64::consts::PI);
        e.max((p.freqs[q] - f).abs() / f)
            .max((p.freqs[q] - fk).abs() / fk)
    });
    println!("sid: Me {e_me:.3e}, Ke {e_ke:.3e}, frequencies {e_f:.3e} (rel.)");
    assert!(
        e_me <= 1e-12 && e_ke <= 1e-12 && e_f <= 1e-10,
        "{e_me:e} {e_ke:e} {e_f:e}"
    );
    assert_eq!(p.freqs, flex.eigenfrequencies_hz);

    // Ct, Cr against dense formulas; bounds by Cauchy–Schwarz in the M inner product
    let t = Mat::from_fn(n, 3, |i, a| if i % 3 == a { 1.0 } else { 0.0 });
    let rot = Mat::from_fn(n, 3, |i, b| cross(unit(b), nodes[i / 3])[i % 3]);
    let s_phi = |b: usize| {
        Mat::from_fn(n, r, |i, l| {
            let u = [0, 1, 2].map(|d| phi[(3 * (i / 3) + d, l)]);
            cross(unit(b), u)[i % 3]
        })
    };
    let ct0 = phi.transpose() * &m * &t;
    let cr0 = phi.transpose() * &m * &rot;
    let jmax = (0..3).fold(0.0f64, |x, a| x.max(j0[a][a]));
    let e_ct = err(&p.body["Ct"].m0, &ct0, mass.sqrt());
    let e_cr0 = err(&p.body["Cr"].m0, &cr0, jmax.sqrt());
    let cr1: Vec<Mat<f64>> = (0..3).map(|b| phi.transpose() * &m * s_phi(b)).collect();
    let mut e_cr1 = 0.0f64;
    for q in 0..r {
        let want = Mat::from_fn(r, 3, |kk, b| cr1[b][(kk, q)]);
        e_cr1 = e_cr1.max(err(&p.body["Cr"].m1[q], &want, 1.0));
    }
    let mean_axis = max_abs(&ct0) / mass.sqrt() + max_abs(&cr0) / jmax.sqrt();
    println!(
        "sid: Ct0 {e_ct:.3e}, Cr0 {e_cr0:.3e}, Cr1 {e_cr1:.3e} (vs dense, rel. to their \
         bounds); Ct0, Cr0 themselves {mean_axis:.3e} (mean-axis frame)"
    );
    assert!(e_ct <= 1e-12 && e_cr0 <= 1e-12 && e_cr1 <= 1e-12);
    assert!(mean_axis <= 1e-10, "{mean_axis:e}");
    // Cr1 is antisymmetric in the two modes; Ge_j = 2 Cr1(·, j, ·)
    let ge = &p.body["Ge"].m0;
    for q in 0..r {
        for kk in 0..r {
            for b in 0..3 {
                let (a1, a2) = (cr1[b][(kk, q)], cr1[b][(q, kk)]);
                assert!((a1 + a2).abs() <= 1e-12, "{a1} {a2}");
                assert!((ge[(kk, 3 * q + b)] - 2.0 * a1).abs() <= 1e-12);
            }
        }
    }

    // J1, Oe, Gr, mdCM1 against central differences of the deformed body's inertia
    let moved = |d: &[(usize, f64)]| -> Vec<[f64; 3]> {
        (0..nn)
            .map(|pp| {
                std::array::from_fn(|a| {
                    nodes[pp][a]
                        + d.iter()
                            .map(|&(q, e)| e * phi[(3 * pp + a, q)])
                            .sum::<f64>()
                })
            })
            .collect()
    };
    let eps = 1e-3;
    let jscale = max_abs(&j0d);
    let (mut e_j1, mut e_oe0, mut e_gr, mut e_md1) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    let mut b_diag = Vec::new();
    for q in 0..r {
        let (_, sp, jp) = dense_inertia(&m, &moved(&[(q, eps)]));
        let (_, sm, jm) = dense_inertia(&m, &moved(&[(q, -eps)]));
        let j1: [[f64; 3]; 3] =
            std::array::from_fn(|a| std::array::from_fn(|b| (jp[a][b] - jm[a][b]) / (2.0 * eps)));
        e_j1 = e_j1.max(err(&p.body["J"].m1[q], &j6(&j1), jscale));
        let oe0 = oe6(&j1).map(|v| -0.5 * v);
        for (i, v) in oe0.iter().enumerate() {
            e_oe0 = e_oe0.max((p.body["Oe"].m0[(q, i)] - v).abs() / jscale);
        }
        // Gr_q = J1_q − skew(Cr0_q)
        let c = [0, 1, 2].map(|b| cr0[(q, b)]);
        let skew = [[0.0, -c[2], c[1]], [c[2], 0.0, -c[0]], [-c[1], c[0], 0.0]];
        for a in 0..3 {
            for b in 0..3 {
                let want = j1[a][b] - skew[a][b];
                e_gr = e_gr.max((p.body["Gr"].m0[(a, 3 * q + b)] - want).abs() / jscale);
            }
            let md1 = (sp[a] - sm[a]) / (2.0 * eps);
            e_md1 = e_md1.max((mdcm.m1[q][(a, 0)] - md1).abs() / mass.sqrt());
        }
        // the second-order part B_qq = ∫Φ̃ᵀΦ̃ dm: (J(ε) + J(−ε) − 2J0) / 2ε²
        let bqq: [[f64; 3]; 3] = std::array::from_fn(|a| {
            std::array::from_fn(|b| (jp[a][b] + jm[a][b] - 2.0 * j0[a][b]) / (2.0 * eps * eps))
        });
        b_diag.push(bqq);
    }
    // Oe1(k, l) = −½ oe6(B_kl + B_lk); B_kl + B_lk from J(ε(Φ_k + Φ_l))
    let mut e_oe1 = 0.0f64;
    let mut oe1_scale = 0.0f64;
    for kk in 0..r {
        for l in 0..r {
            let d: [[f64; 3]; 3] = if kk == l {
                std::array::from_fn(|a| std::array::from_fn(|b| 2.0 * b_diag[kk][a][b]))
            } else {
                let (_, _, jp) = dense_inertia(&m, &moved(&[(kk, eps), (l, eps)]));
                let (_, _, jm) = dense_inertia(&m, &moved(&[(kk, -eps), (l, -eps)]));
                std::array::from_fn(|a| {
                    std::array::from_fn(|b| {
                        (jp[a][b] + jm[a][b] - 2.0 * j0[a][b]) / (2.0 * eps * eps)
                            - b_diag[kk][a][b]
                            - b_diag[l][a][b]
                    })
                })
            };
            let want = oe6(&d).map(|v| -0.5 * v);
            for (i, v) in want.iter().enumerate() {
                oe1_scale = oe1_scale.max(v.abs());
                e_oe1 = e_oe1.max((p.body["Oe"].m1[l][(kk, i)] - v).abs());
            }
        }
    }
    let e_oe1 = e_oe1 / oe1_scale;
    println!(
        "sid: central differences of the deformed body: J1 {e_j1:.3e}, Oe0 {e_oe0:.3e}, \
         Gr {e_gr:.3e}, mdCM1 {e_md1:.3e}, Oe1 {e_oe1:.3e}"
    );
    assert!(e_j1 <= 1e-10 && e_oe0 <= 1e-10 && e_gr <= 1e-10 && e_md1 <= 1e-10);
    assert!(e_oe1 <= 1e-10, "{e_oe1:e}");
}

fn unit(b: usize) -> [f64; 3] {
    std::array::from_fn(|a| if a == b { 1.0 } else { 0.0 })
}

#[test]
fn cli_export_sid() {
    let tmp = tempfile::tempdir().unwrap();
    let w = tmp.path();
    bar_and_roms(w);
    // the SID needs V: the error names the ROM and the fix, nothing is written
    let o = run(
        w,
        &[
            "export", "rom", "--model", "bar", "--format", "sid", "--points", "0", "--out", "s",
        ],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("rom") && err.contains("--keep-basis"), "{err}");
    assert!(!w.join("s").exists());
    let out = ok(
        w,
        &[
            "export", "romv", "--model", "bar", "--format", "sid", "--points", "0", "--out", "s",
        ],
    );
    assert!(
        out.contains(sid::SID_FILE) && out.contains("total mass 1.000000e-1"),
        "{out}"
    );
    let text = std::fs::read_to_string(w.join("s").join(sid::SID_FILE)).unwrap();
    let p = parse(&text);
    assert_eq!(p.nodes.len(), 1656 / 3);
    assert!((p.mass - 0.1).abs() <= 1e-14);
    assert!(out.contains(&format!("{} modes", p.nelastq)), "{out}");
}
