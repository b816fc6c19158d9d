//! Illuminance sensors: the irradiance at points of a scene, in lux, with an honest standard error
//! (`spectrace measure`). A sensor is a point with a normal; it sees the hemisphere its normal faces, and a
//! surface it lies on does not shadow it (CIE 171:2006's measuring points lie on the work plane).
//!
//! Each sample is the path tracer's estimate at a white Lambertian point (E = π L_o): next event
//! estimation plus a cosine-sampled path, MIS-weighted, paths ended by Russian roulette only (the depth cap
//! is [`MEASURE_MAX_DEPTH`], far beyond where roulette has ended every path of a room of reflectance 0.9), so
//! interreflections are exact in expectation. Samples use independent random numbers (PCG32 streams of
//! (seed, point, sample)), so the sample standard error is an unbiased estimate of the estimator's and a
//! point's result is the same at any thread count.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use glam::Vec3;
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::film::Sensor;
use crate::integrators::{PathTracer, RayCount};
use crate::options::PathOptions;
use crate::render::thread_pool;
use crate::sampling::{Rng, Sampler};
use crate::scene::{RenderScene, scene_white};
use crate::spectral::{LaneJob, Lanes, SpectralMode, lane_count, with_lanes};

/// Bounce cap of a measurement: effectively none (Russian roulette ends the paths; a cap would bias a
/// bright room low, as CIE 171 case 5.8 shows of renderers that cut paths).
pub const MEASURE_MAX_DEPTH: u32 = 10_000;

/// Samples per point between two checks of the stopping rule.
const BATCH: u32 = 256;

/// The fewest samples a point takes before the stopping rule may end it: a rule checked on very few
/// samples stops early where a rare bright path has not yet been seen, reading low with too small an
/// error; 1024 samples make that unlikely for all but very heavy tails.
const MIN_SPP: u64 = 1024;

/// A sensor: where, and which hemisphere it sees.
#[derive(Debug, Clone, PartialEq)]
pub struct SensorPoint {
    /// A label, carried to the output.
    pub name: String,
    /// Position (scene units).
    pub position: Vec3,
    /// The normal of the hemisphere seen (any length > 0).
    pub normal: Vec3,
}

/// What to measure with.
#[derive(Debug, Clone)]
pub struct MeasureOptions {
    /// Exactly this many samples per point; `None`: sample to `target_relative_error`.
    pub spp: Option<u32>,
    /// The relative standard error each point samples to (0.01 = 1 %), unless `spp` is given.
    pub target_relative_error: f64,
    /// The most samples a point takes when sampling to the target.
    pub max_spp: u32,
    /// A point whose mean stays 0 after this many samples is reported dark (0 ± 0).
    pub dark_spp: u32,
    /// Wall-clock limit of the whole measurement (points not finished report what they have; then the
    /// result depends on the machine's speed). `None`: no limit.
    pub time_limit: Option<Duration>,
    /// Seed of the random numbers.
    pub seed: u64,
    /// Worker threads (`None`: all cores).
    pub threads: Option<usize>,
    /// Wavelength sampling: `hero:K` (unbiased for any spectrum; the default hero:8), or fixed lanes.
    pub spectral: SpectralMode,
    /// The path tracer's options (its depth and roulette settings are overridden: roulette only).
    pub path: PathOptions,
}

impl Default for MeasureOptions {
    fn default() -> Self {
        Self {
            spp: None,
            target_relative_error: 0.01,
            max_spp: 1 << 22,
            dark_spp: 4096,
            time_limit: None,
            seed: 0,
            threads: None,
            spectral: SpectralMode::Hero { count: 8 },
            path: PathOptions::default(),
        }
    }
}

/// One sensor's result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Measurement {
    /// Illuminance (lux, with the scene's photometric units; otherwise Y in the scene's units).
    pub illuminance: f64,
    /// Standard error of `illuminance` (the sample standard deviation over √samples).
    pub std_error: f64,
    /// CIE 1931 XYZ of the irradiance (Y = `illuminance`).
    pub xyz: [f64; 3],
    /// Samples taken.
    pub samples: u64,
    /// Whether the point stopped because the time limit ran out before its own rule was met.
    pub timed_out: bool,
    /// Samples whose value was not finite: counted as 0 (never seen in practice; reported so that none is
    /// dropped silently).
    pub nonfinite: u64,
}

impl Measurement {
    /// The correlated colour temperature of the irradiance (kelvin, McCamy 1992's cubic in the CIE 1931
    /// chromaticity), where defined: `None` for black, and for chromaticities off the Planckian locus by
    /// more than the approximation covers (outside 2000–25 000 K, or Δuv from the locus beyond 0.05).
    pub fn cct(&self) -> Option<f64> {
        let [x, y, z] = self.xyz;
        let sum = x + y + z;
        if !(sum > 0.0) || !(y > 0.0) {
            return None;
        }
        let (cx, cy) = (x / sum, y / sum);
        let n = (cx - 0.3320) / (0.1858 - cy);
        let cct = 449.0 * n.powi(3) + 3525.0 * n.powi(2) + 6823.3 * n + 5520.33;
        // The distance from the locus in CIE 1960 uv, against the blackbody's chromaticity at that CCT.
        let (u, v) = (4.0 * cx / (-2.0 * cx + 12.0 * cy + 3.0), 6.0 * cy / (-2.0 * cx + 12.0 * cy + 3.0));
        let (bu, bv) = planck_uv(cct);
        let duv = ((u - bu).powi(2) + (v - bv).powi(2)).sqrt();
        ((2000.0..=25_000.0).contains(&cct) && duv <= 0.05).then_some(cct)
    }
}

/// CIE 1960 (u, v) of the Planckian radiator at `t` kelvin (Krystek 1985's rational approximation, valid
/// 1000–15 000 K within 8e-5, used only to reject chromaticities far from the locus).
fn planck_uv(t: f64) -> (f64, f64) {
    let u = (0.860_117_757 + 1.541_182_54e-4 * t + 1.286_412_12e-7 * t * t)
        / (1.0 + 8.424_202_35e-4 * t + 7.081_451_63e-7 * t * t);
    let v = (0.317_398_726 + 4.228_062_45e-5 * t + 4.204_816_91e-8 * t * t)
        / (1.0 - 2.897_418_16e-5 * t + 1.614_560_53e-7 * t * t);
    (u, v)
}

/// Measure the illuminance at every sensor of `points` in `scene` (points in parallel). `done` is called
/// with the number of finished points as they finish; `cancel` stops early with [`Error::Cancelled`].
pub fn measure(
    scene: &RenderScene,
    points: &[SensorPoint],
    options: &MeasureOptions,
    done: &(dyn Fn(usize) + Sync),
    cancel: &AtomicBool,
) -> Result<Vec<Measurement>> {
    if let Some((i, p)) = points
        .iter()
        .enumerate()
        .find(|(_, p)| !(p.position.is_finite() && p.normal.is_finite() && p.normal.length_squared() > 0.0))
    {
        return Err(Error::InvalidOption {
            option: "sensor point",
            value: format!("#{} {:?}: position {}, normal {}", i + 1, p.name, p.position, p.normal),
            expected: "a finite position and a finite, non-zero normal",
        });
    }
    if !(options.target_relative_error > 0.0 && options.target_relative_error.is_finite()) && options.spp.is_none() {
        return Err(Error::InvalidOption {
            option: "target error",
            value: options.target_relative_error.to_string(),
            expected: "a relative standard error > 0",
        });
    }
    if options.spp == Some(0) || options.max_spp == 0 {
        return Err(Error::InvalidOption { option: "spp", value: "0".into(), expected: "at least 1" });
    }
    let pool = thread_pool(&crate::options::RenderOptions { threads: options.threads, ..Default::default() })?;
    let job = MeasureJob { scene, points, options, done, cancel };
    let lanes = lane_count(options.spectral)?;
    pool.install(|| with_lanes(lanes, job))
}

struct MeasureJob<'a> {
    scene: &'a RenderScene,
    points: &'a [SensorPoint],
    options: &'a MeasureOptions,
    done: &'a (dyn Fn(usize) + Sync),
    cancel: &'a AtomicBool,
}

impl LaneJob for MeasureJob<'_> {
    type Output = Result<Vec<Measurement>>;

    fn run<const N: usize>(self) -> Self::Output {
        let MeasureJob { scene, points, options, done, cancel } = self;
        let fixed = match options.spectral {
            SpectralMode::Rgb => Some(Lanes::<N>::rgb()),
            SpectralMode::Bins(n) => Some(Lanes::bins(n, &scene_white(scene))),
            SpectralMode::Hero { .. } => None,
            SpectralMode::Auto => {
                return Err(Error::InvalidOption {
                    option: "spectral mode",
                    value: "auto".into(),
                    expected: "hero:4, hero:8, bins:N or rgb (a measurement has no image to pilot)",
                });
            }
        };
        // Fixed lanes cannot follow a path to the wavelength a fluorescent surface absorbed at.
        if fixed.is_some()
            && let Some(m) = scene.materials.iter().find(|m| m.fluorescence.is_some())
        {
            return Err(Error::FluorescenceNeedsHero {
                material: m.name.clone(),
                spectral: options.spectral.to_string(),
            });
        }
        let path = PathOptions { max_depth: Some(MEASURE_MAX_DEPTH), ..options.path };
        let (tracer, sensor) = PathTracer::<N>::new(scene, fixed, &path);
        let start = Instant::now();
        let finished = AtomicUsize::new(0);
        let results: Vec<Measurement> = points
            .par_iter()
            .enumerate()
            .with_max_len(1)
            .map(|(i, point)| {
                let m = measure_point(&tracer, &sensor, point, i as u64, options, start, cancel);
                done(finished.fetch_add(1, Ordering::Relaxed) + 1);
                m
            })
            .collect();
        if cancel.load(Ordering::Relaxed) {
            return Err(Error::Cancelled);
        }
        Ok(results)
    }
}

/// Running sums of one point's samples.
#[derive(Default)]
struct Sums {
    n: u64,
    nonfinite: u64,
    y: f64,
    y2: f64,
    xyz: [f64; 3],
}

impl Sums {
    fn mean(&self) -> f64 {
        self.y / self.n as f64
    }

    /// The standard error of the mean: √(s² / n), s² the unbiased sample variance.
    fn std_error(&self) -> f64 {
        if self.n < 2 {
            return 0.0;
        }
        let n = self.n as f64;
        let var = ((self.y2 - self.y * self.y / n) / (n - 1.0)).max(0.0);
        (var / n).sqrt()
    }
}

fn measure_point<const N: usize>(
    tracer: &PathTracer<'_, N>,
    sensor: &Sensor<N>,
    point: &SensorPoint,
    index: u64,
    options: &MeasureOptions,
    start: Instant,
    cancel: &AtomicBool,
) -> Measurement {
    let normal = point.normal.normalize();
    let mut sums = Sums::default();
    let mut count = RayCount::default();
    let mut timed_out = false;
    let goal = options.spp.map_or(options.max_spp, |s| s) as u64;
    while sums.n < goal {
        let batch = (goal - sums.n).min(u64::from(BATCH));
        for _ in 0..batch {
            let mut sampler = Sampler::Independent(Rng::new(options.seed, index, sums.n));
            let u = sampler.uniform();
            let lambda = sensor.sample_wavelengths(u.min(0.999_999_9));
            let s = tracer.irradiance(point.position, normal, lambda, sensor, &mut sampler, &mut count);
            let xyz = add(
                sensor.to_xyz(&s.direct, &s.lambda_direct, None).0,
                sensor.to_xyz(&s.indirect.l, &s.lambda_indirect, s.indirect.lane).0,
            );
            let y = f64::from(xyz[1]);
            if y.is_finite() && xyz.iter().all(|v| v.is_finite()) {
                sums.y += y;
                sums.y2 += y * y;
                for (sum, v) in sums.xyz.iter_mut().zip(xyz) {
                    *sum += f64::from(v);
                }
            } else {
                sums.nonfinite += 1;
            }
            sums.n += 1;
        }
        if cancel.load(Ordering::Relaxed) {
            break;
        }
        if options.spp.is_none() && sums.n >= MIN_SPP {
            let mean = sums.mean();
            if mean > 0.0 && sums.std_error() <= options.target_relative_error * mean {
                break;
            }
            if sums.y == 0.0 && sums.n >= u64::from(options.dark_spp) {
                break;
            }
        }
        if options.time_limit.is_some_and(|limit| start.elapsed() >= limit) {
            timed_out = sums.n < goal;
            break;
        }
    }
    let n = sums.n.max(1) as f64;
    Measurement {
        illuminance: sums.mean(),
        std_error: sums.std_error(),
        xyz: sums.xyz.map(|v| v / n),
        samples: sums.n,
        timed_out,
        nonfinite: sums.nonfinite,
    }
}

fn add(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
