//! Render options, the parallel pixel loop and its progress reporting.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use rayon::prelude::*;

use crate::assembly::RenderScene;
use crate::error::{Error, Result};
use crate::film::Image;
use crate::spectral::{Lanes, SpectralMode};
use crate::whitted::{RayCount, Whitted};

/// Which light transport model renders the image.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IntegratorKind {
    /// The paper's model: Whitted ray tracing with Hall's spectral shading.
    WhittedHall,
    /// The physically based spectral path tracer (`docs/path-tracer.md`).
    Path,
}

impl IntegratorKind {
    /// Parse an `--integrator` value.
    pub fn parse(s: &str) -> Result<Self> {
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

impl WavelengthPdf {
    /// Parse `visible` or `illuminant`.
    pub fn parse(s: &str) -> Result<Self> {
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

impl Ambient {
    /// Parse `objects`, `objects:K_A`, `constant:K_A` or `none`.
    pub fn parse(s: &str) -> Result<Self> {
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

/// Everything that controls a render besides the scene.
#[derive(Debug, Clone)]
pub struct RenderOptions {
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Light transport model.
    pub integrator: IntegratorKind,
    /// Spectral sampling strategy.
    pub spectral: SpectralMode,
    /// Samples per pixel (stratified, deterministic for the paper's model).
    pub spp: u32,
    /// Seed of the path tracer's random numbers (each sample's stream is derived from the
    /// seed, the pixel and the sample index, so images do not depend on the thread count).
    pub seed: u64,
    /// Path tracer: stop after the pass during which this much time has passed (the image
    /// averages the samples taken; [`RenderStats::spp`] says how many).
    pub time_limit: Option<Duration>,
    /// Path tracer with `hero:K`: the wavelength density.
    pub wavelength_pdf: WavelengthPdf,
    /// Recursion limit (the paper uses 20); `None` takes the scene's `max_depth` or 20.
    pub max_depth: Option<u32>,
    /// Branches whose coefficient product falls below this are not traced (0 traces the
    /// full tree up to the depth limit).
    pub min_weight: f32,
    /// Bouguer–Beer absorption inside transparent objects (eq. 8).
    pub absorption: bool,
    /// Ambient term.
    pub ambient: Ambient,
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
            integrator: IntegratorKind::WhittedHall,
            spectral: SpectralMode::Auto,
            spp: 1,
            seed: 0,
            time_limit: None,
            wavelength_pdf: WavelengthPdf::Illuminant,
            max_depth: None,
            min_weight: 1e-3,
            absorption: true,
            ambient: Ambient::Objects { k_a: DEFAULT_K_A, exponent: 1.0 },
            threads: None,
            spectral_film: false,
        }
    }
}

/// Progress of a running render, reported after each finished row.
#[derive(Debug, Clone, Copy)]
pub struct Progress {
    /// Rows finished.
    pub rows_done: u32,
    /// Rows in the image.
    pub rows_total: u32,
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
    /// Wall time of the pixel loop (scene assembly excluded).
    pub elapsed: Duration,
    /// Samples whose value was NaN or infinite (replaced by black; must be 0).
    pub nonfinite_samples: u64,
    /// Samples per pixel actually taken (fewer than asked if a time limit stopped the render).
    pub spp: u32,
}

/// Render `scene`. `progress` is called from worker threads after each row; setting `cancel`
/// stops the render at the next row and returns [`Error::Cancelled`].
pub fn render(
    scene: &RenderScene,
    options: &RenderOptions,
    progress: &(dyn Fn(Progress) + Sync),
    cancel: &AtomicBool,
) -> Result<(Image, RenderStats)> {
    if options.width == 0 || options.height == 0 || options.width > 65_536 || options.height > 65_536 {
        return Err(Error::OutOfRange {
            what: "image size",
            value: f64::from(options.width.max(options.height)),
            range: "1..=65536 pixels per side",
        });
    }
    if options.spp == 0 || options.spp > 1 << 20 {
        return Err(Error::OutOfRange { what: "spp", value: f64::from(options.spp), range: "1..=1048576" });
    }
    if !(options.min_weight.is_finite() && options.min_weight >= 0.0) {
        return Err(Error::OutOfRange { what: "min weight", value: options.min_weight.into(), range: ">= 0" });
    }
    if options.integrator == IntegratorKind::Path {
        return render_path(scene, options, progress, cancel);
    }
    let spectral = match options.spectral {
        SpectralMode::Auto => crate::choose_auto(scene, options.integrator),
        SpectralMode::Hero { .. } => {
            return Err(Error::InvalidOption {
                option: "spectral mode",
                value: options.spectral.to_string(),
                expected: "rgb, bins:N or auto for the whitted-hall integrator (hero sampling needs a Monte Carlo integrator)",
            });
        }
        mode => mode,
    };
    check_spectral_film(options, spectral)?;
    let pool = thread_pool(options)?;
    let white = crate::scene_white(scene);
    let (image, rays, elapsed) = pool.install(|| match spectral {
        SpectralMode::Rgb => run::<4>(scene, options, Lanes::rgb(), progress, cancel),
        SpectralMode::Bins(n) if n <= 4 => run::<4>(scene, options, Lanes::bins(n, &white), progress, cancel),
        SpectralMode::Bins(n) if n <= 8 => run::<8>(scene, options, Lanes::bins(n, &white), progress, cancel),
        SpectralMode::Bins(n) if n <= 16 => run::<16>(scene, options, Lanes::bins(n, &white), progress, cancel),
        SpectralMode::Bins(n) if n <= 32 => run::<32>(scene, options, Lanes::bins(n, &white), progress, cancel),
        SpectralMode::Bins(n) if n <= 48 => run::<48>(scene, options, Lanes::bins(n, &white), progress, cancel),
        SpectralMode::Bins(n) if n <= 64 => run::<64>(scene, options, Lanes::bins(n, &white), progress, cancel),
        SpectralMode::Bins(n) => {
            run::<{ crate::spectral::MAX_BINS }>(scene, options, Lanes::bins(n, &white), progress, cancel)
        }
        SpectralMode::Hero { .. } | SpectralMode::Auto => unreachable!("resolved above"),
    })?;
    let nonfinite_samples = image.nonfinite_samples();
    Ok((image, RenderStats { spectral, rays, elapsed, nonfinite_samples, spp: options.spp }))
}

/// The path tracer's dispatch: lane count from the spectral strategy.
fn render_path(
    scene: &RenderScene,
    options: &RenderOptions,
    progress: &(dyn Fn(Progress) + Sync),
    cancel: &AtomicBool,
) -> Result<(Image, RenderStats)> {
    use crate::path::{LaneMode, render_path as run_path};
    let spectral = match options.spectral {
        SpectralMode::Auto => crate::choose_auto(scene, options.integrator),
        mode => mode,
    };
    check_spectral_film(options, spectral)?;
    let pool = thread_pool(options)?;
    let pdf = options.wavelength_pdf;
    let white = crate::scene_white(scene);
    let out = pool.install(|| match spectral {
        SpectralMode::Rgb => run_path::<4>(scene, options, LaneMode::Fixed(Lanes::rgb()), progress, cancel),
        SpectralMode::Bins(n) if n <= 4 => {
            run_path::<4>(scene, options, LaneMode::Fixed(Lanes::bins(n, &white)), progress, cancel)
        }
        SpectralMode::Bins(n) if n <= 8 => {
            run_path::<8>(scene, options, LaneMode::Fixed(Lanes::bins(n, &white)), progress, cancel)
        }
        SpectralMode::Bins(n) if n <= 16 => {
            run_path::<16>(scene, options, LaneMode::Fixed(Lanes::bins(n, &white)), progress, cancel)
        }
        SpectralMode::Bins(n) if n <= 32 => {
            run_path::<32>(scene, options, LaneMode::Fixed(Lanes::bins(n, &white)), progress, cancel)
        }
        SpectralMode::Bins(n) if n <= 48 => {
            run_path::<48>(scene, options, LaneMode::Fixed(Lanes::bins(n, &white)), progress, cancel)
        }
        SpectralMode::Bins(n) if n <= 64 => {
            run_path::<64>(scene, options, LaneMode::Fixed(Lanes::bins(n, &white)), progress, cancel)
        }
        SpectralMode::Bins(n) if n <= crate::spectral::MAX_BINS => run_path::<{ crate::spectral::MAX_BINS }>(
            scene,
            options,
            LaneMode::Fixed(Lanes::bins(n, &white)),
            progress,
            cancel,
        ),
        SpectralMode::Hero { count: 4 } => run_path::<4>(scene, options, LaneMode::Hero(pdf), progress, cancel),
        SpectralMode::Hero { count: 8 } => run_path::<8>(scene, options, LaneMode::Hero(pdf), progress, cancel),
        other => Err(Error::InvalidOption {
            option: "spectral mode",
            value: other.to_string(),
            expected: "rgb, bins:N (2..=96), hero:4, hero:8 or auto",
        }),
    })?;
    let nonfinite_samples = out.image.nonfinite_samples();
    Ok((out.image, RenderStats { spectral, rays: out.rays, elapsed: out.elapsed, nonfinite_samples, spp: out.spp }))
}

/// A spectral film stores radiance at fixed wavelengths: RGB has none, and hero wavelengths
/// differ from sample to sample.
fn check_spectral_film(options: &RenderOptions, spectral: SpectralMode) -> Result<()> {
    if options.spectral_film && !matches!(spectral, SpectralMode::Bins(_)) {
        return Err(Error::InvalidOption {
            option: "spectral mode for a spectral image",
            value: spectral.to_string(),
            expected: "bins:N (fixed wavelengths; bins:95 is the 5 nm grid)",
        });
    }
    Ok(())
}

fn thread_pool(options: &RenderOptions) -> Result<rayon::ThreadPool> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(n) = options.threads {
        builder = builder.num_threads(n.max(1));
    }
    builder.build().map_err(|e| Error::ThreadPool(e.to_string()))
}

fn run<const N: usize>(
    scene: &RenderScene,
    options: &RenderOptions,
    lanes: Lanes<N>,
    progress: &(dyn Fn(Progress) + Sync),
    cancel: &AtomicBool,
) -> Result<(Image, u64, Duration)> {
    let (width, height) = (options.width, options.height);
    let camera = scene.camera(width, height)?;
    let whitted = Whitted::<N>::new(scene, &lanes, options);
    let start = Instant::now();
    let rays = AtomicU64::new(0);
    let rows_done = AtomicU64::new(0);
    let offsets = pixel_offsets(options.spp);
    let inv_spp = 1.0 / options.spp as f32;
    let mut image = Image::new(width, height);
    let mut film = SpectralRows::new(options.spectral_film, &lanes, width, height);
    let film_lanes = film.lanes();
    image.rows_mut().zip(film.rows_mut()).enumerate().try_for_each(|(y, ((row, ids), spectral))| -> Result<()> {
        if cancel.load(Ordering::Relaxed) {
            return Err(Error::Cancelled);
        }
        let mut count = RayCount::default();
        for (x, (pixel, id)) in row.iter_mut().zip(ids.iter_mut()).enumerate() {
            let mut xyz = [0.0f32; 3];
            for (i, &(dx, dy)) in offsets.iter().enumerate() {
                let ray = camera.generate_ray(x as f32 + dx, y as f32 + dy, width, height);
                let (radiance, object) = whitted.trace_camera_ray(&ray, &mut count);
                if i == 0 {
                    *id = object;
                }
                let s = lanes.xyz(&radiance.0);
                for c in 0..3 {
                    xyz[c] += s[c] * inv_spp;
                }
                SpectralRows::add(spectral, x, film_lanes, &radiance.0);
            }
            *pixel = xyz;
        }
        let rays_now = rays.fetch_add(count.rays, Ordering::Relaxed) + count.rays;
        let done = rows_done.fetch_add(1, Ordering::Relaxed) + 1;
        progress(Progress { rows_done: done as u32, rows_total: height, rays: rays_now, elapsed: start.elapsed() });
        Ok(())
    })?;
    film.attach(&mut image, 1.0 / f64::from(options.spp));
    image.sanitize();
    Ok((image, rays.into_inner(), start.elapsed()))
}

/// The spectral film while rendering: per-pixel sums of lane radiance in f64, one chunk per
/// image row. Without a film each row gets an empty chunk (`add` then does nothing).
pub(crate) struct SpectralRows {
    wavelengths: Vec<f32>,
    sums: Vec<f64>,
    row_len: usize,
    height: usize,
}

impl SpectralRows {
    pub(crate) fn new<const N: usize>(keep: bool, lanes: &Lanes<N>, width: u32, height: u32) -> Self {
        let wavelengths = if keep && !lanes.rgb { lanes.lambda[..lanes.active()].to_vec() } else { Vec::new() };
        let row_len = width as usize * wavelengths.len();
        Self { sums: vec![0.0; row_len * height as usize], wavelengths, row_len, height: height as usize }
    }

    /// No film: empty row chunks.
    pub(crate) fn none(height: u32) -> Self {
        Self { wavelengths: Vec::new(), sums: Vec::new(), row_len: 0, height: height as usize }
    }

    /// Wavelengths per pixel (0 without a film).
    pub(crate) fn lanes(&self) -> usize {
        self.wavelengths.len()
    }

    /// One mutable chunk per image row (empty chunks without a film, so the zip with the
    /// image's rows stays aligned).
    pub(crate) fn rows_mut(&mut self) -> impl IndexedParallelIterator<Item = &mut [f64]> + '_ {
        if self.row_len == 0 {
            rayon::iter::Either::Left((0..self.height).into_par_iter().map(|_| -> &mut [f64] { &mut [] }))
        } else {
            rayon::iter::Either::Right(self.sums.par_chunks_mut(self.row_len))
        }
    }

    /// Add the first `lanes` values to pixel `x` of a row chunk (nothing without a film: the
    /// test keeps a render without one at its old speed, measured 2–4 % slower without it).
    #[inline(always)]
    pub(crate) fn add<const N: usize>(row: &mut [f64], x: usize, lanes: usize, values: &[f32; N]) {
        if lanes == 0 {
            return;
        }
        if let Some(pixel) = row.get_mut(x * lanes..(x + 1) * lanes) {
            for (sum, v) in pixel.iter_mut().zip(values) {
                *sum += f64::from(*v);
            }
        }
    }

    /// Store the sums × `scale` (1 / samples per pixel) in the image.
    pub(crate) fn attach(self, image: &mut Image, scale: f64) {
        if self.wavelengths.is_empty() {
            return;
        }
        let values = self.sums.iter().map(|v| (v * scale) as f32).collect();
        image.set_spectral(crate::film::SpectralFilm { wavelengths: self.wavelengths, values });
    }
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

impl Image {
    /// Rows of pixels and of first-hit ids, in parallel (rayon work-stealing, one row a task).
    fn rows_mut(
        &mut self,
    ) -> rayon::iter::Zip<rayon::slice::ChunksMut<'_, [f32; 3]>, rayon::slice::ChunksMut<'_, crate::ObjectId>> {
        let width = self.width() as usize;
        let (pixels, ids) = self.buffers_mut();
        pixels.par_chunks_mut(width).zip(ids.par_chunks_mut(width))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ambient_and_integrator_options_parse() {
        assert_eq!(Ambient::parse("constant:0.1").unwrap(), Ambient::Constant(0.1));
        assert_eq!(Ambient::parse("objects").unwrap(), Ambient::Objects { k_a: DEFAULT_K_A, exponent: 1.0 });
        assert_eq!(Ambient::parse("none").unwrap(), Ambient::None);
        assert!(matches!(Ambient::parse("constant:-1"), Err(Error::InvalidOption { .. })));
        assert!(matches!(Ambient::parse("sky"), Err(Error::InvalidOption { .. })));
        assert_eq!(IntegratorKind::parse("whitted-hall").unwrap(), IntegratorKind::WhittedHall);
        assert_eq!(IntegratorKind::parse("path").unwrap(), IntegratorKind::Path);
        assert!(IntegratorKind::parse("bdpt").is_err());
        assert_eq!(WavelengthPdf::parse("visible").unwrap(), WavelengthPdf::Visible);
        assert!(WavelengthPdf::parse("uniform").is_err());
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
