//! Exposure and display rendering of the PNG. The EXR stays scene-referred (absolute,
//! linear, unscaled); only the 8-bit PNG is exposed by 2^EV and tone-mapped, and the EXR records
//! the exposure that its PNG used in a header attribute.

use std::str::FromStr;

use crate::error::{Error, Result};

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
    pub(crate) fn apply_scaled(&self, rgb: [f32; 3], scale: f32) -> [f32; 3] {
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

/// How a render's PNG exposure is chosen, before the image exists.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Exposure {
    /// A fixed exposure in stops.
    Fixed(f32),
    /// The image's log-average luminance to [`MIDDLE_GREY`], once rendered ([`crate::auto_exposure_ev`]).
    Auto,
}

/// What a render decides about its PNG: the exposure rule and the tone curve. It is decided once, with
/// the scene ([`crate::RenderScene::view_plan`]), and recorded in every film file of the render, so that
/// `merge` of its parts shows the merged image exactly as the single render shows its own.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewPlan {
    /// How the exposure is chosen.
    pub exposure: Exposure,
    /// The display curve.
    pub tonemap: Tonemap,
}

impl Default for ViewPlan {
    /// EV 0 and clamp: the PNG is the EXR clipped.
    fn default() -> Self {
        Self { exposure: Exposure::Fixed(0.0), tonemap: Tonemap::Clamp }
    }
}

impl std::fmt::Display for ViewPlan {
    /// `exposure auto; tonemap pbr-neutral` or `exposure +1.5 EV; tonemap clamp`: the film file's text.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.exposure {
            Exposure::Fixed(ev) => write!(f, "exposure {ev:+} EV; tonemap {}", self.tonemap),
            Exposure::Auto => write!(f, "exposure auto; tonemap {}", self.tonemap),
        }
    }
}

impl FromStr for ViewPlan {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self> {
        let bad = || Error::InvalidOption {
            option: "view",
            value: s.to_owned(),
            expected: "`exposure auto; tonemap NAME` or `exposure EV EV; tonemap NAME`",
        };
        let (exposure, tonemap) = s.split_once("; tonemap ").ok_or_else(bad)?;
        let exposure = match exposure.strip_prefix("exposure ").ok_or_else(bad)? {
            "auto" => Exposure::Auto,
            ev => {
                let ev: f32 = ev.strip_suffix(" EV").and_then(|e| e.parse().ok()).ok_or_else(bad)?;
                if !ev.is_finite() {
                    return Err(bad());
                }
                Exposure::Fixed(ev)
            }
        };
        Ok(Self { exposure, tonemap: tonemap.parse()? })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::output::developed::{Display, Image, auto_exposure_ev};

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
        assert_eq!(image.to_rgb8_view(Display::Srgb, &View::default()), image.to_rgb8(Display::Srgb));
        let bright = image.to_rgb8_view(Display::Srgb, &View { ev: 1.0, tonemap: Tonemap::Clamp });
        let doubled = grey_image(0.6).to_rgb8(Display::Srgb);
        assert_eq!(bright, doubled);
        assert_eq!("pbr-neutral".parse::<Tonemap>().unwrap(), Tonemap::PbrNeutral);
        assert!("filmic".parse::<Tonemap>().is_err());
    }
}
