//! MikkTSpace tangents for meshes a normal map shades but whose file gives none. glTF 2.0 (§3.7.2.1,
//! `TANGENT`): "When tangents are not specified, client implementations SHOULD calculate tangents
//! using default MikkTSpace algorithms with the specified vertex positions, normals, and texture
//! coordinates associated with the normal texture" — the frame the maps were baked in by Blender,
//! Substance and xNormal. Without it a hit falls back to its triangle's own ∂p/∂u
//! (`surface::surface_tangent`), which is MikkTSpace's starting point but not smoothed across
//! faces, so low-polygon curved surfaces show their facets through the normal map.
//!
//! MikkTSpace gives a tangent per triangle corner; corners that share a vertex get the same one
//! unless the uv mapping breaks there (a seam, mirrored uvs), where the vertex is split.

use std::collections::HashMap;

use geometry::Mesh;
use glam::{Vec2, Vec3, Vec4};

/// A mesh as MikkTSpace reads it, and the tangents it writes (one per corner).
struct Corners<'a> {
    mesh: &'a Mesh,
    uvs: &'a [Vec2],
    tangents: Vec<[f32; 4]>,
}

impl Corners<'_> {
    fn vertex(&self, face: usize, vert: usize) -> usize {
        self.mesh.indices()[face][vert] as usize
    }
}

impl mikktspace::Geometry for Corners<'_> {
    fn num_faces(&self) -> usize {
        self.mesh.triangle_count()
    }
    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }
    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.mesh.positions()[self.vertex(face, vert)].to_array()
    }
    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        match self.mesh.normals() {
            Some(n) => n[self.vertex(face, vert)].to_array(),
            None => {
                // Flat shading (glTF: no NORMAL means flat normals).
                let [a, b, c] = self.mesh.indices()[face].map(|i| self.mesh.positions()[i as usize]);
                (b - a).cross(c - a).normalize_or(Vec3::Z).to_array()
            }
        }
    }
    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        // glTF's v grows down the image and a normal map's +Y is up the image: MikkTSpace's
        // bitangent follows +v, so it is given −v (the convention of `surface_tangent`).
        let uv = self.uvs[self.vertex(face, vert)];
        [uv.x, -uv.y]
    }
    fn set_tangent_encoded(&mut self, tangent: [f32; 4], face: usize, vert: usize) {
        self.tangents[3 * face + vert] = tangent;
    }
}

/// `mesh` with MikkTSpace tangents (and vertices split where corners disagree), or `None` when it
/// has no uvs, already has tangents, or MikkTSpace fails (degenerate input): hits then use the
/// per-triangle frame.
pub(crate) fn with_mikktspace_tangents(mesh: &Mesh) -> Option<Mesh> {
    if mesh.tangents().is_some() {
        return None;
    }
    let uvs = mesh.uvs()?;
    let mut corners = Corners { mesh, uvs, tangents: vec![[0.0; 4]; 3 * mesh.triangle_count()] };
    if !mikktspace::generate_tangents(&mut corners) {
        return None;
    }
    let tangents: Vec<Vec4> = corners
        .tangents
        .iter()
        .map(|t| if t.iter().all(|v| v.is_finite()) { Vec4::from_array(*t) } else { Vec4::ZERO })
        .collect();
    // Each (vertex, tangent) pair becomes one vertex: the first pair of a vertex keeps its index,
    // later different ones are appended.
    let n = mesh.positions().len();
    let mut per_vertex: Vec<Option<Vec4>> = vec![None; n];
    let mut split: HashMap<(u32, [u32; 4]), u32> = HashMap::new();
    let mut extra: Vec<(u32, Vec4)> = Vec::new();
    let indices: Vec<[u32; 3]> = mesh
        .indices()
        .iter()
        .enumerate()
        .map(|(face, tri)| {
            std::array::from_fn(|k| {
                let (v, t) = (tri[k], tangents[3 * face + k]);
                match per_vertex[v as usize] {
                    None => {
                        per_vertex[v as usize] = Some(t);
                        v
                    }
                    Some(first) if first == t => v,
                    Some(_) => *split.entry((v, t.to_array().map(f32::to_bits))).or_insert_with(|| {
                        extra.push((v, t));
                        (n + extra.len() - 1) as u32
                    }),
                }
            })
        })
        .collect();
    let mut all: Vec<Vec4> = per_vertex.iter().map(|t| t.unwrap_or(Vec4::ZERO)).collect();
    all.extend(extra.iter().map(|&(_, t)| t));
    let result = if extra.is_empty() {
        mesh.clone()
    } else {
        let pick =
            |v: &[Vec3]| -> Vec<Vec3> { v.iter().copied().chain(extra.iter().map(|&(i, _)| v[i as usize])).collect() };
        let positions = pick(mesh.positions());
        let normals = mesh.normals().map(pick);
        let uvs = Some(uvs.iter().copied().chain(extra.iter().map(|&(i, _)| uvs[i as usize])).collect());
        let colors: Option<Vec<Vec4>> =
            mesh.colors().map(|c| c.iter().copied().chain(extra.iter().map(|&(i, _)| c[i as usize])).collect());
        let second: Option<Vec<Vec2>> =
            mesh.second_uvs().map(|s| s.iter().copied().chain(extra.iter().map(|&(i, _)| s[i as usize])).collect());
        let split = Mesh::new(positions, normals, uvs, indices, mesh.material()).ok()?;
        let split = match colors {
            Some(c) => split.with_colors(c).ok()?,
            None => split,
        };
        match second {
            Some(s) => split.with_second_uvs(s).ok()?,
            None => split,
        }
    };
    result.with_tangents(all).ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A strip around a quarter cylinder (radius 1, axis y, `segments` quads), u along the arc,
    /// v down the axis (glTF: v grows down the image), smooth normals.
    fn quarter_cylinder(segments: u32) -> Mesh {
        let mut positions = Vec::new();
        let mut normals = Vec::new();
        let mut uvs = Vec::new();
        for i in 0..=segments {
            let phi = std::f32::consts::FRAC_PI_2 * i as f32 / segments as f32;
            let n = Vec3::new(phi.sin(), 0.0, phi.cos());
            for (y, v) in [(1.0, 0.0), (-1.0, 1.0)] {
                positions.push(n + Vec3::new(0.0, y, 0.0));
                normals.push(n);
                uvs.push(Vec2::new(i as f32 / segments as f32, v));
            }
        }
        let indices =
            (0..segments).flat_map(|i| [[2 * i, 2 * i + 1, 2 * i + 3], [2 * i, 2 * i + 3, 2 * i + 2]]).collect();
        Mesh::new(positions, Some(normals), Some(uvs), indices, None).unwrap()
    }

    #[test]
    fn a_smooth_cylinder_gets_the_analytic_tangent_at_every_vertex_without_splits() {
        let mesh = quarter_cylinder(6);
        let out = with_mikktspace_tangents(&mesh).unwrap();
        assert_eq!(out.positions().len(), mesh.positions().len(), "no seam: no split");
        for (p, t) in out.positions().iter().zip(out.tangents().unwrap()) {
            // ∂p/∂u runs along the arc: (cos φ, 0, −sin φ) at the point (sin φ, y, cos φ).
            let want = Vec3::new(p.z, 0.0, -p.x).normalize();
            assert!((t.truncate() - want).length() < 1e-4, "{p}: {t} vs {want}");
            // Image up (−∂p/∂v) is +y; the bitangent n × t · w must point there.
            let n = Vec3::new(p.x, 0.0, p.z).normalize();
            assert!((n.cross(t.truncate()) * t.w).y > 0.99, "{p}: w = {}", t.w);
        }
    }

    #[test]
    fn the_sign_matches_the_per_triangle_frame_and_mirrored_uvs_split_the_seam() {
        // Two triangles sharing an edge, the second with its uvs mirrored in u: the shared vertices
        // need opposite bitangent signs, so they are split.
        let positions = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
        ];
        let uvs = vec![Vec2::new(0.0, 1.0), Vec2::new(0.0, 0.0), Vec2::new(-1.0, 1.0), Vec2::new(-1.0, 1.0)];
        let normals = vec![Vec3::Z; 4];
        let mesh = Mesh::new(positions, Some(normals), Some(uvs), vec![[0, 1, 2], [0, 3, 1]], None).unwrap();
        let out = with_mikktspace_tangents(&mesh).unwrap();
        assert_eq!(out.positions().len(), 6, "vertices 0 and 1 split");
        let t = out.tangents().unwrap();
        for (tri, u_sign) in out.indices().iter().zip([1.0f32, -1.0]) {
            for &v in tri {
                let t = t[v as usize];
                // Left triangle: u grows towards +x; right (mirrored): towards −x. Up the image is +y.
                assert!((t.truncate() - Vec3::new(u_sign, 0.0, 0.0)).length() < 1e-4, "{v}: {t}");
                assert!((Vec3::Z.cross(t.truncate()) * t.w).y > 0.99, "{v}: {t}");
            }
        }
    }
}
