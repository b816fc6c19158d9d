//! The plain scene descriptions every loader produces and the layers above consume: numbers, names and file
//! references exactly as the file wrote them.
//!
//! This module is at the bottom of the loader stack, beside `limits`: it depends on no loader. `forms` (the
//! value forms the manifest and glTF extras share) builds on both; the loaders (`manifest`, `gltf_loader`,
//! `obj_loader`) build on those and never on each other; `load` dispatches on top and runs `prefilter`
//! (removal of triangles that cannot be hit) on the result.
//!
//! Geometry knows nothing of colour (see the crate docs) and decides nothing about shading: defaults that
//! depend on the file format (glTF's default material included), Hall coefficients derived from glTF or MTL
//! parameters, the default camera and light, and whether a material transmits or disperses are decided
//! once, by the integrator's scene assembly. The file formats are documented in `docs/scene-format.md`.

use std::path::PathBuf;
use std::sync::Arc;

use glam::Vec3;

use crate::shapes::{Instances, Mesh, Sphere};

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
    /// The inner spectrum as given, not rescaled (manifest `"normalize": false`): as an emission
    /// spectrum its values are radiance (times the intensity) instead of being normalised to
    /// luminance 1. Reflectances are never normalised, so there it is the inner spectrum.
    Absolute(Box<SpectrumDesc>),
}

impl SpectrumDesc {
    /// Whether this spectrum is given as RGB or a constant (`false`) rather than spectral data that the
    /// layers above must inspect for spikes (named, CSV or sampled: `true`).
    pub fn is_spectral(&self) -> bool {
        match self {
            Self::Absolute(inner) => inner.is_spectral(),
            other => matches!(other, Self::Named(_) | Self::Csv { .. } | Self::Samples { .. }),
        }
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
            Self::Absolute(inner) => format!("{} (absolute)", inner.label()),
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

/// Fluorescence of a manifest material: light absorbed at one wavelength and re-emitted at a longer one
/// (`docs/fluorescence.md`).
#[derive(Clone, Debug, PartialEq)]
pub enum FluorescenceDesc {
    /// `{"excitation": SPECTRUM, "emission": SPECTRUM, "yield": q}`: the fraction a(λ_in) absorbed for
    /// re-emission, the shape of the emission (normalised by the layers above) and the quantum yield q.
    Spectra {
        /// a(λ_in), the fraction of the incident light absorbed and re-emitted, in [0, 1].
        excitation: SpectrumDesc,
        /// The emission's spectral shape over λ_out (any scale).
        emission: SpectrumDesc,
        /// Quantum yield q in [0, 1]: photons emitted per photon absorbed.
        quantum_yield: f32,
    },
    /// `{"matrix": "file.csv"}`: a re-radiation (Donaldson) matrix, rows λ_in, columns λ_out; the path is
    /// resolved against the manifest's folder.
    Matrix(PathBuf),
}

/// An image a scene file refers to, as bytes still encoded (PNG, JPEG, …): read and charged to
/// the load budget by the loader, decoded by the integrator's assembly (which knows colour).
#[derive(Clone, Debug, PartialEq)]
pub struct ImageDesc {
    /// What to call it in messages: the resolved file path, or `images[3] (buffer view)`.
    pub label: String,
    /// The MIME type the file states (`image/png`, `image/jpeg`), if any; the bytes decide.
    pub mime: Option<String>,
    /// The encoded bytes (shared: several textures may use one image).
    pub bytes: Arc<[u8]>,
}

/// How texture coordinates outside [0, 1] are mapped (glTF sampler `wrapS`/`wrapT`; OBJ `-clamp`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum WrapMode {
    /// Tile (glTF's default, OpenGL `REPEAT`).
    #[default]
    Repeat,
    /// Tile with every other copy mirrored (`MIRRORED_REPEAT`).
    MirroredRepeat,
    /// Clamp to the edge texels (`CLAMP_TO_EDGE`).
    ClampToEdge,
}

/// `KHR_texture_transform` (or OBJ `-o`/`-s`): uv' = T(offset) · R(rotation) · S(scale) · uv.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureTransform {
    /// Translation in uv units.
    pub offset: [f32; 2],
    /// Rotation in radians, counter-clockwise in uv space (glTF's sign convention).
    pub rotation: f32,
    /// Scale per axis.
    pub scale: [f32; 2],
}

/// A texture a material refers to: an image of [`SceneDescription::images`], how it is sampled and
/// which texture coordinates address it, as the file wrote them.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureDesc {
    /// Index into [`SceneDescription::images`].
    pub image: usize,
    /// The mesh's texture-coordinate set (glTF `texCoord`, after `KHR_texture_transform`'s override).
    pub tex_coord: u32,
    /// Wrap along u and v.
    pub wrap: [WrapMode; 2],
    /// Magnification filter is `NEAREST` (glTF sampler `magFilter` 9728): no bilinear blend.
    pub nearest: bool,
    /// The uv transform, if the file gives one.
    pub transform: Option<TextureTransform>,
    /// glTF `normalTexture.scale` (normal maps) or `occlusionTexture.strength`; 1 elsewhere.
    pub scale: f32,
}

impl TextureDesc {
    /// Image `image` with glTF's sampler defaults: repeat, bilinear, `TEXCOORD_0`, no transform, scale 1.
    pub fn new(image: usize) -> Self {
        Self { image, tex_coord: 0, wrap: [WrapMode::Repeat; 2], nearest: false, transform: None, scale: 1.0 }
    }
}

/// How a material's alpha (base colour A × texture A) is used (glTF `alphaMode`; OBJ `d`/`map_d`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AlphaMode {
    /// Alpha is ignored (glTF's default).
    Opaque,
    /// Cut-out: the surface is absent where alpha < cutoff (glTF `alphaCutoff`, default 0.5).
    Mask(f32),
    /// Partial coverage: alpha is the fraction of light the surface stops.
    Blend,
}

/// The textures of a material, by role (glTF 2.0 §3.9 names; MTL `map_*` statements).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MaterialTextures {
    /// Base colour (sRGB, RGBA: A is alpha): glTF `baseColorTexture`, MTL `map_Kd`.
    pub base_color: Option<TextureDesc>,
    /// Linear; B = metalness, G = roughness: glTF `metallicRoughnessTexture`.
    pub metallic_roughness: Option<TextureDesc>,
    /// Tangent-space normal map (linear, RGB → [−1, 1]³): glTF `normalTexture`, MTL `norm`.
    pub normal: Option<TextureDesc>,
    /// Emissive colour (sRGB): glTF `emissiveTexture`, MTL `map_Ke`.
    pub emissive: Option<TextureDesc>,
    /// Coverage alone (the R channel, or luminance): MTL `map_d`.
    pub alpha: Option<TextureDesc>,
    /// Linear; R = transmission (multiplying the factor): glTF `KHR_materials_transmission.transmissionTexture`.
    pub transmission: Option<TextureDesc>,
    /// Linear; A = the specular layer's strength (× `specularFactor`): `KHR_materials_specular.specularTexture`.
    pub specular: Option<TextureDesc>,
    /// sRGB; RGB tints the layer's F0 (× `specularColorFactor`): `KHR_materials_specular.specularColorTexture`.
    pub specular_color: Option<TextureDesc>,
    /// Linear; R = the coat's weight (× `clearcoatFactor`): `KHR_materials_clearcoat.clearcoatTexture`.
    pub clearcoat: Option<TextureDesc>,
    /// Linear; G = the coat's roughness (× its factor): `KHR_materials_clearcoat.clearcoatRoughnessTexture`.
    pub clearcoat_roughness: Option<TextureDesc>,
    /// The coat's own tangent-space normal map (`scale` read): `KHR_materials_clearcoat.clearcoatNormalTexture`.
    /// Without it the coat takes the interpolated normal, not the base's normal map (as the extension says).
    pub clearcoat_normal: Option<TextureDesc>,
    /// sRGB; RGB × `sheenColorFactor`: `KHR_materials_sheen.sheenColorTexture`.
    pub sheen_color: Option<TextureDesc>,
    /// Linear; A = the sheen's roughness (× its factor): `KHR_materials_sheen.sheenRoughnessTexture`.
    pub sheen_roughness: Option<TextureDesc>,
    /// Linear; RG = the direction in tangent space ([0, 1] → [−1, 1]), B = strength (× `anisotropyStrength`):
    /// `KHR_materials_anisotropy.anisotropyTexture`.
    pub anisotropy: Option<TextureDesc>,
    /// MTL `map_Bump`/`bump` (`scale` = `-bm`): a height field in classic MTL (and three.js, assimp), a
    /// tangent-space normal map from Blender's exporter, which writes its normal maps there. The file
    /// does not say which; the assembly decides from the texels.
    pub bump: Option<TextureDesc>,
    /// MTL `map_Ks`: the specular colour per texel (sRGB RGB, multiplying `Ks`).
    pub specular_map: Option<TextureDesc>,
    /// MTL `map_Ns`: a scalar map (the texels' luminance) multiplying `Ns`.
    pub shininess: Option<TextureDesc>,
}

impl MaterialTextures {
    /// Every role's texture, present or not.
    pub fn roles(&self) -> [&Option<TextureDesc>; 17] {
        [
            &self.base_color,
            &self.metallic_roughness,
            &self.normal,
            &self.emissive,
            &self.alpha,
            &self.transmission,
            &self.specular,
            &self.specular_color,
            &self.clearcoat,
            &self.clearcoat_roughness,
            &self.clearcoat_normal,
            &self.sheen_color,
            &self.sheen_roughness,
            &self.anisotropy,
            &self.bump,
            &self.specular_map,
            &self.shininess,
        ]
    }

    /// Every role's texture, present or not, to change in place (the same order as [`Self::roles`]).
    pub fn roles_mut(&mut self) -> [&mut Option<TextureDesc>; 17] {
        [
            &mut self.base_color,
            &mut self.metallic_roughness,
            &mut self.normal,
            &mut self.emissive,
            &mut self.alpha,
            &mut self.transmission,
            &mut self.specular,
            &mut self.specular_color,
            &mut self.clearcoat,
            &mut self.clearcoat_roughness,
            &mut self.clearcoat_normal,
            &mut self.sheen_color,
            &mut self.sheen_roughness,
            &mut self.anisotropy,
            &mut self.bump,
            &mut self.specular_map,
            &mut self.shininess,
        ]
    }

    /// The TEXCOORD sets the textures address: the primary one (a mesh's uvs, which hits interpolate and
    /// tangents follow: the normal map's set where there is one, else the first role's) and another one
    /// (a mesh's second uvs), if any role uses a different set. A third set is not read (the loader warns).
    pub fn uv_sets(&self) -> (u32, Option<u32>) {
        let mut sets = self.roles().into_iter().flatten().map(|t| t.tex_coord);
        let normal = self.normal.as_ref().or(self.bump.as_ref()).map(|t| t.tex_coord);
        let Some(primary) = normal.or_else(|| sets.next()) else { return (0, None) };
        (primary, self.roles().into_iter().flatten().map(|t| t.tex_coord).find(|&s| s != primary))
    }

    /// Whether any role has a texture.
    pub fn any(&self) -> bool {
        self.roles().iter().any(|t| t.is_some())
    }

    /// Whether a normal map (the base's or the coat's, or an MTL bump map that may turn out to be one)
    /// needs tangents.
    pub fn has_normal_map(&self) -> bool {
        self.normal.is_some() || self.clearcoat_normal.is_some() || self.bump.is_some()
    }
}

/// glTF `KHR_materials_specular`'s factors, as written (its textures are in [`MaterialTextures`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpecularLayer {
    /// `specularFactor`: the strength of the layer (scales its Fresnel, F90 included).
    pub factor: f32,
    /// `specularColorFactor` (linear RGB, may exceed 1): tints the layer's F0.
    pub color: [f32; 3],
}

impl SpecularLayer {
    /// Whether these are the extension's defaults (factor 1, white), which are the plain layer.
    pub fn is_default(&self) -> bool {
        self.factor == 1.0 && self.color == [1.0; 3]
    }

    /// The largest component of `color` (0 for black): the colour is upsampled as a reflectance at this
    /// scale, since it may exceed 1.
    pub fn color_scale(&self) -> f32 {
        self.color.into_iter().fold(0.0f32, f32::max)
    }
}

/// glTF `KHR_materials_clearcoat`'s factors, as written (its textures are in [`MaterialTextures`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Clearcoat {
    /// `clearcoatFactor`: the coat's weight.
    pub factor: f32,
    /// `clearcoatRoughnessFactor`: its perceptual roughness (GGX α = roughness²).
    pub roughness: f32,
}

/// glTF `KHR_materials_sheen`'s factors, as written (its textures are in [`MaterialTextures`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SheenLayer {
    /// `sheenColorFactor` (linear RGB in [0, 1]); black disables the layer.
    pub color: [f32; 3],
    /// `sheenRoughnessFactor` in [0, 1].
    pub roughness: f32,
}

/// glTF `KHR_materials_anisotropy`'s factors, as written (its texture is in [`MaterialTextures`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnisotropyLayer {
    /// `anisotropyStrength` in [0, 1]: how far the roughness along the direction is raised towards 1.
    pub strength: f32,
    /// `anisotropyRotation`: radians counter-clockwise from the tangent (also rotating the texture's directions).
    pub rotation: f32,
}

/// The file format a material was read from. Its fields mean what that format says (a glTF roughness, an MTL
/// `Ns`, a manifest `ks`), and the defaults for unwritten fields depend on it, so the layers above need it
/// to interpret the material.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MaterialFormat {
    /// A manifest `materials` entry (`docs/scene-format.md`).
    Manifest,
    /// A glTF 2.0 material (metallic-roughness PBR with the `KHR_materials_*` extensions read).
    Gltf,
    /// A Wavefront MTL `newmtl` block.
    Mtl,
}

/// A material as read from a scene file: every parameter as the file wrote it, `None` where the file does
/// not say. Nothing is derived here (no shininess from roughness, no model from `illum`); the integrator's
/// assembly interprets the record according to [`MaterialDesc::format`].
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialDesc {
    /// Name (from the manifest key, glTF material name or `newmtl`); unique names are not enforced for files.
    pub name: String,
    /// The format whose meaning the fields carry.
    pub format: MaterialFormat,
    /// The manifest's explicit `model` key: `"hall"`, `"diffuse"`, `"dielectric"`, `"conductor"`, `"mirror"`,
    /// `"plastic"`.
    /// Only a manifest writes it; nothing is guessed.
    pub model: Option<String>,
    /// Manifest `metal`: a chemical symbol naming measured optical constants (`"Au"`), for `"model": "conductor"`.
    pub metal: Option<String>,
    /// Manifest `eta` and `k`: a conductor's measured complex index η(λ) + iκ(λ), for `"model": "conductor"`
    /// (both or neither, never with `metal`).
    pub eta: Option<SpectrumDesc>,
    /// See [`MaterialDesc::eta`].
    pub k: Option<SpectrumDesc>,
    /// Manifest `nonlinear`, for `"model": "plastic"`: whether the base's colour is saturated by the light
    /// reflected back and forth under the coat (Mitsuba 3's `nonlinear`).
    pub nonlinear: Option<bool>,
    /// Diffuse colour: manifest `base_color`, glTF `baseColorFactor` (RGB part), MTL `Kd`.
    pub base_color: Option<SpectrumDesc>,
    /// Manifest `diffuse` (k_d of Hall's model).
    pub diffuse: Option<f32>,
    /// Specular colour: manifest `specular`, MTL `Ks`.
    pub specular: Option<SpectrumDesc>,
    /// Manifest `ks` (k_s of Hall's model).
    pub ks: Option<f32>,
    /// Phong/Hall exponent: manifest `shininess`, MTL `Ns`.
    pub shininess: Option<f32>,
    /// Manifest `metallic`, glTF `metallicFactor` (as written, not clamped).
    pub metallic: Option<f32>,
    /// Manifest `roughness`, glTF `roughnessFactor` (as written, not clamped).
    pub roughness: Option<f32>,
    /// Manifest `transmission`, glTF `KHR_materials_transmission.transmissionFactor`.
    pub transmission: Option<f32>,
    /// Spectral transmittance: manifest `transmittance`, MTL `Tf`.
    pub transmittance: Option<SpectrumDesc>,
    /// Index of refraction: manifest `ior`, glTF `KHR_materials_ior.ior`, MTL `Ni`.
    pub ior: Option<IorDesc>,
    /// Manifest `dispersion`, glTF `KHR_materials_dispersion.dispersion` (20 / Abbe number).
    pub dispersion: Option<f32>,
    /// Absorption inside the object: manifest `absorption`, glTF `KHR_materials_volume` attenuation.
    pub absorption: Option<AbsorptionDesc>,
    /// Manifest `thickness`, glTF `KHR_materials_volume.thicknessFactor` (scene units). Not rendered yet.
    pub thickness: Option<f32>,
    /// Emitted radiance spectrum: manifest `emission`, glTF `emissiveFactor` (when not black), MTL `Ke`.
    pub emission: Option<SpectrumDesc>,
    /// Manifest `emission_strength`, glTF `KHR_materials_emissive_strength.emissiveStrength`.
    pub emission_strength: Option<f32>,
    /// Manifest `double_sided`, glTF `doubleSided`. Not rendered yet.
    pub double_sided: Option<bool>,
    /// glTF `KHR_materials_specular`: the strength and F0 colour of the dielectric specular layer.
    pub specular_layer: Option<SpecularLayer>,
    /// glTF `KHR_materials_clearcoat`: a clear varnish over the material.
    pub clearcoat: Option<Clearcoat>,
    /// glTF `KHR_materials_sheen`: fibres over the material (beneath the coat).
    pub sheen: Option<SheenLayer>,
    /// glTF `KHR_materials_anisotropy`: the specular lobe stretched along a direction in the tangent plane.
    pub anisotropy: Option<AnisotropyLayer>,
    /// Manifest `fluorescence`: re-emission at longer wavelengths (Lambertian materials only); boxed, as few
    /// materials have it and every material record is charged to the load budget by its size.
    pub fluorescence: Option<Box<FluorescenceDesc>>,
    /// Manifest `multiple_scattering`: whether rough conductors and dielectrics are energy-compensated
    /// (default yes); `false` is the single-scattering GGX of pbrt-v4 and Mitsuba 3.
    pub multiple_scattering: Option<bool>,
    /// MTL `d` (dissolve; `Tr` is read as `d = 1 − Tr`).
    pub dissolve: Option<f32>,
    /// MTL `illum` (illumination model number, 0–10).
    pub illum: Option<u8>,
    /// Textures by role, each multiplying its factor (glTF) or replacing its colour (MTL).
    pub textures: MaterialTextures,
    /// glTF `alphaMode` (with `alphaCutoff`); `None` where the file says nothing.
    pub alpha_mode: Option<AlphaMode>,
    /// glTF `baseColorFactor`'s alpha.
    pub alpha: Option<f32>,
    /// Raw glTF material `extras`, a manifest material's `extras` object, or MTL statements this loader does not
    /// read, passed up untouched (spectral overrides go here).
    pub extras: Option<serde_json::Value>,
}

impl MaterialDesc {
    /// A material of the given format in which the file says nothing (every parameter `None`).
    pub fn new(name: impl Into<String>, format: MaterialFormat) -> Self {
        Self {
            name: name.into(),
            format,
            model: None,
            metal: None,
            eta: None,
            k: None,
            nonlinear: None,
            base_color: None,
            diffuse: None,
            specular: None,
            ks: None,
            shininess: None,
            metallic: None,
            roughness: None,
            transmission: None,
            transmittance: None,
            ior: None,
            dispersion: None,
            absorption: None,
            thickness: None,
            emission: None,
            emission_strength: None,
            double_sided: None,
            specular_layer: None,
            clearcoat: None,
            sheen: None,
            anisotropy: None,
            fluorescence: None,
            multiple_scattering: None,
            dissolve: None,
            illum: None,
            textures: MaterialTextures::default(),
            alpha_mode: None,
            alpha: None,
            extras: None,
        }
    }

    /// Whether shading needs the surface's tangents: for a normal map, or for the direction of anisotropy.
    pub fn needs_tangents(&self) -> bool {
        self.textures.has_normal_map() || self.anisotropy.is_some()
    }

    /// A manifest material in which nothing is written (the renderer's defaults apply to every field).
    pub fn named(name: impl Into<String>) -> Self {
        Self::new(name, MaterialFormat::Manifest)
    }

    /// Every spectrum this material refers to, with the field it comes from.
    pub fn spectra(&self) -> Vec<(&'static str, &SpectrumDesc)> {
        let mut out = Vec::new();
        if let Some(s) = &self.base_color {
            out.push(("base_color", s));
        }
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
        if let Some(FluorescenceDesc::Spectra { excitation, emission, .. }) = self.fluorescence.as_deref() {
            out.push(("fluorescence.excitation", excitation));
            out.push(("fluorescence.emission", emission));
        }
        out
    }
}

/// The unit a light's `intensity` is stated in (`docs/scene-format.md`, "Light units").
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightUnit {
    /// Radiant: W (point, spot: flux), W/m² (directional: irradiance), W/(m² sr) (environment).
    Watt,
    /// Luminous flux (point, spot).
    Lumen,
    /// Luminous intensity, lm/sr (point, spot; glTF's unit for them).
    Candela,
    /// Illuminance, lm/m² (directional; glTF's unit for it).
    Lux,
    /// Luminance, cd/m² (environment, background, emissive surfaces).
    Nit,
}

impl LightUnit {
    /// The name a manifest writes.
    pub fn name(self) -> &'static str {
        match self {
            Self::Watt => "W",
            Self::Lumen => "lm",
            Self::Candela => "cd",
            Self::Lux => "lux",
            Self::Nit => "nits",
        }
    }

    /// The unit of a manifest's `"unit"` string.
    pub fn from_name(name: &str) -> Option<Self> {
        [Self::Watt, Self::Lumen, Self::Candela, Self::Lux, Self::Nit].into_iter().find(|u| u.name() == name)
    }
}

/// How bright a light is: a number and its unit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightAmount {
    /// The number the file writes (finite, ≥ 0).
    pub value: f32,
    /// Its unit.
    pub unit: LightUnit,
}

/// A light source as written in a scene file: where it is, its spectrum (whose shape, not scale, is
/// used) and how bright it is in a stated unit; assembly converts to the renderer's photometric scale.
#[derive(Clone, Debug, PartialEq)]
pub enum LightDesc {
    /// Isotropic point light; irradiance at distance d is `intensity · spectrum / d²`.
    Point {
        /// World position.
        position: Vec3,
        /// Emission spectrum.
        spectrum: SpectrumDesc,
        /// Luminous intensity (cd), flux (lm, W).
        intensity: LightAmount,
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
        /// Luminous intensity (cd), flux (lm, W).
        intensity: LightAmount,
    },
    /// Distant light; `direction` is the unit direction the light travels.
    Directional {
        /// Unit direction of travel.
        direction: Vec3,
        /// Emission spectrum.
        spectrum: SpectrumDesc,
        /// Illuminance on a surface facing the light (lux, W/m²).
        intensity: LightAmount,
    },
    /// A luminaire: a point light whose luminous intensity per direction is a measured goniometric web
    /// (an IES LM-63 or EULUMDAT file), oriented by its nadir and C0 plane. A variant of its own rather than
    /// an option of `Point`, so every exhaustive match has to say what a web means to it.
    Luminaire {
        /// World position (the photometric centre).
        position: Vec3,
        /// Unit direction of the luminaire's nadir (γ = 0).
        direction: Vec3,
        /// Unit direction in the luminaire's C0 half-plane, perpendicular to `direction`.
        up: Vec3,
        /// Emission spectrum: its colour only (normalised to luminance 1, unless absolute).
        spectrum: SpectrumDesc,
        /// A plain factor on the file's candela (`intensity`, default 1).
        scale: f32,
        /// The file's web.
        web: PhotometricWeb,
    },
    /// Environment illuminating the scene from all directions: uniform, or an image (`map`).
    Environment {
        /// Emission spectrum (uniform environment; a map's texels give its colour instead).
        spectrum: SpectrumDesc,
        /// Luminance (nits) or radiance (W/(m² sr)); for a map, the factor its texels are multiplied by.
        intensity: LightAmount,
        /// An equirectangular image giving the radiance per direction, if any.
        map: Option<EnvironmentMapDesc>,
    },
}

/// Which half of the C planes a goniometric web gives, the rest following by symmetry (LM-63's last
/// horizontal angle; EULUMDAT's `Isym`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WebSymmetry {
    /// Every plane given (C from 0 up to 360).
    None,
    /// One plane: the same in every C plane.
    Rotational,
    /// Planes C0 to C180, mirrored about the C0–C180 plane: I(C) = I(360° − C).
    C0C180,
    /// Planes C90 to C270, mirrored about the C90–C270 plane: I(C) = I(180° − C).
    C90C270,
    /// Planes C0 to C90, mirrored about both: I(C) = I(180° − C) = I(360° − C).
    Quadrant,
}

/// Which format a goniometric web was read from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PhotometricFormat {
    /// IES LM-63 (1986 to 2019), type C photometry.
    Ies,
    /// EULUMDAT (`.ldt`).
    Ldt,
}

/// A luminaire's goniometric web as its file gives it, in candela after the file's multipliers: intensities
/// at the C planes the file lists (`c_deg`, within 0–360°) and vertical angles γ from the nadir (`gamma_deg`,
/// within 0–180°), both strictly increasing. The renderer expands the symmetry and interpolates.
#[derive(Clone, Debug, PartialEq)]
pub struct PhotometricWeb {
    /// The file, resolved against the scene file's folder.
    pub path: PathBuf,
    /// IES or LDT.
    pub format: PhotometricFormat,
    /// Which planes follow by symmetry.
    pub symmetry: WebSymmetry,
    /// The C planes given, degrees.
    pub c_deg: Vec<f32>,
    /// The vertical angles, degrees from the nadir.
    pub gamma_deg: Vec<f32>,
    /// Candela, plane by plane: `candela[c * gamma_deg.len() + g]`, finite and ≥ 0.
    pub candela: Vec<f32>,
}

/// An equirectangular (latitude–longitude) environment image, as a scene file names it: decoded by the
/// integrator (`docs/scene-format.md`, "Environment maps").
#[derive(Clone, Debug, PartialEq)]
pub struct EnvironmentMapDesc {
    /// The image file (Radiance `.hdr` or OpenEXR `.exr`), resolved against the scene file's folder.
    pub path: PathBuf,
    /// Rotation of the map about the world's +Y axis, degrees (counter-clockwise seen from above).
    pub rotation_deg: f32,
}

impl LightDesc {
    /// The light's kind as a lowercase word (`"point"`, `"spot"`, `"directional"`, `"environment"`).
    pub fn kind(&self) -> &'static str {
        match self {
            Self::Point { .. } => "point",
            Self::Spot { .. } => "spot",
            Self::Luminaire { .. } => "luminaire",
            Self::Directional { .. } => "directional",
            Self::Environment { .. } => "environment",
        }
    }

    /// The light's spectrum.
    pub fn spectrum(&self) -> &SpectrumDesc {
        match self {
            Self::Point { spectrum, .. }
            | Self::Spot { spectrum, .. }
            | Self::Luminaire { spectrum, .. }
            | Self::Directional { spectrum, .. }
            | Self::Environment { spectrum, .. } => spectrum,
        }
    }
}

/// How a camera projects the scene onto its image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// A pinhole: rays from the eye, spread by the camera's `vfov_deg`.
    Perspective,
    /// Parallel rays along the view direction from a rectangle through the eye, `2·xmag` wide and
    /// `2·ymag` high in scene units (glTF 2.0 `camera.orthographic`; both finite and > 0). The renderer
    /// keeps `ymag` and widens or narrows the rectangle to the image's aspect, as `vfov_deg` for a
    /// pinhole; `xmag / ymag` is the camera's aspect ratio.
    Orthographic {
        /// Half the width of the viewed rectangle.
        xmag: f32,
        /// Half the height of the viewed rectangle.
        ymag: f32,
    },
}

/// A camera as written in a scene file.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraDesc {
    /// Eye position.
    pub position: Vec3,
    /// Point looked at.
    pub look_at: Vec3,
    /// Up vector (need not be unit or orthogonal to the view direction, must not be parallel to it).
    pub up: Vec3,
    /// Vertical field of view in degrees, in (0, 180) (perspective projection only).
    pub vfov_deg: f32,
    /// Perspective or orthographic.
    pub projection: Projection,
    /// Width / height the camera was made for (glTF `aspectRatio`, an orthographic camera's `xmag / ymag`),
    /// finite and > 0, if the file says: it sets the default image height from the default width.
    pub aspect_ratio: Option<f32>,
    /// Image width in pixels, if the file fixes it.
    pub width: Option<u32>,
    /// Image height in pixels, if the file fixes it.
    pub height: Option<u32>,
}

/// The kind of file a scene was loaded from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneFormat {
    /// A scene manifest (`.json`).
    Manifest,
    /// A glTF 2.0 file (`.gltf`, `.glb`) loaded directly.
    Gltf,
    /// A Wavefront OBJ file (`.obj`) loaded directly.
    Obj,
}

/// A manifest's `"settings"`: every key is one of these, its value checked when the file is read, so the
/// integrators above read one typed value each (an unwritten key is `None`: the integrator's default).
/// Serialises as written (unset keys left out), for `spectrace info`.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Settings {
    /// The model `--integrator auto` renders with, by name as written (the layers above know the names).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub integrator: Option<String>,
    /// The recursion limit (bounces), in `0..=`[`Settings::MAX_DEPTH`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_depth: Option<u32>,
    /// The bounces before the path tracer's Russian roulette may end a path, in `0..=`[`Settings::MAX_DEPTH`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rr_depth: Option<u32>,
}

impl Settings {
    /// The largest `max_depth` and `rr_depth` a manifest may ask for: far beyond any converged render (a
    /// path rarely survives 64 bounces), while a value written by mistake (`1e30`) is refused, not saturated.
    pub const MAX_DEPTH: u32 = 1024;
}

/// Everything read from a scene file: world-space geometry, materials, lights, camera and settings.
#[derive(Clone, Debug)]
pub struct SceneDescription {
    /// The file's format.
    pub format: SceneFormat,
    /// Analytic spheres; material indices point into `materials`.
    pub spheres: Vec<Sphere>,
    /// World-space triangle meshes; material indices point into `materials`.
    pub meshes: Vec<Mesh>,
    /// Meshes placed several times, kept once in object space with a transform per placement (see
    /// [`crate::LoadOptions::flatten_triangles`]); material indices point into `materials`.
    pub instances: Vec<Instances>,
    /// Materials, indexed by the shapes' material indices.
    pub materials: Vec<MaterialDesc>,
    /// Images the materials' textures use, each read once.
    pub images: Vec<ImageDesc>,
    /// Light sources.
    pub lights: Vec<LightDesc>,
    /// The camera, if the file has one (the first of `cameras`).
    pub camera: Option<CameraDesc>,
    /// Every camera the file holds, named, in file order (glTF may hold several; a manifest's one is named
    /// `"camera"`). `camera` is the first; the layers above may choose another (`--camera N|NAME`).
    pub cameras: Vec<(String, CameraDesc)>,
    /// Radiance seen by rays that escape the scene (spectrum, scale); not a light.
    pub background: Option<(SpectrumDesc, f32)>,
    /// The manifest's render settings, each key checked when the file is read (none for glTF and OBJ).
    pub settings: Settings,
    /// The program that wrote the file, as the file names it (glTF `asset.generator`); `None` where the
    /// file does not say (and for OBJ and manifests). The layers above read exporters' known habits from it.
    pub generator: Option<String>,
    /// Things the user should know: skipped primitives, ignored textures, defaults added.
    pub warnings: Vec<String>,
    /// Digest (XXH64) of the bytes of every file read to build the description, the scene file
    /// and each file it refers to, in the order read (not their paths, so a moved scene keeps
    /// it); 0 for a description built in code. Film files record it so that parts rendered
    /// on different machines are known to come from the same scene.
    pub source_hash: u64,
    /// Every file read to build the description (the scene file, included meshes, MTL files, buffers and
    /// images) or checked for the layers above to read (spectrum CSVs, an environment map), as resolved
    /// (relative to the working folder unless absolute), each once; empty for a description built in code.
    /// A render refuses to write an output over one of them.
    pub source_files: Vec<std::path::PathBuf>,
    /// The memory the loaders charged and the scene's budget ([`crate::LoadOptions::max_memory`]): the
    /// assembly step charges the images it decodes against what is left.
    pub memory: crate::MemoryBudget,
}

impl SceneDescription {
    /// An empty description of a file of the given format.
    pub fn empty(format: SceneFormat) -> Self {
        Self {
            format,
            spheres: Vec::new(),
            meshes: Vec::new(),
            instances: Vec::new(),
            materials: Vec::new(),
            images: Vec::new(),
            lights: Vec::new(),
            camera: None,
            cameras: Vec::new(),
            background: None,
            settings: Settings::default(),
            generator: None,
            warnings: Vec::new(),
            source_hash: 0,
            source_files: Vec::new(),
            memory: crate::MemoryBudget::default(),
        }
    }

    /// Axis-aligned bounds of all spheres, mesh vertices and placed instances, `None` when the scene has no
    /// geometry.
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
        for (a, b) in self.instances.iter().filter_map(Instances::bounds) {
            lo = lo.min(a);
            hi = hi.max(b);
        }
        (lo.x <= hi.x).then_some((lo, hi))
    }
}
