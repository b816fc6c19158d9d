//! CSV spectra: a header line, the wavelength in nm in the first column, one column per
//! spectrum. Every error names the file and the line.

use std::path::Path;

use crate::error::{Error, Result};
use crate::spectrum::DenselySampledSpectrum;

/// One named column of a spectra table.
#[derive(Debug, Clone, PartialEq)]
pub struct NamedSpectrum {
    /// The column header.
    pub name: String,
    /// The values, on the file's own grid when evenly spaced.
    pub spectrum: DenselySampledSpectrum,
}

/// Parse spectra from CSV text; `origin` names the source in errors. Values must be finite
/// and non-negative; wavelengths strictly increasing.
pub fn parse_spectra_csv(text: &str, origin: &str) -> Result<Vec<NamedSpectrum>> {
    parse(text, origin, false)
}

/// Read and parse a CSV spectra file (see [`parse_spectra_csv`]).
pub fn read_spectra_csv(path: &Path) -> Result<Vec<NamedSpectrum>> {
    let origin = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|source| Error::Io { path: origin.clone(), source })?;
    parse_spectra_csv(&text, &origin)
}

/// The parser; `allow_negative` for internal tables that have signed values (the CIE
/// daylight basis functions S1, S2).
pub(crate) fn parse(text: &str, origin: &str, allow_negative: bool) -> Result<Vec<NamedSpectrum>> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut lines = text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty());
    let Some((_, header)) = lines.next() else {
        return Err(Error::Empty { origin: origin.to_owned() });
    };
    let names: Vec<String> = header.split(',').map(|c| c.trim().to_owned()).collect();
    if names.len() < 2 {
        return Err(Error::NoColumns { origin: origin.to_owned() });
    }
    let mut lambdas: Vec<f64> = Vec::new();
    let mut columns: Vec<Vec<f64>> = vec![Vec::new(); names.len() - 1];
    for (index, line) in lines {
        let line_no = index + 1;
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != names.len() {
            return Err(Error::Ragged {
                origin: origin.to_owned(),
                line: line_no,
                found: cells.len(),
                expected: names.len(),
            });
        }
        let mut values = Vec::with_capacity(cells.len());
        for (cell, name) in cells.iter().zip(&names) {
            let v: f64 = cell.parse().map_err(|_| Error::NotANumber {
                origin: origin.to_owned(),
                line: line_no,
                column: name.clone(),
                cell: (*cell).to_owned(),
            })?;
            if !v.is_finite() {
                return Err(Error::NotFinite {
                    origin: origin.to_owned(),
                    line: line_no,
                    column: name.clone(),
                    value: v,
                });
            }
            values.push(v);
        }
        let lambda = values[0];
        if lambda <= 0.0 {
            return Err(Error::BadWavelength { origin: origin.to_owned(), line: line_no, lambda });
        }
        if let Some(&previous) = lambdas.last()
            && !(lambda > previous)
        {
            return Err(Error::Unsorted { origin: origin.to_owned(), line: line_no, lambda, previous });
        }
        for (c, &v) in values[1..].iter().enumerate() {
            if v < 0.0 && !allow_negative {
                return Err(Error::Negative {
                    origin: origin.to_owned(),
                    line: line_no,
                    column: names[c + 1].clone(),
                    value: v,
                });
            }
            columns[c].push(v);
        }
        lambdas.push(lambda);
    }
    if lambdas.is_empty() {
        return Err(Error::Empty { origin: origin.to_owned() });
    }
    names[1..]
        .iter()
        .zip(columns)
        .map(|(name, values)| {
            Ok(NamedSpectrum { name: name.clone(), spectrum: DenselySampledSpectrum::from_samples(&lambdas, &values)? })
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
