//! Project automation, run as `cargo xtask <command>` (the alias in
//! `.cargo/config.toml` builds this binary in release).
//!
//! Each command lives in its own module; `main` only parses the arguments and
//! dispatches. Commands:
//! - `gen-upsampling-table`: fit the RGB → spectrum coefficient table into `data/`.
//! - `upsampling-report`: round-trip error and speed of the upsampling over a dense sRGB grid.
//! - `validate`: the validation suite (colorimetry, analytic renders, hard cases, speed against error, `auto` on absorbing glass, scaling; `--only PART,…` for some of them).
//! - `paper`: the paper's figures 8–11 as side-by-side renders with their backing numbers.
//! - `exr-diff`: the largest difference between two EXR files (refactorings must move no number).
//! - `farm`: a render split into parts (separate processes or a Slurm job array), merged, and
//!   compared byte for byte with the single render.
//! - `modules`: the import graph among a crate's modules, and any circle in it.
//! - `gallery`: the third-party assets rendered with no flags: chosen integrator, camera, exposure, mean, clipping.

mod exr_diff;
mod farm;
mod gallery;
mod modules;
mod paper;
mod stats;
mod upsampling;
mod validate;

use std::path::PathBuf;

use clap::{Parser, Subcommand};

#[derive(Debug, Parser)]
#[command(name = "xtask", about = "spectrace project automation")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Fit the Jakob–Hanika RGB → spectrum coefficient table and write it to data/.
    GenUpsamplingTable(upsampling::GenTableArgs),
    /// Round-trip ΔE00 and timing of `upsample_reflectance` over a dense sRGB grid.
    UpsamplingReport(upsampling::ReportArgs),
    /// Render the paper's figures 8–11 (side-by-side pairs) with the numbers behind them.
    Paper(paper::PaperArgs),
    /// Render the validation suite, check every number against its tolerance, write a report.
    Validate(validate::ValidateArgs),
    /// The largest difference between two EXR files of the same layout.
    ExrDiff(exr_diff::ExrDiffArgs),
    /// Render in parts (`--engine local` processes or a `slurm` job array), merge, compare
    /// byte for byte with one render, and time it.
    Farm(farm::FarmArgs),
    /// Render the third-party assets with no flags and tabulate luminance and clipping (skips when absent).
    Gallery(gallery::GalleryArgs),
    /// The import graph among a crate's modules (default: integrator); fails on a circle.
    Modules(modules::ModulesArgs),
}

fn main() -> anyhow::Result<()> {
    match Cli::parse().command {
        Command::GenUpsamplingTable(args) => upsampling::gen_table(&args),
        Command::UpsamplingReport(args) => upsampling::report(&args),
        Command::Paper(args) => paper::run(&args),
        Command::Validate(args) => validate::run(&args),
        Command::ExrDiff(args) => exr_diff::run(&args),
        Command::Farm(args) => farm::run(&args),
        Command::Gallery(args) => gallery::run(&args),
        Command::Modules(args) => modules::run(&args),
    }
}

/// The workspace root (this crate lives in `<root>/xtask`).
fn project_root() -> PathBuf {
    let manifest_dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    manifest_dir.parent().map(PathBuf::from).unwrap_or(manifest_dir)
}
