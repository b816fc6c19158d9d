//! `cargo xtask gallery`: renders every glTF and OBJ under the third-party asset folder
//! (`../shared/real_assets`, read in place, never copied) with the `spectrace` binary and **no
//! flags** but a small size, and tabulates what a new user would see: the integrator,
//! camera and exposure chosen, the PNG's mean luminance and its clipped pixels, the wall time
//! (load and render), the file's warnings and non-finite samples; and a contact sheet
//! (`gallery.html`, the PNGs with their rows). The project's own glTF scenes (`scenes/`) are
//! rendered too. Skips the third-party part with a message when the folder is absent.
//! `robustness/` (malformed files for the loaders) is left out.

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
    /// Output folder for the renders and the table.
    #[arg(long, default_value = "target/gallery")]
    out: PathBuf,
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
    let mut table = String::from(
        "| asset | integrator | camera | EV | mean | clipped % | time s | warnings | non-finite |\n|---|---|---|---|---|---|---|---|---|\n",
    );
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
        let height = (args.width * 3 / 4).max(1).to_string();
        let started = Instant::now();
        let output = Command::new(&spectrace)
            .args(["render", "--width", &width, "--height", &height, "-o"])
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
        let camera = if note("three-quarter view").is_empty() { "file" } else { "3/4 default" };
        // "spectrace: note: PNG exposure +1.23 EV (…)"
        let ev = note("PNG exposure ").split_whitespace().nth(4).unwrap_or("0").to_owned();
        table.push_str(&format!(
            "| {name} | {integrator} | {camera} | {ev} | {mean:.1} % | {clipped_pct:.2} | {seconds:.2} | {} | {nonfinite} |\n",
            warnings.len()
        ));
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
