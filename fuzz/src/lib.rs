//! What every fuzz target does with a scene once its bytes are on disk: load it, assemble it
//! (materials, lights, BVH), summarise it as `spectrace info` does, and render 8×8 pixels with
//! both integrators. Errors are the expected outcome for most inputs; only a panic, an abort
//! (out of memory), a hang or a non-finite pixel is a finding.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use integrator::{IntegratorKind, RenderOptions, RenderScene, SpectralMode};

/// A folder of this process's own for the files a target writes (in RAM when /dev/shm
/// exists, so the disk is not worn by millions of executions).
pub fn scratch() -> PathBuf {
    let shm = Path::new("/dev/shm");
    let base = if shm.is_dir() { shm.to_path_buf() } else { std::env::temp_dir() };
    let dir = base.join(format!("spectrace-fuzz-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("scratch folder");
    dir
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
    let summary = geometry::summarize(&desc, scene.geometry());
    std::hint::black_box(serde_json::to_string(&summary).expect("summary serialises"));
    let _ = integrator::choose_auto(&scene, IntegratorKind::WhittedHall);
    for (integrator, spectral) in
        [(IntegratorKind::WhittedHall, SpectralMode::Auto), (IntegratorKind::Path, SpectralMode::parse("hero:4").expect("hero:4"))]
    {
        let options = RenderOptions {
            width: 8,
            height: 8,
            integrator,
            spectral,
            threads: Some(1),
            max_depth: Some(8),
            ..RenderOptions::default()
        };
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
