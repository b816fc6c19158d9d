//! Scene assembly: the geometry crate's plain descriptions become spectral materials and
//! lights, and primitives are tied to materials. This is the first place that sees both a
//! mesh and a spectrum.

use std::path::Path;

use colorimetry::DenselySampledSpectrum;
use geometry::{
    AbsorptionDesc, Camera, CameraDesc, IorDesc, LightDesc, LoadOptions, MaterialDesc, MaterialFormat, Scene,
    SceneDescription, SpectrumDesc,
};
use glam::Vec3;
use materials::{Absorption, Ior, Material};

use crate::error::{Error, Result};
use crate::lights::{Emitters, Light, LightKind};

/// Resolution used when neither the scene nor the user gives one: the paper's 640×480.
pub const DEFAULT_RESOLUTION: (u32, u32) = (640, 480);

/// A scene ready to render: acceleration structure, materials, lights, camera, background.
#[derive(Debug)]
pub struct RenderScene {
    pub(crate) geometry: Scene,
    pub(crate) materials: Vec<Material>,
    /// Material of primitives that name none: a mid-grey Lambertian.
    pub(crate) default_material: Material,
    pub(crate) lights: Vec<Light>,
    /// Every light, including emissive primitives and the environment, behind one interface.
    pub(crate) emitters: Emitters,
    pub(crate) camera: CameraDesc,
    pub(crate) resolution: (u32, u32),
    pub(crate) background: Option<DenselySampledSpectrum>,
    pub(crate) settings: serde_json::Map<String, serde_json::Value>,
    /// The lights as descriptions, including a default light assembly added (for `spectrace info`).
    pub(crate) light_descs: Vec<LightDesc>,
    /// Notes for the user (defaults that were filled in), printed by the CLI.
    pub warnings: Vec<String>,
    /// Digest of the scene's files ([`SceneDescription::source_hash`]).
    pub(crate) source_hash: u64,
}

impl RenderScene {
    /// Load a scene file (manifest `.json`, `.gltf`/`.glb` or `.obj`) and assemble it.
    pub fn load(path: &Path) -> Result<Self> {
        Self::load_with(path, &LoadOptions::default())
    }

    /// Load a scene file within the memory budget and file rules of `options`, and assemble it.
    pub fn load_with(path: &Path, options: &LoadOptions) -> Result<Self> {
        Self::from_description(geometry::load_scene_with(path, options)?)
            .map_err(|e| Error::SceneFile { path: path.to_owned(), source: Box::new(e) })
    }

    /// The paper's five transparent spheres (Lee, Lee, Lee & Ha 2004, Table 1), embedded in
    /// the binary so `spectrace render` works with no arguments.
    pub fn default_scene() -> Result<Self> {
        Self::from_description(Self::default_description()?)
    }

    /// The description of the default scene (see [`RenderScene::default_scene`]).
    pub fn default_description() -> Result<SceneDescription> {
        let text = include_str!(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/paper/five_spheres.json"));
        // The embedded manifest references no files, so its base folder is never read.
        Ok(geometry::parse_manifest(text, Path::new("."), "<embedded scenes/paper/five_spheres.json>")?)
    }

    /// Assemble a loaded description: spectra for every material and light, a BVH over all
    /// primitives, and defaults (camera, light) where the file has none.
    pub fn from_description(desc: SceneDescription) -> Result<Self> {
        // The one place defaults are decided: a camera framing the bounds of the description and a D65
        // light when the file has none (computed before the BVH takes the meshes).
        let bounds = desc.bounds();
        let SceneDescription {
            format: _,
            spheres,
            meshes,
            materials: material_descs,
            lights: mut light_descs,
            camera,
            background,
            settings,
            mut warnings,
            source_hash,
        } = desc;
        let materials = material_descs.iter().map(material_from_desc).collect::<Result<Vec<_>>>()?;
        warn_unused_keys(&material_descs, &mut warnings);
        let geometry = Scene::build(spheres, meshes)?;
        let (center, radius) = framing(bounds);
        let camera = match camera {
            Some(c) => c,
            None => {
                let c = default_camera(center, radius);
                warnings.push(format!(
                    "no camera in the scene: added one on +z looking at the centre of the bounds ({:.3}, {:.3}, {:.3}), vfov {}°",
                    center.x, center.y, center.z, c.vfov_deg
                ));
                c
            }
        };
        let resolution = (camera.width.unwrap_or(DEFAULT_RESOLUTION.0), camera.height.unwrap_or(DEFAULT_RESOLUTION.1));

        let mut lights = light_descs
            .iter()
            .enumerate()
            .map(|(index, l)| light_from_desc(l).map_err(|source| Error::Light { index, source }))
            .collect::<Result<Vec<_>>>()?;
        let emissive = materials.iter().any(Material::emits);
        if lights.is_empty() && !emissive {
            let light = default_light(center, radius);
            lights.push(light_from_desc(&light).map_err(|source| Error::Spectrum {
                what: "the default light (added because the scene has none)",
                source,
            })?);
            if let LightDesc::Point { position, intensity, .. } = &light {
                warnings.push(format!(
                    "no light in the scene: added a D65 point light at ({:.3}, {:.3}, {:.3}) with intensity {intensity:.4} (irradiance 1 at the centre)",
                    position.x, position.y, position.z
                ));
            }
            light_descs.push(light);
        }

        let background = match background {
            Some((spectrum, intensity)) => Some(
                emission_spectrum(&spectrum, intensity)
                    .map_err(|source| Error::Spectrum { what: "background", source })?,
            ),
            None => None,
        };

        let mut scene = Self {
            geometry,
            materials,
            default_material: Material::diffuse("default grey", DenselySampledSpectrum::constant(0.5)),
            lights,
            emitters: Emitters::default(),
            camera,
            resolution,
            background,
            settings,
            light_descs,
            warnings,
            source_hash,
        };
        scene.emitters = Emitters::new(
            &scene.lights,
            scene.background.as_ref(),
            &scene.geometry,
            |id| scene.primitive_material(id),
            |m| scene.materials.get(m as usize).filter(|m| m.emits()).and_then(|m| m.emission.as_ref()),
        );
        Ok(scene)
    }

    /// The material index of a primitive (spheres first, then triangles), `None` if it has none.
    pub(crate) fn primitive_material(&self, id: u32) -> Option<u32> {
        match self.geometry.primitive(id) {
            geometry::Primitive::Sphere { index } => self.geometry.spheres().get(index as usize)?.material(),
            geometry::Primitive::Triangle { mesh, .. } => self.geometry.meshes().get(mesh as usize)?.material(),
        }
    }

    /// Digest (XXH64) of the bytes of the scene file and every file it refers to; film files
    /// record it so that parts are known to come from the same scene.
    pub fn source_hash(&self) -> u64 {
        self.source_hash
    }

    /// The image size the scene asks for (the paper's 640×480 if it does not say).
    pub fn resolution(&self) -> (u32, u32) {
        self.resolution
    }

    /// The acceleration structure and primitives.
    pub fn geometry(&self) -> &Scene {
        &self.geometry
    }

    /// All materials, in description order.
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }

    /// A camera for an image of the given size.
    pub(crate) fn camera(&self, width: u32, height: u32) -> Result<Camera> {
        let c = &self.camera;
        Camera::look_at(c.position, c.look_at, c.up, c.vfov_deg, width as f32 / height as f32)
            .map_err(|e| Error::Camera(e.to_string()))
    }

    /// A numeric setting from the manifest's `settings` block.
    pub(crate) fn setting_f64(&self, key: &str) -> Option<f64> {
        self.settings.get(key).and_then(serde_json::Value::as_f64)
    }
}

/// Vertical field of view of the default camera, degrees (a moderate lens, as Blender's 50 mm default ≈ 39.6°).
const DEFAULT_VFOV_DEG: f32 = 40.0;

/// Centre and radius of the bounding sphere of the bounds' box; a unit box at the origin when the scene has
/// no geometry, and at least a tiny positive radius so a single point works.
fn framing(bounds: Option<(Vec3, Vec3)>) -> (Vec3, f32) {
    let (lo, hi) = bounds.unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
    (0.5 * (lo + hi), (0.5 * (hi - lo).length()).max(1e-3))
}

/// The camera of a scene that has none: on +z of the centre, at the distance where the bounding sphere
/// just fits the vertical field of view.
fn default_camera(center: Vec3, radius: f32) -> CameraDesc {
    let distance = radius / (0.5 * DEFAULT_VFOV_DEG.to_radians()).sin();
    CameraDesc {
        position: center + Vec3::new(0.0, 0.0, distance),
        look_at: center,
        up: Vec3::Y,
        vfov_deg: DEFAULT_VFOV_DEG,
        width: None,
        height: None,
    }
}

/// The light of a scene that has neither lights nor emitters: D65, up-left-front, ten bounding radii away
/// (as the paper's light), intensity d² so the irradiance at the centre is 1. Coordinates are bounded by
/// `geometry::MAX_COORDINATE` (1e18), so d² ≤ (10 · √3 · 1e18)² = 3e38 stays finite in f32.
fn default_light(center: Vec3, radius: f32) -> LightDesc {
    let distance = 10.0 * radius;
    LightDesc::Point {
        position: center + distance * Vec3::new(-1.0, 1.0, 1.0).normalize(),
        spectrum: SpectrumDesc::Named("D65".into()),
        intensity: distance * distance,
    }
}

/// One warning for the keys a scene writes that the renderer reads but does not honour yet.
fn warn_unused_keys(materials: &[MaterialDesc], warnings: &mut Vec<String>) {
    let names = |f: &dyn Fn(&MaterialDesc) -> bool| -> Vec<&str> {
        materials.iter().filter(|m| f(m)).map(|m| m.name.as_str()).collect()
    };
    let one_sided = names(&|m| m.double_sided == Some(false) && m.format != MaterialFormat::Gltf);
    if !one_sided.is_empty() {
        warnings.push(format!(
            "material(s) {}: `double_sided: false` is not honoured yet (both sides are shaded)",
            one_sided.join(", ")
        ));
    }
    let thick = names(&|m| m.thickness.is_some_and(|t| t > 0.0));
    if !thick.is_empty() {
        warnings.push(format!(
            "material(s) {}: `thickness` is not used (absorption follows the path length inside the closed mesh)",
            thick.join(", ")
        ));
    }
}

/// Phong/Hall exponent equivalent to a glTF roughness: with α = roughness², the Blinn–Phong exponent that
/// matches a Beckmann distribution of slope α is n = 2/α² − 2 (Walter et al. 2007, "Microfacet models for
/// refraction through rough surfaces", eq. 30 inverted). Clamped to [0, 10⁴] so roughness 0 stays finite.
pub(crate) fn shininess_from_roughness(roughness: f32) -> f32 {
    /// Upper bound for a perfect mirror; large enough that the lobe is a mirror at 8-bit precision.
    const MAX_SHININESS: f32 = 1.0e4;
    let alpha = roughness.clamp(0.0, 1.0).powi(2);
    if alpha <= 0.0 {
        return MAX_SHININESS;
    }
    (2.0 / (alpha * alpha) - 2.0).clamp(0.0, MAX_SHININESS)
}

/// Phong exponent → roughness, inverting [`shininess_from_roughness`]: α = √(2/(n+2)), r = √α.
pub(crate) fn roughness_from_shininess(n: f32) -> f32 {
    (2.0 / (n.max(0.0) + 2.0)).sqrt().sqrt()
}

/// Default roughness of manifest and MTL materials: a middle value, glossy but not a mirror.
const DEFAULT_ROUGHNESS: f32 = 0.5;

/// glTF's default index of refraction (KHR_materials_ior), also the manifest's and MTL's.
const DEFAULT_IOR: f32 = 1.5;

/// Hall's model's coefficients as a file format means them (`docs/scene-format.md`, "glTF", "OBJ/MTL").
#[derive(Debug, PartialEq)]
struct HallParams {
    base_color: SpectrumDesc,
    kd: f32,
    ks: f32,
    /// `None`: white.
    specular: Option<SpectrumDesc>,
    shininess: f32,
    roughness: f32,
    metallic: f32,
    kt: f32,
    ior: IorDesc,
    emission_strength: f32,
}

fn hall_params(d: &MaterialDesc) -> HallParams {
    let ior = d.ior.clone().unwrap_or(IorDesc::Constant(DEFAULT_IOR));
    let emission_strength = d.emission_strength.unwrap_or(1.0).max(0.0);
    match d.format {
        MaterialFormat::Manifest => {
            let roughness = d.roughness.unwrap_or(DEFAULT_ROUGHNESS);
            HallParams {
                base_color: d.base_color.clone().unwrap_or(SpectrumDesc::Constant(0.5)),
                kd: d.diffuse.unwrap_or(1.0),
                ks: d.ks.unwrap_or(0.0),
                specular: d.specular.clone(),
                shininess: d.shininess.unwrap_or_else(|| shininess_from_roughness(roughness)),
                roughness,
                metallic: d.metallic.unwrap_or(0.0),
                kt: d.transmission.unwrap_or(0.0),
                ior,
                emission_strength,
            }
        }
        MaterialFormat::Gltf => {
            // glTF defaults (§3.9.2), decided here only: base colour 1, metallic 1, roughness 1. The loader
            // transcribes, so glTF's default material (§3.9.6) arrives with every field `None`.
            let base_color = d.base_color.clone().unwrap_or(SpectrumDesc::Rgb([1.0; 3]));
            let metallic = d.metallic.unwrap_or(1.0).clamp(0.0, 1.0);
            let roughness = d.roughness.unwrap_or(1.0).clamp(0.0, 1.0);
            let kt = d.transmission.unwrap_or(0.0).clamp(0.0, 1.0);
            // The specular reflection of a dielectric or metal is weighted by its Fresnel term, so Hall's
            // k_s = 1 for glass; a metal reflects its base colour with weight `metallic`.
            let (ks, specular) = if kt > 0.0 {
                (1.0, None)
            } else if metallic > 0.0 {
                (metallic, Some(base_color.clone()))
            } else {
                (0.0, None)
            };
            HallParams {
                base_color,
                kd: 1.0,
                ks,
                specular,
                shininess: shininess_from_roughness(roughness),
                roughness,
                metallic,
                kt,
                ior,
                emission_strength,
            }
        }
        MaterialFormat::Mtl => {
            // The colour carries the magnitude: k_s = 1 unless Ks is black.
            let ks = match &d.specular {
                None => 0.0,
                Some(SpectrumDesc::Rgb(c)) if c.iter().all(|v| *v == 0.0) => 0.0,
                Some(_) => 1.0,
            };
            let (shininess, roughness) = match d.shininess {
                Some(ns) => (ns.max(0.0), roughness_from_shininess(ns)),
                None => (shininess_from_roughness(DEFAULT_ROUGHNESS), DEFAULT_ROUGHNESS),
            };
            // MTL illumination models 4, 6, 7: glass / refraction on; `d` < 1 is see-through.
            let dissolve = d.dissolve.unwrap_or(1.0).clamp(0.0, 1.0);
            let refractive = matches!(d.illum.unwrap_or(2), 4 | 6 | 7);
            let kt = if dissolve < 1.0 {
                1.0 - dissolve
            } else if refractive {
                match &d.transmittance {
                    Some(SpectrumDesc::Rgb(t)) => t.iter().copied().fold(0.0, f32::max).min(1.0),
                    _ => 1.0,
                }
            } else {
                0.0
            };
            HallParams {
                base_color: d.base_color.clone().unwrap_or(SpectrumDesc::Constant(0.5)),
                kd: 1.0,
                ks,
                specular: d.specular.clone(),
                shininess,
                roughness,
                metallic: 0.0,
                kt,
                ior,
                emission_strength,
            }
        }
    }
}

/// A reflectance-like spectrum (values in [0, 1] expected): RGB is upsampled as a reflectance.
fn reflectance_spectrum(desc: &SpectrumDesc) -> materials::Result<DenselySampledSpectrum> {
    Ok(match desc {
        SpectrumDesc::Constant(v) => DenselySampledSpectrum::constant(f64::from(*v)),
        SpectrumDesc::Named(name) => materials::named_spectrum(name)?,
        SpectrumDesc::Rgb(rgb) => materials::reflectance_from_rgb(*rgb),
        SpectrumDesc::Csv { path, column } => materials::csv_spectrum(path, column.as_deref())?,
        SpectrumDesc::Samples { lambda, values } => {
            let l: Vec<f64> = lambda.iter().map(|&x| f64::from(x)).collect();
            let v: Vec<f64> = values.iter().map(|&x| f64::from(x)).collect();
            DenselySampledSpectrum::from_samples(&l, &v)?
        }
    })
}

/// An emission spectrum scaled to luminance `intensity` (RGB colours are upsampled as light).
fn emission_spectrum(desc: &SpectrumDesc, intensity: f32) -> materials::Result<DenselySampledSpectrum> {
    if !(intensity.is_finite() && intensity >= 0.0) {
        return Err(materials::Error::OutOfRange { what: "intensity", value: intensity.into(), range: "finite, >= 0" });
    }
    let spd = match desc {
        SpectrumDesc::Rgb(rgb) => materials::illuminant_from_rgb(*rgb)?,
        SpectrumDesc::Constant(v) => DenselySampledSpectrum::constant(f64::from(*v)),
        other => materials::luminance_normalized(&reflectance_spectrum(other)?),
    };
    Ok(spd.scaled(f64::from(intensity)))
}

fn light_from_desc(desc: &LightDesc) -> materials::Result<Light> {
    Ok(match desc {
        LightDesc::Point { position, spectrum, intensity } => {
            Light::new(LightKind::Point { position: *position }, emission_spectrum(spectrum, *intensity)?)
        }
        LightDesc::Spot { position, direction, inner_cone_deg, outer_cone_deg, spectrum, intensity } => Light::new(
            LightKind::Spot {
                position: *position,
                direction: direction.normalize_or(Vec3::NEG_Y),
                cos_inner: inner_cone_deg.to_radians().cos(),
                cos_outer: outer_cone_deg.to_radians().cos(),
            },
            emission_spectrum(spectrum, *intensity)?,
        ),
        LightDesc::Directional { direction, spectrum, intensity } => Light::new(
            LightKind::Directional { direction: direction.normalize_or(Vec3::NEG_Y) },
            emission_spectrum(spectrum, *intensity)?,
        ),
        LightDesc::Environment { spectrum, intensity } => {
            Light::new(LightKind::Environment, emission_spectrum(spectrum, *intensity)?)
        }
    })
}

fn material_from_desc(desc: &MaterialDesc) -> Result<Material> {
    let wrap = |source| Error::Material { material: desc.name.clone(), source };
    let p = hall_params(desc);
    let diffuse = reflectance_spectrum(&p.base_color).map_err(wrap)?;
    let specular = match &p.specular {
        Some(s) => reflectance_spectrum(s).map_err(wrap)?,
        None => DenselySampledSpectrum::constant(1.0),
    };
    // glTF tints transmitted light by the base colour; a manifest may give its own spectrum.
    let transmittance = match &desc.transmittance {
        Some(s) => reflectance_spectrum(s).map_err(wrap)?,
        None => diffuse.clone(),
    };
    let mut ior = match p.ior {
        IorDesc::Constant(n) => Ior::Constant(n),
        IorDesc::Cauchy { a, b } => Ior::Cauchy { a, b },
        IorDesc::Sellmeier { b, c } => Ior::Sellmeier { b, c },
        IorDesc::Abbe { nd, vd } => Ior::from_abbe(nd, vd).map_err(wrap)?,
    };
    // KHR_materials_dispersion: dispersion = 20 / V_d on top of a constant index.
    let dispersion = desc.dispersion.unwrap_or(0.0);
    if dispersion > 0.0
        && let Ior::Constant(nd) = ior
    {
        ior = Ior::from_abbe(nd, 20.0 / dispersion).map_err(wrap)?;
    }
    let absorption = match &desc.absorption {
        None => None,
        Some(AbsorptionDesc::PerUnit(t)) => {
            Some(Absorption::from_per_unit_transmittance(&reflectance_spectrum(t).map_err(wrap)?).map_err(wrap)?)
        }
        Some(AbsorptionDesc::SigmaA(s)) => {
            Some(Absorption::from_sigma_a(&reflectance_spectrum(s).map_err(wrap)?).map_err(wrap)?)
        }
        Some(AbsorptionDesc::Attenuation { color, distance }) => {
            let c = materials::reflectance_from_rgb(*color);
            Some(Absorption::from_attenuation(&c, f64::from(*distance)).map_err(wrap)?)
        }
    };
    let emission = match &desc.emission {
        Some(e) if p.emission_strength > 0.0 => Some(emission_spectrum(e, p.emission_strength).map_err(wrap)?),
        _ => None,
    };
    let material = Material {
        name: desc.name.clone(),
        kd: p.kd,
        diffuse,
        ks: p.ks,
        specular,
        shininess: p.shininess,
        kt: p.kt,
        transmittance,
        ior,
        absorption,
        emission,
        roughness: p.roughness,
        metallic: p.metallic,
    };
    material.validate().map_err(wrap)?;
    Ok(material)
}
