//! The paper's model ("whitted-hall"): backward Whitted ray tracing with Hall's spectral
//! shading (Lee, Lee, Lee & Ha 2004, eqs. 1–2 and 6–9). `docs/paper-model.md` goes through it
//! equation by equation: what the paper writes and what this code does.
//!
//! All spectral arithmetic is on lane arrays ([`SampledSpectrum<N>`]) precomputed per render,
//! so the inner loop does no table look-ups. The geometry of the ray tree is the same for every
//! wavelength (the paper's IOR does not vary with λ), so one tree carries all lanes.

use colorimetry::{SampledSpectrum, SampledWavelengths};
use geometry::{Hit, Ray, spawn_ray, spawn_shadow_ray};
use glam::{Vec2, Vec3};
use materials::{hall, scattering};

use crate::film::{ObjectId, Sensor};
use crate::integrators::kernel::{Kernel, Radiance, RayCount, Splat};
use crate::lights::{Emission, LightKind, LightSampleContext, emits_towards};
use crate::options::{Ambient, WhittedOptions};
use crate::sampling::Sampler;
use crate::scene::RenderScene;
use crate::spectral::{Lanes, SpectrumKind};

/// Most surfaces a shadow ray may cross before the light counts as blocked: enough for the
/// paper's five spheres seen through one another, bounded so a pathological mesh cannot stall.
const MAX_SHADOW_CROSSINGS: u32 = 32;

/// A material reduced to lane arrays for one render.
#[derive(Debug, Clone)]
struct LaneMaterial<const N: usize> {
    /// k_d F_d(λ).
    kd: SampledSpectrum<N>,
    /// k_s F_s(λ).
    ks: SampledSpectrum<N>,
    /// k_t T_s(λ).
    kt: SampledSpectrum<N>,
    /// k_d F_d(λ) I_a(λ): the ambient term of eq. 6, constant per material.
    ambient: SampledSpectrum<N>,
    /// σ_a(λ), only when absorption is on and the medium absorbs.
    sigma_a: Option<SampledSpectrum<N>>,
    emission: Option<SampledSpectrum<N>>,
    /// Whether the emission leaves both faces.
    two_sided: bool,
    shininess: f32,
    /// Index of refraction at n_d's wavelength (this model does not disperse).
    eta: f32,
    has_diffuse: bool,
    has_specular: bool,
    transmissive: bool,
    /// k_s and k_t weighted per hit by Fresnel's F and 1 − F ([`materials::Material::fresnel_weighted`]).
    fresnel: bool,
}

/// A point, spot or directional light with its emission on the lanes.
#[derive(Debug, Clone)]
struct LaneLight<const N: usize> {
    kind: LightKind,
    spectrum: SampledSpectrum<N>,
}

/// Everything one render of the paper's model needs, precomputed.
pub(crate) struct Whitted<'a, const N: usize> {
    scene: &'a RenderScene,
    materials: Vec<LaneMaterial<N>>,
    default_material: LaneMaterial<N>,
    lights: Vec<LaneLight<N>>,
    background: SampledSpectrum<N>,
    max_depth: u32,
    min_weight: f32,
    /// The lanes' wavelengths and whether they are RGB, for an environment map's texels.
    map_lambda: SampledWavelengths<N>,
    map_rgb: bool,
}

impl<'a, const N: usize> Whitted<'a, N> {
    pub(crate) fn new(scene: &'a RenderScene, sensor: &Sensor<N>, options: &WhittedOptions) -> Self {
        let Sensor::Fixed(lanes) = sensor else { unreachable!("the paper's model renders fixed lanes") };
        let project = |s: &colorimetry::DenselySampledSpectrum, kind| SampledSpectrum(lanes.project(s, kind));
        let refl = SpectrumKind::Reflectance;

        // S̄(λ), what the ambient terms are a fraction of: the light arriving at the middle of
        // the scene (point and spot lights with their fall-off there, directional lights as
        // they are; the environment is already seen through the background).
        // Emissive surfaces light the scene only through reflected rays in this model.
        let emission = |e: Emission| match e {
            Emission::Light(i) => project(&scene.lights[i].spectrum, SpectrumKind::Emission),
            Emission::Background => {
                scene.background.as_ref().map_or(SampledSpectrum([0.0; N]), |b| project(b, SpectrumKind::Emission))
            }
            Emission::Material(_) => unreachable!("only point, spot and directional lights are projected"),
        };
        let lights: Vec<LaneLight<N>> = scene
            .emitters
            .iter()
            .filter(|(kind, _)| kind.is_delta())
            .map(|(kind, e)| LaneLight { kind: kind.clone(), spectrum: emission(e) })
            .collect();
        let (lo, hi) = scene.geometry.bounds();
        let center = LightSampleContext { p: (lo + hi) * 0.5, ns: Vec3::Y };
        let mut light_sum = SampledSpectrum([0.0; N]);
        for l in &lights {
            if let Some(sample) = l.kind.sample_li(&center, Vec2::ZERO, 1.0) {
                light_sum += l.spectrum * sample.scale;
            }
        }
        let ambient = ambient_spectrum(scene, lanes, options.ambient, light_sum);

        let lane_material = |m: &materials::Material| {
            let kd = project(&m.diffuse, refl) * m.kd;
            let ks = project(&m.specular, refl) * m.ks;
            let kt =
                if m.is_transmissive() { project(&m.transmittance, refl) * m.kt } else { SampledSpectrum([0.0; N]) };
            let sigma_a = match (&m.absorption, options.absorption) {
                (Some(a), true) if m.absorbs() => {
                    Some(SampledSpectrum(lanes.project(a.sigma_a(), SpectrumKind::SigmaA)))
                }
                _ => None,
            };
            LaneMaterial {
                ambient: kd * ambient,
                kd,
                ks,
                kt,
                sigma_a,
                emission: m.emission.as_ref().map(|e| project(e, SpectrumKind::Emission)),
                two_sided: m.two_sided,
                shininess: m.shininess,
                eta: m.ior.eval(materials::LAMBDA_D),
                has_diffuse: kd.0.iter().any(|&v| v > 0.0),
                has_specular: ks.0.iter().any(|&v| v > 0.0),
                transmissive: kt.0.iter().any(|&v| v > 0.0),
                fresnel: m.fresnel_weighted,
            }
        };
        let materials = scene.materials.iter().map(lane_material).collect();
        let default_material = lane_material(&scene.default_material);
        // Escaping rays see the environment: environment lights and the background.
        let mut background = SampledSpectrum([0.0; N]);
        for &e in scene.emitters.le_escaped() {
            background += emission(e);
        }
        Self {
            scene,
            materials,
            default_material,
            lights,
            background,
            max_depth: options.max_depth.or(scene.settings.max_depth).unwrap_or(20),
            min_weight: options.min_weight,
            map_lambda: lanes.wavelengths,
            map_rgb: lanes.rgb,
        }
    }

    #[inline]
    fn material(&self, index: Option<u32>) -> &LaneMaterial<N> {
        index.and_then(|i| self.materials.get(i as usize)).unwrap_or(&self.default_material)
    }

    /// Eqs. 1–2: the ray tree. `weight` is the largest lane of the product of coefficients
    /// along the path so far (Hall & Greenberg's adaptive depth control prunes branches whose
    /// contribution cannot exceed `min_weight`). `inside` is the medium the ray travels in.
    fn trace(
        &self,
        ray: &Ray,
        depth: u32,
        weight: f32,
        inside: Option<&LaneMaterial<N>>,
        count: &mut RayCount,
    ) -> SampledSpectrum<N> {
        self.trace_with_id(ray, depth, weight, inside, count).0
    }

    fn trace_with_id(
        &self,
        ray: &Ray,
        depth: u32,
        weight: f32,
        inside: Option<&LaneMaterial<N>>,
        count: &mut RayCount,
    ) -> (SampledSpectrum<N>, ObjectId) {
        count.rays += 1;
        let Some(hit) = self.scene.geometry.intersect(ray, f32::INFINITY) else {
            // An environment map is seen by escaping rays (camera, mirror and refracted rays), as the
            // uniform environment is; in the paper's model it lights nothing else.
            let mut background = self.background;
            if let Some(map) = self.scene.emitters.environment_map() {
                background += map.eval(ray.dir.normalize(), &self.map_lambda, self.map_rgb);
            }
            return (background, ObjectId::Background);
        };
        let id = ObjectId::Material(hit.material);
        // The medium this segment crossed: the object whose surface it leaves through (this
        // also covers a camera that starts inside glass), else the one it was sent into.
        let leaving = hit.n.dot(ray.dir) > 0.0;
        let medium = if leaving { Some(self.material(hit.material)).filter(|m| m.transmissive) } else { inside };
        let color = self.shade(&hit, ray, depth, weight, inside, count);
        // Eq. 8 (Bouguer–Beer): T = t_λ^b = exp(−σ_a b), b = distance travelled inside.
        let color = match medium.and_then(|m| m.sigma_a.as_ref()) {
            Some(sigma_a) => color * materials::beer_transmittance(sigma_a, hit.t * ray.dir.length()),
            None => color,
        };
        (color, id)
    }

    fn shade(
        &self,
        hit: &Hit,
        ray: &Ray,
        depth: u32,
        weight: f32,
        inside: Option<&LaneMaterial<N>>,
        count: &mut RayCount,
    ) -> SampledSpectrum<N> {
        let m = self.material(hit.material);
        let wo = -ray.dir.normalize();
        // The paper flips the normal when the ray leaves a transparent object: both normals
        // are made to face the viewer.
        let entering = hit.n.dot(wo) > 0.0;
        let ng = if entering { hit.n } else { -hit.n };
        let mut ns = if entering { hit.ns } else { -hit.ns };
        if ns.dot(wo) <= 0.0 {
            // Interpolated normals can face away at silhouettes; fall back to the true normal.
            ns = ng;
        }

        let mut color = m.ambient;
        if let Some(e) = &m.emission
            && emits_towards(m.two_sided, hit.n, wo)
        {
            color += *e;
        }

        // Eqs. 6–7: local illumination from each light, with (filtered) shadow rays.
        for l in &self.lights {
            let Some(ls) = l.kind.sample_li(&LightSampleContext { p: hit.p, ns }, Vec2::ZERO, 1.0) else { continue };
            let same_side = ng.dot(ls.wi) > 0.0;
            if same_side && (m.has_diffuse || m.has_specular) {
                let Some(visibility) = self.shadow(hit, ls.target, ls.wi, inside, count) else {
                    continue;
                };
                let mut term = SampledSpectrum([0.0; N]);
                if m.has_diffuse {
                    term += m.kd * hall::diffuse_weight(ns, ls.wi);
                }
                if m.has_specular {
                    term += m.ks * hall::specular_weight(ns, wo, ls.wi, m.shininess);
                }
                color += term * l.spectrum * visibility * ls.scale;
            } else if !same_side && m.transmissive {
                // Light behind a transparent surface: Hall's transmitted highlight.
                let (eta_v, eta_l) = if entering { (1.0, m.eta) } else { (m.eta, 1.0) };
                let w = hall::transmission_weight(ns, wo, ls.wi, eta_v, eta_l, m.shininess);
                if w > 0.0 {
                    // The shadow ray crosses this surface: it travels inside the object when
                    // the viewer is outside, and outside when the viewer is inside.
                    let start = if entering { Some(m) } else { None };
                    let Some(visibility) = self.shadow(hit, ls.target, ls.wi, start, count) else {
                        continue;
                    };
                    color += m.kt * l.spectrum * visibility * (w * ls.scale);
                }
            }
        }

        if depth >= self.max_depth {
            return color;
        }

        // Eq. 1: specular reflection, R = V − 2 (V·N) N.
        // A Fresnel-weighted surface shares the light: F reflected, 1 − F transmitted (F = 1 under
        // total internal reflection), so k_s F + k_t (1 − F) ≤ 1.
        let (ks, kt) = if m.fresnel && m.transmissive {
            let f = scattering::fr_dielectric(ng.dot(wo), if entering { m.eta } else { 1.0 / m.eta });
            (m.ks * f, m.kt * (1.0 - f))
        } else {
            (m.ks, m.kt)
        };
        let mut reflect_coeff = ks;
        let mut reflect_weight = weight * ks.max_component();
        // Eq. 2: refraction (Snell); under total internal reflection the transmitted share is
        // reflected instead.
        if m.transmissive {
            let eta = if entering { m.eta } else { 1.0 / m.eta };
            match scattering::refract(wo, ng, eta) {
                Some((wt, _)) => {
                    let w = weight * kt.max_component();
                    if w > self.min_weight {
                        let next_inside = if entering { Some(m) } else { None };
                        let transmitted = self.trace(&spawn_ray(hit, wt), depth + 1, w, next_inside, count);
                        color += kt * transmitted;
                    }
                }
                None => {
                    reflect_coeff += kt;
                    reflect_weight = weight * reflect_coeff.max_component();
                }
            }
        }
        if reflect_weight > self.min_weight {
            let wr = scattering::reflect(wo, ns);
            // A shading normal can mirror the ray below the surface; use the true normal then.
            let wr = if wr.dot(ng) > 0.0 { wr } else { scattering::reflect(wo, ng) };
            let reflected = self.trace(&spawn_ray(hit, wr), depth + 1, reflect_weight, inside, count);
            color += reflect_coeff * reflected;
        }
        color
    }

    /// Visibility of a light: `None` if an opaque surface blocks it, else the product of the
    /// transmittances k_t T_s of transparent surfaces crossed (Hall's filtered shadows) and,
    /// with absorption on, Beer attenuation inside them. `start` is the medium the shadow ray
    /// starts in.
    fn shadow(
        &self,
        hit: &Hit,
        target: Option<Vec3>,
        wi: Vec3,
        start: Option<&LaneMaterial<N>>,
        count: &mut RayCount,
    ) -> Option<SampledSpectrum<N>> {
        count.shadow_ray();
        let (ray, t_max) = spawn_shadow_ray(hit, target, wi);
        let start = start.filter(|m| m.sigma_a.is_some());
        if start.is_none() && !self.scene.geometry.occluded(&ray, t_max) {
            return Some(SampledSpectrum([1.0; N]));
        }
        // Something is in the way (or the ray starts in an absorbing medium): walk along the
        // ray through transparent surfaces.
        let mut visibility = SampledSpectrum([1.0; N]);
        let mut current = ray;
        let mut remaining = t_max;
        let mut entered_at: Option<(f32, &LaneMaterial<N>)> = start.map(|m| (0.0, m));
        let mut travelled = 0.0f32;
        for _ in 0..MAX_SHADOW_CROSSINGS {
            count.shadow_ray();
            let Some(h) = self.scene.geometry.intersect(&current, remaining) else {
                // Reached the light; still inside a medium if the light is inside an object.
                if let Some((start, inner)) = entered_at
                    && let Some(sigma_a) = &inner.sigma_a
                {
                    let end = travelled + remaining * current.dir.length();
                    visibility *= materials::beer_transmittance(sigma_a, end - start);
                }
                return Some(visibility);
            };
            let m = self.material(h.material);
            if !m.transmissive {
                return None;
            }
            visibility *= m.kt;
            let dir_len = current.dir.length();
            let at = travelled + h.t * dir_len;
            let entering = h.n.dot(current.dir) < 0.0;
            if entering {
                entered_at = Some((at, m));
            } else {
                // Leaving without having entered: the shadow ray started inside this object.
                let (start, inner) = entered_at.take().unwrap_or((0.0, m));
                if let Some(sigma_a) = &inner.sigma_a {
                    visibility *= materials::beer_transmittance(sigma_a, at - start);
                }
            }
            if visibility.max_component() <= 0.0 {
                return None;
            }
            travelled = at;
            remaining -= h.t;
            current = spawn_ray(&h, current.dir);
        }
        None
    }
}

impl<const N: usize> Kernel<N> for Whitted<'_, N> {
    /// The paper's model is deterministic: fixed sub-pixel positions, fixed lanes.
    const RANDOM: bool = false;

    /// Radiance (lane values) arriving along a camera ray, and what the ray saw first.
    #[inline]
    fn li(
        &self,
        ray: &Ray,
        _lambda: &mut SampledWavelengths<N>,
        _sensor: &Sensor<N>,
        _sampler: &mut Sampler,
        count: &mut RayCount,
        _splats: &mut Vec<Splat<N>>,
    ) -> Radiance<N> {
        let (l, first) = self.trace_with_id(ray, 0, 1.0, None, count);
        Radiance { l, first, lane: None }
    }
}

/// The ambient light I_a(λ) of eq. 6: a constant fraction of the light (the classic term
/// the paper compares with, e.g. 10 %) or the paper's object ambient (eq. 9),
/// I_a(λ) = K_a S̄(λ) Σ_i k_i R_i(λ)^n, with k_i the share of object i (all primitives of
/// material i) in the scene's surface area and R_i its diffuse reflectance.
fn ambient_spectrum<const N: usize>(
    scene: &RenderScene,
    lanes: &Lanes<N>,
    ambient: Ambient,
    light_sum: SampledSpectrum<N>,
) -> SampledSpectrum<N> {
    match ambient {
        Ambient::None => SampledSpectrum([0.0; N]),
        Ambient::Constant(k_a) => light_sum * k_a,
        Ambient::Objects { k_a, exponent } => {
            let weights = material_area_shares(scene);
            let mut sum = SampledSpectrum([0.0; N]);
            for (material, k_i) in scene.materials.iter().zip(&weights) {
                let r = SampledSpectrum(lanes.project(&material.diffuse, SpectrumKind::Reflectance));
                sum += SampledSpectrum(r.0.map(|v| v.max(0.0).powf(exponent))) * *k_i;
            }
            light_sum * sum * k_a
        }
    }
}

/// k_i of eq. 9: each material's share of the total surface area (Σ k_i = 1).
pub(crate) fn material_area_shares(scene: &RenderScene) -> Vec<f32> {
    let mut area = vec![0.0f64; scene.materials.len()];
    for id in 0..scene.geometry.primitive_count() as u32 {
        if let Some(m) = scene.primitive_material(id)
            && let Some(a) = area.get_mut(m as usize)
        {
            *a += f64::from(scene.geometry.primitive_area(id));
        }
    }
    let total: f64 = area.iter().sum();
    area.iter().map(|&a| if total > 0.0 { (a / total) as f32 } else { 0.0 }).collect()
}
