//! Trace one ray set that `traversal_table` exported (`SPECTRACE_EXPORT_RAYS=DIR`) with
//! `Scene::intersect` (`Scene::occluded` with `--any`), `PASSES` times, and print the hits and
//! the rate (rays per second of this thread's CPU time over all passes, so a run of ~1 s reads
//! the 4 ms clock to 0.4 %): a fixed workload for an instruction count, or for an A/B of two
//! builds on the very same rays (`taskset -c 1`, the two binaries alternating).
//! `xtask/compare/embree_direct.c` runs the same rays through Embree, with the same arguments
//! and output format (it replaced an earlier `embree_trace.py`, which went through embreex's
//! Python loop); `xtask/compare/trace_ab.py` alternates any of them on one core.
//!
//!     cargo build --profile bench -p geometry --example trace_exported
//!     valgrind --tool=callgrind target/release/examples/trace_exported DIR terrain_2k primary 1
//!     valgrind --tool=callgrind target/release/examples/trace_exported DIR terrain_2k primary 3
//!
//! Half the difference of the two totals, over the ray count, is the instructions per ray of
//! one pass (the build and the file reading cancel). With `--tool=cachegrind --cache-sim=no
//! --branch-sim=yes`, the same difference counts branches and (simulated) mispredictions. With
//! `--miss` the scene is one far-away triangle the rays all miss at the root: the fixed cost
//! of a query.

use std::process::ExitCode;

use geometry::{Mesh, Scene};
use glam::Vec3;

#[path = "../benches/common/mod.rs"]
mod common;

fn run(args: &[String]) -> Result<(), String> {
    let [dir, name, kind, passes, rest @ ..] = args else {
        return Err("usage: trace_exported DIR SCENE primary|incoherent PASSES [--miss] [--any]".into());
    };
    let passes: usize = passes.parse().map_err(|_| format!("PASSES: not a count: {passes}"))?;
    let (mut tris, rays) = common::read_exported(dir, name, kind)?;
    if rest.iter().any(|a| a == "--miss") {
        tris = vec![[Vec3::splat(1e6), Vec3::new(1e6 + 1.0, 1e6, 1e6), Vec3::new(1e6, 1e6 + 1.0, 1e6)]];
    }
    let indices = (0..tris.len() as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
    let positions = tris.into_iter().flatten().collect();
    let mesh = Mesh::new(positions, None, None, indices, None).map_err(|e| e.to_string())?;
    let scene = Scene::build(Vec::new(), vec![mesh]).map_err(|e| e.to_string())?;
    let any = rest.iter().any(|a| a == "--any");
    let mut hits = 0;
    let clock = || common::thread_cpu_seconds().ok_or("no thread CPU clock on this system");
    let t0 = clock()?;
    for _ in 0..passes {
        hits += if any {
            rays.iter().filter(|r| scene.occluded(std::hint::black_box(r), f32::INFINITY)).count()
        } else {
            rays.iter().filter(|r| scene.intersect(std::hint::black_box(r), f32::INFINITY).is_some()).count()
        };
    }
    let rate = (rays.len() * passes) as f64 / (clock()? - t0) / 1e6;
    println!("{name} {kind}{} {rate:.3} M/s over {passes} passes; {hits} hits", if any { " any" } else { "" });
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
