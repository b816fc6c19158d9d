//! From material descriptions to spectral materials: the one rule that decides each material's
//! model and Hall coefficients from what its file format means (`docs/scene-format.md`,
//! "Material models"). Texture loading asks it too (an MTL `map_Ks` needs the model before
//! assembly), so it sits below both.

use colorimetry::DenselySampledSpectrum;
use geometry::{AbsorptionDesc, FluorescenceDesc, IorDesc, MaterialDesc, MaterialFormat, SpectrumDesc};
use materials::bsdf::Metal;
use materials::{Absorption, Coat, ConductorIndex, DielectricSpecular, Fluorescence, Ior, Material, MaterialModel};

use crate::error::{Error, Result};

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
pub(crate) const DEFAULT_ROUGHNESS: f32 = 0.5;

/// glTF's default index of refraction (KHR_materials_ior), also the manifest's and MTL's.
pub(crate) const DEFAULT_IOR: f32 = 1.5;

/// Hall's k_s of a manifest plastic without `ks`: ((1.5 − 1)/(1.5 + 1))², its coat's reflectance at normal
/// incidence.
const PLASTIC_KS: f32 = 0.04;

/// Hall's model's coefficients as a file format means them (`docs/scene-format.md`, "glTF", "OBJ/MTL").
#[derive(Debug, PartialEq)]
pub(crate) struct HallParams {
    pub(crate) base_color: SpectrumDesc,
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

pub(crate) fn hall_params(d: &MaterialDesc) -> HallParams {
    let ior = d.ior.clone().unwrap_or(IorDesc::Constant(DEFAULT_IOR));
    let emission_strength = d.emission_strength.unwrap_or(1.0).max(0.0);
    match d.format {
        MaterialFormat::Manifest => {
            let roughness = d.roughness.unwrap_or(DEFAULT_ROUGHNESS);
            // A mirror or conductor is all specular unless the file adds a diffuse part; a plastic's coat
            // reflects F0 of index 1.5 at normal incidence (what Hall's k_s gives it in the paper's model).
            let specular_model = matches!(d.model.as_deref(), Some("mirror" | "conductor"));
            let plastic = d.model.as_deref() == Some("plastic");
            HallParams {
                base_color: d.base_color.clone().unwrap_or(SpectrumDesc::Constant(0.5)),
                kd: d.diffuse.unwrap_or(if specular_model { 0.0 } else { 1.0 }),
                ks: d.ks.unwrap_or(if specular_model {
                    1.0
                } else if plastic {
                    PLASTIC_KS
                } else {
                    0.0
                }),
                specular: d.specular.clone(),
                shininess: d.shininess.unwrap_or_else(|| shininess_from_roughness(roughness)),
                roughness,
                metallic: d.metallic.unwrap_or(0.0),
                // `"model": "dielectric"` alone means clear glass.
                kt: d.transmission.unwrap_or(if d.model.as_deref() == Some("dielectric") { 1.0 } else { 0.0 }),
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
                // Transmitted light is not also diffusely reflected (KHR_materials_transmission: the
                // transmission replaces the diffuse lobe by the factor).
                kd: 1.0 - kt,
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

/// The physically based model of a material, decided here once: the manifest's explicit `model` key, else
/// what the file format means (`docs/scene-format.md`, "Material models"). `transmits`: k_t T_s is not
/// black; `diffuse_black`: F_d is black.
pub(crate) fn material_model(
    d: &MaterialDesc,
    p: &HallParams,
    transmits: bool,
    diffuse_black: bool,
) -> materials::Result<MaterialModel> {
    // The physical models are polished unless the file says otherwise (Hall's exponent keeps its own
    // default, `DEFAULT_ROUGHNESS`, so the paper's scenes keep their highlights).
    let roughness = || d.roughness.unwrap_or(0.0).clamp(0.0, 1.0);
    Ok(match d.format {
        MaterialFormat::Manifest => match d.model.as_deref() {
            Some("diffuse") => MaterialModel::Diffuse,
            Some("dielectric") => MaterialModel::Dielectric { roughness: roughness() },
            Some("mirror") => MaterialModel::Mirror,
            Some("plastic") => {
                MaterialModel::Plastic { roughness: roughness(), nonlinear: d.nonlinear.unwrap_or(false) }
            }
            Some("conductor") => MaterialModel::Conductor {
                metal: d.metal.as_deref().map(str::parse::<Metal>).transpose()?,
                roughness: roughness(),
            },
            // Hall's coefficients read physically (a manifest without `model` is a Hall material):
            // transmissive → smooth dielectric, metallic or purely specular → mirror, else Lambertian.
            _ => {
                if transmits {
                    MaterialModel::Dielectric { roughness: 0.0 }
                } else if p.metallic >= 0.5 || (p.kd == 0.0 && p.ks > 0.0) {
                    MaterialModel::Mirror
                } else {
                    MaterialModel::Diffuse
                }
            }
        },
        // glTF 2.0: transmission refracts into the closed mesh when KHR_materials_volume gives a thickness,
        // else the surface is thin-walled (KHR_materials_volume: "thicknessFactor 0 … thin-walled"); a
        // transmission factor below 1 or a metallic part blends that glass with the opaque BRDF, as
        // KHR_materials_transmission writes it; everything else is the metallic–roughness BRDF of Appendix B.
        MaterialFormat::Gltf => {
            let thin = !d.thickness.is_some_and(|t| t > 0.0);
            // A transmission texture varies the factor over the surface: the blend, read per hit.
            if transmits && (p.kt < 1.0 || p.metallic > 0.0 || d.textures.transmission.is_some()) {
                // KHR_materials_transmission's blend: part glass, part the opaque BRDF.
                MaterialModel::GltfTransmission {
                    metallic: p.metallic,
                    roughness: p.roughness,
                    transmission: p.kt,
                    thin,
                }
            } else if transmits {
                if thin { MaterialModel::ThinDielectric } else { MaterialModel::Dielectric { roughness: p.roughness } }
            } else {
                MaterialModel::GltfMetalRough { metallic: p.metallic, roughness: p.roughness }
            }
        }
        // MTL: glass (illum 4/6/7 or d < 1) is a smooth dielectric (`Ns` of glass sets its highlight, not a
        // rough surface); illum 5 or a black Kd with a Ks is a GGX conductor reflecting Ks; a Ks with Kd is a
        // GGX specular layer over the diffuse one (the glTF BRDF with metallic 0, Fresnel from Ni);
        // α from Ns as documented; illum 0/1 or no Ks is Lambertian.
        MaterialFormat::Mtl => {
            let illum = d.illum.unwrap_or(2);
            if transmits {
                MaterialModel::Dielectric { roughness: 0.0 }
            } else if p.ks > 0.0 && (illum == 5 || diffuse_black) {
                MaterialModel::Conductor { metal: None, roughness: p.roughness }
            } else if p.ks > 0.0 && illum >= 2 {
                MaterialModel::GltfMetalRough { metallic: 0.0, roughness: p.roughness }
            } else {
                MaterialModel::Diffuse
            }
        }
    })
}

/// The solid reading of a glTF material's transmission ([`material_model`] reads one without
/// `KHR_materials_volume` as a thin wall): the same glass refracting into the mesh it encloses, of the
/// material's roughness. Other models are returned unchanged.
pub(crate) fn solid_glass_model(desc: &MaterialDesc, model: MaterialModel) -> MaterialModel {
    match model {
        MaterialModel::ThinDielectric => MaterialModel::Dielectric { roughness: hall_params(desc).roughness },
        MaterialModel::GltfTransmission { metallic, roughness, transmission, .. } => {
            MaterialModel::GltfTransmission { metallic, roughness, transmission, thin: false }
        }
        other => other,
    }
}

/// `KHR_materials_specular` on a glTF dielectric layer of index `ior` (at n_d): F0(λ) = min(F0_ior ·
/// colour(λ), 1) with F0_ior = ((n − 1)/(n + 1))² (1 in `KHR_materials_ior`'s mode 0). The colour may exceed 1:
/// it is upsampled as a reflectance at its largest component's scale. `None` for the extension's defaults
/// (factor 1, white, no texture), which are the plain layer.
pub(crate) fn dielectric_specular(
    layer: &geometry::SpecularLayer,
    ior: &Ior,
    textured: bool,
) -> Option<DielectricSpecular> {
    if layer.is_default() && !textured {
        return None;
    }
    let n = ior.eval(materials::LAMBDA_D);
    let f0_ior = if n > 0.0 { f64::from(((n - 1.0) / (n + 1.0)).powi(2)) } else { 1.0 };
    let scale = layer.color_scale();
    let color = if scale > 0.0 {
        materials::reflectance_from_rgb(layer.color.map(|c| c / scale))
    } else {
        DenselySampledSpectrum::constant(0.0)
    };
    let f0 = color.map(|c| (f0_ior * c * f64::from(scale)).clamp(0.0, 1.0));
    Some(DielectricSpecular { weight: layer.factor, f0, f0_scale: (f0_ior * f64::from(scale)) as f32 })
}

/// A reflectance-like spectrum (values in [0, 1] expected): RGB is upsampled as a reflectance.
pub(crate) fn reflectance_spectrum(desc: &SpectrumDesc) -> materials::Result<DenselySampledSpectrum> {
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
        SpectrumDesc::Absolute(inner) => reflectance_spectrum(inner)?,
    })
}

/// An emission spectrum scaled to luminance `intensity` (RGB colours are upsampled as light);
/// an absolute one (`"normalize": false`) is its own values times `intensity`.
pub(crate) fn emission_spectrum(desc: &SpectrumDesc, intensity: f32) -> materials::Result<DenselySampledSpectrum> {
    emission_spectrum_scaled(desc, f64::from(intensity))
}

pub(crate) fn emission_spectrum_scaled(
    desc: &SpectrumDesc,
    intensity: f64,
) -> materials::Result<DenselySampledSpectrum> {
    if !(intensity.is_finite() && intensity >= 0.0) {
        return Err(materials::Error::OutOfRange { what: "intensity", value: intensity, range: "finite, >= 0" });
    }
    let spd = match desc {
        SpectrumDesc::Rgb(rgb) => materials::illuminant_from_rgb(*rgb)?,
        SpectrumDesc::Constant(v) => DenselySampledSpectrum::constant(f64::from(*v)),
        SpectrumDesc::Absolute(inner) => match inner.as_ref() {
            SpectrumDesc::Rgb(rgb) => materials::illuminant_from_rgb(*rgb)?,
            other => reflectance_spectrum(other)?,
        },
        other => materials::luminance_normalized(&reflectance_spectrum(other)?),
    };
    Ok(spd.scaled(intensity))
}

/// The transmittance of `desc` given its diffuse reflectance (see [`material_from_desc`]).
pub(crate) fn transmittance_spectrum(
    desc: &MaterialDesc,
    diffuse: &DenselySampledSpectrum,
) -> materials::Result<DenselySampledSpectrum> {
    Ok(match (&desc.transmittance, desc.format) {
        (Some(s), _) => reflectance_spectrum(s)?,
        (None, MaterialFormat::Mtl | MaterialFormat::Manifest) => DenselySampledSpectrum::constant(1.0),
        (None, MaterialFormat::Gltf) => diffuse.clone(),
    })
}

/// A manifest conductor's measured `eta` and `k` ([`ConductorIndex`]: covering 360–830 nm, read linearly).
/// They are optical constants, not colours: an RGB triple is refused rather than upsampled.
fn conductor_index(desc: &MaterialDesc) -> materials::Result<Option<ConductorIndex>> {
    let (Some(eta), Some(k)) = (&desc.eta, &desc.k) else { return Ok(None) };
    let constants = |what: &'static str, s: &SpectrumDesc| match s {
        SpectrumDesc::Rgb(_) => Err(materials::Error::NotAColour { what }),
        SpectrumDesc::Constant(v) => Ok(DenselySampledSpectrum::constant(f64::from(*v))),
        other => reflectance_spectrum(other),
    };
    Ok(Some(ConductorIndex::new(constants("eta", eta)?, constants("k", k)?)?))
}

/// A manifest material's `fluorescence`, with the reflectance a re-radiation matrix gives (its diagonal).
fn fluorescence(desc: &MaterialDesc) -> materials::Result<(Option<Fluorescence>, Option<DenselySampledSpectrum>)> {
    Ok(match desc.fluorescence.as_deref() {
        None => (None, None),
        Some(FluorescenceDesc::Spectra { excitation, emission, quantum_yield }) => {
            let excitation = reflectance_spectrum(excitation)?;
            let emission = reflectance_spectrum(emission)?;
            (Some(Fluorescence::from_spectra(excitation, &emission, *quantum_yield)?), None)
        }
        Some(FluorescenceDesc::Matrix(path)) => {
            if desc.base_color.is_some() {
                return Err(materials::Error::FluorescenceMatrixReflectance);
            }
            let (f, reflectance) = Fluorescence::from_matrix_csv(path)?;
            (Some(f), Some(reflectance))
        }
    })
}

/// The model [`material_from_desc`] decides for `desc`, for what must agree with it before the material is
/// built (an MTL `map_Ks` needs a specular layer before assembly; its textures are loaded first).
pub(crate) fn model_of(desc: &MaterialDesc) -> materials::Result<MaterialModel> {
    let p = hall_params(desc);
    let diffuse = reflectance_spectrum(&p.base_color)?;
    let transmits = p.kt > 0.0 && transmittance_spectrum(desc, &diffuse)?.max_value() > 0.0;
    material_model(desc, &p, transmits, diffuse.max_value() <= 0.0)
}

pub(crate) fn material_from_desc(desc: &MaterialDesc) -> Result<Material> {
    let wrap = |source| Error::Material { material: desc.name.clone(), source };
    let p = hall_params(desc);
    let (fluorescence, matrix_reflectance) = fluorescence(desc).map_err(wrap)?;
    // A re-radiation matrix's diagonal is the surface's reflectance.
    let diffuse = match matrix_reflectance {
        Some(r) => r,
        None => reflectance_spectrum(&p.base_color).map_err(wrap)?,
    };
    let metal = desc.metal.as_deref().map(str::parse::<Metal>).transpose().map_err(wrap)?;
    let conductor_index = conductor_index(desc).map_err(wrap)?;
    // A named or measured metal's specular colour is its normal-incidence reflectance (what Hall's model
    // and RGB rendering see of it).
    let specular = match (&p.specular, metal, &conductor_index) {
        (Some(s), ..) => reflectance_spectrum(s).map_err(wrap)?,
        (None, Some(metal), _) => metal.normal_reflectance(),
        (None, None, Some(index)) => index.normal_reflectance(),
        (None, None, None) => DenselySampledSpectrum::constant(1.0),
    };
    // glTF tints transmitted light by the base colour; a manifest without `transmittance` is clear glass (as
    // documented, and as pbrt-v4 and Mitsuba 3 default: it was tinted by the diffuse colour, 0.5 unless
    // given, which halved the light at each crossing); MTL glass without `Tf` is clear (its `Kd` is the
    // colour of the diffuse part, often black for glass).
    let transmittance = transmittance_spectrum(desc, &diffuse).map_err(wrap)?;
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
    let transmits = p.kt > 0.0 && transmittance.max_value() > 0.0;
    let model = material_model(desc, &p, transmits, diffuse.max_value() <= 0.0).map_err(wrap)?;
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
        model,
        // glTF writes a transmission factor, not Hall's constants: its reflection and transmission share
        // the light by Fresnel (k_s = k_t = 1 made glass 10–30× brighter than paper).
        fresnel_weighted: desc.format == MaterialFormat::Gltf && transmits,
        // glTF's doubleSided defaults to false; the manifest's `double_sided` and OBJ default to both sides.
        two_sided: desc.double_sided.unwrap_or(desc.format != MaterialFormat::Gltf),
        multiple_scattering: desc.multiple_scattering.unwrap_or(true),
        dielectric_specular: desc.specular_layer.as_ref().and_then(|l| {
            dielectric_specular(l, &ior, desc.textures.specular.is_some() || desc.textures.specular_color.is_some())
        }),
        coat: desc.clearcoat.map(|c| Coat { weight: c.factor, roughness: c.roughness }),
        sheen: desc.sheen.map(|s| materials::Sheen {
            color: materials::reflectance_from_rgb(s.color),
            color_max: s.color[0].max(s.color[1]).max(s.color[2]),
            roughness: s.roughness,
        }),
        anisotropy: desc.anisotropy.map(|a| materials::Anisotropy { strength: a.strength, rotation: a.rotation }),
        conductor_index,
        fluorescence,
    };
    material.validate().map_err(wrap)?;
    Ok(material)
}
