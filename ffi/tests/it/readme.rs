//! The README's snippets work: the C program compiles (warnings as errors) against the
//! static library and runs; the Python snippets run when numpy/scipy (and pyMOR) are there.

use crate::common::*;
use std::path::Path;
use std::process::Command;

/// The bodies of the README's fenced blocks of language `lang`, in order.
fn blocks(lang: &str) -> Vec<String> {
    let readme =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("README.md")).unwrap();
    let mut out = Vec::new();
    let mut cur: Option<String> = None;
    for line in readme.lines() {
        match &mut cur {
            None if line.trim() == format!("```{lang}") => cur = Some(String::new()),
            Some(b) if line.trim() == "```" => {
                out.push(std::mem::take(b));
                cur = None;
            }
            Some(b) => {
                b.push_str(line);
                b.push('\n');
            }
            None => {}
        }
    }
    out
}

#[test]
fn readme_c_snippet_compiles_and_runs() {
    let c = blocks("c");
    assert_eq!(c.len(), 1, "one C program in the README");
    let dir = scratch("readme_c");
    let src = dir.join("app.c");
    std::fs::write(&src, &c[0]).unwrap();
    let exe = dir.join("app");
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = Command::new("cc")
        .args(["-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-I"])
        .arg(manifest.join("include"))
        .arg(&src)
        .arg(static_lib())
        .args([
            "-lgcc_s",
            "-lutil",
            "-lrt",
            "-lpthread",
            "-lm",
            "-ldl",
            "-lc",
            "-o",
        ])
        .arg(&exe)
        .output()
        .expect("run cc");
    assert!(
        out.status.success(),
        "cc: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = Command::new(&exe).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    println!("{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success());
    assert!(stdout.contains("ROM order 4"), "{stdout}");
    assert_eq!(stdout.matches("eps(").count(), 3);
}

fn python_has(modules: &str) -> bool {
    Command::new("python3")
        .args(["-c", &format!("import {modules}")])
        .output()
        .is_ok_and(|o| o.status.success())
}

fn run_python(code: &str) -> String {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = Command::new("python3")
        .args(["-c", code])
        .env("PYTHONPATH", manifest.join("python"))
        .env("SPARSEMOR_LIB", shared_lib())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    println!("{stdout}{}", String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "python snippet failed");
    stdout
}

#[test]
fn readme_python_snippets_run() {
    let py = blocks("python");
    assert_eq!(py.len(), 2, "the Python and the pyMOR snippet");
    if !python_has("numpy, scipy") {
        println!(
            "NOTE: python3 with numpy and scipy not found; skipping (pip install numpy scipy)"
        );
        return;
    }
    let out = run_python(&py[0]);
    assert!(out.contains("order 4"), "{out}");
    if !python_has("pymor") {
        println!("NOTE: pyMOR not installed; skipping the pyMOR snippet (pip install pymor)");
        return;
    }
    let out = run_python(&format!("{}\n{}", py[0], py[1]));
    assert!(out.contains("pyMOR: |H - Hr| / |H| ="), "{out}");
}
