//! Trace one ray set that `traversal_table` exported (`SPECTRACE_EXPORT_RAYS=DIR`) with
//! `Scene::intersect`, `PASSES` times, and print the hits: a fixed workload for an instruction
//! count. `xtask/compare/embree_trace.py` runs the same rays through Embree.
//!
//!     cargo build --profile bench -p geometry --example trace_exported
//!     valgrind --tool=callgrind target/release/examples/trace_exported DIR terrain_2k primary 1
//!     valgrind --tool=callgrind target/release/examples/trace_exported DIR terrain_2k primary 3
//!
//! Half the difference of the two totals, over the ray count, is the instructions per ray of
//! one pass (the build and the file reading cancel). With `--miss` the scene is one far-away
//! triangle the rays all miss at the root: the fixed cost of a query.

use std::process::ExitCode;

use geometry::{Mesh, Ray, Scene};
use glam::Vec3;

fn floats(path: &str) -> Result<Vec<f32>, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("{path}: {e}"))?;
    if bytes.len() % 4 != 0 {
        return Err(format!("{path}: {} bytes, not a whole number of f32", bytes.len()));
    }
    Ok(bytes.chunks_exact(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect())
}

fn run(args: &[String]) -> Result<(), String> {
    let [dir, name, kind, passes, rest @ ..] = args else {
        return Err("usage: trace_exported DIR SCENE primary|incoherent PASSES [--miss]".into());
    };
    let passes: usize = passes.parse().map_err(|_| format!("PASSES: not a count: {passes}"))?;
    let miss = rest.iter().any(|a| a == "--miss");
    let positions: Vec<Vec3> = if miss {
        vec![Vec3::splat(1e6), Vec3::new(1e6 + 1.0, 1e6, 1e6), Vec3::new(1e6, 1e6 + 1.0, 1e6)]
    } else {
        floats(&format!("{dir}/{name}.tris"))?.chunks_exact(3).map(Vec3::from_slice).collect()
    };
    let indices = (0..positions.len() as u32 / 3).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
    let mesh = Mesh::new(positions, None, None, indices, None).map_err(|e| e.to_string())?;
    let scene = Scene::build(Vec::new(), vec![mesh]).map_err(|e| e.to_string())?;
    let rays: Vec<Ray> = floats(&format!("{dir}/{name}_{kind}.rays"))?
        .chunks_exact(6)
        .map(|c| Ray { origin: Vec3::from_slice(&c[..3]), dir: Vec3::from_slice(&c[3..]) })
        .collect();
    let mut hits = 0;
    for _ in 0..passes {
        hits += rays.iter().filter(|r| scene.intersect(std::hint::black_box(r), f32::INFINITY).is_some()).count();
    }
    println!("{} rays × {passes} passes at {}: {hits} hits", rays.len(), scene.simd_level().name());
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
