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
mod error;
mod film;
mod film_file;
mod lights;
mod output;
mod path;
mod render;
mod sampling;
mod spectral;
mod summary;
mod whitted;

pub use assembly::{DEFAULT_RESOLUTION, RenderScene};
pub use error::{Error, Result};
pub use film::{Display, Film, Image, ObjectId};
pub use film_file::{FILM_MAGIC, FILM_VERSION, FilmFile, FilmHeader, Merged, Merger, merge_parts};
pub use output::{OutputFile, OutputKind, check_distinct_outputs, remove_pending_outputs};
pub use render::{
    Ambient, Checkpoint, DEFAULT_K_A, Integrator, IntegratorKind, MAX_PIXELS, MAX_SIDE, MAX_SPECTRAL_SAMPLES,
    MAX_THREADS, PathOptions, Progress, RenderControl, RenderOptions, RenderStats, WavelengthPdf, WhittedOptions,
    part_samples, render, render_film, render_film_with, resolved_spectral,
};
pub use spectral::{MAX_BINS, SpectralMode};
pub use summary::summarize;

/// Spikiness (see `materials::spikiness`) above which a spectrum counts as a line spectrum
/// that coarse wavelength sampling would miss. Measured: F2 1.52, F11 1.01; D50 0.22,
/// D65 0.16; ColorChecker and TCS reflectances below 0.09.
const SPIKY: f64 = 0.5;

/// Wavelength counts `auto` may choose, cheapest first.
const AUTO_CANDIDATES: [usize; 8] = [8, 12, 16, 24, 32, 48, 64, 95];

/// Largest colour error (ΔE00) `auto` accepts for any light × surface spectrum of the scene,
/// against the 1 nm integral: a tenth of a just-noticeable difference.
const AUTO_MAX_DELTA_E: f64 = 0.1;

/// The 5 nm grid over 360–830 nm, on which the CIE tabulates line spectra.
const FINE_BINS: usize = 95;

/// What `--spectral auto` picks for a scene.
///
/// The paper's model (`whitted-hall`): the fewest evenly spaced wavelengths whose colour error
/// is negligible (ΔE00 < 0.1) for every product of a light spectrum with a surface spectrum of
/// the scene, once and twice (two interactions), against the 1 nm integral. Smooth scenes get
/// few wavelengths; line spectra such as F11 need the 5 nm grid.
///
/// The path tracer (`path`):
/// - a dispersive dielectric → `hero:8` (fixed lanes would have to keep one lane per path past
///   the prism and waste the others; hero sampling keeps its hero wavelength, stratified);
/// - otherwise the same bin count as the paper's model: fixed bins add no colour noise and
///   their bias is below ΔE00 0.1 by construction. Measured on the F11 ColorChecker
///   (`docs/path-tracer.md`): `bins:95` costs 1.4–1.9× `hero:8` per sample on the Cornell box
///   but reaches mean ΔE00 0.03 at 1 spp, where `hero:8` needs ~512 spp.
pub fn choose_auto(scene: &RenderScene, integrator: IntegratorKind) -> SpectralMode {
    match integrator {
        IntegratorKind::Path if scene.materials.iter().any(materials::Material::is_dispersive) => {
            SpectralMode::Hero { count: 8 }
        }
        IntegratorKind::WhittedHall | IntegratorKind::Path => SpectralMode::Bins(auto_bins(scene)),
    }
}

/// The spectra that light the scene: point/spot/directional/environment lights, the
/// background and emissive materials (black ones dropped).
fn emitter_spectra(scene: &RenderScene) -> Vec<&colorimetry::DenselySampledSpectrum> {
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

fn auto_bins(scene: &RenderScene) -> usize {
    use colorimetry::{DenselySampledSpectrum, Lab, Xyz, delta_e_2000};
    let lights = emitter_spectra(scene);
    let white = scene_white(scene);
    let mut surfaces = vec![DenselySampledSpectrum::constant(1.0)];
    for m in &scene.materials {
        let used = [(m.kd > 0.0, &m.diffuse), (m.ks > 0.0, &m.specular), (m.is_transmissive(), &m.transmittance)];
        for (on, s) in used {
            if on && !materials::is_flat(s) {
                surfaces.push(s.clone());
                surfaces.push(s.product(s));
            }
        }
    }
    let xyz = colorimetry::relative_xyz;
    // (lit surface spectrum, its light's 1 nm XYZ, its own 1 nm XYZ).
    let cases: Vec<_> = lights
        .iter()
        .flat_map(|l| surfaces.iter().map(move |r| ((*l).clone(), r.product(l))))
        .map(|(light, lit)| {
            let (light_xyz, color) = (xyz(&light), xyz(&lit));
            (lit, light_xyz, color)
        })
        .collect();
    let lab = |c: Xyz, white: Xyz| Lab::from_xyz(c.scaled(1.0 / white.y), white.scaled(1.0 / white.y));
    for n in AUTO_CANDIDATES {
        let lanes = spectral::Lanes::<{ MAX_BINS }>::bins(n, &white);
        let lane_xyz = |s: &DenselySampledSpectrum| {
            let v = lanes.xyz(&lanes.project(s, spectral::SpectrumKind::Emission));
            Xyz { x: v[0].into(), y: v[1].into(), z: v[2].into() }
        };
        // Absolute error: the lanes' colour of each lit surface against its 1 nm colour, both
        // in CIELAB relative to the light's exact white (what the film's XYZ will be judged by).
        let acceptable = cases.iter().all(|(lit, light_xyz, color)| {
            light_xyz.y <= 0.0
                || delta_e_2000(lab(*color, *light_xyz), lab(lane_xyz(lit), *light_xyz)) < AUTO_MAX_DELTA_E
        });
        if acceptable {
            return n;
        }
    }
    FINE_BINS
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
