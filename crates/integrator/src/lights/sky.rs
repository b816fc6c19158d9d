//! A spectral daylight sky and sun: Preetham, Shirley & Smits 1999, "A Practical Analytic Model for
//! Daylight" (SIGGRAPH 99), with +Y up.
//!
//! The sky: the Perez et al. distribution F(θ, γ) = (1 + A e^{B / cos θ})(1 + C e^{D γ} + E cos² γ)
//! (θ the view's zenith angle, γ its angle to the sun) for each of Y, x and y, with the paper's
//! turbidity-linear coefficients (Appendix A.2), scaled by the zenith values: Y = Y_z F(θ, γ) / F(0, θ_s).
//! Zenith luminance Y_z(T, θ_s) and chromaticities x_z, y_z are the paper's fits (Appendix A.2). Y is in
//! kcd/m²; spectrace uses nits (cd/m²). Each direction's spectrum is the CIE daylight spectrum of its
//! chromaticity (CIE 015:2018 eq. 4.11: S0 + M1 S1 + M2 S2), scaled to luminance Y, as the paper does
//! (§3.2). Below the horizon the model is undefined: the sky is black there.
//!
//! The sun: the extraterrestrial solar radiance times the transmittances of Rayleigh scattering, aerosols
//! (Ångström's law with β from T), ozone, mixed gases and water vapour along the relative optical mass of
//! the sun's direction (the paper's Appendix A.1, after Iqbal 1983, "An Introduction to Solar
//! Radiation"). Tables: `SOLAR_*`, `K_O`, `K_G`, `K_WA` below.

use std::f64::consts::PI;

use colorimetry::DenselySampledSpectrum;
use glam::{DVec3, Vec3};

use crate::lights::envmap::{EnvironmentMap, daylight_basis_luminance};

/// The turbidities the model's fits were made for (the paper's Figure 4 spans 2–10; outside, Y_z and the
/// Perez coefficients leave their fitted range: Y_z < 0 at the horizon beyond T ≈ 11.2).
pub(crate) const TURBIDITY_RANGE: (f32, f32) = (2.0, 10.0);

/// The sun's mean angular radius, 959.63″ at 1 AU (IAU 2015 nominal solar radius over 1 AU): its
/// solid angle Ω = 2π (1 − cos r) = 6.7996e-5 sr turns the tabulated radiance into irradiance.
const SUN_ANGULAR_RADIUS_DEG: f64 = 959.63 / 3600.0;

/// Perez coefficients A..E = a T + b for Y, x and y (Preetham et al. 1999, Appendix A.2), rows (a, b).
const PEREZ_Y: [[f64; 2]; 5] =
    [[0.1787, -1.4630], [-0.3554, 0.4275], [-0.0227, 5.3251], [0.1206, -2.5771], [-0.0670, 0.3703]];
const PEREZ_X: [[f64; 2]; 5] =
    [[-0.0193, -0.2592], [-0.0665, 0.0008], [-0.0004, 0.2125], [-0.0641, -0.8989], [-0.0033, 0.0452]];
const PEREZ_SMALL_Y: [[f64; 2]; 5] =
    [[-0.0167, -0.2608], [-0.0950, 0.0092], [-0.0079, 0.2102], [-0.0441, -1.6537], [-0.0109, 0.0529]];

/// Zenith chromaticity x_z = [T² T 1] M [θ_s³ θ_s² θ_s 1]ᵀ (Appendix A.2), rows T², T, 1.
const ZENITH_X: [[f64; 4]; 3] =
    [[0.00166, -0.00375, 0.00209, 0.0], [-0.02903, 0.06377, -0.03202, 0.00394], [0.11693, -0.21196, 0.06052, 0.25886]];
const ZENITH_Y: [[f64; 4]; 3] =
    [[0.00275, -0.00610, 0.00317, 0.0], [-0.04214, 0.08970, -0.04153, 0.00516], [0.15346, -0.26756, 0.06670, 0.26688]];

/// The direction of azimuth `phi` and zenith angle `theta` (radians) in the environment maps' convention
/// (`envmap.rs` `uv_to_direction`, +Y up, φ = 0 towards −Z), in f64 for baking and integration.
fn map_direction(phi: f64, theta: f64) -> DVec3 {
    DVec3::new(phi.sin() * theta.sin(), theta.cos(), -phi.cos() * theta.sin())
}

/// Perez coefficients A..E at turbidity `t`.
fn coefficients(rows: &[[f64; 2]; 5], t: f64) -> [f64; 5] {
    rows.map(|[a, b]| a * t + b)
}

/// The Perez function F(θ, γ) (Preetham et al. 1999 eq. 3) of coefficients `c`, for cos θ ≥ 0 (at the
/// horizon e^{B / cos θ} → 0, as B < 0 for every T ≥ 2).
pub(crate) fn perez(c: &[f64; 5], cos_theta: f64, gamma: f64) -> f64 {
    let [a, b, cc, d, e] = *c;
    let cos_gamma = gamma.cos();
    (1.0 + a * (b / cos_theta).exp()) * (1.0 + cc * (d * gamma).exp() + e * cos_gamma * cos_gamma)
}

/// Zenith luminance Y_z (kcd/m²) at turbidity `t`, sun zenith angle `theta_s` (Appendix A.2):
/// χ = (4/9 − T/120)(π − 2θ_s), Y_z = (4.0453 T − 4.9710) tan χ − 0.2155 T + 2.4192.
pub(crate) fn zenith_luminance(t: f64, theta_s: f64) -> f64 {
    let chi = (4.0 / 9.0 - t / 120.0) * (PI - 2.0 * theta_s);
    (4.0453 * t - 4.9710) * chi.tan() - 0.2155 * t + 2.4192
}

/// Zenith chromaticity (x_z, y_z) (Appendix A.2).
pub(crate) fn zenith_chromaticity(t: f64, theta_s: f64) -> [f64; 2] {
    let tv = [t * t, t, 1.0];
    let th = [theta_s.powi(3), theta_s.powi(2), theta_s, 1.0];
    let poly = |m: &[[f64; 4]; 3]| (0..3).map(|i| tv[i] * (0..4).map(|j| m[i][j] * th[j]).sum::<f64>()).sum();
    [poly(&ZENITH_X), poly(&ZENITH_Y)]
}

/// A Preetham sky for one turbidity and sun position.
#[derive(Debug, Clone)]
pub(crate) struct PreethamSky {
    turbidity: f64,
    /// Sun zenith angle θ_s, radians.
    theta_s: f64,
    /// Unit direction towards the sun.
    sun: DVec3,
    /// Perez coefficients for Y, x, y.
    perez: [[f64; 5]; 3],
    /// Y_z (nits), x_z, y_z divided by F(0, θ_s) of each.
    zenith_over_f0: [f64; 3],
}

impl PreethamSky {
    /// The sky at `turbidity` (within [`TURBIDITY_RANGE`]) with the sun `elevation_deg` above the horizon
    /// (0–90) at `azimuth_deg` (the environment maps' φ: 0 towards −Z, 90 towards +X); an error names the
    /// value out of range.
    pub(crate) fn new(turbidity: f32, elevation_deg: f32, azimuth_deg: f32) -> Result<Self, String> {
        let (lo, hi) = TURBIDITY_RANGE;
        if !(turbidity >= lo && turbidity <= hi) {
            return Err(format!("turbidity {turbidity} is outside the model's range {lo}–{hi}"));
        }
        if !(0.0..=90.0).contains(&elevation_deg) {
            return Err(format!("sun elevation {elevation_deg}° is outside 0–90°"));
        }
        if !azimuth_deg.is_finite() {
            return Err(format!("sun azimuth {azimuth_deg}° must be finite"));
        }
        let t = f64::from(turbidity);
        let theta_s = (90.0 - f64::from(elevation_deg)).to_radians();
        let phi = f64::from(azimuth_deg).to_radians();
        let sun = map_direction(phi, theta_s);
        let perez = [coefficients(&PEREZ_Y, t), coefficients(&PEREZ_X, t), coefficients(&PEREZ_SMALL_Y, t)];
        let [xz, yz] = zenith_chromaticity(t, theta_s);
        let zenith = [zenith_luminance(t, theta_s) * 1000.0, xz, yz];
        let zenith_over_f0 = [0, 1, 2].map(|i| zenith[i] / self::perez(&perez[i], 1.0, theta_s));
        Ok(Self { turbidity: t, theta_s, sun, perez, zenith_over_f0 })
    }

    /// Unit direction towards the sun.
    pub(crate) fn sun_direction(&self) -> Vec3 {
        self.sun.as_vec3()
    }

    /// Luminance Y (nits) and chromaticity x, y seen looking along unit `d`; `None` at and below the
    /// horizon.
    pub(crate) fn xyy(&self, d: DVec3) -> Option<[f64; 3]> {
        let cos_theta = d.y;
        if !(cos_theta > 0.0) {
            return None;
        }
        let gamma = d.dot(self.sun).clamp(-1.0, 1.0).acos();
        let [y, x, small_y] = [0, 1, 2].map(|i| self.zenith_over_f0[i] * perez(&self.perez[i], cos_theta, gamma));
        Some([y, x, small_y])
    }

    /// The daylight weights (w0, w1, w2) of the spectrum seen along `d`, w0 S0 + w1 S1 + w2 S2, its
    /// relative luminance Y nits (`basis_luminance`: the relative luminances of S0, S1, S2); zero below
    /// the horizon.
    pub(crate) fn daylight_weights(&self, d: DVec3, basis_luminance: &[f64; 3]) -> [f64; 3] {
        let Some([y, x, small_y]) = self.xyy(d) else { return [0.0; 3] };
        let [m1, m2] = colorimetry::daylight_m1_m2(x, small_y);
        let unit = basis_luminance[0] + m1 * basis_luminance[1] + m2 * basis_luminance[2];
        if !(unit > 0.0 && y > 0.0) {
            return [0.0; 3];
        }
        let k = y / unit;
        [k, k * m1, k * m2]
    }

    /// The sun's spectral radiance at `lambda_nm`, W/(m² sr nm) (Appendix A.1): the solar table times
    /// τ_R τ_A τ_O τ_G τ_WA along the relative optical mass m = 1 / (cos θ_s + 0.15 (93.885 − θ_s°)^−1.253)
    /// (Kasten 1966, finite at the horizon: m = 36.5).
    pub(crate) fn sun_radiance(&self, lambda_nm: f64) -> f64 {
        let m = 1.0 / (self.theta_s.cos() + 0.15 * (93.885 - self.theta_s.to_degrees()).powf(-1.253));
        let um = lambda_nm / 1000.0;
        // Ångström: β = 0.04608 T − 0.04586, α = 1.3; ozone 0.35 cm (NTP); water vapour w = 2 cm.
        let beta = 0.04608 * self.turbidity - 0.04586;
        let tau_r = (-m * 0.008735 * um.powf(-4.08)).exp();
        let tau_a = (-m * beta * um.powf(-1.3)).exp();
        let tau_o = (-m * lerp_table(&K_O, lambda_nm) * 0.35).exp();
        let k_g = lerp_table(&K_G, lambda_nm);
        let tau_g = (-1.41 * k_g * m / (1.0 + 118.93 * k_g * m).powf(0.45)).exp();
        let k_wa = lerp_table(&K_WA, lambda_nm);
        let w = 2.0;
        let tau_wa = (-0.2385 * k_wa * w * m / (1.0 + 20.07 * k_wa * w * m).powf(0.45)).exp();
        (solar_radiance(lambda_nm) * tau_r * tau_a * tau_o * tau_g * tau_wa).max(0.0)
    }

    /// The sun's spectral irradiance at normal incidence, W/(m² nm), on the 1 nm grid of 360–830 nm: its
    /// radiance times its solid angle (a disc of 0.267°, treated as a directional light).
    pub(crate) fn sun_irradiance(&self) -> DenselySampledSpectrum {
        let omega = 2.0 * PI * (1.0 - SUN_ANGULAR_RADIUS_DEG.to_radians().cos());
        let values = (360..=830).map(|l| self.sun_radiance(f64::from(l)) * omega).collect();
        DenselySampledSpectrum::new(360.0, 1.0, values).expect("the sun's radiance is finite")
    }
}

/// Size of the baked sky map (equirectangular, full sphere, black below the horizon): 512 × 256 texels
/// of 0.70° (the horizon falls between rows 127 and 128).
pub(crate) const SKY_MAP_SIZE: (usize, usize) = (512, 256);

impl PreethamSky {
    /// The sky as a daylight environment map of `width` × `height` texels (each the model at its centre),
    /// times `intensity`, in the maps' orientation (`envmap.rs`, rotation 0).
    pub(crate) fn bake(&self, width: usize, height: usize, intensity: f64) -> crate::error::Result<EnvironmentMap> {
        let basis = daylight_basis_luminance();
        let mut weights = Vec::with_capacity(width * height);
        for row in 0..height {
            let theta = PI * (row as f64 + 0.5) / height as f64;
            for column in 0..width {
                let phi = 2.0 * PI * (column as f64 + 0.5) / width as f64;
                let d = map_direction(phi, theta);
                weights.push(self.daylight_weights(d, &basis).map(|w| w * intensity));
            }
        }
        EnvironmentMap::from_daylight("<preetham sky>", width, height, &weights)
    }

    /// Irradiance (lux) of the sky alone on a horizontal plane facing up, ∫ Y cos θ dω over the upper
    /// hemisphere, by the midpoint rule on a θ × φ grid of `rows` × `columns` cells (each weighted by its
    /// exact ∫ cos θ dω).
    pub(crate) fn horizontal_illuminance(&self, rows: usize, columns: usize) -> f64 {
        let mut sum = 0.0;
        for i in 0..rows {
            let (t0, t1) = (0.5 * PI * i as f64 / rows as f64, 0.5 * PI * (i + 1) as f64 / rows as f64);
            let weight = 2.0 * PI / columns as f64 * (t1.sin().powi(2) - t0.sin().powi(2)) / 2.0;
            let theta = 0.5 * (t0 + t1);
            for j in 0..columns {
                let phi = 2.0 * PI * (j as f64 + 0.5) / columns as f64;
                let d = map_direction(phi, theta);
                sum += self.xyy(d).map_or(0.0, |v| v[0]) * weight;
            }
        }
        sum
    }
}

/// Linear interpolation in a table of (nm, value), 0 outside it (as the tables end in 0 where their
/// absorption does).
fn lerp_table(table: &[(f64, f64)], lambda: f64) -> f64 {
    let (first, last) = (table[0], table[table.len() - 1]);
    if lambda <= first.0 || lambda >= last.0 {
        return if lambda == first.0 {
            first.1
        } else if lambda == last.0 {
            last.1
        } else {
            0.0
        };
    }
    let i = table.partition_point(|&(l, _)| l <= lambda);
    let ((l0, v0), (l1, v1)) = (table[i - 1], table[i]);
    v0 + (v1 - v0) * (lambda - l0) / (l1 - l0)
}

/// The extraterrestrial solar radiance at `lambda_nm`, W/(m² sr nm): the table, interpolated linearly,
/// held at its end values outside 380–750 nm (an approximation: the table stops there; ȳ ≤ 4e-5 below
/// 380 nm and ≤ 1.2e-4 beyond 750 nm, of its peak 1, so the sun's luminance hardly depends on it).
fn solar_radiance(lambda_nm: f64) -> f64 {
    let x = ((lambda_nm - 380.0) / 10.0).clamp(0.0, (SOLAR_RADIANCE.len() - 1) as f64);
    let i = (x as usize).min(SOLAR_RADIANCE.len() - 2);
    let f = x - i as f64;
    SOLAR_RADIANCE[i] * (1.0 - f) + SOLAR_RADIANCE[i + 1] * f
}

/// Extraterrestrial solar spectral radiance, W/(m² sr nm), 380–750 nm every 10 nm: the sun's table of
/// Preetham et al. 1999 (Appendix A.1), from Iqbal 1983; as transcribed in Brian Smits's reference code
/// (RiSunConstants.C, 1999) and, identically, in Mitsuba 3 `src/emitters/sunsky/sunmodel.h`
/// (`sol_amplitudes`) and LuxCore `sun_spect.h`. Times the sun's solid angle it is the ASTM E490
/// irradiance to 2 % (500 nm: 28712.1 × 6.80e-5 = 1.952 W/(m² nm); E490: 1.92).
const SOLAR_RADIANCE: [f64; 38] = [
    16559.0, 16233.7, 21127.5, 25888.2, 25829.1, 24232.3, 26760.5, 29658.3, 30545.4, 30057.5, 30663.7, 28830.4,
    28712.1, 27825.0, 27100.6, 27233.6, 26361.3, 25503.8, 25060.2, 25311.6, 25355.9, 25134.2, 24631.5, 24173.2,
    23685.3, 23212.1, 22827.7, 22339.8, 21970.2, 21526.7, 21097.9, 20728.3, 20240.4, 19870.8, 19427.2, 19072.4,
    18628.9, 18259.2,
];

/// Ozone absorption coefficient k_o (cm⁻¹) by wavelength (nm): Iqbal 1983 p. 127, via Preetham et al.
/// 1999 Appendix A.1 (the same three transcriptions as [`SOLAR_RADIANCE`]; they list a 65th value, 0,
/// with no wavelength, dropped here).
const K_O: [(f64, f64); 64] = [
    (300.0, 10.0),
    (305.0, 4.8),
    (310.0, 2.7),
    (315.0, 1.35),
    (320.0, 0.8),
    (325.0, 0.380),
    (330.0, 0.160),
    (335.0, 0.075),
    (340.0, 0.04),
    (345.0, 0.019),
    (350.0, 0.007),
    (355.0, 0.0),
    (445.0, 0.003),
    (450.0, 0.003),
    (455.0, 0.004),
    (460.0, 0.006),
    (465.0, 0.008),
    (470.0, 0.009),
    (475.0, 0.012),
    (480.0, 0.014),
    (485.0, 0.017),
    (490.0, 0.021),
    (495.0, 0.025),
    (500.0, 0.03),
    (505.0, 0.035),
    (510.0, 0.04),
    (515.0, 0.045),
    (520.0, 0.048),
    (525.0, 0.057),
    (530.0, 0.063),
    (535.0, 0.07),
    (540.0, 0.075),
    (545.0, 0.08),
    (550.0, 0.085),
    (555.0, 0.095),
    (560.0, 0.103),
    (565.0, 0.110),
    (570.0, 0.12),
    (575.0, 0.122),
    (580.0, 0.12),
    (585.0, 0.118),
    (590.0, 0.115),
    (595.0, 0.12),
    (600.0, 0.125),
    (605.0, 0.130),
    (610.0, 0.12),
    (620.0, 0.105),
    (630.0, 0.09),
    (640.0, 0.079),
    (650.0, 0.067),
    (660.0, 0.057),
    (670.0, 0.048),
    (680.0, 0.036),
    (690.0, 0.028),
    (700.0, 0.023),
    (710.0, 0.018),
    (720.0, 0.014),
    (730.0, 0.011),
    (740.0, 0.010),
    (750.0, 0.009),
    (760.0, 0.007),
    (770.0, 0.004),
    (780.0, 0.0),
    (790.0, 0.0),
];

/// Mixed-gas absorption coefficient k_g (cm⁻¹): Iqbal 1983 p. 130, via Preetham et al. 1999 (as [`K_O`]).
const K_G: [(f64, f64); 4] = [(759.0, 0.0), (760.0, 3.0), (770.0, 0.210), (771.0, 0.0)];

/// Water-vapour absorption coefficient k_wa (cm⁻¹): Iqbal 1983 p. 130, via Preetham et al. 1999 (as
/// [`K_O`]); beyond 800 nm 0 (the table's end, an approximation: 0.036 there).
const K_WA: [(f64, f64); 13] = [
    (689.0, 0.0),
    (690.0, 0.016),
    (700.0, 0.024),
    (710.0, 0.0125),
    (720.0, 1.0),
    (730.0, 0.87),
    (740.0, 0.061),
    (750.0, 0.001),
    (760.0, 0.00001),
    (770.0, 0.00001),
    (780.0, 0.0006),
    (790.0, 0.0175),
    (800.0, 0.036),
];

#[cfg(test)]
pub(super) mod tests;
