//! BVH build time, memory and ray throughput (primary and incoherent rays), one thread, at
//! every SIMD level this CPU supports, on the benchmark scenes: procedural terrains of 100k
//! and 1.0M triangles and a closed 1.3M-triangle icosphere. Rays are generated before timing:
//! 1024² primary rays from a camera, and one cosine-weighted hemisphere ray spawned from each
//! primary hit. `obvhs_moller_trumbore_*` traces the 1M terrain's rays through obvhs's own
//! CWBVH traversal and (non-watertight) triangle test, as a same-run reference.
//!
//! `taskset -c 1 cargo bench -p geometry --bench bvh -- --warm-up-time 1 --measurement-time 3`
//! `benches/traversal_table.rs` measures the same queries in interleaved rounds in CPU time,
//! which a shared machine disturbs less, and exports the rays for the Embree comparison.

use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use geometry::{Mesh, Ray, Scene, SimdLevel};

mod common;
use common::{SCENES, rays};

fn bench(c: &mut Criterion) {
    let levels: Vec<SimdLevel> = SimdLevel::supported().collect();
    for (name, make) in SCENES {
        let mesh = make();
        let triangles = mesh.triangle_count();
        let start = Instant::now();
        let mut scene = Scene::build(Vec::new(), vec![mesh.clone()]).unwrap();
        let stats = scene.stats();
        eprintln!(
            "{name}: {triangles} triangles: build {:.1} ms (one call, parallel), {} nodes, {:.1} bytes/triangle",
            start.elapsed().as_secs_f64() * 1e3,
            stats.node_count,
            stats.bytes_per_primitive
        );
        let (primary, incoherent) = rays(&scene);
        let mut group = c.benchmark_group(name);
        group.sample_size(10);
        for &level in &levels {
            scene.set_simd_level(level);
            let l = level.name();
            group.throughput(Throughput::Elements(primary.len() as u64));
            group.bench_function(format!("{l}/primary_closest_hit"), |bencher| {
                bencher
                    .iter(|| primary.iter().filter(|r| scene.intersect(black_box(r), f32::INFINITY).is_some()).count())
            });
            group.throughput(Throughput::Elements(incoherent.len() as u64));
            group.bench_function(format!("{l}/incoherent_closest_hit"), |bencher| {
                bencher.iter(|| {
                    incoherent.iter().filter(|r| scene.intersect(black_box(r), f32::INFINITY).is_some()).count()
                })
            });
            group.bench_function(format!("{l}/incoherent_any_hit"), |bencher| {
                bencher.iter(|| incoherent.iter().filter(|r| scene.occluded(black_box(r), f32::INFINITY)).count())
            });
        }
        if name == "terrain_1m" {
            obvhs_reference(&mut group, &mesh, &primary, &incoherent);
        }
        group.finish();
        group_build(c, name, &mesh);
    }
}

/// The same rays through obvhs's own CWBVH and Möller–Trumbore test (not watertight): the
/// baseline comparison, measured in the same process and conditions.
fn obvhs_reference(
    group: &mut criterion::BenchmarkGroup<'_, criterion::measurement::WallTime>,
    mesh: &Mesh,
    primary: &[Ray],
    incoherent: &[Ray],
) {
    let tris: Vec<obvhs::triangle::Triangle> = mesh
        .indices()
        .iter()
        .map(|t| {
            let p = |i: u32| glam::Vec3A::from(mesh.positions()[i as usize]);
            obvhs::triangle::Triangle { v0: p(t[0]), v1: p(t[1]), v2: p(t[2]) }
        })
        .collect();
    let native = obvhs::cwbvh::builder::build_cwbvh_from_tris(
        &tris,
        obvhs::BvhBuildParams::medium_build(),
        &mut std::time::Duration::default(),
    );
    let to_native = |r: &Ray| obvhs::ray::Ray::new_inf(r.origin.into(), r.dir.into());
    for (name, rays) in [("primary", primary), ("incoherent", incoherent)] {
        let native_rays: Vec<_> = rays.iter().map(to_native).collect();
        group.throughput(Throughput::Elements(native_rays.len() as u64));
        group.bench_function(format!("obvhs_moller_trumbore_{name}"), |bencher| {
            bencher.iter(|| {
                native_rays
                    .iter()
                    .filter(|r| {
                        let mut hit = obvhs::ray::RayHit::none();
                        native.ray_traverse(**r, &mut hit, |ray, id| {
                            tris[native.primitive_indices[id] as usize].intersect(ray)
                        })
                    })
                    .count()
            })
        });
    }
}

fn group_build(c: &mut Criterion, name: &str, mesh: &Mesh) {
    let mut group = c.benchmark_group(name);
    group.sample_size(10);
    group.throughput(Throughput::Elements(mesh.triangle_count() as u64));
    group.bench_function("build", |bencher| bencher.iter(|| Scene::build(Vec::new(), vec![mesh.clone()]).unwrap()));
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
