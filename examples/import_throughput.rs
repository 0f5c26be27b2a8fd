//! Import throughput of the text readers (MB/s of file read into a model) on a converted
//! hex8 box model: Abaqus COORDINATE (both triangles, as Abaqus writes them), Abaqus node-DoF,
//! the `.inp` deck's `*Node` block, a decimal-comma node table, Harwell–Boeing `RSA` (lower
//! triangle, `(8I10)`, `(1P,4E20.12)` as ANSYS's HBMAT) and Nastran OP4 ASCII (lower triangle in
//! BIGMAT string records, `1P,3E23.16`); values as Rust's `{:E}` writes them (an exponent like `E5`, which
//! Fortran input reads).
//!
//! Run with `cargo run --release --example import_throughput [-- NX NY NZ]` (elements per
//! side, default 20 20 80: 37,044 nodes, N = 111,132 DoFs). The files are written into a
//! temporary directory and removed at the end.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use sparsemor::fe::{bar_model, BoxSpec};
use sparsemor::io::import::{self, abaqus, harwell_boeing};
use sparsemor::io::op4;
use sparsemor::sparse::Csc;

/// Writes `a` (full storage) with 1-based indices, one entry per line, through `line`.
fn write_entries(path: &Path, a: &Csc, line: impl Fn(&mut String, usize, usize, f64)) -> u64 {
    let mut s = String::with_capacity(48 * a.compute_nnz());
    for j in 0..a.ncols() {
        for (&i, &v) in a.row_idx_of_col_raw(j).iter().zip(a.val_of_col(j)) {
            line(&mut s, i, j, v);
        }
    }
    std::fs::write(path, &s).unwrap();
    s.len() as u64
}

/// Lines of `items` strings, `per` to a line.
fn lines_of(out: &mut String, items: impl Iterator<Item = String>, per: usize) {
    let items: Vec<String> = items.collect();
    for chunk in items.chunks(per) {
        out.push_str(&chunk.concat());
        out.push('\n');
    }
}

/// The lower triangle of `a` as 0-based CSC parts.
fn lower(a: &Csc) -> (Vec<usize>, Vec<usize>, Vec<f64>) {
    let (mut ptr, mut rows, mut vals) = (vec![0], Vec::new(), Vec::new());
    for j in 0..a.ncols() {
        for (&i, &v) in a.row_idx_of_col_raw(j).iter().zip(a.val_of_col(j)) {
            if i >= j {
                rows.push(i);
                vals.push(v);
            }
        }
        ptr.push(rows.len());
    }
    (ptr, rows, vals)
}

/// `a`'s lower triangle as a Harwell–Boeing `RSA` file.
fn write_hb(path: &Path, a: &Csc) -> u64 {
    let (ptr, rows, vals) = lower(a);
    let (n, nnz) = (a.ncols(), vals.len());
    let (pc, ic, vc) = ((n + 1).div_ceil(8), nnz.div_ceil(8), nnz.div_ceil(4));
    let mut s = format!("{:<72}{:<8}\n", "throughput", "K");
    s += &format!("{:14}{:14}{:14}{:14}{:14}\n", pc + ic + vc, pc, ic, vc, 0);
    s += &format!("RSA{:11}{n:14}{n:14}{nnz:14}{:14}\n", "", 0);
    s += &format!("{:<16}{:<16}{:<20}\n", "(8I10)", "(8I10)", "(1P,4E20.12)");
    lines_of(&mut s, ptr.iter().map(|p| format!("{:10}", p + 1)), 8);
    lines_of(&mut s, rows.iter().map(|r| format!("{:10}", r + 1)), 8);
    lines_of(&mut s, vals.iter().map(|&v| format!("{v:20.12E}")), 4);
    std::fs::write(path, &s).unwrap();
    s.len() as u64
}

/// `a`'s lower triangle as an OP4 ASCII file (symmetric form 6, real double, BIGMAT strings).
fn write_op4_ascii(path: &Path, name: &str, a: &Csc) -> u64 {
    let (ptr, rows, vals) = lower(a);
    let n = a.ncols();
    let mut s = format!("{n:8}{:8}{:8}{:8}{name:<8}1P,3E23.16\n", -(n as i64), 6, 2);
    for j in 0..n {
        let (r, v) = (&rows[ptr[j]..ptr[j + 1]], &vals[ptr[j]..ptr[j + 1]]);
        // strings of consecutive rows: (L + 1, first row) then the values
        let mut strings = Vec::new();
        let mut start = 0;
        for k in 1..=r.len() {
            if k == r.len() || r[k] != r[k - 1] + 1 {
                strings.push(start..k);
                start = k;
            }
        }
        let words: usize = strings.iter().map(|g| 2 + 2 * g.len()).sum();
        s += &format!("{:8}{:8}{words:8}\n", j + 1, 0);
        for g in strings {
            s += &format!("{:8}{:8}\n", 2 * g.len() + 1, r[g.start] + 1);
            lines_of(&mut s, v[g].iter().map(|&x| format!("{x:23.16E}")), 3);
        }
    }
    s += &format!("{:8}{:8}{:8}\n", n + 1, 1, 2);
    s += &format!("{:23.16E}\n", 1.0);
    std::fs::write(path, &s).unwrap();
    s.len() as u64
}

fn timed<T>(f: impl FnOnce() -> T) -> (T, f64) {
    let t = Instant::now();
    let out = f();
    (out, t.elapsed().as_secs_f64())
}

fn main() {
    let e: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|s| s.parse().ok())
        .collect();
    let elements = if e.len() == 3 {
        [e[0], e[1], e[2]]
    } else {
        [20, 20, 80]
    };
    let spec = BoxSpec {
        elements,
        size_m: [0.1, 0.1, 0.4],
        ..BoxSpec::paper_bar()
    };
    let model = bar_model(&spec).unwrap();
    let nodes = model.nodes.clone().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let p = |f: &str| dir.path().join(f);
    println!(
        "hex8 box {:?} elements: N = {}, nnz(K) = {}, nnz(M) = {}",
        elements,
        model.n(),
        model.stiffness.compute_nnz(),
        model.mass.compute_nnz()
    );

    // The deck: *Node with the box's nodes, numbered from 1.
    let mut deck = String::from("*Heading\n*Node\n");
    for (k, x) in nodes.iter().enumerate() {
        let _ = writeln!(deck, "{}, {:?}, {:?}, {:?}", k + 1, x[0], x[1], x[2]);
    }
    std::fs::write(p("box.inp"), &deck).unwrap();

    let coord = |s: &mut String, i: usize, j: usize, v: f64| {
        let _ = writeln!(s, "{} {}  {:.15e}", i + 1, j + 1, v);
    };
    let node_dof = |s: &mut String, i: usize, j: usize, v: f64| {
        let _ = writeln!(
            s,
            "{},{}, {},{}, {:.15e}",
            i / 3 + 1,
            i % 3 + 1,
            j / 3 + 1,
            j % 3 + 1,
            v
        );
    };
    println!("| reader | files | MB | s | MB/s |");
    println!("|---|---|---:|---:|---:|");
    for (name, line) in [
        (
            "Abaqus COORDINATE",
            &coord as &dyn Fn(&mut String, usize, usize, f64),
        ),
        ("Abaqus node-DoF", &node_dof),
    ] {
        let (k, m) = (p("box_STIF1.mtx"), p("box_MASS1.mtx"));
        let bytes = write_entries(&k, &model.stiffness, line)
            + write_entries(&m, &model.mass, line)
            + deck.len() as u64;
        let (imp, s) = timed(|| abaqus::read(&k, &m, Some(&p("box.inp"))).unwrap());
        assert_eq!(imp.n(), model.n());
        println!(
            "| {name} | K, M, .inp | {:.0} | {s:.2} | {:.0} |",
            bytes as f64 / 1e6,
            bytes as f64 / 1e6 / s
        );
    }

    // A node table as the German-locale ANSYS export writes it (tabs, decimal comma).
    let mut table =
        String::from("Knotennummer\tX-Position (m)\tY-Position (m)\tZ-Position (m)\t\n");
    for (k, x) in nodes.iter().enumerate() {
        let c = |v: f64| format!("{v:e}").replace('.', ",");
        let _ = writeln!(table, "{}\t{}\t{}\t{}\t", k + 1, c(x[0]), c(x[1]), c(x[2]));
    }
    std::fs::write(p("nodes.txt"), &table).unwrap();
    let (t, s) = timed(|| import::read_node_table(&p("nodes.txt")).unwrap());
    assert_eq!(t.rows.len(), nodes.len());
    println!(
        "| node table (decimal comma) | nodes.txt | {:.1} | {s:.3} | {:.0} |",
        table.len() as f64 / 1e6,
        table.len() as f64 / 1e6 / s
    );
    let bytes = write_hb(&p("K.hb"), &model.stiffness) + write_hb(&p("M.hb"), &model.mass);
    let (kk, s) = timed(|| {
        (
            harwell_boeing::read(&p("K.hb")).unwrap(),
            harwell_boeing::read(&p("M.hb")).unwrap(),
        )
    });
    assert_eq!(kk.0.ncols(), model.n());
    println!(
        "| Harwell–Boeing RSA | K, M | {:.0} | {s:.2} | {:.0} |",
        bytes as f64 / 1e6,
        bytes as f64 / 1e6 / s
    );
    drop(kk);
    let bytes = write_op4_ascii(&p("kaa.op4"), "KAA", &model.stiffness)
        + write_op4_ascii(&p("maa.op4"), "MAA", &model.mass);
    let (mm, s) = timed(|| {
        (
            op4::read_op4(&p("kaa.op4")).unwrap(),
            op4::read_op4(&p("maa.op4")).unwrap(),
        )
    });
    assert_eq!(mm.0.len(), 1);
    println!(
        "| Nastran OP4 ASCII | KAA, MAA | {:.0} | {s:.2} | {:.0} |",
        bytes as f64 / 1e6,
        bytes as f64 / 1e6 / s
    );
}
