//! Exposure and display rendering of the PNG (issue 13). The EXR stays scene-referred (absolute,
//! linear, unscaled); only the 8-bit PNG is exposed by 2^EV and tone-mapped, and the EXR records
//! the exposure that its PNG used in a header attribute.

use std::str::FromStr;

use crate::error::{Error, Result};
use crate::film::Image;

/// The curve from exposed linear RGB to display values in [0, 1], before the sRGB transfer curve.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Tonemap {
    /// Clip each channel to [0, 1]: exact colours below white (the default, for colour-accuracy work).
    #[default]
    Clamp,
    /// Khronos PBR Neutral (KhronosGroup/ToneMapping, `PBR_Neutral/README.md`, 2024): identity but for a
    /// small toe below 2·F90 = 0.08 and a highlight shoulder from K_s = 0.76, desaturating towards white.
    /// Keeps base colours as authored (within 4 % up to 0.76), meant for product renders.
    PbrNeutral,
}

impl FromStr for Tonemap {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        match s {
            "clamp" => Ok(Self::Clamp),
            "pbr-neutral" | "khronos-pbr-neutral" => Ok(Self::PbrNeutral),
            _ => Err(Error::InvalidOption { option: "tonemap", value: s.to_owned(), expected: "clamp or pbr-neutral" }),
        }
    }
}

impl std::fmt::Display for Tonemap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Clamp => "clamp",
            Self::PbrNeutral => "pbr-neutral",
        })
    }
}

/// How the PNG shows the image: linear RGB × 2^`ev`, then `tonemap`. [`View::default`] (EV 0, clamp) is
/// what spectrace has always written.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct View {
    /// Exposure in stops: the PNG shows the EXR's values × 2^ev.
    pub ev: f32,
    /// The display curve.
    pub tonemap: Tonemap,
}

impl View {
    /// Whether this view leaves values as they are (EV 0, clamp): the PNG is then the EXR clipped.
    pub fn is_identity(&self) -> bool {
        self.ev == 0.0 && self.tonemap == Tonemap::Clamp
    }

    /// Display values in [0, 1] of one linear RGB pixel (non-finite and negative channels become 0).
    pub fn apply(&self, rgb: [f32; 3]) -> [f32; 3] {
        self.apply_scaled(rgb, self.ev.exp2())
    }

    /// [`View::apply`] with the exposure's scale 2^EV computed once by the caller.
    #[inline]
    fn apply_scaled(&self, rgb: [f32; 3], scale: f32) -> [f32; 3] {
        let exposed = rgb.map(|c| if c.is_finite() { (c * scale).max(0.0) } else { 0.0 });
        match self.tonemap {
            Tonemap::Clamp => exposed.map(|c| c.min(1.0)),
            Tonemap::PbrNeutral => pbr_neutral(exposed),
        }
    }
}

/// Middle grey: the display value the log-average luminance is mapped to by auto-exposure (Reinhard et
/// al. 2002, "Photographic tone reproduction for digital images", the key a = 0.18 of a normal-key scene).
pub const MIDDLE_GREY: f32 = 0.18;

/// Auto-exposure: the EV that maps the image's log-average luminance to [`MIDDLE_GREY`],
/// EV = log2(0.18 / exp(mean ln Y)) over the pixels with finite Y > 0 (Reinhard et al. 2002, eq. 1,
/// without their δ: black pixels, such as an empty background, are left out rather than floored so that
/// an object on black is exposed for itself). `None` when no pixel has light.
pub fn auto_exposure_ev(image: &Image) -> Option<f32> {
    let (mut sum, mut count) = (0.0f64, 0u64);
    for p in image.pixels() {
        let y = p[1];
        if y.is_finite() && y > 0.0 {
            sum += f64::from(y).ln();
            count += 1;
        }
    }
    if count == 0 {
        return None;
    }
    let log_average = (sum / count as f64).exp();
    let ev = (f64::from(MIDDLE_GREY) / log_average).log2();
    // Y is bounded by the film (2^42) and positive, so this is finite; clamp anyway to what an f32 scale holds.
    Some(ev.clamp(-120.0, 120.0) as f32)
}

/// Khronos PBR Neutral on non-negative linear Rec. 709 RGB, as its specification writes it
/// (KhronosGroup/ToneMapping, `PBR_Neutral/README.md`): F90 = 0.04, K_s = 0.8 − F90, K_d = 0.15;
/// x = min(R, G, B); f = x − x²/(4 F90) if x ≤ 2 F90, else F90; p = max(c − f);
/// p_n = 1 − (1 − K_s)²/(p + 1 − 2 K_s); g = 1/(K_d (p − p_n) + 1);
/// out = c − f if p ≤ K_s, else (c − f)(p_n/p) g + p_n (1 − g).
pub fn pbr_neutral(c: [f32; 3]) -> [f32; 3] {
    const F90: f32 = 0.04;
    const K_S: f32 = 0.8 - F90;
    const K_D: f32 = 0.15;
    let x = c[0].min(c[1]).min(c[2]);
    let f = if x <= 2.0 * F90 { x - x * x / (4.0 * F90) } else { F90 };
    let shifted = c.map(|v| v - f);
    let p = shifted[0].max(shifted[1]).max(shifted[2]);
    if p <= K_S {
        return shifted;
    }
    let p_n = 1.0 - (1.0 - K_S) * (1.0 - K_S) / (p + 1.0 - 2.0 * K_S);
    let g = 1.0 / (K_D * (p - p_n) + 1.0);
    shifted.map(|v| (v * (p_n / p) * g + p_n * (1.0 - g)).clamp(0.0, 1.0))
}

/// Name of the EXR layer attribute (text) recording how its PNG was shown: `exposure <EV> EV; tonemap
/// <name>`. One attribute, not two: the `exr` crate keeps custom attributes in a `HashMap` and writes
/// them in its random iteration order, so two would make the file's bytes differ from run to run.
pub const EXR_VIEW_ATTRIBUTE: &str = "displayView";

impl View {
    /// The text of [`EXR_VIEW_ATTRIBUTE`].
    pub fn exr_text(&self) -> String {
        format!("exposure {:+} EV; tonemap {}", self.ev, self.tonemap)
    }
}

impl Image {
    /// Set how the PNG shows this image (the EXR's pixels stay as rendered; its header records `view`).
    pub fn set_view(&mut self, view: View) {
        self.view = view;
    }

    /// How the PNG shows this image.
    pub fn view(&self) -> View {
        self.view
    }

    /// 8-bit display-encoded RGB through `view` (exposure, tone curve), then the sRGB transfer curve.
    pub fn to_rgb8_view(&self, display: crate::Display, view: &View) -> Vec<u8> {
        if view.is_identity() {
            return self.to_rgb8(display);
        }
        let scale = view.ev.exp2();
        self.to_linear_rgb(display)
            .iter()
            .flat_map(|p| view.apply_scaled(*p, scale).map(colorimetry::srgb_encode_u8))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grey_image(y: f32) -> Image {
        let mut image = Image::new(4, 3);
        for p in &mut image.xyz {
            *p = [0.9505 * y, y, 1.089 * y];
        }
        image
    }

    #[test]
    fn auto_exposure_of_uniform_grey_maps_it_to_middle_grey() {
        for y in [1e-4f32, 0.05, 0.18, 1.0, 81_527.0] {
            let ev = auto_exposure_ev(&grey_image(y)).unwrap();
            assert!((ev - (0.18 / y).log2()).abs() < 1e-5, "Y {y}: EV {ev}");
            assert!((y * ev.exp2() - MIDDLE_GREY).abs() < 1e-5 * MIDDLE_GREY.max(1.0), "Y {y}");
        }
        // The geometric mean: half the pixels at 0.02, half at 2 → log-average 0.2.
        let mut image = grey_image(0.02);
        for p in image.xyz.iter_mut().step_by(2) {
            *p = [1.9, 2.0, 2.2];
        }
        let ev = auto_exposure_ev(&image).unwrap();
        assert!((ev - (0.18f32 / 0.2).log2()).abs() < 1e-5, "{ev}");
        // Black pixels are left out; an all-black image has no exposure to choose.
        let mut image = grey_image(0.5);
        image.xyz[0] = [0.0; 3];
        image.xyz[1] = [f32::NAN; 3];
        assert!((auto_exposure_ev(&image).unwrap() - (0.18f32 / 0.5).log2()).abs() < 1e-5);
        assert_eq!(auto_exposure_ev(&grey_image(0.0)), None);
    }

    #[test]
    fn pbr_neutral_matches_the_specification_at_known_inputs() {
        // By hand from the specification's formulas (module docs):
        // 0.5 grey: f = F90 = 0.04, p = 0.46 ≤ K_s → 0.46.
        // 0.02 grey: f = 0.02 − 0.0004/0.16 = 0.0175 → 0.0025.
        // (2, 1, 0.5): f = 0.04, c − f = (1.96, 0.96, 0.46), p = 1.96, p_n = 1 − 0.0576/1.44 = 0.96,
        //   g = 1/1.15; out = (c − f)·(0.96/1.96)/1.15 + 0.96·(0.15/1.15) = (0.96, 0.534090, 0.321135).
        let cases: [([f32; 3], [f32; 3]); 3] =
            [([0.5; 3], [0.46; 3]), ([0.02; 3], [0.0025; 3]), ([2.0, 1.0, 0.5], [0.96, 0.534_090, 0.321_135])];
        for (input, expected) in cases {
            let out = pbr_neutral(input);
            for k in 0..3 {
                assert!((out[k] - expected[k]).abs() < 2e-6, "{input:?} → {out:?}, expected {expected:?}");
            }
        }
        // Increasing along grey (strictly up to ~100, where f32 saturates at 1), never above 1; 0 at 0.
        let mut last = -1.0;
        for i in 0..200 {
            let v = pbr_neutral([1.1f32.powi(i - 50); 3])[0];
            assert!((v > last || (i > 98 && v == last)) && v <= 1.0, "{i}: {v}");
            last = v;
        }
        assert_eq!(pbr_neutral([0.0; 3]), [0.0; 3]);
    }

    #[test]
    fn the_view_exposes_then_maps_and_the_identity_is_the_old_png() {
        let view = View { ev: 2.0, tonemap: Tonemap::Clamp };
        assert_eq!(view.apply([0.1, 0.2, 0.3]), [0.4, 0.8, 1.0]);
        assert_eq!(view.apply([f32::NAN, -1.0, f32::INFINITY]), [0.0, 0.0, 0.0]);
        let image = grey_image(0.3);
        assert_eq!(image.to_rgb8_view(crate::Display::Srgb, &View::default()), image.to_rgb8(crate::Display::Srgb));
        let bright = image.to_rgb8_view(crate::Display::Srgb, &View { ev: 1.0, tonemap: Tonemap::Clamp });
        let doubled = grey_image(0.6).to_rgb8(crate::Display::Srgb);
        assert_eq!(bright, doubled);
        assert_eq!("pbr-neutral".parse::<Tonemap>().unwrap(), Tonemap::PbrNeutral);
        assert!("filmic".parse::<Tonemap>().is_err());
    }
}
