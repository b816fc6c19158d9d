//! Where material and light spectra come from: built-in names, CSV files, RGB colours.

use std::path::Path;

pub use colorimetry::luminance_normalized;
use colorimetry::{DenselySampledSpectrum, Illuminant, RgbIlluminantSpectrum, Spectrum};

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

/// Rec. 709 luminance coefficients of linear sRGB (ITU-R BT.709-6 item 3.3; IEC 61966-2-1):
/// the Y a light of colour `rgb` must have, so that cd, lux and nits stay exact.
pub const REC709_LUMINANCE: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// The emission spectrum of a light given as a linear sRGB colour: the one RGB → illuminant
/// recipe, pbrt-v4's `RGBIlluminantSpectrum` (`scale · s(λ) · D65(λ)`, `scale = 2 · max(rgb)`,
/// `s` the sigmoid of `rgb / scale`), the form environment-map texels take too.
///
/// The sigmoid is the exact fit ([`colorimetry::RgbIlluminantSpectrum::fit`], about 20 µs)
/// rather than the table lookup texels use: this runs once per light at assembly, and the fit's
/// colour is the requested one to ΔE00 < 1e-6 where the lookup is off by up to ΔE00 1.2 for
/// saturated reds. The two agree to the lookup's accuracy (about 0.3 % of the scale).
///
/// The spectrum on the 1 nm grid is then scaled so that its relative luminance (Σ S ȳ / Σ ȳ) is
/// exactly the colour's Rec. 709 Y ([`REC709_LUMINANCE`]): that is what the photometric units
/// (cd, lux, nits) rest on. The factor is 1 for white (measured 6e-12) and differs from 1 by
/// the sRGB matrix's Y row (0.212639, 0.715169, 0.072192, from the primaries and white) against
/// the rounded Rec. 709 coefficients: measured 1.8e-4 for (1, 0, 0), 1.1e-4 for (0, 0, 1),
/// 4e-5 for (0, 1, 0) (test `illuminant_from_rgb_is_pbrts_recipe_at_the_colours_luminance`).
pub fn illuminant_from_rgb(rgb: [f32; 3]) -> Result<DenselySampledSpectrum> {
    let max = rgb.iter().copied().fold(0.0f32, f32::max);
    if !(max.is_finite()) || rgb.iter().any(|&c| c < 0.0) {
        return Err(Error::OutOfRange { what: "light colour component", value: max.into(), range: "finite, >= 0" });
    }
    let luminance: f32 = rgb.iter().zip(REC709_LUMINANCE).map(|(c, k)| c * k).sum();
    if luminance == 0.0 {
        return Ok(DenselySampledSpectrum::constant(0.0));
    }
    let spd = Spectrum::RgbIlluminant(RgbIlluminantSpectrum::fit(rgb.map(f64::from))).to_densely_sampled();
    Ok(luminance_normalized(&spd).scaled(f64::from(luminance)))
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

    /// Relative XYZ (Σ S x̄ / Σ ȳ …) of a light spectrum against the sRGB XYZ of its colour, as
    /// ΔE00 with the colour's own luminance as white's Y (so a bright light is judged as a
    /// white-1 one).
    fn light_delta_e(rgb: [f32; 3], spd: &DenselySampledSpectrum) -> f64 {
        let srgb = colorimetry::RgbColorSpace::srgb();
        let want = srgb.rgb_to_xyz(colorimetry::Rgb { r: rgb[0].into(), g: rgb[1].into(), b: rgb[2].into() });
        let got = colorimetry::relative_xyz(spd);
        let scale = f64::from(rgb.iter().copied().fold(0.0f32, f32::max));
        let white = srgb.rgb_to_xyz(colorimetry::Rgb { r: scale, g: scale, b: scale });
        colorimetry::delta_e_2000(colorimetry::Lab::from_xyz(got, white), colorimetry::Lab::from_xyz(want, white))
    }

    /// (b) and (c): the light's XYZ is the sRGB XYZ of its colour, saturated primaries
    /// included, and its luminance the Rec. 709 Y to 1e-6; and it is pbrt-v4's spectrum (the
    /// exact fit) up to that luminance factor, which stays within 1e-4 of 1.
    #[test]
    fn illuminant_from_rgb_is_pbrts_recipe_at_the_colours_luminance() {
        for rgb in [
            [1.0f32, 1.0, 1.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [1.0, 0.8, 0.6],
            [3.0, 0.0, 0.5],
            [0.02, 0.09, 0.3],
            [81_527.0, 60_000.0, 41_000.0],
        ] {
            let spd = illuminant_from_rgb(rgb).unwrap();
            let y: f64 = rgb.iter().zip(REC709_LUMINANCE).map(|(c, k)| f64::from(*c) * f64::from(k)).sum();
            let luminance = colorimetry::relative_luminance(&spd);
            assert!((luminance / y - 1.0).abs() < 1e-6, "{rgb:?}: Y {luminance} vs {y}");
            // Measured: white 3e-10; (1, 0, 0) 4.3e-3, (3, 0, 0.5) 3.9e-3, blue 1.5e-3, green
            // 1.0e-3, the others ≤ 1.1e-3: what is left is the luminance scaled from the sRGB
            // matrix's Y row to the rounded Rec. 709 coefficients.
            let de = light_delta_e(rgb, &spd);
            assert!(de < 5e-3, "{rgb:?}: ΔE00 {de}");
            let pbrt = RgbIlluminantSpectrum::fit(rgb.map(f64::from));
            let factor = spd.eval(550.0) / pbrt.eval(550.0);
            assert!((factor - 1.0).abs() < 3e-4, "{rgb:?}: luminance factor {factor}");
            for lambda in [400.0, 450.0, 500.0, 600.0, 650.0, 700.0] {
                let want = factor * pbrt.eval(lambda);
                assert!((spd.eval(lambda) - want).abs() <= 1e-12 * want.max(1e-30), "{rgb:?} at {lambda}");
            }
        }
        assert_eq!(illuminant_from_rgb([0.0; 3]).unwrap().max_value(), 0.0);
        assert!(illuminant_from_rgb([1.0, -0.1, 0.0]).is_err());
        assert!(illuminant_from_rgb([f32::INFINITY, 0.0, 0.0]).is_err());
    }

    /// The recipe this replaced (sigmoid of rgb / max × D65) has the right colour but another
    /// metamer: the comparison with pbrt-v4's spectrum above fails on it (measured for
    /// (1, 0.8, 0.6): colour within ΔE00 0.01 of the new one's, spectra up to 24 % apart over
    /// 400–700 nm, 4.7 % at 650 nm), so that check can fail.
    #[test]
    fn the_replaced_recipe_is_another_metamer() {
        let rgb = [1.0f32, 0.8, 0.6];
        let old = luminance_normalized(&reflectance_from_rgb(rgb).product(&Illuminant::D65.spectrum().unwrap()))
            .scaled(0.2126 + 0.7152 * 0.8 + 0.0722 * 0.6);
        assert!(light_delta_e(rgb, &old) < 0.01, "{}", light_delta_e(rgb, &old));
        let new = illuminant_from_rgb(rgb).unwrap();
        let worst = (400..=700).step_by(10).map(|nm| (old.eval(f64::from(nm)) / new.eval(f64::from(nm)) - 1.0).abs());
        let worst = worst.fold(0.0, f64::max);
        assert!(worst > 0.05);
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
