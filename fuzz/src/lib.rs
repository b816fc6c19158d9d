//! What every fuzz target does with its bytes: put them in a file of the format's name, load
//! it, assemble it (materials, lights, BVH), summarise it as `spectrace info` does, and render
//! 8×8 pixels with both integrators. Errors are the expected outcome for most inputs; only a
//! panic, an abort (out of memory), a hang or a non-finite pixel is a finding.
//!
//! The same file is compiled into the end-to-end tests (`tests/e2e/fuzz_replay.rs`), which
//! replay every input in `fuzz/regressions/<target>/` on the stable toolchain.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::sync::atomic::AtomicBool;

use integrator::{Integrator, IntegratorKind, PathOptions, RenderOptions, RenderScene, SpectralMode, WhittedOptions};

/// A folder of this process's own for the files a target writes (in RAM when /dev/shm
/// exists, so the disk is not worn by millions of executions). Named and created once per
/// process, not on every write.
pub fn scratch() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let shm = Path::new("/dev/shm");
        let base = if shm.is_dir() { shm.to_path_buf() } else { std::env::temp_dir() };
        let dir = base.join(format!("spectrace-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("scratch folder");
        dir
    })
}

/// Write `bytes` to `name` in the scratch folder and return its path.
pub fn put(name: &str, bytes: &[u8]) -> PathBuf {
    let path = scratch().join(name);
    std::fs::write(&path, bytes).expect("scratch file");
    path
}

/// Load the scene file and run it through the whole pipeline.
pub fn run_file(path: &Path) {
    let Ok(desc) = geometry::load_scene(path) else { return };
    run_description(desc);
}

/// Assemble, summarise and render a loaded scene description.
pub fn run_description(desc: geometry::SceneDescription) {
    let Ok(scene) = RenderScene::from_description(desc.clone()) else { return };
    let summary = integrator::summarize(&desc, &scene);
    std::hint::black_box(serde_json::to_string(&summary).expect("summary serialises"));
    let _ = integrator::choose_auto(&scene, IntegratorKind::WhittedHall);
    for (integrator, spectral) in [
        (
            Integrator::WhittedHall(WhittedOptions { max_depth: Some(8), ..WhittedOptions::default() }),
            SpectralMode::Auto,
        ),
        (
            Integrator::Path(PathOptions { max_depth: Some(8), ..PathOptions::default() }),
            SpectralMode::Hero { count: 4 },
        ),
    ] {
        let options =
            RenderOptions { width: 8, height: 8, integrator, spectral, threads: Some(1), ..RenderOptions::default() };
        if let Ok((image, stats)) = integrator::render(&scene, &options, &|_| {}, &AtomicBool::new(false)) {
            assert_eq!(stats.nonfinite_samples, 0, "non-finite samples reached the film");
            for c in image.to_linear_rgb(integrator::Display::Srgb) {
                assert!(c.iter().all(|v| v.is_finite()), "non-finite pixel {c:?}");
            }
        }
    }
}

/// Split an OBJ+MTL input at its first `%%mtl` line: (OBJ bytes, MTL bytes).
pub fn split_obj_mtl(data: &[u8]) -> (&[u8], &[u8]) {
    const MARK: &[u8] = b"\n%%mtl\n";
    match data.windows(MARK.len()).position(|w| w == MARK) {
        Some(i) => (&data[..i], &data[i + MARK.len()..]),
        None => (data, &[]),
    }
}

/// The committed scenes folder, from the fuzz crate (`fuzz/`) or a workspace crate
/// (`crates/cli/`, for the replay tests).
pub fn scenes_dir() -> PathBuf {
    let here = Path::new(env!("CARGO_MANIFEST_DIR"));
    [here.join("../scenes"), here.join("../../scenes")].into_iter().find(|p| p.is_dir()).expect("scenes folder")
}

/// Target `gltf`: glTF (JSON) bytes.
pub fn gltf(data: &[u8]) {
    run_file(&put("fuzz.gltf", data));
}

/// Target `glb`: binary glTF bytes.
pub fn glb(data: &[u8]) {
    run_file(&put("fuzz.glb", data));
}

/// Target `obj_mtl`: the OBJ text, then (after a line `%%mtl`) its material library. The OBJ
/// gets `mtllib fuzz.mtl` prepended so every input exercises both parsers.
pub fn obj_mtl(data: &[u8]) {
    let (obj, mtl) = split_obj_mtl(data);
    put("fuzz.mtl", mtl);
    let mut text = b"mtllib fuzz.mtl\n".to_vec();
    text.extend_from_slice(obj);
    run_file(&put("fuzz.obj", &text));
}

/// Target `luminaire`: a photometric file, read as IES when its first byte is even and as EULUMDAT
/// otherwise (the rest is the file), as the web of a luminaire over a plane, then rendered.
pub fn luminaire(data: &[u8]) {
    let Some((&first, file)) = data.split_first() else { return };
    let name = if first % 2 == 0 { "fuzz.ies" } else { "fuzz.ldt" };
    put(name, file);
    let manifest = format!(
        r#"{{"camera": {{"position": [0, 1, 3], "look_at": [0, 0, 0], "vfov_deg": 60}},
        "lights": [{{"type": "point", "position": [0, 2, 0], "ies": "{name}"}}],
        "objects": [{{"type": "quad", "corner": [-2, 0, -2], "edge_u": [0, 0, 4], "edge_v": [4, 0, 0]}}]}}"#
    );
    run_file(&put("fuzz_luminaire.json", manifest.as_bytes()));
}

/// Target `manifest`: manifest JSON text; references resolve under `scenes/reference/`, so
/// mutated manifests also load the committed meshes and spectra.
pub fn manifest(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    if let Ok(desc) = geometry::parse_manifest(&text, &scenes_dir().join("reference"), "fuzz.json") {
        run_description(desc);
    }
}

/// Target `csv`: CSV spectra parsed, extended to the visible range as `spectrace color` does
/// (their XYZ must be finite), then used as a material's reflectance and a light's spectrum in
/// a one-sphere scene rendered 8×8.
pub fn csv(data: &[u8]) {
    let text = String::from_utf8_lossy(data);
    if let Ok(table) = colorimetry::parse_spectra_csv(&text, "fuzz.csv") {
        for column in &table {
            if let Ok(held) = column.spectrum.held_to_visible() {
                let white = colorimetry::DenselySampledSpectrum::constant(1.0);
                let xyz = colorimetry::reflectance_to_xyz(
                    &held,
                    &white,
                    colorimetry::Observer::Cie1931,
                    &colorimetry::Integration::Step(1.0),
                );
                assert!(xyz.x.is_finite() && xyz.y.is_finite() && xyz.z.is_finite(), "{xyz:?}");
            }
        }
    }
    put("fuzz.csv", data);
    let manifest = r#"{
        "camera": {"position": [0, 0, 4], "look_at": [0, 0, 0], "vfov_deg": 40},
        "lights": [{"type": "point", "position": [2, 2, 4], "spectrum": {"csv": "fuzz.csv"}}],
        "materials": {"m": {"model": "diffuse", "base_color": {"csv": "fuzz.csv"}}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m"}]
    }"#;
    if let Ok(desc) = geometry::parse_manifest(manifest, scratch(), "fuzz.json") {
        run_description(desc);
    }
}

/// Target `film`: a film file's bytes, read as `merge` and `--resume` read them; a film that
/// reads is merged with itself (refused: the same samples twice), checked for resumption
/// against its own header, and developed into an image as `merge` would (no file written).
pub fn film(data: &[u8]) {
    film_bytes(data);
    // Most mutations only break a checksum: also read the bytes with both checksums made right,
    // so the fuzzer reaches what is checked after them.
    film_bytes(&with_film_checksums(data));
}

/// `data` with a film file's header checksum (after the header its length announces) and final
/// checksum recomputed, where the length leaves room for them.
fn with_film_checksums(data: &[u8]) -> Vec<u8> {
    let mut bytes = data.to_vec();
    let Some(len) = bytes.get(12..16).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize) else {
        return bytes;
    };
    let header_end = 16 + len;
    if bytes.len() >= header_end + 16 {
        let sum = geometry::xxh64(&bytes[..header_end], 0);
        bytes[header_end..header_end + 8].copy_from_slice(&sum.to_le_bytes());
        let body = bytes.len() - 8;
        let sum = geometry::xxh64(&bytes[..body], 0);
        bytes[body..].copy_from_slice(&sum.to_le_bytes());
    }
    bytes
}

fn film_bytes(data: &[u8]) {
    let path = Path::new("fuzz.film");
    let Ok(file) = integrator::FilmFile::from_bytes(data, path) else { return };
    let merged = integrator::merge_parts(vec![(path.into(), file.clone()), ("again.film".into(), file.clone())]);
    assert!(merged.is_err(), "the same sample range twice must not merge");
    let (width, height) = (file.film.width(), file.film.height());
    let header = file.header.clone();
    let view = header.view.parse::<integrator::ViewPlan>().unwrap_or_default();
    if let Ok(film) = file.resumable(&header, width, height, path) {
        let plan = integrator::OutputPlan::new(None, integrator::Display::Srgb, None, None, view)
            .expect("a plan without files");
        let (image, v) = plan.develop(&film, header.samples.start);
        assert!(v.ev.is_finite(), "view {v:?}");
        if let Some(e) = film.error_estimate(f64::from(v.ev).exp2(), header.samples.start) {
            assert!(e.pixels.iter().chain(&e.tiles).all(|x| !x.is_nan()), "a NaN error estimate");
        }
        for c in image.to_linear_rgb(integrator::Display::Srgb) {
            assert!(c.iter().all(|x| x.is_finite()), "non-finite pixel {c:?}");
        }
        std::hint::black_box(image.to_rgb8(integrator::Display::Srgb));
    }
}

/// Target `envmap`: an environment map's bytes, as `.hdr` when they start with `#?` (Radiance's
/// magic) and as `.exr` otherwise, lighting a one-sphere manifest rendered 8×8.
pub fn envmap(data: &[u8]) {
    let name = if data.starts_with(b"#?") { "fuzz.hdr" } else { "fuzz.exr" };
    put(name, data);
    let manifest = format!(
        r#"{{
        "camera": {{"position": [0, 0, 4], "look_at": [0, 0, 0], "vfov_deg": 40}},
        "lights": [{{"type": "environment", "map": "{name}"}}],
        "materials": {{"m": {{"model": "diffuse", "base_color": {{"rgb": [0.5, 0.5, 0.5]}}}}}},
        "objects": [{{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "m"}}]
    }}"#
    );
    if let Ok(desc) = geometry::parse_manifest(&manifest, scratch(), "fuzz.json") {
        run_description(desc);
    }
}

/// Target `texture`: an image's bytes (PNG, JPEG, WebP or KTX2, told apart by content) as the
/// base colour, normal and metallic–roughness texture of a glTF quad rendered 8×8.
pub fn texture(data: &[u8]) {
    put("fuzz.img", data);
    run_file(&put("fuzz.gltf", TEXTURED_QUAD.as_bytes()));
}

/// A unit quad facing +Z with uvs, one material whose three textures read `fuzz.img`, and a
/// camera in front of it.
const TEXTURED_QUAD: &str = r#"{
  "asset": {"version": "2.0"},
  "scene": 0,
  "scenes": [{"nodes": [0, 1]}],
  "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0, 0, 2]}],
  "cameras": [{"type": "perspective", "perspective": {"yfov": 0.9, "znear": 0.01}}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0}]}],
  "materials": [{
    "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicRoughnessTexture": {"index": 0}},
    "normalTexture": {"index": 0}
  }],
  "textures": [{"source": 0}],
  "images": [{"uri": "fuzz.img"}],
  "buffers": [{"byteLength": 92, "uri": "data:application/octet-stream;base64,AACAvwAAgL8AAAAAAACAPwAAgL8AAAAAAACAPwAAgD8AAAAAAACAvwAAgD8AAAAAAAAAAAAAgD8AAIA/AACAPwAAgD8AAAAAAAAAAAAAAAAAAAEAAgAAAAIAAwA="}],
  "bufferViews": [
    {"buffer": 0, "byteOffset": 0, "byteLength": 48},
    {"buffer": 0, "byteOffset": 48, "byteLength": 32},
    {"buffer": 0, "byteOffset": 80, "byteLength": 12}
  ],
  "accessors": [
    {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]},
    {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
    {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}
  ]
}"#;
