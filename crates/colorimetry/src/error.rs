//! Errors of the colorimetry crate.

/// What can go wrong building spectra, reading spectral tables or naming illuminants.
///
/// `line` is the 1-based line of a file; for samples not read from one (a manifest's
/// `samples`, piecewise-linear knots) it is the sample's 1-based index.
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
    #[error("{origin}:{line}: column `{column}`: {} is not finite", Num(*value))]
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
    #[error("{origin}:{line}: column `{column}`: {} is negative (spectra must be >= 0)", Num(*value))]
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
    #[error("{origin}:{line}: wavelength {} nm after {} nm (must increase)", Num(*lambda), Num(*previous))]
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
    #[error("{origin}:{line}: wavelength {} nm must be > 0", Num(*lambda))]
    BadWavelength {
        /// File name.
        origin: String,
        /// 1-based line number.
        line: usize,
        /// The wavelength.
        lambda: f64,
    },
    /// A wavelength beyond the longest a spectrum may name (100 000 nm, the far infrared).
    #[error("{origin}:{line}: wavelength {} nm is beyond the longest supported, {} nm", Num(*lambda), Num(*max))]
    WavelengthTooLong {
        /// File name.
        origin: String,
        /// 1-based line number.
        line: usize,
        /// The wavelength.
        lambda: f64,
        /// The limit (nm).
        max: f64,
    },
    /// Two rows closer in wavelength than a grid may be ([`crate::MIN_STEP_NM`]).
    #[error(
        "{origin}:{line}: wavelength {} nm is only {} nm after {} nm (rows must be at least {} nm apart)",
        Num(*lambda), Num(lambda - previous), Num(*previous), Num(*min)
    )]
    RowsTooClose {
        /// File name.
        origin: String,
        /// 1-based line number.
        line: usize,
        /// This row's wavelength.
        lambda: f64,
        /// The previous row's wavelength.
        previous: f64,
        /// The minimum spacing (nm).
        min: f64,
    },
    /// A grid step finer than [`crate::MIN_STEP_NM`].
    #[error("{origin}: wavelength step {} nm is finer than the minimum, {} nm", Num(*step), Num(*min))]
    StepTooSmall {
        /// What the grid belongs to.
        origin: String,
        /// The step (nm).
        step: f64,
        /// The minimum (nm).
        min: f64,
    },
    /// A grid (or table) with more samples than allowed; checked before allocating.
    #[error("{origin}{}: {} {what}, more than the limit of {limit}", AtLine(*line), Num(*samples))]
    TooManySamples {
        /// What the grid belongs to (a file name, for a table).
        origin: String,
        /// 1-based line number, for a table read from a file.
        line: Option<usize>,
        /// What is counted, in words (`samples`, or a table's values).
        what: &'static str,
        /// Samples it would need (f64: the count may not fit an integer).
        samples: f64,
        /// The limit.
        limit: usize,
    },
    /// A spectrum with no wavelength in the visible range, which holding its end values would
    /// turn into a flat spectrum made up across 360–830 nm.
    #[error("spectrum defined only at {}–{} nm, outside the visible range 360–830 nm", Num(*lambda_min), Num(*lambda_max))]
    OutsideVisible {
        /// First wavelength (nm).
        lambda_min: f64,
        /// Last wavelength (nm).
        lambda_max: f64,
    },
    /// A value so large that the colour sums would overflow (more than 1e30 in magnitude).
    #[error("{origin}:{line}: column `{column}`: {} is too large (spectra must be <= {})", Num(*value), Num(*max))]
    ValueTooLarge {
        /// File name.
        origin: String,
        /// 1-based line number.
        line: usize,
        /// Column header.
        column: String,
        /// The value.
        value: f64,
        /// The limit.
        max: f64,
    },
    /// A header with more columns than a table may have.
    #[error("{origin}:1: {columns} columns, more than the limit of {limit}")]
    TooManyColumns {
        /// File name.
        origin: String,
        /// Columns in the header.
        columns: usize,
        /// The limit.
        limit: usize,
    },
    /// A spectra file that is not a regular file (a device, a FIFO, a folder) or is larger
    /// than [`crate::MAX_CSV_BYTES`]; checked before reading.
    #[error("{path}: {reason}")]
    NotReadable {
        /// The path.
        path: String,
        /// Why, in words (with the size and limit where that is the reason).
        reason: String,
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
    #[error("{what} = {} is out of range ({range})", Num(*value))]
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

/// A number as an error message shows it: plain for ordinary magnitudes (`545`, `-0.1`,
/// `0.001`), scientific beyond them (`1e-300`, `1e308`), so a hostile value does not print
/// three hundred digits.
#[derive(Debug, Clone, Copy)]
pub struct Num(pub f64);

impl std::fmt::Display for Num {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let a = self.0.abs();
        if a == 0.0 || !a.is_finite() || (1e-4..1e7).contains(&a) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

/// `:line` after a file name when there is a line, nothing otherwise.
struct AtLine(Option<usize>);

impl std::fmt::Display for AtLine {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.0 {
            Some(line) => write!(f, ":{line}"),
            None => Ok(()),
        }
    }
}

/// Result with this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
