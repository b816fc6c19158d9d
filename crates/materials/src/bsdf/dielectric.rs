//! Rough and thin dielectrics in the local shading frame (z = the interface normal the index
//! refers to; ω_o may be on either side).
//!
//! - [`RoughDielectricBxdf`]: GGX reflection and transmission (Walter et al. 2007,
//!   "Microfacet Models for Refraction through Rough Surfaces"; pbrt-v4 `DielectricBxDF`'s rough
//!   branch), radiance mode (transmitted radiance scaled by 1/η'²), optional Turquin 2019
//!   energy compensation. Below α = 1e-3 the smooth interface of [`super::Bsdf::Dielectric`]
//!   is used instead.
//! - [`ThinDielectricBxdf`]: a thin slab whose internal reflections are summed in closed form
//!   (pbrt-v4 `ThinDielectricBxDF`): R' = R + T² R / (1 − R²), T' = 1 − R'; transmission
//!   leaves along −ω_o.

use colorimetry::SampledSpectrum;
use glam::{Vec2, Vec3};

use super::compensation::dielectric_table;
use super::microfacet::TrowbridgeReitz;
use super::{BsdfSample, BxdfFlags, LocalSample};
use crate::scattering::{fr_dielectric, refract};

/// A rough dielectric interface.
#[derive(Debug, Clone, Copy)]
pub struct RoughDielectricBxdf<const N: usize> {
    distrib: TrowbridgeReitz,
    eta: f32,
    tint: SampledSpectrum<N>,
    compensate: bool,
}

impl<const N: usize> RoughDielectricBxdf<N> {
    /// An interface of index `eta` (inside over outside, > 0) with roughness `distrib`,
    /// transmission filtered by `tint`; `compensate` scales the lobe by the inverse albedo.
    pub fn new(distrib: TrowbridgeReitz, eta: f32, tint: SampledSpectrum<N>, compensate: bool) -> Self {
        Self { distrib, eta, tint, compensate }
    }

    /// Index inside over outside.
    #[inline]
    pub fn eta(&self) -> f32 {
        self.eta
    }

    /// Transmission filter.
    #[inline]
    pub fn tint(&self) -> SampledSpectrum<N> {
        self.tint
    }

    /// Whether the interface is handled as smooth (α < 1e-3, or η = 1 which does not bend
    /// light, or η ≤ 0, glTF's "Fresnel ≡ 1").
    #[inline]
    pub fn is_smooth(&self) -> bool {
        self.distrib.effectively_smooth() || self.eta == 1.0 || self.eta <= 0.0
    }

    /// What the lobe can do.
    #[inline]
    pub fn flags(&self) -> BxdfFlags {
        let kind = if self.is_smooth() { BxdfFlags::SPECULAR } else { BxdfFlags::GLOSSY };
        BxdfFlags::REFLECTION | BxdfFlags::TRANSMISSION | kind
    }

    /// 1 / E(μ_o) (Turquin 2019) or 1.
    #[inline]
    fn compensation(&self, wo: Vec3) -> f32 {
        if !self.compensate {
            return 1.0;
        }
        let e = dielectric_table().e(wo.z.abs(), self.distrib.alpha_iso().min(1.0), self.eta, wo.z < 0.0);
        if e > 0.0 { 1.0 / e } else { 1.0 }
    }

    /// The generalised half vector of (ω_o, ω_i) facing +z, the relative index η' crossed
    /// (1 for reflection), or `None` for degenerate or back-facing configurations.
    #[inline]
    fn half_vector(&self, wo: Vec3, wi: Vec3) -> Option<(Vec3, f32, bool)> {
        let (cos_o, cos_i) = (wo.z, wi.z);
        if cos_i == 0.0 || cos_o == 0.0 {
            return None;
        }
        let reflect = cos_i * cos_o > 0.0;
        let etap = if reflect {
            1.0
        } else if cos_o > 0.0 {
            self.eta
        } else {
            1.0 / self.eta
        };
        let wm = wi * etap + wo;
        if wm.length_squared() == 0.0 {
            return None;
        }
        let wm = wm.normalize();
        let wm = if wm.z < 0.0 { -wm } else { wm };
        // Microfacets seen from behind by either direction contribute nothing.
        if wm.dot(wi) * cos_i < 0.0 || wm.dot(wo) * cos_o < 0.0 {
            return None;
        }
        Some((wm, etap, reflect))
    }

    /// f(ω_o, ω_i) in the local frame.
    pub(crate) fn f(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum<N> {
        let black = SampledSpectrum([0.0; N]);
        if self.is_smooth() {
            return black;
        }
        let Some((wm, etap, reflect)) = self.half_vector(wo, wi) else { return black };
        let f = fr_dielectric(wo.dot(wm), self.eta);
        let (d, g) = (self.distrib.d(wm), self.distrib.g(wo, wi));
        let scale = self.compensation(wo);
        if reflect {
            SampledSpectrum([d * g * f / (4.0 * wi.z * wo.z).abs() * scale; N])
        } else {
            let denom = (wi.dot(wm) + wo.dot(wm) / etap).powi(2) * wi.z * wo.z;
            let ft = d * (1.0 - f) * g * (wi.dot(wm) * wo.dot(wm) / denom).abs() / (etap * etap);
            self.tint * (ft * scale)
        }
    }

    /// Density of [`RoughDielectricBxdf::sample_f`] in the local frame.
    pub(crate) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.is_smooth() {
            return 0.0;
        }
        let Some((wm, etap, reflect)) = self.half_vector(wo, wi) else { return 0.0 };
        let r = fr_dielectric(wo.dot(wm), self.eta);
        let dv = self.distrib.d_visible(wo, wm);
        if reflect {
            dv / (4.0 * wo.dot(wm).abs()) * r
        } else {
            let denom = (wi.dot(wm) + wo.dot(wm) / etap).powi(2);
            dv * wi.dot(wm).abs() / denom * (1.0 - r)
        }
    }

    /// Sample ω_i: a visible normal, then reflection with probability F, else refraction.
    pub(crate) fn sample_f(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<LocalSample<N>> {
        if wo.z == 0.0 {
            return None;
        }
        let wm = self.distrib.sample_wm(wo, u);
        let r = fr_dielectric(wo.dot(wm), self.eta);
        let (d, dv) = (self.distrib.d(wm), self.distrib.d_visible(wo, wm));
        let scale = self.compensation(wo);
        if uc < r {
            let wi = 2.0 * wo.dot(wm) * wm - wo;
            if wi.z * wo.z <= 0.0 {
                return None;
            }
            let pdf = dv / (4.0 * wo.dot(wm).abs()) * r;
            let f = d * self.distrib.g(wo, wi) * r / (4.0 * wi.z * wo.z).abs() * scale;
            if !(pdf > 0.0) || !f.is_finite() {
                return None;
            }
            return Some(LocalSample {
                wi,
                f: SampledSpectrum([f; N]),
                pdf,
                flags: BxdfFlags::REFLECTION | BxdfFlags::GLOSSY,
                etap: 1.0,
            });
        }
        // Total internal reflection has r = 1, so this branch is not reached then; refract
        // can still fail by rounding at the critical angle.
        let (wi, etap) = refract(wo, wm, self.eta)?;
        if wi.z * wo.z >= 0.0 {
            return None;
        }
        let denom = (wi.dot(wm) + wo.dot(wm) / etap).powi(2);
        let pdf = dv * wi.dot(wm).abs() / denom * (1.0 - r);
        let ft = d * (1.0 - r) * self.distrib.g(wo, wi) * (wi.dot(wm) * wo.dot(wm) / (denom * wi.z * wo.z)).abs()
            / (etap * etap);
        let f = self.tint * (ft * scale);
        if !(pdf > 0.0) || !f.is_finite() {
            return None;
        }
        Some(LocalSample { wi, f, pdf, flags: BxdfFlags::TRANSMISSION | BxdfFlags::GLOSSY, etap })
    }
}

/// A thin dielectric slab (smooth, both faces parallel): glTF transmission without volume.
#[derive(Debug, Clone, Copy)]
pub struct ThinDielectricBxdf<const N: usize> {
    eta: f32,
    tint: SampledSpectrum<N>,
}

impl<const N: usize> ThinDielectricBxdf<N> {
    /// A slab of index `eta` (> 0; 0 reflects everything), transmission filtered once by `tint`.
    pub fn new(eta: f32, tint: SampledSpectrum<N>) -> Self {
        Self { eta, tint }
    }

    /// What the lobe can do.
    #[inline]
    pub fn flags(&self) -> BxdfFlags {
        BxdfFlags::REFLECTION | BxdfFlags::TRANSMISSION | BxdfFlags::SPECULAR
    }

    /// Reflectance of the slab, inter-reflections included, at |cos θ| = `cos`.
    #[inline]
    pub fn reflectance(&self, cos: f32) -> f32 {
        let r = fr_dielectric(cos.abs(), self.eta);
        let t = 1.0 - r;
        if r < 1.0 { r + t * t * r / (1.0 - r * r) } else { r }
    }

    /// Reflect along `wr` (the caller's mirror direction) with probability R', else leave along
    /// `wt` (−ω_o); the weight is R'/R' = 1 or T'·tint/T' = tint. `cos_o` is ω_o's cosine
    /// against the interface normal.
    pub(crate) fn sample_f(&self, cos_o: f32, uc: f32, wr: Vec3, wt: Vec3) -> Option<BsdfSample<N>> {
        let r = self.reflectance(cos_o);
        let (wi, weight, pdf, flags) = if uc < r {
            (wr, SampledSpectrum([1.0; N]), r, BxdfFlags::REFLECTION | BxdfFlags::SPECULAR)
        } else {
            (wt, self.tint, 1.0 - r, BxdfFlags::TRANSMISSION | BxdfFlags::SPECULAR)
        };
        (pdf > 0.0).then_some(BsdfSample { wi, weight, pdf, eta_scale: 1.0, flags })
    }
}
