//! The `sparsemor` binary end to end: generate, info, sweep, reduce, evaluate, modes — the
//! outputs they write and the errors they give for bad settings (exit code, stderr, nothing
//! left behind).

use sparsemor::frf::{transfer_function, Part};
use sparsemor::io::model_dir;
use sparsemor::sweep::{no_progress, SweepOptions};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

/// The paper bar's I/O DoFs (inputs = outputs): nodes 0, 264, 540.
const PAPER_IO: [usize; 9] = [0, 1, 2, 792, 793, 794, 1620, 1621, 1622];

/// A fresh, empty directory `<CARGO_TARGET_TMPDIR>/cli/<name>`.
fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("cli")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("create scratch dir");
    dir
}

pub(crate) fn run(cwd: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_sparsemor"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("run sparsemor")
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

/// Runs a command that must succeed; returns stdout.
pub(crate) fn ok(cwd: &Path, args: &[&str]) -> String {
    let out = run(cwd, args);
    assert!(
        out.status.success(),
        "sparsemor {args:?} failed ({}):\nstdout:\n{}\nstderr:\n{}",
        out.status,
        text(&out.stdout),
        text(&out.stderr)
    );
    text(&out.stdout)
}

/// Runs a command that must fail cleanly; asserts stderr names every needle and returns it.
fn fails(cwd: &Path, args: &[&str], needles: &[&str]) -> String {
    let out = run(cwd, args);
    let err = text(&out.stderr);
    assert!(
        !out.status.success(),
        "sparsemor {args:?} succeeded but should have failed; stderr:\n{err}"
    );
    assert!(
        out.status.code().is_some(),
        "sparsemor {args:?} was killed by a signal: {}",
        out.status
    );
    assert!(
        !err.contains("panicked"),
        "sparsemor {args:?} panicked:\n{err}"
    );
    for n in needles {
        assert!(
            err.contains(n),
            "sparsemor {args:?}: {n:?} not in stderr:\n{err}"
        );
    }
    err
}

fn entries(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .expect("list dir")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// The paper bar written once by `sparsemor generate bar` (shared, read-only afterwards).
fn bar() -> &'static Path {
    static BAR: OnceLock<PathBuf> = OnceLock::new();
    BAR.get_or_init(|| {
        let parent = scratch("shared");
        let out = run(&parent, &["generate", "bar", "--out", "bar"]);
        let err = text(&out.stderr);
        assert!(out.status.success(), "generate bar failed:\n{err}");
        assert!(err.contains("N = 1656"), "generate: {err}");
        let dir = parent.join("bar");
        for f in ["model.toml", "M.mtx", "K.mtx", "nodes.csv"] {
            assert!(dir.join(f).is_file(), "generate did not write {f}");
        }
        dir
    })
}

fn bar_str() -> &'static str {
    bar().to_str().expect("utf-8 path")
}

/// CSV rows (header excluded) split at commas, after checking the header.
fn csv(path: &Path, header: &str) -> Vec<Vec<String>> {
    let s = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = s.lines();
    assert_eq!(lines.next(), Some(header), "{}: header", path.display());
    lines
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

fn num(s: &str) -> f64 {
    s.parse()
        .unwrap_or_else(|_| panic!("'{s}' is not a number"))
}

// ---------------------------------------------------------------------------------------------
// generate, info, sweep

#[test]
fn generate_info_sweep_matches_the_library_bit_exactly() {
    let info = ok(bar(), &["info", bar_str()]);
    let field = |name: &str| {
        info.lines()
            .find(|l| l.starts_with(name))
            .unwrap_or_else(|| panic!("no `{name}` line in info:\n{info}"))
            .trim_start_matches(name)
            .trim()
            .to_string()
    };
    assert_eq!(field("N "), "1656", "info:\n{info}");
    assert!(field("rigid modes").starts_with("6:"), "info:\n{info}");
    // info says what the sweep will do: the damped bar takes the complex LDLᵀ
    let factorization = field("factorization");
    assert!(
        factorization.contains("complex-symmetric supernodal LDLᵀ")
            && factorization.contains("auto → ldlt: damped"),
        "{factorization}"
    );
    assert!(!factorization.contains("2N"), "{factorization}");

    let work = scratch("sweep_ok");
    let args = [
        "sweep",
        bar_str(),
        "--band",
        "1:1000",
        "--points",
        "7",
        "--part",
        "elastic",
        "--threads",
        "2",
        "--out",
        "frf.csv",
        "--stats",
        "stats.csv",
    ];
    ok(&work, &args);
    assert_eq!(
        entries(&work),
        ["frf.csv", "stats.csv"],
        "only the CSVs are left (no temporary file)"
    );
    let rows = csv(&work.join("frf.csv"), "f_hz,output,input,re,im");
    assert_eq!(rows.len(), 7 * 9 * 9);
    assert!(rows.iter().all(|r| r.len() == 5));

    // Frequencies: 7 distinct increasing values from exactly 1 to exactly 1000.
    let mut freqs: Vec<f64> = rows.iter().map(|r| num(&r[0])).collect();
    freqs.dedup();
    assert_eq!(freqs.len(), 7);
    assert!(freqs.windows(2).all(|w| w[0] < w[1]));
    assert_eq!((freqs[0], freqs[6]), (1.0, 1000.0));
    // DoF columns: the 9 paper I/O DoFs, outputs × inputs in scene order per frequency.
    for (k, chunk) in rows.chunks(81).enumerate() {
        for (o, &od) in PAPER_IO.iter().enumerate() {
            for (i, &id) in PAPER_IO.iter().enumerate() {
                let r = &chunk[o * 9 + i];
                assert_eq!(num(&r[0]), freqs[k]);
                assert_eq!(
                    (r[1].as_str(), r[2].as_str()),
                    (od.to_string().as_str(), id.to_string().as_str())
                );
            }
        }
    }

    // The same numbers from the library, bit for bit.
    let (model, scene, _) = model_dir::read(bar()).expect("read the generated bar");
    assert_eq!(scene.inputs, PAPER_IO);
    assert_eq!(scene.outputs, PAPER_IO);
    let opts = SweepOptions {
        threads: 2,
        ..Default::default()
    };
    let body = sparsemor::body::Body::new(&model).expect("prepare the bar");
    let frf = transfer_function(
        &body,
        &scene,
        &freqs,
        Part::Elastic,
        &opts,
        None,
        &no_progress,
    )
    .expect("library sweep");
    // The per-frequency statistics: the library's accuracy numbers, bit for bit.
    let stats = csv(
        &work.join("stats.csv"),
        "f_hz,factor_s,solve_s,probe_error,backward_error,refinement_steps,pivot_ratio,pivoted,krylov_dim,relative_residual,normwise_backward_error",
    );
    assert_eq!(stats.len(), 7);
    for (r, s) in stats.iter().zip(&frf.freq_stats) {
        assert_eq!(num(&r[0]), s.freq_hz);
        assert_eq!(num(&r[3]).to_bits(), s.probe_error.to_bits(), "{r:?}");
        assert_eq!(num(&r[4]).to_bits(), s.backward_error.to_bits(), "{r:?}");
        assert_eq!(r[5], s.refinement_steps.to_string());
        assert_eq!(r[7], u8::from(s.pivoted).to_string());
        assert_eq!(r[8], s.space_dim.to_string());
        assert_eq!(num(&r[9]).to_bits(), s.relative_residual.to_bits(), "{r:?}");
        assert_eq!(
            num(&r[10]).to_bits(),
            s.normwise_backward_error.to_bits(),
            "{r:?}"
        );
        // the bar is damped proportionally: every elastic response comes from the shifted
        // Krylov space, no factorization, certified by its residual
        assert!(s.from_space(), "{r:?}");
        assert!(num(&r[1]) == 0.0 && num(&r[2]) > 0.0, "{r:?}");
        assert!(
            s.backward_error > 0.0
                && (s.backward_error <= sparsemor::sweep::CERTIFIED_BACKWARD_ERROR
                    || s.relative_residual <= sparsemor::sweep::CERTIFIED_RELATIVE_RESIDUAL
                    || s.normwise_backward_error
                        <= sparsemor::sweep::CERTIFIED_NORMWISE_BACKWARD_ERROR),
            "{r:?}"
        );
    }
    for (k, h) in frf.h.iter().enumerate() {
        for o in 0..9 {
            for i in 0..9 {
                let r = &rows[k * 81 + o * 9 + i];
                let (re, im) = (num(&r[3]), num(&r[4]));
                let z = h[(o, i)];
                assert!(
                    re.to_bits() == z.re.to_bits() && im.to_bits() == z.im.to_bits(),
                    "f = {} Hz, H[{o},{i}]: CSV {re:e}{im:+e}i vs library {:e}{:+e}i",
                    freqs[k],
                    z.re,
                    z.im
                );
            }
        }
    }
}

#[test]
fn generate_with_elements_and_size() {
    let work = scratch("generate_sized");
    ok(
        &work,
        &[
            "generate",
            "bar",
            "--elements",
            "2x3x10",
            "--size",
            "0.006x0.008x0.1",
            "--out",
            "D2",
        ],
    );
    let info = ok(&work, &["info", "D2"]);
    // (2+1)(3+1)(10+1) nodes × 3 DoFs
    assert!(
        info.lines()
            .any(|l| l.starts_with("N ") && l.ends_with(" 396")),
        "info:\n{info}"
    );

    fails(
        &work,
        &["generate", "bar", "--elements", "2x3", "--out", "D3"],
        &["error:", "--elements", "2x3"],
    );
    fails(
        &work,
        &["generate", "bar", "--size", "0.006x0.008", "--out", "D3"],
        &["error:", "--size"],
    );
    fails(
        &work,
        &["generate", "beam", "--out", "D3"],
        &["error:", "beam", "bar"],
    );
    assert_eq!(
        entries(&work),
        ["D2"],
        "failed generates leave nothing behind"
    );
}

#[test]
fn generate_refuses_a_non_empty_output_directory() {
    let work = scratch("generate_nonempty");
    std::fs::create_dir(work.join("out")).expect("mkdir");
    std::fs::write(work.join("out/keep.txt"), "x").expect("write");
    fails(
        &work,
        &["generate", "bar", "--out", "out"],
        &["error:", "not empty"],
    );
    assert_eq!(entries(&work.join("out")), ["keep.txt"]);
    assert_eq!(entries(&work), ["out"]);
}

/// A memory budget that is not a number above 0 is refused by name, by every command that
/// takes one, before any work (the model here does not exist). `NaN` used to run with a
/// budget of 0 bytes and fail later with an unrelated least-squares message.
#[test]
fn a_memory_budget_must_be_a_number_above_zero() {
    let work = scratch("memory_budget");
    for budget in ["nan", "0", "inf", "8GB"] {
        for command in [
            &["reduce", "none", "--method", "linefit", "--out", "o"][..],
            &["sweep", "none", "--freqs", "100", "--out", "o.csv"],
            &["modes", "none"],
        ] {
            let mut args = command.to_vec();
            args.extend(["--memory-gb", budget]);
            fails(&work, &args, &["--memory-gb", "no memory budget"]);
        }
    }
}

/// `reduce` and `report` check their output directory before any work: the model here does
/// not even exist, and the error is about the directory (a 10⁶-DoF reduction used to fail
/// only after its minutes of work).
#[test]
fn reduce_and_report_refuse_a_non_empty_output_directory_first() {
    let work = scratch("reduce_nonempty");
    std::fs::create_dir(work.join("out")).expect("mkdir");
    std::fs::write(work.join("out/keep.txt"), "x").expect("write");
    for args in [
        &[
            "reduce",
            "no_such_model",
            "--method",
            "linefit",
            "--out",
            "out",
        ][..],
        &["report", "no_such_model", "no_such_rom", "--out", "out"][..],
    ] {
        fails(&work, args, &["error:", "out", "not empty"]);
    }
    assert_eq!(entries(&work.join("out")), ["keep.txt"]);
}

#[test]
fn sweep_bad_settings_fail_cleanly_without_output() {
    let cases: [(&str, &[&str], &[&str]); 7] = [
        (
            "part",
            &["--band", "1:1000", "--points", "3", "--part", "bogus"],
            &["--part", "bogus", "total", "elastic", "rigid"],
        ),
        ("no_band", &[], &["--band", "--freqs"]),
        (
            "reversed_band",
            &["--band", "5:1"],
            &["--band", "5:1", "LO < HI"],
        ),
        (
            "backend",
            &["--band", "1:1000", "--backend", "nope"],
            &["--backend", "nope", "faer-lblt"],
        ),
        ("bad_band", &["--band", "1-1000"], &["--band", "LO:HI"]),
        ("zero_hz", &["--freqs", "0,10"], &["0 Hz", "free body"]),
        ("bad_freq", &["--freqs", "10,abc"], &["--freqs", "abc"]),
    ];
    for (name, extra, needles) in cases {
        let work = scratch(&format!("sweep_bad_{name}"));
        let mut args = vec!["sweep", bar_str()];
        args.extend_from_slice(extra);
        args.extend_from_slice(&["--threads", "1", "--out", "frf.csv"]);
        let err = fails(&work, &args, needles);
        assert!(err.starts_with("error:"), "{name}: {err}");
        assert!(
            entries(&work).is_empty(),
            "{name}: left {:?} behind",
            entries(&work)
        );
    }
}

// ---------------------------------------------------------------------------------------------
// reduce, evaluate, modes

const REF_FREQS: &str =
    "50,100,150,200,250,300,350,400,450,500,550,600,650,700,750,800,850,900,950,1000";

#[test]
fn reduce_linefit_then_evaluate() {
    let work = scratch("reduce_ok");
    let out = ok(
        &work,
        &[
            "reduce",
            bar_str(),
            "--method",
            "linefit",
            "--extra-interface",
            "5",
            "--ref-freqs",
            REF_FREQS,
            "--threads",
            "2",
            "--out",
            "ROM",
        ],
    );
    assert!(
        out.lines()
            .any(|l| l.starts_with("order") && l.ends_with(" 14")),
        "reduce:\n{out}"
    );
    let mut expected = vec![
        "Br.mtx", "Cr.mtx", "Dr.mtx", "Kr.mtx", "Mr.mtx", "rom.npz", "rom.toml",
    ];
    expected.sort();
    assert_eq!(entries(&work.join("ROM")), expected);
    assert_eq!(
        entries(&work),
        ["ROM"],
        "no temporary directory left behind"
    );

    ok(
        &work,
        &[
            "evaluate",
            bar_str(),
            "ROM",
            "--points",
            "50",
            "--threads",
            "2",
            "--csv",
            "eps.csv",
        ],
    );
    let rows = csv(&work.join("eps.csv"), "f_hz,eps_elastic,eps_total");
    assert_eq!(rows.len(), 50);
    // The band [0, 1000] starts at 0 on a free body: evaluated from 1 Hz.
    assert_eq!(num(&rows[0][0]), 1.0);
    assert_eq!(num(&rows[49][0]), 1000.0);
    for r in &rows {
        assert_eq!(r.len(), 3);
        let (e1, e) = (num(&r[1]), num(&r[2]));
        assert!(
            e1.is_finite() && e1 >= 0.0 && e.is_finite() && e >= 0.0,
            "row {r:?}"
        );
    }
    let worst = rows.iter().map(|r| num(&r[1])).fold(0.0, f64::max);
    assert!(
        worst < 0.1,
        "line-fitting elastic error up to {worst:.3e} on the paper bar"
    );
    // evaluated far above the band the ROM was built for: said so
    let out = ok(
        &work,
        &[
            "evaluate",
            bar_str(),
            "ROM",
            "--band",
            "1:100000",
            "--points",
            "5",
            "--no-modes",
        ],
    );
    assert!(
        out.lines()
            .any(|l| l.starts_with("note") && l.contains("100.0x") && l.contains("extrapolation")),
        "evaluate above the band:\n{out}"
    );
}

/// Craig–Bampton of the free bar, then `evaluate`: the ROM keeps the six rigid modes, which
/// `reduce`, `evaluate` and the demo's table word the same (`Kr semidefinite (6 rigid)`), and
/// no frequency reads `-0.0`.
#[test]
fn reduce_craig_bampton_then_evaluate() {
    let work = scratch("reduce_cb");
    let reduced = ok(
        &work,
        &[
            "reduce",
            bar_str(),
            "--method",
            "craig-bampton",
            "--extra-interface",
            "1",
            "--modes",
            "32",
            "--threads",
            "2",
            "--out",
            "ROM",
        ],
    );
    assert!(
        reduced.contains("method           craig-bampton") && reduced.contains("K_ii by cholesky"),
        "reduce:\n{reduced}"
    );
    let toml = std::fs::read_to_string(work.join("ROM/rom.toml")).unwrap();
    assert!(
        toml.contains("[craig_bampton]") && toml.contains("order = 42"),
        "{toml}"
    );
    let out = ok(
        &work,
        &[
            "evaluate",
            bar_str(),
            "ROM",
            "--points",
            "50",
            "--threads",
            "2",
            "--csv",
            "eps.csv",
        ],
    );
    let rows = csv(&work.join("eps.csv"), "f_hz,eps_elastic,eps_total");
    let worst = rows.iter().map(|r| num(&r[1])).fold(0.0, f64::max);
    // c = 32: 9.8e-3 on 2000 points (README, tradeoff)
    assert!(
        worst < 2e-2,
        "Craig–Bampton c = 32: eps up to {worst:.3e}\n{out}"
    );
    let line = |out: &str, prefix: &str| -> String {
        out.lines()
            .find(|l| l.starts_with(prefix))
            .unwrap_or_else(|| panic!("no '{prefix}' line:\n{out}"))[prefix.len()..]
            .trim()
            .to_string()
    };
    let freqs = line(&out, "ROM eigenfreqs");
    let freqs: Vec<&str> = freqs.split(' ').collect();
    assert_eq!(freqs[..6], ["0"; 6], "evaluate:\n{out}");
    assert!(
        freqs[6..].iter().all(|f| num(f) > 100.0),
        "evaluate:\n{out}"
    );
    let stability = line(&out, "stability");
    assert_eq!(stability, "Mr SPD, Kr semidefinite (6 rigid)");
    assert!(
        line(&reduced, "Kr").starts_with("semidefinite (6 rigid) (eigenvalues"),
        "reduce:\n{reduced}"
    );
    // the demo's own Craig–Bampton ROM (10 boundary DoFs + 4 modes) in its table
    let demo = ok(&work, &["demo", "--threads", "2"]);
    let row = demo
        .lines()
        .find(|l| l.starts_with("| Craig–Bampton"))
        .unwrap_or_else(|| panic!("no Craig–Bampton row in the demo:\n{demo}"));
    let cells: Vec<&str> = row.split('|').map(str::trim).collect();
    assert_eq!(cells[cells.len() - 2], stability, "demo:\n{demo}");
    for (name, text) in [("reduce", &reduced), ("evaluate", &out), ("demo", &demo)] {
        assert!(!text.contains("-0.0"), "{name}:\n{text}");
    }
}

#[test]
fn reduce_bad_settings_fail_cleanly_without_output() {
    let cases: [(&str, &[&str], &[&str]); 8] = [
        (
            "interface_without_outputs",
            &[
                "--method",
                "linefit",
                "--interface",
                "0,1,2,792,793,794,1620,1621,5,6",
                "--ref-freqs",
                REF_FREQS,
            ],
            &["output DoF 1622", "interface"],
        ),
        (
            "interface_duplicate",
            &[
                "--method",
                "linefit",
                "--interface",
                "0,1,2,792,793,794,1620,1621,1622,5,0",
                "--ref-freqs",
                REF_FREQS,
            ],
            &["interface", "DoF 0", "twice"],
        ),
        // n = 9 outputs + 10 = 19 > 2pz = 2·9·1 = 18
        (
            "too_few_ref_freqs",
            &[
                "--method",
                "linefit",
                "--extra-interface",
                "10",
                "--ref-freqs",
                "100",
            ],
            &["2pz", "< n = 19"],
        ),
        (
            "method",
            &[
                "--method",
                "foo",
                "--extra-interface",
                "5",
                "--ref-freqs",
                REF_FREQS,
            ],
            &["--method", "foo", "linefit", "serep"],
        ),
        (
            "no_ref_freqs",
            &["--method", "linefit", "--extra-interface", "5"],
            &["--ref-freqs"],
        ),
        // SEREP with fewer modes than its 9 retained DoFs: singular Mr, Kr — refused up front
        (
            "serep_fewer_modes_than_masters",
            &["--method", "serep", "--modes", "3"],
            &["c = 3 modes < r = 9", "at least 9 modes"],
        ),
        (
            "craig_bampton_without_modes",
            &["--method", "craig-bampton", "--extra-interface", "1"],
            &["craig-bampton needs --modes"],
        ),
        // the 9 outputs sit at three nodes on one edge: they do not hold the free bar
        (
            "craig_bampton_collinear_boundary",
            &[
                "--method",
                "craig-bampton",
                "--extra-interface",
                "0",
                "--modes",
                "4",
            ],
            &["do not hold the free body", "non-collinear"],
        ),
    ];
    for (name, extra, needles) in cases {
        let work = scratch(&format!("reduce_bad_{name}"));
        let mut args = vec!["reduce", bar_str()];
        args.extend_from_slice(extra);
        args.extend_from_slice(&["--threads", "1", "--out", "ROM"]);
        let err = fails(&work, &args, needles);
        assert!(err.starts_with("error:"), "{name}: {err}");
        assert!(
            entries(&work).is_empty(),
            "{name}: left {:?} behind",
            entries(&work)
        );
    }
}

#[test]
fn modes_in_band_are_six_rigid_then_six_elastic() {
    let work = scratch("modes");
    ok(
        &work,
        &["modes", bar_str(), "--band", "0:1000", "--csv", "m.csv"],
    );
    let rows = csv(&work.join("m.csv"), "index,f_hz,kind,lambda");
    assert_eq!(rows.len(), 12, "{rows:?}");
    for (k, r) in rows.iter().enumerate() {
        assert_eq!(r.len(), 4);
        assert_eq!(r[0], (k + 1).to_string());
        assert_eq!(r[2], if k < 6 { "rigid" } else { "elastic" }, "row {r:?}");
        let f = num(&r[1]);
        if k >= 6 {
            assert!(f > 1.0 && f <= 1000.0, "elastic mode {} at {f} Hz", k + 1);
        } else {
            // a rigid mode is 0 Hz, never negative; its computed λ (rounding level) is kept
            assert_eq!(f, 0.0, "rigid mode {} at {f} Hz", k + 1);
            let lambda7 = num(&rows[6][3]);
            assert!(
                num(&r[3]).abs() <= 1e-9 * lambda7,
                "rigid lambda {} vs lambda_7 {lambda7}",
                r[3]
            );
        }
    }
    let out = ok(&work, &["modes", bar_str(), "--count", "8"]);
    assert!(
        !out.contains(" -0."),
        "a negative frequency printed:\n{out}"
    );
    let f: Vec<f64> = rows.iter().map(|r| num(&r[1])).collect();
    assert!(f.windows(2).all(|w| w[0] <= w[1]), "ascending: {f:?}");
}

#[cfg(not(feature = "umfpack"))]
#[test]
fn bench_with_a_backend_this_build_lacks_is_an_error() {
    let work = scratch("bench_umfpack");
    fails(
        &work,
        &["bench", "sweep", "--backends", "umfpack", "--max-n", "2000"],
        &["umfpack", "--features umfpack"],
    );
}

/// A tolerance that cannot be met: the ROM is written, the exit status is 3 (documented in
/// `--help`), `rom.toml` records the request, the error reached and its kind, and the CLI words
/// the hint with its own flags.
#[test]
fn unmet_tolerance_writes_the_rom_and_exits_with_status_3() {
    let help = ok(&scratch("help"), &["--help"]);
    assert!(help.contains("Exit status") && help.contains("3  the ROM was written"));
    for (name, extra, hint) in [
        ("stagnated", &["--max-order", "14"][..], "--max-order"),
        ("budget", &["--max-points", "5"][..], "--max-points"),
    ] {
        let work = scratch(&format!("unmet_{name}"));
        let mut args = vec![
            "reduce",
            bar_str(),
            "--method",
            "linefit",
            "--extra-interface",
            "5",
            "--tol",
            "1e-6",
            "--threads",
            "1",
            "--out",
            "rom",
        ];
        args.extend_from_slice(extra);
        let out = run(&work, &args);
        let (stdout, stderr) = (text(&out.stdout), text(&out.stderr));
        assert_eq!(out.status.code(), Some(3), "{name}: {stdout}\n{stderr}");
        assert!(
            stdout.contains("NOT reached") && stdout.contains(hint),
            "{name}: {stdout}"
        );
        assert!(!stdout.contains("max_points") && !stdout.contains("max_order"));
        // the progress table leaves what a step did not measure empty
        assert!(!stdout.contains("NaN"), "{name}: {stdout}");
        let toml = std::fs::read_to_string(work.join("rom").join("rom.toml")).expect("rom.toml");
        assert!(toml.contains("[sampling]"), "{toml}");
        assert!(
            toml.contains("tol = 1e-6") || toml.contains("tol = 0.000001"),
            "{toml}"
        );
        let status = if name == "budget" {
            "budget spent"
        } else {
            "stagnated"
        };
        assert!(toml.contains(&format!("status = \"{status}\"")), "{toml}");
        assert!(toml.contains("error_kind = "), "{toml}");
        let rom = sparsemor::io::rom_dir::read(&work.join("rom")).expect("read the ROM back");
        let s = rom.sampling().expect("the [sampling] table is read back");
        assert!(
            s.error > 1e-6 && stdout.contains(&format!("{:.2e}", s.error)),
            "{stdout}"
        );
    }
}

/// `bench sweep` reports no made-up fill for faer LU: a dash with its footnote.
#[test]
fn bench_marks_the_fill_it_cannot_report() {
    let out = ok(
        &scratch("bench_lu"),
        &["bench", "sweep", "--backends", "faer-lu", "--max-n", "2000"],
    );
    let row = out
        .lines()
        .find(|l| l.contains("faer-lu"))
        .unwrap_or_else(|| panic!("no faer-lu row:\n{out}"));
    assert!(row.contains("— (a)") && !row.contains("| 0 |"), "{row}");
    assert!(out.contains("(a) faer LU and UMFPACK"), "{out}");
}

/// With stderr not a terminal (a script, a log file) no progress bar is drawn: stderr holds
/// only the closing summary line.
#[test]
fn no_progress_bar_when_stderr_is_not_a_terminal() {
    let work = scratch("quiet_progress");
    let out = run(
        &work,
        &[
            "sweep",
            bar_str(),
            "--band",
            "1:1000",
            "--points",
            "40",
            "--threads",
            "1",
            "--out",
            "f.csv",
        ],
    );
    let err = text(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(
        !err.contains("eta") && !err.contains("[="),
        "a bar was drawn:\n{err}"
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("40 frequencies in"), "{err}");
}

/// Ctrl-C (SIGINT) during a long sweep stops it cleanly: a clear message, a non-zero exit
/// status and no output file.
#[cfg(unix)]
#[test]
fn ctrl_c_stops_a_long_sweep_and_writes_nothing() {
    let work = scratch("ctrl_c");
    let child = Command::new(env!("CARGO_BIN_EXE_sparsemor"))
        .args([
            "sweep",
            bar_str(),
            "--band",
            "1:1000",
            "--points",
            "200000",
            "--threads",
            "1",
            "--out",
            "f.csv",
        ])
        .current_dir(&work)
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("start the sweep");
    std::thread::sleep(std::time::Duration::from_secs(2));
    let kill = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .expect("kill -INT");
    assert!(kill.success());
    let out = child.wait_with_output().expect("wait");
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("cancelled"), "{err}");
    assert!(
        entries(&work).is_empty(),
        "left {:?} behind",
        entries(&work)
    );
}

/// A real factor that does not fit `--memory-gb` goes to an unnamed file in the temporary
/// directory: the run says so with the bytes it moved, reaches the tolerance with the same
/// order and errors as in memory, and leaves the directory empty.
#[test]
fn a_factor_beyond_the_memory_budget_goes_to_disk_and_leaves_nothing() {
    let work = scratch("factor_on_disk");
    let tmp = work.join("tmp");
    std::fs::create_dir_all(&tmp).unwrap();
    let reduce = |out: &str, budget: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_sparsemor"))
            .args(["reduce", bar_str(), "--method", "linefit", "--tol", "1e-3"])
            .args(budget)
            .args(["--out", out])
            .env("TMPDIR", &tmp)
            .current_dir(&work)
            .output()
            .expect("run sparsemor");
        let stdout = text(&out.stdout);
        assert!(out.status.success(), "{stdout}{}", text(&out.stderr));
        stdout
    };
    let in_memory = reduce("memory", &[]);
    let on_disk = reduce("disk", &["--memory-gb", "0.01"]);
    assert!(!in_memory.contains("factor on disk"), "{in_memory}");
    assert!(on_disk.contains("factor on disk:"), "{on_disk}");
    let reached = |s: &str| {
        s.lines()
            .find(|l| l.starts_with("tolerance 1.0e-3 reached"))
            .map(str::to_owned)
    };
    assert!(reached(&in_memory).is_some(), "{in_memory}");
    assert_eq!(reached(&in_memory), reached(&on_disk));
    assert!(entries(&tmp).is_empty(), "left {:?} behind", entries(&tmp));
}

/// The elastic part of a free body is finite at 0 Hz: `sweep --band 0:1000 --part elastic`
/// works (the model's own band starts at 0); the total at 0 Hz is refused with the reason.
#[test]
fn elastic_sweep_from_zero_hertz() {
    let work = scratch("sweep_zero_elastic");
    ok(
        &work,
        &[
            "sweep",
            bar_str(),
            "--band",
            "0:1000",
            "--points",
            "5",
            "--part",
            "elastic",
            "--threads",
            "1",
            "--out",
            "frf.csv",
        ],
    );
    let rows = csv(&work.join("frf.csv"), "f_hz,output,input,re,im");
    assert!(rows.iter().any(|r| num(&r[0]) == 0.0));
    assert!(rows
        .iter()
        .all(|r| num(&r[3]).is_finite() && num(&r[4]).is_finite()));
    fails(
        &scratch("sweep_zero_total"),
        &[
            "sweep",
            bar_str(),
            "--band",
            "0:1000",
            "--points",
            "5",
            "--out",
            "frf.csv",
        ],
        &["0 Hz", "free body", "elastic part"],
    );
}

/// `--retain` and `--interface` take NODE:DIR as well as indices (node i owns DoFs 3i..3i+2 of
/// the generated bar): the same DoFs named either way give the same ROM files, byte for byte;
/// a DoF the model lacks is an error naming the option.
#[test]
fn dofs_given_as_node_dir_or_index_give_the_same_rom() {
    let work = scratch("node_dir");
    for (retain, out) in [("0,1,2,100", "A"), ("0:x,0:y,0:z,33:y", "B")] {
        ok(
            &work,
            &[
                "reduce",
                bar_str(),
                "--method",
                "serep",
                "--modes",
                "6",
                "--retain",
                retain,
                "--threads",
                "1",
                "--out",
                out,
            ],
        );
    }
    for f in ["Mr.mtx", "Kr.mtx", "Br.mtx", "Cr.mtx"] {
        let a = std::fs::read(work.join("A").join(f)).unwrap();
        let b = std::fs::read(work.join("B").join(f)).unwrap();
        assert!(a == b, "{f} differs between indices and NODE:DIR");
    }
    fails(
        &work,
        &[
            "reduce",
            bar_str(),
            "--method",
            "linefit",
            "--interface",
            "9999:x",
            "--tol",
            "1e-2",
            "--out",
            "C",
        ],
        &["--interface", "no DoF 9999:x", "nodes numbered from 0"],
    );
    assert!(!work.join("C").exists());
}

/// A model with a loss factor (docs/design.md §3.12): `info` names the damping path, the ROM
/// directory holds K4r.mtx, OP4 and DMIG carry it (K4R, K4AAX with K42GG), and the
/// time-domain exports refuse it by name.
#[test]
fn structural_damping_from_model_toml_to_the_exports() {
    let dir = scratch("structural");
    let model = dir.join("bar");
    std::fs::create_dir_all(&model).unwrap();
    for f in ["M.mtx", "K.mtx", "nodes.csv"] {
        std::fs::copy(bar().join(f), model.join(f)).unwrap();
    }
    let toml = std::fs::read_to_string(bar().join("model.toml")).unwrap();
    assert!(toml.contains("\n[scene]"));
    let toml = toml.replacen("\n[scene]", "\n[structural]\neta = 0.02\n\n[scene]", 1);
    std::fs::write(model.join("model.toml"), toml).unwrap();
    let info = ok(&dir, &["info", "bar"]);
    assert!(
        info.contains("loss factor eta = 2e-2") && info.contains("damping path     proportional"),
        "{info}"
    );
    ok(
        &dir,
        &[
            "reduce",
            "bar",
            "--method",
            "linefit",
            "--ref-freqs",
            "100,400,700,950",
            "--extra-interface",
            "2",
            "--keep-basis",
            "--out",
            "rom",
        ],
    );
    assert!(dir.join("rom/K4r.mtx").is_file());
    let rom_toml = std::fs::read_to_string(dir.join("rom/rom.toml")).unwrap();
    assert!(rom_toml.contains("structural_damping = true"), "{rom_toml}");
    ok(
        &dir,
        &[
            "export", "rom", "--model", "bar", "--format", "op4", "--out", "op4",
        ],
    );
    let op4 = std::fs::read_to_string(dir.join("op4/rom.op4")).unwrap();
    assert!(op4.contains("K4R"), "no K4R in rom.op4");
    let dmig = ok(
        &dir,
        &[
            "export", "rom", "--model", "bar", "--format", "dmig", "--out", "dmig",
        ],
    );
    assert!(dmig.contains("K4AAX"), "{dmig}");
    let bdf = std::fs::read_to_string(dir.join("dmig/dmig.bdf")).unwrap();
    assert!(
        bdf.contains("K42GG = K4AAX") && bdf.contains("DMIG    K4AAX"),
        "{bdf}"
    );
    for format in ["sid", "mbdyn", "exudyn"] {
        fails(
            &dir,
            &[
                "export", "rom", "--model", "bar", "--format", format, "--out", format,
            ],
            &["structural (hysteretic) damping K4r", "--format op4"],
        );
        assert!(!dir.join(format).exists(), "{format}: a directory was left");
    }
}
