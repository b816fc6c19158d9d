//! Bidirectional path tracing ("bdpt", Veach 1997 ch. 10; the structure of pbrt-v4's `BDPTIntegrator`):
//! a camera subpath and a light subpath per sample, every connection (s light vertices, t camera
//! vertices) weighted by multiple importance sampling (power heuristic) over all the strategies that could
//! have made the same path. Light tracing (t = 1) sends its light to the pixel the connection lands in as a
//! splat ([`Splat`]). It finds what the camera side alone cannot: light from a point or small light that
//! reaches a diffuse surface through smooth glass or a mirror (caustics).
//!
//! Spectral as the path tracer: both subpaths carry the sample's wavelengths, and a dispersive interface on
//! either side keeps one wavelength (the hero; with fixed lanes one lane) for the whole sample. Surfaces are
//! the path tracer's (`PathTracer::scattering`): every material, texture and cut-out renders alike.
//!
//! Lights at infinity (the environment, a directional light) start light subpaths on a disc the size of the
//! scene (pbrt-v4's construction, `Emitters::sample_le`); escaping camera walks end on a vertex at infinity.
//! Paths through a smooth surface seen from the camera and lit through another (light → glass → diffuse →
//! glass → camera) have no strategy here at all: they are the "specular–diffuse–specular" paths only photon
//! mapping finds (`sppm.rs`), and BDPT leaves them out as pbrt-v4's does (`docs/path-tracer.md`).

use colorimetry::{SampledSpectrum, SampledWavelengths};
use geometry::{Camera, Hit, Ray, spawn_ray, spawn_ray_to};
use glam::Vec3;
use materials::bsdf::{Bsdf, Frame};

use crate::film::{ObjectId, Sensor};
use crate::integrators::kernel::{Kernel, Radiance, RayCount, Splat};
use crate::integrators::path::{HitSurface, LastSpectrum, PathTracer, lifted_point};
use crate::lights::{LightKind, LightSampleContext, emits_towards};
use crate::sampling::Sampler;
use crate::texture::{MAX_ALPHA_SKIPS, Uv};

/// Sampler blocks (see `Sampler::start_block`): the camera subpath's bounce d takes `2d + 2` as the path
/// tracer does, the light subpath `LIGHT_BLOCKS + d`, the light sample at camera vertex t
/// `NEE_BLOCKS + t`.
const LIGHT_BLOCKS: u32 = 1 << 20;
const NEE_BLOCKS: u32 = 1 << 21;

/// What a vertex is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    /// The pinhole.
    Camera,
    /// A light subpath's first vertex: light `light` of the scene's emitters.
    Light { light: usize },
    /// A light at infinity (the environment, a directional light): a light subpath's first vertex, a
    /// direction sampled towards it from the camera side, or where a camera subpath escapes. Its `p` is a
    /// point along its direction from the next vertex (so that directions to it are right); densities to
    /// it stay per steradian, and the next vertex's density from it is per unit area of the disc light
    /// from infinity enters through (pbrt-v4 `Vertex::IsInfiniteLight`).
    Infinite { light: usize },
    /// A surface the walk hit.
    Surface,
}

/// One vertex of a subpath (pbrt-v4 `Vertex`).
#[derive(Clone, Copy)]
pub(super) struct Vertex<const N: usize> {
    kind: Kind,
    pub(super) p: Vec3,
    /// Geometric normal (zero at a point: the camera, a point light).
    ng: Vec3,
    /// Shading normal for the cosines of connections (zero at a point).
    ns: Vec3,
    /// The surface hit (surface vertices and area-light points: rays leave from it).
    hit: Option<Hit>,
    pub(super) frame: Frame,
    pub(super) bsdf: Option<Bsdf<N>>,
    /// The subpath's throughput up to and including this vertex's arrival (pbrt-v4 `beta`).
    pub(super) beta: SampledSpectrum<N>,
    /// Density per unit area of this vertex when its own subpath made it, and when the other side would
    /// have (pbrt-v4 `pdfFwd`, `pdfRev`).
    pdf_fwd: f32,
    pdf_rev: f32,
    /// A delta scattering event (smooth glass, a mirror): no connection here.
    delta: bool,
    /// The light this surface is, where it emits (camera subpaths ending on an area light).
    emitter: Option<usize>,
    /// The material's σ_a where it encloses an absorbing medium (Beer–Lambert on connections inside).
    absorbs: bool,
    pub(super) material: Option<u32>,
}

impl<const N: usize> Vertex<N> {
    fn point(kind: Kind, p: Vec3, beta: SampledSpectrum<N>, pdf_fwd: f32) -> Self {
        Self {
            kind,
            p,
            ng: Vec3::ZERO,
            ns: Vec3::ZERO,
            hit: None,
            frame: Frame { n: Vec3::Z, ns: Vec3::Z },
            bsdf: None,
            beta,
            pdf_fwd,
            pdf_rev: 0.0,
            delta: false,
            emitter: None,
            absorbs: false,
            material: None,
        }
    }

    fn on_surface(&self) -> bool {
        self.ng != Vec3::ZERO
    }

    /// Whether a connection can end here: a finite light, the camera, or a surface with a non-delta lobe
    /// (a light at infinity is reached by next-event estimation and escaping rays only).
    pub(super) fn connectible(&self) -> bool {
        match self.kind {
            Kind::Surface => self.bsdf.as_ref().is_some_and(|b| !b.is_specular()),
            Kind::Infinite { .. } => false,
            _ => true,
        }
    }

    fn is_infinite(&self) -> bool {
        matches!(self.kind, Kind::Infinite { .. })
    }

    /// The light this vertex stands for as a subpath's light end: a light vertex's, or an emitting
    /// surface's.
    fn light(&self) -> Option<usize> {
        match self.kind {
            Kind::Light { light } | Kind::Infinite { light } => Some(light),
            Kind::Surface => self.emitter,
            Kind::Camera => None,
        }
    }
}

/// Which way a subpath carries its quantity: radiance from the camera, importance from a light.
#[derive(Clone, Copy, PartialEq)]
enum Mode {
    Radiance,
    Importance,
}

/// The bidirectional path tracer: the path tracer's surfaces and lights, a pinhole camera.
pub(crate) struct Bdpt<'a, const N: usize> {
    tracer: PathTracer<'a, N>,
    camera: Camera,
    width: u32,
    height: u32,
    /// The image plane's area at distance 1 ([`Camera::image_plane_area`]).
    plane_area: f32,
    /// Photon mapping's camera pass (`sppm.rs`): camera walks stop at the first surface with a non-delta
    /// lobe (the visible point), and the strategies left — light hit through delta vertices, a light
    /// sampled at the visible point — each count in full, since photons make every other path.
    gather: bool,
}

impl<'a, const N: usize> Bdpt<'a, N> {
    /// BDPT over `tracer`'s scene seen by `camera` (a pinhole) in a `width`×`height` image.
    pub(crate) fn new(tracer: PathTracer<'a, N>, camera: Camera, width: u32, height: u32) -> Self {
        let plane_area = camera.image_plane_area();
        Self { tracer, camera, width, height, plane_area, gather: false }
    }

    /// The walks and strategies of photon mapping's camera pass and photon pass (see [`Bdpt::gather`]).
    pub(super) fn for_photon_mapping(tracer: PathTracer<'a, N>, camera: Camera, width: u32, height: u32) -> Self {
        Self { gather: true, ..Self::new(tracer, camera, width, height) }
    }

    pub(super) fn tracer(&self) -> &PathTracer<'a, N> {
        &self.tracer
    }

    /// Density per steradian with which the camera sends a ray along unit `w` (pbrt-v4
    /// `PerspectiveCamera::PDF_We`'s direction part): 1 / (A cos³ θ) inside the image, else 0.
    fn camera_pdf_dir(&self, w: Vec3) -> f32 {
        let cos = w.dot(self.camera.forward());
        if cos <= 0.0 {
            return 0.0;
        }
        match self.camera.raster_of(self.camera.position() + w, self.width, self.height) {
            Some(_) => 1.0 / (self.plane_area * cos * cos * cos),
            None => 0.0,
        }
    }

    /// A density per steradian at `from` towards `to`, per unit area at `to`; per steradian still where
    /// `to` is at infinity (pbrt-v4 `Vertex::ConvertDensity`).
    fn to_area(pdf: f32, from: Vec3, to: &Vertex<N>) -> f32 {
        if to.is_infinite() {
            return pdf;
        }
        let d = to.p - from;
        let d2 = d.length_squared();
        if !(d2 > 0.0) {
            return 0.0;
        }
        let mut pdf = pdf / d2;
        if to.on_surface() {
            pdf *= to.ng.dot(d / d2.sqrt()).abs();
        }
        pdf
    }

    /// Density (per unit area at `next`) with which vertex `v`, reached from `prev`, sends its subpath on
    /// to `next` (pbrt-v4 `Vertex::Pdf`).
    fn pdf(&self, v: &Vertex<N>, prev: Option<&Vertex<N>>, next: &Vertex<N>) -> f32 {
        let w = next.p - v.p;
        let Some(w) = w.try_normalize() else { return 0.0 };
        let pdf_dir = match v.kind {
            Kind::Camera => self.camera_pdf_dir(w),
            Kind::Light { .. } | Kind::Infinite { .. } => return self.pdf_light(v, next),
            Kind::Surface => {
                let (Some(prev), Some(bsdf)) = (prev, v.bsdf.as_ref()) else { return self.pdf_light(v, next) };
                let Some(wo) = (prev.p - v.p).try_normalize() else { return 0.0 };
                bsdf.pdf(&v.frame, wo, w)
            }
        };
        Self::to_area(pdf_dir, v.p, next)
    }

    /// Density (per unit area at `next`) with which light vertex `v` emits towards `next` (pbrt-v4
    /// `Vertex::PdfLight`); from a light at infinity the disc's density, per unit area across the
    /// direction, times the cosine at `next`.
    fn pdf_light(&self, v: &Vertex<N>, next: &Vertex<N>) -> f32 {
        let Some(light) = v.light() else { return 0.0 };
        let Some(w) = (next.p - v.p).try_normalize() else { return 0.0 };
        let emitters = &self.tracer.scene.emitters;
        if v.is_infinite() {
            let cos = if next.on_surface() { next.ng.dot(w).abs() } else { 1.0 };
            return emitters.disc_pdf() * cos;
        }
        let (_, pdf_dir) = emitters.kind(light).pdf_le(v.ng, w);
        Self::to_area(pdf_dir, v.p, next)
    }

    /// Density per unit area with which a light subpath starts at light vertex `v` (pbrt-v4
    /// `Vertex::PdfLightOrigin`): the light's choice probability times its position density; for a light
    /// at infinity times the density of its direction instead (`toward` from the light).
    fn pdf_light_origin(&self, v: &Vertex<N>, toward: Vec3) -> f32 {
        let Some(light) = v.light() else { return 0.0 };
        if v.is_infinite() {
            return self.le_density(light, -toward);
        }
        let emitters = &self.tracer.scene.emitters;
        let (pdf_pos, _) = emitters.kind(light).pdf_le(v.ng, toward);
        emitters.probability(light) * pdf_pos
    }

    /// Density with which a light subpath leaves light at infinity `light` from direction `wi` (unit,
    /// towards the light): its choice probability times the direction's density (times 1 for a directional
    /// light, whose direction is certain).
    fn le_density(&self, light: usize, wi: Vec3) -> f32 {
        let emitters = &self.tracer.scene.emitters;
        emitters.probability(light) * emitters.pdf_le(light, Vec3::ZERO, -wi).1
    }

    /// Density with which next-event estimation at surface vertex `x`, seen from `toward` (the next vertex
    /// on the camera's side), picks direction `wi` to light at infinity `light`, the light's choice
    /// included ([`Emitters::sample_li`]: about the shading normal on that side).
    fn nee_density(&self, light: usize, x: &Vertex<N>, toward: Vec3, wi: Vec3) -> f32 {
        let emitters = &self.tracer.scene.emitters;
        if emitters.kind(light).is_delta() {
            return emitters.probability(light);
        }
        let Some(wo) = (toward - x.p).try_normalize() else { return 0.0 };
        let ns = x.frame.facing(wo).1;
        emitters.pdf_li_escaped(&LightSampleContext { p: x.p, ns }, wi)
    }

    /// Light a vertex on light `light` at `p` (normal `n` on an area light) sends along unit `w`: for a
    /// light at infinity the radiance (environment) or irradiance (directional light) along `w`. The light's
    /// spectrum goes through `last` (the previous light evaluated at the same call site of this sample).
    /// ([`PathTracer::sampled_radiance`] is next-event estimation's; this one also has a vertex's light:
    /// its side, a spot's cone, a luminaire's web, from a direction no light sample chose.)
    #[allow(clippy::too_many_arguments)]
    fn emitted(
        &self,
        light: usize,
        p: Vec3,
        n: Vec3,
        w: Vec3,
        lambda: &SampledWavelengths<N>,
        last: &mut LastSpectrum<N>,
    ) -> SampledSpectrum<N> {
        let black = SampledSpectrum([0.0; N]);
        let tracer = &self.tracer;
        let kind = tracer.scene.emitters.kind(light);
        let scale = match *kind {
            LightKind::Triangle { two_sided, .. } | LightKind::Sphere { two_sided, .. } => {
                if !emits_towards(two_sided, n, w) {
                    return black;
                }
                if !tracer.textured_lights.is_empty()
                    && let Some(le) = tracer.textured_light_radiance(light, Some(p), lambda)
                {
                    return le;
                }
                1.0
            }
            LightKind::Point { .. } => 1.0,
            LightKind::Luminaire { ref web, .. } => web.intensity(w),
            LightKind::Spot { direction, cos_inner, cos_outer, .. } => {
                crate::lights::smoothstep(cos_outer, cos_inner, w.dot(direction))
            }
            LightKind::Directional { .. } => 1.0,
            LightKind::Environment => return tracer.environment_radiance(-w, lambda),
        };
        tracer.spectra.eval_memo(tracer.light_spectra[light], lambda, last) * scale
    }

    /// Whether light passes from `a` to `b` (0 to 1 through cut-outs), with Beer–Lambert absorption where
    /// the segment runs inside an absorbing dielectric.
    fn transmittance(
        &self,
        a: &Vertex<N>,
        b: &Vertex<N>,
        lambda: &SampledWavelengths<N>,
        count: &mut RayCount,
    ) -> Option<SampledSpectrum<N>> {
        let tracer = &self.tracer;
        let geometry = &tracer.scene.geometry;
        // Rays leave from a surface (offset off it); a point (camera, point light) is the target.
        let (from, to) = match (a.hit.as_ref(), b.hit.as_ref()) {
            (Some(_), _) => (a, b),
            (None, Some(_)) => (b, a),
            (None, None) => return None,
        };
        let hit = from.hit.as_ref()?;
        count.shadow_ray();
        let visible = if tracer.scene.alpha_cutouts {
            tracer.visibility(hit, None, Some(to.p), (to.p - from.p).normalize_or_zero(), count)
        } else {
            let (ray, t_max) = spawn_ray_to(hit, to.p);
            if geometry.occluded(&ray, t_max) { 0.0 } else { 1.0 }
        };
        if visible <= 0.0 {
            return None;
        }
        let mut tr = SampledSpectrum([visible; N]);
        let d = b.p - a.p;
        for (v, w) in [(a, d), (b, -d)] {
            if v.absorbs && v.ng.dot(w) < 0.0 {
                let m = tracer.material(v.material);
                if let Some(sigma_a) = m.sigma_a {
                    tr *= materials::beer_transmittance(&tracer.spectra.eval(sigma_a, lambda), d.length());
                }
                break;
            }
        }
        Some(tr)
    }

    /// Extend `path` (whose last vertex sent `ray` with density `pdf_dir` per steradian, per unit area
    /// across the ray from a light at infinity, and throughput `beta`) by a random walk of at most `max`
    /// vertices in all (pbrt-v4 `RandomWalk`). A camera walk that escapes into an environment ends on a
    /// vertex at infinity (strategy s = 0).
    #[allow(clippy::too_many_arguments)]
    fn walk<const ROUGH: bool>(
        &self,
        mut ray: Ray,
        mut beta: SampledSpectrum<N>,
        pdf_dir: f32,
        mode: Mode,
        path: &mut Vec<Vertex<N>>,
        max: usize,
        lambda: &mut SampledWavelengths<N>,
        sensor: &Sensor<N>,
        lane: &mut Option<usize>,
        sampler: &mut Sampler,
        count: &mut RayCount,
    ) {
        let tracer = &self.tracer;
        let scene = tracer.scene;
        let mut pdf_fwd = pdf_dir;
        let mut eta_scale = 1.0f32;
        let mut skipped = 0.0f32;
        let mut skips = 0u32;
        let mut last = LastSpectrum(None);
        let mut bounce = 0u32;
        while path.len() < max {
            count.rays += 1;
            let Some(hit) = scene.geometry.intersect(&ray, f32::INFINITY) else {
                if mode == Mode::Radiance
                    && let Some(light) = scene.emitters.environment()
                {
                    let from = path.last().expect("a walk starts from a vertex").p;
                    path.push(Vertex::point(Kind::Infinite { light }, from + ray.dir.normalize(), beta, pdf_fwd));
                }
                break;
            };
            let textures = tracer.textures(hit.material);
            let colors = tracer.vertex_color_of(textures, &hit);
            let uv = if textures.is_some() { tracer.hit_uvs(textures, &hit) } else { Uv::same(hit.uv) };
            if skips < MAX_ALPHA_SKIPS && PathTracer::<N>::cut_away(textures, colors, uv, sampler) {
                skipped += hit.t * ray.dir.length();
                skips += 1;
                ray = spawn_ray(&hit, ray.dir);
                continue;
            }
            let m = tracer.material(hit.material);
            let dir_len = ray.dir.length();
            let segment = hit.t * dir_len + skipped;
            skipped = 0.0;
            let wo = -ray.dir / dir_len;
            if let Some(sigma_a) = m.sigma_a
                && hit.n.dot(wo) < 0.0
            {
                beta *= materials::beer_transmittance(&tracer.spectra.eval(sigma_a, lambda), segment);
            }
            let prev = *path.last().expect("a walk starts from a vertex");
            let mut v = Vertex {
                kind: Kind::Surface,
                p: hit.p,
                ng: hit.n,
                ns: hit.ns,
                hit: Some(hit),
                frame: Frame { n: hit.n, ns: hit.ns },
                bsdf: None,
                beta,
                pdf_fwd: 0.0,
                pdf_rev: 0.0,
                delta: false,
                emitter: None,
                absorbs: m.sigma_a.is_some(),
                material: hit.material,
            };
            v.pdf_fwd = if prev.is_infinite() {
                // From infinity: the disc's density across the ray, per unit area here.
                pdf_fwd * hit.n.dot(wo).abs()
            } else {
                Self::to_area(pdf_fwd, prev.p, &v)
            };
            if m.emission.is_some() && mode == Mode::Radiance {
                v.emitter = scene.emitters.light_of_primitive(hit.primitive);
            }
            if path.len() + 1 >= max || beta.is_black() {
                path.push(v);
                break;
            }
            let (bsdf, frame) = tracer.scattering::<ROUGH>(
                &hit,
                m,
                HitSurface { textures, colors, uv },
                wo,
                lambda,
                sensor,
                lane,
                sampler,
                &mut last,
            );
            v.frame = frame;
            v.ns = frame.facing(wo).1;
            v.bsdf = Some(bsdf);
            path.push(v);
            if self.gather && mode == Mode::Radiance && !bsdf.is_specular() {
                break;
            }
            let block = match mode {
                Mode::Radiance => 2 * bounce + 2,
                Mode::Importance => LIGHT_BLOCKS + bounce,
            };
            sampler.start_block(block);
            let Some(s) = bsdf.sample_f(&frame, wo, sampler.uniform(), sampler.uniform2()) else { break };
            let i = path.len() - 1;
            let delta = s.flags.is_specular();
            let mut weight = s.weight;
            if mode == Mode::Importance {
                // The adjoint BSDF: a refraction does not scale importance by 1/η² as it scales radiance,
                // and shading normals need Veach's correction (pbrt-v4 `CorrectShadingNormal`).
                weight *= s.eta_scale * shading_correction(&frame, wo, s.wi);
            }
            beta *= weight;
            eta_scale *= s.eta_scale;
            let (pdf_next, pdf_back) = if delta { (0.0, 0.0) } else { (s.pdf, bsdf.pdf(&frame, s.wi, wo)) };
            path[i].delta = delta;
            path[i - 1].pdf_rev = Self::to_area(pdf_back, hit.p, &prev);
            pdf_fwd = pdf_next;
            ray = spawn_ray(&hit, s.wi);
            bounce += 1;
            if bounce >= tracer.rr_depth {
                let rr = match mode {
                    Mode::Radiance => (beta * eta_scale).max_component(),
                    Mode::Importance => beta.max_component() / path[0].beta.max_component().max(f32::MIN_POSITIVE),
                };
                if rr < 1.0 {
                    let q = (1.0 - rr).max(0.0);
                    if sampler.uniform() < q {
                        break;
                    }
                    beta = beta / (1.0 - q);
                }
            }
        }
    }

    /// The camera subpath of `ray` (a unit direction from the pinhole).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn camera_subpath<const ROUGH: bool>(
        &self,
        ray: &Ray,
        path: &mut Vec<Vertex<N>>,
        lambda: &mut SampledWavelengths<N>,
        sensor: &Sensor<N>,
        lane: &mut Option<usize>,
        sampler: &mut Sampler,
        count: &mut RayCount,
    ) {
        path.clear();
        let one = SampledSpectrum([1.0; N]);
        path.push(Vertex::point(Kind::Camera, ray.origin, one, 1.0));
        let dir = ray.dir.normalize();
        let pdf_dir = self.camera_pdf_dir(dir);
        let max = self.tracer.max_depth as usize + 2;
        let ray = Ray { origin: ray.origin, dir };
        self.walk::<ROUGH>(ray, one, pdf_dir, Mode::Radiance, path, max, lambda, sensor, lane, sampler, count)
    }

    /// The light subpath: a light chosen ∝ power, a ray leaving it, a walk (pbrt-v4
    /// `GenerateLightSubpath`). A light at infinity starts it on the disc its light enters the scene
    /// through ([`Emitters::sample_le`]). Empty where the chosen light sends nothing.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn light_subpath<const ROUGH: bool>(
        &self,
        path: &mut Vec<Vertex<N>>,
        lambda: &mut SampledWavelengths<N>,
        sensor: &Sensor<N>,
        lane: &mut Option<usize>,
        sampler: &mut Sampler,
        count: &mut RayCount,
    ) {
        path.clear();
        let emitters = &self.tracer.scene.emitters;
        sampler.start_block(LIGHT_BLOCKS - 1);
        let u = sampler.uniform();
        let (u1, u2) = (sampler.uniform2(), sampler.uniform2());
        let Some((light, pmf)) = emitters.choose(u) else { return };
        if pmf <= 0.0 {
            return;
        }
        let Some(le) = emitters.sample_le(light, u1, u2) else { return };
        let n = le.n.unwrap_or(Vec3::ZERO);
        let radiance = self.emitted(light, le.p, n, le.w, lambda, &mut LastSpectrum(None));
        if radiance.is_black() {
            return;
        }
        // The light vertex, the throughput leaving it and the density (per steradian, or per unit area across
        // the ray from infinity) of the walk's first vertex.
        let (vertex, ray, beta, pdf_walk) = if emitters.kind(light).is_infinite() {
            // pbrt-v4's densities: the light vertex's is its direction's, the first surface's the
            // disc's (set by the walk); radiance over the disc's and the direction's densities.
            let pdf_origin = pmf * le.pdf_dir;
            let v = Vertex::point(Kind::Infinite { light }, le.p, radiance * (1.0 / (pmf * le.pdf_pos)), pdf_origin);
            (v, Ray { origin: le.p, dir: le.w }, radiance * (1.0 / (pdf_origin * le.pdf_pos)), le.pdf_pos)
        } else {
            let pdf_origin = pmf * le.pdf_pos;
            let mut v = Vertex::point(Kind::Light { light }, le.p, radiance * (1.0 / pdf_origin), pdf_origin);
            let cos = if le.n.is_some() { n.dot(le.w).abs() } else { 1.0 };
            let ray = match le.n {
                Some(n) => {
                    // An area light's point lies on its surface: rays leave it offset as from a hit.
                    let hit = lifted_point(le.p, n);
                    v.ng = n;
                    v.ns = n;
                    v.hit = Some(hit);
                    spawn_ray(&hit, le.w)
                }
                None => Ray { origin: le.p, dir: le.w },
            };
            (v, ray, radiance * (cos / (pdf_origin * le.pdf_dir)), le.pdf_dir)
        };
        path.push(vertex);
        let max = self.tracer.max_depth as usize + 1;
        self.walk::<ROUGH>(ray, beta, pdf_walk, Mode::Importance, path, max, lambda, sensor, lane, sampler, count);
    }

    /// The BSDF value at surface vertex `v` for light arriving from `toward_light` and leaving towards
    /// `toward_camera` (points), times nothing else; black where `v` has no BSDF.
    fn f(v: &Vertex<N>, toward_camera: Vec3, toward_light: Vec3) -> SampledSpectrum<N> {
        let (Some(bsdf), Some(wo), Some(wi)) =
            (v.bsdf.as_ref(), (toward_camera - v.p).try_normalize(), (toward_light - v.p).try_normalize())
        else {
            return SampledSpectrum([0.0; N]);
        };
        bsdf.f(&v.frame, wo, wi)
    }

    /// The MIS weight of the path made by connecting `light[..s]` (with `qs`, a resampled light vertex when
    /// s = 1) to `camera[..t]` (with `pt`, the resampled camera vertex when t = 1): the power heuristic over
    /// every (s′, t′) that makes the same path, from the ratios of the vertices' densities (pbrt-v4
    /// `MISWeight`, there with the balance heuristic).
    fn mis_weight(
        &self,
        light: &[Vertex<N>],
        camera: &[Vertex<N>],
        s: usize,
        t: usize,
        qs_sampled: Option<&Vertex<N>>,
        pt_sampled: Option<&Vertex<N>>,
    ) -> f32 {
        if s + t == 2 || self.gather {
            return 1.0;
        }
        let qs = qs_sampled.or_else(|| s.checked_sub(1).map(|i| &light[i]));
        let pt = pt_sampled.unwrap_or(&camera[t - 1]);
        let qs_minus = if s >= 2 { Some(&light[s - 2]) } else { None };
        let pt_minus = if t >= 2 { Some(&camera[t - 2]) } else { None };
        // The reverse densities the connection changes, beside the vertices (their other fields are what
        // the subpaths made): where pt would have been made from the light side, and pt⁻ too; qs and qs⁻
        // from the camera side. The connection's ends are no delta events.
        let pt_rev = match qs {
            Some(q) => self.pdf(q, qs_minus, pt),
            None => self.pdf_light_origin(pt, pt_minus.map_or(Vec3::Z, |m| (m.p - pt.p).normalize_or_zero())),
        };
        let pt_minus_rev = pt_minus.map_or(0.0, |m| match qs {
            Some(q) => self.pdf(pt, Some(q), m),
            None => self.pdf_light(pt, m),
        });
        let qs_rev = qs.map_or(0.0, |q| self.pdf(pt, pt_minus, q));
        let qs_minus_rev = match (qs, qs_minus) {
            (Some(q), Some(m)) => self.pdf(q, Some(pt), m),
            _ => 0.0,
        };
        // A light at infinity at the path's end: next-event estimation samples its direction with another
        // density than its light subpaths do (about the shading normal, against over the sphere), so the
        // strategy s′ = 1 has its own density for that vertex, p_nee, where every s′ ≥ 2 has p_le. The
        // ratios below carry p_le (in the vertex's pdf_fwd or pdf_rev), and the terms are corrected by
        // p_nee / p_le for s′ = 1, or all others by p_le / p_nee when this strategy is s = 1.
        let infinite = match s {
            0 => pt.is_infinite().then(|| {
                let light = pt.light().expect("a light at infinity");
                let x1 = pt_minus.expect("t ≥ 3 when s = 0 and s + t > 2");
                let wi = (pt.p - x1.p).normalize_or_zero();
                (self.nee_density(light, x1, camera[t - 3].p, wi), pt_rev)
            }),
            1 => qs
                .filter(|q| q.is_infinite())
                .map(|q| (q.pdf_fwd, self.pdf_light_origin(q, (pt.p - q.p).normalize_or_zero()))),
            _ => light[0].is_infinite().then(|| {
                let (x0, x1) = (&light[0], &light[1]);
                let toward = if s >= 3 { light[2].p } else { pt.p };
                let wi = (x0.p - x1.p).normalize_or_zero();
                let nee = self.nee_density(x0.light().expect("a light at infinity"), x1, toward, wi);
                (nee, x0.pdf_fwd)
            }),
        };
        let remap = |p: f32| if p != 0.0 { p } else { 1.0 };
        // (pdf_fwd, pdf_rev, delta) of each vertex, the connection's four changed ones in place.
        let densities = |v: &Vertex<N>| (v.pdf_fwd, v.pdf_rev, v.delta);
        let camera_at = |i: usize| {
            if i == t - 1 {
                (pt.pdf_fwd, pt_rev, false)
            } else if t >= 2 && i == t - 2 {
                pt_minus.map_or((0.0, 0.0, false), |m| (m.pdf_fwd, pt_minus_rev, m.delta))
            } else {
                densities(&camera[i])
            }
        };
        let light_at = |i: usize| {
            if i == s - 1 {
                qs.map_or((0.0, 0.0, false), |q| (q.pdf_fwd, qs_rev, false))
            } else if s >= 2 && i == s - 2 {
                qs_minus.map_or((0.0, 0.0, false), |m| (m.pdf_fwd, qs_minus_rev, m.delta))
            } else {
                densities(&light[i])
            }
        };
        let mut sum = 0.0f32;
        let mut ri = 1.0f32;
        for i in (1..t).rev() {
            let (fwd, rev, delta) = camera_at(i);
            // (s′, t′) = (s + t − i, i).
            let term = match infinite {
                None => {
                    ri *= remap(rev) / remap(fwd);
                    ri
                }
                // The vertex at infinity itself (s = 0): s′ = 1 samples it with p_nee, s′ ≥ 2 with p_le
                // (not remapped: 0 there means no light subpath makes this path).
                Some((nee, le)) if s == 0 && i == t - 1 => {
                    ri = le / remap(fwd);
                    nee / remap(fwd)
                }
                Some(_) if s == 0 => {
                    ri *= remap(rev) / remap(fwd);
                    ri
                }
                Some((nee, le)) => {
                    ri *= remap(rev) / remap(fwd);
                    if s == 1 { ri * (le / nee) } else { ri }
                }
            };
            if !delta && !camera_at(i - 1).2 {
                sum += term * term;
            }
        }
        ri = 1.0;
        for i in (0..s).rev() {
            let (fwd, rev, delta) = light_at(i);
            ri *= remap(rev) / remap(fwd);
            let term = match infinite {
                Some((nee, le)) if s >= 2 && i == 1 => ri * (nee / le),
                _ => ri,
            };
            let delta_light = if i > 0 {
                light_at(i - 1).2
            } else {
                self.is_delta_light(if s == 1 { qs.expect("s ≥ 1") } else { &light[0] })
            };
            if !delta && !delta_light {
                sum += term * term;
            }
        }
        // (A density ratio that overflows makes this strategy's weight 0, as its limit is.)
        if sum.is_nan() { 0.0 } else { 1.0 / (1.0 + sum) }
    }

    fn is_delta_light(&self, v: &Vertex<N>) -> bool {
        v.light().is_some_and(|l| self.tracer.scene.emitters.kind(l).is_delta())
    }

    /// The radiance of every strategy of one sample, and the splats of its light tracing.
    #[allow(clippy::too_many_arguments)]
    fn connect_all(
        &self,
        camera: &[Vertex<N>],
        light: &[Vertex<N>],
        lambda: &SampledWavelengths<N>,
        sampler: &mut Sampler,
        count: &mut RayCount,
        splats: &mut Vec<Splat<N>>,
    ) -> SampledSpectrum<N> {
        let mut l = SampledSpectrum([0.0; N]);
        let max_depth = self.tracer.max_depth as usize;
        // The wavelengths are final here (both walks have made their dispersive choices): each strategy
        // evaluates a light's spectrum once per sample.
        let (mut last_hit, mut last_sampled) = (LastSpectrum(None), LastSpectrum(None));
        for t in 1..=camera.len() {
            for s in 0..=light.len() {
                let depth = (s + t) as isize - 2;
                if (s == 1 && t == 1) || depth < 0 || depth as usize > max_depth {
                    continue;
                }
                if t == 1 {
                    if s >= 2 {
                        self.splat(light, s, camera, lambda, count, splats);
                    }
                    continue;
                }
                let c = match s {
                    0 => self.hit_light(camera, t, lambda, &mut last_hit),
                    1 => {
                        sampler.start_block(NEE_BLOCKS + t as u32);
                        self.light_sample(camera, t, lambda, &mut last_sampled, sampler, count)
                    }
                    _ => self.connect(light, s, camera, t, lambda, count),
                };
                l += c;
            }
        }
        l
    }

    /// s = 0: the camera subpath's last vertex is on an area light, or at infinity where it escaped.
    pub(super) fn hit_light(
        &self,
        camera: &[Vertex<N>],
        t: usize,
        lambda: &SampledWavelengths<N>,
        last: &mut LastSpectrum<N>,
    ) -> SampledSpectrum<N> {
        let black = SampledSpectrum([0.0; N]);
        let pt = &camera[t - 1];
        let Some(light) = pt.light() else { return black };
        let Some(w) = (camera[t - 2].p - pt.p).try_normalize() else { return black };
        let le = self.emitted(light, pt.p, pt.ng, w, lambda, last);
        if le.is_black() {
            return black;
        }
        let weight = self.mis_weight(&[], camera, 0, t, None, None);
        pt.beta * le * weight
    }

    /// s = 1: a light sampled from the camera subpath's last vertex (next-event estimation).
    pub(super) fn light_sample(
        &self,
        camera: &[Vertex<N>],
        t: usize,
        lambda: &SampledWavelengths<N>,
        last: &mut LastSpectrum<N>,
        sampler: &mut Sampler,
        count: &mut RayCount,
    ) -> SampledSpectrum<N> {
        let black = SampledSpectrum([0.0; N]);
        let pt = &camera[t - 1];
        let (Some(bsdf), Some(hit)) = (pt.bsdf.as_ref(), pt.hit) else { return black };
        if !pt.connectible() {
            return black;
        }
        let tracer = &self.tracer;
        let emitters = &tracer.scene.emitters;
        if emitters.is_empty() {
            return black;
        }
        let Some(wo) = (camera[t - 2].p - pt.p).try_normalize() else { return black };
        let ns = pt.frame.facing(wo).1;
        let u = sampler.uniform();
        let u2 = sampler.uniform2();
        let Some((light, ls)) = emitters.sample_li(&LightSampleContext { p: pt.p, ns }, u, u2) else { return black };
        let f = bsdf.f_cos(&pt.frame, wo, ls.wi);
        if f.is_black() {
            return black;
        }
        let Some(target) = ls.target else {
            // A light at infinity: a vertex along the sampled direction, of the density it was sampled
            // with (the weight tells that density from a light subpath's).
            count.shadow_ray();
            let visible = if tracer.scene.alpha_cutouts {
                tracer.visibility(&hit, None, None, ls.wi, count)
            } else {
                let ray = spawn_ray(&hit, ls.wi);
                if tracer.scene.geometry.occluded(&ray, f32::INFINITY) { 0.0 } else { 1.0 }
            };
            if visible == 0.0 {
                return black;
            }
            let le = tracer.sampled_radiance(light, &ls, lambda, last);
            let qs = Vertex::point(Kind::Infinite { light }, pt.p + ls.wi, le, ls.pdf);
            let weight = self.mis_weight(&[], camera, 1, t, Some(&qs), None);
            return pt.beta * f * le * (visible * weight * ls.scale / ls.pdf);
        };
        // A light vertex at the sampled point: its normal on an area light, on the side it is seen from.
        let n = if ls.n.dot(-ls.wi) >= 0.0 { ls.n } else { -ls.n };
        let le = self.emitted(light, target, n, -ls.wi, lambda, last);
        if le.is_black() {
            return black;
        }
        let mut qs = Vertex::point(Kind::Light { light }, target, le, 0.0);
        qs.ng = n;
        qs.ns = n;
        if n != Vec3::ZERO {
            qs.hit = Some(lifted_point(target, n));
        }
        qs.pdf_fwd = self.pdf_light_origin(&qs, -ls.wi);
        let Some(tr) = self.transmittance(pt, &qs, lambda, count) else { return black };
        let weight = self.mis_weight(&[], camera, 1, t, Some(&qs), None);
        pt.beta * f * le * tr * (weight * ls.scale / ls.pdf)
    }

    /// s ≥ 2, t ≥ 2: the two subpaths' last vertices joined by a shadow ray.
    fn connect(
        &self,
        light: &[Vertex<N>],
        s: usize,
        camera: &[Vertex<N>],
        t: usize,
        lambda: &SampledWavelengths<N>,
        count: &mut RayCount,
    ) -> SampledSpectrum<N> {
        let black = SampledSpectrum([0.0; N]);
        let (qs, pt) = (&light[s - 1], &camera[t - 1]);
        if !qs.connectible() || !pt.connectible() {
            return black;
        }
        let fq = Self::f(qs, pt.p, light[s - 2].p);
        let fp = Self::f(pt, camera[t - 2].p, qs.p);
        let c = qs.beta * fq * fp * pt.beta;
        if c.is_black() {
            return black;
        }
        let g = geometric_term(qs, pt);
        if !(g > 0.0) {
            return black;
        }
        let Some(tr) = self.transmittance(qs, pt, lambda, count) else { return black };
        let weight = self.mis_weight(light, camera, s, t, None, None);
        c * tr * (g * weight)
    }

    /// t = 1: the light subpath's vertex s − 1 seen by the camera (light tracing), splatted to the pixel it
    /// projects to.
    fn splat(
        &self,
        light: &[Vertex<N>],
        s: usize,
        camera: &[Vertex<N>],
        lambda: &SampledWavelengths<N>,
        count: &mut RayCount,
        splats: &mut Vec<Splat<N>>,
    ) {
        let qs = &light[s - 1];
        if !qs.connectible() {
            return;
        }
        let eye = camera[0].p;
        let Some((x, y, cos)) = self.camera.raster_of(qs.p, self.width, self.height) else { return };
        let d2 = (qs.p - eye).length_squared();
        // The camera's importance over the density of the point as seen from it: We / pdf =
        // 1 / (A cos⁴ θ) · cos θ / d² (pbrt-v4 `PerspectiveCamera::SampleWi`, a pinhole of lens area 1).
        let camera_beta = 1.0 / (self.plane_area * cos * cos * cos * d2);
        let to_eye = (eye - qs.p).normalize_or_zero();
        let f = Self::f(qs, eye, light[s - 2].p);
        let mut c = qs.beta * f * (camera_beta * qs.ns.dot(to_eye).abs());
        if c.is_black() {
            return;
        }
        let mut pt = Vertex::point(Kind::Camera, eye, SampledSpectrum([camera_beta; N]), 0.0);
        pt.pdf_fwd = 1.0;
        let Some(tr) = self.transmittance(qs, &pt, lambda, count) else { return };
        let weight = self.mis_weight(light, camera, s, 1, None, Some(&pt));
        c *= tr * weight;
        let (x, y) = ((x as u32).min(self.width - 1), (y as u32).min(self.height - 1));
        splats.push(Splat { x, y, l: c });
    }

    /// One sample: both subpaths, every connection.
    #[allow(clippy::too_many_arguments)]
    fn sample<const ROUGH: bool>(
        &self,
        ray: &Ray,
        lambda: &mut SampledWavelengths<N>,
        sensor: &Sensor<N>,
        sampler: &mut Sampler,
        count: &mut RayCount,
        splats: &mut Vec<Splat<N>>,
    ) -> Radiance<N> {
        let mut lane = None;
        let (mut camera, mut light) = (Vec::with_capacity(8), Vec::with_capacity(8));
        self.camera_subpath::<ROUGH>(ray, &mut camera, lambda, sensor, &mut lane, sampler, count);
        self.light_subpath::<ROUGH>(&mut light, lambda, sensor, &mut lane, sampler, count);
        let first = match camera.get(1) {
            Some(v) if v.kind == Kind::Surface => ObjectId::Material(v.material),
            _ => ObjectId::Background,
        };
        let l = self.connect_all(&camera, &light, lambda, sampler, count, splats);
        Radiance { l, first, lane }
    }
}

/// |cos θ at a| |cos θ at b| / d² between two vertices (shading normals; 1 at a point).
fn geometric_term<const N: usize>(a: &Vertex<N>, b: &Vertex<N>) -> f32 {
    let d = b.p - a.p;
    let d2 = d.length_squared();
    if !(d2 > 0.0) {
        return 0.0;
    }
    let w = d / d2.sqrt();
    let mut g = 1.0 / d2;
    if a.on_surface() {
        g *= a.ns.dot(w).abs();
    }
    if b.on_surface() {
        g *= b.ns.dot(w).abs();
    }
    g
}

/// Veach's correction of the adjoint BSDF for shading normals (pbrt-v4 `CorrectShadingNormal`, importance):
/// |wo·ns| |wi·ng| / (|wo·ng| |wi·ns|), `wo` the direction the importance came from, `wi` where it goes.
fn shading_correction(frame: &Frame, wo: Vec3, wi: Vec3) -> f32 {
    let (ng, ns) = frame.facing(wo);
    let den = wo.dot(ng).abs() * wi.dot(ns).abs();
    if den == 0.0 { 0.0 } else { wo.dot(ns).abs() * wi.dot(ng).abs() / den }
}

impl<const N: usize> Kernel<N> for Bdpt<'_, N> {
    const RANDOM: bool = true;
    const SPLATS: bool = true;

    fn li(
        &self,
        ray: &Ray,
        lambda: &mut SampledWavelengths<N>,
        sensor: &Sensor<N>,
        sampler: &mut Sampler,
        count: &mut RayCount,
        splats: &mut Vec<Splat<N>>,
    ) -> Radiance<N> {
        if self.tracer.rough {
            self.sample::<true>(ray, lambda, sensor, sampler, count, splats)
        } else {
            self.sample::<false>(ray, lambda, sensor, sampler, count, splats)
        }
    }
}
