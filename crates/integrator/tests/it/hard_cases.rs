//! Hard cases for the paper's model: each renders without NaN/Inf and gives the expected answer.

use integrator::{Ambient, RenderOptions};

use crate::{assert_all_finite, options, render_with, scene};

/// A glass sphere before an equal-energy background, lit by an equal-energy point light: with
/// one emitter spectrum the wavelength lanes are calibrated to it, so the background's Y is
/// exactly 1 at any bin count.
fn glass_sphere_scene(ior: f32, per_unit: f32, camera_z: f32, radius: f32) -> String {
    format!(
        r#"{{ "camera": {{"position": [0, 0, {camera_z}], "look_at": [0, 0, -100], "vfov_deg": 30}},
        "lights": [{{"type": "point", "position": [5, 5, 10], "spectrum": "E", "intensity": 150}}],
        "background": {{"spectrum": "E", "intensity": 1}},
        "materials": {{"glass": {{"diffuse": 0, "ks": 0, "transmission": 1, "transmittance": 1,
                                 "ior": {ior}, "absorption": {{"per_unit": {per_unit}}}}}}},
        "objects": [{{"type": "sphere", "center": [0, 0, 0], "radius": {radius}, "material": "glass"}}] }}"#
    )
}

#[test]
fn index_one_sphere_is_invisible() {
    // IOR 1, k_t = 1, T_s = 1, no reflection, no absorption: every ray passes straight
    // through, so the image equals the background (Y = 1) everywhere.
    let s = scene(&glass_sphere_scene(1.0, 1.0, 5.0, 1.0));
    let (image, stats) = render_with(&s, &options(16, 16));
    assert_all_finite(&image, &stats);
    for p in image.pixels() {
        assert!((p[1] - 1.0).abs() < 1e-5, "{p:?}");
    }
}

#[test]
fn camera_inside_a_glass_sphere_sees_out() {
    // From the centre of a sphere every camera ray leaves at normal incidence: no bending,
    // no total internal reflection, one exit. With t = 0.5 per unit and radius 2 the
    // background arrives attenuated by 0.5² exactly.
    let s = scene(&glass_sphere_scene(1.5, 0.5, 0.0, 2.0));
    let (image, stats) = render_with(&s, &options(8, 8));
    assert_all_finite(&image, &stats);
    for p in image.pixels() {
        assert!((p[1] - 0.25).abs() < 1e-4, "{p:?}");
    }
}

#[test]
fn thick_dense_absorber_goes_black_not_nan() {
    // t = 1e-30 per unit through a sphere of radius 1000: t^b underflows far below f32's
    // smallest value. Pixels through the sphere must be exactly 0, never NaN.
    let s = scene(&glass_sphere_scene(1.3, 1e-30, 5000.0, 1000.0));
    let (image, stats) = render_with(&s, &options(8, 8));
    assert_all_finite(&image, &stats);
    let centre = image.xyz(4, 4);
    assert_eq!(centre[1], 0.0, "{centre:?}");
}

#[test]
fn total_internal_reflection_keeps_energy_inside() {
    // A ray entering a dense sphere (n = 2.4) near its rim refracts steeply; internal rays
    // hitting past the critical angle reflect with the full k_t. Renders stay finite and no
    // pixel exceeds the background (the model has no gain: k_t = 1, T_s = 1, no lights seen).
    let s = scene(&glass_sphere_scene(2.4, 1.0, 4.0, 1.0));
    let (image, stats) = render_with(
        &s,
        &options(24, 24).whitted(|w| {
            w.min_weight = 0.0;
            w.max_depth = Some(30);
        }),
    );
    assert_all_finite(&image, &stats);
    for p in image.pixels() {
        assert!(p[1] <= 1.0 + 1e-4, "{p:?}");
    }
}

#[test]
fn facing_mirrors_stop_at_the_depth_limit() {
    // Two parallel perfect mirrors with the camera between them: the reflected ray bounces
    // forever unless the depth limit stops it. The ray count is bounded by the depth.
    let json = r#"{ "camera": {"position": [0, 0, 0], "look_at": [0, 0, -1], "vfov_deg": 1},
        "lights": [{"type": "point", "position": [0, 0.5, 0], "intensity": 1}],
        "materials": {"mirror": {"diffuse": 0.1, "ks": 1.0, "specular": 1.0}},
        "objects": [
          {"type": "quad", "corner": [-5, -5, -1], "edge_u": [10, 0, 0], "edge_v": [0, 10, 0], "material": "mirror"},
          {"type": "quad", "corner": [-5, -5, 1], "edge_u": [0, 10, 0], "edge_v": [10, 0, 0], "material": "mirror"}
        ] }"#;
    let s = scene(json);
    for depth in [0u32, 5, 20] {
        let (image, stats) = render_with(
            &s,
            &options(1, 1).whitted(|w| {
                w.max_depth = Some(depth);
                w.min_weight = 0.0;
            }),
        );
        assert_all_finite(&image, &stats);
        // One camera ray + `depth` reflections, each with at most one shadow ray (+1 crossing
        // walk if blocked).
        assert!(stats.rays <= u64::from(depth + 1) * 3, "depth {depth}: {} rays", stats.rays);
    }
}

#[test]
fn every_committed_scene_renders_without_nan() {
    // Every scene in scenes/ (manifests, glTF, OBJ), at a tiny size, in both colour modes.
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes");
    let mut files = Vec::new();
    let mut stack = vec![root];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else if matches!(path.extension().and_then(|e| e.to_str()), Some("json" | "gltf" | "glb" | "obj"))
                && !path.starts_with(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/meshes"))
            {
                files.push(path);
            }
        }
    }
    assert!(files.len() >= 6, "expected the committed scenes, found {files:?}");
    let bdpt = integrator::Integrator::Bdpt(integrator::PathOptions {
        sampler: integrator::SamplerKind::Independent,
        ..integrator::PathOptions::default()
    });
    let sppm = integrator::Integrator::Sppm(integrator::SppmOptions {
        path: integrator::PathOptions {
            sampler: integrator::SamplerKind::Independent,
            ..integrator::PathOptions::default()
        },
        photons: Some(500),
        radius: None,
    });
    for path in files {
        let s = integrator::RenderScene::load(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        for spectral in [integrator::SpectralMode::Rgb, integrator::SpectralMode::Auto] {
            let opts = RenderOptions { spectral, ..options(12, 9) }
                .whitted(|w| w.ambient = Ambient::Objects { k_a: 0.1, exponent: 1.0 });
            let (image, stats) = render_with(&s, &opts);
            assert_eq!(stats.nonfinite_samples, 0, "{}", path.display());
            assert!(image.pixels().iter().flatten().all(|v| v.is_finite()), "{}", path.display());
        }
        // Bidirectional path tracing too (a pinhole camera only: light tracing connects to one).
        let opts = RenderOptions {
            spectral: integrator::SpectralMode::Hero { count: 4 },
            spp: 2,
            integrator: bdpt,
            ..options(12, 9)
        };
        match integrator::render(&s, &opts, &|_| {}, &std::sync::atomic::AtomicBool::new(false)) {
            Ok((image, stats)) => {
                assert_eq!(stats.nonfinite_samples, 0, "bdpt: {}", path.display());
                assert!(image.pixels().iter().flatten().all(|v| v.is_finite()), "bdpt: {}", path.display());
            }
            Err(e) => assert!(e.to_string().contains("orthographic"), "bdpt: {}: {e}", path.display()),
        }
        // And photon mapping, over the same walks (its own passes and gathers).
        let opts = RenderOptions { integrator: sppm, ..opts };
        match integrator::render(&s, &opts, &|_| {}, &std::sync::atomic::AtomicBool::new(false)) {
            Ok((image, stats)) => {
                assert_eq!(stats.nonfinite_samples, 0, "sppm: {}", path.display());
                assert!(image.pixels().iter().flatten().all(|v| v.is_finite()), "sppm: {}", path.display());
            }
            Err(e) => assert!(e.to_string().contains("orthographic"), "sppm: {}: {e}", path.display()),
        }
    }
}

#[test]
fn dense_medium_in_a_tiny_scene_keeps_its_optical_depth() {
    // σ_a = 1000 per unit through a sphere of radius 1e-3 (optical depth 2 along the axis):
    // the centre pixel is e^{−2} of the background in every colour mode. Passing σ_a through
    // e^{−σ_a} per unit length (as RGB mode once did) underflowed to black here.
    let json = r#"{ "camera": {"position": [0, 0, 0.01], "look_at": [0, 0, 0], "vfov_deg": 1},
        "lights": [{"type": "point", "position": [0, 0.01, 0.01], "intensity": 0}],
        "background": {"spectrum": "E", "intensity": 1},
        "materials": {"glass": {"diffuse": 0, "ks": 0, "transmission": 1, "transmittance": 1, "ior": 1.0,
                                "absorption": {"sigma_a": 1000}}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 0.001, "material": "glass"}] }"#;
    let s = scene(json);
    for spectral in [integrator::SpectralMode::Bins(16), integrator::SpectralMode::Rgb] {
        let (image, stats) = render_with(&s, &RenderOptions { spectral, ..options(1, 1) });
        assert_all_finite(&image, &stats);
        let y = image.xyz(0, 0)[1];
        assert!((y - (-2.0f32).exp()).abs() < 1e-4, "{spectral}: Y = {y}, expected e^-2");
    }
}
