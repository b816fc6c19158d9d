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
    /// The permutation (kx, ky, kz) = ((k+1)%3, (k+2)%3, k), k the axis the direction is
    /// largest along, applied by run-time indexed loads in the tests below.
    axes: [usize; 3],
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
        // (Indexing an array: indexing the `Vec3` is a `match`, three branches per ray.)
        let c = dir.to_array();
        let d = Vec3::new(c[kx], c[ky], c[kz]);
        Self { origin, length, axes: [kx, ky, kz], sx: -d.x / d.z, sy: -d.y / d.z, sz: 1.0 / d.z }
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

/// Intersect the triangle (p0, p1, p2) in (0, t_max), t in units of the ray's direction (strictly
/// before `t_max`, as traversal needs: a later triangle must be strictly closer to replace a hit);
/// degenerate triangles never hit. The ray's axis permutation is applied by indexed loads.
/// (It used to be a const-generic parameter, the whole query compiled three times
/// and picked per ray: that `match` on the ray's dominant axis was a branch most incoherent rays
/// mispredicted, and three copies of the kernel; run-time indices cost almost nothing, and
/// the queries ran 5–11 % faster: `docs/perf.md`.)
///
/// The edge functions are plain `a·b − c·d` in f32, as in Woop et al. (not pbrt-v4's FMA
/// `DifferenceOfProducts`): the two triangles sharing an edge evaluate it on the same
/// transformed vertices in swapped order, and plain products make the two results exact
/// negations of each other, which is what watertightness needs (the FMA form is more
/// accurate but not exactly antisymmetric, and costs a library call without target FMA).
/// An edge function that is exactly 0 in f32 is recomputed in f64 — only that edge, so the
/// decision for an edge never depends on the triangle's other edges and both neighbours
/// always agree.
///
/// Also the reference of [`intersect_packet`] (tested lane for lane against this one).
#[inline(always)]
pub(crate) fn intersect_triangle(r: &TriangleRay, t_max: f32, p0: Vec3, p1: Vec3, p2: Vec3) -> Option<TriangleHit> {
    let [kx, ky, kz] = r.axes;
    let perm = |p: Vec3| {
        let q = (p - r.origin).to_array();
        Vec3::new(q[kx], q[ky], q[kz])
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
    // Edges of both signs: outside. `|` and `&`, not `||` and `&&`: one branch on the outcome
    // (mostly "outside", well predicted) instead of one per edge sign, which a ray's position
    // makes random (0.4 fewer mispredictions per incoherent ray, cachegrind).
    if ((e0 < 0.0) | (e1 < 0.0) | (e2 < 0.0)) & ((e0 > 0.0) | (e1 > 0.0) | (e2 > 0.0)) {
        return None;
    }
    let det = e0 + e1 + e2;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let t_max_scaled = t_max * r.length;
    p0t.z *= r.sz;
    p1t.z *= r.sz;
    p2t.z *= r.sz;
    let t_scaled = e0 * p0t.z + e1 * p1t.z + e2 * p2t.z;
    if det < 0.0 && (t_scaled >= 0.0 || t_scaled < t_max_scaled * det) {
        return None;
    }
    if det > 0.0 && (t_scaled <= 0.0 || t_scaled > t_max_scaled * det) {
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
    let t_unit = t / r.length;
    (t_unit < t_max).then_some(TriangleHit { t: t_unit, b })
}

/// Absolute error bound of the barycentric hit point b0 p0 + b1 p1 + b2 p2 (pbrt-v4).
#[inline]
pub(crate) fn triangle_point_error(b: [f32; 3], p0: Vec3, p1: Vec3, p2: Vec3) -> Vec3 {
    ((b[0] * p0).abs() + (b[1] * p1).abs() + (b[2] * p2).abs()) * gamma(7)
}

/// Up to four triangles of one leaf (a leaf of five to eight has two packets) in
/// structure-of-arrays form (`v[vertex][axis][lane]`) with their primitive indices, so that a
/// packet is one four-lane watertight test (as Embree's `triangle4v`): no index indirection, and
/// four triangles cost about one test.
/// Unused lanes hold NaN vertices (never hit, and never reach the f64 edge path) and
/// [`NO_LANE`].
#[derive(Debug, Clone, Copy)]
#[repr(C, align(16))]
pub(crate) struct TrianglePacket {
    pub(crate) v: [[[f32; 4]; 3]; 3],
    pub(crate) prim: [u32; 4],
}

/// The primitive index of an unused packet lane.
pub(crate) const NO_LANE: u32 = u32::MAX;

impl TrianglePacket {
    /// A packet of `tris` (at most four: vertices and primitive index).
    pub(crate) fn new(tris: impl IntoIterator<Item = ([Vec3; 3], u32)>) -> Self {
        let mut p = Self { v: [[[f32::NAN; 4]; 3]; 3], prim: [NO_LANE; 4] };
        for (lane, (vertices, prim)) in tris.into_iter().enumerate() {
            assert!(lane < 4, "a packet holds four triangles");
            for (k, v) in vertices.iter().enumerate() {
                for axis in 0..3 {
                    p.v[k][axis][lane] = v[axis];
                }
            }
            p.prim[lane] = prim;
        }
        p
    }

    /// The vertices of `lane`.
    #[inline(always)]
    pub(crate) fn vertices(&self, lane: usize) -> [Vec3; 3] {
        // Nine scalar loads. (`self.v.map(..)` copied the packet's 144 bytes of vertices to the
        // stack first: ~25 more instructions per hit, callgrind.)
        let v = |k: usize| Vec3::new(self.v[k][0][lane], self.v[k][1][lane], self.v[k][2][lane]);
        [v(0), v(1), v(2)]
    }
}

/// [`intersect_triangle`] on the four lanes of a packet at once: lane for lane the same IEEE
/// operations in the same order (four-lane glam `Vec4`, plain products, the same f64 recompute
/// of an edge function that is exactly 0), so each lane's decision, t and barycentrics are
/// bit for bit those of the scalar test at the same `t_max`. Of the lanes that hit (and are not
/// `skip`), the nearest wins, the lowest lane on a tie: (lane, hit).
///
/// With `EARLY` the test returns as soon as the edge tests leave no lane (closest-hit queries);
/// without it (any-hit queries) it runs on to its one final branch. The same hits either way;
/// measured (`trace_exported`, 4 rounds): any-hit rays 2–4 % faster without that exit,
/// closest-hit rays no faster (primary up to 2.6 % slower), so each query keeps its better one.
#[inline(always)]
pub(crate) fn intersect_packet<const EARLY: bool>(
    r: &TriangleRay,
    t_max: f32,
    pk: &TrianglePacket,
    skip: Option<u32>,
) -> Option<(usize, TriangleHit)> {
    use glam::{BVec4A, Vec4};
    let [kx, ky, kz] = r.axes;
    let o = r.origin.to_array();
    let (ox, oy, oz) = (Vec4::splat(o[kx]), Vec4::splat(o[ky]), Vec4::splat(o[kz]));
    let (sx, sy, sz) = (Vec4::splat(r.sx), Vec4::splat(r.sy), Vec4::splat(r.sz));
    let vertex = |k: usize| {
        let z = Vec4::from_array(pk.v[k][kz]) - oz;
        let x = Vec4::from_array(pk.v[k][kx]) - ox + sx * z;
        let y = Vec4::from_array(pk.v[k][ky]) - oy + sy * z;
        (x, y, z)
    };
    let (p0x, p0y, p0z) = vertex(0);
    let (p1x, p1y, p1z) = vertex(1);
    let (p2x, p2y, p2z) = vertex(2);
    let mut e0 = p1x * p2y - p1y * p2x;
    let mut e1 = p2x * p0y - p2y * p0x;
    let mut e2 = p0x * p1y - p0y * p1x;
    let zero = Vec4::ZERO;
    if (e0.cmpeq(zero) | e1.cmpeq(zero) | e2.cmpeq(zero)).any() {
        // Rare (a ray through an edge or vertex, exactly): the scalar recompute, lane by lane.
        let fix = |e: &mut Vec4, ax: Vec4, by: Vec4, ay: Vec4, bx: Vec4| {
            let mut a = e.to_array();
            for lane in 0..4 {
                if a[lane] == 0.0 {
                    a[lane] = edge_f64(ax[lane], by[lane], ay[lane], bx[lane]);
                }
            }
            *e = Vec4::from_array(a);
        };
        fix(&mut e0, p1x, p2y, p1y, p2x);
        fix(&mut e1, p2x, p0y, p2y, p0x);
        fix(&mut e2, p0x, p1y, p0y, p1x);
    }
    let negative = e0.cmplt(zero) | e1.cmplt(zero) | e2.cmplt(zero);
    let positive = e0.cmpgt(zero) | e1.cmpgt(zero) | e2.cmpgt(zero);
    let det = e0 + e1 + e2;
    // `det.is_finite()` per lane: |det| < ∞ is false for ±∞ and NaN alike.
    let mut hit = !(negative & positive) & det.cmpne(zero) & det.abs().cmplt(Vec4::INFINITY);
    if let Some(skip) = skip {
        hit &= BVec4A::from_array(pk.prim.map(|p| p != skip));
    }
    if EARLY && !hit.any() {
        return None;
    }
    let t_max_scaled = Vec4::splat(t_max * r.length);
    let (p0z, p1z, p2z) = (p0z * sz, p1z * sz, p2z * sz);
    let t_scaled = e0 * p0z + e1 * p1z + e2 * p2z;
    let bound = t_max_scaled * det;
    let behind_or_beyond_neg = t_scaled.cmpge(zero) | t_scaled.cmplt(bound);
    let behind_or_beyond_pos = t_scaled.cmple(zero) | t_scaled.cmpgt(bound);
    hit &= !(det.cmplt(zero) & behind_or_beyond_neg) & !(det.cmpgt(zero) & behind_or_beyond_pos);
    if !hit.any() {
        return None;
    }
    let inv_det = Vec4::ONE / det;
    let t = t_scaled * inv_det;
    hit &= t.abs().cmplt(Vec4::INFINITY);
    // The error bound on t, as in the scalar test (same operations, same order).
    let max_zt = p0z.abs().max(p1z.abs()).max(p2z.abs());
    let delta_z = Vec4::splat(gamma(3)) * max_zt;
    let max_xt = p0x.abs().max(p1x.abs()).max(p2x.abs());
    let max_yt = p0y.abs().max(p1y.abs()).max(p2y.abs());
    let delta_x = Vec4::splat(gamma(5)) * (max_xt + max_zt);
    let delta_y = Vec4::splat(gamma(5)) * (max_yt + max_zt);
    let delta_e = Vec4::splat(2.0) * (Vec4::splat(gamma(2)) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    let max_e = e0.abs().max(e1.abs()).max(e2.abs());
    let delta_t = Vec4::splat(3.0)
        * (Vec4::splat(gamma(3)) * max_e * max_zt + delta_e * max_zt + delta_z * max_e)
        * inv_det.abs();
    let t_unit = t / Vec4::splat(r.length);
    hit &= t.cmpgt(delta_t) & t_unit.cmplt(Vec4::splat(t_max));
    let mut bits = hit.bitmask();
    if bits == 0 {
        return None;
    }
    let ts = t_unit.to_array();
    let mut best = bits.trailing_zeros() as usize;
    bits &= bits - 1;
    while bits != 0 {
        let lane = bits.trailing_zeros() as usize;
        bits &= bits - 1;
        if ts[lane] < ts[best] {
            best = lane;
        }
    }
    let inv = inv_det[best];
    Some((best, TriangleHit { t: ts[best], b: [e0[best] * inv, e1[best] * inv, e2[best] * inv] }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scalar(r: &TriangleRay, t_max: f32, p: [Vec3; 3]) -> Option<TriangleHit> {
        intersect_triangle(r, t_max, p[0], p[1], p[2])
    }

    #[test]
    fn packet_lanes_decide_as_the_scalar_test_bit_for_bit() {
        // Random rays at packets of 1–4 random triangles, half of them sharing vertices on a
        // small grid so that rays through edges and vertices (the f64 edge path) occur. The
        // packet's answer must be the scalar test's nearest hit (lowest lane on a tie), with the
        // same bits of t and barycentrics; one lane is also tested alone in every lane slot.
        let mut next = crate::test_uniform(0x2545_f491_4f6c_dd1d);
        let (mut hits, mut edge_hits) = (0, 0);
        for case in 0..20_000 {
            let grid = case % 2 == 0;
            let point = |next: &mut dyn FnMut() -> f32| {
                if grid {
                    Vec3::new((next() * 4.0).floor(), (next() * 4.0).floor(), 0.0) * 0.25
                } else {
                    Vec3::new(next(), next(), next()) * 2.0 - 1.0
                }
            };
            let n = 1 + case % 4;
            let tris: Vec<([Vec3; 3], u32)> =
                (0..n).map(|i| ([point(&mut next), point(&mut next), point(&mut next)], 10 + i as u32)).collect();
            let origin = Vec3::new(next(), next(), 2.0 + next()) - Vec3::new(0.5, 0.5, 0.0);
            let target = if grid { point(&mut next) } else { Vec3::new(next(), next(), 0.0) - 0.5 };
            let dir = (target - origin) * (0.5 + next());
            let r = TriangleRay::new(origin, dir);
            let t_max = if case % 3 == 0 { f32::INFINITY } else { 1.0 + next() };
            let skip = (case % 5 == 0).then_some(10);
            let pk = TrianglePacket::new(tris.iter().copied());
            let mut expected: Option<(usize, TriangleHit)> = None;
            for (lane, (p, prim)) in tris.iter().enumerate() {
                if Some(*prim) == skip {
                    continue;
                }
                if let Some(h) = scalar(&r, t_max, *p) {
                    if h.b.contains(&0.0) {
                        edge_hits += 1;
                    }
                    if expected.is_none_or(|(_, e)| h.t < e.t) {
                        expected = Some((lane, h));
                    }
                }
            }
            let got = intersect_packet::<true>(&r, t_max, &pk, skip);
            let bits = |x: Option<(usize, TriangleHit)>| x.map(|(l, h)| (l, h.t.to_bits(), h.b.map(f32::to_bits)));
            assert_eq!(bits(got), bits(expected), "case {case}");
            let no_early_exit = intersect_packet::<false>(&r, t_max, &pk, skip);
            assert_eq!(bits(no_early_exit), bits(expected), "case {case}, without the early exit");
            hits += usize::from(got.is_some());
            // The first triangle alone in each lane of an otherwise empty packet.
            for lane in 0..4 {
                let mut alone = TrianglePacket::new([]);
                for k in 0..3 {
                    for axis in 0..3 {
                        alone.v[k][axis][lane] = tris[0].0[k][axis];
                    }
                }
                alone.prim[lane] = 7;
                let want = scalar(&r, t_max, tris[0].0).map(|h| (lane, h));
                assert_eq!(
                    bits(intersect_packet::<true>(&r, t_max, &alone, None)),
                    bits(want),
                    "case {case}, lane {lane}"
                );
            }
        }
        // The cases must exercise both outcomes and the exact-edge path.
        assert!(hits > 4_000 && hits < 16_000, "{hits} hits");
        assert!(edge_hits > 50, "{edge_hits} hits on an edge");
    }

    #[test]
    fn unused_lanes_never_hit() {
        // A packet of one triangle: rays through the NaN lanes' "triangles" find nothing else.
        let pk = TrianglePacket::new([([Vec3::ZERO, Vec3::X, Vec3::Y], 3)]);
        let r = TriangleRay::new(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z);
        let (lane, h) = intersect_packet::<true>(&r, f32::INFINITY, &pk, None).expect("the triangle");
        assert_eq!((lane, h.t), (0, 1.0));
        assert!(intersect_packet::<true>(&r, f32::INFINITY, &pk, Some(3)).is_none(), "skipped");
        let miss = TriangleRay::new(Vec3::new(2.0, 2.0, 1.0), Vec3::NEG_Z);
        assert!(intersect_packet::<true>(&miss, f32::INFINITY, &pk, None).is_none());
    }
}
