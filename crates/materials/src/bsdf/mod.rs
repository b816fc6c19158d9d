//! Scattering models evaluated at a path's wavelengths: a per-hit value type [`Bsdf`] with
//! `f`, `sample_f`, `pdf` and [`BxdfFlags`] (pbrt-v4 `base/bxdf.h`, `bxdfs.h`), in world
//! space around a [`Frame`] of geometric and shading normals.
//!
//! The lobes:
//! - [`Bsdf::Lambertian`]: reflectance `r`, reflecting on the side the light arrives from
//!   (surfaces are two-sided);
//! - [`Bsdf::Dielectric`]: a smooth interface with the exact Fresnel equations; transmission
//!   is tinted by `tint` and radiance is scaled by 1/η² when it crosses (pbrt-v4
//!   `DielectricBxDF` in radiance mode);
//! - [`Bsdf::Mirror`]: a smooth mirror with reflectance `r`;
//! - [`Bsdf::Conductor`]: a Trowbridge–Reitz (GGX) rough conductor with a spectral complex
//!   index η + iκ and optional multiple-scattering compensation (Kulla & Conty 2017);
//! - [`Bsdf::RoughDielectric`]: a GGX rough dielectric interface (Walter et al. 2007, pbrt-v4
//!   `DielectricBxDF` rough branch), with optional energy compensation (Turquin 2019);
//! - [`Bsdf::ThinDielectric`]: a thin slab with inter-reflection summed in closed form (pbrt-v4
//!   `ThinDielectricBxDF`), for glTF transmission without volume;
//! - [`Bsdf::GltfMetalRough`]: the glTF 2.0 metallic–roughness BRDF (spec Appendix B), with optional
//!   multiple-scattering compensation of its microfacet layers (Kulla & Conty 2017);
//! - [`Bsdf::Plastic`]: a smooth or rough dielectric coat over a Lambertian base (Mitsuba 3's
//!   `plastic` and `roughplastic`).
//!
//! The first three are what the path tracer has always used; their arithmetic is unchanged
//! (`xtask/compare/same_renders.sh OLD NEW` renders every scene with two binaries and
//! compares the outputs byte for byte). The rough lobes work in a local shading frame
//! (z = shading normal, x/y = [`crate::sampling::basis`] of it, which also orients
//! anisotropy until hits carry a tangent).

mod compensation;
mod conductor;
mod dielectric;
mod gltf;
mod microfacet;
mod plastic;
mod sheen;
mod spectral_ior;
#[cfg(test)]
pub(crate) mod test_support;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_plastic;

use std::f32::consts::FRAC_1_PI;
use std::ops::BitOr;

use colorimetry::SampledSpectrum;
use glam::{Vec2, Vec3};

pub use conductor::ConductorBxdf;
pub use dielectric::{RoughDielectricBxdf, ThinDielectricBxdf};
pub use gltf::GltfMetalRoughBxdf;
pub(crate) use gltf::schlick;
pub use microfacet::TrowbridgeReitz;
pub use plastic::{PlasticBxdf, PlasticTable, plastic_table};
pub use sheen::{MIN_SHEEN_ROUGHNESS, SheenBxdf, sheen_albedo};
pub use spectral_ior::{KNOWN_METALS, Metal};

use crate::sampling::{basis, cosine_hemisphere};
use crate::scattering::{fr_dielectric, reflect, refract};

/// What kind of scattering a lobe (or a sampled direction) is (pbrt-v4 `BxDFFlags`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BxdfFlags(u8);

impl BxdfFlags {
    /// Light leaves on the side it arrived from.
    pub const REFLECTION: Self = Self(1);
    /// Light crosses the surface.
    pub const TRANSMISSION: Self = Self(2);
    /// A smooth, wide lobe (Lambertian).
    pub const DIFFUSE: Self = Self(4);
    /// A lobe with a finite density (rough microfacets).
    pub const GLOSSY: Self = Self(8);
    /// A Dirac delta: no density, no light sampling, no MIS.
    pub const SPECULAR: Self = Self(16);

    /// Whether all of `other`'s bits are set.
    #[inline]
    fn contains(self, other: Self) -> bool {
        self.0 & other.0 == other.0
    }
    /// Whether any reflection is possible.
    #[cfg(test)]
    #[inline]
    pub(crate) fn is_reflective(self) -> bool {
        self.contains(Self::REFLECTION)
    }
    /// Whether any transmission is possible.
    #[inline]
    pub fn is_transmissive(self) -> bool {
        self.contains(Self::TRANSMISSION)
    }
    /// Whether a delta lobe is present.
    #[inline]
    pub fn is_specular(self) -> bool {
        self.contains(Self::SPECULAR)
    }
    /// Whether a lobe with a density is present (diffuse or glossy): light sampling helps.
    #[inline]
    pub(crate) fn is_non_specular(self) -> bool {
        self.0 & (Self::DIFFUSE.0 | Self::GLOSSY.0) != 0
    }
}

impl BitOr for BxdfFlags {
    type Output = Self;
    #[inline]
    fn bitor(self, rhs: Self) -> Self {
        Self(self.0 | rhs.0)
    }
}

/// Where a surface scatters: `n` the geometric normal as stored (outward for closed
/// objects), `ns` the shading normal in `n`'s hemisphere.
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    /// Geometric normal, unit, as stored.
    pub n: Vec3,
    /// Shading (interpolated) normal, unit, in `n`'s hemisphere.
    pub ns: Vec3,
}

impl Frame {
    /// Geometric and shading normals turned to the side of `wo`; the shading normal falls back
    /// to the geometric one where interpolation tilts it past `wo`. Always inlined (a few compares, called
    /// at every vertex; the bidirectional integrator's calls had moved it out of line).
    #[inline(always)]
    pub fn facing(&self, wo: Vec3) -> (Vec3, Vec3) {
        let ng = if self.n.dot(wo) >= 0.0 { self.n } else { -self.n };
        let ns = if self.ns.dot(ng) >= 0.0 { self.ns } else { -self.ns };
        let ns = if ns.dot(wo) > 0.0 { ns } else { ng };
        (ng, ns)
    }

    /// The shading normal on the stored side, unless it disagrees with the geometric normal
    /// about which side `wo` is on (then the geometric one): the normal an interface's η
    /// refers to.
    #[inline]
    fn interface_normal(&self, wo: Vec3) -> Vec3 {
        if self.ns.dot(wo).signum() == self.n.dot(wo).signum() { self.ns } else { self.n }
    }

    /// Whether a pair a lobe's local frame sees as a reflection (`local_reflection`) or a
    /// transmission is the same to the geometric normal; otherwise light would leak through
    /// the surface.
    #[inline]
    fn agrees_with_geometry(&self, wo: Vec3, wi: Vec3, local_reflection: bool) -> bool {
        local_reflection == (self.n.dot(wo) * self.n.dot(wi) > 0.0)
    }
}

/// A sampled scattering direction.
#[derive(Debug, Clone, Copy)]
pub struct BsdfSample<const N: usize> {
    /// Unit direction towards where the light comes from.
    pub wi: Vec3,
    /// f · |cos θ_i| / pdf: the factor the path throughput is multiplied by.
    pub weight: SampledSpectrum<N>,
    /// Density of `wi` per steradian (for MIS); for specular samples the discrete probability
    /// of the chosen lobe (meaningless for MIS).
    pub pdf: f32,
    /// η² of a refraction (1 otherwise): radiance scaling undone in Russian roulette
    /// (pbrt-v4's `etaScale`).
    pub eta_scale: f32,
    /// The kind of scattering sampled (reflection or transmission; diffuse, glossy or specular).
    pub flags: BxdfFlags,
}

/// A sample in the local shading frame (pbrt-v4 `BSDFSample`): `f` the BSDF value (not
/// divided by the density), `etap` the relative index crossed (1 for reflection).
#[derive(Debug, Clone, Copy)]
pub(crate) struct LocalSample<const N: usize> {
    pub(crate) wi: Vec3,
    pub(crate) f: SampledSpectrum<N>,
    pub(crate) pdf: f32,
    pub(crate) flags: BxdfFlags,
    pub(crate) etap: f32,
}

/// A scattering model with its spectra evaluated at the path's wavelengths.
#[derive(Debug, Clone, Copy)]
pub enum Bsdf<const N: usize> {
    /// Lambertian reflection, reflectance `r`.
    Lambertian {
        /// Reflectance per wavelength, in [0, 1].
        r: SampledSpectrum<N>,
    },
    /// A smooth dielectric interface.
    Dielectric {
        /// Index inside over outside (0: glTF's "Fresnel ≡ 1" mode).
        eta: f32,
        /// Transmission filter applied at each crossing.
        tint: SampledSpectrum<N>,
    },
    /// A smooth mirror.
    Mirror {
        /// Reflectance per wavelength.
        r: SampledSpectrum<N>,
    },
    /// A rough (or, below α = 1e-3, smooth) conductor with a spectral complex index.
    Conductor(ConductorBxdf<N>),
    /// A rough (or, below α = 1e-3, smooth) dielectric interface.
    RoughDielectric(RoughDielectricBxdf<N>),
    /// A thin-walled dielectric slab (no refraction of the direction).
    ThinDielectric(ThinDielectricBxdf<N>),
    /// The glTF 2.0 metallic–roughness BRDF.
    GltfMetalRough(GltfMetalRoughBxdf<N>),
    /// `KHR_materials_sheen`'s lobe, picked in place of the material it layers (see `sheen.rs`).
    Sheen(SheenBxdf<N>),
    /// A dielectric coat over a Lambertian base (see `plastic.rs`).
    Plastic(PlasticBxdf<N>),
}

/// Local shading coordinates: `z` along `n`, `x`, `y` along [`basis`]`(n)`.
#[derive(Debug, Clone, Copy)]
struct Local {
    t: Vec3,
    b: Vec3,
    n: Vec3,
}

impl Local {
    #[inline]
    fn new(n: Vec3) -> Self {
        let (t, b) = basis(n);
        Self { t, b, n }
    }
    /// The frame about `n` whose x axis is `tangent` made orthogonal to `n` (Gram–Schmidt); [`Local::new`]'s
    /// where `tangent` is zero or parallel to `n`.
    #[inline]
    fn oriented(n: Vec3, tangent: Vec3) -> Self {
        match (tangent - n * n.dot(tangent)).try_normalize() {
            Some(t) => Self { t, b: n.cross(t), n },
            None => Self::new(n),
        }
    }
    #[inline]
    fn local(&self, w: Vec3) -> Vec3 {
        Vec3::new(w.dot(self.t), w.dot(self.b), w.dot(self.n))
    }
    #[inline]
    fn world(&self, w: Vec3) -> Vec3 {
        w.x * self.t + w.y * self.b + w.z * self.n
    }
}

/// A lobe's direction in world space (the local x axis of an anisotropic lobe), octahedrally encoded
/// (Cigolle et al. 2014) in two snorm16: four bytes keep the rough lobes no larger than the conductor
/// (`bsdf_size_is_the_conductors`). [`Direction::NONE`] where the lobe's frame is any basis about the
/// normal.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Direction([i16; 2]);

impl Direction {
    /// No direction (outside the encoder's range).
    pub(crate) const NONE: Self = Self([i16::MIN; 2]);

    /// `w` on the octahedron, unfolded onto [−1, 1]² and quantised; [`Self::NONE`] for a zero or non-finite `w`.
    pub(crate) fn new(w: Vec3) -> Self {
        let Some(w) = w.try_normalize() else { return Self::NONE };
        let p = w.truncate() / (w.x.abs() + w.y.abs() + w.z.abs());
        let p = if w.z >= 0.0 { p } else { (Vec2::ONE - Vec2::new(p.y, p.x).abs()) * p.signum() };
        let q = |v: f32| (v.clamp(-1.0, 1.0) * 32767.0).round() as i16;
        Self([q(p.x), q(p.y)])
    }

    /// The unit vector encoded; `None` for [`Self::NONE`].
    #[inline]
    pub(crate) fn get(self) -> Option<Vec3> {
        if self == Self::NONE {
            return None;
        }
        let p = Vec2::new(f32::from(self.0[0]), f32::from(self.0[1])) / 32767.0;
        let z = 1.0 - p.x.abs() - p.y.abs();
        let xy = if z >= 0.0 { p } else { (Vec2::ONE - Vec2::new(p.y, p.x).abs()) * p.signum() };
        Some(xy.extend(z).normalize())
    }

    /// The local frame about `n`: x along the direction made orthogonal to `n` where there is one.
    #[inline]
    fn frame(self, n: Vec3) -> Local {
        match self.get() {
            None => Local::new(n),
            Some(t) => Local::oriented(n, t),
        }
    }
}

impl<const N: usize> Bsdf<N> {
    /// What the model can do.
    #[inline]
    pub fn flags(&self) -> BxdfFlags {
        match self {
            Self::Lambertian { .. } => BxdfFlags::REFLECTION | BxdfFlags::DIFFUSE,
            Self::Mirror { .. } => BxdfFlags::REFLECTION | BxdfFlags::SPECULAR,
            Self::Dielectric { eta, .. } => {
                if *eta <= 0.0 {
                    BxdfFlags::REFLECTION | BxdfFlags::SPECULAR
                } else {
                    BxdfFlags::REFLECTION | BxdfFlags::TRANSMISSION | BxdfFlags::SPECULAR
                }
            }
            Self::Conductor(c) => c.flags(),
            Self::RoughDielectric(d) => d.flags(),
            Self::ThinDielectric(d) => d.flags(),
            Self::GltfMetalRough(g) => g.flags(),
            Self::Sheen(s) => s.flags(),
            Self::Plastic(p) => p.flags(),
        }
    }

    /// Whether the model has only delta lobes (light sampling is pointless there).
    #[inline]
    pub fn is_specular(&self) -> bool {
        !self.flags().is_non_specular()
    }

    /// f(wo, wi), the BSDF value (0 for delta lobes, whose value at a given direction is zero
    /// with probability one).
    ///
    /// The reflection models (Lambertian, conductor, glTF metallic–roughness) have a value wherever
    /// `wi` is above the shading surface, as in pbrt-v4, even below the geometric one: there, near
    /// the shadow terminator of a smooth-shaded low-poly mesh, the shadow ray from the lifted point
    /// (the geometry crate's `Scene::terminator_shadow_ray`) decides
    /// whether light arrives (without, each facet's horizon showed as a step in the shading).
    /// [`Bsdf::sample_f`] still returns only directions above the geometric surface (a
    /// bounce ray below it would start inside the object), and [`Bsdf::pdf`] is 0 where it does
    /// not, so light sampling alone covers those directions and MIS stays unbiased.
    #[inline]
    pub fn f(&self, frame: &Frame, wo: Vec3, wi: Vec3) -> SampledSpectrum<N> {
        let black = SampledSpectrum([0.0; N]);
        if let Self::Lambertian { r } = self {
            let (_, ns) = frame.facing(wo);
            return if ns.dot(wi) > 0.0 { *r * FRAC_1_PI } else { black };
        }
        self.f_local(frame, wo, wi).map_or(black, |(f, _)| f)
    }

    /// f(wo, wi) · |cos θ_i| for non-specular models (0 for delta lobes). Always inlined: with a second
    /// integrator calling it, the compiler moved it out of the path tracer's light sampling, +1.5 % of
    /// the Cornell box's instructions (cachegrind).
    #[inline(always)]
    pub fn f_cos(&self, frame: &Frame, wo: Vec3, wi: Vec3) -> SampledSpectrum<N> {
        let black = SampledSpectrum([0.0; N]);
        if let Self::Lambertian { r } = self {
            let (_, ns) = frame.facing(wo);
            let cos = ns.dot(wi);
            return if cos > 0.0 { *r * (cos * FRAC_1_PI) } else { black };
        }
        self.f_local(frame, wo, wi).map_or(black, |(f, cos)| f * cos)
    }

    /// Density per steradian with which [`Bsdf::sample_f`] picks `wi` (0 for delta lobes). Always
    /// inlined, as [`Bsdf::f_cos`].
    #[inline(always)]
    pub fn pdf(&self, frame: &Frame, wo: Vec3, wi: Vec3) -> f32 {
        if let Self::Lambertian { .. } = self {
            let (ng, ns) = frame.facing(wo);
            return lambert_cos(ng, ns, wi).map_or(0.0, |cos| cos * FRAC_1_PI);
        }
        let Some((wo_l, wi_l)) = self.local_pair(frame, wo, wi, true) else { return 0.0 };
        match self {
            Self::Conductor(c) => c.pdf(wo_l, wi_l),
            Self::RoughDielectric(d) => d.pdf(wo_l, wi_l),
            Self::GltfMetalRough(g) => g.pdf(wo_l, wi_l),
            Self::Sheen(s) => s.pdf(wo_l, wi_l),
            Self::Plastic(p) => p.pdf(wo_l, wi_l),
            _ => 0.0,
        }
    }

    /// The rough lobes' f and |cos θ_i| in their local frame; `None` for the other models and
    /// where [`Bsdf::local_pair`] rejects the pair.
    #[inline]
    fn f_local(&self, frame: &Frame, wo: Vec3, wi: Vec3) -> Option<(SampledSpectrum<N>, f32)> {
        let (wo_l, wi_l) = self.local_pair(frame, wo, wi, false)?;
        let f = match self {
            Self::Conductor(c) => c.f(wo_l, wi_l),
            Self::RoughDielectric(d) => d.f(wo_l, wi_l),
            Self::GltfMetalRough(g) => g.f(wo_l, wi_l),
            Self::Sheen(s) => s.f(wo_l, wi_l),
            Self::Plastic(p) => p.f(wo_l, wi_l),
            _ => return None,
        };
        Some((f, wi_l.z.abs()))
    }

    /// (wo, wi) in a rough lobe's local frame; `None` for the other models (Lambertian is
    /// evaluated in world space, delta lobes have no value) and where the geometric normal
    /// forbids the pair (light would leak through the surface). With `sampled`, the pairs
    /// [`Bsdf::sample_f`] can return (for its density); without, the pairs with a value, which for
    /// reflection also include directions below the geometric surface but above the shading
    /// one (see [`Bsdf::f`]).
    #[inline]
    fn local_pair(&self, frame: &Frame, wo: Vec3, wi: Vec3, sampled: bool) -> Option<(Vec3, Vec3)> {
        match self {
            // Reflection only: wi must be on wo's side of the shading surface, and of the
            // geometric one for a sample.
            Self::Conductor(_) | Self::GltfMetalRough(_) | Self::Sheen(_) | Self::Plastic(_) => {
                let (ng, ns) = frame.facing(wo);
                if ns.dot(wi) <= 0.0 || (sampled && ng.dot(wi) <= 0.0) {
                    return None;
                }
                let l = match self {
                    Self::GltfMetalRough(g) => g.direction().frame(ns),
                    _ => Local::new(ns),
                };
                Some((l.local(wo), l.local(wi)))
            }
            Self::RoughDielectric(d) => {
                let l = d.direction().frame(frame.interface_normal(wo));
                let (wo_l, wi_l) = (l.local(wo), l.local(wi));
                frame.agrees_with_geometry(wo, wi, wo_l.z * wi_l.z > 0.0).then_some((wo_l, wi_l))
            }
            Self::Lambertian { .. } | Self::Dielectric { .. } | Self::Mirror { .. } | Self::ThinDielectric(_) => None,
        }
    }

    /// Sample an incident direction; `uc` chooses between lobes (reflection or refraction),
    /// `u` the direction. `None` when the sample carries no light.
    #[inline]
    pub fn sample_f(&self, frame: &Frame, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample<N>> {
        let (ng, ns) = frame.facing(wo);
        match self {
            Self::Lambertian { r } => {
                let wi = cosine_hemisphere(ns, u);
                let cos = lambert_cos(ng, ns, wi)?;
                Some(BsdfSample {
                    wi,
                    weight: *r,
                    pdf: cos * FRAC_1_PI,
                    eta_scale: 1.0,
                    flags: BxdfFlags::REFLECTION | BxdfFlags::DIFFUSE,
                })
            }
            Self::Mirror { r } => {
                let wi = mirror(wo, ns, ng);
                Some(BsdfSample {
                    wi,
                    weight: *r,
                    pdf: 1.0,
                    eta_scale: 1.0,
                    flags: BxdfFlags::REFLECTION | BxdfFlags::SPECULAR,
                })
            }
            &Self::Dielectric { eta, tint } => {
                // Fresnel against the stored normal keeps track of inside and outside.
                // (The shading normal lies in the stored normal's hemisphere; where it puts wo on
                // the other side than the geometric normal does, trust the geometric one.)
                let n_out = frame.interface_normal(wo);
                let f = fr_dielectric(n_out.dot(wo), eta);
                if uc < f {
                    // Reflection with probability F: weight F / F = 1.
                    let wi = mirror(wo, ns, ng);
                    return Some(BsdfSample {
                        wi,
                        weight: SampledSpectrum([1.0; N]),
                        pdf: f,
                        eta_scale: 1.0,
                        flags: BxdfFlags::REFLECTION | BxdfFlags::SPECULAR,
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
                    eta_scale: etap * etap,
                    flags: BxdfFlags::TRANSMISSION | BxdfFlags::SPECULAR,
                })
            }
            Self::Conductor(c) => {
                let l = Local::new(ns);
                reflection_sample(c.sample_f(l.local(wo), uc, u)?, &l, wo, ns, ng)
            }
            Self::RoughDielectric(d) => {
                if d.is_smooth() {
                    return Bsdf::Dielectric { eta: d.eta(), tint: d.tint() }.sample_f(frame, wo, uc, u);
                }
                let l = d.direction().frame(frame.interface_normal(wo));
                let wo_l = l.local(wo);
                let s = d.sample_f(wo_l, uc, u)?;
                let wi = l.world(s.wi);
                frame.agrees_with_geometry(wo, wi, wo_l.z * s.wi.z > 0.0).then(|| world_sample(s, wi))
            }
            Self::GltfMetalRough(g) => {
                let l = g.direction().frame(ns);
                reflection_sample(g.sample_f(l.local(wo), uc, u)?, &l, wo, ns, ng)
            }
            Self::ThinDielectric(d) => d.sample_f(frame.interface_normal(wo).dot(wo), uc, mirror(wo, ns, ng), -wo),
            Self::Sheen(s) => {
                let l = Local::new(ns);
                reflection_sample(s.sample_f(l.local(wo), u)?, &l, wo, ns, ng)
            }
            Self::Plastic(p) => {
                let l = Local::new(ns);
                reflection_sample(p.sample_f(l.local(wo), uc, u)?, &l, wo, ns, ng)
            }
        }
    }
}

/// Density of a two-lobe reflection model that picks, with probability `p_glossy`, a visible normal of
/// `distrib` (unless the lobe is a delta, `smooth`) and otherwise a cosine-weighted direction, in the local
/// frame with `wo` and `wi` above the surface (the glTF and plastic models).
#[inline]
fn glossy_or_cosine_pdf(distrib: &TrowbridgeReitz, smooth: bool, p_glossy: f32, wo: Vec3, wi: Vec3) -> f32 {
    let mut pdf = (1.0 - p_glossy) * wi.z * FRAC_1_PI;
    if !smooth {
        let wm = (wo + wi).normalize();
        pdf += p_glossy * distrib.d_visible(wo, wm) / (4.0 * wo.dot(wm).abs());
    }
    pdf
}

/// |cos θ_i| of a Lambertian lobe for a sampled direction (and its density): `wi` against the
/// shading normal, or `None` unless both normals agree that `wi` is on `wo`'s side (a bounce ray
/// below the geometric surface would start inside the object).
#[inline]
fn lambert_cos(ng: Vec3, ns: Vec3, wi: Vec3) -> Option<f32> {
    let cos = ns.dot(wi);
    if cos <= 0.0 || ng.dot(wi) <= 0.0 { None } else { Some(cos) }
}

/// A local sample turned into the path tracer's weight form, direction already in world space.
#[inline]
fn world_sample<const N: usize>(s: LocalSample<N>, wi: Vec3) -> BsdfSample<N> {
    let weight = if s.flags.is_specular() { s.f } else { s.f * (s.wi.z.abs() / s.pdf) };
    let transmitted = s.flags.is_transmissive();
    BsdfSample { wi, weight, pdf: s.pdf, eta_scale: if transmitted { s.etap * s.etap } else { 1.0 }, flags: s.flags }
}

/// A reflection lobe's local sample in world space. A delta lobe mirrors like
/// [`Bsdf::Mirror`] (about the shading normal, else the geometric one); any other direction
/// must stay above the geometric surface.
#[inline]
fn reflection_sample<const N: usize>(
    s: LocalSample<N>,
    l: &Local,
    wo: Vec3,
    ns: Vec3,
    ng: Vec3,
) -> Option<BsdfSample<N>> {
    let wi = if s.flags.is_specular() { mirror(wo, ns, ng) } else { l.world(s.wi) };
    if ng.dot(wi) <= 0.0 {
        return None;
    }
    Some(world_sample(s, wi))
}

/// Mirror reflection about the shading normal, falling back to the geometric normal where the
/// shading normal would send the ray below the surface.
#[inline]
fn mirror(wo: Vec3, ns: Vec3, ng: Vec3) -> Vec3 {
    let wi = reflect(wo, ns);
    if wi.dot(ng) > 0.0 { wi } else { reflect(wo, ng) }
}
