//! The material record shared by both integrators, with its physically based model decided once, at
//! assembly ([`MaterialModel`]).

use colorimetry::DenselySampledSpectrum;

use crate::absorption::Absorption;
use crate::bsdf::Metal;
use crate::error::{Error, Result};
use crate::fluorescence::Fluorescence;
use crate::ior::Ior;
use crate::spectra::is_flat;

/// A surface and, for transparent objects, the medium it encloses.
///
/// The paper's Hall model reads the coefficients and spectra directly (`k_d F_d(λ)`,
/// `k_s F_s(λ)`, `k_t T_s(λ)`, exponent n). The path tracer reads the same record through its
/// [`MaterialModel`], which the scene assembly chose from the file's explicit `model` key or
/// from what the file format means (pbrt-v4's `Material` variants: the closed list of what a
/// surface can be); nothing downstream guesses.
#[derive(Debug, Clone)]
pub struct Material {
    /// Name, for messages and `spectrace info`.
    pub name: String,
    /// k_d: weight of the diffuse term.
    pub kd: f32,
    /// F_d(λ) (the paper's R_i(λ)): diffuse reflectance in [0, 1].
    pub diffuse: DenselySampledSpectrum,
    /// k_s: weight of specular reflection (highlights and the reflected ray).
    pub ks: f32,
    /// F_s(λ): specular reflectance in [0, 1].
    pub specular: DenselySampledSpectrum,
    /// n: exponent of the highlights (Table 1's "diffuse factor" 20).
    pub shininess: f32,
    /// k_t: weight of transmission.
    pub kt: f32,
    /// T_s(λ): spectral transmittance of the surface in [0, 1].
    pub transmittance: DenselySampledSpectrum,
    /// Index of refraction of the enclosed medium.
    pub ior: Ior,
    /// Absorption of the enclosed medium (Bouguer–Beer), if any.
    pub absorption: Option<Absorption>,
    /// Emitted radiance spectrum, if the surface emits: luminance-normalised × strength (nits), or as
    /// written × strength for an absolute (`"normalize": false`) spectrum.
    pub emission: Option<DenselySampledSpectrum>,
    /// Whether an emitting surface emits from both faces; otherwise only from its front, the side its
    /// geometric normal (triangle winding, sphere outside) points to. Manifests and OBJ: both; glTF:
    /// `doubleSided` (the specification's default is one-sided).
    pub two_sided: bool,
    /// The physically based model: which BSDF the path tracer builds from this record.
    pub model: MaterialModel,
    /// Whether Hall's k_s and k_t of a transmissive surface are weighted per hit by the Fresnel
    /// reflectance F and 1 − F (glTF transmission, whose k_s = k_t = 1 assume it), rather than
    /// constants as the paper writes them. Read by the paper's model only.
    pub fresnel_weighted: bool,
    /// Whether the rough conductor, dielectric and glTF metallic–roughness models (with its clear coat) add
    /// the energy of multiple scattering between microfacets (Kulla–Conty; Turquin), which single-scattering
    /// GGX loses (up to 69 % of a white metal's at α = 1). Default yes; `false` (the manifest's
    /// `"multiple_scattering": false`) gives the uncompensated lobes of pbrt-v4 and Mitsuba 3 and the glTF
    /// specification's single-scattering layers, for comparisons.
    pub multiple_scattering: bool,
    /// glTF `KHR_materials_specular` on the dielectric specular layer of the glTF models; `None`: the
    /// plain layer (weight 1, F0 from `ior`).
    pub dielectric_specular: Option<DielectricSpecular>,
    /// glTF `KHR_materials_clearcoat`: a clear GGX varnish over the model; `None`: none.
    pub coat: Option<Coat>,
    /// glTF `KHR_materials_sheen`: a layer of fibres over the model (beneath the coat); `None`: none.
    pub sheen: Option<Sheen>,
    /// glTF `KHR_materials_anisotropy` on the glTF models' specular lobes and rough glass; `None`: isotropic.
    pub anisotropy: Option<Anisotropy>,
    /// A conductor's measured complex index (manifest `eta` and `k`), read by [`MaterialModel::Conductor`]
    /// without a named `metal`; `None`: the metal's tables, or the specular colour's index.
    pub conductor_index: Option<ConductorIndex>,
    /// Re-emission at other wavelengths ([`Fluorescence`]) beside the Lambertian reflectance k_d F_d;
    /// only [`MaterialModel::Diffuse`] has it. `None`: light keeps its wavelength.
    pub fluorescence: Option<Fluorescence>,
}

/// A conductor's complex index of refraction η(λ) + iκ(λ) relative to the outside medium, as measured:
/// read by linear interpolation in wavelength between the data's samples. The data must cover the
/// wavelengths the renderer samples ([`colorimetry::LAMBDA_MIN`]–[`colorimetry::LAMBDA_MAX`]): nothing is
/// extrapolated ([`ConductorIndex::new`] refuses shorter data).
#[derive(Debug, Clone, PartialEq)]
pub struct ConductorIndex {
    eta: DenselySampledSpectrum,
    k: DenselySampledSpectrum,
}

/// The largest η or κ a measured index may have.
const MAX_INDEX: f64 = 1e4;

impl ConductorIndex {
    /// η and κ, each covering 360–830 nm, η > 0 and κ ≥ 0 throughout.
    pub fn new(eta: DenselySampledSpectrum, k: DenselySampledSpectrum) -> Result<Self> {
        let (lo, hi) = (f64::from(colorimetry::LAMBDA_MIN), f64::from(colorimetry::LAMBDA_MAX));
        for (what, s) in [("eta", &eta), ("k", &k)] {
            if s.lambda_min() > lo || s.lambda_max() < hi {
                return Err(Error::Uncovered { what, from: s.lambda_min(), to: s.lambda_max() });
            }
        }
        // The grid points within the sampled range (and the one beyond each end, which interpolation reads).
        fn inside(s: &DenselySampledSpectrum, lo: f64, hi: f64) -> impl Iterator<Item = f64> + '_ {
            let (first, step) = (s.lambda_min(), s.step());
            s.values()
                .iter()
                .enumerate()
                .filter(move |(i, _)| (lo - step..=hi + step).contains(&(first + step * *i as f64)))
                .map(|(_, v)| *v)
        }
        // Measured metals have η below 10 and κ below 100 in the visible; the bound only keeps the Fresnel
        // arithmetic finite.
        if let Some(v) = inside(&eta, lo, hi).find(|v| !(*v > 0.0 && *v <= MAX_INDEX)) {
            return Err(Error::OutOfRange { what: "eta", value: v, range: "> 0 and at most 10 000" });
        }
        if let Some(v) = inside(&k, lo, hi).find(|v| !(*v >= 0.0 && *v <= MAX_INDEX)) {
            return Err(Error::OutOfRange { what: "k", value: v, range: ">= 0 and at most 10 000" });
        }
        Ok(Self { eta, k })
    }

    /// η(λ).
    pub fn eta(&self) -> &DenselySampledSpectrum {
        &self.eta
    }

    /// κ(λ).
    pub fn k(&self) -> &DenselySampledSpectrum {
        &self.k
    }

    /// Reflectance at normal incidence, ((η − 1)² + κ²) / ((η + 1)² + κ²), at every nanometre of 360–830 nm:
    /// the metal's colour, for RGB rendering and Hall's specular colour F_s.
    pub fn normal_reflectance(&self) -> DenselySampledSpectrum {
        let lambda: Vec<f64> = (0..=470).map(|i| f64::from(colorimetry::LAMBDA_MIN) + f64::from(i)).collect();
        let r: Vec<f64> = lambda
            .iter()
            .map(|&l| {
                let (n, k) = (self.eta.eval(l), self.k.eval(l));
                ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k)
            })
            .collect();
        DenselySampledSpectrum::from_samples(&lambda, &r)
            .expect("a 1 nm grid with finite reflectances in [0, 1] is a valid spectrum")
    }
}

/// `KHR_materials_anisotropy`: the GGX α along a direction in the tangent plane raised to
/// mix(α, 1, strength²), α across it unchanged ([`crate::bsdf::GltfMetalRoughBxdf::with_anisotropy`]). The
/// direction is the tangent rotated by `rotation` counter-clockwise (and, with a texture, its texel's
/// direction rotated so).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Anisotropy {
    /// `anisotropyStrength` in (0, 1].
    pub strength: f32,
    /// `anisotropyRotation` in radians.
    pub rotation: f32,
}

/// `KHR_materials_sheen`: f = f_sheen + f_material (1 − max₃(colour) E(μ_o)) (`bsdf::SheenBxdf`, the
/// extension's albedo scaling in its view-only form), so the path tracer picks the sheen with probability
/// max₃(colour) E(μ_o) at each hit and the material otherwise (an exact mixture).
#[derive(Debug, Clone)]
pub struct Sheen {
    /// `sheenColorFactor` as a reflectance spectrum.
    pub color: DenselySampledSpectrum,
    /// The factor's largest channel (linear RGB), max₃ above.
    pub color_max: f32,
    /// `sheenRoughnessFactor` in [0, 1] (used directly as the distribution's r, as the extension says).
    pub roughness: f32,
}

/// `KHR_materials_specular` as the glTF models use it: the dielectric specular layer's Fresnel is
/// weight · (F0(λ) + (1 − F0(λ))(1 − |V·H|)⁵) with F0(λ) = min(((1 − ior)/(1 + ior))² · colour(λ), 1), and
/// the diffuse layer beneath it loses what the layer's strongest wavelength reflects (the extension's
/// `max_value(fr)`, taken over λ).
#[derive(Debug, Clone)]
pub struct DielectricSpecular {
    /// `specularFactor` in [0, 1].
    pub weight: f32,
    /// F0(λ) in [0, 1], the colour and the index already applied.
    pub f0: DenselySampledSpectrum,
    /// ((1 − ior)/(1 + ior))² (1 for `KHR_materials_ior`'s 0) × the colour's largest component: what a `specularColorTexture`'s texels,
    /// upsampled with the colour divided by that component, are scaled by (`f0` is then per hit).
    pub f0_scale: f32,
}

/// `KHR_materials_clearcoat`: `mix(material, specular_brdf(α = roughness²), weight · F(|N·V|))` with
/// Schlick's F of index 1.5 (F0 = 0.04). The mix depends on the view direction only, so the path tracer
/// picks the coat with that probability at each hit and the material otherwise (an exact mixture).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coat {
    /// `clearcoatFactor` in (0, 1].
    pub weight: f32,
    /// `clearcoatRoughnessFactor` in [0, 1] (GGX α = roughness²).
    pub roughness: f32,
}

/// What a surface is for a physically based integrator (pbrt-v4 `Material`'s closed list of
/// variants). Each variant says which fields of the [`Material`] record its BSDF reads.
///
/// Roughness is glTF's perceptual roughness r in [0, 1]; the GGX (Trowbridge–Reitz) α is r²
/// (glTF 2.0 Appendix B; pbrt-v4's `remaproughness` is the same idea).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum MaterialModel {
    /// Lambertian reflection of k_d F_d(λ).
    Diffuse,
    /// A smooth mirror reflecting k_s F_s(λ) at every angle.
    Mirror,
    /// A dielectric interface: Fresnel-weighted reflection and refraction into the enclosed
    /// medium (`ior`, `absorption`), transmission filtered by k_t T_s(λ); smooth at roughness 0,
    /// else GGX (Walter et al. 2007).
    Dielectric {
        /// Perceptual roughness r (α = r²).
        roughness: f32,
    },
    /// A thin-walled dielectric slab (glTF transmission without `KHR_materials_volume`): Fresnel
    /// reflection with inter-reflections, transmission straight through filtered by k_t T_s(λ);
    /// encloses no medium.
    ThinDielectric,
    /// A GGX conductor with the measured complex index of `metal`, or (`None`) a normal-incidence
    /// reflectance k_s F_s(λ) (η = 1, κ from the reflectance), with Kulla–Conty compensation.
    Conductor {
        /// The measured metal, if named.
        metal: Option<Metal>,
        /// Perceptual roughness r (α = r²).
        roughness: f32,
    },
    /// A dielectric coat of index `ior` (at n_d) over a Lambertian base k_d F_d(λ), with the light between
    /// them summed (Mitsuba 3's `plastic` at roughness 0, `roughplastic` otherwise; `bsdf::PlasticBxdf`).
    Plastic {
        /// Perceptual roughness r of the coat (α = r²).
        roughness: f32,
        /// Whether the base's colour applies at every bounce under the coat (Mitsuba's `nonlinear`).
        nonlinear: bool,
    },
    /// The glTF 2.0 metallic–roughness BRDF (Appendix B) with base colour F_d(λ) and the
    /// dielectric index `ior` at n_d, its diffuse layer coupled by albedo scaling
    /// ([`crate::bsdf::GltfMetalRoughBxdf::conserving`]), and with [`Material::multiple_scattering`] the
    /// multiple scattering of its microfacet layers put back ([`crate::bsdf::GltfMetalRoughBxdf::compensated`]).
    GltfMetalRough {
        /// glTF `metallicFactor` in [0, 1].
        metallic: f32,
        /// glTF `roughnessFactor` in [0, 1].
        roughness: f32,
    },
    /// The glTF BRDF with `KHR_materials_transmission` where it is not plain glass (a factor below 1, or a
    /// metallic part): the extension's `dielectric_brdf = fresnel_mix(ior, mix(diffuse_brdf,
    /// specular_btdf, transmission), specular_brdf)` inside `mix(dielectric_brdf, metal_brdf, metallic)`.
    /// Its three parts share the specular layer, so it is the mixture of [`MaterialModel::GltfMetalRough`]
    /// (weight 1 − (1 − metallic)·transmission) and the dielectric (thin or rough or smooth, tinted by the
    /// base colour; weight (1 − metallic)·transmission), which the path tracer picks between per hit.
    GltfTransmission {
        /// glTF `metallicFactor` in [0, 1].
        metallic: f32,
        /// glTF `roughnessFactor` in [0, 1], of every part.
        roughness: f32,
        /// `transmissionFactor` in (0, 1].
        transmission: f32,
        /// Whether the transmitting part is thin-walled (no `KHR_materials_volume` thickness) or refracts
        /// into the enclosed medium.
        thin: bool,
    },
}

impl MaterialModel {
    /// The name `spectrace info` reports (for the first six, the manifest `model` value).
    pub fn name(&self) -> &'static str {
        match self {
            Self::Diffuse => "diffuse",
            Self::Mirror => "mirror",
            Self::Dielectric { .. } => "dielectric",
            Self::ThinDielectric => "thin_dielectric",
            Self::Conductor { .. } => "conductor",
            Self::Plastic { .. } => "plastic",
            Self::GltfMetalRough { .. } => "gltf_metal_rough",
            Self::GltfTransmission { .. } => "gltf_transmission",
        }
    }

    /// The parameters in [0, 1] the model carries: (what, value).
    fn unit_parameters(&self) -> Vec<(&'static str, f32)> {
        match *self {
            Self::Dielectric { roughness } | Self::Conductor { roughness, .. } | Self::Plastic { roughness, .. } => {
                vec![("roughness", roughness)]
            }
            Self::GltfMetalRough { metallic, roughness } => vec![("metallic", metallic), ("roughness", roughness)],
            Self::GltfTransmission { metallic, roughness, transmission, .. } => {
                vec![("metallic", metallic), ("roughness", roughness), ("transmission", transmission)]
            }
            Self::Diffuse | Self::Mirror | Self::ThinDielectric => Vec::new(),
        }
    }
}

impl Coat {
    /// The coat's share of the light seen from a direction at `cos_o` to the coat's normal:
    /// weight · F_Schlick(F0 = 0.04, |cos_o|), the probability with which the path tracer picks it.
    pub fn probability(&self, cos_o: f32) -> f32 {
        /// ((1 − 1.5) / (1 + 1.5))²: the coat's index is 1.5 (the extension fixes it).
        const COAT_F0: f32 = 0.04;
        self.weight * crate::bsdf::schlick(COAT_F0, cos_o.abs())
    }
}

impl Material {
    /// A Lambertian surface with the given reflectance.
    pub fn diffuse(name: &str, reflectance: DenselySampledSpectrum) -> Self {
        Self {
            name: name.to_owned(),
            kd: 1.0,
            diffuse: reflectance,
            ks: 0.0,
            specular: DenselySampledSpectrum::constant(0.0),
            shininess: 1.0,
            kt: 0.0,
            transmittance: DenselySampledSpectrum::constant(0.0),
            ior: Ior::Constant(1.5),
            absorption: None,
            emission: None,
            model: MaterialModel::Diffuse,
            fresnel_weighted: false,
            multiple_scattering: true,
            dielectric_specular: None,
            coat: None,
            sheen: None,
            anisotropy: None,
            conductor_index: None,
            fluorescence: None,
            two_sided: true,
        }
    }

    /// Check coefficients and spectra: finite, non-negative, reflectances within [0, 1].
    pub fn validate(&self) -> Result<()> {
        for (what, v) in [("kd", self.kd), ("ks", self.ks), ("kt", self.kt), ("shininess", self.shininess)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::OutOfRange { what, value: v.into(), range: "finite, >= 0" });
            }
        }
        for (what, v) in self.model.unit_parameters() {
            if !(0.0..=1.0).contains(&v) {
                return Err(Error::OutOfRange { what, value: v.into(), range: "[0, 1]" });
            }
        }
        for (what, s) in [
            ("diffuse reflectance", &self.diffuse),
            ("specular reflectance", &self.specular),
            ("transmittance", &self.transmittance),
        ] {
            for &v in s.values() {
                if !(0.0..=1.0).contains(&v) {
                    return Err(Error::OutOfRange { what, value: v, range: "[0, 1]" });
                }
            }
        }
        if let Some(c) = &self.coat {
            for (what, v) in [("clearcoat", c.weight), ("clearcoat roughness", c.roughness)] {
                if !(0.0..=1.0).contains(&v) {
                    return Err(Error::OutOfRange { what, value: v.into(), range: "[0, 1]" });
                }
            }
        }
        if let Some(d) = &self.dielectric_specular {
            if !(0.0..=1.0).contains(&d.weight) {
                return Err(Error::OutOfRange { what: "specular weight", value: d.weight.into(), range: "[0, 1]" });
            }
            if let Some(&v) = d.f0.values().iter().find(|v| !(0.0..=1.0).contains(*v)) {
                return Err(Error::OutOfRange { what: "specular F0", value: v, range: "[0, 1]" });
            }
        }
        if let Some(e) = &self.emission
            && let Some(&v) = e.values().iter().find(|v| !(v.is_finite() && **v >= 0.0))
        {
            return Err(Error::OutOfRange { what: "emission", value: v, range: "finite, >= 0" });
        }
        let n = self.ior.eval(550.0);
        if !(n.is_finite() && n >= 0.0) {
            return Err(Error::OutOfRange { what: "ior at 550 nm", value: n.into(), range: "finite, >= 0" });
        }
        if let Some(f) = &self.fluorescence {
            if self.model != MaterialModel::Diffuse {
                return Err(Error::FluorescenceModel);
            }
            f.check_energy(&self.lambertian_reflectance())?;
        }
        Ok(())
    }

    /// The reflectance the path tracer gives a Lambertian surface: k_d F_d(λ) clamped to [0, 1].
    pub fn lambertian_reflectance(&self) -> DenselySampledSpectrum {
        self.diffuse.map(|v| (v * f64::from(self.kd)).clamp(0.0, 1.0))
    }

    /// Whether light passes through the surface: the model transmits and its filter
    /// k_t T_s(λ) is not black. The one answer both integrators and `spectrace info` use.
    pub fn is_transmissive(&self) -> bool {
        matches!(
            self.model,
            MaterialModel::Dielectric { .. } | MaterialModel::ThinDielectric | MaterialModel::GltfTransmission { .. }
        ) && self.kt > 0.0
            && self.transmittance.max_value() > 0.0
    }

    /// Whether light refracts into a medium the surface encloses (a dielectric that is not
    /// thin-walled and transmits).
    pub fn encloses_medium(&self) -> bool {
        matches!(self.model, MaterialModel::Dielectric { .. } | MaterialModel::GltfTransmission { thin: false, .. })
            && self.is_transmissive()
    }

    /// Whether refraction separates wavelengths (only then do paths split by wavelength).
    pub fn is_dispersive(&self) -> bool {
        self.encloses_medium() && self.ior.is_dispersive()
    }

    /// Whether the enclosed medium absorbs (only then is Beer's law evaluated).
    pub fn absorbs(&self) -> bool {
        self.encloses_medium() && self.absorption.as_ref().is_some_and(Absorption::absorbs)
    }

    /// Whether the surface emits light.
    pub fn emits(&self) -> bool {
        self.emission.as_ref().is_some_and(|e| e.max_value() > 0.0)
    }

    /// Whether every spectrum of the material is flat (the same at all wavelengths).
    pub fn is_spectrally_flat(&self) -> bool {
        is_flat(&self.diffuse)
            && is_flat(&self.specular)
            && is_flat(&self.transmittance)
            && self.absorption.as_ref().is_none_or(|a| is_flat(a.sigma_a()))
            && self.emission.as_ref().is_none_or(is_flat)
            && !self.ior.is_dispersive()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validation_rejects_reflectance_above_one_and_negative_coefficients() {
        let mut m = Material::diffuse("m", DenselySampledSpectrum::constant(0.5));
        assert!(m.validate().is_ok());
        m.diffuse = DenselySampledSpectrum::constant(1.5);
        assert!(matches!(m.validate(), Err(Error::OutOfRange { what: "diffuse reflectance", .. })));
        m.diffuse = DenselySampledSpectrum::constant(0.5);
        m.kd = -1.0;
        assert!(matches!(m.validate(), Err(Error::OutOfRange { what: "kd", .. })));
    }

    #[test]
    fn flags_follow_the_data() {
        let mut m = Material::diffuse("glass", DenselySampledSpectrum::constant(0.0));
        assert!(!m.is_transmissive() && !m.absorbs() && !m.is_dispersive());
        m.kt = 0.9;
        m.transmittance = DenselySampledSpectrum::constant(1.0);
        m.absorption = Some(Absorption::from_per_unit_transmittance(&DenselySampledSpectrum::constant(0.95)).unwrap());
        // Hall coefficients alone do not make a surface transmit: the model decides.
        assert!(!m.is_transmissive() && !m.absorbs());
        m.model = MaterialModel::ThinDielectric;
        assert!(m.is_transmissive() && !m.encloses_medium() && !m.absorbs(), "a thin wall encloses nothing");
        m.model = MaterialModel::Dielectric { roughness: 0.0 };
        assert!(m.is_transmissive() && m.absorbs() && !m.is_dispersive());
        assert!(m.is_spectrally_flat());
        m.ior = Ior::from_abbe(1.5, 40.0).unwrap();
        assert!(m.is_dispersive() && !m.is_spectrally_flat());
        // A part-transmitting glTF surface transmits; it encloses a medium only with a volume.
        m.model = MaterialModel::GltfTransmission { metallic: 0.0, roughness: 0.1, transmission: 0.5, thin: true };
        assert!(m.is_transmissive() && !m.encloses_medium() && !m.absorbs());
        m.model = MaterialModel::GltfTransmission { metallic: 0.0, roughness: 0.1, transmission: 0.5, thin: false };
        assert!(m.is_transmissive() && m.encloses_medium() && m.absorbs());
    }

    #[test]
    fn validation_rejects_model_parameters_outside_the_unit_interval() {
        let mut m = Material::diffuse("m", DenselySampledSpectrum::constant(0.5));
        m.model = MaterialModel::GltfMetalRough { metallic: 1.0, roughness: 1.0 };
        assert!(m.validate().is_ok());
        m.model = MaterialModel::GltfMetalRough { metallic: 1.5, roughness: 0.5 };
        assert!(matches!(m.validate(), Err(Error::OutOfRange { what: "metallic", .. })));
        m.model = MaterialModel::Conductor { metal: Some(Metal::Au), roughness: f32::NAN };
        assert!(matches!(m.validate(), Err(Error::OutOfRange { what: "roughness", .. })));
    }
}
