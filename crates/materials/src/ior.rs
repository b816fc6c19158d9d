//! Index of refraction as a function of wavelength.
//!
//! Only a varying IOR makes a dielectric disperse light; [`Ior::is_dispersive`] lets the
//! integrators skip per-wavelength refraction (and keep all wavelengths on one path) when
//! it does not.

use crate::error::{Error, Result};

/// Fraunhofer d line (helium, 587.5618 nm), where glass catalogues quote n_d (nm). Also the one
/// wavelength at which a model that cannot disperse (Hall's, RGB lanes) takes the index.
pub const LAMBDA_D: f32 = 587.56;
/// Fraunhofer F line (hydrogen), used in the Abbe number (nm).
const LAMBDA_F: f32 = 486.13;
/// Fraunhofer C line (hydrogen), used in the Abbe number (nm).
const LAMBDA_C: f32 = 656.27;

/// A refractive index, constant or varying with wavelength.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Ior {
    /// The same index at every wavelength. `0` is glTF's special "Fresnel ≡ 1" mode.
    Constant(f32),
    /// Cauchy's equation n(λ) = a + b / λ², λ in µm.
    Cauchy {
        /// Constant term.
        a: f32,
        /// Coefficient of 1/λ² (µm²).
        b: f32,
    },
    /// Sellmeier's equation n² = 1 + Σ bᵢ λ² / (λ² − cᵢ), λ in µm.
    Sellmeier {
        /// Oscillator strengths.
        b: [f32; 3],
        /// Resonance wavelengths squared (µm²).
        c: [f32; 3],
    },
}

impl Ior {
    /// Cauchy's equation through n_d with Abbe number V_d = (n_d − 1) / (n_F − n_C): how glTF's
    /// `KHR_materials_dispersion` (dispersion = 20 / V_d) and glass catalogues specify glass.
    pub fn from_abbe(nd: f32, vd: f32) -> Result<Self> {
        if !(nd.is_finite() && nd >= 1.0) {
            return Err(Error::OutOfRange { what: "n_d", value: nd.into(), range: "finite, >= 1" });
        }
        if !(vd.is_finite() && vd > 0.0) {
            return Err(Error::OutOfRange { what: "Abbe number", value: vd.into(), range: "finite, > 0" });
        }
        let um = |nm: f32| nm * 1e-3;
        let inv_sq = |nm: f32| 1.0 / (um(nm) * um(nm));
        // n_F − n_C = b (1/λF² − 1/λC²) = (n_d − 1) / V_d.
        let b = (nd - 1.0) / (vd * (inv_sq(LAMBDA_F) - inv_sq(LAMBDA_C)));
        let a = nd - b * inv_sq(LAMBDA_D);
        Ok(Self::Cauchy { a, b })
    }

    /// The index at wavelength `lambda` (nm).
    #[inline]
    pub fn eval(&self, lambda: f32) -> f32 {
        match *self {
            Self::Constant(n) => n,
            Self::Cauchy { a, b } => {
                let l = lambda * 1e-3;
                a + b / (l * l)
            }
            Self::Sellmeier { b, c } => {
                let l2 = (lambda * 1e-3) * (lambda * 1e-3);
                let sum: f32 = (0..3).map(|i| b[i] * l2 / (l2 - c[i])).sum();
                (1.0 + sum).max(0.0).sqrt()
            }
        }
    }

    /// Whether the index varies with wavelength (so refraction separates wavelengths).
    pub fn is_dispersive(&self) -> bool {
        match *self {
            Self::Constant(_) => false,
            Self::Cauchy { b, .. } => b != 0.0,
            Self::Sellmeier { b, .. } => b.iter().any(|&x| x != 0.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn abbe_cauchy_reproduces_nd_and_vd_of_bk7() {
        // Schott N-BK7: n_d = 1.5168, V_d = 64.17 (Schott data sheet).
        let ior = Ior::from_abbe(1.5168, 64.17).unwrap();
        let nd = ior.eval(LAMBDA_D);
        let vd = (nd - 1.0) / (ior.eval(LAMBDA_F) - ior.eval(LAMBDA_C));
        assert!((nd - 1.5168).abs() < 1e-5, "{nd}");
        assert!((vd - 64.17).abs() < 0.05, "{vd}");
        assert!(ior.is_dispersive());
    }

    #[test]
    fn sellmeier_bk7_matches_catalogue_at_d_line() {
        // Schott N-BK7 Sellmeier coefficients (Schott data sheet); catalogue n_d = 1.5168.
        let ior = Ior::Sellmeier {
            b: [1.039_612, 0.231_792_34, 1.010_469_5],
            c: [0.006_000_698_7, 0.020_017_914, 103.560_65],
        };
        assert!((ior.eval(LAMBDA_D) - 1.5168).abs() < 1e-4);
    }

    #[test]
    fn constant_is_not_dispersive_and_bad_abbe_is_an_error() {
        assert!(!Ior::Constant(1.3).is_dispersive());
        assert!(matches!(Ior::from_abbe(1.5, 0.0), Err(Error::OutOfRange { .. })));
        assert!(matches!(Ior::from_abbe(f32::NAN, 40.0), Err(Error::OutOfRange { .. })));
    }
}
