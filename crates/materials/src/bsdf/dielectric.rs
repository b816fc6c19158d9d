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
use super::{BsdfSample, BxdfFlags, Direction, LocalSample};
use crate::scattering::{fr_dielectric, reflect, refract};

/// A rough dielectric interface.
#[derive(Debug, Clone, Copy)]
pub struct RoughDielectricBxdf<const N: usize> {
    distrib: TrowbridgeReitz,
    eta: f32,
    tint: SampledSpectrum<N>,
    /// With energy compensation: α the albedo table is read at, min(1, √(α_x α_y)).
    compensation_alpha: Option<f32>,
    /// The world direction of the local x axis (α_x), where [`Self::along`] gave one.
    direction: Direction,
}

impl<const N: usize> RoughDielectricBxdf<N> {
    /// An interface of index `eta` (inside over outside, > 0) with roughness `distrib`,
    /// transmission filtered by `tint`; `compensate` scales the lobe by the inverse albedo.
    pub fn new(distrib: TrowbridgeReitz, eta: f32, tint: SampledSpectrum<N>, compensate: bool) -> Self {
        let compensation_alpha = compensate.then(|| distrib.alpha_iso().min(1.0));
        Self { distrib, eta, tint, compensation_alpha, direction: Direction::NONE }
    }

    /// The same lobe with its local x axis (where α is `distrib`'s α_x) along `direction`, a world-space
    /// vector in or near the tangent plane (`KHR_materials_anisotropy`); a zero or non-finite one leaves
    /// the frame as it was.
    pub fn along(self, direction: Vec3) -> Self {
        match Direction::new(direction) {
            Direction::NONE => self,
            direction => Self { direction, ..self },
        }
    }

    /// The direction of [`Self::along`].
    #[inline]
    pub(crate) fn direction(&self) -> Direction {
        self.direction
    }

    /// Index inside over outside.
    #[inline]
    pub(crate) fn eta(&self) -> f32 {
        self.eta
    }

    /// Transmission filter.
    #[inline]
    pub(crate) fn tint(&self) -> SampledSpectrum<N> {
        self.tint
    }

    /// Whether the interface is handled as smooth (α < 1e-3, or η = 1 which does not bend
    /// light, or η ≤ 0, glTF's "Fresnel ≡ 1").
    #[inline]
    pub(crate) fn is_smooth(&self) -> bool {
        self.distrib.effectively_smooth() || self.eta == 1.0 || self.eta <= 0.0
    }

    /// What the lobe can do.
    #[inline]
    pub(crate) fn flags(&self) -> BxdfFlags {
        let kind = if self.is_smooth() { BxdfFlags::SPECULAR } else { BxdfFlags::GLOSSY };
        BxdfFlags::REFLECTION | BxdfFlags::TRANSMISSION | kind
    }

    /// 1 / E(μ_o) (Turquin 2019) or 1.
    #[inline]
    fn compensation(&self, wo: Vec3) -> f32 {
        let Some(alpha) = self.compensation_alpha else { return 1.0 };
        let e = dielectric_table().e(wo.z.abs(), alpha, self.eta, wo.z < 0.0);
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
        let fr = fr_dielectric(wo.dot(wm), self.eta);
        let scale = self.compensation(wo);
        if reflect {
            SampledSpectrum([self.f_reflect(wo, wi, wm, fr) * scale; N])
        } else {
            self.tint * (self.f_transmit(wo, wi, wm, etap, fr) * scale)
        }
    }

    /// Density of [`RoughDielectricBxdf::sample_f`] in the local frame.
    pub(crate) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.is_smooth() {
            return 0.0;
        }
        let Some((wm, etap, reflect)) = self.half_vector(wo, wi) else { return 0.0 };
        let fr = fr_dielectric(wo.dot(wm), self.eta);
        if reflect { self.pdf_reflect(wo, wm, fr) } else { self.pdf_transmit(wo, wi, wm, etap, fr) }
    }

    /// The uncompensated value of the reflection off microfacet ω_m, Fresnel reflectance `fr`:
    /// D G F / |4 cos θ_i cos θ_o|.
    #[inline]
    fn f_reflect(&self, wo: Vec3, wi: Vec3, wm: Vec3, fr: f32) -> f32 {
        self.distrib.d(wm) * self.distrib.g(wo, wi) * fr / (4.0 * wi.z * wo.z).abs()
    }

    /// Density of sampling the reflection: the visible normal's density times the Jacobian
    /// 1 / (4 |ω_o·ω_m|), times the probability F of choosing reflection.
    #[inline]
    fn pdf_reflect(&self, wo: Vec3, wm: Vec3, fr: f32) -> f32 {
        self.distrib.d_visible(wo, wm) / (4.0 * wo.dot(wm).abs()) * fr
    }

    /// (ω_i·ω_m + ω_o·ω_m / η')², the denominator of refraction's Jacobian.
    #[inline]
    fn refraction_denom(wo: Vec3, wi: Vec3, wm: Vec3, etap: f32) -> f32 {
        (wi.dot(wm) + wo.dot(wm) / etap).powi(2)
    }

    /// The uncompensated, untinted value of the refraction through microfacet ω_m (Walter et
    /// al. 2007 eq. 21, radiance mode): D (1 − F) G |ω_i·ω_m ω_o·ω_m / (denom cos θ_i cos θ_o)| / η'².
    #[inline]
    fn f_transmit(&self, wo: Vec3, wi: Vec3, wm: Vec3, etap: f32, fr: f32) -> f32 {
        let denom = Self::refraction_denom(wo, wi, wm, etap) * wi.z * wo.z;
        self.distrib.d(wm) * (1.0 - fr) * self.distrib.g(wo, wi) * (wi.dot(wm) * wo.dot(wm) / denom).abs()
            / (etap * etap)
    }

    /// Density of sampling the refraction: the visible normal's density times the Jacobian
    /// |ω_i·ω_m| / denom, times the probability 1 − F of choosing refraction.
    #[inline]
    fn pdf_transmit(&self, wo: Vec3, wi: Vec3, wm: Vec3, etap: f32, fr: f32) -> f32 {
        self.distrib.d_visible(wo, wm) * wi.dot(wm).abs() / Self::refraction_denom(wo, wi, wm, etap) * (1.0 - fr)
    }

    /// Sample ω_i: a visible normal, then reflection with probability F, else refraction.
    pub(crate) fn sample_f(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<LocalSample<N>> {
        if wo.z == 0.0 {
            return None;
        }
        let wm = self.distrib.sample_wm(wo, u);
        let fr = fr_dielectric(wo.dot(wm), self.eta);
        let scale = self.compensation(wo);
        let (wi, f, pdf, flags, etap) = if uc < fr {
            let wi = reflect(wo, wm);
            if wi.z * wo.z <= 0.0 {
                return None;
            }
            let f = SampledSpectrum([self.f_reflect(wo, wi, wm, fr) * scale; N]);
            (wi, f, self.pdf_reflect(wo, wm, fr), BxdfFlags::REFLECTION | BxdfFlags::GLOSSY, 1.0)
        } else {
            // Total internal reflection has fr = 1, so this branch is not reached then; refract
            // can still fail by rounding at the critical angle.
            let (wi, etap) = refract(wo, wm, self.eta)?;
            if wi.z * wo.z >= 0.0 {
                return None;
            }
            let f = self.tint * (self.f_transmit(wo, wi, wm, etap, fr) * scale);
            (wi, f, self.pdf_transmit(wo, wi, wm, etap, fr), BxdfFlags::TRANSMISSION | BxdfFlags::GLOSSY, etap)
        };
        if !(pdf > 0.0) || !f.is_finite() {
            return None;
        }
        Some(LocalSample { wi, f, pdf, flags, etap })
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
    pub(crate) fn flags(&self) -> BxdfFlags {
        BxdfFlags::REFLECTION | BxdfFlags::TRANSMISSION | BxdfFlags::SPECULAR
    }

    /// Reflectance of the slab, inter-reflections included, at |cos θ| = `cos`.
    #[inline]
    pub(crate) fn reflectance(&self, cos: f32) -> f32 {
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
