//! The JSON summary printed by `spectrace info SCENE`: what the scene contains and what it needs, so the
//! layers above can "model only what a scene needs" (dispersion, absorbing media, spiky spectra).

use serde_json::{Value, json};

use crate::bvh::Scene;
use crate::scene::{AbsorptionDesc, CameraDesc, IorDesc, LightDesc, MaterialDesc, SceneDescription, SpectrumDesc};

/// Summarises a loaded scene and its built BVH as JSON.
///
/// Keys: `triangles`, `spheres`, `meshes`, `materials` (each with `name`, `model`, `uses`: `transmission`,
/// `absorption`, `dispersion`, `emission`, and its spectra), `lights`, `camera`, `bounds` (`min`, `max`),
/// `bvh` (`nodes`, `build_ms`, `bytes`, `bytes_per_primitive`), `settings`, `warnings`, and `needs`:
/// `{dispersion, absorbing_media, emission, transmission, spectral_inputs}` where `spectral_inputs` lists
/// the names or files of the non-RGB spectra used (for the layers above to check for spikes).
pub fn summarize(desc: &SceneDescription, scene: &Scene) -> Value {
    let stats = scene.stats();
    let (lo, hi) = scene.bounds();
    // Only materials some primitive uses count towards `needs` (a file may define unused ones).
    let mut used = vec![false; desc.materials.len()];
    let used_ids = desc.spheres.iter().map(|s| s.material()).chain(desc.meshes.iter().map(|m| m.material()));
    for id in used_ids.flatten() {
        if let Some(u) = used.get_mut(id as usize) {
            *u = true;
        }
    }
    let used_materials = || desc.materials.iter().zip(&used).filter(|(_, u)| **u).map(|(m, _)| m);

    let mut spectral_inputs: Vec<String> = Vec::new();
    let mut note = |s: &SpectrumDesc| {
        if s.is_spectral() {
            let label = s.label();
            if !spectral_inputs.contains(&label) {
                spectral_inputs.push(label);
            }
        }
    };
    for m in used_materials() {
        for (_, s) in m.spectra() {
            note(s);
        }
    }
    for l in &desc.lights {
        note(l.spectrum());
    }
    if let Some((s, _)) = &desc.background {
        note(s);
    }

    let materials: Vec<Value> = desc.materials.iter().zip(&used).map(|(m, u)| material_json(m, *u)).collect();
    json!({
        "triangles": scene.triangle_count(),
        "spheres": scene.sphere_count(),
        "meshes": desc.meshes.len(),
        "materials": materials,
        "lights": desc.lights.iter().map(light_json).collect::<Vec<_>>(),
        "camera": desc.camera.as_ref().map(camera_json),
        "background": desc.background.as_ref().map(|(s, i)| json!({"spectrum": s.label(), "intensity": i})),
        "bounds": {"min": lo.to_array(), "max": hi.to_array()},
        "bvh": {
            "nodes": stats.node_count,
            "build_ms": stats.build_time.as_secs_f64() * 1e3,
            "bytes": stats.bytes,
            "bytes_per_primitive": stats.bytes_per_primitive,
        },
        "settings": desc.settings,
        "warnings": desc.warnings,
        "needs": {
            "dispersion": used_materials().any(MaterialDesc::is_dispersive),
            "absorbing_media": used_materials().any(|m| m.is_transmissive() && absorbs(m)),
            "emission": used_materials().any(MaterialDesc::is_emissive),
            "transmission": used_materials().any(MaterialDesc::is_transmissive),
            "spectral_inputs": spectral_inputs,
        },
    })
}

/// Whether the material's absorption attenuates at all (a per-unit transmittance of exactly 1, σ_a = 0 or an
/// infinite attenuation distance does not).
fn absorbs(m: &MaterialDesc) -> bool {
    match &m.absorption {
        None => false,
        Some(AbsorptionDesc::PerUnit(SpectrumDesc::Constant(t))) => *t < 1.0,
        Some(AbsorptionDesc::SigmaA(SpectrumDesc::Constant(s))) => *s > 0.0,
        Some(AbsorptionDesc::Attenuation { distance, .. }) => distance.is_finite(),
        Some(_) => true,
    }
}

fn ior_json(ior: &IorDesc) -> Value {
    match ior {
        IorDesc::Constant(n) => json!(n),
        IorDesc::Cauchy { a, b } => json!({"cauchy": {"a": a, "b": b}}),
        IorDesc::Sellmeier { b, c } => json!({"sellmeier": {"b": b, "c": c}}),
        IorDesc::Abbe { nd, vd } => json!({"abbe": {"nd": nd, "vd": vd}}),
    }
}

fn material_json(m: &MaterialDesc, used: bool) -> Value {
    json!({
        "name": m.name,
        "model": m.model,
        "used": used,
        "uses": {
            "transmission": m.is_transmissive(),
            "absorption": m.is_transmissive() && absorbs(m),
            "dispersion": m.is_dispersive(),
            "emission": m.is_emissive(),
        },
        "ior": ior_json(&m.ior),
        "spectra": m.spectra().into_iter().map(|(k, s)| json!({"field": k, "spectrum": s.label()})).collect::<Vec<_>>(),
    })
}

fn light_json(l: &LightDesc) -> Value {
    let mut v = json!({"type": l.kind(), "spectrum": l.spectrum().label()});
    let obj = v.as_object_mut();
    if let Some(obj) = obj {
        match l {
            LightDesc::Point { position, intensity, .. } => {
                obj.insert("position".into(), json!(position.to_array()));
                obj.insert("intensity".into(), json!(intensity));
            }
            LightDesc::Spot { position, direction, inner_cone_deg, outer_cone_deg, intensity, .. } => {
                obj.insert("position".into(), json!(position.to_array()));
                obj.insert("direction".into(), json!(direction.to_array()));
                obj.insert("inner_cone_deg".into(), json!(inner_cone_deg));
                obj.insert("outer_cone_deg".into(), json!(outer_cone_deg));
                obj.insert("intensity".into(), json!(intensity));
            }
            LightDesc::Directional { direction, intensity, .. } => {
                obj.insert("direction".into(), json!(direction.to_array()));
                obj.insert("intensity".into(), json!(intensity));
            }
            LightDesc::Environment { intensity, .. } => {
                obj.insert("intensity".into(), json!(intensity));
            }
        }
    }
    v
}

fn camera_json(c: &CameraDesc) -> Value {
    json!({
        "position": c.position.to_array(),
        "look_at": c.look_at.to_array(),
        "up": c.up.to_array(),
        "vfov_deg": c.vfov_deg,
        "width": c.width,
        "height": c.height,
    })
}
