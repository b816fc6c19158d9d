//! The developed image: each pixel's mean XYZ (and spectral radiance) over its samples, made
//! from a [`Film`], with its conversion to a display's RGB.

use colorimetry::{RgbColorSpace, Xyz};

use crate::error::{Error, Result};
use crate::film::estimate::ErrorEstimate;
use crate::film::{Film, ObjectId, pixel_mean, pixel_value};
use crate::output::view::{Exposure, MIDDLE_GREY, View, ViewPlan};

/// Which display the output RGB is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Display {
    /// sRGB / Rec. 709 primaries, D65 white, sRGB transfer curve (the default).
    Srgb,
    /// The paper's 9300 K monitor (its eq. 4 matrix M), sRGB transfer curve for the PNG.
    Paper9300,
}

impl std::str::FromStr for Display {
    type Err = Error;

    /// `srgb` or `paper9300`.
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "srgb" => Ok(Self::Srgb),
            "paper9300" => Ok(Self::Paper9300),
            _ => Err(Error::InvalidOption { option: "display", value: s.to_owned(), expected: "srgb or paper9300" }),
        }
    }
}

impl Display {
    /// The RGB colour space of the display.
    pub fn color_space(self) -> &'static RgbColorSpace {
        match self {
            Self::Srgb => RgbColorSpace::srgb(),
            Self::Paper9300 => RgbColorSpace::paper_9300(),
        }
    }
}

impl Film {
    /// The image: each pixel's mean XYZ (and spectral radiance) over its samples, plus the light
    /// other pixels' samples splatted to it over the samples per pixel.
    pub fn to_image(&self) -> Image {
        let mut image = Image::new(self.width, self.height);
        // With splats a pixel adds its splat sums over the samples per pixel (`film::splat`);
        // without, its mean alone, as it always was.
        let splats = self.splat_scales(0).map(|s| s.whole);
        match splats {
            None => {
                for (out, p) in image.xyz.iter_mut().zip(&self.pixels) {
                    *out = p.xyz.map(|s| pixel_mean(s, p.count));
                }
            }
            Some(scale) => {
                for ((out, p), splat) in image.xyz.iter_mut().zip(&self.pixels).zip(&self.splats.xyz) {
                    *out = [0, 1, 2].map(|c| pixel_value(p.xyz[c], p.count, splat[c], scale));
                }
            }
        }
        image.ids.copy_from_slice(&self.ids);
        image.nonfinite = self.nonfinite;
        if !self.wavelengths.is_empty() {
            let lanes = self.wavelengths.len();
            let own = self.spectral.chunks(lanes).zip(&self.pixels);
            let values = match splats {
                None => own.flat_map(|(sums, p)| sums.iter().map(move |&s| pixel_mean(s, p.count))).collect(),
                Some(scale) => own
                    .zip(self.splats.spectral.chunks(lanes))
                    .flat_map(|((sums, p), splat)| {
                        sums.iter().zip(splat).map(move |(&s, &t)| pixel_value(s, p.count, t, scale))
                    })
                    .collect(),
            };
            image.spectral = Some(SpectralFilm { wavelengths: self.wavelengths.clone(), values });
        }
        // Means of finite fixed-point sums (|sum| < 2¹²⁷ · 2⁻⁶⁴) are finite: non-finite samples
        // were counted and added as black by `add_sample`.
        debug_assert!(image.xyz.iter().flatten().all(|v| v.is_finite()));
        image
    }
}

/// A rendered image: mean CIE XYZ per pixel, scaled so a white diffuser under the scene's light
/// has Y = 1 (the paper's k normalisation, without its factor 100).
#[derive(Debug, Clone)]
pub struct Image {
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) xyz: Vec<[f32; 3]>,
    /// What each pixel's first camera ray hit (for per-object statistics in reports).
    pub(crate) ids: Vec<ObjectId>,
    pub(crate) nonfinite: u64,
    /// Spectral radiance per pixel at fixed wavelengths, when the render kept it.
    pub(crate) spectral: Option<SpectralFilm>,
    /// Per-pixel variance of the mean luminance and sample counts, for a variance image.
    pub(crate) sample_stats: Option<SampleStats>,
    /// Each pixel's estimated error and its samples, for an error map.
    pub(crate) error: Option<(ErrorEstimate, Vec<u32>)>,
    /// How the PNG shows it (exposure, tone curve); recorded in the EXR's header when not the identity.
    pub(crate) view: View,
    /// The false-colour picture's luminance range (lo, hi); `None`: chosen from the image.
    pub(crate) false_color_range: Option<(f32, f32)>,
}

/// What [`Image::set_sample_statistics`] keeps of a film.
#[derive(Debug, Clone)]
pub(crate) struct SampleStats {
    pub(crate) variance: Vec<f32>,
    pub(crate) counts: Vec<u32>,
}

/// Per-pixel radiance at the lanes' wavelengths (`RenderOptions::spectral_film`): what a
/// spectral EXR stores. Values are pixel-major: `values[pixel * wavelengths.len() + i]`.
#[derive(Debug, Clone)]
pub(crate) struct SpectralFilm {
    pub(crate) wavelengths: Vec<f32>,
    pub(crate) values: Vec<f32>,
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Self {
            width,
            height,
            xyz: vec![[0.0; 3]; n],
            ids: vec![ObjectId::Background; n],
            nonfinite: 0,
            spectral: None,
            sample_stats: None,
            error: None,
            view: View::default(),
            false_color_range: None,
        }
    }

    #[cfg(test)]
    pub(crate) fn set_spectral(&mut self, film: SpectralFilm) {
        debug_assert_eq!(film.values.len(), self.xyz.len() * film.wavelengths.len());
        self.spectral = Some(film);
    }

    /// The wavelengths (nm) and per-pixel radiance at them (pixel-major, row by row from the
    /// top), if the render kept a spectral film.
    pub fn spectral(&self) -> Option<(&[f32], &[f32])> {
        self.spectral.as_ref().map(|f| (f.wavelengths.as_slice(), f.values.as_slice()))
    }

    /// Keep `film`'s per-pixel luminance variance and sample counts (the film this image was
    /// resolved from), for an [`crate::OutputKind::Variance`] image.
    pub fn set_sample_statistics(&mut self, film: &Film) {
        self.sample_stats = Some(SampleStats { variance: film.luminance_variance(), counts: film.sample_counts() });
    }

    /// Keep `film`'s error estimate at the display scale `scale` (its samples starting at index
    /// `first`), for an [`crate::OutputKind::ErrorMap`] image; nothing without half-film sums.
    pub fn set_error_estimate(&mut self, film: &Film, scale: f64, first: u32) {
        self.error = film.error_estimate(scale, first).map(|e| (e, film.sample_counts()));
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// XYZ of every pixel, row by row from the top.
    pub fn pixels(&self) -> &[[f32; 3]] {
        &self.xyz
    }

    /// What each pixel's first camera ray hit, row by row from the top.
    pub fn object_ids(&self) -> &[ObjectId] {
        &self.ids
    }

    /// XYZ of one pixel.
    pub fn xyz(&self, x: u32, y: u32) -> [f32; 3] {
        self.xyz[y as usize * self.width as usize + x as usize]
    }

    /// Samples that were NaN or infinite and were added to the film as black (must be 0).
    pub fn nonfinite_samples(&self) -> u64 {
        self.nonfinite
    }

    /// Linear RGB of the display for every pixel.
    pub fn to_linear_rgb(&self, display: Display) -> Vec<[f32; 3]> {
        let space = display.color_space();
        self.xyz
            .iter()
            .map(|p| {
                let rgb = space.xyz_to_rgb(Xyz { x: p[0].into(), y: p[1].into(), z: p[2].into() });
                [rgb.r as f32, rgb.g as f32, rgb.b as f32]
            })
            .collect()
    }

    /// 8-bit display-encoded RGB (sRGB transfer curve, clipped to [0, 1]).
    pub fn to_rgb8(&self, display: Display) -> Vec<u8> {
        self.to_linear_rgb(display).iter().flat_map(|p| p.map(colorimetry::srgb_encode_u8)).collect()
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
    pub fn to_rgb8_view(&self, display: Display, view: &View) -> Vec<u8> {
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

/// Auto-exposure: the EV that maps the image's log-average luminance to [`MIDDLE_GREY`],
/// EV = log2(0.18 / exp(mean ln Y)) over the pixels with finite Y > 0 (Reinhard et al. 2002, eq. 1,
/// without their δ: black pixels, such as an empty background, are left out rather than floored so that
/// an object on black is exposed for itself). `None` when no pixel has light.
pub fn auto_exposure_ev(image: &Image) -> Option<f32> {
    auto_exposure_ev_of(image.pixels().iter().map(|p| p[1]))
}

/// [`auto_exposure_ev`] of the luminances `ys` (a film's pixel means, a reference's pixels).
pub fn auto_exposure_ev_of(ys: impl Iterator<Item = f32>) -> Option<f32> {
    let (mut sum, mut count) = (0.0f64, 0u64);
    for y in ys {
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

impl ViewPlan {
    /// The view this plan gives `image`: its fixed EV, or the auto-exposure of this image (EV 0 for an
    /// image with no light).
    pub fn view_for(&self, image: &Image) -> View {
        let ev = match self.exposure {
            Exposure::Fixed(ev) => ev,
            Exposure::Auto => auto_exposure_ev(image).unwrap_or(0.0),
        };
        View { ev, tonemap: self.tonemap }
    }
}
