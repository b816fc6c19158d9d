//! `cargo xtask gallery`: renders every glTF and OBJ under the third-party asset folder
//! (`../shared/real_assets`, read in place, never copied) with the `spectrace` binary and **no
//! flags** but a small size, and tabulates what a new user would see: the integrator,
//! camera and exposure chosen, the PNG's mean luminance and its clipped pixels, the wall time
//! (load and render), the file's warnings and non-finite samples; and a contact sheet
//! (`gallery.html`, the PNGs with their rows). The project's own glTF scenes (`scenes/`) are
//! rendered too. Skips the third-party part with a message when the folder is absent.
//! `robustness/` (malformed files for the loaders) is left out.
//!
//! With `--seeds`, each file is rendered again with `--seed 1`, and the table adds what a render
//! to a target error reports (spp, the estimated mean ΔE00 and worst tile) beside the measured
//! mean ΔE00 between the two renders over √2 (each one's error, if the estimate is honest), at
//! the PNG's exposure, clipped at white, as the estimate judges (`docs/defaults.md`, "Samples").

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::Context as _;

/// Arguments of `cargo xtask gallery`.
#[derive(Debug, clap::Args)]
pub(crate) struct GalleryArgs {
    /// Folder of the assets [default: ../shared/real_assets beside the project].
    #[arg(long)]
    assets: Option<PathBuf>,
    /// The spectrace binary [default: target/release/spectrace].
    #[arg(long)]
    spectrace: Option<PathBuf>,
    /// Image width (height is 3/4 of it).
    #[arg(long, default_value_t = 96)]
    width: u32,
    /// Image height [default: 3/4 of the width].
    #[arg(long)]
    height: Option<u32>,
    /// Output folder for the renders and the table.
    #[arg(long, default_value = "target/gallery")]
    out: PathBuf,
    /// Render each file a second time with `--seed 1` and compare the two (see the module docs).
    #[arg(long)]
    seeds: bool,
    /// More arguments for every render (e.g. `--extra=--time-limit --extra=30`), said in the table.
    #[arg(long, allow_hyphen_values = true)]
    extra: Vec<String>,
}

/// Rec. 709 luma weights (ITU-R BT.709-6, item 3.2), applied to the PNG's display values.
const LUMA: [f64; 3] = [0.2126, 0.7152, 0.0722];

pub(crate) fn run(args: &GalleryArgs) -> anyhow::Result<()> {
    let root = crate::project_root();
    let assets = args.assets.clone().unwrap_or_else(|| root.join("../shared/real_assets"));
    let mut files = Vec::new();
    if assets.is_dir() {
        collect(&assets, &mut files)?;
    } else {
        println!("gallery: third-party assets skipped, no asset folder at {}", assets.display());
    }
    files.retain(|f| !f.strip_prefix(&assets).is_ok_and(|r| r.starts_with("robustness")));
    let mut own = Vec::new();
    collect(&root.join("scenes"), &mut own)?;
    own.retain(|f| f.extension().is_some_and(|e| e != "obj"));
    files.sort();
    own.sort();
    files.extend(own);
    let spectrace = args.spectrace.clone().unwrap_or_else(|| root.join("target/release/spectrace"));
    anyhow::ensure!(spectrace.is_file(), "{}: build it first (cargo build --release -p cli)", spectrace.display());
    let out = root.join(&args.out);
    std::fs::create_dir_all(&out).with_context(|| out.display().to_string())?;
    let mut table = if args.extra.is_empty() {
        String::new()
    } else {
        format!("Every render with `{}`.\n\n", args.extra.join(" "))
    };
    table.push_str(if args.seeds {
        "| asset | integrator | camera | lights | EV | mean | clipped % | time s | spp | estimated ΔE00 (worst tile) | seeds' ΔE00 / √2 | warnings | non-finite |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n"
    } else {
        "| asset | integrator | camera | EV | mean | clipped % | time s | warnings | non-finite |\n|---|---|---|---|---|---|---|---|---|\n"
    });
    let mut html = String::from(
        "<!doctype html><meta charset=utf-8><title>spectrace gallery</title>\n<style>figure{display:inline-block;margin:4px;font:11px sans-serif;width:260px;vertical-align:top}img{width:256px;image-rendering:pixelated}</style>\n",
    );
    let (mut loaded, mut good) = (0, 0);
    for file in &files {
        let name =
            file.strip_prefix(&assets).or_else(|_| file.strip_prefix(&root)).unwrap_or(file).display().to_string();
        let tag = name.replace(['/', '.', ' '], "_");
        let exr = out.join(format!("{tag}.exr"));
        let width = args.width.to_string();
        let height = args.height.unwrap_or((args.width * 3 / 4).max(1)).to_string();
        let started = Instant::now();
        let output = Command::new(&spectrace)
            .args(["render", "--width", &width, "--height", &height])
            .args(&args.extra)
            .arg("-o")
            .arg(&exr)
            .arg(file)
            .output()
            .with_context(|| spectrace.display().to_string())?;
        let seconds = started.elapsed().as_secs_f64();
        let stderr = String::from_utf8_lossy(&output.stderr);
        if !output.status.success() {
            let reason = stderr.lines().last().unwrap_or("").replace('|', "/");
            table.push_str(&format!("| {name} | not loaded: {reason} | | | | | {seconds:.2} | | |\n"));
            html.push_str(&format!(
                "<figure><figcaption>{name}: not loaded: {}</figcaption></figure>\n",
                escape(&reason)
            ));
            continue;
        }
        // Notes about the file itself start with its path; the render line counts non-finite samples.
        let file_text = file.display().to_string();
        let warnings: Vec<&str> = stderr.lines().filter(|l| l.contains(&file_text)).collect();
        let nonfinite = stderr
            .lines()
            .find_map(|l| l.split(" non-finite samples").next().filter(|_| l.contains(" non-finite samples")))
            .and_then(|l| l.rsplit(' ').next())
            .unwrap_or("?")
            .to_owned();
        loaded += 1;
        let png = image::open(exr.with_extension("png")).context("reading the PNG")?.to_rgb8();
        let (mut sum, mut clipped) = (0.0f64, 0usize);
        for p in png.pixels() {
            sum += (0..3).map(|k| LUMA[k] * f64::from(p[k]) / 255.0).sum::<f64>();
            clipped += usize::from(p.0.contains(&255));
        }
        let n = (png.width() * png.height()).max(1) as f64;
        let (mean, clipped_pct) = (100.0 * sum / n, 100.0 * clipped as f64 / n);
        if (5.0..=90.0).contains(&mean) && clipped_pct < 1.0 {
            good += 1;
        }
        let note = |key: &str| stderr.lines().find(|l| l.contains(key)).unwrap_or("").to_owned();
        let integrator = note("note: integrator ")
            .split(':')
            .nth(2)
            .map_or("?", |s| s.trim().trim_start_matches("integrator "))
            .to_owned();
        let camera_note = note("note: camera: ");
        let camera = if camera_note.is_empty() {
            "file".to_owned()
        } else {
            camera_note.split("note: camera: ").nth(1).unwrap_or("?").replace('|', "/")
        };
        // "spectrace: note: PNG exposure +1.23 EV (…)"
        let ev = note("PNG exposure ").split_whitespace().nth(4).unwrap_or("0").to_owned();
        if args.seeds {
            // What the lights rule decided, in `info`'s words (the render's note varies by case).
            let info = Command::new(&spectrace)
                .args(["info", "--width", &width, "--height", &height])
                .arg(file)
                .output()
                .with_context(|| spectrace.display().to_string())?;
            let lights = serde_json::from_slice::<serde_json::Value>(&info.stdout)
                .ok()
                .and_then(|v| v["lights_why"].as_str().map(|s| s.replace('|', "/")))
                .unwrap_or_else(|| "?".to_owned());
            // The summary: "spectrace: 400x300 bins:24 16..4096 spp (mean 2078) in …" or "… 64 spp in …".
            let size = format!("spectrace: {width}x{height} ");
            let summary = stderr.lines().find(|l| l.starts_with(&size)).unwrap_or("");
            let spp = summary
                .split(" in ")
                .next()
                .and_then(|s| s.strip_prefix(&size))
                .and_then(|s| s.split_once(' ').map(|(_, rest)| rest))
                .unwrap_or("?")
                .to_owned();
            let estimated = note("estimated error:")
                .split("mean ΔE00 ")
                .nth(1)
                .map(|s| {
                    let mean = s.split(',').next().unwrap_or("?");
                    let worst = s.split("tile ").nth(1).and_then(|t| t.split(';').next()).unwrap_or("?");
                    format!("{mean} ({worst})")
                })
                .unwrap_or_else(|| "–".to_owned());
            let second = out.join(format!("{tag}_seed1.exr"));
            let again = Command::new(&spectrace)
                .args(["render", "--quiet", "--seed", "1", "--width", &width, "--height", &height])
                .args(&args.extra)
                .arg("-o")
                .arg(&second)
                .arg(file)
                .output()?;
            let seeds = if again.status.success() {
                let scale = f64::from(ev.parse::<f32>().unwrap_or(0.0)).exp2();
                format!("{:.2}", seeds_error(&exr, &second, scale)? / std::f64::consts::SQRT_2)
            } else {
                "failed".to_owned()
            };
            table.push_str(&format!(
                "| {name} | {integrator} | {camera} | {lights} | {ev} | {mean:.1} % | {clipped_pct:.2} | {seconds:.2} | {spp} | {estimated} | {seeds} | {} | {nonfinite} |\n",
                warnings.len()
            ));
        } else {
            table.push_str(&format!(
                "| {name} | {integrator} | {camera} | {ev} | {mean:.1} % | {clipped_pct:.2} | {seconds:.2} | {} | {nonfinite} |\n",
                warnings.len()
            ));
        }
        let notes: String =
            warnings.iter().map(|w| format!("<br>{}", escape(w.trim_start_matches("spectrace: note: ")))).collect();
        html.push_str(&format!(
            "<figure><img src=\"{tag}.png\"><figcaption><b>{name}</b><br>{integrator}, {camera} camera, EV {ev}, mean {mean:.1} %, clipped {clipped_pct:.2} %, {seconds:.2} s{notes}</figcaption></figure>\n"
        ));
    }
    table.push_str(&format!(
        "\n{loaded} of {} assets load; {good} have a mean luminance in 5–90 % and < 1 % clipped pixels.\n",
        files.len()
    ));
    std::fs::write(out.join("gallery.md"), &table)?;
    std::fs::write(out.join("gallery.html"), &html)?;
    print!("{table}");
    Ok(())
}

/// Mean ΔE00 between two renders' EXRs (linear sRGB) as their PNG shows them at `scale`.
fn seeds_error(a: &Path, b: &Path, scale: f64) -> anyhow::Result<f64> {
    let srgb = colorimetry::RgbColorSpace::srgb();
    let (pa, pb) = (rgb_pixels(a)?, rgb_pixels(b)?);
    anyhow::ensure!(pa.len() == pb.len(), "{} and {}: sizes differ", a.display(), b.display());
    let xyz = |c: [f32; 3]| {
        let x = srgb.rgb_to_xyz(colorimetry::Rgb { r: c[0].into(), g: c[1].into(), b: c[2].into() });
        [x.x, x.y, x.z]
    };
    let sum: f64 = pa.iter().zip(&pb).map(|(p, q)| integrator::displayed_delta_e(xyz(*p), xyz(*q), scale)).sum();
    Ok(sum / pa.len().max(1) as f64)
}

/// An EXR's R, G, B channels, pixel by pixel.
fn rgb_pixels(path: &Path) -> anyhow::Result<Vec<[f32; 3]>> {
    let image = exr::prelude::read_all_flat_layers_from_file(path).with_context(|| path.display().to_string())?;
    let layer = image.layer_data.first().context("no layer")?;
    let channel = |name: &str| -> anyhow::Result<Vec<f32>> {
        let c = layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.to_string() == name)
            .with_context(|| format!("{}: no channel {name}", path.display()))?;
        Ok(c.sample_data.values_as_f32().collect())
    };
    let (r, g, b) = (channel("R")?, channel("G")?, channel("B")?);
    Ok(r.iter().zip(&g).zip(&b).map(|((r, g), b)| [*r, *g, *b]).collect())
}

/// `text` safe inside HTML.
fn escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;")
}

/// Every `.gltf`, `.glb` and `.obj` below `dir`.
fn collect(dir: &Path, files: &mut Vec<PathBuf>) -> anyhow::Result<()> {
    for entry in std::fs::read_dir(dir).with_context(|| dir.display().to_string())? {
        let path = entry?.path();
        if path.is_dir() {
            collect(&path, files)?;
        } else if path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| ["gltf", "glb", "obj"].contains(&e.to_ascii_lowercase().as_str()))
        {
            files.push(path);
        }
    }
    Ok(())
}
