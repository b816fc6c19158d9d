//! The assembled scene: descriptions from the `geometry` crate become a [`RenderScene`] of spectral
//! materials, lights, textures and a camera, decided once before any ray is traced.
//!
//! `assembly` runs the steps (materials, textures, lights, camera); `camera` frames files that
//! have none, choosing among candidate views by `survey`'s cheap pass (which also measures how brightly
//! emitters light what the camera sees); `solids` reads glTF glass on closed meshes as solid; `tangents`
//! supplies glTF's MikkTSpace tangents; `summary` reports what was built.

pub(crate) mod assembly;
pub(crate) mod camera;
pub(crate) mod solids;
pub(crate) mod summary;
pub(crate) mod survey;
pub(crate) mod tangents;

pub use assembly::{
    AssemblyOptions, CIE_SKY_DEFAULT_LUX, CieSkyOption, CieSunOption, DefaultLights, EnvironmentOption, RenderScene,
    SkyOption,
};
pub use camera::{CameraOptions, UpAxis};

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
