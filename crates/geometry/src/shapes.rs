//! The primitives: triangle meshes and analytic spheres, validated on construction.

use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};

use crate::error::{Error, Result};

/// A triangle mesh in world space. Constructed only through [`Mesh::new`], so positions and
/// normals are finite and every index is in range.
#[derive(Debug, Clone)]
pub struct Mesh {
    positions: Vec<Vec3>,
    normals: Option<Vec<Vec3>>,
    uvs: Option<Vec<Vec2>>,
    /// A second uv set: the other TEXCOORD set its material's textures address (glTF `texCoord` 1 beside
    /// 0, say), for those textures.
    second_uvs: Option<Vec<Vec2>>,
    /// Per-vertex tangents (xyz) and bitangent sign (w), as glTF's `TANGENT` gives them.
    tangents: Option<Vec<Vec4>>,
    /// Per-vertex linear RGBA (glTF `COLOR_0`, OBJ `v x y z r g b`), multiplying the base colour.
    colors: Option<Vec<Vec4>>,
    indices: Vec<[u32; 3]>,
    material: Option<u32>,
}

impl Mesh {
    /// A mesh; rejects NaN/Inf positions or normals, indices out of range, and normal or UV
    /// arrays whose length differs from the positions'.
    pub fn new(
        positions: Vec<Vec3>,
        normals: Option<Vec<Vec3>>,
        uvs: Option<Vec<Vec2>>,
        indices: Vec<[u32; 3]>,
        material: Option<u32>,
    ) -> Result<Self> {
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(Error::Invalid(format!("vertex {i} position {:?} is not finite", positions[i])));
        }
        if let Some(n) = &normals {
            if n.len() != positions.len() {
                return Err(Error::Invalid(format!("{} normals for {} positions", n.len(), positions.len())));
            }
            if let Some(i) = n.iter().position(|v| !v.is_finite()) {
                return Err(Error::Invalid(format!("vertex {i} normal {:?} is not finite", n[i])));
            }
        }
        if let Some(uv) = &uvs {
            if uv.len() != positions.len() {
                return Err(Error::Invalid(format!("{} UVs for {} positions", uv.len(), positions.len())));
            }
            if let Some(i) = uv.iter().position(|v| !v.is_finite()) {
                return Err(Error::Invalid(format!("vertex {i} UV {:?} is not finite", uv[i])));
            }
        }
        if let Some((t, tri)) =
            indices.iter().enumerate().find(|(_, tri)| tri.iter().any(|&i| i as usize >= positions.len()))
        {
            return Err(Error::Invalid(format!(
                "triangle {t} indices {tri:?} out of range ({} vertices)",
                positions.len()
            )));
        }
        Ok(Self { positions, normals, uvs, second_uvs: None, tangents: None, colors: None, indices, material })
    }

    /// The mesh with a second uv set ([`Mesh::second_uvs`]); rejects a count differing from the positions'
    /// or a non-finite value.
    pub fn with_second_uvs(mut self, uvs: Vec<Vec2>) -> Result<Self> {
        if uvs.len() != self.positions.len() {
            return Err(Error::Invalid(format!("{} second UVs for {} positions", uvs.len(), self.positions.len())));
        }
        if let Some(i) = uvs.iter().position(|v| !v.is_finite()) {
            return Err(Error::Invalid(format!("vertex {i} second UV {:?} is not finite", uvs[i])));
        }
        self.second_uvs = Some(uvs);
        Ok(self)
    }

    /// The second uv set, if the mesh has one: what textures on the material's other TEXCOORD set read.
    pub fn second_uvs(&self) -> Option<&[Vec2]> {
        self.second_uvs.as_deref()
    }

    /// The mesh with per-vertex tangents (xyz, and the bitangent sign in w: glTF `TANGENT`);
    /// rejects a count differing from the positions' or a non-finite value.
    pub fn with_tangents(mut self, tangents: Vec<Vec4>) -> Result<Self> {
        self.check_per_vertex(&tangents, "tangent")?;
        self.tangents = Some(tangents);
        Ok(self)
    }

    /// The mesh with per-vertex colours (linear RGBA, glTF `COLOR_0`); rejects a count differing
    /// from the positions' or a non-finite value.
    pub fn with_colors(mut self, colors: Vec<Vec4>) -> Result<Self> {
        self.check_per_vertex(&colors, "colour")?;
        self.colors = Some(colors);
        Ok(self)
    }

    /// One `what` per vertex, all finite.
    fn check_per_vertex(&self, values: &[Vec4], what: &str) -> Result<()> {
        if values.len() != self.positions.len() {
            return Err(Error::Invalid(format!("{} {what}s for {} positions", values.len(), self.positions.len())));
        }
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(Error::Invalid(format!("vertex {i} {what} {:?} is not finite", values[i])));
        }
        Ok(())
    }

    /// Vertex colours (linear RGBA), if the mesh has them.
    pub fn colors(&self) -> Option<&[Vec4]> {
        self.colors.as_deref()
    }

    /// The vertex colour of triangle `triangle` at barycentrics `b` (weights of its three vertices),
    /// interpolated as UVs are; `None` without vertex colours or for a triangle out of range.
    #[cfg(test)]
    pub(crate) fn color_at(&self, triangle: usize, b: [f32; 3]) -> Option<Vec4> {
        let colors = self.colors.as_deref()?;
        let tri = self.indices.get(triangle)?;
        Some(b[0] * colors[tri[0] as usize] + b[1] * colors[tri[1] as usize] + b[2] * colors[tri[2] as usize])
    }

    /// Vertex positions.
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }
    /// Vertex normals, if the mesh has them.
    pub fn normals(&self) -> Option<&[Vec3]> {
        self.normals.as_deref()
    }
    /// Vertex texture coordinates, if the mesh has them.
    pub fn uvs(&self) -> Option<&[Vec2]> {
        self.uvs.as_deref()
    }
    /// The same vertices and attributes with other triangles (fewer, or the winding reversed);
    /// rejects indices out of range.
    pub fn with_indices(&self, indices: Vec<[u32; 3]>) -> Result<Self> {
        let mut m = Self::new(self.positions.clone(), None, None, indices, self.material)?;
        m.normals.clone_from(&self.normals);
        m.uvs.clone_from(&self.uvs);
        m.second_uvs.clone_from(&self.second_uvs);
        m.tangents.clone_from(&self.tangents);
        m.colors.clone_from(&self.colors);
        Ok(m)
    }

    /// Vertex tangents with the bitangent sign in w, if the mesh has them.
    pub fn tangents(&self) -> Option<&[Vec4]> {
        self.tangents.as_deref()
    }
    /// Triangles as vertex indices.
    pub fn indices(&self) -> &[[u32; 3]] {
        &self.indices
    }
    /// Material index, if any.
    pub fn material(&self) -> Option<u32> {
        self.material
    }
    /// Replace the material index.
    pub fn set_material(&mut self, material: Option<u32>) {
        self.material = material;
    }
    /// Number of triangles.
    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    /// The mesh transformed by `m`: positions and tangents by `m`, normals by its inverse
    /// transpose, the bitangent sign flipped by a mirroring `m` (cross products change sign). The
    /// winding is kept as it is: a caller applying a mirroring transform (negative
    /// determinant) decides whether to reverse it (the loaders do, as glTF requires).
    pub fn transformed(&self, m: Mat4) -> Self {
        let normal_matrix = Mat3::from_mat4(m).inverse().transpose();
        let positions = self.positions.iter().map(|&p| m.transform_point3(p)).collect();
        let normals =
            self.normals.as_ref().map(|n| n.iter().map(|&v| (normal_matrix * v).normalize_or_zero()).collect());
        let linear = Mat3::from_mat4(m);
        let sign = linear.determinant().signum();
        let tangents = self.tangents.as_ref().map(|t| {
            t.iter().map(|&v| (linear * v.truncate()).normalize_or_zero().extend(v.w.signum() * sign)).collect()
        });
        Self {
            positions,
            normals,
            uvs: self.uvs.clone(),
            second_uvs: self.second_uvs.clone(),
            tangents,
            colors: self.colors.clone(),
            indices: self.indices.clone(),
            material: self.material,
        }
    }
}

/// An analytic sphere (the paper's scenes are spheres: kept exact, not tessellated).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    center: Vec3,
    radius: f32,
    material: Option<u32>,
}

impl Sphere {
    /// A sphere; the centre must be finite and the radius finite and positive.
    pub fn new(center: Vec3, radius: f32, material: Option<u32>) -> Result<Self> {
        if !center.is_finite() {
            return Err(Error::Invalid(format!("sphere centre {center:?} is not finite")));
        }
        if !(radius > 0.0 && radius.is_finite()) {
            return Err(Error::Invalid(format!("sphere radius {radius} must be finite and > 0")));
        }
        Ok(Self { center, radius, material })
    }
    /// Centre.
    pub fn center(&self) -> Vec3 {
        self.center
    }
    /// Radius.
    pub fn radius(&self) -> f32 {
        self.radius
    }
    /// Material index, if any.
    pub fn material(&self) -> Option<u32> {
        self.material
    }
}

/// One object placed several times: its meshes (the primitives of one glTF mesh) in object space and an
/// object-to-world transform per placement. The BVH keeps one copy of the meshes and a top-level
/// structure over the placements (two levels), instead of a world-space copy per placement.
#[derive(Debug, Clone)]
pub struct Instances {
    meshes: Vec<Mesh>,
    transforms: Vec<Mat4>,
}

impl Instances {
    /// The meshes placed by each transform; every transform must be finite with a non-zero determinant
    /// (a mirroring one is fine: normals are transformed by the inverse transpose, so they face as in
    /// a world-space copy whose winding the loader reversed).
    pub fn new(meshes: Vec<Mesh>, transforms: Vec<Mat4>) -> Result<Self> {
        if let Some(i) = transforms.iter().position(|m| {
            let det = m.determinant();
            !(m.is_finite() && det.is_finite() && det != 0.0)
        }) {
            return Err(Error::Invalid(format!("instance {i}: transform is singular or not finite")));
        }
        Ok(Self { meshes, transforms })
    }
    /// Add a placement (finite, non-singular).
    pub fn push_transform(&mut self, m: Mat4) -> Result<()> {
        let det = m.determinant();
        if !(m.is_finite() && det.is_finite() && det != 0.0) {
            return Err(Error::Invalid("instance transform is singular or not finite".to_owned()));
        }
        self.transforms.push(m);
        Ok(())
    }
    /// The object-space meshes.
    pub fn meshes(&self) -> &[Mesh] {
        &self.meshes
    }
    /// The object-space meshes, to change in place (the assembly adds tangents where normal maps need them).
    pub fn meshes_mut(&mut self) -> &mut [Mesh] {
        &mut self.meshes
    }
    /// Replace the meshes (e.g. after removing unhittable triangles).
    pub fn set_meshes(&mut self, meshes: Vec<Mesh>) {
        self.meshes = meshes;
    }
    pub(crate) fn take_meshes(&mut self) -> Vec<Mesh> {
        std::mem::take(&mut self.meshes)
    }
    /// Object-to-world transforms, one per placement.
    pub fn transforms(&self) -> &[Mat4] {
        &self.transforms
    }
    /// Triangles of one placement.
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(Mesh::triangle_count).sum()
    }
    /// World-space bounds of every placement, `None` without triangles.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let (lo, hi) = self.object_bounds()?;
        let mut out = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for m in &self.transforms {
            let (a, b) = transform_bounds(*m, lo, hi);
            out = (out.0.min(a), out.1.max(b));
        }
        Some(out)
    }
    /// Object-space bounds of the meshes' vertices, `None` without any.
    pub(crate) fn object_bounds(&self) -> Option<(Vec3, Vec3)> {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for p in self.meshes.iter().flat_map(|m| m.positions()) {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        (lo.x <= hi.x).then_some((lo, hi))
    }
}

/// The axis-aligned box around the eight transformed corners of `lo`–`hi`.
pub(crate) fn transform_bounds(m: Mat4, lo: Vec3, hi: Vec3) -> (Vec3, Vec3) {
    let mut out = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for i in 0..8 {
        let c = Vec3::new(
            if i & 1 == 0 { lo.x } else { hi.x },
            if i & 2 == 0 { lo.y } else { hi.y },
            if i & 4 == 0 { lo.z } else { hi.z },
        );
        let p = m.transform_point3(c);
        out = (out.0.min(p), out.1.max(p));
    }
    out
}

/// Which mesh holds triangle `t` (an index among all triangles of a list of meshes) and its index
/// within that mesh, given each mesh's first triangle (`first[0] = 0`, ascending; a trailing total
/// is allowed). A binary search over a few entries, not a per-triangle table, which would cost a
/// cache miss per hit on large meshes.
#[inline]
pub(crate) fn locate_triangle(first: &[usize], t: usize) -> (usize, usize) {
    let mesh = first.partition_point(|&o| o <= t) - 1;
    (mesh, t - first[mesh])
}
