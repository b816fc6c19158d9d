//! `cargo xtask validate`: renders the validation suite, checks every number against its
//! expected value with a stated tolerance, and writes `OUT/report.md` with plots beside it.
//! Exits non-zero if any check fails; the last line is `N passed, N failed`.
//!
//! Expected values are analytic (or published) wherever one exists; otherwise the reference is
//! the project's own converged render, named as such in the report.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use anyhow::Context as _;
use colorimetry::{
    DenselySampledSpectrum, Illuminant, Integration, Lab, Observer, Rgb, RgbColorSpace, Xyz, colorchecker,
    delta_e_2000, reflectance_to_xyz, upsample_reflectance,
};
use integrator::{Ambient, Image, IntegratorKind, RenderOptions, RenderScene, SpectralMode, WavelengthPdf};

/// Arguments of `cargo xtask validate`.
#[derive(Debug, clap::Args)]
pub(crate) struct ValidateArgs {
    /// A subset at small sizes that runs in well under two minutes on two cores (CI).
    #[arg(long)]
    quick: bool,
    /// Output folder for report.md and the plots.
    #[arg(long, default_value = "target/validate")]
    out: PathBuf,
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

pub(crate) fn run(args: &ValidateArgs) -> anyhow::Result<()> {
    let root = crate::project_root();
    let out = if args.out.is_absolute() { args.out.clone() } else { root.join(&args.out) };
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let start = Instant::now();
    let mut report = Report::default();
    colorimetry_checks(&mut report, args.quick);
    whitted_checks(&mut report)?;
    path_checks(&mut report, &root, args.quick)?;
    hard_cases(&mut report, &out)?;
    speed_vs_error(&mut report, &root, &out, args.quick)?;
    // The paper's figures 8–11 with their backing numbers (cargo xtask paper), into OUT/paper/.
    let (w, h) = if args.quick { (160, 120) } else { (640, 480) };
    let paper_out = out.join("paper");
    crate::paper::run(&crate::paper::PaperArgs { out: paper_out.clone(), width: w, height: h })?;
    let paper_ok = paper_out.join("paper.md").is_file();
    report.check(
        "paper",
        format!("figures 8–11 rendered at {w}×{h} without NaN"),
        "see paper/paper.md".into(),
        "0 non-finite".into(),
        "analytic",
        paper_ok,
    );
    report.sections.push_str(
        "## The paper's figures

Side-by-side pairs and their numbers: [paper/paper.md](paper/paper.md).

",
    );
    scaling(&mut report, args.quick)?;

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
    let path = out.join("report.md");
    std::fs::write(&path, md).with_context(|| format!("writing {}", path.display()))?;
    println!("report: {}", path.display());
    println!("{passed} passed, {failed} failed");
    if failed > 0 {
        anyhow::bail!("{failed} validation checks failed");
    }
    Ok(())
}

fn white_xyz(illuminant: &DenselySampledSpectrum, integration: &Integration) -> Xyz {
    reflectance_to_xyz(&DenselySampledSpectrum::constant(1.0), illuminant, Observer::Cie1931, integration)
}

fn colorimetry_checks(report: &mut Report, quick: bool) {
    // CIE 015:2018 white points, 2°: tolerance 3e-5 in xy (PROVENANCE.md: 1 nm vs the
    // published 5-decimal values).
    for (name, xy) in [("D65", [0.31272, 0.32903]), ("D50", [0.34567, 0.35850]), ("A", [0.447575, 0.40745])] {
        let s = Illuminant::parse(name).and_then(|i| i.spectrum()).expect("built-in illuminant");
        let got = white_xyz(&s, &Integration::Step(1.0)).chromaticity();
        let err = (got[0] - xy[0]).abs().max((got[1] - xy[1]).abs());
        report.check(
            "colorimetry",
            format!("{name} white point xy"),
            format!("({:.5}, {:.5})", got[0], got[1]),
            "|Δxy| < 3e-5".into(),
            "published",
            err < 3e-5,
        );
    }
    // The ColorChecker under each illuminant, integrated at the renderer's wavelength counts
    // (bins:N = N evenly spaced wavelengths over 360–830 nm) against 1 nm.
    let mut table = String::from(
        "## What a wavelength count costs: ColorChecker, max ΔE00 vs 1 nm\n\n| illuminant | bins:8 | bins:16 | bins:32 | bins:95 |\n| --- | --- | --- | --- | --- |\n",
    );
    for name in ["D65", "A", "F2", "F11"] {
        let s = Illuminant::parse(name).and_then(|i| i.spectrum()).expect("built-in illuminant");
        let reference = Integration::Step(1.0);
        let mut row = format!("| {name} |");
        let mut worst95 = 0.0;
        for n in [8usize, 16, 32, 95] {
            let step = 470.0 / (n - 1) as f64;
            let integration = Integration::Step(step);
            let (w_ref, w) = (white_xyz(&s, &reference), white_xyz(&s, &integration));
            let worst = colorchecker()
                .iter()
                .map(|p| {
                    let a = Lab::from_xyz(reflectance_to_xyz(&p.spectrum, &s, Observer::Cie1931, &reference), w_ref);
                    let b = Lab::from_xyz(reflectance_to_xyz(&p.spectrum, &s, Observer::Cie1931, &integration), w);
                    delta_e_2000(a, b)
                })
                .fold(0.0, f64::max);
            write!(row, " {worst:.3} |").ok();
            if n == 95 {
                worst95 = worst;
            }
        }
        table.push_str(&row);
        table.push('\n');
        // The 5 nm grid carries the CIE's own tabulation of these illuminants: within 0.5 ΔE00.
        report.check(
            "colorimetry",
            format!("ColorChecker under {name}, bins:95 vs 1 nm"),
            format!("max ΔE00 {worst95:.3}"),
            "< 0.5".into(),
            "published",
            worst95 < 0.5,
        );
    }
    report.sections.push_str(&table);
    report.sections.push('\n');
    // RGB upsampling round trip over a grid of the sRGB gamut (white excepted: unreachable by
    // reflectances within [0, 1], see colorimetry's upsample docs; it is within 0.005).
    let steps = if quick { 9 } else { 17 };
    let srgb = RgbColorSpace::srgb();
    let d65 = Illuminant::D65.spectrum().expect("D65");
    let white = Xyz::from_xy_y(srgb.white(), 1.0);
    let mut worst: f64 = 0.0;
    for i in 0..steps * steps * steps {
        let c = [i % steps, (i / steps) % steps, i / (steps * steps)].map(|v| v as f64 / (steps - 1) as f64);
        let spectrum = upsample_reflectance(c).to_spectrum();
        let xyz = reflectance_to_xyz(&spectrum, &d65, Observer::Cie1931, &Integration::Step(1.0)).scaled(0.01);
        let want = srgb.rgb_to_xyz(Rgb { r: c[0], g: c[1], b: c[2] });
        worst = worst.max(delta_e_2000(Lab::from_xyz(xyz, white), Lab::from_xyz(want, white)));
    }
    report.check(
        "colorimetry",
        format!("RGB upsampling round trip, {steps}³ sRGB grid"),
        format!("max ΔE00 {worst:.4}"),
        "< 0.01".into(),
        "analytic",
        worst < 0.01,
    );
}

fn scene(json: &str) -> anyhow::Result<RenderScene> {
    Ok(RenderScene::from_description(geometry::parse_manifest(json, Path::new("."), "<validate>")?)?)
}

fn render(scene: &RenderScene, options: &RenderOptions) -> anyhow::Result<(Image, integrator::RenderStats)> {
    Ok(integrator::render(scene, options, &|_| {}, &AtomicBool::new(false))?)
}

fn small(w: u32, h: u32) -> RenderOptions {
    RenderOptions { width: w, height: h, ambient: Ambient::None, ..RenderOptions::default() }
}

fn whitted_checks(report: &mut Report) -> anyhow::Result<()> {
    // Eq. 8 through a slab of thickness b keeping t per unit (index 1, k_t = 1, flat spectra):
    // Y = t^b exactly, up to f32 rounding (1e-5).
    for (b, t) in [(0.5f32, 0.99f32), (1.0, 0.95), (4.0, 0.5), (10.0, 0.1), (50.0, 0.01)] {
        let json = format!(
            r#"{{ "camera": {{"position": [0, 0, 10], "look_at": [0, 0, 0], "vfov_deg": 10}},
            "lights": [{{"type": "point", "position": [0, 0, 50], "intensity": 0}}],
            "background": {{"spectrum": "E", "intensity": 1}},
            "materials": {{"glass": {{"diffuse": 0, "ks": 0, "transmission": 1, "transmittance": 1, "ior": 1.0, "absorption": {{"per_unit": {t}}}}}}},
            "objects": [
              {{"type": "quad", "corner": [-5, -5, 0], "edge_u": [10, 0, 0], "edge_v": [0, 10, 0], "material": "glass"}},
              {{"type": "quad", "corner": [-5, -5, -{b}], "edge_u": [0, 10, 0], "edge_v": [10, 0, 0], "material": "glass"}}
            ] }}"#
        );
        let (image, stats) = render(&scene(&json)?, &small(3, 3))?;
        let (y, expected) = (image.xyz(1, 1)[1], t.powf(b));
        let pass = (y - expected).abs() < 1e-5 && stats.nonfinite_samples == 0;
        report.check(
            "analytic (whitted-hall)",
            format!("Beer slab t = {t}, b = {b}"),
            format!("Y = {y:.6e}"),
            format!("t^b = {expected:.6e} ± 1e-5"),
            "analytic",
            pass,
        );
    }
    // IOR 1, k_t = 1: a glass sphere is invisible; the image is the background everywhere.
    let json = r#"{ "camera": {"position": [0, 0, 5], "look_at": [0, 0, 0], "vfov_deg": 30},
        "lights": [{"type": "point", "position": [5, 5, 10], "intensity": 150}],
        "background": {"spectrum": "E", "intensity": 1},
        "materials": {"glass": {"diffuse": 0, "ks": 0, "transmission": 1, "transmittance": 1, "ior": 1.0}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "glass"}] }"#;
    let (image, _) = render(&scene(json)?, &small(16, 16))?;
    let worst = image.pixels().iter().map(|p| (p[1] - 1.0).abs()).fold(0.0f32, f32::max);
    report.check(
        "analytic (whitted-hall)",
        "IOR 1 sphere is invisible",
        format!("max |Y − 1| = {worst:.1e}"),
        "< 1e-5".into(),
        "analytic",
        worst < 1e-5,
    );
    Ok(())
}

fn path_options(w: u32, h: u32, spectral: SpectralMode, spp: u32) -> RenderOptions {
    RenderOptions {
        width: w,
        height: h,
        integrator: IntegratorKind::Path,
        spectral,
        spp,
        seed: 1,
        ..RenderOptions::default()
    }
}

/// Mean and standard error of Y over the image.
fn mean_se(image: &Image) -> (f64, f64) {
    let v: Vec<f64> = image.pixels().iter().map(|p| f64::from(p[1])).collect();
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

fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

fn p95(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    s.get(((s.len().max(1) - 1) as f64 * 0.95).round() as usize).copied().unwrap_or(0.0)
}

fn path_checks(report: &mut Report, root: &Path, quick: bool) -> anyhow::Result<()> {
    let reference_scene = |name: &str| RenderScene::load(&root.join("scenes/reference").join(name));
    // White furnace: a white Lambertian sphere in a uniform white environment renders as the
    // environment, exactly with fixed bins (every path has throughput 1).
    let furnace = reference_scene("white_furnace.json")?;
    let (image, _) = render(&furnace, &path_options(16, 16, SpectralMode::Bins(8), 4))?;
    let worst = image.pixels().iter().map(|p| (f64::from(p[1]) - 1.0).abs()).fold(0.0, f64::max);
    report.check(
        "analytic (path)",
        "white furnace, bins:8",
        format!("max |Y − 1| = {worst:.1e}"),
        "< 1e-4".into(),
        "analytic",
        worst < 1e-4,
    );
    // Beer slab from clear to black: n = 1.5, d = 1, σ_a varied; within 5 standard errors.
    let slab_text = std::fs::read_to_string(root.join("scenes/reference/slab_beer.json"))?;
    for sigma in [0.0, 0.7, 3.0, 20.0] {
        let json = slab_text.replace("\"sigma_a\": 0.7", &format!("\"sigma_a\": {sigma}"));
        let desc = geometry::parse_manifest(&json, &root.join("scenes/reference"), "slab")?;
        let s = RenderScene::from_description(desc)?;
        let (image, _) = render(&s, &path_options(16, 16, SpectralMode::Bins(8), if quick { 16 } else { 64 }))?;
        let (m, se) = mean_se(&image);
        let expected = slab_transmittance(1.5, sigma, 1.0);
        let tol = 5.0 * se.max(1e-6);
        report.check(
            "analytic (path)",
            format!("Beer slab σ_a = {sigma}"),
            format!("Y = {m:.5} ± {se:.5}"),
            format!("{expected:.5} ± 5σ"),
            "analytic",
            (m - expected).abs() < tol,
        );
    }
    // ColorChecker under a uniform D65 environment: each patch is analytic.
    let chart = reference_scene("colorchecker_d65.json")?;
    let (reference, white) = chart_reference(Illuminant::D65);
    let (image, _) = render(&chart, &path_options(6, 4, SpectralMode::Hero { count: 8 }, 256))?;
    let de = mean(&chart_errors(&image, &reference, white));
    report.check(
        "analytic (path)",
        "ColorChecker under D65, hero:8, 256 spp",
        format!("mean ΔE00 {de:.3}"),
        "< 0.2".into(),
        "analytic",
        de < 0.2,
    );
    Ok(())
}

fn hard_cases(report: &mut Report, out: &Path) -> anyhow::Result<()> {
    let glass = |camera: &str, ior: f32, per_unit: f64, radius: f32| {
        format!(
            r#"{{ "camera": {camera},
            "lights": [{{"type": "point", "position": [5, 5, 10], "intensity": 150}}],
            "background": {{"spectrum": "E", "intensity": 1}},
            "materials": {{"glass": {{"diffuse": 0.05, "ks": 0.1, "transmission": 0.9, "transmittance": "colorchecker:13", "ior": {ior}, "absorption": {{"per_unit": {per_unit}}}}},
                          "floor": {{"base_color": "colorchecker:20"}}}},
            "objects": [{{"type": "sphere", "center": [0, 0, 0], "radius": {radius}, "material": "glass"}},
                        {{"type": "quad", "corner": [-50, -1.5, 50], "edge_u": [100, 0, 0], "edge_v": [0, 0, -100], "material": "floor"}}] }}"#
        )
    };
    let cases = [
        (
            "glass sphere at grazing angles (silhouette fills the view)",
            glass(r#"{"position": [0, 0, 1.02], "look_at": [0, 0, 0], "vfov_deg": 170}"#, 1.5, 0.9, 1.0),
        ),
        (
            "camera inside glass",
            glass(r#"{"position": [0.1, 0.2, 0.3], "look_at": [0, 0, -5], "vfov_deg": 90}"#, 1.5, 0.9, 1.0),
        ),
        (
            "extreme absorption (t = 1e-30 per unit, radius 1000)",
            glass(r#"{"position": [0, 0, 3000], "look_at": [0, 0, 0], "vfov_deg": 60}"#, 1.3, 1e-30, 1000.0),
        ),
        (
            "total internal reflection (n = 2.4)",
            glass(r#"{"position": [0, 0, 4], "look_at": [0, 0, 0], "vfov_deg": 40}"#, 2.4, 1.0, 1.0),
        ),
    ];
    // Nested and touching dielectrics, and a slab 1e-4 thick: finite, non-negative images.
    let nested = r#"{ "camera": {"position": [0, 0.3, 4], "look_at": [0, 0, 0], "vfov_deg": 40},
        "lights": [{"type": "point", "position": [3, 4, 5], "intensity": 50}],
        "background": {"spectrum": "E", "intensity": 1},
        "materials": {"outer": {"diffuse": 0, "ks": 0.1, "transmission": 0.9, "transmittance": "colorchecker:14", "ior": 1.5, "absorption": {"sigma_a": 0.5}},
                      "inner": {"diffuse": 0, "ks": 0.1, "transmission": 0.9, "transmittance": "colorchecker:15", "ior": 1.33}},
        "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "outer"},
                    {"type": "sphere", "center": [0, 0, 0], "radius": 0.5, "material": "inner"},
                    {"type": "sphere", "center": [1.5, 0, 0], "radius": 0.5, "material": "inner"}] }"#;
    let thin = r#"{ "camera": {"position": [0.2, 0.1, 3], "look_at": [0, 0, 0], "vfov_deg": 50},
        "lights": [{"type": "point", "position": [3, 4, 5], "intensity": 50}],
        "background": {"spectrum": "E", "intensity": 1},
        "materials": {"glass": {"diffuse": 0, "ks": 0.1, "transmission": 0.9, "transmittance": 1, "ior": 1.5, "absorption": {"sigma_a": 100}}},
        "objects": [{"type": "quad", "corner": [-1, -1, 0], "edge_u": [2, 0, 0], "edge_v": [0, 2, 0], "material": "glass"},
                    {"type": "quad", "corner": [-1, -1, -0.0001], "edge_u": [0, 2, 0], "edge_v": [2, 0, 0], "material": "glass"}] }"#;
    let mut cases: Vec<(&str, String)> = cases.into_iter().collect();
    cases.push(("nested and touching dielectrics", nested.to_owned()));
    cases.push(("slab 1e-4 thick", thin.to_owned()));
    for (name, json) in &cases {
        let s = scene(json)?;
        for (label, options) in
            [("whitted-hall", small(48, 32)), ("path hero:4", path_options(48, 32, SpectralMode::Hero { count: 4 }, 8))]
        {
            let (image, stats) = render(&s, &options)?;
            let negative = image.pixels().iter().flatten().filter(|v| **v < 0.0).count();
            report.check(
                "hard case",
                format!("{name}, {label}"),
                format!("{} NaN/Inf, {negative} negative", stats.nonfinite_samples),
                "0, 0".into(),
                "analytic",
                stats.nonfinite_samples == 0 && negative == 0,
            );
        }
    }
    // Leaks: the camera inside a closed box of quads, looking into a corner, with a very bright
    // background outside: no camera ray may see it through an edge or a corner.
    let json = r#"{ "camera": {"position": [0.1, 0.05, 0.2], "look_at": [1, 0.7, -0.3], "vfov_deg": 150},
        "lights": [{"type": "point", "position": [0, 0, 0], "intensity": 0.1}],
        "background": {"spectrum": "E", "intensity": 1000},
        "materials": {"wall": {"base_color": 0.5}},
        "objects": [
          {"type": "quad", "corner": [-1, -1, -1], "edge_u": [2, 0, 0], "edge_v": [0, 2, 0], "material": "wall"},
          {"type": "quad", "corner": [-1, -1, 1], "edge_u": [0, 2, 0], "edge_v": [2, 0, 0], "material": "wall"},
          {"type": "quad", "corner": [-1, -1, -1], "edge_u": [0, 0, 2], "edge_v": [2, 0, 0], "material": "wall"},
          {"type": "quad", "corner": [-1, 1, -1], "edge_u": [2, 0, 0], "edge_v": [0, 0, 2], "material": "wall"},
          {"type": "quad", "corner": [-1, -1, -1], "edge_u": [0, 2, 0], "edge_v": [0, 0, 2], "material": "wall"},
          {"type": "quad", "corner": [1, -1, -1], "edge_u": [0, 0, 2], "edge_v": [0, 2, 0], "material": "wall"}
        ] }"#;
    let (image, _) = render(&scene(json)?, &small(256, 256))?;
    let leaks = image.object_ids().iter().filter(|id| matches!(id, integrator::ObjectId::Background)).count();
    report.check(
        "hard case",
        "closed box seen from inside: camera rays through edges and corners",
        format!("{leaks} leaks / 65536 rays"),
        "0".into(),
        "analytic",
        leaks == 0,
    );
    // Far from the origin and tiny: the same image as at unit scale (whitted-hall, bins:16).
    let base = glass(r#"{"position": [0, 0.5, 4], "look_at": [0, 0, 0], "vfov_deg": 40}"#, 1.5, 0.9, 1.0);
    let (unit, _) = render(&scene(&base)?, &RenderOptions { spectral: SpectralMode::Bins(16), ..small(48, 32) })?;
    for (label, scale, offset) in [("offset 1e5", 1.0f64, 1e5f64), ("scale 1e-4", 1e-4, 0.0)] {
        let moved = transform_manifest(&base, scale, offset);
        let (image, _) = render(&scene(&moved)?, &RenderOptions { spectral: SpectralMode::Bins(16), ..small(48, 32) })?;
        let de = delta_e_all(&image, &unit);
        // At 1e5 every coordinate carries ulp(1e5) = 0.008 of rounding, which shifts silhouettes
        // by a pixel here and there: the mean over the image stays small; at 1e-4 the geometry
        // is exact up to relative rounding.
        let tol = if offset > 0.0 { 2.0 } else { 0.5 };
        if mean(&de) >= tol {
            // Diagnostics for a failure: both images beside the report.
            let stem = label.replace(' ', "_");
            image.write_png(&out.join(format!("failed_{stem}.png")), integrator::Display::Srgb)?;
            unit.write_png(&out.join(format!("failed_{stem}_reference.png")), integrator::Display::Srgb)?;
        }
        report.check(
            "hard case",
            format!("five-sphere-like scene at {label} vs unit scale"),
            format!("mean ΔE00 {:.3}", mean(&de)),
            format!("< {tol}"),
            "converged",
            mean(&de) < tol,
        );
    }
    Ok(())
}

/// Rewrite every coordinate-like array and radius of a manifest: p → p·scale + offset
/// (vectors), r → r·scale (radii, edges). Light intensity scales with scale² (inverse square).
fn transform_manifest(json: &str, scale: f64, offset: f64) -> String {
    let mut v: serde_json::Value = serde_json::from_str(json).expect("valid manifest");
    let point = |p: &mut serde_json::Value| {
        if let Some(a) = p.as_array_mut() {
            for c in a.iter_mut() {
                *c = serde_json::json!(c.as_f64().unwrap_or(0.0) * scale + offset);
            }
        }
    };
    let vector = |p: &mut serde_json::Value| {
        if let Some(a) = p.as_array_mut() {
            for c in a.iter_mut() {
                *c = serde_json::json!(c.as_f64().unwrap_or(0.0) * scale);
            }
        }
    };
    point(&mut v["camera"]["position"]);
    point(&mut v["camera"]["look_at"]);
    if let Some(lights) = v["lights"].as_array_mut() {
        for l in lights {
            point(&mut l["position"]);
            let i = l["intensity"].as_f64().unwrap_or(1.0);
            l["intensity"] = serde_json::json!(i * scale * scale);
        }
    }
    if let Some(objects) = v["objects"].as_array_mut() {
        for o in objects.iter_mut().filter_map(|o| o.as_object_mut()) {
            // Only keys that exist: indexing a JSON map with a missing key would add a null.
            for (key, value) in o.iter_mut() {
                match key.as_str() {
                    "center" | "corner" => point(value),
                    "edge_u" | "edge_v" => vector(value),
                    "radius" => *value = serde_json::json!(value.as_f64().unwrap_or(1.0) * scale),
                    _ => {}
                }
            }
        }
    }
    // Absorption is per scene unit: keep the optical depth the same, as σ_a / scale (t^(1/scale)
    // would underflow for small scales).
    if let Some(t) = v["materials"]["glass"]["absorption"]["per_unit"].as_f64() {
        v["materials"]["glass"]["absorption"] = serde_json::json!({ "sigma_a": -t.ln() / scale });
    }
    v.to_string()
}

/// The D65 white at Y = 1: reference white of the ΔE00 comparisons between renders.
const WHITE: Xyz = Xyz { x: 0.95047, y: 1.0, z: 1.08883 };

fn delta_e_all(a: &Image, b: &Image) -> Vec<f64> {
    let lab = |p: &[f32; 3]| Lab::from_xyz(Xyz { x: p[0].into(), y: p[1].into(), z: p[2].into() }, WHITE);
    a.pixels().iter().zip(b.pixels()).map(|(p, q)| delta_e_2000(lab(p), lab(q))).collect()
}

fn relative_mse(a: &Image, b: &Image) -> f64 {
    let (mut num, mut n) = (0.0, 0usize);
    for (p, q) in a.pixels().iter().zip(b.pixels()) {
        for c in 0..3 {
            let r = f64::from(q[c]);
            num += (f64::from(p[c]) - r).powi(2) / (r * r + 1e-2);
            n += 1;
        }
    }
    num / n.max(1) as f64
}

/// One point of a speed-against-error curve.
struct Point {
    strategy: String,
    spp: u32,
    seconds: f64,
    mean_de: f64,
    p95_de: f64,
    rel_mse: f64,
}

fn speed_vs_error(report: &mut Report, root: &Path, out: &Path, quick: bool) -> anyhow::Result<()> {
    let mut md = String::from("## Speed against error\n\n");
    // 1. The paper's model on the default scene: reference = bins:95 (the 5 nm grid).
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
        let de = delta_e_all(&image, &reference);
        points.push(Point {
            strategy: format!("{mode} → {}", stats.spectral),
            spp: 1,
            seconds: stats.elapsed.as_secs_f64(),
            mean_de: mean(&de),
            p95_de: p95(&de),
            rel_mse: relative_mse(&image, &reference),
        });
    }
    writeln!(
        md,
        "### The paper's five spheres, whitted-hall, {}×{} (reference: bins:95, converged)\n",
        size.0, size.1
    )?;
    table(&mut md, &points);
    let auto = points.iter().find(|p| p.strategy.starts_with("auto")).map(|p| p.mean_de).unwrap_or(f64::INFINITY);
    report.check(
        "speed vs error",
        "default scene: auto within ΔE00 0.5 of bins:95 (mean)",
        format!("{auto:.3}"),
        "< 0.5".into(),
        "converged",
        auto < 0.5,
    );

    // 2. The path tracer on the ColorChecker under D65 and F11: analytic reference per pixel.
    for (file, illuminant) in [("colorchecker_d65.json", Illuminant::D65), ("colorchecker_f11.json", Illuminant::F11)] {
        let chart = RenderScene::load(&root.join("scenes/reference").join(file))?;
        let (reference, white) = chart_reference(illuminant);
        let (w, h) = (60, 40);
        let spps: &[u32] = if quick { &[4, 16] } else { &[4, 16, 64, 256] };
        let mut points = Vec::new();
        let strategies: Vec<(String, SpectralMode, WavelengthPdf)> = vec![
            ("rgb".into(), SpectralMode::Rgb, WavelengthPdf::Visible),
            ("bins:16".into(), SpectralMode::Bins(16), WavelengthPdf::Visible),
            ("bins:32".into(), SpectralMode::Bins(32), WavelengthPdf::Visible),
            ("bins:95".into(), SpectralMode::Bins(95), WavelengthPdf::Visible),
            ("hero:4 visible".into(), SpectralMode::Hero { count: 4 }, WavelengthPdf::Visible),
            ("hero:8 visible".into(), SpectralMode::Hero { count: 8 }, WavelengthPdf::Visible),
            ("hero:8 illuminant".into(), SpectralMode::Hero { count: 8 }, WavelengthPdf::Illuminant),
            ("auto".into(), SpectralMode::Auto, WavelengthPdf::Illuminant),
        ];
        for (label, mode, pdf) in &strategies {
            for &spp in spps {
                let options = RenderOptions { wavelength_pdf: *pdf, ..path_options(w, h, *mode, spp) };
                let (image, stats) = render(&chart, &options)?;
                let de = chart_errors(&image, &reference, white);
                points.push(Point {
                    strategy: format!("{label} ({})", stats.spectral),
                    spp,
                    seconds: stats.elapsed.as_secs_f64(),
                    mean_de: mean(&de),
                    p95_de: p95(&de),
                    rel_mse: chart_relative_mse(&image, &reference),
                });
            }
        }
        writeln!(md, "### ColorChecker under {} (path tracer, {w}×{h}, reference: analytic)\n", illuminant.name())?;
        table(&mut md, &points);
        let fastest = points.iter().filter(|p| p.mean_de < 1.0).min_by(|a, b| a.seconds.total_cmp(&b.seconds));
        writeln!(
            md,
            "Fastest to mean ΔE00 < 1: {}\n",
            fastest.map_or("none".into(), |p| format!("{} at {} spp, {:.3} s", p.strategy, p.spp, p.seconds))
        )?;
        let png = out.join(format!("speed_vs_error_{}.png", illuminant.name()));
        plot(&png, &points)?;
        writeln!(
            md,
            "![speed vs error]({}) — x: wall time (log), y: mean ΔE00 (log); one polyline per strategy in table order, colours as listed: rgb red, bins:16 orange, bins:32 olive, bins:95 green, hero:4 cyan, hero:8 visible blue, hero:8 illuminant purple, auto black. Grid lines at decades.\n",
            png.file_name().and_then(|n| n.to_str()).unwrap_or("")
        )?;
        let rgb_err =
            points.iter().filter(|p| p.strategy.starts_with("rgb")).map(|p| p.mean_de).fold(f64::INFINITY, f64::min);
        if illuminant == Illuminant::F11 {
            // Where RGB is wrong: under a line spectrum RGB cannot be right at any spp.
            report.check(
                "speed vs error",
                "F11 chart: RGB error stays above 1 ΔE00 (RGB is wrong here)",
                format!("{rgb_err:.2}"),
                "> 1".into(),
                "analytic",
                rgb_err > 1.0,
            );
        }
        let auto_best =
            points.iter().filter(|p| p.strategy.starts_with("auto")).map(|p| p.mean_de).fold(f64::INFINITY, f64::min);
        report.check(
            "speed vs error",
            format!("{} chart: auto reaches mean ΔE00 < 0.5", illuminant.name()),
            format!("{auto_best:.3}"),
            "< 0.5".into(),
            "analytic",
            auto_best < 0.5,
        );
    }
    report.sections.push_str(&md);
    Ok(())
}

fn table(md: &mut String, points: &[Point]) {
    md.push_str(
        "| strategy | spp | time (s) | ΔE00 mean | ΔE00 p95 | rel. MSE |\n| --- | --- | --- | --- | --- | --- |\n",
    );
    for p in points {
        let _ = writeln!(
            md,
            "| {} | {} | {:.3} | {:.3} | {:.3} | {:.2e} |",
            p.strategy, p.spp, p.seconds, p.mean_de, p.p95_de, p.rel_mse
        );
    }
    md.push('\n');
}

fn plot(path: &Path, points: &[Point]) -> anyhow::Result<()> {
    use plotters::prelude::*;
    let (w, h) = (640u32, 480u32);
    let t_min = points.iter().map(|p| p.seconds).fold(f64::INFINITY, f64::min).max(1e-5).log10().floor();
    let t_max = points.iter().map(|p| p.seconds).fold(0.0, f64::max).max(1e-4).log10().ceil();
    let e_min = points.iter().map(|p| p.mean_de).fold(f64::INFINITY, f64::min).max(1e-4).log10().floor();
    let e_max = points.iter().map(|p| p.mean_de).fold(0.0, f64::max).max(1e-3).log10().ceil();
    let mut buffer = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buffer, (w, h)).into_drawing_area();
        root.fill(&WHITE_COLOR).map_err(|e| anyhow::anyhow!("{e}"))?;
        let map = |t: f64, e: f64| {
            let x = 20.0 + (t.max(1e-9).log10() - t_min) / (t_max - t_min).max(1e-9) * f64::from(w - 40);
            let y = f64::from(h) - 20.0 - (e.max(1e-9).log10() - e_min) / (e_max - e_min).max(1e-9) * f64::from(h - 40);
            (x as i32, y as i32)
        };
        let grey = RGBColor(220, 220, 220);
        for d in t_min as i32..=t_max as i32 {
            let (x, _) = map(10f64.powi(d), 1.0);
            root.draw(&PathElement::new(vec![(x, 0), (x, h as i32)], grey)).map_err(|e| anyhow::anyhow!("{e}"))?;
        }
        for d in e_min as i32..=e_max as i32 {
            let (_, y) = map(1.0, 10f64.powi(d));
            root.draw(&PathElement::new(vec![(0, y), (w as i32, y)], grey)).map_err(|e| anyhow::anyhow!("{e}"))?;
        }
        let palette = [RED, RGBColor(255, 140, 0), RGBColor(128, 128, 0), GREEN, CYAN, BLUE, MAGENTA, BLACK];
        let mut strategies: Vec<&str> = Vec::new();
        for p in points {
            if !strategies.contains(&p.strategy.as_str()) {
                strategies.push(&p.strategy);
            }
        }
        for (i, s) in strategies.iter().enumerate() {
            let color = palette[i % palette.len()];
            let line: Vec<(i32, i32)> =
                points.iter().filter(|p| p.strategy == *s).map(|p| map(p.seconds, p.mean_de)).collect();
            root.draw(&PathElement::new(line.clone(), color.stroke_width(2))).map_err(|e| anyhow::anyhow!("{e}"))?;
            for pt in line {
                root.draw(&Circle::new(pt, 4, color.filled())).map_err(|e| anyhow::anyhow!("{e}"))?;
            }
        }
        root.present().map_err(|e| anyhow::anyhow!("{e}"))?;
    }
    // plotters' bitmap backend draws into memory; the image crate writes the PNG.
    image::save_buffer(path, &buffer, w, h, image::ExtendedColorType::Rgb8)
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

const WHITE_COLOR: plotters::style::RGBColor = plotters::style::RGBColor(255, 255, 255);

fn scaling(report: &mut Report, quick: bool) -> anyhow::Result<()> {
    let mut md = String::from("## Scaling\n\n");
    // Time vs triangles: a bumpy terrain under the paper's model, one D65 light.
    md.push_str("### Time vs triangles (whitted-hall, 320×240, bins:16, all cores)\n\n| triangles | BVH build (ms) | render (s) | Mrays/s |\n| --- | --- | --- | --- |\n");
    let sizes: &[u32] = if quick { &[71, 224] } else { &[71, 224, 708] };
    for &n in sizes {
        let mesh = terrain(n);
        let triangles = mesh.triangle_count();
        let desc = geometry::SceneDescription {
            meshes: vec![mesh],
            camera: Some(geometry::CameraDesc {
                position: glam::Vec3::new(0.0, 1.6, 1.6),
                look_at: glam::Vec3::ZERO,
                up: glam::Vec3::Y,
                vfov_deg: 50.0,
                width: None,
                height: None,
            }),
            ..geometry::parse_manifest("{}", Path::new("."), "<terrain>")?
        };
        let s = RenderScene::from_description(desc)?;
        let build_ms = s.geometry().stats().build_time.as_secs_f64() * 1e3;
        let (_, stats) = render(&s, &RenderOptions { spectral: SpectralMode::Bins(16), ..small(320, 240) })?;
        let secs = stats.elapsed.as_secs_f64();
        writeln!(md, "| {triangles} | {build_ms:.1} | {secs:.3} | {:.2} |", stats.rays as f64 / secs / 1e6)?;
    }
    // Time vs image size, threads and wavelength count: the default scene.
    let five = RenderScene::default_scene()?;
    md.push_str("\n### Time vs image size, threads and wavelengths (default scene, whitted-hall)\n\n| size | threads | spectral | time (s) | Mrays/s |\n| --- | --- | --- | --- | --- |\n");
    let mut one_thread = 0.0;
    let mut two_threads = 0.0;
    let configs: Vec<((u32, u32), usize, SpectralMode)> = if quick {
        vec![
            ((160, 120), 1, SpectralMode::Bins(32)),
            ((160, 120), 2, SpectralMode::Bins(32)),
            ((320, 240), 2, SpectralMode::Bins(32)),
            ((320, 240), 2, SpectralMode::Bins(8)),
            ((320, 240), 2, SpectralMode::Bins(95)),
        ]
    } else {
        vec![
            ((160, 120), 2, SpectralMode::Bins(32)),
            ((320, 240), 2, SpectralMode::Bins(32)),
            ((640, 480), 1, SpectralMode::Bins(32)),
            ((640, 480), 2, SpectralMode::Bins(32)),
            ((1280, 960), 2, SpectralMode::Bins(32)),
            ((640, 480), 2, SpectralMode::Bins(8)),
            ((640, 480), 2, SpectralMode::Bins(16)),
            ((640, 480), 2, SpectralMode::Bins(64)),
            ((640, 480), 2, SpectralMode::Bins(95)),
            ((640, 480), 2, SpectralMode::Rgb),
        ]
    };
    for ((w, h), threads, mode) in configs {
        let options =
            RenderOptions { width: w, height: h, threads: Some(threads), spectral: mode, ..RenderOptions::default() };
        let (_, stats) = render(&five, &options)?;
        let secs = stats.elapsed.as_secs_f64();
        if mode == SpectralMode::Bins(32) && (w, h) == if quick { (160, 120) } else { (640, 480) } {
            if threads == 1 { one_thread = secs } else { two_threads = secs }
        }
        writeln!(md, "| {w}×{h} | {threads} | {mode} | {secs:.3} | {:.2} |", stats.rays as f64 / secs / 1e6)?;
    }
    md.push('\n');
    report.sections.push_str(&md);
    // Rows are independent: two threads must not be slower than one (a loose sanity bound on
    // a shared machine, not a timing assertion of the test suite).
    report.check(
        "scaling",
        "2 threads vs 1 thread (default scene)",
        format!("{:.2}× speed-up", one_thread / two_threads.max(1e-9)),
        "> 0.8".into(),
        "converged",
        one_thread / two_threads.max(1e-9) > 0.8,
    );
    Ok(())
}

/// A bumpy heightfield of n×n quads (2n² triangles).
fn terrain(n: u32) -> geometry::Mesh {
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (i as f32 / n as f32 * 2.0 - 1.0, j as f32 / n as f32 * 2.0 - 1.0);
            positions.push(glam::Vec3::new(x, 0.1 * (7.0 * x).sin() * (5.0 * z).cos(), z));
        }
    }
    let mut indices = Vec::new();
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i;
            indices.push([a, a + n + 1, a + 1]);
            indices.push([a + 1, a + n + 1, a + n + 2]);
        }
    }
    geometry::Mesh::new(positions, None, None, indices, None).expect("finite terrain")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The quick validation suite is part of `cargo test --workspace` (and so of CI): every
    /// check must pass.
    #[test]
    fn quick_validation_passes() {
        let out = crate::project_root().join("target/validate-quick-test");
        run(&ValidateArgs { quick: true, out }).expect("every quick validation check passes");
    }
}
