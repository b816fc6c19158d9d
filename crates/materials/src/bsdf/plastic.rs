//! Plastic: a dielectric coat of relative index η, smooth or GGX-rough, over a Lambertian base, with the
//! light reflected back and forth between the coat and the base summed in closed form. The model is
//! Mitsuba 3's `plastic` / `roughplastic` (after Weidlich & Wilkie 2007's layering), so that a scene
//! moves between the two renderers unchanged, in the local shading frame (ω_o in +z):
//!
//! ```text
//! f(ω_o, ω_i) = F(ω_o·ω_h) D(ω_h) G(ω_o, ω_i) / (4 μ_o μ_i)                 (the coat; a delta when smooth)
//!             + ρ / (1 − ρ_int) · T(μ_o) T(μ_i) / (π η²)                     (the base seen through it)
//! ```
//!
//! - T(μ) is the coat's transmittance for light arriving at cos θ = μ from outside: 1 − F(μ) when smooth,
//!   else the single-scattering GGX transmission albedo (refraction through visible microfacets, masked);
//! - ρ_int = 2 ∫ R_int(μ) μ dμ is the coat's reflectance for the base's diffuse light seen from inside
//!   (index 1/η, total internal reflection included), R_int its directional reflectance;
//! - ρ/(1 − ρ_int) sums the bounces under the coat with the base's colour applied once (Mitsuba's default,
//!   `"nonlinear": false`); with `nonlinear` it is ρ/(1 − ρ ρ_int), the geometric series of the base's
//!   colour at every bounce, which darkens and saturates colours as real varnished paint does.
//!
//! The 1/η² is the radiance compression when light leaves the denser coat. For a smooth coat and a white
//! base the two terms reflect exactly 1 in a furnace (T integrates to η² (1 − ρ_int)). A rough coat as
//! Mitsuba writes it loses much more than its single-scattering GGX interface does, because the light
//! under it crosses that interface many times: as written here a white plastic reflects 0.797 of a white
//! furnace at α 0.2, 0.553 at α 0.5 and 0.365 at α 1 (normal incidence); Mitsuba 3.9.1's own `roughplastic`
//! reads 0.794, 0.540, 0.336, the difference being the masking term above. That is what
//! `"multiple_scattering": false` renders, for comparisons.
//!
//! By default (`compensate`) the energy is conserved instead, reciprocally: what the coat does not reflect
//! enters it, T(μ) = 1 − R(μ) with R the coat's single-scattering reflection albedo, and ρ_int = 1 −
//! T_avg/η² with T_avg = 2 ∫ T(μ) μ dμ, the relation the smooth coat satisfies exactly. A white base then
//! reflects R(μ) + T(μ) = 1 at every roughness; a smooth coat is unchanged (both readings coincide).
//!
//! Differences from Mitsuba 3 worth knowing (measured in `xtask/compare/mitsuba_materials.py`):
//! - the shadowing–masking G is the height-correlated Smith form the other GGX lobes here use (Mitsuba's
//!   is the separable G1·G1, which shadows more at grazing angles: Heitz 2014 shows the correlated form
//!   is the exact one for the microsurface both assume);
//! - the tables are per (α, η) material, T on 64 nodes in √μ (Mitsuba: 64 in μ), read linearly; ρ_int is
//!   Mitsuba's 64-node average (which reads ≈ 1.6 % below the integral: the white furnace of the next
//!   paragraph is 0.807 at α 0.2 with the integral, 0.797 with Mitsuba's rule, 0.794 in Mitsuba).
//!
//! Sampling picks the coat with probability ∝ (1 − T(μ_o)) w against T(μ_o)(1 − w), w = 1/(1 + mean ρ)
//! (Mitsuba's rule), then a visible normal or a cosine-weighted direction.

use std::collections::HashMap;
use std::f32::consts::FRAC_1_PI;
use std::sync::{LazyLock, Mutex};

use colorimetry::SampledSpectrum;
use glam::{Vec2, Vec3};

use super::compensation::stratum;
use super::microfacet::TrowbridgeReitz;
use super::{BxdfFlags, LocalSample, glossy_or_cosine_pdf};
use crate::sampling::cosine_hemisphere;
use crate::scattering::{fr_dielectric, reflect, refract};

/// Nodes of the transmittance table, uniform in √μ on [0, 1] (dense near grazing, where T changes fastest).
const TABLE_MU: usize = 64;
/// Stratified visible-normal samples per node of a rough coat (side of the square).
const STRATA: usize = 32;
/// The smallest μ a node is computed at (exactly grazing has no albedo defined).
const MU_FLOOR: f32 = 1e-4;
/// Nodes of Mitsuba 3's `roughplastic` tables (`MI_ROUGH_TRANSMITTANCE_RES`).
const MITSUBA_NODES: usize = 64;
/// Sub-intervals of the smooth coat's internal-reflectance integral (midpoint rule; the integrand has
/// a kink at the critical angle, so many).
const SMOOTH_STEPS: usize = 1 << 14;

/// A coat's transmittance T(μ) on [`TABLE_MU`] nodes uniform in √μ, and its internal diffuse reflectance.
#[derive(Debug)]
pub struct PlasticTable {
    transmittance: [f32; TABLE_MU],
    internal_reflectance: f32,
}

/// The direction in the xz plane at cos θ = μ (floored at [`MU_FLOOR`]).
#[inline]
fn at_mu(mu: f32) -> Vec3 {
    let mu = mu.clamp(MU_FLOOR, 1.0);
    Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu)
}

/// Single-scattering albedos (reflected, transmitted) of a GGX interface of relative index `eta` (the far
/// side over `wo`'s side, so `1/η` from inside) seen from `wo` (z > 0): visible normals, each weighted by
/// its Fresnel share and the masking of the outgoing direction given `wo`'s, G(ω_o, ω)/G1(ω_o).
fn interface_albedos(d: &TrowbridgeReitz, wo: Vec3, eta: f32) -> (f32, f32) {
    let g1 = d.g1(wo);
    let (mut r, mut t) = (0.0f64, 0.0f64);
    for i in 0..STRATA {
        for j in 0..STRATA {
            let wm = d.sample_wm(wo, stratum(i, j, STRATA));
            let f = fr_dielectric(wo.dot(wm), eta);
            let wr = reflect(wo, wm);
            if wr.z > 0.0 {
                r += f64::from(f * d.g(wo, wr) / g1);
            }
            if f < 1.0
                && let Some((wt, _)) = refract(wo, wm, eta)
                && wt.z < 0.0
            {
                t += f64::from((1.0 - f) * d.g(wo, wt) / g1);
            }
        }
    }
    let n = (STRATA * STRATA) as f64;
    ((r / n) as f32, (t / n) as f32)
}

impl PlasticTable {
    /// The table of a coat of GGX roughness `alpha` (below 1e-3: smooth) and relative index `eta` > 0, with
    /// the energy single scattering loses given back (`compensate`, module docs) or not (Mitsuba's).
    fn compute(alpha: f32, eta: f32, compensate: bool) -> Self {
        let d = TrowbridgeReitz::isotropic(alpha);
        let node = |m: usize| m as f32 / (TABLE_MU - 1) as f32;
        // 2 ∫ g(μ) μ dμ = 4 ∫ g(s²) s³ ds of a function tabulated on the √μ nodes (trapezoid rule).
        let cosine_average = |g: &[f32; TABLE_MU]| {
            let integrand = |m: usize| 4.0 * g[m] * node(m).powi(3);
            let inner: f32 = (1..TABLE_MU - 1).map(integrand).sum();
            (inner + 0.5 * (integrand(0) + integrand(TABLE_MU - 1))) / (TABLE_MU - 1) as f32
        };
        let mut transmittance = [0.0; TABLE_MU];
        if d.effectively_smooth() {
            for (m, t) in transmittance.iter_mut().enumerate() {
                *t = 1.0 - fr_dielectric(at_mu(node(m) * node(m)).z, eta);
            }
            // 2 ∫ F(μ, 1/η) μ dμ, midpoint rule (equal to 1 − T_avg/η², so compensation changes nothing).
            let h = 1.0 / SMOOTH_STEPS as f64;
            let sum: f64 = (0..SMOOTH_STEPS)
                .map(|k| {
                    let mu = (k as f64 + 0.5) * h;
                    f64::from(fr_dielectric(mu as f32, 1.0 / eta)) * mu
                })
                .sum();
            return Self { transmittance, internal_reflectance: (2.0 * h * sum) as f32 };
        }
        if compensate {
            for (m, t) in transmittance.iter_mut().enumerate() {
                *t = 1.0 - interface_albedos(&d, at_mu(node(m) * node(m)), eta).0;
            }
            let internal_reflectance = 1.0 - cosine_average(&transmittance) / (eta * eta);
            return Self { transmittance, internal_reflectance };
        }
        for (m, t) in transmittance.iter_mut().enumerate() {
            *t = interface_albedos(&d, at_mu(node(m) * node(m)), eta).1;
        }
        // ρ_int as Mitsuba 3 computes it, so that this reading is its model: 2 × the mean of R_int(μ) μ over
        // 64 evenly spaced μ including both ends (a Riemann sum 63/64 of the trapezoid rule's, so ≈ 1.6 %
        // below the integral; the compensated reading integrates).
        let internal_reflectance = 2.0
            * (0..MITSUBA_NODES)
                .map(|i| {
                    let mu = i as f32 / (MITSUBA_NODES - 1) as f32;
                    interface_albedos(&d, at_mu(mu), 1.0 / eta).0 * mu
                })
                .sum::<f32>()
            / MITSUBA_NODES as f32;
        Self { transmittance, internal_reflectance }
    }

    /// T(μ), linear in √μ between nodes.
    #[inline]
    pub(crate) fn transmittance(&self, mu: f32) -> f32 {
        let t = mu.clamp(0.0, 1.0).sqrt() * (TABLE_MU - 1) as f32;
        let i = (t as usize).min(TABLE_MU - 2);
        let f = t - i as f32;
        self.transmittance[i] + f * (self.transmittance[i + 1] - self.transmittance[i])
    }

    /// ρ_int: the fraction of the base's diffuse light the coat reflects back down.
    #[inline]
    pub(crate) fn internal_reflectance(&self) -> f32 {
        self.internal_reflectance
    }
}

/// The table of a coat of GGX roughness `alpha` and index `eta`, compensated or not, computed once per
/// distinct case and kept for the process (a scene has a handful of plastics; the path tracer asks for it
/// while assembling, never per hit).
pub fn plastic_table(alpha: f32, eta: f32, compensate: bool) -> &'static PlasticTable {
    type Key = (u32, u32, bool);
    static TABLES: LazyLock<Mutex<HashMap<Key, &'static PlasticTable>>> = LazyLock::new(Default::default);
    // The lobe reads a smooth table for any α below the smooth threshold: one key for all of them.
    let d = TrowbridgeReitz::isotropic(alpha);
    let alpha = if d.effectively_smooth() { 0.0 } else { d.alpha_iso() };
    let eta = if eta.is_finite() && eta > 0.0 { eta } else { 1.5 };
    // (A smooth coat's table is the same either way.)
    let compensate = compensate && alpha > 0.0;
    let key = (alpha.to_bits(), eta.to_bits(), compensate);
    let mut tables = TABLES.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    tables.entry(key).or_insert_with(|| Box::leak(Box::new(PlasticTable::compute(alpha, eta, compensate))))
}

/// A plastic at one hit.
#[derive(Debug, Clone, Copy)]
pub struct PlasticBxdf<const N: usize> {
    /// ρ/(1 − ρ_int) (or ρ/(1 − ρ ρ_int)) / (π η²): the base term without the two transmittances.
    diffuse: SampledSpectrum<N>,
    /// Probability weight w of the coat in sampling.
    coat_weight: f32,
    distrib: TrowbridgeReitz,
    eta: f32,
    table: &'static PlasticTable,
}

impl<const N: usize> PlasticBxdf<N> {
    /// A coat of roughness `distrib` and index `eta` (inside over outside, as every dielectric here) over a
    /// base of reflectance `base` in [0, 1]; `nonlinear` as the module docs say. `table` must be
    /// [`plastic_table`] of the same α and η.
    pub fn new(
        base: SampledSpectrum<N>,
        distrib: TrowbridgeReitz,
        eta: f32,
        nonlinear: bool,
        table: &'static PlasticTable,
    ) -> Self {
        let base = base.map(|b| if b.is_finite() { b.clamp(0.0, 1.0) } else { 0.0 });
        let rho_int = table.internal_reflectance();
        let eta = if eta.is_finite() && eta > 0.0 { eta } else { 1.5 };
        let diffuse = base.map(|b| {
            let denominator = 1.0 - if nonlinear { b * rho_int } else { rho_int };
            if denominator > 0.0 { b / denominator * FRAC_1_PI / (eta * eta) } else { 0.0 }
        });
        Self { diffuse, coat_weight: 1.0 / (1.0 + base.average()), distrib, eta, table }
    }

    /// Whether the coat is a delta lobe.
    #[inline]
    fn is_smooth(&self) -> bool {
        self.distrib.effectively_smooth()
    }

    /// What the model can do.
    pub(crate) fn flags(&self) -> BxdfFlags {
        let coat = if self.is_smooth() { BxdfFlags::SPECULAR } else { BxdfFlags::GLOSSY };
        BxdfFlags::REFLECTION | BxdfFlags::DIFFUSE | coat
    }

    /// Probability of sampling the coat from `wo` (Mitsuba's rule, module docs).
    #[inline]
    fn coat_probability(&self, mu_o: f32) -> f32 {
        let t = self.table.transmittance(mu_o);
        let coat = (1.0 - t) * self.coat_weight;
        let base = t * (1.0 - self.coat_weight);
        if coat + base > 0.0 { coat / (coat + base) } else { 1.0 }
    }

    /// f(ω_o, ω_i) without the smooth coat's delta.
    pub(crate) fn f(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum<N> {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return SampledSpectrum([0.0; N]);
        }
        let mut f = self.diffuse * (self.table.transmittance(wo.z) * self.table.transmittance(wi.z));
        if !self.is_smooth() {
            let wm = (wo + wi).normalize();
            let coat =
                fr_dielectric(wo.dot(wm), self.eta) * self.distrib.d(wm) * self.distrib.g(wo, wi) / (4.0 * wo.z * wi.z);
            if coat.is_finite() {
                f += SampledSpectrum([coat; N]);
            }
        }
        f
    }

    /// Density of [`Self::sample_f`]'s non-delta samples.
    pub(crate) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        glossy_or_cosine_pdf(&self.distrib, self.is_smooth(), self.coat_probability(wo.z), wo, wi)
    }

    /// The coat with [`Self::coat_probability`], else the base.
    pub(crate) fn sample_f(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<LocalSample<N>> {
        if wo.z <= 0.0 {
            return None;
        }
        let p = self.coat_probability(wo.z);
        let coat = uc < p;
        if coat && self.is_smooth() {
            let f = fr_dielectric(wo.z, self.eta) / p;
            return Some(LocalSample {
                wi: Vec3::new(-wo.x, -wo.y, wo.z),
                f: SampledSpectrum([f; N]),
                pdf: p,
                flags: BxdfFlags::REFLECTION | BxdfFlags::SPECULAR,
                etap: 1.0,
            });
        }
        let wi = if coat { reflect(wo, self.distrib.sample_wm(wo, u)) } else { cosine_hemisphere(Vec3::Z, u) };
        if wi.z <= 0.0 {
            return None;
        }
        let (f, pdf) = (self.f(wo, wi), self.pdf(wo, wi));
        if !(pdf > 0.0) || !f.is_finite() {
            return None;
        }
        let kind = if coat { BxdfFlags::GLOSSY } else { BxdfFlags::DIFFUSE };
        Some(LocalSample { wi, f, pdf, flags: BxdfFlags::REFLECTION | kind, etap: 1.0 })
    }
}
