//! The crate's error type. Every variant carries the facts a user needs to fix the
//! input: which field, what was expected, what came.

use std::fmt;

/// Everything that can go wrong on a path that user input reaches.
#[derive(Debug)]
pub enum Error {
    /// A calibration file breaks the schema of `conventions.md` or holds impossible values.
    Calib {
        /// Dotted path of the offending field, e.g. `camera.fx`.
        field: String,
        /// What is wrong with it.
        problem: String,
    },
    /// A pattern spec file is malformed or inconsistent.
    Spec {
        /// Dotted path of the offending field, e.g. `families[1].angle_deg`.
        field: String,
        /// What is wrong with it.
        problem: String,
    },
    /// An image has a different size from the one required.
    ImageSize {
        /// What the calibration or spec requires (width, height).
        expected: (usize, usize),
        /// What the image has (width, height).
        got: (usize, usize),
    },
    /// Bytes that are not a decodable image (or a PFM/PNG that is broken).
    ImageDecode(String),
    /// A file could not be read or written.
    Io {
        /// The path involved.
        path: String,
        /// The operating system's reason.
        reason: String,
    },
    /// A request that makes no sense (unknown scene, bad option value, ...).
    Invalid(String),
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Calib { field, problem } => write!(f, "calibration: {field}: {problem}"),
            Error::Spec { field, problem } => write!(f, "pattern spec: {field}: {problem}"),
            Error::ImageSize { expected, got } => write!(
                f,
                "image is {}x{} but {}x{} was expected",
                got.0, got.1, expected.0, expected.1
            ),
            Error::ImageDecode(msg) => write!(f, "not a readable image: {msg}"),
            Error::Io { path, reason } => write!(f, "{path}: {reason}"),
            Error::Invalid(msg) => f.write_str(msg),
        }
    }
}

impl std::error::Error for Error {}

impl Error {
    /// An I/O error on `path`.
    pub fn io(path: impl AsRef<std::path::Path>, err: std::io::Error) -> Self {
        Error::Io {
            path: path.as_ref().display().to_string(),
            reason: err.to_string(),
        }
    }
}

/// Shorthand for results in this crate.
pub type Result<T> = std::result::Result<T, Error>;
