//! Scene assembly: the geometry crate's plain descriptions become spectral materials and
//! lights, and primitives are tied to materials. This is the first place that sees both a
//! mesh and a spectrum.

use std::path::Path;

use colorimetry::DenselySampledSpectrum;
use geometry::{
    AbsorptionDesc, Camera, CameraDesc, IorDesc, LightDesc, MaterialDesc, Scene, SceneDescription, SpectrumDesc,
};
use glam::Vec3;
use materials::{Absorption, Ior, Material};

use crate::error::{Error, Result};
use crate::light::{Light, LightKind};

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
    pub(crate) camera: CameraDesc,
    pub(crate) resolution: (u32, u32),
    pub(crate) background: Option<DenselySampledSpectrum>,
    pub(crate) settings: serde_json::Map<String, serde_json::Value>,
    /// Notes for the user (defaults that were filled in), printed by the CLI.
    pub warnings: Vec<String>,
}

impl RenderScene {
    /// Load a scene file (manifest `.json`, `.gltf`/`.glb` or `.obj`) and assemble it.
    pub fn load(path: &Path) -> Result<Self> {
        Self::from_description(geometry::load_scene(path)?)
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
        let SceneDescription { spheres, meshes, materials, lights, camera, background, settings, mut warnings } = desc;
        let materials = materials.iter().map(material_from_desc).collect::<Result<Vec<_>>>()?;
        let geometry = Scene::build(spheres, meshes)?;
        let (lo, hi) = geometry.bounds();
        let (center, radius) = if geometry.primitive_count() == 0 {
            (Vec3::ZERO, 1.0)
        } else {
            ((lo + hi) * 0.5, ((hi - lo).length() * 0.5).max(1e-6))
        };

        let camera = match camera {
            Some(c) => c,
            None => {
                warnings.push("the scene has no camera: using one that frames the whole scene".to_owned());
                CameraDesc {
                    position: center + Vec3::new(0.0, 0.0, 2.6 * radius),
                    look_at: center,
                    up: Vec3::Y,
                    vfov_deg: 45.0,
                    width: None,
                    height: None,
                }
            }
        };
        let resolution = (camera.width.unwrap_or(DEFAULT_RESOLUTION.0), camera.height.unwrap_or(DEFAULT_RESOLUTION.1));

        let mut lights = lights
            .iter()
            .enumerate()
            .map(|(index, l)| light_from_desc(l).map_err(|source| Error::Light { index, source }))
            .collect::<Result<Vec<_>>>()?;
        let emissive = materials.iter().any(Material::emits);
        if lights.is_empty() && !emissive {
            // A file with no light would render black: light it the way the paper does, with a
            // D65 point light, placed above and behind the camera's left shoulder.
            let up = camera.up.normalize_or(Vec3::Y);
            let forward = (camera.look_at - camera.position).normalize_or(Vec3::NEG_Z);
            let left = up.cross(forward).normalize_or(Vec3::X);
            let position = camera.position + (left + up) * radius * 2.0 - forward * radius;
            lights.push(Light::new(
                LightKind::Point { position },
                d65(1.0).map_err(|source| Error::Light { index: 0, source })?,
            ));
            warnings.push("the scene has no light: added a D65 point light near the camera".to_owned());
        }

        let background = match background {
            Some((spectrum, intensity)) => Some(
                emission_spectrum(&spectrum, intensity)
                    .map_err(|source| Error::Spectrum { what: "background", source })?,
            ),
            None => None,
        };

        Ok(Self {
            geometry,
            materials,
            default_material: Material::diffuse("default grey", DenselySampledSpectrum::constant(0.5)),
            lights,
            camera,
            resolution,
            background,
            settings,
            warnings,
        })
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

fn d65(intensity: f32) -> materials::Result<DenselySampledSpectrum> {
    emission_spectrum(&SpectrumDesc::Named("D65".to_owned()), intensity)
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
    let diffuse = reflectance_spectrum(&desc.base_color).map_err(wrap)?;
    let specular = match &desc.specular {
        Some(s) => reflectance_spectrum(s).map_err(wrap)?,
        None => DenselySampledSpectrum::constant(1.0),
    };
    // glTF tints transmitted light by the base colour; a manifest may give its own spectrum.
    let transmittance = match &desc.transmittance {
        Some(s) => reflectance_spectrum(s).map_err(wrap)?,
        None => diffuse.clone(),
    };
    let mut ior = match desc.ior {
        IorDesc::Constant(n) => Ior::Constant(n),
        IorDesc::Cauchy { a, b } => Ior::Cauchy { a, b },
        IorDesc::Sellmeier { b, c } => Ior::Sellmeier { b, c },
        IorDesc::Abbe { nd, vd } => Ior::from_abbe(nd, vd).map_err(wrap)?,
    };
    // KHR_materials_dispersion: dispersion = 20 / V_d on top of a constant index.
    if desc.dispersion > 0.0
        && let Ior::Constant(nd) = ior
    {
        ior = Ior::from_abbe(nd, 20.0 / desc.dispersion).map_err(wrap)?;
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
        Some(e) if desc.emission_strength > 0.0 => Some(emission_spectrum(e, desc.emission_strength).map_err(wrap)?),
        _ => None,
    };
    let material = Material {
        name: desc.name.clone(),
        kd: desc.diffuse,
        diffuse,
        ks: desc.ks,
        specular,
        shininess: desc.shininess,
        kt: desc.transmission,
        transmittance,
        ior,
        absorption,
        emission,
        roughness: desc.roughness,
        metallic: desc.metallic,
    };
    material.validate().map_err(wrap)?;
    Ok(material)
}
