//! Outputs that would replace a command's own inputs are refused before anything is written, and
//! the inputs keep their bytes.

use std::path::Path;

use crate::render::{refused, repo, scratch, spectrace};

/// Runs `spectrace <args>` in `dir`; it must succeed. Returns stderr.
fn run(dir: &Path, args: &[&str]) -> String {
    let output = spectrace().current_dir(dir).args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(output.status.success(), "{args:?}: {stderr}");
    stderr
}

/// A 2×2 PNG texture `dir/name`.
fn write_texture(dir: &Path, name: &str) {
    let mut img = image::RgbImage::new(2, 2);
    for (i, p) in img.pixels_mut().enumerate() {
        p.0 = [60 * i as u8, 200, 40];
    }
    img.save(dir.join(name)).unwrap();
}

/// A glTF quad (positions, uvs, indices in `quad.bin`) textured with `tex.png`.
fn write_textured_gltf(dir: &Path) {
    let mut bin = Vec::new();
    for v in [-1.0f32, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0, -1.0, 0.0, -1.0, -1.0, 0.0] {
        bin.extend_from_slice(&v.to_le_bytes());
    }
    for v in [0.0f32, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0] {
        bin.extend_from_slice(&v.to_le_bytes());
    }
    for i in [0u16, 3, 2, 0, 2, 1] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    std::fs::write(dir.join("quad.bin"), &bin).unwrap();
    let gltf = format!(
        r#"{{"asset": {{"version": "2.0"}},
        "buffers": [{{"uri": "quad.bin", "byteLength": {}}}],
        "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 80}}, {{"buffer": 0, "byteOffset": 80, "byteLength": 12}}],
        "accessors": [
          {{"bufferView": 0, "byteOffset": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]}},
          {{"bufferView": 0, "byteOffset": 48, "componentType": 5126, "count": 4, "type": "VEC2"}},
          {{"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}}],
        "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1}}, "indices": 2, "material": 0}}]}}],
        "materials": [{{"pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0}}, "metallicFactor": 0}}}}],
        "textures": [{{"source": 0}}], "images": [{{"uri": "tex.png"}}],
        "nodes": [{{"mesh": 0}}], "scenes": [{{"nodes": [0]}}], "scene": 0}}"#,
        bin.len()
    );
    std::fs::write(dir.join("quad.gltf"), gltf).unwrap();
    write_texture(dir, "tex.png");
}

/// Each file's bytes, to check that a refused command left them alone.
fn contents(dir: &Path, names: &[&str]) -> Vec<Vec<u8>> {
    names.iter().map(|n| std::fs::read(dir.join(n)).unwrap()).collect()
}

const SMALL: [&str; 5] = ["--width", "8", "--height", "6", "-q"];

#[test]
fn an_output_on_a_gltf_scenes_texture_or_file_is_refused() {
    // `-o tex.exr` wrote tex.png over the scene's texture, with exit 0.
    let dir = scratch("outputs_gltf");
    write_textured_gltf(&dir);
    let files = ["quad.gltf", "quad.bin", "tex.png"];
    let before = contents(&dir, &files);
    // The scene renders (the texture is read) before any refusal is tested.
    run(&dir, &[&["render", "quad.gltf", "-o", "ok.exr"], &SMALL[..]].concat());
    let with = |extra: &[&'static str]| [&["render", "quad.gltf"], extra, &SMALL[..]].concat();
    refused(
        &dir,
        &with(&["-o", "tex.exr"]),
        1,
        &[
            "tex.png: would overwrite the scene's input tex.png; write the output elsewhere",
            "-o tex.exr also writes tex.png",
        ],
    );
    // Another spelling of the same file.
    std::fs::create_dir(dir.join("sub")).unwrap();
    refused(&dir, &with(&["-o", "sub/../tex.exr"]), 1, &["sub/../tex.png: would overwrite the scene's input tex.png"]);
    // Films and checkpoints must be named .film, so none can land on a scene file or an image.
    refused(&dir, &with(&["--film", "quad.gltf"]), 1, &["--film quad.gltf: a film file must end in .film"]);
    refused(&dir, &with(&["--checkpoint", "tex.png"]), 1, &["--checkpoint tex.png: a film file must end in .film"]);
    refused(&dir, &with(&["--film", "x.exr"]), 1, &["--film x.exr: a film file must end in .film"]);
    assert_eq!(contents(&dir, &files), before, "the scene's files were changed");
}

#[test]
fn an_output_on_an_obj_scenes_texture_mtl_or_environment_map_is_refused() {
    let dir = scratch("outputs_obj");
    for name in ["cube_and_sphere.obj", "cube_and_sphere.mtl"] {
        std::fs::copy(repo("scenes/obj").join(name), dir.join(name)).unwrap();
    }
    // A texture for the floor, so the MTL names an image an output could replace.
    let mtl = std::fs::read_to_string(dir.join("cube_and_sphere.mtl")).unwrap();
    std::fs::write(
        dir.join("cube_and_sphere.mtl"),
        mtl.replacen("newmtl floor\n", "newmtl floor\nmap_Kd wood.png\n", 1),
    )
    .unwrap();
    write_texture(&dir, "wood.png");
    // An environment map: any EXR will do, a render's.
    run(&dir, &[&["render", "-o", "env.exr"], &SMALL[..]].concat());
    let files = ["cube_and_sphere.obj", "cube_and_sphere.mtl", "wood.png", "env.exr"];
    let before = contents(&dir, &files);
    let with =
        |extra: &[&'static str]| [&["render", "cube_and_sphere.obj", "--env", "env.exr"], extra, &SMALL[..]].concat();
    run(&dir, &with(&["-o", "ok.exr"]));
    refused(
        &dir,
        &with(&["--film", "cube_and_sphere.mtl"]),
        1,
        &["--film cube_and_sphere.mtl: a film file must end in .film"],
    );
    refused(&dir, &with(&["-o", "wood.exr"]), 1, &["wood.png: would overwrite the scene's input wood.png"]);
    refused(&dir, &with(&["-o", "env.exr"]), 1, &["env.exr: would overwrite the scene's input env.exr"]);
    assert_eq!(contents(&dir, &files), before, "the scene's files were changed");
}

#[test]
fn merge_and_resume_do_not_write_over_their_films() {
    let dir = scratch("outputs_films");
    let scene = repo("scenes/reference/cornell_box.json").display().to_string();
    let part = |k: &str, film: &str| {
        let args = ["render", &scene, "--spp", "2", "--integrator", "path", "--spectral", "bins:8", "--part", k];
        run(&dir, &[&args[..], &["--film", film], &SMALL[..]].concat());
    };
    part("1/2", "a.film");
    part("2/2", "b.film");
    let films = ["a.film", "b.film"];
    let before = contents(&dir, &films);
    refused(
        &dir,
        &["merge", "a.film", "b.film", "--film", "a.film"],
        1,
        &["a.film: would overwrite the part a.film; write the output elsewhere"],
    );
    refused(
        &dir,
        &["merge", "a.film", "b.film", "--film", "./b.film", "-o", "m.exr"],
        1,
        &["would overwrite the part b.film"],
    );
    refused(
        &dir,
        &["merge", "a.film", "b.film", "--film", "m.exr"],
        1,
        &["--film m.exr: a film file must end in .film"],
    );
    assert_eq!(contents(&dir, &films), before, "the parts were changed");
    // A render resumed into its own checkpoint is the workflow checkpoints are for: allowed.
    let render = ["render", &scene, "--spp", "2", "--integrator", "path", "--spectral", "bins:8"];
    run(&dir, &[&render[..], &["--time-limit", "0.001", "--film", "c.film"], &SMALL[..]].concat());
    run(&dir, &[&render[..], &["--resume", "c.film", "--checkpoint", "c.film", "-o", "r.exr"], &SMALL[..]].concat());
    assert!(dir.join("r.exr").exists());
}
