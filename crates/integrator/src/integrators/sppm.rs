//! Stochastic progressive photon mapping ("sppm", Hachisuka & Jensen 2009; the structure of pbrt-v4's
//! `SPPMIntegrator`): the light paths no bidirectional connection can make. A caustic seen through glass or
//! in a mirror (light → glass → diffuse → glass → camera) has a delta vertex at both ends of its diffuse
//! vertex, so neither side can be joined to the other by a shadow ray; photon mapping joins them by
//! proximity instead, with a radius that shrinks so that the estimate converges (it is consistent, not
//! unbiased).
//!
//! Each iteration k:
//! 1. **Camera pass.** Every pixel traces one camera path through delta vertices (smooth glass, mirrors)
//!    to the first surface with a non-delta lobe: its *visible point*. Light the path meets on the way
//!    (an area light, the environment) and a light sampled at the visible point (next-event estimation)
//!    count in full and go to the film as the pixel's sample k.
//! 2. **Photon pass.** `photons` light paths leave the lights (chosen ∝ power, `LightKind::sample_le`).
//!    At each of their vertices after the first bounce on a surface with a non-delta lobe (direct light
//!    is the camera pass's), every visible point within its radius r gathers the photon's flux Φ through
//!    its BSDF: β_vp · f(wo, wi) · Φ.
//! 3. **Radius update** (Hachisuka & Jensen's with α = 2/3, per pixel): with M photons gathered this
//!    iteration and N before, N′ = N + αM, r′ = r √(N′ / (N + M)), τ′ = (τ + Φ_k) r′² / r².
//!
//! The image is the camera pass's mean plus τ / (K · photons · π r²) after K iterations: the film holds the
//! camera passes as samples and the photon term as splat sums (which it divides by the K samples per pixel).
//! r shrinks as K^(−1/6) and the variance of the density estimate grows only as slowly, so both the bias and
//! the noise go to 0 (Hachisuka & Jensen 2009, §4).
//!
//! **First radius.** By default two pixel footprints at the visible point: the distance along the camera
//! path times the side of a pixel at distance 1, so the blur starts at about the image's own resolution at
//! every depth; `--radius` sets it in scene units instead, as pbrt-v4's `radius`.
//!
//! **Spectral.** One set of wavelengths per iteration, shared by the camera and photon passes (pbrt-v4's
//! SPPM does the same), stratified over the iterations. A dispersive interface on either side keeps the
//! hero wavelength only (the path tracer's rule); a gathered photon counts at the hero alone when either
//! its path or the visible point's did.
//!
//! **Determinism.** A pixel's camera path draws from (seed, pixel, k), photon j of iteration k from its own
//! stream (seed, j, k); photons are traced in fixed chunks whose gathers are added in chunk order, so an
//! image is the same bits at any thread count.
//!
//! **Which photons a point takes.** Those within its radius on a surface of the same material facing the
//! same way (see `same_surface`): distance alone lets light trapped behind a thin surface leak through.
//!
//! **Left out** (as pbrt-v4's): a visible point on a surface with both a delta and a non-delta lobe keeps
//! the non-delta part only; glossy surfaces are gathered on like diffuse ones (blurred by r, not followed
//! further). Renders are not split into sample ranges or resumed: the radius couples the iterations.

use std::sync::atomic::{AtomicBool, Ordering};

use colorimetry::{SampledSpectrum, SampledWavelengths};
use geometry::Camera;
use glam::Vec3;
use materials::bsdf::{Bsdf, Frame};
use rayon::prelude::*;

use crate::error::{Error, Result};
use crate::film::splat::{SPLAT_BATCH, SplatValue};
use crate::film::{Film, ObjectId, Sensor};
use crate::integrators::bdpt::{Bdpt, Vertex};
use crate::integrators::kernel::RayCount;
use crate::integrators::path::{LastSpectrum, PathTracer};
use crate::sampling::{Rng, Sampler};

/// The radius schedule's α (Hachisuka & Jensen 2009): the share of this iteration's photons a pixel keeps.
const ALPHA: f64 = 2.0 / 3.0;
/// The first radius in pixel footprints at the visible point (without `--radius`).
const FOOTPRINTS: f32 = 2.0;
/// Photons per parallel task: fixed, so the order their gathers are added in does not depend on threads.
const PHOTON_CHUNK: u64 = 1024;
/// Streams of photon j: far from every pixel's (pixel indices stay below 2³²).
const PHOTON_STREAMS: u64 = 1 << 48;
/// The stream of the iterations' wavelengths.
const WAVELENGTH_STREAM: u64 = (1 << 48) - 1;

/// A pixel's visible point of one iteration.
struct VisiblePoint<const N: usize> {
    pixel: u32,
    p: Vec3,
    wo: Vec3,
    bsdf: Bsdf<N>,
    frame: Frame,
    beta: SampledSpectrum<N>,
    /// Whether the camera path kept the hero wavelength only.
    hero_only: bool,
    lane: Option<usize>,
    /// The camera path's length to it (for the first radius).
    distance: f32,
    /// Its geometric normal, on the side the camera path arrived from, and its material.
    n: Vec3,
    material: Option<u32>,
}

/// What each pixel carries across iterations.
#[derive(Clone)]
struct PixelState<const N: usize> {
    /// The gather radius squared (0 before the pixel's first visible point).
    r2: f64,
    /// Photons kept (Hachisuka & Jensen's N).
    n: f64,
    /// The flux gathered, scaled to the current radius: XYZ and lane values.
    tau: [f64; 3],
    tau_values: [f64; N],
}

/// One photon's gather at one visible point, converted to XYZ and lane values.
struct Gather<const N: usize> {
    point: u32,
    xyz: [f32; 3],
    values: [f32; N],
}

/// The visible points of an iteration in a hashed grid of cells as wide as the largest radius.
struct Grid {
    lo: Vec3,
    cell: f32,
    /// `entries[starts[h]..starts[h + 1]]` are the points whose sphere overlaps a cell hashing to h.
    starts: Vec<u32>,
    entries: Vec<u32>,
}

impl Grid {
    fn new<const N: usize>(points: &[VisiblePoint<N>], radius: &[f32]) -> Option<Self> {
        let largest = radius.iter().copied().fold(0.0f32, f32::max);
        if points.is_empty() || !(largest > 0.0) {
            return None;
        }
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for (v, &r) in points.iter().zip(radius) {
            lo = lo.min(v.p - r);
            hi = hi.max(v.p + r);
        }
        // Cells as wide as the largest radius, but no more than 2²⁰ along the grid's longest side, so cell
        // coordinates stay small integers for any scene.
        let cell = largest.max((hi - lo).max_element() / (1 << 20) as f32);
        let table = (points.len() * 2).next_power_of_two();
        let mut keyed: Vec<u64> = points
            .par_iter()
            .zip(radius)
            .enumerate()
            .flat_map_iter(|(i, (v, &r))| {
                let a = ((v.p - r - lo) / cell).floor().as_ivec3();
                let b = ((v.p + r - lo) / cell).floor().as_ivec3();
                (a.z..=b.z).flat_map(move |z| {
                    (a.y..=b.y)
                        .flat_map(move |y| (a.x..=b.x).map(move |x| (u64::from(hash(x, y, z, table)) << 32) | i as u64))
                })
            })
            .collect();
        keyed.par_sort_unstable();
        let mut starts = vec![0u32; table + 1];
        for &k in &keyed {
            starts[(k >> 32) as usize + 1] += 1;
        }
        for h in 0..table {
            starts[h + 1] += starts[h];
        }
        let entries = keyed.iter().map(|&k| k as u32).collect();
        Some(Self { lo, cell, starts, entries })
    }

    /// The points whose cells hash as `p`'s.
    fn near(&self, p: Vec3) -> &[u32] {
        let c = ((p - self.lo) / self.cell).floor();
        if !c.is_finite() || c.min_element() < 0.0 || c.max_element() > (1 << 21) as f32 {
            return &[];
        }
        let c = c.as_ivec3();
        let table = self.starts.len() - 1;
        let h = hash(c.x, c.y, c.z, table) as usize;
        &self.entries[self.starts[h] as usize..self.starts[h + 1] as usize]
    }
}

/// pbrt-v4's grid hash (Teschner et al. 2003) into a table of `size` (a power of two) cells.
fn hash(x: i32, y: i32, z: i32, size: usize) -> u32 {
    let h =
        (x as u32).wrapping_mul(73_856_093) ^ (y as u32).wrapping_mul(19_349_663) ^ (z as u32).wrapping_mul(83_492_791);
    h & (size as u32 - 1)
}

/// Photon mapping over the bidirectional walks ([`Bdpt::for_photon_mapping`]).
pub(crate) struct PhotonMapping<'a, const N: usize> {
    walks: Bdpt<'a, N>,
    camera: Camera,
    width: u32,
    height: u32,
    seed: u64,
    photons: u64,
    radius: Option<f32>,
}

impl<'a, const N: usize> PhotonMapping<'a, N> {
    /// `photons` per iteration (at least 1), the first radius in scene units or `None` for
    /// [`FOOTPRINTS`] pixel footprints.
    pub(crate) fn new(
        tracer: PathTracer<'a, N>,
        camera: Camera,
        width: u32,
        height: u32,
        seed: u64,
        photons: u64,
        radius: Option<f32>,
    ) -> Self {
        let walks = Bdpt::for_photon_mapping(tracer, camera, width, height);
        Self { walks, camera, width, height, seed, photons: photons.max(1), radius }
    }

    /// Render `iterations` iterations into `film` (a fresh film with splat sums): the camera passes as
    /// its samples, the photon term as its splats. `progress` hears of each iteration done; once
    /// `out_of_time`, the iterations stop.
    pub(crate) fn render(
        &self,
        film: &mut Film,
        sensor: &Sensor<N>,
        iterations: u32,
        cancel: &AtomicBool,
        out_of_time: &dyn Fn() -> bool,
        progress: &dyn Fn(u32, RayCount),
    ) -> Result<RayCount> {
        let iterate = if self.walks.tracer().rough { Self::iterate::<true> } else { Self::iterate::<false> };
        iterate(self, film, sensor, iterations, cancel, out_of_time, progress)
    }

    fn iterate<const ROUGH: bool>(
        &self,
        film: &mut Film,
        sensor: &Sensor<N>,
        iterations: u32,
        cancel: &AtomicBool,
        out_of_time: &dyn Fn() -> bool,
        progress: &dyn Fn(u32, RayCount),
    ) -> Result<RayCount> {
        let pixels = self.width as usize * self.height as usize;
        let mut state = vec![PixelState::<N> { r2: 0.0, n: 0.0, tau: [0.0; 3], tau_values: [0.0; N] }; pixels];
        let mut total = RayCount::default();
        let mut nonfinite = 0u64;
        // The side of a pixel on the image plane at distance 1.
        let footprint = (self.camera.image_plane_area() / (self.width as f32 * self.height as f32)).sqrt();
        let mut wavelengths = Rng::new(self.seed, WAVELENGTH_STREAM, 0);
        let rotation = wavelengths.uniform();
        for k in 0..iterations {
            if cancel.load(Ordering::Relaxed) {
                return Err(Error::Cancelled);
            }
            // Stratified over the iterations, rotated at random.
            let u = (rotation + (k as f32 + wavelengths.uniform()) / iterations as f32).fract();
            let lambda = sensor.sample_wavelengths(u.min(0.999_999_9));
            let (points, count) = self.camera_pass::<ROUGH>(film, sensor, &lambda, k);
            add(&mut total, count);
            // A pixel's first radius, from its first visible point.
            for v in &points {
                let s = &mut state[v.pixel as usize];
                if s.r2 == 0.0 {
                    let r = self.radius.unwrap_or(FOOTPRINTS * footprint * v.distance);
                    s.r2 = f64::from(r) * f64::from(r);
                }
            }
            if k == 0 {
                film.set_has_first_sample();
            }
            let radius: Vec<f32> = points.iter().map(|v| state[v.pixel as usize].r2.sqrt() as f32).collect();
            let mut flux = vec![([0.0f64; 3], [0.0f64; N], 0u64); points.len()];
            if let Some(grid) = Grid::new(&points, &radius) {
                let chunks = self.photons.div_ceil(PHOTON_CHUNK);
                // Batches of chunks bound the gathers held at once.
                let batch = 64 * rayon::current_num_threads() as u64;
                let mut first = 0;
                while first < chunks {
                    if cancel.load(Ordering::Relaxed) {
                        return Err(Error::Cancelled);
                    }
                    let last = (first + batch).min(chunks);
                    let results: Vec<(Vec<Gather<N>>, RayCount)> = (first..last)
                        .into_par_iter()
                        .map(|c| self.photon_chunk::<ROUGH>(c, k, &grid, &points, &radius, sensor, &lambda))
                        .collect();
                    for (gathers, count) in results {
                        add(&mut total, count);
                        for g in gathers {
                            // A non-finite gather would stay in τ for good: counted and dropped.
                            if !(g.xyz.iter().chain(&g.values).all(|v| v.is_finite())) {
                                nonfinite += 1;
                                continue;
                            }
                            let f = &mut flux[g.point as usize];
                            for (s, v) in f.0.iter_mut().zip(g.xyz) {
                                *s += f64::from(v);
                            }
                            for (s, v) in f.1.iter_mut().zip(g.values) {
                                *s += f64::from(v);
                            }
                            f.2 += 1;
                        }
                    }
                    first = last;
                }
            }
            // The radius update, per pixel.
            for (v, (xyz, values, m)) in points.iter().zip(flux) {
                let s = &mut state[v.pixel as usize];
                if m == 0 {
                    continue;
                }
                let m = m as f64;
                let n = s.n + ALPHA * m;
                let shrink = n / (s.n + m);
                for (t, x) in s.tau.iter_mut().zip(xyz) {
                    *t = (*t + x) * shrink;
                }
                for (t, x) in s.tau_values.iter_mut().zip(values) {
                    *t = (*t + x) * shrink;
                }
                s.n = n;
                s.r2 *= shrink;
            }
            progress(k + 1, total);
            if out_of_time() {
                break;
            }
        }
        // The photon term as splat sums: τ / (photons · π r²), which the film divides by its K samples.
        let (rows, target) = film.pass_mut();
        drop(rows);
        let mut batch: Vec<SplatValue<N>> = Vec::with_capacity(SPLAT_BATCH);
        for (pixel, s) in state.iter().enumerate() {
            if s.n == 0.0 || s.r2 <= 0.0 {
                continue;
            }
            let scale = 1.0 / (self.photons as f64 * std::f64::consts::PI * s.r2);
            batch.push(SplatValue {
                pixel,
                second: false,
                xyz: s.tau.map(|t| (t * scale) as f32),
                values: s.tau_values.map(|t| (t * scale) as f32),
            });
            if batch.len() >= SPLAT_BATCH {
                target.add(&mut batch);
            }
        }
        target.add(&mut batch);
        let (splat_nonfinite, clamped) = target.finish();
        film.add_counts(nonfinite + splat_nonfinite, clamped);
        Ok(total)
    }

    /// Every pixel's camera path of iteration `k`: its light to the film as sample k, its visible point.
    fn camera_pass<const ROUGH: bool>(
        &self,
        film: &mut Film,
        sensor: &Sensor<N>,
        lambda: &SampledWavelengths<N>,
        k: u32,
    ) -> (Vec<VisiblePoint<N>>, RayCount) {
        let (width, height) = (self.width, self.height);
        let (rows, _splats) = film.pass_mut();
        let rows: Vec<(Vec<VisiblePoint<N>>, RayCount, u64, u64)> = rows
            .enumerate()
            .map(|(y, mut row)| {
                let mut count = RayCount::default();
                let mut points = Vec::new();
                let mut path = Vec::with_capacity(8);
                for x in 0..width as usize {
                    let pixel = y as u64 * u64::from(width) + x as u64;
                    let mut sampler = Sampler::Independent(Rng::new(self.seed, pixel, u64::from(k)));
                    let jitter = sampler.uniform2();
                    let ray = self.camera.generate_ray(x as f32 + jitter.x, y as f32 + jitter.y, width, height);
                    let mut lambda = *lambda;
                    let mut lane = None;
                    self.walks.camera_subpath::<ROUGH>(
                        &ray,
                        &mut path,
                        &mut lambda,
                        sensor,
                        &mut lane,
                        &mut sampler,
                        &mut count,
                    );
                    // Light met through delta vertices (an area light, the environment the path escaped
                    // to), then a light sampled at the visible point.
                    let mut l = SampledSpectrum([0.0; N]);
                    let mut last = LastSpectrum(None);
                    for t in 2..=path.len() {
                        l += self.walks.hit_light(&path, t, &lambda, &mut last);
                    }
                    let t = path.len();
                    let vp = path.last().filter(|v| t >= 2 && v.connectible() && v.bsdf.is_some());
                    if vp.is_some() {
                        l += self.walks.light_sample(&path, t, &lambda, &mut last, &mut sampler, &mut count);
                    }
                    if k == 0 {
                        let first = path.get(1).map_or(ObjectId::Background, |v| ObjectId::Material(v.material));
                        row.set_first_hit(x, first);
                    }
                    let (xyz, values) = sensor.to_xyz(&l, &lambda, lane);
                    row.add_sample(x, k, xyz, &values);
                    let Some(v) = vp else { continue };
                    let (Some(bsdf), Some(wo)) = (v.bsdf, (path[t - 2].p - v.p).try_normalize()) else { continue };
                    if v.beta.is_black() {
                        continue;
                    }
                    let distance = path.windows(2).map(|w| (w[1].p - w[0].p).length()).sum();
                    points.push(VisiblePoint {
                        pixel: pixel as u32,
                        p: v.p,
                        wo,
                        bsdf,
                        frame: v.frame,
                        beta: v.beta,
                        hero_only: lambda.secondary_terminated(),
                        lane,
                        distance,
                        n: if v.frame.n.dot(wo) >= 0.0 { v.frame.n } else { -v.frame.n },
                        material: v.material,
                    });
                }
                (points, count, row.nonfinite, row.clamped)
            })
            .collect();
        let mut points = Vec::new();
        let mut total = RayCount::default();
        let (mut nonfinite, mut clamped) = (0, 0);
        for (p, c, n, cl) in rows {
            points.extend(p);
            add(&mut total, c);
            nonfinite += n;
            clamped += cl;
        }
        film.add_counts(nonfinite, clamped);
        (points, total)
    }
}

impl<const N: usize> PhotonMapping<'_, N> {
    /// Photons `chunk · PHOTON_CHUNK ..` of iteration `k`: their gathers at the visible points in `grid`.
    #[allow(clippy::too_many_arguments)]
    fn photon_chunk<const ROUGH: bool>(
        &self,
        chunk: u64,
        k: u32,
        grid: &Grid,
        points: &[VisiblePoint<N>],
        radius: &[f32],
        sensor: &Sensor<N>,
        lambda: &SampledWavelengths<N>,
    ) -> (Vec<Gather<N>>, RayCount) {
        let mut count = RayCount::default();
        let mut gathers = Vec::new();
        let mut path: Vec<Vertex<N>> = Vec::with_capacity(8);
        let photons = chunk * PHOTON_CHUNK..((chunk + 1) * PHOTON_CHUNK).min(self.photons);
        for j in photons {
            let mut sampler = Sampler::Independent(Rng::new(self.seed, PHOTON_STREAMS + j, u64::from(k)));
            let mut own = *lambda;
            let mut lane = None;
            self.walks.light_subpath::<ROUGH>(&mut path, &mut own, sensor, &mut lane, &mut sampler, &mut count);
            // Vertex 0 is on the light and vertex 1 is lit directly (the camera pass's light sample).
            for i in 2..path.len() {
                let q = &path[i];
                if !q.connectible() || q.beta.is_black() {
                    continue;
                }
                let Some(wi) = (path[i - 1].p - q.p).try_normalize() else { continue };
                // The photon's surface, facing where it came from.
                let n = if q.frame.n.dot(wi) >= 0.0 { q.frame.n } else { -q.frame.n };
                for &index in grid.near(q.p) {
                    let v = &points[index as usize];
                    let r = radius[index as usize];
                    if (v.p - q.p).length_squared() >= r * r || !same_surface(v, n, q.material) {
                        continue;
                    }
                    let lane = match (lane, v.lane) {
                        (Some(a), Some(b)) if a != b => continue,
                        (a, b) => a.or(b),
                    };
                    let phi = v.beta * v.bsdf.f(&v.frame, v.wo, wi) * q.beta;
                    if phi.is_black() {
                        continue;
                    }
                    let mut at = *lambda;
                    if v.hero_only || own.secondary_terminated() {
                        at.terminate_secondary();
                    }
                    let (xyz, values) = sensor.to_xyz(&phi, &at, lane);
                    gathers.push(Gather { point: index, xyz, values });
                }
            }
        }
        (gathers, count)
    }
}

/// Whether a photon on a surface of `material` facing `n` lights a visible point's surface: the same
/// material, facing within 60° of the same way. Distance alone would let a point take photons from another
/// surface within its radius: a lamp 0.01 below a ceiling (the Cornell box's) would gather the light
/// trapped between the two, several times its own radiance. Like the radius's blur, the bias this check
/// leaves at material edges and creases shrinks with the radius.
fn same_surface<const N: usize>(v: &VisiblePoint<N>, n: Vec3, material: Option<u32>) -> bool {
    v.material == material && v.n.dot(n) > 0.5
}

fn add(total: &mut RayCount, count: RayCount) {
    total.rays += count.rays;
    total.shadow += count.shadow;
}
