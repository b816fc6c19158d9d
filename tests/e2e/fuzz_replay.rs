//! Every input in `fuzz/regressions/<target>/` (inputs that once crashed, hung or exhausted
//! memory, found by the fuzz targets or by hand) replayed through the fuzz targets' own
//! pipeline (load → assemble → info → 8×8 renders), on the stable toolchain. A panic fails
//! the test with the file's name.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::PathBuf;

#[path = "../../fuzz/src/lib.rs"]
#[allow(dead_code, unreachable_pub)]
mod pipeline;

/// One fuzz target's entry point.
type Target = fn(&[u8]);

#[test]
fn every_fuzz_regression_replays_without_a_panic() {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/regressions");
    let targets: [(&str, Target); 8] = [
        ("gltf", pipeline::gltf),
        ("glb", pipeline::glb),
        ("obj_mtl", pipeline::obj_mtl),
        ("manifest", pipeline::manifest),
        ("csv", pipeline::csv),
        ("film", pipeline::film),
        ("envmap", pipeline::envmap),
        ("texture", pipeline::texture),
    ];
    let mut replayed = 0;
    let mut failures = Vec::new();
    for (target, run) in targets {
        let mut files: Vec<PathBuf> = std::fs::read_dir(root.join(target))
            .unwrap_or_else(|e| panic!("fuzz/regressions/{target}: {e}"))
            .map(|e| e.unwrap().path())
            .filter(|p| !p.file_name().is_some_and(|n| n.to_string_lossy().starts_with('.')))
            .collect();
        files.sort();
        for file in files {
            let bytes = std::fs::read(&file).unwrap();
            if catch_unwind(AssertUnwindSafe(|| run(&bytes))).is_err() {
                failures.push(format!("{target}/{}", file.file_name().unwrap().to_string_lossy()));
            }
            replayed += 1;
        }
    }
    let _ = std::fs::remove_dir_all(pipeline::scratch());
    eprintln!("replayed {replayed} fuzz regression inputs");
    assert!(replayed >= 5, "the regression folders are missing");
    assert!(failures.is_empty(), "panicked: {failures:?}");
}
