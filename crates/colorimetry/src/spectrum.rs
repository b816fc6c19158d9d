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
/// 2²⁰ samples at that step. A finer step (`500, 500.0000000001` in a file, or
/// `--step 1e-9`) asked for terabytes before this bound.
pub const MIN_STEP_NM: f64 = 1e-3;

/// Most samples one spectrum grid may hold: 2²⁰ f64 = 8 MiB. It fits 360–830 nm at
/// [`MIN_STEP_NM`] (470 001 samples) and a table resampled at 1 nm up to
/// [`MAX_WAVELENGTH_NM`] (100 001 samples).
pub(crate) const MAX_SPECTRUM_SAMPLES: usize = 1 << 20;

/// Longest wavelength a spectrum may name (nm): 100 µm, the far infrared, 120 × the visible
/// range's end. Solar and lamp tables stop at 2500–4000 nm; nothing here is used above 830 nm.
pub(crate) const MAX_WAVELENGTH_NM: f64 = 1e5;

/// Largest magnitude of a spectral value given as samples (a CSV table, a manifest's
/// `samples`, piecewise-linear knots): 1e30. Radiance in photons s⁻¹ m⁻² sr⁻¹ nm⁻¹ of the Sun
/// is ~1e22, so real data fits with margin, while a product of two such values summed over
/// [`MAX_SPECTRUM_SAMPLES`] stays far inside f64 (values of 1e308 made XYZ infinite and printed
/// `null`), and one value stays inside f32 (3.4e38, the renderer's lanes).
pub(crate) const MAX_SPECTRUM_VALUE: f64 = 1e30;

/// Smallest magnitude a spectral value keeps: f32's smallest normal number, 1.18e-38. Every
/// [`DenselySampledSpectrum`] holds smaller values as zero (see `flush_tiny` for why).
pub const MIN_SPECTRUM_VALUE: f64 = f32::MIN_POSITIVE as f64;

/// `v`, or 0 when its magnitude is below [`MIN_SPECTRUM_VALUE`]. Every spectrum's values pass
/// through this, because a value that small is noise no instrument reports, yet it is where
/// arithmetic leaves the normal range: the renderer's lanes are f32, where such a value is
/// subnormal (or zero), so a quantity divided by it overflows to infinity and infinity times a
/// zero lane is NaN, in every sample that meets it. In the f64 sums here the same happens one
/// step earlier for an f64-subnormal value (1e-320): its luminance Σ S ȳ is subnormal, and the
/// normalisation Σ ȳ / Σ S ȳ ([`crate::luminance_normalized`], an illuminant's white in
/// [`crate::reflectance_to_xyz`]) is infinite. Zero is the honest reading and stays finite in
/// every use (a zero luminance is "no light", not a division).
#[inline]
pub(crate) fn flush_tiny(v: f64) -> f64 {
    if v.abs() < MIN_SPECTRUM_VALUE { 0.0 } else { v }
}

/// Whole nanometres in [`LAMBDA_MIN`, `LAMBDA_MAX`]: 471, the rows of the CIE 1 nm tables.
pub(crate) const VISIBLE_SAMPLES: usize = (LAMBDA_MAX - LAMBDA_MIN) as usize + 1;

/// 360, 361, …, 830 nm in order: the 1 nm grid of the CIE tables, on which the colorimetric
/// sums and every 1 nm spectrum of this crate are taken (whole numbers, exact in f64).
pub(crate) fn visible_nm() -> impl Iterator<Item = f64> {
    (0..VISIBLE_SAMPLES).map(|i| f64::from(LAMBDA_MIN) + i as f64)
}

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

/// The one check of a wavelength step (a spectrum's grid, an [`crate::Integration`]): finite
/// and at least [`MIN_STEP_NM`]; `origin` names the grid in the error.
pub(crate) fn check_step(origin: &str, step: f64) -> Result<()> {
    if step >= MIN_STEP_NM && step.is_finite() {
        return Ok(());
    }
    Err(if step > 0.0 && step < MIN_STEP_NM {
        Error::StepTooSmall { origin: origin.to_owned(), step, min: MIN_STEP_NM }
    } else {
        Error::OutOfRange { what: "wavelength step", value: step, range: "> 0, finite" }
    })
}

/// Where samples come from, for the errors of their checks.
#[derive(Debug, Clone, Copy)]
pub(crate) struct SampleSource<'a> {
    /// The file (or other source) name.
    pub(crate) origin: &'a str,
    /// What the wavelength and the value are called in messages (a file's column headers).
    pub(crate) columns: [&'a str; 2],
    /// The file line of each sample; without a file, sample `i` is reported as `i + 1`.
    pub(crate) lines: Option<&'a [usize]>,
}

impl<'a> SampleSource<'a> {
    /// Samples that are not from a file: `[nm, value]` pairs, sample `i` reported as `i + 1`.
    pub(crate) fn unfiled(origin: &'a str) -> Self {
        Self { origin, columns: ["nm", "value"], lines: None }
    }

    /// The same source with its value column called `column`.
    pub(crate) fn with_value_column(self, column: &'a str) -> Self {
        Self { columns: [self.columns[0], column], ..self }
    }

    fn line(&self, i: usize) -> usize {
        self.lines.map_or(i + 1, |lines| lines[i])
    }
}

/// Every wavelength finite, > 0, at most [`MAX_WAVELENGTH_NM`] and after the previous one by
/// at least [`MIN_STEP_NM`]; the error names the first offending sample.
pub(crate) fn check_wavelengths(source: &SampleSource<'_>, lambdas: &[f64]) -> Result<()> {
    let origin = || source.origin.to_owned();
    for (i, &lambda) in lambdas.iter().enumerate() {
        let line = source.line(i);
        if !lambda.is_finite() {
            let column = source.columns[0].to_owned();
            return Err(Error::NotFinite { origin: origin(), line, column, value: lambda });
        }
        if lambda <= 0.0 {
            return Err(Error::BadWavelength { origin: origin(), line, lambda });
        }
        if lambda > MAX_WAVELENGTH_NM {
            return Err(Error::WavelengthTooLong { origin: origin(), line, lambda, max: MAX_WAVELENGTH_NM });
        }
        if i > 0 {
            let previous = lambdas[i - 1];
            if !(lambda > previous) {
                return Err(Error::Unsorted { origin: origin(), line, lambda, previous });
            }
            if lambda - previous < MIN_STEP_NM {
                return Err(Error::RowsTooClose { origin: origin(), line, lambda, previous, min: MIN_STEP_NM });
            }
        }
    }
    Ok(())
}

/// Every value finite and at most [`MAX_SPECTRUM_VALUE`] in magnitude; the error names the
/// first offending sample.
pub(crate) fn check_values(source: &SampleSource<'_>, values: &[f64]) -> Result<()> {
    let Some(i) = values.iter().position(|v| !(v.abs() <= MAX_SPECTRUM_VALUE)) else {
        return Ok(());
    };
    let (origin, line, column, value) =
        (source.origin.to_owned(), source.line(i), source.columns[1].to_owned(), values[i]);
    Err(if value.is_finite() {
        Error::ValueTooLarge { origin, line, column, value, max: MAX_SPECTRUM_VALUE }
    } else {
        Error::NotFinite { origin, line, column, value }
    })
}

/// [`check_wavelengths`] and [`check_values`] of `(lambdas[i], values[i])`, which must be as
/// many and at least one.
pub(crate) fn check_samples(source: &SampleSource<'_>, lambdas: &[f64], values: &[f64]) -> Result<()> {
    if lambdas.is_empty() || lambdas.len() != values.len() {
        return Err(Error::Empty { origin: source.origin.to_owned() });
    }
    check_wavelengths(source, lambdas)?;
    check_values(source, values)
}

/// The grid [`DenselySampledSpectrum::from_samples`] puts samples on, laid out from their
/// wavelengths alone, so that a table of many columns is checked and sized once.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum SampleGrid {
    /// Evenly spaced wavelengths: the samples' own grid (exact).
    Even {
        /// First wavelength (nm).
        first: f64,
        /// Spacing (nm).
        step: f64,
        /// Samples.
        count: usize,
    },
    /// Uneven wavelengths: every whole nanometre of their range, from `first`.
    WholeNanometres {
        /// First whole nanometre.
        first: f64,
        /// Whole nanometres in the range.
        count: usize,
    },
}

impl SampleGrid {
    /// Checks the wavelengths ([`check_wavelengths`]) and lays out their grid, bounded by
    /// [`MAX_SPECTRUM_SAMPLES`] before anything is allocated.
    pub(crate) fn new(source: &SampleSource<'_>, lambdas: &[f64]) -> Result<Self> {
        if lambdas.is_empty() {
            return Err(Error::Empty { origin: source.origin.to_owned() });
        }
        check_wavelengths(source, lambdas)?;
        if lambdas.len() == 1 {
            return Ok(Self::Even { first: lambdas[0], step: 1.0, count: 1 });
        }
        let step = lambdas[1] - lambdas[0];
        let even = lambdas.windows(2).all(|w| ((w[1] - w[0]) - step).abs() <= 1e-9 * step.max(1.0));
        if even {
            let count = lambdas.len();
            if count > MAX_SPECTRUM_SAMPLES {
                return Err(Error::TooManySamples {
                    origin: source.origin.to_owned(),
                    line: None,
                    what: "samples",
                    samples: count as f64,
                    limit: MAX_SPECTRUM_SAMPLES,
                });
            }
            return Ok(Self::Even { first: lambdas[0], step, count });
        }
        let (first, last) = (lambdas[0].ceil(), lambdas[lambdas.len() - 1].floor());
        if last < first {
            return Err(Error::Empty { origin: format!("{} (no whole nanometre in their range)", source.origin) });
        }
        // Wavelengths are in (0, MAX_WAVELENGTH_NM]: at most 100 000 whole nanometres, within
        // MAX_SPECTRUM_SAMPLES (a 1e300 nm row used to overflow the count here).
        Ok(Self::WholeNanometres { first, count: (last - first) as usize + 1 })
    }

    /// Values of one spectrum on this grid.
    pub(crate) fn len(&self) -> usize {
        match *self {
            Self::Even { count, .. } | Self::WholeNanometres { count, .. } => count,
        }
    }

    /// The piecewise-linear spectrum through `(lambdas[i], values[i])` on this grid (made by
    /// [`SampleGrid::new`] from the same `lambdas`); the values are checked
    /// ([`check_values`]).
    pub(crate) fn spectrum(
        &self,
        source: &SampleSource<'_>,
        lambdas: &[f64],
        values: &[f64],
    ) -> Result<DenselySampledSpectrum> {
        if values.len() != lambdas.len() {
            return Err(Error::Empty { origin: source.origin.to_owned() });
        }
        check_values(source, values)?;
        match *self {
            Self::Even { first, step, .. } => {
                DenselySampledSpectrum::new_in(source.origin, first, step, values.to_vec())
            }
            Self::WholeNanometres { first, count } => {
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
                DenselySampledSpectrum::new_in(source.origin, first, 1.0, out)
            }
        }
    }
}

/// A spectrum tabulated on an even wavelength grid; linear interpolation between samples and
/// zero outside the grid. Values are finite by construction, and zero or at least
/// [`MIN_SPECTRUM_VALUE`] in magnitude.
#[derive(Debug, Clone, PartialEq)]
pub struct DenselySampledSpectrum {
    lambda_min: f64,
    step: f64,
    values: Vec<f64>,
}

impl DenselySampledSpectrum {
    /// Samples `values` at `lambda_min + i·step` nm. The grid is bounded: step ≥
    /// [`MIN_STEP_NM`], at most 2²⁰ values.
    pub fn new(lambda_min: f64, step: f64, values: Vec<f64>) -> Result<Self> {
        Self::new_in("spectrum", lambda_min, step, values)
    }

    /// [`Self::new`] with `origin` naming the source in errors.
    pub(crate) fn new_in(origin: &str, lambda_min: f64, step: f64, mut values: Vec<f64>) -> Result<Self> {
        check_step(origin, step)?;
        if !lambda_min.is_finite() {
            return Err(Error::OutOfRange { what: "first wavelength", value: lambda_min, range: "finite" });
        }
        if values.is_empty() {
            return Err(Error::Empty { origin: origin.to_owned() });
        }
        if values.len() > MAX_SPECTRUM_SAMPLES {
            return Err(Error::TooManySamples {
                origin: origin.to_owned(),
                line: None,
                what: "samples",
                samples: values.len() as f64,
                limit: MAX_SPECTRUM_SAMPLES,
            });
        }
        if let Some(&v) = values.iter().find(|v| !v.is_finite()) {
            return Err(Error::OutOfRange { what: "spectrum value", value: v, range: "finite" });
        }
        for v in &mut values {
            *v = flush_tiny(*v);
        }
        Ok(Self { lambda_min, step, values })
    }

    /// `f` at every whole nanometre of 360–830 nm ([`visible_nm`]): the 1 nm grid of the CIE
    /// tables. Errors where `f` is not finite.
    pub(crate) fn from_fn_visible(f: impl Fn(f64) -> f64) -> Result<Self> {
        Self::new(f64::from(LAMBDA_MIN), 1.0, visible_nm().map(f).collect())
    }

    /// A piecewise-linear spectrum through `(lambdas[i], values[i])`: kept on its own grid
    /// when evenly spaced (exact), otherwise resampled at every whole nanometre of its range
    /// (exact at those wavelengths). Zero outside the given range.
    ///
    /// Every sample is checked, the error naming the first offending one by its 1-based
    /// index: wavelengths finite, > 0, at most 100 000 nm, increasing by at least
    /// [`MIN_STEP_NM`]; values finite and at most 1e30 in magnitude (so that colour sums stay
    /// finite). The grid bounds of [`Self::new`] apply, checked before it is allocated.
    pub fn from_samples(lambdas: &[f64], values: &[f64]) -> Result<Self> {
        let source = SampleSource::unfiled("spectrum samples");
        if lambdas.len() != values.len() {
            return Err(Error::Empty { origin: source.origin.to_owned() });
        }
        SampleGrid::new(&source, lambdas)?.spectrum(&source, lambdas, values)
    }

    /// The same value at every nanometre of 360–830 nm.
    pub fn constant(value: f64) -> Self {
        let value = flush_tiny(value);
        Self { lambda_min: f64::from(LAMBDA_MIN), step: 1.0, values: vec![value; VISIBLE_SAMPLES] }
    }

    /// The value at `lambda` nm: linear interpolation, 0 outside the grid.
    #[inline]
    pub fn eval(&self, lambda: f64) -> f64 {
        if self.values.len() == 1 {
            return if self.locate(lambda).is_some() { self.values[0] } else { 0.0 };
        }
        self.locate(lambda).map_or(0.0, |(i, f)| self.interpolate(i, f))
    }

    /// Where `lambda` falls on the grid: the interval `i` and the fraction `f` within it (`i` + 1 a valid
    /// index for grids of two or more points); `None` outside the grid. Spectra on the same grid share it
    /// (`SampledSpectrum::to_xyz` locates once for x̄, ȳ, z̄).
    #[inline]
    fn locate(&self, lambda: f64) -> Option<(usize, f64)> {
        let pos = (lambda - self.lambda_min) / self.step;
        let last = (self.values.len() - 1) as f64;
        // A hair of tolerance so the last grid point is inside despite rounding of `pos`.
        if !(pos >= -1e-9 && pos <= last + 1e-9) {
            return None;
        }
        let pos = pos.clamp(0.0, last);
        let i = (pos as usize).min(self.values.len().saturating_sub(2));
        Some((i, pos - i as f64))
    }

    /// The linear interpolation at [`Self::locate`]'s (`i`, `f`) (a grid of two or more points).
    #[inline]
    fn interpolate(&self, i: usize, f: f64) -> f64 {
        self.values[i] * (1.0 - f) + self.values[i + 1] * f
    }

    /// Whether `other` has the same grid (first wavelength, step and length), so that one
    /// [`Self::locate`] serves both.
    fn same_grid(&self, other: &Self) -> bool {
        self.lambda_min == other.lambda_min && self.step == other.step && self.values.len() == other.values.len()
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

    /// `f` applied to every value (e.g. R(λ)ⁿ, t_λ^b). Non-finite and tiny results become 0 so
    /// the invariants hold.
    pub fn map(&self, f: impl Fn(f64) -> f64) -> Self {
        let values = self
            .values
            .iter()
            .map(|&v| {
                let r = f(v);
                if r.is_finite() { flush_tiny(r) } else { 0.0 }
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
            .map(|(i, &v)| flush_tiny(v * other.eval(self.lambda_min + self.step * i as f64)))
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
                line: None,
                what: "samples",
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
    /// extended grid of more than 2²⁰ samples (checked before allocating).
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
                line: None,
                what: "samples",
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
    /// p(λ) ∝ [`visible_wavelength_shape`] = sech²(0.0072 (λ − 538)) over 360–830 nm.
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

/// Centre of the visible-range wavelength density (nm): pbrt-v4 `VisibleWavelengthsPDF`
/// (`util/sampling.h`).
pub const VISIBLE_PDF_CENTER_NM: f64 = 538.0;

/// Rate of the visible-range density's fall-off (1/nm), pbrt-v4 `VisibleWavelengthsPDF`: the
/// density is ∝ sech²(rate · (λ − centre)), half its peak about 122 nm either side.
pub const VISIBLE_PDF_RATE_PER_NM: f64 = 0.0072;

/// The shape of the visible-range density, `sech²(0.0072 (λ − 538))` ([`VISIBLE_PDF_RATE_PER_NM`],
/// [`VISIBLE_PDF_CENTER_NM`]), 1 at the centre and not normalised, in f64: the one definition
/// of the curve. Hero sampling ([`SampledWavelengths::sample_visible`]) evaluates the same
/// expression in f32 on the hot path; the film's illuminant-driven table mixes this shape in.
pub fn visible_wavelength_shape(lambda: f64) -> f64 {
    let c = (VISIBLE_PDF_RATE_PER_NM * (lambda - VISIBLE_PDF_CENTER_NM)).cosh();
    1.0 / (c * c)
}

/// [`VISIBLE_PDF_CENTER_NM`] and [`VISIBLE_PDF_RATE_PER_NM`] in f32 (both exact conversions of
/// the literals: the test `visible_density_constants_are_pbrts` checks the bits), and the
/// inverse rate of the inverse CDF.
const CENTER_F32: f32 = VISIBLE_PDF_CENTER_NM as f32;
const RATE_F32: f32 = VISIBLE_PDF_RATE_PER_NM as f32;
const INVERSE_RATE_F32: f32 = (1.0 / VISIBLE_PDF_RATE_PER_NM) as f32;

/// `tanh(rate · (centre − 360))`, as pbrt-v4 rounds it (0.85691062; 1 f32 ulp below the
/// f32 of the exact value, kept so that sampled wavelengths keep their bits).
const VISIBLE_CDF_LOW: f32 = 0.856_910_6;
/// `tanh(rate · (centre − 360)) + tanh(rate · (830 − centre))` (pbrt-v4's 1.82750197, the same f32).
const VISIBLE_CDF_SPAN: f32 = 1.827_502;
/// `rate / VISIBLE_CDF_SPAN`: the density's normalisation over 360–830 nm (pbrt-v4's
/// 0.0039398042).
const VISIBLE_PDF_NORM: f32 = 0.003_939_804;

/// Inverse CDF of the visible-range density (pbrt-v4 `SampleVisibleWavelengths`).
fn sample_visible_wavelength(u: f32) -> f32 {
    CENTER_F32 - INVERSE_RATE_F32 * (VISIBLE_CDF_LOW - VISIBLE_CDF_SPAN * u).atanh()
}

/// pbrt-v4 `VisibleWavelengthsPDF`: [`visible_wavelength_shape`] normalised over 360–830 nm,
/// in f32 (0 outside).
fn visible_wavelength_pdf(lambda: f32) -> f32 {
    if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&lambda) {
        return 0.0;
    }
    let c = (RATE_F32 * (lambda - CENTER_F32)).cosh();
    VISIBLE_PDF_NORM / (c * c)
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

    /// Largest lane (NaN lanes ignored; −∞ if every lane is NaN).
    #[inline]
    pub fn max_component(&self) -> f32 {
        // Eight running maxima, each a compare-and-select, instead of one fold with `f32::max`:
        // that fold is a serial chain with a NaN fix-up per lane (about 7 scalar instructions a
        // lane in the path tracer's Russian roulette, docs/perf.md), while `if v > m` is exactly
        // x86's `maxps` and vectorises. A maximum does not depend on the order it is taken in,
        // so the value is the fold's (NaN is skipped by both; of a −0 and a +0 lane either may
        // come out, as with `f32::max`, and every caller only compares the result).
        let mut m = [f32::NEG_INFINITY; 8];
        for chunk in self.0.chunks(8) {
            for (m, &v) in m.iter_mut().zip(chunk) {
                *m = if v > *m { v } else { *m };
            }
        }
        m.into_iter().fold(f32::NEG_INFINITY, |a, v| if v > a { v } else { a })
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
        // The three functions share one grid (the CIE tables do): each wavelength is located once, the
        // same arithmetic as three `eval`s (bit for bit).
        let shared = cmf.x.values.len() >= 2 && cmf.x.same_grid(&cmf.y) && cmf.x.same_grid(&cmf.z);
        let mut xyz = [0.0f64; 3];
        for i in 0..N {
            let p = lambda.pdf[i];
            if p == 0.0 {
                continue;
            }
            let l = f64::from(lambda.lambda[i]);
            let w = f64::from(self.0[i]) / f64::from(p);
            if shared {
                if let Some((j, f)) = cmf.x.locate(l) {
                    xyz[0] += cmf.x.interpolate(j, f) * w;
                    xyz[1] += cmf.y.interpolate(j, f) * w;
                    xyz[2] += cmf.z.interpolate(j, f) * w;
                } else {
                    // `eval` is 0 there: adding 0 · w keeps a NaN or infinite w as three evals would.
                    xyz.iter_mut().for_each(|v| *v += 0.0 * w);
                }
            } else {
                xyz[0] += cmf.x.eval(l) * w;
                xyz[1] += cmf.y.eval(l) * w;
                xyz[2] += cmf.z.eval(l) * w;
            }
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

    /// `to_xyz` locates each wavelength once for x̄, ȳ, z̄; it must give, bit for bit, the sums of three
    /// `eval`s, at grid points, between them, at and beyond both ends, at NaN, and for infinite, NaN,
    /// zero and negative values (the lanes of zero density are skipped by both).
    #[test]
    fn to_xyz_is_three_evals_bit_for_bit() {
        let lambda = [360.0, 555.5, 829.99, 830.0, 830.0001, 300.0, f32::NAN, 471.25];
        let values = [
            [1.0, 0.5, 2.0, 0.25, 1.0, 3.0, 1.0, 0.75],
            [f32::INFINITY, 1.0, f32::NAN, 1.0, f32::INFINITY, f32::NAN, f32::INFINITY, -2.0],
            [0.0, -0.0, 1e-30, 1e30, 0.5, 0.0, 0.0, 1.0],
        ];
        for observer in [Observer::Cie1931, Observer::Cie1964] {
            let cmf = observer.cmf();
            for pdf in [[1.0 / 470.0; 8], [0.003, 0.0, 0.002, 0.001, 0.0, 0.004, 0.002, 0.001]] {
                let l = SampledWavelengths { lambda, pdf };
                for v in values {
                    let got = SampledSpectrum(v).to_xyz(&l, observer);
                    let mut xyz = [0.0f64; 3];
                    for i in 0..8 {
                        if pdf[i] == 0.0 {
                            continue;
                        }
                        let (w, at) = (f64::from(v[i]) / f64::from(pdf[i]), f64::from(lambda[i]));
                        xyz[0] += cmf.x.eval(at) * w;
                        xyz[1] += cmf.y.eval(at) * w;
                        xyz[2] += cmf.z.eval(at) * w;
                    }
                    let norm = 8.0 * y_integral(observer);
                    let want = xyz.map(|c| (c / norm) as f32);
                    assert_eq!(
                        got.map(f32::to_bits),
                        want.map(f32::to_bits),
                        "{observer:?} {v:?} {pdf:?}: {got:?} vs {want:?}"
                    );
                }
            }
        }
    }

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
    fn every_sample_is_checked_by_the_constructor() {
        // A manifest's `{"samples": …}` took [-5, 400] nm and a value of 3e38 (only the CSV
        // parser checked them); the constructor now does, naming the sample by its index.
        let e = |l: &[f64], v: &[f64]| DenselySampledSpectrum::from_samples(l, v).unwrap_err().to_string();
        assert_eq!(e(&[-5.0, 400.0], &[1.0, 1.0]), "spectrum samples:1: wavelength -5 nm must be > 0");
        assert_eq!(
            e(&[400.0, 500.0], &[1.0, 3e38]),
            "spectrum samples:2: column `value`: 3e38 is too large (spectra must be <= 1e30)"
        );
        assert_eq!(e(&[400.0, 500.0], &[-2e30, 1.0]).split(':').nth(1), Some("1"));
        assert_eq!(e(&[400.0, 500.0], &[1.0, f64::NAN]), "spectrum samples:2: column `value`: NaN is not finite");
        assert_eq!(e(&[400.0, f64::INFINITY], &[1.0, 1.0]), "spectrum samples:2: column `nm`: inf is not finite");
        // Rows closer than the finest step, even where the rest is uneven (it used to be
        // resampled quietly).
        assert!(
            e(&[400.0, 500.0, 500.0000001], &[1.0; 3])
                .starts_with("spectrum samples:3: wavelength 500.0000001 nm is only")
        );
        // The bound itself and negative values (a CSV policy, not the constructor's) pass.
        let ok = DenselySampledSpectrum::from_samples(&[400.0, 500.0], &[-1e30, 1e30]).unwrap();
        assert_eq!((ok.eval(400.0), ok.eval(500.0)), (-1e30, 1e30));
    }

    #[test]
    fn the_visible_grid_is_the_whole_nanometres() {
        let grid: Vec<f64> = visible_nm().collect();
        assert_eq!(grid.len(), 471);
        // The grids it replaced: `360 + i`, `T_ORIGIN_NM + i · 1.0` and `f64::from(360..=830)`.
        for (i, &l) in grid.iter().enumerate() {
            assert_eq!(l.to_bits(), (360.0 + i as f64).to_bits());
            assert_eq!(l.to_bits(), f64::from(360 + i as u32).to_bits());
        }
        let s = DenselySampledSpectrum::from_fn_visible(|l| l * 0.5).unwrap();
        assert_eq!((s.lambda_min(), s.step(), s.values().len()), (360.0, 1.0, 471));
        assert_eq!(s.eval(830.0), 415.0);
        assert_eq!(DenselySampledSpectrum::constant(2.0).values().len(), VISIBLE_SAMPLES);
        assert!(DenselySampledSpectrum::from_fn_visible(|l| if l > 800.0 { f64::NAN } else { 1.0 }).is_err());
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

    /// The f32 constants of the hot path are the literals pbrt-v4 writes, and those are the
    /// curve's ([`VISIBLE_PDF_CENTER_NM`], [`VISIBLE_PDF_RATE_PER_NM`]) to f32 rounding; the f32
    /// density is the f64 shape, normalised.
    #[test]
    fn visible_density_constants_are_pbrts() {
        // The bits the sampler used before the constants were named.
        assert_eq!(CENTER_F32.to_bits(), 538.0f32.to_bits());
        assert_eq!(RATE_F32.to_bits(), 0.0072f32.to_bits());
        assert_eq!(INVERSE_RATE_F32.to_bits(), 138.888_89f32.to_bits());
        let rate = VISIBLE_PDF_RATE_PER_NM;
        let low = (rate * (VISIBLE_PDF_CENTER_NM - f64::from(LAMBDA_MIN))).tanh();
        let span = low + (rate * (f64::from(LAMBDA_MAX) - VISIBLE_PDF_CENTER_NM)).tanh();
        // Within 1 f32 ulp of the exact values (pbrt-v4 truncates tanh to 8 digits).
        let ulp = |x: f32| f64::from(x) * f64::from(f32::EPSILON);
        assert!((f64::from(VISIBLE_CDF_LOW) - low).abs() <= ulp(VISIBLE_CDF_LOW), "{low}");
        assert!((f64::from(VISIBLE_CDF_SPAN) - span).abs() <= ulp(VISIBLE_CDF_SPAN), "{span}");
        assert!((f64::from(VISIBLE_PDF_NORM) - rate / span).abs() <= ulp(VISIBLE_PDF_NORM), "{}", rate / span);
        // The ends of the inverse CDF are the ends of the range.
        assert!((sample_visible_wavelength(0.0) - LAMBDA_MIN).abs() < 1e-3);
        assert!((sample_visible_wavelength(1.0) - LAMBDA_MAX).abs() < 0.05, "{}", sample_visible_wavelength(1.0));
        for nm in [360.0f32, 450.0, 538.0, 600.0, 700.0, 830.0] {
            let f32_pdf = f64::from(visible_wavelength_pdf(nm));
            let f64_pdf = visible_wavelength_shape(f64::from(nm)) * rate / span;
            assert!((f32_pdf / f64_pdf - 1.0).abs() < 1e-6, "{nm}: {f32_pdf} vs {f64_pdf}");
        }
        assert_eq!(visible_wavelength_shape(VISIBLE_PDF_CENTER_NM), 1.0);
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
        // The grid used to be unbounded (terabyte allocations, `capacity overflow`,
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
        fn max_component_is_the_max_fold_in_any_order(
            lanes in prop::collection::vec(prop_oneof![
                4 => -1e3f32..1e3,
                1 => Just(f32::NAN),
                1 => Just(0.0f32),
                1 => Just(f32::INFINITY),
                1 => Just(f32::NEG_INFINITY),
            ], 64),
        ) {
            // The fold it replaced (docs/perf.md), at every lane count a render uses.
            fn check<const N: usize>(lanes: &[f32]) {
                let s = SampledSpectrum::<N>(lanes[..N].try_into().unwrap());
                let want = s.0.iter().copied().fold(f32::NEG_INFINITY, f32::max);
                assert_eq!(s.max_component().to_bits(), want.to_bits(), "{:?}", s.0);
            }
            check::<3>(&lanes);
            check::<4>(&lanes);
            check::<8>(&lanes);
            check::<13>(&lanes);
            check::<32>(&lanes);
            check::<64>(&lanes);
        }

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
