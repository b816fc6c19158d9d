//! Photometric units end to end: a light stated in cd, lux, lm or W lights a white
//! Lambertian plane with the luminance photometry predicts, and the film's Y is in nits.

use integrator::SpectralMode;

use crate::{assert_all_finite, options, render_with, scene};

/// A white diffuse quad in the z = 0 plane, seen straight down the z axis from 1 m through a
/// narrow lens (the light's fall-off across the pixel is below 1e-6), and one light.
fn plane_under(light: &str) -> String {
    format!(
        r#"{{ "camera": {{"position": [0, 0, 1], "look_at": [0, 0, 0], "up": [0, 1, 0], "vfov_deg": 0.01}},
        "lights": [{light}],
        "materials": {{"white": {{"base_color": 1, "diffuse": 1, "ks": 0}}}},
        "objects": [{{"type": "quad", "corner": [-1, -1, 0], "edge_u": [2, 0, 0], "edge_v": [0, 2, 0], "material": "white"}}]
        }}"#
    )
}

/// Y of the single pixel, path-traced (a delta light over a lone plane: every sample is exact).
fn path_y(light: &str) -> f64 {
    let s = scene(&plane_under(light));
    let opts = integrator::RenderOptions { spectral: SpectralMode::Bins(16), spp: 2, ..options(1, 1) }.path(|_| {});
    let (image, stats) = render_with(&s, &opts);
    assert_all_finite(&image, &stats);
    f64::from(image.xyz(0, 0)[1])
}

fn assert_close(got: f64, want: f64, what: &str) {
    assert!((got / want - 1.0).abs() < 1e-4, "{what}: Y = {got}, expected {want}");
}

#[test]
fn one_candela_at_one_metre_gives_one_lux_and_one_over_pi_nits() {
    let pi = std::f64::consts::PI;
    // E = I / d² = 1 lux; a white Lambertian surface has L = E / π.
    assert_close(
        path_y(r#"{"type": "point", "position": [0, 0, 1], "spectrum": "D65", "intensity": 1}"#),
        1.0 / pi,
        "1 cd",
    );
    assert_close(
        path_y(r#"{"type": "point", "position": [0, 0, 1], "spectrum": "D65", "intensity": 1, "unit": "cd"}"#),
        1.0 / pi,
        "1 cd, stated",
    );
    // Twice as far: a quarter.
    assert_close(
        path_y(r#"{"type": "point", "position": [0, 0, 2], "spectrum": "D65", "intensity": 1}"#),
        0.25 / pi,
        "1 cd at 2 m",
    );
    // 100 lux from a directional light along −z.
    assert_close(
        path_y(r#"{"type": "directional", "direction": [0, 0, -1], "spectrum": "A", "intensity": 100, "unit": "lux"}"#),
        100.0 / pi,
        "100 lux",
    );
}

#[test]
fn flux_spreads_over_the_sphere_and_watts_go_through_the_spectrum_efficacy() {
    let pi = std::f64::consts::PI;
    // 1000 lm from a point source: I = 1000 / 4π cd.
    let lm = path_y(r#"{"type": "point", "position": [0, 0, 1], "spectrum": "D65", "intensity": 1000, "unit": "lm"}"#);
    assert_close(lm, 1000.0 / (4.0 * pi) / pi, "1000 lm");
    // 1 W of D65: Φ_v = K_m Σ S ȳ / Σ S lm, computed here from the same tables.
    let d65 = colorimetry::Illuminant::D65.spectrum().unwrap();
    let efficacy = colorimetry::luminous_efficacy(&d65);
    assert!((182.5..183.7).contains(&efficacy), "D65 over 360–830 nm: {efficacy} lm/W, 183.1 by hand");
    let w = path_y(r#"{"type": "point", "position": [0, 0, 1], "spectrum": "D65", "intensity": 1, "unit": "W"}"#);
    assert_close(w, efficacy / (4.0 * pi) / pi, "1 W");
    // An irradiance of 1 W/m² of equal-energy light: K_m Σȳ / 471 = 154.95 lux.
    let wm2 =
        path_y(r#"{"type": "directional", "direction": [0, 0, -1], "spectrum": "E", "intensity": 1, "unit": "W"}"#);
    assert_close(wm2, 683.0 * colorimetry::y_sum() / 471.0 / pi, "1 W/m²");
}

#[test]
fn the_paper_model_reads_illuminance_times_reflectance() {
    // Hall's diffuse term is k_d F_d S cos θ: the pixel's Y is the illuminance itself (π times
    // the Lambertian luminance) — the paper's convention, kept; docs/scene-format.md says so.
    let s = scene(&plane_under(r#"{"type": "point", "position": [0, 0, 1], "spectrum": "D65", "intensity": 1}"#));
    let (image, stats) =
        render_with(&s, &integrator::RenderOptions { spectral: SpectralMode::Bins(16), ..options(1, 1) });
    assert_all_finite(&image, &stats);
    assert_close(f64::from(image.xyz(0, 0)[1]), 1.0, "Hall, 1 cd at 1 m");
}

#[test]
fn a_unit_that_does_not_fit_the_light_is_refused_with_its_place() {
    let json = plane_under(r#"{"type": "directional", "direction": [0, 0, -1], "intensity": 1, "unit": "cd"}"#);
    let e = geometry::parse_manifest(&json, std::path::Path::new("."), "<test>").unwrap_err().to_string();
    assert!(e.contains("lights[0].unit") && e.contains("\"lux\""), "{e}");
}

/// An OBJ file's quad (z = 0, facing +z), assembled with a camera 1 m in front of it; `mtl`: the text of an
/// MTL file whose first material the quad uses, else no material.
fn obj_plane(mtl: Option<&str>) -> integrator::RenderScene {
    obj_plane_with(mtl, integrator::DefaultLights::default()).unwrap()
}

/// [`obj_plane`], with the given default lights.
fn obj_plane_with(
    mtl: Option<&str>,
    default_lights: integrator::DefaultLights,
) -> integrator::Result<integrator::RenderScene> {
    let tag = mtl.map_or(0, str::len);
    let dir = std::env::temp_dir().join(format!("spectrace-units-{}-{tag}-{default_lights:?}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let obj = dir.join("plane.obj");
    let material = match mtl {
        Some(text) => {
            std::fs::write(dir.join("plane.mtl"), text).unwrap();
            let name = text.lines().find_map(|l| l.strip_prefix("newmtl ")).expect("a newmtl line");
            format!("mtllib plane.mtl\nusemtl {name}\n")
        }
        None => String::new(),
    };
    std::fs::write(&obj, format!("{material}v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nf 1 2 3 4\n")).unwrap();
    let mut desc = geometry::load_scene(&obj).unwrap();
    desc.camera = Some(geometry::CameraDesc {
        position: glam::Vec3::new(0.0, 0.0, 1.0),
        look_at: glam::Vec3::ZERO,
        up: glam::Vec3::Y,
        vfov_deg: 0.01,
        projection: geometry::Projection::Perspective,
        aspect_ratio: None,
        width: Some(1),
        height: Some(1),
    });
    let _ = std::fs::remove_dir_all(&dir);
    let options = integrator::AssemblyOptions { default_lights, ..Default::default() };
    integrator::RenderScene::from_description_with(desc, &options)
}

#[test]
fn a_file_without_lights_reads_as_light_grey() {
    // Default lighting: environment 0.3 nits + key light 0.5 nits on a white surface facing the camera.
    // A face without material gets an OBJ's default grey, Blender's 0.8 (it was 0.5, a mid grey no OBJ
    // viewer uses): Y = 0.64.
    let s = obj_plane(None);
    let opts = integrator::RenderOptions { spectral: SpectralMode::Bins(16), spp: 4096, ..options(1, 1) }.path(|_| {});
    let (image, stats) = render_with(&s, &opts);
    assert_all_finite(&image, &stats);
    let y = f64::from(image.xyz(0, 0)[1]);
    assert!((y / 0.64 - 1.0).abs() < 0.03, "Y = {y}, expected 0.8 × 0.8");
    // A material its MTL names keeps its colour: Kd 0.25 under the same lights, Y = 0.2.
    let s = obj_plane(Some("newmtl grey\nKd 0.25 0.25 0.25\n"));
    let (image, _) = render_with(&s, &opts);
    let y = f64::from(image.xyz(0, 0)[1]);
    assert!((y / 0.2 - 1.0).abs() < 0.03, "Y = {y}, expected 0.8 × 0.25");
}

#[test]
fn light_env_none_keeps_only_the_key_light_and_no_default_lights_adds_nothing() {
    // `--light-env none`: the key light's 0.5 nits on a white surface alone, over black, on the OBJ's default
    // grey: Y = 0.5 × 0.8.
    let s = obj_plane_with(None, integrator::DefaultLights::KeyOnly).unwrap();
    assert!(s.warnings.iter().any(|w| w.contains("key light") && w.contains("black")), "{:?}", s.warnings);
    let opts = integrator::RenderOptions { spectral: SpectralMode::Bins(16), spp: 256, ..options(1, 1) }.path(|_| {});
    let (image, stats) = render_with(&s, &opts);
    assert_all_finite(&image, &stats);
    let y = f64::from(image.xyz(0, 0)[1]);
    // One delta light on a plane facing the camera: every sample is the same, up to rounding.
    assert!((y / 0.4 - 1.0).abs() < 1e-3, "Y = {y}, expected 0.5 × 0.8");
    // `--no-default-lights`: a file with no light, emitter or background is refused.
    let err = obj_plane_with(None, integrator::DefaultLights::None).err().map(|e| e.to_string()).unwrap_or_default();
    assert!(err.contains("no light"), "{err}");
}

/// Y seen by a 1-pixel path-traced camera at `eye` looking at the origin, where an emissive quad
/// (z = 0, front +z, luminance 2 nits) faces +z; `double_sided` as given, a white plane at z = −1.
fn emitter_seen_from(eye: [f32; 3], double_sided: bool) -> (f64, f64) {
    let json = format!(
        r#"{{ "camera": {{"position": {eye:?}, "look_at": [0, 0, 0], "up": [0, 1, 0], "vfov_deg": 0.01}},
        "materials": {{"glow": {{"base_color": 0, "emission": "D65", "emission_strength": 2, "double_sided": {double_sided}}},
                       "white": {{"base_color": 1, "diffuse": 1, "ks": 0}}}},
        "objects": [
          {{"type": "quad", "corner": [-0.1, -0.1, 0], "edge_u": [0.2, 0, 0], "edge_v": [0, 0.2, 0], "material": "glow"}},
          {{"type": "quad", "corner": [-5, -5, -1], "edge_u": [10, 0, 0], "edge_v": [0, 10, 0], "material": "white"}}
        ] }}"#
    );
    let s = scene(&json);
    let opts = integrator::RenderOptions { spectral: SpectralMode::Bins(16), spp: 64, ..options(1, 1) }.path(|_| {});
    let (image, stats) = render_with(&s, &opts);
    assert_all_finite(&image, &stats);
    // The white plane's luminance straight below the emitter (seen past it at a slant).
    let below = scene(
        &json
            .replace(&format!("{eye:?}"), "[0.5, 0, 1]")
            .replace("\"look_at\": [0, 0, 0]", "\"look_at\": [0.5, 0, -1]"),
    );
    let (lit, _) = render_with(&below, &opts);
    (f64::from(image.xyz(0, 0)[1]), f64::from(lit.xyz(0, 0)[1]))
}

#[test]
fn one_sided_emitters_show_and_light_only_their_front() {
    let (front, _) = emitter_seen_from([0.0, 0.0, 1.0], false);
    assert_close(front, 2.0, "front of a one-sided emitter");
    let (back, plane_one_sided) = emitter_seen_from([0.0, 0.0, -0.5], false);
    assert!(back < 1e-3, "no back-face emission leak: Y = {back}");
    assert!(plane_one_sided < 1e-6, "the plane behind a one-sided emitter stays dark: {plane_one_sided}");
    let (back_two, plane_two_sided) = emitter_seen_from([0.0, 0.0, -0.5], true);
    assert_close(back_two, 2.0, "back of a two-sided emitter");
    assert!(plane_two_sided > 1e-3, "a two-sided emitter lights the plane behind it: {plane_two_sided}");
}
