//! The MUMPS backend (cargo feature `mumps`, docs/design.md §3.1): the complex-symmetric
//! multifrontal LDLᵀ of MUMPS 5 (`zmumps_c`, SYM = 2: symmetric with pivoting), in core or
//! **out of core**, in one process or **over the ranks of `mpirun`**: with a directory the
//! factors are written there as they are computed and read back by the solves (ICNTL(22) = 1),
//! so only the active fronts stay in memory; with [`share`] every rank holds and computes a
//! part of each factorization (`ranks.rs`). Either way a body whose factor does not fit one
//! process can still be swept.
//!
//! - **Input**: the pencil's lower pattern, 1-based, assembled and centralized on rank 0
//!   (ICNTL(5) = 0, ICNTL(18) = 0); the values of A(iω) gathered per frequency; METIS ordering
//!   (ICNTL(7) = 5); right-hand sides and solutions on rank 0.
//! - **Analysis**: [`analyse`] runs MUMPS's analysis once on a scratch instance to read what it
//!   predicts — factor entries (INFOG(3)) and the memory of one factorization in core or out of
//!   core on the rank that needs most (INFOG(16) / INFOG(26)) — for the sweep's memory budget.
//!   Each numeric factorization is its own MUMPS instance, which analyses the pattern again at
//!   its first factorization and refactors with new values after that.
//! - **Singularity**: null pivots are detected (ICNTL(24) = 1) and a factorization with one is
//!   refused as singular, as MUMPS's own numerically-singular status (INFOG(1) = −10); the
//!   sweep's probe solve checks every factorization as for the other backends. MUMPS reports
//!   no pivot ratio, so [`Factorization::pivot_ratio`] is NaN.
//! - **One call at a time**: MUMPS's out-of-core layer keeps its files in process-global C
//!   state (`mumps_io_basic.c`), and shared factorizations take their jobs in rank 0's order,
//!   so every call into MUMPS holds one lock; two sweep workers then take turns (MUMPS's own
//!   BLAS may use threads).
//! - **Errors**: a negative INFOG(1) becomes [`Error::Factor`] with MUMPS's code, INFOG(2) and
//!   what to change (memory, the out-of-core directory); no MUMPS output is printed
//!   (ICNTL(1..4)).
//! - **Files**: an instance deletes its out-of-core files when it is dropped (JOB = −2).
//! - **Automatic**: without a directory, an analysis whose in-core estimate of one
//!   factorization exceeds the memory budget keeps the factors in the temporary directory.

#[allow(
    non_camel_case_types,
    non_snake_case,
    non_upper_case_globals,
    dead_code,
    clippy::all
)]
mod sys {
    include!(concat!(env!("OUT_DIR"), "/mumps_bindings.rs"));
}

use super::backend::{
    Analysed, Backend, Factorization, Footprint, Storage, SymbolicFactorization, Values,
};
use super::pattern;
use crate::pencil::Pencil;
use crate::{Error, Result};
use faer::{c64, MatMut, Par};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

mod ranks;

pub use ranks::{dismiss, ranks, share};

/// The analysis: the 1-based lower pattern MUMPS reads, where the out-of-core factors go,
/// and what MUMPS's own analysis predicted.
struct Symbolic {
    n: i32,
    irn: Vec<i32>,
    jcn: Vec<i32>,
    out_of_core: Option<PathBuf>,
}

/// Analyses the pencil's pattern for MUMPS, with its factors in `storage.dir`, or in the
/// temporary directory when MUMPS's in-core estimate of one factorization exceeds
/// `storage.budget`.
///
/// # Errors
/// [`Error::InvalidSetting`] when N or the pattern exceeds MUMPS's 32-bit indices, or the
/// directory does not exist; [`Error::Factor`] when MUMPS's analysis fails.
pub(super) fn analyse(pencil: &Pencil, storage: Storage<'_>) -> Result<Analysed> {
    let out_of_core = storage.dir;
    let n = i32::try_from(pencil.n()).map_err(|_| {
        Error::InvalidSetting(format!(
            "backend mumps: N = {} exceeds MUMPS's 32-bit indices",
            pencil.n()
        ))
    })?;
    if let Some(dir) = out_of_core {
        if !dir.is_dir() {
            return Err(Error::InvalidSetting(format!(
                "out-of-core directory {}: not an existing directory; create it (the factors are written there)",
                dir.display()
            )));
        }
    }
    let lower = pattern::lower(pencil);
    let (mut irn, mut jcn) = (Vec::new(), Vec::new());
    for j in 0..pencil.n() {
        for &i in lower.row_idx_of_col_raw(j) {
            irn.push(i as i32 + 1);
            jcn.push(j as i32 + 1);
        }
    }
    let mut symbolic = Symbolic {
        n,
        irn,
        jcn,
        out_of_core: out_of_core.map(Path::to_path_buf),
    };
    // MUMPS's analysis on a scratch instance: what one factorization will take. INFOG(3):
    // entries of the factors (all ranks); INFOG(16) / INFOG(26): MB of one factorization in
    // core / out of core on the rank that needs most (negative: millions)
    let (entries, in_core, on_disk) = {
        let mut scratch = Instance::new(symbolic.out_of_core.as_deref())?;
        scratch.set_pattern(&symbolic);
        scratch.run(1, "analysis")?;
        let infog = |k: usize| scaled(scratch.id.infog[k - 1], 1);
        (infog(3), infog(16) * 1_000_000, infog(26) * 1_000_000)
    };
    if symbolic.out_of_core.is_none() && in_core > storage.budget {
        symbolic.out_of_core = Some(std::env::temp_dir());
    }
    let footprint = Footprint {
        factor_nnz: entries,
        bytes: if symbolic.out_of_core.is_some() {
            on_disk
        } else {
            in_core
        },
    };
    Ok((Box::new(symbolic), footprint))
}

/// A MUMPS count: k·unit when k ≥ 0, |k| millions when negative (MUMPS's convention for
/// counts beyond 32 bits).
fn scaled(k: i32, unit: usize) -> usize {
    if k >= 0 {
        k as usize * unit
    } else {
        k.unsigned_abs() as usize * 1_000_000
    }
}

impl SymbolicFactorization for Symbolic {
    fn backend(&self) -> Backend {
        Backend::Mumps
    }

    fn out_of_core(&self) -> bool {
        self.out_of_core.is_some()
    }

    fn ranks(&self) -> usize {
        ranks()
    }

    fn numeric(&self, _pencil: &Pencil) -> Result<Box<dyn Factorization + '_>> {
        let mut instance = Instance::new(self.out_of_core.as_deref())?;
        instance.set_pattern(self);
        Ok(Box::new(Numeric {
            symbolic: self,
            instance,
            values: Vec::new(),
            rhs: Vec::new(),
            analysed: false,
            factored: false,
        }))
    }
}

/// One MUMPS instance: the C structure, boxed (MUMPS keeps its address between calls). On
/// rank 0 (or a process of its own) it points to a [`Symbolic`] pattern that outlives it
/// ([`Instance::set_pattern`]); on the other ranks of shared factorizations it holds no
/// matrix (the `serve` loop).
struct Instance {
    id: Box<sys::ZMUMPS_STRUC_C>,
    /// Rank 0's number of this instance, announced with each of its jobs when the
    /// factorizations are shared; `None` on the other ranks (they only follow).
    announced: Option<u64>,
    /// The out-of-core directory as a C string (MUMPS copies it at each call).
    ooc_dir: Option<Vec<u8>>,
    /// JOB = −1 succeeded: MUMPS holds memory (and files) that JOB = −2 releases.
    initialized: bool,
}

// SAFETY: the structure's pointers refer to a pattern that outlives the instance (shared,
// read-only), to its owner's buffers, or to MUMPS's internal memory, which is used by one
// call at a time under the lock; nothing is tied to the creating thread.
unsafe impl Send for Instance {}

/// Numbers of the instances rank 0 creates.
static NEXT_INSTANCE: AtomicU64 = AtomicU64::new(0);

impl Instance {
    /// A new MUMPS instance (JOB = −1) with sparsemor's controls, its factors in `dir` (out
    /// of core) or in memory; on rank 0 of shared factorizations every rank makes its part.
    fn new(dir: Option<&Path>) -> Result<Self> {
        let ooc_dir = match dir {
            Some(dir) => {
                let bytes = dir.as_os_str().as_encoded_bytes().to_vec();
                if bytes.len() >= 255 || bytes.contains(&0) {
                    return Err(Error::InvalidSetting(format!(
                        "out-of-core directory {}: MUMPS takes paths of at most 254 bytes",
                        dir.display()
                    )));
                }
                Some(bytes)
            }
            None => None,
        };
        let number = ranks::is_host().then(|| NEXT_INSTANCE.fetch_add(1, Ordering::Relaxed));
        Self::start(number, ooc_dir)
    }

    /// JOB = −1 and the controls; `announced` as in [`Instance::announced`].
    fn start(announced: Option<u64>, ooc_dir: Option<Vec<u8>>) -> Result<Self> {
        // SAFETY: ZMUMPS_STRUC_C is a plain C structure of integers, reals, pointers and
        // character arrays; all zeros is the state MUMPS expects before JOB = −1.
        let id: Box<sys::ZMUMPS_STRUC_C> = Box::new(unsafe { std::mem::zeroed() });
        let mut inst = Instance {
            id,
            announced,
            ooc_dir,
            initialized: false,
        };
        inst.id.par = 1;
        inst.id.sym = 2;
        inst.id.comm_fortran = ranks::communicator()?;
        inst.run(-1, "initialization")?;
        inst.initialized = true;
        let icntl = &mut inst.id.icntl;
        // no output streams: library code never prints
        icntl[0] = -1;
        icntl[1] = -1;
        icntl[2] = -1;
        icntl[3] = 0;
        // METIS ordering on the pattern alone (no value-based matching or compression, so the
        // scratch analysis needs no values), null-pivot detection, out of core when asked
        icntl[5] = 0;
        icntl[6] = 5;
        icntl[11] = 1;
        icntl[23] = 1;
        icntl[21] = i32::from(inst.ooc_dir.is_some());
        Ok(inst)
    }

    /// Points the instance to the pattern of `s` (rank 0; the pattern must outlive it).
    fn set_pattern(&mut self, s: &Symbolic) {
        self.id.n = s.n;
        self.id.nnz = s.irn.len() as i64;
        self.id.nz = i32::try_from(s.irn.len()).unwrap_or(0);
        // MUMPS reads the pattern through mutable pointers but does not write it
        self.id.irn = s.irn.as_ptr().cast_mut();
        self.id.jcn = s.jcn.as_ptr().cast_mut();
    }

    /// Runs JOB = `job` ("what" names it in an error), announced to the other ranks first
    /// when the factorizations are shared.
    fn run(&mut self, job: i32, what: &str) -> Result<()> {
        if let Some(dir) = &self.ooc_dir {
            let dst = &mut self.id.ooc_tmpdir;
            dst.fill(0);
            for (d, &b) in dst.iter_mut().zip(dir) {
                *d = b as _;
            }
        }
        self.id.job = job;
        {
            let _one = ranks::lock();
            if let Some(instance) = self.announced {
                let dir = match (job, &self.ooc_dir) {
                    (-1, Some(dir)) => dir.clone(),
                    _ => Vec::new(),
                };
                ranks::announce(ranks::Job { instance, job, dir });
            }
            // SAFETY: `id` was zeroed and initialized by JOB = −1 before any other job; its
            // pointers (pattern, values, right-hand side) are valid for the lengths set
            // (n, nnz, nrhs·lrhs) during the call; one call at a time (the lock).
            unsafe { sys::zmumps_c(&mut *self.id) };
        }
        let (info1, info2) = (self.id.infog[0], self.id.infog[1]);
        if info1 < 0 {
            return Err(Error::Factor(describe(what, info1, info2)));
        }
        Ok(())
    }
}

impl Drop for Instance {
    fn drop(&mut self) {
        // JOB = −2 frees MUMPS's memory and deletes the out-of-core files; the pointers into
        // buffers that may be gone are cleared first (MUMPS does not read them here)
        if !self.initialized {
            return;
        }
        self.id.a = std::ptr::null_mut();
        self.id.rhs = std::ptr::null_mut();
        let _ = self.run(-2, "termination");
    }
}

/// The other ranks' side of shared factorizations (ranks ≥ 1 after [`share`]): makes, runs
/// and ends their part of each MUMPS instance as rank 0 announces it, until rank 0
/// [`dismiss`]es them; returns rank 0's exit code. A failed job needs nothing here: MUMPS's
/// status is global, rank 0 sees it and reports it.
///
/// # Errors
/// [`Error::Distributed`] when a job names an instance this rank does not have (its part
/// could not be made); the MPI launcher then ends the job.
pub fn serve() -> Result<i32> {
    let mut instances: HashMap<u64, Instance> = HashMap::new();
    loop {
        let job = match ranks::next() {
            Ok(job) => job,
            Err(code) => return Ok(code),
        };
        if job.job == -1 {
            let dir = (!job.dir.is_empty()).then_some(job.dir);
            if let Ok(inst) = Instance::start(None, dir) {
                instances.insert(job.instance, inst);
            }
            continue;
        }
        if job.job == -2 {
            // the drop runs JOB = −2
            if instances.remove(&job.instance).is_some() {
                continue;
            }
        } else if let Some(inst) = instances.get_mut(&job.instance) {
            let _ = inst.run(job.job, "");
            continue;
        }
        return Err(Error::Distributed(format!(
            "MUMPS over ranks: rank 0 announced job {} of instance {}, which this rank could not make",
            job.job, job.instance
        )));
    }
}

/// MUMPS's error code `info1` (INFOG(1)) with INFOG(2), in words, with what to change.
fn describe(what: &str, info1: i32, info2: i32) -> String {
    let why = match info1 {
        -8 | -9 | -14 | -15 | -17 | -20 => {
            "its work arrays were too small; MUMPS sizes them from its analysis, so this pencil \
             needs more memory than estimated"
        }
        -13 => "a memory allocation failed; lower --memory-gb's share or use --out-of-core DIR",
        -10 => "the matrix is numerically singular (a frequency at an undamped eigenfrequency?)",
        -90..=-70 => {
            "out-of-core file I/O failed: is the directory writable, with room for the factors?"
        }
        _ => "see the MUMPS user guide, INFO(1)",
    };
    format!("MUMPS {what} failed: INFOG(1) = {info1}, INFOG(2) = {info2}: {why}")
}

/// One numeric factorization: its instance, the values it factors (MUMPS reads them at
/// each factorization) and where it is in its life.
struct Numeric<'a> {
    symbolic: &'a Symbolic,
    instance: Instance,
    values: Vec<sys::mumps_double_complex>,
    /// The right-hand sides, column after column (MUMPS solves them in place).
    rhs: Vec<sys::mumps_double_complex>,
    analysed: bool,
    factored: bool,
}

impl Factorization for Numeric<'_> {
    fn factor(&mut self, a: &Values<'_>, freq_hz: f64, _: Par) -> Result<()> {
        self.factored = false;
        let nnz = self.symbolic.irn.len();
        if self.values.len() != nnz {
            self.values
                .try_reserve_exact(nnz)
                .map_err(|_| Error::Factor(format!("cannot allocate {nnz} matrix entries")))?;
            self.values
                .resize(nnz, sys::mumps_double_complex { r: 0.0, i: 0.0 });
        }
        for (p, v) in self.values.iter_mut().enumerate() {
            let e = a.entry(p);
            *v = sys::mumps_double_complex { r: e.re, i: e.im };
        }
        self.instance.id.a = self.values.as_mut_ptr();
        let job = if self.analysed { 2 } else { 4 };
        match self.instance.run(job, "factorization") {
            Ok(()) => {}
            Err(e) if self.instance.id.infog[0] == -10 => {
                return Err(Error::Singular {
                    freq_hz,
                    detail: format!("{e}"),
                })
            }
            Err(e) => return Err(e),
        }
        self.analysed = true;
        // INFOG(28): null pivots found (ICNTL(24) = 1)
        let null_pivots = self.instance.id.infog[27];
        if null_pivots > 0 {
            return Err(Error::Singular {
                freq_hz,
                detail: format!("MUMPS found {null_pivots} null pivot(s) (INFOG(28))"),
            });
        }
        self.factored = true;
        Ok(())
    }

    fn solve(&mut self, mut rhs: MatMut<'_, c64>, _: Par) {
        assert!(self.factored, "solve only after a successful factorization");
        let (n, k) = (rhs.nrows(), rhs.ncols());
        let b = &mut self.rhs;
        b.clear();
        b.extend(
            (0..k)
                .flat_map(|c| (0..n).map(move |i| (i, c)))
                .map(|(i, c)| sys::mumps_double_complex {
                    r: rhs[(i, c)].re,
                    i: rhs[(i, c)].im,
                }),
        );
        let id = &mut self.instance.id;
        id.rhs = b.as_mut_ptr();
        id.nrhs = k as i32;
        id.lrhs = n as i32;
        // a solve of a successful factorization fails only on out-of-core I/O; the probe
        // column then is not solved either and the sweep refuses the frequency
        if self.instance.run(3, "solve").is_err() {
            self.rhs.iter_mut().for_each(|v| {
                *v = sys::mumps_double_complex {
                    r: f64::NAN,
                    i: f64::NAN,
                }
            });
        }
        self.instance.id.rhs = std::ptr::null_mut();
        for c in 0..k {
            for i in 0..n {
                let v = self.rhs[c * n + i];
                rhs[(i, c)] = c64::new(v.r, v.i);
            }
        }
    }

    fn pivot_ratio(&self) -> f64 {
        f64::NAN
    }

    fn reads_arrays(&self) -> bool {
        // the values are copied into MUMPS's layout from the pencil directly
        false
    }
}
