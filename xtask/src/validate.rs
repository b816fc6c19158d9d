//! `cargo xtask validate`: renders the validation suite, checks every number against its
//! expected value with a stated tolerance, and writes `OUT/report.md` with plots beside it.
//! Exits non-zero if any check fails; the last line is `N passed, N failed`.
//!
//! Expected values are analytic (or published) wherever one exists; otherwise the reference is
//! the project's own converged render (cached by [`refs`]), named as such in the report.
//!
//! One submodule per category: [`colorimetry`], [`analytic`], [`hard`], [`caustics`], [`speed`] (speed
//! against error; its `PATH_CASES` list is where new reference scenes plug in) and
//! [`scaling`]; the paper's figures come from `crate::paper`.

mod absorbing;
mod analytic;
mod auto_time;
mod caustics;
mod cie171;
mod colorimetry;
mod estimate;
mod hard;
mod refs;
mod sampler;
mod scaling;
mod speed;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use ::colorimetry::{
    DenselySampledSpectrum, Illuminant, Integration, Lab, Observer, Rgb, RgbColorSpace, Xyz, colorchecker,
    delta_e_2000, reflectance_to_xyz, upsample_reflectance,
};
use anyhow::Context as _;
use integrator::{
    Ambient, Image, Integrator, PathOptions, RenderOptions, RenderScene, SamplerKind, SpectralMode, WavelengthPdf,
};

use crate::stats::{WHITE, delta_e_all, mean, p95, xyz_of};

/// Arguments of `cargo xtask validate`.
#[derive(Debug, clap::Args)]
pub(crate) struct ValidateArgs {
    /// A subset at small sizes that runs in well under two minutes on two cores (CI).
    #[arg(long)]
    quick: bool,
    /// Output folder for report.md and the plots.
    #[arg(long, default_value = "target/validate")]
    out: PathBuf,
    /// Folder of the cached converged references (rendered when missing or stale).
    #[arg(long, default_value = "target/validate-refs")]
    refs: PathBuf,
    /// Render every converged reference again, ignoring the cache.
    #[arg(long)]
    regen: bool,
    /// Run only these parts (comma-separated): colorimetry, analytic, hard, caustics, speed, absorbing,
    /// auto, sampler, estimate, cie171, paper, scaling. The report then holds only their checks.
    #[arg(long, value_delimiter = ',')]
    only: Vec<String>,
}

/// One check: what was measured, against what, with which tolerance.
struct Check {
    category: &'static str,
    name: String,
    measured: String,
    tolerance: String,
    reference: &'static str,
    pass: bool,
}

#[derive(Default)]
struct Report {
    checks: Vec<Check>,
    sections: String,
}

impl Report {
    fn check(
        &mut self,
        category: &'static str,
        name: impl Into<String>,
        measured: String,
        tolerance: String,
        reference: &'static str,
        pass: bool,
    ) {
        let name = name.into();
        println!("{} {category}: {name}: {measured} ({tolerance})", if pass { "ok  " } else { "FAIL" });
        self.checks.push(Check { category, name, measured, tolerance, reference, pass });
    }
}

/// The parts `--only` may name, in the order they run.
const PARTS: [&str; 12] = [
    "colorimetry",
    "analytic",
    "hard",
    "caustics",
    "speed",
    "absorbing",
    "auto",
    "sampler",
    "estimate",
    "cie171",
    "paper",
    "scaling",
];

pub(crate) fn run(args: &ValidateArgs) -> anyhow::Result<()> {
    let root = crate::project_root();
    let absolute = |p: &Path| if p.is_absolute() { p.to_path_buf() } else { root.join(p) };
    let out = absolute(&args.out);
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let refs = refs::RefCache::new(absolute(&args.refs), args.regen)?;
    let start = Instant::now();
    let mut report = Report::default();
    let mut durations = Vec::new();
    let mut step = |name: &str, since: &mut Instant| {
        durations.push((name.to_owned(), since.elapsed().as_secs_f64()));
        *since = Instant::now();
    };
    let mut since = Instant::now();
    let wanted = |part: &str| args.only.is_empty() || args.only.iter().any(|p| p == part);
    if let Some(unknown) = args.only.iter().find(|p| !PARTS.contains(&p.as_str())) {
        anyhow::bail!("--only {unknown}: expected some of {}", PARTS.join(", "));
    }
    if wanted("colorimetry") {
        colorimetry::checks(&mut report, args.quick);
        step("colorimetry", &mut since);
    }
    if wanted("analytic") {
        analytic::whitted_checks(&mut report)?;
        analytic::path_checks(&mut report, &root, args.quick)?;
        step("analytic renders", &mut since);
    }
    if wanted("hard") {
        hard::checks(&mut report, &out, args.quick)?;
        step("hard cases", &mut since);
    }
    if wanted("caustics") {
        caustics::checks(&mut report, &root, args.quick)?;
        step("caustics", &mut since);
    }
    if wanted("speed") {
        speed::speed_vs_error(&mut report, &root, &out, &refs, args.quick)?;
        step("speed against error", &mut since);
    }
    if wanted("absorbing") {
        absorbing::checks(&mut report, &root, &refs, args.quick)?;
        step("auto on absorbing glass", &mut since);
    }
    if wanted("auto") {
        auto_time::checks(&mut report, &root, &refs, args.quick)?;
        step("auto by time to error", &mut since);
    }
    if wanted("sampler") {
        sampler::checks(&mut report, &root, &refs, args.quick)?;
        step("Sobol' points against independent numbers", &mut since);
    }
    if wanted("estimate") {
        estimate::checks(&mut report, &root, &refs, args.quick)?;
        step("the error estimate against the true error", &mut since);
    }
    if wanted("cie171") {
        cie171::checks(&mut report, &root, args.quick)?;
        step("CIE 171 analytic cases", &mut since);
    }
    if wanted("paper") {
        paper(&mut report, &out, args.quick);
        step("the paper's figures", &mut since);
    }
    if wanted("scaling") {
        scaling::scaling(&mut report, &out, args.quick)?;
        step("scaling", &mut since);
    }

    let (passed, failed) =
        (report.checks.iter().filter(|c| c.pass).count(), report.checks.iter().filter(|c| !c.pass).count());
    let mut md = String::new();
    writeln!(md, "# spectrace validation report\n")?;
    writeln!(
        md,
        "`cargo xtask validate{}` — {passed} passed, {failed} failed, {:.1} s. Machine: {} cores. \
         Reference kinds: *analytic* (closed form), *published* (CIE 015, IEC 61966-2-1), *converged* (the \
         project's own high-sample render).\n",
        if args.quick { " --quick" } else { "" },
        start.elapsed().as_secs_f64(),
        std::thread::available_parallelism().map_or(1, |n| n.get())
    )?;
    writeln!(md, "| | category | check | measured | tolerance | reference |\n| --- | --- | --- | --- | --- | --- |")?;
    for c in &report.checks {
        writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} |",
            if c.pass { "✓" } else { "✗" },
            c.category,
            c.name,
            c.measured,
            c.tolerance,
            c.reference
        )?;
    }
    md.push('\n');
    md.push_str(&report.sections);
    md.push_str("## Durations\n\n| part | wall time (s) |\n| --- | --- |\n");
    for (name, seconds) in &durations {
        writeln!(md, "| {name} | {seconds:.1} |")?;
    }
    let path = out.join("report.md");
    std::fs::write(&path, md).with_context(|| format!("writing {}", path.display()))?;
    println!("report: {}", path.display());
    println!("{passed} passed, {failed} failed");
    if failed > 0 {
        anyhow::bail!("{failed} validation checks failed");
    }
    Ok(())
}

/// The paper's figures 8–11 as `cargo xtask paper` renders them, into `OUT/paper/`, with its
/// table of backing numbers copied into the report. A render that fails (or has a non-finite
/// sample, which `paper` treats as an error) is a failed check, not an abort.
fn paper(report: &mut Report, out: &Path, quick: bool) {
    let (w, h) = if quick { (160, 120) } else { (640, 480) };
    let paper_out = out.join("paper");
    let result = crate::paper::run(&crate::paper::PaperArgs { out: paper_out.clone(), width: w, height: h })
        .and_then(|()| Ok(std::fs::read_to_string(paper_out.join("paper.md"))?));
    let (measured, pass) = match &result {
        Ok(_) => ("0 non-finite samples".to_owned(), true),
        Err(e) => (format!("error: {e:#}"), false),
    };
    report.check(
        "paper",
        format!("figures 8–11 rendered at {w}×{h}"),
        measured,
        "renders complete, 0 non-finite".into(),
        "analytic",
        pass,
    );
    report.sections.push_str("## The paper's figures (from `cargo xtask paper`)\n\n");
    report.sections.push_str("Side-by-side pairs and the images: [paper/paper.md](paper/paper.md).\n\n");
    if let Ok(text) = result {
        // The numbers, without the images (paper.md's own headings one level down).
        let numbers = text.split("\n## Fig").next().unwrap_or("");
        for line in numbers.lines().skip_while(|l| l.starts_with("# ")) {
            let line = if line.starts_with("## ") { format!("#{line}") } else { line.to_owned() };
            report.sections.push_str(&line);
            report.sections.push('\n');
        }
        report.sections.push('\n');
    }
}

fn white_xyz(illuminant: &DenselySampledSpectrum, integration: &Integration) -> Xyz {
    reflectance_to_xyz(&DenselySampledSpectrum::constant(1.0), illuminant, Observer::Cie1931, integration)
}

fn scene(json: &str) -> anyhow::Result<RenderScene> {
    scene_in(json, Path::new("."))
}

/// A manifest whose relative file names resolve against `dir`.
fn scene_in(json: &str, dir: &Path) -> anyhow::Result<RenderScene> {
    Ok(RenderScene::from_description(geometry::parse_manifest(json, dir, "<validate>")?)?)
}

/// The scene `file` under the project's `scenes/`, assembled; an error names the file.
fn load_scene(root: &Path, file: &str) -> anyhow::Result<RenderScene> {
    let path = root.join("scenes").join(file);
    RenderScene::load(&path).with_context(|| format!("loading {}", path.display()))
}

fn render(scene: &RenderScene, options: &RenderOptions) -> anyhow::Result<(Image, integrator::RenderStats)> {
    Ok(integrator::render(scene, options, &|_| {}, &AtomicBool::new(false))?)
}

/// Clear glass (k_t = 1, T_s = 1, no reflection or diffuse term) before a white background
/// (Y = 1): whatever reaches the camera is the background times t^b, so answers are exact.
/// The light is equal-energy like the background: with one emitter spectrum the wavelength
/// lanes are calibrated to it, and the background's Y is exact at any bin count.
pub(crate) fn clear_sphere(camera: &str, ior: f32, per_unit: f64, radius: f32) -> String {
    format!(
        r#"{{ "camera": {camera},
        "lights": [{{"type": "point", "position": [5, 5, 10], "spectrum": "E", "intensity": 150}}],
        "background": {{"spectrum": "E", "intensity": 1}},
        "materials": {{"glass": {{"diffuse": 0, "ks": 0, "transmission": 1, "transmittance": 1, "ior": {ior}, "absorption": {{"per_unit": {per_unit}}}}}}},
        "objects": [{{"type": "sphere", "center": [0, 0, 0], "radius": {radius}, "material": "glass"}}] }}"#
    )
}

/// A clear slab of index 1 (k_t = 1, T_s = 1) keeping `per_unit` per unit thickness,
/// `thickness` thick, its front face the square of half-size `half` at z = 0, before the same
/// equal-energy background: a pixel looking through it sees Y = per_unit^b, b the path inside.
pub(crate) fn clear_slab(camera: &str, half: f64, per_unit: f64, thickness: f64) -> String {
    let size = 2.0 * half;
    format!(
        r#"{{ "camera": {camera},
        "lights": [{{"type": "point", "position": [0, 0, 50], "intensity": 0}}],
        "background": {{"spectrum": "E", "intensity": 1}},
        "materials": {{"glass": {{"diffuse": 0, "ks": 0, "transmission": 1, "transmittance": 1, "ior": 1.0, "absorption": {{"per_unit": {per_unit}}}}}}},
        "objects": [
          {{"type": "quad", "corner": [-{half}, -{half}, 0], "edge_u": [{size}, 0, 0], "edge_v": [0, {size}, 0], "material": "glass"}},
          {{"type": "quad", "corner": [-{half}, -{half}, -{thickness}], "edge_u": [0, {size}, 0], "edge_v": [{size}, 0, 0], "material": "glass"}}
        ] }}"#
    )
}

fn small(w: u32, h: u32) -> RenderOptions {
    RenderOptions { width: w, height: h, ..RenderOptions::default() }.whitted(|w| w.ambient = Ambient::None)
}

/// The converged path-traced reference of `file` (`scene`) at `w`×`h`, `spectral` at `spp`
/// (seed 1, the default sampler), from `refs` or rendered into it: one key for every part that
/// asks for the same image (the `auto` and `sampler` parts share the Cornell box's).
fn path_reference(
    refs: &refs::RefCache,
    scene: &RenderScene,
    file: &str,
    spectral: SpectralMode,
    (w, h): (u32, u32),
    spp: u32,
) -> anyhow::Result<refs::Reference> {
    let key = format!("{file} path {}-{w}x{h} {spp}spp seed1 sobol-blocks", spectral.to_string().replace(':', "-"));
    refs.get(&key, (w, h), || Ok(render(scene, &path_options(w, h, spectral, spp))?.0))
}

/// `options` with independent numbers: for the parts whose error model is the independent
/// samples' (error ∝ 1/√spp, extrapolated from one spp to another); Sobol' points, the default,
/// converge faster (the `sampler` part).
fn independent(options: RenderOptions) -> RenderOptions {
    options.path(|p| p.sampler = SamplerKind::Independent)
}

fn path_options(w: u32, h: u32, spectral: SpectralMode, spp: u32) -> RenderOptions {
    RenderOptions {
        width: w,
        height: h,
        integrator: Integrator::Path(PathOptions::default()),
        spectral,
        spp,
        seed: 1,
        ..RenderOptions::default()
    }
}

/// Mean and standard error of Y over the image.
fn mean_se(image: &Image) -> (f64, f64) {
    mean_se_of(image.pixels().iter().map(|p| f64::from(p[1])))
}

/// Mean and standard error of the mean of `values`.
fn mean_se_of(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let v: Vec<f64> = values.collect();
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    (mean, (var / n).sqrt())
}

fn slab_transmittance(n: f64, sigma_a: f64, d: f64) -> f64 {
    let f = ((n - 1.0) / (n + 1.0)).powi(2);
    let t = (-sigma_a * d).exp();
    (1.0 - f).powi(2) * t / (1.0 - f * f * t * t)
}

/// Per-patch analytic XYZ of the ColorChecker (white Y = 1) and the illuminant's white.
fn chart_reference(illuminant: Illuminant) -> (Vec<Xyz>, Xyz) {
    let s = illuminant.spectrum().expect("illuminant");
    let patches = colorchecker()
        .iter()
        .map(|p| reflectance_to_xyz(&p.spectrum, &s, Observer::Cie1931, &Integration::Step(1.0)).scaled(0.01))
        .collect();
    (patches, white_xyz(&s, &Integration::Step(1.0)).scaled(0.01))
}

/// ΔE00 of every pixel of a 6k×4k chart render against its patch's analytic colour.
fn chart_errors(image: &Image, reference: &[Xyz], white: Xyz) -> Vec<f64> {
    let (w, h) = (image.width(), image.height());
    let mut out = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let patch = (y * 4 / h) * 6 + x * 6 / w;
            let p = image.xyz(x, y);
            let got = Xyz { x: p[0].into(), y: p[1].into(), z: p[2].into() };
            out.push(delta_e_2000(Lab::from_xyz(got, white), Lab::from_xyz(reference[patch as usize], white)));
        }
    }
    out
}

/// Relative MSE of a chart render against the analytic patch colours (XYZ, per channel).
fn chart_relative_mse(image: &Image, reference: &[Xyz]) -> f64 {
    let (w, h) = (image.width(), image.height());
    let (mut sum, mut n) = (0.0, 0usize);
    for y in 0..h {
        for x in 0..w {
            let want = reference[((y * 4 / h) * 6 + x * 6 / w) as usize];
            let p = image.xyz(x, y);
            for (got, want) in p.iter().zip([want.x, want.y, want.z]) {
                sum += (f64::from(*got) - want).powi(2) / (want * want + 1e-2);
                n += 1;
            }
        }
    }
    sum / n.max(1) as f64
}

/// Mean over pixels and channels of (x − r)² / (r² + 0.01): relative squared error, with 0.01
/// (ΔY = 0.1 of white) keeping black reference pixels from dominating.
fn relative_mse(a: &[[f32; 3]], b: &[[f32; 3]]) -> f64 {
    let (mut num, mut n) = (0.0, 0usize);
    for (p, q) in a.iter().zip(b) {
        for c in 0..3 {
            let r = f64::from(q[c]);
            num += (f64::from(p[c]) - r).powi(2) / (r * r + 1e-2);
            n += 1;
        }
    }
    num / n.max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The quick validation suite is part of `cargo test --workspace` (and so of CI): every
    /// check must pass.
    #[test]
    fn quick_validation_passes() {
        let out = crate::project_root().join("target/validate-quick-test");
        let refs = crate::project_root().join("target/validate-quick-test-refs");
        run(&ValidateArgs { quick: true, out, refs, regen: false, only: Vec::new() })
            .expect("every quick validation check passes");
    }
}
