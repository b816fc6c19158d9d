//! The acceleration structure: `sah.rs` builds a binary BVH over conservatively padded primitive
//! bounds, which we collapse into an eight-wide one and traverse ourselves (`wide.rs`), running
//! our watertight triangle test (four triangles of a leaf at once; a leaf has one or two such
//! packets) and stable sphere test at its leaves.

use std::time::{Duration, Instant};

use glam::{Affine3A, Mat3, Vec2, Vec3, Vec3A};
use obvhs::aabb::Aabb;
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::ray::{Hit, NO_PRIMITIVE, Ray, ShadowRay, gamma, offset_ray_origin};
use crate::sah;
use crate::shapes::{Instances, Mesh, Sphere, locate_triangle, transform_bounds};
use crate::simd::{Kernel, NodeTest, SimdLevel, Supported, dispatch};
use crate::sphere::{intersect_sphere, sphere_hit_point};
use crate::triangle::{
    NO_LANE, TriangleHit, TrianglePacket, TriangleRay, intersect_packet, intersect_triangle, triangle_point_error,
};
use crate::wide::{Collapsed, MAX_PRIMITIVES, PACKET, WideBvh, WideNode, packets_in};

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
    /// Bytes of BVH nodes and of the leaf-ordered primitive data (triangle vertices, index).
    pub bytes: usize,
    /// `bytes` per primitive (each placement of an instanced triangle counted).
    pub bytes_per_primitive: f64,
}

/// Relative padding of primitive bounds: 2⁻¹⁸ ≈ 3.8e-6 of the coordinates' magnitude, far
/// above the few ulps (≈ 6e-8 each) the slab test and the boxes' outward rounding can lose, far below any geometric feature that matters.
const PAD_RELATIVE: f32 = 1.0 / 262_144.0;

/// A primitive's bounds `lo`..`hi`, padded so that the BVH's float slab test can never cull a
/// ray that the exact intersection tests would hit (a Woop test alone still leaks through an
/// unpadded box test at shared edges and vertices).
fn padded(lo: Vec3, hi: Vec3) -> Aabb {
    let magnitude = lo.abs().max(hi.abs()).max_element() + (hi - lo).max_element();
    let pad = Vec3::splat(magnitude * PAD_RELATIVE + f32::MIN_POSITIVE);
    Aabb { min: Vec3A::from(lo - pad), max: Vec3A::from(hi + pad) }
}

/// Largest bound magnitude built as it is: 2⁴⁰ ≈ 1.1e12. The surface-area costs (the build's and the
/// collapse's, `wide.rs`) sum node areas in f32, which
/// overflows to ∞ once the sum passes 3.4e38 (≈ 2000 coincident triangles spanning 1e18, the
/// loaders' coordinate limit); every split then costs ∞ and none is chosen. (obvhs's CWBVH
/// conversion, which we used before, then read an invalid child slot; our collapse then builds
/// two-child wide nodes, several times the nodes of a sane tree.) Below 2⁴⁰ a node's half area is at most
/// 3·(2⁴¹)² ≈ 1.5e25, so the sum over the 2³⁰ nodes of the largest tree stays below 2e34.
const MAX_UNSCALED_MAGNITUDE: f32 = (1u64 << 40) as f32;

/// What a tree's leaves hold, which decides their cost and size.
#[derive(Debug, Clone, Copy)]
enum Leaves {
    /// Spheres and triangles (the first `n_spheres` primitives are spheres): a leaf of three to
    /// eight triangles is one or two [`TrianglePacket`]s, each tested at once; one of one or two
    /// triangles, or one sphere, is tested a primitive at a time.
    Primitives { n_spheres: u32 },
    /// Placements of the top level: one per leaf, each leaf a whole object traversal.
    Placements,
}

/// The eight-wide BVH over `bounds` (whose union is `lo`..`hi`) and its primitives in leaf order:
/// [`sah::build`] builds the binary tree (binned SAH, split costs in blocks of four triangles:
/// `docs/perf.md`; obvhs's PLOC and reinsertion before), which
/// [`WideBvh::from_bvh2`] collapses. Bounds beyond ±[`MAX_UNSCALED_MAGNITUDE`] are first scaled by
/// a power of two 2⁻ᵏ ≤ 1/(the largest magnitude), and the tree's boxes by 2ᵏ back. Scaling by a
/// power of two is exact (no bound reaches the subnormal range at these magnitudes unless it is
/// tiny, and each scaled bound is also rounded outward, so it still contains its primitive), so
/// the surface-area costs (the build's and the collapse's) make the same decisions on numbers that
/// cannot overflow.
///
/// The collapse's leaf costs, in units of a wide node's: a packet of n triangles costs
/// 0.3·(1 + 0.3·(n − 1)), four triangles not much more than one, since they are one four-lane
/// test (0.3 per triangle is Ylitie et al.'s constant, and obvhs's); smaller leaves 0.3·n. One `traversal_table` run
/// each (1 thread, AVX2, primary/incoherent/any-hit M rays/s): on the 100k terrain leaves costed
/// 0.3·n gave 6.24/3.33/3.60, 0.3·(1 + 0.3·(n − 1)) 6.25/3.59/3.99; on the 1M terrain
/// 0.3·(1 + 0.1·(n − 1)) gave 4.37/2.21/2.28 against 4.52/2.48/2.66. A leaf of five to eight is
/// two packets, costed as a full one plus one of n − 4 (costing it as one packet of n,
/// so that larger leaves are chosen more often, measured within ±1 % of that: terrain 2k and
/// 100k, `trace_exported`, 4 interleaved rounds). A placement is a leaf of its
/// own: each is a whole object's traversal (leaves of up to four cost the instanced row 10–20 %).
fn build_scaled(mut bounds: Vec<Aabb>, lo: Vec3, hi: Vec3, leaves: Leaves) -> Collapsed {
    let magnitude = lo.abs().max(hi.abs()).max_element();
    let scale = if magnitude > MAX_UNSCALED_MAGNITUDE {
        // 2ᵏ with k = ⌈log₂ magnitude⌉ (magnitude is finite: checked by the callers).
        let k = magnitude.log2().ceil() as i32;
        let down = 2f32.powi(-k);
        for b in &mut bounds {
            b.min = Vec3A::from((Vec3::from(b.min) * down).map(f32::next_down));
            b.max = Vec3A::from((Vec3::from(b.max) * down).map(f32::next_up));
        }
        2f32.powi(k)
    } else {
        1.0
    };
    // Split costs count triangles in packets, as the collapse will lay them out.
    let block = match leaves {
        Leaves::Primitives { .. } => PACKET,
        Leaves::Placements => 1,
    };
    let bvh2 = sah::build(&mut bounds, block);
    // The binary tree holds the boxes now: 32 bytes per primitive fewer at the collapse's peak.
    drop(bounds);
    match leaves {
        Leaves::Primitives { n_spheres } => WideBvh::from_bvh2(
            &bvh2,
            scale,
            |count| {
                let packet = |n: usize| 0.3 * (1.0 + 0.3 * (n as f32 - 1.0));
                match count {
                    _ if count < PACKED_FROM => 0.3 * count as f32,
                    ..=4 => packet(count),
                    _ => packet(4) + packet(count - 4),
                }
            },
            // A packet holds triangles only; a sphere is a leaf of its own.
            |prims| prims.len() == 1 || prims.iter().all(|&p| p >= n_spheres),
            PACKED_FROM,
        ),
        Leaves::Placements => WideBvh::from_bvh2(&bvh2, scale, |_| 0.3, |prims| prims.len() == 1, usize::MAX),
    }
}

/// Scenes of this many primitives or more build their bounds and leaves in parallel.
const PARALLEL_BUILD: usize = 1 << 14;

/// Leaves of this many triangles or more are four-lane packets; smaller ones (and spheres) are
/// tested one primitive at a time from [`Scene::singles`]: a packet is 160 bytes, a single 40.
/// Measured against packets for every leaf (`traversal_table`, 1 thread, AVX2, the same binary
/// with the threshold switched, 5 interleaved pairs; ratios of this layout to that one,
/// primary/incoherent/any-hit): terrain 100k 1.00/0.95/0.98, terrain 1M 1.03/1.08/1.08,
/// icosphere 1.3M 0.95/0.94/0.93, instanced 0.93/0.91/0.93, for 60 instead of 90 bytes per
/// triangle (the target bound is 64). Leaves of one or two triangles were two thirds of all
/// in the tree of packets only (1M terrain).
const PACKED_FROM: usize = 3;

/// Set in a hit's slot that is a packet lane (4 · packet + lane), clear in one of [`Scene::singles`].
const PACKED_SLOT: usize = 1 << (usize::BITS - 1);

/// All spheres and triangles of a scene with their BVH.
#[derive(Debug)]
pub struct Scene {
    spheres: Vec<Sphere>,
    meshes: Vec<Mesh>,
    /// Index of each mesh's first triangle among all triangles (prefix sums of the meshes'
    /// triangle counts), for [`locate_triangle`].
    triangle_offsets: Vec<usize>,
    triangle_count: usize,
    bvh: WideBvh,
    /// One packet per four triangles of a leaf of three to eight ([`PACKED_FROM`]), in the BVH's
    /// leaf order (such a leaf refers to its first packet): the triangles' vertices and global
    /// primitive indices. Traversal reads it in order, without an index indirection.
    packets: Vec<TrianglePacket>,
    /// The primitives of the smaller leaves (one or two triangles, or a sphere), in leaf order (a
    /// leaf refers to consecutive slots): triangle vertices (NaN for a sphere) and the global
    /// primitive index, tested one by one.
    singles: Vec<([Vec3; 3], u32)>,
    bounds: (Vec3, Vec3),
    build_time: Duration,
    /// Instruction-set level of the queries ([`SimdLevel::default_level`] at build), checked
    /// against the CPU once, here, rather than per ray.
    simd: Supported,
    /// Objects placed several times (two-level BVH), `None` when the scene has none: a scene
    /// without instances pays one pointer test per query.
    instances: Option<Box<InstanceSet>>,
    /// Whether hits on spheres carry their (φ/2π, θ/π) coordinates ([`Scene::set_sphere_uvs`]).
    sphere_uvs: bool,
}

/// The triangle a hit lies on ([`Scene::hit_triangle`]), for per-vertex data the hit record does not carry.
#[derive(Debug, Clone, Copy)]
pub struct HitTriangle<'a> {
    /// The mesh, in its own space (a placed object's space on a placed instance).
    pub mesh: &'a Mesh,
    /// The mesh's id ([`Scene::mesh_by_id`]).
    pub mesh_id: usize,
    /// The triangle's index in the mesh.
    pub triangle: usize,
    /// The placement's object-to-world and world-to-object transforms; `None` for world-space meshes.
    placement: Option<(&'a Affine3A, &'a Affine3A)>,
}

impl HitTriangle<'_> {
    /// A world-space point in the mesh's space.
    pub fn point_to_mesh(&self, p: Vec3) -> Vec3 {
        self.placement.map_or(p, |(_, to_object)| to_object.transform_point3(p))
    }

    /// A tangent vector of the mesh (a tangent, ∂p/∂u) in world space: by the object-to-world transform's
    /// linear part (not the inverse transpose, which is for normals).
    pub fn vector_to_world(&self, v: Vec3) -> Vec3 {
        self.placement.map_or(v, |(to_world, _)| to_world.transform_vector3(v))
    }

    /// Whether the placement mirrors (a negative determinant): a tangent frame's handedness then flips
    /// in world space, since cross(M a, M b) = det(M) M⁻ᵀ (a × b).
    pub fn mirrored(&self) -> bool {
        self.placement.is_some_and(|(to_world, _)| to_world.matrix3.determinant() < 0.0)
    }

    /// The triangle's three vertex indices in the mesh.
    pub fn vertices(&self) -> [usize; 3] {
        self.mesh.indices()[self.triangle].map(|i| i as usize)
    }

    /// The barycentric weights at the world-space point `p` on the triangle ([`barycentrics`], in the
    /// mesh's space); `None` for a degenerate triangle.
    pub fn barycentrics(&self, p: Vec3) -> Option<[f32; 3]> {
        barycentrics(self.vertices().map(|i| self.mesh.positions()[i]), self.point_to_mesh(p))
    }
}

/// The second level: one BVH per placed object (a [`Scene`] of its object-space meshes, the
/// bottom level) and a top-level BVH over the placements' world bounds. A ray reaching a
/// placement's leaf is transformed into object space and traced through the object's BVH with
/// the same watertight test; its hit is transformed back with a conservative error bound.
#[derive(Debug)]
struct InstanceSet {
    objects: Vec<Scene>,
    /// The mesh id ([`Scene::mesh_by_id`]) of each object's first mesh.
    mesh_offsets: Vec<usize>,
    /// Placements in the top-level BVH's leaf order.
    placements: Vec<Placement>,
    tlas: WideBvh,
    bounds: (Vec3, Vec3),
    /// Σ placements × triangles per placement.
    triangles: u64,
}

#[derive(Debug, Clone, Copy)]
struct Placement {
    object_to_world: Affine3A,
    world_to_object: Affine3A,
    /// Inverse transpose of the linear part: normals to world space.
    normal_to_world: Mat3,
    object: u32,
}

/// Bytes per placement: its three matrices, index and share of the top-level BVH.
const BYTES_PER_PLACEMENT: usize = std::mem::size_of::<Placement>() + std::mem::size_of::<WideNode>() / 2;

impl Scene {
    /// Build the BVH over every sphere and triangle (in parallel).
    pub fn build(spheres: Vec<Sphere>, meshes: Vec<Mesh>) -> Result<Self> {
        Self::build_with_instances(spheres, meshes, Vec::new())
    }

    /// Build the BVH over every sphere and world-space triangle, and a two-level BVH over the
    /// placed objects of `instances` (none: exactly [`Scene::build`]).
    pub fn build_with_instances(spheres: Vec<Sphere>, meshes: Vec<Mesh>, instances: Vec<Instances>) -> Result<Self> {
        let mut scene = Self::build_one_level(spheres, meshes)?;
        let instances: Vec<Instances> = instances.into_iter().filter(|i| i.triangle_count() > 0).collect();
        if instances.iter().any(|i| !i.transforms().is_empty()) {
            let start = Instant::now();
            let set = InstanceSet::build(instances, scene.meshes.len())?;
            let (lo, hi) = if scene.primitive_count() > 0 {
                (scene.bounds.0.min(set.bounds.0), scene.bounds.1.max(set.bounds.1))
            } else {
                set.bounds
            };
            scene.bounds = (lo, hi);
            scene.build_time += start.elapsed();
            scene.instances = Some(Box::new(set));
        }
        Ok(scene)
    }

    fn build_one_level(spheres: Vec<Sphere>, meshes: Vec<Mesh>) -> Result<Self> {
        let start = Instant::now();
        let mut triangle_offsets = Vec::with_capacity(meshes.len());
        let mut triangle_count = 0usize;
        for mesh in &meshes {
            triangle_offsets.push(triangle_count);
            triangle_count += mesh.indices().len();
        }
        let count = spheres.len() + triangle_count;
        if count > MAX_PRIMITIVES {
            return Err(Error::Invalid(format!("{count} primitives: at most {MAX_PRIMITIVES} are supported")));
        }
        // Triangle `t`'s vertices (among all triangles), read from its mesh where they are needed:
        // a flat copy of every triangle's vertices was 36 bytes a triangle at the build's peak.
        let triangle = |t: usize| {
            let (m, t) = locate_triangle(&triangle_offsets, t);
            let (mesh, p) = (&meshes[m], meshes[m].positions());
            mesh.indices()[t].map(|i| p[i as usize])
        };
        // Bounds, their union, and below the leaves' vertices, in parallel: each element is
        // computed alone, and min/max are exact in any order, so the results are the serial ones.
        let mut bounds_list = Vec::with_capacity(count);
        for s in &spheres {
            let r = Vec3::splat(s.radius());
            bounds_list.push(padded(s.center() - r, s.center() + r));
        }
        // Small scenes stay on this thread: starting rayon's pool costs milliseconds, more than
        // their whole build.
        let parallel = count >= PARALLEL_BUILD;
        for mesh in &meshes {
            let p = mesh.positions();
            let bound = |tri: &[u32; 3]| {
                let t = tri.map(|i| p[i as usize]);
                padded(t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]))
            };
            if parallel {
                bounds_list.par_extend(mesh.indices().par_iter().map(bound));
            } else {
                bounds_list.extend(mesh.indices().iter().map(bound));
            }
        }
        let empty = || (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        let add = |(lo, hi): (Vec3, Vec3), b: &Aabb| (lo.min(b.min.into()), hi.max(b.max.into()));
        let (lo, hi) = if parallel {
            bounds_list.par_iter().fold(empty, add).reduce(empty, |a, b| (a.0.min(b.0), a.1.max(b.1)))
        } else {
            bounds_list.iter().fold(empty(), add)
        };
        if !(lo.is_finite() && hi.is_finite()) && count > 0 {
            return Err(Error::Invalid("scene bounds are not finite".to_owned()));
        }
        let n_spheres = spheres.len();
        let bvh =
            (count > 0).then(|| build_scaled(bounds_list, lo, hi, Leaves::Primitives { n_spheres: n_spheres as u32 }));
        let bounds = if count > 0 { (lo, hi) } else { (Vec3::ZERO, Vec3::ZERO) };
        // (A sphere's "vertices" are NaN: only its index is read.)
        let vertices =
            |prim: u32| if (prim as usize) < n_spheres { [Vec3::NAN; 3] } else { triangle(prim as usize - n_spheres) };
        let single = |&prim: &u32| (vertices(prim), prim);
        let packet = |lanes: &[u32]| {
            TrianglePacket::new(lanes.iter().take_while(|&&p| p != NO_LANE).map(|&prim| (vertices(prim), prim)))
        };
        let (singles, packets) = match &bvh {
            None => (Vec::new(), Vec::new()),
            Some(b) if parallel => {
                (b.singles.par_iter().map(single).collect(), b.packed.par_chunks(4).map(packet).collect())
            }
            Some(b) => (b.singles.iter().map(single).collect(), b.packed.chunks(4).map(packet).collect()),
        };
        let bvh = bvh.map(|b| b.bvh).unwrap_or_default();
        Ok(Self {
            spheres,
            meshes,
            triangle_offsets,
            triangle_count,
            bvh,
            singles,
            packets,
            bounds,
            build_time: start.elapsed(),
            simd: Supported::default_level(),
            instances: None,
            sphere_uvs: true,
        })
    }

    /// The closest hit in (0, `t_max`).
    /// `#[inline]`: without it, once the shadow-ray queries were added, the paper's scene ran
    /// 0.9 % more instructions (callgrind), these calls no longer inlined into the integrators.
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        if !Self::valid(ray) {
            return None;
        }
        let found = dispatch(self.simd, Query::<true, false> { scene: self, ray, t_max, skip: NO_PRIMITIVE });
        if let Some(set) = &self.instances {
            let t_best = found.map_or(t_max, |f| f.1);
            if let Some(hit) = set.intersect(self.simd, ray, t_best) {
                return Some(hit);
            }
        }
        let (slot, t, b) = found?;
        Some(self.hit_record(ray, slot, t, b))
    }

    /// Whether anything lies in (0, `t_max`) along the ray (shadow rays; stops at the first hit).
    #[inline]
    pub fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        if !Self::valid(ray) {
            return false;
        }
        dispatch(self.simd, Query::<false, false> { scene: self, ray, t_max, skip: NO_PRIMITIVE }).is_some()
            || self.instances.as_ref().is_some_and(|set| set.occluded(self.simd, ray, t_max))
    }

    /// The shadow ray from `hit` to the point `target` (or along `wi` to infinity, without one)
    /// for light the shading normal sees but the flat triangle hides: below its plane on the side
    /// `side` (the geometric normal turned to the viewer) and above the shading normal's horizon,
    /// near the shadow terminator of a smooth-shaded low-poly mesh. From the hit point that ray
    /// would enter the solid (every facet's edge a step in the shadow); this one starts from the
    /// lifted point ([`Scene::lifted_point`]) and passes through its own triangle (Hanika 2021).
    /// `None` where there is no lift (spheres, meshes without normals, placed instances): the light
    /// is hidden there. Out of line: only directions in that wedge ask, and the plain rays
    /// ([`crate::spawn_ray_to`], [`crate::spawn_ray`]) serve all others (a lifted origin there
    /// could start inside another object meeting this one: a dark seam where parts intersect).
    #[inline(never)]
    pub fn terminator_shadow_ray(&self, hit: &Hit, side: Vec3, target: Option<Vec3>, wi: Vec3) -> Option<ShadowRay> {
        let lifted = self.lifted_point(hit, side)?;
        // Offset up, along `side`: near a vertex the lift is about 0, and an origin pushed towards
        // the light would start below the facet, inside the solid (its own triangle is skipped anyway).
        // The lift's rounding: a handful of operations whose results are the size of the lift
        // (those on full-size coordinates round within p_error).
        let error = hit.p_error + gamma(8) * (lifted - hit.p).abs();
        let origin = offset_ray_origin(lifted, error, side, side);
        let skip = hit.primitive;
        Some(match target {
            Some(q) => ShadowRay { ray: Ray { origin, dir: q - origin }, t_max: 1.0 - 1e-4, skip },
            None => ShadowRay { ray: Ray { origin, dir: wi }, t_max: f32::INFINITY, skip },
        })
    }

    /// Whether anything other than the primitive it leaves blocks a shadow ray from a lifted
    /// point ([`Scene::terminator_shadow_ray`]). Out of line, as an instantiation of the query of
    /// its own, so that the other queries do not carry the test.
    #[inline(never)]
    pub fn shadow_occluded(&self, shadow: &ShadowRay) -> bool {
        let (ray, t_max, skip) = (&shadow.ray, shadow.t_max, shadow.skip);
        Self::valid(ray)
            && (dispatch(self.simd, Query::<false, true> { scene: self, ray, t_max, skip }).is_some()
                || self.instances.as_ref().is_some_and(|set| set.occluded(self.simd, ray, t_max)))
    }

    /// The closest surface other than the primitive it leaves on a shadow ray from a lifted point
    /// ([`Scene::terminator_shadow_ray`]), for walking through cut-outs and transparent surfaces.
    /// (The body repeats [`Scene::intersect`]'s, as [`Scene::shadow_occluded`] repeats
    /// [`Scene::occluded`]'s: one generic body for both moved the compiler's inlining of the path
    /// tracer, +2.1 % instructions on the Cornell box and −2.1 % on the paper's scene, callgrind.)
    #[inline(never)]
    pub fn shadow_blocker(&self, shadow: &ShadowRay) -> Option<Hit> {
        let (ray, t_max, skip) = (&shadow.ray, shadow.t_max, shadow.skip);
        if !Self::valid(ray) {
            return None;
        }
        let found = dispatch(self.simd, Query::<true, true> { scene: self, ray, t_max, skip });
        if let Some(set) = &self.instances {
            let t_best = found.map_or(t_max, |f| f.1);
            if let Some(hit) = set.intersect(self.simd, ray, t_best) {
                return Some(hit);
            }
        }
        let (slot, t, b) = found?;
        Some(self.hit_record(ray, slot, t, b))
    }

    /// Whether hits on spheres carry surface coordinates in [`Hit::uv`] (the default), or
    /// `Vec2::ZERO`: a renderer whose materials read no texture turns them off, and sphere hits
    /// skip an `atan2` and an `acos` (1.5 % of the Cornell box's path-tracing time, perf).
    pub fn set_sphere_uvs(&mut self, on: bool) {
        self.sphere_uvs = on;
    }

    /// The instruction-set level this scene's queries run at.
    pub fn simd_level(&self) -> SimdLevel {
        self.simd.level()
    }

    /// Run this scene's queries at `level` (for measurement and tests: every level gives the
    /// same hits). Returns `false` and changes nothing if the CPU does not support it.
    pub fn set_simd_level(&mut self, level: SimdLevel) -> bool {
        match Supported::new(level) {
            Some(supported) => {
                self.simd = supported;
                true
            }
            None => false,
        }
    }

    /// Finite origin and direction, and a direction other than zero. (Six `is_finite`: ~45
    /// instructions, but independent integer compares. One sum of the six components times 0,
    /// a dozen instructions but five dependent additions, together with `TriangleRay::new`'s
    /// permutation as a `match`, measured ~2 % slower end to end on the Cornell box path tracer,
    /// whose rays arrive just computed: `docs/perf.md`.)
    fn valid(ray: &Ray) -> bool {
        ray.origin.is_finite() && ray.dir.is_finite() && ray.dir != Vec3::ZERO
    }

    /// The closest hit (`CLOSEST`) or the first hit found (any-hit, for shadow rays: stops
    /// there), as (leaf-order slot, t, barycentrics); with `SKIP`, primitive `skip` is passed
    /// through.
    #[inline(always)]
    fn query<const CLOSEST: bool, const SKIP: bool, N: NodeTest>(
        &self,
        node_test: N,
        ray: &Ray,
        tri_ray: &TriangleRay,
        t_max: f32,
        skip: u32,
    ) -> Option<(usize, f32, [f32; 3])> {
        let n_spheres = self.spheres.len() as u32;
        let mut best = None;
        self.bvh.traverse::<CLOSEST, N>(
            node_test,
            ray.origin.to_array(),
            ray.dir.to_array(),
            t_max,
            // Always inlined: left to itself the compiler kept the leaf test out of line, a
            // call per leaf (14 % of traversal time on the 100k-triangle terrain, perf).
            #[inline(always)]
            |start, count, mut t_max| {
                if count < PACKED_FROM {
                    for (slot, ([p0, p1, p2], prim)) in self.singles[start..start + count].iter().enumerate() {
                        // (Before the test: its result would be dropped.) Strictly closer only
                        // (both tests): a ray through a shared edge hits both triangles at the
                        // same t, and the barycentrics must stay those of the one kept.
                        if SKIP && *prim == skip {
                            continue;
                        }
                        let hit = if *prim < n_spheres {
                            intersect_sphere(&self.spheres[*prim as usize], ray.origin, ray.dir, t_max)
                                .map(|t| (t, [0.0; 3]))
                        } else {
                            intersect_triangle(tri_ray, t_max, *p0, *p1, *p2).map(|h| (h.t, h.b))
                        };
                        if let Some((t, b)) = hit {
                            best = Some((start + slot, t, b));
                            if !CLOSEST {
                                return None;
                            }
                            t_max = t;
                        }
                    }
                    return Some(t_max);
                }
                // (Triangles only: a sphere is a leaf of its own, among the singles.) One or two
                // packets; the second sees the first's hit as `t_max`, so only a strictly closer
                // hit replaces it, as between leaves.
                for packet in start..start + packets_in(count) {
                    if let Some((lane, TriangleHit { t, b })) =
                        intersect_packet::<CLOSEST>(tri_ray, t_max, &self.packets[packet], SKIP.then_some(skip))
                    {
                        best = Some((PACKED_SLOT | (4 * packet + lane), t, b));
                        if !CLOSEST {
                            return None;
                        }
                        t_max = t;
                    }
                }
                Some(t_max)
            },
        );
        best
    }

    /// (mesh, triangle within it) of the triangle with index `index` among all triangles.
    /// (`#[inline]`: it was a call per hit. A shortcut for scenes of one mesh saved a further 5
    /// instructions per ray, callgrind: not worth a special case.)
    #[inline]
    fn triangle_source(&self, index: usize) -> (usize, usize) {
        locate_triangle(&self.triangle_offsets, index)
    }

    /// The hit record of primitive slot `slot` (leaf order). Reads the vertices from the
    /// leaf data the test just used (in cache) and the mesh only for normals and UVs.
    /// Always inlined: called from two places since instancing, the compiler kept it out of line,
    /// which cost 0.8 % of a Cornell render (callgrind).
    #[inline(always)]
    fn hit_record(&self, ray: &Ray, slot: usize, t: f32, b: [f32; 3]) -> Hit {
        let ([p0, p1, p2], prim) = if slot & PACKED_SLOT != 0 {
            let (packet, lane) = ((slot & !PACKED_SLOT) / 4, slot % 4);
            (self.packets[packet].vertices(lane), self.packets[packet].prim[lane])
        } else {
            self.singles[slot]
        };
        let n_spheres = self.spheres.len();
        if (prim as usize) < n_spheres {
            let s = &self.spheres[prim as usize];
            let (p, p_error, n) = sphere_hit_point(s, ray.origin, ray.dir, t);
            let uv = if self.sphere_uvs {
                let phi = n.z.atan2(n.x);
                Vec2::new(
                    (phi / std::f32::consts::TAU).rem_euclid(1.0),
                    n.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI,
                )
            } else {
                Vec2::ZERO
            };
            return Hit {
                t,
                p,
                p_error,
                n,
                ns: n,
                uv,
                primitive: prim,
                placement: NO_PRIMITIVE,
                object_primitive: NO_PRIMITIVE,
                material: s.material(),
            };
        }
        let index = prim as usize - n_spheres;
        let (mesh_index, tri_index) = self.triangle_source(index);
        let mesh = &self.meshes[mesh_index];
        let p = b[0] * p0 + b[1] * p1 + b[2] * p2;
        let p_error = triangle_point_error(b, p0, p1, p2);
        // Degenerate triangles never hit, so the cross product is non-zero; normalize_or keeps
        // that an invariant rather than an assumption.
        let n = (p1 - p0).cross(p2 - p0).normalize_or(Vec3::Z);
        let tri = || mesh.indices()[tri_index];
        let ns = match mesh.normals() {
            Some(normals) => {
                let tri = tri();
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
            Some(uvs) => {
                let tri = tri();
                b[0] * uvs[tri[0] as usize] + b[1] * uvs[tri[1] as usize] + b[2] * uvs[tri[2] as usize]
            }
            None => Vec2::new(b[1], b[2]),
        };
        Hit {
            t,
            p,
            p_error,
            n,
            ns,
            uv,
            primitive: prim,
            placement: NO_PRIMITIVE,
            object_primitive: NO_PRIMITIVE,
            material: mesh.material(),
        }
    }

    /// Hanika's lift of a hit on a smooth-shaded triangle, seen from the side `side` of its plane
    /// ("Hacking the shadow terminator", Ray Tracing Gems II, 2021): the hit point projected onto
    /// each vertex's tangent plane where it lies below it (never down), the projections blended
    /// with its barycentrics; vertex normals are turned to `side` first. On a convex
    /// smooth-shaded patch this lands near the smooth surface the vertex normals describe; it is
    /// the hit point at the vertices and on flat or concave patches, and two triangles give the
    /// same point along their shared edge. `None` for spheres, meshes without normals and placed
    /// instances (whose hits have no primitive id to pass through).
    pub fn lifted_point(&self, hit: &Hit, side: Vec3) -> Option<Vec3> {
        // Not on placed instances: the shadow ray would have to skip its own triangle in that
        // placement only, which the skip (a global primitive id) cannot say.
        if hit.placement != NO_PRIMITIVE {
            return None;
        }
        let (mesh, triangle, b) = self.hit_barycentrics(hit)?;
        let mesh = &self.meshes[mesh];
        let normals = mesh.normals()?;
        let tri = mesh.indices()[triangle];
        let mut lift = Vec3::ZERO;
        for (k, &i) in tri.iter().enumerate() {
            let ni = normals[i as usize].normalize_or_zero();
            let ni = if ni.dot(side) < 0.0 { -ni } else { ni };
            lift += (b[k] * (hit.p - mesh.positions()[i as usize]).dot(ni).min(0.0)) * ni;
        }
        Some(hit.p - lift)
    }

    /// Bounds of everything in the scene (padded).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }
    /// Number of placements of objects placed several times (two-level BVH), 0 without.
    pub fn instance_count(&self) -> usize {
        self.instances.as_ref().map_or(0, |s| s.placements.len())
    }
    /// Triangles of all placements together (what a world-space copy of each would hold).
    pub fn instanced_triangle_count(&self) -> u64 {
        self.instances.as_ref().map_or(0, |s| s.triangles)
    }
    /// Number of primitives (spheres + triangles), placed instances excepted: the primitive ids
    /// of hits and lights. A hit on a placed instance has primitive id `u32::MAX`.
    pub fn primitive_count(&self) -> usize {
        self.spheres.len() + self.triangle_count
    }
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.triangle_count
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

    /// What a global primitive index refers to (spheres first, then every mesh's triangles
    /// in order). Panics if `id` ≥ [`Scene::primitive_count`] (ids come from hits).
    pub fn primitive(&self, id: u32) -> Primitive {
        let n = self.spheres.len();
        if (id as usize) < n {
            Primitive::Sphere { index: id }
        } else {
            assert!((id as usize) < self.primitive_count(), "primitive {id} of {}", self.primitive_count());
            let (mesh, triangle) = self.triangle_source(id as usize - n);
            Primitive::Triangle { mesh: mesh as u32, triangle: triangle as u32 }
        }
    }

    /// Surface area of a primitive. Panics if `id` ≥ [`Scene::primitive_count`].
    pub fn primitive_area(&self, id: u32) -> f32 {
        match self.primitive(id) {
            Primitive::Sphere { index } => {
                let r = self.spheres[index as usize].radius();
                4.0 * std::f32::consts::PI * r * r
            }
            Primitive::Triangle { mesh, triangle } => {
                let mesh = &self.meshes[mesh as usize];
                let [p0, p1, p2] = mesh.indices()[triangle as usize].map(|i| mesh.positions()[i as usize].as_dvec3());
                // In f64: with coordinates near 1e12 the f32 cross product's squared length
                // overflows (∞ area, then ∞/∞ = NaN in every area share; found by the glTF fuzz
                // target). Within the loaders' coordinate limit the area itself fits in f32.
                (0.5 * (p1 - p0).cross(p2 - p0).length()) as f32
            }
        }
    }

    /// The triangle a hit lies on: its mesh (in the mesh's own space, an object's for a placed
    /// instance), the mesh's id ([`Scene::mesh_by_id`]), the triangle's index and the placement's
    /// transforms. `None` for spheres and for hits not made by this scene.
    pub fn hit_triangle(&self, hit: &Hit) -> Option<HitTriangle<'_>> {
        if hit.placement != NO_PRIMITIVE {
            let set = self.instances.as_deref()?;
            let placement = set.placements.get(hit.placement as usize)?;
            let object = set.objects.get(placement.object as usize)?;
            let Primitive::Triangle { mesh, triangle } = object.checked_primitive(hit.object_primitive)? else {
                return None;
            };
            return Some(HitTriangle {
                mesh: object.meshes.get(mesh as usize)?,
                mesh_id: set.mesh_offsets.get(placement.object as usize)? + mesh as usize,
                triangle: triangle as usize,
                placement: Some((&placement.object_to_world, &placement.world_to_object)),
            });
        }
        let Primitive::Triangle { mesh, triangle } = self.checked_primitive(hit.primitive)? else { return None };
        Some(HitTriangle {
            mesh: self.meshes.get(mesh as usize)?,
            mesh_id: mesh as usize,
            triangle: triangle as usize,
            placement: None,
        })
    }

    /// [`Scene::primitive`], `None` past the primitives.
    fn checked_primitive(&self, id: u32) -> Option<Primitive> {
        ((id as usize) < self.primitive_count()).then(|| self.primitive(id))
    }

    /// A mesh by id: the world-space meshes first ([`Scene::meshes`], ids 0, 1, …), then each placed
    /// object's meshes, object by object (the ids [`Scene::hit_triangle`] gives).
    pub fn mesh_by_id(&self, id: usize) -> Option<&Mesh> {
        if let Some(mesh) = self.meshes.get(id) {
            return Some(mesh);
        }
        let set = self.instances.as_deref()?;
        // The last object whose first mesh id is at most `id`.
        let object = set.mesh_offsets.partition_point(|&first| first <= id).checked_sub(1)?;
        set.objects[object].meshes.get(id - set.mesh_offsets[object])
    }

    /// Each placed object's mesh with the world-space box around all its placements (for sizes an
    /// interpretation needs, such as the longest path through an absorbing object).
    pub fn placed_mesh_bounds(&self) -> Vec<(&Mesh, (Vec3, Vec3))> {
        let Some(set) = self.instances.as_deref() else { return Vec::new() };
        let mut out: Vec<_> = set
            .objects
            .iter()
            .flat_map(|o| o.meshes.iter())
            .map(|m| (m, (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY))))
            .collect();
        // Each mesh's object-space box once, then transformed per placement (not the vertices per placement).
        let boxes: Vec<Option<(Vec3, Vec3)>> = out
            .iter()
            .map(|(mesh, _)| {
                let &p0 = mesh.positions().first()?;
                Some(mesh.positions().iter().fold((p0, p0), |(lo, hi), &v| (lo.min(v), hi.max(v))))
            })
            .collect();
        for placement in &set.placements {
            let first = set.mesh_offsets[placement.object as usize] - self.meshes.len();
            let to_world = glam::Mat4::from(placement.object_to_world);
            for k in 0..set.objects[placement.object as usize].meshes.len() {
                let Some((lo, hi)) = boxes[first + k] else { continue };
                let (a, b) = crate::shapes::transform_bounds(to_world, lo, hi);
                let slot = &mut out[first + k].1;
                *slot = (slot.0.min(a), slot.1.max(b));
            }
        }
        out
    }

    /// Every mesh in id order ([`Scene::mesh_by_id`]).
    pub fn all_meshes(&self) -> impl Iterator<Item = &Mesh> {
        let placed = self.instances.iter().flat_map(|set| set.objects.iter().flat_map(|o| o.meshes.iter()));
        self.meshes.iter().chain(placed)
    }

    /// Where a hit lies on its mesh: the mesh's id ([`Scene::mesh_by_id`]), the triangle's index within
    /// it and the hit point's barycentric weights of the triangle's three vertices (non-negative,
    /// summing to 1). Recomputed from `hit.p` (taken to object space on a placed instance), which lies
    /// on the triangle up to rounding: the hit record does not carry them, so that queries on meshes
    /// without per-vertex data beyond normals and UVs pay nothing for them. `None` for spheres and
    /// degenerate triangles.
    pub fn hit_barycentrics(&self, hit: &Hit) -> Option<(usize, usize, [f32; 3])> {
        let at = self.hit_triangle(hit)?;
        Some((at.mesh_id, at.triangle, at.barycentrics(hit.p)?))
    }

    /// The mesh's vertex colour (linear RGBA) interpolated at `hit` as UVs are; `None` for spheres
    /// and meshes without vertex colours. The renderer interpolates the colours'
    /// spectra instead (`integrator`'s `VertexColors`); this is the RGBA reference its tests check.
    #[cfg(test)]
    pub(crate) fn vertex_color(&self, hit: &Hit) -> Option<glam::Vec4> {
        let (mesh, triangle, b) = self.hit_barycentrics(hit)?;
        self.mesh_by_id(mesh)?.color_at(triangle, b)
    }

    /// Node count, build time and memory of the acceleration structure.
    pub fn stats(&self) -> BvhStats {
        let mut nodes = self.bvh.node_count();
        let mut bytes = self.bvh.bytes()
            + self.packets.len() * std::mem::size_of::<TrianglePacket>()
            + self.singles.len() * std::mem::size_of::<([Vec3; 3], u32)>();
        if let Some(set) = &self.instances {
            nodes += set.tlas.node_count();
            bytes += set.placements.len() * BYTES_PER_PLACEMENT;
            for o in &set.objects {
                let s = o.stats();
                nodes += s.node_count;
                bytes += s.bytes;
            }
        }
        let count = (self.primitive_count() as u64 + self.instanced_triangle_count()).max(1);
        BvhStats {
            node_count: nodes,
            build_time: self.build_time,
            bytes,
            bytes_per_primitive: bytes as f64 / count as f64,
        }
    }
}

/// A closest-hit (`CLOSEST`) or any-hit query as a [`Kernel`]: the triangle test's axis
/// permutation is fixed per ray, so it is dispatched once here.
struct Query<'a, const CLOSEST: bool, const SKIP: bool> {
    scene: &'a Scene,
    ray: &'a Ray,
    t_max: f32,
    /// A primitive the query passes through (with `SKIP`).
    skip: u32,
}

impl<const CLOSEST: bool, const SKIP: bool> Kernel for Query<'_, CLOSEST, SKIP> {
    type Output = Option<(usize, f32, [f32; 3])>;
    #[inline(always)]
    fn run<N: NodeTest>(self, node_test: N) -> Self::Output {
        let Self { scene, ray, t_max, skip } = self;
        scene.query::<CLOSEST, SKIP, N>(node_test, ray, &TriangleRay::new(ray.origin, ray.dir), t_max, skip)
    }
}

impl InstanceSet {
    /// The set of `instances`, whose meshes' ids ([`Scene::mesh_by_id`]) start at `first_mesh_id`.
    fn build(instances: Vec<Instances>, first_mesh_id: usize) -> Result<Self> {
        let mut objects = Vec::with_capacity(instances.len());
        let mut placements = Vec::new();
        let mut bounds_list = Vec::new();
        let mut triangles = 0u64;
        for instance in instances {
            let Some((lo, hi)) = instance.object_bounds() else { continue };
            let per = instance.triangle_count() as u64;
            for &m in instance.transforms() {
                let (a, b) = transform_bounds(m, lo, hi);
                bounds_list.push(padded(a, b));
                let linear = Mat3::from_mat4(m);
                placements.push(Placement {
                    object_to_world: Affine3A::from_mat4(m),
                    world_to_object: Affine3A::from_mat4(m.inverse()),
                    normal_to_world: linear.inverse().transpose(),
                    object: objects.len() as u32,
                });
                triangles += per;
            }
            objects.push(Scene::build_one_level(Vec::new(), instance.meshes().to_vec())?);
        }
        if placements.len() > MAX_PRIMITIVES {
            return Err(Error::Invalid(format!(
                "{} placements: at most {MAX_PRIMITIVES} are supported",
                placements.len()
            )));
        }
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for b in &bounds_list {
            lo = lo.min(b.min.into());
            hi = hi.max(b.max.into());
        }
        if !(lo.is_finite() && hi.is_finite()) {
            return Err(Error::Invalid("instance bounds are not finite".to_owned()));
        }
        let Collapsed { bvh: tlas, singles: order, .. } = build_scaled(bounds_list, lo, hi, Leaves::Placements);
        let placements = order.iter().map(|&i| placements[i as usize]).collect();
        let mesh_offsets = objects
            .iter()
            .scan(first_mesh_id, |next, o| {
                let first = *next;
                *next += o.meshes.len();
                Some(first)
            })
            .collect();
        Ok(Self { objects, mesh_offsets, placements, tlas, bounds: (lo, hi), triangles })
    }

    /// The closest hit on a placement strictly before `t_max`, in world space. Kept out of line
    /// (as `occluded`), so that scenes without instances do not carry its code in their queries.
    #[inline(never)]
    fn intersect(&self, simd: Supported, ray: &Ray, t_max: f32) -> Option<Hit> {
        let (index, object_ray, dt, slot, t, b) = dispatch(simd, TopQuery::<true> { set: self, ray, t_max })?;
        let placement = &self.placements[index];
        let local = self.objects[placement.object as usize].hit_record(&object_ray, slot, t, b);
        Some(placement.hit_to_world(local, t + dt, index as u32))
    }

    #[inline(never)]
    fn occluded(&self, simd: Supported, ray: &Ray, t_max: f32) -> bool {
        dispatch(simd, TopQuery::<false> { set: self, ray, t_max }).is_some()
    }
}

impl Placement {
    /// The ray in object space, its origin moved forward past its own rounding error (pbrt-v4
    /// `Transform::ApplyInverse(Ray, tMax)`), and the distance `dt` it moved (in units of the
    /// direction, which is not renormalised, so t means the same in both spaces).
    #[inline(always)]
    fn ray_to_object(&self, ray: &Ray) -> (Ray, f32) {
        let m = &self.world_to_object;
        let origin = m.transform_point3(ray.origin);
        let dir = m.transform_vector3(ray.dir);
        // |M| |o| + |translation|, each coordinate within γ(3) of exact (pbrt-v4 `Transform`
        // applied to a point with error).
        let error = gamma(3) * (abs_linear(m) * ray.origin.abs() + Vec3::from(m.translation.abs()));
        let length2 = dir.length_squared();
        let dt = if length2 > 0.0 { dir.abs().dot(error) / length2 } else { 0.0 };
        (Ray { origin: origin + dir * dt, dir }, dt)
    }

    /// An object-space hit in world space: the point and its error bound by the object-to-world
    /// transform (pbrt-v4 `Transform::ApplyError`: the transformed error box |M|·e(1 + γ(3)) plus
    /// γ(3)(|M||p| + |translation|) for the transform's own rounding), normals by the inverse
    /// transpose. The primitive id is `u32::MAX` (placed instances are not light sources); the placement
    /// (`index`) and the object's primitive id say where the hit lies.
    #[inline]
    fn hit_to_world(&self, local: Hit, t: f32, index: u32) -> Hit {
        let m = &self.object_to_world;
        let abs = abs_linear(m);
        let p = m.transform_point3(local.p);
        let p_error = (1.0 + gamma(3)) * (abs * local.p_error)
            + gamma(3) * (abs * local.p.abs() + Vec3::from(m.translation.abs()));
        let n = (self.normal_to_world * local.n).normalize_or(Vec3::Z);
        let ns = match (self.normal_to_world * local.ns).try_normalize() {
            Some(s) if s.dot(n) < 0.0 => -s,
            Some(s) => s,
            None => n,
        };
        Hit {
            t,
            p,
            p_error,
            n,
            ns,
            uv: local.uv,
            primitive: NO_PRIMITIVE,
            placement: index,
            object_primitive: local.primitive,
            material: local.material,
        }
    }
}

/// The linear part of `m` with every entry's magnitude: |M|, the bound of a transform's rounding.
#[inline(always)]
fn abs_linear(m: &Affine3A) -> Mat3 {
    let a = &m.matrix3;
    Mat3::from_cols(Vec3::from(a.x_axis.abs()), Vec3::from(a.y_axis.abs()), Vec3::from(a.z_axis.abs()))
}

/// The top-level query as a [`Kernel`]: the world ray through the placements' BVH; at each
/// placement the object-space ray through the object's BVH, its triangle-test permutation
/// dispatched per placement (the transform changes the dominant axis).
struct TopQuery<'a, const CLOSEST: bool> {
    set: &'a InstanceSet,
    ray: &'a Ray,
    t_max: f32,
}

impl<const CLOSEST: bool> Kernel for TopQuery<'_, CLOSEST> {
    /// (placement slot, object ray, its origin shift dt, object's primitive slot, t, barycentrics).
    type Output = Option<(usize, Ray, f32, usize, f32, [f32; 3])>;
    #[inline(always)]
    fn run<N: NodeTest>(self, node_test: N) -> Self::Output {
        let Self { set, ray, t_max } = self;
        let mut best = None;
        set.tlas.traverse::<CLOSEST, N>(
            node_test,
            ray.origin.to_array(),
            ray.dir.to_array(),
            t_max,
            // Always inlined, like `Scene::query`'s: the object-level traversal runs in here,
            // and out of line (no target features) its AVX2 node test became ~20 intrinsic calls
            // per node (instanced scenes 2.8× slower at AVX2; found by review).
            #[inline(always)]
            |start, count, mut t_max| {
                for (k, placement) in set.placements[start..start + count].iter().enumerate() {
                    let (object_ray, dt) = placement.ray_to_object(ray);
                    let limit = t_max - dt;
                    if !(limit > 0.0) || !Scene::valid(&object_ray) {
                        continue;
                    }
                    let object = &set.objects[placement.object as usize];
                    let tri_ray = TriangleRay::new(object_ray.origin, object_ray.dir);
                    let found =
                        object.query::<CLOSEST, false, N>(node_test, &object_ray, &tri_ray, limit, NO_PRIMITIVE);
                    if let Some((slot, t, b)) = found {
                        // Strictly closer than the best so far, as within one BVH.
                        if t + dt < t_max {
                            best = Some((start + k, object_ray, dt, slot, t, b));
                            if !CLOSEST {
                                return None;
                            }
                            t_max = t + dt;
                        }
                    }
                }
                Some(t_max)
            },
        );
        best
    }
}

/// The barycentric weights of `p`, a point on the triangle `v` up to rounding (its projection onto the
/// triangle's plane otherwise), each ≥ 0 and summing to 1: a point rounded just outside gives a weight of
/// about −1e-7, clamped, so that an interpolated value stays within its vertices' range. `None` for a
/// triangle whose Gram determinant is 0 or not finite (a sliver can cancel or underflow to 0 though its
/// area is positive).
pub fn barycentrics(v: [Vec3; 3], p: Vec3) -> Option<[f32; 3]> {
    let (e0, e1, e2) = (v[1] - v[0], v[2] - v[0], p - v[0]);
    let (d00, d01, d11) = (e0.dot(e0), e0.dot(e1), e1.dot(e1));
    let (d20, d21) = (e2.dot(e0), e2.dot(e1));
    let denom = d00 * d11 - d01 * d01;
    if denom == 0.0 || !denom.is_finite() {
        return None;
    }
    let b1 = (d11 * d20 - d01 * d21) / denom;
    let b2 = (d00 * d21 - d01 * d20) / denom;
    let b = [1.0 - b1 - b2, b1, b2].map(|w| w.max(0.0));
    let sum = b[0] + b[1] + b[2];
    (sum > 0.0 && sum.is_finite()).then(|| b.map(|w| w / sum))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The primitives of a leaf (start, count) of the scene's tree.
    fn leaf_primitives(scene: &Scene, (start, count): (usize, usize)) -> Vec<u32> {
        if count < PACKED_FROM {
            scene.singles[start..start + count].iter().map(|s| s.1).collect()
        } else {
            packet_lanes(scene, (start, count))[..count].to_vec()
        }
    }

    /// The lanes of a packed leaf's packets, in order.
    fn packet_lanes(scene: &Scene, (start, count): (usize, usize)) -> Vec<u32> {
        scene.packets[start..start + packets_in(count)].iter().flat_map(|p| p.prim).collect()
    }

    /// Every primitive is in exactly one leaf of the tree.
    fn assert_each_primitive_once(scene: &Scene) {
        let mut prims: Vec<u32> = scene.bvh.leaves().into_iter().flat_map(|l| leaf_primitives(scene, l)).collect();
        prims.sort_unstable();
        let expected: Vec<u32> = (0..scene.primitive_count() as u32).collect();
        assert_eq!(prims, expected, "leaf primitives");
    }

    /// 2000 triangles sharing one box of half-width `big`, as a scene.
    fn fan(big: f32) -> Scene {
        let n = 2000u32;
        let positions: Vec<Vec3> = (0..n)
            .flat_map(|i| {
                let x = -big + big * (i as f32 / n as f32);
                [Vec3::new(-big, -big, 0.0), Vec3::new(big, -big, 0.0), Vec3::new(x, big, 0.0)]
            })
            .collect();
        let indices = (0..n).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        Scene::build(Vec::new(), vec![Mesh::new(positions, None, None, indices, None).unwrap()]).unwrap()
    }

    #[test]
    fn leaves_of_three_to_eight_triangles_are_packets_and_spheres_stand_alone() {
        // Thirty small spheres along the x axis among 400 small triangles along the same line, so
        // that the binary tree mixes the two kinds in small subtrees.
        let spheres: Vec<Sphere> =
            (0..30).map(|i| Sphere::new(Vec3::new(i as f32 * 0.1, 0.0, 0.0), 0.03, None).unwrap()).collect();
        let positions: Vec<Vec3> = (0..400)
            .flat_map(|i| {
                let x = i as f32 * 0.0075;
                [Vec3::new(x, -0.02, 0.0), Vec3::new(x + 0.005, -0.02, 0.0), Vec3::new(x, 0.02, 0.01)]
            })
            .collect();
        let indices = (0..400).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        let mesh = Mesh::new(positions, None, None, indices, None).unwrap();
        let scene = Scene::build(spheres, vec![mesh]).unwrap();
        assert_each_primitive_once(&scene);
        let leaves = scene.bvh.leaves();
        let packed: Vec<_> = leaves.iter().filter(|l| l.1 >= PACKED_FROM).collect();
        let packets: usize = packed.iter().map(|l| packets_in(l.1)).sum();
        assert_eq!(packets, scene.packets.len(), "one packet per four triangles of a packed leaf");
        assert!(packed.iter().any(|l| l.1 > 4), "no leaf of two packets: {packed:?}");
        assert_eq!(leaves.iter().filter(|l| l.1 < PACKED_FROM).map(|l| l.1).sum::<usize>(), scene.singles.len());
        let (mut sphere_leaves, mut packed_triangles) = (0, 0);
        for &leaf in &leaves {
            let prims = leaf_primitives(&scene, leaf);
            assert!((1..=8).contains(&prims.len()));
            if prims.iter().any(|&p| p < 30) {
                assert_eq!(prims.len(), 1, "a sphere shares a leaf: {prims:?}");
                sphere_leaves += 1;
            }
        }
        for &&(packet, count) in &packed {
            let lanes = packet_lanes(&scene, (packet, count));
            assert!(lanes[..count].iter().all(|&p| p >= 30));
            packed_triangles += count;
            for (lane, &prim) in lanes.iter().enumerate().skip(count) {
                assert_eq!(prim, NO_LANE);
                assert!(scene.packets[packet + lane / 4].vertices(lane % 4).iter().all(|v| v.is_nan()));
            }
        }
        assert_eq!(sphere_leaves, 30);
        assert!(packed_triangles > 100, "{packed_triangles} triangles in packets");
        // Every triangle of a leaf's second packet is found, closest and any-hit, by a ray at
        // its centroid along its plane's normal (all 400 triangles lie in one plane, side by side).
        let mut second = 0;
        for &&(packet, count) in packed.iter().filter(|l| l.1 > 4) {
            for lane in 0..count - 4 {
                let pk = &scene.packets[packet + 1];
                let [p0, p1, p2] = pk.vertices(lane);
                let n = (p1 - p0).cross(p2 - p0).normalize();
                let ray = Ray { origin: (p0 + p1 + p2) / 3.0 + 1e-3 * n, dir: -n };
                let hit = scene.intersect(&ray, f32::INFINITY).expect("the triangle");
                assert_eq!(hit.primitive, pk.prim[lane]);
                assert!(scene.occluded(&ray, f32::INFINITY));
                second += 1;
            }
        }
        assert!(second > 0);
    }

    #[test]
    fn coincident_boxes_near_the_coordinate_limit_build_the_tree_they_build_near_the_origin() {
        // At 2⁵⁹ ≈ 5.8e17 (within the loaders' limit of 1e18) summed SAH costs overflow to ∞
        // unscaled: obvhs's CWBVH conversion then chose no split and built 1499 nodes (binary,
        // split slots invalid: a debug assertion in obvhs) instead of the 286 of the same
        // triangles at ½ (286 with today's collapse too).
        let (near, far) = (fan(0.5), fan((1u64 << 59) as f32));
        assert_each_primitive_once(&far);
        assert_eq!(far.bvh.node_count(), near.bvh.node_count());
        assert_eq!(far.bvh.leaves(), near.bvh.leaves());
        assert!(near.bvh.node_count() < 2000 / 4, "{} nodes", near.bvh.node_count());
    }

    #[test]
    fn scaled_builds_give_the_tree_of_the_unscaled_scene_times_the_scale() {
        // The same random triangles at 1 and at 2⁵⁰ (beyond MAX_UNSCALED_MAGNITUDE): a power-of-two
        // scale is exact, so the trees decide alike and every decoded box scales by 2⁵⁰, up to the
        // one ulp outward rounding of the scaled path.
        let mut uniform = crate::test_uniform(12345);
        let mut next = || uniform() - 0.5;
        let positions: Vec<Vec3> = (0..600).map(|_| Vec3::new(next(), next(), next())).collect();
        let indices: Vec<[u32; 3]> = (0..200).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        let s = (1u64 << 50) as f32;
        let small = Mesh::new(positions.clone(), None, None, indices.clone(), None).unwrap();
        let large = Mesh::new(positions.iter().map(|p| *p * s).collect(), None, None, indices, None).unwrap();
        let (a, b) = (Scene::build(Vec::new(), vec![small]).unwrap(), Scene::build(Vec::new(), vec![large]).unwrap());
        assert_each_primitive_once(&b);
        assert_eq!(a.bvh.leaves(), b.bvh.leaves(), "same leaves in the same order");
        assert_eq!(a.bvh.node_count(), b.bvh.node_count());
    }

    #[test]
    fn rays_are_valid_exactly_when_finite_with_a_direction_and_others_miss() {
        // `valid` itself, and what the queries make of a ray it refuses: a miss (not a panic), on
        // a sphere and a quad the ray would otherwise hit, for every component made NaN or ±∞
        // alone, and for no direction.
        let quad = [[-9.0, -9.0], [9.0, -9.0], [9.0, 9.0], [-9.0, 9.0]].map(|[x, y]| Vec3::new(x, y, 3.0));
        let quad = Mesh::new(quad.to_vec(), None, None, vec![[0, 1, 2], [0, 2, 3]], None).unwrap();
        let scene = Scene::build(vec![Sphere::new(Vec3::ZERO, 1.0, None).unwrap()], vec![quad]).unwrap();
        let good = Ray { origin: Vec3::new(0.1, -0.2, -5.0), dir: Vec3::new(-0.0, 0.01, 1.0) };
        assert!(Scene::valid(&good));
        assert!(scene.intersect(&good, f32::INFINITY).is_some() && scene.occluded(&good, f32::INFINITY));
        let extreme =
            Ray { origin: Vec3::new(f32::MAX, -0.0, f32::MIN_POSITIVE), dir: Vec3::new(-f32::MAX, 0.0, 1e-30) };
        assert!(Scene::valid(&extreme));
        let mut refused = vec![Ray { dir: Vec3::new(0.0, -0.0, 0.0), ..good }];
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            for k in 0..6 {
                let mut ray = good;
                if k < 3 {
                    ray.origin[k] = bad
                } else {
                    ray.dir[k - 3] = bad
                }
                refused.push(ray);
            }
        }
        for ray in refused {
            assert!(!Scene::valid(&ray), "{ray:?}");
            assert!(scene.intersect(&ray, f32::INFINITY).is_none() && !scene.occluded(&ray, f32::INFINITY), "{ray:?}");
        }
    }

    #[test]
    fn sphere_hits_carry_surface_coordinates_unless_turned_off() {
        // A ray down the unit sphere's +x side at height y = 0.5 meets n = (√0.75, 0.5, 0):
        // φ = atan2(0, √0.75) = 0, θ = acos(0.5) = π/3, so uv = (0, 1/3).
        let mut scene = Scene::build(vec![Sphere::new(Vec3::ZERO, 1.0, None).unwrap()], Vec::new()).unwrap();
        let ray = Ray { origin: Vec3::new(5.0, 0.5, 0.0), dir: -Vec3::X };
        let on = scene.intersect(&ray, f32::INFINITY).unwrap();
        assert!((on.uv - Vec2::new(0.0, 1.0 / 3.0)).abs().max_element() < 1e-6, "{}", on.uv);
        scene.set_sphere_uvs(false);
        let off = scene.intersect(&ray, f32::INFINITY).unwrap();
        assert_eq!(off.uv, Vec2::ZERO);
        // Nothing else about the hit changes.
        assert_eq!((off.t, off.p, off.n, off.primitive), (on.t, on.p, on.n, on.primitive));
    }

    #[test]
    fn vertex_colour_at_a_hit_is_the_barycentric_mix_of_its_vertices() {
        // The unit right triangle in z = 0: a point (x, y) on it has barycentrics (1 − x − y, x, y),
        // the weights of vertices 0, 1, 2. Vertex 1 is blue, the others red, so at (0.3, 0.2) the
        // colour is 0.7 red + 0.3 blue.
        let (red, blue) = (glam::Vec4::new(1.0, 0.0, 0.0, 1.0), glam::Vec4::new(0.0, 0.0, 1.0, 0.5));
        let positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        let mesh = Mesh::new(positions.clone(), None, None, vec![[0, 1, 2]], None).unwrap();
        let colored = mesh.clone().with_colors(vec![red, blue, red]).unwrap();
        let scene =
            Scene::build(vec![Sphere::new(Vec3::new(5.0, 0.0, 0.0), 1.0, None).unwrap()], vec![colored]).unwrap();
        let down = |x: f32, y: f32| Ray { origin: Vec3::new(x, y, 1.0), dir: -Vec3::Z };
        let hit = scene.intersect(&down(0.3, 0.2), f32::INFINITY).expect("the triangle");
        let (_, _, b) = scene.hit_barycentrics(&hit).unwrap();
        for (got, want) in b.iter().zip([0.5, 0.3, 0.2]) {
            assert!((got - want).abs() < 1e-6, "barycentrics {b:?}");
        }
        let c = scene.vertex_color(&hit).unwrap();
        let want = glam::Vec4::new(0.7, 0.0, 0.3, 0.85);
        assert!((c - want).abs().max_element() < 1e-6, "{c} (want {want})");
        // At a vertex its own colour, whatever the rounding of the hit point.
        let at_blue = scene.intersect(&down(1.0 - 1e-6, 0.0), f32::INFINITY).unwrap();
        assert!((scene.vertex_color(&at_blue).unwrap() - blue).abs().max_element() < 1e-5);
        // Spheres and meshes without colours have none.
        let sphere = scene.intersect(&Ray { origin: Vec3::new(5.0, 0.0, 3.0), dir: -Vec3::Z }, f32::INFINITY);
        assert_eq!(sphere.map(|h| scene.vertex_color(&h)), Some(None));
        let plain = Scene::build(Vec::new(), vec![mesh]).unwrap();
        let hit = plain.intersect(&down(0.3, 0.2), f32::INFINITY).unwrap();
        assert!(plain.hit_barycentrics(&hit).is_some() && plain.vertex_color(&hit).is_none());
    }

    #[test]
    fn colours_follow_the_triangles_kept_and_refuse_a_wrong_count() {
        let positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::Y];
        let mesh = Mesh::new(positions, None, None, vec![[0, 1, 2], [0, 2, 3]], None).unwrap();
        assert!(mesh.clone().with_colors(vec![glam::Vec4::ONE; 3]).is_err());
        assert!(mesh.clone().with_colors(vec![glam::Vec4::splat(f32::NAN); 4]).is_err());
        let colors: Vec<glam::Vec4> = (0..4).map(|i| glam::Vec4::splat(i as f32 / 4.0)).collect();
        let colored = mesh.with_colors(colors.clone()).unwrap();
        // The second triangle is degenerate (vertices 2 and 3 coincide): the build drops it, the colours stay.
        let scene = Scene::build(Vec::new(), vec![colored]).unwrap();
        assert_eq!(scene.meshes()[0].colors(), Some(&colors[..]));
    }
}
