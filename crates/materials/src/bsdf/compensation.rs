//! Directional albedo tables of single-scattering GGX, for energy compensation of the
//! multiple scattering that microfacet models ignore.
//!
//! - Conductors: Kulla & Conty 2017 ("Revisiting Physically Based Shading at Imageworks",
//!   SIGGRAPH course): E(μ, α) of a GGX mirror with F = 1 and its cosine-weighted average
//!   E_avg(α) = 2 ∫ E(μ) μ dμ define a reciprocal extra lobe
//!   f_ms = F_ms (1 − E(μ_o)) (1 − E(μ_i)) / (π (1 − E_avg)).
//! - Dielectrics: Turquin 2019 ("Practical multiple scattering compensation for microfacet
//!   models", Imageworks tech report): the single-scattering lobe is scaled by 1 / E(μ_o, α, η),
//!   E the reflection-plus-transmission albedo of the interface (radiance scaling undone).
//!
//! The tables are computed by this code on first use (never by a scene that has no rough
//! material): deterministic stratified visible-normal sampling, whose estimator of the
//! albedo is G(ω_o, ω_i) / G1(ω_o) per sampled normal (Heitz 2018), times the Fresnel
//! weight for the dielectric. A unit test checks them against brute-force quadrature of f·cos.

use std::sync::LazyLock;

use glam::{Vec2, Vec3};

use super::microfacet::TrowbridgeReitz;
use crate::scattering::{fr_dielectric, reflect, refract};

/// Grid of the conductor table: √μ (μ = cos θ_o) and √α, both uniform on [0, 1]: dense near
/// grazing and near smooth, where the albedo changes fastest.
const CONDUCTOR_MU: usize = 32;
const CONDUCTOR_ALPHA: usize = 32;
/// Stratified visible-normal samples per conductor cell (side of the square).
const CONDUCTOR_STRATA: usize = 24;

/// Grid of the dielectric tables: √μ, √α uniform on [0, 1], η uniform on [1, DIELECTRIC_ETA_MAX].
const DIELECTRIC_MU: usize = 16;
const DIELECTRIC_ALPHA: usize = 16;
const DIELECTRIC_ETA: usize = 16;
/// Largest relative index tabulated (diamond is 2.42; higher indices are clamped to this).
const DIELECTRIC_ETA_MAX: f32 = 3.0;
const DIELECTRIC_STRATA: usize = 16;

/// The smallest μ a table cell is computed at: exactly grazing directions have no albedo
/// defined; the limit is approached closely enough.
const MU_FLOOR: f32 = 2e-3;

/// E(μ, α) of a white GGX mirror and E_avg(α); the same for the Schlick-weighted albedo E₂.
#[derive(Debug)]
pub(crate) struct ConductorTable {
    e: Vec<f32>,
    e_avg: Vec<f32>,
    e_schlick: Vec<f32>,
    e_schlick_avg: Vec<f32>,
}

/// E(μ, α, η) of a GGX dielectric interface seen from outside (η ≥ 1) and from inside.
#[derive(Debug)]
pub(crate) struct DielectricTable {
    outside: Vec<f32>,
    inside: Vec<f32>,
}

/// Position of `x` ∈ [lo, hi] on a uniform grid of `n` nodes: (cell index, fraction).
#[inline]
fn locate(x: f32, lo: f32, hi: f32, n: usize) -> (usize, f32) {
    let t = ((x - lo) / (hi - lo)).clamp(0.0, 1.0) * (n - 1) as f32;
    let i = (t as usize).min(n - 2);
    (i, t - i as f32)
}

#[inline]
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + t * (b - a)
}

/// A row of values at √α uniform on [0, 1], read linearly in √α.
#[inline]
fn linear(row: &[f32], alpha: f32) -> f32 {
    let (a, ta) = locate(alpha.max(0.0).sqrt(), 0.0, 1.0, row.len());
    lerp(row[a], row[a + 1], ta)
}

/// A plane of values, α-major rows of `n_mu` entries at √μ uniform on [0, 1] (rows at √α
/// uniform on [0, 1]), read bilinearly in (√μ, √α).
#[inline]
fn bilinear(plane: &[f32], n_mu: usize, mu: f32, alpha: f32) -> f32 {
    let (m, tm) = locate(mu.max(0.0).sqrt(), 0.0, 1.0, n_mu);
    let (a, ta) = locate(alpha.max(0.0).sqrt(), 0.0, 1.0, plane.len() / n_mu);
    let at = |a: usize, m: usize| plane[a * n_mu + m];
    lerp(lerp(at(a, m), at(a, m + 1), tm), lerp(at(a + 1, m), at(a + 1, m + 1), tm), ta)
}

/// The direction in the xz plane at grid node `s` = √μ.
#[inline]
fn direction(s: f32) -> Vec3 {
    let mu = (s * s).max(MU_FLOOR);
    Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu)
}

/// The u of stratum (i, j) of an s × s grid, jittered deterministically (golden-ratio offsets).
#[inline]
pub(crate) fn stratum(i: usize, j: usize, s: usize) -> Vec2 {
    let jx = (0.5 + 0.618_034 * (i * s + j) as f32).fract();
    let jy = (0.5 + 0.754_878 * (j * s + i) as f32).fract();
    Vec2::new((i as f32 + jx) / s as f32, (j as f32 + jy) / s as f32)
}

/// The white GGX mirror's albedo E₁ and its Schlick-weighted albedo E₂ = ∫ (1 − ω_o·ω_m)⁵ f cos
/// (so that a Schlick-Fresnel lobe of normal reflectance f0 reflects f0 E₁ + (1 − f0) E₂).
pub(crate) fn mirror_albedos(d: &TrowbridgeReitz, wo: Vec3, strata: usize) -> (f32, f32) {
    let g1 = d.g1(wo);
    let (mut e1, mut e2) = (0.0f64, 0.0f64);
    for i in 0..strata {
        for j in 0..strata {
            let wm = d.sample_wm(wo, stratum(i, j, strata));
            let wi = reflect(wo, wm);
            if wi.z > 0.0 {
                let w = f64::from(d.g(wo, wi) / g1);
                e1 += w;
                e2 += w * f64::from((1.0 - wo.dot(wm).clamp(0.0, 1.0)).powi(5));
            }
        }
    }
    let n = (strata * strata) as f64;
    ((e1 / n) as f32, (e2 / n) as f32)
}

/// Single-scattering albedo (reflection + transmission, radiance scaling undone) of a GGX
/// dielectric interface of relative index `eta` seen from `wo` (z < 0: from inside).
pub(crate) fn dielectric_albedo(d: &TrowbridgeReitz, wo: Vec3, eta: f32, strata: usize) -> f32 {
    let g1 = d.g1(wo);
    let mut sum = 0.0f64;
    for i in 0..strata {
        for j in 0..strata {
            let wm = d.sample_wm(wo, stratum(i, j, strata));
            let f = fr_dielectric(wo.dot(wm), eta);
            let wr = reflect(wo, wm);
            if wr.z * wo.z > 0.0 {
                sum += f64::from(f * d.g(wo, wr) / g1);
            }
            if let Some((wt, _)) = refract(wo, wm, eta)
                && wt.z * wo.z < 0.0
            {
                sum += f64::from((1.0 - f) * d.g(wo, wt) / g1);
            }
        }
    }
    (sum / (strata * strata) as f64) as f32
}

impl ConductorTable {
    fn compute() -> Self {
        let cells = CONDUCTOR_MU * CONDUCTOR_ALPHA;
        let (mut e, mut e_schlick) = (vec![1.0; cells], vec![0.0; cells]);
        let node = |m: usize| m as f32 / (CONDUCTOR_MU - 1) as f32;
        // α = 0: a smooth mirror reflects all (E₁ = 1) and E₂ = (1 − μ)⁵.
        for (m, cell) in e_schlick.iter_mut().take(CONDUCTOR_MU).enumerate() {
            *cell = (1.0 - node(m) * node(m)).powi(5);
        }
        for a in 1..CONDUCTOR_ALPHA {
            let d = TrowbridgeReitz::isotropic((a as f32 / (CONDUCTOR_ALPHA - 1) as f32).powi(2));
            for m in 0..CONDUCTOR_MU {
                (e[a * CONDUCTOR_MU + m], e_schlick[a * CONDUCTOR_MU + m]) =
                    mirror_albedos(&d, direction(node(m)), CONDUCTOR_STRATA);
            }
        }
        // Averages 2 ∫ E(μ) μ dμ = 4 ∫ E(s²) s³ ds, trapezoidal rule on the s = √μ grid.
        let average = |table: &[f32], a: usize| {
            let row = &table[a * CONDUCTOR_MU..(a + 1) * CONDUCTOR_MU];
            let h = 1.0 / (CONDUCTOR_MU - 1) as f32;
            let integrand = |m: usize| 2.0 * row[m] * node(m).powi(3);
            let inner: f32 = (1..CONDUCTOR_MU - 1).map(integrand).sum();
            2.0 * h * (inner + 0.5 * (integrand(0) + integrand(CONDUCTOR_MU - 1)))
        };
        let e_avg = (0..CONDUCTOR_ALPHA).map(|a| if a == 0 { 1.0 } else { average(&e, a) }).collect();
        let e_schlick_avg = (0..CONDUCTOR_ALPHA).map(|a| average(&e_schlick, a)).collect();
        Self { e, e_avg, e_schlick, e_schlick_avg }
    }

    /// The Schlick-weighted albedo E₂(μ, α), bilinear in (√μ, √α).
    pub(crate) fn e_schlick(&self, mu: f32, alpha: f32) -> f32 {
        bilinear(&self.e_schlick, CONDUCTOR_MU, mu, alpha)
    }

    /// The average of E₂, linear in √α.
    pub(crate) fn e_schlick_avg(&self, alpha: f32) -> f32 {
        linear(&self.e_schlick_avg, alpha)
    }

    /// E(μ, α), bilinear in (√μ, √α).
    pub(crate) fn e(&self, mu: f32, alpha: f32) -> f32 {
        bilinear(&self.e, CONDUCTOR_MU, mu, alpha)
    }

    /// E_avg(α), linear in √α.
    pub(crate) fn e_avg(&self, alpha: f32) -> f32 {
        linear(&self.e_avg, alpha)
    }
}

impl DielectricTable {
    fn compute() -> Self {
        let cells = DIELECTRIC_MU * DIELECTRIC_ALPHA * DIELECTRIC_ETA;
        let (mut outside, mut inside) = (vec![1.0; cells], vec![1.0; cells]);
        for k in 0..DIELECTRIC_ETA {
            let eta = 1.0 + (DIELECTRIC_ETA_MAX - 1.0) * k as f32 / (DIELECTRIC_ETA - 1) as f32;
            for a in 1..DIELECTRIC_ALPHA {
                let d = TrowbridgeReitz::isotropic((a as f32 / (DIELECTRIC_ALPHA - 1) as f32).powi(2));
                for m in 0..DIELECTRIC_MU {
                    let wo = direction(m as f32 / (DIELECTRIC_MU - 1) as f32);
                    let i = (k * DIELECTRIC_ALPHA + a) * DIELECTRIC_MU + m;
                    outside[i] = dielectric_albedo(&d, wo, eta, DIELECTRIC_STRATA);
                    inside[i] = dielectric_albedo(&d, -wo, eta, DIELECTRIC_STRATA);
                }
            }
        }
        Self { outside, inside }
    }

    /// E(μ, α, η) for a ray on the side z > 0 (`from_inside` false) or z < 0 of an interface
    /// of index `eta` (inside over outside), trilinear in (√μ, √α, η); η clamped to [1, 3] (η < 1 is read as
    /// the same interface seen from the other side).
    pub(crate) fn e(&self, mu: f32, alpha: f32, eta: f32, from_inside: bool) -> f32 {
        let (eta, from_inside) = if eta < 1.0 { (1.0 / eta, !from_inside) } else { (eta, from_inside) };
        let table = if from_inside { &self.inside } else { &self.outside };
        let (k, tk) = locate(eta, 1.0, DIELECTRIC_ETA_MAX, DIELECTRIC_ETA);
        let size = DIELECTRIC_ALPHA * DIELECTRIC_MU;
        let plane = |k: usize| bilinear(&table[k * size..(k + 1) * size], DIELECTRIC_MU, mu, alpha);
        lerp(plane(k), plane(k + 1), tk)
    }
}

/// The conductor table, computed on first use.
pub(crate) fn conductor_table() -> &'static ConductorTable {
    static TABLE: LazyLock<ConductorTable> = LazyLock::new(ConductorTable::compute);
    &TABLE
}

/// The dielectric tables, computed on first use.
pub(crate) fn dielectric_table() -> &'static DielectricTable {
    static TABLE: LazyLock<DielectricTable> = LazyLock::new(DielectricTable::compute);
    &TABLE
}
