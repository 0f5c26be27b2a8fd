//! Build script: links ARPACK only with the `arpack` feature, UMFPACK (SuiteSparse) only
//! with the `umfpack` feature and MUMPS only with the `mumps` feature.
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
    #[cfg(feature = "mumps")]
    mumps();
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

/// With the `mumps` feature: links the MPI-parallel MUMPS of Debian's `libmumps-dev`
/// (`zmumps`, `dmumps` and their common and PORD libraries; MPI itself comes with the `mpi`
/// feature's rsmpi; `MUMPS_LIB_DIR` adds a search path) and generates the declarations of
/// `zmumps_c`, `dmumps_c` and their structures from the installed headers with bindgen (the
/// structures change between MUMPS versions, so they are read, not written by hand).
/// `MUMPS_INCLUDE_DIR` names the directory of `zmumps_c.h`, else /usr/include.
#[cfg(feature = "mumps")]
fn mumps() {
    for var in ["MUMPS_LIB_DIR", "MUMPS_INCLUDE_DIR"] {
        println!("cargo:rerun-if-env-changed={var}");
    }
    if let Some(dir) = std::env::var_os("MUMPS_LIB_DIR") {
        println!(
            "cargo:rustc-link-search=native={}",
            PathBuf::from(dir).display()
        );
    }
    for lib in ["zmumps", "dmumps", "mumps_common", "pord"] {
        println!("cargo:rustc-link-lib={lib}");
    }
    let include =
        std::env::var_os("MUMPS_INCLUDE_DIR").map_or("/usr/include".into(), PathBuf::from);
    let header = "#include <zmumps_c.h>\n#include <dmumps_c.h>\n";
    let bindings = bindgen::Builder::default()
        .header_contents("sparsemor_mumps.h", header)
        .clang_arg(format!("-I{}", include.display()))
        .allowlist_function("[zd]mumps_c")
        .allowlist_type("[ZD]MUMPS_STRUC_C")
        .derive_default(false)
        .layout_tests(true)
        .generate()
        .unwrap_or_else(|e| {
            panic!(
                "feature mumps: could not read zmumps_c.h/dmumps_c.h in {} ({e}); \
                 install libmumps-dev or set MUMPS_INCLUDE_DIR",
                include.display()
            )
        });
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    bindings
        .write_to_file(out.join("mumps_bindings.rs"))
        .expect("OUT_DIR is writable");
}
