//! ROM exports for Nastran and MBDyn (docs/design.md §3.9, §4): the OP4 file read back by
//! sparsemor's reader (bit for bit) and by pyNastran; the DMIG bulk data read by pyNastran's
//! BDF reader, keyed by grid/component and scalar points; the MBDyn FEM file's rigid-body
//! inertia against a dense reference computed here and its modal matrices against the
//! projected ROM; the command's errors. The pyNastran checks are skipped (with a note) when
//! python3 lacks pyNastran.

use crate::cli::{ok, run};
use crate::common::dense;
use faer::Mat;
use sparsemor::body::Body;
use sparsemor::fe::{bar_model, paper_scene, BoxSpec};
use sparsemor::io::op4::{read_op4, Encoding};
use sparsemor::io::{dmig, mbdyn, op4};
use sparsemor::model::Model;
use sparsemor::reduce::craig_bampton::{self, CraigBamptonOptions};
use sparsemor::reduce::flexible::elastic_basis;
use sparsemor::reduce::linefit::{self, Interface, LineFitOptions, References};
use sparsemor::reduce::Rom;
use sparsemor::rigid;
use sparsemor::scene::Scene;
use sparsemor::sweep::no_progress;
use std::collections::HashMap;
use std::path::Path;
use std::process::Command;

/// A small free bar (3 × 3 × 9 nodes, N = 243): fast, and with all six rigid modes.
fn spec() -> BoxSpec {
    BoxSpec {
        elements: [2, 2, 8],
        size_m: [0.006, 0.008, 0.1],
        mass_kg: 0.1,
        young_pa: 2e10,
        poisson: 0.3,
    }
}

pub(crate) fn model_scene() -> (Model, Scene) {
    let s = spec();
    (bar_model(&s).unwrap(), paper_scene(&s))
}

/// Line-fitting ROM with V kept (physical coordinates only).
pub(crate) fn linefit_rom(model: &Model, scene: &Scene) -> Rom {
    let body = Body::new(model).unwrap();
    let mut opts = LineFitOptions::new(
        Interface::OutputsPlus(3),
        References::Explicit(vec![100.0, 400.0, 1600.0]),
    );
    opts.keep_basis = true;
    linefit::reduce(&body, scene, &opts, None, &no_progress).unwrap()
}

/// Craig–Bampton ROM: boundary DoFs, then 4 modal coordinates.
fn cb_rom(model: &Model, scene: &Scene) -> Rom {
    let body = Body::new(model).unwrap();
    let opts = CraigBamptonOptions::new(Interface::OutputsPlus(1), 4, 1.0e5);
    craig_bampton::reduce(&body, scene, &opts).unwrap()
}

/// True when python3 has pyNastran; prints why a check is skipped otherwise.
pub(crate) fn has_pynastran() -> bool {
    let ok = Command::new("python3")
        .args(["-c", "import pyNastran, numpy"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        println!("NOTE: python3 with pyNastran not found; the pyNastran check was skipped");
    }
    ok
}

pub(crate) fn python(script: &str, args: &[&Path]) -> String {
    let out = Command::new("python3")
        .arg("-c")
        .arg(script)
        .args(args)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

/// max |a − b| / max |b|.
fn rel(a: &Mat<f64>, b: &Mat<f64>) -> f64 {
    assert_eq!((a.nrows(), a.ncols()), (b.nrows(), b.ncols()));
    let mut num = 0.0f64;
    let mut den = 0.0f64;
    for j in 0..b.ncols() {
        for i in 0..b.nrows() {
            num = num.max((a[(i, j)] - b[(i, j)]).abs());
            den = den.max(b[(i, j)].abs());
        }
    }
    if den == 0.0 {
        num
    } else {
        num / den
    }
}

/// `name r c` then `i j value.hex()` lines, as the Python side prints matrices.
pub(crate) fn parse_matrices(text: &str) -> HashMap<String, Mat<f64>> {
    let mut out = HashMap::new();
    let mut cur: Option<(String, Mat<f64>)> = None;
    for line in text.lines() {
        let t: Vec<&str> = line.split_whitespace().collect();
        match t.as_slice() {
            ["matrix", name, r, c] => {
                if let Some((n, m)) = cur.take() {
                    out.insert(n, m);
                }
                cur = Some((
                    name.to_string(),
                    Mat::zeros(r.parse().unwrap(), c.parse().unwrap()),
                ));
            }
            [i, j, v] if cur.is_some() => {
                let m = &mut cur.as_mut().unwrap().1;
                m[(i.parse().unwrap(), j.parse().unwrap())] = parse_hex(v);
            }
            _ => {}
        }
    }
    if let Some((n, m)) = cur {
        out.insert(n, m);
    }
    out
}

/// Python's `float.hex()`.
fn parse_hex(s: &str) -> f64 {
    let (sign, s) = s.strip_prefix('-').map_or((1.0, s), |r| (-1.0, r));
    if s == "0x0.0p+0" {
        return sign * 0.0;
    }
    let s = s.strip_prefix("0x").unwrap();
    let (mant, exp) = s.split_once('p').unwrap();
    let (int, frac) = mant.split_once('.').unwrap_or((mant, ""));
    let mut bits = u64::from_str_radix(int, 16).unwrap();
    for c in frac.chars() {
        bits = bits * 16 + u64::from(c.to_digit(16).unwrap());
    }
    let e: i32 = exp.parse::<i32>().unwrap() - 4 * frac.len() as i32;
    sign * bits as f64 * 2f64.powi(e)
}

const PY_OP4: &str = r#"
import sys
import numpy as np
from pyNastran.op4.op4 import read_op4
mats = read_op4(sys.argv[1])
for name, mat in mats.items():
    a = mat.data
    a = a.toarray() if hasattr(a, "toarray") else np.asarray(a)
    print("matrix", name.strip(), a.shape[0], a.shape[1])
    for j in range(a.shape[1]):
        for i in range(a.shape[0]):
            if a[i, j] != 0.0:
                print(i, j, float(a[i, j]).hex())
"#;

#[test]
fn op4_export_round_trips_bitwise_and_through_pynastran() {
    let (model, scene) = model_scene();
    let rom = linefit_rom(&model, &scene);
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("op4");
    op4::write_rom(&dir, &rom).unwrap();
    let path = dir.join(op4::ROM_FILE);
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(
        text.starts_with(&format!(
            "{:8}{:8}       6       2MR      1P,3E23.16\n",
            rom.order(),
            rom.order()
        )),
        "{}",
        &text[..80]
    );
    let mats = read_op4(&path).unwrap();
    assert_eq!(mats.len(), 5);
    for ((m, (name, form)), (_, a)) in mats.iter().zip(op4::ROM_MATRICES).zip(rom.matrices()) {
        assert_eq!((m.name.as_str(), m.form, m.precision), (name, form, 2));
        assert_eq!((m.rows, m.cols), (a.nrows(), a.ncols()));
        assert_eq!(m.encoding, Encoding::Ascii);
        let back = dense(&m.entries.clone().into_csc(a.nrows().max(a.ncols()), false));
        for j in 0..a.ncols() {
            for i in 0..a.nrows() {
                assert_eq!(
                    back[(i, j)].to_bits(),
                    a[(i, j)].to_bits(),
                    "{name} ({i}, {j})"
                );
            }
        }
    }
    println!("op4: sparsemor's reader gives Mr, Dr, Kr, Br, Cr back bit for bit");
    // a second export into the now non-empty directory names it and the fix
    let e = op4::write_rom(&dir, &rom).unwrap_err().to_string();
    assert!(
        e.contains(&dir.display().to_string()) && e.contains("not empty"),
        "{e}"
    );
    if !has_pynastran() {
        return;
    }
    let py = parse_matrices(&python(PY_OP4, &[&path]));
    for ((name, _), (_, a)) in op4::ROM_MATRICES.iter().zip(rom.matrices()) {
        let b = &py[*name];
        let e = rel(b, a);
        println!("op4: pyNastran {name} rel. error {e:.3e}");
        assert!(e <= 1e-12, "{name}: {e:e}");
    }
}

const PY_DMIG: &str = r#"
import sys
import numpy as np
if not hasattr(np, 'in1d'):
    np.in1d = np.isin  # pyNastran 1.4.1 calls np.in1d, removed in NumPy 2.4
from pyNastran.bdf.bdf import BDF
model = BDF(debug=None)
model.read_bdf(sys.argv[1], punch=True, xref=False)
print("spoints", " ".join(str(s) for s in sorted(model.spoints)))
for name in sorted(model.dmig):
    m = model.dmig[name]
    a, rows, cols = m.get_matrix(is_sparse=False, apply_symmetry=True)
    print("form", name, m.matrix_form, m.tin)
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
fn dmig_export_reads_back_in_pynastran() {
    // the 16-character real keeps at least 11 significant digits (10 with a three-digit
    // exponent) and parses back
    for (k, v) in [
        1.0,
        -1.0,
        0.1,
        1.0 / 3.0,
        -2.0 / 3.0e-7,
        6.02214076e23,
        -1.234_567_890_123_456_7e-123,
        123_456_789.012_345_67,
        -9.999_999_999_999_999e99,
        5e-324,
        f64::MAX,
    ]
    .iter()
    .enumerate()
    {
        let s = dmig::real_field(*v, 16).unwrap();
        assert!(s.len() <= 16 && s.contains('.'), "{k}: '{s}'");
        let t = s.trim_start_matches('-');
        let at = t[1..].rfind(['+', '-']).map(|i| i + 1 + s.len() - t.len());
        let back: f64 = match at {
            Some(i) => format!("{}e{}", &s[..i], &s[i..]).parse().unwrap(),
            None => s.parse().unwrap(),
        };
        let tol = if v.abs().log10().abs() >= 99.0 {
            5e-10
        } else {
            5e-11
        };
        assert!(((back - v) / v).abs() <= tol, "{v:e} -> '{s}' -> {back:e}");
    }
    assert!(dmig::real_field(f64::NAN, 16).is_none());

    let (model, scene) = model_scene();
    let rom = cb_rom(&model, &scene);
    let keys = dmig::coordinates(&rom, &model, None, None).unwrap();
    let modal = rom.order() - rom.dofs.len();
    assert_eq!(modal, 4);
    let max_grid = (model.n() / 3) as u64;
    for (r, c) in keys.iter().enumerate() {
        match c.dof {
            Some(d) => {
                assert_eq!(d, rom.dofs[r]);
                assert_eq!((c.id, c.component), ((d / 3) as u64 + 1, (d % 3) as u8 + 1));
            }
            None => assert_eq!(
                (c.id, c.component),
                (max_grid + 1 + (r - rom.dofs.len()) as u64, 0)
            ),
        }
    }
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("dmig");
    dmig::write(&dir, &rom, &model, None, None).unwrap();
    let csv = std::fs::read_to_string(dir.join(dmig::MAP_FILE)).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], "row,id,component,kind,model_dof");
    assert_eq!(lines.len(), rom.order() + 1);
    for (r, c) in keys.iter().enumerate() {
        let want = match c.dof {
            Some(d) => format!("{r},{},{},grid,{d}", c.id, c.component),
            None => format!("{r},{},0,spoint,", c.id),
        };
        assert_eq!(lines[r + 1], want);
    }
    if !has_pynastran() {
        return;
    }
    let out = python(PY_DMIG, &[&dir.join(dmig::BULK_FILE)]);
    let spoints: Vec<u64> = out
        .lines()
        .find_map(|l| l.strip_prefix("spoints"))
        .unwrap()
        .split_whitespace()
        .map(|s| s.parse().unwrap())
        .collect();
    let want_spoints: Vec<u64> = keys
        .iter()
        .filter(|c| c.dof.is_none())
        .map(|c| c.id)
        .collect();
    assert_eq!(spoints, want_spoints);
    let index: HashMap<(u64, u8), usize> = keys
        .iter()
        .enumerate()
        .map(|(r, c)| ((c.id, c.component), r))
        .collect();
    let py = parse_matrices(&out);
    let damped = rom.dr.col_iter().any(|c| c.iter().any(|&v| v != 0.0));
    assert!(damped, "the bar has Rayleigh damping");
    for (name, a) in [("MAAX", &rom.mr), ("KAAX", &rom.kr), ("BAAX", &rom.dr)] {
        assert!(out.contains(&format!("form {name} 6 2")), "{out}");
        // pyNastran's row order → the ROM's
        let mut perm = vec![usize::MAX; rom.order()];
        for l in out
            .lines()
            .filter(|l| l.starts_with(&format!("key {name} ")))
        {
            let t: Vec<&str> = l.split_whitespace().collect();
            let (i, g, c): (usize, u64, u8) = (
                t[2].parse().unwrap(),
                t[3].parse().unwrap(),
                t[4].parse().unwrap(),
            );
            perm[i] = index[&(g, c)];
        }
        assert!(
            perm.iter().all(|&p| p != usize::MAX),
            "{name}: every row keyed"
        );
        let b = &py[name];
        let back = Mat::from_fn(rom.order(), rom.order(), |i, j| {
            let (pi, pj) = (
                perm.iter().position(|&p| p == i).unwrap(),
                perm.iter().position(|&p| p == j).unwrap(),
            );
            b[(pi, pj)]
        });
        let e = rel(&back, a);
        println!(
            "dmig: pyNastran {name} rel. error {e:.3e} (order {})",
            rom.order()
        );
        assert!(e <= 1e-12, "{name}: {e:e}");
    }
}

/// Rigid-body properties from dense M, per direction block: m = 1ᵀM_d1, m·c = 1ᵀM_d x,
/// Q = xᵀM_d x (averaged over the three directions), J_O = tr(Q) I − Q, moved to the centre.
fn dense_rigid_body(model: &Model) -> (f64, [f64; 3], [[f64; 3]; 3]) {
    let m = dense(&model.mass);
    let nodes = model.nodes.as_ref().unwrap();
    let n = model.n();
    let (mut mass, mut s, mut q) = (0.0, [0.0; 3], [[0.0; 3]; 3]);
    for i in 0..n {
        for j in 0..n {
            if i % 3 != j % 3 {
                continue;
            }
            let (pi, pj) = (nodes[i / 3], nodes[j / 3]);
            let v = m[(i, j)] / 3.0;
            mass += v;
            for k in 0..3 {
                s[k] += v * pj[k];
                for l in 0..3 {
                    q[k][l] += v * pi[k] * pj[l];
                }
            }
        }
    }
    let c = s.map(|x| x / mass);
    let tr = q[0][0] + q[1][1] + q[2][2];
    let c2: f64 = c.iter().map(|x| x * x).sum();
    let mut j = [[0.0; 3]; 3];
    for a in 0..3 {
        for b in 0..3 {
            let d = if a == b { 1.0 } else { 0.0 };
            j[a][b] = (tr * d - q[a][b]) - mass * (c2 * d - c[a] * c[b]);
        }
    }
    (mass, c, j)
}

/// The numbers after `** RECORD GROUP g` up to the next `**` line.
pub(crate) fn group(text: &str, g: usize) -> Vec<f64> {
    let head = format!("** RECORD GROUP {g},");
    let mut lines = text.lines().skip_while(|l| !l.starts_with(&head)).skip(1);
    let mut out = Vec::new();
    for l in lines.by_ref() {
        if l.starts_with("**") {
            if g == 8 && l.contains("MODE SHAPE #") {
                continue;
            }
            break;
        }
        out.extend(l.split_whitespace().map(|t| t.parse::<f64>().unwrap()));
    }
    out
}

#[test]
fn mbdyn_export_rigid_body_and_modal_matrices() {
    let (model, scene) = model_scene();
    let rom = linefit_rom(&model, &scene);
    let body = Body::new(&model).unwrap();
    let flex = elastic_basis(&body, &scene, &rom).unwrap();
    let rb = rigid::inertia(&model).unwrap();
    let (mass, c, j) = dense_rigid_body(&model);
    let em = (rb.mass - mass).abs() / mass;
    let nodes = model.nodes.as_ref().unwrap();
    let scale = nodes
        .iter()
        .flat_map(|p| p.iter())
        .fold(0.0f64, |a, x| a.max(x.abs()));
    let ec = (0..3).fold(0.0f64, |a, k| a.max((rb.center[k] - c[k]).abs())) / scale;
    let jmax = j.iter().flatten().fold(0.0f64, |a, x| a.max(x.abs()));
    let ej = (0..9).fold(0.0f64, |a, k| {
        a.max((rb.inertia[k / 3][k % 3] - j[k / 3][k % 3]).abs())
    }) / jmax;
    println!("mbdyn: rigid body vs dense M: mass {em:.3e}, centre {ec:.3e}, inertia {ej:.3e}");
    assert!(
        em <= 1e-12 && ec <= 1e-12 && ej <= 1e-12,
        "{em:e} {ec:e} {ej:e}"
    );
    // and the analytic box: 0.1 kg, the centre of the bounding box, m(b² + c²)/12
    let (lo, hi) = (0..3).fold(([f64::MAX; 3], [f64::MIN; 3]), |(mut lo, mut hi), k| {
        for p in nodes {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
        (lo, hi)
    });
    let l = spec().size_m;
    assert!((rb.mass - 0.1).abs() <= 1e-14);
    for k in 0..3 {
        assert!((rb.center[k] - (lo[k] + hi[k]) / 2.0).abs() <= 1e-15);
        let (a, b) = ((k + 1) % 3, (k + 2) % 3);
        let box_j = 0.1 * (l[a] * l[a] + l[b] * l[b]) / 12.0;
        assert!((rb.inertia[k][k] - box_j).abs() <= 1e-12 * box_j, "{k}");
    }

    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("mbdyn");
    mbdyn::write(&dir, &model, &flex, None, &[]).unwrap();
    let text = std::fs::read_to_string(dir.join(mbdyn::FEM_FILE)).unwrap();
    let r = flex.phi.ncols();
    let nn = nodes.len();
    let header: Vec<&str> = text
        .lines()
        .skip_while(|l| !l.starts_with("** RECORD GROUP 1,"))
        .nth(2)
        .unwrap()
        .split_whitespace()
        .collect();
    assert_eq!(
        header,
        ["REV0", &nn.to_string(), &r.to_string(), "0", "0", "0"]
    );
    let labels = group(&text, 2);
    assert_eq!(labels, (1..=nn).map(|k| k as f64).collect::<Vec<_>>());
    assert_eq!(group(&text, 3), vec![0.0; r]);
    assert_eq!(group(&text, 4), vec![0.0; r]);
    for k in 0..3 {
        assert_eq!(
            group(&text, 5 + k),
            nodes.iter().map(|p| p[k]).collect::<Vec<_>>()
        );
    }
    let shapes = group(&text, 8);
    assert_eq!(shapes.len(), r * nn * 6);
    for m in 0..r {
        for p in 0..nn {
            for a in 0..6 {
                let want = if a < 3 { flex.phi[(3 * p + a, m)] } else { 0.0 };
                assert_eq!(shapes[(m * nn + p) * 6 + a], want);
            }
        }
    }
    for (g, a) in [(9, &flex.rom.mr), (10, &flex.rom.kr), (13, &flex.rom.dr)] {
        let v = group(&text, g);
        let back = Mat::from_fn(r, r, |i, j| v[i * r + j]);
        let e = rel(&back, a);
        println!("mbdyn: record group {g} rel. error {e:.3e}");
        assert!(e <= 1e-12, "{g}: {e:e}");
    }
    let g12 = group(&text, 12);
    assert_eq!(g12.len(), 13);
    assert_eq!(g12[0], rb.mass);
    assert_eq!(&g12[1..4], &rb.center);
    assert_eq!(&g12[4..], rb.inertia.as_flattened());
    assert!(text.trim_end().ends_with("** END OF FILE"));
}

/// In `w`: the built-in bar (`bar`) and its line-fitting ROM without V (`rom`) and with V
/// (`romv`), by the command.
pub(crate) fn bar_and_roms(w: &Path) {
    ok(w, &["generate", "bar", "--out", "bar"]);
    for (out, keep) in [("rom", false), ("romv", true)] {
        let mut args = vec![
            "reduce",
            "bar",
            "--method",
            "linefit",
            "--extra-interface",
            "5",
            "--ref-freqs",
            "50,100,200,400,800",
            "--out",
            out,
        ];
        if keep {
            args.push("--keep-basis");
        }
        ok(w, &args);
    }
}

#[test]
fn cli_export_op4_dmig_mbdyn() {
    let tmp = tempfile::tempdir().unwrap();
    let w = tmp.path();
    bar_and_roms(w);
    let out = ok(
        w,
        &[
            "export", "rom", "--model", "bar", "--format", "op4", "--out", "op4",
        ],
    );
    assert!(out.contains("rom.op4"), "{out}");
    assert!(w.join("op4").join(op4::ROM_FILE).is_file());
    let out = ok(
        w,
        &[
            "export", "rom", "--model", "bar", "--format", "dmig", "--out", "dmig",
        ],
    );
    assert!(out.contains("MAAX, KAAX, BAAX"), "{out}");
    assert!(w.join("dmig").join(dmig::BULK_FILE).is_file());
    assert!(w.join("dmig").join(dmig::MAP_FILE).is_file());
    // mbdyn needs V: the error names the ROM and the fix, nothing is written
    let o = run(
        w,
        &[
            "export", "rom", "--model", "bar", "--format", "mbdyn", "--points", "0", "--out", "mb",
        ],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("rom") && err.contains("--keep-basis"), "{err}");
    assert!(!w.join("mb").exists());
    let out = ok(
        w,
        &[
            "export", "romv", "--model", "bar", "--format", "mbdyn", "--points", "0", "--out", "mb",
        ],
    );
    assert!(out.contains("total mass 1.000000e-1"), "{out}");
    assert!(w.join("mb").join(mbdyn::FEM_FILE).is_file());
    // a non-empty output directory: named, with the fix, before any work
    let o = run(
        w,
        &[
            "export", "rom", "--model", "bar", "--format", "op4", "--out", "dmig",
        ],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(
        err.contains("dmig") && err.contains("not empty") && err.contains("remove it"),
        "{err}"
    );
}
