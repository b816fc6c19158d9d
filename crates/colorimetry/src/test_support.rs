//! Helpers shared by the unit tests of the upsampling and continuous-spectrum modules.

use crate::{
    DenselySampledSpectrum, Illuminant, Integration, Lab, Observer, Rgb, RgbColorSpace, Xyz, delta_e_2000,
    reflectance_to_xyz,
};

/// The project's target for the round trip: ΔE00 < 0.01.
pub(crate) const TARGET_DELTA_E00: f64 = 0.01;

/// ΔE00 between linear sRGB `rgb` and the colour of `reflectance` through the crate's
/// public pipeline: under D65, CIE 1931 2°, 1 nm steps, `reflectance_to_xyz` (the paper's
/// k), Y/100, the sRGB white as CIELAB white.
pub(crate) fn round_trip_delta_e00(rgb: [f64; 3], reflectance: &DenselySampledSpectrum) -> f64 {
    let srgb = RgbColorSpace::srgb();
    let white = srgb.rgb_to_xyz(Rgb { r: 1.0, g: 1.0, b: 1.0 });
    let d65 = Illuminant::D65.spectrum().expect("D65 is tabulated");
    let xyz = reflectance_to_xyz(reflectance, &d65, Observer::Cie1931, &Integration::Step(1.0));
    let xyz = Xyz { x: xyz.x / 100.0, y: xyz.y / 100.0, z: xyz.z / 100.0 };
    let target = srgb.rgb_to_xyz(Rgb { r: rgb[0], g: rgb[1], b: rgb[2] });
    delta_e_2000(Lab::from_xyz(target, white), Lab::from_xyz(xyz, white))
}

/// The 17³ grid over the RGB cube (levels i/16), blue fastest.
pub(crate) fn grid_17() -> impl Iterator<Item = [f64; 3]> {
    let steps = 17;
    let level = move |i: usize| i as f64 / (steps - 1) as f64;
    (0..steps * steps * steps).map(move |n| [level(n / (steps * steps)), level(n / steps % steps), level(n % steps)])
}
