//! The physically based spectral path tracer ("path"): unidirectional path tracing with
//! next-event estimation and multiple importance sampling (Veach 1997, power heuristic),
//! Russian roulette (pbrt-v4 `PathIntegrator::Li`), Beer–Lambert absorption inside
//! dielectrics, and dispersion by hero-wavelength sampling (Wilkie et al. 2014; pbrt-v4
//! `DielectricMaterial::GetBxDF` drops the secondary wavelengths only where the index varies).
//!
//! One code path serves every spectral strategy: a path carries N lanes and a
//! [`SampledWavelengths<N>`]. With fixed lanes (`rgb`, `bins:N`) every spectrum of the scene
//! is projected once per render and the film sums lanes with the [`Lanes`] weights; with
//! `hero:K` the wavelengths are drawn per sample and spectra are evaluated at them, and the
//! film accumulates the Monte Carlo estimate `SampledSpectrum::to_xyz`.
//! `docs/path-tracer.md` documents the model and its choices.

use colorimetry::{DenselySampledSpectrum, SampledSpectrum, SampledWavelengths};
use geometry::{Hit, Primitive, Ray, ShadowRay, spawn_ray, spawn_shadow_ray};
use glam::{Vec2, Vec3};
use materials::bsdf::{
    Bsdf, ConductorBxdf, Frame, GltfMetalRoughBxdf, Metal, PlasticBxdf, PlasticTable, RoughDielectricBxdf, SheenBxdf,
    ThinDielectricBxdf, TrowbridgeReitz, plastic_table, sheen_albedo,
};
use materials::{Anisotropy, Coat, Ior, LAMBDA_D, MaterialModel};

use crate::film::{ObjectId, Sensor, WavelengthTable};
use crate::integrators::fluorescence::FluorescenceTables;
use crate::integrators::kernel::{Kernel, Radiance, RayCount, Splat};
use crate::lights::envmap::EnvironmentMap;
use crate::lights::{Emission, LiSample, LightSampleContext, emits_towards};
use crate::options::{PathOptions, WavelengthPdf};
use crate::sampling::{Sampler, power_heuristic};
use crate::scene::RenderScene;
use crate::spectral::{Lanes, SpectrumKind};
use crate::surface::{HitTangent, tangent_frame, triangle_uvs};
use crate::texture::{MAX_ALPHA_SKIPS, MaterialTextures, Uv, VertexColorHit};

/// Bounces when neither the options nor the scene's `max_depth` setting say: deep enough
/// that Russian roulette, not the limit, ends almost every path.
const DEFAULT_MAX_DEPTH: u32 = 64;

/// Russian roulette starts after this many bounces when neither the options nor the scene's
/// `rr_depth` setting say, so short paths (direct and first indirect light) are never cut.
/// Measured as time to equal error (`docs/path-tracer.md`, "Light transport"): against starting
/// after the 1st bounce, the 3rd is 1.1–2.2× faster on the five glass spheres and two glTF
/// scenes, about 10 % slower on the Cornell box.
const RR_START_DEPTH: u32 = 3;

/// Index into the render's spectrum table.
pub(super) type SpecId = u32;

/// Every spectrum of the scene, either projected on fixed lanes or kept dense for hero sampling.
pub(super) enum Spectra<const N: usize> {
    Fixed(Vec<SampledSpectrum<N>>),
    Dense(Vec<DenselySampledSpectrum>),
}

impl<const N: usize> Spectra<N> {
    #[inline]
    pub(super) fn eval(&self, id: SpecId, lambda: &SampledWavelengths<N>) -> SampledSpectrum<N> {
        match self {
            Self::Fixed(v) => v[id as usize],
            Self::Dense(v) => v[id as usize].sample(lambda),
        }
    }

    /// [`Spectra::eval`] through `last`, the previous spectrum this path evaluated at the same call
    /// site. Hero wavelengths stay the same along a path (dispersion changes only their densities),
    /// so the light at every next-event estimate, or the wall a path bounces off again, is the value
    /// interpolated before: with `hero:4` on the Cornell box the interpolation was 11 % of the
    /// instructions (docs/perf.md). Fixed lanes read their projected table and leave `last` alone.
    #[inline]
    pub(super) fn eval_memo(
        &self,
        id: SpecId,
        lambda: &SampledWavelengths<N>,
        last: &mut LastSpectrum<N>,
    ) -> SampledSpectrum<N> {
        match self {
            Self::Fixed(v) => v[id as usize],
            Self::Dense(v) => {
                if let Some((last_id, s)) = last.0
                    && last_id == id
                {
                    return s;
                }
                let s = v[id as usize].sample(lambda);
                last.0 = Some((id, s));
                s
            }
        }
    }
}

/// The last spectrum evaluated at one call site of a path, with its table index (see
/// [`Spectra::eval_memo`]); starts empty with each camera ray.
#[derive(Clone, Copy)]
pub(super) struct LastSpectrum<const N: usize>(pub(super) Option<(SpecId, SampledSpectrum<N>)>);

/// A material's BSDF with its spectra in the render's table: the [`MaterialModel`] baked.
#[derive(Debug, Clone, Copy)]
enum PathScattering {
    /// Lambertian, reflectance k_d F_d clamped to 1.
    Diffuse { r: SpecId },
    /// Smooth mirror, reflectance k_s F_s clamped to 1.
    Mirror { r: SpecId },
    /// Smooth dielectric, transmission filter k_t T_s clamped to 1.
    Dielectric { tint: SpecId },
    /// GGX rough dielectric (α > 0), transmission filter k_t T_s clamped to 1.
    RoughDielectric { tint: SpecId, alpha: f32, compensate: bool },
    /// Thin-walled dielectric, transmission filter k_t T_s clamped to 1, index at n_d.
    ThinDielectric { tint: SpecId, eta: f32 },
    /// GGX conductor: a named metal, a measured index `index` (η, κ), or the reflectance `r` = k_s F_s
    /// clamped to 1 (also the metal's colour in RGB, where the lanes are not wavelengths).
    Conductor { metal: Option<Metal>, index: Option<(SpecId, SpecId)>, r: SpecId, alpha: f32, compensate: bool },
    /// A dielectric coat over a Lambertian base k_d F_d clamped to 1, index at n_d, with its table.
    Plastic { base: SpecId, alpha: f32, eta: f32, nonlinear: bool, table: &'static PlasticTable },
    /// The glTF metallic–roughness BRDF: base colour k_d F_d clamped to 1, index at n_d.
    GltfMetalRough { base: SpecId, metallic: f32, roughness: f32, ior: f32, specular: Option<SpecularLayer> },
    /// [`MaterialModel::GltfTransmission`]: per hit, the glass part (tinted by the base colour F_d
    /// clamped to 1; thin-walled at the index at n_d, or refracting) with probability
    /// (1 − metallic)·transmission, else the metallic–roughness BRDF with the rest of the metal.
    GltfTransmission {
        base: SpecId,
        metallic: f32,
        roughness: f32,
        ior: f32,
        transmission: f32,
        thin: bool,
        specular: Option<SpecularLayer>,
    },
}

/// [`materials::DielectricSpecular`] with its F0 in the render's table.
#[derive(Debug, Clone, Copy)]
struct SpecularLayer {
    weight: f32,
    f0: SpecId,
    /// The largest F0 over the spectrum.
    f0_max: f32,
    /// What a specular colour texture's texels are scaled by ([`materials::DielectricSpecular::f0_scale`]).
    f0_scale: f32,
}

/// `KHR_materials_specular` at one hit, its textures applied.
#[derive(Debug, Clone, Copy)]
struct HitSpecular<const N: usize> {
    weight: f32,
    f0: SampledSpectrum<N>,
    f0_max: f32,
}

#[derive(Debug, Clone)]
pub(super) struct PathMaterial {
    scattering: PathScattering,
    /// σ_a of the enclosed medium, when it absorbs (only a transmissive model encloses one).
    pub(super) sigma_a: Option<SpecId>,
    pub(super) emission: Option<SpecId>,
    /// Whether the emission leaves both faces.
    two_sided: bool,
    ior: Ior,
    /// `KHR_materials_clearcoat`, picked per hit with [`Coat::probability`].
    coat: Option<Coat>,
    /// `KHR_materials_sheen`, picked per hit (beneath the coat) by [`PathTracer::pick_sheen`].
    sheen: Option<PathSheen>,
    /// `KHR_materials_anisotropy` of the glTF models' lobes and rough glass, oriented per hit by
    /// [`PathTracer::anisotropy_at`].
    anisotropy: Option<Anisotropy>,
    /// [`materials::Material::multiple_scattering`] of the glTF metallic–roughness lobes and the clear coat
    /// (the conductor and rough dielectric carry theirs in their variants).
    multiple_scattering: bool,
    /// The material's entry in [`PathTracer::fluorescence`] (hero wavelengths only: fixed lanes cannot shift).
    fluorescence: Option<u32>,
}

/// [`materials::Sheen`] with its colour in the spectra table.
#[derive(Debug, Clone, Copy)]
struct PathSheen {
    color: SpecId,
    color_max: f32,
    roughness: f32,
}

/// An area light whose radiance is read from its material's emissive texture.
#[derive(Debug, Clone, Copy)]
pub(super) struct TexturedLight {
    material: u32,
    /// The triangle's vertices.
    p: [Vec3; 3],
    /// The uvs of its vertices (the barycentrics themselves for a mesh without uvs, as on hits).
    uv: [Vec2; 3],
}

impl TexturedLight {
    /// The uv at `q`, a point on the triangle (up to rounding): its barycentrics' blend of the vertices' uvs
    /// (`geometry::barycentrics`, as hits interpolate vertex data); the first vertex's on a sliver whose Gram
    /// determinant cancels to 0.
    fn uv_at(&self, q: Vec3) -> Vec2 {
        match geometry::barycentrics(self.p, q) {
            Some([b0, b1, b2]) => b0 * self.uv[0] + b1 * self.uv[1] + b2 * self.uv[2],
            None => self.uv[0],
        }
    }
}

/// Everything a path-traced render needs, precomputed.
pub(crate) struct PathTracer<'a, const N: usize> {
    pub(super) scene: &'a RenderScene,
    pub(super) spectra: Spectra<N>,
    materials: Vec<PathMaterial>,
    default_material: PathMaterial,
    /// The emission of each light of `scene.emitters`, in its order.
    pub(super) light_spectra: Vec<SpecId>,
    /// The spectra the uniform environment sums (an environment map adds its radiance per direction).
    environment_spectra: Vec<SpecId>,
    /// D65 at luminance 1, the illuminant of emissive textures' texels; `None` without such textures.
    illuminant: Option<SpecId>,
    /// For each light of `scene.emitters` (empty without emissive textures): where it is a triangle of
    /// a material with an emissive texture, that material and its vertices' uvs.
    pub(super) textured_lights: Vec<Option<TexturedLight>>,
    /// Whether the lanes are RGB channels (an environment map then gives its texels' RGB).
    rgb_lanes: bool,
    pub(super) max_depth: u32,
    /// Bounces before Russian roulette may end a path.
    pub(super) rr_depth: u32,
    /// Whether any material needs a rough or layered BSDF: otherwise [`PathTracer::trace`] is
    /// instantiated with the smooth models only, so scenes without them pay nothing.
    pub(super) rough: bool,
    /// The fluorescent materials' sampling tables (empty with fixed lanes, which cannot shift wavelengths).
    fluorescence: FluorescenceTables,
}

/// Every spectrum a render reads, each with what it is (the lanes project reflectances, emission
/// and absorption differently), indexed by [`SpecId`].
#[derive(Default)]
struct SpectrumTable(Vec<(DenselySampledSpectrum, SpectrumKind)>);

impl SpectrumTable {
    fn add(&mut self, s: DenselySampledSpectrum, kind: SpectrumKind) -> SpecId {
        self.0.push((s, kind));
        (self.0.len() - 1) as SpecId
    }
}

/// `s · k` clamped to [0, 1]: a reflectance as Hall's coefficient scales it.
fn clamp01(s: &DenselySampledSpectrum, k: f32) -> DenselySampledSpectrum {
    s.map(|v| (v * f64::from(k)).clamp(0.0, 1.0))
}

/// A material as the path tracer reads it: its model's lobes with their spectra in `table`.
fn path_material(table: &mut SpectrumTable, m: &materials::Material) -> PathMaterial {
    // (Only the glTF models read it; only glTF materials have it.)
    let specular = m.dielectric_specular.as_ref().map(|d| SpecularLayer {
        weight: d.weight,
        f0: table.add(d.f0.clone(), SpectrumKind::Reflectance),
        f0_max: d.f0.max_value() as f32,
        f0_scale: d.f0_scale,
    });
    let scattering = match m.model {
        MaterialModel::Diffuse => {
            PathScattering::Diffuse { r: table.add(clamp01(&m.diffuse, m.kd), SpectrumKind::Reflectance) }
        }
        MaterialModel::Mirror => {
            PathScattering::Mirror { r: table.add(clamp01(&m.specular, m.ks), SpectrumKind::Reflectance) }
        }
        MaterialModel::Dielectric { roughness } => {
            let tint = table.add(clamp01(&m.transmittance, m.kt), SpectrumKind::Reflectance);
            // (`KHR_materials_anisotropy` stretches even a smooth interface: the rough lobe then.)
            if roughness > 0.0 || m.anisotropy.is_some() {
                PathScattering::RoughDielectric {
                    tint,
                    alpha: roughness * roughness,
                    compensate: m.multiple_scattering,
                }
            } else {
                PathScattering::Dielectric { tint }
            }
        }
        MaterialModel::ThinDielectric => PathScattering::ThinDielectric {
            tint: table.add(clamp01(&m.transmittance, m.kt), SpectrumKind::Reflectance),
            eta: m.ior.eval(LAMBDA_D),
        },
        MaterialModel::Conductor { metal, roughness } => PathScattering::Conductor {
            metal,
            // η and κ are read at the lanes' wavelengths like a reflectance (fixed lanes point-sample
            // them); RGB lanes never read them (the reflectance `r` stands in there).
            index: m.conductor_index.as_ref().map(|c| {
                (
                    table.add(c.eta().clone(), SpectrumKind::Reflectance),
                    table.add(c.k().clone(), SpectrumKind::Reflectance),
                )
            }),
            r: table.add(clamp01(&m.specular, m.ks), SpectrumKind::Reflectance),
            alpha: roughness * roughness,
            compensate: m.multiple_scattering,
        },
        MaterialModel::Plastic { roughness, nonlinear } => {
            let (alpha, eta) = (roughness * roughness, m.ior.eval(LAMBDA_D));
            PathScattering::Plastic {
                base: table.add(clamp01(&m.diffuse, m.kd), SpectrumKind::Reflectance),
                alpha,
                eta,
                nonlinear,
                table: plastic_table(alpha, eta, m.multiple_scattering),
            }
        }
        MaterialModel::GltfMetalRough { metallic, roughness } => PathScattering::GltfMetalRough {
            base: table.add(clamp01(&m.diffuse, m.kd), SpectrumKind::Reflectance),
            metallic,
            roughness,
            ior: m.ior.eval(LAMBDA_D),
            specular,
        },
        // glTF's base colour is the diffuse colour and the transmission tint alike (k_d = 1 − k_t is
        // Hall's split, which the mixture weight replaces).
        MaterialModel::GltfTransmission { metallic, roughness, transmission, thin } => {
            PathScattering::GltfTransmission {
                base: table.add(clamp01(&m.diffuse, 1.0), SpectrumKind::Reflectance),
                metallic,
                roughness,
                ior: m.ior.eval(LAMBDA_D),
                transmission,
                thin,
                specular,
            }
        }
    };
    PathMaterial {
        scattering,
        sigma_a: m
            .absorption
            .as_ref()
            .filter(|_| m.absorbs())
            .map(|a| table.add(a.sigma_a().clone(), SpectrumKind::SigmaA)),
        emission: m.emission.as_ref().filter(|_| m.emits()).map(|e| table.add(e.clone(), SpectrumKind::Emission)),
        two_sided: m.two_sided,
        ior: m.ior,
        coat: m.coat,
        sheen: m.sheen.as_ref().map(|s| PathSheen {
            color: table.add(s.color.clone(), SpectrumKind::Reflectance),
            color_max: s.color_max,
            roughness: s.roughness,
        }),
        anisotropy: m.anisotropy,
        multiple_scattering: m.multiple_scattering,
        fluorescence: None,
    }
}

impl<'a, const N: usize> PathTracer<'a, N> {
    /// The tracer for `scene` and the film's sensor: `fixed` lanes (`rgb`, `bins:N`), or hero
    /// wavelengths (`None`) drawn from `options.wavelength_pdf`.
    pub(crate) fn new(scene: &'a RenderScene, fixed: Option<Lanes<N>>, options: &PathOptions) -> (Self, Sensor<N>) {
        let mut table = SpectrumTable::default();
        let mut materials: Vec<PathMaterial> = scene.materials.iter().map(|m| path_material(&mut table, m)).collect();
        let default_material = path_material(&mut table, &scene.default_material);
        let rough = materials.iter().chain([&default_material]).any(|m| {
            m.coat.is_some()
                || m.sheen.is_some()
                || !matches!(
                    m.scattering,
                    PathScattering::Diffuse { .. } | PathScattering::Mirror { .. } | PathScattering::Dielectric { .. }
                )
        });

        // The spectrum of each light, in the table: a light's own, the background, or the
        // emitting material's.
        let mut emission = |e: Emission| match e {
            Emission::Light(i) => table.add(scene.lights[i].spectrum.clone(), SpectrumKind::Emission),
            Emission::Background => {
                table.add(scene.background.clone().expect("the environment sums a background"), SpectrumKind::Emission)
            }
            Emission::Material(m) => {
                materials.get(m as usize).and_then(|m| m.emission).expect("area lights emit by their material")
            }
        };
        let environment_spectra: Vec<SpecId> = scene.emitters.le_escaped().iter().map(|&e| emission(e)).collect();
        let light_spectra: Vec<SpecId> = scene.emitters.iter().map(|(_, e)| emission(e)).collect();
        // An environment map beside uniform environments: its mean spectrum is not among the lights' (the
        // environment's entry is the first uniform one), but the wavelength density should follow it too.
        let map_mean: Option<SpecId> = match (scene.emitters.environment_map(), environment_spectra.is_empty()) {
            (Some(_), false) => scene
                .lights
                .iter()
                .position(|l| l.map.is_some())
                .map(|i| table.add(scene.lights[i].spectrum.clone(), SpectrumKind::Emission)),
            _ => None,
        };
        let emissive_textures = scene.textures.iter().flatten().any(MaterialTextures::has_emissive_texture);
        let illuminant =
            emissive_textures.then(|| table.add(colorimetry::srgb_illuminant().clone(), SpectrumKind::Emission));
        let textured_lights = if emissive_textures { textured_lights(scene) } else { Vec::new() };
        let rgb_lanes = fixed.as_ref().is_some_and(|lanes| lanes.rgb);
        let mut fluorescence = FluorescenceTables::default();
        if fixed.is_none() {
            let lights: Vec<&DenselySampledSpectrum> = light_spectra
                .iter()
                .chain(environment_spectra.iter().skip(1))
                .chain(map_mean.iter())
                .map(|&id| &table.0[id as usize].0)
                .collect();
            for (m, path) in scene.materials.iter().zip(&mut materials) {
                if let Some(f) = &m.fluorescence {
                    path.fluorescence = Some(fluorescence.add(f, &m.lambertian_reflectance(), &lights));
                }
            }
        }

        let (spectra, sensor) = match fixed {
            Some(lanes) => {
                let projected = table.0.iter().map(|(s, kind)| SampledSpectrum(lanes.project(s, *kind))).collect();
                (Spectra::Fixed(projected), Sensor::Fixed(lanes))
            }
            None => {
                let sensor = match options.wavelength_pdf {
                    WavelengthPdf::Visible => Sensor::Visible,
                    WavelengthPdf::Illuminant => {
                        let emitters: Vec<&DenselySampledSpectrum> = light_spectra
                            .iter()
                            .chain(environment_spectra.iter().skip(1))
                            .chain(map_mean.iter())
                            .map(|&id| &table.0[id as usize].0)
                            .collect();
                        Sensor::Tabulated(WavelengthTable::illuminant(&emitters))
                    }
                };
                (Spectra::Dense(table.0.into_iter().map(|(s, _)| s).collect()), sensor)
            }
        };
        let max_depth = options.max_depth.or(scene.settings.max_depth).unwrap_or(DEFAULT_MAX_DEPTH);
        let rr_depth = options.rr_depth.or(scene.settings.rr_depth).unwrap_or(RR_START_DEPTH);
        let tracer = Self {
            scene,
            spectra,
            materials,
            default_material,
            light_spectra,
            environment_spectra,
            illuminant,
            textured_lights,
            rgb_lanes,
            max_depth,
            rr_depth,
            rough,
            fluorescence,
        };
        (tracer, sensor)
    }

    #[cfg(test)]
    pub(crate) fn fluorescence_tables(&self) -> &FluorescenceTables {
        &self.fluorescence
    }

    #[cfg(test)]
    pub(crate) fn fluorescence_tables_mut(&mut self) -> &mut FluorescenceTables {
        &mut self.fluorescence
    }

    #[inline]
    pub(super) fn material(&self, index: Option<u32>) -> &PathMaterial {
        index.and_then(|i| self.materials.get(i as usize)).unwrap_or(&self.default_material)
    }

    /// The textures of material `index`, if it has any (`scene.textures` is empty for untextured scenes,
    /// so they pay one bounds check per hit).
    #[inline]
    pub(super) fn textures(&self, index: Option<u32>) -> Option<&MaterialTextures> {
        self.scene.textures.get(index? as usize)?.as_ref()
    }

    /// The hit's uvs in both of its mesh's sets, the second interpolated only where `textures` (the hit
    /// material's) read it.
    #[inline]
    pub(super) fn hit_uvs(&self, textures: Option<&MaterialTextures>, hit: &Hit) -> Uv {
        match textures {
            Some(t) if t.reads_second_uvs() => match crate::surface::second_uv(&self.scene.geometry, hit) {
                Some(second) => Uv { primary: hit.uv, second },
                None => Uv::same(hit.uv),
            },
            _ => Uv::same(hit.uv),
        }
    }

    /// The vertex colour at `hit`, if its mesh has vertex colours its material takes. Out of line: only
    /// the textured instantiation calls it, for materials that take vertex colours.
    #[inline(never)]
    fn vertex_color(&self, hit: &Hit) -> Option<VertexColorHit<'_>> {
        let at = self.scene.geometry.hit_triangle(hit)?;
        let colors = self.scene.vertex_colors.get(at.mesh_id)?.as_ref()?;
        Some(colors.at(at.mesh.indices()[at.triangle], at.barycentrics(hit.p)?))
    }

    /// The vertex colour at `hit` where `textures` (the hit material's) say its meshes have some.
    #[inline]
    pub(super) fn vertex_color_of(&self, textures: Option<&MaterialTextures>, hit: &Hit) -> Option<VertexColorHit<'_>> {
        if textures.is_some_and(MaterialTextures::has_vertex_colors) { self.vertex_color(hit) } else { None }
    }

    /// The base colour where vertex colours apply: they replace the material's when they include its
    /// factor, else they multiply its texture's or spectrum's reflectance. Out of line: only hits on
    /// vertex-coloured meshes need it, and textured scenes' loops stay as they were.
    #[inline(never)]
    fn vertex_colored_base(
        &self,
        colors: &VertexColorHit<'_>,
        textures: Option<&MaterialTextures>,
        uv: Uv,
        id: SpecId,
        lambda: &SampledWavelengths<N>,
        last: &mut LastSpectrum<N>,
    ) -> SampledSpectrum<N> {
        let tint = colors.eval(lambda, self.rgb_lanes);
        if colors.replaces_base() {
            return tint;
        }
        tint * match textures.and_then(|t| t.base_color.as_ref()) {
            Some(t) => t.eval(uv, lambda, self.rgb_lanes).0,
            None => self.spectra.eval_memo(id, lambda, last),
        }
    }

    /// Whether light passes between `hit` and the light sample (`target`, or direction `wi` to
    /// infinity), as a fraction: 0 or 1 through opaque surfaces; cut-outs (MASK) pass where
    /// alpha is below the cutoff and blended surfaces (BLEND) pass 1 − alpha, their expected
    /// transmission (no random choice, so shadow rays add no noise there). The first segment is
    /// `lifted` where given (the shadow terminator's wedge), the rest plain rays from each blocker.
    /// Kept out of line: only scenes with cut-outs call it, and inlined it would crowd the BSDF
    /// calls out of [`PathTracer::sample_light`] for every scene.
    #[inline(never)]
    pub(super) fn visibility(
        &self,
        hit: &Hit,
        lifted: Option<&ShadowRay>,
        target: Option<Vec3>,
        wi: Vec3,
        count: &mut RayCount,
    ) -> f32 {
        let geometry = &self.scene.geometry;
        let mut visible = 1.0f32;
        let mut from = *hit;
        for segment in 0..MAX_ALPHA_SKIPS {
            let blocker = match lifted.filter(|_| segment == 0) {
                Some(lifted) => geometry.shadow_blocker(lifted),
                None => {
                    let (shadow, t_max) = spawn_shadow_ray(&from, target, wi);
                    geometry.intersect(&shadow, t_max)
                }
            };
            let Some(blocker) = blocker else { return visible };
            let textures = self.textures(blocker.material);
            let vertex_alpha = self.vertex_color_of(textures, &blocker).map_or(1.0, |c| c.alpha());
            let coverage = textures.map_or(1.0, |t| t.coverage(self.hit_uvs(Some(t), &blocker), vertex_alpha));
            visible *= 1.0 - coverage;
            if visible <= 0.0 {
                return 0.0;
            }
            count.shadow_ray();
            from = blocker;
        }
        0.0
    }

    /// Radiance of the environment from `wi` (unit, pointing away from the scene): its uniform spectra
    /// summed, plus its map's [`PathTracer::map_radiance`] where it has one. The one definition for an
    /// escaping ray, next-event estimation and bdpt's vertices at infinity. Always inlined, as it was before
    /// the trace loop had map instances (measured: out of line it cost the white furnace 2–3 % more
    /// instructions).
    #[inline(always)]
    pub(super) fn environment_radiance(&self, wi: Vec3, lambda: &SampledWavelengths<N>) -> SampledSpectrum<N> {
        let mut l = SampledSpectrum([0.0; N]);
        for &id in &self.environment_spectra {
            l += self.spectra.eval(id, lambda);
        }
        if let Some(map) = self.scene.emitters.environment_map() {
            l += self.map_radiance(map, wi, lambda);
        }
        l
    }

    /// An environment map's radiance from `wi` (unit, pointing away from the scene): out of line, and
    /// added by the callers, so that the trace loop of scenes without a map is the one they had.
    #[inline(never)]
    pub(super) fn map_radiance(
        &self,
        map: &EnvironmentMap,
        wi: Vec3,
        lambda: &SampledWavelengths<N>,
    ) -> SampledSpectrum<N> {
        map.eval(wi, lambda, self.rgb_lanes)
    }

    /// Index of refraction for this path, splitting it by wavelength at the first dispersive
    /// surface: hero sampling keeps the hero wavelength (pbrt-v4 `TerminateSecondary`); fixed
    /// wavelength lanes keep one lane chosen uniformly; RGB lanes cannot split and use n_d.
    fn eta(
        ior: &Ior,
        lambda: &mut SampledWavelengths<N>,
        sensor: &Sensor<N>,
        lane: &mut Option<usize>,
        sampler: &mut Sampler,
    ) -> f32 {
        if !ior.is_dispersive() {
            return ior.eval(LAMBDA_D);
        }
        let j = match (sensor, *lane) {
            (_, Some(j)) => j,
            (Sensor::Fixed(lanes), None) if lanes.rgb => return ior.eval(LAMBDA_D),
            (Sensor::Fixed(lanes), None) => {
                let active = lanes.active();
                let j = ((sampler.uniform_aside() * active as f32) as usize).min(active - 1);
                *lane = Some(j);
                j
            }
            (Sensor::Visible | Sensor::Tabulated(_), None) => {
                lambda.terminate_secondary();
                *lane = Some(0);
                0
            }
        };
        ior.eval(lambda.lambda(j))
    }

    /// Radiance of the environment along an escaping ray and its MIS weight against light sampling,
    /// when `bsdf` gives the previous vertex's BSDF density and shading normal (`None`: weight 1,
    /// after a specular bounce or at the camera, which light sampling cannot reach).
    #[inline]
    pub(super) fn escaped_radiance(
        &self,
        ray: &Ray,
        lambda: &SampledWavelengths<N>,
        bsdf: Option<(f32, Vec3)>,
    ) -> (SampledSpectrum<N>, f32) {
        let emitters = &self.scene.emitters;
        let le = self.environment_radiance(ray.dir.normalize(), lambda);
        let weight = match bsdf {
            None => 1.0,
            Some((prev_pdf, prev_ns)) => {
                let ctx = LightSampleContext { p: ray.origin, ns: prev_ns };
                power_heuristic(prev_pdf, emitters.pdf_li_escaped(&ctx, ray.dir.normalize()))
            }
        };
        (le, weight)
    }

    /// What an emissive surface sends back: its emissive texture at `uv`, else its emission spectrum.
    #[inline]
    fn surface_emission(
        &self,
        emission: SpecId,
        textures: Option<&MaterialTextures>,
        uv: Uv,
        lambda: &SampledWavelengths<N>,
    ) -> SampledSpectrum<N> {
        match textures.filter(|t| t.has_emissive_texture()) {
            Some(t) => self.textured_emission(t, uv, lambda),
            None => self.spectra.eval(emission, lambda),
        }
    }

    /// Radiance along a camera ray (pbrt-v4 `PathIntegrator::Li`).
    ///
    /// `ROUGH`: whether the scene has rough or layered materials; without them the smooth models'
    /// code is all this instantiation contains. `TEXTURED`: whether any material has textures;
    /// without, no texture or cut-out code is in the loop (measured: +2.6 % instructions on the
    /// Cornell box when it was a run-time check).
    #[allow(clippy::too_many_arguments)]
    fn trace<const ROUGH: bool, const TEXTURED: bool>(
        &self,
        camera_ray: &Ray,
        start: PathStart,
        lambda: &mut SampledWavelengths<N>,
        sensor: &Sensor<N>,
        lane: &mut Option<usize>,
        sampler: &mut Sampler,
        count: &mut RayCount,
    ) -> (SampledSpectrum<N>, ObjectId) {
        let mut radiance = SampledSpectrum([0.0; N]);
        let mut beta = SampledSpectrum([1.0; N]);
        let mut eta_scale = 1.0f32;
        let mut ray = *camera_ray;
        let mut specular_bounce = start.specular;
        // The previous vertex's BSDF density and facing shading normal, for MIS at emitters.
        let mut prev_pdf = start.pdf;
        let mut prev_ns = start.ns;
        let mut first = ObjectId::Background;
        let mut depth = 0u32;
        // Distance travelled through cut-outs since the last vertex, and how many were passed.
        let mut skipped = 0.0f32;
        let mut skips = 0u32;
        // The surface's scattering spectrum and the sampled light's emission, as last evaluated.
        let mut last_surface = LastSpectrum(None);
        let mut last_light = LastSpectrum(None);
        // The film's wavelengths, once a fluorescent hit has moved `lambda` to the path's λ_in.
        let mut film_lambda = None;
        loop {
            count.rays += 1;
            let Some(hit) = self.scene.geometry.intersect(&ray, f32::INFINITY) else {
                if self.scene.emitters.has_environment() {
                    let weight = if specular_bounce { None } else { Some((prev_pdf, prev_ns)) };
                    let (le, weight) = self.escaped_radiance(&ray, lambda, weight);
                    radiance += beta * le * weight;
                }
                break;
            };
            let textures = if TEXTURED { self.textures(hit.material) } else { None };
            let colors = if TEXTURED { self.vertex_color_of(textures, &hit) } else { None };
            let uv = if TEXTURED { self.hit_uvs(textures, &hit) } else { Uv::same(hit.uv) };
            // A cut-out (or, with probability 1 − alpha, a blended surface) is not there: go on
            // through it in the same direction, the path's vertex unchanged.
            if skips < MAX_ALPHA_SKIPS && Self::cut_away(textures, colors, uv, sampler) {
                skipped += hit.t * ray.dir.length();
                skips += 1;
                ray = spawn_ray(&hit, ray.dir);
                continue;
            }
            if depth == 0 {
                first = ObjectId::Material(hit.material);
            }
            let m = self.material(hit.material);
            let dir_len = ray.dir.length();
            // The length of the segment from the previous vertex, through any cut-outs.
            let segment = if TEXTURED { hit.t * dir_len + skipped } else { hit.t * dir_len };
            let wo = -ray.dir / dir_len;
            // Beer–Lambert over the segment just travelled inside a dielectric: the ray leaves
            // through this surface (this also covers a camera inside glass).
            // Only a material that encloses a medium has `sigma_a` (tested first: it is rarely there).
            if let Some(sigma_a) = m.sigma_a
                && hit.n.dot(wo) < 0.0
            {
                beta *= materials::beer_transmittance(&self.spectra.eval(sigma_a, lambda), segment);
            }
            if let Some(e) = m.emission
                && emits_towards(m.two_sided, hit.n, wo)
            {
                let weight = if specular_bounce {
                    1.0
                } else {
                    let light_pdf = self.scene.emitters.pdf_li_hit(hit.primitive, hit.n, wo, segment);
                    power_heuristic(prev_pdf, light_pdf)
                };
                radiance += beta * self.surface_emission(e, textures, uv, lambda) * weight;
            }
            if depth >= self.max_depth || beta.is_black() {
                break;
            }
            if TEXTURED {
                skipped = 0.0;
            }
            let (mut bsdf, frame) = self.scattering::<ROUGH>(
                &hit,
                m,
                HitSurface { textures, colors, uv },
                wo,
                lambda,
                sensor,
                lane,
                sampler,
                &mut last_surface,
            );
            // A fluorescent surface's lobe is reweighted in place (moving the BSDF cost every hit 0.2 % more
            // instructions on the Cornell box).
            if let Some(f) = m.fluorescence
                && let Bsdf::Lambertian { r } = &mut bsdf
            {
                let (u_choice, u_lambda) = (sampler.uniform_aside(), sampler.uniform_aside());
                let shifted;
                (*r, shifted) = self.fluorescence.scatter(f, *r, lambda, &mut film_lambda, u_choice, u_lambda);
                if shifted {
                    (last_surface, last_light, *lane) = (LastSpectrum(None), LastSpectrum(None), Some(0));
                }
            }
            // Each sampling step its own block of dimensions (`Sampler`): whether the light was
            // sampled does not shift the BSDF's numbers.
            if !bsdf.is_specular() && !self.scene.emitters.is_empty() {
                sampler.start_block(2 * depth + 1);
                radiance += beta * self.sample_light(&hit, &frame, wo, &bsdf, lambda, &mut last_light, sampler, count);
            }
            sampler.start_block(2 * depth + 2);
            let Some(s) = bsdf.sample_f(&frame, wo, sampler.uniform(), sampler.uniform2()) else { break };
            beta *= s.weight;
            eta_scale *= s.eta_scale;
            specular_bounce = s.flags.is_specular();
            prev_pdf = s.pdf;
            prev_ns = frame.facing(wo).1;
            ray = spawn_ray(&hit, s.wi);
            depth += 1;
            // Russian roulette on the throughput with refraction's radiance scaling undone
            // (pbrt-v4: rrBeta = beta · etaScale, q = max(0, 1 − max(rrBeta))).
            if depth >= self.rr_depth {
                let rr = (beta * eta_scale).max_component();
                if rr < 1.0 {
                    let q = (1.0 - rr).max(0.0);
                    if sampler.uniform() < q {
                        break;
                    }
                    beta = beta / (1.0 - q);
                }
            }
        }
        if let Some(film) = film_lambda {
            *lambda = film;
        }
        (radiance, first)
    }

    /// Whether a ray goes on through the surface it hit as if it were not there: a cut-out (MASK) where alpha
    /// is below the cutoff, a blended surface (BLEND) with probability 1 − alpha. Shared by the path tracer's
    /// and the bidirectional walks; draws a number only where coverage is strictly between 0 and 1.
    #[inline(always)]
    pub(super) fn cut_away(
        textures: Option<&MaterialTextures>,
        colors: Option<VertexColorHit<'_>>,
        uv: Uv,
        sampler: &mut Sampler,
    ) -> bool {
        let Some(t) = textures.filter(|t| t.has_alpha()) else { return false };
        let coverage = t.coverage(uv, colors.map_or(1.0, |c| c.alpha()));
        coverage <= 0.0 || (coverage < 1.0 && sampler.uniform_aside() >= coverage)
    }

    /// The BSDF at `hit` (material `m`, seen from `wo`) and its shading frame: the material's model with its
    /// textures and vertex colours applied, a clear coat or sheen picked with its share of the light, the
    /// path split by wavelength at a dispersive interface ([`PathTracer::eta`]). `last` memoises the surface
    /// spectrum ([`Spectra::eval_memo`]). The path tracer's loop and the bidirectional walks build every
    /// vertex's BSDF here.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn scattering<const ROUGH: bool>(
        &self,
        hit: &Hit,
        m: &PathMaterial,
        surface: HitSurface<'_>,
        wo: Vec3,
        lambda: &mut SampledWavelengths<N>,
        sensor: &Sensor<N>,
        lane: &mut Option<usize>,
        sampler: &mut Sampler,
        last: &mut LastSpectrum<N>,
    ) -> (Bsdf<N>, Frame) {
        let HitSurface { textures, colors, uv } = surface;
        // A texture's base colour replaces the material's (it already includes the factor).
        let base = |id: SpecId, lambda: &SampledWavelengths<N>, last: &mut LastSpectrum<N>| match textures
            .and_then(|t| t.base_color.as_ref())
        {
            Some(t) => t.eval(uv, lambda, self.rgb_lanes).0,
            None => self.spectra.eval_memo(id, lambda, last),
        };
        // Where vertex colours apply, `vertex_colored_base` gives the base colour instead; chosen at
        // its uses below rather than inside `base`, which would then capture `colors` (callgrind,
        // Cornell box, path, 4 spp at 128²: +0.069 % instructions folded into `base`, +0.029 % so).
        // A clear coat is picked with its share of the light seen from `wo`, the material otherwise. The
        // coat has its own normal: its normal map's, else the interpolated one (not the base's map).
        let tangent = HitTangent::new(&self.scene.geometry, hit);
        let coated = if ROUGH {
            m.coat
                .map(|c| match textures {
                    Some(t) => {
                        let ns = if t.has_coat_normal_map() {
                            t.coat_normal(uv, hit.ns, tangent.get(), hit.n)
                        } else {
                            hit.ns
                        };
                        (t.coat(uv, c), ns)
                    }
                    None => (c, hit.ns),
                })
                .filter(|(c, ns)| sampler.uniform_aside() < c.probability(wo.dot(*ns)))
        } else {
            None
        };
        let ns = match (coated, textures.filter(|t| t.has_base_normal_map())) {
            (Some((_, ns)), _) => ns,
            (None, Some(t)) => t.shading_normal(uv, hit.ns, &tangent, hit.n),
            (None, None) => hit.ns,
        };
        let frame = Frame { n: hit.n, ns };
        // The textures with this hit's uvs, for anisotropy's direction.
        let at_uv = textures.map(|t| (t, uv));
        // `KHR_materials_sheen`, beneath the coat: in place of the material with its share of the light.
        let sheen = match m.sheen {
            Some(s) if ROUGH && coated.is_none() => {
                self.pick_sheen(s, textures, uv, frame.facing(wo).1.dot(wo), lambda, sampler)
            }
            _ => None,
        };
        // `KHR_materials_specular` at the hit: its strength and F0 per texel where textured.
        let hit_specular = |s: Option<SpecularLayer>| {
            s.map(|s| {
                let weight = textures.map_or(s.weight, |t| t.specular_weight(uv, s.weight));
                let (f0, f0_max) = textures
                    .and_then(|t| t.specular_f0(uv, lambda, self.rgb_lanes, s.f0_scale))
                    .unwrap_or_else(|| (self.spectra.eval(s.f0, lambda), s.f0_max));
                HitSpecular { weight, f0, f0_max }
            })
        };
        let bsdf = match m.scattering {
            _ if let Some((c, _)) = coated => {
                let coat = GltfMetalRoughBxdf::clearcoat(c.roughness);
                Bsdf::GltfMetalRough(if m.multiple_scattering { coat.compensated() } else { coat })
            }
            _ if let Some(s) = sheen => Bsdf::Sheen(s),
            PathScattering::Diffuse { r } => Bsdf::Lambertian {
                r: match colors {
                    Some(c) => self.vertex_colored_base(&c, textures, uv, r, lambda, last),
                    None => base(r, lambda, last),
                },
            },
            PathScattering::Mirror { r } => Bsdf::Mirror { r: self.spectra.eval_memo(r, lambda, last) },
            PathScattering::Dielectric { tint } => {
                let eta = Self::eta(&m.ior, lambda, sensor, lane, sampler);
                Bsdf::Dielectric { eta, tint: self.spectra.eval_memo(tint, lambda, last) }
            }
            // Never reached when !ROUGH (`rough` is false only if no material has these).
            _ if !ROUGH => Bsdf::Lambertian { r: SampledSpectrum([0.0; N]) },
            PathScattering::RoughDielectric { tint, alpha, compensate } => {
                let eta = Self::eta(&m.ior, lambda, sensor, lane, sampler);
                let tint = self.spectra.eval_memo(tint, lambda, last);
                match m.anisotropy {
                    None => Bsdf::RoughDielectric(RoughDielectricBxdf::new(
                        TrowbridgeReitz::isotropic(alpha),
                        eta,
                        tint,
                        compensate,
                    )),
                    Some(a) => self.anisotropic_glass(a, at_uv, &tangent, ns, alpha, eta, tint, compensate),
                }
            }
            PathScattering::ThinDielectric { tint, eta } => {
                Bsdf::ThinDielectric(ThinDielectricBxdf::new(eta, self.spectra.eval_memo(tint, lambda, last)))
            }
            PathScattering::Conductor { metal, index, r, alpha, compensate } => {
                // An MTL `map_Ns` varies the roughness per texel (α = roughness²).
                let alpha = textures.and_then(|t| t.roughness_map(uv)).map_or(alpha, |r| r * r);
                let distrib = TrowbridgeReitz::isotropic(alpha);
                // RGB lanes are not wavelengths: there the metal is its reflectance colour.
                let spectral = !matches!(sensor, Sensor::Fixed(lanes) if lanes.rgb);
                Bsdf::Conductor(match (metal, index) {
                    (Some(metal), _) if spectral => ConductorBxdf::metal(metal, lambda, distrib, compensate),
                    (_, Some((eta, k))) if spectral => ConductorBxdf::new(
                        distrib,
                        self.spectra.eval(eta, lambda),
                        self.spectra.eval(k, lambda),
                        compensate,
                    ),
                    _ => ConductorBxdf::from_reflectance(self.spectra.eval_memo(r, lambda, last), distrib, compensate),
                })
            }
            PathScattering::Plastic { base: id, alpha, eta, nonlinear, table } => Bsdf::Plastic(PlasticBxdf::new(
                base(id, lambda, last),
                TrowbridgeReitz::isotropic(alpha),
                eta,
                nonlinear,
                table,
            )),
            PathScattering::GltfMetalRough { base: id, metallic, roughness, ior, specular } => {
                let (metallic, roughness) =
                    textures.map_or((metallic, roughness), |t| t.metallic_roughness(uv, metallic, roughness));
                let base = match colors {
                    Some(c) => self.vertex_colored_base(&c, textures, uv, id, lambda, last),
                    None => base(id, lambda, last),
                };
                let specular = hit_specular(specular);
                let anisotropy = m.anisotropy.map(|a| self.anisotropy_at(a, at_uv, &tangent, ns));
                let g = self.metal_rough(base, metallic, roughness, ior, specular, anisotropy);
                Bsdf::GltfMetalRough(g.energy(m.multiple_scattering))
            }
            PathScattering::GltfTransmission { base: id, metallic, roughness, ior, transmission, thin, specular } => {
                let (metallic, roughness) =
                    textures.map_or((metallic, roughness), |t| t.metallic_roughness(uv, metallic, roughness));
                let transmission = textures.map_or(transmission, |t| t.transmission(uv, transmission));
                let glass = (1.0 - metallic) * transmission;
                let colour = match colors {
                    Some(c) => self.vertex_colored_base(&c, textures, uv, id, lambda, last),
                    None => base(id, lambda, last),
                };
                if sampler.uniform_aside() < glass {
                    if thin {
                        Bsdf::ThinDielectric(ThinDielectricBxdf::new(ior, colour))
                    } else {
                        let eta = Self::eta(&m.ior, lambda, sensor, lane, sampler);
                        let alpha = roughness * roughness;
                        match m.anisotropy {
                            Some(a) => self.anisotropic_glass(a, at_uv, &tangent, ns, alpha, eta, colour, true),
                            None if roughness > 0.0 => Bsdf::RoughDielectric(RoughDielectricBxdf::new(
                                TrowbridgeReitz::isotropic(alpha),
                                eta,
                                colour,
                                true,
                            )),
                            None => Bsdf::Dielectric { eta, tint: colour },
                        }
                    }
                } else {
                    // What is not glass: metallic / (1 − glass) of it is metal (glass < 1 here).
                    let metal = if glass < 1.0 { metallic / (1.0 - glass) } else { 1.0 };
                    let specular = hit_specular(specular);
                    let anisotropy = m.anisotropy.map(|a| self.anisotropy_at(a, at_uv, &tangent, ns));
                    let metal = metal.min(1.0);
                    let g = self.metal_rough(colour, metal, roughness, ior, specular, anisotropy);
                    Bsdf::GltfMetalRough(g.energy(m.multiple_scattering))
                }
            }
        };
        (bsdf, frame)
    }

    /// The radiance that light `light`'s emissive texture sends from the sampled point `target`; `None` if
    /// the light has no emissive texture. Out of line, so that [`PathTracer::sample_light`] stays as small
    /// as it was for every other light (measured: inlined, it cost the untextured Cornell box 3 % more
    /// instructions, `Bsdf::f_cos` and `pdf` then left out of line).
    #[cold]
    #[inline(never)]
    pub(super) fn textured_light_radiance(
        &self,
        light: usize,
        target: Option<Vec3>,
        lambda: &SampledWavelengths<N>,
    ) -> Option<SampledSpectrum<N>> {
        let textured = self.textured_lights.get(light)?.as_ref()?;
        let t = self.textures(Some(textured.material))?;
        Some(self.textured_emission(t, Uv::same(textured.uv_at(target?)), lambda))
    }

    /// The radiance of an emissive texture at `uv`. Out of line: only its emitters need it.
    #[inline(never)]
    fn textured_emission(&self, t: &MaterialTextures, uv: Uv, lambda: &SampledWavelengths<N>) -> SampledSpectrum<N> {
        let illuminant = self.illuminant.map_or(SampledSpectrum([1.0; N]), |id| self.spectra.eval(id, lambda));
        t.emission(uv, lambda, &illuminant, self.rgb_lanes).unwrap_or(SampledSpectrum([0.0; N]))
    }

    /// The sheen lobe, with probability max₃(C) E(μ_o) (`mu_o` the cosine of the view direction to the
    /// shading normal), its colour C / P then; `None` (the material beneath) otherwise. Out of line: only
    /// sheen materials call it.
    #[inline(never)]
    fn pick_sheen(
        &self,
        s: PathSheen,
        textures: Option<&MaterialTextures>,
        uv: Uv,
        mu_o: f32,
        lambda: &SampledWavelengths<N>,
        sampler: &mut Sampler,
    ) -> Option<SheenBxdf<N>> {
        let roughness = textures.map_or(s.roughness, |t| t.sheen_roughness(uv, s.roughness));
        let (color, color_max) = match textures.and_then(|t| t.sheen_color(uv, lambda, self.rgb_lanes)) {
            Some(c) => c,
            None => (self.spectra.eval(s.color, lambda), s.color_max),
        };
        let p = (color_max * sheen_albedo(mu_o, roughness)).min(1.0);
        (p > 0.0 && sampler.uniform_aside() < p).then(|| SheenBxdf::new(color * (1.0 / p), roughness))
    }

    /// The glTF metallic–roughness BRDF of a hit, with `KHR_materials_specular` and `KHR_materials_anisotropy`
    /// (its strength and world direction, [`Self::anisotropy_at`]) where the material has them, before its
    /// diffuse coupling ([`GltfMetalRoughBxdf::conserving`] or [`GltfMetalRoughBxdf::compensated`]).
    fn metal_rough(
        &self,
        base: SampledSpectrum<N>,
        metallic: f32,
        roughness: f32,
        ior: f32,
        specular: Option<HitSpecular<N>>,
        anisotropy: Option<(f32, Vec3)>,
    ) -> GltfMetalRoughBxdf<N> {
        let g = GltfMetalRoughBxdf::new(base, metallic, roughness, ior);
        let g = match specular {
            None => g,
            Some(s) => g.with_specular(s.weight, s.f0, s.f0_max),
        };
        match anisotropy {
            None => g,
            Some((strength, direction)) => g.with_anisotropy(strength, direction),
        }
    }

    /// A rough dielectric of roughness α stretched by `KHR_materials_anisotropy` along its direction at the
    /// hit ([`Self::anisotropy_at`]). Out of line: only anisotropic glass calls it.
    #[allow(clippy::too_many_arguments)]
    #[inline(never)]
    fn anisotropic_glass(
        &self,
        a: Anisotropy,
        textures: Option<(&MaterialTextures, Uv)>,
        tangent: &HitTangent,
        ns: Vec3,
        alpha: f32,
        eta: f32,
        tint: SampledSpectrum<N>,
        compensate: bool,
    ) -> Bsdf<N> {
        let (strength, direction) = self.anisotropy_at(a, textures, tangent, ns);
        let distrib = TrowbridgeReitz::stretched(alpha, strength);
        // (A distribution the stretch leaves smooth samples as the smooth interface: `Bsdf::sample_f`.)
        Bsdf::RoughDielectric(RoughDielectricBxdf::new(distrib, eta, tint, compensate).along(direction))
    }

    /// `KHR_materials_anisotropy` at a hit: the strength (× the texture's B) and the direction in world
    /// space, the tangent frame's (the file's `TANGENT`, else MikkTSpace's or ∂p/∂u; about the shading normal
    /// `ns`) rotated by `anisotropyRotation`, or the texture's direction rotated so. Without a tangent frame
    /// (no TANGENT and no UVs: assembly warns) an arbitrary one about `ns`. Out of line:
    /// only anisotropic materials call it.
    #[inline(never)]
    fn anisotropy_at(
        &self,
        a: Anisotropy,
        textures: Option<(&MaterialTextures, Uv)>,
        tangent: &HitTangent,
        ns: Vec3,
    ) -> (f32, Vec3) {
        let (direction, scale) = textures.and_then(|(t, uv)| t.anisotropy(uv)).unwrap_or((Vec2::X, 1.0));
        let (sin, cos) = a.rotation.sin_cos();
        let d = Vec2::new(cos * direction.x - sin * direction.y, sin * direction.x + cos * direction.y);
        let (t, b) = tangent.get().and_then(|t| tangent_frame(t, ns)).unwrap_or_else(|| materials::sampling::basis(ns));
        (a.strength * scale, t * d.x + b * d.y)
    }

    /// Next-event estimation: one light chosen by power, one point or direction on it, a
    /// shadow ray, MIS-weighted against BSDF sampling for lights that BSDF sampling can hit.
    #[allow(clippy::too_many_arguments)]
    fn sample_light(
        &self,
        hit: &Hit,
        frame: &Frame,
        wo: Vec3,
        bsdf: &Bsdf<N>,
        lambda: &SampledWavelengths<N>,
        last_light: &mut LastSpectrum<N>,
        sampler: &mut Sampler,
        count: &mut RayCount,
    ) -> SampledSpectrum<N> {
        let black = SampledSpectrum([0.0; N]);
        let u = sampler.uniform();
        let u2 = sampler.uniform2();
        let (ng, ns) = frame.facing(wo);
        let ctx = LightSampleContext { p: hit.p, ns };
        let Some((light, ls)) = self.scene.emitters.sample_li(&ctx, u, u2) else { return black };
        let f = bsdf.f_cos(frame, wo, ls.wi);
        if f.is_black() {
            return black;
        }
        let geometry = &self.scene.geometry;
        // Light the shading normal sees below the flat triangle (the shadow terminator's wedge,
        // see `Bsdf::f`) arrives only along the lifted shadow ray; without one (no vertex normals:
        // a normal map, a placed instance) it is hidden, as the facet hides it.
        let lifted = if ls.wi.dot(ng) <= 0.0 && ls.wi.dot(ns) > 0.0 {
            match geometry.terminator_shadow_ray(hit, ng, ls.target, ls.wi) {
                Some(lifted) => Some(lifted),
                None => return black,
            }
        } else {
            None
        };
        count.shadow_ray();
        let visible = if self.scene.alpha_cutouts {
            self.visibility(hit, lifted.as_ref(), ls.target, ls.wi, count)
        } else {
            let occluded = match &lifted {
                Some(lifted) => geometry.shadow_occluded(lifted),
                None => {
                    let (shadow, t_max) = spawn_shadow_ray(hit, ls.target, ls.wi);
                    geometry.occluded(&shadow, t_max)
                }
            };
            if occluded { 0.0 } else { 1.0 }
        };
        if visible == 0.0 {
            return black;
        }
        let le = self.sampled_radiance(light, &ls, lambda, last_light);
        if ls.delta {
            f * le * (visible * ls.scale / ls.pdf)
        } else {
            let weight = power_heuristic(ls.pdf, bsdf.pdf(frame, wo, ls.wi));
            f * le * (visible * weight / ls.pdf)
        }
    }
}

impl<const N: usize> PathTracer<'_, N> {
    /// The light that light sample `ls` of light `light` brings (next-event estimation, here and in bdpt):
    /// the environment's along `ls.wi` (with its map), an emissive texture's at the sampled point, else the
    /// light's spectrum (through `last`, the previous light this path evaluated).
    #[inline(always)]
    pub(super) fn sampled_radiance(
        &self,
        light: usize,
        ls: &LiSample,
        lambda: &SampledWavelengths<N>,
        last: &mut LastSpectrum<N>,
    ) -> SampledSpectrum<N> {
        if self.scene.emitters.is_environment(light) {
            self.environment_radiance(ls.wi, lambda)
        } else if !self.textured_lights.is_empty()
            && let Some(le) = self.textured_light_radiance(light, ls.target, lambda)
        {
            le
        } else {
            self.spectra.eval_memo(self.light_spectra[light], lambda, last)
        }
    }
}

/// [`PathTracer::textured_lights`] of `scene`.
fn textured_lights(scene: &RenderScene) -> Vec<Option<TexturedLight>> {
    let geometry = &scene.geometry;
    let mut lights = vec![None; scene.emitters.iter().count()];
    for (primitive, light) in scene.emitters.area_lights() {
        let Some(material) = scene.primitive_material(primitive) else { continue };
        let textured = scene.textures.get(material as usize).and_then(Option::as_ref);
        if !textured.is_some_and(MaterialTextures::has_emissive_texture) {
            continue;
        }
        let Primitive::Triangle { mesh, triangle } = geometry.primitive(primitive) else { continue };
        let mesh = &geometry.meshes()[mesh as usize];
        let uv =
            triangle_uvs(mesh, triangle as usize, textured.is_some_and(MaterialTextures::emissive_reads_second_uvs));
        let p = mesh.indices()[triangle as usize].map(|i| mesh.positions()[i as usize]);
        lights[light] = Some(TexturedLight { material, p, uv });
    }
    lights
}

impl<const N: usize> Kernel<N> for PathTracer<'_, N> {
    const RANDOM: bool = true;

    #[inline]
    fn li(
        &self,
        ray: &Ray,
        lambda: &mut SampledWavelengths<N>,
        sensor: &Sensor<N>,
        sampler: &mut Sampler,
        count: &mut RayCount,
        _splats: &mut Vec<Splat<N>>,
    ) -> Radiance<N> {
        let r = self.trace_path(ray, PathStart::CAMERA, lambda, sensor, sampler, count);
        debug_assert!(r.l.is_finite(), "non-finite radiance {:?}", r.l);
        r
    }
}

impl<const N: usize> PathTracer<'_, N> {
    /// [`PathTracer::trace`] instantiated for this scene: the rough and layered models only where a material
    /// needs them, texture code only where a material has textures (camera rays and sensors alike).
    #[inline]
    fn trace_path(
        &self,
        ray: &Ray,
        start: PathStart,
        lambda: &mut SampledWavelengths<N>,
        sensor: &Sensor<N>,
        sampler: &mut Sampler,
        count: &mut RayCount,
    ) -> Radiance<N> {
        let mut lane = None;
        let textured = !self.scene.textures.is_empty();
        let (l, first) = match (self.rough, textured) {
            (true, true) => self.trace::<true, true>(ray, start, lambda, sensor, &mut lane, sampler, count),
            (true, false) => self.trace::<true, false>(ray, start, lambda, sensor, &mut lane, sampler, count),
            (false, true) => self.trace::<false, true>(ray, start, lambda, sensor, &mut lane, sampler, count),
            (false, false) => self.trace::<false, false>(ray, start, lambda, sensor, &mut lane, sampler, count),
        };
        Radiance { l, first, lane }
    }
}

/// What a hit's textures say about its surface: the material's textures, the mesh's vertex colour there,
/// and the hit's uvs (all absent or plain in untextured scenes).
#[derive(Clone, Copy)]
pub(super) struct HitSurface<'t> {
    pub(super) textures: Option<&'t MaterialTextures>,
    pub(super) colors: Option<VertexColorHit<'t>>,
    pub(super) uv: Uv,
}

/// Where a path starts, for MIS at the first emitter it meets: a camera ray (as a specular bounce: emitters
/// seen directly count fully), or a direction sampled with density `pdf` about the normal `ns` of a point
/// whose light was also sampled (an illuminance sensor).
#[derive(Debug, Clone, Copy)]
struct PathStart {
    specular: bool,
    pdf: f32,
    ns: Vec3,
}

impl PathStart {
    const CAMERA: Self = Self { specular: true, pdf: 0.0, ns: Vec3::Z };
}

/// A hit record for a point `p` that lies on no primitive (an illuminance sensor, a point sampled on an area
/// light) with normal `n`, so that rays leave it as from a surface: lifted along `n` by a relative 2⁻¹⁶ of its
/// largest coordinate. The same lift along every axis (the offset takes the part along `n`): a point on a
/// floor at z = 0 is lifted by its x and y too, so a surface whose vertices carry rounding (a transform, a
/// unit scale) still lies below it.
pub(super) fn lifted_point(p: Vec3, n: Vec3) -> Hit {
    Hit {
        t: 0.0,
        p,
        p_error: Vec3::splat((p.abs().max_element() + 1e-3) * (1.0 / 65536.0)),
        n,
        ns: n,
        uv: Vec2::ZERO,
        primitive: u32::MAX,
        placement: u32::MAX,
        object_primitive: u32::MAX,
        material: None,
    }
}

/// What one sample of an illuminance sensor measured: the light sampled directly, at every wavelength of the
/// sample, and π × the radiance along a cosine-sampled direction, which a dispersive path may have narrowed to
/// `lane` and whose `lambda` it may have changed.
pub(crate) struct IrradianceSample<const N: usize> {
    pub(crate) direct: SampledSpectrum<N>,
    pub(crate) lambda_direct: SampledWavelengths<N>,
    pub(crate) indirect: Radiance<N>,
    pub(crate) lambda_indirect: SampledWavelengths<N>,
}

impl<const N: usize> PathTracer<'_, N> {
    /// One sample of the irradiance E = ∫ L cos θ dω over the hemisphere of the unit normal `n` at `p`, by
    /// the path tracer's own estimator at a white Lambertian point (E = π L_o of a surface of albedo 1): next
    /// event estimation and a cosine-sampled path, weighted by MIS, with Russian roulette ending paths. The
    /// point may lie on a surface: its rays leave from `p` lifted along `n` by a relative 2⁻¹⁶ of its
    /// coordinates, so the surface it lies on neither shadows it nor is seen by it.
    pub(crate) fn irradiance(
        &self,
        p: Vec3,
        n: Vec3,
        lambda: SampledWavelengths<N>,
        sensor: &Sensor<N>,
        sampler: &mut Sampler,
        count: &mut RayCount,
    ) -> IrradianceSample<N> {
        let hit = lifted_point(p, n);
        let frame = Frame { n, ns: n };
        let white = Bsdf::Lambertian { r: SampledSpectrum([1.0; N]) };
        let pi = std::f32::consts::PI;
        let mut direct = SampledSpectrum([0.0; N]);
        if !self.scene.emitters.is_empty() {
            sampler.start_block(1);
            let mut last_light = LastSpectrum(None);
            direct = self.sample_light(&hit, &frame, n, &white, &lambda, &mut last_light, sampler, count) * pi;
        }
        sampler.start_block(2);
        let mut lambda_indirect = lambda;
        let mut indirect = Radiance { l: SampledSpectrum([0.0; N]), first: ObjectId::Background, lane: None };
        if let Some(s) = white.sample_f(&frame, n, sampler.uniform(), sampler.uniform2()) {
            let ray = spawn_ray(&hit, s.wi);
            let start = PathStart { specular: false, pdf: s.pdf, ns: n };
            let r = self.trace_path(&ray, start, &mut lambda_indirect, sensor, sampler, count);
            // The sample's weight f cos / pdf is 1 for a white Lambertian: E = π L.
            indirect = Radiance { l: r.l * (pi * s.weight.0[0]), ..r };
        }
        IrradianceSample { direct, lambda_direct: lambda, indirect, lambda_indirect }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The uv at a light sample: the barycentric blend on a proper triangle, and a finite uv (no panic) on
    /// slivers whose Gram determinant cancels or underflows to 0.
    #[test]
    fn textured_light_uv_is_the_barycentric_blend_and_finite_on_slivers() {
        let uv = [Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0)];
        let light = TexturedLight { material: 0, p: [Vec3::ZERO, Vec3::X, Vec3::Y], uv };
        let got = light.uv_at(Vec3::new(0.25, 0.5, 0.0));
        assert!((got - Vec2::new(0.25, 0.5)).length() < 1e-6, "{got}");
        // Rounding off the triangle is clamped back onto it.
        let got = light.uv_at(Vec3::new(1.5, -0.1, 0.0));
        assert!(got.x <= 1.0 && got.y >= 0.0 && got.x + got.y <= 1.0 + 1e-6, "{got}");
        for p in [
            [Vec3::ZERO, Vec3::X * 1e-12, Vec3::Y * 1e-12],
            [Vec3::ZERO, Vec3::X, Vec3::new(2.0, 1e-7, 0.0)],
            [Vec3::ZERO, Vec3::X, Vec3::X * 2.0],
        ] {
            let got = TexturedLight { material: 0, p, uv }.uv_at(Vec3::ZERO);
            assert!(got.is_finite(), "{p:?}: {got}");
        }
    }
}
