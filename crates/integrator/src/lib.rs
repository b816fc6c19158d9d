//! `integrator`: turns a scene into an image.
//!
//! Scene assembly (geometry descriptions → spectral materials and lights), the paper's
//! model (`whitted-hall`: Whitted ray tracing with Hall's spectral shading, Bouguer–Beer
//! absorption and the object ambient of Lee, Lee, Lee & Ha 2004), spectral sampling
//! strategies, the XYZ film and EXR/PNG output.
//!
//! **Invariant:** this is the first crate that sees both a mesh and a spectrum; it depends on
//! `colorimetry`, `geometry` and `materials`, and knows nothing of terminals or arguments.
//!
//! Conventions used throughout: `wo` and `wi` point away from the surface; `n` is the
//! geometric normal, `ns` the shading normal; `lambda` wavelengths in nm; `eta` a relative
//! index of refraction; `t` the ray parameter; `sigma_a` an absorption coefficient per
//! scene unit. Lane values are radiance at the lanes' wavelengths (or RGB channels).
//!
//! ```no_run
//! use std::sync::atomic::AtomicBool;
//! use integrator::{RenderOptions, RenderScene, render};
//!
//! let scene = RenderScene::default_scene()?; // the paper's five spheres
//! let options = RenderOptions { width: 64, height: 48, ..RenderOptions::default() };
//! let (image, stats) = render(&scene, &options, &|_| {}, &AtomicBool::new(false))?;
//! assert_eq!(stats.nonfinite_samples, 0);
//! image.write_png(std::path::Path::new("five_spheres.png"), integrator::Display::Srgb)?;
//! # Ok::<(), integrator::Error>(())
//! ```
#![warn(missing_docs)]

mod assembly;
mod auto;
mod camera;
mod envmap;
mod error;
mod exposure;
mod film;
mod film_file;
mod ktx;
mod lights;
#[cfg(test)]
mod material_tests;
mod output;
mod path;
mod pilot;
mod render;
mod sampling;
mod sky;
mod spectral;
mod summary;
mod surface;
mod tangents;
mod texture;
mod whitted;

pub use assembly::{AssemblyOptions, DEFAULT_RESOLUTION, DefaultLights, EnvironmentOption, RenderScene, SkyOption};
pub use auto::choose_auto;
pub use camera::{CameraOptions, UpAxis};
pub use error::{Error, Result};
pub use exposure::{EXR_VIEW_ATTRIBUTE, MIDDLE_GREY, Tonemap, View, auto_exposure_ev, pbr_neutral};
pub use film::{Display, Film, Image, ObjectId};
pub use film_file::{FILM_MAGIC, FILM_VERSION, FilmFile, FilmHeader, Merged, Merger, merge_parts};
pub use output::{OutputFile, OutputKind, check_distinct_outputs, remove_pending_outputs};
pub use pilot::{AutoCandidate, AutoDecision, auto_decision, pilot_strategies};
pub use render::{
    Ambient, Checkpoint, DEFAULT_K_A, Integrator, IntegratorKind, MAX_PIXELS, MAX_SIDE, MAX_SPECTRAL_SAMPLES,
    MAX_THREADS, PathOptions, Progress, RenderControl, RenderOptions, RenderStats, SamplerKind, WavelengthPdf,
    WhittedOptions, part_samples, render, render_film, render_film_with, resolved_spectral,
};
pub use spectral::{MAX_BINS, SpectralMode};
pub use summary::summarize;

/// Spikiness (see `materials::spikiness`) above which a spectrum counts as a line spectrum
/// that coarse wavelength sampling would miss. Measured: F2 1.52, F11 1.01; D50 0.22,
/// D65 0.16; ColorChecker and TCS reflectances below 0.09.
const SPIKY: f64 = 0.5;

/// The spectra that light the scene: point/spot/directional/environment lights, the
/// background and emissive materials (black ones dropped).
pub(crate) fn emitter_spectra(scene: &RenderScene) -> Vec<&colorimetry::DenselySampledSpectrum> {
    let mut lights: Vec<_> = scene.lights.iter().map(|l| &l.spectrum).collect();
    lights.extend(scene.background.iter());
    lights.extend(scene.materials.iter().filter_map(|m| m.emission.as_ref()));
    lights.retain(|l| l.max_value() > 0.0);
    lights
}

/// The white fixed wavelength lanes are calibrated to (`Lanes::bins`): the mean of the
/// scene's emitter spectra, each at luminance 1. With one light spectrum (most scenes) that
/// light's colour comes out exact; with several, their mixture does.
pub(crate) fn scene_white(scene: &RenderScene) -> colorimetry::DenselySampledSpectrum {
    let lights = emitter_spectra(scene);
    if lights.is_empty() {
        return colorimetry::DenselySampledSpectrum::constant(1.0);
    }
    if lights.len() == 1 {
        return lights[0].clone();
    }
    let normalized: Vec<_> = lights.iter().map(|l| materials::luminance_normalized(l)).collect();
    let (lo, hi) = (colorimetry::LAMBDA_MIN as u32, colorimetry::LAMBDA_MAX as u32);
    let mean = (lo..=hi)
        .map(|nm| normalized.iter().map(|s| s.eval(f64::from(nm))).sum::<f64>() / normalized.len() as f64)
        .collect();
    colorimetry::DenselySampledSpectrum::new(f64::from(lo), 1.0, mean).unwrap_or_else(|_| lights[0].clone())
}

/// Whether any light, background or material spectrum of the scene is a line spectrum.
pub fn scene_is_spiky(scene: &RenderScene) -> bool {
    let spiky = |s: &colorimetry::DenselySampledSpectrum| materials::spikiness(s) > SPIKY;
    scene.lights.iter().any(|l| spiky(&l.spectrum))
        || scene.background.as_ref().is_some_and(spiky)
        || scene.materials.iter().any(|m| {
            spiky(&m.diffuse) || spiky(&m.specular) || spiky(&m.transmittance) || m.emission.as_ref().is_some_and(spiky)
        })
}
