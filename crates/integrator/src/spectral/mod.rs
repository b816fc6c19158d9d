//! Spectral sampling strategies and the projection of spectra onto "lanes".
//!
//! Every integrator works on a fixed-size array of lanes, `SampledSpectrum<N>`. What a lane
//! means depends on the strategy:
//! - `rgb`: three lanes are linear sRGB channels (the paper's RGB baseline);
//! - `bins:N`: N wavelengths evenly spaced over 360–830 nm (the paper's Σ … Δλ);
//! - `hero:K` (path tracer): K wavelengths drawn per path.
//!
//! A lane set also knows how to turn lane values into XYZ, so the film only stores XYZ.

use std::fmt;

use colorimetry::{DenselySampledSpectrum, LAMBDA_MAX, LAMBDA_MIN, Observer, RgbColorSpace, SampledWavelengths, Xyz};

use crate::error::{Error, Result};

/// How wavelengths are chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SpectralMode {
    /// Three RGB channels (linear sRGB primaries, D65 white = (1, 1, 1)).
    Rgb,
    /// `count` wavelengths evenly spaced over 360–830 nm, both ends included
    /// (`bins:95` is the 5 nm grid).
    Bins(usize),
    /// Hero-wavelength sampling with `count` wavelengths per path (path tracer only).
    Hero {
        /// Wavelengths per path (4 or 8).
        count: usize,
    },
    /// Let the renderer choose for the scene (see `auto::choose_auto`).
    Auto,
}

/// Largest `bins:N` supported: one lane per 5 nm over 360–830 nm, rounded up to a multiple of 8.
pub const MAX_BINS: usize = 96;

impl std::str::FromStr for SpectralMode {
    type Err = Error;

    /// `rgb`, `bins:N`, `hero`, `hero:K` or `auto`.
    fn from_str(s: &str) -> Result<Self> {
        let bad = || Error::InvalidOption {
            option: "spectral mode",
            value: s.to_owned(),
            expected: "rgb, bins:N (2..=96), hero, hero:4, hero:8 or auto",
        };
        let lower = s.trim().to_ascii_lowercase();
        match lower.split_once(':') {
            None => match lower.as_str() {
                "rgb" => Ok(Self::Rgb),
                "auto" => Ok(Self::Auto),
                "hero" => Ok(Self::Hero { count: 4 }),
                _ => Err(bad()),
            },
            Some(("bins", n)) => match n.parse::<usize>() {
                Ok(n) if (2..=MAX_BINS).contains(&n) => Ok(Self::Bins(n)),
                _ => Err(bad()),
            },
            Some(("hero", k)) => match k.parse::<usize>() {
                Ok(k @ (4 | 8)) => Ok(Self::Hero { count: k }),
                _ => Err(bad()),
            },
            _ => Err(bad()),
        }
    }
}

impl fmt::Display for SpectralMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Rgb => write!(f, "rgb"),
            Self::Bins(n) => write!(f, "bins:{n}"),
            Self::Hero { count } => write!(f, "hero:{count}"),
            Self::Auto => write!(f, "auto"),
        }
    }
}

/// What a spectrum represents, which decides how it becomes RGB in `rgb` mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum SpectrumKind {
    /// Reflectance or transmittance in [0, 1]: RGB is its colour under D65.
    Reflectance,
    /// Emitted radiance: RGB is its own colour, luminance preserved.
    Emission,
    /// An absorption coefficient σ_a(λ) per unit length: sampled at wavelengths; in RGB it goes
    /// through the colour of its transmittance ([`Lanes::project`]).
    SigmaA,
}

/// A fixed set of lanes: wavelengths (or RGB channels) and the weights that turn lane values
/// into XYZ.
#[derive(Debug, Clone)]
pub(crate) struct Lanes<const N: usize> {
    /// Wavelength of each lane (nm; density 1, unused); unused lanes repeat the last
    /// wavelength with zero weight.
    pub(crate) wavelengths: SampledWavelengths<N>,
    /// XYZ = Σ_i weight[c][i] · L_i.
    pub(crate) to_xyz: [[f32; N]; 3],
    /// Whether lanes are RGB channels rather than wavelengths.
    pub(crate) rgb: bool,
    /// Lanes in use (the rest repeat the last wavelength with zero weight); read per
    /// dispersive hit and sample, so kept rather than recounted.
    active: usize,
}

impl<const N: usize> Lanes<N> {
    /// `count` wavelengths over 360–830 nm, both ends included, each weighted by its spacing
    /// (the paper's X = k Σ S R x̄ Δλ), calibrated to the scene's light `white`: each of X, Y,
    /// Z is normalised so that `white` has exactly its 1 nm XYZ. The paper's k normalises Y
    /// only; at coarse spacing the point-sampled x̄ and z̄ then put the light's own white off
    /// (ΔE00 5 for an equal-energy light at 8 lanes). What remains is the error of lit
    /// surfaces, which `choose_auto` bounds.
    pub(crate) fn bins(count: usize, white: &DenselySampledSpectrum) -> Self {
        let mut lanes = Self::point_sampled(count);
        let exact = colorimetry::relative_xyz(white);
        let exact = [exact.x, exact.y, exact.z];
        let got = lanes.xyz(&lanes.project(white, SpectrumKind::Emission));
        for (c, row) in lanes.to_xyz.iter_mut().enumerate() {
            // A black channel of the light (or a black light) keeps the plain weights.
            if exact[c] > 0.0 && got[c] > 0.0 {
                let scale = (exact[c] / f64::from(got[c])) as f32;
                row.iter_mut().for_each(|w| *w *= scale);
            }
        }
        lanes
    }

    /// The paper's weights as written: point samples of the CMFs normalised by Σ ȳ, so an
    /// equal-energy spectrum of value 1 gives exactly Y = 1 (its k without the factor 100).
    fn point_sampled(count: usize) -> Self {
        assert!((2..=N).contains(&count), "bins:{count} needs 2..={N} lanes");
        let step = (LAMBDA_MAX - LAMBDA_MIN) / (count - 1) as f32;
        let cmf = Observer::Cie1931.cmf();
        let mut lambda = [LAMBDA_MAX; N];
        let mut w = [[0.0f64; N]; 3];
        for i in 0..count {
            let l = LAMBDA_MIN + step * i as f32;
            lambda[i] = l;
            let lf = f64::from(l);
            w[0][i] = cmf.x.eval(lf);
            w[1][i] = cmf.y.eval(lf);
            w[2][i] = cmf.z.eval(lf);
        }
        // Δλ cancels between the sum and its normalisation; only Σ ȳ remains.
        let norm: f64 = w[1].iter().sum();
        let to_xyz = w.map(|row| row.map(|v| (v / norm) as f32));
        Self { wavelengths: SampledWavelengths::from_parts(lambda, [1.0; N]), to_xyz, rgb: false, active: count }
    }

    /// Three linear sRGB channels (N must be ≥ 3; lanes beyond 3 are unused).
    pub(crate) fn rgb() -> Self {
        assert!(N >= 3);
        let m = RgbColorSpace::srgb().rgb_to_xyz_matrix();
        let mut to_xyz = [[0.0f32; N]; 3];
        for (c, row) in to_xyz.iter_mut().enumerate() {
            for i in 0..3 {
                row[i] = m[c][i] as f32;
            }
        }
        Self { wavelengths: SampledWavelengths::from_parts([550.0; N], [1.0; N]), to_xyz, rgb: true, active: 3 }
    }

    /// Number of lanes actually in use.
    #[inline]
    pub(crate) fn active(&self) -> usize {
        self.active
    }

    /// XYZ (white Y = 1) of lane values.
    #[inline]
    pub(crate) fn xyz(&self, values: &[f32; N]) -> [f32; 3] {
        let mut out = [0.0f32; 3];
        for (c, row) in self.to_xyz.iter().enumerate() {
            out[c] = row.iter().zip(values).map(|(w, v)| w * v).sum();
        }
        out
    }

    /// A spectrum as lane values.
    pub(crate) fn project(&self, s: &DenselySampledSpectrum, kind: SpectrumKind) -> [f32; N] {
        if kind == SpectrumKind::SigmaA && self.rgb {
            return self.project_sigma_a(s);
        }
        let mut out = [0.0f32; N];
        if self.rgb {
            let rgb = spectrum_to_rgb(s, kind);
            out[..3].copy_from_slice(&rgb);
        } else {
            for (o, &l) in out.iter_mut().zip(self.wavelengths.lambdas()) {
                *o = s.eval(f64::from(l)) as f32;
            }
        }
        out
    }
}

impl<const N: usize> Lanes<N> {
    /// An absorption coefficient σ_a(λ) as RGB lane values: it goes through the RGB colour of the transmittance e^{−σ_a L} over a
    /// length L at which the medium is neither clear nor black (σ_max L = 1), so the
    /// exponential neither underflows nor rounds to 1 whatever the scene's units.
    fn project_sigma_a(&self, sigma_a: &DenselySampledSpectrum) -> [f32; N] {
        let max = sigma_a.max_value();
        if !(max > 0.0) {
            return [0.0; N];
        }
        let length = 1.0 / max;
        let t = self.project(&sigma_a.map(|s| (-s * length).exp()), SpectrumKind::Reflectance);
        t.map(|t| if t > 0.0 { (-f64::from(t).ln() / length) as f32 } else { 1e30 })
    }
}

/// The linear sRGB triple the paper's RGB baseline would use for a spectrum.
pub(crate) fn spectrum_to_rgb(s: &DenselySampledSpectrum, kind: SpectrumKind) -> [f32; 3] {
    let observer = Observer::Cie1931;
    let integration = colorimetry::Integration::Step(1.0);
    let xyz = match kind {
        SpectrumKind::Reflectance => {
            let d65 = colorimetry::Illuminant::D65.spectrum().unwrap_or_else(|_| DenselySampledSpectrum::constant(1.0));
            let xyz = colorimetry::reflectance_to_xyz(s, &d65, observer, &integration);
            Xyz { x: xyz.x / 100.0, y: xyz.y / 100.0, z: xyz.z / 100.0 }
        }
        // σ_a never gets here (`Lanes::project` takes it through its transmittance's colour).
        SpectrumKind::Emission | SpectrumKind::SigmaA => colorimetry::relative_xyz(s),
    };
    let rgb = RgbColorSpace::srgb().xyz_to_rgb(xyz);
    [rgb.r as f32, rgb.g as f32, rgb.b as f32]
}

/// Lane counts the renderer is compiled for, smallest first ([`with_lanes`] has one arm each).
const LANE_COUNTS: [usize; 7] = [4, 8, 16, 32, 48, 64, MAX_BINS];

/// The lanes a spectral strategy needs.
pub(crate) fn lane_count(spectral: SpectralMode) -> Result<usize> {
    let bad = || Error::InvalidOption {
        option: "spectral mode",
        value: spectral.to_string(),
        expected: "rgb, bins:N (2..=96), hero:4, hero:8 or auto",
    };
    match spectral {
        SpectralMode::Rgb => Ok(4),
        SpectralMode::Bins(n @ 2..=MAX_BINS) => LANE_COUNTS.iter().copied().find(|&lanes| n <= lanes).ok_or_else(bad),
        SpectralMode::Hero { count: count @ (4 | 8) } => Ok(count),
        SpectralMode::Bins(_) | SpectralMode::Hero { .. } | SpectralMode::Auto => Err(bad()),
    }
}

/// Work generic over the lane count, for [`with_lanes`].
pub(crate) trait LaneJob {
    type Output;
    fn run<const N: usize>(self) -> Self::Output;
}

/// The one place that turns a run-time lane count (one of [`LANE_COUNTS`], from
/// [`lane_count`]) into a compile-time one.
pub(crate) fn with_lanes<J: LaneJob>(lanes: usize, job: J) -> J::Output {
    debug_assert!(LANE_COUNTS.contains(&lanes), "{lanes} lanes");
    match lanes {
        4 => job.run::<4>(),
        8 => job.run::<8>(),
        16 => job.run::<16>(),
        32 => job.run::<32>(),
        48 => job.run::<48>(),
        64 => job.run::<64>(),
        _ => job.run::<MAX_BINS>(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_spectral_mode_gets_enough_lanes() {
        assert_eq!(lane_count(SpectralMode::Rgb).unwrap(), 4);
        assert_eq!(lane_count(SpectralMode::Bins(5)).unwrap(), 8);
        assert_eq!(lane_count(SpectralMode::Bins(95)).unwrap(), 96);
        assert_eq!(lane_count(SpectralMode::Hero { count: 8 }).unwrap(), 8);
        assert!(lane_count(SpectralMode::Hero { count: 5 }).is_err());
        assert!(lane_count(SpectralMode::Bins(97)).is_err());
        // bins:1 and bins:0 reached an assert in the lane constructor: an error now.
        assert!(lane_count(SpectralMode::Bins(1)).is_err() && lane_count(SpectralMode::Bins(0)).is_err());
    }

    #[test]
    fn parses_every_mode_and_rejects_the_rest() {
        assert_eq!("rgb".parse::<SpectralMode>().unwrap(), SpectralMode::Rgb);
        assert_eq!("bins:95".parse::<SpectralMode>().unwrap(), SpectralMode::Bins(95));
        assert_eq!("hero".parse::<SpectralMode>().unwrap(), SpectralMode::Hero { count: 4 });
        assert_eq!("HERO:8".parse::<SpectralMode>().unwrap(), SpectralMode::Hero { count: 8 });
        assert_eq!("auto".parse::<SpectralMode>().unwrap(), SpectralMode::Auto);
        for bad in ["bins:1", "bins:97", "bins:x", "hero:3", "rgbx", ""] {
            assert!(matches!(bad.parse::<SpectralMode>(), Err(Error::InvalidOption { .. })), "{bad}");
        }
    }

    #[test]
    fn equal_energy_white_has_unit_luminance_in_every_lane_set() {
        for count in [8usize, 16, 32, 95] {
            let lanes = Lanes::<96>::point_sampled(count);
            let ones = lanes.project(&DenselySampledSpectrum::constant(1.0), SpectrumKind::Emission);
            let xyz = lanes.xyz(&ones);
            assert!((xyz[1] - 1.0).abs() < 1e-5, "bins:{count} Y = {}", xyz[1]);
            assert_eq!(lanes.active(), count);
        }
    }

    #[test]
    fn rgb_lanes_map_d65_white_to_one() {
        let lanes = Lanes::<4>::rgb();
        let d65 = materials::luminance_normalized(&materials::named_spectrum("D65").unwrap());
        let rgb = lanes.project(&d65, SpectrumKind::Emission);
        for c in &rgb[..3] {
            assert!((c - 1.0).abs() < 2e-3, "{rgb:?}");
        }
        let white = lanes.project(&DenselySampledSpectrum::constant(1.0), SpectrumKind::Reflectance);
        for c in &white[..3] {
            assert!((c - 1.0).abs() < 2e-3, "{white:?}");
        }
    }

    #[test]
    fn calibrated_lanes_give_the_light_its_1_nm_colour() {
        use colorimetry::{Integration, Lab, Observer, Xyz, delta_e_2000, emission_to_xyz};
        let exact = |s: &DenselySampledSpectrum| {
            let one =
                emission_to_xyz(&DenselySampledSpectrum::constant(1.0), Observer::Cie1931, &Integration::Step(1.0));
            let v = emission_to_xyz(s, Observer::Cie1931, &Integration::Step(1.0));
            [v.x / one.y, v.y / one.y, v.z / one.y]
        };
        let de = |a: [f32; 3], b: [f64; 3]| {
            let w = Xyz { x: b[0], y: b[1], z: b[2] };
            let a = Xyz { x: a[0].into(), y: a[1].into(), z: a[2].into() };
            delta_e_2000(Lab::from_xyz(a, w), Lab::from_xyz(w, w))
        };
        for name in ["E", "D65", "A", "F11"] {
            let light = materials::named_spectrum(name).unwrap();
            let want = exact(&light);
            for count in [8usize, 16, 32, 95] {
                let lanes = Lanes::<96>::bins(count, &light);
                let got = lanes.xyz(&lanes.project(&light, SpectrumKind::Emission));
                for c in 0..3 {
                    assert!(
                        (f64::from(got[c]) / want[c] - 1.0).abs() < 1e-5,
                        "{name} bins:{count}: {got:?} vs {want:?}"
                    );
                }
            }
        }
        // Why: uncalibrated, the point-sampled CMFs at 8 wavelengths put an equal-energy
        // light's white ΔE00 ~5 off (measured 4.96), though its Y is exact.
        let e = DenselySampledSpectrum::constant(1.0);
        let lanes = Lanes::<96>::point_sampled(8);
        let off = de(lanes.xyz(&lanes.project(&e, SpectrumKind::Emission)), exact(&e));
        assert!(off > 4.0, "ΔE00 {off}");
    }
}
