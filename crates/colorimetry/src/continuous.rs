//! [`Spectrum`]: one continuous spectrum type, as pbrt-v4's `Spectrum` (`util/spectrum.h`):
//! a closed enum of the few shapes a scene needs, each evaluated in its own cheap way
//! (a constant is one number, not 471; an RGB albedo is three coefficients).

use std::sync::LazyLock;

use crate::data::{Illuminant, blackbody};
use crate::error::{Error, Result};
use crate::luminance::{luminance_normalized, y_sum, y_weighted_sum};
use crate::spectrum::{DenselySampledSpectrum, LAMBDA_MAX, LAMBDA_MIN, SampledSpectrum, SampledWavelengths};
use crate::upsample::{RgbSigmoid, RgbToSpectrumTable, upsample_illuminant};

/// A spectrum defined at every wavelength (nm).
///
/// Flatness, the maximum and luminance come from the variant where it can tell
/// (`Constant`, `Blackbody`, the RGB forms); only `DenselySampled` and `PiecewiseLinear`
/// scan their values.
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
            Self::PiecewiseLinear(_) | Self::Blackbody(_) => {
                SampledSpectrum(lambda.lambdas().map(|l| self.eval(f64::from(l)) as f32))
            }
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
            Self::RgbIlluminant(s) => f64::from(s.scale) * s.sigmoid.max_value() * s.illuminant.max_value(),
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
    /// 1 nm over 360–830 nm; [`crate::relative_luminance`] for the dense form, bit for bit).
    pub fn luminance(&self) -> f64 {
        match self {
            Self::Constant(c) => *c,
            Self::DenselySampled(s) => crate::relative_luminance(s),
            _ => y_weighted_sum(|l| self.eval(l)) / y_sum(),
        }
    }

    /// The spectrum on the 1 nm grid over 360–830 nm (a `DenselySampled` one is returned as
    /// it is, on its own grid).
    pub fn to_densely_sampled(&self) -> DenselySampledSpectrum {
        match self {
            Self::DenselySampled(s) => s.clone(),
            Self::Constant(c) => DenselySampledSpectrum::constant(*c),
            _ => {
                let count = (LAMBDA_MAX - LAMBDA_MIN) as usize + 1;
                let values =
                    (0..count).map(|i| sanitise(self.eval(f64::from(LAMBDA_MIN) + i as f64))).collect::<Vec<_>>();
                DenselySampledSpectrum::new(f64::from(LAMBDA_MIN), 1.0, values)
                    .expect("finite values on the fixed 1 nm grid")
            }
        }
    }

    /// An RGB albedo from linear sRGB (channels clamped to [0, 1]) by table lookup: see
    /// [`RgbSigmoid::from_rgb`] for its cost and accuracy.
    pub fn rgb_albedo(rgb: [f32; 3]) -> Self {
        Self::RgbAlbedo(RgbSigmoid::from_rgb(RgbToSpectrumTable::srgb(), rgb))
    }
}

/// Non-finite values (an extreme blackbody, a NaN wavelength) become 0 in a dense table.
fn sanitise(v: f64) -> f64 {
    if v.is_finite() { v } else { 0.0 }
}

/// Whether `f` is the same at every whole nanometre of 360–830 nm.
fn scan_is_constant(f: impl Fn(f64) -> f64) -> bool {
    let first = f(f64::from(LAMBDA_MIN));
    let mut lambda = f64::from(LAMBDA_MIN);
    while lambda <= f64::from(LAMBDA_MAX) {
        if f(lambda) != first {
            return false;
        }
        lambda += 1.0;
    }
    true
}

/// Linear interpolation between knots `(lambda[i], value[i])`, 0 outside the knots.
/// Knots strictly increasing, values finite (checked by [`PiecewiseLinearSpectrum::new`]).
#[derive(Debug, Clone, PartialEq)]
pub struct PiecewiseLinearSpectrum {
    lambdas: Vec<f64>,
    values: Vec<f64>,
}

impl PiecewiseLinearSpectrum {
    /// The spectrum through `(lambdas[i], values[i])`.
    pub fn new(lambdas: Vec<f64>, values: Vec<f64>) -> Result<Self> {
        if lambdas.is_empty() || lambdas.len() != values.len() {
            return Err(Error::Empty { origin: "piecewise-linear spectrum knots".to_owned() });
        }
        if let Some(&v) = lambdas.iter().chain(&values).find(|v| !v.is_finite()) {
            return Err(Error::OutOfRange { what: "piecewise-linear spectrum knot", value: v, range: "finite" });
        }
        for (i, w) in lambdas.windows(2).enumerate() {
            if !(w[1] > w[0]) {
                // No file here: `line` is the 1-based index of the offending knot.
                return Err(Error::Unsorted {
                    origin: "piecewise-linear spectrum knots".to_owned(),
                    line: i + 2,
                    lambda: w[1],
                    previous: w[0],
                });
            }
        }
        Ok(Self { lambdas, values })
    }

    /// The value at `lambda` nm: the knot's value at a knot, linear between, 0 outside.
    pub fn eval(&self, lambda: f64) -> f64 {
        let n = self.lambdas.len();
        if !(lambda >= self.lambdas[0] && lambda <= self.lambdas[n - 1]) {
            return 0.0;
        }
        // First knot above λ; at the last knot step back so that [i, i + 1] exists.
        let upper = self.lambdas.partition_point(|&l| l <= lambda);
        if upper == 0 || n == 1 {
            return self.values[0];
        }
        let i = (upper - 1).min(n - 2);
        let (l0, l1) = (self.lambdas[i], self.lambdas[i + 1]);
        let f = (lambda - l0) / (l1 - l0);
        if f == 0.0 {
            return self.values[i];
        }
        if f == 1.0 {
            return self.values[i + 1];
        }
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
    /// A black body at `kelvin` (> 0, finite).
    pub fn new(kelvin: f64) -> Result<Self> {
        if !(kelvin > 0.0 && kelvin.is_finite()) {
            return Err(Error::OutOfRange { what: "temperature (K)", value: kelvin, range: "> 0, finite" });
        }
        let peak_nm = WIEN_DISPLACEMENT_M_K / kelvin * 1e9;
        let peak = blackbody(peak_nm, kelvin);
        if !(peak > 0.0 && peak.is_finite()) {
            return Err(Error::OutOfRange { what: "temperature (K)", value: kelvin, range: "a finite Planck peak" });
        }
        Ok(Self { kelvin, normalization: 1.0 / peak })
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

/// `2 · max(r, g, b)` and `rgb / scale` (negative and non-finite channels as 0), pbrt-v4's
/// split of an unbounded RGB into a brightness and a colour of largest channel ½.
fn split_brightness(rgb: [f32; 3]) -> ([f32; 3], f32) {
    let rgb = rgb.map(|c| if c.is_finite() { c.max(0.0) } else { 0.0 });
    let scale = 2.0 * rgb[0].max(rgb[1]).max(rgb[2]);
    if scale == 0.0 { ([0.0; 3], 0.0) } else { (rgb.map(|c| c / scale), scale) }
}

impl RgbUnboundedSpectrum {
    /// Linear sRGB `rgb` (≥ 0) by table lookup.
    pub fn from_rgb(table: &RgbToSpectrumTable, rgb: [f32; 3]) -> Self {
        let (color, scale) = split_brightness(rgb);
        Self { sigmoid: RgbSigmoid::from_rgb(table, color), scale }
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
    let count = (LAMBDA_MAX - LAMBDA_MIN) as usize + 1;
    let values = (0..count).map(|i| d65.eval(f64::from(LAMBDA_MIN) + i as f64)).collect();
    let grid = DenselySampledSpectrum::new(f64::from(LAMBDA_MIN), 1.0, values).expect("D65 values are finite");
    luminance_normalized(&grid)
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
pub struct RgbIlluminantSpectrum {
    sigmoid: RgbSigmoid,
    scale: f32,
    illuminant: &'static DenselySampledSpectrum,
}

impl RgbIlluminantSpectrum {
    /// Linear sRGB `rgb` (≥ 0) by table lookup (a few ns; see [`RgbSigmoid::from_rgb`]).
    pub fn from_rgb(table: &RgbToSpectrumTable, rgb: [f32; 3]) -> Self {
        let (color, scale) = split_brightness(rgb);
        Self { sigmoid: RgbSigmoid::from_rgb(table, color), scale, illuminant: srgb_illuminant() }
    }

    /// Linear sRGB `rgb` by the exact fit of [`crate::upsample_illuminant`] (about 20 µs):
    /// the same spectrum as [`crate::upsample_illuminant_spectrum`], up to f32 rounding.
    pub fn fit(rgb: [f64; 3]) -> Self {
        let (polynomial, scale) = upsample_illuminant(rgb);
        Self { sigmoid: polynomial.into(), scale: scale as f32, illuminant: srgb_illuminant() }
    }

    /// The value at `lambda` nm.
    pub fn eval(&self, lambda: f64) -> f64 {
        f64::from(self.scale) * self.sigmoid.eval(lambda) * self.illuminant.eval(lambda)
    }

    /// Values at the sampled wavelengths (f32).
    #[inline]
    pub fn sample<const N: usize>(&self, lambda: &SampledWavelengths<N>) -> SampledSpectrum<N> {
        self.sigmoid.sample(lambda) * self.illuminant.sample(lambda) * self.scale
    }
}

#[cfg(test)]
mod tests;
