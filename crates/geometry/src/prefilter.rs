//! Triangles that cannot change an image, removed before the BVH build.
//!
//! (Written for obvhs's PLOC build, the earlier BVH builder; the binned SAH build that
//! replaced it splits coincident boxes in the middle by count, in O(n log n), but these triangles
//! still cost memory and time and change no image.) obvhs's PLOC build pairs each cluster with the neighbour (within a small window of the Morton order)
//! whose union box has the least area, and merges two clusters only when they choose each other. Its
//! comparison is `cost <= best` (obvhs 0.4 `ploc/mod.rs`, `find_best_node`), so when many neighbours tie —
//! identical boxes — every cluster chooses the farthest one to its right, almost no pair agrees, and each
//! pass merges O(1) pairs: O(n²) passes×work. Ties of that kind come from exactly two kinds of input, both
//! removed here:
//! - **zero-area triangles** (all three vertices collinear, e.g. an index buffer of zeros): a watertight
//!   test can never report a hit on one whose vertices coincide (two equal vertices give equal projected
//!   points, so one edge function is exactly 0 and the other two are exactly opposite: rejected), and a
//!   collinear one has no surface: any hit the rounding produced would carry an undefined normal;
//! - **exact duplicates** (the same three positions in the same winding with the same material, e.g. one
//!   triangle instanced 10⁶ times): a ray hits each copy at the same `t`, and the closest-hit test keeps
//!   the first copy found, so keeping one copy leaves every hit the same.

use std::collections::HashSet;

use glam::{DVec3, Vec3};

use crate::shapes::Mesh;

/// Whether the triangle has zero area (in f64, exact for f32 inputs up to the cross product's rounding).
pub(crate) fn is_degenerate([a, b, c]: [Vec3; 3]) -> bool {
    if a == b || b == c || a == c {
        return true;
    }
    let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    (b - a).cross(c - a) == DVec3::ZERO
}

/// What [`remove_unhittable`] removed.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Removed {
    /// Zero-area triangles.
    pub(crate) degenerate: usize,
    /// Exact duplicates of a triangle kept.
    pub(crate) duplicates: usize,
}

/// The triangle's positions as bits, rotated so the smallest comes first (same winding, any start vertex):
/// the key under which duplicates are equal.
fn key(t: [Vec3; 3], material: Option<u32>) -> ([[u32; 3]; 3], Option<u32>) {
    let bits = t.map(|p| p.to_array().map(f32::to_bits));
    let first = (0..3).min_by_key(|&i| bits[i]).unwrap_or(0);
    ([bits[first], bits[(first + 1) % 3], bits[(first + 2) % 3]], material)
}

/// Removes zero-area and duplicate triangles from `meshes` (a duplicate of a triangle in an earlier mesh
/// counts, so instanced copies collapse), dropping meshes left without triangles. Meshes with nothing to
/// remove are kept as they are (no copy).
pub(crate) fn remove_unhittable(meshes: Vec<Mesh>) -> (Vec<Mesh>, Removed) {
    let mut removed = Removed::default();
    let mut seen = HashSet::new();
    let mut out = Vec::with_capacity(meshes.len());
    for mesh in meshes {
        let p = mesh.positions();
        let mut keep = Vec::with_capacity(mesh.indices().len());
        for tri in mesh.indices() {
            let t = tri.map(|i| p[i as usize]);
            if is_degenerate(t) {
                removed.degenerate += 1;
            } else if !seen.insert(key(t, mesh.material())) {
                removed.duplicates += 1;
            } else {
                keep.push(*tri);
            }
        }
        if keep.len() == mesh.indices().len() {
            out.push(mesh);
        } else if !keep.is_empty() {
            // Same vertices and attributes, fewer triangles: cannot fail (indices were valid before).
            if let Ok(m) = mesh.with_indices(keep) {
                out.push(m);
            }
        }
    }
    (out, removed)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mesh(positions: Vec<Vec3>, indices: Vec<[u32; 3]>, material: Option<u32>) -> Mesh {
        Mesh::new(positions, None, None, indices, material).unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn degenerate_triangles_are_found() {
        assert!(is_degenerate([Vec3::ZERO, Vec3::ZERO, Vec3::X]));
        assert!(is_degenerate([Vec3::ZERO, Vec3::X, Vec3::splat(2.0) * Vec3::X]));
        assert!(is_degenerate([Vec3::ZERO, Vec3::ONE, Vec3::splat(3.0)]));
        assert!(!is_degenerate([Vec3::ZERO, Vec3::X, Vec3::Y]));
        // A sliver far from the origin still has area.
        assert!(!is_degenerate([Vec3::splat(1e6), Vec3::new(1e6 + 1.0, 1e6, 1e6), Vec3::new(1e6, 1e6 + 0.0625, 1e6)]));
    }

    #[test]
    fn duplicates_collapse_across_meshes_but_not_across_windings_or_materials() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        let meshes = vec![
            mesh(p.clone(), vec![[0, 1, 2], [1, 2, 0], [0, 2, 1], [0, 0, 1]], Some(0)),
            mesh(p.clone(), vec![[2, 0, 1]], Some(0)),
            mesh(p, vec![[0, 1, 2]], Some(1)),
        ];
        let (out, removed) = remove_unhittable(meshes);
        assert_eq!(removed, Removed { degenerate: 1, duplicates: 2 });
        // Mesh 0 keeps [0,1,2] and its reverse; mesh 1 is gone; mesh 2 has another material.
        assert_eq!(out.len(), 2);
        assert_eq!(out[0].indices(), &[[0, 1, 2], [0, 2, 1]]);
        assert_eq!(out[1].material(), Some(1));
    }
}
