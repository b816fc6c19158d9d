//! `geometry`: where rays meet surfaces.
//!
//! Rays and hit records, analytic spheres and triangle meshes, a watertight ray–triangle
//! test (Woop, Benthin & Wald 2013), robust secondary-ray offsets (pbrt-v4), a BVH built with
//! obvhs, a pinhole camera, and loaders for glTF 2.0, OBJ/MTL and the scene manifest.
//!
//! **Invariant:** depends on no workspace crate and knows nothing of colour. Material and
//! light descriptions go up as plain data (numbers, names, raw JSON `extras`); hits report
//! primitive and material indices.
//!
//! ```
//! use geometry::{Ray, Scene, Sphere};
//! use glam::Vec3;
//!
//! let scene = Scene::build(vec![Sphere::new(Vec3::ZERO, 1.0, None)?], Vec::new())?;
//! let hit = scene.intersect(&Ray { origin: Vec3::new(0.0, 0.0, 5.0), dir: Vec3::NEG_Z }, f32::INFINITY).unwrap();
//! assert!((hit.t - 4.0).abs() < 1e-6);
//! assert_eq!(hit.n, Vec3::Z);
//! # Ok::<(), geometry::Error>(())
//! ```
#![warn(missing_docs)]

mod bvh;
mod camera;
mod error;
mod ray;
mod sah;
mod shapes;
mod simd;
mod sphere;
mod triangle;
mod wide;

/// Numbers for tests: a seeded LCG's uniform values in [0, 1), 24 bits each.
#[cfg(test)]
pub(crate) fn test_uniform(seed: u64) -> impl FnMut() -> f32 {
    let mut state = seed;
    move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 40) as f32 / (1u64 << 24) as f32
    }
}

pub use bvh::{BvhStats, HitTriangle, Primitive, Scene, barycentrics};
pub use camera::Camera;
pub use error::{Error, Result};
pub use ray::{Hit, Ray, ShadowRay, spawn_ray, spawn_ray_to, spawn_shadow_ray};
pub use shapes::{Instances, Mesh, Sphere};
pub use simd::SimdLevel;

// --- loaders, layered without cycles: `desc` (plain types) and `limits` (budget, file and coordinate
// rules) at the bottom ← `forms` (value forms shared by the manifest and glTF extras) ← `manifest`,
// `gltf_loader`, `obj_loader` (none uses another) ← `load` (dispatch, includes, then `prefilter`) ---
mod desc;
mod forms;
mod gltf_loader;
mod hash;
mod limits;
mod load;
mod manifest;
mod obj_loader;
mod obj_plain;
mod overrides;
mod photometry;
mod prefilter;
pub use desc::{
    AbsorptionDesc, AlphaMode, AnisotropyLayer, CameraDesc, Clearcoat, EnvironmentMapDesc, FluorescenceDesc, ImageDesc,
    IorDesc, LightAmount, LightDesc, LightUnit, MaterialDesc, MaterialFormat, MaterialTextures, PhotometricFormat,
    PhotometricWeb, Projection, SceneDescription, SceneFormat, Settings, SheenLayer, SpectrumDesc, SpecularLayer,
    TextureDesc, TextureTransform, WebSymmetry, WrapMode,
};
pub use hash::xxh64;
pub use limits::{DEFAULT_FLATTEN_TRIANGLES, DEFAULT_MAX_MEMORY, LoadOptions, MAX_COORDINATE, MemoryBudget};
pub use load::{load_scene, load_scene_with, parse_manifest, parse_manifest_with};
pub use overrides::{Override, Variation};
