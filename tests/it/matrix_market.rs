//! Tests of `sparsemor::io::matrix_market`: round trips, conventions, every malformed-input
//! error (with its line), the real ANSYS example and a round-trip property.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

use faer::sparse::{SparseColMat, SymbolicSparseColMat};
use faer::Mat;
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use sparsemor::io::matrix_market::{self, MtxData, Symmetry};
use sparsemor::Error;

// ---------------------------------------------------------------------------------------------
// Helpers

fn tmpdir() -> tempfile::TempDir {
    tempfile::tempdir().expect("temp dir")
}

fn put(dir: &Path, name: &str, content: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, content).expect("write test file");
    p
}

fn gzip(data: &[u8]) -> Vec<u8> {
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    enc.write_all(data).expect("gzip");
    enc.finish().expect("gzip")
}

/// Builds a canonical CSC matrix from (row, col) -> value.
fn csc(
    nrows: usize,
    ncols: usize,
    map: &BTreeMap<(usize, usize), f64>,
) -> SparseColMat<usize, f64> {
    // BTreeMap keyed by (col, row) gives column-major order.
    let by_col: BTreeMap<(usize, usize), f64> =
        map.iter().map(|(&(i, j), &v)| ((j, i), v)).collect();
    let mut col_ptr = vec![0usize; ncols + 1];
    let mut row_idx = Vec::new();
    let mut val = Vec::new();
    for (&(j, i), &v) in &by_col {
        col_ptr[j + 1] += 1;
        row_idx.push(i);
        val.push(v);
    }
    for j in 0..ncols {
        col_ptr[j + 1] += col_ptr[j];
    }
    SparseColMat::new(
        SymbolicSparseColMat::new_checked(nrows, ncols, col_ptr, None, row_idx),
        val,
    )
}

/// Asserts identical shape, pattern and value bits.
fn assert_same(a: &SparseColMat<usize, f64>, b: &SparseColMat<usize, f64>) {
    assert_eq!((a.nrows(), a.ncols()), (b.nrows(), b.ncols()), "shape");
    let (sa, va) = a.parts();
    let (sb, vb) = b.parts();
    assert_eq!(sa.col_ptr(), sb.col_ptr(), "column pointers");
    assert_eq!(sa.row_idx(), sb.row_idx(), "row indices");
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(va), bits(vb), "value bits");
}

fn assert_same_dense(a: &Mat<f64>, b: &Mat<f64>) {
    assert_eq!((a.nrows(), a.ncols()), (b.nrows(), b.ncols()), "shape");
    for j in 0..a.ncols() {
        for i in 0..a.nrows() {
            assert_eq!(a[(i, j)].to_bits(), b[(i, j)].to_bits(), "entry ({i}, {j})");
        }
    }
}

/// Dense copy of a sparse matrix.
fn dense(a: &SparseColMat<usize, f64>) -> Mat<f64> {
    let mut m = Mat::zeros(a.nrows(), a.ncols());
    for j in 0..a.ncols() {
        for (&i, &v) in a.row_idx_of_col_raw(j).iter().zip(a.val_of_col(j)) {
            m[(i, j)] += v;
        }
    }
    m
}

fn dense_from(rows: &[&[f64]]) -> Mat<f64> {
    Mat::from_fn(rows.len(), rows[0].len(), |i, j| rows[i][j])
}

/// Interesting values: tiny, huge, negative, subnormal, negative zero, long mantissas.
const SPECIAL: [f64; 12] = [
    1e-300,
    -1e-300,
    1e300,
    -1.7976931348623157e308,
    5e-324,
    -2.2250738585072014e-308,
    -0.0,
    0.1,
    1.0 / 3.0,
    -123456789.12345679,
    3027152.8056777236,
    1e22,
];

fn random_value(rng: &mut impl Rng) -> f64 {
    if rng.gen_bool(0.2) {
        SPECIAL[rng.gen_range(0..SPECIAL.len())]
    } else {
        let m: f64 = rng.gen_range(-1.0..1.0);
        m * 10f64.powi(rng.gen_range(-20..20))
    }
}

/// Reads `content` (as a file) and returns the parse error's (line, message), asserting that
/// it is an `Error::Parse` naming the file.
fn parse_error(content: &[u8]) -> (usize, String) {
    let dir = tmpdir();
    let p = put(dir.path(), "bad.mtx", content);
    match matrix_market::read(&p) {
        Err(Error::Parse { path, line, msg }) => {
            assert_eq!(path, p, "error names the file");
            (line, msg)
        }
        Err(e) => panic!("expected a parse error, got {e:?}"),
        Ok(m) => panic!(
            "expected a parse error, read a {}x{} matrix",
            m.nrows(),
            m.ncols()
        ),
    }
}

/// Asserts a parse error at `line` whose message contains every one of `needles`
/// (case-insensitively).
#[track_caller]
fn expect_error(content: &str, line: usize, needles: &[&str]) {
    let (l, msg) = parse_error(content.as_bytes());
    assert_eq!(l, line, "line of error `{msg}`");
    for n in needles {
        assert!(
            msg.to_lowercase().contains(&n.to_lowercase()),
            "message `{msg}` should mention `{n}`"
        );
    }
}

const GEN: &str = "%%MatrixMarket matrix coordinate real general\n";
const SYM: &str = "%%MatrixMarket matrix coordinate real symmetric\n";

// ---------------------------------------------------------------------------------------------
// Round trips

fn random_sparse(
    rng: &mut impl Rng,
    nrows: usize,
    ncols: usize,
    nnz: usize,
) -> BTreeMap<(usize, usize), f64> {
    let mut map = BTreeMap::new();
    for _ in 0..nnz {
        map.insert(
            (rng.gen_range(0..nrows), rng.gen_range(0..ncols)),
            random_value(rng),
        );
    }
    map
}

#[test]
fn round_trip_general_sparse_is_bit_exact() {
    let dir = tmpdir();
    let mut rng = rand::rngs::StdRng::seed_from_u64(7);
    for (k, &(m, n, nnz)) in [
        (1, 1, 1),
        (50, 40, 300),
        (7, 300, 900),
        (200, 3, 500),
        (5, 5, 0),
    ]
    .iter()
    .enumerate()
    {
        let a = csc(m, n, &random_sparse(&mut rng, m, n, nnz));
        let p = dir.path().join(format!("g{k}.mtx"));
        matrix_market::write_coordinate(&p, a.as_ref(), false).unwrap();
        let b = matrix_market::read_sparse(&p).unwrap();
        assert_same(&a, &b);
        let full = matrix_market::read(&p).unwrap();
        assert_eq!(full.symmetry, Symmetry::General);
        assert!(!dir.path().join(format!("g{k}.mtx.tmp")).exists());
    }
}

#[test]
fn round_trip_symmetric_sparse_is_bit_exact() {
    let dir = tmpdir();
    let mut rng = rand::rngs::StdRng::seed_from_u64(11);
    for (k, &(n, nnz)) in [(1, 1), (30, 100), (300, 2000)].iter().enumerate() {
        let lower = random_sparse(&mut rng, n, n, nnz);
        let mut full = BTreeMap::new();
        for (&(i, j), &v) in &lower {
            let (i, j) = if i >= j { (i, j) } else { (j, i) };
            full.insert((i, j), v);
            full.insert((j, i), v);
        }
        let a = csc(n, n, &full);
        let p = dir.path().join(format!("s{k}.mtx"));
        matrix_market::write_coordinate(&p, a.as_ref(), true).unwrap();
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.starts_with("%%MatrixMarket matrix coordinate real symmetric\n"));
        // Only the lower triangle is written.
        let stored = full.keys().filter(|(i, j)| i >= j).count();
        assert_eq!(text.lines().count(), 2 + stored);
        let m = matrix_market::read(&p).unwrap();
        assert_eq!(m.symmetry, Symmetry::Symmetric);
        let MtxData::Sparse(b) = m.data else {
            panic!("coordinate file gives sparse data")
        };
        assert_same(&a, &b);
    }
}

#[test]
fn round_trip_dense_is_bit_exact() {
    let dir = tmpdir();
    let mut rng = rand::rngs::StdRng::seed_from_u64(3);
    for (k, &(m, n)) in [(1, 1), (13, 7), (4, 30), (0, 3)].iter().enumerate() {
        let a = Mat::from_fn(m, n, |_, _| random_value(&mut rng));
        let p = dir.path().join(format!("d{k}.mtx"));
        matrix_market::write_array(&p, a.as_ref()).unwrap();
        let b = matrix_market::read_dense(&p).unwrap();
        assert_same_dense(&a, &b);
    }
    // Every special value, including -0.0, survives.
    let a = Mat::from_fn(SPECIAL.len(), 1, |i, _| SPECIAL[i]);
    let p = dir.path().join("special.mtx");
    matrix_market::write_array(&p, a.as_ref()).unwrap();
    assert_same_dense(&a, &matrix_market::read_dense(&p).unwrap());
}

#[test]
fn reads_gzip_by_magic_bytes() {
    let dir = tmpdir();
    let mut rng = rand::rngs::StdRng::seed_from_u64(5);
    let a = csc(40, 40, &random_sparse(&mut rng, 40, 40, 200));
    let plain = dir.path().join("a.mtx");
    matrix_market::write_coordinate(&plain, a.as_ref(), false).unwrap();
    let bytes = std::fs::read(&plain).unwrap();
    // With the usual extension and without any: detection is by content.
    for name in ["a.mtx.gz", "compressed.mtx", "noext"] {
        let p = put(dir.path(), name, &gzip(&bytes));
        assert_same(&a, &matrix_market::read_sparse(&p).unwrap());
    }
    // Array files too.
    let d = dense_from(&[&[1.0, 2.0], &[3.0, 4.5]]);
    let pd = dir.path().join("d.mtx");
    matrix_market::write_array(&pd, d.as_ref()).unwrap();
    let gz = put(dir.path(), "d.mtx.gz", &gzip(&std::fs::read(&pd).unwrap()));
    assert_same_dense(&d, &matrix_market::read_dense(&gz).unwrap());
}

#[test]
fn gzip_of_a_large_file_parses_in_parallel_path() {
    // Large enough (> 1 MiB of entries) for the chunked parallel parser.
    let dir = tmpdir();
    let mut rng = rand::rngs::StdRng::seed_from_u64(9);
    let n = 3000;
    let a = csc(n, n, &random_sparse(&mut rng, n, n, 60_000));
    let p = dir.path().join("big.mtx");
    matrix_market::write_coordinate(&p, a.as_ref(), false).unwrap();
    assert!(std::fs::metadata(&p).unwrap().len() > 1 << 20);
    assert_same(&a, &matrix_market::read_sparse(&p).unwrap());
    let gz = put(dir.path(), "big.mtx.gz", &gzip(&std::fs::read(&p).unwrap()));
    assert_same(&a, &matrix_market::read_sparse(&gz).unwrap());
}

// ---------------------------------------------------------------------------------------------
// Conventions

#[test]
fn symmetric_lower_file_is_expanded() {
    let dir = tmpdir();
    let p = put(
        dir.path(),
        "s.mtx",
        format!("{SYM}3 3 5\n1 1 4\n2 1 -1\n3 1 0.5\n2 2 5\n3 3 6\n").as_bytes(),
    );
    let a = matrix_market::read_sparse(&p).unwrap();
    assert_eq!(a.compute_nnz(), 7);
    let expected = dense_from(&[&[4.0, -1.0, 0.5], &[-1.0, 5.0, 0.0], &[0.5, 0.0, 6.0]]);
    assert_same_dense(&dense(&a), &expected);
    // Rows sorted within columns.
    assert_eq!(a.symbolic().row_idx(), &[0, 1, 2, 0, 1, 0, 2]);
    assert_same_dense(&matrix_market::read_dense(&p).unwrap(), &expected);
}

#[test]
fn symmetric_upper_only_file_is_accepted() {
    let dir = tmpdir();
    let p = put(
        dir.path(),
        "u.mtx",
        format!("{SYM}3 3 4\n1 1 4\n1 2 -1\n1 3 0.5\n3 3 6\n").as_bytes(),
    );
    let expected = dense_from(&[&[4.0, -1.0, 0.5], &[-1.0, 0.0, 0.0], &[0.5, 0.0, 6.0]]);
    assert_same_dense(&dense(&matrix_market::read_sparse(&p).unwrap()), &expected);
}

#[test]
fn duplicates_are_summed() {
    let dir = tmpdir();
    let p = put(
        dir.path(),
        "dup.mtx",
        format!("{GEN}2 2 5\n1 1 1\n2 1 2\n1 1 10\n1 2 3\n2 1 20\n").as_bytes(),
    );
    let a = matrix_market::read_sparse(&p).unwrap();
    assert_eq!(a.compute_nnz(), 3);
    assert_same_dense(&dense(&a), &dense_from(&[&[11.0, 3.0], &[22.0, 0.0]]));

    // Symmetric: duplicates summed and mirrored consistently.
    let p = put(
        dir.path(),
        "dups.mtx",
        format!("{SYM}2 2 4\n2 1 0.1\n1 1 1\n2 1 0.2\n1 1 2\n").as_bytes(),
    );
    let a = matrix_market::read_sparse(&p).unwrap();
    assert_eq!(a.compute_nnz(), 3);
    let d = dense(&a);
    assert_eq!(d[(1, 0)].to_bits(), (0.1f64 + 0.2).to_bits());
    assert_eq!(d[(0, 1)].to_bits(), d[(1, 0)].to_bits());
    assert_eq!(d[(0, 0)], 3.0);
}

#[test]
fn integer_field_is_read_as_real() {
    let dir = tmpdir();
    let p = put(
        dir.path(),
        "i.mtx",
        b"%%MatrixMarket matrix coordinate integer general\n2 3 2\n1 3 -7\n2 1 42\n",
    );
    let d = dense(&matrix_market::read_sparse(&p).unwrap());
    assert_same_dense(&d, &dense_from(&[&[0.0, 0.0, -7.0], &[42.0, 0.0, 0.0]]));
    let p = put(
        dir.path(),
        "ia.mtx",
        b"%%MatrixMarket matrix array integer general\n1 2\n5\n-6\n",
    );
    assert_same_dense(
        &matrix_market::read_dense(&p).unwrap(),
        &dense_from(&[&[5.0, -6.0]]),
    );
}

#[test]
fn comments_blank_lines_crlf_tabs_and_case() {
    let dir = tmpdir();
    let text = "%%matrixmarket MATRIX Coordinate REAL General\r\n\
                % a comment\r\n\
                \r\n\
                %another comment\n\
                   \t\n\
                  2   2\t2  \r\n\
                \n\
                1\t1   1.5e0\r\n\
                \n\
                \x20 2 2 -2.5  \r\n\
                \n";
    let p = put(dir.path(), "c.mtx", text.as_bytes());
    let d = dense(&matrix_market::read_sparse(&p).unwrap());
    assert_same_dense(&d, &dense_from(&[&[1.5, 0.0], &[0.0, -2.5]]));
    // `double` is a synonym of `real`.
    let p = put(
        dir.path(),
        "dbl.mtx",
        b"%%MatrixMarket matrix coordinate double general\n1 1 1\n1 1 2\n",
    );
    assert_eq!(dense(&matrix_market::read_sparse(&p).unwrap())[(0, 0)], 2.0);
}

#[test]
fn array_symmetric_is_lower_column_major_and_expanded() {
    let dir = tmpdir();
    // Lower triangle of [[1,2,3],[2,4,5],[3,5,6]] column by column: 1 2 3 4 5 6.
    let p = put(
        dir.path(),
        "as.mtx",
        b"%%MatrixMarket matrix array real symmetric\n3 3\n1\n2\n3\n4\n5\n6\n",
    );
    let m = matrix_market::read(&p).unwrap();
    assert_eq!(m.symmetry, Symmetry::Symmetric);
    let expected = dense_from(&[&[1.0, 2.0, 3.0], &[2.0, 4.0, 5.0], &[3.0, 5.0, 6.0]]);
    let MtxData::Dense(d) = m.data else {
        panic!("array file gives dense data")
    };
    assert_same_dense(&d, &expected);
}

#[test]
fn array_general_is_column_major() {
    let dir = tmpdir();
    let p = put(
        dir.path(),
        "a.mtx",
        b"%%MatrixMarket matrix array real general\n2 3\n1\n2\n3\n4\n5\n6\n",
    );
    let expected = dense_from(&[&[1.0, 3.0, 5.0], &[2.0, 4.0, 6.0]]);
    assert_same_dense(&matrix_market::read_dense(&p).unwrap(), &expected);
    let text = {
        let q = dir.path().join("w.mtx");
        matrix_market::write_array(&q, expected.as_ref()).unwrap();
        std::fs::read_to_string(&q).unwrap()
    };
    assert!(text.starts_with("%%MatrixMarket matrix array real general\n2 3\n"));
}

#[test]
fn conversions_between_sparse_and_dense() {
    let dir = tmpdir();
    // read_sparse of an array file keeps the nonzeros.
    let p = put(
        dir.path(),
        "a.mtx",
        b"%%MatrixMarket matrix array real general\n2 2\n0\n2\n0\n-1\n",
    );
    let a = matrix_market::read_sparse(&p).unwrap();
    assert_eq!(a.compute_nnz(), 2);
    assert_same_dense(&dense(&a), &dense_from(&[&[0.0, 0.0], &[2.0, -1.0]]));
    // read_dense of a coordinate file.
    let p = put(
        dir.path(),
        "c.mtx",
        format!("{GEN}2 3 2\n2 3 7\n1 1 1\n").as_bytes(),
    );
    assert_same_dense(
        &matrix_market::read_dense(&p).unwrap(),
        &dense_from(&[&[1.0, 0.0, 0.0], &[0.0, 0.0, 7.0]]),
    );
}

#[test]
fn empty_matrices() {
    let dir = tmpdir();
    let p = put(dir.path(), "e.mtx", format!("{GEN}0 0 0\n").as_bytes());
    let a = matrix_market::read_sparse(&p).unwrap();
    assert_eq!((a.nrows(), a.ncols(), a.compute_nnz()), (0, 0, 0));
    let p = put(dir.path(), "e2.mtx", format!("{GEN}4 5 0").as_bytes());
    let a = matrix_market::read_sparse(&p).unwrap();
    assert_eq!((a.nrows(), a.ncols(), a.compute_nnz()), (4, 5, 0));
}

/// Empty arrays: 0×3 and 3×0 read as such; a 0×18518521 size line (found by fuzzing: faer
/// pads columns to 16 rows, so it asked for 2.4 GB) is an error naming the size line.
#[test]
fn empty_arrays_and_an_implausible_empty_size() {
    let dir = tmpdir();
    let arr = "%%MatrixMarket matrix array real general\n";
    for (r, c) in [(0usize, 3usize), (3, 0)] {
        let p = put(dir.path(), "a.mtx", format!("{arr}{r} {c}\n").as_bytes());
        let a = matrix_market::read_dense(&p).unwrap();
        assert_eq!((a.nrows(), a.ncols()), (r, c));
    }
    expect_error(&format!("{arr}0 18518521\n"), 2, &["empty", "size line"]);
}

// ---------------------------------------------------------------------------------------------
// Malformed input: one test per problem, each checking the line and the message

#[test]
fn error_missing_banner() {
    expect_error("3 3 1\n1 1 1\n", 1, &["banner"]);
    expect_error(
        "%MatrixMarket matrix coordinate real general\n1 1 1\n1 1 1\n",
        1,
        &["banner"],
    );
    expect_error("", 1, &["empty", "banner"]);
}

#[test]
fn error_bad_banner() {
    expect_error(
        "%%MatrixMarket matrix coordinate real\n1 1 1\n1 1 1\n",
        1,
        &["banner", "5 words"],
    );
    expect_error(
        "%%MatrixMarket vector coordinate real general\n1 1 1\n1 1 1\n",
        1,
        &["vector"],
    );
}

#[test]
fn error_unsupported_field() {
    for field in ["complex", "pattern", "Complex"] {
        expect_error(
            &format!("%%MatrixMarket matrix coordinate {field} general\n1 1 1\n1 1 1\n"),
            1,
            &[
                "unsupported field",
                &field.to_lowercase(),
                "real",
                "integer",
            ],
        );
    }
}

#[test]
fn error_unsupported_symmetry() {
    for sym in ["hermitian", "skew-symmetric"] {
        expect_error(
            &format!("%%MatrixMarket matrix coordinate real {sym}\n1 1 1\n1 1 1\n"),
            1,
            &["unsupported symmetry", sym, "general and symmetric"],
        );
    }
}

#[test]
fn error_unsupported_format() {
    expect_error(
        "%%MatrixMarket matrix dense real general\n1 1\n1\n",
        1,
        &["unsupported format", "dense", "coordinate", "array"],
    );
}

#[test]
fn error_bad_size_line() {
    // Comments and blank lines before the size line count for the line number.
    expect_error(
        &format!("{GEN}% c\n\n3 3\n"),
        4,
        &["bad size line", "rows columns entries"],
    );
    expect_error(&format!("{GEN}3 x 4\n"), 2, &["bad size line"]);
    expect_error(&format!("{GEN}-3 3 1\n"), 2, &["bad size line"]);
    expect_error(&format!("{GEN}3 3 1 1\n"), 2, &["bad size line"]);
    expect_error(
        &format!("{GEN}99999999999999999999999 3 1\n"),
        2,
        &["bad size line"],
    );
    expect_error(
        "%%MatrixMarket matrix array real general\n3 3 9\n",
        2,
        &["bad size line", "rows columns"],
    );
}

#[test]
fn error_missing_size_line() {
    expect_error(
        &format!("{GEN}% only a comment\n"),
        2,
        &["missing size line"],
    );
    expect_error(GEN, 1, &["missing size line"]);
}

#[test]
fn error_non_square_symmetric() {
    expect_error(&format!("{SYM}3 4 1\n1 1 1\n"), 2, &["square", "3x4"]);
    expect_error(
        "%%MatrixMarket matrix array real symmetric\n2 3\n1\n",
        2,
        &["square"],
    );
}

#[test]
fn error_too_few_entries() {
    // Reported at the last line, with expected and found counts.
    expect_error(
        &format!("{GEN}3 3 4\n1 1 1\n2 2 2\n\n3 3 3\n"),
        6,
        &["too few", "4", "only 3"],
    );
    expect_error(
        &format!("{GEN}3 3 2\n1 1 1"),
        3,
        &["too few", "2", "only 1"],
    );
    expect_error(&format!("{GEN}3 3 2\n"), 2, &["too few", "only 0"]);
    expect_error(
        "%%MatrixMarket matrix array real general\n2 2\n1\n2\n3\n",
        5,
        &["too few", "4 values", "only 3"],
    );
    // A huge declared array size does not allocate: still a clean error.
    expect_error(
        "%%MatrixMarket matrix array real general\n100000000 100000000\n1\n",
        3,
        &["too few"],
    );
}

#[test]
fn error_too_many_entries() {
    expect_error(
        &format!("{GEN}3 3 2\n1 1 1\n2 2 2\n\n3 3 3\n"),
        6,
        &["too many", "2 entries"],
    );
    expect_error(
        "%%MatrixMarket matrix array real symmetric\n2 2\n1\n2\n3\n4\n",
        6,
        &["too many", "3 values"],
    );
}

#[test]
fn error_unparsable_number() {
    expect_error(
        &format!("{GEN}3 3 2\n1 1 1\n2 2 1.2.3\n"),
        4,
        &["unparsable value", "1.2.3"],
    );
    expect_error(
        &format!("{GEN}3 3 2\n1 1 1\n2 2 0x10\n"),
        4,
        &["unparsable value"],
    );
    expect_error(
        &format!("{GEN}3 3 1\nabc 1 1\n"),
        3,
        &["unparsable row index", "abc"],
    );
    expect_error(
        &format!("{GEN}3 3 1\n1 -2 1\n"),
        3,
        &["unparsable column index", "-2"],
    );
    expect_error(
        &format!("{GEN}3 3 1\n1 2.0 1\n"),
        3,
        &["unparsable column index"],
    );
    expect_error(
        "%%MatrixMarket matrix array real general\n1 2\n1\nfoo\n",
        4,
        &["unparsable value"],
    );
}

#[test]
fn error_index_out_of_range() {
    expect_error(
        &format!("{GEN}3 4 2\n1 1 1\n0 1 1\n"),
        4,
        &["row index 0", "out of range", "1..=3"],
    );
    expect_error(
        &format!("{GEN}3 4 1\n4 1 1\n"),
        3,
        &["row index 4", "out of range", "1..=3"],
    );
    expect_error(
        &format!("{GEN}3 4 1\n1 5 1\n"),
        3,
        &["column index 5", "out of range", "1..=4"],
    );
    expect_error(
        &format!("{GEN}3 4 1\n1 123456789012 1\n"),
        3,
        &["column index 123456789012", "out of range"],
    );
}

#[test]
fn error_non_finite_value() {
    for v in ["nan", "NaN", "inf", "-inf", "Infinity", "1e400", "-2e308"] {
        expect_error(
            &format!("{GEN}2 2 2\n1 1 1\n2 2 {v}\n"),
            4,
            &["not finite", v],
        );
    }
    expect_error(
        "%%MatrixMarket matrix array real general\n1 1\nnan\n",
        3,
        &["not finite"],
    );
}

#[test]
fn error_wrong_number_of_tokens() {
    expect_error(
        &format!("{GEN}3 3 2\n1 1 1\n2 2\n"),
        4,
        &["wrong number of tokens", "expected 3", "found 2"],
    );
    expect_error(
        &format!("{GEN}3 3 2\n1 1 1 7\n2 2 2\n"),
        3,
        &["wrong number of tokens", "found 4"],
    );
    expect_error(
        "%%MatrixMarket matrix array real general\n2 1\n1 2\n",
        3,
        &["wrong number of tokens", "1 value per line", "found 2"],
    );
}

#[test]
fn error_mixed_triangles() {
    expect_error(
        &format!("{SYM}3 3 4\n1 1 1\n2 1 2\n3 3 3\n1 3 4\n"),
        6,
        &["mixes triangles", "(1, 3)", "upper", "line 4"],
    );
    expect_error(
        &format!("{SYM}3 3 3\n1 2 1\n2 2 2\n3 1 4\n"),
        5,
        &["mixes triangles", "lower", "line 3"],
    );
}

#[test]
fn error_corrupt_gzip() {
    let mut gz = gzip(format!("{GEN}1 1 1\n1 1 1\n").as_bytes());
    // Truncated stream.
    let cut = gz.len() / 2;
    let (line, msg) = parse_error(&gz[..cut]);
    assert_eq!(line, 0);
    assert!(msg.contains("gzip"), "{msg}");
    // Damaged payload (CRC mismatch or invalid deflate data).
    let k = gz.len() - 12;
    gz[k] ^= 0xff;
    let (_, msg) = parse_error(&gz);
    assert!(msg.contains("gzip"), "{msg}");
    // Just the magic bytes.
    let (_, msg) = parse_error(&[0x1f, 0x8b]);
    assert!(msg.contains("gzip"), "{msg}");
}

#[test]
fn error_io_missing_file() {
    let dir = tmpdir();
    let p = dir.path().join("nope.mtx");
    match matrix_market::read(&p) {
        Err(Error::Io { path, .. }) => assert_eq!(path, p),
        other => panic!("expected an I/O error, got {other:?}"),
    }
}

#[test]
fn errors_in_large_files_have_exact_lines() {
    // Above the parallel threshold: the chunked parser must report the same first error and
    // line as a sequential one.
    let n = 80_000;
    let body: String = (1..=n)
        .map(|k| format!("{} {} {}.25\n", k % 500 + 1, k % 400 + 1, k))
        .collect();
    let good = format!("{GEN}% comment\n500 400 {n}\n{body}");
    assert!(good.len() > 1 << 20);
    let dir = tmpdir();
    let p = put(dir.path(), "good.mtx", good.as_bytes());
    // (k mod 500, k mod 400) repeats with period lcm(500, 400) = 2000; duplicates are summed.
    assert_eq!(matrix_market::read_sparse(&p).unwrap().compute_nnz(), 2000);

    // Entry k sits on line k + 3.
    let lines: Vec<&str> = good.lines().collect();
    let with = |k: usize, replacement: &str| {
        let mut l = lines.clone();
        l[k + 2] = replacement;
        l.join("\n") + "\n"
    };
    expect_error(
        &with(70_001, "1 401 1"),
        70_004,
        &["column index 401", "out of range"],
    );
    expect_error(&with(12_345, "1 1 oops"), 12_348, &["unparsable value"]);
    expect_error(&with(79_999, "1 1"), 80_002, &["wrong number of tokens"]);
    // Two problems: the first one is reported.
    let mut l = lines.clone();
    l[50_002] = "1 1 nan";
    l[60_002] = "0 1 1";
    expect_error(&(l.join("\n") + "\n"), 50_003, &["not finite"]);
    // Entry counts.
    expect_error(
        &good.replacen(&format!(" {n}\n"), &format!(" {}\n", n - 1), 1),
        n + 3,
        &["too many"],
    );
    expect_error(
        &good.replacen(&format!(" {n}\n"), &format!(" {}\n", n + 5), 1),
        n + 3,
        &["too few", "only 80000"],
    );

    // Symmetric: triangles mixed far apart, in different chunks.
    let sym_body: String = (1..=n)
        .map(|k| format!("{} {} 1\n", k % 300 + 301, k % 300 + 1))
        .collect();
    let sym = format!("{SYM}600 600 {n}\n{sym_body}");
    let p = put(dir.path(), "sym.mtx", sym.as_bytes());
    assert_eq!(matrix_market::read_sparse(&p).unwrap().compute_nnz(), 600);
    let mut l: Vec<&str> = sym.lines().collect();
    l[75_001] = "1 2 1";
    expect_error(
        &(l.join("\n") + "\n"),
        75_002,
        &["mixes triangles", "line 3"],
    );
}

// ---------------------------------------------------------------------------------------------
// Writers

#[test]
fn writer_refuses_non_finite_and_leaves_no_file() {
    let dir = tmpdir();
    let p = dir.path().join("x.mtx");
    let mut map = BTreeMap::new();
    map.insert((0, 0), 1.0);
    map.insert((1, 0), f64::NAN);
    let a = csc(2, 2, &map);
    assert!(matches!(
        matrix_market::write_coordinate(&p, a.as_ref(), false),
        Err(Error::InvalidModel(_))
    ));
    let d = dense_from(&[&[1.0, f64::INFINITY]]);
    assert!(matches!(
        matrix_market::write_array(&p, d.as_ref()),
        Err(Error::InvalidModel(_))
    ));
    assert!(!p.exists());
    assert!(!dir.path().join("x.mtx.tmp").exists());
}

#[test]
fn writer_symmetric_needs_square() {
    let dir = tmpdir();
    let a = csc(2, 3, &BTreeMap::new());
    let p = dir.path().join("ns.mtx");
    assert!(matrix_market::write_coordinate(&p, a.as_ref(), true).is_err());
    assert!(!p.exists());
}

#[test]
fn writer_io_error_leaves_nothing_and_keeps_old_file() {
    let dir = tmpdir();
    let a = csc(1, 1, &BTreeMap::from([((0, 0), 2.0)]));
    // Missing directory: an I/O error naming the temporary file.
    let p = dir.path().join("missing").join("a.mtx");
    assert!(matches!(
        matrix_market::write_coordinate(&p, a.as_ref(), false),
        Err(Error::Io { .. })
    ));
    // Rename onto a directory fails: the old directory stays, the temporary file is removed.
    let target = dir.path().join("isdir.mtx");
    std::fs::create_dir(&target).unwrap();
    std::fs::write(target.join("keep"), b"x").unwrap();
    assert!(matrix_market::write_coordinate(&target, a.as_ref(), false).is_err());
    assert!(target.join("keep").exists());
    assert!(!dir.path().join("isdir.mtx.tmp").exists());
    // Overwriting an existing file works.
    let p = dir.path().join("over.mtx");
    std::fs::write(&p, b"old").unwrap();
    matrix_market::write_coordinate(&p, a.as_ref(), false).unwrap();
    assert_eq!(dense(&matrix_market::read_sparse(&p).unwrap())[(0, 0)], 2.0);
}

// ---------------------------------------------------------------------------------------------
// The real ANSYS example

#[test]
fn reads_real_ansys_stiffness() {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/ansys_example_full/K.mtx");
    if !p.exists() {
        println!("skipped: {} is absent", p.display());
        return;
    }
    let m = matrix_market::read(&p).unwrap();
    assert_eq!(m.symmetry, Symmetry::Symmetric);
    let MtxData::Sparse(k) = m.data else {
        panic!("K.mtx is a coordinate file")
    };
    assert_eq!((k.nrows(), k.ncols()), (900, 900));
    assert_eq!(k.compute_nnz(), 77_020);
    let stored_lower = (0..900)
        .map(|j| k.row_idx_of_col_raw(j).iter().filter(|&&i| i >= j).count())
        .sum::<usize>();
    assert_eq!(stored_lower, 38_960);
    // Exactly symmetric after expansion.
    let d = dense(&k);
    for j in 0..900 {
        for i in 0..j {
            assert_eq!(d[(i, j)].to_bits(), d[(j, i)].to_bits(), "({i}, {j})");
        }
        assert!(d[(j, j)] > 0.0, "positive diagonal at {j}");
    }
    // Re-written symmetric, it reads back identically.
    let dir = tmpdir();
    let q = dir.path().join("K.mtx");
    matrix_market::write_coordinate(&q, k.as_ref(), true).unwrap();
    assert_same(&k, &matrix_market::read_sparse(&q).unwrap());
}

// ---------------------------------------------------------------------------------------------
// Property

fn finite_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        any::<f64>().prop_filter("finite", |v| v.is_finite()),
        -1e6..1e6f64,
        Just(-0.0),
        Just(5e-324),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn prop_write_read_sparse_round_trip(
        nrows in 1usize..40,
        ncols in 1usize..40,
        entries in proptest::collection::vec((0usize..40, 0usize..40, finite_f64()), 0..200),
        symmetric in any::<bool>(),
    ) {
        let dir = tmpdir();
        let p = dir.path().join("p.mtx");
        let mut map = BTreeMap::new();
        let n = nrows.min(ncols);
        for (i, j, v) in entries {
            if symmetric {
                let (i, j) = (i % n, j % n);
                map.insert((i, j), v);
                map.insert((j, i), v);
            } else {
                map.insert((i % nrows, j % ncols), v);
            }
        }
        let (m, c) = if symmetric { (n, n) } else { (nrows, ncols) };
        let a = csc(m, c, &map);
        matrix_market::write_coordinate(&p, a.as_ref(), symmetric).unwrap();
        let b = matrix_market::read_sparse(&p).unwrap();
        assert_same(&a, &b);
    }

    #[test]
    fn prop_arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..300)) {
        let mut data = GEN.as_bytes().to_vec();
        data.extend_from_slice(&bytes);
        let _ = matrix_market::parse_bytes(&data, Path::new("fuzz.mtx"));
        let _ = matrix_market::parse_bytes(&bytes, Path::new("fuzz.mtx"));
    }

    #[test]
    fn prop_mutated_valid_file_never_panics(
        pos in 0usize..200,
        byte in prop_oneof![Just(b' '), Just(b'\n'), Just(b'0'), Just(b'-'), Just(b'9'), Just(b'e'), any::<u8>()],
        sym in any::<bool>(),
    ) {
        let header = if sym { SYM } else { GEN };
        let mut data = format!("{header}4 4 5\n1 1 1.5\n2 1 -2e3\n3 3 4\n4 2 0.25\n4 4 1e-5\n").into_bytes();
        let k = pos % data.len();
        data[k] = byte;
        let _ = matrix_market::parse_bytes(&data, Path::new("mut.mtx"));
        let mut arr = b"%%MatrixMarket matrix array real symmetric\n3 3\n1\n2\n3\n4\n5\n6\n".to_vec();
        let k = pos % arr.len();
        arr[k] = byte;
        let _ = matrix_market::parse_bytes(&arr, Path::new("mut.mtx"));
    }
}
