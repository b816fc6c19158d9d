//! Integration tests of the integrator: analytic answers and hard cases, rendered at tiny
//! resolutions.

mod bdpt;
mod defaults;
mod envmap;
mod film;
mod fluorescence;
mod hard_cases;
mod luminaires;
mod measure;
mod mirrored_disc;
mod paper_model;
mod path;
mod prism;
mod spectral_film;
mod sppm;
mod terminator;
mod textures;
mod units;
mod vertex_colors;

use std::path::Path;
use std::sync::atomic::AtomicBool;

use integrator::{Image, RenderOptions, RenderScene, RenderStats, render};

/// Assemble a manifest given as JSON text.
/// Everything an error says, its sources included.
pub(crate) fn chain(e: &dyn std::error::Error) -> String {
    let mut out = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        out.push_str(": ");
        out.push_str(&s.to_string());
        source = s.source();
    }
    out
}

pub(crate) fn scene(json: &str) -> RenderScene {
    let desc = geometry::parse_manifest(json, Path::new("."), "<test>").expect("test manifest parses");
    RenderScene::from_description(desc).expect("test scene assembles")
}

/// Render with the given options; panics on error (tests only).
pub(crate) fn render_with(scene: &RenderScene, options: &RenderOptions) -> (Image, RenderStats) {
    render(scene, options, &|_| {}, &AtomicBool::new(false)).expect("render succeeds")
}

/// Small render options: `w`×`h`, no ambient unless asked.
pub(crate) fn options(w: u32, h: u32) -> RenderOptions {
    RenderOptions { width: w, height: h, threads: Some(1), ..Default::default() }
        .whitted(|w| w.ambient = integrator::Ambient::None)
}

/// Every pixel finite (the film replaces non-finite values, so check its counter too).
pub(crate) fn assert_all_finite(image: &Image, stats: &RenderStats) {
    assert_eq!(stats.nonfinite_samples, 0, "non-finite samples reached the film");
    assert!(image.pixels().iter().flatten().all(|v| v.is_finite()));
}

/// A scene of `scenes/reference/`.
pub(crate) fn reference(name: &str) -> RenderScene {
    RenderScene::load(&path::reference_path(name)).expect("reference scene loads")
}
