//! The spectral film (`--spectral-exr`): each pixel's radiance at the rendered wavelengths.
//! (The paper's model's film is checked with its grey plane in `paper_model.rs`.)

use std::path::Path;
use std::sync::atomic::AtomicBool;

use integrator::{Error, Integrator, PathOptions, RenderOptions, RenderScene, SpectralMode};
use materials::{luminance_normalized, named_spectrum};

use crate::{assert_all_finite, options, render_with, scene};

/// Check `values` (pixel-major, `lambdas.len()` per pixel) at `pixel` against `expected(λ)`.
pub(crate) fn assert_pixel(lambdas: &[f32], values: &[f32], pixel: usize, expected: impl Fn(f64) -> f64, what: &str) {
    let n = lambdas.len();
    for (i, &lambda) in lambdas.iter().enumerate() {
        let (got, want) = (f64::from(values[pixel * n + i]), expected(f64::from(lambda)));
        assert!((got - want).abs() <= 1e-4 * want.abs() + 1e-6, "{what} at {lambda} nm: {got} vs {want}");
    }
}

#[test]
fn path_tracer_film_is_reflectance_times_the_environment() {
    // A Lambertian patch in a uniform environment returns R(λ) L_e(λ) on every path (the
    // furnace argument), so each pixel of the 6×4 chart (one patch per pixel, patch 1 top
    // left) holds its patch's reflectance times D65 at unit luminance, exactly.
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/reference/colorchecker_d65.json");
    let chart = RenderScene::load(&file).unwrap();
    let options = RenderOptions {
        width: 6,
        height: 4,
        integrator: Integrator::Path(PathOptions::default()),
        spectral: SpectralMode::Bins(16),
        spectral_film: true,
        threads: Some(2),
        ..RenderOptions::default()
    };
    let (image, stats) = render_with(&chart, &options);
    assert_all_finite(&image, &stats);
    let (lambdas, values) = image.spectral().expect("a spectral film");
    assert_eq!(lambdas.len(), 16);
    assert_eq!((lambdas[0], lambdas[15]), (360.0, 830.0));
    let light = luminance_normalized(&named_spectrum("D65").unwrap());
    for pixel in 0..24 {
        let patch = named_spectrum(&format!("colorchecker:{}", pixel + 1)).unwrap();
        assert_pixel(lambdas, values, pixel, |l| patch.eval(l) * light.eval(l), &format!("patch {}", pixel + 1));
    }
}

#[test]
fn a_film_needs_fixed_wavelengths() {
    let chart = scene(
        r#"{ "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "vfov_deg": 30},
        "lights": [{"type": "environment", "spectrum": "D65"}],
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1}] }"#,
    );
    let cases = [
        (Integrator::default(), SpectralMode::Rgb),
        (Integrator::Path(PathOptions::default()), SpectralMode::Rgb),
        (Integrator::Path(PathOptions::default()), SpectralMode::Hero { count: 4 }),
    ];
    for (integrator, spectral) in cases {
        let opts = RenderOptions { integrator, spectral, spectral_film: true, ..options(4, 4) };
        let result = integrator::render(&chart, &opts, &|_| {}, &AtomicBool::new(false));
        assert!(matches!(result, Err(Error::InvalidOption { .. })), "{integrator:?} {spectral}: {result:?}");
    }
    // Without a film there is none to read.
    let (image, _) = render_with(&chart, &options(4, 4));
    assert!(image.spectral().is_none());
}
