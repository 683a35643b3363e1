//! Python's side of carom's errors: `carom.SceneError`, OS errors by errno, the output-path
//! check made before a run, and a panic's text.

use pyo3::create_exception;
use pyo3::exceptions::{PyFileNotFoundError, PyIsADirectoryError, PyOSError, PyValueError};
use pyo3::prelude::*;
use std::path::Path;

create_exception!(
    carom,
    SceneError,
    PyValueError,
    "A scene that could not be parsed or accepted.\n\n\
     The message is the one `carom run` prints: the file (or `preset:NAME`, or `<string>` for\n\
     `from_toml`), the field and what is wrong with it. The attributes `origin` (str) and\n\
     `field` (str or None) hold the first two on their own."
);

/// An OSError for `path` (FileNotFoundError, PermissionError, ... by the errno of `error`):
/// `what` and the system's reason, e.g. `[Errno 2] cannot read scene file: No such file or
/// directory: 'x.toml'`.
pub(crate) fn os_error(what: &str, error: &std::io::Error, path: &Path) -> PyErr {
    let reason = error.to_string();
    // (the errno is in the exception already)
    let reason = match reason.rfind(" (os error ") {
        Some(at) => &reason[..at],
        None => &reason[..],
    };
    let message = format!("{what}: {reason}");
    match error.raw_os_error() {
        Some(errno) => PyOSError::new_err((errno, message, path.display().to_string())),
        None => PyOSError::new_err(format!("{message}: {}", path.display())),
    }
}

/// Refuses an output path whose folder is missing or which is a folder itself (what the CLI
/// checks before a run; a device or a pipe is refused by `carom_output::write_atomic`).
pub(crate) fn check_output_path(path: &Path) -> PyResult<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    if !dir.is_dir() {
        return Err(PyFileNotFoundError::new_err(format!(
            "cannot write {}: folder {} does not exist",
            path.display(),
            dir.display()
        )));
    }
    if path.is_dir() {
        return Err(PyIsADirectoryError::new_err(format!(
            "cannot write {}: it is a folder",
            path.display()
        )));
    }
    Ok(())
}

/// A `carom.SceneError` with `message`, and `origin` and `field` as attributes.
pub(crate) fn scene_error(
    py: Python<'_>,
    message: String,
    origin: &str,
    field: Option<&str>,
) -> PyErr {
    let err = SceneError::new_err(message);
    let value = err.value(py);
    // (setting attributes on a fresh exception object cannot fail but for memory)
    let _ = value.setattr("origin", origin);
    let _ = value.setattr("field", field);
    err
}

/// The text of a panic's payload.
pub(crate) fn panic_text(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        s.to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "a panic".to_string()
    }
}
