//! Support for sparsemor's fuzz targets (issue 13): a counting allocator that measures the
//! peak of live heap bytes during one call, the stated allocation bounds, a small archive
//! format that turns one fuzz input into a directory of files, and a peek at a Matrix Market
//! size line (the "declared size" the bounds may depend on).
//!
//! Allocation bound, checked by every target after every call:
//!
//! ```text
//! peak live bytes ≤ fixed_bytes() + BYTES_PER_INPUT_BYTE · input bytes + declared
//! ```
//!
//! [`fixed_bytes`] holds what does not depend on the input: faer's dense kernels
//! (private-gemm-x86) keep a page pool of twice the L3 cache per thread, reserved (not touched)
//! on a thread's first product and kept ([`page_pool_bytes`]; found by the `rom_dir` target on
//! its first seed, the definiteness check of Mr: 64 MiB on a 32 MiB-L3 machine, and 960 MiB on
//! this project's 480 MiB-L3 machine, where the `ffi` smoke run tripped over the old constant
//! 64 MiB), plus 2 MiB for I/O buffers (the importers' format sniffing reads up to 1 MiB).
//!
//! where `declared` is what the format lets a file ask for without holding the data:
//! `8·(ncols + 1)` per coordinate file (the CSC column pointers) and `8·nrows·ncols` per file
//! read as a dense matrix (ROM matrices). A target returns early, without calling the library,
//! when the declared term alone passes [`DECLARED_MAX`]: a 20-byte file may legitimately
//! declare 10⁹ columns, and what it costs is stated, not fuzzed.

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

/// The stated multiple of the input size (uncompressed) that one call may hold live at once.
pub const BYTES_PER_INPUT_BYTE: usize = 256;

/// The page pool faer's dense kernels reserve per thread: twice the L3 cache, as
/// private-gemm-x86 sizes it (read from Linux's sysfs; 32 MiB assumed where it is not there).
pub fn page_pool_bytes() -> usize {
    static BYTES: std::sync::OnceLock<usize> = std::sync::OnceLock::new();
    *BYTES.get_or_init(|| {
        let l3 = std::fs::read_to_string("/sys/devices/system/cpu/cpu0/cache/index3/size")
            .ok()
            .and_then(|s| {
                let s = s.trim();
                let (digits, unit) =
                    s.split_at(s.find(|c: char| !c.is_ascii_digit()).unwrap_or(s.len()));
                let k = match unit {
                    "K" => 1 << 10,
                    "M" => 1 << 20,
                    "" => 1,
                    _ => return None,
                };
                digits.parse::<usize>().ok().map(|d| d * k)
            })
            .unwrap_or(32 << 20);
        2 * l3
    })
}

/// The input-independent part of the bound: one thread's page pool and 2 MiB (module doc).
pub fn fixed_bytes() -> usize {
    page_pool_bytes() + (2 << 20)
}

/// Inputs whose declared sizes ask for more than this are skipped (see the module doc).
pub const DECLARED_MAX: usize = 256 << 20;

struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
/// [`fixed_bytes`] once [`measured`] has run (0 before), for the allocator's hook.
static FIXED: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

// SAFETY: forwards to the system allocator; the counters do not affect the allocations.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc(layout) };
        if !p.is_null() {
            grow(layout.size());
        }
        p
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { System.alloc_zeroed(layout) };
        if !p.is_null() {
            grow(layout.size());
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) };
        LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = unsafe { System.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            LIVE.fetch_sub(layout.size(), Ordering::Relaxed);
            grow(new_size);
        }
        p
    }
}

fn grow(size: usize) {
    let live = LIVE.fetch_add(size, Ordering::Relaxed) + size;
    // the allocator must not compute it (that reads a file, which allocates)
    let fixed = FIXED.load(Ordering::Relaxed);
    if fixed > 0 && live >= fixed && live - size < fixed {
        large(size);
    }
    PEAK.fetch_max(live, Ordering::Relaxed);
}

/// Called when the live heap crosses [`fixed_bytes`]: a place for a debugger breakpoint
/// (`nm` the binary for `sparsemor_fuzz5large`) when a target reports a bound exceeded.
#[inline(never)]
pub fn large(size: usize) {
    std::hint::black_box(size);
}

#[global_allocator]
static ALLOC: Counting = Counting;

/// Runs `f` and returns its result with the peak of live heap bytes above the level at entry.
pub fn measured<T>(f: impl FnOnce() -> T) -> (T, usize) {
    FIXED.store(fixed_bytes(), Ordering::Relaxed);
    let base = LIVE.load(Ordering::Relaxed);
    PEAK.store(base, Ordering::Relaxed);
    let out = f();
    (out, PEAK.load(Ordering::Relaxed).saturating_sub(base))
}

/// Panics (a fuzz finding) when `peak` exceeds the stated bound for `input_len` bytes of
/// input plus `declared` bytes the format lets the input ask for.
pub fn check_bound(what: &str, peak: usize, input_len: usize, declared: usize) {
    let fixed = fixed_bytes();
    let bound = fixed + BYTES_PER_INPUT_BYTE * input_len + declared;
    assert!(
        peak <= bound,
        "{what}: peak heap {peak} B > bound {bound} B ({fixed} fixed + {BYTES_PER_INPUT_BYTE} x {input_len} input bytes + {declared} declared)"
    );
}

/// The dimensions on the size line of Matrix Market text (`None` if there is no such line).
/// Independent of the library's reader: the banner, then the first line that is neither blank
/// nor a comment, its first two tokens.
pub fn mtx_dims(text: &[u8]) -> Option<(u128, u128)> {
    let mut lines = text.split(|&b| b == b'\n');
    lines.next()?;
    for line in lines {
        let s = String::from_utf8_lossy(line);
        let t: Vec<&str> = s.split_ascii_whitespace().collect();
        match t.first() {
            None => continue,
            Some(w) if w.starts_with('%') => continue,
            Some(_) => {
                let r = t.first()?.parse().ok()?;
                let c = t.get(1)?.parse().ok()?;
                return Some((r, c));
            }
        }
    }
    None
}

/// Decompresses gzip data as far as it goes (the uncompressed size that bounds a reader's
/// memory), or returns `data` when it is not gzip.
pub fn plain(data: &[u8]) -> Vec<u8> {
    use std::io::Read;
    if !data.starts_with(&[0x1f, 0x8b]) {
        return data.to_vec();
    }
    let mut out = Vec::new();
    let mut dec = flate2::read::MultiGzDecoder::new(data);
    let mut buf = [0u8; 8192];
    while let Ok(k) = dec.read(&mut buf) {
        if k == 0 {
            break;
        }
        out.extend_from_slice(&buf[..k]);
    }
    out
}

/// gzip-compresses `data`.
pub fn gzip(data: &[u8]) -> Vec<u8> {
    use std::io::Write;
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    e.write_all(data).expect("in-memory write");
    e.finish().expect("in-memory write")
}

/// The declared-size term of the bound for one Matrix Market file (see the module doc);
/// `dense` when the file is read as a dense matrix. Saturates on absurd sizes.
pub fn declared_bytes(text: &[u8], dense: bool) -> usize {
    let Some((r, c)) = mtx_dims(&plain(text)) else {
        return 0;
    };
    let bytes = if dense {
        r.saturating_mul(c).saturating_mul(8)
    } else {
        c.saturating_add(1).saturating_mul(8)
    };
    usize::try_from(bytes).unwrap_or(usize::MAX)
}

/// One fuzz input as a set of files: sections `=== NAME\n` + content, up to the next
/// `\n=== ` (or the end). Names outside `allowed` are dropped, so the fuzzer cannot write
/// outside the temporary directory. Returns the directory and the files written.
pub fn unpack(data: &[u8], allowed: &[&str]) -> (tempfile::TempDir, Vec<PathBuf>) {
    let dir = tempfile::tempdir().expect("temporary directory");
    let mut files = Vec::new();
    for section in split_sections(data) {
        let (head, body) = match section.iter().position(|&b| b == b'\n') {
            Some(k) => (&section[..k], &section[k + 1..]),
            None => (section, &[][..]),
        };
        let name = String::from_utf8_lossy(head).trim().to_string();
        if let Some(&ok) = allowed.iter().find(|&&a| a == name) {
            let path = dir.path().join(ok);
            if !files.contains(&path) {
                std::fs::write(&path, body).expect("write into the temporary directory");
                files.push(path);
            }
        }
    }
    (dir, files)
}

/// The sections of an archive, each without its `=== ` marker.
fn split_sections(data: &[u8]) -> Vec<&[u8]> {
    const MARK: &[u8] = b"=== ";
    let mut starts = Vec::new();
    if data.starts_with(MARK) {
        starts.push(MARK.len());
    }
    for k in 0..data.len().saturating_sub(MARK.len()) {
        if data[k] == b'\n' && data[k + 1..].starts_with(MARK) {
            starts.push(k + 1 + MARK.len());
        }
    }
    starts
        .iter()
        .enumerate()
        .map(|(i, &s)| {
            let end = starts
                .get(i + 1)
                .map_or(data.len(), |&e| e - MARK.len() - 1);
            &data[s..end.max(s)]
        })
        .collect()
}

/// The sum of the declared-size terms of the `.mtx` files among `files`.
pub fn declared_in(files: &[PathBuf], dense: bool) -> usize {
    files
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "mtx"))
        .filter_map(|p| std::fs::read(p).ok())
        .fold(0usize, |acc, t| {
            acc.saturating_add(declared_bytes(&t, dense))
        })
}

/// Total bytes of the files (uncompressed when gzip).
pub fn input_bytes(files: &[PathBuf]) -> usize {
    files
        .iter()
        .filter_map(|p| std::fs::read(p).ok())
        .map(|t| plain(&t).len())
        .sum()
}

/// Re-validates a matrix the reader accepted: every value finite, canonical CSC (rows
/// strictly increasing in each column, in range), a `symmetric` file exactly symmetric; and
/// the written file reads back bit-exactly.
pub fn revalidate(m: &sparsemor::io::matrix_market::MtxMatrix) {
    use sparsemor::io::matrix_market::{self as mm, MtxData, Symmetry};
    static DIR: std::sync::OnceLock<tempfile::TempDir> = std::sync::OnceLock::new();
    let path = DIR
        .get_or_init(|| tempfile::tempdir().expect("temporary directory"))
        .path()
        .join("back.mtx");
    match &m.data {
        MtxData::Sparse(a) => {
            for j in 0..a.ncols() {
                let rows = a.symbolic().row_idx_of_col_raw(j);
                assert!(
                    rows.windows(2).all(|w| w[0] < w[1]),
                    "column {j} not canonical"
                );
                assert!(rows.iter().all(|&i| i < a.nrows()), "row out of range");
                assert!(
                    a.val_of_col(j).iter().all(|v| v.is_finite()),
                    "non-finite in column {j}"
                );
            }
            if m.symmetry == Symmetry::Symmetric {
                let t = a.as_ref().transpose().to_col_major().expect("transpose");
                assert_eq!(
                    t.symbolic().col_ptr(),
                    a.symbolic().col_ptr(),
                    "not symmetric"
                );
                assert_eq!(
                    t.symbolic().row_idx(),
                    a.symbolic().row_idx(),
                    "not symmetric"
                );
                assert!(
                    t.val()
                        .iter()
                        .zip(a.val())
                        .all(|(x, y)| x.to_bits() == y.to_bits()),
                    "values not symmetric"
                );
            }
            mm::write_coordinate(&path, a.as_ref(), false).expect("write back");
            let b = mm::read_sparse(&path).expect("read back");
            assert_eq!(b.symbolic().col_ptr(), a.symbolic().col_ptr());
            assert_eq!(b.symbolic().row_idx(), a.symbolic().row_idx());
            assert!(b
                .val()
                .iter()
                .zip(a.val())
                .all(|(x, y)| x.to_bits() == y.to_bits()));
        }
        MtxData::Dense(a) => {
            assert!((0..a.ncols()).all(|j| (0..a.nrows()).all(|i| a[(i, j)].is_finite())));
            if a.nrows() * a.ncols() <= 1 << 16 {
                mm::write_array(&path, a.as_ref()).expect("write back");
                let b = mm::read_dense(&path).expect("read back");
                assert_eq!((b.nrows(), b.ncols()), (a.nrows(), a.ncols()));
                assert!((0..a.ncols())
                    .all(|j| (0..a.nrows()).all(|i| a[(i, j)].to_bits() == b[(i, j)].to_bits())));
            }
        }
    }
}
