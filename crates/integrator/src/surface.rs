//! Per-hit surface data the hit record does not carry, read back from the mesh only where a
//! material needs it: tangents for normal maps.

use geometry::{Hit, Mesh, Scene};
use glam::{Vec2, Vec3, Vec4};

/// The tangent frame (T, B) about the unit shading normal `ns` of a tangent with its bitangent's sign in w
/// ([`surface_tangent`]): T the tangent made orthogonal to `ns` (Gram–Schmidt: the interpolated tangent is
/// not exactly orthogonal), B = `ns` × T · sign(w), as glTF defines it. `None` for a tangent along `ns`.
#[inline]
pub(crate) fn tangent_frame(tangent: Vec4, ns: Vec3) -> Option<(Vec3, Vec3)> {
    let t = (tangent.truncate() - ns * ns.dot(tangent.truncate())).try_normalize()?;
    Some((t, ns.cross(t) * if tangent.w < 0.0 { -1.0 } else { 1.0 }))
}

/// The uvs of triangle `triangle`'s vertices in the mesh's primary set, or its second set with `second`
/// where it has one; else the barycentric corners (0, 0), (1, 0), (0, 1) (what a hit's uv is without them).
pub(crate) fn triangle_uvs(mesh: &Mesh, triangle: usize, second: bool) -> [Vec2; 3] {
    let tri = mesh.indices()[triangle];
    match mesh.second_uvs().filter(|_| second).or(mesh.uvs()) {
        Some(uvs) => tri.map(|i| uvs[i as usize]),
        None => [Vec2::ZERO, Vec2::X, Vec2::Y],
    }
}

/// [`surface_tangent`] of one hit, computed on first use and kept: the coat's normal map, the
/// base's and the anisotropy direction may each ask for it at the same hit.
pub(crate) struct HitTangent<'a> {
    scene: &'a Scene,
    hit: &'a Hit,
    value: std::cell::OnceCell<Option<Vec4>>,
}

impl<'a> HitTangent<'a> {
    pub(crate) fn new(scene: &'a Scene, hit: &'a Hit) -> Self {
        Self { scene, hit, value: std::cell::OnceCell::new() }
    }

    pub(crate) fn get(&self) -> Option<Vec4> {
        *self.value.get_or_init(|| surface_tangent(self.scene, self.hit))
    }

    /// ∂p/∂u and ∂p/∂v at the hit ([`uv_derivatives`]), for a bump map (asked once per hit: not kept).
    pub(crate) fn uv_derivatives(&self) -> Option<(Vec3, Vec3)> {
        uv_derivatives(self.scene, self.hit)
    }
}

/// The hit's uv in its mesh's second set (the barycentric blend of its vertices'); `None` for spheres and
/// meshes with one set. Out of line: only materials with a texture on a second set ask.
#[inline(never)]
pub(crate) fn second_uv(scene: &Scene, hit: &Hit) -> Option<Vec2> {
    let at = scene.hit_triangle(hit)?;
    let uvs = at.mesh.second_uvs()?;
    let (tri, [b0, b1, b2]) = (at.vertices(), at.barycentrics(hit.p)?);
    Some(b0 * uvs[tri[0]] + b1 * uvs[tri[1]] + b2 * uvs[tri[2]])
}

/// ∂p/∂u and ∂p/∂v of the hit's triangle (constant over it) from its vertices' uvs: `None` for spheres,
/// meshes without uvs, and uvs that are collinear or give a non-finite derivative (in world space on a placed
/// instance).
pub(crate) fn uv_derivatives(scene: &Scene, hit: &Hit) -> Option<(Vec3, Vec3)> {
    let at = scene.hit_triangle(hit)?;
    let (dpdu, dpdv) = triangle_derivatives(at.mesh, at.vertices())?;
    (dpdu.is_finite() && dpdv.is_finite()).then(|| (at.vector_to_world(dpdu), at.vector_to_world(dpdv)))
}

/// ∂p/∂u and ∂p/∂v of a triangle from its uvs (`None` for collinear uvs; the callers check finiteness).
fn triangle_derivatives(mesh: &Mesh, tri: [usize; 3]) -> Option<(Vec3, Vec3)> {
    let (p, uv) = (mesh.positions(), mesh.uvs()?);
    let (d1, d2) = (uv[tri[1]] - uv[tri[0]], uv[tri[2]] - uv[tri[0]]);
    let det = d1.x * d2.y - d2.x * d1.y;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let (e1, e2) = (p[tri[1]] - p[tri[0]], p[tri[2]] - p[tri[0]]);
    let dpdu = (e1 * d2.y - e2 * d1.y) / det;
    let dpdv = (e2 * d1.x - e1 * d2.x) / det;
    Some((dpdu, dpdv))
}

/// The tangent at a triangle hit, with the sign of the bitangent that points "up" the image (glTF:
/// +Y of a normal map, towards decreasing v) in w: the mesh's `TANGENT` interpolated, else the
/// triangle's ∂p/∂u from its UVs (the per-face frame MikkTSpace starts from; it differs from
/// MikkTSpace's per-vertex averaging only across faces); on a placed instance, taken to world space. `None` for
/// spheres, or without UVs.
pub(crate) fn surface_tangent(scene: &Scene, hit: &Hit) -> Option<Vec4> {
    let at = scene.hit_triangle(hit)?;
    let tri = at.vertices();
    if let Some(tangents) = at.mesh.tangents() {
        let [b0, b1, b2] = at.barycentrics(hit.p)?;
        let t = tangents[tri[0]] * b0 + tangents[tri[1]] * b1 + tangents[tri[2]] * b2;
        // A mirroring placement flips the frame's handedness (B = N × T · w in world space).
        let w = if at.mirrored() { -tangents[tri[0]].w } else { tangents[tri[0]].w };
        return Some(at.vector_to_world(t.truncate()).extend(w));
    }
    let (dpdu, dpdv) = triangle_derivatives(at.mesh, tri)?;
    let (dpdu, dpdv) = (at.vector_to_world(dpdu), at.vector_to_world(dpdv));
    // Image up is −∂p/∂v in glTF's uv (v grows down the image).
    let sign = if hit.ns.cross(dpdu).dot(-dpdv) < 0.0 { -1.0 } else { 1.0 };
    dpdu.is_finite().then(|| dpdu.extend(sign))
}
