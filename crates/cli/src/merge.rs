//! `spectrace merge`: the films of a render's parts into its images.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context as _;
use integrator::{Display, FilmFile, OutputPlan};

/// Arguments of `spectrace merge`.
#[derive(Debug, clap::Args)]
pub(crate) struct MergeArgs {
    /// The parts' film files (`spectrace render --part K/M --film PART.film`), in any order.
    #[arg(required = true, value_name = "PART.film")]
    parts: Vec<PathBuf>,
    /// Output EXR (linear RGB); a display-encoded PNG of the same name is written beside it.
    #[arg(short, long, value_name = "OUT.exr")]
    output: Option<PathBuf>,
    /// Also write the spectral OpenEXR (the parts need per-wavelength sums: rendered with
    /// --spectral-film).
    #[arg(long, value_name = "FILE.exr")]
    spectral_exr: Option<PathBuf>,
    /// Also write an EXR of per-pixel statistics: variance of the mean luminance
    /// (`Y.variance`), relative error √variance / Y (`Y.relativeError`) and samples (`spp`).
    #[arg(long, value_name = "FILE.exr")]
    variance: Option<PathBuf>,
    /// Also write each pixel's estimated colour error (the parts need half-film sums: rendered
    /// with --error-map): ΔE00 per pixel and per 8×8 tile, and the samples.
    #[arg(long, value_name = "FILE.exr")]
    error_map: Option<PathBuf>,
    /// Write the merged film too (it merges further: a tree of merges for many parts).
    #[arg(long, value_name = "FILE.film")]
    film: Option<PathBuf>,
    /// Write the images even if samples are missing (a part not rendered or interrupted);
    /// each pixel averages the samples it has (the `spp` channel of --variance says how many).
    #[arg(long)]
    allow_gaps: bool,
    /// Output display: `srgb` or `paper9300`.
    #[arg(long, default_value = "srgb")]
    display: Display,
    /// No summary on stderr.
    #[arg(short, long)]
    quiet: bool,
}

pub(crate) fn run(args: &MergeArgs) -> anyhow::Result<()> {
    if args.output.is_none() && args.film.is_none() {
        anyhow::bail!("nothing to write: give -o OUT.exr and/or --film OUT.film");
    }
    if (args.spectral_exr.is_some() || args.variance.is_some() || args.error_map.is_some()) && args.output.is_none() {
        anyhow::bail!("--spectral-exr, --variance and --error-map go with -o OUT.exr");
    }
    // The same plan as the render's: its view comes from the parts' headers, below.
    let mut plan = OutputPlan::new(
        args.output.as_deref(),
        args.display,
        args.spectral_exr.as_deref(),
        args.variance.as_deref(),
        integrator::ViewPlan::default(),
    )?;
    if let Some(path) = &args.error_map {
        plan.add_error_map(path)?;
    }
    if let Some(film) = &args.film {
        crate::render::check_film_extension("--film", film)?;
    }
    let mut paths: Vec<&std::path::Path> = plan.outputs.iter().map(|o| o.path.as_path()).collect();
    paths.extend(args.film.as_deref());
    // Before reading a part: no output on a part (it would be replaced) or on another output.
    let parts: Vec<(&std::path::Path, &str)> = args.parts.iter().map(|p| (p.as_path(), "the part")).collect();
    integrator::check_outputs_spare_inputs(&paths, &parts)?;

    let start = Instant::now();
    // One part at a time: only the sum and the part being added are in memory.
    let mut merger = integrator::Merger::new();
    let (mut read, mut merge) = (std::time::Duration::ZERO, std::time::Duration::ZERO);
    for path in &args.parts {
        let t = Instant::now();
        let part = FilmFile::read(path)?;
        read += t.elapsed();
        let t = Instant::now();
        merger.add(path.clone(), part)?;
        merge += t.elapsed();
    }
    let bytes_read: u64 = args.parts.iter().filter_map(|p| std::fs::metadata(p).ok()).map(|m| m.len()).sum();
    let merged = merger.finish()?;
    if !merged.is_complete() {
        let gaps = merged.gaps().join("\n  ");
        if !args.allow_gaps {
            anyhow::bail!("the parts do not make the whole render:\n  {gaps}\n(--allow-gaps writes the images anyway)");
        }
        if !args.quiet {
            eprintln!("spectrace: warning: the parts do not make the whole render:\n  {gaps}");
        }
    }
    let file = &merged.file;
    // As `render` does: the parts' non-finite samples were added as black.
    let samples = file.film.sample_counts().iter().map(|&c| u64::from(c)).sum();
    match integrator::nonfinite_verdict(file.film.nonfinite_samples(), samples) {
        integrator::NonfiniteVerdict::Clean => {}
        integrator::NonfiniteVerdict::Warn(message) => eprintln!("spectrace: warning: {message}"),
        integrator::NonfiniteVerdict::Refuse(message) => anyhow::bail!("{message}; nothing was written"),
    }
    if args.spectral_exr.is_some() && file.film.wavelengths().is_empty() {
        anyhow::bail!(
            "--spectral-exr: the films have no per-wavelength sums (render the parts with --spectral-film and bins:N)"
        );
    }
    if let Some(path) = &args.film {
        file.write(path).context("writing the merged film")?;
    }
    if !plan.outputs.is_empty() {
        plan.view =
            file.header.view.parse().with_context(|| format!("{}: the film's view", args.parts[0].display()))?;
        if args.error_map.is_some() && !file.film.has_halves() {
            anyhow::bail!(
                "--error-map: the films have no half-film sums (render the parts with --error-map, or to a target error)"
            );
        }
        let (image, _) = plan.develop(&file.film, file.header.samples.start);
        plan.write(&image).context("writing the outputs (none was written)")?;
    }
    let write = start.elapsed().saturating_sub(read + merge);
    if !args.quiet {
        let mut written: Vec<String> = plan.outputs.iter().map(|o| o.path.display().to_string()).collect();
        written.extend(args.film.iter().map(|p| p.display().to_string()));
        let h = &file.header;
        eprintln!(
            "spectrace: merged {} parts ({:.1} MB): {}x{} {} samples {}..{} of {} spp, {}..={} per pixel; \
             read {:.3} s, merge {:.3} s, write {:.3} s -> {}",
            args.parts.len(),
            bytes_read as f64 / 1e6,
            file.film.width(),
            file.film.height(),
            h.spectral,
            h.samples.start,
            h.samples.end,
            h.spp,
            file.film.min_sample_count(),
            file.film.max_sample_count(),
            read.as_secs_f64(),
            merge.as_secs_f64(),
            write.as_secs_f64(),
            written.join(", ")
        );
    }
    Ok(())
}
