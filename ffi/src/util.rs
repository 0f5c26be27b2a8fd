//! Checked access to caller memory: no reference is formed before the pointer has been
//! checked for NULL, alignment and a byte length that fits `isize`; caller-owned output
//! buffers (possibly uninitialized) are only written through raw pointers. Caller memory is
//! never taken over (`Vec::from_raw_parts` is never used on it).

use crate::error::{write_str, Failure, SparsemorStatus};
use std::ffi::c_char;

/// NULL, alignment and size check of a caller array of `len` values of `T` (no access).
pub(crate) fn check_ptr<T>(ptr: *const T, len: usize, what: &str) -> Result<(), Failure> {
    if ptr.is_null() || !ptr.is_aligned() {
        return Err(Failure::null(what));
    }
    if len
        .checked_mul(std::mem::size_of::<T>())
        .is_none_or(|b| b > isize::MAX as usize)
    {
        return Err(Failure::arg(format!(
            "{what}: length {len} is too large for this address space"
        )));
    }
    Ok(())
}

/// The caller's array `ptr[0..len]` (read only). NULL is accepted when `len == 0`.
///
/// # Safety
/// When non-NULL, `ptr` must point to `len` initialized values that stay unchanged during the
/// call.
pub(crate) unsafe fn slice_in<'a, T>(
    ptr: *const T,
    len: usize,
    what: &str,
) -> Result<&'a [T], Failure> {
    if len == 0 {
        return Ok(&[]);
    }
    check_ptr(ptr, len, what)?;
    // SAFETY: non-null, aligned, size fits isize; validity is the caller's contract.
    Ok(unsafe { std::slice::from_raw_parts(ptr, len) })
}

/// A shared reference to a caller object (handle or input struct) after the NULL check.
///
/// # Safety
/// When non-NULL, `ptr` must point to a live object of type `T`.
pub(crate) unsafe fn obj<'a, T>(ptr: *const T, what: &str) -> Result<&'a T, Failure> {
    check_ptr(ptr, 1, what)?;
    // SAFETY: checked non-null and aligned; liveness is the caller's contract.
    Ok(unsafe { &*ptr })
}

/// A mutable reference to a handle after the NULL check.
///
/// # Safety
/// When non-NULL, `ptr` must point to a live object of type `T` not used elsewhere during the
/// call.
pub(crate) unsafe fn obj_mut<'a, T>(ptr: *mut T, what: &str) -> Result<&'a mut T, Failure> {
    check_ptr(ptr, 1, what)?;
    // SAFETY: checked non-null and aligned; exclusivity and liveness are the caller's contract.
    Ok(unsafe { &mut *ptr })
}

/// Writes `value` to the caller's `*ptr` (which may be uninitialized).
///
/// # Safety
/// When non-NULL, `ptr` must be valid for a write of `T`.
pub(crate) unsafe fn write_out<T>(ptr: *mut T, value: T, what: &str) -> Result<(), Failure> {
    check_ptr(ptr, 1, what)?;
    // SAFETY: checked non-null and aligned; writability is the caller's contract.
    unsafe { ptr.write(value) };
    Ok(())
}

/// Writes `value` to `*ptr` when `ptr` is not NULL (optional out-parameters).
///
/// # Safety
/// When non-NULL, `ptr` must be valid for a write of `T`.
pub(crate) unsafe fn write_opt<T>(ptr: *mut T, value: T, what: &str) -> Result<(), Failure> {
    if ptr.is_null() {
        return Ok(());
    }
    // SAFETY: forwarded contract.
    unsafe { write_out(ptr, value, what) }
}

/// Copies `src` into the caller's buffer `dst[0..dst_len]` (possibly uninitialized) after
/// checking the length: the usual "caller-owned buffer with explicit length" protocol.
///
/// `*required` (when not NULL) always receives `src.len()`. `dst == NULL && dst_len == 0` is a
/// pure size query and succeeds. A shorter buffer fails with
/// [`SparsemorStatus::BufferTooSmall`] and writes nothing to `dst`.
///
/// # Safety
/// `dst` must be NULL or valid for `dst_len` writes of `T`; `required` NULL or writable.
pub(crate) unsafe fn copy_to_buffer<T: Copy>(
    src: &[T],
    dst: *mut T,
    dst_len: usize,
    required: *mut usize,
    what: &str,
) -> Result<(), Failure> {
    // SAFETY: forwarded contract.
    unsafe { write_opt(required, src.len(), "required-length pointer")? };
    if dst.is_null() && dst_len == 0 {
        return Ok(());
    }
    if dst_len < src.len() {
        return Err(Failure::new(
            SparsemorStatus::BufferTooSmall,
            format!(
                "{what}: buffer holds {dst_len} elements but {} are needed",
                src.len()
            ),
        ));
    }
    check_ptr(dst as *const T, dst_len, what)?;
    // SAFETY: dst is valid for dst_len >= src.len() writes (caller contract, checked length);
    // the caller's buffer cannot overlap our own `src`.
    unsafe { std::ptr::copy_nonoverlapping(src.as_ptr(), dst, src.len()) };
    Ok(())
}

/// [`crate::error::write_str`] for exported string getters: writes `*required` (bytes including the NUL,
/// when not NULL) and turns a failure into a message. `buf == NULL && buf_len == 0` is a pure
/// size query and succeeds.
///
/// # Safety
/// As [`crate::error::write_str`]; `required` NULL or writable.
pub(crate) unsafe fn copy_string(
    s: &str,
    buf: *mut c_char,
    buf_len: usize,
    required: *mut usize,
    what: &str,
) -> Result<(), Failure> {
    // SAFETY: forwarded contract.
    unsafe { write_opt(required, s.len() + 1, "required-length pointer")? };
    if buf.is_null() && buf_len == 0 {
        return Ok(());
    }
    // SAFETY: forwarded contract.
    match unsafe { write_str(s.as_bytes(), buf, buf_len) } {
        SparsemorStatus::Ok => Ok(()),
        SparsemorStatus::NullPointer => Err(Failure::null(what)),
        st => Err(Failure::new(
            st,
            format!(
                "{what}: buffer holds {buf_len} bytes but {} are needed (text plus NUL); the text was truncated",
                s.len() + 1
            ),
        )),
    }
}
