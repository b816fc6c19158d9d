//! Loader tests: every committed scene loads, each format's features and transforms, and each error case
//! (matching the `Err` variant and checking that the message names the file).

use std::path::{Path, PathBuf};

use geometry::{
    AbsorptionDesc, AnisotropyLayer, Clearcoat, Error, IorDesc, LightDesc, LoadOptions, MaterialDesc, MaterialFormat,
    Scene, SceneDescription, SpectrumDesc, SpecularLayer, load_scene, load_scene_with, parse_manifest,
};
use glam::Vec3;
use serde_json::json;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn scene(rel: &str) -> SceneDescription {
    let path = repo().join("scenes").join(rel);
    load_scene(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// A fresh folder for one test's files, under the target directory's temp area.
fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join("spectrace-geometry-loaders").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
    dir
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    path
}

fn f32_bytes(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// A one-triangle glTF document whose buffer comes from `uri` (None: the GLB binary chunk); `nodes` and
/// extra top-level keys are merged in.
fn triangle_gltf(uri: Option<&str>, byte_length: usize, extra: serde_json::Value) -> serde_json::Value {
    let mut buffer = json!({"byteLength": byte_length});
    if let Some(u) = uri {
        buffer["uri"] = json!(u);
    }
    let mut doc = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3"}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}],
        "buffers": [buffer],
    });
    if let (Some(d), Some(e)) = (doc.as_object_mut(), extra.as_object()) {
        for (k, v) in e {
            d.insert(k.clone(), v.clone());
        }
    }
    doc
}

/// [`triangle_gltf`] with its buffer inline and its primitive using material 0 of `extra`.
fn material_triangle(extra: serde_json::Value) -> serde_json::Value {
    let uri = data_uri(&f32_bytes(&TRIANGLE));
    let mut doc = triangle_gltf(Some(&uri), 36, extra);
    doc["meshes"][0]["primitives"][0]["material"] = json!(0);
    doc
}

const TRIANGLE: [f32; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];

fn data_uri(bytes: &[u8]) -> String {
    // Minimal base64 encoder (RFC 4648) so the tests need no extra crate.
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::from("data:application/octet-stream;base64,");
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], *chunk.get(1).unwrap_or(&0), *chunk.get(2).unwrap_or(&0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * i)) as usize & 63] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

fn write_gltf(dir: &Path, name: &str, doc: &serde_json::Value) -> PathBuf {
    write(dir, name, doc.to_string().as_bytes())
}

fn all_scene_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
        let path = entry.unwrap_or_else(|e| panic!("{e}")).path();
        if path.is_dir() {
            all_scene_files(&path, out);
        } else if matches!(path.extension().and_then(|e| e.to_str()), Some("json" | "gltf" | "glb" | "obj")) {
            out.push(path);
        }
    }
}

#[test]
fn every_committed_scene_loads_and_builds() {
    let mut files = Vec::new();
    all_scene_files(&repo().join("scenes"), &mut files);
    files.sort();
    // paper: 4 manifests; meshes: icosphere.obj, gem.gltf; gltf: glass_torus; obj: cube_and_sphere.
    assert!(files.len() >= 8, "{files:?}");
    for path in files {
        let desc = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
        assert!(!desc.spheres.is_empty() || !desc.meshes.is_empty(), "{}: no geometry", path.display());
        for m in desc.meshes.iter().map(|m| m.material()).chain(desc.spheres.iter().map(|s| s.material())) {
            assert!(m.is_none_or(|i| (i as usize) < desc.materials.len()), "{}: bad material index", path.display());
        }
        let built = Scene::build(desc.spheres.clone(), desc.meshes.clone()).unwrap_or_else(|e| panic!("{e}"));
        let triangles: usize = desc.meshes.iter().map(|m| m.triangle_count()).sum();
        assert_eq!(built.triangle_count(), triangles, "{}", path.display());
        // No committed scene has a zero-area or duplicate triangle: the pre-filter changes none of them.
        assert!(!desc.warnings.iter().any(|w| w.contains("cannot be hit")), "{}: {:?}", path.display(), desc.warnings);
    }
}

#[test]
fn five_spheres_has_the_papers_table_1_parameters() {
    let d = scene("paper/five_spheres.json");
    assert_eq!(d.spheres.len(), 5);
    assert!(d.spheres.iter().all(|s| s.radius() == 1.0));
    let camera = d.camera.as_ref().unwrap_or_else(|| panic!("camera"));
    assert_eq!((camera.width, camera.height), (Some(640), Some(480)));
    assert_eq!(d.settings.max_depth, Some(20));
    let [LightDesc::Point { position, spectrum, .. }] = d.lights.as_slice() else { panic!("{:?}", d.lights) };
    assert_eq!(spectrum, &SpectrumDesc::Named("D65".into()));
    // Far from the centre: ≥ 10× the spheres' extent (≈ 11 units).
    assert!(position.distance(Vec3::Y) > 100.0);
    let mut colours = Vec::new();
    for s in &d.spheres {
        let m = &d.materials[s.material().unwrap_or_else(|| panic!("material")) as usize];
        assert_eq!(m.transmission, Some(0.9));
        assert_eq!(m.ks, Some(0.1));
        assert_eq!(m.shininess, Some(20.0));
        assert_eq!(m.ior, Some(IorDesc::Constant(1.3)));
        assert_eq!(m.absorption, Some(AbsorptionDesc::PerUnit(SpectrumDesc::Constant(0.95))));
        colours.push(m.transmittance.clone());
    }
    colours.dedup();
    assert_eq!(colours.len(), 5, "each sphere has its own colour");
}

#[test]
fn mesh_variants_have_the_expected_triangle_counts() {
    // Icosphere with 4 subdivisions: 20·4⁴ = 5120 triangles; backdrop: 2 quads of 2 triangles.
    let one = scene("paper/one_sphere_mesh.json");
    assert_eq!(one.meshes.iter().map(|m| m.triangle_count()).sum::<usize>(), 5120 + 4);
    let four = scene("paper/four_spheres_mesh.json");
    assert_eq!(four.meshes.iter().map(|m| m.triangle_count()).sum::<usize>(), 4 * 5120 + 4);
    // Transform translate (0.9, 0.6, 0), scale 0.6 on a unit sphere: x ∈ [0.3, 1.5].
    let (lo, hi) = bounds(four.meshes[2].positions());
    assert!((lo.x - 0.3).abs() < 1e-5 && (hi.x - 1.5).abs() < 1e-5, "{lo} {hi}");
    let gem = scene("paper/gltf_mesh.json");
    assert_eq!(gem.meshes.iter().map(|m| m.triangle_count()).sum::<usize>(), 64 + 4);
}

fn bounds(points: &[Vec3]) -> (Vec3, Vec3) {
    points.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| (lo.min(*p), hi.max(*p)))
}

#[test]
fn glass_torus_reads_transmission_ior_volume_light_and_camera() {
    let d = scene("gltf/glass_torus.gltf");
    let glass = d.materials.iter().find(|m| m.name == "green glass").unwrap_or_else(|| panic!("{:?}", d.materials));
    assert_eq!(glass.transmission, Some(1.0));
    assert_eq!(glass.ior, Some(IorDesc::Constant(1.5)));
    assert_eq!(glass.thickness, Some(0.7));
    assert_eq!(glass.absorption, Some(AbsorptionDesc::Attenuation { color: [0.55, 0.9, 0.6], distance: 0.8 }));
    assert!(glass.extras.is_some());
    // The light's extras carry a spectral override ("D65") that replaces its RGB colour.
    let [LightDesc::Point { position, spectrum, intensity }] = d.lights.as_slice() else { panic!("{:?}", d.lights) };
    assert_eq!(spectrum, &SpectrumDesc::Named("D65".into()));
    assert_eq!(*position, Vec3::new(-3.0, 6.0, 4.0));
    assert_eq!(
        *intensity,
        geometry::LightAmount { value: 47.0, unit: geometry::LightUnit::Candela },
        "KHR_lights_punctual point lights are in candela"
    );
    let c = d.camera.as_ref().unwrap_or_else(|| panic!("camera"));
    // yfov 0.6981317 rad = 40°.
    assert!((c.vfov_deg - 40.0).abs() < 1e-4);
    assert_eq!(c.position, Vec3::new(0.0, 2.2, 5.5));
    // The camera node is rotated −20° about x: it looks down −z, tilted 20° down.
    let dir = (c.look_at - c.position).normalize();
    assert!((dir - Vec3::new(0.0, -(20f32.to_radians().sin()), -(20f32.to_radians().cos()))).length() < 1e-5, "{dir}");
    assert!(d.warnings.is_empty(), "{:?}", d.warnings);
    assert_eq!(d.meshes.iter().map(|m| m.triangle_count()).sum::<usize>(), 64 * 24 * 2 + 2);
}

#[test]
fn gem_reads_dispersion_from_the_raw_extension() {
    let d = scene("meshes/gem.gltf");
    assert_eq!(d.materials[0].dispersion, Some(0.453));
    assert_eq!(d.materials[0].ior, Some(IorDesc::Constant(2.417)));
    assert_eq!(d.materials[0].transmission, Some(1.0));
    // No camera or light in the file, and none added: defaults are the assembly's.
    assert!(d.camera.is_none() && d.lights.is_empty());
}

#[test]
fn obj_scene_reads_mtl_with_one_component_kd() {
    let d = scene("obj/cube_and_sphere.obj");
    let by_name = |n: &str| d.materials.iter().find(|m| m.name == n).unwrap_or_else(|| panic!("{n}"));
    // `Kd 0.5` means grey 0.5 (MTL: g and b default to r).
    assert_eq!(by_name("floor").base_color, Some(SpectrumDesc::Rgb([0.5; 3])));
    let glass = by_name("glass");
    assert_eq!(glass.ior, Some(IorDesc::Constant(1.5)));
    assert_eq!(glass.transmittance, Some(SpectrumDesc::Rgb([0.9, 0.95, 0.9])));
    // illum 7 with d = 1: transmission from Tf's largest component.
    assert_eq!((glass.illum, glass.dissolve), (Some(7), Some(1.0)));
    assert_eq!(glass.model, None);
    assert_eq!(by_name("red_paint").shininess, Some(50.0));
    // floor (quad → 2 triangles), cube (6 quads → 12), sphere (320).
    assert_eq!(d.meshes.iter().map(|m| m.triangle_count()).sum::<usize>(), 2 + 12 + 320);
}

#[test]
fn gltf_external_buffer_loads() {
    let dir = temp_dir("external");
    write(&dir, "tri.bin", &f32_bytes(&TRIANGLE));
    let path = write_gltf(&dir, "tri.gltf", &triangle_gltf(Some("tri.bin"), 36, json!({})));
    let d = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(d.meshes[0].positions()[1], Vec3::X);
}

#[test]
fn gltf_embedded_buffer_loads() {
    let dir = temp_dir("embedded");
    let uri = data_uri(&f32_bytes(&TRIANGLE));
    let path = write_gltf(&dir, "tri.gltf", &triangle_gltf(Some(&uri), 36, json!({})));
    let d = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(d.meshes[0].positions()[2], Vec3::Y);
}

#[test]
fn glb_loads() {
    let dir = temp_dir("glb");
    let mut json_chunk = triangle_gltf(None, 36, json!({})).to_string().into_bytes();
    while !json_chunk.len().is_multiple_of(4) {
        json_chunk.push(b' ');
    }
    let bin = f32_bytes(&TRIANGLE);
    // GLB: 12-byte header, then chunks of (length, type, data); glTF 2.0 §4.4.
    let total = 12 + 8 + json_chunk.len() + 8 + bin.len();
    let mut glb = Vec::new();
    glb.extend_from_slice(b"glTF");
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&(total as u32).to_le_bytes());
    glb.extend_from_slice(&(json_chunk.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"JSON");
    glb.extend_from_slice(&json_chunk);
    glb.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"BIN\0");
    glb.extend_from_slice(&bin);
    let path = write(&dir, "tri.glb", &glb);
    let d = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(d.meshes[0].positions(), &[Vec3::ZERO, Vec3::X, Vec3::Y]);
}

#[test]
fn gltf_node_transforms_are_flattened_into_world_space() {
    let dir = temp_dir("transforms");
    let uri = data_uri(&f32_bytes(&TRIANGLE));
    // Parent translates by (10, 0, 0); child scales by 2: vertex (1, 0, 0) → (2, 0, 0) → (12, 0, 0).
    let doc = triangle_gltf(
        Some(&uri),
        36,
        json!({"nodes": [{"translation": [10, 0, 0], "children": [1]}, {"scale": [2, 2, 2], "mesh": 0}]}),
    );
    let d = load_scene(&write_gltf(&dir, "t.gltf", &doc)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(d.meshes[0].positions()[1], Vec3::new(12.0, 0.0, 0.0));
    assert_eq!(d.meshes[0].positions()[2], Vec3::new(10.0, 2.0, 0.0));
}

#[test]
fn gltf_mirroring_transform_keeps_winding_outward() {
    let dir = temp_dir("mirror");
    let uri = data_uri(&f32_bytes(&TRIANGLE));
    let doc = triangle_gltf(Some(&uri), 36, json!({"nodes": [{"scale": [1, 1, -1], "mesh": 0}]}));
    let d = load_scene(&write_gltf(&dir, "m.gltf", &doc)).unwrap_or_else(|e| panic!("{e}"));
    // The triangle lies in z = 0 facing +z. Mirroring z leaves the positions in place, but a mirror turns the
    // outward side to −z (glTF 2.0 §3.7.4 reverses the winding when det < 0).
    let p = d.meshes[0].positions();
    let [a, b, c] = d.meshes[0].indices()[0];
    let n = (p[b as usize] - p[a as usize]).cross(p[c as usize] - p[a as usize]);
    assert!(n.z < 0.0, "a mirrored +z face points to −z in world space: {n}");
}

#[test]
fn gltf_triangle_lists_of_partial_triangles_are_noted() {
    let dir = temp_dir("partial-triangles");
    // Four vertices, not indexed: one triangle and one vertex left over.
    let mut four = TRIANGLE.to_vec();
    four.extend([1.0, 1.0, 0.0]);
    let mut doc = triangle_gltf(Some(&data_uri(&f32_bytes(&four))), 48, json!({}));
    doc["accessors"][0]["count"] = json!(4);
    doc["bufferViews"][0]["byteLength"] = json!(48);
    let d = load_scene(&write_gltf(&dir, "p.gltf", &doc)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(d.meshes[0].indices(), &[[0, 1, 2]]);
    let notes: Vec<&String> = d.warnings.iter().filter(|w| w.contains("multiple of 3")).collect();
    assert_eq!(notes.len(), 1, "{:?}", d.warnings);
    assert!(
        notes[0].contains("p.gltf")
            && notes[0].contains("meshes[0] primitive 0: 4 vertices (not indexed)")
            && notes[0].contains("the last 1 ignored"),
        "{}",
        notes[0]
    );
    // Five u16 indices: one triangle, two left over; the mesh placed twice is noted once.
    let mut bytes = f32_bytes(&TRIANGLE);
    bytes.extend([0u16, 1, 2, 0, 1].iter().flat_map(|i| i.to_le_bytes()));
    let mut doc = triangle_gltf(Some(&data_uri(&bytes)), 46, json!({}));
    doc["bufferViews"] = json!([{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 10}]);
    doc["accessors"]
        .as_array_mut()
        .unwrap_or_else(|| panic!("accessors"))
        .push(json!({"bufferView": 1, "componentType": 5123, "count": 5, "type": "SCALAR"}));
    doc["meshes"][0]["primitives"][0]["indices"] = json!(1);
    doc["nodes"] = json!([{"mesh": 0}, {"mesh": 0, "translation": [5, 0, 0]}]);
    doc["scenes"] = json!([{"nodes": [0, 1]}]);
    let d = load_scene(&write_gltf(&dir, "i.gltf", &doc)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(d.meshes.len(), 2);
    let notes: Vec<&String> = d.warnings.iter().filter(|w| w.contains("multiple of 3")).collect();
    assert_eq!(notes.len(), 1, "{:?}", d.warnings);
    assert!(notes[0].contains("i.gltf") && notes[0].contains("5 indices") && notes[0].contains("last 2"), "{notes:?}");
}

#[test]
fn gltf_projective_node_matrix_is_noted_and_read_as_affine() {
    let dir = temp_dir("projective");
    let uri = data_uri(&f32_bytes(&TRIANGLE));
    // Column-major: translation (2, 0, 0), bottom row (0.5, 0, 0, -1).
    let matrix = json!([1, 0, 0, 0.5, 0, 1, 0, 0, 0, 0, 1, 0, 2, 0, 0, -1]);
    let doc = triangle_gltf(Some(&uri), 36, json!({"nodes": [{"matrix": matrix, "mesh": 0, "name": "lens"}]}));
    let d = load_scene(&write_gltf(&dir, "p.gltf", &doc)).unwrap_or_else(|e| panic!("{e}"));
    let p = d.meshes[0].positions();
    assert_eq!(p[1], Vec3::new(3.0, 0.0, 0.0));
    // The affine part does not mirror: the face still points to +z (the determinant of the matrix as
    // written, −1, would have reversed the winding).
    let [a, b, c] = d.meshes[0].indices()[0];
    let n = (p[b as usize] - p[a as usize]).cross(p[c as usize] - p[a as usize]);
    assert!(n.z > 0.0, "{n}");
    let note = d.warnings.iter().find(|w| w.contains("bottom row")).unwrap_or_else(|| panic!("{:?}", d.warnings));
    assert!(note.contains("p.gltf: nodes[0] 'lens'") && note.contains("(0.5, 0, 0, -1)"), "{note}");
}

#[test]
fn gltf_buffer_shorter_than_a_view_is_an_error_naming_both() {
    let dir = temp_dir("short-buffer");
    // 36 bytes of data, but the buffer declares 24: the view's last 12 bytes are not the buffer's.
    let uri = data_uri(&f32_bytes(&TRIANGLE));
    let (e, msg) = error_message(&write_gltf(&dir, "s.gltf", &triangle_gltf(Some(&uri), 24, json!({}))));
    assert!(matches!(&e, Error::GltfData { context, .. } if context == "bufferViews[0]"), "{e:?}");
    assert!(msg.contains("byteOffset 0 + byteLength 36 passes the end of buffers[0] (byteLength 24)"), "{msg}");
    // A view starting inside the buffer and ending past it.
    let mut doc = triangle_gltf(Some(&uri), 36, json!({}));
    doc["bufferViews"][0]["byteOffset"] = json!(12);
    let (_, msg) = error_message(&write_gltf(&dir, "o.gltf", &doc));
    assert!(msg.contains("bufferViews[0]: byteOffset 12 + byteLength 36 passes the end of buffers[0]"), "{msg}");
}

#[test]
fn gltf_strips_are_triangulated_and_lines_skipped() {
    let dir = temp_dir("modes");
    let quad = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0];
    let uri = data_uri(&f32_bytes(&quad));
    let doc = json!({
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [
            {"attributes": {"POSITION": 0}, "mode": 5},
            {"attributes": {"POSITION": 0}, "mode": 1}
        ]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3"}],
        "bufferViews": [{"buffer": 0, "byteLength": 48}],
        "buffers": [{"byteLength": 48, "uri": uri}],
    });
    let d = load_scene(&write_gltf(&dir, "s.gltf", &doc)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(d.meshes.len(), 1);
    assert_eq!(d.meshes[0].indices(), &[[0, 1, 2], [2, 1, 3]]);
    assert!(d.warnings.iter().any(|w| w.contains("Lines")), "{:?}", d.warnings);
}

#[test]
fn gltf_ior_zero_is_kept() {
    let dir = temp_dir("ior0");
    let doc = material_triangle(
        json!({"materials": [{"extensions": {"KHR_materials_ior": {"ior": 0.0}}}], "extensionsUsed": ["KHR_materials_ior"]}),
    );
    let d = load_scene(&write_gltf(&dir, "i.gltf", &doc)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(d.materials[0].ior, Some(IorDesc::Constant(0.0)));
}

fn error_message(path: &Path) -> (Error, String) {
    let e = load_scene(path).err().unwrap_or_else(|| panic!("{} loaded", path.display()));
    let msg = e.to_string();
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or_default();
    assert!(msg.contains(name), "message does not name {name}: {msg}");
    (e, msg)
}

#[test]
fn gltf_missing_buffer_file_names_it() {
    let dir = temp_dir("missing-buffer");
    let path = write_gltf(&dir, "m.gltf", &triangle_gltf(Some("nowhere.bin"), 36, json!({})));
    let (e, msg) = error_message(&path);
    assert!(matches!(e, Error::GltfBuffer { buffer: 0, .. }), "{e:?}");
    assert!(msg.contains("nowhere.bin"), "{msg}");
}

#[test]
fn gltf_index_out_of_range_is_an_error() {
    let dir = temp_dir("bad-index");
    let mut bytes = f32_bytes(&TRIANGLE);
    bytes.extend_from_slice(&[0, 0, 1, 0, 7, 0, 0, 0]); // u16 indices 0, 1, 7 (+ padding)
    let uri = data_uri(&bytes);
    let mut doc = triangle_gltf(Some(&uri), 44, json!({}));
    doc["bufferViews"] = json!([{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}]);
    doc["accessors"]
        .as_array_mut()
        .unwrap_or_else(|| panic!("accessors"))
        .push(json!({"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}));
    doc["meshes"][0]["primitives"][0]["indices"] = json!(1);
    let (e, _) = error_message(&write_gltf(&dir, "b.gltf", &doc));
    assert!(matches!(e, Error::IndexOutOfRange { index: 7, vertex_count: 3, .. }), "{e:?}");
}

#[test]
fn gltf_nan_and_infinite_vertices_are_errors() {
    let dir = temp_dir("nan");
    for (name, bad) in [("nan.gltf", f32::NAN), ("inf.gltf", f32::INFINITY)] {
        let mut tri = TRIANGLE;
        tri[4] = bad;
        let uri = data_uri(&f32_bytes(&tri));
        let (e, _) = error_message(&write_gltf(&dir, name, &triangle_gltf(Some(&uri), 36, json!({}))));
        assert!(matches!(e, Error::NonFiniteVertex { vertex: 1, .. }), "{e:?}");
    }
}

#[test]
fn gltf_unsupported_required_extension_is_named() {
    let dir = temp_dir("required");
    let uri = data_uri(&f32_bytes(&TRIANGLE));
    let doc = triangle_gltf(
        Some(&uri),
        36,
        json!({"extensionsUsed": ["EXT_lights_image_based"], "extensionsRequired": ["EXT_lights_image_based"]}),
    );
    let (e, msg) = error_message(&write_gltf(&dir, "d.gltf", &doc));
    assert!(matches!(e, Error::UnsupportedExtension { .. }), "{e:?}");
    assert!(msg.contains("EXT_lights_image_based"), "{msg}");
    // Draco required but used by no primitive: nothing is missing, so the file loads (see
    // `compressed_data_variants_and_animations_get_one_line_each`).
    let doc = triangle_gltf(
        Some(&uri),
        36,
        json!({"extensionsUsed": ["KHR_draco_mesh_compression"], "extensionsRequired": ["KHR_draco_mesh_compression"]}),
    );
    assert!(load_scene(&write_gltf(&dir, "draco_unused.gltf", &doc)).is_ok());
}

#[test]
fn gltf_required_volume_and_dispersion_are_accepted() {
    let dir = temp_dir("required-ok");
    let uri = data_uri(&f32_bytes(&TRIANGLE));
    let doc = triangle_gltf(
        Some(&uri),
        36,
        json!({"extensionsUsed": ["KHR_materials_volume", "KHR_materials_dispersion"],
               "extensionsRequired": ["KHR_materials_volume", "KHR_materials_dispersion"]}),
    );
    load_scene(&write_gltf(&dir, "ok.gltf", &doc)).unwrap_or_else(|e| panic!("{e}"));
}

#[test]
fn gltf_specular_and_clearcoat_factors_and_textures_are_read() {
    let dir = temp_dir("specular-clearcoat");
    let doc = material_triangle(json!({"extensionsUsed": ["KHR_materials_specular", "KHR_materials_clearcoat"],
    "extensionsRequired": ["KHR_materials_specular", "KHR_materials_clearcoat"],
    "textures": [{"source": 0}, {"source": 1}],
    "images": [{"uri": "data:image/png;base64,AAEC"}, {"uri": "data:image/png;base64,AAED"}],
    "materials": [
        {"name": "coated", "extensions": {
            "KHR_materials_specular": {"specularFactor": 0.3, "specularColorFactor": [2.0, 1.0, 0.5],
                                       "specularColorTexture": {"index": 1}},
            "KHR_materials_clearcoat": {"clearcoatFactor": 0.7, "clearcoatRoughnessFactor": 0.2,
                                        "clearcoatNormalTexture": {"index": 0, "scale": 0.5}}}},
        {"name": "defaults", "extensions": {"KHR_materials_specular": {},
                                            "KHR_materials_clearcoat": {}}},
        {"name": "bad", "extensions": {"KHR_materials_specular": {"specularFactor": 4.0,
                                                                   "specularColorFactor": [1, -1, 1]}}}
    ]}));
    let d = load_scene(&write_gltf(&dir, "coat.gltf", &doc)).unwrap_or_else(|e| panic!("{e}"));
    let m = |name: &str| d.materials.iter().find(|m| m.name == name).unwrap_or_else(|| panic!("{name}"));
    assert_eq!(m("coated").specular_layer, Some(SpecularLayer { factor: 0.3, color: [2.0, 1.0, 0.5] }));
    assert_eq!(m("coated").clearcoat, Some(Clearcoat { factor: 0.7, roughness: 0.2 }));
    // The extensions' defaults: the plain layer; a coat of factor 0 is no coat.
    assert_eq!(m("defaults").specular_layer, Some(SpecularLayer { factor: 1.0, color: [1.0; 3] }));
    assert_eq!(m("defaults").clearcoat, None);
    // Out-of-range values fall back to the defaults, each with a warning naming the key.
    assert_eq!(m("bad").specular_layer, Some(SpecularLayer { factor: 1.0, color: [1.0; 3] }));
    let said = |s: &str| d.warnings.iter().any(|w| w.contains(s));
    assert!(said("'bad': specularFactor 4"), "{:?}", d.warnings);
    assert!(said("'bad': KHR_materials_specular.specularColorFactor"), "{:?}", d.warnings);
    // Every texture of both extensions is read: the coat's normal map with its `scale`.
    let textures = &m("coated").textures;
    // (Images are numbered as first read: the specular colour's comes first.)
    assert_eq!(textures.specular_color.as_ref().map(|t| t.image), Some(0));
    assert_eq!(textures.clearcoat_normal.as_ref().map(|t| (t.image, t.scale)), Some((1, 0.5)));
    assert!(textures.has_normal_map(), "the coat's map needs tangents");
    assert!(!said("ignored"), "{:?}", d.warnings);
    assert!(!said("not rendered yet"), "{:?}", d.warnings);
}

/// `KHR_materials_anisotropy` (required, as Blender writes it): strength, rotation and texture are read, a
/// strength of 0 is no anisotropy, and a bad rotation falls back to 0 with a warning.
#[test]
fn gltf_anisotropy_factors_and_texture_are_read() {
    let dir = temp_dir("anisotropy");
    let doc = material_triangle(
        json!({"extensionsUsed": ["KHR_materials_anisotropy"], "extensionsRequired": ["KHR_materials_anisotropy"],
        "textures": [{"source": 0}], "images": [{"uri": "data:image/png;base64,AAEC"}],
        "materials": [
            {"name": "brushed", "extensions": {"KHR_materials_anisotropy": {
                "anisotropyStrength": 0.6, "anisotropyRotation": 1.57, "anisotropyTexture": {"index": 0}}}},
            {"name": "none", "extensions": {"KHR_materials_anisotropy": {}}},
            {"name": "bad", "extensions": {"KHR_materials_anisotropy": {"anisotropyStrength": 1, "anisotropyRotation": "x"}}}
        ]}),
    );
    let d = load_scene(&write_gltf(&dir, "brushed.gltf", &doc)).unwrap_or_else(|e| panic!("{e}"));
    let m = |name: &str| d.materials.iter().find(|m| m.name == name).unwrap_or_else(|| panic!("{name}"));
    assert_eq!(m("brushed").anisotropy, Some(AnisotropyLayer { strength: 0.6, rotation: 1.57 }));
    assert_eq!(m("brushed").textures.anisotropy.as_ref().map(|t| t.image), Some(0));
    assert!(m("brushed").needs_tangents(), "the direction is given in tangent space");
    assert_eq!(m("none").anisotropy, None);
    assert!(!m("none").needs_tangents());
    assert_eq!(m("bad").anisotropy, Some(AnisotropyLayer { strength: 1.0, rotation: 0.0 }));
    let said = |s: &str| d.warnings.iter().any(|w| w.contains(s));
    assert!(said("'bad': anisotropyRotation \"x\""), "{:?}", d.warnings);
    assert!(!said("not rendered yet"), "{:?}", d.warnings);
}

#[test]
fn gltf_malformed_json_is_a_gltf_error() {
    let dir = temp_dir("malformed-gltf");
    let (e, _) = error_message(&write(&dir, "x.gltf", b"{\"asset\": {\"version\": \"2.0\"},"));
    assert!(matches!(e, Error::Gltf { .. }), "{e:?}");
}

#[test]
fn manifest_missing_material_names_it() {
    let text = r#"{"materials": {"glass": {}}, "objects": [{"type": "sphere", "center": [0,0,0], "radius": 1, "material": "glas"}]}"#;
    let e = parse_manifest(text, Path::new("."), "m.json").err().unwrap_or_else(|| panic!("loaded"));
    assert!(matches!(&e, Error::MissingMaterial { name, .. } if name == "glas"), "{e:?}");
    let msg = e.to_string();
    assert!(msg.contains("m.json") && msg.contains("`glas`") && msg.contains("glass"), "{msg}");
}

#[test]
fn manifest_unknown_top_level_key_is_named() {
    let e = parse_manifest(r#"{"camra": {}}"#, Path::new("."), "m.json").err().unwrap_or_else(|| panic!("loaded"));
    assert!(matches!(e, Error::ManifestSyntax { .. }), "{e:?}");
    let msg = e.to_string();
    assert!(msg.contains("camra") && msg.contains("m.json"), "{msg}");
}

#[test]
fn manifest_malformed_json_is_a_syntax_error_with_line() {
    let dir = temp_dir("malformed-manifest");
    let (e, msg) = error_message(&write(&dir, "bad.json", b"{\n  \"lights\": [\n}"));
    assert!(matches!(e, Error::ManifestSyntax { .. }), "{e:?}");
    assert!(msg.contains("line 3"), "{msg}");
}

#[test]
fn manifest_bad_value_names_its_path() {
    let text = r#"{"materials": {"g": {"ior": {"abbe": {"nd": 1.5, "vd": -3}}}}}"#;
    let e = parse_manifest(text, Path::new("."), "m.json").err().unwrap_or_else(|| panic!("loaded"));
    assert!(matches!(&e, Error::ManifestValue { context, .. } if context == "materials.g.ior.abbe"), "{e:?}");
}

#[test]
fn manifest_mesh_reference_with_matrix_and_file_materials() {
    let dir = temp_dir("manifest-mesh");
    let doc = material_triangle(
        json!({"materials": [{"name": "red", "pbrMetallicRoughness": {"baseColorFactor": [1, 0, 0, 1]}}]}),
    );
    write_gltf(&dir, "tri.gltf", &doc);
    let text = r#"{
        "materials": {"white": {"base_color": 1}},
        "objects": [
            {"type": "mesh", "file": "tri.gltf", "transform": {"matrix": [[1,0,0,3],[0,1,0,0],[0,0,1,0],[0,0,0,1]]}},
            {"type": "sphere", "center": [0,0,0], "radius": 1, "material": "white"}
        ]
    }"#;
    let d = parse_manifest(text, &dir, "m.json").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(d.meshes[0].positions()[1], Vec3::new(4.0, 0.0, 0.0));
    // The file's material is appended after the manifest's and the mesh points to it.
    let m = d.meshes[0].material().unwrap_or_else(|| panic!("material")) as usize;
    assert_eq!(d.materials[m].name, "red");
    assert_eq!(d.materials[m].base_color, Some(SpectrumDesc::Rgb([1.0, 0.0, 0.0])));
}

/// Two textured glTF files in one manifest: the second file's images follow the first's, and every texture
/// role of its materials (the extensions' too) points to its own images.
#[test]
fn manifest_includes_shift_every_texture_role_to_their_own_images() {
    let dir = temp_dir("manifest-two-gltf");
    let textured = |name: &str| {
        material_triangle(
            json!({"extensionsUsed": ["KHR_materials_sheen", "KHR_materials_anisotropy", "KHR_materials_clearcoat"],
            "textures": [{"source": 0}, {"source": 1}],
            "images": [{"uri": "data:image/png;base64,AAEC"}, {"uri": "data:image/png;base64,AAED"}],
            "materials": [{"name": name, "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}},
                "extensions": {
                    "KHR_materials_sheen": {"sheenColorFactor": [1, 1, 1], "sheenRoughnessTexture": {"index": 1}},
                    "KHR_materials_anisotropy": {"anisotropyStrength": 1, "anisotropyTexture": {"index": 1}},
                    "KHR_materials_clearcoat": {"clearcoatFactor": 1, "clearcoatTexture": {"index": 1}}}}]}),
        )
    };
    write_gltf(&dir, "a.gltf", &textured("a"));
    write_gltf(&dir, "b.gltf", &textured("b"));
    let text = r#"{"objects": [{"type": "mesh", "file": "a.gltf"}, {"type": "mesh", "file": "b.gltf"}]}"#;
    let d = parse_manifest(text, &dir, "m.json").unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(d.images.len(), 4);
    let m = |name: &str| d.materials.iter().find(|m| m.name == name).unwrap_or_else(|| panic!("{name}"));
    for (name, first) in [("a", 0), ("b", 2)] {
        let t = &m(name).textures;
        assert_eq!(t.base_color.as_ref().map(|t| t.image), Some(first), "{name}");
        for (role, texture) in
            [("sheen roughness", &t.sheen_roughness), ("anisotropy", &t.anisotropy), ("clearcoat", &t.clearcoat)]
        {
            assert_eq!(texture.as_ref().map(|t| t.image), Some(first + 1), "{name}: {role}");
        }
    }
}

#[test]
fn mtl_one_component_kd_loads_as_grey() {
    let dir = temp_dir("kd-one");
    write(&dir, "a.mtl", b"newmtl grey\nKd 0.5\n");
    let path = write(&dir, "a.obj", b"mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl grey\nf 1 2 3\n");
    let d = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(d.materials[0].base_color, Some(SpectrumDesc::Rgb([0.5, 0.5, 0.5])));
    assert_eq!(d.meshes[0].material(), Some(0));
}

#[test]
fn mtl_spectral_kd_does_not_panic_and_is_kept() {
    let dir = temp_dir("kd-spectral");
    write(&dir, "a.mtl", b"newmtl s\nKd spectral x.rfl\nKs spectral refl.csv\n");
    write(&dir, "refl.csv", b"nm,r\n400,0.1\n700,0.2\n");
    let path = write(&dir, "a.obj", b"mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl s\nf 1 2 3\n");
    let d = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    let m = &d.materials[0];
    assert!(d.warnings.iter().any(|w| w.contains("x.rfl")), "{:?}", d.warnings);
    assert!(m.extras.as_ref().is_some_and(|x| x.get("Kd_spectral").is_some()), "{:?}", m.extras);
    assert_eq!(m.specular, Some(SpectrumDesc::Csv { path: dir.join("refl.csv"), column: None }));
}

#[test]
fn mtl_bad_line_names_file_and_line() {
    let dir = temp_dir("mtl-bad");
    write(&dir, "a.mtl", b"newmtl s\n# comment\nKs 0.5 0.5\n");
    let path = write(&dir, "a.obj", b"mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let e = load_scene(&path).err().unwrap_or_else(|| panic!("loaded"));
    assert!(matches!(e, Error::ObjSyntax { line: 3, .. }), "{e:?}");
    assert!(e.to_string().contains("a.mtl:3"), "{e}");
}

#[test]
fn a_repeated_mtllib_reads_its_file_once() {
    let dir = temp_dir("mtllib-repeated");
    let mtl: String = (0..50).map(|i| format!("newmtl m{i}\nKd 0.{i:02} 0.5 0.5\n")).collect();
    write(&dir, "many.mtl", mtl.as_bytes());
    write(&dir, "other.mtl", b"newmtl extra\nKd 1 0 0\n");
    // 200 lines naming many.mtl (one of them as ./many.mtl, the same file), then another file once.
    let mut obj = "mtllib many.mtl\n".repeat(199);
    obj.push_str("mtllib ./many.mtl\nmtllib other.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m7\nf 1 2 3\n");
    let d = load_scene(&write(&dir, "r.obj", obj.as_bytes())).unwrap_or_else(|e| panic!("{e}"));
    let names: Vec<&str> = d.materials.iter().map(|m| m.name.as_str()).collect();
    assert_eq!(names.len(), 51, "{} materials", names.len());
    assert_eq!(names[7], "m7");
    assert_eq!(names[50], "extra");
    assert_eq!(d.meshes[0].material(), Some(7));
    assert_eq!(d.materials[7].base_color, Some(SpectrumDesc::Rgb([0.07, 0.5, 0.5])));
    let notes: Vec<&String> = d.warnings.iter().filter(|w| w.contains("mtllib")).collect();
    assert_eq!(notes.len(), 1, "{notes:?}");
    assert!(notes[0].contains("r.obj") && notes[0].contains("199 `mtllib` line(s)"), "{}", notes[0]);
}

#[test]
fn mtl_material_structures_are_charged_to_the_budget() {
    let dir = temp_dir("mtl-budget");
    // 20 000 materials in a 270 KB file: the file fits a 4 MiB budget, its materials' records do not.
    let mtl: String = (0..20_000).map(|i| format!("newmtl m{i}\n")).collect();
    assert!(mtl.len() < 300_000);
    write(&dir, "big.mtl", mtl.as_bytes());
    let path = write(&dir, "b.obj", b"mtllib big.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let small = LoadOptions { max_memory: 4 << 20, ..LoadOptions::default() };
    let e = load_scene_with(&path, &small).err().unwrap_or_else(|| panic!("20 000 materials fit in 4 MiB"));
    let msg = e.to_string();
    assert!(matches!(e, Error::OverBudget { requested, .. } if requested > 4 << 20), "{e:?}");
    assert!(msg.contains("big.mtl") && msg.contains("20000 materials"), "{msg}");
    // The default budget reads it, and the charge is in the description's accounting.
    let d = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(d.materials.len(), 20_000);
    assert!(d.memory.used > 20_000 * 2048, "{}", d.memory.used);
}

#[test]
fn obj_nan_vertex_and_bad_face_index_are_errors() {
    let dir = temp_dir("obj-bad");
    let (e, msg) = error_message(&write(&dir, "nan.obj", b"v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n"));
    assert!(matches!(e, Error::NonFiniteVertex { vertex: 1, .. }), "{e:?}");
    assert!(msg.contains("line 2"), "{msg}");
    let (e, msg) = error_message(&write(&dir, "idx.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n"));
    assert!(matches!(e, Error::IndexOutOfRange { index: 4, vertex_count: 3, .. }), "{e:?}");
    assert!(msg.contains("line 4"), "{msg}");
    let (e, _) = error_message(&write(&dir, "huge.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/-99999999999999 2 3\n"));
    assert!(matches!(e, Error::IndexOutOfRange { .. }), "{e:?}");
}

#[test]
fn obj_faces_of_fewer_than_three_vertices_are_noted() {
    let dir = temp_dir("obj-short-faces");
    let obj = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2\nf 3\nf 2 3\n";
    let d = load_scene(&write(&dir, "s.obj", obj)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(d.meshes[0].triangle_count(), 1);
    let notes: Vec<&String> = d.warnings.iter().filter(|w| w.contains("fewer than 3")).collect();
    assert_eq!(notes.len(), 1, "{:?}", d.warnings);
    assert!(notes[0].contains("s.obj: 3 face(s)") && notes[0].contains("line 5"), "{}", notes[0]);
    // A face of no vertices is malformed: an error with its line.
    let (e, msg) = error_message(&write(&dir, "e.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf\n"));
    assert!(matches!(e, Error::ObjSyntax { line: 5, .. }), "{e:?}");
    assert!(msg.contains("e.obj:5: `f` without vertices"), "{msg}");
}

#[test]
fn unknown_extension_is_refused() {
    let dir = temp_dir("ext");
    let (e, _) = error_message(&write(&dir, "scene.ply", b"ply"));
    assert!(matches!(e, Error::UnsupportedFormat { .. }), "{e:?}");
}

#[test]
fn manifest_transform_that_makes_a_vertex_nan_is_refused() {
    // A finite, invertible matrix (determinant 2) whose first row sends (1e18, −1e18, 0) to
    // 1e48 − 1e48 = ∞ − ∞ = NaN in f32. The file itself is valid (|coordinates| ≤ 1e18), so only
    // the check after the manifest's transform can refuse it, and it must: a NaN vertex would
    // reach the BVH build.
    let dir = temp_dir("nan-transform");
    write(&dir, "far.obj", b"v 1e18 -1e18 0\nv 0 0 0\nv 0 0 1\nf 1 2 3\n");
    let text = r#"{"objects": [{"type": "mesh", "file": "far.obj",
        "transform": {"matrix": [[1e30, 1e30, 0, 0], [-1e-30, 1e-30, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}}]}"#;
    let (e, msg) = error_message(&write(&dir, "m.json", text.as_bytes()));
    let Error::IncludedFile { context, cause, .. } = &e else { panic!("{e:?}") };
    assert_eq!(context, "objects[0]");
    assert!(matches!(**cause, Error::CoordinateTooLarge { vertex: 0, .. }), "{cause:?}");
    assert!(msg.contains("objects[0]") && msg.contains("far.obj"), "{msg}");
}

/// A manifest including a glTF whose mesh is placed twice (kept once, as instances) keeps both placements,
/// under the include's transform, with the file's material. Before, the include dropped them silently: the
/// note said "instanced" and the render had nothing there.
#[test]
fn manifest_includes_keep_the_files_instances_under_their_transform() {
    let dir = temp_dir("manifest-instances");
    let mut doc = material_triangle(json!({"materials": [{"name": "placed"}]}));
    doc["nodes"] = json!([{"mesh": 0, "translation": [1, 0, 0]}, {"mesh": 0, "translation": [0, 2, 0]}]);
    doc["scenes"] = json!([{"nodes": [0, 1]}]);
    write_gltf(&dir, "twice.gltf", &doc);
    let text = r#"{"materials": {"own": {"base_color": 0.5}},
        "objects": [{"type": "sphere", "center": [0, 0, -5], "radius": 1, "material": "own"},
                    {"type": "mesh", "file": "twice.gltf", "transform": {"translate": [0, 0, 3], "scale": 2}}]}"#;
    let path = write(&dir, "m.json", text.as_bytes());
    let options = LoadOptions { flatten_triangles: 0, ..LoadOptions::default() };
    let d = load_scene_with(&path, &options).unwrap_or_else(|e| panic!("{e}"));
    assert!(d.meshes.is_empty(), "{} world-space meshes", d.meshes.len());
    assert_eq!(d.instances.len(), 1);
    let placed = &d.instances[0];
    let origins: Vec<Vec3> = placed.transforms().iter().map(|m| m.transform_point3(Vec3::ZERO)).collect();
    assert_eq!(origins, vec![Vec3::new(2.0, 0.0, 3.0), Vec3::new(0.0, 4.0, 3.0)]);
    let material = placed.meshes()[0].material().map(|m| d.materials[m as usize].name.as_str());
    assert_eq!(material, Some("placed"));
    // The include's transform cannot carry the placements past the coordinate limit unchecked.
    let far = text.replace(r#""translate": [0, 0, 3]"#, r#""translate": [2e18, 0, 3]"#);
    assert_ne!(far, text);
    let e =
        load_scene_with(&write(&dir, "far.json", far.as_bytes()), &options).err().unwrap_or_else(|| panic!("loaded"));
    let Error::IncludedFile { cause, .. } = &e else { panic!("{e:?}") };
    assert!(matches!(**cause, Error::CoordinateTooLarge { .. }), "{cause:?}");
}

#[test]
fn gltf_primitive_without_material_gets_an_empty_gltf_material() {
    // The loader transcribes: the file writes no material, so the description says nothing, and glTF's
    // default material (§3.9.6: base colour 1, metallic 1, roughness 1, single-sided) is the assembly's
    // `MaterialFormat::Gltf` defaults, decided there once.
    let dir = temp_dir("default-material");
    let uri = data_uri(&f32_bytes(&TRIANGLE));
    let d = load_scene(&write_gltf(&dir, "t.gltf", &triangle_gltf(Some(&uri), 36, json!({}))))
        .unwrap_or_else(|e| panic!("{e}"));
    let m = d.meshes[0].material().unwrap_or_else(|| panic!("no material index")) as usize;
    assert_eq!(d.materials.len(), 1);
    assert_eq!(d.materials[m], MaterialDesc::new("gltf-default", MaterialFormat::Gltf));
}

// --- Bounded resources, hostile geometry, clear errors (each failed before its fix) ---

/// A glTF whose `nodes` all instance mesh 0, whose POSITION accessor has `count` vertices without a buffer
/// view (all zeros: free in file size, not in memory).
fn shared_accessor_gltf(nodes: usize, count: usize) -> serde_json::Value {
    json!({
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": (0..nodes).collect::<Vec<_>>()}],
        "nodes": (0..nodes).map(|_| json!({"mesh": 0})).collect::<Vec<_>>(),
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [{"componentType": 5126, "count": count, "type": "VEC3",
                       "sparse": {"count": 1, "indices": {"bufferView": 0, "componentType": 5125},
                                  "values": {"bufferView": 1}}}],
        "bufferViews": [{"buffer": 0, "byteLength": 4}, {"buffer": 0, "byteOffset": 4, "byteLength": 12}],
        "buffers": [{"uri": data_uri(&[0u8; 16]), "byteLength": 16}],
    })
}

#[test]
fn budget_is_per_scene_not_per_accessor_read() {
    let dir = temp_dir("budget");
    let options = LoadOptions { max_memory: 64 << 20, ..LoadOptions::default() };
    // One node: ≈ 19 MB charged, within 64 MiB.
    let one = write_gltf(&dir, "one.gltf", &shared_accessor_gltf(1, 99_999));
    load_scene_with(&one, &options)
        .map(|_| ())
        .or_else(|e| match e {
            // All its triangles are zero-area: loaded, then refused for having no geometry — not for memory.
            Error::NoGeometry { .. } => Ok(()),
            other => Err(other),
        })
        .unwrap_or_else(|e| panic!("{e}"));
    // Fifty nodes sharing the accessor, copied into world space: each read is charged, the file is refused
    // by name, with the budget.
    let fifty = write_gltf(&dir, "fifty.gltf", &shared_accessor_gltf(50, 99_999));
    assert!(std::fs::metadata(&fifty).map(|m| m.len()).unwrap_or(0) < 2000);
    let copies = LoadOptions { flatten_triangles: u64::MAX, ..options.clone() };
    let e = load_scene_with(&fifty, &copies).err().unwrap_or_else(|| panic!("loaded"));
    let msg = e.to_string();
    assert!(matches!(e, Error::OverBudget { limit, .. } if limit == 64 << 20), "{e:?}");
    assert!(msg.contains("fifty.gltf") && msg.contains(&(64u64 << 20).to_string()), "{msg}");
    // By default the 49 copies (1.6M triangles) would pass `flatten_triangles`: the mesh is read once and
    // placed 50 times (two-level BVH), within the budget.
    match load_scene_with(&fifty, &options) {
        Ok(_) | Err(Error::NoGeometry { .. }) => {}
        Err(e) => panic!("{e}"),
    }
}

#[test]
fn devices_and_absolute_buffer_paths_are_refused() {
    let dir = temp_dir("devices");
    let doc = triangle_gltf(Some("/dev/zero"), 36, json!({}));
    let path = write_gltf(&dir, "dev.gltf", &doc);
    let (e, msg) = error_message(&path);
    assert!(matches!(e, Error::AbsolutePath { .. }), "{e:?}");
    assert!(msg.contains("/dev/zero"), "{msg}");
    let allow = LoadOptions { allow_absolute_paths: true, ..LoadOptions::default() };
    let e = load_scene_with(&path, &allow).err().unwrap_or_else(|| panic!("loaded"));
    assert!(matches!(e, Error::NotRegularFile { .. }), "{e:?}");
    // A spectrum CSV naming a device through a relative path is refused too.
    let text = r#"{"materials": {"m": {"base_color": {"csv": "../../../../../../../../dev/zero"}}}}"#;
    let e = parse_manifest(text, &dir, "m.json").err().unwrap_or_else(|| panic!("loaded"));
    assert!(matches!(e, Error::NotRegularFile { .. }), "{e:?}");
}

#[test]
fn an_absolute_image_path_is_refused_in_gltf_as_in_mtl() {
    // One rule for every file a scene names: a glTF image by absolute path was dropped with a note
    // (the render went on without its texture) where an MTL map, a buffer or a mesh is an error.
    let dir = temp_dir("absolute_image");
    let image = dir.join("tex.png");
    std::fs::write(&image, b"not decoded by the loader").unwrap();
    let doc = material_triangle(json!({
        "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
        "textures": [{"source": 0}],
        "images": [{"uri": image.display().to_string()}],
    }));
    let path = write_gltf(&dir, "abs.gltf", &doc);
    let (e, msg) = error_message(&path);
    assert!(matches!(e, Error::AbsolutePath { .. }), "{e:?}");
    assert!(msg.contains("abs.gltf") && msg.contains("tex.png") && msg.contains("--allow-absolute-paths"), "{msg}");
    let allow = LoadOptions { allow_absolute_paths: true, ..LoadOptions::default() };
    let desc = load_scene_with(&path, &allow).unwrap();
    assert_eq!(desc.images.len(), 1);
    // The MTL side of the rule, as it was.
    std::fs::write(dir.join("abs.mtl"), format!("newmtl m\nKd 1 1 1\nmap_Kd {}\n", image.display())).unwrap();
    let obj = write(&dir, "abs.obj", b"mtllib abs.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m\nf 1 2 3\n");
    let e = load_scene(&obj).err().unwrap_or_else(|| panic!("loaded"));
    assert!(matches!(e, Error::AbsolutePath { .. }) && e.to_string().contains("abs.mtl"), "{e:?}");
}

#[test]
fn coordinates_beyond_1e18_are_refused_naming_file_and_object() {
    let dir = temp_dir("far");
    let far: Vec<f32> = vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1e25, 1.0, 0.0];
    let doc = triangle_gltf(Some(&data_uri(&f32_bytes(&far))), 36, json!({}));
    let (e, msg) = error_message(&write_gltf(&dir, "far.gltf", &doc));
    assert!(matches!(e, Error::CoordinateTooLarge { vertex: 2, .. }), "{e:?}");
    assert!(msg.contains("meshes[0]"), "{msg}");
    let (e, msg) = error_message(&write(&dir, "far.obj", b"o big\nv 0 0 0\nv 1 0 0\nv 0 2e18 0\nf 1 2 3\n"));
    assert!(matches!(e, Error::CoordinateTooLarge { .. }) && msg.contains("big"), "{msg}");
    let text = r#"{"objects": [{"type": "sphere", "center": [1e25, 0, 0], "radius": 1}]}"#;
    let e = parse_manifest(text, &dir, "m.json").err().map(|e| e.to_string()).unwrap_or_default();
    assert!(e.contains("m.json") && e.contains("objects[0]"), "{e}");
    // A valid file pushed far away by the manifest's transform.
    write(&dir, "t.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let text = r#"{"objects": [{"type": "mesh", "file": "t.obj", "transform": {"translate": [2e18, 0, 0]}}]}"#;
    let e = parse_manifest(text, &dir, "m.json").err().map(|e| e.to_string()).unwrap_or_default();
    assert!(e.contains("m.json") && e.contains("objects[0]") && e.contains("t.obj"), "{e}");
}

#[test]
fn zero_area_and_duplicate_triangles_are_removed_before_the_build() {
    let dir = temp_dir("degenerate");
    // 20 000 copies of one triangle plus 20 000 triangles with all three vertices equal.
    let mut obj = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\n");
    for _ in 0..20_000 {
        obj.push_str("f 1 2 3\nf 1 1 1\n");
    }
    let d = load_scene(&write(&dir, "dup.obj", obj.as_bytes())).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(d.meshes.iter().map(|m| m.triangle_count()).sum::<usize>(), 1);
    assert!(d.warnings.iter().any(|w| w.contains("20000 zero-area and 19999 duplicate")), "{:?}", d.warnings);
    // Only zero-area triangles: nothing to render is an error, not a blank image.
    let (e, _) = error_message(&write(&dir, "flat.obj", b"v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n"));
    assert!(matches!(e, Error::NoGeometry { .. }), "{e:?}");
}

#[test]
fn empty_or_garbage_obj_is_a_no_geometry_error() {
    let dir = temp_dir("empty-obj");
    let (e, msg) = error_message(&write(&dir, "empty.obj", b""));
    assert!(matches!(e, Error::NoGeometry { .. }) && msg.contains("empty"), "{msg}");
    let (e, msg) = error_message(&write(&dir, "garbage.obj", b"hello world\nthis is not an obj\n"));
    assert!(matches!(e, Error::NoGeometry { .. }) && msg.contains("not OBJ statements"), "{msg}");
}

#[test]
fn manifest_with_a_utf8_bom_loads() {
    let dir = temp_dir("bom");
    let path = write(
        &dir,
        "bom.json",
        "\u{feff}{\"objects\": [{\"type\": \"sphere\", \"center\": [0,0,0], \"radius\": 1}]}".as_bytes(),
    );
    let d = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(d.spheres.len(), 1);
}

#[test]
fn negative_gltf_ior_is_warned_not_silently_replaced() {
    let dir = temp_dir("neg-ior");
    let doc = triangle_gltf(
        Some(&data_uri(&f32_bytes(&TRIANGLE))),
        36,
        json!({"materials": [{"name": "bad", "extensions": {"KHR_materials_ior": {"ior": -1.0}}}],
               "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}],
               "extensionsUsed": ["KHR_materials_ior"]}),
    );
    let d = load_scene(&write_gltf(&dir, "n.gltf", &doc)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(d.materials[0].ior, None);
    assert!(d.warnings.iter().any(|w| w.contains("n.gltf") && w.contains("-1")), "{:?}", d.warnings);
}

#[test]
fn missing_mesh_names_the_manifest_and_the_object() {
    let dir = temp_dir("missing-mesh");
    let text = r#"{"objects": [{"type": "sphere", "center": [0,0,0], "radius": 1},
                              {"type": "mesh", "file": "nowhere.obj"}]}"#;
    let e = parse_manifest(text, &dir, "scene.json").err().unwrap_or_else(|| panic!("loaded"));
    let msg = e.to_string();
    assert!(matches!(e, Error::IncludedFile { .. }), "{e:?}");
    assert!(msg.contains("scene.json") && msg.contains("objects[1]") && msg.contains("nowhere.obj"), "{msg}");
    // A report that walks the error's sources (anyhow's `{:#}`) states the cause once.
    let mut chain = msg.clone();
    let mut next = std::error::Error::source(&e);
    while let Some(source) = next {
        chain.push_str(&format!(": {source}"));
        next = source.source();
    }
    assert_eq!(chain.matches("nowhere.obj").count(), 1, "{chain}");
}

/// The malformed files of /work/shared/real_assets/robustness (third-party, read only): none may panic.
#[test]
fn robustness_corpus_never_panics() {
    let dir = Path::new("/work/shared/real_assets/robustness");
    if !dir.is_dir() {
        eprintln!("skipped: {} is absent", dir.display());
        return;
    }
    let mut files = Vec::new();
    all_scene_files(dir, &mut files);
    let mut count = 0;
    for path in files {
        let ext = path.extension().and_then(|e| e.to_str()).unwrap_or_default().to_ascii_lowercase();
        if !matches!(ext.as_str(), "gltf" | "glb" | "obj") {
            continue;
        }
        count += 1;
        let result =
            std::panic::catch_unwind(|| load_scene(&path).and_then(|d| Scene::build(d.spheres, d.meshes)).map(|_| ()));
        match result {
            Err(_) => panic!("{}: panicked", path.display()),
            Ok(Err(e @ Error::ParserPanic { .. })) => panic!("{e}"),
            Ok(_) => {}
        }
    }
    assert!(count > 0);
}

#[test]
fn the_source_digest_covers_referenced_files_but_not_where_the_scene_lies() {
    // prism.json includes prism.obj: a copy of the folder elsewhere keeps the digest, a
    // changed byte in the included file changes it.
    let src = repo().join("scenes/reference");
    let (a, b) = (temp_dir("digest-a"), temp_dir("digest-b"));
    for dir in [&a, &b] {
        for name in ["prism.json", "prism.obj"] {
            std::fs::copy(src.join(name), dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        }
    }
    let digest = |dir: &Path| load_scene(&dir.join("prism.json")).unwrap_or_else(|e| panic!("{e}")).source_hash;
    let original = digest(&src);
    assert_ne!(original, 0);
    assert_eq!(digest(&a), original);
    let mut obj = std::fs::read(b.join("prism.obj")).unwrap_or_else(|e| panic!("{e}"));
    obj.extend_from_slice(b"# one more comment\n");
    write(&b, "prism.obj", &obj);
    assert_ne!(digest(&b), original, "the included mesh is part of the digest");
    assert_ne!(scene("reference/cornell_box.json").source_hash, original);
}

/// A glTF file with no nodes, or whose scene lists none (the `nodes` key is optional in glTF 2.0),
/// is valid: "nothing to render" naming the file and the reason, not a parse error (the scene without a
/// `nodes` key was "missing field `nodes`" before). Also in a GLB container.
#[test]
fn gltf_without_nodes_is_nothing_to_render_not_a_parse_error() {
    let dir = temp_dir("empty-gltf");
    let cases: [(&str, &[u8], &str); 4] = [
        ("no_nodes.gltf", br#"{"asset": {"version": "2.0"}}"#, "no nodes and no scene"),
        (
            "scene_without_nodes.gltf",
            br#"{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{}]}"#,
            "scene 0 has no nodes",
        ),
        ("empty_list.gltf", br#"{"asset": {"version": "2.0"}, "scenes": [{"nodes": []}]}"#, "scene 0 has no nodes"),
        (
            "empty_node.gltf",
            br#"{"asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"name": "empty"}]}"#,
            "",
        ),
    ];
    for (name, json, why) in cases {
        let (e, msg) = error_message(&write(&dir, name, json));
        assert!(matches!(e, Error::NoGeometry { .. }), "{name}: {e:?}");
        assert!(msg.contains("nothing to render") && msg.contains(name) && msg.contains(why), "{msg}");
    }
    // The same scene in a GLB (JSON chunk padded to 4 bytes, no BIN chunk).
    let mut json = br#"{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"name": "s"}]}"#.to_vec();
    json.resize(json.len().next_multiple_of(4), b' ');
    let mut glb = b"glTF".to_vec();
    glb.extend(2u32.to_le_bytes());
    glb.extend((12 + 8 + json.len() as u32).to_le_bytes());
    glb.extend((json.len() as u32).to_le_bytes());
    glb.extend(b"JSON");
    glb.extend(&json);
    let (e, msg) = error_message(&write(&dir, "empty.glb", &glb));
    assert!(matches!(e, Error::NoGeometry { .. }) && msg.contains("scene 0 has no nodes"), "{msg}");
}

/// Draco, meshopt and KTX2 get one line naming the extension and a way forward: an error when
/// the geometry exists only compressed, a warning when an uncompressed fallback is there; variants keep
/// the default material and animations (also `KHR_animation_pointer` ones, which `gltf-json` could not
/// parse: "missing field `node`") are ignored, each with one warning, required or not. Before: Draco and
/// meshopt named only "unsupported glTF extension", the used-only meshopt file failed with "refers to the
/// GLB binary chunk", variants and animations were silent, and the pointer animation was a parse error.
#[test]
fn compressed_data_variants_and_animations_get_one_line_each() {
    let dir = temp_dir("gltf-extensions");
    let uri = data_uri(&f32_bytes(&[TRIANGLE.as_slice(), &[0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0]].concat()));
    let base = || triangle_gltf(Some(&uri), 68, json!({}));
    let draco_ext = json!({"KHR_draco_mesh_compression": {"bufferView": 0, "attributes": {"POSITION": 0}}});

    // Draco required, POSITION only compressed: an error with the way forward.
    let mut d = base();
    d["extensionsUsed"] = json!(["KHR_draco_mesh_compression"]);
    d["extensionsRequired"] = json!(["KHR_draco_mesh_compression"]);
    d["accessors"][0].as_object_mut().unwrap().remove("bufferView");
    d["meshes"][0]["primitives"][0]["extensions"] = draco_ext.clone();
    let (_, msg) = error_message(&write_gltf(&dir, "draco.gltf", &d));
    assert!(msg.contains("KHR_draco_mesh_compression") && msg.contains("gltf-transform cp"), "{msg}");
    // Draco used with the uncompressed fallback: loads, one warning.
    let mut d = base();
    d["extensionsUsed"] = json!(["KHR_draco_mesh_compression"]);
    d["meshes"][0]["primitives"][0]["extensions"] = draco_ext;
    let desc = load_scene(&write_gltf(&dir, "draco_fallback.gltf", &d)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(desc.meshes[0].triangle_count(), 1);
    assert_eq!(
        desc.warnings.iter().filter(|w| w.contains("KHR_draco_mesh_compression")).count(),
        1,
        "{:?}",
        desc.warnings
    );

    // meshopt required, its fallback buffer without data: an error; with data: a warning.
    let mut d = base();
    d["extensionsUsed"] = json!(["EXT_meshopt_compression"]);
    d["extensionsRequired"] = json!(["EXT_meshopt_compression"]);
    let meshopt = json!({"EXT_meshopt_compression": {"buffer": 1, "byteLength": 36, "byteStride": 12, "count": 3, "mode": "ATTRIBUTES"}});
    d["buffers"] =
        json!([{"byteLength": 36, "extensions": {"EXT_meshopt_compression": {"fallback": true}}}, d["buffers"][0]]);
    d["bufferViews"][0]["extensions"] = meshopt.clone();
    let (_, msg) = error_message(&write_gltf(&dir, "meshopt.gltf", &d));
    assert!(
        msg.contains("EXT_meshopt_compression") && msg.contains("bufferViews[0]") && msg.contains("gltf-transform cp"),
        "{msg}"
    );
    let mut d = base();
    d["extensionsUsed"] = json!(["EXT_meshopt_compression"]);
    d["bufferViews"][0]["extensions"] = meshopt;
    let desc = load_scene(&write_gltf(&dir, "meshopt_fallback.gltf", &d)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(desc.meshes[0].triangle_count(), 1);
    assert!(desc.warnings.iter().any(|w| w.contains("EXT_meshopt_compression")), "{:?}", desc.warnings);

    // KTX2 only (required): loads (textures are not geometry), the warning names the tool.
    let mut d = base();
    d["extensionsUsed"] = json!(["KHR_texture_basisu"]);
    d["extensionsRequired"] = json!(["KHR_texture_basisu"]);
    d["images"] = json!([{"uri": "t.ktx2", "mimeType": "image/ktx2"}]);
    d["textures"] = json!([{"extensions": {"KHR_texture_basisu": {"source": 0}}}]);
    d["materials"] = json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    d["meshes"][0]["primitives"][0]["material"] = json!(0);
    let desc = load_scene(&write_gltf(&dir, "ktx2.gltf", &d)).unwrap_or_else(|e| panic!("{e}"));
    let ktx = desc
        .warnings
        .iter()
        .find(|w| w.contains("KHR_texture_basisu"))
        .unwrap_or_else(|| panic!("{:?}", desc.warnings));
    assert!(ktx.contains("1 without a PNG/JPEG fallback") && ktx.contains("ktxdecompress"), "{ktx}");

    // Variants, required: the default material (red), the variants named.
    let mut d = base();
    d["extensionsUsed"] = json!(["KHR_materials_variants"]);
    d["extensionsRequired"] = json!(["KHR_materials_variants"]);
    d["materials"] = json!([{"name": "red", "pbrMetallicRoughness": {"baseColorFactor": [1, 0, 0, 1]}},
                            {"name": "blue", "pbrMetallicRoughness": {"baseColorFactor": [0, 0, 1, 1]}}]);
    d["extensions"] = json!({"KHR_materials_variants": {"variants": [{"name": "day"}, {"name": "night"}]}});
    d["meshes"][0]["primitives"][0]["material"] = json!(0);
    d["meshes"][0]["primitives"][0]["extensions"] =
        json!({"KHR_materials_variants": {"mappings": [{"material": 1, "variants": [1]}]}});
    let desc = load_scene(&write_gltf(&dir, "variants.gltf", &d)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(desc.meshes[0].material(), Some(0));
    assert!(desc.warnings.iter().any(|w| w.contains("variants 'day', 'night' ignored")), "{:?}", desc.warnings);

    // Animations: a TRS one and a KHR_animation_pointer one (required); the rest pose, one warning each file.
    let mut d = base();
    d["bufferViews"] = json!([{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 8},
                              {"buffer": 0, "byteOffset": 44, "byteLength": 24}]);
    d["accessors"] = json!([d["accessors"][0], {"bufferView": 1, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [0], "max": [1]},
                            {"bufferView": 2, "componentType": 5126, "count": 2, "type": "VEC3"}]);
    d["animations"] = json!([{"samplers": [{"input": 1, "output": 2}], "channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}]}]);
    let desc = load_scene(&write_gltf(&dir, "anim.gltf", &d)).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(desc.meshes[0].positions()[1], Vec3::X, "rest pose");
    assert_eq!(desc.warnings.iter().filter(|w| w.contains("1 animation(s) ignored")).count(), 1, "{:?}", desc.warnings);
    d["extensionsUsed"] = json!(["KHR_animation_pointer"]);
    d["extensionsRequired"] = json!(["KHR_animation_pointer"]);
    d["animations"][0]["channels"][0]["target"] =
        json!({"path": "pointer", "extensions": {"KHR_animation_pointer": {"pointer": "/nodes/0/translation"}}});
    let desc = load_scene(&write_gltf(&dir, "pointer.gltf", &d)).unwrap_or_else(|e| panic!("{e}"));
    assert!(desc.warnings.iter().any(|w| w.contains("with KHR_animation_pointer) ignored")), "{:?}", desc.warnings);
    // An unknown required extension is still refused, naming it.
    d["extensionsRequired"] = json!(["EXT_unknown"]);
    let (_, msg) = error_message(&write_gltf(&dir, "unknown.gltf", &d));
    assert!(msg.contains("EXT_unknown"), "{msg}");
}

/// A glTF of one triangle mesh placed by `EXT_mesh_gpu_instancing` on node 0 (translations (0,0,0),
/// (2,0,0), (0,3,0); scale 2 on the second) and referenced again by node 1 (translated by z = −1).
fn instanced_triangle_gltf() -> serde_json::Value {
    let translations = [0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 3.0, 0.0];
    let scales = [1.0, 1.0, 1.0, 2.0, 2.0, 2.0, 1.0, 1.0, 1.0];
    let bytes = f32_bytes(&[TRIANGLE.as_slice(), &translations, &scales].concat());
    let uri = data_uri(&bytes);
    let mut d = triangle_gltf(Some(&uri), bytes.len(), json!({}));
    d["extensionsUsed"] = json!(["EXT_mesh_gpu_instancing"]);
    d["extensionsRequired"] = json!(["EXT_mesh_gpu_instancing"]);
    d["scenes"] = json!([{"nodes": [0, 1]}]);
    d["nodes"] = json!([
        {"mesh": 0, "extensions": {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": 1, "SCALE": 2}}}},
        {"mesh": 0, "translation": [0, 0, -1]}
    ]);
    d["bufferViews"] = json!([{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 36},
                              {"buffer": 0, "byteOffset": 72, "byteLength": 36}]);
    d["accessors"] = json!([d["accessors"][0], {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"},
                            {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC3"}]);
    d
}

/// `EXT_mesh_gpu_instancing` places the node's mesh once per instance (it was drawn once, at the
/// node, silently); with repeated node references a mesh placed 4 times is copied into world space while
/// the copies are small, and kept once with 4 transforms (two-level BVH) beyond `flatten_triangles`.
#[test]
fn gpu_instancing_and_repeated_meshes_place_every_instance() {
    let dir = temp_dir("instancing");
    let path = write_gltf(&dir, "instanced.gltf", &instanced_triangle_gltf());
    let d = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    assert!(d.instances.is_empty());
    let second_vertex: Vec<Vec3> = d.meshes.iter().map(|m| m.positions()[1]).collect();
    // Instance i at T·S: vertex (1, 0, 0) → (1, 0, 0), (2 + 2, 0, 0), (1, 3, 0); node 1: (1, 0, −1).
    assert_eq!(second_vertex, [Vec3::X, Vec3::new(4.0, 0.0, 0.0), Vec3::new(1.0, 3.0, 0.0), Vec3::new(1.0, 0.0, -1.0)]);

    let options = LoadOptions { flatten_triangles: 0, ..LoadOptions::default() };
    let d = load_scene_with(&path, &options).unwrap_or_else(|e| panic!("{e}"));
    assert!(d.meshes.is_empty());
    assert_eq!(d.instances.len(), 1);
    let placed: Vec<Vec3> = d.instances[0].transforms().iter().map(|m| m.transform_point3(Vec3::X)).collect();
    assert_eq!(placed, second_vertex);
    assert!(d.warnings.iter().any(|w| w.contains("placed 4 times in all are instanced")), "{:?}", d.warnings);
    let (lo, hi) = d.bounds().unwrap();
    assert_eq!((lo, hi), (Vec3::new(0.0, 0.0, -1.0), Vec3::new(4.0, 4.0, 0.0)));
    // The two-level scene hits the instances where the copies are.
    let scene = Scene::build_with_instances(d.spheres, d.meshes, d.instances).unwrap();
    let hit = scene.intersect(&geometry::Ray { origin: Vec3::new(2.5, 0.5, 5.0), dir: Vec3::NEG_Z }, f32::INFINITY);
    let hit = hit.expect("the scaled instance at x = 2..4");
    assert!((hit.t - 5.0).abs() < 1e-5 && (hit.p - Vec3::new(2.5, 0.5, 0.0)).length() < 1e-5, "{hit:?}");
    let hit = scene.intersect(&geometry::Ray { origin: Vec3::new(0.2, 0.2, -0.5), dir: Vec3::NEG_Z }, f32::INFINITY);
    assert!((hit.expect("node 1's copy").t - 0.5).abs() < 1e-6);
}

/// Writes `forest.glb`: one 100 000-triangle mesh (a 250 × 200-quad height field, 1 × 0.8 units) placed
/// 10⁴ times by `EXT_mesh_gpu_instancing` on a 100 × 100 grid, each turned about +Y: 10⁹ triangles, which
/// as world-space copies would need ~256 GB. Returns its path.
pub(crate) fn write_forest(dir: &Path) -> PathBuf {
    let (nx, nz) = (250u32, 200u32);
    let mut positions = Vec::new();
    for j in 0..=nz {
        for i in 0..=nx {
            let (x, z) = (i as f32 / nx as f32, 0.8 * j as f32 / nz as f32);
            positions.extend([x, 0.05 * (12.0 * x).sin() * (9.0 * z).cos(), z]);
        }
    }
    let mut indices = Vec::new();
    for j in 0..nz {
        for i in 0..nx {
            let v = j * (nx + 1) + i;
            indices.extend([v, v + nx + 1, v + 1, v + 1, v + nx + 1, v + nx + 2]);
        }
    }
    assert_eq!(indices.len(), 300_000);
    let mut translations = Vec::new();
    let mut rotations = Vec::new();
    for k in 0..10_000u32 {
        translations.extend([1.5 * (k % 100) as f32, 0.0, 1.5 * (k / 100) as f32]);
        let half = 0.5 * (k as f32 * 0.37);
        rotations.extend([0.0, half.sin(), 0.0, half.cos()]);
    }
    let mut bin = f32_bytes(&positions);
    let p_len = bin.len();
    bin.extend(indices.iter().flat_map(|i| i.to_le_bytes()));
    let i_len = bin.len() - p_len;
    bin.extend(f32_bytes(&translations));
    bin.extend(f32_bytes(&rotations));
    let t_len = translations.len() * 4;
    let r_len = rotations.len() * 4;
    let doc = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["EXT_mesh_gpu_instancing"],
        "scene": 0, "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"mesh": 0, "extensions": {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": 2, "ROTATION": 3}}}},
            {"camera": 0, "translation": [75, 60, 190], "rotation": [-0.2588190451, 0, 0, 0.9659258263]}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": positions.len() / 3, "type": "VEC3"},
            {"bufferView": 1, "componentType": 5125, "count": indices.len(), "type": "SCALAR"},
            {"bufferView": 2, "componentType": 5126, "count": 10_000, "type": "VEC3"},
            {"bufferView": 3, "componentType": 5126, "count": 10_000, "type": "VEC4"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteLength": p_len},
            {"buffer": 0, "byteOffset": p_len, "byteLength": i_len},
            {"buffer": 0, "byteOffset": p_len + i_len, "byteLength": t_len},
            {"buffer": 0, "byteOffset": p_len + i_len + t_len, "byteLength": r_len}
        ],
        "buffers": [{"byteLength": bin.len()}]
    });
    let mut json = doc.to_string().into_bytes();
    json.resize(json.len().next_multiple_of(4), b' ');
    bin.resize(bin.len().next_multiple_of(4), 0);
    let mut glb = b"glTF".to_vec();
    glb.extend(2u32.to_le_bytes());
    glb.extend((12 + 8 + json.len() as u32 + 8 + bin.len() as u32).to_le_bytes());
    glb.extend((json.len() as u32).to_le_bytes());
    glb.extend(b"JSON");
    glb.extend(&json);
    glb.extend((bin.len() as u32).to_le_bytes());
    glb.extend(b"BIN\0");
    glb.extend(&bin);
    write(dir, "forest.glb", &glb)
}

/// 10⁴ instances of a 100k-triangle mesh load (two-level BVH) within the default memory budget
/// (0.4 s, 9 MB of BVH); as world-space copies the same file is refused by the budget before anything
/// is allocated, not an out-of-memory abort. `SPECTRACE_FOREST_DIR=DIR` keeps the file there for measuring
/// the CLI (`/usr/bin/time -v spectrace info DIR/forest.glb`).
#[test]
fn ten_thousand_instances_of_a_100k_triangle_mesh_load() {
    let dir = std::env::var_os("SPECTRACE_FOREST_DIR").map_or_else(|| temp_dir("forest"), PathBuf::from);
    std::fs::create_dir_all(&dir).unwrap();
    let path = write_forest(&dir);
    let start = std::time::Instant::now();
    let d = load_scene(&path).unwrap_or_else(|e| panic!("{e}"));
    let loaded = start.elapsed();
    assert!(d.meshes.is_empty());
    assert_eq!((d.instances.len(), d.instances[0].transforms().len()), (1, 10_000));
    assert_eq!(d.instances[0].triangle_count(), 100_000);
    let scene = Scene::build_with_instances(d.spheres, d.meshes, d.instances).unwrap();
    assert_eq!(scene.instanced_triangle_count(), 1_000_000_000);
    let s = scene.stats();
    eprintln!("forest: load {loaded:?}, BVH build {:?}, {} nodes, {} MB", s.build_time, s.node_count, s.bytes >> 20);
    // A ray straight down onto instance 0 (at the origin, not turned) hits the height field there.
    let hit = scene.intersect(&geometry::Ray { origin: Vec3::new(0.3, 10.0, 0.2), dir: Vec3::NEG_Y }, f32::INFINITY);
    assert!(hit.is_some_and(|h| h.p.y.abs() <= 0.05 + 1e-4), "{hit:?}");
    let flatten_all = LoadOptions { flatten_triangles: u64::MAX, ..LoadOptions::default() };
    let e = load_scene_with(&path, &flatten_all).expect_err("10⁹ copied triangles exceed the budget");
    assert!(matches!(e, Error::OverBudget { .. }), "{e}");
}

/// The one-triangle glTF with a COLOR_0 accessor of `count` elements of `kind` (`"VEC3"`/`"VEC4"`) and
/// `component_type`, its bytes after the positions.
fn colored_triangle(
    dir: &Path,
    name: &str,
    colors: &[u8],
    kind: &str,
    component_type: u32,
    normalized: bool,
    count: usize,
) -> SceneDescription {
    let mut bytes = f32_bytes(&TRIANGLE);
    bytes.extend_from_slice(colors);
    let uri = data_uri(&bytes);
    let mut doc = triangle_gltf(Some(&uri), bytes.len(), json!({}));
    doc["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"] = json!(1);
    doc["bufferViews"] =
        json!([{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": colors.len()}]);
    doc["accessors"].as_array_mut().unwrap().push(
        json!({"bufferView": 1, "componentType": component_type, "normalized": normalized, "count": count, "type": kind}),
    );
    load_scene(&write_gltf(dir, name, &doc)).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn gltf_color_0_float_and_normalized_integers_load_as_the_same_linear_rgba() {
    // glTF 2.0 §3.7.2.1: COLOR_0 is VEC3 or VEC4 of FLOAT or normalized UNSIGNED_BYTE/SHORT; §3.11
    // decodes normalized integers as c / (2ⁿ − 1). 51/255 = 13107/65535 = 0.2 and 102/255 = 0.4 exactly,
    // so all three encodings name the same colours; VEC3 has alpha 1.
    let dir = temp_dir("color-0");
    let want = [[1.0, 0.2, 0.0, 1.0], [0.0, 0.0, 1.0, 0.4], [0.4, 0.4, 0.2, 1.0]];
    let float: Vec<f32> = want.iter().flatten().copied().collect();
    let u8s: Vec<u8> = float.iter().map(|v| (v * 255.0).round() as u8).collect();
    let u16s: Vec<u8> = float.iter().flat_map(|v| ((v * 65535.0).round() as u16).to_le_bytes()).collect();
    let cases =
        [("float.gltf", f32_bytes(&float), 5126, false), ("u8.gltf", u8s, 5121, true), ("u16.gltf", u16s, 5123, true)];
    for (name, bytes, component_type, normalized) in cases {
        let d = colored_triangle(&dir, name, &bytes, "VEC4", component_type, normalized, 3);
        let got = d.meshes[0].colors().unwrap_or_else(|| panic!("{name}: colours dropped: {:?}", d.warnings));
        for (g, w) in got.iter().zip(&want) {
            assert!((g.to_array().iter().zip(w)).all(|(a, b)| (a - b).abs() < 1e-7), "{name}: {g} vs {w:?}");
        }
        assert!(d.warnings.iter().all(|w| !w.contains("COLOR_0")), "{name}: {:?}", d.warnings);
    }
    let rgb: Vec<f32> = want.iter().flat_map(|c| [c[0], c[1], c[2]]).collect();
    let d = colored_triangle(&dir, "vec3.gltf", &f32_bytes(&rgb), "VEC3", 5126, false, 3);
    assert_eq!(d.meshes[0].colors().unwrap()[1].to_array(), [0.0, 0.0, 1.0, 1.0]);
}

#[test]
fn gltf_color_0_of_the_wrong_count_or_not_finite_warns_and_is_dropped() {
    let dir = temp_dir("color-0-bad");
    let two = f32_bytes(&[1.0, 0.0, 0.0, 1.0, 0.0, 0.0]);
    let d = colored_triangle(&dir, "count.gltf", &two, "VEC3", 5126, false, 2);
    assert!(d.meshes[0].colors().is_none());
    assert!(
        d.warnings
            .iter()
            .any(|w| w.contains("COLOR_0 count differs from POSITION") && w.contains("vertex colours dropped")),
        "{:?}",
        d.warnings
    );
    let nan = f32_bytes(&[1.0, 0.0, 0.0, f32::NAN, 0.0, 0.0, 1.0, 1.0, 1.0]);
    let d = colored_triangle(&dir, "nan.gltf", &nan, "VEC3", 5126, false, 3);
    assert!(d.meshes[0].colors().is_none());
    assert!(d.warnings.iter().any(|w| w.contains("COLOR_0") && w.contains("not finite")), "{:?}", d.warnings);
    // Integers that are not normalized are not a colour glTF allows: an error naming the file.
    let bytes = [255u8, 0, 0, 255, 0, 0, 255, 255, 255, 255, 255, 255];
    let mut all = f32_bytes(&TRIANGLE);
    all.extend_from_slice(&bytes);
    let uri = data_uri(&all);
    let mut doc = triangle_gltf(Some(&uri), all.len(), json!({}));
    doc["meshes"][0]["primitives"][0]["attributes"]["COLOR_0"] = json!(1);
    doc["bufferViews"] = json!([{"buffer": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 12}]);
    doc["accessors"]
        .as_array_mut()
        .unwrap()
        .push(json!({"bufferView": 1, "componentType": 5121, "count": 3, "type": "VEC4"}));
    let path = write_gltf(&dir, "raw-u8.gltf", &doc);
    let message = match load_scene(&path) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("non-normalized UNSIGNED_BYTE colours accepted"),
    };
    assert!(message.contains("raw-u8.gltf") && message.contains("COLOR_0"), "{message}");
}

#[test]
fn obj_vertex_colours_are_read_with_their_vertices() {
    let dir = temp_dir("obj-colors");
    let obj = "v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0.5 1\nf 1 2 3\n";
    let d = load_scene(&write(&dir, "c.obj", obj.as_bytes())).unwrap_or_else(|e| panic!("{e}"));
    let c = d.meshes[0].colors().expect("colours");
    for (p, c) in d.meshes[0].positions().iter().zip(c) {
        let want = if *p == Vec3::ZERO {
            [1.0, 0.0, 0.0, 1.0]
        } else if *p == Vec3::X {
            [0.0, 1.0, 0.0, 1.0]
        } else {
            [0.0, 0.5, 1.0, 1.0]
        };
        assert_eq!(c.to_array(), want, "vertex {p}");
    }
    // Without colours none are made up.
    let plain = load_scene(&write(&dir, "p.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")).unwrap();
    assert!(plain.meshes[0].colors().is_none());
}

/// A glTF material's `extras.multiple_scattering` is the manifest key of that name (a boolean; anything
/// else leaves the default).
#[test]
fn gltf_material_extras_select_the_uncompensated_layers() {
    let dir = std::env::temp_dir().join("spectrace-gltf-extras-ms");
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let positions: Vec<u8> =
        [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0].iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(dir.join("t.bin"), &positions).unwrap_or_else(|e| panic!("{e}"));
    let uri = "t.bin";
    let file = |extras: serde_json::Value| {
        let doc = json!({
            "asset": {"version": "2.0"},
            "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}],
            "materials": [{"name": "m", "extras": extras}],
            "buffers": [{"byteLength": 36, "uri": uri}],
            "bufferViews": [{"buffer": 0, "byteLength": 36}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                           "min": [0, 0, 0], "max": [1, 1, 0]}]
        });
        let path = dir.join("t.gltf");
        std::fs::write(&path, doc.to_string()).unwrap_or_else(|e| panic!("{e}"));
        load_scene(&path).unwrap_or_else(|e| panic!("{e}")).materials[0].multiple_scattering
    };
    assert_eq!(file(json!({"multiple_scattering": false})), Some(false));
    assert_eq!(file(json!({"multiple_scattering": true})), Some(true));
    assert_eq!(file(json!({"multiple_scattering": "no"})), None);
    assert_eq!(file(json!({})), None);
}
