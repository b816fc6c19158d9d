//! The cheap pass: what a camera would show of the scene, from a coarse grid of rays traced against the
//! scene's BVH before any rendering. Two defaults read it (`docs/defaults.md`): the default camera
//! (which of the candidate views shows most front-facing, lit surface) and the lights (whether a file lit
//! only by its emitters lights what the camera sees to a readable level).
//!
//! A view is a [`GRID`] of rays through pixel centres. Each ray is a miss (nothing), a back face (a
//! triangle seen against its winding, unless its glTF material is double-sided: the inside of a closed
//! object, the outside of a room's walls) or a front face; with lights or emitters in the file, a front
//! face also asks whether it is lit: one shadow ray towards each of the file's lights (up to
//! [`MAX_LIGHTS`]) and one towards a point on the emitters.

use geometry::{Camera, CameraDesc, Hit, LightDesc, Projection, Scene};
use glam::Vec3;
use materials::Material;

use crate::sampling::{Rng, uniform_triangle};

/// Rays per view: a 32 × 24 grid of pixel centres (768 rays, the 4:3 default image at 1/20 of its
/// side). Enough to tell a view of walls from a view into a room (a wall is hundreds of rays), cheap
/// enough for a few dozen views on a million triangles (measured in `docs/defaults.md`).
pub(crate) const GRID: (u32, u32) = (32, 24);

/// Emitter samples per visible point for the emitters' illuminance there ([`Survey::emitter_light`]):
/// eight shadow rays, whose mean is noisy per point (a point in half shadow may miss every unoccluded
/// part) but whose median over hundreds of points is stable.
const EMITTER_SAMPLES: u32 = 8;

/// The file's lights that get a shadow ray per visible point (the first ones); more would cost without
/// changing which surfaces count as lit.
const MAX_LIGHTS: usize = 8;

/// Weight of a front face that no light reaches, against 1 for a fully lit one, when the file has lights
/// or emitters: an unlit surface still shows the object (the default environment or the file's other
/// lights reach it), but a view of lit surfaces shows what the file's lights are for.
const UNLIT_WEIGHT: f32 = 0.25;

/// A back face's weight in a view's score: −1, so a view that sees as much back as front scores 0, as a
/// view of nothing does, and one of back faces only −1.
const BACK_WEIGHT: f32 = -1.0;

/// A light the survey casts shadow rays to.
#[derive(Debug, Clone, Copy)]
enum SurveyLight {
    /// A point or spot light: lit where its position is unoccluded above the surface (and inside the
    /// spot's outer cone).
    At { position: Vec3, spot: Option<(Vec3, f32)> },
    /// A directional light: lit where nothing lies towards `towards`.
    Towards(Vec3),
}

/// An emissive primitive: a world-space triangle (mesh, triangle) or a sphere, its material's emission
/// luminance, and whether it emits from both faces.
#[derive(Debug, Clone, Copy)]
enum EmitterShape {
    Triangle { mesh: u32, triangle: u32 },
    Sphere { index: u32 },
}

/// What a view showed, of the rays through the framed box. The score is the quality of what it sees, not
/// how much: every candidate frames the same box, and how much of the frame an object fills depends on its
/// shape's outline from that side (a helmet on a square base fills the view from below), not on what the
/// file is about.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct ViewScore {
    /// Mean per ray that meets a surface: a front face its weight (1, or [`UNLIT_WEIGHT`] to 1 by how lit
    /// it is), a back face [`BACK_WEIGHT`]. In [−1, 1]; 0 for a view of nothing.
    pub(crate) score: f32,
    /// Rays through the framed box.
    pub(crate) rays: u32,
    /// Rays that met a front face (or a double-sided material's back).
    pub(crate) front: u32,
    /// Rays that met a back face.
    pub(crate) back: u32,
    /// Back faces within 2 % of the scene's extent from a face of its bounding box: a room's walls seen
    /// from outside.
    pub(crate) back_on_bounds: u32,
}

/// How the emitters alone light what a camera sees ([`Survey::emitter_light`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct EmitterLight {
    /// The fraction of the visible surfaces (emitters left out) that the emitters reach at all.
    pub(crate) lit_fraction: f64,
    /// The median over those lit surfaces of the luminance a white Lambertian surface there would have,
    /// E/π nits (0 when none is lit).
    pub(crate) median_lit_nits: f64,
}

/// The scene as the cheap pass sees it: the BVH, which materials are double-sided or emit, the file's
/// lights and the emitters' primitives weighted by power.
pub(crate) struct Survey<'a> {
    geometry: &'a Scene,
    /// Per material: glTF `doubleSided` (both faces are meant to be seen).
    double_sided: Vec<bool>,
    /// Per material: whether it emits.
    emits: Vec<bool>,
    lights: Vec<SurveyLight>,
    emitters: Vec<(EmitterShape, bool)>,
    /// Cumulative power (luminance × area) of `emitters`, for choosing one by power.
    emitter_cdf: Vec<f64>,
    /// The box the views frame, for [`ViewScore::rays`] and [`ViewScore::back_on_bounds`].
    bounds: (Vec3, Vec3),
}

impl<'a> Survey<'a> {
    /// The survey of `geometry` with its `materials` (`double_sided`: glTF's `doubleSided` per material)
    /// and the file's `lights` (environments are left out: they light every surface alike); views frame
    /// the box `framed` (the bounds without ground planes).
    pub(crate) fn new(
        geometry: &'a Scene,
        materials: &[Material],
        double_sided: Vec<bool>,
        lights: &[LightDesc],
        framed: (Vec3, Vec3),
    ) -> Self {
        let lights = lights
            .iter()
            .filter_map(|l| match l {
                LightDesc::Point { position, .. } | LightDesc::Luminaire { position, .. } => {
                    Some(SurveyLight::At { position: *position, spot: None })
                }
                LightDesc::Spot { position, direction, outer_cone_deg, .. } => Some(SurveyLight::At {
                    position: *position,
                    spot: Some((direction.normalize_or(Vec3::NEG_Y), outer_cone_deg.to_radians().cos())),
                }),
                LightDesc::Directional { direction, .. } => {
                    Some(SurveyLight::Towards(-direction.normalize_or(Vec3::NEG_Y)))
                }
                LightDesc::Environment { .. } => None,
            })
            .take(MAX_LIGHTS)
            .collect();
        let luminance: Vec<Option<(f64, bool)>> = materials
            .iter()
            .map(|m| {
                let e = m.emission.as_ref().filter(|_| m.emits())?;
                let y = colorimetry::relative_luminance(e);
                (y > 0.0 && y.is_finite()).then_some((y, m.two_sided))
            })
            .collect();
        let emits = luminance.iter().map(Option::is_some).collect();
        let (mut emitters, mut emitter_cdf, mut total) = (Vec::new(), Vec::new(), 0.0f64);
        let mut add = |shape, material: Option<u32>, area: f64| {
            let Some(Some((y, two_sided))) = material.and_then(|m| luminance.get(m as usize)) else { return };
            let power = y * area;
            if power > 0.0 && power.is_finite() {
                total += power;
                emitters.push((shape, *two_sided));
                emitter_cdf.push(total);
            }
        };
        for (index, s) in geometry.spheres().iter().enumerate() {
            let area = 4.0 * std::f64::consts::PI * f64::from(s.radius()).powi(2);
            add(EmitterShape::Sphere { index: index as u32 }, s.material(), area);
        }
        for (mesh_index, mesh) in geometry.meshes().iter().enumerate() {
            if !mesh.material().is_some_and(|m| luminance.get(m as usize).is_some_and(Option::is_some)) {
                continue;
            }
            for (triangle, [a, b, c]) in mesh.indices().iter().enumerate() {
                let p = mesh.positions();
                let [a, b, c] = [*a, *b, *c].map(|i| p[i as usize].as_dvec3());
                let area = 0.5 * (b - a).cross(c - a).length();
                add(
                    EmitterShape::Triangle { mesh: mesh_index as u32, triangle: triangle as u32 },
                    mesh.material(),
                    area,
                );
            }
        }
        Self { geometry, double_sided, emits, lights, emitters, emitter_cdf, bounds: framed }
    }

    /// Whether the file has lights or emitters of its own (then views are weighed by what they light).
    pub(crate) fn has_lights(&self) -> bool {
        !self.lights.is_empty() || !self.emitters.is_empty()
    }

    /// Whether the scene has emissive primitives (placed instances' emitters are not counted).
    pub(crate) fn has_emitters(&self) -> bool {
        !self.emitters.is_empty()
    }

    /// The grid of rays `camera` sees at image aspect `aspect`; `None` for a camera that cannot be built.
    fn rays(camera: &CameraDesc, aspect: f32) -> Option<impl Iterator<Item = (u64, geometry::Ray)>> {
        let camera = match camera.projection {
            Projection::Perspective => {
                Camera::look_at(camera.position, camera.look_at, camera.up, camera.vfov_deg, aspect)
            }
            Projection::Orthographic { ymag, .. } => {
                Camera::orthographic(camera.position, camera.look_at, camera.up, ymag, aspect)
            }
        }
        .ok()?;
        let (w, h) = GRID;
        Some((0..w * h).map(move |i| {
            let (x, y) = (i % w, i / w);
            (u64::from(i), camera.generate_ray(x as f32 + 0.5, y as f32 + 0.5, w, h))
        }))
    }

    /// Whether a hit on material `material` is seen from its front (`facing`: against its geometric normal)
    /// or on a double-sided material; and the normal on the side the ray came from.
    fn seen_front(&self, hit: &Hit, dir: Vec3) -> (bool, Vec3) {
        let facing = hit.n.dot(dir) < 0.0;
        let double_sided = hit.material.and_then(|m| self.double_sided.get(m as usize)).copied().unwrap_or(false);
        (facing || double_sided, if facing { hit.n } else { -hit.n })
    }

    /// The score of the view `camera` (image aspect `aspect`); a camera that cannot be built scores as a
    /// view of nothing.
    pub(crate) fn score(&self, camera: &CameraDesc, aspect: f32) -> ViewScore {
        let Some(rays) = Self::rays(camera, aspect) else { return ViewScore::default() };
        let (lo, hi) = self.bounds;
        let margin = 0.02 * (hi - lo).max_element();
        let on_bounds = |p: Vec3| ((p - lo).abs().min_element().min((hi - p).abs().min_element())) <= margin;
        let mut out = ViewScore::default();
        let mut sum = 0.0f64;
        for (index, ray) in rays {
            if !crosses_box(&ray, lo, hi) {
                continue;
            }
            out.rays += 1;
            let Some(hit) = self.geometry.intersect(&ray, f32::INFINITY) else { continue };
            let (front, n) = self.seen_front(&hit, ray.dir);
            if !front {
                out.back += 1;
                out.back_on_bounds += u32::from(on_bounds(hit.p));
                sum += f64::from(BACK_WEIGHT);
                continue;
            }
            out.front += 1;
            let emitter = hit.material.and_then(|m| self.emits.get(m as usize)).copied().unwrap_or(false);
            let weight = if self.has_lights() && !emitter {
                let mut rng = Rng::new(0x5EED, index, 0);
                UNLIT_WEIGHT + (1.0 - UNLIT_WEIGHT) * self.lit_fraction(&hit, n, &mut rng)
            } else {
                1.0
            };
            sum += f64::from(weight);
        }
        let hits = out.front + out.back;
        out.score = if hits > 0 { (sum / f64::from(hits)) as f32 } else { 0.0 };
        out
    }

    /// The fraction of the file's lights (each light one test, the emitters together one) that reach the
    /// hit point from the side `n` faces.
    fn lit_fraction(&self, hit: &Hit, n: Vec3, rng: &mut Rng) -> f32 {
        let (mut tests, mut lit) = (0u32, 0u32);
        for light in &self.lights {
            tests += 1;
            let reaches = match *light {
                SurveyLight::At { position, spot } => {
                    let w = position - hit.p;
                    let inside_cone =
                        spot.is_none_or(|(axis, cos_outer)| (-w).normalize_or_zero().dot(axis) >= cos_outer);
                    inside_cone && w.dot(n) > 0.0 && {
                        let (ray, t_max) = geometry::spawn_ray_to(hit, position);
                        !self.geometry.occluded(&ray, t_max)
                    }
                }
                SurveyLight::Towards(w) => {
                    w.dot(n) > 0.0 && !self.geometry.occluded(&geometry::spawn_ray(hit, w), f32::INFINITY)
                }
            };
            lit += u32::from(reaches);
        }
        if !self.emitters.is_empty() {
            tests += 1;
            lit += u32::from(self.emitter_sample(hit, n, rng).is_some_and(|g| g > 0.0));
        }
        if tests == 0 { 1.0 } else { lit as f32 / tests as f32 }
    }

    /// One sample of the emitters' light at `hit` (normal `n` on the viewer's side): a point chosen by
    /// power, then uniformly on its primitive; returns cos θ_s cos θ_e / d² where it is unoccluded (0
    /// elsewhere), the geometry term whose mean times the emitters' total power is the illuminance.
    /// `None` without emitters.
    fn emitter_sample(&self, hit: &Hit, n: Vec3, rng: &mut Rng) -> Option<f64> {
        let total = *self.emitter_cdf.last()?;
        let u = f64::from(rng.uniform()) * total;
        let chosen = self.emitter_cdf.partition_point(|&c| c <= u).min(self.emitters.len() - 1);
        let (shape, two_sided) = self.emitters[chosen];
        let (q, nq) = match shape {
            EmitterShape::Triangle { mesh, triangle } => {
                let mesh = &self.geometry.meshes()[mesh as usize];
                let [a, b, c] = mesh.indices()[triangle as usize].map(|i| mesh.positions()[i as usize]);
                let (b0, b1) = uniform_triangle(rng.uniform2());
                (b0 * a + b1 * b + (1.0 - b0 - b1) * c, (b - a).cross(c - a).normalize_or_zero())
            }
            EmitterShape::Sphere { index } => {
                let s = &self.geometry.spheres()[index as usize];
                let d = materials::sampling::uniform_sphere(rng.uniform2());
                (s.center() + s.radius() * d, d)
            }
        };
        let w = q - hit.p;
        let d2 = f64::from(w.length_squared());
        let wn = w.normalize_or_zero();
        let cos_s = f64::from(n.dot(wn));
        let cos_e = if two_sided { f64::from(nq.dot(wn).abs()) } else { f64::from(-nq.dot(wn)) };
        if !(cos_s > 0.0 && cos_e > 0.0 && d2 > 0.0) {
            return Some(0.0);
        }
        let (ray, t_max) = geometry::spawn_ray_to(hit, q);
        Some(if self.geometry.occluded(&ray, t_max) { 0.0 } else { cos_s * cos_e / d2 })
    }

    /// How the emitters alone light the surfaces `camera` sees (emitters left out): which fraction they
    /// reach, and the median over those of the luminance they give a white Lambertian surface, E/π nits, E
    /// estimated with [`EMITTER_SAMPLES`] shadow rays per point. `None` when the view meets nothing or the
    /// scene has no emitters.
    pub(crate) fn emitter_light(&self, camera: &CameraDesc, aspect: f32) -> Option<EmitterLight> {
        let total = *self.emitter_cdf.last()?;
        let mut values = Vec::new();
        for (index, ray) in Self::rays(camera, aspect)? {
            let Some(hit) = self.geometry.intersect(&ray, f32::INFINITY) else { continue };
            if hit.material.and_then(|m| self.emits.get(m as usize)).copied().unwrap_or(false) {
                continue;
            }
            // Whichever face the camera sees is lit from its own side (both are shaded).
            let n = if hit.n.dot(ray.dir) < 0.0 { hit.n } else { -hit.n };
            let mut rng = Rng::new(0x11_6874, index, 0);
            let g: f64 = (0..EMITTER_SAMPLES).filter_map(|_| self.emitter_sample(&hit, n, &mut rng)).sum();
            values.push(total * g / f64::from(EMITTER_SAMPLES) / std::f64::consts::PI);
        }
        if values.is_empty() {
            return None;
        }
        let visible = values.len();
        values.retain(|&v| v > 0.0);
        values.sort_by(f64::total_cmp);
        Some(EmitterLight {
            lit_fraction: values.len() as f64 / visible as f64,
            median_lit_nits: values.get(values.len() / 2).copied().unwrap_or(0.0),
        })
    }
}

/// Whether `ray` passes through the box `lo`–`hi` ahead of its origin (slab test; a ray starting inside
/// does).
fn crosses_box(ray: &geometry::Ray, lo: Vec3, hi: Vec3) -> bool {
    let inv = ray.dir.recip();
    let (a, b) = ((lo - ray.origin) * inv, (hi - ray.origin) * inv);
    // NaN (0 · ∞ for a ray in a slab's plane) is dropped by min/max in favour of the other bound.
    let near = a.min(b).max_element().max(0.0);
    let far = a.max(b).min_element();
    near <= far
}

/// A direction uniformly distributed on the unit sphere.
#[cfg(test)]
mod tests {
    use geometry::{Mesh, SpectrumDesc};

    use super::*;

    /// A square of side `side` at height `y`, centred on the y axis, wound to face `up` or down.
    fn square(side: f32, y: f32, up: bool, material: u32) -> Mesh {
        let h = 0.5 * side;
        let p = vec![Vec3::new(-h, y, -h), Vec3::new(h, y, -h), Vec3::new(h, y, h), Vec3::new(-h, y, h)];
        // Counter-clockwise seen from above faces up.
        let t = if up { vec![[0, 2, 1], [0, 3, 2]] } else { vec![[0, 1, 2], [0, 2, 3]] };
        Mesh::new(p, None, None, t, Some(material)).unwrap()
    }

    fn looking_down(from: Vec3) -> CameraDesc {
        CameraDesc {
            position: from,
            look_at: Vec3::new(from.x, 0.0, from.z),
            up: Vec3::Z,
            vfov_deg: 1.0,
            projection: Projection::Perspective,
            aspect_ratio: None,
            width: None,
            height: None,
        }
    }

    /// A lamp of luminance 1 and side 0.2 m facing down from 2 m over a floor: E = L A / h² = 0.01 lux below
    /// it (the square's own cosines and distances change that by 0.5 %), so a white floor reads 0.01/π.
    #[test]
    fn the_emitters_light_is_their_illuminance_over_pi() {
        let geometry = Scene::build(Vec::new(), vec![square(20.0, 0.0, true, 0), square(0.2, 2.0, false, 1)]).unwrap();
        let floor = Material::diffuse("floor", colorimetry::DenselySampledSpectrum::constant(0.5));
        let mut lamp = Material::diffuse("lamp", colorimetry::DenselySampledSpectrum::constant(0.0));
        lamp.emission = Some(crate::material_desc::emission_spectrum(&SpectrumDesc::Named("D65".into()), 1.0).unwrap());
        lamp.two_sided = false;
        let materials = [floor, lamp];
        let survey = Survey::new(&geometry, &materials, vec![false; 2], &[], geometry.bounds());
        assert!(survey.has_emitters() && survey.has_lights());
        let light = survey.emitter_light(&looking_down(Vec3::new(0.0, 1.0, 0.0)), 4.0 / 3.0).unwrap();
        let expected = 0.01 / std::f64::consts::PI;
        assert_eq!(light.lit_fraction, 1.0);
        assert!((light.median_lit_nits / expected - 1.0).abs() < 0.01, "{light:?}, expected {expected}");
        // Turned to face up, the one-sided lamp lights the ceiling it faces, not the floor.
        let geometry = Scene::build(Vec::new(), vec![square(20.0, 0.0, true, 0), square(0.2, 2.0, true, 1)]).unwrap();
        let survey = Survey::new(&geometry, &materials, vec![false; 2], &[], geometry.bounds());
        let light = survey.emitter_light(&looking_down(Vec3::new(0.0, 1.0, 0.0)), 4.0 / 3.0).unwrap();
        assert_eq!((light.lit_fraction, light.median_lit_nits), (0.0, 0.0));
    }

    /// A view of front faces scores 1, of back faces −1; a point light on the other side leaves them unlit
    /// ([`UNLIT_WEIGHT`]).
    #[test]
    fn views_score_front_faces_back_faces_and_light() {
        let grey = [Material::diffuse("grey", colorimetry::DenselySampledSpectrum::constant(0.5))];
        let up = Scene::build(Vec::new(), vec![square(2.0, 0.0, true, 0)]).unwrap();
        let down = Scene::build(Vec::new(), vec![square(2.0, 0.0, false, 0)]).unwrap();
        let camera = looking_down(Vec3::new(0.0, 5.0, 0.0));
        let score = |geometry: &Scene, double_sided: bool, lights: &[LightDesc]| {
            Survey::new(geometry, &grey, vec![double_sided], lights, geometry.bounds()).score(&camera, 4.0 / 3.0)
        };
        let front = score(&up, false, &[]);
        assert_eq!((front.score, front.front, front.back), (1.0, 768, 0));
        let back = score(&down, false, &[]);
        assert_eq!((back.score, back.front, back.back), (-1.0, 0, 768));
        assert_eq!(back.back_on_bounds, 768);
        // glTF doubleSided: both faces are meant to be seen.
        assert_eq!(score(&down, true, &[]).score, 1.0);
        let lamp = |y: f32| LightDesc::Point {
            position: Vec3::new(0.0, y, 0.0),
            spectrum: SpectrumDesc::Named("D65".into()),
            intensity: geometry::LightAmount { value: 1.0, unit: geometry::LightUnit::Candela },
        };
        assert_eq!(score(&up, false, &[lamp(1.0)]).score, 1.0);
        assert_eq!(score(&up, false, &[lamp(-1.0)]).score, UNLIT_WEIGHT);
    }
}
