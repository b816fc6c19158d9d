//! Whole-image render time of the two integrators, one thread, per spectral strategy:
//! the paper's default scene (five spheres, 640×480, `whitted-hall`) in RGB and with 8–95
//! wavelength bins and `auto`, and the Cornell box (512×512, 4 spp, `path`). Throughput is in
//! pixels (paper) or camera samples (path) per second. Error against the converged image is
//! reported beside these times by `cargo xtask paper` and `cargo xtask validate`.
//!
//! `cargo bench -p integrator --bench render -- --warm-up-time 1 --measurement-time 5`

use std::path::Path;
use std::sync::atomic::AtomicBool;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use integrator::{Integrator, PathOptions, RenderOptions, RenderScene, SpectralMode, render};

fn run(scene: &RenderScene, options: &RenderOptions) -> u64 {
    let (_, stats) = render(scene, options, &|_| {}, &AtomicBool::new(false)).expect("render");
    assert_eq!(stats.nonfinite_samples, 0);
    stats.rays
}

fn paper(c: &mut Criterion) {
    let scene = RenderScene::default_scene().expect("default scene");
    let mut group = c.benchmark_group("five_spheres_640x480_whitted_hall");
    group.sample_size(10);
    let base = RenderOptions { threads: Some(1), ..RenderOptions::default() };
    group.throughput(Throughput::Elements(u64::from(base.width * base.height)));
    let modes = [
        ("rgb", SpectralMode::Rgb),
        ("auto", SpectralMode::Auto),
        ("bins8", SpectralMode::Bins(8)),
        ("bins16", SpectralMode::Bins(16)),
        ("bins32", SpectralMode::Bins(32)),
        ("bins95", SpectralMode::Bins(95)),
    ];
    for (name, spectral) in modes {
        let options = RenderOptions { spectral, ..base.clone() };
        group.bench_function(name, |b| b.iter(|| run(&scene, &options)));
    }
    group.finish();
}

fn path(c: &mut Criterion) {
    let file = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/reference/cornell_box.json");
    let scene = RenderScene::load(&file).expect("Cornell box");
    let mut group = c.benchmark_group("cornell_box_512x512_path_4spp");
    group.sample_size(10);
    let base = RenderOptions {
        width: 512,
        height: 512,
        integrator: Integrator::Path(PathOptions::default()),
        spp: 4,
        threads: Some(1),
        ..RenderOptions::default()
    };
    group.throughput(Throughput::Elements(u64::from(base.width * base.height * base.spp)));
    for (name, spectral) in
        [("auto", SpectralMode::Auto), ("hero4", SpectralMode::Hero { count: 4 }), ("rgb", SpectralMode::Rgb)]
    {
        let options = RenderOptions { spectral, ..base.clone() };
        group.bench_function(name, |b| b.iter(|| run(&scene, &options)));
    }
    group.finish();
}

criterion_group!(benches, paper, path);
criterion_main!(benches);
