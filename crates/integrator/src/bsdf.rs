//! The path tracer's scattering models, evaluated at the path's wavelengths (pbrt-v4
//! `base/bxdf.h`: `f`, `sample_f`, `pdf`), in world space.
//!
//! The physically based reading of a [`materials::Material`] (see `docs/path-tracer.md`):
//! - `Diffuse` → Lambertian, reflectance k_d · F_d(λ) (clamped to 1), reflecting on the side the
//!   light arrives from (surfaces are two-sided);
//! - `Dielectric` → a smooth interface with the exact Fresnel equations; transmission is tinted
//!   by k_t · T_s(λ) at each crossing (1 for clear glass) and radiance is scaled by 1/η² when
//!   it crosses (pbrt-v4 `DielectricBxDF` in radiance mode);
//! - `Conductor` → a smooth mirror with reflectance k_s · F_s(λ).
//!
//! Rough (GGX) variants are not modelled: no scene in `scenes/` needs them.

use colorimetry::SampledSpectrum;
use glam::{Vec2, Vec3};
use materials::scattering::{fr_dielectric, reflect, refract};

use crate::sampling::cosine_hemisphere;

/// A scattering model with its spectra evaluated at the path's wavelengths.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Bsdf<const N: usize> {
    /// Lambertian reflection, reflectance `r`.
    Lambertian { r: SampledSpectrum<N> },
    /// A smooth dielectric interface; `eta` is the index inside over outside (0: glTF's
    /// "Fresnel ≡ 1" mode), `tint` the transmission filter.
    Dielectric { eta: f32, tint: SampledSpectrum<N> },
    /// A smooth mirror with reflectance `r`.
    Mirror { r: SampledSpectrum<N> },
}

/// Where a surface scatters: `n` the geometric normal as stored (outward for closed
/// objects), `ns` the shading normal in `n`'s hemisphere.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Frame {
    pub(crate) n: Vec3,
    pub(crate) ns: Vec3,
}

impl Frame {
    /// Geometric and shading normals turned to the side of `wo`; the shading normal falls back
    /// to the geometric one where interpolation tilts it past `wo`.
    #[inline]
    pub(crate) fn facing(&self, wo: Vec3) -> (Vec3, Vec3) {
        let ng = if self.n.dot(wo) >= 0.0 { self.n } else { -self.n };
        let ns = if self.ns.dot(ng) >= 0.0 { self.ns } else { -self.ns };
        let ns = if ns.dot(wo) > 0.0 { ns } else { ng };
        (ng, ns)
    }
}

/// A sampled scattering direction.
#[derive(Debug, Clone, Copy)]
pub(crate) struct BsdfSample<const N: usize> {
    /// Unit direction towards where the light comes from.
    pub(crate) wi: Vec3,
    /// f · |cos θ_i| / pdf: the factor the path throughput is multiplied by.
    pub(crate) weight: SampledSpectrum<N>,
    /// Density of `wi` per steradian (for MIS); meaningless for specular samples.
    pub(crate) pdf: f32,
    /// Whether the lobe is a Dirac delta (no light sampling, no MIS).
    pub(crate) specular: bool,
    /// η² of a refraction (1 otherwise): radiance scaling undone in Russian roulette
    /// (pbrt-v4's `etaScale`).
    pub(crate) eta_scale: f32,
}

impl<const N: usize> Bsdf<N> {
    /// Whether the model has only delta lobes (light sampling is pointless there).
    #[inline]
    pub(crate) fn is_specular(&self) -> bool {
        !matches!(self, Self::Lambertian { .. })
    }

    /// f(wo, wi) · |cos θ_i| for non-specular models (0 for delta lobes, whose value at a
    /// sampled light direction is zero with probability one).
    #[inline]
    pub(crate) fn f_cos(&self, frame: &Frame, wo: Vec3, wi: Vec3) -> SampledSpectrum<N> {
        match *self {
            Self::Lambertian { r } => {
                let (ng, ns) = frame.facing(wo);
                // Both normals must agree that wi is on wo's side: no light leaks through.
                let cos = ns.dot(wi);
                if cos <= 0.0 || ng.dot(wi) <= 0.0 {
                    return SampledSpectrum([0.0; N]);
                }
                r * (cos * std::f32::consts::FRAC_1_PI)
            }
            Self::Dielectric { .. } | Self::Mirror { .. } => SampledSpectrum([0.0; N]),
        }
    }

    /// Density per steradian with which [`Bsdf::sample`] picks `wi`.
    #[inline]
    pub(crate) fn pdf(&self, frame: &Frame, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Self::Lambertian { .. } => {
                let (ng, ns) = frame.facing(wo);
                let cos = ns.dot(wi);
                if cos <= 0.0 || ng.dot(wi) <= 0.0 { 0.0 } else { cos * std::f32::consts::FRAC_1_PI }
            }
            Self::Dielectric { .. } | Self::Mirror { .. } => 0.0,
        }
    }

    /// Sample an incident direction; `uc` chooses between reflection and refraction, `u` the
    /// direction. `None` when the sample carries no light.
    #[inline]
    pub(crate) fn sample(&self, frame: &Frame, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample<N>> {
        let (ng, ns) = frame.facing(wo);
        match *self {
            Self::Lambertian { r } => {
                let wi = cosine_hemisphere(ns, u);
                let cos = ns.dot(wi);
                if cos <= 0.0 || ng.dot(wi) <= 0.0 {
                    return None;
                }
                Some(BsdfSample {
                    wi,
                    weight: r,
                    pdf: cos * std::f32::consts::FRAC_1_PI,
                    specular: false,
                    eta_scale: 1.0,
                })
            }
            Self::Mirror { r } => {
                let wi = mirror(wo, ns, ng);
                Some(BsdfSample { wi, weight: r, pdf: 1.0, specular: true, eta_scale: 1.0 })
            }
            Self::Dielectric { eta, tint } => {
                // Fresnel against the stored normal keeps track of inside and outside.
                // (The shading normal lies in the stored normal's hemisphere; where it puts wo on
                // the other side than the geometric normal does, trust the geometric one.)
                let n_out = if frame.ns.dot(wo).signum() == frame.n.dot(wo).signum() { frame.ns } else { frame.n };
                let f = fr_dielectric(n_out.dot(wo), eta);
                if uc < f {
                    // Reflection with probability F: weight F / F = 1.
                    let wi = mirror(wo, ns, ng);
                    return Some(BsdfSample {
                        wi,
                        weight: SampledSpectrum([1.0; N]),
                        pdf: f,
                        specular: true,
                        eta_scale: 1.0,
                    });
                }
                let (wi, etap) = match refract(wo, n_out, eta) {
                    Some((wi, etap)) if wi.dot(ng) < 0.0 => (wi, etap),
                    Some(_) => refract(wo, frame.n, eta)?,
                    None => return None, // F = 1 then, so this branch has probability 0.
                };
                // Transmission with probability 1 − F: weight (1 − F) T / ((1 − F) η'²).
                Some(BsdfSample {
                    wi,
                    weight: tint * (1.0 / (etap * etap)),
                    pdf: 1.0 - f,
                    specular: true,
                    eta_scale: etap * etap,
                })
            }
        }
    }
}

/// Mirror reflection about the shading normal, falling back to the geometric normal where the
/// shading normal would send the ray below the surface.
#[inline]
fn mirror(wo: Vec3, ns: Vec3, ng: Vec3) -> Vec3 {
    let wi = reflect(wo, ns);
    if wi.dot(ng) > 0.0 { wi } else { reflect(wo, ng) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::{Rng, uniform_sphere};

    const FRAME: Frame = Frame { n: Vec3::Z, ns: Vec3::Z };

    /// Directional albedo ∫ f |cos| dωi estimated from `count` samples of `bsdf.sample`, the
    /// refraction's radiance scaling η'² undone (it moves radiance between media; it creates no
    /// energy), for `wo` above or below the surface.
    fn albedo(bsdf: &Bsdf<4>, wo: Vec3, count: u32, rng: &mut Rng) -> f64 {
        let mut sum = 0.0f64;
        for _ in 0..count {
            if let Some(s) = bsdf.sample(&FRAME, wo, rng.uniform(), rng.uniform2()) {
                assert!(s.weight.is_finite() && s.wi.is_finite());
                sum += f64::from(s.weight.max_component() * s.eta_scale);
            }
        }
        sum / f64::from(count)
    }

    #[test]
    fn every_bsdf_reflects_no_more_than_it_receives() {
        // For each model, 200 directions over the whole sphere (both sides), 2000 samples
        // each. The estimator is bounded by 1 sample-wise (weights are F/F, (1−F)T/(1−F) or R),
        // so any mean above 1 + 1e-5 (rounding) would be a real energy gain.
        let mut rng = Rng::new(42, 0, 0);
        let models = [
            Bsdf::Lambertian { r: SampledSpectrum([1.0, 0.5, 0.2, 0.0]) },
            Bsdf::Mirror { r: SampledSpectrum([1.0, 0.9, 0.8, 0.7]) },
            Bsdf::Dielectric { eta: 1.5, tint: SampledSpectrum([1.0; 4]) },
            Bsdf::Dielectric { eta: 1.33, tint: SampledSpectrum([0.9, 0.8, 0.7, 0.6]) },
            Bsdf::Dielectric { eta: 0.0, tint: SampledSpectrum([1.0; 4]) },
        ];
        for bsdf in &models {
            for _ in 0..200 {
                let wo = uniform_sphere(rng.uniform2());
                if wo.z.abs() < 1e-3 {
                    continue;
                }
                let a = albedo(bsdf, wo, 2000, &mut rng);
                assert!(a <= 1.0 + 1e-5, "{bsdf:?} at {wo}: albedo {a}");
            }
        }
    }

    #[test]
    fn white_lambertian_albedo_is_one_and_f_matches_pdf() {
        let bsdf = Bsdf::Lambertian { r: SampledSpectrum([1.0; 4]) };
        let wo = Vec3::new(0.3, 0.1, 0.9).normalize();
        let mut rng = Rng::new(1, 1, 1);
        for _ in 0..1000 {
            let s = bsdf.sample(&FRAME, wo, rng.uniform(), rng.uniform2()).expect("above the surface");
            // f cos / pdf = R exactly, and eval agrees with sample.
            let f = bsdf.f_cos(&FRAME, wo, s.wi);
            assert!((f.0[0] / s.pdf - 1.0).abs() < 1e-4);
            assert!((bsdf.pdf(&FRAME, wo, s.wi) - s.pdf).abs() < 1e-6);
        }
        // Lit from below: nothing reflected towards wo.
        assert_eq!(bsdf.f_cos(&FRAME, wo, -Vec3::Z).0, [0.0; 4]);
    }

    #[test]
    fn dielectric_chooses_reflection_with_the_fresnel_probability() {
        // Normal incidence on η = 1.5: F = 0.04. The share of reflected samples over 20 000
        // draws has standard deviation √(F(1−F)/n) = 0.0014; 5 of them.
        let bsdf = Bsdf::Dielectric { eta: 1.5, tint: SampledSpectrum([1.0; 4]) };
        let mut rng = Rng::new(3, 0, 0);
        let n = 20_000;
        let reflected =
            (0..n).filter(|_| bsdf.sample(&FRAME, Vec3::Z, rng.uniform(), rng.uniform2()).unwrap().wi.z > 0.0).count();
        assert!((reflected as f64 / f64::from(n) - 0.04).abs() < 5.0 * 0.0014);
        // The transmitted ray goes straight through and carries 1/η² of the radiance.
        let t = bsdf.sample(&FRAME, Vec3::Z, 0.99, Vec2::ZERO).unwrap();
        assert!((t.wi + Vec3::Z).length() < 1e-6);
        assert!((t.weight.0[0] - 1.0 / 2.25).abs() < 1e-6 && (t.eta_scale - 2.25).abs() < 1e-6);
    }
}
