//! Watertight ray–triangle intersection (Woop, Benthin & Wald 2013, "Watertight Ray/Triangle
//! Intersection", JCGT 2(1); as in pbrt-v4 `Triangle::Intersect`): rays through shared edges
//! and vertices of a closed mesh always hit one of the triangles.

use glam::Vec3;

use crate::ray::gamma;

/// Per-ray data of the watertight test, computed once per ray: the axis permutation that
/// makes the direction's largest component z, and the shear that maps the ray to +z. The
/// direction is normalised first: pbrt-v4's error bound on t adds world-space x, y extents to
/// z extents measured in units of t, which is only consistent for unit directions (with a
/// direction of length 5e-4 the bound is 20× too large and every hit is rejected).
#[derive(Debug, Clone, Copy)]
pub(crate) struct TriangleRay {
    origin: Vec3,
    /// |dir|: t in the caller's units is t_unit / length.
    length: f32,
    kz: usize,
    sx: f32,
    sy: f32,
    sz: f32,
}

impl TriangleRay {
    #[inline]
    pub(crate) fn new(origin: Vec3, dir: Vec3) -> Self {
        let length = dir.length();
        let dir = dir / length;
        let a = dir.abs();
        let kz = if a.x > a.y {
            if a.x > a.z { 0 } else { 2 }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let kx = (kz + 1) % 3;
        let ky = (kx + 1) % 3;
        let d = Vec3::new(dir[kx], dir[ky], dir[kz]);
        Self { origin, length, kz, sx: -d.x / d.z, sy: -d.y / d.z, sz: 1.0 / d.z }
    }
}

/// Barycentrics and ray parameter of a hit.
#[derive(Debug, Clone, Copy)]
pub(crate) struct TriangleHit {
    pub(crate) t: f32,
    pub(crate) b: [f32; 3],
}

/// a·b − c·d with one rounding error (Kahan's algorithm with FMA, pbrt-v4 `DifferenceOfProducts`).
#[inline]
fn difference_of_products(a: f32, b: f32, c: f32, d: f32) -> f32 {
    let cd = c * d;
    let err = (-c).mul_add(d, cd);
    let dop = a.mul_add(b, -cd);
    dop + err
}

/// Intersect the triangle (p0, p1, p2) in (0, t_max), t in units of the ray's direction.
/// Degenerate triangles never hit.
#[inline]
pub(crate) fn intersect_triangle(r: &TriangleRay, t_max: f32, p0: Vec3, p1: Vec3, p2: Vec3) -> Option<TriangleHit> {
    // One predictable branch per call instead of nine run-time indexed loads.
    match r.kz {
        0 => intersect_permuted::<1, 2, 0>(r, t_max, p0, p1, p2),
        1 => intersect_permuted::<2, 0, 1>(r, t_max, p0, p1, p2),
        _ => intersect_permuted::<0, 1, 2>(r, t_max, p0, p1, p2),
    }
}

#[inline(always)]
fn intersect_permuted<const KX: usize, const KY: usize, const KZ: usize>(
    r: &TriangleRay,
    t_max: f32,
    p0: Vec3,
    p1: Vec3,
    p2: Vec3,
) -> Option<TriangleHit> {
    let t_max = t_max * r.length;
    let perm = |p: Vec3| {
        let q = (p - r.origin).to_array();
        Vec3::new(q[KX], q[KY], q[KZ])
    };
    let (mut p0t, mut p1t, mut p2t) = (perm(p0), perm(p1), perm(p2));
    p0t.x += r.sx * p0t.z;
    p0t.y += r.sy * p0t.z;
    p1t.x += r.sx * p1t.z;
    p1t.y += r.sy * p1t.z;
    p2t.x += r.sx * p2t.z;
    p2t.y += r.sy * p2t.z;

    let mut e0 = difference_of_products(p1t.x, p2t.y, p1t.y, p2t.x);
    let mut e1 = difference_of_products(p2t.x, p0t.y, p2t.y, p0t.x);
    let mut e2 = difference_of_products(p0t.x, p1t.y, p0t.y, p1t.x);
    if e0 == 0.0 || e1 == 0.0 || e2 == 0.0 {
        // Exactly on an edge in f32: decide in f64 so neighbours agree (watertightness).
        let f = |a: f32, b: f32, c: f32, d: f32| (f64::from(a) * f64::from(b) - f64::from(c) * f64::from(d)) as f32;
        e0 = f(p1t.x, p2t.y, p1t.y, p2t.x);
        e1 = f(p2t.x, p0t.y, p2t.y, p0t.x);
        e2 = f(p0t.x, p1t.y, p0t.y, p1t.x);
    }
    if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
        return None;
    }
    let det = e0 + e1 + e2;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    p0t.z *= r.sz;
    p1t.z *= r.sz;
    p2t.z *= r.sz;
    let t_scaled = e0 * p0t.z + e1 * p1t.z + e2 * p2t.z;
    if det < 0.0 && (t_scaled >= 0.0 || t_scaled < t_max * det) {
        return None;
    }
    if det > 0.0 && (t_scaled <= 0.0 || t_scaled > t_max * det) {
        return None;
    }
    let inv_det = 1.0 / det;
    let b = [e0 * inv_det, e1 * inv_det, e2 * inv_det];
    let t = t_scaled * inv_det;
    if !t.is_finite() {
        return None;
    }

    // Conservatively reject hits at t ≤ 0 (pbrt-v4's bound on the error of t).
    let max_zt = p0t.z.abs().max(p1t.z.abs()).max(p2t.z.abs());
    let delta_z = gamma(3) * max_zt;
    let max_xt = p0t.x.abs().max(p1t.x.abs()).max(p2t.x.abs());
    let max_yt = p0t.y.abs().max(p1t.y.abs()).max(p2t.y.abs());
    let delta_x = gamma(5) * (max_xt + max_zt);
    let delta_y = gamma(5) * (max_yt + max_zt);
    let delta_e = 2.0 * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    let max_e = e0.abs().max(e1.abs()).max(e2.abs());
    let delta_t = 3.0 * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * inv_det.abs();
    if t <= delta_t {
        return None;
    }
    Some(TriangleHit { t: t / r.length, b })
}

/// Absolute error bound of the barycentric hit point b0 p0 + b1 p1 + b2 p2 (pbrt-v4).
#[inline]
pub(crate) fn triangle_point_error(b: [f32; 3], p0: Vec3, p1: Vec3, p2: Vec3) -> Vec3 {
    ((b[0] * p0).abs() + (b[1] * p1).abs() + (b[2] * p2).abs()) * gamma(7)
}
