//! Reductions (line-fitting, SEREP, Craig–Bampton) and the ROM handle with its queries.

use crate::error::{ffi_body, Failure, SparsemorStatus};
use crate::model::SparsemorModel;
use crate::options::SparsemorOptions;
use crate::pool::in_pool;
use crate::util::{check_ptr, copy_string, copy_to_buffer, obj, slice_in, write_opt, write_out};
use faer::{Mat, MatRef};
use sparsemor::eigen::EigenOptions;
use sparsemor::metrics::Reference;
use sparsemor::pool::resolve_threads;
use sparsemor::reduce::craig_bampton::CraigBamptonOptions;
use sparsemor::reduce::interface::Interface;
use sparsemor::reduce::serep::{ModeChoice, SerepOptions};
use sparsemor::reduce::{reduce, Context, Method, Reductor, Rom};
use sparsemor::scene::Scene;
use sparsemor::sparse::Csc;
use sparsemor::sweep::{no_progress, Progress, SweepOptions};
use std::ffi::{c_char, c_void};
use std::sync::Mutex;

/// `sparsemor_rom_copy_matrix`: reduced mass Mr (n×n).
pub const SPARSEMOR_MATRIX_MR: u32 = 0;
/// `sparsemor_rom_copy_matrix`: reduced damping Dr (n×n).
pub const SPARSEMOR_MATRIX_DR: u32 = 1;
/// `sparsemor_rom_copy_matrix`: reduced stiffness Kr (n×n).
pub const SPARSEMOR_MATRIX_KR: u32 = 2;
/// `sparsemor_rom_copy_matrix`: reduced input matrix Br = Vᵀ P B (n×p).
pub const SPARSEMOR_MATRIX_BR: u32 = 3;
/// `sparsemor_rom_copy_matrix`: reduced output matrix Cr = C V (q×n).
pub const SPARSEMOR_MATRIX_CR: u32 = 4;
/// `sparsemor_rom_copy_matrix`: the basis V (N×n), only when kept
/// (`sparsemor_options_set_keep_basis`). Always in the DoFs of the model as created: for a ROM
/// of a general scene (`sparsemor_model_set_scene_general`) it is T V, the coupled model's
/// basis mapped back by q = T z, so q ≈ V x_r is a state of the original model.
pub const SPARSEMOR_MATRIX_V: u32 = 5;
/// `sparsemor_rom_copy_matrix`: reduced structural damping K4r = VᵀHV (n×n, symmetric),
/// H = ηK + K₄, of a ROM whose model has structural damping
/// (`sparsemor_rom_has_structural_damping`): Hr(iω) = Cr(Kr + iK4r − ω²Mr + iωDr)⁻¹Br
/// (docs/design.md §3.12). A ROM without it has no K4r: `SPARSEMOR_STATUS_NOT_AVAILABLE`
/// (its Hr is the one without the iK4r term).
pub const SPARSEMOR_MATRIX_K4R: u32 = 6;

/// `sparsemor_rom_method`: line-fitting.
pub const SPARSEMOR_METHOD_LINEFIT: u32 = 0;
/// `sparsemor_rom_method`: SEREP.
pub const SPARSEMOR_METHOD_SEREP: u32 = 1;
/// `sparsemor_rom_method`: Craig–Bampton.
pub const SPARSEMOR_METHOD_CRAIG_BAMPTON: u32 = 2;

/// Progress callback: called after each finished frequency of a sweep with the number of
/// frequencies done, their total, the frequency just finished (Hz) and the caller's
/// `user_data`. Return 0 to continue, nonzero to cancel (the reduction then fails with
/// `SPARSEMOR_STATUS_CANCELLED` after the frequencies already being solved finish).
///
/// The callback may be called from worker threads other than the caller's, but never
/// concurrently (calls are serialized by the library) and never after the reduction
/// returned. It must not call back into the same model, options or ROM handles' mutating
/// functions, and must not unwind (C++ exceptions, longjmp) through the library.
pub type SparsemorProgressFn = Option<
    unsafe extern "C" fn(done: usize, total: usize, freq_hz: f64, user_data: *mut c_void) -> i32,
>;

/// Opaque reduced-model handle: Mr q̈ + Dr q̇ + Kr q = Br u, y = Cr q (in the frequency
/// domain with + iK4r q when the model has structural damping) and the diagnostics
/// of its construction. Made by `sparsemor_reduce_linefit`, `sparsemor_reduce_serep` or
/// `sparsemor_reduce_craig_bampton`,
/// released by `sparsemor_rom_free`. Independent of the model handle it came from.
pub struct SparsemorRom {
    pub(crate) rom: Rom,
    /// T V (N×n): the kept basis in the original DoFs, for a ROM of a coupled model (a general
    /// scene); `rom.basis` is then V in the coupled model's DoFs.
    pub(crate) basis_original: Option<Mat<f64>>,
    /// Whether the ROM is one of a coupled model (a general scene): its DoFs are then the
    /// coupled model's.
    pub(crate) coupled: bool,
}

/// The caller's callback, serialized by a mutex.
struct Callback {
    f: unsafe extern "C" fn(usize, usize, f64, *mut c_void) -> i32,
    user_data: *mut c_void,
    lock: Mutex<()>,
}

// SAFETY: the callback contract (documented on SparsemorProgressFn) allows calls from other
// threads; the mutex makes them sequential, so `user_data` is never used concurrently.
unsafe impl Sync for Callback {}

impl Callback {
    fn new(f: SparsemorProgressFn, user_data: *mut c_void) -> Option<Self> {
        f.map(|f| Callback {
            f,
            user_data,
            lock: Mutex::new(()),
        })
    }

    /// true = continue.
    fn call(&self, done: usize, total: usize, freq_hz: f64) -> bool {
        let _g = self.lock.lock().unwrap_or_else(|p| p.into_inner());
        // SAFETY: the caller supplied a valid function pointer and its user data.
        unsafe { (self.f)(done, total, freq_hz, self.user_data) == 0 }
    }
}

/// T V: a basis of the coupled model (N'×n) in the original DoFs (N×n), for q = T z.
fn to_original(t: &Csc, v: MatRef<'_, f64>) -> Mat<f64> {
    let mut out = Mat::<f64>::zeros(t.nrows(), v.ncols());
    for j in 0..t.ncols() {
        for (&i, &x) in t.row_idx_of_col_raw(j).iter().zip(t.val_of_col(j)) {
            for c in 0..v.ncols() {
                out[(i, c)] += x * v[(j, c)];
            }
        }
    }
    out
}

/// Stores a new ROM handle in `*rom_out`, reclaiming it if the write fails. `t`: q = T z of a
/// coupled model, to hand the basis out in the original DoFs.
unsafe fn emit(rom: Rom, t: Option<&Csc>, rom_out: *mut *mut SparsemorRom) -> Result<(), Failure> {
    let basis_original = match (t, &rom.basis) {
        (Some(t), Some(v)) => Some(to_original(t, v.as_ref())),
        _ => None,
    };
    let h = Box::into_raw(Box::new(SparsemorRom {
        rom,
        basis_original,
        coupled: t.is_some(),
    }));
    // SAFETY: forwarded contract; rom_out was checked writable at entry.
    if let Err(e) = unsafe { write_out(rom_out, h, "rom_out") } {
        drop(unsafe { Box::from_raw(h) });
        return Err(e);
    }
    Ok(())
}

/// Reduces the model by line-fitting (docs/design.md §3.3): V = Πᵀ[I; W] with W fitted by least
/// squares to the elastic responses at the reference frequencies, then Galerkin projection.
///
/// Uses the model's scene (inputs, outputs, band; `sparsemor_model_set_scene` first) and
/// from `options`: threads, interface, reference frequencies (explicit or a count), keep-basis
/// — or, with a tolerance (`sparsemor_options_set_tolerance`), the sampling loop of docs/design.md
/// §3.5 chooses the frequencies (not reaching the tolerance is not an error: see
/// `sparsemor_rom_sampling_converged` and the step log).
///
/// `progress` (may be NULL) is called after each reference frequency (see
/// `SparsemorProgressFn`). On success `*rom_out` receives a new ROM handle; on failure it is
/// set to NULL.
///
/// # Safety
/// `model`, `options` live handles; `progress` NULL or a valid function; `rom_out` writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_reduce_linefit(
    model: *const SparsemorModel,
    options: *const SparsemorOptions,
    progress: SparsemorProgressFn,
    user_data: *mut c_void,
    rom_out: *mut *mut SparsemorRom,
) -> SparsemorStatus {
    ffi_body!({
        unsafe { write_out(rom_out, std::ptr::null_mut(), "rom_out")? };
        let active = unsafe { obj(model, "model")? }.with_scene()?;
        let (m, scene) = (active.body, active.scene);
        let o = unsafe { obj(options, "options")? };
        let threads = resolve_threads(o.threads);
        let cb = Callback::new(progress, user_data);
        let report = |p: Progress| {
            cb.as_ref()
                .is_none_or(|c| c.call(p.done, p.total, p.freq_hz))
        };
        let opts = o.linefit(threads)?;
        let context = Context {
            progress: &report,
            ..Context::default()
        };
        let reductor = Reductor::LineFit(opts);
        let rom = in_pool(threads, || reduce(m, scene, &reductor, &context))??;
        unsafe { emit(rom, active.t, rom_out) }
    })
}

/// Reduces the model by SEREP (docs/design.md §3.6): V = U_c U_cr⁺ from c eigenvectors and their
/// rows at the retained DoFs, then Galerkin projection.
///
/// Uses the model's scene (the band sets the eigensolver's shift) and from `options`: the
/// modes (default: as many lowest deformation modes as retained DoFs), the retained DoFs
/// (default: the outputs), keep-basis, threads (the size of the call's thread pool, used by
/// the dense kernels; the sparse eigensolver itself is sequential).
///
/// The library's SEREP has no progress hook inside the eigensolver: `progress` (may be NULL)
/// is called twice, with (0, 1, 0.0) before the work starts and (1, 1, 0.0) when the ROM is
/// ready; returning nonzero cancels (`SPARSEMOR_STATUS_CANCELLED`, no ROM).
///
/// # Safety
/// As `sparsemor_reduce_linefit`.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_reduce_serep(
    model: *const SparsemorModel,
    options: *const SparsemorOptions,
    progress: SparsemorProgressFn,
    user_data: *mut c_void,
    rom_out: *mut *mut SparsemorRom,
) -> SparsemorStatus {
    ffi_body!({
        unsafe { write_out(rom_out, std::ptr::null_mut(), "rom_out")? };
        let active = unsafe { obj(model, "model")? }.with_scene()?;
        let (m, scene) = (active.body, active.scene);
        let o = unsafe { obj(options, "options")? };
        let retain = o
            .serep_retain
            .clone()
            .unwrap_or_else(|| scene.outputs.clone());
        let modes = o
            .serep_modes
            .clone()
            .unwrap_or(ModeChoice::LowestDeformation(retain.len()));
        let reductor = Reductor::Serep(SerepOptions {
            modes,
            retain: Some(retain),
            keep_basis: o.keep_basis,
            eigen: EigenOptions::for_band(scene.band_hz[1]),
        });
        let rom = bracketed(progress, user_data, resolve_threads(o.threads), || {
            reduce(m, scene, &reductor, &Context::default())
        })?;
        unsafe { emit(rom, active.t, rom_out) }
    })
}

/// Runs a reduction without a progress hook inside in the call's thread pool;
/// `progress` (may be NULL) is called with (0, 1, 0.0) before the work and (1, 1, 0.0) after
/// it, nonzero cancels (`SPARSEMOR_STATUS_CANCELLED`, no ROM).
fn bracketed(
    progress: SparsemorProgressFn,
    user_data: *mut c_void,
    threads: usize,
    work: impl FnOnce() -> sparsemor::Result<Rom> + Send,
) -> Result<Rom, Failure> {
    let cb = Callback::new(progress, user_data);
    let cancelled = || {
        Failure::new(
            SparsemorStatus::Cancelled,
            sparsemor::Error::Cancelled.to_string(),
        )
    };
    if cb.as_ref().is_some_and(|c| !c.call(0, 1, 0.0)) {
        return Err(cancelled());
    }
    let rom = in_pool(threads, work)??;
    if cb.as_ref().is_some_and(|c| !c.call(1, 1, 0.0)) {
        return Err(cancelled());
    }
    Ok(rom)
}

/// Reduces the model by Craig–Bampton (docs/design.md §3.8): V = [I 0; Ψ Φ_c] with the static
/// constraint modes Ψ = −K_ii⁻¹K_ib of the boundary DoFs and the c lowest fixed-interface
/// modes Φ_c, then Galerkin projection. The ROM's coordinates are the boundary DoFs
/// (`sparsemor_rom_dofs`) followed by the c modal amplitudes.
///
/// Uses the model's scene (the band sets the eigensolver's shift) and from `options`: c
/// (`sparsemor_options_set_craig_bampton_modes`, required), the boundary = the interface
/// (default: the outputs; a free body needs a boundary that holds its rigid motions, e.g.
/// `sparsemor_options_set_interface_outputs_plus(options, 1)` when the outputs lie on one
/// line), keep-basis, threads (the factorization of K_ii and its block solves).
///
/// Progress as for `sparsemor_reduce_serep`: (0, 1, 0.0) before, (1, 1, 0.0) after.
///
/// # Safety
/// As `sparsemor_reduce_linefit`.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_reduce_craig_bampton(
    model: *const SparsemorModel,
    options: *const SparsemorOptions,
    progress: SparsemorProgressFn,
    user_data: *mut c_void,
    rom_out: *mut *mut SparsemorRom,
) -> SparsemorStatus {
    ffi_body!({
        unsafe { write_out(rom_out, std::ptr::null_mut(), "rom_out")? };
        let active = unsafe { obj(model, "model")? }.with_scene()?;
        let (m, scene) = (active.body, active.scene);
        let o = unsafe { obj(options, "options")? };
        let c = o.cb_modes.ok_or_else(|| {
            Failure::arg(
                "Craig–Bampton needs the number of fixed-interface modes: call sparsemor_options_set_craig_bampton_modes",
            )
        })?;
        let threads = resolve_threads(o.threads);
        let interface = o.interface.clone().unwrap_or(Interface::OutputsPlus(0));
        let mut opts = CraigBamptonOptions::new(interface, c, scene.band_hz[1]);
        opts.keep_basis = o.keep_basis;
        opts.threads = threads;
        let reductor = Reductor::CraigBampton(opts);
        let rom = bracketed(progress, user_data, threads, || {
            reduce(m, scene, &reductor, &Context::default())
        })?;
        unsafe { emit(rom, active.t, rom_out) }
    })
}

/// Releases a ROM. NULL is a no-op.
///
/// # Safety
/// `rom` NULL or a live handle from a reduction.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_free(rom: *mut SparsemorRom) -> SparsemorStatus {
    ffi_body!({
        if !rom.is_null() {
            // SAFETY: a live handle from Box::into_raw (caller contract).
            drop(unsafe { Box::from_raw(rom) });
        }
        Ok(())
    })
}

/// How the ROM was built: `SPARSEMOR_METHOD_LINEFIT`, `SPARSEMOR_METHOD_SEREP` or
/// `SPARSEMOR_METHOD_CRAIG_BAMPTON`.
///
/// # Safety
/// `rom` a live handle; `method_out` writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_method(
    rom: *const SparsemorRom,
    method_out: *mut u32,
) -> SparsemorStatus {
    ffi_body!({
        let r = unsafe { obj(rom, "rom")? };
        let m = match r.rom.method() {
            Method::LineFit => SPARSEMOR_METHOD_LINEFIT,
            Method::Serep => SPARSEMOR_METHOD_SEREP,
            Method::CraigBampton => SPARSEMOR_METHOD_CRAIG_BAMPTON,
        };
        unsafe { write_out(method_out, m, "method_out") }
    })
}

/// Order n of the ROM (size of Mr, Dr, Kr).
///
/// # Safety
/// `rom` a live handle; `order_out` writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_order(
    rom: *const SparsemorRom,
    order_out: *mut usize,
) -> SparsemorStatus {
    ffi_body!({
        let r = unsafe { obj(rom, "rom")? };
        unsafe { write_out(order_out, r.rom.order(), "order_out") }
    })
}

/// Number of inputs p (columns of Br).
///
/// # Safety
/// `rom` a live handle; `n_out` writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_n_inputs(
    rom: *const SparsemorRom,
    n_out: *mut usize,
) -> SparsemorStatus {
    ffi_body!({
        let r = unsafe { obj(rom, "rom")? };
        unsafe { write_out(n_out, r.rom.br.ncols(), "n_out") }
    })
}

/// Number of outputs q (rows of Cr).
///
/// # Safety
/// `rom` a live handle; `n_out` writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_n_outputs(
    rom: *const SparsemorRom,
    n_out: *mut usize,
) -> SparsemorStatus {
    ffi_body!({
        let r = unsafe { obj(rom, "rom")? };
        unsafe { write_out(n_out, r.rom.cr.nrows(), "n_out") }
    })
}

fn matrix<'a>(r: &'a SparsemorRom, which: u32) -> Result<(MatRef<'a, f64>, &'static str), Failure> {
    let rom = &r.rom;
    Ok(match which {
        SPARSEMOR_MATRIX_MR => (rom.mr.as_ref(), "Mr"),
        SPARSEMOR_MATRIX_DR => (rom.dr.as_ref(), "Dr"),
        SPARSEMOR_MATRIX_KR => (rom.kr.as_ref(), "Kr"),
        SPARSEMOR_MATRIX_BR => (rom.br.as_ref(), "Br"),
        SPARSEMOR_MATRIX_CR => (rom.cr.as_ref(), "Cr"),
        SPARSEMOR_MATRIX_V => match r.basis_original.as_ref().or(rom.basis.as_ref()) {
            Some(v) => (v.as_ref(), "V"),
            None => {
                return Err(Failure::new(
                    SparsemorStatus::NotAvailable,
                    "V was not kept: call sparsemor_options_set_keep_basis(options, 1) before the reduction",
                ))
            }
        },
        SPARSEMOR_MATRIX_K4R => match rom.k4r.as_ref() {
            Some(k4r) => (k4r.as_ref(), "K4r"),
            None => {
                return Err(Failure::new(
                    SparsemorStatus::NotAvailable,
                    "K4r: the ROM has no structural damping (its model had eta = 0 and no K4, so \
                     its transfer function has no iK4r term): ask \
                     sparsemor_rom_has_structural_damping first, or give the model structural \
                     damping (sparsemor_model_set_structural_damping) before the reduction",
                ))
            }
        },
        w => {
            return Err(Failure::arg(format!(
                "matrix id {w}: use SPARSEMOR_MATRIX_MR, _DR, _KR, _BR, _CR, _V or _K4R (0..6)"
            )))
        }
    })
}

/// Shape of a ROM matrix (`SPARSEMOR_MATRIX_*`): Mr, Dr, Kr, K4r n×n; Br n×p; Cr q×n; V
/// N×n. `rows_out`, `cols_out` may each be NULL. V without keep-basis and K4r of a ROM without
/// structural damping: `SPARSEMOR_STATUS_NOT_AVAILABLE`.
///
/// # Safety
/// `rom` a live handle; non-NULL outs writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_matrix_shape(
    rom: *const SparsemorRom,
    which: u32,
    rows_out: *mut usize,
    cols_out: *mut usize,
) -> SparsemorStatus {
    ffi_body!({
        let (m, _) = matrix(unsafe { obj(rom, "rom")? }, which)?;
        unsafe { write_opt(rows_out, m.nrows(), "rows_out")? };
        unsafe { write_opt(cols_out, m.ncols(), "cols_out") }
    })
}

/// Copies a ROM matrix (`SPARSEMOR_MATRIX_*`) in column-major order (entry (i, j) at
/// `buf[i + j·rows]`) into the caller's `buf` of `buf_len` doubles.
///
/// `*required_len` (when not NULL) receives rows·cols. `buf == NULL && buf_len == 0` only
/// queries that length. A shorter buffer fails with `SPARSEMOR_STATUS_BUFFER_TOO_SMALL` and
/// leaves `buf` untouched. V without keep-basis and K4r of a ROM without structural damping:
/// `SPARSEMOR_STATUS_NOT_AVAILABLE`.
///
/// # Safety
/// `rom` a live handle; `buf` NULL or valid for `buf_len` doubles; `required_len` NULL or
/// writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_copy_matrix(
    rom: *const SparsemorRom,
    which: u32,
    buf: *mut f64,
    buf_len: usize,
    required_len: *mut usize,
) -> SparsemorStatus {
    ffi_body!({
        let (m, name) = matrix(unsafe { obj(rom, "rom")? }, which)?;
        let (rows, cols) = (m.nrows(), m.ncols());
        let need = rows * cols;
        unsafe { write_opt(required_len, need, "required_len")? };
        if buf.is_null() && buf_len == 0 {
            return Ok(());
        }
        if buf_len < need {
            return Err(Failure::new(
                SparsemorStatus::BufferTooSmall,
                format!(
                    "{name} is {rows}×{cols}: buffer holds {buf_len} doubles but {need} are needed"
                ),
            ));
        }
        check_ptr(buf.cast_const(), buf_len, "buf")?;
        let dst = buf;
        for j in 0..cols {
            for i in 0..rows {
                // SAFETY: i + j·rows < need <= buf_len; buf valid for writes (caller contract).
                unsafe { dst.add(i + j * rows).write(m[(i, j)]) };
            }
        }
        Ok(())
    })
}

/// Whether the ROM has structural damping (`*has_out`, 0/1): a reduced K4r = VᵀHV,
/// H = ηK + K₄, and the transfer function Hr(iω) = Cr(Kr + iK4r − ω²Mr + iωDr)⁻¹Br
/// (docs/design.md §3.12). When 1, `SPARSEMOR_MATRIX_K4R` copies K4r.
///
/// # Safety
/// `rom` a live handle; `has_out` writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_has_structural_damping(
    rom: *const SparsemorRom,
    has_out: *mut i32,
) -> SparsemorStatus {
    ffi_body!({
        let r = unsafe { obj(rom, "rom")? };
        unsafe { write_out(has_out, i32::from(r.rom.k4r.is_some()), "has_out") }
    })
}

/// The full-model DoF of each physical ROM coordinate (line-fitting interface, SEREP retained
/// DoFs, Craig–Bampton boundary DoFs — its modal coordinates follow them and have no DoF),
/// in ROM order, copied into `buf` (same length protocol as `sparsemor_rom_copy_matrix`).
/// For a ROM of a general scene these are DoFs of the coupled model (a remote point's DoF,
/// a row of C, ...): `sparsemor_model_coordinate` on the model handle names each.
///
/// # Safety
/// `rom` a live handle; `buf` NULL or valid for `buf_len` values; `required_len` NULL or
/// writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_dofs(
    rom: *const SparsemorRom,
    buf: *mut usize,
    buf_len: usize,
    required_len: *mut usize,
) -> SparsemorStatus {
    ffi_body!({
        let r = unsafe { obj(rom, "rom")? };
        unsafe { copy_to_buffer(&r.rom.dofs, buf, buf_len, required_len, "ROM DoFs") }
    })
}

/// The reference frequencies (Hz) a line-fitting ROM was fitted at (none for SEREP),
/// copied into `buf` (same length protocol as `sparsemor_rom_copy_matrix`).
///
/// # Safety
/// As `sparsemor_rom_dofs`.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_reference_frequencies(
    rom: *const SparsemorRom,
    buf: *mut f64,
    buf_len: usize,
    required_len: *mut usize,
) -> SparsemorStatus {
    ffi_body!({
        let r = unsafe { obj(rom, "rom")? };
        unsafe {
            copy_to_buffer(
                r.rom.ref_freqs_hz(),
                buf,
                buf_len,
                required_len,
                "reference frequencies",
            )
        }
    })
}

/// Numerics of the line-fitting least-squares fit (docs/design.md §3.3).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SparsemorFitReport {
    /// cond(T_oᵀ) before column equilibration.
    pub cond_raw: f64,
    /// cond(T_oᵀ) after column equilibration (what the rank decision uses).
    pub cond_equilibrated: f64,
    /// Numerical rank of T_oᵀ.
    pub rank: usize,
    /// 1 when singular values were truncated (rank < n), else 0.
    pub truncated: i32,
    /// Max over non-interface DoFs of the relative fit residual (eq. 22).
    pub residual_max: f64,
    /// Mean of the relative fit residual.
    pub residual_mean: f64,
    /// DoF with the largest fit residual: the best candidate to add to the interface.
    pub residual_argmax_dof: usize,
    /// Rows of T_oᵀ (2·p·z).
    pub rows: usize,
}

/// The fit diagnostics of a line-fitting ROM; `SPARSEMOR_STATUS_NOT_AVAILABLE` for SEREP.
///
/// # Safety
/// `rom` a live handle; `report_out` writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_fit_report(
    rom: *const SparsemorRom,
    report_out: *mut SparsemorFitReport,
) -> SparsemorStatus {
    ffi_body!({
        let r = unsafe { obj(rom, "rom")? };
        let f = r.rom.fit().ok_or_else(|| {
            Failure::new(
                SparsemorStatus::NotAvailable,
                "fit diagnostics exist only for line-fitting ROMs",
            )
        })?;
        let rep = SparsemorFitReport {
            cond_raw: f.cond_raw,
            cond_equilibrated: f.cond_equilibrated,
            rank: f.rank,
            truncated: i32::from(f.truncated),
            residual_max: f.residual_max,
            residual_mean: f.residual_mean,
            residual_argmax_dof: f.residual_argmax_dof,
            rows: f.rows,
        };
        unsafe { write_out(report_out, rep, "report_out") }
    })
}

/// cond(U_cr) of a SEREP ROM (the conditioning of the retained rows of the modes);
/// `SPARSEMOR_STATUS_NOT_AVAILABLE` for line-fitting.
///
/// # Safety
/// `rom` a live handle; `cond_out` writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_serep_cond(
    rom: *const SparsemorRom,
    cond_out: *mut f64,
) -> SparsemorStatus {
    ffi_body!({
        let r = unsafe { obj(rom, "rom")? };
        let c = r.rom.serep_cond().ok_or_else(|| {
            Failure::new(
                SparsemorStatus::NotAvailable,
                "cond(U_cr) exists only for SEREP ROMs",
            )
        })?;
        unsafe { write_out(cond_out, c, "cond_out") }
    })
}

/// Numerics of a Craig–Bampton ROM (docs/design.md §3.8).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SparsemorCraigBamptonReport {
    /// Number of boundary DoFs n_b (the first n_b ROM coordinates).
    pub boundary: usize,
    /// Number of fixed-interface modes c (the last c coordinates).
    pub modes: usize,
    /// 1 when K_ii was factored by Cholesky (positive definite), 0 for LBLᵀ.
    pub cholesky: i32,
    /// min/max |pivot| of the LBLᵀ factorization; NaN for Cholesky.
    pub pivot_ratio: f64,
    /// Largest relative residual ‖K_ii ψ_j + K_ib e_j‖ / ‖K_ib e_j‖ of the constraint modes.
    pub static_residual: f64,
    /// Largest backward error of the fixed-interface modes (0 for c = 0).
    pub mode_residual_max: f64,
}

/// The Craig–Bampton report; `SPARSEMOR_STATUS_NOT_AVAILABLE` for other methods. The
/// fixed-interface frequencies: `sparsemor_rom_fixed_interface_frequencies`.
///
/// # Safety
/// `rom` a live handle; `report_out` writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_craig_bampton_report(
    rom: *const SparsemorRom,
    report_out: *mut SparsemorCraigBamptonReport,
) -> SparsemorStatus {
    ffi_body!({
        let r = unsafe { obj(rom, "rom")? };
        let cb = craig_bampton_of(&r.rom)?;
        let rep = SparsemorCraigBamptonReport {
            boundary: r.rom.dofs.len(),
            modes: cb.fixed_interface_hz.len(),
            cholesky: i32::from(cb.factorization == "cholesky"),
            pivot_ratio: cb.pivot_ratio.unwrap_or(f64::NAN),
            static_residual: cb.static_residual,
            mode_residual_max: cb.mode_residuals.iter().copied().fold(0.0, f64::max),
        };
        unsafe { write_out(report_out, rep, "report_out") }
    })
}

/// The frequencies (Hz, ascending) of a Craig–Bampton ROM's fixed-interface modes, copied
/// into `buf` (same length protocol as `sparsemor_rom_copy_matrix`);
/// `SPARSEMOR_STATUS_NOT_AVAILABLE` for other methods.
///
/// # Safety
/// As `sparsemor_rom_dofs`.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_fixed_interface_frequencies(
    rom: *const SparsemorRom,
    buf: *mut f64,
    buf_len: usize,
    required_len: *mut usize,
) -> SparsemorStatus {
    ffi_body!({
        let r = unsafe { obj(rom, "rom")? };
        let cb = craig_bampton_of(&r.rom)?;
        unsafe {
            copy_to_buffer(
                &cb.fixed_interface_hz,
                buf,
                buf_len,
                required_len,
                "fixed-interface frequencies",
            )
        }
    })
}

fn craig_bampton_of(rom: &Rom) -> Result<&sparsemor::reduce::CraigBamptonReport, Failure> {
    rom.craig_bampton().ok_or_else(|| {
        Failure::new(
            SparsemorStatus::NotAvailable,
            "Craig–Bampton numerics exist only for Craig–Bampton ROMs",
        )
    })
}

/// Definiteness of a symmetric reduced matrix (Cholesky test and extreme eigenvalues).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SparsemorDefiniteness {
    /// 1 when the Cholesky factorization succeeded (positive definite), else 0.
    pub positive_definite: i32,
    /// Smallest eigenvalue.
    pub min_eig: f64,
    /// Largest eigenvalue.
    pub max_eig: f64,
}

/// Definiteness of Mr and Kr (a stable ROM has both positive definite). Either out pointer
/// may be NULL.
///
/// # Safety
/// `rom` a live handle; non-NULL outs writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_definiteness(
    rom: *const SparsemorRom,
    mass_out: *mut SparsemorDefiniteness,
    stiffness_out: *mut SparsemorDefiniteness,
) -> SparsemorStatus {
    ffi_body!({
        let r = unsafe { obj(rom, "rom")? };
        let conv = |d: &sparsemor::reduce::Definiteness| SparsemorDefiniteness {
            positive_definite: i32::from(d.positive_definite),
            min_eig: d.min_eig,
            max_eig: d.max_eig,
        };
        unsafe { write_opt(mass_out, conv(&r.rom.mass_definiteness), "mass_out")? };
        unsafe {
            write_opt(
                stiffness_out,
                conv(&r.rom.stiffness_definiteness),
                "stiffness_out",
            )
        }
    })
}

/// Number of timed phases of the reduction.
///
/// # Safety
/// `rom` a live handle; `count_out` writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_timing_count(
    rom: *const SparsemorRom,
    count_out: *mut usize,
) -> SparsemorStatus {
    ffi_body!({
        let r = unsafe { obj(rom, "rom")? };
        unsafe { write_out(count_out, r.rom.timings.len(), "count_out") }
    })
}

/// Phase `index` (0-based, < `sparsemor_rom_timing_count`) of the reduction: its wall time
/// in seconds to `*seconds_out` (may be NULL) and its name (UTF-8, NUL-terminated) into
/// `name_buf` of `name_len` bytes; `*name_required` (may be NULL) receives the bytes needed
/// including the NUL. `name_buf == NULL && name_len == 0` only queries; a short buffer gets
/// a truncated, NUL-terminated name and `SPARSEMOR_STATUS_BUFFER_TOO_SMALL`.
///
/// # Safety
/// `rom` a live handle; `name_buf` NULL or valid for `name_len` bytes; outs NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_timing(
    rom: *const SparsemorRom,
    index: usize,
    name_buf: *mut c_char,
    name_len: usize,
    name_required: *mut usize,
    seconds_out: *mut f64,
) -> SparsemorStatus {
    ffi_body!({
        let r = unsafe { obj(rom, "rom")? };
        let t = r.rom.timings.get(index).ok_or_else(|| {
            Failure::arg(format!(
                "timing index {index} is out of range: the ROM has {} timed phases",
                r.rom.timings.len()
            ))
        })?;
        unsafe { write_opt(seconds_out, t.seconds, "seconds_out")? };
        unsafe { copy_string(&t.phase, name_buf, name_len, name_required, "timing name") }
    })
}

/// Number of warnings of the reduction (ill-conditioning, rank truncation, indefinite Mr or
/// Kr, ...).
///
/// # Safety
/// `rom` a live handle; `count_out` writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_warning_count(
    rom: *const SparsemorRom,
    count_out: *mut usize,
) -> SparsemorStatus {
    ffi_body!({
        let r = unsafe { obj(rom, "rom")? };
        unsafe { write_out(count_out, r.rom.warnings.len(), "count_out") }
    })
}

/// Warning `index` (0-based) as UTF-8 text into `buf`; same buffer protocol as the name of
/// `sparsemor_rom_timing`.
///
/// # Safety
/// `rom` a live handle; `buf` NULL or valid for `buf_len` bytes; `required` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_warning(
    rom: *const SparsemorRom,
    index: usize,
    buf: *mut c_char,
    buf_len: usize,
    required: *mut usize,
) -> SparsemorStatus {
    ffi_body!({
        let r = unsafe { obj(rom, "rom")? };
        let w = r.rom.warnings.get(index).ok_or_else(|| {
            Failure::arg(format!(
                "warning index {index} is out of range: the ROM has {} warnings",
                r.rom.warnings.len()
            ))
        })?;
        unsafe { copy_string(w, buf, buf_len, required, "warning") }
    })
}

/// The relative transfer-function error of the ROM against the full model (eq. 23),
/// ε(f) = ‖H(iω) − Hr(iω)‖_F / ‖H(iω)‖_F, at `n_freqs` frequencies (Hz, finite, > 0 on a
/// free body): the elastic variant (H1 vs ROM) to `eps_elastic_out[k]` and the total variant
/// (H0 + H1 vs H0 + ROM; equal to the elastic one on a constrained body) to
/// `eps_total_out[k]`. Both buffers must hold `n_freqs` doubles. Costs one sparse
/// factorization of the full model per frequency, on all cores.
///
/// `model` must be the model the ROM was built from (its N is checked), with the same scene
/// kind: a ROM of a general scene is compared with the coupled model (whose transfer function
/// at its DoFs is C A⁻¹ B of the original), so the handle must still hold that scene.
///
/// # Safety
/// `model`, `rom` live handles; `freqs_hz` valid for `n_freqs` reads; the two outs for
/// `n_freqs` writes.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_transfer_error(
    model: *const SparsemorModel,
    rom: *const SparsemorRom,
    freqs_hz: *const f64,
    n_freqs: usize,
    eps_elastic_out: *mut f64,
    eps_total_out: *mut f64,
) -> SparsemorStatus {
    ffi_body!({
        let m = unsafe { obj(model, "model")? };
        let body = m.active_body();
        let r = unsafe { obj(rom, "rom")? };
        if r.coupled != m.coupled.is_some() {
            return Err(Failure::arg(if r.coupled {
                "the ROM is one of a general scene (a coupled model) but the model handle now \
                 holds a DoF scene: set the general scene again (sparsemor_model_set_scene_general)"
            } else {
                "the ROM is one of a DoF scene but the model handle holds a general scene: \
                 compare it with a handle of the plain model (sparsemor_model_set_scene)"
            }));
        }
        r.rom.check_model(body.n())?;
        if n_freqs == 0 {
            return Err(Failure::arg("transfer error: n_freqs = 0"));
        }
        let f = unsafe { slice_in(freqs_hz, n_freqs, "freqs_hz")? };
        if let Some((k, v)) = f.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(Failure::arg(format!(
                "frequency {k} is {v} Hz: need finite values"
            )));
        }
        // check both outputs before the expensive work
        check_ptr(eps_elastic_out.cast_const(), n_freqs, "eps_elastic_out")?;
        check_ptr(eps_total_out.cast_const(), n_freqs, "eps_total_out")?;
        let threads = resolve_threads(0);
        let curve = in_pool(threads, || {
            // the ROM's inputs and outputs over the span of the evaluated frequencies
            let scene = Scene {
                inputs: r.rom.inputs.clone(),
                outputs: r.rom.outputs.clone(),
                band_hz: [0.0, f.iter().copied().fold(0.0, f64::max)],
            };
            Reference::compute(
                body,
                &scene,
                f,
                &SweepOptions {
                    threads,
                    ..Default::default()
                },
                None,
                &no_progress,
            )?
            .error(&r.rom)
        })??;
        unsafe {
            std::ptr::copy_nonoverlapping(curve.eps_elastic.as_ptr(), eps_elastic_out, n_freqs);
            std::ptr::copy_nonoverlapping(curve.eps_total.as_ptr(), eps_total_out, n_freqs);
        }
        Ok(())
    })
}

/// The request and result of a tolerance-driven line-fitting ROM: the tolerance asked for
/// (`*tol_out`), the error reached (`*error_out`: the max true elastic ε of eq. 23 at the
/// sampled points and the last step's points, the verified indicator maxima or every
/// candidate of a shifted Krylov space's grid — a lower bound of the max over the band;
/// when the tolerance was not met, the best such value of the loop) and the factorizations
/// the loop spent (`*factorizations_out`, the inertia count's included; with the verification
/// pass's: `sparsemor_rom_factorizations_in_all`). Any out pointer may be NULL.
/// `SPARSEMOR_STATUS_NOT_AVAILABLE` for a ROM that did not come from the sampling loop.
///
/// # Safety
/// `rom` a live handle; each out pointer NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_sampling_result(
    rom: *const SparsemorRom,
    tol_out: *mut f64,
    error_out: *mut f64,
    factorizations_out: *mut usize,
) -> SparsemorStatus {
    ffi_body!({
        let s = sampling(unsafe { obj(rom, "rom")? })?;
        unsafe { write_opt(tol_out, s.tol, "tol_out")? };
        unsafe { write_opt(error_out, s.error, "error_out")? };
        unsafe { write_opt(factorizations_out, s.factorizations, "factorizations_out") }
    })
}

/// Every factorization of the run that made a tolerance-driven line-fitting ROM
/// (`*count_out`): the inertia count's, the sampling loop's and the verification pass's (docs/
/// design.md §3.5). `SPARSEMOR_STATUS_NOT_AVAILABLE` for a ROM that did not come from the
/// sampling loop.
///
/// # Safety
/// `rom` a live handle; `count_out` writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_factorizations_in_all(
    rom: *const SparsemorRom,
    count_out: *mut usize,
) -> SparsemorStatus {
    ffi_body!({
        let s = sampling(unsafe { obj(rom, "rom")? })?;
        unsafe { write_out(count_out, s.factorizations_in_all, "count_out") }
    })
}

/// The ROM's sampling report, or `NOT_AVAILABLE` when it did not come from the sampling loop.
fn sampling(r: &SparsemorRom) -> Result<&sparsemor::reduce::linefit::SamplingReport, Failure> {
    r.rom.sampling().ok_or_else(|| {
        Failure::new(
            SparsemorStatus::NotAvailable,
            "the ROM did not come from the sampling loop (no tolerance was set)",
        )
    })
}

/// Whether the ROM came from the sampling loop (`*is_sampled_out`, 0/1) and, if so, whether
/// it reached the tolerance (`*converged_out`, 0/1; may be NULL).
///
/// # Safety
/// `rom` a live handle; `is_sampled_out` writable; `converged_out` NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_sampling_converged(
    rom: *const SparsemorRom,
    is_sampled_out: *mut i32,
    converged_out: *mut i32,
) -> SparsemorStatus {
    ffi_body!({
        let r = unsafe { obj(rom, "rom")? };
        unsafe {
            write_out(
                is_sampled_out,
                i32::from(r.rom.sampling().is_some()),
                "is_sampled_out",
            )?
        };
        unsafe {
            write_opt(
                converged_out,
                i32::from(r.rom.sampling().is_some_and(|s| s.outcome.reached())),
                "converged_out",
            )
        }
    })
}

/// Number of steps of the sampling loop (0 for a ROM from explicit frequencies or SEREP).
///
/// # Safety
/// `rom` a live handle; `count_out` writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_step_count(
    rom: *const SparsemorRom,
    count_out: *mut usize,
) -> SparsemorStatus {
    ffi_body!({
        let r = unsafe { obj(rom, "rom")? };
        unsafe {
            write_out(
                count_out,
                r.rom.sampling().map_or(0, |s| s.steps.len()),
                "count_out",
            )
        }
    })
}

/// Step `index` (0-based) of the sampling loop: order, number of new points, indicator max,
/// true error at the new points, true error at the earlier points (NaN where not measured),
/// factorizations so far and seconds so far. Every out pointer may be NULL.
///
/// # Safety
/// `rom` a live handle; outs NULL or writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_rom_step(
    rom: *const SparsemorRom,
    index: usize,
    order_out: *mut usize,
    n_points_out: *mut usize,
    indicator_max_out: *mut f64,
    true_error_out: *mut f64,
    sampled_error_out: *mut f64,
    factorizations_out: *mut usize,
    seconds_out: *mut f64,
) -> SparsemorStatus {
    ffi_body!({
        let r = unsafe { obj(rom, "rom")? };
        let steps = r.rom.sampling().map_or(&[][..], |s| &s.steps[..]);
        let s = steps.get(index).ok_or_else(|| {
            Failure::arg(format!(
                "step index {index} is out of range: the ROM has {} sampling steps",
                steps.len()
            ))
        })?;
        unsafe {
            write_opt(order_out, s.order, "order_out")?;
            write_opt(n_points_out, s.points_hz.len(), "n_points_out")?;
            write_opt(indicator_max_out, s.indicator_max, "indicator_max_out")?;
            write_opt(true_error_out, s.true_error_max, "true_error_out")?;
            write_opt(sampled_error_out, s.sampled_error_max, "sampled_error_out")?;
            write_opt(factorizations_out, s.factorizations, "factorizations_out")?;
            write_opt(seconds_out, s.seconds, "seconds_out")
        }
    })
}
