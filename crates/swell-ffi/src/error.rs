//! Status codes, the thread's last error message, and the guard every exported function runs
//! its body in (no panic crosses the C boundary).

use std::cell::RefCell;
use std::ffi::{CString, c_char};
use std::panic::{AssertUnwindSafe, catch_unwind};

/// What every fallible function returns: [`SWELL_OK`] or one of the `SWELL_ERR_*` codes.
/// On an error, [`swell_last_error_message`] says what was wrong.
pub type SwellStatus = i32;

/// Success.
pub const SWELL_OK: SwellStatus = 0;
/// A pointer the function needs was null.
pub const SWELL_ERR_NULL: SwellStatus = 1;
/// Text that is not UTF-8 or not JSON, or JSON of the wrong shape (a wrongly typed or unknown
/// field): the server answers 400 `bad_json` for the same text.
pub const SWELL_ERR_BAD_JSON: SwellStatus = 2;
/// A spec the model rejects (a value out of range, an inconsistent layer): the server answers
/// 422 `invalid_spec` for the same spec.
pub const SWELL_ERR_INVALID_SPEC: SwellStatus = 3;
/// An argument out of range: a non-finite time or coordinate, a tick in the past, a bad span or
/// option.
pub const SWELL_ERR_INVALID_ARGUMENT: SwellStatus = 4;
/// No body with that id in the world (or one already has the id asked for).
pub const SWELL_ERR_NOT_FOUND: SwellStatus = 5;
/// Something this ABI cannot reproduce to the server's bits. No function returns it at present
/// (body worlds of scenes with `body_impacts` were refused with it before they derived
/// splashes and wakes); kept so the codes stay what they were.
pub const SWELL_ERR_UNSUPPORTED: SwellStatus = 6;
/// A bug in the library: a panic was caught at the boundary. The handle involved may be left
/// in any state that is safe to free; please report the message.
pub const SWELL_ERR_PANIC: SwellStatus = 7;

/// An error on its way to the caller: a code and a message for people.
#[derive(Debug, Clone, PartialEq)]
pub struct Error {
    /// One of the `SWELL_ERR_*` codes.
    pub code: SwellStatus,
    /// What was wrong, naming the argument or field.
    pub message: String,
}

impl Error {
    /// An error with `code`.
    pub fn new(code: SwellStatus, message: impl Into<String>) -> Error {
        Error {
            code,
            message: message.into(),
        }
    }

    /// A null pointer passed as `what`.
    pub fn null(what: &str) -> Error {
        Error::new(SWELL_ERR_NULL, format!("{what} must not be null"))
    }

    /// An argument out of range.
    pub fn invalid(message: impl Into<String>) -> Error {
        Error::new(SWELL_ERR_INVALID_ARGUMENT, message)
    }

    /// The model rejected a spec.
    pub fn spec(e: &swell_waves::SpecError) -> Error {
        Error::new(SWELL_ERR_INVALID_SPEC, e.to_string())
    }
}

thread_local! {
    /// The last error on this thread: its code and message (NUL-free, so it is a C string).
    static LAST: RefCell<(SwellStatus, CString)> = RefCell::new((SWELL_OK, CString::default()));
}

fn set_last(code: SwellStatus, message: &str) {
    // A message with an interior NUL (from a caller's text echoed back) is cut there.
    let text = message.split('\0').next().unwrap_or_default();
    let c = CString::new(text).unwrap_or_default();
    LAST.with(|l| *l.borrow_mut() = (code, c));
}

/// Runs an exported function's body: its error becomes the status and the thread's last error;
/// a panic is caught here, reported as [`SWELL_ERR_PANIC`], and never unwinds into C.
pub(crate) fn guard(body: impl FnOnce() -> Result<(), Error>) -> SwellStatus {
    match catch_unwind(AssertUnwindSafe(body)) {
        Ok(Ok(())) => SWELL_OK,
        Ok(Err(e)) => {
            set_last(e.code, &e.message);
            e.code
        }
        Err(payload) => {
            let what = payload
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            set_last(
                SWELL_ERR_PANIC,
                &format!("internal error (a panic was caught at the C boundary): {what}"),
            );
            SWELL_ERR_PANIC
        }
    }
}

/// The message of the most recent call on this thread that failed (UTF-8, NUL-terminated);
/// an empty string if none has. Never null. The text stays valid until the next failing call on
/// the same thread: copy it to keep it.
#[unsafe(no_mangle)]
pub extern "C" fn swell_last_error_message() -> *const c_char {
    catch_unwind(|| LAST.with(|l| l.borrow().1.as_ptr())).unwrap_or(c"".as_ptr())
}

/// The code of the most recent call on this thread that failed ([`SWELL_OK`] if none has).
#[unsafe(no_mangle)]
pub extern "C" fn swell_last_error_code() -> SwellStatus {
    catch_unwind(|| LAST.with(|l| l.borrow().0)).unwrap_or(SWELL_ERR_PANIC)
}

#[cfg(test)]
mod tests {
    use std::ffi::CStr;

    use super::*;

    fn last() -> String {
        // SAFETY: the pointer is a NUL-terminated thread-local string, read before the next call.
        unsafe { CStr::from_ptr(swell_last_error_message()) }
            .to_string_lossy()
            .into_owned()
    }

    /// A panic inside an exported function's body is a status and a message, never an unwind
    /// into the caller; errors keep their code; success leaves the last error as it was.
    #[test]
    fn the_guard_turns_panics_and_errors_into_codes_and_messages() {
        let status = guard(|| panic!("boom at the boundary"));
        assert_eq!(status, SWELL_ERR_PANIC);
        assert_eq!(swell_last_error_code(), SWELL_ERR_PANIC);
        assert!(last().contains("boom at the boundary"), "{}", last());
        assert_eq!(
            guard(|| Err(Error::invalid("t = NaN must be finite"))),
            SWELL_ERR_INVALID_ARGUMENT
        );
        assert_eq!(last(), "t = NaN must be finite");
        assert_eq!(guard(|| Ok(())), SWELL_OK);
        assert_eq!(last(), "t = NaN must be finite");
        // A message with an interior NUL is cut there rather than lost.
        guard(|| Err(Error::invalid("before\0after")));
        assert_eq!(last(), "before");
    }
}
