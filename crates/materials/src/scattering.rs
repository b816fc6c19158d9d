//! Specular reflection, refraction and the Fresnel equations (pbrt-v4
//! `util/scattering.h`): small pure functions, each separately testable.
//!
//! Convention (as in pbrt-v4 and the integrator crate): `wo` and `wi` point *away* from the
//! surface; `n` is a unit normal; `eta` is the relative index η_t / η_i of the side `n` does
//! not point to over the side it points to.

use glam::Vec3;

/// Mirror `wo` about `n`: the paper's eq. 1, R = V − 2 (V·N) N, with V = −wo.
#[inline]
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    -wo + 2.0 * wo.dot(n) * n
}

/// Refract `wi` through a surface with normal `n` and relative index `eta` (Snell's law,
/// the paper's eq. 2). When `wi` is on the side opposite `n` the interface is crossed the
/// other way: the normal is flipped and `eta` inverted, as the paper flips the normal when
/// a ray leaves a transparent object.
///
/// Returns the unit transmitted direction and the relative index actually used, or `None`
/// under total internal reflection. `eta == 0` (glTF's "Fresnel ≡ 1" mode) never transmits.
#[inline]
pub fn refract(wi: Vec3, n: Vec3, eta: f32) -> Option<(Vec3, f32)> {
    if eta <= 0.0 {
        return None;
    }
    let mut cos_theta_i = n.dot(wi);
    let (n, eta) = if cos_theta_i < 0.0 {
        cos_theta_i = -cos_theta_i;
        (-n, 1.0 / eta)
    } else {
        (n, eta)
    };
    let sin2_theta_i = (1.0 - cos_theta_i * cos_theta_i).max(0.0);
    let sin2_theta_t = sin2_theta_i / (eta * eta);
    if sin2_theta_t >= 1.0 {
        return None;
    }
    let cos_theta_t = (1.0 - sin2_theta_t).sqrt();
    let wt = -wi / eta + (cos_theta_i / eta - cos_theta_t) * n;
    // wt is unit up to rounding; renormalise so long paths do not drift.
    Some((wt.normalize(), eta))
}

/// Unpolarised Fresnel reflectance of a dielectric interface (exact equations, pbrt-v4
/// `FrDielectric`). `cos_theta_i` is measured against the normal `eta` refers to; a negative
/// cosine means the ray arrives from the other side. Returns 1 under total internal
/// reflection and for `eta == 0` (glTF's special mode).
#[inline]
pub fn fr_dielectric(cos_theta_i: f32, eta: f32) -> f32 {
    if eta <= 0.0 {
        return 1.0;
    }
    let mut cos_theta_i = cos_theta_i.clamp(-1.0, 1.0);
    let mut eta = eta;
    if cos_theta_i < 0.0 {
        eta = 1.0 / eta;
        cos_theta_i = -cos_theta_i;
    }
    let sin2_theta_i = 1.0 - cos_theta_i * cos_theta_i;
    let sin2_theta_t = sin2_theta_i / (eta * eta);
    if sin2_theta_t >= 1.0 {
        return 1.0;
    }
    let cos_theta_t = (1.0 - sin2_theta_t).max(0.0).sqrt();
    let r_parl = (eta * cos_theta_i - cos_theta_t) / (eta * cos_theta_i + cos_theta_t);
    let r_perp = (cos_theta_i - eta * cos_theta_t) / (cos_theta_i + eta * cos_theta_t);
    0.5 * (r_parl * r_parl + r_perp * r_perp)
}

/// Unpolarised Fresnel reflectance of a conductor with complex index η + iκ relative to the
/// outside medium (pbrt-v4 `FrComplex`), for `cos_theta_i` in [0, 1].
pub fn fr_conductor(cos_theta_i: f32, eta: f32, k: f32) -> f32 {
    // Complex arithmetic on (re, im) pairs, written out to stay dependency-free.
    let cos_i = cos_theta_i.clamp(0.0, 1.0);
    let sin2_i = 1.0 - cos_i * cos_i;
    // eta² as a complex number.
    let (e2r, e2i) = (eta * eta - k * k, 2.0 * eta * k);
    // sin²θt = sin²θi / η²
    let d = e2r * e2r + e2i * e2i;
    let (s2r, s2i) = (sin2_i * e2r / d, -sin2_i * e2i / d);
    // cosθt = sqrt(1 − sin²θt)
    let (cr, ci) = complex_sqrt(1.0 - s2r, -s2i);
    // r_parl = (η cosθi − cosθt) / (η cosθi + cosθt)
    let (ar, ai) = (eta * cos_i, k * cos_i);
    let r_parl = complex_norm_ratio((ar - cr, ai - ci), (ar + cr, ai + ci));
    // r_perp = (cosθi − η cosθt) / (cosθi + η cosθt)
    let (br, bi) = (eta * cr - k * ci, eta * ci + k * cr);
    let r_perp = complex_norm_ratio((cos_i - br, -bi), (cos_i + br, bi));
    0.5 * (r_parl + r_perp)
}

/// |a|² / |b|² for complex a, b.
fn complex_norm_ratio(a: (f32, f32), b: (f32, f32)) -> f32 {
    (a.0 * a.0 + a.1 * a.1) / (b.0 * b.0 + b.1 * b.1)
}

/// Principal square root of re + i·im.
fn complex_sqrt(re: f32, im: f32) -> (f32, f32) {
    let modulus = (re * re + im * im).sqrt();
    let r = (0.5 * (modulus + re)).max(0.0).sqrt();
    let i = (0.5 * (modulus - re)).max(0.0).sqrt().copysign(im);
    (r, i)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn normal_incidence_fresnel_is_schlick_r0() {
        // At normal incidence both polarisations give ((η−1)/(η+1))².
        for eta in [1.3f32, 1.5, 2.4] {
            let r0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
            assert!((fr_dielectric(1.0, eta) - r0).abs() < 1e-6);
            assert!((fr_dielectric(-1.0, eta) - r0).abs() < 1e-6, "symmetric from inside");
        }
    }

    #[test]
    fn total_internal_reflection_at_and_past_the_critical_angle() {
        // Leaving glass of index 1.3: the critical angle is asin(1/1.3).
        let eta = 1.3f32;
        let critical = (1.0 / eta).asin();
        let n = Vec3::Z;
        let inside = |theta: f32| Vec3::new(theta.sin(), 0.0, -theta.cos()); // below the surface
        // Just below the critical angle: transmits, Fresnel < 1.
        let before = critical - 1e-3;
        assert!(refract(inside(before), n, eta).is_some());
        assert!(fr_dielectric(-before.cos(), eta) < 1.0);
        // Just past it: no transmitted ray, Fresnel = 1 exactly.
        let past = critical + 1e-3;
        assert!(refract(inside(past), n, eta).is_none());
        assert_eq!(fr_dielectric(-past.cos(), eta), 1.0);
    }

    #[test]
    fn index_one_passes_straight_through_with_no_reflection() {
        let wi = Vec3::new(0.3, 0.4, 0.866_025_4).normalize();
        let (wt, _) = refract(wi, Vec3::Z, 1.0).unwrap();
        assert!((wt + wi).length() < 1e-6);
        assert!(fr_dielectric(wi.z, 1.0).abs() < 1e-12);
    }

    #[test]
    fn gltf_ior_zero_reflects_everything() {
        assert_eq!(fr_dielectric(0.5, 0.0), 1.0);
        assert!(refract(Vec3::Z, Vec3::Z, 0.0).is_none());
    }

    #[test]
    fn conductor_with_zero_k_matches_dielectric() {
        for cos in [1.0f32, 0.7, 0.3, 0.05] {
            let a = fr_conductor(cos, 1.5, 0.0);
            let b = fr_dielectric(cos, 1.5);
            assert!((a - b).abs() < 1e-5, "{cos}: {a} vs {b}");
        }
        // Gold-like metal at 600 nm (η ≈ 0.2, κ ≈ 3): highly reflective at normal incidence.
        let r = fr_conductor(1.0, 0.2, 3.0);
        let expected = ((0.2f32 - 1.0).powi(2) + 9.0) / ((0.2f32 + 1.0).powi(2) + 9.0);
        assert!((r - expected).abs() < 1e-5);
    }

    proptest! {
        #[test]
        fn refract_obeys_snell_and_returns_unit_vectors(
            theta in 0.0f32..1.55, phi in 0.0f32..std::f32::consts::TAU, eta in 1.0f32..2.5, from_inside in any::<bool>()
        ) {
            let z = if from_inside { -theta.cos() } else { theta.cos() };
            let wi = Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), z);
            if let Some((wt, eta_used)) = refract(wi, Vec3::Z, eta) {
                prop_assert!((wt.length() - 1.0).abs() < 1e-5);
                // Snell: sinθi = η' sinθt, with η' the index actually used.
                // Sines from the tangential components: √(1 − cos²) cancels catastrophically
                // near normal incidence (found by proptest, kept in proptest-regressions/).
                let sin_i = wi.truncate().length();
                let sin_t = wt.truncate().length();
                prop_assert!((sin_i - eta_used * sin_t).abs() < 2e-4, "{sin_i} vs {}", eta_used * sin_t);
                // Crosses the surface.
                prop_assert!(wt.z * wi.z <= 0.0);
            } else {
                prop_assert!(from_inside, "TIR only when leaving the denser medium");
            }
            let f = fr_dielectric(wi.z, eta);
            prop_assert!((0.0..=1.0).contains(&f));
        }
    }
}
