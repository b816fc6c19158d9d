//! `KHR_materials_sheen`: the "Charlie" sheen lobe of Conty Estevez and Kulla ("Production Friendly
//! Microfacet Sheen BRDF", SIGGRAPH 2017), as the extension's implementation notes give it: the
//! exponentiated-sine fibre distribution D(h) = (2 + 1/r) sin^(1/r) θ_h / 2π and their fitted
//! visibility V = 1 / ((1 + Λ(μ_o) + Λ(μ_i)) 4 μ_o μ_i), Fresnel 1, f = C · D · V.
//!
//! The layer sits on the glTF metallic–roughness material by albedo scaling with the view direction
//! only, which the extension names as the simplified form: f = f_sheen + f_base (1 − max₃(C) E(μ_o)), E the
//! lobe's directional albedo ([`sheen_albedo`]). That mix depends on the view direction alone, so a path
//! tracer picks the sheen with probability P = max₃(C) E(μ_o) and the base otherwise — an exact mixture
//! (as Cycles layers its sheen, and as this project picks the clear coat); the lobe it picks is
//! [`SheenBxdf`] with C / P as its colour.

use std::f32::consts::{FRAC_1_PI, PI};
use std::sync::LazyLock;

use colorimetry::SampledSpectrum;
use glam::{Vec2, Vec3};

use super::{BxdfFlags, LocalSample};

/// Smallest sheen roughness used: below it sin^(1/r) θ_h is a spike at grazing angles that no sampler
/// or table resolves in f32 (the Khronos sample viewer clamps too, at 1e-6 of a quantity it squares).
pub const MIN_SHEEN_ROUGHNESS: f32 = 0.07;

/// The sheen lobe at one hit, its colour already divided by the probability it was picked with.
#[derive(Debug, Clone, Copy)]
pub struct SheenBxdf<const N: usize> {
    color: SampledSpectrum<N>,
    roughness: f32,
}

impl<const N: usize> SheenBxdf<N> {
    /// The lobe of colour `color` (per lane) and sheen roughness `roughness` (clamped to
    /// [[`MIN_SHEEN_ROUGHNESS`], 1]).
    pub fn new(color: SampledSpectrum<N>, roughness: f32) -> Self {
        Self { color, roughness: clamp_roughness(roughness) }
    }

    pub(crate) fn flags(&self) -> BxdfFlags {
        BxdfFlags::REFLECTION | BxdfFlags::GLOSSY
    }

    /// f(wo, wi) in the local frame (z the shading normal), both above the surface.
    #[inline]
    pub(crate) fn f(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum<N> {
        self.color * charlie(wo, wi, self.roughness)
    }

    /// Uniform over the hemisphere: the lobe peaks towards grazing angles, where a cosine-weighted
    /// sample would be rare and its weight (∝ 1 / μ_i) unbounded.
    #[inline]
    pub(crate) fn pdf(&self, _wo: Vec3, wi: Vec3) -> f32 {
        if wi.z > 0.0 { 0.5 * FRAC_1_PI } else { 0.0 }
    }

    #[inline]
    pub(crate) fn sample_f(&self, wo: Vec3, u: Vec2) -> Option<LocalSample<N>> {
        let z = u.x;
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * PI * u.y;
        let wi = Vec3::new(r * phi.cos(), r * phi.sin(), z);
        (wi.z > 0.0 && wo.z > 0.0).then(|| LocalSample {
            wi,
            f: self.f(wo, wi),
            pdf: 0.5 * FRAC_1_PI,
            flags: self.flags(),
            etap: 1.0,
        })
    }
}

fn clamp_roughness(r: f32) -> f32 {
    if r.is_nan() { 1.0 } else { r.clamp(MIN_SHEEN_ROUGHNESS, 1.0) }
}

/// D · V of the Charlie lobe for local directions above the surface (0 otherwise).
#[inline]
fn charlie(wo: Vec3, wi: Vec3, r: f32) -> f32 {
    let (mo, mi) = (wo.z, wi.z);
    if mo <= 0.0 || mi <= 0.0 {
        return 0.0;
    }
    let Some(h) = (wo + wi).try_normalize() else { return 0.0 };
    let v = 1.0 / ((1.0 + lambda(mo, r) + lambda(mi, r)) * (4.0 * mo * mi));
    let f = charlie_d(h.z, r) * v;
    if f.is_finite() { f } else { 0.0 }
}

/// The Charlie distribution D(h) = (2 + 1/r) sin^(1/r) θ_h / 2π at cos θ_h = `cos_h`.
#[inline]
fn charlie_d(cos_h: f32, r: f32) -> f32 {
    let sin2h = (1.0 - cos_h * cos_h).max(0.0);
    let inv_r = 1.0 / r;
    (2.0 + inv_r) * sin2h.powf(0.5 * inv_r) * (0.5 * FRAC_1_PI)
}

/// Conty Estevez and Kulla's fit of the Charlie shadowing exponent, L(x) = a / (1 + b x^c) + d x + e with
/// coefficients interpolated in (1 − r)² (their Table 1, as the extension's notes print it).
fn l(x: f32, r: f32) -> f32 {
    let t = (1.0 - r) * (1.0 - r);
    let mix = |p: f32, q: f32| p + (q - p) * t;
    let (a, b, c) = (mix(21.5473, 25.3245), mix(3.82987, 3.32435), mix(0.19823, 0.16801));
    let (d, e) = (mix(-1.97760, -1.27393), mix(-4.32054, -4.85967));
    a / (1.0 + b * x.powf(c)) + d * x + e
}

/// Λ(μ): exp(L(μ)) below ½, mirrored about ½ above (their eq. 3), so that it is smooth at μ = ½.
fn lambda(mu: f32, r: f32) -> f32 {
    if mu < 0.5 { l(mu, r).exp() } else { (2.0 * l(0.5, r) - l(1.0 - mu, r)).exp() }
}

/// Rows (roughness) and columns (μ_o) of the albedo table.
const TABLE_R: usize = 16;
const TABLE_MU: usize = 32;

/// E(μ_o, r) = ∫ D V μ_i dω_i on a grid of μ_o ∈ [0, 1] (32 columns) × r ∈ [[`MIN_SHEEN_ROUGHNESS`], 1]
/// (16 rows), integrated once per process (about 30 ms) by the midpoint rule in (μ_i, φ) — the lobe is
/// symmetric about the plane of incidence, so φ over [0, π] counts twice.
static ALBEDO: LazyLock<Vec<f32>> = LazyLock::new(|| {
    let mut table = Vec::with_capacity(TABLE_R * TABLE_MU);
    for row in 0..TABLE_R {
        let r = row_roughness(row);
        for col in 0..TABLE_MU {
            table.push(integrate_albedo(col as f32 / (TABLE_MU - 1) as f32, r, 64, 32) as f32);
        }
    }
    table
});

fn row_roughness(row: usize) -> f32 {
    MIN_SHEEN_ROUGHNESS + (1.0 - MIN_SHEEN_ROUGHNESS) * row as f32 / (TABLE_R - 1) as f32
}

/// ∫ D V μ_i dω_i at view cosine `mu_o` by the midpoint rule with `n_mu` × `n_phi` cells.
fn integrate_albedo(mu_o: f32, r: f32, n_mu: usize, n_phi: usize) -> f64 {
    // At μ_o = 0 the lobe is seen edge-on; the limit is taken just above it.
    let mu_o = mu_o.max(1e-3);
    let wo = Vec3::new((1.0 - mu_o * mu_o).sqrt(), 0.0, mu_o);
    let mut sum = 0.0f64;
    for i in 0..n_mu {
        let mu_i = (i as f32 + 0.5) / n_mu as f32;
        let s = (1.0 - mu_i * mu_i).sqrt();
        for j in 0..n_phi {
            let phi = PI * (j as f32 + 0.5) / n_phi as f32;
            let wi = Vec3::new(s * phi.cos(), s * phi.sin(), mu_i);
            sum += f64::from(charlie(wo, wi, r) * mu_i);
        }
    }
    // dω = dμ dφ; cells of (1 / n_mu) × (π / n_phi), twice for φ ∈ [π, 2π].
    sum * 2.0 * std::f64::consts::PI / (n_mu * n_phi) as f64
}

/// The directional albedo E(μ_o) of the sheen lobe of roughness `roughness` (clamped as in
/// [`SheenBxdf::new`]), colour 1: bilinear in the precomputed table.
pub fn sheen_albedo(mu_o: f32, roughness: f32) -> f32 {
    let table = &*ALBEDO;
    let r = clamp_roughness(roughness);
    let y = ((r - MIN_SHEEN_ROUGHNESS) / (1.0 - MIN_SHEEN_ROUGHNESS) * (TABLE_R - 1) as f32)
        .clamp(0.0, (TABLE_R - 1) as f32);
    let x = (if mu_o.is_nan() { 0.0 } else { mu_o.clamp(0.0, 1.0) }) * (TABLE_MU - 1) as f32;
    let (x0, y0) = ((x as usize).min(TABLE_MU - 2), (y as usize).min(TABLE_R - 2));
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    let at = |row: usize, col: usize| table[row * TABLE_MU + col];
    let top = at(y0, x0) * (1.0 - fx) + at(y0, x0 + 1) * fx;
    let bottom = at(y0 + 1, x0) * (1.0 - fx) + at(y0 + 1, x0 + 1) * fx;
    top * (1.0 - fy) + bottom * fy
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::test_support::TestRng;

    /// Monte Carlo estimate of the lobe's albedo at `mu_o` with colour 1, by its own sampling.
    fn sampled_albedo(mu_o: f32, r: f32, n: u32) -> f64 {
        let lobe = SheenBxdf::<1>::new(SampledSpectrum([1.0]), r);
        let wo = Vec3::new((1.0 - mu_o * mu_o).sqrt(), 0.0, mu_o);
        let mut rng = TestRng::new(7);
        let mut sum = 0.0f64;
        for _ in 0..n {
            if let Some(s) = lobe.sample_f(wo, rng.uniform2()) {
                sum += f64::from(s.f.0[0] * s.wi.z / s.pdf);
            }
        }
        sum / f64::from(n)
    }

    #[test]
    fn the_albedo_table_matches_the_lobe_it_tabulates() {
        let mut worst: f64 = 0.0;
        for &r in &[0.07, 0.3, 0.5, 0.8, 1.0] {
            for &mu in &[0.1, 0.3, 0.5, 0.7, 0.95] {
                let table = f64::from(sheen_albedo(mu, r));
                // A finer quadrature of the same integral.
                let fine = integrate_albedo(mu, r, 512, 256);
                let sampled = sampled_albedo(mu, r, 200_000);
                assert!((table - fine).abs() < 0.01 * fine.max(0.05), "r {r} μ {mu}: table {table}, fine {fine}");
                assert!((sampled - fine).abs() < 0.02 * fine.max(0.05), "r {r} μ {mu}: sampled {sampled}, fine {fine}");
                worst = worst.max((table - fine).abs());
                // The lobe never reflects more than it receives (the layering relies on E ≤ 1).
                assert!(fine <= 1.0, "r {r} μ {mu}: albedo {fine}");
            }
        }
        assert!(worst < 0.01, "worst table error {worst}");
    }

    /// An independent property of the distribution the table integrates: its microfacets cover the
    /// surface once, ∫ D(h) cos θ_h dω_h = 1 over the hemisphere, at every roughness (a wrong exponent or
    /// normalisation in D fails this; the Λ fit is transcribed from the extension's notes and checked there).
    #[test]
    fn the_charlie_distribution_is_normalised() {
        for r in [MIN_SHEEN_ROUGHNESS, 0.2, 0.5, 1.0] {
            let n = 4000;
            let integral: f64 = (0..n)
                .map(|i| {
                    let theta = (i as f64 + 0.5) / n as f64 * std::f64::consts::FRAC_PI_2;
                    let d = f64::from(charlie_d(theta.cos() as f32, r));
                    d * theta.cos() * theta.sin() * std::f64::consts::TAU * std::f64::consts::FRAC_PI_2 / n as f64
                })
                .sum();
            assert!((integral - 1.0).abs() < 2e-3, "r {r}: ∫ D cos = {integral}");
        }
    }

    #[test]
    fn the_lobe_is_finite_at_grazing_angles_and_any_roughness() {
        for r in [0.0, 1e-9, 0.07, 0.5, 1.0, f32::NAN] {
            let lobe = SheenBxdf::<1>::new(SampledSpectrum([1.0]), r);
            for (mo, mi) in [(1e-7, 0.5), (0.5, 1e-7), (1e-7, 1e-7), (1.0, 1.0), (0.0, 0.3)] {
                let wo = Vec3::new((1.0f32 - mo * mo).sqrt(), 0.0, mo);
                let wi = Vec3::new(-(1.0f32 - mi * mi).sqrt(), 0.0, mi);
                let f = lobe.f(wo, wi).0[0];
                assert!(f.is_finite() && f >= 0.0, "r {r}, μ_o {mo}, μ_i {mi}: {f}");
            }
            assert!(sheen_albedo(0.5, r).is_finite());
        }
    }
}
