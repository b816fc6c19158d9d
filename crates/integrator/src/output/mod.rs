//! What a render's sums become for people and tools: the developed [`Image`], how its PNG is
//! shown ([`view`]: exposure and tone curve), and the image files: linear-RGB OpenEXR, spectral
//! OpenEXR (Fichet et al. 2021) and 8-bit PNG, written all or nothing ([`crate::files`]).

use std::io::{Seek, Write};
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::files::{Encoder, check_distinct_outputs, write_all_or_nothing};
use crate::film::Film;

pub(crate) mod developed;
mod false_color;
pub use false_color::false_color_png;
pub(crate) mod view;

pub use developed::{Display, Image, auto_exposure_ev, auto_exposure_ev_of};
pub use view::{EXR_VIEW_ATTRIBUTE, Exposure, MIDDLE_GREY, Tonemap, View, ViewPlan, pbr_neutral};

/// What one output file holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputKind {
    /// Linear RGB OpenEXR (32-bit float) in the display's primaries.
    Exr(Display),
    /// 8-bit PNG, display-encoded.
    Png(Display),
    /// The spectral film as an OpenEXR (Fichet et al. 2021 layout).
    SpectralExr,
    /// Per-pixel sample statistics as an OpenEXR: the variance of the mean luminance, the
    /// relative error √variance / Y and the samples taken ([`Image::set_sample_statistics`]).
    Variance,
    /// Each pixel's estimated error as an OpenEXR: ΔE00 per pixel (`deltaE00`), per tile
    /// (`deltaE00.tile`) and the samples taken (`spp`) ([`Image::set_error_estimate`]).
    ErrorMap,
    /// Luminance in false colour on a logarithmic scale, with a legend: an 8-bit PNG
    /// ([`OutputPlan::add_false_color`]).
    FalseColor,
}

/// One file to write: where, and what.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OutputFile {
    /// Destination path.
    pub path: PathBuf,
    /// Its content.
    pub kind: OutputKind,
}

/// What a render writes and how its PNG is shown, planned once: `render` and `merge` both make their
/// images through it from the film and the [`ViewPlan`] its header records, so the merge of a render's
/// parts writes the single render's bytes.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputPlan {
    /// The files, in the order they are written.
    pub outputs: Vec<OutputFile>,
    /// How the PNG is shown.
    pub view: ViewPlan,
    /// Whether the image keeps the film's sample statistics (an [`OutputKind::Variance`] output).
    variance: bool,
    /// Whether the image keeps the film's error estimate (an [`OutputKind::ErrorMap`] output).
    error_map: bool,
    /// The luminance range of an [`OutputKind::FalseColor`] output (`None`: from the image).
    false_color_range: Option<(f32, f32)>,
}

impl OutputPlan {
    /// The files of `-o OUT.exr` (with `OUT.png` beside it), a spectral EXR and a variance EXR; each
    /// checked to end in `.exr`, and no two on one path.
    pub fn new(
        exr: Option<&Path>,
        display: Display,
        spectral_exr: Option<&Path>,
        variance: Option<&Path>,
        view: ViewPlan,
    ) -> Result<Self> {
        let must_be_exr = |path: &Path, what: &str| -> Result<()> {
            if path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
                Ok(())
            } else {
                Err(Error::Write { path: path.to_owned(), message: format!("{what} must end in .exr") })
            }
        };
        let mut outputs = Vec::new();
        if let Some(exr) = exr {
            must_be_exr(exr, "the output (a .png is written beside it)")?;
            outputs.push(OutputFile { path: exr.to_owned(), kind: OutputKind::Exr(display) });
            outputs.push(OutputFile { path: exr.with_extension("png"), kind: OutputKind::Png(display) });
        }
        if let Some(path) = spectral_exr {
            must_be_exr(path, "the spectral image")?;
            outputs.push(OutputFile { path: path.to_owned(), kind: OutputKind::SpectralExr });
        }
        if let Some(path) = variance {
            must_be_exr(path, "the variance image")?;
            outputs.push(OutputFile { path: path.to_owned(), kind: OutputKind::Variance });
        }
        let paths: Vec<&Path> = outputs.iter().map(|o| o.path.as_path()).collect();
        check_distinct_outputs(&paths)?;
        Ok(Self { outputs, view, variance: variance.is_some(), error_map: false, false_color_range: None })
    }

    /// Also write the film's error estimate to `path` (`--error-map`), checked like the others.
    pub fn add_error_map(&mut self, path: &Path) -> Result<()> {
        if !path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
            return Err(Error::Write { path: path.to_owned(), message: "the error map must end in .exr".to_owned() });
        }
        self.outputs.push(OutputFile { path: path.to_owned(), kind: OutputKind::ErrorMap });
        let paths: Vec<&Path> = self.outputs.iter().map(|o| o.path.as_path()).collect();
        check_distinct_outputs(&paths)?;
        self.error_map = true;
        Ok(())
    }

    /// Also write the luminance in false colour to `path` (`--false-color`, a .png), on the scale from
    /// `range`'s lo to hi (cd/m²; both > 0, lo < hi) or, without one, the four decades below the power of
    /// ten at or above the image's 99.9th percentile.
    pub fn add_false_color(&mut self, path: &Path, range: Option<(f32, f32)>) -> Result<()> {
        if !path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("png")) {
            return Err(Error::Write {
                path: path.to_owned(),
                message: "the false-colour image must end in .png".to_owned(),
            });
        }
        if let Some((lo, hi)) = range
            && !(lo > 0.0 && hi > lo && hi.is_finite())
        {
            return Err(Error::InvalidOption {
                option: "false-colour range",
                value: format!("{lo},{hi}"),
                expected: "LO,HI with 0 < LO < HI (cd/m²)",
            });
        }
        self.outputs.push(OutputFile { path: path.to_owned(), kind: OutputKind::FalseColor });
        let paths: Vec<&Path> = self.outputs.iter().map(|o| o.path.as_path()).collect();
        check_distinct_outputs(&paths)?;
        self.false_color_range = range;
        Ok(())
    }

    /// The image of `film` (its pixels holding samples from index `first` on) as these outputs
    /// show it, and the view its PNG takes (auto-exposure resolved on this image).
    pub fn develop(&self, film: &Film, first: u32) -> (Image, View) {
        let mut image = film.to_image();
        if self.variance {
            image.set_sample_statistics(film);
        }
        let view = self.view.view_for(&image);
        image.set_view(view);
        image.false_color_range = self.false_color_range;
        if self.error_map {
            // Judged as the PNG shows it: at the view's exposure.
            image.set_error_estimate(film, f64::from(view.ev).exp2(), first);
        }
        (image, view)
    }

    /// Write every output of `image`, all or nothing ([`Image::write_outputs`]).
    pub fn write(&self, image: &Image) -> Result<()> {
        if self.outputs.is_empty() {
            return Ok(());
        }
        image.write_outputs(&self.outputs)
    }
}

impl Image {
    /// Write a linear-RGB OpenEXR (32-bit float, the display's primaries) atomically.
    pub fn write_exr(&self, path: &Path, display: Display) -> Result<()> {
        self.write_outputs(&[OutputFile { path: path.to_owned(), kind: OutputKind::Exr(display) }])
    }

    /// Write the spectral film as an OpenEXR in the layout of Fichet, Pacanowski & Wilkie,
    /// "An OpenEXR Layout for Spectral Images" (JCGT 10(3), 2021): one 32-bit channel per
    /// wavelength named `S0.<nm with a decimal comma>nm` (emissive, Stokes component 0), and
    /// the attribute `spectralLayoutVersion` = "1.0". Radiance is relative: every light is
    /// scaled to luminance 1 × its intensity, so `emissiveUnits` is not claimed.
    pub fn write_spectral_exr(&self, path: &Path) -> Result<()> {
        self.write_outputs(&[OutputFile { path: path.to_owned(), kind: OutputKind::SpectralExr }])
    }

    /// Write an 8-bit display-encoded PNG atomically.
    pub fn write_png(&self, path: &Path, display: Display) -> Result<()> {
        self.write_outputs(&[OutputFile { path: path.to_owned(), kind: OutputKind::Png(display) }])
    }

    /// Write every output, all or nothing: each to a temporary file beside it, checked and
    /// fsynced; then, only when all succeeded, each renamed into place. On an error (a full
    /// disk, a missing folder, no spectral film) every temporary is removed, nothing is
    /// renamed, and the error names the file that failed. Two outputs on one path are refused
    /// before anything is written (see [`check_distinct_outputs`]).
    pub fn write_outputs(&self, outputs: &[OutputFile]) -> Result<()> {
        let paths: Vec<&Path> = outputs.iter().map(|o| o.path.as_path()).collect();
        check_distinct_outputs(&paths)?;
        if outputs.iter().any(|o| o.kind == OutputKind::SpectralExr) && self.spectral.is_none() {
            let path = outputs.iter().find(|o| o.kind == OutputKind::SpectralExr).map(|o| o.path.clone());
            return Err(Error::Write {
                path: path.unwrap_or_default(),
                message: "the render kept no spectral film (render with fixed wavelengths, bins:N)".to_owned(),
            });
        }
        let files: Vec<(&Path, Encoder<'_>)> = outputs
            .iter()
            .map(|o| -> (&Path, Encoder<'_>) { (o.path.as_path(), Box::new(move |w| self.encode(o.kind, w))) })
            .collect();
        write_all_or_nothing(&files)
    }

    /// Encode one output into `w`.
    fn encode<W: Write + Seek>(&self, kind: OutputKind, w: &mut W) -> std::result::Result<(), String> {
        match kind {
            OutputKind::Exr(display) => self.encode_exr(display, w),
            OutputKind::Png(display) => self.encode_png(display, w),
            OutputKind::SpectralExr => self.encode_spectral_exr(w),
            OutputKind::Variance => self.encode_variance_exr(w),
            OutputKind::ErrorMap => self.encode_error_exr(w),
            OutputKind::FalseColor => self.encode_false_color(w),
        }
    }

    fn encode_false_color<W: Write>(&self, w: &mut W) -> std::result::Result<(), String> {
        use image::ImageEncoder as _;
        let y: Vec<f32> = self.xyz.iter().map(|p| p[1]).collect();
        let range = false_color::scale_range(&y, self.false_color_range);
        let (rgb, width, height) =
            false_color::false_color(&y, self.width as usize, self.height as usize, range, "nits");
        image::codecs::png::PngEncoder::new(w)
            .write_image(&rgb, width as u32, height as u32, image::ExtendedColorType::Rgb8)
            .map_err(|e| e.to_string())
    }

    fn encode_error_exr<W: Write + Seek>(&self, w: &mut W) -> std::result::Result<(), String> {
        let Some((estimate, counts)) = &self.error else {
            return Err(
                "no error estimate: the film kept no half-film sums (render with --error-map or a target error)"
                    .to_owned(),
            );
        };
        let (width, height) = (self.width as usize, self.height as usize);
        let tile: Vec<f32> = (0..width * height)
            .map(|i| estimate.tiles[estimate.tile_of((i % width) as u32, (i / width) as u32)])
            .collect();
        let spp: Vec<f32> = counts.iter().map(|&c| c as f32).collect();
        self.encode_channels_exr(
            "error",
            [("deltaE00", estimate.pixels.clone()), ("deltaE00.tile", tile), ("spp", spp)],
            w,
        )
    }

    /// A layer of named f32 channels, one value per pixel, as a lossless OpenEXR.
    fn encode_channels_exr<W: Write + Seek>(
        &self,
        layer_name: &str,
        channels: [(&str, Vec<f32>); 3],
        w: &mut W,
    ) -> std::result::Result<(), String> {
        use exr::prelude::*;
        let channels: SmallVec<[AnyChannel<FlatSamples>; 4]> =
            channels.into_iter().map(|(name, values)| AnyChannel::new(name, FlatSamples::F32(values))).collect();
        let (width, height) = (self.width as usize, self.height as usize);
        let attributes = ImageAttributes::new(IntegerBounds::from_dimensions((width, height)));
        let layer = Layer::new(
            (width, height),
            LayerAttributes::named(layer_name),
            Encoding::SMALL_LOSSLESS,
            AnyChannels::sort(channels),
        );
        Image { attributes, layer_data: layer }.write().to_buffered(w).map_err(|e| e.to_string())
    }

    fn encode_variance_exr<W: Write + Seek>(&self, w: &mut W) -> std::result::Result<(), String> {
        let Some(stats) = &self.sample_stats else {
            return Err("no sample statistics (they come from a film: spectrace merge)".to_owned());
        };
        let relative: Vec<f32> = stats
            .variance
            .iter()
            .zip(&self.xyz)
            .map(|(v, xyz)| if xyz[1] > 0.0 { v.sqrt() / xyz[1] } else { 0.0 })
            .collect();
        let spp: Vec<f32> = stats.counts.iter().map(|&c| c as f32).collect();
        self.encode_channels_exr(
            "statistics",
            [("Y.variance", stats.variance.clone()), ("Y.relativeError", relative), ("spp", spp)],
            w,
        )
    }

    fn encode_exr<W: Write + Seek>(&self, display: Display, w: &mut W) -> std::result::Result<(), String> {
        use exr::prelude::*;
        let rgb = self.to_linear_rgb(display);
        let width = self.width as usize;
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
        // The pixels stay absolute; the header says how the PNG beside them was exposed (only when it
        // was: an EV 0 clamp view writes the same file as before).
        let mut layer_attributes = LayerAttributes::named("rgb");
        if !self.view.is_identity() {
            layer_attributes.other.insert(
                Text::from(view::EXR_VIEW_ATTRIBUTE),
                AttributeValue::Text(Text::from(self.view.exr_text().as_str())),
            );
        }
        let layer = Layer::new(
            (self.width as usize, self.height as usize),
            layer_attributes,
            Encoding::SMALL_LOSSLESS,
            channels,
        );
        Image { attributes, layer_data: layer }.write().to_buffered(w).map_err(|e| e.to_string())
    }

    fn encode_spectral_exr<W: Write + Seek>(&self, w: &mut W) -> std::result::Result<(), String> {
        use exr::prelude::*;
        let Some(film) = &self.spectral else {
            return Err("the render kept no spectral film (render with fixed wavelengths, bins:N)".to_owned());
        };
        let (width, height) = (self.width as usize, self.height as usize);
        let n = film.wavelengths.len();
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
        Image { attributes, layer_data: layer }.write().to_buffered(w).map_err(|e| e.to_string())
    }

    fn encode_png<W: Write>(&self, display: Display, w: &mut W) -> std::result::Result<(), String> {
        use image::ImageEncoder as _;
        let bytes = self.to_rgb8_view(display, &self.view);
        image::codecs::png::PngEncoder::new(w)
            .write_image(&bytes, self.width, self.height, image::ExtendedColorType::Rgb8)
            .map_err(|e| e.to_string())
    }
}

/// `S0.550,000000nm`: Fichet et al.'s emissive channel name (decimal comma, unit suffix).
fn fichet_channel_name(lambda_nm: f32) -> String {
    format!("S0.{lambda_nm:.6}nm").replace('.', ",").replacen(',', ".", 1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::BufWriter;

    use crate::files::encode_checked;
    use crate::output::developed::SpectralFilm;

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

    /// A disk that is full: every write fails with ENOSPC.
    struct FullDisk;
    impl Write for FullDisk {
        fn write(&mut self, _: &[u8]) -> std::io::Result<usize> {
            Err(std::io::Error::from_raw_os_error(28))
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    impl Seek for FullDisk {
        fn seek(&mut self, _: std::io::SeekFrom) -> std::io::Result<u64> {
            Ok(0)
        }
    }

    #[test]
    fn a_full_disk_is_an_error_even_when_the_image_fits_the_buffer() {
        // The PNG fits BufWriter's 8 KiB buffer, so the encoder itself never
        // sees the failing disk; only the final flush does. Dropping the buffer (what
        // `image::save_buffer_with_format` does) swallows that error: the bug, shown here.
        let image = Image::new(4, 4);
        let mut unchecked = BufWriter::new(FullDisk);
        assert!(image.encode_png(Display::Srgb, &mut unchecked).is_ok(), "the encoder alone does not see it");
        drop(unchecked);
        // The checked path reports it, for each kind of output.
        for kind in [OutputKind::Png(Display::Srgb), OutputKind::Exr(Display::Srgb)] {
            let err = encode_checked(FullDisk, |w| image.encode(kind, w)).map(|_| ()).unwrap_err();
            assert!(err.contains("No space left on device"), "{kind:?}: {err}");
        }
    }

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("spectrace-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn outputs_are_all_or_nothing() {
        let dir = scratch("all-or-nothing");
        let image = Image::new(3, 2);
        let out = |name: &str, kind| OutputFile { path: dir.join(name), kind };
        // The spectral EXR cannot be written (no film): neither the EXR nor the PNG appears.
        let err = image
            .write_outputs(&[
                out("x.exr", OutputKind::Exr(Display::Srgb)),
                out("x.png", OutputKind::Png(Display::Srgb)),
                out("s.exr", OutputKind::SpectralExr),
            ])
            .unwrap_err();
        assert!(err.to_string().contains("s.exr: the render kept no spectral film"), "{err}");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
        // A failure after the first file is complete (a missing folder for the second): the
        // first one's temporary is removed, nothing renamed.
        let err = image
            .write_outputs(&[
                out("x.exr", OutputKind::Exr(Display::Srgb)),
                out("missing/x.png", OutputKind::Png(Display::Srgb)),
            ])
            .unwrap_err();
        assert!(matches!(&err, Error::Write { path, .. } if path.ends_with("missing/x.png")), "{err}");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
        // Success: both files, no temporaries.
        image
            .write_outputs(&[
                out("x.exr", OutputKind::Exr(Display::Srgb)),
                out("x.png", OutputKind::Png(Display::Srgb)),
            ])
            .unwrap();
        let mut names: Vec<_> = std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name()).collect();
        names.sort();
        assert_eq!(names, ["x.exr", "x.png"]);
        assert_eq!(&std::fs::read(dir.join("x.png")).unwrap()[1..4], b"PNG");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn two_outputs_on_one_path_are_refused_before_writing() {
        let dir = scratch("same-path");
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        let a = dir.join("x.exr");
        let b = dir.join("sub/../x.exr");
        let err = check_distinct_outputs(&[&a, &dir.join("x.png"), &b]).unwrap_err();
        assert!(err.to_string().contains("given for two outputs"), "{err}");
        let err = Image::new(1, 1)
            .write_outputs(&[
                OutputFile { path: a.clone(), kind: OutputKind::Exr(Display::Srgb) },
                OutputFile { path: a.clone(), kind: OutputKind::Exr(Display::Srgb) },
            ])
            .unwrap_err();
        assert!(matches!(err, Error::Write { .. }));
        assert!(check_distinct_outputs(&[&a, &dir.join("x.png")]).is_ok());
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1, "only `sub`");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
