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
mod light;
mod render;
mod spectral;
mod whitted;

pub use assembly::{DEFAULT_RESOLUTION, RenderScene};
pub use error::{Error, Result};
pub use film::{Display, Image};
pub use render::{Ambient, DEFAULT_K_A, IntegratorKind, Progress, RenderOptions, RenderStats, render};
pub use spectral::{MAX_BINS, SpectralMode};
pub use whitted::ObjectId;

/// Spikiness (see `materials::spikiness`) above which a spectrum counts as a line spectrum
/// that coarse wavelength sampling would miss. Measured: F2 1.52, F11 1.01; D50 0.22,
/// D65 0.16; ColorChecker and TCS reflectances below 0.09.
const SPIKY: f64 = 0.5;

/// Wavelength count `auto` uses for scenes whose spectra are all smooth.
const SMOOTH_BINS: usize = 16;

/// The 5 nm grid over 360–830 nm, on which the CIE tabulates line spectra.
const FINE_BINS: usize = 95;

/// What `--spectral auto` picks for a scene: the cheapest strategy whose error is negligible
/// for the spectra the scene contains. Line spectra (fluorescent lamps) need the full 5 nm
/// grid; smooth spectra are integrated accurately by a few wavelengths.
pub fn choose_auto(scene: &RenderScene, _integrator: IntegratorKind) -> SpectralMode {
    if scene_is_spiky(scene) { SpectralMode::Bins(FINE_BINS) } else { SpectralMode::Bins(SMOOTH_BINS) }
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
