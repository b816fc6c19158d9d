//! Glass as authored: glTF's `KHR_materials_transmission` without `KHR_materials_volume` is, by the
//! specification, a thin wall (a surface with no inside), but exporters write it for solid glass objects
//! too (Blender exports its glass that way unless a volume is set up), and a closed mesh has an inside.
//! Such a material on closed meshes renders as solid glass (its index from `KHR_materials_ior`, default
//! 1.5); on open meshes it stays thin-walled; `--thin-glass` keeps the specification's reading everywhere.

use geometry::{Instances, MaterialDesc, MaterialFormat, Mesh};

/// Whether every edge of `mesh` is shared by exactly two of its triangles once vertices at the same
/// position are welded (a mesh split at UV or normal seams is still closed); triangles whose corners weld
/// together are left out. An empty mesh is not closed.
pub(crate) fn is_closed(mesh: &Mesh) -> bool {
    // Weld: one id per distinct position (bit pattern, so −0 and +0 differ; the loaders do not write −0 for
    // shared vertices), by sorting rather than hashing, in O(n log n) with 8 bytes per vertex.
    let positions = mesh.positions();
    let key = |i: usize| {
        let p = positions[i];
        (p.x.to_bits(), p.y.to_bits(), p.z.to_bits())
    };
    let mut order: Vec<u32> = (0..positions.len() as u32).collect();
    order.sort_unstable_by_key(|&i| key(i as usize));
    let mut weld = vec![0u32; positions.len()];
    let mut id = 0u32;
    for (k, &i) in order.iter().enumerate() {
        if k > 0 && key(order[k - 1] as usize) != key(i as usize) {
            id += 1;
        }
        weld[i as usize] = id;
    }
    let mut edges: Vec<(u32, u32)> = Vec::with_capacity(3 * mesh.triangle_count());
    for t in mesh.indices() {
        let [a, b, c] = t.map(|i| weld[i as usize]);
        if a == b || b == c || a == c {
            continue;
        }
        for (u, v) in [(a, b), (b, c), (c, a)] {
            edges.push((u.min(v), u.max(v)));
        }
    }
    if edges.is_empty() {
        return false;
    }
    edges.sort_unstable();
    // Runs of equal edges: each must be exactly two long.
    let mut start = 0;
    for k in 1..=edges.len() {
        if k == edges.len() || edges[k] != edges[start] {
            if k - start != 2 {
                return false;
            }
            start = k;
        }
    }
    true
}

/// Which glTF transmitting materials without a volume render solid: those used only by closed meshes,
/// and, for a material used by closed and open meshes alike, a copy of it (named `"<name> (closed
/// meshes)"`, appended to `descs`) that the closed ones are given. Returns a flag per material of `descs`
/// (after the copies) and adds a note naming them; with `thin` (`--thin-glass`) nothing is solid and the
/// note says so if any material would have been.
pub(crate) fn solid_glass(
    meshes: &mut [Mesh],
    instances: &mut [Instances],
    descs: &mut Vec<MaterialDesc>,
    thin: bool,
    warnings: &mut Vec<String>,
) -> Vec<bool> {
    let candidate = |d: &MaterialDesc| {
        d.format == MaterialFormat::Gltf && d.transmission.is_some_and(|t| t > 0.0) && d.thickness.is_none()
    };
    let mut solid = vec![false; descs.len()];
    if !descs.iter().any(candidate) {
        return solid;
    }
    // Per candidate material: (closed meshes, open meshes).
    let mut uses = vec![(0usize, 0usize); descs.len()];
    let all = || meshes.iter().chain(instances.iter().flat_map(Instances::meshes));
    let closed: Vec<bool> = all()
        .map(|m| m.material().is_some_and(|i| descs.get(i as usize).is_some_and(candidate)) && is_closed(m))
        .collect();
    for (mesh, &c) in all().zip(&closed) {
        let Some(i) = mesh.material().map(|i| i as usize).filter(|&i| descs.get(i).is_some_and(candidate)) else {
            continue;
        };
        if c { uses[i].0 += 1 } else { uses[i].1 += 1 }
    }
    let mut names = Vec::new();
    let mut copies: Vec<(usize, u32)> = Vec::new();
    for (i, &(closed_uses, open_uses)) in uses.iter().enumerate() {
        if closed_uses == 0 {
            continue;
        }
        names.push(format!("'{}'{}", descs[i].name, if open_uses > 0 { " (its closed meshes)" } else { "" }));
        if thin {
            continue;
        }
        if open_uses == 0 {
            solid[i] = true;
        } else {
            let mut copy = descs[i].clone();
            copy.name = format!("{} (closed meshes)", copy.name);
            copies.push((i, descs.len() as u32));
            descs.push(copy);
            solid.push(true);
        }
    }
    if !copies.is_empty() {
        let meshes = meshes.iter_mut().chain(placed_meshes(instances));
        for (mesh, &c) in meshes.zip(&closed) {
            if let Some(&(_, copy)) = copies.iter().find(|(i, _)| c && mesh.material() == Some(*i as u32)) {
                mesh.set_material(Some(copy));
            }
        }
    }
    if !names.is_empty() {
        warnings.push(if thin {
            format!(
                "material(s) {}: KHR_materials_transmission without KHR_materials_volume on closed meshes: thin-walled, as the specification reads it (--thin-glass)",
                names.join(", ")
            )
        } else {
            format!(
                "material(s) {}: KHR_materials_transmission without KHR_materials_volume on closed meshes: rendered as solid glass (index from KHR_materials_ior, else 1.5); --thin-glass keeps the specification's thin walls",
                names.join(", ")
            )
        });
    }
    solid
}

/// The object-space meshes of every placed object.
pub(crate) fn placed_meshes(instances: &mut [Instances]) -> impl Iterator<Item = &mut Mesh> {
    instances.iter_mut().flat_map(|i| i.meshes_mut().iter_mut())
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;

    /// A unit cube: 8 corners, 12 triangles, or 24 vertices (4 per face, split at the normal seams).
    fn cube(split: bool, faces: usize) -> Mesh {
        let corner = |i: u32| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32);
        let quads = [[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]];
        let (mut positions, mut indices) = (Vec::new(), Vec::new());
        for q in quads.iter().take(faces) {
            let ids: Vec<u32> = if split {
                let base = positions.len() as u32;
                positions.extend(q.iter().map(|&i| corner(i)));
                (base..base + 4).collect()
            } else {
                q.to_vec()
            };
            indices.push([ids[0], ids[1], ids[2]]);
            indices.push([ids[0], ids[2], ids[3]]);
        }
        if !split {
            positions = (0..8).map(corner).collect();
        }
        Mesh::new(positions, None, None, indices, Some(0)).unwrap()
    }

    #[test]
    fn a_cube_is_closed_welded_or_not_and_an_open_box_is_not() {
        assert!(is_closed(&cube(false, 6)));
        // Split at every face (as exporters write flat-shaded cubes): closed once welded.
        assert!(is_closed(&cube(true, 6)));
        // Five faces: the open side's four edges have one triangle each.
        assert!(!is_closed(&cube(false, 5)));
        assert!(!is_closed(&cube(true, 5)));
        // One triangle: every edge once.
        let one = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], None, None, vec![[0, 1, 2]], None).unwrap();
        assert!(!is_closed(&one));
    }

    #[test]
    fn glass_on_closed_meshes_is_solid_on_open_ones_thin_and_a_shared_material_is_split() {
        let glass = || {
            let mut d = MaterialDesc::new("glass", MaterialFormat::Gltf);
            d.transmission = Some(1.0);
            d
        };
        let mut volume = glass();
        volume.name = "volume".into();
        volume.thickness = Some(0.0);
        let run = |meshes: &mut Vec<Mesh>, thin: bool| {
            let mut descs = vec![glass(), volume.clone()];
            let mut warnings = Vec::new();
            let solid = solid_glass(meshes, &mut [], &mut descs, thin, &mut warnings);
            (solid, descs, warnings)
        };
        // Closed only: the material itself is solid; a volume material (thickness 0) is left to its extension.
        let mut closed = vec![cube(true, 6)];
        let (solid, descs, warnings) = run(&mut closed, false);
        assert_eq!((solid, descs.len()), (vec![true, false], 2));
        assert!(warnings[0].contains("'glass'") && warnings[0].contains("solid glass"), "{warnings:?}");
        // Open only: thin, no note.
        let (solid, _, warnings) = run(&mut vec![cube(true, 5)], false);
        assert_eq!(solid, vec![false, false]);
        assert!(warnings.is_empty());
        // Both: the closed mesh gets a solid copy, the open one keeps the thin original.
        let mut both = vec![cube(true, 5), cube(false, 6)];
        let (solid, descs, _) = run(&mut both, false);
        assert_eq!(solid, vec![false, false, true]);
        assert_eq!(descs[2].name, "glass (closed meshes)");
        assert_eq!((both[0].material(), both[1].material()), (Some(0), Some(2)));
        // --thin-glass: nothing solid, and the note says what was kept thin.
        let (solid, descs, warnings) = run(&mut vec![cube(false, 6)], true);
        assert_eq!((solid, descs.len()), (vec![false, false], 2));
        assert!(warnings[0].contains("--thin-glass"), "{warnings:?}");
    }
}
