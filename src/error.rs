//! Errors and exit statuses.
//!
//! Bad input (scene files, CLI flags, a feature the build lacks) is an [`Error::Input`] and
//! exits with status 2; a run that fails (NaN, a particle leaving the domain, I/O) is an
//! [`Error::Run`] and exits with status 1. Neither panics.

use std::fmt;
use std::path::{Path, PathBuf};

/// Where in an input file a problem was found.
#[derive(Debug, Clone, PartialEq)]
pub struct Location {
    /// File the value came from (or `--set` for a command-line override).
    pub file: PathBuf,
    /// 1-based line number, when known.
    pub line: Option<usize>,
}

/// Every error hsph reports to a user.
#[derive(Debug, Clone, PartialEq)]
pub enum Error {
    /// Invalid input: exit status 2.
    Input {
        /// File and line, when the problem is in a file.
        at: Option<Location>,
        /// Dotted key path, e.g. `discretisation.dx` or `fluid[0].min`.
        key: String,
        /// What is wrong and what would be valid.
        message: String,
    },
    /// A run that failed after it started: exit status 1.
    Run(String),
    /// A run stopped by a signal before it had anything to keep (during its set-up): exit
    /// status 3, like a run stopped at a step boundary ([`crate::signals`]).
    Stopped(String),
}

impl Error {
    /// An input error tied to a key, without a file location.
    pub fn input(key: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Input {
            at: None,
            key: key.into(),
            message: message.into(),
        }
    }

    /// A run-time failure.
    pub fn run(message: impl Into<String>) -> Self {
        Error::Run(message.into())
    }

    /// An I/O failure on `path`.
    pub fn io(path: &Path, e: std::io::Error) -> Self {
        Error::Run(format!("{}: {e}", path.display()))
    }

    /// Process exit status for this error.
    pub fn exit_code(&self) -> i32 {
        match self {
            Error::Input { .. } => 2,
            Error::Run(_) => 1,
            Error::Stopped(_) => 3,
        }
    }

    /// Asking for a cargo feature this binary was built without.
    pub fn missing_feature(what: &str, feature: &str) -> Self {
        Error::input(
            what,
            format!(
                "this hsph was built without the `{feature}` cargo feature; rebuild with \
                 `cargo build --release --features {feature}` (see README, 'Optional features')"
            ),
        )
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Input { at, key, message } => {
                write!(f, "error: ")?;
                if let Some(at) = at {
                    write!(f, "{}", at.file.display())?;
                    if let Some(l) = at.line {
                        write!(f, ":{l}")?;
                    }
                    write!(f, ": ")?;
                }
                if key.is_empty() {
                    write!(f, "{message}")
                } else {
                    write!(f, "key `{key}`: {message}")
                }
            }
            Error::Run(m) => write!(f, "error: {m}"),
            Error::Stopped(m) => write!(f, "stopped: {m}"),
        }
    }
}

impl std::error::Error for Error {}

/// Result alias used throughout hsph.
pub type Result<T> = std::result::Result<T, Error>;
