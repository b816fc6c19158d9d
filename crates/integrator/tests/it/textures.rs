//! Image textures end to end: a textured quad, lit by a delta light and seen head on,
//! renders each texel's colour at the pixels the uv mapping predicts; cut-outs, texture
//! transforms and normal maps change exactly the pixels and values they should.
//!
//! The assets are written by the tests into a temporary folder: an OBJ or glTF quad covering
//! [−1, 1]² in the z = 0 plane, uv (0, 0) at its top-left corner (−1, 1), seen from z = 2
//! through a lens whose field of view it fills, 8×8 pixels (4×4 per texel of a 2×2 image).

use std::path::{Path, PathBuf};

use colorimetry::{RgbColorSpace, Xyz, srgb_decode};
use integrator::{RenderScene, SpectralMode};

use crate::{assert_all_finite, chain, options, render_with};

/// Illuminance of the test light (lux): a white Lambertian surface facing it reads E / π.
const E: f64 = 3.0;

/// A fresh folder for one test's files.
fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("spectrace-textures-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

fn write_png(path: &Path, width: u32, height: u32, texels: &[[u8; 4]]) {
    let mut img = image::RgbaImage::new(width, height);
    for (i, p) in img.pixels_mut().enumerate() {
        p.0 = texels[i];
    }
    img.save(path).expect("write PNG");
}

/// `texels` written as `dir/name` (a `width` × `height` PNG) and the glTF `textures`, `samplers` and `images`
/// arrays (JSON text) that read it as texture 0 with nearest filtering.
fn nearest_texture(dir: &Path, name: &str, width: u32, height: u32, texels: &[[u8; 4]]) -> String {
    write_png(&dir.join(name), width, height, texels);
    format!(
        r#""textures": [{{"source": 0, "sampler": 0}}], "samplers": [{{"magFilter": 9728}}], "images": [{{"uri": "{name}"}}]"#
    )
}

/// The quad as OBJ (OBJ's vt has v up, so the top-left corner is vt (0, 1)) with `mtl` as its material.
fn write_obj_quad(dir: &Path, mtl: &str) -> PathBuf {
    std::fs::write(dir.join("quad.mtl"), format!("newmtl m\n{mtl}\n")).expect("write MTL");
    let obj = "mtllib quad.mtl\nusemtl m\n\
               v -1 1 0\nv 1 1 0\nv 1 -1 0\nv -1 -1 0\n\
               vt 0 1\nvt 1 1\nvt 1 0\nvt 0 0\n\
               f 1/1 4/4 3/3\nf 1/1 3/3 2/2\n";
    let path = dir.join("quad.obj");
    std::fs::write(&path, obj).expect("write OBJ");
    path
}

/// The quad as glTF with one material (`material` is its JSON) and the given textures/samplers/images
/// arrays (JSON text); positions, normals, uvs and indices in `quad.bin`.
fn write_gltf_quad(dir: &Path, material: &str, textures: &str, extensions_used: &str) -> PathBuf {
    write_gltf_quad_with_normal(dir, material, textures, extensions_used, [0.0, 0.0, 1.0], QUAD_UVS)
}

/// The quad's uvs, corner by corner (top-left, top-right, bottom-right, bottom-left): u along +x, v down.
const QUAD_UVS: [[f32; 2]; 4] = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];

/// [`write_gltf_quad`] with `normal` as every vertex's normal and `uvs` as the corners' uvs.
fn write_gltf_quad_with_normal(
    dir: &Path,
    material: &str,
    textures: &str,
    extensions_used: &str,
    normal: [f32; 3],
    uvs: [[f32; 2]; 4],
) -> PathBuf {
    let mut bin = Vec::new();
    for p in [[-1.0f32, 1.0, 0.0], [1.0, 1.0, 0.0], [1.0, -1.0, 0.0], [-1.0, -1.0, 0.0]] {
        p.iter().for_each(|v| bin.extend_from_slice(&v.to_le_bytes()));
    }
    for _ in 0..4 {
        normal.iter().for_each(|v| bin.extend_from_slice(&v.to_le_bytes()));
    }
    for uv in uvs {
        uv.iter().for_each(|v| bin.extend_from_slice(&v.to_le_bytes()));
    }
    for i in [0u16, 3, 2, 0, 2, 1] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    std::fs::write(dir.join("quad.bin"), &bin).expect("write bin");
    let gltf = format!(
        r#"{{"asset": {{"version": "2.0"}}, {extensions_used}
        "buffers": [{{"uri": "quad.bin", "byteLength": {len}}}],
        "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 128}}, {{"buffer": 0, "byteOffset": 128, "byteLength": 12}}],
        "accessors": [
          {{"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]}},
          {{"bufferView": 0, "byteOffset": 48, "componentType": 5126, "count": 4, "type": "VEC3"}},
          {{"bufferView": 0, "byteOffset": 96, "componentType": 5126, "count": 4, "type": "VEC2"}},
          {{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}}],
        "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}}, "indices": 3, "material": 0}}]}}],
        "materials": [{material}],
        {textures},
        "nodes": [{{"mesh": 0}}], "scenes": [{{"nodes": [0]}}], "scene": 0}}"#,
        len = bin.len()
    );
    let path = dir.join("quad.gltf");
    std::fs::write(&path, gltf).expect("write glTF");
    path
}

/// A manifest around `mesh` (a file in `dir`): the head-on camera, a directional light of E lux
/// travelling along `light_dir`, and `extra` objects (JSON, each with a leading comma).
fn scene_around(dir: &Path, mesh: &Path, light_dir: [f64; 3], extra: &str) -> RenderScene {
    let vfov = 2.0 * 0.5f64.atan().to_degrees();
    let manifest = format!(
        r#"{{"camera": {{"position": [0, 0, 2], "look_at": [0, 0, 0], "up": [0, 1, 0], "vfov_deg": {vfov}}},
        "lights": [{{"type": "directional", "direction": [{}, {}, {}], "spectrum": "D65", "intensity": {E}, "unit": "lux"}}],
        "materials": {{"white": {{"base_color": 1, "diffuse": 1, "ks": 0}}}},
        "objects": [{{"type": "mesh", "file": "{}"}}{extra}]}}"#,
        light_dir[0],
        light_dir[1],
        light_dir[2],
        mesh.file_name().and_then(|n| n.to_str()).expect("file name"),
    );
    let path = dir.join("scene.json");
    std::fs::write(&path, manifest).expect("write manifest");
    RenderScene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// Linear sRGB of every pixel, path-traced with RGB lanes and direct light only (a delta light over
/// one or two planes: each sample is exact up to rounding).
fn render_rgb(scene: &RenderScene) -> Vec<Vec<[f64; 3]>> {
    render_rgb_spp(scene, 4)
}

/// [`render_rgb`] at `spp` samples per pixel (for stochastic layer choices such as the clear coat's).
fn render_rgb_spp(scene: &RenderScene, spp: u32) -> Vec<Vec<[f64; 3]>> {
    let opts =
        integrator::RenderOptions { spectral: SpectralMode::Rgb, spp, ..options(8, 8) }.path(|p| p.max_depth = Some(1));
    let (image, stats) = render_with(scene, &opts);
    assert_all_finite(&image, &stats);
    let srgb = RgbColorSpace::srgb();
    (0..8)
        .map(|y| {
            (0..8)
                .map(|x| {
                    let [x_, y_, z_] = image.xyz(x, y).map(f64::from);
                    let rgb = srgb.xyz_to_rgb(Xyz { x: x_, y: y_, z: z_ });
                    [rgb.r, rgb.g, rgb.b]
                })
                .collect()
        })
        .collect()
}

fn linear(texel: [u8; 4]) -> [f64; 3] {
    [0, 1, 2].map(|c| srgb_decode(f64::from(texel[c]) / 255.0))
}

fn assert_rgb(got: [f64; 3], want: [f64; 3], tolerance: f64, what: &str) {
    for c in 0..3 {
        assert!((got[c] - want[c]).abs() <= tolerance * want[c].max(0.02), "{what}: got {got:?}, expected {want:?}");
    }
}

const CHECKER: [[u8; 4]; 4] = [[200, 30, 30, 255], [30, 200, 30, 255], [30, 30, 200, 255], [240, 240, 240, 255]];

#[test]
fn checkerboard_texels_render_their_colours_at_the_predicted_pixels() {
    let dir = folder("checker");
    // Each checker square is 2×2 texels, so the bilinear footprint of pixels 1 and 2 of each
    // quadrant stays inside its square (MTL has no nearest filter).
    let texels: Vec<[u8; 4]> = (0..16).map(|i| CHECKER[(i % 4) / 2 + 2 * (i / 8)]).collect();
    write_png(&dir.join("checker.png"), 4, 4, &texels);
    // MTL: map_Kd replaces Kd; the surface is Lambertian, so L = ρ E / π per channel.
    let obj = write_obj_quad(&dir, "Kd 0.8 0.8 0.8\nmap_Kd checker.png");
    let scene = scene_around(&dir, &obj, [0.0, 0.0, -1.0], "");
    let rgb = render_rgb(&scene);
    let k = E / std::f64::consts::PI;
    // Square (i, j) of the image covers pixels 4i..4i+4, 4j..4j+4 (image and render both top-down).
    for (t, texel) in CHECKER.iter().enumerate() {
        let (tx, ty) = (t % 2, t / 2);
        for (px, py) in [(1, 1), (2, 2), (1, 2), (2, 1)] {
            let (x, y) = (4 * tx + px, 4 * ty + py);
            let want = linear(*texel).map(|c| c * k);
            // RGB lanes carry the texel's linear colour exactly; 1e-3 allows f32 rounding.
            assert_rgb(rgb[y][x], want, 1e-3, &format!("texel {t} at pixel ({x}, {y})"));
        }
    }
}

#[test]
fn texture_transform_offset_moves_texels_as_the_extension_says() {
    let dir = folder("transform");
    // Left texel red, right texel green.
    let textures = &nearest_texture(&dir, "two.png", 2, 1, &[[220, 20, 20, 255], [20, 220, 20, 255]]);
    let dominant = |rgb: &[f64; 3]| {
        if rgb[0] > 3.0 * rgb[1] {
            'r'
        } else if rgb[1] > 3.0 * rgb[0] {
            'g'
        } else {
            '?'
        }
    };
    let row = |material: &str, used: &str| -> String {
        let gltf = write_gltf_quad(&dir, material, textures, used);
        let rgb = render_rgb(&scene_around(&dir, &gltf, [0.0, 0.0, -1.0], ""));
        rgb[4].iter().map(dominant).collect()
    };
    let plain = r#"{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0}}"#;
    assert_eq!(row(plain, ""), "rrrrgggg");
    // KHR_texture_transform: uv' = uv + (0.5, 0); with REPEAT the halves swap.
    let shifted = r#"{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"offset": [0.5, 0]}}}, "metallicFactor": 0}}"#;
    let used = r#""extensionsUsed": ["KHR_texture_transform"], "extensionsRequired": ["KHR_texture_transform"],"#;
    assert_eq!(row(shifted, used), "ggggrrrr");
    // Scale 2 along u: four texels across the quad.
    let scaled = r#"{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"scale": [2, 1]}}}, "metallicFactor": 0}}"#;
    assert_eq!(row(scaled, used), "rrggrrgg");
}

/// `KHR_materials_transmission`'s texture multiplies the factor per texel. Left texel R = 255
/// (transmission 1: thin glass, which under a delta light and one bounce shows almost nothing), right texel
/// R = 0 (opaque plastic). Each half renders as the untextured material of its transmission does.
/// Before, the texture was ignored (with a warning) and the whole quad was glass.
#[test]
fn transmission_texture_multiplies_the_factor_per_texel() {
    let dir = folder("transmission");
    let textures = &nearest_texture(&dir, "t.png", 2, 1, &[[255, 0, 0, 255], [0, 0, 0, 255]]);
    let used = r#""extensionsUsed": ["KHR_materials_transmission"],"#;
    let material = |transmission: &str| {
        format!(
            r#"{{"pbrMetallicRoughness": {{"baseColorFactor": [0.8, 0.6, 0.4, 1], "metallicFactor": 0, "roughnessFactor": 0.5}},
               "extensions": {{"KHR_materials_transmission": {transmission}}}}}"#
        )
    };
    let render = |m: &str| {
        let gltf = write_gltf_quad(&dir, m, textures, used);
        render_rgb(&scene_around(&dir, &gltf, [0.0, 0.0, -1.0], ""))
    };
    let textured = render(&material(r#"{"transmissionFactor": 1, "transmissionTexture": {"index": 0}}"#));
    let glass = render(&material(r#"{"transmissionFactor": 1}"#));
    let opaque = render(&material(r#"{"transmissionFactor": 0}"#));
    let luminance = |rgb: [f64; 3]| 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
    assert!(luminance(opaque[4][6]) > 10.0 * luminance(glass[4][1]).max(1e-3), "the two must differ");
    for y in 0..8 {
        for x in 0..8 {
            let want = if x < 4 { glass[y][x] } else { opaque[y][x] };
            let got = textured[y][x];
            let (g, w) = (luminance(got), luminance(want));
            assert!((g - w).abs() <= 0.02 * w + 1e-3, "pixel ({x}, {y}): {got:?} vs {want:?}");
        }
    }
}

/// The textures of `KHR_materials_specular` (A × `specularFactor`) and `KHR_materials_clearcoat`
/// (R × `clearcoatFactor`) vary those factors per texel: with the left texel 1 and the right 0, each half
/// renders as the untextured material with that factor does. The specular layer over a black base is
/// all the reflection there is, so its off half is exactly black. Before, both textures were ignored
/// (with a warning) and the whole quad had the factor.
#[test]
fn specular_and_clearcoat_textures_multiply_their_factors_per_texel() {
    let dir = folder("specular-coat");
    let textures = &nearest_texture(&dir, "on_off.png", 2, 1, &[[255, 0, 0, 255], [0, 0, 0, 0]]);
    let used = r#""extensionsUsed": ["KHR_materials_specular", "KHR_materials_clearcoat"],"#;
    let material = |base: &str, extensions: &str| {
        format!(
            r#"{{"pbrMetallicRoughness": {{"baseColorFactor": {base}, "metallicFactor": 0, "roughnessFactor": 0.6}},
               "extensions": {{{extensions}}}}}"#
        )
    };
    let render = |m: &str| {
        let gltf = write_gltf_quad(&dir, m, textures, used);
        render_rgb(&scene_around(&dir, &gltf, [0.2, 0.1, -1.0], ""))
    };
    let luminance = |rgb: [f64; 3]| 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
    let halves_match = |textured: &[Vec<[f64; 3]>], on: &[Vec<[f64; 3]>], off: &[Vec<[f64; 3]>], what: &str| {
        for y in 0..8 {
            for x in 0..8 {
                let want = luminance(if x < 4 { on[y][x] } else { off[y][x] });
                let got = luminance(textured[y][x]);
                assert!((got - want).abs() <= 0.02 * want + 1e-4, "{what} pixel ({x}, {y}): {got} vs {want}");
            }
        }
    };
    let black = "[0, 0, 0, 1]";
    let layer = render(&material(black, r#""KHR_materials_specular": {"specularFactor": 1}"#));
    let none = render(&material(black, r#""KHR_materials_specular": {"specularFactor": 0}"#));
    assert!(none.iter().flatten().all(|p| *p == [0.0; 3]), "specular 0 over black reflects nothing");
    assert!(luminance(layer[4][2]) > 1e-3, "the layer must show");
    let textured = render(&material(black, r#""KHR_materials_specular": {"specularTexture": {"index": 0}}"#));
    halves_match(&textured, &layer, &none, "specular");
    let red = "[0.7, 0.1, 0.1, 1]";
    let coated =
        render(&material(red, r#""KHR_materials_clearcoat": {"clearcoatFactor": 1, "clearcoatRoughnessFactor": 0.5}"#));
    let bare = render(&material(red, r#""KHR_materials_clearcoat": {"clearcoatFactor": 0}"#));
    let textured = render(&material(
        red,
        r#""KHR_materials_clearcoat": {"clearcoatFactor": 1, "clearcoatRoughnessFactor": 0.5, "clearcoatTexture": {"index": 0}}"#,
    ));
    let total = |image: &[Vec<[f64; 3]>]| image.iter().flatten().map(|p| luminance(*p)).sum::<f64>();
    let (with, without) = (total(&coated), total(&bare));
    eprintln!("coated / bare quad luminance: {}", with / without);
    assert!((with - without).abs() > 0.03 * without, "the coat must show: {with} vs {without}");
    halves_match(&textured, &coated, &bare, "clearcoat");
}

/// Writes a 1×1 tangent-space normal map tilting the normal by `theta` towards +u (+x on the quads here),
/// 8-bit encoded, and returns the unit normal the renderer decodes from those bytes.
fn write_tilted_normal_map(path: &Path, theta: f64) -> [f64; 3] {
    let encode = |v: f64| ((v + 1.0) * 0.5 * 255.0).round() as u8;
    let texel = [encode(theta.sin()), encode(0.0), encode(theta.cos()), 255];
    write_png(path, 1, 1, &[texel]);
    let decoded = [0, 1, 2].map(|c| 2.0 * f64::from(texel[c]) / 255.0 - 1.0);
    let len = decoded.iter().map(|v| v * v).sum::<f64>().sqrt();
    decoded.map(|v| v / len)
}

/// `specularColorTexture` × `specularColorFactor` tints F0 per texel: over a black base, where the specular
/// layer is all the reflection, each half of a two-texel quad renders as the untextured material whose
/// factor is that texel's linear colour × the factor. Before, the texture was ignored (a warning) and the
/// orange half had the factor's colour.
#[test]
fn specular_colour_texture_tints_f0_per_texel() {
    let dir = folder("specular-colour");
    let (white, orange) = ([255, 255, 255, 255], [255, 128, 0, 255]);
    let textures = &nearest_texture(&dir, "tint.png", 2, 1, &[white, orange]);
    let used = r#""extensionsUsed": ["KHR_materials_specular"],"#;
    let render = |specular: &str| {
        let m = format!(
            r#"{{"pbrMetallicRoughness": {{"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0, "roughnessFactor": 0.6}},
               "extensions": {{"KHR_materials_specular": {specular}}}}}"#
        );
        let gltf = write_gltf_quad(&dir, &m, textures, used);
        render_rgb(&scene_around(&dir, &gltf, [0.2, 0.1, -1.0], ""))
    };
    // A factor above 1 in red (the extension allows it; F0 = 0.04 × 2 stays below 1).
    let factor = [2.0, 1.0, 0.5];
    let untextured = |texel: [u8; 4]| {
        let c = linear(texel);
        render(&format!(
            r#"{{"specularColorFactor": [{}, {}, {}]}}"#,
            c[0] * factor[0],
            c[1] * factor[1],
            c[2] * factor[2]
        ))
    };
    let textured = render(r#"{"specularColorFactor": [2, 1, 0.5], "specularColorTexture": {"index": 0}}"#);
    let (left, right) = (untextured(white), untextured(orange));
    assert!(right[4][6][0] > 3.0 * right[4][6][2] + 1e-4, "the orange layer must be orange: {:?}", right[4][6]);
    for y in 0..8 {
        for x in 0..8 {
            let want = if x < 4 { left[y][x] } else { right[y][x] };
            let got = textured[y][x];
            for c in 0..3 {
                assert!((got[c] - want[c]).abs() <= 0.02 * want[c] + 1e-5, "pixel ({x}, {y}): {got:?} vs {want:?}");
            }
        }
    }
}

/// `clearcoatNormalTexture` tilts the coat's normal, and only the coat's: over a base that reflects nothing
/// (black, `specularFactor` 0), a coat with a map tilting 20° towards +x on a flat quad renders as the same
/// coat on a quad whose vertex normals are the tilted normal; the base's normal map leaves the coat flat
/// (`KHR_materials_clearcoat`: "If clearcoatNormalTexture is not given, no normal mapping is applied to the
/// clear coat layer, even if normal mapping is applied to the base material"). Before, the coat map was
/// ignored and the coat took the base's map.
#[test]
fn the_coat_has_its_own_normal_map_and_not_the_bases() {
    let dir = folder("coat-normal");
    // The decoded normal is also the comparison quad's vertex normal.
    let tilted = write_tilted_normal_map(&dir.join("tilt.png"), 20f64.to_radians()).map(|v| v as f32);
    let textures = r#""textures": [{"source": 0}], "images": [{"uri": "tilt.png"}]"#;
    let used = r#""extensionsUsed": ["KHR_materials_specular", "KHR_materials_clearcoat"],"#;
    let render = |base_map: bool, coat_map: bool, normal: [f32; 3]| {
        let normal_texture = if base_map { r#", "normalTexture": {"index": 0}"# } else { "" };
        let coat_normal = if coat_map { r#", "clearcoatNormalTexture": {"index": 0}"# } else { "" };
        let m = format!(
            r#"{{"pbrMetallicRoughness": {{"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0}}{normal_texture},
               "extensions": {{"KHR_materials_specular": {{"specularFactor": 0}},
                              "KHR_materials_clearcoat": {{"clearcoatFactor": 1, "clearcoatRoughnessFactor": 0.3{coat_normal}}}}}}}"#
        );
        let gltf = write_gltf_quad_with_normal(&dir, &m, textures, used, normal, QUAD_UVS);
        // Light from 30° towards +x: the tilted coat's mirror direction is 10° from it, the flat one's 30°.
        let phi = 30f64.to_radians();
        let image = render_rgb_spp(&scene_around(&dir, &gltf, [-phi.sin(), 0.0, -phi.cos()], ""), 256);
        image.iter().flatten().map(|p| p[1]).sum::<f64>()
    };
    let flat = render(false, false, [0.0, 0.0, 1.0]);
    let coat_mapped = render(false, true, [0.0, 0.0, 1.0]);
    let tilted_mesh = render(false, false, tilted);
    let base_mapped = render(true, false, [0.0, 0.0, 1.0]);
    eprintln!("coat: flat {flat}, coat map {coat_mapped}, tilted normals {tilted_mesh}, base map {base_mapped}");
    assert!(flat > 0.0);
    assert!(coat_mapped > 2.0 * flat, "the coat's map must tilt the coat: {coat_mapped} vs flat {flat}");
    assert!((coat_mapped - tilted_mesh).abs() <= 0.02 * tilted_mesh, "{coat_mapped} vs {tilted_mesh}");
    assert!(
        (base_mapped - flat).abs() <= 0.02 * flat,
        "the base's map must not tilt the coat: {base_mapped} vs {flat}"
    );
}

#[test]
fn mask_cut_outs_let_light_through_exactly_where_alpha_is_below_the_cutoff() {
    let dir = folder("mask");
    // Coverage 0 on the left texel, 1 on the right; the quad itself is black.
    write_png(&dir.join("mask.png"), 2, 1, &[[0, 0, 0, 255], [255, 255, 255, 255]]);
    let obj = write_obj_quad(&dir, "Kd 0 0 0\nmap_d mask.png");
    // A white floor one unit behind the quad, larger than the view.
    let floor =
        r#", {"type": "quad", "corner": [-3, -3, -1], "edge_u": [6, 0, 0], "edge_v": [0, 6, 0], "material": "white"}"#;
    let rgb = render_rgb(&scene_around(&dir, &obj, [0.0, 0.0, -1.0], floor));
    let k = E / std::f64::consts::PI;
    for y in [1, 4, 6] {
        for (x, &got) in rgb[y].iter().enumerate() {
            // Left half: the floor, lit through the cut-out (its shadow ray passes the quad there);
            // right half: the black quad.
            let want = if x < 4 { [k; 3] } else { [0.0; 3] };
            assert_rgb(got, want, 1e-3, &format!("pixel ({x}, {y})"));
        }
    }
    // The same floor with an opaque black quad (no map_d) is black everywhere in view.
    let dir = folder("mask-opaque");
    let obj = write_obj_quad(&dir, "Kd 0 0 0");
    let rgb = render_rgb(&scene_around(&dir, &obj, [0.0, 0.0, -1.0], floor));
    assert_rgb(rgb[4][1], [0.0; 3], 1e-3, "opaque quad");
}

#[test]
fn a_normal_map_tilts_the_shading_normal_by_the_encoded_angle() {
    let dir = folder("normal");
    let n = write_tilted_normal_map(&dir.join("normal.png"), 20f64.to_radians());
    // Light arriving from 30° towards +x: towards the light is (sin 30°, 0, cos 30°).
    let phi = 30f64.to_radians();
    let light_dir = [-phi.sin(), 0.0, -phi.cos()];
    let to_light = [phi.sin(), 0.0, phi.cos()];
    let flat = write_obj_quad(&dir, "Kd 1 1 1");
    let flat_rgb = render_rgb(&scene_around(&dir, &flat, light_dir, ""));
    let k = E / std::f64::consts::PI;
    assert_rgb(flat_rgb[4][4], [k * phi.cos(); 3], 1e-3, "flat");
    let mapped = write_obj_quad(&dir, "Kd 1 1 1\nnorm normal.png");
    let rgb = render_rgb(&scene_around(&dir, &mapped, light_dir, ""));
    let cos = n[0] * to_light[0] + n[1] * to_light[1] + n[2] * to_light[2];
    // cos(30° − 20°) / cos 30° = 1.137: the map's tilt, not noise, raises the value.
    assert!((cos / phi.cos() - 1.137).abs() < 0.01);
    for (x, y) in [(1, 1), (4, 4), (6, 2)] {
        assert_rgb(rgb[y][x], [k * cos; 3], 1e-3, &format!("normal-mapped pixel ({x}, {y})"));
    }
}

/// MTL `map_Bump` as a height field: a grey ramp in u (texel i = i/255, 256 wide, so a central difference
/// one texel apart gives ∂h/∂u = 256/255 exactly) times `-bm 0.5` on the quad, whose ∂p/∂u is (2, 0, 0),
/// tilts the normal towards −x by atan(0.5 · 256/255 / 2) = 14.1°; lit from 30° towards +x, the quad
/// then reads k cos(44.1°). Before, `map_Bump` was ignored with a warning (the quad read k cos 30°).
#[test]
fn a_height_bump_map_tilts_the_normal_against_its_gradient() {
    let dir = folder("bump");
    let ramp: Vec<[u8; 4]> = (0..=255u8).map(|i| [i, i, i, 255]).collect();
    write_png(&dir.join("ramp.png"), 256, 1, &ramp);
    let phi = 30f64.to_radians();
    let light_dir = [-phi.sin(), 0.0, -phi.cos()];
    let k = E / std::f64::consts::PI;
    for bm in [0.5f64, -0.5] {
        let obj = write_obj_quad(&dir, &format!("Kd 1 1 1\nmap_Bump -bm {bm} ramp.png"));
        let scene = scene_around(&dir, &obj, light_dir, "");
        assert!(scene.warnings.iter().any(|w| w.contains("ramp.png read as a height field")), "{:?}", scene.warnings);
        let rgb = render_rgb(&scene);
        let theta = (bm * 256.0 / 255.0 / 2.0).atan();
        // The normal (−sin θ, 0, cos θ) against the light (sin 30°, 0, cos 30°).
        let cos = (phi + theta).cos();
        assert!((theta.abs().to_degrees() - 14.09).abs() < 0.01);
        for (x, y) in [(2, 1), (4, 4), (5, 6)] {
            assert_rgb(rgb[y][x], [k * cos; 3], 1e-3, &format!("bump -bm {bm}, pixel ({x}, {y})"));
        }
    }
}

/// MTL `map_Bump` holding a tangent-space normal map (as Blender's exporter writes one) is read as `norm`:
/// the same image through either statement renders the same quad, and not the flat one.
#[test]
fn a_normal_map_written_as_map_bump_renders_as_norm() {
    let dir = folder("bump-normal");
    write_tilted_normal_map(&dir.join("normal.png"), 10f64.to_radians());
    let phi = 30f64.to_radians();
    let light_dir = [-phi.sin(), 0.0, -phi.cos()];
    let render = |mtl: &str| {
        let obj = write_obj_quad(&dir, mtl);
        let scene = scene_around(&dir, &obj, light_dir, "");
        (render_rgb(&scene), scene.warnings)
    };
    let (norm, _) = render("Kd 1 1 1\nnorm normal.png");
    let (bump, warnings) = render("Kd 1 1 1\nmap_Bump normal.png");
    let (flat, _) = render("Kd 1 1 1");
    assert!(warnings.iter().any(|w| w.contains("normal.png read as a tangent-space normal map")), "{warnings:?}");
    assert!(norm[4][4][1] > 1.05 * flat[4][4][1], "the map must tilt: {:?} vs {:?}", norm[4][4], flat[4][4]);
    for (x, y) in [(1, 1), (4, 4), (6, 2)] {
        assert_rgb(bump[y][x], norm[y][x], 1e-6, &format!("pixel ({x}, {y})"));
    }
}

/// `gltf` (a [`write_gltf_quad_with_normal`] document) with one more vertex attribute `attribute`: four
/// float `kind` values (VEC2, VEC4) read from the file `uri` of `bytes` bytes (buffer 1, buffer view 2,
/// accessor 4).
fn with_attribute(gltf: &str, uri: &str, bytes: usize, kind: &str, attribute: &str) -> String {
    let patched = gltf
        .replace(
            r#""byteLength": 140}]"#,
            &format!(r#""byteLength": 140}}, {{"uri": "{uri}", "byteLength": {bytes}}}]"#),
        )
        .replace(
            r#""byteLength": 12}]"#,
            &format!(r#""byteLength": 12}}, {{"buffer": 1, "byteOffset": 0, "byteLength": {bytes}}}]"#),
        )
        .replace(
            r#""type": "SCALAR"}]"#,
            &format!(
                r#""type": "SCALAR"}}, {{"bufferView": 2, "componentType": 5126, "count": 4, "type": "{kind}"}}]"#
            ),
        )
        .replace(r#""TEXCOORD_0": 2}"#, &format!(r#""TEXCOORD_0": 2, "{attribute}": 4}}"#));
    assert_ne!(patched, gltf, "the document's layout changed");
    patched
}

/// A mesh placed twice renders the same whether the placements are world-space copies or instances of a
/// two-level BVH: its normal map (tilting towards +u and +v) and its vertex colours read through the placement
/// (one mirrored in x, one rotated a quarter turn about z, both half size), so that the tangent frame is
/// taken to world space with the right handedness. Before, instanced hits carried no mesh: their normal map
/// and vertex colours were dropped (with a warning).
#[test]
fn instances_shade_as_their_world_space_copies() {
    let dir = folder("instances");
    // Tilted along both tangent axes, so that the bitangent's sign (mirroring) shows.
    let encode = |v: f64| ((v + 1.0) * 0.5 * 255.0).round() as u8;
    write_png(
        &dir.join("tilt.png"),
        1,
        1,
        &[[encode(0.3), encode(0.25), encode((1.0f64 - 0.3 * 0.3 - 0.25 * 0.25).sqrt()), 255]],
    );
    let textures = r#""textures": [{"source": 0}], "images": [{"uri": "tilt.png"}]"#;
    let colors: [[f32; 4]; 4] =
        [[1.0, 0.2, 0.2, 1.0], [0.2, 1.0, 0.2, 1.0], [0.2, 0.2, 1.0, 1.0], [1.0, 1.0, 1.0, 1.0]];
    std::fs::write(
        dir.join("colors.bin"),
        colors.as_flattened().iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<_>>(),
    )
    .expect("write colours");
    let write = |normal_map: bool| {
        let m = if normal_map {
            r#"{"pbrMetallicRoughness": {"metallicFactor": 0, "roughnessFactor": 1}, "normalTexture": {"index": 0}}"#
        } else {
            r#"{"pbrMetallicRoughness": {"metallicFactor": 0, "roughnessFactor": 1}}"#
        };
        let path = write_gltf_quad_with_normal(&dir, m, textures, "", [0.0, 0.0, 1.0], QUAD_UVS);
        let gltf = std::fs::read_to_string(&path).expect("read glTF");
        let q = std::f32::consts::FRAC_1_SQRT_2;
        let patched = with_attribute(&gltf, "colors.bin", 64, "VEC4", "COLOR_0")
            .replace(
                r#""nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}]"#,
                &format!(
                    r#""nodes": [{{"mesh": 0, "translation": [-0.5, 0, 0], "scale": [-0.5, 0.5, 1]}},
                                 {{"mesh": 0, "translation": [0.5, 0, 0], "rotation": [0, 0, {q}, {q}], "scale": [0.5, 0.5, 1]}}],
                       "scenes": [{{"nodes": [0, 1]}}]"#
                ),
            );
        assert_ne!(patched, gltf);
        std::fs::write(&path, patched).expect("write glTF");
        path
    };
    let phi = 30f64.to_radians();
    let render = |normal_map: bool, flatten_triangles: u64| {
        let gltf = write(normal_map);
        scene_around(&dir, &gltf, [-phi.sin(), 0.0, -phi.cos()], "");
        let options = geometry::LoadOptions { flatten_triangles, ..geometry::LoadOptions::default() };
        let scene = RenderScene::load_with(&dir.join("scene.json"), &options).unwrap_or_else(|e| panic!("{e}"));
        let instanced = scene.warnings.iter().any(|w| w.contains("instanced (kept once"));
        assert_eq!(instanced, flatten_triangles == 0, "{:?}", scene.warnings);
        render_rgb(&scene)
    };
    let (copies, instances) = (render(true, 1 << 20), render(true, 0));
    let unmapped = render(false, 0);
    let mut tilted = 0;
    for y in 0..8 {
        for x in 0..8 {
            assert_rgb(instances[y][x], copies[y][x], 1e-4, &format!("pixel ({x}, {y})"));
            tilted += usize::from((instances[y][x][1] - unmapped[y][x][1]).abs() > 0.05 * unmapped[y][x][1]);
        }
    }
    // Both placements are in view and coloured (the vertex colours differ from corner to corner).
    assert!(tilted >= 16, "the normal map must show on the instances: {tilted} pixels");
    let (left, right) = (instances[4][1], instances[4][6]);
    assert!(
        left[0] > 0.01 && right[0] > 0.01 && (left[0] - right[0]).abs() > 0.1 * left[0].max(right[0]),
        "{left:?} {right:?}"
    );
}

/// MTL `map_Ns` multiplies `Ns` per texel: each half of a quad whose map is white on the left and 16/255
/// on the right renders as the untextured material of that half's exponent (the exponent whose roughness
/// is the 8-bit value the map is turned into). Before, `map_Ns` was ignored with a warning (both halves had
/// `Ns 100`).
#[test]
fn mtl_map_ns_varies_the_exponent_per_texel() {
    let dir = folder("map-ns");
    let grey = |v: u8| [v, v, v, 255];
    write_png(&dir.join("ns.png"), 4, 1, &[grey(255), grey(255), grey(16), grey(16)]);
    let phi = 30f64.to_radians();
    let render =
        |mtl: &str| render_rgb(&scene_around(&dir, &write_obj_quad(&dir, mtl), [-phi.sin(), 0.0, -phi.cos()], ""));
    // The 8-bit roughness of Ns 100 × v, and the Ns whose roughness (2 / (Ns + 2))^¼ is exactly that.
    let ns_of = |v: f64| {
        let g = (255.0 * (2.0 / (100.0 * v + 2.0)).powf(0.25)).round();
        2.0 / (g / 255.0).powi(4) - 2.0
    };
    // A dielectric layer over a dark diffuse one, and a conductor (black Kd) reflecting Ks.
    for base in ["Kd 0.05 0.05 0.05\nKs 1 1 1", "Kd 0 0 0\nKs 0.9 0.9 0.9"] {
        let textured = render(&format!("{base}\nNs 100\nmap_Ns ns.png"));
        let left = render(&format!("{base}\nNs {}", ns_of(1.0)));
        let right = render(&format!("{base}\nNs {}", ns_of(16.0 / 255.0)));
        for y in [2, 4, 6] {
            for x in [1, 2] {
                assert_rgb(textured[y][x], left[y][x], 2e-3, &format!("{base}: left pixel ({x}, {y})"));
            }
            for x in [5, 6] {
                let (l, r) = (left[y][x][1], right[y][x][1]);
                // By more than five times the (relative) tolerance of the textured half's match.
                assert!((l - r).abs() > 5.0 * 2e-3 * l.max(r), "{base}: the halves must differ: {l} vs {r}");
                assert_rgb(textured[y][x], right[y][x], 2e-3, &format!("{base}: right pixel ({x}, {y})"));
            }
        }
    }
}

/// MTL `map_Ks` tints the specular layer per texel (as `specularColorTexture`): white texels render as the
/// untextured material, black ones lose the highlight and keep the diffuse layer; on a conductor (black
/// `Kd`), whose reflectance `Ks` is not textured, a warning says so. Before, `map_Ks` was ignored.
#[test]
fn mtl_map_ks_tints_the_specular_layer_per_texel() {
    let dir = folder("map-ks");
    let (white, black) = ([255; 4], [0, 0, 0, 255]);
    write_png(&dir.join("ks.png"), 4, 1, &[white, white, black, black]);
    let phi = 30f64.to_radians();
    let scene = |mtl: &str| scene_around(&dir, &write_obj_quad(&dir, mtl), [-phi.sin(), 0.0, -phi.cos()], "");
    let textured = render_rgb(&scene("Kd 0.3 0.3 0.3\nKs 1 1 1\nNs 100\nmap_Ks ks.png"));
    let plain = render_rgb(&scene("Kd 0.3 0.3 0.3\nKs 1 1 1\nNs 100"));
    let diffuse = render_rgb(&scene("Kd 0.3 0.3 0.3"));
    for y in [2, 4, 6] {
        for x in [1, 2] {
            assert_rgb(textured[y][x], plain[y][x], 2e-3, &format!("white texel, pixel ({x}, {y})"));
        }
        for x in [5, 6] {
            let (got, plain, diffuse) = (textured[y][x][1], plain[y][x][1], diffuse[y][x][1]);
            assert!(got < plain - 0.02 * plain, "black texel keeps a highlight: {got} vs {plain}");
            assert!((got - diffuse).abs() < 0.05 * diffuse, "black texel: {got} vs diffuse {diffuse}");
        }
    }
    let conductor = scene("Kd 0 0 0\nKs 0.9 0.6 0.3\nNs 100\nmap_Ks ks.png");
    assert!(conductor.warnings.iter().any(|w| w.contains("`map_Ks` not used")), "{:?}", conductor.warnings);
}

/// A material whose base colour reads `TEXCOORD_1` beside a normal map on `TEXCOORD_0` reads each texture
/// in its own set: with TEXCOORD_1 the mirror image of TEXCOORD_0 in u, the base colour shows mirrored (the
/// render equals the same quad whose base colour reads TEXCOORD_0 from the mirrored image), while the normal
/// map keeps TEXCOORD_0. Before, a mesh held one set and every texture read it (with a warning).
#[test]
fn textures_read_their_own_texcoord_set() {
    let dir = folder("texcoord-1");
    let (red, green) = ([200, 30, 30, 255], [30, 200, 30, 255]);
    write_png(&dir.join("rg.png"), 2, 1, &[red, green]);
    write_png(&dir.join("gr.png"), 2, 1, &[green, red]);
    write_png(&dir.join("flat.png"), 1, 1, &[[128, 128, 255, 255]]);
    let mirrored: [[f32; 2]; 4] = [[1.0, 0.0], [0.0, 0.0], [0.0, 1.0], [1.0, 1.0]];
    std::fs::write(
        dir.join("uv1.bin"),
        mirrored.as_flattened().iter().flat_map(|v| v.to_le_bytes()).collect::<Vec<_>>(),
    )
    .expect("write uv1");
    let render = |image: &str, set: u32| {
        let textures = format!(
            r#""textures": [{{"source": 0, "sampler": 0}}, {{"source": 1}}], "samplers": [{{"magFilter": 9728}}],
               "images": [{{"uri": "{image}"}}, {{"uri": "flat.png"}}]"#
        );
        let m = format!(
            r#"{{"pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0, "texCoord": {set}}}, "metallicFactor": 0, "roughnessFactor": 1}},
                "normalTexture": {{"index": 1}}}}"#
        );
        let path = write_gltf_quad_with_normal(&dir, &m, &textures, "", [0.0, 0.0, 1.0], QUAD_UVS);
        let gltf = std::fs::read_to_string(&path).expect("read glTF");
        let patched = with_attribute(&gltf, "uv1.bin", 32, "VEC2", "TEXCOORD_1");
        std::fs::write(&path, patched).expect("write glTF");
        let scene = scene_around(&dir, &path, [0.0, 0.0, -1.0], "");
        assert!(!scene.warnings.iter().any(|w| w.contains("TEXCOORD")), "{:?}", scene.warnings);
        render_rgb(&scene)
    };
    let second_set = render("rg.png", 1);
    let mirrored_image = render("gr.png", 0);
    for y in 0..8 {
        for x in 0..8 {
            assert_rgb(second_set[y][x], mirrored_image[y][x], 1e-6, &format!("pixel ({x}, {y})"));
        }
    }
    // The left half is green: TEXCOORD_1 puts the image's right texel there.
    let (left, right) = (second_set[4][1], second_set[4][6]);
    assert!(left[1] > 2.0 * left[0] && right[0] > 2.0 * right[1], "{left:?} {right:?}");
}

/// `EXT_texture_webp`, required and without a PNG fallback: the WebP image (lossless, written here) renders
/// exactly as the same texels in a PNG. Before, the required extension made the file an error.
#[test]
fn a_webp_texture_renders_as_the_same_png() {
    let dir = folder("webp");
    let texels = [[200u8, 30, 30, 255], [30, 200, 30, 255]];
    write_png(&dir.join("rg.png"), 2, 1, &texels);
    let file = std::fs::File::create(dir.join("rg.webp")).expect("create WebP");
    image::codecs::webp::WebPEncoder::new_lossless(file)
        .encode(texels.as_flattened(), 2, 1, image::ExtendedColorType::Rgba8)
        .expect("write WebP");
    let m =
        r#"{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0, "roughnessFactor": 1}}"#;
    let render = |textures: &str, used: &str| {
        let gltf = write_gltf_quad(&dir, m, textures, used);
        let scene = scene_around(&dir, &gltf, [0.0, 0.0, -1.0], "");
        render_rgb(&scene)
    };
    let png = render(
        r#""textures": [{"source": 0, "sampler": 0}], "samplers": [{"magFilter": 9728}], "images": [{"uri": "rg.png"}]"#,
        "",
    );
    let webp = render(
        r#""textures": [{"sampler": 0, "extensions": {"EXT_texture_webp": {"source": 0}}}], "samplers": [{"magFilter": 9728}],
           "images": [{"uri": "rg.webp"}]"#,
        r#""extensionsUsed": ["EXT_texture_webp"], "extensionsRequired": ["EXT_texture_webp"],"#,
    );
    assert!(png[4][1][0] > 2.0 * png[4][1][1] && png[4][6][1] > 2.0 * png[4][6][0], "{:?} {:?}", png[4][1], png[4][6]);
    for y in 0..8 {
        for x in 0..8 {
            assert_rgb(webp[y][x], png[y][x], 1e-9, &format!("pixel ({x}, {y})"));
        }
    }
}

#[test]
fn decoded_textures_are_charged_to_the_scene_memory_budget_before_decoding() {
    let dir = folder("budget");
    // 512×512 texels of 512 distinct colours: 1 MiB as RGBA8, charged for decoding (output and the
    // 8-bit copy, working), kept (1 MiB), then as a colour texture (1 MiB of palette indices, and
    // 40 B per texel of working memory while its distinct colours are counted).
    let texels: Vec<[u8; 4]> =
        (0..512 * 512u32).map(|i| [(i % 256) as u8, (i / 256 % 2) as u8 * 255, 7, 255]).collect();
    write_png(&dir.join("big.png"), 512, 512, &texels);
    let obj = write_obj_quad(&dir, "map_Kd big.png");
    let load = |max_memory: u64| {
        RenderScene::load_with(&obj, &geometry::LoadOptions { max_memory, ..geometry::LoadOptions::default() })
    };
    // The OBJ, MTL, PNG and mesh take a few KB: 3 MiB passes the loaders but not the decode.
    let refused = load(3 << 20).err().map(|e| chain(&e)).unwrap_or_default();
    assert!(
        refused.contains("big.png") && refused.contains("decoding a 512×512") && refused.contains("memory budget"),
        "{refused}"
    );
    // 8 MiB holds the image (3 MiB while decoding) but not the colour count's 11 MiB of working memory.
    let refused = load(8 << 20).err().map(|e| chain(&e)).unwrap_or_default();
    assert!(refused.contains("big.png") && refused.contains("distinct colours"), "{refused}");
    load(16 << 20).unwrap_or_else(|e| panic!("{e}"));
    std::fs::remove_dir_all(&dir).ok();
}

/// An emissive texture's texels are seen at their pixels, each the RGB light of its colour × the factor ×
/// `KHR_materials_emissive_strength`, on RGB lanes and on wavelengths alike. Before, the quad glowed in the
/// image's mean colour everywhere.
#[test]
fn emissive_texels_are_seen_at_the_predicted_pixels() {
    let dir = folder("emissive");
    let texels: Vec<[u8; 4]> = (0..16).map(|i| CHECKER[(i % 4) / 2 + 2 * (i / 8)]).collect();
    let textures = &nearest_texture(&dir, "checker.png", 4, 4, &texels);
    let material = r#"{"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "roughnessFactor": 0}, "emissiveFactor": [1, 0.5, 1],
        "emissiveTexture": {"index": 0}, "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 2}}}"#;
    let used = r#""extensionsUsed": ["KHR_materials_emissive_strength"],"#;
    let gltf = write_gltf_quad(&dir, material, textures, used);
    // No light but the quad: the directional light adds nothing on a smooth black metal, a delta lobe no
    // light sample reaches (a rough one reflects a little: Schlick's F of black is 1 at grazing, and the
    // compensated lobe sends ~0.1 % of it back).
    let scene = scene_around(&dir, &gltf, [0.0, 0.0, -1.0], "");
    let factor = [2.0, 1.0, 2.0];
    // RGB lanes carry the colour exactly (up to f32 rounding); 32 wavelength bins reproduce a saturated
    // colour to 0.2 % of its largest channel (its weak channels are off by 0.002 of 1.15 for the blue texel).
    for (mode, tolerance) in [(SpectralMode::Rgb, 1e-3), (SpectralMode::Bins(32), 5e-3)] {
        let opts =
            integrator::RenderOptions { spectral: mode, spp: 4, ..options(8, 8) }.path(|p| p.max_depth = Some(1));
        let (image, stats) = render_with(&scene, &opts);
        assert_all_finite(&image, &stats);
        let srgb = RgbColorSpace::srgb();
        for (t, texel) in CHECKER.iter().enumerate() {
            let (tx, ty) = (t % 2, t / 2);
            for (px, py) in [(1, 1), (2, 2), (1, 2), (2, 1)] {
                let (x, y) = (4 * tx + px, 4 * ty + py);
                let [x_, y_, z_] = image.xyz(x as u32, y as u32).map(f64::from);
                let rgb = srgb.xyz_to_rgb(Xyz { x: x_, y: y_, z: z_ });
                let want = [0, 1, 2].map(|c| linear(*texel)[c] * factor[c]);
                let peak = want.iter().copied().fold(0.0, f64::max);
                let got = [rgb.r, rgb.g, rgb.b];
                let ok = (0..3).all(|c| (got[c] - want[c]).abs() <= tolerance * peak);
                assert!(ok, "{mode:?}: texel {t} at pixel ({x}, {y}): got {got:?}, expected {want:?}");
            }
        }
    }
}

/// Mean luminance of the pixels in columns `columns` of every row.
fn mean_y(image: &integrator::Image, columns: std::ops::Range<u32>, height: u32) -> f64 {
    let n = (columns.len() as u32 * height) as f64;
    columns.flat_map(|x| (0..height).map(move |y| (x, y))).map(|(x, y)| f64::from(image.xyz(x, y)[1])).sum::<f64>() / n
}

/// Light sampling reads the emissive texture where it samples the light: a 2 × 2 quad lamp whose left half
/// is white and right half black lights a floor as a lamp of only the left half does (same mean within
/// Monte Carlo error, next-event estimation and BSDF sampling together), the floor below the black half
/// lit only obliquely. Before, the whole lamp emitted the image's mean colour and the floor was lit
/// evenly left and right.
#[test]
fn light_sampling_reads_the_emissive_texture_at_the_sampled_point() {
    let dir = folder("emissive-lamp");
    let textures = &nearest_texture(&dir, "half.png", 2, 1, &[[255, 255, 255, 255], [0, 0, 0, 255]]);
    let material = r#"{"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1]}, "emissiveFactor": [1, 1, 1], "emissiveTexture": {"index": 0}}"#;
    let gltf = write_gltf_quad(&dir, material, textures, "");
    // The camera looks down at the floor from below the lamp, which it does not see.
    let manifest = |lamp: &str| {
        format!(
            r#"{{"camera": {{"position": [0, 0.7, 3], "look_at": [0, 0, 0], "up": [0, 1, 0], "vfov_deg": 24}},
            "background": 0,
            "materials": {{"white": {{"base_color": 0.8, "diffuse": 1, "ks": 0}},
                           "lamp": {{"base_color": 0, "emission": "D65", "emission_strength": 1, "double_sided": false}}}},
            "objects": [{{"type": "quad", "corner": [-3, 0, 3], "edge_u": [6, 0, 0], "edge_v": [0, 0, -6], "material": "white"}}, {lamp}]}}"#
        )
    };
    // The glTF quad's front (+z) turned to face down, 1 above the floor; u < ½ (white) is x < 0.
    let textured = format!(
        r#"{{"type": "mesh", "file": "{}", "transform": {{"rotate": {{"axis": [1, 0, 0], "deg": 90}}, "translate": [0, 1, 0]}}}}"#,
        gltf.file_name().and_then(|n| n.to_str()).expect("file name")
    );
    // The left half alone, facing down: corner and edges ordered so that edge_u × edge_v is −y.
    let half =
        r#"{"type": "quad", "corner": [-1, 1, -1], "edge_u": [1, 0, 0], "edge_v": [0, 0, 2], "material": "lamp"}"#;
    let (w, h) = (32, 24);
    let render = |lamp: &str, name: &str| {
        let path = dir.join(name);
        std::fs::write(&path, manifest(lamp)).expect("write manifest");
        let scene = RenderScene::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let opts = integrator::RenderOptions { spectral: SpectralMode::Rgb, spp: 64, ..options(w, h) }
            .path(|p| p.max_depth = Some(1));
        let (image, stats) = render_with(&scene, &opts);
        assert_all_finite(&image, &stats);
        let (left, right) = (mean_y(&image, 2..w / 2 - 2, h), mean_y(&image, w / 2 + 2..w - 2, h));
        (left, right)
    };
    let (tex_left, tex_right) = render(&textured, "textured.json");
    let (half_left, half_right) = render(half, "half.json");
    // The floor below the black half is lit obliquely by the white half, at half the irradiance; the mean
    // colour over the whole lamp would give both sides (0.5 · (left + right)) instead, 25 % and 50 % off.
    assert!(half_left > 1.7 * half_right, "the reference is lit unevenly: {half_left} vs {half_right}");
    assert!((tex_left / half_left - 1.0).abs() < 0.05, "below the white half: {tex_left} vs {half_left}");
    assert!((tex_right / half_right - 1.0).abs() < 0.08, "below the black half: {tex_right} vs {half_right}");
}

/// `KHR_materials_sheen` end to end: a quad lit by a directional light 60° off its normal renders, per
/// channel, E cos θ_i · (f_sheen + (1 − max₃(C) E(μ_o)) f_base) — the extension's albedo-scaled layering in
/// its view-only form, the path tracer picking the sheen with probability max₃(C) E(μ_o) — computed here
/// from the materials crate's public lobes; a sheen colour texture's black texel leaves the base alone; and
/// under a clear coat the sheen stays beneath it (c F of the coat's lobe, the rest the sheen over the base).
/// Before, the sheen was ignored with a warning (the base alone everywhere).
#[test]
fn sheen_layers_over_the_base_as_the_extension_says() {
    use colorimetry::SampledSpectrum;
    use materials::bsdf::{Bsdf, Frame, GltfMetalRoughBxdf, SheenBxdf, sheen_albedo};
    let dir = folder("sheen");
    let textures = &nearest_texture(&dir, "on_off.png", 2, 1, &[[255, 255, 255, 255], [0, 0, 0, 255]]);
    let used = r#""extensionsUsed": ["KHR_materials_sheen", "KHR_materials_clearcoat"],"#;
    let (color, roughness, base) = ([0.9f32, 0.5, 0.2], 0.5f32, 0.3f32);
    let material = |sheen: &str| {
        format!(
            r#"{{"pbrMetallicRoughness": {{"baseColorFactor": [{base}, {base}, {base}, 1], "metallicFactor": 0, "roughnessFactor": 0.7}},
               "extensions": {{"KHR_materials_sheen": {{"sheenColorFactor": [{}, {}, {}], "sheenRoughnessFactor": {roughness}{sheen}}}}}}}"#,
            color[0], color[1], color[2]
        )
    };
    let (theta, spp) = (60f64.to_radians(), 1024);
    let light = [-theta.sin(), 0.0, -theta.cos()];
    let render_lit = |m: &str, light: [f64; 3], spp: u32| {
        let gltf = write_gltf_quad(&dir, m, textures, used);
        render_rgb_spp(&scene_around(&dir, &gltf, light, ""), spp)
    };
    let render = |m: &str| render_lit(m, light, spp);
    let sheen = render(&material(""));
    let textured = render(&material(r#", "sheenColorTexture": {"index": 0}"#));
    // The same with a clear coat on top (the extension's order: coat over sheen over base), lit at 20° so
    // that the coat's highlight is in view (about pixel column 6).
    let coat = materials::Coat { weight: 0.8, roughness: 0.3 };
    let theta_coat = 20f64.to_radians();
    let coated = render_lit(
        &material("").replace(
            r#""extensions": {"#,
            r#""extensions": {"KHR_materials_clearcoat": {"clearcoatFactor": 0.8, "clearcoatRoughnessFactor": 0.3}, "#,
        ),
        [-theta_coat.sin(), 0.0, -theta_coat.cos()],
        65536,
    );
    let bare = render(
        r#"{"pbrMetallicRoughness": {"baseColorFactor": [0.3, 0.3, 0.3, 1], "metallicFactor": 0, "roughnessFactor": 0.7}}"#,
    );
    // The model at pixel (x, y): wo towards the camera at z = 2 from the pixel's centre on the quad.
    let wi = glam::Vec3::new(theta.sin() as f32, 0.0, theta.cos() as f32);
    let frame = Frame { n: glam::Vec3::Z, ns: glam::Vec3::Z };
    // The sheen over the base (or the base alone) seen from `wo`, lit from `wi`.
    let layered = |wo: glam::Vec3, wi: glam::Vec3, with_sheen: bool| -> [f64; 3] {
        let base =
            Bsdf::GltfMetalRough(GltfMetalRoughBxdf::new(SampledSpectrum([base; 3]), 0.0, 0.7, 1.5).compensated());
        let f_base = base.f_cos(&frame, wo, wi);
        let lobe = Bsdf::Sheen(SheenBxdf::new(SampledSpectrum(color), roughness)).f_cos(&frame, wo, wi);
        let scale = 1.0 - color[0].max(color[1]).max(color[2]) * sheen_albedo(wo.z, roughness);
        [0, 1, 2].map(|c| E * f64::from(if with_sheen { lobe.0[c] + scale * f_base.0[c] } else { f_base.0[c] }))
    };
    let view = |x: f32, y: f32| {
        let p = glam::Vec3::new(-1.0 + x / 4.0, 1.0 - y / 4.0, 0.0);
        (glam::Vec3::new(0.0, 0.0, 2.0) - p).normalize()
    };
    let expected = |x: usize, y: usize, with_sheen: bool| layered(view(x as f32 + 0.5, y as f32 + 0.5), wi, with_sheen);
    // Coated, averaged over the pixel (8 × 8 points: the coat's highlight varies across it): c F(μ_o) of the
    // coat's lobe, the rest the sheen layered over the base; and the same without the coat.
    let wi_coat = glam::Vec3::new(theta_coat.sin() as f32, 0.0, theta_coat.cos() as f32);
    let coated_expected = |x: usize, y: usize| -> ([f64; 3], [f64; 3]) {
        let (mut with, mut without) = ([0.0; 3], [0.0; 3]);
        for k in 0..1024 {
            let wo = view(x as f32 + ((k % 32) as f32 + 0.5) / 32.0, y as f32 + ((k / 32) as f32 + 0.5) / 32.0);
            let share = f64::from(coat.probability(wo.z));
            let f_coat = Bsdf::<3>::GltfMetalRough(GltfMetalRoughBxdf::clearcoat(coat.roughness).compensated())
                .f_cos(&frame, wo, wi_coat);
            let under = layered(wo, wi_coat, true);
            for c in 0..3 {
                with[c] += (share * E * f64::from(f_coat.0[c]) + (1.0 - share) * under[c]) / 1024.0;
                without[c] += under[c] / 1024.0;
            }
        }
        (with, without)
    };
    for (x, y) in [(2, 3), (3, 3), (3, 4), (2, 4), (5, 3), (5, 4)] {
        let want = expected(x, y, true);
        let plain = expected(x, y, false);
        // Stochastic layer choice at 1024 samples and the pixel's footprint: 3 %.
        assert_rgb(sheen[y][x], want, 0.03, &format!("sheen at pixel ({x}, {y})"));
        assert_rgb(bare[y][x], plain, 0.01, &format!("base alone at pixel ({x}, {y})"));
        assert!((want[0] - plain[0]).abs() > 0.15 * plain[0], "the sheen must show: {want:?} vs {plain:?}");
        // Texture: white texels (x < 4) are the factor's sheen, black ones (x ≥ 4) no sheen at all.
        let (t, what) = if x < 4 { (sheen[y][x], "white texel") } else { (bare[y][x], "black texel") };
        assert_rgb(textured[y][x], t, 0.03, &format!("{what} at pixel ({x}, {y})"));
    }
    let mut highlights = 0;
    for (x, y) in [(4, 3), (5, 3), (6, 3), (7, 3), (5, 4), (6, 4), (2, 3), (2, 4)] {
        let (want, uncoated) = coated_expected(x, y);
        // The coat is picked in 3–4 % of the samples, so its highlight is the noisy part: σ ≈ 1.4 % of the
        // pixel at 65536 samples (measured: 0.3 % and 3.0 % off at the two mirror-image pixels (6, 4), (6, 3)).
        assert_rgb(coated[y][x], want, 0.05, &format!("coated sheen at pixel ({x}, {y})"));
        if (want[0] - uncoated[0]).abs() > 0.2 * uncoated[0] {
            highlights += 1;
        }
    }
    assert!(highlights >= 2, "the coat's highlight must show at some pixels ({highlights})");
}

/// `KHR_materials_anisotropy` on a white metal quad (uv u along +x: its tangent, generated by MikkTSpace, is
/// +x and its bitangent +y): each pixel is E cos θ_i f(wo, wi) of the glTF lobe stretched along the direction
/// the extension gives, computed here from the materials crate's public lobe — the tangent rotated 30°
/// counter-clockwise by `anisotropyRotation`, or, with a texture, each texel's direction (left texel along
/// the tangent, right along the bitangent) so rotated, times its strength. Before, the extension was ignored with a
/// warning: the isotropic lobe everywhere, which the test tells apart (and a rotation of −30°, so the
/// direction's sign is seen too).
#[test]
fn anisotropy_stretches_the_lobe_along_the_extensions_direction() {
    use colorimetry::SampledSpectrum;
    use materials::bsdf::{Bsdf, Frame, GltfMetalRoughBxdf, RoughDielectricBxdf, TrowbridgeReitz};
    let dir = folder("anisotropy");
    let textures = &nearest_texture(&dir, "directions.png", 2, 1, &[[255, 128, 255, 255], [128, 255, 128, 255]]);
    let used =
        r#""extensionsUsed": ["KHR_materials_anisotropy", "KHR_materials_transmission", "KHR_materials_volume"],"#;
    let (roughness, strength, rotation) = (0.5f32, 0.8f32, 30f32.to_radians());
    let material = |anisotropy: &str| {
        format!(
            r#"{{"pbrMetallicRoughness": {{"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 1, "roughnessFactor": {roughness}}},
               "extensions": {{"KHR_materials_anisotropy": {{"anisotropyStrength": {strength}{anisotropy}}}}}}}"#
        )
    };
    let (theta, spp) = (50f64.to_radians(), 512);
    let light = [-theta.sin() * 0.8, -theta.sin() * 0.6, -theta.cos()];
    let render = |m: &str| {
        let gltf = write_gltf_quad(&dir, m, textures, used);
        render_rgb_spp(&scene_around(&dir, &gltf, light, ""), spp)
    };
    let rotated = render(&material(&format!(r#", "anisotropyRotation": {rotation}"#)));
    // The same quad with u mirrored (u along −x): its tangent is −x and its bitangent sign w = −1, so the
    // bitangent stays +y and the rotated direction is mirrored about the y axis.
    let mirrored_uvs = QUAD_UVS.map(|[u, v]| [1.0 - u, v]);
    let mirrored_quad = write_gltf_quad_with_normal(
        &dir,
        &material(&format!(r#", "anisotropyRotation": {rotation}"#)),
        textures,
        used,
        [0.0, 0.0, 1.0],
        mirrored_uvs,
    );
    let mirrored_uv = render_rgb_spp(&scene_around(&dir, &mirrored_quad, light, ""), spp);
    let textured =
        render(&material(&format!(r#", "anisotropyRotation": {rotation}, "anisotropyTexture": {{"index": 0}}"#)));
    // Rough glass (transmission with a volume: the dielectric model) stretched the same way; seen from the
    // light's side, its reflection.
    let glass = render(&format!(
        r#"{{"pbrMetallicRoughness": {{"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0, "roughnessFactor": {roughness}}},
           "extensions": {{"KHR_materials_transmission": {{"transmissionFactor": 1}}, "KHR_materials_volume": {{"thicknessFactor": 1}},
                          "KHR_materials_anisotropy": {{"anisotropyStrength": {strength}, "anisotropyRotation": {rotation}}}}}}}"#
    ));
    let wi = -glam::Vec3::new(light[0] as f32, light[1] as f32, light[2] as f32).normalize();
    let frame = Frame { n: glam::Vec3::Z, ns: glam::Vec3::Z };
    // The lobe with the direction `d` (xy in the tangent frame) and strength `s`, averaged over pixel (x, y)
    // (8 × 8 points: the lobe varies across a pixel by several per cent).
    let averaged = |x: usize, y: usize, lobe: &Bsdf<1>| -> f64 {
        let mut sum = 0.0;
        for (i, j) in (0..64).map(|k| (k % 8, k / 8)) {
            let (u, v) = ((x as f32 + (i as f32 + 0.5) / 8.0) / 4.0, (y as f32 + (j as f32 + 0.5) / 8.0) / 4.0);
            let wo = (glam::Vec3::new(0.0, 0.0, 2.0) - glam::Vec3::new(u - 1.0, 1.0 - v, 0.0)).normalize();
            sum += f64::from(lobe.f_cos(&frame, wo, wi).0[0]);
        }
        E * sum / 64.0
    };
    let expected = |x: usize, y: usize, d: glam::Vec2, s: f32| -> f64 {
        let g = GltfMetalRoughBxdf::new(SampledSpectrum([1.0]), 1.0, roughness, 1.5);
        averaged(
            x,
            y,
            &Bsdf::GltfMetalRough(if s > 0.0 { g.with_anisotropy(s, d.extend(0.0)) } else { g }.compensated()),
        )
    };
    let glass_lobe = |d: glam::Vec2| {
        let distrib = TrowbridgeReitz::stretched(roughness * roughness, strength);
        Bsdf::RoughDielectric(RoughDielectricBxdf::new(distrib, 1.5, SampledSpectrum([1.0]), true).along(d.extend(0.0)))
    };
    let half = 2.0 * 128.0 / 255.0 - 1.0;
    let (along_u, along_v) = (glam::Vec2::new(1.0, half), glam::Vec2::new(half, 1.0));
    let at = |a: f32| glam::Vec2::new(a.cos(), a.sin());
    // The texel's direction turned by the rotation, as the extension says.
    let turned = |d: glam::Vec2| glam::Vec2::from_angle(rotation).rotate(d);
    let (mut distinct, mut glass_distinct) = (0, 0);
    for y in 1..7 {
        for x in 1..7 {
            let want = expected(x, y, at(rotation), strength);
            // A single lobe and a delta light: only the sample's place in the pixel varies (512 of them: the
            // largest deviation measured 1.1 %).
            assert_rgb(rotated[y][x], [want; 3], 0.02, &format!("rotated 30° at pixel ({x}, {y})"));
            let mirror = |d: glam::Vec2| glam::Vec2::new(-d.x, d.y);
            let want_mirrored = expected(x, y, mirror(at(rotation)), strength);
            assert_rgb(mirrored_uv[y][x], [want_mirrored; 3], 0.02, &format!("mirrored uvs at pixel ({x}, {y})"));
            let (d, s) = if x < 4 { (along_u, strength) } else { (along_v, strength * 128.0 / 255.0) };
            let d = turned(d);
            let want_texture = expected(x, y, d, s);
            assert_rgb(textured[y][x], [want_texture; 3], 0.02, &format!("textured at pixel ({x}, {y})"));
            let want_glass = averaged(x, y, &glass_lobe(at(rotation)));
            assert_rgb(glass[y][x], [want_glass; 3], 0.02, &format!("glass at pixel ({x}, {y})"));
            let plain_glass = RoughDielectricBxdf::new(
                TrowbridgeReitz::isotropic(roughness * roughness),
                1.5,
                SampledSpectrum([1.0]),
                true,
            );
            if (want_glass - averaged(x, y, &Bsdf::RoughDielectric(plain_glass))).abs() > 0.1 * want_glass {
                glass_distinct += 1;
            }
            let (isotropic, mirrored) = (expected(x, y, at(0.0), 0.0), expected(x, y, at(-rotation), strength));
            if (want - isotropic).abs() > 0.1 * want && (want - mirrored).abs() > 0.1 * want {
                distinct += 1;
            }
        }
    }
    assert!(distinct >= 12, "only {distinct} pixels tell the rotated lobe from the isotropic and the mirrored one");
    assert!(glass_distinct >= 12, "only {glass_distinct} pixels tell the stretched glass from the isotropic");
}

/// A 512×512 PNG of 64 flat colours (8×8 blocks of 64×64 texels) at `dir/name`: 1 MiB of texels, and as a
/// colour texture 1 MiB of palette indices and 64 entries.
fn write_atlas(dir: &Path, name: &str) {
    let texels: Vec<[u8; 4]> = (0..512 * 512u32)
        .map(|i| {
            let (bx, by) = ((i % 512) / 64, (i / 512) / 64);
            [30 + 25 * bx as u8, 30 + 25 * by as u8, 128, 255]
        })
        .collect();
    write_png(&dir.join(name), 512, 512, &texels);
}

/// The `textures:` note of a scene's assembly.
fn texture_note(scene: &RenderScene) -> &str {
    scene.warnings.iter().find(|w| w.starts_with("textures:")).map_or("(no textures note)", String::as_str)
}

/// `scene`'s image, every pixel's XYZ, path-traced on RGB lanes.
fn render_xyz(scene: &RenderScene) -> Vec<[f32; 3]> {
    let opts = integrator::RenderOptions { spectral: SpectralMode::Rgb, spp: 1, ..options(8, 8) }
        .path(|p| p.max_depth = Some(1));
    let (image, _) = render_with(scene, &opts);
    (0..8).flat_map(|y| (0..8).map(move |x| (x, y))).map(|(x, y)| image.xyz(x, y)).collect()
}

/// One image named by 50 glTF `images` entries (an exporter writing one per texture), each the base colour of
/// its own material: decoded once and fitted once, 1 MiB of indices and 64 colours in all, and the scene
/// renders as one material with the image does. Before, it was decoded 50 times and each material fitted
/// its own copy: "50 images, 50.1 MiB of texel data" (a 4096² atlas used 40 times took 2.6 GB).
#[test]
fn one_image_used_by_fifty_gltf_materials_is_decoded_and_fitted_once() {
    let dir = folder("shared-gltf");
    write_atlas(&dir, "atlas.png");
    let m =
        r#"{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0, "roughnessFactor": 1}}"#;
    let single = write_gltf_quad(&dir, m, r#""textures": [{"source": 0}], "images": [{"uri": "atlas.png"}]"#, "");
    let single = scene_around(&dir, &single, [0.0, 0.0, -1.0], "");
    assert!(
        texture_note(&single).starts_with("textures: 1 images, 1.0 MiB of texel data"),
        "{}",
        texture_note(&single)
    );
    let want = render_xyz(&single);
    // The same quad drawn 50 times over, primitive i with material i, texture i and image i.
    let path = dir.join("quad.gltf");
    let mut gltf: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).expect("read glTF")).expect("glTF JSON");
    let n = 50;
    let material: serde_json::Value = serde_json::from_str(m).expect("material JSON");
    gltf["materials"] = (0..n)
        .map(|i| {
            let mut m = material.clone();
            m["pbrMetallicRoughness"]["baseColorTexture"]["index"] = i.into();
            m
        })
        .collect();
    gltf["textures"] = (0..n).map(|i| serde_json::json!({"source": i})).collect();
    gltf["images"] = (0..n).map(|_| serde_json::json!({"uri": "atlas.png"})).collect();
    let primitive = gltf["meshes"][0]["primitives"][0].clone();
    gltf["meshes"][0]["primitives"] = (0..n)
        .map(|i| {
            let mut p = primitive.clone();
            p["material"] = i.into();
            p
        })
        .collect();
    std::fs::write(&path, gltf.to_string()).expect("write glTF");
    let shared = scene_around(&dir, &path, [0.0, 0.0, -1.0], "");
    assert!(
        texture_note(&shared).starts_with("textures: 1 images, 1.0 MiB of texel data"),
        "{}",
        texture_note(&shared)
    );
    assert_eq!(shared.materials().len(), n + 1, "the 50 materials and the manifest's");
    assert_eq!(render_xyz(&shared), want, "the shared texture renders as the single one");
    std::fs::remove_dir_all(&dir).ok();
}

/// OBJ materials sharing one `map_Kd` (an exported texture atlas): the image was read once already, but each
/// material fitted its own palette ("1 images, 50.1 MiB"); now one palette serves all 50.
#[test]
fn one_map_kd_shared_by_fifty_mtl_materials_is_fitted_once() {
    let dir = folder("shared-mtl");
    write_atlas(&dir, "atlas.png");
    let n = 50;
    let mtl: String = (0..n).map(|i| format!("newmtl m{i}\nKd 0.8 0.8 0.8\nmap_Kd atlas.png\n\n")).collect();
    std::fs::write(dir.join("atlas.mtl"), mtl).expect("write MTL");
    let faces: String = (0..n).map(|i| format!("usemtl m{i}\nf 1/1 4/4 3/3\nf 1/1 3/3 2/2\n")).collect();
    let obj =
        format!("mtllib atlas.mtl\nv -1 1 0\nv 1 1 0\nv 1 -1 0\nv -1 -1 0\nvt 0 1\nvt 1 1\nvt 1 0\nvt 0 0\n{faces}");
    let path = dir.join("atlas.obj");
    std::fs::write(&path, obj).expect("write OBJ");
    let scene = scene_around(&dir, &path, [0.0, 0.0, -1.0], "");
    assert!(texture_note(&scene).starts_with("textures: 1 images, 1.0 MiB of texel data"), "{}", texture_note(&scene));
    assert_eq!(scene.materials().len(), n + 1, "the 50 materials and the manifest's");
    std::fs::remove_dir_all(&dir).ok();
}
