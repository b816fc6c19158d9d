//! Fluorescent materials through the public render API: the brightener effect against colorimetry's
//! formula, the spectral modes that can and cannot render re-emission, `auto` and `info`.

use colorimetry::{DenselySampledSpectrum, Integration, Observer, Xyz, emission_to_xyz, reflectance_to_xyz};
use integrator::{Error, Image, Integrator, PathOptions, RenderOptions, SpectralMode};

use crate::{assert_all_finite, render_with, scene};

/// A white sample (reflectance 0.8) with an optical brightener: excitation 0.15 in the UV (320–380 nm, 20 nm
/// ramps), blue emission peaked at 435 nm, quantum yield 0.9.
const BRIGHTENED: &str = r#"{"model": "diffuse", "base_color": 0.8, "fluorescence": {
    "excitation": {"samples": [[300, 0], [320, 0.15], [380, 0.15], [400, 0]]},
    "emission": {"samples": [[400, 0], [435, 1], [470, 0]]}, "yield": 0.9}}"#;

/// The same sample without the brightener.
const PLAIN: &str = r#"{"model": "diffuse", "base_color": 0.8}"#;

/// A sphere of `material` filling the view, in a uniform environment of the named illuminant.
fn sample_scene(material: &str, illuminant: &str) -> String {
    format!(
        r#"{{"camera": {{"position": [0, 0, 2], "look_at": [0, 0, 0], "vfov_deg": 20, "width": 16, "height": 16}},
            "lights": [{{"type": "environment", "spectrum": "{illuminant}", "intensity": 1}}],
            "materials": {{"sample": {material}}},
            "objects": [{{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "sample"}}]}}"#
    )
}

fn hero_options(spp: u32) -> RenderOptions {
    RenderOptions {
        width: 16,
        height: 16,
        integrator: Integrator::Path(PathOptions::default()),
        spectral: SpectralMode::Hero { count: 8 },
        spp,
        seed: 1,
        threads: Some(2),
        ..RenderOptions::default()
    }
}

/// Mean XYZ over the image and the standard error of each channel's mean.
fn mean_xyz(image: &Image) -> ([f64; 3], [f64; 3]) {
    let n = image.pixels().len() as f64;
    let mut mean = [0.0; 3];
    let mut se = [0.0; 3];
    for c in 0..3 {
        let v: Vec<f64> = image.pixels().iter().map(|p| f64::from(p[c])).collect();
        mean[c] = v.iter().sum::<f64>() / n;
        se[c] = (v.iter().map(|x| (x - mean[c]).powi(2)).sum::<f64>() / (n - 1.0) / n).sqrt();
    }
    (mean, se)
}

/// The environment of [`sample_scene`]: the named illuminant at luminance 1, as assembly makes it.
fn environment(illuminant: &str) -> DenselySampledSpectrum {
    materials::luminance_normalized(&materials::named_spectrum(illuminant).expect("a named illuminant"))
}

/// The colour the formula gives the sample of an assembled [`sample_scene`] in a uniform environment `e`:
/// reflected ρ E plus re-emitted ∫ k E dλ_in, each in the film's units (E has Y = 1).
fn formula_xyz(s: &integrator::RenderScene, e: &DenselySampledSpectrum) -> [f64; 3] {
    let m = &s.materials()[0];
    let integration = Integration::Step(1.0);
    let white = emission_to_xyz(e, Observer::Cie1931, &integration);
    let reflected = reflectance_to_xyz(&m.lambertian_reflectance(), e, Observer::Cie1931, &integration).scaled(0.01);
    let fluoresced = match &m.fluorescence {
        Some(f) => emission_to_xyz(&f.reemitted_radiance(e), Observer::Cie1931, &integration).scaled(1.0 / white.y),
        None => Xyz { x: 0.0, y: 0.0, z: 0.0 },
    };
    [reflected.x + fluoresced.x, reflected.y + fluoresced.y, reflected.z + fluoresced.z]
}

fn xy(c: [f64; 3]) -> [f64; 2] {
    let sum = c[0] + c[1] + c[2];
    [c[0] / sum, c[1] / sum]
}

/// The sample's chromaticity minus the illuminant's (a perfect white's) under the same light.
fn shift(c: [f64; 3], white: [f64; 3]) -> [f64; 2] {
    let (a, b) = (xy(c), xy(white));
    [a[0] - b[0], a[1] - b[1]]
}

#[test]
fn brightener_is_bluer_under_d65_than_under_a_by_the_formulas_amount() {
    let mut shifts = Vec::new();
    for illuminant in ["D65", "A"] {
        let e = environment(illuminant);
        let white = formula_xyz(&scene(&sample_scene(r#"{"model": "diffuse", "base_color": 1.0}"#, illuminant)), &e);
        for (material, fluorescent) in [(BRIGHTENED, true), (PLAIN, false)] {
            let s = scene(&sample_scene(material, illuminant));
            let want = formula_xyz(&s, &e);
            let (image, stats) = render_with(&s, &hero_options(64));
            assert_all_finite(&image, &stats);
            let (got, se) = mean_xyz(&image);
            // Each channel within 5 standard errors of the formula (three channels × four renders: a 5σ
            // two-sided test keeps the family-wise false-alarm rate below 1e-5), and the errors small enough
            // that the check means something: 0.2 % of the channel.
            for c in 0..3 {
                assert!(se[c] < 0.002 * want[c], "{illuminant} {fluorescent}: channel {c} se {} of {}", se[c], want[c]);
                assert!(
                    (got[c] - want[c]).abs() < 5.0 * se[c] + 1e-6,
                    "{illuminant} {fluorescent}: XYZ {got:?} ± {se:?}, formula {want:?}"
                );
            }
            let (got_shift, want_shift) = (shift(got, white), shift(want, white));
            println!("{illuminant} fluorescent={fluorescent}: Δxy render {got_shift:?}, formula {want_shift:?}");
            // 0.2 % on each of X, Y, Z moves x and y by at most ~1e-3: the rendered shift matches to that.
            for c in 0..2 {
                assert!((got_shift[c] - want_shift[c]).abs() < 1e-3, "{illuminant}: {got_shift:?} vs {want_shift:?}");
            }
            shifts.push((illuminant, fluorescent, want_shift));
        }
    }
    let find = |i: &str, f: bool| shifts.iter().find(|s| s.0 == i && s.1 == f).expect("rendered").2;
    // The plain sample has a flat reflectance: it is the illuminant's own colour (Δxy = 0 up to rounding).
    for i in ["D65", "A"] {
        let s = find(i, false);
        assert!(s[0].abs() < 1e-9 && s[1].abs() < 1e-9, "{i}: {s:?}");
    }
    // The brightened one moves towards blue (x and y both fall), about 3× (x) and 5× (y) more under D65's
    // UV than under A's (formula: D65 (−0.0033, −0.0069), A (−0.0011, −0.0015); the renders agree to 1e-4).
    let (d65, a) = (find("D65", true), find("A", true));
    assert!(d65[0] < -0.003 && d65[1] < -0.006, "D65 {d65:?}");
    assert!(a[0] < 0.0 && a[1] < 0.0, "A {a:?}");
    assert!(d65[0] < 2.5 * a[0] && d65[1] < 4.0 * a[1], "D65 {d65:?} vs A {a:?}");
}

#[test]
fn fixed_lanes_refuse_a_fluorescent_scene_naming_the_material() {
    let s = scene(&sample_scene(BRIGHTENED, "D65"));
    for spectral in [SpectralMode::Bins(16), SpectralMode::Rgb] {
        let options = RenderOptions { spectral, ..hero_options(1) };
        let e = integrator::render(&s, &options, &|_| {}, &std::sync::atomic::AtomicBool::new(false))
            .expect_err("fixed lanes cannot shift wavelength");
        assert!(matches!(&e, Error::FluorescenceNeedsHero { material, .. } if material == "sample"), "{e}");
        assert!(e.to_string().contains("hero"), "{e}");
    }
    // `auto` picks hero wavelengths for it, and fixed bins for the plain sample.
    assert_eq!(integrator::choose_auto(&s, integrator::IntegratorKind::Path), SpectralMode::Hero { count: 8 });
    let plain = scene(&sample_scene(PLAIN, "D65"));
    assert!(matches!(integrator::choose_auto(&plain, integrator::IntegratorKind::Path), SpectralMode::Bins(_)));
}

#[test]
fn info_lists_fluorescent_materials_under_needs() {
    let json = sample_scene(BRIGHTENED, "D65");
    let desc = geometry::parse_manifest(&json, std::path::Path::new("."), "<test>").expect("parses");
    let s = scene(&json);
    let summary = integrator::summarize(&desc, &s);
    assert_eq!(summary["needs"]["fluorescence"], serde_json::json!(["sample"]));
    assert_eq!(summary["materials"][0]["uses"]["fluorescence"], serde_json::json!("excitation/emission"));
    let plain = sample_scene(PLAIN, "D65");
    let desc = geometry::parse_manifest(&plain, std::path::Path::new("."), "<test>").expect("parses");
    assert_eq!(integrator::summarize(&desc, &scene(&plain))["needs"]["fluorescence"], serde_json::json!([]));
}

#[test]
fn energy_gaining_fluorescence_is_an_error_naming_the_material() {
    let json = sample_scene(
        r#"{"model": "diffuse", "base_color": 0.9, "fluorescence": {
            "excitation": {"samples": [[360, 0.2], [400, 0.2]]}, "emission": {"samples": [[420, 0], [450, 1], [480, 0]]},
            "yield": 1}}"#,
        "D65",
    );
    let desc = geometry::parse_manifest(&json, std::path::Path::new("."), "<test>").expect("parses");
    let Err(e) = integrator::RenderScene::from_description(desc) else { panic!("ρ + a = 1.1 is refused") };
    let msg = crate::chain(&e);
    assert!(msg.contains("material `sample`") && msg.contains("reflectance + excitation"), "{msg}");
}

#[test]
fn a_reradiation_matrix_renders_its_diagonal_and_re_emission() {
    // A 3 × 3 matrix on 400, 450, 500 nm: 0.3 of the energy at 400 nm is re-emitted in the 450 nm cell.
    let dir = std::env::temp_dir().join(format!("spectrace-fluorescence-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    std::fs::write(dir.join("m.csv"), "nm,400,450,500\n400,0.5,0.3,0\n450,0,0.6,0\n500,0,0,0.7\n").expect("write");
    let json = sample_scene(r#"{"model": "diffuse", "fluorescence": {"matrix": "m.csv"}}"#, "E");
    let desc = geometry::parse_manifest(&json, &dir, "<test>").expect("parses");
    let s = integrator::RenderScene::from_description(desc).expect("assembles");
    let m = &s.materials()[0];
    let reflectance: &DenselySampledSpectrum = &m.diffuse;
    assert_eq!(reflectance.eval(450.0), 0.6);
    let want = formula_xyz(&s, &environment("E"));
    let (image, stats) = render_with(&s, &hero_options(64));
    assert_all_finite(&image, &stats);
    let (got, se) = mean_xyz(&image);
    for c in 0..3 {
        assert!((got[c] - want[c]).abs() < 5.0 * se[c] + 1e-6, "{got:?} ± {se:?} vs {want:?}");
    }
    // `base_color` beside a matrix is ambiguous: an error naming the key.
    let json = sample_scene(r#"{"model": "diffuse", "base_color": 0.5, "fluorescence": {"matrix": "m.csv"}}"#, "E");
    let desc = geometry::parse_manifest(&json, &dir, "<test>").expect("parses");
    let Err(e) = integrator::RenderScene::from_description(desc) else { panic!("base_color with a matrix is refused") };
    let msg = crate::chain(&e);
    assert!(msg.contains("material `sample`") && msg.contains("base_color"), "{msg}");
    std::fs::remove_dir_all(&dir).ok();
}
