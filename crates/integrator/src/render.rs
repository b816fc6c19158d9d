//! The one pixel loop: each sample's wavelengths from the film's sensor, its ray from the
//! camera, its radiance from the integrator's [`Kernel`], added to the [`Film`]; passes over the
//! image, progress, cancellation and checkpoints.
//!
//! One sample's trip (pbrt-v4 `RayIntegrator::EvaluatePixelSample`): the pixel loop
//! ([`render_resolved`] → `render_pixels`) asks the film's [`Sensor`] for the sample's
//! wavelengths and the camera for its ray, the integrator [`Kernel`] for the radiance along it
//! (`integrators/whitted.rs` or `integrators/path.rs`), and adds the result to the film's row.

use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use colorimetry::SampledWavelengths;
use geometry::{Camera, Ray};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::film::estimate::{ErrorEstimate, TILE, tile_grid, tile_index};
use crate::film::splat::{SPLAT_BATCH, SplatValue};
use crate::film::{Film, MAX_SPP, Sensor, second_half};
use crate::integrators::{Bdpt, Kernel, PathTracer, PhotonMapping, Radiance, RayCount, Splat, Whitted};
use crate::options::{Integrator, PathOptions, RenderOptions, SamplerKind};
use crate::output::auto_exposure_ev_of;
use crate::sampling::{Rng, Sampler, SobolSample};
use crate::scene::{RenderScene, scene_white};
use crate::spectral::{LaneJob, Lanes, SpectralMode, lane_count, with_lanes};

/// Progress of a running render, reported after each finished row.
#[derive(Debug, Clone, Copy)]
pub struct Progress {
    /// Rows finished (over all passes).
    pub rows_done: u64,
    /// Rows to render (image rows × passes: up to 2¹⁶ × 2²⁰ with a time limit).
    pub rows_total: u64,
    /// Rays traced so far (camera, secondary and shadow rays).
    pub rays: u64,
    /// Samples taken so far by this render (a resumed film's not counted).
    pub samples: u64,
    /// Time since the render started.
    pub elapsed: Duration,
    /// With a target error: the estimate after the last finished stage.
    pub error: Option<ErrorProgress>,
}

/// Where an adaptive render stands after a stage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorProgress {
    /// Mean of the pixels' estimated ΔE00.
    pub mean: f64,
    /// The largest tile's estimated ΔE00.
    pub worst_tile: f64,
    /// The target per tile.
    pub target: f64,
    /// Share of the tiles that reached it.
    pub tiles_done: f64,
    /// Time the other tiles are expected to need (error ∝ 1/√spp, at the rate so far).
    pub remaining: Option<Duration>,
}

/// The error a render reached (estimated from its half-films; [`crate::ErrorEstimate`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorReached {
    /// Mean of the pixels' estimated ΔE00.
    pub mean: f64,
    /// The largest tile's estimated ΔE00.
    pub worst_tile: f64,
    /// The target per tile, if the render had one.
    pub target: Option<f64>,
    /// Share of the tiles at or below the target (1 without a target).
    pub tiles_done: f64,
}

/// What an estimate says a render reached, against `target` (the share of tiles at or below it;
/// 1 without one).
fn error_reached(e: &ErrorEstimate, target: Option<f64>) -> ErrorReached {
    ErrorReached {
        mean: e.mean(),
        worst_tile: e.worst_tile(),
        target,
        tiles_done: target
            .map_or(1.0, |t| e.tiles.iter().filter(|&&v| f64::from(v) <= t).count() as f64 / e.tiles.len() as f64),
    }
}

/// Figures about a finished render.
#[derive(Debug, Clone)]
pub struct RenderStats {
    /// The spectral strategy actually used (`auto` resolved).
    pub spectral: SpectralMode,
    /// Rays traced.
    pub rays: u64,
    /// Of those, shadow rays: visibility queries towards sampled lights (with their continuations
    /// through cut-outs and transparent surfaces).
    pub shadow_rays: u64,
    /// Wall time of the pixel loop (scene assembly excluded).
    pub elapsed: Duration,
    /// Samples whose value was NaN or infinite (added as black; must be 0): see
    /// [`nonfinite_verdict`].
    pub nonfinite_samples: u64,
    /// Samples the film holds (all pixels; a resumed film's included, as in `nonfinite_samples`).
    pub samples: u64,
    /// Fewest samples any pixel got (fewer than asked if a time limit stopped the render).
    pub spp: u32,
    /// Most samples any pixel got (an adaptive render's busiest tile).
    pub max_spp: u32,
    /// The estimated error reached, where the film kept half-film sums (a target error, an
    /// error map).
    pub error: Option<ErrorReached>,
    /// Samples whose value was beyond the film's range (2⁴²) and was clamped (should be 0).
    pub clamped_samples: u64,
}

/// Largest share of a render's samples that may be non-finite for its images to be written.
/// A non-finite sample is added as black, so a share s darkens the image by s on average: at
/// 1 % that stays within the noise of a few hundred spp and is not mistaken for a dark scene,
/// while more means a material, light or texture that fails systematically, and the image
/// (black where it fails, in the worst case all of it) would be a wrong answer given silently.
pub const MAX_NONFINITE_SHARE: f64 = 0.01;

/// What a render's non-finite samples (NaN or infinite, added to the film as black) mean for
/// its images, from [`nonfinite_verdict`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum NonfiniteVerdict {
    /// None: the image is what the renderer computed.
    Clean,
    /// A few (at most [`MAX_NONFINITE_SHARE`]): write the image, and say so loudly.
    Warn(String),
    /// More than [`MAX_NONFINITE_SHARE`]: the image would be a silent wrong answer; write nothing.
    Refuse(String),
}

/// The verdict on `nonfinite` non-finite samples out of `samples` ([`RenderStats`]); the
/// messages give the count and the share.
pub fn nonfinite_verdict(nonfinite: u64, samples: u64) -> NonfiniteVerdict {
    if nonfinite == 0 {
        return NonfiniteVerdict::Clean;
    }
    let share = nonfinite as f64 / samples.max(1) as f64;
    let counted = format!("{nonfinite} of {samples} samples ({:.3} %) were NaN or infinite", 100.0 * share);
    if share > MAX_NONFINITE_SHARE {
        NonfiniteVerdict::Refuse(format!(
            "{counted}, more than {} %: the image would be black where they fell; a bug in a material, light or texture (please report the scene)",
            100.0 * MAX_NONFINITE_SHARE
        ))
    } else {
        NonfiniteVerdict::Warn(format!(
            "{counted} and were added as black: the image is darker where they fell (please report the scene)"
        ))
    }
}

/// Calls [`render_film_with`] makes between passes over the image: a checkpoint.
#[derive(Clone, Copy)]
pub struct Checkpoint<'a> {
    /// Least time between two calls (zero: after every pass).
    pub every: Duration,
    /// Called with the film so far (every pixel holding a prefix of its sample range); an
    /// error stops the render.
    pub write: &'a (dyn Fn(&Film) -> Result<()> + Sync),
}

impl std::fmt::Debug for Checkpoint<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Checkpoint").field("every", &self.every).finish_non_exhaustive()
    }
}

/// What a caller controls in a running render besides its options.
pub struct RenderControl<'a> {
    /// Called from worker threads after each row.
    pub progress: &'a (dyn Fn(Progress) + Sync),
    /// Setting it stops the render at the next row with [`Error::Cancelled`].
    pub cancel: &'a AtomicBool,
    /// The film of an interrupted render of the same scene, options and sample range
    /// (checked by the caller, e.g. `FilmFile::resumable`): each pixel continues after the
    /// samples it holds, and the result is bit for bit the uninterrupted render's.
    pub resume: Option<Film>,
    /// Write the film periodically; samples are then taken in passes of one per pixel.
    pub checkpoint: Option<Checkpoint<'a>>,
    /// The strategy [`resolved_spectral`] gave for these options, where the caller has it
    /// already (`auto` may run a pilot render to decide; `None` decides here).
    pub spectral: Option<SpectralMode>,
}

impl std::fmt::Debug for RenderControl<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RenderControl").field("checkpoint", &self.checkpoint).finish_non_exhaustive()
    }
}

/// Check what [`RenderOptions::check_limits`] does not: the samples per pixel, the
/// sample range and the paper's model's weight threshold. Returns the sample range to render.
pub(crate) fn check_options(options: &RenderOptions) -> Result<Range<u32>> {
    options.check_limits()?;
    if options.spp == 0 || options.spp > MAX_SPP {
        return Err(Error::OutOfRange { what: "spp", value: f64::from(options.spp), range: "1..=1048576" });
    }
    let samples = options.samples.clone().unwrap_or(0..options.spp);
    if samples.start >= samples.end || samples.end > options.spp {
        return Err(Error::InvalidOption {
            option: "sample range",
            value: format!("{}..{}", samples.start, samples.end),
            expected: "a non-empty range within 0..spp",
        });
    }
    if let Some(t) = options.target_error {
        if !(t.delta_e.is_finite() && t.delta_e > 0.0) {
            return Err(Error::OutOfRange { what: "target error", value: t.delta_e.into(), range: "> 0 (a ΔE00)" });
        }
        if options.samples.is_some() {
            return Err(Error::InvalidOption {
                option: "sample range",
                value: format!("{}..{} with a target error", samples.start, samples.end),
                expected: "all samples: an adaptive render decides from the whole film, so it is not split into parts (give a fixed spp)",
            });
        }
    }
    if let Integrator::WhittedHall(w) = &options.integrator
        && !(w.min_weight.is_finite() && w.min_weight >= 0.0)
    {
        return Err(Error::OutOfRange { what: "min weight", value: w.min_weight.into(), range: ">= 0" });
    }
    Ok(samples)
}

/// Render `scene` with the spectral mode already resolved (never `auto`): the pixel loop over
/// `samples` (the range [`check_options`] returned), on the render's own thread pool.
pub(crate) fn render_resolved(
    scene: &RenderScene,
    options: &RenderOptions,
    control: RenderControl<'_>,
    spectral: SpectralMode,
    samples: Range<u32>,
) -> Result<(Film, RenderStats)> {
    let RenderControl { progress, cancel, resume, checkpoint, spectral: _ } = control;
    if options.spectral_film && !matches!(spectral, SpectralMode::Bins(_)) {
        return Err(Error::InvalidOption {
            option: "spectral mode for a spectral image",
            value: spectral.to_string(),
            expected: "bins:N (fixed wavelengths; bins:95 is the 5 nm grid)",
        });
    }
    // Fixed lanes cannot follow a path to the wavelength a fluorescent surface absorbed at.
    if let Integrator::Path(_) = &options.integrator
        && !matches!(spectral, SpectralMode::Hero { .. })
        && let Some(m) = scene.materials.iter().find(|m| m.fluorescence.is_some())
    {
        return Err(Error::FluorescenceNeedsHero { material: m.name.clone(), spectral: spectral.to_string() });
    }
    // Bidirectional path tracing and photon mapping do not shift wavelengths: they would render a
    // fluorescent surface's reflectance alone, a wrong answer given silently.
    if let Integrator::Bdpt(_) | Integrator::Sppm(_) = &options.integrator
        && let Some(m) = scene.materials.iter().find(|m| m.fluorescence.is_some())
    {
        return Err(Error::InvalidOption {
            option: "integrator",
            value: format!("{} with the fluorescent material `{}`", integrator_name(&options.integrator), m.name),
            expected: "--integrator path (bidirectional path tracing and photon mapping do not render fluorescence yet)",
        });
    }
    if let Integrator::Sppm(_) = &options.integrator {
        // The radius couples the iterations: a part, a resumed film or a half-film is not a sum of
        // independent samples.
        let refused = if samples.start != 0 || samples.end != options.spp {
            Some(format!("sample range {}..{}", samples.start, samples.end))
        } else if resume.is_some() || checkpoint.is_some() {
            Some("a resumed or checkpointed render".to_owned())
        } else if options.keeps_halves() {
            Some("a target error or an error map".to_owned())
        } else {
            None
        };
        if let Some(value) = refused {
            return Err(Error::InvalidOption {
                option: "sppm render",
                value,
                expected: "one whole render (photon mapping's radius couples its iterations: no parts, resume, checkpoints or error estimate; --integrator bdpt has them)",
            });
        }
    }
    let lanes = lane_count(spectral)?;
    let pool = thread_pool(options)?;
    let job = RenderJob { scene, options, spectral, samples, progress, cancel, resume, checkpoint };
    pool.install(|| with_lanes(lanes, job))
}

struct RenderJob<'a> {
    scene: &'a RenderScene,
    options: &'a RenderOptions,
    spectral: SpectralMode,
    samples: Range<u32>,
    progress: &'a (dyn Fn(Progress) + Sync),
    cancel: &'a AtomicBool,
    resume: Option<Film>,
    checkpoint: Option<Checkpoint<'a>>,
}

impl LaneJob for RenderJob<'_> {
    type Output = Result<(Film, RenderStats)>;

    fn run<const N: usize>(self) -> Self::Output {
        let fixed = || match self.spectral {
            SpectralMode::Rgb => Lanes::<N>::rgb(),
            SpectralMode::Bins(n) => Lanes::bins(n, &scene_white(self.scene)),
            SpectralMode::Hero { .. } | SpectralMode::Auto => unreachable!("no fixed lanes for {}", self.spectral),
        };
        match &self.options.integrator {
            Integrator::WhittedHall(o) => {
                let sensor = Sensor::Fixed(fixed());
                let kernel = Whitted::new(self.scene, &sensor, o);
                render_pixels(&kernel, &sensor, self)
            }
            Integrator::Path(o) => {
                let sensor = match self.spectral {
                    SpectralMode::Hero { .. } => None,
                    _ => Some(fixed()),
                };
                let (kernel, sensor) = PathTracer::<N>::new(self.scene, sensor, o);
                render_pixels(&kernel, &sensor, self)
            }
            Integrator::Bdpt(o) => {
                let sensor = match self.spectral {
                    SpectralMode::Hero { .. } => None,
                    _ => Some(fixed()),
                };
                let camera = self.scene.camera(self.options.width, self.options.height)?;
                if camera.is_orthographic() {
                    return Err(Error::InvalidOption {
                        option: "integrator",
                        value: "bdpt with an orthographic camera".to_owned(),
                        expected: "a perspective camera (light tracing connects to a pinhole), or --integrator path",
                    });
                }
                let (tracer, sensor) = PathTracer::<N>::new(self.scene, sensor, o);
                let kernel = Bdpt::new(tracer, camera, self.options.width, self.options.height);
                render_pixels(&kernel, &sensor, self)
            }
            Integrator::Sppm(o) => {
                let sensor = match self.spectral {
                    SpectralMode::Hero { .. } => None,
                    _ => Some(fixed()),
                };
                let (width, height) = (self.options.width, self.options.height);
                let camera = self.scene.camera(width, height)?;
                if camera.is_orthographic() {
                    return Err(Error::InvalidOption {
                        option: "integrator",
                        value: "sppm with an orthographic camera".to_owned(),
                        expected: "a perspective camera, or --integrator path",
                    });
                }
                let (tracer, sensor) = PathTracer::<N>::new(self.scene, sensor, &o.path);
                let photons = o.photons.unwrap_or(u64::from(width) * u64::from(height));
                let mapping = PhotonMapping::new(tracer, camera, width, height, self.options.seed, photons, o.radius);
                render_photon_mapping(&mapping, &sensor, self)
            }
        }
    }
}

/// The name `--integrator` takes for `integrator`.
fn integrator_name(integrator: &Integrator) -> &'static str {
    match integrator {
        Integrator::WhittedHall(_) => "whitted-hall",
        Integrator::Path(_) => "path",
        Integrator::Bdpt(_) => "bdpt",
        Integrator::Sppm(_) => "sppm",
    }
}

/// Photon mapping's render: its iterations (the samples per pixel) into a film with splat sums, the
/// camera passes as samples and the photon term as splats (`integrators/sppm.rs`). A time limit stops it
/// after the iteration that passes it; the film is normalised by the iterations it holds.
fn render_photon_mapping<const N: usize>(
    mapping: &PhotonMapping<'_, N>,
    sensor: &Sensor<N>,
    job: RenderJob<'_>,
) -> Result<(Film, RenderStats)> {
    let RenderJob { options, spectral, progress, cancel, .. } = job;
    let (width, height) = (options.width, options.height);
    let wavelengths = if options.spectral_film { sensor.film_wavelengths().unwrap_or_default() } else { Vec::new() };
    let mut film = Film::new(width, height, wavelengths).with_splats();
    let start = Instant::now();
    let out_of_time = || options.time_limit.is_some_and(|limit| start.elapsed() >= limit);
    let pixels = u64::from(width) * u64::from(height);
    let report = |done: u32, count: RayCount| {
        progress(Progress {
            rows_done: u64::from(done) * u64::from(height),
            rows_total: u64::from(options.spp) * u64::from(height),
            rays: count.rays,
            samples: u64::from(done) * pixels,
            elapsed: start.elapsed(),
            error: None,
        })
    };
    let count = mapping.render(&mut film, sensor, options.spp, cancel, &out_of_time, &report)?;
    let stats = film_stats(&film, spectral, count, start.elapsed(), None);
    Ok((film, stats))
}

/// The pixel loop: samples `job.samples` of every pixel, in passes over the image, rows in
/// parallel. The random numbers of sample i of pixel p depend only on (seed, p, i) and the
/// film's sums are exact, so the image is the same for any thread count, pass size or split
/// into sample ranges.
///
/// A kernel that splats ([`Kernel::SPLATS`]) gets a film with splat sums: each sample's splats are
/// converted with its final wavelengths and lane, kept in a bounded batch per row task and added
/// under the lock of the row it lands in (`film::splat`); integer sums again, so the same bits
/// for any thread count. Other kernels compile to the loop without them.
///
/// With a target error the samples are taken in stages ([`stage_ends`]); after each, the tiles
/// whose estimated error reached the target stop. Which tiles go on is decided from the film
/// alone (its sums and counts), so a resumed render decides as the uninterrupted one did: a
/// tile is still sampling when it holds more samples than the last finished stage's end.
fn render_pixels<const N: usize, K: Kernel<N>>(
    kernel: &K,
    sensor: &Sensor<N>,
    job: RenderJob<'_>,
) -> Result<(Film, RenderStats)> {
    let RenderJob { scene, options, spectral, samples, progress, cancel, resume, checkpoint } = job;
    let (width, height) = (options.width, options.height);
    let camera = scene.camera(width, height)?;
    let wavelengths = if options.spectral_film { sensor.film_wavelengths().unwrap_or_default() } else { Vec::new() };
    let mut film = match resume {
        Some(film) => {
            if (film.width, film.height) != (width, height)
                || film.wavelengths != wavelengths
                || film.has_halves() != options.keeps_halves()
                || film.has_splats() != K::SPLATS
            {
                return Err(Error::InvalidOption {
                    option: "film to resume",
                    value: format!("{}x{} with {} wavelengths", film.width, film.height, film.wavelengths.len()),
                    expected: "a film of the same size, wavelengths, error estimate and splats as the render",
                });
            }
            if film.max_sample_count() > samples.len() as u32 {
                return Err(Error::InvalidOption {
                    option: "film to resume",
                    value: format!("{} samples in a pixel", film.max_sample_count()),
                    expected: "at most the render's sample range",
                });
            }
            film
        }
        None => {
            let film = Film::new(width, height, wavelengths);
            let film = if options.keeps_halves() { film.with_halves() } else { film };
            if K::SPLATS { film.with_splats() } else { film }
        }
    };
    let sampler = PixelSampler::new(kernel, sensor, camera, options);
    let range = samples.len() as u32;
    let stages = stage_ends(range, options.target_error.is_some());
    let (tiles_x, tiles_y) = tile_grid(width, height);
    let tile_of = |i: usize| tile_index((i % width as usize) as u32, (i / width as usize) as u32, tiles_x);
    // Where the film stands: the first stage not finished by every sampling tile, and which tiles
    // are sampling (all, in the first stage; a fresh film is there).
    let most = film.max_sample_count();
    let mut stage = stages.partition_point(|&end| end < most).min(stages.len() - 1);
    let mut active = vec![true; tiles_x as usize * tiles_y as usize];
    if stage > 0 {
        let done = stages[stage - 1];
        let mut tile_most = vec![0u32; active.len()];
        for (i, p) in film.pixels.iter().enumerate() {
            let t = tile_of(i);
            tile_most[t] = tile_most[t].max(p.count);
        }
        for (a, m) in active.iter_mut().zip(tile_most) {
            *a = m > done;
        }
    }
    // With a time limit, passes of one sample each spread the samples taken evenly over the
    // image when it stops, and every row of a pass is short whatever the spp. The first pass
    // ignores the limit, so every pixel gets at least one sample. Checkpoints are taken
    // between passes, so they also want short passes. A render to a target error keeps a pass
    // per stage under its time limit: a stage is at most half the samples taken before it, and
    // passes of one sample over the few tiles still sampling left a core idle (1.5 of 2 busy).
    let short_passes = checkpoint.is_some() || (options.time_limit.is_some() && options.target_error.is_none());
    let mut last_checkpoint = Instant::now();
    let start = Instant::now();
    let out_of_time = || options.time_limit.is_some_and(|limit| start.elapsed() >= limit);
    let rays = AtomicU64::new(0);
    let shadow_rays = AtomicU64::new(0);
    let rows_done = AtomicU64::new(0);
    let taken = AtomicU64::new(0);
    // The estimate after the last finished stage, shown with every row of the next.
    let mut shown = None::<ErrorProgress>;
    let mut first_pass = true;
    let mut reached = None;
    let mut stopped_by_time = false;
    'stages: loop {
        let (lo, hi) = (if stage == 0 { 0 } else { stages[stage - 1] }, stages[stage]);
        let pass_size = if short_passes { 1 } else { hi - lo };
        let passes = (hi - lo).div_ceil(pass_size);
        // Skip the passes every sampling pixel has done (a resumed film).
        let fewest = film
            .pixels
            .iter()
            .enumerate()
            .filter(|(i, _)| active[tile_of(*i)])
            .map(|(_, p)| p.count)
            .min()
            .unwrap_or(hi);
        let skip = (fewest.saturating_sub(lo) / pass_size).min(passes);
        let active_rows = (0..height as usize)
            .filter(|&y| (0..tiles_x as usize).any(|tx| active[tile_index(0, y as u32, tiles_x) + tx]))
            .count() as u64;
        let rows_total = rows_done.load(Ordering::Relaxed) + active_rows * u64::from(passes - skip);
        for pass in skip..passes {
            let end = samples.start + (lo + (pass + 1) * pass_size).min(hi);
            let (rows, splat_target) = film.pass_mut();
            let counts: Vec<(u64, u64)> = rows
                // One row per task for a render to a target error: the few rows its late stages
                // sample would otherwise sit in one thread's half of the image while the other
                // idles (wall time 0.75×, measured). A fixed-spp render keeps rayon's own split.
                .with_max_len(if options.target_error.is_some() { 1 } else { usize::MAX })
                .enumerate()
                .map(|(y, mut row)| -> Result<(u64, u64)> {
                    if cancel.load(Ordering::Relaxed) {
                        return Err(Error::Cancelled);
                    }
                    let row_tiles = tile_index(0, y as u32, tiles_x);
                    if !active[row_tiles..row_tiles + tiles_x as usize].iter().any(|&a| a) {
                        return Ok((0, 0));
                    }
                    if !first_pass && out_of_time() {
                        return Ok((0, 0));
                    }
                    let mut count = RayCount::default();
                    let mut fixed = Sampler::Independent(Rng::new(0, 0, 0));
                    let mut row_samples = 0u64;
                    let mut splats = Vec::new();
                    // This row's samples' splats, converted, added to the film in batches.
                    let mut batch = Vec::<SplatValue<N>>::new();
                    for x in 0..width as usize {
                        if !active[row_tiles + x / TILE as usize] {
                            continue;
                        }
                        let pixel = y as u64 * u64::from(width) + x as u64;
                        let rotation = sampler.rotation(pixel);
                        // Each pixel continues after the samples it holds (a pixel a time limit
                        // left behind catches up), so it always holds a prefix of the range.
                        let next = samples.start + row.count(x);
                        for i in next..end {
                            // Within the pixel too: a row of 64 pixels at 2²⁰ spp is minutes of work.
                            // A relaxed load every CANCEL_EVERY samples costs nothing next to them,
                            // and a cancelled render's film is dropped, so a pixel left half done is
                            // never seen.
                            if i % CANCEL_EVERY == 0 && cancel.load(Ordering::Relaxed) {
                                return Err(Error::Cancelled);
                            }
                            if K::SPLATS {
                                splats.clear();
                            }
                            let (r, lambda) = sampler.sample(x, y, rotation, i, &mut fixed, &mut count, &mut splats);
                            if i == 0 {
                                row.set_first_hit(x, r.first);
                            }
                            let (xyz, values) = sensor.to_xyz(&r.l, &lambda, r.lane);
                            row.add_sample(x, i, xyz, &values);
                            if K::SPLATS {
                                // With the sample's final wavelengths and lane, as its own value.
                                for s in &splats {
                                    if s.x >= width || s.y >= height {
                                        debug_assert!(false, "a splat outside the image: ({}, {})", s.x, s.y);
                                        continue;
                                    }
                                    let (xyz, values) = sensor.to_xyz(&s.l, &lambda, r.lane);
                                    let pixel = s.y as usize * width as usize + s.x as usize;
                                    batch.push(SplatValue { pixel, second: second_half(i), xyz, values });
                                }
                                if batch.len() >= SPLAT_BATCH {
                                    splat_target.add(&mut batch);
                                }
                            }
                        }
                        row_samples += u64::from(end.saturating_sub(next));
                    }
                    if K::SPLATS {
                        splat_target.add(&mut batch);
                    }
                    let rays_now = rays.fetch_add(count.rays, Ordering::Relaxed) + count.rays;
                    shadow_rays.fetch_add(count.shadow, Ordering::Relaxed);
                    let samples_now = taken.fetch_add(row_samples, Ordering::Relaxed) + row_samples;
                    let rows = rows_done.fetch_add(1, Ordering::Relaxed) + 1;
                    progress(Progress {
                        rows_done: rows,
                        rows_total,
                        rays: rays_now,
                        samples: samples_now,
                        elapsed: start.elapsed(),
                        error: shown,
                    });
                    Ok((row.nonfinite, row.clamped))
                })
                .collect::<Result<_>>()?;
            let (nonfinite, clamped) = splat_target.finish();
            film.add_counts(nonfinite, clamped);
            for (nonfinite, clamped) in counts {
                film.add_counts(nonfinite, clamped);
            }
            if samples.start == 0 && lo + pass * pass_size == 0 {
                film.set_has_first_sample();
            }
            first_pass = false;
            if out_of_time() {
                stopped_by_time = true;
                break 'stages;
            }
            let last = stage + 1 == stages.len() && pass + 1 == passes;
            if let Some(c) = &checkpoint
                && !last
                && last_checkpoint.elapsed() >= c.every
            {
                (c.write)(&film)?;
                last_checkpoint = Instant::now();
            }
        }
        let Some(target) = options.target_error else { break };
        // The stage is done: the tiles that reached the target stop.
        let scale = display_scale(&film, target.exposure_ev);
        let Some(e) = film.error_estimate(scale, samples.start) else { break };
        let goal = f64::from(target.delta_e);
        let mut remaining = 0.0f64;
        for (t, error) in still_sampling(&mut active, &e.tiles, goal, tiles_x) {
            // Error ∝ 1/√spp: the samples this tile still needs, at most the range.
            let needed = (f64::from(hi) * (error / goal).powi(2)).min(f64::from(range));
            remaining += (needed - f64::from(hi)).max(0.0) * tile_pixels(t, tiles_x, width, height);
        }
        // Done are the tiles that stopped: with auto-exposure a tile stopped at an earlier stage
        // may now read a little above the target, but it has stopped all the same.
        let done = active.iter().filter(|&&a| !a).count() as f64 / active.len() as f64;
        let summary = ErrorReached { tiles_done: done, ..error_reached(&e, Some(goal)) };
        let rate = taken.load(Ordering::Relaxed) as f64 / start.elapsed().as_secs_f64().max(1e-6);
        let now = ErrorProgress {
            mean: summary.mean,
            worst_tile: summary.worst_tile,
            target: goal,
            tiles_done: summary.tiles_done,
            remaining: (rate > 0.0).then(|| Duration::from_secs_f64((remaining / rate).min(1e9))),
        };
        shown = Some(now);
        reached = Some(summary);
        progress(Progress {
            rows_done: rows_done.load(Ordering::Relaxed),
            rows_total: rows_done.load(Ordering::Relaxed),
            rays: rays.load(Ordering::Relaxed),
            samples: taken.load(Ordering::Relaxed),
            elapsed: start.elapsed(),
            error: Some(now),
        });
        stage += 1;
        if !active.contains(&true) || stage == stages.len() {
            break;
        }
        if let Some(c) = &checkpoint
            && last_checkpoint.elapsed() >= c.every
        {
            (c.write)(&film)?;
            last_checkpoint = Instant::now();
        }
    }
    let error = match reached {
        // The last stage's estimate, unless the time limit stopped a stage part way.
        Some(r) if !stopped_by_time => Some(r),
        // Stopped by the time limit, or a film kept its halves for an error map: measure now.
        _ => {
            let target = options.target_error;
            film.error_estimate(display_scale(&film, target.and_then(|t| t.exposure_ev)), samples.start)
                .map(|e| error_reached(&e, target.map(|t| f64::from(t.delta_e))))
        }
    };
    let count = RayCount { rays: rays.into_inner(), shadow: shadow_rays.into_inner() };
    let stats = film_stats(&film, spectral, count, start.elapsed(), error);
    Ok((film, stats))
}

/// A finished render's statistics: its rays, time and error, and what its film holds.
fn film_stats(
    film: &Film,
    spectral: SpectralMode,
    count: RayCount,
    elapsed: Duration,
    error: Option<ErrorReached>,
) -> RenderStats {
    RenderStats {
        spectral,
        rays: count.rays,
        shadow_rays: count.shadow,
        elapsed,
        nonfinite_samples: film.nonfinite_samples(),
        samples: film.sample_counts().iter().map(|&c| u64::from(c)).sum(),
        spp: film.min_sample_count(),
        max_spp: film.max_sample_count(),
        clamped_samples: film.clamped_samples(),
        error,
    }
}

/// After a stage: which sampling tiles go on, as (tile, the error it is judged by). A tile stops
/// only when it and every sampling tile next to it (eight around it) are at or below `goal`; it
/// is judged by the largest error among them.
///
/// A tile's own estimate is made from the samples its mean is made from, so a tile whose samples
/// happened to miss the rare bright paths (a caustic, light leaking past an edge) looks both
/// darker and less noisy than it is, and stopping it on its own estimate keeps that luck: on the
/// Cornell box at target 2 the images read 0.4–0.9 % dark, blocks of them up to 5 %. Its
/// neighbours' samples are independent of its own, so waiting for them too (as Cycles dilates its
/// unconverged pixels) takes that correlation out of the decision: no bias was left within the
/// noise (`docs/defaults.md`, "Why a tile waits for its neighbours"). Tiles that stopped at an
/// earlier stage stay stopped and hold no one back.
fn still_sampling(active: &mut [bool], errors: &[f32], goal: f64, tiles_x: u32) -> Vec<(usize, f64)> {
    let tiles_x = tiles_x as usize;
    let tiles_y = active.len() / tiles_x;
    let above = |t: usize| active[t] && f64::from(errors[t]) > goal;
    let mut going = Vec::new();
    for (t, _) in active.iter().enumerate().filter(|(_, a)| **a) {
        let (x, y) = (t % tiles_x, t / tiles_x);
        let mut worst = None::<f64>;
        for ny in y.saturating_sub(1)..=(y + 1).min(tiles_y - 1) {
            for nx in x.saturating_sub(1)..=(x + 1).min(tiles_x - 1) {
                let n = ny * tiles_x + nx;
                if above(n) {
                    worst = Some(worst.map_or(f64::from(errors[n]), |w| w.max(f64::from(errors[n]))));
                }
            }
        }
        if let Some(w) = worst {
            going.push((t, w));
        }
    }
    active.fill(false);
    for &(t, _) in &going {
        active[t] = true;
    }
    going
}

/// Pixels in tile `t` (edge tiles are cut by the image's border).
fn tile_pixels(t: usize, tiles_x: u32, width: u32, height: u32) -> f64 {
    let (tx, ty) = (t as u32 % tiles_x, t as u32 / tiles_x);
    let w = (width - tx * TILE).min(TILE);
    let h = (height - ty * TILE).min(TILE);
    f64::from(w * h)
}

/// The display's scale (2^EV) the error is judged at: the fixed exposure, or the auto-exposure of
/// the film as it stands (as the PNG will be exposed).
fn display_scale(film: &Film, exposure_ev: Option<f32>) -> f64 {
    let ev = exposure_ev.unwrap_or_else(|| auto_exposure_ev_of(film.mean_luminances()).unwrap_or(0.0));
    f64::from(ev).exp2()
}

/// Samples per pixel of an adaptive render's first stage: every pixel takes them before any tile
/// is judged. Each half-film then holds 8, so a tile's estimate is its pixels' mean over 64 draws.
pub const FIRST_STAGE_SPP: u32 = 16;

/// Where the stages of a render of `range` samples per pixel end (counts from the range's start):
/// one stage without a target; with one, 16, 24, 32, 48, 64, 96, … (each power of two and 1.5
/// times it: at most 1.5× the samples a tile needs), up to `range`.
pub fn stage_ends(range: u32, adaptive: bool) -> Vec<u32> {
    if !adaptive {
        return vec![range];
    }
    let mut ends = Vec::new();
    let mut power = FIRST_STAGE_SPP;
    while power < range {
        ends.push(power);
        let half_step = power + power / 2;
        if half_step < range {
            ends.push(half_step);
        }
        power = power.saturating_mul(2);
    }
    ends.push(range);
    ends
}

/// Samples between two looks at the cancel flag in the pixel loop: a sample takes from about a
/// microsecond (one sphere, whitted-hall) to a few hundred (deep paths), so a Ctrl-C is seen
/// within milliseconds at worst.
const CANCEL_EVERY: u32 = 16;

/// Everything that decides one camera sample: the film's wavelengths, the camera ray and the
/// integrator's radiance along it. The pixel loop and `auto`'s pilot (`pilot.rs`) take their
/// samples through it, so the pilot measures exactly the samples a render would take.
pub(crate) struct PixelSampler<'a, const N: usize, K> {
    kernel: &'a K,
    sensor: &'a Sensor<N>,
    camera: Camera,
    width: u32,
    height: u32,
    spp: u32,
    seed: u64,
    /// Deterministic sub-pixel positions (kernels that are not [`Kernel::RANDOM`]).
    offsets: Vec<(f32, f32)>,
    /// Only hero sensors place wavelengths per sample; fixed lanes are the same for all.
    hero: bool,
    sobol: bool,
    /// Sobol' points in two independent randomisations, one per half-film (a film that keeps
    /// half-film sums: [`SobolSample::of_half`]).
    halves: bool,
    fixed_lambda: SampledWavelengths<N>,
}

impl<'a, const N: usize, K: Kernel<N>> PixelSampler<'a, N, K> {
    pub(crate) fn new(kernel: &'a K, sensor: &'a Sensor<N>, camera: Camera, options: &RenderOptions) -> Self {
        Self {
            kernel,
            sensor,
            camera,
            width: options.width,
            height: options.height,
            spp: options.spp,
            seed: options.seed,
            offsets: if K::RANDOM { Vec::new() } else { pixel_offsets(options.spp) },
            hero: !matches!(sensor, Sensor::Fixed(_)),
            sobol: matches!(options.integrator, Integrator::Path(PathOptions { sampler: SamplerKind::Sobol, .. })),
            halves: options.keeps_halves(),
            fixed_lambda: sensor.sample_wavelengths(0.0),
        }
    }

    /// With independent numbers, a random rotation per pixel of the stratified hero
    /// wavelengths, so a partial set of strata (time limit, sample range) is still unbiased. It
    /// has its own stream, so skipping it for fixed lanes changes no other number. (Sobol'
    /// points stratify the wavelengths themselves.)
    #[inline]
    pub(crate) fn rotation(&self, pixel: u64) -> f32 {
        if K::RANDOM && self.hero && !self.sobol { Rng::new(self.seed, pixel, u64::MAX).uniform() } else { 0.0 }
    }

    /// Sample `i` of pixel (x, y) (`rotation` from [`PixelSampler::rotation`]): its radiance and
    /// wavelengths. The random numbers depend only on (seed, pixel, i).
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn sample(
        &self,
        x: usize,
        y: usize,
        rotation: f32,
        i: u32,
        fixed: &mut Sampler,
        count: &mut RayCount,
        splats: &mut Vec<Splat<N>>,
    ) -> (Radiance<N>, SampledWavelengths<N>) {
        let (width, height) = (self.width, self.height);
        let mut own;
        let (sampler, mut lambda, ray) = if K::RANDOM {
            let pixel = y as u64 * u64::from(width) + x as u64;
            // The camera's numbers (block 0 of Sobol' points): first the hero wavelengths, then
            // the position in the pixel; both are drawn for fixed lanes too.
            let u = if self.sobol {
                own = Sampler::Sobol(if self.halves {
                    SobolSample::of_half(self.seed, pixel, i)
                } else {
                    SobolSample::new(self.seed, pixel, i)
                });
                own.uniform()
            } else {
                own = Sampler::Independent(Rng::new(self.seed, pixel, u64::from(i)));
                let u = rotation + (i as f32 + own.uniform()) / self.spp as f32;
                if u >= 1.0 { u - 1.0 } else { u }
            };
            let lambda = if self.hero { self.sensor.sample_wavelengths(u.min(0.999_999_9)) } else { self.fixed_lambda };
            let jitter = own.uniform2();
            let ray = camera_ray(&self.camera, x, y, jitter.x, jitter.y, width, height);
            (&mut own, lambda, ray)
        } else {
            let (dx, dy) = self.offsets[i as usize];
            (fixed, self.fixed_lambda, camera_ray(&self.camera, x, y, dx, dy, width, height))
        };
        let r = self.kernel.li(&ray, &mut lambda, self.sensor, sampler, count, splats);
        (r, lambda)
    }
}

#[inline]
fn camera_ray(camera: &Camera, x: usize, y: usize, dx: f32, dy: f32, width: u32, height: u32) -> Ray {
    camera.generate_ray(x as f32 + dx, y as f32 + dy, width, height)
}

pub(crate) fn thread_pool(options: &RenderOptions) -> Result<rayon::ThreadPool> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = options.threads {
        builder = builder.num_threads(n);
    }
    builder.build().map_err(|e| Error::ThreadPool(e.to_string()))
}

/// Deterministic sub-pixel positions: the pixel centre for one sample, otherwise the R2
/// low-discrepancy sequence (Roberts 2018), which stratifies well for any count.
fn pixel_offsets(spp: u32) -> Vec<(f32, f32)> {
    if spp == 1 {
        return vec![(0.5, 0.5)];
    }
    // 1/φ₂ and 1/φ₂², φ₂ the plastic number (Roberts, "The unreasonable effectiveness of
    // quasirandom sequences", 2018).
    const A1: f64 = 0.754_877_666_246_692_8;
    const A2: f64 = 0.569_840_290_998_053_3;
    (0..spp).map(|i| (((0.5 + A1 * f64::from(i)) % 1.0) as f32, ((0.5 + A2 * f64::from(i)) % 1.0) as f32)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tile_stops_only_with_its_sampling_neighbours() {
        // 4 × 3 tiles; goal 1. Tile 5 (x 1, y 1) is above; tile 11 (corner) has stopped earlier
        // and reads above, which holds no one back.
        let mut active = vec![true; 12];
        active[11] = false;
        let mut errors = vec![0.5f32; 12];
        errors[5] = 1.5;
        errors[11] = 3.0;
        let going = still_sampling(&mut active, &errors, 1.0, 4);
        let tiles: Vec<usize> = going.iter().map(|&(t, _)| t).collect();
        // Tile 5 and its eight neighbours (x 0..=2, y 0..=2); x 3 and tile 11 stop.
        assert_eq!(tiles, vec![0, 1, 2, 4, 5, 6, 8, 9, 10]);
        assert!(going.iter().all(|&(_, e)| e == 1.5));
        let expected: Vec<bool> = (0..12).map(|t| tiles.contains(&t)).collect();
        assert_eq!(active, expected);
        // Next stage: all at or below the goal, every tile stops.
        let going = still_sampling(&mut active, &[0.9; 12], 1.0, 4);
        assert!(going.is_empty() && active.iter().all(|a| !a));
        // A single tile.
        let mut one = vec![true];
        assert_eq!(still_sampling(&mut one, &[2.0], 1.0, 1), vec![(0, 2.0)]);
        assert!(one[0]);
    }

    #[test]
    fn non_finite_samples_warn_up_to_one_percent_and_refuse_beyond() {
        assert_eq!(nonfinite_verdict(0, 1000), NonfiniteVerdict::Clean);
        assert_eq!(nonfinite_verdict(0, 0), NonfiniteVerdict::Clean);
        assert_eq!(
            nonfinite_verdict(3, 3072),
            NonfiniteVerdict::Warn(
                "3 of 3072 samples (0.098 %) were NaN or infinite and were added as black: the image is darker where they fell (please report the scene)"
                    .to_owned()
            )
        );
        // Exactly 1 % is still written; one more sample is not.
        assert!(matches!(nonfinite_verdict(10, 1000), NonfiniteVerdict::Warn(_)));
        assert_eq!(
            nonfinite_verdict(11, 1000),
            NonfiniteVerdict::Refuse(
                "11 of 1000 samples (1.100 %) were NaN or infinite, more than 1 %: the image would be black where they fell; a bug in a material, light or texture (please report the scene)"
                    .to_owned()
            )
        );
        // All of them: the silent black image this is for.
        let all = nonfinite_verdict(3072, 3072);
        assert!(
            matches!(&all, NonfiniteVerdict::Refuse(m) if m.starts_with("3072 of 3072 samples (100.000 %)")),
            "{all:?}"
        );
    }

    /// Splats through the whole pixel loop, with a kernel whose answer is known exactly: every
    /// sample of pixel (x, y) sees [`OWN`] and splats [`splat_from`] (x, y) to pixel
    /// ((x + 1) mod w, (y + 1) mod h), in another row, so rows running in parallel add to each
    /// other's splat sums.
    mod splats {
        use std::path::Path;
        use std::sync::Mutex;

        use colorimetry::{DenselySampledSpectrum, SampledSpectrum};

        use super::*;
        use crate::film::ObjectId;
        use crate::film::estimate::pixel_error_with_splats;
        use crate::film::file::{FilmFile, FilmHeader};
        use crate::film::splat::SplatScales;
        use crate::options::Integrator;

        const OWN: [f32; 4] = [0.25, 0.5, 0.125, 0.25];
        const W: u32 = 7;
        const H: u32 = 5;
        const SPP: u32 = 4;

        /// What pixel (x, y) sends to its neighbour: different per pixel and per lane, so a splat
        /// added to the wrong pixel or lane shows.
        fn splat_from(x: u32, y: u32) -> [f32; 4] {
            let v = 0.125 * (1 + x + W * y) as f32;
            [v, 2.0 * v, 0.5 * v, 0.75 * v]
        }

        struct SplatKernel {
            camera: Camera,
        }

        impl SplatKernel {
            /// The pixel a camera ray goes through: how many pixel edges it lies beyond, each edge a
            /// plane through the eye (the deterministic sub-pixel positions keep ≥ 0.0098 pixel from
            /// the edges at 4 spp, far beyond rounding).
            fn pixel_of(&self, ray: &Ray) -> (u32, u32) {
                let dir = |x: f32, y: f32| self.camera.generate_ray(x, y, W, H).dir;
                let columns = (1..W)
                    .filter(|&e| {
                        let e = e as f32;
                        let normal = dir(e, 0.0).cross(dir(e, H as f32));
                        (normal.dot(ray.dir) > 0.0) != (normal.dot(dir(e - 0.5, 0.5 * H as f32)) > 0.0)
                    })
                    .count();
                let rows = (1..H)
                    .filter(|&e| {
                        let e = e as f32;
                        let normal = dir(0.0, e).cross(dir(W as f32, e));
                        (normal.dot(ray.dir) > 0.0) != (normal.dot(dir(0.5 * W as f32, e - 0.5)) > 0.0)
                    })
                    .count();
                (columns as u32, rows as u32)
            }
        }

        impl Kernel<4> for SplatKernel {
            const RANDOM: bool = false;
            const SPLATS: bool = true;

            fn li(
                &self,
                ray: &Ray,
                _lambda: &mut SampledWavelengths<4>,
                _sensor: &Sensor<4>,
                _sampler: &mut Sampler,
                count: &mut RayCount,
                splats: &mut Vec<Splat<4>>,
            ) -> Radiance<4> {
                count.rays += 1;
                let (x, y) = self.pixel_of(ray);
                splats.push(Splat { x: (x + 1) % W, y: (y + 1) % H, l: SampledSpectrum(splat_from(x, y)) });
                Radiance { l: SampledSpectrum(OWN), first: ObjectId::Background, lane: None }
            }
        }

        fn scene() -> RenderScene {
            let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/reference/cornell_box.json");
            RenderScene::load(&path).unwrap()
        }

        fn sensor() -> Sensor<4> {
            Sensor::Fixed(Lanes::bins(4, &DenselySampledSpectrum::constant(1.0)))
        }

        fn options(threads: usize) -> RenderOptions {
            RenderOptions {
                width: W,
                height: H,
                integrator: Integrator::default(),
                spectral: SpectralMode::Bins(4),
                spp: SPP,
                threads: Some(threads),
                spectral_film: true,
                ..RenderOptions::default()
            }
        }

        fn render(
            scene: &RenderScene,
            options: &RenderOptions,
            resume: Option<Film>,
            checkpoint: Option<Checkpoint<'_>>,
        ) -> Film {
            let sensor = sensor();
            let kernel = SplatKernel { camera: scene.camera(W, H).unwrap() };
            let cancel = AtomicBool::new(false);
            let job = RenderJob {
                scene,
                options,
                spectral: options.spectral,
                samples: check_options(options).unwrap(),
                progress: &|_| {},
                cancel: &cancel,
                resume,
                checkpoint,
            };
            thread_pool(options).unwrap().install(|| render_pixels(&kernel, &sensor, job)).unwrap().0
        }

        /// Own value plus the splat from the pixel up and to the left, as the film should show it.
        fn expected(x: u32, y: u32) -> ([f32; 3], [f32; 4]) {
            let Sensor::Fixed(lanes) = sensor() else { unreachable!() };
            let from = splat_from((x + W - 1) % W, (y + H - 1) % H);
            let (own_xyz, splat_xyz) = (lanes.xyz(&OWN), lanes.xyz(&from));
            (
                [0, 1, 2].map(|c| (f64::from(own_xyz[c]) + f64::from(splat_xyz[c])) as f32),
                [0, 1, 2, 3].map(|i| (f64::from(OWN[i]) + f64::from(from[i])) as f32),
            )
        }

        fn assert_expected(film: &Film) {
            let image = film.to_image();
            let (_, spectral) = image.spectral().unwrap();
            for y in 0..H {
                for x in 0..W {
                    let (xyz, values) = expected(x, y);
                    assert_eq!(image.xyz(x, y), xyz, "pixel ({x}, {y})");
                    let i = (y * W + x) as usize;
                    assert_eq!(spectral[4 * i..4 * i + 4], values, "pixel ({x}, {y})");
                }
            }
        }

        #[test]
        fn splats_land_in_their_pixels_divided_by_the_samples_per_pixel() {
            let scene = scene();
            let one = render(&scene, &options(1), None, None);
            assert!(one.has_splats() && one.min_sample_count() == SPP && one.nonfinite_samples() == 0);
            // Every pixel got SPP splats of its neighbour's value: the sums are exact.
            let Sensor::Fixed(lanes) = sensor() else { unreachable!() };
            let from = lanes.xyz(&splat_from(0, 0));
            let sum = one.splats.xyz[(W + 1) as usize][1];
            assert_eq!(crate::film::from_fixed(sum, crate::film::FRACTION_BITS), 4.0 * f64::from(from[1]));
            assert_expected(&one);
            // Rows in parallel add to each other's splat sums: the same bits.
            let two = render(&scene, &options(2), None, None);
            assert!(one == two, "1 and 2 threads differ");
            // Mean luminance (auto-exposure) reads the splats too.
            let y: Vec<f32> = one.mean_luminances().collect();
            assert_eq!(y[0], expected(0, 0).0[1]);
        }

        #[test]
        fn sample_ranges_with_splats_merge_into_the_whole_render() {
            let scene = scene();
            let whole = render(&scene, &options(2), None, None);
            let part =
                |range: Range<u32>| render(&scene, &RenderOptions { samples: Some(range), ..options(2) }, None, None);
            let mut merged = part(3..4);
            merged.merge(&part(0..1)).unwrap();
            merged.merge(&part(1..3)).unwrap();
            assert!(merged == whole, "the merged film differs from the whole render");
            assert_expected(&merged);
            // A part alone is normalised by its own samples: 1 per pixel, and still the exact value.
            assert_expected(&part(1..2));
            // A film without splat sums is another render's.
            let mut plain = Film::new(W, H, whole.wavelengths.clone());
            let err = plain.merge(&whole).unwrap_err().to_string();
            assert!(err.contains("splat sums"), "{err}");
        }

        #[test]
        fn a_resumed_render_with_splats_is_the_uninterrupted_one() {
            let scene = scene();
            let whole = render(&scene, &options(2), None, None);
            // Checkpoints after every pass of one sample per pixel: keep them all.
            let kept = Mutex::new(Vec::new());
            let write = |film: &Film| -> Result<()> {
                kept.lock().unwrap().push(film.clone());
                Ok(())
            };
            let checkpoint = Checkpoint { every: Duration::ZERO, write: &write };
            let checkpointed = render(&scene, &options(2), None, Some(checkpoint));
            assert!(checkpointed == whole);
            let kept = kept.into_inner().unwrap();
            assert_eq!(kept.len(), SPP as usize - 1);
            for partial in kept {
                let held = partial.max_sample_count();
                assert!(partial != whole && partial.min_sample_count() == held);
                assert_expected(&partial);
                // Through the file, as `--resume` reads it.
                let header = FilmHeader::new(1, &options(2), SpectralMode::Bins(4), "exposure auto".to_owned());
                let bytes = FilmFile { header, film: partial }.to_bytes();
                let back = FilmFile::from_bytes(&bytes, Path::new("c.film")).unwrap().film;
                let resumed = render(&scene, &options(1), Some(back), None);
                assert!(resumed == whole, "resumed from {held} samples per pixel");
            }
        }

        #[test]
        fn splat_sums_survive_the_film_file_and_a_damaged_splat_section_is_named() {
            let scene = scene();
            let with_halves = RenderOptions { error_estimate: true, ..options(2) };
            for options in [options(2), with_halves] {
                let film = render(&scene, &options, None, None);
                assert_eq!(film.has_halves(), options.error_estimate);
                let header = FilmHeader::new(7, &options, SpectralMode::Bins(4), "exposure auto".to_owned());
                let file = FilmFile { header, film };
                let bytes = file.to_bytes();
                assert_eq!(u32::from_le_bytes(bytes[8..12].try_into().unwrap()), 4, "splats need version 4");
                let back = FilmFile::from_bytes(&bytes, Path::new("s.film")).unwrap();
                assert!(back == file);
                assert_expected(&back.film);
                // The splat section cut short, or flagged in a version 3 file.
                let cut = bytes.len() - 8 - 16;
                let e = FilmFile::from_bytes(&bytes[..cut], Path::new("s.film")).unwrap_err().to_string();
                assert!(e.starts_with("s.film: truncated"), "{e}");
                let mut v3 = bytes.clone();
                v3[8..12].copy_from_slice(&3u32.to_le_bytes());
                let header_end = 16 + u32::from_le_bytes(v3[12..16].try_into().unwrap()) as usize;
                let checksum = geometry::xxh64(&v3[..header_end], 0);
                v3[header_end..header_end + 8].copy_from_slice(&checksum.to_le_bytes());
                let e = FilmFile::from_bytes(&v3, Path::new("s.film")).unwrap_err().to_string();
                assert_eq!(e, "s.film: corrupted: splat sums (flag bit 2) in a version 3 file, which has none");
                // A flipped byte in the splat sums: the checksum.
                let mut flipped = bytes.clone();
                flipped[cut] ^= 1;
                let e = FilmFile::from_bytes(&flipped, Path::new("s.film")).unwrap_err().to_string();
                assert!(e.starts_with("s.film: corrupted: checksum"), "{e}");
            }
        }

        #[test]
        fn half_films_divide_their_splats_by_their_own_samples() {
            // Every sample is the same, so both half-films must show exactly the same value and
            // the estimated error is 0 in every pixel: if each half keeps the splats of its own
            // sample indices and divides them by its own samples per pixel. At 3 spp the halves
            // are unequal (indices 0 and 2, and 1), so the per-half division shows. Judged at a
            // display scale that keeps every pixel (Y up to 9) below white, where nothing clips.
            const DISPLAY: f64 = 0.05;
            let scene = scene();
            let film = render(&scene, &RenderOptions { error_estimate: true, spp: 3, ..options(2) }, None, None);
            let estimate = film.error_estimate(DISPLAY, 0).unwrap();
            assert!(estimate.pixels.iter().all(|&e| e == 0.0), "{:?}", estimate.pixels);
            let scales = film.splat_scales(0).unwrap();
            assert_eq!((scales.whole, scales.first_half, scales.second_half), (1.0 / 3.0, 0.5, 1.0));
            // The mistakes this guards against read an error: the halves' splats divided by the
            // whole film's samples per pixel, or splats not split by half.
            let (p, h, s, sh) = (film.pixels[0], film.halves[0], film.splats.xyz[0], film.splats.halves[0]);
            let error = |second: [i128; 3], scales| {
                pixel_error_with_splats(p.xyz, h, p.count, 0, DISPLAY, Some((s, second, scales)))
            };
            assert_eq!(error(sh, scales), 0.0);
            let whole = SplatScales { first_half: scales.whole, second_half: scales.whole, ..scales };
            assert!(error(sh, whole) > 1.0, "{}", error(sh, whole));
            assert!(error([0; 3], scales) > 1.0, "{}", error([0; 3], scales));
        }
    }

    #[test]
    fn pixel_offsets_stay_inside_the_pixel() {
        for spp in [1, 2, 7, 64] {
            let o = pixel_offsets(spp);
            assert_eq!(o.len(), spp as usize);
            assert!(o.iter().all(|&(x, y)| (0.0..1.0).contains(&x) && (0.0..1.0).contains(&y)));
        }
    }
}
