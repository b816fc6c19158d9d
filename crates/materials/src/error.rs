//! Errors of the materials crate.

use std::path::PathBuf;

/// What can go wrong turning a material or light description into spectra.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A spectrum name that is not built in.
    #[error("unknown spectrum name `{name}` (known: {known})")]
    UnknownSpectrum {
        /// The name as written.
        name: String,
        /// The names that are accepted.
        known: &'static str,
    },
    /// A metal name with no built-in optical constants.
    #[error("unknown metal `{name}` (known: {known})")]
    UnknownMetal {
        /// The name as written.
        name: String,
        /// The names that are accepted.
        known: &'static str,
    },
    /// A CSV file has no column of the requested name.
    #[error("{}: no column named `{column}` (columns: {})", path.display(), available.join(", "))]
    MissingColumn {
        /// The CSV file.
        path: PathBuf,
        /// The column asked for.
        column: String,
        /// The columns the file has.
        available: Vec<String>,
    },
    /// A parameter outside its valid range.
    #[error("{what} = {value} is out of range ({range})")]
    OutOfRange {
        /// Which parameter.
        what: &'static str,
        /// The offending value.
        value: f64,
        /// The valid range, in words.
        range: &'static str,
    },
    /// Measured data that does not cover the wavelengths the renderer samples (nothing is extrapolated).
    #[error(
        "{what} covers {from}–{to} nm, but the renderer samples 360–830 nm: give data over that whole range \
         (values are interpolated, never extrapolated)"
    )]
    Uncovered {
        /// Which quantity.
        what: &'static str,
        /// The data's first wavelength (nm).
        from: f64,
        /// The data's last wavelength (nm).
        to: f64,
    },
    /// An optical constant given as an RGB colour.
    #[error("{what} is an optical constant, not a colour: give it as a number, a named or CSV spectrum, or samples")]
    NotAColour {
        /// Which quantity.
        what: &'static str,
    },
    /// A re-radiation matrix file that cannot be read as one (`line` 0: the file as a whole).
    #[error("{}:{line}: {message}", path.display())]
    Matrix {
        /// The CSV file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// What is wrong there.
        message: String,
    },
    /// A fluorescent material that would send back more energy than it receives at some wavelength.
    #[error("fluorescence: {what} = {value:.6} at {lambda} nm exceeds 1 (the surface would create energy)")]
    FluorescenceGainsEnergy {
        /// The sum that exceeds 1.
        what: &'static str,
        /// Where (nm).
        lambda: f64,
        /// Its value.
        value: f64,
    },
    /// Fluorescence on a model other than the Lambertian one.
    #[error("fluorescence needs a Lambertian material (`\"model\": \"diffuse\"`)")]
    FluorescenceModel,
    /// `base_color` beside a re-radiation matrix, whose diagonal is the reflectance.
    #[error("base_color: a fluorescence matrix's diagonal is the reflectance; remove `base_color`")]
    FluorescenceMatrixReflectance,
    /// An error from the colorimetry crate (a CSV file, an illuminant).
    #[error(transparent)]
    Colorimetry(#[from] colorimetry::Error),
}

/// Result with this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
