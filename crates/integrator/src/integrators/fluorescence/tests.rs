//! The path tracer's fluorescence against analytic answers, per wavelength: camera paths are traced at one
//! film wavelength λ_out in every lane (density 1), so the film's estimate (1/N) Σ L_j / p_j of a sample is
//! an estimate of the radiance at λ_out itself.

use std::path::Path;

use colorimetry::{DenselySampledSpectrum, SampledWavelengths};
use geometry::Ray;
use glam::Vec3;

use super::*;
use crate::integrators::{Kernel, PathTracer, RayCount};
use crate::options::PathOptions;
use crate::sampling::{Rng, Sampler};
use crate::scene::RenderScene;

const N: usize = 4;

fn scene(json: &str) -> RenderScene {
    let desc = geometry::parse_manifest(json, Path::new("."), "<test>").expect("test manifest parses");
    RenderScene::from_description(desc).expect("test scene assembles")
}

/// A sphere of material `material` (JSON) at the origin seen from (0, 0, 4), lit by `lights` (JSON).
fn sphere_scene(material: &str, lights: &str) -> RenderScene {
    scene(&format!(
        r#"{{"camera": {{"position": [0, 0, 4], "look_at": [0, 0, 0], "vfov_deg": 40, "width": 4, "height": 4}},
            "lights": {lights},
            "materials": {{"m": {material}}},
            "objects": [{{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m"}}]}}"#
    ))
}

/// A brightener-like coating: excitation 0.4 over 330–400 nm (ramps of 20 nm), emission peaked at 440 nm,
/// yield 0.9, on a reflectance 0.5.
const COATED: &str = r#"{"model": "diffuse", "base_color": 0.5, "fluorescence": {
    "excitation": {"samples": [[310, 0], [330, 0.4], [400, 0.4], [420, 0]]},
    "emission": {"samples": [[400, 0], [440, 1], [500, 0]]}, "yield": 0.9}}"#;

/// Mean and standard error of `samples` estimates of the radiance at `lambda_out` along `ray`.
fn estimate(
    tracer: &PathTracer<'_, N>,
    sensor: &crate::film::Sensor<N>,
    ray: &Ray,
    lambda_out: f32,
    samples: u64,
) -> (f64, f64) {
    let (mut sum, mut sum2) = (0.0f64, 0.0f64);
    let mut count = RayCount::default();
    for i in 0..samples {
        let mut sampler = Sampler::Independent(Rng::new(7, u64::from(lambda_out.to_bits()), i));
        let mut lambda = SampledWavelengths::<N>::from_parts([lambda_out; N], [1.0; N]);
        let r = tracer.li(ray, &mut lambda, sensor, &mut sampler, &mut count, &mut Vec::new());
        let pdf = lambda.pdf();
        let v: f64 =
            (0..N).filter(|&j| pdf[j] > 0.0).map(|j| f64::from(r.l[j]) / f64::from(pdf[j])).sum::<f64>() / N as f64;
        sum += v;
        sum2 += v * v;
    }
    let n = samples as f64;
    let mean = sum / n;
    (mean, ((sum2 / n - mean * mean).max(0.0) / (n - 1.0)).sqrt())
}

/// The furnace: a fluorescent Lambertian sphere in a uniform environment E sends back
/// ρ(λ) E(λ) + ∫ k(λ_in, λ) E(λ_in) dλ_in, k = q a(λ_in) e(λ) λ_in/λ (photon yield), whichever the direction.
/// Returns the largest relative error over the wavelengths checked and the largest error in standard errors.
fn furnace_errors(wrong_pdf: bool) -> (f64, f64) {
    let scene = sphere_scene(COATED, r#"[{"type": "environment", "spectrum": "D65", "intensity": 1}]"#);
    let (mut tracer, sensor) = PathTracer::<N>::new(&scene, None, &PathOptions::default());
    tracer.fluorescence_tables_mut().wrong_pdf = wrong_pdf;
    let m = &scene.materials[0];
    let e = crate::scene::emitter_spectra(&scene)[0].clone();
    // D65 is tabulated from 300 nm: the environment must reach the excitation there.
    assert!(e.lambda_min() <= 300.0 && e.eval(320.0) > 0.0);
    let fluoresced = m.fluorescence.as_ref().expect("fluorescent").reemitted_radiance(&e);
    let rho = m.lambertian_reflectance();
    let ray = Ray { origin: Vec3::new(0.0, 0.0, 4.0), dir: Vec3::new(0.05, -0.1, -1.0) };
    let mut worst = (0.0f64, 0.0f64);
    // 380: reflection only (no emission there); 420–480: mostly re-emitted light; 600: reflection only.
    for lambda in [380.0f32, 420.0, 440.0, 460.0, 480.0, 600.0] {
        let l = f64::from(lambda);
        let expected = rho.eval(l) * e.eval(l) + fluoresced.eval(l);
        let (mean, se) = estimate(&tracer, &sensor, &ray, lambda, 40_000);
        let rel = (mean / expected - 1.0).abs();
        // Where only reflection contributes every sample is the same up to float rounding (se ≈ 0): a floor.
        let z = (mean - expected).abs() / se.max(1e-6 * expected);
        if !wrong_pdf {
            // The estimate is precise enough for the 0.5 % check to mean something.
            assert!(se < 0.0015 * expected, "{lambda} nm: standard error {se} of {expected}");
            println!(
                "{lambda} nm: {mean:.5} ± {se:.5}, expected {expected:.5} ({:+.3} %)",
                100.0 * (mean / expected - 1.0)
            );
        }
        worst = (worst.0.max(rel), worst.1.max(z));
    }
    worst
}

#[test]
fn fluorescent_furnace_matches_the_analytic_radiance_per_wavelength() {
    // Each wavelength's mean lies within 0.5 % of ρE + ∫kE (the reference's own 1 nm midpoint quadrature of a
    // piecewise-linear excitation is exact to far below that) and within 4.5 standard errors (six wavelengths:
    // a two-sided 4.5σ test has a family-wise false-alarm rate of 4e-5).
    let (rel, z) = furnace_errors(false);
    assert!(rel < 0.005, "largest relative error {rel}");
    assert!(z < 4.5, "largest error {z} standard errors");
}

#[test]
fn fluorescent_furnace_fails_with_a_wrong_wavelength_pdf() {
    // The same check with the λ_in density reported as uniform over 300–830 nm while λ_in is drawn from the
    // excitation: the re-emitted part is then off by the ratio of the densities, far beyond the tolerances.
    let (rel, z) = furnace_errors(true);
    assert!(rel > 0.05 && z > 4.5, "a wrong pdf went unnoticed: {rel} relative, {z} standard errors");
}

/// L = L_e + ρ L + ∫ k(λ_in, λ) L(λ_in) dλ_in on every whole nanometre from 300 to 830, by iteration from L_e
/// (converges: no wavelength sends back more than it receives, and the Stokes shift loses energy).
fn enclosure_radiance(m: &materials::Material, le: &DenselySampledSpectrum) -> Vec<f64> {
    let f = m.fluorescence.as_ref().expect("fluorescent");
    let rho = m.lambertian_reflectance();
    let grid: Vec<f32> = (300..=830).map(|l| l as f32).collect();
    let emitted: Vec<f64> = grid.iter().map(|&l| le.eval(f64::from(l))).collect();
    let kernel: Vec<Vec<f64>> =
        grid.iter().map(|&lo| grid.iter().map(|&li| f64::from(f.kernel(li, lo))).collect()).collect();
    let mut l = emitted.clone();
    for _ in 0..2000 {
        let next: Vec<f64> = (0..grid.len())
            .map(|o| {
                // Trapezoid rule in λ_in over the 1 nm grid.
                let fl: f64 = (0..grid.len())
                    .map(|i| kernel[o][i] * l[i] * if i == 0 || i == grid.len() - 1 { 0.5 } else { 1.0 })
                    .sum();
                emitted[o] + rho.eval(f64::from(grid[o])) * l[o] + fl
            })
            .collect();
        l = next;
    }
    l
}

#[test]
fn closed_fluorescent_enclosure_converges_to_the_balance_of_emission_and_absorption() {
    // The camera inside an emitting, reflecting and fluorescing sphere: the radiance is the same everywhere
    // and solves L = L_e + ρL + ∫kL. With yield 1 and ρ + a = 0.95 at the excitation, a path gains no
    // energy at any bounce, so the series converges; the renderer's sum of up to 64 bounces with Russian
    // roulette must agree per wavelength (6 standard errors: three wavelengths, and the 64-bounce cut
    // leaves 0.95^64 ≈ 4 % of a path that never fluoresced… at most, which the check below bounds too).
    let material = r#"{"model": "diffuse", "base_color": 0.55, "emission": 1.0, "fluorescence": {
        "excitation": {"samples": [[360, 0.4], [420, 0.4], [440, 0]]},
        "emission": {"samples": [[440, 0], [480, 1], [520, 0]]}, "yield": 1.0}}"#;
    let scene = scene(&format!(
        r#"{{"camera": {{"position": [0, 0, 0], "look_at": [0, 0, -1], "vfov_deg": 40, "width": 4, "height": 4}},
            "materials": {{"m": {material}}},
            "objects": [{{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m"}}]}}"#
    ));
    let options = PathOptions { max_depth: Some(1000), ..PathOptions::default() };
    let (tracer, sensor) = PathTracer::<N>::new(&scene, None, &options);
    let m = &scene.materials[0];
    let le = m.emission.clone().expect("emits");
    let reference = enclosure_radiance(m, &le);
    let ray = Ray { origin: Vec3::ZERO, dir: Vec3::new(0.1, 0.2, -1.0) };
    for lambda in [400u32, 480, 600] {
        let expected = reference[(lambda - 300) as usize];
        let (mean, se) = estimate(&tracer, &sensor, &ray, lambda as f32, 20_000);
        println!("{lambda} nm: {mean:.4} ± {se:.4}, expected {expected:.4}");
        assert!(mean.is_finite() && (mean - expected).abs() < 6.0 * se, "{lambda} nm: {mean} ± {se} vs {expected}");
        assert!((mean / expected - 1.0).abs() < 0.02, "{lambda} nm: {mean} vs {expected}");
    }
    // Without the re-emission the enclosure at 480 nm would be L_e / (1 − ρ): the fluorescence is visible.
    assert!(reference[180] > 1.2 / (1.0 - 0.55), "{}", reference[180]);
}

#[test]
fn lambda_in_density_integrates_to_one_and_follows_the_excitation() {
    let scene = sphere_scene(COATED, r#"[{"type": "environment", "spectrum": "D65", "intensity": 1}]"#);
    let (tracer, _) = PathTracer::<N>::new(&scene, None, &PathOptions::default());
    let t = &tracer.fluorescence_tables().materials[0];
    let density = t.classes[0].as_ref().expect("a density");
    let total: f64 = (0..BINS).map(|b| f64::from(density.pdf(LAMBDA_UV_MIN + b as f32 + 0.5))).sum();
    assert!((total - 1.0).abs() < 1e-5, "{total}");
    // Zero where nothing is absorbed, positive throughout the excitation.
    assert_eq!(density.pdf(450.0), 0.0);
    assert!(density.pdf(311.0) > 0.0 && density.pdf(419.5) > 0.0);
    // Samples land inside the excitation.
    for i in 0..100 {
        let (l, p) = density.sample((i as f32 + 0.5) / 100.0);
        assert!((310.0..=420.0).contains(&l) && p > 0.0, "{l} {p}");
    }
    // Fluorescing is chosen where it is emitted, never where it is not.
    assert_eq!(t.choice[(600.0 - LAMBDA_UV_MIN) as usize], 0.0);
    assert!(t.choice[(440.0 - LAMBDA_UV_MIN) as usize] >= MIN_CHOICE);
}
