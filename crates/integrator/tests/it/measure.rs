//! Illuminance sensors (`integrator::measure`) against analytic illuminance: a point light over a plane
//! (direct light, exact per sample), and the interreflection of a closed grey cube (CIE 171:2006 case 5.8,
//! the quick form; `cargo xtask validate --only cie171` runs the full cases).

use std::sync::atomic::AtomicBool;

use glam::Vec3;
use integrator::{MeasureOptions, Measurement, SensorPoint, measure};

use crate::scene;

fn point(name: &str, position: Vec3, normal: Vec3) -> SensorPoint {
    SensorPoint { name: name.into(), position, normal }
}

fn run(json: &str, points: &[SensorPoint], options: &MeasureOptions) -> Vec<Measurement> {
    measure(&scene(json), points, options, &|_| {}, &AtomicBool::new(false)).unwrap_or_else(|e| panic!("{e}"))
}

/// 100 cd, 2 m above a plane: E = I h / d³ at points on the plane (which lie on it and must not be shadowed
/// by it), exact per sample (one delta light, fixed lanes, a black plane).
#[test]
fn a_point_light_over_a_plane_gives_i_h_over_d_cubed() {
    let json = r#"{
        "lights": [{"type": "point", "position": [0, 0, 2], "spectrum": "D65", "intensity": 100, "unit": "cd"}],
        "materials": {"black": {"model": "diffuse", "base_color": 0}},
        "objects": [{"type": "quad", "corner": [-5, -5, 0], "edge_u": [10, 0, 0], "edge_v": [0, 10, 0], "material": "black"}]
    }"#;
    let points = [
        point("below", Vec3::ZERO, Vec3::Z),
        point("off axis", Vec3::new(1.5, 0.0, 0.0), Vec3::new(0.0, 0.0, 3.0)),
        point("tilted", Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, -1.0, 1.0)),
        point("facing away", Vec3::new(0.0, 0.0, 0.5), -Vec3::Z),
    ];
    // Fixed wavelength lanes (calibrated to a white): every sample of a delta light is then exact; hero
    // wavelengths would add colour noise to each sample.
    let spectral = integrator::SpectralMode::Bins(16);
    let options = MeasureOptions { spp: Some(64), seed: 1, threads: Some(2), spectral, ..Default::default() };
    let m = run(json, &points, &options);
    let (h, d) = (2.0f64, (1.5f64 * 1.5 + 4.0).sqrt());
    // The tilted sensor's normal (0, −1, 1)/√2 against the direction to the light (0, −1, 2)/√5.
    let tilted = 100.0 / 5.0 * (3.0 / (2.0f64.sqrt() * 5.0f64.sqrt()));
    for (got, want) in [(m[0], 100.0 / 4.0), (m[1], 100.0 * h / d.powi(3)), (m[2], tilted)] {
        assert!((got.illuminance / want - 1.0).abs() < 1e-4, "{got:?} against {want}");
        assert!(got.std_error < 1e-4 * want, "one delta light: no variance, {got:?}");
    }
    // Facing down, it sees the black plane only (and the tilted one sees part of it: a grey plane would add
    // its reflected light there).
    assert_eq!(m[3].illuminance, 0.0, "{:?}", m[3]);
    // D65 light: the irradiance's CCT is D65's, 6504 K.
    let cct = m[0].cct().unwrap_or_else(|| panic!("no CCT for {:?}", m[0]));
    assert!((cct - 6504.0).abs() < 30.0, "{cct}");
}

/// The closed grey cube of CIE 171 case 5.8 (4 m, reflectance ρ, an isotropic 10 000 lm source at its
/// centre): the indirect illuminance averaged over the faces is ρΦ / (S (1 − ρ)), S = 96 m². One face
/// suffices (symmetry): its mean is the 4 × 4 Gauss–Legendre rule over the face of the measured illuminance
/// less the analytic direct part I h / d³. Debug builds are slow: ρ = 0.5, 2 % per point (the xtask case
/// runs ρ = 0.5 and 0.9 at 1 %).
#[test]
fn a_closed_grey_cube_reflects_rho_phi_over_s_one_minus_rho() {
    let rho = 0.5f64;
    let phi = 10_000.0f64;
    let json = format!(
        r#"{{
        "lights": [{{"type": "point", "position": [0, 0, 0], "spectrum": "E", "intensity": {phi}, "unit": "lm"}}],
        "materials": {{"wall": {{"model": "diffuse", "base_color": {rho}}}}},
        "objects": [
            {{"type": "quad", "corner": [-2, -2, -2], "edge_u": [4, 0, 0], "edge_v": [0, 4, 0], "material": "wall"}},
            {{"type": "quad", "corner": [-2, -2, 2], "edge_u": [0, 4, 0], "edge_v": [4, 0, 0], "material": "wall"}},
            {{"type": "quad", "corner": [-2, -2, -2], "edge_u": [0, 4, 0], "edge_v": [0, 0, 4], "material": "wall"}},
            {{"type": "quad", "corner": [2, -2, -2], "edge_u": [0, 0, 4], "edge_v": [0, 4, 0], "material": "wall"}},
            {{"type": "quad", "corner": [-2, -2, -2], "edge_u": [0, 0, 4], "edge_v": [4, 0, 0], "material": "wall"}},
            {{"type": "quad", "corner": [-2, 2, -2], "edge_u": [4, 0, 0], "edge_v": [0, 0, 4], "material": "wall"}}
        ]
    }}"#
    );
    // 4-point Gauss–Legendre on [−1, 1] (Abramowitz & Stegun 25.4).
    let gl = [
        (-0.861_136_311_6, 0.347_854_845_1),
        (-0.339_981_043_6, 0.652_145_154_9),
        (0.339_981_043_6, 0.652_145_154_9),
        (0.861_136_311_6, 0.347_854_845_1),
    ];
    let mut points = Vec::new();
    for (x, _) in gl {
        for (y, _) in gl {
            // The floor z = −2, seen from above.
            points.push(point("floor", Vec3::new(2.0 * x as f32, 2.0 * y as f32, -2.0), Vec3::Z));
        }
    }
    let options = MeasureOptions { target_relative_error: 0.02, seed: 3, threads: Some(2), ..Default::default() };
    let m = run(&json, &points, &options);
    let intensity = phi / (4.0 * std::f64::consts::PI);
    let mut mean_indirect = 0.0;
    for (k, (got, p)) in m.iter().zip(&points).enumerate() {
        let (wx, wy) = (gl[k / 4].1, gl[k % 4].1);
        let d2 = f64::from(p.position.length_squared());
        let direct = intensity * 2.0 / (d2 * d2.sqrt());
        assert!(got.std_error <= 0.021 * got.illuminance, "{got:?}");
        mean_indirect += (got.illuminance - direct) * wx * wy / 4.0;
    }
    let expected = rho * phi / (96.0 * (1.0 - rho));
    assert!((mean_indirect / expected - 1.0).abs() < 0.02, "indirect mean {mean_indirect}, expected {expected}");
}

/// The standard error is honest: over 12 seeds at a fixed spp, the scatter of the estimates matches the
/// mean reported standard error (within the sampling error of a standard deviation from 12 values, ±40 %).
#[test]
fn std_error_matches_the_scatter_between_seeds() {
    let json = r#"{
        "lights": [{"type": "environment", "spectrum": "D65", "intensity": 1}],
        "materials": {"grey": {"model": "diffuse", "base_color": 0.5}},
        "objects": [{"type": "sphere", "center": [0, 0, 1.2], "radius": 1, "material": "grey"}]
    }"#;
    let points = [point("under", Vec3::ZERO, Vec3::Z)];
    let estimates: Vec<Measurement> = (0..12u64)
        .map(|seed| {
            run(json, &points, &MeasureOptions { spp: Some(512), seed, threads: Some(1), ..Default::default() })[0]
        })
        .collect();
    let n = estimates.len() as f64;
    let mean = estimates.iter().map(|m| m.illuminance).sum::<f64>() / n;
    let scatter = (estimates.iter().map(|m| (m.illuminance - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    let reported = estimates.iter().map(|m| m.std_error).sum::<f64>() / n;
    assert!(scatter > 0.6 * reported && scatter < 1.4 * reported, "scatter {scatter}, reported {reported}");
    // And the mean is right: a unit-luminance sky hidden by a sphere of angular radius asin(1/1.2) above the
    // sensor gives π (1 − sin² α) = π (1 − 1/1.44) from the sky, plus the grey sphere's own light.
    let sky = std::f64::consts::PI * (1.0 - 1.0 / 1.44);
    assert!(mean > sky && mean < sky + 0.5 * std::f64::consts::PI / 1.44 + 4.0 * reported, "{mean} vs {sky}");
}

/// A sensor placed on a floor whose stored height carries rounding (here 1e-6 m above z = 0, as a
/// transformed or rescaled mesh has) is lifted above it by a relative 2⁻¹⁶ of its largest coordinate,
/// whatever its normal's axis, so the floor does not shadow it.
#[test]
fn a_sensor_on_a_rounded_floor_is_not_shadowed_by_it() {
    let json = r#"{
        "lights": [{"type": "point", "position": [4, 4, 2], "spectrum": "E", "intensity": 100, "unit": "cd"}],
        "materials": {"black": {"model": "diffuse", "base_color": 0}},
        "objects": [{"type": "quad", "corner": [-10, -10, 0.000001], "edge_u": [20, 0, 0], "edge_v": [0, 20, 0], "material": "black"}]
    }"#;
    let spectral = integrator::SpectralMode::Bins(16);
    let options = MeasureOptions { spp: Some(4), seed: 1, threads: Some(1), spectral, ..Default::default() };
    let m = run(json, &[point("floor", Vec3::new(4.0, 4.0, 0.0), Vec3::Z)], &options);
    assert!((m[0].illuminance / 25.0 - 1.0).abs() < 1e-3, "{:?}", m[0]);
}
