//! The CIE standard general sky (ISO 15469:2004(E) / CIE S 011/E:2003, "Spatial distribution of
//! daylight — CIE standard general sky"): fifteen relative sky luminance distributions, from the
//! heavily overcast sky (type 1) to the turbid cloudless sky (type 15), each the product of a
//! gradation function of the zenith angle Z and an indicatrix function of the angular distance χ to
//! the sun, relative to the zenith:
//!
//! L(χ, Z) / L_z = f(χ) φ(Z) / (f(Z_s) φ(0)),
//! φ(Z) = 1 + a exp(b / cos Z) (φ = 1 at the horizon, the limit as cos Z → 0⁺ for b < 0),
//! f(χ) = 1 + c (exp(d χ) − exp(d π/2)) + e cos² χ,
//! cos χ = cos Z_s cos Z + sin Z_s sin Z cos(α − α_s),
//!
//! Z_s the sun's zenith angle (so f(Z_s) is the indicatrix at the zenith). The standard gives the shape
//! only; the absolute scale here is a diffuse horizontal illuminance D_v (lux) or a zenith luminance L_z
//! (nits): L_z = D_v / ∫ (L / L_z) cos Z dω over the upper hemisphere, integrated numerically. The
//! spectrum is the CIE daylight spectrum of one correlated colour temperature (CIE 015:2018 eqs.
//! 4.7–4.11) in every direction: the standard defines luminance, not colour.
//!
//! Below the horizon the sky is black (the standard describes the sky hemisphere only; a ground is the
//! scene's). The sun is not part of the standard's distribution (its circumsolar brightening is); a sun
//! is added by assembly as a directional light of a given illuminance.

use std::f64::consts::{FRAC_PI_2, PI};

use glam::{DVec3, Vec3};

use crate::lights::envmap::{EnvironmentMap, daylight_basis_luminance};

/// The standard's six gradation groups (a, b) and six indicatrix groups (c, d, e), combined into the
/// fifteen sky types: ISO 15469:2004 / CIE S 011/E:2003 Table 1 (also Darula & Kittler, "CIE general
/// sky standard defining luminance distributions", eSim 2002, Table 1). Row `n − 1` is type `n`:
/// (a, b, c, d, e).
///
/// 1. overcast, steep gradation towards the zenith, azimuthal uniformity (the standard's alternative
///    form of the CIE overcast sky); 2. overcast, steep gradation, slight brightening towards the sun;
///    3. overcast, moderately graded, azimuthal uniformity; 4. overcast, moderately graded, slight
///    brightening towards the sun; 5. sky of uniform luminance; 6. partly cloudy, no gradation towards
///    the zenith, slight brightening towards the sun; 7. partly cloudy, no gradation towards the zenith,
///    brighter circumsolar region; 8. partly cloudy, no gradation towards the zenith, distinct solar
///    corona; 9. partly cloudy, the sun obscured; 10. partly cloudy, brighter circumsolar region;
///    11. white-blue sky with a distinct solar corona; 12. CIE standard clear sky, low illuminance
///    turbidity; 13. CIE standard clear sky, polluted atmosphere; 14. cloudless turbid sky with a broad
///    solar corona; 15. white-blue turbid sky with a broad solar corona.
pub(crate) const CIE_SKY_TYPES: [[f64; 5]; 15] = [
    // Gradation group I (a = 4, b = −0.7) with indicatrix groups 1, 2.
    [4.0, -0.70, 0.0, -1.0, 0.00],
    [4.0, -0.70, 2.0, -1.5, 0.15],
    // Gradation II (1.1, −0.8): indicatrix 1, 2.
    [1.1, -0.80, 0.0, -1.0, 0.00],
    [1.1, -0.80, 2.0, -1.5, 0.15],
    // Gradation III (0, −1): indicatrix 1 (the uniform sky), 2, 3, 4.
    [0.0, -1.00, 0.0, -1.0, 0.00],
    [0.0, -1.00, 2.0, -1.5, 0.15],
    [0.0, -1.00, 5.0, -2.5, 0.30],
    [0.0, -1.00, 10.0, -3.0, 0.45],
    // Gradation IV (−1, −0.55): indicatrix 2, 3, 4.
    [-1.0, -0.55, 2.0, -1.5, 0.15],
    [-1.0, -0.55, 5.0, -2.5, 0.30],
    [-1.0, -0.55, 10.0, -3.0, 0.45],
    // Gradation V (−1, −0.32): indicatrix 4, 5.
    [-1.0, -0.32, 10.0, -3.0, 0.45],
    [-1.0, -0.32, 16.0, -3.0, 0.30],
    // Gradation VI (−1, −0.15): indicatrix 5, 6.
    [-1.0, -0.15, 16.0, -3.0, 0.30],
    [-1.0, -0.15, 24.0, -2.8, 0.15],
];

/// How the sky's absolute luminance is given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CieSkyScale {
    /// The sky's diffuse illuminance on an unobstructed horizontal plane, lux (the sun excluded).
    DiffuseHorizontalLux(f32),
    /// The zenith luminance L_z, cd/m² (nits).
    ZenithNits(f32),
}

/// Cells of the midpoint rule that turns a diffuse horizontal illuminance into L_z: 512 zenith rings ×
/// 1024 azimuths (cells of 0.18° × 0.35°). The integrand is smooth (the steepest, type 15's circumsolar
/// indicatrix, changes by 2.7 per radian relative), so the rule's error is below 1e-5: halving the cells
/// changes the integral by 1.2e-5 at most (type 15 with the sun 5° up; `cie_sky/tests.rs`), and the
/// error, ∝ cell², is a third of that change.
const SCALE_GRID: (usize, usize) = (512, 1024);

/// Size of the table an environment map samples the sky by: 1024 × 512 texels of 0.35°. The map's
/// radiance is the model evaluated per direction ([`EnvironmentMap::from_luminance`]); the table only
/// shapes the sampling density, so its resolution changes noise, never the expectation.
pub(crate) const CIE_SKY_MAP_SIZE: (usize, usize) = (1024, 512);

/// One CIE standard general sky: its type's parameters, the sun's position and the absolute scale.
#[derive(Debug, Clone)]
pub(crate) struct CieSky {
    sky_type: u8,
    /// (a, b, c, d, e) of [`CIE_SKY_TYPES`].
    params: [f64; 5],
    /// Unit direction towards the sun (the environment maps' frame, +Y up).
    sun: DVec3,
    /// 1 / (f(Z_s) φ(0)): the relative luminance's denominator.
    inverse_zenith: f64,
    /// L_z, nits.
    zenith_nits: f64,
    /// D_v / L_z, integrated once (the scale and the sky's illuminance both need it).
    relative_horizontal: f64,
}

impl CieSky {
    /// Sky `sky_type` (1–15) with the sun `elevation_deg` above the horizon (0–90) at `azimuth_deg` (the
    /// environment maps' φ: 0 towards −Z, 90 towards +X), scaled by `scale`; an error names the value out
    /// of range.
    pub(crate) fn new(sky_type: u8, elevation_deg: f32, azimuth_deg: f32, scale: CieSkyScale) -> Result<Self, String> {
        if !(1..=15).contains(&sky_type) {
            return Err(format!("sky type {sky_type} is not one of the standard's 1–15"));
        }
        if !(0.0..=90.0).contains(&elevation_deg) {
            return Err(format!("sun elevation {elevation_deg}° is outside 0–90°"));
        }
        if !azimuth_deg.is_finite() {
            return Err(format!("sun azimuth {azimuth_deg}° must be finite"));
        }
        let params = CIE_SKY_TYPES[usize::from(sky_type) - 1];
        let zs = (90.0 - f64::from(elevation_deg)).to_radians();
        let phi = f64::from(azimuth_deg).to_radians();
        let sun = DVec3::new(phi.sin() * zs.sin(), zs.cos(), -phi.cos() * zs.sin());
        let mut sky = Self { sky_type, params, sun, inverse_zenith: 0.0, zenith_nits: 0.0, relative_horizontal: 0.0 };
        sky.inverse_zenith = 1.0 / (sky.indicatrix(zs) * sky.gradation(1.0));
        sky.relative_horizontal = sky.relative_horizontal_illuminance(SCALE_GRID.0, SCALE_GRID.1);
        sky.zenith_nits = match scale {
            CieSkyScale::ZenithNits(l) if l.is_finite() && l >= 0.0 => f64::from(l),
            CieSkyScale::DiffuseHorizontalLux(e) if e.is_finite() && e >= 0.0 => f64::from(e) / sky.relative_horizontal,
            CieSkyScale::ZenithNits(v) | CieSkyScale::DiffuseHorizontalLux(v) => {
                return Err(format!("sky luminance scale {v} must be finite and ≥ 0"));
            }
        };
        Ok(sky)
    }

    /// The gradation φ(Z) = 1 + a exp(b / cos Z), for `cos_z` = cos Z; 1 at and below the horizon (the
    /// limit as cos Z → 0⁺, every type's b being negative).
    pub(crate) fn gradation(&self, cos_z: f64) -> f64 {
        let [a, b, ..] = self.params;
        if cos_z > 0.0 { 1.0 + a * (b / cos_z).exp() } else { 1.0 }
    }

    /// The indicatrix f(χ) = 1 + c (exp(d χ) − exp(d π/2)) + e cos² χ, χ in radians.
    pub(crate) fn indicatrix(&self, chi: f64) -> f64 {
        let [_, _, c, d, e] = self.params;
        let cos_chi = chi.cos();
        1.0 + c * ((d * chi).exp() - (d * FRAC_PI_2).exp()) + e * cos_chi * cos_chi
    }

    /// L / L_z seen looking along unit `d`: at the horizon itself (Z = 90°) the standard's limit φ = 1; 0
    /// below it.
    pub(crate) fn relative_luminance(&self, d: DVec3) -> f64 {
        if !(d.y >= 0.0) {
            return 0.0;
        }
        let chi = d.dot(self.sun).clamp(-1.0, 1.0).acos();
        self.indicatrix(chi) * self.gradation(d.y) * self.inverse_zenith
    }

    /// Luminance (nits) seen looking along unit `d`; 0 below the horizon.
    pub(crate) fn luminance(&self, d: DVec3) -> f64 {
        self.zenith_nits * self.relative_luminance(d)
    }

    /// L_z, nits.
    pub(crate) fn zenith_luminance(&self) -> f64 {
        self.zenith_nits
    }

    /// Unit direction towards the sun.
    pub(crate) fn sun_direction(&self) -> Vec3 {
        self.sun.as_vec3()
    }

    /// ∫ (L / L_z) cos Z dω over the upper hemisphere, by the midpoint rule on `rows` × `columns` cells of
    /// Z × α, each weighted by its exact ∫ cos Z dω (as `PreethamSky::horizontal_illuminance`).
    fn relative_horizontal_illuminance(&self, rows: usize, columns: usize) -> f64 {
        let mut sum = 0.0;
        for i in 0..rows {
            let (z0, z1) = (FRAC_PI_2 * i as f64 / rows as f64, FRAC_PI_2 * (i + 1) as f64 / rows as f64);
            let weight = PI / columns as f64 * (z1.sin().powi(2) - z0.sin().powi(2));
            let z = 0.5 * (z0 + z1);
            let (sin_z, cos_z) = z.sin_cos();
            let mut ring = 0.0;
            for j in 0..columns {
                let alpha = 2.0 * PI * (j as f64 + 0.5) / columns as f64;
                ring += self.relative_luminance(DVec3::new(alpha.sin() * sin_z, cos_z, -alpha.cos() * sin_z));
            }
            sum += ring * weight;
        }
        sum
    }

    /// The sky's illuminance (lux) on an unobstructed horizontal plane (D_v).
    pub(crate) fn horizontal_illuminance(&self) -> f64 {
        self.zenith_nits * self.relative_horizontal
    }

    /// The sky as an environment map of CIE daylight at `cct` kelvin (4000–25000) in every direction: its
    /// radiance is that spectrum, normalised to 1 nit, times [`CieSky::luminance`] evaluated along each
    /// direction (no tabulation error); it is importance-sampled by a `width` × `height` table of the
    /// luminance at texel centres.
    pub(crate) fn environment_map(
        &self,
        cct: f64,
        width: usize,
        height: usize,
    ) -> crate::error::Result<EnvironmentMap> {
        let name = format!("<CIE sky type {}>", self.sky_type);
        let [x, y] = colorimetry::daylight_chromaticity(cct).map_err(|e| crate::error::Error::EnvironmentMap {
            path: std::path::PathBuf::from(&name),
            reason: e.to_string(),
        })?;
        let [m1, m2] = colorimetry::daylight_m1_m2(x, y);
        let basis = daylight_basis_luminance();
        let unit = basis[0] + m1 * basis[1] + m2 * basis[2];
        let weights = [1.0 / unit, m1 / unit, m2 / unit];
        let sky = self.clone();
        let luminance = move |d: Vec3| sky.luminance(d.as_dvec3().normalize_or_zero()) as f32;
        EnvironmentMap::from_luminance(&name, width, height, weights, Box::new(luminance))
    }
}

#[cfg(test)]
mod tests;
