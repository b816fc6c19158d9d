//! The JSON summary printed by `spectrace info SCENE`: what the scene contains and what it needs, so the
//! renderer can "model only what a scene needs" (dispersion, absorbing media, spiky spectra). The facts
//! that need interpretation (does a material transmit, disperse, absorb, emit; which camera and lights)
//! are the assembled scene's, so `info` reports what a render does, not what the file hints.

use geometry::{CameraDesc, IorDesc, LightDesc, MaterialDesc, SceneDescription, SpectrumDesc};
use materials::Material;
use serde_json::{Value, json};

use crate::scene::assembly::RenderScene;

/// Summarises a loaded description and the scene assembled from it as JSON.
///
/// Keys: `triangles`, `spheres`, `meshes`, `materials` (each with `name`, `model` (the assembled
/// [`materials::MaterialModel`]), `model_key` (the manifest's `model` as written, if any), `uses`: `transmission`,
/// `absorption`, `dispersion`, `emission`, `vertex_colors` (a mesh's vertex colours multiply its base
/// colour), `clearcoat`, `sheen`, `anisotropy` and `specular_layer` (glTF `KHR_materials_clearcoat`,
/// `KHR_materials_sheen`, `KHR_materials_anisotropy`, `KHR_materials_specular` other than its defaults), and its
/// spectra), `lights` (the file's and what assembly added), `lights_why` (what was added and why), `camera`
/// (with `source`: which camera or default view, and why), `bounds` (`min`, `max`),
/// `bvh` (`nodes`, `build_ms`, `bytes`, `bytes_per_primitive`), `memory` (`charged_bytes`, `budget_bytes`:
/// the scene's memory budget, see `geometry::MemoryBudget`), `settings`, `generator` (glTF `asset.generator`),
/// `warnings`, and `needs`:
/// `{dispersion, absorbing_media, emission, transmission, fluorescence, spectral_inputs}` where
/// `fluorescence` names the used materials that re-emit at other wavelengths (a path tracer with hero
/// wavelengths renders them; fixed lanes cannot shift wavelength) and `spectral_inputs` lists the names or
/// files of the non-RGB spectra used (for the layers above to check for spikes).
pub fn summarize(desc: &SceneDescription, render_scene: &RenderScene) -> Value {
    let scene = render_scene.geometry();
    let stats = scene.stats();
    let (lo, hi) = scene.bounds();
    // Only materials some primitive uses count towards `needs` (a file may define unused ones).
    let mut used = vec![false; desc.materials.len()];
    let used_ids = desc
        .spheres
        .iter()
        .map(|s| s.material())
        .chain(desc.meshes.iter().map(|m| m.material()))
        .chain(desc.instances.iter().flat_map(|i| i.meshes().iter().map(|m| m.material())));
    for id in used_ids.flatten() {
        if let Some(u) = used.get_mut(id as usize) {
            *u = true;
        }
    }
    let used_materials_desc = || desc.materials.iter().zip(&used).filter(|(_, u)| **u).map(|(m, _)| m);
    let assembled = render_scene.materials();
    let used_assembled = || assembled.iter().zip(&used).filter(|(_, u)| **u).map(|(m, _)| m);

    let mut spectral_inputs: Vec<String> = Vec::new();
    let mut note = |s: &SpectrumDesc| {
        if s.is_spectral() {
            let label = s.label();
            if !spectral_inputs.contains(&label) {
                spectral_inputs.push(label);
            }
        }
    };
    for m in used_materials_desc() {
        for (_, s) in m.spectra() {
            note(s);
        }
    }
    for l in &render_scene.light_descs {
        note(l.spectrum());
    }
    if let Some((s, _)) = &desc.background {
        note(s);
    }

    let vertex_colored = |i: usize| {
        render_scene
            .textures
            .get(i)
            .and_then(Option::as_ref)
            .is_some_and(crate::texture::MaterialTextures::has_vertex_colors)
    };
    let materials: Vec<Value> = desc
        .materials
        .iter()
        .zip(assembled)
        .zip(&used)
        .enumerate()
        .map(|(i, ((d, m), u))| material_json(d, m, *u, vertex_colored(i)))
        .collect();
    json!({
        "triangles": scene.triangle_count(),
        "spheres": scene.sphere_count(),
        "meshes": desc.meshes.len(),
        "instances": {
            "meshes": desc.instances.len(),
            "placements": scene.instance_count(),
            "triangles": scene.instanced_triangle_count(),
        },
        "materials": materials,
        "lights": render_scene.light_descs.iter().map(light_json).collect::<Vec<_>>(),
        "lights_why": render_scene.lights_why,
        "camera": camera_json(&render_scene.camera, &render_scene.camera_source, &desc.cameras),
        "background": desc.background.as_ref().map(|(s, i)| json!({"spectrum": s.label(), "intensity": i})),
        "bounds": {"min": lo.to_array(), "max": hi.to_array()},
        "bvh": {
            "nodes": stats.node_count,
            "build_ms": stats.build_time.as_secs_f64() * 1e3,
            "bytes": stats.bytes,
            "bytes_per_primitive": stats.bytes_per_primitive,
        },
        "memory": {"charged_bytes": render_scene.memory.used, "budget_bytes": render_scene.memory.limit},
        "settings": desc.settings,
        "generator": desc.generator,
        "warnings": render_scene.warnings,
        "needs": {
            "dispersion": used_assembled().any(Material::is_dispersive),
            "absorbing_media": used_assembled().any(Material::absorbs),
            "emission": used_assembled().any(Material::emits),
            "transmission": used_assembled().any(Material::is_transmissive),
            "fluorescence": used_assembled()
                .filter(|m| m.fluorescence.is_some())
                .map(|m| m.name.clone())
                .collect::<Vec<_>>(),
            "spectral_inputs": spectral_inputs,
        },
    })
}

fn ior_json(ior: &IorDesc) -> Value {
    match ior {
        IorDesc::Constant(n) => json!(n),
        IorDesc::Cauchy { a, b } => json!({"cauchy": {"a": a, "b": b}}),
        IorDesc::Sellmeier { b, c } => json!({"sellmeier": {"b": b, "c": c}}),
        IorDesc::Abbe { nd, vd } => json!({"abbe": {"nd": nd, "vd": vd}}),
    }
}

fn material_json(d: &MaterialDesc, m: &Material, used: bool, vertex_colors: bool) -> Value {
    json!({
        "name": d.name,
        "model": m.model.name(),
        "model_key": d.model,
        "used": used,
        "uses": {
            "transmission": m.is_transmissive(),
            "absorption": m.absorbs(),
            "dispersion": m.is_dispersive(),
            "emission": m.emits(),
            "vertex_colors": vertex_colors,
            "clearcoat": m.coat.is_some(),
            "sheen": m.sheen.is_some(),
            "anisotropy": m.anisotropy.is_some(),
            "specular_layer": m.dielectric_specular.is_some(),
            "fluorescence": m.fluorescence.as_ref().map(materials::Fluorescence::describe),
        },
        "ior": d.ior.as_ref().map(ior_json),
        "spectra": d.spectra().into_iter().map(|(k, s)| json!({"field": k, "spectrum": s.label()})).collect::<Vec<_>>(),
    })
}

fn light_json(l: &LightDesc) -> Value {
    let mut v = json!({"type": l.kind(), "spectrum": l.spectrum().label()});
    let obj = v.as_object_mut();
    if let Some(obj) = obj {
        match l {
            LightDesc::Point { position, intensity, .. } => {
                obj.insert("position".into(), json!(position.to_array()));
                obj.insert("intensity".into(), json!(intensity.value));
                obj.insert("unit".into(), json!(intensity.unit.name()));
            }
            LightDesc::Spot { position, direction, inner_cone_deg, outer_cone_deg, intensity, .. } => {
                obj.insert("position".into(), json!(position.to_array()));
                obj.insert("direction".into(), json!(direction.to_array()));
                obj.insert("inner_cone_deg".into(), json!(inner_cone_deg));
                obj.insert("outer_cone_deg".into(), json!(outer_cone_deg));
                obj.insert("intensity".into(), json!(intensity.value));
                obj.insert("unit".into(), json!(intensity.unit.name()));
            }
            LightDesc::Luminaire { position, direction, up, scale, web, .. } => {
                obj.insert("position".into(), json!(position.to_array()));
                obj.insert("direction".into(), json!(direction.to_array()));
                obj.insert("up".into(), json!(up.to_array()));
                obj.insert("intensity".into(), json!(scale));
                obj.insert("ies".into(), json!(web.path.display().to_string()));
                obj.insert("symmetry".into(), json!(format!("{:?}", web.symmetry)));
                obj.insert("web".into(), json!([web.c_deg.len(), web.gamma_deg.len()]));
                let peak = web.candela.iter().copied().fold(0.0f32, f32::max);
                obj.insert("peak_cd".into(), json!(peak));
            }
            LightDesc::Directional { direction, intensity, .. } => {
                obj.insert("direction".into(), json!(direction.to_array()));
                obj.insert("intensity".into(), json!(intensity.value));
                obj.insert("unit".into(), json!(intensity.unit.name()));
            }
            LightDesc::Environment { intensity, map, .. } => {
                obj.insert("intensity".into(), json!(intensity.value));
                obj.insert("unit".into(), json!(intensity.unit.name()));
                if let Some(m) = map {
                    obj.insert("map".into(), json!(m.path.display().to_string()));
                    obj.insert("rotation_deg".into(), json!(m.rotation_deg));
                }
            }
        }
    }
    v
}

fn camera_json(c: &CameraDesc, source: &str, file_cameras: &[(String, CameraDesc)]) -> Value {
    json!({
        "source": source,
        "file_cameras": file_cameras.iter().map(|(name, _)| name.as_str()).collect::<Vec<_>>(),
        "position": c.position.to_array(),
        "look_at": c.look_at.to_array(),
        "up": c.up.to_array(),
        "vfov_deg": c.vfov_deg,
        "projection": match c.projection {
            geometry::Projection::Perspective => json!("perspective"),
            geometry::Projection::Orthographic { xmag, ymag } => json!({"orthographic": {"xmag": xmag, "ymag": ymag}}),
        },
        "aspect_ratio": c.aspect_ratio,
        "width": c.width,
        "height": c.height,
    })
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;

    fn summary(json: &str) -> Value {
        let desc = geometry::parse_manifest(json, Path::new("."), "t.json").unwrap_or_else(|e| panic!("{e}"));
        let scene = RenderScene::from_description(desc.clone()).unwrap_or_else(|e| panic!("{e}"));
        summarize(&desc, &scene)
    }

    /// `info` says which glTF materials carry a clear coat or a (non-default) specular layer.
    #[test]
    fn clearcoat_and_specular_layer_are_reported() {
        let mut d = SceneDescription::empty(geometry::SceneFormat::Gltf);
        d.spheres.push(geometry::Sphere::new(glam::Vec3::ZERO, 1.0, Some(0)).unwrap());
        d.spheres.push(geometry::Sphere::new(glam::Vec3::X * 3.0, 1.0, Some(1)).unwrap());
        let mut coated = MaterialDesc::new("coated", geometry::MaterialFormat::Gltf);
        coated.clearcoat = Some(geometry::Clearcoat { factor: 0.5, roughness: 0.1 });
        coated.specular_layer = Some(geometry::SpecularLayer { factor: 0.5, color: [1.0; 3] });
        coated.sheen = Some(geometry::SheenLayer { color: [0.5, 0.2, 0.1], roughness: 0.5 });
        coated.anisotropy = Some(geometry::AnisotropyLayer { strength: 0.5, rotation: 0.2 });
        let mut plain = MaterialDesc::new("plain", geometry::MaterialFormat::Gltf);
        plain.specular_layer = Some(geometry::SpecularLayer { factor: 1.0, color: [1.0; 3] });
        d.materials.extend([coated, plain]);
        let scene = RenderScene::from_description(d.clone()).unwrap_or_else(|e| panic!("{e}"));
        let s = summarize(&d, &scene);
        assert_eq!(s["materials"][0]["uses"]["clearcoat"], json!(true));
        assert_eq!(s["materials"][0]["uses"]["specular_layer"], json!(true));
        assert_eq!(s["materials"][0]["uses"]["sheen"], json!(true));
        assert_eq!(s["materials"][1]["uses"]["sheen"], json!(false));
        assert_eq!(s["materials"][0]["uses"]["anisotropy"], json!(true));
        assert_eq!(s["materials"][1]["uses"]["anisotropy"], json!(false));
        // The extension's defaults are the plain layer: nothing to report.
        assert_eq!(s["materials"][1]["uses"]["clearcoat"], json!(false));
        assert_eq!(s["materials"][1]["uses"]["specular_layer"], json!(false));
    }

    /// `info` reports the assembled model and the one `is_transmissive`. `"model": "dielectric"`
    /// with transmission 0 is a dielectric whose transmission is black (reflection only), so not transmissive;
    /// without `transmission` it is clear glass.
    #[test]
    fn dielectric_model_without_transmission_is_reported_as_rendered() {
        let s = summary(
            r#"{"materials": {"g": {"model": "dielectric", "transmission": 0, "ior": {"abbe": {"nd": 1.5, "vd": 30}}}},
                "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "g"}]}"#,
        );
        assert_eq!(s["materials"][0]["model"], json!("dielectric"));
        assert_eq!(s["materials"][0]["model_key"], json!("dielectric"));
        assert_eq!(s["materials"][0]["uses"]["transmission"], json!(false));
        assert_eq!(s["materials"][0]["uses"]["dispersion"], json!(false));
        assert_eq!(s["needs"]["transmission"], json!(false));
        let glass = summary(
            r#"{"materials": {"g": {"model": "dielectric", "ior": 1.5}},
                "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "g"}]}"#,
        );
        assert_eq!(glass["needs"]["transmission"], json!(true));
        // A Hall material with k_t > 0 and no `model` reads as a dielectric; `"model": "diffuse"` does not
        // transmit whatever k_t says.
        let hall = summary(
            r#"{"materials": {"a": {"transmission": 0.9}, "b": {"model": "diffuse", "transmission": 0.9}},
                "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "a"},
                            {"type": "sphere", "center": [3, 0, 0], "radius": 1, "material": "b"}]}"#,
        );
        assert_eq!(hall["materials"][0]["model"], json!("dielectric"));
        assert_eq!(hall["materials"][0]["model_key"], json!(null));
        assert_eq!(hall["materials"][1]["model"], json!("diffuse"));
        assert_eq!(hall["materials"][1]["uses"]["transmission"], json!(false));
        let t = summary(
            r#"{"materials": {"g": {"transmission": 1, "ior": {"abbe": {"nd": 1.5, "vd": 30}}}},
                "objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material": "g"}]}"#,
        );
        assert_eq!(t["needs"]["transmission"], json!(true));
        assert_eq!(t["needs"]["dispersion"], json!(true));
    }

    /// The default light is reported (it is part of the assembled scene), once.
    #[test]
    fn default_light_and_camera_are_reported() {
        let s = summary(r#"{"objects": [{"type": "sphere", "center": [0, 0, 0], "radius": 1}]}"#);
        assert_eq!(s["lights"].as_array().map(Vec::len), Some(1));
        assert_eq!(s["lights"][0]["spectrum"], json!("D65"));
        assert_eq!(s["camera"]["vfov_deg"], json!(40.0));
    }
}
