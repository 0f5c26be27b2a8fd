//! Build script: links the system ARPACK when the `arpack` feature is on (this script
//! handles only ARPACK).

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    if std::env::var_os("CARGO_FEATURE_ARPACK").is_some() {
        println!("cargo:rustc-link-lib=arpack");
    }
}
