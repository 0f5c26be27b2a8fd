//! Runs the Python binding's tests (`python/test_sparsemor.py`: scipy.sparse models reduced
//! through the C ABI, ROM transfer functions checked against dense solves) against this
//! build's shared library, and the pyMOR example when pyMOR is installed. Skipped with a note
//! when python3 with numpy and scipy is missing (CI installs them: `pip install numpy scipy`).

use crate::common::*;
use std::path::Path;
use std::process::Command;

fn python_has(modules: &str) -> bool {
    Command::new("python3")
        .args(["-c", &format!("import {modules}")])
        .output()
        .is_ok_and(|o| o.status.success())
}

fn run_python(script: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("python")
        .join(script);
    let out = Command::new("python3")
        .arg(&path)
        .env("SPARSEMOR_LIB", shared_lib())
        .output()
        .expect("run python3");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    println!(
        "--- {script}\n{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "{script} failed: {}", out.status);
    stdout
}

#[test]
fn python_binding_tests() {
    if !python_has("numpy, scipy") {
        println!("NOTE: python3 with numpy and scipy not found; skipping the Python binding tests (pip install numpy scipy)");
        return;
    }
    let out = run_python("test_sparsemor.py");
    assert!(out.contains(" passed, 0 failed"), "{out}");
}

#[test]
fn pymor_example() {
    if !python_has("numpy, scipy, pymor") {
        println!("NOTE: pyMOR not installed; skipping example_pymor.py (pip install pymor)");
        return;
    }
    let out = run_python("example_pymor.py");
    assert!(out.contains("example_pymor: OK"), "{out}");
}
