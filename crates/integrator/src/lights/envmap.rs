//! Image-based environment light: an equirectangular (latitude–longitude) map decoded from a
//! Radiance `.hdr` or OpenEXR `.exr` file, each texel an RGB illuminant spectrum, importance
//! sampled by a piecewise-constant density ∝ luminance × sin θ (PBRT 3rd ed. §14.2.4; pbrt-v4
//! `ImageInfiniteLight`, which uses the equal-area octahedral mapping instead).
//!
//! Orientation (Mitsuba 3's `envmap` convention, +Y up): texture coordinates (u, v) ∈ [0, 1)², u
//! along a row from the left edge, v down the rows from the top, map to the direction
//! φ = 2π u, θ = π v, d = (sin φ sin θ, cos θ, −cos φ sin θ): the top row is +Y (θ = 0), the bottom
//! row −Y, and along the horizon's row the left edge (u = 0) looks towards −Z, u = ¼ towards +X,
//! the centre (u = ½) towards +Z and u = ¾ towards −X. `rotation_deg` turns the map about +Y
//! (counter-clockwise seen from above: +Z turns towards +X). Lookups are nearest-texel, so the
//! radiance is exactly the piecewise-constant function the density is built from; an analytic map
//! (`from_luminance`, the CIE sky) evaluates its radiance per direction and keeps the table for the
//! density only.
//!
//! Texels are linear Rec. 709 / sRGB primaries (the files' usual space); their luminance
//! Y = 0.2126 R + 0.7152 G + 0.0722 B, times the light's `intensity`, is in nits. Each becomes
//! `colorimetry::RgbIlluminantSpectrum` (sigmoid × D65, pbrt-v4 `RGBIlluminantSpectrum`) once, at
//! load, by table lookup: the recipe of every RGB light (`materials::illuminant_from_rgb`, which
//! fits the sigmoid exactly and scales to Rec. 709 Y, once per light), at a few ns per texel. In
//! `rgb` lanes the texel's RGB is used directly.

use std::f32::consts::PI;
use std::fmt;
use std::io::Cursor;
use std::path::{Path, PathBuf};

use colorimetry::{
    DenselySampledSpectrum, RgbIlluminantSpectrum, RgbToSpectrumTable, SampledSpectrum, SampledWavelengths,
};
use glam::{Vec2, Vec3};

use crate::error::{Error, Result};
use crate::sampling::PiecewiseConstant2D;

/// Most texels a map may have: 8192 × 4096 (an "8k" HDRI), about 1 GB once each texel carries its
/// spectrum and density. Larger files are refused before their pixels are decoded.
pub(crate) const MAX_TEXELS: usize = 8192 * 4096;

/// One texel: its RGB (× intensity) and the illuminant spectrum of that RGB.
#[derive(Clone, Copy)]
struct Texel {
    rgb: [f32; 3],
    spectrum: RgbIlluminantSpectrum,
}

/// One texel of a daylight map (the analytic sky, `sky.rs`): the weights of its spectrum
/// w0 S0 + w1 S1 + w2 S2 in the CIE daylight basis, that spectrum's RGB (for `rgb` lanes) and its
/// luminance (nits).
#[derive(Clone, Copy)]
struct DaylightTexel {
    weights: [f32; 3],
    rgb: [f32; 3],
    luminance: f32,
}

/// A luminance (nits) per unit direction of a map's frame.
pub(crate) type LuminanceFn = Box<dyn Fn(Vec3) -> f32 + Send + Sync>;

/// A map's texels: RGB from a file, or daylight spectra; or no texels but one daylight spectrum of 1 nit
/// (`unit`) times a luminance evaluated per direction (the CIE sky, `cie_sky.rs`).
enum Texels {
    Rgb(Vec<Texel>),
    Daylight(Vec<DaylightTexel>),
    Analytic { unit: DaylightTexel, luminance: LuminanceFn },
}

/// The CIE daylight basis S0, S1, S2 on the 1 nm grid of 360–830 nm, each with its relative luminance and
/// RGB (`spectral::spectrum_to_rgb`, linear in the spectrum, so a texel's are the weighted sums).
struct DaylightBasis {
    spectra: [DenselySampledSpectrum; 3],
    luminance: [f64; 3],
    rgb: [[f32; 3]; 3],
}

static DAYLIGHT_BASIS: std::sync::LazyLock<DaylightBasis> = std::sync::LazyLock::new(|| {
    let spectra = colorimetry::daylight_basis().clone().map(|s| {
        let values = (360..=830).map(|l| s.eval(f64::from(l))).collect();
        DenselySampledSpectrum::new(360.0, 1.0, values).expect("the CIE daylight basis is finite")
    });
    let luminance = [0, 1, 2].map(|i| colorimetry::relative_luminance(&spectra[i]));
    let rgb = [0, 1, 2].map(|i| crate::spectral::spectrum_to_rgb(&spectra[i], crate::spectral::SpectrumKind::Emission));
    DaylightBasis { spectra, luminance, rgb }
});

/// Relative luminances of the daylight basis S0, S1, S2 (what the sky's weights are scaled by).
pub(crate) fn daylight_basis_luminance() -> [f64; 3] {
    DAYLIGHT_BASIS.luminance
}

/// An equirectangular environment map, ready to evaluate and sample (see the module docs).
pub(crate) struct EnvironmentMap {
    path: PathBuf,
    width: usize,
    height: usize,
    texels: Texels,
    distribution: PiecewiseConstant2D,
    /// sin and cos of the rotation about +Y.
    rotation: (f32, f32),
    /// Mean RGB over the sphere (each texel weighted by its solid angle), × intensity.
    mean_rgb: [f64; 3],
    /// For a daylight map, the mean of its texels' weights (solid-angle weighted).
    mean_daylight: Option<[f64; 3]>,
    /// XXH64 of the file's bytes (0 for a map built in memory).
    digest: u64,
}

impl fmt::Debug for EnvironmentMap {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("EnvironmentMap")
            .field("path", &self.path)
            .field("size", &(self.width, self.height))
            .field("mean_rgb", &self.mean_rgb)
            .finish_non_exhaustive()
    }
}

/// Rec. 709 luminance of linear sRGB (IEC 61966-2-1; `materials::REC709_LUMINANCE`, which RGB lights
/// are scaled to).
#[inline]
fn luminance(rgb: [f32; 3]) -> f32 {
    0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]
}

impl EnvironmentMap {
    /// Decodes `path` (`.hdr` or `.exr`), multiplies its texels by `intensity` and turns it by
    /// `rotation_deg` about +Y. Texels that are NaN, infinite or negative become 0 with a warning in
    /// `warnings`; a file that cannot be read or decoded is an error naming it. The file (a regular
    /// file: no device) and the map are charged to the scene's `memory` budget before they are read
    /// or decoded.
    pub(crate) fn load(
        path: &Path,
        intensity: f32,
        rotation_deg: f32,
        memory: &mut geometry::MemoryBudget,
        warnings: &mut Vec<String>,
    ) -> Result<Self> {
        let fail = |reason: String| Error::EnvironmentMap { path: path.to_owned(), reason };
        let meta = std::fs::metadata(path).map_err(|e| fail(format!("cannot read: {e}")))?;
        if !meta.is_file() {
            return Err(fail("not a regular file".to_owned()));
        }
        memory.charge(path, || "reading the environment map".to_owned(), meta.len())?;
        let bytes = std::fs::read(path).map_err(|e| fail(format!("cannot read: {e}")))?;
        let extension = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        let hdr = match extension.as_deref() {
            Some("hdr") => true,
            Some("exr") => false,
            _ => return Err(fail("not a Radiance .hdr or OpenEXR .exr file (by its extension)".to_owned())),
        };
        // The size from the header, charged before a texel is decoded.
        let (w, h) = if hdr { hdr_size(&bytes) } else { exr_size(&bytes) }.map_err(fail)?;
        let texels = (w as u64).saturating_mul(h as u64);
        let what = || format!("a {w}×{h} environment map");
        memory.fits(path, what, texels.saturating_mul(DECODE_BYTES_PER_TEXEL + KEPT_BYTES_PER_TEXEL))?;
        memory.charge(path, what, texels.saturating_mul(KEPT_BYTES_PER_TEXEL))?;
        let (width, height, rgb) = if hdr { decode_hdr(&bytes) } else { decode_exr(&bytes) }.map_err(fail)?;
        let (mut map, bad) = Self::from_rgb(path, width, height, rgb, intensity, rotation_deg)?;
        map.digest = geometry::xxh64(&bytes, 0);
        if bad > 0 {
            warnings.push(format!(
                "{}: {bad} of {} texels were NaN, infinite or negative and were set to 0",
                path.display(),
                width * height
            ));
        }
        Ok(map)
    }

    /// A map from `width` × `height` linear sRGB texels, rows from the top; also returns how many
    /// texels were NaN, infinite or negative (and set to 0).
    pub(crate) fn from_rgb(
        path: &Path,
        width: usize,
        height: usize,
        rgb: Vec<[f32; 3]>,
        intensity: f32,
        rotation_deg: f32,
    ) -> Result<(Self, usize)> {
        let fail = |reason: String| Error::EnvironmentMap { path: path.to_owned(), reason };
        if width == 0 || height == 0 || rgb.len() != width * height {
            return Err(fail(format!("{width}×{height} image with {} texels", rgb.len())));
        }
        if !(intensity.is_finite() && intensity >= 0.0) {
            return Err(fail(format!("intensity {intensity} must be finite and ≥ 0")));
        }
        let table = RgbToSpectrumTable::srgb();
        let mut bad = 0usize;
        let texels: Vec<Texel> = rgb
            .into_iter()
            .map(|c| {
                let c = if c.iter().all(|v| v.is_finite() && *v >= 0.0) {
                    c
                } else {
                    bad += 1;
                    [0.0; 3]
                };
                // A finite texel times a finite intensity can still overflow f32.
                let scaled = c.map(|v| v * intensity);
                let scaled = if scaled.iter().all(|v| v.is_finite()) { scaled } else { [f32::MAX / 4.0; 3] };
                Texel { rgb: scaled, spectrum: RgbIlluminantSpectrum::from_rgb(table, scaled) }
            })
            .collect();
        // Density ∝ luminance × sin θ at the row's centre (the Jacobian of the lat-long mapping);
        // the mean weighs each texel by its exact solid angle, Δφ (cos θ₀ − cos θ₁).
        let mut func = Vec::with_capacity(width * height);
        let mut mean = [0.0f64; 3];
        let mut total_solid_angle = 0.0f64;
        for row in 0..height {
            let (sin_theta, solid_angle) = row_measure(row, width, height);
            for t in &texels[row * width..(row + 1) * width] {
                func.push(luminance(t.rgb).max(0.0) * sin_theta);
                for (m, &c) in mean.iter_mut().zip(&t.rgb) {
                    *m += f64::from(c) * solid_angle;
                }
                total_solid_angle += solid_angle;
            }
        }
        let mean_rgb = mean.map(|m| m / total_solid_angle);
        let distribution = PiecewiseConstant2D::new(&func, width, height);
        let angle = rotation_deg.to_radians();
        let map = Self {
            path: path.to_owned(),
            width,
            height,
            texels: Texels::Rgb(texels),
            distribution,
            rotation: angle.sin_cos(),
            mean_rgb,
            mean_daylight: None,
            digest: 0,
        };
        Ok((map, bad))
    }

    /// A daylight map (the analytic sky) from `width` × `height` texels' daylight weights, rows from the
    /// top (see [`DaylightTexel`]); non-finite or negative-luminance texels become black. Sampled by
    /// luminance × sin θ as the RGB maps.
    pub(crate) fn from_daylight(name: &str, width: usize, height: usize, weights: &[[f64; 3]]) -> Result<Self> {
        if width == 0 || height == 0 || weights.len() != width * height {
            return Err(Error::EnvironmentMap {
                path: PathBuf::from(name),
                reason: format!("{width}×{height} map with {} texels", weights.len()),
            });
        }
        let basis = &*DAYLIGHT_BASIS;
        let texels: Vec<DaylightTexel> = weights
            .iter()
            .map(|w| {
                let luminance = w[0] * basis.luminance[0] + w[1] * basis.luminance[1] + w[2] * basis.luminance[2];
                if !(luminance > 0.0 && luminance.is_finite() && w.iter().all(|v| v.is_finite())) {
                    return DaylightTexel { weights: [0.0; 3], rgb: [0.0; 3], luminance: 0.0 };
                }
                let rgb = [0, 1, 2].map(|c| {
                    (w[0] * f64::from(basis.rgb[0][c])
                        + w[1] * f64::from(basis.rgb[1][c])
                        + w[2] * f64::from(basis.rgb[2][c])) as f32
                });
                DaylightTexel { weights: w.map(|v| v as f32), rgb, luminance: luminance as f32 }
            })
            .collect();
        let mut func = Vec::with_capacity(width * height);
        let (mut mean_rgb, mut mean_weights, mut total) = ([0.0f64; 3], [0.0f64; 3], 0.0f64);
        for row in 0..height {
            let (sin_theta, solid_angle) = row_measure(row, width, height);
            for t in &texels[row * width..(row + 1) * width] {
                func.push(t.luminance * sin_theta);
                for c in 0..3 {
                    mean_rgb[c] += f64::from(t.rgb[c]) * solid_angle;
                    mean_weights[c] += f64::from(t.weights[c]) * solid_angle;
                }
                total += solid_angle;
            }
        }
        let distribution = PiecewiseConstant2D::new(&func, width, height);
        Ok(Self {
            path: PathBuf::from(name),
            width,
            height,
            texels: Texels::Daylight(texels),
            distribution,
            rotation: (0.0, 1.0),
            mean_rgb: mean_rgb.map(|m| m / total),
            mean_daylight: Some(mean_weights.map(|m| m / total)),
            digest: 0,
        })
    }

    /// A map whose radiance along a direction is one daylight spectrum (`weights` on S0, S1, S2, of
    /// luminance 1 nit) times `luminance` of that direction (a unit vector of the map's frame; nits, ≥ 0):
    /// exact per direction, with no texels. Sampled ∝ luminance × sin θ by the table of `luminance` at
    /// the centres of `width` × `height` texels (only the density is piecewise constant, so the table's
    /// resolution changes noise, not the expectation); the mean, for power and white, is that table's.
    pub(crate) fn from_luminance(
        name: &str,
        width: usize,
        height: usize,
        weights: [f64; 3],
        luminance: LuminanceFn,
    ) -> Result<Self> {
        let fail = |reason: String| Error::EnvironmentMap { path: PathBuf::from(name), reason };
        if width == 0 || height == 0 || width.saturating_mul(height) > MAX_TEXELS {
            return Err(fail(format!("{width}×{height} sampling table")));
        }
        let basis = &*DAYLIGHT_BASIS;
        let unit_luminance = (0..3).map(|i| weights[i] * basis.luminance[i]).sum::<f64>();
        if !((unit_luminance - 1.0).abs() < 1e-6 && weights.iter().all(|w| w.is_finite())) {
            return Err(fail(format!("daylight weights {weights:?} of luminance {unit_luminance}, not 1")));
        }
        let rgb = [0, 1, 2].map(|c| (0..3).map(|i| weights[i] * f64::from(basis.rgb[i][c])).sum::<f64>() as f32);
        let unit = DaylightTexel { weights: weights.map(|w| w as f32), rgb, luminance: 1.0 };
        let mut func = Vec::with_capacity(width * height);
        let (mut mean, mut total) = (0.0f64, 0.0f64);
        for row in 0..height {
            let (sin_theta, solid_angle) = row_measure(row, width, height);
            for column in 0..width {
                let uv = Vec2::new((column as f32 + 0.5) / width as f32, (row as f32 + 0.5) / height as f32);
                let l = luminance(Self::uv_to_direction(uv).0);
                let l = if l.is_finite() && l > 0.0 { l } else { 0.0 };
                func.push(l * sin_theta);
                mean += f64::from(l) * solid_angle;
                total += solid_angle;
            }
        }
        let mean = mean / total;
        Ok(Self {
            path: PathBuf::from(name),
            width,
            height,
            distribution: PiecewiseConstant2D::new(&func, width, height),
            rotation: (0.0, 1.0),
            mean_rgb: rgb.map(|c| f64::from(c) * mean),
            mean_daylight: Some(weights.map(|w| w * mean)),
            digest: 0,
            texels: Texels::Analytic { unit, luminance },
        })
    }

    /// The spectrum of the map's mean radiance (what its power, the scene's white and the spectral
    /// choices are computed from): an RGB map's mean RGB as an illuminant spectrum (sigmoid × D65, so a
    /// constant map's mean is its texels' spectrum); a daylight map's mean weights on the daylight basis.
    pub(crate) fn mean_spectrum(&self) -> DenselySampledSpectrum {
        match self.mean_daylight {
            None => {
                let mean = self.mean_rgb.map(|c| c as f32);
                let table = RgbToSpectrumTable::srgb();
                colorimetry::Spectrum::RgbIlluminant(RgbIlluminantSpectrum::from_rgb(table, mean)).to_densely_sampled()
            }
            Some(w) => {
                let [s0, s1, s2] = &DAYLIGHT_BASIS.spectra;
                let values = (0..s0.values().len())
                    .map(|i| (w[0] * s0.values()[i] + w[1] * s1.values()[i] + w[2] * s2.values()[i]).max(0.0))
                    .collect();
                DenselySampledSpectrum::new(360.0, 1.0, values).expect("the mean weights are finite")
            }
        }
    }

    /// XXH64 of the file's bytes.
    pub(crate) fn digest(&self) -> u64 {
        self.digest
    }

    /// Width and height in texels.
    #[cfg(test)]
    pub(crate) fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Mean linear sRGB radiance over the sphere (solid-angle weighted, × intensity): its luminance is
    /// the map's mean luminance in nits, what its power and the scene's white are computed from.
    #[cfg(test)]
    pub(crate) fn mean_rgb(&self) -> [f64; 3] {
        self.mean_rgb
    }

    /// A world direction in the map's frame (the rotation undone).
    #[inline]
    fn to_local(&self, w: Vec3) -> Vec3 {
        let (s, c) = self.rotation;
        // Rotation about +Y by −α: x' = c x − s z, z' = s x + c z.
        Vec3::new(c * w.x - s * w.z, w.y, s * w.x + c * w.z)
    }

    /// A direction of the map's frame in the world (rotated by α about +Y).
    #[inline]
    fn to_world(&self, d: Vec3) -> Vec3 {
        let (s, c) = self.rotation;
        Vec3::new(c * d.x + s * d.z, d.y, -s * d.x + c * d.z)
    }

    /// Texture coordinates of a unit direction of the map's frame.
    #[inline]
    pub(crate) fn direction_to_uv(d: Vec3) -> Vec2 {
        let mut u = d.x.atan2(-d.z) * (0.5 / PI);
        if u < 0.0 {
            u += 1.0;
        }
        Vec2::new(u, d.y.clamp(-1.0, 1.0).acos() / PI)
    }

    /// The unit direction of texture coordinates (u, v), and sin θ.
    #[inline]
    pub(crate) fn uv_to_direction(uv: Vec2) -> (Vec3, f32) {
        let (sin_phi, cos_phi) = (2.0 * PI * uv.x).sin_cos();
        let (sin_theta, cos_theta) = (PI * uv.y).sin_cos();
        (Vec3::new(sin_phi * sin_theta, cos_theta, -cos_phi * sin_theta), sin_theta)
    }

    /// The texel (column, row) of texture coordinates.
    #[inline]
    fn texel_of(&self, uv: Vec2) -> (usize, usize) {
        let column = ((uv.x * self.width as f32) as usize).min(self.width - 1);
        let row = ((uv.y * self.height as f32) as usize).min(self.height - 1);
        (column, row)
    }

    /// Index of the texel seen along world direction `w`.
    #[inline]
    fn texel_index(&self, w: Vec3) -> usize {
        let (column, row) = self.texel_of(Self::direction_to_uv(self.to_local(w)));
        row * self.width + column
    }

    /// Radiance arriving from world direction `w` (unit; pointing away from the scene, i.e. the way
    /// an escaping ray travels) at wavelengths `lambda`, or as RGB lanes when `rgb`.
    #[inline]
    pub(crate) fn eval<const N: usize>(
        &self,
        w: Vec3,
        lambda: &SampledWavelengths<N>,
        rgb: bool,
    ) -> SampledSpectrum<N> {
        let lanes = |c: &[f32; 3]| {
            let mut out = [0.0f32; N];
            out[..3].copy_from_slice(c);
            SampledSpectrum(out)
        };
        match &self.texels {
            Texels::Rgb(texels) => {
                let t = &texels[self.texel_index(w)];
                if rgb { lanes(&t.rgb) } else { t.spectrum.sample(lambda) }
            }
            Texels::Daylight(texels) => {
                let t = &texels[self.texel_index(w)];
                if rgb { lanes(&t.rgb) } else { daylight_sample(t.weights, lambda) }
            }
            Texels::Analytic { unit, luminance } => {
                let l = luminance(self.to_local(w)).max(0.0);
                if rgb { lanes(&unit.rgb.map(|c| c * l)) } else { daylight_sample(unit.weights.map(|v| v * l), lambda) }
            }
        }
    }

    /// Luminance (nits) arriving from world direction `w`.
    #[cfg(test)]
    pub(crate) fn luminance(&self, w: Vec3) -> f32 {
        match &self.texels {
            Texels::Rgb(texels) => luminance(texels[self.texel_index(w)].rgb),
            Texels::Daylight(texels) => texels[self.texel_index(w)].luminance,
            Texels::Analytic { luminance, .. } => luminance(self.to_local(w)).max(0.0),
        }
    }

    /// A world direction sampled ∝ luminance × solid angle, and its density per steradian; `None` at
    /// the poles (sin θ = 0, density undefined).
    #[inline]
    pub(crate) fn sample(&self, u: Vec2) -> Option<(Vec3, f32)> {
        let (uv, pdf_uv, _) = self.distribution.sample(u);
        let (d, sin_theta) = Self::uv_to_direction(uv);
        if !(sin_theta > 0.0) || !(pdf_uv > 0.0) {
            return None;
        }
        // dω = sin θ dθ dφ = 2π² sin θ du dv.
        let pdf = pdf_uv / (2.0 * PI * PI * sin_theta);
        pdf.is_finite().then(|| (self.to_world(d), pdf))
    }

    /// The density per steradian with which [`EnvironmentMap::sample`] picks world direction `w` (unit).
    #[inline]
    pub(crate) fn pdf(&self, w: Vec3) -> f32 {
        let d = self.to_local(w);
        let sin_theta = (d.x * d.x + d.z * d.z).sqrt();
        if !(sin_theta > 0.0) {
            return 0.0;
        }
        let (column, row) = self.texel_of(Self::direction_to_uv(d));
        self.distribution.pdf_of(column, row) / (2.0 * PI * PI * sin_theta)
    }
}

/// w0 S0(λ) + w1 S1(λ) + w2 S2(λ) at the sampled wavelengths, clamped at 0 (far from the daylight locus
/// the basis can go negative at the spectrum's ends).
#[inline(never)]
fn daylight_sample<const N: usize>(w: [f32; 3], lambda: &SampledWavelengths<N>) -> SampledSpectrum<N> {
    let [s0, s1, s2] = &DAYLIGHT_BASIS.spectra;
    let (a, b, c) = (s0.sample(lambda), s1.sample(lambda), s2.sample(lambda));
    SampledSpectrum(std::array::from_fn(|j| (w[0] * a.0[j] + w[1] * b.0[j] + w[2] * c.0[j]).max(0.0)))
}

/// Bytes per texel a map keeps: its [`Texel`] and its density's function and CDF (f32 each).
const KEPT_BYTES_PER_TEXEL: u64 = std::mem::size_of::<Texel>() as u64 + 8;

/// Working bytes per texel while a map is decoded and built, freed before rendering: the decoder's
/// output (RGB f32, 12; an EXR's channels as read, up to RGBA f32, 16), the linear RGB list (12) and
/// the density's function before it is normalised (4).
const DECODE_BYTES_PER_TEXEL: u64 = 16 + 12 + 4;

/// Checks a decoded size against [`MAX_TEXELS`].
fn check_size(width: usize, height: usize) -> std::result::Result<(), String> {
    if width == 0 || height == 0 {
        return Err(format!("empty image ({width}×{height})"));
    }
    if width.saturating_mul(height) > MAX_TEXELS {
        return Err(format!("{width}×{height} texels exceed the limit of {MAX_TEXELS} (8192×4096)"));
    }
    Ok(())
}

/// The size a Radiance file's header states (checked against [`MAX_TEXELS`]), without decoding.
fn hdr_size(bytes: &[u8]) -> std::result::Result<(usize, usize), String> {
    use image::ImageDecoder;
    let decoder = image::codecs::hdr::HdrDecoder::new(Cursor::new(bytes)).map_err(|e| e.to_string())?;
    let (w, h) = decoder.dimensions();
    check_size(w as usize, h as usize)?;
    Ok((w as usize, h as usize))
}

/// The size of the first layer an OpenEXR file's header states (checked against [`MAX_TEXELS`]),
/// without reading pixels.
fn exr_size(bytes: &[u8]) -> std::result::Result<(usize, usize), String> {
    let meta = exr::meta::MetaData::read_from_buffered(Cursor::new(bytes), false).map_err(|e| e.to_string())?;
    let Some(header) = meta.headers.first() else { return Err("no layer".to_owned()) };
    let (w, h) = (header.layer_size.width(), header.layer_size.height());
    check_size(w, h)?;
    Ok((w, h))
}

/// A Radiance RGBE file as linear RGB rows from the top (its size checked first: [`hdr_size`]).
fn decode_hdr(bytes: &[u8]) -> std::result::Result<(usize, usize, Vec<[f32; 3]>), String> {
    use image::ImageDecoder;
    let decoder = image::codecs::hdr::HdrDecoder::new(Cursor::new(bytes)).map_err(|e| e.to_string())?;
    let (w, h) = decoder.dimensions();
    let (width, height) = (w as usize, h as usize);
    let image = image::DynamicImage::from_decoder(decoder).map_err(|e| e.to_string())?.into_rgb32f();
    Ok((width, height, image.pixels().map(|p| p.0).collect()))
}

/// The first RGB(A) layer of an OpenEXR file, at its largest resolution, as linear RGB rows from the
/// top (alpha ignored; the header's size is checked first, [`exr_size`], and the layer read again).
fn decode_exr(bytes: &[u8]) -> std::result::Result<(usize, usize, Vec<[f32; 3]>), String> {
    use exr::prelude::*;
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .rgba_channels(
            |size, _| (size.width(), vec![[0.0f32; 3]; size.width() * size.height()]),
            |(width, pixels): &mut (usize, Vec<[f32; 3]>), position, (r, g, b, _): (f32, f32, f32, f32)| {
                pixels[position.y() * *width + position.x()] = [r, g, b];
            },
        )
        .first_valid_layer()
        .all_attributes()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| e.to_string())?;
    let size = image.layer_data.size;
    check_size(size.width(), size.height())?;
    Ok((size.width(), size.height(), image.layer_data.channel_data.pixels.1))
}

/// Row `row` of a `width` × `height` lat-long map: sin θ at the row's centre (the sampling density's
/// Jacobian) and one texel's exact solid angle, Δφ (cos θ₀ − cos θ₁) (the mean's weight).
fn row_measure(row: usize, width: usize, height: usize) -> (f32, f64) {
    let sin_theta = (PI * (row as f32 + 0.5) / height as f32).sin();
    let (t0, t1) =
        (std::f64::consts::PI * row as f64 / height as f64, std::f64::consts::PI * (row + 1) as f64 / height as f64);
    (sin_theta, 2.0 * std::f64::consts::PI / width as f64 * (t0.cos() - t1.cos()))
}

#[cfg(test)]
mod tests;
