//! [`Spectrum`]: one continuous spectrum type, as pbrt-v4's `Spectrum` (`util/spectrum.h`):
//! a closed enum of the few shapes a scene needs, each evaluated in its own cheap way
//! (a constant is one number, not 471; an RGB albedo is three coefficients).

use std::sync::LazyLock;

use crate::data::{Illuminant, blackbody};
use crate::error::{Error, Result};
use crate::luminance::{luminance_normalized, y_sum, y_weighted_sum};
use crate::spectrum::{
    DenselySampledSpectrum, SampleSource, SampledSpectrum, SampledWavelengths, check_samples, visible_nm,
};
use crate::upsample::{RgbSigmoid, RgbToSpectrumTable, split_brightness, upsample_illuminant};

/// A spectrum defined at every wavelength (nm).
///
/// The maximum comes from the variant without a scan except for `DenselySampled` and
/// `PiecewiseLinear` (their values) and `RgbIlluminant` (the D65 table's maximum); flatness
/// without a scan for `Constant`, `Blackbody` and RGB albedo or unbounded colours with a
/// constant polynomial. Luminance is the 1 nm sum for every variant but `Constant`.
#[derive(Debug, Clone, PartialEq)]
pub enum Spectrum {
    /// The same value at every wavelength (pbrt-v4 `ConstantSpectrum`).
    Constant(f64),
    /// A table on an even grid, linear in between, 0 outside.
    DenselySampled(DenselySampledSpectrum),
    /// Linear between arbitrary knots, 0 outside (pbrt-v4 `PiecewiseLinearSpectrum`).
    PiecewiseLinear(PiecewiseLinearSpectrum),
    /// Planck's law at a temperature, normalised to peak 1 (pbrt-v4 `BlackbodySpectrum`).
    Blackbody(BlackbodySpectrum),
    /// A reflectance in [0, 1] from an RGB colour (pbrt-v4 `RGBAlbedoSpectrum`).
    RgbAlbedo(RgbSigmoid),
    /// An unbounded RGB quantity, `scale · s(λ)` (pbrt-v4 `RGBUnboundedSpectrum`).
    RgbUnbounded(RgbUnboundedSpectrum),
    /// An RGB light, `scale · s(λ) · D65(λ)` (pbrt-v4 `RGBIlluminantSpectrum`).
    RgbIlluminant(RgbIlluminantSpectrum),
}

impl From<DenselySampledSpectrum> for Spectrum {
    fn from(spectrum: DenselySampledSpectrum) -> Self {
        Self::DenselySampled(spectrum)
    }
}

impl Spectrum {
    /// The value at `lambda` nm.
    #[inline]
    pub fn eval(&self, lambda: f64) -> f64 {
        match self {
            Self::Constant(c) => *c,
            Self::DenselySampled(s) => s.eval(lambda),
            Self::PiecewiseLinear(s) => s.eval(lambda),
            Self::Blackbody(s) => s.eval(lambda),
            Self::RgbAlbedo(s) => s.eval(lambda),
            Self::RgbUnbounded(s) => s.eval(lambda),
            Self::RgbIlluminant(s) => s.eval(lambda),
        }
    }

    /// Values at the sampled wavelengths (f32). The RGB forms evaluate in f32 throughout.
    #[inline]
    pub fn sample<const N: usize>(&self, lambda: &SampledWavelengths<N>) -> SampledSpectrum<N> {
        match self {
            Self::Constant(c) => SampledSpectrum::splat(*c as f32),
            Self::DenselySampled(s) => s.sample(lambda),
            Self::RgbAlbedo(s) => s.sample(lambda),
            Self::RgbUnbounded(s) => s.sample(lambda),
            Self::RgbIlluminant(s) => s.sample(lambda),
            Self::PiecewiseLinear(s) => SampledSpectrum(lambda.lambdas().map(|l| s.eval(f64::from(l)) as f32)),
            Self::Blackbody(s) => SampledSpectrum(lambda.lambdas().map(|l| s.eval(f64::from(l)) as f32)),
        }
    }

    /// An upper bound of the values over 360–830 nm: the maximum itself for every variant
    /// except `RgbIlluminant` (the product of its factors' maxima, as pbrt-v4 bounds it).
    pub fn max_value(&self) -> f64 {
        match self {
            Self::Constant(c) => *c,
            Self::DenselySampled(s) => s.max_value(),
            Self::PiecewiseLinear(s) => s.max_value(),
            Self::Blackbody(_) => 1.0,
            Self::RgbAlbedo(s) => s.max_value(),
            Self::RgbUnbounded(s) => f64::from(s.scale) * s.sigmoid.max_value(),
            Self::RgbIlluminant(s) => f64::from(s.0.scale) * s.0.sigmoid.max_value() * srgb_illuminant().max_value(),
        }
    }

    /// Whether the spectrum has the same value at every whole nanometre of 360–830 nm.
    /// Told by the variant for `Constant`, `Blackbody` (never) and the RGB albedo and
    /// unbounded forms (a constant polynomial); the others are scanned.
    pub fn is_constant(&self) -> bool {
        match self {
            Self::Constant(_) => true,
            Self::Blackbody(_) => false,
            Self::RgbAlbedo(s) => s.constant_value().is_some() || scan_is_constant(|l| self.eval(l)),
            Self::RgbUnbounded(s) => {
                s.sigmoid.constant_value().is_some() || s.scale == 0.0 || scan_is_constant(|l| self.eval(l))
            }
            Self::DenselySampled(_) | Self::PiecewiseLinear(_) | Self::RgbIlluminant(_) => {
                scan_is_constant(|l| self.eval(l))
            }
        }
    }

    /// Luminance relative to an equal-energy spectrum of value 1 (`Σ S ȳ / Σ ȳ`, CIE 1931,
    /// 1 nm over 360–830 nm; for the dense form the same sum as [`crate::relative_luminance`],
    /// bit for bit).
    pub fn luminance(&self) -> f64 {
        match self {
            Self::Constant(c) => *c,
            _ => y_weighted_sum(|l| self.eval(l)) / y_sum(),
        }
    }

    /// The spectrum on the 1 nm grid over 360–830 nm (a `DenselySampled` one is returned as
    /// it is, on its own grid).
    pub fn to_densely_sampled(&self) -> DenselySampledSpectrum {
        match self {
            Self::DenselySampled(s) => s.clone(),
            Self::Constant(c) => DenselySampledSpectrum::constant(*c),
            // Every variant is finite on 360–830 nm: knots and values are bounded, RGB scales
            // are at most 2e30 and sigmoid coefficients bounded, and a black body's peak is a
            // finite, positive number (`BlackbodySpectrum::new`).
            _ => DenselySampledSpectrum::from_fn_visible(|l| self.eval(l))
                .expect("every variant is finite over 360–830 nm"),
        }
    }

    /// An RGB albedo from linear sRGB (channels clamped to [0, 1]) by table lookup: see
    /// [`RgbSigmoid::from_rgb`] for its cost and accuracy.
    pub fn rgb_albedo(rgb: [f32; 3]) -> Self {
        Self::RgbAlbedo(RgbSigmoid::from_rgb(RgbToSpectrumTable::srgb(), rgb))
    }
}

/// Whether `f` is the same at every whole nanometre of 360–830 nm.
fn scan_is_constant(f: impl Fn(f64) -> f64) -> bool {
    let mut lambdas = visible_nm();
    let first = lambdas.next().map(&f);
    lambdas.all(|l| Some(f(l)) == first)
}

/// Linear interpolation between knots `(lambda[i], value[i])`, 0 outside the knots.
/// Knots and values checked as [`DenselySampledSpectrum::from_samples`] checks its samples.
#[derive(Debug, Clone, PartialEq)]
pub struct PiecewiseLinearSpectrum {
    lambdas: Vec<f64>,
    values: Vec<f64>,
}

impl PiecewiseLinearSpectrum {
    /// The spectrum through `(lambdas[i], values[i])`: at least one knot; wavelengths finite,
    /// positive, at most 100 000 nm and increasing by at least [`crate::MIN_STEP_NM`]; values
    /// finite and at most 1e30 in magnitude. The error names the first offending knot by its
    /// 1-based index.
    pub fn new(lambdas: Vec<f64>, values: Vec<f64>) -> Result<Self> {
        check_samples(&SampleSource::unfiled("piecewise-linear spectrum knots"), &lambdas, &values)?;
        Ok(Self { lambdas, values })
    }

    /// The value at `lambda` nm: the knot's value at a knot (the blend below is exact there:
    /// `f` is 0, or 1 at the last knot), linear between, 0 outside.
    pub fn eval(&self, lambda: f64) -> f64 {
        let n = self.lambdas.len();
        if !(lambda >= self.lambdas[0] && lambda <= self.lambdas[n - 1]) {
            return 0.0;
        }
        if n == 1 {
            return self.values[0];
        }
        // The last knot ≤ λ (there is one: λ ≥ the first), stepped back at the last knot so
        // that [i, i + 1] exists.
        let i = (self.lambdas.partition_point(|&l| l <= lambda) - 1).min(n - 2);
        let (l0, l1) = (self.lambdas[i], self.lambdas[i + 1]);
        let f = (lambda - l0) / (l1 - l0);
        self.values[i] * (1.0 - f) + self.values[i + 1] * f
    }

    /// Largest knot value (the maximum of a piecewise-linear function is at a knot).
    pub fn max_value(&self) -> f64 {
        self.values.iter().copied().fold(f64::NEG_INFINITY, f64::max)
    }

    /// The knot wavelengths (nm).
    pub fn lambdas(&self) -> &[f64] {
        &self.lambdas
    }

    /// The knot values.
    pub fn values(&self) -> &[f64] {
        &self.values
    }
}

/// Wien's displacement constant b = 2.897771955e-3 m·K (CODATA 2018): Planck's law peaks
/// at λ_max = b / T.
const WIEN_DISPLACEMENT_M_K: f64 = 2.897_771_955e-3;

/// Planck's law at a temperature, normalised so that its peak (at Wien's λ_max = b/T, even
/// outside the visible range) is 1, as pbrt-v4's `BlackbodySpectrum`. The embedded
/// illuminant `bb<K>` ([`crate::Illuminant::Blackbody`]) is normalised to S(560 nm) = 100
/// instead, the CIE's convention for illuminants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlackbodySpectrum {
    kelvin: f64,
    normalization: f64,
}

impl BlackbodySpectrum {
    /// A black body at `kelvin`: finite, > 0 and with a Planck peak whose reciprocal is
    /// finite (about 1e-59 to 1e64 K). The crate's one check of a temperature
    /// ([`crate::Illuminant::Blackbody`] and its name `bb<K>` use it too).
    pub fn new(kelvin: f64) -> Result<Self> {
        // `blackbody` is 0 for a temperature ≤ 0 or NaN (and at the 0 nm peak of +∞ K), so
        // one test of the normalisation rejects those along with peaks that under- or
        // overflow.
        let normalization = 1.0 / blackbody(WIEN_DISPLACEMENT_M_K / kelvin * 1e9, kelvin);
        if !(normalization > 0.0 && normalization.is_finite()) {
            return Err(Error::OutOfRange {
                what: "temperature (K)",
                value: kelvin,
                range: "> 0, finite, with a finite Planck peak",
            });
        }
        Ok(Self { kelvin, normalization })
    }

    /// The temperature (K).
    pub fn kelvin(&self) -> f64 {
        self.kelvin
    }

    /// `B(λ, T) / B(λ_max, T)`, in [0, 1].
    pub fn eval(&self, lambda: f64) -> f64 {
        blackbody(lambda, self.kelvin) * self.normalization
    }
}

/// `scale · s(λ)`: an RGB colour of any brightness (pbrt-v4 `RGBUnboundedSpectrum`):
/// `scale = 2 · max(r, g, b)` and the sigmoid of `rgb / scale`, whose largest channel is
/// ½, safely inside the set that reflectances reach.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RgbUnboundedSpectrum {
    sigmoid: RgbSigmoid,
    scale: f32,
}

/// [`split_brightness`] of f32 channels, in f64 (so `2 · max` cannot overflow) and rounded
/// once to f32: the same bits as the split in f32 wherever that does not overflow (f64
/// carries more than twice f32's digits, so the rounding through f64 is exact).
fn split_brightness_f32(rgb: [f32; 3]) -> ([f32; 3], f32) {
    let (color, scale) = split_brightness(rgb.map(f64::from));
    (color.map(|c| c as f32), scale as f32)
}

impl RgbUnboundedSpectrum {
    /// Linear sRGB `rgb` (≥ 0) by table lookup.
    pub fn from_rgb(table: &RgbToSpectrumTable, rgb: [f32; 3]) -> Self {
        let (color, scale) = split_brightness_f32(rgb);
        Self { sigmoid: RgbSigmoid::from_rgb(table, color), scale }
    }

    /// Linear sRGB `rgb` by the exact fit (about 20 µs): [`RgbIlluminantSpectrum::fit`] without the
    /// illuminant, so that `fit(rgb)(λ) · D65(λ)` (D65 at luminance 1, [`srgb_illuminant`]) is that light.
    pub fn fit(rgb: [f64; 3]) -> Self {
        let (polynomial, scale) = upsample_illuminant(rgb);
        Self { sigmoid: polynomial.into(), scale: scale as f32 }
    }

    /// The value at `lambda` nm.
    pub fn eval(&self, lambda: f64) -> f64 {
        f64::from(self.scale) * self.sigmoid.eval(lambda)
    }

    /// Values at the sampled wavelengths (f32).
    #[inline]
    pub fn sample<const N: usize>(&self, lambda: &SampledWavelengths<N>) -> SampledSpectrum<N> {
        self.sigmoid.sample(lambda) * self.scale
    }
}

/// D65 on the 1 nm grid over 360–830 nm scaled to relative luminance 1: the sRGB
/// illuminant of [`RgbIlluminantSpectrum`] (pbrt-v4 normalises its colour spaces'
/// illuminants to luminance 1 too).
static D65_UNIT: LazyLock<DenselySampledSpectrum> = LazyLock::new(|| {
    let d65 = Illuminant::D65.spectrum().expect("D65 is an embedded, tested table");
    luminance_normalized(&DenselySampledSpectrum::from_fn_visible(|l| d65.eval(l)).expect("D65 values are finite"))
});

/// The illuminant of linear sRGB lights: D65 at relative luminance 1 on the 1 nm grid.
pub fn srgb_illuminant() -> &'static DenselySampledSpectrum {
    &D65_UNIT
}

/// An RGB light, `scale · s(λ) · D65(λ)` with D65 at relative luminance 1 (pbrt-v4
/// `RGBIlluminantSpectrum`): `scale = 2 · max(r, g, b)`, `s` the sigmoid of `rgb / scale`.
/// White (1, 1, 1) has relative luminance 1; its XYZ relative to `Σȳ`
/// ([`crate::relative_xyz`]) is the sRGB XYZ of `rgb` (within the sigmoid's accuracy).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RgbIlluminantSpectrum(RgbUnboundedSpectrum);

impl RgbIlluminantSpectrum {
    /// Linear sRGB `rgb` (≥ 0) by table lookup (a few ns; see [`RgbSigmoid::from_rgb`]).
    pub fn from_rgb(table: &RgbToSpectrumTable, rgb: [f32; 3]) -> Self {
        Self(RgbUnboundedSpectrum::from_rgb(table, rgb))
    }

    /// Linear sRGB `rgb` by the exact fit of [`crate::upsample_illuminant`] (about 20 µs):
    /// the same spectrum as [`crate::upsample_illuminant_spectrum`], up to f32 rounding.
    pub fn fit(rgb: [f64; 3]) -> Self {
        Self(RgbUnboundedSpectrum::fit(rgb))
    }

    /// The value at `lambda` nm.
    pub fn eval(&self, lambda: f64) -> f64 {
        self.0.eval(lambda) * srgb_illuminant().eval(lambda)
    }

    /// Values at the sampled wavelengths (f32): sigmoid × illuminant, then the scale, in that
    /// order (the order fixes the f32 rounding every render was made with).
    #[inline]
    pub fn sample<const N: usize>(&self, lambda: &SampledWavelengths<N>) -> SampledSpectrum<N> {
        self.0.sigmoid.sample(lambda) * srgb_illuminant().sample(lambda) * self.0.scale
    }
}

#[cfg(test)]
mod tests;
