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

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use crate::shapes::{Mesh, locate_triangle};

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

/// A 63-bit hash of a [`key`] (the top bit clear: [`DEGENERATE`] marks zero-area triangles). Equal keys
/// hash equal; unequal ones that collide are told apart by comparing the keys.
fn hash_key((bits, material): ([[u32; 3]; 3], Option<u32>)) -> u64 {
    let mut h = material.map_or(0x51_7cc1_b727_220a, |m| u64::from(m) + 1);
    for &w in bits.as_flattened() {
        h = (h ^ u64::from(w)).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        h ^= h >> 29;
    }
    h >> 1
}

/// Scenes of this many triangles or more are hashed and sorted in parallel.
const PARALLEL_MIN: usize = 1 << 14;

/// The sort key of a zero-area triangle.
const DEGENERATE: u64 = u64::MAX;

/// Removes zero-area and duplicate triangles from `meshes` (a duplicate of a triangle in an earlier mesh
/// counts, so instanced copies collapse), dropping meshes left without triangles. Meshes with nothing to
/// remove are kept as they are (no copy).
///
/// Duplicates are found by sorting (hash, triangle) pairs in parallel, not by inserting every key into a
/// hash set: on a 1.6M-triangle terrain the set took 0.5 s and ~100 MB (SipHash over 44-byte keys);
/// the sort takes 16 bytes a triangle. The first triangle of each key is kept, as before.
pub(crate) fn remove_unhittable(meshes: Vec<Mesh>) -> (Vec<Mesh>, Removed) {
    let mut removed = Removed::default();
    let mut offsets = Vec::with_capacity(meshes.len() + 1);
    offsets.push(0usize);
    for mesh in &meshes {
        offsets.push(offsets[offsets.len() - 1] + mesh.indices().len());
    }
    let total = offsets[meshes.len()];
    let key_of = |global: usize| {
        let (m, t) = locate_triangle(&offsets, global);
        let mesh = &meshes[m];
        let p = mesh.positions();
        key(mesh.indices()[t].map(|i| p[i as usize]), mesh.material())
    };
    let mut records: Vec<(u64, usize)> = Vec::with_capacity(total);
    for (m, mesh) in meshes.iter().enumerate() {
        let (p, base, material) = (mesh.positions(), offsets[m], mesh.material());
        let record = |(t, tri): (usize, &[u32; 3])| {
            let t3 = tri.map(|i| p[i as usize]);
            let h = if is_degenerate(t3) { DEGENERATE } else { hash_key(key(t3, material)) };
            (h, base + t)
        };
        // Small scenes stay on this thread (starting rayon's pool costs more than their sort).
        if total >= PARALLEL_MIN {
            records.par_extend(mesh.indices().par_iter().enumerate().map(record));
        } else {
            records.extend(mesh.indices().iter().enumerate().map(record));
        }
    }
    if total >= PARALLEL_MIN {
        records = sorted_by_buckets(records);
    } else {
        records.sort_unstable();
    }
    let mut remove = vec![false; total];
    let mut run_start = 0;
    while run_start < records.len() {
        let h = records[run_start].0;
        let run_end = run_start + records[run_start..].iter().take_while(|r| r.0 == h).count();
        let run = &records[run_start..run_end];
        if h == DEGENERATE {
            removed.degenerate += run.len();
            run.iter().for_each(|&(_, g)| remove[g] = true);
        } else if run.len() > 1 {
            // Equal hashes: equal keys (or a collision). Sorted by key, then triangle, the first
            // triangle of each key stays.
            let mut members: Vec<_> = run.iter().map(|&(_, g)| (key_of(g), g)).collect();
            members.sort_unstable();
            for pair in members.windows(2) {
                if pair[0].0 == pair[1].0 {
                    removed.duplicates += 1;
                    remove[pair[1].1] = true;
                }
            }
        }
        run_start = run_end;
    }
    // The pairs are dead weight while the meshes are rebuilt.
    drop(records);
    let mut out = Vec::with_capacity(meshes.len());
    for (m, mesh) in meshes.into_iter().enumerate() {
        let remove = &remove[offsets[m]..offsets[m + 1]];
        if !remove.contains(&true) {
            out.push(mesh);
            continue;
        }
        let keep: Vec<[u32; 3]> = mesh.indices().iter().zip(remove).filter(|(_, r)| !**r).map(|(t, _)| *t).collect();
        if !keep.is_empty() {
            // Same vertices and attributes, fewer triangles: cannot fail (indices were valid before).
            if let Ok(m) = mesh.with_indices(keep) {
                out.push(m);
            }
        }
    }
    (out, removed)
}

/// Buckets of [`sorted_by_buckets`], by the hash's top bits: about 400 records each on a
/// 1.6M-triangle scene, so that each bucket's sort runs in the cache.
const BUCKET_BITS: u32 = 12;

/// `records` sorted: scattered into buckets by their hashes' top bits (the buckets in order of
/// the hash), then each bucket sorted; both in parallel. The same order as any sort of the whole
/// (the pairs are distinct). `par_sort_unstable` of the whole was 5 % of the samples of `info` on
/// a 1.6M-triangle terrain: each of its recursion's top levels is a pass over all the pairs.
fn sorted_by_buckets(records: Vec<(u64, usize)>) -> Vec<(u64, usize)> {
    const BUCKETS: usize = 1 << BUCKET_BITS;
    // Hashes have 63 bits; [`DEGENERATE`] (all 64) joins the last bucket, which it ends.
    let bucket = |h: u64| ((h >> (63 - BUCKET_BITS)) as usize).min(BUCKETS - 1);
    // Each part of the records counts its buckets, then scatters into its own slice of each
    // bucket (buckets in order, and within a bucket the parts in order).
    let parts: Vec<&[(u64, usize)]> = records.chunks(records.len().div_ceil(SCATTER_PARTS).max(1)).collect();
    let counts: Vec<Vec<usize>> = parts
        .par_iter()
        .map(|part| {
            let mut count = vec![0usize; BUCKETS];
            part.iter().for_each(|&(h, _)| count[bucket(h)] += 1);
            count
        })
        .collect();
    let mut out = vec![(0u64, 0usize); records.len()];
    let mut targets: Vec<Vec<&mut [(u64, usize)]>> = parts.iter().map(|_| Vec::with_capacity(BUCKETS)).collect();
    let mut rest = out.as_mut_slice();
    for b in 0..BUCKETS {
        for (count, target) in counts.iter().zip(&mut targets) {
            let (slice, tail) = std::mem::take(&mut rest).split_at_mut(count[b]);
            target.push(slice);
            rest = tail;
        }
    }
    parts.par_iter().zip(targets).for_each(|(part, mut target)| {
        let mut filled = vec![0usize; BUCKETS];
        for &(h, g) in *part {
            let b = bucket(h);
            target[b][filled[b]] = (h, g);
            filled[b] += 1;
        }
    });
    drop(records);
    let mut buckets = Vec::with_capacity(BUCKETS);
    let mut rest = out.as_mut_slice();
    for b in 0..BUCKETS {
        let (slice, tail) = std::mem::take(&mut rest).split_at_mut(counts.iter().map(|c| c[b]).sum());
        buckets.push(slice);
        rest = tail;
    }
    buckets.into_par_iter().for_each(|slice| slice.sort_unstable());
    out
}

/// Parts of [`sorted_by_buckets`]'s scatter: a few per core of the machines this runs on.
const SCATTER_PARTS: usize = 8;

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
    fn buckets_sort_as_the_whole_sorts() {
        // Hashes spread over 63 bits, some equal, a few degenerate; more records than buckets
        // and buckets left empty.
        let mut uniform = crate::test_uniform(0x2545_f491);
        let mut bits24 = || (uniform() * (1u32 << 24) as f32) as u64;
        let mut records: Vec<(u64, usize)> = (0..20_000)
            .map(|g| {
                let h = match g % 10 {
                    0 => DEGENERATE,
                    1 => 1 << 40,
                    _ => (bits24() << 39) | (bits24() << 15) | (bits24() >> 9),
                };
                (h, g)
            })
            .collect();
        records.extend([(u64::MAX >> 1, 20_000), (0, 20_001)]);
        let mut expected = records.clone();
        expected.sort_unstable();
        assert_eq!(sorted_by_buckets(records), expected);
    }

    #[test]
    fn the_sort_removes_what_a_hash_set_of_keys_removes() {
        // Vertices on a 3×3×1 grid, so that random triangles repeat (in all windings and rotations)
        // and many are collinear; four meshes, two materials.
        let positions: Vec<Vec3> = (0..9).map(|i| Vec3::new((i % 3) as f32, (i / 3) as f32, 0.0)).collect();
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % 9) as u32
        };
        let meshes: Vec<Mesh> = (0..4)
            .map(|m| mesh(positions.clone(), (0..5000).map(|_| [next(), next(), next()]).collect(), Some(m % 2)))
            .collect();
        // The reference: meshes in order, the first of each key kept.
        let mut seen = std::collections::HashSet::new();
        let mut expected = Removed::default();
        let mut kept = Vec::new();
        for mesh in &meshes {
            let p = mesh.positions();
            let keep: Vec<[u32; 3]> = mesh
                .indices()
                .iter()
                .copied()
                .filter(|tri| {
                    let t = tri.map(|i| p[i as usize]);
                    if is_degenerate(t) {
                        expected.degenerate += 1;
                        false
                    } else if !seen.insert(key(t, mesh.material())) {
                        expected.duplicates += 1;
                        false
                    } else {
                        true
                    }
                })
                .collect();
            if !keep.is_empty() {
                kept.push(keep);
            }
        }
        let (out, removed) = remove_unhittable(meshes);
        assert_eq!(removed, expected);
        assert!(removed.degenerate > 1000 && removed.duplicates > 1000, "{removed:?}");
        let out: Vec<Vec<[u32; 3]>> = out.iter().map(|m| m.indices().to_vec()).collect();
        assert_eq!(out, kept);
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
