//! Scene errors: every message names the file and, where there is one, the field.

/// A scene that could not be read, parsed or accepted.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{origin}: {}{message}", field.as_ref().map(|f| format!("field `{f}`: ")).unwrap_or_default())]
pub struct SceneError {
    /// The file (or other origin, such as `preset:NAME`) the scene came from.
    pub origin: String,
    /// Dotted path of the offending field, e.g. `particles[3].radius`; `None` for errors that
    /// concern the whole file (unreadable, malformed TOML with its own location).
    pub field: Option<String>,
    /// What is wrong, in words.
    pub message: String,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_the_file_and_the_field() {
        let mut e = SceneError {
            origin: "bad.toml".into(),
            field: Some("particles[3].radius".into()),
            message: "must be a finite number > 0, got -1".into(),
        };
        assert_eq!(
            e.to_string(),
            "bad.toml: field `particles[3].radius`: must be a finite number > 0, got -1"
        );
        e.field = None;
        assert_eq!(
            e.to_string(),
            "bad.toml: must be a finite number > 0, got -1"
        );
    }
}
