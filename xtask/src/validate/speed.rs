//! Speed against error: each spectral strategy's error against a converged or analytic
//! reference versus wall time, tabled and plotted log–log (one PNG per scene).
//!
//! - The paper's model on the default scene: deterministic, one point per strategy; the
//!   reference is bins:95 (the 5 nm grid, the paper's own sampling).
//! - The path tracer on the scenes of [`PATH_CASES`], at increasing spp, against a converged
//!   render cached by [`super::refs`]. **To add a reference scene, add a [`PathCase`].**
//! - The path tracer on the ColorChecker under D65 and F11, against the analytic patch colours.

use super::refs::RefCache;
use super::*;

/// One point of a speed-against-error curve.
struct Point {
    strategy: String,
    spp: u32,
    seconds: f64,
    mean_de: f64,
    p95_de: f64,
    rel_mse: f64,
}

impl Point {
    /// A measured render: `auto` is labelled with the strategy it chose.
    fn new(label: &str, mode: SpectralMode, stats: &integrator::RenderStats, de: &[f64], rel_mse: f64) -> Self {
        let strategy = if mode == SpectralMode::Auto { format!("auto ({})", stats.spectral) } else { label.into() };
        Self {
            strategy,
            spp: stats.spp,
            seconds: stats.elapsed.as_secs_f64(),
            mean_de: mean(de),
            p95_de: p95(de),
            rel_mse,
        }
    }
}

/// A labelled strategy: the `--spectral` mode and, for hero sampling, the wavelength pdf.
type Strategy = (&'static str, SpectralMode, WavelengthPdf);

/// Every strategy the path tracer offers, in the order of the tables and plots.
const PATH_STRATEGIES: &[Strategy] = &[
    ("rgb", SpectralMode::Rgb, WavelengthPdf::Visible),
    ("bins:8", SpectralMode::Bins(8), WavelengthPdf::Visible),
    ("bins:16", SpectralMode::Bins(16), WavelengthPdf::Visible),
    ("bins:32", SpectralMode::Bins(32), WavelengthPdf::Visible),
    ("bins:95", SpectralMode::Bins(95), WavelengthPdf::Visible),
    ("hero:4 visible", SpectralMode::Hero { count: 4 }, WavelengthPdf::Visible),
    ("hero:8 visible", SpectralMode::Hero { count: 8 }, WavelengthPdf::Visible),
    ("hero:8 illuminant", SpectralMode::Hero { count: 8 }, WavelengthPdf::Illuminant),
    ("auto", SpectralMode::Auto, WavelengthPdf::Illuminant),
];

/// A scene for the path tracer's speed-against-error curves, against a converged reference.
struct PathCase {
    /// Under `scenes/`.
    file: &'static str,
    /// Image size of the full run and of `--quick`.
    size: (u32, u32),
    quick_size: (u32, u32),
    /// The spp of the curve's points (full run, `--quick`).
    spps: &'static [u32],
    quick_spps: &'static [u32],
    strategies: &'static [Strategy],
    /// The converged reference: bins:95 (fixed 5 nm grid: no colour noise, and within 0.1
    /// ΔE00 of the 1 nm integral on the ColorChecker under every CIE illuminant checked in the
    /// colorimetry section) at `reference_spp` (full) or `quick_reference_spp`.
    reference_spp: u32,
    quick_reference_spp: u32,
}

/// The reference scenes with no analytic answer (the analytic ones, ColorChecker, slab and
/// furnace, are checked against their closed forms instead). The reference has 16× (full) or
/// 64× (quick) the spp of the curve's last point, so its own noise adds at most 1/16 of the
/// last point's MSE.
const PATH_CASES: &[PathCase] = &[
    PathCase {
        file: "reference/cornell_box.json",
        size: (64, 64),
        quick_size: (16, 16),
        spps: &[1, 4, 16, 64, 256],
        quick_spps: &[1, 4, 16],
        strategies: PATH_STRATEGIES,
        reference_spp: 4096,
        quick_reference_spp: 1024,
    },
    PathCase {
        file: "paper/five_spheres.json",
        size: (80, 60),
        quick_size: (20, 15),
        spps: &[1, 4, 16, 64, 256],
        quick_spps: &[1, 4, 16],
        strategies: PATH_STRATEGIES,
        reference_spp: 4096,
        quick_reference_spp: 1024,
    },
];

pub(crate) fn speed_vs_error(
    report: &mut Report,
    root: &Path,
    out: &Path,
    refs: &RefCache,
    quick: bool,
) -> anyhow::Result<()> {
    let mut md = String::from(
        "## Speed against error\n\nError against wall time (all cores) for each spectral strategy: ΔE00 \
         (CIELAB relative to the D65 white at Y = 1) mean and 95th percentile over the pixels, and the \
         relative MSE (mean of (x − r)² / (r² + 0.01) over pixels and XYZ channels). Timings are of one \
         render each on a shared machine: read them to within ±20 %.\n\n",
    );
    whitted_default(report, out, &mut md, quick)?;
    for case in PATH_CASES {
        path_case(report, root, out, refs, case, quick, &mut md)?;
    }
    charts(report, root, out, quick, &mut md)?;
    report.sections.push_str(&md);
    Ok(())
}

/// The paper's model on the default scene: reference bins:95 (converged for this model: its
/// result is exact for the 5 nm grid; there is no Monte Carlo noise).
fn whitted_default(report: &mut Report, out: &Path, md: &mut String, quick: bool) -> anyhow::Result<()> {
    let five = RenderScene::default_scene()?;
    let size = if quick { (160, 120) } else { (640, 480) };
    let base = RenderOptions { width: size.0, height: size.1, ..RenderOptions::default() };
    let (reference, _) = render(&five, &RenderOptions { spectral: SpectralMode::Bins(95), ..base.clone() })?;
    let mut points = Vec::new();
    for mode in [
        SpectralMode::Rgb,
        SpectralMode::Bins(8),
        SpectralMode::Bins(16),
        SpectralMode::Bins(32),
        SpectralMode::Bins(95),
        SpectralMode::Auto,
    ] {
        let (image, stats) = render(&five, &RenderOptions { spectral: mode, ..base.clone() })?;
        let de = delta_e_all(image.pixels(), reference.pixels());
        let label = mode.to_string();
        points.push(Point::new(&label, mode, &stats, &de, relative_mse(image.pixels(), reference.pixels())));
    }
    writeln!(
        md,
        "### The paper's five spheres, whitted-hall, {}×{} (reference: bins:95, converged — the model is \
         deterministic)\n",
        size.0, size.1
    )?;
    table(md, &points);
    fastest(md, &points)?;
    plot_section(md, out, "speed_vs_error_default_whitted.png", &points)?;
    // auto picks the fewest bins whose error is negligible for smooth spectra: within 0.5 ΔE00
    // mean (half a just-noticeable difference) of the 5 nm grid.
    let auto = points.iter().find(|p| p.strategy.starts_with("auto")).map_or(f64::INFINITY, |p| p.mean_de);
    report.check(
        "speed vs error",
        "default scene (whitted-hall): auto within ΔE00 0.5 of bins:95 (mean)",
        format!("{auto:.3}"),
        "< 0.5 (half a JND)".into(),
        "converged",
        auto < 0.5,
    );
    Ok(())
}

fn path_case(
    report: &mut Report,
    root: &Path,
    out: &Path,
    refs: &RefCache,
    case: &PathCase,
    quick: bool,
    md: &mut String,
) -> anyhow::Result<()> {
    let scene = load_scene(root, case.file)?;
    let (w, h) = if quick { case.quick_size } else { case.size };
    let spps = if quick { case.quick_spps } else { case.spps };
    let ref_spp = if quick { case.quick_reference_spp } else { case.reference_spp };
    let key = format!("{} path bins-95 {w}x{h} {ref_spp}spp seed1 sobol-blocks", case.file);
    let mut nonfinite = 0;
    let reference = refs.get(&key, (w, h), || {
        let (image, stats) = render(&scene, &path_options(w, h, SpectralMode::Bins(95), ref_spp))?;
        anyhow::ensure!(
            stats.nonfinite_samples == 0,
            "reference {key}: {} non-finite samples",
            stats.nonfinite_samples
        );
        Ok(image)
    })?;
    let mut points = Vec::new();
    for (label, mode, pdf) in case.strategies {
        for &spp in spps {
            // Seed 2: independent of the reference's seed 1.
            let options = independent(RenderOptions { seed: 2, ..path_options(w, h, *mode, spp) })
                .path(|p| p.wavelength_pdf = *pdf);
            let (image, stats) = render(&scene, &options)?;
            nonfinite += stats.nonfinite_samples;
            let de = delta_e_all(image.pixels(), &reference.pixels);
            points.push(Point::new(label, *mode, &stats, &de, relative_mse(image.pixels(), &reference.pixels)));
        }
    }
    let origin = match reference.rendered_in {
        Some(s) => format!("rendered this run in {s:.1} s"),
        None => "cached".to_owned(),
    };
    writeln!(
        md,
        "### {} (path tracer, {w}×{h}; reference: bins:95 at {ref_spp} spp, converged, {origin}: `{}`)\n",
        case.file,
        reference.path.display()
    )?;
    table(md, &points);
    fastest(md, &points)?;
    let stem = case.file.trim_end_matches(".json").replace('/', "_");
    plot_section(md, out, &format!("speed_vs_error_{stem}.png"), &points)?;
    report.check(
        "speed vs error",
        format!("{}: every path render finite", case.file),
        format!("{nonfinite} NaN/Inf"),
        "0".into(),
        "analytic",
        nonfinite == 0,
    );
    // Unbiased with finite variance: MSE(s) ≈ σ²/s + σ²/R (R the reference's spp), so from the
    // first to the last spp it falls by E = (1/s₀ + 1/R) / (1/s₁ + 1/R). The measured ratio is
    // itself a noisy estimate (caustic paths are heavy-tailed): it must reach E/4.
    let (s0, s1) = (spps[0], spps[spps.len() - 1]);
    let expected = (1.0 / f64::from(s0) + 1.0 / f64::from(ref_spp)) / (1.0 / f64::from(s1) + 1.0 / f64::from(ref_spp));
    let mse_at = |spp: u32| points.iter().find(|p| p.strategy == "bins:95" && p.spp == spp).map(|p| p.rel_mse);
    if let (Some(first), Some(last)) = (mse_at(s0), mse_at(s1)) {
        let ratio = first / last.max(1e-30);
        report.check(
            "speed vs error",
            format!("{}: bins:95 relative MSE falls as 1/spp ({s0} → {s1} spp)", case.file),
            format!("÷{ratio:.1}"),
            format!("≥ ÷{:.1} (E/4, E = {expected:.1})", expected / 4.0),
            "converged",
            ratio >= expected / 4.0,
        );
    }
    Ok(())
}

/// The path tracer on the ColorChecker under D65 and F11: analytic reference per pixel.
fn charts(report: &mut Report, root: &Path, out: &Path, quick: bool, md: &mut String) -> anyhow::Result<()> {
    for (file, illuminant) in [("colorchecker_d65.json", Illuminant::D65), ("colorchecker_f11.json", Illuminant::F11)] {
        let chart = RenderScene::load(&root.join("scenes/reference").join(file))?;
        let (reference, white) = chart_reference(illuminant);
        let (w, h) = (60, 40);
        let spps: &[u32] = if quick { &[4, 16] } else { &[4, 16, 64, 256] };
        let mut points = Vec::new();
        for (label, mode, pdf) in PATH_STRATEGIES {
            for &spp in spps {
                let options = independent(path_options(w, h, *mode, spp)).path(|p| p.wavelength_pdf = *pdf);
                let (image, stats) = render(&chart, &options)?;
                let de = chart_errors(&image, &reference, white);
                points.push(Point::new(label, *mode, &stats, &de, chart_relative_mse(&image, &reference)));
            }
        }
        writeln!(md, "### ColorChecker under {} (path tracer, {w}×{h}, reference: analytic)\n", illuminant.name())?;
        table(md, &points);
        fastest(md, &points)?;
        plot_section(md, out, &format!("speed_vs_error_{}.png", illuminant.name()), &points)?;
        let best = |prefix: &str| {
            points.iter().filter(|p| p.strategy.starts_with(prefix)).map(|p| p.mean_de).fold(f64::INFINITY, f64::min)
        };
        if illuminant == Illuminant::F11 {
            // Where RGB is wrong: under a line spectrum RGB cannot be right at any spp (it has
            // no noise on flat patches: its error is all bias). More than one JND.
            let rgb = best("rgb");
            report.check(
                "speed vs error",
                "F11 chart: RGB error stays above 1 ΔE00 (RGB is wrong here)",
                format!("{rgb:.2}"),
                "> 1".into(),
                "analytic",
                rgb > 1.0,
            );
        }
        let auto = best("auto");
        report.check(
            "speed vs error",
            format!("{} chart: auto reaches mean ΔE00 < 0.5", illuminant.name()),
            format!("{auto:.3}"),
            "< 0.5 (half a JND)".into(),
            "analytic",
            auto < 0.5,
        );
    }
    Ok(())
}

fn table(md: &mut String, points: &[Point]) {
    md.push_str(
        "| strategy | spp | time (ms) | ΔE00 mean | ΔE00 p95 | rel. MSE |\n| --- | --- | --- | --- | --- | --- |\n",
    );
    for p in points {
        let _ = writeln!(
            md,
            "| {} | {} | {:.2} | {:.3} | {:.3} | {:.2e} |",
            p.strategy,
            p.spp,
            p.seconds * 1e3,
            p.mean_de,
            p.p95_de,
            p.rel_mse
        );
    }
    md.push('\n');
}

/// The strategy and spp that reach mean ΔE00 < 1 (one JND) in the least wall time.
fn fastest(md: &mut String, points: &[Point]) -> anyhow::Result<()> {
    let best = points.iter().filter(|p| p.mean_de < 1.0).min_by(|a, b| a.seconds.total_cmp(&b.seconds));
    writeln!(
        md,
        "**Fastest to mean ΔE00 < 1:** {}\n",
        best.map_or("none of these".into(), |p| format!("{} at {} spp, {:.2} ms", p.strategy, p.spp, p.seconds * 1e3))
    )?;
    Ok(())
}

/// Named colours of the plot lines, in strategy order.
pub(crate) const PALETTE: [(&str, (u8, u8, u8)); 10] = [
    ("red", (220, 0, 0)),
    ("orange", (255, 140, 0)),
    ("olive", (128, 128, 0)),
    ("green", (0, 170, 0)),
    ("cyan", (0, 190, 190)),
    ("blue", (0, 0, 230)),
    ("magenta", (220, 0, 220)),
    ("black", (0, 0, 0)),
    ("grey", (140, 140, 140)),
    ("brown", (140, 70, 20)),
];

fn plot_section(md: &mut String, out: &Path, file: &str, points: &[Point]) -> anyhow::Result<()> {
    let strategies = plot(&out.join(file), points)?;
    let legend: Vec<String> =
        strategies.iter().zip(PALETTE.iter().cycle()).map(|(s, (colour, _))| format!("{s} {colour}")).collect();
    writeln!(
        md,
        "![speed vs error]({file})\n\nx: wall time (s, log), y: mean ΔE00 (log), grid lines at decades; one \
         polyline per strategy (points at increasing spp): {}.\n",
        legend.join(", ")
    )?;
    Ok(())
}

/// Draw the log–log plot of mean ΔE00 against wall time; returns the strategies in the order
/// of their colours.
fn plot(path: &Path, points: &[Point]) -> anyhow::Result<Vec<String>> {
    let mut strategies: Vec<String> = Vec::new();
    for p in points {
        if !strategies.contains(&p.strategy) {
            strategies.push(p.strategy.clone());
        }
    }
    let series: Vec<Vec<(f64, f64)>> = strategies
        .iter()
        .map(|s| points.iter().filter(|p| p.strategy == *s).map(|p| (p.seconds, p.mean_de)).collect())
        .collect();
    plot_loglog(path, &series, Some(1.0))?;
    Ok(strategies)
}

/// A log–log plot of polylines (colours in [`PALETTE`] order), decade grid lines, and an
/// optional darker horizontal line at `mark` (ΔE00 = 1, one JND). No text: the report's
/// caption names the axes and the colours (plotters' text needs a font file).
pub(crate) fn plot_loglog(path: &Path, series: &[Vec<(f64, f64)>], mark: Option<f64>) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let plot_err = |e: DrawingAreaErrorKind<_>| anyhow::anyhow!("plotting {}: {e}", path.display());
    let (w, h) = (640u32, 480u32);
    let all = || series.iter().flatten().filter(|(x, y)| *x > 0.0 && *y > 0.0);
    let x_min = all().map(|p| p.0).fold(f64::INFINITY, f64::min).max(1e-9).log10().floor();
    let x_max = all().map(|p| p.0).fold(0.0, f64::max).max(1e-9).log10().ceil().max(x_min + 1.0);
    let y_min = all().map(|p| p.1).fold(f64::INFINITY, f64::min).max(1e-6).log10().floor();
    let y_max = all().map(|p| p.1).fold(0.0, f64::max).max(1e-6).log10().ceil().max(y_min + 1.0);
    let mut buffer = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buffer, (w, h)).into_drawing_area();
        root.fill(&RGBColor(255, 255, 255)).map_err(plot_err)?;
        let map = |x: f64, y: f64| {
            let px = 20.0 + (x.max(1e-12).log10() - x_min) / (x_max - x_min) * f64::from(w - 40);
            let py = f64::from(h) - 20.0 - (y.max(1e-12).log10() - y_min) / (y_max - y_min) * f64::from(h - 40);
            (px as i32, py as i32)
        };
        let grey = RGBColor(220, 220, 220);
        for d in x_min as i32..=x_max as i32 {
            let (x, _) = map(10f64.powi(d), 1.0);
            root.draw(&PathElement::new(vec![(x, 0), (x, h as i32)], grey)).map_err(plot_err)?;
        }
        for d in y_min as i32..=y_max as i32 {
            let (_, y) = map(1.0, 10f64.powi(d));
            root.draw(&PathElement::new(vec![(0, y), (w as i32, y)], grey)).map_err(plot_err)?;
        }
        if let Some(m) = mark {
            let (_, y) = map(1.0, m);
            root.draw(&PathElement::new(vec![(0, y), (w as i32, y)], RGBColor(150, 150, 150).stroke_width(2)))
                .map_err(plot_err)?;
        }
        for (line, (_, (r, g, b))) in series.iter().zip(PALETTE.iter().cycle()) {
            let color = RGBColor(*r, *g, *b);
            let line: Vec<(i32, i32)> =
                line.iter().filter(|(x, y)| *x > 0.0 && *y > 0.0).map(|(x, y)| map(*x, *y)).collect();
            root.draw(&PathElement::new(line.clone(), color.stroke_width(2))).map_err(plot_err)?;
            for pt in line {
                root.draw(&Circle::new(pt, 4, color.filled())).map_err(plot_err)?;
            }
        }
        root.present().map_err(plot_err)?;
    }
    // plotters' bitmap backend draws into memory; the image crate writes the PNG.
    image::save_buffer(path, &buffer, w, h, image::ExtendedColorType::Rgb8)
        .with_context(|| format!("writing {}", path.display()))
}
