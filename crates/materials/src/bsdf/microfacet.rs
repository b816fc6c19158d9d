//! The Trowbridge–Reitz (GGX) microfacet distribution with visible-normal sampling (Heitz
//! 2018, "Sampling the GGX Distribution of Visible Normals", JCGT 7(4); pbrt-v4
//! `TrowbridgeReitzDistribution`), in the local shading frame (z = normal).

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

/// Below this roughness the surface is treated as smooth (a delta lobe): the density would
/// be too peaked for f32 (pbrt-v4 `EffectivelySmooth`, same threshold).
const SMOOTH_ALPHA: f32 = 1e-3;

/// Roughness floor for lobes that are not smooth, so D stays finite in f32 (pbrt-v4 clamps
/// α to 1e-4 the same way).
const MIN_ALPHA: f32 = 1e-4;

/// An anisotropic GGX distribution with roughness `alpha_x`, `alpha_y` along the local x and y.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrowbridgeReitz {
    alpha_x: f32,
    alpha_y: f32,
}

impl TrowbridgeReitz {
    /// A distribution with the given α (negative or NaN values count as 0, i.e. smooth).
    pub fn new(alpha_x: f32, alpha_y: f32) -> Self {
        let clean = |a: f32| if a > 0.0 { a.min(1e3) } else { 0.0 };
        let (mut alpha_x, mut alpha_y) = (clean(alpha_x), clean(alpha_y));
        if alpha_x.max(alpha_y) >= SMOOTH_ALPHA {
            alpha_x = alpha_x.max(MIN_ALPHA);
            alpha_y = alpha_y.max(MIN_ALPHA);
        }
        Self { alpha_x, alpha_y }
    }

    /// An isotropic distribution.
    pub fn isotropic(alpha: f32) -> Self {
        Self::new(alpha, alpha)
    }

    /// `KHR_materials_anisotropy`'s stretch of the isotropic `alpha` by `strength` ∈ [0, 1]: α_x =
    /// mix(α, 1, strength²) along the direction (local x), α_y = α across it.
    pub fn stretched(alpha: f32, strength: f32) -> Self {
        let strength = if strength.is_finite() { strength.clamp(0.0, 1.0) } else { 0.0 };
        Self::new(alpha + (1.0 - alpha) * strength * strength, alpha)
    }

    /// Whether the surface is so smooth that it is handled as a delta lobe.
    #[inline]
    pub(crate) fn effectively_smooth(&self) -> bool {
        self.alpha_x.max(self.alpha_y) < SMOOTH_ALPHA
    }

    /// (α_x, α_y).
    #[cfg(test)]
    #[inline]
    pub(crate) fn alpha(&self) -> (f32, f32) {
        (self.alpha_x, self.alpha_y)
    }

    /// The isotropic α with the same footprint, √(α_x α_y): what the energy tables use.
    #[inline]
    pub(crate) fn alpha_iso(&self) -> f32 {
        (self.alpha_x * self.alpha_y).sqrt()
    }

    /// The smaller of α_x and α_y.
    #[inline]
    pub(crate) fn alpha_min(&self) -> f32 {
        self.alpha_x.min(self.alpha_y)
    }

    /// Density of microfacet normals per unit projected area, D(ω_m) = 1 / (π α_x α_y
    /// ((x/α_x)² + (y/α_y)² + z²)²), the form without tan θ that stays finite at grazing.
    #[inline]
    pub(crate) fn d(&self, wm: Vec3) -> f32 {
        if wm.z <= 0.0 {
            return 0.0;
        }
        let (x, y) = (wm.x / self.alpha_x, wm.y / self.alpha_y);
        let s = x * x + y * y + wm.z * wm.z;
        1.0 / (PI * self.alpha_x * self.alpha_y * s * s)
    }

    /// Smith's auxiliary function Λ(ω) = (√(1 + α² tan²θ) − 1) / 2 with α² = α_x² cos²φ +
    /// α_y² sin²φ; infinite at grazing (G1 = 0 there).
    #[inline]
    pub(crate) fn lambda(&self, w: Vec3) -> f32 {
        let z2 = w.z * w.z;
        if z2 == 0.0 {
            return f32::INFINITY;
        }
        let a2t2 = ((self.alpha_x * w.x).powi(2) + (self.alpha_y * w.y).powi(2)) / z2;
        // √(1 + x) − 1 = x / (√(1 + x) + 1) keeps precision for tiny α.
        0.5 * a2t2 / ((1.0 + a2t2).sqrt() + 1.0)
    }

    /// Masking G1(ω) = 1 / (1 + Λ(ω)).
    #[inline]
    pub(crate) fn g1(&self, w: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(w))
    }

    /// Height-correlated masking–shadowing G(ω_o, ω_i) = 1 / (1 + Λ(ω_o) + Λ(ω_i)).
    #[inline]
    pub(crate) fn g(&self, wo: Vec3, wi: Vec3) -> f32 {
        1.0 / (1.0 + self.lambda(wo) + self.lambda(wi))
    }

    /// Density of visible normals seen from `w`: D_ω(ω_m) = G1(ω) / |cos θ| · D(ω_m) ·
    /// max(0, ω·ω_m), for `w` below the surface read as seen from −ω (normals stay in +z).
    #[inline]
    pub(crate) fn d_visible(&self, w: Vec3, wm: Vec3) -> f32 {
        let cos = w.z.abs();
        let facing = w.dot(wm) * w.z.signum();
        if cos == 0.0 || facing <= 0.0 {
            return 0.0;
        }
        self.g1(w) / cos * self.d(wm) * facing
    }

    /// A visible normal seen from `w` (either hemisphere: it is mirrored to +z), distributed
    /// as [`TrowbridgeReitz::d_visible`]; always in the +z hemisphere.
    pub(crate) fn sample_wm(&self, w: Vec3, u: Vec2) -> Vec3 {
        // Stretch to the hemisphere configuration (α = 1).
        let mut wh = Vec3::new(self.alpha_x * w.x, self.alpha_y * w.y, w.z).normalize_or(Vec3::Z);
        if wh.z < 0.0 {
            wh = -wh;
        }
        // Orthonormal basis about wh; at normal incidence any tangent works.
        let t1 = if wh.z < 0.99999 { Vec3::Z.cross(wh).normalize() } else { Vec3::X };
        let t2 = wh.cross(t1);
        // A uniform disk point, squeezed onto the visible half of the projected hemisphere.
        let r = u.x.sqrt();
        let phi = 2.0 * PI * u.y;
        let (px, py) = (r * phi.cos(), r * phi.sin());
        let h = (1.0 - px * px).max(0.0).sqrt();
        let s = 0.5 * (1.0 + wh.z);
        let py = (1.0 - s) * h + s * py;
        let pz = (1.0 - px * px - py * py).max(0.0).sqrt();
        let nh = px * t1 + py * t2 + pz * wh;
        // Unstretch.
        Vec3::new(self.alpha_x * nh.x, self.alpha_y * nh.y, nh.z.max(1e-6)).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫ f(ω_m) dω_m over the +z hemisphere by midpoint quadrature in (cos θ, φ), `nt` × 256
    /// cells, the cos θ grid dense near the pole to resolve peaks there.
    fn hemisphere_integral(nt: usize, f: impl Fn(Vec3) -> f64) -> f64 {
        let np = 256;
        let mut sum = 0.0f64;
        for i in 0..nt {
            // u ∈ (0,1) → cos θ = 1 − u², dense near the pole; dcos = 2u du.
            let u = (i as f64 + 0.5) / nt as f64;
            let cos = 1.0 - u * u;
            let sin = (1.0 - cos * cos).max(0.0).sqrt();
            for j in 0..np {
                let phi = (j as f64 + 0.5) / np as f64 * std::f64::consts::TAU;
                let wm = Vec3::new((sin * phi.cos()) as f32, (sin * phi.sin()) as f32, cos as f32);
                sum += f(wm) * 2.0 * u / nt as f64 * std::f64::consts::TAU / np as f64;
            }
        }
        sum
    }

    #[test]
    fn d_is_normalised_over_projected_area() {
        // ∫ D(ω_m) cos θ_m dω_m = 1 (projected area normalisation).
        for (ax, ay) in [(0.05, 0.05), (0.2, 0.2), (0.5, 0.5), (1.0, 1.0), (0.1, 0.6)] {
            let d = TrowbridgeReitz::new(ax, ay);
            let a = hemisphere_integral(4000, |wm| f64::from(d.d(wm)) * f64::from(wm.z));
            assert!((a - 1.0).abs() < 5e-3, "α = ({ax}, {ay}): ∫ D cos = {a}");
        }
    }

    #[test]
    fn visible_normals_are_normalised_and_sampling_is_finite_at_grazing() {
        // ∫ D_ω(ω_m) dω_m = 1 for every ω (Heitz 2014, eq. 17): the Smith G1 is consistent with D.
        for alpha in [0.2f32, 0.5, 1.0] {
            let d = TrowbridgeReitz::new(alpha, 0.7 * alpha);
            for theta in [0.0f32, 1.0, 1.48] {
                let w = Vec3::new(theta.sin() * 0.8, theta.sin() * 0.6, theta.cos());
                let total = hemisphere_integral(2000, |wm| f64::from(d.d_visible(w, wm)));
                assert!((total - 1.0).abs() < 5e-3, "α {alpha}, θ {theta}: {total}");
            }
        }
        // Exactly grazing and exactly normal directions: no NaN anywhere.
        let d = TrowbridgeReitz::new(0.3, 0.05);
        for w in [Vec3::X, Vec3::Y, Vec3::Z, Vec3::NEG_Z, Vec3::new(1.0, 1.0, 0.0).normalize()] {
            for u in [Vec2::ZERO, Vec2::splat(0.5), Vec2::new(0.999_999, 0.999_999)] {
                let wm = d.sample_wm(w, u);
                assert!(wm.is_finite() && wm.z > 0.0, "{w} {u}: {wm}");
                assert!(d.d(wm).is_finite() && d.lambda(wm).is_finite() && d.d_visible(w, wm).is_finite());
            }
            assert!(d.g1(w).is_finite());
        }
    }

    #[test]
    fn tiny_alpha_is_smooth_and_negative_alpha_is_clean() {
        assert!(TrowbridgeReitz::isotropic(5e-4).effectively_smooth());
        assert!(!TrowbridgeReitz::isotropic(2e-3).effectively_smooth());
        assert!(TrowbridgeReitz::isotropic(-1.0).effectively_smooth());
        assert!(TrowbridgeReitz::isotropic(f32::NAN).effectively_smooth());
        // One axis smooth, the other not: the smooth axis is floored so D stays finite.
        let d = TrowbridgeReitz::new(0.0, 0.3);
        assert_eq!(d.alpha(), (MIN_ALPHA, 0.3));
        assert!(d.d(Vec3::new(0.0, 0.6, 0.8)).is_finite());
    }
}
