//! The acceleration structure: obvhs builds a compressed-wide BVH (CWBVH) over conservatively
//! padded primitive bounds; our watertight triangle test and stable sphere test run in its
//! traversal closure.

use std::time::{Duration, Instant};

use glam::{Vec2, Vec3, Vec3A};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::CwBvh;
use obvhs::cwbvh::builder::build_cwbvh;
use obvhs::ray::{Ray as BvhRay, RayHit};
use obvhs::{Boundable, BvhBuildParams};

use crate::error::{Error, Result};
use crate::ray::{Hit, Ray};
use crate::shapes::{Mesh, Sphere};
use crate::sphere::{intersect_sphere, sphere_hit_point};
use crate::triangle::{TriangleRay, intersect_triangle, triangle_point_error};

/// What a global primitive index refers to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Primitive {
    /// `Scene::spheres()[index]`.
    Sphere {
        /// Index into the spheres.
        index: u32,
    },
    /// Triangle `triangle` of `Scene::meshes()[mesh]`.
    Triangle {
        /// Index into the meshes.
        mesh: u32,
        /// Triangle within the mesh.
        triangle: u32,
    },
}

/// Figures about the acceleration structure, for `spectrace info` and benchmarks.
#[derive(Debug, Clone, Copy)]
pub struct BvhStats {
    /// Number of BVH nodes.
    pub node_count: usize,
    /// Wall time of the build (bounds, BVH, triangle layout).
    pub build_time: Duration,
    /// Bytes of BVH nodes, primitive indices and triangle vertex data.
    pub bytes: usize,
    /// `bytes` per primitive.
    pub bytes_per_primitive: f64,
}

/// A primitive's bounds, padded so that the BVH's float slab test can never cull a ray that
/// the exact intersection tests would hit (a Woop test alone still leaks through an unpadded
/// box test at shared edges and vertices).
struct Bounds(Aabb);

impl Boundable for Bounds {
    fn aabb(&self) -> Aabb {
        self.0
    }
}

/// Relative padding of primitive bounds: 2⁻¹⁸ ≈ 3.8e-6 of the coordinates' magnitude, far
/// above the few ulps (≈ 6e-8 each) the slab test and the CWBVH's conservative quantisation
/// can lose, far below any geometric feature that matters.
const PAD_RELATIVE: f32 = 1.0 / 262_144.0;

fn padded(lo: Vec3, hi: Vec3) -> Bounds {
    let magnitude = lo.abs().max(hi.abs()).max_element() + (hi - lo).max_element();
    let pad = Vec3::splat(magnitude * PAD_RELATIVE + f32::MIN_POSITIVE);
    Bounds(Aabb { min: Vec3A::from(lo - pad), max: Vec3A::from(hi + pad) })
}

/// All spheres and triangles of a scene with their BVH.
#[derive(Debug)]
pub struct Scene {
    spheres: Vec<Sphere>,
    meshes: Vec<Mesh>,
    /// Triangle vertices by global primitive index − sphere count, for cache-friendly tests.
    triangles: Vec<[Vec3; 3]>,
    /// (mesh, triangle) of each triangle in `triangles`.
    triangle_source: Vec<(u32, u32)>,
    bvh: Option<CwBvh>,
    /// Primitives in the BVH's leaf order (index = obvhs's primitive slot): triangle vertices
    /// (unused for spheres) and the global primitive index. Traversal reads this array in
    /// order instead of chasing `primitive_indices` into scattered memory.
    ordered: Vec<([Vec3; 3], u32)>,
    bounds: (Vec3, Vec3),
    build_time: Duration,
}

impl Scene {
    /// Build the BVH over every sphere and triangle (in parallel).
    pub fn build(spheres: Vec<Sphere>, meshes: Vec<Mesh>) -> Result<Self> {
        let start = Instant::now();
        let mut triangles = Vec::new();
        let mut triangle_source = Vec::new();
        for (m, mesh) in meshes.iter().enumerate() {
            let p = mesh.positions();
            for (t, tri) in mesh.indices().iter().enumerate() {
                triangles.push([p[tri[0] as usize], p[tri[1] as usize], p[tri[2] as usize]]);
                triangle_source.push((m as u32, t as u32));
            }
        }
        let count = spheres.len() + triangles.len();
        if count > u32::MAX as usize - 1 {
            return Err(Error::Invalid(format!("{count} primitives: at most {} are supported", u32::MAX - 1)));
        }
        let mut bounds_list = Vec::with_capacity(count);
        for s in &spheres {
            let r = Vec3::splat(s.radius());
            bounds_list.push(padded(s.center() - r, s.center() + r));
        }
        for t in &triangles {
            bounds_list.push(padded(t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2])));
        }
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for b in &bounds_list {
            lo = lo.min(b.0.min.into());
            hi = hi.max(b.0.max.into());
        }
        if !(lo.is_finite() && hi.is_finite()) && count > 0 {
            return Err(Error::Invalid("scene bounds are not finite".to_owned()));
        }
        let bvh = (count > 0).then(|| {
            let mut core = Duration::ZERO;
            build_cwbvh(&bounds_list, BvhBuildParams::medium_build(), &mut core)
        });
        let bounds = if count > 0 { (lo, hi) } else { (Vec3::ZERO, Vec3::ZERO) };
        let n_spheres = spheres.len();
        let ordered = bvh
            .as_ref()
            .map(|b| {
                b.primitive_indices
                    .iter()
                    .map(|&prim| {
                        let vertices = if (prim as usize) < n_spheres {
                            [Vec3::ZERO; 3]
                        } else {
                            triangles[prim as usize - n_spheres]
                        };
                        (vertices, prim)
                    })
                    .collect()
            })
            .unwrap_or_default();
        Ok(Self { spheres, meshes, triangles, triangle_source, bvh, ordered, bounds, build_time: start.elapsed() })
    }

    fn bvh_ray(ray: &Ray, t_max: f32) -> BvhRay {
        // Exact reciprocals (obvhs's `safe_inverse` replaces |x| ≤ ε by ±1/ε, which is wrong
        // for small components). Zero components (±0) get a huge *positive* finite value: obvhs
        // orders each slab by `direction < 0.0`, which is false for −0, so a negative
        // reciprocal there would swap the slab and cull the ray (found by the test
        // `grazing_spawned_rays_never_rehit_their_surface`); finite so 0·∞ cannot make NaN.
        let inv = |x: f32| if x == 0.0 { 1e30 } else { 1.0 / x };
        BvhRay {
            origin: ray.origin.into(),
            direction: ray.dir.into(),
            inv_direction: Vec3A::new(inv(ray.dir.x), inv(ray.dir.y), inv(ray.dir.z)),
            tmin: 0.0,
            tmax: t_max,
        }
    }

    /// The closest hit in (0, `t_max`).
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        let bvh = self.bvh.as_ref()?;
        if !(ray.origin.is_finite() && ray.dir.is_finite()) || ray.dir == Vec3::ZERO {
            return None;
        }
        let tri_ray = TriangleRay::new(ray.origin, ray.dir);
        let n_spheres = self.spheres.len();
        let mut best_b = [0.0f32; 3];
        let mut hit = RayHit::none();
        let found = bvh.ray_traverse(Self::bvh_ray(ray, t_max), &mut hit, |r, id| {
            let ([p0, p1, p2], prim) = self.ordered[id];
            let prim = prim as usize;
            if prim < n_spheres {
                intersect_sphere(&self.spheres[prim], ray.origin, ray.dir, r.tmax).unwrap_or(f32::INFINITY)
            } else {
                match intersect_triangle(&tri_ray, r.tmax, p0, p1, p2) {
                    // obvhs keeps a hit only if it is strictly closer; a tie (a ray through a
                    // shared edge hits both triangles at the same t) must not overwrite the
                    // barycentrics of the triangle it keeps.
                    Some(h) if h.t < r.tmax => {
                        best_b = h.b;
                        h.t
                    }
                    _ => f32::INFINITY,
                }
            }
        });
        if !found {
            return None;
        }
        let prim = self.ordered[hit.primitive_id as usize].1;
        Some(self.hit_record(ray, prim, hit.t, best_b))
    }

    /// Whether anything lies in (0, `t_max`) along the ray (shadow rays; stops at the first hit).
    pub fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        let Some(bvh) = self.bvh.as_ref() else { return false };
        if !(ray.origin.is_finite() && ray.dir.is_finite()) || ray.dir == Vec3::ZERO {
            return false;
        }
        let tri_ray = TriangleRay::new(ray.origin, ray.dir);
        let n_spheres = self.spheres.len();
        !bvh.ray_traverse_miss(Self::bvh_ray(ray, t_max), |r, id| {
            let ([p0, p1, p2], prim) = self.ordered[id];
            let prim = prim as usize;
            if prim < n_spheres {
                intersect_sphere(&self.spheres[prim], ray.origin, ray.dir, r.tmax).unwrap_or(f32::INFINITY)
            } else {
                intersect_triangle(&tri_ray, r.tmax, p0, p1, p2).map_or(f32::INFINITY, |h| h.t)
            }
        })
    }

    fn hit_record(&self, ray: &Ray, prim: u32, t: f32, b: [f32; 3]) -> Hit {
        let n_spheres = self.spheres.len();
        if (prim as usize) < n_spheres {
            let s = &self.spheres[prim as usize];
            let (p, p_error, n) = sphere_hit_point(s, ray.origin, ray.dir, t);
            let phi = n.z.atan2(n.x);
            let uv = Vec2::new(
                (phi / std::f32::consts::TAU).rem_euclid(1.0),
                n.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI,
            );
            return Hit { t, p, p_error, n, ns: n, uv, primitive: prim, material: s.material() };
        }
        let index = prim as usize - n_spheres;
        let [p0, p1, p2] = self.triangles[index];
        let (mesh_index, tri_index) = self.triangle_source[index];
        let mesh = &self.meshes[mesh_index as usize];
        let p = b[0] * p0 + b[1] * p1 + b[2] * p2;
        let p_error = triangle_point_error(b, p0, p1, p2);
        // Degenerate triangles never hit, so the cross product is non-zero; normalize_or keeps
        // that an invariant rather than an assumption.
        let n = (p1 - p0).cross(p2 - p0).normalize_or(Vec3::Z);
        let tri = mesh.indices()[tri_index as usize];
        let ns = match mesh.normals() {
            Some(normals) => {
                let s =
                    b[0] * normals[tri[0] as usize] + b[1] * normals[tri[1] as usize] + b[2] * normals[tri[2] as usize];
                match s.try_normalize() {
                    Some(s) if s.dot(n) < 0.0 => -s,
                    Some(s) => s,
                    None => n,
                }
            }
            None => n,
        };
        let uv = match mesh.uvs() {
            Some(uvs) => b[0] * uvs[tri[0] as usize] + b[1] * uvs[tri[1] as usize] + b[2] * uvs[tri[2] as usize],
            None => Vec2::new(b[1], b[2]),
        };
        Hit { t, p, p_error, n, ns, uv, primitive: prim, material: mesh.material() }
    }

    /// Bounds of everything in the scene (padded).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }
    /// Number of primitives (spheres + triangles).
    pub fn primitive_count(&self) -> usize {
        self.spheres.len() + self.triangles.len()
    }
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }
    /// Number of spheres.
    pub fn sphere_count(&self) -> usize {
        self.spheres.len()
    }
    /// The spheres.
    pub fn spheres(&self) -> &[Sphere] {
        &self.spheres
    }
    /// The meshes.
    pub fn meshes(&self) -> &[Mesh] {
        &self.meshes
    }

    /// What a global primitive index refers to (spheres first, then every mesh's triangles).
    pub fn primitive(&self, id: u32) -> Primitive {
        let n = self.spheres.len();
        if (id as usize) < n {
            Primitive::Sphere { index: id }
        } else {
            let (mesh, triangle) = self.triangle_source[id as usize - n];
            Primitive::Triangle { mesh, triangle }
        }
    }

    /// Surface area of a primitive.
    pub fn primitive_area(&self, id: u32) -> f32 {
        let n = self.spheres.len();
        if (id as usize) < n {
            let r = self.spheres[id as usize].radius();
            4.0 * std::f32::consts::PI * r * r
        } else {
            let [p0, p1, p2] = self.triangles[id as usize - n];
            0.5 * (p1 - p0).cross(p2 - p0).length()
        }
    }

    /// Node count, build time and memory of the acceleration structure.
    pub fn stats(&self) -> BvhStats {
        let (nodes, indices) = self.bvh.as_ref().map_or((0, 0), |b| (b.nodes.len(), b.primitive_indices.len()));
        let bytes = nodes * std::mem::size_of::<obvhs::cwbvh::node::CwBvhNode>()
            + indices * 4
            + self.ordered.len() * std::mem::size_of::<([Vec3; 3], u32)>();
        let count = self.primitive_count().max(1);
        BvhStats {
            node_count: nodes,
            build_time: self.build_time,
            bytes,
            bytes_per_primitive: bytes as f64 / count as f64,
        }
    }
}
