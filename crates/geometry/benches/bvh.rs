//! BVH build time, memory and ray throughput (primary and incoherent rays), one thread, at
//! every SIMD level this CPU supports, on the issue-15 scenes: procedural terrains of 100k
//! and 1.0M triangles and a closed 1.3M-triangle icosphere. Rays are generated before timing:
//! 1024² primary rays from a camera, and one cosine-weighted hemisphere ray spawned from each
//! primary hit. `obvhs_moller_trumbore_*` traces the 1M terrain's rays through obvhs's own
//! CWBVH traversal and (non-watertight) triangle test, as a same-run reference.
//!
//! `taskset -c 1 cargo bench -p geometry --bench bvh -- --warm-up-time 1 --measurement-time 3`
//!
//! With `SPECTRACE_EXPORT_RAYS=DIR` the triangles (`SCENE.tris`: f32 x, y, z per vertex, three
//! per triangle), the rays (`SCENE_primary.rays`, `SCENE_incoherent.rays`: f32 origin and
//! direction) and our hit counts (`SCENE.hits.json`) are written to DIR for
//! `xtask/compare/embree_bvh.py`, which traces the same rays with Embree.

use std::hint::black_box;
use std::io::Write;
use std::time::Instant;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use geometry::{Camera, Mesh, Ray, Scene, SimdLevel, spawn_ray};
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

/// A closed icosphere of radius `r` centred at `c`: 20·4ⁿ triangles sharing edges and vertices.
fn icosphere(subdivisions: u32, c: Vec3, r: f32) -> Mesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|p| Vec3::from_array(*p).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut cache = std::collections::HashMap::new();
        let mut mid = |a: u32, b: u32, v: &mut Vec<Vec3>| {
            *cache.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push(((v[a as usize] + v[b as usize]) * 0.5).normalize());
                v.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(f.len() * 4);
        for [a, b, c] in f {
            let (ab, bc, ca) = (mid(a, b, &mut v), mid(b, c, &mut v), mid(c, a, &mut v));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    let positions = v.iter().map(|p| c + *p * r).collect();
    Mesh::new(positions, None, None, f, None).unwrap()
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

fn write_f32(path: &std::path::Path, values: impl Iterator<Item = f32>) {
    let mut out = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    for v in values {
        out.write_all(&v.to_le_bytes()).unwrap();
    }
}

fn export(dir: &str, name: &str, mesh: &Mesh, primary: &[Ray], incoherent: &[Ray], hits: &str) {
    let dir = std::path::Path::new(dir);
    std::fs::create_dir_all(dir).unwrap();
    let p = mesh.positions();
    write_f32(
        &dir.join(format!("{name}.tris")),
        mesh.indices().iter().flat_map(|t| t.map(|i| p[i as usize])).flat_map(|v| v.to_array()),
    );
    for (kind, rays) in [("primary", primary), ("incoherent", incoherent)] {
        write_f32(
            &dir.join(format!("{name}_{kind}.rays")),
            rays.iter().flat_map(|r| [r.origin.to_array(), r.dir.to_array()]).flatten(),
        );
    }
    std::fs::write(dir.join(format!("{name}.hits.json")), hits).unwrap();
}

fn bench(c: &mut Criterion) {
    let levels: Vec<SimdLevel> = SimdLevel::ALL.into_iter().filter(|l| l.is_supported()).collect();
    let scenes: [(&str, fn() -> Mesh); 3] = [
        // 2·224² ≈ 100k and 2·708² ≈ 1.0M triangles; 20·4⁸ = 1,310,720.
        ("terrain_100k", || terrain(224)),
        ("terrain_1m", || terrain(708)),
        ("icosphere_1_3m", || icosphere(8, Vec3::ZERO, 1.0)),
    ];
    for (name, make) in scenes {
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
        // Hit counts must be identical at every level (they are bit-identical by construction;
        // the tests check the hits themselves).
        let mut counts = Vec::new();
        for &level in &levels {
            scene.set_simd_level(level);
            let p = primary.iter().filter(|r| scene.intersect(r, f32::INFINITY).is_some()).count();
            let i = incoherent.iter().filter(|r| scene.intersect(r, f32::INFINITY).is_some()).count();
            let a = incoherent.iter().filter(|r| scene.occluded(r, f32::INFINITY)).count();
            counts.push((level, p, i, a));
        }
        assert!(counts.windows(2).all(|w| (w[0].1, w[0].2, w[0].3) == (w[1].1, w[1].2, w[1].3)), "{counts:?}");
        let (_, p, i, a) = counts[0];
        eprintln!("{name}: hits primary {p}/{}, incoherent {i}/{}, any-hit {a}", primary.len(), incoherent.len());
        if let Ok(dir) = std::env::var("SPECTRACE_EXPORT_RAYS") {
            let hits = format!(
                "{{\"triangles\": {triangles}, \"primary\": {p}, \"incoherent\": {i}, \"incoherent_any\": {a}}}\n"
            );
            export(&dir, name, &mesh, &primary, &incoherent, &hits);
        }
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
/// comparison issue 3 quoted, measured in the same process and conditions.
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
