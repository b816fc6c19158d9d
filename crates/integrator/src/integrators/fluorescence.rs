//! Fluorescent surfaces in the path tracer: at a hit on a [`Fluorescence`] material a camera path either
//! reflects (the Lambertian lobe, all hero wavelengths kept) or fluoresces: the film keeps recording the
//! wavelength λ_out the path carries, and the path goes on towards the light at a λ_in drawn from the
//! kernel's λ_in profile for λ_out times the scene's light spectra, with the secondary hero wavelengths
//! terminated as dispersion terminates them (they cannot follow one λ_in). `docs/fluorescence.md` has
//! the estimator and its checks.
//!
//! The choice is made by the hero wavelength λ_out with probability P(λ_out) = F / (F + ρ), F the
//! fluorescent and ρ the reflected part of the surface's radiance factor under the scene's lights at
//! λ_out, clamped to [`MIN_CHOICE`, `MAX_CHOICE`]: each branch is divided by its probability, so the
//! estimate is unbiased for any P in (0, 1) (the reflection branch keeps all lanes, weighted 1/(1 − P) by
//! the hero's P; the fluorescence branch only the hero, whose film density pbrt-v4's
//! `TerminateSecondary` divides by N).

use colorimetry::{DenselySampledSpectrum, LAMBDA_MAX, SampledSpectrum, SampledWavelengths};
use materials::{Fluorescence, LAMBDA_UV_MIN};

/// 1 nm bins of λ_in from [`LAMBDA_UV_MIN`] to [`LAMBDA_MAX`].
const BINS: usize = (LAMBDA_MAX - LAMBDA_UV_MIN) as usize;

/// The light spectra's share of the λ_in density is mixed with this constant (relative to their peak), so
/// λ_in that no light emits but other fluorescent or coloured surfaces may send still has a density.
const LIGHT_FLOOR: f64 = 0.1;

/// Bounds of the probability of fluorescing where a surface both reflects and fluoresces: neither branch
/// is starved where the scene's lights (which P is estimated from) are a poor guide to the light arriving.
const MIN_CHOICE: f32 = 0.05;
const MAX_CHOICE: f32 = 0.95;

/// A density over λ_in in [`BINS`] bins, constant within each.
#[derive(Debug, Clone)]
struct BinnedDensity {
    /// Cumulative, `BINS + 1` entries from 0 to 1.
    cdf: Vec<f32>,
    /// Per nm, per bin.
    pdf: Vec<f32>,
}

impl BinnedDensity {
    /// The density ∝ `weights` (one per bin, ≥ 0); `None` if they are all 0.
    fn new(weights: &[f64]) -> Option<Self> {
        let sum: f64 = weights.iter().sum();
        if !(sum > 0.0) {
            return None;
        }
        let mut cdf = Vec::with_capacity(weights.len() + 1);
        let mut acc = 0.0;
        cdf.push(0.0);
        for w in weights {
            acc += w / sum;
            cdf.push(acc as f32);
        }
        *cdf.last_mut().expect("non-empty") = 1.0;
        Some(Self { cdf, pdf: weights.iter().map(|w| (w / sum) as f32).collect() })
    }

    /// λ_in for `u` ∈ [0, 1) and its density per nm.
    fn sample(&self, u: f32) -> (f32, f32) {
        // The last bin whose cumulative start is ≤ u (zero-width bins are never chosen).
        let b = (self.cdf.partition_point(|&c| c <= u).max(1) - 1).min(BINS - 1);
        let width = self.cdf[b + 1] - self.cdf[b];
        let f = if width > 0.0 { ((u - self.cdf[b]) / width).clamp(0.0, 1.0) } else { 0.5 };
        (LAMBDA_UV_MIN + b as f32 + f, self.pdf[b])
    }

    /// The density at `lambda` nm.
    #[cfg(test)]
    fn pdf(&self, lambda: f32) -> f32 {
        let b = (lambda - LAMBDA_UV_MIN).floor();
        if (0.0..BINS as f32).contains(&b) { self.pdf[b as usize] } else { 0.0 }
    }
}

/// One fluorescent material's sampling tables.
#[derive(Debug, Clone)]
struct MaterialTables {
    fluorescence: Fluorescence,
    /// The λ_in density of each of the kernel's classes ([`Fluorescence::class_of`]).
    classes: Vec<Option<BinnedDensity>>,
    /// P(λ_out) at every whole nanometre from [`LAMBDA_UV_MIN`] to [`LAMBDA_MAX`].
    choice: Vec<f32>,
}

/// The fluorescent materials of a render, indexed by `PathMaterial::fluorescence`.
#[derive(Debug, Clone, Default)]
pub(crate) struct FluorescenceTables {
    materials: Vec<MaterialTables>,
    /// A deliberately wrong λ_in density for the test that shows the furnace check can fail.
    #[cfg(test)]
    wrong_pdf: bool,
}

impl FluorescenceTables {
    /// Add a material with its kernel and Lambertian reflectance, given the scene's light spectra; returns
    /// its index.
    pub(crate) fn add(
        &mut self,
        fluorescence: &Fluorescence,
        reflectance: &DenselySampledSpectrum,
        lights: &[&DenselySampledSpectrum],
    ) -> u32 {
        let importance = light_importance(lights);
        let centre = |b: usize| LAMBDA_UV_MIN + b as f32 + 0.5;
        let classes = (0..fluorescence.class_count())
            .map(|c| {
                let lambda_out = fluorescence.class_lambda_out(c);
                // The largest of the bin's ends and centre: the kernel is piecewise linear in λ_in between
                // whole nanometres (or a matrix's rows), so a bin where it is positive anywhere gets a density.
                let weights: Vec<f64> = (0..BINS)
                    .map(|b| {
                        let l = LAMBDA_UV_MIN + b as f32;
                        let k = fluorescence
                            .kernel(l, lambda_out)
                            .max(fluorescence.kernel(l + 0.5, lambda_out))
                            .max(fluorescence.kernel(l + 1.0, lambda_out));
                        f64::from(k) * importance[b]
                    })
                    .collect();
                BinnedDensity::new(&weights)
            })
            .collect();
        let choice = (0..=BINS)
            .map(|j| {
                let lambda_out = LAMBDA_UV_MIN + j as f32;
                let fluoresced: f64 =
                    (0..BINS).map(|b| f64::from(fluorescence.kernel(centre(b), lambda_out)) * importance[b]).sum();
                let at_out = importance[j.min(BINS - 1)];
                let f = fluoresced / at_out;
                let rho = reflectance.eval(f64::from(lambda_out));
                if f > 0.0 { ((f / (f + rho)) as f32).clamp(MIN_CHOICE, MAX_CHOICE) } else { 0.0 }
            })
            .collect();
        self.materials.push(MaterialTables { fluorescence: fluorescence.clone(), classes, choice });
        (self.materials.len() - 1) as u32
    }

    /// The reflectance of a Lambertian lobe at a hit on fluorescent material `index`, reflectance `r`: `r`
    /// divided by the probability of reflecting, or — fluorescing — the kernel over its probability and
    /// λ_in's density in the hero lane (0 in the others). Fluorescing moves `lambda` to λ_in in every lane
    /// (their values are read at it; only the hero's is kept), after keeping in `film_lambda` the film's
    /// wavelengths with the secondary ones terminated, if the path had not already done so; it returns
    /// `true` then (what the caller memoised at the old wavelengths is stale).
    #[inline(never)]
    pub(crate) fn scatter<const N: usize>(
        &self,
        index: u32,
        r: SampledSpectrum<N>,
        lambda: &mut SampledWavelengths<N>,
        film_lambda: &mut Option<SampledWavelengths<N>>,
        u_choice: f32,
        u_lambda: f32,
    ) -> (SampledSpectrum<N>, bool) {
        let t = &self.materials[index as usize];
        let lambda_out = lambda.lambda(0);
        let j = (lambda_out - LAMBDA_UV_MIN).round();
        let p = if (0.0..=BINS as f32).contains(&j) { t.choice[j as usize] } else { 0.0 };
        if !(p > 0.0 && u_choice < p) {
            return (if p > 0.0 { r * (1.0 / (1.0 - p)) } else { r }, false);
        }
        let class = t.fluorescence.class_of(lambda_out).and_then(|c| t.classes[c].as_ref());
        let mut out = [0.0; N];
        let lambda_in = match class {
            Some(density) => {
                let (lambda_in, pdf) = density.sample(u_lambda);
                #[cfg(test)]
                let pdf = if self.wrong_pdf { 1.0 / BINS as f32 } else { pdf };
                if pdf > 0.0 {
                    out[0] = t.fluorescence.kernel(lambda_in, lambda_out) / (p * pdf);
                }
                lambda_in
            }
            None => lambda_out,
        };
        if film_lambda.is_none() {
            lambda.terminate_secondary();
            *film_lambda = Some(*lambda);
        }
        *lambda = SampledWavelengths::from_parts([lambda_in; N], [1.0; N]);
        (SampledSpectrum(out), true)
    }
}

/// Σ of the lights' spectra, each over its own peak, then over the sum's peak, plus [`LIGHT_FLOOR`], at the
/// centre of each λ_in bin; flat without lights.
fn light_importance(lights: &[&DenselySampledSpectrum]) -> Vec<f64> {
    let centre = |b: usize| f64::from(LAMBDA_UV_MIN) + b as f64 + 0.5;
    let mut sum = vec![0.0f64; BINS];
    for l in lights {
        let peak = (0..BINS).map(|b| l.eval(centre(b))).fold(0.0, f64::max);
        if peak > 0.0 {
            sum.iter_mut().enumerate().for_each(|(b, s)| *s += l.eval(centre(b)) / peak);
        }
    }
    let peak = sum.iter().copied().fold(0.0, f64::max);
    sum.iter().map(|s| if peak > 0.0 { s / peak } else { 0.0 } + LIGHT_FLOOR).collect()
}

#[cfg(test)]
mod tests;
