//! Typed errors of the library.
//!
//! Every error names the file it came from and, for structured input, the JSON path of the
//! offending field (`frames[12].contacts[3].link`), what was found and what was expected.
//! `anyhow` is used only in the command line (`src/bin/dexwarp`); everything below it returns
//! [`Error`].

use std::path::{Path, PathBuf};

/// Result alias used across the crate.
pub type Result<T, E = Error> = std::result::Result<T, E>;

/// What went wrong, with enough context for the user to fix the input.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written.
    #[error("{}: {action}: {source}", path.display())]
    Io {
        path: PathBuf,
        /// `"cannot read"`, `"cannot write"`, ...
        action: &'static str,
        #[source]
        source: std::io::Error,
    },

    /// The file is not well-formed JSON, or a field has the wrong type.
    #[error("{}: {field}: {message}", path.display())]
    Parse {
        path: PathBuf,
        /// JSON path of the field (`frames[3].joints`), or `line L, column C` for syntax errors.
        field: String,
        message: String,
    },

    /// A field parsed but its value is not acceptable.
    #[error("{}: {field}: {message}", path.display())]
    Invalid {
        path: PathBuf,
        /// JSON path (or URDF element) of the offending value.
        field: String,
        /// What was found and what was expected.
        message: String,
    },

    /// An input exceeds a size limit; refused before any large allocation.
    #[error(
        "{}: {what} is {found}, over the limit of {limit}; if the input is genuine, raise the limit with {flag}",
        path.display()
    )]
    TooLarge {
        path: PathBuf,
        what: &'static str,
        found: u64,
        limit: u64,
        /// The command-line option that raises this limit.
        flag: &'static str,
    },

    /// A stage produced a NaN or an infinity: the input drove a computation out of range.
    /// Caught at the stage boundary, so it is reported instead of written as a "pass".
    #[error(
        "{}: stage {stage}: {quantity} at {} is {value}; expected a finite number (the input drives this stage out of range; check the values it starts from)",
        path.display(),
        frame.map_or("the whole trajectory".to_string(), |f| format!("output frame {f}"))
    )]
    NonFinite {
        /// The config (warp) or demonstration (validate) of the run.
        path: PathBuf,
        stage: &'static str,
        /// Output frame, when the quantity is per frame.
        frame: Option<usize>,
        quantity: &'static str,
        value: f64,
    },

    /// A feature of the input that dexwarp does not support.
    #[error("{}: {field}: {message}", path.display())]
    Unsupported {
        path: PathBuf,
        field: String,
        message: String,
    },
}

impl Error {
    /// An [`Error::Invalid`] for `path` at `field`.
    pub fn invalid(path: &Path, field: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Invalid {
            path: path.to_path_buf(),
            field: field.into(),
            message: message.into(),
        }
    }

    /// An [`Error::Unsupported`] for `path` at `field`.
    pub fn unsupported(path: &Path, field: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Unsupported {
            path: path.to_path_buf(),
            field: field.into(),
            message: message.into(),
        }
    }

    /// An [`Error::Io`] for reading `path`.
    pub fn read(path: &Path, source: std::io::Error) -> Self {
        Error::Io {
            path: path.to_path_buf(),
            action: "cannot read",
            source,
        }
    }

    /// An [`Error::Io`] for writing `path`.
    pub fn write(path: &Path, source: std::io::Error) -> Self {
        Error::Io {
            path: path.to_path_buf(),
            action: "cannot write",
            source,
        }
    }
}
