//! The Harwell–Boeing (HBMAT) reader, `io::import::harwell_boeing`: cross-check against scipy's
//! `hb_write`, a property test with a test-side writer in several Fortran formats, one test
//! per bad-file class, and an APDL Math set with HB K and M through `io::import`.

use crate::common::dense;
use proptest::prelude::*;
use sparsemor::fe::{bar_model, BoxSpec};
use sparsemor::io::import::harwell_boeing;
use sparsemor::io::import::{self, Format};
use sparsemor::sparse::Csc;
use sparsemor::Error;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// How the test-side writer prints the values.
#[derive(Clone, Copy, Debug)]
struct RealFmt {
    per_line: usize,
    /// Exponent letter, `E` or `D`.
    letter: char,
    /// `1P` scale (d.ddd) instead of 0.ddd.
    one_p: bool,
    /// `1P,` instead of `1P` in the format.
    comma: bool,
    /// Extra width beyond the longest field (0: fields run together).
    pad: usize,
}

/// A value as Fortran's `Ew.d`/`Dw.d` (or `1P,Ew.d`) prints it with 17 significant digits;
/// an exponent of 3 digits drops the letter (`0.15-120`), as Fortran does.
fn fortran_real(v: f64, f: &RealFmt) -> String {
    let s = format!("{:.16e}", v); // d.dddddddddddddddde±x
    let (mant, exp) = s.split_once('e').unwrap();
    let mut exp: i32 = exp.parse().unwrap();
    let (neg, mant) = match mant.strip_prefix('-') {
        Some(m) => (true, m),
        None => (false, mant),
    };
    let digits: String = mant.chars().filter(|c| *c != '.').collect();
    let body = if f.one_p {
        format!("{}.{}", &digits[..1], &digits[1..])
    } else if v == 0.0 {
        format!("0.{digits}")
    } else {
        exp += 1;
        format!("0.{digits}")
    };
    let e = if exp.abs() >= 100 {
        format!("{}{:03}", if exp < 0 { '-' } else { '+' }, exp.abs())
    } else {
        format!(
            "{}{}{:02}",
            f.letter,
            if exp < 0 { '-' } else { '+' },
            exp.abs()
        )
    };
    format!("{}{body}{e}", if neg { "-" } else { "" })
}

/// Writes a Harwell–Boeing file of the 0-based CSC parts; `int_pad` extra width for the
/// integers (0: the widest runs into its neighbour).
#[allow(clippy::too_many_arguments)]
fn write_hb(
    path: &Path,
    mxtype: &str,
    nrow: usize,
    ncol: usize,
    ptr: &[usize],
    rows: &[usize],
    vals: &[f64],
    int_per_line: usize,
    int_pad: usize,
    rf: &RealFmt,
) {
    let nnz = vals.len();
    let iw = (nnz + 1).max(nrow).to_string().len() + int_pad;
    let fields: Vec<String> = vals.iter().map(|&v| fortran_real(v, rf)).collect();
    let vw = fields.iter().map(String::len).max().unwrap_or(1) + rf.pad;
    let d = if rf.one_p { 16 } else { 17 };
    let lines = |items: usize, per: usize| items.div_ceil(per);
    let (pc, ic, vc) = (
        lines(ncol + 1, int_per_line),
        lines(nnz, int_per_line),
        lines(nnz, rf.per_line),
    );
    let mut out = format!("{:<72}{:<8}\n", "sparsemor test matrix", "KEY");
    out += &format!("{:14}{:14}{:14}{:14}{:14}\n", pc + ic + vc, pc, ic, vc, 0);
    out += &format!(
        "{:<3}{:11}{:14}{:14}{:14}{:14}\n",
        mxtype, "", nrow, ncol, nnz, 0
    );
    let scale = match (rf.one_p, rf.comma) {
        (false, _) => "",
        (true, true) => "1P,",
        (true, false) => "1P",
    };
    let ifmt = format!("({int_per_line}I{iw})");
    let vfmt = format!("({scale}{}{}{vw}.{d})", rf.per_line, rf.letter);
    out += &format!("{ifmt:<16}{ifmt:<16}{vfmt:<20}\n");
    let mut section = |items: Vec<String>, per: usize, w: usize| {
        for chunk in items.chunks(per) {
            for s in chunk {
                out += &format!("{s:>w$}");
            }
            out.push('\n');
        }
    };
    section(
        ptr.iter().map(|p| (p + 1).to_string()).collect(),
        int_per_line,
        iw,
    );
    section(
        rows.iter().map(|r| (r + 1).to_string()).collect(),
        int_per_line,
        iw,
    );
    section(fields, rf.per_line, vw);
    std::fs::write(path, out).unwrap();
}

/// CSC parts of `entries` ((row, col) → value), columns in order, rows sorted.
fn csc_parts(
    ncol: usize,
    entries: &BTreeMap<(usize, usize), f64>,
) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
    let mut by_col: BTreeMap<(usize, usize), f64> = BTreeMap::new();
    for (&(r, c), &v) in entries {
        by_col.insert((c, r), v);
    }
    let mut ptr = vec![0usize; ncol + 1];
    let (mut rows, mut vals) = (Vec::new(), Vec::new());
    for (&(c, r), &v) in &by_col {
        ptr[c + 1] += 1;
        rows.push(r);
        vals.push(v);
    }
    for j in 0..ncol {
        ptr[j + 1] += ptr[j];
    }
    (ptr, rows, vals)
}

/// Writes the lower triangle of a full-storage symmetric matrix as `RSA`.
fn write_rsa(path: &Path, a: &Csc, rf: &RealFmt) {
    let mut e = BTreeMap::new();
    for j in 0..a.ncols() {
        for (&i, &v) in a.row_idx_of_col_raw(j).iter().zip(a.val_of_col(j)) {
            if i >= j {
                e.insert((i, j), v);
            }
        }
    }
    let (p, r, v) = csc_parts(a.ncols(), &e);
    write_hb(path, "RSA", a.nrows(), a.ncols(), &p, &r, &v, 10, 1, rf);
}

const PLAIN: RealFmt = RealFmt {
    per_line: 3,
    letter: 'E',
    one_p: true,
    comma: true,
    pad: 1,
};

fn has_python_scipy() -> bool {
    std::process::Command::new("python3")
        .args(["-c", "import scipy"])
        .output()
        .is_ok_and(|o| o.status.success())
}

const SCIPY_SCRIPT: &str = r#"
import sys
import numpy as np
import scipy.sparse as sp
import scipy.io as sio
out = sys.argv[1]
rng = np.random.default_rng(20261123)
n = 60
a = sp.random(n, n, density=0.08, random_state=rng, format="csc")
a.data = rng.standard_normal(a.nnz) * 10.0 ** rng.uniform(-12, 12, a.nnz)
a = (a + a.T + sp.diags(10.0 ** rng.uniform(-3, 3, n))).tocsc()
a.sort_indices()
sio.hb_write(out + "/full.hb", a)
low = sp.tril(a).tocsc()
low.sort_indices()
sio.hb_write(out + "/lower.hb", low)
r = sp.random(30, 17, density=0.2, random_state=rng, format="csc")
# scipy prints 24-character fields under (3E25.16); with a 3-digit exponent a negative
# value then runs into the one before, which no reader can split, so |exponent| < 100.
r.data = rng.standard_normal(r.nnz) * 10.0 ** rng.uniform(-90, 90, r.nnz)
r.sort_indices()
sio.hb_write(out + "/rect.hb", r)
for name, m in (("full", a), ("rect", r)):
    c = m.tocoo()
    with open(out + "/" + name + ".txt", "w") as f:
        f.write(f"{m.shape[0]} {m.shape[1]}\n")
        for i, j, v in zip(c.row, c.col, c.data):
            f.write(f"{int(i)} {int(j)} {float(v)!r}\n")
"#;

/// (rows, cols, entries) of a `repr()` text written by the script.
fn read_repr(path: &Path) -> (usize, usize, Vec<(usize, usize, f64)>) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let shape: Vec<usize> = lines
        .next()
        .unwrap()
        .split_whitespace()
        .map(|t| t.parse().unwrap())
        .collect();
    let entries = lines
        .map(|l| {
            let t: Vec<&str> = l.split_whitespace().collect();
            (
                t[0].parse().unwrap(),
                t[1].parse().unwrap(),
                t[2].parse().unwrap(),
            )
        })
        .collect();
    (shape[0], shape[1], entries)
}

/// max |a_ij − v| / max |v| over the entries, and whether `a` has no other nonzeros.
fn compare(a: &Csc, shape: (usize, usize), entries: &[(usize, usize, f64)]) -> (f64, f64) {
    assert_eq!((a.nrows(), a.ncols()), shape);
    let d = dense(a);
    let mut seen = faer::Mat::<f64>::zeros(shape.0, shape.1);
    let (mut max_rel, mut max_v) = (0.0f64, 0.0f64);
    for &(i, j, v) in entries {
        max_rel = max_rel.max((d[(i, j)] - v).abs() / v.abs());
        max_v = max_v.max(v.abs());
        seen[(i, j)] = 1.0;
    }
    for j in 0..shape.1 {
        for i in 0..shape.0 {
            assert!(
                seen[(i, j)] == 1.0 || d[(i, j)] == 0.0,
                "extra entry ({i}, {j})"
            );
        }
    }
    (max_rel, max_v)
}

#[test]
fn hbmat_matches_scipy_hb_write() {
    if !has_python_scipy() {
        println!("note: python3 with scipy not available; scipy cross-check skipped");
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let out = std::process::Command::new("python3")
        .args(["-c", SCIPY_SCRIPT])
        .arg(tmp.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // scipy writes RUA with (3E25.16): 17 significant digits, so every value round-trips.
    let head = std::fs::read_to_string(tmp.path().join("full.hb")).unwrap();
    let line4 = head.lines().nth(3).unwrap();
    println!("scipy formats: {line4}");
    let (nr, nc, e) = read_repr(&tmp.path().join("full.txt"));
    let full = harwell_boeing::read(&tmp.path().join("full.hb")).unwrap();
    let (rel, _) = compare(&full, (nr, nc), &e);
    println!(
        "scipy RUA {nr}x{nc}, {} entries: max relative difference {rel:e}",
        e.len()
    );
    assert!(rel <= 1e-15, "{rel}");
    // The lower triangle as written by scipy, relabelled RSA: expands to the full matrix.
    let lower = tmp.path().join("lower.hb");
    let text = std::fs::read_to_string(&lower).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    assert!(lines[2].starts_with("RUA"));
    lines[2].replace_range(..3, "RSA");
    std::fs::write(&lower, lines.join("\n") + "\n").unwrap();
    let sym = harwell_boeing::read(&lower).unwrap();
    let (rel_sym, _) = compare(&sym, (nr, nc), &e);
    println!("scipy lower triangle as RSA, expanded: max relative difference {rel_sym:e}");
    assert!(rel_sym <= 1e-15, "{rel_sym}");
    // Rectangular, values over 1e±90.
    let (nr, nc, e) = read_repr(&tmp.path().join("rect.txt"));
    let rect = harwell_boeing::read(&tmp.path().join("rect.hb")).unwrap();
    let (rel_rect, max) = compare(&rect, (nr, nc), &e);
    println!("scipy RUA {nr}x{nc}, |v| up to {max:e}: max relative difference {rel_rect:e}");
    assert!(rel_rect <= 1e-15, "{rel_rect}");
}

fn real_fmt() -> impl Strategy<Value = RealFmt> {
    (
        1usize..6,
        prop::bool::ANY,
        prop::bool::ANY,
        prop::bool::ANY,
        0usize..3,
    )
        .prop_map(|(per_line, d, one_p, comma, pad)| RealFmt {
            per_line,
            letter: if d { 'D' } else { 'E' },
            one_p,
            comma,
            pad,
        })
}

fn value() -> impl Strategy<Value = f64> {
    (-1.0f64..1.0, -310i32..310).prop_map(|(m, e)| {
        let v = m * 10f64.powi(e);
        if v.is_finite() {
            v
        } else {
            m
        }
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]
    #[test]
    fn hbmat_written_in_any_format_reads_back(
        nrow in 1usize..9,
        ncol in 1usize..9,
        symmetric in prop::bool::ANY,
        raw in proptest::collection::vec((0usize..9, 0usize..9, value()), 0..40),
        int_per_line in 1usize..12,
        int_pad in 0usize..3,
        rf in real_fmt(),
    ) {
        let ncol = if symmetric { nrow } else { ncol };
        let mut stored = BTreeMap::new();
        let mut want = faer::Mat::<f64>::zeros(nrow, ncol);
        for (i, j, v) in raw {
            let (i, j) = (i % nrow, j % ncol);
            let (i, j) = if symmetric { (i.max(j), i.min(j)) } else { (i, j) };
            stored.insert((i, j), v);
        }
        for (&(i, j), &v) in &stored {
            want[(i, j)] = v;
            if symmetric {
                want[(j, i)] = v;
            }
        }
        let (p, r, v) = csc_parts(ncol, &stored);
        let tmp = tempfile::tempdir().unwrap();
        let path = tmp.path().join("a.hb");
        let ty = if symmetric { "RSA" } else { "RUA" };
        write_hb(&path, ty, nrow, ncol, &p, &r, &v, int_per_line, int_pad, &rf);
        let a = harwell_boeing::read(&path)
            .map_err(|e| TestCaseError::fail(format!("{e}\n{}", std::fs::read_to_string(&path).unwrap())))?;
        let got = dense(&a);
        prop_assert_eq!((got.nrows(), got.ncols()), (nrow, ncol));
        for j in 0..ncol {
            for i in 0..nrow {
                // Exact (== also equates -0 and the +0 that `dense` sums a stored -0 into).
                prop_assert!(got[(i, j)] == want[(i, j)], "({}, {}): {} vs {}", i, j, got[(i, j)], want[(i, j)]);
            }
        }
        // Explicit zeros and symmetric mirror images are stored, nothing else.
        let expect_nnz = stored.keys().map(|&(i, j)| if symmetric && i != j { 2 } else { 1 }).sum::<usize>();
        prop_assert_eq!(a.compute_nnz(), expect_nnz);
    }

    #[test]
    fn hbmat_reader_never_panics(text in "[0-9 RSUACPE().ID+\\-\\n]{0,300}") {
        let tmp = tempfile::tempdir().unwrap();
        let p = tmp.path().join("x.hb");
        std::fs::write(&p, format!("title\n{text}")).unwrap();
        let _ = harwell_boeing::read(&p);
    }
}

/// The 3×3 symmetric test matrix [[4, 1, 0], [1, 5, 2], [0, 2, 6]] as RSA, lines 1–8:
/// title, counts, type, formats, pointers, row indices, values (2 lines).
fn small_rsa() -> Vec<String> {
    [
        format!("{:<72}{:<8}", "small", "KEY"),
        format!("{:14}{:14}{:14}{:14}{:14}", 4, 1, 1, 2, 0),
        format!("{:<3}{:11}{:14}{:14}{:14}{:14}", "RSA", "", 3, 3, 5, 0),
        format!("{:<16}{:<16}{:<20}", "(4I3)", "(5I3)", "(3E24.16)"),
        "  1  3  5  6".into(),
        "  1  2  2  3  3".into(),
        "  4.0000000000000000E+00  1.0000000000000000E+00  5.0000000000000000E+00".into(),
        "  2.0000000000000000E+00  6.0000000000000000E+00".into(),
    ]
    .to_vec()
}

/// `small_rsa` with `edit` applied, written and read.
fn read_edited(
    edit: impl FnOnce(&mut Vec<String>),
) -> (PathBuf, Result<Csc, Error>, tempfile::TempDir) {
    let mut lines = small_rsa();
    edit(&mut lines);
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("bad.hb");
    std::fs::write(&p, lines.join("\n") + "\n").unwrap();
    let r = harwell_boeing::read(&p);
    (p, r, tmp)
}

/// The edit must fail with a parse error naming the file, `line` and `needle`.
fn expect_error(edit: impl FnOnce(&mut Vec<String>), line: usize, needle: &str) {
    let (p, r, _tmp) = read_edited(edit);
    match r {
        Err(Error::Parse {
            path, line: l, msg, ..
        }) => {
            assert_eq!(path, p);
            assert_eq!(l, line, "{msg}");
            assert!(msg.contains(needle), "'{msg}' lacks '{needle}'");
            println!("{}:{l}: {msg}", path.display());
        }
        other => panic!("expected a parse error with '{needle}', got {other:?}"),
    }
}

#[test]
fn hbmat_small_file_reads() {
    let (_p, r, _tmp) = read_edited(|_| {});
    let d = dense(&r.unwrap());
    let want = [[4.0, 1.0, 0.0], [1.0, 5.0, 2.0], [0.0, 2.0, 6.0]];
    for (i, row) in want.iter().enumerate() {
        for (j, &v) in row.iter().enumerate() {
            assert_eq!(d[(i, j)], v);
        }
    }
    // The same with 4 counts on line 2 (RHSCRD omitted), 3 on line 3, the upper triangle
    // stored instead, D exponents and a 1P scale factor.
    let (_p, r, _tmp) = read_edited(|l| {
        l[1] = format!("{:14}{:14}{:14}{:14}", 4, 1, 1, 2);
        l[2] = format!("{:<3}{:11}{:14}{:14}{:14}", "RSA", "", 3, 3, 5);
        l[3] = format!("{:<16}{:<16}{:<20}", "(4I3)", "(5I3)", "(1P,3D24.16)");
        l[4] = "  1  2  4  6".into();
        l[5] = "  1  1  2  2  3".into();
        l[6] = l[6].replace('E', "D");
    });
    let d = dense(&r.unwrap());
    assert_eq!(d[(0, 1)], 1.0);
    assert_eq!(d[(1, 0)], 1.0);
    assert_eq!(d[(2, 2)], 6.0);
}

#[test]
fn hbmat_bad_files() {
    // Truncated: the last value line is missing.
    expect_error(|l| l.truncate(7), 8, "truncated");
    expect_error(|l| l.truncate(3), 4, "truncated");
    // Wrong counts: TOTCRD disagrees; PTRCRD disagrees with the format; a row index short.
    expect_error(|l| l[1] = l[1].replacen("   4", "   5", 1), 2, "TOTCRD");
    expect_error(
        |l| l[1] = format!("{:14}{:14}{:14}{:14}{:14}", 5, 2, 1, 2, 0),
        4,
        "PTRCRD",
    );
    expect_error(|l| l[5] = "  1  2  2  3".into(), 6, "ends after 4 field(s)");
    expect_error(|l| l[5] = "  1  2  2  3  3  3".into(), 6, "unexpected '3'");
    // Types that are not read.
    expect_error(|l| l[2].replace_range(..3, "CSA"), 3, "complex");
    expect_error(|l| l[2].replace_range(..3, "PSA"), 3, "pattern");
    expect_error(|l| l[2].replace_range(..3, "RSE"), 3, "elemental");
    expect_error(|l| l[2].replace_range(..3, "RZA"), 3, "skew");
    // Right-hand sides.
    expect_error(
        |l| l[1] = format!("{:14}{:14}{:14}{:14}{:14}", 5, 1, 1, 2, 1),
        2,
        "right-hand sides",
    );
    // Bad Fortran formats.
    expect_error(
        |l| l[3] = "(4X3)           (5I3)           (3E24.16)".into(),
        4,
        "pointer format (4X3)",
    );
    expect_error(
        |l| l[3] = "(4I3)           (5I3)           (3E24)".into(),
        4,
        "value format",
    );
    expect_error(|l| l[3] = "(4I3)           (5I3)".into(), 4, "found 2");
    // Pointers: not starting at 1, decreasing, not ending at NNZERO + 1.
    expect_error(|l| l[4] = "  2  3  5  6".into(), 5, "first column pointer");
    expect_error(|l| l[4] = "  1  3  2  6".into(), 5, "never decrease");
    expect_error(|l| l[4] = "  1  3  5  5".into(), 5, "NNZERO + 1");
    // Row indices: out of range, repeated, both triangles of a symmetric matrix.
    expect_error(|l| l[5] = "  1  4  2  3  3".into(), 6, "outside 1..=3");
    expect_error(|l| l[5] = "  1  1  2  3  3".into(), 6, "twice");
    expect_error(|l| l[5] = "  1  2  1  3  3".into(), 6, "other one");
    // Values: not a number, run-over text.
    expect_error(
        |l| l[7] = "  2.0000000000000000E+00  6.00000000000x0000E+00".into(),
        8,
        "not a finite number",
    );
    // A header declaring 10^12 entries in a small file: refused before any allocation.
    expect_error(
        |l| {
            l[2] = format!(
                "{:<3}{:11}{:14}{:14}{:14}{:14}",
                "RUA", "", 1_000_000, 1_000_000, 1_000_000_000_000u64, 0
            )
        },
        3,
        "declares",
    );
    // Text after the last value.
    expect_error(|l| l.push("  7.0E+00".into()), 9, "after the last value");
}

#[test]
fn hbmat_apdl_math_set_imports_the_bar() {
    let spec = BoxSpec {
        elements: [1, 1, 3],
        size_m: [0.01, 0.01, 0.1],
        mass_kg: 0.1,
        young_pa: 2e11,
        poisson: 0.3,
    };
    let model = bar_model(&spec).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let rf = RealFmt {
        per_line: 4,
        letter: 'D',
        one_p: true,
        comma: true,
        pad: 1,
    };
    write_rsa(&dir.join("STIF.hb"), &model.stiffness, &rf);
    write_rsa(&dir.join("MASS.hb"), &model.mass, &PLAIN);
    let nodes = model.nodes.as_ref().unwrap();
    let mut map = format!(
        "%%MatrixMarket matrix array integer general\n{} 1\n",
        nodes.len()
    );
    let mut table = String::from("node x y z\n");
    for (i, c) in nodes.iter().enumerate() {
        map += &format!("{}\n", 101 + i);
        table += &format!("{} {:e} {:e} {:e}\n", 101 + i, c[0], c[1], c[2]);
    }
    std::fs::write(dir.join("map.txt"), map).unwrap();
    std::fs::write(dir.join("nodes.txt"), table).unwrap();
    let files: Vec<PathBuf> = ["STIF.hb", "MASS.hb", "map.txt", "nodes.txt"]
        .iter()
        .map(|f| dir.join(f))
        .collect();
    let imp = import::read(&files).unwrap();
    assert_eq!(imp.format, Format::AnsysApdlMath);
    assert!(imp.producer.contains("Harwell-Boeing"), "{}", imp.producer);
    assert_eq!(imp.n(), model.n());
    assert_eq!(imp.dofs_per_node, 3);
    assert_eq!(imp.dofs[3].node, 102);
    let same = |a: &Csc, b: &Csc| {
        let (da, db) = (dense(a), dense(b));
        (0..a.ncols()).all(|j| (0..a.nrows()).all(|i| da[(i, j)] == db[(i, j)]))
    };
    assert!(same(&imp.stiffness, &model.stiffness));
    assert!(same(&imp.mass, &model.mass));
    assert_eq!(imp.stiffness.compute_nnz(), model.stiffness.compute_nnz());
    assert_eq!(imp.nodes.as_ref().unwrap(), nodes);
    let (m, _) = imp.clone().into_model("hb bar".into()).unwrap();
    assert_eq!(m.n(), model.n());
    // With K=/M= prefixes and neutral names, and one of them Matrix Market.
    std::fs::rename(dir.join("STIF.hb"), dir.join("a.hb")).unwrap();
    sparsemor::io::matrix_market::write_coordinate(&dir.join("b.mtx"), model.mass.as_ref(), true)
        .unwrap();
    let files = vec![
        PathBuf::from(format!("K={}", dir.join("a.hb").display())),
        PathBuf::from(format!("M={}", dir.join("b.mtx").display())),
        dir.join("map.txt"),
    ];
    let imp2 = import::read(&files).unwrap();
    assert!(same(&imp2.stiffness, &model.stiffness));
    assert!(same(&imp2.mass, &model.mass));
    // Without the mapping vector: the same refusal as for Matrix Market.
    let e = import::read(&files[..2]).unwrap_err();
    assert!(e.to_string().contains("mapping vector"), "{e}");
}
