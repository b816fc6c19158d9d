//! The top of the loader stack: [`load_scene`] reads a scene file by its extension, loads the mesh files a
//! manifest includes, and removes what cannot be hit. Nothing is interpreted here either (no default
//! camera or light: those are the integrator's assembly's); the description says what the files say.
//!
//! Module layering (no cycles): `desc` (plain types) and `limits` ← `forms` ← `manifest`, `gltf_loader`,
//! `obj_loader` ← `load`, which also runs `prefilter`.

use std::path::Path;

use glam::{Mat4, Vec3};

use crate::desc::{LightDesc, SceneDescription};
use crate::error::{Error, Result};
use crate::limits::{Budget, LoadOptions, check_coordinates};
use crate::manifest::Include;
use crate::shapes::Mesh;

/// Loads a scene by its extension — `.json` (manifest), `.gltf`/`.glb`, `.obj` (+ `.mtl`) — with the default
/// [`LoadOptions`].
///
/// # Errors
/// See [`load_scene_with`].
pub fn load_scene(path: &Path) -> Result<SceneDescription> {
    load_scene_with(path, &LoadOptions::default())
}

/// Loads a scene by its extension within the budget and file rules of `options`.
///
/// A glTF or OBJ file must contain geometry ([`Error::NoGeometry`] otherwise); a manifest gets exactly what
/// it says. Zero-area and exactly duplicated triangles are removed, with a warning: the watertight test
/// never hits a zero-area triangle, and of exact copies (same positions, winding and material) the
/// closest hit keeps the first found, so neither can change an image, while left in they make the BVH
/// build quadratic.
///
/// # Errors
/// [`Error::UnsupportedFormat`] for another extension, [`Error::OverBudget`] when the scene's data would pass
/// `options.max_memory`, the file-rule errors ([`Error::NotRegularFile`], [`Error::FileTooLarge`],
/// [`Error::AbsolutePath`]), [`Error::CoordinateTooLarge`], and the errors of each format, each naming the
/// file.
pub fn load_scene_with(path: &Path, options: &LoadOptions) -> Result<SceneDescription> {
    let budget = Budget::new(options.clone());
    let extension = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default();
    let desc = match extension.as_str() {
        "json" => {
            let bytes = budget.read(path, path)?;
            let text = String::from_utf8(bytes).map_err(|e| Error::ReadFile {
                path: path.to_path_buf(),
                cause: std::io::Error::new(std::io::ErrorKind::InvalidData, e.utf8_error()),
            })?;
            let base = path.parent().unwrap_or_else(|| Path::new("."));
            manifest(&text, base, &path.display().to_string(), &budget)?
        }
        _ if !options.variation.is_empty() && matches!(extension.as_str(), "gltf" | "glb" | "obj") => {
            return Err(Error::VariationNeedsManifest { path: path.to_path_buf() });
        }
        "gltf" | "glb" => crate::gltf_loader::load_gltf_file(path, &budget)?,
        "obj" => crate::obj_loader::load_obj_file(path, &budget)?,
        _ => return Err(Error::UnsupportedFormat { path: path.to_path_buf(), extension }),
    };
    let mut desc = finish(desc, &path.display().to_string());
    desc.source_hash = budget.content_hash();
    desc.source_files = budget.files();
    desc.memory = budget.memory();
    if extension == "json" { Ok(desc) } else { require_geometry(desc, path) }
}

/// Parses a manifest from text with the default [`LoadOptions`]. `base_dir` resolves relative file paths
/// (spectra CSVs, meshes); `origin` names the manifest in error messages (a path, or e.g.
/// `"<embedded default scene>"`).
///
/// # Errors
/// [`Error::ManifestSyntax`] for malformed JSON or an unknown key (the message names the key, line and
/// column), [`Error::ManifestValue`] for a value out of range (with its path in the document),
/// [`Error::MissingMaterial`] for an object naming a material that is not defined, and
/// [`Error::IncludedFile`] (naming the manifest and the object) for a mesh file that cannot be loaded.
pub fn parse_manifest(text: &str, base_dir: &Path, origin: &str) -> Result<SceneDescription> {
    parse_manifest_with(text, base_dir, origin, &LoadOptions::default())
}

/// [`parse_manifest`] within the budget and file rules of `options`.
///
/// # Errors
/// As [`parse_manifest`], and the budget and file-rule errors of [`load_scene_with`].
pub fn parse_manifest_with(
    text: &str,
    base_dir: &Path,
    origin: &str,
    options: &LoadOptions,
) -> Result<SceneDescription> {
    let budget = Budget::new(options.clone());
    budget.record(text.as_bytes());
    let mut desc = finish(manifest(text, base_dir, origin, &budget)?, origin);
    desc.source_hash = budget.content_hash();
    desc.source_files = budget.files();
    desc.memory = budget.memory();
    Ok(desc)
}

fn manifest(text: &str, base_dir: &Path, origin: &str, budget: &Budget) -> Result<SceneDescription> {
    let (mut desc, includes) = crate::manifest::parse(text, base_dir, origin, budget)?;
    // Meshes included so far, which shift the later includes' positions.
    let mut inserted = 0;
    for include in includes {
        let context = include.context.clone();
        let at = include.position + inserted;
        let before = desc.meshes.len();
        include_file(&mut desc, include, budget).map_err(|cause| Error::IncludedFile {
            origin: origin.to_owned(),
            context,
            cause: Box::new(cause),
        })?;
        // include_file appends; rotate the new meshes to where the object stands in the manifest.
        let added = desc.meshes.len() - before;
        desc.meshes[at..].rotate_right(added);
        inserted += added;
    }
    Ok(desc)
}

fn require_geometry(desc: SceneDescription, path: &Path) -> Result<SceneDescription> {
    let instanced = desc.instances.iter().any(|i| i.triangle_count() > 0 && !i.transforms().is_empty());
    if desc.meshes.iter().any(|m| m.triangle_count() > 0) || !desc.spheres.is_empty() || instanced {
        return Ok(desc);
    }
    let detail = match std::fs::metadata(path) {
        Ok(m) if m.len() == 0 => "; the file is empty".to_owned(),
        // The loader's notes say why (skipped primitives, unknown statements, removed triangles).
        _ => desc.warnings.iter().map(|w| format!("; {w}")).collect(),
    };
    Err(Error::NoGeometry { path: path.to_path_buf(), detail })
}

/// Removes unhittable triangles, with a warning naming the file.
fn finish(mut desc: SceneDescription, origin: &str) -> SceneDescription {
    let (meshes, mut removed) = crate::prefilter::remove_unhittable(std::mem::take(&mut desc.meshes));
    desc.meshes = meshes;
    for instance in &mut desc.instances {
        let (meshes, r) = crate::prefilter::remove_unhittable(instance.take_meshes());
        instance.set_meshes(meshes);
        removed.degenerate += r.degenerate;
        removed.duplicates += r.duplicates;
    }
    if removed.degenerate > 0 || removed.duplicates > 0 {
        desc.warnings.push(format!(
            "{origin}: {} zero-area and {} duplicate triangle(s) removed (they cannot be hit)",
            removed.degenerate, removed.duplicates
        ));
    }
    desc
}

/// Loads a glTF/OBJ file a manifest includes into `desc`, transformed by the include's matrix.
fn include_file(desc: &mut SceneDescription, include: Include, budget: &Budget) -> Result<()> {
    let Include { path, matrix, material: material_override, .. } = include;
    let extension = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default();
    let sub = if extension == "obj" {
        crate::obj_loader::load_obj_file(&path, budget)?
    } else {
        crate::gltf_loader::load_gltf_file(&path, budget)?
    };
    let sub = require_geometry(sub, &path)?;
    // Material counts are tiny compared with u32::MAX.
    let offset = desc.materials.len() as u32;
    // A mirroring transform turns outward faces inward; reversing the winding keeps geometric normals
    // outward (as glTF 2.0 §3.7.4 requires for node transforms), which refraction relies on.
    // `Mesh::transformed` keeps the winding as it is.
    let mirrored = matrix.determinant() < 0.0;
    let use_file_materials = material_override.is_none();
    for mut mesh in sub.meshes {
        let m = if use_file_materials { mesh.material().map(|i| i + offset) } else { material_override };
        mesh.set_material(m);
        let mesh = if matrix == Mat4::IDENTITY { mesh } else { mesh.transformed(matrix) };
        // The transform may carry a valid file beyond the coordinates the renderer supports.
        check_coordinates(mesh.positions(), &path, "after the manifest's transform")?;
        desc.meshes.push(if mirrored { reverse_winding(&mesh, &path)? } else { mesh });
    }
    // Meshes the file places several times (instances) follow their placements under the include's matrix.
    // (Before, they were dropped: a manifest including such a file rendered without them, silently.)
    for mut instance in sub.instances {
        for mesh in instance.meshes_mut() {
            let m = if use_file_materials { mesh.material().map(|i| i + offset) } else { material_override };
            mesh.set_material(m);
        }
        if matrix != Mat4::IDENTITY {
            let transforms = instance.transforms().iter().map(|t| matrix * *t).collect();
            instance =
                crate::Instances::new(instance.take_meshes(), transforms).map_err(|e| Error::InvalidGeometry {
                    path: path.clone(),
                    context: "instances after the manifest's transform".to_owned(),
                    cause: Box::new(e),
                })?;
        }
        if let Some((lo, hi)) = instance.bounds() {
            check_coordinates(&[lo, hi], &path, "instances after the manifest's transform (their placements' bounds)")?;
        }
        desc.instances.push(instance);
    }
    if use_file_materials {
        // The file's images follow the manifest's, so its textures' image indices shift too.
        let image_offset = desc.images.len();
        // Every role: before, only the five core ones were shifted, so an extension's texture (transmission,
        // specular, clear coat, sheen, anisotropy) of a second included file read the first file's image.
        for mut m in sub.materials {
            for texture in m.textures.roles_mut().into_iter().flatten() {
                texture.image += image_offset;
            }
            desc.materials.push(m);
        }
        desc.images.extend(sub.images);
    }
    for light in sub.lights {
        desc.lights.push(transform_light(light, matrix));
    }
    if sub.camera.is_some() {
        desc.warnings.push(format!("{}: the file's camera is ignored (the manifest's is used)", path.display()));
    }
    desc.warnings.extend(sub.warnings);
    Ok(())
}

fn reverse_winding(mesh: &Mesh, path: &Path) -> Result<Mesh> {
    let indices = mesh.indices().iter().map(|[a, b, c]| [*a, *c, *b]).collect();
    mesh.with_indices(indices).map_err(|e| Error::InvalidGeometry {
        path: path.to_path_buf(),
        context: "mirrored mesh".to_owned(),
        cause: Box::new(e),
    })
}

fn transform_light(light: LightDesc, m: Mat4) -> LightDesc {
    let dir = |d: Vec3| m.transform_vector3(d).try_normalize().unwrap_or(d);
    match light {
        LightDesc::Point { position, spectrum, intensity } => {
            LightDesc::Point { position: m.transform_point3(position), spectrum, intensity }
        }
        LightDesc::Spot { position, direction, inner_cone_deg, outer_cone_deg, spectrum, intensity } => {
            LightDesc::Spot {
                position: m.transform_point3(position),
                direction: dir(direction),
                inner_cone_deg,
                outer_cone_deg,
                spectrum,
                intensity,
            }
        }
        LightDesc::Directional { direction, spectrum, intensity } => {
            LightDesc::Directional { direction: dir(direction), spectrum, intensity }
        }
        LightDesc::Luminaire { position, direction, up, spectrum, scale, web } => {
            let direction = dir(direction);
            // Kept perpendicular to the nadir (a shear would tilt it); the old C0 if the transform folds it onto it.
            let up = dir(up).reject_from_normalized(direction).try_normalize().unwrap_or(up);
            LightDesc::Luminaire { position: m.transform_point3(position), direction, up, spectrum, scale, web }
        }
        env @ LightDesc::Environment { .. } => env,
    }
}

#[cfg(test)]
#[path = "load_fuzz_tests.rs"]
mod fuzz_tests;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mirrored_mesh_keeps_outward_winding() {
        let dir = std::env::temp_dir().join("spectrace-geometry-manifest-mirror");
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
        std::fs::write(dir.join("t.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap_or_else(|e| panic!("{e}"));
        let text = r#"{"objects":[{"type":"mesh","file":"t.obj","transform":{"scale":[1,1,-1]}}]}"#;
        let d = parse_manifest(text, &dir, "m.json").unwrap_or_else(|e| panic!("{e}"));
        let p = d.meshes[0].positions();
        let [a, b, c] = d.meshes[0].indices()[0];
        // The +z-facing triangle, mirrored in z, faces −z.
        assert!((p[b as usize] - p[a as usize]).cross(p[c as usize] - p[a as usize]).z < 0.0);
    }
}
