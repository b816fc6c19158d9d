//! Environment maps end to end: maps written here in code (never third-party HDRIs), read
//! from `.hdr` and `.exr`, rendered with known answers; bad files are errors naming the file.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use colorimetry::{RgbIlluminantSpectrum, RgbToSpectrumTable, Spectrum};
use integrator::{AssemblyOptions, EnvironmentOption, Film, RenderOptions, RenderScene, SpectralMode};

use crate::{assert_all_finite, chain, options};

/// A fresh folder for one test's files.
fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("spectrace-envmap-it-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A Radiance `.hdr` of `width` × `height` texels, rows from the top (RGBE: use values with 8-bit mantissas).
fn write_hdr(path: &Path, width: usize, height: usize, rgb: &[[f32; 3]]) {
    let pixels: Vec<image::Rgb<f32>> = rgb.iter().map(|&c| image::Rgb(c)).collect();
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    image::codecs::hdr::HdrEncoder::new(file).encode(&pixels, width, height).unwrap();
}

/// An OpenEXR file of 32-bit float RGB (any value, NaN and negatives included).
fn write_exr(path: &Path, width: usize, height: usize, rgb: &[[f32; 3]]) {
    exr::prelude::write_rgb_file(path, width, height, |x, y| {
        let c = rgb[y * width + x];
        (c[0], c[1], c[2])
    })
    .unwrap();
}

fn assemble(json: &str, dir: &Path) -> integrator::Result<RenderScene> {
    let desc = geometry::parse_manifest(json, dir, "<test>")?;
    RenderScene::from_description(desc)
}

fn film(scene: &RenderScene, options: &RenderOptions) -> Film {
    let (film, stats) = integrator::render_film(scene, options, &|_| {}, &AtomicBool::new(false)).unwrap();
    assert_all_finite(&film.to_image(), &stats);
    film
}

/// Relative luminance of the spectrum a grey texel `v` becomes (the sigmoid fit of grey is flat to a few
/// 1e-4, so this is `v` to that precision).
fn grey_texel_luminance(v: f32) -> f64 {
    Spectrum::RgbIlluminant(RgbIlluminantSpectrum::from_rgb(RgbToSpectrumTable::srgb(), [v; 3])).luminance()
}

/// A grey diffuse sphere in a uniform environment of 0.5 nits, and in a constant map of the same
/// radiance: the same image (white furnace: a convex sphere sees the environment over its whole
/// hemisphere, L = ρ L_env).
#[test]
fn constant_map_renders_as_the_uniform_environment_of_its_radiance() {
    let dir = temp_dir("constant");
    write_hdr(&dir.join("grey.hdr"), 8, 4, &[[0.5; 3]; 32]);
    // 6 % brighter (9/16, exact in RGBE): the z-test below must reject it.
    write_hdr(&dir.join("brighter.hdr"), 8, 4, &[[0.5625; 3]; 32]);
    let scene = |env: &str| {
        format!(
            r#"{{ "camera": {{"position": [0, 0, 4], "look_at": [0, 0, 0], "vfov_deg": 40}},
            "lights": [{env}],
            "materials": {{"grey": {{"model": "diffuse", "base_color": 0.8}}}},
            "objects": [{{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "grey"}}] }}"#
        )
    };
    let uniform = assemble(&scene(r#"{"type": "environment", "spectrum": "D65", "intensity": 0.5}"#), &dir).unwrap();
    let map = assemble(&scene(r#"{"type": "environment", "map": "grey.hdr"}"#), &dir).unwrap();
    // The texels' spectrum is D65 × the sigmoid fit of grey; its luminance, not exactly 0.5, is the expectation.
    let fit = grey_texel_luminance(0.5) / 0.5;
    assert!((fit - 1.0).abs() < 2e-3, "grey fit {fit}");
    for spectral in [SpectralMode::Bins(16), SpectralMode::Rgb, SpectralMode::Hero { count: 4 }] {
        let opts = RenderOptions { spectral, spp: 256, ..options(8, 8) }.path(|_| {});
        let (a, b) = (film(&uniform, &opts), film(&map, &opts));
        let (ia, ib) = (a.to_image(), b.to_image());
        let (va, vb) = (a.luminance_variance(), b.luminance_variance());
        let mut worst = 0.0f64;
        for (i, (pa, pb)) in ia.pixels().iter().zip(ib.pixels()).enumerate() {
            let (ya, yb) = (f64::from(pa[1]), f64::from(pb[1]));
            // Per-pixel z-test on the difference (Šidák over 64 pixels at family 1e-3: |z| < 4.2), after the
            // grey fit's bias; RGB lanes use the texel's RGB, whose luminance is 0.5 exactly.
            let expected = if spectral == SpectralMode::Rgb { ya } else { ya * fit };
            let sigma = (f64::from(va[i]) + f64::from(vb[i])).sqrt().max(1e-6 * ya);
            let z = (yb - expected) / sigma;
            worst = worst.max(z.abs());
            assert!(z.abs() < 4.2, "{spectral} pixel {i}: map {yb}, uniform {ya} (× fit {expected}), z = {z}");
        }
        // The uniform environment's sphere is ρ L = 0.4 nits (on fixed lanes its estimator has no variance),
        // the background 0.5.
        let centre = 4 * 8 + 4;
        let fixed = spectral != SpectralMode::Hero { count: 4 };
        assert!(!fixed || (f64::from(ia.pixels()[centre][1]) / 0.4 - 1.0).abs() < 1e-5, "{spectral}: centre");
        assert!(!fixed || (f64::from(ia.pixels()[0][1]) / 0.5 - 1.0).abs() < 1e-5, "{spectral}: corner");
        eprintln!("{spectral}: worst |z| {worst:.2}, centre {} ± {}", ib.pixels()[centre][1], vb[centre].sqrt());
    }
    // The test can fail: a map 6 % too bright is rejected by the same per-pixel test.
    let brighter = assemble(&scene(r#"{"type": "environment", "map": "brighter.hdr"}"#), &dir).unwrap();
    let opts = RenderOptions { spectral: SpectralMode::Bins(16), spp: 256, ..options(8, 8) }.path(|_| {});
    let (a, b) = (film(&uniform, &opts), film(&brighter, &opts));
    let (va, vb) = (a.luminance_variance(), b.luminance_variance());
    let worst = (a.to_image().pixels().iter().zip(b.to_image().pixels()).enumerate())
        .map(|(i, (pa, pb))| {
            let sigma = (f64::from(va[i]) + f64::from(vb[i])).sqrt().max(1e-6);
            ((f64::from(pb[1]) - f64::from(pa[1]) * fit) / sigma).abs()
        })
        .fold(0.0, f64::max);
    assert!(worst > 4.2, "a 6 % brighter map passed the test (worst |z| {worst})");
    // The paper's model sees the map through escaping rays exactly as the uniform environment.
    let opts = RenderOptions { spectral: SpectralMode::Bins(16), ..options(8, 8) };
    let (a, b) = (film(&uniform, &opts).to_image(), film(&map, &opts).to_image());
    let (ya, yb) = (f64::from(a.pixels()[0][1]), f64::from(b.pixels()[0][1]));
    assert!((yb / (ya * fit) - 1.0).abs() < 1e-3, "whitted background: map {yb}, uniform {ya}");
    std::fs::remove_dir_all(&dir).ok();
}

/// World direction of texture coordinates (u, v) in the documented convention (`docs/scene-format.md`):
/// φ = 2π u, θ = π v, d = (sin φ sin θ, cos θ, −cos φ sin θ).
fn direction(u: f64, v: f64) -> [f64; 3] {
    let (phi, theta) = (2.0 * std::f64::consts::PI * u, std::f64::consts::PI * v);
    [phi.sin() * theta.sin(), theta.cos(), -phi.cos() * theta.sin()]
}

/// One bright texel of an otherwise black map lights a white Lambertian plane facing +Y with the
/// irradiance E = L Δφ (sin² θ₁ − sin² θ₀) / 2 of that texel's solid angle, L = E/π nits seen from above;
/// a small black sphere placed in the texel's direction shadows the point, one placed opposite does not.
#[test]
fn one_bright_texel_lights_a_plane_from_its_direction_with_the_analytic_irradiance() {
    let dir = temp_dir("texel");
    let (width, height, column, row) = (64usize, 32usize, 12usize, 10usize);
    let mut rgb = vec![[0.0f32; 3]; width * height];
    rgb[row * width + column] = [1024.0; 3];
    write_exr(&dir.join("texel.exr"), width, height, &rgb);
    let pi = std::f64::consts::PI;
    let (t0, t1) = (pi * row as f64 / height as f64, pi * (row + 1) as f64 / height as f64);
    let irradiance =
        grey_texel_luminance(1024.0) * 2.0 * pi / width as f64 * (t1.sin().powi(2) - t0.sin().powi(2)) / 2.0;
    let want = irradiance / pi;
    let d = direction((column as f64 + 0.5) / width as f64, (row as f64 + 0.5) / height as f64);
    let scene = |blocker: Option<[f64; 3]>| {
        let sphere = blocker.map_or(String::new(), |c| {
            format!(
                r#", {{"type": "sphere", "center": [{}, {}, {}], "radius": 0.2, "material": "black"}}"#,
                c[0], c[1], c[2]
            )
        });
        let json = format!(
            r#"{{ "camera": {{"position": [0, 1, 0], "look_at": [0, 0, 0], "up": [0, 0, -1], "vfov_deg": 0.01}},
            "lights": [{{"type": "environment", "map": "texel.exr"}}],
            "materials": {{"white": {{"model": "diffuse", "base_color": 1}}, "black": {{"model": "diffuse", "base_color": 0}}}},
            "objects": [{{"type": "quad", "corner": [-2, 0, -2], "edge_u": [0, 0, 4], "edge_v": [4, 0, 0], "material": "white"}}{sphere}] }}"#
        );
        assemble(&json, &dir).unwrap()
    };
    let opts = RenderOptions { spectral: SpectralMode::Bins(16), spp: 4096, ..options(1, 1) }.path(|_| {});
    let y = |blocker| {
        let f = film(&scene(blocker), &opts);
        (f64::from(f.to_image().pixels()[0][1]), f64::from(f.luminance_variance()[0]).sqrt())
    };
    // The sphere subtends 11.5° from the point, the texel 5.6° × 5.6°: in its direction it hides all of it.
    let (lit, sigma) = y(None);
    let (opposite, sigma_opposite) = y(Some([-d[0], d[1], -d[2]]));
    let (shadowed, _) = y(Some(d));
    eprintln!(
        "one texel: Y = {lit} ± {sigma} (analytic {want}), opposite blocker {opposite}, blocker towards it {shadowed}"
    );
    // 4σ of the estimate, plus 2e-3 for the 16 lanes' calibration to the map's mean spectrum rather than
    // the texel's own (the same D65 × sigmoid up to the fit).
    for (got, s, what) in [(lit, sigma, "lit"), (opposite, sigma_opposite, "blocker opposite")] {
        assert!((got - want).abs() < 4.0 * s + 2e-3 * want, "{what}: Y = {got} ± {s}, analytic {want}");
    }
    assert!(shadowed < 1e-6 * want, "the blocker towards the texel leaves {shadowed}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_map_files_and_keys_are_errors_naming_them() {
    let dir = temp_dir("errors");
    std::fs::write(dir.join("garbage.hdr"), b"#?RADIANCE\nnot really\n").unwrap();
    std::fs::write(dir.join("truncated.exr"), b"v/1\x01\x02\x00\x00\x00").unwrap();
    write_hdr(&dir.join("ok.hdr"), 2, 1, &[[1.0; 3]; 2]);
    let light = |l: &str| {
        format!(
            r#"{{ "camera": {{"position": [0, 0, 4], "look_at": [0, 0, 0], "vfov_deg": 40}}, "lights": [{l}],
            "objects": [{{"type": "sphere", "center": [0, 0, 0], "radius": 1}}] }}"#
        )
    };
    for (l, needle) in [
        (r#"{"type": "environment", "map": "missing.hdr"}"#, "missing.hdr"),
        (r#"{"type": "environment", "map": "garbage.hdr"}"#, "garbage.hdr"),
        (r#"{"type": "environment", "map": "truncated.exr"}"#, "truncated.exr"),
        (r#"{"type": "environment", "map": "ok.png"}"#, "ok.png"),
        (r#"{"type": "environment", "map": "ok.hdr", "spectrum": "D65"}"#, "spectrum"),
        (r#"{"type": "environment", "map": "ok.hdr", "unit": "W"}"#, "unit"),
        (r#"{"type": "environment", "rotation_deg": 90}"#, "rotation_deg"),
        (r#"{"type": "environment", "map": "ok.hdr"}, {"type": "environment", "map": "ok.hdr"}"#, "at most one"),
    ] {
        let err = assemble(&light(l), &dir).map(|_| ()).expect_err(l);
        let message = chain(&err);
        assert!(message.contains(needle), "{l}: {message}");
        eprintln!("{message}");
    }
    // `--env` with a file that is not there.
    let desc = geometry::parse_manifest(&light(r#"{"type": "point", "position": [0, 3, 0]}"#), &dir, "<test>").unwrap();
    let options = AssemblyOptions {
        environment: Some(EnvironmentOption { path: dir.join("nowhere.exr"), intensity: 1.0, rotation_deg: 0.0 }),
        ..Default::default()
    };
    let err = RenderScene::from_description_with(desc, &options).expect_err("missing --env file");
    assert!(chain(&err).contains("nowhere.exr"), "{}", chain(&err));
    std::fs::remove_dir_all(&dir).ok();
}

/// NaN, infinite and negative texels (EXR can hold them) become black with one warning naming the file;
/// the render stays finite.
#[test]
fn nan_infinite_and_negative_texels_are_clamped_with_a_warning() {
    let dir = temp_dir("nan");
    let mut rgb = vec![[0.25f32; 3]; 8];
    rgb[1] = [f32::NAN, 0.0, 0.0];
    rgb[2] = [f32::INFINITY; 3];
    rgb[6] = [-1.0, 0.5, 0.5];
    write_exr(&dir.join("bad.exr"), 4, 2, &rgb);
    let scene = assemble(
        r#"{ "camera": {"position": [0, 0, 4], "look_at": [0, 0, 0], "vfov_deg": 90},
        "lights": [{"type": "environment", "map": "bad.exr", "intensity": 2}],
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1}] }"#,
        &dir,
    )
    .unwrap();
    let warning = scene.warnings.iter().find(|w| w.contains("bad.exr")).expect("a warning names the map");
    assert!(warning.contains("3 of 8 texels"), "{warning}");
    let opts = RenderOptions { spectral: SpectralMode::Hero { count: 4 }, spp: 8, ..options(8, 8) }.path(|_| {});
    let image = film(&scene, &opts).to_image();
    assert!(image.pixels().iter().all(|p| p.iter().all(|v| v.is_finite() && *v >= 0.0)));
    std::fs::remove_dir_all(&dir).ok();
}

/// `--env`: an OBJ file without lights gets the map instead of the default environment and key light,
/// and a manifest's own environment and background are replaced.
#[test]
fn env_option_replaces_default_lights_and_the_files_environment() {
    let dir = temp_dir("option");
    write_hdr(&dir.join("sky.hdr"), 4, 2, &[[2.0; 3]; 8]);
    std::fs::write(dir.join("tri.obj"), "v -1 -1 0\nv 1 -1 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let env_options = |intensity| AssemblyOptions {
        environment: Some(EnvironmentOption { path: dir.join("sky.hdr"), intensity, rotation_deg: 0.0 }),
        ..Default::default()
    };
    let obj_desc = geometry::load_scene(&dir.join("tri.obj")).unwrap();
    let obj = RenderScene::from_description_with(obj_desc.clone(), &env_options(0.25)).unwrap();
    assert!(!obj.warnings.iter().any(|w| w.contains("no light in the file")), "{:?}", obj.warnings);
    assert!(obj.warnings.iter().any(|w| w.contains("--env") && w.contains("sky.hdr")), "{:?}", obj.warnings);
    let info = integrator::summarize(&obj_desc, &obj);
    let lights = info["lights"].as_array().unwrap();
    assert_eq!(lights.len(), 1, "{lights:?}");
    assert!(lights[0]["map"].as_str().unwrap().ends_with("sky.hdr"));
    // A background pixel is the map's 2 × 0.25 = 0.5 nits.
    let opts = RenderOptions { spectral: SpectralMode::Bins(16), spp: 1, ..options(4, 4) }.path(|_| {});
    let image = film(&obj, &opts).to_image();
    let y = f64::from(image.pixels()[0][1]);
    assert!((y / (0.25 * grey_texel_luminance(2.0)) - 1.0).abs() < 1e-3, "background {y}");

    let manifest = r#"{ "camera": {"position": [0, 0, 4], "look_at": [0, 0, 0], "vfov_deg": 40},
        "lights": [{"type": "environment", "intensity": 3}, {"type": "point", "position": [0, 3, 0]}],
        "background": {"spectrum": "D65", "intensity": 7},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1}] }"#;
    let desc = geometry::parse_manifest(manifest, &dir, "<test>").unwrap();
    let replaced = RenderScene::from_description_with(desc.clone(), &env_options(1.0)).unwrap();
    let info = integrator::summarize(&desc, &replaced);
    let kinds: Vec<&str> = info["lights"].as_array().unwrap().iter().map(|l| l["type"].as_str().unwrap()).collect();
    assert_eq!(kinds, ["point", "environment"]);
    assert!(
        replaced.warnings.iter().any(|w| w.contains("replacing the file's 1 environment light(s) and its background"))
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn an_environment_map_is_charged_to_the_scene_memory_budget_before_decoding() {
    let dir = temp_dir("budget");
    // 256×128 texels: ≈ 36 B each kept (RGB, spectrum, density) and ≈ 32 B each while decoding,
    // about 1.2 MB kept and 2.2 MB at the peak.
    write_hdr(&dir.join("sky.hdr"), 256, 128, &vec![[0.5; 3]; 256 * 128]);
    let json = r#"{ "camera": {"position": [0, 0, 4], "look_at": [0, 0, 0], "vfov_deg": 40},
        "lights": [{"type": "environment", "map": "sky.hdr"}],
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1}] }"#;
    let load = |max_memory: u64| {
        let options = geometry::LoadOptions { max_memory, ..geometry::LoadOptions::default() };
        RenderScene::from_description(geometry::parse_manifest_with(json, &dir, "<test>", &options)?)
    };
    let refused = load(1 << 20).err().map(|e| chain(&e)).unwrap_or_default();
    assert!(
        refused.contains("sky.hdr") && refused.contains("256×128 environment map") && refused.contains("memory budget"),
        "{refused}"
    );
    load(4 << 20).unwrap_or_else(|e| panic!("{}", chain(&e)));
    std::fs::remove_dir_all(&dir).ok();
}
