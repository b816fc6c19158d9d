//! Bouguer–Beer–Lambert absorption inside transparent objects (the paper's eq. 8).
//!
//! The paper writes T = t_λ^b, with t_λ the transmittance per unit thickness and b the path
//! length inside the object. We store the equivalent absorption coefficient
//! σ_a(λ) = −ln t_λ and evaluate T = exp(−σ_a b), which is t_λ^b exactly, accepts the other
//! common parameterisations (σ_a directly, glTF's attenuation colour at a distance) and
//! underflows cleanly to 0 for thick, dense absorbers instead of producing NaN.

use colorimetry::{DenselySampledSpectrum, SampledSpectrum, SampledWavelengths};

use crate::error::{Error, Result};

/// Stand-in for σ_a where t_λ = 0 (a perfect absorber): large enough that any positive
/// thickness above 1e-28 units gives exp(−σ b) = 0 in f32, finite so that b = 0 gives
/// T = 1 instead of ∞·0 = NaN.
const SIGMA_A_MAX: f64 = 1e30;

/// A homogeneous absorbing medium: σ_a(λ) per scene unit.
#[derive(Debug, Clone)]
pub struct Absorption {
    sigma_a: DenselySampledSpectrum,
}

impl Absorption {
    /// From the paper's t_λ, the fraction transmitted through one unit of thickness
    /// (Table 1's "absorption 95 %" means t_λ = 0.95 per unit). Values must lie in [0, 1].
    pub fn from_per_unit_transmittance(t: &DenselySampledSpectrum) -> Result<Self> {
        check_range(t, "transmittance per unit length", 0.0, 1.0, "[0, 1]")?;
        Ok(Self { sigma_a: t.map(|t| if t > 0.0 { (-t.ln()).min(SIGMA_A_MAX) } else { SIGMA_A_MAX }) })
    }

    /// From an absorption coefficient per scene unit (≥ 0).
    pub fn from_sigma_a(sigma_a: &DenselySampledSpectrum) -> Result<Self> {
        check_range(sigma_a, "absorption coefficient", 0.0, f64::MAX, ">= 0, finite")?;
        Ok(Self { sigma_a: sigma_a.map(|s| s.min(SIGMA_A_MAX)) })
    }

    /// From glTF `KHR_materials_volume`: light keeps the fraction `color(λ)` after travelling
    /// `distance` units, so σ_a = −ln(color) / distance.
    pub fn from_attenuation(color: &DenselySampledSpectrum, distance: f64) -> Result<Self> {
        if !(distance > 0.0) {
            return Err(Error::OutOfRange {
                what: "attenuation distance",
                value: distance,
                range: "> 0 (may be infinite)",
            });
        }
        check_range(color, "attenuation colour", 0.0, 1.0, "[0, 1]")?;
        Ok(Self { sigma_a: color.map(|c| if c > 0.0 { (-c.ln() / distance).min(SIGMA_A_MAX) } else { SIGMA_A_MAX }) })
    }

    /// σ_a(λ) per scene unit.
    pub fn sigma_a(&self) -> &DenselySampledSpectrum {
        &self.sigma_a
    }

    /// Whether the medium absorbs at all (σ_a > 0 somewhere): a clear medium needs no Beer work.
    pub fn absorbs(&self) -> bool {
        self.sigma_a.max_value() > 0.0
    }

    /// Transmittance exp(−σ_a b) at the sampled wavelengths after `distance` units.
    #[inline]
    pub fn transmittance<const N: usize>(&self, lambda: &SampledWavelengths<N>, distance: f32) -> SampledSpectrum<N> {
        beer_transmittance(&self.sigma_a.sample(lambda), distance)
    }
}

/// Eq. 8 (Bouguer–Beer): T = exp(−σ_a b) = t_λ^b for each wavelength, in [0, 1] for any
/// non-negative σ_a and any distance; a non-positive or NaN distance transmits everything.
#[inline]
pub fn beer_transmittance<const N: usize>(sigma_a: &SampledSpectrum<N>, distance: f32) -> SampledSpectrum<N> {
    let b = if distance > 0.0 { distance } else { 0.0 };
    let mut out = *sigma_a;
    for v in out.0.iter_mut() {
        // σ_a ≤ 1e30 and b finite keeps the product finite or +∞, never NaN (b = 0 → 0).
        *v = (-(*v * b)).exp();
    }
    out
}

fn check_range(s: &DenselySampledSpectrum, what: &'static str, lo: f64, hi: f64, range: &'static str) -> Result<()> {
    for &v in s.values() {
        if !(v >= lo && v <= hi) {
            return Err(Error::OutOfRange { what, value: v, range });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn flat(v: f64) -> DenselySampledSpectrum {
        DenselySampledSpectrum::constant(v)
    }

    fn lambdas() -> SampledWavelengths<4> {
        SampledWavelengths::from_parts([450.0, 520.0, 600.0, 700.0], [1.0; 4])
    }

    #[test]
    fn per_unit_transmittance_to_the_power_of_thickness() {
        // Table 1: 95 % per unit thickness; through 2.5 units T = 0.95^2.5.
        let a = Absorption::from_per_unit_transmittance(&flat(0.95)).unwrap();
        let t = a.transmittance(&lambdas(), 2.5);
        for v in t.0 {
            assert!((v - 0.95f32.powf(2.5)).abs() < 1e-6, "{v}");
        }
    }

    #[test]
    fn absorber_underflows_to_zero_not_nan() {
        let opaque = Absorption::from_per_unit_transmittance(&flat(0.0)).unwrap();
        assert!(opaque.transmittance(&lambdas(), 1e-3).0.iter().all(|&v| v == 0.0));
        // Zero thickness of a perfect absorber transmits everything (no ∞·0).
        assert!(opaque.transmittance(&lambdas(), 0.0).0.iter().all(|&v| v == 1.0));
        // Dense and thick: underflow to exactly 0.
        let dense = Absorption::from_sigma_a(&flat(1e6)).unwrap();
        assert!(dense.transmittance(&lambdas(), 1e6).0.iter().all(|&v| v == 0.0));
        // NaN distance is treated as zero length, never propagated.
        assert!(dense.transmittance(&lambdas(), f32::NAN).0.iter().all(|&v| v == 1.0));
    }

    #[test]
    fn gltf_attenuation_keeps_the_colour_at_the_distance() {
        let a = Absorption::from_attenuation(&flat(0.25), 2.0).unwrap();
        let t = a.transmittance(&lambdas(), 2.0);
        assert!(t.0.iter().all(|&v| (v - 0.25).abs() < 1e-6));
        // Infinite distance: no absorption.
        let clear = Absorption::from_attenuation(&flat(0.25), f64::INFINITY).unwrap();
        assert!(!clear.absorbs());
    }

    #[test]
    fn out_of_range_inputs_are_errors() {
        assert!(matches!(Absorption::from_per_unit_transmittance(&flat(1.2)), Err(Error::OutOfRange { .. })));
        assert!(matches!(Absorption::from_sigma_a(&flat(-1.0)), Err(Error::OutOfRange { .. })));
        assert!(matches!(Absorption::from_attenuation(&flat(0.5), 0.0), Err(Error::OutOfRange { .. })));
    }

    proptest! {
        #[test]
        fn beer_attenuation_stays_in_unit_interval(t in 0.0f64..=1.0, b in 0.0f32..1e12) {
            let a = Absorption::from_per_unit_transmittance(&flat(t)).unwrap();
            for v in a.transmittance(&lambdas(), b).0 {
                prop_assert!((0.0..=1.0).contains(&v), "{v}");
            }
        }
    }
}
