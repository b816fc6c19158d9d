//! Hard cases for intersection and the BVH: watertightness, self-intersection, axis-parallel
//! and degenerate inputs, scale invariance, and the BVH against brute force.

use geometry::{Hit, Mesh, Primitive, Ray, Scene, SimdLevel, Sphere, spawn_ray};
use glam::Vec3;
use proptest::prelude::*;

use crate::common::{Xorshift, icosphere};

/// Uniform unit vectors from the shared xorshift stream (a test-only extra).
trait UnitVector {
    fn unit_vector(&mut self) -> Vec3;
}

impl UnitVector for Xorshift {
    fn unit_vector(&mut self) -> Vec3 {
        let z = 2.0 * self.next() - 1.0;
        let phi = std::f32::consts::TAU * self.next();
        let s = (1.0 - z * z).max(0.0).sqrt();
        Vec3::new(s * phi.cos(), s * phi.sin(), z)
    }
}

#[test]
fn rays_through_vertices_and_edges_of_a_closed_mesh_never_leak() {
    // Every vertex and every edge point of a closed icosphere, aimed at from many directions
    // outside it and from its centre: each ray must hit the mesh (a miss is a crack).
    // At the scene's default level only: `every_simd_level_gives_bit_identical_hits` shows
    // that every level returns the same hits bit for bit.
    let mesh = icosphere(4, Vec3::new(0.3, -0.2, 0.1), 1.0);
    let scene = Scene::build(Vec::new(), vec![mesh.clone()]).unwrap();
    let p = mesh.positions();
    let mut targets: Vec<Vec3> = p.to_vec();
    for tri in mesh.indices() {
        for (a, b) in [(tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])] {
            let (a, b) = (p[a as usize], p[b as usize]);
            targets.extend([0.5, 0.25, 1.0 / 3.0].map(|s| a + (b - a) * s));
        }
    }
    let mut rng = Xorshift(0x9E37_79B9_7F4A_7C15);
    let (mut rays, mut leaks) = (0u64, 0u64);
    let center = Vec3::new(0.3, -0.2, 0.1);
    for &target in &targets {
        // From the centre (inside) and from 20 random points outside that see the target from
        // the front: a ray aimed at a point on the silhouette may legitimately pass outside
        // the mesh once its direction is rounded to f32, which is a miss, not a leak.
        let normal = (target - center).normalize();
        let mut origins = vec![center];
        while origins.len() < 21 {
            let origin = center + rng.unit_vector() * (3.0 + 10.0 * rng.next());
            if (origin - target).normalize().dot(normal) > 0.05 {
                origins.push(origin);
            }
        }
        for origin in origins {
            rays += 1;
            if scene.intersect(&Ray { origin, dir: target - origin }, f32::INFINITY).is_none() {
                leaks += 1;
            }
        }
    }
    assert!(rays >= 1_000_000, "{rays} rays");
    assert_eq!(leaks, 0, "{leaks} of {rays} rays at {:?} leaked through the closed mesh", scene.simd_level());
}

#[test]
fn grazing_spawned_rays_never_rehit_their_surface() {
    // Leave a convex surface (sphere, icosphere) almost tangentially on the outside: there is
    // nothing to hit, so any hit is a self-intersection.
    let sphere = Scene::build(vec![Sphere::new(Vec3::new(1e3, 0.0, 0.0), 2.5, None).unwrap()], Vec::new()).unwrap();
    let mesh = Scene::build(Vec::new(), vec![icosphere(3, Vec3::ZERO, 1.0)]).unwrap();
    let mut rng = Xorshift(12345);
    for (scene, center, r) in [(&sphere, Vec3::new(1e3, 0.0, 0.0), 2.5f32), (&mesh, Vec3::ZERO, 1.0)] {
        for _ in 0..20_000 {
            let dir_in = rng.unit_vector();
            let hit: Hit =
                scene.intersect(&Ray { origin: center + dir_in * (4.0 * r), dir: -dir_in }, f32::INFINITY).unwrap();
            // A direction whose cosine with the normal is tiny but positive.
            let tangent = hit.n.any_orthonormal_vector();
            let cos = 10f32.powf(-1.0 - 5.0 * rng.next());
            let dir = (tangent + hit.n * cos).normalize();
            let again = scene.intersect(&spawn_ray(&hit, dir), f32::INFINITY);
            assert!(again.is_none(), "re-hit at t = {:?} (cos {cos})", again.map(|h| h.t));
            // And straight back inside: the far side, never the starting point.
            let inside = scene.intersect(&spawn_ray(&hit, -hit.n), f32::INFINITY);
            let inside = inside.unwrap_or_else(|| panic!("inward ray from {} (n {}) found no far side", hit.p, hit.n));
            assert!(inside.t > r, "inside ray hit at t = {}", inside.t);
        }
    }
}

#[test]
fn axis_parallel_rays_hit_where_expected() {
    // A cube [−1, 1]³ as 12 triangles; rays along ±x, ±y, ±z (zero direction components).
    let p: Vec<Vec3> = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { -1.0 } else { 1.0 },
            )
        })
        .collect();
    let f = vec![
        [0, 2, 1],
        [1, 2, 3],
        [4, 5, 6],
        [5, 7, 6],
        [0, 1, 4],
        [1, 5, 4],
        [2, 6, 3],
        [3, 6, 7],
        [0, 4, 2],
        [2, 4, 6],
        [1, 3, 5],
        [3, 7, 5],
    ];
    let scene = Scene::build(Vec::new(), vec![Mesh::new(p, None, None, f, None).unwrap()]).unwrap();
    for axis in [Vec3::X, Vec3::Y, Vec3::Z, Vec3::NEG_X, Vec3::NEG_Y, Vec3::NEG_Z] {
        // Through the middle, and exactly along an edge and a face diagonal of the cube.
        for offset in [Vec3::ZERO, Vec3::splat(0.5), Vec3::splat(1.0)] {
            let lateral = offset - axis.abs() * offset;
            let origin = lateral - axis * 5.0;
            let hit = scene.intersect(&Ray { origin, dir: axis }, f32::INFINITY);
            let hit = hit.unwrap_or_else(|| panic!("missed along {axis} at {lateral}"));
            assert!((hit.t - 4.0).abs() < 1e-5, "{axis} {lateral}: t = {}", hit.t);
            assert!(hit.p.is_finite() && hit.n.is_finite());
        }
    }
}

#[test]
fn degenerate_triangles_are_skipped_without_nan() {
    let p = vec![
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0), // good
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(0.5, 0.5, 1.0),
        Vec3::new(1.0, 1.0, 1.0), // collinear
    ];
    let f = vec![[3, 4, 5], [3, 3, 4], [0, 0, 0], [0, 1, 2]];
    let scene = Scene::build(Vec::new(), vec![Mesh::new(p, None, None, f, None).unwrap()]).unwrap();
    for (x, y) in [(0.0, 0.0), (0.5, 0.5), (0.25, 0.25), (-1.0, -1.0)] {
        let hit = scene.intersect(&Ray { origin: Vec3::new(x, y, 5.0), dir: Vec3::NEG_Z }, f32::INFINITY);
        if let Some(h) = hit {
            assert_eq!(h.primitive, 3, "only the good triangle can be hit");
            assert!(h.p.is_finite() && h.n.is_finite() && h.ns.is_finite() && h.uv.is_finite());
            assert!((h.t - 5.0).abs() < 1e-5);
        }
    }
    assert!(scene.intersect(&Ray { origin: Vec3::new(0.0, 0.0, 5.0), dir: Vec3::NEG_Z }, f32::INFINITY).is_some());
}

#[test]
fn far_and_tiny_scenes_hit_like_unit_scale() {
    // The same mesh shrunk to 1e-4 and/or moved to 1e5, against the identical geometry
    // expressed relative to the offset at unit scale (built from the *stored* f32 vertices, so
    // input quantisation is the same on both sides): every ray aimed at a front-facing
    // centroid hits the same triangle at the same t. What is checked is that intersection
    // loses nothing to the magnitude of the coordinates beyond their own rounding.
    let base = icosphere(2, Vec3::ZERO, 1.0);
    let eye = Vec3::new(0.1, 0.2, 5.0);
    // (A mesh of size 1e-4 at 1e5 is not representable in f32: ulp(1e5) = 0.0078.)
    for (scale, offset) in [(1e-4f32, Vec3::ZERO), (1.0, Vec3::splat(1e5)), (1.0, Vec3::new(1e5, -1e5, 3e4))] {
        let m = glam::Mat4::from_translation(offset) * glam::Mat4::from_scale(Vec3::splat(scale));
        let world = base.transformed(m);
        let relative: Vec<Vec3> = world.positions().iter().map(|p| (*p - offset) / scale).collect();
        let unit_mesh = Mesh::new(relative.clone(), None, None, world.indices().to_vec(), None).unwrap();
        let (far, unit) = (
            Scene::build(Vec::new(), vec![world.clone()]).unwrap(),
            Scene::build(Vec::new(), vec![unit_mesh]).unwrap(),
        );
        let mut compared = 0;
        for tri in world.indices() {
            let [a, b, c] = tri.map(|i| relative[i as usize]);
            let centroid = (a + b + c) / 3.0;
            let n = (b - a).cross(c - a).normalize();
            if n.dot((eye - centroid).normalize()) < 0.3 {
                continue; // back-facing or grazing: a ray there is not a fair comparison
            }
            let origin = offset + eye * scale;
            let ray = Ray { origin, dir: (offset + centroid * scale) - origin };
            let unit_ray = Ray { origin: (ray.origin - offset) / scale, dir: ray.dir / scale };
            let (h, u) = (far.intersect(&ray, f32::INFINITY), unit.intersect(&unit_ray, f32::INFINITY));
            let (h, u) = (h.expect("far/tiny ray hits"), u.expect("unit ray hits"));
            assert_eq!(h.primitive, u.primitive, "scale {scale} offset {offset}");
            // t is a ratio of differences of stored coordinates: equal up to a few ulps.
            assert!((h.t - u.t).abs() < 1e-4 * u.t, "scale {scale} offset {offset}: t {} vs {}", h.t, u.t);
            compared += 1;
        }
        assert!(compared > 50, "{compared}");
    }
}

#[test]
fn ray_from_inside_a_sphere_finds_the_far_side() {
    let scene = Scene::build(vec![Sphere::new(Vec3::new(1.0, 2.0, 3.0), 2.0, Some(7)).unwrap()], Vec::new()).unwrap();
    let hit = scene.intersect(&Ray { origin: Vec3::new(1.5, 2.0, 3.0), dir: Vec3::X }, f32::INFINITY).unwrap();
    assert!((hit.t - 1.5).abs() < 1e-5 && (hit.p - Vec3::new(3.0, 2.0, 3.0)).length() < 1e-5);
    assert_eq!(hit.n, Vec3::X, "outward normal");
    assert_eq!(hit.material, Some(7));
}

#[test]
fn bad_geometry_is_an_error_and_empty_scenes_miss() {
    assert!(Mesh::new(vec![Vec3::NAN, Vec3::ONE, Vec3::X], None, None, vec![[0, 1, 2]], None).is_err());
    assert!(Mesh::new(vec![Vec3::INFINITY, Vec3::ONE, Vec3::X], None, None, vec![[0, 1, 2]], None).is_err());
    assert!(Mesh::new(vec![Vec3::ZERO, Vec3::ONE, Vec3::X], None, None, vec![[0, 1, 3]], None).is_err());
    assert!(Sphere::new(Vec3::ZERO, 0.0, None).is_err());
    assert!(Sphere::new(Vec3::ZERO, f32::NAN, None).is_err());
    let empty = Scene::build(Vec::new(), Vec::new()).unwrap();
    let ray = Ray { origin: Vec3::ZERO, dir: Vec3::X };
    assert!(empty.intersect(&ray, f32::INFINITY).is_none() && !empty.occluded(&ray, f32::INFINITY));
    // A NaN ray is a miss, not a panic.
    let one = Scene::build(vec![Sphere::new(Vec3::ZERO, 1.0, None).unwrap()], Vec::new()).unwrap();
    assert!(one.intersect(&Ray { origin: Vec3::NAN, dir: Vec3::X }, f32::INFINITY).is_none());
}

/// A hit as the bits of every field, so that equal means bit-identical (±0 differ).
fn hit_bits(h: &Hit) -> (Vec<u32>, u32, Option<u32>) {
    let f = [h.t].into_iter().chain(h.p.to_array()).chain(h.p_error.to_array()).chain(h.n.to_array());
    (f.chain(h.ns.to_array()).chain(h.uv.to_array()).map(f32::to_bits).collect(), h.primitive, h.material)
}

#[test]
fn every_simd_level_gives_bit_identical_hits() {
    // The same rays at every level the CPU supports: primary rays at a closed icosphere with
    // spheres, then one diffuse bounce from each hit (spawned from the SSE2 hit), closest-hit
    // and any-hit. Each level must agree with SSE2 (the scalar-equivalent reference) bit
    // for bit, on hits and misses.
    let levels: Vec<SimdLevel> = SimdLevel::supported().collect();
    eprintln!("levels on this CPU: {levels:?}");
    let mesh = icosphere(5, Vec3::new(0.1, 0.0, -0.2), 1.0);
    let spheres = vec![Sphere::new(Vec3::new(1.5, 0.5, 0.0), 0.4, None).unwrap()];
    let mut scene = Scene::build(spheres, vec![mesh]).unwrap();
    let mut rng = Xorshift(0x0123_4567_89AB_CDEF);
    let mut rays: Vec<Ray> = (0..20_000)
        .map(|_| {
            let origin = rng.unit_vector() * 4.0;
            let target = rng.unit_vector() * 1.3;
            Ray { origin, dir: target - origin }
        })
        .collect();
    scene.set_simd_level(SimdLevel::Sse2);
    let bounces: Vec<Ray> = rays
        .iter()
        .filter_map(|r| scene.intersect(r, f32::INFINITY))
        .map(|h| spawn_ray(&h, h.n + rng.unit_vector()))
        .collect();
    assert!(bounces.len() > 5_000, "{} hits", bounces.len());
    rays.extend(bounces);
    let trace = |scene: &Scene| -> Vec<_> {
        rays.iter()
            .map(|r| {
                (
                    scene.intersect(r, f32::INFINITY).map(|h| hit_bits(&h)),
                    scene.occluded(r, f32::INFINITY),
                    scene.occluded(r, 0.5),
                )
            })
            .collect()
    };
    let reference = trace(&scene);
    for &level in &levels[1..] {
        assert!(scene.set_simd_level(level));
        assert_eq!(scene.simd_level(), level);
        let got = trace(&scene);
        let differ = got.iter().zip(&reference).filter(|(a, b)| a != b).count();
        assert_eq!(differ, 0, "{level:?}: {differ} of {} rays differ from SSE2", rays.len());
    }
}

fn arb_vec3(range: f32) -> impl Strategy<Value = Vec3> {
    (-range..range, -range..range, -range..range).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn bvh_closest_hit_equals_brute_force(
        tris in prop::collection::vec((arb_vec3(5.0), arb_vec3(5.0), arb_vec3(5.0)), 1..40),
        spheres in prop::collection::vec((arb_vec3(5.0), 0.1f32..2.0), 0..6),
        rays in prop::collection::vec((arb_vec3(8.0), arb_vec3(1.0)), 1..20),
    ) {
        let positions: Vec<Vec3> = tris.iter().flat_map(|(a, b, c)| [*a, *b, *c]).collect();
        let indices: Vec<[u32; 3]> = (0..tris.len() as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        let mesh = Mesh::new(positions, None, None, indices, None).unwrap();
        let spheres: Vec<Sphere> = spheres.iter().map(|(c, r)| Sphere::new(*c, *r, None).unwrap()).collect();
        let mut scene = Scene::build(spheres.clone(), vec![mesh.clone()]).unwrap();
        // Brute force: one single-primitive scene per primitive (the BVH is trivial there).
        let mut singles: Vec<Scene> = spheres.iter().map(|s| Scene::build(vec![*s], Vec::new()).unwrap()).collect();
        for t in mesh.indices() {
            let p: Vec<Vec3> = t.iter().map(|&i| mesh.positions()[i as usize]).collect();
            singles.push(Scene::build(Vec::new(), vec![Mesh::new(p, None, None, vec![[0, 1, 2]], None).unwrap()]).unwrap());
        }
        // Every SIMD level the CPU has goes through the same check.
        let levels: Vec<SimdLevel> = SimdLevel::supported().collect();
        for (origin, dir) in rays {
            if dir.length() < 1e-3 { continue; }
            let ray = Ray { origin, dir };
            let brute = singles.iter().filter_map(|s| s.intersect(&ray, f32::INFINITY)).map(|h| h.t).fold(f32::INFINITY, f32::min);
            for &level in &levels {
                scene.set_simd_level(level);
                match scene.intersect(&ray, f32::INFINITY) {
                    Some(h) => prop_assert!((h.t - brute).abs() <= 1e-5 * brute.max(1.0), "{level:?}: bvh {} vs brute {brute}", h.t),
                    None => prop_assert!(brute.is_infinite(), "{level:?}: bvh missed, brute force hit at {brute}"),
                }
                prop_assert_eq!(scene.occluded(&ray, f32::INFINITY), brute.is_finite(), "{:?}", level);
            }
        }
    }
}

#[test]
fn rays_at_vertices_of_a_1_3m_triangle_sphere_never_leak() {
    // The watertightness trap at full size: a closed icosphere of 20·4⁸ = 1,310,720 triangles, where
    // obvhs's own Möller–Trumbore test and unpadded box test leak by the thousands. Every
    // vertex (655,362) is aimed at from the centre and from one random point outside.
    let center = Vec3::new(-0.4, 0.25, 0.6);
    let mesh = icosphere(8, center, 2.0);
    assert_eq!(mesh.triangle_count(), 1_310_720);
    // At the scene's default level only (see `every_simd_level_gives_bit_identical_hits`).
    let scene = Scene::build(Vec::new(), vec![mesh.clone()]).unwrap();
    let mut rng = Xorshift(0xD1B5_4A32_D192_ED03);
    let (mut rays, mut leaks) = (0u64, 0u64);
    for &target in mesh.positions() {
        let normal = (target - center).normalize();
        let outside = loop {
            let origin = center + rng.unit_vector() * (6.0 + 20.0 * rng.next());
            // See the vertex from the front (a silhouette ray may legitimately miss).
            if (origin - target).normalize().dot(normal) > 0.05 {
                break origin;
            }
        };
        for origin in [center, outside] {
            rays += 1;
            if scene.intersect(&Ray { origin, dir: target - origin }, f32::INFINITY).is_none() {
                leaks += 1;
            }
        }
    }
    assert_eq!(rays, 1_310_724);
    assert_eq!(leaks, 0, "{leaks} of {rays} rays at {:?} leaked through the closed mesh", scene.simd_level());
}

#[test]
fn spawned_rays_find_surfaces_closer_than_obvhs_box_epsilon() {
    // Two parallel squares 1e-6 apart in a 1e-5-sized scene: a ray spawned from the lower one
    // must hit the upper one at t ≈ 1e-6. obvhs's own node test clamps the entry distance to
    // 1e-4 and would cull that box; our traversal clamps to 0.
    let square = |z: f32| {
        let p =
            vec![Vec3::new(0.0, 0.0, z), Vec3::new(1e-5, 0.0, z), Vec3::new(0.0, 1e-5, z), Vec3::new(1e-5, 1e-5, z)];
        Mesh::new(p, None, None, vec![[0, 1, 2], [1, 3, 2]], Some(if z == 0.0 { 0 } else { 1 })).unwrap()
    };
    let scene = Scene::build(Vec::new(), vec![square(0.0), square(1e-6)]).unwrap();
    let down = scene.intersect(&Ray { origin: Vec3::new(3e-6, 4e-6, 1.0), dir: Vec3::NEG_Z }, f32::INFINITY);
    let down = down.expect("the upper square is hit from above");
    assert_eq!(down.material, Some(1));
    // Leave it downwards: the lower square is 1e-6 away.
    let below = scene.intersect(&spawn_ray(&down, Vec3::NEG_Z), f32::INFINITY).expect("lower square");
    assert_eq!(below.material, Some(0));
    assert!((below.t - 1e-6).abs() < 1e-9, "t = {}", below.t);
    assert!(scene.occluded(&spawn_ray(&down, Vec3::new(0.1, 0.2, -1.0)), f32::INFINITY));
    // And back up from the lower square: the upper one, not itself.
    let up = scene.intersect(&spawn_ray(&below, Vec3::Z), f32::INFINITY).expect("upper square");
    assert_eq!(up.material, Some(1));
}

#[test]
fn area_of_a_large_triangle_far_out_is_finite_and_exact() {
    // Legs of 1e12 at 4e11 from the origin: the f32 cross product's squared length (≈ 1e48)
    // overflows, which made the area ∞ and every eq.-9 area share NaN (found by the glTF fuzz
    // target: `fuzz/regressions/gltf/gltf_far_triangle_area_nan.gltf`).
    let o = Vec3::splat(4e11);
    let legs = 1e12f32;
    let tri = vec![o, o + Vec3::new(legs, 0.0, 0.0), o + Vec3::new(0.0, legs, 0.0)];
    let scene = Scene::build(Vec::new(), vec![Mesh::new(tri, None, None, vec![[0, 1, 2]], None).unwrap()]).unwrap();
    let area = scene.primitive_area(0);
    let exact = 0.5 * f64::from(legs) * f64::from(legs);
    assert!(area.is_finite() && (f64::from(area) / exact - 1.0).abs() < 1e-6, "{area} vs {exact}");
}

#[test]
fn primitive_ids_map_to_spheres_then_each_meshs_triangles() {
    // Two spheres, then meshes of 2, 0 and 1 triangles: ids 0–1 spheres, 2–3 mesh 0, 4 mesh 2.
    let tri = |x: f32| [Vec3::new(x, 0.0, 0.0), Vec3::new(x + 2.0, 0.0, 0.0), Vec3::new(x, 2.0, 0.0)];
    let two = Mesh::new([tri(0.0), tri(10.0)].concat(), None, None, vec![[0, 1, 2], [3, 4, 5]], Some(5)).unwrap();
    let empty = Mesh::new(Vec::new(), None, None, Vec::new(), Some(6)).unwrap();
    let one = Mesh::new(tri(20.0).to_vec(), None, None, vec![[0, 1, 2]], Some(7)).unwrap();
    let spheres = vec![
        Sphere::new(Vec3::new(0.0, 0.0, 10.0), 1.0, Some(1)).unwrap(),
        Sphere::new(Vec3::new(10.0, 0.0, 10.0), 0.5, Some(2)).unwrap(),
    ];
    let scene = Scene::build(spheres, vec![two, empty, one]).unwrap();
    assert_eq!((scene.primitive_count(), scene.sphere_count(), scene.triangle_count()), (5, 2, 3));
    let expected = [
        Primitive::Sphere { index: 0 },
        Primitive::Sphere { index: 1 },
        Primitive::Triangle { mesh: 0, triangle: 0 },
        Primitive::Triangle { mesh: 0, triangle: 1 },
        Primitive::Triangle { mesh: 2, triangle: 0 },
    ];
    for (id, want) in expected.iter().enumerate() {
        assert_eq!(scene.primitive(id as u32), *want);
    }
    assert!((scene.primitive_area(1) - std::f32::consts::PI).abs() < 1e-6, "4π·0.5²");
    assert_eq!(scene.primitive_area(4), 2.0, "right triangle with legs 2");
    // Hits report the same ids and the owning mesh's material.
    let down = |x: f32| scene.intersect(&Ray { origin: Vec3::new(x, 0.5, 5.0), dir: Vec3::NEG_Z }, f32::INFINITY);
    let (a, b, c) = (down(10.5).unwrap(), down(20.5).unwrap(), down(0.5).unwrap());
    assert_eq!((a.primitive, a.material), (3, Some(5)));
    assert_eq!((b.primitive, b.material), (4, Some(7)));
    assert_eq!((c.primitive, c.material), (2, Some(5)));
    let up = scene.intersect(&Ray { origin: Vec3::new(10.0, 0.0, 0.0), dir: Vec3::Z }, f32::INFINITY).unwrap();
    assert_eq!((up.primitive, up.material, up.n), (1, Some(2), Vec3::NEG_Z));
    let stats = scene.stats();
    assert!(stats.node_count >= 1 && stats.bytes > 0 && stats.bytes_per_primitive > 0.0);
}

/// A random placement: rotation, non-uniform scale (mirrored for odd `i`), translation up to 1e3.
fn placement(rng: &mut Xorshift, i: usize) -> glam::Mat4 {
    let axis = rng.unit_vector();
    let angle = std::f32::consts::TAU * rng.next();
    let mut scale = Vec3::new(0.2 + 2.0 * rng.next(), 0.2 + 2.0 * rng.next(), 0.2 + 2.0 * rng.next());
    if i % 2 == 1 {
        scale.x = -scale.x;
    }
    let translation = 1e3 * Vec3::new(rng.next(), rng.next(), rng.next());
    glam::Mat4::from_scale_rotation_translation(scale, glam::Quat::from_axis_angle(axis, angle), translation)
}

/// The world-space copy the loader would make: positions and normals transformed, winding reversed
/// under a mirroring transform.
fn flattened(mesh: &Mesh, m: glam::Mat4) -> Mesh {
    let t = mesh.transformed(m);
    let mut indices = t.indices().to_vec();
    if m.determinant() < 0.0 {
        for tri in &mut indices {
            tri.swap(1, 2);
        }
    }
    Mesh::new(t.positions().to_vec(), t.normals().map(<[Vec3]>::to_vec), None, indices, t.material()).unwrap()
}

/// The two-level BVH (one object BVH, placements with object-to-world transforms) finds
/// the hits of world-space copies: same material, same facing normal, t within 1e-5 relative, and the
/// two points within the sum of their error bounds (the instanced bound transforms the object-space one
/// conservatively); shadow queries agree; a ray spawned from an instanced hit never re-hits its surface.
#[test]
fn instanced_objects_hit_like_world_space_copies() {
    let mut rng = Xorshift(0x1234_5678);
    let mut sphere = icosphere(2, Vec3::ZERO, 1.0);
    sphere.set_material(Some(3));
    let transforms: Vec<glam::Mat4> = (0..40).map(|i| placement(&mut rng, i)).collect();
    let copies: Vec<Mesh> = transforms.iter().map(|m| flattened(&sphere, *m)).collect();
    let flat = Scene::build(Vec::new(), copies).unwrap();
    let instances = geometry::Instances::new(vec![sphere.clone()], transforms.clone()).unwrap();
    let two_level = Scene::build_with_instances(Vec::new(), Vec::new(), vec![instances]).unwrap();
    assert_eq!((two_level.instance_count(), two_level.instanced_triangle_count()), (40, 40 * 320));
    assert_eq!(two_level.triangle_count(), 0);

    let (mut hits, mut disagreements, mut neighbours) = (0, 0, 0);
    for k in 0..20_000 {
        // Rays from around the cloud towards a random placement's centre, slightly off.
        let target = transforms[k % 40].transform_point3(0.9 * rng.unit_vector());
        let origin = Vec3::splat(500.0) + 1.5e3 * rng.unit_vector();
        let ray = Ray { origin, dir: (target - origin).normalize() };
        let (a, b) = (flat.intersect(&ray, f32::INFINITY), two_level.intersect(&ray, f32::INFINITY));
        assert_eq!(flat.occluded(&ray, 1e4), two_level.occluded(&ray, 1e4));
        let (a, b) = match (a, b) {
            (Some(a), Some(b)) => (a, b),
            (None, None) => continue,
            // Only a ray grazing a silhouette may differ (the object-space ray is rounded).
            (a, b) => {
                disagreements += 1;
                let h = a.or(b).unwrap();
                assert!(h.n.dot(ray.dir).abs() < 0.05, "a miss on one side only, away from a silhouette: {h:?}");
                continue;
            }
        };
        hits += 1;
        assert_eq!(b.material, Some(3));
        assert_eq!(b.primitive, u32::MAX);
        assert!((a.t - b.t).abs() <= 1e-5 * a.t, "t {} vs {}", a.t, b.t);
        let gap = (a.p - b.p).abs();
        let allowed = a.p_error + b.p_error;
        // Different triangles of a shared edge may be chosen; their points then still agree.
        assert!(gap.cmple(allowed + Vec3::splat(1e-5 * a.t)).all(), "gap {gap} > {allowed}");
        // The same triangle (nearly always), else a neighbour across the edge the ray passes (icosphere
        // faces meet at ≈ 15°, more under a non-uniform scale).
        if a.n.dot(b.n) < 0.9999 {
            neighbours += 1;
            assert!(a.n.dot(b.n) > 0.5, "normals {} vs {}", a.n, b.n);
        }
        assert!(b.n.dot(ray.dir) < 0.0, "instances keep the outward normal (mirrored ones too)");
        // Leaving the surface outwards: never a hit on the same sphere near t = 0.
        let out = spawn_ray(&b, b.n);
        if let Some(again) = two_level.intersect(&out, f32::INFINITY) {
            assert!(again.t > 1e-2, "self-hit at t = {}", again.t);
        }
    }
    assert!(hits > 10_000, "{hits} hits");
    assert!(disagreements * 1000 < hits, "{disagreements} disagreements in {hits} hits");
    assert!(neighbours * 100 < hits, "{neighbours} neighbour triangles in {hits} hits");
}

/// An icosphere of unit radius at the origin, smooth-shaded: each vertex normal points away
/// from the centre (the sphere it approximates).
fn smooth_icosphere(subdivisions: u32) -> Mesh {
    let flat = icosphere(subdivisions, Vec3::ZERO, 1.0);
    let normals = flat.positions().to_vec();
    Mesh::new(flat.positions().to_vec(), Some(normals), None, flat.indices().to_vec(), None).unwrap()
}

/// The hit of a ray from outside aimed at the origin through `target`.
fn hit_towards(scene: &Scene, target: Vec3) -> Hit {
    let ray = Ray { origin: 3.0 * target.normalize(), dir: -target.normalize() };
    scene.intersect(&ray, f32::INFINITY).expect("the ray hits the sphere")
}

/// Hanika's lift on an icosahedron with its vertices' sphere normals, where the answer is known
/// in closed form: at a facet's centroid c (distance |c| from the centre, so c·vᵢ = |c|²) each
/// vertex plane lies 1 − |c|² above, the lift is c(2 − |c|²); at an edge midpoint m of vertices
/// a, b it is m(1 + (1 − a·b)/2), from either of the two triangles; at a vertex, none. Wound the
/// other way (geometric normals inward) and seen from outside, the same. Flat-shaded, there is
/// no lift.
#[test]
fn lifted_points_are_hanikas_and_agree_along_shared_edges() {
    let mesh = icosphere(0, Vec3::ZERO, 1.0);
    let smooth = Scene::build(Vec::new(), vec![smooth_icosphere(0)]).unwrap();
    let reversed: Vec<[u32; 3]> = mesh.indices().iter().map(|&[a, b, c]| [a, c, b]).collect();
    let inward = Scene::build(Vec::new(), vec![smooth_icosphere(0).with_indices(reversed).unwrap()]).unwrap();
    let flat = Scene::build(Vec::new(), vec![mesh.clone()]).unwrap();
    let v = mesh.positions();
    let mut edges = 0;
    for scene in [&smooth, &inward] {
        // Seen from outside: the side of the geometric normal facing away from the centre.
        let lifted = |target: Vec3| {
            let hit = hit_towards(scene, target);
            let side = if hit.n.dot(hit.p) > 0.0 { hit.n } else { -hit.n };
            (hit, side, scene.lifted_point(&hit, side).expect("smooth-shaded triangles lift"))
        };
        for [a, b, c] in mesh.indices().iter().map(|t| t.map(|i| v[i as usize])) {
            let centroid = (a + b + c) / 3.0;
            let (hit, side, p) = lifted(centroid);
            let expected = centroid * (2.0 - centroid.length_squared());
            assert!((p - expected).length() < 1e-5, "centroid {centroid}: {p} ≠ {expected}");
            assert!((p - hit.p).dot(side) > 0.1, "the lift is up, and large at a coarse centroid");
            // Each edge's midpoint approached from inside this triangle (1e-4 of the way to the
            // opposite vertex): so every edge from both of its triangles.
            for [e0, e1, opposite] in [[a, b, c], [b, c, a], [c, a, b]] {
                let mid = (e0 + e1) / 2.0;
                let (hit, _, p) = lifted(mid + 1e-4 * (opposite - mid));
                assert!(hit.p.distance(mid) < 2e-4, "the ray hits near the midpoint");
                let expected = mid * (1.0 + (1.0 - e0.dot(e1)) / 2.0);
                assert!((p - expected).length() < 1e-3, "edge midpoint {mid}: {p} ≠ {expected}");
                edges += 1;
            }
            let (hit, _, p) = lifted(a);
            assert!((p - hit.p).length() < 1e-5, "vertex {a}: lifted to {p}");
        }
    }
    assert_eq!(edges, 2 * 20 * 3, "each of the 30 edges from both triangles, both windings");
    let hit = hit_towards(&flat, v[0] + v[11] + v[5]);
    assert_eq!(flat.lifted_point(&hit, hit.n), None, "flat-shaded: no lift");
}

/// Near the shadow terminator of a smooth-shaded icosahedron, light arriving below the flat
/// facet's plane but above the shading normal's horizon: a plain shadow ray from the hit point
/// enters the solid and is blocked by its far side, the one from the lifted point passes (to a
/// direction and to a point), on both windings. A sphere put in its way still blocks it, and is
/// the blocker found.
#[test]
fn shadow_rays_from_lifted_points_clear_the_terminator() {
    let mesh = icosphere(0, Vec3::ZERO, 1.0);
    let reversed: Vec<[u32; 3]> = mesh.indices().iter().map(|&[a, b, c]| [a, c, b]).collect();
    let v = mesh.positions();
    let mut cleared = 0;
    for smooth_mesh in [smooth_icosphere(0), smooth_icosphere(0).with_indices(reversed).unwrap()] {
        let smooth = Scene::build(Vec::new(), vec![smooth_mesh.clone()]).unwrap();
        for [a, b, c] in mesh.indices().iter().map(|t| t.map(|i| v[i as usize])) {
            // A point toward vertex a, where the shading normal tilts towards a; seen from outside.
            let hit = hit_towards(&smooth, 0.7 * a + 0.15 * b + 0.15 * c);
            let n = if hit.n.dot(hit.p) > 0.0 { hit.n } else { -hit.n };
            let ns = if hit.ns.dot(n) > 0.0 { hit.ns } else { -hit.ns };
            let tangent = (ns - ns.dot(n) * n).normalize();
            // Half-way (in slope) between the facet's horizon and the shading normal's.
            let below = (tangent - 0.5 * tangent.dot(ns) / n.dot(ns) * n).normalize();
            assert!(below.dot(n) < 0.0 && below.dot(ns) > 0.0, "in the terminator wedge");
            assert!(smooth.occluded(&spawn_ray(&hit, below), f32::INFINITY), "the solid blocks a plain ray");
            let lifted = smooth.terminator_shadow_ray(&hit, n, None, below).expect("a lifted ray");
            cleared += usize::from(!smooth.shadow_occluded(&lifted));
            let target = hit.p + 10.0 * below;
            let to_point = smooth.terminator_shadow_ray(&hit, n, Some(target), below).expect("a lifted ray");
            assert!(!smooth.shadow_occluded(&to_point), "to {target}");
            // The same light behind a sphere: hidden, by the sphere (primitive 0: spheres first).
            let sphere = Sphere::new(hit.p + 3.0 * below, 0.5, None).unwrap();
            let blocked = Scene::build(vec![sphere], vec![smooth_mesh.clone()]).unwrap();
            let hit = hit_towards(&blocked, 0.7 * a + 0.15 * b + 0.15 * c);
            let lifted = blocked.terminator_shadow_ray(&hit, n, Some(target), below).expect("a lifted ray");
            assert!(blocked.shadow_occluded(&lifted), "the sphere blocks the lifted ray");
            let blocker = blocked.shadow_blocker(&lifted).expect("a blocker");
            assert_eq!(blocker.primitive, 0, "the blocker is the sphere");
            assert!((blocker.p.distance(hit.p + 3.0 * below) - 0.5).abs() < 1e-3, "on the sphere");
        }
    }
    assert_eq!(cleared, 40, "every facet's terminator ray clears the solid, both windings");
}
