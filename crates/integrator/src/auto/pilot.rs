//! `--spectral auto` for the path tracer, second step: among the strategies whose colour bias
//! is negligible (first step, [`choose_auto`](crate::auto::choose::choose_auto)), the one expected to reach a given colour
//! error in the least time. The rule is documented in `docs/path-tracer.md`, "Time to error".
//!
//! Time to an error is cost per sample × samples needed. Samples needed come from a short pilot
//! render of each candidate (Monte Carlo error falls as 1/√spp, so the error of a few samples
//! predicts the spp for any target); cost per sample comes from the pilot's ray count and a
//! cost model per ray measured once (below), not from the pilot's clock, so the choice is the
//! same on every machine, at any thread count and in every part of a split render.

use colorimetry::{Lab, Xyz, delta_e_2000};
use rayon::prelude::*;

use crate::error::Result;
use crate::film::Sensor;
// CIELAB's reference white, D65 at Y = 1, as `cargo xtask validate` and the Mitsuba comparison
// score images.
use crate::film::estimate::WHITE;
use crate::integrators::{PathTracer, RayCount};
use crate::options::{Integrator, IntegratorKind, PathOptions, RenderOptions, SamplerKind, SppmOptions};
use crate::render::{PixelSampler, thread_pool};
use crate::sampling::{Rng, Sampler};
use crate::scene::{RenderScene, scene_white};
use crate::spectral::{LaneJob, Lanes, MAX_BINS, SpectralMode, lane_count, with_lanes};

/// Cost of one lane per ray, relative to the ray's lane-independent cost (traversal, BSDF,
/// light choice, RNG). Measured on the Cornell box (`docs/path-tracer.md`, "Time to error":
/// time per ray of `bins:8` … `bins:95`, fastest of 5 runs, fitted as a line in the lanes).
pub(crate) const LANE_COST: f64 = 0.0065;

/// Extra cost per hero wavelength per ray (spectra interpolated at each sample's wavelengths
/// instead of read from a projected table), in the same units; measured with [`LANE_COST`]
/// from `hero:4` and `hero:8`.
pub(crate) const HERO_WAVELENGTH_COST: f64 = 0.05;

/// The pilot samples at most this many columns and rows of pixels, evenly spread over the image.
const PILOT_GRID: u32 = 32;

/// Samples per pixel of each of the pilot's two independent renders. Few samples predict too
/// little error: path noise is heavy-tailed (a 4-spp pixel rarely holds the rare bright path that
/// a 64-spp one always does), and stratified hero wavelengths converge faster than 1/√spp (the
/// error of 4 strata extrapolates to far more than that of 64). Measured on the scenes of
/// `cargo xtask validate --only auto`, spp to ΔE00 1 predicted over measured: 4 spp on 64²
/// pixels 0.19–5.2, 16 spp on 32² pixels (as many samples) 0.42–1.8; the ratios between
/// candidates, all the choice uses, within ×1.37 (docs/path-tracer.md, "Time to error").
const PILOT_SPP: u32 = 16;

/// Side, in pilot pixels, of the blocks whose squared errors are pooled before the square
/// root, so that a block's rare bright paths count for its neighbours too.
const BLOCK: usize = 4;

/// E|x| / √(E x²) of a normal variable: turns the root-mean-square error a block's pooled
/// squares give into the mean error that ΔE00 images are scored by. Exact for noise along one
/// direction (lightness); for chromatic noise ΔE00 acts as a norm of up to three components,
/// whose mean over RMS reaches 0.92, so hero wavelengths' error is predicted up to ~10 % low
/// (a helper's simulation through `mean_error`: 1.01, 1.05 and 1.11 measured over predicted for
/// lightness, grey-chromatic and red-chromatic Gaussian noise). Not corrected: the candidates'
/// ratios measured on the Cornell box agree within ×1.04 (docs/path-tracer.md).
const MEAN_ABS_PER_RMS: f64 = 0.797_884_560_802_865_4;

/// Seeds of the two pilot renders: fixed, so the choice depends on neither `--seed` nor the
/// thread count (a render split into parts chooses the same in every part).
const PILOT_SEEDS: [u64; 2] = [0x5eed_a070_0000_0001, 0x5eed_a070_0000_0002];

/// The pilot is skipped where its samples would be more than 1/32 of the render's.
const PILOT_SHARE: u64 = 32;

/// Step of the numerical derivative of ΔE00 along a pixel's noise (relative: the two Lab
/// colours compared are ε·d apart, so ΔE00/ε is the local, linear error).
const EPSILON: f64 = 1e-4;

/// What `--spectral auto` decided for a render, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct AutoDecision {
    /// The strategy the render uses.
    pub spectral: SpectralMode,
    /// The strategies the pilot compared (empty when no pilot was needed).
    pub candidates: Vec<AutoCandidate>,
    /// One line on how the choice was made.
    pub reason: String,
}

/// One strategy as the pilot measured it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AutoCandidate {
    /// The strategy.
    pub spectral: SpectralMode,
    /// Rays traced per camera sample in the pilot.
    pub rays_per_sample: f64,
    /// Modelled cost of one sample: rays per sample × (1 + lanes · [`LANE_COST`] + hero
    /// wavelengths · [`HERO_WAVELENGTH_COST`]), in units of a ray's lane-independent cost.
    pub cost_per_sample: f64,
    /// Mean ΔE00 per pixel of a 1-spp image, predicted from the pilot.
    pub error_1spp: f64,
}

impl AutoCandidate {
    /// Samples per pixel to reach a mean ΔE00 of `delta_e` (error ∝ 1/√spp).
    pub fn spp_for(&self, delta_e: f64) -> f64 {
        (self.error_1spp / delta_e).powi(2)
    }

    /// Modelled time to a mean ΔE00 of `delta_e`, in the units of `cost_per_sample`.
    pub fn cost_for(&self, delta_e: f64) -> f64 {
        self.spp_for(delta_e) * self.cost_per_sample
    }
}

/// Modelled cost per ray of a strategy (see [`AutoCandidate::cost_per_sample`]).
pub(crate) fn cost_per_ray(spectral: SpectralMode) -> f64 {
    let lanes = lane_count(spectral).unwrap_or(MAX_BINS) as f64;
    let hero = match spectral {
        SpectralMode::Hero { count } => count as f64,
        _ => 0.0,
    };
    1.0 + lanes * LANE_COST + hero * HERO_WAVELENGTH_COST
}

/// What `--spectral auto` picks for a render of `scene` with `options`:
/// - the paper's model, a dispersive scene, or a path-traced scene whose cheapest unbiased
///   bin count is no dearer per ray than `hero:4`: the first step's choice ([`choose_auto`](crate::auto::choose::choose_auto));
///   fixed bins have no colour noise, so where they cost no more they reach any error first;
/// - otherwise the candidates (that bin count if there is one, `hero:4`, `hero:8`) are piloted
///   and the one with the least cost per sample × (1-spp error)² wins: the least time to any
///   target error.
pub fn auto_decision(scene: &RenderScene, options: &RenderOptions) -> Result<AutoDecision> {
    let first = crate::auto::choose::choose_auto(scene, options.integrator.kind());
    let keep = |reason: String| Ok(AutoDecision { spectral: first, candidates: Vec::new(), reason });
    let hero4 = SpectralMode::Hero { count: 4 };
    let bins = matches!(first, SpectralMode::Bins(_));
    let mut strategies = vec![hero4, SpectralMode::Hero { count: 8 }];
    if bins {
        strategies.insert(0, first);
    }
    let grid = pilot_pixels(options.width, options.height);
    let pilot_samples = (grid.pixels.len() as u64) * u64::from(PILOT_SPP) * PILOT_SEEDS.len() as u64;
    // The whole render's samples, not a part's (`--part`): every part must decide alike, so each
    // part pays the whole pilot.
    let render_samples = (u64::from(options.width) * u64::from(options.height)).saturating_mul(u64::from(options.spp));
    let not_piloted = if options.integrator.kind() == IntegratorKind::WhittedHall {
        Some("the paper's model: bins".to_owned())
    } else if scene.materials.iter().any(materials::Material::is_dispersive) {
        Some("a dispersive dielectric: hero wavelengths".to_owned())
    } else if bins && cost_per_ray(first) <= cost_per_ray(hero4) {
        Some(format!("{first} has no colour noise and costs no more per ray than hero:4"))
    } else if options.spectral_film && bins {
        Some("a spectral image needs fixed wavelengths".to_owned())
    } else if options.time_limit.is_some() && options.target_error.is_none() {
        // Its spp says nothing of its length, and its limit is not to be spent on a pilot. (An
        // adaptive render's limit is a cap, and its spp a bound, so it is piloted.)
        Some("a time-limited render is not piloted".to_owned())
    } else if render_samples < PILOT_SHARE * pilot_samples * strategies.len() as u64 {
        Some("a render too small to pilot".to_owned())
    } else {
        None
    };
    if let Some(reason) = not_piloted {
        return keep(reason);
    }
    let candidates = pilot_strategies(scene, options, &strategies)?;
    let best = fastest(&candidates);
    let next = second_best_cost(&candidates, best) / best.cost_for(1.0);
    // Every candidate's error is 0 (no light reaches the pilot's pixels, say): nothing to weigh,
    // the bias rule's choice is kept.
    let spectral = if next.is_nan() { first } else { best.spectral };
    Ok(AutoDecision {
        spectral,
        reason: if next.is_nan() {
            format!("piloted: no colour noise measured in any candidate; {first} kept")
        } else if next < 1000.0 {
            format!("piloted: {} reaches a given error first (the next best takes {next:.2}× its time)", best.spectral)
        } else {
            // No colour noise against some (fixed bins on flat, directly lit surfaces): a ratio
            // of a rounding error says nothing.
            format!("piloted: {} reaches a given error first (the others take over 1000× its time)", best.spectral)
        },
        candidates,
    })
}

/// Pilot each of `strategies` (fixed bins or hero wavelengths, for the path tracer of `options`)
/// for a render of `scene` with `options`: what [`auto_decision`] compares (it pilots only where
/// hero wavelengths might win; `cargo xtask validate --only auto` pilots every candidate to check
/// the rule against measured times).
pub fn pilot_strategies(
    scene: &RenderScene,
    options: &RenderOptions,
    strategies: &[SpectralMode],
) -> Result<Vec<AutoCandidate>> {
    let path = match options.integrator {
        Integrator::Path(path) | Integrator::Bdpt(path) | Integrator::Sppm(SppmOptions { path, .. }) => path,
        Integrator::WhittedHall(_) => PathOptions::default(),
    };
    let pixels = pilot_pixels(options.width, options.height);
    let pool = thread_pool(options)?;
    strategies.iter().map(|&spectral| pool.install(|| pilot(scene, options, path, spectral, &pixels))).collect()
}

/// The candidate with the least modelled time to an error (the first on a tie).
fn fastest(candidates: &[AutoCandidate]) -> AutoCandidate {
    let mut best = candidates[0];
    for c in &candidates[1..] {
        if c.cost_for(1.0) < best.cost_for(1.0) {
            best = *c;
        }
    }
    best
}

/// The least time to an error of the candidates other than `best`.
fn second_best_cost(candidates: &[AutoCandidate], best: AutoCandidate) -> f64 {
    candidates.iter().filter(|c| c.spectral != best.spectral).map(|c| c.cost_for(1.0)).fold(f64::INFINITY, f64::min)
}

/// The pixels the pilot samples: up to [`PILOT_GRID`]² spread evenly over the image (each at
/// its own index in the image, so its random numbers are those a render would draw for it).
fn pilot_pixels(width: u32, height: u32) -> PilotGrid {
    let (gx, gy) = (width.min(PILOT_GRID), height.min(PILOT_GRID));
    let at = |i: u32, n: u32, size: u32| ((u64::from(i) * 2 + 1) * u64::from(size) / (2 * u64::from(n))) as u32;
    let pixels = (0..gy).flat_map(|j| (0..gx).map(move |i| (at(i, gx, width), at(j, gy, height)))).collect();
    PilotGrid { pixels, columns: gx as usize }
}

/// The pilot's pixels, row by row of a grid `columns` wide.
struct PilotGrid {
    pixels: Vec<(u32, u32)>,
    columns: usize,
}

/// Pilot `spectral`: two independent renders of [`PILOT_SPP`] samples of each pilot pixel.
fn pilot(
    scene: &RenderScene,
    options: &RenderOptions,
    path: PathOptions,
    spectral: SpectralMode,
    grid: &PilotGrid,
) -> Result<AutoCandidate> {
    let pixels = &grid.pixels[..];
    // Independent numbers, whatever the render uses: the error model (∝ 1/√spp) holds for them,
    // and it is an upper bound for Sobol' points, which stratify (docs/path-tracer.md).
    let path = PathOptions { sampler: SamplerKind::Independent, ..path };
    let options =
        RenderOptions { spp: PILOT_SPP, samples: None, integrator: Integrator::Path(path), ..options.clone() };
    let [a, b] = with_lanes(lane_count(spectral)?, PilotJob { scene, options: &options, path, spectral, pixels })?;
    let samples = (pixels.len() as f64) * f64::from(PILOT_SPP) * 2.0;
    let rays_per_sample = (a.rays + b.rays) as f64 / samples;
    Ok(AutoCandidate {
        spectral,
        rays_per_sample,
        cost_per_sample: rays_per_sample * cost_per_ray(spectral),
        error_1spp: mean_error(&a.means, &b.means, grid.columns) * f64::from(PILOT_SPP).sqrt(),
    })
}

/// The expected mean ΔE00 per pixel of one render's pixel means against the truth, from two
/// independent renders a and b of a grid of pixels `columns` wide:
/// - a − b has twice the variance of a's error, so |a − b|²/2 estimates its expected square;
/// - ΔE00 is taken along a − b at the pixel's colour (a step of ε, divided by ε): the linear
///   error that Monte Carlo noise makes once it is small, where error ∝ 1/√spp;
/// - the squares are pooled over blocks of [`BLOCK`]² pixels (neighbours share their rare
///   bright paths), and the blocks' root-mean-square errors averaged, as mean errors.
pub(crate) fn mean_error(a: &[[f64; 3]], b: &[[f64; 3]], columns: usize) -> f64 {
    let lab = |c: [f64; 3]| Lab::from_xyz(Xyz { x: c[0].max(0.0), y: c[1].max(0.0), z: c[2].max(0.0) }, WHITE);
    let columns = columns.max(1);
    let block_columns = columns.div_ceil(BLOCK);
    let rows = a.len().div_ceil(columns);
    let mut blocks = vec![(0.0f64, 0usize); block_columns * rows.div_ceil(BLOCK)];
    for (k, (p, q)) in a.iter().zip(b).enumerate() {
        let mean = [0.5 * (p[0] + q[0]), 0.5 * (p[1] + q[1]), 0.5 * (p[2] + q[2])];
        let step =
            [mean[0] + EPSILON * (p[0] - q[0]), mean[1] + EPSILON * (p[1] - q[1]), mean[2] + EPSILON * (p[2] - q[2])];
        let e = delta_e_2000(lab(mean), lab(step)) / EPSILON;
        let block = &mut blocks[(k / columns / BLOCK) * block_columns + (k % columns) / BLOCK];
        block.0 += 0.5 * e * e;
        block.1 += 1;
    }
    let filled = blocks.iter().filter(|b| b.1 > 0);
    let (sum, count) = filled.fold((0.0, 0usize), |(s, n), b| (s + (b.0 / b.1 as f64).sqrt(), n + 1));
    MEAN_ABS_PER_RMS * sum / count.max(1) as f64
}

/// The pilot's renders of one strategy (one per seed of [`PILOT_SEEDS`], with one kernel: its
/// spectra are projected once), generic over the lane count.
struct PilotJob<'a> {
    scene: &'a RenderScene,
    options: &'a RenderOptions,
    path: PathOptions,
    spectral: SpectralMode,
    pixels: &'a [(u32, u32)],
}

/// A pilot render's result: rays traced and each pilot pixel's mean XYZ.
struct PilotRun {
    rays: u64,
    means: Vec<[f64; 3]>,
}

impl LaneJob for PilotJob<'_> {
    type Output = Result<[PilotRun; 2]>;

    fn run<const N: usize>(self) -> Self::Output {
        let Self { scene, options, path, spectral, pixels } = self;
        let fixed = match spectral {
            SpectralMode::Bins(n) => Some(Lanes::<N>::bins(n, &scene_white(scene))),
            _ => None,
        };
        let (kernel, sensor): (PathTracer<'_, N>, Sensor<N>) = PathTracer::new(scene, fixed, &path);
        let camera = scene.camera(options.width, options.height)?;
        Ok(PILOT_SEEDS.map(|seed| {
            let sampler = PixelSampler::new(&kernel, &sensor, camera, &RenderOptions { seed, ..options.clone() });
            let per_pixel: Vec<(u64, [f64; 3])> = pixels
                .par_iter()
                .map(|&(x, y)| {
                    let mut count = RayCount::default();
                    let mut fixed = Sampler::Independent(Rng::new(0, 0, 0));
                    let rotation = sampler.rotation(u64::from(y) * u64::from(options.width) + u64::from(x));
                    let mut sum = [0.0f64; 3];
                    for i in 0..options.spp {
                        let (r, lambda) = sampler.sample(
                            x as usize,
                            y as usize,
                            rotation,
                            i,
                            &mut fixed,
                            &mut count,
                            &mut Vec::new(),
                        );
                        let (xyz, _) = sensor.to_xyz(&r.l, &lambda, r.lane);
                        // The film adds a non-finite sample as black.
                        if xyz.iter().all(|v| v.is_finite()) {
                            sum.iter_mut().zip(xyz).for_each(|(s, v)| *s += f64::from(v));
                        }
                    }
                    (count.rays, sum.map(|s| s / f64::from(options.spp)))
                })
                .collect();
            PilotRun { rays: per_pixel.iter().map(|p| p.0).sum(), means: per_pixel.into_iter().map(|p| p.1).collect() }
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn candidate(spectral: SpectralMode, cost_per_sample: f64, error_1spp: f64) -> AutoCandidate {
        AutoCandidate { spectral, rays_per_sample: 1.0, cost_per_sample, error_1spp }
    }

    #[test]
    fn the_fastest_candidate_is_the_least_cost_times_squared_error() {
        let bins = candidate(SpectralMode::Bins(95), 1.6, 4.0);
        let hero = candidate(SpectralMode::Hero { count: 4 }, 1.0, 5.0);
        // 1.6 · 16 = 25.6 > 1.0 · 25 = 25: hero, narrowly.
        assert_eq!(fastest(&[bins, hero]).spectral, hero.spectral);
        let hero = candidate(SpectralMode::Hero { count: 4 }, 1.0, 5.1);
        assert_eq!(fastest(&[bins, hero]).spectral, bins.spectral);
        // The spp for ΔE00 1 and 0.5 of a 1-spp error of 4: 16 and 64.
        assert!((bins.spp_for(1.0) - 16.0).abs() < 1e-12 && (bins.spp_for(0.5) - 64.0).abs() < 1e-12);
    }

    #[test]
    fn pilot_pixels_spread_over_the_image_without_repeats() {
        let grid = pilot_pixels(640, 480);
        let p = grid.pixels;
        assert_eq!((p.len(), grid.columns), (32 * 32, 32));
        assert_eq!(p[0], (10, 7));
        assert_eq!(*p.last().unwrap(), (630, 472));
        let mut sorted = p.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), p.len());
        // Smaller than the grid: every pixel once.
        assert_eq!(pilot_pixels(3, 2).pixels, vec![(0, 0), (1, 0), (2, 0), (0, 1), (1, 1), (2, 1)]);
    }

    #[test]
    fn the_error_of_a_grey_pixel_is_its_lightness_noise() {
        // Two renders of a grey pixel differing in Y only by 2·δ: the error of one is δ·√2 in Y
        // (RMS; × √(2/π) as a mean). At Y = 0.2 (L* 51.84), dL*/dY = 116/3 · 0.2^(−2/3) = 113.1,
        // and ΔE00 of a pure L* step is the step over S_L = 1 + 0.015 (L − 50)²/√(20 + (L − 50)²)
        // = 1.0101 here.
        let (y, delta) = (0.2, 1e-3);
        let grey = |y: f64| [WHITE.x * y, y, WHITE.z * y];
        let e = mean_error(&[grey(y + delta)], &[grey(y - delta)], 1);
        let l = 116.0 * y.cbrt() - 16.0;
        let s_l = 1.0 + 0.015 * (l - 50.0).powi(2) / (20.0 + (l - 50.0).powi(2)).sqrt();
        let slope = 116.0 / 3.0 * y.powf(-2.0 / 3.0);
        let want = MEAN_ABS_PER_RMS * slope / s_l * 2.0 * delta / std::f64::consts::SQRT_2;
        assert!((e / want - 1.0).abs() < 1e-4, "{e} vs {want}");
        // Identical renders have no error.
        assert_eq!(mean_error(&[grey(y)], &[grey(y)], 1), 0.0);
        // Pooled over a block: one noisy pixel among 16 of a 4 × 4 block counts as √(1/16) of its
        // error for the block (a root mean square), not 1/16; a second block of 8 quiet pixels
        // (a grid 4 wide, 6 rows) halves the mean over blocks.
        let mut a = vec![grey(y); 24];
        let b = vec![grey(y); 24];
        a[5] = grey(y + 2.0 * delta);
        let pooled = mean_error(&a, &b, 4);
        // (The slope is taken at the pair's mean, Y + δ: 0.5 % lower.)
        assert!((pooled / (want / 4.0 / 2.0) - 1.0).abs() < 1e-2, "{pooled} vs {}", want / 8.0);
    }
}
