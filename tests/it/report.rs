//! `sparsemor report` end to end (issue 9 item 4): the bar, a line-fitting ROM (--tol 1e-2)
//! and a SEREP ROM (9 modes), a tradeoff CSV; the page is checked as text and then opened in
//! headless Chromium (Debian `chromium`, installed by `.ci/run`; the browser part is skipped
//! with a note when it is missing): every figure rendered as a non-empty SVG with axis labels
//! and data, no console message, and a screenshot that is not blank. With
//! `SPARSEMOR_UPDATE_SCREENSHOT=1` the screenshot is copied to `docs/report.png`.

use crate::cli::{ok as succeeds, run as sparsemor};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Runs a report that must fail before writing: stderr names `needle`, `out` not created.
fn refused(cwd: &Path, args: &[&str], out: &str, needle: &str) {
    let o = sparsemor(cwd, &[args, &["--out", out]].concat());
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{args:?} should fail: {err}");
    assert!(err.contains(needle), "{args:?}: '{needle}' not in: {err}");
    assert!(!cwd.join(out).exists(), "{args:?} wrote {out}");
    let leftovers: Vec<_> = std::fs::read_dir(cwd)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains(".tmp-"))
        .collect();
    assert!(
        leftovers.is_empty(),
        "temporary directories left: {leftovers:?}"
    );
}

/// What each figure must show: a text only it has (an axis description or title) and the
/// least number of data elements of one kind.
struct Expect {
    label: &'static str,
    element: &'static str,
    at_least: usize,
}

const FIGURES: [Expect; 7] = [
    Expect {
        label: "|H| output DoF 0 / input DoF 0",
        element: "<polyline",
        at_least: 3,
    },
    Expect {
        label: "|H| output DoF 1622 / input DoF 0",
        element: "<polyline",
        at_least: 3,
    },
    Expect {
        label: "relative transfer-function error",
        element: "<polyline",
        at_least: 5,
    },
    Expect {
        label: "full-model eigenfrequency (Hz)",
        element: "<circle",
        at_least: 12,
    },
    Expect {
        label: "MAC, a",
        element: "<rect",
        at_least: 6 * 8,
    },
    Expect {
        label: "MAC, b",
        element: "<rect",
        at_least: 6 * 9,
    },
    Expect {
        label: "wall time of the reduction (s)",
        element: "<circle",
        at_least: 4,
    },
];

/// Points of the longest `points="…"` list in `svg` (the densest curve).
fn longest_curve(svg: &str) -> usize {
    svg.split("points=\"")
        .skip(1)
        .map(|s| s[..s.find('"').unwrap_or(0)].split_whitespace().count())
        .max()
        .unwrap_or(0)
}

/// Checks every figure of a page (the written file or the browser's DOM).
fn check_figures(html: &str, grid: usize) {
    let figures: Vec<&str> = html.split("<figure>").skip(1).collect();
    assert_eq!(figures.len(), FIGURES.len(), "figures on the page");
    for (fig, want) in figures.iter().zip(&FIGURES) {
        let svg = &fig[fig.find("<svg").expect("an <svg> per figure")..fig.find("</svg>").unwrap()];
        let count = |needle: &str| svg.matches(needle).count();
        assert!(svg.contains(want.label), "figure without '{}'", want.label);
        assert!(count("<text") >= 8, "'{}': axis labels missing", want.label);
        assert!(
            count(want.element) >= want.at_least,
            "'{}': {} {} elements, expected >= {}",
            want.label,
            count(want.element),
            want.element,
            want.at_least
        );
    }
    // the |H| curves and ε(f) are drawn over the whole grid
    for fig in &figures[..3] {
        assert!(
            longest_curve(fig) >= grid,
            "a curve over the {grid}-point grid"
        );
    }
}

/// Runs Chromium headless on `url` with `extra` flags (fresh profile, 120 s limit);
/// returns (stdout, stderr), or `None` when `chromium` is not installed.
fn chromium(url: &str, extra: &[&str], scratch: &Path) -> Option<(String, String)> {
    let profile = tempfile::tempdir_in(scratch).unwrap();
    let (out, err) = (scratch.join("chromium.out"), scratch.join("chromium.err"));
    let child = Command::new("chromium")
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--enable-logging=stderr",
            "--v=0",
        ])
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .args(extra)
        .arg(url)
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&out).unwrap())
        .stderr(std::fs::File::create(&err).unwrap())
        .spawn();
    let mut child = match child {
        Ok(c) => c,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return None,
        Err(e) => panic!("chromium: {e}"),
    };
    let t = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if t.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("chromium did not finish within 120 s");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    let read = |p: &PathBuf| std::fs::read_to_string(p).unwrap_or_default();
    Some((read(&out), read(&err)))
}

/// Fraction of non-white pixels and of coloured (not grey) pixels of an RGB(A) PNG.
fn ink(png_path: &Path) -> (u32, u32, f64, f64) {
    let file = std::io::BufReader::new(std::fs::File::open(png_path).unwrap());
    let mut reader = png::Decoder::new(file).read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    let channels = info.color_type.samples();
    assert!(channels >= 3, "an RGB screenshot");
    let (mut dark, mut colour, mut n) = (0usize, 0usize, 0usize);
    for p in buf[..info.buffer_size()].chunks(channels) {
        let (r, g, b) = (p[0] as i32, p[1] as i32, p[2] as i32);
        n += 1;
        dark += usize::from(r.min(g).min(b) < 200);
        colour += usize::from((r - g).abs().max((g - b).abs()).max((r - b).abs()) > 60);
    }
    (
        info.width,
        info.height,
        dark as f64 / n as f64,
        colour as f64 / n as f64,
    )
}

#[test]
fn report_of_two_roms_renders_in_chromium() {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("report");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    succeeds(&dir, &["generate", "bar", "--out", "bar"]);
    for args in [
        ["--method", "linefit", "--tol", "1e-2", "--out", "a"],
        ["--method", "serep", "--modes", "9", "--out", "b"],
    ] {
        succeeds(&dir, &[&["reduce", "bar"], &args[..]].concat());
    }
    succeeds(
        &dir,
        &[
            "tradeoff",
            "bar",
            "--tols",
            "1e-1,1e-2",
            "--serep-modes",
            "6,9",
            "--points",
            "100",
            "--csv",
            "t.csv",
            "--svg",
            "t.svg",
        ],
    );
    let grid = 400;
    let points = grid.to_string();
    let report = [
        "report",
        "bar",
        "a",
        "b",
        "--tradeoff",
        "t.csv",
        "--tol",
        "1e-2",
        "--points",
        &points,
    ];
    // bad input: a clear error, nothing written
    refused(&dir, &["report", "bar", "a", "missing"], "bad", "missing");
    refused(
        &dir,
        &[&report[..], &["--pairs", "5:0"]].concat(),
        "bad",
        "--pairs '5:0'",
    );
    std::fs::write(dir.join("x.csv"), "f,eps\n1,2\n").unwrap();
    refused(
        &dir,
        &["report", "bar", "a", "--tradeoff", "x.csv"],
        "bad",
        "header",
    );
    succeeds(&dir, &[&report[..], &["--out", "rep"]].concat());

    let page = dir.join("rep").join("index.html");
    let html = std::fs::read_to_string(&page).unwrap();
    for forbidden in ["<script", " src=", " href=", "<link"] {
        assert!(!html.contains(forbidden), "not self-contained: {forbidden}");
    }
    check_figures(&html, grid);
    let table = &html[html.find("<table>").expect("the ROM table")..];
    assert_eq!(table.matches("<tr>").count(), 3, "header + one row per ROM");
    for cell in [
        "linefit",
        "serep",
        "cond(T_o)",
        "cond(U_cr)",
        "SPD",
        "1.0e-2 reached",
    ] {
        assert!(table.contains(cell), "table without '{cell}'");
    }

    let url = format!("file://{}", page.display());
    let Some((dom, log)) = chromium(&url, &["--dump-dom"], &dir) else {
        eprintln!("SKIPPED the browser check: `chromium` is not installed (apt-get install chromium; .ci/run does)");
        return;
    };
    check_figures(&dom, grid);
    for bad in ["Uncaught", "ERROR:CONSOLE", "CONSOLE("] {
        assert!(!log.contains(bad), "console message '{bad}' in:\n{log}");
    }
    let shot = dir.join("report.png");
    chromium(
        &url,
        &[
            &format!("--screenshot={}", shot.display()),
            "--window-size=1200,3800",
            "--hide-scrollbars",
        ],
        &dir,
    );
    let (w, h, dark, colour) = ink(&shot);
    assert_eq!((w, h), (1200, 3800));
    assert!(dark > 0.02, "screenshot nearly blank: {dark:.4} dark");
    assert!(colour > 0.005, "no coloured curves or cells: {colour:.4}");
    if std::env::var_os("SPARSEMOR_UPDATE_SCREENSHOT").is_some() {
        let docs = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/report.png");
        std::fs::copy(&shot, &docs).unwrap();
        eprintln!("wrote {}", docs.display());
    }
}
