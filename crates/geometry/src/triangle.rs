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

    /// The axis the ray's direction is largest along (0, 1, 2): the z of the permutation.
    #[inline]
    pub(crate) fn axis(&self) -> usize {
        self.kz
    }
}

/// Barycentrics and ray parameter of a hit.
#[derive(Debug, Clone, Copy)]
pub(crate) struct TriangleHit {
    pub(crate) t: f32,
    pub(crate) b: [f32; 3],
}

/// Edge function x0·y1 − y0·x1 in f64, where both products are exact (24 + 24 bits < 53) and
/// the difference is rounded once.
#[inline(never)]
#[cold]
fn edge_f64(x0: f32, y1: f32, y0: f32, x1: f32) -> f32 {
    (f64::from(x0) * f64::from(y1) - f64::from(y0) * f64::from(x1)) as f32
}

/// Intersect the triangle (p0, p1, p2) in (0, t_max], t in units of the ray's direction;
/// degenerate triangles never hit. The axis permutation (KX, KY, KZ) = ((k+1)%3, (k+2)%3, k)
/// with k = [`TriangleRay::axis`] is fixed at compile time: the caller dispatches once per
/// ray instead of paying nine run-time indexed loads per triangle.
///
/// The edge functions are plain `a·b − c·d` in f32, as in Woop et al. (not pbrt-v4's FMA
/// `DifferenceOfProducts`): the two triangles sharing an edge evaluate it on the same
/// transformed vertices in swapped order, and plain products make the two results exact
/// negations of each other, which is what watertightness needs (the FMA form is more
/// accurate but not exactly antisymmetric, and costs a library call without target FMA).
/// An edge function that is exactly 0 in f32 is recomputed in f64 — only that edge, so the
/// decision for an edge never depends on the triangle's other edges and both neighbours
/// always agree.
#[inline(always)]
pub(crate) fn intersect_permuted<const KX: usize, const KY: usize, const KZ: usize>(
    r: &TriangleRay,
    t_max: f32,
    p0: Vec3,
    p1: Vec3,
    p2: Vec3,
) -> Option<TriangleHit> {
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

    let mut e0 = p1t.x * p2t.y - p1t.y * p2t.x;
    let mut e1 = p2t.x * p0t.y - p2t.y * p0t.x;
    let mut e2 = p0t.x * p1t.y - p0t.y * p1t.x;
    if e0 == 0.0 {
        e0 = edge_f64(p1t.x, p2t.y, p1t.y, p2t.x);
    }
    if e1 == 0.0 {
        e1 = edge_f64(p2t.x, p0t.y, p2t.y, p0t.x);
    }
    if e2 == 0.0 {
        e2 = edge_f64(p0t.x, p1t.y, p0t.y, p1t.x);
    }
    if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
        return None;
    }
    let det = e0 + e1 + e2;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let t_max = t_max * r.length;
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

    // Conservatively reject hits at t ≤ 0 (pbrt-v4's bound on the error of t; the edge
    // functions' bound δe covers plain products as well, each being within γ(2) of exact).
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
