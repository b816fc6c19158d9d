//! What a render is asked to do besides the scene: the image size, the integrator and its
//! options, the spectral mode, samples and seed, and the limits every option is checked against.
//! Everything here is plain data; the renderer's parts read it, none of them is imported here.

use std::fmt;
use std::ops::Range;
use std::str::FromStr;
use std::time::Duration;

use crate::error::{Error, Result};
use crate::limits::{MAX_PIXELS, MAX_SIDE, MAX_SPECTRAL_SAMPLES, MAX_THREADS};
use crate::spectral::{MAX_BINS, SpectralMode};

/// Resolution used when neither the scene nor the user gives one: the paper's 640×480.
pub const DEFAULT_RESOLUTION: (u32, u32) = (640, 480);

/// Which light transport model renders the image (the selector; [`Integrator`] carries each
/// model's own options).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IntegratorKind {
    /// The paper's model: Whitted ray tracing with Hall's spectral shading.
    WhittedHall,
    /// The physically based spectral path tracer (`docs/path-tracer.md`).
    Path,
    /// Bidirectional path tracing over the path tracer's surfaces and lights: caustics from small lights
    /// (`docs/path-tracer.md`, "Bidirectional path tracing").
    Bdpt,
    /// Stochastic progressive photon mapping: also caustics seen through glass or in a mirror
    /// (`docs/path-tracer.md`, "Photon mapping").
    Sppm,
}

impl FromStr for IntegratorKind {
    type Err = Error;

    /// `whitted-hall` (also `whitted`, `paper`), `path`, `bdpt` or `sppm`.
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "whitted-hall" | "whitted" | "paper" => Ok(Self::WhittedHall),
            "path" => Ok(Self::Path),
            "bdpt" => Ok(Self::Bdpt),
            "sppm" => Ok(Self::Sppm),
            _ => Err(Error::InvalidOption {
                option: "integrator",
                value: s.to_owned(),
                expected: "whitted-hall, path, bdpt or sppm",
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

/// Options of stochastic progressive photon mapping (`sppm`): the path tracer's (its sampler is always
/// independent numbers) and the photon pass's. Its samples per pixel are its iterations.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SppmOptions {
    /// Depth, roulette and wavelength density, as the path tracer's.
    pub path: PathOptions,
    /// Photons per iteration; `None`: one per pixel (pbrt-v4's default).
    pub photons: Option<u64>,
    /// The gather radius of the first iteration, in scene units; `None`: two pixel footprints at each
    /// visible point.
    pub radius: Option<f32>,
}

/// The light transport model with its options: only meaningful combinations can be written.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Integrator {
    /// The paper's model.
    WhittedHall(WhittedOptions),
    /// The physically based path tracer.
    Path(PathOptions),
    /// Bidirectional path tracing, with the path tracer's options (its sampler is always independent
    /// numbers: the light subpath's dimensions are not stratified).
    Bdpt(PathOptions),
    /// Stochastic progressive photon mapping over BDPT's walks.
    Sppm(SppmOptions),
}

impl Integrator {
    /// Which model this is.
    pub fn kind(&self) -> IntegratorKind {
        match self {
            Self::WhittedHall(_) => IntegratorKind::WhittedHall,
            Self::Path(_) => IntegratorKind::Path,
            Self::Bdpt(_) => IntegratorKind::Bdpt,
            Self::Sppm(_) => IntegratorKind::Sppm,
        }
    }
}

impl Default for Integrator {
    fn default() -> Self {
        Self::WhittedHall(WhittedOptions::default())
    }
}

/// What an adaptive render stops at (`--target-error`): every tile of [`TILE`] × [`TILE`] pixels
/// takes samples until the mean of its pixels' estimated CIEDE2000 errors, as the PNG shows them,
/// is at most `delta_e` (`film/estimate.rs`; `docs/defaults.md`, "Samples").
///
/// [`TILE`]: crate::TILE
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TargetError {
    /// The mean ΔE00 per tile to reach (> 0).
    pub delta_e: f32,
    /// The exposure the colours are judged at, in stops (the PNG's): `None` for auto-exposure,
    /// re-measured on the image as it converges.
    pub exposure_ev: Option<f32>,
}

impl std::fmt::Display for TargetError {
    /// `1` or `1@+2.5EV` or `1@auto`: the film key's text.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.exposure_ev {
            Some(ev) => write!(f, "{:?}@{ev:+}EV", self.delta_e),
            None => write!(f, "{:?}@auto", self.delta_e),
        }
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
    /// pixel (of one stage with a target error), and rows not yet started are skipped once the
    /// time is up, so the limit is kept to within about one row's time after the first pass
    /// (each pixel averages the samples it got; [`RenderStats::spp`] says the fewest).
    pub time_limit: Option<Duration>,
    /// Worker threads (`None`: all cores).
    pub threads: Option<usize>,
    /// Sample adaptively to a target error ([`TargetError`]): `spp` is then the most samples a
    /// pixel may take, and each tile of the image stops when its estimated error is reached.
    pub target_error: Option<TargetError>,
    /// Keep the half-film sums that estimate each pixel's error (`--error-map`) without a
    /// target; implied by `target_error`.
    pub error_estimate: bool,
    /// Keep each pixel's radiance at the wavelengths rendered ([`Image::spectral`], written by
    /// [`Image::write_spectral_exr`]); needs fixed wavelengths (`bins:N`, or `auto` choosing
    /// bins).
    pub spectral_film: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self {
            width: DEFAULT_RESOLUTION.0,
            height: DEFAULT_RESOLUTION.1,
            integrator: Integrator::default(),
            spectral: SpectralMode::Auto,
            spp: 1,
            samples: None,
            seed: 0,
            time_limit: None,
            threads: None,
            target_error: None,
            error_estimate: false,
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
            Integrator::Path(_) | Integrator::Bdpt(_) | Integrator::Sppm(_) => WhittedOptions::default(),
        };
        f(&mut o);
        Self { integrator: Integrator::WhittedHall(o), ..self }
    }

    /// These options with the path tracer and its options changed by `f` (the defaults if they
    /// held the paper's model's).
    pub fn path(self, f: impl FnOnce(&mut PathOptions)) -> Self {
        let mut o = match self.integrator {
            Integrator::Path(o) | Integrator::Bdpt(o) | Integrator::Sppm(SppmOptions { path: o, .. }) => o,
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
            Integrator::Bdpt(p) => {
                format!(
                    "bdpt max_depth={:?} rr_depth={:?} wavelength_pdf={:?}",
                    p.max_depth, p.rr_depth, p.wavelength_pdf
                )
            }
            Integrator::Sppm(o) => {
                let p = o.path;
                format!(
                    "sppm max_depth={:?} rr_depth={:?} wavelength_pdf={:?} photons={:?} radius={:?}",
                    p.max_depth, p.rr_depth, p.wavelength_pdf, o.photons, o.radius
                )
            }
            Integrator::Path(p) => {
                format!(
                    "path max_depth={:?} rr_depth={:?} wavelength_pdf={:?} sampler={}",
                    p.max_depth, p.rr_depth, p.wavelength_pdf, p.sampler
                )
            }
        };
        let mut key =
            format!("{integrator} spectral={} spp={} spectral_film={}", self.spectral, self.spp, self.spectral_film);
        // Only when set, so the keys (and film files) of fixed-spp renders stay as they were.
        if let Some(t) = self.target_error {
            key.push_str(&format!(" target_error={t}"));
        } else if self.error_estimate {
            key.push_str(" halves=true");
        }
        key
    }

    /// Whether the film keeps the half-film sums that estimate the error.
    pub fn keeps_halves(&self) -> bool {
        self.target_error.is_some() || self.error_estimate
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
        assert_eq!("bdpt".parse::<IntegratorKind>().unwrap(), IntegratorKind::Bdpt);
        assert_eq!("sppm".parse::<IntegratorKind>().unwrap(), IntegratorKind::Sppm);
        assert!("photons".parse::<IntegratorKind>().is_err());
        assert_eq!("visible".parse::<WavelengthPdf>().unwrap(), WavelengthPdf::Visible);
        assert!("uniform".parse::<WavelengthPdf>().is_err());
    }
}
