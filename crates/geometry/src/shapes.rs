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
    /// Per-vertex tangents (xyz) and bitangent sign (w), as glTF's `TANGENT` gives them.
    tangents: Option<Vec<Vec4>>,
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
        Ok(Self { positions, normals, uvs, tangents: None, indices, material })
    }

    /// The mesh with per-vertex tangents (xyz, and the bitangent sign in w: glTF `TANGENT`);
    /// rejects a count differing from the positions' or a non-finite value.
    pub fn with_tangents(mut self, tangents: Vec<Vec4>) -> Result<Self> {
        if tangents.len() != self.positions.len() {
            return Err(Error::Invalid(format!("{} tangents for {} positions", tangents.len(), self.positions.len())));
        }
        if let Some(i) = tangents.iter().position(|v| !v.is_finite()) {
            return Err(Error::Invalid(format!("vertex {i} tangent {:?} is not finite", tangents[i])));
        }
        self.tangents = Some(tangents);
        Ok(self)
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
        m.tangents.clone_from(&self.tangents);
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
            tangents,
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
