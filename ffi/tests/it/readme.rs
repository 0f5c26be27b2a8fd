//! The README's C snippet works: the program compiles (warnings as errors) against the
//! static library and runs. (The Python package's tests run the main README's Python
//! snippets: python/tests/test_readme.py.)

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
