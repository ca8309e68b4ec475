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
    /// A calibration from another tool (OpenCV, Bouguet's toolbox) that cannot be
    /// imported: which format it was read as, which of its fields, what is wrong.
    Import {
        /// The format the file was read as, e.g. `OpenCV YAML`; `unknown` when none fits.
        format: &'static str,
        /// The field as the file names it, e.g. `cam_K` or `kc_left(6)`, or
        /// `line 3, column 7` for a syntax error.
        field: String,
        /// What is wrong with it.
        problem: String,
    },
    /// A pattern image that cannot be read into a spec (`pattern import`): which
    /// part of it and what is wrong.
    PatternImport {
        /// What the problem is in: `stripes`, `palette`, `sequence`, `margins`,
        /// `image` or an option (`scale`, `offset`).
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
    /// A pixel buffer whose length does not fit the size it is said to have.
    BufferLength {
        /// The stated size (width, height).
        size: (usize, usize),
        /// Values per pixel (4 for RGBA bytes, 1 for a plane of floats).
        per_pixel: usize,
        /// The buffer's length.
        got: usize,
    },
    /// An image smaller than a stage can work on.
    ImageTooSmall {
        /// The least (width, height).
        min: (usize, usize),
        /// What came.
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
    /// An input file holds something broken: which file, and the error inside it.
    InFile {
        /// The file.
        path: String,
        /// What is wrong with its content.
        source: Box<Error>,
    },
    /// A setting out of its range or of the wrong form (a command-line option, a
    /// scanner or pattern setting).
    Setting {
        /// The setting's name as the user gives it, e.g. `crosstalk`.
        name: &'static str,
        /// What is wrong with the value, and what would be right.
        problem: String,
    },
    /// The pattern spec and the calibration describe different projectors.
    ProjectorMismatch {
        /// The pattern's projector size (width, height).
        pattern: (u32, u32),
        /// The calibration's projector size (width, height).
        calibration: (u32, u32),
    },
    /// Frames for measuring the camera's colour mixing that cannot give it.
    ColourFrames(String),
    /// A scanned frame that the colour mixing cannot be read from
    /// ([`crate::calib::estimate_crosstalk_from_stripes`]).
    FrameMixing(String),
    /// A simulator scene or simulator setting that cannot be rendered.
    Scene(String),
    /// A broken invariant inside the library (not the input's fault): please report it.
    Internal(String),
}

/// Writes through to a formatter with control characters escaped (`\n` as the two
/// characters `\` `n`), so that an error stays one line whatever input text it quotes
/// (a JSON key holding an escaped newline, a file name).
struct OneLine<'a, 'b>(&'a mut fmt::Formatter<'b>);

impl fmt::Write for OneLine<'_, '_> {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        for c in s.chars() {
            if c.is_control() {
                write!(self.0, "{}", c.escape_default())?;
            } else {
                fmt::Write::write_char(self.0, c)?;
            }
        }
        Ok(())
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use fmt::Write as _;
        let f = &mut OneLine(f);
        match self {
            Error::Calib { field, problem } => write!(f, "calibration: {field}: {problem}"),
            Error::Import { format, field, problem } => {
                write!(f, "calibration import ({format}): {field}: {problem}")
            }
            Error::Spec { field, problem } => write!(f, "pattern spec: {field}: {problem}"),
            Error::PatternImport { field, problem } => write!(f, "pattern import: {field}: {problem}"),
            Error::ImageSize { expected, got } => write!(
                f,
                "image is {}x{} but {}x{} was expected",
                got.0, got.1, expected.0, expected.1
            ),
            Error::BufferLength { size: (w, h), per_pixel, got } => write!(
                f,
                "{got} values cannot be a {w}x{h} image of {per_pixel} per pixel (expected {})",
                w * h * per_pixel
            ),
            Error::ImageTooSmall { min, got } => {
                write!(f, "image of {}x{} is too small (at least {}x{})", got.0, got.1, min.0, min.1)
            }
            Error::ImageDecode(msg) => write!(f, "not a readable image: {msg}"),
            Error::Io { path, reason } => write!(f, "{path}: {reason}"),
            Error::InFile { path, source } => write!(f, "{path}: {source}"),
            Error::Setting { name, problem } => write!(f, "{name}: {problem}"),
            Error::ProjectorMismatch { pattern, calibration } => write!(
                f,
                "the pattern is {}x{} but the calibration's projector is {}x{}: they must describe the same projector",
                pattern.0, pattern.1, calibration.0, calibration.1
            ),
            Error::ColourFrames(msg) => write!(f, "colour frames: {msg}"),
            Error::FrameMixing(msg) => write!(f, "colour mixing from the frame: {msg}"),
            Error::Scene(msg) => write!(f, "simulator: {msg}"),
            Error::Internal(msg) => write!(f, "internal error (please report): {msg}"),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::InFile { source, .. } => Some(source.as_ref()),
            _ => None,
        }
    }
}

impl Error {
    /// `self` as found in the file at `path`.
    pub fn in_file(self, path: impl AsRef<std::path::Path>) -> Self {
        Error::InFile { path: path.as_ref().display().to_string(), source: Box::new(self) }
    }

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
