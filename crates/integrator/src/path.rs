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
use geometry::{Hit, Ray, spawn_ray, spawn_ray_to};
use glam::Vec3;
use materials::bsdf::{Bsdf, Frame};
use materials::{Ior, LAMBDA_D, Scattering};

use crate::assembly::RenderScene;
use crate::film::{ObjectId, Sensor, WavelengthTable};
use crate::lights::{Emission, LightSampleContext};
use crate::render::{Kernel, PathOptions, Radiance, RayCount, WavelengthPdf};
use crate::sampling::{Rng, power_heuristic};
use crate::spectral::{Lanes, SpectrumKind};

/// Bounces when neither the options nor the scene's `max_depth` setting say: deep enough
/// that Russian roulette, not the limit, ends almost every path.
const DEFAULT_MAX_DEPTH: u32 = 64;

/// Russian roulette starts after this many bounces, so short paths (direct and first indirect
/// light) are never cut (pbrt-v4 starts at depth 1; a few more keep low-order noise down).
const RR_START_DEPTH: u32 = 3;

/// Index into the render's spectrum table.
type SpecId = u32;

/// Every spectrum of the scene, either projected on fixed lanes or kept dense for hero sampling.
enum Spectra<const N: usize> {
    Fixed(Vec<SampledSpectrum<N>>),
    Dense(Vec<DenselySampledSpectrum>),
}

impl<const N: usize> Spectra<N> {
    #[inline]
    fn eval(&self, id: SpecId, lambda: &SampledWavelengths<N>) -> SampledSpectrum<N> {
        match self {
            Self::Fixed(v) => v[id as usize],
            Self::Dense(v) => v[id as usize].sample(lambda),
        }
    }
}

/// What a spectrum means, for the RGB projection.
#[derive(Clone, Copy, PartialEq)]
enum Kind {
    Reflectance,
    Emission,
    /// An absorption coefficient: in RGB it goes through the colour of e^{−σ_a} (one unit).
    SigmaA,
}

#[derive(Debug, Clone)]
struct PathMaterial {
    scattering: Scattering,
    /// k_d F_d (Lambertian) or k_s F_s (mirror), clamped to 1.
    reflectance: SpecId,
    /// k_t T_s, the transmission filter of a dielectric, clamped to 1.
    tint: SpecId,
    sigma_a: Option<SpecId>,
    emission: Option<SpecId>,
    ior: Ior,
}

/// Everything a path-traced render needs, precomputed.
pub(crate) struct PathTracer<'a, const N: usize> {
    scene: &'a RenderScene,
    spectra: Spectra<N>,
    materials: Vec<PathMaterial>,
    default_material: PathMaterial,
    /// The emission of each light of `scene.emitters`, in its order.
    light_spectra: Vec<SpecId>,
    /// The spectra the environment sums.
    environment_spectra: Vec<SpecId>,
    max_depth: u32,
}

impl<'a, const N: usize> PathTracer<'a, N> {
    /// The tracer for `scene` and the film's sensor: `fixed` lanes (`rgb`, `bins:N`), or hero
    /// wavelengths (`None`) drawn from `options.wavelength_pdf`.
    pub(crate) fn new(scene: &'a RenderScene, fixed: Option<Lanes<N>>, options: &PathOptions) -> (Self, Sensor<N>) {
        let mut table: Vec<(DenselySampledSpectrum, Kind)> = Vec::new();
        let mut add = |s: DenselySampledSpectrum, kind: Kind| -> SpecId {
            table.push((s, kind));
            (table.len() - 1) as SpecId
        };
        let clamp01 = |s: &DenselySampledSpectrum, k: f32| s.map(|v| (v * f64::from(k)).clamp(0.0, 1.0));
        let mut path_material = |m: &materials::Material| -> PathMaterial {
            let scattering = m.scattering();
            let reflectance = match scattering {
                Scattering::Conductor => clamp01(&m.specular, m.ks),
                _ => clamp01(&m.diffuse, m.kd),
            };
            let tint = clamp01(&m.transmittance, m.kt);
            PathMaterial {
                scattering,
                reflectance: add(reflectance, Kind::Reflectance),
                tint: add(tint, Kind::Reflectance),
                sigma_a: m.absorption.as_ref().filter(|_| m.absorbs()).map(|a| add(a.sigma_a().clone(), Kind::SigmaA)),
                emission: m.emission.as_ref().filter(|_| m.emits()).map(|e| add(e.clone(), Kind::Emission)),
                ior: m.ior,
            }
        };
        let materials: Vec<PathMaterial> = scene.materials.iter().map(&mut path_material).collect();
        let default_material = path_material(&scene.default_material);

        // The spectrum of each light, in the table: a light's own, the background, or the
        // emitting material's.
        let mut emission = |e: Emission| match e {
            Emission::Light(i) => add(scene.lights[i].spectrum.clone(), Kind::Emission),
            Emission::Background => {
                add(scene.background.clone().expect("the environment sums a background"), Kind::Emission)
            }
            Emission::Material(m) => {
                materials.get(m as usize).and_then(|m| m.emission).expect("area lights emit by their material")
            }
        };
        let environment_spectra: Vec<SpecId> =
            scene.emitters.environment_spectra().iter().map(|&e| emission(e)).collect();
        let light_spectra: Vec<SpecId> = scene.emitters.iter().map(|(_, e)| emission(e)).collect();

        let (spectra, sensor) = match fixed {
            Some(lanes) => {
                let projected = table
                    .iter()
                    .map(|(s, kind)| match kind {
                        Kind::Reflectance => SampledSpectrum(lanes.project(s, SpectrumKind::Reflectance)),
                        Kind::Emission => SampledSpectrum(lanes.project(s, SpectrumKind::Emission)),
                        Kind::SigmaA => SampledSpectrum(lanes.project_sigma_a(s)),
                    })
                    .collect();
                (Spectra::Fixed(projected), Sensor::Fixed(lanes))
            }
            None => {
                let sensor = match options.wavelength_pdf {
                    WavelengthPdf::Visible => Sensor::Visible,
                    WavelengthPdf::Illuminant => {
                        let emitters: Vec<&DenselySampledSpectrum> = light_spectra
                            .iter()
                            .chain(environment_spectra.iter().skip(1))
                            .map(|&id| &table[id as usize].0)
                            .collect();
                        Sensor::Tabulated(WavelengthTable::illuminant(&emitters))
                    }
                };
                (Spectra::Dense(table.into_iter().map(|(s, _)| s).collect()), sensor)
            }
        };
        let max_depth = options
            .max_depth
            .unwrap_or_else(|| scene.setting_f64("max_depth").map_or(DEFAULT_MAX_DEPTH, |d| d.max(0.0) as u32));
        let tracer =
            Self { scene, spectra, materials, default_material, light_spectra, environment_spectra, max_depth };
        (tracer, sensor)
    }

    #[inline]
    fn material(&self, index: Option<u32>) -> &PathMaterial {
        index.and_then(|i| self.materials.get(i as usize)).unwrap_or(&self.default_material)
    }

    #[inline]
    fn environment_radiance(&self, lambda: &SampledWavelengths<N>) -> SampledSpectrum<N> {
        let mut l = SampledSpectrum([0.0; N]);
        for &id in &self.environment_spectra {
            l += self.spectra.eval(id, lambda);
        }
        l
    }

    /// Index of refraction for this path, splitting it by wavelength at the first dispersive
    /// surface: hero sampling keeps the hero wavelength (pbrt-v4 `TerminateSecondary`); fixed
    /// wavelength lanes keep one lane chosen uniformly; RGB lanes cannot split and use n_d.
    fn eta(
        ior: &Ior,
        lambda: &mut SampledWavelengths<N>,
        sensor: &Sensor<N>,
        lane: &mut Option<usize>,
        rng: &mut Rng,
    ) -> f32 {
        if !ior.is_dispersive() {
            return ior.eval(LAMBDA_D);
        }
        let j = match (sensor, *lane) {
            (_, Some(j)) => j,
            (Sensor::Fixed(lanes), None) if lanes.rgb => return ior.eval(LAMBDA_D),
            (Sensor::Fixed(lanes), None) => {
                let active = lanes.active();
                let j = ((rng.uniform() * active as f32) as usize).min(active - 1);
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

    /// Radiance along a camera ray (pbrt-v4 `PathIntegrator::Li`).
    fn trace(
        &self,
        camera_ray: &Ray,
        lambda: &mut SampledWavelengths<N>,
        sensor: &Sensor<N>,
        lane: &mut Option<usize>,
        rng: &mut Rng,
        count: &mut RayCount,
    ) -> (SampledSpectrum<N>, ObjectId) {
        let mut radiance = SampledSpectrum([0.0; N]);
        let mut beta = SampledSpectrum([1.0; N]);
        let mut eta_scale = 1.0f32;
        let mut ray = *camera_ray;
        let mut specular_bounce = true;
        // The previous vertex's BSDF density and facing shading normal, for MIS at emitters.
        let mut prev_pdf = 0.0f32;
        let mut prev_ns = Vec3::Z;
        let mut first = ObjectId::Background;
        let mut depth = 0u32;
        loop {
            count.rays += 1;
            let Some(hit) = self.scene.geometry.intersect(&ray, f32::INFINITY) else {
                let emitters = &self.scene.emitters;
                if emitters.has_environment() {
                    let le = self.environment_radiance(lambda);
                    let weight = if specular_bounce {
                        1.0
                    } else {
                        let ctx = LightSampleContext { p: ray.origin, ns: prev_ns };
                        power_heuristic(prev_pdf, emitters.pdf_li_escaped(&ctx, ray.dir.normalize()))
                    };
                    radiance += beta * le * weight;
                }
                break;
            };
            if depth == 0 {
                first = ObjectId::Material(hit.material);
            }
            let m = self.material(hit.material);
            let dir_len = ray.dir.length();
            let wo = -ray.dir / dir_len;
            // Beer–Lambert over the segment just travelled inside a dielectric: the ray leaves
            // through this surface (this also covers a camera inside glass).
            if m.scattering == Scattering::Dielectric
                && hit.n.dot(wo) < 0.0
                && let Some(sigma_a) = m.sigma_a
            {
                beta *= materials::beer_transmittance(&self.spectra.eval(sigma_a, lambda), hit.t * dir_len);
            }
            if let Some(e) = m.emission {
                let weight = if specular_bounce {
                    1.0
                } else {
                    let light_pdf = self.scene.emitters.pdf_li_hit(hit.primitive, hit.n, wo, hit.t * dir_len);
                    power_heuristic(prev_pdf, light_pdf)
                };
                radiance += beta * self.spectra.eval(e, lambda) * weight;
            }
            if depth >= self.max_depth || beta.is_black() {
                break;
            }
            let bsdf = match m.scattering {
                Scattering::Diffuse => Bsdf::Lambertian { r: self.spectra.eval(m.reflectance, lambda) },
                Scattering::Conductor => Bsdf::Mirror { r: self.spectra.eval(m.reflectance, lambda) },
                Scattering::Dielectric => {
                    let eta = Self::eta(&m.ior, lambda, sensor, lane, rng);
                    Bsdf::Dielectric { eta, tint: self.spectra.eval(m.tint, lambda) }
                }
            };
            let frame = Frame { n: hit.n, ns: hit.ns };
            if !bsdf.is_specular() && !self.scene.emitters.is_empty() {
                radiance += beta * self.sample_light(&hit, &frame, wo, &bsdf, lambda, rng, count);
            }
            let Some(s) = bsdf.sample_f(&frame, wo, rng.uniform(), rng.uniform2()) else { break };
            beta *= s.weight;
            eta_scale *= s.eta_scale;
            specular_bounce = s.flags.is_specular();
            prev_pdf = s.pdf;
            prev_ns = frame.facing(wo).1;
            ray = spawn_ray(&hit, s.wi);
            depth += 1;
            // Russian roulette on the throughput with refraction's radiance scaling undone
            // (pbrt-v4: rrBeta = beta · etaScale, q = max(0, 1 − max(rrBeta))).
            if depth >= RR_START_DEPTH {
                let rr = (beta * eta_scale).max_component();
                if rr < 1.0 {
                    let q = (1.0 - rr).max(0.0);
                    if rng.uniform() < q {
                        break;
                    }
                    beta = beta / (1.0 - q);
                }
            }
        }
        (radiance, first)
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
        rng: &mut Rng,
        count: &mut RayCount,
    ) -> SampledSpectrum<N> {
        let black = SampledSpectrum([0.0; N]);
        let u = rng.uniform();
        let u2 = rng.uniform2();
        let ctx = LightSampleContext { p: hit.p, ns: frame.facing(wo).1 };
        let Some((light, ls)) = self.scene.emitters.sample_li(&ctx, u, u2) else { return black };
        let f = bsdf.f_cos(frame, wo, ls.wi);
        if f.is_black() {
            return black;
        }
        count.rays += 1;
        let (shadow, t_max) = match ls.target {
            Some(q) => spawn_ray_to(hit, q),
            None => (spawn_ray(hit, ls.wi), f32::INFINITY),
        };
        if self.scene.geometry.occluded(&shadow, t_max) {
            return black;
        }
        let le = if self.scene.emitters.is_environment(light) {
            self.environment_radiance(lambda)
        } else {
            self.spectra.eval(self.light_spectra[light], lambda)
        };
        if ls.delta {
            f * le * (ls.scale / ls.pdf)
        } else {
            let weight = power_heuristic(ls.pdf, bsdf.pdf(frame, wo, ls.wi));
            f * le * (weight / ls.pdf)
        }
    }
}

impl<const N: usize> Kernel<N> for PathTracer<'_, N> {
    const RANDOM: bool = true;

    #[inline]
    fn li(
        &self,
        ray: &Ray,
        lambda: &mut SampledWavelengths<N>,
        sensor: &Sensor<N>,
        rng: &mut Rng,
        count: &mut RayCount,
    ) -> Radiance<N> {
        let mut lane = None;
        let (l, first) = self.trace(ray, lambda, sensor, &mut lane, rng, count);
        debug_assert!(l.is_finite(), "non-finite radiance {l:?}");
        Radiance { l, first, lane }
    }
}
