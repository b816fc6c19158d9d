//! Spectrum → CIE XYZ, exactly as the paper writes it: X = k Σ S R x̄ Δλ, k = 100 / Σ S ȳ Δλ.

use crate::data::Observer;
use crate::error::Result;
use crate::spectrum::{DenselySampledSpectrum, LAMBDA_MAX, LAMBDA_MIN, check_step};

/// CIE 1931/1964 tristimulus values.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Xyz {
    /// X.
    pub x: f64,
    /// Y (luminance).
    pub y: f64,
    /// Z.
    pub z: f64,
}

impl Xyz {
    /// Chromaticity (x, y) = (X, Y) / (X + Y + Z); (0, 0) for black.
    pub fn chromaticity(self) -> [f64; 2] {
        let sum = self.x + self.y + self.z;
        if sum == 0.0 { [0.0, 0.0] } else { [self.x / sum, self.y / sum] }
    }

    /// XYZ from chromaticity and luminance.
    pub fn from_xy_y(xy: [f64; 2], y: f64) -> Self {
        if xy[1] == 0.0 {
            return Self { x: 0.0, y: 0.0, z: 0.0 };
        }
        Self { x: xy[0] * y / xy[1], y, z: (1.0 - xy[0] - xy[1]) * y / xy[1] }
    }

    /// `m` · (X, Y, Z)ᵀ (e.g. a [`crate::bradford`] adaptation).
    pub fn transformed(self, m: [[f64; 3]; 3]) -> Self {
        let v = [self.x, self.y, self.z];
        let r = |row: [f64; 3]| row[0] * v[0] + row[1] * v[1] + row[2] * v[2];
        Self { x: r(m[0]), y: r(m[1]), z: r(m[2]) }
    }

    /// Every component times `factor`.
    pub fn scaled(self, factor: f64) -> Self {
        Self { x: self.x * factor, y: self.y * factor, z: self.z * factor }
    }
}

/// How a spectral integral is discretised: the paper's Σ … Δλ.
#[derive(Debug, Clone, PartialEq)]
pub enum Integration {
    /// λ = 360, 360 + s, …, up to 830 nm; each term weighted by s. The step must be finite
    /// and at least [`crate::MIN_STEP_NM`] ([`Integration::step`] checks it): with any other
    /// step the sums are NaN, not another sum (0 and negative steps used to become 1 nm
    /// silently) nor a huge one (1e-9 nm asked for 4.7e11 nodes).
    Step(f64),
    /// Arbitrary bins: (centre λ, width Δλ).
    Bins(Vec<(f64, f64)>),
}

impl Integration {
    /// `Integration::Step(step)` once the step is checked: finite and at least
    /// [`crate::MIN_STEP_NM`] (the bound of spectrum grids, which keeps 360–830 nm within
    /// 470 001 nodes).
    pub fn step(step: f64) -> Result<Self> {
        check_step("integration", step)?;
        Ok(Self::Step(step))
    }

    /// The (λ, Δλ) nodes of the sum; `None` for a step [`Integration::step`] refuses.
    fn nodes(&self) -> Option<Vec<(f64, f64)>> {
        match self {
            Self::Step(step) => {
                let step = *step;
                check_step("integration", step).ok()?;
                let (lo, hi) = (f64::from(LAMBDA_MIN), f64::from(LAMBDA_MAX));
                let count = ((hi - lo) / step + 1e-9).floor() as usize + 1;
                Some((0..count).map(|i| (lo + step * i as f64, step)).collect())
            }
            Self::Bins(bins) => Some(bins.clone()),
        }
    }
}

/// The XYZ of a sum over no valid nodes (see [`Integration::Step`]).
const NAN_XYZ: Xyz = Xyz { x: f64::NAN, y: f64::NAN, z: f64::NAN };

/// Tristimulus values of a reflectance under an illuminant (the paper's eq.), so that a
/// perfect reflector has Y = 100. NaN for a step [`Integration::step`] refuses.
pub fn reflectance_to_xyz(
    reflectance: &DenselySampledSpectrum,
    illuminant: &DenselySampledSpectrum,
    observer: Observer,
    integration: &Integration,
) -> Xyz {
    let Some(nodes) = integration.nodes() else {
        return NAN_XYZ;
    };
    let cmf = observer.cmf();
    let (mut x, mut y, mut z, mut norm) = (0.0, 0.0, 0.0, 0.0);
    for (l, dl) in nodes {
        let s = illuminant.eval(l) * dl;
        let sr = s * reflectance.eval(l);
        let ybar = cmf.y.eval(l);
        x += sr * cmf.x.eval(l);
        y += sr * ybar;
        z += sr * cmf.z.eval(l);
        norm += s * ybar;
    }
    // An illuminant with next to no light has a norm so small that 100 / norm overflows (an
    // f64-subnormal one; spectra flush values below f32's smallest normal, which keeps norm far
    // above that, but the white is said to be dark rather than infinite either way).
    let k = if norm > 0.0 { 100.0 / norm } else { 0.0 };
    let k = if k.is_finite() { k } else { 0.0 };
    Xyz { x: k * x, y: k * y, z: k * z }
}

/// Unnormalised tristimulus values of an emission spectrum: X = Σ S x̄ Δλ. NaN for a step
/// [`Integration::step`] refuses.
pub fn emission_to_xyz(spd: &DenselySampledSpectrum, observer: Observer, integration: &Integration) -> Xyz {
    let Some(nodes) = integration.nodes() else {
        return NAN_XYZ;
    };
    let cmf = observer.cmf();
    let (mut x, mut y, mut z) = (0.0, 0.0, 0.0);
    for (l, dl) in nodes {
        let s = spd.eval(l) * dl;
        x += s * cmf.x.eval(l);
        y += s * cmf.y.eval(l);
        z += s * cmf.z.eval(l);
    }
    Xyz { x, y, z }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::Illuminant;

    fn white_point(illuminant: Illuminant, observer: Observer) -> Xyz {
        let s = illuminant.spectrum().unwrap();
        reflectance_to_xyz(&DenselySampledSpectrum::constant(1.0), &s, observer, &Integration::Step(1.0))
    }

    #[test]
    fn d65_white_point_matches_cie015() {
        // CIE 015:2018 (PROVENANCE.md): 2° xy (0.31272, 0.32903), XYZ (95.047, 100, 108.883);
        // 10° xy (0.31382, 0.33100), XYZ (94.811, 100, 107.304). At 1 nm with linear
        // interpolation and the 780 nm value held above, agreement is expected to 3e-5 in xy
        // and 0.02 in X, Z (PROVENANCE.md "How to reproduce them").
        let w = white_point(Illuminant::D65, Observer::Cie1931);
        let xy = w.chromaticity();
        assert!((xy[0] - 0.31272).abs() < 3e-5 && (xy[1] - 0.32903).abs() < 3e-5, "{xy:?}");
        assert!((w.x - 95.047).abs() < 0.02 && (w.y - 100.0).abs() < 1e-9 && (w.z - 108.883).abs() < 0.02, "{w:?}");
        let w10 = white_point(Illuminant::D65, Observer::Cie1964);
        let xy = w10.chromaticity();
        assert!((xy[0] - 0.31382).abs() < 3e-5 && (xy[1] - 0.33100).abs() < 3e-5, "{xy:?}");
        assert!((w10.x - 94.811).abs() < 0.02 && (w10.z - 107.304).abs() < 0.02, "{w10:?}");
    }

    #[test]
    fn a_and_d50_white_points_match_cie015() {
        // CIE 015:2018: A 2° (0.44757/0.44758, 0.40745), XYZ (109.850, 100, 35.585);
        // D50 2° (0.34567, 0.35850), XYZ (96.422, 100, 82.521). Tolerances as for D65.
        let a = white_point(Illuminant::A, Observer::Cie1931);
        let xy = a.chromaticity();
        assert!((xy[0] - 0.447575).abs() < 3e-5 && (xy[1] - 0.40745).abs() < 3e-5, "{xy:?}");
        assert!((a.x - 109.850).abs() < 0.02 && (a.z - 35.585).abs() < 0.02, "{a:?}");
        let d50 = white_point(Illuminant::D50, Observer::Cie1931);
        let xy = d50.chromaticity();
        assert!((xy[0] - 0.34567).abs() < 3e-5 && (xy[1] - 0.35850).abs() < 3e-5, "{xy:?}");
        assert!((d50.x - 96.422).abs() < 0.02 && (d50.z - 82.521).abs() < 0.02, "{d50:?}");
    }

    #[test]
    fn fluorescent_chromaticities_match_cie015_at_1nm() {
        // CIE 015:2018: F2 (0.37208, 0.37529), F11 (0.38052, 0.37713), 2°, reproduced from the
        // 5 nm tables linearly interpolated to 1 nm (PROVENANCE.md). Published to 5 decimals.
        for (ill, xy) in [(Illuminant::F2, [0.37208, 0.37529]), (Illuminant::F11, [0.38052, 0.37713])] {
            let got = white_point(ill, Observer::Cie1931).chromaticity();
            assert!((got[0] - xy[0]).abs() < 5e-5 && (got[1] - xy[1]).abs() < 5e-5, "{ill:?}: {got:?}");
        }
    }

    #[test]
    fn steps_are_checked_in_the_library() {
        let d65 = Illuminant::D65.spectrum().unwrap();
        let white = DenselySampledSpectrum::constant(1.0);
        let xyz = |step| reflectance_to_xyz(&white, &d65, Observer::Cie1931, &Integration::Step(step));
        // A step of 0 or less was the 1 nm sum in disguise; now no sum at all.
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let got = xyz(bad);
            assert!(got.x.is_nan() && got.y.is_nan() && got.z.is_nan(), "step {bad}: {got:?}");
            let e = emission_to_xyz(&d65, Observer::Cie1931, &Integration::Step(bad));
            assert!(e.y.is_nan(), "step {bad}: {e:?}");
            let err = Integration::step(bad).unwrap_err();
            assert!(matches!(err, crate::Error::OutOfRange { .. }), "{err}");
        }
        // 1e-9 nm asked for 4.7e11 nodes (7.5 TB) before it was checked.
        assert!(xyz(1e-9).y.is_nan());
        let fine = Integration::step(1e-9).unwrap_err();
        assert_eq!(fine.to_string(), "integration: wavelength step 1e-9 nm is finer than the minimum, 0.001 nm");
        // Valid steps are the same variant, summing as before.
        assert_eq!(Integration::step(5.0).unwrap(), Integration::Step(5.0));
        assert_eq!(Integration::step(crate::MIN_STEP_NM).unwrap(), Integration::Step(crate::MIN_STEP_NM));
        assert!((xyz(1.0).y - 100.0).abs() < 1e-9);
    }

    #[test]
    fn bins_and_steps_agree_on_the_same_nodes() {
        let d65 = Illuminant::D65.spectrum().unwrap();
        let r = crate::data::colorchecker()[12].spectrum.clone();
        let bins: Vec<(f64, f64)> = (0..=94).map(|i| (360.0 + 5.0 * f64::from(i), 5.0)).collect();
        let a = reflectance_to_xyz(&r, &d65, Observer::Cie1931, &Integration::Step(5.0));
        let b = reflectance_to_xyz(&r, &d65, Observer::Cie1931, &Integration::Bins(bins));
        assert!((a.x - b.x).abs() < 1e-12 && (a.y - b.y).abs() < 1e-12 && (a.z - b.z).abs() < 1e-12);
    }
}
