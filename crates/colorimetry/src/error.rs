//! Errors of the colorimetry crate.

/// What can go wrong building spectra, reading spectral tables or naming illuminants.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A spectrum or table with no values.
    #[error("{origin}: no data")]
    Empty {
        /// File (or other source) name.
        origin: String,
    },
    /// A cell that is not a number.
    #[error("{origin}:{line}: column `{column}`: `{cell}` is not a number")]
    NotANumber {
        /// File name.
        origin: String,
        /// 1-based line number.
        line: usize,
        /// Column header.
        column: String,
        /// The offending text.
        cell: String,
    },
    /// A NaN or infinite value.
    #[error("{origin}:{line}: column `{column}`: {value} is not finite")]
    NotFinite {
        /// File name.
        origin: String,
        /// 1-based line number.
        line: usize,
        /// Column header.
        column: String,
        /// The value.
        value: f64,
    },
    /// A negative spectral value where only non-negative ones make sense.
    #[error("{origin}:{line}: column `{column}`: {value} is negative (spectra must be >= 0)")]
    Negative {
        /// File name.
        origin: String,
        /// 1-based line number.
        line: usize,
        /// Column header.
        column: String,
        /// The value.
        value: f64,
    },
    /// Wavelengths out of order or repeated.
    #[error("{origin}:{line}: wavelength {lambda} nm after {previous} nm (must increase)")]
    Unsorted {
        /// File name.
        origin: String,
        /// 1-based line number.
        line: usize,
        /// This row's wavelength.
        lambda: f64,
        /// The previous row's wavelength.
        previous: f64,
    },
    /// A wavelength that is zero or negative.
    #[error("{origin}:{line}: wavelength {lambda} nm must be > 0")]
    BadWavelength {
        /// File name.
        origin: String,
        /// 1-based line number.
        line: usize,
        /// The wavelength.
        lambda: f64,
    },
    /// A row with the wrong number of cells.
    #[error("{origin}:{line}: {found} cells, the header has {expected}")]
    Ragged {
        /// File name.
        origin: String,
        /// 1-based line number.
        line: usize,
        /// Cells found.
        found: usize,
        /// Cells expected.
        expected: usize,
    },
    /// A header with no spectrum column.
    #[error("{origin}:1: the header needs a wavelength column and at least one spectrum column")]
    NoColumns {
        /// File name.
        origin: String,
    },
    /// A file that could not be read. The I/O error is the `source`, not part of the message,
    /// so that a report walking the chain (anyhow's `{:#}`) states it once.
    #[error("{path}: cannot read file")]
    Io {
        /// The path.
        path: String,
        /// The I/O error.
        #[source]
        source: std::io::Error,
    },
    /// An illuminant name that is not known.
    #[error("unknown illuminant `{name}` (known: {known})")]
    UnknownIlluminant {
        /// The name as given.
        name: String,
        /// The accepted names.
        known: &'static str,
    },
    /// A parameter outside its valid range.
    #[error("{what} = {value} is out of range ({range})")]
    OutOfRange {
        /// Which parameter.
        what: &'static str,
        /// The value.
        value: f64,
        /// The valid range, in words.
        range: &'static str,
    },
    /// Primaries and white that do not define a colour space (collinear, or y = 0).
    #[error("colour space `{0}`: primaries and white point are degenerate")]
    DegenerateColorSpace(String),
}

/// Result with this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
