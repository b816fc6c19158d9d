//! Photometric files: a luminaire's goniometric web from an IES LM-63 file (1986, 1991, 1995, 2002, 2019;
//! type C photometry) or a EULUMDAT file (`.ldt`), transcribed into a [`PhotometricWeb`]: the C planes the
//! file gives, its vertical angles and its intensities in candela after the file's multipliers. The
//! symmetry is recorded, not expanded, and nothing is interpolated: both are the renderer's.
//!
//! Our own reader rather than a crate's: the one crate that reads both formats (`eulumdat`) is
//! AGPL-3.0-licensed, which this MIT/Apache-2.0 workspace cannot take, and it brings a photometry suite
//! (diagrams, road lighting, XML) for the two hundred lines needed here.
//!
//! Every fault is an [`Error::Photometric`] naming the file and, where it has one, the line; a web's size is
//! checked on the counts the file claims before anything is allocated ([`MAX_WEB_VALUES`]) and charged to
//! the scene's budget. The robustness test below feeds truncated and mutated files and asserts an error,
//! never a panic.

use std::path::Path;

use crate::desc::{PhotometricFormat, PhotometricWeb, WebSymmetry};
use crate::error::{Error, Result};
use crate::limits::{BYTES_PER_WEB_VALUE, Budget, MAX_WEB_VALUES};

/// Angles closer than this (degrees) are the same angle: files write 90, 90.0 or 89.99999.
const ANGLE_TOLERANCE: f64 = 1e-3;

/// The format of a photometric file: by its extension (`.ies`, `.ldt`, any case), else by its content (an
/// IES file has a `TILT=` line; anything else is read as EULUMDAT).
pub(crate) fn format_of(path: &Path, text: &str) -> PhotometricFormat {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("ies") => PhotometricFormat::Ies,
        Some("ldt") => PhotometricFormat::Ldt,
        _ if text.lines().any(|l| l.trim_start().to_ascii_uppercase().starts_with("TILT")) => PhotometricFormat::Ies,
        _ => PhotometricFormat::Ldt,
    }
}

/// Reads `text`, the contents of `path`, as `format`; `referrer` (the scene file) is charged for the web.
/// Returns the web and warnings (data the renderer does not honour).
pub(crate) fn parse(
    text: &str,
    path: &Path,
    format: PhotometricFormat,
    budget: &Budget,
    referrer: &Path,
) -> Result<(PhotometricWeb, Vec<String>)> {
    let charge = |values: u64| {
        budget.charge_items(
            referrer,
            || format!("the goniometric web of {}", path.display()),
            values,
            BYTES_PER_WEB_VALUE,
        )
    };
    match format {
        PhotometricFormat::Ies => parse_ies(text, path, charge),
        PhotometricFormat::Ldt => parse_ldt(text, path, charge),
    }
}

fn fault(path: &Path, line: Option<usize>, message: impl Into<String>) -> Error {
    Error::Photometric { path: path.to_path_buf(), line, message: message.into() }
}

/// Whitespace- (and comma-) separated tokens with their 1-based line numbers.
struct Tokens<'a> {
    path: &'a Path,
    items: Vec<(&'a str, usize)>,
    next: usize,
    /// The line the text ends on, for "ended before" errors.
    last_line: usize,
}

impl<'a> Tokens<'a> {
    fn new(path: &'a Path, lines: impl Iterator<Item = (usize, &'a str)>, separators: &[char]) -> Self {
        let mut items = Vec::new();
        let mut last_line = 0;
        for (number, line) in lines {
            last_line = number;
            items.extend(
                line.split(|c: char| c.is_whitespace() || separators.contains(&c))
                    .filter(|t| !t.is_empty())
                    .map(|t| (t, number)),
            );
        }
        Self { path, items, next: 0, last_line }
    }

    fn remaining(&self) -> usize {
        self.items.len() - self.next
    }

    /// The next token as a finite number.
    fn number(&mut self, what: &str) -> Result<(f64, usize)> {
        let Some(&(token, line)) = self.items.get(self.next) else {
            return Err(fault(self.path, Some(self.last_line), format!("the file ends before {what}")));
        };
        self.next += 1;
        match token.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok((v, line)),
            _ => Err(fault(self.path, Some(line), format!("`{token}` is not a finite number ({what})"))),
        }
    }

    /// The next token as a count in `1..=max`.
    fn count(&mut self, what: &str, max: u64) -> Result<usize> {
        let (v, line) = self.number(what)?;
        if v.fract() != 0.0 || v < 1.0 || v > max as f64 {
            return Err(fault(self.path, Some(line), format!("{what} is {v}: expected a whole number in 1..={max}")));
        }
        Ok(v as usize)
    }

    /// `n` angles in `lo..=hi` degrees, strictly increasing.
    fn angles(&mut self, n: usize, what: &str, lo: f64, hi: f64) -> Result<Vec<f32>> {
        let mut out = Vec::with_capacity(n);
        let mut previous = f64::NEG_INFINITY;
        for i in 0..n {
            let (v, line) = self.number(&format!("{what} {}", i + 1))?;
            if !(lo - ANGLE_TOLERANCE..=hi + ANGLE_TOLERANCE).contains(&v) {
                return Err(fault(self.path, Some(line), format!("{what} {v}° is outside {lo}–{hi}°")));
            }
            if v <= previous {
                return Err(fault(self.path, Some(line), format!("{what}s must increase: {v}° after {previous}°")));
            }
            previous = v;
            out.push(v.clamp(lo, hi) as f32);
        }
        Ok(out)
    }

    /// `n` intensities, each ≥ 0, times `multiplier`, as candela.
    fn intensities(&mut self, n: usize, multiplier: f64) -> Result<Vec<f32>> {
        let mut out = Vec::with_capacity(n);
        for i in 0..n {
            let (v, line) = self.number(&format!("intensity {} of {n}", i + 1))?;
            let cd = v * multiplier;
            if !(v >= 0.0) || !(cd as f32).is_finite() {
                return Err(fault(
                    self.path,
                    Some(line),
                    format!("intensity {v} must be ≥ 0 (and finite after the multipliers)"),
                ));
            }
            out.push(cd as f32);
        }
        Ok(out)
    }
}

/// Checks the claimed size of a web (C planes × vertical angles) against [`MAX_WEB_VALUES`] and the numbers
/// the file has left (`before`: those still to read before the intensities), then charges it.
fn check_size(
    tokens: &Tokens<'_>,
    planes: usize,
    angles: usize,
    before: usize,
    expanded_planes: usize,
    charge: &impl Fn(u64) -> Result<()>,
) -> Result<usize> {
    let values = planes.saturating_mul(angles);
    let expanded = (expanded_planes as u64 + 1).saturating_mul(angles as u64);
    if expanded > MAX_WEB_VALUES {
        return Err(fault(
            tokens.path,
            None,
            format!(
                "a web of {expanded_planes} C planes × {angles} angles is larger than the limit of {MAX_WEB_VALUES} values"
            ),
        ));
    }
    if values.saturating_add(before) > tokens.remaining() {
        return Err(fault(
            tokens.path,
            Some(tokens.last_line),
            format!("the file ends before its {planes} × {angles} intensities ({} numbers left)", tokens.remaining()),
        ));
    }
    charge(expanded)?;
    Ok(values)
}

fn same_angle(a: f32, b: f64) -> bool {
    (f64::from(a) - b).abs() <= ANGLE_TOLERANCE
}

/// IES LM-63: keyword lines up to `TILT=`, the tilt data if included, then the numbers (separated by spaces,
/// line breaks or commas): lamps, lumens per lamp, candela multiplier, vertical and horizontal angle counts,
/// photometric type, units, the luminous opening's size; ballast factor, the ballast–lamp photometric factor
/// (before 2002; "future use" since), input watts; the angles and the candela, plane by plane.
fn parse_ies(text: &str, path: &Path, charge: impl Fn(u64) -> Result<()>) -> Result<(PhotometricWeb, Vec<String>)> {
    let mut warnings = Vec::new();
    let first = text.lines().next().unwrap_or("").trim().to_ascii_uppercase();
    // Since LM-63-2002 the third factor of line 10 is "future use" (1): only older files' is a multiplier.
    let modern = first.contains("LM-63-2002") || first.contains("LM-63-2019");
    let tilt_index = text
        .lines()
        .position(|l| l.trim_start().to_ascii_uppercase().starts_with("TILT"))
        .ok_or_else(|| fault(path, None, "no `TILT=` line: not an IES LM-63 file"))?;
    let tilt_line = text.lines().nth(tilt_index).unwrap_or("");
    let tilt = tilt_line.split_once('=').map(|(_, v)| v.trim()).unwrap_or("");
    let mut tokens = Tokens::new(path, text.lines().enumerate().skip(tilt_index + 1).map(|(i, l)| (i + 1, l)), &[',']);
    match tilt.to_ascii_uppercase().as_str() {
        "NONE" => {}
        "" => {
            return Err(fault(path, Some(tilt_index + 1), "`TILT=` names nothing (expected NONE, INCLUDE or a file)"));
        }
        upper => {
            if upper == "INCLUDE" {
                // Lamp-to-luminaire geometry, the pair count, the angles and the factors: read past them.
                tokens.number("the tilt's lamp-to-luminaire geometry")?;
                let pairs = tokens.count("the tilt's angle count", 10_000)?;
                for _ in 0..2 * pairs {
                    tokens.number("the tilt's angles and factors")?;
                }
            }
            warnings.push(format!(
                "{}: TILT={tilt}: tilt factors are not honoured (the lamp is taken in its measured position)",
                path.display()
            ));
        }
    }
    let _lamps = tokens.number("the number of lamps")?;
    let _lumens = tokens.number("the lumens per lamp")?;
    let (multiplier, line) = tokens.number("the candela multiplier")?;
    if multiplier < 0.0 {
        return Err(fault(path, Some(line), format!("candela multiplier {multiplier} must be ≥ 0")));
    }
    let vertical = tokens.count("the number of vertical angles", MAX_WEB_VALUES)?;
    let horizontal = tokens.count("the number of horizontal angles", MAX_WEB_VALUES)?;
    let (kind, line) = tokens.number("the photometric type")?;
    match kind as i64 {
        1 if kind.fract() == 0.0 => {}
        2 | 3 if kind.fract() == 0.0 => {
            let name = if kind == 2.0 { "B" } else { "A" };
            return Err(fault(path, Some(line), format!("type {name} photometry is not supported (only type C, 1)")));
        }
        _ => return Err(fault(path, Some(line), format!("photometric type {kind} is not 1, 2 or 3"))),
    }
    let _units = tokens.number("the units type")?;
    for what in ["the opening's width", "the opening's length", "the opening's height"] {
        tokens.number(what)?;
    }
    let (ballast, line) = tokens.number("the ballast factor")?;
    if ballast < 0.0 {
        return Err(fault(path, Some(line), format!("ballast factor {ballast} must be ≥ 0")));
    }
    let (lamp_factor, line) = tokens.number("the ballast–lamp photometric factor")?;
    if !modern && lamp_factor < 0.0 {
        return Err(fault(path, Some(line), format!("ballast–lamp photometric factor {lamp_factor} must be ≥ 0")));
    }
    let _watts = tokens.number("the input watts")?;
    if vertical < 2 {
        return Err(fault(path, None, "a web needs at least two vertical angles"));
    }
    // At most 4 × the planes once mirrored (quadrant symmetry), plus the closing 360° plane.
    let values =
        check_size(&tokens, horizontal, vertical, horizontal + vertical, horizontal.saturating_mul(4), &charge)?;
    let gamma_deg = tokens.angles(vertical, "vertical angle", 0.0, 180.0)?;
    let c_deg = tokens.angles(horizontal, "horizontal angle", 0.0, 360.0)?;
    let (c_first, c_last) = (c_deg[0], c_deg[horizontal - 1]);
    let symmetry = if horizontal == 1 {
        WebSymmetry::Rotational
    } else if same_angle(c_first, 0.0) && same_angle(c_last, 90.0) {
        WebSymmetry::Quadrant
    } else if same_angle(c_first, 0.0) && same_angle(c_last, 180.0) {
        WebSymmetry::C0C180
    } else if same_angle(c_first, 90.0) && same_angle(c_last, 270.0) {
        WebSymmetry::C90C270
    } else if same_angle(c_first, 0.0) && f64::from(c_last) > 180.0 {
        WebSymmetry::None
    } else {
        return Err(fault(
            path,
            None,
            format!(
                "horizontal angles from {c_first}° to {c_last}° give no LM-63 symmetry (0 alone, 0–90, 0–180, 90–270, \
                 or 0 to more than 180)"
            ),
        ));
    };
    let factor = multiplier * ballast * if modern { 1.0 } else { lamp_factor };
    let candela = tokens.intensities(values, factor)?;
    let web = PhotometricWeb {
        path: path.to_path_buf(),
        format: PhotometricFormat::Ies,
        symmetry,
        c_deg,
        gamma_deg,
        candela,
    };
    Ok((web, warnings))
}

/// EULUMDAT: 26 header lines (line 2 the type, 3 the symmetry `Isym`, 4 the C-plane count `Mc`, 6 the
/// angle count `Ng`, 24 the conversion factor for intensities, 26 the number of lamp sets `n`), per set six
/// lines (lamps, type, total flux in lm, colour temperature, colour rendering, watts: six blocks of `n`
/// lines), ten direct ratios, `Mc` C angles, `Ng` γ angles, then the intensities in cd/klm of the given planes,
/// plane by plane. Candela = value × conversion factor × the first set's flux / 1000.
fn parse_ldt(text: &str, path: &Path, charge: impl Fn(u64) -> Result<()>) -> Result<(PhotometricWeb, Vec<String>)> {
    let lines: Vec<&str> = text.lines().collect();
    let line = |index: usize, what: &str| -> Result<&str> {
        lines.get(index).copied().ok_or_else(|| {
            fault(
                path,
                Some(lines.len()),
                format!("the file ends before line {} ({what}): not a EULUMDAT file?", index + 1),
            )
        })
    };
    // Some writers use a decimal comma.
    let number = |index: usize, what: &str| -> Result<f64> {
        let text = line(index, what)?.trim().replace(',', ".");
        match text.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            _ => Err(fault(path, Some(index + 1), format!("`{}` is not a finite number ({what})", text.trim()))),
        }
    };
    let whole = |index: usize, what: &str, lo: i64, hi: i64| -> Result<usize> {
        let v = number(index, what)?;
        if v.fract() != 0.0 || v < lo as f64 || v > hi as f64 {
            return Err(fault(path, Some(index + 1), format!("{what} is {v}: expected a whole number in {lo}..={hi}")));
        }
        Ok(v as usize)
    };
    let isym = whole(2, "the symmetry indicator Isym", 0, 4)?;
    let max = MAX_WEB_VALUES as i64;
    let mc = whole(3, "the number of C planes Mc", 1, max)?;
    let ng = whole(5, "the number of angles per plane Ng", 2, max)?;
    let factor = number(23, "the conversion factor for intensities")?;
    if !(factor > 0.0) {
        return Err(fault(path, Some(24), format!("conversion factor {factor} must be > 0")));
    }
    let sets = whole(25, "the number of lamp sets", 1, 10_000)?;
    let flux_line = 26 + 2 * sets;
    let flux = number(flux_line, "the first lamp set's total flux")?;
    if !(flux > 0.0) {
        return Err(fault(path, Some(flux_line + 1), format!("lamp flux {flux} lm must be > 0")));
    }
    let angles_start = 26 + 6 * sets + 10;
    // Which of the Mc planes carry data (EULUMDAT's Mc1..Mc2); C90–C270 as the common readers take it.
    let (first, count, symmetry) = match isym {
        0 => (0, mc, WebSymmetry::None),
        1 => (0, 1, WebSymmetry::Rotational),
        2 | 3 if mc % 2 != 0 || (isym == 3 && mc % 4 != 0) => {
            return Err(fault(path, Some(4), format!("Mc = {mc} C planes cannot be halved for Isym {isym}")));
        }
        2 => (0, mc / 2 + 1, WebSymmetry::C0C180),
        3 => (mc / 4, mc / 2 + 1, WebSymmetry::C90C270),
        _ if mc % 4 != 0 => {
            return Err(fault(path, Some(4), format!("Mc = {mc} C planes cannot be quartered for Isym 4")));
        }
        _ => (0, mc / 4 + 1, WebSymmetry::Quadrant),
    };
    // The numeric block, one value a line as written or several (lenient); a comma is a decimal point.
    let block: Vec<String> = lines.iter().skip(angles_start).map(|l| l.replace(',', ".")).collect();
    let mut tokens = Tokens::new(path, block.iter().enumerate().map(|(i, l)| (angles_start + i + 1, l.as_str())), &[]);
    if mc.saturating_add(ng) > tokens.remaining() {
        return Err(fault(
            path,
            Some(tokens.last_line),
            format!("the file ends before its {mc} C angles and {ng} γ angles"),
        ));
    }
    let all_c = tokens.angles(mc, "C angle", 0.0, 360.0)?;
    let gamma_deg = tokens.angles(ng, "γ angle", 0.0, 180.0)?;
    let c_deg: Vec<f32> = if isym == 1 { vec![0.0] } else { all_c[first..first + count].to_vec() };
    let bounds_ok = match symmetry {
        WebSymmetry::None | WebSymmetry::Rotational => true,
        WebSymmetry::C0C180 => same_angle(c_deg[0], 0.0) && same_angle(c_deg[count - 1], 180.0),
        WebSymmetry::C90C270 => same_angle(c_deg[0], 90.0) && same_angle(c_deg[count - 1], 270.0),
        WebSymmetry::Quadrant => same_angle(c_deg[0], 0.0) && same_angle(c_deg[count - 1], 90.0),
    };
    if !bounds_ok {
        return Err(fault(
            path,
            Some(angles_start + first + 1),
            format!(
                "Isym {isym}: its planes run from C{}° to C{}°, not the half or quadrant it names",
                c_deg[0],
                c_deg[count - 1]
            ),
        ));
    }
    let values = check_size(&tokens, count, ng, 0, mc, &charge)?;
    let candela = tokens.intensities(values, factor * flux / 1000.0)?;
    let web = PhotometricWeb {
        path: path.to_path_buf(),
        format: PhotometricFormat::Ldt,
        symmetry,
        c_deg,
        gamma_deg,
        candela,
    };
    Ok((web, Vec::new()))
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use super::*;
    use crate::limits::LoadOptions;

    fn asset(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/luminaires").join(name)
    }

    fn read(text: &str, name: &str) -> Result<(PhotometricWeb, Vec<String>)> {
        let path = Path::new(name);
        let budget = Budget::new(LoadOptions::default());
        parse(text, path, format_of(path, text), &budget, Path::new("scene.json"))
    }

    fn read_asset(name: &str) -> PhotometricWeb {
        read(&std::fs::read_to_string(asset(name)).unwrap(), name).unwrap().0
    }

    #[test]
    fn the_same_luminaire_reads_alike_from_ies_and_ldt_after_their_multipliers() {
        let ies = read_asset("lambert_1000cd.ies");
        let ldt = read_asset("lambert_1000cd.ldt");
        for web in [&ies, &ldt] {
            assert_eq!(web.symmetry, WebSymmetry::Rotational);
            assert_eq!(web.c_deg, [0.0]);
            assert_eq!(web.gamma_deg.len(), 37);
            assert_eq!(web.gamma_deg[36], 90.0);
            // 500 × 2 (IES multiplier; LDT: 500 cd/klm × 2000 lm / 1000).
            assert!((web.candela[0] - 1000.0).abs() < 1e-3, "{}", web.candela[0]);
            assert!((web.candela[24] - 500.0).abs() < 1e-3, "γ = 60°: {}", web.candela[24]);
        }
        assert_eq!((ies.format, ldt.format), (PhotometricFormat::Ies, PhotometricFormat::Ldt));
        let (a, b) = (read_asset("asymmetric.ies"), read_asset("asymmetric.ldt"));
        assert_eq!((a.symmetry, b.symmetry), (WebSymmetry::None, WebSymmetry::None));
        assert_eq!((a.c_deg.len(), a.c_deg[71]), (72, 355.0));
        assert_eq!((a.c_deg.clone(), a.gamma_deg.clone()), (b.c_deg.clone(), b.gamma_deg.clone()));
        assert!(a.candela.iter().zip(&b.candela).all(|(x, y)| (x - y).abs() < 1e-3));
    }

    /// An IES file with the given horizontal angles, two vertical angles and 7 cd everywhere.
    fn ies_with(horizontal: &[f32], extra: &str) -> String {
        let values = "7 7".to_owned();
        let planes: Vec<String> = horizontal.iter().map(|_| values.clone()).collect();
        let h: Vec<String> = horizontal.iter().map(|a| a.to_string()).collect();
        format!(
            "IESNA:LM-63-2002\n[TEST] t\nTILT=NONE\n1 1000 1 2 {} 1 1 0 0 0\n1 1 10\n0 90\n{}\n{}\n{extra}",
            horizontal.len(),
            h.join(" "),
            planes.join("\n")
        )
    }

    #[test]
    fn ies_symmetry_follows_its_horizontal_angles() {
        let cases: [(&[f32], WebSymmetry); 5] = [
            (&[0.0], WebSymmetry::Rotational),
            (&[0.0, 45.0, 90.0], WebSymmetry::Quadrant),
            (&[0.0, 90.0, 180.0], WebSymmetry::C0C180),
            (&[90.0, 180.0, 270.0], WebSymmetry::C90C270),
            (&[0.0, 120.0, 240.0], WebSymmetry::None),
        ];
        for (angles, symmetry) in cases {
            let (web, _) = read(&ies_with(angles, ""), "t.ies").unwrap();
            assert_eq!(web.symmetry, symmetry, "{angles:?}");
            assert!(web.candela.iter().all(|&c| c == 7.0));
        }
        let e = read(&ies_with(&[0.0, 60.0, 120.0], ""), "t.ies").unwrap_err().to_string();
        assert!(e.starts_with("t.ies: horizontal angles from 0° to 120°"), "{e}");
    }

    #[test]
    fn ies_tilt_data_are_read_past_with_a_warning_and_old_files_apply_the_ballast_lamp_factor() {
        let text =
            "IESNA91\nTILT=INCLUDE\n1\n3\n0 45 90\n1 0.9 0.8\n1 1000 2 2 1 1 1 0 0 0\n0.5 0.5 10\n0 90\n0\n10 20\n";
        let (web, warnings) = read(text, "old.ies").unwrap();
        // 2 (multiplier) × 0.5 (ballast) × 0.5 (ballast–lamp factor, a multiplier before LM-63-2002).
        assert_eq!(web.candela, [5.0, 10.0]);
        assert!(warnings.len() == 1 && warnings[0].contains("TILT=INCLUDE"), "{warnings:?}");
    }

    #[test]
    fn faults_name_the_file_and_line() {
        let cases = [
            (ies_with(&[0.0], "").replace("1 1000 1 2 1 1", "1 1000 1 2 1 2"), "t.ies:4: type B photometry"),
            (ies_with(&[0.0], "").replace("7 7", "7 -7"), "t.ies:8: intensity -7 must be ≥ 0"),
            (ies_with(&[0.0], "").replace("7 7", "7 x"), "t.ies:8: `x` is not a finite number"),
            (ies_with(&[0.0], "").replace("0 90", "90 0"), "t.ies:6: vertical angles must increase"),
            (ies_with(&[0.0], "").replace("7 7", "7"), "t.ies:8: the file ends before its 1 × 2 intensities"),
            ("IESNA:LM-63-2002\n1 2 3\n".to_owned(), "t.ies: no `TILT=` line"),
            (ies_with(&[0.0], "").replace("1 1000 1 2 1 1", "1 1000 1 2000 2000 1"), "larger than the limit"),
        ];
        for (text, expected) in cases {
            let e = read(&text, "t.ies").unwrap_err().to_string();
            assert!(e.contains(expected), "{e}\nexpected: {expected}");
        }
        let ldt = std::fs::read_to_string(asset("lambert_1000cd.ldt")).unwrap();
        let bad_isym = ldt.replacen("\r\n1\r\n24\r\n", "\r\n7\r\n24\r\n", 1);
        let e = read(&bad_isym, "t.ldt").unwrap_err().to_string();
        assert!(e.starts_with("t.ldt:3: the symmetry indicator Isym is 7"), "{e}");
        let e = read(&ldt[..400], "t.ldt").unwrap_err().to_string();
        assert!(e.starts_with("t.ldt:") && e.contains("ends before"), "{e}");
    }

    /// The fuzz targets take too long to build here: every truncation of the small files and thousands of
    /// token mutations of all four must give a web or an error, never a panic, and never a web that breaks
    /// the description's rules.
    #[test]
    fn truncated_and_mutated_files_give_errors_never_panics() {
        let mut uniform = crate::test_uniform(43);
        let replacements =
            ["-1", "0", "1e39", "nan", "inf", "x", "", "4", "3", "360", "180", "90", "1e9", ",", "TILT=INCLUDE"];
        for name in ["lambert_1000cd.ies", "lambert_1000cd.ldt", "asymmetric.ies", "asymmetric.ldt"] {
            let text = std::fs::read_to_string(asset(name)).unwrap();
            let check = |text: &str| {
                if let Ok((web, _)) = read(text, name) {
                    assert!(!web.gamma_deg.is_empty() && !web.c_deg.is_empty());
                    assert_eq!(web.candela.len(), web.c_deg.len() * web.gamma_deg.len());
                    assert!(web.candela.iter().all(|c| c.is_finite() && *c >= 0.0));
                    assert!(web.gamma_deg.windows(2).all(|w| w[0] < w[1]) && web.c_deg.windows(2).all(|w| w[0] < w[1]));
                }
            };
            if text.len() < 2000 {
                for end in (0..text.len()).filter(|&i| text.is_char_boundary(i)) {
                    check(&text[..end]);
                }
            }
            let tokens: Vec<&str> = text.split_inclusive(char::is_whitespace).collect();
            for _ in 0..1500 {
                let mut mutated: Vec<String> = tokens.iter().map(|t| (*t).to_owned()).collect();
                for _ in 0..1 + (uniform() * 3.0) as usize {
                    let i = ((uniform() * mutated.len() as f32) as usize).min(mutated.len() - 1);
                    let r =
                        replacements[((uniform() * replacements.len() as f32) as usize).min(replacements.len() - 1)];
                    mutated[i] = format!("{r}{}", if uniform() < 0.7 { " " } else { "\n" });
                }
                check(&mutated.concat());
            }
        }
    }
}
