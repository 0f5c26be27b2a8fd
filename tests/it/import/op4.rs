//! Nastran OP4 (the reader `io::op4::read_op4`, the import `io::import::nastran`): round trips
//! through the library writer `io::op4` (ASCII and binary, both byte orders, dense,
//! string-sparse and BIGMAT records), the pyNastran cross-check, one test per bad-file class,
//! and `sparsemor import` end to end.

use crate::common::dense;
use proptest::prelude::*;
use sparsemor::fe::{bar_model, BoxSpec};
use sparsemor::io::import::{self, Direction, Format};
use sparsemor::io::op4::{
    self, columns_of_csc as columns, read_op4, Encoding as Enc, Layout as Lay, Matrix as Mat4,
};
use sparsemor::sparse::Csc;
use sparsemor::Error;
use std::path::{Path, PathBuf};

/// Appends `m` with the library writer (`io::op4`, which the ROM export uses too).
pub fn write_op4(out: &mut Vec<u8>, m: &Mat4, enc: Enc, lay: Lay) {
    op4::append(out, m, enc, lay).unwrap();
}

fn scratch() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

fn csc(n: usize, cols: &[Vec<(usize, f64)>]) -> Csc {
    let mut t = sparsemor::sparse::Triplets::default();
    for (j, c) in cols.iter().enumerate() {
        for &(i, v) in c {
            if v != 0.0 {
                t.push(i, j, v);
            }
        }
    }
    t.into_csc(n, false)
}

fn same(a: &Csc, b: &Csc) -> bool {
    a.nrows() == b.nrows()
        && a.ncols() == b.ncols()
        && (0..a.ncols()).all(|j| {
            a.row_idx_of_col_raw(j) == b.row_idx_of_col_raw(j) && a.val_of_col(j) == b.val_of_col(j)
        })
}

/// A random symmetric n×n matrix, columns of (row, value), full storage.
fn symmetric(n: usize, raw: &[(usize, usize, f64)], single: bool) -> Vec<Vec<(usize, f64)>> {
    let mut d = vec![vec![0.0; n]; n];
    for (i, row) in d.iter_mut().enumerate() {
        row[i] = 1.0 + i as f64;
    }
    for &(i, j, v) in raw {
        let (i, j) = (i % n, j % n);
        let v = if single { f64::from(v as f32) } else { v };
        d[i][j] = v;
        d[j][i] = v;
    }
    (0..n)
        .map(|j| {
            (0..n)
                .filter(|&i| d[i][j] != 0.0)
                .map(|i| (i, d[i][j]))
                .collect()
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]
    #[test]
    fn op4_round_trip(n in 1usize..14,
                      raw in proptest::collection::vec((0usize..14, 0usize..14, -1e9f64..1e9), 0..40),
                      enc in prop_oneof![Just(Enc::Ascii), Just(Enc::BinaryLittleEndian), Just(Enc::BinaryBigEndian)],
                      lay in prop_oneof![Just(Lay::Dense), Just(Lay::Sparse), Just(Lay::BigMat)],
                      single in any::<bool>(), lower in any::<bool>(), second in any::<bool>()) {
        let full = symmetric(n, &raw, single);
        let stored: Vec<Vec<(usize, f64)>> = full
            .iter()
            .enumerate()
            .map(|(j, c)| c.iter().copied().filter(|e| !lower || e.0 >= j).collect())
            .collect();
        let ty = if single { 1 } else { 2 };
        let mut bytes = Vec::new();
        write_op4(&mut bytes, &Mat4 { name: "KAA", rows: n, cols: stored.clone(), form: 6, precision: ty }, enc, lay);
        if second {
            write_op4(&mut bytes, &Mat4 { name: "MAA", rows: n, cols: full.clone(), form: 1, precision: ty }, enc, lay);
        }
        let tmp = scratch();
        let p = tmp.path().join("a.op4");
        std::fs::write(&p, &bytes).unwrap();
        let ms = read_op4(&p).unwrap();
        prop_assert_eq!(ms.len(), 1 + usize::from(second));
        let m = &ms[0];
        prop_assert_eq!((m.name.as_str(), m.rows, m.cols, m.form, m.precision), ("KAA", n, n, 6, ty));
        prop_assert_eq!(m.bigmat, lay == Lay::BigMat);
        prop_assert_eq!(m.encoding, enc);
        prop_assert!(same(&m.entries.clone().into_csc(n, false), &csc(n, &stored)));
        if second {
            prop_assert!(same(&ms[1].entries.clone().into_csc(n, false), &csc(n, &full)));
            // Through the import: K (one triangle, form 6) is mirrored to full storage.
            let imp = import::read(std::slice::from_ref(&p));
            if n % 6 == 0 {
                let imp = imp.unwrap();
                prop_assert!(same(&imp.stiffness, &csc(n, &full)));
                prop_assert!(same(&imp.mass, &csc(n, &full)));
            } else {
                let e = imp.unwrap_err().to_string();
                prop_assert!(e.contains("DoF map"), "{}", e);
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]
    /// Corrupted files (bytes overwritten, the file cut) give errors, never panics.
    #[test]
    fn op4_reader_never_panics(enc in prop_oneof![Just(Enc::Ascii), Just(Enc::BinaryLittleEndian), Just(Enc::BinaryBigEndian)],
                               lay in prop_oneof![Just(Lay::Dense), Just(Lay::Sparse), Just(Lay::BigMat)],
                               edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 0..6),
                               cut in any::<usize>(), cut_it in any::<bool>()) {
        let mut b = small("KAA", 7, enc, lay, 2);
        b.extend(small("MAA", 7, enc, lay, 1));
        for (at, v) in edits {
            let n = b.len();
            b[at % n] = if enc == Enc::Ascii { b"0123456789-+ E.\n"[v as usize % 16] } else { v };
        }
        if cut_it {
            b.truncate(cut % (b.len() + 1));
        }
        let tmp = scratch();
        let p = tmp.path().join("x.op4");
        std::fs::write(&p, &b).unwrap();
        let _ = read_op4(&p);
        let _ = import::read(std::slice::from_ref(&p));
    }
}

/// K and M in one file, the assumed DoF map (N = 12), and a DoF map file.
#[test]
fn op4_import_with_assumed_and_given_dof_map() {
    let n = 12;
    let k = symmetric(n, &[(0, 1, -0.5), (3, 7, 0.25)], false);
    let m = symmetric(n, &[], false);
    let mut bytes = Vec::new();
    write_op4(
        &mut bytes,
        &Mat4 {
            name: "KGG",
            rows: n,
            cols: k.clone(),
            form: 6,
            precision: 2,
        },
        Enc::BinaryBigEndian,
        Lay::Sparse,
    );
    write_op4(
        &mut bytes,
        &Mat4 {
            name: "MGG",
            rows: n,
            cols: m.clone(),
            form: 6,
            precision: 2,
        },
        Enc::BinaryBigEndian,
        Lay::Sparse,
    );
    let tmp = scratch();
    let p = tmp.path().join("model.op4");
    std::fs::write(&p, &bytes).unwrap();
    let imp = import::read(std::slice::from_ref(&p)).unwrap();
    assert_eq!(imp.format, Format::NastranOp4);
    assert_eq!(imp.format.name(), "nastran-op4");
    assert_eq!(imp.dofs_per_node, 6);
    assert_eq!(imp.dofs[7].node, 2);
    assert_eq!(imp.dofs[7].dir, Direction::Y);
    assert!(
        imp.notes.iter().any(|n| n.contains("ASSUMED")),
        "{:?}",
        imp.notes
    );
    assert!(
        imp.notes.iter().any(|n| n.contains("lumped")),
        "{:?}",
        imp.notes
    );
    assert!(same(&imp.stiffness, &csc(n, &k)));
    // A DoF map: 4 solid nodes 10, 20, 30, 40 with x, y, z.
    let map = tmp.path().join("dofs.csv");
    let rows: String = (0..n)
        .map(|i| format!("{},{}\n", 10 * (i / 3 + 1), i % 3 + 1))
        .collect();
    std::fs::write(&map, format!("node,component\n{rows}")).unwrap();
    let imp = import::read(&[p.clone(), map.clone()]).unwrap();
    assert_eq!(imp.dofs_per_node, 3);
    assert_eq!(imp.dofs[5].to_string(), "20:z");
    assert!(!imp.notes.iter().any(|n| n.contains("ASSUMED")));
    // K= / M= roles for files holding one matrix under other names.
    let (kp, mp) = (tmp.path().join("a.op4"), tmp.path().join("b.op4"));
    let mut kb = Vec::new();
    write_op4(
        &mut kb,
        &Mat4 {
            name: "STIFF",
            rows: n,
            cols: k.clone(),
            form: 1,
            precision: 2,
        },
        Enc::Ascii,
        Lay::Dense,
    );
    let mut mb = Vec::new();
    write_op4(
        &mut mb,
        &Mat4 {
            name: "MASS",
            rows: n,
            cols: m.clone(),
            form: 6,
            precision: 1,
        },
        Enc::BinaryLittleEndian,
        Lay::Dense,
    );
    std::fs::write(&kp, kb).unwrap();
    std::fs::write(&mp, mb).unwrap();
    let args = [
        PathBuf::from(format!("K={}", kp.display())),
        PathBuf::from(format!("M={}", mp.display())),
    ];
    let imp = import::read(&args).unwrap();
    assert!(same(&imp.stiffness, &csc(n, &k)));
    assert!(
        imp.notes.iter().any(|n| n.contains("single precision")),
        "{:?}",
        imp.notes
    );
}

fn expect(e: Error, needles: &[&str]) {
    let msg = e.to_string();
    for n in needles {
        assert!(msg.contains(n), "'{msg}' lacks '{n}'");
    }
}

fn small(name: &str, n: usize, enc: Enc, lay: Lay, ty: i32) -> Vec<u8> {
    let mut b = Vec::new();
    let cols = symmetric(n, &[(0, 1, -0.5)], false);
    write_op4(
        &mut b,
        &Mat4 {
            name,
            rows: n,
            cols,
            form: 6,
            precision: ty,
        },
        enc,
        lay,
    );
    b
}

#[test]
fn op4_bad_files() {
    let tmp = scratch();
    let write = |name: &str, b: &[u8]| -> PathBuf {
        let p = tmp.path().join(name);
        std::fs::write(&p, b).unwrap();
        p
    };
    let good = small("KAA", 6, Enc::BinaryLittleEndian, Lay::Sparse, 2);
    // Truncated record (binary): cut inside the last column record.
    let p = write("trunc.op4", &good[..good.len() - 30]);
    expect(
        read_op4(&p).unwrap_err(),
        &["trunc.op4", "byte ", "truncated"],
    );
    // Truncated ASCII file: no end record.
    let a = small("KAA", 6, Enc::Ascii, Lay::Dense, 2);
    let text = String::from_utf8(a).unwrap();
    let cut: String = text.lines().take(5).map(|l| format!("{l}\n")).collect();
    let p = write("trunc_ascii.op4", cut.as_bytes());
    expect(
        read_op4(&p).unwrap_err(),
        &["trunc_ascii.op4", "line 1", "truncated"],
    );
    // A wrong record-length marker: the trailing marker of the header record.
    let mut b = good.clone();
    b[28] = 20;
    let p = write("marker.op4", &b);
    expect(
        read_op4(&p).unwrap_err(),
        &["marker.op4", "byte 0", "says 20"],
    );
    // A declared record size larger than the file: the first column record claims 10^6 bytes.
    let mut b = good.clone();
    b[32..36].copy_from_slice(&1_000_000i32.to_le_bytes());
    let p = write("big_record.op4", &b);
    expect(
        read_op4(&p).unwrap_err(),
        &["big_record.op4", "byte 32", "1000000 bytes"],
    );
    // A hostile header: 2^31-1 rows and columns and a handful of entries.
    let k = small("KAA", 6, Enc::BinaryLittleEndian, Lay::BigMat, 2);
    let mut b = k.clone();
    b.extend(small("MAA", 6, Enc::BinaryLittleEndian, Lay::BigMat, 2));
    let huge = i32::MAX - 1;
    for (at, end) in [(4, k.len()), (k.len() + 4, b.len())] {
        b[at..at + 4].copy_from_slice(&huge.to_le_bytes());
        b[at + 4..at + 8].copy_from_slice(&(-huge).to_le_bytes());
        // The end record (the last 28 bytes) names column N + 1.
        b[end - 24..end - 20].copy_from_slice(&(huge + 1).to_le_bytes());
    }
    let p = write("huge.op4", &b);
    let e = import::read(std::slice::from_ref(&p)).unwrap_err();
    expect(e, &["huge.op4", "byte 0", "declares N = 2147483646"]);
    // ASCII header with 10^12 rows.
    let p = write(
        "huge_ascii.op4",
        format!(
            "{:8}{:>14}{:8}{:8} {:<8}1P,3E23.16\n",
            1, 1_000_000_000_000i64, 6, 2, "KAA"
        )
        .as_bytes(),
    );
    expect(read_op4(&p).unwrap_err(), &["huge_ascii.op4:1", "rows"]);
    let p = write(
        "min_ascii.op4",
        format!(
            "{:8}{:>21}{:8}{:8} {:<8}1P,3E23.16\n",
            1,
            i64::MIN,
            6,
            2,
            "KAA"
        )
        .as_bytes(),
    );
    expect(read_op4(&p).unwrap_err(), &["min_ascii.op4:1", "rows"]);
    // Complex type.
    let mut b = good.clone();
    b[16..20].copy_from_slice(&4i32.to_le_bytes());
    let p = write("complex.op4", &b);
    expect(
        read_op4(&p).unwrap_err(),
        &["complex.op4", "byte 0", "KAA", "complex", "type 4"],
    );
    let text = String::from_utf8(small("MAA", 6, Enc::Ascii, Lay::Sparse, 2)).unwrap();
    let p = write(
        "complex_ascii.op4",
        text.replacen("       6       2MAA", "       6       3MAA", 1)
            .as_bytes(),
    );
    expect(
        read_op4(&p).unwrap_err(),
        &["complex_ascii.op4:1", "MAA", "type 3"],
    );
    // A matrix missing: no mass.
    let p = write("k_only.op4", &good);
    expect(
        import::read(std::slice::from_ref(&p)).unwrap_err(),
        &["no mass matrix", "k_only.op4", "MAA"],
    );
    // K and M of different sizes.
    let mut b = good.clone();
    b.extend(small("MAA", 12, Enc::BinaryLittleEndian, Lay::Dense, 2));
    let p = write("sizes.op4", &b);
    expect(
        import::read(std::slice::from_ref(&p)).unwrap_err(),
        &[
            "mismatched sizes",
            "KAA in",
            "sizes.op4",
            "byte 0",
            "MAA in",
            "6x6",
            "12x12",
        ],
    );
    // A value outside the declared rows (ASCII): names the line.
    let text = String::from_utf8(small("KAA", 3, Enc::Ascii, Lay::Dense, 2)).unwrap();
    let p = write(
        "rows.op4",
        text.replacen("       2       1       4", "       2       3       4", 1)
            .as_bytes(),
    );
    expect(
        read_op4(&p).unwrap_err(),
        &["rows.op4:", "more values than the 3 rows"],
    );
    // N not a multiple of 6 and no DoF map.
    let mut b = small("KAA", 4, Enc::BinaryBigEndian, Lay::BigMat, 2);
    b.extend(small("MAA", 4, Enc::BinaryBigEndian, Lay::BigMat, 2));
    let p = write("nomap.op4", &b);
    expect(
        import::read(std::slice::from_ref(&p)).unwrap_err(),
        &["DoF map", "N = 4"],
    );
}

/// Runs `python3 script args`; `None` (and a note) when pyNastran is not installed.
fn python(script: &str, args: &[&Path]) -> Option<()> {
    let ok = std::process::Command::new("python3")
        .args(["-c", "import pyNastran, scipy"])
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false);
    if !ok {
        println!("note: python3 with pyNastran and scipy not available; the pyNastran cross-check was skipped");
        return None;
    }
    let out = std::process::Command::new("python3")
        .arg("-c")
        .arg(script)
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    print!("{}", String::from_utf8_lossy(&out.stdout));
    Some(())
}

/// A dense matrix as pyNastran's side wrote it: `n` then `i j value` rows (repr floats).
fn read_values(p: &Path) -> Csc {
    let text = std::fs::read_to_string(p).unwrap();
    let mut lines = text.lines();
    let n: usize = lines.next().unwrap().trim().parse().unwrap();
    let mut cols = vec![Vec::new(); n];
    for l in lines {
        let t: Vec<&str> = l.split_whitespace().collect();
        let (i, j, v): (usize, usize, f64) = (
            t[0].parse().unwrap(),
            t[1].parse().unwrap(),
            t[2].parse().unwrap(),
        );
        cols[j].push((i, v));
    }
    csc(n, &cols)
}

/// max |a - b| / max |b|, same pattern.
fn rel(a: &Csc, b: &Csc) -> f64 {
    assert!((0..a.ncols()).all(|j| a.row_idx_of_col_raw(j) == b.row_idx_of_col_raw(j)));
    let max_b = b.val().iter().fold(0.0f64, |m, v| m.max(v.abs()));
    a.val()
        .iter()
        .zip(b.val())
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()))
        / max_b
}

const PY_WRITE: &str = r#"
import sys, numpy as np
from scipy.sparse import coo_matrix
from pyNastran.op4.op4 import OP4
out = sys.argv[1]
rng = np.random.default_rng(7)
n = 12
def sym(diag):
    a = np.zeros((n, n))
    for _ in range(20):
        i, j = rng.integers(0, n, 2)
        a[i, j] = a[j, i] = rng.uniform(-1, 1) * 10.0 ** rng.integers(-8, 9)
    a[np.diag_indices(n)] = diag * rng.uniform(1, 2, n)
    return a
k, m = sym(1e6), sym(1.0)
def dump(a, name):
    with open(f"{out}/{name}.txt", "w") as f:
        f.write(f"{n}\n")
        for j in range(n):
            for i in range(n):
                if a[i, j] != 0.0:
                    f.write(f"{i} {j} {float(a[i, j])!r}\n")
dump(k, "K"); dump(m, "M")
op4 = OP4()
op4.write_op4(f"{out}/dense.op4", {"KAA": (6, k), "MAA": (6, m)}, is_binary=False)
op4.write_op4(f"{out}/sparse.op4", {"KAA": (6, coo_matrix(k)), "MAA": (6, coo_matrix(m))}, is_binary=False)
try:
    op4.write_op4(f"{out}/binary.op4", {"KAA": (6, k), "MAA": (6, m)}, is_binary=True)
    print("pyNastran binary write: ok")
except Exception as e:
    import os
    os.remove(f"{out}/binary.op4")
    print(f"pyNastran binary write failed: {e!r}")
"#;

const PY_READ: &str = r#"
import sys
from pyNastran.op4.op4 import read_op4
src, out = sys.argv[1], sys.argv[2]
mats = read_op4(src)
for name, mat in mats.items():
    a = mat.data
    a = a.toarray() if hasattr(a, "toarray") else a
    with open(f"{out}/{name}.txt", "w") as f:
        f.write(f"{a.shape[0]}\n")
        for j in range(a.shape[1]):
            for i in range(a.shape[0]):
                if a[i, j] != 0.0:
                    f.write(f"{i} {j} {float(a[i, j])!r}\n")
"#;

/// pyNastran writes K and M (ASCII dense and sparse; binary if its writer works), sparsemor
/// reads them; and pyNastran reads the binary files of the test writer (both byte orders,
/// dense and sparse records). Binary doubles must agree exactly, 16-digit ASCII to 1e-15.
#[test]
fn op4_pynastran_cross_check() {
    let tmp = scratch();
    let dir = tmp.path();
    if python(PY_WRITE, &[dir]).is_none() {
        return;
    }
    let (k, m) = (
        read_values(&dir.join("K.txt")),
        read_values(&dir.join("M.txt")),
    );
    for f in ["dense.op4", "sparse.op4", "binary.op4"] {
        let p = dir.join(f);
        if !p.exists() {
            continue;
        }
        let imp = import::read(std::slice::from_ref(&p)).unwrap();
        let (ek, em) = (rel(&imp.stiffness, &k), rel(&imp.mass, &m));
        println!("pyNastran {f} -> sparsemor: K rel. error {ek:.3e}, M rel. error {em:.3e}");
        let tol = if f == "binary.op4" { 0.0 } else { 1e-15 };
        assert!(ek <= tol && em <= tol, "{f}: {ek:e} {em:e}");
    }
    // The other direction: pyNastran reads binary files of the test writer.
    for (enc, lay) in [
        (Enc::BinaryLittleEndian, Lay::Dense),
        (Enc::BinaryBigEndian, Lay::Dense),
        (Enc::BinaryLittleEndian, Lay::Sparse),
        (Enc::BinaryBigEndian, Lay::Sparse),
    ] {
        let mut b = Vec::new();
        write_op4(
            &mut b,
            &Mat4 {
                name: "KAA",
                rows: 12,
                cols: columns(&k, false),
                form: 6,
                precision: 2,
            },
            enc,
            lay,
        );
        write_op4(
            &mut b,
            &Mat4 {
                name: "MAA",
                rows: 12,
                cols: columns(&m, false),
                form: 6,
                precision: 2,
            },
            enc,
            lay,
        );
        let p = dir.join(format!("{enc:?}_{lay:?}.op4"));
        std::fs::write(&p, &b).unwrap();
        let sub = dir.join(format!("{enc:?}_{lay:?}"));
        std::fs::create_dir(&sub).unwrap();
        python(PY_READ, &[&p, &sub]).unwrap();
        let (pk, pm) = (
            read_values(&sub.join("KAA.txt")),
            read_values(&sub.join("MAA.txt")),
        );
        let imp = import::read(std::slice::from_ref(&p)).unwrap();
        let (ek, em) = (rel(&imp.stiffness, &pk), rel(&imp.mass, &pm));
        println!("test writer {enc:?} {lay:?} -> pyNastran vs sparsemor: K {ek:.3e}, M {em:.3e}");
        assert!(ek == 0.0 && em == 0.0);
        assert!(same(&imp.stiffness, &k) && same(&imp.mass, &m));
    }
}

/// `sparsemor import K.op4 M.op4 dofs.csv --out DIR` on a small bar, then the model directory
/// holds the same K and M; and one file holding both.
#[test]
fn op4_cli_import_end_to_end() {
    let model = bar_model(&BoxSpec {
        elements: [1, 1, 3],
        size_m: [0.01, 0.01, 0.1],
        mass_kg: 0.1,
        young_pa: 2e11,
        poisson: 0.3,
    })
    .unwrap();
    let n = model.stiffness.nrows();
    let tmp = scratch();
    let (kp, mp, both) = (
        tmp.path().join("K.op4"),
        tmp.path().join("M.op4"),
        tmp.path().join("km.op4"),
    );
    let (mut kb, mut mb) = (Vec::new(), Vec::new());
    write_op4(
        &mut kb,
        &Mat4 {
            name: "KAA",
            rows: n,
            cols: columns(&model.stiffness, true),
            form: 6,
            precision: 2,
        },
        Enc::BinaryLittleEndian,
        Lay::Sparse,
    );
    write_op4(
        &mut mb,
        &Mat4 {
            name: "MAA",
            rows: n,
            cols: columns(&model.mass, false),
            form: 6,
            precision: 2,
        },
        Enc::Ascii,
        Lay::Dense,
    );
    std::fs::write(&kp, &kb).unwrap();
    std::fs::write(&mp, &mb).unwrap();
    let mut bb = Vec::new();
    write_op4(
        &mut bb,
        &Mat4 {
            name: "KGG",
            rows: n,
            cols: columns(&model.stiffness, false),
            form: 6,
            precision: 2,
        },
        Enc::BinaryBigEndian,
        Lay::BigMat,
    );
    write_op4(
        &mut bb,
        &Mat4 {
            name: "MGG",
            rows: n,
            cols: columns(&model.mass, true),
            form: 6,
            precision: 2,
        },
        Enc::BinaryBigEndian,
        Lay::BigMat,
    );
    std::fs::write(&both, &bb).unwrap();
    let map = tmp.path().join("dofs.txt");
    let rows: String = (0..n)
        .map(|i| format!("{} {}\n", i / 3 + 1, i % 3 + 1))
        .collect();
    std::fs::write(&map, rows).unwrap();
    for (k, sources) in [
        ("two", vec![kp.clone(), mp.clone(), map.clone()]),
        ("one", vec![both.clone(), map.clone()]),
    ] {
        let out = tmp.path().join(format!("model_{k}"));
        let mut args: Vec<String> = vec!["import".into()];
        args.extend(sources.iter().map(|p| p.display().to_string()));
        args.extend([
            "--out".into(),
            out.display().to_string(),
            "--band".into(),
            "0:50000".into(),
        ]);
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_sparsemor"))
            .args(&args)
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{}\n{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        let (read, _, _) = sparsemor::io::model_dir::read(&out).unwrap();
        assert!(
            dense(&read.stiffness) == dense(&model.stiffness),
            "{k}: K differs"
        );
        assert!(dense(&read.mass) == dense(&model.mass), "{k}: M differs");
        let manifest = std::fs::read_to_string(out.join("model.toml")).unwrap();
        assert!(manifest.contains("nastran-op4"), "{manifest}");
    }
}
