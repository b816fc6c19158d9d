//! Image files: linear-RGB OpenEXR, spectral OpenEXR (Fichet et al. 2021) and 8-bit PNG,
//! each written through a temporary file and renamed, so a reader never sees half a file.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::film::{Display, Image};

impl Image {
    /// Write a linear-RGB OpenEXR (32-bit float, the display's primaries) atomically.
    pub fn write_exr(&self, path: &Path, display: Display) -> Result<()> {
        let rgb = self.to_linear_rgb(display);
        let width = self.width as usize;
        write_atomically(path, |tmp| {
            use exr::prelude::*;
            let space = display.color_space();
            let white = space.white();
            let p = space.primaries();
            let channels = SpecificChannels::rgb(|pos: Vec2<usize>| {
                let c = rgb[pos.y() * width + pos.x()];
                (c[0], c[1], c[2])
            });
            let mut attributes =
                ImageAttributes::new(IntegerBounds::from_dimensions((self.width as usize, self.height as usize)));
            attributes.chromaticities = Some(attribute::Chromaticities {
                red: Vec2(p[0][0] as f32, p[0][1] as f32),
                green: Vec2(p[1][0] as f32, p[1][1] as f32),
                blue: Vec2(p[2][0] as f32, p[2][1] as f32),
                white: Vec2(white[0] as f32, white[1] as f32),
            });
            attributes.other.insert(
                Text::from("colorSpace"),
                AttributeValue::Text(Text::from(format!("linear {}", space.name()).as_str())),
            );
            let layer = Layer::new(
                (self.width as usize, self.height as usize),
                LayerAttributes::named("rgb"),
                Encoding::SMALL_LOSSLESS,
                channels,
            );
            Image { attributes, layer_data: layer }.write().to_file(tmp).map_err(|e| e.to_string())
        })
    }

    /// Write the spectral film as an OpenEXR in the layout of Fichet, Pacanowski & Wilkie,
    /// "An OpenEXR Layout for Spectral Images" (JCGT 10(3), 2021): one 32-bit channel per
    /// wavelength named `S0.<nm with a decimal comma>nm` (emissive, Stokes component 0), and
    /// the attribute `spectralLayoutVersion` = "1.0". Radiance is relative: every light is
    /// scaled to luminance 1 × its intensity, so `emissiveUnits` is not claimed.
    pub fn write_spectral_exr(&self, path: &Path) -> Result<()> {
        let Some(film) = &self.spectral else {
            return Err(Error::Write {
                path: path.to_owned(),
                message: "the render kept no spectral film (render with fixed wavelengths, bins:N)".to_owned(),
            });
        };
        let (width, height) = (self.width as usize, self.height as usize);
        let n = film.wavelengths.len();
        write_atomically(path, |tmp| {
            use exr::prelude::*;
            let channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = film
                .wavelengths
                .iter()
                .enumerate()
                .map(|(i, lambda)| {
                    let samples: Vec<f32> = film.values.iter().skip(i).step_by(n).copied().collect();
                    AnyChannel::new(fichet_channel_name(*lambda).as_str(), FlatSamples::F32(samples))
                })
                .collect();
            let mut attributes = ImageAttributes::new(IntegerBounds::from_dimensions((width, height)));
            attributes.other.insert(Text::from("spectralLayoutVersion"), AttributeValue::Text(Text::from("1.0")));
            let layer = Layer::new(
                (width, height),
                LayerAttributes::named("spectral"),
                Encoding::SMALL_LOSSLESS,
                AnyChannels::sort(channels),
            );
            Image { attributes, layer_data: layer }.write().to_file(tmp).map_err(|e| e.to_string())
        })
    }

    /// Write an 8-bit display-encoded PNG atomically.
    pub fn write_png(&self, path: &Path, display: Display) -> Result<()> {
        let bytes = self.to_rgb8(display);
        write_atomically(path, |tmp| {
            image::save_buffer_with_format(
                tmp,
                &bytes,
                self.width,
                self.height,
                image::ExtendedColorType::Rgb8,
                image::ImageFormat::Png,
            )
            .map_err(|e| e.to_string())
        })
    }
}

/// `S0.550,000000nm`: Fichet et al.'s emissive channel name (decimal comma, unit suffix).
fn fichet_channel_name(lambda_nm: f32) -> String {
    format!("S0.{lambda_nm:.6}nm").replace('.', ",").replacen(',', ".", 1)
}

/// Write through a temporary file in the same folder, then rename: a reader never sees a
/// half-written image, and a failed or cancelled write leaves the old file untouched.
fn write_atomically(path: &Path, write: impl FnOnce(&Path) -> std::result::Result<(), String>) -> Result<()> {
    let file_name = path
        .file_name()
        .ok_or_else(|| Error::Write { path: path.to_owned(), message: "not a file name".to_owned() })?;
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(file_name);
    tmp_name.push(format!(".{}.tmp", std::process::id()));
    let tmp: PathBuf = path.with_file_name(tmp_name);
    let result = write(&tmp).and_then(|()| std::fs::rename(&tmp, path).map_err(|e| e.to_string()));
    if let Err(message) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(Error::Write { path: path.to_owned(), message });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::SpectralFilm;

    #[test]
    fn spectral_exr_reads_back_one_channel_per_wavelength() {
        let dir = std::env::temp_dir().join(format!("spectrace-spectral-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("s.exr");
        let mut image = Image::new(2, 1);
        // Pixel-major: pixel 0 = (1, 2, 3), pixel 1 = (4, 5, 6) at 400, 500, 600 nm.
        image.set_spectral(SpectralFilm {
            wavelengths: vec![400.0, 500.0, 600.0],
            values: vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0],
        });
        image.write_spectral_exr(&path).unwrap();
        let read = exr::prelude::read_all_flat_layers_from_file(&path).unwrap();
        let layer = &read.layer_data[0];
        let channels: Vec<(String, Vec<f32>)> = layer
            .channel_data
            .list
            .iter()
            .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
            .collect();
        assert_eq!(
            channels,
            vec![
                ("S0.400,000000nm".to_owned(), vec![1.0, 4.0]),
                ("S0.500,000000nm".to_owned(), vec![2.0, 5.0]),
                ("S0.600,000000nm".to_owned(), vec![3.0, 6.0]),
            ]
        );
        let key = exr::prelude::Text::from("spectralLayoutVersion");
        // A single-part file has one header: the reader puts custom attributes with the layer.
        let version = read.attributes.other.get(&key).or_else(|| layer.attributes.other.get(&key));
        assert!(matches!(version, Some(exr::prelude::AttributeValue::Text(t)) if t == "1.0"));
        // No film: a clear error, no file.
        let err = Image::new(1, 1).write_spectral_exr(&dir.join("none.exr"));
        assert!(matches!(err, Err(Error::Write { .. })));
        assert!(!dir.join("none.exr").exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn fichet_channel_names_use_a_decimal_comma() {
        assert_eq!(fichet_channel_name(550.0), "S0.550,000000nm");
        assert_eq!(fichet_channel_name(364.947_4), "S0.364,947388nm");
    }

    #[test]
    fn failed_write_leaves_no_file_behind() {
        let dir = std::env::temp_dir().join(format!("spectrace-film-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let target = dir.join("out.png");
        let err = write_atomically(&target, |tmp| {
            std::fs::write(tmp, b"partial").unwrap();
            Err("disk full".to_owned())
        });
        assert!(matches!(err, Err(Error::Write { .. })));
        assert!(std::fs::read_dir(&dir).unwrap().next().is_none(), "temporary file removed, no output");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
