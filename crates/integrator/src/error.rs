//! Errors of the integrator crate.

use std::path::PathBuf;

/// What can go wrong assembling a scene, rendering or writing images.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The scene description could not be loaded or built.
    #[error(transparent)]
    Geometry(#[from] geometry::Error),
    /// A scene file whose content could not be assembled (a material's or light's spectrum);
    /// the file's own loader errors already name it and are `Geometry`.
    #[error("{}", path.display())]
    SceneFile {
        /// The scene file.
        path: PathBuf,
        /// What was wrong in it.
        #[source]
        source: Box<Error>,
    },
    /// A material or light spectrum could not be built.
    #[error("material `{material}`")]
    Material {
        /// The material's name.
        material: String,
        /// What was wrong.
        #[source]
        source: materials::Error,
    },
    /// A fluorescent material in a path-traced render with fixed lanes.
    #[error(
        "material `{material}` fluoresces, which `--spectral {spectral}` cannot render (fixed lanes cannot \
         shift a path's wavelength): use hero, hero:8 or auto"
    )]
    FluorescenceNeedsHero {
        /// The first fluorescent material.
        material: String,
        /// The spectral mode asked for, as `--spectral` spells it (text: the error module depends on no
        /// other module of the crate).
        spectral: String,
    },
    /// A light's spectrum or parameters are invalid.
    #[error("light {index}")]
    Light {
        /// Index of the light in the scene description.
        index: usize,
        /// What was wrong.
        #[source]
        source: materials::Error,
    },
    /// An environment map that cannot be read, decoded or used.
    #[error("environment map {}: {reason}", path.display())]
    EnvironmentMap {
        /// The image file.
        path: PathBuf,
        /// What was wrong.
        reason: String,
    },
    /// A spectrum used elsewhere (background, ambient) is invalid.
    #[error("{what}")]
    Spectrum {
        /// Where the spectrum is used.
        what: &'static str,
        /// What was wrong.
        #[source]
        source: materials::Error,
    },
    /// An option string that does not parse.
    #[error("invalid {option} `{value}`: expected {expected}")]
    InvalidOption {
        /// The option's name.
        option: &'static str,
        /// The value given.
        value: String,
        /// What is accepted.
        expected: &'static str,
    },
    /// A render setting out of range.
    #[error("{what} = {value} is out of range ({range})")]
    OutOfRange {
        /// Which setting.
        what: &'static str,
        /// The offending value.
        value: f64,
        /// The valid range, in words.
        range: &'static str,
    },
    /// An image side beyond [`crate::limits::MAX_SIDE`] (or 0).
    #[error("{side} {value} is out of range: 1..={max} pixels per side", max = crate::limits::MAX_SIDE)]
    SideOutOfRange {
        /// `width` or `height`.
        side: &'static str,
        /// The size asked for.
        value: u32,
    },
    /// More pixels than [`crate::limits::MAX_PIXELS`].
    #[error(
        "{width}x{height} = {pixels} pixels is more than the limit of {max} pixels per image (2^27, about 14 GB)",
        pixels = u64::from(*width) * u64::from(*height), max = crate::limits::MAX_PIXELS
    )]
    TooManyPixels {
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
    },
    /// A spectral film of more pixel × wavelength samples than [`crate::limits::MAX_SPECTRAL_SAMPLES`].
    #[error(
        "{pixels} pixels x {wavelengths} wavelengths = {samples} samples is more than the limit of {max} \
         (2^28, about 5.5 GB); use fewer pixels or bins:N with a smaller N",
        samples = pixels * wavelengths, max = crate::limits::MAX_SPECTRAL_SAMPLES
    )]
    TooManySpectralSamples {
        /// Pixels of the image.
        pixels: u64,
        /// Wavelengths per pixel (the most `auto` may choose when it is not resolved yet).
        wavelengths: u64,
    },
    /// A worker-thread count beyond [`crate::limits::MAX_THREADS`] (or 0).
    #[error("threads {0} is out of range: 1..={max}", max = crate::limits::MAX_THREADS)]
    ThreadsOutOfRange(usize),
    /// The scene has nothing that emits light.
    #[error("the scene has no light (add a light, an emissive material or an environment)")]
    NoLight,
    /// The camera is missing or degenerate.
    #[error("camera: {0}")]
    Camera(String),
    /// The render was cancelled (Ctrl-C) before it finished.
    #[error("render cancelled")]
    Cancelled,
    /// Writing an output image failed.
    #[error("{}: {message}", path.display())]
    Write {
        /// The file being written.
        path: PathBuf,
        /// What went wrong.
        message: String,
    },
    /// A film file that cannot be read or used: not a film file, another format version,
    /// truncated, corrupted (checksum), or not the render it is resumed for.
    #[error("{}: {message}", path.display())]
    FilmFile {
        /// The film file.
        path: PathBuf,
        /// What is wrong with it.
        message: String,
    },
    /// Two film files that are not parts of one render, or whose sample ranges overlap.
    #[error("{}: cannot merge with {}: {message}", path.display(), other.display())]
    FilmMismatch {
        /// The film file refused.
        path: PathBuf,
        /// The film file it was compared with.
        other: PathBuf,
        /// How they differ.
        message: String,
    },
    /// A thread pool could not be created.
    #[error("thread pool: {0}")]
    ThreadPool(String),
}

/// Result with this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
