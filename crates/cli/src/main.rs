//! `spectrace`: the command-line front end. Thin by design: argument parsing, progress
//! reporting and exit codes; everything else lives in the library crates.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

mod color;
mod info;
mod measure;
mod merge;
mod render;
mod view;

/// A spectral ray tracer: every ray carries a spectrum, not three RGB numbers.
///
/// Run `spectrace render` with no arguments to render the paper's five transparent spheres
/// (Lee, Lee, Lee & Ha 2004) to render.exr and render.png.
#[derive(Debug, Parser)]
#[command(name = "spectrace", version, about, long_about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

// One value per process, parsed once: boxing the large `render` arguments would buy nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Subcommand)]
enum Command {
    /// Render a scene (default: the paper's five spheres) to EXR and PNG.
    Render(render::RenderArgs),
    /// Merge the film files of a render's parts (`render --part K/M --film`) into its images,
    /// bit for bit those of the whole render.
    Merge(merge::MergeArgs),
    /// Print a JSON summary of a scene: geometry, materials, lights, and what it needs.
    Info(info::InfoArgs),
    /// Compute XYZ, chromaticity and sRGB of spectra in a CSV file.
    Color(color::ColorArgs),
    /// Measure the illuminance (lux) at sensor points of a scene, with its standard error.
    Measure(measure::MeasureArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => render::run(&args),
        Command::Merge(args) => merge::run(&args),
        Command::Info(args) => info::run(&args),
        Command::Color(args) => color::run(&args),
        Command::Measure(args) => measure::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("spectrace: error: {error:#}");
            ExitCode::FAILURE
        }
    }
}

/// Write `text` to standard output. A reader that stops early (`spectrace info … | head`) closes
/// the pipe: that ends the output, it is not an error (`print!` would panic on it).
pub(crate) fn write_stdout(text: &str) -> anyhow::Result<()> {
    use std::io::Write as _;
    match std::io::stdout().lock().write_all(text.as_bytes()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => Ok(other?),
    }
}
