//! Source checks of the ABI discipline (docs/design.md §6) that the compiler cannot do:
//! every exported function runs its body under the panic guard, and caller memory is never
//! taken over with `Vec::from_raw_parts`.

use std::path::Path;

fn sources() -> Vec<(String, String)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut v: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "rs"))
        .map(|p| {
            (
                p.display().to_string(),
                std::fs::read_to_string(&p).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

#[test]
fn every_export_runs_under_the_panic_guard() {
    let mut exports = Vec::new();
    for (path, text) in sources() {
        let parts: Vec<&str> = text.split("extern \"C\" fn ").collect();
        for part in &parts[1..] {
            let name = part.split('(').next().unwrap();
            // the body: from the first `{` after the signature to the next export
            let body = &part[part.find(") -> ").unwrap_or(0)..];
            let body = &body[body.find('{').expect("fn body")..];
            let first = body.lines().nth(1).unwrap_or("").trim();
            assert!(
                first.starts_with("ffi_body!(") || first.starts_with("error::ffi_body!(")
                    || first.starts_with("catch_unwind(") || first.starts_with("let r = catch_unwind("),
                "{path}: `{name}` does not start its body with ffi_body! / catch_unwind (first line: {first:?})"
            );
            exports.push(name.to_string());
        }
    }
    // every function of the header is one of them
    let header =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("include/sparsemor.h"))
            .unwrap();
    let mut declared: Vec<String> = header
        .split("sparsemor_")
        .skip(1)
        .filter_map(|t| {
            let name: String = t
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
                .collect();
            t[name.len()..]
                .starts_with('(')
                .then(|| format!("sparsemor_{name}"))
        })
        .collect();
    declared.sort();
    declared.dedup();
    exports.sort();
    assert_eq!(declared, exports, "header functions vs guarded exports");
    println!("{} exported functions, each guarded", exports.len());
}

#[test]
fn caller_memory_is_never_taken_over() {
    for (path, text) in sources() {
        let code = text.lines().filter(|l| !l.trim_start().starts_with("//"));
        for line in code {
            assert!(
                !line.contains("Vec::from_raw_parts"),
                "{path} uses Vec::from_raw_parts: {line}"
            );
        }
    }
}
