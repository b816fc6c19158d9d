//! BVH build time, memory and ray throughput (primary and incoherent rays), one thread, on
//! procedural terrains of 100k and 1.0M triangles. Rays are generated before timing:
//! 1024² primary rays from a camera, and one cosine-weighted hemisphere ray spawned from each
//! primary hit. `obvhs_moller_trumbore_*` traces the same rays through obvhs's own CWBVH
//! traversal and (non-watertight) triangle test, as a same-run reference.
//!
//! `taskset -c 0 cargo bench -p geometry --bench bvh -- --warm-up-time 1 --measurement-time 3`

use std::hint::black_box;
use std::time::Instant;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use geometry::{Camera, Mesh, Ray, Scene, spawn_ray};
use glam::Vec3;

/// A bumpy heightfield of `n`×`n` quads (2n² triangles): a terrain seen from above.
fn terrain(n: u32) -> Mesh {
    let mut positions = Vec::with_capacity(((n + 1) * (n + 1)) as usize);
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (i as f32 / n as f32 * 2.0 - 1.0, j as f32 / n as f32 * 2.0 - 1.0);
            let y = 0.1 * (7.0 * x).sin() * (5.0 * z).cos() + 0.03 * (31.0 * x + 17.0 * z).sin();
            positions.push(Vec3::new(x, y, z));
        }
    }
    let mut indices = Vec::with_capacity((2 * n * n) as usize);
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            let (b, c, d) = (a + 1, a + n + 1, a + n + 2);
            indices.push([a, c, b]);
            indices.push([b, c, d]);
        }
    }
    Mesh::new(positions, None, None, indices, None).unwrap()
}

struct Xorshift(u64);
impl Xorshift {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

fn rays(scene: &Scene) -> (Vec<Ray>, Vec<Ray>) {
    let (w, h) = (1024u32, 1024u32);
    let camera = Camera::look_at(Vec3::new(0.0, 1.6, 1.6), Vec3::ZERO, Vec3::Y, 50.0, 1.0).unwrap();
    let primary: Vec<Ray> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, w, h))
        .collect();
    // Incoherent: cosine-weighted hemisphere directions from every primary hit, spawned robustly.
    let mut rng = Xorshift(0x2545_F491_4F6C_DD1D);
    let mut incoherent = Vec::new();
    for r in &primary {
        if let Some(hit) = scene.intersect(r, f32::INFINITY) {
            let (u1, u2) = (rng.next(), rng.next());
            let (rad, phi) = (u1.sqrt(), std::f32::consts::TAU * u2);
            let n = if hit.n.dot(r.dir) < 0.0 { hit.n } else { -hit.n };
            let (t, b) = n.any_orthonormal_pair();
            let dir = t * (rad * phi.cos()) + b * (rad * phi.sin()) + n * (1.0 - u1).max(0.0).sqrt();
            incoherent.push(spawn_ray(&hit, dir));
        }
    }
    (primary, incoherent)
}

fn bench(c: &mut Criterion) {
    for n in [224u32, 708] {
        // 2·224² ≈ 100k and 2·708² ≈ 1.0M triangles.
        let mesh = terrain(n);
        let triangles = mesh.triangle_count();
        let start = Instant::now();
        let scene = Scene::build(Vec::new(), vec![mesh.clone()]).unwrap();
        let stats = scene.stats();
        eprintln!(
            "{triangles} triangles: build {:.1} ms (one call, parallel), {} nodes, {:.1} bytes/triangle",
            start.elapsed().as_secs_f64() * 1e3,
            stats.node_count,
            stats.bytes_per_primitive
        );
        let (primary, incoherent) = rays(&scene);
        let mut group = c.benchmark_group(format!("{}k_triangles", triangles / 1000));
        group.sample_size(10);
        group.throughput(Throughput::Elements(primary.len() as u64));
        group.bench_function("primary_closest_hit", |bencher| {
            bencher.iter(|| primary.iter().filter(|r| scene.intersect(black_box(r), f32::INFINITY).is_some()).count())
        });
        group.throughput(Throughput::Elements(incoherent.len() as u64));
        group.bench_function("incoherent_closest_hit", |bencher| {
            bencher
                .iter(|| incoherent.iter().filter(|r| scene.intersect(black_box(r), f32::INFINITY).is_some()).count())
        });
        group.bench_function("incoherent_any_hit", |bencher| {
            bencher.iter(|| incoherent.iter().filter(|r| scene.occluded(black_box(r), f32::INFINITY)).count())
        });
        // The same rays through obvhs's own CWBVH and Möller–Trumbore test (not watertight):
        // the comparison the issue quotes, measured in the same process and conditions.
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
        for (name, rays) in [("primary", &primary), ("incoherent", &incoherent)] {
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
        group.finish();
        group_build(c, &mesh, triangles);
    }
}

fn group_build(c: &mut Criterion, mesh: &Mesh, triangles: usize) {
    let mut group = c.benchmark_group(format!("{}k_triangles", triangles / 1000));
    group.sample_size(10);
    group.throughput(Throughput::Elements(triangles as u64));
    group.bench_function("build", |bencher| bencher.iter(|| Scene::build(Vec::new(), vec![mesh.clone()]).unwrap()));
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
