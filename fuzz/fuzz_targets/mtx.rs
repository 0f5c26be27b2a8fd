//! Matrix Market reader on raw bytes, plain and gzip: the first byte chooses whether the rest
//! is parsed as it is (which also feeds corrupt gzip when it starts with 1f 8b) or gzip-
//! compressed first (so mutations of the text reach the parser through the gzip path).
//! On success the matrix re-validates (module `check` of the shared code) and round-trips.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sparsemor::io::matrix_market::parse_bytes;
use sparsemor_fuzz::{
    check_bound, declared_bytes, gzip, measured, plain, revalidate, DECLARED_MAX,
};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let bytes = if mode & 1 == 1 {
        gzip(rest)
    } else {
        rest.to_vec()
    };
    let declared = declared_bytes(&bytes, false);
    if declared > DECLARED_MAX {
        return;
    }
    let text_len = plain(&bytes).len();
    let (result, peak) = measured(|| parse_bytes(&bytes, Path::new("fuzz.mtx")));
    check_bound("parse_bytes", peak, text_len.max(bytes.len()), declared);
    if let Ok(m) = result {
        revalidate(&m);
    }
});
