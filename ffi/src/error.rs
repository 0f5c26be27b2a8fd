//! Status codes, the thread-local last error and the panic guard every export runs in.
//!
//! The discipline is regex-capi's and libgit2's (docs/design.md §6): every exported
//! body runs inside [`ffi_body!`], which calls [`guard`]: the body runs under
//! `catch_unwind`, an `Err` becomes its [`SparsemorStatus`] plus a message stored in a
//! thread-local, and a panic becomes [`SparsemorStatus::Panic`] with the panic message. The
//! message is read back with `sparsemor_last_error_length` and `sparsemor_last_error_message`.

use std::cell::RefCell;
use std::ffi::c_char;
use std::panic::{catch_unwind, AssertUnwindSafe};

/// Result code of every `sparsemor_*` function that can fail.
///
/// `SPARSEMOR_STATUS_OK` (0) means success; on any other value the function's outputs are
/// unspecified (handles written through `*_out` are set to NULL) and
/// `sparsemor_last_error_message` explains the failure. Codes are stable within one ABI
/// version.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SparsemorStatus {
    /// Success.
    Ok = 0,
    /// A required pointer argument was NULL (or misaligned).
    NullPointer = 1,
    /// An argument is invalid: a length, a CSC array (unsorted, duplicate, out-of-range or
    /// non-monotone index), a non-finite value, a DoF list, a frequency, an option.
    InvalidArgument = 2,
    /// The matrices do not form a valid model (not symmetric, mass diagonal not positive,
    /// node coordinates inconsistent with N, ...).
    InvalidModel = 3,
    /// A caller buffer is too small; the required length was written to the `*_required`
    /// out-parameter (when given) and is in the message.
    BufferTooSmall = 4,
    /// The requested quantity does not exist for this ROM (V not kept, fit diagnostics of a
    /// SEREP ROM, ...).
    NotAvailable = 5,
    /// A pencil A(iω) is numerically singular at a frequency (undamped model at an
    /// eigenfrequency?); the message names the frequency.
    Singular = 7,
    /// A factorization, eigensolver or dense decomposition failed for another reason.
    Numerical = 8,
    /// The progress callback returned nonzero.
    Cancelled = 9,
    /// An I/O error (not produced by the current API; reserved).
    Io = 10,
    /// A bug: a panic inside the library was caught at the ABI boundary. Please report the
    /// message.
    Panic = 11,
}

/// An error on its way to the caller: status plus message.
#[derive(Debug)]
pub(crate) struct Failure {
    pub status: SparsemorStatus,
    pub message: String,
}

impl Failure {
    pub fn new(status: SparsemorStatus, message: impl Into<String>) -> Self {
        Failure {
            status,
            message: message.into(),
        }
    }

    pub fn arg(message: impl Into<String>) -> Self {
        Self::new(SparsemorStatus::InvalidArgument, message)
    }

    pub fn null(what: &str) -> Self {
        Self::new(
            SparsemorStatus::NullPointer,
            format!("{what} is NULL (or not aligned for its type)"),
        )
    }
}

impl From<sparsemor::Error> for Failure {
    fn from(e: sparsemor::Error) -> Self {
        use sparsemor::Error as E;
        let status = match &e {
            E::InvalidModel(_) => SparsemorStatus::InvalidModel,
            E::InvalidSetting(_) | E::DofOutOfRange { .. } | E::Underdetermined { .. } => {
                SparsemorStatus::InvalidArgument
            }
            E::Singular { .. } => SparsemorStatus::Singular,
            E::Factor(_) | E::NotConverged(_) => SparsemorStatus::Numerical,
            // the C ABI runs in one process; these come only from MPI runs of the library
            E::Remote { .. } | E::Distributed(_) => SparsemorStatus::Numerical,
            E::Cancelled => SparsemorStatus::Cancelled,
            E::Io { .. } | E::Parse { .. } => SparsemorStatus::Io,
        };
        Failure::new(status, e.to_string())
    }
}

/// What an exported body returns.
pub(crate) type FfiResult = Result<(), Failure>;

thread_local! {
    static LAST_ERROR: RefCell<Option<String>> = const { RefCell::new(None) };
}

pub(crate) fn set_last_error(msg: String) {
    LAST_ERROR.with(|e| *e.borrow_mut() = Some(msg));
}

pub(crate) fn clear_last_error() {
    LAST_ERROR.with(|e| *e.borrow_mut() = None);
}

/// Runs `f` with the last-error bookkeeping and the panic guard (see the module doc).
pub(crate) fn guard(f: impl FnOnce() -> FfiResult) -> SparsemorStatus {
    clear_last_error();
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(())) => SparsemorStatus::Ok,
        Ok(Err(e)) => {
            set_last_error(e.message);
            e.status
        }
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "(non-string panic payload)".into());
            // Dropping the payload could itself panic (a panicking Drop); forget it.
            std::mem::forget(payload);
            set_last_error(format!(
                "internal error (panic caught at the C ABI boundary; please report): {what}"
            ));
            SparsemorStatus::Panic
        }
    }
}

/// The body of every exported function: `ffi_body!({ ...; Ok(()) })` runs the block inside
/// [`guard`] (catch_unwind, thread-local last error) and returns the status.
macro_rules! ffi_body {
    ($body:block) => {
        $crate::error::guard(move || -> $crate::error::FfiResult { $body })
    };
}
pub(crate) use ffi_body;

/// Length in bytes of the last error message of this thread, including the terminating NUL;
/// 0 when the last `sparsemor_*` call on this thread succeeded.
///
/// Every `sparsemor_*` function except the two last-error getters clears the message when it
/// starts, so the message always belongs to the most recent call on the calling thread.
#[no_mangle]
pub extern "C" fn sparsemor_last_error_length() -> usize {
    catch_unwind(|| LAST_ERROR.with(|e| e.borrow().as_ref().map_or(0, |m| m.len() + 1)))
        .unwrap_or(0)
}

/// Copies the last error message of this thread (UTF-8, NUL-terminated) into `buf` of
/// `buf_len` bytes.
///
/// Returns `SPARSEMOR_STATUS_OK` when the whole message fit (an empty string when there is no
/// error), `SPARSEMOR_STATUS_BUFFER_TOO_SMALL` when it did not (`buf` then holds as much of the
/// message as fits, NUL-terminated, if `buf_len > 0`; ask `sparsemor_last_error_length` for
/// the size), `SPARSEMOR_STATUS_NULL_POINTER` when `buf` is NULL and `buf_len > 0`. This
/// function does not change the stored message.
///
/// # Safety
/// `buf` must be NULL or point to `buf_len` writable bytes.
#[no_mangle]
pub unsafe extern "C" fn sparsemor_last_error_message(
    buf: *mut std::ffi::c_char,
    buf_len: usize,
) -> SparsemorStatus {
    let r = catch_unwind(|| {
        LAST_ERROR.with(|e| {
            let e = e.borrow();
            let msg = e.as_deref().unwrap_or("").as_bytes();
            // SAFETY: the caller guarantees `buf` points to `buf_len` writable bytes.
            unsafe { write_str(msg, buf, buf_len) }
        })
    });
    r.unwrap_or(SparsemorStatus::Panic)
}

/// Copies `msg` plus a terminating NUL into `buf[0..buf_len]`. Returns the status without
/// touching the last error (used by the last-error getter itself). On a short buffer the
/// longest prefix that fits is written, NUL-terminated (when `buf_len > 0`), cut at a UTF-8
/// character boundary.
///
/// # Safety
/// `buf` must be NULL or valid for `buf_len` byte writes.
pub(crate) unsafe fn write_str(msg: &[u8], buf: *mut c_char, buf_len: usize) -> SparsemorStatus {
    if buf_len == 0 {
        // not even room for the NUL
        return SparsemorStatus::BufferTooSmall;
    }
    if buf.is_null() {
        return SparsemorStatus::NullPointer;
    }
    let fits = msg.len() < buf_len;
    let mut n = msg.len().min(buf_len - 1);
    if !fits {
        // do not cut a UTF-8 sequence in half
        while n > 0 && (msg[n] & 0xC0) == 0x80 {
            n -= 1;
        }
    }
    // SAFETY: buf is valid for buf_len > n bytes (caller contract).
    unsafe {
        std::ptr::copy_nonoverlapping(msg.as_ptr(), buf.cast::<u8>(), n);
        buf.add(n).write(0);
    }
    if fits {
        SparsemorStatus::Ok
    } else {
        SparsemorStatus::BufferTooSmall
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_becomes_status_panic_with_its_message() {
        let st = guard(|| panic!("boom {}", 42));
        assert_eq!(st, SparsemorStatus::Panic);
        let len = sparsemor_last_error_length();
        let mut buf = vec![0u8; len];
        let st = unsafe { sparsemor_last_error_message(buf.as_mut_ptr().cast(), len) };
        assert_eq!(st, SparsemorStatus::Ok);
        let msg = std::str::from_utf8(&buf[..len - 1]).unwrap();
        assert!(msg.contains("panic caught at the C ABI boundary"), "{msg}");
        assert!(msg.contains("boom 42"), "{msg}");
        // a static-str payload too, and the next successful call clears the message
        assert_eq!(guard(|| panic!("static")), SparsemorStatus::Panic);
        assert_eq!(guard(|| Ok(())), SparsemorStatus::Ok);
        assert_eq!(sparsemor_last_error_length(), 0);
    }

    #[test]
    fn a_panic_inside_a_call_local_pool_is_caught_too() {
        let st = guard(|| {
            crate::pool::in_pool(2, || -> usize { panic!("in a worker") })?;
            Ok(())
        });
        assert_eq!(st, SparsemorStatus::Panic);
    }
}
