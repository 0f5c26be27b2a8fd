//! Options handle: threads, tolerance and sampling limits, interface, reference frequencies, SEREP
//! modes and retained DoFs, Craig–Bampton modes, keep-basis flag.

use crate::error::{ffi_body, Failure, SparsemorStatus};
use crate::util::{obj_mut, slice_in, write_out};
use sparsemor::reduce::linefit::{Interface, LineFitOptions, References, SamplingOptions};
use sparsemor::reduce::serep::ModeChoice;

/// How the reference frequencies of line-fitting are given.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum RefFreqs {
    Unset,
    Explicit(Vec<f64>),
    Count(usize),
}

/// Opaque options handle for `sparsemor_reduce_linefit` and `sparsemor_reduce_serep`.
/// Created by `sparsemor_options_new` with the defaults listed there, released by
/// `sparsemor_options_free`. One handle may serve any number of reductions.
#[derive(Clone, Debug)]
pub struct SparsemorOptions {
    pub(crate) threads: usize,
    pub(crate) tolerance: Option<f64>,
    pub(crate) max_points: Option<usize>,
    pub(crate) max_order: usize,
    /// `None`: the default, [`Interface::Auto`] with a tolerance, the outputs otherwise.
    pub(crate) interface: Option<Interface>,
    pub(crate) ref_freqs: RefFreqs,
    pub(crate) serep_modes: Option<ModeChoice>,
    pub(crate) serep_retain: Option<Vec<usize>>,
    /// Craig–Bampton's number of fixed-interface modes; unset until
    /// `sparsemor_options_set_craig_bampton_modes`.
    pub(crate) cb_modes: Option<usize>,
    pub(crate) keep_basis: bool,
}

impl Default for SparsemorOptions {
    fn default() -> Self {
        SparsemorOptions {
            threads: 0,
            tolerance: None,
            max_points: None,
            max_order: 0,
            interface: None,
            ref_freqs: RefFreqs::Unset,
            serep_modes: None,
            serep_retain: None,
            cb_modes: None,
            keep_basis: false,
        }
    }
}

impl SparsemorOptions {
    /// The library's line-fitting options: the tolerance (with explicit frequencies as
    /// extra seeds) when one is set, else the explicit frequencies or the count.
    pub(crate) fn linefit(&self, threads: usize) -> Result<LineFitOptions, Failure> {
        let references = match (self.tolerance, &self.ref_freqs) {
            (Some(tol), seeds) => {
                let mut s = SamplingOptions::new(tol);
                if let RefFreqs::Explicit(f) = seeds {
                    s.seeds_hz = f.clone();
                }
                s.max_points = self.max_points;
                s.max_order = (self.max_order > 0).then_some(self.max_order);
                References::Tolerance(s)
            }
            (None, RefFreqs::Explicit(f)) => References::Explicit(f.clone()),
            (None, RefFreqs::Count(z)) => References::Count(*z),
            (None, RefFreqs::Unset) => {
                return Err(Failure::arg(
                    "line-fitting needs reference frequencies: call sparsemor_options_set_reference_frequencies \
                     or sparsemor_options_set_reference_count",
                ))
            }
        };
        let interface = self.interface.clone().unwrap_or(match self.tolerance {
            Some(_) => Interface::Auto,
            None => Interface::OutputsPlus(0),
        });
        let mut o = LineFitOptions::new(interface, references);
        o.keep_basis = self.keep_basis;
        o.sweep.threads = threads;
        Ok(o)
    }
}

/// A DoF list from the caller: non-empty, no duplicates (the range is checked against the
/// model at reduction time).
unsafe fn dof_list(ptr: *const usize, len: usize, what: &str) -> Result<Vec<usize>, Failure> {
    if len == 0 {
        return Err(Failure::arg(format!("{what}: empty list")));
    }
    // SAFETY: forwarded caller contract.
    let v = unsafe { slice_in(ptr, len, what)? }.to_vec();
    let mut s = v.clone();
    s.sort_unstable();
    if let Some(w) = s.windows(2).find(|w| w[0] == w[1]) {
        return Err(Failure::arg(format!("{what}: DoF {} appears twice", w[0])));
    }
    Ok(v)
}

/// Creates an options handle with the defaults: threads 0 (all cores), no tolerance,
/// interface = the outputs (outputs + 0) — with a tolerance the outputs plus ⌈q/2⌉ spread
/// DoFs for q outputs, growing up to the automatic cap —, no reference frequencies
/// (line-fitting needs them or a tolerance),
/// SEREP with c = r modes (as many lowest deformation modes as retained DoFs) retaining the
/// outputs, V not kept. `*options_out` receives the handle (NULL on failure).
///
/// # Safety
/// `options_out` writable.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_options_new(
    options_out: *mut *mut SparsemorOptions,
) -> SparsemorStatus {
    ffi_body!({
        let h = Box::into_raw(Box::default());
        // SAFETY: caller contract; on failure the box is reclaimed.
        if let Err(e) = unsafe { write_out(options_out, h, "options_out") } {
            drop(unsafe { Box::from_raw(h) });
            return Err(e);
        }
        Ok(())
    })
}

/// Releases an options handle. NULL is a no-op.
///
/// # Safety
/// `options` NULL or a live handle from `sparsemor_options_new`.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_options_free(options: *mut SparsemorOptions) -> SparsemorStatus {
    ffi_body!({
        if !options.is_null() {
            // SAFETY: a live handle from Box::into_raw (caller contract).
            drop(unsafe { Box::from_raw(options) });
        }
        Ok(())
    })
}

/// Worker threads of the frequency sweep; 0 = `RAYON_NUM_THREADS` if set, else all available
/// cores. Every reduction runs on its own thread pool, which ends with the call (no threads
/// linger in the caller's process). Results are bit-for-bit
/// reproducible for a fixed thread count of 1; with more threads the assignment of
/// frequencies to workers depends on timing and line-fitting results may differ in the last
/// bits.
///
/// # Safety
/// `options` a live handle.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_options_set_threads(
    options: *mut SparsemorOptions,
    threads: usize,
) -> SparsemorStatus {
    ffi_body!({
        let o = unsafe { obj_mut(options, "options")? };
        if threads > 4096 {
            return Err(Failure::arg(format!(
                "threads = {threads}: use 0 (all cores) or a count <= 4096"
            )));
        }
        o.threads = threads;
        Ok(())
    })
}

/// The accuracy target of line-fitting with tolerance-driven frequency sampling (docs/design.md
/// §3.5): with a tolerance set, `sparsemor_reduce_linefit` chooses the reference frequencies
/// itself (explicit reference frequencies, if set, become extra seeds) until the true elastic
/// error (eq. 23) at two consecutive steps' new and earlier points is ≤ tol, the budget of
/// `sparsemor_options_set_sampling_limits` is spent, or more frequencies stop helping; the
/// step log is read with `sparsemor_rom_step_count` / `sparsemor_rom_step`. Validated:
/// finite, 0 < tol < 1; 0 clears it.
///
/// # Safety
/// `options` a live handle.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_options_set_tolerance(
    options: *mut SparsemorOptions,
    tolerance: f64,
) -> SparsemorStatus {
    ffi_body!({
        let o = unsafe { obj_mut(options, "options")? };
        if tolerance == 0.0 {
            o.tolerance = None;
            return Ok(());
        }
        if !(tolerance.is_finite() && tolerance > 0.0 && tolerance < 1.0) {
            return Err(Failure::arg(format!(
                "tolerance = {tolerance}: need a finite relative error 0 < tol < 1 (or 0 to clear)"
            )));
        }
        o.tolerance = Some(tolerance);
        Ok(())
    })
}

/// Limits of the sampling loop (with a tolerance): at most `max_points` full solves (0 =
/// the library's default: 60 when every frequency is factored, 8 × the order cap when one
/// shifted Krylov space answers them) and interface growth up to order `max_order` (0 = the
/// automatic cap min(max(3·n0, 40, q + 2c), N/2, memory) for q outputs and c modes in the
/// band, the library's `SamplingOptions::auto_max_order`; a value at most the initial order
/// n0 keeps the order fixed).
///
/// # Safety
/// `options` a live handle.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_options_set_sampling_limits(
    options: *mut SparsemorOptions,
    max_points: usize,
    max_order: usize,
) -> SparsemorStatus {
    ffi_body!({
        let o = unsafe { obj_mut(options, "options")? };
        o.max_points = (max_points > 0).then_some(max_points);
        o.max_order = max_order;
        Ok(())
    })
}

/// Line-fitting interface = exactly these DoFs (the ROM coordinates, order n = `n_dofs`;
/// must contain every output). Non-empty, no duplicates; copied.
///
/// # Safety
/// `options` a live handle; `dofs` valid for `n_dofs` values.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_options_set_interface(
    options: *mut SparsemorOptions,
    dofs: *const usize,
    n_dofs: usize,
) -> SparsemorStatus {
    ffi_body!({
        let o = unsafe { obj_mut(options, "options")? };
        o.interface = Some(Interface::Explicit(unsafe {
            dof_list(dofs, n_dofs, "interface")?
        }));
        Ok(())
    })
}

/// Line-fitting interface = the outputs plus `k` DoFs spread along the body (along the long
/// axis of the node cloud, transverse directions; evenly over 0..N without nodes).
///
/// # Safety
/// `options` a live handle.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_options_set_interface_outputs_plus(
    options: *mut SparsemorOptions,
    k: usize,
) -> SparsemorStatus {
    ffi_body!({
        let o = unsafe { obj_mut(options, "options")? };
        o.interface = Some(Interface::OutputsPlus(k));
        Ok(())
    })
}

/// Line-fitting reference frequencies (Hz): finite, >= 0 (> 0 on a free body); need
/// 2·p·z >= n (p inputs, z frequencies, n interface DoFs). Copied.
///
/// # Safety
/// `options` a live handle; `freqs_hz` valid for `n_freqs` values.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_options_set_reference_frequencies(
    options: *mut SparsemorOptions,
    freqs_hz: *const f64,
    n_freqs: usize,
) -> SparsemorStatus {
    ffi_body!({
        let o = unsafe { obj_mut(options, "options")? };
        if n_freqs == 0 {
            return Err(Failure::arg("reference frequencies: empty list"));
        }
        let f = unsafe { slice_in(freqs_hz, n_freqs, "freqs_hz")? };
        if let Some((k, v)) = f
            .iter()
            .enumerate()
            .find(|(_, v)| !(v.is_finite() && **v >= 0.0))
        {
            return Err(Failure::arg(format!(
                "reference frequency {k} is {v} Hz: need finite values >= 0"
            )));
        }
        o.ref_freqs = RefFreqs::Explicit(f.to_vec());
        Ok(())
    })
}

/// Line-fitting reference frequencies chosen by the library: `z` points placed from the
/// in-band resonances of the full model (beside each resonance, between resonances, up to
/// the band end; the rule of `sparsemor::reduce::linefit::place_reference_frequencies`).
/// Costs one partial eigensolve of the full model. `z >= 1`.
///
/// # Safety
/// `options` a live handle.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_options_set_reference_count(
    options: *mut SparsemorOptions,
    z: usize,
) -> SparsemorStatus {
    ffi_body!({
        let o = unsafe { obj_mut(options, "options")? };
        if z == 0 {
            return Err(Failure::arg("reference count z = 0: need z >= 1"));
        }
        o.ref_freqs = RefFreqs::Count(z);
        Ok(())
    })
}

/// SEREP keeps the `c` lowest deformation (non-rigid) modes; `c >= 1`.
///
/// # Safety
/// `options` a live handle.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_options_set_serep_modes(
    options: *mut SparsemorOptions,
    c: usize,
) -> SparsemorStatus {
    ffi_body!({
        let o = unsafe { obj_mut(options, "options")? };
        if c == 0 {
            return Err(Failure::arg("SEREP mode count c = 0: need c >= 1"));
        }
        o.serep_modes = Some(ModeChoice::LowestDeformation(c));
        Ok(())
    })
}

/// SEREP keeps these modes: 1-based numbers among all modes in ascending frequency, rigid
/// ones included (on a free body modes 1–6 are rigid). Non-empty, >= 1, no duplicates.
///
/// # Safety
/// `options` a live handle; `numbers` valid for `n_numbers` values.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_options_set_serep_mode_numbers(
    options: *mut SparsemorOptions,
    numbers: *const usize,
    n_numbers: usize,
) -> SparsemorStatus {
    ffi_body!({
        let o = unsafe { obj_mut(options, "options")? };
        let v = unsafe { dof_list(numbers, n_numbers, "SEREP mode numbers")? };
        if v.contains(&0) {
            return Err(Failure::arg(
                "SEREP mode numbers are 1-based: 0 is not a mode",
            ));
        }
        o.serep_modes = Some(ModeChoice::Numbers(v));
        Ok(())
    })
}

/// SEREP retained DoFs (the ROM coordinates, order r = `n_dofs`); default: the outputs.
///
/// # Safety
/// `options` a live handle; `dofs` valid for `n_dofs` values.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_options_set_serep_retained(
    options: *mut SparsemorOptions,
    dofs: *const usize,
    n_dofs: usize,
) -> SparsemorStatus {
    ffi_body!({
        let o = unsafe { obj_mut(options, "options")? };
        o.serep_retain = Some(unsafe { dof_list(dofs, n_dofs, "SEREP retained DoFs")? });
        Ok(())
    })
}

/// Craig–Bampton (`sparsemor_reduce_craig_bampton`) keeps the `c` lowest fixed-interface
/// modes; `c = 0` is static (Guyan) condensation. The boundary DoFs are the interface
/// (`sparsemor_options_set_interface` / `_interface_outputs_plus`; default: the outputs).
///
/// # Safety
/// `options` a live handle.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_options_set_craig_bampton_modes(
    options: *mut SparsemorOptions,
    c: usize,
) -> SparsemorStatus {
    ffi_body!({
        let o = unsafe { obj_mut(options, "options")? };
        o.cb_modes = Some(c);
        Ok(())
    })
}

/// Keep the basis V (N×n) in the ROM (nonzero) so `sparsemor_rom_copy_matrix` can return
/// it with `SPARSEMOR_MATRIX_V`; default 0 (V is N×n doubles: only ask when needed).
///
/// # Safety
/// `options` a live handle.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_options_set_keep_basis(
    options: *mut SparsemorOptions,
    keep: i32,
) -> SparsemorStatus {
    ffi_body!({
        let o = unsafe { obj_mut(options, "options")? };
        o.keep_basis = keep != 0;
        Ok(())
    })
}
