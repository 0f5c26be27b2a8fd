//! The C ABI driven by structured input: `sparsemor_model_new` (M, K, D or Rayleigh, nodes),
//! `sparsemor_model_set_scene`, a sequence of `sparsemor_options_*` calls, then
//! `sparsemor_reduce_linefit` or `_serep` and the ROM queries. The harness honours the C
//! contract (every pointer/length pair it passes is a real buffer); everything inside the
//! buffers is hostile: CSC structure, values, DoF lists, frequencies, option values.
//!
//! Never `SPARSEMOR_STATUS_PANIC` (libfuzzer-sys aborts on any panic, caught or not); on
//! success the ROM re-validates: shapes n×n, n×p, q×n, every entry finite, Mr and Kr
//! symmetric to rounding, `rom_dofs` of length n and in range.
#![no_main]

use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use sparsemor_ffi::*;
use sparsemor_fuzz::{check_bound, measured, page_pool_bytes};
use std::ptr::{null, null_mut};

#[derive(Arbitrary, Debug)]
struct Input {
    n: u8,
    mass: Matrix,
    stiffness: Matrix,
    damping: Option<Matrix>,
    alpha: f64,
    beta: f64,
    nodes: Option<Vec<[f64; 3]>>,
    dofs_per_node: u8,
    inputs: Vec<u8>,
    outputs: Vec<u8>,
    band: Band,
    options: Vec<Opt>,
    serep: bool,
}

/// A matrix: raw CSC arrays (mostly rejected), or triplets the harness turns into valid CSC
/// structure with hostile values, or a spring chain (SPD for positive springs) scaled.
#[derive(Arbitrary, Debug)]
enum Matrix {
    Raw {
        col_ptr: Vec<u8>,
        row_idx: Vec<u8>,
        values: Vec<f64>,
        lower: bool,
    },
    Triplets(Vec<(u8, u8, f64)>, bool),
    /// `scale` = 10^(e % 25 − 12): finite and positive, from 1e-12 to 1e12.
    Chain {
        springs: Vec<u8>,
        scale: u8,
        ground: u8,
    },
}

/// Mostly plausible bands (so the reductions run), sometimes arbitrary values.
#[derive(Arbitrary, Debug)]
enum Band {
    Hz(u16, u16),
    Raw(f64, f64),
}

#[derive(Arbitrary, Debug)]
enum Opt {
    Threads(u8),
    Tolerance(f64),
    Limits(u8, u8),
    Interface(Vec<u16>),
    OutputsPlus(u8),
    RefFreqs(Vec<f64>),
    RefCount(u8),
    SerepModes(u8),
    SerepModeNumbers(Vec<u16>),
    SerepRetained(Vec<u16>),
    KeepBasis(bool),
}

/// Owned CSC arrays; `csc()` borrows them for one call.
struct Owned {
    n: usize,
    col_ptr: Vec<usize>,
    row_idx: Vec<usize>,
    values: Vec<f64>,
    storage: u32,
}

impl Owned {
    fn csc(&self) -> SparsemorCsc {
        SparsemorCsc {
            n: self.n,
            nnz: self.row_idx.len(),
            col_ptr: self.col_ptr.as_ptr(),
            row_idx: self.row_idx.as_ptr(),
            values: self.values.as_ptr(),
            storage: self.storage,
        }
    }
}

fn build(m: &Matrix, n: usize) -> Owned {
    match m {
        Matrix::Raw {
            col_ptr,
            row_idx,
            values,
            lower,
        } => {
            // The caller contract: col_ptr has n + 1 entries, row_idx and values nnz.
            let mut cp: Vec<usize> = col_ptr.iter().map(|&c| c as usize).collect();
            cp.resize(n + 1, 0);
            let nnz = cp[n].min(row_idx.len()).min(values.len());
            cp[n] = nnz;
            Owned {
                n,
                col_ptr: cp,
                row_idx: row_idx[..nnz].iter().map(|&r| r as usize).collect(),
                values: values[..nnz].to_vec(),
                storage: u32::from(*lower),
            }
        }
        Matrix::Triplets(t, lower) => {
            let mut cols = vec![Vec::<(usize, f64)>::new(); n];
            for &(i, j, v) in t {
                let (i, j) = (i as usize % n, j as usize % n);
                let (i, j) = if *lower { (i.max(j), i.min(j)) } else { (i, j) };
                if !cols[j].iter().any(|e| e.0 == i) {
                    cols[j].push((i, v));
                }
                if !*lower && !cols[i].iter().any(|e| e.0 == j) {
                    cols[i].push((j, v));
                }
            }
            from_cols(n, cols, u32::from(*lower))
        }
        Matrix::Chain {
            springs,
            scale,
            ground,
        } => {
            let scale = 10f64.powi(i32::from(*scale % 25) - 12);
            let k = |e: usize| f64::from(springs.get(e).copied().unwrap_or(1)) * scale;
            let mut cols = vec![Vec::<(usize, f64)>::new(); n];
            for (j, col) in cols.iter_mut().enumerate() {
                let left = if j > 0 {
                    k(j - 1)
                } else {
                    f64::from(*ground) * scale
                };
                let right = if j + 1 < n { k(j) } else { 0.0 };
                col.push((j, left + right));
                if j + 1 < n {
                    col.push((j + 1, -k(j)));
                }
            }
            from_cols(n, cols, SPARSEMOR_STORAGE_LOWER)
        }
    }
}

fn from_cols(n: usize, mut cols: Vec<Vec<(usize, f64)>>, storage: u32) -> Owned {
    let mut o = Owned {
        n,
        col_ptr: vec![0],
        row_idx: vec![],
        values: vec![],
        storage,
    };
    for c in &mut cols {
        c.sort_by_key(|e| e.0);
        for &(i, v) in c.iter() {
            o.row_idx.push(i);
            o.values.push(v);
        }
        o.col_ptr.push(o.row_idx.len());
    }
    o
}

fn dofs(v: &[u16]) -> Vec<usize> {
    v.iter().take(64).map(|&d| d as usize).collect()
}

/// Applies one option; only the status matters (it must not be PANIC).
unsafe fn apply(o: *mut SparsemorOptions, opt: &Opt) -> SparsemorStatus {
    unsafe {
        match opt {
            // two threads at most: the machine is shared, and one is bit-identical anyway
            Opt::Threads(t) => sparsemor_options_set_threads(o, 1 + (*t as usize % 2)),
            Opt::Tolerance(t) => sparsemor_options_set_tolerance(o, *t),
            // at most 12 factorizations and order 24 keep one execution short
            Opt::Limits(p, q) => {
                sparsemor_options_set_sampling_limits(o, *p as usize % 13, *q as usize % 25)
            }
            Opt::Interface(d) => {
                let d = dofs(d);
                sparsemor_options_set_interface(o, d.as_ptr(), d.len())
            }
            Opt::OutputsPlus(k) => sparsemor_options_set_interface_outputs_plus(o, *k as usize),
            Opt::RefFreqs(f) => {
                let f: Vec<f64> = f.iter().take(32).copied().collect();
                sparsemor_options_set_reference_frequencies(o, f.as_ptr(), f.len())
            }
            Opt::RefCount(z) => sparsemor_options_set_reference_count(o, *z as usize % 40),
            Opt::SerepModes(c) => sparsemor_options_set_serep_modes(o, *c as usize),
            Opt::SerepModeNumbers(d) => {
                let d = dofs(d);
                sparsemor_options_set_serep_mode_numbers(o, d.as_ptr(), d.len())
            }
            Opt::SerepRetained(d) => {
                let d = dofs(d);
                sparsemor_options_set_serep_retained(o, d.as_ptr(), d.len())
            }
            Opt::KeepBasis(k) => sparsemor_options_set_keep_basis(o, i32::from(*k)),
        }
    }
}

fn not_panic(s: SparsemorStatus, what: &str) -> SparsemorStatus {
    assert_ne!(
        s,
        SparsemorStatus::Panic,
        "{what} returned SPARSEMOR_STATUS_PANIC"
    );
    s
}

/// A ROM matrix through the length-query protocol.
unsafe fn matrix(rom: *const SparsemorRom, which: u32) -> (usize, usize, Vec<f64>) {
    let (mut r, mut c, mut len) = (0usize, 0usize, 0usize);
    unsafe {
        assert_eq!(
            sparsemor_rom_matrix_shape(rom, which, &mut r, &mut c),
            SparsemorStatus::Ok
        );
        let s = sparsemor_rom_copy_matrix(rom, which, null_mut(), 0, &mut len);
        assert!(matches!(
            s,
            SparsemorStatus::Ok | SparsemorStatus::BufferTooSmall
        ));
        assert_eq!(len, r * c);
        let mut buf = vec![f64::NAN; len];
        let s = sparsemor_rom_copy_matrix(rom, which, buf.as_mut_ptr(), len, &mut len);
        assert_eq!(s, SparsemorStatus::Ok);
        (r, c, buf)
    }
}

fn run(inp: &Input) {
    let n = 1 + inp.n as usize % 24;
    let (m, k) = (build(&inp.mass, n), build(&inp.stiffness, n));
    let d = inp.damping.as_ref().map(|d| build(d, n));
    let (mc, kc, dc) = (m.csc(), k.csc(), d.as_ref().map(Owned::csc));
    let nodes: Vec<f64> = inp
        .nodes
        .iter()
        .flatten()
        .take(24)
        .flatten()
        .copied()
        .collect();
    let mut model = null_mut();
    unsafe {
        let s = sparsemor_model_new(
            &mc,
            &kc,
            dc.as_ref().map_or(null(), |d| d as *const _),
            inp.alpha,
            inp.beta,
            if inp.nodes.is_some() {
                nodes.as_ptr()
            } else {
                null()
            },
            nodes.len() / 3,
            inp.dofs_per_node as usize % 8,
            &mut model,
        );
        if not_panic(s, "model_new") != SparsemorStatus::Ok {
            assert!(model.is_null());
            return;
        }
        // DoFs mostly in range: 0..n+2
        let near =
            |v: &[u8]| -> Vec<usize> { v.iter().take(32).map(|&d| d as usize % (n + 2)).collect() };
        let (i, o) = (near(&inp.inputs), near(&inp.outputs));
        let band = match inp.band {
            Band::Hz(a, b) => (f64::from(a), f64::from(b)),
            Band::Raw(a, b) => (a, b),
        };
        let s = sparsemor_model_set_scene(
            model,
            i.as_ptr(),
            i.len(),
            o.as_ptr(),
            o.len(),
            band.0,
            band.1,
        );
        let mut opts = null_mut();
        assert_eq!(sparsemor_options_new(&mut opts), SparsemorStatus::Ok);
        for opt in inp.options.iter().take(16) {
            not_panic(apply(opts, opt), "options_*");
        }
        if not_panic(s, "set_scene") == SparsemorStatus::Ok {
            reduce_and_check(model, opts, inp.serep, n);
        }
        sparsemor_options_free(opts);
        sparsemor_model_free(model);
    }
}

unsafe fn reduce_and_check(
    model: *mut SparsemorModel,
    opts: *mut SparsemorOptions,
    serep: bool,
    n_full: usize,
) {
    let mut rom = null_mut();
    unsafe {
        let s = if serep {
            sparsemor_reduce_serep(model, opts, None, null_mut(), &mut rom)
        } else {
            sparsemor_reduce_linefit(model, opts, None, null_mut(), &mut rom)
        };
        if not_panic(s, "reduce") != SparsemorStatus::Ok {
            assert!(rom.is_null());
            return;
        }
        let mut order = 0;
        assert_eq!(sparsemor_rom_order(rom, &mut order), SparsemorStatus::Ok);
        let (r, c, mr) = matrix(rom, SPARSEMOR_MATRIX_MR);
        assert_eq!((r, c), (order, order));
        let (_, _, kr) = matrix(rom, SPARSEMOR_MATRIX_KR);
        let (_, _, dr) = matrix(rom, SPARSEMOR_MATRIX_DR);
        let (br_r, _, br) = matrix(rom, SPARSEMOR_MATRIX_BR);
        let (_, cr_c, cr) = matrix(rom, SPARSEMOR_MATRIX_CR);
        assert_eq!((br_r, cr_c), (order, order));
        for (name, a) in [
            ("Mr", &mr),
            ("Kr", &kr),
            ("Dr", &dr),
            ("Br", &br),
            ("Cr", &cr),
        ] {
            assert!(
                a.iter().all(|v| v.is_finite()),
                "{name} has a non-finite entry"
            );
        }
        for (name, a) in [("Mr", &mr), ("Kr", &kr)] {
            let scale = a.iter().fold(0.0f64, |s, v| s.max(v.abs()));
            for i in 0..order {
                for j in 0..i {
                    let (x, y) = (a[i + j * order], a[j + i * order]);
                    assert!(
                        (x - y).abs() <= 1e-8 * scale,
                        "{name} not symmetric: {x} vs {y}"
                    );
                }
            }
        }
        let mut len = 0;
        let s = sparsemor_rom_dofs(rom, null_mut(), 0, &mut len);
        assert!(matches!(
            s,
            SparsemorStatus::Ok | SparsemorStatus::BufferTooSmall
        ));
        assert_eq!(len, order);
        let mut d = vec![usize::MAX; len];
        assert_eq!(
            sparsemor_rom_dofs(rom, d.as_mut_ptr(), len, &mut len),
            SparsemorStatus::Ok
        );
        assert!(d.iter().all(|&x| x < n_full), "ROM DoF out of range: {d:?}");
        let (mut mdef, mut kdef) = (
            SparsemorDefiniteness::default(),
            SparsemorDefiniteness::default(),
        );
        not_panic(
            sparsemor_rom_definiteness(rom, &mut mdef, &mut kdef),
            "rom_definiteness",
        );
        let f = [1.0f64, 10.0];
        let (mut e1, mut e2) = (0.0, 0.0);
        not_panic(
            sparsemor_rom_transfer_error(model, rom, f.as_ptr(), f.len(), &mut e1, &mut e2),
            "rom_transfer_error",
        );
        sparsemor_rom_free(rom);
    }
}

fuzz_target!(|inp: Input| {
    let ((), peak) = measured(|| run(&inp));
    // n ≤ 24 DoFs: every dense or sparse object is tiny; the fixed part bounds the call, plus
    // one page pool for each of the (up to two) rayon workers
    check_bound("C ABI", peak, 0, 2 * page_pool_bytes());
});
