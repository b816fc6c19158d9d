//! The film: how each sample's wavelengths are chosen ([`Sensor`]) and the exact per-pixel sums
//! samples are added to ([`Film`]); film files ([`file`]) carry it between processes. What is
//! made of the sums for display (the image, its view, the files) is `output/`.
//!
//! **Why fixed-point sums.** A render split by sample range over several processes or machines
//! must merge to exactly the bits of one render. Floating-point addition is not associative,
//! so a film of f64 sums would depend on the order in which parts are added. The film instead
//! adds every sample value as a 128-bit integer with 64 fractional bits: integer addition is
//! associative, so any partition of the samples, any thread count and any merge order give
//! the same sums. An f32 sample value is converted exactly for |v| ≥ 2⁻⁴¹ (its 24-bit mantissa
//! fits above the 2⁻⁶⁴ step) and truncated below (an error under 2⁻⁶⁴ per sample). The sums
//! are then exact, which plain f64 sums of f32 values also are unless their exponents span
//! more than 29 bits; so images come out bit-identical to f64 accumulation almost always, and
//! otherwise within one f32 rounding.

use colorimetry::{DenselySampledSpectrum, LAMBDA_MAX, LAMBDA_MIN, Observer, SampledSpectrum, SampledWavelengths};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::spectral::Lanes;

pub(crate) mod estimate;
pub(crate) mod file;
mod fixed;
pub(crate) mod splat;

use splat::{SplatScales, SplatSums, SplatTarget};

pub(crate) use fixed::{
    FRACTION_BITS, MAX_SPP, MAX_SQUARED_LUMINANCE, SQUARE_FRACTION_BITS, clamp_sample, from_fixed, pixel_mean,
    pixel_value, second_half, second_half_count, to_fixed, to_fixed_f32,
};

/// What a pixel's first camera ray hit: a material (by index; `None` = the default material)
/// or nothing. Reports use it to average over objects (e.g. "the spheres").
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ObjectId {
    /// The ray escaped.
    Background,
    /// The ray hit a surface with this material index.
    Material(Option<u32>),
}

/// One pixel's sums: Σ X, Σ Y, Σ Z, Σ Y² (fixed point) and the number of samples.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct PixelSums {
    pub(crate) xyz: [i128; 3],
    pub(crate) y2: i128,
    pub(crate) count: u32,
}

/// The per-pixel sums of one render or of a range of its samples. Films of disjoint sample
/// ranges of the same render merge ([`Film::merge`]) into exactly the film of their union.
#[derive(Debug, Clone, PartialEq)]
pub struct Film {
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) pixels: Vec<PixelSums>,
    /// Wavelengths of the spectral channels (empty: no spectral film).
    pub(crate) wavelengths: Vec<f32>,
    /// Σ lane radiance per pixel and wavelength, pixel-major.
    pub(crate) spectral: Vec<i128>,
    /// Σ X, Σ Y, Σ Z per pixel of the samples in the second half ([`second_half`]), or empty:
    /// with the whole sums they make two half-films, whose difference estimates each pixel's
    /// error ([`estimate`]). Kept only when asked for ([`Film::with_halves`]).
    pub(crate) halves: Vec<[i128; 3]>,
    /// Light samples sent to other pixels than their own, or empty ([`Film::with_splats`]).
    pub(crate) splats: SplatSums,
    /// What each pixel's sample 0 hit (valid where `has_first_sample`).
    pub(crate) ids: Vec<ObjectId>,
    pub(crate) has_first_sample: bool,
    /// Samples whose value was NaN or infinite (added as black; must be 0), and splats (dropped).
    pub(crate) nonfinite: u64,
    /// Sample and splat values that exceeded [`fixed::MAX_SAMPLE_VALUE`] (clamped).
    pub(crate) clamped: u64,
}

/// One row of a film, lent to a worker thread.
pub(crate) struct FilmRow<'a> {
    pixels: &'a mut [PixelSums],
    halves: &'a mut [[i128; 3]],
    spectral: &'a mut [i128],
    ids: &'a mut [ObjectId],
    lanes: usize,
    pub(crate) nonfinite: u64,
    pub(crate) clamped: u64,
}

impl Film {
    /// An empty film; `wavelengths` non-empty keeps per-wavelength sums too.
    pub(crate) fn new(width: u32, height: u32, wavelengths: Vec<f32>) -> Self {
        let n = width as usize * height as usize;
        Self {
            width,
            height,
            pixels: vec![PixelSums::default(); n],
            spectral: vec![0; n * wavelengths.len()],
            halves: Vec::new(),
            splats: SplatSums::default(),
            wavelengths,
            ids: vec![ObjectId::Background; n],
            has_first_sample: false,
            nonfinite: 0,
            clamped: 0,
        }
    }

    /// This film keeping the sums of the second half-film too ([`second_half`]), so that each
    /// pixel's error can be estimated ([`Film::error_estimate`]).
    pub(crate) fn with_halves(mut self) -> Self {
        self.halves = vec![[0; 3]; self.pixels.len()];
        if self.has_splats() {
            self.splats.halves = vec![[0; 3]; self.pixels.len()];
        }
        self
    }

    /// Whether the film keeps the half-film sums that estimate its error.
    pub fn has_halves(&self) -> bool {
        !self.halves.is_empty()
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Samples taken in pixel (`x`, `y`).
    pub fn sample_count(&self, x: u32, y: u32) -> u32 {
        self.pixels[y as usize * self.width as usize + x as usize].count
    }

    /// Fewest samples taken in any pixel.
    pub fn min_sample_count(&self) -> u32 {
        self.pixels.iter().map(|p| p.count).min().unwrap_or(0)
    }

    /// Most samples taken in any pixel.
    pub fn max_sample_count(&self) -> u32 {
        self.pixels.iter().map(|p| p.count).max().unwrap_or(0)
    }

    /// Samples taken in each pixel, row by row from the top.
    pub fn sample_counts(&self) -> Vec<u32> {
        self.pixels.iter().map(|p| p.count).collect()
    }

    /// Wavelengths (nm) of the spectral sums (empty without a spectral film).
    pub fn wavelengths(&self) -> &[f32] {
        &self.wavelengths
    }

    /// Each pixel's mean luminance Y, as its image shows it, row by row.
    pub(crate) fn mean_luminances(&self) -> Box<dyn Iterator<Item = f32> + '_> {
        match self.splat_scales(0) {
            None => Box::new(self.pixels.iter().map(|p| pixel_mean(p.xyz[1], p.count))),
            Some(scales) => Box::new(
                self.pixels
                    .iter()
                    .zip(&self.splats.xyz)
                    .map(move |(p, s)| pixel_value(p.xyz[1], p.count, s[1], scales.whole)),
            ),
        }
    }

    /// Samples that were NaN or infinite (added as black).
    pub fn nonfinite_samples(&self) -> u64 {
        self.nonfinite
    }

    /// Samples beyond the film's range (2⁴²), clamped to it.
    pub fn clamped_samples(&self) -> u64 {
        self.clamped
    }

    /// The rows, in parallel, for one pass of the pixel loop.
    #[cfg(test)]
    pub(crate) fn rows_mut(&mut self) -> impl IndexedParallelIterator<Item = FilmRow<'_>> + '_ {
        self.pass_mut().0
    }

    /// The rows, in parallel, for one pass of the pixel loop, and the splat sums, which any row
    /// adds to (nothing without splats); the splat target's counters go to
    /// [`Film::add_counts`] after the pass.
    pub(crate) fn pass_mut(&mut self) -> (impl IndexedParallelIterator<Item = FilmRow<'_>> + '_, SplatTarget<'_>) {
        let width = self.width as usize;
        let lanes = self.wavelengths.len();
        let splats = SplatTarget::new(&mut self.splats, width, lanes);
        let spectral_row = (width * lanes).max(1);
        // Without a spectral film each row gets an empty slice (chunks of an empty vector
        // would be too few to zip).
        let empty = self.spectral.is_empty();
        let height = self.height as usize;
        let spectral = if empty {
            rayon::iter::Either::Left((0..height).into_par_iter().map(|_| -> &mut [i128] { &mut [] }))
        } else {
            rayon::iter::Either::Right(self.spectral.par_chunks_mut(spectral_row))
        };
        let halves = if self.halves.is_empty() {
            rayon::iter::Either::Left((0..height).into_par_iter().map(|_| -> &mut [[i128; 3]] { &mut [] }))
        } else {
            rayon::iter::Either::Right(self.halves.par_chunks_mut(width))
        };
        let rows = self.pixels.par_chunks_mut(width).zip(self.ids.par_chunks_mut(width)).zip(spectral).zip(halves).map(
            move |(((pixels, ids), spectral), halves)| FilmRow {
                pixels,
                halves,
                spectral,
                ids,
                lanes,
                nonfinite: 0,
                clamped: 0,
            },
        );
        (rows, splats)
    }

    /// Add the counters of finished rows.
    pub(crate) fn add_counts(&mut self, nonfinite: u64, clamped: u64) {
        self.nonfinite += nonfinite;
        self.clamped += clamped;
    }

    pub(crate) fn set_has_first_sample(&mut self) {
        self.has_first_sample = true;
    }

    /// Add `other`, the film of a disjoint range of samples of the same render: the result is
    /// bit for bit the film of both ranges rendered at once.
    pub fn merge(&mut self, other: &Film) -> Result<()> {
        if (self.width, self.height) != (other.width, other.height)
            || self.wavelengths != other.wavelengths
            || self.has_halves() != other.has_halves()
            || self.has_splats() != other.has_splats()
        {
            return Err(Error::InvalidOption {
                option: "film to merge",
                value: format!(
                    "{}x{} with {} wavelengths{}{}",
                    other.width,
                    other.height,
                    other.wavelengths.len(),
                    if other.has_halves() { " and half-film sums" } else { "" },
                    if other.has_splats() { " and splat sums" } else { "" }
                ),
                expected: "a film of the same size and wavelengths, keeping half-film and splat sums alike",
            });
        }
        // Films a render writes cannot overflow (a sample is below 2^42 with 64 fractional bits, at
        // most 2^20 of them: under 2^126), but a file can say anything its checksums agree with:
        // check every sum first, so a refused merge leaves this film as it was.
        let fits = self.pixels.iter().zip(&other.pixels).all(|(a, b)| {
            a.xyz.iter().zip(&b.xyz).all(|(x, y)| x.checked_add(*y).is_some())
                && a.y2.checked_add(b.y2).is_some()
                && a.count.checked_add(b.count).is_some()
        }) && self.spectral.iter().zip(&other.spectral).all(|(a, b)| a.checked_add(*b).is_some())
            && self
                .halves
                .iter()
                .zip(&other.halves)
                .all(|(a, b)| a.iter().zip(b).all(|(x, y)| x.checked_add(*y).is_some()))
            && [(&self.splats.xyz, &other.splats.xyz), (&self.splats.halves, &other.splats.halves)].iter().all(
                |(a, b)| a.iter().zip(b.iter()).all(|(a, b)| a.iter().zip(b).all(|(x, y)| x.checked_add(*y).is_some())),
            )
            && self.splats.spectral.iter().zip(&other.splats.spectral).all(|(a, b)| a.checked_add(*b).is_some())
            && self.nonfinite.checked_add(other.nonfinite).is_some()
            && self.clamped.checked_add(other.clamped).is_some();
        if !fits {
            return Err(Error::InvalidOption {
                option: "film to merge",
                value: "sums beyond the film's range".to_owned(),
                expected: "sums a render can make (the file is damaged or was not written by a render)",
            });
        }
        for (a, b) in self.pixels.iter_mut().zip(&other.pixels) {
            for c in 0..3 {
                a.xyz[c] += b.xyz[c];
            }
            a.y2 += b.y2;
            a.count += b.count;
        }
        for (a, b) in self.spectral.iter_mut().zip(&other.spectral) {
            *a += b;
        }
        for (a, b) in self.halves.iter_mut().zip(&other.halves) {
            for (x, y) in a.iter_mut().zip(b) {
                *x += y;
            }
        }
        for (a, b) in self
            .splats
            .xyz
            .iter_mut()
            .zip(&other.splats.xyz)
            .chain(self.splats.halves.iter_mut().zip(&other.splats.halves))
        {
            for (x, y) in a.iter_mut().zip(b) {
                *x += y;
            }
        }
        for (a, b) in self.splats.spectral.iter_mut().zip(&other.splats.spectral) {
            *a += b;
        }
        if other.has_first_sample {
            self.ids.copy_from_slice(&other.ids);
            self.has_first_sample = true;
        }
        self.nonfinite += other.nonfinite;
        self.clamped += other.clamped;
        Ok(())
    }

    /// Per-pixel variance of the mean luminance, s²/n with s² the unbiased sample variance of
    /// Y (0 where fewer than two samples were taken): what a relative-error image shows. It is
    /// the variance of the mean for independent samples; the path tracer's default Sobol' points
    /// stratify, and their mean's error is usually lower than this says. It is that of the
    /// pixel's own samples: light splatted from other pixels ([`splat`]) keeps no squares.
    pub fn luminance_variance(&self) -> Vec<f32> {
        self.pixels
            .iter()
            .map(|p| {
                if p.count < 2 {
                    return 0.0;
                }
                let n = f64::from(p.count);
                let mean = from_fixed(p.xyz[1], FRACTION_BITS) / n;
                let mean_sq = from_fixed(p.y2, SQUARE_FRACTION_BITS) / n;
                ((mean_sq - mean * mean).max(0.0) * n / (n - 1.0) / n) as f32
            })
            .collect()
    }
}

impl Film {
    /// This film keeping splat sums too (after [`Film::with_halves`] where it keeps halves), for a
    /// kernel that splats ([`crate::integrators::Kernel::SPLATS`]).
    pub(crate) fn with_splats(mut self) -> Self {
        let n = self.pixels.len();
        self.splats = SplatSums {
            xyz: vec![[0; 3]; n],
            spectral: vec![0; n * self.wavelengths.len()],
            halves: if self.has_halves() { vec![[0; 3]; n] } else { Vec::new() },
        };
        self
    }

    /// Whether the film keeps splat sums (its render's integrator sends light to other pixels).
    pub fn has_splats(&self) -> bool {
        !self.splats.xyz.is_empty()
    }

    /// The factors of the splat sums for a film whose samples start at index `first`; `None`
    /// without splats.
    pub(crate) fn splat_scales(&self, first: u32) -> Option<SplatScales> {
        if !self.has_splats() {
            return None;
        }
        let pixels = self.pixels.len() as f64;
        let (mut total, mut second) = (0u64, 0u64);
        for p in &self.pixels {
            total += u64::from(p.count);
            second += u64::from(second_half_count(first..first.saturating_add(p.count)));
        }
        let inverse = |samples: u64| if samples == 0 { 0.0 } else { pixels / samples as f64 };
        Some(SplatScales { whole: inverse(total), first_half: inverse(total - second), second_half: inverse(second) })
    }
}

impl FilmRow<'_> {
    /// Add sample `index` to pixel `x` of this row: its XYZ and, with a spectral film, its lane
    /// values (the first `lanes` of them). A non-finite sample counts as black.
    #[inline]
    pub(crate) fn add_sample<const N: usize>(&mut self, x: usize, index: u32, xyz: [f32; 3], values: &[f32; N]) {
        let finite = xyz.iter().all(|v| v.is_finite()) && values.iter().take(self.lanes).all(|v| v.is_finite());
        let pixel = &mut self.pixels[x];
        pixel.count += 1;
        if !finite {
            self.nonfinite += 1;
            return;
        }
        let mut clamp = |v: f32| clamp_sample(v, &mut self.clamped);
        let [x_, y, z] = xyz.map(&mut clamp);
        let fixed = [to_fixed_f32(x_), to_fixed_f32(y), to_fixed_f32(z)];
        for (sum, v) in pixel.xyz.iter_mut().zip(fixed) {
            *sum += v;
        }
        if !self.halves.is_empty() && second_half(index) {
            for (sum, v) in self.halves[x].iter_mut().zip(fixed) {
                *sum += v;
            }
        }
        // Y² of an f32 is exact in f64 (48 significant bits).
        let y_for_square = f64::from(y).clamp(-MAX_SQUARED_LUMINANCE, MAX_SQUARED_LUMINANCE);
        pixel.y2 += to_fixed(y_for_square * y_for_square, SQUARE_FRACTION_BITS);
        if self.lanes > 0 {
            let sums = &mut self.spectral[x * self.lanes..(x + 1) * self.lanes];
            for (sum, &v) in sums.iter_mut().zip(values) {
                *sum += to_fixed_f32(clamp(v));
            }
        }
    }

    /// Samples pixel `x` of this row holds so far.
    #[inline]
    pub(crate) fn count(&self, x: usize) -> u32 {
        self.pixels[x].count
    }

    /// Record what pixel `x`'s sample 0 hit.
    #[inline]
    pub(crate) fn set_first_hit(&mut self, x: usize, id: ObjectId) {
        self.ids[x] = id;
    }
}

/// How a render's samples get their wavelengths and how lane values become XYZ: the film's
/// side of spectral sampling (pbrt-v4 `Film::SampleWavelengths` and `Film::AddSample`).
pub(crate) enum Sensor<const N: usize> {
    /// Fixed lanes (`rgb`, `bins:N`): the same wavelengths for every sample.
    Fixed(Lanes<N>),
    /// `hero:N` with pbrt-v4's visible-range density.
    Visible,
    /// `hero:N` with a density tabulated from the scene's lights.
    Tabulated(WavelengthTable),
}

impl<const N: usize> Sensor<N> {
    /// The wavelengths of one sample; `u` ∈ [0, 1) places hero wavelengths.
    #[inline]
    pub(crate) fn sample_wavelengths(&self, u: f32) -> SampledWavelengths<N> {
        match self {
            Self::Fixed(lanes) => lanes.wavelengths,
            Self::Visible => SampledWavelengths::sample_visible(u),
            Self::Tabulated(t) => t.sample(u),
        }
    }

    /// Wavelengths kept per pixel by a spectral film (fixed wavelength lanes only).
    pub(crate) fn film_wavelengths(&self) -> Option<Vec<f32>> {
        match self {
            Self::Fixed(lanes) if !lanes.rgb => Some(lanes.wavelengths.lambdas()[..lanes.active()].to_vec()),
            _ => None,
        }
    }

    /// XYZ of a sample's radiance and the lane values behind it. `lane` is the one wavelength
    /// lane a dispersive path kept (fixed lanes; chosen with probability 1/active, so that lane
    /// alone weighted by `active` is an unbiased estimate).
    #[inline]
    pub(crate) fn to_xyz(
        &self,
        radiance: &SampledSpectrum<N>,
        lambda: &SampledWavelengths<N>,
        lane: Option<usize>,
    ) -> ([f32; 3], [f32; N]) {
        match self {
            Self::Fixed(lanes) => {
                let values = match lane {
                    Some(j) => {
                        let mut single = [0.0f32; N];
                        single[j] = radiance.0[j] * lanes.active() as f32;
                        single
                    }
                    None => radiance.0,
                };
                (lanes.xyz(&values), values)
            }
            Self::Visible | Self::Tabulated(_) => (radiance.to_xyz(lambda, Observer::Cie1931), radiance.0),
        }
    }
}

/// Share of the visible-range density mixed into the illuminant-aware wavelength density, so
/// wavelengths where the lights are dark but a surface still matters (none in practice) keep a
/// positive density and the estimator stays unbiased for any scene.
const VISIBLE_MIX: f64 = 0.1;

/// A tabulated wavelength density on the 1 nm grid, piecewise constant, and its CDF.
pub(crate) struct WavelengthTable {
    /// cdf[i] = P(λ < LAMBDA_MIN + i nm); 471 + 1 entries.
    cdf: Vec<f32>,
    /// Density (per nm) in bin i.
    pdf: Vec<f32>,
    /// guide[k] = the number of cdf entries ≤ k / GUIDE_CELLS, k = 0..=GUIDE_CELLS: a `u` in
    /// cell k is searched for between guide[k] and guide[k + 1] only (empty if the cdf were not
    /// sorted, which it is by construction: then every search is the full one).
    guide: Vec<u32>,
}

/// Cells of [`WavelengthTable`]'s guide over [0, 1): a power of two, so `u · GUIDE_CELLS` and
/// the cell bounds k / GUIDE_CELLS are exact in f32 and a `u` in cell k lies in [k/G, (k+1)/G).
/// The full binary search over the 472 entries, per hero wavelength, was 3.6 % of the Cornell
/// box's instructions with `hero:4` (docs/perf.md).
const GUIDE_CELLS: usize = 1024;

impl WavelengthTable {
    /// p(λ) ∝ (1 − VISIBLE_MIX) S(λ) (x̄ + ȳ + z̄)(λ) / ∫… + VISIBLE_MIX p_visible(λ), S the
    /// sum of the scene's light spectra, each scaled to unit luminance (so a dim light still
    /// shapes the density).
    pub(crate) fn illuminant(lights: &[&DenselySampledSpectrum]) -> Self {
        let cmf = Observer::Cie1931.cmf();
        let bins = (LAMBDA_MAX - LAMBDA_MIN) as usize;
        let centre = |i: usize| f64::from(LAMBDA_MIN) + i as f64 + 0.5;
        let mut s = vec![0.0f64; bins];
        for l in lights {
            let y: f64 = (0..bins).map(|i| l.eval(centre(i)) * cmf.y.eval(centre(i))).sum();
            if y > 0.0 {
                for (i, v) in s.iter_mut().enumerate() {
                    *v += l.eval(centre(i)) / y;
                }
            }
        }
        let f: Vec<f64> =
            (0..bins).map(|i| s[i] * (cmf.x.eval(centre(i)) + cmf.y.eval(centre(i)) + cmf.z.eval(centre(i)))).collect();
        let f_sum: f64 = f.iter().sum();
        // pbrt-v4's visible density, integrated over each bin by its value at the centre.
        let visible: Vec<f64> = (0..bins).map(|i| colorimetry::visible_wavelength_shape(centre(i))).collect();
        let v_sum: f64 = visible.iter().sum();
        let mix = if f_sum > 0.0 { 1.0 - VISIBLE_MIX } else { 0.0 };
        let p: Vec<f64> = (0..bins)
            .map(|i| {
                mix * f.get(i).map_or(0.0, |v| v / f_sum.max(f64::MIN_POSITIVE)) + (1.0 - mix) * visible[i] / v_sum
            })
            .collect();
        let mut cdf = Vec::with_capacity(bins + 1);
        let mut acc = 0.0f64;
        cdf.push(0.0f32);
        for v in &p {
            acc += v;
            cdf.push(acc as f32);
        }
        // Σ p = 1 up to rounding; pin the end so u < 1 always lands in a bin.
        let last = cdf.len() - 1;
        cdf[last] = 1.0;
        let guide = if cdf.is_sorted() {
            (0..=GUIDE_CELLS).map(|k| cdf.partition_point(|&c| c <= k as f32 / GUIDE_CELLS as f32) as u32).collect()
        } else {
            Vec::new()
        };
        Self { cdf, pdf: p.iter().map(|&v| v as f32).collect(), guide }
    }

    /// The number of cdf entries ≤ `up` (`cdf.partition_point(|&c| c <= up)`), searched within
    /// `up`'s guide cell: entries before it are ≤ k/G ≤ `up`, entries after it > (k+1)/G > `up`,
    /// so on the sorted cdf the count is the full search's.
    #[inline(always)]
    fn entries_at_most(&self, up: f32) -> usize {
        let k = (up * GUIDE_CELLS as f32) as usize;
        if !(up >= 0.0) || k >= GUIDE_CELLS || self.guide.is_empty() {
            return self.cdf.partition_point(|&c| c <= up);
        }
        let (lo, hi) = (self.guide[k] as usize, self.guide[k + 1] as usize);
        lo + self.cdf[lo..hi].partition_point(|&c| c <= up)
    }

    /// N wavelengths stratified over the CDF: lane i uses (u + i/N) mod 1.
    pub(crate) fn sample<const N: usize>(&self, u: f32) -> SampledWavelengths<N> {
        let mut lambda = [0.0f32; N];
        let mut pdf = [0.0f32; N];
        for i in 0..N {
            let mut up = u + i as f32 / N as f32;
            if up >= 1.0 {
                up -= 1.0;
            }
            let bin = self.entries_at_most(up).saturating_sub(1).min(self.pdf.len() - 1);
            let width = self.cdf[bin + 1] - self.cdf[bin];
            let frac = if width > 0.0 { ((up - self.cdf[bin]) / width).clamp(0.0, 1.0) } else { 0.5 };
            lambda[i] = LAMBDA_MIN + bin as f32 + frac;
            pdf[i] = self.pdf[bin];
        }
        SampledWavelengths::from_parts(lambda, pdf)
    }
}

#[cfg(test)]
mod tests {
    use super::fixed::{MAX_SAMPLE_VALUE, inverse_power_of_two};
    use super::*;

    #[test]
    fn a_merge_whose_sums_would_overflow_is_refused_and_changes_nothing() {
        // A film file can hold any sums its checksums agree with; merging one with itself made
        // `merge` overflow (found by the `film` fuzz target).
        let mut a = Film::new(1, 1, Vec::new());
        a.pixels[0].xyz[1] = i128::MAX / 2 + 1;
        a.pixels[0].count = 1;
        let before = a.clone();
        let err = a.merge(&before).unwrap_err().to_string();
        assert!(err.contains("beyond the film's range"), "{err}");
        assert_eq!(a, before);
        let mut b = Film::new(1, 1, Vec::new());
        b.pixels[0].xyz[1] = 5;
        b.pixels[0].count = 1;
        a.merge(&b).unwrap();
        assert_eq!((a.pixels[0].xyz[1], a.pixels[0].count), (i128::MAX / 2 + 6, 2));
    }

    #[test]
    fn guided_wavelength_search_counts_what_the_full_search_counts() {
        // A flat light, and one that is a single 1 nm line (the cdf jumps by ~0.9 in one bin, so
        // many guide cells share one entry), at cell bounds, just below them, and in between.
        let flat = DenselySampledSpectrum::constant(1.0);
        let line = DenselySampledSpectrum::new(
            f64::from(LAMBDA_MIN),
            1.0,
            (0..=470).map(|i| if i == 186 { 1.0 } else { 0.0 }).collect(),
        )
        .unwrap();
        for light in [&flat, &line] {
            let table = WavelengthTable::illuminant(&[light]);
            assert_eq!(table.guide.len(), GUIDE_CELLS + 1, "the cdf is sorted");
            let mut checked = 0;
            for k in 0..=GUIDE_CELLS * 4 {
                let bound = k as f32 / (GUIDE_CELLS * 4) as f32;
                for up in [bound, bound.next_down(), bound.next_up(), 0.999_999_94, 0.0] {
                    if !(0.0..1.0).contains(&up) {
                        continue;
                    }
                    let want = table.cdf.partition_point(|&c| c <= up);
                    assert_eq!(table.entries_at_most(up), want, "u = {up}");
                    checked += 1;
                }
            }
            // Every cdf entry below 1 is itself a place where the count steps.
            for &c in &table.cdf[..table.cdf.len() - 1] {
                for up in [c, c.next_down(), c.next_up()] {
                    if (0.0..1.0).contains(&up) {
                        assert_eq!(table.entries_at_most(up), table.cdf.partition_point(|&e| e <= up), "u = {up}");
                    }
                }
            }
            assert!(checked > 4 * GUIDE_CELLS);
        }
    }

    #[test]
    fn fixed_point_is_exact_where_representable_and_sums_associate() {
        for v in [1.0f32, -0.75, 3.0e-12, 2.0e9, 1.5e-6, -7.25e3, 1.0e-12] {
            let back = from_fixed(to_fixed(f64::from(v), FRACTION_BITS), FRACTION_BITS);
            assert_eq!(back, f64::from(v), "{v}");
        }
        // Below the last bit (2^-64) values truncate towards zero, symmetrically.
        assert_eq!(to_fixed(1e-21, FRACTION_BITS), 0);
        assert_eq!(to_fixed(-3.0 * 2f64.powi(-64), FRACTION_BITS), -3);
        // Unlike f64, the order of additions does not matter.
        let values = [1e8f64, 1e-9, -1e8, 3.3e-7];
        let f64_fwd = values.iter().fold(0.0, |a, b| a + b);
        let f64_rev = values.iter().rev().fold(0.0, |a, b| a + b);
        assert_ne!(f64_fwd, f64_rev, "the example must show f64's order dependence");
        let fwd: i128 = values.iter().map(|&v| to_fixed(v, FRACTION_BITS)).sum();
        let rev: i128 = values.iter().rev().map(|&v| to_fixed(v, FRACTION_BITS)).sum();
        assert_eq!(fwd, rev);
    }

    #[test]
    fn fast_conversions_equal_the_general_ones() {
        // The hot-path conversions must give the same integers and the same f64 as the
        // general ones: f32 values over the whole accepted exponent range, both signs, and
        // sums up to 2^126 (beyond the fast path's 2^106 too).
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for _ in 0..200_000 {
            let r = next();
            let exponent = (r % 170) as u32; // up to 2^42
            let v = f32::from_bits((exponent << 23) | ((r >> 8) as u32 & 0x7f_ffff) | (((r >> 40) as u32 & 1) << 31));
            assert_eq!(to_fixed_f32(v), to_fixed(f64::from(v), FRACTION_BITS), "{v:e}");
            let sum = (i128::from(next() as i64) << (next() % 63)) ^ i128::from(next() as i64);
            assert_eq!(from_fixed(sum, FRACTION_BITS).to_bits(), (sum as f64 * 2f64.powi(-64)).to_bits(), "{sum}");
        }
        assert_eq!(to_fixed_f32(MAX_SAMPLE_VALUE as f32), to_fixed(MAX_SAMPLE_VALUE, FRACTION_BITS));
        assert_eq!(to_fixed_f32(f32::from_bits(1)), 0, "subnormals are below the last bit");
        assert_eq!(inverse_power_of_two(64), 2f64.powi(-64));
        assert_eq!(inverse_power_of_two(32), 2f64.powi(-32));
    }

    #[test]
    fn non_finite_and_huge_samples_are_counted_not_summed() {
        let mut film = Film::new(2, 1, Vec::new());
        let (nonfinite, clamped) = {
            let mut row = film.rows_mut().collect::<Vec<_>>().pop().unwrap();
            row.add_sample::<4>(0, 0, [f32::NAN, 1.0, 1.0], &[0.0; 4]);
            row.add_sample::<4>(0, 0, [1.0, 1.0, 1.0], &[0.0; 4]);
            row.add_sample::<4>(1, 0, [1e20, 1e20, 1e20], &[0.0; 4]);
            (row.nonfinite, row.clamped)
        };
        film.add_counts(nonfinite, clamped);
        assert_eq!((film.nonfinite_samples(), film.clamped), (1, 3));
        let image = film.to_image();
        // Pixel 0: a black sample and a white one; pixel 1: clamped to MAX_SAMPLE_VALUE.
        assert_eq!(image.xyz(0, 0), [0.5, 0.5, 0.5]);
        assert_eq!(image.xyz(1, 0)[1], MAX_SAMPLE_VALUE as f32);
        assert_eq!(image.nonfinite_samples(), 1);
    }

    #[test]
    fn the_second_moment_does_not_overflow_at_the_brightest_samples() {
        // Before the clamp, Y² of a 2⁴² sample at 32 fractional bits was 2¹¹⁶: 2¹¹ of them
        // overflowed i128 (a panic in debug builds, wrapped sums in release).
        let mut film = Film::new(1, 1, Vec::new());
        {
            let mut row = film.rows_mut().collect::<Vec<_>>().pop().unwrap();
            for _ in 0..4096 {
                row.add_sample::<4>(0, 0, [1e20, 1e20, 1e20], &[0.0; 4]);
            }
        }
        let variance = film.luminance_variance()[0];
        assert!(variance.is_finite() && variance >= 0.0, "{variance}");
        assert_eq!(film.to_image().xyz(0, 0)[1], MAX_SAMPLE_VALUE as f32);
    }
}
