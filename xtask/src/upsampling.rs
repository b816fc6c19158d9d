//! `gen-upsampling-table` and `upsampling-report`: the Jakob–Hanika 2019
//! coefficient table behind `colorimetry::upsample_reflectance`, and a check
//! of the round trip RGB → spectrum → RGB over a dense grid of the sRGB cube.

use std::{
    fs,
    path::{Path, PathBuf},
    time::Instant,
};

use anyhow::{Context, Result, ensure};
use clap::Args;
use colorimetry::{
    Illuminant, Integration, Lab, Observer, Rgb, RgbColorSpace, SigmoidPolynomial, Xyz, build_upsampling_table,
    delta_e_2000, emission_to_xyz, reflectance_to_xyz, upsample_illuminant_spectrum, upsample_reflectance,
};
use rayon::prelude::*;

use crate::project_root;

/// Where the crate embeds the table from (`include_bytes!` in `colorimetry/src/upsample.rs`).
const TABLE_PATH: &str = "data/rgb_to_spectrum_srgb.bin";

/// The project's round-trip target: max ΔE00 below 0.01.
const MAX_DELTA_E00: f64 = 0.01;

/// A round trip counts as exact below this ΔE00: the fit stops at 1e-10 ΔE*ab
/// (`colorimetry`'s `EXACT_RESIDUAL`), with margin for ΔE00's weighting of near-neutral a*.
const EXACT_DELTA_E00: f64 = 1e-8;

/// Arguments of `gen-upsampling-table`.
#[derive(Debug, Args)]
pub(crate) struct GenTableArgs {
    /// Samples per axis in each of the three blocks; the file holds 16 + 36·res³ bytes
    /// (32: 1.1 MiB; pbrt-v4 uses 64, 9 MiB).
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(2..=128))]
    resolution: u32,
    /// Output file [default: data/rgb_to_spectrum_srgb.bin in the workspace].
    #[arg(long)]
    output: Option<PathBuf>,
}

/// Arguments of `upsampling-report`.
#[derive(Debug, Args)]
pub(crate) struct ReportArgs {
    /// Grid points per channel: the report checks steps³ colours evenly spread over [0, 1]³.
    #[arg(long, default_value_t = 33, value_parser = clap::value_parser!(u32).range(2..=257))]
    steps: u32,
}

/// Fits the table and writes it (temporary file, then rename).
pub(crate) fn gen_table(args: &GenTableArgs) -> Result<()> {
    let resolution = args.resolution as usize;
    let path = args.output.clone().unwrap_or_else(|| project_root().join(TABLE_PATH));
    let start = Instant::now();
    let table = build_upsampling_table(resolution);
    let seconds = start.elapsed().as_secs_f64();
    write_atomically(&path, &table.bytes)?;
    println!("wrote {} ({} bytes, resolution {resolution})", path.display(), table.bytes.len());
    println!("fitted {} entries in {seconds:.2} s (one thread)", 3 * resolution.pow(3));
    println!(
        "largest residual {:.3e} ΔE*ab; {} entries above 1e-6 (targets near white that no reflectance in [0, 1] reaches)",
        table.max_residual, table.inexact_entries
    );
    println!("rebuild spectrace (the table is embedded) and run `cargo xtask upsampling-report`");
    Ok(())
}

/// Writes `bytes` to a temporary file beside `path`, then renames it over `path`.
fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    let temporary = path.with_extension("bin.tmp");
    fs::write(&temporary, bytes).with_context(|| format!("writing {}", temporary.display()))?;
    fs::rename(&temporary, path).with_context(|| format!("renaming {} to {}", temporary.display(), path.display()))
}

/// Round-trip error of one colour.
#[derive(Debug, Clone, Copy)]
struct RoundTrip {
    rgb: [f64; 3],
    delta_e00: f64,
    min_reflectance: f64,
    max_reflectance: f64,
}

/// The independent check: the spectrum on its 1 nm grid, through the crate's
/// public `reflectance_to_xyz` (D65, CIE 1931 2°, 1 nm steps, Y of white = 100),
/// compared in CIELAB/CIEDE2000 with the input colour's XYZ (sRGB white as the
/// CIELAB white).
struct Checker {
    d65: colorimetry::DenselySampledSpectrum,
    srgb: &'static RgbColorSpace,
    white: Xyz,
}

impl Checker {
    fn new() -> Result<Self> {
        let srgb = RgbColorSpace::srgb();
        let d65 = Illuminant::D65.spectrum().context("D65 spectrum")?;
        Ok(Self { d65, srgb, white: srgb.rgb_to_xyz(Rgb { r: 1.0, g: 1.0, b: 1.0 }) })
    }

    fn delta_e00(&self, rgb: [f64; 3], xyz: Xyz) -> f64 {
        let target = self.srgb.rgb_to_xyz(Rgb { r: rgb[0], g: rgb[1], b: rgb[2] });
        delta_e_2000(Lab::from_xyz(target, self.white), Lab::from_xyz(xyz, self.white))
    }

    fn reflectance(&self, rgb: [f64; 3], polynomial: &SigmoidPolynomial) -> RoundTrip {
        let spectrum = polynomial.to_spectrum();
        let xyz = reflectance_to_xyz(&spectrum, &self.d65, Observer::Cie1931, &Integration::Step(1.0));
        let xyz = Xyz { x: xyz.x / 100.0, y: xyz.y / 100.0, z: xyz.z / 100.0 };
        RoundTrip {
            rgb,
            delta_e00: self.delta_e00(rgb, xyz),
            min_reflectance: spectrum.min_value(),
            max_reflectance: spectrum.max_value(),
        }
    }
}

/// Upsamples every colour of a steps³ grid, reports time per call and the round-trip error.
pub(crate) fn report(args: &ReportArgs) -> Result<()> {
    let steps = args.steps as usize;
    let level = |i: usize| i as f64 / (steps - 1) as f64;
    let colors: Vec<[f64; 3]> =
        (0..steps.pow(3)).map(|n| [level(n / (steps * steps)), level(n / steps % steps), level(n % steps)]).collect();
    println!("command: cargo xtask upsampling-report --steps {steps}");

    // Warm the lazily built table and forward model so the timing is of calls only.
    let _ = upsample_reflectance([0.5, 0.4, 0.3]);
    let start = Instant::now();
    let polynomials: Vec<SigmoidPolynomial> = colors.iter().map(|&rgb| upsample_reflectance(rgb)).collect();
    let seconds = start.elapsed().as_secs_f64();
    println!(
        "upsample_reflectance: {} colours in {seconds:.3} s on one thread = {:.2} µs per call",
        colors.len(),
        seconds * 1e6 / colors.len() as f64
    );

    let checker = Checker::new()?;
    let trips: Vec<RoundTrip> =
        colors.par_iter().zip(&polynomials).map(|(&rgb, polynomial)| checker.reflectance(rgb, polynomial)).collect();
    let worst = trips.iter().max_by(|a, b| a.delta_e00.total_cmp(&b.delta_e00)).context("empty grid")?;
    let mean = trips.iter().map(|t| t.delta_e00).sum::<f64>() / trips.len() as f64;
    let above = trips.iter().filter(|t| t.delta_e00 >= MAX_DELTA_E00).count();
    let min_reflectance = trips.iter().map(|t| t.min_reflectance).fold(f64::INFINITY, f64::min);
    let max_reflectance = trips.iter().map(|t| t.max_reflectance).fold(f64::NEG_INFINITY, f64::max);
    println!(
        "round trip (D65, CIE 1931 2°, 1 nm, 360–830 nm): max ΔE00 {:.3e} at rgb {:?}, mean ΔE00 {mean:.3e}, {above} colours ≥ {MAX_DELTA_E00}",
        worst.delta_e00, worst.rgb
    );
    let inexact: Vec<&RoundTrip> = trips.iter().filter(|t| t.delta_e00 >= EXACT_DELTA_E00).collect();
    let inexact_min_channel =
        inexact.iter().map(|t| t.rgb[0].min(t.rgb[1]).min(t.rgb[2])).fold(f64::INFINITY, f64::min);
    println!(
        "{} of {} colours not exact (ΔE00 ≥ {EXACT_DELTA_E00:e}); smallest channel among them: {inexact_min_channel}",
        inexact.len(),
        trips.len()
    );
    println!("reflectance range over all spectra: [{min_reflectance}, {max_reflectance}]");

    println!("hard cases:");
    for (name, rgb) in [
        ("black", [0.0, 0.0, 0.0]),
        ("white", [1.0, 1.0, 1.0]),
        ("red", [1.0, 0.0, 0.0]),
        ("green", [0.0, 1.0, 0.0]),
        ("blue", [0.0, 0.0, 1.0]),
        ("cyan", [0.0, 1.0, 1.0]),
        ("magenta", [1.0, 0.0, 1.0]),
        ("yellow", [1.0, 1.0, 0.0]),
    ] {
        let polynomial = upsample_reflectance(rgb);
        let trip = checker.reflectance(rgb, &polynomial);
        let [c0, c1, c2] = polynomial.coefficients();
        println!(
            "  {name:8} ΔE00 {:.3e}  R ∈ [{:.6}, {:.6}]  c = ({c0:.4e}, {c1:.4e}, {c2:.4e})",
            trip.delta_e00, trip.min_reflectance, trip.max_reflectance
        );
    }

    // Light colours: emission_to_xyz / Σȳ is the XYZ with the sRGB white at Y = 1.
    let y_integral: f64 = Observer::Cie1931.cmf().y.values().iter().sum();
    let lights = [[1.0, 1.0, 1.0], [10.0, 5.0, 1.0], [0.2, 0.9, 3.0], [0.0, 0.0, 7.5], [100.0, 0.0, 0.0]];
    let mut worst_light: f64 = 0.0;
    for rgb in lights {
        let spectrum = upsample_illuminant_spectrum(rgb);
        let xyz = emission_to_xyz(&spectrum, Observer::Cie1931, &Integration::Step(1.0));
        let scale = rgb[0].max(rgb[1]).max(rgb[2]);
        // Compare at unit brightness: CIELAB of a light brighter than the white is extrapolated.
        let xyz = Xyz { x: xyz.x / y_integral / scale, y: xyz.y / y_integral / scale, z: xyz.z / y_integral / scale };
        worst_light = worst_light.max(checker.delta_e00(rgb.map(|c| c / scale), xyz));
    }
    println!("upsample_illuminant_spectrum: max ΔE00 {worst_light:.3e} over {} light colours", lights.len());

    ensure!(
        worst.delta_e00 < MAX_DELTA_E00 && min_reflectance >= 0.0 && max_reflectance <= 1.0,
        "round trip misses its target: max ΔE00 {} (must be < {MAX_DELTA_E00}), reflectance range [{min_reflectance}, {max_reflectance}] (must be within [0, 1])",
        worst.delta_e00
    );
    Ok(())
}
