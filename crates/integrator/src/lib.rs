//! `integrator`: turns a scene into an image.
//!
//! Scene assembly (geometry descriptions → spectral materials and lights), the paper's
//! model (`whitted-hall`: Whitted ray tracing with Hall's spectral shading, Bouguer–Beer
//! absorption and the object ambient of Lee, Lee, Lee & Ha 2004) and the spectral path tracer,
//! spectral sampling strategies, the XYZ film and EXR/PNG output.
//!
//! The modules, each importing only from those above it in this list (`ARCHITECTURE.md`
//! draws the graph; `cargo xtask modules` checks it):
//! `error`, `options`, `sampling`, `surface`, `files` → `spectral` → `film` → `output`;
//! `material_desc` → `texture` → `lights` → `scene` → `integrators` → `render` → `auto`.
//!
//! **Invariant:** this is the first crate that sees both a mesh and a spectrum; it depends on
//! `colorimetry`, `geometry` and `materials`, and knows nothing of terminals or arguments.
//!
//! Conventions used throughout: `wo` and `wi` point away from the surface; `n` is the
//! geometric normal, `ns` the shading normal; `lambda` wavelengths in nm; `eta` a relative
//! index of refraction; `t` the ray parameter; `sigma_a` an absorption coefficient per
//! scene unit. Lane values are radiance at the lanes' wavelengths (or RGB channels).
//!
//! ```no_run
//! use std::sync::atomic::AtomicBool;
//! use integrator::{RenderOptions, RenderScene, render};
//!
//! let scene = RenderScene::default_scene()?; // the paper's five spheres
//! let options = RenderOptions { width: 64, height: 48, ..RenderOptions::default() };
//! let (image, stats) = render(&scene, &options, &|_| {}, &AtomicBool::new(false))?;
//! assert_eq!(stats.nonfinite_samples, 0);
//! image.write_png(std::path::Path::new("five_spheres.png"), integrator::Display::Srgb)?;
//! # Ok::<(), integrator::Error>(())
//! ```
#![warn(missing_docs)]

mod auto;
mod error;
mod files;
mod film;
mod integrators;
mod lights;
mod limits;
mod material_desc;
#[cfg(test)]
mod material_tests;
mod measure;
mod options;
mod output;
mod render;
mod sampling;
mod scene;
mod spectral;
mod surface;
mod texture;

// Rendering: options in, film or image out.
pub use auto::{
    AutoCandidate, AutoDecision, auto_decision, choose_auto, pilot_strategies, render, render_film, render_film_with,
    resolved_spectral,
};
pub use error::{Error, Result};
pub use limits::{MAX_PIXELS, MAX_SIDE, MAX_SPECTRAL_SAMPLES, MAX_THREADS};
pub use measure::{MEASURE_MAX_DEPTH, MeasureOptions, Measurement, SensorPoint, measure};
pub use options::{
    Ambient, DEFAULT_K_A, DEFAULT_RESOLUTION, Integrator, IntegratorKind, PathOptions, RenderOptions, SamplerKind,
    SppmOptions, TargetError, WavelengthPdf, WhittedOptions, part_samples,
};
pub use render::{
    Checkpoint, ErrorProgress, ErrorReached, FIRST_STAGE_SPP, MAX_NONFINITE_SHARE, NonfiniteVerdict, Progress,
    RenderControl, RenderStats, nonfinite_verdict, stage_ends,
};
pub use spectral::{MAX_BINS, SpectralMode};

// Scenes.
pub use lights::cie_sky::CieSkyScale;
pub use scene::summary::summarize;
pub use scene::{
    AssemblyOptions, CIE_SKY_DEFAULT_LUX, CameraOptions, CieSkyOption, CieSunOption, DefaultLights, EnvironmentOption,
    RenderScene, SkyOption, UpAxis, scene_is_spiky,
};

// Films (parts of a render) and their files.
pub use film::estimate::{ErrorEstimate, TILE, displayed_delta_e};
pub use film::file::{FILM_MAGIC, FILM_VERSION, FilmFile, FilmHeader, Merged, Merger, merge_parts};
pub use film::{Film, ObjectId};

// Images and their files.
pub use files::{
    check_distinct_outputs, check_outputs_spare_inputs, remove_pending_outputs, write_bytes_atomically,
    write_files_atomically,
};
pub use output::{
    Display, EXR_VIEW_ATTRIBUTE, Exposure, Image, MIDDLE_GREY, OutputFile, OutputKind, OutputPlan, Tonemap, View,
    ViewPlan, auto_exposure_ev, auto_exposure_ev_of, false_color_png, pbr_neutral,
};
