//! Ray–sphere intersection with the numerically stable quadratic of Haines et al., "Precision
//! Improvements for Ray/Sphere Intersection" (Ray Tracing Gems, ch. 7), and reprojection of
//! the hit point onto the surface (pbrt-v4) for a tight error bound.

use glam::Vec3;

use crate::ray::gamma;
use crate::shapes::Sphere;

/// The nearest root in (0, t_max), or `None`. A ray starting inside finds the far side.
#[inline]
pub(crate) fn intersect_sphere(s: &Sphere, origin: Vec3, dir: Vec3, t_max: f32) -> Option<f32> {
    let r = s.radius();
    let f = origin - s.center();
    let a = dir.length_squared();
    if a == 0.0 {
        return None;
    }
    let b = -f.dot(dir);
    // Δ/a computed as r² − |f + (b/a) d|², which avoids the cancellation of b² − ac.
    let l = f + (b / a) * dir;
    let disc = a * (r * r - l.length_squared());
    if !(disc >= 0.0) {
        return None;
    }
    let c = f.length_squared() - r * r;
    let q = b + disc.sqrt().copysign(b);
    if q == 0.0 {
        return None;
    }
    let (mut t0, mut t1) = (c / q, q / a);
    if t0 > t1 {
        std::mem::swap(&mut t0, &mut t1);
    }
    if t0 > 0.0 && t0 < t_max {
        Some(t0)
    } else if t1 > 0.0 && t1 < t_max {
        Some(t1)
    } else {
        None
    }
}

/// The hit point reprojected onto the sphere, its error bound and the outward normal.
#[inline]
pub(crate) fn sphere_hit_point(s: &Sphere, origin: Vec3, dir: Vec3, t: f32) -> (Vec3, Vec3, Vec3) {
    let mut local = origin + t * dir - s.center();
    let len = local.length();
    if len > 0.0 {
        local *= s.radius() / len;
    }
    let n = (local / s.radius()).normalize_or(Vec3::Z);
    let p = s.center() + local;
    // Reprojection leaves γ(5)|p_local| (pbrt-v4); adding the centre costs one more rounding.
    let p_error = gamma(5) * local.abs() + gamma(1) * (s.center().abs() + local.abs());
    (p, p_error, n)
}
