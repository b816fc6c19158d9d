//! `spectrace color`: colour math from the command line, so the colorimetry can be checked
//! from outside (against published tables or another implementation).

use std::path::{Path, PathBuf};

use anyhow::Context as _;
use colorimetry::{
    DenselySampledSpectrum, Illuminant, Integration, MIN_STEP_NM, NamedSpectrum, Observer, RgbColorSpace, Xyz,
    bradford, emission_to_xyz, quantize_u8, read_spectra_csv, reflectance_to_xyz, srgb_encode,
};
use materials::Fluorescence;

/// Arguments of `spectrace color`.
#[derive(Debug, clap::Args)]
pub(crate) struct ColorArgs {
    /// CSV file: header line, first column wavelength in nm, one column per spectrum
    /// (reflectances in [0, 1]). Linear between rows; outside the file's range the first and
    /// last values are held (CIE / colour-science convention, as for the built-in tables).
    /// Optional with `--matrix`, whose diagonal is the reflectance.
    #[arg(required_unless_present = "matrix")]
    reflectance: Option<PathBuf>,
    /// Fluorescence: a CSV whose first spectrum column is the excitation a(λ_in) in [0, 1] (the
    /// fraction absorbed for re-emission; read over its own range, down to 300 nm). Needs
    /// `--emission` and `--yield`; the colour is then that of the reflected plus re-emitted light
    /// (`docs/fluorescence.md`).
    #[arg(long, requires_all = ["emission", "quantum_yield"], conflicts_with = "matrix")]
    excitation: Option<PathBuf>,
    /// Fluorescence: a CSV whose first spectrum column is the emission's shape (normalised to unit area).
    #[arg(long, requires = "excitation")]
    emission: Option<PathBuf>,
    /// Fluorescence: the quantum yield in [0, 1] (photons emitted per photon absorbed).
    #[arg(long = "yield", requires = "excitation")]
    quantum_yield: Option<f32>,
    /// Fluorescence: a re-radiation (Donaldson) matrix CSV, rows λ_in, columns λ_out, energy fractions;
    /// its diagonal is the reflectance.
    #[arg(long, conflicts_with = "reflectance")]
    matrix: Option<PathBuf>,
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
    /// Wavelength step in nm, 0.001 to 100: the tables are resampled to 360, 360+step, … 830 nm
    /// before summing.
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
        return held(first, path);
    }
    Ok(Illuminant::parse(name)?.spectrum()?)
}

/// A file's column extended to 360–830 nm; the error names the file and the column (a
/// spectrum that misses the visible range, or whose extension is too large a grid).
fn held(column: NamedSpectrum, path: &Path) -> anyhow::Result<DenselySampledSpectrum> {
    column.spectrum.held_to_visible().with_context(|| format!("{}: column `{}`", path.display(), column.name))
}

/// `--excitation`, `--emission` and `--yield` as a kernel (clap makes them come together).
fn fluorescence_spectra(args: &ColorArgs) -> anyhow::Result<Option<Fluorescence>> {
    let (Some(excitation), Some(emission), Some(q)) = (&args.excitation, &args.emission, args.quantum_yield) else {
        return Ok(None);
    };
    let first = |path: &Path| -> anyhow::Result<DenselySampledSpectrum> {
        let table = read_spectra_csv(path)?;
        let first = table.into_iter().next().with_context(|| format!("{}: no spectrum column", path.display()))?;
        Ok(first.spectrum)
    };
    let f = Fluorescence::from_spectra(first(excitation)?, &first(emission)?, q).with_context(|| {
        format!("--excitation {} --emission {} --yield {q}", excitation.display(), emission.display())
    })?;
    Ok(Some(f))
}

/// The coarsest `--step` (nm): a sum over the visible range needs a few nodes at least.
const MAX_STEP_NM: f64 = 100.0;

pub(crate) fn run(args: &ColorArgs) -> anyhow::Result<()> {
    // The finest step is the library's own bound (`--step 1e-9` once asked for 7.5 TB of
    // integration nodes); the coarsest is this command's.
    let Some(integration) = Integration::step(args.step).ok().filter(|_| args.step <= MAX_STEP_NM) else {
        anyhow::bail!("--step {} is out of range [{MIN_STEP_NM}, {MAX_STEP_NM}] nm", colorimetry::Num(args.step));
    };
    let illuminant = illuminant(&args.illuminant).with_context(|| format!("illuminant `{}`", args.illuminant))?;
    let (fluorescence, spectra, source) = match (&args.reflectance, &args.matrix) {
        (_, Some(matrix)) => {
            let (f, diagonal) = Fluorescence::from_matrix_csv(matrix)?;
            (Some(f), vec![NamedSpectrum { name: "diagonal".into(), spectrum: diagonal }], matrix)
        }
        (Some(path), None) => {
            let spectra = read_spectra_csv(path)?
                .into_iter()
                .map(|s| Ok(NamedSpectrum { name: s.name.clone(), spectrum: held(s, path)? }))
                .collect::<anyhow::Result<Vec<_>>>()?;
            (fluorescence_spectra(args)?, spectra, path)
        }
        (None, None) => anyhow::bail!("give a reflectance CSV or --matrix"),
    };
    let selected: Vec<_> = match &args.column {
        Some(c) => {
            let found: Vec<_> = spectra.iter().filter(|s| &s.name == c).collect();
            if found.is_empty() {
                let names: Vec<&str> = spectra.iter().map(|s| s.name.as_str()).collect();
                anyhow::bail!("{}: no column `{c}` (columns: {})", source.display(), names.join(", "));
            }
            found
        }
        None => spectra.iter().collect(),
    };
    let white = reflectance_to_xyz(&DenselySampledSpectrum::constant(1.0), &illuminant, args.observer, &integration);
    if !(white.y > 0.0 && white.y.is_finite()) {
        // An illuminant that is black over 360–830 nm has no white to normalise or adapt to
        // (the Bradford matrix would be 0/0 and the JSON would print `null`).
        anyhow::bail!("illuminant `{}`: no light in 360–830 nm (its white has Y = {})", args.illuminant, white.y);
    }
    // sRGB's white is D65 (x, y = 0.3127, 0.3290, IEC 61966-2-1): adapt other whites to it.
    // The CIE D65 table's own white (0.31272, 0.32903) is adapted too, by a matrix within
    // 3e-4 of identity (measured 2.2e-4), so that a perfect reflector under D65 is exactly
    // sRGB (1, 1, 1).
    let srgb = RgbColorSpace::srgb();
    let d65 = Xyz::from_xy_y(srgb.white(), 100.0);
    let adapt = bradford(white, d65);
    let mut out = String::new();
    // The re-emitted light in the units of the reflected: 100 / Σ E ȳ Δλ, as `reflectance_to_xyz` scales.
    let reemitted = fluorescence.as_ref().map(|f| {
        let e = emission_to_xyz(&illuminant, args.observer, &integration);
        emission_to_xyz(&f.reemitted_radiance(&illuminant), args.observer, &integration).scaled(100.0 / e.y)
    });
    for s in selected {
        if let Some(f) = &fluorescence {
            f.check_energy(&s.spectrum).with_context(|| format!("{}: column `{}`", source.display(), s.name))?;
        }
        let mut xyz = reflectance_to_xyz(&s.spectrum, &illuminant, args.observer, &integration);
        if let Some(r) = reemitted {
            xyz = Xyz { x: xyz.x + r.x, y: xyz.y + r.y, z: xyz.z + r.z };
        }
        let linear = srgb.xyz_to_rgb(xyz.transformed(adapt).scaled(0.01));
        let rgb = [linear.r, linear.g, linear.b];
        // Spectra read from files are bounded (values at most 1e30), so this holds; a JSON `null`
        // must never be printed as if it were a colour.
        if ![xyz.x, xyz.y, xyz.z, rgb[0], rgb[1], rgb[2]].iter().all(|v| v.is_finite()) {
            anyhow::bail!("{}: column `{}`: the colour is not finite", source.display(), s.name);
        }
        let json = serde_json::json!({
            "name": s.name,
            "XYZ": [xyz.x, xyz.y, xyz.z],
            "reemitted_XYZ": reemitted.map(|r| [r.x, r.y, r.z]),
            "xy": xyz.chromaticity(),
            "srgb_linear": rgb,
            "srgb8": rgb.map(|c| quantize_u8(srgb_encode(c))),
        });
        out.push_str(&json.to_string());
        out.push('\n');
    }
    crate::write_stdout(&out)
}
