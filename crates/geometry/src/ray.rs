//! Rays, hit records and robust spawning of secondary rays (pbrt-v4 `OffsetRayOrigin`).

use glam::{Vec2, Vec3};

/// A ray `origin + t·dir`; `dir` need not be unit length (t is in units of `dir`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Origin.
    pub origin: Vec3,
    /// Direction.
    pub dir: Vec3,
}

/// What a ray hit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit.
    pub t: f32,
    /// Hit point.
    pub p: Vec3,
    /// Conservative absolute error bound of `p`, per axis.
    pub p_error: Vec3,
    /// Unit geometric normal: cross(p1 − p0, p2 − p0) for triangles (winding decides the
    /// side), outward for spheres.
    pub n: Vec3,
    /// Unit shading normal (interpolated vertex normals, else `n`), in `n`'s hemisphere.
    pub ns: Vec3,
    /// Surface coordinates: the mesh's UVs, else barycentrics (b1, b2); spheres: (φ/2π, θ/π).
    pub uv: Vec2,
    /// Global primitive index in the [`crate::Scene`]; `u32::MAX` on placed instances.
    pub primitive: u32,
    /// On a placed instance: the placement's index and the primitive's index in the placed object
    /// ([`crate::Scene::hit_triangle`] reads the mesh back through them); `u32::MAX` for both elsewhere.
    pub placement: u32,
    /// See [`Hit::placement`].
    pub object_primitive: u32,
    /// Material of the primitive.
    pub material: Option<u32>,
}

/// The primitive id of none: hits on placed instances, and queries that skip nothing.
pub(crate) const NO_PRIMITIVE: u32 = u32::MAX;

/// A shadow ray from a lifted point ([`crate::Scene::terminator_shadow_ray`]): occluded if
/// anything other than the primitive it leaves lies in (0, `t_max`) along it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShadowRay {
    /// The ray.
    pub ray: Ray,
    /// Where along it occluders count up to.
    pub t_max: f32,
    pub(crate) skip: u32,
}

/// γ(n) = n·ε / (1 − n·ε), ε = half an f32 ulp at 1: the bound on the relative error of n
/// rounded operations (pbrt-v4 `gamma`, Higham 2002).
#[inline]
pub(crate) const fn gamma(n: i32) -> f32 {
    let e = f32::EPSILON * 0.5;
    (n as f32 * e) / (1.0 - n as f32 * e)
}

/// The origin of a ray leaving `p` (error bound `p_error`, normal `n`) towards `w`: moved
/// along ±n just past the error box, then rounded away from the surface, so the new ray
/// cannot re-hit the surface it starts on (pbrt-v4 `OffsetRayOrigin`).
#[inline(always)] // Two calls per bounce; left out of line (as the compiler chose once `trace` grew) it cost 0.7 % of a Cornell render.
pub(crate) fn offset_ray_origin(p: Vec3, p_error: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    let d = n.abs().dot(p_error);
    let mut offset = d * n;
    if w.dot(n) < 0.0 {
        offset = -offset;
    }
    let mut po = p + offset;
    for i in 0..3 {
        if offset[i] > 0.0 {
            po[i] = po[i].next_up();
        } else if offset[i] < 0.0 {
            po[i] = po[i].next_down();
        }
    }
    po
}

/// A secondary ray leaving `hit` in direction `dir`, robustly offset (no scene-scale epsilon).
#[inline]
pub fn spawn_ray(hit: &Hit, dir: Vec3) -> Ray {
    Ray { origin: offset_ray_origin(hit.p, hit.p_error, hit.n, dir), dir }
}

/// A shadow ray from `hit` to the point `target` ([`spawn_ray_to`]) or, without one, along `wi`
/// to infinity ([`spawn_ray`]), and the `t_max` to test occlusion against: a light sample's two
/// kinds (area and point lights; directional lights and the environment).
#[inline(always)]
pub fn spawn_shadow_ray(hit: &Hit, target: Option<Vec3>, wi: Vec3) -> (Ray, f32) {
    match target {
        Some(q) => spawn_ray_to(hit, q),
        None => (spawn_ray(hit, wi), f32::INFINITY),
    }
}

/// A shadow ray from `hit` towards the point `target`, and the `t_max` to test occlusion
/// against: just short of the target (pbrt-v4's `ShadowEpsilon` = 1e-4 of the segment), so a
/// light at the target is not counted as its own occluder.
#[inline]
pub fn spawn_ray_to(hit: &Hit, target: Vec3) -> (Ray, f32) {
    let origin = offset_ray_origin(hit.p, hit.p_error, hit.n, target - hit.p);
    (Ray { origin, dir: target - origin }, 1.0 - 1e-4)
}
