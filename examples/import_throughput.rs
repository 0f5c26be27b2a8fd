//! Import throughput of the text readers (MB/s of file read into a model) on a converted
//! hex8 box model: Abaqus COORDINATE (both triangles, as Abaqus writes them), Abaqus node-DoF,
//! the `.inp` deck's `*Node` block and a decimal-comma node table.
//!
//! Run with `cargo run --release --example import_throughput [-- NX NY NZ]` (elements per
//! side, default 20 20 80: 37,044 nodes, N = 111,132 DoFs). The files are written into a
//! temporary directory and removed at the end.

use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

use sparsemor::fe::{bar_model, BoxSpec};
use sparsemor::io::{abaqus, import};
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
}
