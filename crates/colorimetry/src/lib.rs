//! `colorimetry`: spectra and the colour they make.
//!
//! Densely sampled spectra and the few wavelengths a path carries; the CIE 1931 2° and
//! 1964 10° observers; illuminants (D65, D50, A, F2, F11, E, daylight at any CCT, Planck);
//! spectrum → XYZ exactly as Lee et al. (2004) write it (X = k Σ S R x̄ Δλ,
//! k = 100 / Σ S ȳ Δλ); RGB colour spaces from primaries and white (sRGB, Display P3,
//! Rec. 2020, a D93 display and the paper's 9300 K display); Bradford adaptation; the sRGB
//! curve; CIELAB and CIEDE2000; RGB → spectrum upsampling (Jakob & Hanika 2019); CSV spectra.
//! All tables are embedded: nothing is read at run time.
//!
//! **Invariant:** depends on no workspace crate and knows nothing of rays, meshes or
//! materials. f64 for tables and colorimetric sums; [`SampledSpectrum`] is f32 (hot path).
//!
//! ```
//! use colorimetry::{DenselySampledSpectrum, Illuminant, Integration, Observer, reflectance_to_xyz};
//!
//! // The D65 white point (CIE 015:2018: x, y = 0.31272, 0.32903).
//! let d65 = Illuminant::D65.spectrum()?;
//! let white = DenselySampledSpectrum::constant(1.0);
//! let xyz = reflectance_to_xyz(&white, &d65, Observer::Cie1931, &Integration::Step(1.0));
//! let [x, y] = xyz.chromaticity();
//! assert!((x - 0.31272).abs() < 3e-5 && (y - 0.32903).abs() < 3e-5);
//! assert!((xyz.y - 100.0).abs() < 1e-9);
//! # Ok::<(), colorimetry::Error>(())
//! ```
#![warn(missing_docs)]

mod continuous;
mod csv;
mod data;
mod error;
mod lab;
mod luminance;
mod rgb;
mod spectrum;
#[cfg(test)]
mod test_support;
mod xyz;

pub use continuous::{
    BlackbodySpectrum, PiecewiseLinearSpectrum, RgbIlluminantSpectrum, RgbUnboundedSpectrum, Spectrum, srgb_illuminant,
};
pub use csv::{MAX_CSV_BYTES, NamedSpectrum, parse_spectra_csv, read_spectra_csv};
pub use data::{
    Cmf, Illuminant, KNOWN_ILLUMINANTS, Observer, blackbody, colorchecker, daylight_basis, daylight_chromaticity,
    daylight_m1_m2, tcs,
};
pub use error::{Error, Num, Result};
pub use lab::{Lab, delta_e_2000};
pub use luminance::{K_M, luminance_normalized, luminous_efficacy, relative_luminance, relative_xyz, y_sum};
pub use rgb::{Rgb, RgbColorSpace, bradford, quantize_u8, srgb_decode, srgb_encode, srgb_encode_u8};
pub use spectrum::{
    DenselySampledSpectrum, LAMBDA_MAX, LAMBDA_MIN, MIN_SPECTRUM_VALUE, MIN_STEP_NM, SampledSpectrum,
    SampledWavelengths, VISIBLE_PDF_CENTER_NM, VISIBLE_PDF_RATE_PER_NM, visible_wavelength_shape,
};
pub use xyz::{Integration, Xyz, emission_to_xyz, reflectance_to_xyz};

// --- upsampling ---
mod upsample;
pub use upsample::{
    RgbSigmoid, RgbToSpectrumTable, SigmoidPolynomial, UpsamplingTable, build_upsampling_table, upsample_illuminant,
    upsample_illuminant_spectrum, upsample_reflectance,
};
