//! Fluorescence: light absorbed at one wavelength λ_in and re-emitted, diffusely, at another λ_out.
//!
//! A fluorescent surface is described by its re-radiation kernel k(λ_in, λ_out) (per nm of λ_in and of
//! λ_out): under a uniform incident radiance L_i(λ) it sends back, besides its ordinary reflection,
//!
//! L_fl(λ_out) = ∫ k(λ_in, λ_out) L_i(λ_in) dλ_in,
//!
//! Lambertian in direction (the bispectral BRDF is k / π). Two descriptions give k:
//!
//! - **Excitation and emission** (the separable model of Wilkie et al. 2006, "A reflectance model for
//!   diffuse fluorescent surfaces"): a(λ_in), the fraction of the incident light absorbed for re-emission,
//!   e(λ_out), the emission's shape normalised here to ∫ e dλ = 1, and the quantum yield q. This model
//!   conserves **photons**: q photons leave per photon absorbed, each carrying the energy of its own
//!   wavelength, so k = q · a(λ_in) · e(λ_out) · λ_in / λ_out, and light absorbed at λ_in is re-emitted with
//!   the energy fraction q · λ_in · ∫ e(λ)/λ dλ (the Stokes shift loses the rest as heat).
//! - **A re-radiation (Donaldson) matrix** R(λ_in, λ_out) read from a CSV, in energy: entry (i, o) is the
//!   fraction of the energy arriving in the cell of λ_in = λ_i that leaves in the cell of λ_out = λ_o; the
//!   diagonal is the ordinary reflectance. k is the off-diagonal part, linear in λ_in between rows and
//!   constant over each λ_out cell.
//!
//! Neither may create energy: per wavelength, reflectance + excitation ≤ 1 and reflectance + re-emitted
//! energy fraction ≤ 1 ([`Fluorescence::check_energy`]); a matrix's rows sum to at most 1 and it re-emits
//! nothing below the wavelength it absorbs (anti-Stokes emission is not modelled).

use std::path::Path;

use colorimetry::{DenselySampledSpectrum, LAMBDA_MAX, LAMBDA_MIN};

use crate::error::{Error, Result};

/// The shortest wavelength light is carried at after a fluorescent event (nm): the start of UV-A's
/// neighbour UV-B and of the CIE's D65 and D50 tables, which is where daylight's measured ultraviolet
/// content starts. Excitation below it is ignored.
pub const LAMBDA_UV_MIN: f32 = 300.0;

/// How much the energy checks forgive (rounding of data written with a few digits).
const ENERGY_TOLERANCE: f64 = 1e-6;

/// A fluorescent surface's re-radiation kernel (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Fluorescence {
    kernel: Kernel,
}

#[derive(Debug, Clone, PartialEq)]
enum Kernel {
    Spectra {
        excitation: DenselySampledSpectrum,
        /// e(λ_out) with ∫ e dλ = 1.
        emission: DenselySampledSpectrum,
        quantum_yield: f64,
    },
    Matrix {
        lambda_min: f64,
        step: f64,
        n: usize,
        /// R(λ_i, λ_o) at `i * n + o`, the diagonal set to 0 (it is the reflectance).
        off_diagonal: Vec<f64>,
    },
}

impl Fluorescence {
    /// The separable model: excitation a(λ_in) in [0, 1], emission shape e(λ_out) ≥ 0 (normalised here),
    /// quantum yield q in [0, 1].
    pub fn from_spectra(
        excitation: DenselySampledSpectrum,
        emission: &DenselySampledSpectrum,
        quantum_yield: f32,
    ) -> Result<Self> {
        let q = f64::from(quantum_yield);
        if !(0.0..=1.0).contains(&q) {
            return Err(Error::OutOfRange { what: "fluorescence yield", value: q, range: "[0, 1]" });
        }
        if let Some(&v) = excitation.values().iter().find(|&&v| !(0.0..=1.0).contains(&v)) {
            return Err(Error::OutOfRange { what: "fluorescence excitation", value: v, range: "[0, 1]" });
        }
        if let Some(&v) = emission.values().iter().find(|&&v| v < 0.0) {
            return Err(Error::OutOfRange { what: "fluorescence emission", value: v, range: ">= 0" });
        }
        // The trapezoid rule is exact for the piecewise-linear spectrum.
        let values = emission.values();
        let area: f64 = values.windows(2).map(|w| 0.5 * (w[0] + w[1]) * emission.step()).sum();
        if !(area > 0.0) {
            return Err(Error::OutOfRange { what: "fluorescence emission's integral", value: area, range: "> 0" });
        }
        let emission = emission.scaled(1.0 / area);
        Ok(Self { kernel: Kernel::Spectra { excitation, emission, quantum_yield: q } })
    }

    /// A re-radiation matrix from a CSV file: a header row whose first cell is free and whose other cells
    /// are the λ_out of each column, then one row per λ_in (first cell) with the energy fractions R(λ_in,
    /// λ_out). Rows and columns share one evenly spaced grid. Returns the kernel and the reflectance (the
    /// diagonal, held outside the grid as colorimetry holds tables).
    pub fn from_matrix_csv(path: &Path) -> Result<(Self, DenselySampledSpectrum)> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::Matrix {
            path: path.to_owned(),
            line: 0,
            message: e.to_string(),
        })?;
        Self::parse_matrix(path, &text)
    }

    fn parse_matrix(path: &Path, text: &str) -> Result<(Self, DenselySampledSpectrum)> {
        let bad = |line: usize, message: String| Error::Matrix { path: path.to_owned(), line, message };
        let number = |line: usize, cell: &str| -> Result<f64> {
            let v: f64 = cell.trim().parse().map_err(|_| bad(line, format!("`{}` is not a number", cell.trim())))?;
            if v.is_finite() { Ok(v) } else { Err(bad(line, format!("{v} is not finite"))) }
        };
        let mut rows = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.trim_start_matches('\u{feff}')))
            .filter(|(_, l)| !l.trim().is_empty() && !l.trim_start().starts_with('#'));
        let Some((header_line, header)) = rows.next() else { return Err(bad(1, "empty file".into())) };
        let columns: Vec<f64> = header.split(',').skip(1).map(|c| number(header_line, c)).collect::<Result<_>>()?;
        let n = columns.len();
        if n < 2 {
            return Err(bad(header_line, "needs at least two λ_out columns".into()));
        }
        let (lambda_min, step) = (columns[0], columns[1] - columns[0]);
        if !(step >= 0.1) {
            return Err(bad(
                header_line,
                format!("λ_out must increase (by at least 0.1 nm): {} then {}", columns[0], columns[1]),
            ));
        }
        for (i, &c) in columns.iter().enumerate() {
            if (c - (lambda_min + step * i as f64)).abs() > 1e-6 * step.max(1.0) {
                return Err(bad(header_line, format!("λ_out {c} breaks the even {step} nm spacing")));
            }
        }
        let mut matrix = vec![0.0; n * n];
        let mut diagonal = vec![0.0; n];
        let mut count = 0;
        for (line, row) in rows {
            if count == n {
                return Err(bad(line, format!("more than the {n} rows of the {n} columns")));
            }
            let cells: Vec<&str> = row.split(',').collect();
            if cells.len() != n + 1 {
                return Err(bad(line, format!("{} values, expected λ_in and {n}", cells.len())));
            }
            let lambda_in = number(line, cells[0])?;
            let want = lambda_min + step * count as f64;
            if (lambda_in - want).abs() > 1e-6 * step.max(1.0) {
                return Err(bad(line, format!("λ_in {lambda_in}, expected {want} (rows on the columns' grid)")));
            }
            let mut sum = 0.0;
            for (o, cell) in cells[1..].iter().enumerate() {
                let v = number(line, cell)?;
                if v < 0.0 {
                    return Err(bad(line, format!("R({lambda_in}, {}) = {v} is negative", columns[o])));
                }
                if o < count && v > 0.0 {
                    return Err(bad(
                        line,
                        format!(
                            "R({lambda_in}, {}) = {v}: emission below the absorbed wavelength (anti-Stokes) is not \
                             modelled; it must be 0",
                            columns[o]
                        ),
                    ));
                }
                sum += v;
                if o == count {
                    diagonal[o] = v;
                } else {
                    matrix[count * n + o] = v;
                }
            }
            if sum > 1.0 + ENERGY_TOLERANCE {
                return Err(bad(
                    line,
                    format!("the row of λ_in {lambda_in} sums to {sum}: more energy leaves than arrives (at most 1)"),
                ));
            }
            count += 1;
        }
        if count != n {
            return Err(bad(text.lines().count(), format!("{count} rows, expected {n} (one per column)")));
        }
        let reflectance = DenselySampledSpectrum::new(lambda_min, step, diagonal)
            .and_then(|d| d.held_to_visible())
            .map_err(|e| bad(header_line, e.to_string()))?;
        Ok((Self { kernel: Kernel::Matrix { lambda_min, step, n, off_diagonal: matrix } }, reflectance))
    }

    /// k(λ_in, λ_out) per nm of λ_in and λ_out: L_fl(λ_out) = ∫ k L_i(λ_in) dλ_in under a uniform radiance L_i.
    #[inline]
    pub fn kernel(&self, lambda_in: f32, lambda_out: f32) -> f32 {
        if lambda_in < LAMBDA_UV_MIN {
            return 0.0;
        }
        match &self.kernel {
            Kernel::Spectra { excitation, emission, quantum_yield } => {
                let (li, lo) = (f64::from(lambda_in), f64::from(lambda_out));
                let a = excitation.eval(li);
                if a == 0.0 {
                    return 0.0;
                }
                (quantum_yield * a * emission.eval(lo) * li / lo) as f32
            }
            Kernel::Matrix { lambda_min, step, n, off_diagonal } => {
                let (li, lo) = (f64::from(lambda_in), f64::from(lambda_out));
                // λ_out: the cell it falls in; λ_in: linear between rows.
                let o = ((lo - lambda_min) / step).round();
                let pos = (li - lambda_min) / step;
                let last = (*n - 1) as f64;
                if !(0.0..=last).contains(&o) || !(-1e-9..=last + 1e-9).contains(&pos) {
                    return 0.0;
                }
                let o = o as usize;
                let pos = pos.clamp(0.0, last);
                let i = (pos as usize).min(n - 2);
                let f = pos - i as f64;
                let v = off_diagonal[i * n + o] * (1.0 - f) + off_diagonal[(i + 1) * n + o] * f;
                (v / step) as f32
            }
        }
    }

    /// How [`Self::kernel`] varies with λ_in for each λ_out, so that a sampler can tabulate it once per
    /// class: the class of `lambda_out` (`None` where nothing is emitted at it), among
    /// [`Self::class_count`]. The separable model has one class (k ∝ a(λ_in) λ_in for any λ_out); a
    /// matrix one per column.
    pub fn class_of(&self, lambda_out: f32) -> Option<usize> {
        match &self.kernel {
            Kernel::Spectra { .. } => Some(0),
            Kernel::Matrix { lambda_min, step, n, .. } => {
                let o = ((f64::from(lambda_out) - lambda_min) / step).round();
                (0.0..=(*n - 1) as f64).contains(&o).then_some(o as usize)
            }
        }
    }

    /// The number of classes [`Self::class_of`] returns.
    pub fn class_count(&self) -> usize {
        match &self.kernel {
            Kernel::Spectra { .. } => 1,
            Kernel::Matrix { n, .. } => *n,
        }
    }

    /// A λ_out of class `class`, at which [`Self::kernel`] has the class's shape in λ_in.
    pub fn class_lambda_out(&self, class: usize) -> f32 {
        match &self.kernel {
            // Any λ_out at which e > 0 would do; the shape does not depend on it. 1 nm from the emission's peak.
            Kernel::Spectra { emission, .. } => {
                let values = emission.values();
                let peak = values.iter().enumerate().fold(0, |best, (i, &v)| if v > values[best] { i } else { best });
                (emission.lambda_min() + emission.step() * peak as f64) as f32
            }
            Kernel::Matrix { lambda_min, step, .. } => (lambda_min + step * class as f64) as f32,
        }
    }

    /// The range of λ_in at which the surface absorbs for re-emission (nm), within [`LAMBDA_UV_MIN`],
    /// [`LAMBDA_MAX`].
    pub fn excitation_range(&self) -> (f32, f32) {
        let (lo, hi) = match &self.kernel {
            Kernel::Spectra { excitation, .. } => (excitation.lambda_min(), excitation.lambda_max()),
            Kernel::Matrix { lambda_min, step, n, .. } => (*lambda_min, lambda_min + step * (*n - 1) as f64),
        };
        ((lo as f32).max(LAMBDA_UV_MIN), (hi as f32).min(LAMBDA_MAX))
    }

    /// The fraction of the energy arriving at `lambda_in` that is re-emitted: ∫ k(λ_in, λ_out) dλ_out.
    pub fn reemitted(&self, lambda_in: f32) -> f64 {
        if lambda_in < LAMBDA_UV_MIN {
            return 0.0;
        }
        match &self.kernel {
            Kernel::Spectra { excitation, emission, quantum_yield } => {
                let li = f64::from(lambda_in);
                let a = excitation.eval(li);
                if a == 0.0 {
                    return 0.0;
                }
                quantum_yield * a * li * stokes_integral(emission)
            }
            Kernel::Matrix { step, n, .. } => {
                (0..*n).map(|o| f64::from(self.kernel(lambda_in, self.class_lambda_out(o))) * step).sum()
            }
        }
    }

    /// That no wavelength gains energy with the Lambertian reflectance `reflectance` beside this kernel: at
    /// every nanometre from [`LAMBDA_UV_MIN`] to [`LAMBDA_MAX`] and every sample of the data, reflectance +
    /// excitation ≤ 1 (the separable model: what is absorbed for re-emission is not also reflected) and
    /// reflectance + re-emitted fraction ≤ 1.
    pub fn check_energy(&self, reflectance: &DenselySampledSpectrum) -> Result<()> {
        let mut lambdas: Vec<f64> = (LAMBDA_UV_MIN as u32..=LAMBDA_MAX as u32).map(f64::from).collect();
        if let Kernel::Spectra { excitation, .. } = &self.kernel {
            let (lo, step) = (excitation.lambda_min(), excitation.step());
            lambdas.extend((0..excitation.values().len()).map(|i| lo + step * i as f64));
        }
        for l in lambdas.into_iter().filter(|&l| l >= f64::from(LAMBDA_UV_MIN)) {
            let rho = reflectance.eval(l);
            if let Kernel::Spectra { excitation, .. } = &self.kernel {
                let sum = rho + excitation.eval(l);
                if sum > 1.0 + ENERGY_TOLERANCE {
                    return Err(Error::FluorescenceGainsEnergy {
                        what: "reflectance + excitation",
                        lambda: l,
                        value: sum,
                    });
                }
            }
            let sum = rho + self.reemitted(l as f32);
            if sum > 1.0 + ENERGY_TOLERANCE {
                return Err(Error::FluorescenceGainsEnergy {
                    what: "reflectance + re-emitted energy (yield × λ_in/λ_out over the emission)",
                    lambda: l,
                    value: sum,
                });
            }
        }
        Ok(())
    }

    /// L_fl(λ_out) = ∫ k(λ_in, λ_out) L(λ_in) dλ_in at every nanometre of 360–830 nm: the re-emitted radiance
    /// of a surface under a uniform radiance `light` (or, as a factor, the re-emitted part of its radiance
    /// factor under an illuminant). λ_in is integrated at every nanometre from [`LAMBDA_UV_MIN`] (midpoint
    /// rule).
    pub fn reemitted_radiance(&self, light: &DenselySampledSpectrum) -> DenselySampledSpectrum {
        let (lo, hi) = (LAMBDA_UV_MIN as u32, LAMBDA_MAX as u32);
        let incident: Vec<(f32, f64)> =
            (lo..hi).map(|l| l as f64 + 0.5).map(|l| (l as f32, light.eval(l))).filter(|(_, e)| *e != 0.0).collect();
        let values = (LAMBDA_MIN as u32..=hi)
            .map(|lo| incident.iter().map(|&(li, e)| f64::from(self.kernel(li, lo as f32)) * e).sum::<f64>())
            .collect();
        DenselySampledSpectrum::new(f64::from(LAMBDA_MIN), 1.0, values)
            .unwrap_or_else(|_| DenselySampledSpectrum::constant(0.0))
    }

    /// The model's name, for `info`.
    pub fn describe(&self) -> &'static str {
        match self.kernel {
            Kernel::Spectra { .. } => "excitation/emission",
            Kernel::Matrix { .. } => "re-radiation matrix",
        }
    }
}

/// ∫ e(λ)/λ dλ over the emission's grid (trapezoid rule on its samples).
fn stokes_integral(emission: &DenselySampledSpectrum) -> f64 {
    let (lo, step) = (emission.lambda_min(), emission.step());
    emission
        .values()
        .windows(2)
        .enumerate()
        .map(|(i, w)| {
            let (l0, l1) = (lo + step * i as f64, lo + step * (i + 1) as f64);
            0.5 * (w[0] / l0.max(1.0) + w[1] / l1.max(1.0)) * step
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A triangle peaked at `peak` nm, 2 `half` nm wide at half height (area 2 `half` `height`), zero beyond.
    fn triangle(peak: f64, half: f64, height: f64) -> DenselySampledSpectrum {
        DenselySampledSpectrum::from_samples(&[peak - 2.0 * half, peak, peak + 2.0 * half], &[0.0, height, 0.0])
            .unwrap()
    }

    #[test]
    fn emission_is_normalised_and_the_yield_counts_photons() {
        // Excitation 0.5 at 340–360 nm, emission a triangle at 450 nm of any height: light absorbed at 350 nm
        // is re-emitted with the energy fraction q a · 350 ∫ e(λ)/λ dλ. For a triangle narrow against its
        // centre ∫ e/λ ≈ 1/450 (1 + (half/450)²·…): within 1e-3 relative.
        let a = DenselySampledSpectrum::from_samples(&[330.0, 340.0, 360.0, 370.0], &[0.0, 0.5, 0.5, 0.0]).unwrap();
        let f = Fluorescence::from_spectra(a, &triangle(450.0, 10.0, 7.0), 0.8).unwrap();
        let want = 0.8 * 0.5 * 350.0 / 450.0;
        let got = f.reemitted(350.0);
        assert!((got / want - 1.0).abs() < 1e-3, "{got} vs {want}");
        // The kernel at the peak: q a e(450) λ_in/λ_out with e(450) = 1/20 (unit area over a 40 nm base).
        let k = f64::from(f.kernel(350.0, 450.0));
        assert!((k / (0.8 * 0.5 * 0.05 * 350.0 / 450.0) - 1.0).abs() < 1e-5, "{k}");
        // Nothing below 300 nm or outside the excitation.
        assert_eq!(f.kernel(299.0, 450.0), 0.0);
        assert_eq!(f.kernel(400.0, 450.0), 0.0);
        assert_eq!(f.excitation_range(), (330.0, 370.0));
    }

    #[test]
    fn reemitted_radiance_integrates_the_kernel_over_the_light() {
        // Under a flat radiance 2 from 300 nm, L_fl(450) = ∫ q a(λ) e(450) λ/450 · 2 dλ with e(450) = 1/20. a
        // is 0.5 on 340–360 with 10 nm ramps, so ∫ a λ dλ = 0.5 · (20 · 350 + 2 · 5 · 350) = 0.5 · 10 500 (the
        // ramps are symmetric about 350): L = 0.8 · 0.05 · 2 · 5250 / 450.
        let a = DenselySampledSpectrum::from_samples(&[330.0, 340.0, 360.0, 370.0], &[0.0, 0.5, 0.5, 0.0]).unwrap();
        let f = Fluorescence::from_spectra(a, &triangle(450.0, 10.0, 1.0), 0.8).unwrap();
        let light = DenselySampledSpectrum::new(300.0, 1.0, vec![2.0; 531]).unwrap();
        let l = f.reemitted_radiance(&light);
        let want = 0.8 * 0.05 * 2.0 * 5250.0 / 450.0;
        assert!((l.eval(450.0) / want - 1.0).abs() < 1e-4, "{} vs {want}", l.eval(450.0));
        assert_eq!(l.eval(400.0), 0.0);
    }

    #[test]
    fn energy_gaining_descriptions_are_errors_naming_the_wavelength() {
        let a = DenselySampledSpectrum::from_samples(&[340.0, 420.0], &[0.4, 0.4]).unwrap();
        let f = Fluorescence::from_spectra(a.clone(), &triangle(450.0, 10.0, 1.0), 1.0).unwrap();
        // 0.6 + 0.4 = 1: allowed; 0.7 + 0.4 is not.
        f.check_energy(&DenselySampledSpectrum::constant(0.6)).unwrap();
        let e = f.check_energy(&DenselySampledSpectrum::constant(0.7)).unwrap_err().to_string();
        assert!(e.contains("reflectance + excitation") && e.contains("360 nm"), "{e}");
        // Emission well below the excitation with yield 1 gains energy (λ_in/λ_out > 1): anti-Stokes.
        let blue = DenselySampledSpectrum::from_samples(&[600.0, 620.0], &[0.9, 0.9]).unwrap();
        let f = Fluorescence::from_spectra(blue, &triangle(450.0, 10.0, 1.0), 1.0).unwrap();
        let e = f.check_energy(&DenselySampledSpectrum::constant(0.0)).unwrap_err().to_string();
        assert!(e.contains("re-emitted energy") && e.contains("600 nm"), "{e}");
        // Out-of-range inputs.
        let bad = DenselySampledSpectrum::from_samples(&[340.0, 420.0], &[1.2, 0.4]).unwrap();
        assert!(Fluorescence::from_spectra(bad, &triangle(450.0, 10.0, 1.0), 1.0).is_err());
        assert!(Fluorescence::from_spectra(a.clone(), &DenselySampledSpectrum::constant(0.0), 1.0).is_err());
        assert!(Fluorescence::from_spectra(a, &triangle(450.0, 10.0, 1.0), 1.5).is_err());
    }

    const MATRIX: &str = "nm,400,410,420\n400,0.5,0.2,0.1\n410,0,0.6,0.3\n420,0,0,0.9\n";

    #[test]
    fn a_matrix_gives_its_diagonal_as_reflectance_and_the_rest_as_kernel() {
        let (f, r) = Fluorescence::parse_matrix(Path::new("m.csv"), MATRIX).unwrap();
        assert_eq!(r.eval(410.0), 0.6);
        // Held outside the grid.
        assert_eq!(r.eval(380.0), 0.5);
        assert_eq!(r.eval(700.0), 0.9);
        // Per nm: the cell's fraction over the 10 nm step; linear between rows.
        assert!((f.kernel(400.0, 410.0) - 0.02).abs() < 1e-7);
        assert!((f.kernel(405.0, 420.0) - 0.5 * (0.01 + 0.03)).abs() < 1e-7);
        assert_eq!(f.kernel(410.0, 410.0), 0.0);
        assert!((f.reemitted(400.0) - 0.3).abs() < 1e-6);
        f.check_energy(&r).unwrap();
        assert_eq!(f.class_count(), 3);
        assert_eq!(f.class_of(418.0), Some(2));
        assert_eq!(f.class_of(500.0), None);
    }

    #[test]
    fn bad_matrices_are_errors_naming_file_and_line() {
        let cases = [
            ("nm,400,410\n400,0.5,x\n410,0,0.5\n", ":2:", "not a number"),
            ("nm,400,410\n400,0.5,0.2\n410,0.1,0.5\n", ":3:", "anti-Stokes"),
            ("nm,400,410\n400,0.9,0.2\n410,0,0.5\n", ":2:", "sums to"),
            ("nm,400,410\n400,0.5,0.2\n", ":2:", "1 rows, expected 2"),
            ("nm,400,410\n400,0.5,0.2\n420,0,0.5\n", ":3:", "expected 410"),
            ("nm,400,410\n400,0.5,-0.2\n410,0,0.5\n", ":2:", "negative"),
            ("nm,400,410,430\n", ":1:", "spacing"),
            ("nm,400,410\n400,0.5\n410,0,0.5\n", ":2:", "2 values"),
        ];
        for (text, line, what) in cases {
            let e = Fluorescence::parse_matrix(Path::new("m.csv"), text).unwrap_err().to_string();
            assert!(e.starts_with("m.csv") && e.contains(line) && e.contains(what), "{text:?}: {e}");
        }
    }
}
