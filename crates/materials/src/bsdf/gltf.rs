//! The glTF 2.0 metallic–roughness BRDF of the specification's Appendix B ("BRDF Implementation"),
//! evaluated per wavelength, in the local shading frame (ω_o in +z):
//!
//! ```text
//! material        = mix(dielectric_brdf, metal_brdf, metallic)
//! metal_brdf      = conductor_fresnel(f0 = baseColor, bsdf = specular_brdf(α = roughness²))
//! dielectric_brdf = fresnel_mix(ior = 1.5, base = diffuse_brdf(color = baseColor),
//!                               layer = specular_brdf(α = roughness²))
//! ```
//!
//! with Schlick's Fresnel on |V·H| in both mixes, `diffuse_brdf` = color / π and
//! `specular_brdf` = D · V_smith, the GGX D and the height-correlated Smith visibility (which
//! equal [`TrowbridgeReitz::d`] and [`TrowbridgeReitz::g`] / (4 cos θ_o cos θ_i)). Below
//! roughness² = 1e-3 the specular layer is a delta lobe.
//!
//! `KHR_materials_specular` ([`GltfMetalRoughBxdf::with_specular`]) scales the dielectric layer's
//! Fresnel by its factor and tints its F0 per wavelength; `KHR_materials_clearcoat`'s layer is
//! [`GltfMetalRoughBxdf::clearcoat`].
//!
//! Three forms, each a step on the one before:
//!
//! - [`GltfMetalRoughBxdf::new`]: the spec's formula. Its `fresnel_mix` weights the diffuse layer by
//!   1 − F(V·H) for each light direction while the specular layer reflects about F(N·V) in total, so
//!   at grazing view a dielectric reflects more than it receives (measured: albedo 1.59 for smooth
//!   white plastic at 85°, 1.11 at roughness 0.5).
//! - [`GltfMetalRoughBxdf::conserving`]: the specular and metal layers as written, the diffuse layer
//!   coupled by albedo scaling instead (Kelemen & Szirmay-Kalos 2001; Kulla & Conty 2017): f_d = base
//!   (1 − E_s(μ_o)) (1 − E_s(μ_i)) / (π (1 − E_s,avg)), E_s the specular layer's directional albedo,
//!   which is reciprocal and makes a white dielectric reflect exactly 1 in a furnace. Its microfacet
//!   layers are single-scattering GGX, which loses the light that meets a second microfacet: glTF's
//!   default material (white, metallic 1, roughness 1) reflects 1 − ln 2 ≈ 0.31 at normal view, a white
//!   metal at roughness 0.5 about 0.9.
//! - [`GltfMetalRoughBxdf::compensated`] (what the path tracer builds unless a material turns
//!   `multiple_scattering` off): the conserving model plus Kulla & Conty's reciprocal
//!   multiple-scattering lobe f_ms = F_ms (1 − E(μ_o)) (1 − E(μ_i)) / (π (1 − E_avg)) of each
//!   microfacet layer, E the white GGX mirror's albedo ([`super::compensation`]) and F_ms =
//!   F_avg² E_avg / (1 − F_avg (1 − E_avg)) from the layer's average Schlick Fresnel F_avg = f0 +
//!   (1 − f0)/21 (per wavelength: the base colour for the metal, F0(λ) and `specularFactor` for the
//!   dielectric layer). The metal then reflects F_avg-weighted white (a white metal exactly 1); the
//!   dielectric layer's lobe is what its multiple bounces send back out (the rest enters the diffuse
//!   layer), and the diffuse coupling reads the compensated layer albedo E_s + F_ms (1 − E), so a white
//!   dielectric still reflects exactly 1 and never more. Anisotropic lobes read the isotropic tables at
//!   their smaller α, the material's own, for the coupling and the lobe alike: a stretched lobe loses
//!   at least what the unstretched one does, so the lobe puts back no more than is lost and a little
//!   light stays lost.

use std::f32::consts::FRAC_1_PI;

use colorimetry::SampledSpectrum;
use glam::{Vec2, Vec3};

use super::compensation::conductor_table;
use super::microfacet::TrowbridgeReitz;
use super::{BxdfFlags, Direction, LocalSample, glossy_or_cosine_pdf};
use crate::sampling::cosine_hemisphere;
use crate::scattering::reflect;

/// The weight (1 − cos)⁵ of Schlick's approximation, `cos` clamped to [0, 1].
#[inline]
fn schlick_weight(cos: f32) -> f32 {
    (1.0 - cos.clamp(0.0, 1.0)).powi(5)
}

/// Schlick's approximation F = f0 + (1 − f0)(1 − cos)⁵ of a dielectric's Fresnel reflectance
/// (glTF Appendix B, `fresnel_mix`; `conductor_fresnel` is the same mix per wavelength).
#[inline]
pub(crate) fn schlick(f0: f32, cos: f32) -> f32 {
    f0 + (1.0 - f0) * schlick_weight(cos)
}

/// The glTF metallic–roughness model of one hit.
#[derive(Debug, Clone, Copy)]
pub struct GltfMetalRoughBxdf<const N: usize> {
    base: SampledSpectrum<N>,
    metallic: f32,
    distrib: TrowbridgeReitz,
    /// Dielectric reflectance at normal incidence, ((1 − ior) / (1 + ior))²; under
    /// `KHR_materials_specular` the largest F0(λ) of the layer (over the whole spectrum, not the lanes).
    f0: f32,
    /// `KHR_materials_specular`'s `specularFactor` (1 without it): scales the dielectric layer's Fresnel.
    specular_weight: f32,
    /// `KHR_materials_specular`'s F0(λ) per lane, where the material has the extension (the scalar
    /// arithmetic otherwise: per-lane Fresnel cost a glTF scene without it 0.3 % of its instructions); lane 0
    /// negative ([`NO_F0_LANES`]) where it has not. (Not an `Option`, whose tag would make the model larger
    /// than the conductor: see [`Coupling`].)
    f0_lanes: SampledSpectrum<N>,
    /// The diffuse coupling, and whether the multiple-scattering lobe is on ([`Coupling`]).
    coupling: Coupling,
    /// `KHR_materials_anisotropy`'s direction (the local x axis, along which α is `distrib`'s α_x).
    direction: Direction,
}

/// How the diffuse layer is coupled to the specular one, in one `f32`: the spec's `fresnel_mix` (negative);
/// albedo scaling by the single-scattering layer, its cosine-weighted average albedo E_s,avg ∈ [0, 1]
/// ([`GltfMetalRoughBxdf::conserving`]); or albedo scaling by the compensated layer, its average E_c,avg ∈
/// [0, 1] stored as [`Coupling::COMPENSATED`] + E_c,avg, with the multiple-scattering lobe on
/// ([`GltfMetalRoughBxdf::compensated`]). (Not an enum with a payload: its tag would make the model larger
/// than the conductor, and so every [`super::Bsdf`], and would take the niche the `Bsdf` keeps its own tag in.)
#[derive(Debug, Clone, Copy)]
struct Coupling(f32);

impl Coupling {
    /// The spec's `fresnel_mix`.
    const SPEC: Self = Self(-1.0);
    /// The offset of the compensated coupling's average (any number above 1 whose sum with a value in [0, 1]
    /// keeps 2⁻²² of it: 2 leaves 22 of the 24 bits, errors ≤ 2.4e-7).
    const COMPENSATED: f32 = 2.0;

    /// The average albedo the diffuse layer is scaled by; `None` for the spec's coupling.
    #[inline]
    fn avg(self) -> Option<f32> {
        if self.0 < 0.0 {
            None
        } else if self.0 >= Self::COMPENSATED {
            Some(self.0 - Self::COMPENSATED)
        } else {
            Some(self.0)
        }
    }

    /// Whether the multiple-scattering lobe is on.
    #[inline]
    fn compensated(self) -> bool {
        self.0 >= Self::COMPENSATED
    }
}

/// Cosine-weighted hemispherical average of Schlick's Fresnel of normal reflectance `f0`:
/// 2 ∫ (f0 + (1 − f0)(1 − μ)⁵) μ dμ = f0 + (1 − f0)/21.
#[inline]
fn schlick_avg(f0: f32) -> f32 {
    f0 + (1.0 - f0) / 21.0
}

/// Kulla & Conty's F_ms = F_avg² E_avg / (1 − F_avg (1 − E_avg)): the share of the light that meets
/// more than one microfacet and leaves, for microfacets of average Fresnel `f_avg` ∈ [0, 1] (a geometric
/// series of bounces, each reflecting F_avg) and a white mirror of average albedo `e_avg` ∈ (0, 1).
/// At most 1, and 1 for white microfacets.
#[inline]
fn fresnel_multiple(f_avg: f32, e_avg: f32) -> f32 {
    f_avg * f_avg * e_avg / (1.0 - f_avg * (1.0 - e_avg))
}

/// [`GltfMetalRoughBxdf::f0_lanes`]' lanes without `KHR_materials_specular` (any negative value).
const NO_F0_LANES: f32 = -1.0;

impl<const N: usize> GltfMetalRoughBxdf<N> {
    /// `base` the base colour as a reflectance spectrum, `metallic` and `roughness` in [0, 1]
    /// (clamped, as the spec requires), `ior` the dielectric index (1.5 unless
    /// `KHR_materials_ior` says otherwise).
    pub fn new(base: SampledSpectrum<N>, metallic: f32, roughness: f32, ior: f32) -> Self {
        let roughness = if roughness.is_finite() { roughness.clamp(0.0, 1.0) } else { 1.0 };
        let metallic = if metallic.is_finite() { metallic.clamp(0.0, 1.0) } else { 1.0 };
        let f0 = if ior > 0.0 { ((1.0 - ior) / (1.0 + ior)).powi(2) } else { 1.0 };
        Self {
            base: base.map(|b| b.clamp(0.0, 1.0)),
            metallic,
            distrib: TrowbridgeReitz::isotropic(roughness * roughness),
            f0,
            specular_weight: 1.0,
            f0_lanes: SampledSpectrum([NO_F0_LANES; N]),
            coupling: Coupling::SPEC,
            direction: Direction::NONE,
        }
    }

    /// The same model with `KHR_materials_anisotropy`: α along `direction` (a world-space vector in, or
    /// near, the tangent plane) raised to mix(α, 1, strength²), α across it unchanged, for the metal and
    /// dielectric specular lobes alike. Call before [`Self::conserving`] or [`Self::compensated`], whose
    /// coupling reads the distribution. A zero direction or strength leaves the model isotropic.
    pub fn with_anisotropy(self, strength: f32, direction: Vec3) -> Self {
        let strength = if strength.is_finite() { strength.clamp(0.0, 1.0) } else { 0.0 };
        let direction = Direction::new(direction);
        if strength == 0.0 || direction == Direction::NONE {
            return self;
        }
        Self { distrib: TrowbridgeReitz::stretched(self.distrib.alpha_iso(), strength), direction, ..self }
    }

    /// The anisotropic direction ([`Self::with_anisotropy`]).
    #[inline]
    pub(crate) fn direction(&self) -> Direction {
        self.direction
    }

    /// `KHR_materials_clearcoat`'s layer: `specular_brdf(α = roughness²)` alone, D · V_smith with no
    /// Fresnel (the coat's Fresnel is its mixing weight, [`crate::Coat::probability`]), which is this model
    /// as a white metal. Its [`Self::compensated`] form adds the white lobe (F_ms = 1): with F = 1 the
    /// light single scattering loses is microfacet geometry, not the Fresnel the weight already stands for,
    /// so the compensated coat reflects exactly its weight and a coat over a white conserving material
    /// reflects 1.
    pub fn clearcoat(roughness: f32) -> Self {
        Self::new(SampledSpectrum([1.0; N]), 1.0, roughness, 1.5)
    }

    /// The same model with `KHR_materials_specular` on its dielectric layer (`crate::DielectricSpecular`):
    /// `weight` its factor, `f0` its F0(λ) per lane and `f0_max` the largest F0 over the spectrum. Call
    /// before [`Self::conserving`] or [`Self::compensated`], whose coupling depends on the layer.
    pub fn with_specular(self, weight: f32, f0: SampledSpectrum<N>, f0_max: f32) -> Self {
        Self {
            f0: f0_max.clamp(0.0, 1.0),
            specular_weight: weight.clamp(0.0, 1.0),
            f0_lanes: f0.map(|v| if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) }),
            ..self
        }
    }

    /// The same model with the diffuse layer coupled by albedo scaling (module docs), so that
    /// it never reflects more than it receives.
    pub fn energy_conserving(base: SampledSpectrum<N>, metallic: f32, roughness: f32, ior: f32) -> Self {
        Self::new(base, metallic, roughness, ior).conserving()
    }

    /// This model with the diffuse layer coupled by albedo scaling (see [`Self::energy_conserving`]).
    pub fn conserving(self) -> Self {
        Self { coupling: Coupling(self.specular_albedo_avg(self.distrib.alpha_min())), ..self }
    }

    /// [`Self::compensated`] where `compensate` (a material's `multiple_scattering`), else
    /// [`Self::conserving`] (the specification's layers with the diffuse coupling).
    pub fn energy(self, compensate: bool) -> Self {
        if compensate { self.compensated() } else { self.conserving() }
    }

    /// This model conserving ([`Self::conserving`]) and with the multiple-scattering lobe of its metal and
    /// dielectric specular layers (module docs), the diffuse layer coupled to the compensated specular
    /// layer. A smooth model has nothing to compensate and is [`Self::conserving`]'s.
    pub fn compensated(self) -> Self {
        let alpha = self.distrib.alpha_min();
        let e_avg = conductor_table().e_avg(alpha);
        // (α this small reflects all but 1e-6 in single scattering: nothing to put back.)
        if self.is_smooth() || e_avg >= 1.0 - 1e-6 {
            return self.conserving();
        }
        let avg = self.specular_albedo_avg(alpha) + self.dielectric_multiple(e_avg) * (1.0 - e_avg);
        Self { coupling: Coupling(Coupling::COMPENSATED + avg.clamp(0.0, 1.0)), ..self }
    }

    /// E_avg of the white mirror for the multiple-scattering lobe, `None` without it.
    #[inline]
    fn multiple_scattering(&self) -> Option<f32> {
        self.coupling.compensated().then(|| conductor_table().e_avg(self.distrib.alpha_min()))
    }

    /// The dielectric layer's F_ms at its strongest wavelength (the diffuse coupling's, as
    /// [`Self::dielectric_fresnel`]): from specularFactor · Schlick(F0_max) averaged.
    #[inline]
    fn dielectric_multiple(&self, e_avg: f32) -> f32 {
        fresnel_multiple(self.specular_weight * schlick_avg(self.f0), e_avg)
    }

    /// The multiple-scattering lobe's F_ms per wavelength, both layers mixed by `metallic`.
    #[inline]
    fn fresnel_multiple(&self, e_avg: f32) -> SampledSpectrum<N> {
        let metal = if self.metallic > 0.0 {
            self.base.map(|b| fresnel_multiple(schlick_avg(b), e_avg)) * self.metallic
        } else {
            SampledSpectrum([0.0; N])
        };
        if self.metallic >= 1.0 {
            return metal;
        }
        let w = self.specular_weight;
        let dielectric = match (self.f0_lanes.0[0] >= 0.0).then_some(self.f0_lanes) {
            None => SampledSpectrum([self.dielectric_multiple(e_avg); N]),
            Some(f0) => f0.map(|f0| fresnel_multiple(w * schlick_avg(f0), e_avg)),
        };
        metal + dielectric * (1.0 - self.metallic)
    }

    /// The dielectric layer's Fresnel weight at `cos` for the diffuse coupling and sampling: its strongest
    /// wavelength's, specularFactor · Schlick(F0_max, cos) (the extension's `max_value(fr)`).
    #[inline]
    fn dielectric_fresnel(&self, cos: f32) -> f32 {
        self.specular_weight * schlick(self.f0, cos)
    }

    /// Directional albedo of the dielectric specular layer at μ: f0 E₁ + (1 − f0) E₂.
    #[inline]
    fn specular_albedo(&self, mu: f32, alpha: f32) -> f32 {
        if self.is_smooth() {
            return self.dielectric_fresnel(mu);
        }
        let t = conductor_table();
        self.layer_albedo(t.e(mu, alpha), t.e_schlick(mu, alpha))
    }

    /// [`Self::specular_albedo`] of a rough layer from the white mirror's albedos E₁ and E₂ at μ.
    #[inline]
    fn layer_albedo(&self, e1: f32, e2: f32) -> f32 {
        self.specular_weight * (self.f0 * e1 + (1.0 - self.f0) * e2)
    }

    /// Cosine-weighted average of [`Self::specular_albedo`].
    #[inline]
    fn specular_albedo_avg(&self, alpha: f32) -> f32 {
        if self.is_smooth() {
            // 2 ∫ (1 − μ)⁵ μ dμ = 1/21.
            return self.specular_weight * (self.f0 + (1.0 - self.f0) / 21.0);
        }
        let t = conductor_table();
        self.specular_weight * (self.f0 * t.e_avg(alpha) + (1.0 - self.f0) * t.e_schlick_avg(alpha))
    }

    /// Whether the specular layer is a delta lobe.
    #[inline]
    pub(crate) fn is_smooth(&self) -> bool {
        self.distrib.effectively_smooth()
    }

    /// What the model can do.
    pub(crate) fn flags(&self) -> BxdfFlags {
        let specular = if self.is_smooth() { BxdfFlags::SPECULAR } else { BxdfFlags::GLOSSY };
        // (The multiple-scattering lobe is diffuse-like and sampled as the diffuse layer is.)
        if self.metallic >= 1.0 && self.multiple_scattering().is_none() {
            BxdfFlags::REFLECTION | specular
        } else {
            BxdfFlags::REFLECTION | BxdfFlags::DIFFUSE | specular
        }
    }

    /// The total Fresnel weight of the specular layer at |V·H| = `vh`, per wavelength:
    /// (1 − metallic) F_dielectric + metallic F_conductor(base).
    #[inline]
    fn specular_fresnel(&self, vh: f32) -> SampledSpectrum<N> {
        let conductor = self.base + (SampledSpectrum([1.0; N]) - self.base) * schlick_weight(vh);
        match (self.f0_lanes.0[0] >= 0.0).then_some(self.f0_lanes) {
            None => conductor * self.metallic + (1.0 - self.metallic) * self.dielectric_fresnel(vh),
            Some(f0) => {
                let dielectric = f0 + (SampledSpectrum([1.0; N]) - f0) * schlick_weight(vh);
                conductor * self.metallic + dielectric * ((1.0 - self.metallic) * self.specular_weight)
            }
        }
    }

    /// The diffuse layer's value: (1 − metallic)(1 − F_dielectric(|V·H|)) base / π as the spec
    /// writes it, or the albedo-scaled coupling.
    #[inline]
    fn diffuse(&self, wo: Vec3, wi: Vec3, vh: f32) -> SampledSpectrum<N> {
        let weight = match self.coupling.avg() {
            None => 1.0 - self.dielectric_fresnel(vh),
            Some(avg) if avg >= 1.0 => 0.0,
            Some(avg) => {
                // The tables are isotropic: a lobe `KHR_materials_anisotropy` stretched reads them at its smaller α,
                // the material's own (its albedo is at most that of the unstretched lobe, so the diffuse layer
                // never gets more than the specular one leaves: no energy is gained, a little is lost).
                let alpha = self.distrib.alpha_min();
                let (eo, ei) = (self.specular_albedo(wo.z, alpha), self.specular_albedo(wi.z, alpha));
                ((1.0 - eo) * (1.0 - ei)).max(0.0) / (1.0 - avg)
            }
        };
        self.base * ((1.0 - self.metallic) * weight * FRAC_1_PI)
    }

    /// Probability of sampling the specular layer from `wo`, else the cosine lobe: its share of the energy
    /// estimated at V·H = N·V (metallic + (1 − metallic) F against (1 − metallic)(1 − F) · mean base);
    /// with the multiple-scattering lobe, the layers' albedos at μ_o from the tables instead, the cosine
    /// lobe then sampling the diffuse and multiple-scattering lobes by their energies together.
    #[inline]
    fn specular_probability(&self, wo: Vec3) -> f32 {
        let base = self.base.average().clamp(0.0, 1.0);
        let (ws, wd) = match self.multiple_scattering() {
            None => {
                let fr = self.dielectric_fresnel(wo.z);
                (self.metallic + (1.0 - self.metallic) * fr, (1.0 - self.metallic) * (1.0 - fr) * base)
            }
            Some(e_avg) => {
                let alpha = self.distrib.alpha_min();
                let t = conductor_table();
                let (e1, e2) = (t.e(wo.z, alpha), t.e_schlick(wo.z, alpha));
                let m = self.metallic;
                // Single scattering of each layer: Schlick's f0 E₁ + (1 − f0) E₂ (the metal's at its mean
                // colour); multiple scattering F_ms (1 − E₁); the diffuse layer what the compensated
                // dielectric layer leaves.
                let (metal, dielectric) = (base * e1 + (1.0 - base) * e2, self.layer_albedo(e1, e2));
                let (metal_ms, dielectric_ms) =
                    (fresnel_multiple(schlick_avg(base), e_avg), self.dielectric_multiple(e_avg));
                let single = m * metal + (1.0 - m) * dielectric;
                let multiple = (m * metal_ms + (1.0 - m) * dielectric_ms) * (1.0 - e1);
                let diffuse = (1.0 - m) * (1.0 - dielectric - dielectric_ms * (1.0 - e1)).max(0.0) * base;
                (single, multiple + diffuse)
            }
        };
        if ws + wd > 0.0 { ws / (ws + wd) } else { 1.0 }
    }

    /// f(ω_o, ω_i) without the delta part.
    pub(crate) fn f(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum<N> {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return SampledSpectrum([0.0; N]);
        }
        let wm = (wo + wi).normalize();
        let vh = wo.dot(wm).abs();
        if let Some(e_avg) = self.multiple_scattering() {
            // (Rough here: `compensated` leaves a smooth model without the lobe.)
            let spec = self.distrib.d(wm) * self.distrib.g(wo, wi) / (4.0 * wo.z * wi.z);
            return self.specular_fresnel(vh) * spec + self.compensated_lobes(wo.z, wi.z, e_avg);
        }
        let mut f = self.diffuse(wo, wi, vh);
        if !self.is_smooth() {
            let spec = self.distrib.d(wm) * self.distrib.g(wo, wi) / (4.0 * wo.z * wi.z);
            f += self.specular_fresnel(vh) * spec;
        }
        f
    }

    /// The multiple-scattering lobe and the diffuse layer coupled to the compensated dielectric layer, at
    /// cosines `mu_o`, `mu_i`: each a product of one factor per direction (so reciprocal), the factors read
    /// from the same table cells.
    #[inline]
    fn compensated_lobes(&self, mu_o: f32, mu_i: f32, e_avg: f32) -> SampledSpectrum<N> {
        let alpha = self.distrib.alpha_min();
        let t = conductor_table();
        let (eo, ei) = (t.e(mu_o, alpha), t.e(mu_i, alpha));
        let escape = ((1.0 - eo) * (1.0 - ei)).max(0.0) / (1.0 - e_avg);
        let mut f = self.fresnel_multiple(e_avg) * (escape * FRAC_1_PI);
        let avg = self.coupling.avg().unwrap_or(1.0);
        if self.metallic < 1.0 && avg < 1.0 {
            let dielectric_ms = self.dielectric_multiple(e_avg);
            let layer = |mu: f32, e1: f32| self.layer_albedo(e1, t.e_schlick(mu, alpha)) + dielectric_ms * (1.0 - e1);
            let (lo, li) = (layer(mu_o, eo), layer(mu_i, ei));
            let weight = ((1.0 - lo) * (1.0 - li)).max(0.0) / (1.0 - avg);
            f += self.base * ((1.0 - self.metallic) * weight * FRAC_1_PI);
        }
        f
    }

    /// Density of [`GltfMetalRoughBxdf::sample_f`]'s non-delta samples.
    pub(crate) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        glossy_or_cosine_pdf(&self.distrib, self.is_smooth(), self.specular_probability(wo), wo, wi)
    }

    /// Sample the specular layer with [`Self::specular_probability`], else the diffuse one.
    pub(crate) fn sample_f(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<LocalSample<N>> {
        if wo.z <= 0.0 {
            return None;
        }
        let p = self.specular_probability(wo);
        let specular = uc < p;
        if specular && self.is_smooth() {
            // Mirror direction: V·H = N·V; weight F / p.
            let wi = Vec3::new(-wo.x, -wo.y, wo.z);
            return Some(LocalSample {
                wi,
                f: self.specular_fresnel(wo.z) * (1.0 / p),
                pdf: p,
                flags: BxdfFlags::REFLECTION | BxdfFlags::SPECULAR,
                etap: 1.0,
            });
        }
        let wi = if specular {
            let wm = self.distrib.sample_wm(wo, u);
            reflect(wo, wm)
        } else {
            cosine_hemisphere(Vec3::Z, u)
        };
        if wi.z <= 0.0 {
            return None;
        }
        let (f, pdf) = (self.f(wo, wi), self.pdf(wo, wi));
        if !(pdf > 0.0) || !f.is_finite() {
            return None;
        }
        let kind = if specular { BxdfFlags::GLOSSY } else { BxdfFlags::DIFFUSE };
        Some(LocalSample { wi, f, pdf, flags: BxdfFlags::REFLECTION | kind, etap: 1.0 })
    }
}
