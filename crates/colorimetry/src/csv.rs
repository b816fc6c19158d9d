//! CSV spectra: a header line, the wavelength in nm in the first column, one column per
//! spectrum. Lines starting with `#` are comments; blank lines are skipped (both are still
//! counted, so errors name the file's own line). Every error names the file and the line.
//!
//! Hostile files are bounded before anything large is allocated: the file size
//! ([`MAX_CSV_BYTES`], regular files only), the column count ([`MAX_CSV_COLUMNS`]) and the
//! values held ([`MAX_TABLE_SAMPLES`]). Every sample is checked by the spectrum constructor's
//! own checks (wavelengths at least [`crate::MIN_STEP_NM`] apart, at most 100 000 nm, values
//! at most 1e30), which name the row's line here.

use std::io::Read as _;
use std::path::Path;

use crate::error::{Error, Result};
use crate::spectrum::{DenselySampledSpectrum, SampleGrid, SampleSource};

/// Largest spectra file read (bytes): 64 MiB. A 1 nm table of the whole Munsell book (1 269
/// columns × 471 rows × ~8 characters) is under 5 MiB; a 100 MB header once peaked at 4.1 GB.
pub const MAX_CSV_BYTES: u64 = 64 << 20;

/// Most columns a spectra table may have (the wavelength column included): 4096, three times
/// the Munsell book's 1 269 chips.
pub(crate) const MAX_CSV_COLUMNS: usize = 4096;

/// Most values one table may hold, after resampling uneven rows to 1 nm: 2²⁴ f64 = 128 MiB.
pub(crate) const MAX_TABLE_SAMPLES: usize = 1 << 24;

/// One named column of a spectra table.
#[derive(Debug, Clone, PartialEq)]
pub struct NamedSpectrum {
    /// The column header.
    pub name: String,
    /// The values, on the file's own grid when evenly spaced.
    pub spectrum: DenselySampledSpectrum,
}

/// Parse spectra from CSV text; `origin` names the source in errors. Values must be finite,
/// non-negative and at most 1e30; wavelengths strictly increasing, at least
/// [`crate::MIN_STEP_NM`] apart and in (0, 100 000] nm (the checks of
/// [`DenselySampledSpectrum::from_samples`]).
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
    // The file line of each row, for the errors of the samples' checks.
    let mut rows: Vec<usize> = Vec::new();
    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); names.len() - 1];
    for (index, line) in lines {
        let line_no = index + 1;
        if (lambdas.len() + 1) * (names.len() - 1) > MAX_TABLE_SAMPLES {
            return Err(Error::TooManySamples {
                origin: origin.to_owned(),
                line: Some(line_no),
                what: "values in the table",
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
            if c == 0 {
                lambda = v;
                continue;
            }
            // −∞ is left to the samples' check, which calls it not finite.
            if v < 0.0 && v.is_finite() && !allow_negative {
                return Err(Error::Negative {
                    origin: origin.to_owned(),
                    line: line_no,
                    column: quoted(name),
                    value: v,
                });
            }
            columns[c - 1].push(v);
        }
        lambdas.push(lambda);
        rows.push(line_no);
    }
    let Some(&last_line) = rows.last() else {
        return Err(Error::Empty { origin: origin.to_owned() });
    };
    let quoted_names: Vec<String> = names.iter().map(|n| quoted(n)).collect();
    let source = SampleSource { origin, columns: [&quoted_names[0], ""], lines: Some(&rows) };
    // The wavelengths are checked once, and the grid every column gets is the constructor's
    // own: the whole table is bounded from it before any column is built.
    let grid = SampleGrid::new(&source, &lambdas)?;
    let total = grid.len() as f64 * columns.len() as f64;
    if total > MAX_TABLE_SAMPLES as f64 {
        return Err(Error::TooManySamples {
            origin: origin.to_owned(),
            line: Some(last_line),
            what: match grid {
                SampleGrid::Even { .. } => "values in the table",
                SampleGrid::WholeNanometres { .. } => "values in the table (its uneven rows resampled at 1 nm)",
            },
            samples: total,
            limit: MAX_TABLE_SAMPLES,
        });
    }
    names[1..]
        .iter()
        .zip(&quoted_names[1..])
        .zip(columns)
        .map(|((name, quoted_name), values)| {
            let spectrum = grid.spectrum(&source.with_value_column(quoted_name), &lambdas, &values)?;
            Ok(NamedSpectrum { name: name.clone(), spectrum })
        })
        .collect()
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

    /// CSV files whose first lines are `#` comments used to be rejected. Comments (also
    /// indented, also between rows and after the last one), blank and whitespace-only lines
    /// and CRLF endings are skipped; the line numbers of errors stay the file's own.
    #[test]
    fn comment_and_blank_lines_are_skipped_and_still_counted() {
        let text = "# measured 2026-11-30, spectroradiometer X\r\n# units: W/(sr m^2 nm)\r\n\r\n\
                    wavelength_nm,radiance\r\n  # 400 nm first\r\n400,0.5\r\n   \r\n410,0.75\r\n# end\r\n\r\n";
        let t = parse_spectra_csv(text, "c.csv").unwrap();
        assert_eq!(t.len(), 1);
        assert_eq!(t[0].name, "radiance");
        let s = &t[0].spectrum;
        assert_eq!((s.lambda_min(), s.lambda_max()), (400.0, 410.0));
        assert!((s.eval(405.0) - 0.625).abs() < 1e-12);
        // The bad row is on the file's line 8 (two comments, a blank line, the header, an
        // indented comment, a row, a blank line before it).
        let bad = text.replace("410,0.75", "410,x");
        assert_eq!(
            parse_spectra_csv(&bad, "c.csv").unwrap_err().to_string(),
            "c.csv:8: column `radiance`: `x` is not a number"
        );
        // Only comments: no header.
        assert!(matches!(parse_spectra_csv("# a\n\n# b\n", "c.csv"), Err(Error::Empty { .. })));
    }

    #[test]
    fn an_even_table_is_bounded_by_its_own_grid() {
        // 200 columns every 5 nm from 1 to 99 996 nm: 20 000 rows, 4e6 values, kept on their
        // own grid. The table bound assumed every table was resampled at 1 nm (2e7 values)
        // and refused it.
        let header: String = (0..200).map(|i| format!(",c{i}")).collect();
        let mut text = format!("wavelength_nm{header}\n");
        for row in 0..20_000 {
            text.push_str(&format!("{}{}\n", 1 + 5 * row, ",0.5".repeat(200)));
        }
        let table = parse_spectra_csv(&text, "even.csv").unwrap();
        assert_eq!(table.len(), 200);
        let s = &table[199].spectrum;
        assert_eq!((s.lambda_min(), s.step(), s.values().len(), s.lambda_max()), (1.0, 5.0, 20_000, 99_996.0));
        // The same rows made uneven are resampled at 1 nm, 99 996 values a column: refused
        // before any column is built, naming the file's last line.
        let uneven = text.replacen("\n6,", "\n7,", 1);
        let err = parse_spectra_csv(&uneven, "uneven.csv").unwrap_err();
        assert!(
            matches!(err, Error::TooManySamples { line: Some(20_001), samples, .. } if samples == 200.0 * 99_996.0),
            "{err}"
        );
        assert_eq!(
            err.to_string(),
            "uneven.csv:20001: 1.99992e7 values in the table (its uneven rows resampled at 1 nm), more than the \
             limit of 16777216"
        );
    }

    #[test]
    fn values_below_f32s_smallest_normal_are_zero() {
        use crate::{Integration, Observer, SampledWavelengths, luminance_normalized, reflectance_to_xyz};
        // 1e-45 is an f32 subnormal (the smallest), 1e-39 one too, 1e-320 an f64 subnormal.
        let text = "nm,a,b,c\n400,0.5,0.5,1e-320\n500,1e-45,1e-39,1e-320\n600,0.5,0.5,1e-320\n";
        let table = parse_spectra_csv(text, "tiny.csv").unwrap();
        for column in &table[..2] {
            let s = &column.spectrum;
            assert_eq!(s.values()[1], 0.0, "{}: 500 nm", column.name);
            assert_eq!(s.eval(500.0), 0.0);
            // In the renderer's f32 lanes every value is 0 or normal, never subnormal.
            let lanes = s.sample(&SampledWavelengths::<4>::from_parts([450.0, 499.99, 500.0, 550.0], [1.0; 4]));
            assert!(lanes.0.iter().all(|v| *v == 0.0 || v.is_normal()), "{}: {:?}", column.name, lanes.0);
            assert!((lanes[0] - 0.25).abs() < 1e-6 && lanes[2] == 0.0, "{:?}", lanes.0);
            let n = luminance_normalized(s);
            assert!(n.values().iter().all(|v| v.is_finite()), "{:?}", n.values());
            assert!((crate::relative_luminance(&n) - 1.0).abs() < 1e-12);
        }
        // A table of f64 subnormals is no light: its white is dark (0), not infinite.
        let dark = &table[2].spectrum;
        assert!(dark.values().iter().all(|v| *v == 0.0), "{:?}", dark.values());
        let grey = DenselySampledSpectrum::constant(0.5);
        let xyz = reflectance_to_xyz(&grey, dark, Observer::Cie1931, &Integration::Step(1.0));
        assert_eq!((xyz.x, xyz.y, xyz.z), (0.0, 0.0, 0.0));
        assert_eq!(luminance_normalized(dark).values(), dark.values());
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
