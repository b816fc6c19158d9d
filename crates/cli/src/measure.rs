//! `spectrace measure`: illuminance at sensor points (lux), from a CSV of points or a grid on a plane,
//! estimated by the path tracer (`integrator::measure`), written as CSV.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use anyhow::{Context as _, bail};
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};
use integrator::{MeasureOptions, Measurement, RenderScene, SensorPoint, SpectralMode};

/// The columns a points file must have, in any order (others are ignored, and a note names them).
const COLUMNS: [&str; 7] = ["name", "x", "y", "z", "nx", "ny", "nz"];

/// The most cells a side of a grid's false-colour picture may have (one pixel each at least).
const MAX_PICTURE_SIDE: usize = 8192;

/// The most points a file or grid may give (10⁷: a few hundred MB of results at most).
const MAX_POINTS: usize = 10_000_000;

/// Arguments of `spectrace measure`.
#[derive(Debug, clap::Args)]
pub(crate) struct MeasureArgs {
    /// Scene file (.json manifest, .gltf/.glb, .obj); the default scene when omitted.
    scene: Option<PathBuf>,
    /// Sensor points: a CSV file with a header and the columns name,x,y,z,nx,ny,nz (scene units, metres for
    /// photometry; the normal, of any length, is the side the sensor faces).
    #[arg(long, value_name = "CSV", required_unless_present = "grid")]
    points: Option<PathBuf>,
    /// A regular grid of sensors facing +normal on a rectangle instead of --points:
    /// `CORNER_X,CORNER_Y,CORNER_Z,U_X,U_Y,U_Z,V_X,V_Y,V_Z,NU,NV`: cells of the rectangle spanned by the
    /// edges U and V from the corner, NU × NV of them, a sensor at each cell's centre facing U × V.
    #[arg(long, value_name = "SPEC", conflicts_with = "points", allow_hyphen_values = true)]
    grid: Option<String>,
    /// Output CSV: name,x,y,z,nx,ny,nz (the sensor columns), then illuminance_lux, std_error_lux, X, Y, Z, cct_k, samples
    /// [default: standard output].
    #[arg(short, long, value_name = "CSV")]
    output: Option<PathBuf>,
    /// With --grid: also write the grid's illuminance in false colour on a logarithmic scale, with a
    /// legend in lux, as a PNG.
    #[arg(long, value_name = "FILE.png", requires = "grid")]
    false_color: Option<PathBuf>,
    /// Exactly N samples per point (otherwise each point samples to --target-error).
    #[arg(long, value_name = "N", conflicts_with = "target_error")]
    spp: Option<u32>,
    /// Relative standard error each point samples to, in percent [default: 1].
    #[arg(long, value_name = "PCT")]
    target_error: Option<f64>,
    /// The most samples a point takes to reach --target-error [default: 4194304].
    #[arg(long, value_name = "N")]
    max_spp: Option<u32>,
    /// Stop after this many seconds; unfinished points report what they have, marked in a note.
    #[arg(long, value_name = "S")]
    time_limit: Option<f64>,
    /// Seed of the random numbers: the same seed gives the same numbers at any thread count.
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Worker threads [default: all cores].
    #[arg(long)]
    threads: Option<usize>,
    /// Wavelength sampling: hero:8 or hero:4 (unbiased for any spectrum), bins:N or rgb.
    #[arg(long, default_value = "hero:8")]
    spectral: SpectralMode,
    /// No progress bar or notes on stderr.
    #[arg(short, long)]
    quiet: bool,
    #[command(flatten)]
    load: crate::render::LoadArgs,
    #[command(flatten)]
    camera: crate::view::CameraArgs,
    #[command(flatten)]
    env: crate::view::EnvArgs,
}

pub(crate) fn run(args: &MeasureArgs) -> anyhow::Result<()> {
    args.load.check_scene(args.scene.as_deref())?;
    // A grid's cell counts, for its picture.
    let (points, grid) = match (&args.points, &args.grid) {
        (Some(path), _) => (read_points(path, args.quiet)?, None),
        (None, Some(spec)) => {
            let (points, nu, nv) = grid_points(spec)?;
            (points, Some((nu, nv)))
        }
        (None, None) => bail!("give --points CSV or --grid SPEC"),
    };
    if args.false_color.is_some() && args.output.is_none() {
        bail!("--false-color goes with -o OUT.csv (the CSV is the measurement; the picture shows it)");
    }
    if let Some(output) = &args.output {
        let mut inputs: Vec<(&Path, &str)> = Vec::new();
        if let Some(p) = &args.points {
            inputs.push((p, "the points file"));
        }
        if let Some(s) = &args.scene {
            inputs.push((s, "the scene file"));
        }
        let outputs: Vec<&Path> = [Some(output.as_path()), args.false_color.as_deref()].into_iter().flatten().collect();
        integrator::check_outputs_spare_inputs(&outputs, &inputs)?;
    }
    let mut assembly = args.camera.assembly((None, None));
    args.env.apply(&mut assembly)?;
    let scene = match &args.scene {
        Some(path) => {
            let desc = geometry::load_scene_with(path, &args.load.options())?;
            RenderScene::from_description_with(desc, &assembly)
                .with_context(|| format!("assembling {}", path.display()))?
        }
        None => {
            let desc = RenderScene::default_description().context("building the default scene")?;
            RenderScene::from_description_with(desc, &assembly).context("assembling the default scene")?
        }
    };
    if !args.quiet {
        for w in &scene.warnings {
            eprintln!("spectrace: note: {w}");
        }
        if !scene.has_photometric_lights() {
            eprintln!(
                "spectrace: note: no light is in photometric units: the values are Y in the scene's units, not lux"
            );
        }
    }
    let target = args.target_error.unwrap_or(1.0);
    if !(target > 0.0 && target.is_finite()) {
        bail!("--target-error {target}: expected a percentage > 0");
    }
    let defaults = MeasureOptions::default();
    let options = MeasureOptions {
        spp: args.spp,
        target_relative_error: target / 100.0,
        max_spp: args.max_spp.unwrap_or(defaults.max_spp),
        time_limit: match args.time_limit {
            Some(s) if s > 0.0 && s.is_finite() => Some(Duration::from_secs_f64(s)),
            Some(s) => bail!("--time-limit {s}: expected seconds > 0"),
            None => None,
        },
        seed: args.seed,
        threads: args.threads,
        spectral: args.spectral,
        ..defaults
    };
    let cancel = Arc::new(AtomicBool::new(false));
    {
        let cancel = Arc::clone(&cancel);
        let _ = ctrlc::set_handler(move || cancel.store(true, Ordering::SeqCst));
    }
    let bar = if args.quiet { ProgressBar::hidden() } else { ProgressBar::new(points.len() as u64) };
    bar.set_style(
        ProgressStyle::with_template("{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} points")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let result = integrator::measure(&scene, &points, &options, &|n| bar.set_position(n as u64), &cancel);
    bar.finish_and_clear();
    let results = match result {
        Err(integrator::Error::Cancelled) => bail!("interrupted; nothing was written"),
        other => other?,
    };
    let nonfinite: u64 = results.iter().map(|m| m.nonfinite).sum();
    if nonfinite > 0 {
        eprintln!("spectrace: warning: {nonfinite} samples were not finite and were counted as 0");
    }
    let late = results.iter().filter(|m| m.timed_out).count();
    if late > 0 && !args.quiet {
        eprintln!(
            "spectrace: note: the time limit stopped {late} of {} points before their target; their std_error_lux says how far they got",
            results.len()
        );
    }
    let text = to_csv(&points, &results);
    match (&args.output, &args.false_color, grid) {
        (Some(csv), Some(png), Some((nu, nv))) => {
            if nu.max(nv) > MAX_PICTURE_SIDE {
                bail!(
                    "--false-color: the grid has {}×{} cells; a picture is drawn of at most {MAX_PICTURE_SIDE} a side",
                    nu,
                    nv
                );
            }
            // Rows of the picture run along V from the far edge, so V points up as on a plan.
            let values: Vec<f32> = (0..nv)
                .rev()
                .flat_map(|j| (0..nu).map(move |i| j * nu + i))
                .map(|k| results[k].illuminance as f32)
                .collect();
            let cell = (512 / nu.max(nv)).max(1);
            let picture =
                integrator::false_color_png(&values, nu, nv, cell, None, "lux").map_err(anyhow::Error::msg)?;
            integrator::write_files_atomically(&[(csv, text.as_bytes()), (png, &picture)])?;
        }
        (Some(path), ..) => integrator::write_bytes_atomically(path, text.as_bytes())?,
        (None, ..) => crate::write_stdout(&text)?,
    }
    Ok(())
}

/// The output CSV: the sensor columns and the measurement.
fn to_csv(points: &[SensorPoint], results: &[Measurement]) -> String {
    let mut out = String::from("name,x,y,z,nx,ny,nz,illuminance_lux,std_error_lux,X,Y,Z,cct_k,samples\n");
    for (p, m) in points.iter().zip(results) {
        let cct = m.cct().map_or(String::new(), |t| format!("{t:.0}"));
        out += &format!(
            "{},{},{},{},{},{},{},{:.6e},{:.3e},{:.6e},{:.6e},{:.6e},{},{}\n",
            csv_field(&p.name),
            p.position.x,
            p.position.y,
            p.position.z,
            p.normal.x,
            p.normal.y,
            p.normal.z,
            m.illuminance,
            m.std_error,
            m.xyz[0],
            m.xyz[1],
            m.xyz[2],
            cct,
            m.samples
        );
    }
    out
}

/// A name as a CSV field: quoted when it holds a comma, quote or line break.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) { format!("\"{}\"", s.replace('"', "\"\"")) } else { s.to_owned() }
}

/// Read a points file: a header naming the columns, then one point per line; errors name the file and line.
fn read_points(path: &Path, quiet: bool) -> anyhow::Result<Vec<SensorPoint>> {
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    // A spreadsheet's UTF-8 byte-order mark is not part of the first column's name.
    let text = text.strip_prefix('\u{feff}').unwrap_or(&text);
    if !quiet && let Some(header) = text.lines().find(|l| !l.trim().is_empty()) {
        let extra: Vec<&str> = header
            .split(',')
            .map(|c| c.trim().trim_matches('"'))
            .filter(|c| !COLUMNS.contains(&c.to_ascii_lowercase().as_str()))
            .collect();
        if !extra.is_empty() {
            eprintln!("spectrace: note: {}: columns {} are not read", path.display(), extra.join(", "));
        }
    }
    parse_points(text).map_err(|(line, message)| anyhow::anyhow!("{}:{line}: {message}", path.display()))
}

/// The points of a CSV text, or (line, message).
fn parse_points(text: &str) -> Result<Vec<SensorPoint>, (usize, String)> {
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let Some((h, header)) = lines.next() else {
        return Err((1, "empty file: expected a header name,x,y,z,nx,ny,nz".into()));
    };
    let names: Vec<String> = header.split(',').map(|s| s.trim().trim_matches('"').to_ascii_lowercase()).collect();
    let mut index = [0usize; 7];
    for (k, column) in COLUMNS.iter().enumerate() {
        index[k] = names.iter().position(|n| n == column).ok_or_else(|| {
            (
                h + 1,
                format!("no column `{column}` in the header (expected name,x,y,z,nx,ny,nz; found {})", names.join(",")),
            )
        })?;
    }
    let mut points = Vec::new();
    for (i, line) in lines {
        let fields = split_csv(line);
        if fields.len() != names.len() {
            return Err((i + 1, format!("{} fields, the header has {}", fields.len(), names.len())));
        }
        let number = |k: usize| -> Result<f32, (usize, String)> {
            let s = fields[index[k]].trim();
            match s.parse::<f32>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err((i + 1, format!("`{}` = {s:?} is not a finite number", COLUMNS[k]))),
            }
        };
        let position = Vec3::new(number(1)?, number(2)?, number(3)?);
        let normal = Vec3::new(number(4)?, number(5)?, number(6)?);
        if normal.length_squared() == 0.0 || !normal.length_squared().is_finite() {
            return Err((i + 1, "the normal (nx, ny, nz) is zero: it says which side the sensor faces".into()));
        }
        if points.len() == MAX_POINTS {
            return Err((i + 1, format!("more than {MAX_POINTS} points")));
        }
        points.push(SensorPoint { name: fields[index[0]].clone(), position, normal });
    }
    if points.is_empty() {
        return Err((h + 1, "no points after the header".into()));
    }
    Ok(points)
}

/// One CSV line's fields, with double-quoted fields (and "" inside them) understood.
fn split_csv(line: &str) -> Vec<String> {
    let mut fields = Vec::new();
    let mut field = String::new();
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '"' if quoted && chars.peek() == Some(&'"') => {
                chars.next();
                field.push('"');
            }
            '"' => quoted = !quoted,
            ',' if !quoted => fields.push(std::mem::take(&mut field)),
            c => field.push(c),
        }
    }
    fields.push(field);
    fields
}

/// The sensors of `--grid CORNER,U,V,NU,NV` (11 numbers), row by row along U, and (NU, NV).
fn grid_points(spec: &str) -> anyhow::Result<(Vec<SensorPoint>, usize, usize)> {
    let v: Vec<f64> = spec
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--grid {spec}: expected 11 numbers"))?;
    let [cx, cy, cz, ux, uy, uz, vx, vy, vz, nu, nv] = v.as_slice() else {
        bail!(
            "--grid {spec}: expected 11 numbers (corner, edge U, edge V, cells along U, cells along V), got {}",
            v.len()
        )
    };
    let (corner, u, w) = (
        Vec3::new(*cx as f32, *cy as f32, *cz as f32),
        Vec3::new(*ux as f32, *uy as f32, *uz as f32),
        Vec3::new(*vx as f32, *vy as f32, *vz as f32),
    );
    let normal = u.cross(w);
    if !(corner.is_finite() && normal.is_finite() && normal.length_squared() > 0.0) {
        bail!("--grid {spec}: the edges must be finite and not parallel");
    }
    let whole = |x: f64| x >= 1.0 && x.fract() == 0.0 && x <= MAX_POINTS as f64;
    if !(whole(*nu) && whole(*nv) && nu * nv <= MAX_POINTS as f64) {
        bail!("--grid {spec}: the cell counts must be whole numbers ≥ 1, at most {MAX_POINTS} points in all");
    }
    let (nu, nv) = (*nu as usize, *nv as usize);
    let mut points = Vec::with_capacity(nu * nv);
    for j in 0..nv {
        for i in 0..nu {
            let p = corner + u * ((i as f32 + 0.5) / nu as f32) + w * ((j as f32 + 0.5) / nv as f32);
            points.push(SensorPoint { name: format!("{i}_{j}"), position: p, normal });
        }
    }
    Ok((points, nu, nv))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_files_are_read_by_header_and_refused_with_the_line() {
        let p = parse_points("x,y,z,name,nx,ny,nz\n1,2,3,\"a, b\",0,0,2\n\n4,5,6,c,1,0,0\n")
            .unwrap_or_else(|e| panic!("{e:?}"));
        assert_eq!(p.len(), 2);
        assert_eq!(
            (p[0].name.as_str(), p[0].position, p[0].normal),
            ("a, b", Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.0, 0.0, 2.0))
        );
        assert_eq!(p[1].name, "c");
        for (text, line, says) in [
            ("", 1, "empty"),
            ("name,x,y,z,nx,ny\n", 1, "no column `nz`"),
            ("name,x,y,z,nx,ny,nz\na,1,2,3,0,0\n", 2, "6 fields"),
            ("name,x,y,z,nx,ny,nz\na,1,2,3,0,0,1\nb,1,NaN,3,0,0,1\n", 3, "`y`"),
            ("name,x,y,z,nx,ny,nz\na,1,2,3,0,0,0\n", 2, "zero"),
            ("name,x,y,z,nx,ny,nz\n", 1, "no points"),
        ] {
            let (l, m) = parse_points(text).err().unwrap_or_else(|| panic!("{text:?} was read"));
            assert!(l == line && m.contains(says), "{text:?}: line {l}: {m}");
        }
    }

    #[test]
    fn a_grid_puts_a_sensor_at_each_cell_centre_facing_u_cross_v() {
        let (g, nu, nv) = grid_points("0,0,0.8, 4,0,0, 0,4,0, 4,2").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((g.len(), nu, nv), (8, 4, 2));
        assert_eq!(g[0].position, Vec3::new(0.5, 1.0, 0.8));
        assert_eq!(g[7].position, Vec3::new(3.5, 3.0, 0.8));
        assert!(g.iter().all(|p| p.normal.normalize() == Vec3::Z));
        assert!(grid_points("0,0,0,1,0,0,2,0,0,2,2").is_err(), "parallel edges");
        assert!(grid_points("0,0,0,1,0,0,0,1,0,2.5,2").is_err(), "fractional count");
        assert!(grid_points("0,0,0,1,0,0,0,1,0,2").is_err(), "ten numbers");
    }

    #[test]
    fn csv_output_quotes_names_and_leaves_an_undefined_cct_empty() {
        let p = [SensorPoint { name: "a,b".into(), position: Vec3::ZERO, normal: Vec3::Z }];
        let m = [Measurement {
            illuminance: 0.0,
            std_error: 0.0,
            xyz: [0.0; 3],
            samples: 4096,
            timed_out: false,
            nonfinite: 0,
        }];
        let text = to_csv(&p, &m);
        assert_eq!(
            text.lines().nth(1),
            Some("\"a,b\",0,0,0,0,0,1,0.000000e0,0.000e0,0.000000e0,0.000000e0,0.000000e0,,4096")
        );
    }
}
