//! A rough conductor: GGX microfacets with the Fresnel reflectance of a complex index η + iκ
//! per wavelength (pbrt-v4 `ConductorBxDF`), plus an optional reciprocal multiple-scattering
//! lobe (Kulla & Conty 2017), in the local shading frame with ω_o in +z.

use std::f32::consts::FRAC_1_PI;

use colorimetry::{SampledSpectrum, SampledWavelengths};
use glam::{Vec2, Vec3};

use super::compensation::conductor_table;
use super::microfacet::TrowbridgeReitz;
use super::{BxdfFlags, LocalSample, Metal};
use crate::sampling::cosine_hemisphere;
use crate::scattering::{fr_conductor, reflect};

/// Reflectance is capped here when turned into an index, so κ = 2√r / √(1 − r) stays finite
/// (r = 1 − 1e-5 gives κ ≈ 632, F ≥ 0.99999 at every angle).
const MAX_REFLECTANCE: f32 = 1.0 - 1e-5;

/// 8-point Gauss–Legendre rule on [0, 1]: (node, weight) (Abramowitz & Stegun table 25.4,
/// mapped from [−1, 1]).
pub(crate) const GAUSS_LEGENDRE_8: [(f32, f32); 8] = [
    (0.019_855_072, 0.050_614_27),
    (0.101_666_76, 0.111_190_52),
    (0.237_233_8, 0.156_853_32),
    (0.408_282_68, 0.181_341_89),
    (0.591_717_3, 0.181_341_89),
    (0.762_766_2, 0.156_853_32),
    (0.898_333_24, 0.111_190_52),
    (0.980_144_9, 0.050_614_27),
];

/// The Kulla–Conty lobe's constants for one hit.
#[derive(Debug, Clone, Copy)]
struct MultiScatter<const N: usize> {
    /// F_ms = F_avg² E_avg / (1 − F_avg (1 − E_avg)) per wavelength, divided by π (1 − E_avg).
    scale: SampledSpectrum<N>,
    /// α the albedo table is read at (√(α_x α_y)).
    alpha: f32,
}

/// A rough conductor.
#[derive(Debug, Clone, Copy)]
pub struct ConductorBxdf<const N: usize> {
    distrib: TrowbridgeReitz,
    eta: SampledSpectrum<N>,
    k: SampledSpectrum<N>,
    ms: Option<MultiScatter<N>>,
}

impl<const N: usize> ConductorBxdf<N> {
    /// A conductor of complex index `eta` + i`k` (relative to the outside medium) per
    /// wavelength, roughness `distrib`; `compensate` adds the multiple-scattering lobe.
    pub fn new(distrib: TrowbridgeReitz, eta: SampledSpectrum<N>, k: SampledSpectrum<N>, compensate: bool) -> Self {
        let mut c = Self { distrib, eta, k, ms: None };
        if compensate && !distrib.effectively_smooth() {
            let alpha = distrib.alpha_iso().min(1.0);
            let table = conductor_table();
            let e_avg = table.e_avg(alpha);
            if e_avg < 1.0 - 1e-6 {
                // F_avg = 2 ∫ F(μ) μ dμ per wavelength.
                let mut f_avg = SampledSpectrum([0.0; N]);
                for &(mu, w) in &GAUSS_LEGENDRE_8 {
                    f_avg += c.fresnel(mu) * (2.0 * mu * w);
                }
                let f_ms = f_avg * f_avg * e_avg / (SampledSpectrum([1.0; N]) - f_avg * (1.0 - e_avg));
                c.ms = Some(MultiScatter { scale: f_ms * (FRAC_1_PI / (1.0 - e_avg)), alpha });
            }
        }
        c
    }

    /// A measured metal at the path's wavelengths.
    pub fn metal(metal: Metal, lambda: &SampledWavelengths<N>, distrib: TrowbridgeReitz, compensate: bool) -> Self {
        let (eta, k) = metal.ior().sample(lambda);
        Self::new(distrib, eta, k, compensate)
    }

    /// A conductor whose normal-incidence reflectance is `r` (η = 1, κ = 2√r / √(1 − r), as
    /// pbrt-v4's `ConductorMaterial` with `reflectance`), for artist colours such as glTF's
    /// base colour of a metal.
    pub fn from_reflectance(r: SampledSpectrum<N>, distrib: TrowbridgeReitz, compensate: bool) -> Self {
        let r = r.map(|r| r.clamp(0.0, MAX_REFLECTANCE));
        let k = r.map(|r| 2.0 * r.sqrt() / (1.0 - r).sqrt());
        Self::new(distrib, SampledSpectrum([1.0; N]), k, compensate)
    }

    /// What the lobe can do.
    #[inline]
    pub(crate) fn flags(&self) -> BxdfFlags {
        if self.distrib.effectively_smooth() {
            BxdfFlags::REFLECTION | BxdfFlags::SPECULAR
        } else {
            BxdfFlags::REFLECTION | BxdfFlags::GLOSSY
        }
    }

    /// Whether the lobe is a delta (α < 1e-3).
    #[inline]
    pub(crate) fn is_smooth(&self) -> bool {
        self.distrib.effectively_smooth()
    }

    /// Fresnel reflectance per wavelength at |cos θ| = `cos`.
    #[inline]
    pub(crate) fn fresnel(&self, cos: f32) -> SampledSpectrum<N> {
        let mut f = [0.0; N];
        for (i, f) in f.iter_mut().enumerate() {
            *f = fr_conductor(cos, self.eta.0[i], self.k.0[i]);
        }
        SampledSpectrum(f)
    }

    /// 1 − E(μ) of the white GGX mirror at `w` (0 without the multiple-scattering lobe): the
    /// Kulla–Conty lobe's factor for one direction and, from ω_o, its share of the energy
    /// (clamped to [0, 1], the probability of sampling it).
    #[inline]
    fn ms_escape(&self, w: Vec3) -> f32 {
        match self.ms {
            Some(ms) => 1.0 - conductor_table().e(w.z.abs(), ms.alpha),
            None => 0.0,
        }
    }

    /// The single-scattering microfacet value for a valid reflection pair.
    #[inline]
    fn f_single(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum<N> {
        let (cos_o, cos_i) = (wo.z.abs(), wi.z.abs());
        let wm = wi + wo;
        if cos_i == 0.0 || cos_o == 0.0 || wm.length_squared() == 0.0 {
            return SampledSpectrum([0.0; N]);
        }
        let wm = wm.normalize();
        let f = self.fresnel(wo.dot(wm).abs());
        f * (self.distrib.d(wm) * self.distrib.g(wo, wi) / (4.0 * cos_i * cos_o))
    }

    /// The Kulla–Conty value (1 − E(μ_o)) (1 − E(μ_i)) F_ms / (π (1 − E_avg)), with
    /// `escape_o` = [`Self::ms_escape`]`(wo)`.
    #[inline]
    fn f_multi(&self, escape_o: f32, wi: Vec3) -> SampledSpectrum<N> {
        match self.ms {
            Some(ms) => ms.scale * (escape_o * self.ms_escape(wi)).max(0.0),
            None => SampledSpectrum([0.0; N]),
        }
    }

    /// f(ω_o, ω_i) in the local frame (0 for the smooth lobe and across the surface).
    pub(crate) fn f(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum<N> {
        if wo.z * wi.z <= 0.0 || self.is_smooth() {
            return SampledSpectrum([0.0; N]);
        }
        self.f_with(wo, wi, self.ms_escape(wo))
    }

    /// [`Self::f`] of a valid rough pair, given [`Self::ms_escape`]`(wo)`.
    #[inline]
    fn f_with(&self, wo: Vec3, wi: Vec3, escape_o: f32) -> SampledSpectrum<N> {
        self.f_single(wo, wi) + self.f_multi(escape_o, wi)
    }

    /// Density of [`ConductorBxdf::sample_f`] in the local frame.
    pub(crate) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z * wi.z <= 0.0 || self.is_smooth() {
            return 0.0;
        }
        self.pdf_with(wo, wi, self.ms_escape(wo).clamp(0.0, 1.0))
    }

    /// [`Self::pdf`] of a valid rough pair, given the multiple-scattering lobe's probability.
    #[inline]
    fn pdf_with(&self, wo: Vec3, wi: Vec3, p_ms: f32) -> f32 {
        let wm = wo + wi;
        let single = if wm.length_squared() == 0.0 {
            0.0
        } else {
            let wm = wm.normalize();
            let wm = if wm.z < 0.0 { -wm } else { wm };
            self.distrib.d_visible(wo, wm) / (4.0 * wo.dot(wm).abs())
        };
        (1.0 - p_ms) * single + p_ms * wi.z.abs() * FRAC_1_PI
    }

    /// Sample ω_i from ω_o (z > 0) in the local frame; `uc` picks the multiple-scattering lobe.
    pub(crate) fn sample_f(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<LocalSample<N>> {
        if wo.z <= 0.0 {
            return None;
        }
        if self.is_smooth() {
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            return Some(LocalSample {
                wi,
                f: self.fresnel(wo.z),
                pdf: 1.0,
                flags: BxdfFlags::REFLECTION | BxdfFlags::SPECULAR,
                etap: 1.0,
            });
        }
        let escape_o = self.ms_escape(wo);
        let p_ms = escape_o.clamp(0.0, 1.0);
        let wi = if uc < p_ms {
            cosine_hemisphere(Vec3::Z, u)
        } else {
            let wm = self.distrib.sample_wm(wo, u);
            reflect(wo, wm)
        };
        if wi.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf_with(wo, wi, p_ms);
        let f = self.f_with(wo, wi, escape_o);
        if !(pdf > 0.0) || !f.is_finite() {
            return None;
        }
        Some(LocalSample { wi, f, pdf, flags: BxdfFlags::REFLECTION | BxdfFlags::GLOSSY, etap: 1.0 })
    }
}
