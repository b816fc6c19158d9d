//! `spectrace color`: colour math from the command line, so the colorimetry can be checked
//! from outside (against published tables or another implementation).

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use colorimetry::{
    DenselySampledSpectrum, Illuminant, Integration, Observer, RgbColorSpace, Xyz, bradford, quantize_u8,
    read_spectra_csv, reflectance_to_xyz, srgb_encode,
};

/// Arguments of `spectrace color`.
#[derive(Debug, clap::Args)]
pub(crate) struct ColorArgs {
    /// CSV file: header line, first column wavelength in nm, one column per spectrum
    /// (reflectances in [0, 1]). Linear between rows; outside the file's range the first and
    /// last values are held (CIE / colour-science convention, as for the built-in tables).
    reflectance: PathBuf,
    /// Only this column (default: every column).
    #[arg(long)]
    column: Option<String>,
    /// Illuminant: D65, D50, A, F2, F11, E, daylight by temperature (D9300), Planck by
    /// temperature (bb3000), or a CSV file with the SPD in its first spectrum column (its end
    /// values held outside its range, like the reflectances).
    #[arg(long, default_value = "D65")]
    illuminant: String,
    /// Observer: 2 (CIE 1931) or 10 (CIE 1964).
    #[arg(long, default_value = "2", value_parser = parse_observer)]
    observer: Observer,
    /// Wavelength step in nm: the tables are resampled to 360, 360+step, … 830 nm before summing.
    #[arg(long, default_value_t = 1.0)]
    step: f64,
}

fn parse_observer(s: &str) -> Result<Observer, String> {
    match s {
        "2" => Ok(Observer::Cie1931),
        "10" => Ok(Observer::Cie1964),
        _ => Err(format!("expected 2 or 10, got `{s}`")),
    }
}

/// An illuminant by name, or the first spectrum of a CSV file when the argument names a file.
fn illuminant(name: &str) -> anyhow::Result<DenselySampledSpectrum> {
    let path = Path::new(name);
    if path.extension().is_some_and(|e| e.eq_ignore_ascii_case("csv")) || path.is_file() {
        let table = read_spectra_csv(path)?;
        let first = table.into_iter().next().with_context(|| format!("{}: no spectrum column", path.display()))?;
        return Ok(first.spectrum.held_to_visible());
    }
    Ok(Illuminant::parse(name)?.spectrum()?)
}

pub(crate) fn run(args: &ColorArgs) -> anyhow::Result<()> {
    if !(args.step > 0.0 && args.step <= 100.0) {
        anyhow::bail!("--step {} is out of range (0, 100] nm", args.step);
    }
    let illuminant = illuminant(&args.illuminant).with_context(|| format!("illuminant `{}`", args.illuminant))?;
    let spectra: Vec<_> = read_spectra_csv(&args.reflectance)?
        .into_iter()
        .map(|s| colorimetry::NamedSpectrum { spectrum: s.spectrum.held_to_visible(), name: s.name })
        .collect();
    let selected: Vec<_> = match &args.column {
        Some(c) => {
            let found: Vec<_> = spectra.iter().filter(|s| &s.name == c).collect();
            if found.is_empty() {
                let names: Vec<&str> = spectra.iter().map(|s| s.name.as_str()).collect();
                anyhow::bail!("{}: no column `{c}` (columns: {})", args.reflectance.display(), names.join(", "));
            }
            found
        }
        None => spectra.iter().collect(),
    };
    let integration = Integration::Step(args.step);
    let white = reflectance_to_xyz(&DenselySampledSpectrum::constant(1.0), &illuminant, args.observer, &integration);
    // sRGB's white is D65 (x, y = 0.3127, 0.3290, IEC 61966-2-1): adapt other whites to it.
    // The CIE D65 table's own white (0.31272, 0.32903) is adapted too, by a matrix within
    // 3e-4 of identity (measured 2.2e-4), so that a perfect reflector under D65 is exactly
    // sRGB (1, 1, 1).
    let srgb = RgbColorSpace::srgb();
    let d65 = Xyz::from_xy_y(srgb.white(), 100.0);
    let adapt = bradford(white, d65);
    let mut out = String::new();
    for s in selected {
        let xyz = reflectance_to_xyz(&s.spectrum, &illuminant, args.observer, &integration);
        let linear = srgb.xyz_to_rgb(xyz.transformed(adapt).scaled(0.01));
        let rgb = [linear.r, linear.g, linear.b];
        let json = serde_json::json!({
            "name": s.name,
            "XYZ": [xyz.x, xyz.y, xyz.z],
            "xy": xyz.chromaticity(),
            "srgb_linear": rgb,
            "srgb8": rgb.map(|c| quantize_u8(srgb_encode(c))),
        });
        out.push_str(&json.to_string());
        out.push('\n');
    }
    print!("{out}");
    Ok(())
}
