//! Brief fuzzing of the loaders' in-memory entry points with proptest (no cargo-fuzz): random bytes, random
//! token soups in each format's grammar, and random mutations of the committed scenes. The claim: no input
//! panics, in our code or in `gltf`/`tobj` (which would surface as [`Error::ParserPanic`]). Inputs that once
//! failed are kept as regression fixtures in `tests/it/fixtures/fuzz/` and replayed here.
//! `PROPTEST_CASES` raises the case count.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::Path;

use proptest::prelude::*;

use crate::desc::SceneDescription;
use crate::error::Error;
use crate::limits::Budget;

fn scenes_dir() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
}

fn read(path: &str) -> Vec<u8> {
    std::fs::read(scenes_dir().join(path)).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// Runs a loader; fails with the input when it panics or reports a third-party panic.
fn check<T: std::fmt::Debug>(
    input: &[u8],
    f: impl FnOnce() -> crate::error::Result<T>,
) -> std::result::Result<(), TestCaseError> {
    match catch_unwind(AssertUnwindSafe(f)) {
        Err(_) => Err(TestCaseError::fail(format!("panic on input {:?}", String::from_utf8_lossy(input)))),
        Ok(Err(e @ Error::ParserPanic { .. })) => {
            Err(TestCaseError::fail(format!("{e} on input {:?}", String::from_utf8_lossy(input))))
        }
        Ok(_) => Ok(()),
    }
}

/// A budget small enough that a fuzzed claim of a huge accessor is refused quickly (256 MiB).
fn budget() -> Budget {
    Budget::new(crate::LoadOptions { max_memory: 256 << 20, ..crate::LoadOptions::default() })
}

/// What the loaders produced, through the pre-filter and the BVH build (obvhs must not panic either).
fn build(desc: SceneDescription) -> crate::error::Result<crate::Scene> {
    let (meshes, _) = crate::prefilter::remove_unhittable(desc.meshes);
    crate::Scene::build(desc.spheres, meshes)
}

fn gltf(bytes: &[u8]) -> std::result::Result<(), TestCaseError> {
    check(bytes, || build(crate::gltf_loader::load_gltf_slice(bytes, None, Path::new("fuzz.gltf"), &budget())?))
}

fn obj(bytes: &[u8]) -> std::result::Result<(), TestCaseError> {
    let text = String::from_utf8_lossy(bytes);
    check(bytes, || build(crate::obj_loader::load_obj_text(&text, None, Path::new("fuzz.obj"), &budget())?))
}

fn mtl(bytes: &[u8]) -> std::result::Result<(), TestCaseError> {
    let text = String::from_utf8_lossy(bytes);
    check(bytes, || {
        let clean = crate::obj_loader::sanitize_mtl_text(&text, Path::new("fuzz.mtl"))?;
        // tobj's own errors are fine; only a panic is a failure.
        let _ = crate::limits::guard_panic(Path::new("fuzz.mtl"), "tobj", || {
            Ok(tobj::load_mtl_buf(&mut clean.as_bytes()))
        })?;
        Ok(())
    })
}

fn manifest(bytes: &[u8]) -> std::result::Result<(), TestCaseError> {
    let text = String::from_utf8_lossy(bytes);
    // Mesh references resolve under the scenes folder, so mutated manifests also load real files.
    let base = scenes_dir().join("paper");
    check(bytes, || build(crate::load::parse_manifest(&text, &base, "fuzz.json")?))
}

/// Applies random edits (byte overwrite, insert, delete, truncate) to a valid file.
fn mutate(mut data: Vec<u8>, edits: &[(u8, usize, u8)]) -> Vec<u8> {
    for &(kind, at, byte) in edits {
        if data.is_empty() {
            data.push(byte);
            continue;
        }
        let i = at % data.len();
        match kind % 4 {
            0 => data[i] = byte,
            1 => data.insert(i, byte),
            2 => {
                data.remove(i);
            }
            _ => data.truncate(i),
        }
    }
    data
}

/// Bytes that matter in the formats: digits, signs, separators, JSON punctuation.
fn interesting_byte() -> impl Strategy<Value = u8> {
    prop_oneof![any::<u8>(), prop::sample::select(b"0123456789-+.eE/ \n{}[]:,\"nNaIf".to_vec())]
}

fn edits() -> impl Strategy<Value = Vec<(u8, usize, u8)>> {
    prop::collection::vec((any::<u8>(), any::<usize>(), interesting_byte()), 1..8)
}

fn obj_token() -> impl Strategy<Value = String> {
    prop_oneof![
        prop::sample::select(vec!["v", "vt", "vn", "f", "l", "p", "o", "g", "usemtl", "s", "#", "mtllib"])
            .prop_map(str::to_owned),
        (-5i64..5).prop_map(|i| i.to_string()),
        (-5i64..5, -5i64..5).prop_map(|(a, b)| format!("{a}/{b}")),
        (-5i64..5, -5i64..5).prop_map(|(a, b)| format!("{a}//{b}")),
        (-5i64..5, -5i64..5, -5i64..5).prop_map(|(a, b, c)| format!("{a}/{b}/{c}")),
        prop::sample::select(vec![
            "nan",
            "inf",
            "-inf",
            "1e39",
            "0.5",
            "-99999999999999999999",
            "1/-99999999999999",
            "/",
            "//",
            "x.mtl"
        ])
        .prop_map(str::to_owned),
        any::<f32>().prop_map(|f| f.to_string()),
    ]
}

fn mtl_token() -> impl Strategy<Value = String> {
    prop_oneof![
        prop::sample::select(vec![
            "newmtl", "Kd", "Ks", "Ka", "Ke", "Tf", "Ns", "Ni", "d", "Tr", "illum", "map_Kd", "spectral", "xyz",
            "-halo", "bump"
        ])
        .prop_map(str::to_owned),
        prop::sample::select(vec!["0.5", "1", "nan", "inf", "x.rfl", "a.csv", "-1", "300", "1e40", ""])
            .prop_map(str::to_owned),
        any::<f32>().prop_map(|f| f.to_string()),
    ]
}

fn lines_of(token: BoxedStrategy<String>) -> impl Strategy<Value = Vec<u8>> {
    prop::collection::vec(prop::collection::vec(token, 0..6), 0..24)
        .prop_map(|lines| lines.into_iter().map(|l| l.join(" ")).collect::<Vec<_>>().join("\n").into_bytes())
}

proptest! {
    #[test]
    fn random_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..512)) {
        gltf(&bytes)?;
        obj(&bytes)?;
        mtl(&bytes)?;
        manifest(&bytes)?;
        // Random bytes behind a GLB header reach the binary-chunk parser.
        let mut glb = b"glTF\x02\x00\x00\x00".to_vec();
        glb.extend_from_slice(&bytes);
        gltf(&glb)?;
    }

    #[test]
    fn obj_token_soup_never_panics(text in lines_of(obj_token().boxed())) {
        obj(&text)?;
    }

    #[test]
    fn mtl_token_soup_never_panics(text in lines_of(mtl_token().boxed())) {
        mtl(&text)?;
    }

    #[test]
    fn mutated_gltf_never_panics(e in edits()) {
        gltf(&mutate(read("meshes/gem.gltf"), &e))?;
    }

    #[test]
    fn mutated_obj_never_panics(e in edits()) {
        obj(&mutate(read("obj/cube_and_sphere.obj"), &e))?;
        mtl(&mutate(read("obj/cube_and_sphere.mtl"), &e))?;
    }

    #[test]
    fn mutated_manifest_never_panics(e in edits()) {
        manifest(&mutate(read("paper/gltf_mesh.json"), &e))?;
    }
}

/// Replays every file kept in `tests/it/fixtures/fuzz/` through the loader its extension names.
#[test]
fn fuzz_regressions_never_panic() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/it/fixtures/fuzz");
    let mut count = 0;
    for entry in std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display())) {
        let path = entry.unwrap_or_else(|e| panic!("{e}")).path();
        let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let result = match path.extension().and_then(|e| e.to_str()) {
            Some("gltf" | "glb") => gltf(&bytes),
            Some("obj") => obj(&bytes),
            Some("mtl") => mtl(&bytes),
            Some("json") => manifest(&bytes),
            _ => continue,
        };
        count += 1;
        if let Err(e) = result {
            panic!("{}: {e}", path.display());
        }
    }
    assert!(count > 0, "no fuzz fixtures in {}", dir.display());
}
