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
    /// Samples `values` at `lambda_min + i·step` nm.
    pub fn new(lambda_min: f64, step: f64, values: Vec<f64>) -> Result<Self> {
        if !(step > 0.0 && step.is_finite()) {
            return Err(Error::OutOfRange { what: "wavelength step", value: step, range: "> 0, finite" });
        }
        if !lambda_min.is_finite() {
            return Err(Error::OutOfRange { what: "first wavelength", value: lambda_min, range: "finite" });
        }
        if values.is_empty() {
            return Err(Error::Empty { origin: "spectrum".to_owned() });
        }
        if let Some(&v) = values.iter().find(|v| !v.is_finite()) {
            return Err(Error::OutOfRange { what: "spectrum value", value: v, range: "finite" });
        }
        Ok(Self { lambda_min, step, values })
    }

    /// A piecewise-linear spectrum through `(lambdas[i], values[i])`: kept on its own grid
    /// when evenly spaced (exact), otherwise resampled at every whole nanometre of its range
    /// (exact at those wavelengths). Zero outside the given range.
    pub fn from_samples(lambdas: &[f64], values: &[f64]) -> Result<Self> {
        if lambdas.is_empty() || lambdas.len() != values.len() {
            return Err(Error::Empty { origin: "spectrum samples".to_owned() });
        }
        for (i, w) in lambdas.windows(2).enumerate() {
            if !(w[1] > w[0]) {
                // No file here: `line` is the 1-based index of the offending sample.
                return Err(Error::Unsorted {
                    origin: "spectrum samples".to_owned(),
                    line: i + 2,
                    lambda: w[1],
                    previous: w[0],
                });
            }
        }
        if lambdas.len() == 1 {
            return Self::new(lambdas[0], 1.0, values.to_vec());
        }
        let step = lambdas[1] - lambdas[0];
        let even = lambdas.windows(2).all(|w| ((w[1] - w[0]) - step).abs() <= 1e-9 * step.max(1.0));
        if even {
            return Self::new(lambdas[0], step, values.to_vec());
        }
        let (first, last) = (lambdas[0].ceil(), lambdas[lambdas.len() - 1].floor());
        if last < first {
            return Err(Error::Empty { origin: "spectrum samples (no whole nanometre in their range)".to_owned() });
        }
        let count = (last - first) as usize + 1;
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
        Self::new(first, 1.0, out)
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
    /// exact where the new grid contains the old points).
    pub fn resampled(&self, lambda_min: f64, step: f64, count: usize) -> Self {
        let values = (0..count.max(1)).map(|i| self.eval(lambda_min + step * i as f64)).collect();
        Self { lambda_min, step: if step > 0.0 { step } else { 1.0 }, values }
    }

    /// The same spectrum, defined over at least 360–830 nm by holding its first and last
    /// values outside its own range (the CIE's convention for D65 above 780 nm; colour-science
    /// extrapolates tables the same way). The embedded illuminants and ColorChecker are
    /// extended like this; `spectrace color` does the same to the files it reads.
    pub fn held_to_visible(&self) -> Self {
        let lo = f64::from(LAMBDA_MIN).min(self.lambda_min);
        let hi = f64::from(LAMBDA_MAX).max(self.lambda_max());
        let before = ((self.lambda_min - lo) / self.step).ceil() as usize;
        let after = ((hi - self.lambda_max()) / self.step).ceil() as usize;
        let first = self.values[0];
        let last = self.values[self.values.len() - 1];
        let mut values = vec![first; before];
        values.extend_from_slice(&self.values);
        values.extend(std::iter::repeat_n(last, after));
        Self { lambda_min: self.lambda_min - before as f64 * self.step, step: self.step, values }
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
        let s = DenselySampledSpectrum::new(380.0, 5.0, vec![0.2, 0.4, 0.6]).unwrap().held_to_visible();
        assert_eq!(s.lambda_min(), 360.0);
        assert!(s.lambda_max() >= 830.0);
        // Interpolation between equal held values: exact up to one rounding.
        for (l, v) in [(361.0, 0.2), (387.5, 0.5), (830.0, 0.6)] {
            assert!((s.eval(l) - v).abs() < 1e-15, "{l}: {}", s.eval(l));
        }
        assert_eq!(s.step(), 5.0);
    }

    proptest! {
        #[test]
        fn resampling_onto_a_finer_grid_and_back_is_exact(values in prop::collection::vec(0.0f64..1.0, 2..40)) {
            let s = DenselySampledSpectrum::new(400.0, 5.0, values.clone()).unwrap();
            let fine = s.resampled(400.0, 1.0, (values.len() - 1) * 5 + 1);
            let back = fine.resampled(400.0, 5.0, values.len());
            for (a, b) in back.values().iter().zip(&values) {
                prop_assert!((a - b).abs() < 1e-12);
            }
        }
    }
}
