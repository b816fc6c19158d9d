//! The throughput table: closest-hit (primary and incoherent rays) and any-hit
//! (incoherent rays) per scene at every SIMD level this CPU supports, one thread, in
//! interleaved rounds (each round runs every level once on every ray set, so slow phases of a
//! shared machine hit all levels alike); the median of the rounds' throughputs, in rays per
//! second of this thread's CPU time. Also build time, bytes per triangle and hit counts (which
//! must be identical at every level).
//!
//! `taskset -c 1 cargo bench -p geometry --bench traversal_table` (`TABLE_ROUNDS`, default 5;
//! `TABLE_LEVELS=avx2,sse2` runs only the levels named, e.g. for a profile of one kernel). Two
//! small terrains (2k, 10k triangles) come first: their trees fit in the caches.
//!
//! With `SPECTRACE_EXPORT_RAYS=DIR` the triangles (`SCENE.tris`: f32 x, y, z per vertex, three
//! per triangle), the rays (`SCENE_primary.rays`, `SCENE_incoherent.rays`: f32 origin and
//! direction) and our hit counts (`SCENE.hits.json`) are written to DIR for
//! `xtask/compare/embree_bvh.py`, which traces the same rays with Embree through embreex, and
//! `xtask/compare/embree_direct.c`, which calls the same library from C (with `trace_ab.py`
//! alternating it and `examples/trace_exported.rs`: the comparison to quote).

use std::hint::black_box;
use std::time::Instant;

use geometry::{Instances, Ray, Scene, SimdLevel};
use glam::{Mat4, Vec3};

mod common;
use common::{SCENES, SMALL_SCENES, cornell_box, export, icosphere, rays, rays_from, thread_cpu_seconds};

fn seconds() -> f64 {
    thread_cpu_seconds().unwrap_or_else(|| {
        static START: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();
        START.get_or_init(Instant::now).elapsed().as_secs_f64()
    })
}

/// (hits per pass, CPU seconds per pass) of `reps` passes over `rays`.
fn pass(scene: &Scene, rays: &[Ray], any: bool, reps: usize) -> (usize, f64) {
    let t = seconds();
    let mut hits = 0;
    for _ in 0..reps {
        hits = if any {
            rays.iter().filter(|r| scene.occluded(black_box(r), f32::INFINITY)).count()
        } else {
            rays.iter().filter(|r| scene.intersect(black_box(r), f32::INFINITY).is_some()).count()
        };
    }
    (hits, (seconds() - t) / reps as f64)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let rounds: usize = std::env::var("TABLE_ROUNDS").ok().and_then(|s| s.parse().ok()).unwrap_or(5);
    let filter = std::env::args().skip(1).find(|a| !a.starts_with('-'));
    // `TABLE_LEVELS=avx2` (comma-separated names) keeps only those levels: a profile of one kernel.
    let only = std::env::var("TABLE_LEVELS").ok();
    let levels: Vec<SimdLevel> =
        SimdLevel::supported().filter(|l| only.as_ref().is_none_or(|o| o.split(',').any(|n| n == l.name()))).collect();
    let time_kind = if thread_cpu_seconds().is_some() { "thread CPU time" } else { "wall time" };
    println!("median of {rounds} interleaved rounds, M rays/s of {time_kind}, one thread");
    println!();
    print!("| scene | rays |");
    for l in &levels {
        print!(" {} |", l.name());
    }
    println!();
    println!("|---|---|{}", "---|".repeat(levels.len()));
    let mut notes = Vec::new();
    for (name, make) in SMALL_SCENES.into_iter().chain(SCENES) {
        if filter.as_ref().is_some_and(|f| !name.contains(f.as_str())) {
            continue;
        }
        let mesh = make();
        let wall = Instant::now();
        let mut scene = Scene::build(Vec::new(), vec![mesh.clone()]).unwrap();
        let stats = scene.stats();
        notes.push(format!(
            "{name}: {} triangles, build {:.0} ms wall, {} nodes, {:.1} bytes/triangle",
            mesh.triangle_count(),
            wall.elapsed().as_secs_f64() * 1e3,
            stats.node_count,
            stats.bytes_per_primitive
        ));
        let (primary, incoherent) = rays(&scene);
        let hits = rows(name, &mut scene, (&primary, &incoherent), &levels, rounds, 1, &mut notes);
        if let Ok(dir) = std::env::var("SPECTRACE_EXPORT_RAYS") {
            let json = format!(
                "{{\"triangles\": {}, \"primary\": {}, \"incoherent\": {}, \"incoherent_any\": {}}}\n",
                mesh.triangle_count(),
                hits[0][0],
                hits[1][0],
                hits[2][0]
            );
            export(&dir, name, &mesh, &primary, &incoherent, &json);
        }
    }
    // Instances (the two-level BVH): an icosphere placed 64 times. Its object-level traversal
    // runs inside the top level's leaf test, which must be compiled into the SIMD kernel too
    // (out of line, the AVX2 node test became a call per intrinsic, ~2.8× slower).
    let name = "instanced_64x5k";
    if filter.as_ref().is_none_or(|f| name.contains(f.as_str())) {
        let ball = icosphere(4, Vec3::ZERO, 0.09);
        let transforms: Vec<Mat4> = (0..64)
            .map(|i| {
                Mat4::from_translation(Vec3::new((i % 8) as f32 * 0.25 - 0.875, 0.0, (i / 8) as f32 * 0.25 - 0.875))
            })
            .collect();
        let instances = Instances::new(vec![ball], transforms).unwrap();
        let mut scene = Scene::build_with_instances(Vec::new(), Vec::new(), vec![instances]).unwrap();
        notes.push(format!("{name}: {} placements of {} triangles", scene.instance_count(), 20 * 4u32.pow(4)));
        let (primary, incoherent) = rays(&scene);
        rows(name, &mut scene, (&primary, &incoherent), &levels, rounds, 1, &mut notes);
    }
    // The Cornell box (12 triangles, two spheres): what the path tracer's reference scene asks
    // of traversal, where a ray's fixed cost outweighs its node and leaf tests.
    let name = "cornell_box";
    if filter.as_ref().is_none_or(|f| name.contains(f.as_str())) {
        let (mut scene, camera) = cornell_box();
        // As the path tracer assembles it: no material reads a texture, so sphere hits carry
        // no surface coordinates (their atan2 and acos were 3 % of this row's time).
        scene.set_sphere_uvs(false);
        notes.push(format!("{name}: 12 triangles and 2 spheres, {} nodes", scene.stats().node_count));
        let (primary, incoherent) = rays_from(&scene, &camera);
        // Eight passes per measurement: one takes ~0.1 s, a few ticks of the CPU-time clock.
        rows(name, &mut scene, (&primary, &incoherent), &levels, rounds, 8, &mut notes);
    }
    println!();
    for n in notes {
        println!("{n}");
    }
}

/// The table's three rows for one scene (interleaved rounds over every level, each timing
/// `reps` passes); the hit counts per row, which must be equal at every level.
fn rows(
    name: &str,
    scene: &mut Scene,
    (primary, incoherent): (&[Ray], &[Ray]),
    levels: &[SimdLevel],
    rounds: usize,
    reps: usize,
    notes: &mut Vec<String>,
) -> Vec<Vec<usize>> {
    let kinds: [(&str, &[Ray], bool); 3] = [
        ("primary closest", primary, false),
        ("incoherent closest", incoherent, false),
        ("incoherent any", incoherent, true),
    ];
    let mut rates = vec![vec![Vec::new(); levels.len()]; kinds.len()];
    let mut hits = vec![vec![0; levels.len()]; kinds.len()];
    for _ in 0..rounds {
        for (k, &(_, rays, any)) in kinds.iter().enumerate() {
            for (l, &level) in levels.iter().enumerate() {
                scene.set_simd_level(level);
                let (h, t) = pass(scene, rays, any, reps);
                hits[k][l] = h;
                rates[k][l].push(rays.len() as f64 / t / 1e6);
            }
        }
    }
    for (k, &(kind, rays, _)) in kinds.iter().enumerate() {
        assert!(hits[k].iter().all(|&h| h == hits[k][0]), "{name} {kind}: hit counts differ by level: {:?}", hits[k]);
        print!("| {name} | {kind} |");
        for r in &rates[k] {
            print!(" {:.2} |", median(r.clone()));
        }
        println!();
        notes.push(format!("{name} {kind}: {} hits of {} rays at every level", hits[k][0], rays.len()));
    }
    hits
}
