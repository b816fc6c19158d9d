//! Time loading a scene file (parse and the removal of unhittable triangles) and building its
//! BVH, separately, for the load-and-build comparison (`xtask/compare/embree_build.py`,
//! `docs/perf.md`, "Loading and building"):
//!
//!     cargo build --release -p geometry --example load_build
//!     target/release/examples/load_build FILE [ROUNDS]
//!
//! Loads once, then builds `ROUNDS` times (default 3) from copies of the loaded meshes, and prints
//! one line per phase: `load_ms`, then `build_ms` per round (`Scene::stats`'s build time, the
//! figure `spectrace info` reports as `bvh.build_ms`), with the triangle count and the BVH's bytes
//! per triangle.

use std::process::ExitCode;
use std::time::Instant;

fn run(args: &[String]) -> Result<(), String> {
    let (file, rounds) = match args {
        [file] => (file, 3),
        [file, rounds] => (file, rounds.parse().map_err(|_| format!("ROUNDS: not a count: {rounds}"))?),
        _ => return Err("usage: load_build FILE [ROUNDS]".into()),
    };
    let start = Instant::now();
    let desc = geometry::load_scene(std::path::Path::new(file)).map_err(|e| e.to_string())?;
    let load = start.elapsed();
    let triangles: usize = desc.meshes.iter().map(|m| m.triangle_count()).sum();
    println!("load_ms {:.1} triangles {triangles}", load.as_secs_f64() * 1e3);
    for _ in 0..rounds {
        let scene = geometry::Scene::build(desc.spheres.clone(), desc.meshes.clone()).map_err(|e| e.to_string())?;
        let stats = scene.stats();
        println!(
            "build_ms {:.1} nodes {} bytes_per_primitive {:.2}",
            stats.build_time.as_secs_f64() * 1e3,
            stats.node_count,
            stats.bytes_per_primitive
        );
    }
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("load_build: {e}");
            ExitCode::FAILURE
        }
    }
}
