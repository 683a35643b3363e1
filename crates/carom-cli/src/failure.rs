//! Why a command failed, and the exit status that says so: 2 for bad input (a flag, a scene, a
//! checkpoint), 1 for a failure while working, 130 after an interrupt.

use std::path::{Path, PathBuf};

/// Exit status after an interrupt (128 + SIGINT), for the graceful stop and the immediate exit.
pub const INTERRUPTED: u8 = 130;

/// A failure with the exit status it deserves.
#[derive(Debug, thiserror::Error)]
pub enum Failure {
    /// Bad input: a flag, a file name (exit status 2). The message names the flag or field.
    #[error("{0}")]
    Input(String),
    /// A scene file that could not be read or accepted (exit status 2).
    #[error(transparent)]
    Scene(#[from] carom_scene::SceneError),
    /// A checkpoint that could not be read back (exit status 2).
    #[error("{path}: {source}")]
    Checkpoint {
        /// The checkpoint, as shown to the user.
        path: String,
        /// What the reader found.
        source: carom_output::checkpoint::CheckpointError,
    },
    /// An output file that could not be written (exit status 1).
    #[error("cannot write {}: {source}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// Any other failure while working (exit status 1).
    #[error("{0}")]
    Runtime(String),
    /// Stopped by Ctrl-C or SIGTERM (exit status 130).
    #[error("{0}")]
    Interrupted(String),
    /// An exit status without a message: a rank other than 0 of a split run (rank 0 says why).
    #[error("")]
    Quiet(u8),
}

impl Failure {
    /// Bad input (exit status 2).
    pub fn input(message: impl Into<String>) -> Self {
        Self::Input(message.into())
    }

    /// A failure while working (exit status 1).
    pub fn runtime(message: impl Into<String>) -> Self {
        Self::Runtime(message.into())
    }

    /// `path` could not be written.
    pub fn write(path: &Path, source: std::io::Error) -> Self {
        Self::Write {
            path: path.to_path_buf(),
            source,
        }
    }

    /// The process's exit status.
    pub fn status(&self) -> u8 {
        match self {
            Self::Input(_) | Self::Scene(_) | Self::Checkpoint { .. } => 2,
            Self::Write { .. } | Self::Runtime(_) => 1,
            Self::Interrupted(_) => INTERRUPTED,
            Self::Quiet(status) => *status,
        }
    }

    /// False for [`Failure::Quiet`]: nothing to print.
    pub fn speaks(&self) -> bool {
        !matches!(self, Self::Quiet(_))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn statuses_and_messages() {
        assert_eq!(Failure::input("--x: bad").status(), 2);
        assert_eq!(Failure::runtime("boom").status(), 1);
        let write = Failure::write(Path::new("a/b.csv"), std::io::Error::other("disk full"));
        assert_eq!(write.status(), 1);
        assert_eq!(write.to_string(), "cannot write a/b.csv: disk full");
        assert_eq!(Failure::Interrupted("stop".into()).status(), INTERRUPTED);
        assert!(!Failure::Quiet(130).speaks());
        let checkpoint = Failure::Checkpoint {
            path: "ck.bin".into(),
            source: carom_output::checkpoint::CheckpointError::NotACheckpoint,
        };
        assert_eq!(checkpoint.status(), 2);
        assert_eq!(
            checkpoint.to_string(),
            "ck.bin: not a carom checkpoint (bad magic bytes)"
        );
    }
}
