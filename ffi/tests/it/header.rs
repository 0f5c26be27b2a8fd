//! The checked-in C header `include/sparsemor.h` must equal what cbindgen generates from the
//! current sources (docs/design.md §6). Regenerate with
//! `SPARSEMOR_FFI_REGENERATE=1 cargo test -p sparsemor-ffi --test it header`.

use std::path::PathBuf;

fn generate() -> String {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let config = cbindgen::Config::from_file(dir.join("cbindgen.toml")).expect("cbindgen.toml");
    let bindings = cbindgen::Builder::new()
        .with_crate(&dir)
        .with_config(config)
        .generate()
        .expect("cbindgen could not generate the header");
    let mut out = Vec::new();
    bindings.write(&mut out);
    String::from_utf8(out).expect("header is UTF-8")
}

#[test]
fn header_is_up_to_date() {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("include/sparsemor.h");
    let fresh = generate();
    if std::env::var_os("SPARSEMOR_FFI_REGENERATE").is_some_and(|v| v == "1") {
        std::fs::write(&path, &fresh).expect("write include/sparsemor.h");
        eprintln!("regenerated {}", path.display());
        return;
    }
    let checked_in = std::fs::read_to_string(&path).unwrap_or_default();
    if checked_in != fresh {
        let line = checked_in
            .lines()
            .zip(fresh.lines())
            .position(|(a, b)| a != b)
            .map_or_else(
                || checked_in.lines().count().min(fresh.lines().count()) + 1,
                |i| i + 1,
            );
        panic!(
            "{} is stale (first difference at line {line}); regenerate it with\n  \
             SPARSEMOR_FFI_REGENERATE=1 cargo test -p sparsemor-ffi --test it header\nand commit the result",
            path.display()
        );
    }
}

#[test]
fn header_has_the_versioned_abi_constant() {
    let h = generate();
    let want = format!(
        "#define SPARSEMOR_ABI_VERSION {}",
        sparsemor_ffi::SPARSEMOR_ABI_VERSION
    );
    assert!(h.contains(&want), "header lacks `{want}`");
}
