//! Spectra: densely sampled tables (f64, for colorimetric sums) and the handful of
//! wavelengths one path carries (f32, the renderer's hot path).

use std::ops::{Add, AddAssign, Div, Index, IndexMut, Mul, MulAssign, Sub};

use crate::data::Observer;
use crate::error::{Error, Result};

/// Shortest wavelength of the visible range used throughout (nm): the first row of the
/// CIE 1931 and 1964 1 nm tables.
pub const LAMBDA_MIN: f32 = 360.0;
/// Longest wavelength of the visible range used throughout (nm): the last CIE table row.
pub const LAMBDA_MAX: f32 = 830.0;

/// Finest wavelength step a spectrum grid may have (nm). Laboratory spectrometers resolve
/// about 0.01–0.1 nm and the CIE tables are at 1 or 5 nm, so 0.001 nm leaves a factor of ten
/// below the finest real data, while keeping the visible range (470 nm) within
/// [`MAX_SPECTRUM_SAMPLES`] at that step. A finer step (`500, 500.0000000001` in a file, or
/// `--step 1e-9`) asked for terabytes before this bound.
pub const MIN_STEP_NM: f64 = 1e-3;

/// Most samples one spectrum grid may hold: 2²⁰ f64 = 8 MiB. It fits 360–830 nm at
/// [`MIN_STEP_NM`] (470 001 samples) and a table resampled at 1 nm up to
/// [`MAX_WAVELENGTH_NM`] (100 001 samples).
pub const MAX_SPECTRUM_SAMPLES: usize = 1 << 20;

/// Longest wavelength a spectrum may name (nm): 100 µm, the far infrared, 120 × the visible
/// range's end. Solar and lamp tables stop at 2500–4000 nm; nothing here is used above 830 nm.
pub const MAX_WAVELENGTH_NM: f64 = 1e5;

/// ∫ ȳ(λ) dλ of each observer, summed at 1 nm over 360–830 nm (the tables' own sums,
/// quoted in `data/PROVENANCE.md`: Σȳ = 106.856917, Σȳ₁₀ = 116.661877; the unit test
/// `y_integrals_are_the_table_sums` recomputes them). Normalises Monte Carlo XYZ estimates so
/// an equal-energy spectrum of value 1 has Y = 1 for either observer.
fn y_integral(observer: Observer) -> f64 {
    match observer {
        Observer::Cie1931 => 106.856_917,
        Observer::Cie1964 => 116.661_877,
    }
}

/// A spectrum tabulated on an even wavelength grid; linear interpolation between samples and
/// zero outside the grid. Values are finite by construction.
#[derive(Debug, Clone, PartialEq)]
pub struct DenselySampledSpectrum {
    lambda_min: f64,
    step: f64,
    values: Vec<f64>,
}

impl DenselySampledSpectrum {
    /// Samples `values` at `lambda_min + i·step` nm. The grid is bounded: step ≥
    /// [`MIN_STEP_NM`], at most [`MAX_SPECTRUM_SAMPLES`] values.
    pub fn new(lambda_min: f64, step: f64, values: Vec<f64>) -> Result<Self> {
        Self::new_in("spectrum", lambda_min, step, values)
    }

    /// [`Self::new`] with `origin` naming the source in errors.
    pub(crate) fn new_in(origin: &str, lambda_min: f64, step: f64, values: Vec<f64>) -> Result<Self> {
        if !(step > 0.0 && step.is_finite()) {
            return Err(Error::OutOfRange { what: "wavelength step", value: step, range: "> 0, finite" });
        }
        if step < MIN_STEP_NM {
            return Err(Error::StepTooSmall { origin: origin.to_owned(), step, min: MIN_STEP_NM });
        }
        if !lambda_min.is_finite() {
            return Err(Error::OutOfRange { what: "first wavelength", value: lambda_min, range: "finite" });
        }
        if values.is_empty() {
            return Err(Error::Empty { origin: origin.to_owned() });
        }
        if values.len() > MAX_SPECTRUM_SAMPLES {
            return Err(Error::TooManySamples {
                origin: origin.to_owned(),
                samples: values.len() as f64,
                limit: MAX_SPECTRUM_SAMPLES,
            });
        }
        if let Some(&v) = values.iter().find(|v| !v.is_finite()) {
            return Err(Error::OutOfRange { what: "spectrum value", value: v, range: "finite" });
        }
        Ok(Self { lambda_min, step, values })
    }

    /// A piecewise-linear spectrum through `(lambdas[i], values[i])`: kept on its own grid
    /// when evenly spaced (exact), otherwise resampled at every whole nanometre of its range
    /// (exact at those wavelengths). Zero outside the given range. The grid bounds of
    /// [`Self::new`] apply; the resampled grid is checked before it is allocated.
    pub fn from_samples(lambdas: &[f64], values: &[f64]) -> Result<Self> {
        Self::from_samples_in("spectrum samples", lambdas, values)
    }

    /// [`Self::from_samples`] with `origin` naming the source in errors.
    pub(crate) fn from_samples_in(origin: &str, lambdas: &[f64], values: &[f64]) -> Result<Self> {
        if lambdas.is_empty() || lambdas.len() != values.len() {
            return Err(Error::Empty { origin: origin.to_owned() });
        }
        for (i, w) in lambdas.windows(2).enumerate() {
            if !(w[1] > w[0]) {
                // No file here: `line` is the 1-based index of the offending sample.
                return Err(Error::Unsorted { origin: origin.to_owned(), line: i + 2, lambda: w[1], previous: w[0] });
            }
        }
        if let Some(i) = lambdas.iter().position(|l| !(*l <= MAX_WAVELENGTH_NM)) {
            return Err(Error::WavelengthTooLong {
                origin: origin.to_owned(),
                line: i + 1,
                lambda: lambdas[i],
                max: MAX_WAVELENGTH_NM,
            });
        }
        if lambdas.len() == 1 {
            return Self::new_in(origin, lambdas[0], 1.0, values.to_vec());
        }
        let step = lambdas[1] - lambdas[0];
        let even = lambdas.windows(2).all(|w| ((w[1] - w[0]) - step).abs() <= 1e-9 * step.max(1.0));
        if even {
            return Self::new_in(origin, lambdas[0], step, values.to_vec());
        }
        let (first, last) = (lambdas[0].ceil(), lambdas[lambdas.len() - 1].floor());
        if last < first {
            return Err(Error::Empty { origin: format!("{origin} (no whole nanometre in their range)") });
        }
        // Counted in f64 and checked before the cast and the allocation (a 1e300 nm row used
        // to overflow here).
        let samples = last - first + 1.0;
        if samples > MAX_SPECTRUM_SAMPLES as f64 {
            return Err(Error::TooManySamples { origin: origin.to_owned(), samples, limit: MAX_SPECTRUM_SAMPLES });
        }
        let count = samples as usize;
        let mut out = Vec::with_capacity(count);
        let mut segment = 0;
        for i in 0..count {
            let l = first + i as f64;
            while segment + 2 < lambdas.len() && lambdas[segment + 1] < l {
                segment += 1;
            }
            let (l0, l1) = (lambdas[segment], lambdas[segment + 1]);
            let f = ((l - l0) / (l1 - l0)).clamp(0.0, 1.0);
            out.push(values[segment] * (1.0 - f) + values[segment + 1] * f);
        }
        Self::new_in(origin, first, 1.0, out)
    }

    /// The same value at every nanometre of 360–830 nm.
    pub fn constant(value: f64) -> Self {
        let n = (LAMBDA_MAX - LAMBDA_MIN) as usize + 1;
        Self { lambda_min: f64::from(LAMBDA_MIN), step: 1.0, values: vec![value; n] }
    }

    /// The value at `lambda` nm: linear interpolation, 0 outside the grid.
    #[inline]
    pub fn eval(&self, lambda: f64) -> f64 {
        let pos = (lambda - self.lambda_min) / self.step;
        let last = (self.values.len() - 1) as f64;
        // A hair of tolerance so the last grid point is inside despite rounding of `pos`.
        if !(pos >= -1e-9 && pos <= last + 1e-9) {
            return 0.0;
        }
        if self.values.len() == 1 {
            return self.values[0];
        }
        let pos = pos.clamp(0.0, last);
        let i = (pos as usize).min(self.values.len() - 2);
        let f = pos - i as f64;
        self.values[i] * (1.0 - f) + self.values[i + 1] * f
    }

    /// Values at the sampled wavelengths.
    #[inline]
    pub fn sample<const N: usize>(&self, lambda: &SampledWavelengths<N>) -> SampledSpectrum<N> {
        SampledSpectrum(lambda.lambda.map(|l| self.eval(f64::from(l)) as f32))
    }

    /// First wavelength of the grid (nm).
    pub fn lambda_min(&self) -> f64 {
        self.lambda_min
    }

    /// Last wavelength of the grid (nm).
    pub fn lambda_max(&self) -> f64 {
        self.lambda_min + self.step * (self.values.len() - 1) as f64
    }

    /// Grid spacing (nm).
    pub fn step(&self) -> f64 {
        self.step
    }

    /// The tabulated values.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Largest tabulated value.
    pub fn max_value(&self) -> f64 {
        self.values.iter().copied().fold(f64::NEG_INFINITY, f64::max)
    }

    /// Smallest tabulated value.
    pub fn min_value(&self) -> f64 {
        self.values.iter().copied().fold(f64::INFINITY, f64::min)
    }

    /// Every value times `factor`.
    pub fn scaled(&self, factor: f64) -> Self {
        self.map(|v| v * factor)
    }

    /// `f` applied to every value (e.g. R(λ)ⁿ, t_λ^b). Non-finite results become 0 so the
    /// invariant holds.
    pub fn map(&self, f: impl Fn(f64) -> f64) -> Self {
        let values = self
            .values
            .iter()
            .map(|&v| {
                let r = f(v);
                if r.is_finite() { r } else { 0.0 }
            })
            .collect();
        Self { lambda_min: self.lambda_min, step: self.step, values }
    }

    /// Pointwise product on `self`'s grid.
    pub fn product(&self, other: &Self) -> Self {
        let values = self
            .values
            .iter()
            .enumerate()
            .map(|(i, &v)| v * other.eval(self.lambda_min + self.step * i as f64))
            .collect();
        Self { lambda_min: self.lambda_min, step: self.step, values }
    }

    /// Resampled onto `count` points from `lambda_min` every `step` nm (linear interpolation;
    /// exact where the new grid contains the old points). The grid bounds of [`Self::new`]
    /// are checked before anything is allocated.
    pub fn resampled(&self, lambda_min: f64, step: f64, count: usize) -> Result<Self> {
        if count > MAX_SPECTRUM_SAMPLES {
            return Err(Error::TooManySamples {
                origin: "resampled spectrum".to_owned(),
                samples: count as f64,
                limit: MAX_SPECTRUM_SAMPLES,
            });
        }
        let values = (0..count).map(|i| self.eval(lambda_min + step * i as f64)).collect();
        Self::new_in("resampled spectrum", lambda_min, step, values)
    }

    /// The same spectrum, defined over at least 360–830 nm by holding its first and last
    /// values outside its own range (the CIE's convention for D65 above 780 nm; colour-science
    /// extrapolates tables the same way). The embedded illuminants and ColorChecker are
    /// extended like this; `spectrace color` does the same to the files it reads.
    ///
    /// Errors: a spectrum that does not reach into 360–830 nm at all (holding one end value
    /// across the whole visible range would silently make up a flat spectrum), and an
    /// extended grid of more than [`MAX_SPECTRUM_SAMPLES`] (checked before allocating).
    pub fn held_to_visible(&self) -> Result<Self> {
        let (visible_min, visible_max) = (f64::from(LAMBDA_MIN), f64::from(LAMBDA_MAX));
        if self.lambda_max() < visible_min || self.lambda_min > visible_max {
            return Err(Error::OutsideVisible { lambda_min: self.lambda_min, lambda_max: self.lambda_max() });
        }
        let lo = visible_min.min(self.lambda_min);
        let hi = visible_max.max(self.lambda_max());
        let before = ((self.lambda_min - lo) / self.step).ceil();
        let after = ((hi - self.lambda_max()) / self.step).ceil();
        let samples = before + after + self.values.len() as f64;
        if !(samples <= MAX_SPECTRUM_SAMPLES as f64) {
            return Err(Error::TooManySamples {
                origin: format!("spectrum extended to {visible_min}–{visible_max} nm at its {} nm step", self.step),
                samples,
                limit: MAX_SPECTRUM_SAMPLES,
            });
        }
        let (before, after) = (before as usize, after as usize);
        let first = self.values[0];
        let last = self.values[self.values.len() - 1];
        let mut values = Vec::with_capacity(samples as usize);
        values.extend(std::iter::repeat_n(first, before));
        values.extend_from_slice(&self.values);
        values.extend(std::iter::repeat_n(last, after));
        Ok(Self { lambda_min: self.lambda_min - before as f64 * self.step, step: self.step, values })
    }
}

/// The wavelengths carried by one path, with their sampling densities (pbrt-v4
/// `SampledWavelengths`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampledWavelengths<const N: usize> {
    lambda: [f32; N],
    pdf: [f32; N],
}

impl<const N: usize> SampledWavelengths<N> {
    /// A hero wavelength at `u` ∈ [0, 1) across [`lambda_min`, `lambda_max`) and N − 1 more
    /// equally spaced after it, wrapping around (Wilkie et al. 2014). Uniform density.
    pub fn sample_uniform(u: f32, lambda_min: f32, lambda_max: f32) -> Self {
        let span = lambda_max - lambda_min;
        let mut lambda = [0.0; N];
        let delta = span / N as f32;
        lambda[0] = lambda_min + u.clamp(0.0, 1.0) * span;
        for i in 1..N {
            let mut l = lambda[i - 1] + delta;
            if l > lambda_max {
                l = lambda_min + (l - lambda_max);
            }
            lambda[i] = l;
        }
        Self { lambda, pdf: [1.0 / span; N] }
    }

    /// N stratified wavelengths importance-sampled from pbrt-v4's visible-range density
    /// p(λ) ∝ sech²(0.0072 (λ − 538)) over 360–830 nm.
    pub fn sample_visible(u: f32) -> Self {
        let mut lambda = [0.0; N];
        let mut pdf = [0.0; N];
        for i in 0..N {
            let mut up = u + i as f32 / N as f32;
            if up > 1.0 {
                up -= 1.0;
            }
            lambda[i] = sample_visible_wavelength(up);
            pdf[i] = visible_wavelength_pdf(lambda[i]);
        }
        Self { lambda, pdf }
    }

    /// Given wavelengths and densities (e.g. fixed bins with pdf = 1/Δλ).
    pub fn from_parts(lambda: [f32; N], pdf: [f32; N]) -> Self {
        Self { lambda, pdf }
    }

    /// The i-th wavelength (nm).
    #[inline]
    pub fn lambda(&self, i: usize) -> f32 {
        self.lambda[i]
    }

    /// All wavelengths (nm).
    #[inline]
    pub fn lambdas(&self) -> &[f32; N] {
        &self.lambda
    }

    /// Sampling densities (per nm).
    #[inline]
    pub fn pdf(&self) -> SampledSpectrum<N> {
        SampledSpectrum(self.pdf)
    }

    /// Keep only the hero wavelength (its density divided by N, as pbrt-v4 does), for paths
    /// whose direction depends on wavelength (dispersion).
    pub fn terminate_secondary(&mut self) {
        if self.secondary_terminated() {
            return;
        }
        for p in self.pdf.iter_mut().skip(1) {
            *p = 0.0;
        }
        self.pdf[0] /= N as f32;
    }

    /// Whether only the hero wavelength is left.
    pub fn secondary_terminated(&self) -> bool {
        self.pdf.iter().skip(1).all(|&p| p == 0.0)
    }
}

/// Inverse CDF of the visible-range density (pbrt-v4 `SampleVisibleWavelengths`).
fn sample_visible_wavelength(u: f32) -> f32 {
    538.0 - 138.888_89 * (0.856_910_6 - 1.827_502 * u).atanh()
}

/// pbrt-v4 `VisibleWavelengthsPDF`: 0.0039398042 / cosh²(0.0072 (λ − 538)) in 360–830 nm.
fn visible_wavelength_pdf(lambda: f32) -> f32 {
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lambda) {
        return 0.0;
    }
    let c = (0.0072 * (lambda - 538.0)).cosh();
    0.003_939_804 / (c * c)
}

/// Values at N sampled wavelengths (or N channels). Plain arrays so loops vectorise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampledSpectrum<const N: usize>(pub [f32; N]);

impl<const N: usize> SampledSpectrum<N> {
    /// All lanes equal to `v`.
    #[inline]
    pub fn splat(v: f32) -> Self {
        Self([v; N])
    }

    /// `f` applied lane by lane.
    #[inline]
    pub fn map(self, f: impl Fn(f32) -> f32) -> Self {
        Self(self.0.map(f))
    }

    /// e^v per lane.
    #[inline]
    pub fn exp(self) -> Self {
        self.map(f32::exp)
    }

    /// √v per lane (negative lanes give 0).
    #[inline]
    pub fn sqrt(self) -> Self {
        self.map(|v| v.max(0.0).sqrt())
    }

    /// Negative lanes set to 0.
    #[inline]
    pub fn clamp_zero(self) -> Self {
        self.map(|v| v.max(0.0))
    }

    /// a / b per lane, 0 where b = 0 (pbrt-v4 `SafeDiv`).
    #[inline]
    pub fn safe_div(self, b: Self) -> Self {
        let mut out = self;
        for (o, d) in out.0.iter_mut().zip(b.0) {
            *o = if d != 0.0 { *o / d } else { 0.0 };
        }
        out
    }

    /// Largest lane.
    #[inline]
    pub fn max_component(&self) -> f32 {
        self.0.iter().copied().fold(f32::NEG_INFINITY, f32::max)
    }

    /// Smallest lane.
    #[inline]
    pub fn min_component(&self) -> f32 {
        self.0.iter().copied().fold(f32::INFINITY, f32::min)
    }

    /// Mean of the lanes.
    #[inline]
    pub fn average(&self) -> f32 {
        self.0.iter().sum::<f32>() / N as f32
    }

    /// Whether every lane is 0.
    #[inline]
    pub fn is_black(&self) -> bool {
        self.0.iter().all(|&v| v == 0.0)
    }

    /// Whether every lane is finite.
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.0.iter().all(|v| v.is_finite())
    }

    /// Monte Carlo estimate of XYZ (pbrt-v4 `SampledSpectrum::ToXYZ`):
    /// X = (1/N) Σ x̄(λᵢ) L(λᵢ) / p(λᵢ) / ∫ȳ (∫ȳ of the same observer), lanes with zero
    /// density skipped, so an equal-energy spectrum of value 1 has Y = 1 in expectation.
    pub fn to_xyz(&self, lambda: &SampledWavelengths<N>, observer: Observer) -> [f32; 3] {
        let cmf = observer.cmf();
        let mut xyz = [0.0f64; 3];
        for i in 0..N {
            let p = lambda.pdf[i];
            if p == 0.0 {
                continue;
            }
            let l = f64::from(lambda.lambda[i]);
            let w = f64::from(self.0[i]) / f64::from(p);
            xyz[0] += cmf.x.eval(l) * w;
            xyz[1] += cmf.y.eval(l) * w;
            xyz[2] += cmf.z.eval(l) * w;
        }
        let norm = N as f64 * y_integral(observer);
        xyz.map(|v| (v / norm) as f32)
    }
}

macro_rules! lanewise {
    ($trait:ident, $method:ident, $op_assign:tt) => {
        impl<const N: usize> $trait for SampledSpectrum<N> {
            type Output = Self;
            #[inline]
            fn $method(self, rhs: Self) -> Self {
                let mut out = self;
                for (o, r) in out.0.iter_mut().zip(rhs.0) {
                    *o $op_assign r;
                }
                out
            }
        }
        impl<const N: usize> $trait<f32> for SampledSpectrum<N> {
            type Output = Self;
            #[inline]
            fn $method(self, rhs: f32) -> Self {
                let mut out = self;
                for o in &mut out.0 {
                    *o $op_assign rhs;
                }
                out
            }
        }
    };
}

lanewise!(Add, add, +=);
lanewise!(Sub, sub, -=);
lanewise!(Mul, mul, *=);
// Plain lane division (IEEE: x / 0 is ±inf or NaN); `safe_div` is the guarded form.
lanewise!(Div, div, /=);

// Only the compound assignments the contract lists (+= and *=): adding `-=` or `/=` would make
// clippy's `assign_op_pattern` flag existing `a = a / b` code in the crates above.
impl<const N: usize> AddAssign for SampledSpectrum<N> {
    #[inline]
    fn add_assign(&mut self, rhs: Self) {
        *self = *self + rhs;
    }
}

impl<const N: usize> MulAssign for SampledSpectrum<N> {
    #[inline]
    fn mul_assign(&mut self, rhs: Self) {
        *self = *self * rhs;
    }
}

impl<const N: usize> MulAssign<f32> for SampledSpectrum<N> {
    #[inline]
    fn mul_assign(&mut self, rhs: f32) {
        *self = *self * rhs;
    }
}

impl<const N: usize> Index<usize> for SampledSpectrum<N> {
    type Output = f32;
    #[inline]
    fn index(&self, i: usize) -> &f32 {
        &self.0[i]
    }
}

impl<const N: usize> IndexMut<usize> for SampledSpectrum<N> {
    #[inline]
    fn index_mut(&mut self, i: usize) -> &mut f32 {
        &mut self.0[i]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn interpolates_linearly_and_is_zero_outside() {
        let s = DenselySampledSpectrum::new(400.0, 10.0, vec![0.0, 1.0, 3.0]).unwrap();
        assert_eq!(s.eval(405.0), 0.5);
        assert_eq!(s.eval(415.0), 2.0);
        assert_eq!(s.eval(420.0), 3.0);
        assert_eq!(s.eval(399.0), 0.0);
        assert_eq!(s.eval(421.0), 0.0);
        assert_eq!(s.lambda_max(), 420.0);
    }

    #[test]
    fn invalid_spectra_are_errors() {
        assert!(DenselySampledSpectrum::new(400.0, 0.0, vec![1.0]).is_err());
        assert!(DenselySampledSpectrum::new(400.0, 1.0, vec![]).is_err());
        assert!(DenselySampledSpectrum::new(400.0, 1.0, vec![f64::NAN]).is_err());
        assert!(matches!(
            DenselySampledSpectrum::from_samples(&[400.0, 410.0, 410.0], &[1.0, 2.0, 3.0]),
            Err(Error::Unsorted { line: 3, .. })
        ));
        assert!(matches!(
            DenselySampledSpectrum::from_samples(&[400.2, 400.5, 400.9], &[1.0, 2.0, 3.0]),
            Err(Error::Empty { .. })
        ));
        assert!(DenselySampledSpectrum::from_samples(&[400.0, 410.0], &[1.0]).is_err());
    }

    #[test]
    fn uneven_samples_resample_exactly_at_whole_nanometres() {
        let s = DenselySampledSpectrum::from_samples(&[400.0, 410.0, 440.0], &[0.0, 1.0, 4.0]).unwrap();
        assert_eq!(s.step(), 1.0);
        assert!((s.eval(405.0) - 0.5).abs() < 1e-12);
        assert!((s.eval(430.0) - 3.0).abs() < 1e-12);
    }

    #[test]
    fn uniform_hero_wavelengths_are_equally_spaced_and_wrap() {
        let w = SampledWavelengths::<4>::sample_uniform(0.9, 360.0, 830.0);
        assert!((w.lambda(0) - (360.0 + 0.9 * 470.0)).abs() < 1e-3);
        for i in 0..4 {
            assert!((360.0..=830.0).contains(&w.lambda(i)));
        }
        let mut w = w;
        w.terminate_secondary();
        assert!(w.secondary_terminated());
        assert!((w.pdf()[0] - 1.0 / 470.0 / 4.0).abs() < 1e-9);
    }

    #[test]
    fn visible_pdf_integrates_to_one() {
        // Σ p(λ) Δλ over 360–830 at 0.1 nm: the density is normalised (pbrt-v4's constant).
        let sum: f64 = (0..4700).map(|i| f64::from(visible_wavelength_pdf(360.05 + i as f32 * 0.1)) * 0.1).sum();
        assert!((sum - 1.0).abs() < 1e-3, "{sum}");
        // The inverse CDF maps u = 0.5 near the density's centre (538 nm).
        assert!((sample_visible_wavelength(0.5) - 538.0).abs() < 15.0);
    }

    #[test]
    fn monte_carlo_xyz_of_equal_energy_is_one() {
        // Average the estimator over many stratified hero samples: Y → 1 for both observers.
        // 4096 strata × 4 lanes of a smooth integrand: the stratified estimate is within
        // 2e-3 (the remaining error is the 1 nm table's own trapezoid-vs-sum difference).
        for observer in [Observer::Cie1931, Observer::Cie1964] {
            let n = 4096;
            let mut y = 0.0f64;
            for k in 0..n {
                let u = (k as f32 + 0.5) / n as f32;
                let w = SampledWavelengths::<4>::sample_visible(u);
                y += f64::from(SampledSpectrum::splat(1.0).to_xyz(&w, observer)[1]);
            }
            assert!((y / f64::from(n) - 1.0).abs() < 2e-3, "{observer:?}: {}", y / f64::from(n));
        }
    }

    #[test]
    fn y_integrals_are_the_table_sums() {
        for observer in [Observer::Cie1931, Observer::Cie1964] {
            let sum: f64 = observer.cmf().y.values().iter().sum();
            // The constants are the sums to the 6 decimals PROVENANCE.md quotes.
            assert!((sum - y_integral(observer)).abs() < 1e-6, "{observer:?}: {sum}");
        }
    }

    #[test]
    fn lane_arithmetic() {
        let a = SampledSpectrum([1.0f32, 2.0, 3.0, 4.0]);
        let b = SampledSpectrum([2.0f32, 0.0, 1.0, 8.0]);
        assert_eq!((a + b).0, [3.0, 2.0, 4.0, 12.0]);
        assert_eq!((a - b).0, [-1.0, 2.0, 2.0, -4.0]);
        assert_eq!((a * b).0, [2.0, 0.0, 3.0, 32.0]);
        assert_eq!((a / b).0[0], 0.5);
        assert!((a / b).0[1].is_infinite());
        assert_eq!(a.safe_div(b).0, [0.5, 0.0, 3.0, 0.5]);
        assert_eq!((a + 1.0).0, [2.0, 3.0, 4.0, 5.0]);
        assert_eq!((a - 1.0).0, [0.0, 1.0, 2.0, 3.0]);
        assert_eq!((a * 2.0).0, [2.0, 4.0, 6.0, 8.0]);
        assert_eq!((a / 2.0).0, [0.5, 1.0, 1.5, 2.0]);
        let mut c = a;
        c += b;
        c *= 0.5;
        c *= b;
        c = c / SampledSpectrum::splat(0.75);
        assert_eq!(c.0, [4.0, 0.0, 4.0 * 2.0 / 3.0, 64.0]);
        c = SampledSpectrum([1.0, 0.0, 1.5, 16.0]);
        assert_eq!(c.max_component(), 16.0);
        assert_eq!(c.min_component(), 0.0);
        assert_eq!(c.average(), 18.5 / 4.0);
        assert!(!c.is_black() && SampledSpectrum::<4>::splat(0.0).is_black());
        assert!(!(a / b).is_finite() && a.is_finite());
        assert_eq!(SampledSpectrum([-4.0f32, 9.0]).sqrt().0, [0.0, 3.0]);
        assert_eq!(SampledSpectrum([-4.0f32, 9.0]).clamp_zero().0, [0.0, 9.0]);
        c[1] = 7.0;
        assert_eq!(c[1], 7.0);
    }

    #[test]
    fn held_to_visible_extends_with_the_end_values() {
        let s = DenselySampledSpectrum::new(380.0, 5.0, vec![0.2, 0.4, 0.6]).unwrap().held_to_visible().unwrap();
        assert_eq!(s.lambda_min(), 360.0);
        assert!(s.lambda_max() >= 830.0);
        // Interpolation between equal held values: exact up to one rounding.
        for (l, v) in [(361.0, 0.2), (387.5, 0.5), (830.0, 0.6)] {
            assert!((s.eval(l) - v).abs() < 1e-15, "{l}: {}", s.eval(l));
        }
        assert_eq!(s.step(), 5.0);
    }

    #[test]
    fn every_grid_is_bounded_before_it_is_allocated() {
        // Issue 16 item 4: the grid was unbounded (terabyte allocations, `capacity overflow`,
        // an integer overflow in `from_samples`).
        let step = DenselySampledSpectrum::new(500.0, 1e-10, vec![1.0, 1.0]).unwrap_err();
        assert_eq!(step.to_string(), "spectrum: wavelength step 1e-10 nm is finer than the minimum, 0.001 nm");
        let many = DenselySampledSpectrum::new(400.0, 1.0, vec![0.0; MAX_SPECTRUM_SAMPLES + 1]).unwrap_err();
        assert!(matches!(many, Error::TooManySamples { limit: MAX_SPECTRUM_SAMPLES, .. }), "{many}");
        // A far last sample made `(last - first) as usize + 1` overflow.
        let far = DenselySampledSpectrum::from_samples(&[400.0, 401.0, 1e300], &[1.0; 3]).unwrap_err();
        assert_eq!(
            far.to_string(),
            "spectrum samples:3: wavelength 1e300 nm is beyond the longest supported, 100000 nm"
        );
        // Uneven samples resampling to more than the limit: refused from the count.
        let wide = DenselySampledSpectrum::from_samples(&[0.5, 2.0, 1.5e5], &[1.0; 3]).unwrap_err();
        assert!(matches!(wide, Error::WavelengthTooLong { line: 3, .. }), "{wide}");
        assert!(matches!(
            DenselySampledSpectrum::constant(1.0).resampled(360.0, 1.0, MAX_SPECTRUM_SAMPLES + 1),
            Err(Error::TooManySamples { .. })
        ));
        assert!(matches!(
            DenselySampledSpectrum::constant(1.0).resampled(360.0, 1e-9, 2),
            Err(Error::StepTooSmall { .. })
        ));
        // Extending a fine grid far from the visible range would need 1e8 samples.
        let fine_ir = DenselySampledSpectrum::new(99_000.0, MIN_STEP_NM, vec![1.0; 2]).unwrap();
        assert!(matches!(fine_ir.held_to_visible(), Err(Error::OutsideVisible { .. })));
        let fine_reaching = DenselySampledSpectrum::new(800.0, MIN_STEP_NM, vec![1.0; 999_000]).unwrap();
        let err = fine_reaching.held_to_visible().unwrap_err();
        assert!(matches!(err, Error::TooManySamples { .. }), "{err}");
        // The finest step still fits the visible range: 470 001 samples.
        let finest = DenselySampledSpectrum::new(360.0, MIN_STEP_NM, vec![1.0; 2]).unwrap().held_to_visible().unwrap();
        assert_eq!(finest.values().len(), 470_001);
    }

    #[test]
    fn numbers_in_messages_are_short() {
        use crate::error::Num;
        let shown: Vec<String> = [545.0, -0.1, 0.001, 0.0, 1e-300, 1e308, 2.5e7, f64::INFINITY]
            .iter()
            .map(|&v| Num(v).to_string())
            .collect();
        assert_eq!(shown, ["545", "-0.1", "0.001", "0", "1e-300", "1e308", "2.5e7", "inf"]);
    }

    proptest! {
        #[test]
        fn resampling_onto_a_finer_grid_and_back_is_exact(values in prop::collection::vec(0.0f64..1.0, 2..40)) {
            let s = DenselySampledSpectrum::new(400.0, 5.0, values.clone()).unwrap();
            let fine = s.resampled(400.0, 1.0, (values.len() - 1) * 5 + 1).unwrap();
            let back = fine.resampled(400.0, 5.0, values.len()).unwrap();
            for (a, b) in back.values().iter().zip(&values) {
                prop_assert!((a - b).abs() < 1e-12);
            }
        }
    }
}
