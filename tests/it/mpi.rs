//! `mpirun -np 2 sparsemor …` (cargo feature `mpi`, OpenMPI, loopback, docs/design.md §9):
//! the distributed ROM equals the one-process ROM, the tolerance run meets its tolerance with
//! the same verification, a failing rank ends every rank with its error, and the commands that
//! do not run distributed say so.

use crate::cli::{ok, run};
use sparsemor::io::rom_dir;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

fn scratch(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("mpi")
        .join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `mpirun -np ranks sparsemor args…` in `cwd`, output captured.
fn mpirun_command(cwd: &Path, ranks: usize, args: &[&str]) -> Command {
    let mut c = Command::new("mpirun");
    c.args(["--oversubscribe", "-np", &ranks.to_string()])
        .arg(env!("CARGO_BIN_EXE_sparsemor"))
        .args(args)
        .current_dir(cwd)
        // CI runs as root; shared-memory transport without ptrace-based single copy (containers)
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .env("OMPI_MCA_btl_vader_single_copy_mechanism", "none")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    c
}

/// Runs [`mpirun_command`]; panics if it is still running after 5 min (a hang is the failure
/// this guards against, not a slow run).
fn mpirun(cwd: &Path, ranks: usize, args: &[&str]) -> Output {
    let mut child = mpirun_command(cwd, ranks, args)
        .spawn()
        .expect("mpirun (OpenMPI: apt-get install openmpi-bin libopenmpi-dev)");
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(300) {
            let _ = child.kill();
            panic!("mpirun {args:?} hung for 5 minutes");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    child.wait_with_output().unwrap()
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

fn mpirun_ok(cwd: &Path, ranks: usize, args: &[&str]) -> String {
    let out = mpirun(cwd, ranks, args);
    assert!(
        out.status.success(),
        "mpirun -np {ranks} sparsemor {args:?} failed ({}):\n{}\n{}",
        out.status,
        text(&out.stdout),
        text(&out.stderr)
    );
    text(&out.stdout)
}

fn bar(dir: &Path) {
    ok(dir, &["generate", "bar", "--out", "bar"]);
}

/// `reduce bar` by line-fitting with 5 extra interface DoFs at 7 fixed reference frequencies
/// on one thread, then `extra`.
fn fixed_reduce<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    let fixed = [
        "reduce",
        "bar",
        "--method",
        "linefit",
        "--extra-interface",
        "5",
        "--ref-freqs",
        "50,100,200,400,600,800,1000",
        "--threads",
        "1",
    ];
    [&fixed[..], extra].concat()
}

/// Reads the ROMs `one` and `two` and asserts that each matrix of `two` is within relative
/// distance `tol` of `one`'s (`what` labels the output); returns `two`.
fn same_rom(one: &Path, two: &Path, tol: f64, what: &str) -> sparsemor::reduce::Rom {
    let one = rom_dir::read(one).unwrap();
    let two = rom_dir::read(two).unwrap();
    for ((name, a), (_, b)) in two.matrices().iter().zip(one.matrices()) {
        let d = (*a - b).norm_l2() / b.norm_l2();
        println!("{what}, {name}: relative difference {d:.1e}");
        assert!(d <= tol, "{what}, {name}: {d:.2e}");
    }
    two
}

/// `dir/springs`: three undamped springs with K₀₀ = (2π·1 Hz)², so A(i·2π·1 Hz) has an
/// exactly zero diagonal entry (singular at 1 Hz).
fn springs(dir: &Path) {
    let m = dir.join("springs");
    std::fs::create_dir_all(&m).unwrap();
    let w = 2.0 * std::f64::consts::PI;
    let k = [w * w, 2.0 * w * w + 1.0, 3.0 * w * w + 2.0];
    let mm = |d: [f64; 3]| {
        format!(
            "%%MatrixMarket matrix coordinate real symmetric\n3 3 3\n1 1 {:?}\n2 2 {:?}\n3 3 {:?}\n",
            d[0], d[1], d[2]
        )
    };
    std::fs::write(m.join("M.mtx"), mm([1.0; 3])).unwrap();
    std::fs::write(m.join("K.mtx"), mm(k)).unwrap();
    std::fs::write(
        m.join("model.toml"),
        "name = \"springs\"\nmass = \"M.mtx\"\nstiffness = \"K.mtx\"\n\n[scene]\n\
         inputs = [0, 1]\noutputs = [0, 2]\nband_hz = [0.1, 2.0]\n",
    )
    .unwrap();
}

#[test]
fn mpirun_linefit_rom_equals_the_one_process_rom() {
    let dir = scratch("linefit");
    bar(&dir);
    // factored, the ranks' ROM differs by the TSQR merge's rounding; from the Krylov space
    // each rank grows its own space, and the ROMs agree to the responses' certificates
    for (solve, tol) in [("factor", 1e-12), ("auto", 1e-10)] {
        let common = fixed_reduce(&["--solve", solve]);
        let (one, two) = (format!("one-{solve}"), format!("two-{solve}"));
        ok(&dir, &[&common[..], &["--out", &one]].concat());
        mpirun_ok(&dir, 2, &[&common[..], &["--out", &two]].concat());
        let two = same_rom(&dir.join(one), &dir.join(two), tol, solve);
        assert_eq!(two.fit().unwrap().solves.frequencies, 7);
    }
}

/// With `--backend mumps` both ranks hold and compute a part of every factorization (MUMPS
/// on a communicator of 2, docs/design.md §9): the ROM equals the one-process MUMPS ROM to
/// the rounding of two backward-stable factorizations of the same matrices, and a MUMPS
/// failure (a singular frequency) reaches rank 0 and ends both ranks with its error.
#[cfg(feature = "mumps")]
#[test]
fn mpirun_mumps_ranks_share_each_factorization() {
    let dir = scratch("mumps");
    bar(&dir);
    let common = fixed_reduce(&["--backend", "mumps", "--solve", "factor"]);
    ok(&dir, &[&common[..], &["--out", "one"]].concat());
    mpirun_ok(&dir, 2, &[&common[..], &["--out", "two"]].concat());
    // two backward-stable factorizations of the same matrices (fronts mapped differently,
    // BLAS threads as the machine gives), their rounding amplified by the fit's conditioning
    // (cond 1e6 here): 4e-14 to 4e-13 measured; the issue's bound is 1e-10
    same_rom(&dir.join("one"), &dir.join("two"), 1e-10, "mumps");
    // the analysis' footprint is that of MUMPS's communicator: both ranks
    let out = mpirun(
        &dir,
        2,
        &[
            "sweep",
            "bar",
            "--freqs",
            "100",
            "--backend",
            "mumps",
            "--out",
            "bar.csv",
            "-v",
        ],
    );
    let err = text(&out.stderr);
    assert!(
        out.status.success() && err.contains("of 2 sharing it"),
        "{err}"
    );
    springs(&dir);
    let out = mpirun(
        &dir,
        2,
        &[
            "sweep",
            "springs",
            "--freqs",
            "0.5,1",
            "--backend",
            "mumps",
            "--out",
            "h.csv",
        ],
    );
    let err = text(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("at 1 Hz is numerically singular"), "{err}");
    assert!(!dir.join("h.csv").exists(), "no output after a failed run");
}

#[test]
fn mpirun_tolerance_run_meets_its_tolerance() {
    let dir = scratch("tol");
    bar(&dir);
    let stdout = mpirun_ok(
        &dir,
        2,
        &[
            "reduce",
            "bar",
            "--method",
            "linefit",
            "--tol",
            "1e-3",
            "--threads",
            "1",
            "--out",
            "rom",
        ],
    );
    let rom = rom_dir::read(&dir.join("rom")).unwrap();
    let s = rom.sampling().unwrap();
    let v = s.verified.expect("verification ran");
    println!(
        "{:?}: error {:.2e}, verified {:.2e} on {} points",
        s.outcome, s.error, v.error, v.points
    );
    assert!(
        s.outcome.reached() && s.error <= 1e-3 && v.error <= 1e-3,
        "{stdout}"
    );
}

#[test]
fn mpirun_sweep_equals_the_one_process_sweep() {
    let dir = scratch("sweep");
    bar(&dir);
    // factored: bit for bit (a free body's total response is H0 + H1, and H1 from each
    // rank's own Krylov space agrees to its certificate only)
    let common = [
        "sweep", "bar", "--band", "1:1000", "--points", "41", "--part", "total", "--solve",
        "factor",
    ];
    ok(&dir, &[&common[..], &["--out", "one.csv"]].concat());
    mpirun_ok(&dir, 2, &[&common[..], &["--out", "two.csv"]].concat());
    assert_eq!(
        std::fs::read(dir.join("one.csv")).unwrap(),
        std::fs::read(dir.join("two.csv")).unwrap()
    );
}

#[test]
fn mpirun_failing_rank_ends_every_rank_with_its_error() {
    let dir = scratch("singular");
    springs(&dir);
    // frequency k goes to rank k mod 2: 1 Hz to rank 1
    let start = Instant::now();
    let out = mpirun(
        &dir,
        2,
        &["sweep", "springs", "--freqs", "0.5,1", "--out", "h.csv"],
    );
    let err = text(&out.stderr);
    println!("ended in {:.1} s:\n{err}", start.elapsed().as_secs_f64());
    assert!(!out.status.success());
    assert!(
        err.contains("error: rank 1: A(s) at 1 Hz is numerically singular"),
        "{err}"
    );
    assert!(!dir.join("h.csv").exists(), "no output after a failed run");
}

#[test]
fn mpirun_of_a_command_that_does_not_run_distributed_says_so() {
    let dir = scratch("modes");
    bar(&dir);
    let out = mpirun(
        &dir,
        2,
        &[
            "reduce", "bar", "--method", "serep", "--modes", "9", "--out", "r",
        ],
    );
    let err = text(&out.stderr);
    assert!(!out.status.success());
    assert!(err.contains("only line-fitting runs distributed"), "{err}");
    assert!(!dir.join("r").exists());
    // and without mpirun the same binary runs it
    let single = run(
        &dir,
        &[
            "reduce", "bar", "--method", "serep", "--modes", "9", "--out", "r",
        ],
    );
    assert!(single.status.success(), "{}", text(&single.stderr));
}

/// The process of rank `rank` among the children of `mpirun` (its environment names the rank).
fn rank_pid(mpirun: u32, rank: usize) -> Option<u32> {
    let want = format!("OMPI_COMM_WORLD_RANK={rank}\0");
    std::fs::read_dir("/proc").ok()?.flatten().find_map(|e| {
        let pid: u32 = e.file_name().to_str()?.parse().ok()?;
        let stat = std::fs::read_to_string(e.path().join("stat")).ok()?;
        let ppid: u32 = stat
            .rsplit_once(')')?
            .1
            .split_whitespace()
            .nth(1)?
            .parse()
            .ok()?;
        let env = std::fs::read(e.path().join("environ")).ok()?;
        (ppid == mpirun && String::from_utf8_lossy(&env).contains(&want)).then_some(pid)
    })
}

#[test]
fn mpirun_killed_rank_ends_every_rank() {
    let dir = scratch("killed");
    ok(
        &dir,
        &["generate", "bar", "--elements", "3x4x200", "--out", "bar"],
    );
    let args = ["sweep", "bar", "--band", "1:1000", "--points", "5000"];
    let mut child = mpirun_command(
        &dir,
        2,
        &[&args[..], &["--threads", "1", "--out", "h.csv"]].concat(),
    )
    .spawn()
    .unwrap();
    let start = Instant::now();
    let pid = loop {
        if let Some(p) = rank_pid(child.id(), 1) {
            break p;
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "rank 1 never started"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    // let it start solving, then kill it the hard way (as the kernel's OOM killer would)
    std::thread::sleep(Duration::from_secs(2));
    assert!(
        child.try_wait().unwrap().is_none(),
        "the sweep ended before rank 1 was killed"
    );
    let killed = Instant::now();
    Command::new("kill")
        .args(["-9", &pid.to_string()])
        .status()
        .unwrap();
    while child.try_wait().unwrap().is_none() {
        assert!(
            killed.elapsed() < Duration::from_secs(120),
            "the job hung after rank 1 died"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    let out = child.wait_with_output().unwrap();
    println!(
        "mpirun ended {:.1} s after rank 1 was killed:\n{}",
        killed.elapsed().as_secs_f64(),
        text(&out.stderr)
    );
    assert!(!out.status.success());
    assert!(!dir.join("h.csv").exists(), "no output after a failed run");
}
