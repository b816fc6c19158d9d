//! Plain scene descriptions handed to the layers above, and [`load_scene`], the one entry point that
//! reads a scene file by its extension.
//!
//! Geometry knows nothing of colour (see the crate docs): spectra, indices of refraction and absorption are
//! *descriptions* — numbers, names and file references — that the `materials` and `integrator` crates turn
//! into sampled spectra. The file formats are documented in `docs/scene-format.md`.

use std::path::{Path, PathBuf};

use glam::Vec3;

use crate::error::{Error, Result};
use crate::shapes::{Mesh, Sphere};

/// A spectrum as written in a scene file, not yet interpreted.
#[derive(Clone, Debug, PartialEq)]
pub enum SpectrumDesc {
    /// A flat spectrum, e.g. `0.9`.
    Constant(f32),
    /// A built-in spectrum by name: `"D65"`, `"A"`, `"F11"`, `"E"`, `"bb6500"` (blackbody at 6500 K),
    /// `"colorchecker:13"`, `"tcs:09"`, … The `materials`/`colorimetry` crates decide which names exist.
    Named(String),
    /// A linear sRGB colour (glTF `baseColorFactor`, OBJ `Kd`), to be upsampled to a spectrum.
    Rgb([f32; 3]),
    /// A column of a CSV file (wavelength in nm first); the path is already resolved against the scene file's
    /// folder. `column: None` means the first value column.
    Csv {
        /// Resolved path of the CSV file.
        path: PathBuf,
        /// Header name of the value column.
        column: Option<String>,
    },
    /// Piecewise-linear samples; `lambda` (nm) strictly increasing, both finite, equal lengths ≥ 2.
    Samples {
        /// Wavelengths in nanometres.
        lambda: Vec<f32>,
        /// Values at those wavelengths.
        values: Vec<f32>,
    },
}

impl SpectrumDesc {
    /// Whether this spectrum is given as RGB or a constant (`false`) rather than spectral data that the
    /// layers above must inspect for spikes (named, CSV or sampled: `true`).
    pub fn is_spectral(&self) -> bool {
        matches!(self, Self::Named(_) | Self::Csv { .. } | Self::Samples { .. })
    }

    /// A short human-readable label: the name, the CSV file (and column), or `samples[N]`.
    pub fn label(&self) -> String {
        match self {
            Self::Constant(v) => format!("{v}"),
            Self::Named(name) => name.clone(),
            Self::Rgb([r, g, b]) => format!("rgb({r}, {g}, {b})"),
            Self::Csv { path, column: Some(c) } => format!("{}#{c}", path.display()),
            Self::Csv { path, column: None } => path.display().to_string(),
            Self::Samples { lambda, .. } => format!("samples[{}]", lambda.len()),
        }
    }
}

/// An index of refraction, constant or varying with wavelength.
#[derive(Clone, Debug, PartialEq)]
pub enum IorDesc {
    /// A constant IOR. `0.0` is glTF's special mode of `KHR_materials_ior` (Fresnel ≡ 1: all light is
    /// reflected or transmitted according to the transmission factor, no refraction) and is kept as is.
    Constant(f32),
    /// Cauchy: n(λ) = a + b / λ², λ in µm, `b` in µm².
    Cauchy {
        /// Constant term.
        a: f32,
        /// Coefficient of 1/λ² (µm²).
        b: f32,
    },
    /// Sellmeier: n²(λ) = 1 + Σ bᵢ λ² / (λ² − cᵢ), λ in µm, `c` in µm².
    Sellmeier {
        /// Numerator coefficients.
        b: [f32; 3],
        /// Resonance terms (µm²).
        c: [f32; 3],
    },
    /// From the refractive index at the d line (587.6 nm) and the Abbe number.
    Abbe {
        /// n_d, refractive index at 587.56 nm.
        nd: f32,
        /// V_d, Abbe number (> 0).
        vd: f32,
    },
}

impl IorDesc {
    /// Whether the IOR varies with wavelength (so refraction disperses light).
    pub fn varies_with_wavelength(&self) -> bool {
        match self {
            Self::Constant(_) => false,
            Self::Cauchy { b, .. } => *b != 0.0,
            Self::Sellmeier { .. } | Self::Abbe { .. } => true,
        }
    }
}

/// Absorption inside a transparent object (Bouguer–Beer).
#[derive(Clone, Debug, PartialEq)]
pub enum AbsorptionDesc {
    /// The paper's t_λ: transmittance per unit length, T = t_λ^b for a path of length b (scene units).
    PerUnit(SpectrumDesc),
    /// Absorption coefficient σ_a per scene unit, T = exp(−σ_a b).
    SigmaA(SpectrumDesc),
    /// glTF `KHR_materials_volume`: T = color^(b / distance) (linear RGB colour, distance in scene units).
    Attenuation {
        /// `attenuationColor`, the transmittance after travelling `distance`.
        color: [f32; 3],
        /// `attenuationDistance` (> 0, may be `f32::INFINITY` meaning no absorption).
        distance: f32,
    },
}

/// A material as read from a scene file: every field a spectral renderer may use.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialDesc {
    /// Name (from the manifest key, glTF material name or `newmtl`); unique names are not enforced for files.
    pub name: String,
    /// Optional explicit model hint: `"hall"`, `"diffuse"`, `"dielectric"`, `"conductor"`, `"mirror"`.
    pub model: Option<String>,
    /// Diffuse reflectance (glTF `baseColorFactor`, OBJ `Kd`). Default `Constant(0.5)` (pbrt-v4's diffuse default).
    pub base_color: SpectrumDesc,
    /// k_d, the diffuse weight of the paper's / Hall's model. Default 1.
    pub diffuse: f32,
    /// Specular reflectance spectrum F_s (OBJ `Ks` colour). `None`: white.
    pub specular: Option<SpectrumDesc>,
    /// k_s, the specular coefficient. Default 0.
    pub ks: f32,
    /// Phong/Hall exponent n. Manifest: as written, else derived from `roughness`; OBJ: `Ns`; glTF: from roughness.
    pub shininess: f32,
    /// glTF metallic factor. Default 0.
    pub metallic: f32,
    /// glTF roughness factor. Default 0.5 (manifest, OBJ); glTF default 1.
    pub roughness: f32,
    /// k_t (glTF `transmissionFactor`). Default 0.
    pub transmission: f32,
    /// Spectral transmittance T_s (OBJ `Tf`). `None`: white.
    pub transmittance: Option<SpectrumDesc>,
    /// Index of refraction. Default `Constant(1.5)` (glTF's default).
    pub ior: IorDesc,
    /// `KHR_materials_dispersion` (20 / Abbe number), 0 = none.
    pub dispersion: f32,
    /// Absorption inside the object, if any.
    pub absorption: Option<AbsorptionDesc>,
    /// `KHR_materials_volume` thickness factor (scene units), 0 = thin-walled.
    pub thickness: f32,
    /// Emitted radiance spectrum (before `emission_strength`). `None`: not emissive.
    pub emission: Option<SpectrumDesc>,
    /// Scale on `emission` (`KHR_materials_emissive_strength`). Default 1.
    pub emission_strength: f32,
    /// Whether back faces are shaded as front faces (glTF `doubleSided`).
    pub double_sided: bool,
    /// Raw glTF material `extras` or unknown manifest keys, passed up untouched (spectral overrides go here).
    pub extras: Option<serde_json::Value>,
}

/// Default roughness of manifest and OBJ materials: a middle value, glossy but not a mirror.
pub(crate) const DEFAULT_ROUGHNESS: f32 = 0.5;

impl MaterialDesc {
    /// A material with the documented defaults (a grey diffuse surface) and the given name.
    pub fn named(name: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            model: None,
            base_color: SpectrumDesc::Constant(0.5),
            diffuse: 1.0,
            specular: None,
            ks: 0.0,
            shininess: shininess_from_roughness(DEFAULT_ROUGHNESS),
            metallic: 0.0,
            roughness: DEFAULT_ROUGHNESS,
            transmission: 0.0,
            transmittance: None,
            ior: IorDesc::Constant(1.5),
            dispersion: 0.0,
            absorption: None,
            thickness: 0.0,
            emission: None,
            emission_strength: 1.0,
            double_sided: false,
            extras: None,
        }
    }

    /// Whether the material emits light (an emission spectrum that is not zero, with a positive strength).
    pub fn is_emissive(&self) -> bool {
        let zero = match &self.emission {
            None => true,
            Some(SpectrumDesc::Constant(v)) => *v == 0.0,
            Some(SpectrumDesc::Rgb(c)) => c.iter().all(|v| *v == 0.0),
            Some(_) => false,
        };
        !zero && self.emission_strength > 0.0
    }

    /// Whether the material transmits light (k_t > 0 or a transmission model hint).
    pub fn is_transmissive(&self) -> bool {
        self.transmission > 0.0 || self.model.as_deref() == Some("dielectric")
    }

    /// Whether refraction through this material disperses light (wavelength-dependent IOR or dispersion > 0).
    pub fn is_dispersive(&self) -> bool {
        self.is_transmissive() && (self.ior.varies_with_wavelength() || self.dispersion > 0.0)
    }

    /// Every spectrum this material refers to, with the field it comes from.
    pub fn spectra(&self) -> Vec<(&'static str, &SpectrumDesc)> {
        let mut out = vec![("base_color", &self.base_color)];
        if let Some(s) = &self.specular {
            out.push(("specular", s));
        }
        if let Some(s) = &self.transmittance {
            out.push(("transmittance", s));
        }
        if let Some(s) = &self.emission {
            out.push(("emission", s));
        }
        match &self.absorption {
            Some(AbsorptionDesc::PerUnit(s)) => out.push(("absorption", s)),
            Some(AbsorptionDesc::SigmaA(s)) => out.push(("absorption", s)),
            _ => {}
        }
        out
    }
}

impl Default for MaterialDesc {
    fn default() -> Self {
        Self::named("default")
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

/// A light source as written in a scene file. Intensities are numbers scaling the spectrum; the integrator
/// defines the units (`docs/scene-format.md` gives the conventions).
#[derive(Clone, Debug, PartialEq)]
pub enum LightDesc {
    /// Isotropic point light; irradiance at distance d is `intensity · spectrum / d²`.
    Point {
        /// World position.
        position: Vec3,
        /// Emission spectrum.
        spectrum: SpectrumDesc,
        /// Scale (glTF: candela).
        intensity: f32,
    },
    /// Spot light, full intensity inside `inner_cone_deg`, smooth falloff to zero at `outer_cone_deg`.
    Spot {
        /// World position.
        position: Vec3,
        /// Unit direction the spot points to.
        direction: Vec3,
        /// Half-angle of the full-intensity cone, degrees.
        inner_cone_deg: f32,
        /// Half-angle where the intensity reaches zero, degrees.
        outer_cone_deg: f32,
        /// Emission spectrum.
        spectrum: SpectrumDesc,
        /// Scale (glTF: candela).
        intensity: f32,
    },
    /// Distant light; `direction` is the unit direction the light travels.
    Directional {
        /// Unit direction of travel.
        direction: Vec3,
        /// Emission spectrum.
        spectrum: SpectrumDesc,
        /// Scale (glTF: lux, irradiance on a surface facing the light).
        intensity: f32,
    },
    /// Uniform environment illuminating the scene from all directions.
    Environment {
        /// Emission spectrum.
        spectrum: SpectrumDesc,
        /// Scale (radiance).
        intensity: f32,
    },
}

impl LightDesc {
    /// The light's kind as a lowercase word (`"point"`, `"spot"`, `"directional"`, `"environment"`).
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Point { .. } => "point",
            Self::Spot { .. } => "spot",
            Self::Directional { .. } => "directional",
            Self::Environment { .. } => "environment",
        }
    }

    /// The light's spectrum.
    pub fn spectrum(&self) -> &SpectrumDesc {
        match self {
            Self::Point { spectrum, .. }
            | Self::Spot { spectrum, .. }
            | Self::Directional { spectrum, .. }
            | Self::Environment { spectrum, .. } => spectrum,
        }
    }
}

/// A pinhole camera as written in a scene file.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraDesc {
    /// Eye position.
    pub position: Vec3,
    /// Point looked at.
    pub look_at: Vec3,
    /// Up vector (need not be unit or orthogonal to the view direction, must not be parallel to it).
    pub up: Vec3,
    /// Vertical field of view in degrees, in (0, 180).
    pub vfov_deg: f32,
    /// Image width in pixels, if the file fixes it.
    pub width: Option<u32>,
    /// Image height in pixels, if the file fixes it.
    pub height: Option<u32>,
}

/// Everything read from a scene file: world-space geometry, materials, lights, camera and settings.
#[derive(Clone, Debug)]
pub struct SceneDescription {
    /// Analytic spheres; material indices point into `materials`.
    pub spheres: Vec<Sphere>,
    /// World-space triangle meshes; material indices point into `materials`.
    pub meshes: Vec<Mesh>,
    /// Materials, indexed by the shapes' material indices.
    pub materials: Vec<MaterialDesc>,
    /// Light sources.
    pub lights: Vec<LightDesc>,
    /// The camera, if the file has one.
    pub camera: Option<CameraDesc>,
    /// Radiance seen by rays that escape the scene (spectrum, scale); not a light.
    pub background: Option<(SpectrumDesc, f32)>,
    /// Free-form render settings from the manifest (`"max_depth"`, `"ambient"`, …).
    pub settings: serde_json::Map<String, serde_json::Value>,
    /// Things the user should know: skipped primitives, ignored textures, defaults added.
    pub warnings: Vec<String>,
}

impl SceneDescription {
    /// An empty description.
    pub(crate) fn empty() -> Self {
        Self {
            spheres: Vec::new(),
            meshes: Vec::new(),
            materials: Vec::new(),
            lights: Vec::new(),
            camera: None,
            background: None,
            settings: serde_json::Map::new(),
            warnings: Vec::new(),
        }
    }

    /// Axis-aligned bounds of all spheres and mesh vertices, `None` when the scene has no geometry.
    pub fn bounds(&self) -> Option<(Vec3, Vec3)> {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for s in &self.spheres {
            lo = lo.min(s.center() - Vec3::splat(s.radius()));
            hi = hi.max(s.center() + Vec3::splat(s.radius()));
        }
        for m in &self.meshes {
            for p in m.positions() {
                lo = lo.min(*p);
                hi = hi.max(*p);
            }
        }
        (lo.x <= hi.x).then_some((lo, hi))
    }

    /// For a scene loaded straight from a glTF or OBJ file: add a camera framing the geometry and a D65 point
    /// light when the file has none, each with a warning, so the file renders without a manifest.
    pub(crate) fn add_defaults_for_bare_file(&mut self) {
        let (lo, hi) = self.bounds().unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
        let center = 0.5 * (lo + hi);
        // Radius of the bounding sphere of the box; at least a tiny positive size so a single point works.
        let radius = (0.5 * (hi - lo).length()).max(1e-3);
        if self.camera.is_none() {
            let vfov_deg = DEFAULT_VFOV_DEG;
            // Distance at which the bounding sphere just fits the vertical field of view.
            let distance = radius / (0.5 * vfov_deg.to_radians()).sin();
            self.camera = Some(CameraDesc {
                position: center + Vec3::new(0.0, 0.0, distance),
                look_at: center,
                up: Vec3::Y,
                vfov_deg,
                width: None,
                height: None,
            });
            self.warnings.push(format!(
                "no camera in file: added one on +z looking at the centre of the bounds ({:.3}, {:.3}, {:.3}), vfov {vfov_deg}°",
                center.x, center.y, center.z
            ));
        }
        if self.lights.is_empty() && !self.materials.iter().any(MaterialDesc::is_emissive) {
            // Up-left-front, ten bounding radii away, as the paper's light; intensity d² gives irradiance ≈ 1
            // at the centre.
            let distance = 10.0 * radius;
            let position = center + distance * Vec3::new(-1.0, 1.0, 1.0).normalize();
            self.lights.push(LightDesc::Point {
                position,
                spectrum: SpectrumDesc::Named("D65".into()),
                intensity: distance * distance,
            });
            self.warnings.push(format!(
                "no light in file: added a D65 point light at ({:.3}, {:.3}, {:.3}) with intensity {:.4} (irradiance 1 at the centre)",
                position.x,
                position.y,
                position.z,
                distance * distance
            ));
        }
    }
}

/// Vertical field of view of the default camera, degrees (a moderate lens, as Blender's 50 mm default ≈ 39.6°).
pub(crate) const DEFAULT_VFOV_DEG: f32 = 40.0;

/// Loads a scene by its extension: `.json` (manifest), `.gltf`/`.glb`, `.obj` (+ `.mtl`).
///
/// A glTF or OBJ file loaded directly gets a default camera and a D65 point light when it has none (each
/// reported in [`SceneDescription::warnings`]); a manifest gets exactly what it says.
///
/// # Errors
/// [`Error::UnsupportedFormat`] for another extension; otherwise the errors of each format, each naming the file.
pub fn load_scene(path: &Path) -> Result<SceneDescription> {
    let extension = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).unwrap_or_default();
    match extension.as_str() {
        "json" => {
            let text =
                std::fs::read_to_string(path).map_err(|cause| Error::ReadFile { path: path.to_path_buf(), cause })?;
            let base = path.parent().unwrap_or_else(|| Path::new("."));
            crate::manifest::parse_manifest(&text, base, &path.display().to_string())
        }
        "gltf" | "glb" => {
            let mut desc = crate::gltf_loader::load_gltf_file(path)?;
            desc.add_defaults_for_bare_file();
            Ok(desc)
        }
        "obj" => {
            let mut desc = crate::obj_loader::load_obj_file(path)?;
            desc.add_defaults_for_bare_file();
            Ok(desc)
        }
        _ => Err(Error::UnsupportedFormat { path: path.to_path_buf(), extension }),
    }
}

/// Runs a third-party parser, turning a panic inside it into [`Error::ParserPanic`] so no input can crash
/// the program. Our own code must not rely on this: the loaders validate before calling (see the fuzz tests,
/// which fail on this variant).
pub(crate) fn guard_panic<T>(path: &Path, library: &'static str, f: impl FnOnce() -> Result<T>) -> Result<T> {
    match std::panic::catch_unwind(std::panic::AssertUnwindSafe(f)) {
        Ok(result) => result,
        Err(payload) => {
            let message = payload
                .downcast_ref::<&str>()
                .map(|s| (*s).to_owned())
                .or_else(|| payload.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".to_owned());
            Err(Error::ParserPanic { path: path.to_path_buf(), library, message })
        }
    }
}

#[cfg(test)]
mod fuzz_tests;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shininess_from_roughness_matches_walter_mapping() {
        // roughness 0.5 → α = 0.25 → n = 2/0.0625 − 2 = 30.
        assert!((shininess_from_roughness(0.5) - 30.0).abs() < 1e-4);
        // roughness 1 → α = 1 → n = 0 (a cosine lobe).
        assert_eq!(shininess_from_roughness(1.0), 0.0);
        assert_eq!(shininess_from_roughness(0.0), 1.0e4);
    }

    #[test]
    fn constant_ior_does_not_disperse_but_abbe_does() {
        let mut m = MaterialDesc::named("glass");
        m.transmission = 1.0;
        assert!(!m.is_dispersive());
        m.ior = IorDesc::Abbe { nd: 1.5, vd: 40.0 };
        assert!(m.is_dispersive());
    }

    #[test]
    fn zero_emission_is_not_emissive() {
        let mut m = MaterialDesc::named("e");
        m.emission = Some(SpectrumDesc::Rgb([0.0; 3]));
        assert!(!m.is_emissive());
        m.emission = Some(SpectrumDesc::Named("D65".into()));
        assert!(m.is_emissive());
    }
}
