//! The warps the BSDFs sample with (moved from the integrator so that a BSDF and its sampling
//! live together): an orthonormal basis, the concentric disk, the cosine hemisphere and the
//! uniform sphere.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

/// An orthonormal basis (t, b) completing the unit vector `n` (Duff et al. 2017, "Building
/// an orthonormal basis, revisited", JCGT 6(1)).
#[inline]
pub fn basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x), Vec3::new(b, sign + n.y * n.y * a, -n.y))
}

/// Shirley–Chiu concentric map of the unit square onto the unit disk (pbrt-v4
/// `SampleUniformDiskConcentric`).
#[inline]
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) =
        if o.x.abs() > o.y.abs() { (o.x, PI / 4.0 * (o.y / o.x)) } else { (o.y, PI / 2.0 - PI / 4.0 * (o.x / o.y)) };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// A cosine-distributed direction about the unit vector `n` (Malley's method); its density
/// is `cos θ / π` per steradian.
#[inline]
pub fn cosine_hemisphere(n: Vec3, u: Vec2) -> Vec3 {
    let d = concentric_disk(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    let (t, b) = basis(n);
    (d.x * t + d.y * b + z * n).normalize()
}

/// A uniformly distributed unit vector (density 1/4π).
#[inline]
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::test_support::TestRng;

    #[test]
    fn cosine_samples_have_mean_cosine_two_thirds() {
        // E[cos θ] under p = cos θ/π is 2/3; Var = 1/2 − 4/9 = 1/18; 5 standard errors.
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        let mut rng = TestRng::new(0);
        let count = 50_000;
        let mut sum = 0.0f64;
        for _ in 0..count {
            let w = cosine_hemisphere(n, rng.uniform2());
            assert!((w.length() - 1.0).abs() < 1e-4 && w.dot(n) >= -1e-6);
            sum += f64::from(w.dot(n));
        }
        let se = (1.0 / 18.0 / f64::from(count)).sqrt();
        assert!((sum / f64::from(count) - 2.0 / 3.0).abs() < 5.0 * se);
    }

    #[test]
    fn basis_is_orthonormal() {
        for n in [Vec3::Z, Vec3::NEG_Z, Vec3::X, Vec3::new(0.2, 0.3, -0.9).normalize()] {
            let (t, b) = basis(n);
            assert!(t.dot(n).abs() < 1e-6 && b.dot(n).abs() < 1e-6 && t.dot(b).abs() < 1e-6);
            assert!((t.length() - 1.0).abs() < 1e-6 && (b.length() - 1.0).abs() < 1e-6);
        }
    }
}
