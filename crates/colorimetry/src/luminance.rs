//! Luminance relative to an equal-energy spectrum of value 1: the one place for
//! `Σ S ȳ / Σ ȳ` (CIE 1931 2°, 1 nm steps over 360–830 nm).
//!
//! This is the paper's `k = 100 / Σ S ȳ Δλ` without the factor 100, and the scale
//! every light in spectrace is given in ("intensity 1 = the luminance of an
//! equal-energy light of value 1"). The sums run in the same order, over the same
//! wavelengths, as the copies they replace or are to replace, and give the same bits
//! (test `results_are_bit_identical_to_the_copies_they_replace`):
//! `materials::luminance_normalized` (now this one) and the integrator's
//! `relative_luminance` and `unit_xyz` (still its own, to be switched). The D65 of the
//! RGB illuminant ([`crate::srgb_illuminant`]), which had its own copy here, is within
//! one rounding of it, not bit-identical: the scale is applied as `v · (Σȳ / Σ S ȳ)`
//! rather than `v · Σȳ / Σ S ȳ` (measured: 151 of 471 values differ, by at most
//! 2.5e-16 relative).

use std::sync::LazyLock;

use crate::data::Observer;
use crate::spectrum::{DenselySampledSpectrum, visible_nm};
use crate::xyz::{Integration, Xyz, emission_to_xyz};

/// `Σ ȳ(λ)` at λ = 360, 361, …, 830 nm (CIE 1931 2°), summed in that order: 106.856917
/// (`data/PROVENANCE.md`; the unit test recomputes it).
static Y_SUM: LazyLock<f64> = LazyLock::new(|| y_weighted_sum(|_| 1.0));

/// `Σ f(λ) ȳ(λ)` over λ = 360, 361, …, 830 nm (CIE 1931 2°), in that order.
pub(crate) fn y_weighted_sum(f: impl Fn(f64) -> f64) -> f64 {
    let y = &Observer::Cie1931.cmf().y;
    let mut sum = 0.0;
    for lambda in visible_nm() {
        sum += f(lambda) * y.eval(lambda);
    }
    sum
}

/// `Σ ȳ` at 1 nm over 360–830 nm (CIE 1931 2°): the luminance sum of the constant 1.
pub fn y_sum() -> f64 {
    *Y_SUM
}

/// Luminance of an emission spectrum relative to an equal-energy spectrum of value 1:
/// `Σ S ȳ / Σ ȳ` at 1 nm over 360–830 nm (CIE 1931 2°). D65 scaled by
/// [`luminance_normalized`] gives 1.
pub fn relative_luminance(spd: &DenselySampledSpectrum) -> f64 {
    y_weighted_sum(|lambda| spd.eval(lambda)) / y_sum()
}

/// The spectrum scaled to relative luminance 1 ([`relative_luminance`]): every value times
/// `Σ ȳ / Σ S ȳ`. A spectrum of zero or negative luminance is returned unchanged, as is one
/// whose scale would not be finite.
pub fn luminance_normalized(spd: &DenselySampledSpectrum) -> DenselySampledSpectrum {
    let sy = y_weighted_sum(|lambda| spd.eval(lambda));
    // Spectra hold no value below f32's smallest normal (`flush_tiny`), so Σ S ȳ is either 0 or
    // far above the f64 subnormals whose reciprocal overflows; the check keeps an infinite scale
    // (which would zero the spectrum through `map`) out regardless.
    let scale = y_sum() / sy;
    if sy > 0.0 && scale.is_finite() { spd.scaled(scale) } else { spd.clone() }
}

/// K_m, the maximum luminous efficacy of photopic vision: 683 lm/W at 540 THz (≈ 555 nm), the
/// SI definition of the candela (BIPM, SI Brochure 9th ed., 2019).
pub const K_M: f64 = 683.0;

/// Luminous efficacy of radiation with spectrum `spd` (lm/W): `K_m Σ S ȳ / Σ S` at 1 nm over
/// 360–830 nm (CIE 1931 2°) — what turns a radiant quantity (W, W/m², W/(m² sr)) of that
/// spectrum into its photometric one (lm, lux, cd/m²). 0 for a spectrum with no power.
pub fn luminous_efficacy(spd: &DenselySampledSpectrum) -> f64 {
    let power: f64 = visible_nm().map(|lambda| spd.eval(lambda)).sum();
    if power > 0.0 { K_M * y_weighted_sum(|lambda| spd.eval(lambda)) / power } else { 0.0 }
}

/// XYZ of an emission spectrum relative to an equal-energy spectrum of value 1:
/// `X = Σ S x̄ / Σ ȳ` (and Y, Z alike) at 1 nm over 360–830 nm (CIE 1931 2°), so Y is
/// [`relative_luminance`].
pub fn relative_xyz(spd: &DenselySampledSpectrum) -> Xyz {
    let xyz = emission_to_xyz(spd, Observer::Cie1931, &Integration::Step(1.0));
    let y = y_sum();
    Xyz { x: xyz.x / y, y: xyz.y / y, z: xyz.z / y }
}

#[cfg(test)]
mod tests {
    #[test]
    fn luminous_efficacy_matches_published_values() {
        use super::*;
        // Monochromatic 555 nm: ȳ(555) = 1.0 in the CIE 1931 table, so 683 lm/W.
        let line =
            DenselySampledSpectrum::new(360.0, 1.0, (360..=830).map(|nm| if nm == 555 { 1.0 } else { 0.0 }).collect())
                .unwrap();
        assert!((luminous_efficacy(&line) - 683.0).abs() < 1e-9, "{}", luminous_efficacy(&line));
        // Equal energy over 360–830 nm: 683 · Σȳ / 471 = 683 · 106.856917 / 471 = 154.95 lm/W.
        let flat = DenselySampledSpectrum::constant(2.5);
        assert!((luminous_efficacy(&flat) - 683.0 * 106.856_917 / 471.0).abs() < 1e-4);
        assert_eq!(luminous_efficacy(&DenselySampledSpectrum::constant(0.0)), 0.0);
    }

    use super::*;
    use crate::data::Illuminant;

    #[test]
    fn y_sum_is_the_table_sum() {
        // data/PROVENANCE.md quotes Σȳ = 106.856917 (6 decimals).
        assert!((y_sum() - 106.856_917).abs() < 1e-6, "{}", y_sum());
        assert_eq!(relative_luminance(&DenselySampledSpectrum::constant(1.0)), 1.0);
    }

    #[test]
    fn normalised_d65_has_unit_luminance() {
        let d65 = Illuminant::D65.spectrum().unwrap();
        // D65 at S(560) = 100 has relative luminance about 100 (a spectrum of 100 everywhere
        // would have exactly 100; D65 is near 100 where ȳ is large).
        let raw = relative_luminance(&d65);
        assert!((raw - 100.0).abs() < 5.0, "{raw}");
        let unit = luminance_normalized(&d65);
        assert!((relative_luminance(&unit) - 1.0).abs() < 1e-15, "{}", relative_luminance(&unit));
        assert!((relative_xyz(&unit).y - 1.0).abs() < 1e-15);
        // Chromaticity unchanged by the scale: CIE 015:2018 D65 xy (0.31272, 0.32903) to the
        // 3e-5 the 1 nm interpolated table reproduces (see `d65_white_point_matches_cie015`).
        let [x, y] = relative_xyz(&unit).chromaticity();
        assert!((x - 0.31272).abs() < 3e-5 && (y - 0.32903).abs() < 3e-5, "{x} {y}");
        // Black stays black (no division by zero).
        let black = DenselySampledSpectrum::constant(0.0);
        assert_eq!(luminance_normalized(&black), black);
    }

    /// The replaced copies, written out as they were, give the same bits.
    #[test]
    fn results_are_bit_identical_to_the_copies_they_replace() {
        let y = &Observer::Cie1931.cmf().y;
        for spd in [
            Illuminant::D65.spectrum().unwrap(),
            Illuminant::F11.spectrum().unwrap(),
            Illuminant::A.spectrum().unwrap(),
            DenselySampledSpectrum::new(400.5, 3.25, vec![0.1, 2.0, 0.7, 5.0, 1e-3]).unwrap(),
        ] {
            // materials::luminance_normalized and integrator path.rs relative_luminance.
            let (mut sy, mut yy) = (0.0, 0.0);
            let mut lambda = 360.0;
            while lambda <= 830.0 {
                let ybar = y.eval(lambda);
                sy += spd.eval(lambda) * ybar;
                yy += ybar;
                lambda += 1.0;
            }
            assert_eq!(relative_luminance(&spd).to_bits(), (sy / yy).to_bits());
            assert_eq!(luminance_normalized(&spd), spd.scaled(yy / sy));
            // integrator spectral.rs unit_xyz.
            let integration = Integration::Step(1.0);
            let xyz = emission_to_xyz(&spd, Observer::Cie1931, &integration);
            let ybar = emission_to_xyz(&DenselySampledSpectrum::constant(1.0), Observer::Cie1931, &integration).y;
            let got = relative_xyz(&spd);
            assert_eq!(
                [got.x, got.y, got.z].map(f64::to_bits),
                [xyz.x / ybar, xyz.y / ybar, xyz.z / ybar].map(f64::to_bits)
            );
        }
    }

    /// The D65 of the RGB illuminant (`srgb_illuminant`) against the copy it replaced in
    /// `upsample.rs` (`D65_UNIT_LUMINANCE`: `d65(λ) · Σȳ / Σ d65 ȳ`, multiplied before
    /// dividing).
    #[test]
    fn the_rgb_illuminant_d65_is_within_a_rounding_of_the_copy_it_replaced() {
        let d65 = Illuminant::D65.spectrum().unwrap();
        let y = &Observer::Cie1931.cmf().y;
        let grid = || (360..=830).map(f64::from);
        let y_sum: f64 = grid().map(|l| y.eval(l)).sum();
        let d65_y_sum: f64 = grid().map(|l| d65.eval(l) * y.eval(l)).sum();
        let copy: Vec<f64> = grid().map(|l| d65.eval(l) * y_sum / d65_y_sum).collect();
        let now = crate::srgb_illuminant().values();
        let (mut differ, mut worst) = (0, 0.0f64);
        for (a, b) in now.iter().zip(&copy) {
            differ += usize::from(a.to_bits() != b.to_bits());
            worst = worst.max((a - b).abs() / b);
        }
        eprintln!("sRGB illuminant vs the replaced copy: {differ} of 471 values differ, by at most {worst:e}");
        // The sums are the same (same order, same terms); the scale is applied as
        // `v · (Σȳ / Σ S ȳ)` rather than `v · Σȳ / Σ S ȳ`, one rounding apart.
        assert!(worst <= 2.0 * f64::EPSILON, "{worst:e}");
    }
}
