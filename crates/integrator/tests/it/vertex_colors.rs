//! Vertex colours end to end: glTF 2.0 §3.7.2.1 and §3.9.2 define the base colour
//! as `baseColorFactor × baseColorTexture × COLOR_0` in linear RGB, so a quad whose vertices are all
//! one colour on a white factor must render as the same quad with that colour as its factor.
//!
//! The assets are written by the tests into a temporary folder: a glTF quad covering [−1, 1]² in the
//! z = 0 plane, seen head on from z = 2 through a lens whose field of view it fills, lit along −z by a
//! directional light, 8×8 pixels.

use std::path::{Path, PathBuf};

use integrator::{Image, RenderScene, SpectralMode};

use crate::{assert_all_finite, options, render_with};

/// Illuminance of the test light (lux).
const E: f64 = 3.0;

fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("spectrace-vertex-colors-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// A COLOR_0 accessor: its bytes (four vertices), type (`VEC3`/`VEC4`), component type, normalized.
struct Colors<'a> {
    bytes: &'a [u8],
    kind: &'a str,
    component_type: u32,
    normalized: bool,
}

fn f32_bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// The quad as glTF (`name`.gltf and .bin in `dir`) with `material` (JSON) and optionally COLOR_0.
fn write_quad(dir: &Path, name: &str, material: &str, colors: Option<&Colors<'_>>) -> PathBuf {
    let mut bin = Vec::new();
    for p in [[-1.0f32, 1.0, 0.0], [1.0, 1.0, 0.0], [1.0, -1.0, 0.0], [-1.0, -1.0, 0.0]] {
        bin.extend(f32_bytes(&p));
    }
    for _ in 0..4 {
        bin.extend(f32_bytes(&[0.0, 0.0, 1.0]));
    }
    for i in [0u16, 3, 2, 0, 2, 1] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    let (color_attribute, color_view, color_accessor) = match colors {
        Some(c) => {
            let offset = bin.len();
            bin.extend_from_slice(c.bytes);
            (
                r#", "COLOR_0": 3"#.to_owned(),
                format!(r#", {{"buffer": 0, "byteOffset": {offset}, "byteLength": {}}}"#, c.bytes.len()),
                format!(
                    r#", {{"bufferView": 2, "componentType": {}, "normalized": {}, "count": 4, "type": "{}"}}"#,
                    c.component_type, c.normalized, c.kind
                ),
            )
        }
        None => Default::default(),
    };
    std::fs::write(dir.join(format!("{name}.bin")), &bin).expect("write bin");
    let gltf = format!(
        r#"{{"asset": {{"version": "2.0"}},
        "buffers": [{{"uri": "{name}.bin", "byteLength": {len}}}],
        "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 96}}, {{"buffer": 0, "byteOffset": 96, "byteLength": 12}}{color_view}],
        "accessors": [
          {{"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]}},
          {{"bufferView": 0, "byteOffset": 48, "componentType": 5126, "count": 4, "type": "VEC3"}},
          {{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}}{color_accessor}],
        "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1{color_attribute}}}, "indices": 2, "material": 0}}]}}],
        "materials": [{material}],
        "nodes": [{{"mesh": 0}}], "scenes": [{{"nodes": [0]}}], "scene": 0}}"#,
        len = bin.len()
    );
    let path = dir.join(format!("{name}.gltf"));
    std::fs::write(&path, gltf).expect("write glTF");
    path
}

/// A manifest around the glTF file `mesh`: the head-on camera and a directional light of E lux along −z.
fn scene_around(dir: &Path, mesh: &Path) -> RenderScene {
    let vfov = 2.0 * 0.5f64.atan().to_degrees();
    let name = mesh.file_stem().and_then(|n| n.to_str()).expect("file name");
    let manifest = format!(
        r#"{{"camera": {{"position": [0, 0, 2], "look_at": [0, 0, 0], "up": [0, 1, 0], "vfov_deg": {vfov}}},
        "lights": [{{"type": "directional", "direction": [0, 0, -1], "spectrum": "D65", "intensity": {E}, "unit": "lux"}}],
        "objects": [{{"type": "mesh", "file": "{name}.gltf"}}]}}"#
    );
    let path = dir.join(format!("{name}.json"));
    std::fs::write(&path, manifest).expect("write manifest");
    RenderScene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// A glTF dielectric (metallic 0) of base colour factor `rgb`.
fn material(rgb: [f32; 3]) -> String {
    format!(
        r#"{{"pbrMetallicRoughness": {{"baseColorFactor": [{}, {}, {}, 1], "metallicFactor": 0, "roughnessFactor": 1}}}}"#,
        rgb[0], rgb[1], rgb[2]
    )
}

/// The path tracer's image (direct light only: a delta light over one plane, so every sample is the
/// same up to rounding and the spectral lanes' choice).
fn render_path(scene: &RenderScene, spectral: SpectralMode) -> Image {
    let opts = integrator::RenderOptions { spectral, spp: 4, ..options(8, 8) }.path(|p| p.max_depth = Some(1));
    let (image, stats) = render_with(scene, &opts);
    assert_all_finite(&image, &stats);
    image
}

fn render_whitted(scene: &RenderScene) -> Image {
    let opts = integrator::RenderOptions { spectral: SpectralMode::Bins(16), spp: 1, ..options(8, 8) };
    let (image, stats) = render_with(scene, &opts);
    assert_all_finite(&image, &stats);
    image
}

/// The largest difference between two images' pixels relative to the larger of the two XYZ values
/// (at least `floor`, so that black channels compare absolutely).
fn max_relative_difference(a: &Image, b: &Image, floor: f32) -> f32 {
    a.pixels()
        .iter()
        .zip(b.pixels())
        .flat_map(|(p, q)| (0..3).map(move |c| (p[c] - q[c]).abs() / p[c].abs().max(q[c].abs()).max(floor)))
        .fold(0.0, f32::max)
}

fn mean_xyz(image: &Image) -> [f32; 3] {
    let n = image.pixels().len() as f32;
    let mut sum = [0.0f32; 3];
    for p in image.pixels() {
        for c in 0..3 {
            sum[c] += p[c] / n;
        }
    }
    sum
}

/// Four vertices of linear `rgb` as a float VEC3 accessor.
fn float_rgb(rgb: [f32; 3]) -> Vec<u8> {
    f32_bytes(&[rgb; 4].concat())
}

#[test]
fn red_vertex_colours_on_a_white_factor_render_as_a_red_factor() {
    let dir = folder("red");
    let red = [1.0f32, 0.0, 0.0];
    let bytes = float_rgb(red);
    let colors = Colors { bytes: &bytes, kind: "VEC3", component_type: 5126, normalized: false };
    let colored = scene_around(&dir, &write_quad(&dir, "colored", &material([1.0; 3]), Some(&colors)));
    let factor = scene_around(&dir, &write_quad(&dir, "factor", &material(red), None));
    let white = scene_around(&dir, &write_quad(&dir, "white", &material([1.0; 3]), None));
    assert!(colored.warnings.iter().any(|w| w.starts_with("vertex colours: 1 mesh(es)")), "{:?}", colored.warnings);
    // RGB lanes carry linear sRGB: factor × COLOR_0 is the same product of numbers either way.
    let (a, b) = (render_path(&colored, SpectralMode::Rgb), render_path(&factor, SpectralMode::Rgb));
    let rgb_lanes = max_relative_difference(&a, &b, 1e-3);
    assert!(rgb_lanes < 1e-5, "RGB lanes: relative difference {rgb_lanes}");
    // Spectral lanes: both are the Jakob–Hanika sigmoid of linear (1, 0, 0) — the material's the exact
    // fit sampled on its 1 nm grid, the vertex palette's the refined fit texels use (round trip ΔE00 <
    // 0.001) — at the same wavelengths, so the images agree to a few tenths of a per cent.
    for spectral in [SpectralMode::Hero { count: 4 }, SpectralMode::Bins(16)] {
        let (a, b) = (render_path(&colored, spectral), render_path(&factor, spectral));
        let (ma, mb) = (mean_xyz(&a), mean_xyz(&b));
        for c in 0..3 {
            assert!((ma[c] - mb[c]).abs() <= 3e-3 * mb[c].abs().max(1e-3), "{spectral:?}: mean XYZ {ma:?} vs {mb:?}");
        }
    }
    // The colour is not ignored: the white quad differs by far (its X is about twice the red's… and its
    // Z, which red lacks, is large).
    let w = mean_xyz(&render_path(&white, SpectralMode::Rgb));
    let m = mean_xyz(&a);
    assert!(w[2] > 10.0 * m[2] && w[1] > 2.0 * m[1], "white {w:?} vs vertex-coloured {m:?}");
    // The paper's model reads base colour factors, not textures or vertex colours (as for textures):
    // its image of the vertex-coloured quad is that of the white one.
    let whitted = max_relative_difference(&render_whitted(&colored), &render_whitted(&white), 1e-3);
    assert_eq!(whitted, 0.0);
}

#[test]
fn normalized_byte_short_and_float_colours_render_alike() {
    // 51/255 = 13107/65535 = 0.2 and 204/255 = 0.8: three encodings of the linear colour (0.2, 0.8, 1),
    // rendered on a white factor, and the same colour as the factor.
    let dir = folder("encodings");
    let rgb = [0.2f32, 0.8, 1.0];
    let float = float_rgb(rgb);
    let bytes: Vec<u8> = [[51u8, 204, 255, 255]; 4].concat();
    let shorts: Vec<u8> = [[13107u16, 52428, 65535, 65535]; 4].concat().iter().flat_map(|v| v.to_le_bytes()).collect();
    let white = material([1.0; 3]);
    let render = |name: &str, colors: &Colors<'_>| {
        render_path(&scene_around(&dir, &write_quad(&dir, name, &white, Some(colors))), SpectralMode::Hero { count: 4 })
    };
    let from_float = render("float", &Colors { bytes: &float, kind: "VEC3", component_type: 5126, normalized: false });
    let from_bytes = render("u8", &Colors { bytes: &bytes, kind: "VEC4", component_type: 5121, normalized: true });
    let from_shorts = render("u16", &Colors { bytes: &shorts, kind: "VEC4", component_type: 5123, normalized: true });
    // The decoded colours are equal up to one f32 rounding of the division, well inside the fit's.
    assert!(max_relative_difference(&from_float, &from_bytes, 1e-3) < 1e-4);
    assert!(max_relative_difference(&from_float, &from_shorts, 1e-3) < 1e-4);
    let factor = render_path(
        &scene_around(&dir, &write_quad(&dir, "factor", &material(rgb), None)),
        SpectralMode::Hero { count: 4 },
    );
    let (ma, mb) = (mean_xyz(&from_bytes), mean_xyz(&factor));
    for c in 0..3 {
        assert!((ma[c] - mb[c]).abs() <= 3e-3 * mb[c], "mean XYZ {ma:?} vs factor {mb:?}");
    }
}

#[test]
fn vertex_colours_multiply_a_coloured_factor_in_linear_rgb() {
    // glTF: base colour = factor × COLOR_0 per channel; factor (0.5, 1, 0.25) × colour (1, 0.5, 0.8)
    // = (0.5, 0.5, 0.2), checked against that product as the factor (RGB lanes: exact up to rounding).
    let dir = folder("product");
    let bytes = float_rgb([1.0, 0.5, 0.8]);
    let colors = Colors { bytes: &bytes, kind: "VEC3", component_type: 5126, normalized: false };
    let product = render_path(
        &scene_around(&dir, &write_quad(&dir, "tinted", &material([0.5, 1.0, 0.25]), Some(&colors))),
        SpectralMode::Rgb,
    );
    let want = render_path(
        &scene_around(&dir, &write_quad(&dir, "want", &material([0.5, 0.5, 0.2]), None)),
        SpectralMode::Rgb,
    );
    let d = max_relative_difference(&product, &want, 1e-3);
    assert!(d < 1e-5, "relative difference {d}");
}

/// The quad as OBJ with a vertex colour per `v` line (`colors`: "r g b", or empty for none) and
/// optionally an MTL material (`mtl`: its statements).
fn write_obj_quad(dir: &Path, name: &str, colors: &str, mtl: Option<&str>) -> PathBuf {
    let mut obj = String::new();
    if let Some(m) = mtl {
        std::fs::write(dir.join(format!("{name}.mtl")), format!("newmtl m\n{m}\n")).expect("write MTL");
        obj.push_str(&format!("mtllib {name}.mtl\nusemtl m\n"));
    }
    for v in ["-1 1 0", "1 1 0", "1 -1 0", "-1 -1 0"] {
        obj.push_str(&format!("v {v} {colors}\n"));
    }
    obj.push_str("f 1 4 3\nf 1 3 2\n");
    let path = dir.join(format!("{name}.obj"));
    std::fs::write(&path, obj).expect("write OBJ");
    path
}

/// A manifest around the OBJ file `mesh`, as [`scene_around`].
fn scene_around_obj(dir: &Path, mesh: &Path) -> RenderScene {
    let vfov = 2.0 * 0.5f64.atan().to_degrees();
    let name = mesh.file_stem().and_then(|n| n.to_str()).expect("file name");
    let manifest = format!(
        r#"{{"camera": {{"position": [0, 0, 2], "look_at": [0, 0, 0], "up": [0, 1, 0], "vfov_deg": {vfov}}},
        "lights": [{{"type": "directional", "direction": [0, 0, -1], "spectrum": "D65", "intensity": {E}, "unit": "lux"}}],
        "objects": [{{"type": "mesh", "file": "{name}.obj"}}]}}"#
    );
    let path = dir.join(format!("{name}.json"));
    std::fs::write(&path, manifest).expect("write manifest");
    RenderScene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn obj_vertex_colours_multiply_kd_and_stand_alone_without_a_material() {
    // A Lambertian quad facing a directional light reads ρ E / π per channel (RGB lanes).
    let dir = folder("obj");
    let k = (E / std::f64::consts::PI) as f32;
    let red_kd = scene_around_obj(&dir, &write_obj_quad(&dir, "kd", "", Some("Kd 1 0 0")));
    let colored = scene_around_obj(&dir, &write_obj_quad(&dir, "colored", "1 0.25 0", Some("Kd 1 0.4 0.5")));
    let bare = scene_around_obj(&dir, &write_obj_quad(&dir, "bare", "1 0 0", None));
    assert!(bare.warnings.iter().any(|w| w.contains("vertex colours and no material")), "{:?}", bare.warnings);
    let srgb = colorimetry::RgbColorSpace::srgb();
    let centre_rgb = |scene: &RenderScene| {
        let image = render_path(scene, SpectralMode::Rgb);
        let [x, y, z] = image.xyz(4, 4).map(f64::from);
        let rgb = srgb.xyz_to_rgb(colorimetry::Xyz { x, y, z });
        [rgb.r as f32, rgb.g as f32, rgb.b as f32]
    };
    let close = |got: [f32; 3], want: [f32; 3], what: &str| {
        // RGB lanes carry the colour exactly; 1e-3 of the value allows f32 rounding and the film's XYZ
        // round trip (as the texture tests allow).
        assert!(got.iter().zip(&want).all(|(g, w)| (g - w).abs() <= 1e-3 * k), "{what}: {got:?} vs {want:?}");
    };
    close(centre_rgb(&red_kd), [k, 0.0, 0.0], "Kd red");
    close(centre_rgb(&bare), [k, 0.0, 0.0], "red vertices without a material");
    // (1, 0.25, 0) × Kd (1, 0.4, 0.5) = (1, 0.1, 0).
    close(centre_rgb(&colored), [k, 0.1 * k, 0.0], "vertex colours × Kd");
}

#[test]
fn vertex_alpha_multiplies_the_material_alpha_of_a_mask() {
    // A MASK quad (cutoff 0.5) whose vertices have alpha 0 is cut out everywhere: the camera sees the
    // white Lambertian floor one unit behind it, which reads E / π (RGB lanes). With alpha 1 the quad
    // hides the floor.
    let dir = folder("alpha");
    let vfov = 2.0 * 0.5f64.atan().to_degrees();
    let k = (E / std::f64::consts::PI) as f32;
    let centre = |alpha: f32| {
        let bytes = f32_bytes(&[[0.5, 0.5, 0.5, alpha]; 4].concat());
        let colors = Colors { bytes: &bytes, kind: "VEC4", component_type: 5126, normalized: false };
        let name = format!("alpha{alpha}");
        let material = r#"{"alphaMode": "MASK", "pbrMetallicRoughness": {"metallicFactor": 0}}"#;
        write_quad(&dir, &name, material, Some(&colors));
        let manifest = format!(
            r#"{{"camera": {{"position": [0, 0, 2], "look_at": [0, 0, 0], "up": [0, 1, 0], "vfov_deg": {vfov}}},
            "lights": [{{"type": "directional", "direction": [0, 0, -1], "spectrum": "D65", "intensity": {E}, "unit": "lux"}}],
            "materials": {{"white": {{"base_color": 1, "diffuse": 1, "ks": 0}}}},
            "objects": [{{"type": "mesh", "file": "{name}.gltf"}},
              {{"type": "quad", "corner": [-3, -3, -1], "edge_u": [6, 0, 0], "edge_v": [0, 6, 0], "material": "white"}}]}}"#
        );
        let path = dir.join(format!("{name}.json"));
        std::fs::write(&path, manifest).expect("write manifest");
        let scene = RenderScene::load(&path).unwrap_or_else(|e| panic!("{e}"));
        render_path(&scene, SpectralMode::Rgb).xyz(4, 4)[1]
    };
    let (cut, kept) = (centre(0.0), centre(1.0));
    // Y of the white floor is ρ E / π with ρ = 1; 1e-3 as in the other RGB-lane checks.
    assert!((cut - k).abs() <= 1e-3 * k, "alpha 0: Y {cut} (floor {k})");
    // The grey quad (base colour 0.5) reflects far less than the white floor.
    assert!(kept < 0.8 * k, "alpha 1: Y {kept} (floor {k})");
}
