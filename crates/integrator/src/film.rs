//! The film (XYZ per pixel) and display conversion; writing files is `output.rs`.

use colorimetry::{RgbColorSpace, Xyz};

use crate::error::{Error, Result};
use crate::whitted::ObjectId;

/// Which display the output RGB is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Display {
    /// sRGB / Rec. 709 primaries, D65 white, sRGB transfer curve (the default).
    Srgb,
    /// The paper's 9300 K monitor (its eq. 4 matrix M), sRGB transfer curve for the PNG.
    Paper9300,
}

impl Display {
    /// Parse a `--display` value.
    pub fn parse(s: &str) -> Result<Self> {
        match s {
            "srgb" => Ok(Self::Srgb),
            "paper9300" => Ok(Self::Paper9300),
            _ => Err(Error::InvalidOption { option: "display", value: s.to_owned(), expected: "srgb or paper9300" }),
        }
    }

    /// The RGB colour space of the display.
    pub fn color_space(self) -> &'static RgbColorSpace {
        match self {
            Self::Srgb => RgbColorSpace::srgb(),
            Self::Paper9300 => RgbColorSpace::paper_9300(),
        }
    }
}

/// A rendered image: CIE XYZ per pixel, scaled so a white diffuser under the scene's light
/// has Y = 1 (the paper's k normalisation, without its factor 100).
#[derive(Debug, Clone)]
pub struct Image {
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) xyz: Vec<[f32; 3]>,
    /// What each pixel's first camera ray hit (for per-object statistics in reports).
    ids: Vec<ObjectId>,
    nonfinite: u64,
    /// Spectral radiance per pixel at fixed wavelengths, when the render kept it.
    pub(crate) spectral: Option<SpectralFilm>,
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
        Self { width, height, xyz: vec![[0.0; 3]; n], ids: vec![ObjectId::Background; n], nonfinite: 0, spectral: None }
    }

    pub(crate) fn set_spectral(&mut self, film: SpectralFilm) {
        debug_assert_eq!(film.values.len(), self.xyz.len() * film.wavelengths.len());
        self.spectral = Some(film);
    }

    /// The wavelengths (nm) and per-pixel radiance at them (pixel-major, row by row from the
    /// top), if the render kept a spectral film.
    pub fn spectral(&self) -> Option<(&[f32], &[f32])> {
        self.spectral.as_ref().map(|f| (f.wavelengths.as_slice(), f.values.as_slice()))
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

    pub(crate) fn buffers_mut(&mut self) -> (&mut [[f32; 3]], &mut [ObjectId]) {
        (&mut self.xyz, &mut self.ids)
    }

    /// What each pixel's first camera ray hit, row by row from the top.
    pub fn object_ids(&self) -> &[ObjectId] {
        &self.ids
    }

    /// XYZ of one pixel.
    pub fn xyz(&self, x: u32, y: u32) -> [f32; 3] {
        self.xyz[y as usize * self.width as usize + x as usize]
    }

    /// Number of pixel values that were NaN or infinite and were replaced by 0 (must be 0).
    pub fn nonfinite_samples(&self) -> u64 {
        self.nonfinite
    }

    /// Replace non-finite values by 0 and count them, so no NaN or Inf reaches a file.
    pub(crate) fn sanitize(&mut self) {
        for p in &mut self.xyz {
            for c in p.iter_mut() {
                if !c.is_finite() {
                    *c = 0.0;
                    self.nonfinite += 1;
                }
            }
        }
        // A non-finite lane makes its pixel's XYZ non-finite too, so it is counted above.
        if let Some(film) = &mut self.spectral {
            film.values.iter_mut().filter(|v| !v.is_finite()).for_each(|v| *v = 0.0);
        }
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
        self.to_linear_rgb(display)
            .iter()
            .flat_map(|p| p.map(|c| colorimetry::quantize_u8(colorimetry::srgb_encode(f64::from(c)))))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sanitize_counts_and_zeroes_nonfinite_values() {
        let mut image = Image::new(2, 1);
        image.xyz[0] = [f32::NAN, 1.0, f32::INFINITY];
        image.sanitize();
        assert_eq!(image.nonfinite_samples(), 2);
        assert_eq!(image.xyz(0, 0), [0.0, 1.0, 0.0]);
    }
}
