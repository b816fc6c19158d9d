//! Where material and light spectra come from: built-in names, CSV files, RGB colours.

use std::path::Path;

pub use colorimetry::luminance_normalized;
use colorimetry::{DenselySampledSpectrum, Illuminant};

use crate::error::{Error, Result};

/// The spectrum names [`named_spectrum`] accepts, for error messages and `--help`.
pub const KNOWN_SPECTRUM_NAMES: &str =
    "D65, D50, A, F2, F11, E, D<kelvin> (daylight, 4000-25000), bb<kelvin> (Planck), colorchecker:1..24, tcs:1..14";

/// A built-in spectrum by name: illuminants as `colorimetry` names them (`D65`, `F11`,
/// `D9300`, `bb6500`, …), ColorChecker patches `colorchecker:N` (1 = dark skin … 24 = black,
/// chart order) and CIE 13.3 test colours `tcs:N`.
pub fn named_spectrum(name: &str) -> Result<DenselySampledSpectrum> {
    let unknown = || Error::UnknownSpectrum { name: name.to_owned(), known: KNOWN_SPECTRUM_NAMES };
    let trimmed = name.trim();
    if let Some((set, index)) = trimmed.split_once(':') {
        let table = match set.to_ascii_lowercase().as_str() {
            "colorchecker" => colorimetry::colorchecker(),
            "tcs" => colorimetry::tcs(),
            _ => return Err(unknown()),
        };
        let i: usize = index.trim().parse().map_err(|_| unknown())?;
        return match i.checked_sub(1).and_then(|i| table.get(i)) {
            Some(patch) => Ok(patch.spectrum.clone()),
            None => Err(unknown()),
        };
    }
    let illuminant = Illuminant::parse(trimmed).map_err(|_| unknown())?;
    Ok(illuminant.spectrum()?)
}

/// One column of a CSV spectra file (the first spectrum column when `column` is `None`).
pub fn csv_spectrum(path: &Path, column: Option<&str>) -> Result<DenselySampledSpectrum> {
    let table = colorimetry::read_spectra_csv(path)?;
    let found = match column {
        Some(c) => table.iter().find(|s| s.name == c),
        None => table.first(),
    };
    match found {
        Some(s) => Ok(s.spectrum.clone()),
        None => Err(Error::MissingColumn {
            path: path.to_owned(),
            column: column.unwrap_or("<first>").to_owned(),
            available: table.iter().map(|s| s.name.clone()).collect(),
        }),
    }
}

/// A smooth reflectance in [0, 1] whose colour under D65 is the given linear sRGB colour
/// (Jakob & Hanika 2019 upsampling; components are clamped to [0, 1]).
pub fn reflectance_from_rgb(rgb: [f32; 3]) -> DenselySampledSpectrum {
    colorimetry::upsample_reflectance(rgb.map(f64::from)).to_spectrum()
}

/// An emission spectrum for a light given as a linear sRGB colour: the smooth reflectance
/// of `rgb / max(rgb)` times D65, normalised to luminance and scaled by the colour's
/// luminance, so white (1, 1, 1) is D65 with Y = 1.
///
/// This is the recipe every scene with an RGB light (glTF lights and emissive materials, OBJ
/// `Ke`) has been rendered with; it is kept as it is so that renders stay bit-identical.
/// pbrt-v4's `RGBIlluminantSpectrum` ([`colorimetry::RgbIlluminantSpectrum`]) divides by
/// `2 · max(rgb)` instead, which keeps the sigmoid's colour inside the reachable set (here
/// white is off by ΔE00 0.0035) but gives other metamers: measured, the same light colours
/// agree in luminance to 2e-4 and in colour to ΔE00 0.004, yet ColorChecker patches lit by
/// saturated lights differ by up to ΔE00 10 (a red (1, 0, 0) light; 0.5 for (1, 0.8, 0.6)).
/// Switching is a rendering change to make on purpose, not a refactoring.
pub fn illuminant_from_rgb(rgb: [f32; 3]) -> Result<DenselySampledSpectrum> {
    let max = rgb.iter().copied().fold(0.0f32, f32::max);
    if !(max.is_finite()) || rgb.iter().any(|&c| c < 0.0) {
        return Err(Error::OutOfRange { what: "light colour component", value: max.into(), range: "finite, >= 0" });
    }
    if max == 0.0 {
        return Ok(DenselySampledSpectrum::constant(0.0));
    }
    let shape = reflectance_from_rgb(rgb.map(|c| c / max));
    let d65 = Illuminant::D65.spectrum()?;
    let spd = luminance_normalized(&shape.product(&d65));
    // Luminance of the requested linear sRGB colour (Rec. 709 Y coefficients, IEC 61966-2-1).
    let luminance = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
    Ok(spd.scaled(f64::from(luminance)))
}

/// Whether a spectrum is the same at every wavelength of the visible range: such spectra
/// need no per-wavelength work.
pub fn is_flat(s: &DenselySampledSpectrum) -> bool {
    let first = s.eval(colorimetry::LAMBDA_MIN as f64);
    let mut lambda = colorimetry::LAMBDA_MIN as f64;
    while lambda <= colorimetry::LAMBDA_MAX as f64 {
        if s.eval(lambda) != first {
            return false;
        }
        lambda += 1.0;
    }
    true
}

/// The largest jump between neighbouring 1 nm samples relative to the spectrum's maximum
/// over the visible range: near 0 for smooth spectra (daylight, reflectances); large for
/// line spectra (F11's mercury and rare-earth lines), which need fine wavelength sampling.
pub fn spikiness(s: &DenselySampledSpectrum) -> f64 {
    let (lo, hi) = (colorimetry::LAMBDA_MIN as f64, colorimetry::LAMBDA_MAX as f64);
    let max = s.max_value();
    if max <= 0.0 {
        return 0.0;
    }
    // Second difference at 5 nm spacing: a line that occupies one 5 nm row (how the CIE
    // tabulates F-series lines) gives a large value, a smooth curve a small one.
    let mut worst: f64 = 0.0;
    let mut lambda = lo + 5.0;
    while lambda + 5.0 <= hi {
        let d2 = s.eval(lambda - 5.0) - 2.0 * s.eval(lambda) + s.eval(lambda + 5.0);
        worst = worst.max(d2.abs() / max);
        lambda += 1.0;
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colorchecker_names_are_one_based_chart_order() {
        // Patch 19 is "white 9.5": reflectance ≈ 0.9 at 560 nm (Ohta 1997 table).
        let white = named_spectrum("colorchecker:19").unwrap();
        assert!((white.eval(560.0) - 0.9).abs() < 0.05, "{}", white.eval(560.0));
        assert!(matches!(named_spectrum("colorchecker:25"), Err(Error::UnknownSpectrum { .. })));
        assert!(matches!(named_spectrum("colorchecker:0"), Err(Error::UnknownSpectrum { .. })));
        assert!(matches!(named_spectrum("nonsense"), Err(Error::UnknownSpectrum { .. })));
    }

    /// The RGB light recipe every scene has been rendered with, pinned bit for bit by its
    /// values at 450, 550 and 650 nm (recorded from the recipe as it is, printed as the shortest
    /// decimals that give back the same f64; that its luminance sum is bit-identical to the copy
    /// it replaced is colorimetry's `results_are_bit_identical_to_the_copies_they_replace`). A
    /// change here is a rendering change.
    #[test]
    fn illuminant_from_rgb_is_unchanged() {
        for (rgb, golden) in [
            ([1.0f32, 1.0, 1.0], [1.183_400_616_383_586_6, 1.052_304_836_549_098_8, 0.809_378_538_900_697_4]),
            ([1.0, 0.8, 0.6], [0.726_238_847_372_961_5, 0.867_865_166_300_816_4, 0.781_239_277_951_260_6]),
            ([3.0, 0.0, 0.5], [0.264_776_082_473_618_5, 0.098_045_514_856_852_44, 2.413_949_668_897_197_8]),
        ] {
            let spd = illuminant_from_rgb(rgb).unwrap();
            for (lambda, expected) in [450.0, 550.0, 650.0].into_iter().zip(golden) {
                assert_eq!(spd.eval(lambda), expected, "{rgb:?} at {lambda} nm");
            }
            // Scaled to the colour's Rec. 709 luminance.
            let y = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
            assert!((colorimetry::relative_luminance(&spd) - f64::from(y)).abs() < 1e-12, "{rgb:?}");
        }
    }

    #[test]
    fn f11_is_spiky_and_d65_and_reflectances_are_not() {
        let f11 = spikiness(&named_spectrum("F11").unwrap());
        let d65 = spikiness(&named_spectrum("D65").unwrap());
        let red = spikiness(&named_spectrum("colorchecker:15").unwrap());
        // Measured: F2 1.52, F11 1.01; D50 0.22, D65 0.16 (the kinks of the 10 nm daylight
        // basis); A and Planck < 0.001; ColorChecker ≤ 0.088, TCS ≤ 0.073.
        assert!(f11 > 0.8, "F11 {f11}");
        assert!(d65 < 0.3, "D65 {d65}");
        assert!(red < 0.1, "red {red}");
        assert!(is_flat(&DenselySampledSpectrum::constant(0.9)));
        assert!(!is_flat(&named_spectrum("colorchecker:15").unwrap()));
    }
}
