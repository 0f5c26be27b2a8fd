//! Importers (io::import, io::import::ansys, io::import::abaqus) on the real files of
//! `../shared/data/`, the rotor cross-check between ANSYS and Abaqus, and one test per bad-file
//! class.

use crate::common::dense;
use proptest::prelude::*;
use sparsemor::body::Body;
use sparsemor::eigen::{eigenpairs, EigenOptions, Request};
use sparsemor::io::import::{self, Direction, Dof, Format, Imported};
use sparsemor::io::import::{abaqus, ansys};
use sparsemor::io::matrix_market;
use sparsemor::io::model_dir::{self, DofNames};
use sparsemor::sparse::Csc;
use sparsemor::Error;
use std::path::{Path, PathBuf};

fn data(rel: &str) -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../shared/data")
        .join(rel);
    if p.exists() {
        Some(p)
    } else {
        println!("note: {} not found; skipped", p.display());
        None
    }
}

fn scratch() -> tempfile::TempDir {
    tempfile::tempdir().unwrap()
}

/// max |a - b| / max |b| over all entries, after checking equal patterns of nonzeros.
fn rel_diff(a: &Csc, b: &Csc) -> f64 {
    assert_eq!((a.nrows(), a.ncols()), (b.nrows(), b.ncols()));
    let (da, db) = (dense(a), dense(b));
    let mut max_b = 0.0f64;
    let mut max_d = 0.0f64;
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            max_b = max_b.max(db[(i, j)].abs());
            max_d = max_d.max((da[(i, j)] - db[(i, j)]).abs());
        }
    }
    max_d / max_b
}

fn expect_parse(e: Error, needle: &str) {
    let msg = e.to_string();
    assert!(msg.contains(needle), "'{msg}' lacks '{needle}'");
}

// ---------------------------------------------------------------------------------------------
// ANSYS .full

#[test]
fn ansys_full_equals_the_independent_extraction() {
    let Some(dir) = data("ansys_example_full") else {
        return;
    };
    let imp = import::read(&[dir.join("file.full")]).unwrap();
    assert_eq!(imp.format, Format::AnsysFull);
    assert!(imp.producer.starts_with("ANSYS 15.0"), "{}", imp.producer);
    assert_eq!(imp.n(), 900);
    assert_eq!(imp.removed.len(), 63);
    let k = matrix_market::read_sparse(&dir.join("K.mtx")).unwrap();
    let m = matrix_market::read_sparse(&dir.join("M.mtx")).unwrap();
    let (dk, dm) = (rel_diff(&imp.stiffness, &k), rel_diff(&imp.mass, &m));
    println!("file.full vs K.mtx: {dk:.3e}, vs M.mtx: {dm:.3e}");
    assert!(dk <= 1e-14 && dm <= 1e-14);
    assert_eq!(imp.stiffness.compute_nnz(), 77_020);
    assert_eq!(imp.mass.compute_nnz(), 32_004);
    // Node order: ascending node numbers, x, y, z per node; constrained nodes removed whole.
    let nodes: Vec<u64> = imp.dofs.iter().step_by(3).map(|d| d.node).collect();
    assert!(nodes.windows(2).all(|w| w[0] < w[1]));
    assert!(imp.dofs.chunks(3).all(|c| c.iter().map(|d| d.dir).eq([
        Direction::X,
        Direction::Y,
        Direction::Z
    ])));
    let removed: std::collections::BTreeSet<u64> = imp.removed.iter().map(|d| d.node).collect();
    assert_eq!(removed.len(), 21);
    assert!(nodes.iter().all(|n| !removed.contains(n)));
}

/// Rewrites a little-endian ANSYS binary file in big-endian byte order, record by record
/// (integers per 4 bytes, reals per 8).
fn to_big_endian(bytes: &[u8]) -> Vec<u8> {
    let mut out = bytes.to_vec();
    let word = |p: usize| u32::from_le_bytes(bytes[p..p + 4].try_into().unwrap());
    let mut p = 0;
    while p + 12 <= bytes.len() {
        let n = word(p) as usize;
        let flags = word(p + 4);
        if p + 12 + 4 * n > bytes.len() {
            break;
        }
        for q in [p, p + 4, p + 8 + 4 * n] {
            out[q..q + 4].reverse();
        }
        let width = if flags & (1 << 31) != 0 { 4 } else { 8 };
        for q in (p + 8..p + 8 + 4 * n).step_by(width) {
            out[q..q + width].reverse();
        }
        p += 12 + 4 * n;
    }
    out
}

#[test]
fn ansys_full_big_endian_reads_the_same() {
    let Some(dir) = data("ansys_example_full") else {
        return;
    };
    let bytes = std::fs::read(dir.join("file.full")).unwrap();
    let tmp = scratch();
    let p = tmp.path().join("be.full");
    std::fs::write(&p, to_big_endian(&bytes)).unwrap();
    let le = ansys::read_full(&dir.join("file.full"), None).unwrap();
    let be = ansys::read_full(&p, None).unwrap();
    assert_eq!(le.dofs, be.dofs);
    assert_eq!(rel_diff(&be.stiffness, &le.stiffness), 0.0);
    assert_eq!(rel_diff(&be.mass, &le.mass), 0.0);
}

/// The example file with `edit` applied, read back.
fn full_edited(edit: impl FnOnce(&mut Vec<u8>)) -> Option<Result<Imported, Error>> {
    let dir = data("ansys_example_full")?;
    let mut bytes = std::fs::read(dir.join("file.full")).unwrap();
    edit(&mut bytes);
    let tmp = scratch();
    let p = tmp.path().join("bad.full");
    std::fs::write(&p, bytes).unwrap();
    Some(ansys::read_full(&p, None))
}

#[test]
fn ansys_full_bad_files() {
    // Truncated: the stiffness records run past the end.
    if let Some(r) = full_edited(|b| b.truncate(300_000)) {
        expect_parse(r.unwrap_err(), "truncated");
    }
    // Wrong magic: the first word is not 100.
    if let Some(r) = full_edited(|b| b[0] = 99) {
        expect_parse(r.unwrap_err(), "not an ANSYS binary file");
    }
    // A result file (unit 12), not a full file.
    if let Some(r) = full_edited(|b| b[8] = 12) {
        expect_parse(r.unwrap_err(), "unit 12");
    }
    // Mismatched sizes: neqn in the full header no longer matches the nodes' DoFs.
    if let Some(r) = full_edited(|b| b[4 * 103 + 12] = 0xc4) {
        expect_parse(r.unwrap_err(), "the full header says 964");
    }
    // Unknown DoF label: DoF key 20 (TEMP) in the DoF set.
    if let Some(r) = full_edited(|b| b[4 * 206 + 8] = 20) {
        expect_parse(r.unwrap_err(), "DoF key 20");
    }
    // A corrupt footer.
    if let Some(r) = full_edited(|b| b[4 * 205] = 7) {
        expect_parse(r.unwrap_err(), "corrupt");
    }
    // Unsymmetric matrices (keyuns).
    if let Some(r) = full_edited(|b| b[4 * 105 + 4 * 13] = 1) {
        expect_parse(r.unwrap_err(), "unsymmetric");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Random garbage, and the real file with random bytes overwritten: an error or a model,
    /// never a panic.
    #[test]
    fn ansys_full_never_panics(garbage in proptest::collection::vec(any::<u8>(), 0..2000),
                               at in 0usize..851_968, len in 1usize..64, seed in any::<u8>()) {
        let tmp = scratch();
        let p = tmp.path().join("g.full");
        let mut g = garbage;
        if g.len() >= 4 { g[..4].copy_from_slice(&100u32.to_le_bytes()); }
        std::fs::write(&p, &g).unwrap();
        let _ = ansys::read_full(&p, None);
        if let Some(r) = full_edited(|b| {
            let end = (at + len).min(b.len());
            b[at..end].iter_mut().for_each(|x| *x ^= seed | 1);
        }) {
            let _ = r;
        }
    }
}

// ---------------------------------------------------------------------------------------------
// ANSYS APDL Math export and the Abaqus files: the rotor cross-check

fn ansys_rotor() -> Option<Vec<PathBuf>> {
    let d = data("ansys_rotor_exudyn")?;
    Some(
        [
            "rotorAnsysStiffnessMatrixSparse.txt",
            "rotorAnsysMassMatrixSparse.txt",
            "rotorAnsysMatrixDofMappingVector.txt",
            "rotorAnsysNodalCoordinates.txt",
        ]
        .iter()
        .map(|f| d.join(f))
        .collect(),
    )
}

pub(crate) fn abaqus_set(job: &str, sep: &str) -> Option<Vec<PathBuf>> {
    let d = data("abaqus_exudyn")?;
    Some(vec![
        d.join(format!("{job}{sep}STIF1.mtx")),
        d.join(format!("{job}{sep}MASS1.mtx")),
        d.join(format!("{job}.inp")),
    ])
}

/// Eigenfrequencies of the lowest `count` modes and the rigid count.
fn modes(imp: Imported, count: usize) -> (Vec<f64>, usize) {
    let (model, _) = imp.into_model("t".into()).unwrap();
    let body = Body::new(&model).unwrap();
    let m = eigenpairs(&body, Request::Lowest(count), &EigenOptions::for_band(1e3)).unwrap();
    (m.freqs_hz(), m.rigid)
}

#[test]
fn rotor_ansys_and_abaqus_agree() {
    let (Some(a), Some(b)) = (ansys_rotor(), abaqus_set("rotorDiscTest", "")) else {
        return;
    };
    let ansys = import::read(&a).unwrap();
    assert_eq!(ansys.format, Format::AnsysApdlMath);
    assert_eq!(ansys.n(), 345);
    assert!(ansys.nodes.is_some());
    assert!(ansys.units.contains("in m"), "{}", ansys.units);
    let mut abq = import::read(&b).unwrap();
    assert_eq!(abq.format, Format::AbaqusCoordinate);
    assert!(abq.producer.contains("Abaqus/CAE 2019"), "{}", abq.producer);
    assert!(abq.notes.iter().any(|n| n.contains("lumped")));
    abq.scale_stiffness(1e-2).unwrap();
    let (fa, ra) = modes(ansys, 18);
    let (fb, rb) = modes(abq, 18);
    assert_eq!((ra, rb), (6, 6));
    println!(
        "rotor elastic frequencies (Hz):\n  ANSYS  {:?}\n  Abaqus {:?}",
        &fa[6..],
        &fb[6..]
    );
    assert!((fa[6] - 104.63701).abs() < 1e-5, "{}", fa[6]);
    assert!((fb[6] - 104.63701).abs() < 1e-5, "{}", fb[6]);
    let worst = fa[6..18]
        .iter()
        .zip(&fb[6..18])
        .map(|(x, y)| ((x - y) / x).abs())
        .fold(0.0, f64::max);
    println!("max relative difference of the first 12 elastic frequencies: {worst:.2e}");
    assert!(worst <= 1e-6);
}

#[test]
fn abaqus_blocks_import_with_six_rigid_modes() {
    for job in ["blockC3D8", "blockC3D10", "blockC3D20R"] {
        let Some(files) = abaqus_set(job, "_") else {
            return;
        };
        let imp = import::read(&files).unwrap();
        let nodes = imp.nodes.as_ref().expect("deck nodes").len();
        assert_eq!(3 * nodes, imp.n(), "{job}");
        assert_eq!(
            imp.dofs[0],
            Dof {
                node: 1,
                dir: Direction::X
            }
        );
        let (f, rigid) = modes(imp, 10);
        println!("{job}: N = {}, first elastic {:.3} Hz", 3 * nodes, f[6]);
        assert_eq!(rigid, 6, "{job}");
    }
}

// ---------------------------------------------------------------------------------------------
// Abaqus node-DoF format, bad files, property tests

/// Rewrites a COORDINATE file (3 DoFs per node, `nodes` in equation order) in the node-DoF
/// format `node, dof, node, dof, value`.
fn to_node_dof(coordinate: &Path, nodes: &[u64], out: &Path) {
    let text = std::fs::read_to_string(coordinate).unwrap();
    let mut s = String::new();
    for l in text.lines() {
        let t: Vec<&str> = l.split_whitespace().collect();
        let (i, j): (usize, usize) = (t[0].parse().unwrap(), t[1].parse().unwrap());
        s.push_str(&format!(
            "{}, {}, {}, {}, {}\n",
            nodes[(i - 1) / 3],
            (i - 1) % 3 + 1,
            nodes[(j - 1) / 3],
            (j - 1) % 3 + 1,
            t[2]
        ));
    }
    std::fs::write(out, s).unwrap();
}

#[test]
fn abaqus_node_dof_format_reads_like_coordinate() {
    let Some(files) = abaqus_set("blockC3D8", "_") else {
        return;
    };
    let coord = import::read(&files).unwrap();
    let nodes: Vec<u64> = coord.dofs.iter().step_by(3).map(|d| d.node).collect();
    let tmp = scratch();
    let (k, m) = (
        tmp.path().join("job_STIF2.mtx"),
        tmp.path().join("job_MASS2.mtx"),
    );
    to_node_dof(&files[0], &nodes, &k);
    to_node_dof(&files[1], &nodes, &m);
    let nd = abaqus::read(&k, &m, Some(&files[2])).unwrap();
    assert_eq!(nd.format, Format::AbaqusNodeDof);
    assert_eq!(nd.dofs, coord.dofs);
    assert_eq!(nd.nodes, coord.nodes);
    assert_eq!(rel_diff(&nd.stiffness, &coord.stiffness), 0.0);
    assert_eq!(rel_diff(&nd.mass, &coord.mass), 0.0);
}

#[test]
fn abaqus_rotations_and_internal_nodes() {
    let tmp = scratch();
    let deck = tmp.path().join("two.inp");
    std::fs::write(
        &deck,
        "*Heading\n*Node\n 5, 0., 0., 0.\n 7, 1., 0., 0.\n*Element, type=B31\n1, 5, 7\n",
    )
    .unwrap();
    // A diagonal matrix over node 5 and 7 (DoFs 1-6) and one internal node 9 (DoF 1).
    let mut s = String::new();
    for (node, dofs) in [(7u64, 6u64), (5, 6), (9, 1)] {
        for d in 1..=dofs {
            s.push_str(&format!("{node}, {d}, {node}, {d}, {}\n", node * 10 + d));
        }
    }
    let (k, m) = (tmp.path().join("K.mtx"), tmp.path().join("M.mtx"));
    std::fs::write(&k, &s).unwrap();
    std::fs::write(&m, &s).unwrap();
    let imp = abaqus::read(&k, &m, Some(&deck)).unwrap();
    assert_eq!(imp.dofs_per_node, 6);
    assert_eq!(imp.n(), 13);
    assert_eq!(
        imp.dofs[0],
        Dof {
            node: 5,
            dir: Direction::X
        }
    );
    assert_eq!(
        imp.dofs[11],
        Dof {
            node: 7,
            dir: Direction::Rz
        }
    );
    assert_eq!(
        imp.dofs[12],
        Dof {
            node: 9,
            dir: Direction::X
        }
    );
    assert_eq!(dense(&imp.stiffness)[(11, 11)], 76.0);
    assert!(imp
        .notes
        .iter()
        .any(|n| n.contains("internal node") && n.contains('9')));
    assert!(imp.nodes.is_none(), "node 9 has no coordinates");
}

/// Writes `text` to a scratch file named `name` and returns (dir, path).
fn file(name: &str, text: &str) -> (tempfile::TempDir, PathBuf) {
    let tmp = scratch();
    let p = tmp.path().join(name);
    std::fs::write(&p, text).unwrap();
    (tmp, p)
}

#[test]
fn abaqus_bad_files() {
    let (_a, good) = file("K.mtx", "1 1 2.0\n2 2 2.0\n3 3 2.0\n");
    // Truncated line.
    let (_b, p) = file("M.mtx", "1 1 1.0\n2 2\n");
    let e = abaqus::read(&good, &p, None).unwrap_err();
    assert!(matches!(e, Error::Parse { line: 2, .. }), "{e}");
    // Unknown DoF label (11: temperature).
    let (_c, p) = file("M.mtx", "1, 1, 1, 1, 1.0\n1, 11, 1, 11, 1.0\n");
    expect_parse(
        abaqus::read(&p, &p, None).unwrap_err(),
        "unknown DoF label 11",
    );
    // The two files in different formats.
    let (_g, nd) = file("M.mtx", "1, 1, 1, 1, 1.0\n");
    expect_parse(abaqus::read(&good, &nd, None).unwrap_err(), "different");
    // Locale-broken number.
    let (_d, p) = file("M.mtx", "1 1 1,5\n");
    let e = abaqus::read(&good, &p, None).unwrap_err();
    assert!(matches!(e, Error::Parse { line: 1, .. }), "{e}");
    // Mismatched sizes: the deck defines 2 nodes, the matrices 1 node's 3 DoFs.
    let (_e, deck) = file("d.inp", "*Node\n1, 0., 0., 0.\n2, 1., 0., 0.\n");
    expect_parse(
        abaqus::read(&good, &good, Some(&deck)).unwrap_err(),
        "mismatched sizes",
    );
    // A bad *Node line.
    let (_f, deck) = file("d.inp", "*Node\n1, 0., 0., 0.\n2, x, 0., 0.\n");
    let e = abaqus::read(&good, &good, Some(&deck)).unwrap_err();
    assert!(matches!(e, Error::Parse { line: 3, .. }), "{e}");
}

#[test]
fn apdl_math_bad_files() {
    let Some(files) = ansys_rotor() else {
        return;
    };
    // Mapping vector of the wrong length.
    let (_a, map) = file(
        "map.txt",
        "%%MatrixMarket matrix array integer general\n2 1\n1\n2\n",
    );
    let e = ansys::read_apdl_math(&files[0], &files[1], &map, None).unwrap_err();
    expect_parse(e, "expected N/3 = 115");
    // Mismatched sizes of K and M.
    let (_b, m) = file(
        "m.mtx",
        "%%MatrixMarket matrix coordinate real symmetric\n3 3 1\n1 1 1.0\n",
    );
    expect_parse(
        ansys::read_apdl_math(&files[0], &m, &files[2], None).unwrap_err(),
        "mismatched sizes",
    );
    // Locale-broken coordinate (a thousands separator and a decimal comma).
    let (_c, t) = file(
        "nodes.txt",
        "Knotennummer\tX (m)\tY (m)\tZ (m)\n3\t1.000,5\t0,\t0,\n",
    );
    let e = ansys::read_apdl_math(&files[0], &files[1], &files[2], Some(&t)).unwrap_err();
    assert!(matches!(e, Error::Parse { line: 2, .. }), "{e}");
    // A node of the mapping missing from the table.
    let (_d, t) = file("nodes.txt", "node;x;y;z\n3;0,1;0;0\n");
    expect_parse(
        ansys::read_apdl_math(&files[0], &files[1], &files[2], Some(&t)).unwrap_err(),
        "node 31 of the matrices has no coordinates",
    );
    // The set without its mapping vector.
    expect_parse(import::read(&files[..2]).unwrap_err(), "mapping vector");
}

#[test]
fn node_tables_in_every_separator() {
    for text in [
        "node x y z\n1 0.5 1.5 2.5\n",
        "node;x;y;z\n1;0,5;1,5;2,5\n",
        "node,x,y,z\n1,0.5,1.5,2.5\n",
        "Knotennummer\tX-Position (mm)\tY\tZ\t\n1\t0,5\t1,5\t2,5\t\n",
    ] {
        let (_t, p) = file("n.txt", text);
        let t = import::read_node_table(&p).unwrap();
        assert_eq!(t.rows, vec![(1, [0.5, 1.5, 2.5])], "{text}");
    }
    let (_t, p) = file("n.txt", "Knotennummer\tX-Position (mm)\n1\t0,5\t1,5\t2,5\n");
    assert_eq!(
        import::read_node_table(&p).unwrap().length_unit.as_deref(),
        Some("mm")
    );
}

fn lower_coordinate_text(entries: &[(usize, usize, f64)]) -> String {
    entries
        .iter()
        .map(|(i, j, v)| format!("{} {} {v:e}\n", i + 1, j + 1))
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// A random symmetric matrix written as one COORDINATE triangle reads back mirrored, equal
    /// to the last bit.
    #[test]
    fn abaqus_coordinate_round_trip(n in 1usize..12, raw in proptest::collection::vec((0usize..12, 0usize..12, -1e9f64..1e9), 1..40)) {
        let mut entries: Vec<(usize, usize, f64)> = raw.into_iter()
            .map(|(i, j, v)| (i.max(j) % n, i.min(j) % n, v))
            .map(|(i, j, v)| (i.max(j), i.min(j), v))
            .collect();
        entries.sort_by_key(|e| (e.1, e.0));
        entries.dedup_by_key(|e| (e.1, e.0));
        entries.push((n - 1, n - 1, 1.0));
        entries.dedup_by_key(|e| (e.1, e.0));
        let (_t, p) = file("K.mtx", &lower_coordinate_text(&entries));
        let imp = abaqus::read(&p, &p, None);
        if n % 3 != 0 {
            prop_assert!(imp.is_err());
        } else {
            let imp = imp.unwrap();
            let d = dense(&imp.stiffness);
            for &(i, j, v) in &entries {
                prop_assert_eq!(d[(i, j)], v);
                prop_assert_eq!(d[(j, i)], v);
            }
        }
    }

    /// Random text as Abaqus matrices, decks and node tables: an error or a model, never a panic.
    #[test]
    fn text_readers_never_panic(text in "[0-9 ,.eE+\\-\\t\\n*a-zN;]{0,300}") {
        let (_t, p) = file("K.mtx", &text);
        let _ = abaqus::read(&p, &p, Some(&p));
        let _ = import::read_node_table(&p);
        let _ = import::read(std::slice::from_ref(&p));
    }
}

// ---------------------------------------------------------------------------------------------
// End to end: line-fitting and SEREP on the Abaqus blocks (outputs named node:dir), and the
// CLI (`import`, `modes`) on both rotors

#[test]
fn abaqus_blocks_reduce_end_to_end() {
    use sparsemor::reduce::linefit::{self, Interface, LineFitOptions, References};
    use sparsemor::reduce::serep::{self, ModeChoice, SerepOptions};
    use sparsemor::scene::Scene;
    for job in ["blockC3D8", "blockC3D10", "blockC3D20R"] {
        let Some(files) = abaqus_set(job, "_") else {
            return;
        };
        let imp = import::read(&files).unwrap();
        let io = DofNames::from_map(&imp.dofs)
            .indices("1:x,1:y,1:z", "outputs")
            .unwrap();
        let scene = Scene {
            inputs: io.clone(),
            outputs: io.clone(),
            band_hz: [0.0, 2000.0],
        };
        let (model, _) = imp.into_model(job.into()).unwrap();
        let body = Body::new(&model).unwrap();
        let opts = LineFitOptions::new(
            Interface::OutputsPlus(6),
            References::Explicit(vec![100.0, 400.0, 800.0, 1200.0, 1600.0]),
        );
        let rom =
            linefit::reduce(&body, &scene, &opts, None, &sparsemor::sweep::no_progress).unwrap();
        assert_eq!(rom.order(), 9, "{job}");
        let opts = SerepOptions {
            modes: ModeChoice::LowestDeformation(3),
            retain: Some(io),
            keep_basis: false,
            eigen: EigenOptions::for_band(2000.0),
        };
        let rom = serep::reduce(&body, &scene, &opts, None).unwrap();
        assert_eq!(rom.order(), 3, "{job}");
    }
}

fn cli(args: &[&str]) -> String {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_sparsemor"))
        .args(args)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "sparsemor {args:?} failed:\n{text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

/// `sparsemor modes --csv` frequencies and the rigid count.
fn cli_modes(dir: &Path, csv: &Path) -> (Vec<f64>, usize) {
    let d = dir.to_str().unwrap();
    cli(&[
        "modes",
        d,
        "--band",
        "0:420",
        "--csv",
        csv.to_str().unwrap(),
    ]);
    let text = std::fs::read_to_string(csv).unwrap();
    let rows: Vec<Vec<String>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect();
    let f = rows.iter().map(|r| r[1].parse().unwrap()).collect();
    (f, rows.iter().filter(|r| r[2] == "rigid").count())
}

#[test]
fn cli_import_and_modes_on_both_rotors() {
    let (Some(a), Some(b)) = (ansys_rotor(), abaqus_set("rotorDiscTest", "")) else {
        return;
    };
    let tmp = scratch();
    let (da, db) = (tmp.path().join("ansys"), tmp.path().join("abaqus"));
    let mut args: Vec<&str> = vec!["import"];
    args.extend(a.iter().map(|p| p.to_str().unwrap()));
    args.extend(["--out", da.to_str().unwrap()]);
    cli(&args);
    let mut args: Vec<&str> = vec!["import"];
    args.extend(b.iter().map(|p| p.to_str().unwrap()));
    args.extend([
        "--scale-stiffness",
        "1e-2",
        "--inputs",
        "111:x,111:y",
        "--outputs",
        "111:y",
    ]);
    args.extend(["--out", db.to_str().unwrap()]);
    let printed = cli(&args);
    assert!(
        printed.contains("inputs 111:x,111:y, outputs 111:y"),
        "{printed}"
    );
    // The written directory reads back with its DoF map.
    let map = sparsemor::io::model_dir::read_dof_map(&db)
        .unwrap()
        .unwrap();
    assert_eq!(map.len(), 345);
    let (_, scene, _) = sparsemor::io::model_dir::read(&db).unwrap();
    assert_eq!(map[scene.outputs[0]], "111:y".parse().unwrap());
    let (fa, ra) = cli_modes(&da, &tmp.path().join("a.csv"));
    let (fb, rb) = cli_modes(&db, &tmp.path().join("b.csv"));
    assert_eq!((ra, rb), (6, 6));
    assert!(fa.len() >= 18 && fb.len() >= 18);
    for f in [fa[6], fb[6]] {
        assert!((f - 104.63701).abs() < 1e-5, "{f}");
    }
    for k in 6..18 {
        assert!(
            ((fa[k] - fb[k]) / fa[k]).abs() <= 1e-6,
            "mode {k}: {} vs {}",
            fa[k],
            fb[k]
        );
    }
}

// ---------------------------------------------------------------------------------------------
// model.toml pointing at the FE code's files ([import]) and DoFs named NODE:DIR

/// A model directory whose `model.toml` names the ANSYS `.full` file loads the same K and M
/// as the converted directory that `sparsemor import` writes, and its `[scene]` may name DoFs
/// as NODE:DIR; a wrong `format`, both matrix sources, or an unknown DoF is an error naming
/// `model.toml` and the fix.
#[test]
fn a_model_toml_may_point_at_the_original_files() {
    let Some(dir) = data("ansys_example_full") else {
        return;
    };
    let full = dir.join("file.full");
    let imp = import::read(std::slice::from_ref(&full)).unwrap();
    let first = imp.dofs[0];
    let second = imp.dofs[1];
    let (converted, _) = imp.clone().into_model("converted".into()).unwrap();
    let tmp = scratch();
    let write = |toml: &str| {
        std::fs::write(tmp.path().join("model.toml"), toml).unwrap();
        model_dir::load(tmp.path())
    };
    let scene = format!(
        "[scene]\ninputs = [\"{first}\", 1]\noutputs = [\"{second}\"]\nband_hz = [0.0, 100.0]\n"
    );
    let import = format!(
        "[import]\nformat = \"ansys-full\"\nfiles = [{:?}]\n",
        full.display().to_string()
    );
    let loaded = write(&format!("name = \"direct\"\n{import}{scene}")).unwrap();
    assert_eq!(rel_diff(&loaded.model.stiffness, &converted.stiffness), 0.0);
    assert_eq!(rel_diff(&loaded.model.mass, &converted.mass), 0.0);
    assert_eq!(loaded.scene.inputs, vec![0, 1]);
    assert_eq!(loaded.scene.outputs, vec![1]);
    assert_eq!(loaded.model.dofs_per_node, imp.dofs_per_node);
    // K scaled on load, as `import --scale-stiffness` does
    let scaled = write(&format!(
        "name = \"direct\"\n{}scale_stiffness = 0.5\n{scene}",
        import
    ))
    .unwrap();
    let half = scaled.model.stiffness.val()[0] / converted.stiffness.val()[0];
    assert_eq!(half, 0.5);

    let cases: [(String, &[&str]); 5] = [
        (
            format!(
                "name = \"x\"\n{}{scene}",
                import.replace("ansys-full", "abaqus-coordinate")
            ),
            &["model.toml", "format = \"abaqus-coordinate\"", "ansys-full"],
        ),
        (
            format!("name = \"x\"\nmass = \"M.mtx\"\nstiffness = \"K.mtx\"\n{import}{scene}"),
            &["model.toml", "either `mass` and `stiffness`", "[import]"],
        ),
        (
            format!(
                "name = \"x\"\n{import}{}",
                scene.replace(&second.to_string(), "999999:z")
            ),
            &["model.toml", "[scene] outputs", "999999:z", "DoF map"],
        ),
        (
            format!(
                "name = \"x\"\n{import}{}",
                scene.replace(&second.to_string(), "7:w")
            ),
            &["[scene] outputs", "direction 'w'"],
        ),
        (
            format!("name = \"x\"\n{}length_unit = \"inch\"\n{scene}", import),
            &["model.toml", "length unit 'inch'"],
        ),
    ];
    for (toml, needles) in cases {
        let msg = write(&toml).unwrap_err().to_string();
        for n in needles {
            assert!(msg.contains(n), "'{msg}' lacks '{n}'");
        }
    }
}

/// A model without a DoF map names node i's DoFs dofs_per_node·i + k; names and indices
/// mix; a direction the model lacks, a node past the end and an index ≥ N are errors.
#[test]
fn dof_names_without_a_map_count_nodes_from_zero() {
    let names = DofNames::PerNode {
        n: 12,
        dofs_per_node: 3,
    };
    assert_eq!(
        names.indices("0:x, 3:z,1:y,5", "--interface").unwrap(),
        [0, 11, 4, 5]
    );
    for (bad, needle) in [
        (
            "1:rx",
            "no DoF 1:rx (4 nodes numbered from 0, 3 DoFs each (x, y, z))",
        ),
        ("4:x", "no DoF 4:x"),
        ("12", "12"),
        ("x", "expected NODE:DIR"),
    ] {
        let msg = names.index(bad, "--interface").unwrap_err().to_string();
        assert!(msg.contains(needle) && msg.contains("--interface"), "{msg}");
    }
    let six = DofNames::PerNode {
        n: 12,
        dofs_per_node: 6,
    };
    assert_eq!(six.index("1:rz", "x").unwrap(), 11);
}

/// `[import] files` naming a device is refused before a byte is read (the import's sniffing
/// would otherwise block on a pipe or read /dev/zero forever).
#[test]
fn an_import_naming_a_device_is_refused() {
    let tmp = scratch();
    std::fs::write(
        tmp.path().join("model.toml"),
        "name = \"x\"\n[import]\nformat = \"ansys-full\"\nfiles = [\"/dev/zero\"]\n\
         [scene]\ninputs = [0]\noutputs = [0]\nband_hz = [0.0, 1.0]\n",
    )
    .unwrap();
    let msg = model_dir::load(tmp.path()).unwrap_err().to_string();
    assert!(
        msg.contains("/dev/zero") && msg.contains("not a regular file"),
        "{msg}"
    );
}

mod op4;

/// EXUDYN's own readers (`FEMinterface.Read{Stiffness,Mass}MatrixFrom{Ansys,Abaqus}`, pip
/// `exudyn`) give the same K and M as sparsemor's importers on the ANSYS rotor (APDL-Math
/// export + DoF mapping vector; EXUDYN orders DoFs by node, 3·(node − 1) + dir, sparsemor keeps
/// the equation order and names each DoF, so the test maps one onto the other) and on the
/// Abaqus rotor and blocks (COORDINATE: both keep the file's order). Skipped without exudyn.
#[test]
fn exudyn_readers_give_the_same_k_and_m() {
    let has = std::process::Command::new("python3")
        .args(["-c", "import exudyn.FEM, scipy"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !has {
        println!("NOTE: python3 with exudyn and scipy not found; skipped (pip install exudyn)");
        return;
    }
    let (Some(ansys), Some(rotor)) = (ansys_rotor(), abaqus_set("rotorDiscTest", "")) else {
        return;
    };
    let mut cases = vec![("ansys", ansys), ("abaqus", rotor)];
    for job in ["blockC3D8", "blockC3D10", "blockC3D20R"] {
        cases.extend(abaqus_set(job, "_").map(|f| ("abaqus", f)));
    }
    const SCRIPT: &str = r#"
import sys, numpy as np, scipy.io as sio, scipy.sparse as sp
import exudyn.FEM as F
kind, k, m, mapping, tmp = sys.argv[1:6]
f = F.FEMinterface()
if kind == "ansys":
    f.ReadStiffnessMatrixFromAnsys(k, mapping)
    f.ReadMassMatrixFromAnsys(m, mapping)
else:
    f.ReadStiffnessMatrixFromAbaqus(k)
    f.ReadMassMatrixFromAbaqus(m)
p = np.loadtxt(tmp + "/perm.txt", dtype=int, ndmin=1)
for name, ours, theirs in [("K", "K.mtx", f.stiffnessMatrix), ("M", "M.mtx", f.massMatrix)]:
    s = sp.coo_matrix(sio.mmread(tmp + "/" + ours))
    e = sp.csr_matrix(theirs)
    assert e.shape == s.shape, (e.shape, s.shape)
    mapped = sp.coo_matrix((s.data, (p[s.row], p[s.col])), shape=s.shape).tocsr()
    print(name, abs(mapped - e).max() / abs(e).max())
"#;
    for (kind, files) in cases {
        let imp = import::read(&files).unwrap();
        let tmp = scratch();
        let t = tmp.path();
        matrix_market::write_coordinate(&t.join("K.mtx"), imp.stiffness.as_ref(), false).unwrap();
        matrix_market::write_coordinate(&t.join("M.mtx"), imp.mass.as_ref(), false).unwrap();
        let perm: Vec<String> = imp
            .dofs
            .iter()
            .enumerate()
            .map(|(i, d)| match kind {
                "ansys" => (3 * (d.node as usize - 1) + d.dir as usize).to_string(),
                _ => i.to_string(),
            })
            .collect();
        std::fs::write(t.join("perm.txt"), perm.join("\n")).unwrap();
        let mapping = if kind == "ansys" {
            &files[2]
        } else {
            &files[0]
        };
        let arg = |p: &Path| p.to_str().unwrap().to_string();
        let out = std::process::Command::new("python3")
            .args(["-c", SCRIPT, kind, &arg(&files[0]), &arg(&files[1])])
            .args([arg(mapping), arg(t)])
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout).into_owned();
        assert!(
            out.status.success(),
            "{kind} {:?}: {text}{}",
            files[0],
            String::from_utf8_lossy(&out.stderr)
        );
        println!(
            "{:?} vs EXUDYN's reader: {}",
            files[0].file_name().unwrap(),
            text.replace('\n', " ")
        );
        for line in text.lines() {
            let (name, diff) = line.split_once(' ').unwrap();
            let diff: f64 = diff.trim().parse().unwrap();
            assert!(diff <= 1e-14, "{kind} {name}: {diff:e}");
        }
        assert_eq!(text.lines().count(), 2, "{text}");
    }
}
