//! Structure-aware Matrix Market input: a valid banner and size line always, then hostile
//! entries (indices 0, past the end, negative, huge; values NaN, Inf, 1e400, subnormal, hex,
//! signs; wrong token counts, comment and blank lines, CRLF, both triangles of a symmetric
//! file, too many or too few entries), so mutation works past the header. Plain or gzip.
#![no_main]

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use sparsemor::io::matrix_market::parse_bytes;
use sparsemor_fuzz::{check_bound, gzip, measured, revalidate};
use std::fmt::Write;
use std::path::Path;

#[derive(Arbitrary, Debug)]
struct Input {
    array: bool,
    symmetric: bool,
    field: u8,
    gzip: bool,
    crlf: bool,
    nrows: u8,
    ncols: u8,
    /// Added to the true entry count on the size line (too many / too few).
    count_skew: i8,
    lines: Vec<Line>,
}

#[derive(Arbitrary, Debug)]
enum Line {
    Entry(Index, Index, Value),
    Value(Value),
    Comment,
    Blank,
    Tokens(u8),
    Raw(String),
}

#[derive(Arbitrary, Debug)]
enum Index {
    In(u8),
    Zero,
    Past(u8),
    Negative,
    Huge,
    Text(String),
}

#[derive(Arbitrary, Debug)]
enum Value {
    Finite(f64),
    Int(i64),
    Special(u8),
}

fn index(i: &Index, dim: usize, out: &mut String) {
    let _ = match i {
        Index::In(k) => write!(out, "{}", 1 + *k as usize % dim.max(1)),
        Index::Zero => write!(out, "0"),
        Index::Past(k) => write!(out, "{}", dim + 1 + *k as usize),
        Index::Negative => write!(out, "-1"),
        Index::Huge => write!(out, "18446744073709551617"),
        Index::Text(s) => write!(out, "{s}"),
    };
}

fn value(v: &Value, out: &mut String) {
    const SPECIAL: [&str; 12] = [
        "nan",
        "inf",
        "-inf",
        "1e400",
        "-1e400",
        "4.9e-324",
        "1e-400",
        "0x1p3",
        "+.5",
        "-0",
        "1.7976931348623157e308",
        "1,5",
    ];
    let _ = match v {
        Value::Finite(x) => write!(out, "{x:e}"),
        Value::Int(k) => write!(out, "{k}"),
        Value::Special(k) => write!(out, "{}", SPECIAL[*k as usize % SPECIAL.len()]),
    };
}

fuzz_target!(|inp: Input| {
    let (nrows, ncols) = (inp.nrows as usize, inp.ncols as usize);
    let ncols = if inp.symmetric { nrows } else { ncols };
    let field = ["real", "double", "integer", "complex", "pattern"][inp.field as usize % 5];
    let nl = if inp.crlf { "\r\n" } else { "\n" };
    let entries = inp
        .lines
        .iter()
        .filter(|l| matches!(l, Line::Entry(..) | Line::Value(_)))
        .count();
    let declared = (entries as i64 + inp.count_skew as i64).max(0);
    let mut t = String::new();
    let _ = write!(
        t,
        "%%MatrixMarket matrix {} {field} {}{nl}% fuzz{nl}",
        if inp.array { "array" } else { "coordinate" },
        if inp.symmetric {
            "symmetric"
        } else {
            "general"
        }
    );
    if inp.array {
        let _ = write!(t, "{nrows} {ncols}{nl}");
    } else {
        let _ = write!(t, "{nrows} {ncols} {declared}{nl}");
    }
    for line in &inp.lines {
        match line {
            Line::Entry(i, j, v) => {
                index(i, nrows, &mut t);
                t.push(' ');
                index(j, ncols, &mut t);
                t.push(' ');
                value(v, &mut t);
            }
            Line::Value(v) => value(v, &mut t),
            Line::Comment => t.push_str("% comment"),
            Line::Blank => {}
            Line::Tokens(k) => {
                for _ in 0..*k % 7 {
                    t.push_str("1 ");
                }
            }
            Line::Raw(s) => t.push_str(s),
        }
        t.push_str(nl);
    }
    let text_len = t.len();
    let bytes = if inp.gzip {
        gzip(t.as_bytes())
    } else {
        t.into_bytes()
    };
    let (result, peak) = measured(|| parse_bytes(&bytes, Path::new("fuzz.mtx")));
    check_bound("parse_bytes", peak, text_len, 8 * (ncols + 1));
    if let Ok(m) = result {
        revalidate(&m);
    }
});
