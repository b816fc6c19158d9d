//! Render options, the one pixel loop, the lane-count dispatcher and progress reporting.
//!
//! One sample's trip (pbrt-v4 `RayIntegrator::EvaluatePixelSample`): the pixel loop
//! ([`render_film`] → `render_pixels`) asks the film's [`Sensor`] for the sample's
//! wavelengths and the camera for its ray, the integrator [`Kernel`] for the radiance along it
//! (`whitted.rs` or `path.rs`), and adds the result to the [`Film`] row (`film.rs`).

use std::fmt;
use std::ops::Range;
use std::str::FromStr;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use colorimetry::{SampledSpectrum, SampledWavelengths};
use geometry::{Camera, Ray};
use rayon::prelude::*;

use crate::assembly::RenderScene;
use crate::error::{Error, Result};
use crate::film::{Film, Image, MAX_SPP, ObjectId, Sensor};
use crate::path::PathTracer;
use crate::sampling::{Rng, Sampler, SobolSample};
use crate::spectral::{Lanes, MAX_BINS, SpectralMode};
use crate::whitted::Whitted;

/// Which light transport model renders the image (the selector; [`Integrator`] carries each
/// model's own options).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IntegratorKind {
    /// The paper's model: Whitted ray tracing with Hall's spectral shading.
    WhittedHall,
    /// The physically based spectral path tracer (`docs/path-tracer.md`).
    Path,
}

impl FromStr for IntegratorKind {
    type Err = Error;

    /// `whitted-hall` (also `whitted`, `paper`) or `path`.
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "whitted-hall" | "whitted" | "paper" => Ok(Self::WhittedHall),
            "path" => Ok(Self::Path),
            _ => Err(Error::InvalidOption {
                option: "integrator",
                value: s.to_owned(),
                expected: "whitted-hall or path",
            }),
        }
    }
}

/// The density hero sampling draws wavelengths from (path tracer, `hero:K` only).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WavelengthPdf {
    /// pbrt-v4's and Mitsuba 3's visible-range density p(λ) ∝ sech²(0.0072 (λ − 538)).
    Visible,
    /// p(λ) ∝ S(λ) (x̄ + ȳ + z̄)(λ), S the sum of the scene's light spectra (each at unit
    /// luminance), mixed with 10 % of the visible density: follows the lines of spiky lamps.
    Illuminant,
}

impl FromStr for WavelengthPdf {
    type Err = Error;

    /// `visible` or `illuminant`.
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "visible" => Ok(Self::Visible),
            "illuminant" => Ok(Self::Illuminant),
            _ => Err(Error::InvalidOption {
                option: "wavelength pdf",
                value: s.to_owned(),
                expected: "visible or illuminant",
            }),
        }
    }
}

/// The random numbers of the path tracer's samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SamplerKind {
    /// Padded Sobol' points, shuffled and digitally shifted per dimension (the design of
    /// pbrt-v4's `PaddedSobolSampler`): every
    /// power-of-two prefix of a pixel's samples is stratified in each dimension and pair.
    #[default]
    Sobol,
    /// Independent uniform numbers (PCG32 per sample), stratified only over hero wavelengths.
    Independent,
}

impl FromStr for SamplerKind {
    type Err = Error;

    /// `sobol` or `independent`.
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "sobol" => Ok(Self::Sobol),
            "independent" => Ok(Self::Independent),
            _ => Err(Error::InvalidOption { option: "sampler", value: s.to_owned(), expected: "sobol or independent" }),
        }
    }
}

impl fmt::Display for SamplerKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Sobol => "sobol",
            Self::Independent => "independent",
        })
    }
}

/// The ambient term of the paper's model.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Ambient {
    /// No ambient light.
    None,
    /// A constant fraction K_a of the light (the paper's comparison uses 10 %).
    Constant(f32),
    /// The paper's eq. 9: I_a = K_a S̄ Σ_i k_i R_i^n, built from the scene's objects.
    Objects {
        /// K_a, the overall strength.
        k_a: f32,
        /// n, the exponent on each object's reflectance.
        exponent: f32,
    },
}

impl FromStr for Ambient {
    type Err = Error;

    /// `objects`, `objects:K_A`, `constant:K_A` or `none`.
    fn from_str(s: &str) -> Result<Self> {
        let bad = || Error::InvalidOption {
            option: "ambient",
            value: s.to_owned(),
            expected: "objects, objects:K_A, constant:K_A (e.g. constant:0.1) or none",
        };
        let number = |v: &str| v.parse::<f32>().ok().filter(|k| k.is_finite() && *k >= 0.0).ok_or_else(bad);
        match s.split_once(':') {
            None if s == "objects" => Ok(Self::Objects { k_a: DEFAULT_K_A, exponent: 1.0 }),
            None if s == "none" => Ok(Self::None),
            Some(("objects", k)) => Ok(Self::Objects { k_a: number(k)?, exponent: 1.0 }),
            Some(("constant", k)) => Ok(Self::Constant(number(k)?)),
            _ => Err(bad()),
        }
    }
}

/// Default K_a: the 10 % the paper uses for its constant-ambient comparison, so the two
/// ambient modes have the same overall strength and differ only in colour.
pub const DEFAULT_K_A: f32 = 0.1;

/// Options of the paper's model (`whitted-hall`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WhittedOptions {
    /// Recursion limit (the paper uses 20); `None` takes the scene's `max_depth` or 20.
    pub max_depth: Option<u32>,
    /// Branches whose coefficient product falls below this are not traced (0 traces the
    /// full tree up to the depth limit).
    pub min_weight: f32,
    /// Bouguer–Beer absorption inside transparent objects (eq. 8).
    pub absorption: bool,
    /// Ambient term.
    pub ambient: Ambient,
}

impl Default for WhittedOptions {
    fn default() -> Self {
        Self {
            max_depth: None,
            min_weight: 1e-3,
            absorption: true,
            ambient: Ambient::Objects { k_a: DEFAULT_K_A, exponent: 1.0 },
        }
    }
}

/// Options of the path tracer (`path`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PathOptions {
    /// Bounce limit; `None` takes the scene's `max_depth` or 64.
    pub max_depth: Option<u32>,
    /// Bounces after which Russian roulette may end a path; `None` takes the scene's
    /// `rr_depth` setting or 3.
    pub rr_depth: Option<u32>,
    /// With `hero:K`: the wavelength density.
    pub wavelength_pdf: WavelengthPdf,
    /// The samples' random numbers.
    pub sampler: SamplerKind,
}

impl Default for PathOptions {
    fn default() -> Self {
        Self {
            max_depth: None,
            rr_depth: None,
            wavelength_pdf: WavelengthPdf::Illuminant,
            sampler: SamplerKind::default(),
        }
    }
}

/// The light transport model with its options: only meaningful combinations can be written.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Integrator {
    /// The paper's model.
    WhittedHall(WhittedOptions),
    /// The physically based path tracer.
    Path(PathOptions),
}

impl Integrator {
    /// Which model this is.
    pub fn kind(&self) -> IntegratorKind {
        match self {
            Self::WhittedHall(_) => IntegratorKind::WhittedHall,
            Self::Path(_) => IntegratorKind::Path,
        }
    }
}

impl Default for Integrator {
    fn default() -> Self {
        Self::WhittedHall(WhittedOptions::default())
    }
}

/// Everything that controls a render besides the scene.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderOptions {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Light transport model and its options.
    pub integrator: Integrator,
    /// Spectral sampling strategy.
    pub spectral: SpectralMode,
    /// Samples per pixel (deterministic sub-pixel positions for the paper's model).
    pub spp: u32,
    /// Render only these sample indices of the `spp` (a part of a render split across
    /// processes; `None`: all). The parts' films merge into exactly the whole render's.
    pub samples: Option<Range<u32>>,
    /// Seed of the random numbers (each sample's stream is derived from the seed, the pixel
    /// and the sample index, so images do not depend on the thread count).
    pub seed: u64,
    /// Stop once this much time has passed: samples are then taken in passes of one per
    /// pixel, and rows not yet started are skipped once the time is up, so the limit is kept
    /// to within about one row's time after the first pass (each pixel averages the samples it
    /// got; [`RenderStats::spp`] says the fewest).
    pub time_limit: Option<Duration>,
    /// Worker threads (`None`: all cores).
    pub threads: Option<usize>,
    /// Keep each pixel's radiance at the wavelengths rendered ([`Image::spectral`], written by
    /// [`Image::write_spectral_exr`]); needs fixed wavelengths (`bins:N`, or `auto` choosing
    /// bins).
    pub spectral_film: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            width: crate::DEFAULT_RESOLUTION.0,
            height: crate::DEFAULT_RESOLUTION.1,
            integrator: Integrator::default(),
            spectral: SpectralMode::Auto,
            spp: 1,
            samples: None,
            seed: 0,
            time_limit: None,
            threads: None,
            spectral_film: false,
        }
    }
}

impl RenderOptions {
    /// Check the image size, the spectral film's size and the thread count against
    /// [`MAX_SIDE`], [`MAX_PIXELS`], [`MAX_SPECTRAL_SAMPLES`] and [`MAX_THREADS`] (before
    /// anything is allocated; [`render_film`] calls it too).
    pub fn check_limits(&self) -> Result<()> {
        for (side, value) in [("width", self.width), ("height", self.height)] {
            if value == 0 || value > MAX_SIDE {
                return Err(Error::SideOutOfRange { side, value });
            }
        }
        let pixels = u64::from(self.width) * u64::from(self.height);
        if pixels > MAX_PIXELS {
            return Err(Error::TooManyPixels { width: self.width, height: self.height });
        }
        if self.spectral_film {
            // `auto` resolves during the render: count the most wavelengths it may choose.
            let wavelengths = match self.spectral {
                SpectralMode::Bins(n) => n as u64,
                _ => MAX_BINS as u64,
            };
            if pixels * wavelengths > MAX_SPECTRAL_SAMPLES {
                return Err(Error::TooManySpectralSamples { pixels, wavelengths });
            }
        }
        if let Some(threads) = self.threads
            && !(1..=MAX_THREADS).contains(&threads)
        {
            return Err(Error::ThreadsOutOfRange(threads));
        }
        Ok(())
    }

    /// These options with the paper's model and its options changed by `f` (the defaults if
    /// they held the path tracer's).
    pub fn whitted(self, f: impl FnOnce(&mut WhittedOptions)) -> Self {
        let mut o = match self.integrator {
            Integrator::WhittedHall(o) => o,
            Integrator::Path(_) => WhittedOptions::default(),
        };
        f(&mut o);
        Self { integrator: Integrator::WhittedHall(o), ..self }
    }

    /// These options with the path tracer and its options changed by `f` (the defaults if they
    /// held the paper's model's).
    pub fn path(self, f: impl FnOnce(&mut PathOptions)) -> Self {
        let mut o = match self.integrator {
            Integrator::Path(o) => o,
            Integrator::WhittedHall(_) => PathOptions::default(),
        };
        f(&mut o);
        Self { integrator: Integrator::Path(o), ..self }
    }

    /// Every option that changes the film, besides the seed, the sample range and the image
    /// size (which a film file records on their own), as one canonical line: the integrator
    /// and its options, the spectral mode asked for, the samples per pixel and whether
    /// per-wavelength sums are kept. Threads and the time limit change no sum and are left
    /// out. Film files store it and its digest, and parts merge only when it is the same.
    pub fn result_key(&self) -> String {
        let integrator = match &self.integrator {
            Integrator::WhittedHall(w) => format!(
                "whitted-hall max_depth={:?} min_weight={:?} absorption={} ambient={:?}",
                w.max_depth, w.min_weight, w.absorption, w.ambient
            ),
            Integrator::Path(p) => {
                format!(
                    "path max_depth={:?} rr_depth={:?} wavelength_pdf={:?} sampler={}",
                    p.max_depth, p.rr_depth, p.wavelength_pdf, p.sampler
                )
            }
        };
        format!("{integrator} spectral={} spp={} spectral_film={}", self.spectral, self.spp, self.spectral_film)
    }
}

/// The sample indices of part `k` of `m` (k = 1..=m, as a Slurm array task id) of a render of
/// `spp` samples per pixel: `⌊(k−1)·spp/m⌋ .. ⌊k·spp/m⌋`, so the parts are disjoint, cover
/// `0..spp` and differ in size by at most one.
pub fn part_samples(k: u32, m: u32, spp: u32) -> Result<Range<u32>> {
    if m == 0 || k == 0 || k > m {
        return Err(Error::InvalidOption {
            option: "part",
            value: format!("{k}/{m}"),
            expected: "K/M with 1 <= K <= M (e.g. 3/8)",
        });
    }
    if m > spp {
        return Err(Error::InvalidOption {
            option: "part",
            value: format!("{k}/{m} of {spp} spp"),
            expected: "at most as many parts as samples per pixel",
        });
    }
    let at = |i: u32| (u64::from(i) * u64::from(spp) / u64::from(m)) as u32;
    Ok(at(k - 1)..at(k))
}

/// Longest image side in pixels.
pub const MAX_SIDE: u32 = 65_536;

/// Most pixels in one image: 2²⁷ (e.g. 16384 × 8192). Measured peak memory of an RGB render
/// is 106 bytes per pixel (112 MB at 1000², 33 MB at 500²; `/usr/bin/time -v spectrace render
/// --width 1000 --height 1000 --spectral rgb`), 80 of them the film's fixed-point sums, so
/// about 14 GB at the limit; `--width 65536 --height 65536` (2³² pixels) aborted allocating.
pub const MAX_PIXELS: u64 = 1 << 27;

/// Most pixel × wavelength samples of a spectral film: 2²⁸. Measured 20.6 bytes per sample at
/// peak (1.97 GB for 1000² × 95 wavelengths, 0.50 GB for 500² × 95: a 16-byte sum and the f32
/// image value), so about 5.5 GB at the limit; e.g. 1680² pixels at 95 wavelengths.
pub const MAX_SPECTRAL_SAMPLES: u64 = 1 << 28;

/// Most worker threads: each reserves a stack; `--threads 100000` hung creating the pool.
pub const MAX_THREADS: usize = 1024;

/// Progress of a running render, reported after each finished row.
#[derive(Debug, Clone, Copy)]
pub struct Progress {
    /// Rows finished (over all passes).
    pub rows_done: u64,
    /// Rows to render (image rows × passes: up to 2¹⁶ × 2²⁰ with a time limit).
    pub rows_total: u64,
    /// Rays traced so far (camera, secondary and shadow rays).
    pub rays: u64,
    /// Time since the render started.
    pub elapsed: Duration,
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
    /// Samples whose value was NaN or infinite (added as black; must be 0).
    pub nonfinite_samples: u64,
    /// Fewest samples any pixel got (fewer than asked if a time limit stopped the render).
    pub spp: u32,
    /// Samples whose value was beyond the film's range (2⁴²) and was clamped (should be 0).
    pub clamped_samples: u64,
}

/// Per-thread counters.
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct RayCount {
    /// Every ray traced.
    pub(crate) rays: u64,
    /// Those of them that were shadow rays ([`RenderStats::shadow_rays`]).
    pub(crate) shadow: u64,
}

impl RayCount {
    /// Count one shadow ray (it is a ray too).
    #[inline]
    pub(crate) fn shadow_ray(&mut self) {
        self.rays += 1;
        self.shadow += 1;
    }
}

/// What an integrator returns for one camera sample.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Radiance<const N: usize> {
    /// Radiance at the sample's lanes.
    pub(crate) l: SampledSpectrum<N>,
    /// What the camera ray hit first.
    pub(crate) first: ObjectId,
    /// With fixed lanes, the one lane a dispersive path kept (see [`Sensor::to_xyz`]).
    pub(crate) lane: Option<usize>,
}

/// An integrator as the pixel loop sees it: radiance along a camera ray.
pub(crate) trait Kernel<const N: usize>: Sync {
    /// Whether samples are random (camera jitter and hero wavelengths drawn from the sample's
    /// own stream); otherwise sub-pixel positions are the deterministic R2 sequence.
    const RANDOM: bool;

    /// Radiance arriving along `ray` at `lambda` (which a dispersive path may narrow).
    fn li(
        &self,
        ray: &Ray,
        lambda: &mut SampledWavelengths<N>,
        sensor: &Sensor<N>,
        sampler: &mut Sampler,
        count: &mut RayCount,
    ) -> Radiance<N>;
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

/// Render `scene`. `progress` is called from worker threads after each row; setting `cancel`
/// stops the render at the next row and returns [`Error::Cancelled`].
pub fn render(
    scene: &RenderScene,
    options: &RenderOptions,
    progress: &(dyn Fn(Progress) + Sync),
    cancel: &AtomicBool,
) -> Result<(Image, RenderStats)> {
    let (film, stats) = render_film(scene, options, progress, cancel)?;
    Ok((film.to_image(), stats))
}

/// Render `scene` (or the sample range `options.samples` of it) into a [`Film`], which can be
/// merged with the films of the other ranges.
pub fn render_film(
    scene: &RenderScene,
    options: &RenderOptions,
    progress: &(dyn Fn(Progress) + Sync),
    cancel: &AtomicBool,
) -> Result<(Film, RenderStats)> {
    render_film_with(scene, options, RenderControl { progress, cancel, resume: None, checkpoint: None, spectral: None })
}

/// [`render_film`] with checkpoints and resumption ([`RenderControl`]).
pub fn render_film_with(
    scene: &RenderScene,
    options: &RenderOptions,
    control: RenderControl<'_>,
) -> Result<(Film, RenderStats)> {
    let RenderControl { progress, cancel, resume, checkpoint, spectral } = control;
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
    if let Integrator::WhittedHall(w) = &options.integrator
        && !(w.min_weight.is_finite() && w.min_weight >= 0.0)
    {
        return Err(Error::OutOfRange { what: "min weight", value: w.min_weight.into(), range: ">= 0" });
    }
    let spectral = match spectral {
        Some(s) => s,
        None => resolved_spectral(scene, options)?,
    };
    if options.spectral_film && !matches!(spectral, SpectralMode::Bins(_)) {
        return Err(Error::InvalidOption {
            option: "spectral mode for a spectral image",
            value: spectral.to_string(),
            expected: "bins:N (fixed wavelengths; bins:95 is the 5 nm grid)",
        });
    }
    let lanes = lane_count(spectral)?;
    let pool = thread_pool(options)?;
    let job = RenderJob { scene, options, spectral, samples, progress, cancel, resume, checkpoint };
    pool.install(|| with_lanes(lanes, job))
}

/// The spectral mode a render of `scene` with `options` uses: `auto` resolved, hero refused
/// for the paper's model.
pub fn resolved_spectral(scene: &RenderScene, options: &RenderOptions) -> Result<SpectralMode> {
    Ok(match options.spectral {
        SpectralMode::Auto => crate::auto_decision(scene, options)?.spectral,
        SpectralMode::Hero { .. } if options.integrator.kind() == IntegratorKind::WhittedHall => {
            return Err(Error::InvalidOption {
                option: "spectral mode",
                value: options.spectral.to_string(),
                expected: "rgb, bins:N or auto for the whitted-hall integrator (hero sampling needs a Monte Carlo integrator)",
            });
        }
        mode => mode,
    })
}

/// Lane counts the renderer is compiled for, smallest first ([`with_lanes`] has one arm each).
const LANE_COUNTS: [usize; 7] = [4, 8, 16, 32, 48, 64, MAX_BINS];

/// The lanes a spectral strategy needs.
pub(crate) fn lane_count(spectral: SpectralMode) -> Result<usize> {
    let bad = || Error::InvalidOption {
        option: "spectral mode",
        value: spectral.to_string(),
        expected: "rgb, bins:N (2..=96), hero:4, hero:8 or auto",
    };
    match spectral {
        SpectralMode::Rgb => Ok(4),
        SpectralMode::Bins(n @ 2..=MAX_BINS) => LANE_COUNTS.iter().copied().find(|&lanes| n <= lanes).ok_or_else(bad),
        SpectralMode::Hero { count: count @ (4 | 8) } => Ok(count),
        SpectralMode::Bins(_) | SpectralMode::Hero { .. } | SpectralMode::Auto => Err(bad()),
    }
}

/// Work generic over the lane count, for [`with_lanes`].
pub(crate) trait LaneJob {
    type Output;
    fn run<const N: usize>(self) -> Self::Output;
}

/// The one place that turns a run-time lane count (one of [`LANE_COUNTS`], from
/// [`lane_count`]) into a compile-time one.
pub(crate) fn with_lanes<J: LaneJob>(lanes: usize, job: J) -> J::Output {
    debug_assert!(LANE_COUNTS.contains(&lanes), "{lanes} lanes");
    match lanes {
        4 => job.run::<4>(),
        8 => job.run::<8>(),
        16 => job.run::<16>(),
        32 => job.run::<32>(),
        48 => job.run::<48>(),
        64 => job.run::<64>(),
        _ => job.run::<MAX_BINS>(),
    }
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
            SpectralMode::Bins(n) => Lanes::bins(n, &crate::scene_white(self.scene)),
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
        }
    }
}

/// The pixel loop: samples `job.samples` of every pixel, in passes over the image (one pass
/// without a time limit), rows in parallel. The random numbers of sample i of pixel p depend
/// only on (seed, p, i) and the film's sums are exact, so the image is the same for any thread
/// count, pass size or split into sample ranges.
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
            if (film.width, film.height) != (width, height) || film.wavelengths != wavelengths {
                return Err(Error::InvalidOption {
                    option: "film to resume",
                    value: format!("{}x{} with {} wavelengths", film.width, film.height, film.wavelengths.len()),
                    expected: "a film of the same size and wavelengths as the render",
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
        None => Film::new(width, height, wavelengths),
    };
    let sampler = PixelSampler::new(kernel, sensor, camera, options);
    // With a time limit, passes of one sample each spread the samples taken evenly over the
    // image when it stops, and every row of a pass is short whatever the spp. The first pass
    // ignores the limit, so every pixel gets at least one sample. Checkpoints are taken
    // between passes, so they also want short passes.
    let short_passes = options.time_limit.is_some() || checkpoint.is_some();
    let pass_size = if short_passes { 1 } else { samples.len() as u32 };
    let passes = (samples.len() as u32).div_ceil(pass_size);
    // A resumed film: skip the passes every pixel has done. Each pixel holds the first
    // `count` samples of the range and continues after them (rows a time limit skipped hold
    // one fewer than the others).
    let first_pass = film.min_sample_count() / pass_size;
    let rows_total = u64::from(height) * u64::from(passes - first_pass);
    let mut last_checkpoint = Instant::now();
    let start = Instant::now();
    let out_of_time = || options.time_limit.is_some_and(|limit| start.elapsed() >= limit);
    let rays = AtomicU64::new(0);
    let shadow_rays = AtomicU64::new(0);
    let rows_done = AtomicU64::new(0);
    for pass in first_pass..passes {
        let first_sample = samples.start + pass * pass_size;
        let last_sample = (first_sample + pass_size).min(samples.end);
        let counts: Vec<(u64, u64)> = film
            .rows_mut()
            .enumerate()
            .map(|(y, mut row)| -> Result<(u64, u64)> {
                if cancel.load(Ordering::Relaxed) {
                    return Err(Error::Cancelled);
                }
                if pass > 0 && out_of_time() {
                    return Ok((0, 0));
                }
                let mut count = RayCount::default();
                let mut fixed = Sampler::Independent(Rng::new(0, 0, 0));
                for x in 0..width as usize {
                    let pixel = y as u64 * u64::from(width) + x as u64;
                    let rotation = sampler.rotation(pixel);
                    let next = samples.start + row.count(x);
                    for i in first_sample.max(next)..last_sample {
                        let (r, lambda) = sampler.sample(x, y, rotation, i, &mut fixed, &mut count);
                        if i == 0 {
                            row.set_first_hit(x, r.first);
                        }
                        let (xyz, values) = sensor.to_xyz(&r.l, &lambda, r.lane);
                        row.add_sample(x, xyz, &values);
                    }
                }
                let rays_now = rays.fetch_add(count.rays, Ordering::Relaxed) + count.rays;
                shadow_rays.fetch_add(count.shadow, Ordering::Relaxed);
                let rows = rows_done.fetch_add(1, Ordering::Relaxed) + 1;
                progress(Progress { rows_done: rows, rows_total, rays: rays_now, elapsed: start.elapsed() });
                Ok((row.nonfinite, row.clamped))
            })
            .collect::<Result<_>>()?;
        for (nonfinite, clamped) in counts {
            film.add_counts(nonfinite, clamped);
        }
        if first_sample == 0 {
            film.set_has_first_sample();
        }
        if out_of_time() {
            break;
        }
        if let Some(c) = &checkpoint
            && pass + 1 < passes
            && last_checkpoint.elapsed() >= c.every
        {
            (c.write)(&film)?;
            last_checkpoint = Instant::now();
        }
    }
    let stats = RenderStats {
        spectral,
        rays: rays.into_inner(),
        shadow_rays: shadow_rays.into_inner(),
        elapsed: start.elapsed(),
        nonfinite_samples: film.nonfinite_samples(),
        spp: film.min_sample_count(),
        clamped_samples: film.clamped_samples(),
    };
    Ok((film, stats))
}

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
    pub(crate) fn sample(
        &self,
        x: usize,
        y: usize,
        rotation: f32,
        i: u32,
        fixed: &mut Sampler,
        count: &mut RayCount,
    ) -> (Radiance<N>, SampledWavelengths<N>) {
        let (width, height) = (self.width, self.height);
        let mut own;
        let (sampler, mut lambda, ray) = if K::RANDOM {
            let pixel = y as u64 * u64::from(width) + x as u64;
            // The camera's numbers (block 0 of Sobol' points): first the hero wavelengths, then
            // the position in the pixel; both are drawn for fixed lanes too.
            let u = if self.sobol {
                own = Sampler::Sobol(SobolSample::new(self.seed, pixel, i));
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
        let r = self.kernel.li(&ray, &mut lambda, self.sensor, sampler, count);
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
    fn ambient_and_integrator_options_parse() {
        assert_eq!("constant:0.1".parse::<Ambient>().unwrap(), Ambient::Constant(0.1));
        assert_eq!("objects".parse::<Ambient>().unwrap(), Ambient::Objects { k_a: DEFAULT_K_A, exponent: 1.0 });
        assert_eq!("none".parse::<Ambient>().unwrap(), Ambient::None);
        assert!(matches!("constant:-1".parse::<Ambient>(), Err(Error::InvalidOption { .. })));
        assert!(matches!("sky".parse::<Ambient>(), Err(Error::InvalidOption { .. })));
        assert_eq!("whitted-hall".parse::<IntegratorKind>().unwrap(), IntegratorKind::WhittedHall);
        assert_eq!("path".parse::<IntegratorKind>().unwrap(), IntegratorKind::Path);
        assert!("bdpt".parse::<IntegratorKind>().is_err());
        assert_eq!("visible".parse::<WavelengthPdf>().unwrap(), WavelengthPdf::Visible);
        assert!("uniform".parse::<WavelengthPdf>().is_err());
    }

    #[test]
    fn pixel_offsets_stay_inside_the_pixel() {
        for spp in [1, 2, 7, 64] {
            let o = pixel_offsets(spp);
            assert_eq!(o.len(), spp as usize);
            assert!(o.iter().all(|&(x, y)| (0.0..1.0).contains(&x) && (0.0..1.0).contains(&y)));
        }
    }

    #[test]
    fn every_spectral_mode_gets_enough_lanes() {
        assert_eq!(lane_count(SpectralMode::Rgb).unwrap(), 4);
        assert_eq!(lane_count(SpectralMode::Bins(5)).unwrap(), 8);
        assert_eq!(lane_count(SpectralMode::Bins(95)).unwrap(), 96);
        assert_eq!(lane_count(SpectralMode::Hero { count: 8 }).unwrap(), 8);
        assert!(lane_count(SpectralMode::Hero { count: 5 }).is_err());
        assert!(lane_count(SpectralMode::Bins(97)).is_err());
        // bins:1 and bins:0 reached an assert in the lane constructor: an error now.
        assert!(lane_count(SpectralMode::Bins(1)).is_err() && lane_count(SpectralMode::Bins(0)).is_err());
    }
}
