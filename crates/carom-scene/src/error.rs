//! Scene errors: every message names the file and, where there is one, the field.

use std::fmt;

/// A scene that could not be read, parsed or accepted.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneError {
    /// The file (or other origin, such as `preset:NAME`) the scene came from.
    pub origin: String,
    /// Dotted path of the offending field, e.g. `particles[3].radius`; `None` for errors that
    /// concern the whole file (unreadable, malformed TOML with its own location).
    pub field: Option<String>,
    /// What is wrong, in words.
    pub message: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.field {
            Some(field) => write!(f, "{}: field `{}`: {}", self.origin, field, self.message),
            None => write!(f, "{}: {}", self.origin, self.message),
        }
    }
}

impl std::error::Error for SceneError {}
