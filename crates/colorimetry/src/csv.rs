//! CSV spectra: a header line, the wavelength in nm in the first column, one column per
//! spectrum. Lines starting with `#` are comments; blank lines are skipped (both are still
//! counted, so errors name the file's own line). Every error names the file and the line.
//!
//! Hostile files are bounded before anything large is allocated: the file size
//! ([`MAX_CSV_BYTES`], regular files only), the column count ([`MAX_CSV_COLUMNS`]), the
//! values held ([`MAX_TABLE_SAMPLES`]), the values themselves ([`MAX_SPECTRUM_VALUE`]) and the
//! wavelength grid ([`crate::MIN_STEP_NM`], [`crate::MAX_WAVELENGTH_NM`],
//! [`crate::MAX_SPECTRUM_SAMPLES`]).

use std::io::Read as _;
use std::path::Path;

use crate::error::{Error, Result};
use crate::spectrum::{DenselySampledSpectrum, MAX_SPECTRUM_SAMPLES, MAX_WAVELENGTH_NM, MIN_STEP_NM};

/// Largest spectra file read (bytes): 64 MiB. A 1 nm table of the whole Munsell book (1 269
/// columns × 471 rows × ~8 characters) is under 5 MiB; a 100 MB header once peaked at 4.1 GB.
pub const MAX_CSV_BYTES: u64 = 64 << 20;

/// Most columns a spectra table may have (the wavelength column included): 4096, three times
/// the Munsell book's 1 269 chips.
pub const MAX_CSV_COLUMNS: usize = 4096;

/// Most values one table may hold, after resampling uneven rows to 1 nm: 2²⁴ f64 = 128 MiB.
pub const MAX_TABLE_SAMPLES: usize = 1 << 24;

/// Largest magnitude of a spectral value: 1e30. Radiance in photons s⁻¹ m⁻² sr⁻¹ nm⁻¹ of the
/// Sun is ~1e22, so real data fits with margin, while a product of two such values summed
/// over [`MAX_SPECTRUM_SAMPLES`] stays far inside f64 (values of 1e308 made XYZ infinite and
/// printed `null`), and one value stays inside f32 (3.4e38, the renderer's lanes).
pub const MAX_SPECTRUM_VALUE: f64 = 1e30;

/// One named column of a spectra table.
#[derive(Debug, Clone, PartialEq)]
pub struct NamedSpectrum {
    /// The column header.
    pub name: String,
    /// The values, on the file's own grid when evenly spaced.
    pub spectrum: DenselySampledSpectrum,
}

/// Parse spectra from CSV text; `origin` names the source in errors. Values must be finite,
/// non-negative and at most [`MAX_SPECTRUM_VALUE`]; wavelengths strictly increasing, at least
/// [`MIN_STEP_NM`] apart and in (0, [`MAX_WAVELENGTH_NM`]] nm.
pub fn parse_spectra_csv(text: &str, origin: &str) -> Result<Vec<NamedSpectrum>> {
    parse(text, origin, false)
}

/// Read and parse a CSV spectra file (see [`parse_spectra_csv`]). Only a regular file of at
/// most [`MAX_CSV_BYTES`] is read (no devices such as `/dev/zero`, no FIFOs).
pub fn read_spectra_csv(path: &Path) -> Result<Vec<NamedSpectrum>> {
    let origin = path.display().to_string();
    let io = |source| Error::Io { path: origin.clone(), source };
    // `metadata` follows symbolic links and does not block (opening a FIFO would).
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        return Err(Error::NotReadable { path: origin, reason: "not a regular file".to_owned() });
    }
    let too_large = |bytes: u64| Error::NotReadable {
        path: origin.clone(),
        reason: format!("{bytes} bytes, more than the limit for a spectra file ({MAX_CSV_BYTES} bytes)"),
    };
    if meta.len() > MAX_CSV_BYTES {
        return Err(too_large(meta.len()));
    }
    // Read at most one byte past the limit, in case the file grew since `metadata`.
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    std::fs::File::open(path).and_then(|f| f.take(MAX_CSV_BYTES + 1).read_to_end(&mut bytes)).map_err(io)?;
    if bytes.len() as u64 > MAX_CSV_BYTES {
        return Err(too_large(bytes.len() as u64));
    }
    let text = String::from_utf8(bytes)
        .map_err(|e| io(std::io::Error::new(std::io::ErrorKind::InvalidData, e.utf8_error())))?;
    parse_spectra_csv(&text, &origin)
}

/// A cell as quoted in an error: at most 40 characters, so a hostile megabyte-long cell does
/// not become a megabyte-long message.
fn quoted(cell: &str) -> String {
    match cell.char_indices().nth(40) {
        Some((end, _)) => format!("{}…", &cell[..end]),
        None => cell.to_owned(),
    }
}

/// The parser; `allow_negative` for internal tables that have signed values (the CIE
/// daylight basis functions S1, S2).
pub(crate) fn parse(text: &str, origin: &str, allow_negative: bool) -> Result<Vec<NamedSpectrum>> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text.lines().enumerate().filter(|(_, l)| {
        let l = l.trim_start();
        !l.is_empty() && !l.starts_with('#')
    });
    let Some((_, header)) = lines.next() else {
        return Err(Error::Empty { origin: origin.to_owned() });
    };
    // Counted before anything per column is allocated.
    let columns = header.split(',').count();
    if columns > MAX_CSV_COLUMNS {
        return Err(Error::TooManyColumns { origin: origin.to_owned(), columns, limit: MAX_CSV_COLUMNS });
    }
    let names: Vec<String> = header.split(',').map(|c| c.trim().to_owned()).collect();
    if names.len() < 2 {
        return Err(Error::NoColumns { origin: origin.to_owned() });
    }
    let mut lambdas: Vec<f64> = Vec::new();
    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); names.len() - 1];
    let mut last_line = 0;
    for (index, line) in lines {
        let line_no = index + 1;
        last_line = line_no;
        if (lambdas.len() + 1) * (names.len() - 1) > MAX_TABLE_SAMPLES {
            return Err(Error::TooManySamples {
                origin: format!("{origin}:{line_no}"),
                samples: ((lambdas.len() + 1) * (names.len() - 1)) as f64,
                limit: MAX_TABLE_SAMPLES,
            });
        }
        let cells = line.split(',').map(str::trim);
        let found = cells.clone().count();
        if found != names.len() {
            return Err(Error::Ragged { origin: origin.to_owned(), line: line_no, found, expected: names.len() });
        }
        let mut lambda = 0.0;
        for (c, (cell, name)) in cells.zip(&names).enumerate() {
            let v: f64 = cell.parse().map_err(|_| Error::NotANumber {
                origin: origin.to_owned(),
                line: line_no,
                column: quoted(name),
                cell: quoted(cell),
            })?;
            if !v.is_finite() {
                return Err(Error::NotFinite {
                    origin: origin.to_owned(),
                    line: line_no,
                    column: quoted(name),
                    value: v,
                });
            }
            if c == 0 {
                lambda = check_wavelength(v, lambdas.last().copied(), origin, line_no)?;
                continue;
            }
            if v < 0.0 && !allow_negative {
                return Err(Error::Negative {
                    origin: origin.to_owned(),
                    line: line_no,
                    column: quoted(name),
                    value: v,
                });
            }
            if v.abs() > MAX_SPECTRUM_VALUE {
                return Err(Error::ValueTooLarge {
                    origin: origin.to_owned(),
                    line: line_no,
                    column: quoted(name),
                    value: v,
                    max: MAX_SPECTRUM_VALUE,
                });
            }
            columns[c - 1].push(v);
        }
        lambdas.push(lambda);
    }
    if lambdas.is_empty() {
        return Err(Error::Empty { origin: origin.to_owned() });
    }
    // Uneven rows are resampled at every whole nanometre: bound the whole table before the
    // columns are built (each column is checked again on its own).
    let resampled = (lambdas[lambdas.len() - 1].floor() - lambdas[0].ceil() + 1.0).max(lambdas.len() as f64);
    let total = resampled.min(MAX_SPECTRUM_SAMPLES as f64) * columns.len() as f64;
    if total > MAX_TABLE_SAMPLES as f64 {
        return Err(Error::TooManySamples {
            origin: format!("{origin}:{last_line}: table resampled at 1 nm"),
            samples: total,
            limit: MAX_TABLE_SAMPLES,
        });
    }
    names[1..]
        .iter()
        .zip(columns)
        .map(|(name, values)| {
            let spectrum = DenselySampledSpectrum::from_samples_in(
                &format!("{origin}: column `{}`", quoted(name)),
                &lambdas,
                &values,
            )?;
            Ok(NamedSpectrum { name: name.clone(), spectrum })
        })
        .collect()
}

/// A row's wavelength: > 0, at most [`MAX_WAVELENGTH_NM`], after the previous one by at least
/// [`MIN_STEP_NM`].
fn check_wavelength(lambda: f64, previous: Option<f64>, origin: &str, line: usize) -> Result<f64> {
    if lambda <= 0.0 {
        return Err(Error::BadWavelength { origin: origin.to_owned(), line, lambda });
    }
    if lambda > MAX_WAVELENGTH_NM {
        return Err(Error::WavelengthTooLong { origin: origin.to_owned(), line, lambda, max: MAX_WAVELENGTH_NM });
    }
    if let Some(previous) = previous {
        if !(lambda > previous) {
            return Err(Error::Unsorted { origin: origin.to_owned(), line, lambda, previous });
        }
        if lambda - previous < MIN_STEP_NM {
            return Err(Error::RowsTooClose { origin: origin.to_owned(), line, lambda, previous, min: MIN_STEP_NM });
        }
    }
    Ok(lambda)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_columns_on_their_own_grid() {
        let t = parse_spectra_csv("wavelength_nm,a,b\n400,0.1,1\n410,0.2,2\n420,0.3,3\n", "t.csv").unwrap();
        assert_eq!(t.len(), 2);
        assert_eq!(t[1].name, "b");
        assert_eq!(t[0].spectrum.step(), 10.0);
        assert!((t[0].spectrum.eval(415.0) - 0.25).abs() < 1e-12);
    }

    #[test]
    fn each_bad_input_is_a_precise_error() {
        let e = |text: &str| parse_spectra_csv(text, "x.csv").unwrap_err();
        assert!(matches!(e(""), Error::Empty { .. }));
        assert!(matches!(e("wavelength_nm,a\n"), Error::Empty { .. }));
        assert!(matches!(e("wavelength_nm\n400\n"), Error::NoColumns { .. }));
        let unsorted = e("wavelength_nm,a\n400,1\n550,1\n545,1\n");
        assert!(matches!(unsorted, Error::Unsorted { line: 4, .. }));
        assert_eq!(unsorted.to_string(), "x.csv:4: wavelength 545 nm after 550 nm (must increase)");
        assert!(matches!(e("wavelength_nm,a\n400,1\n400,1\n"), Error::Unsorted { line: 3, .. }));
        let nan = e("wavelength_nm,a\n400,NaN\n");
        assert!(matches!(nan, Error::NotFinite { line: 2, .. }), "{nan}");
        let text = e("wavelength_nm,a\n400,0.5\n410,abc\n");
        assert!(matches!(&text, Error::NotANumber { line: 3, column, .. } if column == "a"));
        assert!(text.to_string().starts_with("x.csv:3:"));
        assert!(matches!(e("wavelength_nm,a\n400,-0.1\n"), Error::Negative { line: 2, .. }));
        assert!(matches!(e("wavelength_nm,a\n400,1,2\n"), Error::Ragged { line: 2, .. }));
        let zero = e("wavelength_nm,a\n0,1\n");
        assert_eq!(zero.to_string(), "x.csv:2: wavelength 0 nm must be > 0");
        // Blank lines are skipped but still counted: the error names the file's own line.
        assert!(matches!(e("wavelength_nm,a\n\n400,1\n\n400,2\n"), Error::Unsorted { line: 5, .. }));
        let inf = e("wavelength_nm,a\n400,inf\n");
        assert!(matches!(&inf, Error::NotFinite { line: 2, column, .. } if column == "a"), "{inf}");
        let neg = e("wavelength_nm,a\n400,0.5\n410,-0.1\n");
        assert_eq!(neg.to_string(), "x.csv:3: column `a`: -0.1 is negative (spectra must be >= 0)");
    }
}
