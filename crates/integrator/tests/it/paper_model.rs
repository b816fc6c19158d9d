//! The paper's model against answers computed by hand.

use colorimetry::{Illuminant, Integration, Observer};
use integrator::{Ambient, SpectralMode};

use crate::spectral_film::assert_pixel;
use crate::{assert_all_finite, options, render_with, scene};

/// A camera on the z axis looking down −z at whatever is at the origin.
const CAMERA: &str = r#""camera": {"position": [0, 0, 10], "look_at": [0, 0, 0], "vfov_deg": 10}"#;

/// A slab of thickness `b` (two facing quads at z = 0 and z = −b, index 1 so rays go straight
/// through, k_t = 1, no reflection) in front of a uniform background of luminance 1.
fn slab_scene(b: f32, per_unit: f32) -> String {
    format!(
        r#"{{ {CAMERA},
        "lights": [{{"type": "point", "position": [0, 0, 50], "intensity": 0}}],
        "background": {{"spectrum": "E", "intensity": 1}},
        "materials": {{"glass": {{"diffuse": 0, "ks": 0, "transmission": 1, "transmittance": 1,
                                 "ior": 1.0, "absorption": {{"per_unit": {per_unit}}}}}}},
        "objects": [
          {{"type": "quad", "corner": [-5, -5, 0], "edge_u": [10, 0, 0], "edge_v": [0, 10, 0], "material": "glass"}},
          {{"type": "quad", "corner": [-5, -5, -{b}], "edge_u": [0, 10, 0], "edge_v": [10, 0, 0], "material": "glass"}}
        ] }}"#
    )
}

#[test]
fn slab_attenuates_by_t_to_the_power_b() {
    // Eq. 8: through b units of a medium keeping t per unit, T = t^b. Flat spectra, so every
    // lane and hence Y carries exactly T (float rounding only: 1e-5).
    for (b, t) in [(1.0f32, 0.95f32), (2.5, 0.95), (4.0, 0.5), (0.25, 0.1)] {
        let s = scene(&slab_scene(b, t));
        let (image, stats) = render_with(&s, &options(3, 3));
        assert_all_finite(&image, &stats);
        let y = image.xyz(1, 1)[1];
        assert!((y - t.powf(b)).abs() < 1e-5, "b = {b}, t = {t}: Y = {y}, expected {}", t.powf(b));
        // Absorption off: the slab is clear.
        let (clear, _) = render_with(&s, &options(3, 3).whitted(|w| w.absorption = false));
        assert!((clear.xyz(1, 1)[1] - 1.0).abs() < 1e-5);
    }
}

#[test]
fn white_lit_grey_plane_has_the_xyz_colorimetry_predicts() {
    // A neutral-5 ColorChecker plane facing a D65 point light at distance 10 with intensity
    // 10² (irradiance 1), absorption off, K_a = 0: the Hall diffuse term is F_d(λ) S(λ), so
    // the pixel's XYZ is the reflectance's XYZ under D65 at the same 5 nm grid (bins:95),
    // divided by 100 (the film stores Y = 1 for white), with each of X, Y, Z scaled so that
    // D65 itself has its 1 nm XYZ (the lanes' calibration to the scene's light, the paper's k
    // applied to all three channels).
    let json = format!(
        r#"{{ {CAMERA},
        "lights": [{{"type": "point", "position": [0, 0, 10], "spectrum": "D65", "intensity": 100}}],
        "materials": {{"grey": {{"base_color": "colorchecker:22", "diffuse": 1, "ks": 0}}}},
        "objects": [{{"type": "quad", "corner": [-1, -1, 0], "edge_u": [2, 0, 0], "edge_v": [0, 2, 0], "material": "grey"}}]
        }}"#
    );
    let s = scene(&json);
    let opts = integrator::RenderOptions { spectral: SpectralMode::Bins(95), spectral_film: true, ..options(1, 1) }
        .whitted(|w| {
            w.absorption = false;
            w.ambient = Ambient::None;
        });
    let (image, stats) = render_with(&s, &opts);
    assert_all_finite(&image, &stats);
    let grey = materials::named_spectrum("colorchecker:22").unwrap();
    let d65 = Illuminant::D65.spectrum().unwrap();
    let at = |step: f64| {
        let white = colorimetry::DenselySampledSpectrum::constant(1.0);
        colorimetry::reflectance_to_xyz(&white, &d65, Observer::Cie1931, &Integration::Step(step))
    };
    let (white_1nm, white_5nm) = (at(1.0), at(5.0));
    let coarse = colorimetry::reflectance_to_xyz(&grey, &d65, Observer::Cie1931, &Integration::Step(5.0));
    let expected = colorimetry::Xyz {
        x: coarse.x * white_1nm.x / white_5nm.x,
        y: coarse.y * white_1nm.y / white_5nm.y,
        z: coarse.z * white_1nm.z / white_5nm.z,
    };
    let got = image.xyz(0, 0);
    // The camera ray hits the plane at normal incidence exactly at the light's foot point;
    // f32 lane arithmetic against f64 sums: 1e-4 relative.
    for (g, e) in got.iter().zip([expected.x, expected.y, expected.z]) {
        let e = (e / 100.0) as f32;
        assert!((g - e).abs() < 1e-4 * e.max(1e-3), "got {got:?}, expected {expected:?}/100");
    }
    // Before the XYZ sums: the spectral film holds F_d(λ) S(λ) at each of the 95 wavelengths,
    // S being D65 at unit luminance.
    let (lambdas, values) = image.spectral().expect("a spectral film");
    assert_eq!(lambdas.len(), 95);
    let light = materials::luminance_normalized(&d65);
    assert_pixel(lambdas, values, 0, |l| grey.eval(l) * light.eval(l), "grey plane");
}

#[test]
fn object_ambient_matches_eq_9_by_hand() {
    // Two objects with flat reflectances 0.2 and 0.8 and areas 1 : 3 (quads 1×1 and 1×3, the
    // second out of view), K_a = 0.1, n = 1, a directional light of luminance 1 shining on the
    // back of the visible quad (so it adds no direct light): the pixel sees only ambient,
    // Y = k_d R_1 · K_a · (k_1 R_1 + k_2 R_2) = 0.2 · 0.1 · (0.25·0.2 + 0.75·0.8).
    let json = format!(
        r#"{{ {CAMERA},
        "lights": [{{"type": "directional", "direction": [0, 0, 1], "spectrum": "E", "intensity": 1}}],
        "materials": {{"a": {{"base_color": 0.2, "ks": 0}}, "b": {{"base_color": 0.8, "ks": 0}}}},
        "objects": [
          {{"type": "quad", "corner": [-0.5, -0.5, 0], "edge_u": [1, 0, 0], "edge_v": [0, 1, 0], "material": "a"}},
          {{"type": "quad", "corner": [100, 0, 0], "edge_u": [1, 0, 0], "edge_v": [0, 3, 0], "material": "b"}}
        ] }}"#
    );
    let s = scene(&json);
    let opts = options(1, 1).whitted(|w| w.ambient = Ambient::Objects { k_a: 0.1, exponent: 1.0 });
    let (image, _) = render_with(&s, &opts);
    let expected = 0.2 * 0.1 * (0.25 * 0.2 + 0.75 * 0.8);
    let y = image.xyz(0, 0)[1];
    assert!((y - expected).abs() < 1e-5, "Y = {y}, expected {expected}");
    // The constant ambient of the same strength gives k_d R_1 · K_a.
    let (constant, _) = render_with(&s, &opts.clone().whitted(|w| w.ambient = Ambient::Constant(0.1)));
    assert!((constant.xyz(0, 0)[1] - 0.2 * 0.1).abs() < 1e-5);
}

#[test]
fn default_scene_renders_finite_and_deterministic() {
    let s = integrator::RenderScene::default_scene().unwrap();
    let opts = integrator::RenderOptions { width: 32, height: 24, threads: Some(2), ..Default::default() };
    let (a, stats) = render_with(&s, &opts);
    assert_all_finite(&a, &stats);
    let (b, _) = render_with(&s, &opts);
    assert_eq!(a.pixels(), b.pixels(), "renders are deterministic");
    // Something is lit: the mean luminance is well above the background's 0.02.
    let mean_y: f32 = a.pixels().iter().map(|p| p[1]).sum::<f32>() / a.pixels().len() as f32;
    assert!(mean_y > 0.05, "mean Y {mean_y}");
}

#[test]
fn auto_uses_few_wavelengths_for_smooth_spectra_and_the_5nm_grid_for_f11() {
    let smooth = integrator::RenderScene::default_scene().unwrap();
    let SpectralMode::Bins(n_smooth) = integrator::choose_auto(&smooth, integrator::IntegratorKind::WhittedHall) else {
        panic!("auto chooses bins for whitted-hall");
    };
    assert!(n_smooth <= 32, "{n_smooth}");
    let f11 = scene(&format!(
        r#"{{ {CAMERA},
        "lights": [{{"type": "point", "position": [0, 0, 10], "spectrum": "F11", "intensity": 100}}],
        "materials": {{"red": {{"base_color": "colorchecker:15"}}}},
        "objects": [{{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "red"}}] }}"#
    ));
    assert_eq!(integrator::choose_auto(&f11, integrator::IntegratorKind::WhittedHall), SpectralMode::Bins(95));
}
