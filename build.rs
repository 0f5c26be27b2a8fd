//! Build script: links ARPACK only with the `arpack` feature and UMFPACK (SuiteSparse) only
//! with the `umfpack` feature.
//!
//! Without the features nothing is linked, so a default build needs no system library.
//!
//! With the feature:
//! * `cargo:rustc-link-lib=umfpack` (the system library; on Debian 12 from `libsuitesparse-dev`);
//! * `UMFPACK_LIB_DIR`, if set, is added as a native search path;
//! * the UMFPACK header (`UMFPACK_INCLUDE_DIR`, else the usual system locations) is read for
//!   `UMFPACK_MAIN_VERSION`. UMFPACK 6 (SuiteSparse 7) changed the C return type of the
//!   `umfpack_?l_*` functions from `SuiteSparse_long` to `int` and the `sys` argument of
//!   `solve` to `int`; for version >= 6 the cfg `umfpack_v6` is set so the hand-written
//!   `extern "C"` block in `src/factor/umfpack/sys.rs` matches the installed ABI. If no header is
//!   found, the 5.x prototypes (the ones checked against UMFPACK 5.7.9) are assumed.

use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rustc-check-cfg=cfg(umfpack_v6)");
    if std::env::var_os("CARGO_FEATURE_ARPACK").is_some() {
        println!("cargo:rustc-link-lib=arpack");
    }
    if std::env::var_os("CARGO_FEATURE_UMFPACK").is_none() {
        return;
    }
    println!("cargo:rerun-if-env-changed=UMFPACK_LIB_DIR");
    println!("cargo:rerun-if-env-changed=UMFPACK_INCLUDE_DIR");
    if let Some(dir) = std::env::var_os("UMFPACK_LIB_DIR") {
        println!(
            "cargo:rustc-link-search=native={}",
            PathBuf::from(dir).display()
        );
    }
    println!("cargo:rustc-link-lib=umfpack");

    let mut dirs: Vec<PathBuf> = Vec::new();
    if let Some(dir) = std::env::var_os("UMFPACK_INCLUDE_DIR") {
        dirs.push(dir.into());
    }
    for d in [
        "/usr/include/suitesparse",
        "/usr/include",
        "/usr/local/include/suitesparse",
        "/usr/local/include",
    ] {
        dirs.push(d.into());
    }
    for dir in dirs {
        let header = dir.join("umfpack.h");
        let Ok(text) = std::fs::read_to_string(&header) else {
            continue;
        };
        println!("cargo:rerun-if-changed={}", header.display());
        let major = text.lines().find_map(|l| {
            let mut it = l.split_whitespace();
            (it.next() == Some("#define") && it.next() == Some("UMFPACK_MAIN_VERSION"))
                .then(|| it.next().and_then(|v| v.parse::<u32>().ok()))
                .flatten()
        });
        match major {
            Some(v) if v >= 6 => println!("cargo:rustc-cfg=umfpack_v6"),
            Some(_) => {}
            None => println!(
                "cargo:warning=could not read UMFPACK_MAIN_VERSION from {}; assuming UMFPACK 5.x",
                header.display()
            ),
        }
        return;
    }
    println!(
        "cargo:warning=umfpack.h not found (set UMFPACK_INCLUDE_DIR); assuming the UMFPACK 5.x ABI"
    );
}
