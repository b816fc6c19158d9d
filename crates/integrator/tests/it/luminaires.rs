//! Luminaires from photometric files (`scenes/luminaires/`, made by `make_webs.py` there): the illuminance a
//! goniometric web gives a white Lambertian floor, read from the film (Y in nits, E = π L), against
//! CIE 171:2006 test case 5.2 and against the asymmetric web's formula.

use std::path::Path;

use integrator::{RenderOptions, RenderScene, SpectralMode};

use crate::{assert_all_finite, options, render_with};

fn folder() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/luminaires"))
}

/// A 4 × 4 m white Lambertian floor (y = 0) under `light`, seen straight down from 0.5 m above the point
/// (x, 0, z) through a lens so narrow that the pixel is a point.
fn floor_scene(light: &str, x: f64, z: f64) -> RenderScene {
    let json = format!(
        r#"{{ "camera": {{"position": [{x}, 0.5, {z}], "look_at": [{x}, 0, {z}], "up": [0, 0, 1], "vfov_deg": 0.01}},
        "lights": [{light}],
        "materials": {{"white": {{"base_color": 1, "diffuse": 1, "ks": 0}}}},
        "objects": [{{"type": "quad", "corner": [-2, 0, -2], "edge_u": [0, 0, 4], "edge_v": [4, 0, 0], "material": "white"}}]
        }}"#
    );
    let desc = geometry::parse_manifest(&json, folder(), "<test>").expect("test manifest parses");
    RenderScene::from_description(desc).expect("test scene assembles")
}

/// Illuminance (lux) at (x, 0, z): π × the path-traced luminance of the floor (a delta light over a lone
/// plane: every sample is exact).
fn lux(light: &str, x: f64, z: f64) -> f64 {
    let s = floor_scene(light, x, z);
    let opts = RenderOptions { spectral: SpectralMode::Bins(16), spp: 2, ..options(1, 1) }.path(|_| {});
    let (image, stats) = render_with(&s, &opts);
    assert_all_finite(&image, &stats);
    std::f64::consts::PI * f64::from(image.xyz(0, 0)[1])
}

/// CIE 171:2006 case 5.2's points (m from the centre) and I₀ h² / d⁴.
fn cie_points() -> Vec<(&'static str, f64, f64, f64)> {
    let h = 3.0;
    [("A", 0.0, 0.0), ("B", 0.5, 0.0), ("C", 1.0, 0.0), ("D", 1.5, 0.0), ("E", 0.5, 0.5)]
        .into_iter()
        .chain([("F", 1.0, 0.5), ("G", 1.5, 0.5), ("H", 1.0, 1.0), ("I", 1.5, 1.0), ("J", 1.5, 1.5)])
        .map(|(name, x, y)| {
            let d2: f64 = x * x + y * y + h * h;
            (name, x, y, 1000.0 * h * h / (d2 * d2))
        })
        .collect()
}

#[test]
fn cie_171_case_5_2_lambertian_point_source_from_an_ies_file() {
    let light = r#"{"type": "point", "position": [0, 3, 0], "ies": "lambert_1000cd.ies"}"#;
    let points = cie_points();
    // The test case's table: A 111.11 lx … J 49.39 lx (I₀ h²/d⁴ gives 49.383 there).
    assert!((points[0].3 - 111.11).abs() < 0.005 && (points[9].3 - 49.39).abs() < 0.01);
    eprintln!("point  x    y    computed   analytic   rel. error  (path, 2 spp, bins:16)");
    for (name, x, y, analytic) in points {
        let e = lux(light, x, y);
        let error = e / analytic - 1.0;
        eprintln!("{name}      {x:.1}  {y:.1}  {e:9.3}  {analytic:9.3}  {error:+.5}");
        assert!(error.abs() < 0.01, "{name}: {e} lx, CIE 171 gives {analytic}");
    }
}

#[test]
fn the_same_luminaire_as_ies_and_ldt_gives_the_same_illuminance() {
    for (ies, ldt, up) in
        [("lambert_1000cd.ies", "lambert_1000cd.ldt", ""), ("asymmetric.ies", "asymmetric.ldt", r#", "up": [1, 0, 0]"#)]
    {
        for (x, z) in [(0.0, 0.0), (1.0, 0.5), (-1.5, 0.7), (0.3, -1.9)] {
            let a = lux(&format!(r#"{{"type": "point", "position": [0, 3, 0], "ies": "{ies}"{up}}}"#), x, z);
            let b = lux(&format!(r#"{{"type": "point", "position": [0, 3, 0], "ies": "{ldt}"{up}}}"#), x, z);
            eprintln!("{ies} vs {ldt} at ({x}, {z}): {a:.4} vs {b:.4} lx");
            assert!((a / b - 1.0).abs() < 1e-4, "({x}, {z}): {ies} {a} lx, {ldt} {b} lx");
        }
    }
}

#[test]
fn an_asymmetric_web_matches_its_analytic_illuminance_at_every_azimuth() {
    // The file's formula (make_webs.py): I(γ, C) = 1000 cd · cos γ · (1 + sin γ (0.4 cos C + 0.3 sin C)).
    let intensity = |gamma: f64, c: f64| 1000.0 * gamma.cos() * (1.0 + gamma.sin() * (0.4 * c.cos() + 0.3 * c.sin()));
    let (h, r) = (3.0f64, 1.5f64);
    // Nadir down, C0 along +X: C90 = C0 × nadir = −Z (counter-clockwise seen from above).
    let light = r#"{"type": "point", "position": [0, 3, 0], "ies": "asymmetric.ies", "up": [1, 0, 0], "intensity": 2}"#;
    let mut seen = Vec::new();
    for c_deg in [0.0f64, 45.0, 90.0, 135.0, 180.0, 222.5, 270.0, 315.0] {
        let c = c_deg.to_radians();
        let (x, z) = (r * c.cos(), -r * c.sin());
        let gamma = (r / h).atan();
        let d2 = r * r + h * h;
        // × 2: `intensity` scales the file's candela.
        let analytic = 2.0 * intensity(gamma, c) * gamma.cos() / d2;
        let e = lux(light, x, z);
        eprintln!("C{c_deg:5.1}: {e:8.3} lx, analytic {analytic:8.3}, {:+.5}", e / analytic - 1.0);
        assert!((e / analytic - 1.0).abs() < 0.005, "C{c_deg}: {e} lx, analytic {analytic}");
        seen.push(e);
    }
    // Asymmetric indeed: C90 and C270 differ by the sin C term, C0 and C180 by the cos C term.
    assert!(seen[2] / seen[6] > 1.2 && seen[0] / seen[4] > 1.3, "{seen:?}");
}

#[test]
fn the_paper_model_sees_the_web_too() {
    // Hall's diffuse term reads the illuminance itself (units.rs): Y = E.
    let light = r#"{"type": "point", "position": [0, 3, 0], "ies": "lambert_1000cd.ies"}"#;
    for (name, x, y, analytic) in cie_points().into_iter().step_by(3) {
        let s = floor_scene(light, x, y);
        let (image, stats) = render_with(&s, &RenderOptions { spectral: SpectralMode::Bins(16), ..options(1, 1) });
        assert_all_finite(&image, &stats);
        let e = f64::from(image.xyz(0, 0)[1]);
        assert!((e / analytic - 1.0).abs() < 0.01, "whitted-hall at {name}: {e} lx, {analytic}");
    }
}

#[test]
fn luminaire_keys_and_files_are_checked() {
    let parse = |light: &str| {
        let json =
            format!(r#"{{"lights": [{light}], "objects": [{{"type": "sphere", "center": [0, 0, 0], "radius": 1}}]}}"#);
        geometry::parse_manifest(&json, folder(), "scene.json").map(|_| ()).unwrap_err().to_string()
    };
    let cases = [
        (
            r#"{"type": "point", "position": [0, 3, 0], "direction": [0, -1, 0]}"#,
            "lights[0].direction: orients a luminaire",
        ),
        (
            r#"{"type": "point", "position": [0, 3, 0], "ies": "asymmetric.ies", "unit": "lm"}"#,
            "lights[0].unit: a luminaire's file",
        ),
        (
            r#"{"type": "point", "position": [0, 3, 0], "ies": "asymmetric.ies", "up": [0, 2, 0]}"#,
            "lights[0].up: must not be parallel",
        ),
        (r#"{"type": "point", "position": [0, 3, 0], "ies": "missing.ies"}"#, "missing.ies"),
        (
            r#"{"type": "point", "position": [0, 3, 0], "ies": "make_webs.py"}"#,
            "make_webs.py:3: `` is not a finite number (the symmetry indicator Isym)",
        ),
        (r#"{"type": "point", "position": [0, 3, 0], "ies": "a.ies", "colour": 1}"#, "colour"),
    ];
    for (light, expected) in cases {
        let e = parse(light);
        assert!(e.contains(expected), "{e}\nexpected: {expected}");
    }
}
