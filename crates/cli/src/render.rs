//! `spectrace render`: wiring between arguments, the integrator and the terminal.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use anyhow::Context as _;
use indicatif::{ProgressBar, ProgressStyle};
use integrator::{
    Ambient, Display, Integrator, IntegratorKind, OutputPlan, PathOptions, RenderOptions, RenderScene, SamplerKind,
    SpectralMode, WavelengthPdf, WhittedOptions,
};

/// Arguments of `spectrace render`.
#[derive(Debug, Clone, clap::Args)]
pub(crate) struct RenderArgs {
    /// Scene file: a manifest (.json), glTF (.gltf/.glb) or OBJ (.obj). Without it, the
    /// paper's five transparent spheres are rendered.
    scene: Option<PathBuf>,
    /// Output EXR (linear RGB); a display-encoded PNG of the same name is written beside it
    /// [default: render.exr, none when --film is given].
    #[arg(help_heading = "Output", short, long)]
    output: Option<PathBuf>,
    /// Image width in pixels [default: the scene's, else 640].
    #[arg(help_heading = "Output", long)]
    width: Option<u32>,
    /// Image height in pixels [default: the scene's, else 480].
    #[arg(help_heading = "Output", long)]
    height: Option<u32>,
    /// Light transport: `whitted-hall` (the paper's model), `path` (physically based spectral
    /// path tracing) or `auto` (the scene's `settings.integrator`, else path; the paper's scenes
    /// ask for whitted-hall).
    #[arg(help_heading = "Light transport", long, default_value = "auto")]
    integrator: crate::view::IntegratorChoice,
    /// Spectral sampling: `rgb`, `bins:N` (N wavelengths over 360-830 nm; bins:95 = 5 nm),
    /// `hero[:K]` (path tracer: K = 4 or 8 wavelengths drawn per sample) or `auto` (chosen from
    /// the scene's spectra).
    #[arg(help_heading = "Sampling", long, default_value = "auto")]
    spectral: SpectralMode,
    #[command(flatten)]
    sampling: SamplingArgs,
    /// Path tracer with `hero:K`: wavelength density, `illuminant` (follows the lights'
    /// spectra) or `visible` (pbrt-v4's).
    #[arg(help_heading = "Sampling", long, default_value = "illuminant")]
    wavelength_pdf: WavelengthPdf,
    /// Path tracer: the samples' random numbers, `sobol` (padded Sobol' points, shuffled and shifted,
    /// stratified over each pixel's samples) or `independent` (PCG32 per sample) [default:
    /// sobol].
    #[arg(help_heading = "Sampling", long)]
    sampler: Option<SamplerKind>,
    /// Bouguer-Beer absorption inside transparent objects (the paper's eq. 8).
    #[arg(help_heading = "Light transport", long, default_value = "on", value_parser = parse_on_off, action = clap::ArgAction::Set)]
    absorption: bool,
    /// Ambient term: `objects` (the paper's eq. 9), `objects:K_A`, `constant:K_A` or `none`.
    #[arg(help_heading = "Light transport", long, default_value = "objects")]
    ambient: Ambient,
    /// Output display: `srgb` or `paper9300` (the paper's 9300 K monitor, its eq. 4).
    #[arg(help_heading = "Output", long, default_value = "srgb")]
    display: Display,
    /// Maximum recursion depth [default: the scene's `max_depth`, else 20 for whitted-hall (the
    /// paper's value) or 64 for path].
    #[arg(help_heading = "Light transport", long)]
    max_depth: Option<u32>,
    /// Path tracer: bounces before Russian roulette may end a path [default: the scene's
    /// `rr_depth`, else 3].
    #[arg(help_heading = "Light transport", long)]
    rr_depth: Option<u32>,
    /// Photon mapping (`--integrator sppm`): photons per iteration [default: one per pixel].
    #[arg(help_heading = "Light transport", long)]
    photons: Option<u64>,
    /// Photon mapping: the first iteration's gather radius in scene units [default: two pixel
    /// footprints at each visible point]; it shrinks with every iteration.
    #[arg(help_heading = "Light transport", long)]
    radius: Option<f32>,
    /// Skip ray-tree branches whose weight is below this (0 = trace the full tree).
    #[arg(help_heading = "Light transport", long, default_value_t = 1e-3)]
    min_weight: f32,
    /// Worker threads, 1 to 1024 [default: all cores].
    #[arg(help_heading = "Limits", long)]
    threads: Option<usize>,
    /// Also write a spectral OpenEXR (Fichet et al. 2021 layout: one channel `S0.<λ>nm` per
    /// wavelength, relative radiance). Needs fixed wavelengths: `--spectral bins:N`, or `auto`
    /// where it chooses bins.
    #[arg(help_heading = "Output", long, value_name = "FILE.exr")]
    spectral_exr: Option<PathBuf>,
    /// Also write each pixel's estimated colour error as an OpenEXR: ΔE00 per pixel (`deltaE00`)
    /// and per 8×8 tile (`deltaE00.tile`), and the samples taken (`spp`).
    #[arg(help_heading = "Output", long, value_name = "FILE.exr")]
    error_map: Option<PathBuf>,
    /// Also write the luminance (cd/m² with photometric lights) in false colour on a logarithmic scale,
    /// with a legend, as a PNG (Radiance's `falsecolor -log`).
    #[arg(help_heading = "Output", long, value_name = "FILE.png")]
    false_color: Option<PathBuf>,
    /// The false-colour scale's ends in cd/m² [default: the four decades below the power of ten at or
    /// above the image's 99.9th percentile].
    #[arg(help_heading = "Output", long, value_name = "LO,HI", requires = "false_color", value_parser = parse_luminance_range)]
    false_color_range: Option<(f32, f32)>,
    /// No progress bar or notes on stderr.
    #[arg(help_heading = "Output", short, long)]
    quiet: bool,
    #[command(flatten)]
    parts: PartArgs,
    #[command(flatten)]
    load: LoadArgs,
    #[command(flatten)]
    camera: crate::view::CameraArgs,
    #[command(flatten)]
    env: crate::view::EnvArgs,
    #[command(flatten)]
    exposure: crate::view::ExposureArgs,
}

/// How many samples a render takes: exactly `--spp`, or until a target error (docs/defaults.md,
/// "Samples"). Shared by `render` and `info`, which says what a render would stop at.
#[derive(Debug, Clone, clap::Args)]
#[command(next_help_heading = "Sampling")]
pub(crate) struct SamplingArgs {
    /// Samples per pixel, exactly (whitted-hall: deterministic sub-pixel positions; path:
    /// jittered) [default: the path tracer renders to --target-error; whitted-hall takes 1].
    #[arg(long, conflicts_with_all = ["target_error", "max_spp"])]
    spp: Option<u32>,
    /// Path tracer: take samples until every 8×8-pixel tile's estimated mean colour error
    /// (CIEDE2000 against the converged image, as the PNG shows it) is at most this [default: 1,
    /// when --spp is not given].
    #[arg(long, value_name = "DELTA_E00")]
    target_error: Option<f32>,
    /// Most samples per pixel a render to --target-error takes [default: 4096].
    #[arg(long)]
    max_spp: Option<u32>,
    /// Stop after this many seconds (0: no limit). Samples are then taken one per pixel per pass
    /// (one stage per pass with a target error), and rows not started when time is up are skipped
    /// (every pixel gets at least one sample) [default: 300 for a render to --target-error, else
    /// none].
    #[arg(long, value_parser = parse_time_limit)]
    time_limit: Option<std::time::Duration>,
    /// Seed of the path tracer's random numbers (same seed: same image, any thread count).
    #[arg(long, default_value_t = 0)]
    seed: u64,
}

/// Error a path-traced render takes samples to when neither `--spp` nor `--target-error` is given:
/// ΔE00 1 is about the smallest colour difference seen between two patches side by side, so the
/// noise left is at the edge of visibility.
pub(crate) const DEFAULT_TARGET_ERROR: f32 = 1.0;
/// Most samples per pixel of a render to a target error when `--max-spp` is not given (Cycles'
/// default maximum).
pub(crate) const DEFAULT_MAX_SPP: u32 = 4096;
/// Time limit of a render to a target error when `--time-limit` is not given: a first image is
/// answered within minutes, however hard the scene.
pub(crate) const DEFAULT_TIME_LIMIT: std::time::Duration = std::time::Duration::from_secs(300);
/// Photon mapping's iterations without `--spp` (pbrt-v4's default for its SPPM).
const SPPM_ITERATIONS: u32 = 64;
/// Most photons per iteration (2³⁰): beyond any render's need; a mistyped count is refused, not run for days.
const MAX_PHOTONS: u64 = 1 << 30;

/// What a render will take: its samples per pixel (a bound with a target), the target, the time
/// limit, and how that was decided (one line for notes and `info`).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct SamplingPlan {
    pub(crate) spp: u32,
    pub(crate) target: Option<f32>,
    pub(crate) time_limit: Option<std::time::Duration>,
    pub(crate) seed: u64,
    pub(crate) why: String,
}

impl SamplingArgs {
    /// Decide the samples for the integrator `kind`: `--spp N` is exactly N; without it the path
    /// tracer renders to a target error and the paper's model (deterministic) takes 1 sample.
    pub(crate) fn plan(&self, kind: IntegratorKind) -> anyhow::Result<SamplingPlan> {
        let limit = |default: Option<std::time::Duration>| match self.time_limit {
            Some(d) if d.is_zero() => None,
            Some(d) => Some(d),
            None => default,
        };
        let check_spp = |what: &str, spp: u32| -> anyhow::Result<()> {
            anyhow::ensure!((1..=1 << 20).contains(&spp), "{what} {spp} is outside 1..=1048576");
            Ok(())
        };
        if let Some(spp) = self.spp {
            check_spp("--spp", spp)?;
            return Ok(SamplingPlan {
                spp,
                target: None,
                time_limit: limit(None),
                seed: self.seed,
                why: format!("{spp} spp (--spp)"),
            });
        }
        if kind == IntegratorKind::WhittedHall {
            if self.target_error.is_some() || self.max_spp.is_some() {
                anyhow::bail!(
                    "--target-error and --max-spp need the path tracer: whitted-hall is deterministic (give --spp N, or --integrator path)"
                );
            }
            return Ok(SamplingPlan {
                spp: 1,
                target: None,
                time_limit: limit(None),
                seed: self.seed,
                why: "1 spp (whitted-hall is deterministic; --spp N for anti-aliasing)".to_owned(),
            });
        }
        if kind == IntegratorKind::Sppm {
            // Photon mapping keeps no half-films, so it has no error estimate to stop at.
            if self.target_error.is_some() {
                anyhow::bail!(
                    "--target-error: sppm has no error estimate (its radius couples the iterations); give --spp N iterations, or --integrator bdpt"
                );
            }
            let spp = self.max_spp.unwrap_or(SPPM_ITERATIONS);
            check_spp("--max-spp", spp)?;
            let time_limit = limit(Some(DEFAULT_TIME_LIMIT));
            return Ok(SamplingPlan {
                spp,
                target: None,
                time_limit,
                seed: self.seed,
                why: match time_limit {
                    Some(t) => format!("{spp} photon-mapping iterations, or fewer after {} s", t.as_secs_f64()),
                    None => format!("{spp} photon-mapping iterations"),
                },
            });
        }
        let target = self.target_error.unwrap_or(DEFAULT_TARGET_ERROR);
        anyhow::ensure!(
            target.is_finite() && target > 0.0,
            "--target-error {target} must be a positive ΔE00 (e.g. 1, or 0.5 for a cleaner image)"
        );
        let spp = self.max_spp.unwrap_or(DEFAULT_MAX_SPP);
        check_spp("--max-spp", spp)?;
        let time_limit = limit(Some(DEFAULT_TIME_LIMIT));
        let given = if self.target_error.is_some() { "--target-error" } else { "the default" };
        let cap = match time_limit {
            Some(t) => format!("at most {spp} spp or {} s", t.as_secs_f64()),
            None => format!("at most {spp} spp"),
        };
        Ok(SamplingPlan {
            spp,
            target: Some(target),
            time_limit,
            seed: self.seed,
            why: format!(
                "to a mean ΔE00 of {target} in every {tile}×{tile} tile ({given}), {cap}",
                tile = integrator::TILE
            ),
        })
    }
}

fn parse_time_limit(s: &str) -> Result<std::time::Duration, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && (0.0..1e9).contains(&v) => Ok(std::time::Duration::from_secs_f64(v)),
        _ => Err(format!("expected a number of seconds >= 0 (0: no limit), got `{s}`")),
    }
}

/// Rendering a part of a render, checkpoints and resuming (docs/film-format.md).
#[derive(Debug, Clone, clap::Args)]
#[command(next_help_heading = "Distributed and resumable rendering")]
pub(crate) struct PartArgs {
    /// Render part K of M of the samples (K = 1..M, e.g. a Slurm array task id); needs --film.
    /// Merge the parts with `spectrace merge`.
    #[arg(long, value_name = "K/M", value_parser = parse_part, conflicts_with = "samples")]
    part: Option<(u32, u32)>,
    /// Render only the sample indices A..B (A included, B not) of the --spp; needs --film.
    #[arg(long, value_name = "A..B", value_parser = parse_range)]
    samples: Option<std::ops::Range<u32>>,
    /// Write the film (exact per-pixel sums, mergeable and resumable) to this file.
    #[arg(long, value_name = "FILE.film")]
    film: Option<PathBuf>,
    /// Keep per-wavelength sums in the film, so `spectrace merge --spectral-exr` can write a
    /// spectral image (fixed wavelengths only; implied by --spectral-exr).
    #[arg(long)]
    spectral_film: bool,
    /// Write the film to this file periodically (and when the render ends or its time limit
    /// is up), so a killed render can be resumed with --resume FILE.
    #[arg(long, value_name = "FILE.film")]
    checkpoint: Option<PathBuf>,
    /// Seconds between checkpoints (0: after every pass of one sample per pixel).
    #[arg(long, value_name = "SECONDS", default_value = "60", value_parser = parse_interval)]
    checkpoint_every: std::time::Duration,
    /// Continue the render whose film (a checkpoint, or a --film of a time-limited render) is
    /// this file; the scene and options must be the same. The result is bit for bit the
    /// uninterrupted render's.
    #[arg(long, value_name = "FILE.film")]
    resume: Option<PathBuf>,
}

fn parse_part(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("expected K/M with 1 <= K <= M (e.g. 3/8), got `{s}`");
    let (k, m) = s.split_once('/').ok_or_else(bad)?;
    let (k, m) = (k.trim().parse::<u32>().map_err(|_| bad())?, m.trim().parse::<u32>().map_err(|_| bad())?);
    if k == 0 || k > m {
        return Err(bad());
    }
    Ok((k, m))
}

fn parse_range(s: &str) -> Result<std::ops::Range<u32>, String> {
    let bad = || format!("expected A..B with A < B (e.g. 0..16), got `{s}`");
    let (a, b) = s.split_once("..").ok_or_else(bad)?;
    let (a, b) = (a.trim().parse::<u32>().map_err(|_| bad())?, b.trim().parse::<u32>().map_err(|_| bad())?);
    if a >= b {
        return Err(bad());
    }
    Ok(a..b)
}

fn parse_interval(s: &str) -> Result<std::time::Duration, String> {
    match s.parse::<f64>() {
        Ok(v) if (0.0..1e9).contains(&v) => Ok(std::time::Duration::from_secs_f64(v)),
        _ => Err(format!("expected a number of seconds >= 0, got `{s}`")),
    }
}

/// What a scene may cost to load (shared by `render` and `info`).
#[derive(Debug, Clone, clap::Args)]
pub(crate) struct LoadArgs {
    /// Memory budget for the scene's data, in bytes or with a K/M/G suffix (powers of 1024): files,
    /// decoded geometry and the BVH; a scene that needs more is refused before allocating [default: 8G].
    #[arg(long, value_parser = parse_bytes, help_heading = "Limits")]
    max_memory: Option<u64>,
    /// Let a scene refer to files by absolute path (refused by default: a scene is a movable folder).
    #[arg(long, help_heading = "Limits")]
    allow_absolute_paths: bool,
    /// Change a value of the manifest before it is read, e.g. `materials.glass.ior=1.6` or
    /// `lights.0.intensity=2` (a dotted path: keys, and array indices from 0; the value is JSON, or
    /// else a string). Repeatable; a later one wins. For sweeps (docs/scene-format.md "Overrides and frames").
    #[arg(long = "set", value_name = "PATH=VALUE", action = clap::ArgAction::Append, help_heading = "Scene")]
    set: Vec<geometry::Override>,
    /// Render frame K (from 0) of the manifest's `frames`: its changes apply before --set. `{frame}` in
    /// output and film paths becomes K.
    #[arg(long, value_name = "K", help_heading = "Scene")]
    frame: Option<u32>,
}

impl LoadArgs {
    pub(crate) fn options(&self) -> geometry::LoadOptions {
        geometry::LoadOptions {
            max_memory: self.max_memory.unwrap_or(geometry::DEFAULT_MAX_MEMORY),
            allow_absolute_paths: self.allow_absolute_paths,
            variation: geometry::Variation { frame: self.frame, overrides: self.set.clone() },
            ..geometry::LoadOptions::default()
        }
    }

    /// Refuses --frame and --set without a scene file: they change a manifest's document, and the
    /// default scene is built in (a glTF or OBJ file given them is refused by the loader).
    pub(crate) fn check_scene(&self, scene: Option<&Path>) -> anyhow::Result<()> {
        if scene.is_some() {
            return Ok(());
        }
        if self.frame.is_some() {
            anyhow::bail!(
                "--frame needs a scene manifest with \"frames\" (no scene file given; the default scene has none)"
            );
        }
        if !self.set.is_empty() {
            anyhow::bail!("--set needs a scene manifest (no scene file given; the default scene is built in)");
        }
        Ok(())
    }

    /// `path` with `{frame}` replaced by the frame number (unchanged without --frame).
    pub(crate) fn frame_path(&self, path: &Path) -> PathBuf {
        match (self.frame, path.to_str()) {
            (Some(k), Some(text)) if text.contains("{frame}") => PathBuf::from(text.replace("{frame}", &k.to_string())),
            _ => path.to_path_buf(),
        }
    }
}

fn parse_bytes(s: &str) -> Result<u64, String> {
    let (digits, shift) =
        match s.trim().to_ascii_uppercase().strip_suffix('B').unwrap_or(&s.trim().to_ascii_uppercase()) {
            t if t.ends_with('K') => (t[..t.len() - 1].to_owned(), 10),
            t if t.ends_with('M') => (t[..t.len() - 1].to_owned(), 20),
            t if t.ends_with('G') => (t[..t.len() - 1].to_owned(), 30),
            t => (t.to_owned(), 0),
        };
    match digits.trim().parse::<u64>() {
        Ok(v) if v > 0 => v.checked_mul(1 << shift).ok_or_else(|| format!("`{s}` is too large")),
        _ => Err(format!("expected a positive number of bytes (e.g. 512M, 8G), got `{s}`")),
    }
}

fn parse_on_off(s: &str) -> Result<bool, String> {
    match s {
        "on" | "true" | "yes" => Ok(true),
        "off" | "false" | "no" => Ok(false),
        _ => Err(format!("expected on or off, got `{s}`")),
    }
}

/// Exit status for a render stopped by Ctrl-C (128 + SIGINT, the shell convention).
pub(crate) const EXIT_CANCELLED: u8 = 130;

/// The library's limits on the image and the pool ([`RenderOptions::check_limits`]),
/// checked before the scene is rendered, in the words of the command line.
fn check_limits(options: &RenderOptions, args: &RenderArgs) -> anyhow::Result<()> {
    match options.check_limits() {
        Ok(()) => Ok(()),
        Err(integrator::Error::SideOutOfRange { side, value }) => {
            let given = if side == "width" { args.width.is_some() } else { args.height.is_some() };
            let from = if given { "" } else { " (the scene's)" };
            anyhow::bail!("--{side} {value}{from} is out of range: 1..={} pixels per side", integrator::MAX_SIDE)
        }
        Err(integrator::Error::ThreadsOutOfRange(threads)) => {
            anyhow::bail!("--threads {threads} is out of range: 1..={}", integrator::MAX_THREADS)
        }
        Err(e @ integrator::Error::TooManySpectralSamples { .. }) => anyhow::bail!("--spectral-exr: {e}"),
        Err(e) => Err(e.into()),
    }
}

/// `args` with `{frame}` in every output, film and checkpoint path replaced by `--frame`'s number, so one
/// command line serves every task of a job array.
fn with_frame_paths(args: &RenderArgs) -> RenderArgs {
    let mut args = args.clone();
    let load = args.load.clone();
    let frame = |p: &mut Option<PathBuf>| {
        if let Some(path) = p.as_mut() {
            *path = load.frame_path(path);
        }
    };
    frame(&mut args.output);
    frame(&mut args.spectral_exr);
    frame(&mut args.parts.film);
    frame(&mut args.parts.checkpoint);
    frame(&mut args.parts.resume);
    args
}

/// Whether the outputs are being written: a signal then removes their temporaries and exits.
static WRITING: AtomicBool = AtomicBool::new(false);

/// SIGINTs and SIGTERMs received: the second exits at once, whatever the render is doing.
static SIGNALS: AtomicU32 = AtomicU32::new(0);

pub(crate) fn run(args: &RenderArgs) -> anyhow::Result<()> {
    args.load.check_scene(args.scene.as_deref())?;
    let args = &with_frame_paths(args);
    let parts = &args.parts;
    // Images are written unless only a film is asked for.
    let image_path = match (&args.output, &parts.film) {
        (Some(path), _) => Some(path.clone()),
        (None, None) => Some(PathBuf::from("render.exr")),
        (None, Some(_)) => None,
    };
    // A part is a range of a fixed number of samples: an adaptive render decides from the whole
    // film, so it is not split.
    let part_spp = match (parts.part.is_some() || parts.samples.is_some(), args.sampling.spp) {
        (false, _) => None,
        (true, Some(spp)) => Some(spp),
        (true, None) => anyhow::bail!(
            "--part/--samples need --spp N: a render to a target error decides which pixels go on from the whole film, so it is not split into parts"
        ),
    };
    let samples = match (parts.part, &parts.samples, part_spp) {
        (Some((k, m)), _, Some(spp)) => Some(integrator::part_samples(k, m, spp).context("--part")?),
        (None, Some(range), _) => Some(range.clone()),
        _ => None,
    };
    if let (Some(range), Some(spp)) = (&samples, part_spp) {
        if parts.film.is_none() {
            anyhow::bail!(
                "--part/--samples render only samples {}..{} of {}: give --film PART.film and merge the parts with `spectrace merge`",
                range.start,
                range.end,
                spp
            );
        }
        if range.end > spp {
            anyhow::bail!("--samples {}..{} is beyond --spp {}", range.start, range.end, spp);
        }
    }
    if args.spectral_exr.is_some() && image_path.is_none() {
        anyhow::bail!("--spectral-exr needs an image (-o); to keep the spectrum in the film, use --spectral-film");
    }
    // Before loading or rendering anything: the image files (the view is the scene's, below), and
    // no two outputs on one path, which would replace each other.
    for (flag, path) in [("--film", &parts.film), ("--checkpoint", &parts.checkpoint)] {
        if let Some(path) = path {
            check_film_extension(flag, path)?;
        }
    }
    let png = image_path.as_deref().map(png_path).transpose()?;
    // The PNG is not named on the command line: an error about it says where it comes from.
    let explain = |e: integrator::Error| -> anyhow::Error {
        match (e, &image_path, &png) {
            (integrator::Error::Write { path, message }, Some(output), Some(png)) => {
                anyhow::anyhow!("{}: {message} (-o {} also writes {})", path.display(), output.display(), png.display())
            }
            (other, ..) => other.into(),
        }
    };
    let mut plan = OutputPlan::new(
        image_path.as_deref(),
        args.display,
        args.spectral_exr.as_deref(),
        None,
        integrator::ViewPlan::default(),
    )
    .map_err(explain)?;
    if let Some(path) = &args.error_map {
        if image_path.is_none() {
            anyhow::bail!("--error-map goes with an image (-o); the film keeps what it needs when rendered with it");
        }
        plan.add_error_map(path).map_err(explain)?;
    }
    if let Some(path) = &args.false_color {
        if image_path.is_none() {
            anyhow::bail!("--false-color goes with an image (-o)");
        }
        plan.add_false_color(path, args.false_color_range).map_err(explain)?;
    }
    let mut paths: Vec<&Path> = plan.outputs.iter().map(|o| o.path.as_path()).collect();
    paths.extend(parts.film.as_deref());
    if parts.checkpoint != parts.film {
        paths.extend(parts.checkpoint.as_deref());
    }
    integrator::check_distinct_outputs(&paths).map_err(explain)?;

    let mut assembly = args.camera.assembly((args.width, args.height));
    args.env.apply(&mut assembly)?;
    let scene = match &args.scene {
        // Scene errors name the file (and line) themselves.
        Some(path) => RenderScene::load_with_options(path, &args.load.options(), &assembly)?,
        None => RenderScene::from_description_with(RenderScene::default_description()?, &assembly)
            .context("building the default scene")?,
    };
    // Still before anything is written: no output may replace a file the scene was read from, nor
    // the film to resume, unless it is the film or checkpoint that continues it (what a resumed
    // render writes there holds the resumed samples and more).
    let inputs: Vec<(&Path, &str)> = scene.input_files().iter().map(|p| (p.as_path(), "the scene's input")).collect();
    integrator::check_outputs_spare_inputs(&paths, &inputs).map_err(explain)?;
    if let Some(resume) = &parts.resume {
        let images: Vec<&Path> = plan.outputs.iter().map(|o| o.path.as_path()).collect();
        integrator::check_outputs_spare_inputs(&images, &[(resume, "the film to resume")]).map_err(explain)?;
    }
    let (integrator_kind, integrator_note) = args.integrator.resolve(&scene);
    let (view_plan, exposure_why) = args.exposure.plan(&scene)?;
    plan.view = view_plan;
    if !args.quiet {
        for w in scene.warnings.iter().chain(&integrator_note) {
            eprintln!("spectrace: note: {w}");
        }
    }
    let (width, height) = scene.resolution_for(args.width, args.height);
    if integrator_kind == IntegratorKind::WhittedHall && args.rr_depth.is_some() {
        // The paper's model has no Russian roulette: say so rather than drop the flag silently.
        eprintln!("spectrace: warning: --rr-depth is ignored by whitted-hall (it has no Russian roulette)");
    }
    if integrator_kind == IntegratorKind::WhittedHall
        && let Some(m) = scene.fluorescent_material()
    {
        // The paper's model keeps every wavelength where it is: say what it leaves out.
        eprintln!(
            "spectrace: note: whitted-hall renders material `{m}`'s reflectance only, not its fluorescence (--integrator path renders it)"
        );
    }
    if integrator_kind == IntegratorKind::WhittedHall && args.sampler.is_some() {
        // Its sub-pixel positions are deterministic and it draws no other numbers.
        eprintln!("spectrace: warning: --sampler is ignored by whitted-hall (it draws no random numbers)");
    }
    let sampling = args.sampling.plan(integrator_kind)?;
    if !args.quiet && args.sampling.spp.is_none() {
        eprintln!("spectrace: note: samples: {}", sampling.why);
    }
    let integrator = match integrator_kind {
        IntegratorKind::WhittedHall => Integrator::WhittedHall(WhittedOptions {
            max_depth: args.max_depth,
            min_weight: args.min_weight,
            absorption: args.absorption,
            ambient: args.ambient,
        }),
        IntegratorKind::Path => Integrator::Path(PathOptions {
            max_depth: args.max_depth,
            rr_depth: args.rr_depth,
            wavelength_pdf: args.wavelength_pdf,
            sampler: args.sampler.unwrap_or_default(),
        }),
        IntegratorKind::Bdpt => {
            if args.sampler.is_some_and(|s| s != integrator::SamplerKind::Independent) {
                anyhow::bail!(
                    "--sampler {}: bdpt draws independent numbers (its light subpaths are not stratified)",
                    args.sampler.unwrap_or_default()
                );
            }
            Integrator::Bdpt(PathOptions {
                max_depth: args.max_depth,
                rr_depth: args.rr_depth,
                wavelength_pdf: args.wavelength_pdf,
                sampler: integrator::SamplerKind::Independent,
            })
        }
        IntegratorKind::Sppm => {
            if args.sampler.is_some_and(|s| s != integrator::SamplerKind::Independent) {
                anyhow::bail!(
                    "--sampler {}: sppm draws independent numbers (its photons are not stratified)",
                    args.sampler.unwrap_or_default()
                );
            }
            if let Some(r) = args.radius {
                anyhow::ensure!(r.is_finite() && r > 0.0, "--radius {r} must be a positive length in scene units");
            }
            if let Some(p) = args.photons {
                anyhow::ensure!(
                    (1..=MAX_PHOTONS).contains(&p),
                    "--photons {p} is outside 1..={MAX_PHOTONS} (photons per iteration)"
                );
            }
            Integrator::Sppm(integrator::SppmOptions {
                path: PathOptions {
                    max_depth: args.max_depth,
                    rr_depth: args.rr_depth,
                    wavelength_pdf: args.wavelength_pdf,
                    sampler: integrator::SamplerKind::Independent,
                },
                photons: args.photons,
                radius: args.radius,
            })
        }
    };
    if integrator_kind != IntegratorKind::Sppm && (args.photons.is_some() || args.radius.is_some()) {
        eprintln!("spectrace: warning: --photons and --radius are photon mapping's (--integrator sppm): ignored");
    }
    let options = RenderOptions {
        width,
        height,
        integrator,
        spectral: args.spectral,
        spp: sampling.spp,
        samples,
        seed: sampling.seed,
        time_limit: sampling.time_limit,
        threads: args.threads,
        target_error: sampling.target.map(|delta_e| integrator::TargetError {
            delta_e,
            exposure_ev: match view_plan.exposure {
                integrator::Exposure::Fixed(ev) => Some(ev),
                integrator::Exposure::Auto => None,
            },
        }),
        error_estimate: args.error_map.is_some(),
        spectral_film: args.spectral_exr.is_some() || parts.spectral_film,
    };
    check_limits(&options, args)?;
    // Resolved once: `auto` may run a pilot render to decide, and then says what it measured.
    let spectral = if options.spectral == SpectralMode::Auto {
        let auto = integrator::auto_decision(&scene, &options)?;
        if !args.quiet && !auto.candidates.is_empty() {
            let spp: Vec<String> =
                auto.candidates.iter().map(|c| format!("{} {:.0}", c.spectral, c.spp_for(1.0))).collect();
            eprintln!(
                "spectrace: note: --spectral auto {}; the pilot's spp to mean ΔE00 1: {}",
                auto.reason,
                spp.join(", ")
            );
        }
        auto.spectral
    } else {
        integrator::resolved_spectral(&scene, &options)?
    };
    let header = integrator::FilmHeader::new(scene.source_hash(), &options, spectral, view_plan.to_string());
    let resume = match &parts.resume {
        Some(path) => {
            let file = integrator::FilmFile::read(path)?;
            Some(file.resumable(&header, options.width, options.height, path)?)
        }
        None => None,
    };

    let cancel = Arc::new(AtomicBool::new(false));
    {
        let cancel = Arc::clone(&cancel);
        // SIGINT and SIGTERM (ctrlc's `termination` feature): during the render, stop within
        // a few samples; during the write, or at a second signal (a render that does not stop
        // soon enough for the user), remove the temporaries (a checkpoint being written) and
        // exit at once.
        let _ = ctrlc::set_handler(move || {
            let again = SIGNALS.fetch_add(1, Ordering::SeqCst) > 0;
            cancel.store(true, Ordering::SeqCst);
            if WRITING.load(Ordering::SeqCst) || again {
                integrator::remove_pending_outputs();
                let when = if again { "interrupted again" } else { "interrupted while writing" };
                eprintln!("spectrace: {when}; nothing was written");
                std::process::exit(i32::from(EXIT_CANCELLED));
            }
        });
    }
    let bar = if args.quiet { ProgressBar::hidden() } else { ProgressBar::new(u64::from(options.height)) };
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {wide_bar} {msg}")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let report = |p: integrator::Progress| {
        let secs = p.elapsed.as_secs_f64().max(1e-9);
        let speed = format!("{:.2} Mrays/s", p.rays as f64 / secs / 1e6);
        match p.error {
            // A render to a target error: the bar counts tiles done.
            Some(e) => {
                bar.set_length(1000);
                bar.set_position((e.tiles_done * 1000.0).round() as u64);
                let left = match e.remaining {
                    Some(t) => format!(", ~{} left", human_duration(t)),
                    None => String::new(),
                };
                bar.set_message(format!(
                    "{:.0} % of tiles at ΔE00 ≤ {}; mean ΔE00 {:.2}, worst tile {:.2}{left}; {speed}",
                    100.0 * e.tiles_done,
                    e.target,
                    e.mean,
                    e.worst_tile
                ));
            }
            None if options.target_error.is_some() => {
                bar.set_length(p.rows_total.max(1));
                bar.set_position(p.rows_done);
                bar.set_message(format!(
                    "{}/{} rows of the first {} spp; {speed}",
                    p.rows_done,
                    p.rows_total,
                    integrator::FIRST_STAGE_SPP
                ));
            }
            None => {
                // With --time-limit, passes of one sample make more rows than the image has.
                bar.set_length(p.rows_total);
                bar.set_position(p.rows_done);
                bar.set_message(format!("{}/{} rows; {speed}", p.rows_done, p.rows_total));
            }
        }
    };
    let write_checkpoint = |film: &integrator::Film| -> integrator::Result<()> {
        match &parts.checkpoint {
            Some(path) => header.write_film(film, path),
            None => Ok(()),
        }
    };
    let checkpoint = parts
        .checkpoint
        .as_ref()
        .map(|_| integrator::Checkpoint { every: parts.checkpoint_every, write: &write_checkpoint });
    let control =
        integrator::RenderControl { progress: &report, cancel: &cancel, resume, checkpoint, spectral: Some(spectral) };
    let result = integrator::render_film_with(&scene, &options, control);
    bar.finish_and_clear();
    let (film, stats) = match result {
        Err(integrator::Error::Cancelled) => cancelled(),
        other => other?,
    };
    // Non-finite samples are added as black: a few are said loudly (even with --quiet), and an
    // image made mostly of them is not written at all, film included.
    match integrator::nonfinite_verdict(stats.nonfinite_samples, stats.samples) {
        integrator::NonfiniteVerdict::Clean => {}
        integrator::NonfiniteVerdict::Warn(message) => eprintln!("spectrace: warning: {message}"),
        integrator::NonfiniteVerdict::Refuse(message) => anyhow::bail!("{message}; nothing was written"),
    }
    // The film first: it is what a time-limited or partial render is for.
    for path in [&parts.film, &parts.checkpoint].into_iter().flatten() {
        header.write_film(&film, path).context("writing the film")?;
    }
    let (image, view) = plan.develop(&film, header.samples.start);
    if !args.quiet && !view.is_identity() {
        let how =
            if view_plan.exposure == integrator::Exposure::Auto { "auto: log-average luminance to 0.18; " } else { "" };
        eprintln!(
            "spectrace: note: PNG exposure {:+.2} EV ({how}{exposure_why}), tonemap {}; the EXR is not scaled",
            view.ev, view.tonemap
        );
    }

    // Set before checking `cancel`, as the handler sets `cancel` before checking this: a
    // signal arriving now is seen by one side or the other (or both, which is harmless).
    WRITING.store(true, Ordering::SeqCst);
    if cancel.load(Ordering::SeqCst) {
        cancelled();
    }
    // All or nothing: every file is written to a temporary and fsynced, then all are renamed.
    plan.write(&image).context("writing the outputs (none was written)")?;
    WRITING.store(false, Ordering::SeqCst);
    if !args.quiet {
        let secs = stats.elapsed.as_secs_f64();
        let mut written: Vec<String> = plan.outputs.iter().map(|o| o.path.display().to_string()).collect();
        written.extend([&parts.film, &parts.checkpoint].into_iter().flatten().map(|p| p.display().to_string()));
        written.dedup();
        let written = written.join(", ");
        let range = header.samples.clone();
        let spp = if stats.spp != stats.max_spp {
            // Adaptive, or stopped by the time limit part way through a pass.
            let pixels = f64::from(options.width) * f64::from(options.height);
            format!("{}..{} spp (mean {:.0})", stats.spp, stats.max_spp, stats.samples as f64 / pixels)
        } else if range.len() as u32 == options.spp {
            format!("{} spp", stats.spp)
        } else {
            format!("{} spp (samples {}..{} of {})", stats.spp, range.start, range.end, options.spp)
        };
        eprintln!(
            "spectrace: {}x{} {} {spp} in {:.3} s ({} rays, {} of them shadow rays, {:.2} Mrays/s, {} non-finite samples) -> {written}",
            options.width,
            options.height,
            stats.spectral,
            secs,
            stats.rays,
            stats.shadow_rays,
            stats.rays as f64 / secs.max(1e-9) / 1e6,
            stats.nonfinite_samples,
        );
        if let Some(e) = stats.error {
            let stop = match e.target {
                Some(target) if e.tiles_done >= 1.0 => format!("every tile reached the target ΔE00 {target}"),
                Some(target) => format!(
                    "{:.1} % of the tiles reached the target ΔE00 {target} (stopped by {})",
                    100.0 * e.tiles_done,
                    if stats.max_spp >= options.spp { "--max-spp" } else { "the time limit" }
                ),
                None => "no target".to_owned(),
            };
            eprintln!(
                "spectrace: estimated error: mean ΔE00 {:.2}, worst 8×8 tile {:.2}; {stop}",
                e.mean, e.worst_tile
            );
        }
        if stats.clamped_samples > 0 {
            eprintln!(
                "spectrace: warning: {} samples were brighter than the film holds (2^42 in film units) and were clamped",
                stats.clamped_samples
            );
        }
    }
    Ok(())
}

/// `t` as `42 s`, `3 min 20 s` or `2 h 05 min`.
fn human_duration(t: std::time::Duration) -> String {
    let s = t.as_secs();
    match s {
        0..60 => format!("{s} s"),
        60..3600 => format!("{} min {:02} s", s / 60, s % 60),
        _ => format!("{} h {:02} min", s / 3600, s % 3600 / 60),
    }
}

/// A render stopped by SIGINT or SIGTERM: nothing written, exit 130.
fn cancelled() -> ! {
    eprintln!("spectrace: render cancelled; nothing was written");
    std::process::exit(i32::from(EXIT_CANCELLED));
}

/// A film or checkpoint path must end in `.film`: the rule that keeps `--film scene.gltf` or
/// `--checkpoint render.png` from being taken for a film's name (the file would hold film bytes).
pub(crate) fn check_film_extension(flag: &str, path: &Path) -> anyhow::Result<()> {
    match path.extension().and_then(|e| e.to_str()) {
        Some(ext) if ext.eq_ignore_ascii_case("film") => Ok(()),
        _ => anyhow::bail!("{flag} {}: a film file must end in .film", path.display()),
    }
}

/// `out.exr` → `out.png`; the output must be an `.exr` so the pair is unambiguous.
fn png_path(output: &Path) -> anyhow::Result<PathBuf> {
    match output.extension().and_then(|e| e.to_str()) {
        Some(ext) if ext.eq_ignore_ascii_case("exr") => Ok(output.with_extension("png")),
        _ => anyhow::bail!("{}: the output must end in .exr (a .png is written beside it)", output.display()),
    }
}

/// `LO,HI`: two numbers.
fn parse_luminance_range(s: &str) -> Result<(f32, f32), String> {
    let parts: Vec<&str> = s.split(',').collect();
    let [lo, hi] = parts.as_slice() else { return Err(format!("expected LO,HI, got {s:?}")) };
    let number = |t: &str| t.trim().parse::<f32>().map_err(|e| format!("{t:?}: {e}"));
    Ok((number(lo)?, number(hi)?))
}
