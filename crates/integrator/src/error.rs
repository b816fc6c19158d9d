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
    /// A light's spectrum or parameters are invalid.
    #[error("light {index}")]
    Light {
        /// Index of the light in the scene description.
        index: usize,
        /// What was wrong.
        #[source]
        source: materials::Error,
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
    /// A thread pool could not be created.
    #[error("thread pool: {0}")]
    ThreadPool(String),
}

/// Result with this crate's [`Error`].
pub type Result<T, E = Error> = std::result::Result<T, E>;
